//! Phase-current ADC format shared by the reference model (which records it), the firmware's
//! built-in trace (which stores it packed in flash) and acquisition (which converts it back).
//!
//! Current sensors: 12-bit ADC over ±20 A, mid-scale at zero current (physics.md §3.8):
//! `counts = clamp(round(ADC_MIDSCALE + i/AMPS_PER_COUNT), 0, ADC_MAX)`.

/// ADC resolution.
pub const ADC_BITS: u32 = 12;
/// Largest ADC code.
pub const ADC_MAX: u16 = (1 << ADC_BITS) - 1;
/// Code of zero current.
pub const ADC_MIDSCALE: u16 = 1 << (ADC_BITS - 1);
/// Current sensor range: ±`CURRENT_FULL_SCALE_A`.
pub const CURRENT_FULL_SCALE_A: f32 = 20.0;
/// Nominal current per ADC code (40 A over 4096 codes).
pub const AMPS_PER_COUNT: f32 = 2.0 * CURRENT_FULL_SCALE_A / (1 << ADC_BITS) as f32;
/// ADC sample rate of the phase currents: one frame per control period (10 kHz).
pub const SAMPLE_RATE_HZ: u32 = 10_000;

/// Nominal conversion of a current to its ADC code (saturating at the rails).
pub fn amps_to_counts(i_a: f32) -> u16 {
    let c = libm::roundf(ADC_MIDSCALE as f32 + i_a / AMPS_PER_COUNT);
    if c.is_nan() || c < 0.0 {
        0
    } else if c > ADC_MAX as f32 {
        ADC_MAX
    } else {
        c as u16
    }
}

/// Nominal conversion of an ADC code back to amperes.
pub fn counts_to_amps(counts: u16) -> f32 {
    (counts as f32 - ADC_MIDSCALE as f32) * AMPS_PER_COUNT
}
