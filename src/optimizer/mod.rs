//! Memory-bounded, step-wise optimizers (contract first, algorithms in their own files).
//!
//! The contract follows argmin (`CostFunction` / `Solver::next_iter`) without an allocator:
//! - an [`Objective`] maps a candidate `x ∈ R^D` to a cost (lower is better);
//! - an optimizer owns all its storage, sized by const generics (`P` individuals × `D` parameters);
//! - [`Optimizer::step`] does at most ONE objective evaluation, so firmware can budget work per
//!   control cycle; [`run`] loops until termination or an evaluation budget;
//! - every optimizer keeps its best point, its counters, its status and its stopping rule in one
//!   shared search state (`search_state.rs`), so the four obey the same bookkeeping, and one
//!   contract-test suite (`tests.rs`) checks that contract against all four.
//!
//! Invalid costs: a non-finite cost ranks worst (it is treated as `f32::INFINITY`), never a panic.

pub mod de;
pub mod ga;
pub mod pattern;
pub mod pso;
pub mod rng;
mod search_state;
#[cfg(test)]
mod tests;

pub use search_state::MAX_STALL_ITERATIONS;
pub(crate) use search_state::{NoTarget, SearchState, Stopping};

/// A function to minimise over `D` parameters.
pub trait Objective<const D: usize> {
    /// Cost of `x` (lower is better). `abandon_above` is the value the evaluation must beat to matter
    /// (`f32::INFINITY` when it must run to the end): an objective MAY stop early and return any value
    /// `> abandon_above` as soon as it knows its result will exceed it (early abandoning).
    fn cost(&mut self, x: &[f32; D], abandon_above: f32) -> f32;
}

/// Box bounds of the search space; a `periodic` parameter wraps around instead of being clamped.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Bounds<const D: usize> {
    /// Lower bound per parameter.
    pub lower: [f32; D],
    /// Upper bound per parameter (`> lower`).
    pub upper: [f32; D],
    /// Parameters that live on a circle (the eccentricity phase).
    pub periodic: [bool; D],
}

impl<const D: usize> Bounds<D> {
    /// The unit box `[0, 1]^D`, nothing periodic.
    pub const fn unit() -> Self {
        Self { lower: [0.0; D], upper: [1.0; D], periodic: [false; D] }
    }

    /// The centre of the box, `(lᵢ + uᵢ)/2` per parameter: the best point an optimizer reports
    /// before its first evaluation.
    pub fn centre(&self) -> [f32; D] {
        let mut c = [0.0; D];
        for (d, x) in c.iter_mut().enumerate() {
            *x = 0.5 * (self.lower[d] + self.upper[d]);
        }
        c
    }

    /// `true` when every bound is finite and `lower < upper`.
    pub fn is_valid(&self) -> bool {
        self.lower.iter().zip(self.upper.iter()).all(|(l, u)| l.is_finite() && u.is_finite() && l < u)
    }

    /// The interval of parameter `i`; `None` when `i ≥ D` (there is no such parameter).
    pub fn interval(&self, i: usize) -> Option<Interval> {
        let (&lower, &upper, &periodic) = (self.lower.get(i)?, self.upper.get(i)?, self.periodic.get(i)?);
        Some(Interval { lower, upper, periodic })
    }

    /// The interval of every parameter, in order: zipped with a point's coordinates, each
    /// coordinate meets its own interval, with no index to get wrong.
    pub fn intervals(&self) -> impl Iterator<Item = Interval> + '_ {
        let lower_upper = self.lower.iter().zip(&self.upper);
        lower_upper.zip(&self.periodic).map(|((&lower, &upper), &periodic)| Interval { lower, upper, periodic })
    }

    /// Brings every coordinate of `x` into the box (see [`Interval::enforce`]).
    pub fn enforce_point(&self, x: &mut [f32; D]) {
        for (xi, interval) in x.iter_mut().zip(self.intervals()) {
            interval.enforce(xi);
        }
    }
}

/// The range of one parameter of [`Bounds`]: `[lower, upper]`, a circle when `periodic`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Interval {
    /// Lower bound.
    pub lower: f32,
    /// Upper bound (`> lower`).
    pub upper: f32,
    /// The parameter lives on a circle (the eccentricity phase).
    pub periodic: bool,
}

impl Interval {
    /// Signed difference `to − from`; for a periodic parameter the shortest way round the circle,
    /// in `[−span/2, span/2]` (so a swarm or a crossover can meet across the wrap point).
    pub fn delta(&self, from: f32, to: f32) -> f32 {
        let d = to - from;
        if self.periodic {
            let span = self.upper - self.lower;
            d - span * libm::roundf(d / span)
        } else {
            d
        }
    }

    /// Brings `x` back into the interval: wraps a periodic parameter, clamps another.
    /// Returns `true` when the value was clamped (not wrapped), so the caller can damp its velocity.
    pub fn enforce(&self, x: &mut f32) -> bool {
        let (lo, hi) = (self.lower, self.upper);
        if !x.is_finite() {
            *x = 0.5 * (lo + hi);
            return true;
        }
        if self.periodic {
            let span = hi - lo;
            let mut y = lo + fmod_exact(*x - lo, span);
            if y < lo {
                y += span;
            }
            if y >= hi {
                y = lo;
            }
            *x = y;
            false
        } else if *x < lo {
            *x = lo;
            true
        } else if *x > hi {
            *x = hi;
            true
        } else {
            false
        }
    }
}

/// Puts `guesses` (each brought into `bounds`) in place of the first starting points: the
/// optimizers' `with_initial_guesses`. Extra guesses beyond the population are ignored.
pub(crate) fn place_guesses<const D: usize>(bounds: &Bounds<D>, points: &mut [[f32; D]], guesses: &[[f32; D]]) {
    for (point, guess) in points.iter_mut().zip(guesses) {
        *point = *guess;
        bounds.enforce_point(point);
    }
}

/// Why an optimizer stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum TerminationReason {
    /// The iteration (generation) limit was reached.
    MaxIterations,
    /// The best cost improved by less than the function tolerance over the stall window.
    FunctionTolerance,
    /// The best cost reached the target cost.
    TargetReached,
}

/// What one [`Optimizer::step`] left behind.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SearchStatus {
    /// More work to do.
    Running,
    /// Finished; further steps do nothing.
    Done(TerminationReason),
}

/// Why a configuration was refused (checked once at construction; the hot loop has no checks).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ConfigError {
    /// Bounds not finite or `lower >= upper`.
    Bounds,
    /// A coefficient is negative or not finite.
    Coefficient,
    /// Zero iterations, a stall window of zero or above [`MAX_STALL_ITERATIONS`], a negative or NaN tolerance,
    /// or a NaN / `+∞` target cost.
    Termination,
    /// The optimizer is not built into this binary (the core's cargo features `ga` and `de`).
    NotBuilt,
}

impl core::fmt::Display for ConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            ConfigError::Bounds => "bounds must be finite with lower < upper",
            ConfigError::Coefficient => "optimizer coefficients must be finite and non-negative",
            ConfigError::Termination => "iterations and stall window must be > 0 and the tolerance >= 0",
            ConfigError::NotBuilt => "this optimizer is not built in (cargo features `ga`, `de`)",
        })
    }
}

impl core::error::Error for ConfigError {}

/// Common step-wise interface of the population optimizers.
pub trait Optimizer<const D: usize> {
    /// Does at most one objective evaluation (plus the bookkeeping that follows it).
    fn step<O: Objective<D>>(&mut self, objective: &mut O) -> SearchStatus;
    /// Best point found so far and its cost (`f32::INFINITY` before the first evaluation).
    fn best(&self) -> (&[f32; D], f32);
    /// Objective evaluations done so far.
    fn evaluations(&self) -> u32;
    /// Completed iterations (generations).
    fn iterations(&self) -> u32;
}

/// Steps `optimizer` until it finishes or `max_evaluations` more evaluations are spent.
/// Returns the final status (`Running` when the budget ran out first).
pub fn run<const D: usize, S: Optimizer<D>, O: Objective<D>>(
    optimizer: &mut S,
    objective: &mut O,
    max_evaluations: u32,
) -> SearchStatus {
    let start = optimizer.evaluations();
    loop {
        let status = optimizer.step(objective);
        if let SearchStatus::Done(_) = status {
            return status;
        }
        if optimizer.evaluations().wrapping_sub(start) >= max_evaluations {
            return SearchStatus::Running;
        }
    }
}

/// `x mod y` with the sign of `x` (C's `fmod`), by binary long division of the significands:
/// shifts and subtractions only. `fmod` is exact (its result is representable), so this returns
/// the bits of `libm::fmodf`; it is used instead because libm's version keeps a remainder by a
/// divisor the compiler cannot prove non-zero, a panic path the on-board code must not link
/// (`scripts/prove-no-panic`). After musl's `fmodf`. NaN when `x` is not finite or `y` is NaN or 0.
fn fmod_exact(x: f32, y: f32) -> f32 {
    let (mut ux, mut uy) = (x.to_bits(), y.to_bits());
    let (mut ex, mut ey) = (((ux >> 23) & 0xff) as i32, ((uy >> 23) & 0xff) as i32);
    let sign = ux & 0x8000_0000;
    if uy << 1 == 0 || y.is_nan() || ex == 0xff {
        #[allow(clippy::eq_op)] // 0/0 or ∞/∞: the NaN libm returns in these cases
        return (x * y) / (x * y);
    }
    if ux << 1 <= uy << 1 {
        return if ux << 1 == uy << 1 { 0.0 * x } else { x };
    }
    // Significands with the implicit bit; subnormals normalized.
    (ux, ex) = normalized_significand(ux, ex);
    (uy, ey) = normalized_significand(uy, ey);
    while ex > ey {
        let d = ux.wrapping_sub(uy);
        if d >> 31 == 0 {
            if d == 0 {
                return 0.0 * x;
            }
            ux = d;
        }
        ux <<= 1;
        ex -= 1;
    }
    let d = ux.wrapping_sub(uy);
    if d >> 31 == 0 {
        if d == 0 {
            return 0.0 * x;
        }
        ux = d;
    }
    while ux >> 23 == 0 {
        ux <<= 1;
        ex -= 1;
    }
    if ex > 0 {
        ux = (ux - (1 << 23)) | ((ex as u32) << 23);
    } else {
        ux = ux.wrapping_shr((1 - ex) as u32);
    }
    f32::from_bits(ux | sign)
}

/// The significand of the finite, non-zero `f32` bits `u` of biased exponent `e`, with its
/// implicit bit at bit 23 (a subnormal's shifted up, its exponent lowered to match).
fn normalized_significand(u: u32, e: i32) -> (u32, i32) {
    if e != 0 {
        return ((u & 0x007f_ffff) | (1 << 23), e);
    }
    let mut e = e;
    let mut i = u << 9;
    while i >> 31 == 0 && i != 0 {
        e -= 1;
        i <<= 1;
    }
    (u.wrapping_shl((1 - e) as u32), e)
}

#[cfg(test)]
mod fmod_tests {
    use super::fmod_exact;

    #[test]
    fn fmod_exact_has_the_bits_of_libm() {
        let mut state = 0x9e37_79b9u32;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            f32::from_bits(state)
        };
        let special = [0.0, -0.0, 1.0, -1.0, core::f32::consts::TAU, 1e-40, -3e-39, 1e30, f32::MIN_POSITIVE];
        for &x in &special {
            for &y in &special {
                let (a, b) = (fmod_exact(x, y), libm::fmodf(x, y));
                assert!(a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()), "{x} mod {y}: {a} vs {b}");
            }
        }
        for _ in 0..200_000 {
            let (x, y) = (next(), next());
            let (a, b) = (fmod_exact(x, y), libm::fmodf(x, y));
            assert!(a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()), "{x} mod {y}: {a} vs {b}");
            let (x, y) = (next() * 1e-30, core::f32::consts::TAU);
            let (a, b) = (fmod_exact(x, y), libm::fmodf(x, y));
            assert!(a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()), "{x} mod {y}: {a} vs {b}");
        }
    }
}
