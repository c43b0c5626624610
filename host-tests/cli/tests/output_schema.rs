//! Every JSON and CSV output of `ema identify`, `compare` and `campaign` against
//! `docs/output-schema.md` (`ema discover`'s: in `discover_cli.rs`), and no progress bar on
//! stderr when the output is captured (not a terminal).

mod common;
#[path = "common/schema.rs"]
mod schema;

use std::path::PathBuf;

use common::{contract_status, ema, s, scratch};

fn committed_trace() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../traces/standard.ematrace"))
}

/// Runs `ema` expecting success and nothing at all on stderr; returns stdout as JSON.
fn json_quietly(args: &[&str]) -> serde_json::Value {
    let out = ema(args);
    let err = String::from_utf8_lossy(&out.stderr);
    let expected = contract_status(args, &String::from_utf8_lossy(&out.stdout));
    assert_eq!(out.status.code(), Some(expected), "{args:?}: {err}");
    assert!(err.is_empty(), "{args:?}: stderr is not empty (a progress bar without a terminal?): {err:?}");
    serde_json::from_slice(&out.stdout).expect("JSON on stdout")
}

#[test]
fn identify_json_matches_the_schema() {
    let trace = committed_trace();
    let trace = s(&trace);
    // two iterations: no diagnosis (k_not_a_diagnosis); the on-board budget: a diagnosis (k, modes)
    let short = json_quietly(&["identify", "--firmware-trace", trace, "--json", "--max-iterations", "2"]);
    let full = json_quietly(&["identify", "--firmware-trace", trace, "--json"]);
    assert!(short.get("k_not_a_diagnosis").is_some() && full.get("modes").is_some(), "{short}\n{full}");
    assert_eq!(full["input_file"], trace);
    // a recording CSV: its path in input_file, and no spinner on a captured stderr
    let dir = scratch("schema", "identify");
    let csv = dir.join("rec.csv");
    let wrote = ema(&["simulate", "--seed", "3", "--out", s(&csv)]);
    assert!(wrote.status.success(), "{}", String::from_utf8_lossy(&wrote.stderr));
    let from_csv = json_quietly(&["identify", s(&csv), "--json", "--max-iterations", "2"]);
    assert_eq!(from_csv["input_file"], s(&csv));
    // a warm start (--prior): the warm object
    let prior = "0.25,0,0,0,0,0,0.5,0.5";
    let warm = json_quietly(&["identify", "--firmware-trace", trace, "--json", "--prior", prior]);
    assert_eq!((&warm["start"], &full["start"]), (&serde_json::json!("warm"), &serde_json::json!("cold")), "{warm}");
    // a zero beyond self-calibration on phase B: the sensors' fault object
    let text = std::fs::read_to_string(&csv).expect("written");
    let broken = dir.join("broken.csv");
    std::fs::write(&broken, common::with_pretrigger(&text, 300, [0.0, 12.0, 0.0])).expect("writable");
    let fault = json_quietly(&["identify", s(&broken), "--json", "--max-iterations", "2"]);
    assert_eq!(fault["sensors"]["fault"]["phase"], "B", "{fault}");
    schema::check_json("`ema identify --json`", &[&short, &full, &from_csv, &warm, &fault]);
}

#[test]
fn compare_json_matches_the_schema() {
    let v = json_quietly(&["compare", "--json"]);
    assert!(v.get("input_file").is_none(), "compare reads no file: {v}");
    schema::check_json("`ema compare --json`", &[&v]);
}

#[test]
fn campaign_outputs_match_the_schema_and_show_no_progress_without_a_terminal() {
    let dir = scratch("schema", "campaign");
    let out = dir.join("out");
    let mut args = vec!["campaign", "--runs", "1", "--modes", "gain", "--algorithms", "pso"];
    args.extend(["--max-iterations", "2", "--threads", "2", "--json", "--out", s(&out)]);
    let printed = json_quietly(&args);
    let written: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).expect("summary.json")).expect("JSON");
    assert_eq!(printed, written, "--json prints summary.json");
    schema::check_json("`ema campaign --json` and `summary.json`", &[&printed]);
    let csv = |name: &str| std::fs::read_to_string(out.join(name)).expect("written");
    schema::check_csv("`runs.csv` (`ema campaign --out DIR`)", &csv("runs.csv"));
    schema::check_csv("`summary.csv` (`ema campaign --out DIR`)", &csv("summary.csv"));
    // the same quantity has one name in the CSV and the JSON
    let header: Vec<String> = csv("summary.csv").lines().next().unwrap().split(',').map(str::to_string).collect();
    let cell = printed["cells"][0].as_object().expect("a cell");
    assert_eq!(cell.keys().cloned().collect::<std::collections::BTreeSet<_>>(), header.into_iter().collect());
    // --quiet is accepted (and changes nothing but the bar)
    args.extend(["--force", "--quiet"]);
    let quiet = json_quietly(&args);
    assert_eq!(quiet["cells"][0]["mean_err_percent"], printed["cells"][0]["mean_err_percent"]);
}
