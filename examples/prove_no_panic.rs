//! Link-time proof that the on-board path cannot panic: `scripts/prove-no-panic` builds this
//! program for the MCU with a panic handler that calls a function defined nowhere. The release
//! build (fat LTO) removes every panic call the optimizer proves unreachable; if one path to a
//! panic survives, the handler is linked and the link fails on the undefined symbol. The script
//! builds it at both optimisation levels the core ships at: opt-level 3 (the root's release
//! profile, the QEMU firmware) and "s" (the board's, `boards/nucleo-f446re`).
//!
//! The path covered is the firmware's: a packed trace of any content (the bytes pass through
//! `black_box`, so nothing is folded from the built-in trace) behind the replay ADC → timer-paced
//! sampler (the interrupt's producer, ticked here from the consumer's wait hook, with a trigger
//! level and settings of any value) → the flight API (`HealthMonitor`: acquisition, the plan from
//! a health record decoded from bytes of any content and held as the firmwares hold it
//! (`KeptRecord`, a load of any outcome), identification, the report with its
//! uncertainty, the flight recorded with its pooled evidence) → health report. The calibration, the acquisition and identification settings,
//! the actuator parameters and the command profile pass through `black_box` too: the proof holds
//! for any of them (the solver, the polish, model selection and the effect terms included), not
//! only for the on-board defaults. The command that drives the model is the profile or, chosen
//! through `black_box`, a sampled command built from it at any stride (its checked constructor
//! and the interpolating cursor included). The health record (decoded from bytes of any content,
//! the flight appended, encoded) and the RAM flash it is written to are covered as well; the
//! flash store over `sequential-storage` is not (see `persist` below).
#![no_std]
#![no_main]

use core::cell::Cell;
use core::hint::black_box;
use core::panic::PanicInfo;

use cortex_m_rt::entry;
use ema_monitor::acquisition::{
    AcquisitionConfig, Calibration, PhaseA, PhaseB, PhaseC, PhaseCurrentReader, ReplayAdc, ReplayReader, Sampler,
    SamplerConfig, SamplerProducer, SAMPLER_QUEUE,
};
use ema_monitor::command::ONBOARD_COMMAND_SAMPLES;
use ema_monitor::conditioning::ConditionedWindow;
use ema_monitor::diagnosis::{Identification, IdentifyConfig, ONBOARD_POPULATION, ONBOARD_WINDOW};
use ema_monitor::flight::{Acquired, HealthMonitor, NoHooks};
use ema_monitor::persist::{HealthRecord, KeptRecord, RamFlash, StoreError};
use ema_monitor::trace::PackedTrace;
use ema_monitor::{Command, EmaParams, Profile, SampledCommand};

static TRACE: &[u8] = include_bytes!("../traces/standard.ematrace");

#[entry]
fn main() -> ! {
    let bytes: &[u8] = black_box(TRACE);
    let report = PackedTrace::parse(bytes).ok().and_then(|trace| {
        let adc = ReplayAdc::new(trace);
        let pins = (PhaseA, PhaseB, PhaseC);
        let (calibration, acquisition) = black_box((Calibration::NOMINAL, AcquisitionConfig::DEFAULT));
        let reader = PhaseCurrentReader::new(adc, pins, calibration, acquisition).ok()?;
        let mut sampler = Sampler::<SAMPLER_QUEUE>::new();
        let config = black_box(SamplerConfig { frames: 8500, trigger_timeout_frames: 1000 });
        let producer: Cell<Option<SamplerProducer<'_, ReplayReader<'_>>>> = Cell::new(None);
        let (p, mut live) = sampler.split(reader, config, || {
            // the timer interrupt's part, one tick per wait
            if let Some(mut p) = producer.take() {
                let tick = p.ticks();
                p.tick(tick >= black_box(3));
                producer.set(Some(p));
            }
        });
        producer.set(Some(p));
        let params = black_box(EmaParams::NOMINAL);
        let profile = black_box(Profile::STANDARD);
        let sampled = SampledCommand::<ONBOARD_COMMAND_SAMPLES>::sampled(&profile, black_box(1), &params).ok()?;
        let command = if black_box(true) { Command::Profile(&profile) } else { sampled.as_command() };
        // the flight API both firmwares call: acquisition, then plan, identification, report
        // with its uncertainty and record with the pooled evidence, over a record of any content
        let config = black_box(IdentifyConfig { max_iterations: 30, ..IdentifyConfig::onboard() });
        let monitor = HealthMonitor::<'_, ONBOARD_WINDOW, ONBOARD_POPULATION>::new(params, command, config).ok()?;
        let mut measured = ConditionedWindow::<ONBOARD_WINDOW>::new();
        let acquired = monitor.acquire(&mut live, &mut measured, black_box(10_000.0)).ok()?;
        let sensor = black_box(ema_monitor::acquisition::TemperatureSensor::TMP36_3V3);
        let temperature = sensor.judge(sensor.celsius(black_box(620)), &params);
        let acquired = Acquired { temperature_c: temperature.celsius_or_nan(), ..acquired };
        live.outcome().ok()?;
        let mut bytes = [0u8; HealthRecord::ENCODED_LEN];
        black_box(&mut bytes);
        // a record of either version and of any identity, as a load of any outcome gives it
        // (stored, none, unreadable, not archived), adopted, then the flight on it
        let len = black_box(HealthRecord::ENCODED_LEN);
        let decoded = bytes.get(..len).map(HealthRecord::decode);
        let loaded = match black_box(decoded) {
            Some(Ok(r)) => Ok(Some(r)),
            Some(Err(e)) => Err(StoreError::Record(e)),
            None => Ok(None),
        };
        let mut kept = KeptRecord::from_load(loaded);
        black_box(monitor.with_unit_serial(black_box(3)).adopt(kept.record_mut()));
        if black_box(false) {
            kept.archive_failed(StoreError::Full);
        }
        let flight = monitor.diagnose_kept(&measured, &acquired, &mut kept, &mut NoHooks).ok()?;
        black_box(kept.savable());
        let record = *kept.record();
        // a commissioning window written and read back as the flash keeps it
        let mut window_bytes = [0u8; ema_monitor::persist::window_encoded_len(ONBOARD_WINDOW)];
        let n = ema_monitor::persist::window::encode_window(&measured, black_box(20.0), &mut window_bytes).unwrap_or(0);
        black_box(&mut window_bytes);
        let len = black_box(n);
        let _ = window_bytes.get(..len).map(|b| ema_monitor::persist::window::decode_window_into(b, &mut measured));
        black_box(&record);
        // the identification's public calls in any order: a report before the first
        // evaluation, the search, then a step after the end
        let mut id =
            Identification::<ONBOARD_WINDOW, ONBOARD_POPULATION>::new(&measured, params, command, &config).ok()?;
        let early = id.report();
        id.run(black_box(u32::MAX));
        id.step();
        black_box(id.report());
        let report = flight.report;
        Some((early, report))
    });
    black_box(&report);
    persist(report.map(|(_, r)| r));
    loop {
        cortex_m::asm::wfi();
    }
}

/// The health record's path: load a record from bytes of any content, record the flight, encode
/// it, and write, read and erase it on a RAM flash whose power may be cut at any byte and whose
/// reads may fail. The
/// `HealthStore` itself stays out of the proof: `sequential-storage`'s async state machines and
/// flash-data-dependent slicing keep panic calls the optimizer cannot remove
/// (`docs/persistence.md`, "Panic paths").
#[inline(never)]
fn persist(report: Option<ema_monitor::health::HealthReport>) {
    use embedded_storage::nor_flash::{NorFlash, ReadNorFlash};
    let mut bytes = [0u8; HealthRecord::ENCODED_LEN];
    black_box(&mut bytes);
    let mut record = HealthRecord::decode(&bytes).unwrap_or_default();
    if let Some(r) = report {
        record.new_flight(&r, black_box(true));
    }
    record.set_evidence(black_box([0.0; 5]), black_box(1));
    black_box(record.history(black_box(ema_monitor::faults::FaultMode::Backlash)).iter().count());
    let mut flash = RamFlash::<4, 2048>::new();
    flash.cut_power_after(black_box(1234));
    let (offset, len) = black_box((0u32, HealthRecord::ENCODED_LEN));
    if let Ok(n) = record.encode(&mut bytes) {
        let _ = flash.write(offset, bytes.get(..n.min(len)).unwrap_or(&[]));
    }
    flash.power_on();
    flash.fail_reads_after(black_box(1), black_box(2));
    let _ = flash.read(black_box(8), &mut bytes);
    let _ = flash.erase(black_box(0), black_box(4096));
    black_box(flash.flip(black_box(17), 0x10));
    black_box((&bytes, flash.erase_counts()));
}

#[panic_handler]
fn panic(_info: &PanicInfo) -> ! {
    extern "C" {
        /// Defined nowhere: referencing it fails the link.
        fn ema_no_panic_proof_failed_a_panic_path_is_linked() -> !;
    }
    // SAFETY: never executed; the symbol does not exist, so a build that references it does not link.
    unsafe { ema_no_panic_proof_failed_a_panic_path_is_linked() }
}
