//! Whether an ordinary unit explains a diagnosis: after an identification that found a fault,
//! the best healthy unit within the unit's tolerances is fitted to the same recording (the core's
//! commissioning on one flight, [`ema_monitor::commissioning`]), and the fault stands only when
//! it pays for its parameters against that unit
//! ([`ema_monitor::commissioning::fault_pays_over_unit`]), or when that unit needs a parameter
//! beyond its tolerance ([`ema_monitor::commissioning::Baseline::beyond_tolerance`]: an
//! unmodelled effect, not an ordinary unit); and never when every phase reads shorted
//! ([`ema_monitor::commissioning::every_phase_shorted`]). Otherwise the report abstains with
//! [`Abstain::UnitMismatch`]: the recording shows a unit that differs from its parameters, not a
//! fault, and commissioning gives the unit its own.
//!
//! A unit that was never commissioned is judged against the tolerance table; a commissioned one
//! against the 1σ its commissioning left.

use ema_monitor::commissioning::{
    commission, every_phase_shorted, fault_pays_over_unit, BaselineFit, CommissioningFlight, SWARM_ITERATIONS,
    SWARM_PARTICLES,
};
use ema_monitor::conditioning::ConditionedWindow;
use ema_monitor::diagnosis::{configured_fit, group_present, group_size, IdentifyConfig};
use ema_monitor::faults::FaultGroup;
use ema_monitor::health::{Abstain, HealthReport, Status};
use ema_monitor::unit::{Tolerances, UNIT_PARAM_COUNT};
use ema_monitor::{Command, EmaParams, FaultVector};

/// The best healthy unit for a recording, against the diagnosis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UnitCheck {
    /// The unit's deviations from the parameters, in tolerance σ.
    pub z: [f32; UNIT_PARAM_COUNT],
    /// Its fitness (healthy faults), A².
    pub error_unit: f32,
    /// The diagnosis's fitness, A².
    pub error_fault: f32,
    /// Every phase reads shorted ([`every_phase_shorted`]): a unit that differs from its
    /// parameters, whatever the fits say.
    pub every_phase_shorted: bool,
    /// The diagnosis pays for its fault parameters against the unit (and not every phase reads
    /// shorted).
    pub fault_pays: bool,
}

/// The unit check of `report` (an identification of `trace` of the unit `params` under `command`
/// with `config`), for a unit known to within `tolerances`: `None` when there is nothing to check
/// (no fault reported, or tolerances all zero: the unit is exactly its parameters).
pub fn check_unit<const W: usize>(
    trace: &ConditionedWindow<W>,
    params: &EmaParams,
    command: Command<'_>,
    config: &IdentifyConfig,
    tolerances: &Tolerances,
    report: &HealthReport,
) -> Option<UnitCheck> {
    if !matches!(report.status, Status::Degraded | Status::Failing)
        || tolerances.relative_sigma.iter().all(|s| *s == 0.0)
    {
        return None;
    }
    let fit = configured_fit(trace, *params, command, config).ok()?;
    let flights = [CommissioningFlight { fit: &fit, temperature_c: f32::NAN }];
    let mut objective = BaselineFit::new(&flights, *params, *tolerances, config.independent_frames_per_block).ok()?;
    let unit = commission::<W, SWARM_PARTICLES>(&mut objective, SWARM_ITERATIONS, config.seed, &mut || {}).ok()?;
    let error_unit = fit.error_of_unit(&unit.params, &FaultVector::HEALTHY, f32::INFINITY);
    let k = &report.faults;
    let error_fault = fit.error(k);
    let parameters: usize = FaultGroup::ALL.into_iter().filter(|&g| group_present(&k.0, g)).map(group_size).sum();
    let z_sq: f32 = unit.z.iter().map(|z| z * z).sum();
    // a unit that needs a parameter beyond its tolerance is not an ordinary one
    let pays = unit.beyond_tolerance().is_some()
        || fault_pays_over_unit(error_fault, error_unit, z_sq, parameters, fit.effective_samples(k));
    let pattern = every_phase_shorted(k);
    Some(UnitCheck { z: unit.z, error_unit, error_fault, every_phase_shorted: pattern, fault_pays: pays && !pattern })
}

/// `report` as the unit check leaves it: abstaining with [`Abstain::UnitMismatch`] when the
/// fault does not pay against the unit.
pub fn with_unit_check(report: HealthReport, check: Option<&UnitCheck>) -> HealthReport {
    match check {
        Some(c) if !c.fault_pays => report.abstaining(Status::Inconclusive(Abstain::UnitMismatch)),
        _ => report,
    }
}
