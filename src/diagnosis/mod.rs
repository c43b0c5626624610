//! The pipeline: a conditioned trace + the monitor model's fitness + an optimizer → a health report.
//!
//! [`acquire`] reads and conditions the phase currents; [`Identification`] owns the optimizer's
//! fixed-size state and borrows the trace; it advances one objective evaluation per
//! [`Identification::step`], so firmware can spread the work over control cycles, or call
//! [`Identification::run`] to finish at once ([`Identification::run_with`]: the same loop with a
//! [`StepDriver`] around each step). Configuration ([`IdentifyConfig`]) is checked once in
//! [`Identification::new`]; after that nothing in the loop can fail or panic.
//!
//! The identification is stages over one state, driven by one executor, as the optimizers are
//! (`docs/decisions/0036-identification-stages-executor.md`): [`Identification`]
//! (`identification.rs`) holds the state (`state.rs`: the fitness, the best vector, the groups
//! kept, the evaluations spent, changed only through its methods) and the stage under way, steps
//! it, and builds in place the stage each step names (`stage.rs`). The stages, one file each:
//! the global search (`global.rs`: PSO, GA or DE from [`starting_guesses`] and random points),
//! model selection (`selection.rs`: each fault group must pay for its parameters), the polish of
//! the groups kept by a compass search (`polish.rs`). A warm start from the previous flight's
//! diagnosis replaces the global search by the prior and its drift polish (`warm.rs`,
//! [`Identification::warm`]) and adds new-fault probes (`probes.rs`). Over flights, [`evidence`]
//! sums each fault mode's log-likelihood ratio in a sequential test. After the report, the
//! uncertainty of the reported vector (`uncertainty.rs`: the 1σ of each parameter and the
//! severity below which a group reported healthy could hide) is one more lockstep run of the
//! model.

mod config;
pub mod evidence;
mod global;
mod groups;
mod identification;
mod polish;
mod probes;
mod selection;
mod stage;
mod state;
mod uncertainty;
mod verdict;
mod warm;

pub use config::{
    configured_fit, fault_bounds, starting_guesses, Algorithm, IdentifyConfig, ONBOARD_MAX_ITERATIONS,
    ONBOARD_POPULATION, ONBOARD_WINDOW,
};
pub use groups::{group_present, group_size, without_group};
pub use identification::{Identification, StepDriver};
pub use selection::{group_pays, helps_without_its_best_window, refit_replaces};
pub use state::WarmReport;
pub use uncertainty::{covariance_noise_a2, uncertainty_at, with_uncertainty, Fisher};
pub use verdict::{covers, rate_matches, window_noise_variance_a2, AcquisitionSummary};
pub use warm::{plan_start, ColdReason, Start};

// The tuning the crate's other modules read; the rest of it stays in the stage that uses it.
pub(crate) use verdict::MODEL_MISMATCH_A;
pub(crate) use warm::COLD_EVERY_FLIGHTS;

/// The few tuning constants a host tool reuses to reproduce the identification's decisions (the
/// discrepancy workflow refits as model selection does and judges a window's gain as its window
/// check does; the fit test's allowance for the monitor model's known mismatch). A flight needs
/// none of them; the rest of the tuning stays inside the crate, documented where it is used.
pub mod tuning {
    pub use super::selection::{SELECTION_REFIT, WINDOW_GAIN_SHARE};
    pub use super::verdict::MODEL_MISMATCH_A;
}

use crate::acquisition::{AcquisitionError, GainCheck, PhaseCurrents, MAX_GAIN_MISMATCH};
use crate::conditioning::{ConditionedWindow, ConditioningError};
use crate::fitness::PoolError;
use crate::optimizer::ConfigError;

/// Why an identification could not start.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum MonitorError {
    /// The conditioned window was refused.
    Conditioning(ConditioningError),
    /// The optimizer settings were refused.
    Optimizer(ConfigError),
    /// An actuator parameter is outside its range or the set is not physical ([`crate::EmaParams::check`]).
    Params,
    /// The trace is longer than the command (profile or sampled) that drives the model.
    TraceLongerThanProfile,
    /// The fast-regime weight is not in `(0, 1]`.
    FastRegimeWeight,
    /// The prior of a warm start is not a fault vector (a non-finite element, or one outside
    /// `[0, 1]`).
    Prior,
    /// The recordings to pool were refused.
    Pool(PoolError),
    /// The health record belongs to another unit or was made under other parameters
    /// ([`crate::flight::HealthMonitor::adopt`]).
    ForeignRecord,
    /// Commissioning settings refused: 1 to
    /// [`crate::flight::MAX_ONBOARD_COMMISSIONING_FLIGHTS`] flights and a valid tolerance table.
    Commissioning,
    /// The health record is collecting a commissioning, and this build has none (the
    /// `commissioning` feature): the unit is diagnosed once a build with commissioning has
    /// finished it, or after a maintenance reset.
    CommissioningNotBuilt,
    /// The identification asks for model effect terms ([`crate::ModelEffects`] other than
    /// `NONE`), and this build has none (the `effect-terms` feature).
    EffectsNotBuilt,
}

impl core::fmt::Display for MonitorError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            MonitorError::Conditioning(e) => write!(f, "measured trace refused: {e}"),
            MonitorError::Optimizer(e) => write!(f, "optimizer settings refused: {e}"),
            MonitorError::Params => f.write_str("an actuator parameter is outside its range (EmaParams::check)"),
            MonitorError::TraceLongerThanProfile => {
                f.write_str("the trace is longer than the command that drives the model")
            }
            MonitorError::FastRegimeWeight => f.write_str("the fast-regime weight is not in (0, 1]"),
            MonitorError::Prior => f.write_str("the prior of a warm start is not a fault vector in [0, 1]"),
            MonitorError::Pool(e) => write!(f, "recordings refused: {e}"),
            MonitorError::Commissioning => {
                f.write_str("commissioning settings refused: 1 to 3 flights and a valid tolerance table")
            }
            MonitorError::CommissioningNotBuilt => f.write_str(
                "the health record is collecting a commissioning, and this build has none (feature `commissioning`)",
            ),
            MonitorError::EffectsNotBuilt => {
                f.write_str("the model's effect terms are asked for, and this build has none (feature `effect-terms`)")
            }
            MonitorError::ForeignRecord => {
                f.write_str("the health record is another unit's or was made under other parameters")
            }
        }
    }
}

impl core::error::Error for MonitorError {}

impl From<ConditioningError> for MonitorError {
    fn from(e: ConditioningError) -> Self {
        MonitorError::Conditioning(e)
    }
}

impl From<ConfigError> for MonitorError {
    fn from(e: ConfigError) -> Self {
        MonitorError::Optimizer(e)
    }
}

/// Reads every frame of `source` until it reports [`AcquisitionError::EndOfData`] into `trace`
/// and closes the window. A frame refused by acquisition's checks (a spike, a dropout, a stuck or
/// inconsistent channel) is masked: the last good frame is pushed in its place (zero currents
/// before the first good frame), and it is counted in the returned [`AcquisitionSummary`]. The
/// diagnosis goes on; too many refused frames make the report a sensor fault
/// ([`AcquisitionSummary::is_sensor_fault`], [`crate::health::HealthReport::with_acquisition`]).
pub fn acquire<const W: usize, S: PhaseCurrents>(
    source: &mut S,
    trace: &mut ConditionedWindow<W>,
) -> Result<AcquisitionSummary, MonitorError> {
    let mut summary = AcquisitionSummary::default();
    let mut gains = GainCheck::new();
    let mut run = 0u32;
    let mut held = [0.0f32; 3];
    loop {
        match source.read_frame() {
            Ok(f) => {
                held = [f.ia_a, f.ib_a, f.ic_a];
                gains.add(held);
                summary.count(false, &mut run);
            }
            Err(AcquisitionError::EndOfData) => break,
            Err(_) => summary.count(true, &mut run),
        }
        trace.push(held[0], held[1], held[2])?;
    }
    trace.finish()?;
    summary.sensors = source.sensor_check().with_gains(gains.mismatch(), MAX_GAIN_MISMATCH);
    Ok(summary)
}
