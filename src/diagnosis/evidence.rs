//! Evidence over flights: per fault mode, a log-likelihood ratio from each flight, summed over
//! flights by a sequential test, so that a fault too small to pay the information criterion in
//! one flight is found after a few (`docs/decisions/0020-evidence-over-flights.md`).
//!
//! **One flight** ([`flight_evidence`]). With Gaussian residuals of `n` effective samples
//! ([`EquivalentCurrentFit::effective_samples`], the count model selection uses), the log-likelihood ratio
//! of the diagnosis with mode `m` against the diagnosis without it is
//!
//! ```text
//! λ_m = (n/2)·ln(E_without / E_with)
//! ```
//!
//! - a mode in the diagnosis: `E_with` is the diagnosis' cost and `E_without` the cost with the
//!   mode's groups set back to healthy (one evaluation, no refit);
//! - a mode absent from it: `E_without` is the diagnosis' cost and `E_with` the least cost of the
//!   mode added to the diagnosis at a small severity, from a quadratic through probes on each
//!   direction of the mode (friction, backlash, gain: 2 probes each; each phase's short: 2;
//!   eccentricity: 5 probes for the quadratic in `ζ·(cos φ, sin φ)`). At most
//!   [`MAX_FLIGHT_EVALUATIONS`] = 18 evaluations per flight, the effective samples included.
//!
//! **Over flights** ([`Evidence::update`]): a CUSUM-type sum with a floor,
//!
//! ```text
//! S_F = max(S_{F−1} + λ_F − c_m, −h_m),   h_m = max(P_m − c_m, P_m/2),   P_m = (p_m/2)·ln n
//! ```
//!
//! `P_m` is model selection's price of the mode's `p_m` parameters (half the BIC's
//! `p_m·ln n`, since `λ` is half the BIC's `n·ln(E_without/E_with)`), and `c_m` ([`ALLOWANCE`])
//! the evidence a flight must bring to count: a flight of a healthy actuator brings `λ ≈ χ²_p/2`
//! (mean `p/2`) by fitting noise, and the allowance makes the sum drift down on those. The mode
//! is **present** when `S_F > h_m`; from `S_0 = 0` one flight decides exactly as the information
//! criterion, `λ_1 > P_m` (gain drift, whose allowance exceeds its price, asks for
//! `λ_1 > c_m + P_m/2`, [`threshold`]). It is **absent** when `S_F` sits on its floor `−h_m`,
//! **undecided** in between. The floor bounds the memory: a fault that appears after a long
//! healthy series is found within `2·h_m/(λ − c_m)` flights.
//!
//! The state to persist is [`Evidence`]: the five sums and the flight count.
//!
//! **Declaration** ([`record_flight`], the one path of the firmware and of `ema history`). A mode
//! the sum calls present while this flight's own diagnosis dropped it is *declared by pooled
//! evidence*: its parameters are refitted on this flight's recording with the other groups held
//! at the diagnosis ([`refit_mode`], at most [`MAX_REFIT_EVALUATIONS`] evaluations), and the
//! diagnosis with the refitted mode is what the health record keeps (the prior of the next warm
//! flight, the mode's history and trend). The refit needs only the current recording, so the
//! board holds one trace, not the flights since the onset
//! (`docs/decisions/0024-declaration-by-pooled-evidence.md`).

use super::config::{configured_fit, IdentifyConfig};
use super::groups::{group_present, without_group};
use super::identification::Identification;
use crate::conditioning::ConditionedWindow;
use crate::faults::FaultMode;
use crate::faults::{FaultGroup, FaultVector, FAULT_COUNT, MODE_COUNT};
use crate::fitness::EquivalentCurrentFit;
use crate::health::HealthReport;
use crate::persist::HealthRecord;
use crate::{Command, EmaParams};

/// Free parameters of each mode's alternative (`p_m`): one for each but eccentricity (magnitude and
/// phase). A short is one parameter: the best of the three phases.
pub const MODE_PARAMETERS: [usize; MODE_COUNT] = [1, 1, 1, 2, 1];

/// Probe step of each mode (normalized severity): friction 0.05 (×1.1 of nominal), backlash 0.02
/// (×3 of nominal), short 0.03 (1.5 % of the turns), eccentricity 0.08 (`ζ` = 0.04), gain 0.03.
pub const PROBE_STEP: [f32; MODE_COUNT] = [0.05, 0.02, 0.03, 0.08, 0.03];

/// Evidence a flight must bring for each mode to raise its sum (nats), `c_m`: one nat per
/// parameter, twice the mean `1/2` that fitting noise brings per free parameter; gain drift 8,
/// above the largest gain probe's `λ` on healthy flights with sensor noise (7.2 in 100; the
/// controller's noise is partly fitted by the loop gain), while a 3 % drift brings about 230
/// (`docs/decisions/0020-evidence-over-flights.md`).
pub const ALLOWANCE: [f32; MODE_COUNT] = [1.0, 1.0, 1.0, 2.0, 8.0];

/// Most evaluations [`flight_evidence`] spends: the effective samples, then friction 2,
/// backlash 2, shorts 6, eccentricity 5, gain 2 probes when every mode is absent.
pub const MAX_FLIGHT_EVALUATIONS: u32 = 18;

/// One flight's evidence per mode.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FlightEvidence {
    /// `λ_m` per mode, ≥ 0 (nats).
    pub llr: [f32; MODE_COUNT],
    /// The effective samples `n` of the diagnosis' residual.
    pub effective_samples: f32,
    /// Objective evaluations spent (at most [`MAX_FLIGHT_EVALUATIONS`]).
    pub evaluations: u32,
}

/// What the sequential test says of a mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Decision {
    /// The accumulated evidence passes the price: the fault is there.
    Present,
    /// The sum sits on its floor: the flights speak against the fault.
    Absent,
    /// Neither yet.
    Undecided,
}

impl Decision {
    /// `present`, `absent` or `undecided`.
    pub const fn label(self) -> &'static str {
        match self {
            Decision::Present => "present",
            Decision::Absent => "absent",
            Decision::Undecided => "undecided",
        }
    }
}

/// The accumulated evidence of a series of flights: what the health record persists.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Evidence {
    /// `S_F` per mode (nats), in the order of [`FaultMode::ALL`].
    pub llr: [f32; MODE_COUNT],
    /// Flights pooled since the last reset.
    pub flights: u32,
}

impl Default for Evidence {
    fn default() -> Self {
        Self::NONE
    }
}

/// The per-mode price `P_m = (p_m/2)·ln n` of model selection for `n` effective samples (0 when
/// `n ≤ 1`).
pub fn price(mode: FaultMode, effective_samples: f32) -> f32 {
    let p = MODE_PARAMETERS.get(mode.index()).copied().unwrap_or(1) as f32;
    if effective_samples > 1.0 {
        0.5 * p * libm::logf(effective_samples)
    } else {
        0.0
    }
}

/// The per-flight allowance `c_m` ([`ALLOWANCE`]).
pub fn allowance(mode: FaultMode) -> f32 {
    ALLOWANCE.get(mode.index()).copied().unwrap_or(1.0)
}

/// The threshold `h_m = max(P_m − c_m, P_m/2)` of the sum (module doc): `P_m − c_m` makes one
/// flight decide as the information criterion; the floor `P_m/2` keeps a mode whose allowance
/// nears or exceeds its price (gain drift) from being declared on one flight's small excess.
pub fn threshold(mode: FaultMode, effective_samples: f32) -> f32 {
    let p = price(mode, effective_samples);
    let h = p - allowance(mode);
    if h > 0.5 * p {
        h
    } else {
        0.5 * p
    }
}

impl Evidence {
    /// No flight yet (after maintenance).
    pub const NONE: Self = Self { llr: [0.0; MODE_COUNT], flights: 0 };

    /// Adds one flight: `S = max(S + λ − c, −h)` per mode, `h` from the flight's effective samples.
    /// A non-finite `λ` counts as 0.
    pub fn update(&mut self, flight: &FlightEvidence) {
        for (m, (s, &l)) in FaultMode::ALL.into_iter().zip(self.llr.iter_mut().zip(&flight.llr)) {
            let l = if l.is_finite() { l } else { 0.0 };
            let floor = -threshold(m, flight.effective_samples);
            let next = *s + l - allowance(m);
            *s = if next > floor { next } else { floor };
        }
        self.flights = self.flights.saturating_add(1);
    }

    /// The decision per mode with the price of `effective_samples` (the last flight's).
    pub fn decisions(&self, effective_samples: f32) -> [Decision; MODE_COUNT] {
        FaultMode::ALL.map(|m| {
            let h = threshold(m, effective_samples);
            let s = self.llr.get(m.index()).copied().unwrap_or(0.0);
            if s > h {
                Decision::Present
            } else if s <= -h {
                Decision::Absent
            } else {
                Decision::Undecided
            }
        })
    }

    /// Runs [`flight_evidence`] on a finished identification and adds the flight. A report that is
    /// no diagnosis (INCONCLUSIVE, SENSOR_FAULT) adds nothing: `None`.
    pub fn observe<const W: usize, const P: usize>(
        &mut self,
        identification: &Identification<'_, W, P>,
    ) -> Option<FlightEvidence> {
        let report = identification.report();
        if !report.status.is_diagnosis() {
            return None;
        }
        let flight = flight_evidence(identification.fitness(), &report.faults, report.fitness, &mut || {});
        self.update(&flight);
        Some(flight)
    }
}

/// The groups of `mode` ([`FaultMode::groups`]), in the order of [`FaultGroup::ALL`].
fn mode_groups(mode: FaultMode) -> impl Iterator<Item = FaultGroup> + Clone {
    let (first, last) = mode.groups();
    FaultGroup::ALL.into_iter().filter(move |g| (first.index()..=last.index()).contains(&g.index()))
}

/// `true` when one of `mode`'s fault groups is present in `k` (a diagnosis' decision on it).
pub fn mode_present(k: &FaultVector, mode: FaultMode) -> bool {
    mode_groups(mode).any(|group| group_present(&k.0, group))
}

/// `(n/2)·ln(without/with)`, ≥ 0 (0 when either cost is not positive and finite).
fn llr(effective_samples: f32, with: f32, without: f32) -> f32 {
    if !(with > 0.0 && with.is_finite() && without.is_finite() && without > with) {
        return 0.0;
    }
    0.5 * effective_samples * libm::logf(without / with)
}

/// The least of a one-dimensional quadratic through `E(0) = e0`, `E(a) = ea`, `E(b) = eb`
/// (`a ≠ b`, both ≠ 0) over `[lo, hi]`, and never above the three values.
fn quadratic_min(e0: f32, (a, ea): (f32, f32), (b, eb): (f32, f32), lo: f32, hi: f32) -> f32 {
    let measured = e0.min(ea).min(eb);
    // E(s) = e0 + g·s + q·s²: solve the two equations
    let det = a * b * (b - a);
    if det == 0.0 {
        return measured;
    }
    let g = ((ea - e0) * b * b - (eb - e0) * a * a) / det;
    let q = ((eb - e0) * a - (ea - e0) * b) / det;
    if q.is_nan() || q <= 0.0 {
        return measured;
    }
    // max/min, not clamp: no panic path for bounds the optimizer cannot order
    let s = (-g / (2.0 * q)).max(lo).min(hi);
    let e = e0 + g * s + q * s * s;
    if e.is_finite() && e < measured {
        e
    } else {
        measured
    }
}

/// One flight's evidence per mode (module doc) from the fitness `fit` the diagnosis `k` of cost
/// `cost` was fitted on: at most [`MAX_FLIGHT_EVALUATIONS`] evaluations, `between_runs` called
/// before each (a firmware feeds its watchdog there).
pub fn flight_evidence<const W: usize>(
    fit: &EquivalentCurrentFit<'_, W>,
    k: &FaultVector,
    cost: f32,
    between_runs: &mut impl FnMut(),
) -> FlightEvidence {
    between_runs();
    let n = fit.effective_samples(k);
    let mut evaluations = 1u32;
    let mut eval = |x: &[f32; FAULT_COUNT]| {
        between_runs();
        evaluations += 1;
        fit.error(&FaultVector(*x))
    };
    let mut out = [0.0f32; MODE_COUNT];
    for (m, lambda) in FaultMode::ALL.into_iter().zip(out.iter_mut()) {
        let groups = mode_groups(m);
        let mut without = k.0;
        let mut present = false;
        for g in groups.clone() {
            if group_present(&k.0, g) {
                without = without_group(&without, g);
                present = true;
            }
        }
        let step = PROBE_STEP.get(m.index()).copied().unwrap_or(0.05);
        *lambda = if present {
            llr(n, cost, eval(&without))
        } else {
            let best = match m {
                // eccentricity: the quadratic in v = ζ·(cos φ, sin φ)
                FaultMode::Eccentricity => eccentricity_probe(&mut eval, &k.0, cost, step),
                // gain drift: both directions around the diagnosis' gain
                FaultMode::GainDrift => {
                    let g = k.0[7];
                    let at = |s: f32| {
                        let mut x = k.0;
                        x[7] = (g + s).clamp(0.0, 1.0);
                        x
                    };
                    let (lo, hi) = (-step, step);
                    let (e_lo, e_hi) = (eval(&at(lo)), eval(&at(hi)));
                    quadratic_min(cost, (lo, e_lo), (hi, e_hi), -2.0 * step, 2.0 * step)
                }
                // one-sided severities: friction, backlash, each phase's short
                _ => {
                    let mut best = cost;
                    for group in groups {
                        let (first, _) = group.params();
                        let at = |s: f32| with_parameter(&k.0, first, s);
                        let (e1, e2) = (eval(&at(step)), eval(&at(2.0 * step)));
                        best = best.min(quadratic_min(cost, (step, e1), (2.0 * step, e2), 0.0, 3.0 * step));
                    }
                    best
                }
            };
            llr(n, best, cost)
        };
    }
    FlightEvidence { llr: out, effective_samples: n, evaluations }
}

/// The least cost of an eccentricity added to `k` (absent in it) from a quadratic in
/// `v = ζ·(cos φ, sin φ)` through five probes of magnitude `step` (the two axes both ways and
/// the diagonal), `|v|` at most `3·step`; never above the probes' or `cost`.
fn eccentricity_probe(
    eval: &mut impl FnMut(&[f32; FAULT_COUNT]) -> f32,
    k: &[f32; FAULT_COUNT],
    cost: f32,
    step: f32,
) -> f32 {
    // φ = 2π·k7 − π: φ = 0 at k7 = 0.5, π/2 at 0.75, −π/2 at 0.25, π at 1.0, π/4 at 0.625
    let mut at = |magnitude: f32, phase: f32| {
        let mut x = *k;
        x[5] = magnitude;
        x[6] = phase;
        eval(&x)
    };
    let (px, mx, py, my) = (at(step, 0.5), at(step, 1.0), at(step, 0.75), at(step, 0.25));
    let diagonal = at(step, 0.625);
    let measured = cost.min(px).min(mx).min(py).min(my).min(diagonal);
    let d2 = step * step;
    let (gx, gy) = ((px - mx) / (2.0 * step), (py - my) / (2.0 * step));
    let (hxx, hyy) = ((px + mx - 2.0 * cost) / (2.0 * d2), (py + my - 2.0 * cost) / (2.0 * d2));
    let d = step * core::f32::consts::FRAC_1_SQRT_2;
    let hxy = ((diagonal - cost - (gx + gy) * d) / (d * d) - hxx - hyy) / 2.0;
    let det = hxx * hyy - hxy * hxy;
    if !(hxx > 0.0 && det > 0.0) {
        return measured;
    }
    // minimum of E0 + g·v + vᵀHv: v = −H⁻¹g/2
    let (mut vx, mut vy) = (-(hyy * gx - hxy * gy) / (2.0 * det), -(hxx * gy - hxy * gx) / (2.0 * det));
    let r = libm::sqrtf(vx * vx + vy * vy);
    let limit = 3.0 * step;
    if r > limit {
        (vx, vy) = (vx * limit / r, vy * limit / r);
    }
    let e = cost + gx * vx + gy * vy + hxx * vx * vx + 2.0 * hxy * vx * vy + hyy * vy * vy;
    if e.is_finite() && e < measured {
        e
    } else {
        measured
    }
}

/// Most evaluations [`refit_mode`] spends on one declared mode.
pub const MAX_REFIT_EVALUATIONS: u32 = 32;

/// Evaluations of each golden-section search of [`refit_mode`].
pub const GOLDEN_EVALUATIONS: u32 = 14;

/// Width of each refit's search, in probe steps ([`PROBE_STEP`]): severities up to 8 steps
/// (friction 0.4, backlash 0.16, short 0.24, eccentricity 0.64; gain ±0.24 about the diagnosis),
/// well beyond what a single flight fails to price.
pub const REFIT_SPAN_STEPS: f32 = 8.0;

/// One flight through the evidence pooled over flights ([`record_flight`]).
#[derive(Clone, Copy, Debug)]
pub struct PooledFlight {
    /// The flight's evidence per mode.
    pub flight: FlightEvidence,
    /// The accumulated evidence after the flight (what the record now holds).
    pub evidence: Evidence,
    /// Per mode: present by the accumulated evidence while absent from the flight's own diagnosis.
    pub declared: [bool; MODE_COUNT],
    /// The report the record keeps: the flight's own, with each declared mode refitted in.
    pub report: HealthReport,
    /// Evaluations of the refits.
    pub refit_evaluations: u32,
}

impl PooledFlight {
    /// `true` when a mode is declared by pooled evidence.
    pub fn any_declared(&self) -> bool {
        self.declared.iter().any(|&d| d)
    }
}

/// Adds one flight to `record`, the one path of the firmware and of `ema history`: for a
/// diagnosis, its evidence on `fit` (the fitness `report` was fitted on) joins the record's
/// accumulators ([`Evidence::update`]); each mode the accumulators call present and the
/// diagnosis lacks is declared and refitted ([`refit_mode`]); the report with the refitted
/// modes ([`HealthReport::new`] of the new vector, the flight's fit check, acquisition counts and
/// uncertainty kept) becomes the record's flight ([`HealthRecord::new_flight`]). A report that is
/// no diagnosis, or no fitness, adds the flight as it is and no evidence: `None`.
/// `between_runs` is called before each model run (a firmware feeds its watchdog there: the
/// flight's evidence takes up to [`MAX_FLIGHT_EVALUATIONS`] runs, each declared mode's refit up
/// to [`MAX_REFIT_EVALUATIONS`]).
pub fn record_flight<const W: usize>(
    record: &mut HealthRecord,
    fit: Option<&EquivalentCurrentFit<'_, W>>,
    params: &EmaParams,
    report: &HealthReport,
    cold: bool,
    between_runs: &mut impl FnMut(),
) -> Option<PooledFlight> {
    let Some(fit) = fit.filter(|_| report.status.is_diagnosis()) else {
        record.new_flight(report, cold);
        return None;
    };
    let mut evidence = Evidence { llr: *record.evidence(), flights: record.pooled_flights() };
    let flight = flight_evidence(fit, &report.faults, report.fitness, between_runs);
    evidence.update(&flight);
    record.set_evidence(evidence.llr, evidence.flights);
    let decisions = evidence.decisions(flight.effective_samples);
    let mut declared = [false; MODE_COUNT];
    let (mut k, mut cost, mut refit_evaluations) = (report.faults, report.fitness, 0u32);
    for (m, (d, decision)) in FaultMode::ALL.into_iter().zip(declared.iter_mut().zip(decisions)) {
        if decision == Decision::Present && !mode_present(&report.faults, m) {
            *d = true;
            let (refit, e, n) = refit_mode(fit, &k, cost, m, between_runs);
            refit_evaluations += n;
            if e < cost {
                (k, cost) = (refit, e);
            }
        }
    }
    let pooled = if k == report.faults {
        *report
    } else {
        let r = HealthReport::new(k, params, cost, report.evaluations, report.iterations, report.termination);
        HealthReport {
            fit_check: report.fit_check,
            refused_frames: report.refused_frames,
            uncertainty: report.uncertainty,
            untested_groups: report.untested_groups,
            ..r
        }
    };
    record.new_flight(&pooled, cold);
    Some(PooledFlight { flight, evidence, declared, report: pooled, refit_evaluations })
}

/// [`record_flight`] for a caller that no longer holds the identification (the firmware, which
/// keeps these evaluations out of the identification's instruction count): the fitness of
/// `trace` under `command` with `config`'s effects and fast-regime weight is built again, as
/// [`super::with_uncertainty`] builds it. A fitness the configuration refuses adds the flight
/// without evidence.
#[allow(clippy::too_many_arguments, reason = "record_flight's, with the fitness's three parts")]
pub fn record_flight_on<'a, const W: usize>(
    record: &mut HealthRecord,
    trace: &'a ConditionedWindow<W>,
    params: EmaParams,
    command: impl Into<Command<'a>>,
    config: &IdentifyConfig,
    report: &HealthReport,
    cold: bool,
    between_runs: &mut impl FnMut(),
) -> Option<PooledFlight> {
    between_runs();
    let fit = configured_fit(trace, params, command, config).ok();
    record_flight(record, fit.as_ref(), &params, report, cold, between_runs)
}

/// `k` with parameter `i` set to `value` (`k` unchanged when `i` is out of range).
fn with_parameter(k: &[f32; FAULT_COUNT], i: usize, value: f32) -> [f32; FAULT_COUNT] {
    let mut x = *k;
    if let Some(v) = x.get_mut(i) {
        *v = value;
    }
    x
}

/// The least of `f` over `[lo, hi]` by golden-section search in `evaluations` evaluations (at
/// least 2): the point and its value.
fn golden(f: &mut impl FnMut(f32) -> f32, lo: f32, hi: f32, evaluations: u32) -> (f32, f32) {
    const R: f32 = 0.618_034;
    let (mut a, mut b) = (lo, hi);
    let (mut x1, mut x2) = (b - R * (b - a), a + R * (b - a));
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 2..evaluations {
        if f1 <= f2 {
            (b, x2, f2) = (x2, x1, f1);
            x1 = b - R * (b - a);
            f1 = f(x1);
        } else {
            (a, x1, f1) = (x1, x2, f2);
            x2 = a + R * (b - a);
            f2 = f(x2);
        }
    }
    if f1 <= f2 {
        (x1, f1)
    } else {
        (x2, f2)
    }
}

/// Refits mode `mode` into `k` (cost `cost`) on `fit`, the other groups held: friction,
/// backlash and gain by a golden-section search of the severity over [`REFIT_SPAN_STEPS`] probe
/// steps; a short on the phase whose probe at one step costs least, then as friction; an
/// eccentricity along the direction of least cost of the five-probe quadratic in
/// `ζ·(cos φ, sin φ)` ([`flight_evidence`]'s), then its magnitude and phase in turn. The vector,
/// its cost and the evaluations spent (at most [`MAX_REFIT_EVALUATIONS`]); `k` and `cost` when
/// nothing lowers the cost. `between_runs` is called before each evaluation.
pub fn refit_mode<const W: usize>(
    fit: &EquivalentCurrentFit<'_, W>,
    k: &FaultVector,
    cost: f32,
    mode: FaultMode,
    between_runs: &mut impl FnMut(),
) -> (FaultVector, f32, u32) {
    let mut evaluations = 0u32;
    let mut eval = |x: &[f32; FAULT_COUNT]| {
        between_runs();
        evaluations += 1;
        fit.error(&FaultVector(*x))
    };
    let step = PROBE_STEP.get(mode.index()).copied().unwrap_or(0.05);
    let span = REFIT_SPAN_STEPS * step;
    let base = k.0;
    let severity = |eval: &mut dyn FnMut(&[f32; FAULT_COUNT]) -> f32, i: usize, lo: f32, hi: f32| {
        let (s, e) = golden(&mut |s| eval(&with_parameter(&base, i, s)), lo, hi, GOLDEN_EVALUATIONS);
        (with_parameter(&base, i, s), e)
    };
    let (x, e) = match mode {
        FaultMode::Friction | FaultMode::Backlash => {
            severity(&mut eval, mode.groups().0.severity_param().index(), 0.0, span)
        }
        FaultMode::ShortCircuit => {
            // the phase whose probe at one step costs least
            let mut phase = 2;
            let mut least = f32::INFINITY;
            for i in 2..5 {
                let e = eval(&with_parameter(&base, i, step));
                if e < least {
                    (phase, least) = (i, e);
                }
            }
            severity(&mut eval, phase, 0.0, span)
        }
        FaultMode::Eccentricity => refit_eccentricity(&mut eval, &base, cost, step, span),
        FaultMode::GainDrift => {
            let g = base[7];
            severity(&mut eval, 7, (g - span).max(0.0), (g + span).min(1.0))
        }
    };
    if e.is_finite() && e < cost {
        (FaultVector(x), e, evaluations)
    } else {
        (*k, cost, evaluations)
    }
}

/// The eccentricity of [`refit_mode`]: the direction of the five-probe quadratic's least
/// (the probe of least cost when the quadratic has no minimum), the magnitude along it over
/// `[0, span]`, then the phase over a quarter turn about it.
fn refit_eccentricity(
    eval: &mut dyn FnMut(&[f32; FAULT_COUNT]) -> f32,
    k: &[f32; FAULT_COUNT],
    cost: f32,
    step: f32,
    span: f32,
) -> ([f32; FAULT_COUNT], f32) {
    let at = |magnitude: f32, phase: f32| {
        let mut x = *k;
        x[5] = magnitude;
        x[6] = phase;
        x
    };
    let phases = [0.5, 1.0, 0.75, 0.25, 0.625];
    let e: [f32; 5] = core::array::from_fn(|i| eval(&at(step, phases.get(i).copied().unwrap_or(0.5))));
    let [px, mx, py, my, diagonal] = e;
    let (gx, gy) = ((px - mx) / (2.0 * step), (py - my) / (2.0 * step));
    let d2 = step * step;
    let (hxx, hyy) = ((px + mx - 2.0 * cost) / (2.0 * d2), (py + my - 2.0 * cost) / (2.0 * d2));
    let d = step * core::f32::consts::FRAC_1_SQRT_2;
    let hxy = ((diagonal - cost - (gx + gy) * d) / (d * d) - hxx - hyy) / 2.0;
    let det = hxx * hyy - hxy * hxy;
    let mut phase = 0.5;
    let mut least = f32::INFINITY;
    for (&p, &v) in phases.iter().zip(&e) {
        if v < least {
            (phase, least) = (p, v);
        }
    }
    if hxx > 0.0 && det > 0.0 {
        let (vx, vy) = (-(hyy * gx - hxy * gy) / (2.0 * det), -(hxx * gy - hxy * gx) / (2.0 * det));
        if vx.is_finite() && vy.is_finite() && (vx != 0.0 || vy != 0.0) {
            // φ = 2π·k7 − π
            phase = (libm::atan2f(vy, vx) + core::f32::consts::PI) / (2.0 * core::f32::consts::PI);
        }
    }
    let (magnitude, _) = golden(&mut |s| eval(&at(s, phase)), 0.0, span, GOLDEN_EVALUATIONS);
    let wrap = |p: f32| p - libm::floorf(p);
    let (offset, e) = golden(
        &mut |o| eval(&at(magnitude, wrap(phase + o))),
        -0.125,
        0.125,
        MAX_REFIT_EVALUATIONS - 5 - GOLDEN_EVALUATIONS,
    );
    (at(magnitude, wrap(phase + offset)), e)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_flight_decides_as_the_information_criterion() {
        let n = 800.0;
        for m in FaultMode::ALL {
            let p = price(m, n);
            assert!((p - 0.5 * MODE_PARAMETERS[m.index()] as f32 * libm::logf(n)).abs() < 1e-6);
            // the one-flight threshold: the price, or c + P/2 when the allowance nears the price
            let p = (allowance(m) + threshold(m, n)).max(p);
            for (l, expected) in [(p * 1.01, Decision::Present), (p * 0.99, Decision::Undecided)] {
                let mut e = Evidence::NONE;
                let mut llr = [0.0; MODE_COUNT];
                llr[m.index()] = l;
                e.update(&FlightEvidence { llr, effective_samples: n, evaluations: 1 });
                assert_eq!(e.decisions(n)[m.index()], expected, "{m:?}, λ {l}, price {p}");
            }
        }
    }

    #[test]
    fn small_evidence_adds_up_and_noise_sinks_to_the_floor() {
        let n = 800.0;
        let h = threshold(FaultMode::Friction, n);
        // 2 nats a flight: below the price alone (3.3), present after a few flights
        let mut e = Evidence::NONE;
        let mut flights = 0;
        while e.decisions(n)[0] != Decision::Present {
            let mut llr = [0.0; MODE_COUNT];
            llr[0] = 2.0;
            e.update(&FlightEvidence { llr, effective_samples: n, evaluations: 1 });
            flights += 1;
            assert!(flights < 10);
        }
        assert!(flights > 1, "{flights}");
        // noise: 0.5 nat a flight sinks to the floor, and stays there
        let mut e = Evidence::NONE;
        for _ in 0..50 {
            e.update(&FlightEvidence { llr: [0.5; MODE_COUNT], effective_samples: n, evaluations: 1 });
        }
        assert_eq!(e.llr[0], -h);
        assert_eq!(e.decisions(n)[0], Decision::Absent);
        assert_eq!(e.flights, 50);
    }

    #[test]
    fn the_quadratic_finds_the_least_cost() {
        // E(s) = 1 + (s − 0.05)²: least 1 at 0.05
        let e = |s: f32| 1.0 + (s - 0.05) * (s - 0.05);
        let m = quadratic_min(e(0.0), (0.03, e(0.03)), (0.06, e(0.06)), 0.0, 0.09);
        assert!((m - 1.0).abs() < 1e-5, "{m}");
        // concave: the least measured value
        let m = quadratic_min(1.0, (0.03, 0.99), (0.06, 0.9), 0.0, 0.09);
        assert_eq!(m, 0.9);
    }

    #[test]
    fn golden_section_finds_the_least_of_a_unimodal_function() {
        let mut calls = 0;
        let (x, e) = golden(
            &mut |s: f32| {
                calls += 1;
                1.0 + (s - 0.13) * (s - 0.13)
            },
            0.0,
            0.64,
            GOLDEN_EVALUATIONS,
        );
        assert_eq!(calls, GOLDEN_EVALUATIONS);
        assert!((x - 0.13).abs() < 0.01 && (e - 1.0).abs() < 1e-4, "{x} {e}");
    }

    #[test]
    fn the_eccentricity_quadratic_finds_a_phase_between_the_probes() {
        // E(v) = 1 + |v − v0|² with v0 at ζ 0.1, φ = 1 rad
        let v0 = (0.1 * libm::cosf(1.0), 0.1 * libm::sinf(1.0));
        let mut eval = |x: &[f32; FAULT_COUNT]| {
            let phi = 2.0 * core::f32::consts::PI * x[6] - core::f32::consts::PI;
            let (vx, vy) = (x[5] * libm::cosf(phi), x[5] * libm::sinf(phi));
            1.0 + (vx - v0.0) * (vx - v0.0) + (vy - v0.1) * (vy - v0.1)
        };
        let cost = 1.0 + 0.01;
        let e = eccentricity_probe(&mut eval, &FaultVector::HEALTHY.0, cost, 0.08);
        assert!((e - 1.0).abs() < 1e-4, "{e}");
    }
}
