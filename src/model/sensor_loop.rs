//! The current loop regulating the *measured* phase currents (`sensor_offset`): an effect term
//! of the monitor model that acts within a Hall sector. Constants are precomputed once per
//! model; the term is `None` (and costs nothing per step) when its severity is 0. Without the
//! `effect-terms` feature the model holds none, and this module is not used.
#![cfg_attr(not(feature = "effect-terms"), allow(dead_code, unused_imports))]

use crate::effects::{maxima, EffectId, ModelEffects};
use crate::params::EmaParams;
use crate::six_step::sector_phases;

/// The hysteresis current loop regulating *measured* currents `i_m,j = (1 + g_j)·i_j + o_j`:
/// the positive phase `p` of the pair wants the true current `T_p = (I_ref − o_p)/(1 + g_p)`, the
/// negative one `q` (measuring `−I`) wants `T_q = (I_ref + o_q)/(1 + g_q)`. Each leg switches up
/// below its band and down above it, so between the two targets the pair sees 0 V and the current
/// drifts at `−(K_eq ω + R_eq I)/L_eq`: it is held in the band of the target that drift runs into,
/// `T_held = min(T_p, T_q)` if `K_eq·ω + R_eq·I > 0` (the 0 V drift lowers `I`), `max` otherwise;
/// that leg regulates, the other stays latched. `o = s·(0.2, −0.1, 0.15) A`,
/// `g = s·(0.02, −0.02, 0.01)`.
///
/// Two consequences follow (the reference model's regulated and idle phase currents show both):
///
/// **The controller's jitter lifts the held current toward the other target.** `I_ref` jumps by
/// `σ_J` ≈ 0.29 A from one control period to the next (the derivative on the position noise and
/// code, [`EmaParams::controller_jitter_a`]). When the 0 V drift per period,
/// `a = |K_eq ω + R_eq I|·T/L_eq`, is small against it, the current no longer runs down its band:
/// it only moves when a jump pushes a threshold past it, from either end, and sits halfway
/// between the two targets on average. So
///
/// ```text
/// I_target = T_held + (T_other − T_held)·½·exp(−(a/σ_J)²)
/// ```
///
/// **The freewheel conducts through the idle phase.** The 0 V state is both legs on one rail:
/// the lower one (`ρ = −1`) when `p` has the lower target, the upper one (`ρ = +1`) otherwise.
/// With both pair terminals at `ρV/2` the idle phase `r` floats at `ρV/2 + e_r`, so while
/// `ρ·e_r > 0` (half of each sector) its diode to that rail conducts and `i_r` (sign `−ρ`) grows
/// at `2|e_r|/(3L_r)` (all three on one rail, flat-top EMFs `e_p + e_q = 0`); each pulse of the
/// regulating leg (`V` across the pair) drains it again at `V/(3L_r)`, faster than it grew. Over
/// one freewheel of length `t_0` and one pulse `t_u` the idle phase carries the triangle's mean
///
/// ```text
/// i_r = −ρ · ½·(2|e_r|·t_0/(3L_r))·t_0/(t_0 + t_u) · d/(d + d_sync)
/// t_0 = 1/(|K_eq ω + R_eq I|/(2h·L_eq) + 1/τ_J),   t_u = 2h·L_eq/(V − |K_eq ω + R_eq I|)
/// τ_J = 2·2h·T/σ_J                                  (the jitter cuts the freewheel short)
/// ```
///
/// and the pair phase that does not regulate returns it (`−i_r`), so `I_3eq` reads `|i_r|` more
/// where the idle current adds to it. `d = |T_p − T_q|`: targets closer than `d_sync`
/// ([`FREEWHEEL_SYNC_A`]) switch both legs together. The factor 2 in `τ_J`, `d_sync` and the
/// `σ_J` scale of the share are fitted to the reference model, whose idle phase carries a few
/// hundredths of an ampere on average between 20 and 120 rad/s from a moderate severity up; the
/// rest follows from the circuit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct SensorLoop {
    /// Per sector `(1/(1+g_p), o_p/(1+g_p), 1/(1+g_q), o_q/(1+g_q))`.
    targets: [[f32; 4]; 6],
    /// Per sector `(2h·L_eq, 2/(3L_r), T/L_eq)`.
    freewheel: [[f32; 3]; 6],
    /// `1/a_J`.
    inv_drift_scale_a: f32,
    /// `1/τ_J`.
    inv_reset_s: f32,
    /// `V`.
    supply_v: f32,
}

/// Share of the way to the other target the held current sits at when the 0 V drift is nil
/// (`½`: the current then only moves when the jittering band pushes it, symmetrically from both
/// ends, [`SensorLoop`]).
pub(crate) const HOLD_SHARE_AT_REST: f32 = 0.5;

/// `a_J/σ_J`: the drift per control period `a` at which the share has fallen by `1/e`
/// (`share = ½·exp(−(a/a_J)²)`, [`SensorLoop`]): the natural scale, a drift of one jitter per
/// period; scales from 0.75 to 1.5 fit the reference model about equally well.
pub(crate) const HOLD_DRIFT_PER_JITTER: f32 = 1.0;

/// Target difference below which the two legs switch together (A, [`SensorLoop`]).
pub(crate) const FREEWHEEL_SYNC_A: f32 = 0.01;

/// What the loop holds in one step ([`SensorLoop::hold`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Hold {
    /// True pair current the loop holds.
    pub(crate) target_a: f32,
    /// Mean idle-phase current `i_r` of the freewheel (signed, 0 when it does not conduct).
    pub(crate) idle_a: f32,
    /// `true` when `p` is the regulated phase (`q` returns the idle current), `false` for `q`.
    pub(crate) regulated_p: bool,
}

impl SensorLoop {
    /// The loop of `effects`, `None` when `sensor_offset` is off. `phase_l_h` per phase,
    /// `jitter_a` the controller's `σ_J` on `I_ref`.
    pub(crate) fn of(effects: &ModelEffects, params: &EmaParams, phase_l_h: &[f32; 3], jitter_a: f32) -> Option<Self> {
        let s = effects.get(EffectId::SensorOffset);
        if s == 0.0 {
            return None;
        }
        let band_a = 2.0 * params.hysteresis_half_band_a;
        let mut targets = [[0.0; 4]; 6];
        let mut freewheel = [[0.0; 3]; 6];
        for (sector, (t, f)) in targets.iter_mut().zip(freewheel.iter_mut()).enumerate() {
            let (p, q, r) = sector_phases(sector); // phases below 3 the compiler knows: no bounds check
            let inv_p = 1.0 / (1.0 + s * maxima::SENSOR_GAIN[p]);
            let inv_q = 1.0 / (1.0 + s * maxima::SENSOR_GAIN[q]);
            *t = [inv_p, s * maxima::SENSOR_OFFSET_A[p] * inv_p, inv_q, s * maxima::SENSOR_OFFSET_A[q] * inv_q];
            let l_eq = phase_l_h[p] + phase_l_h[q];
            *f = [band_a * l_eq, 2.0 / (3.0 * phase_l_h[r]), params.control_period_s / l_eq];
        }
        let inv_reset_s = if jitter_a > 0.0 { jitter_a / (2.0 * band_a * params.control_period_s) } else { 0.0 };
        let inv_drift_scale_a = if jitter_a > 0.0 { 1.0 / (HOLD_DRIFT_PER_JITTER * jitter_a) } else { f32::INFINITY };
        Some(Self { targets, freewheel, inv_reset_s, inv_drift_scale_a, supply_v: params.supply_voltage_v })
    }

    /// The true pair current the loop holds for `i_ref_a` in `sector`, `back_v = R_eq·I + K_eq·ω`,
    /// and the freewheel's idle-phase current for the idle phase's EMF `idle_emf_v`.
    pub(crate) fn hold(&self, sector: usize, i_ref_a: f32, back_v: f32, idle_emf_v: f32) -> Hold {
        let sector = sector % 6;
        let [inv_p, off_p, inv_q, off_q] = self.targets[sector];
        let t_p = inv_p * i_ref_a - off_p;
        let t_q = inv_q * i_ref_a + off_q;
        let regulated_p = (back_v > 0.0) == (t_p < t_q);
        let (held, other) = if regulated_p { (t_p, t_q) } else { (t_q, t_p) };
        let [band_l, rise, period_over_l] = self.freewheel[sector];
        let back = libm::fabsf(back_v);
        // The controller's jitter pulls the held current toward the other target where the 0 V
        // drift per control period is small against it.
        let x = back * period_over_l * self.inv_drift_scale_a;
        let target_a = held + (other - held) * HOLD_SHARE_AT_REST * libm::expf(-x * x);
        // The freewheel's rail: the lower one (ρ = −1) when p has the lower target.
        let rail = if t_p < t_q { -1.0 } else { 1.0 };
        let mut idle_a = 0.0;
        if rail * idle_emf_v > 0.0 && back > 0.0 && back < self.supply_v {
            let t_0 = 1.0 / (back / band_l + self.inv_reset_s);
            let t_u = band_l / (self.supply_v - back);
            let d = libm::fabsf(t_p - t_q);
            let mean = 0.5 * rise * libm::fabsf(idle_emf_v) * t_0 * t_0 / (t_0 + t_u) * d / (d + FREEWHEEL_SYNC_A);
            idle_a = -rail * mean;
        }
        Hold { target_a, idle_a, regulated_p }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_loop_holds_the_target_the_free_wheel_drift_runs_into() {
        let p = EmaParams::NOMINAL;
        let effects = ModelEffects::NONE.with(EffectId::SensorOffset, 1.0).unwrap();
        let l = SensorLoop::of(&effects, &p, &[p.phase_inductance_h; 3], 0.29).unwrap();
        // Sector 0 = (a+, b−): T_a = (I − 0.2)/1.02, T_b = (I − 0.1)/0.98.
        let (t_a, t_b) = ((5.0 - 0.2) / 1.02, (5.0 - 0.1) / 0.98);
        // A fast 0 V drift (200 V over 4 mH: 5 A per control period, ≫ σ_J): the target itself.
        let motoring = l.hold(0, 5.0, 200.0, 0.0);
        assert!((motoring.target_a - t_a).abs() < 1e-5 && motoring.regulated_p, "motoring: the lower, a's");
        let generating = l.hold(0, 5.0, -200.0, 0.0);
        assert!((generating.target_a - t_b).abs() < 1e-5 && !generating.regulated_p, "generating: the higher, b's");
        // No drift: halfway, whichever leg regulates; in between, ½·exp(−(a/σ_J)²) of the way.
        let at_rest = l.hold(0, 5.0, 1e-6, 0.0);
        assert!((at_rest.target_a - 0.5 * (t_a + t_b)).abs() < 1e-4, "{at_rest:?}");
        let a = 30.0 * 1.0e-4 / 4.0e-3; // 0.75 A per period
        let share = 0.5 * libm::expf(-(a / 0.29) * (a / 0.29));
        let slow = l.hold(0, 5.0, 30.0, 0.0);
        assert!((slow.target_a - (t_a + share * (t_b - t_a))).abs() < 1e-5, "{slow:?}");
        assert!(SensorLoop::of(&ModelEffects::NONE, &p, &[p.phase_inductance_h; 3], 0.29).is_none());
    }

    #[test]
    fn the_idle_phase_conducts_through_the_freewheel_rail_only() {
        let p = EmaParams::NOMINAL;
        let effects = ModelEffects::NONE.with(EffectId::SensorOffset, 1.0).unwrap();
        let l = SensorLoop::of(&effects, &p, &[p.phase_inductance_h; 3], 0.29).unwrap();
        // Sector 0: a has the lower target, so the freewheel is on the lower rail (ρ = −1) and c's
        // diode conducts while e_c < 0, carrying i_c > 0.
        let on = l.hold(0, 5.0, 30.0, -5.0);
        assert!(on.idle_a > 0.0, "{on:?}");
        assert_eq!(l.hold(0, 5.0, 30.0, 5.0).idle_a, 0.0, "e_c > 0 keeps the diode blocked");
        assert_eq!(l.hold(0, 5.0, 0.0, -5.0).idle_a, 0.0, "no drift, no freewheel");
        assert_eq!(l.hold(0, 5.0, 300.0, -5.0).idle_a, 0.0, "no pulse above the supply");
        // Sector 3 = (b+, a−): T_b = (I + 0.1)/0.98 > T_a = (I + 0.2)/1.02 for I = 5: b higher,
        // upper rail, c conducts while e_c > 0 and carries i_c < 0.
        assert!(l.hold(3, 5.0, 30.0, 5.0).idle_a < 0.0);
        // A steeper idle EMF charges more; a faster drift (shorter freewheel) less.
        assert!(l.hold(0, 5.0, 30.0, -10.0).idle_a > on.idle_a);
        assert!(l.hold(0, 5.0, 60.0, -5.0).idle_a < on.idle_a);
        // The triangle's mean: t_0 = 1/(30/(0.6·4e-3) + 0.29/(2·0.6·1e-4)), t_u = 0.6·4e-3/240.
        let (band_l, t_u) = (0.6 * 4.0e-3, 0.6 * 4.0e-3 / 240.0);
        let t_0 = 1.0 / (30.0 / band_l + 0.29 / (2.0 * 0.6 * 1.0e-4));
        let d = t_b_minus_t_a(5.0);
        let expected = 0.5 * (2.0 * 5.0 / (3.0 * 2.0e-3)) * t_0 * t_0 / (t_0 + t_u) * d / (d + FREEWHEEL_SYNC_A);
        assert!((on.idle_a - expected).abs() < 1e-6, "{} vs {expected}", on.idle_a);
    }

    fn t_b_minus_t_a(i: f32) -> f32 {
        (i - 0.1) / 0.98 - (i - 0.2) / 1.02
    }
}
