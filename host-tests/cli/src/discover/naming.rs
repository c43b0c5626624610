//! Step 3, name: one search round fits every library effect not yet on with the faults on the fit
//! part and scores it on the held-out part against the best fit without a new effect; the naming
//! rules decide whether its winner is named (`docs/decisions/0009-effect-naming-rules.md`).

use ema_monitor::conditioning::ConditionedWindow;
use ema_monitor::{Command, EffectId, EmaParams, ModelEffects};
use indicatif::ProgressBar;
use rayon::prelude::*;
use serde::Serialize;

use super::fitting::{fault_parameter_count, fit_model, parameter_count, ModelFit, Part, PartFit, MIN_SEVERITY};
use super::residual::{series, structural_energy, NOISE_FLOOR_A};

/// Held-out ΔBIC above which an effect may be named (Kass & Raftery 1995: > 10 is very strong).
pub const BIC_STRONG: f64 = 10.0;
/// In-sample ΔBIC it must also reach (Kass & Raftery: > 6 is strong); the held-out part, which
/// the fit never saw, carries the decisive evidence.
pub const BIC_FIT_STRONG: f64 = 6.0;
/// Share of the structural residual energy an effect that replaces faults must remove to be
/// named. Such an effect wins the information criterion by parsimony (fewer parameters for the
/// same fit), which a wrong effect can do too: a compliant transmission, outside the library, can
/// pass for a hot winding that replaces a short and an eccentricity while removing next to
/// nothing of the gap. Correct namings that replace faults remove 12 % or more over the tests'
/// and `scripts/discover-matrix`'s recordings, wrong ones at most 2.1 %; 5 % sits between, a
/// factor 2.5 from each (`docs/decisions/0009-effect-naming-rules.md`).
///
/// An effect that does not replace faults needs only a positive share: the gap on the standard
/// manoeuvre is mostly the model's floor (sensor noise and known mismatch,
/// [`CLEAN_FLOOR_A`](super::residual::CLEAN_FLOOR_A)), and a hidden cogging at severity 1, fitted at
/// 0.95–0.97 with a held-out ΔBIC of 18–28, removes 2–8 % of it.
pub const MIN_GAP_SHARE_REPLACING: f64 = 0.05;
/// Share of the gap above the sensor noise ([`Candidate::above_noise_share`]) an effect must
/// close to be named: the materiality test. The held-out ΔBIC says an effect is *supported*; with
/// thousands of samples a term that removes a sliver of a large residual can carry strong
/// evidence and still explain nothing of what is wrong (a compliant transmission, outside the
/// library, read as a hot winding at severity 0.02 that removes 5 % of the gap). Noise sets the
/// scale: only the energy above [`NOISE_FLOOR_A`] is a gap any model can close.
///
/// Every correct naming over `scripts/discover-matrix`'s recordings removes 62 % or more of it
/// (cogging, the weakest, 62–64 %; the others 90 % and more); 25 % sits a factor 2.5 below
/// (`docs/decisions/0009-effect-naming-rules.md`).
pub const MIN_ABOVE_NOISE_SHARE: f64 = 0.25;
/// Held-out ΔBIC an effect that replaces faults must carry *at its own fault vector*
/// ([`Candidate::bic_own_held_out`]: the fit against itself with the effect switched off). Its
/// held-out evidence against the reference may come from the faults alone: a round's reference
/// can keep spurious fault parameters that any refit from other starts drops, and an effect that
/// "replaces" them then shows a large held-out ΔBIC although the same fit with the effect off is
/// as good. Same bar as [`BIC_STRONG`].
pub const BIC_OWN_STRONG: f64 = BIC_STRONG;
/// A fitted severity at or above this sits at the fit's bound
/// ([`MAX_SEVERITY`](ema_monitor::effects::MAX_SEVERITY), a quarter beyond the library's
/// documented maximum): the effect behind the residual is stronger than, or different from, the
/// library's (a DC-link sag fits as dead time at its bound), so it is not named. The bound lies
/// beyond the maximum so that an effect *at* its documented maximum fits below it and can be
/// named.
pub const PINNED_SEVERITY: f32 = 1.2;
/// Effects outside the library known to leave the same signature as a library effect on the
/// standard manoeuvre, so that a recording cannot tell them apart; a naming of `effect` is
/// reported with them. A dead time and a DC-link source resistance both lower the voltage the
/// inverter applies at full duty, and the manoeuvre reaches full duty only in the fast reversal,
/// with the current at its limit, where a drop `R·I` is a constant like the dead time's `2ΔV`:
/// a sag of 0.9 Ω (severity 0.3) fits as a dead time of 0.42–0.49 with the structural residual left
/// at the floor (0.045–0.048 A), one of 1.8 Ω as 0.78–0.87 (0.053–0.054 A left), and
/// the dead-time severity fitted window by window is as consistent as on a true dead time
/// (`docs/decisions/0009-effect-naming-rules.md`). A manoeuvre that reaches full duty at several
/// currents would separate them.
pub fn same_signature(effect: EffectId) -> &'static [&'static str] {
    match effect {
        EffectId::DeadTime => &["a DC-link source resistance (bus sag)"],
        _ => &[],
    }
}

/// Largest number of effects named.
pub const MAX_NAMED: usize = 2;

/// One library effect tried as the missing one; serialized as one entry of the JSON report's
/// `rounds` (`docs/output-schema.md`).
#[derive(Clone, Debug, Serialize)]
pub struct Candidate {
    /// The effect (its ID in the JSON report).
    #[serde(serialize_with = "effect_id")]
    pub effect: EffectId,
    /// Its fitted severity.
    pub severity: f32,
    /// ΔBIC on the fit part (positive: the effect pays for its parameter).
    pub bic_fit: f64,
    /// `n_eff·ln(E_reference/E_fit)` on the fit part: the ΔBIC without its parameter term, ≥ 0
    /// when the candidate fits the fit part at least as well as the round's reference.
    ///
    /// An effect that *replaces* fault parameters must reach 0 (the "strong" in-sample bar,
    /// [`BIC_FIT_STRONG`], is for the others): it competes with faults fitted to the same chunks
    /// that mimic it there, so a right effect fits the fit part about as well as they do and its
    /// ΔBIC is mostly the parameter credit, `−Δp·ln n_eff`. That credit is parsimony, not
    /// evidence: a candidate that replaces an eccentricity while fitting the fit part worse can
    /// still show a large held-out ΔBIC when the round's reference generalises badly, and the
    /// evidence then comes from the reference, not from the effect.
    pub fit_gain: f64,
    /// ΔBIC on the held-out part: the evidence.
    pub bic_held_out: f64,
    /// Share of the structural residual energy (whole recording) it removes.
    pub gap_share: f64,
    /// Share of the structural residual energy *above the sensor noise* (whole recording) it
    /// removes: `(E_reference − E_after) / (E_reference − n·σ_n²)` with `σ_n` =
    /// [`NOISE_FLOOR_A`] and `n` structural samples; 0 when the reference is at or below the
    /// noise. The materiality test ([`MIN_ABOVE_NOISE_SHARE`]).
    pub above_noise_share: f64,
    /// The effect explains what the reference fit attributed to fault groups, with fewer fault
    /// parameters left (e.g. a winding temperature rise read as shorts on all three phases).
    pub replaces_faults: bool,
    /// ΔBIC on the held-out part of the fit against itself with the effect switched off: what the
    /// effect carries at its own fault vector ([`BIC_OWN_STRONG`]).
    pub bic_own_held_out: f64,
    /// The fit with the effect on (fit part); its fault vector is the JSON report's `k`.
    #[serde(rename = "k", serialize_with = "fit_fault_vector")]
    pub fit: ModelFit,
}

/// Serializes an effect as its ID.
fn effect_id<S: serde::Serializer>(effect: &EffectId, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(effect.id())
}

/// Serializes a fit as its fault vector.
fn fit_fault_vector<S: serde::Serializer>(fit: &ModelFit, s: S) -> Result<S::Ok, S::Error> {
    fit.k.0.serialize(s)
}

/// The verdict of one search round.
#[derive(Clone, Debug)]
pub struct Round {
    /// Every candidate, best evidence first.
    pub candidates: Vec<Candidate>,
    /// The winner's posterior weight, when one is named.
    pub named: Option<(EffectId, f32, f64)>,
    /// The best candidate had the evidence but fitted at its bound ([`PINNED_SEVERITY`]).
    pub pinned: Option<EffectId>,
}

impl Round {
    /// A candidate's unnormalized posterior weight, `exp(ΔBIC_held-out/2)` (capped).
    fn weight(c: &Candidate) -> f64 {
        (c.bic_held_out.min(1400.0) / 2.0).exp()
    }

    /// `1 + Σ weights`: the reference (no effect) counts 1.
    fn weight_sum(candidates: &[Candidate]) -> f64 {
        1.0 + candidates.iter().map(Self::weight).sum::<f64>()
    }

    /// The posterior weight of `c` among this round's candidates: the confidence a name gets.
    fn confidence(&self, c: &Candidate) -> f64 {
        Self::weight(c) / Self::weight_sum(&self.candidates)
    }

    /// Monitor-model evaluations its candidates' fits took.
    pub(super) fn evaluations(&self) -> u64 {
        self.candidates.iter().map(|c| u64::from(c.fit.evaluations)).sum()
    }

    /// The pinned winner (when there is one) with its fit and the confidence it would be named with.
    pub(super) fn pinned_winner(&self) -> Option<(EffectId, ModelFit, f64)> {
        let c = self.candidates.first()?;
        self.pinned.map(|p| (p, c.fit.clone(), self.confidence(c)))
    }
}

/// The naming rules short of the bound: strong held-out evidence, in-sample support, a severity
/// that counts, and a material share of the gap above the noise closed
/// ([`MIN_ABOVE_NOISE_SHARE`]); an effect that replaces faults must also remove
/// [`MIN_GAP_SHARE_REPLACING`] of the gap and carry its own evidence ([`BIC_OWN_STRONG`]).
pub(super) fn has_evidence(c: &Candidate) -> bool {
    c.bic_held_out > BIC_STRONG
        && if c.replaces_faults { c.fit_gain >= 0.0 } else { c.bic_fit > BIC_FIT_STRONG }
        && c.severity >= MIN_SEVERITY
        && c.gap_share > 0.0
        && c.above_noise_share >= MIN_ABOVE_NOISE_SHARE
        && (!c.replaces_faults || (c.gap_share >= MIN_GAP_SHARE_REPLACING && c.bic_own_held_out > BIC_OWN_STRONG))
}

/// `ΔBIC = n·ln(E0/E1) − (p1 − p0)·ln(n)`: positive when the second model pays for its extra
/// parameters (or explains as much with fewer).
fn delta_bic(n_eff: f64, before: f32, after: f32, extra_parameters: f64) -> f64 {
    if !(before > 0.0 && after > 0.0) {
        return f64::NEG_INFINITY;
    }
    n_eff * (f64::from(before) / f64::from(after)).ln() - extra_parameters * n_eff.max(2.0).ln()
}

/// One search round: every effect not yet on, fitted on the fit part from `base_fit`, scored
/// on the held-out part against the reference model. The reference is the best model without a
/// new effect: `base_fit`, or a candidate fit whose new effect ended negligible (set to zero and
/// re-scored), since every candidate fit also searches the faults from more starts; otherwise a
/// better fault fit would pass for evidence of an effect.
#[allow(clippy::too_many_arguments)]
pub(super) fn search_round<const W: usize>(
    trace: &ConditionedWindow<W>,
    params: &EmaParams,
    profile: &Command<'_>,
    on: &[EffectId],
    base_fit: &ModelFit,
    n_eff_part: f64,
    bar: &ProgressBar,
) -> (Round, ModelFit) {
    let effects: Vec<EffectId> = EffectId::ALL.iter().copied().filter(|e| !on.contains(e)).collect();
    bar.inc_length(effects.len() as u64);
    bar.set_message(format!(
        "candidate effects on top of [{}]",
        on.iter().map(|e| e.id()).collect::<Vec<_>>().join(", ")
    ));
    let fit_one = |effect: &EffectId| {
        let mut free: Vec<EffectId> = on.to_vec();
        free.push(*effect);
        let fit = fit_model(trace, params, profile, &free, base_fit, Part::Fit, n_eff_part);
        bar.inc(1);
        (*effect, fit)
    };
    // On the caller's rayon pool ([`super::discover_with_progress`] installs one of `--threads`
    // workers); the fits come back in library order (`collect` keeps the input's order), so ties
    // (candidates whose effect ended at 0, the reference among equal errors) come out the same on
    // every run and for every thread count.
    let mut fits: Vec<(EffectId, ModelFit)> = effects.par_iter().map(fit_one).collect();
    fits.sort_by_key(|(effect, _)| *effect);
    let fit_part = PartFit::new(trace, *params, *profile, ModelEffects::NONE, vec![], Part::Fit);
    let held = PartFit::new(trace, *params, *profile, ModelEffects::NONE, vec![], Part::HeldOut);
    // the reference: the best fit without a new effect
    let mut reference = base_fit.clone();
    for (effect, fit) in &fits {
        if fit.effects.get(*effect) < MIN_SEVERITY {
            let effects = fit.effects.without(*effect);
            let error = fit_part.error(&fit.k, &effects, f32::INFINITY);
            if error < reference.error {
                reference = ModelFit { k: fit.k, effects, error, evaluations: 0 };
            }
        }
    }
    let reference_held_out = held.error(&reference.k, &reference.effects, f32::INFINITY);
    let reference_energy =
        structural_energy(&series(trace, params, profile, &reference.k, &reference.effects)).max(1e-30);
    let reference_parameters = parameter_count(&reference);
    let above_noise_share = |after_energy: f64, samples: usize| {
        let above = reference_energy - samples as f64 * NOISE_FLOOR_A * NOISE_FLOOR_A;
        if above > 0.0 {
            (reference_energy - after_energy) / above
        } else {
            0.0
        }
    };
    let mut candidates: Vec<Candidate> = fits
        .into_iter()
        .map(|(effect, fit)| {
            let extra = parameter_count(&fit) as f64 - reference_parameters as f64;
            let e_held = held.error(&fit.k, &fit.effects, f32::INFINITY);
            let e_held_without = held.error(&fit.k, &fit.effects.without(effect), f32::INFINITY);
            let after = series(trace, params, profile, &fit.k, &fit.effects);
            Candidate {
                effect,
                severity: fit.effects.get(effect),
                bic_fit: delta_bic(n_eff_part, reference.error, fit.error, extra),
                fit_gain: delta_bic(n_eff_part, reference.error, fit.error, 0.0),
                bic_held_out: delta_bic(n_eff_part, reference_held_out, e_held, extra),
                gap_share: 1.0 - structural_energy(&after) / reference_energy,
                above_noise_share: above_noise_share(structural_energy(&after), after.structural_a.len()),
                replaces_faults: fault_parameter_count(&fit.k) < fault_parameter_count(&reference.k),
                bic_own_held_out: delta_bic(n_eff_part, e_held_without, e_held, 1.0),
                fit,
            }
        })
        .collect();
    candidates.sort_by(|a, b| b.bic_held_out.total_cmp(&a.bic_held_out));
    let weight_sum = Round::weight_sum(&candidates);
    let named = candidates.first().and_then(|c| {
        (has_evidence(c) && c.severity < PINNED_SEVERITY).then(|| (c.effect, c.severity, Round::weight(c) / weight_sum))
    });
    let pinned =
        candidates.first().and_then(|c| (has_evidence(c) && c.severity >= PINNED_SEVERITY).then_some(c.effect));
    (Round { candidates, named, pinned }, reference)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ema_monitor::FaultVector;

    /// A candidate with strong evidence on every other rule.
    fn strong(above_noise_share: f64) -> Candidate {
        Candidate {
            effect: EffectId::WindingTemperature,
            severity: 0.5,
            bic_fit: 40.0,
            fit_gain: 40.0,
            bic_held_out: 60.0,
            gap_share: 0.05,
            above_noise_share,
            replaces_faults: false,
            bic_own_held_out: 60.0,
            fit: ModelFit { k: FaultVector::HEALTHY, effects: ModelEffects::NONE, error: 1.0, evaluations: 0 },
        }
    }

    /// Strong evidence is not enough: an effect that closes 5 % of the gap above the noise (a
    /// compliant transmission read as a hot winding) is not named; one that closes most of it is.
    #[test]
    fn an_effect_that_closes_a_sliver_of_the_gap_is_not_named() {
        assert!(!has_evidence(&strong(0.05)));
        assert!(!has_evidence(&strong(MIN_ABOVE_NOISE_SHARE - 0.01)));
        assert!(has_evidence(&strong(MIN_ABOVE_NOISE_SHARE)));
        assert!(has_evidence(&strong(0.9)));
    }

    #[test]
    fn only_the_dead_time_has_a_known_look_alike() {
        for e in EffectId::ALL {
            assert_eq!(same_signature(e).is_empty(), e != EffectId::DeadTime, "{e:?}");
        }
    }
}
