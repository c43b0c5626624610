//! Six-step commutation geometry of a three-phase trapezoidal BLDC motor: the conducting pair of
//! each Hall sector, the roles of the phases at a commutation, and the phases' trapezoidal
//! back-EMF shape.
//!
//! ```text
//! Hall angle   θ_H = (θ_e − π/6) mod 2π,   sector s = ⌊θ_H/(π/3)⌋ ∈ 0..6
//! pair         (p, q) = PAIRS[s]            (p driven positive, q negative, r = 3 − p − q idle)
//! shape        f_j(θ_e) = f(θ_e − j·2π/3),  f the trapezoid of flat top ±1 and ramps of width r
//! ```
//!
//! A leaf module: it imports nothing from the crate, so the monitor model, its effect terms and
//! the conditioning share one table without importing each other.

use core::f32::consts::{FRAC_PI_3, PI};

/// `2π`.
pub(crate) const TWO_PI: f32 = 2.0 * PI;

/// Conducting pair `(positive phase, negative phase)` per Hall sector (phases a, b, c = 0, 1, 2).
pub(crate) const PAIRS: [(usize, usize); 6] = [(0, 1), (0, 2), (1, 2), (1, 0), (2, 0), (2, 1)];

/// A phase (a, b, c = 0, 1, 2) held in a type whose only values are those three: an index made
/// from it is in range of any per-phase array, so indexing one needs no bounds check and has no
/// panic path (the on-board path is proven panic-free, `scripts/prove-no-panic`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub(crate) enum Phase {
    A = 0,
    B = 1,
    C = 2,
}

impl Phase {
    /// The phase's index into a per-phase array: 0, 1 or 2.
    pub(crate) const fn index(self) -> usize {
        self as usize
    }
}

/// [`PAIRS`] with the idle phase: `(p, q, r)` per Hall sector, in the bounded [`Phase`] type.
const ROLES: [(Phase, Phase, Phase); 6] = {
    use Phase::{A, B, C};
    [(A, B, C), (A, C, B), (B, C, A), (B, A, C), (C, A, B), (C, B, A)]
};

/// The conducting pair `(p, q)` and the idle phase `r = 3 − p − q` of Hall sector `sector mod 6`,
/// each an index below 3 (the compiler knows it: per-phase arrays indexed by them have no bounds
/// check).
#[cfg_attr(not(target_os = "none"), inline)]
pub(crate) fn sector_phases(sector: usize) -> (usize, usize, usize) {
    let (p, q, r) = ROLES[sector % 6];
    (p as usize, q as usize, r as usize)
}

/// [`sector_phases`] as [`Phase`]s, in the table: for phases kept in an array and read back in a
/// loop, where an index alone would lose its bound and keep a bounds check. A reference, so that
/// each phase is read on its own, as a `Phase` (a tuple returned by value can come back as one
/// packed integer, from which a phase is extracted without its bound).
#[cfg_attr(not(target_os = "none"), inline)]
pub(crate) fn sector_roles(sector: usize) -> &'static (Phase, Phase, Phase) {
    &ROLES[sector % 6]
}

/// Hall sector `0..6` of a Hall angle in `[0, 2π)` (an angle that rounds to 2π reads sector 5).
pub(crate) fn sector_of(hall_angle_rad: f32) -> usize {
    let sector = (hall_angle_rad * (1.0 / FRAC_PI_3)) as usize;
    if sector < 6 {
        sector
    } else {
        5
    }
}

/// Wraps an angle that moved by less than 2π per step back into `[0, 2π)`.
pub(crate) fn wrap(a: f32) -> f32 {
    if a >= TWO_PI {
        a - TWO_PI
    } else if a < 0.0 {
        a + TWO_PI
    } else {
        a
    }
}

/// `(common, outgoing, incoming)` phases of the commutation into `sector`, from `sector − 1` when
/// turning forward, from `sector + 1` when turning backward: a look-up in [`COMMUTATION_ROLES`].
pub(crate) fn commutation_roles(sector: usize, forward: bool) -> (usize, usize, usize) {
    let (c, o, n) = COMMUTATION_ROLES[sector % 6][usize::from(forward)];
    (c as usize, o as usize, n as usize)
}

/// [`commutation_roles`] of every sector, backward (`[0]`) and forward (`[1]`), derived from
/// [`ROLES`] at compile time: the common phase is the one both pairs share, the incoming one the
/// new pair's other phase, the outgoing one the old pair's.
const COMMUTATION_ROLES: [[(Phase, Phase, Phase); 2]; 6] = {
    let mut table = [[(Phase::A, Phase::A, Phase::A); 2]; 6];
    let mut sector = 0;
    while sector < 6 {
        let mut direction = 0;
        while direction < 2 {
            let previous = if direction == 1 { (sector + 5) % 6 } else { (sector + 1) % 6 };
            let (a, b, _) = ROLES[sector];
            let (x, y, _) = ROLES[previous];
            let common = if a as u8 == x as u8 || a as u8 == y as u8 { a } else { b };
            let incoming = if common as u8 == a as u8 { b } else { a };
            let outgoing = if common as u8 == x as u8 { y } else { x };
            table[sector][direction] = (common, outgoing, incoming);
            direction += 1;
        }
        sector += 1;
    }
    table
};

/// Trapezoidal back-EMF shape `f(θ_e)` of phase a at any electrical angle: linear ramps of width
/// `1/inv_ramp_per_rad` from the zero crossings at 0 and π, flat top ±1 between (ramp `π/6`: the
/// ideal 120° flat top). The same shape as the reference model's.
pub(crate) fn phase_emf_shape(theta_e_rad: f32, inv_ramp_per_rad: f32) -> f32 {
    phase_emf_shape_in_turn(theta_e_rad - TWO_PI * libm::floorf(theta_e_rad * (1.0 / TWO_PI)), inv_ramp_per_rad)
}

/// [`phase_emf_shape`] of an angle `x` already in `[0, 2π)`.
#[inline]
pub(crate) fn phase_emf_shape_in_turn(x: f32, inv_ramp_per_rad: f32) -> f32 {
    let (sign, y) = if x < PI { (1.0, x) } else { (-1.0, x - PI) };
    let u = if y < PI - y { y } else { PI - y };
    let f = u * inv_ramp_per_rad;
    sign * if f > 1.0 {
        1.0
    } else if f > 0.0 {
        f
    } else {
        0.0
    }
}

/// [`phase_emf_shape`] of an angle less than one turn outside `[0, 2π)` (a phase's
/// `θ_e − j·2π/3` with `θ_e ∈ [π/6, 2π + π/6)`), folded by one turn instead of a `floor`: the
/// same value up to the rounding of the fold, at the cost of two comparisons.
#[cfg_attr(not(target_os = "none"), inline)]
pub(crate) fn phase_emf_shape_near_turn(theta_e_rad: f32, inv_ramp_per_rad: f32) -> f32 {
    let x = if theta_e_rad < 0.0 {
        theta_e_rad + TWO_PI
    } else if theta_e_rad >= TWO_PI {
        theta_e_rad - TWO_PI
    } else {
        theta_e_rad
    };
    phase_emf_shape_in_turn(x, inv_ramp_per_rad)
}

/// The ideal back-EMF shapes `f_j` of the three phases (120° flat tops) at the Hall angle
/// `hall_rad` in its Hall `sector`: the sector's pair on its flat tops (+1, −1), the idle phase on
/// its 60° ramp, falling in even sectors, rising in odd ones. [`phase_emf_shape`] of ramp `π/6`
/// without its folds.
pub(crate) fn ideal_emf_shapes(sector: usize, hall_rad: f32) -> [f32; 3] {
    let (a, b, idle) = sector_phases(sector);
    // The angle into the sector; at the 5 → 0 edge `hall_rad` may round to either side of 2π.
    let mut within = wrap(hall_rad) - sector as f32 * FRAC_PI_3;
    if within > PI {
        within -= TWO_PI;
    } else if within < -PI {
        within += TWO_PI;
    }
    let within = clamp(within, 0.0, FRAC_PI_3);
    let ramp = 1.0 - within * (6.0 / PI);
    let mut f = [0.0f32; 3];
    f[a] = 1.0;
    f[b] = -1.0;
    f[idle] = if sector.is_multiple_of(2) { ramp } else { -ramp };
    f
}

fn clamp(x: f32, lo: f32, hi: f32) -> f32 {
    if x < lo {
        lo
    } else if x > hi {
        hi
    } else {
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f32::consts::FRAC_PI_6;

    #[test]
    fn phase_emf_shape_is_the_reference_trapezoid() {
        let r = 1.0 / FRAC_PI_6;
        assert!((phase_emf_shape(PI / 12.0, r) - 0.5).abs() < 1e-6);
        assert_eq!(phase_emf_shape(PI / 2.0, r), 1.0);
        assert_eq!(phase_emf_shape(1.5 * PI, r), -1.0);
        assert_eq!(phase_emf_shape(1.5 * PI - 2.0 * TWO_PI, r), -1.0);
        assert!(phase_emf_shape(PI, r).abs() < 1e-5);
    }

    #[test]
    fn ideal_shapes_are_the_trapezoid_of_a_sixth_of_a_turn() {
        for n in 0..600 {
            let hall = (n as f32 + 0.5) * (TWO_PI / 600.0);
            let sector = sector_of(hall);
            let f = ideal_emf_shapes(sector, hall);
            for (j, fj) in f.iter().enumerate() {
                let theta = hall + FRAC_PI_6 - j as f32 * (2.0 * FRAC_PI_3);
                let reference = phase_emf_shape(theta, 6.0 / PI);
                assert!((fj - reference).abs() < 1e-4, "hall {hall}, phase {j}: {fj} vs {reference}");
                let folded = phase_emf_shape_near_turn(theta, 6.0 / PI);
                assert!((folded - reference).abs() < 1e-5, "hall {hall}, phase {j}: {folded} vs {reference}");
            }
        }
    }

    #[test]
    fn commutation_roles_follow_the_six_step_table() {
        // forward 0 → 1: (a+, b−) → (a+, c−): a stays, b leaves, c enters
        assert_eq!(commutation_roles(1, true), (0, 1, 2));
        // backward 1 → 0: (a+, c−) → (a+, b−): a stays, c leaves, b enters
        assert_eq!(commutation_roles(0, false), (0, 2, 1));
        for sector in 0..6 {
            for forward in [true, false] {
                let (c, o, n) = commutation_roles(sector, forward);
                assert!(c != o && o != n && c != n);
                let (p, q) = PAIRS[sector];
                assert!((c == p || c == q) && (n == p || n == q), "the new pair is (common, incoming)");
            }
        }
    }

    #[test]
    fn commutation_roles_table_is_the_shared_and_the_changed_phases() {
        for sector in 0..12 {
            for forward in [true, false] {
                let previous = if forward { (sector + 5) % 6 } else { (sector + 1) % 6 };
                let ((a, b), (x, y)) = (PAIRS[sector % 6], PAIRS[previous]);
                let common = if a == x || a == y { a } else { b };
                let expected = (common, if common == x { y } else { x }, if common == a { b } else { a });
                assert_eq!(commutation_roles(sector, forward), expected, "sector {sector}, forward {forward}");
            }
        }
    }

    #[test]
    fn sector_phases_are_the_pairs_and_the_idle_phase() {
        for sector in 0..12 {
            let (p, q) = PAIRS[sector % 6];
            assert_eq!(sector_phases(sector), (p, q, 3 - p - q), "sector {sector}");
        }
    }
}
