//! `ema pod` end to end on the built binary: a small run on units drawn off nominal, its JSON
//! against docs/output-schema.md, its files, and its refusals.

mod common;
#[path = "common/schema.rs"]
mod schema;
use common::{accepted, refused, s, scratch};

#[test]
fn a_small_run_on_drawn_units_detects_large_faults_and_matches_the_schema() {
    let dir = scratch("pod", "small").join("out");
    let out = accepted(&[
        "pod",
        "--units",
        "--seeds",
        "1",
        "--severities",
        "0.01,0.3",
        "--healthy",
        "2",
        "--json",
        "--out",
        s(&dir),
        "-q",
    ]);
    let doc: serde_json::Value = serde_json::from_str(&out).expect("JSON");
    schema::check_json("`ema pod --json` and `pod.json`", &[&doc]);
    assert_eq!(doc["units"], "drawn");
    let modes = doc["modes"].as_array().expect("modes");
    assert_eq!(modes.len(), 5);
    // at 0.3 a fault of every mode is far above its detectable severity but eccentricity's
    let large: Vec<bool> = modes.iter().map(|m| m["by_severity"][1][2].as_u64() == Some(1)).collect();
    assert!(large.iter().filter(|&&h| h).count() >= 4, "{large:?}: {doc}");
    for m in modes {
        assert_eq!(m["recordings"], 2, "{m}");
        assert_eq!(m["by_severity"][1][0], 0.3, "{m}");
    }
    let fa = &doc["false_alarms"];
    assert_eq!((fa["recordings"].as_u64(), fa["false_degraded"].as_u64()), (Some(2), Some(0)), "{fa}");
    // two recordings without a false alarm bound the rate by 1 − 0.05^{1/2}
    assert!((fa["false_degraded_upper_95"].as_f64().unwrap() - 0.7764).abs() < 1e-3, "{fa}");
    // the files: the same document, one CSV row per recording, the plot naming every mode
    let written: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("pod.json")).expect("pod.json")).unwrap();
    assert_eq!(written, doc);
    let csv = std::fs::read_to_string(dir.join("recordings.csv")).expect("recordings.csv");
    assert_eq!(csv.lines().count(), 1 + 12, "{csv}");
    assert!(csv.starts_with("mode,severity,seed,status,hit\n"));
    let svg = std::fs::read_to_string(dir.join("pod.svg")).expect("pod.svg");
    for name in ["friction", "backlash", "short circuit", "eccentricity", "gain drift", "probability of detection"] {
        assert!(svg.contains(name), "{name} missing from pod.svg");
    }
    // an existing output directory's files are not replaced without --force
    refused(&["pod", "--no-faults", "--healthy", "1", "--out", s(&dir)], &["pod.json", "--force"]);
}

#[test]
fn bad_flags_are_refused_before_any_recording() {
    refused(&["pod", "--severities", "0.1,1.5"], &["--severities", "(0, 1)"]);
    refused(&["pod", "--severities", "0"], &["--severities"]);
    refused(&["pod", "--no-faults"], &["--no-faults", "--healthy"]);
    refused(&["pod", "--seeds", "0"], &["--seeds"]);
}
