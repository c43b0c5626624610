//! Recordings transformed the way test benches write them — resampled (5, 20, 100 kHz), renamed
//! columns with an extra one, semicolon and tab delimiters, a byte order mark, timestamp jitter,
//! a pre-trigger and trailing idle, a command quantised to 1e-5 rad — each give the diagnosis of
//! the clean 10 kHz file: the same status, and the paper's Err% (Dalla Vedova, Berri, Re, ICSRS
//! 2018; `FaultVector::paper_error_percent`, as `ema campaign` scores) within 0.5 of the clean
//! file's against the truth. At 5 kHz a block of the monitor holds two independent samples
//! instead of four: the fit test's noise model is told so, as `ema identify` tells it
//! (`LoadSummary::independent_frames_per_block`). Every refused variant fails with a message
//! that says what to change.
//!
//! The transforms are written here independently of the reader: a Lanczos interpolation
//! (`a = 8`, scaled to the lower rate) for the sensor channels, and the command held between the
//! controller's 10 kHz updates, as a faster data logger samples it.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

mod common;
use common::{accepted, refused, s, scratch};

use ema_cli::identify::identify_recording;
use ema_cli::recording::{write_csv, Recording, RecordingArgs};
use ema_monitor::diagnosis::IdentifyConfig;
use ema_monitor::{EmaParams, FaultVector, Profile};
use ema_reference::{simulate, SimConfig};

/// The fault vector of the recordings: friction and a short on phase a.
const TRUTH: FaultVector = FaultVector([0.3, 0.0, 0.2, 0.0, 0.0, 0.0, 0.5, 0.5]);

/// Largest difference of Err% between a transformed recording and the clean one.
const ERR_TOLERANCE: f64 = 0.5;

/// The clean 10 kHz recording (reference model, noise on).
fn clean() -> &'static Recording {
    static REC: OnceLock<Recording> = OnceLock::new();
    REC.get_or_init(|| {
        let r = simulate(&SimConfig { faults: TRUTH, seed: 11, ..SimConfig::default() }).expect("simulates");
        Recording::from_reference(&r, Vec::new())
    })
}

/// How a bench writes the clean recording.
#[derive(Clone)]
struct Bench {
    rate_hz: f64,
    header: [&'static str; 6],
    extra_column: bool,
    delimiter: char,
    decimal_comma: bool,
    bom: bool,
    jitter_s: f64,
    pre_trigger_s: f64,
    trailing_s: f64,
    quantum_rad: f64,
    /// A `temperature_C` column (last): a ramp from the first to the second value over the rows.
    temperature_c: Option<(f64, f64)>,
}

impl Default for Bench {
    fn default() -> Self {
        Self {
            rate_hz: 10_000.0,
            header: ["time_s", "command_rad", "position_rad", "ia_A", "ib_A", "ic_A"],
            extra_column: false,
            delimiter: ',',
            decimal_comma: false,
            bom: false,
            jitter_s: 0.0,
            pre_trigger_s: 0.0,
            trailing_s: 0.0,
            quantum_rad: 0.0,
            temperature_c: None,
        }
    }
}

/// Lanczos kernel, `a` lobes.
fn lanczos(x: f64, a: f64) -> f64 {
    if x == 0.0 {
        1.0
    } else if x.abs() >= a {
        0.0
    } else {
        let px = std::f64::consts::PI * x;
        a * px.sin() * (px / a).sin() / (px * px)
    }
}

/// `x` (10 kHz from time 0) at time `t`, band-limited to the lower of 10 kHz and `rate_hz`.
fn interpolate(x: &[f64], t: f64, rate_hz: f64) -> f64 {
    let a = 8.0;
    let scale = (rate_hz / 1e4).min(1.0); // below 1: an anti-aliasing low-pass at the new Nyquist rate
    let p = t * 1e4;
    let reach = (a / scale).ceil() as i64;
    let (mut acc, mut total) = (0.0, 0.0);
    for i in (p.floor() as i64 - reach)..=(p.floor() as i64 + reach) {
        if i < 0 || i >= x.len() as i64 {
            continue;
        }
        let w = lanczos((p - i as f64) * scale, a);
        acc += w * x[i as usize];
        total += w;
    }
    acc / total
}

/// A small deterministic generator for the jitter: uniform in [-1, 1].
struct Xorshift(u64);
impl Xorshift {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

/// The file a bench would write of the clean recording.
fn bench_file(b: &Bench) -> String {
    let rec = clean();
    let end = rec.time_s[rec.len() - 1];
    let period = 1.0 / b.rate_hz;
    let hold = |t: f64| rec.command_rad[((t * 1e4 + 1e-6).floor() as usize).min(rec.len() - 1)];
    let mut rows: Vec<[f64; 6]> = Vec::new();
    let n_pre = (b.pre_trigger_s * b.rate_hz).round() as usize;
    let n = (end * b.rate_hz + 1e-6).floor() as usize + 1;
    let n_post = (b.trailing_s * b.rate_hz).round() as usize;
    // at 10 kHz and below, every 10 kHz / rate-th sample: a slower logger reads the same sensors
    let step = 1e4 / b.rate_hz;
    let channel = |x: &[f64], t: f64| {
        if step >= 1.0 && step.fract() == 0.0 {
            x[(t * 1e4).round() as usize]
        } else {
            interpolate(x, t, b.rate_hz)
        }
    };
    for j in 0..n_pre + n + n_post {
        let file_t = j as f64 * period;
        // manoeuvre time; idle before and after: its opening and closing 10 ms, repeated
        let (src, command) = if j < n_pre {
            (((j as f64 - n_pre as f64) * period).rem_euclid(0.01), rec.command_rad[0])
        } else if j < n_pre + n {
            let t = (j - n_pre) as f64 * period;
            (t, hold(t))
        } else {
            let t = end + (j - n_pre - n + 1) as f64 * period;
            (end - 0.01 + (t - end).rem_euclid(0.01), rec.command_rad[rec.len() - 1])
        };
        rows.push([
            file_t,
            command,
            channel(&rec.position_rad, src),
            channel(&rec.ia_a, src),
            channel(&rec.ib_a, src),
            channel(&rec.ic_a, src),
        ]);
    }
    let mut rng = Xorshift(0x9e37_79b9_7f4a_7c15);
    let d = b.delimiter.to_string();
    let mut text = if b.bom { "\u{feff}".to_owned() } else { String::new() };
    let mut header: Vec<&str> = b.header.to_vec();
    if b.extra_column {
        header.insert(2, "supply_V");
    }
    if b.temperature_c.is_some() {
        header.push("temperature_C");
    }
    let total = rows.len();
    text.push_str(&header.join(&d));
    text.push('\n');
    for (j, r) in rows.into_iter().enumerate() {
        let mut v = r;
        v[0] += b.jitter_s * rng.next();
        if b.quantum_rad > 0.0 {
            v[1] = (v[1] / b.quantum_rad).round() * b.quantum_rad;
        }
        let mut fields: Vec<String> = v.iter().map(|x| x.to_string()).collect();
        if b.extra_column {
            fields.insert(2, "270.5".to_owned());
        }
        if let Some(t) = b.temperature_c {
            fields.push(ramp(t, j, total).to_string());
        }
        let mut line = fields.join(&d);
        if b.decimal_comma {
            line = line.replace('.', ",");
        }
        text.push_str(&line);
        text.push('\n');
    }
    text
}

/// Row `j` of `n` of the temperature ramp `(first, last)`.
fn ramp((first, last): (f64, f64), j: usize, n: usize) -> f64 {
    first + (last - first) * j as f64 / (n - 1) as f64
}

/// Writes `text` to a fresh file `name`.
fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("writable");
    p
}

/// `--column` items for the bench's header.
fn columns(b: &Bench) -> Vec<String> {
    let keys = ["time", "command", "position", "ia", "ib", "ic"];
    keys.iter().zip(b.header).map(|(k, h)| format!("{k}={h}")).collect()
}

/// Status (with its reason) and Err% of the diagnosis of `path`, read under `args`.
fn diagnose(path: &Path, args: &RecordingArgs) -> (String, f64, ema_cli::recording::LoadSummary) {
    let loaded = args.load(path, Some(&Profile::STANDARD), &EmaParams::NOMINAL).unwrap_or_else(|e| panic!("{e}"));
    let outcome = identify_recording(
        &loaded.recording,
        path,
        &EmaParams::NOMINAL,
        &Profile::STANDARD,
        &IdentifyConfig {
            independent_frames_per_block: loaded.summary.independent_frames_per_block(),
            ..IdentifyConfig::default()
        },
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let r = &outcome.report;
    (format!("{:?}", r.status), f64::from(r.faults.paper_error_percent(&TRUTH)), loaded.summary)
}

#[test]
fn transformed_recordings_give_the_clean_diagnosis() {
    let dir = scratch("formats", "same");
    let clean_path = dir.join("clean.csv");
    let mut bytes = Vec::new();
    write_csv(&mut bytes, clean()).expect("in memory");
    std::fs::write(&clean_path, bytes).expect("writable");
    let (status, err, _) = diagnose(&clean_path, &RecordingArgs::default());
    let renamed = ["t", "cmd", "pos", "Ia", "Ib", "Ic"];
    let cases: Vec<(&str, Bench)> = vec![
        ("5khz", Bench { rate_hz: 5_000.0, ..Bench::default() }),
        ("20khz", Bench { rate_hz: 20_000.0, ..Bench::default() }),
        ("100khz", Bench { rate_hz: 100_000.0, ..Bench::default() }),
        ("renamed", Bench { header: renamed, extra_column: true, ..Bench::default() }),
        ("semicolon", Bench { delimiter: ';', decimal_comma: true, ..Bench::default() }),
        ("tab-bom", Bench { delimiter: '\t', bom: true, ..Bench::default() }),
        ("jitter", Bench { rate_hz: 20_000.0, jitter_s: 1e-6, ..Bench::default() }),
        ("padded", Bench { pre_trigger_s: 0.01, trailing_s: 0.05, ..Bench::default() }),
        ("padded-20khz", Bench { rate_hz: 20_000.0, pre_trigger_s: 0.01, trailing_s: 0.05, ..Bench::default() }),
        ("quantised", Bench { quantum_rad: 1e-5, ..Bench::default() }),
        (
            "bench-like",
            Bench {
                rate_hz: 20_000.0,
                header: renamed,
                extra_column: true,
                delimiter: ';',
                jitter_s: 1e-6,
                pre_trigger_s: 0.01,
                trailing_s: 0.05,
                quantum_rad: 1e-5,
                ..Bench::default()
            },
        ),
    ];
    let mut table = format!("clean: {status}, Err% {err:.3}\n");
    let mut failures = Vec::new();
    let paths: Vec<PathBuf> =
        cases.iter().map(|(name, b)| write(&dir, &format!("{name}.csv"), &bench_file(b))).collect();
    let results: Vec<_> = std::thread::scope(|scope| {
        let runs: Vec<_> = cases
            .iter()
            .zip(&paths)
            .map(|((_, b), path)| {
                scope.spawn(move || diagnose(path, &RecordingArgs { columns: columns(b), ..RecordingArgs::default() }))
            })
            .collect();
        runs.into_iter().map(|r| r.join().expect("no panic")).collect()
    });
    for ((name, b), (st, e, summary)) in cases.iter().zip(results) {
        table.push_str(&format!("{name}: {st}, Err% {e:.3} (Δ {:+.3}); {}\n", e - err, summary.line()));
        if st != status || (e - err).abs() > ERR_TOLERANCE {
            failures.push(name);
        }
        if b.pre_trigger_s > 0.0 {
            assert!((summary.start_s - b.pre_trigger_s).abs() < 1e-6, "{name}: {}", summary.line());
        }
    }
    eprintln!("{table}");
    assert!(failures.is_empty(), "{failures:?} differ from the clean diagnosis:\n{table}");
}

/// At the monitor's rate a pre-trigger and trailing idle are cut, not interpolated: the rows of
/// the manoeuvre come out exactly as the clean file's.
#[test]
fn padding_at_the_monitor_rate_is_cut_exactly() {
    let dir = scratch("formats", "cut");
    let b = Bench { pre_trigger_s: 0.0123, trailing_s: 0.2, ..Bench::default() };
    let path = write(&dir, "padded.csv", &bench_file(&b));
    let loaded = RecordingArgs::default().load(&path, Some(&Profile::STANDARD), &EmaParams::NOMINAL).expect("reads");
    let rec = clean();
    assert!(!loaded.summary.resampled && (loaded.summary.start_s - 0.0123).abs() < 1e-9, "{:?}", loaded.summary);
    assert_eq!(loaded.recording.len(), rec.len());
    assert_eq!(
        (&loaded.recording.ia_a, &loaded.recording.ib_a, &loaded.recording.ic_a),
        (&rec.ia_a, &rec.ib_a, &rec.ic_a)
    );
    assert_eq!(loaded.recording.position_rad, rec.position_rad);
    // --start says the same
    let given = RecordingArgs { start: Some(0.0123), ..RecordingArgs::default() };
    let l = given.load(&path, Some(&Profile::STANDARD), &EmaParams::NOMINAL).expect("reads");
    assert_eq!((l.recording.ia_a, l.summary.start_from), (rec.ia_a.clone(), "given"));
}

/// A temperature column follows the rows: cut with them at the monitor's rate, interpolated with
/// them from 20 kHz, the pre-trigger and trailing idle left out; the identification reads it.
#[test]
fn the_temperature_column_follows_the_trimming_and_the_resampling() {
    let dir = scratch("formats", "temperature");
    let ramp_c = (-40.0, -30.0);
    for rate_hz in [10_000.0, 20_000.0] {
        let b = Bench {
            rate_hz,
            header: ["t", "cmd", "pos", "Ia", "Ib", "Ic"],
            extra_column: true,
            delimiter: ';',
            decimal_comma: true,
            pre_trigger_s: 0.0123,
            trailing_s: 0.05,
            temperature_c: Some(ramp_c),
            ..Bench::default()
        };
        let text = bench_file(&b);
        let rows = text.lines().count() - 1;
        let path = write(&dir, &format!("{rate_hz}.csv"), &text);
        let args = RecordingArgs { columns: columns(&b), ..RecordingArgs::default() };
        let loaded = args.load(&path, Some(&Profile::STANDARD), &EmaParams::NOMINAL).unwrap_or_else(|e| panic!("{e}"));
        let (rec, summary) = (&loaded.recording, &loaded.summary);
        assert_eq!(summary.resampled, rate_hz != 10_000.0, "{}", summary.line());
        let t = rec.temperature_c.as_ref().expect("the temperature column");
        assert_eq!((t.len(), rec.len()), (clean().len(), clean().len()));
        // each output row carries the ramp at its own place in the file: at the monitor's rate the
        // row `start + k`; from 20 kHz the file time `start + k·T`, T the control period (f32)
        let period = f64::from(EmaParams::NOMINAL.control_period_s);
        let first_row = (summary.start_s * rate_hz).round();
        for (k, &value) in t.iter().enumerate() {
            let file_row =
                if summary.resampled { (summary.start_s + k as f64 * period) * rate_hz } else { first_row + k as f64 };
            let want = ramp_c.0 + (ramp_c.1 - ramp_c.0) * file_row / (rows - 1) as f64;
            assert!((value - want).abs() < 1e-9, "{rate_hz} Hz, row {k}: {value} against {want}");
        }
        let mean = rec.mean_temperature_c().expect("a mean");
        assert!(mean > t[0] && mean < t[t.len() - 1], "{mean}");
    }
    // a file without the column and with another extra one reads as before
    let plain = write(&dir, "plain.csv", &bench_file(&Bench { extra_column: true, ..Bench::default() }));
    let loaded = RecordingArgs::default().load(&plain, Some(&Profile::STANDARD), &EmaParams::NOMINAL).expect("reads");
    assert_eq!(loaded.recording.temperature_c, None);
}

#[test]
fn refused_files_say_what_to_change() {
    let dir = scratch("formats", "refused");
    let load = |p: &Path, args: &RecordingArgs| {
        args.load(p, Some(&Profile::STANDARD), &EmaParams::NOMINAL).err().map(|e| e.to_string()).unwrap_or_default()
    };
    let default = RecordingArgs::default();
    let e = load(&write(&dir, "4khz.csv", &bench_file(&Bench { rate_hz: 4_000.0, ..Bench::default() })), &default);
    assert!(
        e.contains("4khz.csv") && e.contains("sample rate 4000 Hz") && e.contains("record at 5 kHz or more"),
        "{e}"
    );
    let e = load(&write(&dir, "200khz.csv", &bench_file(&Bench { rate_hz: 200_000.0, ..Bench::default() })), &default);
    assert!(e.contains("sample rate 200000 Hz") && e.contains("decimate the file to 100 kHz or less"), "{e}");
    // ±2.5 µs at 20 kHz: 5 % of the period
    let jittery = Bench { rate_hz: 20_000.0, jitter_s: 2.5e-6, ..Bench::default() };
    let e = load(&write(&dir, "jitter.csv", &bench_file(&jittery)), &default);
    assert!(e.contains("jitter.csv' line ") && e.contains("field 'time_s'"), "{e}");
    assert!(e.contains("off the uniform grid") && e.contains("jitter up to 2 µs is tolerated"), "{e}");
    // renamed columns without --column
    let renamed = Bench { header: ["t", "cmd", "pos", "Ia", "Ib", "Ic"], ..Bench::default() };
    let p = write(&dir, "renamed.csv", &bench_file(&renamed));
    let e = load(&p, &default);
    assert!(e.contains("renamed.csv' line 1: no column 'time_s' for the time channel"), "{e}");
    assert!(
        e.contains("the header has 't', 'cmd', 'pos', 'Ia', 'Ib', 'Ic'") && e.contains("--column time=HEADER"),
        "{e}"
    );
    let partly = RecordingArgs { columns: columns(&renamed)[..5].to_vec(), ..RecordingArgs::default() };
    assert!(load(&p, &partly).contains("no column 'ic_A' for the ic channel"));
    // longer than a recording may last: 61 s at 5 kHz
    let mut long = String::from("time_s,command_rad,position_rad,ia_A,ib_A,ic_A\n");
    for j in 0..=305_000 {
        long.push_str(&format!("{},0,0,0,0,0\n", j as f64 / 5e3));
    }
    let e = load(&write(&dir, "long.csv", &long), &default);
    assert!(e.contains("field 'time_s'") && e.contains("more than the 60 s a recording may last"), "{e}");
    assert!(e.contains("cut the file to the manoeuvre"), "{e}");
    // a pre-trigger with a command that starts after the manoeuvre began
    let late = Bench { pre_trigger_s: 0.0, ..Bench::default() };
    let text = bench_file(&late);
    let lines: Vec<&str> = text.lines().collect();
    let cut = format!("{}\n{}\n", lines[0], lines[150..].join("\n")); // from 14.9 ms: after the first step
    let e = load(&write(&dir, "late.csv", &cut), &default);
    assert!(e.contains("the recording starts after the manoeuvre") && e.contains("--start SECONDS"), "{e}");
    // bad flags
    let bad = RecordingArgs { columns: vec!["current=Ia".into()], ..RecordingArgs::default() };
    assert!(load(&p, &bad).contains("unknown key 'current', the keys are time, command, position, ia, ib, ic"));
    let bad = RecordingArgs { delimiter: Some("1".into()), ..RecordingArgs::default() };
    assert!(load(&p, &bad).contains("--delimiter: '1' cannot separate numbers"));
}

/// The flags reach the command line: a bench-like file identified by `ema identify` with
/// `--column`, and the trimmed start in the report.
#[test]
fn identify_takes_the_recording_flags() {
    let dir = scratch("formats", "cli");
    let b = Bench {
        rate_hz: 20_000.0,
        header: ["t", "cmd", "pos", "Ia", "Ib", "Ic"],
        delimiter: ';',
        pre_trigger_s: 0.01,
        trailing_s: 0.02,
        ..Bench::default()
    };
    let p = write(&dir, "bench.csv", &bench_file(&b));
    let mut args = vec!["identify", s(&p), "--max-iterations", "2"];
    let cols = columns(&b);
    for c in &cols {
        args.extend(["--column", c.as_str()]);
    }
    let text = accepted(&args);
    assert!(
        text.contains("recording: 20000 Hz resampled to 10000 Hz; manoeuvre starts at 0.010000 s (aligned)"),
        "{text}"
    );
    let mut json = args.clone();
    json.extend(["--json", "--delimiter", "semicolon", "--start", "0.01"]);
    let v: serde_json::Value = serde_json::from_str(accepted(&json).trim()).expect("JSON");
    assert_eq!(
        (v["recording"]["start_from"].as_str(), v["recording"]["rows"].as_u64()),
        (Some("given"), Some(8500)),
        "{v}"
    );
    refused(&["identify", s(&p), "--max-iterations", "2"], &["bench.csv", "line 1", "no column 'time_s'", "--column"]);
}

/// The README's worked example: `traces/bench/bench.csv` (20 kHz, the bench's column names,
/// semicolons, a pre-trigger) on the actuator of `traces/bench/actuator.toml` is identified as
/// recorded (friction 0.3, a 0.2 short on phase A); against the nominal actuator's parameters every
/// phase reads shorted, and the monitor abstains (unit mismatch) instead of a false diagnosis.
#[test]
fn the_shipped_bench_recording_is_identified_with_its_actuator() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../traces/bench");
    let (csv, toml) = (format!("{dir}/bench.csv"), format!("{dir}/actuator.toml"));
    let columns = [
        "--column",
        "time=t",
        "--column",
        "command=cmd",
        "--column",
        "position=pos",
        "--column",
        "ia=Ia",
        "--column",
        "ib=Ib",
        "--column",
        "ic=Ic",
    ];
    let run = |params: bool| -> serde_json::Value {
        let mut args = vec!["identify", csv.as_str(), "--json"];
        args.extend(columns);
        if params {
            args.extend(["--params", toml.as_str()]);
        }
        serde_json::from_str(&accepted(&args)).expect("json")
    };
    let truth = FaultVector([0.3, 0.0, 0.2, 0.0, 0.0, 0.0, 0.5, 0.5]);
    let with = run(true);
    assert_eq!(with["status"], "DEGRADED", "{with}");
    let k: Vec<f32> = with["k"].as_array().expect("k").iter().map(|v| v.as_f64().unwrap_or(f64::NAN) as f32).collect();
    let err = FaultVector(k.try_into().expect("8 values")).paper_error_percent(&truth);
    assert!(err < 1.0, "Err% {err}: {with}");
    let start_s = with["recording"]["start_s"].as_f64().unwrap_or(f64::NAN);
    assert!((start_s - 0.01).abs() < 1e-6, "{with}");
    let without = run(false);
    assert_eq!(
        (&without["status"], &without["reason"]),
        (&"INCONCLUSIVE".into(), &"unit mismatch".into()),
        "{without}"
    );
    let k = without.get("k").or_else(|| without.get("k_not_a_diagnosis")).expect("k");
    let k: Vec<f32> = k.as_array().expect("k").iter().map(|v| v.as_f64().unwrap_or(f64::NAN) as f32).collect();
    let err_without = FaultVector(k.try_into().expect("8 values")).paper_error_percent(&truth);
    assert!(err_without > 5.0 * err.max(0.5), "Err% {err_without} without the parameters, {err} with");
}
