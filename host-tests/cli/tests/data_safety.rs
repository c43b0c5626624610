//! No lost data: every file the `ema` commands write is checked before the work starts (and
//! after the inputs: a bad input leaves no output behind), replaces an existing regular file only
//! with `--force` and nothing else ever (a symlink, FIFO or device stays as it is), and is written
//! to a temporary file renamed into place, so a failed or interrupted write leaves the old file
//! intact.

use std::os::unix::fs::{symlink, FileTypeExt};
use std::os::unix::process::ExitStatusExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

mod common;
use common::{accepted, ema, refused, s, scratch};

use ema_cli::recording::read_recording;

/// Longest time a refusal may take: the checks run before any simulation or identification, so a
/// refused command returns at once. The commands refused below take far longer when they run
/// (campaign and discover: tens of seconds or more on 2 cores).
const FAST: Duration = Duration::from_secs(3);

/// Sorted names in `dir`.
fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .expect("readable dir")
        .map(|e| e.expect("entry").file_name().into_string().expect("utf-8 name"))
        .collect();
    v.sort();
    v
}

/// `refused`, timed: asserts the refusal came within [`FAST`] and returns the error line.
fn refused_fast(args: &[&str], needles: &[&str]) -> String {
    let start = Instant::now();
    let err = refused(args, needles);
    let elapsed = start.elapsed();
    assert!(elapsed < FAST, "{args:?}: refused after {elapsed:?}, the work ran first: {err}");
    err
}

/// Runs `ema` in `dir` as its working directory.
fn ema_in(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_ema")).current_dir(dir).args(args).output().expect("the binary runs")
}

/// Runs `ema` through bash with the file-size limit at 16 KiB (`ulimit -f`), so writing a
/// recording (about 0.5 MB) fails in the middle. `ignore_signal`: SIGXFSZ ignored, so the write
/// returns an error (EFBIG) to `ema`; otherwise the signal kills `ema` mid-write, as an
/// interruption would.
fn ema_with_small_file_limit(args: &[&str], ignore_signal: bool) -> Output {
    let trap = if ignore_signal { "trap '' XFSZ; " } else { "" };
    Command::new("bash")
        .current_dir(std::env::temp_dir())
        .arg("-c")
        .arg(format!("{trap}ulimit -c 0; ulimit -f 16; exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_ema"))
        .args(args)
        .output()
        .expect("bash runs")
}

/// SIGXFSZ on Linux: the file-size limit was exceeded.
const XFSZ: i32 = 25;

fn committed_trace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../traces/standard.ematrace")
}

#[test]
fn simulate_keeps_an_existing_file_unless_forced() {
    let dir = scratch("safety", "simulate");
    let out = dir.join("rec.csv");
    std::fs::write(&out, "precious\n").unwrap();
    // a 20 s manoeuvre takes the reference model about 15 s: a refusal within FAST ran none of it
    let profile_dir = scratch("safety", "simulate-profile");
    let long = profile_dir.join("long.profile");
    std::fs::write(&long, "hold 0 0\nsine 0.01 0 0.02 5\nend 20\n").unwrap();
    let err = refused_fast(&["simulate", "--profile", s(&long), "--out", s(&out)], &["rec.csv", "exists", "--force"]);
    assert!(!err.contains("cannot write"), "{err}");
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "precious\n");
    assert_eq!(entries(&dir), ["rec.csv"]);
    // --force replaces it with a complete recording, no temporary file left
    accepted(&["simulate", "--out", s(&out), "--force"]);
    assert_eq!(read_recording(&out).expect("a valid recording").len(), 8500);
    assert_eq!(entries(&dir), ["rec.csv", "rec.json"]);
    // a new file needs no --force
    accepted(&["simulate", "--noise", "off", "--out", s(&dir.join("new.csv"))]);
    assert_eq!(entries(&dir), ["new.csv", "new.json", "rec.csv", "rec.json"]);
    // an existing sidecar alone stops the command too: both files are replaced together or not at all
    std::fs::write(dir.join("side.json"), "{}").unwrap();
    refused_fast(&["simulate", "--out", s(&dir.join("side.csv"))], &["side.json", "exists", "--force"]);
    assert_eq!(std::fs::read_to_string(dir.join("side.json")).unwrap(), "{}");
}

#[test]
fn simulate_refuses_an_unwritable_destination_before_running() {
    let dir = scratch("safety", "unwritable");
    // a directory where the file is expected, even with --force
    let sub = dir.join("taken.csv");
    std::fs::create_dir(&sub).unwrap();
    std::fs::write(sub.join("inside.txt"), "kept").unwrap();
    refused_fast(&["simulate", "--out", s(&sub), "--force"], &["taken.csv", "is a directory"]);
    assert_eq!(std::fs::read_to_string(sub.join("inside.txt")).unwrap(), "kept");
    assert_eq!(entries(&sub), ["inside.txt"]);
    // a directory that does not exist, and a parent that is a file
    let missing = dir.join("missing").join("rec.csv");
    refused_fast(&["simulate", "--out", s(&missing)], &["rec.csv", "does not exist"]);
    let file = dir.join("plain.txt");
    std::fs::write(&file, "x").unwrap();
    refused_fast(&["simulate", "--out", s(&file.join("rec.csv")), "--force"], &["not a directory"]);
    assert_eq!(entries(&dir), ["plain.txt", "taken.csv"]);
}

#[test]
fn a_write_failing_midway_keeps_the_old_file_and_no_temporary_file() {
    let dir = scratch("safety", "midway");
    let out = dir.join("rec.csv");
    std::fs::write(&out, "old recording\n").unwrap();
    // the write fails with EFBIG after 16 KiB: exit 1 (a failed write, not a bad input: docs/cli.md)
    // naming the file, old file intact, no temp file
    let o = ema_with_small_file_limit(&["simulate", "--out", s(&out), "--force"], true);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.starts_with("error: cannot write") && err.contains("rec.csv"), "{err}");
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "old recording\n");
    assert_eq!(entries(&dir), ["rec.csv"]);
    // killed in the middle of the write (SIGXFSZ): the destination is still the old file, never
    // a truncated recording a reader would accept; only the hidden temporary file remains
    let o = ema_with_small_file_limit(&["simulate", "--out", s(&out), "--force"], false);
    assert_eq!(o.status.signal(), Some(XFSZ), "{o:?}");
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "old recording\n");
    let left: Vec<String> = entries(&dir).into_iter().filter(|n| n != "rec.csv").collect();
    assert!(left.len() == 1 && left[0].starts_with(".rec.csv.") && left[0].ends_with(".tmp"), "{left:?}");
    // the same with no old file: nothing appears under the destination's name
    let fresh = dir.join("fresh.csv");
    let o = ema_with_small_file_limit(&["simulate", "--out", s(&fresh)], true);
    assert_eq!(o.status.code(), Some(1));
    assert!(!fresh.exists());
}

#[test]
fn campaign_checks_out_dir_before_the_first_run() {
    let dir = scratch("safety", "campaign");
    // `ema campaign` with about a minute of identifications, writing to `out`
    fn campaign(out: &Path, force: bool, needles: &[&str]) {
        let mut args = vec!["campaign", "--runs", "2", "--algorithms", "pso", "--max-iterations", "30"];
        args.extend(["--threads", "1", "--out", s(out)]);
        if force {
            args.push("--force");
        }
        refused_fast(&args, needles);
    }
    // an existing output file without --force
    let out = dir.join("results");
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join("summary.json"), "{\"old\": true}").unwrap();
    campaign(&out, false, &["summary.json", "--force"]);
    assert_eq!(std::fs::read_to_string(out.join("summary.json")).unwrap(), "{\"old\": true}");
    assert_eq!(entries(&out), ["summary.json"]);
    // one of its files is a directory: refused even with --force
    std::fs::create_dir(out.join("error.svg")).unwrap();
    campaign(&out, true, &["error.svg", "is a directory"]);
    // --out names a regular file
    let file = dir.join("file.txt");
    std::fs::write(&file, "x").unwrap();
    campaign(&file, false, &["file.txt", "not a directory"]);
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "x");
    // --out under a file: cannot be created
    campaign(&file.join("sub"), false, &["file.txt"]);
    assert_eq!(entries(&dir), ["file.txt", "results"]);
}

#[test]
fn campaign_writes_its_files_and_replaces_them_only_with_force() {
    let dir = scratch("safety", "campaign-write");
    let out = dir.join("new").join("out");
    let quick =
        ["campaign", "--runs", "1", "--modes", "gain", "--max-iterations", "2", "--threads", "1", "--out", s(&out)];
    accepted(&quick);
    let files = ["error.svg", "runs.csv", "summary.csv", "summary.json", "time.svg"];
    assert_eq!(entries(&out), files);
    std::fs::write(out.join("runs.csv"), "old").unwrap();
    refused_fast(&quick, &["runs.csv", "--force"]);
    assert_eq!(std::fs::read_to_string(out.join("runs.csv")).unwrap(), "old");
    let forced: Vec<&str> = quick.iter().copied().chain(["--force"]).collect();
    accepted(&forced);
    assert!(std::fs::read_to_string(out.join("runs.csv")).unwrap().starts_with("algorithm,mode,level"));
    assert_eq!(entries(&out), files);
}

#[test]
fn discover_checks_out_dir_before_the_fits() {
    let dir = scratch("safety", "discover");
    let csv = dir.join("rec.csv");
    accepted(&["simulate", "--seed", "2", "--out", s(&csv)]);
    let out = dir.join("disc");
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join("model-config.txt"), "effect viscous 0.5\n").unwrap();
    refused_fast(&["discover", s(&csv), "--out", s(&out)], &["model-config.txt", "--force"]);
    assert_eq!(std::fs::read_to_string(out.join("model-config.txt")).unwrap(), "effect viscous 0.5\n");
    assert_eq!(entries(&out), ["model-config.txt"]);
    // --out is a regular file, or lies under one
    refused_fast(&["discover", s(&csv), "--out", s(&csv), "--force"], &["rec.csv"]);
    refused_fast(&["discover", s(&csv), "--out", s(&csv.join("sub"))], &["rec.csv"]);
    assert_eq!(read_recording(&csv).expect("the recording is untouched").len(), 8500);
    assert_eq!(entries(&dir), ["disc", "rec.csv", "rec.json"]);
}

#[test]
fn firmware_trace_writes_to_the_working_directory_not_the_source_tree() {
    let dir = scratch("safety", "fwtrace");
    let committed = std::fs::read(committed_trace()).expect("committed trace");
    let modified = std::fs::metadata(committed_trace()).unwrap().modified().unwrap();
    let o = ema_in(&dir, &["firmware-trace"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("standard.ematrace"));
    assert_eq!(std::fs::read(dir.join("standard.ematrace")).expect("written in the working directory"), committed);
    assert_eq!(entries(&dir), ["standard.ematrace"]);
    assert_eq!(std::fs::metadata(committed_trace()).unwrap().modified().unwrap(), modified);
    // again: refused, then replaced with --force
    let start = Instant::now();
    let o = ema_in(&dir, &["firmware-trace"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("standard.ematrace") && err.contains("--force"), "{err}");
    assert!(start.elapsed() < FAST);
    std::fs::write(dir.join("standard.ematrace"), b"old").unwrap();
    let o = ema_in(&dir, &["firmware-trace", "--force"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(std::fs::read(dir.join("standard.ematrace")).unwrap(), committed);
    // --from without --out: the recording's name with .ematrace, in the working directory
    let rec_dir = scratch("safety", "fwtrace-rec");
    let csv = rec_dir.join("run7.csv");
    accepted(&["simulate", "--faults", "0.25,0,0,0,0,0,0.5,0.5", "--seed", "1", "--out", s(&csv)]);
    let o = ema_in(&dir, &["firmware-trace", "--from", s(&csv)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(std::fs::read(dir.join("run7.ematrace")).expect("written in the working directory"), committed);
    assert_eq!(entries(&rec_dir), ["run7.csv", "run7.json"]);
    assert_eq!(entries(&dir), ["run7.ematrace", "standard.ematrace"]);
    assert_eq!(std::fs::metadata(committed_trace()).unwrap().modified().unwrap(), modified);
}

/// A FIFO at `path`.
fn mkfifo(path: &Path) {
    let status = Command::new("mkfifo").arg(path).status().expect("mkfifo runs");
    assert!(status.success(), "mkfifo {}", path.display());
}

/// The effective user id (`id -u`).
fn uid() -> u32 {
    let out = Command::new("id").arg("-u").output().expect("id runs");
    String::from_utf8_lossy(&out.stdout).trim().parse().expect("a user id")
}

#[test]
fn outputs_never_replace_a_symlink_a_fifo_or_a_device() {
    let dir = scratch("safety", "nodes");
    let precious = dir.join("precious.txt");
    std::fs::write(&precious, "precious\n").unwrap();
    let to_file = dir.join("to-file.csv");
    symlink(&precious, &to_file).unwrap();
    let to_null = dir.join("to-null.csv");
    symlink("/dev/null", &to_null).unwrap();
    let fifo = dir.join("fifo.csv");
    mkfifo(&fifo);
    for (target, kind) in [(&to_file, "a symlink"), (&to_null, "a symlink"), (&fifo, "a FIFO")] {
        for force in [false, true] {
            let mut args = vec!["simulate", "--out", s(target)];
            if force {
                args.push("--force");
            }
            refused_fast(&args, &[s(target), kind, "not replaced"]);
        }
        // the same for every command that writes one file
        refused_fast(&["fleet", "--units", "1", "--out", s(target), "--force"], &[kind]);
        refused_fast(&["firmware-trace", "--out", s(target), "--force"], &[kind]);
    }
    assert!(std::fs::symlink_metadata(&to_file).unwrap().file_type().is_symlink());
    assert!(std::fs::symlink_metadata(&to_null).unwrap().file_type().is_symlink());
    assert!(std::fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());
    assert_eq!(std::fs::read_link(&to_null).unwrap(), Path::new("/dev/null"));
    assert_eq!(std::fs::read_to_string(&precious).unwrap(), "precious\n");
    // and in an output directory: one of campaign's files a symlink to a file
    let out = dir.join("campaign");
    std::fs::create_dir(&out).unwrap();
    symlink(&precious, out.join("runs.csv")).unwrap();
    let args = ["campaign", "--runs", "1", "--modes", "gain", "--max-iterations", "2", "--out", s(&out), "--force"];
    refused_fast(&args, &["runs.csv", "a symlink"]);
    assert_eq!(std::fs::read_to_string(&precious).unwrap(), "precious\n");
    assert_eq!(entries(&dir), ["campaign", "fifo.csv", "precious.txt", "to-file.csv", "to-null.csv"]);
    assert_eq!(entries(&out), ["runs.csv"]);
}

/// As root, a device node (`mknod DIR/full c 1 7`, the kernel's /dev/full) given as `--out` with
/// `--force` stays a character device: before the fix it became a regular file. Without root,
/// `mknod` is refused, and the case is skipped with a note saying so.
#[test]
fn as_root_a_device_node_given_as_out_stays_a_device() {
    let uid = uid();
    if uid != 0 {
        eprintln!(
            "skipped: the device case needs root to mknod (running as uid {uid}); the symlink to /dev/null stands in"
        );
        return;
    }
    let dir = scratch("safety", "device");
    let device = dir.join("full");
    let status = Command::new("mknod").arg(&device).args(["c", "1", "7"]).status().expect("mknod runs");
    assert!(status.success(), "mknod as root");
    for args in
        [vec!["simulate", "--out", s(&device), "--force"], vec!["firmware-trace", "--out", s(&device), "--force"]]
    {
        refused_fast(&args, &["full", "a character device", "not replaced"]);
        let meta = std::fs::symlink_metadata(&device).unwrap();
        assert!(meta.file_type().is_char_device(), "{args:?}: the node is still a device: {meta:?}");
    }
    assert_eq!(entries(&dir), ["full"]);
}

#[test]
fn a_bad_input_leaves_no_output_directory() {
    let dir = scratch("safety", "inputs-first");
    let bad = dir.join("bad.csv");
    std::fs::write(&bad, "time_s,command_rad,position_rad,ia_A,ib_A,ic_A\n0,0,0,0,0,0\n0.0001,0,0,x,0,0\n").unwrap();
    let good = dir.join("good.csv");
    accepted(&["simulate", "--out", s(&good)]);
    let out = dir.join("out");
    refused_fast(&["discover", s(&bad), "--out", s(&out)], &["bad.csv", "line 3", "field 'ia_A'"]);
    assert!(!out.exists(), "discover created its --out before refusing its input");
    // history reads every recording before the first flight and before --out
    refused_fast(&["history", s(&good), s(&bad), "--out", s(&out)], &["bad.csv", "line 3"]);
    refused_fast(&["history", s(&good), s(&dir.join("missing.csv")), "--out", s(&out)], &["missing.csv"]);
    assert!(!out.exists(), "history created its --out before refusing an input");
    assert_eq!(entries(&dir), ["bad.csv", "good.csv", "good.json"]);
}

#[test]
fn help_documents_force_and_the_default_trace_location() {
    for cmd in ["simulate", "firmware-trace", "campaign", "discover", "history", "commission", "fleet", "pod"] {
        let help = accepted(&[cmd, "--help"]);
        assert!(help.contains("--force"), "{cmd} --help lacks --force: {help}");
        assert!(help.contains("regular file"), "{cmd} --help does not say what --force replaces: {help}");
    }
    let help = accepted(&["firmware-trace", "--help"]);
    assert!(help.contains("current directory") && help.contains("standard.ematrace"), "{help}");
    // commands that write nothing take no --force
    let o = ema(&["identify", "x.csv", "--force"]);
    assert_eq!(o.status.code(), Some(2));
}
