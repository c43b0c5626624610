//! The health report as the firmware builds log it over defmt (the QEMU firmware and the board
//! crate log the same lines): status and reason, one line per fault mode under a diagnosis, the
//! severities with their 1σ or detectable-below values, the fault vector and its bits, the fit,
//! and the one-line summary that `scripts/parity` compares
//! with the host's `ema identify --firmware-trace FILE --bits`. Built with the `defmt` feature.

use crate::acquisition::{SensorCheck, ZeroSource};
use crate::diagnosis::evidence::PooledFlight;
use crate::diagnosis::{ColdReason, Start};
use crate::faults::FaultMode;
use crate::flight::Flight;
use crate::health::{Abstain, Condition, HealthReport};
use crate::persist::{Commissioning, CommissioningRefusal, StoreError};
use crate::unit::unit_name;

/// Logs how flight `number` starts: `flight 2: warm start from the health record's diagnosis`,
/// or `flight 1: cold identification` with the reason when it is not the missing prior.
pub fn log_start(number: u32, start: Start) {
    match start {
        Start::Warm => defmt::info!("flight {=u32}: warm start from the health record's diagnosis", number),
        Start::Cold(ColdReason::NoPrior) => defmt::info!("flight {=u32}: cold identification", number),
        Start::Cold(reason) => defmt::info!("flight {=u32}: cold identification ({})", number, reason),
    }
}

/// Logs a diagnosed flight: its temperature when one was read, its report ([`log_report`]), what
/// the warm stages did when it started warm, and each mode declared by the evidence pooled over
/// flights. Not inlined: the log's temporaries stay out of the frame that lies under the
/// identification.
#[inline(never)]
pub fn log_flight(flight: &Flight) {
    if flight.temperature_c.is_finite() {
        defmt::info!("flight {=u32} diagnosed at {=f32} C", flight.number, flight.temperature_c);
    }
    log_sensors(&flight.sensors);
    log_report(&flight.report);
    if let Some(warm) = &flight.warm {
        defmt::info!(
            "warm start: probes fired {=u8:07b} (groups), {=u16} probes, {=u8} refits, {=u32} evaluations of the warm stages; cold next: {=bool}",
            warm.fired,
            warm.probes,
            warm.refits,
            warm.evaluations,
            warm.needs_cold(&flight.report)
        );
    }
    if let Some(pooled) = flight.pooled.as_ref().filter(|p| p.any_declared()) {
        log_declared(pooled);
    }
    if let Some(state) = flight.commissioning {
        log_commissioning(state);
    }
}

/// Logs the current sensors' zero points and gain check in one line, and why they are not
/// trusted.
pub fn log_sensors(check: &SensorCheck) {
    let [a, b, c] = check.zero_shift_counts;
    let resolved = check.gain_mismatch.iter().all(|g| g.is_finite());
    let gains_pct = 100.0 * check.gain_mismatch.iter().fold(0.0f32, |m, g| m.max(libm::fabsf(*g)));
    match (check.source, resolved) {
        (ZeroSource::Rest, true) => defmt::info!(
            "sensors: zeros from {=u32} rest frames, A {=f32} B {=f32} C {=f32} counts; gains within {=f32} %",
            check.rest_frames,
            a,
            b,
            c,
            gains_pct
        ),
        (ZeroSource::Rest, false) => defmt::info!(
            "sensors: zeros from {=u32} rest frames, A {=f32} B {=f32} C {=f32} counts; gains not resolved",
            check.rest_frames,
            a,
            b,
            c
        ),
        (ZeroSource::Declared, true) => defmt::info!("sensors: declared zeros; gains within {=f32} %", gains_pct),
        (ZeroSource::Declared, false) => defmt::info!("sensors: declared zeros; gains not resolved"),
    }
    if let Some(fault) = check.fault {
        defmt::error!("sensors: calibration not trusted: {}", fault);
    }
}

/// Logs how keeping commissioning window `slot` went; `true` when it was kept.
pub fn log_window_kept(slot: u8, kept: Result<(), StoreError>) -> bool {
    match kept {
        Ok(()) => {
            defmt::info!("commissioning: window {=u8} kept", slot);
            true
        }
        Err(e) => {
            defmt::error!("commissioning: window {=u8} not kept: {}", slot, e);
            false
        }
    }
}

/// Logs a commissioning window `slot` that could not be read back; gives the flight's
/// temperature when it was.
pub fn log_window_loaded(slot: u8, loaded: Result<Option<f32>, StoreError>) -> Option<f32> {
    match loaded {
        Ok(Some(t)) => Some(t),
        Ok(None) => {
            defmt::error!("commissioning: window {=u8} not found", slot);
            None
        }
        Err(e) => {
            defmt::error!("commissioning: window {=u8} unreadable: {}", slot, e);
            None
        }
    }
}

/// Logs where a commissioning stands after one of its flights.
fn log_commissioning(state: Commissioning) {
    match state {
        Commissioning::Off => {}
        Commissioning::Collecting { planned, kept } => {
            defmt::info!("commissioning: {=u8} of {=u8} flights kept", kept, planned)
        }
        Commissioning::Commissioned(b) => {
            defmt::info!("commissioning: baseline kept, deviations (tolerance sigma) {=[?]}", b.z[..]);
            defmt::info!("commissioning: their 1-sigma {=[?]}, resolved {=[?]}", b.sigma_z[..], b.resolved[..]);
        }
        Commissioning::Refused(CommissioningRefusal::OutOfTolerance { param, z }) => defmt::warn!(
            "commissioning refused: {=str} fits {=f32} sigma from nominal, beyond its tolerance (a fault, or another actuator)",
            unit_name(usize::from(param)),
            z
        ),
        Commissioning::Refused(CommissioningRefusal::NotHealthy(status)) => {
            defmt::warn!("commissioning refused: the last flight is {} against the fitted baseline", status)
        }
        Commissioning::Refused(CommissioningRefusal::Failed) => {
            defmt::warn!("commissioning refused: the baseline fit failed (a window not kept or not read back)")
        }
    }
}

/// Logs each mode declared by the evidence pooled over flights (present by the summed evidence,
/// dropped by the flight's own model selection) with its refitted severity.
fn log_declared(pooled: &PooledFlight) {
    for (m, (&declared, mode)) in FaultMode::ALL.into_iter().zip(pooled.declared.iter().zip(pooled.report.modes.iter()))
    {
        if declared {
            defmt::info!(
                "pooled evidence: {=str} declared after {=u32} flights (sum {=f32} nats), refitted severity {=f32}",
                m.name(),
                pooled.evidence.flights,
                pooled.evidence.llr.get(m.index()).copied().unwrap_or(0.0),
                mode.severity
            );
        }
    }
}

/// Logs the health report: the status (with its reason when the monitor abstains), one line per
/// fault mode under a diagnosis, the fault vector (its bits always), the fit, and the summary line
/// of the host/target parity check ([`log_summary`]).
pub fn log_report(r: &HealthReport) {
    match r.status.reason() {
        Some(reason) => defmt::warn!("EMA health: {=str} ({=str})", r.status.label(), reason.label()),
        None if r.status.is_diagnosis() => defmt::info!("EMA health: {=str}", r.status.label()),
        None => defmt::warn!("EMA health: {=str}", r.status.label()),
    }
    if !r.status.is_diagnosis() {
        defmt::warn!("no diagnosis: the fault vector below is not reported as one");
    }
    let blind = r.status.reason() == Some(Abstain::NothingAssessable);
    for m in r.modes.iter().filter(|m| r.status.is_diagnosis() && m.condition != Condition::NotAssessed) {
        match m.mode {
            FaultMode::ShortCircuit => defmt::info!(
                "  {=str}: {=str}, severity {=f32}, {=f32} {=str} (phase {=char})",
                m.mode.name(),
                m.condition.label(),
                m.severity,
                m.value,
                m.unit(),
                ['A', 'B', 'C'][usize::from(m.phase) % 3]
            ),
            _ => defmt::info!(
                "  {=str}: {=str}, severity {=f32}, {=f32} {=str}",
                m.mode.name(),
                m.condition.label(),
                m.severity,
                m.value,
                m.unit()
            ),
        }
    }
    if blind {
        defmt::warn!("no mode assessable: a fault of DEGRADED size would not be seen on this recording");
    }
    log_uncertainty(r);
    let k = &r.faults.0;
    defmt::info!("fault vector k = {}", k);
    defmt::println!(
        "fault vector bits: {=u32:08x} {=u32:08x} {=u32:08x} {=u32:08x} {=u32:08x} {=u32:08x} {=u32:08x} {=u32:08x}",
        k[0].to_bits(),
        k[1].to_bits(),
        k[2].to_bits(),
        k[3].to_bits(),
        k[4].to_bits(),
        k[5].to_bits(),
        k[6].to_bits(),
        k[7].to_bits()
    );
    defmt::info!(
        "fitness {=f32} A^2, {=u32} evaluations, {=u32} iterations, stop: {}",
        r.fitness,
        r.evaluations,
        r.iterations,
        r.termination
    );
    if r.untested_groups > 0 {
        defmt::warn!(
            "model selection: {=u8} fault group(s) not tested (selection and polish budget spent): reported as found",
            r.untested_groups
        );
    }
    log_summary(r);
}

/// Logs what the recording can tell under a diagnosis (or when no mode is assessable), when the
/// report carries it ([`crate::health::Uncertainty`]): each mode found as `friction 0.25 ± 0.01`
/// (severity and its 1σ), each mode reported healthy as `backlash healthy (not detectable below
/// 0.002)`, each mode not assessed as `eccentricity NOT_ASSESSED (not detectable below 0.17)`,
/// then the 1σ of the 8 parameters.
pub fn log_uncertainty(r: &HealthReport) {
    let Some(u) = &r.uncertainty else { return };
    if !r.status.is_diagnosis() && r.status.reason() != Some(Abstain::NothingAssessable) {
        return;
    }
    for (m, floor) in r.modes.iter().zip(u.detectable_below) {
        match floor {
            Some(floor) if m.condition == Condition::NotAssessed => {
                defmt::warn!("  {=str}: NOT_ASSESSED (not detectable below {=f32})", m.mode.name(), floor)
            }
            Some(floor) => defmt::info!("  {=str} healthy (not detectable below {=f32})", m.mode.name(), floor),
            None => defmt::info!("  {=str} {=f32} ± {=f32}", m.mode.name(), m.severity, u.severity_sigma(m)),
        }
    }
    defmt::info!("fault vector 1-sigma = {}", u.sigma);
}

/// Logs the report's one-line summary, the line `scripts/parity` compares with the host's
/// (`ema identify --firmware-trace FILE --bits`, the same format):
/// `summary: STATUS fitness F evaluations N bits K1 … K8`, where `STATUS` is the status label with
/// its reason in parentheses under `INCONCLUSIVE` (`INCONCLUSIVE(rate mismatch)`), `F` and `K1 … K8`
/// the `f32` bit patterns (8 lower-case hex digits) of the fitness and of the fault vector.
pub fn log_summary(r: &HealthReport) {
    let (open, reason, close) = match r.status.reason() {
        Some(reason) => ("(", reason.label(), ")"),
        None => ("", "", ""),
    };
    let k = &r.faults.0;
    defmt::println!(
        "summary: {=str}{=str}{=str}{=str} fitness {=u32:08x} evaluations {=u32} bits {=u32:08x} {=u32:08x} {=u32:08x} {=u32:08x} {=u32:08x} {=u32:08x} {=u32:08x} {=u32:08x}",
        r.status.label(),
        open,
        reason,
        close,
        r.fitness.to_bits(),
        r.evaluations,
        k[0].to_bits(),
        k[1].to_bits(),
        k[2].to_bits(),
        k[3].to_bits(),
        k[4].to_bits(),
        k[5].to_bits(),
        k[6].to_bits(),
        k[7].to_bits()
    );
}
