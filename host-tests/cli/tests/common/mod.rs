//! Helpers shared by the `ema` integration tests (each test crate uses a subset).
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use ema_cli::params_file::template;
use ema_cli::recording::sidecar::Sidecar;
use ema_monitor::params::FIELDS;
use ema_monitor::EmaParams;

/// A fresh scratch directory for one test of the test crate `prefix`.
pub fn scratch(prefix: &str, name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("ema-{prefix}-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir is writable");
    dir
}

/// Runs the `ema` binary.
pub fn ema(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_ema")).args(args).output().expect("the binary runs")
}

/// A temp path as `&str`.
pub fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 temp path")
}

/// Runs `ema` expecting failure: exit status 2, nothing on stdout and exactly one stderr line
/// starting with `error:` that contains every `needle`; no panic, no backtrace.
pub fn refused(args: &[&str], needles: &[&str]) -> String {
    let out = ema(args);
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    assert_eq!(err.lines().count(), 1, "{args:?}: one line expected, got {err:?}");
    assert!(err.starts_with("error: "), "{args:?}: {err}");
    assert!(out.stdout.is_empty(), "{args:?}: {}", String::from_utf8_lossy(&out.stdout));
    assert!(!err.contains("panicked") && !err.contains("backtrace"), "{err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: '{n}' missing from {err:?}");
    }
    err
}

/// Runs `ema` expecting it to succeed by the exit-code contract (docs/cli.md): the status
/// [`contract_status`] gives its output (0, or 3 or 4 for a report that is no diagnosis), with
/// nothing on stderr but progress; returns stdout.
pub fn accepted(args: &[&str]) -> String {
    let out = ema(args);
    let stdout = String::from_utf8(out.stdout).expect("utf-8 stdout");
    let expected = contract_status(args, &stdout);
    assert_eq!(out.status.code(), Some(expected), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    stdout
}

/// The exit status the contract (docs/cli.md, "Exit codes") gives a command that succeeded with
/// the output `stdout`: for `ema identify` the report's status, for `ema history FILE…` the last
/// flight's (0 for a diagnosis, 3 for INCONCLUSIVE, 4 for SENSOR_FAULT; no `--fail-on` here);
/// 0 for every other command and for `ema history --simulate`.
pub fn contract_status(args: &[&str], stdout: &str) -> i32 {
    assert!(!args.contains(&"--fail-on"), "{args:?}: give the expected status of --fail-on explicitly");
    let status = match args.first() {
        _ if args.contains(&"--help") => return 0,
        Some(&"identify") => identify_status(stdout),
        Some(&"history") if !args.contains(&"--simulate") => history_status(stdout),
        _ => return 0,
    };
    match status.as_str() {
        "HEALTHY" | "DEGRADED" | "FAILING" => 0,
        "INCONCLUSIVE" => 3,
        "SENSOR_FAULT" => 4,
        other => panic!("{args:?}: no status in the output ('{other}'):\n{stdout}"),
    }
}

/// The status of an `ema identify` report, text (`EMA health: STATUS`) or JSON (`"status"`).
pub fn identify_status(stdout: &str) -> String {
    let word = |rest: &str| rest.chars().take_while(|c| c.is_ascii_uppercase() || *c == '_').collect::<String>();
    if let Some((_, rest)) = stdout.split_once("EMA health: ") {
        return word(rest);
    }
    stdout
        .split_once("\"status\":")
        .map_or_else(String::new, |(_, rest)| word(rest.trim_start().trim_start_matches('"')))
}

/// The status of the last flight of an `ema history` report, JSON (`flights[-1].status`) or text
/// (the `status` column of the flights table's last row).
pub fn history_status(stdout: &str) -> String {
    if let Ok(v) = serde_json::from_str::<serde_json::Value>(stdout.trim()) {
        return v["flights"]
            .as_array()
            .and_then(|f| f.last())
            .and_then(|f| f["status"].as_str())
            .unwrap_or("")
            .to_owned();
    }
    let rows = stdout
        .lines()
        .take_while(|l| !l.is_empty())
        .filter(|l| l.trim_start_matches("| ").chars().next().is_some_and(|c| c.is_ascii_digit()));
    rows.last().and_then(|l| l.split('|').nth(4)).map_or_else(String::new, |c| c.trim().to_owned())
}

/// Runs `ema`, expecting exit status `code` (the contract of docs/cli.md); returns stdout.
pub fn exits(args: &[&str], code: i32) -> String {
    let out = ema(args);
    assert_eq!(out.status.code(), Some(code), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).expect("utf-8 stdout")
}

/// A bench's version of the recording CSV `text` (`ema simulate`'s columns): `rest_rows` rows at
/// rest before it (command, position and currents zero, the time axis shifted so that they come
/// first), and each phase current through a sensor with a zero error of `offsets_a` (A) on every
/// row, with a ±1-count dither at rest so that a sensor is never frozen.
pub fn with_pretrigger(text: &str, rest_rows: usize, offsets_a: [f64; 3]) -> String {
    const AMPS_PER_COUNT: f64 = 40.0 / 4096.0;
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header = lines.next().expect("a header");
    let rows: Vec<Vec<f64>> =
        lines.map(|l| l.split(',').map(|x| x.parse::<f64>().expect("a number")).collect()).collect();
    let period = rows[1][0] - rows[0][0];
    let mut out = format!("{header}\n");
    for k in 0..rest_rows {
        let dither = if k % 2 == 0 { 0.0 } else { AMPS_PER_COUNT };
        let [a, b, c] = offsets_a.map(|o| o + dither);
        out.push_str(&format!("{},0,0,{a},{b},{c}\n", k as f64 * period));
    }
    for (k, r) in rows.iter().enumerate() {
        let t = (rest_rows + k) as f64 * period;
        let [a, b, c] = [r[3] + offsets_a[0], r[4] + offsets_a[1], r[5] + offsets_a[2]];
        out.push_str(&format!("{t},{},{},{a},{b},{c}\n", r[1], r[2]));
    }
    out
}

/// The unit's parameter file (its parameters at 20 °C, from the recording's sidecar), beside it.
pub fn unit_params_file(recording: &Path) -> PathBuf {
    let side = Sidecar::for_recording(recording).expect("readable").expect("a sidecar");
    let mut p = EmaParams::NOMINAL;
    for f in FIELDS.iter() {
        f.set(&mut p, side.params[f.name]);
    }
    assert_ne!(p, EmaParams::NOMINAL, "a drawn unit");
    let path = recording.with_extension("toml");
    std::fs::write(&path, template(&p)).expect("writes");
    path
}
