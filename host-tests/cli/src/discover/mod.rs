//! `ema discover`: where the monitor model and a recording disagree, which library effect is
//! missing, and how much of the gap it closes.
//!
//! 1. **Fit** the current model (the on-board identification: PSO, model selection, polish) and
//!    take the residual `r_i = I_3eq,i − Ĩ_MM,i` of the 0.4 ms block means ([`residual`]). The
//!    sensor noise is not a discrepancy any model could remove, so the residual judged here is the
//!    *structural* one: `r` averaged over [`SMOOTH_BLOCKS`] blocks (2 ms). Its RMS is "the gap";
//!    the raw RMS is reported beside it.
//! 2. **Where** ([`localisation`]): the 25 ms windows holding most of the structural residual
//!    energy, and its share per operating regime (direction, speed, reversals, current level)
//!    against the regime's share of time; the share of the raw residual carried by rotor-angle
//!    orders (1, 2, 6 per electrical turn; 6 per electrical turn is also cogging's 24 per
//!    mechanical turn) by least squares on `sin/cos(n·θ)`.
//! 3. **Name** ([`naming`]): every library effect ([`EffectId::ALL`]) is fitted with the faults
//!    ([`fit_model`] in [`fitting`]: compass searches from the current fit and from it with its
//!    electrical or mechanical faults reset, at the best severity of a scan, then model selection
//!    and a polish) on alternate 25 ms chunks of the recording, and scored on the held-out chunks:
//!    `ΔBIC = n_eff·ln(E_before/E_after) − Δp·ln(n_eff)` on each part (`Δp` the change in free
//!    parameters, `n_eff` the residual's effective sample count,
//!    [`EquivalentCurrentFit::effective_samples`]). An effect is named only when the held-out ΔBIC exceeds
//!    [`BIC_STRONG`] (Kass & Raftery's "very strong") and the in-sample one [`BIC_FIT_STRONG`]
//!    ("strong"; for an effect that replaces faults: a fit of the fit part at least as good as the
//!    reference's, [`Candidate::fit_gain`]), the fitted severity is neither negligible nor at its
//!    bound ([`PINNED_SEVERITY`]), and the structural residual on the whole recording is smaller
//!    with it; an effect that leaves fewer fault parameters than the fit without it (a winding
//!    temperature rise read as shorts on three phases) must remove a share of the gap too
//!    ([`MIN_GAP_SHARE_REPLACING`]): parsimony alone does not make a missing effect. Confidence is
//!    the winner's posterior weight among "no effect" and all candidates,
//!    `exp(ΔBIC_j/2)/(1 + Σ exp(ΔBIC/2))`. The search repeats for a second effect on top of the
//!    first. A winner at its bound may be absorbing a second effect (a dead time that took a
//!    viscous friction too): the round runs again with it on, and if that round names another
//!    effect and puts the pinned one back under its bound, both are named. The rules and their
//!    evidence: `docs/decisions/0009-effect-naming-rules.md`.
//! 4. **Add**: the named effects are refitted with the faults on the whole recording. One the
//!    refit puts at its bound ([`PINNED_SEVERITY`]) is withdrawn, as a round would have refused
//!    it ([`Withdrawal::AtBound`]). They must shrink its structural gap; if they do not, the last
//!    one named is withdrawn and the rest refitted: the rounds compare fits of the fit part, whose
//!    reference can fit the whole recording worse than step 1's fit does (a compliant
//!    transmission, outside the library, can pass for a hot winding that removes a share of the
//!    round's gap and none of the recording's).
//! 5. **Show** ([`report`]): structural and raw residual RMS before/after, overall and in the
//!    windows of step 2, and the structural residual's part above the sensor noise
//!    ([`above_noise_a`]); with `--truth`, the paper's Err% of the fault vector before/after.
//! 6. **Diagnose as on board**: the firmware's identification ([`IdentifyConfig::onboard`])
//!    without and with the named effects promoted: the fault vectors it would report.
//!
//! `--out DIR` writes `discovery.json`, `residual.csv`, `fit.svg`, `residual.svg` and
//! `model-config.txt` (the promoted model: `effect ID SEVERITY` lines for the firmware build;
//! [`OUTPUT_FILES`]). It is created once the inputs are checked (a bad recording or flag leaves
//! no directory behind) and checked before the fits start (an existing file there is replaced only
//! with `--force`), and its files are written whole or not at all ([`crate::output`]).

pub mod discovery;
pub mod fitting;
pub mod localisation;
pub mod naming;
pub mod report;
pub mod residual;

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::Args;
use ema_monitor::command::CommandSource;
use ema_monitor::conditioning::ConditionedWindow;
use ema_monitor::diagnosis::IdentifyConfig;
use ema_monitor::fitness::EquivalentCurrentFit;
use ema_monitor::{Command, EffectId, EmaParams, FaultVector, ModelEffects};
use indicatif::ProgressBar;

pub use discovery::{Discovery, Withdrawal};
pub use fitting::{
    fault_parameter_count, fit_model, parameter_count, ModelFit, Part, PartFit, CHUNK_BLOCKS, MIN_SEVERITY,
};
pub use localisation::{
    hot_windows, order_share, orders, regimes, unexplained, Regime, Window, UNEXPLAINED_FACTOR, WINDOW_S,
};
pub use naming::{
    same_signature, Candidate, Round, BIC_FIT_STRONG, BIC_OWN_STRONG, BIC_STRONG, MAX_NAMED, MIN_ABOVE_NOISE_SHARE,
    MIN_GAP_SHARE_REPLACING, PINNED_SEVERITY,
};
pub use report::{model_config, summary, to_json, verdict, write_outputs, OUTPUT_FILES};
pub use residual::{above_noise_a, moving_mean, series, Series, CLEAN_FLOOR_A, NOISE_FLOOR_A, SMOOTH_BLOCKS};

use crate::error::CliError;
use crate::output::{prepare_dir, OutputArgs};
use crate::params::ParamsArgs;
use crate::progress::{self, ProgressArgs};
use crate::recording::RecordingArgs;
use crate::runtime::command::{command_for, resolve_command, CommandArg, ModelCommand};
use crate::runtime::identification::identify_trace;
use crate::runtime::recording::condition_recording_for;
use crate::runtime::source::HOST_WINDOW;
use crate::runtime::temperature::model_params;
use crate::simulate::parse_faults;
use localisation::window_rms;
use naming::search_round;
use residual::structural_energy;

/// Arguments of `ema discover`.
#[derive(Args, Debug, Clone)]
#[command(mut_arg("out", |a| a.value_name("DIR").help("Write discovery.json, residual.csv, fit.svg, \
    residual.svg and model-config.txt here (created if needed; checked before the fits start)")))]
pub struct DiscoverArgs {
    /// Recording CSV (docs/recordings.md: columns, delimiter, 5-100 kHz, trimming).
    pub file: PathBuf,
    /// How to read the recording.
    #[command(flatten)]
    pub recording: RecordingArgs,
    /// The true fault vector k1..k8, when known: reports the fault-vector error before and after.
    #[arg(long, value_name = "K1,...,K8", allow_hyphen_values = true)]
    pub truth: Option<String>,
    /// Command profile the recording was made with: `standard` or a profile file.
    #[arg(long, default_value = "standard")]
    pub profile: String,
    /// What drives the monitor model: the command profile (`--profile`, which the recording's
    /// command must match) or the recording's own command column (any manoeuvre).
    #[arg(long, value_enum, default_value = "profile")]
    pub command: CommandArg,
    /// Print JSON instead of the readable summary.
    #[arg(long)]
    pub json: bool,
    /// `--out DIR` and `--force`.
    #[command(flatten)]
    pub output: OutputArgs,
    /// Seed of the optimizers.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Worker threads for the candidate fits (default: all cores). The results do not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    /// `--quiet`.
    #[command(flatten)]
    pub progress: ProgressArgs,
    /// The actuator's parameters.
    #[command(flatten)]
    pub params: ParamsArgs,
}

/// Runs the whole workflow on a conditioned trace of the actuator `params`, the model driven by
/// `command` (a profile or the recording's sampled command).
pub fn discover<'c, const W: usize>(
    trace: &ConditionedWindow<W>,
    params: &EmaParams,
    command: impl CommandSource<'c>,
    file: &Path,
    truth: Option<FaultVector>,
    seed: u64,
    threads: usize,
) -> Result<Discovery, CliError> {
    let d = discover_with_progress(trace, params, command, file, seed, threads, &ProgressBar::hidden())?;
    Ok(Discovery { truth, ..d })
}

/// [`discover`], advancing `bar` by one step per fit: the current model, the reference of the
/// fit part, each round's candidates (added to the bar's length as a round starts), the refit
/// and the on-board diagnoses; its message names the step. The truth is the caller's to set
/// ([`Discovery::truth`], `None` here): it scores the result and changes nothing in it.
pub fn discover_with_progress<'c, const W: usize>(
    trace: &ConditionedWindow<W>,
    params: &EmaParams,
    command: impl CommandSource<'c>,
    file: &Path,
    seed: u64,
    threads: usize,
    bar: &ProgressBar,
) -> Result<Discovery, CliError> {
    // One rayon pool of `threads` workers for every parallel part; without one (the system
    // refuses threads) the work runs on rayon's global pool.
    let profile = &command.into_command();
    match rayon::ThreadPoolBuilder::new().num_threads(threads.max(1)).build() {
        Ok(pool) => pool.install(|| discover_in_pool(trace, params, profile, file, seed, bar)),
        Err(_) => discover_in_pool(trace, params, profile, file, seed, bar),
    }
}

/// [`discover_with_progress`] on the current rayon pool.
fn discover_in_pool<const W: usize>(
    trace: &ConditionedWindow<W>,
    params: &EmaParams,
    profile: &Command<'_>,
    file: &Path,
    seed: u64,
    bar: &ProgressBar,
) -> Result<Discovery, CliError> {
    let start = Instant::now();
    bar.set_length(4);
    bar.set_message("fitting the current model");
    // 1. the current model, as on board (whole recording)
    // Every sample at full weight: the discrepancies discover looks for live in the fast regime too.
    let config = IdentifyConfig { seed, fast_regime_weight: 1.0, ..IdentifyConfig::onboard() };
    // step 6's diagnosis before promotion depends on nothing else: it runs beside this fit
    let onboard = IdentifyConfig { seed, ..IdentifyConfig::onboard() };
    let (report, onboard_before) = rayon::join(
        || identify_trace(trace, params, profile, &config, file),
        || identify_trace(trace, params, profile, &onboard, file),
    );
    let (report, onboard_before) = (report?.report, onboard_before?.report);
    bar.inc(1);
    let mut evaluations = u64::from(report.evaluations);
    let whole = PartFit::new(trace, *params, *profile, ModelEffects::NONE, vec![], Part::All);
    let before = ModelFit {
        k: report.faults,
        effects: ModelEffects::NONE,
        error: whole.error(&report.faults, &ModelEffects::NONE, f32::INFINITY),
        evaluations: report.evaluations,
    };
    let series_before = series(trace, params, profile, &before.k, &ModelEffects::NONE);
    // 2. where
    let mut windows = hot_windows(&series_before);
    let regimes = regimes(&series_before);
    let orders = orders(&series_before);
    // 3. name: the reference (no effect) fitted on the fit part like every candidate
    let fit = EquivalentCurrentFit::new(trace, *params, *profile).map_err(|e| CliError::Simulation(e.to_string()))?;
    let n_eff_part = 0.5 * f64::from(fit.effective_samples(&before.k));
    let mut on: Vec<EffectId> = Vec::new();
    let mut named = Vec::new();
    let mut rounds = Vec::new();
    bar.set_message("fitting the reference on the fit part");
    let mut base_fit = fit_model(trace, params, profile, &on, &before, Part::Fit, n_eff_part);
    bar.inc(1);
    evaluations += u64::from(base_fit.evaluations);
    while named.len() < MAX_NAMED {
        let (round, reference) = search_round(trace, params, profile, &on, &base_fit, n_eff_part, bar);
        evaluations += round.evaluations();
        let winner = round.named;
        let winner_fit = winner.and(round.candidates.first()).map(|c| c.fit.clone());
        let pinned = if winner.is_none() { round.pinned_winner() } else { None };
        rounds.push(round);
        match (winner, winner_fit) {
            (Some(w), Some(fit)) => {
                named.push(w);
                on.push(w.0);
                base_fit = fit;
            }
            _ => {
                // A winner at its bound may be absorbing a second effect: a round with it on
                if let Some((p, p_fit, p_confidence)) = pinned.filter(|_| named.len() + 2 <= MAX_NAMED) {
                    let mut trial: Vec<EffectId> = on.clone();
                    trial.push(p);
                    let (pair_round, _) = search_round(trace, params, profile, &trial, &p_fit, n_eff_part, bar);
                    evaluations += pair_round.evaluations();
                    let pair = pair_round.named.zip(pair_round.candidates.first().map(|c| c.fit.clone()));
                    let p_severity = pair.as_ref().map_or(0.0, |(_, fit)| fit.effects.get(p));
                    rounds.push(pair_round);
                    if let Some((w, fit)) = pair.filter(|_| (MIN_SEVERITY..PINNED_SEVERITY).contains(&p_severity)) {
                        named.push((p, p_severity, p_confidence));
                        named.push(w);
                        on.push(p);
                        on.push(w.0);
                        base_fit = fit;
                        continue;
                    }
                }
                base_fit = reference;
                break;
            }
        }
    }
    // 4. add: the named effects refitted with the faults on the whole recording; one the refit
    // puts at its bound is withdrawn, as a round would have refused it; then they must shrink the
    // structural gap, or the last one named is withdrawn (its evidence came from comparing fits of
    // the fit part only); the rest are refitted
    bar.set_message("refitting the named effects on the whole recording");
    let energy_before = structural_energy(&series_before);
    let mut withdrawn = Vec::new();
    let (after, series_after) = loop {
        if on.is_empty() {
            break (before.clone(), series_before.clone());
        }
        bar.inc_length(1);
        let fit = fit_model(trace, params, profile, &on, &base_fit, Part::All, 2.0 * n_eff_part);
        bar.inc(1);
        evaluations += u64::from(fit.evaluations);
        let (effect, why) = match on.iter().find(|e| fit.effects.get(**e) >= PINNED_SEVERITY) {
            Some(&pinned) => (pinned, Withdrawal::AtBound(fit.effects.get(pinned))),
            None => {
                let series_after = series(trace, params, profile, &fit.k, &fit.effects);
                if structural_energy(&series_after) < energy_before {
                    for (e, s, _) in &mut named {
                        *s = fit.effects.get(*e);
                    }
                    break (fit, series_after);
                }
                match on.last() {
                    Some(&last) => (last, Withdrawal::GapNotShrunk),
                    None => break (before.clone(), series_before.clone()),
                }
            }
        };
        on.retain(|e| *e != effect);
        named.retain(|n| n.0 != effect);
        withdrawn.push((effect, why));
        base_fit.effects = base_fit.effects.without(effect);
    };
    // 5. the diagnosis the firmware gives, before and after promoting the named effects
    bar.set_message("the on-board diagnosis");
    bar.inc(1);
    evaluations += u64::from(onboard_before.evaluations);
    let onboard_after = if on.is_empty() {
        onboard_before.faults
    } else {
        let promoted =
            identify_trace(trace, params, profile, &IdentifyConfig { effects: after.effects, ..onboard }, file)?.report;
        evaluations += u64::from(promoted.evaluations);
        promoted.faults
    };
    bar.inc(1);
    for w in &mut windows {
        w.rms_after_a = window_rms(&series_after, w.start_s, w.end_s);
    }
    let unexplained = unexplained(&series_after);
    Ok(Discovery {
        unexplained,
        file: file.to_path_buf(),
        command: None,
        before,
        after,
        onboard_before: onboard_before.faults,
        onboard_after,
        series_before,
        series_after,
        windows,
        regimes,
        orders,
        rounds,
        named,
        withdrawn,
        truth: None,
        seconds: start.elapsed().as_secs_f64(),
        evaluations,
    })
}

/// Runs `ema discover`.
pub fn run(args: &DiscoverArgs) -> Result<String, CliError> {
    let resolved = resolve_command(args.command, &args.profile)?;
    let truth = args.truth.as_deref().map(parse_faults).transpose()?;
    let params = args.params.load()?;
    let recording =
        args.recording.load(&args.file, resolved.as_ref().and_then(ModelCommand::profile), &params)?.recording;
    // the actuator at the recording's temperature, when it has one
    let params = model_params(&recording, &args.file, &params)?.params;
    let command = command_for(resolved, &recording, &args.file, &params)?;
    let trace = condition_recording_for(&recording, &args.file, &params, &command)?;
    // every input is checked: only now is the output directory created (and its files checked)
    let overwrite = args.output.overwrite();
    if let Some(dir) = &args.output.out {
        prepare_dir(dir, &OUTPUT_FILES, overwrite)?;
    }
    let threads = args.threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let bar = progress::bar(4, "fits", args.progress.visible());
    let d =
        discover_with_progress::<HOST_WINDOW>(&trace, &params, command.command(), &args.file, args.seed, threads, &bar);
    bar.finish_and_clear();
    let d = Discovery { command: Some(command.to_json()), truth, ..d? };
    if let Some(dir) = &args.output.out {
        write_outputs(dir, &d, overwrite)?;
    }
    Ok(if args.json { to_json(&d) } else { summary(&d) })
}
