//! What a recording can tell: the 1σ of each fault parameter at the estimate and, for a fault
//! group reported healthy, the smallest severity model selection would have kept on this
//! recording.
//!
//! **Sensitivities.** Column `j` of the Jacobian of the monitor model's window samples is a
//! finite difference, `d_i,j = (Ĩ_MM,i(k + h_j·e_j) − Ĩ_MM,i(k))/h_j`, `|h_j|` = [`FISHER_STEP`].
//! A parameter at the top of its range steps down (one-sided); a group reported healthy steps up
//! from healthy (one-sided from the bound 0). A healthy eccentricity has no phase: its two
//! columns are the magnitude's at the phases `φ = 0` and `φ = π/2` (`k7` = 0.5 and 0.75). The
//! eccentricity enters the model as `k_j·(1 + ζ·cos(θ_m − φ − ψ_j))` (first order in `ζ`), so a
//! small eccentricity at any phase `φ` is `cos φ` times the first column plus `sin φ` times the
//! second.
//!
//! **One run.** The base model and the 8 stepped models run in lockstep, sample by sample, under
//! the same command ([`Fisher::at`]); each window sample adds to two 8×8 sums and nothing is
//! stored per sample. The cost is 9 model runs (one evaluation each) and
//! `2·9·8·4` bytes of model state beside the sums; accumulating one row per pass against a
//! stored base run would take 1 + 8 + 28 runs for the off-diagonal terms, or `8·n` stored
//! samples (68 kB at the on-board window).
//!
//! **Covariance.** The fit minimises `Σ v_i·r_i²` with `v_i = ρ_i·w_i` (the fitness's weights,
//! [`crate::fitness`]). For residual noise of variance `s²` per window sample, the weighted
//! least-squares estimate has the sandwich covariance
//!
//! ```text
//! C = s²·A⁻¹·B·A⁻¹,   A = Σ v_i·d_i·d_iᵀ,   B = Σ v_i²·d_i·d_iᵀ
//! ```
//!
//! (Seber and Wild, *Nonlinear Regression*, 1989, §2.1), over the parameters of the groups
//! present; `C = s²·A⁻¹` when every `v_i` is 1, the Cramér–Rao bound `F⁻¹`, `F = JᵀJ/s²`.
//! `s² = σ² + L·m²`: `σ²` the noise of a window sample of the fit test
//! ([`super::window_noise_variance_a2`]), `m` = [`MODEL_MISMATCH_A`] the monitor model's known
//! structural mismatch and `L` = [`MISMATCH_CORRELATION_SAMPLES`] its correlation length: a
//! smooth error of RMS `m` moves the estimate as much as white noise of variance `L·m²` would.
//! The choice of `L` is calibrated on the identification campaign
//! (`docs/decisions/0022-uncertainty.md`). `σ_i = √C_ii`; a matrix that is not positive
//! definite (a parameter without effect on this recording) gives `σ = +∞` for the parameters
//! inverted with it.
//!
//! **Detectable below.** Model selection keeps a group of `m` parameters when
//! `n_eff·ln(E_without/E_with) > m·ln(n_eff)` ([`super::group_pays`]). A group of severity `s`
//! along its direction `u` raises `E` by `ΔE = s²·uᵀ·S·u/n`, `S` the Schur complement of the
//! group's block of `A` against the parameters of the groups present (the refit of the others),
//! so the smallest severity that pays on this recording is
//!
//! ```text
//! s_min = √(n·E·(n_eff^{m/n_eff} − 1) / λ)
//! ```
//!
//! with `E` the fitness at the estimate, `n_eff` its effective samples, and `λ = S` for one
//! parameter, the smallest eigenvalue of the 2×2 `S` for the eccentricity (its least visible
//! phase). For the short circuit the largest of the three phases' values is reported, so that a
//! short below it may hide on any phase.

use super::config::{configured_fit, IdentifyConfig, PHASE_INDEX};
use super::groups::group_present;
use super::verdict::{window_noise_variance_a2, MODEL_MISMATCH_A};
use crate::command::Command;
use crate::conditioning::ConditionedWindow;
use crate::faults::{FaultGroup, FaultVector, FAULT_COUNT, GROUP_COUNT};
use crate::fitness::{EquivalentCurrentFit, EVIDENCE_WINDOW_SAMPLES};
use crate::health::{lag_correlation, HealthReport, Uncertainty};
use crate::model::MonitorModel;
use crate::params::EmaParams;

/// The finite-difference step `|h|` of the sensitivities, in normalized fault units: 0.01, a
/// tenth of [`crate::health::DEGRADED_AT`], large against the `f32` rounding of a model run
/// (relative `1e-6` of a current of a few amperes) and small against the curvature of the
/// model's response to a severity.
pub const FISHER_STEP: f32 = 0.01;

/// Correlation length `L` of the model mismatch in window samples (module doc): the mismatch
/// [`MODEL_MISMATCH_A`] counts in the residual noise of the covariance as white noise of
/// variance `L·m²`. The mismatch is smooth over a reversal's transient, so `L` is one evidence
/// window ([`EVIDENCE_WINDOW_SAMPLES`], 40 ms); with it ±2σ covers the true values of the
/// identification campaign near 95 % of the time, and without it (`L` = 1) under 80 %
/// (`docs/decisions/0022-uncertainty.md`).
pub const MISMATCH_CORRELATION_SAMPLES: f32 = EVIDENCE_WINDOW_SAMPLES as f32;

/// The one-sided 95 % normal quantile, 1.645: a fault's estimate scatters about its true severity
/// with the reported 1σ, and model selection keeps the group when the estimate reaches `s_min`
/// ([`Fisher::detectable_below`]), so a fault of `s_min + z·σ` is kept with 95 % probability.
/// The "not detectable below" bound is that severity: a fault at or above it is missed at most
/// one time in twenty.
pub const DETECTION_Z: f32 = 1.645;

/// Models run in lockstep: the base and one per column.
const MODELS: usize = FAULT_COUNT + 1;

/// The eccentricity magnitude's index `k6`.
const ECCENTRICITY_INDEX: usize = PHASE_INDEX - 1;

/// The sensitivity sums of one recording at one fault vector ([`Fisher::at`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fisher {
    /// The vector the sensitivities are taken at.
    pub k: FaultVector,
    /// Groups present in `k`, by [`FaultGroup::index`] (their parameters are the free ones).
    pub present: [bool; GROUP_COUNT],
    /// `A = Σ v_i·d_i·d_iᵀ` (upper triangle filled, then mirrored), A² per unit².
    pub information: [[f32; FAULT_COUNT]; FAULT_COUNT],
    /// `B = Σ v_i²·d_i·d_iᵀ`.
    pub weighted_sq: [[f32; FAULT_COUNT]; FAULT_COUNT],
    /// The signed step of each column.
    pub steps: [f32; FAULT_COUNT],
    /// The fitness `E` at `k` (A²).
    pub error: f32,
    /// Effective samples of the residual at `k` (AR(1), as [`EquivalentCurrentFit::effective_samples`]).
    pub effective_samples: f32,
    /// Window samples.
    pub samples: usize,
}

/// The sums of the lockstep run.
struct Sums {
    a: [[f32; FAULT_COUNT]; FAULT_COUNT],
    b: [[f32; FAULT_COUNT]; FAULT_COUNT],
    sq: f32,
    lag: f32,
    previous: f32,
}

impl Fisher {
    /// The sensitivities of `fit` (the monitor model of `params` against its trace) at `k`: one
    /// lockstep run of 9 models (module doc). Groups present in `k` ([`group_present`]) are the
    /// free parameters; the others are stepped up from healthy. Not inlined: the 9 models live
    /// in this frame alone, not beside the fitness its caller builds first.
    #[inline(never)]
    pub fn at<const W: usize>(fit: &EquivalentCurrentFit<'_, W>, params: &EmaParams, k: &FaultVector) -> Self {
        let present = FaultGroup::ALL.map(|g| group_present(&k.0, g));
        let eccentric = present[FaultGroup::Eccentricity.index()];
        let mut steps = [FISHER_STEP; FAULT_COUNT];
        let mut stepped = [k.0; FAULT_COUNT];
        for (j, (h, x)) in steps.iter_mut().zip(stepped.iter_mut()).enumerate() {
            if !eccentric && j == ECCENTRICITY_INDEX {
                x[ECCENTRICITY_INDEX] = FISHER_STEP;
                x[PHASE_INDEX] = 0.5;
            } else if !eccentric && j == PHASE_INDEX {
                x[ECCENTRICITY_INDEX] = FISHER_STEP;
                x[PHASE_INDEX] = 0.75;
            } else if j != PHASE_INDEX && x[j] + FISHER_STEP > 1.0 {
                *h = -FISHER_STEP;
                x[j] -= FISHER_STEP;
            } else {
                x[j] += FISHER_STEP;
            }
        }
        let effects = *fit.effects();
        // built in place, one model at a time (an array built by `from_fn` is moved, so it would
        // be on the stack twice)
        let mut models = [MonitorModel::with_effects(params, k, &effects); MODELS];
        for (model, x) in models.iter_mut().skip(1).zip(stepped.iter()) {
            *model = MonitorModel::with_effects(params, &FaultVector(*x), &effects);
        }
        let inv_step: [f32; FAULT_COUNT] = core::array::from_fn(|j| 1.0 / steps[j]);
        let zero = [[0.0; FAULT_COUNT]; FAULT_COUNT];
        let mut sums = Sums { a: zero, b: zero, sq: 0.0, lag: 0.0, previous: 0.0 };
        crate::lockstep::lockstep(&models, params, fit, |y, v, means| accumulate(&mut sums, &inv_step, y, v, means));
        for j in 0..FAULT_COUNT {
            for l in 0..j {
                sums.a[j][l] = sums.a[l][j];
                sums.b[j][l] = sums.b[l][j];
            }
        }
        let n = fit.trace().len();
        let rho = lag_correlation(sums.sq, sums.lag);
        let error = if n == 0 { f32::INFINITY } else { sums.sq / n as f32 };
        Self {
            k: *k,
            present,
            information: sums.a,
            weighted_sq: sums.b,
            steps,
            error,
            effective_samples: n as f32 * (1.0 - rho) / (1.0 + rho),
            samples: n,
        }
    }

    /// Parameter indices of the groups present, in order, and their count.
    fn free(&self) -> ([usize; FAULT_COUNT], usize) {
        let mut idx = [0usize; FAULT_COUNT];
        let mut d = 0usize;
        for (g, group) in FaultGroup::ALL.into_iter().enumerate() {
            let (first, last) = group.params();
            if self.present[g] {
                for i in first..=last {
                    if let Some(slot) = idx.get_mut(d) {
                        *slot = i;
                        d += 1;
                    }
                }
            }
        }
        (idx, d)
    }

    /// The 1σ of each parameter for residual noise `noise_a2` (A² per window sample, `s²` of the
    /// module doc): groups present from the sandwich covariance of the free parameters; a group
    /// absent from the covariance with its own parameters freed beside them (its σ were it
    /// present; a healthy eccentricity's magnitude at its least visible phase, its phase `+∞`).
    pub fn sigma(&self, noise_a2: f32) -> [f32; FAULT_COUNT] {
        let (free, d) = self.free();
        let mut sigma = [f32::INFINITY; FAULT_COUNT];
        let c = self.covariance(&free, d, noise_a2);
        for (r, &i) in free.iter().enumerate().take(d) {
            if let (Some(s), Some(row)) = (sigma.get_mut(i), c.get(r)) {
                *s = sqrt_or_inf(row.get(r).copied().unwrap_or(f32::INFINITY));
            }
        }
        for (g, group) in FaultGroup::ALL.into_iter().enumerate() {
            let (first, last) = group.params();
            if self.present[g] {
                continue;
            }
            let (set, e, m) = self.with_group(&free, d, first, last);
            let c = self.covariance(&set, e, noise_a2);
            let (p, q) = (d.min(7), (d + 1).min(7));
            if first == ECCENTRICITY_INDEX {
                let (c00, c01, c11) = (c[p][p], c[p][q], c[q][q]);
                sigma[ECCENTRICITY_INDEX] = sqrt_or_inf(largest_eigenvalue(c00, c01, c11));
                sigma[PHASE_INDEX] = f32::INFINITY;
            } else if m == 1 {
                if let Some(s) = sigma.get_mut(first) {
                    *s = sqrt_or_inf(c[p][p]);
                }
            }
        }
        sigma
    }

    /// The severity model selection keeps with 95 % probability on this recording, per fault
    /// mode of [`crate::faults::FaultMode::ALL`], for the modes whose groups are all absent
    /// (`None` for a mode found): `s_min + z·σ`, `s_min` the severity whose expected gain just
    /// pays the information criterion (kept half the time), `σ` the group's 1σ from `sigma`
    /// ([`Fisher::sigma`]), `z` = 1.645 (`DETECTION_Z`); with every `σ` zero, `s_min` itself.
    /// Severity units: `k1`, `k2`, the worst phase's `k3..k5`, `k6`, and `2·|k8 − 0.5|` for the
    /// gain.
    pub fn detectable_below(&self, sigma: &[f32; FAULT_COUNT]) -> [Option<f32>; 5] {
        let (free, d) = self.free();
        let n = self.samples as f32;
        let n_eff = self.effective_samples;
        let price = |m: f32| {
            if n_eff > 1.0 {
                libm::expf(m * libm::logf(n_eff) / n_eff) - 1.0
            } else {
                f32::INFINITY
            }
        };
        let mut group_min = [None::<f32>; GROUP_COUNT];
        for (g, group) in FaultGroup::ALL.into_iter().enumerate() {
            let (first, last) = group.params();
            if self.present[g] {
                continue;
            }
            let (set, e, m) = self.with_group(&free, d, first, last);
            let Some(inv) = self.inverse_information(&set, e) else {
                group_min[g] = Some(f32::INFINITY);
                continue;
            };
            let lambda = if m == 2 {
                // S = (block of A⁻¹)⁻¹: its smallest eigenvalue is 1 / the block's largest
                let (p, q) = (d.min(7), (d + 1).min(7));
                1.0 / largest_eigenvalue(inv[p][p], inv[p][q], inv[q][q])
            } else {
                1.0 / inv[d.min(7)][d.min(7)]
            };
            let need = n * self.error * price(m as f32);
            let s = if lambda > 0.0 && need.is_finite() { libm::sqrtf(need / lambda) } else { f32::INFINITY };
            let s = s + DETECTION_Z * sigma.get(first).copied().unwrap_or(f32::INFINITY);
            group_min[g] = Some(if s.is_nan() { f32::INFINITY } else { s });
        }
        let worst = |a: Option<f32>, b: Option<f32>, c: Option<f32>| match (a, b, c) {
            (Some(a), Some(b), Some(c)) => Some(a.max(b).max(c)),
            _ => None,
        };
        [
            group_min[0],
            group_min[1],
            worst(group_min[2], group_min[3], group_min[4]),
            group_min[5],
            group_min[6].map(|s| 2.0 * s),
        ]
    }

    /// The free set with the group `first..=last` appended (for a healthy eccentricity its two
    /// basis columns), its size and the group's parameter count.
    fn with_group(
        &self,
        free: &[usize; FAULT_COUNT],
        d: usize,
        first: usize,
        last: usize,
    ) -> ([usize; 8], usize, usize) {
        let mut set = *free;
        let mut e = d;
        for i in first..=last {
            if let Some(slot) = set.get_mut(e) {
                *slot = i;
                e += 1;
            }
        }
        (set, e, e - d)
    }

    /// `(A_S)⁻¹` of the parameters `set[..d]`, by a Cholesky factorisation of the Jacobi-scaled
    /// block; `None` when it is not positive definite (to `f32` precision).
    fn inverse_information(&self, set: &[usize; FAULT_COUNT], d: usize) -> Option<[[f32; 8]; 8]> {
        invert(&sub_matrix(&self.information, set, d), d)
    }

    /// The sandwich covariance `s²·A⁻¹·B·A⁻¹` of the parameters `set[..d]` (`+∞` everywhere when
    /// `A` is singular).
    fn covariance(&self, set: &[usize; FAULT_COUNT], d: usize, noise_a2: f32) -> [[f32; 8]; 8] {
        let d = d.min(FAULT_COUNT);
        let Some(ai) = self.inverse_information(set, d) else {
            return [[f32::INFINITY; 8]; 8];
        };
        let b = sub_matrix(&self.weighted_sq, set, d);
        product(&product(&ai, &b, d, 1.0), &ai, d, noise_a2)
    }
}

/// `scale·(x·y)` of the leading `d×d` blocks (`d ≤ 8`), each sum taken in the order of `j`.
fn product(x: &[[f32; 8]; 8], y: &[[f32; 8]; 8], d: usize, scale: f32) -> [[f32; 8]; 8] {
    let mut out = [[0.0f32; 8]; 8];
    for (out_row, x_row) in out.iter_mut().zip(x).take(d) {
        for (c, o) in out_row.iter_mut().enumerate().take(d) {
            let mut acc = 0.0f32;
            for (x_rj, y_row) in x_row.iter().zip(y).take(d) {
                acc += x_rj * y_row[c];
            }
            *o = scale * acc;
        }
    }
    out
}

/// The noise `s²` of the covariance (module doc): the fit test's window-sample noise for
/// `independent_frames` per block plus `MISMATCH_CORRELATION_SAMPLES``·m²`.
pub fn covariance_noise_a2(params: &EmaParams, independent_frames: f32) -> f32 {
    window_noise_variance_a2(params, independent_frames)
        + MISMATCH_CORRELATION_SAMPLES * MODEL_MISMATCH_A * MODEL_MISMATCH_A
}

/// The uncertainty of `k` on the recording of `fit`: its [`Fisher`] sums (9 model runs), the 1σ
/// for the noise of [`covariance_noise_a2`] and the detectable-below severities.
pub fn uncertainty_at<const W: usize>(
    fit: &EquivalentCurrentFit<'_, W>,
    params: &EmaParams,
    k: &FaultVector,
    independent_frames: f32,
) -> Uncertainty {
    let fisher = Fisher::at(fit, params, k);
    let sigma = fisher.sigma(covariance_noise_a2(params, independent_frames));
    Uncertainty { sigma, detectable_below: fisher.detectable_below(&sigma) }
}

/// `report` (an identification of `trace` under `command` with `config`, on the actuator
/// `params`) with its [`Uncertainty`] at the reported vector, for a caller that no longer holds
/// the [`super::Identification`] (the firmware, which keeps this run out of the identification's
/// instruction count): the fitness is built again (one healthy-model run for its fast-regime
/// intervals) and the 9 models run in lockstep. A fitness the configuration refuses leaves the
/// report as it is (the identification refused it first).
pub fn with_uncertainty<'a, const W: usize>(
    trace: &'a ConditionedWindow<W>,
    params: EmaParams,
    command: impl Into<Command<'a>>,
    config: &IdentifyConfig,
    report: HealthReport,
) -> HealthReport {
    let fit = configured_fit(trace, params, command, config).ok();
    match fit {
        Some(fit) => {
            let u = uncertainty_at(&fit, &params, &report.faults, config.independent_frames_per_block);
            report.with_uncertainty(u)
        }
        None => report,
    }
}

/// The block of `m` at the indices `set[..d]`.
fn sub_matrix(m: &[[f32; FAULT_COUNT]; FAULT_COUNT], set: &[usize; FAULT_COUNT], d: usize) -> [[f32; 8]; 8] {
    let mut out = [[0.0f32; 8]; 8];
    for (row, &i) in out.iter_mut().zip(set).take(d) {
        for (x, &j) in row.iter_mut().zip(set).take(d) {
            *x = m.get(i).and_then(|r| r.get(j)).copied().unwrap_or(0.0);
        }
    }
    out
}

/// The inverse of the symmetric `d×d` block `a` (`d ≤ 8`) by Cholesky factorisation after Jacobi
/// scaling (`D·A·D` with unit diagonal, `D = diag(A)^{−1/2}`); `None` when a pivot falls below
/// `1e-6` (not positive definite to `f32` precision) or an entry is not finite.
#[allow(clippy::needless_range_loop, reason = "the factorisation reads as its index formulas")]
fn invert(a: &[[f32; 8]; 8], d: usize) -> Option<[[f32; 8]; 8]> {
    let d = d.min(8);
    let mut scale = [0.0f32; 8];
    for i in 0..d {
        let x = a[i][i];
        if !(x > 0.0 && x.is_finite()) {
            return None;
        }
        scale[i] = 1.0 / libm::sqrtf(x);
    }
    // lower factor L of the scaled matrix
    let mut l = [[0.0f32; 8]; 8];
    for i in 0..d {
        for j in 0..=i {
            let mut s = a[i][j] * scale[i] * scale[j];
            for p in 0..j {
                s -= l[i][p] * l[j][p];
            }
            if i == j {
                if s.is_nan() || s <= 1e-6 {
                    return None;
                }
                l[i][i] = libm::sqrtf(s);
            } else {
                l[i][j] = s / l[j][j];
            }
        }
    }
    // L⁻¹ (lower), then (D·A·D)⁻¹ = L⁻ᵀ·L⁻¹, then A⁻¹ = D·(·)·D
    let mut li = [[0.0f32; 8]; 8];
    for i in 0..d {
        li[i][i] = 1.0 / l[i][i];
        for j in 0..i {
            let mut s = 0.0f32;
            for p in j..i {
                s -= l[i][p] * li[p][j];
            }
            li[i][j] = s / l[i][i];
        }
    }
    let mut out = [[0.0f32; 8]; 8];
    for i in 0..d {
        for j in 0..d {
            let mut s = 0.0f32;
            for p in i.max(j)..d {
                s += li[p][i] * li[p][j];
            }
            out[i][j] = s * scale[i] * scale[j];
        }
    }
    if out.iter().flatten().all(|x| x.is_finite()) {
        Some(out)
    } else {
        None
    }
}

/// The largest eigenvalue of the symmetric 2×2 matrix `[[a, b], [b, c]]`.
fn largest_eigenvalue(a: f32, b: f32, c: f32) -> f32 {
    let mean = 0.5 * (a + c);
    let half = 0.5 * (a - c);
    mean + libm::sqrtf(half * half + b * b)
}

/// `√x`, `+∞` for a non-finite or negative `x`.
fn sqrt_or_inf(x: f32) -> f32 {
    if x >= 0.0 && x.is_finite() {
        libm::sqrtf(x)
    } else {
        f32::INFINITY
    }
}

/// One window sample of [`Fisher::at`]'s lockstep run ([`crate::lockstep`]): the measured block
/// mean `y_i`, its weight `v_i` and the block means of the base model and the 8 stepped ones,
/// compared and accumulated.
#[allow(clippy::needless_range_loop, reason = "the upper triangle of A and B, by index")]
fn accumulate(sums: &mut Sums, inv_step: &[f32; FAULT_COUNT], y_i: f32, v: f32, means: &[f32; MODELS]) {
    let base = means[0];
    let r = y_i - base;
    let u = libm::sqrtf(v) * r;
    sums.sq += u * u;
    sums.lag += u * sums.previous;
    sums.previous = u;
    let mut dcol = [0.0f32; FAULT_COUNT];
    for ((dj, b), h) in dcol.iter_mut().zip(&means[1..]).zip(inv_step) {
        *dj = (b - base) * h;
    }
    for j in 0..FAULT_COUNT {
        let vd = v * dcol[j];
        let v2d = v * vd;
        for l in j..FAULT_COUNT {
            sums.a[j][l] += vd * dcol[l];
            sums.b[j][l] += v2d * dcol[l];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::conditioning::DECIMATION;
    use crate::diagnosis::{Identification, IdentifyConfig, ONBOARD_POPULATION, ONBOARD_WINDOW};
    use crate::fitness::simulate_window;
    use crate::profile::Profile;

    /// The model's own trace of `truth` with Gaussian noise of `sigma` A on the pair current of
    /// every frame (0: noise-free), from the seeded generator `seed`.
    fn trace_of(truth: &FaultVector, sigma: f32, seed: u64) -> ConditionedWindow<ONBOARD_WINDOW> {
        let mut t = ConditionedWindow::<ONBOARD_WINDOW>::new();
        let n = (Profile::STANDARD.duration_s() / EmaParams::NOMINAL.control_period_s) as usize / DECIMATION;
        let mut rng = crate::optimizer::rng::Rng::new(seed);
        simulate_window(&EmaParams::NOMINAL, &Profile::STANDARD, truth, n, |_, i, _| {
            for _ in 0..DECIMATION {
                let pair = i + sigma * rng.normal();
                t.push(pair, -pair, 0.0).unwrap();
            }
            true
        });
        t.finish().unwrap();
        t
    }

    fn fit_of(t: &ConditionedWindow<ONBOARD_WINDOW>) -> EquivalentCurrentFit<'_, ONBOARD_WINDOW> {
        EquivalentCurrentFit::new(t, EmaParams::NOMINAL, &Profile::STANDARD)
            .unwrap()
            .with_fast_regime_weight(0.1)
            .unwrap()
    }

    #[test]
    fn the_lockstep_base_is_the_fitness_and_the_columns_are_finite_differences() {
        let truth = FaultVector([0.3, 0.0, 0.0, 0.2, 0.0, 0.0, 0.5, 0.35]);
        let t = trace_of(&truth, 0.29, 5);
        let fit = fit_of(&t);
        let k = FaultVector([0.31, 0.0, 0.0, 0.19, 0.0, 0.0, 0.5, 0.36]);
        let f = Fisher::at(&fit, &EmaParams::NOMINAL, &k);
        let e = fit.error(&k);
        assert!((f.error - e).abs() <= 1e-5 * e, "{} vs {e}", f.error);
        let n_eff = fit.effective_samples(&k);
        assert!((f.effective_samples - n_eff).abs() <= 1e-3 * n_eff, "{} vs {n_eff}", f.effective_samples);
        assert_eq!(f.present, [true, false, false, true, false, false, true]);
        // A_jj by hand for the friction column: Σ v·d² from two model runs
        let y: std::vec::Vec<f32> = t.current_a().collect();
        let w: std::vec::Vec<f32> = t.weights().collect();
        let (intervals, weight) = fit.fast_regime();
        let mut base = [0.0f32; ONBOARD_WINDOW];
        simulate_window(&EmaParams::NOMINAL, &Profile::STANDARD, &k, y.len(), |i, m, _| {
            base[i] = m;
            true
        });
        let mut stepped = k;
        stepped.0[0] += FISHER_STEP;
        let mut a00 = 0.0f32;
        simulate_window(&EmaParams::NOMINAL, &Profile::STANDARD, &stepped, y.len(), |i, m, _| {
            let fast = intervals.iter().any(|&(s, e)| (s..e).contains(&(i as u32)));
            let d = (m - base[i]) / FISHER_STEP;
            a00 += if fast { weight } else { 1.0 } * w[i] * d * d;
            true
        });
        assert!((f.information[0][0] - a00).abs() <= 1e-3 * a00, "{} vs {a00}", f.information[0][0]);
        assert_eq!(f.information[2][5], f.information[5][2]);
    }

    #[test]
    fn sigma_falls_as_noise_falls_and_absent_groups_get_a_floor() {
        let truth = FaultVector([0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]);
        let t = trace_of(&truth, 0.29, 9);
        let f = Fisher::at(&fit_of(&t), &EmaParams::NOMINAL, &truth);
        let s1 = f.sigma(0.02);
        let s4 = f.sigma(0.02 / 16.0);
        assert!(s1.iter().all(|s| *s > 0.0), "{s1:?}");
        assert!((s1[0] / s4[0] - 4.0).abs() < 1e-3, "σ scales with the noise's RMS: {s1:?} {s4:?}");
        assert!(s1[0] < 0.02, "friction is well seen: {s1:?}");
        assert_eq!(s1[PHASE_INDEX], f32::INFINITY, "a healthy eccentricity has no phase");
        let floor = f.detectable_below(&s1);
        assert_eq!(floor[0], None, "friction is found");
        for (m, s) in floor.iter().enumerate().skip(1) {
            let s = s.unwrap();
            assert!(s > 0.0 && s < 1.0, "mode {m}: {floor:?}");
        }
    }

    #[test]
    fn the_quadratic_form_predicts_the_rise_of_the_error() {
        // noise-free: a friction, a backlash and a gain drift of 0.03 raise E on the healthy
        // recording by about s²·A_jj/n, the form the detectable-below severity inverts. The
        // backlash's rise is sub-quadratic (the free play is crossed or not: a dry contact), so
        // its quadratic form from the first step of 0.01 overstates the rise at 0.03 by up to 2×.
        let t = trace_of(&FaultVector::HEALTHY, 0.0, 1);
        let fit = fit_of(&t);
        let f = Fisher::at(&fit, &EmaParams::NOMINAL, &FaultVector::HEALTHY);
        for (j, tolerance) in [(0usize, 0.3f32), (1, 0.5), (7, 0.3)] {
            let mut k = FaultVector::HEALTHY;
            k.0[j] += 0.03;
            let t2 = trace_of(&k, 0.0, 1);
            let rise = fit_of(&t2).error(&FaultVector::HEALTHY);
            let predicted = 0.03 * 0.03 * f.information[j][j] / f.samples as f32;
            assert!((rise / predicted - 1.0).abs() < tolerance, "k{}: {rise} vs {predicted}", j + 1);
        }
    }

    #[test]
    fn the_identification_reports_its_uncertainty() {
        let truth = FaultVector([0.3, 0.0, 0.0, 0.2, 0.0, 0.0, 0.5, 0.35]);
        let t = trace_of(&truth, 0.29, 3);
        let config = IdentifyConfig::onboard();
        let mut id: Identification<'_, ONBOARD_WINDOW, ONBOARD_POPULATION> =
            Identification::new(&t, EmaParams::NOMINAL, &Profile::STANDARD, &config).unwrap();
        id.run(u32::MAX);
        let r = id.with_uncertainty(id.report());
        let again = with_uncertainty(&t, EmaParams::NOMINAL, &Profile::STANDARD, &config, id.report());
        assert_eq!(again, r, "the firmware's call gives the identification's uncertainty");
        let u = r.uncertainty.unwrap();
        for i in [0usize, 3, 7] {
            assert!(u.sigma[i] > 0.0 && u.sigma[i] < 0.05, "{i}: {u:?}");
            assert!((r.faults.0[i] - truth.0[i]).abs() < 4.0 * u.sigma[i] + 0.01, "{i}: {u:?} {:?}", r.faults);
        }
        assert!(u.detectable_below[3].is_some() && u.detectable_below[0].is_none(), "{u:?}");
        let text = std::format!("{r}");
        assert!(text.contains(" ± ") && text.contains("not detectable below"), "{text}");
    }

    #[test]
    fn a_singular_block_gives_infinite_sigma() {
        let mut a = [[0.0f32; 8]; 8];
        a[0][0] = 1.0;
        a[1][1] = 1.0;
        a[0][1] = 1.0;
        a[1][0] = 1.0;
        assert!(invert(&a, 2).is_none());
        a[1][1] = 2.0;
        let inv = invert(&a, 2).unwrap();
        assert!((inv[0][0] - 2.0).abs() < 1e-5 && (inv[0][1] + 1.0).abs() < 1e-5 && (inv[1][1] - 1.0).abs() < 1e-5);
        assert!((largest_eigenvalue(2.0, 0.0, 1.0) - 2.0).abs() < 1e-6);
        assert_eq!(sqrt_or_inf(f32::NAN), f32::INFINITY);
    }
}
