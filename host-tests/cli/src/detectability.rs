//! `ema detectability`: what a manoeuvre can tell, fault mode by fault mode.
//!
//! For the healthy actuator and for each fault mode at a typical severity (`--severity`, 0.3 by
//! default: friction, backlash, a short on phase A, an eccentricity at `k7` = 0.25, the gain at
//! `0.5 − severity/2`), the reference model records the manoeuvre (`--profile`, sensor noise per
//! `--noise`, seed `--seed`), and the core's Fisher information at the true vector
//! ([`ema_monitor::diagnosis::Fisher`], `src/diagnosis/uncertainty.rs`) gives:
//! - the 1σ of each mode's severity: for the sensor noise alone, the Cramér–Rao bound of the
//!   monitor's weighted least squares (sandwich form, the noise model of the fit test), and
//!   with the model mismatch counted as the reports count it; for a mode present with the other
//!   present groups fitted beside it, for an absent one as if it were fitted;
//! - the minimum detectable severity of each absent mode: the smallest severity model selection
//!   keeps on this recording (its information criterion against the fitness at the truth).
//!
//! The truth stands in for the estimate: the figures are the recording's limits, not a search's.

use std::fmt::Write as _;
use std::path::PathBuf;

use clap::Args;
use ema_monitor::diagnosis::{covariance_noise_a2, window_noise_variance_a2, Fisher, IdentifyConfig};
use ema_monitor::faults::FaultMode;
use ema_monitor::fitness::{EquivalentCurrentFit, FAST_REGIME_WEIGHT};
use ema_monitor::health::{HealthReport, Uncertainty};
use ema_monitor::{EmaParams, FaultVector, Profile, FAULT_COUNT};
use ema_reference::{simulate, SimConfig};
use serde::Serialize;

use crate::error::CliError;
use crate::params::ParamsArgs;
use crate::progress::{self, ProgressArgs};
use crate::recording::Recording;
use crate::runtime::recording::condition_recording;
use crate::schema::Document;
use crate::simulate::{resolve_profile, Noise};

/// Arguments of `ema detectability`.
#[derive(Args, Debug, Clone)]
pub struct DetectabilityArgs {
    /// Command profile: `standard` or a profile file (`ema simulate --help` has the format).
    #[arg(long, value_name = "NAME|FILE", default_value = "standard")]
    pub profile: String,
    /// Severity of each typical fault, in (0, 1).
    #[arg(long, default_value_t = 0.3)]
    pub severity: f32,
    /// Sensor noise of the reference model's recordings.
    #[arg(long, value_enum, default_value_t = Noise::On)]
    pub noise: Noise,
    /// Seed of the reference model's noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Print JSON instead of the tables.
    #[arg(long)]
    pub json: bool,
    /// The actuator's parameters.
    #[command(flatten)]
    pub params: ParamsArgs,
    /// `--quiet`.
    #[command(flatten)]
    pub progress: ProgressArgs,
}

/// One case of the table: a fault vector and what its recording can tell.
#[derive(Clone, Debug, Serialize)]
pub struct CaseJson {
    /// `healthy` or the fault mode present.
    pub case: String,
    /// The true fault vector.
    pub k: [f32; 8],
    /// 1σ of each parameter at the truth (null: not identifiable).
    pub sigma: [f32; 8],
    /// 1σ of each mode's severity (friction, backlash, short circuit, eccentricity, gain drift),
    /// the sensor noise and the model mismatch counted, as the reports carry it; for the short
    /// circuit the largest of the three phases' when no short is present.
    pub severity_sigma: [f32; 5],
    /// The same for the sensor noise alone (the model mismatch left out): the Cramér–Rao bound
    /// of the monitor's weighted fit.
    pub crb_severity_sigma: [f32; 5],
    /// Per mode, the severity model selection keeps with 95 % probability, the reports' "not
    /// detectable below" (null for the mode present, or when none is).
    pub detectable_below: [Option<f32>; 5],
    /// Per mode, the severity whose expected gain just pays model selection's criterion, kept
    /// half the time: `detectable_below` without its `1.645·σ` (null as there).
    pub kept_half_the_time: [Option<f32>; 5],
    /// The fitness at the truth (A²): noise and the monitor model's mismatch.
    #[serde(rename = "fitness_A2")]
    pub fitness_a2: f32,
    /// Effective samples of the residual at the truth (AR(1)-corrected): the `n` of model
    /// selection's price.
    pub effective_samples: f32,
}

/// `ema detectability --json`.
#[derive(Clone, Debug, Serialize)]
pub struct DetectabilityJson {
    /// `--profile`.
    pub profile: String,
    /// `--severity`.
    pub severity: f32,
    /// `--noise`: `on` or `off`.
    pub noise: &'static str,
    /// `--seed`.
    pub seed: u64,
    /// One entry per case: `healthy`, then each mode at `severity`.
    pub cases: Vec<CaseJson>,
}

/// The cases: healthy, then each mode at `severity`.
pub fn cases(severity: f32) -> Vec<(String, FaultVector)> {
    let mut out = vec![("healthy".to_owned(), FaultVector::HEALTHY)];
    for (m, mode) in FaultMode::ALL.iter().enumerate() {
        let mut k = FaultVector::HEALTHY;
        match m {
            0 => k.0[0] = severity,
            1 => k.0[1] = severity,
            2 => k.0[2] = severity,
            3 => {
                k.0[5] = severity;
                k.0[6] = 0.25;
            }
            _ => k.0[7] = 0.5 - 0.5 * severity,
        }
        out.push((mode.name().to_owned(), k));
    }
    out
}

/// What the recording of `k` (reference model, `profile`, `noise`, `seed`) tells at the truth.
pub fn case(
    name: &str,
    k: &FaultVector,
    params: &EmaParams,
    profile: &Profile,
    noise: bool,
    seed: u64,
) -> Result<CaseJson, CliError> {
    let config = SimConfig { params: *params, faults: *k, seed, profile: *profile, noise, ..SimConfig::default() };
    let rec = simulate(&config).map_err(|e| CliError::Simulation(e.to_string()))?;
    let recording = Recording::from_reference(&rec, Vec::new());
    let label = PathBuf::from(format!("detectability case {name}"));
    let trace = condition_recording(&recording, &label, params, profile)?;
    let frames = IdentifyConfig::default().independent_frames_per_block;
    let fit = EquivalentCurrentFit::new(&trace, *params, profile)
        .map_err(|e| CliError::Simulation(e.to_string()))?
        .with_fast_regime_weight(FAST_REGIME_WEIGHT)
        .ok_or_else(|| CliError::Simulation("fast-regime weight refused".into()))?;
    let fisher = Fisher::at(&fit, params, k);
    let sigma = fisher.sigma(covariance_noise_a2(params, frames));
    let u = Uncertainty { sigma, detectable_below: fisher.detectable_below(&sigma) };
    let crb = Uncertainty { sigma: fisher.sigma(window_noise_variance_a2(params, frames)), ..u };
    Ok(CaseJson {
        case: name.to_owned(),
        k: k.0,
        sigma: u.sigma,
        severity_sigma: severity_sigma(k, params, &u),
        crb_severity_sigma: severity_sigma(k, params, &crb),
        detectable_below: u.detectable_below,
        kept_half_the_time: fisher.detectable_below(&[0.0; FAULT_COUNT]),
        fitness_a2: fit.error(k),
        effective_samples: fit.effective_samples(k),
    })
}

/// 1σ of each mode's severity: [`Uncertainty::severity_sigma`] of the report's modes, the short
/// circuit at its worst phase's σ when no phase is shorted.
fn severity_sigma(k: &FaultVector, params: &EmaParams, u: &Uncertainty) -> [f32; 5] {
    let report = HealthReport::new(*k, params, 0.0, 0, 0, None);
    let mut out: [f32; 5] = std::array::from_fn(|j| u.severity_sigma(&report.modes[j]));
    if k.0[2..5].iter().all(|&s| s == 0.0) {
        out[2] = u.sigma[2].max(u.sigma[3]).max(u.sigma[4]);
    }
    out
}

fn cell(x: f32) -> String {
    if x.is_finite() {
        format!("{x:.4}")
    } else {
        "∞".into()
    }
}

/// The two Markdown tables: 1σ per mode, minimum detectable severity per mode.
pub fn tables(doc: &DetectabilityJson) -> String {
    let names: Vec<&str> = FaultMode::ALL.iter().map(|m| m.name()).collect();
    let mut out = format!(
        "1σ of each mode's severity at the truth: sensor noise alone (the Cramér–Rao bound of the monitor's fit) / with the model mismatch (as reported); profile {}, noise {}, seed {}\n\n| case | {} |\n|{}\n",
        doc.profile,
        doc.noise,
        doc.seed,
        names.join(" | "),
        "---|".repeat(names.len() + 1)
    );
    for c in &doc.cases {
        let row: Vec<String> = c
            .crb_severity_sigma
            .iter()
            .zip(&c.severity_sigma)
            .map(|(&crb, &s)| format!("{} / {}", cell(crb), cell(s)))
            .collect();
        let _ = writeln!(out, "| {} | {} |", c.case, row.join(" | "));
    }
    let _ = write!(
        out,
        "\nNot detectable below (kept with 95 % probability) / kept half the time (model selection's price \
         on this recording); – for the mode present\n\n| case | {} | fitness at the truth (A²) | effective samples |\n|{}\n",
        names.join(" | "),
        "---|".repeat(names.len() + 3)
    );
    for c in &doc.cases {
        let row: Vec<String> = c
            .detectable_below
            .iter()
            .zip(&c.kept_half_the_time)
            .map(|(s, half)| match (s, half) {
                (Some(s), Some(half)) => format!("{} / {}", cell(*s), cell(*half)),
                _ => "–".into(),
            })
            .collect();
        let _ =
            writeln!(out, "| {} | {} | {:.4e} | {:.0} |", c.case, row.join(" | "), c.fitness_a2, c.effective_samples);
    }
    out.pop();
    out
}

/// Runs `ema detectability`.
pub fn run(args: &DetectabilityArgs) -> Result<String, CliError> {
    if !(args.severity > 0.0 && args.severity < 1.0) {
        return Err(CliError::flag("--severity", "must be in (0, 1)"));
    }
    let profile = resolve_profile(&args.profile)?;
    let params = args.params.load()?;
    let noise = args.noise == Noise::On;
    let all = cases(args.severity);
    let bar = progress::bar(all.len() as u64, "cases", args.progress.visible());
    let cases = all
        .iter()
        .map(|(name, k)| {
            let result = case(name, k, &params, &profile, noise, args.seed);
            bar.inc(1);
            result
        })
        .collect::<Result<Vec<_>, _>>();
    bar.finish_and_clear();
    let cases = cases?;
    let doc = DetectabilityJson {
        profile: args.profile.clone(),
        severity: args.severity,
        noise: if noise { "on" } else { "off" },
        seed: args.seed,
        cases,
    };
    Ok(if args.json { Document::new(None, doc).to_json() } else { tables(&doc) })
}
