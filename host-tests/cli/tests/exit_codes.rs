//! The exit-code contract of `ema` (docs/cli.md, "Exit codes"; `ema_cli::exit`), on the real
//! binary: 0 for a diagnosis or a command that succeeded, 1 when writing failed, 2 for a usage or
//! input error, 3 for INCONCLUSIVE, 4 for SENSOR_FAULT, 5 for a diagnosis at or above
//! `--fail-on`. The diagnoses are made on an actuator off nominal (its own parameter file).

use std::fs::OpenOptions;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

mod common;
use common::{accepted, exits, identify_status, refused, s, scratch};

use ema_cli::params_file::template;
use ema_monitor::EmaParams;

/// The actuator of these tests: 20 % more winding resistance and 10 % more friction than
/// nominal, as its own parameter file says.
fn actuator(dir: &Path) -> PathBuf {
    let params = EmaParams {
        phase_resistance_ohm: 0.6,
        static_friction_n_m: 0.11,
        dynamic_friction_n_m: 0.077,
        ..EmaParams::NOMINAL
    };
    params.check().expect("a valid actuator");
    assert_ne!(params, EmaParams::NOMINAL);
    let path = dir.join("actuator.toml");
    std::fs::write(&path, template(&params)).expect("writable");
    path
}

/// A recording of the actuator `params` with friction `friction` (k1), noise seed `seed`.
fn flight(dir: &Path, params: &Path, friction: &str, seed: &str) -> PathBuf {
    let out = dir.join(format!("friction-{friction}-seed-{seed}.csv"));
    let faults = format!("{friction},0,0,0,0,0,0.5,0.5");
    accepted(&["simulate", "--params", s(params), "--faults", &faults, "--seed", seed, "--out", s(&out)]);
    out
}

/// `recording` with phase A's current 5 A low on every row: a sensor fault.
fn shifted(recording: &Path) -> PathBuf {
    let text = std::fs::read_to_string(recording).expect("readable");
    let mut lines = text.lines();
    let mut out = format!("{}\n", lines.next().expect("a header"));
    for line in lines {
        let mut fields: Vec<String> = line.split(',').map(str::to_owned).collect();
        let ia: f64 = fields[3].parse().expect("a number");
        fields[3] = (ia - 5.0).to_string();
        out.push_str(&fields.join(","));
        out.push('\n');
    }
    let path = recording.with_file_name("shifted.csv");
    std::fs::write(&path, out).expect("writable");
    path
}

/// `ema identify` of `files` with the actuator's parameters, 40 iterations (the on-board budget),
/// and `extra` flags: the report's status and the exit status.
fn identify(params: &Path, files: &[&Path], extra: &[&str]) -> (String, Option<i32>) {
    let mut args = vec!["identify", "--quiet", "--json", "--max-iterations", "40", "--params", s(params)];
    args.extend(files.iter().map(|f| s(f)));
    args.extend(extra);
    let out = common::ema(&args);
    let stdout = String::from_utf8(out.stdout).expect("utf-8");
    assert!(out.stderr.is_empty(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    (identify_status(&stdout), out.status.code())
}

#[test]
fn a_diagnosis_exits_0_and_5_at_or_above_the_fail_on_level() {
    let dir = scratch("exit", "diagnosis");
    let params = actuator(&dir);
    let healthy = flight(&dir, &params, "0", "1");
    let degraded = flight(&dir, &params, "0.3", "2");
    let failing = flight(&dir, &params, "0.8", "3");
    let cases: [(&Path, &str, &[&str], i32); 7] = [
        (&healthy, "HEALTHY", &[], 0),
        (&healthy, "HEALTHY", &["--fail-on", "degraded"], 0),
        (&degraded, "DEGRADED", &[], 0),
        (&degraded, "DEGRADED", &["--fail-on", "failing"], 0),
        (&degraded, "DEGRADED", &["--fail-on", "degraded"], 5),
        (&failing, "FAILING", &["--fail-on", "failing"], 5),
        (&failing, "FAILING", &["--fail-on", "degraded"], 5),
    ];
    for (file, status, flags, code) in cases {
        assert_eq!(identify(&params, &[file], flags), (status.to_owned(), Some(code)), "{} {flags:?}", file.display());
    }
    // pooled: the pooled report's status
    let again = flight(&dir, &params, "0.8", "4");
    assert_eq!(identify(&params, &[&failing, &again], &[]), ("FAILING".to_owned(), Some(0)));
    assert_eq!(identify(&params, &[&failing, &again], &["--fail-on", "failing"]), ("FAILING".to_owned(), Some(5)));
    // a level that is not one: a usage error
    refused(&["identify", s(&failing), "--fail-on", "inconclusive"], &["--fail-on", "inconclusive"]);
}

#[test]
fn no_diagnosis_exits_3_for_inconclusive_and_4_for_a_sensor_fault_whatever_fail_on_says() {
    let dir = scratch("exit", "abstain");
    // a packed trace declaring 1 kHz: INCONCLUSIVE (rate mismatch)
    let mut bytes = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/../../traces/standard.ematrace")).unwrap();
    bytes[8..12].copy_from_slice(&1000u32.to_le_bytes());
    ema_monitor::trace::reseal(&mut bytes).expect("an EMA3 trace");
    let trace = dir.join("1khz.ematrace");
    std::fs::write(&trace, bytes).unwrap();
    for flags in [&[][..], &["--fail-on", "degraded"], &["--bits"]] {
        let mut args = vec!["identify", "--firmware-trace", s(&trace), "--json"];
        args.extend(flags);
        let out = exits(&args, 3);
        assert_eq!(identify_status(&out), "INCONCLUSIVE", "the report is printed as before: {out}");
    }
    let text = exits(&["identify", "--firmware-trace", s(&trace)], 3);
    assert!(text.starts_with("EMA health: INCONCLUSIVE (rate mismatch)"), "{text}");
    // phase A's sensor 5 A low: SENSOR_FAULT, on the off-nominal actuator
    let params = actuator(&dir);
    let broken = shifted(&flight(&dir, &params, "0.3", "5"));
    assert_eq!(identify(&params, &[&broken], &[]), ("SENSOR_FAULT".to_owned(), Some(4)));
    assert_eq!(identify(&params, &[&broken], &["--fail-on", "degraded"]), ("SENSOR_FAULT".to_owned(), Some(4)));
}

#[test]
fn history_exits_with_its_last_flights_status() {
    let dir = scratch("exit", "history");
    let params = actuator(&dir);
    let first = flight(&dir, &params, "0", "6");
    let last = flight(&dir, &params, "0.8", "7");
    let run = |files: &[&Path], flags: &[&str], code: i32| -> String {
        let mut args = vec!["history", "--quiet", "--json", "--params", s(&params)];
        args.extend(files.iter().map(|f| s(f)));
        args.extend(flags);
        let out = exits(&args, code);
        common::history_status(&out)
    };
    assert_eq!(run(&[&first, &last], &[], 0), "FAILING");
    assert_eq!(run(&[&first, &last], &["--fail-on", "failing"], 5), "FAILING");
    // the order matters: the last flight is the actuator's current state
    assert_eq!(run(&[&last, &first], &["--fail-on", "degraded"], 0), "HEALTHY");
    let broken = shifted(&last);
    assert_eq!(run(&[&first, &broken], &["--fail-on", "degraded"], 4), "SENSOR_FAULT");
    // --simulate measures the method: no status of an actuator, no --fail-on
    refused(&["history", "--simulate", "friction=0.6", "--fail-on", "failing"], &["--fail-on", "--simulate"]);
}

#[test]
fn other_commands_exit_0_1_when_writing_fails_and_2_for_bad_input() {
    assert!(exits(&["params"], 0).contains("phase_resistance_ohm"));
    // stdout that cannot take the output: a runtime failure, not the input's
    let full = OpenOptions::new().write(true).open("/dev/full").expect("/dev/full");
    let out = Command::new(env!("CARGO_BIN_EXE_ema"))
        .arg("params")
        .stdout(Stdio::from(full))
        .output()
        .expect("the binary runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.starts_with("error: writing to stdout"), "{err}");
    // usage and input errors
    refused(&["identify"], &["FILE"]);
    refused(&["identify", "/nonexistent/x.csv"], &["'/nonexistent/x.csv'"]);
    refused(&["params", "--fail-on", "degraded"], &["--fail-on"]);
}
