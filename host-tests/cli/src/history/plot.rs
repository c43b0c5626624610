//! `severity.svg`: severity against flight per mode as the record keeps it, with the trend lines,
//! the failing threshold and the RUL band.

use ema_monitor::faults::FaultMode;
use ema_monitor::health::FAILING_AT;

use super::document::PRESENT_SEVERITY;
use super::json::HistoryJson;
use super::series::Series;
use crate::plots::{self, SeveritySeries};

/// Colours of the five modes in the plot.
const MODE_COLOURS: [(u8, u8, u8); 5] = [(31, 119, 180), (214, 39, 40), (44, 160, 44), (148, 103, 189), (255, 127, 14)];

/// `severity.svg`: the modes that were ever reported or declared, or have a trend that rises; the
/// flights a mode was declared by pooled evidence ringed.
pub fn plot(doc: &HistoryJson, series: &Series) -> std::io::Result<String> {
    let last = doc.flights.last().map_or(1.0, |f| f64::from(f.flight));
    let mut x_max = last + 1.0;
    let points: Vec<Vec<(f64, f64)>> = FaultMode::ALL
        .into_iter()
        .map(|mode| {
            series.record.history(mode).iter().map(|e| (f64::from(e.flight), f64::from(e.severity))).collect::<Vec<_>>()
        })
        .collect();
    // the flights a mode was declared by pooled evidence, at the severity the record keeps
    let declared: Vec<Vec<(f64, f64)>> = (0..FaultMode::ALL.len())
        .map(|i| {
            doc.flights
                .iter()
                .filter(|f| series.declared[i].contains(&f.flight))
                .map(|f| (f64::from(f.flight), f64::from(f.pooled_severity[i])))
                .collect()
        })
        .collect();
    let mut shown = Vec::new();
    for (i, mode) in FaultMode::ALL.iter().enumerate() {
        let ever = points[i].iter().any(|p| p.1 > f64::from(PRESENT_SEVERITY)) || !declared[i].is_empty();
        let p = series.prognosis[i];
        let crossing = p.and_then(|p| p.failing);
        if !ever && crossing.is_none() {
            continue;
        }
        let trend = p.map(|p| {
            let first = points[i].first().map_or(1.0, |q| q.0);
            let end = crossing.map_or(last, |c| f64::from(c.flight).clamp(last, last + 3.0 * (last - first + 1.0)));
            let at = |f: f64| f64::from(p.trend.at(f as f32));
            ((first, at(first)), (end, at(end)))
        });
        if let Some((_, (end, _))) = trend {
            x_max = x_max.max(end + 1.0);
        }
        let band = crossing.map(|c| (f64::from(c.lower), c.upper.map(f64::from)));
        shown.push((mode.name(), MODE_COLOURS[i], i, trend, band));
    }
    let series_list: Vec<SeveritySeries> = shown
        .iter()
        .map(|&(name, colour, i, trend, band)| SeveritySeries {
            name,
            colour,
            points: &points[i],
            declared: &declared[i],
            trend,
            band,
        })
        .collect();
    plots::severity_plot("Severity per flight, trend and RUL band", &series_list, f64::from(FAILING_AT), x_max)
}
