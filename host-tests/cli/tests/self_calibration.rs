//! `ema identify` measures the current sensors' zero points on a recording's rows before its
//! manoeuvre, as a board does on the frames before its trigger: a bench's zero errors read as the
//! ideal sensors do, and a zero ten times beyond what self-calibration corrects is a sensor fault
//! that names its phase.

mod common;

use common::{accepted, s, scratch, with_pretrigger};

/// `ema identify --json` of `csv`.
fn identify(csv: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&accepted(&["identify", s(csv), "--json"])).expect("JSON on stdout")
}

#[test]
fn zero_points_come_from_the_rows_before_the_manoeuvre() {
    let dir = scratch("selfcal", "zero");
    // the drawing's unit with a friction fault, and a unit off nominal (which the drawing's
    // parameters leave inconclusive: the sensors must not change that either)
    for (name, unit) in [("nominal", None), ("unit-4", Some("4"))] {
        let sim = dir.join(format!("{name}.csv"));
        let mut args = vec!["simulate", "--seed", "11", "--faults", "0.3,0,0,0,0,0,0.5,0.5", "--out", s(&sim)];
        if let Some(u) = unit {
            args.extend(["--unit", u]);
        }
        accepted(&args);
        let text = std::fs::read_to_string(&sim).expect("written");
        let ideal = dir.join(format!("{name}-ideal.csv"));
        std::fs::write(&ideal, with_pretrigger(&text, 600, [0.0; 3])).expect("writable");
        let bench = dir.join(format!("{name}-bench.csv"));
        let offsets = [0.15, -0.10, 0.12];
        std::fs::write(&bench, with_pretrigger(&text, 600, offsets)).expect("writable");
        let (a, b) = (identify(&ideal), identify(&bench));
        assert_eq!(b["sensors"]["zero_points"], "rest", "{b}");
        assert_eq!(b["sensors"]["rest_frames"], 600);
        for (j, o) in offsets.iter().enumerate() {
            let shift = b["sensors"]["zero_shift_counts"][j].as_f64().expect("a number");
            // the codes' grid and the dither: within one count
            assert!((shift - o / (40.0 / 4096.0)).abs() < 1.0, "{name} phase {j}: {shift}");
        }
        assert_eq!(b["sensors"]["fault"], serde_json::Value::Null);
        assert_eq!(a["status"], b["status"], "{name}\n{a}\n{b}");
        assert_eq!(b["refused_frames"], 0);
        let key = if a.get("k").is_some() { "k" } else { "k_not_a_diagnosis" };
        let (ka, kb, sigma) = (&a[key], &b[key], &a["sigma"]);
        for k in 0..8 {
            let (x, y) = (ka[k].as_f64().unwrap(), kb[k].as_f64().unwrap());
            let sd = sigma[k].as_f64().unwrap_or(f64::INFINITY);
            assert!((x - y).abs() <= 2.0 * sd, "{name} k{}: {x} against {y} (1σ {sd})", k + 1);
        }
    }
}

#[test]
fn a_zero_beyond_self_calibration_is_a_sensor_fault_naming_its_phase() {
    let dir = scratch("selfcal", "beyond");
    let sim = dir.join("sim.csv");
    accepted(&["simulate", "--seed", "12", "--out", s(&sim)]);
    let text = std::fs::read_to_string(&sim).expect("written");
    let broken = dir.join("broken.csv");
    // 1000 counts on phase C: ten times the 100 counts self-calibration corrects
    std::fs::write(&broken, with_pretrigger(&text, 600, [0.0, 0.0, 1000.0 * 40.0 / 4096.0])).expect("writable");
    let out = common::ema(&["identify", s(&broken), "--json"]);
    assert_eq!(out.status.code(), Some(4), "SENSOR_FAULT exits 4 (docs/cli.md)");
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    assert_eq!(json["status"], "SENSOR_FAULT", "{json}");
    assert_eq!(json["sensors"]["fault"]["phase"], "C", "{json}");
    let reason = json["sensors"]["fault"]["reason"].as_str().expect("a reason");
    assert!(reason.contains("phase C") && reason.contains("beyond"), "{reason}");
    let text = accepted(&["identify", s(&broken)]);
    assert!(text.contains("not trusted: phase C zero"), "{text}");
}
