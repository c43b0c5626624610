//! The independent watchdog (IWDG; RM0390, "Independent watchdog"), at register level: started
//! once, fed, and its timeout changed with the update it needs.
//!
//! **Why not the HAL's.** A new prescaler (IWDG_PR) or reload value (IWDG_RLR) reaches the
//! watchdog's counter, in the LSI's clock domain, up to five LSI cycles after the write: IWDG_SR's
//! PVU and RVU stay set until it has (RM0390, IWDG_SR). A reload (IWDG_KR = 0xAAAA) before that
//! reloads the counter with the *old* value. stm32f4xx-hal's `IndependentWatchdog::start` writes
//! PR and RLR and reloads at once, so a timeout raised for a flash erase stays the old one for
//! the erase and the chip resets in the middle of it. [`Watchdog::set_timeout_ms`] waits for PVU
//! and RVU to clear before it reloads.
//!
//! Every method takes `&self`: each is a short register sequence in thread mode, the type is not
//! `Sync` (the PAC's `IWDG` is not), so no interrupt handler can hold one and run in the middle of
//! another. Feeding from the sampler's wait hook and the flight's hooks then needs no `&mut`.

use core::cell::Cell;

use stm32f4xx_hal::pac::iwdg::pr::PR;
use stm32f4xx_hal::pac::IWDG;

/// The LSI's nominal frequency (Hz); the datasheet's range is 17–47 kHz, so a timeout lasts
/// between 0.68 and 1.9 times its nominal length.
const LSI_HZ: u32 = 32_000;

/// Polls of IWDG_SR while PVU or RVU is set, with [`UPDATE_POLL_CYCLES`] between two polls: at
/// least 5 ms at 180 MHz (more at a slower clock). An update takes up to five LSI cycles
/// (RM0390, IWDG_SR), 0.3 ms at the LSI's slowest (17 kHz).
const UPDATE_POLLS: u32 = 5_000;

/// Core cycles between two polls of IWDG_SR (1 µs at 180 MHz).
const UPDATE_POLL_CYCLES: u32 = 180;

/// The longest timeout: prescaler 256 and reload 4095, 32.768 s at the nominal LSI.
pub const MAX_TIMEOUT_MS: u32 = 32_768;

/// Why a timeout was not set.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum WatchdogError {
    /// The timeout asked for is 0 or above [`MAX_TIMEOUT_MS`]; nothing was written.
    OutOfRange {
        /// The timeout asked for (ms).
        ms: u32,
    },
    /// PVU or RVU was still set after [`UPDATE_POLLS`] polls: the new timeout may not be in
    /// force yet. The counter was reloaded anyway.
    UpdateTimeout {
        /// IWDG_SR.PVU at the last poll.
        pvu: bool,
        /// IWDG_SR.RVU at the last poll.
        rvu: bool,
    },
}

/// What the IWDG's counter runs with, read back from IWDG_PR and IWDG_RLR ([`Watchdog::in_force`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub struct InForce {
    /// IWDG_PR.PR: the LSI is divided by 4·2^PR (PR 6 and 7 both by 256).
    pub prescaler: u8,
    /// IWDG_RLR.RL: the counter's reload value.
    pub reload: u16,
    /// The timeout they give at the nominal LSI (ms): `(RL + 1)·divider / LSI`.
    pub timeout_ms: u32,
}

/// The running independent watchdog and the timeout last set on it.
pub struct Watchdog {
    /// The peripheral, owned: nothing else writes IWDG_KR.
    iwdg: IWDG,
    /// The timeout in force (ms, at the nominal LSI).
    timeout_ms: Cell<u32>,
}

impl Watchdog {
    /// Starts the IWDG (IWDG_KR = 0xCCCC, which also starts the LSI) with its reset timeout,
    /// prescaler 4 and reload 4095: 512 ms at the nominal LSI. [`Watchdog::set_timeout_ms`] sets
    /// the firmware's own. The IWDG cannot be stopped again short of a reset.
    pub fn start(iwdg: IWDG) -> Self {
        iwdg.kr().write(|w| w.key().start());
        Self { iwdg, timeout_ms: Cell::new(512) }
    }

    /// Reloads the counter (IWDG_KR = 0xAAAA): the chip resets if the next feed is more than the
    /// timeout away.
    pub fn feed(&self) {
        self.iwdg.kr().write(|w| w.key().feed());
    }

    /// The timeout set last (ms at the nominal LSI).
    pub fn timeout_ms(&self) -> u32 {
        self.timeout_ms.get()
    }

    /// Sets the timeout to at least `ms` (at the nominal LSI; rounded up to the prescaler's
    /// step) and reloads: waits for a previous update to end, unlocks PR and RLR
    /// (IWDG_KR = 0x5555), writes them, waits for PVU and RVU to clear, then reloads, which also
    /// locks them again (RM0390, IWDG register access protection and IWDG_SR). Gives the timeout
    /// set (ms).
    pub fn set_timeout_ms(&self, ms: u32) -> Result<u32, WatchdogError> {
        let Some((pr, rl, set_ms)) = prescaler_and_reload(ms) else {
            return Err(WatchdogError::OutOfRange { ms });
        };
        let ready = self.wait_updated();
        if ready.is_ok() {
            self.iwdg.kr().write(|w| w.key().unlock());
            self.iwdg.pr().write(|w| w.pr().variant(pr));
            self.iwdg.rlr().write(|w| w.rl().set(rl));
            self.timeout_ms.set(set_ms);
        }
        let updated = ready.and_then(|()| self.wait_updated());
        self.feed();
        updated.map(|()| set_ms)
    }

    /// The prescaler and reload the counter runs with, read back once no update is under way:
    /// IWDG_PR and IWDG_RLR read the values of the LSI's clock domain, valid only while IWDG_SR's
    /// PVU and RVU are clear (RM0390, IWDG_PR and IWDG_RLR). Waits for them (bounded, as
    /// [`Watchdog::set_timeout_ms`]); writes nothing and does not feed.
    pub fn in_force(&self) -> Result<InForce, WatchdogError> {
        self.wait_updated()?;
        let prescaler = self.iwdg.pr().read().pr().bits();
        let reload = self.iwdg.rlr().read().rl().bits();
        let divider = 4u32 << u32::from(prescaler.min(6));
        let timeout_ms = (u32::from(reload) + 1) * divider / (LSI_HZ / 1000); // ≤ 4096·256/32
        Ok(InForce { prescaler, reload, timeout_ms })
    }

    /// Waits, bounded, until IWDG_SR shows no update in progress.
    fn wait_updated(&self) -> Result<(), WatchdogError> {
        let mut sr = self.iwdg.sr().read();
        for _ in 0..UPDATE_POLLS {
            if !sr.pvu().bit_is_set() && !sr.rvu().bit_is_set() {
                return Ok(());
            }
            cortex_m::asm::delay(UPDATE_POLL_CYCLES);
            sr = self.iwdg.sr().read();
        }
        Err(WatchdogError::UpdateTimeout { pvu: sr.pvu().bit_is_set(), rvu: sr.rvu().bit_is_set() })
    }
}

/// The smallest prescaler whose 12-bit reload reaches `ms`, the reload (rounded up) and the
/// timeout they give (ms): `(RL + 1)·4·2^PR / LSI`. `None` for 0 or above [`MAX_TIMEOUT_MS`].
fn prescaler_and_reload(ms: u32) -> Option<(PR, u16, u32)> {
    const PRESCALERS: [(PR, u32); 7] = [
        (PR::DivideBy4, 4),
        (PR::DivideBy8, 8),
        (PR::DivideBy16, 16),
        (PR::DivideBy32, 32),
        (PR::DivideBy64, 64),
        (PR::DivideBy128, 128),
        (PR::DivideBy256, 256),
    ];
    if ms == 0 || ms > MAX_TIMEOUT_MS {
        return None;
    }
    let lsi_ticks = ms * (LSI_HZ / 1000); // ≤ 1 048 576
    PRESCALERS.iter().find_map(|&(pr, divider)| {
        let counts = lsi_ticks.div_ceil(divider);
        let reload = u16::try_from(counts - 1).ok().filter(|&rl| rl <= 0x0FFF)?;
        Some((pr, reload, counts * divider / (LSI_HZ / 1000)))
    })
}
