//! The pair regime: below the fast regime the conducting pair is one equivalent DC motor
//! (`K_eq`, `R_eq`, `L_eq` of the sector's pair) behind a first-order current loop, and the six
//! commutations per electrical turn enter as sector means.
//!
//! ```text
//! current I⁺ = I_ref + (I − I_ref)·e^{−T/τ_c}, its change clamped to the available voltage:
//!         T·(−V_dc − R_eq·I − K_eq·ω)/L_eq ≤ ΔI ≤ T·(V_dc − R_eq·I − K_eq·ω)/L_eq
//!         and, motoring above ω = V_dc/(4k), the commutation-limited rise (below)
//! dip     I_out = I − ½ΔI·min(t_c + t_r, T_s)/T_s,   T_s = (π/3)/(p|ω|)
//! torque  T_m = K_eq·(I_out − ½(I⁺ − I) − ramp loss)
//! ```
//!
//! **Commutation dip** (Carlson, Lajoie-Mazenc, Fagundes, "Analysis of torque ripple due to phase
//! commutation in brushless dc machines", IEEE T-IA 28(3), 1992): at each of the 6 commutations per
//! electrical turn the outgoing phase decays through its diode while the incoming one rises; with
//! per-phase EMF `E = K_eq·|ω|/2` and inductance `L = L_eq/2`, when `4E > V_dc` the current of the
//! third (non-commutated) phase — the one `I_3eq` and the torque follow — falls during the
//! commutation time `t_c = 3L·I/(V_dc + 2E)` by `ΔI = I·(4E − V_dc)/(V_dc + 2E)`, then recovers at
//! `(V_dc − 2E − R_eq I)/(2L)` in `t_r`. The model keeps `I` (what the current loop regulates)
//! and outputs the sector mean `I_out`.
//!
//! **Ramp torque loss.** The outgoing phase's back-EMF is already on its 30° ramp while its
//! current decays over `t_c`, so commutation also costs torque beyond the current dip:
//! `∫(1 − f_out)·i_out dt` over `t_c` averages, per sector and in equivalent current, to
//! `1.5·(p·ω·t_c)²·I/π²` (at every speed, ∝ ω²), which the torque (not `I_out`, which follows the
//! third phase) loses. With the Hall edges a signed angle `a` ahead of the EMFs
//! (`hall_misalignment`, `a = δ_H·sign ω`) the outgoing phase decays partly on its flat top and
//! the incoming one rises partly on its ramp: against the new pair's instantaneous `K_eq` at full
//! current (the step's torque) the loss is `k·i_out·(f_in − f_out)` with
//! `f_in − f_out = (6/π)(φ − a)` at the angle `φ` into the commutation, which averages to
//! `1.5·α·(α − 3a)·I/π²` (`α = p·ω·t_c`; a gain when `a > α/3`).
//!
//! Motoring only: when braking (`I·ω < 0`) the EMF helps the incoming phase and there is no dip.
//!
//! **Commutation-limited current.** Above the onset the current loses `ΔI` at every commutation
//! and regains it only at `(V_dc − 2E − R_eq I)/(2L)` for the rest of the sector, so the current
//! the loop can sustain falls with speed; the rise of `|I|` per step is capped at
//! `T·[(V_dc − 2E − R_eq|I|)/(2L)·(T_s − t_c) − ΔI]/T_s` (negative: `|I|` decays to the
//! sustainable level), as the reference model's current collapses in the fast reversal.

use super::{clamp, sign, ModelState, MonitorModel};
use crate::six_step::{commutation_roles, PAIRS};
use core::f32::consts::PI;

/// The commutation into a sector, per ampere of the current it carries
/// (see [`MonitorModel::commutation`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct Commutation {
    /// `t_c/|I|`: the outgoing phase's decay time per ampere.
    pub(super) time_s_per_a: f32,
    /// `ΔI/|I|`: the dip of the common phase (0 below the onset).
    pub(super) drop_fraction: f32,
    /// `T_s`: time spent in one sector.
    sector_time_s: f32,
    /// `1/T_s` (a product, not a division: the step divides by `T_s` up to twice).
    sectors_per_s: f32,
    /// `K_eq|ω|`: the new pair's back-EMF.
    pair_emf_v: f32,
}

impl MonitorModel {
    /// The electrical step of the pair regime: the current toward `i_ref` through the loop's lag,
    /// clamped by the voltage left across the pair (`back_v = R_eq·I + K_eq·ω`, plus the dead
    /// time's drop) and, motoring above the dip onset, by the commutation-limited rise; sets the
    /// state's `current_a` and `output_current_a` and returns the step's motor torque.
    #[inline(always)]
    pub(super) fn pair_electrical_step<const EFFECTS: bool>(
        &self,
        s: &mut ModelState,
        k_phase: &[f32; 3],
        sector: usize,
        k_eq: f32,
        i_ref: f32,
        back_v: f32,
    ) -> f32 {
        let dt_over_l = self.pair_dt_over_l[sector];
        let (i, w) = (s.current_a, s.motor_speed_rad_s);
        // Commutation terms only while motoring (before or after this step's current change).
        let motoring = i * w > 0.0 || i_ref * w > 0.0;
        let commutation = if motoring { Some(self.commutation::<EFFECTS>(k_phase, sector, w)) } else { None };
        let wanted = i_ref + (i - i_ref) * self.lag_factor - i;
        let mut up = dt_over_l * (self.supply_voltage_v - back_v);
        let mut down = dt_over_l * (-self.supply_voltage_v - back_v);
        if let Some(limit) = commutation.and_then(|c| self.commutation_rise_limit(&c, i, w, sector)) {
            if i > 0.0 {
                up = up.min(limit);
            } else {
                down = down.max(-limit);
            }
        }
        s.current_a = i + clamp(wanted, down, up);
        let (dip_a, torque_loss_a) = match commutation {
            Some(c) => self.commutation_losses::<EFFECTS>(&c, s.current_a, w, sector),
            None => (0.0, 0.0),
        };
        s.output_current_a = s.current_a - dip_a;
        // the torque of the step's mean current: the change ramps in over the step
        k_eq * (s.output_current_a - 0.5 * (s.current_a - i) - torque_loss_a)
    }

    /// The commutation into `sector` at speed `w` (module doc, "Commutation dip"): the phase the
    /// two pairs share (common `c`, its current `I`), the one leaving (`o`, decaying through its
    /// diode) and the one entering (`n`). With the isolated star's neutral
    /// `v_N = Σ Y_j(v_j − e_j)/ΣY_j`, `Y_j = 1/L_j`, flat-top EMFs `E_j = k_j(θ_m)|ω|`:
    ///
    /// ```text
    /// d|i_o|/dt = −(Y_o/Y)·[Y_c(E_c + E_o) + Y_n(V_dc + E_o − E_n)]      (t_c = |I| / that)
    /// d|i_c|/dt =  (Y_c/Y)·[Y_n(V_dc − E_c − E_n) − Y_o(E_c + E_o)]      (ΔI = −that·t_c when < 0)
    /// ```
    ///
    /// Equal phases give Carlson's `t_c = 3L|I|/(V_dc + 2E)`, `ΔI = |I|(4E − V_dc)/(V_dc + 2E)`;
    /// a shorted or eccentric phase changes both, commutation by commutation. `R` is neglected
    /// during `t_c`, as there.
    pub(super) fn commutation<const EFFECTS: bool>(&self, k: &[f32; 3], sector: usize, w: f32) -> Commutation {
        let k_flat = k;
        let shaped;
        let k = match self.emf_shape() {
            Some(shape) if EFFECTS => {
                shaped = shape.commutation_k(k, sector, w > 0.0);
                &shaped
            }
            _ => k,
        };
        let (c, o, n) = commutation_roles(sector, w > 0.0);
        let speed = libm::fabsf(w);
        let (v, dv) = (self.supply_voltage_v, if EFFECTS { self.step_terms.dead_time_pair_v } else { 0.0 });
        let (e_c, e_o, e_n) = (k[c] * speed, k[o] * speed, k[n] * speed);
        let (y_c, y_o, y_n) = (self.phase_inv_l[c], self.phase_inv_l[o], self.phase_inv_l[n]);
        let inv_y = self.inv_y_sum;
        let decay = y_o * inv_y * (y_c * (e_c + e_o + dv) + y_n * (v + e_o - e_n));
        let common = y_c * inv_y * (y_n * (v - dv - e_c - e_n) - y_o * (e_c + e_o + dv));
        let sector_time_s = self.sector_angle_rad / speed;
        let (time_s_per_a, drop_fraction) = if decay > 0.0 {
            (1.0 / decay, if common < 0.0 { -common / decay } else { 0.0 })
        } else {
            (sector_time_s, 0.0) // never reached with physical values: the whole sector commutates
        };
        let (p, q) = PAIRS[sector];
        let pair_k = match self.emf_shape() {
            Some(shape) if EFFECTS => shape.mean_pair_k(k_flat, sector),
            _ => k[p] + k[q],
        };
        let sectors_per_s = speed * self.sectors_per_rad;
        Commutation { time_s_per_a, drop_fraction, sector_time_s, sectors_per_s, pair_emf_v: pair_k * speed }
    }

    /// The recovery slope `(V_dc − 2ΔV − K_eq|ω| − R_eq|I|)/L_eq` of the new pair after `t_c`.
    fn recovery_a_per_s(&self, sector: usize, k_eq_speed_v: f32, i_abs: f32) -> f32 {
        (self.supply_voltage_v - self.step_terms.dead_time_pair_v - k_eq_speed_v - self.pair_r[sector] * i_abs)
            * self.pair_dt_over_l[sector]
            * self.inv_dt
    }

    /// Largest change of `|I|` over one step while motoring above the dip onset: per sector the
    /// current loses `ΔI` during `t_c` and regains the recovery slope only during `T_s − t_c`, so
    /// the sector-start current rises by at most `T·[slope·(T_s − t_c) − ΔI]/T_s` (negative: it
    /// decays to the commutation-limited current). `None` when braking, at rest or below the onset.
    fn commutation_rise_limit(&self, c: &Commutation, i: f32, w: f32, sector: usize) -> Option<f32> {
        if i * w <= 0.0 || c.drop_fraction <= 0.0 {
            return None;
        }
        let i_abs = libm::fabsf(i);
        let (t_c, drop) = (c.time_s_per_a * i_abs, c.drop_fraction * i_abs);
        let slope = self.recovery_a_per_s(sector, c.pair_emf_v, i_abs);
        let rise_time = if c.sector_time_s > t_c { c.sector_time_s - t_c } else { 0.0 };
        Some(self.dt_s * (slope * rise_time - drop) * c.sectors_per_s)
    }

    /// Sector means of the commutation dip of `I_out` and of the ramp torque loss (both as
    /// equivalent currents, signed like `i`; module doc). Zero when braking or at rest.
    fn commutation_losses<const EFFECTS: bool>(&self, c: &Commutation, i: f32, w: f32, sector: usize) -> (f32, f32) {
        if i * w <= 0.0 {
            return (0.0, 0.0);
        }
        let i_abs = libm::fabsf(i);
        let (t_c, drop) = (c.time_s_per_a * i_abs, c.drop_fraction * i_abs);
        let angle = self.pole_pairs * libm::fabsf(w) * t_c;
        // The paper's model (`EFFECTS = false`) has no Hall offset and keeps its own expression,
        // the cheaper one on board (the advance 0, the lower clamp unused).
        let torque_loss = if EFFECTS {
            // `a = δ_H·sign ω`: how far (electrical rad) the commutation runs ahead of the EMFs
            let advance_rad = self.emf_shape().map_or(0.0, |shape| shape.hall_offset_rad) * sign(w);
            let ramp_loss = 1.5 * angle * (angle - 3.0 * advance_rad) * i_abs * (1.0 / (PI * PI));
            clamp(ramp_loss, -0.5 * i_abs, 0.5 * i_abs)
        } else {
            let ramp_loss = 1.5 * angle * angle * i_abs * (1.0 / (PI * PI));
            if ramp_loss < 0.5 * i_abs {
                ramp_loss
            } else {
                0.5 * i_abs
            }
        };
        let dip = if drop > 0.0 {
            let slope = self.recovery_a_per_s(sector, c.pair_emf_v, i_abs);
            let t_r = if slope > 0.0 { drop / slope } else { c.sector_time_s };
            let dip_time = if t_c + t_r < c.sector_time_s { t_c + t_r } else { c.sector_time_s };
            0.5 * drop * dip_time * c.sectors_per_s
        } else {
            0.0
        };
        if i > 0.0 {
            (dip, torque_loss)
        } else {
            (-dip, -torque_loss)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{model, with_effect};
    use super::*;
    use crate::effects::{EffectId, ModelEffects};
    use crate::faults::FaultVector;
    use crate::params::EmaParams;

    #[test]
    fn commutation_dip_starts_at_a_quarter_of_the_bus_voltage() {
        let m = model(FaultVector::HEALTHY.0);
        let k = [0.13f32; 3];
        let at = |i: f32, w: f32| m.commutation_losses::<true>(&m.commutation::<true>(&k, 0, w), i, w, 0);
        let limit = |i: f32, w: f32| m.commutation_rise_limit(&m.commutation::<true>(&k, 0, w), i, w, 0);
        let onset = 270.0 / (4.0 * 0.13); // 4E = V_dc, E = k_0 ω
        assert_eq!(at(15.0, 0.98 * onset).0, 0.0);
        assert!(at(15.0, 1.05 * onset).0 > 0.0);
        // Worked example (the reference model reads 13.6 A, i.e. a 1.4 A dip, at 686 rad/s):
        // E = 89.18 V, t_c = 0.2007 ms, ΔI = 2.901 A, t_r = 2.901·4 mH/(270 − 178.4 − 15) V = 0.1514 ms,
        // T_s = 0.3816 ms → ½·2.901·0.3521/0.3816 = 1.338 A.
        let (d, torque) = at(15.0, 686.0);
        assert!((d - 1.338).abs() < 0.002, "{d}");
        // ramp loss: p·ω·t_c = 4·686·0.2007 ms = 0.5507 rad → 1.5·0.5507²·15/π² = 0.691 A
        assert!((torque - 0.691).abs() < 0.002, "{torque}");
        // Rise limit at the same point: rate = (270 − 178.36 − 15)/4 mH = 19 160 A/s over
        // T_s − t_c = 0.1809 ms regains 3.466 A against the 2.901 A lost: +0.565 A per sector,
        // i.e. 0.565·T/T_s = 0.148 A per step; at 800 rad/s the sector loses more than it regains.
        let l = limit(15.0, 686.0).unwrap();
        assert!((l - 0.148).abs() < 1e-3, "{l}");
        assert!(limit(15.0, 800.0).unwrap() < 0.0);
        assert_eq!(limit(15.0, 0.98 * onset), None);
        assert_eq!(limit(15.0, -686.0), None, "braking");
        let (dn, tn) = at(-15.0, -686.0);
        assert!((dn + d).abs() < 1e-6 && (tn + torque).abs() < 1e-6, "odd in the current");
        assert_eq!(at(15.0, -686.0), (0.0, 0.0), "nothing when braking");
    }

    #[test]
    fn dead_time_moves_the_dip_onset_to_a_quarter_of_the_bus_voltage_less_4_delta_v() {
        // 4E = V_dc − 4ΔV: the common phase's drive and the outgoing phase's decay each carry ΔV
        // twice
        let at_onset = |dead_time_v: f32| (270.0 - 4.0 * dead_time_v) / (4.0 * 0.13);
        let k = [0.13f32; 3];
        let dead = with_effect(FaultVector::HEALTHY.0, EffectId::DeadTime, 1.0);
        assert_eq!(dead.commutation::<true>(&k, 0, 0.99 * at_onset(8.0)).drop_fraction, 0.0);
        assert!(dead.commutation::<true>(&k, 0, 1.01 * at_onset(8.0)).drop_fraction > 0.0);
        let healthy = model(FaultVector::HEALTHY.0);
        let w = 0.98 * at_onset(0.0);
        assert_eq!(healthy.commutation::<true>(&k, 0, w).drop_fraction, 0.0);
        assert!(dead.commutation::<true>(&k, 0, w).drop_fraction > 0.0);
    }

    #[test]
    fn commutation_torque_loss_with_a_hall_offset_integrates_the_ramps() {
        // Against the new pair's K_eq at full current, a commutation over α = p·ω·t_c loses
        // k·i_out·(f_in − f_out): the outgoing phase decays from I while its EMF leaves its flat top
        // at φ = a (the Hall advance), the incoming one carries I − i_out while its EMF reaches its
        // flat top at φ = a. Integrated numerically over the trapezoids' 30° ramps here; the
        // model's sector mean in equivalent current (÷ π/3, ÷ 2k) must match.
        let p = EmaParams::NOMINAL;
        let k = FaultVector::HEALTHY;
        let hall =
            MonitorModel::with_effects(&p, &k, &ModelEffects::NONE.with(EffectId::HallMisalignment, 1.0).unwrap());
        let plain = MonitorModel::new(&p, &k);
        let (kp, i) = ([0.13f32; 3], 15.0f32);
        let ramp = |x: f64| (x * 6.0 / core::f64::consts::PI).clamp(0.0, 1.0);
        let integral = |alpha: f64, a: f64| {
            let n = 20_000;
            let h = alpha / n as f64;
            let sum: f64 = (0..n)
                .map(|j| {
                    let phi = (j as f64 + 0.5) * h;
                    let (f_in, f_out) = (1.0 - ramp(a - phi), 1.0 - ramp(phi - a));
                    f64::from(i) * (1.0 - phi / alpha) * (f_in - f_out)
                })
                .sum();
            sum * h / (core::f64::consts::PI / 3.0) / 2.0
        };
        for (m, w, a) in
            [(&plain, 300.0f32, 0.0f64), (&hall, 300.0, 10f64.to_radians()), (&hall, -300.0, -10f64.to_radians())]
        {
            let c = m.commutation::<true>(&kp, 1, w);
            let alpha = f64::from(4.0 * libm::fabsf(w) * c.time_s_per_a * i);
            let loss = m.commutation_losses::<true>(&c, i * w.signum(), w, 1).1 * w.signum();
            let expected = integral(alpha, a);
            assert!((f64::from(loss) - expected).abs() < 2e-3 * f64::from(i), "a {a}: {loss} vs {expected}");
        }
        // forward, the advance turns the loss into a gain: the outgoing phase decays on its flat top
        let c = hall.commutation::<true>(&kp, 1, 300.0);
        assert!(hall.commutation_losses::<true>(&c, i, 300.0, 1).1 < 0.0);
    }

    #[test]
    fn a_shorted_outgoing_phase_commutates_faster() {
        // A short lowers L_j (∝ (1−s)²) more than k_j (∝ 1−s): its current decays faster, so
        // commutations where it leaves are shorter than the healthy ones; the equal-phase case is
        // the symmetric formula exactly.
        let m = model([0.0, 0.0, 0.6, 0.0, 0.0, 0.0, 0.5, 0.5]); // s_a = 0.3
        let k = [0.13 * 0.7, 0.13, 0.13];
        let w = 700.0;
        let a_leaves = m.commutation::<true>(&k, 2, w); // forward 1 → 2: a leaves
        let a_stays = m.commutation::<true>(&k, 1, w); // forward 0 → 1: b leaves
        assert!(a_leaves.time_s_per_a < a_stays.time_s_per_a);
        let healthy = model(FaultVector::HEALTHY.0).commutation::<true>(&[0.13; 3], 1, w);
        let e = 0.13 * w;
        assert!((healthy.time_s_per_a - 3.0 * 2e-3 / (270.0 + 2.0 * e)).abs() < 1e-9);
        assert!((healthy.drop_fraction - (4.0 * e - 270.0) / (270.0 + 2.0 * e)).abs() < 1e-5);
    }
}
