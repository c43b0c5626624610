//! The readable report of `ema history`: a table of the flights, then one of the modes.

use std::fmt::Write as _;

use ema_monitor::faults::FaultMode;
use ema_monitor::health::DEGRADED_AT;

use super::flight::Start;
use super::json::HistoryJson;

fn opt(v: Option<f32>, digits: usize) -> String {
    v.map_or("–".to_owned(), |v| format!("{v:.digits$}"))
}

/// The readable report: a table of the flights, then one of the modes.
pub fn text(doc: &HistoryJson) -> String {
    let mut out = String::new();
    let names: Vec<&str> = FaultMode::ALL.iter().map(|m| m.name()).collect();
    let _ = writeln!(
        out,
        "| flight | start | evaluations | status | {} | declared by pooled evidence |",
        names.join(" | ")
    );
    let _ = writeln!(out, "|{}", "---|".repeat(5 + names.len()));
    for f in &doc.flights {
        let sev: Vec<String> = f.severity.iter().map(|s| format!("{s:.3}")).collect();
        let declared: Vec<String> = f
            .declared
            .iter()
            .map(|&name| {
                let i = FaultMode::ALL.iter().position(|m| m.name() == name).unwrap_or(0);
                format!("{name} {:.3}", f.pooled_severity[i])
            })
            .collect();
        let declared = if declared.is_empty() { "–".to_owned() } else { declared.join(", ") };
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {declared} |",
            f.flight,
            match f.start {
                Start::Cold => "cold",
                Start::Warm => "warm",
            },
            f.evaluations,
            f.status,
            sev.join(" | ")
        );
    }
    let simulated = doc.campaign.is_some();
    let _ = write!(
        out,
        "\n| mode | slope /flight | crossing flight | {:.0} % interval | flights left | declared (pooled) |",
        100.0 * doc.confidence
    );
    if simulated {
        let _ =
            write!(out, " true crossing | crossing error | onset | detected | false reports | false declarations |");
    }
    let _ = writeln!(out, "\n|{}", "---|".repeat(if simulated { 12 } else { 6 }));
    for m in &doc.modes {
        let interval = match (m.crossing_flight, m.crossing_lower_flight, m.crossing_upper_flight) {
            (None, ..) => "–".to_owned(),
            (Some(_), lo, hi) => format!("[{}, {}]", opt(lo, 2), hi.map_or("∞".to_owned(), |h| format!("{h:.2}"))),
        };
        let left = match (m.remaining_flights, m.remaining_lower_flights, m.remaining_upper_flights) {
            (Some(r), Some(lo), hi) => {
                format!("{r:.2} [{lo:.2}, {}]", hi.map_or("∞".to_owned(), |h| format!("{h:.2}")))
            }
            _ => "–".to_owned(),
        };
        let slope = match (m.slope_per_flight, m.slope_se_per_flight) {
            (Some(b), Some(se)) => format!("{b:.4} ± {se:.4}"),
            _ => "–".to_owned(),
        };
        let declared = m.declared_flight.map_or("–".to_owned(), |f| format!("flight {f}"));
        let _ =
            write!(out, "| {} | {slope} | {} | {interval} | {left} | {declared} |", m.mode, opt(m.crossing_flight, 2));
        if simulated {
            let flight = |v: Option<Option<u32>>| v.flatten().map_or("–".to_owned(), |f| f.to_string());
            let _ = write!(
                out,
                " {} | {} | {} | {} | {} | {} |",
                m.true_crossing_flight.flatten().map_or("–".to_owned(), |f| format!("{f:.2}")),
                m.crossing_error_flights.flatten().map_or("–".to_owned(), |e| format!("{e:+.2}")),
                flight(m.onset_flight),
                flight(m.detected_flight),
                m.false_reports.unwrap_or(0),
                m.false_declarations.unwrap_or(0)
            );
        }
        out.push('\n');
    }
    if let Some(c) = &doc.campaign {
        let _ = write!(
            out,
            "\nlaws {}, seed {}: mean Err% cold {}, warm {}; probes: {}",
            c.laws.join(" "),
            c.seed,
            opt(c.cold_mean_err_percent, 2),
            opt(c.warm_mean_err_percent, 2),
            match (c.probe_false_alarms, c.probe_misses) {
                (Some(fa), Some(miss)) => format!("{fa} false alarms (drift-only flights), {miss} misses"),
                _ => "not run (every flight cold)".to_owned(),
            }
        );
    }
    let _ = write!(
        out,
        "\ntrend: least-squares line over the last {} diagnoses; interval: Fieller's at {:.0} %; failing at severity {}; \
         degraded from {DEGRADED_AT}; declared by pooled evidence: present by the per-mode sequential sum of \
         log-likelihood ratios, dropped by the flight's own model selection, refitted into what the record keeps",
        doc.history_capacity,
        100.0 * doc.confidence,
        doc.failing_at
    );
    out
}
