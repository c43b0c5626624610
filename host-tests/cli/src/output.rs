//! Output files of every command: checked before the work starts, written whole or not at all.
//!
//! Three rules hold for every file the `ema` commands write (`simulate --out`, `firmware-trace`,
//! `campaign --out DIR`, `discover --out DIR`, `history --out DIR`, `commission --out`,
//! `fleet --out`):
//!
//! 1. **Checked up front.** [`check_file`] and [`prepare_dir`] run before any simulation or
//!    identification (and, in a command that reads inputs, once they are checked: a bad input
//!    leaves no output directory behind): the directory exists (an output directory is created),
//!    is a directory, and accepts a new file (one is created and removed); the output path is not
//!    a directory; an existing file is refused unless the command was given `--force`
//!    ([`Overwrite::Replace`]), with [`CliError::Exists`] naming it. A long run never ends in an
//!    error about its output.
//! 2. **Only a regular file is replaced.** Whatever is at the output path that is not a regular
//!    file — a symlink (to a file, a directory or a device alike: the link itself is looked at,
//!    never followed), a FIFO, a character or block device, a socket — is refused with or without
//!    `--force` ([`CliError::Unwritable`], naming the path and what it is): a rename over it would
//!    replace the node by a regular file (as root, `/dev/full` would become a file). The check
//!    runs up front and again just before each rename; a node that appeared in between is refused
//!    there, its temporary file removed.
//! 3. **Atomic replacement.** [`write_files`] and [`write_with`] write each file to a temporary
//!    file in the same directory (`.NAME.PID.N.tmp`, created exclusively), flush it to the disk
//!    (`fsync`) and only then rename it over the destination. A rename within one directory is
//!    atomic (POSIX `rename(2)`), so a reader sees the old file or the complete new one, never a
//!    truncated one: a failed write leaves the old file as it was and removes its temporary file.
//!    When several files are written together (an output directory), every one is written to its
//!    temporary file first and the renames follow, so a failure while writing replaces none of
//!    them. A replaced file keeps its permissions.
//!
//! A process killed between the write and the rename leaves its `.NAME.PID.N.tmp` file behind,
//! and the destination untouched. An error up front (a path that cannot be used) exits 2, a
//! failed write 1 ([`crate::exit`]).

use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};

use clap::Args;

use crate::error::CliError;

/// `--out` and `--force`, shared by the commands that write files (`simulate`, `firmware-trace`,
/// `campaign`, `discover`). A command states what `--out` names (a file or a directory) and
/// whether it is required with `#[command(mut_arg("out", ...))]` on its own arguments.
#[derive(Args, Debug, Clone, Default, PartialEq, Eq)]
pub struct OutputArgs {
    /// Where the command writes its output files (a file or a directory: see the command's help).
    #[arg(long, value_name = "PATH")]
    pub out: Option<PathBuf>,
    /// Replace the output files if they exist as regular files (without it, an existing one stops
    /// the command before it does any work; a symlink, FIFO or device is never replaced).
    #[arg(long)]
    pub force: bool,
}

impl OutputArgs {
    /// [`Overwrite::Replace`] with `--force`, else [`Overwrite::Refuse`].
    pub fn overwrite(&self) -> Overwrite {
        Overwrite::from_force(self.force)
    }
}

/// What to do with an output file that exists already.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Overwrite {
    /// Refuse it (the default): the command stops before doing any work.
    Refuse,
    /// Replace it (`--force`).
    Replace,
}

impl Overwrite {
    /// [`Overwrite::Replace`] when `--force` is given, else [`Overwrite::Refuse`].
    pub fn from_force(force: bool) -> Self {
        if force {
            Overwrite::Replace
        } else {
            Overwrite::Refuse
        }
    }
}

/// Numbers the temporary files of this process, so two in one directory never share a name.
static NEXT_TEMP: AtomicU32 = AtomicU32::new(0);

/// The directory a file path lives in (`.` for a bare file name).
fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// A fresh temporary path in `dir` for `name`: hidden, and unique within this process.
fn temp_path(dir: &Path, name: &str) -> PathBuf {
    let n = NEXT_TEMP.fetch_add(1, Ordering::Relaxed);
    dir.join(format!(".{name}.{}.{n}.tmp", std::process::id()))
}

/// A failed write of `path` (the disk's fault: exit status 1).
fn io_error(path: &Path, source: io::Error) -> CliError {
    CliError::Io { path: path.to_path_buf(), source }
}

/// `path` cannot be used as an output, for `reason` (the command line's fault: exit status 2).
fn refusal(path: &Path, reason: impl Into<String>) -> CliError {
    CliError::Unwritable { path: path.to_path_buf(), reason: reason.into() }
}

/// What a file type that is not a regular file is, for a message: `a symlink`, `a FIFO`, ….
fn node_kind(t: fs::FileType) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    if t.is_symlink() {
        "a symlink"
    } else if t.is_dir() {
        "a directory"
    } else if t.is_fifo() {
        "a FIFO"
    } else if t.is_char_device() {
        "a character device"
    } else if t.is_block_device() {
        "a block device"
    } else if t.is_socket() {
        "a socket"
    } else {
        "not a regular file"
    }
}

/// Checks that `dir` is an existing directory in which a file can be created (creates and
/// removes one); errors name `target`, the output the directory is checked for.
fn check_writable_dir(dir: &Path, target: &Path) -> Result<(), CliError> {
    match fs::metadata(dir) {
        Ok(m) if m.is_dir() => {}
        Ok(_) => return Err(refusal(target, format!("'{}' is not a directory", dir.display()))),
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            return Err(refusal(target, format!("directory '{}' does not exist", dir.display())))
        }
        Err(e) => return Err(refusal(target, e.to_string())),
    }
    let probe = temp_path(dir, "ema-write-probe");
    OpenOptions::new().write(true).create_new(true).open(&probe).map_err(|e| refusal(target, e.to_string()))?;
    fs::remove_file(&probe).map_err(|e| refusal(target, e.to_string()))
}

/// Checks the destination itself, without following a symlink: nothing there, or a regular file
/// that `overwrite` allows to replace. A directory, a symlink, a FIFO, a device or a socket is
/// refused whatever `overwrite` says.
fn check_destination(path: &Path, overwrite: Overwrite) -> Result<(), CliError> {
    match fs::symlink_metadata(path) {
        Ok(m) if m.is_dir() => Err(refusal(path, "it is a directory, not a file")),
        Ok(m) if !m.file_type().is_file() => Err(refusal(
            path,
            format!("it is {}, not a regular file; not replaced, with or without --force", node_kind(m.file_type())),
        )),
        Ok(_) if overwrite == Overwrite::Refuse => Err(CliError::Exists { path: path.to_path_buf() }),
        Ok(_) => Ok(()),
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(refusal(path, e.to_string())),
    }
}

/// The file name of an output path, or an error if it has none (`dir/..`, `/`).
fn file_name(path: &Path) -> Result<&str, CliError> {
    path.file_name().and_then(|n| n.to_str()).ok_or_else(|| refusal(path, "not a file name"))
}

/// Checks, before any work, that `path` can be written: its directory exists and accepts a new
/// file, `path` is not a directory nor any other node than a regular file (a symlink, FIFO or
/// device is refused, with or without `--force`), and an existing regular file is replaced only
/// with [`Overwrite::Replace`].
pub fn check_file(path: &Path, overwrite: Overwrite) -> Result<(), CliError> {
    file_name(path)?;
    check_writable_dir(parent_dir(path), path)?;
    check_destination(path, overwrite)
}

/// Prepares an output directory before any work: creates `dir` (and its parents) if needed,
/// checks that it accepts a new file, and checks each of the files `names` the command writes
/// into it as [`check_file`] does.
pub fn prepare_dir(dir: &Path, names: &[&str], overwrite: Overwrite) -> Result<(), CliError> {
    match fs::metadata(dir) {
        Ok(m) if !m.is_dir() => return Err(refusal(dir, "it is a file, not a directory")),
        Ok(_) => {}
        Err(_) => fs::create_dir_all(dir).map_err(|e| refusal(dir, e.to_string()))?,
    }
    check_writable_dir(dir, dir)?;
    for name in names {
        check_destination(&dir.join(name), overwrite)?;
    }
    Ok(())
}

/// A file written to its temporary path, waiting for its rename; dropped unrenamed (an error on
/// the way), it removes the temporary file.
struct Staged {
    /// The temporary file; `None` once renamed into place.
    temp: Option<PathBuf>,
    /// The destination.
    target: PathBuf,
}

impl Drop for Staged {
    fn drop(&mut self) {
        if let Some(temp) = self.temp.take() {
            let _ = fs::remove_file(temp);
        }
    }
}

/// Writes `target`'s content to a new temporary file beside it with `write`, and flushes it to
/// the disk.
fn stage(
    target: &Path,
    overwrite: Overwrite,
    write: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> Result<Staged, CliError> {
    let name = file_name(target)?;
    let dir = parent_dir(target);
    check_destination(target, overwrite)?;
    let temp = temp_path(dir, name);
    let file = OpenOptions::new().write(true).create_new(true).open(&temp).map_err(|e| io_error(target, e))?;
    // from here on, dropping `staged` removes the temporary file
    let staged = Staged { temp: Some(temp), target: target.to_path_buf() };
    let mut w = BufWriter::new(file);
    write(&mut w).map_err(|e| io_error(target, e))?;
    let file = w.into_inner().map_err(|e| io_error(target, e.into_error()))?;
    file.sync_all().map_err(|e| io_error(target, e))?;
    if let Ok(m) = fs::symlink_metadata(target) {
        if let Some(temp) = &staged.temp {
            fs::set_permissions(temp, m.permissions()).map_err(|e| io_error(target, e))?;
        }
    }
    Ok(staged)
}

/// Renames every staged file into place, then flushes their directories' entries (best effort).
/// Every destination is checked again first (so that a refusal replaces none of them), and each
/// once more just before its own rename, the narrowest window this side of the kernel: a node
/// that is not a regular file is never renamed over, and its temporary file is removed.
fn commit(mut staged: Vec<Staged>, overwrite: Overwrite) -> Result<(), CliError> {
    for s in &staged {
        // a file that appeared during the run is not replaced without --force either
        check_destination(&s.target, overwrite)?;
    }
    for s in &mut staged {
        if let Some(temp) = &s.temp {
            check_destination(&s.target, overwrite)?;
            fs::rename(temp, &s.target).map_err(|e| io_error(&s.target, e))?;
            s.temp = None;
        }
    }
    let mut dirs: Vec<&Path> = staged.iter().map(|s| parent_dir(&s.target)).collect();
    dirs.dedup();
    for d in dirs {
        if let Ok(f) = File::open(d) {
            let _ = f.sync_all();
        }
    }
    Ok(())
}

/// Writes each `(path, content)` atomically: all to temporary files first, then renamed into
/// place. On an error no destination has been touched by the failed write and no temporary file
/// is left. `overwrite` is checked again just before the renames.
pub fn write_files(files: &[(&Path, &[u8])], overwrite: Overwrite) -> Result<(), CliError> {
    let mut staged = Vec::with_capacity(files.len());
    for (path, content) in files {
        staged.push(stage(path, overwrite, |w| w.write_all(content))?);
    }
    commit(staged, overwrite)
}

/// Writes one file atomically, its content produced by `write` (which may stream it); an error
/// from `write` leaves the destination as it was.
pub fn write_with(
    path: &Path,
    overwrite: Overwrite,
    write: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> Result<(), CliError> {
    let staged = stage(path, overwrite, write)?;
    commit(vec![staged], overwrite)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("ema-output-{}-{name}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).expect("temp dir is writable");
        dir
    }

    fn entries(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = fs::read_dir(dir)
            .expect("readable")
            .map(|e| e.expect("entry").file_name().into_string().unwrap())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn a_failed_write_keeps_the_old_file_and_leaves_no_temporary_file() {
        let dir = scratch("fail");
        let path = dir.join("rec.csv");
        fs::write(&path, "old content\n").unwrap();
        let e = write_with(&path, Overwrite::Replace, |w| {
            w.write_all(b"time_s,command_rad\n0,0\n")?;
            Err(io::Error::other("disk full"))
        })
        .expect_err("the write fails");
        assert!(e.to_string().contains("rec.csv") && e.to_string().contains("disk full"), "{e}");
        assert_eq!(fs::read_to_string(&path).unwrap(), "old content\n");
        assert_eq!(entries(&dir), ["rec.csv"]);
        // a failure in the middle of several files replaces none of them
        let other = dir.join("b.txt");
        fs::write(&other, "old b").unwrap();
        let bad = dir.join("sub");
        fs::create_dir(&bad).unwrap();
        let e = write_files(&[(&path, b"new"), (&other, b"new b"), (&bad, b"x")], Overwrite::Replace)
            .expect_err("a directory where a file is expected");
        assert!(e.to_string().contains("directory"), "{e}");
        assert_eq!(fs::read_to_string(&path).unwrap(), "old content\n");
        assert_eq!(fs::read_to_string(&other).unwrap(), "old b");
        assert_eq!(entries(&dir), ["b.txt", "rec.csv", "sub"]);
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn replace_needs_overwrite_and_keeps_permissions() {
        use std::os::unix::fs::PermissionsExt;
        let dir = scratch("replace");
        let path = dir.join("out.txt");
        write_files(&[(&path, b"first")], Overwrite::Refuse).expect("new file");
        assert_eq!(fs::read_to_string(&path).unwrap(), "first");
        let e = write_files(&[(&path, b"second")], Overwrite::Refuse).expect_err("exists");
        assert!(matches!(e, CliError::Exists { .. }) && e.to_string().contains("--force"), "{e}");
        assert_eq!(fs::read_to_string(&path).unwrap(), "first");
        fs::set_permissions(&path, fs::Permissions::from_mode(0o640)).unwrap();
        write_files(&[(&path, b"second")], Overwrite::Replace).expect("replaced");
        assert_eq!(fs::read_to_string(&path).unwrap(), "second");
        assert_eq!(fs::metadata(&path).unwrap().permissions().mode() & 0o777, 0o640);
        assert_eq!(entries(&dir), ["out.txt"]);
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn checks_name_the_file_and_the_reason() {
        let dir = scratch("checks");
        let existing = dir.join("a.csv");
        fs::write(&existing, "x").unwrap();
        let e = check_file(&existing, Overwrite::Refuse).expect_err("exists").to_string();
        assert!(e.contains("a.csv") && e.contains("--force"), "{e}");
        check_file(&existing, Overwrite::Replace).expect("replaceable");
        check_file(&dir.join("new.csv"), Overwrite::Refuse).expect("new file");
        let e = check_file(&dir.join("missing").join("b.csv"), Overwrite::Replace).expect_err("no directory");
        assert!(e.to_string().contains("does not exist") && e.to_string().contains("b.csv"), "{e}");
        let e = check_file(&existing.join("c.csv"), Overwrite::Replace).expect_err("parent is a file");
        assert!(e.to_string().contains("not a directory"), "{e}");
        let e = check_file(&dir, Overwrite::Replace).expect_err("a directory");
        assert!(e.to_string().contains("is a directory"), "{e}");
        // an output directory: created, its files checked
        let out = dir.join("out").join("deeper");
        prepare_dir(&out, &["x.json"], Overwrite::Refuse).expect("created");
        assert!(out.is_dir());
        fs::write(out.join("x.json"), "{}").unwrap();
        let e = prepare_dir(&out, &["y.svg", "x.json"], Overwrite::Refuse).expect_err("x.json exists").to_string();
        assert!(e.contains("x.json") && e.contains("--force"), "{e}");
        prepare_dir(&out, &["y.svg", "x.json"], Overwrite::Replace).expect("replaceable");
        let e = prepare_dir(&existing, &["x.json"], Overwrite::Replace).expect_err("a file, not a directory");
        assert!(e.to_string().contains("a.csv"), "{e}");
        assert_eq!(entries(&dir), ["a.csv", "out"]);
        assert_eq!(entries(&out), ["x.json"]);
        let _ = fs::remove_dir_all(&dir);
    }

    /// A FIFO at `path` (`mkfifo`, as the crate forbids `unsafe` and so `libc::mkfifo`).
    fn mkfifo(path: &Path) {
        let status = std::process::Command::new("mkfifo").arg(path).status().expect("mkfifo runs");
        assert!(status.success(), "mkfifo {}", path.display());
    }

    #[test]
    fn only_a_regular_file_is_replaced() {
        use std::os::unix::fs::symlink;
        let dir = scratch("nodes");
        let target = dir.join("target.txt");
        fs::write(&target, "kept").unwrap();
        let link = dir.join("link.csv");
        symlink(&target, &link).unwrap();
        let dangling = dir.join("dangling.csv");
        symlink(dir.join("nowhere"), &dangling).unwrap();
        let fifo = dir.join("fifo.csv");
        mkfifo(&fifo);
        for (path, kind) in [(&link, "a symlink"), (&dangling, "a symlink"), (&fifo, "a FIFO")] {
            for overwrite in [Overwrite::Refuse, Overwrite::Replace] {
                let e = check_file(path, overwrite).expect_err("not a regular file");
                assert!(matches!(e, CliError::Unwritable { .. }), "{e}");
                let shown = e.to_string();
                assert!(shown.contains(&path.display().to_string()) && shown.contains(kind), "{shown}");
                assert!(shown.contains("not replaced"), "{shown}");
                let e = write_files(&[(path, b"new")], overwrite).expect_err("refused at the write too");
                assert!(e.to_string().contains(kind), "{e}");
            }
        }
        // in an output directory too
        let e = prepare_dir(&dir, &["fifo.csv"], Overwrite::Replace).expect_err("a FIFO inside");
        assert!(e.to_string().contains("a FIFO"), "{e}");
        assert!(fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
        assert!(fs::symlink_metadata(&dangling).unwrap().file_type().is_symlink());
        assert_eq!(fs::read_to_string(&target).unwrap(), "kept");
        assert_eq!(entries(&dir), ["dangling.csv", "fifo.csv", "link.csv", "target.txt"]);
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_node_that_appears_during_the_write_is_not_renamed_over() {
        use std::os::unix::fs::FileTypeExt;
        let dir = scratch("race");
        let path = dir.join("out.csv");
        // the destination is free when checked, and a FIFO by the time the file is renamed
        let e = write_with(&path, Overwrite::Replace, |w| {
            mkfifo(&path);
            w.write_all(b"time_s\n")
        })
        .expect_err("refused before the rename");
        assert!(matches!(e, CliError::Unwritable { .. }) && e.to_string().contains("a FIFO"), "{e}");
        assert!(fs::symlink_metadata(&path).unwrap().file_type().is_fifo());
        assert_eq!(entries(&dir), ["out.csv"], "the temporary file is removed");
        let _ = fs::remove_dir_all(&dir);
    }
}
