//! `ema discover` on the command line: outputs and refusals.

mod common;
#[path = "common/schema.rs"]
mod schema;
use common::{accepted, ema, refused, s, scratch};

#[test]
fn discover_writes_the_summary_json_plots_and_the_promoted_model() {
    let dir = scratch("discover", "outputs");
    let csv = dir.join("viscous.csv");
    accepted(&["simulate", "--effect", "viscous=0.6", "--seed", "4", "--out", s(&csv)]);
    let out = dir.join("out");
    let run = ema(&["discover", s(&csv), "--json", "--out", s(&out), "--truth", "0,0,0,0,0,0,0.5,0.5"]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    // stdout is not a terminal: no progress bar
    assert!(stderr.is_empty(), "{stderr:?}");
    let v: serde_json::Value = serde_json::from_slice(&run.stdout).expect("JSON on stdout");
    schema::check_json("`ema discover --json` and `discovery.json`", &[&v]);
    let written: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("discovery.json")).unwrap()).expect("JSON");
    assert_eq!(written["named"], v["named"]);
    assert_eq!(v["input_file"], s(&csv));
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
    schema::check_csv("`residual.csv` (`ema discover --out DIR`)", &csv_head);
    // the plots' legends explain the shaded windows and name the effect
    let fit = std::fs::read_to_string(out.join("fit.svg")).unwrap();
    assert!(fit.contains("windows holding half the residual energy"), "no shaded-window legend");
    assert!(fit.contains("model after (+ viscous 0."), "the effect is not named in the legend");
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
