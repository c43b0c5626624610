//! `ema compare`: how well the monitor model (MM) reproduces the reference model (RM) when it is
//! given the TRUE fault vector — the mismatch floor under every identification.
//!
//! For the healthy actuator and each single fault at a low (0.25) and a high (0.8) severity: the RM
//! records the standard manoeuvre (noise on), the recording is conditioned exactly as on board
//! (`I_3eq`, 4-frame block means), and the MM runs with the same fault vector. Reported: RMS of the
//! equivalent-current residual overall and per manoeuvre segment, RMS of the position residual,
//! and the fitness `E` at the true vector against `E` at the healthy vector (how much of the fault's
//! signature stands above the floor).
//!
//! `--rotor-angle reference` forces the reference model's rotor angle (mechanical for the
//! eccentricity shape, electrical for the commutation sector) into the monitor model at every step,
//! its mechanics left as they are: what is left is the monitor model's electrical error, with the
//! drift of its rotor angle taken out.

use clap::{Args, ValueEnum};
use ema_monitor::conditioning::{ConditionedWindow, MeasuredEnvelope, DECIMATION};
use ema_monitor::fitness::EquivalentCurrentFit;
use ema_monitor::model::{ModelState, MonitorModel};
use ema_monitor::profile::ProfileCursor;
use ema_monitor::{EmaParams, FaultGroup, FaultParam, FaultVector, Profile};
use ema_reference::{simulate, SimConfig, Truth};
use serde::Serialize;

use crate::error::CliError;
use crate::params::ParamsArgs;
use crate::progress::{self, ProgressArgs};
use crate::runtime::source::HOST_WINDOW;
use crate::schema::Document;

/// Arguments of `ema compare`.
#[derive(Args, Debug, Clone)]
pub struct CompareArgs {
    /// Seed of the reference model's sensor noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Print JSON instead of the Markdown table.
    #[arg(long)]
    pub json: bool,
    /// Which rotor angle the monitor model's shape functions and commutation use.
    #[arg(long, value_enum, default_value_t = RotorAngle::Model)]
    pub rotor_angle: RotorAngle,
    /// The actuator's parameters (both models).
    #[command(flatten)]
    pub params: ParamsArgs,
    /// `--quiet`.
    #[command(flatten)]
    pub progress: ProgressArgs,
}

/// The rotor angle the monitor model runs with in `ema compare`.
#[derive(ValueEnum, Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum RotorAngle {
    /// Its own, integrated from its own speed (as on board)
    Model,
    /// The reference model's, forced in at every step (the mechanics stay the monitor model's)
    Reference,
}

/// Manoeuvre segments of the standard profile, `(name, start_s, end_s)`.
pub const SEGMENTS: [(&str, f64, f64); 4] =
    [("step", 0.0, 0.15), ("reversal", 0.15, 0.30), ("ramp", 0.30, 0.60), ("sine", 0.60, 0.85)];

/// The cases: a name and the true fault vector.
pub fn cases() -> Vec<(String, FaultVector)> {
    let mut out = vec![("healthy".to_string(), FaultVector::HEALTHY)];
    let groups = [
        FaultGroup::Friction,
        FaultGroup::Backlash,
        FaultGroup::ShortA,
        FaultGroup::Eccentricity,
        FaultGroup::GainDrift,
    ];
    for group in groups {
        for (level, value) in [("low", 0.25f32), ("high", 0.8)] {
            let mut k = FaultVector::HEALTHY;
            let index = group.severity_param().index();
            k.0[index] = if group == FaultGroup::GainDrift { 0.5 - value * 0.5 } else { value };
            if group == FaultGroup::Eccentricity {
                k.0[FaultParam::EccentricityPhase.index()] = 0.3;
            }
            out.push((format!("{} {level}", group.name()), k));
        }
    }
    out
}

/// Residuals of one case.
#[derive(Clone, Debug)]
pub struct CaseResult {
    /// Case name.
    pub name: String,
    /// The true fault vector.
    pub faults: FaultVector,
    /// RMS of `I_3eq − |I_MM|` over the whole manoeuvre (A).
    pub current_rms_a: f64,
    /// The same per segment of [`SEGMENTS`] (A).
    pub current_rms_by_segment_a: [f64; 4],
    /// RMS of the position residual (rad).
    pub position_rms_rad: f64,
    /// Fitness at the true vector (A²).
    pub fitness_true: f32,
    /// Fitness at the healthy vector (A²).
    pub fitness_healthy: f32,
}

/// The monitor model's run of the fitness (`fitness::simulate_window`: the expected envelope of
/// `I_out`, then a step; [`DECIMATION`] steps per window sample) for `samples` window samples:
/// each sample's block mean and the surface angle at its end. With [`RotorAngle::Reference`] the
/// rotor angle of `truth` (one entry per step) is forced in before every step.
pub fn model_run(
    params: &EmaParams,
    profile: &Profile,
    faults: &FaultVector,
    samples: usize,
    rotor: RotorAngle,
    truth: &[Truth],
) -> Vec<(f32, f32)> {
    let model = MonitorModel::new(params, faults);
    let envelope = MeasuredEnvelope::of(params);
    let mut state = ModelState::at_rest();
    let mut command = ProfileCursor::new(profile);
    let mut step = 0usize;
    let mut out = Vec::with_capacity(samples);
    for _ in 0..samples {
        let mut block = 0.0f32;
        for _ in 0..DECIMATION {
            block += envelope.expected_a(state.output_current_a);
            if let (RotorAngle::Reference, Some(t)) = (rotor, truth.get(step)) {
                state.set_motor_angle(wrapped(t.motor_angle_rad));
                state.hall_angle_rad = wrapped(t.electrical_angle_rad - std::f64::consts::FRAC_PI_6);
            }
            model.step(&mut state, command.command_rad(step as f32 * model.dt_s()));
            step += 1;
        }
        out.push((block * (1.0 / DECIMATION as f32), state.surface_angle_rad));
    }
    out
}

/// An angle (rad) wrapped into `[0, 2π)` as the monitor model keeps it.
fn wrapped(angle_rad: f64) -> f32 {
    angle_rad.rem_euclid(std::f64::consts::TAU) as f32
}

/// Runs one case of the actuator `params` with the monitor model's rotor angle from `rotor`.
pub fn compare_case(
    name: &str,
    faults: FaultVector,
    seed: u64,
    rotor: RotorAngle,
    params: &EmaParams,
) -> Result<CaseResult, CliError> {
    let params = *params;
    let profile = Profile::STANDARD;
    let config = SimConfig { params, faults, seed, ..SimConfig::default() };
    let rec = simulate(&config).map_err(|e| CliError::Simulation(e.to_string()))?;
    let mut trace = Box::new(ConditionedWindow::<HOST_WINDOW>::new());
    for s in &rec.samples {
        let i = s.phase_current_a;
        trace.push(i[0] as f32, i[1] as f32, i[2] as f32).map_err(|e| CliError::Simulation(e.to_string()))?;
    }
    trace.finish().map_err(|e| CliError::Simulation(e.to_string()))?;
    let n = trace.len();
    let mut sum_sq = 0.0f64;
    let mut seg_sq = [0.0f64; 4];
    let mut seg_n = [0usize; 4];
    let mut pos_sq = 0.0f64;
    let mut pos_n = 0usize;
    let window_dt = f64::from(params.control_period_s) * DECIMATION as f64;
    let run = model_run(&params, &profile, &faults, n, rotor, &rec.truth);
    for (i, (&(model_a, surface_angle_rad), y)) in run.iter().zip(trace.current_a()).enumerate() {
        let r = f64::from(y) - f64::from(model_a);
        sum_sq += r * r;
        let t = (i as f64 + 0.5) * window_dt;
        if let Some(seg) = SEGMENTS.iter().position(|(_, a, b)| t >= *a && t < *b) {
            seg_sq[seg] += r * r;
            seg_n[seg] += 1;
        }
        if let Some(s) = rec.samples.get((i + 1) * DECIMATION) {
            let d = s.position_rad - f64::from(surface_angle_rad);
            pos_sq += d * d;
            pos_n += 1;
        }
    }
    let fit = EquivalentCurrentFit::new(&*trace, params, &profile).map_err(|e| CliError::Simulation(e.to_string()))?;
    let rms = |s: f64, n: usize| if n == 0 { 0.0 } else { (s / n as f64).sqrt() };
    Ok(CaseResult {
        name: name.to_string(),
        faults,
        current_rms_a: rms(sum_sq, n),
        current_rms_by_segment_a: [0, 1, 2, 3].map(|j| rms(seg_sq[j], seg_n[j])),
        position_rms_rad: rms(pos_sq, pos_n),
        fitness_true: fit.error(&faults),
        fitness_healthy: fit.error(&FaultVector::HEALTHY),
    })
}

/// One manoeuvre segment's residual in `ema compare --json`.
#[derive(Clone, Debug, Serialize)]
pub struct SegmentJson {
    /// Segment name ([`SEGMENTS`]).
    pub segment: &'static str,
    /// `I_3eq` residual RMS in the segment (A).
    #[serde(rename = "rms_A")]
    pub rms_a: f64,
}

/// One case of `ema compare --json`.
#[derive(Clone, Debug, Serialize)]
pub struct CaseJson<'a> {
    /// Case name (`healthy`, `friction low`, ...).
    pub case: &'a str,
    /// The true fault vector.
    pub k: [f32; 8],
    /// `I_3eq` residual RMS over the manoeuvre (A).
    #[serde(rename = "current_rms_A")]
    pub current_rms_a: f64,
    /// The same per segment.
    #[serde(rename = "current_rms_by_segment_A")]
    pub current_rms_by_segment_a: Vec<SegmentJson>,
    /// Position residual RMS (rad).
    pub position_rms_rad: f64,
    /// Fitness at the true vector (A²).
    #[serde(rename = "fitness_true_A2")]
    pub fitness_true_a2: f32,
    /// Fitness at the healthy vector (A²).
    #[serde(rename = "fitness_healthy_A2")]
    pub fitness_healthy_a2: f32,
}

/// `ema compare --json`: the settings and one entry per case; `docs/output-schema.md` documents
/// every key.
#[derive(Clone, Debug, Serialize)]
pub struct CompareJson<'a> {
    /// `--seed`.
    pub seed: u64,
    /// `--rotor-angle`: `model` or `reference`.
    pub rotor_angle: RotorAngle,
    /// The cases.
    pub cases: Vec<CaseJson<'a>>,
}

/// Runs `ema compare`.
pub fn run(args: &CompareArgs) -> Result<String, CliError> {
    let params = args.params.load()?;
    let cases = cases();
    let bar = progress::bar(cases.len() as u64, "cases", args.progress.visible());
    let results = cases
        .into_iter()
        .map(|(name, k)| {
            let result = compare_case(&name, k, args.seed, args.rotor_angle, &params);
            bar.inc(1);
            result
        })
        .collect::<Result<Vec<CaseResult>, _>>();
    bar.finish_and_clear();
    let results = results?;
    if args.json {
        let cases = results
            .iter()
            .map(|r| CaseJson {
                case: &r.name,
                k: r.faults.0,
                current_rms_a: r.current_rms_a,
                current_rms_by_segment_a: SEGMENTS
                    .iter()
                    .zip(r.current_rms_by_segment_a)
                    .map(|(&(segment, _, _), rms_a)| SegmentJson { segment, rms_a })
                    .collect(),
                position_rms_rad: r.position_rms_rad,
                fitness_true_a2: r.fitness_true,
                fitness_healthy_a2: r.fitness_healthy,
            })
            .collect();
        let body = CompareJson { seed: args.seed, rotor_angle: args.rotor_angle, cases };
        return Ok(Document::new(None, body).to_json());
    }
    let mut out = String::from(
        "| case (RM fault) | I_3eq residual RMS (A) | step | reversal | ramp | sine | position RMS (rad) | E(true k) (A²) | E(healthy k) (A²) |\n|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in &results {
        let s = r.current_rms_by_segment_a;
        out.push_str(&format!(
            "| {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.2e} | {:.2e} | {:.2e} |\n",
            r.name, r.current_rms_a, s[0], s[1], s[2], s[3], r.position_rms_rad, r.fitness_true, r.fitness_healthy
        ));
    }
    out.push_str(&format!(
        "\nreference model: standard profile, noise on, seed {}; monitor model given the true k, {}.",
        args.seed,
        match args.rotor_angle {
            RotorAngle::Model => "its own rotor angle",
            RotorAngle::Reference => "the reference model's rotor angle forced in",
        }
    ));
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ema_monitor::fitness::simulate_window;

    fn eccentric() -> (FaultVector, ema_reference::Recording) {
        let faults = FaultVector([0.0, 0.0, 0.0, 0.0, 0.0, 0.8, 0.3, 0.5]);
        let rec = simulate(&SimConfig { faults, seed: 1, ..SimConfig::default() }).expect("simulates");
        (faults, rec)
    }

    #[test]
    fn the_model_run_is_the_fitness_run_bit_for_bit() {
        let (faults, rec) = eccentric();
        let (params, profile, n) = (EmaParams::NOMINAL, Profile::STANDARD, 2125);
        let ours = model_run(&params, &profile, &faults, n, RotorAngle::Model, &rec.truth);
        let mut fitness = Vec::new();
        simulate_window(&params, &profile, &faults, n, |_, value, state| {
            fitness.push((value.to_bits(), state.surface_angle_rad.to_bits()));
            true
        });
        let ours: Vec<(u32, u32)> = ours.iter().map(|(a, b)| (a.to_bits(), b.to_bits())).collect();
        assert_eq!(ours, fitness);
    }

    #[test]
    fn the_reference_rotor_angle_changes_the_eccentric_model_run() {
        let (faults, rec) = eccentric();
        let (params, profile, n) = (EmaParams::NOMINAL, Profile::STANDARD, 2125);
        let own = model_run(&params, &profile, &faults, n, RotorAngle::Model, &rec.truth);
        let forced = model_run(&params, &profile, &faults, n, RotorAngle::Reference, &rec.truth);
        let differing = own.iter().zip(&forced).filter(|(a, b)| a.0 != b.0).count();
        assert!(differing > n / 4, "only {differing} of {n} samples differ");
    }
}
