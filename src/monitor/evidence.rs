//! Evidence over flights: per fault mode, a log-likelihood ratio from each flight, summed over
//! flights by a sequential test, so that a fault too small to pay the information criterion in
//! one flight is found after a few (`docs/decisions/0020-evidence-over-flights.md`).
//!
//! **One flight** ([`flight_evidence`]). With Gaussian residuals of `n` effective samples
//! ([`CurrentFit::effective_samples`], the count model selection uses), the log-likelihood ratio
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

use super::identification::Identification;
use super::selection::{group_present, without_group, FAULT_GROUPS};
use crate::faults::{FaultVector, FAULT_COUNT};
use crate::fitness::CurrentFit;
use crate::health::FaultMode;

/// Fault modes with an accumulator: friction, backlash, short circuit, eccentricity, gain drift
/// (the order of [`FaultMode::ALL`]).
pub const EVIDENCE_MODES: usize = 5;

/// Free parameters of each mode's alternative (`p_m`): one for each but eccentricity (magnitude and
/// phase). A short is one parameter: the best of the three phases.
pub const MODE_PARAMETERS: [usize; EVIDENCE_MODES] = [1, 1, 1, 2, 1];

/// The groups of [`FAULT_GROUPS`] that make up each mode, as a range of group indices.
const MODE_GROUPS: [(usize, usize); EVIDENCE_MODES] = [(0, 0), (1, 1), (2, 4), (5, 5), (6, 6)];

/// Probe step of each mode (normalized severity): friction 0.05 (×1.1 of nominal), backlash 0.02
/// (×3 of nominal), short 0.03 (1.5 % of the turns), eccentricity 0.08 (`ζ` = 0.04), gain 0.03.
pub const PROBE_STEP: [f32; EVIDENCE_MODES] = [0.05, 0.02, 0.03, 0.08, 0.03];

/// Evidence a flight must bring for each mode to raise its sum (nats), `c_m`: one nat per
/// parameter, twice the mean `1/2` that fitting noise brings per free parameter; gain drift 8,
/// above the largest gain probe's `λ` on healthy flights with sensor noise (7.2 in 100; the
/// controller's noise is partly fitted by the loop gain), while a 3 % drift brings about 230
/// (`docs/decisions/0020-evidence-over-flights.md`).
pub const ALLOWANCE: [f32; EVIDENCE_MODES] = [1.0, 1.0, 1.0, 2.0, 8.0];

/// Most evaluations [`flight_evidence`] spends: the effective samples, then friction 2,
/// backlash 2, shorts 6, eccentricity 5, gain 2 probes when every mode is absent.
pub const MAX_FLIGHT_EVALUATIONS: u32 = 18;

/// One flight's evidence per mode.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FlightEvidence {
    /// `λ_m` per mode, ≥ 0 (nats).
    pub llr: [f32; EVIDENCE_MODES],
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
    pub llr: [f32; EVIDENCE_MODES],
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
pub fn price(mode: usize, effective_samples: f32) -> f32 {
    let p = MODE_PARAMETERS.get(mode).copied().unwrap_or(1) as f32;
    if effective_samples > 1.0 {
        0.5 * p * libm::logf(effective_samples)
    } else {
        0.0
    }
}

/// The per-flight allowance `c_m` ([`ALLOWANCE`]).
pub fn allowance(mode: usize) -> f32 {
    ALLOWANCE.get(mode).copied().unwrap_or(1.0)
}

/// The threshold `h_m = max(P_m − c_m, P_m/2)` of the sum (module doc): `P_m − c_m` makes one
/// flight decide as the information criterion; the floor `P_m/2` keeps a mode whose allowance
/// nears or exceeds its price (gain drift) from being declared on one flight's small excess.
pub fn threshold(mode: usize, effective_samples: f32) -> f32 {
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
    pub const NONE: Self = Self { llr: [0.0; EVIDENCE_MODES], flights: 0 };

    /// Adds one flight: `S = max(S + λ − c, −h)` per mode, `h` from the flight's effective samples.
    /// A non-finite `λ` counts as 0.
    pub fn update(&mut self, flight: &FlightEvidence) {
        for (m, (s, &l)) in self.llr.iter_mut().zip(&flight.llr).enumerate() {
            let l = if l.is_finite() { l } else { 0.0 };
            let floor = -threshold(m, flight.effective_samples);
            let next = *s + l - allowance(m);
            *s = if next > floor { next } else { floor };
        }
        self.flights = self.flights.saturating_add(1);
    }

    /// The decision per mode with the price of `effective_samples` (the last flight's).
    pub fn decisions(&self, effective_samples: f32) -> [Decision; EVIDENCE_MODES] {
        core::array::from_fn(|m| {
            let h = threshold(m, effective_samples);
            let s = self.llr.get(m).copied().unwrap_or(0.0);
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
        let flight = flight_evidence(identification.fitness(), &report.faults, report.fitness);
        self.update(&flight);
        Some(flight)
    }
}

/// The mode's name ([`FaultMode::name`]) by accumulator index.
pub fn mode_name(mode: usize) -> &'static str {
    FaultMode::ALL.get(mode).map_or("?", |m| m.name())
}

/// `true` when one of mode `mode`'s fault groups is present in `k` (a diagnosis' decision on it).
pub fn mode_present(k: &FaultVector, mode: usize) -> bool {
    MODE_GROUPS.get(mode).is_some_and(|&(first, last)| {
        FAULT_GROUPS.iter().enumerate().any(|(g, &group)| (first..=last).contains(&g) && group_present(&k.0, group))
    })
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
    let s = (-g / (2.0 * q)).clamp(lo, hi);
    let e = e0 + g * s + q * s * s;
    if e.is_finite() && e < measured {
        e
    } else {
        measured
    }
}

/// One flight's evidence per mode (module doc) from the fitness `fit` the diagnosis `k` of cost
/// `cost` was fitted on: at most [`MAX_FLIGHT_EVALUATIONS`] evaluations.
pub fn flight_evidence<const W: usize>(fit: &CurrentFit<'_, W>, k: &FaultVector, cost: f32) -> FlightEvidence {
    let n = fit.effective_samples(k);
    let mut evaluations = 1u32;
    let mut eval = |x: &[f32; FAULT_COUNT]| {
        evaluations += 1;
        fit.error(&FaultVector(*x))
    };
    let mut out = [0.0f32; EVIDENCE_MODES];
    for (m, (&(first, last), lambda)) in MODE_GROUPS.iter().zip(out.iter_mut()).enumerate() {
        let groups = FAULT_GROUPS.iter().enumerate().filter(|(g, _)| (first..=last).contains(g)).map(|(_, &g)| g);
        let mut without = k.0;
        let mut present = false;
        for g in groups.clone() {
            if group_present(&k.0, g) {
                without = without_group(&without, g);
                present = true;
            }
        }
        let step = PROBE_STEP.get(m).copied().unwrap_or(0.05);
        *lambda = if present {
            llr(n, cost, eval(&without))
        } else {
            let best = match m {
                // eccentricity: the quadratic in v = ζ·(cos φ, sin φ)
                3 => eccentricity_probe(&mut eval, &k.0, cost, step),
                // gain drift: both directions around the diagnosis' gain
                4 => {
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
                    for (first, _) in groups {
                        let at = |s: f32| {
                            let mut x = k.0;
                            x[first] = s;
                            x
                        };
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_flight_decides_as_the_information_criterion() {
        let n = 800.0;
        for m in 0..EVIDENCE_MODES {
            let p = price(m, n);
            assert!((p - 0.5 * MODE_PARAMETERS[m] as f32 * libm::logf(n)).abs() < 1e-6);
            // the one-flight threshold: the price, or c + P/2 when the allowance nears the price
            let p = (allowance(m) + threshold(m, n)).max(p);
            for (l, expected) in [(p * 1.01, Decision::Present), (p * 0.99, Decision::Undecided)] {
                let mut e = Evidence::NONE;
                let mut llr = [0.0; EVIDENCE_MODES];
                llr[m] = l;
                e.update(&FlightEvidence { llr, effective_samples: n, evaluations: 1 });
                assert_eq!(e.decisions(n)[m], expected, "mode {m}, λ {l}, price {p}");
            }
        }
    }

    #[test]
    fn small_evidence_adds_up_and_noise_sinks_to_the_floor() {
        let n = 800.0;
        let h = threshold(0, n);
        // 2 nats a flight: below the price alone (3.3), present after a few flights
        let mut e = Evidence::NONE;
        let mut flights = 0;
        while e.decisions(n)[0] != Decision::Present {
            let mut llr = [0.0; EVIDENCE_MODES];
            llr[0] = 2.0;
            e.update(&FlightEvidence { llr, effective_samples: n, evaluations: 1 });
            flights += 1;
            assert!(flights < 10);
        }
        assert!(flights > 1, "{flights}");
        // noise: 0.5 nat a flight sinks to the floor, and stays there
        let mut e = Evidence::NONE;
        for _ in 0..50 {
            e.update(&FlightEvidence { llr: [0.5; EVIDENCE_MODES], effective_samples: n, evaluations: 1 });
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
