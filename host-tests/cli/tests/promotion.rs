//! Promotion of a discovered effect to the firmware, host side: `ema identify --model-config`
//! (the same file and parser as the firmware build's `EMA_MODEL_CONFIG`) and
//! `ema firmware-trace --from RECORDING.csv` (a recording packed for the firmware's `EMA_TRACE`).

use std::path::{Path, PathBuf};

mod common;
use common::{accepted, refused, s, scratch};

use ema_cli::recording::read_recording;
use ema_monitor::trace::{counts_to_amps, PackedTrace};

fn committed_trace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../traces/standard.ematrace")
}

fn json(out: &str) -> serde_json::Value {
    serde_json::from_str(out.trim()).expect("valid JSON")
}

#[test]
fn bad_model_configs_are_refused_naming_file_line_and_field() {
    let dir = scratch("promotion", "bad-config");
    let trace = committed_trace();
    let cases: [(&str, &str, &[&str]); 6] = [
        (
            "unknown.conf",
            "# c\neffect dead_time 0.4\neffect compliance 0.5\n",
            &["line 3", "field 'effect'", "'compliance'"],
        ),
        ("number.conf", "effect viscous 0,3\n", &["line 1", "field 'severity'", "'0,3' is not a number"]),
        ("range.conf", "\neffect viscous 1.5\n", &["line 2", "field 'severity'", "outside [0, 1.25]"]),
        ("keyword.conf", "viscous 0.3\n", &["line 1", "field 'keyword'", "'viscous'"]),
        ("missing.conf", "effect viscous\n", &["line 1", "field 'severity'", "missing severity"]),
        (
            "twice.conf",
            "effect viscous 0.1\neffect viscous 0.2\n",
            &["line 2", "field 'effect'", "already set on line 1"],
        ),
    ];
    for (name, text, needles) in cases {
        let p = dir.join(name);
        std::fs::write(&p, text).expect("writable");
        let mut all = vec![name];
        all.extend_from_slice(needles);
        refused(&["identify", "--firmware-trace", s(&trace), "--model-config", s(&p)], &all);
    }
    // a recording CSV as input reads the same file the same way; a missing file is named too
    let p = dir.join("range.conf");
    refused(&["identify", "any.csv", "--model-config", s(&p)], &["range.conf", "line 2", "field 'severity'"]);
    refused(&["identify", "--firmware-trace", s(&trace), "--model-config", "nope.conf"], &["nope.conf", "cannot read"]);
}

#[test]
fn model_config_switches_the_effects_on() {
    let dir = scratch("promotion", "config");
    let trace = committed_trace();
    let p = dir.join("monitor-model.conf");
    std::fs::write(
        &p,
        "# ema-monitor model configuration (written by `ema discover`)\n\neffect viscous 0.5  # estimated\n",
    )
    .expect("writable");
    let base = ["identify", "--firmware-trace", s(&trace), "--json", "--max-iterations", "2"];
    let none = json(&accepted(&base));
    assert_eq!(none["model_effects"], serde_json::json!({}));
    let mut with = base.to_vec();
    with.extend_from_slice(&["--model-config", s(&p)]);
    let viscous = json(&accepted(&with));
    assert_eq!(viscous["model_effects"], serde_json::json!({"viscous": 0.5}));
    // the effect term is in the model: the same search scores differently
    assert_ne!(viscous["fitness_A2"], none["fitness_A2"]);
    // readable report names the effects
    let text = accepted(&["identify", "--firmware-trace", s(&trace), "--max-iterations", "2", "--model-config", s(&p)]);
    assert!(text.contains("model effects: viscous 0.5"), "{text}");
}

/// The CSV of the built-in run (`ema simulate` with its faults and seed), packed with `--from`, is
/// `traces/standard.ematrace` byte for byte.
#[test]
fn packing_the_builtin_run_reproduces_the_committed_trace() {
    let dir = scratch("promotion", "builtin");
    let csv = dir.join("same.csv");
    accepted(&["simulate", "--faults", "0.25,0,0,0,0,0,0.5,0.5", "--seed", "1", "--out", s(&csv)]);
    let out = dir.join("same.ematrace");
    let summary = accepted(&["firmware-trace", "--from", s(&csv), "--out", s(&out)]);
    assert_eq!(summary.lines().count(), 1, "{summary}");
    for needle in ["8500 frames", "10000 Hz", "38270 bytes", "same.csv", "EMA_TRACE="] {
        assert!(summary.contains(needle), "'{needle}' missing from {summary}");
    }
    let committed = std::fs::read(committed_trace()).expect("committed trace");
    assert!(
        std::fs::read(&out).expect("written") == committed,
        "--from of the built-in run differs from the committed trace"
    );
}

/// A recording with a hidden effect, packed: the codes give back the CSV's currents exactly, and the
/// packed trace identified as on board agrees with the CSV identified at the same iteration budget
/// (friction within 0.05, fitness within 10 %: the window and conditioning path differ).
#[test]
fn packed_effect_recording_identifies_like_the_csv() {
    let dir = scratch("promotion", "effect");
    let csv = dir.join("dead-time.csv");
    accepted(&["simulate", "--faults", "0.25,0,0,0,0,0,0.5,0.5", "--effect", "dead_time=0.48", "--out", s(&csv)]);
    let out = dir.join("dead-time.ematrace");
    accepted(&["firmware-trace", "--from", s(&csv), "--out", s(&out)]);
    let rec = read_recording(&csv).expect("valid recording");
    let bytes = std::fs::read(&out).expect("written");
    let t = PackedTrace::parse(&bytes).expect("valid packed trace");
    assert_eq!(t.frames(), rec.len());
    for (k, f) in t.iter().enumerate() {
        assert_eq!(f.map(|c| f64::from(counts_to_amps(c))), [rec.ia_a[k], rec.ib_a[k], rec.ic_a[k]], "row {k}");
    }
    let packed = json(&accepted(&["identify", "--firmware-trace", s(&out), "--json"]));
    let direct = json(&accepted(&["identify", s(&csv), "--json", "--max-iterations", "30"]));
    let k1 = |v: &serde_json::Value| v["k"][0].as_f64().expect("k1");
    let fit = |v: &serde_json::Value| v["fitness_A2"].as_f64().expect("fitness");
    assert!((k1(&packed) - k1(&direct)).abs() < 0.05, "friction: packed {packed}, CSV {direct}");
    assert!((fit(&packed) - fit(&direct)).abs() < 0.1 * fit(&direct), "fitness: packed {packed}, CSV {direct}");
    assert!((k1(&packed) - 0.25).abs() < 0.05, "friction 0.25 recorded: {packed}");
}

#[test]
fn recordings_the_firmware_cannot_replay_are_refused() {
    let dir = scratch("promotion", "refused");
    let csv = dir.join("standard.csv");
    accepted(&["simulate", "--seed", "2", "--out", s(&csv)]);
    let out = dir.join("x.ematrace");
    // an existing file is kept without --force (the default location: tests/data_safety.rs)
    std::fs::write(&out, b"old").expect("writable");
    refused(&["firmware-trace", "--from", s(&csv), "--out", s(&out)], &["x.ematrace", "--force"]);
    assert_eq!(std::fs::read(&out).expect("kept"), b"old");
    std::fs::remove_file(&out).expect("removable");
    // fewer rows than the standard profile's 8500 frames
    let text = std::fs::read_to_string(&csv).expect("readable");
    let lines: Vec<&str> = text.lines().collect();
    let header = lines.iter().position(|l| l.starts_with("time_s,")).expect("header");
    let short = dir.join("short.csv");
    std::fs::write(&short, lines[..header + 1 + 8000].join("\n") + "\n").expect("writable");
    refused(&["firmware-trace", "--from", s(&short), "--out", s(&out)], &["short.csv", "8000 rows", "8500 frames"]);
    // another command profile of the same length: the firmware replays against the standard one
    let profile = dir.join("step.txt");
    std::fs::write(&profile, "hold 0 0\nhold 0.01 0.02\nend 0.85\n").expect("writable");
    let other = dir.join("other.csv");
    accepted(&["simulate", "--profile", s(&profile), "--out", s(&other)]);
    refused(
        &["firmware-trace", "--from", s(&other), "--out", s(&out)],
        &["other.csv", "field 'command_rad'", "--profile"],
    );
    assert!(!out.exists());
}
