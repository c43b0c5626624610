//! No HEALTHY without evidence: a fault mode reads `HEALTHY` only when the recording could have
//! shown it DEGRADED (its "not detectable below" bound under 0.10), `NOT_ASSESSED` otherwise, and a
//! recording on which no mode is assessed reads `INCONCLUSIVE (nothing assessable)`. Run on units
//! drawn off nominal (`ema simulate --unit`), identified with their own parameter files.

use std::path::{Path, PathBuf};

mod common;
use common::{accepted, s, scratch, unit_params_file};
use serde_json::Value;

/// The DEGRADED threshold of `ema_monitor::health`.
const DEGRADED_AT: f64 = ema_monitor::health::DEGRADED_AT as f64;

/// A recording of unit `unit` (drawn off nominal) under `profile` with `faults`, noise seed
/// `seed`, and the unit's own parameter file.
fn recording(dir: &Path, unit: u32, profile: &str, faults: &str, seed: u32) -> (PathBuf, PathBuf) {
    let tag: String = faults.chars().filter(char::is_ascii_digit).collect();
    let csv = dir.join(format!("u{unit}-{profile}-{seed}-{tag}.csv"));
    let (unit, seed) = (unit.to_string(), seed.to_string());
    accepted(&[
        "simulate",
        "--unit",
        &unit,
        "--profile",
        profile,
        "--faults",
        faults,
        "--seed",
        &seed,
        "--out",
        s(&csv),
    ]);
    let params = unit_params_file(&csv);
    (csv, params)
}

/// `ema identify --json` of `csv` with `params` under `profile`.
fn identify(csv: &Path, params: &Path, profile: &str) -> Value {
    let out = accepted(&["identify", s(csv), "--params", s(params), "--profile", profile, "--json"]);
    serde_json::from_str(&out).expect("a JSON report")
}

/// `params` with `key` set to `value`, written to `out`.
fn with_key(params: &Path, key: &str, value: &str, out: &Path) -> PathBuf {
    let text = std::fs::read_to_string(params).expect("readable");
    let mut found = false;
    let lines: Vec<String> = text
        .lines()
        .map(|l| {
            if l.starts_with(&format!("{key} =")) {
                found = true;
                format!("{key} = {value}")
            } else {
                l.to_owned()
            }
        })
        .collect();
    assert!(found, "{key} in the template");
    std::fs::write(out, lines.join("\n") + "\n").expect("writes");
    out.to_path_buf()
}

/// The `(mode, condition, detectable_below)` of each mode of a report (none without `modes`).
fn modes(report: &Value) -> Vec<(String, String, Option<f64>)> {
    report["modes"]
        .as_array()
        .map(|m| {
            m.iter()
                .map(|m| {
                    let name = m["mode"].as_str().expect("mode").to_owned();
                    let condition = m["condition"].as_str().expect("condition").to_owned();
                    (name, condition, m["detectable_below"].as_f64())
                })
                .collect()
        })
        .unwrap_or_default()
}

#[test]
fn parameters_that_blind_the_fit_test_never_report_a_real_fault_healthy() {
    let dir = scratch("not-assessed", "blind");
    for unit in [11, 12] {
        let (csv, params) = recording(&dir, unit, "standard", "0.3,0,0,0,0,0,0.5,0.5", 1);
        // with its own parameters, the unit's friction fault is found
        let own = identify(&csv, &params, "standard");
        assert_eq!(own["status"], "DEGRADED", "unit {unit}: {own}");
        for (key, value) in [("position_noise_rad", "3e-4"), ("current_noise_a", "1.0")] {
            let blind = with_key(&params, key, value, &dir.join(format!("u{unit}-{key}.toml")));
            let r = identify(&csv, &blind, "standard");
            let status = r["status"].as_str().expect("status");
            let friction = modes(&r).into_iter().find(|m| m.0 == "friction");
            match status {
                "INCONCLUSIVE" if r["reason"] == "nothing assessable" => {
                    let all = modes(&r);
                    assert_eq!(all.len(), 5, "unit {unit}, {key}: the bounds are shown: {r}");
                    assert!(all.iter().all(|m| m.1 == "NOT_ASSESSED" && m.2.is_some_and(|b| b >= DEGRADED_AT)), "{r}");
                }
                // an abstention for another reason (the fit test still refuses the fit)
                "INCONCLUSIVE" | "SENSOR_FAULT" => {}
                _ => {
                    // a diagnosis: friction is either found or not assessed, never healthy
                    let (_, condition, _) = friction.expect("a friction mode");
                    assert!(condition != "HEALTHY", "unit {unit}, {key}: friction {condition}: {r}");
                    assert!(status != "HEALTHY" || condition == "NOT_ASSESSED", "unit {unit}, {key}: {r}");
                }
            }
        }
    }
}

#[test]
fn no_mode_reads_healthy_above_the_degraded_threshold_on_either_manoeuvre() {
    let dir = scratch("not-assessed", "manoeuvres");
    let mut eccentricity = Vec::new();
    for profile in ["standard", "pbit"] {
        for (unit, seed) in [(21, 1), (22, 2), (23, 3)] {
            for faults in ["0,0,0,0,0,0,0.5,0.5", "0,0.3,0,0,0,0,0.5,0.5"] {
                let (csv, params) = recording(&dir, unit, profile, faults, seed);
                let r = identify(&csv, &params, profile);
                let status = r["status"].as_str().expect("status").to_owned();
                for (mode, condition, bound) in modes(&r) {
                    // the four other modes are assessed on both manoeuvres
                    assert!(
                        mode == "eccentricity" || condition != "NOT_ASSESSED",
                        "{profile} unit {unit} {faults}: {mode} {bound:?}"
                    );
                    if condition == "HEALTHY" {
                        if let Some(b) = bound {
                            assert!(b < DEGRADED_AT, "{profile} unit {unit} {faults}: {mode} HEALTHY, bound {b}");
                        }
                    }
                    if condition == "NOT_ASSESSED" {
                        assert!(bound.is_some_and(|b| b >= DEGRADED_AT), "{profile} unit {unit}: {mode} {bound:?}");
                    }
                    if mode == "eccentricity" {
                        eccentricity.push((profile, condition, status.clone(), bound));
                    }
                }
            }
        }
    }
    // eccentricity: found healthy on every recording here, with its bound; the standard
    // manoeuvre does not assess it (its a90/95 lies above 0.3: docs/results/pod.md)
    println!("eccentricity (manoeuvre, condition, status, bound): {eccentricity:?}");
    assert_eq!(eccentricity.len(), 12, "{eccentricity:?}");
    assert!(eccentricity.iter().all(|e| e.3.is_some()), "{eccentricity:?}");
    assert!(eccentricity.iter().filter(|e| e.0 == "standard").all(|e| e.1 == "NOT_ASSESSED"), "{eccentricity:?}");
}
