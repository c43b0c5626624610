//! The MCU debug component (DBGMCU; RM0390, "Debug support"): what a probe keeps while the core
//! sleeps or is halted.

use stm32f4xx_hal::pac::DBGMCU;

/// Keeps the debug connection through low-power modes and freezes the watchdog while a probe
/// halts the core:
/// - DBGMCU_CR: DBG_SLEEP (HCLK and FCLK stay on in Sleep mode, so a probe keeps reaching the core
///   and RTT while thread mode sleeps in `wfi`, which it does between frames and while idle),
///   DBG_STOP and DBG_STANDBY (the same in Stop and Standby, which the firmware does not enter:
///   set so that a probe survives one entered by mistake). Without a probe they cost the clocks'
///   current during `wfi`, the firmware's only low-power state.
/// - DBGMCU_APB1_FZ: DBG_IWDG_STOP, so that a probe halting the core (a breakpoint, a step) does
///   not let the watchdog reset it.
///
/// DBGMCU is reset by a power-on reset only: a system or watchdog reset keeps these bits.
pub fn keep_debug_in_low_power(dbgmcu: &DBGMCU) {
    dbgmcu.cr().modify(|_, w| w.dbg_sleep().set_bit().dbg_stop().set_bit().dbg_standby().set_bit());
    dbgmcu.apb1_fz().modify(|_, w| w.dbg_iwdg_stop().set_bit());
}
