//! The instruction-counted regions: `scripts/qemu-run` counts the instructions executed between
//! the marker functions [`ema_identification_start`] and [`ema_identification_end`] (their
//! addresses read with `nm`): in the default run, the first region is flight 1's cold
//! identification and the second flight 2's warm one; in a commissioning run (`--commission`),
//! the first is the baseline fit of the last commissioning flight and the second that flight's
//! identification against the baseline. Each objective evaluation (a `step()`) and each of the
//! flight's later calls ([`FlightCall`]) lies between [`ema_slice_start`] and [`ema_slice_end`]:
//! the plugin reports the longest step of each identification region and the longest slice of
//! the run, what an integrator schedules the monitor by.

use ema_monitor::conditioning::ConditionedWindow;
use ema_monitor::diagnosis::Start;
use ema_monitor::flight::{FlightCall, FlightHooks};
use ema_monitor::report_log;

use crate::record_flash::{self, RecordFlash};

/// The QEMU firmware's hooks: the flight's start logged, the identification and the baseline fit
/// between the instruction-count markers, the commissioning windows kept in the record's flash.
pub struct CountedRegion<'f> {
    /// The record's flash, where the commissioning windows are kept.
    pub flash: &'f mut RecordFlash,
}

impl FlightHooks for CountedRegion<'_> {
    fn identification_start(&mut self, flight: u32, start: Start) {
        report_log::log_start(flight, start);
        ema_identification_start();
    }

    fn identification_end(&mut self) {
        ema_identification_end();
    }

    fn before_step(&mut self) {
        ema_slice_start();
    }

    fn after_step(&mut self) {
        ema_slice_end();
    }

    fn before_call(&mut self, _call: FlightCall) {
        ema_slice_start();
    }

    fn after_call(&mut self, _call: FlightCall) {
        ema_slice_end();
    }

    fn commissioning_start(&mut self) {
        defmt::info!("commissioning: fitting the unit's baseline");
        ema_identification_start();
    }

    fn commissioning_end(&mut self) {
        ema_identification_end();
    }

    fn keep_window<const W: usize>(&mut self, slot: u8, window: &ConditionedWindow<W>, temperature_c: f32) -> bool {
        record_flash::keep_window(self.flash, slot, window, temperature_c)
    }

    fn load_window<const W: usize>(&mut self, slot: u8, out: &mut ConditionedWindow<W>) -> Option<f32> {
        record_flash::load_window(self.flash, slot, out)
    }
}

/// Start marker of the instruction-counted identification region (its address is read with `nm`).
// SAFETY: `no_mangle` exports a unique symbol name; nothing else in the image defines it.
#[inline(never)]
#[no_mangle]
pub extern "C" fn ema_identification_start() {
    // distinct bodies keep LTO from merging the two markers into one address
    core::hint::black_box(0x5354_4152_u32);
}

/// End marker of the instruction-counted identification region.
// SAFETY: as for `ema_identification_start`.
#[inline(never)]
#[no_mangle]
pub extern "C" fn ema_identification_end() {
    core::hint::black_box(0x454E_4421_u32);
}

/// Start marker of one uninterrupted slice of the monitor's work: an objective evaluation or a
/// flight's later call.
// SAFETY: as for `ema_identification_start`.
#[inline(never)]
#[no_mangle]
pub extern "C" fn ema_slice_start() {
    core::hint::black_box(0x534C_4331_u32);
}

/// End marker of a slice.
// SAFETY: as for `ema_identification_start`.
#[inline(never)]
#[no_mangle]
pub extern "C" fn ema_slice_end() {
    core::hint::black_box(0x534C_4332_u32);
}
