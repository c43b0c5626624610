//! The Cramér–Rao bounds the programs share: finite-difference sensitivities of the monitor
//! model's expected current per window sample, and the weighted least-squares covariance of
//! the fitness's estimator,
//!
//! ```text
//! C = σ²·(SᵀVS)⁻¹ (SᵀV²S) (SᵀVS)⁻¹,   bound_j = √C_jj
//! ```
//!
//! (for `V = I` the Cramér–Rao bound `σ²(SᵀS)⁻¹` of the Fisher information `SᵀS/σ²`).

/// The sensitivities of `model`'s series to each of the eight fault parameters at `point`:
/// central differences of `h`, one-sided at the bounds of `[0, 1]`.
pub fn fault_sensitivities(point: [f32; 8], h: f32, model: impl Fn([f32; 8]) -> Vec<f64>) -> Vec<Vec<f64>> {
    (0..8)
        .map(|j| {
            let (mut up, mut down) = (point, point);
            up[j] = (up[j] + h).min(1.0);
            down[j] = (down[j] - h).max(0.0);
            let span = f64::from(up[j] - down[j]);
            let (a, b) = (model(up), model(down));
            a.iter().zip(&b).map(|(x, y)| (x - y) / span).collect()
        })
        .collect()
}

/// The bounds of the first `N` parameters of `sens` (one series per parameter, one value per
/// window sample), the samples weighted by `weight`, for a window-sample noise `sigma_a`; `None`
/// when the information matrix is singular.
pub fn sandwich_bounds<const N: usize>(sens: &[Vec<f64>], weight: &[f64], sigma_a: f64) -> Option<[f64; N]> {
    let sens = sens.get(..N)?;
    let mut info = [[0.0; N]; N];
    let mut middle = [[0.0; N]; N];
    for (i, w) in weight.iter().enumerate() {
        for a in 0..N {
            for b in 0..N {
                let p = sens[a][i] * sens[b][i];
                info[a][b] += w * p;
                middle[a][b] += w * w * p;
            }
        }
    }
    let inv = invert(info)?;
    let cov = mul(&mul(&inv, &middle), &inv);
    Some(std::array::from_fn(|j| sigma_a * cov[j][j].max(0.0).sqrt()))
}

/// The inverse of `m` (Gauss–Jordan with partial pivoting); `None` when a pivot vanishes.
pub fn invert<const N: usize>(m: [[f64; N]; N]) -> Option<[[f64; N]; N]> {
    let mut a = m;
    let mut inv = [[0.0; N]; N];
    for (i, row) in inv.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    for c in 0..N {
        let p = (c..N).max_by(|&x, &y| a[x][c].abs().total_cmp(&a[y][c].abs()))?;
        if a[p][c].abs() < 1e-300 {
            return None;
        }
        a.swap(c, p);
        inv.swap(c, p);
        let d = a[c][c];
        for j in 0..N {
            a[c][j] /= d;
            inv[c][j] /= d;
        }
        for r in 0..N {
            if r != c {
                let f = a[r][c];
                for j in 0..N {
                    a[r][j] -= f * a[c][j];
                    inv[r][j] -= f * inv[c][j];
                }
            }
        }
    }
    Some(inv)
}

/// The product `a·b`.
pub fn mul<const N: usize>(a: &[[f64; N]; N], b: &[[f64; N]; N]) -> [[f64; N]; N] {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..N).map(|k| a[i][k] * b[k][j]).sum()))
}
