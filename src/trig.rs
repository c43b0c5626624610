//! Single-precision sine and cosine for the model's hot loop.
//!
//! Why not `libm::sincosf`: musl's `sinf`/`cosf` (ported by `libm`) evaluate their kernels in
//! **double** precision. A Cortex-M4F has a single-precision FPU only, so every call runs
//! soft-float `__aeabi_dmul`/`__aeabi_dadd`, about 2 000 instructions per model step
//! (`docs/decisions/0011-libm-and-own-trig.md`).
//! This module uses f32 arithmetic only (still bit-identical on every target: IEEE-754 `+ − ×`,
//! no fused multiply-add, no platform library).
//!
//! Method: Cody–Waite reduction `r = x − n·π/2` with `π/2` split in three f32 parts (exact
//! products for |n| < 2^12), then minimax polynomials on `[−π/4, π/4]` (the coefficients of
//! Cephes `sinf.c`/`cosf.c`, S. L. Moshier, also used by many f32 libms) and the quadrant
//! identities. [`MAX_ERROR`] is the absolute error bound against `libm` checked by the tests over
//! `|x| ≤ 1000`, wider than the model ever asks (it wraps its angles into `[−2π, 2π]`).

/// Largest absolute error against the double-precision-kernel `libm` results, `|x| ≤ 1000`.
pub const MAX_ERROR: f32 = 2.0e-6;

const FRAC_2_PI: f32 = core::f32::consts::FRAC_2_PI;
// π/2 = DP1 + DP2 + DP3 (Cephes: 12-bit-exact leading parts).
const DP1: f32 = f32::from_bits(0x3fc9_0000); // 1.5703125
const DP2: f32 = f32::from_bits(0x39fd_a000); // 4.837512969970703125e-4
const DP3: f32 = f32::from_bits(0x33a2_2169); // 7.54978995489e-8

/// `(sin x, cos x)`.
#[cfg_attr(not(target_os = "none"), inline)]
pub fn sin_cos(x: f32) -> (f32, f32) {
    let q = x * FRAC_2_PI;
    // round to nearest without libm: the model's arguments are far below 2^23
    let n = if q >= 0.0 { (q + 0.5) as i32 } else { (q - 0.5) as i32 };
    let nf = n as f32;
    let r = ((x - nf * DP1) - nf * DP2) - nf * DP3;
    let z = r * r;
    let s = ((-1.951_529_6e-4 * z + 8.332_161e-3) * z - 1.666_665_5e-1) * z * r + r;
    let c = ((2.443_315_7e-5 * z - 1.388_731_6e-3) * z + 4.166_664_6e-2) * z * z - 0.5 * z + 1.0;
    match n & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// `sin x`.
#[cfg_attr(not(target_os = "none"), inline)]
pub fn sin(x: f32) -> f32 {
    sin_cos(x).0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `(x, sin x, cos x)` from exact values.
    const TEST_VECTORS: &[(f32, f32, f32)] = &[
        (0.0, 0.0, 1.0),
        (core::f32::consts::FRAC_PI_6, 0.5, 0.866_025_4),
        (core::f32::consts::FRAC_PI_2, 1.0, 0.0),
        (core::f32::consts::PI, 0.0, -1.0),
        (-core::f32::consts::FRAC_PI_4, -core::f32::consts::FRAC_1_SQRT_2, core::f32::consts::FRAC_1_SQRT_2),
        (3.0 * core::f32::consts::FRAC_PI_2, -1.0, 0.0),
    ];

    #[test]
    fn vectors() {
        for &(x, s, c) in TEST_VECTORS {
            let (ss, cc) = sin_cos(x);
            assert!((ss - s).abs() < MAX_ERROR && (cc - c).abs() < MAX_ERROR, "x {x}: {ss} {cc} vs {s} {c}");
        }
    }

    #[test]
    fn against_libm_over_a_wide_range() {
        let mut worst = 0.0f32;
        for k in -1_000_000..=1_000_000 {
            let x = k as f32 * 1e-3;
            let (s, c) = sin_cos(x);
            let e = (s - libm::sinf(x)).abs().max((c - libm::cosf(x)).abs());
            assert!(e < MAX_ERROR, "x {x}: error {e}");
            worst = worst.max(e);
        }
        assert!(worst > 0.0);
    }
}
