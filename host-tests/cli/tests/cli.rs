//! `ema simulate` end to end on the built binary, and the recording reader's refusals.

use std::path::Path;

mod common;
use common::{ema, refused, scratch};

use ema_cli::recording::sidecar::{Sidecar, SCHEMA_VERSION};
use ema_cli::recording::{read_recording, RecordingErrorKind, HEADER};
use ema_monitor::FaultVector;
use ema_reference::{simulate, Effect, Effects, SimConfig};

#[test]
fn bad_flags_are_refused_with_one_line() {
    let dir = scratch("cli", "flags");
    let out = dir.join("out.csv");
    let out = out.to_str().expect("utf-8 temp path");
    refused(&["simulate", "--faults", "0,0,0", "--out", out], &["--faults", "need 8", "found 3"]);
    refused(&["simulate", "--faults", "0,0,0,0,0,0,0,0,0", "--out", out], &["need 8", "found 9"]);
    refused(&["simulate", "--faults", "0,0,0,0,0,0,0.5,1.5", "--out", out], &["k8 = 1.5", "outside [0, 1]"]);
    refused(&["simulate", "--faults", "-0.2,0,0,0,0,0,0.5,0.5", "--out", out], &["k1 = -0.2", "outside"]);
    refused(&["simulate", "--faults", "0,0,0,NaN,0,0,0.5,0.5", "--out", out], &["k4 = NaN"]);
    refused(&["simulate", "--faults", "0,abc,0,0,0,0,0.5,0.5", "--out", out], &["k2 = 'abc' is not a number"]);
    refused(&["simulate", "--effect", "cogging=1.5", "--out", out], &["--effect", "severity 1.5", "cogging", "[0, 1]"]);
    refused(&["simulate", "--effect", "cogging=-0.5", "--out", out], &["severity -0.5"]);
    refused(&["simulate", "--effect", "stribeck=NaN", "--out", out], &["severity NaN"]);
    refused(&["simulate", "--effect", "stribeck=lots", "--out", out], &["severity 'lots' is not a number"]);
    refused(
        &["simulate", "--effect", "coggin=0.5", "--out", out],
        &["unknown effect 'coggin'", "cogging", "bus_sag", "compliance"],
    );
    refused(&["simulate", "--effect", "cogging", "--out", out], &["'cogging' is not ID=S"]);
    refused(
        &["simulate", "--effect", "viscous=0.1", "--effect", "viscous=0.2", "--out", out],
        &["effect 'viscous' given more than once"],
    );
    refused(&["simulate", "--noise", "loud", "--out", out], &["'loud'", "--noise", "on, off"]);
    refused(&["simulate", "--seed", "x", "--out", out], &["'x'", "--seed"]);
    refused(&["simulate"], &["--out"]);
    refused(&["simulate", "--out", out, "--bogus"], &["--bogus"]);
    refused(&[], &["subcommand"]);
    for weight in ["0", "1.5", "NaN"] {
        refused(
            &["identify", "--firmware-trace", "../traces/standard.ematrace", "--fast-regime-weight", weight],
            &["--fast-regime-weight", "not in (0, 1]"],
        );
        refused(
            &["campaign", "--runs", "1", "--fast-regime-weight", weight],
            &["--fast-regime-weight", "not in (0, 1]"],
        );
    }
    refused(&["simulate", "--profile", "no-such-profile", "--out", out], &["--profile", "no-such-profile", "neither"]);
    let missing_dir = dir.join("missing").join("out.csv");
    refused(&["simulate", "--out", missing_dir.to_str().expect("utf-8")], &["cannot write", "missing"]);
    assert!(!Path::new(out).exists(), "no output on refusal");
}

#[test]
fn bad_profile_files_name_file_and_line() {
    let dir = scratch("cli", "profiles");
    let out = dir.join("out.csv");
    let cases = [
        ("keyword.txt", "hold 0 0\n# fine\nstep 0.1 0.05\nend 0.2\n", "line 3", "unknown keyword 'step'"),
        ("count.txt", "hold 0 0\nramp 0.1 0.05\nend 0.2\n", "line 2", "takes 3 values"),
        ("number.txt", "hold 0 0\nhold 0.1 fast\nend 0.2\n", "line 2", "VALUE 'fast' is not a number"),
        ("order.txt", "hold 0 0\nhold 0.1 0.01\nhold 0.05 0\nend 0.2\n", "line 3", "does not come after"),
        ("stops.txt", "hold 0 0\n\nsine 0.1 0.3 0.4 2\nend 0.2\n", "line 3", "end stops"),
        ("noend.txt", "hold 0 0\n", "noend.txt", "no 'end DURATION'"),
        ("duration.txt", "hold 0 0\nhold 0.1 0\nend 0.1\n", "line 3", "duration 0.1 s"),
    ];
    for (name, text, line, msg) in cases {
        let p = dir.join(name);
        std::fs::write(&p, text).expect("writable");
        let err = refused(
            &["simulate", "--profile", p.to_str().expect("utf-8"), "--out", out.to_str().expect("utf-8")],
            &[name, line, msg],
        );
        // the place every file error opens with: 'PATH' line N
        assert!(err.starts_with(&format!("error: '{}'", p.display())), "{err}");
    }
}

/// A reader that closes the pipe before the summary (`ema … | head -0`) ends the command quietly:
/// exit 0, no panic about a broken pipe.
#[test]
fn a_closed_stdout_is_not_a_panic() {
    use std::process::{Command, Stdio};
    let dir = scratch("cli", "closed-stdout");
    let out = dir.join("rec.csv");
    let mut child = Command::new(env!("CARGO_BIN_EXE_ema"))
        .args(["simulate", "--out", out.to_str().expect("utf-8")])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the binary runs");
    drop(child.stdout.take()); // the reader is gone before the summary is written
    let o = child.wait_with_output().expect("it ends");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(out.exists(), "the recording is still written");
}

#[test]
fn simulate_round_trips_through_the_reader() {
    let dir = scratch("cli", "roundtrip");
    let out = dir.join("rec.csv");
    let faults = "0.2,0.1,0.3,0,0,0.4,0.25,0.6";
    let run = || {
        let o = ema(&[
            "simulate",
            "--faults",
            faults,
            "--effect",
            "cogging=0.3",
            "--effect",
            "dead_time=0.5",
            "--seed",
            "7",
            "--out",
            out.to_str().expect("utf-8"),
            "--force", // the second run replaces the first run's file
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(String::from_utf8_lossy(&o.stdout).contains("wrote 8500 samples"));
        std::fs::read(&out).expect("written")
    };
    let first = run();
    assert_eq!(first, run(), "same seed, same file");
    let rec = read_recording(&out).expect("valid recording");
    let cfg = SimConfig {
        faults: FaultVector([0.2, 0.1, 0.3, 0.0, 0.0, 0.4, 0.25, 0.6]),
        effects: Effects::NONE.with(Effect::Cogging, 0.3).and_then(|e| e.with(Effect::DeadTime, 0.5)).expect("valid"),
        seed: 7,
        ..SimConfig::default()
    };
    let truth = simulate(&cfg).expect("valid");
    assert_eq!(rec.len(), truth.samples.len());
    for (k, s) in truth.samples.iter().enumerate() {
        let row = [rec.time_s[k], rec.command_rad[k], rec.position_rad[k], rec.ia_a[k], rec.ib_a[k], rec.ic_a[k]];
        let want =
            [s.time_s, s.command_rad, s.position_rad, s.phase_current_a[0], s.phase_current_a[1], s.phase_current_a[2]];
        assert_eq!(row, want, "row {k}");
    }
    assert_eq!(rec.sample_period_s(), 1e-4);
    // a plain CSV: the header first, no comment line; the metadata in the sidecar rec.json
    let text = std::fs::read_to_string(&out).expect("readable");
    assert!(text.starts_with(&format!("{}\n", HEADER.join(","))) && !text.contains('#'), "{}", &text[..80]);
    assert!(rec.comments.is_empty(), "{:?}", rec.comments);
    let side = Sidecar::for_recording(&out).expect("readable sidecar").expect("a sidecar beside the recording");
    assert_eq!((side.schema_version, side.tool_version.as_str()), (SCHEMA_VERSION, env!("CARGO_PKG_VERSION")));
    assert_eq!((side.recording.as_str(), side.rows, side.sample_rate_hz), ("rec.csv", 8500, 10_000));
    assert_eq!(side.faults, vec![0.2, 0.1, 0.3, 0.0, 0.0, 0.4, 0.25, 0.6], "{faults}");
    assert_eq!(side.effects.get("cogging"), Some(&0.3));
    assert_eq!(side.effects.get("dead_time"), Some(&0.5));
    assert_eq!((side.profile.as_str(), side.noise, side.seed), ("standard", true, 7));
    assert_eq!(side.columns, HEADER.to_vec());
}

#[test]
fn profile_file_drives_the_command() {
    let dir = scratch("cli", "profile");
    let p = dir.join("p.txt");
    std::fs::write(&p, "# test\nhold 0 0\nramp 0.01 0 0.5   # up\nsine 0.05 0.02 0.01 10\nend 0.1\n")
        .expect("writable");
    let out = dir.join("rec.csv");
    let o = ema(&[
        "simulate",
        "--profile",
        p.to_str().expect("utf-8"),
        "--noise",
        "off",
        "--out",
        out.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let rec = read_recording(&out).expect("valid");
    assert_eq!(rec.len(), 1000);
    assert_eq!(rec.command_rad[50], 0.0);
    assert!((rec.command_rad[300] - 0.01).abs() < 1e-6, "{}", rec.command_rad[300]);
    assert!((rec.command_rad[750] - 0.03).abs() < 1e-6, "{}", rec.command_rad[750]);
    // quarter period of 10 Hz
}

/// The reader refuses every malformed file with its name, the line and the field.
#[test]
fn reader_refuses_bad_files_naming_file_line_and_field() {
    let dir = scratch("cli", "reader");
    let header = HEADER.join(",");
    let good_rows = "0,0,0,0,0,0\n0.0001,0,0,0,0,0\n0.0002,0,0,0,0,0\n";
    // (file, content, expected line, expected field, expected message)
    type Case<'a> = (&'a str, String, Option<usize>, Option<&'a str>, &'a str);
    let cases: Vec<Case> = vec![
        ("empty.csv", String::new(), None, None, "empty file"),
        ("comments.csv", "# only a comment\n\n".into(), None, None, "empty file"),
        (
            "header.csv",
            format!("# c\ntime,cmd,pos,ia,ib,ic\n{good_rows}"),
            Some(2),
            None,
            "no column 'time_s' for the time channel",
        ),
        (
            "fields.csv",
            format!("{header}\n0,0,0,0,0,0\n0.0001,0,0,0,0\n"),
            Some(3),
            None,
            "expected 6 fields (as the header), found 5",
        ),
        (
            "text.csv",
            format!("{header}\n0,0,0,0,0,0\n0.0001,0,0,zero,0,0\n"),
            Some(3),
            Some("ia_A"),
            "'zero' is not a number",
        ),
        (
            "nan.csv",
            format!("{header}\n0,0,NaN,0,0,0\n0.0001,0,0,0,0,0\n"),
            Some(2),
            Some("position_rad"),
            "'NaN' is not a finite",
        ),
        (
            "inf.csv",
            format!("{header}\n0,0,0,0,0,inf\n0.0001,0,0,0,0,0\n"),
            Some(2),
            Some("ic_A"),
            "'inf' is not a finite",
        ),
        (
            "back.csv",
            format!("{header}\n0,0,0,0,0,0\n0.0001,0,0,0,0,0\n0.0001,0,0,0,0,0\n"),
            Some(4),
            Some("time_s"),
            "does not increase",
        ),
        (
            "gap.csv",
            format!("{header}\n0,0,0,0,0,0\n0.0001,0,0,0,0,0\n0.0003,0,0,0,0,0\n"),
            Some(4),
            Some("time_s"),
            "non-uniform",
        ),
        ("short.csv", format!("{header}\n0,0,0,0,0,0\n"), None, None, "too few rows: 1"),
        ("norows.csv", format!("{header}\n"), None, None, "too few rows: 0"),
    ];
    for (name, text, line, field, msg) in cases {
        let p = dir.join(name);
        std::fs::write(&p, &text).expect("writable");
        let e = read_recording(&p).expect_err(name);
        let shown = e.to_string();
        assert_eq!(e.line, line, "{shown}");
        assert_eq!(e.field.as_deref(), field, "{shown}");
        assert!(shown.contains(name) && shown.contains(msg), "{shown}");
        if let Some(l) = line {
            assert!(shown.contains(&format!("line {l}")), "{shown}");
        }
        if let Some(f) = field {
            assert!(shown.contains(&format!("field '{f}'")), "{shown}");
        }
    }
    let missing = read_recording(dir.join("nope.csv")).expect_err("missing file");
    assert!(matches!(missing.kind, RecordingErrorKind::Io(_)));
    assert!(missing.to_string().contains("nope.csv") && missing.to_string().contains("cannot open"), "{missing}");
    // A missing column shows what was looked for, the headers found and the flag to give.
    let e = read_recording(dir.join("header.csv")).expect_err("bad header").to_string();
    assert!(
        e.contains("the header has 'time', 'cmd', 'pos', 'ia', 'ib', 'ic'; name the column with --column time=HEADER"),
        "{e}"
    );
    // A good file with comments and blank lines reads.
    let p = dir.join("good.csv");
    std::fs::write(&p, format!("# a\n\n{header}\n{good_rows}\n")).expect("writable");
    let r = read_recording(&p).expect("valid");
    assert_eq!((r.len(), r.comments.clone()), (3, vec!["a".to_owned()]));
}

/// One error format for every file the commands read (docs/cli.md, "Errors"):
/// `error: 'PATH' line N, field 'NAME': message` (the line, the field when known), and numbers
/// to their meaningful digits, never at full length.
#[test]
fn every_file_error_has_one_format_and_short_numbers() {
    let dir = scratch("cli", "format");
    let p = |name: &str, text: &str| {
        let path = dir.join(name);
        std::fs::write(&path, text).expect("writable");
        path.to_str().expect("utf-8").to_owned()
    };
    let header = HEADER.join(",");
    let good = dir.join("good.csv");
    let good = good.to_str().expect("utf-8");
    common::accepted(&["simulate", "--out", good]);
    let out = dir.join("out.csv");
    let out = out.to_str().expect("utf-8");
    let csv = p("text.csv", &format!("{header}\n0,0,0,0,0,0\n0.0001,0,0,x,0,0\n"));
    let huge = p("huge.csv", &format!("{header}\n0,0,0,0,0,0\n1e308,0,0,0,0,0\n"));
    let params = p("params.toml", "\nphase_resistance_ohm = 1e38\n");
    let tolerances = p("tol.toml", "static_friction = 0.1\n");
    let sensors = p("sensors.toml", "offset_a = 1e300\n");
    let profile = p("profile.txt", "hold 0 0\nhold 1e30 0\nend 2\n");
    let config = p("model.conf", "effect viscous 0.3\neffect viscous 1e300\n");
    let trace = p("garbage.ematrace", "not a trace");
    let cases: Vec<(Vec<&str>, String, &str)> = vec![
        (vec!["identify", &csv], format!("'{csv}' line 3, field 'ia_A' (column 4): "), "'x' is not a number"),
        (vec!["identify", &huge], format!("'{huge}' line 3, field 'time_s' (column 1): "), "span 1e308 s"),
        (
            vec!["identify", "--params", &params, good],
            format!("'{params}' line 2, field 'phase_resistance_ohm': "),
            "= 1e38 is outside",
        ),
        (
            vec!["simulate", "--unit", "1", "--tolerances", &tolerances, "--out", out],
            format!("'{tolerances}' line 1, field 'static_friction': "),
            "did you mean",
        ),
        (
            vec!["simulate", "--sensors", &sensors, "--out", out],
            format!("'{sensors}' line 1, field 'offset_a': "),
            "1e300 A is not inside",
        ),
        (vec!["simulate", "--profile", &profile, "--out", out], format!("'{profile}' line 3: "), "start 1e30 s"),
        (
            vec!["identify", "--model-config", &config, good],
            format!("'{config}' line 2, field 'severity': "),
            "outside",
        ),
        (vec!["identify", "--firmware-trace", &trace], format!("'{trace}': "), "packed trace"),
        (vec!["history", good, "/nonexistent/flight.csv"], "'/nonexistent/flight.csv': ".to_owned(), "cannot"),
        (
            vec!["commission", good, "/nonexistent/flight.csv", "--out", out],
            "'/nonexistent/flight.csv': ".to_owned(),
            "cannot",
        ),
    ];
    for (args, place, message) in cases {
        let err = refused(&args, &[message]);
        assert!(err.starts_with(&format!("error: {place}")), "{args:?}: not '{place}': {err}");
        // no number at full length: no run of more than 12 digits
        let longest = err.split(|c: char| !c.is_ascii_digit()).map(str::len).max().unwrap_or(0);
        assert!(longest <= 12, "{args:?}: a number at full length: {err}");
        assert!(!err.contains("FILE"), "{args:?}: a placeholder instead of the file: {err}");
    }
}

/// The flags mean the same everywhere: every command but `params` takes `-q`/`--quiet`, every
/// command that prints JSON spells it `--json`, every command that writes files takes the shared
/// `--out` and `--force`, and the diagnosing commands take `--fail-on`.
#[test]
fn the_flags_are_the_same_across_commands() {
    let commands = [
        "simulate",
        "identify",
        "firmware-trace",
        "compare",
        "campaign",
        "discover",
        "params",
        "commission",
        "fleet",
        "history",
        "detectability",
        "pod",
    ];
    let writes = ["simulate", "firmware-trace", "campaign", "discover", "commission", "fleet", "history", "pod"];
    let prints_json =
        ["identify", "compare", "campaign", "discover", "commission", "fleet", "history", "detectability", "pod"];
    let diagnoses = ["identify", "history"];
    for cmd in commands {
        let help = common::accepted(&[cmd, "--help"]);
        let has = |flag: &str| help.contains(flag);
        assert_eq!(has("-q, --quiet"), cmd != "params", "{cmd}: -q, --quiet\n{help}");
        assert_eq!(has("--json"), prints_json.contains(&cmd), "{cmd}: --json\n{help}");
        assert_eq!(has("--out <") && has("--force"), writes.contains(&cmd), "{cmd}: --out, --force\n{help}");
        assert_eq!(has("--fail-on <LEVEL>"), diagnoses.contains(&cmd), "{cmd}: --fail-on\n{help}");
        assert!(!has("--format") && !has("--output "), "{cmd}: a second spelling\n{help}");
    }
    // -q where it was refused before
    let dir = scratch("cli", "quiet");
    let out = dir.join("q.csv");
    common::accepted(&["simulate", "-q", "--noise", "off", "--out", out.to_str().expect("utf-8")]);
}
