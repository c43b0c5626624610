//! Step 5, show: the readable summary, the one-line verdict, the JSON report and the files of
//! `--out DIR` (`discovery.json`, `residual.csv`, `fit.svg`, `residual.svg`, `model-config.txt`).

use std::fmt::Write as _;
use std::path::Path;

use ema_monitor::FaultVector;
use serde_json::json;

use super::naming::same_signature;
use super::residual::{above_noise_a, moving_mean, NOISE_FLOOR_A, SMOOTH_BLOCKS};
use super::{Discovery, Withdrawal};
use crate::error::CliError;
use crate::output::{self, Overwrite};
use crate::svg::line_plot;

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

/// The JSON report.
pub fn to_json(d: &Discovery) -> serde_json::Value {
    json!({
        "file": d.file.display().to_string(),
        "named": d.named.iter().map(|(e, s, c)| json!({"effect": e.id(), "severity": s, "confidence": c, "same_signature": same_signature(*e)})).collect::<Vec<_>>(),
        "verdict": verdict(d),
        "unexplained": d.unexplained,
        "withdrawn": d.withdrawn.iter().map(|(e, why)| match why {
            Withdrawal::GapNotShrunk => json!({"effect": e.id(), "reason": "gap_not_shrunk"}),
            Withdrawal::AtBound(s) => json!({"effect": e.id(), "reason": "at_bound", "severity": s}),
        }).collect::<Vec<_>>(),
        "rms_before": d.rms_before_a(),
        "rms_after": d.rms_after_a(),
        "raw_rms_before": d.raw_rms_before_a(),
        "raw_rms_after": d.raw_rms_after_a(),
        "noise_floor": NOISE_FLOOR_A,
        "above_noise_before": above_noise_a(d.rms_before_a()),
        "above_noise_after": above_noise_a(d.rms_after_a()),
        "residual": format!("I_3eq block means minus model, averaged over {SMOOTH_BLOCKS} blocks (2 ms); raw_*: not averaged; A"),
        "windows": d.windows.iter().map(|w| json!({"start_s": w.start_s, "end_s": w.end_s, "share": w.share, "rms_before": w.rms_before_a, "rms_after": w.rms_after_a})).collect::<Vec<_>>(),
        "regimes": d.regimes.iter().map(|r| json!({"family": r.family, "regime": r.name, "time_share": r.time_share, "energy_share": r.energy_share})).collect::<Vec<_>>(),
        "orders": d.orders.iter().map(|(n, s)| json!({"order": n, "share": s})).collect::<Vec<_>>(),
        "rounds": d.rounds.iter().map(|r| r.candidates.iter().map(|c| json!({"effect": c.effect.id(), "severity": c.severity, "bic_fit": finite(c.bic_fit), "fit_gain": finite(c.fit_gain), "bic_held_out": finite(c.bic_held_out), "gap_share": c.gap_share, "above_noise_share": c.above_noise_share, "replaces_faults": c.replaces_faults, "bic_own_held_out": finite(c.bic_own_held_out), "k": c.fit.k.0})).collect::<Vec<_>>()).collect::<Vec<_>>(),
        "k_before": d.before.k.0,
        "k_after": d.after.k.0,
        "fitness_before": d.before.error,
        "fitness_after": d.after.error,
        "err_percent_before": err_percent(d, &d.before.k),
        "err_percent_after": err_percent(d, &d.after.k),
        "k_onboard_before": d.onboard_before.0,
        "k_onboard_after": d.onboard_after.0,
        "err_percent_onboard_before": err_percent(d, &d.onboard_before),
        "err_percent_onboard_after": err_percent(d, &d.onboard_after),
        "seconds": d.seconds,
        "evaluations": d.evaluations,
    })
}

/// `x` as a JSON number, `null` when not finite (JSON has no infinities).
fn finite(x: f64) -> serde_json::Value {
    if x.is_finite() {
        json!(x)
    } else {
        serde_json::Value::Null
    }
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
    let fit = line_plot(
        "Equivalent current I_3eq (2 ms means): measured vs model",
        "A",
        &b.time_s,
        &[
            ("measured", "#222222", &measured),
            ("model before", "#d62728", &model_before),
            ("model after", "#1f77b4", &model_after),
        ],
        &hot,
    );
    let residual = line_plot(
        "Structural residual (measured - model, 2 ms means)",
        "A",
        &b.time_s,
        &[("before", "#d62728", &b.structural_a), ("after", "#1f77b4", &a.structural_a)],
        &hot,
    );
    let contents = [to_json(d).to_string(), model_config(d), csv, fit, residual];
    let paths = OUTPUT_FILES.map(|name| dir.join(name));
    let files: Vec<(&Path, &[u8])> = paths.iter().zip(&contents).map(|(p, c)| (p.as_path(), c.as_bytes())).collect();
    output::write_files(&files, overwrite)
}
