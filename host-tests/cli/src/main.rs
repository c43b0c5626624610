//! `ema`: host tools of ema-monitor. Subcommands: `simulate` (reference model → recording CSV),
//! `identify` (core → health report), `firmware-trace`, `compare`, `campaign`, `discover` (missing
//! effects), `params` (the actuator parameter and tolerance templates), `commission` (a unit's own parameters), `fleet` (units
//! drawn, commissioned and flown), `history` (trend and remaining useful life), `detectability` (what a manoeuvre can tell), `pod`
//! (detection curves and false alarms).
//!
//! The exit status follows the contract of [`ema_cli::exit`]: 0 for a diagnosis or a command that
//! succeeded, 1 when writing failed, 2 for a usage or input error, 3 for INCONCLUSIVE, 4 for
//! SENSOR_FAULT, 5 for a diagnosis at or above `--fail-on`.

use std::io::{ErrorKind as IoErrorKind, Write};
use std::process::ExitCode;

use clap::error::ErrorKind;
use clap::{Parser, Subcommand};
use ema_cli::campaign::{self, CampaignArgs};
use ema_cli::commission::{self, CommissionArgs};
use ema_cli::compare::{self, CompareArgs};
use ema_cli::detectability::{self, DetectabilityArgs};
use ema_cli::discover::{self, DiscoverArgs};
use ema_cli::error::CliError;
use ema_cli::exit::{Done, RUNTIME_FAILURE, USAGE_ERROR};
use ema_cli::firmware_trace::{self, FirmwareTraceArgs};
use ema_cli::fleet::{self, FleetArgs};
use ema_cli::history::{self, HistoryArgs};
use ema_cli::identify::{self, IdentifyArgs};
use ema_cli::params::{self, ParamsCommandArgs};
use ema_cli::pod::{self, PodArgs};
use ema_cli::simulate::{self, SimulateArgs};

/// Host tools of the EMA on-board health monitor.
#[derive(Parser, Debug)]
#[command(name = "ema", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Simulate the reference model (the "real" actuator) and write a 10 kHz recording CSV.
    Simulate(SimulateArgs),
    /// Identify the faults behind a recording with the on-board core (monitor model + PSO/GA).
    Identify(IdentifyArgs),
    /// Pack the firmware's built-in trace (reference model) or a recording (--from) for EMA_TRACE; writes ./NAME.ematrace or --out.
    FirmwareTrace(FirmwareTraceArgs),
    /// Reference model vs monitor model with the true faults: the mismatch floor, per segment.
    Compare(CompareArgs),
    /// The paper's Table II protocol: many reference-model runs identified by the core, scored.
    Campaign(CampaignArgs),
    /// Where the monitor model and a recording disagree, which library effect is missing, and the gap it closes.
    Discover(DiscoverArgs),
    /// Print the nominal actuator parameters (or, with --tolerances, the unit-to-unit tolerance table) as a commented TOML template.
    Params(ParamsCommandArgs),
    /// A unit's own parameters from a few recordings of it, healthy: a parameter file for --params.
    Commission(CommissionArgs),
    /// Units drawn from the tolerance table, commissioned, then flown healthy and faulty from -40 to +70 °C.
    Fleet(FleetArgs),
    /// Identify successive flights of one actuator; the trend and remaining useful life per fault mode.
    History(HistoryArgs),
    /// What a manoeuvre can tell: the 1σ (Cramér–Rao) and minimum detectable severity per fault mode.
    Detectability(DetectabilityArgs),
    /// Probability of detection against severity per fault mode (a90/95), and false alarms on healthy recordings.
    Pod(PodArgs),
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => return clap_error(&e),
    };
    let result: Result<Done, CliError> = match &cli.command {
        Command::Simulate(args) => simulate::run(args).map(Done::success),
        Command::Identify(args) => identify::run(args),
        Command::FirmwareTrace(args) => firmware_trace::run(args).map(Done::success),
        Command::Compare(args) => compare::run(args).map(Done::success),
        Command::Campaign(args) => campaign::run(args).map(Done::success),
        Command::Discover(args) => discover::run(args).map(Done::success),
        Command::Params(args) => params::run(args).map(Done::success),
        Command::Commission(args) => commission::run(args).map(Done::success),
        Command::Fleet(args) => fleet::run(args).map(Done::success),
        Command::History(args) => history::run(args),
        Command::Detectability(args) => detectability::run(args).map(Done::success),
        Command::Pod(args) => pod::run(args).map(Done::success),
    };
    match result {
        // A reader that stops early (`ema discover FILE | head`) is not an error: the status stays
        // the command's.
        Ok(done) => match writeln!(std::io::stdout().lock(), "{}", done.stdout) {
            Err(e) if e.kind() != IoErrorKind::BrokenPipe => {
                eprintln!("error: writing to stdout: {e}");
                ExitCode::from(RUNTIME_FAILURE)
            }
            _ => ExitCode::from(done.code),
        },
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(e.exit_code())
        }
    }
}

/// Help and version go to stdout with success; every other parse error becomes one `error:` line.
fn clap_error(e: &clap::Error) -> ExitCode {
    match e.kind() {
        ErrorKind::DisplayHelp | ErrorKind::DisplayVersion => {
            print!("{e}");
            ExitCode::SUCCESS
        }
        ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
            eprintln!(
                "error: a subcommand is required (simulate, identify, firmware-trace, compare, campaign, discover, params, commission, fleet, history, detectability, pod); try 'ema --help'"
            );
            ExitCode::from(USAGE_ERROR)
        }
        _ => {
            let text = e.to_string();
            let parts: Vec<&str> = text
                .lines()
                .map(str::trim)
                .filter(|l| !l.is_empty() && !l.starts_with("Usage:") && !l.starts_with("For more information"))
                .collect();
            let mut line = String::new();
            for p in parts {
                if !line.is_empty() {
                    line.push_str(if line.ends_with(':') { " " } else { "; " });
                }
                line.push_str(p);
            }
            if line.starts_with("error:") {
                eprintln!("{line}");
            } else {
                eprintln!("error: {line}");
            }
            ExitCode::from(USAGE_ERROR)
        }
    }
}
