//! # ema-monitor: on-board fault identification for flight-control electromechanical actuators
//!
//! An EMA (three-phase trapezoidal BLDC motor, gearbox, PID position loop) degrades slowly: dry
//! friction and backlash grow, stator coils partially short, the rotor goes eccentric, the
//! controller gain drifts. This crate catches it on board, without an allocator,
//! by the method of Dalla Vedova, Berri and Re (ICSRS 2018): a light *monitor model* of the EMA is
//! simulated again and again by a bio-inspired optimizer (PSO; GA and DE for comparison) until its
//! equivalent current matches the measured one; the 8 fault parameters that make it match are the
//! diagnosis.
//!
//! ```text
//!  ADC (embedded-hal OneShot) ─► acquisition ─► conditioning ─► fitness ◄─ model (monitor model)
//!   3 phase currents, counts     amperes,        I_3eq, block      weighted      driven by the same
//!                                 checks          means, weights   residual      command profile
//!                                                                    │
//!                                              optimizer (PSO/GA/DE, step-wise) ─► health report
//! ```
//!
//! Vocabulary of the const generics: `W` = samples in the conditioned window, `P` = individuals
//! (particles), `D` = parameters fitted.
//!
//! Stages, one module each: [`acquisition`], [`conditioning`], [`model`], [`fitness`],
//! [`optimizer`], [`health`]; [`diagnosis`] wires them; [`effects`] holds the optional effect terms
//! the discrepancy workflow adds to the model. Shared definitions: [`params`] (nominal
//! actuator; with [`effects`], the crate `ema-model-config`, which the build script and the host
//! tools use too), [`faults`] (the fault vector and its physical mapping), [`profile`] (the test
//! manoeuvre), [`command`] (what drives the model: a profile or a sampled command), [`trace`]
//! (the ADC format). [`persist`] keeps the health state across power cycles.
//!
//! **Inlining.** The non-generic helpers the fitness loop calls every model step carry
//! `#[inline]` on hosted targets only (the firmware's fat LTO inlines on its own), which changes
//! no result; see `docs/decisions/0012-inlining-hosted-only.md`.
//!
//! The example below runs as a doctest on the host; it is left out of MCU builds, whose
//! doctests could not link `std`.
#![cfg_attr(not(target_os = "none"), doc = include_str!("example.md"))]
#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod acquisition;
pub mod command;
pub mod commissioning;
pub mod conditioning;
pub mod diagnosis;
pub mod envelope;
pub mod faults;
pub mod fitness;
pub mod flight;
pub mod health;
mod lockstep;
pub mod model;
pub mod operating_temperature;
pub mod optimizer;
pub mod persist;
pub mod profile;
pub mod prognosis;
#[cfg(feature = "defmt")]
pub mod report_log;
mod six_step;
#[cfg(test)]
mod test_traces;
pub mod trace;
pub mod trig;
pub mod unit;

// The parameter table and the effect catalogue live in `crates/ema-model-config`, which the
// build script and the host tools share; they are this crate's modules as well.
#[doc(inline)]
pub use ema_model_config::{effects, params};

pub use command::{Command, SampledCommand};
pub use effects::{EffectId, ModelEffects};
pub use faults::{FaultGroup, FaultMode, FaultParam, FaultVector, FAULT_COUNT};
pub use flight::{Acquired, Flight, FlightHooks, HealthMonitor};
pub use params::EmaParams;
pub use profile::Profile;
pub use unit::Tolerances;
