//! `ema firmware-trace`: the committed `traces/standard.ematrace` is exactly what the reference model
//! records today, and the command writes it.

use std::path::{Path, PathBuf};

mod common;
use common::{ema, scratch};

use ema_cli::firmware_trace::{
    default_out, firmware_trace_bytes, firmware_trace_bytes_for, BuiltInProfile, FIRMWARE_TRACE_FAULTS,
    FIRMWARE_TRACE_SEED,
};
use ema_cli::identify::firmware_trace_outcome_for;
use ema_cli::recording::read_recording;
use ema_monitor::diagnosis::IdentifyConfig;
use ema_monitor::health::Status;
use ema_monitor::trace::{counts_to_amps, PackedTrace, SAMPLE_RATE_HZ};
use ema_monitor::Profile;

/// The exact command that regenerates the committed trace.
const REGENERATE: &str =
    "cd host-tests && cargo run --release --bin ema -- firmware-trace --out ../traces/standard.ematrace --force";

fn committed_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../traces/standard.ematrace")
}

fn committed() -> Vec<u8> {
    let path = committed_path();
    std::fs::read(&path).unwrap_or_else(|e| panic!("cannot read {}: {e}; regenerate it: {REGENERATE}", path.display()))
}

fn faults_csv() -> String {
    FIRMWARE_TRACE_FAULTS.0.iter().map(|k| k.to_string()).collect::<Vec<_>>().join(",")
}

#[test]
fn committed_trace_matches_the_reference_model() {
    let fresh =
        firmware_trace_bytes(&ema_monitor::EmaParams::NOMINAL).expect("the reference model records the firmware trace");
    let on_disk = committed();
    let first_difference = fresh.iter().zip(&on_disk).position(|(a, b)| a != b);
    assert!(
        fresh == on_disk,
        "traces/standard.ematrace differs from the reference model's recording (regenerated {} bytes, committed {} \
         bytes, first difference at byte {first_difference:?}); regenerate it with `{REGENERATE}`, check the \
         firmware (`EMA_INSNCOUNT=0 cargo run --release` at the repository root) and commit it",
        fresh.len(),
        on_disk.len(),
    );
    // without --out: a file in the working directory named after the input, not the committed trace
    assert_eq!(default_out(None), PathBuf::from("standard.ematrace"));
    assert_eq!(default_out(Some(Path::new("runs/rec.csv"))), PathBuf::from("rec.ematrace"));
    let t = PackedTrace::parse(&fresh).expect("valid packed trace");
    assert_eq!((t.frames(), t.sample_rate_hz(), fresh.len()), (8500, SAMPLE_RATE_HZ, 38_270));
    assert!(t.has_checksum(), "EMA3: the trace carries its checksum");
}

/// The codes are the reference model's ADC output: the CSV of the same run (`ema simulate` with the
/// same faults and seed) holds exactly `counts_to_amps` of them, row by row.
#[test]
fn trace_codes_are_the_recorded_adc_codes_of_the_same_run() {
    let dir = scratch("fwtrace", "csv");
    let csv = dir.join("same-run.csv");
    let o = ema(&[
        "simulate",
        "--faults",
        &faults_csv(),
        "--seed",
        &FIRMWARE_TRACE_SEED.to_string(),
        "--noise",
        "on",
        "--out",
        csv.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let rec = read_recording(&csv).expect("valid recording");
    let bytes = committed();
    let t = PackedTrace::parse(&bytes).expect("valid packed trace");
    assert_eq!(rec.len(), t.frames());
    for (k, f) in t.iter().enumerate() {
        let amps = f.map(|c| f64::from(counts_to_amps(c)));
        assert_eq!(amps, [rec.ia_a[k], rec.ib_a[k], rec.ic_a[k]], "row {k}: codes {f:?}; regenerate: {REGENERATE}");
    }
    // noise on: a noiseless run of the same faults records other codes
    let quiet = dir.join("quiet.csv");
    let o = ema(&["simulate", "--faults", &faults_csv(), "--noise", "off", "--out", quiet.to_str().expect("utf-8")]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let quiet = read_recording(&quiet).expect("valid recording");
    assert_ne!(quiet.ia_a, rec.ia_a);
}

#[test]
fn firmware_trace_command_writes_the_trace_and_one_summary_line() {
    let dir = scratch("fwtrace", "cmd");
    let out = dir.join("t.ematrace");
    let o = ema(&["firmware-trace", "--out", out.to_str().expect("utf-8")]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(o.stderr.is_empty(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(stdout.lines().count(), 1, "{stdout}");
    for needle in ["8500 frames", "10000 Hz", "38270 bytes", "t.ematrace", &faults_csv(), "seed 1", "noise on"] {
        assert!(stdout.contains(needle), "'{needle}' missing from {stdout}");
    }
    assert!(
        std::fs::read(&out).expect("written") == committed(),
        "the command wrote other bytes than the committed trace; regenerate: {REGENERATE}"
    );
    // an unwritable destination: one error line, exit 2, naming the file
    let bad = dir.join("missing-dir").join("t.ematrace");
    let o = ema(&["firmware-trace", "--out", bad.to_str().expect("utf-8")]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.starts_with("error: cannot write") && err.contains("missing-dir"), "{err}");
    assert!(!bad.exists());
}

/// traces/README.md documents the constants and the command that the code uses.
#[test]
fn readme_documents_the_command_faults_and_seed() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../traces/README.md");
    let readme = std::fs::read_to_string(&path).expect("traces/README.md exists");
    for needle in [
        "cargo run --release --bin ema -- firmware-trace --out ../traces/standard.ematrace --force".to_owned(),
        format!("`{}`", faults_csv()),
        format!("seed `{FIRMWARE_TRACE_SEED}`"),
        "8500 frames".to_owned(),
        "38 270 bytes".to_owned(),
    ] {
        assert!(readme.contains(&needle), "traces/README.md does not mention {needle}");
    }
}

/// The exact command that regenerates the committed pbit trace.
const REGENERATE_PBIT: &str = "cd host-tests && cargo run --release --bin ema -- firmware-trace --profile pbit \
     --out ../traces/pbit.ematrace --force";

/// `traces/pbit.ematrace` (the firmware's trace with `EMA_PROFILE=pbit`) is the reference model's
/// recording of `Profile::PBIT`, and the firmware's whole path on it (replay, acquisition into
/// the on-board window, on-board identification driven by the pbit profile) finds its friction
/// fault and nothing else.
#[test]
fn the_pbit_trace_passes_the_on_board_path() {
    let fresh = firmware_trace_bytes_for(&ema_monitor::EmaParams::NOMINAL, BuiltInProfile::Pbit).expect("recorded");
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../traces/pbit.ematrace");
    let on_disk =
        std::fs::read(&path).unwrap_or_else(|e| panic!("cannot read {}: {e}; {REGENERATE_PBIT}", path.display()));
    assert!(fresh == on_disk, "traces/pbit.ematrace differs from the reference model's recording; {REGENERATE_PBIT}");
    let t = PackedTrace::parse(&fresh).expect("valid packed trace");
    assert_eq!((t.frames(), t.sample_rate_hz(), fresh.len()), (8800, SAMPLE_RATE_HZ, 39_620));
    let report = firmware_trace_outcome_for(
        &fresh,
        &ema_monitor::EmaParams::NOMINAL,
        &Profile::PBIT,
        &IdentifyConfig::onboard(),
    )
    .expect("identified")
    .report;
    assert_eq!(report.status, Status::Degraded, "{report}");
    let k = report.faults.0;
    // reads 0.262: within 0.03 of the truth, as the standard trace reads 0.250
    assert!((k[0] - 0.25).abs() < 0.03, "friction 0.25: {k:?}");
    assert!(k[1..6].iter().all(|&x| x == 0.0) && k[7] == 0.5, "nothing else: {k:?}");
}
