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
