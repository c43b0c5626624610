//! `ema pod`: the probability of detection of each fault mode against its severity, and the false
//! alarms on healthy recordings, as PHM engineers judge a detector (MIL-HDBK-1823A).
//!
//! **Recordings.** For each fault mode and each severity of `--severities`, `--seeds` recordings
//! of the reference model under `--profile` (sensor noise per `--noise`), each with a noise seed of
//! its own and the mode alone at that severity: friction `k1`, backlash `k2`, a short on phase A,
//! B or C in turn, an eccentricity at a phase `k7` spread over the recordings, the gain at
//! `0.5 − severity/2`. `--healthy N` adds N recordings of the healthy actuator. With `--units`
//! each recording is of a unit drawn off nominal from the typical tolerances (its own seed),
//! identified with that unit's parameters: a unit whose commissioning found them exactly.
//!
//! **Identification.** The firmware's settings ([`IdentifyConfig::onboard`]: PSO, 30 iterations,
//! model selection, polish), with the report's uncertainty, as a flight runs them.
//!
//! **Hit.** The report is a diagnosis and the mode is among the fault groups it keeps
//! ([`mode_present`]). An `INCONCLUSIVE` or `SENSOR_FAULT` report is a miss. The hit/miss
//! analysis ([`hit_miss`]) gives `a50`, `a90` and `a90/95` per mode.
//!
//! **False alarms.** On the healthy recordings: the reports `DEGRADED` or `FAILING` (a false
//! alarm), with the exact 95 % upper bound of their rate; the `INCONCLUSIVE` ones; and those that
//! keep any fault group (a fault found below the DEGRADED threshold).

pub mod hit_miss;
mod plot;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use clap::Args;
use ema_monitor::diagnosis::evidence::mode_present;
use ema_monitor::diagnosis::IdentifyConfig;
use ema_monitor::faults::FaultMode;
use ema_monitor::unit::Tolerances;
use ema_monitor::{EmaParams, FaultVector, Profile};
use ema_reference::{simulate, SimConfig};
use rayon::prelude::*;
use serde::Serialize;

use crate::campaign::monitor_params;
use crate::error::CliError;
use crate::output::{prepare_dir, write_files, OutputArgs};
use crate::params::ParamsArgs;
use crate::progress::{self, ProgressArgs};
use crate::recording::Recording;
use crate::runtime::identification::identify_trace;
use crate::runtime::recording::condition_recording;
use crate::schema::Document;
use crate::simulate::{resolve_profile, Noise};
use crate::unit_draw::draw_unit;
use hit_miss::{clopper_pearson_upper, fit};

/// The severities of the default grid: log-spaced from 0.005 to 0.3.
pub const DEFAULT_SEVERITIES: &str = "0.005,0.01,0.02,0.03,0.05,0.07,0.1,0.15,0.2,0.3";

/// The files `--out DIR` receives.
pub const OUTPUT_FILES: [&str; 3] = ["pod.json", "recordings.csv", "pod.svg"];

/// Arguments of `ema pod`.
#[derive(Args, Debug, Clone)]
#[command(mut_arg("out", |a| a.value_name("DIR").help("Write pod.json, recordings.csv (one row per \
    recording) and pod.svg (the curves) here (created if needed; checked before the first recording)")))]
pub struct PodArgs {
    /// Command profile: `standard`, `pbit` or a profile file (`ema simulate --help` has the format).
    #[arg(long, value_name = "NAME|FILE", default_value = "standard")]
    pub profile: String,
    /// Sensor noise of the reference model's recordings.
    #[arg(long, value_enum, default_value_t = Noise::On)]
    pub noise: Noise,
    /// Severities of each mode's faults, comma-separated, each in (0, 1).
    #[arg(long, value_delimiter = ',', default_value = DEFAULT_SEVERITIES)]
    pub severities: Vec<f64>,
    /// Recordings per mode and severity.
    #[arg(long, default_value_t = 6, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub seeds: u32,
    /// Healthy recordings for the false-alarm rates (0: none).
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=100_000))]
    pub healthy: u32,
    /// Skip the fault modes' recordings (with --healthy: the false alarms alone).
    #[arg(long)]
    pub no_faults: bool,
    /// Each recording of a unit drawn off nominal (typical tolerances), identified with its own
    /// parameters.
    #[arg(long)]
    pub units: bool,
    /// Print JSON instead of the tables.
    #[arg(long)]
    pub json: bool,
    /// `--out DIR` and `--force`.
    #[command(flatten)]
    pub output: OutputArgs,
    /// `--quiet`.
    #[command(flatten)]
    pub progress: ProgressArgs,
    /// The actuator's parameters.
    #[command(flatten)]
    pub params: ParamsArgs,
}

/// One recording to identify.
#[derive(Clone, Copy, Debug)]
struct Trial {
    /// The fault mode (`None`: healthy).
    mode: Option<FaultMode>,
    /// Its severity (0 when healthy).
    severity: f64,
    /// The recording's seed (its noise, and its unit under `--units`).
    seed: u64,
    /// Its index among the recordings of its mode and severity.
    index: u32,
}

impl Trial {
    /// The true fault vector.
    fn truth(&self) -> FaultVector {
        let mut k = FaultVector::HEALTHY;
        let s = self.severity as f32;
        match self.mode {
            Some(FaultMode::Friction) => k.0[0] = s,
            Some(FaultMode::Backlash) => k.0[1] = s,
            Some(FaultMode::ShortCircuit) => k.0[2 + (self.index % 3) as usize] = s,
            Some(FaultMode::Eccentricity) => {
                k.0[5] = s;
                // the golden-ratio sequence spreads the phases over the recordings
                k.0[6] = (0.25 + 0.618_034 * self.index as f32).fract();
            }
            Some(FaultMode::GainDrift) => k.0[7] = 0.5 - 0.5 * s,
            None => {}
        }
        k
    }
}

/// One identified recording (a row of `recordings.csv`).
#[derive(Clone, Debug, Serialize)]
pub struct RecordingRow {
    /// The fault mode, or `healthy`.
    pub mode: &'static str,
    /// Its severity.
    pub severity: f64,
    /// The recording's seed.
    pub seed: u64,
    /// The report's status label.
    pub status: &'static str,
    /// The mode found in a diagnosis (for a healthy recording: any mode found).
    pub hit: bool,
}

/// One mode's detection curve in the JSON document.
#[derive(Clone, Debug, Serialize)]
pub struct ModePodJson {
    /// The fault mode.
    pub mode: &'static str,
    /// Recordings identified.
    pub recordings: u32,
    /// Of them, the mode found in a diagnosis.
    pub hits: u32,
    /// Of them, `INCONCLUSIVE` or `SENSOR_FAULT` (counted as misses).
    pub abstentions: u32,
    /// Severity detected with probability 0.5 (null: no curve).
    pub a50: Option<f64>,
    /// Severity detected with probability 0.9 (null: no curve).
    pub a90: Option<f64>,
    /// The upper 95 % confidence bound of `a90` (null: the bound never reaches 0.9).
    pub a90_95: Option<f64>,
    /// Hits per severity: `[severity, recordings, hits]`.
    pub by_severity: Vec<(f64, u32, u32)>,
    /// The fitted curve the figures come from (`None`: no fit), for the plot.
    #[serde(skip)]
    pub curve: Option<hit_miss::PodFit>,
}

/// The false alarms on healthy recordings in the JSON document.
#[derive(Clone, Debug, Serialize)]
pub struct FalseAlarmsJson {
    /// Healthy recordings identified.
    pub recordings: u32,
    /// Of them, reported `DEGRADED` or `FAILING`.
    pub false_degraded: u32,
    /// The exact one-sided 95 % upper bound of the false-DEGRADED rate.
    pub false_degraded_upper_95: f64,
    /// Of them, `INCONCLUSIVE` or `SENSOR_FAULT`.
    pub abstentions: u32,
    /// Of them, a diagnosis that keeps a fault group (below the DEGRADED threshold).
    pub any_mode_found: u32,
    /// The exact one-sided 95 % upper bound of that rate.
    pub any_mode_found_upper_95: f64,
}

/// The document of `ema pod --json` and `pod.json`.
#[derive(Clone, Debug, Serialize)]
pub struct PodJson {
    /// The manoeuvre.
    pub profile: String,
    /// `on` or `off`.
    pub noise: &'static str,
    /// `nominal` or `drawn` (`--units`).
    pub units: &'static str,
    /// Recordings per mode and severity.
    pub seeds: u32,
    /// One entry per fault mode (none under `--no-faults`).
    pub modes: Vec<ModePodJson>,
    /// The false alarms (null without `--healthy`).
    pub false_alarms: Option<FalseAlarmsJson>,
}

/// Runs `ema pod`.
pub fn run(args: &PodArgs) -> Result<String, CliError> {
    if args.severities.is_empty() || args.severities.iter().any(|s| !(*s > 0.0 && *s < 1.0)) {
        return Err(CliError::flag("--severities", "each must be in (0, 1)"));
    }
    if args.no_faults && args.healthy == 0 {
        return Err(CliError::flag("--no-faults", "needs --healthy N: there is nothing to run"));
    }
    let profile = resolve_profile(&args.profile)?;
    let params = args.params.load()?;
    let overwrite = args.output.overwrite();
    if let Some(dir) = &args.output.out {
        prepare_dir(dir, &OUTPUT_FILES, overwrite)?;
    }
    let trials = trials(args);
    let noise = args.noise == Noise::On;
    let bar = progress::bar(trials.len() as u64, "recordings", args.progress.visible());
    let rows = trials
        .par_iter()
        .map(|t| {
            let row = identify(t, &params, &profile, noise, args.units);
            bar.inc(1);
            row
        })
        .collect::<Result<Vec<_>, _>>()?;
    bar.finish_and_clear();
    let doc = document(args, &rows);
    if let Some(dir) = &args.output.out {
        let svg = plot::curves(&doc, &args.severities)
            .map_err(|source| CliError::Io { path: dir.join("pod.svg"), source })?;
        let contents = [Document::new(None, &doc).to_json(), recordings_csv(&rows), svg];
        let paths = OUTPUT_FILES.map(|name| dir.join(name));
        let files: Vec<(&Path, &[u8])> =
            paths.iter().zip(&contents).map(|(p, c)| (p.as_path(), c.as_bytes())).collect();
        write_files(&files, overwrite)?;
    }
    Ok(if args.json { Document::new(None, &doc).to_json() } else { tables(&doc) })
}

/// Every recording of the run: each mode at each severity `--seeds` times, then the healthy ones.
fn trials(args: &PodArgs) -> Vec<Trial> {
    let mut out = Vec::new();
    let modes = if args.no_faults { &[][..] } else { &FaultMode::ALL[..] };
    for &mode in modes {
        let m = mode.index();
        for (j, &severity) in args.severities.iter().enumerate() {
            for index in 0..args.seeds {
                let seed = 0x504F_4400_0000 + ((m as u64 * 1000 + j as u64) << 16) + u64::from(index);
                out.push(Trial { mode: Some(mode), severity, seed, index });
            }
        }
    }
    for index in 0..args.healthy {
        out.push(Trial { mode: None, severity: 0.0, seed: 0x4845_414C_0000 + u64::from(index), index });
    }
    out
}

/// Simulates and identifies one recording.
fn identify(
    t: &Trial,
    base: &EmaParams,
    profile: &Profile,
    noise: bool,
    units: bool,
) -> Result<RecordingRow, CliError> {
    let params = if units {
        draw_unit(base, &Tolerances::TYPICAL, t.seed)
            .map_err(|e| CliError::Simulation(format!("no unit drawn for seed {}: {}", t.seed, e.last)))?
            .params
    } else {
        *base
    };
    let truth = t.truth();
    let config = SimConfig { params, faults: truth, seed: t.seed, profile: *profile, noise, ..SimConfig::default() };
    let rec = simulate(&config).map_err(|e| CliError::Simulation(e.to_string()))?;
    let label = PathBuf::from(format!("pod recording seed {}", t.seed));
    let trace = condition_recording(&Recording::from_reference(&rec, Vec::new()), &label, &params, profile)?;
    let outcome =
        identify_trace(&*trace, &monitor_params(&params, noise), profile, &IdentifyConfig::onboard(), &label)?;
    let r = &outcome.report;
    let found = |m: FaultMode| r.status.is_diagnosis() && mode_present(&r.faults, m);
    let hit = match t.mode {
        Some(m) => found(m),
        None => FaultMode::ALL.into_iter().any(found),
    };
    Ok(RecordingRow {
        mode: t.mode.map_or("healthy", FaultMode::name),
        severity: t.severity,
        seed: t.seed,
        status: r.status.label(),
        hit,
    })
}

/// The document of the identified `rows`.
fn document(args: &PodArgs, rows: &[RecordingRow]) -> PodJson {
    let abstained = |r: &RecordingRow| r.status == "INCONCLUSIVE" || r.status == "SENSOR_FAULT";
    let modes = if args.no_faults { &[][..] } else { &FaultMode::ALL[..] };
    let modes = modes
        .iter()
        .map(|mode| {
            let of: Vec<&RecordingRow> = rows.iter().filter(|r| r.mode == mode.name()).collect();
            let outcomes: Vec<(f64, bool)> = of.iter().map(|r| (r.severity, r.hit)).collect();
            let curve = fit(&outcomes);
            let by_severity = args
                .severities
                .iter()
                .map(|&s| {
                    let at: Vec<&&RecordingRow> = of.iter().filter(|r| r.severity == s).collect();
                    (s, at.len() as u32, at.iter().filter(|r| r.hit).count() as u32)
                })
                .collect();
            ModePodJson {
                mode: mode.name(),
                recordings: of.len() as u32,
                hits: of.iter().filter(|r| r.hit).count() as u32,
                abstentions: of.iter().filter(|r| abstained(r)).count() as u32,
                a50: curve.and_then(|c| c.size_at(0.5)),
                a90: curve.and_then(|c| c.size_at(0.9)),
                a90_95: curve.and_then(|c| c.a90_95()),
                by_severity,
                curve,
            }
        })
        .collect();
    let healthy: Vec<&RecordingRow> = rows.iter().filter(|r| r.mode == "healthy").collect();
    let false_alarms = (!healthy.is_empty()).then(|| {
        let n = healthy.len() as u64;
        let degraded = healthy.iter().filter(|r| r.status == "DEGRADED" || r.status == "FAILING").count() as u64;
        let found = healthy.iter().filter(|r| r.hit).count() as u64;
        FalseAlarmsJson {
            recordings: n as u32,
            false_degraded: degraded as u32,
            false_degraded_upper_95: clopper_pearson_upper(degraded, n, 0.05),
            abstentions: healthy.iter().filter(|r| abstained(r)).count() as u32,
            any_mode_found: found as u32,
            any_mode_found_upper_95: clopper_pearson_upper(found, n, 0.05),
        }
    });
    PodJson {
        profile: args.profile.clone(),
        noise: if args.noise == Noise::On { "on" } else { "off" },
        units: if args.units { "drawn" } else { "nominal" },
        seeds: args.seeds,
        modes,
        false_alarms,
    }
}

/// `recordings.csv`: one row per recording.
fn recordings_csv(rows: &[RecordingRow]) -> String {
    let mut out = String::from("mode,severity,seed,status,hit\n");
    for r in rows {
        let _ = writeln!(out, "{},{},{},{},{}", r.mode, r.severity, r.seed, r.status, r.hit);
    }
    out
}

/// A severity of a curve fitted over the severities `lo..=hi`: `–` for none, and marked when it
/// lies outside the range tested (an extrapolation).
fn cell(x: Option<f64>, lo: f64, hi: f64) -> String {
    match x {
        None => "–".to_owned(),
        Some(v) if v < lo => format!("< {lo}"),
        Some(v) if v > hi => format!("> {hi}"),
        Some(v) => format!("{v:.3}"),
    }
}

/// The text tables of `doc`.
pub fn tables(doc: &PodJson) -> String {
    let mut out = String::new();
    let units =
        if doc.units == "drawn" { "units drawn off nominal, each with its own parameters" } else { "nominal unit" };
    if !doc.modes.is_empty() {
        let _ = writeln!(
            out,
            "Probability of detection: profile {}, noise {}, {units}, {} recordings per severity; a hit is the mode found in a diagnosis\n",
            doc.profile, doc.noise, doc.seeds
        );
        out.push_str("| mode | a50 | a90 | a90/95 | hits / recordings | INCONCLUSIVE or SENSOR_FAULT |\n|---|---|---|---|---|---|\n");
        let tested = doc.modes[0].by_severity.iter().map(|p| p.0);
        let (lo, hi) = tested.fold((f64::INFINITY, 0.0f64), |(lo, hi), s| (lo.min(s), hi.max(s)));
        for m in &doc.modes {
            // every recording a hit: the curve lies below the range, its fit says no more
            let all = m.hits == m.recordings && m.recordings > 0;
            let at = |x: Option<f64>| if all { format!("< {lo} (all detected)") } else { cell(x, lo, hi) };
            let _ = writeln!(
                out,
                "| {} | {} | {} | {} | {} / {} | {} |",
                m.mode,
                at(m.a50),
                at(m.a90),
                at(m.a90_95),
                m.hits,
                m.recordings,
                m.abstentions
            );
        }
        out.push_str("\nHits per severity\n\n| severity |");
        for m in &doc.modes {
            let _ = write!(out, " {} |", m.mode);
        }
        out.push_str("\n|---|");
        out.push_str(&"---|".repeat(doc.modes.len()));
        out.push('\n');
        for (j, &(s, _, _)) in doc.modes[0].by_severity.iter().enumerate() {
            let _ = write!(out, "| {s} |");
            for m in &doc.modes {
                let (_, n, h) = m.by_severity[j];
                let _ = write!(out, " {h}/{n} |");
            }
            out.push('\n');
        }
    }
    if let Some(f) = &doc.false_alarms {
        if !out.is_empty() {
            out.push('\n');
        }
        let pct = |k: u32| 100.0 * f64::from(k) / f64::from(f.recordings.max(1));
        let _ = write!(
            out,
            "False alarms over {} healthy recordings (profile {}, noise {}, {units}): DEGRADED or FAILING {} ({:.2} %, 95 % upper bound {:.2} %); INCONCLUSIVE or SENSOR_FAULT {} ({:.2} %); a fault group kept below DEGRADED {} ({:.2} %, 95 % upper bound {:.2} %)",
            f.recordings,
            doc.profile,
            doc.noise,
            f.false_degraded,
            pct(f.false_degraded),
            100.0 * f.false_degraded_upper_95,
            f.abstentions,
            pct(f.abstentions),
            f.any_mode_found,
            pct(f.any_mode_found),
            100.0 * f.any_mode_found_upper_95
        );
    }
    out.trim_end().to_owned()
}
