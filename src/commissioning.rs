//! Commissioning: a unit's own baseline from a few recordings of it, healthy.
//!
//! A unit differs from the drawing by its production tolerances ([`crate::unit`]). Diagnosed
//! against the drawing, those differences read as faults or as a poor fit. Commissioning moves
//! the unit's parameters instead of the faults: with the fault vector held healthy, it finds the
//! deviations `z` (in tolerance standard deviations, [`Tolerances::apply`]) that make the monitor
//! model match the recordings, with the tolerance table as the prior. The estimate is the
//! maximum a posteriori point of
//!
//! ```text
//! J(z) = Σ_r n_r·E_r(P_r(z)) / (2·s²) + ½·|z|²,    P_r(z) = apply(base, z) at the temperature T_r
//! ```
//!
//! with `E_r` the fitness of recording `r` ([`EquivalentCurrentFit::error_of_unit`], healthy faults),
//! `n_r` its window samples and `s² = σ² + m²` the noise of a window sample and the monitor
//! model's structural mismatch ([`MODEL_MISMATCH_A`]). A direction the recordings do not see
//! stays at the prior's 0 (nominal); one they see moves as far as the data ask.
//!
//! The search: a particle swarm over `z ∈ [−4, 4]^11` seeded with the drawing (`z = 0`), then a
//! damped Gauss–Newton descent from its best point, each step one lockstep run of the base model
//! and the 11 stepped ones per recording ([`BaselineFit::normal_equations`]). The deviations are
//! strongly correlated (the current is a torque over the EMF constant: inertia, friction and
//! hinge load trade against it), a long valley that Gauss–Newton follows and a compass search
//! does not; the response is rough on the scale of an event moving by one control period, which
//! stops a descent from the drawing in a dip that the swarm steps over. The inverse of the
//! Gauss–Newton Hessian is the posterior covariance once the data term is scaled to the noise
//! the fault uncertainty uses ([`covariance_noise_a2`]: the mismatch counted as correlated); a parameter whose posterior 1σ
//! is below [`RESOLVED_BELOW`] of its prior is resolved. Those that are not are put back to
//! nominal (the prior holds them near there already) and the resolved ones descend again
//! without them.
//!
//! A commissioning run does not judge health: a resolved parameter more than
//! [`OUT_OF_TOLERANCE_SIGMAS`] from nominal ([`Baseline::out_of_tolerance`]) is a unit outside
//! its tolerances, or a fault, and must not become a baseline; the caller also diagnoses the
//! recordings against the new baseline before it keeps it.

use crate::diagnosis::{covariance_noise_a2, window_noise_variance_a2, MODEL_MISMATCH_A};
use crate::faults::FaultVector;
use crate::fitness::EquivalentCurrentFit;
use crate::health::DEGRADED_AT;
use crate::model::MonitorModel;
use crate::optimizer::pso::{ParticleSwarm, PsoConfig};
use crate::optimizer::{run, Bounds, ConfigError, Objective, Optimizer};
use crate::params::{EmaParams, ParamsError};
use crate::unit::{ToleranceError, Tolerances, UNIT_PARAM_COUNT};

/// Dimension of the search: the unit parameters.
const D: usize = UNIT_PARAM_COUNT;

/// Most recordings one commissioning fits.
pub const MAX_COMMISSIONING_FLIGHTS: usize = 8;

/// Particles of the commissioning swarm (on the host and on board).
pub const SWARM_PARTICLES: usize = 24;

/// Iterations of the commissioning swarm.
pub const SWARM_ITERATIONS: u32 = 40;

/// Half-width of the search box, in tolerance standard deviations.
pub const SEARCH_SIGMAS: f32 = 4.0;

/// A parameter is resolved when its posterior 1σ is below this fraction of its prior 1σ: the
/// recordings narrow what the tolerance table says about it by at least a tenth. One they do
/// not is left nominal; the prior already holds it near there.
pub const RESOLVED_BELOW: f32 = 0.9;

/// A resolved parameter further than this from nominal (in its tolerance's σ), beyond the
/// estimate's own uncertainty, is not an ordinary unit: [`Baseline::out_of_tolerance`].
pub const OUT_OF_TOLERANCE_SIGMAS: f32 = 3.0;

/// Posterior standard deviations an estimate must lie beyond [`OUT_OF_TOLERANCE_SIGMAS`] to be
/// out of tolerance: about 98 % one-sided confidence that the unit's own value is beyond it.
pub const OUT_OF_TOLERANCE_CONFIDENCE: f32 = 2.0;

/// One recording of the unit: its fitness (built for the base parameters) and the temperature it
/// was flown at.
#[derive(Clone, Copy, Debug)]
pub struct CommissioningFlight<'f, 'a, const W: usize> {
    /// The fitness of the recording.
    pub fit: &'f EquivalentCurrentFit<'a, W>,
    /// Its temperature (°C); NaN when unknown: the parameters are taken at 20 °C.
    pub temperature_c: f32,
}

/// Why a commissioning could not run or gave no baseline.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CommissioningError {
    /// No recording, or more than [`MAX_COMMISSIONING_FLIGHTS`].
    FlightCount,
    /// The tolerance table was refused.
    Tolerances(ToleranceError),
    /// The base parameters, or the fitted unit's, are refused by [`EmaParams::check`].
    Params(ParamsError),
    /// The optimizer settings were refused.
    Optimizer(ConfigError),
}

impl core::fmt::Display for CommissioningError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            CommissioningError::FlightCount => {
                write!(f, "commissioning takes 1 to {MAX_COMMISSIONING_FLIGHTS} recordings")
            }
            CommissioningError::Tolerances(e) => write!(f, "tolerance table refused: {e}"),
            CommissioningError::Params(e) => write!(f, "unit parameters refused: {e}"),
            CommissioningError::Optimizer(e) => write!(f, "optimizer settings refused: {e}"),
        }
    }
}

/// The objective `J(z)` of the module doc, over the unit deviations `z`.
#[derive(Clone, Debug)]
pub struct BaselineFit<'f, 'a, const W: usize> {
    flights: &'f [CommissioningFlight<'f, 'a, W>],
    base: EmaParams,
    tolerances: Tolerances,
    /// `n_r/(2·s²)` of each recording.
    data_scale: [f32; MAX_COMMISSIONING_FLIGHTS],
    /// `s²` of the estimate over `s²` of the covariance (≤ 1): scales the data curvature from
    /// the one to the other.
    noise_ratio: f32,
    evaluations: u32,
}

impl<'f, 'a, const W: usize> BaselineFit<'f, 'a, W> {
    /// The objective over `flights` (1 to [`MAX_COMMISSIONING_FLIGHTS`]), the unit being `base`
    /// moved by `tolerances`; `independent_frames` per block as in the fit test
    /// ([`window_noise_variance_a2`]).
    pub fn new(
        flights: &'f [CommissioningFlight<'f, 'a, W>],
        base: EmaParams,
        tolerances: Tolerances,
        independent_frames: f32,
    ) -> Result<Self, CommissioningError> {
        if flights.is_empty() || flights.len() > MAX_COMMISSIONING_FLIGHTS {
            return Err(CommissioningError::FlightCount);
        }
        tolerances.check().map_err(CommissioningError::Tolerances)?;
        base.check().map_err(CommissioningError::Params)?;
        let s2 = window_noise_variance_a2(&base, independent_frames) + MODEL_MISMATCH_A * MODEL_MISMATCH_A;
        let mut data_scale = [0.0; MAX_COMMISSIONING_FLIGHTS];
        for (scale, flight) in data_scale.iter_mut().zip(flights) {
            *scale = flight.fit.samples() as f32 / (2.0 * s2);
        }
        let noise_ratio = (s2 / covariance_noise_a2(&base, independent_frames)).min(1.0);
        Ok(Self { flights, base, tolerances, data_scale, noise_ratio, evaluations: 0 })
    }

    /// The unit at deviations `z`, at 20 °C.
    pub fn unit(&self, z: &[f32; D]) -> EmaParams {
        self.tolerances.apply(&self.base, z)
    }

    /// `J(z)`, or any value above `abandon_above` once the partial sum exceeds it.
    pub fn value(&mut self, z: &[f32; D], abandon_above: f32) -> f32 {
        self.evaluations = self.evaluations.saturating_add(1);
        let unit = self.unit(z);
        let mut sum = 0.5 * z.iter().map(|x| x * x).sum::<f32>();
        for (flight, &scale) in self.flights.iter().zip(&self.data_scale) {
            if sum.is_nan() || sum > abandon_above {
                return sum;
            }
            let params = unit.at_temperature(flight.temperature_c);
            let budget = (abandon_above - sum) / scale;
            sum += scale * flight.fit.error_of_unit(&params, &FaultVector::HEALTHY, budget);
        }
        if sum.is_finite() {
            sum
        } else {
            f32::INFINITY
        }
    }

    /// Evaluations of `J` so far.
    pub fn evaluations(&self) -> u32 {
        self.evaluations
    }
}

impl<const W: usize> Objective<D> for BaselineFit<'_, '_, W> {
    fn cost(&mut self, x: &[f32; D], abandon_above: f32) -> f32 {
        self.value(x, abandon_above)
    }
}

/// `J` with a call of `tick` before each evaluation ([`commission`]).
struct Ticked<'o, 'f, 'a, const W: usize, F: FnMut()> {
    fit: &'o mut BaselineFit<'f, 'a, W>,
    tick: &'o mut F,
}

impl<const W: usize, F: FnMut()> Objective<D> for Ticked<'_, '_, '_, W, F> {
    fn cost(&mut self, x: &[f32; D], abandon_above: f32) -> f32 {
        (self.tick)();
        self.fit.value(x, abandon_above)
    }
}

/// A unit's commissioned baseline.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Baseline {
    /// The deviations from the base parameters, in tolerance σ (0 where not resolved).
    pub z: [f32; D],
    /// Their posterior 1σ, in tolerance σ (at most 1: the prior).
    pub sigma_z: [f32; D],
    /// Which parameters the recordings resolve ([`RESOLVED_BELOW`]).
    pub resolved: [bool; D],
    /// The unit's parameters at 20 °C.
    pub params: EmaParams,
    /// `J` at `z`.
    pub cost: f32,
    /// Evaluations of `J` spent, a lockstep run of the sensitivities counting as its 12 model runs.
    pub evaluations: u32,
}

impl Baseline {
    /// The resolved parameter furthest beyond [`OUT_OF_TOLERANCE_SIGMAS`], with its deviation,
    /// when its estimate lies beyond it by more than [`OUT_OF_TOLERANCE_CONFIDENCE`] posterior
    /// 1σ: not a unit to keep as a baseline. The margin matters where correlated parameters
    /// trade: a parameter the recordings do not resolve is put back to nominal, and a correlated
    /// one takes up its share of the fit (decision 0029).
    pub fn out_of_tolerance(&self) -> Option<(usize, f32)> {
        self.furthest(OUT_OF_TOLERANCE_CONFIDENCE)
    }

    /// The resolved parameter whose estimate itself lies furthest beyond
    /// [`OUT_OF_TOLERANCE_SIGMAS`], without the confidence margin of
    /// [`Baseline::out_of_tolerance`]: the unit check's rule, where a unit fitted to one
    /// recording to explain a diagnosis away must not need a parameter beyond its tolerance.
    pub fn beyond_tolerance(&self) -> Option<(usize, f32)> {
        self.furthest(0.0)
    }

    /// The resolved parameter furthest beyond [`OUT_OF_TOLERANCE_SIGMAS`] plus `margin`
    /// posterior 1σ, when one is.
    fn furthest(&self, margin: f32) -> Option<(usize, f32)> {
        let excess = |z: f32, sigma_z: f32| libm::fabsf(z) - OUT_OF_TOLERANCE_SIGMAS - margin * sigma_z;
        let parameters = self.z.iter().zip(&self.sigma_z).zip(&self.resolved).enumerate();
        parameters
            .filter(|&(_, (_, &resolved))| resolved)
            .map(|(i, ((&z, &sigma_z), _))| (i, z, excess(z, sigma_z)))
            .max_by(|a, b| a.2.total_cmp(&b.2))
            .filter(|&(_, _, beyond)| beyond > 0.0)
            .map(|(i, z, _)| (i, z))
    }
}

/// Commissions the unit of `fit` (module doc): the swarm of `P` particles for `max_iterations`
/// iterations from the generator `seed`, the damped Gauss–Newton descent from its best point,
/// the posterior, and the second descent without the parameters the recordings do not resolve.
/// `tick` is called before each evaluation of `J` and each recording's lockstep run of the
/// sensitivities (a board feeds its watchdog there).
pub fn commission<const W: usize, const P: usize>(
    fit: &mut BaselineFit<'_, '_, W>,
    max_iterations: u32,
    seed: u64,
    tick: &mut impl FnMut(),
) -> Result<Baseline, CommissioningError> {
    let bounds = Bounds { lower: [-SEARCH_SIGMAS; D], upper: [SEARCH_SIGMAS; D], periodic: [false; D] };
    let config = PsoConfig { max_iterations, ..PsoConfig::default() };
    let mut swarm = ParticleSwarm::<P, D>::new(bounds, config, seed)
        .map_err(CommissioningError::Optimizer)?
        .with_initial_guesses(&[[0.0; D]]);
    run(&mut swarm, &mut Ticked { fit: &mut *fit, tick: &mut *tick }, u32::MAX);
    let (start, start_cost) = (*swarm.best().0, swarm.best().1);
    let (z, cost, hessian) = descend(fit, start, start_cost, [true; D], tick);
    let sigma_z = posterior_sigma(fit.noise_ratio, hessian);
    let resolved: [bool; D] = core::array::from_fn(|i| sigma_z[i] < RESOLVED_BELOW);
    let (z, cost) = if resolved.iter().all(|r| *r) {
        (z, cost)
    } else {
        let kept: [f32; D] = core::array::from_fn(|i| if resolved[i] { z[i] } else { 0.0 });
        tick();
        let kept_cost = fit.value(&kept, f32::INFINITY);
        let (z, cost, _) = descend(fit, kept, kept_cost, resolved, tick);
        (z, cost)
    };
    let params = fit.unit(&z);
    params.check().map_err(CommissioningError::Params)?;
    Ok(Baseline { z, sigma_z, resolved, params, cost, evaluations: fit.evaluations() })
}

/// `true` when a diagnosis pays for its fault parameters against an ordinary unit: when the
/// recording is explained better by the faults `k` on the unit as described (fitness
/// `error_fault`, `fault_parameters` free parameters) than by a healthy unit moved within its
/// tolerances (fitness `error_unit` at deviations of squared norm `unit_z_sq`, the prior's price).
/// In the currency of model selection ([`crate::diagnosis::group_pays`]), with the prior's
/// `−2·ln` density in place of the parameters' price on the unit's side:
///
/// ```text
/// n_eff·ln(E_unit/E_fault) + |z|² > m·ln(n_eff)
/// ```
///
/// A unit that was never commissioned is judged against the tolerance table; a commissioned one
/// against the 1σ its commissioning left, so that a fault it has since developed is not taken for
/// a tolerance.
pub fn fault_pays_over_unit(
    error_fault: f32,
    error_unit: f32,
    unit_z_sq: f32,
    fault_parameters: usize,
    effective_samples: f32,
) -> bool {
    if !(error_fault > 0.0 && error_unit.is_finite() && effective_samples > 1.0) {
        return error_unit > error_fault;
    }
    effective_samples * libm::logf(error_unit / error_fault) + unit_z_sq
        > fault_parameters as f32 * libm::logf(effective_samples)
}

/// `true` when every phase reads shorted at DEGRADED size or more ([`DEGRADED_AT`]): the
/// signature of a unit that differs from its parameters (its EMF constant or inductance), not of
/// an inter-turn short, which starts in one coil.
pub fn every_phase_shorted(k: &FaultVector) -> bool {
    k.0[2..5].iter().all(|&s| s >= DEGRADED_AT)
}

/// Most trial steps of one descent (each one evaluation of `J`; an accepted one also a lockstep
/// run).
const MAX_TRIALS: usize = 40;

/// An accepted step that gains less than this (in units of `J`, a log-likelihood) at low
/// damping ends the descent.
const STEP_TOLERANCE: f32 = 0.01;

/// The finite-difference step of the sensitivities, in tolerance σ: wide enough to average over
/// the roughness of the model's response (an event moving by one control period), narrow against
/// the curvature over the tolerances.
pub const SENSITIVITY_STEP: f32 = 0.5;

/// A Levenberg–Marquardt descent of the `free` deviations from `start` (cost `start_cost`): each
/// trial solves `(H + λ·diag(H))·δ = −g` with the gradient and Gauss–Newton Hessian of
/// [`BaselineFit::normal_equations`]; an accepted trial lowers `λ` threefold and takes new
/// derivatives, a refused one raises it fourfold. Returns the point, its cost and the Hessian
/// there (identity rows for the parameters held).
fn descend<const W: usize>(
    fit: &mut BaselineFit<'_, '_, W>,
    start: [f32; D],
    start_cost: f32,
    free: [bool; D],
    tick: &mut impl FnMut(),
) -> ([f32; D], f32, [[f32; D]; D]) {
    let (mut z, mut cost) = (start, start_cost);
    let (mut gradient, mut hessian) = fit.normal_equations(&z, &free, tick);
    let mut damping = 1e-3f32;
    for _ in 0..MAX_TRIALS {
        let mut damped = hessian;
        for (i, row) in damped.iter_mut().enumerate() {
            row[i] *= 1.0 + damping;
        }
        let trial = invert(damped).map(|inverse| {
            core::array::from_fn(|i| {
                let step: f32 = (0..D).map(|j| inverse[i][j] * gradient[j]).sum();
                (z[i] - step).clamp(-SEARCH_SIGMAS, SEARCH_SIGMAS)
            })
        });
        tick();
        let trial_cost = trial.map_or(f32::INFINITY, |t: [f32; D]| fit.value(&t, cost));
        match trial {
            Some(t) if trial_cost < cost => {
                let gain = cost - trial_cost;
                (z, cost) = (t, trial_cost);
                (gradient, hessian) = fit.normal_equations(&z, &free, tick);
                if gain < STEP_TOLERANCE && damping <= 1e-2 {
                    break;
                }
                damping = (damping / 3.0).max(1e-6);
            }
            _ => {
                damping *= 4.0;
                if damping > 1e6 {
                    break;
                }
            }
        }
    }
    (z, cost, hessian)
}

/// The posterior 1σ of each deviation from the Hessian of `J` (module doc): the data's
/// curvature (the Hessian less the prior's identity) scaled by `noise_ratio` to the covariance's
/// noise, the prior added back, inverted; at most 1, and 1 for every parameter when the matrix
/// cannot be inverted.
fn posterior_sigma(noise_ratio: f32, mut hessian: [[f32; D]; D]) -> [f32; D] {
    for (i, row) in hessian.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            let prior = if i == j { 1.0 } else { 0.0 };
            *v = (*v - prior) * noise_ratio + prior;
        }
    }
    match invert(hessian) {
        Some(c) => core::array::from_fn(|i| {
            let v = c[i][i];
            if v.is_finite() && v > 0.0 {
                libm::sqrtf(v).min(1.0)
            } else {
                1.0
            }
        }),
        None => [1.0; D],
    }
}

/// Models run in lockstep for the sensitivities: the base and one per unit parameter.
const MODELS: usize = D + 1;

/// The sums of one recording's lockstep run: `g = Σ v·r·d`, `A = Σ v·d·dᵀ` (upper triangle).
struct Sums {
    a: [[f32; D]; D],
    g: [f32; D],
}

impl<const W: usize> BaselineFit<'_, '_, W> {
    /// The gradient and Gauss–Newton Hessian of `J` at `z` over the `free` deviations:
    /// `∇J = z − Σ_r (n_r/s²)·(1/n_r)·Σ_i v_i·r_i·d_i` and `H = I + Σ_r (n_r/s²)·(1/n_r)·Σ_i v_i·d_i·d_iᵀ`,
    /// `d_i` the sensitivity of window sample `i` to each deviation (a forward difference of
    /// [`SENSITIVITY_STEP`]), `v_i` the fitness's weight. One lockstep run of 12 models per
    /// recording; nothing is stored per sample. A parameter held has gradient 0 and an identity
    /// row.
    /// `tick` is called before each recording's run.
    pub fn normal_equations(
        &mut self,
        z: &[f32; D],
        free: &[bool; D],
        tick: &mut impl FnMut(),
    ) -> ([f32; D], [[f32; D]; D]) {
        self.evaluations = self.evaluations.saturating_add(MODELS as u32);
        let mut gradient: [f32; D] = *z;
        let mut hessian: [[f32; D]; D] =
            core::array::from_fn(|i| core::array::from_fn(|j| if i == j { 1.0 } else { 0.0 }));
        for (flight, &scale) in self.flights.iter().zip(&self.data_scale) {
            tick();
            let params: [EmaParams; MODELS] = core::array::from_fn(|m| {
                let mut x = *z;
                if let Some(j) = m.checked_sub(1) {
                    if let Some(xj) = x.get_mut(j) {
                        *xj += SENSITIVITY_STEP;
                    }
                }
                self.unit(&x).at_temperature(flight.temperature_c)
            });
            let models: [MonitorModel; MODELS] = core::array::from_fn(|m| {
                MonitorModel::with_effects(&params[m], &FaultVector::HEALTHY, flight.fit.effects())
            });
            let mut sums = Sums { a: [[0.0; D]; D], g: [0.0; D] };
            let fit = flight.fit;
            crate::lockstep::lockstep(&models, &params[0], fit, |y, v, means| sums.add(y, v, means));
            // J's data term is scale·E = scale·(1/n)·Σ v r²: its gradient −2·scale/n·Σ v r d
            let c = 2.0 * scale / fit.samples().max(1) as f32;
            let rows = gradient.iter_mut().zip(hessian.iter_mut()).zip(sums.g.iter().zip(&sums.a)).zip(free);
            for (i, (((g, row), (sg, srow)), _)) in rows.enumerate().filter(|(_, (_, f))| **f) {
                *g -= c * sg;
                for ((h, a), _) in row.iter_mut().zip(srow).zip(free).skip(i).filter(|(_, f)| **f) {
                    *h += c * a;
                }
            }
        }
        for (g, _) in gradient.iter_mut().zip(free).filter(|(_, f)| !**f) {
            *g = 0.0;
        }
        mirror_upper(&mut hessian);
        (gradient, hessian)
    }
}

/// Copies the upper triangle of `m` into its lower one.
fn mirror_upper(m: &mut [[f32; D]; D]) {
    for i in 1..D {
        let (upper, lower) = m.split_at_mut(i);
        for (j, row) in upper.iter().enumerate() {
            lower[0][j] = row[i];
        }
    }
}

impl Sums {
    /// One window sample of the lockstep run ([`crate::lockstep`]): the measured block mean `y_i`,
    /// its weight `v_i`, and the block means of the base model and the 11 stepped ones.
    fn add(&mut self, y_i: f32, v: f32, means: &[f32; MODELS]) {
        let base = means[0];
        let r = y_i - base;
        let mut d = [0.0f32; D];
        for (dj, b) in d.iter_mut().zip(&means[1..]) {
            *dj = (b - base) * (1.0 / SENSITIVITY_STEP);
        }
        for (j, (&dj, row)) in d.iter().zip(self.a.iter_mut()).enumerate() {
            let vd = v * dj;
            self.g[j] += vd * r;
            for (a, &dl) in row.iter_mut().zip(&d).skip(j) {
                *a += vd * dl;
            }
        }
    }
}

/// The inverse of `m` by Gauss–Jordan elimination with partial pivoting; `None` when a pivot is
/// not a positive-definite matrix's (below `1e-6` of the largest diagonal, or not finite).
fn invert(mut m: [[f32; D]; D]) -> Option<[[f32; D]; D]> {
    let scale = (0..D).map(|i| libm::fabsf(m[i][i])).fold(0.0f32, f32::max);
    if !(scale.is_finite() && scale > 0.0) {
        return None;
    }
    let mut inv: [[f32; D]; D] = core::array::from_fn(|i| core::array::from_fn(|j| if i == j { 1.0 } else { 0.0 }));
    for col in 0..D {
        let below = m.iter().enumerate().skip(col);
        let (pivot_row, _) = below.max_by(|(_, a), (_, b)| libm::fabsf(a[col]).total_cmp(&libm::fabsf(b[col])))?;
        if pivot_row >= D {
            return None;
        }
        m.swap(col, pivot_row);
        inv.swap(col, pivot_row);
        let pivot = m[col][col];
        if pivot.is_nan() || libm::fabsf(pivot) <= 1e-6 * scale {
            return None;
        }
        let inv_pivot = 1.0 / pivot;
        for j in 0..D {
            m[col][j] *= inv_pivot;
            inv[col][j] *= inv_pivot;
        }
        for r in 0..D {
            if r != col {
                let factor = m[r][col];
                if factor != 0.0 {
                    for j in 0..D {
                        m[r][j] -= factor * m[col][j];
                        inv[r][j] -= factor * inv[col][j];
                    }
                }
            }
        }
    }
    Some(inv)
}

#[cfg(test)]
mod tests;
