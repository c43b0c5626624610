//! The firmware's acquisition path (`src/main.rs` steps 2 and 3) on arbitrary bytes: a packed
//! trace parsed by [`PackedTrace::parse`], replayed through [`ReplayAdc`] behind the embedded-hal
//! `OneShot` reader [`PhaseCurrentReader`] (nominal calibration, default checks) and acquired by
//! [`diagnosis::acquire`] into the on-board window. Every input gives a value, never a panic; an
//! accepted trace is a closed window of finite currents and weights in `(0, 1]`, no longer than
//! the frames read allow, with every frame counted once.
#![no_main]

use ema_monitor::acquisition::{AcquisitionConfig, Calibration, PhaseA, PhaseB, PhaseC, PhaseCurrentReader, ReplayAdc};
use ema_monitor::conditioning::{ConditionedWindow, DECIMATION};
use ema_monitor::diagnosis::{self, ONBOARD_WINDOW};
use ema_monitor::trace::{PackedTrace, ADC_MAX};
use ema_monitor::EmaParams;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(packed) = PackedTrace::parse(data) else { return };
    assert_eq!(packed.iter().count(), packed.frames());
    assert!(packed.iter().all(|f| f.iter().all(|&c| c <= ADC_MAX)));
    let _ = diagnosis::rate_matches(packed.sample_rate_hz() as f32, &EmaParams::NOMINAL);
    let adc = ReplayAdc::new(packed);
    let Ok(mut reader) =
        PhaseCurrentReader::new(adc, (PhaseA, PhaseB, PhaseC), Calibration::NOMINAL, AcquisitionConfig::DEFAULT)
    else {
        panic!("the nominal calibration and default settings are valid");
    };
    let mut trace = Box::new(ConditionedWindow::<ONBOARD_WINDOW>::new());
    match diagnosis::acquire(&mut reader, &mut trace) {
        Ok(summary) => {
            assert!(trace.is_finished());
            assert_eq!(summary.frames as usize, packed.frames());
            assert!(summary.refused <= summary.frames && summary.longest_refused_run <= summary.refused);
            assert_eq!(trace.len(), packed.frames() / DECIMATION);
            assert!(trace.current_a().all(|i| i.is_finite()));
            assert_eq!(trace.weights().count(), trace.len());
            assert!(trace.weights().all(|w| w > 0.0 && w <= 1.0));
        }
        Err(e) => {
            let _ = e.to_string();
        }
    }
});
