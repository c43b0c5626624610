//! Writes a recording the way a test bench's data logger would: another sample rate, its own
//! column names, a semicolon delimiter, a pre-trigger and trailing idle, and optionally
//! timestamp jitter and a quantised command.
//!
//! ```text
//! cargo run --release -p ema-cli --example bench-like -- rec.csv bench.csv \
//!     [--rate 20000] [--names t,cmd,pos,Ia,Ib,Ic] [--delimiter ';'] [--pre-trigger 0.01] \
//!     [--trailing 0.05] [--jitter-us 0] [--quantum-rad 0] [--force]
//! ema identify bench.csv --column time=t --column command=cmd --column position=pos \
//!     --column ia=Ia --column ib=Ib --column ic=Ic
//! ```
//!
//! The sensor channels are resampled band-limited ([`ema_cli::recording::resample`]); the
//! command is held between the input's samples (a controller updates it once per control period,
//! and a faster logger sees it held). The idle before and after repeats the first and last 10 ms
//! of the recording (the opening hold and the closing state), the command at its first and last
//! value. The output is written whole or not at all ([`ema_cli::output::write_files`]).

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;
use ema_cli::output::{write_files, Overwrite};
use ema_cli::recording::read::read_file;
use ema_cli::recording::{resample, ReadOptions};

/// A bench-like copy of a recording.
#[derive(Parser, Debug)]
struct Args {
    /// Recording to transform (any file `ema identify` reads).
    input: PathBuf,
    /// Output CSV.
    output: PathBuf,
    /// Sample rate of the output, in Hz.
    #[arg(long, default_value_t = 20_000.0)]
    rate: f64,
    /// Column names: time, command, position, ia, ib, ic.
    #[arg(long, default_value = "t,cmd,pos,Ia,Ib,Ic")]
    names: String,
    /// Field delimiter (one character).
    #[arg(long, default_value = ";")]
    delimiter: char,
    /// Idle logged before the manoeuvre, in seconds.
    #[arg(long, default_value_t = 0.01)]
    pre_trigger: f64,
    /// Idle logged after the manoeuvre, in seconds.
    #[arg(long, default_value_t = 0.05)]
    trailing: f64,
    /// Timestamp jitter, uniform in ±this many microseconds.
    #[arg(long, default_value_t = 0.0)]
    jitter_us: f64,
    /// Quantum of the command column, in radians (0: as recorded).
    #[arg(long, default_value_t = 0.0)]
    quantum_rad: f64,
    /// Replace the output if it exists.
    #[arg(long)]
    force: bool,
}

fn main() -> ExitCode {
    match run(&Args::parse()) {
        Ok(summary) => {
            println!("{summary}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}

fn run(a: &Args) -> Result<String, String> {
    let names: Vec<&str> = a.names.split(',').map(str::trim).collect();
    if names.len() != 6 {
        return Err(format!("--names: six names expected, found {}", names.len()));
    }
    if !(a.rate.is_finite() && a.rate > 0.0 && a.pre_trigger >= 0.0 && a.trailing >= 0.0) {
        return Err("--rate must be positive, --pre-trigger and --trailing not negative".into());
    }
    let parsed = read_file(&a.input, &ReadOptions::default()).map_err(|e| e.to_string())?;
    let (rec, grid) = (&parsed.recording, parsed.grid);
    let duration = grid.time_s(rec.len() - 1) - grid.origin_s;
    let period = 1.0 / a.rate;
    let n = (duration / period + 1e-6).floor() as usize + 1;
    let channels = [&rec.position_rad[..], &rec.ia_a[..], &rec.ib_a[..], &rec.ic_a[..]];
    let body = resample::resample(&channels, &grid, grid.origin_s, period, n);
    let idle = ((0.01 / period).round() as usize).clamp(1, n);
    let held =
        |u: f64| rec.command_rad[(((u - grid.origin_s) / grid.period_s + 1e-6).floor() as usize).min(rec.len() - 1)];
    let (n_pre, n_post) = ((a.pre_trigger / period).round() as usize, (a.trailing / period).round() as usize);
    let mut state = 0x9e37_79b9_7f4a_7c15_u64;
    let mut jitter = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        ((state >> 11) as f64 / (1u64 << 52) as f64 - 1.0) * a.jitter_us * 1e-6
    };
    let d = a.delimiter.to_string();
    let mut text = names.join(&d);
    text.push('\n');
    for j in 0..n_pre + n + n_post {
        // the sample of the body this row shows: the opening or closing 10 ms repeated in the idle
        let k = if j < n_pre {
            (j + idle - n_pre % idle) % idle
        } else if j < n_pre + n {
            j - n_pre
        } else {
            n - idle + (j - n_pre - n) % idle
        };
        let command = if j < n_pre { rec.command_rad[0] } else { held(grid.origin_s + k as f64 * period) };
        let command = if a.quantum_rad > 0.0 { (command / a.quantum_rad).round() * a.quantum_rad } else { command };
        let t = j as f64 * period + jitter();
        let fields = [t, command, body[0][k], body[1][k], body[2][k], body[3][k]];
        text.push_str(&fields.map(|v| v.to_string()).join(&d));
        text.push('\n');
    }
    write_files(&[(&a.output, text.as_bytes())], Overwrite::from_force(a.force)).map_err(|e| e.to_string())?;
    Ok(format!(
        "wrote {} rows at {} Hz to {} ({} s pre-trigger, {} s trailing idle, manoeuvre from {} s)",
        n_pre + n + n_post,
        a.rate,
        a.output.display(),
        a.pre_trigger,
        a.trailing,
        n_pre as f64 * period
    ))
}
