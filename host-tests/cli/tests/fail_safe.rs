//! The monitor abstains instead of giving a confident wrong answer: each hostile input of issue
//! #28 item 1 reads `INCONCLUSIVE` or `SENSOR_FAULT`, an isolated glitch is masked and the
//! diagnosis goes on, and clean recordings (healthy and faulty, several seeds) are never
//! `INCONCLUSIVE`.

use std::path::Path;

mod common;
use common::{accepted, refused, s, scratch};

use ema_cli::identify::identify_recording;
use ema_cli::output::Overwrite;
use ema_cli::recording::{write_recording, Recording};
use ema_monitor::diagnosis::IdentifyConfig;
use ema_monitor::health::{Abstain, HealthReport, Status};
use ema_monitor::{FaultVector, Profile};
use ema_reference::{simulate, SimConfig};

const HEALTHY: [f32; 8] = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5];
const FRICTION: [f32; 8] = [0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5];

/// The standard manoeuvre recorded by the reference model with `faults` and noise seed `seed`.
fn recording(faults: [f32; 8], seed: u64) -> Recording {
    let rec = simulate(&SimConfig { faults: FaultVector(faults), seed, ..SimConfig::default() }).unwrap();
    Recording::from_reference(&rec, vec![])
}

/// The on-board budget (40 iterations): enough for the status, and quick.
fn config() -> IdentifyConfig {
    IdentifyConfig { max_iterations: 40, ..IdentifyConfig::default() }
}

fn report(r: &Recording) -> HealthReport {
    identify_recording(r, Path::new("in-memory.csv"), &ema_monitor::EmaParams::NOMINAL, &Profile::STANDARD, &config())
        .unwrap()
        .report
}

#[test]
fn random_currents_that_sum_to_zero_are_inconclusive() {
    let mut r = recording(HEALTHY, 1);
    let mut x = 0x9E37_79B9_7F4A_7C15u64;
    let mut uniform = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 11) as f64 / (1u64 << 53) as f64 * 20.0 - 10.0
    };
    for k in 0..r.len() {
        let (a, b) = (uniform(), uniform());
        (r.ia_a[k], r.ib_a[k], r.ic_a[k]) = (a, b, -a - b);
    }
    let rep = report(&r);
    assert_eq!(rep.status, Status::Inconclusive(Abstain::PoorFit), "{rep}");
    assert!(!rep.fit_check.unwrap().passes());
}

#[test]
fn the_standard_trace_played_backwards_is_inconclusive() {
    let mut r = recording(HEALTHY, 1);
    r.ia_a.reverse();
    r.ib_a.reverse();
    r.ic_a.reverse();
    let rep = report(&r);
    assert_eq!(rep.status, Status::Inconclusive(Abstain::PoorFit), "{rep}");
    let text = rep.to_string();
    assert!(text.starts_with("EMA health: INCONCLUSIVE (poor fit)"), "{text}");
    assert!(!text.contains("backlash ") && text.contains("k (not a diagnosis)"), "{text}");
}

#[test]
fn a_recording_cut_to_its_first_sixth_is_inconclusive() {
    let mut r = recording(HEALTHY, 1);
    let n = r.len() / 6;
    for column in [&mut r.time_s, &mut r.command_rad, &mut r.position_rad, &mut r.ia_a, &mut r.ib_a, &mut r.ic_a] {
        column.truncate(n);
    }
    r.row_line.truncate(n);
    let rep = report(&r);
    assert_eq!(rep.status, Status::Inconclusive(Abstain::PartialCoverage), "{rep}");
}

#[test]
fn a_trace_declaring_1_khz_is_inconclusive() {
    let dir = scratch("fail-safe", "rate");
    let mut bytes = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/../../traces/standard.ematrace")).unwrap();
    bytes[8..12].copy_from_slice(&1000u32.to_le_bytes());
    ema_monitor::trace::reseal(&mut bytes).expect("an EMA3 trace");
    let path = dir.join("1khz.ematrace");
    std::fs::write(&path, bytes).unwrap();
    let out = accepted(&["identify", "--firmware-trace", s(&path), "--json"]);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["status"], "INCONCLUSIVE", "{v}");
    assert_eq!(v["reason"], "rate mismatch", "{v}");
    assert!(v.get("k").is_none() && v.get("modes").is_none() && v["k_not_a_diagnosis"].is_array(), "{v}");
}

#[test]
fn phase_a_shifted_by_minus_5_a_is_a_sensor_fault_not_friction() {
    let dir = scratch("fail-safe", "shift");
    let mut r = recording(HEALTHY, 2);
    for a in &mut r.ia_a {
        *a -= 5.0;
    }
    let path = dir.join("shifted.csv");
    write_recording(&path, &r, Overwrite::Refuse).unwrap();
    let out = accepted(&["identify", s(&path), "--json", "--max-iterations", "40"]);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["status"], "SENSOR_FAULT", "{v}");
    assert!(v["refused_frames"].as_u64().unwrap() > 8000, "{v}");
    assert!(v.get("k").is_none() && v.get("modes").is_none(), "{v}");
    let text = accepted(&["identify", s(&path), "--max-iterations", "40"]);
    assert!(text.starts_with("EMA health: SENSOR_FAULT") && !text.contains("friction"), "{text}");
}

#[test]
fn one_isolated_glitch_is_masked_and_the_diagnosis_goes_on() {
    let clean = recording(FRICTION, 3);
    let mut glitch = clean.clone();
    glitch.ia_a[3000] = 25.0; // beyond the ±20 A sensor: a saturated frame
    let (a, b) = (report(&clean), report(&glitch));
    assert_eq!(b.refused_frames, 1, "{b}");
    assert!(b.status.is_diagnosis() && b.status == a.status, "{a}\n{b}");
    let err = b.faults.paper_error_percent(&a.faults);
    assert!(err < 1.0, "{err} Err% between\n{a}\n{b}");
}

#[test]
fn a_burst_of_bad_frames_is_a_sensor_fault() {
    let mut r = recording(FRICTION, 4);
    for a in &mut r.ia_a[3000..3200] {
        *a = 25.0;
    }
    let rep = report(&r);
    assert_eq!(rep.status, Status::SensorFault, "{rep}");
    assert_eq!(rep.refused_frames, 200);
    assert!(!rep.to_string().contains("friction "), "{rep}");
}

#[test]
fn clean_recordings_are_never_inconclusive() {
    let cases: [[f32; 8]; 5] = [
        HEALTHY,
        FRICTION,
        [0.0, 0.5, 0.0, 0.0, 0.0, 0.0, 0.5, 0.7],
        [0.0, 0.0, 0.0, 0.6, 0.0, 0.0, 0.5, 0.5],
        [0.2, 0.3, 0.0, 0.0, 0.0, 0.4, 0.3, 0.4],
    ];
    for (i, faults) in cases.iter().enumerate() {
        for seed in [11 + i as u64, 21 + i as u64] {
            let rep = report(&recording(*faults, seed));
            assert!(rep.status.is_diagnosis(), "faults {faults:?} seed {seed}:\n{rep}");
            assert_eq!(rep.refused_frames, 0, "faults {faults:?} seed {seed}:\n{rep}");
        }
    }
}

/// A compliant transmission (outside the effect library) at its maximum concentrates its misfit
/// in the fast reversal; averaged over the recording it stayed under the whole-recording fit
/// test, and `ema identify` read a FAILING eccentricity of 0.52 that is not there (seed 8 with
/// friction). The window test of the fit (`health::FitCheck`) catches it: every recording, healthy
/// or with friction, seeds 8 to 10, is INCONCLUSIVE or a correct diagnosis (the truth's status,
/// Err% below 10), 6 of 6.
#[test]
fn a_compliant_transmission_is_never_a_confident_wrong_diagnosis() {
    let mut wrong = Vec::new();
    let mut abstained = 0;
    for faults in [HEALTHY, FRICTION] {
        for seed in [8u64, 9, 10] {
            let effects = ema_reference::Effects::NONE.with(ema_reference::Effect::Compliance, 1.0).unwrap();
            let config = SimConfig { faults: FaultVector(faults), seed, effects, ..SimConfig::default() };
            let rep = report(&Recording::from_reference(&simulate(&config).unwrap(), vec![]));
            let truth = HealthReport::new(FaultVector(faults), &ema_monitor::EmaParams::NOMINAL, 0.0, 0, 0, None);
            let err = rep.faults.paper_error_percent(&FaultVector(faults));
            if rep.status == Status::Inconclusive(Abstain::PoorFit) {
                abstained += 1;
            } else if !(rep.status == truth.status && err < 10.0) {
                wrong.push(format!("faults {faults:?} seed {seed}: Err% {err:.1}\n{rep}"));
            }
        }
    }
    assert!(wrong.is_empty(), "{} of 6 confident and wrong:\n{}", wrong.len(), wrong.join("\n"));
    assert!(abstained >= 4, "only {abstained} of 6 abstained");
}

/// No input file drives an allocation: a profile ending at `1e30` s (which once made the
/// reference model panic with "capacity overflow"), an oversized packed trace, model
/// configuration or recording line are each refused with the file, line and field named, exit
/// status 2, and no output written.
#[test]
fn oversized_inputs_are_refused_with_the_file_line_and_field() {
    let dir = scratch("fail-safe", "bounds");
    let profile = dir.join("far.profile");
    std::fs::write(&profile, "hold 0 0\nhold 0.01 0.05\nend 1e30\n").unwrap();
    let out = dir.join("out.csv");
    let needles = ["far.profile' line 3", "DURATION '1e30' is longer than the 60 s"];
    refused(&["simulate", "--profile", s(&profile), "--out", s(&out)], &needles);
    assert!(!out.exists());
    // the same file for identify, before the recording is read
    refused(&["identify", s(&dir.join("unread.csv")), "--profile", s(&profile)], &needles);

    let trace = dir.join("huge.ematrace");
    std::fs::write(&trace, vec![0u8; ema_cli::identify::MAX_FIRMWARE_TRACE_BYTES + 1]).unwrap();
    refused(&["identify", "--firmware-trace", s(&trace)], &["huge.ematrace", "larger than"]);

    let config = dir.join("huge.config");
    std::fs::write(&config, "#\n".repeat(ema_cli::identify::MAX_MODEL_CONFIG_BYTES)).unwrap();
    let trace = concat!(env!("CARGO_MANIFEST_DIR"), "/../../traces/standard.ematrace");
    refused(&["identify", "--firmware-trace", trace, "--model-config", s(&config)], &["huge.config", "larger than"]);

    let csv = dir.join("long-line.csv");
    std::fs::write(
        &csv,
        format!("# ok\ntime_s,command_rad,position_rad,ia_A,ib_A,ic_A\n0,0,0,0,0,{}\n", "1".repeat(5000)),
    )
    .unwrap();
    refused(&["identify", s(&csv)], &["long-line.csv' line 3", "longer than 4096 bytes"]);
}
