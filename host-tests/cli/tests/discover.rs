//! `ema discover` on reference-model recordings in which an effect is hidden: the workflow sees
//! only the recording (currents, command), never the reference model's configuration.
//!
//! Each case simulates the standard manoeuvre with noise on, runs the whole workflow and checks
//! what it names, the structural residual before/after, and (where the fit had mistaken the
//! effect for faults) the fault-vector error against the truth.

use std::path::Path;

use ema_cli::discover::{discover, Discovery};
use ema_cli::identify::{condition_recording, HOST_WINDOW};
use ema_cli::recording_io::Recording;
use ema_monitor::{EffectId, FaultVector, Profile};
use ema_reference::{simulate, Effect, Effects, SimConfig};

fn run(effects: &[(Effect, f64)], faults: [f32; 8], seed: u64) -> Discovery {
    let mut e = Effects::default();
    for (effect, s) in effects {
        e.set(*effect, *s).unwrap();
    }
    let truth = FaultVector(faults);
    let rec = simulate(&SimConfig { faults: truth, effects: e, seed, ..SimConfig::default() }).unwrap();
    let recording = Recording::from_reference(&rec, vec![]);
    let path = Path::new("in-memory.csv");
    let trace = condition_recording(&recording, path, &Profile::STANDARD).unwrap();
    discover::<HOST_WINDOW>(&trace, &Profile::STANDARD, path, Some(truth), 1, 2).unwrap()
}

fn named(d: &Discovery) -> Vec<EffectId> {
    d.named.iter().map(|(e, _, _)| *e).collect()
}

const HEALTHY: [f32; 8] = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5];
const FRICTION: [f32; 8] = [0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5];

/// Named, its severity close to the truth, and the structural residual at least halved.
fn assert_found_and_halved(d: &Discovery, effect: EffectId, severity: f32) {
    assert_eq!(named(d), vec![effect], "{}", ema_cli::discover::summary(d));
    let s = d.named[0].1;
    assert!((s - severity).abs() < 0.15, "severity {s} for {severity}");
    assert!(d.rms_after_a() <= 0.5 * d.rms_before_a(), "{} -> {}", d.rms_before_a(), d.rms_after_a());
}

#[test]
fn clean_recordings_name_nothing() {
    for (seed, k) in [(11, HEALTHY), (12, FRICTION), (13, [0.0, 0.0, 0.0, 0.4, 0.0, 0.0, 0.5, 0.5])] {
        let d = run(&[], k, seed);
        assert!(d.named.is_empty(), "seed {seed}: {}", ema_cli::discover::summary(&d));
        assert_eq!(ema_cli::discover::verdict(&d), "no missing effect found");
    }
}

#[test]
fn viscous_is_named_and_the_gap_halved() {
    assert_found_and_halved(&run(&[(Effect::Viscous, 0.6)], HEALTHY, 21), EffectId::Viscous, 0.6);
    assert_found_and_halved(&run(&[(Effect::Viscous, 0.6)], FRICTION, 22), EffectId::Viscous, 0.6);
}

#[test]
fn hinge_stiffness_is_named_and_the_gap_halved() {
    assert_found_and_halved(&run(&[(Effect::HingeStiffness, 0.8)], HEALTHY, 31), EffectId::HingeStiffness, 0.8);
    assert_found_and_halved(&run(&[(Effect::HingeStiffness, 0.8)], FRICTION, 32), EffectId::HingeStiffness, 0.8);
}

/// A winding temperature rise lowers k_e and raises R on all three phases alike: the fault-only
/// fit reads it as shorts on three phases, which leaves little residual, so the residual cannot
/// halve; the effect is named because it explains the same with fewer parameters, and the fault
/// vector's error collapses.
#[test]
fn winding_temperature_replaces_spurious_shorts() {
    let d = run(&[(Effect::WindingTemperature, 0.8)], FRICTION, 41);
    assert_eq!(named(&d), vec![EffectId::WindingTemperature], "{}", ema_cli::discover::summary(&d));
    let truth = FaultVector(FRICTION);
    let (before, after) = (d.before.k.paper_error_percent(&truth), d.after.k.paper_error_percent(&truth));
    assert!(after < 0.2 * before && after < 3.0, "Err% {before} -> {after}");
    assert!(d.rms_after_a() <= d.rms_before_a());
}

/// Effects outside the library (a DC-link sag, a compliant transmission): nothing is mislabelled
/// as a library effect, and the residual left is reported where it is.
#[test]
fn effects_outside_the_library_are_not_mislabelled() {
    for (effect, seed) in [(Effect::BusSag, 51), (Effect::Compliance, 52)] {
        let d = run(&[(effect, 1.0)], [0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5], seed);
        assert!(d.named.is_empty(), "{effect}: {}", ema_cli::discover::summary(&d));
        let v = ema_cli::discover::verdict(&d);
        assert!(v.contains("unexplained residual at"), "{effect}: {v}");
    }
}
