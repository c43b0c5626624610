//! Back-EMF shape (`emf_harmonics`) and Hall offset (`hall_misalignment`): effect terms of the
//! monitor model that act within a Hall sector. Constants are precomputed once per model; the
//! term is `None` (and costs nothing per step) when both severities are 0. Without the
//! `effect-terms` feature the model holds none, and this module is not used.
#![cfg_attr(not(feature = "effect-terms"), allow(dead_code, unused_imports))]

use crate::effects::{maxima, EffectId, ModelEffects};
use crate::six_step::{phase_emf_shape, PAIRS};
use core::f32::consts::{FRAC_PI_3, FRAC_PI_6};

/// Back-EMF shape and Hall offset: the conducting pair's EMF constant becomes a function of the
/// rotor position inside the sector, and the commutation happens `δ_H` early (electrical):
///
/// ```text
/// ramp  r = π/6 + s_EMF·20°/side            (flat top 120° − s_EMF·40°)
/// f_j(θ_e) = phase_emf_shape(θ_e − j·2π/3, r)
/// Hall  sector = ⌊((θ_e + δ_H − π/6) mod 2π)/(π/3)⌋,   δ_H = s_Hall·10°
/// pair  K_eq(θ_e) = k_p·f_p(θ_e) − k_q·f_q(θ_e)     (p positive, q negative phase of the sector)
/// ```
///
/// `K_eq` then drives the torque and the back-EMF of the voltage clamp. The commutation terms of
/// the pair regime (flat-top EMFs `k_j|ω|` at the commutation angle) scale each phase's `k_j` by
/// how its shaped EMF compares with the ideal one over the commutation: turning
/// forward the commutation into sector `s` happens at `θ_e = s·π/3 + π/6 − δ_H`, backward at
/// `(s+1)·π/3 + π/6 − δ_H`, and lasts about 30° electrical where it matters (`t_c ≈ 0.2 ms` at
/// the dip onset and above), so the factor is `⟨f_j⟩/⟨f_j,ideal⟩` over the 30° after the
/// commutation angle (signs as at the ideal angle; 1 for the ideal shape). A Hall advance is
/// therefore direction-dependent: forward the *incoming* phase is still on its ramp (lower EMF,
/// faster rise), backward the *outgoing* one (lower EMF, slower decay), and the pair's `K_eq` dips
/// at the start of each sector forward, at its end backward. The recovery after the commutation
/// (commutation-limited current) runs over the rest of the sector, so its back-EMF uses the
/// sector mean `k_p·⟨|f_p|⟩ + k_q·⟨|f_q|⟩` (32-point midpoint rule, once per model).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct EmfShape {
    /// `1/r`.
    pub(crate) inv_ramp_per_rad: f32,
    /// `δ_H` (electrical).
    pub(crate) hall_offset_rad: f32,
    /// `|f_j|` at the commutation into sector `s`, index `2s + forward`.
    boundary: [[f32; 3]; 12],
    /// Per (commutation) sector the means of `|f_p|` and `|f_q|` over the sector.
    sector_mean: [[f32; 2]; 6],
}

impl EmfShape {
    /// The shape terms of `effects`, `None` when both are off.
    pub(crate) fn of(effects: &ModelEffects) -> Option<Self> {
        let narrowing = effects.get(EffectId::EmfHarmonics);
        let hall = effects.get(EffectId::HallMisalignment);
        if narrowing == 0.0 && hall == 0.0 {
            return None;
        }
        let ramp_rad = FRAC_PI_6 + narrowing * (0.5 * maxima::EMF_FLAT_TOP_NARROWING_DEG).to_radians();
        let inv_ramp_per_rad = 1.0 / ramp_rad;
        let hall_offset_rad = hall * maxima::HALL_OFFSET_DEG.to_radians();
        const POINTS: usize = 32;
        let ideal_inv_ramp = 1.0 / FRAC_PI_6;
        let mut boundary = [[1.0; 3]; 12];
        for (index, b) in boundary.iter_mut().enumerate() {
            let (sector, forward) = (index / 2, index % 2 == 1);
            let edge = if forward { sector as f32 } else { sector as f32 + 1.0 };
            let ideal_edge = edge * FRAC_PI_3 + FRAC_PI_6;
            let direction = if forward { 1.0 } else { -1.0 };
            for (j, f) in b.iter_mut().enumerate() {
                let shift = j as f32 * (2.0 * FRAC_PI_3);
                let sign = phase_emf_shape(ideal_edge - direction * 1e-3 - shift, ideal_inv_ramp);
                let (mut shaped, mut ideal) = (0.0, 0.0);
                for point in 0..POINTS {
                    let x = ideal_edge + direction * (point as f32 + 0.5) / POINTS as f32 * FRAC_PI_6 - shift;
                    shaped += sign * phase_emf_shape(x - hall_offset_rad, inv_ramp_per_rad);
                    ideal += sign * phase_emf_shape(x, ideal_inv_ramp);
                }
                *f = shaped / ideal;
            }
        }
        let mut sector_mean = [[0.0; 2]; 6];
        for (sector, mean) in sector_mean.iter_mut().enumerate() {
            let (p, q) = PAIRS[sector];
            for point in 0..POINTS {
                let x = (sector as f32 + (point as f32 + 0.5) / POINTS as f32) * FRAC_PI_3;
                let theta_e = x + FRAC_PI_6 - hall_offset_rad;
                for (m, j) in mean.iter_mut().zip([p, q]) {
                    *m += libm::fabsf(phase_emf_shape(theta_e - j as f32 * (2.0 * FRAC_PI_3), inv_ramp_per_rad))
                        * (1.0 / POINTS as f32);
                }
            }
        }
        Some(Self { inv_ramp_per_rad, hall_offset_rad, boundary, sector_mean })
    }

    /// `K_eq(θ_e) = k_p·f_p − k_q·f_q` of `sector`'s pair at the Hall angle `hall_angle_rad`
    /// (`θ_e − π/6`), per-phase constants `k`.
    pub(crate) fn pair_k(&self, k: &[f32; 3], sector: usize, hall_angle_rad: f32) -> f32 {
        let (p, q) = PAIRS[sector % 6];
        let theta_e = hall_angle_rad + FRAC_PI_6;
        let f = |j: usize| phase_emf_shape(theta_e - j as f32 * (2.0 * FRAC_PI_3), self.inv_ramp_per_rad);
        k[p] * f(p) - k[q] * f(q)
    }

    /// Sector mean of `K_eq` of `sector`'s pair, `k_p·⟨|f_p|⟩ + k_q·⟨|f_q|⟩`.
    pub(crate) fn mean_pair_k(&self, k: &[f32; 3], sector: usize) -> f32 {
        let (p, q) = PAIRS[sector % 6];
        let [m_p, m_q] = self.sector_mean[sector % 6];
        k[p] * m_p + k[q] * m_q
    }

    /// `k_j·|f_j|` at the commutation into `sector` (turning `forward` or not).
    pub(crate) fn commutation_k(&self, k: &[f32; 3], sector: usize, forward: bool) -> [f32; 3] {
        let b = self.boundary[(2 * sector + usize::from(forward)) % 12];
        [k[0] * b[0], k[1] * b[1], k[2] * b[2]]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ideal_pair_sum_is_flat_and_narrowed_one_dips_at_the_sector_edges() {
        let k = [0.13; 3];
        let narrow = EmfShape::of(&ModelEffects::NONE.with(EffectId::EmfHarmonics, 1.0).unwrap()).unwrap();
        for sector in 0..6 {
            let start = sector as f32 * FRAC_PI_3;
            let mid = narrow.pair_k(&k, sector, start + 0.5 * FRAC_PI_3);
            let edge = narrow.pair_k(&k, sector, start + 1e-4);
            assert!((mid - 0.26).abs() < 1e-6, "{mid}");
            // ramp 50°: the phase entering its flat top 30° after its zero crossing reads 30/50
            assert!((edge - 0.13 * 1.6).abs() < 1e-3, "{edge}");
        }
        assert_eq!(EmfShape::of(&ModelEffects::NONE), None);
    }

    #[test]
    fn hall_advance_is_a_lead_forward_and_a_lag_backward() {
        let hall = EmfShape::of(&ModelEffects::NONE.with(EffectId::HallMisalignment, 1.0).unwrap()).unwrap();
        let k = [0.13; 3];
        // Sector 1 = (a+, c−), commutation angle 90° − 10°. Forward 0 → 1: b leaves still on its
        // flat top (over the next 30°: 0.778 against the ideal ramp's 0.5), c enters 10° before
        // the end of its ramp (0.944 against 1).
        let fwd = hall.commutation_k(&k, 1, true);
        assert!((fwd[0] - 0.13).abs() < 1e-5, "{fwd:?}");
        assert!((fwd[1] - 0.13 * 0.778 / 0.5).abs() < 2e-3 && (fwd[2] - 0.13 * 0.944).abs() < 2e-3, "{fwd:?}");
        // Backward 1 → 0 at the same angle: the lag. c leaves already on its ramp (signed mean
        // 0.167 against 0.5), b enters on its flat top.
        let bwd = hall.commutation_k(&k, 0, false);
        assert!((bwd[0] - 0.13).abs() < 1e-5 && (bwd[1] - 0.13).abs() < 1e-5, "{bwd:?}");
        assert!((bwd[2] - 0.13 / 3.0).abs() < 2e-3, "{bwd:?}");
        // Without an offset and with the ideal ramp the factors are 1.
        let ideal = EmfShape::of(&ModelEffects::NONE.with(EffectId::HallMisalignment, 1e-7).unwrap()).unwrap();
        for sector in 0..6 {
            for forward in [true, false] {
                for kj in ideal.commutation_k(&k, sector, forward) {
                    assert!((kj - 0.13).abs() < 1e-4, "{sector} {forward}: {kj}");
                }
            }
        }
        // Commutation (Hall) sector 1 starts at θ_e = 90° − 10°: the pair dips there, not at its end.
        let start = hall.pair_k(&k, 1, FRAC_PI_3 - hall.hall_offset_rad + 1e-4);
        let end = hall.pair_k(&k, 1, 2.0 * FRAC_PI_3 - hall.hall_offset_rad - 1e-4);
        assert!((start - 0.13 * (1.0 + 2.0 / 3.0)).abs() < 1e-3 && (end - 0.26).abs() < 1e-5, "{start} {end}");
    }
}
