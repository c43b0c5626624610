//! Hit/miss analysis of a detection method (MIL-HDBK-1823A, §3.5 and appendix G): the
//! probability of detection against the fault's size, `POD(a) = 1/(1 + e^{−(β₀ + β₁·ln a)})`,
//! and the sizes it detects with 50 and 90 % probability, the latter with its upper 95 %
//! confidence bound, `a90/95`.
//!
//! **Fit.** Logistic regression on `x = ln a` by Firth's bias-reduced likelihood (Firth 1993,
//! *Biometrika* 80: 27–38): Newton steps on the modified score
//! `U*_j = Σ (y_i − p_i + h_i·(½ − p_i))·x_ij`, `h_i` the diagonal of the hat matrix
//! `W^{½}X(XᵀWX)⁻¹XᵀW^{½}`, `W = diag(p_i(1 − p_i))`. Unlike the plain maximum likelihood it stays
//! finite when the hits and misses do not overlap (every recording above some size a hit, every
//! one below a miss), which a monitor with a sharp threshold and a few recordings per size often
//! gives; with overlapping data the two agree closely.
//!
//! **Bound.** The covariance of `(β₀, β₁)` is `(XᵀWX)⁻¹` at the estimate. `a90/95` is where the
//! lower one-sided 95 % Wald bound of the linear predictor, `β₀ + β₁x − 1.645·se(x)`, reaches
//! `logit 0.9` (1823A's Wald method): the root of a quadratic in `x`. It does not exist
//! (`None`) when the bound never reaches 0.9, or when `β₁ ≤ 0` (detection does not grow with
//! size).
//!
//! **False alarms.** [`clopper_pearson_upper`] gives the exact one-sided upper confidence bound of
//! a rate from `k` events in `n` trials (Clopper and Pearson 1934): `3/n` for none at 95 %.

/// `logit 0.9`.
const LOGIT_90: f64 = 2.197_224_577_336_219_6;

/// One-sided 95 % normal quantile.
const Z_95: f64 = 1.644_853_626_951_472_2;

/// A fitted POD curve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PodFit {
    /// Intercept `β₀`.
    pub b0: f64,
    /// Slope `β₁` on `ln a`.
    pub b1: f64,
    /// Covariance of `(β₀, β₁)`: `[v00, v01, v11]`.
    pub cov: [f64; 3],
}

impl PodFit {
    /// The probability of detection at size `a`.
    pub fn pod(&self, a: f64) -> f64 {
        1.0 / (1.0 + (-(self.b0 + self.b1 * a.ln())).exp())
    }

    /// The lower one-sided 95 % bound of the probability of detection at size `a`.
    pub fn pod_lower_95(&self, a: f64) -> f64 {
        let x = a.ln();
        let eta = self.b0 + self.b1 * x - Z_95 * self.se(x);
        1.0 / (1.0 + (-eta).exp())
    }

    /// The size detected with probability `p` (`None` when `β₁ ≤ 0`).
    pub fn size_at(&self, p: f64) -> Option<f64> {
        (self.b1 > 0.0).then(|| (((p / (1.0 - p)).ln() - self.b0) / self.b1).exp())
    }

    /// `a90/95`: the size where the lower 95 % bound reaches 0.9 (module doc).
    pub fn a90_95(&self) -> Option<f64> {
        if self.b1 <= 0.0 {
            return None;
        }
        let [v00, v01, v11] = self.cov;
        let c = self.b0 - LOGIT_90;
        let z2 = Z_95 * Z_95;
        let qa = self.b1 * self.b1 - z2 * v11;
        let qb = 2.0 * (self.b1 * c - z2 * v01);
        let qc = c * c - z2 * v00;
        if qa <= 0.0 {
            return None;
        }
        let disc = qb * qb - 4.0 * qa * qc;
        if disc < 0.0 {
            return None;
        }
        // the larger root: where the rising lower bound crosses logit 0.9
        let x = (-qb + disc.sqrt()) / (2.0 * qa);
        let eta_lo = self.b0 + self.b1 * x - Z_95 * self.se(x);
        ((eta_lo - LOGIT_90).abs() < 1e-6 * (1.0 + LOGIT_90)).then(|| x.exp())
    }

    /// Standard error of the linear predictor at `x = ln a`.
    fn se(&self, x: f64) -> f64 {
        let [v00, v01, v11] = self.cov;
        (v00 + 2.0 * x * v01 + x * x * v11).max(0.0).sqrt()
    }
}

/// Fits the POD curve to `(size, hit)` outcomes (sizes > 0); `None` with fewer than 2 distinct
/// sizes or when the Newton steps do not converge.
pub fn fit(outcomes: &[(f64, bool)]) -> Option<PodFit> {
    let data: Vec<(f64, f64)> = outcomes
        .iter()
        .filter(|(a, _)| *a > 0.0 && a.is_finite())
        .map(|&(a, h)| (a.ln(), f64::from(u8::from(h))))
        .collect();
    let first = data.first()?.0;
    if !data.iter().any(|(x, _)| (x - first).abs() > 1e-12) {
        return None;
    }
    let (mut b0, mut b1) = (0.0f64, 0.0f64);
    for _ in 0..200 {
        let (_, [i00, i01, i11]) = information(&data, b0, b1)?;
        // Firth's modified score
        let (mut u0, mut u1) = (0.0, 0.0);
        for &(x, y) in &data {
            let p = logistic(b0 + b1 * x);
            let w = p * (1.0 - p);
            let h = w * (i00 + 2.0 * x * i01 + x * x * i11);
            let r = y - p + h * (0.5 - p);
            u0 += r;
            u1 += r * x;
        }
        let (d0, d1) = (i00 * u0 + i01 * u1, i01 * u0 + i11 * u1);
        // halve long steps: the modified likelihood is concave, but a step can overshoot
        let scale = (1.0f64).min(5.0 / d0.abs().max(d1.abs()).max(1e-300));
        b0 += scale * d0;
        b1 += scale * d1;
        if (scale * d0).abs() < 1e-10 && (scale * d1).abs() < 1e-10 {
            let (_, cov) = information(&data, b0, b1)?;
            return Some(PodFit { b0, b1, cov });
        }
    }
    None
}

/// `XᵀWX` and its inverse at `(b0, b1)`, each as `[00, 01, 11]`; `None` when singular.
fn information(data: &[(f64, f64)], b0: f64, b1: f64) -> Option<([f64; 3], [f64; 3])> {
    let (mut a, mut b, mut c) = (0.0, 0.0, 0.0);
    for &(x, _) in data {
        let p = logistic(b0 + b1 * x);
        let w = p * (1.0 - p);
        a += w;
        b += w * x;
        c += w * x * x;
    }
    let det = a * c - b * b;
    (det > 0.0 && det.is_finite()).then(|| ([a, b, c], [c / det, -b / det, a / det]))
}

fn logistic(eta: f64) -> f64 {
    1.0 / (1.0 + (-eta).exp())
}

/// The exact one-sided upper `1 − alpha` confidence bound of a rate with `k` events in `n` trials
/// (Clopper–Pearson): the `p` at which `P(X ≤ k) = alpha` for `X ~ B(n, p)`; 1 when `k = n`.
pub fn clopper_pearson_upper(k: u64, n: u64, alpha: f64) -> f64 {
    if n == 0 || k >= n {
        return 1.0;
    }
    let (mut lo, mut hi) = (k as f64 / n as f64, 1.0f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if binomial_cdf(k, n, mid) > alpha {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// `P(X ≤ k)` for `X ~ B(n, p)`, summed in log space.
fn binomial_cdf(k: u64, n: u64, p: f64) -> f64 {
    if p <= 0.0 {
        return 1.0;
    }
    if p >= 1.0 {
        return if k >= n { 1.0 } else { 0.0 };
    }
    let (lp, lq) = (p.ln(), (1.0 - p).ln());
    let mut log_choose = 0.0f64; // ln C(n, 0)
    let mut sum = 0.0f64;
    for i in 0..=k {
        if i > 0 {
            log_choose += ((n - i + 1) as f64).ln() - (i as f64).ln();
        }
        sum += (log_choose + i as f64 * lp + (n - i) as f64 * lq).exp();
    }
    sum.min(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Outcomes drawn from a known logistic curve with a fixed generator.
    fn drawn(b0: f64, b1: f64, sizes: &[f64], per_size: usize) -> Vec<(f64, bool)> {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut out = Vec::new();
        for &a in sizes {
            for _ in 0..per_size {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                let u = (state >> 11) as f64 / (1u64 << 53) as f64;
                out.push((a, u < logistic(b0 + b1 * a.ln())));
            }
        }
        out
    }

    #[test]
    fn a_known_curve_is_recovered_and_its_bound_lies_above_a90() {
        // a50 = 0.05, slope 4 on ln a: a90 = 0.05·e^{2.197/4} = 0.0866
        let (b1, a50) = (4.0, 0.05f64);
        let b0 = -b1 * a50.ln();
        let sizes = [0.01, 0.02, 0.03, 0.05, 0.07, 0.1, 0.15, 0.2, 0.3];
        let f = fit(&drawn(b0, b1, &sizes, 200)).expect("a fit");
        let a90 = f.size_at(0.9).unwrap();
        assert!((f.size_at(0.5).unwrap() / a50 - 1.0).abs() < 0.1, "{f:?}");
        assert!((a90 / 0.0866 - 1.0).abs() < 0.1, "{a90}");
        let bound = f.a90_95().unwrap();
        assert!(bound > a90 && bound < 1.3 * a90, "{bound} {a90}");
        assert!((f.pod_lower_95(bound) - 0.9).abs() < 1e-6);
        // fewer recordings: a wider bound
        let small = fit(&drawn(b0, b1, &sizes, 8)).unwrap();
        assert!(small.a90_95().unwrap() / small.size_at(0.9).unwrap() > bound / a90);
    }

    #[test]
    fn separated_hits_and_misses_give_a_finite_curve() {
        let mut data = Vec::new();
        for &a in &[0.005, 0.01, 0.02] {
            data.extend([(a, false); 6]);
        }
        for &a in &[0.03, 0.05, 0.1] {
            data.extend([(a, true); 6]);
        }
        let f = fit(&data).expect("Firth's fit stays finite");
        let (a50, a90, bound) = (f.size_at(0.5).unwrap(), f.size_at(0.9).unwrap(), f.a90_95().unwrap());
        assert!(a50 > 0.02 && a50 < 0.03, "{a50}");
        assert!(a90 > a50 && bound > a90 && bound < 0.2, "{a90} {bound}");
    }

    #[test]
    fn no_growth_with_size_has_no_a90() {
        let data: Vec<(f64, bool)> = [0.01, 0.1, 0.3].iter().flat_map(|&a| [(a, true), (a, false)]).collect();
        let f = fit(&data).unwrap();
        assert!(f.a90_95().is_none(), "{f:?}");
        assert!(fit(&[(0.1, true), (0.1, false)]).is_none());
    }

    #[test]
    fn clopper_pearson_matches_its_closed_forms() {
        // none in n: 1 − α^{1/n}
        for n in [10u64, 100, 500] {
            let exact = 1.0 - 0.05f64.powf(1.0 / n as f64);
            assert!((clopper_pearson_upper(0, n, 0.05) - exact).abs() < 1e-9, "{n}");
        }
        assert!((clopper_pearson_upper(0, 500, 0.05) - 0.00597).abs() < 1e-5);
        // one in 100: 0.0466 (tables)
        assert!((clopper_pearson_upper(1, 100, 0.05) - 0.0466).abs() < 2e-4);
        assert_eq!(clopper_pearson_upper(5, 5, 0.05), 1.0);
    }
}
