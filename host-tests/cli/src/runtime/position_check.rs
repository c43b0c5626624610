//! The recording's position column checked against its command column and the identified model.
//!
//! The diagnosis uses only the phase currents and the command: a position column zeroed,
//! inverted or written in degrees would give the same diagnosis bit for bit. This check catches
//! such a column, which also says that the file's columns may not be what they seem.
//!
//! The monitor model at the identified fault vector is driven by the recording's command column,
//! one control step per row, and its position transducer's output `m_n` is compared with the
//! recorded position `p_n`, both about their means (a constant offset of the position sensor is
//! not a disagreement). With `p̃`, `m̃` the centred series:
//!
//! ```text
//! ratio = RMS(p̃ − m̃) / RMS(m̃),   gain = Σ p̃·m̃ / Σ m̃²
//! ```
//!
//! The column agrees when `ratio ≤` [`MAX_RATIO`]. The gain names the likely cause of a
//! disagreement: about 0 a column that does not move (zeroed, not connected), about −1 an
//! inverted sign, about 57.3 degrees instead of radians.

use ema_monitor::model::{ModelState, MonitorModel};
use ema_monitor::{EmaParams, FaultVector};
use serde::Serialize;

use crate::recording::Recording;

/// Largest `RMS(p̃ − m̃)/RMS(m̃)` of a position column that agrees with the model. The monitor
/// model at the identified vector follows the reference model's position to 0.05–0.08 % of the
/// swing, healthy or failing, on both manoeuvres, and the bench example's to 0.05 %; a zeroed
/// column gives 1, an inverted one 2, one in degrees 56.
pub const MAX_RATIO: f64 = 0.10;

/// The outcome of the check.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PositionCheck {
    /// `RMS(p̃ − m̃)` (rad).
    pub rms_error_rad: f64,
    /// `RMS(m̃)`, the model's position swing about its mean (rad).
    pub model_swing_rad: f64,
    /// `rms_error_rad / model_swing_rad`.
    pub ratio: f64,
    /// `Σ p̃·m̃ / Σ m̃²`: 1 for a column that follows the model.
    pub gain: f64,
    /// `ratio ≤` [`MAX_RATIO`].
    pub agrees: bool,
}

impl PositionCheck {
    /// What the disagreement most likely is (`None` when the column agrees).
    pub fn likely_cause(&self) -> Option<&'static str> {
        if self.agrees {
            None
        } else if self.gain.abs() < 0.2 {
            Some("the column does not follow the command (zeroed, not connected, or another column)")
        } else if (self.gain + 1.0).abs() < 0.2 {
            Some("the column's sign is inverted")
        } else if (self.gain / (180.0 / std::f64::consts::PI) - 1.0).abs() < 0.2 {
            Some("the column is in degrees, not radians")
        } else {
            Some("the column's scale or timing differs from the model's")
        }
    }
}

/// Checks `recording`'s position column: the monitor model of the actuator `params` with the
/// faults `faults`, driven by the recording's command column (module doc). `None` for a recording
/// too short to check (fewer than 2 rows) or whose model does not move.
pub fn check_position(recording: &Recording, params: &EmaParams, faults: &FaultVector) -> Option<PositionCheck> {
    let n = recording.command_rad.len().min(recording.position_rad.len());
    if n < 2 {
        return None;
    }
    let model = MonitorModel::new(params, faults);
    let mut state = ModelState::at_rest();
    let start = recording.command_rad[0];
    let mut modelled = Vec::with_capacity(n);
    for &c in &recording.command_rad[..n] {
        modelled.push(f64::from(state.measured_position_rad) + start);
        model.step(&mut state, (c - start) as f32);
    }
    let mean = |x: &[f64]| x.iter().sum::<f64>() / x.len() as f64;
    let (pm, mm) = (mean(&recording.position_rad[..n]), mean(&modelled));
    let (mut err, mut swing, mut cross) = (0.0f64, 0.0f64, 0.0f64);
    for (p, m) in recording.position_rad[..n].iter().zip(&modelled) {
        let (p, m) = (p - pm, m - mm);
        err += (p - m) * (p - m);
        swing += m * m;
        cross += p * m;
    }
    if swing.is_nan() || swing <= 0.0 || !err.is_finite() {
        return None;
    }
    let ratio = (err / swing).sqrt();
    Some(PositionCheck {
        rms_error_rad: (err / n as f64).sqrt(),
        model_swing_rad: (swing / n as f64).sqrt(),
        ratio,
        gain: cross / swing,
        agrees: ratio <= MAX_RATIO,
    })
}
