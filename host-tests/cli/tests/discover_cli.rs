//! `ema discover` on the command line: outputs and refusals.

mod common;
use common::{accepted, refused, s, scratch};

#[test]
fn discover_writes_the_summary_json_plots_and_the_promoted_model() {
    let dir = scratch("discover", "outputs");
    let csv = dir.join("viscous.csv");
    accepted(&["simulate", "--effect", "viscous=0.6", "--seed", "4", "--out", s(&csv)]);
    let out = dir.join("out");
    let json = accepted(&["discover", s(&csv), "--json", "--out", s(&out), "--truth", "0,0,0,0,0,0,0.5,0.5"]);
    let v: serde_json::Value = serde_json::from_str(&json).expect("JSON on stdout");
    assert_eq!(v["named"][0]["effect"], "viscous", "{v}");
    let confidence = v["named"][0]["confidence"].as_f64().unwrap();
    assert!((0.0..=1.0).contains(&confidence));
    assert!(v["rms_after_A"].as_f64().unwrap() < v["rms_before_A"].as_f64().unwrap());
    assert!(!v["windows"].as_array().unwrap().is_empty());
    assert!(v["err_percent_after"].as_f64().unwrap() < v["err_percent_before"].as_f64().unwrap());
    for f in ["discovery.json", "residual.csv", "fit.svg", "residual.svg", "model-config.txt"] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    assert!(std::fs::read_to_string(out.join("fit.svg")).unwrap().starts_with("<svg"));
    let config = std::fs::read_to_string(out.join("model-config.txt")).unwrap();
    assert!(config.lines().any(|l| l.starts_with("effect viscous 0.")), "{config}");
    let csv_head = std::fs::read_to_string(out.join("residual.csv")).unwrap();
    assert!(csv_head.starts_with("time_s,measured_A,"));
}

#[test]
fn discover_refuses_bad_inputs_naming_them() {
    let dir = scratch("discover", "refusals");
    let missing = dir.join("missing.csv");
    refused(&["discover", s(&missing)], &["missing.csv"]);
    let bad = dir.join("bad.csv");
    std::fs::write(&bad, "time_s,command_rad,position_rad,ia_A,ib_A,ic_A\n0,0,0,x,0,0\n").unwrap();
    refused(&["discover", s(&bad)], &["bad.csv", "line 2", "ia_A"]);
    let csv = dir.join("clean.csv");
    accepted(&["simulate", "--seed", "2", "--out", s(&csv)]);
    refused(&["discover", s(&csv), "--truth", "0,0"], &["need 8"]);
}
