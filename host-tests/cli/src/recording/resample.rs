//! The recorded channels on the monitor's grid: from a faster file, band-limited with a
//! Kaiser-windowed sinc kernel evaluated at each output time; from a slower one, linearly
//! interpolated.
//!
//! **Faster file (decimation).** An output sample at time `u` is `y(u) = Σ_i x_i · h(u − t_i) / Σ_i h(u − t_i)`, the input
//! samples `x_i` at their grid times `t_i` ([`super::grid`]), with
//! `h(τ) = sinc(2 f_c τ) · w_K(τ / τ_max)`: an ideal low-pass of cut-off `f_c` truncated to
//! [`ZERO_CROSSINGS`] zero crossings each side (`τ_max = ZERO_CROSSINGS / (2 f_c)`) by a Kaiser
//! window of shape [`KAISER_BETA`] (side lobes near −90 dB). The cut-off is the output's Nyquist
//! frequency ([`CUTOFF`] × 10 kHz): the anti-aliasing filter of the decimation.
//! Dividing by `Σ h` makes the gain at DC exactly one for every output time, also where the kernel
//! runs past either end of the file. At 100 kHz in, a kernel spans 480 input samples.
//!
//! **Slower file (interpolation).** A 5 kHz logger without an anti-aliasing filter folds the
//! 2.5–5 kHz band of the phase currents (commutation edges) into its own band, so a band-limited
//! reconstruction rebuilds that band wrongly; the monitor's 0.4 ms block means of `I_3eq` then
//! see ringing that no model explains. The linear interpolation between the two neighbouring
//! samples used here keeps the fault estimate within the 0.5 Err% of the clean file that
//! `host-tests/cli/tests/recording_formats.rs` requires; a band-limited one does not. Either way a
//! block holds only two independent samples, which the monitor's fit test (calibrated on four)
//! can report as a poor fit: `INCONCLUSIVE (poor fit)`, the monitor abstaining.
//!
//! The filter is written here rather than taken from a resampling crate (`rubato`'s sinc
//! resamplers) because the output grid starts at an arbitrary time inside the file — the start of
//! the manoeuvre, found to a fraction of an input sample by [`super::align`] — and runs at a ratio
//! set by the measured mean period: a stream resampler starts at the first input sample with its
//! own delay, so it would need a second, fractional-delay interpolation on top. Evaluating the
//! kernel at each output time does both in one step.

use super::grid::Grid;

/// Zero crossings of the sinc kept on each side of the kernel's centre.
pub const ZERO_CROSSINGS: usize = 24;
/// Cut-off as a share of the lower of the input and output rates: its Nyquist frequency.
pub const CUTOFF: f64 = 0.5;
/// Shape of the Kaiser window.
pub const KAISER_BETA: f64 = 9.0;
/// Table points per zero crossing (the kernel between them linearly interpolated: relative error
/// below 1e-5).
const TABLE_PER_CROSSING: usize = 1024;

/// Modified Bessel function of the first kind, order 0 (power series, to machine precision for
/// the arguments of [`KAISER_BETA`]).
fn bessel_i0(x: f64) -> f64 {
    let (mut sum, mut term, q) = (1.0, 1.0, x * x / 4.0);
    for k in 1..200 {
        term *= q / (k * k) as f64;
        sum += term;
        if term < 1e-17 * sum {
            break;
        }
    }
    sum
}

/// The windowed-sinc kernel, tabulated against the distance in zero crossings.
#[derive(Clone, Debug)]
pub struct Kernel {
    table: Vec<f64>,
}

impl Default for Kernel {
    fn default() -> Self {
        Self::new()
    }
}

impl Kernel {
    /// The kernel of the module's constants.
    pub fn new() -> Self {
        let n = ZERO_CROSSINGS * TABLE_PER_CROSSING;
        let norm = bessel_i0(KAISER_BETA);
        let table = (0..=n + 1)
            .map(|j| {
                let s = j as f64 / TABLE_PER_CROSSING as f64;
                let r = s / ZERO_CROSSINGS as f64;
                if r >= 1.0 {
                    return 0.0;
                }
                let sinc = if s == 0.0 { 1.0 } else { (std::f64::consts::PI * s).sin() / (std::f64::consts::PI * s) };
                sinc * bessel_i0(KAISER_BETA * (1.0 - r * r).sqrt()) / norm
            })
            .collect();
        Self { table }
    }

    /// The kernel at `s` zero crossings from its centre (0 beyond [`ZERO_CROSSINGS`]).
    pub fn at(&self, s: f64) -> f64 {
        let x = s.abs() * TABLE_PER_CROSSING as f64;
        let j = x as usize;
        if j + 1 >= self.table.len() {
            return 0.0;
        }
        let f = x - j as f64;
        self.table[j] * (1.0 - f) + self.table[j + 1] * f
    }
}

/// The channels `inputs` (sampled on `grid`) at `n` output times `start_s + k · out_period_s`:
/// [`band_limited`] from a faster grid, [`linear`] from a slower one.
pub fn resample(inputs: &[&[f64]], grid: &Grid, start_s: f64, out_period_s: f64, n: usize) -> Vec<Vec<f64>> {
    if grid.period_s > out_period_s * (1.0 + 1e-9) {
        let times = (0..n).map(|k| start_s + k as f64 * out_period_s);
        return inputs.iter().map(|x| times.clone().map(|u| linear(x, grid, u)).collect()).collect();
    }
    band_limited(inputs, grid, start_s, out_period_s, n)
}

/// The channels `inputs` (sampled on `grid`) at `n` output times `start_s + k · out_period_s`,
/// through the windowed-sinc kernel. An output time with less than a quarter of the kernel's
/// weight over the file (beyond its ends) takes the nearest input sample.
pub fn band_limited(inputs: &[&[f64]], grid: &Grid, start_s: f64, out_period_s: f64, n: usize) -> Vec<Vec<f64>> {
    let kernel = Kernel::new();
    let len = inputs.first().map_or(0, |x| x.len());
    let cutoff_hz = CUTOFF * grid.rate_hz().min(1.0 / out_period_s);
    // zero crossings per input sample, and the kernel's half width in input samples
    let crossings_per_sample = 2.0 * cutoff_hz * grid.period_s;
    let half_width = ZERO_CROSSINGS as f64 / crossings_per_sample;
    let mut out = vec![Vec::with_capacity(n); inputs.len()];
    let mut weights = Vec::new();
    for k in 0..n {
        let u = start_s + k as f64 * out_period_s;
        let p = (u - grid.origin_s) / grid.period_s; // position in input samples
        let first = (p - half_width).ceil().max(0.0) as usize;
        let last = ((p + half_width).floor().max(0.0) as usize).min(len.saturating_sub(1));
        weights.clear();
        if first <= last {
            weights.extend((first..=last).map(|i| kernel.at((p - i as f64) * crossings_per_sample)));
        }
        let total: f64 = weights.iter().sum();
        let nearest = p.round().clamp(0.0, len.saturating_sub(1) as f64) as usize;
        for (x, y) in inputs.iter().zip(out.iter_mut()) {
            if total > 0.25 / crossings_per_sample {
                let acc: f64 = x[first..=last].iter().zip(&weights).map(|(a, w)| a * w).sum();
                y.push(acc / total);
            } else {
                y.push(x.get(nearest).copied().unwrap_or(0.0));
            }
        }
    }
    out
}

/// `x` (sampled on `grid`) at time `u`, linearly interpolated between its two neighbours (the
/// end value beyond either end; 0 for an empty `x`).
pub fn linear(x: &[f64], grid: &Grid, u: f64) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    let p = ((u - grid.origin_s) / grid.period_s).clamp(0.0, (x.len() - 1) as f64);
    let i = (p.floor() as usize).min(x.len() - 1);
    let j = (i + 1).min(x.len() - 1);
    let f = p - i as f64;
    x[i] * (1.0 - f) + x[j] * f
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kernel_is_a_windowed_sinc() {
        let k = Kernel::new();
        assert!((k.at(0.0) - 1.0).abs() < 1e-12);
        for z in 1..ZERO_CROSSINGS {
            assert!(k.at(z as f64).abs() < 1e-4, "{z}");
        }
        assert_eq!(k.at(ZERO_CROSSINGS as f64 + 0.5), 0.0);
    }

    /// A tone below the cut-off passes a 20 kHz → 10 kHz decimation; one above the output's
    /// Nyquist frequency is removed, not folded.
    #[test]
    fn passes_the_band_and_stops_aliases() {
        let grid = Grid { origin_s: 0.0, period_s: 5e-5 };
        let tone =
            |f: f64| (0..20_000).map(|i| (2.0 * std::f64::consts::PI * f * i as f64 * 5e-5).sin()).collect::<Vec<_>>();
        let rms_mid = |y: &[f64]| (y[2000..8000].iter().map(|v| v * v).sum::<f64>() / 6000.0).sqrt();
        let pass = tone(1000.0);
        let y = resample(&[&pass], &grid, 0.0, 1e-4, 10_000);
        let err: f64 = (2000..8000)
            .map(|k| (y[0][k] - (2.0 * std::f64::consts::PI * 1000.0 * k as f64 * 1e-4).sin()).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-3, "in-band error {err}");
        let alias = tone(7000.0); // would fold to 3 kHz
        let y = resample(&[&alias], &grid, 0.0, 1e-4, 10_000);
        assert!(rms_mid(&y[0]) < 1e-3, "alias rms {}", rms_mid(&y[0]));
    }
}
