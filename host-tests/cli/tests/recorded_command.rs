//! `--command recorded`: the recording's own command column drives the monitor model, so a
//! recording made on a manoeuvre that is not a stored profile is identified as well as one of the
//! standard manoeuvre, and the default `--command profile` refuses it.

use std::path::Path;

mod common;
use common::{accepted, refused, s, scratch};

use ema_cli::identify::{
    identify_recording, identify_recording_with, model_command, recorded_command, CommandArg, ModelCommand,
    HOST_COMMAND_SAMPLES,
};
use ema_cli::recording::Recording;
use ema_monitor::diagnosis::IdentifyConfig;
use ema_monitor::health::HealthReport;
use ema_monitor::profile::Segment;
use ema_monitor::{EmaParams, FaultVector, Profile};
use ema_reference::{simulate, SimConfig};

/// Another manoeuvre than the standard one, as a profile file states it: a step down, a reversal
/// step up, a slow ramp down through zero, and a 5 Hz sine, 0.9 s in all.
const OTHER_PROFILE: &str = "hold 0 0\nhold 0.015 -0.04\nhold 0.13 0.035\nramp 0.27 0.035 -0.25\n\
                             sine 0.57 -0.01 0.015 5\nend 0.9\n";

fn other_profile() -> Profile {
    let segments = [
        Segment::Hold { start_s: 0.0, value_rad: 0.0 },
        Segment::Hold { start_s: 0.015, value_rad: -0.04 },
        Segment::Hold { start_s: 0.13, value_rad: 0.035 },
        Segment::Ramp { start_s: 0.27, start_rad: 0.035, rate_rad_per_s: -0.25 },
        Segment::Sine { start_s: 0.57, offset_rad: -0.01, amplitude_rad: 0.015, frequency_hz: 5.0 },
    ];
    Profile::new(&segments, 0.9, EmaParams::NOMINAL.end_stop_rad).expect("a valid profile")
}

/// The reference model's recording of `profile` with `faults` and noise seed `seed`.
fn recording(profile: Profile, faults: [f32; 8], seed: u64) -> Recording {
    let rec = simulate(&SimConfig { faults: FaultVector(faults), profile, seed, ..SimConfig::default() }).unwrap();
    Recording::from_reference(&rec, vec![])
}

/// The on-board budget (40 iterations) with the host's defaults otherwise.
fn config(seed: u64) -> IdentifyConfig {
    IdentifyConfig { max_iterations: 40, seed, ..IdentifyConfig::default() }
}

fn recorded(r: &Recording, seed: u64) -> HealthReport {
    let path = Path::new("other.csv");
    let command = model_command(CommandArg::Recorded, "standard", r, path, &EmaParams::NOMINAL).unwrap();
    assert!(matches!(command, ModelCommand::Recorded(_)));
    identify_recording_with(r, path, &EmaParams::NOMINAL, &command, &config(seed)).unwrap().report
}

/// Two faulty cases and a healthy one, each on the other manoeuvre driven by its recorded command
/// and on the standard manoeuvre driven by the standard profile: the same status, and an Err%
/// within 1 point of the standard case's and under 1.5 % (0.92, 0.25 and 0.00 against 0.34,
/// 0.49 and 0.29 on the standard manoeuvre).
#[test]
fn another_manoeuvre_is_identified_by_its_recorded_command() {
    let cases: [([f32; 8], u64); 3] = [
        ([0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5], 1),
        ([0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.35], 2),
        ([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5], 3),
    ];
    for (faults, seed) in cases {
        let truth = FaultVector(faults);
        let standard = identify_recording(
            &recording(Profile::STANDARD, faults, seed),
            Path::new("standard.csv"),
            &EmaParams::NOMINAL,
            &Profile::STANDARD,
            &config(seed),
        )
        .unwrap()
        .report;
        let other = recorded(&recording(other_profile(), faults, seed), seed);
        let (e_std, e_other) = (standard.faults.paper_error_percent(&truth), other.faults.paper_error_percent(&truth));
        assert_eq!(other.status, standard.status, "{faults:?}: {other}\nstandard: {standard}");
        assert!(other.status.is_diagnosis(), "{other}");
        assert!(e_other < 1.5 && (e_other - e_std).abs() < 1.0, "{faults:?}: Err% {e_other} vs {e_std}\n{other}");
    }
}

/// Under the default `--command profile` (the standard profile) the same recording is refused:
/// its command is not the profile's.
#[test]
fn the_standard_profile_refuses_another_manoeuvre() {
    let r = recording(other_profile(), [0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5], 1);
    let e = identify_recording(&r, Path::new("other.csv"), &EmaParams::NOMINAL, &Profile::STANDARD, &config(1))
        .unwrap_err()
        .to_string();
    assert!(e.contains("field 'command_rad'") && e.contains("--profile"), "{e}");
}

/// The recorded command's limits, stated in the errors: the buffer's length and the end stops.
#[test]
fn the_recorded_command_has_stated_limits() {
    let path = Path::new("long.csv");
    let n = HOST_COMMAND_SAMPLES + 1;
    let long = Recording {
        time_s: (0..n).map(|k| k as f64 * 1e-4).collect(),
        command_rad: vec![0.0; n],
        row_line: (0..n).map(|k| k + 2).collect(),
        ..Recording::default()
    };
    let e = recorded_command(&long, path, &EmaParams::NOMINAL).unwrap_err().to_string();
    assert!(e.contains("long.csv") && e.contains("at most 32768 rows") && e.contains("3.2768 s"), "{e}");
    let mut beyond = Recording { command_rad: vec![0.0; 100], row_line: (0..100).map(|k| k + 2).collect(), ..long };
    beyond.time_s.truncate(100);
    beyond.command_rad[42] = 0.7;
    let e = recorded_command(&beyond, path, &EmaParams::NOMINAL).unwrap_err().to_string();
    assert!(e.contains("line 44, field 'command_rad': 0.7 rad") && e.contains("end stops"), "{e}");
}

/// The binary end to end: a recording of the other manoeuvre from `ema simulate --profile FILE`
/// is refused by default, identified with `--command recorded` (the report names the command), and
/// `--command recorded` refuses a profile beside it.
#[test]
fn identify_and_discover_take_the_flag() {
    let dir = scratch("recorded-command", "cli");
    let profile = dir.join("other.profile");
    std::fs::write(&profile, OTHER_PROFILE).unwrap();
    let csv = dir.join("other.csv");
    accepted(&["simulate", "--profile", s(&profile), "--faults", "0.3,0,0,0,0,0,0.5,0.5", "--out", s(&csv)]);
    refused(&["identify", s(&csv)], &["other.csv", "field 'command_rad'", "--profile"]);
    let out = accepted(&["identify", s(&csv), "--command", "recorded", "--max-iterations", "10"]);
    assert!(out.contains("command: recorded (9000 samples at 10000 Hz, 0.9 s)"), "{out}");
    let out = accepted(&["identify", s(&csv), "--command", "recorded", "--max-iterations", "10", "--json"]);
    let v: serde_json::Value = serde_json::from_str(&out).expect("json");
    assert_eq!(
        (v["command"]["source"].as_str(), v["command"]["duration_s"].as_f64()),
        (Some("recorded"), Some(0.9)),
        "{out}"
    );
    let out = accepted(&["identify", s(&csv), "--profile", s(&profile), "--max-iterations", "10"]);
    assert!(out.contains(&format!("command: profile {}", s(&profile))), "{out}");
    refused(&["identify", s(&csv), "--command", "recorded", "--profile", s(&profile)], &["--profile", "recorded"]);
    refused(&["discover", s(&csv), "--command", "recorded", "--profile", s(&profile)], &["--profile", "recorded"]);
    refused(&["discover", s(&csv)], &["field 'command_rad'"]);
}
