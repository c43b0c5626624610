//! The pipeline: a conditioned trace + the monitor model's fitness + an optimizer → a health report.
//!
//! [`Identification`] owns the optimizer's fixed-size state and borrows the trace; it advances one
//! objective evaluation per [`Identification::step`], so firmware can spread the work over control
//! cycles, or call [`Identification::run`] to finish at once. Configuration is checked once in
//! [`Identification::new`]; after that nothing in the loop can fail or panic.

use crate::acquisition::{AcquisitionError, PhaseCurrents};
use crate::conditioning::{ConditioningError, MeasuredTrace, DECIMATION};
use crate::faults::{FaultVector, FAULT_COUNT};
use crate::fitness::CurrentFit;
use crate::health::HealthReport;
use crate::optimizer::de::{DeConfig, DifferentialEvolution};
use crate::optimizer::ga::{GaConfig, Genetic};
use crate::optimizer::pso::{ParticleSwarm, PsoConfig};
use crate::optimizer::{Bounds, ConfigError, Optimizer, Status};
use crate::params::EmaParams;
use crate::profile::Profile;

/// Window capacity of the on-board identification: the standard 0.85 s manoeuvre is 2125 window
/// samples at 2.5 kHz; 2200 leaves room for a slightly longer recording.
pub const ONBOARD_WINDOW: usize = 2200;

/// Swarm (population) size of the on-board identification: the paper's 50.
pub const ONBOARD_POPULATION: usize = 50;

/// Iteration limit of the on-board identification: 40 iterations × 50 particles = 2000
/// evaluations, ~6e9 Cortex-M4F instructions on the standard trace (the bar is 1e10; the paper's
/// 200 iterations took 3.0e10). On the built-in trace the fitness at 40 iterations is within 0.2 %
/// of its value at 200 (`ema identify --firmware-trace … --max-iterations N`, README).
pub const ONBOARD_MAX_ITERATIONS: u32 = 40;

/// Index of the eccentricity phase `k7`, the one periodic parameter.
const PHASE_INDEX: usize = 6;

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

/// Settings of one identification. `Default` = the paper: PSO, 200 iterations, tolerance 1e-9.
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
}

impl Default for IdentifyConfig {
    fn default() -> Self {
        Self { algorithm: Algorithm::Pso, seed: 1, max_iterations: 200, function_tolerance: 1e-9, stall_iterations: 20 }
    }
}

impl IdentifyConfig {
    /// The firmware's settings: PSO, seed 1, [`ONBOARD_MAX_ITERATIONS`], the paper's tolerance.
    pub fn onboard() -> Self {
        Self { max_iterations: ONBOARD_MAX_ITERATIONS, ..Self::default() }
    }
}

/// Why an identification could not start.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum MonitorError {
    /// The measured trace was refused.
    Conditioning(ConditioningError),
    /// The optimizer settings were refused.
    Optimizer(ConfigError),
    /// An actuator parameter is not finite or not physical (e.g. a non-positive inertia).
    Params,
    /// The trace is longer than the command profile that drives the model.
    TraceLongerThanProfile,
    /// A frame was refused by acquisition (sensor fault): `frame` is its index.
    Acquisition {
        /// What acquisition found.
        error: AcquisitionError,
        /// Index of the refused frame.
        frame: u32,
    },
}

impl core::fmt::Display for MonitorError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            MonitorError::Conditioning(e) => write!(f, "measured trace refused: {e}"),
            MonitorError::Optimizer(e) => write!(f, "optimizer settings refused: {e}"),
            MonitorError::Params => f.write_str("an actuator parameter is not finite or not physical"),
            MonitorError::TraceLongerThanProfile => f.write_str("the trace is longer than the command profile"),
            MonitorError::Acquisition { error, frame } => write!(f, "frame {frame} refused by acquisition: {error}"),
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
/// and closes the window. A refused frame stops the acquisition with [`MonitorError::Acquisition`]:
/// an identification on data from a faulty sensor would diagnose the sensor, not the actuator.
pub fn acquire<const W: usize, S: PhaseCurrents>(
    source: &mut S,
    trace: &mut MeasuredTrace<W>,
) -> Result<(), MonitorError> {
    let mut frame = 0u32;
    loop {
        match source.read_frame() {
            Ok(f) => trace.push(f.ia_a, f.ib_a, f.ic_a)?,
            Err(AcquisitionError::EndOfData) => break,
            Err(error) => return Err(MonitorError::Acquisition { error, frame }),
        }
        frame = frame.wrapping_add(1);
    }
    Ok(trace.finish()?)
}

/// `true` when every parameter is finite and the physical ones are positive where they must be.
pub fn params_are_valid(p: &EmaParams) -> bool {
    let positive = [
        p.supply_voltage_v,
        p.pole_pairs,
        p.phase_resistance_ohm,
        p.phase_inductance_h,
        p.phase_emf_constant_v_s_per_rad,
        p.current_limit_a,
        p.motor_inertia_kg_m2,
        p.gear_ratio,
        p.control_period_s,
        p.derivative_filter_s,
        p.current_loop_lag_s,
        p.efficiency_opposing,
        p.end_stop_rad,
    ];
    let non_negative = [
        p.hysteresis_half_band_a,
        p.surface_inertia_kg_m2,
        p.viscous_friction_n_m_s_per_rad,
        p.static_friction_n_m,
        p.dynamic_friction_n_m,
        p.nominal_backlash_rad,
        p.hinge_stiffness_n_m_per_rad,
        p.kp_a_per_rad,
        p.ki_a_per_rad_s,
        p.kd_a_s_per_rad,
        p.current_noise_a,
        p.position_noise_rad,
        p.position_resolution_rad,
    ];
    positive.iter().all(|x| x.is_finite() && *x > 0.0)
        && non_negative.iter().all(|x| x.is_finite() && *x >= 0.0)
        && p.efficiency_aiding.is_finite()
        && p.efficiency_aiding <= 1.0
        && p.efficiency_opposing <= 1.0
        && p.dynamic_friction_n_m <= p.static_friction_n_m
        && p.control_period_s < p.derivative_filter_s
}

/// The search space: the unit box, the eccentricity phase periodic.
pub fn fault_bounds() -> Bounds<FAULT_COUNT> {
    let mut b = Bounds::unit();
    b.periodic[PHASE_INDEX] = true;
    b
}

#[derive(Clone, Debug)]
enum Solver<const P: usize> {
    Pso(ParticleSwarm<P, FAULT_COUNT>),
    Ga(Genetic<P, FAULT_COUNT>),
    De(DifferentialEvolution<P, FAULT_COUNT>),
}

/// One fault identification in progress: `W` window samples, `P` individuals.
#[derive(Clone, Debug)]
pub struct Identification<'a, const W: usize, const P: usize> {
    fit: CurrentFit<'a, W>,
    solver: Solver<P>,
    params: EmaParams,
    status: Status,
}

impl<'a, const W: usize, const P: usize> Identification<'a, W, P> {
    /// Prepares the identification of `trace`, measured under `profile` on an actuator whose
    /// healthy parameters are `params`.
    pub fn new(
        trace: &'a MeasuredTrace<W>,
        params: EmaParams,
        profile: Profile,
        config: &IdentifyConfig,
    ) -> Result<Self, MonitorError> {
        if !params_are_valid(&params) {
            return Err(MonitorError::Params);
        }
        if !trace.is_finished() {
            return Err(MonitorError::Conditioning(ConditioningError::Finished));
        }
        let trace_s = (trace.len() * DECIMATION) as f32 * params.control_period_s;
        if trace_s > profile.duration_s() + params.control_period_s {
            return Err(MonitorError::TraceLongerThanProfile);
        }
        let bounds = fault_bounds();
        let healthy = FaultVector::HEALTHY.0;
        let solver = match config.algorithm {
            Algorithm::Pso => {
                let c = PsoConfig {
                    max_iterations: config.max_iterations,
                    function_tolerance: config.function_tolerance,
                    stall_iterations: config.stall_iterations,
                    ..PsoConfig::default()
                };
                Solver::Pso(ParticleSwarm::new(bounds, c, config.seed)?.with_initial_guess(healthy))
            }
            Algorithm::Ga => {
                let c = GaConfig {
                    max_iterations: config.max_iterations,
                    function_tolerance: config.function_tolerance,
                    stall_iterations: config.stall_iterations,
                    ..GaConfig::default()
                };
                Solver::Ga(Genetic::new(bounds, c, config.seed)?.with_initial_guess(healthy))
            }
            Algorithm::De => {
                let c = DeConfig {
                    max_iterations: config.max_iterations,
                    function_tolerance: config.function_tolerance,
                    stall_iterations: config.stall_iterations,
                    ..DeConfig::default()
                };
                Solver::De(DifferentialEvolution::new(bounds, c, config.seed)?.with_initial_guess(healthy))
            }
        };
        Ok(Self { fit: CurrentFit::new(trace, params, profile), solver, params, status: Status::Running })
    }

    /// One objective evaluation (one monitor-model run over the trace, possibly abandoned early).
    pub fn step(&mut self) -> Status {
        if let Status::Done(_) = self.status {
            return self.status;
        }
        self.status = match &mut self.solver {
            Solver::Pso(s) => s.step(&mut self.fit),
            Solver::Ga(s) => s.step(&mut self.fit),
            Solver::De(s) => s.step(&mut self.fit),
        };
        self.status
    }

    /// Steps until the optimizer stops or `max_evaluations` more evaluations are spent.
    pub fn run(&mut self, max_evaluations: u32) -> Status {
        for _ in 0..max_evaluations {
            if let Status::Done(_) = self.step() {
                break;
            }
        }
        self.status
    }

    /// Status after the last step.
    pub fn status(&self) -> Status {
        self.status
    }

    /// The fitness being minimised (to evaluate other vectors against the same trace).
    pub fn fitness(&self) -> &CurrentFit<'a, W> {
        &self.fit
    }

    /// The health report of the best vector so far.
    pub fn report(&self) -> HealthReport {
        let (best, cost, evaluations, iterations) = match &self.solver {
            Solver::Pso(s) => (*s.best().0, s.best().1, s.evaluations(), s.iterations()),
            Solver::Ga(s) => (*s.best().0, s.best().1, s.evaluations(), s.iterations()),
            Solver::De(s) => (*s.best().0, s.best().1, s.evaluations(), s.iterations()),
        };
        let termination = match self.status {
            Status::Done(reason) => Some(reason),
            Status::Running => None,
        };
        HealthReport::new(FaultVector(best), &self.params, cost, evaluations, iterations, termination)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::conditioning::DECIMATION;
    use crate::fitness::simulate_window;

    /// A noise-free "measurement" of the monitor model with faults `k`, through conditioning.
    fn self_trace(k: &FaultVector) -> MeasuredTrace<ONBOARD_WINDOW> {
        let mut t = MeasuredTrace::new();
        let n = (Profile::STANDARD.duration_s() / EmaParams::NOMINAL.control_period_s) as usize / DECIMATION;
        simulate_window(&EmaParams::NOMINAL, &Profile::STANDARD, k, n, |_, i, _| {
            for _ in 0..DECIMATION {
                t.push(i, -i, 0.0).unwrap();
            }
            true
        });
        t.finish().unwrap();
        t
    }

    #[test]
    fn pso_recovers_a_synthetic_fault_vector_from_the_model_itself() {
        // Known answer: friction, a phase-B short and gain drift at once; the on-board budget.
        let truth = FaultVector([0.3, 0.0, 0.0, 0.2, 0.0, 0.0, 0.5, 0.35]);
        let trace = self_trace(&truth);
        let config = IdentifyConfig::onboard();
        let mut id: Identification<'_, ONBOARD_WINDOW, ONBOARD_POPULATION> =
            Identification::new(&trace, EmaParams::NOMINAL, Profile::STANDARD, &config).unwrap();
        id.run(u32::MAX);
        let r = id.report();
        let err = r.faults.paper_error_percent(&truth);
        assert!(err < 1.0, "Err% {err}: {:?}", r.faults.0);
        assert_eq!(r.evaluations, ONBOARD_MAX_ITERATIONS * ONBOARD_POPULATION as u32);
    }

    #[test]
    fn de_recovers_a_synthetic_fault_vector_from_the_model_itself() {
        // The same known answer as the PSO's, with differential evolution at the paper's budget. DE starts
        // slower: at the on-board 2 000 evaluations it is still at Err% 4–5 on this vector (seeds 1, 2; the PSO
        // 0.4), at 5 000 it is at 0.02–0.04 (the PSO 0.07–0.19), at the paper's budget 0.003–0.008 after
        // 6 250–6 750 evaluations (the PSO 0.013–0.03 after 7 000–7 950).
        let truth = FaultVector([0.3, 0.0, 0.0, 0.2, 0.0, 0.0, 0.5, 0.35]);
        let trace = self_trace(&truth);
        let config = IdentifyConfig { algorithm: Algorithm::De, ..IdentifyConfig::default() };
        let mut id: Identification<'_, ONBOARD_WINDOW, ONBOARD_POPULATION> =
            Identification::new(&trace, EmaParams::NOMINAL, Profile::STANDARD, &config).unwrap();
        id.run(u32::MAX);
        let r = id.report();
        let err = r.faults.paper_error_percent(&truth);
        assert!(err < 0.1, "Err% {err}: {:?}", r.faults.0);
        assert!(r.evaluations <= config.max_iterations * ONBOARD_POPULATION as u32);
        assert_eq!(r.evaluations, r.iterations * ONBOARD_POPULATION as u32);
    }

    #[test]
    fn impossible_configurations_are_refused() {
        let trace = self_trace(&FaultVector::HEALTHY);
        let mut bad = EmaParams::NOMINAL;
        bad.control_period_s = f32::NAN;
        let r = Identification::<ONBOARD_WINDOW, 8>::new(&trace, bad, Profile::STANDARD, &IdentifyConfig::default());
        assert!(matches!(r, Err(MonitorError::Params)));
        let short = Profile::new(&[crate::profile::Segment::Hold { start_s: 0.0, value_rad: 0.0 }], 0.1, 0.6).unwrap();
        let r = Identification::<ONBOARD_WINDOW, 8>::new(&trace, EmaParams::NOMINAL, short, &IdentifyConfig::default());
        assert!(matches!(r, Err(MonitorError::TraceLongerThanProfile)));
        let unfinished = MeasuredTrace::<ONBOARD_WINDOW>::new();
        let r = Identification::<ONBOARD_WINDOW, 8>::new(
            &unfinished,
            EmaParams::NOMINAL,
            Profile::STANDARD,
            &IdentifyConfig::default(),
        );
        assert!(matches!(r, Err(MonitorError::Conditioning(ConditioningError::Finished))));
    }
}
