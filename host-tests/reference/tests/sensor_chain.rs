//! The phase-current sensor chain and the pre-trigger of the reference model: the chain stays on
//! the recording path (the drive and the mechanism never see it), and a pre-trigger records the
//! actuator at rest, then the manoeuvre the run without one records.

use ema_monitor::{FaultVector, Profile};
use ema_reference::{simulate, ConfigError, Effect, Effects, Recording, SensorChain, SimConfig, MAX_PRE_TRIGGER_S};

/// A short manoeuvre (the standard profile's first 0.25 s: the step and its transient).
fn short() -> Profile {
    Profile::new(&Profile::STANDARD.segments()[..3], 0.25, 0.6).expect("a valid profile")
}

fn run(sensors: SensorChain, pre_trigger_s: f64, effects: Effects) -> Recording {
    simulate(&SimConfig {
        profile: short(),
        faults: FaultVector([0.3, 0.0, 0.0, 0.2, 0.0, 0.0, 0.5, 0.5]),
        sensors,
        pre_trigger_s,
        effects,
        seed: 4,
        ..SimConfig::default()
    })
    .expect("valid configuration")
}

#[test]
fn the_chain_changes_the_recorded_currents_and_nothing_else() {
    let ideal = run(SensorChain::IDEAL, 0.0, Effects::NONE);
    for chain in [SensorChain::NUCLEO_F446RE, SensorChain::NUCLEO_F446RE_ONESHOT] {
        let other = run(chain, 0.0, Effects::NONE);
        assert_eq!(other.truth, ideal.truth, "the actuator moves as with the ideal chain");
        assert!(other.samples.iter().zip(&ideal.samples).all(|(a, b)| a.position_rad == b.position_rad));
        let differ = other.samples.iter().zip(&ideal.samples).filter(|(a, b)| a.adc_counts != b.adc_counts).count();
        assert!(differ > other.samples.len() / 2, "{differ} of {} frames differ", other.samples.len());
    }
}

#[test]
fn a_pre_trigger_records_the_rest_then_the_same_manoeuvre() {
    for (chain, effects) in [
        (SensorChain::IDEAL, Effects::NONE),
        (SensorChain::NUCLEO_F446RE_ONESHOT, Effects::NONE),
        (SensorChain::IDEAL, Effects::NONE.with(Effect::Cogging, 1.0).expect("valid")),
    ] {
        let plain = run(chain, 0.0, effects);
        let pre = run(chain, 0.03, effects);
        assert_eq!((plain.trigger_index, pre.trigger_index), (0, 300));
        assert_eq!(pre.samples.len(), plain.samples.len() + 300);
        // the rest: the opening command, no current, the mechanism at zero, the sensors' zero points
        let opening = f64::from(short().command_rad(0.0));
        for (s, t) in pre.samples[..300].iter().zip(&pre.truth[..300]) {
            assert_eq!((s.command_rad, t.current_ref_a, t.phase_current_a), (opening, 0.0, [0.0; 3]));
            assert_eq!((t.motor_angle_rad, t.motor_speed_rad_per_s, t.surface_angle_rad), (0.0, 0.0, 0.0));
        }
        for j in 0..3 {
            let mean = pre.samples[..300].iter().map(|s| s.phase_current_a[j]).sum::<f64>() / 300.0;
            let zero = chain.phases[j].offset_a;
            assert!((mean - zero).abs() < 0.005, "phase {j}: rest mean {mean} A, zero error {zero} A");
        }
        // then the manoeuvre of the run without a pre-trigger, 30 ms later
        assert_eq!(pre.truth[300..], plain.truth[..]);
        for (k, (a, b)) in pre.samples[300..].iter().zip(&plain.samples).enumerate() {
            assert_eq!((a.command_rad, a.position_rad, a.adc_counts), (b.command_rad, b.position_rad, b.adc_counts));
            assert!((a.time_s - b.time_s - 0.03).abs() < 1e-12, "sample {k}: {} vs {}", a.time_s, b.time_s);
        }
        assert_eq!(pre.energy, plain.energy);
    }
}

#[test]
fn bad_chains_and_pre_triggers_are_refused() {
    let mut chain = SensorChain::IDEAL;
    chain.phases[2].skew_s = 1e-4;
    let cfg = SimConfig { sensors: chain, ..SimConfig::default() };
    let e = simulate(&cfg).expect_err("a skew of one control period");
    assert!(matches!(&e, ConfigError::Sensors(s) if s.field == "skew_us" && s.phase == Some(2)), "{e:?}");
    assert!(e.to_string().starts_with("sensor chain: skew_us of phase c"), "{e}");
    for bad in [-0.001, f64::NAN, MAX_PRE_TRIGGER_S + 0.1] {
        let cfg = SimConfig { pre_trigger_s: bad, ..SimConfig::default() };
        assert!(matches!(simulate(&cfg), Err(ConfigError::PreTrigger(_))), "{bad}");
    }
    // a pre-trigger and a profile together beyond the model's longest run
    let long = Profile::new(&Profile::STANDARD.segments()[..3], 55.0, 0.6).expect("a valid profile");
    let cfg = SimConfig { profile: long, pre_trigger_s: MAX_PRE_TRIGGER_S, ..SimConfig::default() };
    assert!(matches!(simulate(&cfg), Err(ConfigError::Duration(d)) if d > 60.0));
}
