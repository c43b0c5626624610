//! The report of `ema identify`: the readable text and the JSON document
//! (`docs/output-schema.md`), with `--bits`' fault-vector bits and the firmware's summary line.

use std::path::{Path, PathBuf};

use ema_monitor::acquisition::{SensorCheck, ZeroSource};
use ema_monitor::effects::ModelEffects;
use serde::Serialize;

use super::args::IdentifyArgs;
use crate::recording::LoadSummary;
use crate::runtime::command::{CommandJson, ModelCommand};
use crate::runtime::firmware::{bits_line, summary_line};
use crate::runtime::identification::Outcome;
use crate::runtime::model_config::effects_label;
use crate::runtime::position_check::PositionCheck;
use crate::runtime::unit_check::UnitCheck;
use crate::schema::Document;

/// One fault mode of the JSON report, in physical terms.
#[derive(Clone, Debug, Serialize)]
pub struct ModeJson {
    /// Mode name ([`ema_monitor::faults::FaultMode::name`]).
    pub mode: &'static str,
    /// Severity in [0, 1].
    pub severity: f32,
    /// `HEALTHY`, `DEGRADED`, `FAILING` or `NOT_ASSESSED`.
    pub condition: &'static str,
    /// The physical value, in `unit`.
    pub value: f32,
    /// The unit of `value`, which differs from mode to mode.
    pub unit: &'static str,
    /// 1σ of `severity` (null when not finite or not computed; absent for a mode reported
    /// healthy by model selection, which has `detectable_below`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub severity_sigma: Option<f32>,
    /// For a mode whose fault groups model selection reports healthy: the smallest severity it
    /// would have kept on this recording.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub detectable_below: Option<f32>,
}

/// The current sensors of the JSON report ([`ema_monitor::acquisition::SensorCheck`]).
#[derive(Clone, Debug, Serialize)]
pub struct SensorsJson {
    /// `rest` (measured on the rows before the manoeuvre) or `declared`.
    pub zero_points: &'static str,
    /// Rows the zero points were measured on (0 when declared).
    pub rest_frames: u32,
    /// Each phase's zero in use minus the declared one, in ADC counts of the nominal sensor.
    pub zero_shift_counts: [f32; 3],
    /// Each phase's standard deviation at rest (counts; null when declared).
    pub rest_sd_counts: Option<[f32; 3]>,
    /// Each phase's gain against the median of the three, minus 1 (null when the manoeuvre does
    /// not resolve them).
    pub gain_mismatch: Option<[f32; 3]>,
    /// Why the calibration is not trusted (null when it is).
    pub fault: Option<SensorFaultJson>,
}

/// A sensor fault of the JSON report.
#[derive(Clone, Debug, Serialize)]
pub struct SensorFaultJson {
    /// The reason in words.
    pub reason: String,
    /// The phase it names (`A`, `B`, `C`; null when it concerns all three).
    pub phase: Option<String>,
}

impl SensorsJson {
    /// The JSON form of `check`.
    pub fn of(check: &SensorCheck) -> Self {
        let finite = |v: [f32; 3]| v.iter().all(|x| x.is_finite()).then_some(v);
        Self {
            zero_points: match check.source {
                ZeroSource::Rest => "rest",
                ZeroSource::Declared => "declared",
            },
            rest_frames: check.rest_frames,
            zero_shift_counts: check.zero_shift_counts,
            rest_sd_counts: finite(check.rest_sd_counts),
            gain_mismatch: finite(check.gain_mismatch),
            fault: check
                .fault
                .map(|f| SensorFaultJson { reason: f.to_string(), phase: f.phase().map(|p| p.to_string()) }),
        }
    }
}

/// The text report's line on the current sensors.
pub fn sensors_line(check: &SensorCheck) -> String {
    let zeros = match check.source {
        ZeroSource::Rest => {
            let [a, b, c] = check.zero_shift_counts;
            format!(
                "zero points from {} rows before the manoeuvre: A {a:+.1}, B {b:+.1}, C {c:+.1} counts from the declared",
                check.rest_frames
            )
        }
        ZeroSource::Declared => "declared zero points".to_owned(),
    };
    let gains = match check.gain_mismatch {
        [a, b, c] if a.is_finite() => {
            format!("; gains against their median A {:+.2} %, B {:+.2} %, C {:+.2} %", a * 100.0, b * 100.0, c * 100.0)
        }
        _ => String::new(),
    };
    let fault = check.fault.map_or_else(String::new, |f| format!("; not trusted: {f}"));
    format!("sensors: {zeros}{gains}{fault}")
}

/// The goodness-of-fit test of the JSON report ([`ema_monitor::health::FitCheck`]).
#[derive(Clone, Debug, Serialize)]
pub struct FitTestJson {
    /// The normal score of the chi-square statistic.
    pub z: f32,
    /// The score above which the fit is rejected ([`ema_monitor::health::FIT_TEST_Z`]).
    pub z_limit: f32,
    /// Effective sample count of the residual.
    pub effective_samples: f32,
    /// The variance a residual of noise and known mismatch has (A²).
    #[serde(rename = "expected_A2")]
    pub expected_a2: f32,
    /// Index of the evidence window with the largest window score.
    pub window: u16,
    /// The largest window score `max_j z_j`.
    pub window_z: f32,
    /// The Šidák-corrected limit of `window_z` for the windows tested.
    pub window_z_limit: f32,
}

/// The report of `ema identify --json`; `docs/output-schema.md` documents every key. Under
/// `INCONCLUSIVE` or `SENSOR_FAULT` the fault values are no diagnosis: `k` moves to
/// `k_not_a_diagnosis`, and `overall` and `modes` are left out (`modes` stays when no mode is
/// assessable: it carries each mode's bound).
#[derive(Clone, Debug, Serialize)]
pub struct IdentifyJson {
    /// `HEALTHY`, `DEGRADED`, `FAILING`, `INCONCLUSIVE` or `SENSOR_FAULT`.
    pub status: &'static str,
    /// Why `INCONCLUSIVE` (null otherwise).
    pub reason: Option<&'static str>,
    /// Frames the acquisition checks refused.
    pub refused_frames: u32,
    /// The current sensors' zero points and gain check.
    pub sensors: SensorsJson,
    /// The goodness-of-fit test (null when not run).
    pub fit_test: Option<FitTestJson>,
    /// The fitness of the best vector (A²).
    #[serde(rename = "fitness_A2")]
    pub fitness_a2: f32,
    /// Objective evaluations.
    pub evaluations: u32,
    /// Iterations of the global search.
    pub iterations: u32,
    /// Why the optimizer stopped (null: the budget).
    pub termination: Option<String>,
    /// Fault groups model selection had no budget left to test.
    pub untested_groups: u8,
    /// Wall time of the identification alone (s).
    pub identification_s: f64,
    /// The fault vector k1..k8, under a diagnosis.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub k: Option<[f32; 8]>,
    /// The worst mode's condition, under a diagnosis.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub overall: Option<&'static str>,
    /// The five fault modes, under a diagnosis or when no mode is assessable.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub modes: Option<Vec<ModeJson>>,
    /// The fault vector when the status is no diagnosis.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub k_not_a_diagnosis: Option<[f32; 8]>,
    /// 1σ of each parameter, aligned with `k` (or `k_not_a_diagnosis`); a non-finite σ (not
    /// identifiable on this recording) is null.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sigma: Option<[f32; 8]>,
    /// What drove the monitor model: a profile or the recorded command.
    pub command: CommandJson,
    /// How the recording file was read (rate, resampling, trimmed start), for a recording.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub recording: Option<LoadSummary>,
    /// The position column against the command and the identified model, for a recording.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub position_check: Option<PositionCheck>,
    /// The recording's mean temperature (°C), at which the monitor model took the actuator's
    /// parameters (or the estimated one under `--estimate-temperature`); null without a
    /// temperature column (the parameters as given).
    pub temperature_c: Option<f64>,
    /// The monitor model's effect terms (`--model-config`): effect ID to severity.
    pub model_effects: std::collections::BTreeMap<&'static str, f32>,
    /// `cold` (the global search) or `warm` (from `--prior`).
    pub start: &'static str,
    /// The warm start's prior and stages, under `warm` only.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub warm: Option<WarmJson>,
}

/// The warm start of the JSON report ([`WarmStart`](crate::runtime::identification::WarmStart)).
#[derive(Clone, Debug, Serialize)]
pub struct WarmJson {
    /// The prior fault vector.
    pub prior: [f32; 8],
    /// Probe evaluations run.
    pub probes: u16,
    /// Groups whose probe fired (a new fault).
    pub probes_fired: Vec<&'static str>,
    /// Targeted refits run.
    pub refits: u8,
    /// Evaluations of the warm stages (start, probes, refits).
    pub warm_evaluations: u32,
    /// `true` when the warm result failed its fit check and the identification went on cold.
    pub cold_fallback: bool,
    /// `true` when the next identification must be cold (the warm result failed its fit check).
    pub cold_next: bool,
}

/// The JSON report's body of `outcome`, the monitor model run with `effects` at `temperature_c`
/// (the recording's, when it has one).
pub fn json_body(
    outcome: &Outcome,
    effects: &ModelEffects,
    command: &ModelCommand,
    loaded: Option<&LoadSummary>,
    temperature_c: Option<f64>,
) -> IdentifyJson {
    let r = &outcome.report;
    let diagnosis = r.status.is_diagnosis();
    let blind = r.status.reason() == Some(ema_monitor::health::Abstain::NothingAssessable);
    let modes = r
        .modes
        .iter()
        .enumerate()
        .map(|(j, m)| {
            let floor = r.uncertainty.and_then(|u| u.detectable_below[j]);
            ModeJson {
                mode: m.mode.name(),
                severity: m.severity,
                condition: m.condition.label(),
                value: m.value,
                unit: m.unit(),
                severity_sigma: if floor.is_some() { None } else { r.uncertainty.map(|u| u.severity_sigma(m)) },
                detectable_below: floor,
            }
        })
        .collect();
    IdentifyJson {
        status: r.status.label(),
        reason: r.status.reason().map(|a| a.label()),
        refused_frames: r.refused_frames,
        sensors: SensorsJson::of(&outcome.sensors),
        fit_test: r.fit_check.map(|c| FitTestJson {
            z: c.z,
            z_limit: ema_monitor::health::FIT_TEST_Z,
            effective_samples: c.effective_samples,
            expected_a2: c.expected_a2,
            window: c.window,
            window_z: c.window_z,
            window_z_limit: c.window_limit,
        }),
        fitness_a2: r.fitness,
        evaluations: r.evaluations,
        iterations: r.iterations,
        termination: r.termination.map(|t| format!("{t:?}")),
        untested_groups: r.untested_groups,
        identification_s: outcome.seconds,
        k: diagnosis.then_some(r.faults.0),
        overall: diagnosis.then(|| r.overall().label()),
        modes: (diagnosis || blind).then_some(modes),
        k_not_a_diagnosis: (!diagnosis).then_some(r.faults.0),
        sigma: r.uncertainty.map(|u| u.sigma),
        command: command.to_json(),
        recording: loaded.cloned(),
        position_check: outcome.position,
        temperature_c,
        model_effects: effects.active().map(|(e, s)| (e.id(), s)).collect(),
        start: if outcome.warm.is_some() { "warm" } else { "cold" },
        warm: outcome.warm.map(|w| WarmJson {
            prior: w.prior,
            probes: w.report.probes,
            probes_fired: w.fired(),
            refits: w.report.refits,
            warm_evaluations: w.report.evaluations,
            cold_fallback: w.report.cold_fallback,
            cold_next: w.report.needs_cold(r),
        }),
    }
}

/// The report as a JSON document ([`IdentifyJson`] in a [`Document`] whose `input_file` is the
/// recording or the firmware trace).
pub fn to_json(
    outcome: &Outcome,
    effects: &ModelEffects,
    command: &ModelCommand,
    loaded: Option<&LoadSummary>,
    temperature_c: Option<f64>,
    input_file: Option<&Path>,
) -> String {
    Document::new(input_file, json_body(outcome, effects, command, loaded, temperature_c)).to_json()
}

/// `temperature: -40.0 °C (recording)`, the text report's line for a recording's temperature
/// (`(estimated)` under `--estimate-temperature`).
pub fn temperature_line(temperature_c: f64, estimated: bool) -> String {
    format!("temperature: {temperature_c:.1} °C ({})", if estimated { "estimated" } else { "recording" })
}

/// The output of `ema identify` for one recording or trace: the JSON document under `--json`,
/// else the report with the command, the recording's temperature (when it has one), the
/// identification's time, the model effects (under `--model-config`), the warm start's stages and
/// how the recording was read; `--bits` adds the fault vector's bit patterns and the firmware's
/// summary line.
pub fn render(
    outcome: &Outcome,
    effects: &ModelEffects,
    command: &ModelCommand,
    loaded: Option<&LoadSummary>,
    temperature: Option<(f64, bool)>,
    args: &IdentifyArgs,
) -> String {
    let temperature_c = temperature.map(|(t, _)| t);
    let mut out = if args.json {
        to_json(
            outcome,
            effects,
            command,
            loaded,
            temperature_c,
            args.firmware_trace.as_deref().or(args.files.first().map(PathBuf::as_path)),
        )
    } else {
        let mut text = format!("{}\n  command: {}", outcome.report, command.label());
        text.push_str(&format!("\n  {}", sensors_line(&outcome.sensors)));
        if let Some((t, estimated)) = temperature {
            text.push_str(&format!("\n  {}", temperature_line(t, estimated)));
        }
        text.push_str(&format!("\n  identification took {:.3} s", outcome.seconds));
        if args.model_config.is_some() {
            text.push_str(&format!("\n  model effects: {}", effects_label(effects)));
        }
        if let Some(w) = &outcome.warm {
            let fired = w.fired();
            text.push_str(&format!(
                "\n  warm start from {:?}: probes fired: {} ({} probes, {} refits, {} evaluations of the warm stages){}{}",
                w.prior,
                if fired.is_empty() { "none".to_owned() } else { fired.join(", ") },
                w.report.probes,
                w.report.refits,
                w.report.evaluations,
                if w.report.cold_fallback { "; the warm result failed its fit check: identified cold" } else { "" },
                if w.report.needs_cold(&outcome.report) { "; the next identification must be cold" } else { "" }
            ));
        }
        if let Some(c) = &outcome.unit_check {
            text.push_str(&format!("\n  {}", unit_check_line(c)));
        }
        if let Some(p) = &outcome.position {
            text.push_str(&format!("\n  {}", position_line(p)));
        }
        if let Some(l) = loaded {
            text.push_str(&format!("\n  {}", l.line()));
        }
        text
    };
    if args.bits {
        out.push('\n');
        out.push_str(&bits_line(&outcome.report));
        out.push('\n');
        out.push_str(&summary_line(&outcome.report));
    }
    out
}

/// The position check in one line: the column is used only for it.
pub fn position_line(p: &PositionCheck) -> String {
    let figures = format!("RMS {:.2} % of the model's swing, gain {:.3}", 100.0 * p.ratio, p.gain);
    match p.likely_cause() {
        None => format!("position: agrees with the command and the model ({figures}); not used by the diagnosis"),
        Some(cause) => format!(
            "position: DISAGREES with the command and the model ({figures}): {cause}; the diagnosis does not use it, check the file's columns"
        ),
    }
}

/// The unit check in one line: the best healthy unit's fitness against the diagnosis's, its
/// largest deviations, and the verdict.
pub fn unit_check_line(c: &UnitCheck) -> String {
    let mut largest: Vec<(usize, f32)> = c.z.iter().copied().enumerate().filter(|(_, z)| z.abs() >= 1.0).collect();
    largest.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
    let named: Vec<String> =
        largest.iter().take(3).map(|&(i, z)| format!("{} {z:+.1}σ", ema_monitor::unit::unit_name(i))).collect();
    format!(
        "unit check: the best healthy unit within its tolerances{} fits {:.4e} A^2, the diagnosis {:.4e} A^2: {}",
        if named.is_empty() { String::new() } else { format!(" ({})", named.join(", ")) },
        c.error_unit,
        c.error_fault,
        if c.fault_pays {
            "the fault pays for its parameters"
        } else if c.every_phase_shorted {
            "every phase reads shorted, the signature of a unit that differs from its parameters; commission the unit (ema commission) or check --params"
        } else {
            "an ordinary unit explains the recording as well; commission the unit (ema commission)"
        }
    )
}
