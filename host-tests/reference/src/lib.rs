//! # ema-reference: the high-fidelity reference model (RM) of the EMA
//!
//! The RM plays the real actuator on the host, in `f64`: its recordings stand in for flight data
//! when the on-board monitor (`ema-monitor`, whose light single-phase *monitor model* runs in `f32`)
//! is tested. Its equations are in `docs/model.md`; it takes every shared definition from the
//! `ema-monitor` crate: the nominal table [`ema_monitor::EmaParams::NOMINAL`], the one fault mapping
//! [`ema_monitor::FaultVector::physical`], the command [`ema_monitor::Profile::command_rad`] (an `f32`
//! digital signal) and the 12-bit current ADC format [`ema_monitor::trace`].
//!
//! ```text
//! θ_cmd(t_k) ─► ACE (PID, 10 kHz, ZOH) ─► I_ref ─► 120° Hall commutation ─► hysteresis comparators
//!   ▲                                                   ─► inverter (6 switches + diodes, open phases)
//!   │                                                   ─► star windings R_j, L_j, e_j = k_j f_j ω (isolated neutral)
//!   │                                                   ─► T_m = Σ k_j f_j i_j ─► Borello friction, gear N, backlash,
//!   │                                                      hinge load K_h θ_u, end stops ─► θ_u
//!   └── position transducer (lag, noise, 16 bit) ◄───────────────────────────────────────────┘
//! recorded at t_k = k·T (10 kHz): time_s, command_rad, position_rad, i_a, i_b, i_c (the sensor chain: zero and
//! gain errors, 20 kHz lag, skew, noise, 12-bit ADC; ideal by default)
//! ```
//!
//! Use: [`simulate`]`(&`[`SimConfig`]`) -> Result<`[`Recording`]`, `[`ConfigError`]`>`; or step a
//! [`Simulator`] by hand (`sample`, `advance_period`, `step`) to inspect the state at every step.
//!
//! ## Numerics
//! Fixed step `dt` = 0.25 µs ([`DEFAULT_STEP_S`]), explicit Euler on the currents, semi-implicit
//! Euler on the mechanics, 400 steps per ACE period. `tests/convergence.rs` holds the choice to
//! the finest run (dt = 1, 0.5 and 0.25 µs against 0.05 µs; why 0.25 µs:
//! `docs/decisions/0004-reference-step.md`). Currents sum to zero after every step
//! (isolated-neutral formula weighted by `1/L_j`; a diode current clamped at zero gives its
//! residue back with the same weights).
//!
//! ## Modelling choices (where docs/model.md leaves a choice)
//! * Backlash: the kinematic play operator by default ([`BacklashModel::Play`], as the monitor model);
//!   [`BacklashModel::FreeSurface`] gives the surface its own inertia inside the gap (stiff, heavily
//!   damped contact). The `compliance` effect always uses the 2-DOF dead-zone spring.
//! * Rigid transmission: the hinge load is reflected to the motor even inside the gap (as in the
//!   monitor model); the energy ledger shows the (small) consequence.
//! * Hysteresis comparators see the sensor error of the `sensor_offset` effect (the drive regulates
//!   the measured current) but not the recording's sensor chain ([`SensorChain`]: its zero and gain
//!   errors, lag, conversion instants, noise and ADC act on the recorded currents only).
//! * Parameters: the `f32` table is widened to the `f64` of its shortest decimal form
//!   ([`params::widen`]: `0.13f32` → `0.13`).
//! * Time base: `t_k = k·T` with `T` = 100 µs (written `k/10000` so the CSV holds exact decimals);
//!   the command is `profile.command_rad(k as f32 * T_f32)`: the monitor's `f32` clock, bit for bit.
//!
//! ## Effects (all off by default; severity `s ∈ [0, 1]`, linear in `s` unless stated)
//!
//! | ID | physics | `s = 1` (maximum) | signature (docs/model.md) |
//! |----|---------|-------------------|-----------|
//! | `cogging` | `T_cog = A·sin(24·θ_m)` added to the motor torque | `A` = 0.04 N·m (≈1 % of 3.9 N·m) | 24/rev ripple, present at zero current |
//! | `stribeck` | breakaway `FSJ(1+s)`, sliding `FDJ + s(2FSJ − FDJ)·e^{−(ω/ω_s)²}`, `ω_s` = 5 rad/s | stiction 2×FSJ | current spikes at breakaway, stick-slip |
//! | `viscous` | `C_m + s·ΔC` | `ΔC` = 5e-4 N·m·s/rad (6× nominal) | current ∝ ω, breakaway unchanged |
//! | `winding_temperature` | `ΔT = 100 K·s`: `R×(1+3.93e-3ΔT)`, `k×(1−1.1e-3ΔT)` | +100 K: R +39 %, k −11 % | symmetric current rise ∝ I, voltage-limit change |
//! | `emf_harmonics` | back-EMF flat top `120° − 40°·s` (ramps widen) | 80° flat top | 6θ_e torque ripple ∝ I, lower mean Kt |
//! | `dead_time` | `−sign(i_j)·ΔV` on each conducting phase | ΔV = 8 V | lower top speed, zero-crossing distortion |
//! | `sensor_offset` | `i_meas = (1+g_j)i_j + o_j` (recorded and seen by the comparators) | o = (0.2, −0.1, 0.15) A, g = (+2, −2, +1) % | 1×θ_e / 2×θ_e ripple, Σi_meas ≠ 0 |
//! | `hinge_stiffness` | `K_h×(1+s)` | 2× K_h | holding current ∝ θ_u |
//! | `saturation` | `k_j×1/(1+(I/I_sat)²)`, `I = ½Σ|i_j|`, `I_sat = 30 A/s` | −20 % torque at 15 A | super-linear current at high load only |
//! | `hall_misalignment` | `δ_H = 10°·s` added to `θ_e` in the Hall logic | 10° electrical | direction-dependent top speed, 6θ_e ripple |
//! | `compliance` | 2-DOF dead-zone spring, mode `f_r = 50 Hz/s` (ζ = 0.2); `s < 0.0025` rigid | 50 Hz mode | ringing at f_r after steps and reversals |
//! | `bus_sag` | `V_dc,eff = V_dc − R_bus·Ī_dc`, `R_bus = 3 Ω·s`, `Ī_dc` low-passed 1 ms | 3 Ω | speed ceiling falls with load current |
//!
//! The same table is in `host-tests/reference/README.md`; the numbers live in [`effects::maxima`].
#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod ace;
pub mod analysis;
pub mod effects;
pub mod electrical;
pub mod mechanics;
pub mod params;
pub mod rng;
pub mod sensors;
pub mod sim;

pub use effects::{Effect, Effects, UnknownEffect, EFFECT_COUNT};
pub use params::{BacklashModel, Plant};
pub use sensors::{CurrentAdc, PhaseSensor, SensorChain, SensorChainError};
pub use sim::{
    simulate, ConfigError, EnergyLedger, Recording, Sample, SimConfig, Simulator, Truth, DEFAULT_STEP_S,
    MAX_DURATION_S, MAX_PRE_TRIGGER_S, MAX_SAMPLES,
};
