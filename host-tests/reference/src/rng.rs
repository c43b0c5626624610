//! Seeded noise source: xoshiro256++ seeded through SplitMix64, Gaussian by Box–Muller.
//!
//! Written here with integer and `f64` operations only, and seeded by the core's SplitMix64
//! ([`ema_monitor::optimizer::rng::splitmix64`], the one copy in the project), so that a
//! recording depends only on the seed and this code: the same seed gives the same file on every
//! platform and with every crate version.

use ema_monitor::optimizer::rng::splitmix64;

/// Deterministic pseudo-random generator.
#[derive(Clone, Debug)]
pub struct NoiseRng {
    s: [u64; 4],
    spare: Option<f64>,
}

impl NoiseRng {
    /// Generator for `seed` (any value, 0 included).
    pub fn new(seed: u64) -> Self {
        let mut x = seed;
        let s = [splitmix64(&mut x), splitmix64(&mut x), splitmix64(&mut x), splitmix64(&mut x)];
        Self { s, spare: None }
    }

    /// Next 64 random bits (xoshiro256++).
    pub fn next_u64(&mut self) -> u64 {
        let s = &mut self.s;
        let result = s[0].wrapping_add(s[3]).rotate_left(23).wrapping_add(s[0]);
        let t = s[1] << 17;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(45);
        result
    }

    /// Uniform in `(0, 1]`.
    pub fn uniform(&mut self) -> f64 {
        ((self.next_u64() >> 11) as f64 + 1.0) * (1.0 / (1u64 << 53) as f64)
    }

    /// Standard normal deviate.
    pub fn gaussian(&mut self) -> f64 {
        if let Some(z) = self.spare.take() {
            return z;
        }
        let r = (-2.0 * self.uniform().ln()).sqrt();
        let a = core::f64::consts::TAU * self.uniform();
        self.spare = Some(r * a.sin());
        r * a.cos()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaussian_moments_and_determinism() {
        let mut a = NoiseRng::new(7);
        let mut b = NoiseRng::new(7);
        let n = 200_000;
        let (mut m, mut v) = (0.0, 0.0);
        for _ in 0..n {
            let z = a.gaussian();
            assert_eq!(z, b.gaussian());
            m += z;
            v += z * z;
        }
        m /= n as f64;
        v = v / n as f64 - m * m;
        assert!(m.abs() < 0.01, "mean {m}");
        assert!((v - 1.0).abs() < 0.01, "variance {v}");
        assert_ne!(NoiseRng::new(8).next_u64(), NoiseRng::new(7).next_u64());
    }
}
