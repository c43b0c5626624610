//! The command profile file of the `ema` CLI (`--profile FILE` of simulate, identify, discover
//! and campaign) on arbitrary bytes: the bounded reader [`read_profile_from`], the same as the
//! text parser [`parse_profile`] on UTF-8 within the size limit. For an accepted profile, what
//! the reference model needs to simulate it: [`Simulator::new`] must accept it within
//! [`MAX_SAMPLES`] samples, and two control periods run (bounded time per input, not the whole
//! profile); the command stays finite and inside the end stops (within the f32 sine's error), and the monitor model's
//! [`ProfileCursor`] reads the values [`Profile::command_rad`] gives. Every input gives a value,
//! never a panic.
#![no_main]

use std::path::Path;

use ema_cli::profile_file::{parse_profile, read_profile_from, MAX_DURATION_S, MAX_FILE_BYTES};
use ema_monitor::profile::{ProfileCursor, MAX_SEGMENTS};
use ema_monitor::trig::MAX_ERROR;
use ema_monitor::EmaParams;
use ema_reference::{SimConfig, Simulator, MAX_SAMPLES};
use libfuzzer_sys::fuzz_target;

/// Command instants checked per profile, spread over its duration.
const PROBES: usize = 2000;

fuzz_target!(|data: &[u8]| {
    let path = Path::new("fuzz.profile");
    let end_stop = EmaParams::NOMINAL.end_stop_rad;
    let from_reader = read_profile_from(data, path);
    match std::str::from_utf8(data) {
        Ok(text) if data.len() <= MAX_FILE_BYTES => assert_eq!(from_reader, parse_profile(text, path, end_stop)),
        _ => assert!(from_reader.is_err(), "not UTF-8, or beyond the size limit"),
    }
    let profile = match from_reader {
        Ok(p) => p,
        Err(e) => {
            assert!(e.line.is_none_or(|l| l >= 1));
            let _ = e.to_string();
            return;
        }
    };
    let duration = profile.duration_s();
    assert!(duration > 0.0 && duration <= MAX_DURATION_S);
    assert!((1..=MAX_SEGMENTS).contains(&profile.segments().len()));

    let period = EmaParams::NOMINAL.control_period_s;
    let steps = (duration / period) as usize;
    let stride = (steps / PROBES).max(1);
    let sine_error = end_stop * 2.0 * MAX_ERROR;
    let mut cursor = ProfileCursor::new(&profile);
    for k in (0..=steps).step_by(stride) {
        let t = k as f32 * period;
        let command = profile.command_rad(t);
        // inside the end stops, within the f32 sine's error over the phase range a profile allows
        assert!(command.is_finite() && command.abs() <= end_stop + sine_error, "t = {t}: {command}");
        assert_eq!(cursor.command_rad(t).to_bits(), command.to_bits(), "t = {t}");
    }

    let cfg = SimConfig { profile, ..SimConfig::default() };
    let mut sim = match Simulator::new(&cfg) {
        Ok(sim) => sim,
        Err(e) => panic!("an accepted profile of {duration} s is refused by the reference model: {e}"),
    };
    assert!(sim.sample_count() <= MAX_SAMPLES);
    for _ in 0..sim.sample_count().min(2) {
        let (sample, truth) = sim.sample();
        assert!(sample.command_rad.is_finite() && truth.current_ref_a.is_finite());
        sim.advance_period();
    }
});
