//! The flags of `ema identify` and the identification settings they make, shared with `ema
//! campaign` (`--algorithm`, `--paper-only`, `--fast-regime-weight`).

use std::path::PathBuf;

use clap::{Args, ValueEnum};
use ema_monitor::diagnosis::{Algorithm, IdentifyConfig};
use ema_monitor::FaultVector;

use crate::error::{num, CliError};
use crate::exit::FailOn;
use crate::params::ParamsArgs;
use crate::progress::ProgressArgs;
use crate::recording::RecordingArgs;
use crate::runtime::command::CommandArg;

/// Optimizer choice on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum AlgorithmArg {
    /// Particle swarm (default, as on board).
    Pso,
    /// Genetic algorithm.
    Ga,
    /// Differential evolution.
    De,
}

impl AlgorithmArg {
    /// The flag's value: `pso`, `ga` or `de`.
    pub const fn name(self) -> &'static str {
        match self {
            AlgorithmArg::Pso => "pso",
            AlgorithmArg::Ga => "ga",
            AlgorithmArg::De => "de",
        }
    }
}

impl From<AlgorithmArg> for Algorithm {
    fn from(a: AlgorithmArg) -> Self {
        match a {
            AlgorithmArg::Pso => Algorithm::Pso,
            AlgorithmArg::Ga => Algorithm::Ga,
            AlgorithmArg::De => Algorithm::De,
        }
    }
}

/// Arguments of `ema identify`.
#[derive(Args, Debug, Clone)]
pub struct IdentifyArgs {
    /// Recording CSV to identify (docs/recordings.md: columns, delimiter, 5-100 kHz, trimming);
    /// several recordings of one actuator (at most 10) are fitted by one fault vector
    /// (`pooled over N recordings`), each read with the same flags.
    #[arg(value_name = "FILE", required_unless_present = "firmware_trace", conflicts_with = "firmware_trace")]
    pub files: Vec<PathBuf>,
    /// How to read the recording.
    #[command(flatten)]
    pub recording: RecordingArgs,
    /// Identify the firmware's packed trace instead, exactly as the firmware does. An EMA3 trace's
    /// checksum is checked (a corrupted file is refused); an EMA1 or EMA2 trace has none, and a
    /// warning on stderr says so.
    #[arg(long, value_name = "FILE")]
    pub firmware_trace: Option<PathBuf>,
    /// Optimizer.
    #[arg(long, value_enum, default_value = "pso")]
    pub algorithm: AlgorithmArg,
    /// Seed of the optimizer's random generator.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Iteration limit [default: 200 (the paper) for a CSV, the on-board 40 for --firmware-trace].
    #[arg(long)]
    pub max_iterations: Option<u32>,
    /// Model configuration file (`effect ID SEVERITY` lines): the monitor model's effect terms,
    /// as `EMA_MODEL_CONFIG` gives them to the firmware [default: none].
    #[arg(long, value_name = "CONFIG")]
    pub model_config: Option<PathBuf>,
    /// Command profile the recording was made with: `standard`, `pbit` or a profile file.
    #[arg(long, default_value = "standard")]
    pub profile: String,
    /// What drives the monitor model: the command profile (`--profile`, which the recording's
    /// command must match) or the recording's own command column (any manoeuvre, at most
    /// 32768 rows: 3.2768 s at 10 kHz).
    #[arg(long, value_enum, default_value = "profile", conflicts_with = "firmware_trace")]
    pub command: CommandArg,
    /// The paper's method alone: its fitness (fast-regime weight 1), the global search, no model
    /// selection, no polish.
    #[arg(long)]
    pub paper_only: bool,
    /// Weight of the fast-regime samples (step and reversal transients) in the fitness, in (0, 1]
    /// [default: the monitor's, 0.1; 1 with --paper-only].
    #[arg(long, value_name = "RHO")]
    pub fast_regime_weight: Option<f32>,
    /// Warm start from the previous flight's fault vector `K1,...,K8` (its diagnosis): no global
    /// search; model selection and the polish from it, then the new-fault probes
    /// (docs/identification.md, "Warm start").
    #[arg(long, value_name = "K1,...,K8", value_parser = parse_prior)]
    pub prior: Option<[f32; 8]>,
    /// For a recording without a temperature column: take the temperature as a nuisance
    /// parameter, the one in the parameter file's declared range at which the healthy unit fits
    /// best, and identify there (docs/commissioning.md) [default: 20 °C].
    #[arg(long, conflicts_with = "firmware_trace")]
    pub estimate_temperature: bool,
    /// The unit's tolerances for the unit check (TOML; `ema params --tolerances` prints the
    /// template; `ema commission` writes a commissioned unit's as `NAME.tolerances.toml`): a
    /// fault found must explain the recording better than a healthy unit within them
    /// [default: the typical tolerances, for a unit not commissioned].
    #[arg(long, value_name = "FILE.toml", conflicts_with = "firmware_trace")]
    pub tolerances: Option<PathBuf>,
    /// Print JSON instead of the readable report.
    #[arg(long)]
    pub json: bool,
    /// Exit with status 5 when the diagnosis is at or above LEVEL (`degraded`: DEGRADED or
    /// FAILING; `failing`: FAILING), for a CI pipeline; INCONCLUSIVE and SENSOR_FAULT keep their
    /// statuses 3 and 4 (docs/cli.md).
    #[arg(long, value_enum, value_name = "LEVEL")]
    pub fail_on: Option<FailOn>,
    /// Also print the fault vector's f32 bit patterns and the one-line summary the firmware logs
    /// (for the host/target parity check, `scripts/parity`); with --firmware-trace (and no
    /// --prior), for each of the firmware's two flights: cold, then from the health record the
    /// first left. A refused --firmware-trace prints its summary (`summary: REFUSED <stage>
    /// <error>`) before the error.
    #[arg(long)]
    pub bits: bool,
    /// `--quiet`.
    #[command(flatten)]
    pub progress: ProgressArgs,
    /// The actuator's parameters.
    #[command(flatten)]
    pub params: ParamsArgs,
}

/// `--prior K1,...,K8`: eight numbers in [0, 1].
fn parse_prior(s: &str) -> Result<[f32; 8], String> {
    let k: Vec<f32> =
        s.split(',').map(|x| x.trim().parse::<f32>().map_err(|e| format!("'{x}': {e}"))).collect::<Result<_, _>>()?;
    let k: [f32; 8] = k.try_into().map_err(|k: Vec<f32>| format!("8 values expected, got {}", k.len()))?;
    if FaultVector(k).is_valid() {
        Ok(k)
    } else {
        Err("every value must be finite and in [0, 1]".to_owned())
    }
}

/// What `--paper-only` and `--fast-regime-weight` (checked before, [`check_fast_regime_weight`])
/// make of `config` in `ema identify` and `ema campaign`: the paper's method alone (its fitness,
/// weight 1; no model selection, no polish), then the flag's weight when given.
pub fn method_flags(config: IdentifyConfig, paper_only: bool, fast_regime_weight: Option<f32>) -> IdentifyConfig {
    let config = if paper_only {
        IdentifyConfig { model_selection: false, polish: None, fast_regime_weight: 1.0, ..config }
    } else {
        config
    };
    IdentifyConfig { fast_regime_weight: fast_regime_weight.unwrap_or(config.fast_regime_weight), ..config }
}

/// `--fast-regime-weight`, when given, checked by the core's rule, the flag named in the error.
pub fn check_fast_regime_weight(weight: Option<f32>) -> Result<(), CliError> {
    match weight {
        Some(w) if !ema_monitor::fitness::fast_regime_weight_is_valid(w) => {
            Err(CliError::flag("--fast-regime-weight", format!("{} is not in (0, 1]", num(w))))
        }
        _ => Ok(()),
    }
}
