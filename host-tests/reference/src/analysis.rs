//! Small signal helpers shared by the tests and the command line: windows, moving averages, RMS,
//! equivalent currents and angle-domain (order) components.

use crate::electrical::emf_shapes;

/// Equivalent current, torque-projection form (docs/model.md): `I_3eq = ½·Σ f_j(θ_e)·i_j`,
/// ideal 120° shapes. Equals `T_m/(2 k_0)` in a healthy motor.
pub fn equivalent_current_projection(theta_e_rad: f64, i: [f64; 3]) -> f64 {
    let f = emf_shapes(theta_e_rad, core::f64::consts::PI / 6.0);
    0.5 * (f[0] * i[0] + f[1] * i[1] + f[2] * i[2])
}

/// Equivalent current, magnitude form (docs/model.md): `I_3eq = ½·(|i_a| + |i_b| + |i_c|)·sign`.
pub fn equivalent_current_magnitude(i: [f64; 3], sign: f64) -> f64 {
    0.5 * (i[0].abs() + i[1].abs() + i[2].abs()) * if sign < 0.0 { -1.0 } else { 1.0 }
}

/// Centred moving average over `width` samples (shrinking at the ends).
pub fn moving_average(x: &[f64], width: usize) -> Vec<f64> {
    let n = x.len();
    let half = width / 2;
    let mut prefix = Vec::with_capacity(n + 1);
    prefix.push(0.0);
    for v in x {
        prefix.push(prefix[prefix.len() - 1] + v);
    }
    (0..n)
        .map(|k| {
            let a = k.saturating_sub(half);
            let b = (k + width - half).min(n);
            (prefix[b] - prefix[a]) / (b - a) as f64
        })
        .collect()
}

/// Root mean square of `x` (0 for an empty slice).
pub fn rms(x: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
}

/// RMS of `a − b` over the common length.
pub fn rms_difference(a: &[f64], b: &[f64]) -> f64 {
    let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).collect();
    rms(&d)
}

/// Mean of `x` (0 for an empty slice).
pub fn mean(x: &[f64]) -> f64 {
    if x.is_empty() {
        0.0
    } else {
        x.iter().sum::<f64>() / x.len() as f64
    }
}

/// Indices `k` with `t_start ≤ time[k] < t_end`.
pub fn window(time_s: &[f64], t_start: f64, t_end: f64) -> core::ops::Range<usize> {
    let a = time_s.partition_point(|&t| t < t_start);
    let b = time_s.partition_point(|&t| t < t_end);
    a..b
}

/// Complex amplitude (cosine, sine) of the component of `x` at `order` cycles per unit of `angle`
/// (least-squares projection after removing the mean): `x ≈ m + a·cos(order·θ) + b·sin(order·θ)`.
pub fn order_component(angle: &[f64], x: &[f64], order: f64) -> (f64, f64) {
    let m = mean(x);
    let (mut cc, mut ss, mut cs, mut xc, mut xs) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (th, v) in angle.iter().zip(x) {
        let (s, c) = (order * th).sin_cos();
        cc += c * c;
        ss += s * s;
        cs += c * s;
        xc += (v - m) * c;
        xs += (v - m) * s;
    }
    let det = cc * ss - cs * cs;
    if det.abs() < 1e-300 {
        return (0.0, 0.0);
    }
    ((xc * ss - xs * cs) / det, (xs * cc - xc * cs) / det)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn helpers() {
        let th: Vec<f64> = (0..1000).map(|k| k as f64 * 0.01).collect();
        let x: Vec<f64> = th.iter().map(|t| 1.0 + 0.3 * (9.0 * t).cos() - 0.2 * (9.0 * t).sin()).collect();
        let (a, b) = order_component(&th, &x, 9.0);
        assert!((a - 0.3).abs() < 1e-3 && (b + 0.2).abs() < 1e-3, "{a} {b}");
        assert_eq!(moving_average(&[1.0, 2.0, 3.0], 3), vec![1.5, 2.0, 2.5]);
        assert!((rms(&[3.0, -3.0]) - 3.0).abs() < 1e-12);
        assert_eq!(window(&[0.0, 0.1, 0.2, 0.3], 0.1, 0.3), 1..3);
        assert_eq!(equivalent_current_magnitude([1.0, -1.0, 0.0], -2.0), -1.0);
        assert!((equivalent_current_projection(core::f64::consts::FRAC_PI_3, [2.0, -2.0, 0.0]) - 2.0).abs() < 1e-12);
    }
}
