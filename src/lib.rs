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
//! [`optimizer`], [`health`]; [`monitor`] wires them; [`effects`] holds the optional effect terms
//! the discrepancy workflow adds to the model. Shared definitions: [`params`] (nominal
//! actuator), [`faults`] (the fault vector and its physical mapping), [`profile`] (the test
//! manoeuvre), [`trace`] (the ADC format).
//!
//! **Inlining.** The non-generic helpers the fitness loop calls every model step carry
//! `#[inline]` on hosted targets only (the firmware's fat LTO inlines on its own), which changes
//! no result; see `docs/decisions/0012-inlining-hosted-only.md`.
//!
//! # Example
//!
//! The on-board path on the host: a recorded trace behind the replay ADC, acquisition into the
//! conditioned window, identification, health report (the firmware, `src/main.rs`, does the same).
//!
//! ```
//! use ema_monitor::acquisition::{AcquisitionConfig, Calibration, PhaseA, PhaseB, PhaseC, PhaseCurrentReader, ReplayAdc};
//! use ema_monitor::conditioning::MeasuredTrace;
//! use ema_monitor::monitor::{self, Identification, IdentifyConfig, ONBOARD_POPULATION, ONBOARD_WINDOW};
//! use ema_monitor::{health::Status, trace::PackedTrace, EmaParams, Profile};
//!
//! // A reference-model recording of the standard manoeuvre, friction at 1.5x nominal.
//! let bytes = include_bytes!(concat!(env!("CARGO_MANIFEST_DIR"), "/traces/standard.ematrace"));
//! let adc = ReplayAdc::new(PackedTrace::parse(bytes)?);
//! let pins = (PhaseA, PhaseB, PhaseC);
//! let mut reader = PhaseCurrentReader::new(adc, pins, Calibration::NOMINAL, AcquisitionConfig::DEFAULT)?;
//! let mut trace = MeasuredTrace::<ONBOARD_WINDOW>::new();
//! let acquired = monitor::acquire(&mut reader, &mut trace)?; // refused frames held and counted
//!
//! let config = IdentifyConfig::onboard();
//! let mut id: Identification<'_, ONBOARD_WINDOW, ONBOARD_POPULATION> =
//!     Identification::new(&trace, EmaParams::NOMINAL, Profile::STANDARD, &config)?;
//! id.run(u32::MAX); // or `id.step()`, one model evaluation at a time, between other work
//! let report = id.report().with_acquisition(&acquired);
//! println!("{report}");
//! assert_eq!(report.status, Status::Degraded); // the recording's friction fault
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]
#![forbid(unsafe_code)]

#[macro_use]
mod fmt;

pub mod acquisition;
pub mod conditioning;
pub mod effects;
pub mod faults;
pub mod fitness;
pub mod health;
pub mod model;
pub mod monitor;
pub mod optimizer;
pub mod params;
pub mod profile;
mod six_step;
pub mod trace;
pub mod trig;

pub use effects::{EffectId, ModelEffects};
pub use faults::{FaultVector, FAULT_COUNT};
pub use params::EmaParams;
pub use profile::Profile;
