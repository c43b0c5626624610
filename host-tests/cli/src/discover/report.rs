//! Step 5, show: the readable summary, the one-line verdict, the JSON report and the files of
//! `--out DIR` (`discovery.json`, `residual.csv`, `fit.svg`, `residual.svg`, `model-config.txt`).

use std::fmt::Write as _;
use std::path::Path;

use ema_monitor::FaultVector;
use serde::Serialize;

use super::discovery::{Discovery, Withdrawal};
use super::naming::{same_signature, Candidate};
use super::residual::{above_noise_a, moving_mean, NOISE_FLOOR_A, SMOOTH_BLOCKS};
use crate::error::CliError;
use crate::output::{self, Overwrite};
use crate::plots::{line_plot, Line};
use crate::runtime::command::CommandJson;
use crate::schema::Document;

/// The model configuration the firmware build accepts (`EMA_MODEL_CONFIG`).
pub fn model_config(d: &Discovery) -> String {
    let mut s = format!(
        "# ema-monitor model configuration, written by `ema discover {}`\n# lines: effect ID SEVERITY\n",
        d.file.display()
    );
    for (e, sev, c) in &d.named {
        let _ = writeln!(s, "effect {} {sev} # confidence {c:.3}", e.id());
    }
    s
}

/// The paper's Err% of `k` against `--truth`, when given.
fn err_percent(d: &Discovery, k: &FaultVector) -> Option<f64> {
    d.truth.map(|t| f64::from(k.paper_error_percent(&t)))
}

/// A named effect in the JSON report.
#[derive(Clone, Debug, Serialize)]
pub struct NamedJson {
    /// Effect ID ([`ema_monitor::EffectId::id`]).
    pub effect: &'static str,
    /// Fitted severity (the effect's own scale, 0 = absent).
    pub severity: f32,
    /// Posterior weight among "no effect" and the round's candidates, in [0, 1].
    pub confidence: f64,
    /// Causes outside the library that leave the same signature on this manoeuvre.
    pub same_signature: &'static [&'static str],
}

/// A withdrawn effect in the JSON report.
#[derive(Clone, Debug, Serialize)]
pub struct WithdrawnJson {
    /// Effect ID.
    pub effect: &'static str,
    /// `gap_not_shrunk` or `at_bound`.
    pub reason: &'static str,
    /// The refit's severity, under `at_bound` (else absent).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub severity: Option<f32>,
}

/// A hot window in the JSON report.
#[derive(Clone, Debug, Serialize)]
pub struct WindowJson {
    /// Start (s).
    pub start_s: f64,
    /// End (s).
    pub end_s: f64,
    /// Share of the structural residual energy, in [0, 1].
    pub share: f64,
    /// Structural residual RMS in the window before (A).
    #[serde(rename = "rms_before_A")]
    pub rms_before_a: f64,
    /// The same after adding the named effects (A).
    #[serde(rename = "rms_after_A")]
    pub rms_after_a: f64,
}

/// An operating regime's shares in the JSON report.
#[derive(Clone, Debug, Serialize)]
pub struct RegimeJson {
    /// Family (`direction`, `speed`, ...).
    pub family: &'static str,
    /// Regime name.
    pub regime: &'static str,
    /// Share of the time, in [0, 1].
    pub time_share: f64,
    /// Share of the structural residual energy, in [0, 1].
    pub energy_share: f64,
}

/// A rotor-angle order's share in the JSON report.
#[derive(Clone, Debug, Serialize)]
pub struct OrderJson {
    /// Order name.
    pub order: &'static str,
    /// Share of the raw residual energy, in [0, 1].
    pub share: f64,
}

/// The JSON report of `ema discover` (`--json`, `discovery.json`); `docs/output-schema.md`
/// documents every key.
#[derive(Clone, Debug, Serialize)]
pub struct DiscoveryJson {
    /// What drove the monitor model (left out when unknown).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub command: Option<CommandJson>,
    /// The named effects.
    pub named: Vec<NamedJson>,
    /// [`verdict`].
    pub verdict: String,
    /// Where a residual no library effect explains remains (null: none).
    pub unexplained: Option<String>,
    /// Effects withdrawn at step 4.
    pub withdrawn: Vec<WithdrawnJson>,
    /// Structural residual RMS before (A).
    #[serde(rename = "rms_before_A")]
    pub rms_before_a: f64,
    /// Structural residual RMS after (A).
    #[serde(rename = "rms_after_A")]
    pub rms_after_a: f64,
    /// Raw residual RMS before (A).
    #[serde(rename = "raw_rms_before_A")]
    pub raw_rms_before_a: f64,
    /// Raw residual RMS after (A).
    #[serde(rename = "raw_rms_after_A")]
    pub raw_rms_after_a: f64,
    /// The sensor noise no model removes (A).
    #[serde(rename = "noise_floor_A")]
    pub noise_floor_a: f64,
    /// Structural RMS above the noise floor before (A).
    #[serde(rename = "above_noise_before_A")]
    pub above_noise_before_a: f64,
    /// The same after (A).
    #[serde(rename = "above_noise_after_A")]
    pub above_noise_after_a: f64,
    /// What the residual is.
    pub residual: String,
    /// The hot windows.
    pub windows: Vec<WindowJson>,
    /// The regimes' shares.
    pub regimes: Vec<RegimeJson>,
    /// The rotor-angle orders' shares.
    pub orders: Vec<OrderJson>,
    /// Every round's candidates, best first.
    pub rounds: Vec<Vec<Candidate>>,
    /// Fault vector of the current model's fit.
    pub k_before: [f32; 8],
    /// Fault vector with the named effects.
    pub k_after: [f32; 8],
    /// Fitness before (A²).
    #[serde(rename = "fitness_before_A2")]
    pub fitness_before_a2: f32,
    /// Fitness after (A²).
    #[serde(rename = "fitness_after_A2")]
    pub fitness_after_a2: f32,
    /// Err% of `k_before` against `--truth` (null without it).
    pub err_percent_before: Option<f64>,
    /// Err% of `k_after` against `--truth`.
    pub err_percent_after: Option<f64>,
    /// The on-board diagnosis before.
    pub k_onboard_before: [f32; 8],
    /// The on-board diagnosis with the named effects promoted.
    pub k_onboard_after: [f32; 8],
    /// Err% of `k_onboard_before` against `--truth`.
    pub err_percent_onboard_before: Option<f64>,
    /// Err% of `k_onboard_after` against `--truth`.
    pub err_percent_onboard_after: Option<f64>,
    /// Wall time of the whole workflow (s).
    pub elapsed_s: f64,
    /// Objective evaluations in all.
    pub evaluations: u64,
}

/// The JSON report's body.
pub fn json_body(d: &Discovery) -> DiscoveryJson {
    DiscoveryJson {
        command: d.command.clone(),
        named: d
            .named
            .iter()
            .map(|(e, s, c)| NamedJson {
                effect: e.id(),
                severity: *s,
                confidence: *c,
                same_signature: same_signature(*e),
            })
            .collect(),
        verdict: verdict(d),
        unexplained: d.unexplained.clone(),
        withdrawn: d
            .withdrawn
            .iter()
            .map(|(e, why)| match why {
                Withdrawal::GapNotShrunk => WithdrawnJson { effect: e.id(), reason: "gap_not_shrunk", severity: None },
                Withdrawal::AtBound(s) => WithdrawnJson { effect: e.id(), reason: "at_bound", severity: Some(*s) },
            })
            .collect(),
        rms_before_a: d.rms_before_a(),
        rms_after_a: d.rms_after_a(),
        raw_rms_before_a: d.raw_rms_before_a(),
        raw_rms_after_a: d.raw_rms_after_a(),
        noise_floor_a: NOISE_FLOOR_A,
        above_noise_before_a: above_noise_a(d.rms_before_a()),
        above_noise_after_a: above_noise_a(d.rms_after_a()),
        residual: format!(
            "I_3eq block means minus model, averaged over {SMOOTH_BLOCKS} blocks (2 ms); raw_*: not averaged; A"
        ),
        windows: d
            .windows
            .iter()
            .map(|w| WindowJson {
                start_s: w.start_s,
                end_s: w.end_s,
                share: w.share,
                rms_before_a: w.rms_before_a,
                rms_after_a: w.rms_after_a,
            })
            .collect(),
        regimes: d
            .regimes
            .iter()
            .map(|r| RegimeJson {
                family: r.family,
                regime: r.name,
                time_share: r.time_share,
                energy_share: r.energy_share,
            })
            .collect(),
        orders: d.orders.iter().map(|(n, s)| OrderJson { order: n, share: *s }).collect(),
        rounds: d.rounds.iter().map(|r| r.candidates.to_vec()).collect(),
        k_before: d.before.k.0,
        k_after: d.after.k.0,
        fitness_before_a2: d.before.error,
        fitness_after_a2: d.after.error,
        err_percent_before: err_percent(d, &d.before.k),
        err_percent_after: err_percent(d, &d.after.k),
        k_onboard_before: d.onboard_before.0,
        k_onboard_after: d.onboard_after.0,
        err_percent_onboard_before: err_percent(d, &d.onboard_before),
        err_percent_onboard_after: err_percent(d, &d.onboard_after),
        elapsed_s: d.seconds,
        evaluations: d.evaluations,
    }
}

/// The JSON report: [`DiscoveryJson`] in a [`Document`] whose `input_file` is the recording.
pub fn to_json(d: &Discovery) -> String {
    Document::new(Some(&d.file), json_body(d)).to_json()
}

/// The effects that had the evidence but fitted at their bound, for the verdict.
fn pinned_note(d: &Discovery) -> String {
    let pinned: Vec<&str> = d
        .rounds
        .iter()
        .filter_map(|r| r.pinned)
        .filter(|e| !d.named.iter().any(|n| n.0 == *e))
        .map(|e| e.id())
        .collect();
    if pinned.is_empty() {
        String::new()
    } else {
        format!(
            " (closest library effect: {}, but only at the bound of its fit, beyond its documented maximum: the effect is stronger or different)",
            pinned.join(", ")
        )
    }
}

/// The effects withdrawn at step 4, for the verdict.
fn withdrawn_note(d: &Discovery) -> String {
    if d.withdrawn.is_empty() {
        String::new()
    } else {
        let why: Vec<String> = d
            .withdrawn
            .iter()
            .map(|(e, why)| match why {
                Withdrawal::GapNotShrunk => {
                    format!("{} withdrawn: its refit on the whole recording did not shrink the gap", e.id())
                }
                Withdrawal::AtBound(s) => format!(
                    "{} withdrawn: its refit on the whole recording put it at {s:.2}, the bound of its fit, beyond its documented maximum: the effect is stronger or different",
                    e.id()
                ),
            })
            .collect();
        format!(" ({})", why.join("; "))
    }
}

/// One line: what was found.
pub fn verdict(d: &Discovery) -> String {
    let found = if d.named.is_empty() {
        match &d.unexplained {
            None => "no missing effect found".to_string(),
            Some(u) => format!("no library effect explains the gap: {u}{}", pinned_note(d)),
        }
    } else {
        let names: Vec<String> = d
            .named
            .iter()
            .map(|(e, s, c)| {
                let alike = same_signature(*e);
                let or = if alike.is_empty() {
                    String::new()
                } else {
                    format!(", or what leaves the same signature on this manoeuvre: {}", alike.join(", "))
                };
                format!("{} (severity {s:.2}, confidence {c:.2}{or})", e.id())
            })
            .collect();
        match &d.unexplained {
            None => format!("missing: {}", names.join(" and ")),
            Some(u) => format!("missing: {}; {u}{}", names.join(" and "), pinned_note(d)),
        }
    };
    found + &withdrawn_note(d)
}

/// The readable summary.
pub fn summary(d: &Discovery) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "recording: {}", d.file.display());
    if let Some(c) = &d.command {
        let _ = writeln!(s, "command: {}", c.label());
    }
    let _ = writeln!(s, "verdict: {}", verdict(d));
    let _ = writeln!(
        s,
        "structural residual RMS (2 ms means): {:.4} A before, {:.4} A after ({:.1} % of before); raw: {:.4} -> {:.4} A",
        d.rms_before_a(),
        d.rms_after_a(),
        100.0 * d.rms_after_a() / d.rms_before_a().max(1e-12),
        d.raw_rms_before_a(),
        d.raw_rms_after_a()
    );
    let (above_before, above_after) = (above_noise_a(d.rms_before_a()), above_noise_a(d.rms_after_a()));
    let _ = writeln!(
        s,
        "above the sensor noise ({NOISE_FLOOR_A:.3} A, which no model removes): {above_before:.4} A before, {above_after:.4} A after ({:.1} % of before)",
        100.0 * above_after / above_before.max(1e-12)
    );
    let _ = writeln!(s, "\nwhere (windows holding half the residual energy):");
    for w in &d.windows {
        let _ = writeln!(
            s,
            "  {:.3}-{:.3} s: {:4.1} % of the energy, RMS {:.4} -> {:.4} A",
            w.start_s,
            w.end_s,
            100.0 * w.share,
            w.rms_before_a,
            w.rms_after_a
        );
    }
    let _ = writeln!(s, "\nregimes (share of residual energy / share of time):");
    for r in &d.regimes {
        let _ = writeln!(
            s,
            "  {:9} {:28} {:5.1} % / {:5.1} %",
            r.family,
            r.name,
            100.0 * r.energy_share,
            100.0 * r.time_share
        );
    }
    let _ = writeln!(s, "\nrotor-angle orders (share of the raw residual energy):");
    for (n, v) in &d.orders {
        let _ = writeln!(s, "  {n:28} {:5.2} %", 100.0 * v);
    }
    for (j, r) in d.rounds.iter().enumerate() {
        let _ = writeln!(
            s,
            "\nround {}: candidates (held-out ΔBIC, fit ΔBIC, severity, share of the gap removed, of the gap above the noise, replaces faults (own held-out ΔBIC, in-sample gain))",
            j + 1
        );
        for c in &r.candidates {
            let _ = writeln!(
                s,
                "  {:20} {:9.1} {:9.1} {:6.3} {:6.1} % {:6.1} % {}",
                c.effect.id(),
                c.bic_held_out,
                c.bic_fit,
                c.severity,
                100.0 * c.gap_share,
                100.0 * c.above_noise_share,
                if c.replaces_faults {
                    format!("yes ({:.1}, {:.1})", c.bic_own_held_out, c.fit_gain)
                } else {
                    String::new()
                }
            );
        }
    }
    let _ = writeln!(s, "\nfault vector before: {:?}", d.before.k.0);
    let _ = writeln!(s, "fault vector after:  {:?}", d.after.k.0);
    if let (Some(a), Some(b)) = (err_percent(d, &d.before.k), err_percent(d, &d.after.k)) {
        let _ = writeln!(s, "Err% against --truth: {a:.2} before, {b:.2} after");
    }
    let _ = writeln!(s, "on-board diagnosis before: {:?}", d.onboard_before.0);
    let _ = writeln!(s, "on-board diagnosis after:  {:?} (named effects promoted)", d.onboard_after.0);
    if let (Some(a), Some(b)) = (err_percent(d, &d.onboard_before), err_percent(d, &d.onboard_after)) {
        let _ = writeln!(s, "on-board Err% against --truth: {a:.2} before, {b:.2} after");
    }
    let _ = write!(s, "{} evaluations, {:.1} s", d.evaluations, d.seconds);
    s
}

/// The files `--out DIR` receives, checked before the fits start and written together at the end.
pub const OUTPUT_FILES: [&str; 5] = ["discovery.json", "model-config.txt", "residual.csv", "fit.svg", "residual.svg"];

/// Writes discovery.json, model-config.txt, residual.csv, fit.svg and residual.svg into `dir`
/// (created if needed) through [`output::write_files`]: all complete or none replaced; an existing
/// file is replaced only with [`Overwrite::Replace`].
pub fn write_outputs(dir: &Path, d: &Discovery, overwrite: Overwrite) -> Result<(), CliError> {
    output::prepare_dir(dir, &OUTPUT_FILES, overwrite)?;
    let (b, a) = (&d.series_before, &d.series_after);
    let mut csv = String::from(
        "time_s,measured_A,model_before_A,model_after_A,residual_before_A,residual_after_A,structural_before_A,structural_after_A\n",
    );
    for i in 0..b.time_s.len() {
        let _ = writeln!(
            csv,
            "{:.4},{:.5},{:.5},{:.5},{:.5},{:.5},{:.5},{:.5}",
            b.time_s[i],
            b.measured_a[i],
            b.model_a[i],
            a.model_a[i],
            b.residual_a[i],
            a.residual_a[i],
            b.structural_a[i],
            a.structural_a[i]
        );
    }
    let measured = moving_mean(&b.measured_a, SMOOTH_BLOCKS);
    let model_before = moving_mean(&b.model_a, SMOOTH_BLOCKS);
    let model_after = moving_mean(&a.model_a, SMOOTH_BLOCKS);
    let hot: Vec<(f64, f64)> = d.windows.iter().map(|w| (w.start_s, w.end_s)).collect();
    let shaded = "windows holding half the residual energy";
    let named: Vec<String> = d.named.iter().map(|(e, s, _)| format!("{} {s:.2}", e.id())).collect();
    let after = if named.is_empty() {
        "model after (no effect named)".to_string()
    } else {
        format!("model after (+ {})", named.join(", "))
    };
    let residual_after = if named.is_empty() {
        "after (no effect named)".to_string()
    } else {
        format!("after (+ {})", named.join(", "))
    };
    let fit = line_plot(
        "Equivalent current I_3eq (2 ms means): measured vs model",
        "I_3eq (A)",
        &b.time_s,
        &[
            Line { name: "measured", colour: (34, 34, 34), values: &measured },
            Line { name: "model before", colour: (214, 39, 40), values: &model_before },
            Line { name: &after, colour: (31, 119, 180), values: &model_after },
        ],
        &hot,
        shaded,
    )
    .map_err(|source| CliError::Io { path: dir.join("fit.svg"), source })?;
    let residual = line_plot(
        "Structural residual (measured - model, 2 ms means)",
        "residual (A)",
        &b.time_s,
        &[
            Line { name: "before", colour: (214, 39, 40), values: &b.structural_a },
            Line { name: &residual_after, colour: (31, 119, 180), values: &a.structural_a },
        ],
        &hot,
        shaded,
    )
    .map_err(|source| CliError::Io { path: dir.join("residual.svg"), source })?;
    let contents = [to_json(d), model_config(d), csv, fit, residual];
    let paths = OUTPUT_FILES.map(|name| dir.join(name));
    let files: Vec<(&Path, &[u8])> = paths.iter().zip(&contents).map(|(p, c)| (p.as_path(), c.as_bytes())).collect();
    output::write_files(&files, overwrite)
}
