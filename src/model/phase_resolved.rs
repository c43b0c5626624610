//! The phase-resolved fast regime: above [`PHASE_RESOLVED_ONSET_FRACTION`] of the commutation
//! dip onset the sector means of the pair regime give way to the three phase currents
//! themselves, integrated in [`PHASE_SUBSTEPS`] substeps of 20 µs with the trapezoidal
//! back-EMFs, the six-step inverter, the outgoing phase's diode and each commanded phase's
//! hysteresis loop (averaged: held at its target). A commutation then starts at its Hall edge
//! inside the step, the measured `½Σ|i_j|` is taken at the sample instant as the ADC takes it, and
//! the torque is the step mean of `Σ k_j f_j i_j`.
//!
//! Sector means leave the eccentricity signature too weak in the fast reversal (the reference
//! model's sector-to-sector pattern is stronger than theirs) and let the shorts' commutations
//! drift; the phases resolve that. Braking too: there the back-EMF helps the current, and at each
//! commutation it drives the common phase past its target even with its switch at the opposite
//! rail, so the measured `½Σ|i_j|` bumps up where the pair model holds it.

use super::{sign, ModelState, MonitorModel};
use crate::six_step::{ideal_emf_shapes, phase_emf_shape_near_turn, sector_of, sector_roles, wrap, Phase, PAIRS};
use core::f32::consts::{FRAC_PI_3, FRAC_PI_6};

/// The electrical step resolves the three phases (the fast regime) above
/// this fraction of the healthy dip onset `V_dc/(4k_0)` (519 rad/s nominal): an eccentric phase
/// reaches its own onset from `1/(1 + ζ_max)` = 0.67 of it.
pub const PHASE_RESOLVED_ONSET_FRACTION: f32 = 0.6;

/// Substeps of the phase-resolved electrical step (20 µs at the 100 µs control period): more
/// substeps lower the fast reversal's residuals only marginally and cost the on-board
/// identification its instruction budget (`docs/decisions/0003-phase-resolved-substeps.md`).
pub const PHASE_SUBSTEPS: usize = 5;

impl MonitorModel {
    /// The electrical step of the fast regime: on entry the pair current becomes the phase
    /// currents `(i_p, i_q) = (I, −I)`; the loop's lag (the pair model's first-order response) on
    /// the reference `i_ref` stays in the state's `current_a`, the target of the phases'
    /// hysteresis loops. Returns the step's motor torque.
    #[inline(always)]
    pub(super) fn resolved_electrical_step<const EFFECTS: bool>(
        &self,
        s: &mut ModelState,
        k_phase: &[f32; 3],
        sector: usize,
        i_ref: f32,
    ) -> f32 {
        let (i, w) = (s.current_a, s.motor_speed_rad_s);
        if !s.phase_resolved {
            let (p, q) = PAIRS[sector];
            s.phase_current_a = [0.0; 3];
            s.phase_current_a[p] = i;
            s.phase_current_a[q] = -i;
            s.phase_resolved = true;
        }
        s.current_a = i_ref + (i - i_ref) * self.lag_factor;
        self.phase_resolved_step::<EFFECTS>(s, k_phase, s.current_a, w)
    }

    /// The electrical step of the fast regime (`|ω| >` [`PHASE_RESOLVED_ONSET_FRACTION`] of the dip
    /// onset, motoring or braking): the three phase currents in [`PHASE_SUBSTEPS`] explicit
    /// substeps `h`, with the trapezoidal back-EMFs at the substep's rotor angle and the
    /// inverter's six-step switching, so that each commutation happens at its Hall edge inside
    /// the step and the outgoing phase decays through its diode while the incoming one rises.
    /// `g = sign(I_ref)`:
    ///
    /// ```text
    /// pair (p, q) of the substep's Hall sector, its targets t_p = I_ref*, t_q = −I_ref*
    /// third phase r still conducting (i_r ≠ 0): the commutation, see `commutation_substep`
    /// r open: i_p = −i_q = I,  I += h·(g·V_dc − e_p + e_q − (R_p + R_q)·I)/(L_p + L_q),
    ///     |I| held at |I_ref*| (the hysteresis loop)
    /// e_j = k_j(θ_m)·f(θ_e − j·2π/3)·ω      (f: the trapezoid of ramp π/6, or `emf_harmonics`')
    /// ```
    ///
    /// `I_ref*` is the reference through the loop's lag `τ_c`, as in the pair model. A substep
    /// that contains a Hall edge is split there. Each (part of a) substep takes its EMFs at its
    /// midpoint angle and its torque with the mean of its start and end currents (the midpoint
    /// rule in the angle, the trapezoid rule in the currents): EMFs and currents taken at the
    /// substep's ends would sit half a substep off, and the commutation's torque dip, while an
    /// outgoing phase decays on its falling ramp, would come out too small.
    ///
    /// The state's `output_current_a` is the measured quantity `½Σ|i_j|` at the step's end (signed
    /// like the pair current); the returned motor torque is the step mean of `Σ e_j i_j / ω =
    /// Σ k_j f_j i_j`. This replaces, above its speed, the sector-mean commutation dip, the
    /// commutation-limited rise and the ramp torque loss of the pair regime.
    fn phase_resolved_step<const EFFECTS: bool>(&self, s: &mut ModelState, k: &[f32; 3], target_a: f32, w: f32) -> f32 {
        let h = self.dt_s * (1.0 / PHASE_SUBSTEPS as f32);
        let d_hall = self.pole_pairs * w * h;
        let offset = match self.emf_shape() {
            Some(shape) if EFFECTS => shape.hall_offset_rad,
            _ => 0.0,
        };
        let g = if target_a != 0.0 { sign(target_a) } else { sign(s.current_a) };
        let mut i = s.phase_current_a;
        let mut hall = s.hall_angle_rad;
        let travel = libm::fabsf(d_hall);
        let inv_travel = 1.0 / travel; // |ω| > 0 in the fast regime
        let mut torque_sum = 0.0;
        let mut sector = 0;
        for _ in 0..PHASE_SUBSTEPS {
            // The Hall edge inside the substep, if any, splits it: the commutation starts at its
            // instant (a model continuous in the speed and the faults, not snapped to the substeps).
            let x = if EFFECTS { wrap(hall + offset) } else { hall };
            sector = sector_of(x);
            let within = x - sector as f32 * FRAC_PI_3;
            let (to_edge, next) =
                if d_hall > 0.0 { (FRAC_PI_3 - within, (sector + 1) % 6) } else { (within, (sector + 5) % 6) };
            let first = if to_edge < travel { to_edge * inv_travel } else { 1.0 };
            if first > 0.0 {
                let mid = hall + 0.5 * first * d_hall;
                torque_sum += first * self.phase_substep::<EFFECTS>(&mut i, sector, mid, k, w, target_a, g, first * h);
            }
            if first < 1.0 {
                sector = next;
                let mid = hall + 0.5 * (1.0 + first) * d_hall;
                torque_sum += (1.0 - first)
                    * self.phase_substep::<EFFECTS>(&mut i, sector, mid, k, w, target_a, g, (1.0 - first) * h);
            }
            hall = wrap(hall + d_hall);
        }
        s.phase_current_a = i;
        let measured = 0.5 * (libm::fabsf(i[0]) + libm::fabsf(i[1]) + libm::fabsf(i[2]));
        let (a, b) = PAIRS[sector];
        let pair_sign = if i[a] != i[b] { sign(i[a] - i[b]) } else { g };
        s.output_current_a = pair_sign * measured;
        torque_sum * (1.0 / PHASE_SUBSTEPS as f32)
    }

    /// A (part of a) substep of [`MonitorModel::phase_resolved_step`] of length `h` in `sector`,
    /// the EMFs at its midpoint Hall angle `hall_rad`; returns its mean torque
    /// `Σ k_j f_j (i_j + i_j⁺)/2` (the midpoint rule in the angle, the trapezoid rule in the
    /// currents). `g` is the polarity the pair is driven with.
    #[allow(clippy::too_many_arguments)]
    fn phase_substep<const EFFECTS: bool>(
        &self,
        i: &mut [f32; 3],
        sector: usize,
        hall_rad: f32,
        k: &[f32; 3],
        w: f32,
        target_a: f32,
        g: f32,
        h: f32,
    ) -> f32 {
        let sector = sector % 6; // a Hall sector is below 6: no value changes, no bounds check remains
        let roles = sector_roles(sector);
        let (a, b, r) = (roles.0.index(), roles.1.index(), roles.2.index());
        let f = match self.emf_shape() {
            Some(shape) if EFFECTS => {
                let (theta_e, inv_ramp) = (hall_rad + FRAC_PI_6, shape.inv_ramp_per_rad);
                [
                    phase_emf_shape_near_turn(theta_e, inv_ramp),
                    phase_emf_shape_near_turn(theta_e - 2.0 * FRAC_PI_3, inv_ramp),
                    phase_emf_shape_near_turn(theta_e - 4.0 * FRAC_PI_3, inv_ramp),
                ]
            }
            _ => ideal_emf_shapes(sector, hall_rad),
        };
        let e_v = [k[0] * f[0] * w, k[1] * f[1] * w, k[2] * f[2] * w];
        let i_before = *i;
        if i[r] != 0.0 {
            self.commutation_substep::<EFFECTS>(i, roles, target_a, &e_v, h);
        } else {
            let pair = i[a];
            let mut u = g * self.supply_voltage_v - (e_v[a] - e_v[b]) - (self.phase_r[a] + self.phase_r[b]) * pair;
            if EFFECTS {
                u -= self.step_terms.dead_time_pair_v * sign(pair);
            }
            let mut next = pair + u * self.pair_dt_over_l[sector] * self.inv_dt * h;
            let limit = libm::fabsf(target_a);
            if next * g > limit {
                next = g * limit;
            }
            i[a] = next;
            i[b] = -next;
            i[r] = 0.0;
        }
        let mean = [0.5 * (i_before[0] + i[0]), 0.5 * (i_before[1] + i[1]), 0.5 * (i_before[2] + i[2])];
        k[0] * f[0] * mean[0] + k[1] * f[1] * mean[1] + k[2] * f[2] * mean[2]
    }

    /// One substep of [`MonitorModel::phase_resolved_step`] while the third phase `r` still
    /// conducts through its diode: the commutation. Each commanded phase `j` of the pair `(a, b)`
    /// has its own hysteresis loop around its target `t_a = I_ref`, `t_b = −I_ref`, averaged: its
    /// terminal is at the rail that drives it toward the target, and a phase that sits at its
    /// target while that rail would push it past is **held** there (its switch chops, `di_j = 0`)
    /// and drops out of the neutral point, which the other phases then set alone, unless even the
    /// opposite rail would push it past (braking: the back-EMF drives the common phase beyond its
    /// target): then it runs free at the opposite rail:
    ///
    /// ```text
    /// v_j = sign(t_j − i_j)·V_dc/2 (sign(t_j) at the target),  v_r = −sign(i_r)·V_dc/2
    /// u_j = v_j − e_j − R_j i_j,  v_N = Σ_free Y_j u_j / Σ_free Y_j,  i_j += h·Y_j·(u_j − v_N)
    /// ```
    ///
    /// A free commanded phase that crosses its target is held there and `r` crossing zero is
    /// blocked at zero (its diode), each excess shared by the other free phases in proportion to
    /// `Y_j`. With a shorted common phase (small `L`, large `Y`) holding matters: that phase would
    /// otherwise pin `v_N` and slow the outgoing phase's decay.
    fn commutation_substep<const EFFECTS: bool>(
        &self,
        i: &mut [f32; 3],
        &(pa, pb, pr): &(Phase, Phase, Phase),
        target_a: f32,
        e_v: &[f32; 3],
        h: f32,
    ) {
        let (a, b, r) = (pa.index(), pb.index(), pr.index());
        let half_v = 0.5 * self.supply_voltage_v;
        let y = self.phase_inv_l;
        let mut t = [0.0f32; 3];
        t[a] = target_a;
        t[b] = -target_a;
        let mut u = [0.0f32; 3];
        // the pair looped over as `Phase`s: an index read back from an array of them is still
        // below 3 (a `usize` stored there would keep a bounds check per use)
        for phase in [pa, pb] {
            let j = phase.index();
            let rail = if i[j] < t[j] {
                1.0
            } else if i[j] > t[j] {
                -1.0
            } else {
                sign(t[j])
            };
            u[j] = rail * half_v - e_v[j] - self.phase_r[j] * i[j];
            if EFFECTS {
                u[j] -= 0.5 * self.step_terms.dead_time_pair_v * sign(i[j]);
            }
        }
        u[r] = -sign(i[r]) * half_v - e_v[r] - self.phase_r[r] * i[r];
        if EFFECTS {
            u[r] -= 0.5 * self.step_terms.dead_time_pair_v * sign(i[r]);
        }
        let mut v_all = (y[0] * u[0] + y[1] * u[1] + y[2] * u[2]) * self.inv_y_sum;
        let mut free = [true; 3];
        for phase in [pa, pb] {
            let j = phase.index();
            free[j] = !(i[j] == t[j] && t[j] != 0.0 && sign(t[j]) * (u[j] - v_all) > 0.0);
            if !free[j] {
                // its switch chops only if the opposite rail turns it back; braking, the back-EMF
                // can drive it past its target even there: it then runs free at that rail
                let u_opposite = u[j] - sign(t[j]) * self.supply_voltage_v;
                let v_opposite = v_all + y[j] * (u_opposite - u[j]) * self.inv_y_sum;
                if sign(t[j]) * (u_opposite - v_opposite) > 0.0 {
                    u[j] = u_opposite;
                    v_all = v_opposite;
                    free[j] = true;
                }
            }
        }
        let v_n = if free[a] && free[b] {
            v_all
        } else {
            let (mut num, mut den) = (0.0f32, 0.0f32);
            for j in 0..3 {
                if free[j] {
                    num += y[j] * u[j];
                    den += y[j];
                }
            }
            num / den // r is always free: den ≥ Y_r > 0
        };
        let before = *i;
        for j in 0..3 {
            if free[j] {
                i[j] += h * y[j] * (u[j] - v_n);
            }
        }
        for phase in [pa, pb] {
            let j = phase.index();
            if free[j] && before[j] != t[j] && (before[j] - t[j]) * (i[j] - t[j]) <= 0.0 {
                let excess = i[j] - t[j];
                i[j] = t[j];
                free[j] = false;
                Self::share(i, excess, &free, &y);
            }
        }
        if i[r] * before[r] <= 0.0 {
            // The diode blocks: i_r → 0, its excess shared by the pair.
            let excess = i[r];
            i[r] = 0.0;
            let mut pair = [false; 3];
            pair[a] = free[a];
            pair[b] = free[b];
            if !pair[a] && !pair[b] {
                pair[a] = true;
                pair[b] = true;
            }
            Self::share(i, excess, &pair, &y);
        }
    }

    /// Adds `excess` back to the phases marked in `to`, in proportion to `Y_j` (keeps `Σi = 0`
    /// after a phase was set to a bound); nothing when none is marked.
    fn share(i: &mut [f32; 3], excess: f32, to: &[bool; 3], y: &[f32; 3]) {
        let den: f32 = (0..3).filter(|&j| to[j]).map(|j| y[j]).sum();
        if den > 0.0 {
            for j in 0..3 {
                if to[j] {
                    i[j] += excess * y[j] / den;
                }
            }
        }
    }
}
