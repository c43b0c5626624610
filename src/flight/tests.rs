//! The flight API over several flights, on units off nominal.

use super::*;
use crate::diagnosis::ColdReason;
use crate::faults::FaultVector;
use crate::Profile;

/// Units off the drawing: winding resistance, EMF constant and dynamic friction a few
/// percent off nominal, as production tolerances spread them.
fn units() -> [EmaParams; 2] {
    let n = EmaParams::NOMINAL;
    [
        EmaParams {
            phase_resistance_ohm: 1.04 * n.phase_resistance_ohm,
            phase_emf_constant_v_s_per_rad: 0.97 * n.phase_emf_constant_v_s_per_rad,
            ..n
        },
        EmaParams {
            phase_emf_constant_v_s_per_rad: 1.02 * n.phase_emf_constant_v_s_per_rad,
            dynamic_friction_n_m: 1.1 * n.dynamic_friction_n_m,
            ..n
        },
    ]
}

/// Frames of `unit` with faults `truth`, from the monitor model itself, with the nominal
/// actuator's noise (0.29 A of controller jitter on the pair current, 0.02 A per sensor).
struct Frames {
    frames: [[f32; 3]; 8500],
    next: usize,
}

impl Frames {
    fn of(unit: &EmaParams, truth: &FaultVector, seed: u64) -> Self {
        let mut frames = [[0.0f32; 3]; 8500];
        let mut next = 0;
        crate::test_traces::noisy_frames(unit, truth, seed, |f| {
            if let Some(slot) = frames.get_mut(next) {
                *slot = f;
            }
            next += 1;
        });
        Self { frames, next: 0 }
    }
}

impl PhaseCurrents for Frames {
    fn read_frame(&mut self) -> Result<crate::acquisition::PhaseFrame, crate::acquisition::AcquisitionError> {
        let [ia_a, ib_a, ic_a] = *self.frames.get(self.next).ok_or(crate::acquisition::AcquisitionError::EndOfData)?;
        self.next += 1;
        Ok(crate::acquisition::PhaseFrame { ia_a, ib_a, ic_a, codes: [0; 3] })
    }
}

#[test]
fn flights_start_cold_then_warm_and_pool_their_evidence_on_units_off_nominal() {
    let truth = FaultVector([0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]);
    for (u, unit) in units().iter().enumerate() {
        // the unit's own parameters: what commissioning gives the monitor
        let monitor = HealthMonitor::onboard(*unit, &Profile::STANDARD, ModelEffects::NONE).unwrap();
        let mut record = HealthRecord::new();
        for flight in 1..=3u32 {
            let mut trace = ConditionedWindow::new();
            let mut source = Frames::of(unit, &truth, 100 * u as u64 + u64::from(flight));
            let acquired = monitor.acquire(&mut source, &mut trace, 10_000.0).unwrap();
            assert_eq!(acquired.summary.frames, 8500);
            let f = monitor.diagnose(&trace, &acquired, &mut record, &mut NoHooks).unwrap();
            let expected = if flight == 1 { Start::Cold(ColdReason::NoPrior) } else { Start::Warm };
            assert_eq!((f.number, f.start), (flight, expected), "unit {u}");
            assert_eq!(f.cold, flight == 1);
            assert!(f.report.status.is_diagnosis(), "unit {u} flight {flight}: {:?}", f.report.status);
            assert!(f.report.uncertainty.is_some());
            let friction = f.report.faults.0[0];
            assert!((friction - 0.3).abs() < 0.03, "unit {u} flight {flight}: friction {friction}");
            assert_eq!(f.pooled.map(|p| p.evidence.flights), Some(flight));
            assert_eq!((record.flights(), record.flights_since_cold()), (flight, flight - 1));
            assert_eq!(record.faults(), f.recorded_report().faults);
        }
    }
}

/// The record's call reaches the hooks between its model runs, so that a firmware feeds its
/// watchdog there: before the fitness's own run (its fast-regime intervals) and before each
/// evaluation of the flight's evidence and of the refits, on the drawing's unit and a drawn one.
#[test]
fn the_record_call_reaches_the_hooks_between_its_model_runs() {
    #[derive(Default)]
    struct Counting {
        in_record: bool,
        runs: u32,
        elsewhere: u32,
    }
    impl FlightHooks for Counting {
        fn before_call(&mut self, call: FlightCall) {
            self.in_record = call == FlightCall::Record;
        }
        fn between_runs(&mut self, call: FlightCall) {
            if self.in_record && call == FlightCall::Record {
                self.runs += 1;
            } else {
                self.elsewhere += 1;
            }
        }
        fn after_call(&mut self, _call: FlightCall) {
            self.in_record = false;
        }
    }
    let truth = FaultVector([0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]);
    for (u, unit) in [EmaParams::NOMINAL, units()[0]].iter().enumerate() {
        let monitor = HealthMonitor::onboard(*unit, &Profile::STANDARD, ModelEffects::NONE).unwrap();
        let mut trace = ConditionedWindow::new();
        let acquired = monitor.acquire(&mut Frames::of(unit, &truth, 21 + u as u64), &mut trace, 10_000.0).unwrap();
        let mut hooks = Counting::default();
        let f = monitor.diagnose(&trace, &acquired, &mut HealthRecord::new(), &mut hooks).unwrap();
        let pooled = f.pooled.expect("a diagnosis adds its evidence");
        assert_eq!(hooks.elsewhere, 0, "unit {u}");
        assert_eq!(hooks.runs, 1 + pooled.flight.evaluations + pooled.refit_evaluations, "unit {u}");
    }
}

#[test]
fn the_flight_api_reports_what_the_identification_reports() {
    let unit = units()[0];
    let truth = FaultVector([0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]);
    let monitor = HealthMonitor::onboard(unit, &Profile::STANDARD, ModelEffects::NONE).unwrap();
    let mut trace = ConditionedWindow::new();
    let acquired = monitor.acquire(&mut Frames::of(&unit, &truth, 7), &mut trace, 10_000.0).unwrap();
    let mut record = HealthRecord::new();
    let flight = monitor.diagnose(&trace, &acquired, &mut record, &mut NoHooks).unwrap();
    let config = IdentifyConfig::onboard();
    let mut id: Identification<'_, ONBOARD_WINDOW, ONBOARD_POPULATION> =
        Identification::new(&trace, unit, &Profile::STANDARD, &config).unwrap();
    id.run(u32::MAX);
    let direct = id.with_uncertainty(id.report());
    assert_eq!(flight.report.faults.0.map(f32::to_bits), direct.faults.0.map(f32::to_bits));
    assert_eq!(flight.report.fitness.to_bits(), direct.fitness.to_bits());
    assert_eq!(flight.report.evaluations, direct.evaluations);
    assert_eq!(flight.report.uncertainty, direct.uncertainty);
}

#[test]
fn a_refused_flight_leaves_the_record_as_it_was_and_a_bad_rate_abstains() {
    let unit = units()[1];
    let monitor = HealthMonitor::onboard(unit, &Profile::STANDARD, ModelEffects::NONE).unwrap();
    let mut trace = ConditionedWindow::new();
    let healthy = FaultVector::HEALTHY;
    let acquired = monitor.acquire(&mut Frames::of(&unit, &healthy, 3), &mut trace, 8_000.0).unwrap();
    let mut record = HealthRecord::new();
    let f = monitor.diagnose(&trace, &acquired, &mut record, &mut NoHooks).unwrap();
    assert_eq!(f.report.status, Status::Inconclusive(Abstain::RateMismatch));
    assert_eq!(record.flights(), 1);
    assert!(!record.has_prior(), "an abstention is no prior for a warm start");
    // a window the acquisition did not close is refused, and nothing is recorded
    let before = record;
    let open = ConditionedWindow::new();
    let e = monitor.diagnose(&open, &acquired, &mut record, &mut NoHooks).unwrap_err();
    assert!(matches!(e, MonitorError::Conditioning(_)), "{e:?}");
    assert!(record.same_bits(&before));
    let bad = EmaParams { phase_resistance_ohm: -1.0, ..unit };
    assert_eq!(HealthMonitor::onboard(bad, &Profile::STANDARD, ModelEffects::NONE).unwrap_err(), MonitorError::Params);
}

#[test]
fn a_record_of_other_parameters_or_another_unit_is_archived_and_a_new_history_starts() {
    let [a, b] = units();
    let monitor = HealthMonitor::onboard(a, &Profile::STANDARD, ModelEffects::NONE).unwrap();
    let report = crate::health::HealthReport::new(FaultVector::HEALTHY, &a, 0.01, 100, 10, None);
    // a new record takes the monitor's identity, and stays
    let mut record = HealthRecord::new();
    assert!(monitor.adopt(&mut record).is_none());
    assert_eq!(record.identity(), monitor.identity());
    record.new_flight(&report, true);
    record.new_flight(&report, false);
    let own = record;
    assert!(monitor.adopt(&mut record).is_none());
    assert!(record.same_bits(&own));
    // other parameters, another unit's serial, a record that does not say: archived
    let others =
        [HealthMonitor::onboard(b, &Profile::STANDARD, ModelEffects::NONE).unwrap(), monitor.with_unit_serial(7)];
    for other in others {
        assert_ne!(other.identity(), monitor.identity());
        let mut loaded = own;
        let mut trace = ConditionedWindow::new();
        let acquired = other.acquire(&mut Frames::of(&b, &FaultVector::HEALTHY, 5), &mut trace, 10_000.0).unwrap();
        assert_eq!(
            other.diagnose(&trace, &acquired, &mut loaded, &mut NoHooks).unwrap_err(),
            MonitorError::ForeignRecord
        );
        assert!(loaded.same_bits(&own), "a refused flight leaves the record as it was");
        let archived = other.adopt(&mut loaded).expect("the old history is handed back");
        assert!(archived.same_bits(&own));
        assert_eq!((loaded.flights(), loaded.identity()), (0, other.identity()));
        let f = other.diagnose(&trace, &acquired, &mut loaded, &mut NoHooks).unwrap();
        assert_eq!((f.number, f.start), (1, Start::Cold(ColdReason::NoPrior)));
    }
    let mut encoded = [0u8; HealthRecord::ENCODED_LEN];
    own.encode(&mut encoded).unwrap();
    encoded[0] = 1;
    let mut version_1 = HealthRecord::decode(&encoded[..752]).unwrap(); // version 1: 752 bytes
    assert_eq!(monitor.adopt(&mut version_1).map(|r| r.flights()), Some(2));
    assert_eq!(version_1.identity(), monitor.identity());
}

#[test]
fn a_flight_with_a_temperature_is_diagnosed_at_that_temperature() {
    let truth = FaultVector([0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]);
    for (u, unit) in units().iter().enumerate() {
        let monitor = HealthMonitor::onboard(*unit, &Profile::STANDARD, ModelEffects::NONE).unwrap();
        for temperature_c in [-35.0f32, 65.0] {
            let hot_or_cold = unit.at_temperature(temperature_c);
            let mut trace = ConditionedWindow::new();
            let seed = 40 + u as u64;
            let acquired = monitor.acquire(&mut Frames::of(&hot_or_cold, &truth, seed), &mut trace, 10_000.0).unwrap();
            let read = Acquired { temperature_c, ..acquired };
            let with = monitor.diagnose(&trace, &read, &mut HealthRecord::new(), &mut NoHooks).unwrap();
            let without = monitor.diagnose(&trace, &acquired, &mut HealthRecord::new(), &mut NoHooks).unwrap();
            assert_eq!(with.temperature_c.to_bits(), temperature_c.to_bits());
            assert!(without.temperature_c.is_nan());
            // the largest error over the eight parameters: a phantom short counts
            let error =
                |f: &Flight| f.report.faults.0.iter().zip(&truth.0).map(|(k, t)| (k - t).abs()).fold(0.0f32, f32::max);
            assert!(with.report.status.is_diagnosis(), "unit {u} at {temperature_c}: {:?}", with.report.status);
            assert!(error(&with) < 0.03, "unit {u} at {temperature_c}: {:?}", with.report.faults.0);
            assert!(
                !without.report.status.is_diagnosis() || error(&without) > 2.0 * error(&with),
                "unit {u} at {temperature_c}: the temperature changes nothing ({:?} without, {:?} with)",
                without.report.faults.0,
                with.report.faults.0
            );
        }
    }
}

/// Hooks that keep the commissioning windows in a RAM flash, as a firmware does in its own.
struct FlashHooks {
    flash: Box<crate::persist::RamFlash<8, 4096>>,
    buffer: Vec<u8>,
}

impl FlashHooks {
    fn new() -> Self {
        Self {
            flash: Box::new(crate::persist::RamFlash::new()),
            buffer: vec![0; crate::persist::window_encoded_len(2304)],
        }
    }

    fn store(&mut self) -> crate::persist::HealthStore<&mut crate::persist::RamFlash<8, 4096>> {
        let range = 0..crate::persist::RamFlash::<8, 4096>::CAPACITY as u32;
        crate::persist::HealthStore::new(&mut *self.flash, range).unwrap()
    }
}

impl FlightHooks for FlashHooks {
    fn keep_window<const W: usize>(&mut self, slot: u8, window: &ConditionedWindow<W>, temperature_c: f32) -> bool {
        let mut buffer = core::mem::take(&mut self.buffer);
        let kept = self.store().keep_window(slot, window, temperature_c, &mut buffer).is_ok();
        self.buffer = buffer;
        kept
    }

    fn load_window<const W: usize>(&mut self, slot: u8, out: &mut ConditionedWindow<W>) -> Option<f32> {
        let mut buffer = core::mem::take(&mut self.buffer);
        let loaded = self.store().load_window(slot, out, &mut buffer).ok().flatten();
        self.buffer = buffer;
        loaded
    }
}

/// A flight of `unit` with faults `truth` at `temperature_c`, read as a firmware reads it.
#[cfg(feature = "commissioning")]
fn fly_at(
    monitor: &HealthMonitor<'_>,
    unit: &EmaParams,
    truth: &FaultVector,
    temperature_c: f32,
    seed: u64,
    record: &mut HealthRecord,
    hooks: &mut impl FlightHooks,
) -> Flight {
    let mut trace = ConditionedWindow::new();
    let frames = &mut Frames::of(&unit.at_temperature(temperature_c), truth, seed);
    let acquired = monitor.acquire(frames, &mut trace, 10_000.0).unwrap();
    let flight = monitor.diagnose(&trace, &Acquired { temperature_c, ..acquired }, record, hooks).unwrap();
    // a power cycle between flights: the record goes through its encoding
    let mut bytes = [0u8; HealthRecord::ENCODED_LEN];
    record.encode(&mut bytes).unwrap();
    *record = HealthRecord::decode(&bytes).unwrap();
    flight
}

/// The board's flight image builds no effect terms (feature `effect-terms`): a monitor asked
/// for one is refused, on the drawing's unit and a drawn one, and the model without them is
/// the paper's model.
#[cfg(not(feature = "effect-terms"))]
#[test]
fn without_effect_terms_built_a_monitor_with_effects_is_refused() {
    use crate::effects::EffectId;
    let cogging = ModelEffects::NONE.with(EffectId::Cogging, 0.5).unwrap();
    for unit in [EmaParams::NOMINAL, units()[0]] {
        let refused = HealthMonitor::onboard(unit, &Profile::STANDARD, cogging).err();
        assert_eq!(refused, Some(MonitorError::EffectsNotBuilt));
        let config =
            crate::diagnosis::IdentifyConfig { effects: cogging, ..crate::diagnosis::IdentifyConfig::onboard() };
        let trace = crate::test_traces::noisy_trace(&unit, &FaultVector::HEALTHY, 3);
        let fit = crate::diagnosis::configured_fit(&trace, unit, &Profile::STANDARD, &config).err();
        assert_eq!(fit, Some(MonitorError::EffectsNotBuilt));
        assert!(HealthMonitor::onboard(unit, &Profile::STANDARD, ModelEffects::NONE).is_ok());
    }
}

/// A build without commissioning (the board's flight image) meets a record that a build with it
/// left collecting: the flight is refused and the record stays as it was, windows and all; a
/// record not commissioning is diagnosed as usual, and a new one does not start commissioning.
#[cfg(not(feature = "commissioning"))]
#[test]
fn without_commissioning_built_a_collecting_record_is_refused_and_kept() {
    use crate::persist::Commissioning;
    let unit = units()[0];
    let monitor = HealthMonitor::onboard(unit, &Profile::STANDARD, ModelEffects::NONE).unwrap();
    let mut trace = ConditionedWindow::new();
    let truth = FaultVector([0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]);
    let acquired = monitor.acquire(&mut Frames::of(&unit, &truth, 11), &mut trace, 10_000.0).unwrap();
    let mut record = HealthRecord::for_unit(monitor.identity());
    record.set_commissioning(Commissioning::Collecting { planned: 3, kept: 1 });
    let before = record;
    let e = monitor.diagnose(&trace, &acquired, &mut record, &mut NoHooks).unwrap_err();
    assert_eq!(e, MonitorError::CommissioningNotBuilt);
    assert!(record.same_bits(&before));
    let mut fresh = HealthRecord::new();
    let f = monitor.diagnose(&trace, &acquired, &mut fresh, &mut NoHooks).unwrap();
    assert_eq!((f.commissioning, fresh.commissioning()), (None, Commissioning::Off));
    assert!(f.report.status.is_diagnosis(), "{:?}", f.report.status);
    assert!((f.report.faults.0[0] - 0.2).abs() < 0.03, "{:?}", f.report.faults.0);
}

#[cfg(feature = "commissioning")]
#[test]
fn a_unit_commissioned_over_its_first_flights_is_diagnosed_against_its_own_baseline() {
    use crate::persist::Commissioning;
    use crate::unit::Tolerances;
    let t = Tolerances::TYPICAL;
    let units = [
        t.apply(&EmaParams::NOMINAL, &[1.5, -1.0, 2.0, 1.0, -1.0, 1.0, -1.5, 2.0, -1.0, 0.5, 1.0]),
        t.apply(&EmaParams::NOMINAL, &[-2.0, 1.0, -1.5, -1.5, 0.5, -1.0, 1.0, -1.0, 1.0, -0.5, -1.5]),
    ];
    let healthy = FaultVector::HEALTHY;
    for (u, unit) in units.iter().enumerate() {
        let monitor = HealthMonitor::onboard(EmaParams::NOMINAL, &Profile::STANDARD, ModelEffects::NONE)
            .unwrap()
            .with_commissioning(3, t)
            .unwrap();
        let (mut record, mut hooks) = (HealthRecord::new(), FlashHooks::new());
        let seed = 200 + 10 * u as u64;
        for (flight, temperature_c) in [(1u32, 20.0f32), (2, -10.0)] {
            let f = fly_at(&monitor, unit, &healthy, temperature_c, seed + u64::from(flight), &mut record, &mut hooks);
            assert_eq!(f.report.status, Status::Inconclusive(Abstain::Commissioning), "unit {u} flight {flight}");
            let kept = Commissioning::Collecting { planned: 3, kept: flight as u8 };
            assert_eq!((f.commissioning, record.commissioning()), (Some(kept), kept));
            assert!(record.history(crate::faults::FaultMode::Friction).is_empty());
        }
        let third = fly_at(&monitor, unit, &healthy, 45.0, seed + 3, &mut record, &mut hooks);
        let Some(Commissioning::Commissioned(baseline)) = third.commissioning else {
            panic!("unit {u}: {:?}, report {:?} {:?}", third.commissioning, third.report.status, third.report.faults.0)
        };
        assert_eq!(third.report.status, Status::Healthy, "unit {u}");
        assert_eq!(record.baseline(), Some(&baseline));
        assert!(baseline.resolved[2], "the EMF constant shows in every flight: {:?}", baseline.resolved);
        // later flights, hot and cold, are diagnosed against the baseline: healthy, and a
        // fault is found near its size (within 0.05: where the manoeuvre does not resolve the
        // static friction, the dynamic friction of the baseline carries its share, and a
        // friction fault reads smaller by that share)
        for (flight, temperature_c, truth) in
            [(4u64, 60.0f32, healthy), (5, -30.0, FaultVector([0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]))]
        {
            let f = fly_at(&monitor, unit, &truth, temperature_c, seed + flight, &mut record, &mut hooks);
            assert_eq!(f.commissioning, None);
            let expected = if truth == healthy { Status::Healthy } else { Status::Degraded };
            assert_eq!(f.report.status, expected, "unit {u} flight {flight}: {:?}", f.report.faults.0);
            let error = f.report.faults.0.iter().zip(&truth.0).map(|(k, t)| (k - t).abs()).fold(0.0f32, f32::max);
            assert!(error < 0.05, "unit {u} flight {flight}: {:?}", f.report.faults.0);
        }
        assert_eq!(record.flights(), 5);
    }
}

#[cfg(feature = "commissioning")]
#[test]
fn a_fault_present_at_commissioning_is_not_baked_into_the_baseline() {
    use crate::persist::{Commissioning, CommissioningRefusal};
    let unit = units()[0];
    let friction = FaultVector([0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]);
    let monitor = HealthMonitor::onboard(unit, &Profile::STANDARD, ModelEffects::NONE)
        .unwrap()
        .with_commissioning(2, crate::unit::Tolerances::TYPICAL)
        .unwrap();
    let (mut record, mut hooks) = (HealthRecord::new(), FlashHooks::new());
    fly_at(&monitor, &unit, &friction, 20.0, 301, &mut record, &mut hooks);
    let second = fly_at(&monitor, &unit, &friction, 20.0, 302, &mut record, &mut hooks);
    let Some(Commissioning::Refused(CommissioningRefusal::OutOfTolerance { param, z })) = second.commissioning else {
        panic!("{:?}", second.commissioning)
    };
    assert!((5..=7).contains(&param) && z > crate::commissioning::OUT_OF_TOLERANCE_SIGMAS, "{param} {z}");
    // diagnosed against the parameters as given, from the refusing flight on
    assert_eq!(second.report.status, Status::Degraded);
    assert!((second.report.faults.0[0] - 0.3).abs() < 0.03, "{:?}", second.report.faults.0);
    let third = fly_at(&monitor, &unit, &friction, 20.0, 303, &mut record, &mut hooks);
    assert_eq!((third.commissioning, third.report.status), (None, Status::Degraded));
    assert_eq!(record.baseline(), None);
}

#[cfg(feature = "commissioning")]
#[test]
fn commissioning_without_flash_or_on_an_unusable_flight_keeps_nothing() {
    use crate::persist::{Commissioning, CommissioningRefusal};
    let unit = units()[1];
    let t = crate::unit::Tolerances::TYPICAL;
    let base = HealthMonitor::onboard(unit, &Profile::STANDARD, ModelEffects::NONE).unwrap();
    assert_eq!(base.with_commissioning(0, t).unwrap_err(), MonitorError::Commissioning);
    assert_eq!(base.with_commissioning(4, t).unwrap_err(), MonitorError::Commissioning);
    let mut wild = t;
    wild.relative_sigma[0] = 2.0;
    assert_eq!(base.with_commissioning(2, wild).unwrap_err(), MonitorError::Commissioning);
    let monitor = base.with_commissioning(2, t).unwrap();
    let mut trace = ConditionedWindow::new();
    let acquired = monitor.acquire(&mut Frames::of(&unit, &FaultVector::HEALTHY, 9), &mut trace, 10_000.0).unwrap();
    // a flight at the wrong rate does not count
    let mut record = HealthRecord::new();
    let slow = Acquired { sample_rate_hz: 8_000.0, ..acquired };
    let f = monitor.diagnose(&trace, &slow, &mut record, &mut FlashHooks::new()).unwrap();
    assert_eq!(f.report.status, Status::Inconclusive(Abstain::RateMismatch));
    assert_eq!(record.commissioning(), Commissioning::Collecting { planned: 2, kept: 0 });
    // no flash to keep the window in: the commissioning ends without a baseline
    let f = monitor.diagnose(&trace, &acquired, &mut record, &mut NoHooks).unwrap();
    assert_eq!(f.commissioning, Some(Commissioning::Refused(CommissioningRefusal::Failed)));
    let f = monitor.diagnose(&trace, &acquired, &mut record, &mut NoHooks).unwrap();
    assert!(f.report.status.is_diagnosis() && f.commissioning.is_none(), "{:?}", f.report.status);
}

/// Sensors of a bench: each phase's zero error (counts) and gain error, as a Hall sensor on a
/// 12-bit ADC gives them.
struct BenchSensors {
    zero_counts: [f32; 3],
    gain_error: [f32; 3],
}

/// The packed trace of `rest` frames at rest, then the flight of `unit` with faults `truth`,
/// every frame through `sensors` onto the 12-bit code grid (zero current at mid-scale).
fn bench_trace(unit: &EmaParams, truth: &FaultVector, seed: u64, rest: usize, sensors: &BenchSensors) -> Vec<u8> {
    use crate::trace::{pack, packed_len, AMPS_PER_COUNT};
    let mut rng = crate::optimizer::rng::Rng::new(seed ^ 0x5EED);
    let code = |j: usize, i: f32| {
        let c = 2048.0 + sensors.zero_counts[j] + (1.0 + sensors.gain_error[j]) * i / AMPS_PER_COUNT;
        libm::roundf(c).clamp(0.0, 4095.0) as u16
    };
    let mut frames: Vec<[u16; 3]> = Vec::new();
    for _ in 0..rest {
        let i = [0.02 * rng.normal(), 0.02 * rng.normal(), 0.02 * rng.normal()];
        frames.push(core::array::from_fn(|j| code(j, i[j])));
    }
    crate::test_traces::noisy_frames(unit, truth, seed, |i| frames.push(core::array::from_fn(|j| code(j, i[j]))));
    let mut bytes = vec![0u8; packed_len(frames.len())];
    pack(&frames, 10_000, &mut bytes).unwrap();
    bytes
}

/// Acquires a packed trace as a board does: its first `rest` frames before the trigger, read as
/// rest frames, then the manoeuvre's.
fn acquire_bench(
    monitor: &HealthMonitor<'_>,
    bytes: &[u8],
    rest: usize,
    config: crate::acquisition::AcquisitionConfig,
) -> (ConditionedWindow<{ crate::diagnosis::ONBOARD_WINDOW }>, Acquired) {
    use crate::acquisition::{Calibration, PhaseA, PhaseB, PhaseC, PhaseCurrentReader, ReplayAdc};
    let adc = ReplayAdc::new(crate::trace::PackedTrace::parse(bytes).unwrap());
    let mut reader = PhaseCurrentReader::new(adc, (PhaseA, PhaseB, PhaseC), Calibration::NOMINAL, config).unwrap();
    for _ in 0..rest {
        reader.read_rest_frame().unwrap();
    }
    PhaseCurrents::start_recording(&mut reader);
    let mut trace = ConditionedWindow::new();
    let acquired = monitor.acquire(&mut reader, &mut trace, 10_000.0).unwrap();
    (trace, acquired)
}

#[test]
fn a_bench_s_sensors_are_calibrated_before_the_trigger_and_diagnose_as_ideal_ones() {
    use crate::acquisition::{AcquisitionConfig, Phase, SensorFault, ZeroSource};
    // zero errors of ±10–15 mV at 0.806 mV/count, gain errors of about 1 %
    let bench = BenchSensors { zero_counts: [18.6, -12.4, 14.9], gain_error: [0.010, -0.008, 0.005] };
    let ideal = BenchSensors { zero_counts: [0.0; 3], gain_error: [0.0; 3] };
    let rest = 600;
    let cases = [(FaultVector([0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]), 0usize), (FaultVector::HEALTHY, 1)];
    for (truth, u) in cases {
        let unit = units()[u];
        let monitor = HealthMonitor::onboard(unit, &Profile::STANDARD, ModelEffects::NONE).unwrap();
        let seed = 900 + u as u64;
        let flight = |sensors: &BenchSensors, config| {
            let (trace, acquired) =
                acquire_bench(&monitor, &bench_trace(&unit, &truth, seed, rest, sensors), rest, config);
            let (mut record, mut hooks) = (HealthRecord::new(), NoHooks);
            monitor.diagnose(&trace, &acquired, &mut record, &mut hooks).unwrap()
        };
        let reference = flight(&ideal, AcquisitionConfig::DEFAULT);
        let calibrated = flight(&bench, AcquisitionConfig::SELF_CALIBRATED);
        let s = calibrated.sensors;
        assert_eq!((s.source, s.fault, calibrated.report.refused_frames), (ZeroSource::Rest, None, 0), "{s:?}");
        for j in 0..3 {
            assert!((s.zero_shift_counts[j] - bench.zero_counts[j]).abs() < 0.5, "zero {j}: {s:?}");
        }
        assert_eq!(calibrated.report.status, reference.report.status, "unit {u}");
        let sigma = reference.report.uncertainty.unwrap().sigma;
        for k in 0..8 {
            let (a, b) = (calibrated.report.faults.0[k], reference.report.faults.0[k]);
            assert!((a - b).abs() <= 2.0 * sigma[k], "unit {u} k{}: {a} against {b} (1σ {})", k + 1, sigma[k]);
        }
        // the same sensors at the declared mid-scale zeros: the flight is not the ideal one
        let declared = flight(&bench, AcquisitionConfig::DEFAULT);
        assert_ne!(declared.report.status, reference.report.status, "unit {u}");
        // ten times the correctable zero error on phase B alone
        let broken = BenchSensors { zero_counts: [18.6, -1000.0, 14.9], ..bench };
        let refused = flight(&broken, AcquisitionConfig::SELF_CALIBRATED);
        assert_eq!(refused.report.status, Status::SensorFault);
        assert!(
            matches!(refused.sensors.fault, Some(SensorFault::ZeroBeyondRange { phase: Phase::B, .. })),
            "{:?}",
            refused.sensors
        );
    }
}

#[test]
fn a_board_s_flights_accumulate_evidence_across_a_sensor_fault() {
    use crate::acquisition::AcquisitionConfig;
    // the board's sequence, through its self-calibrated acquisition and a power cycle between
    // flights: healthy, a friction fault, a flight whose phase-A sensor lost its zero, the fault
    // again
    let bench = BenchSensors { zero_counts: [-9.3, 16.2, 4.4], gain_error: [0.004, -0.006, 0.009] };
    let broken = BenchSensors { zero_counts: [700.0, 16.2, 4.4], ..bench };
    let friction = FaultVector([0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]);
    let unit = units()[1];
    let monitor = HealthMonitor::onboard(unit, &Profile::STANDARD, ModelEffects::NONE).unwrap();
    let (mut record, mut hooks) = (HealthRecord::new(), FlashHooks::new());
    let rest = 400;
    let plan = [(&FaultVector::HEALTHY, &bench), (&friction, &bench), (&friction, &broken), (&friction, &bench)];
    let mut evidence = std::vec::Vec::new();
    for (n, (truth, sensors)) in plan.into_iter().enumerate() {
        let bytes = bench_trace(&unit, truth, 700 + n as u64, rest, sensors);
        let (trace, acquired) = acquire_bench(&monitor, &bytes, rest, AcquisitionConfig::SELF_CALIBRATED);
        let f = monitor.diagnose(&trace, &acquired, &mut record, &mut hooks).unwrap();
        let mut bytes = [0u8; HealthRecord::ENCODED_LEN];
        record.encode(&mut bytes).unwrap();
        record = HealthRecord::decode(&bytes).unwrap();
        assert_eq!(f.number, n as u32 + 1);
        evidence.push(f.pooled.map(|p| p.evidence.flights));
        match n {
            0 => assert_eq!(f.report.status, Status::Healthy, "{:?}", f.report),
            2 => {
                assert_eq!(f.report.status, Status::SensorFault);
                assert_eq!(f.sensors.fault.and_then(|x| x.phase()), Some(crate::acquisition::Phase::A));
            }
            _ => {
                assert!(f.report.status.is_diagnosis(), "flight {}: {:?}", n + 1, f.report.status);
                assert!(
                    (f.recorded_report().faults.0[0] - 0.3).abs() < 0.05,
                    "flight {}: {:?}",
                    n + 1,
                    f.report.faults
                );
            }
        }
    }
    // the sensor fault pools nothing and loses nothing: the fourth flight's evidence holds three
    assert_eq!(evidence, [Some(1), Some(2), None, Some(3)]);
    assert_eq!(record.flights(), 4);
}

/// A record of `flights` diagnosed flights of `monitor`'s unit, friction growing by 0.01 a
/// flight, the first cold: a history as the store keeps it.
#[cfg(feature = "commissioning")]
fn history_of(monitor: &HealthMonitor<'_>, flights: u32) -> HealthRecord {
    let mut record = HealthRecord::for_unit(monitor.identity());
    for f in 0..flights {
        let k = FaultVector([0.01 * f as f32, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]);
        record.new_flight(&crate::health::HealthReport::new(k, monitor.params(), 0.0128, 1600, 30, None), f == 0);
    }
    record
}

/// Every byte of the hooks' flash.
#[cfg(feature = "commissioning")]
fn image(hooks: &FlashHooks) -> Vec<u8> {
    (0..crate::persist::RamFlash::<8, 4096>::CAPACITY).map(|i| hooks.flash.byte(i).unwrap()).collect()
}

/// A flight of `unit` with faults `truth` on the record `kept` holds, as a firmware flies it.
#[cfg(feature = "commissioning")]
fn fly_kept(
    monitor: &HealthMonitor<'_>,
    unit: &EmaParams,
    truth: &FaultVector,
    seed: u64,
    kept: &mut crate::persist::KeptRecord,
    hooks: &mut FlashHooks,
) -> Flight {
    let mut trace = ConditionedWindow::new();
    let acquired = monitor.acquire(&mut Frames::of(unit, truth, seed), &mut trace, 10_000.0).unwrap();
    monitor.diagnose_kept(&trace, &acquired, kept, hooks).unwrap()
}

/// The board's sequence around a read error, on a unit off nominal whose monitor commissions
/// new records: a store of twelve flights; one load fails, the flight runs cold on a new record
/// (no commissioning, no window kept), and nothing is saved, the flash byte for byte as it was;
/// the next load gives the twelve flights with their history, and the flight after it starts
/// warm from them and is saved on top. A maintenance reset then erases the history, and the
/// next flight commissions the unit again.
#[cfg(feature = "commissioning")]
#[test]
fn a_failed_load_flies_cold_saves_nothing_and_the_next_load_keeps_the_history() {
    use crate::faults::FaultMode;
    use crate::persist::{FlashFault, KeptRecord, RecordOrigin, StoreError};
    let unit = units()[0];
    let monitor = HealthMonitor::onboard(unit, &Profile::STANDARD, ModelEffects::NONE)
        .unwrap()
        .with_commissioning(2, crate::unit::Tolerances::TYPICAL)
        .unwrap();
    let truth = FaultVector([0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]);
    let k = 12;
    let history = history_of(&monitor, k);
    let mut hooks = FlashHooks::new();
    hooks.store().save(&history).unwrap();
    let before = (image(&hooks), hooks.flash.touched_bytes());

    // one read fails: a cold flight on a new record, diagnosed, not saved
    hooks.flash.fail_reads_after(0, 1);
    let mut kept = KeptRecord::from_load(hooks.store().load());
    assert_eq!(kept.origin(), RecordOrigin::Unreadable(StoreError::Flash(FlashFault::Other)));
    let f = fly_kept(&monitor, &unit, &truth, 501, &mut kept, &mut hooks);
    assert_eq!((f.number, f.start, f.cold, f.commissioning), (1, Start::Cold(ColdReason::NoPrior), true, None));
    assert!(f.report.status.is_diagnosis(), "{:?}", f.report.status);
    assert!((f.report.faults.0[0] - 0.2).abs() < 0.03, "{:?}", f.report.faults.0);
    assert_eq!((kept.record().flights(), kept.record().identity()), (1, monitor.identity()));
    assert!(kept.savable().is_none());
    assert_eq!((image(&hooks), hooks.flash.touched_bytes()), before, "nothing written: no window, no record");

    // the next load: the twelve flights; the next flight warm from them, saved on top
    let mut kept = KeptRecord::from_load(hooks.store().load());
    assert_eq!(kept.origin(), RecordOrigin::Loaded);
    assert!(kept.record().same_bits(&history));
    let f = fly_kept(&monitor, &unit, &truth, 502, &mut kept, &mut hooks);
    assert_eq!((f.number, f.start, f.commissioning), (k + 1, Start::Warm, None));
    assert!((f.recorded_report().faults.0[0] - 0.2).abs() < 0.03, "{:?}", f.report.faults.0);
    hooks.store().save(kept.savable().unwrap()).unwrap();
    let saved = hooks.store().load().unwrap().unwrap();
    assert_eq!(saved.flights(), k + 1);
    let friction = saved.history(FaultMode::Friction);
    assert!(friction.iter().take(k as usize).eq(history.history(FaultMode::Friction).iter()));
    assert_eq!(friction.latest().map(|e| e.flight), Some(k + 1));

    // a maintenance reset erases it whatever the reads do; a new record commissions again
    hooks.flash.fail_reads_after(0, 1);
    assert!(matches!(KeptRecord::from_load(hooks.store().load()).origin(), RecordOrigin::Unreadable(_)));
    hooks.store().reset().unwrap();
    let mut kept = KeptRecord::from_load(hooks.store().load());
    assert_eq!(kept.origin(), RecordOrigin::Empty);
    let f = fly_kept(&monitor, &unit, &truth, 503, &mut kept, &mut hooks);
    assert_eq!(f.report.status, Status::Inconclusive(Abstain::Commissioning));
    assert!(kept.savable().is_some_and(|r| r.flights() == 1));
}
