//! The flight's report on USART2 (TX on PA2, the NUCLEO's virtual COM port through the ST-LINK),
//! 115200 baud 8N1, beside the defmt log: one machine-readable line per diagnosed flight
//! (docs/board.md, "Report line"):
//!
//! ```text
//! EMA-REPORT v3 flight=12 status=DEGRADED reason=- mode=friction friction=0.2497 … commissioning=- record=ok*F555
//! ```
//!
//! - ASCII, one space between fields, every field `key=value` in a fixed order, every key always
//!   present; `-` stands for no value (no diagnosis, no reading);
//! - the version (`v1`) changes whenever a key is added, removed, reordered or changes meaning;
//! - `*` then the CRC-16/CCITT-FALSE (polynomial 0x1021, initial value 0xFFFF, no reflection, no
//!   final XOR; its check value over `123456789` is 0x29B1) of every byte before the `*`, as four
//!   upper-case hexadecimal digits, then CR LF;
//! - numbers: integers in decimal; reals in fixed point (`-12.5`, `0.0149`), `nan`, `inf` or
//!   `-inf`, and `ovf` from 1e9 on.
//!
//! The writes block, each byte bounded by [`BYTE_TIMEOUT_CYCLES`]; the watchdog is fed every
//! [`FEED_EVERY`] bytes. A line (about 360 bytes, at most about 490) takes 30–40 ms at 115200
//! baud.

use cortex_m::peripheral::DWT;
use ema_monitor::acquisition::{SensorCheck, SensorFault};
use ema_monitor::faults::FaultMode;
use ema_monitor::flight::Flight;
use ema_monitor::health::{Condition, HealthReport, ModeReport};
use ema_monitor::persist::{Commissioning, RecordOrigin};
use stm32f4xx_hal::gpio::PA2;
use stm32f4xx_hal::nb;
use stm32f4xx_hal::pac::USART2;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::Rcc;
use stm32f4xx_hal::serial::{config::Config, Tx};

use crate::rcc::{ClockSource, SYSCLK_HZ};
use crate::watchdog::Watchdog;

/// The line's format version.
pub const VERSION: &str = "v3";

/// Baud rate (8 data bits, no parity, 1 stop bit).
const BAUD: u32 = 115_200;

/// Longest line: the fields at their longest come to about 490 bytes.
const LINE_LEN: usize = 512;

/// Bytes sent between two watchdog feeds (5.6 ms at 115200 baud).
const FEED_EVERY: usize = 64;

/// Longest wait for the transmit register to take one byte, or for the last byte to leave: ten
/// byte times (10 bits each) at [`BAUD`], 0.87 ms. The USART has no flow control, so only a
/// stopped peripheral or clock makes it wait longer.
const BYTE_TIMEOUT_CYCLES: u32 = 10 * 10 * (SYSCLK_HZ / BAUD);

/// Why a line was not sent whole.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum ReportError {
    /// The line did not fit its buffer (nothing sent).
    TooLong,
    /// The USART did not take a byte, or did not finish sending, within [`BYTE_TIMEOUT_CYCLES`]
    /// (`sent` bytes had gone).
    Timeout {
        /// Bytes handed to the USART before it stalled.
        sent: u16,
    },
}

/// USART2's transmitter.
pub struct ReportUart {
    /// The transmit half on PA2 (AF7).
    tx: Tx<USART2>,
}

impl ReportUart {
    /// USART2 at 115200 8N1, transmitting on PA2; `None` when the HAL refuses the settings.
    pub fn new(usart: USART2, pin: PA2, rcc: &mut Rcc) -> Option<Self> {
        let config = Config::default().baudrate(BAUD.bps()).wordlength_8().parity_none();
        usart.tx(pin, config, rcc).ok().map(|tx| Self { tx })
    }

    /// Sends `line` and waits until its last byte has left (USART_SR.TC), feeding `watchdog`.
    /// Gives the bytes sent.
    pub fn send(&mut self, line: &Line, watchdog: &Watchdog) -> Result<usize, ReportError> {
        let bytes = line.bytes().ok_or(ReportError::TooLong)?;
        watchdog.feed();
        for (i, &byte) in bytes.iter().enumerate() {
            if i % FEED_EVERY == 0 {
                watchdog.feed();
            }
            let sent = u16::try_from(i).unwrap_or(u16::MAX);
            bounded(|| self.tx.write(byte)).ok_or(ReportError::Timeout { sent })?;
        }
        let sent = u16::try_from(bytes.len()).unwrap_or(u16::MAX);
        bounded(|| self.tx.flush()).ok_or(ReportError::Timeout { sent })?;
        Ok(bytes.len())
    }
}

/// Polls `op` until it stops blocking, at most [`BYTE_TIMEOUT_CYCLES`]; `None` on the timeout or
/// an error (the transmitter reports none).
fn bounded<E>(mut op: impl FnMut() -> nb::Result<(), E>) -> Option<()> {
    let start = DWT::cycle_count();
    loop {
        match op() {
            Ok(()) => return Some(()),
            Err(nb::Error::Other(_)) => return None,
            Err(nb::Error::WouldBlock) if DWT::cycle_count().wrapping_sub(start) > BYTE_TIMEOUT_CYCLES => return None,
            Err(nb::Error::WouldBlock) => {}
        }
    }
}

/// One report line, built in place.
pub struct Line {
    /// The bytes so far.
    buf: [u8; LINE_LEN],
    /// Bytes used.
    len: usize,
    /// A push did not fit: the line is not sent.
    overflow: bool,
}

impl Line {
    /// The line of `flight`, whose acquisition had `late_frames` late frames, sampled on the
    /// clock `clock`, flown on a health record of origin `record` (fields: docs/board.md,
    /// "Report line").
    pub fn of(flight: &Flight, late_frames: u32, clock: ClockSource, record: RecordOrigin) -> Self {
        let r = &flight.report;
        let diagnosis = r.status.is_diagnosis();
        let mut l = Self { buf: [0; LINE_LEN], len: 0, overflow: false };
        l.text("EMA-REPORT ");
        l.text(VERSION);
        l.key("flight");
        l.uint(flight.number);
        l.key("status");
        l.text(r.status.label());
        l.key("reason");
        match r.status.reason() {
            Some(reason) => l.token(reason.label()),
            None => l.text("-"),
        }
        l.key("mode");
        match worst_mode(r).filter(|_| diagnosis) {
            Some(m) => l.text(m.key()),
            None => l.text("-"),
        }
        for m in &r.modes {
            l.key(m.mode.key());
            if m.condition == Condition::NotAssessed {
                l.text("na");
            } else {
                l.real_or_dash(diagnosis.then_some(m.severity), 4);
            }
        }
        for m in &r.modes {
            l.key_suffixed(m.mode.key(), "_sd");
            l.real_or_dash(r.uncertainty.as_ref().filter(|_| diagnosis).map(|u| u.severity_sigma(m)), 4);
        }
        l.key("phase");
        let short = r.modes.iter().find(|m| m.mode == FaultMode::ShortCircuit).filter(|_| diagnosis);
        match short {
            Some(m) => l.text(["A", "B", "C"].get(usize::from(m.phase)).copied().unwrap_or("?")),
            None => l.text("-"),
        }
        l.key("declared");
        l.declared(flight);
        l.key("start");
        l.text(if flight.cold { "cold" } else { "warm" });
        l.key("temp_c");
        l.real_or_dash(flight.temperature_c.is_finite().then_some(flight.temperature_c), 1);
        l.key("fitness");
        l.real(r.fitness, 6);
        l.key("evals");
        l.uint(r.evaluations);
        l.key("refused");
        l.uint(r.refused_frames);
        l.key("sensors");
        l.sensors(&flight.sensors);
        l.key("late");
        l.uint(late_frames);
        l.key("clock");
        l.text(clock.name());
        l.key("commissioning");
        l.commissioning(flight.commissioning);
        l.key("record");
        l.text(if record.may_save() { "ok" } else { record.label() });
        let crc = crc16(l.buf.get(..l.len).unwrap_or(&[]));
        l.text("*");
        for shift in [12, 8, 4, 0] {
            l.push(b"0123456789ABCDEF".get(usize::from((crc >> shift) & 0xF)).copied().unwrap_or(b'?'));
        }
        l.text("\r\n");
        l
    }

    /// The whole line; `None` when it did not fit.
    pub fn bytes(&self) -> Option<&[u8]> {
        if self.overflow {
            None
        } else {
            self.buf.get(..self.len)
        }
    }

    /// Appends one byte (or marks the line too long).
    fn push(&mut self, byte: u8) {
        match self.buf.get_mut(self.len) {
            Some(slot) => {
                *slot = byte;
                self.len += 1;
            }
            None => self.overflow = true,
        }
    }

    /// The sensors' self-calibration: `-` when trusted, else the fault and its phase
    /// (`zero_B`, `rest_A`, `gain_C`, `rest_frames`).
    fn sensors(&mut self, check: &SensorCheck) {
        let (what, phase) = match check.fault {
            None => return self.text("-"),
            Some(SensorFault::TooFewRestFrames { .. }) => return self.text("rest_frames"),
            Some(SensorFault::NotAtRest { phase, .. }) => ("rest_", phase),
            Some(SensorFault::ZeroBeyondRange { phase, .. }) => ("zero_", phase),
            Some(SensorFault::GainMismatch { phase, .. }) => ("gain_", phase),
        };
        self.text(what);
        self.text(["A", "B", "C"].get(phase.index()).copied().unwrap_or("?"));
    }

    /// Appends `s` as it is.
    fn text(&mut self, s: &str) {
        s.bytes().for_each(|b| self.push(b));
    }

    /// Appends `s` with its spaces as underscores (`poor fit` → `poor_fit`).
    fn token(&mut self, s: &str) {
        s.bytes().for_each(|b| self.push(if b == b' ' { b'_' } else { b }));
    }

    /// Starts field `key`: ` key=`.
    fn key(&mut self, key: &str) {
        self.key_suffixed(key, "");
    }

    /// Starts field `key` + `suffix`: ` keysuffix=` (the 1σ fields, `friction_sd`).
    fn key_suffixed(&mut self, key: &str, suffix: &str) {
        self.push(b' ');
        self.text(key);
        self.text(suffix);
        self.push(b'=');
    }

    /// Appends `n` in decimal.
    fn uint(&mut self, n: u32) {
        self.digits(u64::from(n), 1);
    }

    /// Appends `n` in decimal with at least `width` digits (zeros in front).
    fn digits(&mut self, mut n: u64, width: u32) {
        const MAX: usize = 20; // u64::MAX has 20 digits
        let mut out = [b'0'; MAX];
        let mut count = 0;
        while (n > 0 || count < width as usize) && count < MAX {
            if let Some(d) = out.get_mut(MAX - 1 - count) {
                *d = b'0' + (n % 10) as u8;
            }
            n /= 10;
            count += 1;
        }
        out.get(MAX - count.max(1)..).unwrap_or(&[]).iter().for_each(|&d| self.push(d));
    }

    /// Appends `v` in fixed point with `decimals` decimals (at most 6), rounded to nearest; `nan`,
    /// `inf`, `-inf`, and `ovf` from 1e9 on.
    fn real(&mut self, v: f32, decimals: u32) {
        let decimals = decimals.min(6);
        let magnitude = if v < 0.0 { -v } else { v };
        if v.is_nan() {
            self.text("nan");
        } else if v.is_infinite() {
            self.text(if v > 0.0 { "inf" } else { "-inf" });
        } else if magnitude >= 1e9 {
            self.text("ovf");
        } else {
            let scale = 10u64.pow(decimals);
            // below 1e9 · 1e6, far inside u64: the cast (saturating) never saturates; single
            // precision, the FPU's, keeps the value's own 7 significant digits
            let scaled = (magnitude * scale as f32 + 0.5) as u64;
            if v < 0.0 && scaled > 0 {
                self.push(b'-');
            }
            self.digits(scaled / scale, 1);
            if decimals > 0 {
                self.push(b'.');
                self.digits(scaled % scale, decimals);
            }
        }
    }

    /// [`Line::real`], or `-` for `None`.
    fn real_or_dash(&mut self, v: Option<f32>, decimals: u32) {
        match v {
            Some(v) => self.real(v, decimals),
            None => self.text("-"),
        }
    }

    /// The modes declared by the evidence pooled over flights, comma-separated, or `-`.
    fn declared(&mut self, flight: &Flight) {
        let declared = flight.pooled.as_ref().map(|p| p.declared).unwrap_or_default();
        let mut any = false;
        for (&d, mode) in declared.iter().zip(FaultMode::ALL) {
            if d {
                if any {
                    self.push(b',');
                }
                self.text(mode.key());
                any = true;
            }
        }
        if !any {
            self.text("-");
        }
    }

    /// Where a commissioning stands after this flight: `off`, `collecting:K/N` (K windows kept of
    /// N), `commissioned`, `refused`; `-` for a flight outside commissioning.
    fn commissioning(&mut self, state: Option<Commissioning>) {
        match state {
            None => self.text("-"),
            Some(Commissioning::Off) => self.text("off"),
            Some(Commissioning::Collecting { planned, kept }) => {
                self.text("collecting:");
                self.uint(u32::from(kept));
                self.push(b'/');
                self.uint(u32::from(planned));
            }
            Some(Commissioning::Commissioned(_)) => self.text("commissioned"),
            Some(Commissioning::Refused(_)) => self.text("refused"),
        }
    }
}

/// The mode of the highest severity when it is degraded or failing; `None` when none is.
fn worst_mode(r: &HealthReport) -> Option<FaultMode> {
    r.modes
        .iter()
        .filter(|m| m.condition >= Condition::Degraded)
        .fold(None, |worst: Option<&ModeReport>, m| match worst {
            Some(w) if w.severity >= m.severity => Some(w),
            _ => Some(m),
        })
        .map(|m| m.mode)
}

/// CRC-16/CCITT-FALSE of `bytes`: polynomial 0x1021, initial value 0xFFFF, MSB first, no final
/// XOR.
const fn crc16(bytes: &[u8]) -> u16 {
    let mut crc: u16 = 0xFFFF;
    let mut rest = bytes;
    while let [byte, tail @ ..] = rest {
        crc ^= (*byte as u16) << 8;
        let mut bit = 0;
        while bit < 8 {
            crc = if crc & 0x8000 != 0 { (crc << 1) ^ 0x1021 } else { crc << 1 };
            bit += 1;
        }
        rest = tail;
    }
    crc
}

// The standard check value of CRC-16/CCITT-FALSE, checked when the firmware builds.
const _: () = assert!(crc16(b"123456789") == 0x29B1);
