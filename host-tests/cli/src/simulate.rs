//! `ema simulate`: runs the reference model and writes a recording.
//!
//! ```text
//! ema simulate --faults k1,…,k8 [--effect ID=S]… [--profile standard|FILE] [--params FILE.toml]
//!              [--unit SEED [--tolerances FILE.toml]] [--temperature C] [--sensors PRESET|FILE.toml]
//!              [--pre-trigger-ms N] [--noise on|off] [--seed N] --out FILE.csv [--force]
//! ```
//!
//! The actuator is `--params` (or the nominal set) at 20 °C; `--unit SEED` draws one unit of it
//! from the tolerance table ([`crate::unit_draw`], `--tolerances` or
//! [`Tolerances::TYPICAL`]); `--temperature C` runs the reference model with that unit's
//! parameters at `C` ([`EmaParams::at_temperature`]) and adds the `temperature_C` column.
//!
//! `--sensors` is the phase currents' measurement chain ([`crate::sensors_file`],
//! docs/sensors.md): a preset (`ideal`, the default; `nucleo-f446re`; `nucleo-f446re-oneshot`) or a
//! sensor file. `--pre-trigger-ms N` opens the recording with `N` ms of the actuator at rest
//! before the manoeuvre ([`SimConfig::pre_trigger_s`]): the time column starts at 0, the
//! manoeuvre at `N` ms, as a bench logs before its trigger.
//!
//! `--out F.csv` gets a plain CSV (header and rows, [`crate::recording::write`]) and its metadata
//! in the sidecar `F.json` ([`crate::recording::sidecar`]). Both are checked before the
//! simulation runs; an existing one is replaced only with `--force`, and both are written in one
//! [`write_files`] call: whole or not at all ([`crate::output`]).

use std::path::{Path, PathBuf};

use clap::{Args, ValueEnum};
use ema_monitor::{EffectId, EmaParams, FaultVector, ModelEffects, Profile, Tolerances, FAULT_COUNT};
use ema_reference::{simulate, Effect, Effects, SimConfig};

use crate::error::{num, CliError};
use crate::output::{check_file, write_files, OutputArgs};
use crate::params::ParamsArgs;
use crate::profile_file::read_profile;
use crate::progress::{self, ProgressArgs};
use crate::recording::sidecar::{sidecar_path, Sidecar, SidecarSensors, SidecarUnit, SCHEMA_VERSION};
use crate::recording::write::csv_bytes;
use crate::recording::{Recording, HEADER, MAX_TEMPERATURE_C, MIN_TEMPERATURE_C, TEMPERATURE_HEADER};
use crate::sensors_file::resolve_sensors;
use crate::tolerances_file::read_tolerances;
use crate::unit_draw::draw_unit;

/// Sensor noise switch.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Noise {
    /// Seeded white noise on the position and current sensors.
    On,
    /// No noise (lags and quantization stay).
    Off,
}

/// Arguments of `ema simulate`.
#[derive(Args, Debug, Clone)]
#[command(mut_arg("out", |a| a.required(true).value_name("FILE.csv")
    .help("Output CSV file (written to a temporary file beside it, renamed into place when complete)")))]
pub struct SimulateArgs {
    /// Fault vector k1..k8 in [0, 1]: friction, backlash, short_a, short_b, short_c, eccentricity,
    /// ecc_phase, gain (healthy: 0,0,0,0,0,0,0.5,0.5).
    #[arg(long, value_name = "K1,...,K8", default_value = "0,0,0,0,0,0,0.5,0.5", allow_hyphen_values = true)]
    pub faults: String,
    /// Unmodelled effect at severity S in [0, 1], repeatable (IDs: cogging, stribeck, viscous,
    /// winding_temperature, emf_harmonics, dead_time, sensor_offset, hinge_stiffness, saturation,
    /// hall_misalignment, compliance, bus_sag).
    #[arg(long = "effect", value_name = "ID=S", allow_hyphen_values = true)]
    pub effects: Vec<String>,
    /// Command profile: `standard`, `pbit` (the pre-flight built-in test, docs/pbit.md) or a
    /// profile file (lines `hold START VALUE`, `ramp START START_RAD RATE`,
    /// `sine START OFFSET AMP FREQ`, `end DURATION`; `#` comments).
    #[arg(long, value_name = "NAME|FILE", default_value = "standard")]
    pub profile: String,
    /// Sensor noise.
    #[arg(long, value_enum, default_value_t = Noise::On)]
    pub noise: Noise,
    /// Seed of the noise generator (same seed, same file).
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub seed: u64,
    /// `--out FILE.csv` (required) and `--force`.
    #[command(flatten)]
    pub output: OutputArgs,
    /// The actuator's parameters (recorded in the file's metadata).
    #[command(flatten)]
    pub params: ParamsArgs,
    /// Draw one unit of the actuator: each parameter that varies from unit to unit moved by z
    /// standard deviations of its tolerance, z ~ N(0, 1) from a generator seeded by SEED (same
    /// seed, same unit); the base is --params or the nominal set.
    #[arg(long, value_name = "SEED")]
    pub unit: Option<u64>,
    /// Tolerance table of --unit (TOML; `ema params --tolerances` prints the template)
    /// [default: the typical tolerances].
    #[arg(long, value_name = "FILE.toml", requires = "unit")]
    pub tolerances: Option<PathBuf>,
    /// The actuator's temperature, °C (-100 to 200): the reference model runs with the
    /// parameters at that temperature, and the CSV gets a temperature_C column [default: 20 °C,
    /// no column].
    #[arg(long, value_name = "C", allow_hyphen_values = true)]
    pub temperature: Option<f64>,
    /// The phase currents' measurement chain (docs/sensors.md): a preset, `ideal` (no error,
    /// 20 kHz, the three phases at the frame instant, 12 bits over ±20 A), `nucleo-f446re` (the
    /// board's Hall sensors: zero errors +0.15, -0.10, +0.12 A, gain errors +1.0, -0.8, +0.5 %,
    /// 20 kHz, triple simultaneous ADC, 12 bits over ±20 A) or `nucleo-f446re-oneshot` (the same
    /// sensors converted in sequence at 0, 5, 10 µs); or a sensor file (TOML: `preset = "NAME"`
    /// to start from, then any of adc_bits, full_scale_a, and per phase [a, b, c] offset_a,
    /// gain_error, bandwidth_hz, skew_us).
    #[arg(long, value_name = "PRESET|FILE.toml", default_value = "ideal")]
    pub sensors: String,
    /// Milliseconds of the actuator at rest recorded before the manoeuvre (0 to 10000): the drive
    /// off, the command at the profile's opening value, the currents the sensors' zero errors and
    /// noise; the time column starts at 0 and the manoeuvre at N ms.
    #[arg(long = "pre-trigger-ms", value_name = "N", default_value_t = 0)]
    pub pre_trigger_ms: u32,
    /// `--quiet`.
    #[command(flatten)]
    pub progress: ProgressArgs,
}

/// Longest `--pre-trigger-ms` ([`ema_reference::MAX_PRE_TRIGGER_S`]).
pub const MAX_PRE_TRIGGER_MS: u32 = (ema_reference::MAX_PRE_TRIGGER_S * 1000.0) as u32;

/// The simulated actuator: its parameters at 20 °C (the unit's under `--unit`), the unit drawn and
/// the temperature.
#[derive(Clone, Debug, PartialEq)]
pub struct Actuator {
    /// The parameters at 20 °C: `--params` (or nominal), or the unit drawn from them.
    pub params: EmaParams,
    /// The unit drawn (`--unit`), as the sidecar records it.
    pub unit: Option<SidecarUnit>,
    /// The temperature (`--temperature`, °C).
    pub temperature_c: Option<f64>,
}

impl Actuator {
    /// The parameters the reference model runs: [`Actuator::params`] at the temperature, if any.
    pub fn simulated(&self) -> EmaParams {
        match self.temperature_c {
            Some(t) => self.params.at_temperature(t as f32),
            None => self.params,
        }
    }
}

/// `--temperature C`: finite and within [`MIN_TEMPERATURE_C`] and [`MAX_TEMPERATURE_C`].
pub fn check_temperature(c: f64) -> Result<f64, CliError> {
    if !c.is_finite() {
        return Err(CliError::flag("--temperature", format!("{} is not a temperature; give degrees Celsius", num(c))));
    }
    if !(MIN_TEMPERATURE_C..=MAX_TEMPERATURE_C).contains(&c) {
        return Err(CliError::flag(
            "--temperature",
            format!("{} °C is outside {MIN_TEMPERATURE_C} to {MAX_TEMPERATURE_C} °C", num(c)),
        ));
    }
    Ok(c)
}

/// The actuator the arguments describe: `--params` (or nominal), the unit `--unit` draws from it
/// with `--tolerances` (or [`Tolerances::TYPICAL`]), at `--temperature`; refused when its
/// parameters at that temperature fail [`EmaParams::check`].
pub fn actuator(args: &SimulateArgs) -> Result<Actuator, CliError> {
    let temperature_c = args.temperature.map(check_temperature).transpose()?;
    let base = args.params.load()?;
    let (params, unit) = match args.unit {
        Some(seed) => {
            let tolerances = match &args.tolerances {
                Some(path) => read_tolerances(path)?,
                None => Tolerances::TYPICAL,
            };
            let name = args.tolerances.as_ref().map_or_else(|| "typical".to_owned(), |p| p.display().to_string());
            let drawn = draw_unit(&base, &tolerances, seed).map_err(|e| CliError::flag("--unit", e.to_string()))?;
            (drawn.params, Some(drawn.to_sidecar(&base, &tolerances, name)))
        }
        None => (base, None),
    };
    let actuator = Actuator { params, unit, temperature_c };
    if let Some(t) = temperature_c {
        actuator.simulated().check().map_err(|e| {
            CliError::flag("--temperature", format!("at {t} °C the actuator's parameters are refused: {e}"))
        })?;
    }
    Ok(actuator)
}

/// Parses `k1,…,k8`: exactly eight numbers in `[0, 1]`.
pub fn parse_faults(text: &str) -> Result<FaultVector, CliError> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() != FAULT_COUNT {
        return Err(CliError::flag(
            "--faults",
            format!("need {FAULT_COUNT} comma-separated values k1,...,k8, found {} in '{text}'", parts.len()),
        ));
    }
    let mut k = [0.0f32; FAULT_COUNT];
    for (i, p) in parts.iter().enumerate() {
        let v: f32 =
            p.parse().map_err(|_| CliError::flag("--faults", format!("k{} = '{p}' is not a number", i + 1)))?;
        if !(0.0..=1.0).contains(&v) {
            return Err(CliError::flag("--faults", format!("k{} = {p} is outside [0, 1]", i + 1)));
        }
        k[i] = v;
    }
    Ok(FaultVector(k))
}

/// Parses the `--effect ID=S` list: known IDs, each once, severities in `[0, 1]`.
pub fn parse_effects(list: &[String]) -> Result<Effects, CliError> {
    let mut fx = Effects::NONE;
    let mut seen: Vec<Effect> = Vec::new();
    for item in list {
        let Some((id, sev)) = item.split_once('=') else {
            return Err(CliError::flag("--effect", format!("'{item}' is not ID=S (e.g. cogging=0.5)")));
        };
        let effect: Effect =
            id.trim().parse().map_err(|e: ema_reference::UnknownEffect| CliError::flag("--effect", e.to_string()))?;
        if seen.contains(&effect) {
            return Err(CliError::flag("--effect", format!("effect '{effect}' given more than once")));
        }
        seen.push(effect);
        let s: f64 = sev
            .trim()
            .parse()
            .map_err(|_| CliError::flag("--effect", format!("{id}: severity '{sev}' is not a number")))?;
        fx.set(effect, s).map_err(|e| CliError::flag("--effect", e.to_string()))?;
    }
    Ok(fx)
}

/// One `ID=S` for both sides of a side-by-side run (the `ema-investigations` programs): the
/// actuator's effect, and the monitor model's term at the same severity when the library has one
/// (none for `compliance` or `bus_sag`); `None` gives neither.
pub fn parse_effect_both_sides(item: Option<&str>) -> Result<(Effects, ModelEffects), CliError> {
    let actuator = match item {
        Some(item) => parse_effects(&[item.to_string()])?,
        None => Effects::NONE,
    };
    let mut model = ModelEffects::NONE;
    for (effect, severity) in actuator.active() {
        if let Some(term) = EffectId::from_id(effect.id()) {
            // the actuator's severity is in [0, 1], inside the model's range
            model.set(term, severity as f32).map_err(|e| CliError::flag("EFFECT", e.to_string()))?;
        }
    }
    Ok((actuator, model))
}

/// `standard`, `pbit` ([`Profile::PBIT`]) or a profile file.
pub fn resolve_profile(name: &str) -> Result<Profile, CliError> {
    match name {
        "standard" => return Ok(Profile::STANDARD),
        "pbit" => return Ok(Profile::PBIT),
        _ => {}
    }
    let path = Path::new(name);
    if !path.exists() {
        return Err(CliError::flag(
            "--profile",
            format!("'{name}' is neither 'standard', 'pbit' nor an existing file"),
        ));
    }
    Ok(read_profile(path)?)
}

/// The simulation configuration the arguments describe.
pub fn config(args: &SimulateArgs) -> Result<SimConfig, CliError> {
    config_for(args, &actuator(args)?)
}

/// The simulation configuration of `actuator` under the other arguments.
fn config_for(args: &SimulateArgs, actuator: &Actuator) -> Result<SimConfig, CliError> {
    let params = actuator.simulated();
    if args.pre_trigger_ms > MAX_PRE_TRIGGER_MS {
        return Err(CliError::flag(
            "--pre-trigger-ms",
            format!("{} ms is longer than {MAX_PRE_TRIGGER_MS} ms", args.pre_trigger_ms),
        ));
    }
    Ok(SimConfig {
        params,
        faults: parse_faults(&args.faults)?,
        effects: parse_effects(&args.effects)?,
        profile: resolve_profile(&args.profile)?,
        noise: args.noise == Noise::On,
        seed: args.seed,
        sensors: resolve_sensors(&args.sensors, ema_reference::params::widen(params.control_period_s))?,
        pre_trigger_s: f64::from(args.pre_trigger_ms) / 1000.0,
        ..SimConfig::default()
    })
}

/// Runs `ema simulate`; returns the one-line summary printed on success.
pub fn run(args: &SimulateArgs) -> Result<String, CliError> {
    let actuator = actuator(args)?;
    let cfg = config_for(args, &actuator)?;
    let overwrite = args.output.overwrite();
    let out = args.output.out.as_deref().ok_or_else(|| CliError::flag("--out", "give the output CSV file"))?;
    let side = sidecar_path(out);
    if side == out {
        return Err(CliError::flag("--out", format!("'{}': give the recording a .csv name", out.display())));
    }
    check_file(out, overwrite)?;
    check_file(&side, overwrite)?;
    let spinner = progress::spinner(format!("simulating {}", out.display()), args.progress.visible());
    let result = simulate(&cfg).map_err(|e| CliError::Simulation(e.to_string()));
    spinner.finish_and_clear();
    let result = result?;
    let mut rec = Recording::from_reference(&result, Vec::new());
    let mut columns = HEADER.map(str::to_owned).to_vec();
    if let Some(t) = actuator.temperature_c {
        rec.temperature_c = Some(vec![t; rec.len()]);
        columns.push(TEMPERATURE_HEADER.to_owned());
    }
    let sidecar = Sidecar {
        schema_version: SCHEMA_VERSION,
        tool_version: env!("CARGO_PKG_VERSION").to_owned(),
        generator: "ema simulate: reference model".to_owned(),
        recording: out.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
        columns,
        sample_rate_hz: ema_monitor::trace::SAMPLE_RATE_HZ,
        rows: rec.len(),
        duration_s: f64::from(cfg.profile.duration_s()),
        faults: cfg.faults.0.to_vec(),
        effects: cfg.effects.active().map(|(e, s)| (e.to_string(), s)).collect(),
        profile: args.profile.clone(),
        params_file: args.params.source(),
        params: ema_monitor::params::FIELDS.iter().map(|f| (f.name.to_owned(), f.get(&actuator.params))).collect(),
        noise: cfg.noise,
        seed: cfg.seed,
        unit: actuator.unit.clone(),
        temperature_c: actuator.temperature_c,
        sensors: Some(SidecarSensors::of(&cfg.sensors, &args.sensors)),
        pre_trigger_s: (result.trigger_index > 0).then_some(cfg.pre_trigger_s),
    };
    write_files(&[(out, &csv_bytes(&rec)), (&side, sidecar.to_json().as_bytes())], overwrite)?;
    let mut what = String::new();
    if let Some(u) = &actuator.unit {
        what.push_str(&format!(" of unit {} ({} tolerances)", u.seed, u.tolerances_file));
    }
    if let Some(t) = actuator.temperature_c {
        what.push_str(&format!(" at {t} °C"));
    }
    if args.sensors != "ideal" {
        what.push_str(&format!(" through the {} sensors", args.sensors));
    }
    if result.trigger_index > 0 {
        what.push_str(&format!(", {} ms at rest before the manoeuvre", args.pre_trigger_ms));
    }
    Ok(format!(
        "wrote {} samples ({} s at {} Hz){what} to {} and its metadata to {}",
        rec.len(),
        cfg.profile.duration_s(),
        ema_monitor::trace::SAMPLE_RATE_HZ,
        out.display(),
        side.display()
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_effect_for_both_sides() {
        let (actuator, model) = parse_effect_both_sides(Some("hall_misalignment=0.8")).unwrap();
        assert_eq!(actuator.get(Effect::HallMisalignment), 0.8);
        assert_eq!(model.get(EffectId::HallMisalignment), 0.8);
        // outside the library: the actuator has it, the model has no term for it
        let (actuator, model) = parse_effect_both_sides(Some("bus_sag=1")).unwrap();
        assert_eq!(actuator.get(Effect::BusSag), 1.0);
        assert!(model.is_none());
        assert_eq!(parse_effect_both_sides(None).unwrap(), (Effects::NONE, ModelEffects::NONE));
        for bad in ["hall=1", "cogging", "cogging=x", "cogging=1.1"] {
            assert!(parse_effect_both_sides(Some(bad)).is_err(), "{bad}");
        }
    }

    #[test]
    fn faults_and_effects_parse() {
        assert_eq!(parse_faults("0,0,0,0,0,0,0.5,0.5").ok(), Some(FaultVector::HEALTHY));
        for (bad, msg) in [
            ("0,0,0", "need 8"),
            ("0,0,0,0,0,0,0.5,1.5", "k8 = 1.5 is outside"),
            ("0,0,0,0,0,0,0.5,NaN", "k8 = NaN is outside"),
            ("0,0,x,0,0,0,0.5,0.5", "k3 = 'x' is not a number"),
            ("-0.1,0,0,0,0,0,0.5,0.5", "k1 = -0.1 is outside"),
        ] {
            let e = parse_faults(bad).expect_err(bad).to_string();
            assert!(e.contains(msg) && e.starts_with("--faults"), "{e}");
        }
        let fx = parse_effects(&["cogging=0.5".into(), "bus_sag=1".into()]).expect("valid");
        assert_eq!(fx.get(Effect::Cogging), 0.5);
        for (bad, msg) in [
            (vec!["cog=0.5"], "unknown effect 'cog'"),
            (vec!["cogging=1.5"], "outside [0, 1]"),
            (vec!["cogging=NaN"], "outside [0, 1]"),
            (vec!["cogging"], "not ID=S"),
            (vec!["cogging=0.1", "cogging=0.2"], "more than once"),
        ] {
            let list: Vec<String> = bad.iter().map(|s| s.to_string()).collect();
            let e = parse_effects(&list).expect_err("refused").to_string();
            assert!(e.contains(msg), "{e}");
        }
    }
}
