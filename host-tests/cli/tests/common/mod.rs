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

/// Runs `ema` expecting success; returns stdout.
pub fn accepted(args: &[&str]) -> String {
    let out = ema(args);
    assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
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
