//! The state every stage of an identification works on: the fitness, the best vector and its
//! cost, the groups model selection kept, the evaluations spent after the global search and the
//! warm start's bookkeeping. Its fields are private: a stage reads and changes them through the
//! methods here, so each stage's file says what it does to the shared state and nothing else can.

use super::config::{selection_polish_left, IdentifyConfig};
use super::groups::{group_present, without_group};
use super::MODEL_MISMATCH_A;
use crate::faults::{FaultGroup, FaultVector, FAULT_COUNT, GROUP_COUNT};
use crate::fitness::{EquivalentCurrentFit, PoolError, PooledTrace};
use crate::health::{window_score, Abstain, FitCheck, HealthReport, Status as HealthStatus};
use crate::optimizer::pattern::PatternSearch;
use crate::optimizer::{Optimizer, SearchStatus, TerminationReason};
use crate::params::EmaParams;

/// Whose evaluations a stage spends: the warm stages' ([`WarmReport::evaluations`]), or those of
/// model selection and the polish, which spend from
/// [`IdentifyConfig::selection_polish_max_evaluations`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Account {
    /// The warm stages.
    Warm,
    /// Model selection and the polish (and the score of an outside start point).
    Later,
}

/// The warm identification's state beside its stages: its report, `n` at the prior, whether the
/// probes have started (`probing`: the polish then ends the warm stages) and whether model
/// selection has started (`selected`: the end of the probes then ends them).
#[derive(Clone, Copy, Debug, Default)]
struct WarmState {
    report: WarmReport,
    effective_samples: f32,
    probing: bool,
    selected: bool,
}

/// What a warm identification did, beside its health report ([`super::Identification::warm_report`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct WarmReport {
    /// Groups whose probe fired, bit [`FaultGroup::index`] for each.
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
    /// `true` when `group` was found new by a probe.
    pub fn fired_group(&self, group: FaultGroup) -> bool {
        self.fired & (1 << group.index()) != 0
    }

    /// `true` when the next identification must be cold: the warm result failed its fit check
    /// (a drift the polish could not follow, or a new fault the refit could not fit).
    pub fn needs_cold(&self, report: &HealthReport) -> bool {
        report.fit_check.is_some_and(|c| !c.passes())
    }
}

/// Where a warm start is, as the stage after the polish needs it ([`IdentificationState::warm_phase`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum WarmPhase {
    /// A cold identification.
    Cold,
    /// A warm one whose probes have not started.
    BeforeProbes,
    /// A warm one whose probes have started.
    Probing,
    /// A warm one that failed its fit check and went on cold.
    FellBack,
}

/// The shared state of one identification over a trace of `W` window samples.
#[derive(Clone, Debug)]
pub(super) struct IdentificationState<'a, const W: usize> {
    fit: EquivalentCurrentFit<'a, W>,
    params: EmaParams,
    config: IdentifyConfig,
    /// Best vector and cost of the stages after the global search.
    best: [f32; FAULT_COUNT],
    best_cost: f32,
    /// Groups kept by model selection (all of them when it is off).
    kept: [bool; GROUP_COUNT],
    /// Evaluations spent after the global search (model selection and the polish).
    later_evaluations: u32,
    /// Present groups model selection had no budget left to test.
    untested_groups: u8,
    /// Why the global search stopped (a warm start, which has none, converged).
    global_reason: TerminationReason,
    /// The warm start's state (`None`: a cold identification).
    warm: Option<WarmState>,
}

impl<'a, const W: usize> IdentificationState<'a, W> {
    /// The state of an identification on `fit` before its first step: from the warm start point
    /// `start` when there is one, from the healthy vector (the global search's) otherwise.
    pub(super) fn new(
        fit: EquivalentCurrentFit<'a, W>,
        params: EmaParams,
        config: &IdentifyConfig,
        start: Option<[f32; FAULT_COUNT]>,
    ) -> Self {
        Self {
            fit,
            params,
            config: *config,
            best: start.unwrap_or(FaultVector::HEALTHY.0),
            best_cost: f32::INFINITY,
            kept: [true; GROUP_COUNT],
            later_evaluations: 0,
            untested_groups: 0,
            global_reason: TerminationReason::FunctionTolerance,
            warm: start.map(|_| WarmState::default()),
        }
    }

    /// The configuration the identification runs with.
    pub(super) fn config(&self) -> &IdentifyConfig {
        &self.config
    }

    /// The actuator's healthy parameters.
    pub(super) fn params(&self) -> &EmaParams {
        &self.params
    }

    /// The fitness being minimised.
    pub(super) fn fitness(&self) -> &EquivalentCurrentFit<'a, W> {
        &self.fit
    }

    /// The same state with `more` recordings pooled after the first
    /// ([`EquivalentCurrentFit::pooled_with`]).
    pub(super) fn pooled_with(mut self, more: &'a [PooledTrace<'a, W>]) -> Result<Self, PoolError> {
        self.fit = self.fit.pooled_with(more)?;
        Ok(self)
    }

    /// The best vector of the stages after the global search.
    pub(super) fn best(&self) -> &[f32; FAULT_COUNT] {
        &self.best
    }

    /// The cost of [`IdentificationState::best`] (NaN while unknown).
    pub(super) fn best_cost(&self) -> f32 {
        self.best_cost
    }

    /// Makes `x`, of cost `cost`, the best vector.
    pub(super) fn set_best(&mut self, x: [f32; FAULT_COUNT], cost: f32) {
        (self.best, self.best_cost) = (x, cost);
    }

    /// Sets `group` of the best vector back to healthy; its cost is unknown (NaN) until a later
    /// evaluation.
    pub(super) fn drop_group(&mut self, group: FaultGroup) {
        self.best = without_group(&self.best, group);
        self.best_cost = f32::NAN;
    }

    /// Evaluates the cost of the best vector (one evaluation, spent from `account`).
    pub(super) fn rescore(&mut self, account: Account) {
        self.best_cost = self.fit.error(&FaultVector(self.best));
        self.spend(account, 1);
    }

    /// One evaluation on the fitness, spent from `account`: `run` does it (and nothing else).
    /// Inlined, as the two steps below: no frame of its own between a stage and the model run.
    #[inline(always)]
    pub(super) fn evaluate<T>(
        &mut self,
        account: Account,
        run: impl FnOnce(&mut EquivalentCurrentFit<'a, W>) -> T,
    ) -> T {
        let value = run(&mut self.fit);
        self.spend(account, 1);
        value
    }

    /// One step of a compass search on the fitness, its evaluations spent from `account`.
    #[inline(always)]
    pub(super) fn step_search(&mut self, search: &mut PatternSearch<FAULT_COUNT>, account: Account) -> SearchStatus {
        let before = search.evaluations();
        let status = search.step(&mut self.fit);
        self.spend(account, search.evaluations() - before);
        status
    }

    /// One step of the global search's optimizer on the fitness (it counts its own evaluations).
    #[inline(always)]
    pub(super) fn step_optimizer(&mut self, optimizer: &mut impl Optimizer<FAULT_COUNT>) -> SearchStatus {
        optimizer.step(&mut self.fit)
    }

    fn spend(&mut self, account: Account, evaluations: u32) {
        match (account, self.warm.as_mut()) {
            (Account::Warm, Some(warm)) => warm.report.evaluations += evaluations,
            (Account::Warm, None) => {}
            (Account::Later, _) => self.later_evaluations += evaluations,
        }
    }

    /// What is left of the budget of model selection and the polish.
    pub(super) fn budget_left(&self) -> u32 {
        selection_polish_left(&self.config, self.later_evaluations)
    }

    /// Whether model selection keeps `group`.
    pub(super) fn kept(&self, group: FaultGroup) -> bool {
        self.kept.get(group.index()).is_some_and(|&kept| kept)
    }

    /// Keeps `group` or drops it.
    pub(super) fn keep(&mut self, group: FaultGroup, kept: bool) {
        if let Some(k) = self.kept.get_mut(group.index()) {
            *k = kept;
        }
    }

    /// Which groups model selection kept, by [`FaultGroup::index`].
    pub(super) fn kept_groups(&self) -> [bool; GROUP_COUNT] {
        self.kept
    }

    /// Counts the present groups from `first` on (in [`FaultGroup::ALL`] order) as left untested
    /// (no budget left).
    pub(super) fn leave_untested_from(&mut self, first: FaultGroup) {
        let present = FaultGroup::ALL.iter().skip(first.index()).filter(|&&g| group_present(&self.best, g)).count();
        self.untested_groups = present as u8; // at most GROUP_COUNT = 7
    }

    /// Why the global search stopped (a warm start, which has none, converged): the termination
    /// reason of the stages after it.
    pub(super) fn global_reason(&self) -> TerminationReason {
        self.global_reason
    }

    /// The global search ended at `best` (cost `cost`) for `reason`.
    pub(super) fn global_done(&mut self, best: [f32; FAULT_COUNT], cost: f32, reason: TerminationReason) {
        (self.best, self.best_cost, self.global_reason) = (best, cost, reason);
    }

    /// Where a warm start is.
    pub(super) fn warm_phase(&self) -> WarmPhase {
        match self.warm {
            None => WarmPhase::Cold,
            Some(w) if w.report.cold_fallback => WarmPhase::FellBack,
            Some(w) if w.probing => WarmPhase::Probing,
            Some(_) => WarmPhase::BeforeProbes,
        }
    }

    /// What the warm stages did (`None` for a cold identification).
    pub(super) fn warm_report(&self) -> Option<WarmReport> {
        self.warm.map(|w| w.report)
    }

    /// `n` of the information criterion at the prior (0 before it is evaluated, or when cold).
    pub(super) fn prior_samples(&self) -> f32 {
        self.warm.map_or(0.0, |w| w.effective_samples)
    }

    /// Keeps `n` of the information criterion at the prior.
    pub(super) fn set_prior_samples(&mut self, effective_samples: f32) {
        if let Some(warm) = self.warm.as_mut() {
            warm.effective_samples = effective_samples;
        }
    }

    /// The probes start: the polish then ends the warm stages.
    pub(super) fn begin_probes(&mut self) {
        if let Some(warm) = self.warm.as_mut() {
            warm.probing = true;
        }
    }

    /// Counts one probe run, and its group `fired` when it fired.
    pub(super) fn record_probe(&mut self, fired: Option<FaultGroup>) {
        if let Some(warm) = self.warm.as_mut() {
            warm.report.probes = warm.report.probes.saturating_add(1);
            if let Some(g) = fired {
                warm.report.fired |= 1 << g.index();
            }
        }
    }

    /// Targeted refits run so far (a cold identification runs none, and may start none).
    pub(super) fn refits(&self) -> Option<u8> {
        self.warm.map(|w| w.report.refits)
    }

    /// Counts one targeted refit.
    pub(super) fn record_refit(&mut self) {
        if let Some(warm) = self.warm.as_mut() {
            warm.report.refits += 1;
        }
    }

    /// Model selection starts after a warm start's probes, once: `n` at the prior, or `None`
    /// when it is off, has run already, or the identification is cold.
    pub(super) fn begin_warm_selection(&mut self) -> Option<f32> {
        let model_selection = self.config.model_selection;
        match self.warm.as_mut() {
            Some(warm) if model_selection && !warm.selected => {
                warm.selected = true;
                Some(warm.effective_samples)
            }
            _ => None,
        }
    }

    /// The warm result failed its fit check: the identification goes on cold from the healthy
    /// vector, with the whole budget of model selection and the polish, the warm attempt's
    /// evaluations counted in the warm report. `false` (nothing changed) when it is cold or has
    /// fallen back already.
    pub(super) fn fall_back_cold(&mut self) -> bool {
        let Some(warm) = self.warm.as_mut() else { return false };
        if warm.report.cold_fallback {
            return false;
        }
        warm.report.cold_fallback = true;
        warm.report.evaluations += self.later_evaluations;
        self.later_evaluations = 0;
        self.kept = [true; GROUP_COUNT];
        self.untested_groups = 0;
        (self.best, self.best_cost) = (FaultVector::HEALTHY.0, f32::INFINITY);
        true
    }

    /// `true` when the best vector fails its goodness-of-fit test (one model run, spent from
    /// `account`; [`Self::judge`]).
    pub(super) fn fails_fit_check(&mut self, account: Account) -> bool {
        let report = self.report(self.best, self.best_cost, 0, 0, None);
        self.spend(account, 1);
        report.fit_check.is_some_and(|c| !c.passes())
    }

    /// The health report of `best` (cost `cost`) after `global_evaluations` evaluations and
    /// `iterations` iterations of the global search, judged on the data ([`Self::judge`]).
    pub(super) fn report(
        &self,
        best: [f32; FAULT_COUNT],
        cost: f32,
        global_evaluations: u32,
        iterations: u32,
        termination: Option<TerminationReason>,
    ) -> HealthReport {
        let warm = self.warm.map_or(0, |w| w.report.evaluations);
        let evaluations = global_evaluations + self.later_evaluations + warm;
        let report = HealthReport::new(FaultVector(best), &self.params, cost, evaluations, iterations, termination);
        let report = HealthReport { untested_groups: self.untested_groups, ..report };
        self.judge(report, &FaultVector(best))
    }

    /// The report's status from the data: [`Abstain::PartialCoverage`] when the trace is shorter
    /// than the profile, [`Abstain::PoorFit`] when the goodness-of-fit test ([`FitCheck`]) of `best`
    /// rejects it, on the whole recording or in its worst window (one model run for the effective
    /// sample count and the window sums).
    pub(super) fn judge(&self, report: HealthReport, best: &FaultVector) -> HealthReport {
        let noise = super::window_noise_variance_a2(&self.params, self.config.independent_frames_per_block)
            + MODEL_MISMATCH_A * MODEL_MISMATCH_A;
        let expected = self.fit.mean_sample_weight() * noise;
        let (mut worst, mut at) = (f32::NEG_INFINITY, 0u16);
        let (n_eff, windows) = self.fit.residual_windows(best, |j, w| {
            let z = window_score(w.samples, w.weighted_sq, w.weight, w.lag, noise);
            // a NaN score (non-finite residual) replaces any other, is kept, and fails the test
            if !worst.is_nan() && (z.is_nan() || z > worst) {
                worst = z;
                at = j as u16;
            }
        });
        let check = FitCheck::new(report.fitness, n_eff, expected).with_windows(worst, at, windows);
        let report = HealthReport { fit_check: Some(check), ..report };
        let report =
            if check.passes() { report } else { report.abstaining(HealthStatus::Inconclusive(Abstain::PoorFit)) };
        if self.fit.covers_commands() {
            report
        } else {
            report.abstaining(HealthStatus::Inconclusive(Abstain::PartialCoverage))
        }
    }
}
