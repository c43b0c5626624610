//! The simulation loop: configuration, fixed-step integration, sampling and the recording.
//!
//! Order of operations (docs/model.md). At every ACE instant `t_k = k·T` the sensors are sampled
//! (noise, quantization), the PID computes `I_ref` (held until `t_{k+1}`) and the sample is recorded.
//! Then `T/dt` integration steps follow, each: `θ_e, f_j, k_j, e_j` → Hall sector → inverter and
//! currents → `T_m` → friction and mechanics → sensor lags. A phase current the
//! [`SensorChain`] converts after the frame instant (a skew) is taken during the steps that follow
//! it ([`CurrentSensing`]).
//!
//! **Pre-trigger** ([`SimConfig::pre_trigger_s`]): the recording may open with the actuator at
//! rest before the manoeuvre, as a bench logs before its trigger. Those samples carry the
//! profile's opening command; the drive is off (every switch open, zero current, the ACE not yet
//! running), the mechanism stands still at zero, and only the sensors run: the position reads its
//! noise, the currents their chain's zero errors and noise. Their noise comes from a generator of
//! its own (seeded from [`SimConfig::seed`] and [`PRE_TRIGGER_STREAM`]), so the manoeuvre that
//! follows draws the same noise as without a pre-trigger, and since the current sensors rest at
//! their zero errors either way, its samples are those of the run without one, bit for bit, `N`
//! samples later (except with the `sensor_offset` effect, whose drive-sensor error has then settled
//! through the lags before the manoeuvre instead of entering them at its start).

use core::f64::consts::{PI, TAU};
use core::fmt;

use ema_monitor::{EmaParams, FaultVector, Profile};

use crate::ace::Ace;
use crate::effects::{maxima, Effects};
use crate::electrical::{emf_shapes, hall_sector, ElectricalInputs, Inverter};
use crate::mechanics::{FrictionLaw, MechanicalInputs, Mechanics};
use crate::params::{BacklashModel, Plant};
use crate::rng::NoiseRng;
use crate::sensors::{self, CurrentSensing, Lag, SensorChain, SensorChainError};

/// Default integration step, chosen by the convergence study kept in `tests/convergence.rs`.
pub const DEFAULT_STEP_S: f64 = 2.5e-7;

/// Longest profile the reference model simulates: 60 s (about 45 s of computation).
/// [`Simulator::new`] refuses a longer one with [`ConfigError::Duration`] before anything is
/// allocated, so a profile's duration never sizes an allocation beyond [`MAX_SAMPLES`].
pub const MAX_DURATION_S: f64 = 60.0;

/// Most samples of one simulation: [`MAX_DURATION_S`] at the nominal 10 kHz (about 80 MB of
/// samples and truth). Also refused with [`ConfigError::Duration`]: a profile within
/// [`MAX_DURATION_S`] under a control period shorter than the nominal one.
pub const MAX_SAMPLES: usize = 600_000;

/// Longest pre-trigger, s ([`SimConfig::pre_trigger_s`]); the pre-trigger and the profile
/// together stay within [`MAX_DURATION_S`].
pub const MAX_PRE_TRIGGER_S: f64 = 10.0;

/// Mixed into [`SimConfig::seed`] to seed the pre-trigger's own noise generator.
pub const PRE_TRIGGER_STREAM: u64 = 0x5052_4554_5249_4747; // "PRETRIGG"

/// What to simulate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimConfig {
    /// Nominal actuator (the shared `f32` table, widened to `f64`).
    pub params: EmaParams,
    /// Normalized fault vector, mapped by [`FaultVector::physical`].
    pub faults: FaultVector,
    /// Unmodelled effects (all off by default).
    pub effects: Effects,
    /// Command profile; the simulation lasts `profile.duration_s()`.
    pub profile: Profile,
    /// Sensor noise on (lags and quantization stay when off).
    pub noise: bool,
    /// Seed of the noise generator.
    pub seed: u64,
    /// Quantization of the position (16 bit) and current (12 bit) samples; turning it off (numerical
    /// studies only) records the lagged, noisy values unquantized (the ADC codes are still filled in).
    pub quantization: bool,
    /// Integration step; `T/step_s` is rounded to an integer number of steps per ACE period.
    pub step_s: f64,
    /// Backlash model of the rigid transmission.
    pub backlash_model: BacklashModel,
    /// The phase-current measurement chain ([`SensorChain::IDEAL`] by default).
    pub sensors: SensorChain,
    /// Time at rest recorded before the manoeuvre, s (0 by default; rounded to whole control
    /// periods, at most [`MAX_PRE_TRIGGER_S`]; the module documentation says what it holds).
    pub pre_trigger_s: f64,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            params: EmaParams::NOMINAL,
            faults: FaultVector::HEALTHY,
            effects: Effects::NONE,
            profile: Profile::STANDARD,
            noise: true,
            seed: 1,
            quantization: true,
            step_s: DEFAULT_STEP_S,
            backlash_model: BacklashModel::Play,
            sensors: SensorChain::IDEAL,
            pre_trigger_s: 0.0,
        }
    }
}

/// Why a configuration was refused.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum ConfigError {
    /// A fault is NaN or outside `[0, 1]`.
    Faults,
    /// An effect severity is outside `[0, 1]`.
    Effects,
    /// The step does not divide the ACE period into a whole number of steps, or is not positive.
    Step(f64),
    /// A parameter that must be positive and finite is not.
    Parameter(&'static str),
    /// The profile lasts longer than [`MAX_DURATION_S`] or needs more than [`MAX_SAMPLES`]
    /// samples (its duration, s).
    Duration(f64),
    /// The pre-trigger is negative, not finite or longer than [`MAX_PRE_TRIGGER_S`] (s).
    PreTrigger(f64),
    /// The sensor chain has a value outside its range.
    Sensors(SensorChainError),
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ConfigError::Faults => f.write_str("every fault k1..k8 must be a number in [0, 1]"),
            ConfigError::Effects => f.write_str("every effect severity must be in [0, 1]"),
            ConfigError::Step(dt) => {
                write!(f, "integration step {dt} s must be positive and divide the ACE period into whole steps")
            }
            ConfigError::Parameter(name) => write!(f, "parameter {name} must be positive and finite"),
            ConfigError::Duration(d) => write!(
                f,
                "profile duration {d} s is beyond the reference model's limit ({MAX_DURATION_S} s, {MAX_SAMPLES} samples)"
            ),
            ConfigError::PreTrigger(s) => write!(f, "pre-trigger {s} s must be between 0 and {MAX_PRE_TRIGGER_S} s"),
            ConfigError::Sensors(e) => write!(f, "sensor chain: {e}"),
        }
    }
}

impl std::error::Error for ConfigError {}

/// One recorded sample at an ACE instant: what the sensors deliver.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// `t_k = k·T` (pre-trigger samples included: the manoeuvre starts at the first sample after
    /// them).
    pub time_s: f64,
    /// `θ_cmd(t_k)` (the `f32` profile value, widened; the profile's opening value before the
    /// trigger).
    pub command_rad: f64,
    /// Measured surface position (lag, noise, 16-bit code).
    pub position_rad: f64,
    /// Measured phase currents `a, b, c`, each taken at `t_k` plus its skew: the chain's ADC
    /// codes back in amperes (`counts_to_amps` of them for the 12-bit ±20 A ADC).
    pub phase_current_a: [f64; 3],
    /// Raw codes of the chain's ADC (12 bits for the ideal chain and the presets).
    pub adc_counts: [u16; 3],
}

/// Truth channels at the same instant (for tests and analysis; not recorded to CSV).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Truth {
    /// Current reference computed by the ACE at this instant.
    pub current_ref_a: f64,
    /// Motor angle `θ_m`.
    pub motor_angle_rad: f64,
    /// Motor speed `ω_m`.
    pub motor_speed_rad_per_s: f64,
    /// Electrical angle `θ_e = p·θ_m` wrapped to `[0, 2π)`.
    pub electrical_angle_rad: f64,
    /// True surface angle `θ_u`.
    pub surface_angle_rad: f64,
    /// Surface speed `ω_u`.
    pub surface_speed_rad_per_s: f64,
    /// Hall sector seen by the commutation logic.
    pub hall_sector: u8,
    /// True phase currents.
    pub phase_current_a: [f64; 3],
    /// Electromagnetic torque `T_m = Σ k_j f_j i_j` at this instant.
    pub motor_torque_n_m: f64,
    /// Equivalent current, torque-projection form `I_3eq = ½·Σ f_j(θ_e)·i_j` (ideal 120° shapes).
    pub equivalent_current_a: f64,
    /// Mean electrical power into the windings over the preceding ACE period (0 at `k = 0`).
    pub electrical_power_w: f64,
    /// Mean of the torque-projection equivalent current over the preceding ACE period (every
    /// integration step, so free of the aliasing of the 10 kHz samples; 0 at `k = 0`).
    pub mean_equivalent_current_a: f64,
    /// Mean motor torque over the preceding ACE period (0 at `k = 0`).
    pub mean_motor_torque_n_m: f64,
    /// DC-link voltage at the inverter.
    pub bus_voltage_v: f64,
}

/// Energy ledger over the whole run (joules); see [`EnergyLedger::residual_j`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EnergyLedger {
    /// Electrical energy delivered into the windings `∫Σ(v_j0 − v_n0)·i_j dt`.
    pub electrical_in_j: f64,
    /// Copper loss `∫Σ R_j i_j² dt`.
    pub copper_loss_j: f64,
    /// Electrical → mechanical conversion `∫Σ e_j i_j dt`.
    pub conversion_j: f64,
    /// Mechanical work of the motor torque `∫T_m ω_m dt`.
    pub motor_work_j: f64,
    /// Work of the cogging torque (conservative).
    pub cogging_work_j: f64,
    /// Viscous loss.
    pub viscous_loss_j: f64,
    /// Dry-friction loss (load-dependent term included).
    pub friction_loss_j: f64,
    /// Mechanical output: work delivered to the hinge load (see [`crate::mechanics::MechanicalEnergy::load_work_j`]).
    pub load_work_j: f64,
    /// Kinetic energy destroyed at the end stops.
    pub end_stop_loss_j: f64,
    /// Transmission damping loss (compliant model).
    pub transmission_loss_j: f64,
    /// Change of the magnetic energy `½ΣL_j i_j²`.
    pub magnetic_change_j: f64,
    /// Change of the kinetic energy.
    pub kinetic_change_j: f64,
    /// Change of the hinge spring energy `½K_h θ_u²` (equals `load_work_j` but for the play operator's
    /// load work inside the gap).
    pub hinge_change_j: f64,
    /// Change of the transmission spring energy.
    pub transmission_spring_change_j: f64,
}

impl EnergyLedger {
    /// `E_in + W_cog − (W_load + losses + stored-energy changes)`: zero for an exact energy balance.
    /// ```text
    /// E_in = W_load + E_cu + E_visc + E_fric + E_stop + E_tr + ΔE_mag + ΔE_kin + ΔE_tr,spring − W_cog
    /// ```
    /// (the cogging torque is conservative: its work is minus its potential change).
    pub fn residual_j(&self) -> f64 {
        self.electrical_in_j + self.cogging_work_j
            - (self.load_work_j
                + self.copper_loss_j
                + self.viscous_loss_j
                + self.friction_loss_j
                + self.end_stop_loss_j
                + self.transmission_loss_j
                + self.magnetic_change_j
                + self.kinetic_change_j
                + self.transmission_spring_change_j)
    }
}

/// The output of a simulation: samples at 10 kHz, truth at the same instants, energy ledger.
#[derive(Clone, Debug, PartialEq)]
pub struct Recording {
    /// Sensor samples.
    pub samples: Vec<Sample>,
    /// Truth at the same instants.
    pub truth: Vec<Truth>,
    /// Energy ledger from `t_0` to the last sample (to its last conversion under a skewed chain).
    pub energy: EnergyLedger,
    /// Samples before the manoeuvre's first, at rest ([`SimConfig::pre_trigger_s`]).
    pub trigger_index: usize,
    /// ACE / sample period `T`.
    pub sample_period_s: f64,
    /// Integration step actually used.
    pub step_s: f64,
}

/// The reference model, stepped explicitly (use [`simulate`] for a whole profile).
#[derive(Clone, Debug)]
pub struct Simulator {
    plant: Plant,
    friction: FrictionLaw,
    profile: Profile,
    dt: f64,
    period: f64,
    period_f32: f32,
    /// Phase-current sensor noise σ (`EmaParams::current_noise_a`).
    current_noise_a: f64,
    /// Position transducer noise σ (`EmaParams::position_noise_rad`).
    position_noise_rad: f64,
    steps_per_sample: u32,
    inverter: Inverter,
    mech: Mechanics,
    ace: Ace,
    current_ref_a: f64,
    position_lag: Lag,
    currents: CurrentSensing,
    bus_current: Lag,
    rng: Option<NoiseRng>,
    /// The pre-trigger's noise generator.
    rest_rng: Option<NoiseRng>,
    /// Samples before the manoeuvre's first.
    pre_trigger_samples: u64,
    /// The period being integrated is before the manoeuvre: the drive is off.
    resting: bool,
    /// Steps of the current period already integrated by [`Simulator::sample`] (under a skew).
    steps_done: u32,
    quantization: bool,
    /// Code grid of the position transducer (`EmaParams::position_resolution_rad` over the travel).
    position_grid: sensors::PositionGrid,
    sample_index: u64,
    ledger: EnergyLedger,
    interval_energy_j: f64,
    interval_current_a: f64,
    interval_torque_n_m: f64,
    motor_torque_n_m: f64,
    supply_v: f64,
}

impl Simulator {
    /// A simulator at rest at `t = 0`.
    pub fn new(cfg: &SimConfig) -> Result<Self, ConfigError> {
        if !cfg.faults.is_valid() {
            return Err(ConfigError::Faults);
        }
        if !cfg.effects.is_valid() {
            return Err(ConfigError::Effects);
        }
        check_params(&cfg.params)?;
        let period = crate::params::widen(cfg.params.control_period_s);
        let duration = crate::params::widen(cfg.profile.duration_s());
        let pre = cfg.pre_trigger_s;
        if !(pre.is_finite() && (0.0..=MAX_PRE_TRIGGER_S).contains(&pre)) {
            return Err(ConfigError::PreTrigger(pre));
        }
        let pre_samples = (pre / period).round();
        let samples = (duration / period).round() + pre_samples;
        if !(duration > 0.0 && duration + pre <= MAX_DURATION_S && samples <= MAX_SAMPLES as f64) {
            return Err(ConfigError::Duration(duration + pre));
        }
        cfg.sensors.check(period).map_err(ConfigError::Sensors)?;
        if !(cfg.step_s.is_finite() && cfg.step_s > 0.0 && cfg.step_s <= period) {
            return Err(ConfigError::Step(cfg.step_s));
        }
        let ratio = period / cfg.step_s;
        let steps = ratio.round();
        if (ratio - steps).abs() > 1e-6 * ratio || steps > f64::from(u32::MAX) {
            return Err(ConfigError::Step(cfg.step_s));
        }
        let dt = period / steps;
        let plant = Plant::new(&cfg.params, &cfg.faults, &cfg.effects, cfg.backlash_model);
        Ok(Self {
            friction: FrictionLaw::of(&plant),
            ace: Ace::new(
                plant.kp_a_per_rad,
                plant.ki_a_per_rad_s,
                plant.kd_a_s_per_rad,
                period,
                plant.derivative_filter_s,
                plant.current_limit_a,
            ),
            plant,
            profile: cfg.profile,
            dt,
            period,
            period_f32: cfg.params.control_period_s,
            current_noise_a: crate::params::widen(cfg.params.current_noise_a),
            position_noise_rad: crate::params::widen(cfg.params.position_noise_rad),
            steps_per_sample: steps as u32,
            inverter: Inverter::new(),
            mech: Mechanics::new(),
            current_ref_a: 0.0,
            position_lag: Lag::new(crate::params::widen(cfg.params.position_lag_s), dt),
            currents: CurrentSensing::new(
                &cfg.sensors,
                plant.current_sensor_offset_a,
                plant.current_sensor_gain_error,
                dt,
            ),
            bus_current: Lag::new(maxima::BUS_FILTER_S, dt),
            rng: cfg.noise.then(|| NoiseRng::new(cfg.seed)),
            rest_rng: cfg.noise.then(|| NoiseRng::new(cfg.seed ^ PRE_TRIGGER_STREAM)),
            pre_trigger_samples: pre_samples as u64,
            resting: pre_samples > 0.0,
            steps_done: 0,
            quantization: cfg.quantization,
            position_grid: sensors::PositionGrid::of(
                crate::params::widen(cfg.params.position_resolution_rad),
                crate::params::widen(cfg.params.end_stop_rad),
            ),
            sample_index: 0,
            ledger: EnergyLedger::default(),
            interval_energy_j: 0.0,
            interval_current_a: 0.0,
            interval_torque_n_m: 0.0,
            motor_torque_n_m: 0.0,
            supply_v: plant.supply_voltage_v,
        })
    }

    /// Parameters after faults and effects.
    pub fn plant(&self) -> &Plant {
        &self.plant
    }

    /// Inverter and winding state.
    pub fn inverter(&self) -> &Inverter {
        &self.inverter
    }

    /// Mechanical state.
    pub fn mechanics(&self) -> &Mechanics {
        &self.mech
    }

    /// Integration step in use.
    pub fn step_s(&self) -> f64 {
        self.dt
    }

    /// Steps per ACE period.
    pub fn steps_per_sample(&self) -> u32 {
        self.steps_per_sample
    }

    /// Energy ledger so far.
    pub fn ledger(&self) -> &EnergyLedger {
        &self.ledger
    }

    /// Number of samples: the pre-trigger's and the profile's `round(duration/T)`, instants
    /// `t_k = k·T`, `k = 0..n`.
    pub fn sample_count(&self) -> usize {
        self.pre_trigger_samples as usize
            + (crate::params::widen(self.profile.duration_s()) / self.period).round() as usize
    }

    /// Samples before the manoeuvre's first.
    pub fn trigger_index(&self) -> usize {
        self.pre_trigger_samples as usize
    }

    /// Samples the sensors at the current ACE instant, runs the ACE and returns the record.
    /// Call once per ACE period, before [`Simulator::advance_period`]. Under a chain with skew
    /// it also integrates the period's first steps, up to its last conversion; `advance_period`
    /// integrates the rest.
    pub fn sample(&mut self) -> (Sample, Truth) {
        let k = self.sample_index;
        self.resting = k < self.pre_trigger_samples;
        // the manoeuvre's sample index (0 at the trigger)
        let m = k.saturating_sub(self.pre_trigger_samples);
        // t_k = k·T, computed as k/f_s when the rate is a whole number of hertz (exact decimals in files).
        let rate = 1.0 / self.period;
        let time_s =
            if (rate - rate.round()).abs() < 1e-9 * rate { k as f64 / rate.round() } else { k as f64 * self.period };
        let (current_noise_a, position_noise_rad) = (self.current_noise_a, self.position_noise_rad);
        let rng = if self.resting { self.rest_rng.as_mut() } else { self.rng.as_mut() };
        let (pos_noise, cur_noise) = match rng {
            Some(r) => (
                position_noise_rad * r.gaussian(),
                [r.gaussian(), r.gaussian(), r.gaussian()].map(|z| current_noise_a * z),
            ),
            None => (0.0, [0.0; 3]),
        };
        let raw_position = self.position_lag.value + pos_noise;
        let position_rad = if self.quantization { self.position_grid.quantize(raw_position) } else { raw_position };
        self.currents.start_frame(cur_noise);
        // The command is a digital f32 signal on the f32 clock of the monitor: m as f32 · T_f32
        // (before the trigger, the profile's opening value, and the ACE does not run).
        let command_rad = f64::from(self.profile.command_rad(m as f32 * self.period_f32));
        if !self.resting {
            self.current_ref_a = self.ace.update(command_rad, position_rad);
        }
        let first = self.resting || m == 0;

        let p = &self.plant;
        let theta_e = (p.pole_pairs * self.mech.motor_angle_rad).rem_euclid(TAU);
        let f = emf_shapes(theta_e, PI / 6.0);
        let i = self.inverter.current_a;
        let n_steps = f64::from(self.steps_per_sample);
        let truth = Truth {
            current_ref_a: self.current_ref_a,
            motor_angle_rad: self.mech.motor_angle_rad,
            motor_speed_rad_per_s: self.mech.motor_speed_rad_per_s,
            electrical_angle_rad: theta_e,
            surface_angle_rad: self.mech.surface_angle_rad,
            surface_speed_rad_per_s: self.mech.surface_speed_rad_per_s,
            hall_sector: hall_sector(theta_e + p.hall_offset_rad),
            phase_current_a: i,
            motor_torque_n_m: self.motor_torque_n_m,
            equivalent_current_a: 0.5 * (f[0] * i[0] + f[1] * i[1] + f[2] * i[2]),
            electrical_power_w: if first { 0.0 } else { self.interval_energy_j / self.period },
            mean_equivalent_current_a: if first { 0.0 } else { self.interval_current_a / n_steps },
            mean_motor_torque_n_m: if first { 0.0 } else { self.interval_torque_n_m / n_steps },
            bus_voltage_v: self.supply_v,
        };
        self.interval_energy_j = 0.0;
        self.interval_current_a = 0.0;
        self.interval_torque_n_m = 0.0;
        self.sample_index += 1;
        // the conversions after the frame instant
        self.steps_done = 0;
        while !self.currents.frame_complete() && self.steps_done < self.steps_per_sample {
            self.step();
            self.steps_done += 1;
        }
        let (adc_counts, phase_current_a) = self.currents.frame(self.quantization);
        (Sample { time_s, command_rad, position_rad, phase_current_a, adc_counts }, truth)
    }

    /// Runs the integration steps of one ACE period: after [`Simulator::sample`], those it has not.
    pub fn advance_period(&mut self) {
        for _ in self.steps_done..self.steps_per_sample {
            self.step();
        }
        self.steps_done = 0;
    }

    /// One integration step `dt` with the held current reference; before the trigger, only the
    /// sensors run (the drive is off, the mechanism at rest).
    pub fn step(&mut self) {
        if self.resting {
            self.position_lag.update(self.mech.surface_angle_rad);
            self.currents.update(self.inverter.current_a);
            return;
        }
        let p = &self.plant;
        let dt = self.dt;
        let theta_m = self.mech.motor_angle_rad;
        let omega = self.mech.motor_speed_rad_per_s;
        let theta_e = p.pole_pairs * theta_m;
        let f = emf_shapes(theta_e, p.emf_ramp_width_rad);
        let mut k = p.phase_emf_constant_v_s_per_rad;
        if p.eccentricity > 0.0 {
            for (j, kj) in k.iter_mut().enumerate() {
                let psi = j as f64 * TAU / 3.0;
                *kj *= 1.0 + p.eccentricity * (theta_m - p.eccentricity_phase_rad - psi).cos();
            }
        }
        if p.saturation_current_a.is_finite() {
            let i = self.inverter.current_a;
            let r = 0.5 * (i[0].abs() + i[1].abs() + i[2].abs()) / p.saturation_current_a;
            let s = 1.0 / (1.0 + r * r);
            k = k.map(|kj| kj * s);
        }
        let emf_v = [k[0] * f[0] * omega, k[1] * f[1] * omega, k[2] * f[2] * omega];
        self.supply_v = if p.bus_resistance_ohm > 0.0 {
            p.supply_voltage_v - p.bus_resistance_ohm * self.bus_current.value
        } else {
            p.supply_voltage_v
        };
        let inputs = ElectricalInputs {
            sector: hall_sector(theta_e + p.hall_offset_rad),
            current_ref_a: self.current_ref_a,
            emf_v,
            supply_v: self.supply_v,
            resistance_ohm: p.phase_resistance_ohm,
            inductance_h: p.phase_inductance_h,
            half_band_a: p.hysteresis_half_band_a,
            dead_time_v: p.dead_time_v,
            sensor_offset_a: p.current_sensor_offset_a,
            sensor_gain_error: p.current_sensor_gain_error,
        };
        let ee = self.inverter.step(&inputs, dt);
        let i = self.inverter.current_a;
        let torque = k[0] * f[0] * i[0] + k[1] * f[1] * i[1] + k[2] * f[2] * i[2];
        self.motor_torque_n_m = torque;
        let cogging = if p.cogging_torque_n_m > 0.0 {
            p.cogging_torque_n_m * (maxima::COGGING_CYCLES_PER_REV * theta_m).sin()
        } else {
            0.0
        };
        let kin0 = self.mech.kinetic_energy_j(p);
        let hinge0 = self.mech.hinge_energy_j(p);
        let spring0 = self.mech.transmission_energy_j(p);
        let me = self.mech.step(
            p,
            &self.friction,
            &MechanicalInputs { motor_torque_n_m: torque, cogging_torque_n_m: cogging },
            dt,
        );
        let l = &mut self.ledger;
        l.electrical_in_j += ee.terminal_j;
        l.copper_loss_j += ee.copper_j;
        l.conversion_j += ee.conversion_j;
        l.magnetic_change_j += ee.magnetic_change_j;
        l.motor_work_j += me.motor_work_j;
        l.cogging_work_j += me.cogging_work_j;
        l.viscous_loss_j += me.viscous_loss_j;
        l.friction_loss_j += me.friction_loss_j;
        l.load_work_j += me.load_work_j;
        l.end_stop_loss_j += me.end_stop_loss_j;
        l.transmission_loss_j += me.transmission_loss_j;
        l.kinetic_change_j += self.mech.kinetic_energy_j(p) - kin0;
        l.hinge_change_j += self.mech.hinge_energy_j(p) - hinge0;
        l.transmission_spring_change_j += self.mech.transmission_energy_j(p) - spring0;
        self.interval_energy_j += ee.terminal_j;
        self.interval_torque_n_m += torque;
        self.interval_current_a += if p.emf_ramp_width_rad == PI / 6.0 {
            0.5 * (f[0] * i[0] + f[1] * i[1] + f[2] * i[2])
        } else {
            crate::analysis::equivalent_current_projection(theta_e, i)
        };

        self.position_lag.update(self.mech.surface_angle_rad);
        self.currents.update(i);
        if p.bus_resistance_ohm > 0.0 {
            let i_dc = self.inverter.dc_current_a(self.supply_v);
            self.bus_current.update(i_dc);
        }
    }
}

fn check_params(p: &EmaParams) -> Result<(), ConfigError> {
    let positive: [(&'static str, f32); 12] = [
        ("pole_pairs", p.pole_pairs),
        ("phase_resistance_ohm", p.phase_resistance_ohm),
        ("phase_inductance_h", p.phase_inductance_h),
        ("current_limit_a", p.current_limit_a),
        ("hysteresis_half_band_a", p.hysteresis_half_band_a),
        ("motor_inertia_kg_m2", p.motor_inertia_kg_m2),
        ("gear_ratio", p.gear_ratio),
        ("surface_inertia_kg_m2", p.surface_inertia_kg_m2),
        ("efficiency_opposing", p.efficiency_opposing),
        ("end_stop_rad", p.end_stop_rad),
        ("control_period_s", p.control_period_s),
        ("derivative_filter_s", p.derivative_filter_s),
    ];
    for (name, v) in positive {
        if !(v.is_finite() && v > 0.0) {
            return Err(ConfigError::Parameter(name));
        }
    }
    let non_negative: [(&'static str, f32); 9] = [
        ("supply_voltage_v", p.supply_voltage_v),
        ("phase_emf_constant_v_s_per_rad", p.phase_emf_constant_v_s_per_rad),
        ("viscous_friction_n_m_s_per_rad", p.viscous_friction_n_m_s_per_rad),
        ("static_friction_n_m", p.static_friction_n_m),
        ("dynamic_friction_n_m", p.dynamic_friction_n_m),
        ("nominal_backlash_rad", p.nominal_backlash_rad),
        ("hinge_stiffness_n_m_per_rad", p.hinge_stiffness_n_m_per_rad),
        ("kp_a_per_rad", p.kp_a_per_rad),
        ("ki_a_per_rad_s", p.ki_a_per_rad_s),
    ];
    for (name, v) in non_negative {
        if !(v.is_finite() && v >= 0.0) {
            return Err(ConfigError::Parameter(name));
        }
    }
    if !(p.kd_a_s_per_rad.is_finite() && p.kd_a_s_per_rad >= 0.0) {
        return Err(ConfigError::Parameter("kd_a_s_per_rad"));
    }
    if !(p.efficiency_opposing <= 1.0 && p.efficiency_aiding.is_finite() && p.efficiency_aiding <= 1.0) {
        return Err(ConfigError::Parameter("efficiency_opposing / efficiency_aiding (must be ≤ 1)"));
    }
    Ok(())
}

/// Simulates the pre-trigger and the whole profile: `n` samples at `t_k = k·T`
/// ([`Simulator::sample_count`]).
pub fn simulate(cfg: &SimConfig) -> Result<Recording, ConfigError> {
    let mut sim = Simulator::new(cfg)?;
    let n = sim.sample_count();
    let mut samples = Vec::with_capacity(n);
    let mut truth = Vec::with_capacity(n);
    for k in 0..n {
        let (s, t) = sim.sample();
        samples.push(s);
        truth.push(t);
        if k + 1 < n {
            sim.advance_period();
        }
    }
    Ok(Recording {
        samples,
        truth,
        energy: sim.ledger,
        trigger_index: sim.trigger_index(),
        sample_period_s: sim.period,
        step_s: sim.dt,
    })
}
