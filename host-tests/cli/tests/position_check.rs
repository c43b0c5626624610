//! The position column is checked against the command and the identified model: a column
//! zeroed, inverted or in degrees is named, and the diagnosis (which uses only the currents and
//! the command) stays as it is. On units drawn off nominal, with their own parameter files.

use std::path::Path;

mod common;
use common::{accepted, s, scratch, unit_params_file};
use serde_json::Value;

/// `csv` with its position column (the third) mapped by `f`, written to `out`.
fn with_position(csv: &Path, out: &Path, f: impl Fn(f64) -> f64) {
    let text = std::fs::read_to_string(csv).expect("readable");
    let mut lines = Vec::new();
    for line in text.lines() {
        let mut fields: Vec<String> = line.split(',').map(str::to_owned).collect();
        if let Some(p) = fields.get(2).and_then(|p| p.parse::<f64>().ok()) {
            fields[2] = format!("{}", f(p));
        }
        lines.push(fields.join(","));
    }
    std::fs::write(out, lines.join("\n") + "\n").expect("writes");
}

fn identify(csv: &Path, params: &Path) -> Value {
    serde_json::from_str(&accepted(&["identify", s(csv), "--params", s(params), "--json"])).expect("JSON")
}

#[test]
fn a_zeroed_inverted_or_degree_position_column_is_named_and_the_diagnosis_stays() {
    let dir = scratch("position", "columns");
    for (unit, faults) in [(31, "0.3,0,0,0,0,0,0.5,0.5"), (32, "0,0,0,0,0,0,0.5,0.2")] {
        let csv = dir.join(format!("u{unit}.csv"));
        accepted(&["simulate", "--unit", &unit.to_string(), "--faults", faults, "--out", s(&csv)]);
        let params = unit_params_file(&csv);
        let good = identify(&csv, &params);
        let check = &good["position_check"];
        assert_eq!(check["agrees"], true, "unit {unit}: {check}");
        assert!(check["ratio"].as_f64().unwrap() < 0.01, "unit {unit}: {check}");
        for (name, f, gain, cause) in [
            ("zeroed", (|_| 0.0) as fn(f64) -> f64, 0.0, "does not follow the command"),
            ("inverted", |p| -p, -1.0, "sign is inverted"),
            ("degrees", |p| p.to_degrees(), 57.3, "in degrees"),
        ] {
            let bad = dir.join(format!("u{unit}-{name}.csv"));
            with_position(&csv, &bad, f);
            let r = identify(&bad, &params);
            let c = &r["position_check"];
            assert_eq!(c["agrees"], false, "unit {unit} {name}: {c}");
            assert!((c["gain"].as_f64().unwrap() - gain).abs() < 0.05 * gain.abs().max(1.0), "{name}: {c}");
            // the diagnosis does not use the position: same status, same vector
            assert_eq!((&r["status"], &r["k"]), (&good["status"], &good["k"]), "unit {unit} {name}");
            if unit == 31 {
                let text = accepted(&["identify", s(&bad), "--params", s(&params)]);
                assert!(text.contains("position: DISAGREES") && text.contains(cause), "unit {unit} {name}: {text}");
            }
        }
    }
}
