//! `ema history`: the monitor over a series of flights of one actuator, its trend and remaining
//! useful life per fault mode.
//!
//! ```text
//! ema history FILE… [--json] [--out DIR [--force]] [--params F] [--profile P]
//! ema history --simulate LAW… [--flights N] [--seed S] [--json] [--out DIR]
//! ```
//!
//! Each recording is one flight, in the order given. Every recording is read and checked before
//! the first flight is identified, and before `--out DIR` is created ([`check_flights`]); one
//! given twice (the same file, or the same bytes) is refused. Every flight is one flight of the
//! firmware's flight API, the core's [`HealthMonitor`](ema_monitor::flight::HealthMonitor), through
//! [`identify_flight`]: the recording acquired through the on-board frame checks, then the core's
//! flight policy on the core's [`HealthRecord`](ema_monitor::persist::HealthRecord) (the record the
//! firmware persists, a ring of the last 16 flights per mode): planned from the record (the first
//! flight cold, a later flight warm from the previous diagnosis, with new-fault probes, unless the
//! plan asks for a cold one), identified with the on-board settings
//! ([`IdentifyConfig::onboard`](ema_monitor::diagnosis::IdentifyConfig::onboard): the firmware's
//! iteration budget; the host evaluates the global search's sweeps in parallel, bit for bit the
//! same), reported with its uncertainty, and recorded: when its status is a diagnosis, its five
//! mode severities join the record's history through the evidence pooled over flights
//! ([`evidence::record_flight_on`](ema_monitor::diagnosis::evidence::record_flight_on)): the
//! flight's log-likelihood ratio per mode joins the record's sequential sums, and a mode the sums
//! call present while the flight's own model selection dropped it is *declared by pooled evidence*
//! and refitted into the diagnosis the record keeps
//! (`docs/decisions/0024-declaration-by-pooled-evidence.md`). After each flight the core fits the
//! trend of every mode and the flight at which it reaches the failing threshold, with its interval
//! ([`ema_monitor::prognosis`]).
//!
//! **Degradation campaign** (`--simulate LAW…`): instead of files, the reference model flies
//! `--flights` flights of an actuator whose faults follow the laws, with sensor noise and a noise
//! seed per flight. A law is `MODE=START[+RATE][@ONSET]`: the mode's severity is 0 before flight
//! `ONSET` (default 1) and `START + RATE·(flight − ONSET)` from it on (at most 1), so
//! `friction=0.05+0.04` grows linearly from the first flight and `short_a=0.3@5` is a sudden
//! fault at flight 5. Modes: `friction` (k1), `backlash` (k2), `short_a`, `short_b`, `short_c`
//! (k3–k5), `eccentricity` (k6, minimum gap at 0°), `gain` (k8 = 0.5 + severity/2). Knowing the
//! truth, the command scores each flight (the paper's Err%, cold and warm apart), the probes of
//! the warm flights (false alarms: a drift-only flight, no group present in the truth and absent
//! from the prior, on which a probe fires; misses: a flight with a new fault on which none fires
//! and the report misses it), the detection of each mode (first
//! flight its group is reported after its onset, and reports of a mode that is absent; the same
//! for declarations by pooled evidence), and the prognosis at the last flight against the true
//! crossing of the failing threshold.
//!
//! **Exit status** (docs/cli.md): for recordings, that of the last flight's report as the health
//! record keeps it (with any mode declared by pooled evidence refitted in): the actuator's
//! current state, 0 for a diagnosis, 3 for INCONCLUSIVE, 4 for SENSOR_FAULT, 5 at or above
//! `--fail-on LEVEL`. Under `--simulate` (a measurement of the method) it is 0.
//!
//! `--out DIR` writes `history.json` (the `--json` document) and `severity.svg` (severity against
//! flight per mode as the record keeps it, the flights a mode was declared by pooled evidence
//! ringed, the trend lines, the failing threshold and the RUL band).
//!
//! One concept per file: [`args`] (the flags), [`law`] (degradation laws), [`flight`] (one
//! flight through the core's flight API), [`series`] (the flights, the record and the prognosis), [`json`]
//! (the document's types), [`mod@document`] (the modes' scores), [`mod@text`] (the tables) and [`mod@plot`]
//! (the chart).

pub mod args;
pub mod document;
pub mod flight;
pub mod json;
pub mod law;
pub mod plot;
pub mod series;
pub mod text;

use crate::error::CliError;
use crate::exit::Done;
use crate::output::{prepare_dir, write_files};
use crate::schema::Document;

pub use args::HistoryArgs;
pub use document::{document, PRESENT_SEVERITY};
pub use flight::{identify_flight, FlightResult, Start};
pub use json::{CampaignJson, FlightJson, HistoryJson, ModeJson};
pub use law::{true_crossing, truth_at, Law, LAW_PARAMS};
pub use plot::plot;
pub use series::{check_flights, run_series, Series};
pub use text::text;

/// The files `--out DIR` receives.
pub const OUTPUT_FILES: [&str; 2] = ["history.json", "severity.svg"];

/// Runs `ema history`: every input checked (the laws, the parameters, the profile, and every
/// recording read as its flight will read it, [`check_flights`]) before `--out` is created and
/// before the first flight. Its exit status: for recordings, the last flight's as the health
/// record keeps it ([`Series::current`], under `--fail-on`); under `--simulate`, 0.
pub fn run(args: &HistoryArgs) -> Result<Done, CliError> {
    let laws = args.simulate.iter().map(|l| Law::parse(l)).collect::<Result<Vec<_>, _>>()?;
    if laws.is_empty() && args.files.is_empty() {
        return Err(CliError::usage("give recordings of successive flights or --simulate LAW…"));
    }
    let params = args.params.load()?;
    if laws.is_empty() {
        check_flights(args, &params)?;
    }
    let overwrite = args.output.overwrite();
    if let Some(dir) = &args.output.out {
        prepare_dir(dir, &OUTPUT_FILES, overwrite)?;
    }
    let series = run_series(args, &laws, &params)?;
    let doc = document(&series, &laws, args, &params);
    let json = Document::new(None, &doc).to_json();
    if let Some(dir) = &args.output.out {
        let svg = plot(&doc, &series).map_err(|source| CliError::Io { path: dir.join("severity.svg"), source })?;
        let paths = OUTPUT_FILES.map(|name| dir.join(name));
        write_files(&[(&paths[0], json.as_bytes()), (&paths[1], svg.as_bytes())], overwrite)?;
    }
    let stdout = if args.json { json } else { text(&doc) };
    Ok(match series.current {
        Some(status) if laws.is_empty() => Done::report(stdout, status, args.fail_on),
        _ => Done::success(stdout),
    })
}
