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
//!      feeds its watchdog there, QEMU marks the instruction-counted region around the whole, the
//!      host evaluates a sweep of the global search in parallel in [`FlightHooks::global_cost`]);
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
//! costs it (the board raises its watchdog timeout). What may be saved is the core's policy,
//! shared by both firmwares ([`crate::persist::kept`]): the firmware holds the loaded record as a
//! [`KeptRecord`] and flies with [`HealthMonitor::diagnose_kept`]; after a failed load the
//! flight runs cold on a new record that is not saved, so the stored history is still there for
//! the next load.
//!
//! Nothing here allocates or panics; a refused input is a [`MonitorError`], an unusable recording
//! an honest `INCONCLUSIVE` or `SENSOR_FAULT` report.

use crate::acquisition::{PhaseCurrents, SensorCheck};
use crate::conditioning::ConditionedWindow;
use crate::diagnosis::evidence::{self, PooledFlight};
use crate::diagnosis::{
    self, plan_start, with_uncertainty, AcquisitionSummary, Identification, IdentifyConfig, MonitorError, Start,
    StepDriver, WarmReport, ONBOARD_POPULATION, ONBOARD_WINDOW,
};
use crate::health::{Abstain, HealthReport, Status};
use crate::persist::{Commissioning, HealthRecord, KeptRecord, RecordIdentity};
use crate::unit::Tolerances;
use crate::{Command, EmaParams, ModelEffects};

#[cfg(feature = "commissioning")]
pub mod commissioning;

#[cfg(feature = "commissioning")]
pub use commissioning::MAX_ONBOARD_COMMISSIONING_FLIGHTS;

/// What the firmware does around the identification. Every method does nothing by default.
pub trait FlightHooks {
    /// Before the identification's first evaluation: flight `flight` (1 for the first in the
    /// record) starts as `start` says.
    fn identification_start(&mut self, flight: u32, start: Start) {
        let _ = (flight, start);
    }
    /// Before each step of the identification (the board feeds its watchdog here).
    fn before_step(&mut self) {}
    /// The cost of the global search's next pending particle when the hooks computed it ahead
    /// ([`StepDriver::global_cost`]: a host evaluating a sweep in parallel); `None`, the default,
    /// lets the step evaluate it.
    fn global_cost<const W: usize, const P: usize>(&mut self, id: &Identification<'_, W, P>) -> Option<f32> {
        let _ = id;
        None
    }
    /// After each step of the identification.
    fn after_step(&mut self) {}
    /// After the identification's report, before its uncertainty and the record.
    fn identification_end(&mut self) {}
    /// Before each of a flight's calls after the identification ([`FlightCall`]): one
    /// uninterrupted run each, which a firmware times and feeds its watchdog around.
    fn before_call(&mut self, call: FlightCall) {
        let _ = call;
    }
    /// Between two model runs inside the record's call ([`FlightCall::Record`]: the flight's
    /// evidence, up to 18 runs, and up to 32 for each mode it declares and refits): a firmware
    /// feeds its watchdog here, so that the longest stretch without a feed is one model run.
    fn between_runs(&mut self, call: FlightCall) {
        let _ = call;
    }
    /// After each of a flight's calls after the identification.
    fn after_call(&mut self, call: FlightCall) {
        let _ = call;
    }
    /// Before the baseline fit of the last commissioning flight ([`commissioning`]).
    fn commissioning_start(&mut self) {}
    /// Before each evaluation of the baseline fit and each flight's run of its sensitivities
    /// (at most 12 model runs: the board feeds its watchdog here, with a timeout raised for the
    /// fit at [`FlightHooks::commissioning_start`]).
    fn commissioning_tick(&mut self) {}
    /// After the baseline fit.
    fn commissioning_end(&mut self) {}
    /// Keeps commissioning window `slot` (the closed `window` of a flight flown at
    /// `temperature_c`) in flash for the last commissioning flight
    /// ([`crate::persist::HealthStore::keep_window`]); `false` when it cannot, which ends the
    /// commissioning without a baseline. Without flash (the default) nothing is kept.
    fn keep_window<const W: usize>(&mut self, slot: u8, window: &ConditionedWindow<W>, temperature_c: f32) -> bool {
        let _ = (slot, window, temperature_c);
        false
    }
    /// Reads commissioning window `slot` back into `out` and gives its flight's temperature;
    /// `None` when it cannot ([`crate::persist::HealthStore::load_window`]).
    fn load_window<const W: usize>(&mut self, slot: u8, out: &mut ConditionedWindow<W>) -> Option<f32> {
        let _ = (slot, out);
        None
    }
}

/// A flight's calls after the identification: the uncertainty runs without a hook inside it,
/// the record reaches [`FlightHooks::between_runs`] between its model runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FlightCall {
    /// The report's uncertainty: the fitness built again and 9 model runs in lockstep.
    Uncertainty,
    /// The flight added to the health record with its pooled evidence.
    Record,
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
    /// ([`diagnosis::rate_matches`]): what the monitor model's fixed step assumes.
    pub fn rate_ok(&self, params: &EmaParams) -> bool {
        self.late_frames == 0 && diagnosis::rate_matches(self.sample_rate_hz, params)
    }
}

/// One diagnosed flight ([`HealthMonitor::diagnose`]).
#[derive(Clone, Copy, Debug)]
pub struct Flight {
    /// The flight's number in the record (1 for the first after maintenance).
    pub number: u32,
    /// The temperature the flight was diagnosed at (°C), NaN when none was read.
    pub temperature_c: f32,
    /// What the current sensors' self-calibration found: the zero points in use, the gain check,
    /// and why the flight is a sensor fault when the calibration is not trusted.
    pub sensors: SensorCheck,
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
    /// Where the unit's commissioning stands after a commissioning flight (`None` for any
    /// other flight).
    pub commissioning: Option<Commissioning>,
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
    commissioning_flights: u8,
    tolerances: Tolerances,
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
    /// Refuses parameters outside their range ([`EmaParams::check`]), and effect terms in a build
    /// without them ([`MonitorError::EffectsNotBuilt`]).
    pub fn new(
        params: EmaParams,
        command: impl Into<Command<'c>>,
        config: IdentifyConfig,
    ) -> Result<Self, MonitorError> {
        if params.check().is_err() {
            return Err(MonitorError::Params);
        }
        config.check_effects_built()?;
        Ok(Self {
            params,
            command: command.into(),
            config: IdentifyConfig { prior: None, ..config },
            unit_serial: 0,
            commissioning_flights: 0,
            tolerances: Tolerances::TYPICAL,
        })
    }

    /// The same monitor commissioning each new record (the first after a maintenance reset)
    /// over its first `flights` flights, within `tolerances` ([`commissioning`]). Refuses 0 or
    /// more than [`MAX_ONBOARD_COMMISSIONING_FLIGHTS`] flights, or a table that
    /// [`Tolerances::check`] refuses. Built with the `commissioning` feature.
    #[cfg(feature = "commissioning")]
    pub fn with_commissioning(self, flights: u8, tolerances: Tolerances) -> Result<Self, MonitorError> {
        if !(1..=MAX_ONBOARD_COMMISSIONING_FLIGHTS).contains(&flights) || tolerances.check().is_err() {
            return Err(MonitorError::Commissioning);
        }
        Ok(Self { commissioning_flights: flights, tolerances, ..self })
    }

    /// The parameters a flight is diagnosed against (at 20 °C): the record's baseline once the
    /// unit is commissioned, the monitor's own otherwise.
    fn unit_params(&self, record: &HealthRecord) -> EmaParams {
        match record.baseline() {
            Some(b) => {
                let unit = self.tolerances.apply(&self.params, &b.z);
                if unit.check().is_ok() {
                    unit
                } else {
                    self.params
                }
            }
            None => self.params,
        }
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

    /// Reads every frame of `source` into `trace` and closes the window ([`diagnosis::acquire`]):
    /// a refused frame is held at the last good one and counted. `sample_rate_hz` is the rate the
    /// frames come at; the late frames are 0 (a caller whose timer can overrun sets them).
    pub fn acquire<S: PhaseCurrents>(
        &self,
        source: &mut S,
        trace: &mut ConditionedWindow<W>,
        sample_rate_hz: f32,
    ) -> Result<Acquired, MonitorError> {
        let summary = diagnosis::acquire(source, trace)?;
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
        trace: &ConditionedWindow<W>,
        acquired: &Acquired,
        record: &mut HealthRecord,
        hooks: &mut impl FlightHooks,
    ) -> Result<Flight, MonitorError> {
        self.diagnose_on(trace, acquired, record, hooks, true)
    }

    /// [`HealthMonitor::diagnose`] on the record a firmware keeps in RAM, under the policy of
    /// [`crate::persist::kept`]. A record that may be saved is diagnosed as it is. One that may
    /// not (the load failed, or a record it replaces was not archived) is replaced by a new
    /// record of this monitor's identity, and the flight runs as an ordinary cold one against
    /// the parameters as given: no commissioning starts, since the unit may be commissioned in
    /// the record that could not be read, and so no window is written to the flash the policy
    /// leaves untouched. The caller saves [`KeptRecord::savable`] alone.
    pub fn diagnose_kept(
        &self,
        trace: &ConditionedWindow<W>,
        acquired: &Acquired,
        kept: &mut KeptRecord,
        hooks: &mut impl FlightHooks,
    ) -> Result<Flight, MonitorError> {
        let may_save = kept.may_save();
        let record = kept.record_mut();
        if !may_save {
            *record = HealthRecord::for_unit(self.identity());
        }
        self.diagnose_on(trace, acquired, record, hooks, may_save)
    }

    /// [`HealthMonitor::diagnose`], a new record commissioning the unit only when `commission`.
    fn diagnose_on(
        &self,
        trace: &ConditionedWindow<W>,
        acquired: &Acquired,
        record: &mut HealthRecord,
        hooks: &mut impl FlightHooks,
        commission: bool,
    ) -> Result<Flight, MonitorError> {
        if record.identity() != self.identity() {
            if record.flights() > 0 {
                return Err(MonitorError::ForeignRecord);
            }
            *record = HealthRecord::for_unit(self.identity());
        }
        let commission = commission && self.commissioning_flights > 0;
        if record.flights() == 0 && commission && record.commissioning() == Commissioning::Off {
            record.set_commissioning(Commissioning::Collecting { planned: self.commissioning_flights, kept: 0 });
        }
        if let Commissioning::Collecting { planned, kept } = record.commissioning() {
            #[cfg(feature = "commissioning")]
            return self.commissioning_flight(trace, acquired, record, hooks, planned, kept);
            #[cfg(not(feature = "commissioning"))]
            {
                let _ = (planned, kept);
                return Err(MonitorError::CommissioningNotBuilt);
            }
        }
        let base = self.unit_params(record);
        self.fly(trace, acquired, record, hooks, &base)
    }

    /// The flight policy on parameters `base` (at 20 °C): plan, identify, then
    /// [`HealthMonitor::conclude`]. Inlined into each caller: a frame of its own beside the
    /// caller's would hold a second copy of the flight's report on the identification's stack.
    #[inline(always)]
    fn fly(
        &self,
        trace: &ConditionedWindow<W>,
        acquired: &Acquired,
        record: &mut HealthRecord,
        hooks: &mut impl FlightHooks,
        base: &EmaParams,
    ) -> Result<Flight, MonitorError> {
        let params = base.at_temperature(acquired.temperature_c);
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
        let flight = Flight {
            number,
            temperature_c: acquired.temperature_c,
            sensors: acquired.summary.sensors,
            start,
            cold: prior.is_none() || warm.is_some_and(|w| w.cold_fallback),
            report,
            warm,
            pooled: None,
            commissioning: None,
        };
        Ok(self.conclude(trace, acquired, record, hooks, &params, flight))
    }

    /// The identified `flight`, concluded: its report with the uncertainty and the acquisition's
    /// verdicts, then recorded with the pooled evidence. Not inlined: the reports and evidence
    /// built here stay out of the frame the identification runs above.
    #[inline(never)]
    fn conclude(
        &self,
        trace: &ConditionedWindow<W>,
        acquired: &Acquired,
        record: &mut HealthRecord,
        hooks: &mut impl FlightHooks,
        params: &EmaParams,
        mut flight: Flight,
    ) -> Flight {
        hooks.before_call(FlightCall::Uncertainty);
        let report = self.with_uncertainty(trace, params, flight.report);
        hooks.after_call(FlightCall::Uncertainty);
        let report = report.with_acquisition(&acquired.summary);
        flight.report = if acquired.rate_ok(&self.params) {
            report
        } else {
            report.abstaining(Status::Inconclusive(Abstain::RateMismatch))
        };
        hooks.before_call(FlightCall::Record);
        flight.pooled = self.record(record, trace, params, &flight.report, flight.cold, hooks);
        hooks.after_call(FlightCall::Record);
        flight
    }

    /// The identification, cold without a prior and warm from it, one evaluation per step with
    /// `hooks` around each ([`Identification::run_with`]). Not inlined: the identification's
    /// state lives in this frame alone, not beside the uncertainty's and the record's.
    #[inline(never)]
    fn identify(
        &self,
        trace: &ConditionedWindow<W>,
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
        id.run_with(u32::MAX, &mut AroundSteps(hooks));
        Ok((id.report(), id.warm_report()))
    }

    /// `report` with its uncertainty ([`with_uncertainty`]: the fitness built again, 9 model runs
    /// in lockstep). Not inlined, as [`HealthMonitor::identify`].
    #[inline(never)]
    fn with_uncertainty(&self, trace: &ConditionedWindow<W>, params: &EmaParams, report: HealthReport) -> HealthReport {
        with_uncertainty(trace, *params, self.command, &self.config, report)
    }

    /// Adds the flight's `report` to `record` through the pooled evidence
    /// ([`evidence::record_flight_on`]). Not inlined, as [`HealthMonitor::identify`].
    #[inline(never)]
    fn record(
        &self,
        record: &mut HealthRecord,
        trace: &ConditionedWindow<W>,
        params: &EmaParams,
        report: &HealthReport,
        cold: bool,
        hooks: &mut impl FlightHooks,
    ) -> Option<PooledFlight> {
        let between_runs = &mut || hooks.between_runs(FlightCall::Record);
        evidence::record_flight_on(record, trace, *params, self.command, &self.config, report, cold, between_runs)
    }
}

/// A flight's hooks around each step of the identification ([`StepDriver`]).
struct AroundSteps<'h, H>(&'h mut H);

impl<H: FlightHooks> StepDriver for AroundSteps<'_, H> {
    fn before_step(&mut self) {
        self.0.before_step();
    }

    fn after_step(&mut self) {
        self.0.after_step();
    }

    fn global_cost<const W: usize, const P: usize>(&mut self, id: &Identification<'_, W, P>) -> Option<f32> {
        self.0.global_cost(id)
    }
}

#[cfg(test)]
mod tests;
