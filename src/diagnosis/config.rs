//! What an identification runs with: the optimizer, its budget, the stages after the global
//! search, and the on-board constants; the search box and the swarm's seeded starting points.

use super::MonitorError;
use crate::conditioning::ConditionedWindow;
use crate::conditioning::DECIMATION;
use crate::effects::ModelEffects;
use crate::faults::{FaultVector, FAULT_COUNT};
use crate::fitness::{EquivalentCurrentFit, FAST_REGIME_WEIGHT};
use crate::optimizer::pattern::PatternConfig;
use crate::optimizer::Bounds;
use crate::{Command, EmaParams};

pub use crate::conditioning::ONBOARD_WINDOW;

/// Swarm (population) size of the on-board identification: the paper's 50.
pub const ONBOARD_POPULATION: usize = 50;

/// Iteration limit of the on-board identification: 30 iterations × 50 particles = 1500
/// evaluations (the paper: 200 iterations, 10 000). Model selection and the polish, not the
/// swarm's last iterations, set the reported digits, so a short global search suffices; the
/// identification campaign in `docs/results/` shows the accuracy this budget reaches.
pub const ONBOARD_MAX_ITERATIONS: u32 = 30;

/// Budget of model selection and the polish together (evaluations after the global search), so
/// that an identification's cost is bounded whatever the trace: on board at most 1500 + 700 =
/// 2200 evaluations. Unbounded, the two stages could take 1 + 7·120 + 600 = 1441 evaluations
/// (all seven groups present). The choice is recorded in
/// `docs/decisions/0007-selection-polish-budget.md`.
pub const SELECTION_POLISH_MAX_EVALUATIONS: u32 = 700;

/// Index of the eccentricity phase `k7`, the one periodic parameter.
pub(super) const PHASE_INDEX: usize = 6;

/// Which optimizer identifies the faults.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Algorithm {
    /// Particle swarm (the paper's best, and the firmware's default).
    Pso,
    /// Real-coded genetic algorithm (the paper's comparison).
    Ga,
    /// Differential evolution (the paper's future work).
    De,
}

/// Settings of one identification.
///
/// Stages: the global search (PSO, GA or DE), then, when enabled, **model selection** (a fault
/// group whose removal costs less than the Bayesian information criterion's price of its
/// parameters is set back to healthy, [`FaultGroup`](crate::faults::FaultGroup)) and a **polish** of
/// the parameters left free by a compass search
/// ([`PatternSearch`](crate::optimizer::pattern::PatternSearch)).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct IdentifyConfig {
    /// Optimizer.
    pub algorithm: Algorithm,
    /// Seed of the optimizer's random generator (same seed, same result, on every target).
    pub seed: u64,
    /// Iteration (generation) limit.
    pub max_iterations: u32,
    /// Stop when the best fitness improves by less than this (relative) over `stall_iterations`.
    pub function_tolerance: f32,
    /// Stall window of the tolerance test.
    pub stall_iterations: u32,
    /// Test each fault group against the information criterion after the global search.
    pub model_selection: bool,
    /// Polish the result by compass search (`None`: report the global search's best).
    pub polish: Option<PatternConfig>,
    /// Effect terms the monitor model runs with ([`ModelEffects::NONE`]: the paper's model); set
    /// by a promoted discovery (`ema discover`), fixed during the identification.
    pub effects: ModelEffects,
    /// Weight `ρ` of the fast-regime samples in the fitness, in `(0, 1]` (1: the paper's fitness;
    /// [`FAST_REGIME_WEIGHT`] by default).
    pub fast_regime_weight: f32,
    /// Evaluations model selection and the polish may spend together
    /// (700 by default, `SELECTION_POLISH_MAX_EVALUATIONS`). When it runs out, the groups not yet
    /// tested stay and the polish stops where it is; the report's fitness is always that of the
    /// reported vector (at 0, that may take the one evaluation of a global-search vector whose
    /// absent groups were reset to healthy).
    pub selection_polish_max_evaluations: u32,
    /// Independent frames in a window sample's block, for the noise model of the goodness-of-fit
    /// test ([`super::window_noise_variance_a2`]): [`DECIMATION`] for frames sampled at the
    /// control rate (the firmware's ADC), fewer for a recording interpolated from a slower rate
    /// (`DECIMATION · f_recording / f_control`).
    pub independent_frames_per_block: f32,
    /// The previous flight's fault vector: `Some` makes the identification a **warm start** from
    /// it (no global search; model selection, the polish, the new-fault probes and the targeted
    /// refit, `warm.rs` and `probes.rs`); `None` (the default) a cold one. Whether a warm start
    /// is allowed is [`super::plan_start`]'s decision.
    pub prior: Option<[f32; FAULT_COUNT]>,
    /// Flights after which a cold identification runs again instead of a warm one
    /// ([`super::plan_start`]; 20 by default, `COLD_EVERY_FLIGHTS`).
    pub cold_every_flights: u32,
}

impl Default for IdentifyConfig {
    /// The paper's global search (PSO, 200 iterations, tolerance 1e-9), then model selection and
    /// the polish, on the fitness with the fast regime weighted by [`FAST_REGIME_WEIGHT`].
    fn default() -> Self {
        Self {
            model_selection: true,
            polish: Some(PatternConfig::default()),
            fast_regime_weight: FAST_REGIME_WEIGHT,
            ..Self::paper()
        }
    }
}

impl IdentifyConfig {
    /// Refuses effect terms ([`IdentifyConfig::effects`] other than `NONE`) in a build without
    /// them (the `effect-terms` feature): [`MonitorError::EffectsNotBuilt`].
    pub fn check_effects_built(&self) -> Result<(), MonitorError> {
        if cfg!(feature = "effect-terms") || self.effects.is_none() {
            Ok(())
        } else {
            Err(MonitorError::EffectsNotBuilt)
        }
    }

    /// The paper alone: PSO, 200 iterations, tolerance 1e-9, no selection, no polish.
    pub fn paper() -> Self {
        Self {
            algorithm: Algorithm::Pso,
            seed: 1,
            max_iterations: 200,
            function_tolerance: 1e-9,
            stall_iterations: 20,
            model_selection: false,
            polish: None,
            effects: ModelEffects::NONE,
            fast_regime_weight: 1.0,
            selection_polish_max_evaluations: SELECTION_POLISH_MAX_EVALUATIONS,
            independent_frames_per_block: DECIMATION as f32,
            prior: None,
            cold_every_flights: super::COLD_EVERY_FLIGHTS,
        }
    }

    /// The firmware's settings: PSO with [`ONBOARD_MAX_ITERATIONS`], model selection and the polish.
    pub fn onboard() -> Self {
        Self { max_iterations: ONBOARD_MAX_ITERATIONS, ..Self::default() }
    }
}

/// The fitness of `trace` under `command` as `config` sets it (its effect terms and fast-regime
/// weight): what the identification minimises, and what its uncertainty and the evidence over
/// flights evaluate again after it.
pub fn configured_fit<'a, const W: usize>(
    trace: &'a ConditionedWindow<W>,
    params: EmaParams,
    command: impl Into<Command<'a>>,
    config: &IdentifyConfig,
) -> Result<EquivalentCurrentFit<'a, W>, MonitorError> {
    config.check_effects_built()?;
    let mut fit = EquivalentCurrentFit::new(trace, params, command)?;
    if !fit.configure(config.effects, config.fast_regime_weight) {
        return Err(MonitorError::FastRegimeWeight);
    }
    Ok(fit)
}

/// Evaluations of [`IdentifyConfig::selection_polish_max_evaluations`] left after `used` (a free
/// function: one of its callers holds the selection stage borrowed).
pub(super) fn selection_polish_left(config: &IdentifyConfig, used: u32) -> u32 {
    config.selection_polish_max_evaluations.saturating_sub(used)
}

/// Where the global search starts besides its random points: the healthy actuator, a
/// half-severity short circuit on each phase in turn, and a half-severity eccentricity at the four
/// phases `k7` = 1/8, 3/8, 5/8, 7/8. The three shorts are separate basins of `E` (a short on A
/// explains little of a short on B), and the eccentricity phase is a periodic basin too (an
/// eccentricity at the wrong phase fits worse than none): one starting point in each basin lets
/// the search reach every one of them (`docs/decisions/0010-basin-seeds.md`).
pub fn starting_guesses() -> [[f32; FAULT_COUNT]; 8] {
    let healthy = FaultVector::HEALTHY.0;
    let mut guesses = [healthy; 8];
    for (phase, guess) in guesses.iter_mut().skip(1).take(3).enumerate() {
        guess[2 + phase] = 0.5;
    }
    for (quarter, guess) in guesses.iter_mut().skip(4).enumerate() {
        guess[5] = 0.5;
        guess[PHASE_INDEX] = 0.125 + 0.25 * quarter as f32;
    }
    guesses
}

/// The search space: the unit box, the eccentricity phase periodic.
pub fn fault_bounds() -> Bounds<FAULT_COUNT> {
    let mut b = Bounds::unit();
    b.periodic[PHASE_INDEX] = true;
    b
}
