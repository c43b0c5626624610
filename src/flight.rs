//! One flight, end to end: the entry point both firmwares call.
//!
//! A [`HealthMonitor`] owns what does not change from one flight to the next: the actuator's
//! healthy parameters, the command that drives the monitor model, and the identification's
//! settings. A flight is two calls:
//!
//! 1. [`HealthMonitor::acquire`]: the phase currents from any [`PhaseCurrents`] source (the
//!    timer-paced sampler over an ADC on board, the replay ADC in QEMU, a recording on the host)
//!    into the conditioned window, a refused frame held at the last good one and counted;
//! 2. [`HealthMonitor::diagnose`]: the flight policy on that window and the health record:
//!    - **plan** from the record ([`HealthMonitor::plan`], [`plan_start`]): warm from the last
//!      diagnosis, or cold on the first flight, after maintenance, periodically, or after a warm
//!      result that failed its fit check;
//!    - **identify** (one objective evaluation per step, [`FlightHooks`] around each: the board
//!      feeds its watchdog there, QEMU marks the instruction-counted region around the whole);
//!    - **report** with its uncertainty (1σ and detectable-below severities), the acquisition's
//!      refused frames and the sample-rate check;
//!    - **record** the flight in the [`HealthRecord`] through the evidence pooled over flights
//!      ([`evidence::record_flight`]: a mode declared by the summed evidence is refitted in).
//!
//! The record belongs to one unit under one set of parameters ([`RecordIdentity`]: the
//! parameters' identity and the unit's serial number). [`HealthMonitor::adopt`] makes a loaded
//! record this monitor's: one made under other parameters (a firmware update with another
//! parameter file), for another unit (an actuator swapped without the maintenance reset) or of a
//! version that did not say, is handed back for the caller to archive, and a new history starts.
//! [`HealthMonitor::diagnose`] refuses a record that is not its own, so that no diagnosis is
//! pooled with another unit's evidence.
//!
//! The temperature: a flight flown at a known temperature ([`Acquired::temperature_c`]) is
//! diagnosed with the parameters at that temperature ([`EmaParams::at_temperature`]: winding
//! resistance, EMF constant, friction); without a reading, at the parameters' 20 °C.
//!
//! Saving the record to flash stays with the caller: it knows its flash and what an erase
//! costs it (the board raises its watchdog timeout).
//!
//! Nothing here allocates or panics; a refused input is a [`MonitorError`], an unusable recording
//! an honest `INCONCLUSIVE` or `SENSOR_FAULT` report.

use crate::acquisition::PhaseCurrents;
use crate::conditioning::MeasuredTrace;
use crate::health::{Abstain, HealthReport, Status};
use crate::monitor::evidence::{self, PooledFlight};
use crate::monitor::{
    self, plan_start, with_uncertainty, AcquisitionSummary, Identification, IdentifyConfig, MonitorError, Start,
    WarmReport, ONBOARD_POPULATION, ONBOARD_WINDOW,
};
use crate::optimizer::SearchStatus;
use crate::persist::{HealthRecord, RecordIdentity};
use crate::{Command, EmaParams, ModelEffects};

/// What the firmware does around the identification. Every method does nothing by default.
pub trait FlightHooks {
    /// Before the identification's first evaluation: flight `flight` (1 for the first in the
    /// record) starts as `start` says.
    fn identification_start(&mut self, flight: u32, start: Start) {
        let _ = (flight, start);
    }
    /// Before each objective evaluation (the board feeds its watchdog here).
    fn before_step(&mut self) {}
    /// After each objective evaluation.
    fn after_step(&mut self) {}
    /// After the identification's report, before its uncertainty and the record.
    fn identification_end(&mut self) {}
}

/// Hooks that do nothing: an identification run straight to its end.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoHooks;

impl FlightHooks for NoHooks {}

/// What an acquisition gave besides the window: its counts, how the frames were timed and the
/// actuator's temperature.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Acquired {
    /// Frames read, refused and the longest refused run.
    pub summary: AcquisitionSummary,
    /// The rate the frames were sampled at (Hz): the timer's on board, the recording's declared
    /// rate in a replay.
    pub sample_rate_hz: f32,
    /// Frames whose sampling came late (a tick's handler overran its period), so that the frames
    /// are not evenly spaced; 0 in a replay.
    pub late_frames: u32,
    /// The actuator's temperature during the flight (°C), NaN when none was read: the flight is
    /// then diagnosed at the parameters' 20 °C.
    pub temperature_c: f32,
}

impl Acquired {
    /// `true` when the frames came evenly at the control rate of `params`
    /// ([`monitor::rate_matches`]): what the monitor model's fixed step assumes.
    pub fn rate_ok(&self, params: &EmaParams) -> bool {
        self.late_frames == 0 && monitor::rate_matches(self.sample_rate_hz, params)
    }
}

/// One diagnosed flight ([`HealthMonitor::diagnose`]).
#[derive(Clone, Copy, Debug)]
pub struct Flight {
    /// The flight's number in the record (1 for the first after maintenance).
    pub number: u32,
    /// The temperature the flight was diagnosed at (°C), NaN when none was read.
    pub temperature_c: f32,
    /// How the identification was planned to start.
    pub start: Start,
    /// `true` when the flight counts as a cold identification in the record: planned cold, or a
    /// warm attempt that failed its fit check and went on cold in the same call.
    pub cold: bool,
    /// The flight's own report: the identification's, with its uncertainty, the acquisition's
    /// refused frames and the rate check.
    pub report: HealthReport,
    /// What the warm stages did (`None` for a cold identification).
    pub warm: Option<WarmReport>,
    /// The flight through the evidence pooled over flights (`None` when the report is no
    /// diagnosis: nothing to pool).
    pub pooled: Option<PooledFlight>,
}

impl Flight {
    /// The report the health record keeps: the pooled one (with modes declared by the summed
    /// evidence refitted in) when there is one, the flight's own otherwise.
    pub fn recorded_report(&self) -> &HealthReport {
        self.pooled.as_ref().map_or(&self.report, |p| &p.report)
    }
}

/// The monitor of one actuator: its parameters, its command and the identification's settings,
/// fixed over flights (module doc). `W` is the conditioned window's capacity, `P` the swarm's
/// size; both default to the on-board ones.
#[derive(Clone, Copy, Debug)]
pub struct HealthMonitor<'c, const W: usize = ONBOARD_WINDOW, const P: usize = ONBOARD_POPULATION> {
    params: EmaParams,
    command: Command<'c>,
    config: IdentifyConfig,
    unit_serial: u32,
}

impl<'c> HealthMonitor<'c> {
    /// The firmware's monitor, with the on-board window and swarm: [`IdentifyConfig::onboard`]
    /// with the model's effect terms
    /// `effects` ([`ModelEffects::NONE`]: the paper's model).
    pub fn onboard(
        params: EmaParams,
        command: impl Into<Command<'c>>,
        effects: ModelEffects,
    ) -> Result<Self, MonitorError> {
        Self::new(params, command, IdentifyConfig { effects, ..IdentifyConfig::onboard() })
    }
}

impl<'c, const W: usize, const P: usize> HealthMonitor<'c, W, P> {
    /// The monitor of an actuator whose healthy parameters are `params`, driven by `command`,
    /// identified with `config` (its `prior` is ignored: the health record decides warm or cold).
    /// Refuses parameters outside their range ([`EmaParams::check`]).
    pub fn new(
        params: EmaParams,
        command: impl Into<Command<'c>>,
        config: IdentifyConfig,
    ) -> Result<Self, MonitorError> {
        if params.check().is_err() {
            return Err(MonitorError::Params);
        }
        Ok(Self { params, command: command.into(), config: IdentifyConfig { prior: None, ..config }, unit_serial: 0 })
    }

    /// The same monitor for the unit of serial number `serial` (0: none given), as the integrator
    /// reads it (a label, the actuator's own memory); part of the record's identity.
    pub fn with_unit_serial(self, serial: u32) -> Self {
        Self { unit_serial: serial, ..self }
    }

    /// The identity of the records this monitor keeps: its parameters' and its unit's.
    pub fn identity(&self) -> RecordIdentity {
        RecordIdentity { params: self.params.identity(), unit_serial: self.unit_serial }
    }

    /// Makes `record` (as loaded from flash) this monitor's. A record of this monitor's identity
    /// is left as it is, and so is a new one (no flight), which takes the identity. Any other
    /// (other parameters, another unit, a record of version 1 that does not say) is replaced by
    /// a new record of this identity and returned: the caller keeps it where it stays readable
    /// ([`crate::persist::HealthStore::archive`]).
    pub fn adopt(&self, record: &mut HealthRecord) -> Option<HealthRecord> {
        let identity = self.identity();
        if record.identity() == identity {
            return None;
        }
        let old = *record;
        *record = HealthRecord::for_unit(identity);
        (old.flights() > 0).then_some(old)
    }

    /// The actuator's healthy parameters.
    pub fn params(&self) -> &EmaParams {
        &self.params
    }

    /// The command that drives the monitor model.
    pub fn command(&self) -> Command<'c> {
        self.command
    }

    /// The identification's settings.
    pub fn config(&self) -> &IdentifyConfig {
        &self.config
    }

    /// Frames of one manoeuvre at the control rate: what the sampler records after its trigger.
    pub fn frames(&self) -> u32 {
        self.command.frames(&self.params)
    }

    /// How the next flight starts, from what `record` holds: warm from its diagnosis when it has
    /// one ([`HealthRecord::has_prior`]) and no cold identification is due ([`plan_start`]).
    pub fn plan(&self, record: &HealthRecord) -> Start {
        let prior = record.has_prior().then(|| record.faults().0);
        let last_needs_cold = record.status().is_some_and(|s| matches!(s, Status::Inconclusive(_)));
        plan_start(prior.as_ref(), record.flights_since_cold(), last_needs_cold, &self.config)
    }

    /// Reads every frame of `source` into `trace` and closes the window ([`monitor::acquire`]):
    /// a refused frame is held at the last good one and counted. `sample_rate_hz` is the rate the
    /// frames come at; the late frames are 0 (a caller whose timer can overrun sets them).
    pub fn acquire<S: PhaseCurrents>(
        &self,
        source: &mut S,
        trace: &mut MeasuredTrace<W>,
        sample_rate_hz: f32,
    ) -> Result<Acquired, MonitorError> {
        let summary = monitor::acquire(source, trace)?;
        Ok(Acquired { summary, sample_rate_hz, late_frames: 0, temperature_c: f32::NAN })
    }

    /// Diagnoses one flight on the acquired `trace` and adds it to `record` (module doc): plan,
    /// identify, report with its uncertainty, record with the pooled evidence, all with the
    /// parameters at the flight's temperature. A record of another identity that holds flights
    /// is refused ([`MonitorError::ForeignRecord`]: [`HealthMonitor::adopt`] it first); a new one
    /// takes this identity. A refused identification (a trace longer than the command, settings
    /// out of range) leaves `record` as it was.
    pub fn diagnose(
        &self,
        trace: &MeasuredTrace<W>,
        acquired: &Acquired,
        record: &mut HealthRecord,
        hooks: &mut impl FlightHooks,
    ) -> Result<Flight, MonitorError> {
        if record.identity() != self.identity() {
            if record.flights() > 0 {
                return Err(MonitorError::ForeignRecord);
            }
            *record = HealthRecord::for_unit(self.identity());
        }
        let params = self.params.at_temperature(acquired.temperature_c);
        let start = self.plan(record);
        let prior = match start {
            Start::Warm => Some(record.faults().0),
            Start::Cold(_) => None,
        };
        let number = record.flights().saturating_add(1);
        hooks.identification_start(number, start);
        let identified = self.identify(trace, &params, prior, hooks);
        hooks.identification_end();
        let (report, warm) = identified?;
        let report = self.with_uncertainty(trace, &params, report).with_acquisition(&acquired.summary);
        let report = if acquired.rate_ok(&self.params) {
            report
        } else {
            report.abstaining(Status::Inconclusive(Abstain::RateMismatch))
        };
        let cold = prior.is_none() || warm.is_some_and(|w| w.cold_fallback);
        let pooled = self.record(record, trace, &params, &report, cold);
        Ok(Flight { number, temperature_c: acquired.temperature_c, start, cold, report, warm, pooled })
    }

    /// The identification, cold without a prior and warm from it, one evaluation per step with
    /// `hooks` around each. Not inlined: the identification's state lives in this frame alone,
    /// not beside the uncertainty's and the record's.
    #[inline(never)]
    fn identify(
        &self,
        trace: &MeasuredTrace<W>,
        params: &EmaParams,
        prior: Option<[f32; 8]>,
        hooks: &mut impl FlightHooks,
    ) -> Result<(HealthReport, Option<WarmReport>), MonitorError> {
        let config = IdentifyConfig { prior, ..self.config };
        // worked on in place, inside the `Result` it is built in: moving it out would put a
        // second copy of its state (tens of KiB on board) in this frame
        let mut built: Result<Identification<'_, W, P>, MonitorError> =
            Identification::new(trace, *params, self.command, &config);
        let id = match &mut built {
            Ok(id) => id,
            Err(e) => return Err(*e),
        };
        for _ in 0..u32::MAX {
            hooks.before_step();
            let status = id.step();
            hooks.after_step();
            if let SearchStatus::Done(_) = status {
                break;
            }
        }
        Ok((id.report(), id.warm_report()))
    }

    /// `report` with its uncertainty ([`with_uncertainty`]: the fitness built again, 9 model runs
    /// in lockstep). Not inlined, as [`HealthMonitor::identify`].
    #[inline(never)]
    fn with_uncertainty(&self, trace: &MeasuredTrace<W>, params: &EmaParams, report: HealthReport) -> HealthReport {
        with_uncertainty(trace, *params, self.command, &self.config, report)
    }

    /// Adds the flight's `report` to `record` through the pooled evidence
    /// ([`evidence::record_flight_on`]). Not inlined, as [`HealthMonitor::identify`].
    #[inline(never)]
    fn record(
        &self,
        record: &mut HealthRecord,
        trace: &MeasuredTrace<W>,
        params: &EmaParams,
        report: &HealthReport,
        cold: bool,
    ) -> Option<PooledFlight> {
        evidence::record_flight_on(record, trace, *params, self.command, &self.config, report, cold)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::conditioning::DECIMATION;
    use crate::faults::FaultVector;
    use crate::fitness::simulate_window;
    use crate::monitor::ColdReason;
    use crate::optimizer::rng::Rng;
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
            let mut rng = Rng::new(seed);
            let samples = frames.len() / DECIMATION;
            simulate_window(unit, &Profile::STANDARD, truth, samples, |j, i, _| {
                for f in frames.iter_mut().skip(j * DECIMATION).take(DECIMATION) {
                    let pair = i + 0.29 * rng.normal();
                    *f = [pair + 0.02 * rng.normal(), -pair + 0.02 * rng.normal(), 0.02 * rng.normal()];
                }
                true
            });
            Self { frames, next: 0 }
        }
    }

    impl PhaseCurrents for Frames {
        fn read_frame(&mut self) -> Result<crate::acquisition::PhaseFrame, crate::acquisition::AcquisitionError> {
            let [ia_a, ib_a, ic_a] =
                *self.frames.get(self.next).ok_or(crate::acquisition::AcquisitionError::EndOfData)?;
            self.next += 1;
            Ok(crate::acquisition::PhaseFrame { ia_a, ib_a, ic_a, codes: [0; 3] })
        }
    }

    #[test]
    fn flights_start_cold_then_warm_and_pool_their_evidence_on_units_off_nominal() {
        let truth = FaultVector([0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]);
        for (u, unit) in units().iter().enumerate() {
            // the unit's own parameters: what commissioning gives the monitor
            let monitor = HealthMonitor::onboard(*unit, Profile::STANDARD, ModelEffects::NONE).unwrap();
            let mut record = HealthRecord::new();
            for flight in 1..=3u32 {
                let mut trace = MeasuredTrace::new();
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

    #[test]
    fn the_flight_api_reports_what_the_identification_reports() {
        let unit = units()[0];
        let truth = FaultVector([0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]);
        let monitor = HealthMonitor::onboard(unit, Profile::STANDARD, ModelEffects::NONE).unwrap();
        let mut trace = MeasuredTrace::new();
        let acquired = monitor.acquire(&mut Frames::of(&unit, &truth, 7), &mut trace, 10_000.0).unwrap();
        let mut record = HealthRecord::new();
        let flight = monitor.diagnose(&trace, &acquired, &mut record, &mut NoHooks).unwrap();
        let config = IdentifyConfig::onboard();
        let mut id: Identification<'_, ONBOARD_WINDOW, ONBOARD_POPULATION> =
            Identification::new(&trace, unit, Profile::STANDARD, &config).unwrap();
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
        let monitor = HealthMonitor::onboard(unit, Profile::STANDARD, ModelEffects::NONE).unwrap();
        let mut trace = MeasuredTrace::new();
        let healthy = FaultVector::HEALTHY;
        let acquired = monitor.acquire(&mut Frames::of(&unit, &healthy, 3), &mut trace, 8_000.0).unwrap();
        let mut record = HealthRecord::new();
        let f = monitor.diagnose(&trace, &acquired, &mut record, &mut NoHooks).unwrap();
        assert_eq!(f.report.status, Status::Inconclusive(Abstain::RateMismatch));
        assert_eq!(record.flights(), 1);
        assert!(!record.has_prior(), "an abstention is no prior for a warm start");
        // a window the acquisition did not close is refused, and nothing is recorded
        let before = record;
        let open = MeasuredTrace::new();
        let e = monitor.diagnose(&open, &acquired, &mut record, &mut NoHooks).unwrap_err();
        assert!(matches!(e, MonitorError::Conditioning(_)), "{e:?}");
        assert!(record.same_bits(&before));
        let bad = EmaParams { phase_resistance_ohm: -1.0, ..unit };
        assert_eq!(
            HealthMonitor::onboard(bad, Profile::STANDARD, ModelEffects::NONE).unwrap_err(),
            MonitorError::Params
        );
    }

    #[test]
    fn a_record_of_other_parameters_or_another_unit_is_archived_and_a_new_history_starts() {
        let [a, b] = units();
        let monitor = HealthMonitor::onboard(a, Profile::STANDARD, ModelEffects::NONE).unwrap();
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
            [HealthMonitor::onboard(b, Profile::STANDARD, ModelEffects::NONE).unwrap(), monitor.with_unit_serial(7)];
        for other in others {
            assert_ne!(other.identity(), monitor.identity());
            let mut loaded = own;
            let mut trace = MeasuredTrace::new();
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
        let mut version_1 = HealthRecord::decode(&encoded[..HealthRecord::ENCODED_LEN - 8]).unwrap();
        assert_eq!(monitor.adopt(&mut version_1).map(|r| r.flights()), Some(2));
        assert_eq!(version_1.identity(), monitor.identity());
    }

    #[test]
    fn a_flight_with_a_temperature_is_diagnosed_at_that_temperature() {
        let truth = FaultVector([0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]);
        for (u, unit) in units().iter().enumerate() {
            let monitor = HealthMonitor::onboard(*unit, Profile::STANDARD, ModelEffects::NONE).unwrap();
            for temperature_c in [-35.0f32, 65.0] {
                let hot_or_cold = unit.at_temperature(temperature_c);
                let mut trace = MeasuredTrace::new();
                let seed = 40 + u as u64;
                let acquired =
                    monitor.acquire(&mut Frames::of(&hot_or_cold, &truth, seed), &mut trace, 10_000.0).unwrap();
                let read = Acquired { temperature_c, ..acquired };
                let with = monitor.diagnose(&trace, &read, &mut HealthRecord::new(), &mut NoHooks).unwrap();
                let without = monitor.diagnose(&trace, &acquired, &mut HealthRecord::new(), &mut NoHooks).unwrap();
                assert_eq!(with.temperature_c.to_bits(), temperature_c.to_bits());
                assert!(without.temperature_c.is_nan());
                // the largest error over the eight parameters: a phantom short counts
                let error = |f: &Flight| {
                    f.report.faults.0.iter().zip(&truth.0).map(|(k, t)| (k - t).abs()).fold(0.0f32, f32::max)
                };
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
}
