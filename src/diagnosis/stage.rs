//! The contract between the identification's stages and their executor
//! ([`super::Identification`]): a stage's step spends at most one objective evaluation on the
//! shared state ([`super::state::IdentificationState`]) and answers with a [`Next`], the stage
//! the executor runs after it. A stage moves between its own states in place; a move to another
//! stage is a small [`Next`] that the executor builds the next stage from, in place, so no stage
//! names another and none holds a large value on its way out.

use crate::optimizer::TerminationReason;

/// What the executor does after a stage's step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Next {
    /// The stage goes on: its next step spends the next evaluation.
    Stay,
    /// Model selection from its start: `n` of the information criterion first
    /// (`selection.rs`).
    Select,
    /// Model selection from its first group test, `n` known (a warm start's, `selection.rs`).
    SelectGroups {
        /// `n` of the information criterion.
        effective_samples: f32,
    },
    /// The polish of the kept groups, then [`Next::Finish`] with this reason (`polish.rs`).
    Polish(TerminationReason),
    /// One evaluation of the best vector, whose cost is unknown, then [`Next::Finish`]
    /// (`polish.rs`).
    Rescore(TerminationReason),
    /// The polish is over: the probes a warm start has not run yet, its end, or the end
    /// (`warm.rs`).
    Finish(TerminationReason),
    /// The new-fault probes of a warm start, from the first (`probes.rs`).
    Probes,
    /// The warm stages are over: the fit check of their result, then the end or the cold
    /// fallback (`warm.rs`).
    EndWarm(TerminationReason),
    /// The global search (`global.rs`): a warm start that failed its fit check goes on cold.
    Global,
    /// Finished with this reason.
    Done(TerminationReason),
}
