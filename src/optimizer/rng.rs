//! A tiny seeded deterministic random number generator: xoshiro128++ seeded through SplitMix64.
//!
//! Origin: D. Blackman and S. Vigna, "Scrambled linear pseudorandom number generators", ACM TOMS 47(4), 2021,
//! reference code <https://prng.di.unimi.it/xoshiro128plusplus.c>; the seed is expanded by S. Vigna's
//! <https://prng.di.unimi.it/splitmix64.c>. Two SplitMix64 outputs `a`, `b` become the state
//! `[lo32(a), hi32(a), lo32(b), hi32(b)]`, which is what `rand_xoshiro::Xoshiro128PlusPlus::seed_from_u64`
//! does, so the two generators give the same stream for the same `u64` seed. SplitMix64 is a bijection of its
//! counter, so two consecutive outputs are never both zero and the all-zero state cannot occur.
//!
//! Only integer operations and `libm` are used: a seed produces the same numbers, bit for bit, on the host
//! and on the Cortex-M4F.
//!
//! Conversions:
//! - [`Rng::next_f32`]: the top 24 bits of a `u32` times 2⁻²⁴, i.e. every multiple of 2⁻²⁴ in `[0, 1)` with equal
//!   probability (exact in `f32`);
//! - [`Rng::below`]: D. Lemire's multiply-shift with rejection ("Fast random integer generation in an interval",
//!   ACM TOMACS 29(1), 2019), unbiased;
//! - [`Rng::normal`]: Box–Muller (one of the pair, the other is discarded), with `libm` `logf`, `sqrtf`, `cosf`.

use super::Bounds;

/// SplitMix64 increment (the golden ratio in 64-bit fixed point): the step of its counter, also
/// a good odd multiplier for spreading small keys (flight numbers) over the 64 bits before
/// [`splitmix64_mix`].
pub const SPLITMIX_GAMMA: u64 = 0x9e37_79b9_7f4a_7c15;

/// One SplitMix64 step: advances `state` by [`SPLITMIX_GAMMA`] and returns the next output,
/// [`splitmix64_mix`] of the new state.
pub const fn splitmix64(state: &mut u64) -> u64 {
    *state = state.wrapping_add(SPLITMIX_GAMMA);
    splitmix64_mix(*state)
}

/// SplitMix64's output function (its finaliser, a variant of MurmurHash3's `fmix64`): a
/// bijection of `u64` whose every output bit depends on every input bit. The host derives
/// independent seeds from keys with it (a flight's noise seed from the series seed and the
/// flight number), so those seeds are the same function as the optimizer's seeding.
pub const fn splitmix64_mix(z: u64) -> u64 {
    let z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    let z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// xoshiro128++: 128 bits of state, period 2¹²⁸ − 1, 32-bit outputs.
#[derive(Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Rng {
    s: [u32; 4],
}

impl Rng {
    /// Seeds the generator from a `u64` through SplitMix64 (any seed, including 0, is fine).
    pub const fn new(seed: u64) -> Self {
        let mut sm = seed;
        let a = splitmix64(&mut sm);
        let b = splitmix64(&mut sm);
        Self { s: [a as u32, (a >> 32) as u32, b as u32, (b >> 32) as u32] }
    }

    /// Uses `state` as the raw xoshiro128++ state; an all-zero state (a fixed point) is replaced by
    /// [`Rng::new(0)`](Rng::new).
    pub const fn from_state(state: [u32; 4]) -> Self {
        if state[0] == 0 && state[1] == 0 && state[2] == 0 && state[3] == 0 {
            Self::new(0)
        } else {
            Self { s: state }
        }
    }

    /// Next 32 random bits.
    pub fn next_u32(&mut self) -> u32 {
        let [s0, s1, s2, s3] = self.s;
        let result = s0.wrapping_add(s3).rotate_left(7).wrapping_add(s0);
        let t = s1 << 9;
        let s2 = s2 ^ s0;
        let s3 = s3 ^ s1;
        let s1 = s1 ^ s2;
        let s0 = s0 ^ s3;
        let s2 = s2 ^ t;
        let s3 = s3.rotate_left(11);
        self.s = [s0, s1, s2, s3];
        result
    }

    /// Uniform in `[0, 1)`: the top 24 bits scaled by 2⁻²⁴ (every value exactly representable).
    pub fn next_f32(&mut self) -> f32 {
        const SCALE: f32 = 1.0 / (1u32 << 24) as f32;
        (self.next_u32() >> 8) as f32 * SCALE
    }

    /// Uniform in `[lo, hi]` for `lo <= hi`: `lo + (hi − lo)·u`, then capped at `hi` because the product can
    /// round up to it. Finite inputs give a finite output.
    pub fn uniform(&mut self, lo: f32, hi: f32) -> f32 {
        let x = lo + (hi - lo) * self.next_f32();
        if x > hi {
            hi
        } else {
            x
        }
    }

    /// Uniform integer in `[0, n)`, unbiased (Lemire's method); `below(0)` returns 0.
    pub fn below(&mut self, n: u32) -> u32 {
        if n == 0 {
            return 0;
        }
        let mut m = u64::from(self.next_u32()) * u64::from(n);
        if (m as u32) < n {
            // 2^32 mod n: the number of low products that would over-represent some outputs.
            let threshold = n.wrapping_neg() % n;
            while (m as u32) < threshold {
                m = u64::from(self.next_u32()) * u64::from(n);
            }
        }
        (m >> 32) as u32
    }

    /// `true` with probability `p` (`p <= 0` never, `p >= 1` always).
    pub fn chance(&mut self, p: f32) -> bool {
        self.next_f32() < p
    }

    /// Fills `points` with a Latin-hypercube sample of `bounds`: along every parameter each of the `P` equal
    /// strata holds exactly one point, placed uniformly inside it; the strata are matched up across parameters by
    /// independent Fisher–Yates shuffles (M. D. McKay, R. J. Beckman, W. J. Conover, Technometrics 21(2), 1979).
    pub fn latin_hypercube<const P: usize, const D: usize>(&mut self, bounds: &Bounds<D>, points: &mut [[f32; D]; P]) {
        for (d, interval) in (0..D).zip(bounds.intervals()) {
            for (i, p) in points.iter_mut().enumerate() {
                p[d] = i as f32;
            }
            for i in (1..P).rev() {
                let j = (self.below(i as u32 + 1) as usize).min(i);
                let (a, b) = (points[i][d], points[j][d]);
                points[i][d] = b;
                points[j][d] = a;
            }
            let (lo, span) = (interval.lower, interval.upper - interval.lower);
            for p in points.iter_mut() {
                let mut x = lo + (p[d] + self.next_f32()) / P as f32 * span;
                interval.enforce(&mut x);
                p[d] = x;
            }
        }
    }

    /// Standard normal deviate (mean 0, variance 1), Box–Muller with `libm`; always finite (|z| < 5.8).
    pub fn normal(&mut self) -> f32 {
        // u1 in (0, 1] so the logarithm is finite.
        let u1 = 1.0 - self.next_f32();
        let u2 = self.next_f32();
        libm::sqrtf(-2.0 * libm::logf(u1)) * libm::cosf(core::f32::consts::TAU * u2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splitmix64_reference_vectors() {
        // From rand_xoshiro's test, "produced with the reference implementation" splitmix64.c (first 5 of 50).
        let mut state = 1_477_776_061_723_855_037;
        let expected: [u64; 5] = [
            1_985_237_415_132_408_290,
            2_979_275_885_539_914_483,
            13_511_426_838_097_143_398,
            8_488_337_342_461_049_707,
            15_141_737_807_933_549_159,
        ];
        for e in expected {
            assert_eq!(splitmix64(&mut state), e);
        }
    }

    #[test]
    fn xoshiro128plusplus_reference_vectors() {
        // State [1, 2, 3, 4]; values from the reference xoshiro128plusplus.c (also rand_xoshiro's test).
        let mut rng = Rng::from_state([1, 2, 3, 4]);
        let expected: [u32; 10] = [
            641,
            1_573_767,
            3_222_811_527,
            3_517_856_514,
            836_907_274,
            4_247_214_768,
            3_867_114_732,
            1_355_841_295,
            495_546_011,
            621_204_420,
        ];
        for e in expected {
            assert_eq!(rng.next_u32(), e);
        }
    }

    #[test]
    fn seeded_vectors() {
        // Computed once with the two reference C files compiled together (gcc, x86_64), seeding as documented.
        let cases: [(u64, [u32; 8]); 2] = [
            (0, [0x4653daa3, 0x73922b58, 0xb82b4add, 0xd9fabd3b, 0x3c8698c3, 0x1c9b58ff, 0xccac4646, 0x27e3fd16]),
            (42, [0x9d9452c1, 0x6909d440, 0x6148a68f, 0x54829a5b, 0xc648de34, 0xedc89aa6, 0xff162eb3, 0xab6356aa]),
        ];
        for (seed, expected) in cases {
            let mut rng = Rng::new(seed);
            for e in expected {
                assert_eq!(rng.next_u32(), e, "seed {seed}");
            }
        }
        // next_f32 is the top 24 bits of the same stream.
        let mut rng = Rng::new(0);
        assert_eq!(rng.next_f32(), (0x4653daa3u32 >> 8) as f32 / 16_777_216.0);
        assert_eq!(Rng::from_state([0; 4]), Rng::new(0));
    }

    /// Mean and variance of `n` draws.
    fn moments(n: usize, mut draw: impl FnMut() -> f64) -> (f64, f64) {
        let (mut s, mut s2) = (0.0, 0.0);
        for _ in 0..n {
            let x = draw();
            s += x;
            s2 += x * x;
        }
        let mean = s / n as f64;
        (mean, s2 / n as f64 - mean * mean)
    }

    #[test]
    fn next_f32_statistics() {
        const N: usize = 100_000;
        let mut rng = Rng::new(7);
        let mut lo = 1.0f32;
        let mut hi = 0.0f32;
        let (mean, var) = moments(N, || {
            let x = rng.next_f32();
            assert!((0.0..1.0).contains(&x));
            lo = lo.min(x);
            hi = hi.max(x);
            f64::from(x)
        });
        // U(0,1): mean 1/2, variance 1/12; standard error of the mean 0.29/sqrt(N) ≈ 9e-4 → 5σ bound.
        assert!((mean - 0.5).abs() < 5e-3, "mean {mean}");
        assert!((var - 1.0 / 12.0).abs() < 2e-3, "variance {var}");
        assert!(lo < 1e-4 && hi > 1.0 - 1e-4, "range [{lo}, {hi}]");
    }

    #[test]
    fn uniform_statistics_and_range() {
        const N: usize = 100_000;
        let mut rng = Rng::new(8);
        let (mean, var) = moments(N, || {
            let x = rng.uniform(-3.0, 5.0);
            assert!((-3.0..=5.0).contains(&x));
            f64::from(x)
        });
        assert!((mean - 1.0).abs() < 0.04, "mean {mean}");
        assert!((var - 64.0 / 12.0).abs() < 0.1, "variance {var}");
        // Degenerate interval.
        assert_eq!(rng.uniform(2.0, 2.0), 2.0);
    }

    #[test]
    fn below_is_uniform_and_in_range() {
        const N: usize = 100_000;
        let mut rng = Rng::new(9);
        let mut counts = [0u32; 7];
        for _ in 0..N {
            let k = rng.below(7) as usize;
            counts[k] += 1;
        }
        // Chi-square with 6 degrees of freedom: P(χ² > 22.46) = 0.001.
        let e = N as f64 / 7.0;
        let chi2: f64 = counts.iter().map(|&c| (f64::from(c) - e).powi(2) / e).sum();
        assert!(chi2 < 22.46, "chi2 {chi2}, counts {counts:?}");
        assert_eq!(rng.below(0), 0);
        assert_eq!(rng.below(1), 0);
        // A large n that triggers rejection now and then.
        let n = 3_000_000_000;
        for _ in 0..1000 {
            assert!(rng.below(n) < n);
        }
    }

    #[test]
    fn normal_statistics() {
        const N: usize = 100_000;
        let mut rng = Rng::new(10);
        let (mean, var) = moments(N, || {
            let z = rng.normal();
            assert!(z.is_finite() && z.abs() < 6.0);
            f64::from(z)
        });
        // Standard error of the mean 1/sqrt(N) ≈ 3.2e-3; of the variance sqrt(2/N) ≈ 4.5e-3 → ~5σ bounds.
        assert!(mean.abs() < 0.016, "mean {mean}");
        assert!((var - 1.0).abs() < 0.025, "variance {var}");
    }

    #[test]
    fn latin_hypercube_fills_every_stratum_once() {
        const P: usize = 10;
        let bounds = Bounds { lower: [-1.0, 10.0, 0.0], upper: [1.0, 20.0, 6.0], periodic: [false, false, true] };
        let mut points = [[0.0f32; 3]; P];
        let mut rng = Rng::new(12);
        rng.latin_hypercube(&bounds, &mut points);
        for d in 0..3 {
            let mut seen = [false; P];
            for p in &points {
                let u = (p[d] - bounds.lower[d]) / (bounds.upper[d] - bounds.lower[d]);
                assert!((0.0..1.0).contains(&u), "{p:?}");
                let k = (u * P as f32) as usize;
                assert!(!seen[k], "stratum {k} of parameter {d} twice");
                seen[k] = true;
            }
        }
        // Parameters are not all in the same stratum order (a shuffle per column).
        let order =
            |d: usize| points.map(|p| ((p[d] - bounds.lower[d]) / (bounds.upper[d] - bounds.lower[d]) * 10.0) as u8);
        assert_ne!(order(0), order(1));
    }

    #[test]
    fn chance_frequency() {
        let mut rng = Rng::new(11);
        let hits = (0..100_000).filter(|_| rng.chance(0.125)).count();
        // Binomial sd = sqrt(N p (1-p)) ≈ 105 → 5σ ≈ 520.
        assert!((hits as i64 - 12_500).abs() < 520, "hits {hits}");
        assert!(!rng.chance(0.0));
        assert!(rng.chance(1.0));
    }
}
