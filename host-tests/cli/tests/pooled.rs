//! `ema identify A.csv B.csv …`: one fault vector fitted to several recordings; one recording
//! takes the single-recording path unchanged.

use std::path::PathBuf;

mod common;
#[path = "common/schema.rs"]
mod schema;
use common::{accepted, s, scratch};

use ema_cli::identify::{identify_recording, summary_line};
use ema_cli::pooled::identify_pooled;
use ema_cli::recording::Recording;
use ema_monitor::conditioning::ConditionedWindow;
use ema_monitor::diagnosis::IdentifyConfig;
use ema_monitor::{Command, EmaParams, Profile};

/// A recording of the healthy actuator (`ema simulate --seed SEED`) for the test `test`.
fn recording(test: &str, seed: u64) -> PathBuf {
    let p = scratch("pooled", &format!("{test}-{seed}")).join("rec.csv");
    accepted(&["simulate", "--seed", &seed.to_string(), "--out", s(&p)]);
    p
}

#[test]
fn one_recording_is_the_single_recording_identification() {
    let a = recording("one", 3);
    let text = accepted(&["identify", s(&a), "--max-iterations", "3", "--bits"]);
    assert!(text.starts_with("EMA health:") && !text.contains("pooled"), "{text}");
    let v: serde_json::Value =
        serde_json::from_str(accepted(&["identify", s(&a), "--max-iterations", "3", "--json"]).trim()).unwrap();
    assert!(v.get("pooled_recordings").is_none() && v.get("input_files").is_none(), "{v}");
    // the library's pooled identification of one trace: the single-trace report, bit for bit
    let rec = Recording::from_reference(
        &ema_reference::simulate(&ema_reference::SimConfig { seed: 3, ..Default::default() }).unwrap(),
        Vec::new(),
    );
    let config = IdentifyConfig { max_iterations: 3, ..IdentifyConfig::default() };
    let single = identify_recording(&rec, &a, &EmaParams::NOMINAL, &Profile::STANDARD, &config).unwrap();
    let trace = ema_cli::identify::condition_recording(&rec, &a, &EmaParams::NOMINAL, &Profile::STANDARD).unwrap();
    let traces: [&ConditionedWindow<{ ema_cli::identify::HOST_WINDOW }>; 1] = [&trace];
    let pooled =
        identify_pooled(&traces, &[Command::Profile(&Profile::STANDARD)], &EmaParams::NOMINAL, &config).unwrap();
    assert_eq!(summary_line(&pooled.report), summary_line(&single.report));
    assert_eq!(pooled.report.faults, single.report.faults);
}

#[test]
fn several_recordings_give_one_report_that_says_so() {
    let (a, b) = (recording("two", 3), recording("two", 4));
    let text = accepted(&["identify", s(&a), s(&b), "--max-iterations", "3"]);
    assert!(text.starts_with("pooled over 2 recordings: ") && text.contains("EMA health:"), "{text}");
    let out = accepted(&["identify", s(&a), s(&b), "--max-iterations", "3", "--json"]);
    let v: serde_json::Value = serde_json::from_str(out.trim()).expect("valid JSON");
    assert_eq!(v["pooled_recordings"], 2, "{v}");
    assert_eq!(v["input_files"], serde_json::json!([s(&a), s(&b)]), "{v}");
    assert_eq!(v["input_file"], s(&a), "{v}");
    schema::check_json("`ema identify --json`", &[&v]);
    // more than ten: refused before anything is read
    let many: Vec<&str> = std::iter::repeat_n(s(&a), 11).collect();
    let mut args = vec!["identify"];
    args.extend(many);
    common::refused(&args, &["at most 10"]);
}

/// A recording given twice is one flight, not two: refused, naming both arguments, whether it is
/// the same path, the same file by another path (a symlink, `dir/../`), or a copy of the same
/// bytes; the same for the other commands that take each recording as a flight.
#[test]
fn a_recording_given_twice_is_refused_naming_both() {
    let a = recording("twice", 3);
    let b = recording("twice", 4);
    let dir = a.parent().expect("a directory").to_path_buf();
    let link = dir.join("link.csv");
    std::os::unix::fs::symlink(&a, &link).expect("symlink");
    let dotted = dir.join("..").join(dir.file_name().expect("a name")).join("rec.csv");
    let copy = dir.join("copy.csv");
    std::fs::copy(&a, &copy).expect("copy");
    for (twin, what) in
        [(&a, "the same file"), (&link, "the same file"), (&dotted, "the same file"), (&copy, "identical")]
    {
        let needles = ["recordings 1", "and 3", s(&a), s(twin), what, "give each once"];
        common::refused(&["identify", s(&a), s(&b), s(twin), "--max-iterations", "3"], &needles);
        let out = dir.join("unit.toml");
        common::refused(&["commission", s(&a), s(&b), s(twin), "--out", s(&out)], &needles);
        common::refused(&["history", s(&a), s(&b), s(twin)], &needles);
        assert!(!out.exists());
    }
    // different recordings of one actuator are accepted
    accepted(&["identify", s(&a), s(&b), "--max-iterations", "3"]);
}
