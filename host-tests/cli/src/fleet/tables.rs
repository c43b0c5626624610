//! The markdown tables of `ema fleet`, the ones `docs/results/fleet.md` quotes: the fourth
//! healthy flight, the faulty flights per mode, the minimum detectable severities, and one row
//! per unit.

use std::fmt::Write as _;

use super::json::{FleetJson, FlightJson};

/// A status cell: the flight's label, or `–` for a flight not flown.
fn cell(flight: Option<&FlightJson>) -> String {
    flight.map_or("–".to_owned(), FlightJson::label)
}

/// A severity cell: three decimals, or `–` for none.
fn severity(x: Option<f32>) -> String {
    x.map_or("–".to_owned(), |x| format!("{x:.3}"))
}

/// The tables of `doc`, without a final newline.
pub fn tables(doc: &FleetJson) -> String {
    let mut out = String::new();
    // writing to a String cannot fail
    let _ = write_tables(&mut out, doc);
    out.truncate(out.trim_end_matches('\n').len());
    out
}

/// Writes the tables of `doc` into `out`.
fn write_tables(out: &mut String, doc: &FleetJson) -> std::fmt::Result {
    let n = doc.units.len();
    let commissioned = doc.commissioned;
    let [drawing, own] = &doc.fourth_flight;
    writeln!(out, "## Healthy units, a fourth flight\n")?;
    writeln!(out, "| against | units | false DEGRADED or FAILING | INCONCLUSIVE | HEALTHY |")?;
    writeln!(out, "|---|---|---|---|---|")?;
    writeln!(
        out,
        "| the drawing's parameters | {n} | {} | {} | {} |",
        drawing.alarms, drawing.inconclusive, drawing.healthy
    )?;
    writeln!(
        out,
        "| its commissioned parameters | {commissioned} of {n} commissioned | {} | {} | {} |",
        own.alarms, own.inconclusive, own.healthy
    )?;
    writeln!(
        out,
        "\nCommissioned units flown healthy at −40 °C: {} of {commissioned} HEALTHY; at +70 °C: {} of {commissioned} HEALTHY (temperature known).\n",
        doc.cold_healthy, doc.hot_healthy
    )?;
    writeln!(out, "## One fault mode at {} on a commissioned unit\n", doc.severity)?;
    writeln!(out, "| mode | flights | diagnosed (DEGRADED or FAILING) | mean Err% | largest Err% |")?;
    writeln!(out, "|---|---|---|---|---|")?;
    for m in &doc.fault_modes {
        writeln!(
            out,
            "| {} | {} | {} | {:.2} | {:.2} |",
            m.mode,
            m.flights,
            m.diagnosed,
            m.mean_err_percent.unwrap_or(0.0),
            m.max_err_percent.unwrap_or(0.0)
        )?;
    }
    writeln!(out, "| all | {} | | {:.2} | |", doc.faulty_flights, doc.mean_err_percent.unwrap_or(0.0))?;
    writeln!(out, "\n## Minimum detectable severity of a healthy flight (median over the commissioned units)\n")?;
    writeln!(out, "| mode | the drawing's unit | commissioned units |")?;
    writeln!(out, "|---|---|---|")?;
    for d in &doc.detectable_below {
        writeln!(out, "| {} | {} | {} |", d.mode, severity(d.drawing), severity(d.commissioned_median))?;
    }
    writeln!(out, "\n## Per unit\n")?;
    writeln!(
        out,
        "| unit seed | commissioning | 4th flight, drawing | 4th flight, commissioned | −40 °C | +70 °C | faulty flights (mode °C: status Err%) |"
    )?;
    writeln!(out, "|---|---|---|---|---|---|---|")?;
    for u in &doc.units {
        let faulty: Vec<String> = u
            .faulty
            .iter()
            .map(|f| format!("{} {:.0}: {} {:.2}", f.mode, f.temperature_c, f.label(), f.err_percent))
            .collect();
        writeln!(
            out,
            "| {} | {} | {} | {} | {} | {} | {} |",
            u.seed,
            u.refusal.as_ref().map_or_else(|| "ok".to_owned(), |e| format!("refused: {e}")),
            u.fourth_drawing.label(),
            cell(u.fourth_commissioned.as_ref()),
            cell(u.cold.as_ref()),
            cell(u.hot.as_ref()),
            faulty.join("; ")
        )?;
    }
    Ok(())
}
