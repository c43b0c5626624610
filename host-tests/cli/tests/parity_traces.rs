//! The traces of the host/target parity check (`traces/parity/`, `scripts/parity`): the committed
//! files are what `ema_cli::parity_traces` builds, and on the host each gives the verdict it is
//! there for (`scripts/parity` then checks that the firmware in QEMU prints the same summary).

use std::path::{Path, PathBuf};

mod common;
use common::{ema, s};

use ema_cli::identify::{firmware_trace_outcome, summary_line, Refusal};
use ema_cli::parity_traces::{parity_traces, PARITY_FILES};
use ema_monitor::diagnosis::IdentifyConfig;
use ema_monitor::effects::parse_model_config;
use ema_monitor::health::{Abstain, Status};
use ema_monitor::trace::SAMPLE_RATE_HZ;

const REGENERATE: &str =
    "cd host-tests && cargo run --release -p ema-cli --example parity-traces -- ../traces/parity --force";

fn parity_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../traces/parity")
}

fn committed(name: &str) -> Vec<u8> {
    std::fs::read(parity_dir().join(name))
        .unwrap_or_else(|e| panic!("traces/parity/{name}: {e}; regenerate: {REGENERATE}"))
}

/// The firmware's configuration for a trace: `IdentifyConfig::onboard()` with the model effects of
/// `config` (a file in traces/parity/), as `EMA_MODEL_CONFIG` gives them to the firmware.
fn onboard(config: Option<&str>) -> IdentifyConfig {
    let effects = match config {
        Some(name) => parse_model_config(&String::from_utf8(committed(name)).expect("UTF-8 configuration"))
            .expect("a valid model configuration"),
        None => ema_monitor::ModelEffects::NONE,
    };
    IdentifyConfig { effects, ..IdentifyConfig::onboard() }
}

#[test]
fn committed_parity_traces_are_what_the_generator_writes() {
    let fresh = parity_traces().expect("the parity traces build");
    let names: Vec<&str> = fresh.iter().map(|f| f.name).collect();
    assert_eq!(names, PARITY_FILES);
    for f in &fresh {
        assert!(f.bytes.len() < 50_000, "{}: {} bytes", f.name, f.bytes.len());
        assert!(
            committed(f.name) == f.bytes,
            "traces/parity/{} differs from its generator; regenerate: {REGENERATE}",
            f.name
        );
    }
}

#[test]
fn the_second_fault_is_a_diagnosis_at_10_khz_and_inconclusive_as_declared() {
    let config = onboard(Some("viscous.conf"));
    let mut bytes = committed("backlash-short-viscous-8khz.ematrace");
    let declared =
        firmware_trace_outcome(&bytes, &ema_monitor::EmaParams::NOMINAL, &config).expect("identified").report;
    assert_eq!(declared.status, Status::Inconclusive(Abstain::RateMismatch), "{declared}");
    // the same frames declared at 10 kHz: a diagnosis (backlash and a short on phase C, both
    // DEGRADED), and the declared rate changes nothing but the status
    bytes[8..12].copy_from_slice(&SAMPLE_RATE_HZ.to_le_bytes());
    ema_monitor::trace::reseal(&mut bytes).expect("an EMA3 trace");
    let at_rate = firmware_trace_outcome(&bytes, &ema_monitor::EmaParams::NOMINAL, &config).expect("identified").report;
    assert_eq!(at_rate.status, Status::Degraded, "{at_rate}");
    let k = at_rate.faults.0;
    assert!((k[1] - 0.3).abs() < 0.02 && (k[4] - 0.35).abs() < 0.02, "{k:?}");
    let tail = |line: String| line.split_once(" fitness ").map(|(_, t)| t.to_owned()).expect("a fitness field");
    assert_eq!(tail(summary_line(&declared)), tail(summary_line(&at_rate)));
}

#[test]
fn a_stuck_phase_is_a_sensor_fault() {
    let report =
        firmware_trace_outcome(&committed("stuck-phase-b.ematrace"), &ema_monitor::EmaParams::NOMINAL, &onboard(None))
            .expect("identified")
            .report;
    assert_eq!(report.status, Status::SensorFault, "{report}");
    assert!(summary_line(&report).starts_with("summary: SENSOR_FAULT fitness "), "{}", summary_line(&report));
}

#[test]
fn too_short_and_malformed_traces_are_refused_with_the_firmware_summary() {
    let refusal = |name: &str| {
        firmware_trace_outcome(&committed(name), &ema_monitor::EmaParams::NOMINAL, &onboard(None)).expect_err(name)
    };
    let short: Refusal = refusal("too-short.ematrace");
    assert_eq!(short.summary_line(), "summary: REFUSED acquisition Conditioning(TooShort)");
    let padding = refusal("bad-padding.ematrace");
    assert_eq!(padding.summary_line(), "summary: REFUSED trace Padding");
    let checksum = refusal("bad-checksum.ematrace");
    assert_eq!(checksum.summary_line(), "summary: REFUSED trace Checksum");
    // the same bytes with the checksum written again: the flipped bit reads as another current
    let mut resealed = committed("bad-checksum.ematrace");
    ema_monitor::trace::reseal(&mut resealed).expect("an EMA3 trace");
    let accepted = firmware_trace_outcome(&resealed, &ema_monitor::EmaParams::NOMINAL, &onboard(None));
    assert!(!matches!(&accepted, Err(r) if r.stage == "trace"), "the packed format accepts it: {accepted:?}");

    // the command prints the summary on stdout, then its one error line, exit status 2
    let path = parity_dir().join("bad-padding.ematrace");
    let out = ema(&["identify", "--firmware-trace", s(&path), "--bits"]);
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert_eq!(stdout, "summary: REFUSED trace Padding\n");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.starts_with("error: ") && stderr.contains("packed trace padding is not zero"), "{stderr}");
    // without --bits, a refusal is the usual single error line
    let out = ema(&["identify", "--firmware-trace", s(&path)]);
    assert!(out.stdout.is_empty() && out.status.code() == Some(2));
    // a bad checksum, the same way, the message naming the file
    let path = parity_dir().join("bad-checksum.ematrace");
    let out = ema(&["identify", "--firmware-trace", s(&path), "--bits"]);
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert_eq!(stdout, "summary: REFUSED trace Checksum\n");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.starts_with("error: ") && stderr.contains("bad-checksum.ematrace"), "{stderr}");
    assert!(stderr.contains("checksum does not match"), "{stderr}");
}

/// The firmware's two flights on the built-in trace: `--bits` prints a summary line per flight,
/// the lines the firmware printed in QEMU (the run block of the root README.md, which
/// `scripts/check-docs` holds to the firmware's output): flight 1 cold, flight 2 warm from the
/// record flight 1 left. The flights' identifications step through the host's parallel sweeps;
/// the core's HealthMonitor with the firmware's one-evaluation steps gives the same reports.
#[test]
fn both_flights_are_the_firmwares() {
    use ema_cli::identify::{firmware_trace_flights_for, FIRMWARE_FLIGHTS};
    use ema_monitor::flight::{HealthMonitor, NoHooks};
    use ema_monitor::persist::HealthRecord;
    use ema_monitor::Profile;

    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let readme = std::fs::read_to_string(root.join("README.md")).expect("README.md");
    let firmware: Vec<&str> = readme.lines().filter(|l| l.starts_with("summary: ")).collect();
    assert_eq!(firmware.len(), FIRMWARE_FLIGHTS, "the README's run block: {firmware:?}");
    let trace = root.join("traces/standard.ematrace");
    let out = ema(&["identify", "--firmware-trace", s(&trace), "--bits", "--quiet"]);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    let host: Vec<&str> = stdout.lines().filter(|l| l.starts_with("summary: ")).collect();
    assert_eq!(host, firmware);

    // the host's flights against the core's, stepped one evaluation at a time, on one record
    let bytes = std::fs::read(&trace).expect("the built-in trace");
    let params = ema_monitor::EmaParams::NOMINAL;
    let flights = firmware_trace_flights_for(&bytes, &params, &Profile::STANDARD, &onboard(None), FIRMWARE_FLIGHTS)
        .expect("flown");
    let monitor = HealthMonitor::onboard(params, &Profile::STANDARD, ema_monitor::ModelEffects::NONE).expect("valid");
    let packed = ema_monitor::trace::PackedTrace::parse(&bytes).expect("parses");
    let mut reader = ema_monitor::acquisition::PhaseCurrentReader::new(
        ema_monitor::acquisition::ReplayAdc::new(packed),
        (ema_monitor::acquisition::PhaseA, ema_monitor::acquisition::PhaseB, ema_monitor::acquisition::PhaseC),
        ema_monitor::acquisition::Calibration::NOMINAL,
        ema_monitor::acquisition::replay_config(&packed),
    )
    .expect("the replay reader");
    let mut window = Box::new(ema_monitor::conditioning::ConditionedWindow::new());
    let acquired = monitor.acquire(&mut reader, &mut window, packed.sample_rate_hz() as f32).expect("acquired");
    let mut record = HealthRecord::new();
    let expected: Vec<String> = (0..FIRMWARE_FLIGHTS)
        .map(|_| summary_line(&monitor.diagnose(&window, &acquired, &mut record, &mut NoHooks).expect("flown").report))
        .collect();
    let got: Vec<String> =
        std::iter::once(&flights.first).chain(&flights.later).map(|o| summary_line(&o.report)).collect();
    assert_eq!(got, expected);
    assert!(flights.first.warm.is_none() && flights.later[0].warm.is_some(), "cold, then warm");
}
