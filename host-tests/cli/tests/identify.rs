//! `ema identify` end to end on the built binary: every bad input is one `error:` line naming the
//! file (and the line and field where there is one), exit status 2; good inputs give a report.

use std::path::{Path, PathBuf};

mod common;
use common::{accepted, refused, s, scratch};
use std::sync::OnceLock;

use ema_monitor::diagnosis::tuning::SELECTION_REFIT;
use ema_monitor::diagnosis::ONBOARD_POPULATION;
use ema_monitor::faults::GROUP_COUNT;
use ema_monitor::optimizer::pattern::PatternConfig;
use ema_monitor::FAULT_COUNT;

/// A recording CSV split into its lines: comments and header (kept as they are) and data rows.
struct Csv {
    head: Vec<String>,
    rows: Vec<String>,
}

impl Csv {
    fn read(path: &Path) -> Self {
        let text = std::fs::read_to_string(path).expect("readable recording");
        let lines: Vec<String> = text.lines().map(str::to_owned).collect();
        let header = lines.iter().position(|l| l.starts_with("time_s,")).expect("header line");
        Self { head: lines[..=header].to_vec(), rows: lines[header + 1..].to_vec() }
    }

    /// 1-based line number in the file of data row `r` (0-based).
    fn line_of(&self, r: usize) -> usize {
        self.head.len() + r + 1
    }

    fn write(&self, path: &Path, rows: &[String]) {
        let mut text = self.head.join("\n");
        for r in rows {
            text.push('\n');
            text.push_str(r);
        }
        text.push('\n');
        std::fs::write(path, text).expect("writable");
    }

    /// Rows `0..n` with field `field` of row `r` replaced by `value`.
    fn with_field(&self, n: usize, r: usize, field: usize, value: &str) -> Vec<String> {
        let mut rows = self.rows[..n].to_vec();
        let mut f: Vec<&str> = rows[r].split(',').collect();
        f[field] = value;
        rows[r] = f.join(",");
        rows
    }
}

/// One healthy recording of the standard profile (`ema simulate`, noise on, seed 3), shared by the tests.
fn standard_csv() -> &'static Path {
    static PATH: OnceLock<PathBuf> = OnceLock::new();
    PATH.get_or_init(|| {
        let p = scratch("identify", "standard").join("standard.csv");
        accepted(&["simulate", "--seed", "3", "--out", s(&p)]);
        p
    })
}

#[test]
fn bad_recordings_are_refused_naming_file_line_and_field() {
    let dir = scratch("identify", "bad-csv");
    let csv = Csv::read(standard_csv());
    assert_eq!(csv.rows.len(), 8500);

    // missing file
    let missing = dir.join("nope.csv");
    refused(&["identify", s(&missing)], &["nope.csv", "cannot open"]);

    // wrong header
    let p = dir.join("header.csv");
    std::fs::write(&p, "# a comment\ntime,cmd,pos,ia,ib,ic\n0,0,0,0,0,0\n0.0001,0,0,0,0,0\n").expect("writable");
    refused(&["identify", s(&p)], &["header.csv", "line 2", "no column 'time_s'", "--column time=HEADER"]);

    // NaN in a current, text in a number, time going backwards: line and field named
    let cases = [
        ("nan.csv", 20, 3, "NaN", "field 'ia_A'", "'NaN' is not a finite number"),
        ("text.csv", 7, 4, "three", "field 'ib_A'", "'three' is not a number"),
        ("inf.csv", 30, 5, "-inf", "field 'ic_A'", "'-inf' is not a finite number"),
    ];
    for (name, row, field, value, field_msg, msg) in cases {
        let p = dir.join(name);
        csv.write(&p, &csv.with_field(100, row, field, value));
        let line = format!("line {}", csv.line_of(row));
        refused(&["identify", s(&p)], &[name, &line, field_msg, msg]);
    }
    let p = dir.join("backwards.csv");
    let previous_time = csv.rows[11].split(',').next().expect("time field").to_owned();
    csv.write(&p, &csv.with_field(100, 12, 0, &previous_time));
    let line = format!("line {}", csv.line_of(12));
    refused(&["identify", s(&p)], &["backwards.csv", &line, "field 'time_s'", "does not increase"]);

    // every fifth row: a uniform 2 kHz recording, below the 5 kHz the reader resamples from
    let p = dir.join("2khz.csv");
    let fifth: Vec<String> = csv.rows.iter().step_by(5).cloned().collect();
    csv.write(&p, &fifth);
    refused(&["identify", s(&p)], &["2khz.csv", "time_s", "sample rate 2000 Hz", "5 to 100 kHz", "record at 5 kHz"]);

    // 100 rows of the standard profile: the command matches, but 25 window samples are too few
    let p = dir.join("short.csv");
    csv.write(&p, &csv.rows[..100]);
    refused(&["identify", s(&p)], &["short.csv", "too short"]);
}

#[test]
fn command_column_must_match_the_profile() {
    let dir = scratch("identify", "profile");
    let profile = dir.join("step.txt");
    std::fs::write(&profile, "hold 0 0\nhold 0.01 0.02\nend 0.05\n").expect("writable");
    let rec = dir.join("step.csv");
    accepted(&["simulate", "--profile", s(&profile), "--out", s(&rec)]);
    // the standard profile steps to 0.05 rad at 10 ms, this file's profile to 0.02 rad (f32 values)
    let err = refused(
        &["identify", s(&rec)],
        &["step.csv", "field 'command_rad'", "0.02 but the profile commands 0.05", "--profile"],
    );
    let line: usize = err
        .split("line ")
        .nth(1)
        .and_then(|t| t.split([' ', ',']).next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no line in {err}"));
    // the named line of the file is the first row where the two profiles differ: t = 10 ms
    let text = std::fs::read_to_string(&rec).expect("readable");
    let named = text.lines().nth(line - 1).unwrap_or_else(|| panic!("{err}: no line {line}"));
    let time: f64 = named.split(',').next().and_then(|t| t.parse().ok()).unwrap_or(f64::NAN);
    assert!((time - 0.01).abs() < 1e-9, "{err}: line {line} is '{named}'");
    // positive control: the same file with the profile it was made with is identified
    let out = accepted(&["identify", s(&rec), "--profile", s(&profile), "--max-iterations", "2", "--json"]);
    let v: serde_json::Value = serde_json::from_str(out.trim()).expect("JSON");
    assert_eq!(v["k"].as_array().map(Vec::len), Some(FAULT_COUNT), "{v}");
}

fn committed_trace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../traces/standard.ematrace")
}

#[test]
fn bad_firmware_traces_are_refused_naming_the_file() {
    let dir = scratch("identify", "bad-trace");
    let good = std::fs::read(committed_trace()).expect("committed trace");
    let missing = dir.join("nope.ematrace");
    refused(&["identify", "--firmware-trace", s(&missing)], &["nope.ematrace", "cannot read"]);
    let mut bytes = good.clone();
    bytes[0] = b'X';
    let p = dir.join("magic.ematrace");
    std::fs::write(&p, &bytes).expect("writable");
    refused(&["identify", "--firmware-trace", s(&p)], &["magic.ematrace", "does not start with EMA1"]);
    let p = dir.join("truncated.ematrace");
    std::fs::write(&p, &good[..good.len() - 100]).expect("writable");
    refused(&["identify", "--firmware-trace", s(&p)], &["truncated.ematrace", "checksum does not match", "truncated"]);
    let p = dir.join("header.ematrace");
    std::fs::write(&p, &good[..7]).expect("writable");
    refused(&["identify", "--firmware-trace", s(&p)], &["header.ematrace", "shorter than its 12-byte header"]);
    // one bit of one code flipped: the checksum refuses it, naming the file
    let mut flipped = good.clone();
    flipped[20_000] ^= 0x04;
    let p = dir.join("flipped.ematrace");
    std::fs::write(&p, &flipped).expect("writable");
    refused(&["identify", "--firmware-trace", s(&p)], &["flipped.ematrace", "checksum does not match", "corrupted"]);
}

/// The committed trace as the writers before EMA3 wrote it: `EMA1` (header, codes) or `EMA2`
/// (with the trigger frame), without the checksum.
fn without_checksum(ema3: &[u8], version: u8) -> Vec<u8> {
    assert_eq!(&ema3[..4], b"EMA3");
    let mut out = if version == 1 { b"EMA1".to_vec() } else { b"EMA2".to_vec() };
    out.extend_from_slice(&ema3[4..if version == 1 { 12 } else { 16 }]);
    out.extend_from_slice(&ema3[16..ema3.len() - 4]);
    out
}

/// An EMA1 or EMA2 trace, which carries no checksum, is still identified, with one warning line
/// on stderr naming the file; its flipped bit goes unnoticed (the diagnosis changes, nothing
/// refuses it). An EMA3 trace gives no warning.
#[test]
fn traces_without_checksum_are_read_with_a_warning() {
    let dir = scratch("identify", "legacy-trace");
    let good = std::fs::read(committed_trace()).expect("committed trace");
    let run = |path: &Path| {
        let args = ["identify", "--firmware-trace", s(path), "--max-iterations", "2", "--bits"];
        let out = common::ema(&args);
        let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
        let expected = common::contract_status(&args, &stdout);
        assert_eq!(out.status.code(), Some(expected), "{}", String::from_utf8_lossy(&out.stderr));
        let summary = stdout.lines().find(|l| l.starts_with("summary: ")).map(str::to_owned);
        (
            summary.unwrap_or_else(|| panic!("no summary line in {stdout}")),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    let (reference, quiet) = run(&committed_trace());
    assert!(quiet.is_empty(), "EMA3: no warning, got {quiet:?}");
    for version in [1u8, 2] {
        let p = dir.join(format!("ema{version}.ematrace"));
        std::fs::write(&p, without_checksum(&good, version)).expect("writable");
        let (stdout, stderr) = run(&p);
        assert_eq!(stdout, reference, "EMA{version}: the same frames, the same summary");
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        let needles = [format!("warning: '{}': ", p.display()), format!("EMA{version}"), "no checksum".to_owned()];
        assert!(needles.iter().all(|n| stderr.contains(n)), "{stderr}");
    }
    let mut flipped = without_checksum(&good, 1);
    flipped[20_000] ^= 0x04;
    let p = dir.join("ema1-flipped.ematrace");
    std::fs::write(&p, &flipped).expect("writable");
    let (stdout, stderr) = run(&p);
    assert_ne!(stdout, reference, "a corrupted EMA1 is identified as another recording");
    assert!(stderr.contains("no checksum"), "{stderr}");
}

#[test]
fn bad_flags_are_refused() {
    let trace = committed_trace();
    refused(&["identify", "--firmware-trace", s(&trace), "--algorithm", "annealing"], &["'annealing'", "--algorithm"]);
    refused(&["identify", "--firmware-trace", s(&trace), "--max-iterations", "many"], &["'many'", "--max-iterations"]);
    refused(&["identify"], &["<FILE>"]);
    refused(&["identify", s(standard_csv()), "--firmware-trace", s(&trace)], &["--firmware-trace", "cannot be used"]);
}

/// The JSON report: `status`, `k` (8 numbers in [0, 1]; `k_not_a_diagnosis` when the status is
/// INCONCLUSIVE or SENSOR_FAULT, as on these short or few-iteration runs: returned as `k`),
/// `fitness_A2`, `evaluations`, `untested_groups`, `identification_s`.
fn check_json(out: &str, max_iterations: u64) -> serde_json::Value {
    assert_eq!(out.trim().lines().count(), 1, "{out}");
    let mut v: serde_json::Value = serde_json::from_str(out.trim()).expect("valid JSON");
    let status = v["status"].as_str().unwrap_or_else(|| panic!("no status in {v}")).to_owned();
    let diagnosis = ["HEALTHY", "DEGRADED", "FAILING"].contains(&status.as_str());
    assert!(diagnosis || ["INCONCLUSIVE", "SENSOR_FAULT"].contains(&status.as_str()), "{v}");
    assert_eq!(v.get("k").is_some(), diagnosis, "{v}");
    if !diagnosis {
        v["k"] = v["k_not_a_diagnosis"].clone();
    }
    let k = v["k"].as_array().unwrap_or_else(|| panic!("no k in {v}"));
    assert_eq!(k.len(), FAULT_COUNT, "{v}");
    assert!(k.iter().all(|x| x.as_f64().is_some_and(|x| (0.0..=1.0).contains(&x))), "{v}");
    let fitness = v["fitness_A2"].as_f64().unwrap_or_else(|| panic!("no fitness_A2 in {v}"));
    assert!(fitness.is_finite() && fitness > 0.0, "{v}");
    let seconds = v["identification_s"].as_f64().unwrap_or_else(|| panic!("no identification_s in {v}"));
    assert!(seconds.is_finite() && seconds >= 0.0, "{v}");
    let iterations = v["iterations"].as_u64().unwrap_or_else(|| panic!("no iterations in {v}"));
    assert!((1..=max_iterations).contains(&iterations), "{v}");
    let evaluations = v["evaluations"].as_u64().unwrap_or_else(|| panic!("no evaluations in {v}"));
    // the global search's iterations × population, then model selection and the polish
    let global = ONBOARD_POPULATION as u64 * iterations;
    let later = 1
        + (GROUP_COUNT as u64) * u64::from(SELECTION_REFIT.max_evaluations)
        + u64::from(PatternConfig::default().max_evaluations);
    assert!((global..=global + later).contains(&evaluations), "{v}");
    // groups model selection had no budget left to test (the default budget never runs out on
    // the standard recordings)
    let untested = v["untested_groups"].as_u64().unwrap_or_else(|| panic!("no untested_groups in {v}"));
    assert!(untested <= GROUP_COUNT as u64, "{v}");
    v
}

#[test]
fn firmware_trace_identifies_to_json() {
    let trace = committed_trace();
    let args = ["identify", "--firmware-trace", s(&trace), "--json", "--max-iterations", "5"];
    let v = check_json(&accepted(&args), 5);
    // same seed, same answer (the parity check relies on it)
    let again = check_json(&accepted(&args), 5);
    assert_eq!((&v["k"], &v["fitness_A2"]), (&again["k"], &again["fitness_A2"]));
}

#[test]
fn short_recording_identifies_to_json() {
    let dir = scratch("identify", "good-csv");
    let csv = Csv::read(standard_csv());
    let p = dir.join("first-0.2s.csv");
    csv.write(&p, &csv.rows[..2000]);
    check_json(&accepted(&["identify", s(&p), "--json", "--max-iterations", "5"]), 5);
    let text = accepted(&["identify", s(&p), "--max-iterations", "3", "--algorithm", "ga"]);
    assert!(text.starts_with("EMA health:") && text.contains("identification took"), "{text}");
}

#[test]
fn differential_evolution_is_selectable_and_deterministic() {
    let dir = scratch("identify", "de");
    let csv = Csv::read(standard_csv());
    let p = dir.join("first-0.2s.csv");
    csv.write(&p, &csv.rows[..2000]);
    // the global search alone (model selection returns both to healthy on this short recording)
    // 20 generations of 50 (fewer leave both at the healthy start on this recording): the evaluation
    // count and bounds checks of check_json hold for DE too.
    let args = ["identify", s(&p), "--algorithm", "de", "--json", "--max-iterations", "20", "--paper-only"];
    let de = check_json(&accepted(&args), 20);
    assert_eq!((&de["k"], &de["fitness_A2"]), (&check_json(&accepted(&args), 20)["k"], &de["fitness_A2"]));
    // A different optimizer from the PSO: same input, same seed, another search.
    let pso = check_json(&accepted(&["identify", s(&p), "--json", "--max-iterations", "20", "--paper-only"]), 20);
    assert_ne!(de["k"], pso["k"]);
}

/// The host's parallel global search (`identify::run_to_end`: each PSO sweep evaluated on the
/// rayon pool, the costs handed back in order) gives the firmware's sequential identification bit
/// for bit: faults, cost and evaluations, on a healthy and two faulty recordings, two seeds each.
#[test]
fn parallel_global_search_is_the_sequential_one() {
    use ema_cli::identify::{condition_recording, run_to_end, HOST_WINDOW};
    use ema_cli::recording::Recording;
    use ema_monitor::diagnosis::{Identification, IdentifyConfig};
    use ema_monitor::{EmaParams, FaultVector, Profile};
    use ema_reference::{simulate, SimConfig};

    let vectors = [
        FaultVector::HEALTHY,
        FaultVector([0.25, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]),
        FaultVector([0.0, 0.3, 0.0, 0.2, 0.0, 0.4, 0.7, 0.5]),
    ];
    for (i, truth) in vectors.iter().enumerate() {
        let rec =
            simulate(&SimConfig { faults: *truth, seed: 40 + i as u64, ..SimConfig::default() }).expect("simulates");
        let recording = Recording::from_reference(&rec, Vec::new());
        let trace = condition_recording(&recording, Path::new("parallel"), &EmaParams::NOMINAL, &Profile::STANDARD)
            .expect("conditions");
        for seed in [1, 2] {
            let config = IdentifyConfig { seed, max_iterations: 10, ..IdentifyConfig::onboard() };
            let new = || {
                Box::new(
                    Identification::<'_, HOST_WINDOW, ONBOARD_POPULATION>::new(
                        &trace,
                        EmaParams::NOMINAL,
                        &Profile::STANDARD,
                        &config,
                    )
                    .expect("configures"),
                )
            };
            let mut sequential = new();
            sequential.run(u32::MAX);
            let mut parallel = new();
            run_to_end(&mut parallel);
            let (a, b) = (sequential.report(), parallel.report());
            let bits = |r: &ema_monitor::health::HealthReport| r.faults.0.map(f32::to_bits);
            assert_eq!(bits(&a), bits(&b), "recording {i}, seed {seed}");
            assert_eq!(a.fitness.to_bits(), b.fitness.to_bits(), "recording {i}, seed {seed}");
            assert_eq!(a.evaluations, b.evaluations, "recording {i}, seed {seed}");
        }
    }
}
