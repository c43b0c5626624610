//! The health report: the identified fault vector read as physical faults with a status each.
//!
//! Severity per fault mode, in `[0, 1]` (from the normalized vector, see [`crate::faults`]):
//! friction `k1`; backlash `k2`; short circuit `max(k3, k4, k5)` (the worst phase is named);
//! eccentricity `k6`; gain drift `2·|k8 − 0.5|`.
//!
//! Status thresholds [P, proposed; tune on fleet data]: **healthy** below [`DEGRADED_AT`] (0.10:
//! friction 1.2× nominal, backlash 0.55 mrad, 5 % shorted turns, ζ = 0.05, gain ±10 %, i.e. well
//! above the identification error on a healthy actuator), **degraded** below [`FAILING_AT`]
//! (0.50: friction 2×, backlash 2.5 mrad, 25 % shorted turns, ζ = 0.25, gain ±50 %), **failing**
//! above.

use crate::faults::{FaultVector, BACKLASH_SPAN, FRICTION_SPAN, MAX_ECCENTRICITY, MAX_SHORTED_FRACTION};
use crate::optimizer::TerminationReason;
use crate::params::EmaParams;

/// Severity from which a fault mode is reported as degraded.
pub const DEGRADED_AT: f32 = 0.10;
/// Severity from which a fault mode is reported as failing.
pub const FAILING_AT: f32 = 0.50;

/// The five fault modes of the paper.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FaultMode {
    /// Dry friction growth (bearing and transmission wear).
    Friction,
    /// Backlash growth (gear, ballscrew wear).
    Backlash,
    /// Partial turn-to-turn short circuit of a stator phase.
    ShortCircuit,
    /// Rotor static eccentricity (support bearing degradation).
    Eccentricity,
    /// Drift of the position loop's proportional gain (control electronics).
    GainDrift,
}

impl FaultMode {
    /// All modes in report order.
    pub const ALL: [FaultMode; 5] = [
        FaultMode::Friction,
        FaultMode::Backlash,
        FaultMode::ShortCircuit,
        FaultMode::Eccentricity,
        FaultMode::GainDrift,
    ];

    /// Short name.
    pub const fn name(self) -> &'static str {
        match self {
            FaultMode::Friction => "friction",
            FaultMode::Backlash => "backlash",
            FaultMode::ShortCircuit => "short circuit",
            FaultMode::Eccentricity => "eccentricity",
            FaultMode::GainDrift => "gain drift",
        }
    }
}

/// Condition of one fault mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Condition {
    /// Severity below [`DEGRADED_AT`].
    Healthy,
    /// Severity in `[DEGRADED_AT, FAILING_AT)`.
    Degraded,
    /// Severity from [`FAILING_AT`] on.
    Failing,
}

impl Condition {
    /// The condition of a severity.
    pub fn of(severity: f32) -> Self {
        if severity >= FAILING_AT {
            Condition::Failing
        } else if severity >= DEGRADED_AT {
            Condition::Degraded
        } else {
            Condition::Healthy
        }
    }

    /// Upper-case label.
    pub const fn label(self) -> &'static str {
        match self {
            Condition::Healthy => "HEALTHY",
            Condition::Degraded => "DEGRADED",
            Condition::Failing => "FAILING",
        }
    }
}

/// One fault mode in physical terms.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ModeReport {
    /// Which mode.
    pub mode: FaultMode,
    /// Severity in `[0, 1]`.
    pub severity: f32,
    /// Status from the thresholds.
    pub condition: Condition,
    /// The physical value, in [`ModeReport::unit`]: friction multiplier, backlash mrad, shorted
    /// turns % of the worst phase, eccentricity ζ, proportional gain % of nominal.
    pub value: f32,
    /// Worst phase (0 = A, 1 = B, 2 = C) for a short circuit; the eccentricity phase in degrees is
    /// in [`HealthReport::eccentricity_phase_deg`].
    pub phase: u8,
}

impl ModeReport {
    /// Unit (or meaning) of [`ModeReport::value`].
    pub const fn unit(&self) -> &'static str {
        match self.mode {
            FaultMode::Friction => "x nominal friction",
            FaultMode::Backlash => "mrad free play",
            FaultMode::ShortCircuit => "% turns shorted",
            FaultMode::Eccentricity => "zeta (e/g)",
            FaultMode::GainDrift => "% of nominal Kp",
        }
    }
}

/// Outcome of one identification.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HealthReport {
    /// The identified normalized fault vector.
    pub faults: FaultVector,
    /// The five fault modes in physical terms.
    pub modes: [ModeReport; 5],
    /// Angle of the minimum air gap, degrees (meaningful only with eccentricity).
    pub eccentricity_phase_deg: f32,
    /// Final fitness `E` (A²).
    pub fitness: f32,
    /// Objective evaluations spent.
    pub evaluations: u32,
    /// Optimizer iterations (generations) completed.
    pub iterations: u32,
    /// Why the optimizer stopped (`None`: stopped by the caller's budget).
    pub termination: Option<TerminationReason>,
    /// Fault groups found by the global search that model selection could not price before the
    /// budget of selection and polish ran out
    /// ([`crate::monitor::IdentifyConfig::selection_polish_max_evaluations`]):
    /// reported as found, not tested against the information criterion. 0 when every group
    /// was tested (or model selection is off).
    pub untested_groups: u8,
}

impl HealthReport {
    /// Reads `faults` against the nominal actuator `params`.
    pub fn new(
        faults: FaultVector,
        params: &EmaParams,
        fitness: f32,
        evaluations: u32,
        iterations: u32,
        termination: Option<TerminationReason>,
    ) -> Self {
        let k = &faults.0;
        let mut worst = 0usize;
        for j in 1..3 {
            if k[2 + j] > k[2 + worst] {
                worst = j;
            }
        }
        let mode = |mode, severity: f32, value, phase| ModeReport {
            mode,
            severity,
            condition: Condition::of(severity),
            value,
            phase,
        };
        let backlash_rad = params.nominal_backlash_rad * (1.0 + BACKLASH_SPAN * k[1]);
        let modes = [
            mode(FaultMode::Friction, k[0], 1.0 + FRICTION_SPAN * k[0], 0),
            mode(FaultMode::Backlash, k[1], 1e3 * backlash_rad, 0),
            mode(FaultMode::ShortCircuit, k[2 + worst], 100.0 * MAX_SHORTED_FRACTION * k[2 + worst], worst as u8),
            mode(FaultMode::Eccentricity, k[5], MAX_ECCENTRICITY * k[5], 0),
            mode(FaultMode::GainDrift, 2.0 * libm::fabsf(k[7] - 0.5), 100.0 * (0.5 + k[7]), 0),
        ];
        Self {
            faults,
            modes,
            eccentricity_phase_deg: 360.0 * k[6] - 180.0,
            fitness,
            evaluations,
            iterations,
            termination,
            untested_groups: 0,
        }
    }

    /// The worst condition over all modes.
    pub fn overall(&self) -> Condition {
        let mut worst = Condition::Healthy;
        for m in &self.modes {
            if m.condition > worst {
                worst = m.condition;
            }
        }
        worst
    }
}

impl core::fmt::Display for HealthReport {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        writeln!(f, "EMA health: {}", self.overall().label())?;
        for m in &self.modes {
            write!(
                f,
                "  {:<14} {:<9} severity {:.3}  {:.3} {}",
                m.mode.name(),
                m.condition.label(),
                m.severity,
                m.value,
                m.unit()
            )?;
            match m.mode {
                FaultMode::ShortCircuit => write!(f, " (phase {})", ['A', 'B', 'C'][m.phase as usize % 3])?,
                FaultMode::Eccentricity => write!(f, " (min gap at {:.0} deg)", self.eccentricity_phase_deg)?,
                _ => {}
            }
            writeln!(f)?;
        }
        write!(f, "  k =")?;
        for k in &self.faults.0 {
            write!(f, " {k:.4}")?;
        }
        writeln!(f)?;
        write!(
            f,
            "  fitness {:.4e} A^2, {} evaluations, {} iterations",
            self.fitness, self.evaluations, self.iterations
        )?;
        if self.untested_groups > 0 {
            write!(
                f,
                "\n  model selection: {} fault group(s) not tested (selection and polish budget spent)",
                self.untested_groups
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn healthy_vector_reads_healthy() {
        let r = HealthReport::new(FaultVector::HEALTHY, &EmaParams::NOMINAL, 0.0, 1, 1, None);
        assert_eq!(r.overall(), Condition::Healthy);
        assert!((r.modes[0].value - 1.0).abs() < 1e-6);
        assert!((r.modes[1].value - 0.05).abs() < 1e-6);
        assert!((r.modes[4].value - 100.0).abs() < 1e-4);
    }

    #[test]
    fn faults_read_in_physical_terms() {
        let k = FaultVector([0.25, 0.0, 0.0, 0.8, 0.1, 0.0, 0.5, 0.2]);
        let r = HealthReport::new(k, &EmaParams::NOMINAL, 0.0, 1, 1, None);
        assert!((r.modes[0].value - 1.5).abs() < 1e-6);
        assert_eq!(r.modes[0].condition, Condition::Degraded);
        assert_eq!(r.modes[2].phase, 1);
        assert!((r.modes[2].value - 40.0).abs() < 1e-4);
        assert_eq!(r.modes[2].condition, Condition::Failing);
        assert!((r.modes[4].severity - 0.6).abs() < 1e-6);
        assert!((r.modes[4].value - 70.0).abs() < 1e-4);
        assert_eq!(r.overall(), Condition::Failing);
        let text = std::format!("{r}");
        assert!(text.contains("short circuit") && text.contains("phase B") && text.contains("FAILING"), "{text}");
        assert!(!text.contains("not tested"), "{text}");
        let cut = HealthReport { untested_groups: 2, ..r };
        let text = std::format!("{cut}");
        assert!(
            text.ends_with("model selection: 2 fault group(s) not tested (selection and polish budget spent)"),
            "{text}"
        );
    }
}
