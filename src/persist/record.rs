//! The health record: what the monitor keeps from one flight to the next, fixed-size and without
//! allocation, with an explicit little-endian encoding of [`HealthRecord::ENCODED_LEN`] bytes.
//!
//! It holds the identity of the unit and parameters it was made under ([`RecordIdentity`]), the
//! flight count, the flights since the last cold identification, the last diagnosis
//! (fault vector `k`, its 1σ uncertainty `sigma`, the status), a short history per fault mode (the
//! last [`HISTORY_LEN`] `(flight, severity)` pairs of each of the five [`FaultMode`]s, a ring
//! buffer) and the evidence accumulators of pooling over flights (one summed log-likelihood ratio
//! per fault mode and the number of flights pooled; their meaning belongs to the pooling test,
//! the record only keeps them).
//!
//! **Layout** (offsets in bytes, every multi-byte field little-endian, `f32` as its IEEE-754 bits):
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 1 | format version, [`RECORD_VERSION`] |
//! | 1 | 1 | status of the last report ([`status_code`]; [`NO_STATUS`] before the first flight) |
//! | 2 | 2 | reserved, 0 |
//! | 4 | 4 | flight count (`u32`) |
//! | 8 | 4 | flights since the last cold identification (`u32`) |
//! | 12 | 32 | last `k`, 8 × `f32` (normalized fault vector, [`crate::faults`]) |
//! | 44 | 32 | last `sigma`, 8 × `f32` (NaN where unknown) |
//! | 76 | 20 | evidence: summed log-likelihood ratio per mode, 5 × `f32`, [`FaultMode::ALL`] order |
//! | 96 | 4 | flights pooled into the evidence (`u32`) |
//! | 100 | 5 | history length per mode (`u8`, ≤ [`HISTORY_LEN`]) |
//! | 105 | 5 | history ring head per mode (`u8`, the slot the next entry goes to) |
//! | 110 | 2 | reserved, 0 |
//! | 112 | 640 | history: per mode, [`HISTORY_LEN`] × (flight `u32`, severity `f32`) |
//! | 752 | 4 | identity of the parameters ([`crate::EmaParams::identity`]) |
//! | 756 | 4 | unit serial number (0: not given) |
//! | 760 | 1 | commissioning flights planned (0: none) |
//! | 761 | 1 | commissioning windows kept so far |
//! | 762 | 1 | commissioning state: 0 off, 1 collecting, 2 commissioned, 3 refused (a parameter out of tolerance), 4 refused (not healthy against the baseline), 5 refused (the fit failed) |
//! | 763 | 1 | the parameter out of tolerance (state 3), the status code (state 4), else 0 |
//! | 764 | 2 | resolved unit parameters, one bit each ([`crate::unit::UNIT_PARAMS`] order) |
//! | 766 | 2 | reserved, 0 |
//! | 768 | 44 | the unit's deviations `z`, 11 × `f32` (tolerance σ, [`crate::unit`]) |
//! | 812 | 44 | their posterior 1σ, 11 × `f32` |
//!
//! A record of version 1 (the same layout without the identity and commissioning, 752 bytes) decodes with the
//! identity [`RecordIdentity::UNKNOWN`]: its history stays readable, and the flight API keeps it
//! aside and starts a new one ([`crate::flight::HealthMonitor::adopt`]), since nothing says which
//! parameters it was made under. A record of any other version, of a length that is not its
//! version's, with an unknown status code or ring indices out of range does not decode
//! ([`RecordError`]): the monitor then starts cold.
//! Integrity against bit errors is the store's (CRC-32 per stored item, `docs/persistence.md`).

use crate::faults::FaultMode;
use crate::faults::{FaultVector, FAULT_COUNT};
use crate::health::{Abstain, HealthReport, Status};
use crate::unit::UNIT_PARAM_COUNT;

/// Format version of the encoding; a change of layout takes the next number.
pub const RECORD_VERSION: u8 = 2;

/// Bytes of a version-1 record: the layout without the identity.
const ENCODED_LEN_V1: usize = OFF_IDENTITY;

/// Entries of history kept per fault mode.
pub const HISTORY_LEN: usize = 16;

/// Number of fault modes ([`FaultMode::ALL`]).
pub const MODES: usize = 5;

const OFF_STATUS: usize = 1;
const OFF_FLIGHTS: usize = 4;
const OFF_SINCE_COLD: usize = 8;
const OFF_K: usize = 12;
const OFF_SIGMA: usize = OFF_K + 4 * FAULT_COUNT;
const OFF_EVIDENCE: usize = OFF_SIGMA + 4 * FAULT_COUNT;
const OFF_POOLED: usize = OFF_EVIDENCE + 4 * MODES;
const OFF_HIST_LEN: usize = OFF_POOLED + 4;
const OFF_HIST_HEAD: usize = OFF_HIST_LEN + MODES;
const OFF_HISTORY: usize = 112;
/// Bytes of one history entry: flight `u32` + severity `f32`.
const ENTRY_LEN: usize = 8;
const OFF_IDENTITY: usize = OFF_HISTORY + MODES * HISTORY_LEN * ENTRY_LEN;
const OFF_SERIAL: usize = OFF_IDENTITY + 4;
const OFF_PLANNED: usize = OFF_SERIAL + 4;
const OFF_KEPT: usize = OFF_PLANNED + 1;
const OFF_STATE: usize = OFF_KEPT + 1;
const OFF_DETAIL: usize = OFF_STATE + 1;
const OFF_RESOLVED: usize = OFF_DETAIL + 1;
const OFF_Z: usize = OFF_RESOLVED + 4;
const OFF_SIGMA_Z: usize = OFF_Z + 4 * UNIT_PARAM_COUNT;

/// A unit's baseline as the record keeps it: its deviations from the drawing (tolerance σ,
/// [`crate::unit::Tolerances::apply`]), their posterior 1σ and which ones commissioning resolved.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct UnitBaseline {
    /// The deviations (0 where not resolved).
    pub z: [f32; UNIT_PARAM_COUNT],
    /// Their posterior 1σ.
    pub sigma_z: [f32; UNIT_PARAM_COUNT],
    /// Which ones the commissioning flights resolved.
    pub resolved: [bool; UNIT_PARAM_COUNT],
}

/// Why a commissioning gave no baseline.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CommissioningRefusal {
    /// Unit parameter `param` ([`crate::unit::UNIT_PARAMS`] order) fitted `z` σ from nominal,
    /// beyond [`crate::commissioning::OUT_OF_TOLERANCE_SIGMAS`]: a fault, or another actuator.
    OutOfTolerance {
        /// The parameter.
        param: u8,
        /// Its fitted deviation (tolerance σ).
        z: f32,
    },
    /// The last commissioning flight, diagnosed against the fitted baseline, was not HEALTHY.
    NotHealthy(Status),
    /// The fit itself failed (a window missing from flash, a refused setting).
    Failed,
}

/// Where the record's unit is in its commissioning.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Commissioning {
    /// None asked: the unit is diagnosed against the parameters as given.
    Off,
    /// Collecting the windows of `planned` healthy flights, `kept` so far.
    Collecting {
        /// Commissioning flights asked for.
        planned: u8,
        /// Windows kept so far.
        kept: u8,
    },
    /// Done: later flights are diagnosed against this baseline.
    Commissioned(UnitBaseline),
    /// Done without a baseline; later flights are diagnosed against the parameters as given.
    Refused(CommissioningRefusal),
}

/// Which unit, under which parameters, a record belongs to: the diagnoses, history and evidence
/// it holds mean something only for that unit and those parameters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RecordIdentity {
    /// [`crate::EmaParams::identity`] of the parameters the monitor diagnosed with.
    pub params: u32,
    /// The unit's serial number as the integrator gives it; 0 when none is given.
    pub unit_serial: u32,
}

impl RecordIdentity {
    /// The identity of a record that does not say (a new record, or one of version 1).
    pub const UNKNOWN: Self = Self { params: 0, unit_serial: 0 };
}

/// Why bytes do not decode as a [`HealthRecord`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RecordError {
    /// Not the length of its version's encoding ([`HealthRecord::ENCODED_LEN`] for the current one).
    Length,
    /// The version byte is neither [`RECORD_VERSION`] nor 1 (the record of a newer firmware).
    Version(u8),
    /// Unknown status code.
    Status(u8),
    /// A history length or ring head out of range.
    History,
    /// An unknown commissioning state, or its fields out of range.
    Commissioning,
    /// The output buffer is shorter than [`HealthRecord::ENCODED_LEN`].
    BufferTooSmall,
}

/// One history entry: the flight and a fault mode's severity in it.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HistoryEntry {
    /// Flight number (1 for the first flight recorded).
    pub flight: u32,
    /// Severity in `[0, 1]` ([`crate::health`]).
    pub severity: f32,
}

/// The last [`HISTORY_LEN`] entries of one fault mode, a ring buffer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModeHistory {
    entries: [HistoryEntry; HISTORY_LEN],
    len: u8,
    head: u8,
}

impl ModeHistory {
    /// No entry.
    pub const EMPTY: Self = Self { entries: [HistoryEntry { flight: 0, severity: 0.0 }; HISTORY_LEN], len: 0, head: 0 };

    /// Entries held, at most [`HISTORY_LEN`].
    pub fn len(&self) -> usize {
        usize::from(self.len)
    }

    /// `true` when no entry is held.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Appends an entry, dropping the oldest when full.
    pub fn push(&mut self, entry: HistoryEntry) {
        let head = usize::from(self.head) % HISTORY_LEN;
        self.entries[head] = entry;
        self.head = ((head + 1) % HISTORY_LEN) as u8;
        if usize::from(self.len) < HISTORY_LEN {
            self.len += 1;
        }
    }

    /// The `i`-th entry from the oldest (`0`) to the newest (`len() − 1`).
    pub fn get(&self, i: usize) -> Option<HistoryEntry> {
        if i >= self.len() {
            return None;
        }
        let oldest = (usize::from(self.head) + HISTORY_LEN - self.len()) % HISTORY_LEN;
        self.entries.get((oldest + i) % HISTORY_LEN).copied()
    }

    /// The newest entry.
    pub fn latest(&self) -> Option<HistoryEntry> {
        self.len().checked_sub(1).and_then(|i| self.get(i))
    }

    /// The entries from the oldest to the newest.
    pub fn iter(&self) -> impl Iterator<Item = HistoryEntry> + '_ {
        (0..self.len()).filter_map(move |i| self.get(i))
    }
}

/// The persisted health state of one actuator (module documentation: contents and layout).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HealthRecord {
    identity: RecordIdentity,
    commissioning: Commissioning,
    flights: u32,
    flights_since_cold: u32,
    k: [f32; FAULT_COUNT],
    sigma: [f32; FAULT_COUNT],
    status: Option<Status>,
    history: [ModeHistory; MODES],
    evidence: [f32; MODES],
    pooled_flights: u32,
}

impl Default for HealthRecord {
    fn default() -> Self {
        Self::new()
    }
}

/// The one-byte code of a [`Status`] in the record: 0 healthy, 1 degraded, 2 failing,
/// 3 inconclusive (poor fit), 4 inconclusive (partial coverage), 5 inconclusive (rate mismatch),
/// 6 sensor fault, 7 inconclusive (unit mismatch), 8 inconclusive (commissioning),
/// 9 inconclusive (nothing assessable).
pub const fn status_code(status: Status) -> u8 {
    match status {
        Status::Healthy => 0,
        Status::Degraded => 1,
        Status::Failing => 2,
        Status::Inconclusive(Abstain::PoorFit) => 3,
        Status::Inconclusive(Abstain::PartialCoverage) => 4,
        Status::Inconclusive(Abstain::RateMismatch) => 5,
        Status::Inconclusive(Abstain::UnitMismatch) => 7,
        Status::Inconclusive(Abstain::Commissioning) => 8,
        Status::Inconclusive(Abstain::NothingAssessable) => 9,
        Status::SensorFault => 6,
    }
}

/// The status code of a record that holds no report yet.
pub const NO_STATUS: u8 = 0xFF;

/// The [`Status`] of a code of [`status_code`] (`Ok(None)` for [`NO_STATUS`]); `Err` for an
/// unknown code.
pub const fn status_of_code(code: u8) -> Result<Option<Status>, RecordError> {
    Ok(Some(match code {
        0 => Status::Healthy,
        1 => Status::Degraded,
        2 => Status::Failing,
        3 => Status::Inconclusive(Abstain::PoorFit),
        4 => Status::Inconclusive(Abstain::PartialCoverage),
        5 => Status::Inconclusive(Abstain::RateMismatch),
        6 => Status::SensorFault,
        7 => Status::Inconclusive(Abstain::UnitMismatch),
        8 => Status::Inconclusive(Abstain::Commissioning),
        9 => Status::Inconclusive(Abstain::NothingAssessable),
        NO_STATUS => return Ok(None),
        _ => return Err(RecordError::Status(code)),
    }))
}

impl HealthRecord {
    /// Bytes of the encoding ([`HealthRecord::encode`]).
    pub const ENCODED_LEN: usize = OFF_SIGMA_Z + 4 * UNIT_PARAM_COUNT;

    /// The record before the first flight: no flight, the healthy vector
    /// ([`FaultVector::HEALTHY`]), `sigma` unknown (NaN), no history, no evidence, no status,
    /// identity [`RecordIdentity::UNKNOWN`].
    pub const fn new() -> Self {
        Self::for_unit(RecordIdentity::UNKNOWN)
    }

    /// A new record ([`HealthRecord::new`]) of the unit and parameters `identity`.
    pub const fn for_unit(identity: RecordIdentity) -> Self {
        Self {
            identity,
            commissioning: Commissioning::Off,
            flights: 0,
            flights_since_cold: 0,
            k: FaultVector::HEALTHY.0,
            sigma: [f32::NAN; FAULT_COUNT],
            status: None,
            history: [ModeHistory::EMPTY; MODES],
            evidence: [0.0; MODES],
            pooled_flights: 0,
        }
    }

    /// Appends one flight's report: the flight count goes up by one; the flights since the last
    /// cold identification restart at 0 when `cold` (this flight ran the cold identification) and
    /// go up by one otherwise; the report's fault vector and status become the last diagnosis
    /// (`sigma` the report's 1σ, unknown (NaN) when the report carries no uncertainty); and, when the status is a
    /// diagnosis ([`Status::is_diagnosis`]), each mode's severity joins its history. An
    /// abstention (`INCONCLUSIVE`, `SENSOR_FAULT`) adds nothing to the history: its values are not
    /// a diagnosis.
    pub fn new_flight(&mut self, report: &HealthReport, cold: bool) {
        self.flights = self.flights.saturating_add(1);
        self.flights_since_cold = if cold { 0 } else { self.flights_since_cold.saturating_add(1) };
        self.k = report.faults.0;
        self.sigma = report.uncertainty.map_or([f32::NAN; FAULT_COUNT], |u| u.sigma);
        self.status = Some(report.status);
        if report.status.is_diagnosis() {
            for (history, mode) in self.history.iter_mut().zip(report.modes.iter()) {
                history.push(HistoryEntry { flight: self.flights, severity: mode.severity });
            }
        }
    }

    /// The unit and parameters the record belongs to.
    pub fn identity(&self) -> RecordIdentity {
        self.identity
    }

    /// Where the unit is in its commissioning.
    pub fn commissioning(&self) -> Commissioning {
        self.commissioning
    }

    /// Sets where the unit is in its commissioning (the flight API's, [`crate::flight`]).
    pub fn set_commissioning(&mut self, commissioning: Commissioning) {
        self.commissioning = commissioning;
    }

    /// The unit's baseline, once commissioned.
    pub fn baseline(&self) -> Option<&UnitBaseline> {
        match &self.commissioning {
            Commissioning::Commissioned(b) => Some(b),
            _ => None,
        }
    }

    /// Flights recorded ([`HealthRecord::new_flight`] calls).
    pub fn flights(&self) -> u32 {
        self.flights
    }

    /// Flights since the last cold identification (0 right after one).
    pub fn flights_since_cold(&self) -> u32 {
        self.flights_since_cold
    }

    /// The last fault vector (normalized, [`crate::faults`]).
    pub fn faults(&self) -> FaultVector {
        FaultVector(self.k)
    }

    /// The last fault vector's 1σ uncertainty per parameter, NaN where unknown.
    pub fn sigma(&self) -> &[f32; FAULT_COUNT] {
        &self.sigma
    }

    /// Sets the last fault vector's 1σ uncertainty.
    pub fn set_sigma(&mut self, sigma: [f32; FAULT_COUNT]) {
        self.sigma = sigma;
    }

    /// The status of the last report; `None` before the first flight.
    pub fn status(&self) -> Option<Status> {
        self.status
    }

    /// `true` when the last report is a diagnosis a warm start can start from: at least one
    /// flight, a diagnosis status and a valid fault vector.
    pub fn has_prior(&self) -> bool {
        self.flights > 0 && self.status.is_some_and(Status::is_diagnosis) && self.faults().is_valid()
    }

    /// The history of `mode`.
    pub fn history(&self, mode: FaultMode) -> &ModeHistory {
        &self.history[mode.index()]
    }

    /// The summed log-likelihood ratio per mode ([`FaultMode::ALL`] order).
    pub fn evidence(&self) -> &[f32; MODES] {
        &self.evidence
    }

    /// Flights pooled into the evidence.
    pub fn pooled_flights(&self) -> u32 {
        self.pooled_flights
    }

    /// Sets the evidence accumulators and the flights pooled into them.
    pub fn set_evidence(&mut self, evidence: [f32; MODES], pooled_flights: u32) {
        self.evidence = evidence;
        self.pooled_flights = pooled_flights;
    }

    /// Writes the encoding (module documentation: layout) into `out[..ENCODED_LEN]`.
    pub fn encode(&self, out: &mut [u8]) -> Result<usize, RecordError> {
        let out = out.get_mut(..Self::ENCODED_LEN).ok_or(RecordError::BufferTooSmall)?;
        out.fill(0);
        out[0] = RECORD_VERSION;
        out[OFF_STATUS] = self.status.map_or(NO_STATUS, status_code);
        put_u32(out, OFF_FLIGHTS, self.flights);
        put_u32(out, OFF_SINCE_COLD, self.flights_since_cold);
        for (i, v) in self.k.iter().enumerate() {
            put_f32(out, OFF_K + 4 * i, *v);
        }
        for (i, v) in self.sigma.iter().enumerate() {
            put_f32(out, OFF_SIGMA + 4 * i, *v);
        }
        for (i, v) in self.evidence.iter().enumerate() {
            put_f32(out, OFF_EVIDENCE + 4 * i, *v);
        }
        put_u32(out, OFF_POOLED, self.pooled_flights);
        for (m, h) in self.history.iter().enumerate() {
            out[OFF_HIST_LEN + m] = h.len;
            out[OFF_HIST_HEAD + m] = h.head;
            for (j, e) in h.entries.iter().enumerate() {
                let at = OFF_HISTORY + (m * HISTORY_LEN + j) * ENTRY_LEN;
                put_u32(out, at, e.flight);
                put_f32(out, at + 4, e.severity);
            }
        }
        put_u32(out, OFF_IDENTITY, self.identity.params);
        put_u32(out, OFF_SERIAL, self.identity.unit_serial);
        let (planned, kept, state, detail, baseline) = match self.commissioning {
            Commissioning::Off => (0, 0, 0, 0, None),
            Commissioning::Collecting { planned, kept } => (planned, kept, 1, 0, None),
            Commissioning::Commissioned(b) => (0, 0, 2, 0, Some(b)),
            Commissioning::Refused(CommissioningRefusal::OutOfTolerance { param, z }) => {
                let mut b = UnitBaseline {
                    z: [0.0; UNIT_PARAM_COUNT],
                    sigma_z: [0.0; UNIT_PARAM_COUNT],
                    resolved: [false; UNIT_PARAM_COUNT],
                };
                if let Some(zi) = b.z.get_mut(usize::from(param)) {
                    *zi = z;
                }
                (0, 0, 3, param, Some(b))
            }
            Commissioning::Refused(CommissioningRefusal::NotHealthy(status)) => (0, 0, 4, status_code(status), None),
            Commissioning::Refused(CommissioningRefusal::Failed) => (0, 0, 5, 0, None),
        };
        for (at, v) in [(OFF_PLANNED, planned), (OFF_KEPT, kept), (OFF_STATE, state), (OFF_DETAIL, detail)] {
            if let Some(b) = out.get_mut(at) {
                *b = v;
            }
        }
        if let Some(b) = baseline {
            let mask = b.resolved.iter().enumerate().fold(0u16, |m, (i, r)| m | (u16::from(*r) << i));
            if let Some(dst) = out.get_mut(OFF_RESOLVED..OFF_RESOLVED + 2) {
                dst.copy_from_slice(&mask.to_le_bytes());
            }
            for i in 0..UNIT_PARAM_COUNT {
                put_f32(out, OFF_Z + 4 * i, b.z[i]);
                put_f32(out, OFF_SIGMA_Z + 4 * i, b.sigma_z[i]);
            }
        }
        Ok(Self::ENCODED_LEN)
    }

    /// Reads an encoding of [`HealthRecord::encode`], or of version 1 (identity
    /// [`RecordIdentity::UNKNOWN`]); every check of the module documentation.
    pub fn decode(bytes: &[u8]) -> Result<Self, RecordError> {
        let version = *bytes.first().ok_or(RecordError::Length)?;
        let expected_len = match version {
            1 => ENCODED_LEN_V1,
            RECORD_VERSION => Self::ENCODED_LEN,
            other => return Err(RecordError::Version(other)),
        };
        if bytes.len() != expected_len {
            return Err(RecordError::Length);
        }
        let status = status_of_code(bytes[OFF_STATUS])?;
        let mut record = Self::new();
        record.status = status;
        record.flights = get_u32(bytes, OFF_FLIGHTS);
        record.flights_since_cold = get_u32(bytes, OFF_SINCE_COLD);
        for (i, v) in record.k.iter_mut().enumerate() {
            *v = get_f32(bytes, OFF_K + 4 * i);
        }
        for (i, v) in record.sigma.iter_mut().enumerate() {
            *v = get_f32(bytes, OFF_SIGMA + 4 * i);
        }
        for (i, v) in record.evidence.iter_mut().enumerate() {
            *v = get_f32(bytes, OFF_EVIDENCE + 4 * i);
        }
        record.pooled_flights = get_u32(bytes, OFF_POOLED);
        let lens = bytes.get(OFF_HIST_LEN..OFF_HIST_HEAD).ok_or(RecordError::Length)?;
        let heads = bytes.get(OFF_HIST_HEAD..OFF_HIST_HEAD + MODES).ok_or(RecordError::Length)?;
        for (m, ((h, &len), &head)) in record.history.iter_mut().zip(lens).zip(heads).enumerate() {
            h.len = len;
            h.head = head;
            if usize::from(h.len) > HISTORY_LEN || usize::from(h.head) >= HISTORY_LEN {
                return Err(RecordError::History);
            }
            for (j, e) in h.entries.iter_mut().enumerate() {
                let at = OFF_HISTORY + (m * HISTORY_LEN + j) * ENTRY_LEN;
                *e = HistoryEntry { flight: get_u32(bytes, at), severity: get_f32(bytes, at + 4) };
            }
        }
        if version == RECORD_VERSION {
            record.identity =
                RecordIdentity { params: get_u32(bytes, OFF_IDENTITY), unit_serial: get_u32(bytes, OFF_SERIAL) };
            record.commissioning = decode_commissioning(bytes)?;
        }
        Ok(record)
    }

    /// Bitwise equality: as `==`, but NaN fields (an unknown `sigma`) equal themselves. What a
    /// store round trip must preserve.
    pub fn same_bits(&self, other: &Self) -> bool {
        let mut a = [0u8; Self::ENCODED_LEN];
        let mut b = [0u8; Self::ENCODED_LEN];
        self.encode(&mut a).is_ok() && other.encode(&mut b).is_ok() && a == b
    }
}

/// The commissioning fields of a version-2 encoding of [`HealthRecord::ENCODED_LEN`] bytes.
fn decode_commissioning(bytes: &[u8]) -> Result<Commissioning, RecordError> {
    let byte = |at: usize| bytes.get(at).copied().unwrap_or(0);
    let (planned, kept, detail) = (byte(OFF_PLANNED), byte(OFF_KEPT), byte(OFF_DETAIL));
    let mask = u16::from_le_bytes([byte(OFF_RESOLVED), byte(OFF_RESOLVED + 1)]);
    let baseline = UnitBaseline {
        z: core::array::from_fn(|i| get_f32(bytes, OFF_Z + 4 * i)),
        sigma_z: core::array::from_fn(|i| get_f32(bytes, OFF_SIGMA_Z + 4 * i)),
        resolved: core::array::from_fn(|i| mask & (1 << i) != 0),
    };
    Ok(match byte(OFF_STATE) {
        0 => Commissioning::Off,
        1 if kept < planned => Commissioning::Collecting { planned, kept },
        2 => Commissioning::Commissioned(baseline),
        3 if usize::from(detail) < UNIT_PARAM_COUNT => Commissioning::Refused(CommissioningRefusal::OutOfTolerance {
            param: detail,
            z: baseline.z[usize::from(detail)],
        }),
        4 => match status_of_code(detail)? {
            Some(status) => Commissioning::Refused(CommissioningRefusal::NotHealthy(status)),
            None => return Err(RecordError::Commissioning),
        },
        5 => Commissioning::Refused(CommissioningRefusal::Failed),
        _ => return Err(RecordError::Commissioning),
    })
}

fn put_u32(out: &mut [u8], at: usize, v: u32) {
    if let Some(dst) = out.get_mut(at..at + 4) {
        dst.copy_from_slice(&v.to_le_bytes());
    }
}

fn put_f32(out: &mut [u8], at: usize, v: f32) {
    put_u32(out, at, v.to_bits());
}

fn get_u32(bytes: &[u8], at: usize) -> u32 {
    match bytes.get(at..at + 4) {
        Some(&[a, b, c, d]) => u32::from_le_bytes([a, b, c, d]),
        _ => 0,
    }
}

fn get_f32(bytes: &[u8], at: usize) -> f32 {
    f32::from_bits(get_u32(bytes, at))
}
