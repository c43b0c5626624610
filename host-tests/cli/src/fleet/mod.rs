//! `ema fleet`: units drawn from the tolerance table, each commissioned on its own healthy
//! flights, then flown healthy and faulty at several temperatures, each flight identified as
//! `ema identify` identifies a recording (with the unit check).
//!
//! ```text
//! ema fleet [--units 12] [--seed 4100] [--json] [--out FILE [--force]] [--quiet]
//! ```
//!
//! Per unit `u` (seed `SEED + u`, drawn from `Tolerances::TYPICAL` as `ema simulate --unit`
//! draws), on the reference model with sensor noise and the standard manoeuvre ([`mod@unit`]):
//! - three healthy commissioning flights at 5, 20 and 35 °C (their temperature known, as a
//!   temperature column gives it), commissioned as `ema commission` commissions;
//! - a fourth healthy flight at 20 °C, identified against the drawing's parameters (typical
//!   tolerances in the unit check) and against the commissioned ones (the posterior tolerances);
//! - healthy flights at −40 and +70 °C against the commissioned parameters, the temperature
//!   known;
//! - one flight per fault mode at severity 0.3 (a short on phase A, B, C in turn; eccentricity
//!   at phase 0.3; gain 0.8), at −40, 20 or 70 °C in turn, against the commissioned parameters;
//! - the minimum detectable severities of the fourth flight, against those of the drawing's unit
//!   on its own healthy flight.
//!
//! Units run in parallel (rayon); every flight's noise is seeded by its unit and its place, so
//! the results do not depend on the number of threads. The output is the markdown tables of
//! `docs/results/fleet.md` ([`tables()`]) or, with `--json`, the document [`FleetJson`] ([`json`]);
//! `docs/output-schema.md` lists its keys. `scripts/results-fleet` regenerates the results page's
//! tables with it.

pub mod json;
pub mod tables;
pub mod unit;

use clap::Args;
use ema_monitor::unit::Tolerances;
use ema_monitor::{EmaParams, FaultVector};
use rayon::prelude::*;

use crate::error::CliError;
use crate::output::{check_file, write_files, OutputArgs};
use crate::progress::{self, ProgressArgs};
use crate::schema::Document;

pub use json::{AgainstJson, DetectableJson, FaultyFlightJson, FleetJson, FlightJson, ModeJson, UnitJson};
pub use tables::tables;
pub use unit::{fly_unit, UnitResult};

/// Most units one run flies (`--units`).
pub const MAX_UNITS: u64 = 1000;

/// Arguments of `ema fleet`.
#[derive(Args, Debug, Clone)]
#[command(mut_arg("out", |a| a.value_name("FILE").help("Write the tables (or, with --json, the \
    document) to FILE instead of stdout (checked before the first unit; written whole)")))]
pub struct FleetArgs {
    /// Units drawn from the typical tolerance table.
    #[arg(long, value_name = "N", default_value_t = 12, value_parser = clap::value_parser!(u64).range(1..=MAX_UNITS))]
    pub units: u64,
    /// Seed of the first unit: unit `u` (from 0) is drawn, and its flights seeded, from `SEED + u`.
    #[arg(long, value_name = "S", default_value_t = 4100, allow_negative_numbers = true)]
    pub seed: u64,
    /// Print the JSON document instead of the markdown tables.
    #[arg(long)]
    pub json: bool,
    /// `--out FILE` and `--force`.
    #[command(flatten)]
    pub output: OutputArgs,
    /// `--quiet`.
    #[command(flatten)]
    pub progress: ProgressArgs,
}

/// Runs `ema fleet`: flies the units, then returns the tables or the JSON document, or writes
/// them to `--out` and returns the line naming the file.
pub fn run(args: &FleetArgs) -> Result<String, CliError> {
    if args.units == 0 || args.units > MAX_UNITS {
        return Err(CliError::flag("--units", format!("{} units; give 1 to {MAX_UNITS}", args.units)));
    }
    let overwrite = args.output.overwrite();
    if let Some(out) = &args.output.out {
        check_file(out, overwrite)?;
    }
    let bar = progress::bar(args.units, "units", args.progress.visible());
    let doc = fleet(args.units, args.seed, &|| bar.inc(1));
    bar.finish_and_clear();
    let doc = doc?;
    let text = if args.json { Document::new(None, &doc).to_json() } else { tables(&doc) };
    match &args.output.out {
        Some(out) => {
            write_files(&[(out, format!("{text}\n").as_bytes())], overwrite)?;
            Ok(format!("wrote {}", out.display()))
        }
        None => Ok(text),
    }
}

/// The fleet of `units` units from `seed` (module doc), flown in parallel; `done` is called
/// after each unit (a progress bar's step).
pub fn fleet(units: u64, seed: u64, done: &(dyn Fn() + Sync)) -> Result<FleetJson, CliError> {
    let drawing = unit::record(&EmaParams::NOMINAL, &FaultVector::HEALTHY, 20.0, seed ^ 0xD7)?;
    let drawing_detectable = unit::diagnose(&drawing, &EmaParams::NOMINAL, &Tolerances::TYPICAL)?
        .report
        .uncertainty
        .map_or([None; 5], |u| u.detectable_below);
    let results: Vec<UnitResult> = (0..units)
        .into_par_iter()
        .map(|u| {
            let result = fly_unit(seed.wrapping_add(u));
            done();
            result
        })
        .collect::<Result<_, CliError>>()?;
    Ok(FleetJson::new(seed, &results, &drawing_detectable))
}
