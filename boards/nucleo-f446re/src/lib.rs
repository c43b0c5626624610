//! The NUCLEO-F446RE board's modules and settings, shared by the firmware (`main.rs`, which wires
//! them) and the on-target tests (`tests/on_target.rs`, which run them on the chip through
//! probe-rs): the watchdog, the clocks, the simultaneous sampling and its interrupt, the health
//! record in flash, the report line, the flight loop and the safe state (docs/board.md).
//!
//! The panic handler and the global logger are the binary's and the tests' own choices (the
//! firmware: panic-probe into the safe state; the tests: embedded-test's, which reports the
//! failure to probe-rs), so this library links neither handler.
#![no_std]
#![deny(missing_docs)]

use ema_monitor::EmaParams;

/// DBGMCU: the debug connection through low-power modes.
pub mod dbgmcu;
/// DMA2 stream 0's interrupt: one simultaneous frame per control period into the sampler.
pub mod dma_sampling;
/// FLASH_ACR and FLASH_OPTCR: the data cache flush and the brown-out level.
pub mod flash_control;
/// The flight loop.
pub mod flights;
/// The health record in flash sectors 6–7.
pub mod health_flash;
/// RCC: the clocks and the reset cause.
pub mod rcc;
/// USART2: the report line.
pub mod report_uart;
/// Failure and the safe state.
pub mod safe_state;
/// TIM5: the log's timestamps.
pub mod timestamp;
/// ADC1–3 in triple regular simultaneous mode, triggered by TIM2, read by DMA2.
pub mod triple_adc;
/// The independent watchdog.
pub mod watchdog;

/// Independent-watchdog timeout. The longest thing done between two feeds is one objective
/// evaluation: at most about 1.2e7 instructions at this crate's `opt-level = "s"` (a full,
/// not early-abandoned model run), about 105 ms at 1.6 cycles per instruction and 180 MHz.
/// 500 ms leaves a margin above 4, and above 3 at the LSI's fastest (47 kHz against 32 kHz).
pub const WATCHDOG_MS: u32 = 500;

/// Period of one ADC frame: 100 µs, the control period of `EmaParams::NOMINAL` (10 kHz).
pub const FRAME_PERIOD_US: u32 = 100;

/// The frame rate, 10 kHz.
pub const FRAME_RATE_HZ: u32 = 1_000_000 / FRAME_PERIOD_US;

/// Ticks the sampler waits for the start trigger before it re-arms (10 s).
pub const TRIGGER_TIMEOUT_FRAMES: u32 = 100_000;

/// The actuator's parameters.
pub const PARAMS: EmaParams = EmaParams::NOMINAL;

/// Flights of the commissioning a new record starts with (`docs/commissioning.md`).
pub const COMMISSIONING_FLIGHTS: u8 = 3;
