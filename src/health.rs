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
//!
//! **Status.** The report's [`Status`] is the worst mode's condition only when the data support a
//! diagnosis. The monitor abstains with [`Status::Inconclusive`] when the best fit is far worse
//! than the sensor noise explains ([`Abstain::PoorFit`], the test of [`FitCheck`]), when the
//! recording does not cover the manoeuvre ([`Abstain::PartialCoverage`]) or when its declared
//! sample rate is not the monitor's ([`Abstain::RateMismatch`]); it reports
//! [`Status::SensorFault`] when acquisition refused too many frames
//! ([`crate::acquisition::AcquisitionSummary::is_sensor_fault`]). Under either, the fault values are
//! not a diagnosis: the text report withholds the mode lines (`docs/identification.md`, "Status
//! and when the monitor abstains").

use crate::acquisition::AcquisitionSummary;
use crate::faults::{FaultMode, FaultVector, BACKLASH_SPAN, FRICTION_SPAN, MAX_ECCENTRICITY, MAX_SHORTED_FRACTION};
use crate::optimizer::TerminationReason;
use crate::params::EmaParams;

/// Severity from which a fault mode is reported as degraded.
pub const DEGRADED_AT: f32 = 0.10;
/// Severity from which a fault mode is reported as failing.
pub const FAILING_AT: f32 = 0.50;

/// Condition of one fault mode, ordered from the least to the most severe.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Condition {
    /// No fault found, but the recording could not have shown one of DEGRADED size: the mode's
    /// smallest detectable severity ([`Uncertainty::detectable_below`]) is at or above
    /// [`DEGRADED_AT`]. Set by [`HealthReport::with_uncertainty`]; never a severity's condition.
    NotAssessed,
    /// Severity below [`DEGRADED_AT`] (and, once the report carries its [`Uncertainty`], a
    /// DEGRADED fault of this mode would have been found).
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

    /// Upper-case label: `NOT_ASSESSED`, `HEALTHY`, `DEGRADED`, `FAILING`.
    pub const fn label(self) -> &'static str {
        match self {
            Condition::NotAssessed => "NOT_ASSESSED",
            Condition::Healthy => "HEALTHY",
            Condition::Degraded => "DEGRADED",
            Condition::Failing => "FAILING",
        }
    }
}

/// Why the monitor abstains from a diagnosis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Abstain {
    /// The best fit is far worse than the sensor noise and the monitor model's known mismatch
    /// explain ([`FitCheck`]): the recording is not this actuator under this manoeuvre, or an
    /// effect outside the model dominates it.
    PoorFit,
    /// The recording is shorter than the manoeuvre's profile: part of the evidence is missing.
    PartialCoverage,
    /// The recording's declared sample rate is not the monitor's control rate.
    RateMismatch,
    /// An ordinary unit, moved within its tolerances, explains the recording as well as the
    /// faults found ([`crate::commissioning::fault_pays_over_unit`]): the unit differs from the
    /// parameters the monitor has for it. Commissioning the unit gives it its own.
    UnitMismatch,
    /// A commissioning flight ([`crate::flight`]): its window is kept to fit the unit's
    /// baseline, and no diagnosis is made until the baseline exists.
    Commissioning,
    /// No mode could have been seen DEGRADED on this recording: every mode's smallest detectable
    /// severity is at or above [`DEGRADED_AT`] ([`Condition::NotAssessed`]). The manoeuvre does
    /// not excite the faults, or the declared noise (the parameters' sensor noise figures) is so
    /// large that the fit test and model selection accept anything.
    NothingAssessable,
}

impl Abstain {
    /// Lower-case reason, as logged: `poor fit`, `partial coverage`, `rate mismatch`,
    /// `unit mismatch`, `commissioning`, `nothing assessable`.
    pub const fn label(self) -> &'static str {
        match self {
            Abstain::PoorFit => "poor fit",
            Abstain::PartialCoverage => "partial coverage",
            Abstain::RateMismatch => "rate mismatch",
            Abstain::UnitMismatch => "unit mismatch",
            Abstain::Commissioning => "commissioning",
            Abstain::NothingAssessable => "nothing assessable",
        }
    }
}

/// The overall status of a report: a diagnosis (the worst mode's [`Condition`]) or an abstention.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Status {
    /// Every mode below [`DEGRADED_AT`], and at least one of them assessed
    /// ([`Condition::NotAssessed`] names the others).
    Healthy,
    /// The worst mode in `[DEGRADED_AT, FAILING_AT)`.
    Degraded,
    /// The worst mode from [`FAILING_AT`] on.
    Failing,
    /// The data do not support a diagnosis; the fault values are not reported as one.
    Inconclusive(Abstain),
    /// Acquisition refused too many frames: the sensors, not the actuator, are at fault.
    SensorFault,
}

impl Status {
    /// Upper-case label: `HEALTHY`, `DEGRADED`, `FAILING`, `INCONCLUSIVE`, `SENSOR_FAULT`.
    pub const fn label(self) -> &'static str {
        match self {
            Status::Healthy => "HEALTHY",
            Status::Degraded => "DEGRADED",
            Status::Failing => "FAILING",
            Status::Inconclusive(_) => "INCONCLUSIVE",
            Status::SensorFault => "SENSOR_FAULT",
        }
    }

    /// The reason of an [`Status::Inconclusive`] status.
    pub const fn reason(self) -> Option<Abstain> {
        match self {
            Status::Inconclusive(reason) => Some(reason),
            _ => None,
        }
    }

    /// `true` when the fault values are a diagnosis (healthy, degraded or failing).
    pub const fn is_diagnosis(self) -> bool {
        matches!(self, Status::Healthy | Status::Degraded | Status::Failing)
    }

    /// The status of a diagnosis whose worst mode is `condition`: an abstention
    /// ([`Abstain::NothingAssessable`]) when even the worst mode is not assessed.
    pub const fn of(condition: Condition) -> Self {
        match condition {
            Condition::NotAssessed => Status::Inconclusive(Abstain::NothingAssessable),
            Condition::Healthy => Status::Healthy,
            Condition::Degraded => Status::Degraded,
            Condition::Failing => Status::Failing,
        }
    }
}

/// Family-wise significance level of the goodness-of-fit test: a fit is rejected at `p < 10⁻⁶`.
pub const FIT_TEST_P: f32 = 1e-6;

/// One-sided limit of the whole-recording score: `z > 4.753` is `p <` [`FIT_TEST_P`] in the normal
/// approximation of the chi-square distribution ([`normal_upper_quantile`] of [`FIT_TEST_P`]).
pub const FIT_TEST_Z: f32 = 4.753;

/// The goodness-of-fit test of the final residual against the noise model, on the whole
/// recording and window by window.
///
/// Under the hypothesis "the monitor model explains the recording up to noise", the weighted
/// residual of the best vector is noise of variance `σ² + m²` per window sample (`σ²` the sensor,
/// ripple and controller-jitter noise of a block mean, `m` the monitor model's documented
/// structural mismatch), so with `n_eff` effective samples (AR(1)-corrected,
/// [`crate::fitness::EquivalentCurrentFit::effective_samples`]) `T = n_eff·E/(w̄·(σ² + m²))` follows a
/// chi-square distribution with `n_eff` degrees of freedom, `w̄` the mean sample weight of `E`.
/// Its normal approximation `z = (T − n_eff)/√(2·n_eff)` above [`FIT_TEST_Z`] rejects the fit.
///
/// **Window by window.** An effect outside the model concentrates its misfit where the
/// manoeuvre excites it (a compliant transmission in the fast reversal), and averaged over the
/// whole recording that misfit hides under the noise of the quiet parts. The same hypothesis
/// holds in every evidence window `j` ([`crate::fitness::EquivalentCurrentFit::residual_windows`]):
/// `T_j = ν_j·S_j/(V_j·(σ² + m²))` is chi-square with `ν_j` degrees of freedom, `S_j = Σ ρ_i·w_i·r_i²`
/// and `V_j = Σ ρ_i·w_i` over the window and `ν_j` its own AR(1)-corrected sample count
/// ([`window_score`], Wilson–Hilferty). The largest of the `J` window scores is compared with the
/// Šidák-corrected limit `z_J` = [`normal_upper_quantile`]`(1 − (1 − p)^(1/J))`, `p` =
/// [`FIT_TEST_P`], so that the family of `J` windows keeps the level `p` (Šidák 1967); the fit is
/// rejected when either test rejects it. The evidence behind the window test, the score on clean
/// recordings and on effects outside the library, is in
/// `docs/decisions/0017-windowed-fit-test.md`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FitCheck {
    /// Effective sample count of the residual.
    pub effective_samples: f32,
    /// The variance a residual of noise and known mismatch has, `w̄·(σ² + m²)` (A²).
    pub expected_a2: f32,
    /// `z`, the normal score of the chi-square statistic.
    pub z: f32,
    /// The largest window score `max_j z_j` (`−∞` when no window was tested).
    pub window_z: f32,
    /// Index of the window with the largest score.
    pub window: u16,
    /// The limit of [`FitCheck::window_z`]: the Šidák-corrected `z_J` for the windows tested
    /// (`+∞` when none was).
    pub window_limit: f32,
}

impl FitCheck {
    /// The test of fitness `fitness` (A²) with `effective_samples` and expected variance
    /// `expected_a2` (A²), without the window test. A non-finite or non-positive input gives
    /// `z = +∞` (rejected).
    pub fn new(fitness: f32, effective_samples: f32, expected_a2: f32) -> Self {
        let z = if fitness.is_finite() && effective_samples > 0.0 && expected_a2 > 0.0 && fitness >= 0.0 {
            let t = effective_samples * fitness / expected_a2;
            (t - effective_samples) / libm::sqrtf(2.0 * effective_samples)
        } else {
            f32::INFINITY
        };
        Self { effective_samples, expected_a2, z, window_z: f32::NEG_INFINITY, window: 0, window_limit: f32::INFINITY }
    }

    /// The test with the window test's outcome: the largest score `window_z` of `windows`
    /// windows, in window `window` (a NaN score is kept, and fails).
    pub fn with_windows(self, window_z: f32, window: u16, windows: usize) -> Self {
        let limit = if windows == 0 { f32::INFINITY } else { sidak_limit(windows) };
        Self { window_z, window, window_limit: limit, ..self }
    }

    /// `true` when the fit passes both tests (`z ≤` [`FIT_TEST_Z`] and `max_j z_j ≤ z_J`; NaN
    /// fails).
    pub fn passes(&self) -> bool {
        self.z <= FIT_TEST_Z && self.window_z <= self.window_limit
    }
}

/// The window test's limit `z_J` for `windows` windows: the upper `1 − (1 − p)^(1/J)` quantile of
/// the normal distribution, `p` = [`FIT_TEST_P`] (Šidák 1967): 5.34 for the 22 windows of the
/// standard manoeuvre.
pub fn sidak_limit(windows: usize) -> f32 {
    let j = windows.max(1) as f32;
    // 1 − (1 − p)^(1/J) without the cancellation of the direct form
    let per_window = -libm::expm1f(libm::log1pf(-FIT_TEST_P) / j);
    normal_upper_quantile(per_window)
}

/// The upper quantile `z` with `P(N(0, 1) > z) = p` of the standard normal distribution, for `p`
/// in `(0, 0.5]` (Abramowitz and Stegun 26.2.23, absolute error below 4.5·10⁻⁴): with
/// `t = √(−2·ln p)`, `z = t − (c₀ + c₁t + c₂t²)/(1 + d₁t + d₂t² + d₃t³)`. A `p` outside `(0, 0.5]`
/// (or NaN) gives `+∞` below 0 and 0 above.
pub fn normal_upper_quantile(p: f32) -> f32 {
    if p.is_nan() || p <= 0.0 {
        return f32::INFINITY;
    }
    if p >= 0.5 {
        return 0.0;
    }
    let t = libm::sqrtf(-2.0 * libm::logf(p));
    let num = 2.515_517 + t * (0.802_853 + t * 0.010_328);
    let den = 1.0 + t * (1.432_788 + t * (0.189_269 + t * 0.001_308));
    t - num / den
}

/// The residual's lag-1 correlation `ρ = L/S` from its squared sum `S` and lag-1 sum `L`,
/// clamped to `[0, 0.99]` (0 when `S` is not positive or `L` not finite): the correlation the
/// noise model's effective sample count `n·(1 − ρ)/(1 + ρ)` uses.
pub fn lag_correlation(weighted_sq: f32, lag: f32) -> f32 {
    let rho = if weighted_sq > 0.0 && lag.is_finite() { lag / weighted_sq } else { 0.0 };
    if rho > 0.99 {
        0.99
    } else if rho >= 0.0 {
        rho
    } else {
        0.0
    }
}

/// The normal score of one window's chi-square statistic: the window's `samples` samples with
/// weighted squared residual `S = Σ ρ_i·w_i·r_i²`, weight `V = Σ ρ_i·w_i` and lag-1 sum
/// `L = Σ u_i·u_{i−1}` (`u_i = √(ρ_i·w_i)·r_i`) against the noise variance `noise_a2` (`σ² + m²`,
/// A², unweighted). `ν = samples·(1 − ρ)/(1 + ρ)` with `ρ = L/S` clamped to `[0, 0.99]`, at least
/// 1; `T = ν·S/(V·noise_a2)`; the score is the Wilson–Hilferty transform
/// `z = ((T/ν)^{1/3} − (1 − 2/(9ν)))/√(2/(9ν))` (Wilson and Hilferty 1931), accurate in the upper
/// tail down to a few degrees of freedom where the plain normal approximation is not. A window
/// without weight or a non-positive noise gives `−∞` (no evidence); a non-finite sum gives NaN.
pub fn window_score(samples: u32, weighted_sq: f32, weight: f32, lag: f32, noise_a2: f32) -> f32 {
    let positive = |x: f32| x > 0.0; // NaN is not
    if samples == 0 || !positive(weight) || !positive(noise_a2) {
        return f32::NEG_INFINITY;
    }
    if !weighted_sq.is_finite() || !lag.is_finite() {
        return f32::NAN;
    }
    let rho = lag_correlation(weighted_sq, lag);
    let nu = (samples as f32 * (1.0 - rho) / (1.0 + rho)).max(1.0);
    let ratio = weighted_sq / (weight * noise_a2);
    let a = 2.0 / (9.0 * nu);
    (libm::cbrtf(ratio) - (1.0 - a)) / libm::sqrtf(a)
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

/// What the recording can tell about the reported vector
/// ([`crate::diagnosis::Identification::with_uncertainty`], `src/diagnosis/uncertainty.rs`).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Uncertainty {
    /// 1σ of each normalized fault parameter `k1..k8` at the estimate (`+∞`: not identifiable on
    /// this recording, e.g. the phase of an absent eccentricity). For a group reported healthy,
    /// the σ it would have were it fitted.
    pub sigma: [f32; 8],
    /// Per fault mode of [`FaultMode::ALL`], for a mode whose fault groups are all reported
    /// healthy: the smallest severity model selection would have kept on this recording (a
    /// fault below it can hide); `None` for a mode found.
    pub detectable_below: [Option<f32>; 5],
}

impl Uncertainty {
    /// The 1σ of a mode's severity ([`ModeReport::severity`]): `k1`, `k2`, the reported phase's
    /// short, `k6`, and `2·σ(k8)` for the gain drift.
    pub fn severity_sigma(&self, mode: &ModeReport) -> f32 {
        let s = &self.sigma;
        match mode.mode {
            FaultMode::Friction => s[0],
            FaultMode::Backlash => s[1],
            FaultMode::ShortCircuit => s[2 + usize::from(mode.phase) % 3],
            FaultMode::Eccentricity => s[5],
            FaultMode::GainDrift => 2.0 * s[7],
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
    /// ([`crate::diagnosis::IdentifyConfig::selection_polish_max_evaluations`]):
    /// reported as found, not tested against the information criterion. 0 when every group
    /// was tested (or model selection is off).
    pub untested_groups: u8,
    /// The overall status: the worst mode's condition, or an abstention (module doc).
    pub status: Status,
    /// The goodness-of-fit test of the best vector (`None` when not run).
    pub fit_check: Option<FitCheck>,
    /// Frames acquisition refused (masked by holding the last good frame).
    pub refused_frames: u32,
    /// The 1σ of each parameter and the detectable-below severities (`None`: not computed,
    /// [`crate::diagnosis::Identification::with_uncertainty`] adds it).
    pub uncertainty: Option<Uncertainty>,
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
        let mut worst = Condition::Healthy;
        for m in &modes {
            if m.condition > worst {
                worst = m.condition;
            }
        }
        Self {
            status: Status::of(worst),
            fit_check: None,
            refused_frames: 0,
            faults,
            modes,
            eccentricity_phase_deg: 360.0 * k[6] - 180.0,
            fitness,
            evaluations,
            iterations,
            termination,
            untested_groups: 0,
            uncertainty: None,
        }
    }

    /// The worst condition over all modes ([`Condition::NotAssessed`] only when no mode is
    /// assessed).
    pub fn overall(&self) -> Condition {
        let mut worst = Condition::NotAssessed;
        for m in &self.modes {
            if m.condition > worst {
                worst = m.condition;
            }
        }
        worst
    }

    /// The report with what the recording can tell, `uncertainty`: each mode found healthy whose
    /// smallest detectable severity is not below [`DEGRADED_AT`] becomes
    /// [`Condition::NotAssessed`] (a DEGRADED fault of it could hide in this recording), and a
    /// diagnosis in which no mode is assessed becomes [`Abstain::NothingAssessable`]. An
    /// abstention stays as it is. A NaN bound counts as not assessed.
    pub fn with_uncertainty(self, uncertainty: Uncertainty) -> Self {
        let mut modes = self.modes;
        for (m, floor) in modes.iter_mut().zip(uncertainty.detectable_below) {
            let hidden = floor.is_some_and(|f| f >= DEGRADED_AT || f.is_nan());
            if m.condition == Condition::Healthy && hidden {
                m.condition = Condition::NotAssessed;
            }
        }
        let report = Self { modes, uncertainty: Some(uncertainty), ..self };
        if report.status.is_diagnosis() {
            Self { status: Status::of(report.overall()), ..report }
        } else {
            report
        }
    }

    /// The report with the refused-frame count of `summary`, a [`Status::SensorFault`] when it
    /// shows a sensor fault ([`AcquisitionSummary::is_sensor_fault`]).
    pub fn with_acquisition(self, summary: &AcquisitionSummary) -> Self {
        let report = Self { refused_frames: summary.refused, ..self };
        if summary.is_sensor_fault() {
            report.abstaining(Status::SensorFault)
        } else {
            report
        }
    }

    /// The report with `status` unless it already holds a stronger abstention: a sensor fault
    /// outranks every other status, an inconclusive status outranks a diagnosis.
    pub fn abstaining(self, status: Status) -> Self {
        let rank = |s: Status| match s {
            Status::SensorFault => 2,
            Status::Inconclusive(_) => 1,
            _ => 0,
        };
        if rank(status) > rank(self.status) {
            Self { status, ..self }
        } else {
            self
        }
    }
}

impl core::fmt::Display for HealthReport {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self.status.reason() {
            Some(reason) => writeln!(f, "EMA health: {} ({})", self.status.label(), reason.label())?,
            None => {
                write!(f, "EMA health: {}", self.status.label())?;
                let diagnosis = self.status.is_diagnosis();
                let mut hidden = self.modes.iter().filter(|m| diagnosis && m.condition == Condition::NotAssessed);
                if let Some(first) = hidden.next() {
                    write!(f, " (not assessed: {}", first.mode.name())?;
                    for m in hidden {
                        write!(f, ", {}", m.mode.name())?;
                    }
                    write!(f, ")")?;
                }
                writeln!(f)?;
            }
        }
        if self.refused_frames > 0 {
            writeln!(f, "  refused frames: {} (held at the last good frame)", self.refused_frames)?;
        }
        let blind = self.status.reason() == Some(Abstain::NothingAssessable);
        if blind {
            writeln!(
                f,
                "  no mode assessable: a fault of DEGRADED size ({DEGRADED_AT:.2}) would not be seen on this recording"
            )?;
        } else if !self.status.is_diagnosis() {
            writeln!(f, "  no diagnosis: the fault values below are withheld from the mode report")?;
        }
        let floors = self.uncertainty.map(|u| u.detectable_below);
        for (j, m) in self.modes.iter().enumerate().filter(|_| self.status.is_diagnosis() || blind) {
            let floor = floors.and_then(|d| d.get(j).copied().flatten());
            write!(f, "  {:<14} {:<12} ", m.mode.name(), m.condition.label())?;
            if m.condition == Condition::NotAssessed {
                writeln!(f, "not detectable below {:.3}", floor.unwrap_or(f32::INFINITY))?;
                continue;
            }
            write!(f, "severity {:.3}", m.severity)?;
            if let Some(u) = &self.uncertainty {
                match floor {
                    Some(floor) => write!(f, " (not detectable below {floor:.3})")?,
                    None => write!(f, " ± {:.3}", u.severity_sigma(m))?,
                }
            }
            write!(f, "  {:.3} {}", m.value, m.unit())?;
            match m.mode {
                FaultMode::ShortCircuit => write!(f, " (phase {})", ['A', 'B', 'C'][m.phase as usize % 3])?,
                FaultMode::Eccentricity => write!(f, " (min gap at {:.0} deg)", self.eccentricity_phase_deg)?,
                _ => {}
            }
            writeln!(f)?;
        }
        if self.status.is_diagnosis() {
            write!(f, "  k =")?;
        } else {
            write!(f, "  k (not a diagnosis) =")?;
        }
        for k in &self.faults.0 {
            write!(f, " {k:.4}")?;
        }
        writeln!(f)?;
        if let Some(u) = &self.uncertainty {
            write!(f, "  sigma =")?;
            for s in &u.sigma {
                write!(f, " {s:.4}")?;
            }
            writeln!(f)?;
        }
        write!(
            f,
            "  fitness {:.4e} A^2, {} evaluations, {} iterations",
            self.fitness, self.evaluations, self.iterations
        )?;
        if let Some(c) = &self.fit_check {
            write!(
                f,
                "\n  fit test: z {:.1} (limit {FIT_TEST_Z}), {:.0} effective samples, noise {:.4e} A^2",
                c.z, c.effective_samples, c.expected_a2
            )?;
            if c.window_z > f32::NEG_INFINITY || c.window_z.is_nan() {
                write!(f, "; worst window {} z {:.1} (limit {:.2})", c.window, c.window_z, c.window_limit)?;
            }
        }
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
mod tests;
