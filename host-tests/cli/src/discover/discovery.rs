//! What `ema discover` found ([`Discovery`]): the fits before and after the named effects, the
//! residual's windows, regimes and orders, the search rounds, and the effects withdrawn and why.

use std::path::PathBuf;

use ema_monitor::{EffectId, FaultVector};

use super::fitting::ModelFit;
use super::localisation::{Regime, Window};
use super::naming::Round;
use super::residual::{rms, Series};
use crate::runtime::command::CommandJson;

/// Everything `ema discover` found.
#[derive(Clone, Debug)]
pub struct Discovery {
    /// Recording path.
    pub file: PathBuf,
    /// What drove the monitor model (set by `ema discover`; `None` from [`discover`](super::discover) alone).
    pub command: Option<CommandJson>,
    /// The current model's fit (whole recording).
    pub before: ModelFit,
    /// The model with the named effects (whole recording).
    pub after: ModelFit,
    /// The on-board diagnosis
    /// ([`IdentifyConfig::onboard`](ema_monitor::diagnosis::IdentifyConfig::onboard): fast regime
    /// weighted as on board, model selection, polish) with the paper's model.
    pub onboard_before: FaultVector,
    /// The same with the named effects promoted at their fitted severities (what the firmware
    /// reports once built with `model_config`); `onboard_before` when nothing is named.
    pub onboard_after: FaultVector,
    /// Residual series before and after.
    pub series_before: Series,
    /// After adding the named effects.
    pub series_after: Series,
    /// Hot windows (with RMS before and after).
    pub windows: Vec<Window>,
    /// Regime shares (before).
    pub regimes: Vec<Regime>,
    /// Order shares (before).
    pub orders: Vec<(&'static str, f64)>,
    /// The search rounds.
    pub rounds: Vec<Round>,
    /// Named effects: `(effect, severity, confidence)`.
    pub named: Vec<(EffectId, f32, f64)>,
    /// Effects a round named that step 4 withdrew, in the order withdrawn, and why.
    pub withdrawn: Vec<(EffectId, Withdrawal)>,
    /// Where a residual no library effect explains remains (`None`: at the model's floor).
    pub unexplained: Option<String>,
    /// True fault vector, when given.
    pub truth: Option<FaultVector>,
    /// Wall time (s).
    pub seconds: f64,
    /// Objective evaluations in all.
    pub evaluations: u64,
}

impl Discovery {
    /// Structural residual RMS before (A).
    pub fn rms_before_a(&self) -> f64 {
        rms(self.series_before.structural_a.iter().copied())
    }
    /// Structural residual RMS after (A).
    pub fn rms_after_a(&self) -> f64 {
        rms(self.series_after.structural_a.iter().copied())
    }
    /// Raw residual RMS before (A).
    pub fn raw_rms_before_a(&self) -> f64 {
        rms(self.series_before.residual_a.iter().copied())
    }
    /// Raw residual RMS after (A).
    pub fn raw_rms_after_a(&self) -> f64 {
        rms(self.series_after.residual_a.iter().copied())
    }
}

/// Why step 4 withdrew a named effect.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Withdrawal {
    /// The named effects' refit on the whole recording did not shrink its structural gap; the
    /// last one named goes.
    GapNotShrunk,
    /// The refit on the whole recording put it at this severity, at its fit's bound
    /// ([`PINNED_SEVERITY`](super::naming::PINNED_SEVERITY)), as a round's fit part would have
    /// had it refused: the effect behind the residual is stronger or different. A DC-link sag
    /// (outside the library) can fit as a dead time just under the bound on the fit part and
    /// above it on the whole recording.
    AtBound(f32),
}
