//! # ema-model-config: what configures the monitor model of ema-monitor
//!
//! Two modules, `no_std` and without allocation, shared by the firmware, its build script and the
//! host tools so that each reads the same configuration with the same code:
//!
//! - [`params`]: the actuator's parameters ([`params::EmaParams`], its nominal set and
//!   temperature law), the table of every field with its unit and range ([`params::FIELDS`]) and
//!   the checks a parameter set must pass ([`params::EmaParams::check`]);
//! - [`effects`]: the optional effect terms of the monitor model ([`effects::EffectId`],
//!   [`effects::ModelEffects`]) and the parser of the model configuration file that switches them
//!   on ([`effects::parse_model_config`]).
//!
//! The core (`ema-monitor`) re-exports both as `ema_monitor::params` and `ema_monitor::effects`.
//! The firmware's `build.rs` uses them at build time, with the TOML reader of `ema-params-file`,
//! to check `EMA_PARAMS` and `EMA_MODEL_CONFIG`. The `defmt` feature derives `defmt::Format` on
//! the public types (the core's own `defmt` feature turns it on).
#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod effects;
pub mod params;
