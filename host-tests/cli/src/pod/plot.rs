//! `pod.svg`: each mode's detection curve, as `ema pod` fitted it ([`crate::plots::pod_plot`]).

use std::io;

use super::PodJson;
use crate::plots::{pod_plot, PodCurve};

/// Colours of the five modes.
const COLOURS: [(u8, u8, u8); 5] = [(31, 119, 180), (214, 39, 40), (44, 160, 44), (148, 103, 189), (255, 127, 14)];

/// Points of a fitted curve between the smallest and the largest severity.
const CURVE_POINTS: usize = 120;

/// The SVG of `doc`'s curves over the severities tested.
pub fn curves(doc: &PodJson, severities: &[f64]) -> io::Result<String> {
    let lo = severities.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = severities.iter().copied().fold(0.0, f64::max);
    let grid: Vec<f64> = (0..CURVE_POINTS).map(|i| lo * (hi / lo).powf(i as f64 / (CURVE_POINTS - 1) as f64)).collect();
    let mut fitted: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut lower: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut observed: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut names = Vec::new();
    for m in &doc.modes {
        let curve = m.curve;
        fitted.push(curve.map_or(Vec::new(), |c| grid.iter().map(|&a| (a, c.pod(a))).collect()));
        lower.push(curve.map_or(Vec::new(), |c| grid.iter().map(|&a| (a, c.pod_lower_95(a))).collect()));
        observed.push(
            m.by_severity.iter().filter(|p| p.1 > 0).map(|&(s, n, h)| (s, f64::from(h) / f64::from(n))).collect(),
        );
        names.push(match m.a90_95 {
            Some(a) => format!("{} (a90/95 {a:.3})", m.mode),
            None => format!("{} (no a90/95)", m.mode),
        });
    }
    let curves: Vec<PodCurve> = doc
        .modes
        .iter()
        .enumerate()
        .map(|(j, _)| PodCurve {
            name: &names[j],
            colour: COLOURS[j % COLOURS.len()],
            fitted: &fitted[j],
            lower: &lower[j],
            observed: &observed[j],
        })
        .collect();
    let title =
        format!("Probability of detection, {} manoeuvre, noise {}, {} unit(s)", doc.profile, doc.noise, doc.units);
    pod_plot(&title, &curves, lo, hi)
}
