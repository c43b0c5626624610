//! Writes the traces of the host/target parity check (`ema_cli::parity_traces`) into a directory:
//!
//! ```text
//! cd host-tests && cargo run --release -p ema-cli --example parity-traces -- ../traces/parity [--force]
//! ```
//!
//! An existing file stops it before it writes anything, unless `--force` is given.

use std::path::PathBuf;
use std::process::ExitCode;

use ema_cli::error::CliError;
use ema_cli::output::{prepare_dir, write_files, Overwrite};
use ema_cli::parity_traces::{parity_traces, PARITY_FILES};

fn main() -> ExitCode {
    let mut dir = None;
    let mut force = false;
    for arg in std::env::args().skip(1) {
        match arg.as_str() {
            "--force" => force = true,
            _ if dir.is_none() && !arg.starts_with('-') => dir = Some(PathBuf::from(arg)),
            _ => {
                eprintln!("error: unexpected argument '{arg}'; usage: parity-traces DIR [--force]");
                return ExitCode::from(2);
            }
        }
    }
    let Some(dir) = dir else {
        eprintln!("error: no output directory; usage: parity-traces DIR [--force]");
        return ExitCode::from(2);
    };
    match write(&dir, Overwrite::from_force(force)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}

fn write(dir: &std::path::Path, overwrite: Overwrite) -> Result<(), CliError> {
    prepare_dir(dir, &PARITY_FILES, overwrite)?;
    let files = parity_traces()?;
    let paths: Vec<PathBuf> = files.iter().map(|f| dir.join(f.name)).collect();
    let pairs: Vec<(&std::path::Path, &[u8])> =
        paths.iter().zip(&files).map(|(p, f)| (p.as_path(), f.bytes.as_slice())).collect();
    write_files(&pairs, overwrite)?;
    for f in &files {
        println!("wrote {} ({} bytes)", dir.join(f.name).display(), f.bytes.len());
    }
    Ok(())
}
