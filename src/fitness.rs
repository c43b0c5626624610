//! The fitness: how far the monitor model with a candidate fault vector is from the measurement.
//!
//! The paper's error (§VI), on the conditioned equivalent current:
//!
//! ```text
//! E(k) = (1/n)·Σ_i w_i·(I_3eq,i − Ĩ_MM,i(k))²,     w_i = 1 / (1 + (İ_3eq,i / C)²)
//! ```
//!
//! where `Ĩ_MM` is the monitor model's expected measured envelope (its current `I_out` through the
//! sensors' rectified noise, [`crate::conditioning::MeasuredEnvelope`]) through the same block mean as the measurement
//! ([`crate::conditioning`]) and `C` the RMS of the measured derivative. The mean (not the sum)
//! keeps `E` in A², independent of the trace length. Every term is ≥ 0, so the running partial sum
//! only grows: an evaluation can stop as soon as it exceeds the value it must beat
//! (early abandoning, see [`crate::optimizer::Objective`]).
//!
//! **Fast-regime weight** (ours, [`EquivalentCurrentFit::with_fast_regime_weight`]; the paper's fitness is
//! weight 1): in the step and reversal transients (the healthy model's `|ω_m|` above
//! [`FAST_REGIME_SPEED_RAD_S`]) the residual is dominated by what the monitor model gets only
//! approximately (the current through each commutation above the dip onset), not by noise, and
//! that error is correlated over many samples. Least squares that weighs those samples like the
//! rest lets the mismatch pull the estimate (a short circuit drawing a spurious eccentricity).
//! Their terms are multiplied by `ρ` ([`FAST_REGIME_WEIGHT`] in the monitor's configuration):
//! `E(k) = (1/n)·Σ_i ρ_i·w_i·r_i²`, `ρ_i = ρ` in the fast regime, 1 elsewhere.
//!
//! **Pooled recordings** ([`EquivalentCurrentFit::pooled_with`]): one fault vector fitted to several
//! recordings of one actuator (several flights). Each recording is simulated from rest under its
//! own command, and the terms of all of them are summed and divided by their total sample count
//! `n = Σ_r n_r`, so `E` stays a sample-weighted mean in A² and one recording gives exactly the
//! single-trace value. The effective samples, the mean sample weight and the evidence windows see
//! every recording (`docs/decisions/0020-evidence-over-flights.md`).

use crate::command::{AnyCommandCursor, Command, CommandCursor, CommandSource, SampledCursor};
use crate::conditioning::{ConditionedWindow, ConditioningError, MeasuredEnvelope, SensorErrorEnvelope, DECIMATION};
use crate::effects::ModelEffects;
use crate::faults::{FaultVector, FAULT_COUNT};
use crate::model::{ModelState, MonitorModel};
use crate::optimizer::Objective;
use crate::params::EmaParams;
use crate::profile::ProfileCursor;
use core::num::NonZeroUsize;
use heapless::Vec;

/// Motor speed above which a window sample belongs to the fast regime (rad/s): the step and
/// reversal transients of the healthy model, which accelerate through the commutation-dip onset
/// `V_dc/(4k_0)` = 519 rad/s.
pub const FAST_REGIME_SPEED_RAD_S: f32 = 300.0;

/// The weight `ρ` of a fast-regime sample in the monitor's fitness ([`EquivalentCurrentFit::with_fast_regime_weight`]).
/// 0.1 removes the spurious eccentricities of high short circuits and low gains that the
/// fast-regime mismatch draws; the price is low eccentricities, whose evidence lies mostly in the
/// fast regime. The campaigns behind the value are in `docs/decisions/0001-fast-regime-weight.md`.
pub const FAST_REGIME_WEIGHT: f32 = 0.1;

/// `true` when `weight` is a fast-regime weight the fitness accepts: in `(0, 1]` (NaN is not).
pub fn fast_regime_weight_is_valid(weight: f32) -> bool {
    weight > 0.0 && weight <= 1.0
}

/// Most fast-regime intervals a fitness keeps per recording (the standard manoeuvre has 2; later
/// ones weigh 1).
pub const MAX_FAST_INTERVALS: usize = 8;

/// Most recordings one fitness pools ([`EquivalentCurrentFit::pooled_with`]): the first one and up to
/// `MAX_POOLED_RECORDINGS − 1` more.
pub const MAX_POOLED_RECORDINGS: usize = 10;

/// Most fast-regime intervals a fitness keeps in all: [`MAX_FAST_INTERVALS`] for the first
/// recording and two (the standard manoeuvre's) for each pooled one; intervals beyond weigh 1.
/// Sized for the pooled recordings without growing the on-board fitness' stack by more than a
/// few hundred bytes.
pub const MAX_POOLED_FAST_INTERVALS: usize = MAX_FAST_INTERVALS + 2 * (MAX_POOLED_RECORDINGS - 1);

/// One more recording of the same actuator for a pooled fitness ([`EquivalentCurrentFit::pooled_with`]):
/// a finished conditioned window and the command it was measured under.
#[derive(Clone, Copy, Debug)]
pub struct PooledTrace<'a, const W: usize> {
    /// The conditioned window ([`ConditionedWindow::finish`]ed).
    pub trace: &'a ConditionedWindow<W>,
    /// The command (a [`crate::Profile`] or a sampled command) the trace was measured under.
    pub command: Command<'a>,
}

/// Window samples per evidence window ([`EquivalentCurrentFit::window_errors`]): 100, i.e. 40 ms, about
/// one reversal's transient. Longer traces get longer windows so that there are at most
/// [`MAX_EVIDENCE_WINDOWS`].
pub const EVIDENCE_WINDOW_SAMPLES: usize = 100;

/// Most evidence windows a trace is split into.
pub const MAX_EVIDENCE_WINDOWS: usize = 96;

/// `E(k)` split over consecutive windows of the trace (of the recordings in turn, when pooled):
/// `errors[j]` holds the terms `(1/n)·ρ_i·w_i·r_i²` of window `j`, so the windows sum to `E(k)`.
#[derive(Clone, Debug, PartialEq)]
pub struct WindowErrors {
    /// Per-window parts of `E(k)` (A²), the unused tail zero.
    pub errors: [f32; MAX_EVIDENCE_WINDOWS],
    /// Window samples per window (the last one may be shorter).
    pub window_samples: usize,
    /// Window samples of the whole trace (of every recording, when pooled).
    pub samples: usize,
}

/// The residual sums of one evidence window ([`EquivalentCurrentFit::residual_windows`]), with
/// `u_i = √(ρ_i·w_i)·r_i` the weighted residual of sample `i`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WindowResidual {
    /// Window samples.
    pub samples: u32,
    /// `S = Σ u_i²` (A²).
    pub weighted_sq: f32,
    /// `V = Σ ρ_i·w_i`.
    pub weight: f32,
    /// `L = Σ u_i·u_{i−1}` over consecutive samples of the window (A²).
    pub lag: f32,
}

/// Runs the monitor model with faults `k` under `command` (a [`crate::Profile`], or a sampled
/// command: [`Command`]) for `samples` window samples and hands each block mean of the expected
/// measured envelope ([`MeasuredEnvelope`] of `I_out`, with the sensors' and controller's noise),
/// with the model state at the block's end, to `sink(index, value, state)`; `sink` returns
/// `false` to stop early.
pub fn simulate_window<'c>(
    params: &EmaParams,
    command: impl CommandSource<'c>,
    k: &FaultVector,
    samples: usize,
    sink: impl FnMut(usize, f32, &ModelState) -> bool,
) {
    simulate_window_with_effects(params, command, k, &ModelEffects::NONE, samples, sink)
}

/// [`simulate_window`] with the monitor model's optional effect terms `effects` switched on.
pub fn simulate_window_with_effects<'c>(
    params: &EmaParams,
    command: impl CommandSource<'c>,
    k: &FaultVector,
    effects: &ModelEffects,
    samples: usize,
    mut sink: impl FnMut(usize, f32, &ModelState) -> bool,
) {
    let model = MonitorModel::with_effects(params, k, effects);
    // The command source and the step's effect terms chosen once per window, not per step
    // (MonitorModel::step_with): each pair is its own loop.
    let sink: &mut dyn FnMut(usize, f32, &ModelState) -> bool = &mut sink;
    let command = command.into_command();
    let command = AnyCommandCursor::new(&command);
    if model.has_step_terms() {
        run_window_shared::<true>(&model, params, effects, command, samples, sink)
    } else {
        run_window_shared::<false>(&model, params, effects, command, samples, sink)
    }
}

/// The loop of [`simulate_window_with_effects`], shared by every caller: the sink is called
/// through a pointer once a window sample, the model's step out of line
/// ([`MonitorModel::step_out_of_line`]) and the loop is not inlined, so that the model's step is
/// not compiled into every caller (the board's flash). The objective under a profile, evaluated
/// about 1 600 times a flight, keeps a loop of its own with its step and sink inlined
/// ([`simulate_window_inlined`]): through the pointer each of its window samples would cost
/// about 90 instructions more (4 % of an identification).
#[inline(never)]
fn run_window_shared<const TERMS: bool>(
    model: &MonitorModel,
    params: &EmaParams,
    effects: &ModelEffects,
    command: AnyCommandCursor<'_>,
    samples: usize,
    sink: &mut dyn FnMut(usize, f32, &ModelState) -> bool,
) {
    run_window::<TERMS, true>(model, params, effects, command, samples, sink)
}

/// [`simulate_window_with_effects`] with `sink` compiled into the loop: the objective's hot path
/// ([`EquivalentCurrentFit::error_of_unit`]).
fn simulate_window_inlined<'c>(
    params: &EmaParams,
    command: impl CommandSource<'c>,
    k: &FaultVector,
    effects: &ModelEffects,
    samples: usize,
    mut sink: impl FnMut(usize, f32, &ModelState) -> bool,
) {
    let model = MonitorModel::with_effects(params, k, effects);
    match (&command.into_command(), model.has_step_terms()) {
        (Command::Profile(p), true) => {
            run_window::<true, false>(&model, params, effects, ProfileCursor::new(p), samples, &mut sink)
        }
        (Command::Profile(p), false) => {
            run_window::<false, false>(&model, params, effects, ProfileCursor::new(p), samples, &mut sink)
        }
        // a sampled command is the host's recorded command or a test's: the shared loop
        (Command::Sampled(s), terms) => {
            let command = AnyCommandCursor::Sampled(SampledCursor::new(s));
            if terms {
                run_window_shared::<true>(&model, params, effects, command, samples, &mut sink)
            } else {
                run_window_shared::<false>(&model, params, effects, command, samples, &mut sink)
            }
        }
    }
}

/// The loop of [`simulate_window_with_effects`] with (`TERMS`) or without the step's effect
/// terms, reading the command from `command`; the model's step inlined, or called out of line
/// (`SHARED_STEP`).
fn run_window<const TERMS: bool, const SHARED_STEP: bool>(
    model: &MonitorModel,
    params: &EmaParams,
    effects: &ModelEffects,
    mut command: impl CommandCursor,
    samples: usize,
    sink: &mut (impl FnMut(usize, f32, &ModelState) -> bool + ?Sized),
) {
    let envelope = MeasuredEnvelope::of(params);
    let sensors = SensorErrorEnvelope::of(&envelope, params, effects);
    let dt = model.dt_s();
    let mut state = ModelState::at_rest();
    let mut step = 0u32;
    for i in 0..samples {
        let mut block = 0.0f32;
        for _ in 0..DECIMATION {
            block += match &sensors {
                Some(e) if TERMS => {
                    e.expected_a(model.commutation_sector(&state), state.output_current_a, &state.freewheel_shift_a)
                }
                _ => envelope.expected_a(state.output_current_a),
            };
            let theta = command.command_rad(step, step as f32 * dt);
            if SHARED_STEP {
                model.step_out_of_line::<TERMS>(&mut state, theta);
            } else {
                model.step_with::<TERMS>(&mut state, theta);
            }
            step += 1;
        }
        if !sink(i, block * (1.0 / DECIMATION as f32), &state) {
            return;
        }
    }
}

/// The paper's fitness of the equivalent current `I_3eq` (amperes, not "the current one") over a
/// conditioned window: an [`Objective`] over the 8 fault parameters.
#[derive(Clone, Debug)]
pub struct EquivalentCurrentFit<'a, const W: usize> {
    trace: &'a ConditionedWindow<W>,
    params: EmaParams,
    command: Command<'a>,
    effects: ModelEffects,
    /// The recordings pooled after the first ([`EquivalentCurrentFit::pooled_with`]; empty: one recording).
    more: &'a [PooledTrace<'a, W>],
    /// Window-sample intervals `[start, end)` of the fast regime, in order, indexed over the
    /// recordings in turn (the first one's samples, then the next one's, …).
    fast_intervals: Vec<(u32, u32), MAX_POOLED_FAST_INTERVALS>,
    /// Their weight `ρ` (1: the paper's fitness).
    fast_weight: f32,
}

/// The weight `ρ_i` of each window sample in turn (samples asked for in increasing order).
#[derive(Clone, Debug)]
pub(crate) struct RegimeWeights<'f> {
    intervals: &'f [(u32, u32)],
    next: usize,
    weight: f32,
}

impl RegimeWeights<'_> {
    /// `ρ_i` of window sample `i`; `i` must not decrease between calls.
    pub(crate) fn at(&mut self, i: usize) -> f32 {
        let i = i as u32;
        while let Some(&(_, end)) = self.intervals.get(self.next) {
            if i < end {
                break;
            }
            self.next += 1;
        }
        match self.intervals.get(self.next) {
            Some(&(start, _)) if i >= start => self.weight,
            _ => 1.0,
        }
    }
}

impl<'a, const W: usize> EquivalentCurrentFit<'a, W> {
    /// The fitness of the monitor model of `params`, driven by `command` (a [`crate::Profile`] or
    /// a sampled command), against `trace`. Only a finished trace ([`ConditionedWindow::finish`]) has
    /// the weights `w_i` the fitness needs: an unfinished one is refused with
    /// [`ConditioningError::Finished`].
    pub fn new(
        trace: &'a ConditionedWindow<W>,
        params: EmaParams,
        command: impl Into<Command<'a>>,
    ) -> Result<Self, ConditioningError> {
        if !trace.is_finished() {
            return Err(ConditioningError::Finished);
        }
        Ok(Self {
            trace,
            params,
            command: command.into(),
            effects: ModelEffects::NONE,
            more: &[],
            fast_intervals: Vec::new(),
            fast_weight: 1.0,
        })
    }

    /// The same fitness with the fast-regime samples weighted by `weight` (module doc). The
    /// intervals come from one run of the healthy model (one evaluation's cost). A weight outside
    /// `(0, 1]` (or NaN) is refused: `None`.
    pub fn with_fast_regime_weight(mut self, weight: f32) -> Option<Self> {
        let effects = self.effects;
        self.configure(effects, weight).then_some(self)
    }

    /// The effect terms `effects` and the fast-regime weight `fast_regime_weight` set in place, the
    /// intervals found again ([`EquivalentCurrentFit::with_effects`] then
    /// [`EquivalentCurrentFit::with_fast_regime_weight`]): `false` (the fitness left as it was)
    /// for a weight outside `(0, 1]`. Not inlined: the healthy model's run that finds the
    /// intervals has its frame to itself, not beside its caller's copies of the fitness.
    #[inline(never)]
    pub fn configure(&mut self, effects: ModelEffects, fast_regime_weight: f32) -> bool {
        if !fast_regime_weight_is_valid(fast_regime_weight) {
            return false;
        }
        (self.effects, self.fast_weight) = (effects, fast_regime_weight);
        self.find_fast_intervals();
        true
    }

    /// Finds the fast-regime intervals of every recording (none at weight 1): one run of the
    /// healthy model per recording, at most [`MAX_FAST_INTERVALS`] per recording and
    /// [`MAX_POOLED_FAST_INTERVALS`] in all.
    fn find_fast_intervals(&mut self) {
        self.fast_intervals.clear();
        if self.fast_weight == 1.0 {
            return;
        }
        let mut offset = 0u32;
        for (trace, command) in recordings(self.trace, &self.command, self.more) {
            let mut start: Option<u32> = None;
            let mut kept = 0usize;
            let intervals = &mut self.fast_intervals;
            let n = trace.len();
            let mut keep = |interval: (u32, u32)| {
                // more than MAX_FAST_INTERVALS in one recording: the rest keep weight 1
                if kept < MAX_FAST_INTERVALS && intervals.push(interval).is_ok() {
                    kept += 1;
                }
            };
            simulate_window(&self.params, command, &FaultVector::HEALTHY, n, |i, _, state| {
                let fast = libm::fabsf(state.motor_speed_rad_s) > FAST_REGIME_SPEED_RAD_S;
                match (fast, start) {
                    (true, None) => start = Some(offset + i as u32),
                    (false, Some(s)) => {
                        start = None;
                        keep((s, offset + i as u32));
                    }
                    _ => {}
                }
                true
            });
            if let Some(s) = start {
                keep((s, offset + n as u32));
            }
            offset += n as u32;
        }
    }

    /// The same fitness pooled over `more` recordings of the same actuator besides the first
    /// (module doc): `E(k)` over all of them, each simulated from rest under its own command. At
    /// most [`MAX_POOLED_RECORDINGS`] in all; a recording not finished, or longer than its command
    /// by more than one control period, is refused.
    pub fn pooled_with(mut self, more: &'a [PooledTrace<'a, W>]) -> Result<Self, PoolError> {
        if more.len() + 1 > MAX_POOLED_RECORDINGS {
            return Err(PoolError::TooMany);
        }
        for (index, p) in more.iter().enumerate() {
            if !p.trace.is_finished() {
                return Err(PoolError::Unfinished { index });
            }
            let trace_s = (p.trace.len() * DECIMATION) as f32 * self.params.control_period_s;
            if trace_s > p.command.duration_s(&self.params) + self.params.control_period_s {
                return Err(PoolError::LongerThanCommand { index });
            }
        }
        self.more = more;
        self.find_fast_intervals();
        Ok(self)
    }

    /// Recordings in the fitness: 1, or 1 + the pooled ones.
    pub fn recording_count(&self) -> usize {
        1 + self.more.len()
    }

    /// Window samples of every recording together (`n` of `E(k)`).
    pub fn samples(&self) -> usize {
        self.trace.len() + self.more.iter().map(|p| p.trace.len()).sum::<usize>()
    }

    /// `true` when every recording covers its whole command ([`crate::conditioning::covers`]).
    pub fn covers_commands(&self) -> bool {
        recordings(self.trace, &self.command, self.more)
            .all(|(t, c)| crate::conditioning::covers(t.len(), c.duration_s(&self.params), &self.params))
    }

    /// The fast-regime intervals `[start, end)` in window samples, and their weight.
    pub fn fast_regime(&self) -> (&[(u32, u32)], f32) {
        (&self.fast_intervals, self.fast_weight)
    }

    /// A walker over the sample weights `ρ_i`.
    pub(crate) fn regime_weights(&self) -> RegimeWeights<'_> {
        RegimeWeights { intervals: &self.fast_intervals, next: 0, weight: self.fast_weight }
    }

    /// The same fitness with the monitor model's effect terms `effects` on.
    pub fn with_effects(mut self, effects: ModelEffects) -> Self {
        self.effects = effects;
        self
    }

    /// The effect terms the model runs with.
    pub fn effects(&self) -> &ModelEffects {
        &self.effects
    }

    /// The command that drives the model (on the first recording).
    pub fn command(&self) -> &Command<'a> {
        &self.command
    }

    /// The (first) conditioned window.
    pub fn trace(&self) -> &'a ConditionedWindow<W> {
        self.trace
    }

    /// `E(k)`, evaluated to the end.
    pub fn error(&self, k: &FaultVector) -> f32 {
        self.error_abandoning(k, f32::INFINITY)
    }

    /// `E(k)`, or any value above `abandon_above` as soon as the partial sum exceeds it.
    /// A non-finite result is returned as `f32::INFINITY`.
    pub fn error_abandoning(&self, k: &FaultVector, abandon_above: f32) -> f32 {
        self.error_of_unit(&self.params, k, abandon_above)
    }

    /// `E(k)` of the monitor model of another unit `params` against the same recordings (with
    /// the fast-regime intervals found for the fitness's own parameters), abandoned as
    /// [`EquivalentCurrentFit::error_abandoning`]: the objective of commissioning
    /// ([`crate::commissioning`]), which moves the unit's parameters instead of the faults.
    pub fn error_of_unit(&self, params: &EmaParams, k: &FaultVector, abandon_above: f32) -> f32 {
        let n = self.samples();
        if n == 0 {
            return f32::INFINITY;
        }
        let inv_n = 1.0 / n as f32;
        // Stop when sum·inv_n > abandon_above; compare sums to avoid a multiply per sample.
        let limit = if abandon_above.is_finite() { abandon_above * n as f32 } else { f32::INFINITY };
        let mut sum = 0.0f32;
        let mut rho = self.regime_weights();
        let mut offset = 0usize;
        for (trace, command) in recordings(self.trace, &self.command, self.more) {
            simulate_window_inlined(params, command, k, &self.effects, trace.len(), |i, model_a, _| {
                // i < n and the trace is finished: `sample` never misses (a miss would end the
                // sum; it exists so that no panic path does).
                let Some((y_i, w_i)) = trace.sample(i) else { return false };
                let r = y_i - model_a;
                sum += rho.at(offset + i) * w_i * r * r;
                sum <= limit
            });
            if sum.is_nan() || sum > limit {
                break;
            }
            offset += trace.len();
        }
        let e = sum * inv_n;
        if e.is_finite() {
            e
        } else {
            f32::INFINITY
        }
    }
}

/// Why [`EquivalentCurrentFit::pooled_with`] refused the recordings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PoolError {
    /// More than [`MAX_POOLED_RECORDINGS`] recordings.
    TooMany,
    /// The pooled recording `index` is not finished ([`ConditionedWindow::finish`]).
    Unfinished {
        /// Its index among the pooled ones (0: the second recording).
        index: usize,
    },
    /// The pooled recording `index` is longer than its command.
    LongerThanCommand {
        /// Its index among the pooled ones (0: the second recording).
        index: usize,
    },
}

impl core::fmt::Display for PoolError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            PoolError::TooMany => write!(f, "more than {MAX_POOLED_RECORDINGS} recordings to pool"),
            PoolError::Unfinished { index } => write!(f, "pooled recording {} is not finished", index + 2),
            PoolError::LongerThanCommand { index } => {
                write!(f, "pooled recording {} is longer than its command", index + 2)
            }
        }
    }
}

/// The recordings of a fitness in turn: the first (`trace` under `command`), then `more`.
fn recordings<'s, 'a: 's, const W: usize>(
    trace: &'a ConditionedWindow<W>,
    command: &'s Command<'a>,
    more: &'s [PooledTrace<'a, W>],
) -> impl Iterator<Item = (&'a ConditionedWindow<W>, &'s Command<'a>)> + 's {
    core::iter::once((trace, command)).chain(more.iter().map(|p| (p.trace, &p.command)))
}

impl<const W: usize> EquivalentCurrentFit<'_, W> {
    /// `E(k)` split over windows of [`EVIDENCE_WINDOW_SAMPLES`] (more when the trace would need
    /// more than [`MAX_EVIDENCE_WINDOWS`]): one model run per recording. Pooled recordings are
    /// windowed in turn, as one long trace.
    pub fn window_errors(&self, k: &FaultVector) -> WindowErrors {
        let n = self.samples();
        let window_samples = EVIDENCE_WINDOW_SAMPLES.max(n.div_ceil(MAX_EVIDENCE_WINDOWS));
        let mut out = WindowErrors { errors: [0.0; MAX_EVIDENCE_WINDOWS], window_samples, samples: n };
        if n == 0 {
            return out;
        }
        let inv_n = 1.0 / n as f32;
        let mut rho = self.regime_weights();
        let errors = &mut out.errors;
        // ≥ EVIDENCE_WINDOW_SAMPLES; as a non-zero type the division has no panic path wherever
        // the loop is compiled (the sampled command's loop is out of line)
        let per_window = NonZeroUsize::new(window_samples).unwrap_or(NonZeroUsize::MIN);
        let mut offset = 0usize;
        for (trace, command) in recordings(self.trace, &self.command, self.more) {
            simulate_window_with_effects(&self.params, command, k, &self.effects, trace.len(), |i, model_a, _| {
                let Some((y_i, w_i)) = trace.sample(i) else { return false };
                let r = y_i - model_a;
                let at = offset + i;
                if let Some(e) = errors.get_mut(at / per_window) {
                    *e += rho.at(at) * w_i * r * r * inv_n;
                }
                true
            });
            offset += trace.len();
        }
        out
    }

    /// Mean weight `w̄ = (1/n)·Σ_i ρ_i·w_i` of the samples in `E(k)` (of every recording): a
    /// residual of variance `s²` per sample gives `E ≈ w̄·s²` (the goodness-of-fit test,
    /// [`crate::health::FitCheck`]).
    pub fn mean_sample_weight(&self) -> f32 {
        let n = self.samples();
        if n == 0 {
            return 0.0;
        }
        let mut rho = self.regime_weights();
        let mut sum = 0.0f32;
        let mut offset = 0usize;
        for (trace, _) in recordings(self.trace, &self.command, self.more) {
            sum += trace.weights().enumerate().map(|(i, wi)| rho.at(offset + i) * wi).sum::<f32>();
            offset += trace.len();
        }
        sum / n as f32
    }

    /// Effective number of independent samples in the weighted residual `u_i = √w_i·r_i` of `k`:
    /// `n_eff = n·(1 − ρ)/(1 + ρ)` with `ρ = Σu_i u_{i−1} / Σu_i²` the lag-1 autocorrelation
    /// (clamped to `[0, 0.99]`), the usual AR(1) correction of the sample count (Bartlett 1946):
    /// the block means of a filtered noise are not independent, and an information criterion
    /// that counted every sample would keep parameters that only fit noise. Pooled recordings are
    /// independent of each other: their counts add, each with its own `ρ`.
    pub fn effective_samples(&self, k: &FaultVector) -> f32 {
        self.residual_windows(k, |_, _| {}).0
    }

    /// [`EquivalentCurrentFit::effective_samples`] of `k` and, from the same model run, the residual sums of
    /// each evidence window (the windows of [`EquivalentCurrentFit::window_errors`], which also end at the
    /// end of each pooled recording) handed to `sink(window, sums)` at the window's end: the
    /// goodness-of-fit test's two statistics ([`crate::health::FitCheck`]). Returns `n_eff` and
    /// the number of windows handed to `sink`.
    pub fn residual_windows(&self, k: &FaultVector, mut sink: impl FnMut(usize, &WindowResidual)) -> (f32, usize) {
        let window_samples = EVIDENCE_WINDOW_SAMPLES.max(self.samples().div_ceil(MAX_EVIDENCE_WINDOWS));
        let (mut n_eff, mut windows, mut offset) = (0.0f32, 0usize, 0usize);
        let mut rho = self.regime_weights();
        for (trace, command) in recordings(self.trace, &self.command, self.more) {
            let n = trace.len();
            let (mut sum_sq, mut sum_lag, mut previous) = (0.0f32, 0.0f32, 0.0f32);
            let mut window = WindowResidual::default();
            simulate_window_with_effects(&self.params, command, k, &self.effects, n, |i, model_a, _| {
                let Some((y_i, w_i)) = trace.sample(i) else { return false };
                let v = rho.at(offset + i) * w_i;
                let r = y_i - model_a;
                let u = libm::sqrtf(v) * r;
                sum_sq += u * u;
                sum_lag += u * previous;
                if window.samples > 0 {
                    window.lag += u * previous;
                }
                previous = u;
                window.samples += 1;
                window.weighted_sq += u * u;
                window.weight += v;
                // counted, not divided: no division by the window length on the on-board path
                if window.samples as usize >= window_samples || i + 1 == n {
                    sink(windows, &window);
                    windows += 1;
                    window = WindowResidual::default();
                }
                true
            });
            let r = if sum_sq > 0.0 && sum_lag.is_finite() { sum_lag / sum_sq } else { 0.0 };
            let r = clamp_unit(r, 0.99);
            n_eff += n as f32 * (1.0 - r) / (1.0 + r);
            offset += n;
        }
        (n_eff, windows)
    }
}

/// `x` clamped to `[0, hi]` (NaN → 0).
fn clamp_unit(x: f32, hi: f32) -> f32 {
    if x > hi {
        hi
    } else if x >= 0.0 {
        x
    } else {
        0.0
    }
}

impl<const W: usize> Objective<FAULT_COUNT> for EquivalentCurrentFit<'_, W> {
    fn cost(&mut self, x: &[f32; FAULT_COUNT], abandon_above: f32) -> f32 {
        self.error_abandoning(&FaultVector(*x), abandon_above)
    }
}

#[cfg(test)]
mod tests;
