//! The instruction-counted identification regions: `scripts/qemu-run` counts the instructions
//! executed between the marker functions [`ema_identification_start`] and
//! [`ema_identification_end`] (their addresses read with `nm`), the first region as flight 1's
//! cold identification, the second as flight 2's warm one.

use ema_monitor::flight::FlightHooks;
use ema_monitor::monitor::Start;
use ema_monitor::report_log;

/// The QEMU firmware's hooks: the flight's start logged, and the identification between the
/// instruction-count markers.
pub struct CountedRegion;

impl FlightHooks for CountedRegion {
    fn identification_start(&mut self, flight: u32, start: Start) {
        report_log::log_start(flight, start);
        ema_identification_start();
    }

    fn identification_end(&mut self) {
        ema_identification_end();
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
