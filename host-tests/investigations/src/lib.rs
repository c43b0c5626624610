//! # ema-investigations: the programs behind the figures in `docs/`
//!
//! Each program is an example of this crate, run from `host-tests/`:
//!
//! ```text
//! cargo run --release -p ema-investigations --example NAME -- ARGS
//! ```
//!
//! They drive the reference model (`ema-reference`, the simulated actuator) and the monitor model
//! (`ema-monitor`, built for the host) side by side, and print tables; the `ema` command line
//! (`ema-cli`) supplies the recording reader, the conditioning and the residual series. They are
//! investigations, not API examples: each measures one thing a figure or a decision record cites.
//!
//! | program | what it measures | figure in |
//! |---|---|---|
//! | `floor_split` | the structural residual at the true fault vector split into sensor noise and model mismatch, by band | `docs/results/mismatch-floor.md` |
//! | `structural_floor` | the structural residual of a recording at a given fault vector, by band and 5 ms window | `docs/results/mismatch-floor.md` |
//! | `reference_step` | how far the reference model's recordings move with its integration step | `docs/decisions/0004-reference-step.md` |
//! | `window_gains` | one fault vector's fitness gain over another, evidence window by window | `docs/decisions/0002-window-check.md` |
//! | `freewheel` | the actuator's hysteresis loop with disagreeing current sensors, against the model's term | `docs/model.md` |
//! | `loop_side_by_side` | both control loops (actuator and monitor model) period by period | `docs/model.md` |
//! | `effect_signature` | an effect's signature in the measured current, the actuator's against the model term's | `docs/model.md` |
//! | `fit_power` | the goodness-of-fit test's scores (whole recording, worst window, noise from the recording) on library faults and on effects outside the library | `docs/decisions/0017-windowed-fit-test.md` |
//! | `eccentricity_bias` | the eccentricity a fit restricted to `k6`, `k7` reads on noiseless recordings of eccentricities alone, with the signature-only fit and the reference model's integration step as controls | the program's own documentation |
//! | `temperature_cost` | the Cramér–Rao bounds of the fault parameters with the flight's temperature known and with it a parameter of the flight | `docs/results/temperature-cost.md` |
//! | `position_noise_bias` | what the position transducer's noise changes in the sampled current of the pbit manoeuvre, against the monitor model's envelope | `docs/pbit.md` |
//! | `pbit_design` | the Cramér–Rao bounds of the fault parameters and the healthy bias of the monitor model for the standard manoeuvre, the pbit manoeuvre and the design's candidates, with their peaks against the limits | `docs/pbit.md` |
#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod bounds;
