//! On-target self-test (`cargo test` runs it in QEMU through `scripts/qemu-run`).
//!
//! A tiny harness: [`TESTS`] is a table of `(name, fn() -> Result<(), &'static str>)`; each test
//! runs in turn and prints `PASS name` or `FAIL name: reason` (after one line naming where the
//! core's host unit tests are), then one plain summary line
//! `selftest: N passed, N failed`, and the binary exits 0 if every test passed, 1 otherwise.
//!
//! **Adding a test** = writing a `fn my_test() -> Result<(), &'static str>` (use [`ensure`]) and one
//! table line `("my_test", my_test),`.
//!
//! Output goes through defmt (`defmt::println!`, no level) and the runner decodes it with
//! `defmt-print --log-format "{s}"`, so each line reaches stdout exactly as printed.
#![no_std]
#![no_main]

use cortex_m as _; // critical-section implementation
use defmt_semihosting as _; // defmt logger over semihosting stdout
use panic_probe as _; // a panicking test → HardFault → exit(1)

use cortex_m_rt::{entry, exception, ExceptionFrame};
use ema_monitor::acquisition::{
    manoeuvre_frames, AcquisitionConfig, AcquisitionError, Calibration, Phase, PhaseA, PhaseB, PhaseC,
    PhaseCalibration, PhaseCurrentReader, PhaseCurrents, PhasePin, ReplayAdc, Sampler, SamplerConfig, SamplerConsumer,
    SamplerState, SAMPLER_QUEUE,
};
use ema_monitor::conditioning::{ConditionedWindow, ConditioningError, DECIMATION};
use ema_monitor::diagnosis::{self, Identification, IdentifyConfig, MonitorError, ONBOARD_WINDOW};
use ema_monitor::fitness::{simulate_window, EquivalentCurrentFit};
use ema_monitor::health::HealthReport;
use ema_monitor::model::{ModelState, MonitorModel};
use ema_monitor::optimizer::pso::{ParticleSwarm, PsoConfig};
use ema_monitor::optimizer::{run, Bounds, Objective, Optimizer};
use ema_monitor::persist::{FlashFault, HealthRecord, HealthStore, RamFlash, StoreError};
use ema_monitor::trace::{self, pack, packed_len, PackedTrace, TraceError, ADC_MAX, ADC_MIDSCALE};
use ema_monitor::{Command, EmaParams, FaultVector, Profile, SampledCommand};
use embedded_hal::adc::{Channel, OneShot};

/// A test: `Ok(())` passes, `Err(reason)` fails.
type Test = fn() -> Result<(), &'static str>;

/// Every on-target test, in run order. One line per test.
const TESTS: &[(&str, Test)] = &[
    ("trace_pack_round_trip", trace_pack_round_trip),
    ("trace_corrupt_input_is_error", trace_corrupt_input_is_error),
    ("trace_built_in_decodes", trace_built_in_decodes),
    ("replay_one_shot_reproduces_codes", replay_one_shot_reproduces_codes),
    ("reader_converts_analytically", reader_converts_analytically),
    ("reader_reads_built_in_trace_to_end", reader_reads_built_in_trace_to_end),
    ("reader_detects_saturation_and_sum", reader_detects_saturation_and_sum),
    ("reader_times_out_on_busy_adc", reader_times_out_on_busy_adc),
    ("calibration_fixed_point", calibration_fixed_point),
    ("live_full_manoeuvre_frame_count", live_full_manoeuvre_frame_count),
    ("live_overrun_is_an_error", live_overrun_is_an_error),
    ("live_late_trigger_drops_early_frames", live_late_trigger_drops_early_frames),
    ("live_missing_trigger_times_out", live_missing_trigger_times_out),
    ("fault_vector_physical_mapping", fault_vector_physical_mapping),
    ("fault_vector_paper_error", fault_vector_paper_error),
    ("profile_standard_values", profile_standard_values),
    ("model_step_response_settles", model_step_response_settles),
    ("model_short_circuit_shape_function", model_short_circuit_shape_function),
    ("conditioning_refuses_bad_input", conditioning_refuses_bad_input),
    ("fitness_at_the_true_vector_is_the_windows_rounding", fitness_at_the_true_vector_is_the_windows_rounding),
    ("pso_minimises_a_sphere", pso_minimises_a_sphere),
    ("identification_refuses_impossible_config", identification_refuses_impossible_config),
    ("identification_under_the_sampled_standard_profile", identification_under_the_sampled_standard_profile),
    ("persist_save_load_reset", persist_save_load_reset),
    ("persist_power_cut_keeps_a_record", persist_power_cut_keeps_a_record),
    ("persist_corrupt_byte_is_detected", persist_corrupt_byte_is_detected),
    ("persist_dead_flash_is_an_error", persist_dead_flash_is_an_error),
    ("warm_start_from_the_cold_report", warm_start_from_the_cold_report),
];

#[entry]
fn main() -> ! {
    // `cargo test` at the root builds for the MCU and runs only this binary: say where the rest is.
    defmt::println!("on-target self-test; the core's unit tests: cargo host-test; every suite: scripts/test-all");
    let (mut passed, mut failed) = (0u32, 0u32);
    for (name, test) in TESTS {
        match test() {
            Ok(()) => {
                passed += 1;
                defmt::println!("PASS {=str}", name);
            }
            Err(reason) => {
                failed += 1;
                defmt::println!("FAIL {=str}: {=str}", name, reason);
            }
        }
    }
    defmt::println!("selftest: {=u32} passed, {=u32} failed", passed, failed);
    exit(failed == 0)
}

/// A panic (panic-probe ends in `udf`) or fault must end the QEMU run with failure.
#[exception]
unsafe fn HardFault(_frame: &ExceptionFrame) -> ! {
    exit(false)
}

/// `Err(reason)` unless `cond`.
fn ensure(cond: bool, reason: &'static str) -> Result<(), &'static str> {
    if cond {
        Ok(())
    } else {
        Err(reason)
    }
}

fn close(a: f32, b: f32, tol: f32) -> bool {
    libm::fabsf(a - b) <= tol
}

// ---- trace -------------------------------------------------------------------------------------

const SMALL: [[u16; 3]; 5] = [[2048, 2148, 1948], [0x123, 0x456, 0x789], [0, ADC_MAX, 0], [4095, 0, 17], [1, 2, 3]];

fn trace_pack_round_trip() -> Result<(), &'static str> {
    let mut buf = [0u8; 64];
    for n in [0usize, 1, 2, 5] {
        let len = pack(&SMALL[..n], 10_000, &mut buf).map_err(|_| "pack failed")?;
        ensure(len == packed_len(n), "packed length")?;
        let t = PackedTrace::parse(&buf[..len]).map_err(|_| "parse failed")?;
        ensure(t.frames() == n && t.sample_rate_hz() == 10_000, "header")?;
        for (i, f) in SMALL[..n].iter().enumerate() {
            ensure(t.frame(i) == Some(*f), "frame codes differ")?;
        }
        ensure(t.frame(n).is_none(), "frame past the end")?;
    }
    let len = pack(&SMALL[1..2], 1, &mut buf).map_err(|_| "pack failed")?;
    ensure(buf[..4] == *b"EMA3", "magic")?;
    ensure(buf[16..len - 4] == [0x23, 0x61, 0x45, 0x89, 0x07, 0x00], "byte layout")?;
    ensure(buf[len - 4..len] == trace::crc32(&buf[..len - 4]).to_le_bytes(), "checksum")
}

fn trace_corrupt_input_is_error() -> Result<(), &'static str> {
    let mut buf = [0u8; 64];
    let len = pack(&SMALL[..3], 10_000, &mut buf).map_err(|_| "pack failed")?;
    ensure(PackedTrace::parse(&buf[..len]).is_ok(), "valid trace refused")?;
    for n in 0..len {
        ensure(PackedTrace::parse(&buf[..n]).is_err(), "truncated trace accepted")?;
    }
    let mut bad = buf;
    bad[1] = b'X';
    ensure(PackedTrace::parse(&bad[..len]) == Err(TraceError::BadMagic), "bad magic")?;
    let mut bad = buf;
    bad[8..12].copy_from_slice(&0u32.to_le_bytes());
    ensure(PackedTrace::parse(&bad[..len]) == Err(TraceError::Checksum), "a changed byte, the checksum")?;
    trace::reseal(&mut bad[..len]).map_err(|_| "reseal failed")?;
    ensure(PackedTrace::parse(&bad[..len]) == Err(TraceError::SampleRate), "zero rate")?;
    let mut bad = buf;
    bad[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
    ensure(PackedTrace::parse(&bad[..len]).is_err(), "huge frame count")?;
    for bit in 0..8 * len {
        let mut bad = buf;
        bad[bit / 8] ^= 1 << (bit % 8);
        ensure(PackedTrace::parse(&bad[..len]).is_err(), "a flipped bit accepted")?;
    }
    ensure(pack(&[[0, 4096, 0]], 1, &mut buf) == Err(TraceError::CodeRange), "code range")?;
    ensure(pack(&SMALL, 1, &mut buf[..20]) == Err(TraceError::OutputTooSmall), "small output")
}

static BUILT_IN: &[u8] = include_bytes!("../traces/standard.ematrace");

fn trace_built_in_decodes() -> Result<(), &'static str> {
    let t = PackedTrace::parse(BUILT_IN).map_err(|_| "built-in trace invalid")?;
    ensure(t.frames() > 0, "no frames")?;
    ensure(t.sample_rate_hz() == trace::SAMPLE_RATE_HZ, "sample rate")?;
    let mut n = 0;
    for f in t.iter() {
        ensure(f.iter().all(|&c| c <= ADC_MAX), "code above 12 bits")?;
        n += 1;
    }
    ensure(n == t.frames(), "frame count")
}

// ---- acquisition -------------------------------------------------------------------------------

fn small_trace(buf: &mut [u8], frames: &[[u16; 3]]) -> Result<usize, &'static str> {
    pack(frames, trace::SAMPLE_RATE_HZ, buf).map_err(|_| "pack failed")
}

fn replay_one_shot_reproduces_codes() -> Result<(), &'static str> {
    let mut buf = [0u8; 64];
    let len = small_trace(&mut buf, &SMALL)?;
    let t = PackedTrace::parse(&buf[..len]).map_err(|_| "parse")?;
    let mut adc = ReplayAdc::new(t);
    let (mut a, mut b, mut c) = (PhaseA, PhaseB, PhaseC);
    for f in SMALL {
        // C first: any order completes the frame
        let cc = adc.read(&mut c).map_err(|_| "read C")?;
        let aa = adc.read(&mut a).map_err(|_| "read A")?;
        let bb = adc.read(&mut b).map_err(|_| "read B")?;
        ensure([aa, bb, cc] == f, "replayed codes differ")?;
    }
    ensure(adc.read(&mut a).is_err(), "read past the end")
}

fn reader_converts_analytically() -> Result<(), &'static str> {
    let mut buf = [0u8; 64];
    let len = small_trace(&mut buf, &[[2048, 2148, 1948], [3072, 1536, 1536]])?;
    let t = PackedTrace::parse(&buf[..len]).map_err(|_| "parse")?;
    let mut r = PhaseCurrentReader::new(
        ReplayAdc::new(t).with_busy_polls(2),
        (PhaseA, PhaseB, PhaseC),
        Calibration::NOMINAL,
        AcquisitionConfig::DEFAULT,
    )
    .map_err(|_| "config refused")?;
    let f = r.read_frame().map_err(|_| "frame 0 refused")?;
    ensure(f.currents_a() == [0.0, 0.9765625, -0.9765625], "frame 0 currents")?;
    let f = r.read_frame().map_err(|_| "frame 1 refused")?;
    ensure(f.currents_a() == [10.0, -5.0, -5.0], "frame 1 currents")?;
    ensure(r.read_frame() == Err(AcquisitionError::EndOfData), "end of data")
}

fn reader_reads_built_in_trace_to_end() -> Result<(), &'static str> {
    let t = PackedTrace::parse(BUILT_IN).map_err(|_| "built-in trace invalid")?;
    let mut r = PhaseCurrentReader::new(
        ReplayAdc::new(t),
        (PhaseA, PhaseB, PhaseC),
        Calibration::NOMINAL,
        AcquisitionConfig::DEFAULT,
    )
    .map_err(|_| "config refused")?;
    // every call completes a frame (accepted or refused by a check) until the end of data
    for _ in 0..t.frames() {
        match r.read_frame() {
            Ok(_) => {}
            Err(AcquisitionError::EndOfData) => return Err("end of data too early"),
            Err(AcquisitionError::Timeout { .. } | AcquisitionError::Adc { .. }) => return Err("driver error"),
            Err(_) => {}
        }
    }
    ensure(r.read_frame() == Err(AcquisitionError::EndOfData), "no end of data")?;
    ensure(r.frames_read() as usize == t.frames(), "frame count")
}

fn reader_detects_saturation_and_sum() -> Result<(), &'static str> {
    let mut buf = [0u8; 128];
    let bad_sum = [2148u16; 3];
    let frames = [[2048, 4095, 2048], [2048, 2048, 0], bad_sum, bad_sum, bad_sum, bad_sum, bad_sum];
    let len = small_trace(&mut buf, &frames)?;
    let t = PackedTrace::parse(&buf[..len]).map_err(|_| "parse")?;
    let mut r = PhaseCurrentReader::new(
        ReplayAdc::new(t),
        (PhaseA, PhaseB, PhaseC),
        Calibration::NOMINAL,
        AcquisitionConfig::DEFAULT,
    )
    .map_err(|_| "config refused")?;
    ensure(r.read_frame() == Err(AcquisitionError::Saturated { phase: Phase::B, code: 4095 }), "saturation B")?;
    ensure(r.read_frame() == Err(AcquisitionError::Saturated { phase: Phase::C, code: 0 }), "saturation C")?;
    for _ in 0..4 {
        ensure(r.read_frame().is_ok(), "sum flagged too early")?;
    }
    ensure(r.read_frame() == Err(AcquisitionError::InconsistentSum { sum_ma: 2930 }), "inconsistent sum")
}

/// A driver that never finishes a conversion.
struct BusyAdc;
impl<P: PhasePin + Channel<BusyAdc>> OneShot<BusyAdc, u16, P> for BusyAdc {
    type Error = ();
    fn read(&mut self, _pin: &mut P) -> nb::Result<u16, ()> {
        Err(nb::Error::WouldBlock)
    }
}

fn reader_times_out_on_busy_adc() -> Result<(), &'static str> {
    let mut r =
        PhaseCurrentReader::new(BusyAdc, (PhaseA, PhaseB, PhaseC), Calibration::NOMINAL, AcquisitionConfig::DEFAULT)
            .map_err(|_| "config refused")?;
    ensure(r.read_frame() == Err(AcquisitionError::Timeout { phase: Phase::A }), "timeout")
}

fn calibration_fixed_point() -> Result<(), &'static str> {
    let n = PhaseCalibration::NOMINAL;
    for code in 0..=ADC_MAX {
        ensure(n.to_amps(code) == trace::counts_to_amps(code), "nominal differs from counts_to_amps")?;
    }
    ensure(n.to_amps(ADC_MIDSCALE) == 0.0, "zero")?;
    let cal = PhaseCalibration::from_f32(2000.5, 0.01).map_err(|_| "calibration refused")?;
    ensure(close(cal.to_amps(3000), 9.995, 2e-6), "offset/gain")?;
    ensure(PhaseCalibration::from_f32(2048.0, 0.0).is_err(), "zero gain accepted")?;
    ensure(PhaseCalibration::from_f32(f32::NAN, 0.01).is_err(), "NaN offset accepted")
}

// ---- timer-paced live acquisition (CMSDK timer interrupt → sampler → thread mode) -------------

/// TIMER0 and its interrupt handler, shared with the firmware (`src/main.rs`).
#[path = "../src/qemu_live.rs"]
mod qemu_live;
/// The semihosting exit, shared with the firmware (its maintenance command line is not used here).
#[path = "../src/semihosting_host.rs"]
#[allow(dead_code, reason = "the self-test exits through it and reads no command line")]
mod semihosting_host;
use qemu_live::{arm, disarm};
use semihosting_host::exit;

/// Sleeps until the acquisition ends, without draining the queue (at most `max_wakes` wakes).
fn wait_for_end(consumer: &SamplerConsumer<'static, fn()>, max_wakes: u32) -> SamplerState {
    for _ in 0..max_wakes {
        let state = consumer.state();
        if !matches!(state, SamplerState::Armed | SamplerState::Recording) {
            return state;
        }
        cortex_m::asm::wfi();
    }
    consumer.state()
}

fn live_full_manoeuvre_frame_count() -> Result<(), &'static str> {
    let t = PackedTrace::parse(BUILT_IN).map_err(|_| "built-in trace invalid")?;
    let frames = manoeuvre_frames(&Profile::STANDARD, &EmaParams::NOMINAL);
    ensure(frames == 8500, "manoeuvre frame count")?;
    let sampler = cortex_m::singleton!(: Sampler<SAMPLER_QUEUE> = Sampler::new()).ok_or("sampler taken")?;
    let config = SamplerConfig { frames, trigger_timeout_frames: 1000 };
    let mut consumer = arm(sampler, t, config, 0).map_err(|_| "acquisition config refused")?;
    // the same frames, read directly in thread mode, to compare with
    let mut direct = PhaseCurrentReader::new(
        ReplayAdc::new(t),
        (PhaseA, PhaseB, PhaseC),
        Calibration::NOMINAL,
        AcquisitionConfig::DEFAULT,
    )
    .map_err(|_| "config refused")?;
    let mut n = 0u32;
    let mut same = true;
    loop {
        match consumer.read_frame() {
            Err(AcquisitionError::EndOfData) => break,
            sample => same &= sample == direct.read_frame(),
        }
        n += 1;
    }
    let outcome = consumer.outcome();
    disarm();
    ensure(same, "frames differ from the direct read")?;
    ensure(n == 8500 && outcome == Ok(8500), "not 8500 frames")?;
    ensure(consumer.waited_frames() == 0, "frames dropped before an immediate trigger")
}

fn live_overrun_is_an_error() -> Result<(), &'static str> {
    let t = PackedTrace::parse(BUILT_IN).map_err(|_| "built-in trace invalid")?;
    let sampler = cortex_m::singleton!(: Sampler<8> = Sampler::new()).ok_or("sampler taken")?;
    let config = SamplerConfig { frames: 8500, trigger_timeout_frames: 1000 };
    // thread mode is busy elsewhere (it sleeps without draining): the 8th frame finds 7 queued
    let mut consumer = arm(sampler, t, config, 0).map_err(|_| "acquisition config refused")?;
    let state = wait_for_end(&consumer, 100_000);
    let first = consumer.read_frame();
    disarm();
    ensure(state == SamplerState::Failed(AcquisitionError::Overrun { frame: 7 }), "no overrun at frame 7")?;
    ensure(consumer.outcome() == Err(AcquisitionError::Overrun { frame: 7 }), "outcome")?;
    ensure(first == Err(AcquisitionError::EndOfData), "frames after the overrun")
}

fn live_late_trigger_drops_early_frames() -> Result<(), &'static str> {
    // 400 frames numbered by phase A's code: [1000 + i, 3096 − i, 2048] (clean, sum zero)
    const N: usize = 400;
    let buf = cortex_m::singleton!(: [u8; trace::packed_len(N)] = [0; trace::packed_len(N)]).ok_or("buffer taken")?;
    let mut frames = [[0u16; 3]; N];
    for (i, f) in frames.iter_mut().enumerate() {
        *f = [1000 + i as u16, 3096 - i as u16, 2048];
    }
    let len = small_trace(buf, &frames)?;
    let t = PackedTrace::parse(&buf[..len]).map_err(|_| "parse")?;
    let sampler = cortex_m::singleton!(: Sampler<SAMPLER_QUEUE> = Sampler::new()).ok_or("sampler taken")?;
    let config = SamplerConfig { frames: 200, trigger_timeout_frames: 1000 };
    let mut consumer = arm(sampler, t, config, 123).map_err(|_| "acquisition config refused")?;
    let mut n = 0u16;
    let mut in_order = true;
    loop {
        match consumer.read_frame() {
            Ok(f) => in_order &= f.codes[0] == 1123 + n,
            Err(AcquisitionError::EndOfData) => break,
            Err(_) => in_order = false,
        }
        n += 1;
    }
    disarm();
    ensure(consumer.waited_frames() == 123, "frames dropped before the trigger")?;
    ensure(in_order, "first frame is not the trigger's, or a frame is out of order")?;
    ensure(n == 200 && consumer.outcome() == Ok(200), "frame count after a late trigger")
}

fn live_missing_trigger_times_out() -> Result<(), &'static str> {
    let t = PackedTrace::parse(BUILT_IN).map_err(|_| "built-in trace invalid")?;
    let sampler = cortex_m::singleton!(: Sampler<SAMPLER_QUEUE> = Sampler::new()).ok_or("sampler taken")?;
    let config = SamplerConfig { frames: 8500, trigger_timeout_frames: 300 };
    let mut consumer = arm(sampler, t, config, u32::MAX).map_err(|_| "acquisition config refused")?;
    let first = consumer.read_frame();
    disarm();
    ensure(first == Err(AcquisitionError::EndOfData), "a frame without a trigger")?;
    ensure(consumer.frames_read() == 0, "frames recorded")?;
    ensure(consumer.outcome() == Err(AcquisitionError::NoTrigger { waited_frames: 300 }), "no timeout error")
}

// ---- shared contract ---------------------------------------------------------------------------

fn fault_vector_physical_mapping() -> Result<(), &'static str> {
    let p = EmaParams::NOMINAL;
    let h = FaultVector::HEALTHY.physical(&p);
    ensure(h.static_friction_n_m == p.static_friction_n_m, "healthy friction")?;
    ensure(h.backlash_rad == p.nominal_backlash_rad, "healthy backlash")?;
    ensure(h.shorted_fraction == [0.0; 3] && h.eccentricity == 0.0, "healthy shorts/eccentricity")?;
    ensure(h.eccentricity_phase_rad == 0.0 && h.kp_a_per_rad == p.kp_a_per_rad, "healthy phase/gain")?;
    let f = FaultVector([1.0; 8]).physical(&p);
    ensure(close(f.static_friction_n_m, 3.0 * p.static_friction_n_m, 1e-6), "friction 3x")?;
    ensure(close(f.backlash_rad, 100.0 * p.nominal_backlash_rad, 1e-9), "backlash 100x")?;
    ensure(f.shorted_fraction == [0.5; 3] && f.eccentricity == 0.5, "full shorts/eccentricity")?;
    ensure(close(f.kp_a_per_rad, 1.5 * p.kp_a_per_rad, 1e-3), "gain 1.5x")?;
    let z = FaultVector([0.0; 8]).physical(&p);
    ensure(close(z.eccentricity_phase_rad, -core::f32::consts::PI, 1e-6), "phase -pi")
}

fn fault_vector_paper_error() -> Result<(), &'static str> {
    // Table I (GA, small friction fault), first row: Err% 1.6358
    let truth = FaultVector([0.25, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]);
    let est = FaultVector([0.2446, 0.0009, 0.0030, 0.0023, 0.0003, 0.0015, 0.7045, 0.4851]);
    ensure(close(est.paper_error_percent(&truth), 1.6358, 0.01), "Err% of Table I row 1")
}

fn profile_standard_values() -> Result<(), &'static str> {
    let p = Profile::STANDARD;
    ensure(p.command_rad(0.005) == 0.0, "hold 0")?;
    ensure(p.command_rad(0.1) == 0.05, "step +0.05")?;
    ensure(p.command_rad(0.2) == -0.05, "step -0.05")?;
    ensure(close(p.command_rad(0.45), -0.05 + 0.2 * 0.15, 1e-6), "ramp")?;
    ensure(close(p.command_rad(0.6625), 0.02, 1e-5), "sine peak")?;
    ensure(p.duration_s() == 0.85, "duration")
}

// ---- model, conditioning, fitness, optimizer (the identification stages, on the MCU) ----------

fn model_step_response_settles() -> Result<(), &'static str> {
    let m = MonitorModel::new(&EmaParams::NOMINAL, &FaultVector::HEALTHY);
    let mut s = ModelState::at_rest();
    let mut peak = 0.0f32;
    for _ in 0..3000 {
        m.step(&mut s, 0.05);
        peak = if s.surface_angle_rad > peak { s.surface_angle_rad } else { peak };
    }
    ensure(peak < 0.055, "overshoot above 10 %")?;
    ensure(close(s.surface_angle_rad, 0.05, 0.003), "does not settle on the command")
}

fn model_short_circuit_shape_function() -> Result<(), &'static str> {
    let m = MonitorModel::new(&EmaParams::NOMINAL, &FaultVector([0.0, 0.0, 0.4, 0.0, 0.0, 0.0, 0.5, 0.5]));
    let mut s = ModelState::at_rest();
    s.hall_angle_rad = 0.5; // sector 0: phases A and B conduct
    let (k, r, _) = m.shape(&s);
    ensure(close(k, 0.13 * 1.8, 1e-6) && close(r, 0.9, 1e-6), "pair with the shorted phase")?;
    s.hall_angle_rad = 2.6; // sector 2: phases B and C
    let (k, r, _) = m.shape(&s);
    ensure(close(k, 0.26, 1e-6) && close(r, 1.0, 1e-6), "healthy pair")
}

fn conditioning_refuses_bad_input() -> Result<(), &'static str> {
    let mut t = ConditionedWindow::<60>::new();
    ensure(t.push(f32::NAN, 0.0, 0.0) == Err(ConditioningError::NonFinite), "NaN accepted")?;
    ensure(t.finish() == Err(ConditioningError::TooShort), "empty trace accepted")?;
    for _ in 0..60 * DECIMATION {
        t.push(1.0, -1.0, 0.0).map_err(|_| "push")?;
    }
    ensure(t.finish() == Err(ConditioningError::NoExcitation), "flat trace accepted")
}

/// A noise-free "measurement" made by the monitor model itself.
fn self_trace(k: &FaultVector, t: &mut ConditionedWindow<600>) -> Result<(), &'static str> {
    let mut ok = true;
    simulate_window(&EmaParams::NOMINAL, &Profile::STANDARD, k, 600, |_, i, _| {
        for _ in 0..DECIMATION {
            ok &= t.push(i, -i, 0.0).is_ok();
        }
        true
    });
    ensure(ok, "push")?;
    t.finish().map_err(|_| "finish")
}

fn fitness_at_the_true_vector_is_the_windows_rounding() -> Result<(), &'static str> {
    let truth = FaultVector([0.3, 0.0, 0.2, 0.0, 0.0, 0.0, 0.5, 0.4]);
    let mut t = ConditionedWindow::new();
    self_trace(&truth, &mut t)?;
    let fit =
        EquivalentCurrentFit::new(&t, EmaParams::NOMINAL, &Profile::STANDARD).map_err(|_| "trace not finished")?;
    // only the window's rounding: each sample within half a step of the model's, weights ≤ 1
    let rounding_a = 0.5 * t.step_a();
    ensure(fit.error(&truth) <= rounding_a * rounding_a, "more than the rounding at the truth")?;
    let mut other = truth;
    other.0[7] = 0.6;
    ensure(fit.error(&other) > 1e-6, "gain change invisible")
}

struct Sphere;
impl Objective<3> for Sphere {
    fn cost(&mut self, x: &[f32; 3], _abandon_above: f32) -> f32 {
        (x[0] - 0.3) * (x[0] - 0.3) + (x[1] - 0.7) * (x[1] - 0.7) + (x[2] - 0.1) * (x[2] - 0.1)
    }
}

fn pso_minimises_a_sphere() -> Result<(), &'static str> {
    let mut pso: ParticleSwarm<16, 3> =
        ParticleSwarm::new(Bounds::unit(), PsoConfig::default(), 7).map_err(|_| "config refused")?;
    run(&mut pso, &mut Sphere, 3000);
    let (x, cost) = pso.best();
    ensure(cost < 1e-6, "not converged")?;
    ensure(close(x[0], 0.3, 1e-3) && close(x[1], 0.7, 1e-3) && close(x[2], 0.1, 1e-3), "wrong minimum")
}

fn identification_refuses_impossible_config() -> Result<(), &'static str> {
    let mut t = ConditionedWindow::new();
    self_trace(&FaultVector::HEALTHY, &mut t)?;
    let mut params = EmaParams::NOMINAL;
    params.motor_inertia_kg_m2 = -1.0;
    let r = Identification::<600, 8>::new(&t, params, &Profile::STANDARD, &IdentifyConfig::default());
    ensure(matches!(r, Err(MonitorError::Params)), "negative inertia accepted")?;
    let config = IdentifyConfig { max_iterations: 0, ..IdentifyConfig::default() };
    let r = Identification::<600, 8>::new(&t, EmaParams::NOMINAL, &Profile::STANDARD, &config);
    ensure(matches!(r, Err(MonitorError::Optimizer(_))), "zero iterations accepted")
}

/// The standard profile sampled at the control rate (8500 samples, 34 000 bytes, in a static)
/// drives the on-board identification of the built-in trace to the same report, bit for bit, as
/// the profile itself; a short budget (3 iterations, 60 evaluations after them) keeps the test
/// quick.
fn identification_under_the_sampled_standard_profile() -> Result<(), &'static str> {
    // filled in place in a static: the 34 000 bytes never pass through the stack
    let command = cortex_m::singleton!(: SampledCommand<8500> = SampledCommand::EMPTY).ok_or("command buffer taken")?;
    command.load_profile(&Profile::STANDARD, 1, &EmaParams::NOMINAL).map_err(|_| "sampling refused")?;
    let command: &SampledCommand<8500> = command;
    ensure(manoeuvre_frames(command, &EmaParams::NOMINAL) == 8500, "sampled frame count")?;
    let mut trace = ConditionedWindow::<ONBOARD_WINDOW>::new();
    acquire_built_in(&mut trace)?;
    let config =
        IdentifyConfig { max_iterations: 3, selection_polish_max_evaluations: 60, ..IdentifyConfig::onboard() };
    let by_profile = short_identification(&trace, Command::Profile(&Profile::STANDARD), &config)?;
    let by_samples = short_identification(&trace, command.as_command(), &config)?;
    ensure(by_profile.evaluations >= 150, "budget not spent")?;
    ensure(by_samples == by_profile, "the sampled command gives another report")
}

/// One identification of `trace` under `command`, run to its end.
#[inline(never)]
fn short_identification(
    trace: &ConditionedWindow<ONBOARD_WINDOW>,
    command: Command<'_>,
    config: &IdentifyConfig,
) -> Result<HealthReport, &'static str> {
    let mut id = Identification::<'_, ONBOARD_WINDOW, 50>::new(trace, EmaParams::NOMINAL, command, config)
        .map_err(|_| "identification refused")?;
    id.run(u32::MAX);
    Ok(id.report())
}

// ---- persisted health record -------------------------------------------------------------------

/// The self-test's flash: 4 pages of 2 KiB in RAM (two records per page).
type TestFlash = RamFlash<4, 2048>;
const TEST_RANGE: core::ops::Range<u32> = 0..TestFlash::CAPACITY as u32;

/// A record after `flights` flights of growing friction.
fn record_after(flights: u32) -> HealthRecord {
    let mut r = HealthRecord::new();
    for f in 0..flights {
        let x = 0.02 * f as f32;
        let k = FaultVector([x, 0.5 * x, 0.0, 0.0, 0.0, 0.01, 0.5, 0.5]);
        r.new_flight(&HealthReport::new(k, &EmaParams::NOMINAL, 0.01, 100, 10, None), f == 0);
    }
    r
}

fn test_store(flash: TestFlash) -> Result<HealthStore<TestFlash>, &'static str> {
    HealthStore::new(flash, TEST_RANGE).map_err(|_| "range refused")
}

/// `true` when `loaded` is `Ok(Some(r))` with `r` bit-equal to `expected`, or `Ok(None)` for `None`.
fn loads(loaded: Result<Option<HealthRecord>, StoreError>, expected: Option<&HealthRecord>) -> bool {
    match (loaded, expected) {
        (Ok(Some(a)), Some(b)) => a.same_bits(b),
        (Ok(None), None) => true,
        _ => false,
    }
}

/// A flash holding the saves of `record_after(1..=n)`.
fn flash_with(n: u32) -> Result<TestFlash, &'static str> {
    let mut s = test_store(TestFlash::new())?;
    for i in 1..=n {
        s.save(&record_after(i)).map_err(|_| "save")?;
    }
    Ok(s.into_flash())
}

fn persist_save_load_reset() -> Result<(), &'static str> {
    let mut s = test_store(TestFlash::new())?;
    ensure(loads(s.load(), None), "a fresh flash holds a record")?;
    for i in 1..=5 {
        s.save(&record_after(i)).map_err(|_| "save")?;
        ensure(loads(s.load(), Some(&record_after(i))), "load differs from save")?;
    }
    let mut s = test_store(s.into_flash())?; // power cycle
    ensure(loads(s.load(), Some(&record_after(5))), "record lost across a power cycle")?;
    s.reset().map_err(|_| "reset")?;
    ensure(loads(s.load(), None), "record survives the maintenance reset")
}

/// A power cut at every byte of a save that changes page (two earlier saves fill page 0): the
/// old record or the new one loads after power returns, and the store works again.
fn persist_power_cut_keeps_a_record() -> Result<(), &'static str> {
    let base = flash_with(2)?;
    let (old, new, next) = (record_after(2), record_after(3), record_after(4));
    let cost = {
        let mut s = test_store(base.clone())?;
        s.save(&new).map_err(|_| "save")?;
        s.into_flash().touched_bytes() - base.touched_bytes()
    };
    ensure(cost > HealthRecord::ENCODED_LEN as u32, "save cost")?;
    for cut in 0..cost {
        let mut flash = base.clone();
        flash.cut_power_after(cut);
        let mut s = test_store(flash)?;
        ensure(s.save(&new).is_err(), "a cut save succeeded")?;
        let mut flash = s.into_flash();
        flash.power_on();
        let mut s = test_store(flash)?;
        let loaded = s.load();
        ensure(loads(loaded, Some(&old)) || loads(loaded, Some(&new)), "neither the old nor the new record")?;
        s.save(&next).map_err(|_| "save after the cut")?;
        ensure(loads(s.load(), Some(&next)), "load after the repair")?;
    }
    Ok(())
}

/// Each byte of the newest record's data corrupted in turn: the load never returns it (it gives
/// the previous record).
fn persist_corrupt_byte_is_detected() -> Result<(), &'static str> {
    let base = flash_with(3)?;
    let mut encoded = [0u8; HealthRecord::ENCODED_LEN];
    record_after(3).encode(&mut encoded).map_err(|_| "encode")?;
    let at = (0..TestFlash::CAPACITY - encoded.len())
        .find(|&a| (0..encoded.len()).all(|i| base.byte(a + i) == Some(encoded[i])))
        .ok_or("newest copy not in flash")?;
    for offset in at..at + encoded.len() {
        let mut flash = base.clone();
        flash.flip(offset, 0x10);
        let loaded = test_store(flash)?.load();
        ensure(!loads(loaded, Some(&record_after(3))), "corrupted record returned")?;
        ensure(loads(loaded, Some(&record_after(2))) || loaded.is_err(), "not the previous record")?;
    }
    Ok(())
}

/// A flash that no longer writes: save and reset are error values, the stored record still loads.
fn persist_dead_flash_is_an_error() -> Result<(), &'static str> {
    let mut flash = flash_with(1)?;
    flash.cut_power_after(0);
    let mut s = test_store(flash)?;
    ensure(s.save(&record_after(2)) == Err(StoreError::Flash(FlashFault::Other)), "save on a dead flash")?;
    ensure(s.reset() == Err(StoreError::Flash(FlashFault::Other)), "reset on a dead flash")?;
    ensure(loads(s.load(), Some(&record_after(1))), "record lost")
}

/// The warm start on target: from the firmware's cold diagnosis of the built-in trace (its fault
/// vector bits, `README.md`), the warm identification of the same recording finishes with the
/// same status, no probe fired, and a small fraction of the cold evaluations (1611).
fn warm_start_from_the_cold_report() -> Result<(), &'static str> {
    let mut trace = ConditionedWindow::<ONBOARD_WINDOW>::new();
    acquire_built_in(&mut trace)?;
    let prior = [0x3e7fb45d, 0, 0, 0, 0, 0, 0x3f000000, 0x3efe3b61].map(f32::from_bits);
    let (report, warm) = warm_identification(&trace, &prior)?;
    ensure(report.status == ema_monitor::health::Status::Degraded, "another status than the cold DEGRADED")?;
    ensure(close(report.faults.0[0], prior[0], 0.01), "friction moved")?;
    ensure(warm.fired == 0, "a probe fired on the same recording")?;
    ensure(report.evaluations < 200, "too many evaluations for a warm start")
}

/// Acquires and conditions the built-in trace into `trace` as the firmware does (replay ADC,
/// nominal calibration, default checks).
fn acquire_built_in(trace: &mut ConditionedWindow<ONBOARD_WINDOW>) -> Result<(), &'static str> {
    let t = PackedTrace::parse(BUILT_IN).map_err(|_| "built-in trace invalid")?;
    let mut reader = PhaseCurrentReader::new(
        ReplayAdc::new(t),
        (PhaseA, PhaseB, PhaseC),
        Calibration::NOMINAL,
        AcquisitionConfig::DEFAULT,
    )
    .map_err(|_| "config refused")?;
    diagnosis::acquire(&mut reader, trace).map_err(|_| "acquisition refused")?;
    Ok(())
}

/// A warm identification of `trace` from `prior`, run to its end.
#[inline(never)]
fn warm_identification(
    trace: &ConditionedWindow<ONBOARD_WINDOW>,
    prior: &[f32; 8],
) -> Result<(HealthReport, diagnosis::WarmReport), &'static str> {
    let config = IdentifyConfig::onboard();
    let mut id =
        Identification::<'_, ONBOARD_WINDOW, 50>::warm(trace, EmaParams::NOMINAL, &Profile::STANDARD, &config, prior)
            .map_err(|_| "warm identification refused")?;
    id.run(u32::MAX);
    Ok((id.report(), id.warm_report().ok_or("no warm report")?))
}
