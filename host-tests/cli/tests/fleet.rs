//! `ema fleet`: one unit drawn, commissioned and flown, its JSON document against
//! `docs/output-schema.md`; the commissioned unit's fourth flight reads HEALTHY, as every unit of
//! `docs/results/fleet.md` does; bad flags and an existing output are refused before any work.

mod common;
#[path = "common/schema.rs"]
mod schema;

use common::{ema, refused, s, scratch};

const STATUSES: [&str; 5] = ["HEALTHY", "DEGRADED", "FAILING", "INCONCLUSIVE", "SENSOR_FAULT"];

/// Checks one flight object: a valid status, a reason exactly when INCONCLUSIVE.
fn check_flight(f: &serde_json::Value, what: &str) {
    let status = f["status"].as_str().unwrap_or_else(|| panic!("{what}: no status in {f}"));
    assert!(STATUSES.contains(&status), "{what}: status {status:?}");
    assert_eq!(status == "INCONCLUSIVE", f["reason"].is_string(), "{what}: {f}");
    assert!(f["temperature_c"].is_number(), "{what}: {f}");
}

#[test]
fn one_unit_is_commissioned_and_its_fourth_flight_reads_healthy() {
    let out = ema(&["fleet", "--units", "1", "--seed", "4100", "--json"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.is_empty(), "stderr is not empty (a progress bar without a terminal?): {err:?}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    schema::check_json("`ema fleet --json`", &[&v]);
    assert!(v.get("input_file").is_none(), "fleet reads no file: {v}");
    assert_eq!((v["seed"].as_u64(), v["commissioned"].as_u64()), (Some(4100), Some(1)), "{v}");
    let units = v["units"].as_array().expect("units");
    assert_eq!(units.len(), 1);
    let unit = &units[0];
    assert_eq!((unit["seed"].as_u64(), unit["commissioned"].as_bool()), (Some(4100), Some(true)), "{unit}");
    for key in ["fourth_drawing", "fourth_commissioned", "cold", "hot"] {
        check_flight(&unit[key], key);
    }
    let faulty = unit["faulty"].as_array().expect("faulty flights");
    let modes: Vec<&str> = faulty.iter().map(|f| f["mode"].as_str().expect("mode")).collect();
    assert_eq!(modes, ["friction", "backlash", "short circuit", "eccentricity", "gain drift"]);
    for f in faulty {
        check_flight(f, "faulty flight");
        assert!(f["err_percent"].as_f64().is_some_and(|e| e >= 0.0), "{f}");
    }
    assert_eq!(unit["fourth_commissioned"]["status"], "HEALTHY", "{unit}");
    assert_eq!(unit["fourth_commissioned"]["temperature_c"], 20.0, "{unit}");
    // the summary counts the unit's flights
    assert_eq!(v["fourth_flight"][1]["against"], "commissioned");
    assert_eq!(v["fourth_flight"][1]["healthy"], 1, "{v}");
    assert_eq!(v["faulty_flights"], 5, "{v}");
}

#[test]
fn bad_flags_and_an_existing_output_are_refused_before_any_work() {
    refused(&["fleet", "--units", "0"], &["--units", "0"]);
    refused(&["fleet", "--units", "1001"], &["--units"]);
    refused(&["fleet", "--seed", "-1"], &["--seed"]);
    let dir = scratch("fleet", "exists");
    let out = dir.join("summary.md");
    std::fs::write(&out, "old").expect("writes");
    refused(&["fleet", "--units", "1", "--out", s(&out)], &["summary.md", "--force"]);
    assert_eq!(std::fs::read_to_string(&out).expect("reads"), "old");
    refused(&["fleet", "--units", "1", "--out", s(&dir.join("missing").join("a.md"))], &["does not exist"]);
}
