//! Where an identification is: the stage it runs and each stage's own state (model selection's
//! group under test, the warm start's probes), and what the warm stages report.

use super::groups::FAULT_GROUPS;
use crate::faults::FAULT_COUNT;
use crate::fitness::WindowErrors;
use crate::health::HealthReport;
use crate::optimizer::pattern::PatternSearch;
use crate::optimizer::TerminationReason;

/// Where an identification is (each stage spends one evaluation per `Identification::step`,
/// except the selection state that only picks the next group).
#[derive(Clone, Debug)]
#[allow(clippy::large_enum_variant, reason = "held once, inline in the identification: no allocator to box into")]
pub(super) enum Stage {
    /// The global search (PSO, GA or DE).
    Global,
    /// Model selection ([`Selection`]).
    Select(Selection),
    /// The compass-search polish.
    Polish(PatternSearch<FAULT_COUNT>),
    /// No polish, but selection changed the vector: evaluate it once, then finish.
    Rescore(TerminationReason),
    /// The stages of a warm start ([`WarmStage`]).
    Warm(WarmStage),
    /// Finished with this reason.
    Done(TerminationReason),
}

/// Where model selection is. `group` indexes [`FAULT_GROUPS`]; `effective_samples` is the `n` of
/// the information criterion, evaluated once on the global search's best vector.
#[derive(Clone, Debug)]
#[allow(clippy::large_enum_variant, reason = "held once, inline in the identification: no allocator to box into")]
pub(super) enum Selection {
    /// Evaluates the effective sample count of the best vector (one evaluation).
    EffectiveSamples,
    /// Evaluates the best vector with `group` set back to healthy, before any refit (one
    /// evaluation): a group that does not pay even against this unrefitted cost is dropped
    /// without its refit (`Identification::selection_step`).
    PreCheck {
        /// Group under test.
        group: usize,
        /// `n` of the information criterion.
        effective_samples: f32,
    },
    /// Starts the test of the first present group from `group` on (no evaluation).
    NextGroup {
        /// First group to consider.
        group: usize,
        /// `n` of the information criterion.
        effective_samples: f32,
    },
    /// Refits the other groups with `group` set back to healthy (one evaluation per step).
    Refit {
        /// Group under test.
        group: usize,
        /// `n` of the information criterion.
        effective_samples: f32,
        /// The compass search of the refit.
        search: PatternSearch<FAULT_COUNT>,
    },
    /// Checks window by window a group that paid the information criterion.
    WindowCheck {
        /// Group under test.
        group: usize,
        /// `n` of the information criterion.
        effective_samples: f32,
        /// Which of the check's two evaluations is next.
        check: WindowCheck,
    },
    /// After the groups are judged: scores the vector when selection changed it (one
    /// evaluation), then tries the next possible move of `PHASE_MOVES` from `next` on (one
    /// evaluation each, abandoned above the best cost) and keeps it when it lowers `E`.
    PhaseMove {
        /// First move of `PHASE_MOVES` not tried yet.
        next: usize,
        /// The vector the moves of `next`'s phase start from: the best one before the first of
        /// them, so the second competes with the first instead of moving its result.
        origin: [f32; FAULT_COUNT],
    },
}

/// The window-by-window check of a group that paid the information criterion
/// (`helps_without_its_best_window`): two evaluations, one state each.
#[derive(Clone, Debug)]
#[allow(clippy::large_enum_variant, reason = "held once, inline in the identification: no allocator to box into")]
pub(super) enum WindowCheck {
    /// Evaluates `E` per window of the best vector, with the group.
    With {
        /// The refit without the group.
        without: [f32; FAULT_COUNT],
    },
    /// Evaluates `E` per window of the refit without the group, then decides.
    Without {
        /// The refit without the group.
        without: [f32; FAULT_COUNT],
        /// `E` per window with the group.
        with: WindowErrors,
    },
}

/// Where the warm stages are.
#[derive(Clone, Debug)]
pub(super) enum WarmStage {
    /// Evaluates the prior's cost (one evaluation).
    Start,
    /// Evaluates `n` of the information criterion at the prior (one evaluation), then hands over
    /// to the drift polish (or, with model selection off, to the polish).
    Samples,
    /// Follows the drift of the prior's groups before the probes (`DRIFT_POLISH`; one
    /// evaluation per step).
    Drift(PatternSearch<FAULT_COUNT>),
    /// Runs probe `next` on (one evaluation each); bit `i` of `fired` marks probe `i` fired.
    Probe {
        /// Next probe index.
        next: u8,
        /// Fired probes, bit `i` for probe `i`.
        fired: u16,
    },
    /// Scouts the fired probes in turn (`PROBE_SCOUT`; one evaluation per step).
    Scout {
        /// Fired probes not scouted yet, bit `i` for probe `i`.
        left: u16,
        /// The scout under way.
        search: PatternSearch<FAULT_COUNT>,
        /// The best scouted point and its cost so far.
        best: Option<([f32; FAULT_COUNT], f32)>,
    },
    /// The targeted refit (one evaluation per step).
    Refit(PatternSearch<FAULT_COUNT>),
}

/// The warm identification's state beside the stage: its report, `n`, whether the probes have
/// started (`probing`: the polish then ends the warm stages) and whether model selection has
/// started (`selected`: the end of the probes then ends them).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct WarmState {
    pub(super) report: WarmReport,
    pub(super) effective_samples: f32,
    pub(super) probing: bool,
    pub(super) selected: bool,
}

/// What a warm identification did, beside its health report ([`super::Identification::warm_report`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct WarmReport {
    /// Groups of [`FAULT_GROUPS`] whose probe fired, bit `g` for group `g`.
    pub fired: u8,
    /// Probe evaluations run.
    pub probes: u16,
    /// Targeted refits run.
    pub refits: u8,
    /// Evaluations of the warm stages: the start, the probes, the scouts, the refits and the fit
    /// check (model selection and the polish count in the report's `evaluations`, with these).
    pub evaluations: u32,
    /// The warm result failed its fit check, and the identification went on cold (the global
    /// search, model selection and the polish) in the same call; the evaluations of the warm
    /// attempt are in `evaluations`.
    pub cold_fallback: bool,
}

impl WarmReport {
    /// `true` when group `g` of [`FAULT_GROUPS`] was found new by a probe.
    pub fn fired_group(&self, g: usize) -> bool {
        g < FAULT_GROUPS.len() && self.fired & (1 << g) != 0
    }

    /// `true` when the next identification must be cold: the warm result failed its fit check
    /// (a drift the polish could not follow, or a new fault the refit could not fit).
    pub fn needs_cold(&self, report: &HealthReport) -> bool {
        report.fit_check.is_some_and(|c| !c.passes())
    }
}
