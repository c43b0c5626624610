//! Hall commutation, hysteresis current control, three-phase inverter and star-connected windings
//! (docs/model.md).
//!
//! ```text
//! sector s = floor(((θ_e + δ_H − π/6) mod 2π) / (π/3))          (Hall logic, δ_H = Hall offset)
//! i*_j = c_j(s)·I_ref                                            (120° six-step table, COMMUTATION)
//! commanded phase (c_j ≠ 0):  i_m < i*_j − h → upper on, v_j0 = +V/2;  i_m > i*_j + h → lower on, v_j0 = −V/2;
//!                             else keep the previous switch;  i_m = (1 + g_j)·i_j + o_j (sensor seen by the comparator)
//! idle phase (c_j = 0):       i_j ≠ 0 → freewheel diode, v_j0 = −sign(i_j)·V/2; i_j reaching 0 → OPEN (i_j = 0);
//!                             an OPEN phase conducts again through a diode when |e_j + v_n0| > V/2
//! every conducting phase:     v_j0 −= sign(i_j)·ΔV                (dead time / device drop effect)
//! v_n0   = Σ_C (v_j0 − R_j i_j − e_j)/L_j / Σ_C 1/L_j              (isolated neutral, C = conducting set)
//! di_j/dt = (v_j0 − v_n0 − R_j i_j − e_j)/L_j  (j ∈ C),  0 otherwise   ⇒ Σ di_j/dt = 0
//! ```
//!
//! Explicit Euler on the currents. When a freewheeling current crosses zero inside a step it is set to
//! zero and its residue is given back to the phases still conducting in proportion to `1/L_j` (the same
//! weighting as `v_n0`), so `i_a + i_b + i_c = 0` holds after every step, to rounding.

use core::f64::consts::{PI, TAU};

/// Commutation table `c_j(s)` for sectors 0..5 (docs/model.md).
pub const COMMUTATION: [[i8; 3]; 6] = [[1, -1, 0], [1, 0, -1], [0, 1, -1], [-1, 1, 0], [-1, 0, 1], [0, -1, 1]];

/// Hall sector of an electrical angle (already offset by `δ_H` if the Hall sensors are misaligned).
pub fn hall_sector(theta_e_rad: f64) -> u8 {
    let x = (theta_e_rad - PI / 6.0).rem_euclid(TAU);
    // rem_euclid may return TAU itself for tiny negative inputs: fold it back into sector 5.
    ((x / (PI / 3.0)) as u8).min(5)
}

/// Hall signals (a, b, c) of a sector, as in the table of docs/model.md.
pub fn hall_signals(sector: u8) -> [bool; 3] {
    const H: [[bool; 3]; 6] = [
        [true, false, true],
        [true, false, false],
        [true, true, false],
        [false, true, false],
        [false, true, true],
        [false, false, true],
    ];
    H[usize::from(sector.min(5))]
}

/// Trapezoidal shape `f_a(θ_e)`: linear ramps of width `ramp_rad` around the zero crossings at 0 and π,
/// flat top ±1 in between (`ramp_rad = π/6` gives the ideal 120° flat top of docs/model.md).
pub fn trapezoid(theta_e_rad: f64, ramp_rad: f64) -> f64 {
    let x = theta_e_rad.rem_euclid(TAU);
    let (sign, y) = if x < PI { (1.0, x) } else { (-1.0, x - PI) };
    let u = y.min(PI - y).max(0.0);
    sign * (u / ramp_rad).min(1.0)
}

/// Shapes of the three phases, `f_b(θ) = f_a(θ − 2π/3)`, `f_c(θ) = f_a(θ − 4π/3)`.
pub fn emf_shapes(theta_e_rad: f64, ramp_rad: f64) -> [f64; 3] {
    [
        trapezoid(theta_e_rad, ramp_rad),
        trapezoid(theta_e_rad - TAU / 3.0, ramp_rad),
        trapezoid(theta_e_rad - 2.0 * TAU / 3.0, ramp_rad),
    ]
}

/// Inputs of one electrical step.
#[derive(Clone, Copy, Debug)]
pub struct ElectricalInputs {
    /// Hall sector driving the commutation.
    pub sector: u8,
    /// Signed current reference from the ACE.
    pub current_ref_a: f64,
    /// Back-EMF `e_j` of each phase.
    pub emf_v: [f64; 3],
    /// DC-link voltage at the inverter.
    pub supply_v: f64,
    /// `R_j`.
    pub resistance_ohm: [f64; 3],
    /// `L_j`.
    pub inductance_h: [f64; 3],
    /// Hysteresis half band `h`.
    pub half_band_a: f64,
    /// Dead-time voltage error `ΔV`.
    pub dead_time_v: f64,
    /// Current-sensor offsets seen by the comparators.
    pub sensor_offset_a: [f64; 3],
    /// Current-sensor gain errors seen by the comparators.
    pub sensor_gain_error: [f64; 3],
}

/// Energy flows of one step (joules), evaluated with the step's mid-point currents so that
/// `terminal = copper + conversion + ΔE_magnetic` holds exactly for an explicit Euler step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ElectricalEnergy {
    /// `Σ (v_j0 − v_n0)·i_j·dt`: energy delivered into the windings.
    pub terminal_j: f64,
    /// `Σ R_j·i_j·i_mid,j·dt`.
    pub copper_j: f64,
    /// `Σ e_j·i_mid,j·dt`: energy converted to mechanical work.
    pub conversion_j: f64,
    /// `Σ ½ L_j (i'_j² − i_j²)`.
    pub magnetic_change_j: f64,
}

/// State of the inverter and windings.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Inverter {
    /// Phase currents `i_a, i_b, i_c` (positive into the winding).
    pub current_a: [f64; 3],
    upper_on: [bool; 3],
    commanded: [bool; 3],
    /// Terminal voltages `v_j0` of the last step (0 for open phases).
    pub terminal_v: [f64; 3],
    /// Neutral voltage `v_n0` of the last step.
    pub neutral_v: f64,
    /// Which phases conducted during the last step.
    pub conducting: [bool; 3],
}

impl Inverter {
    /// Currents zero, every switch off.
    pub fn new() -> Self {
        Self::default()
    }

    /// DC-link current drawn by the inverter with the last step's switch states, `I_dc = Σ v_j0·i_j / V_dc`.
    pub fn dc_current_a(&self, supply_v: f64) -> f64 {
        if supply_v <= 0.0 {
            return 0.0;
        }
        (0..3).map(|j| self.terminal_v[j] * self.current_a[j]).sum::<f64>() / supply_v
    }

    /// Advances the currents by `dt`; returns the step's energy flows.
    pub fn step(&mut self, u: &ElectricalInputs, dt: f64) -> ElectricalEnergy {
        let half = 0.5 * u.supply_v;
        let table = COMMUTATION[usize::from(u.sector.min(5))];
        let i = self.current_a;
        let mut v = [0.0; 3];
        let mut on = [false; 3];
        for j in 0..3 {
            let c = table[j];
            if c != 0 {
                let i_star = f64::from(c) * u.current_ref_a;
                let i_meas = (1.0 + u.sensor_gain_error[j]) * i[j] + u.sensor_offset_a[j];
                if !self.commanded[j] {
                    // Newly commanded: start with the switch that drives the current towards its reference.
                    self.upper_on[j] = i_meas <= i_star;
                }
                if i_meas < i_star - u.half_band_a {
                    self.upper_on[j] = true;
                } else if i_meas > i_star + u.half_band_a {
                    self.upper_on[j] = false;
                }
                v[j] = if self.upper_on[j] { half } else { -half };
                on[j] = true;
                self.commanded[j] = true;
            } else {
                self.commanded[j] = false;
                if i[j] != 0.0 {
                    v[j] = -i[j].signum() * half;
                    on[j] = true;
                }
            }
            if on[j] && i[j] != 0.0 {
                v[j] -= i[j].signum() * u.dead_time_v;
            }
        }
        let mut v_n = neutral_voltage(&v, &on, &i, u);
        // An open phase whose floating terminal would pass a rail conducts through that rail's diode.
        let mut reopened = false;
        for j in 0..3 {
            if !on[j] {
                let floating = v_n + u.emf_v[j];
                if floating.abs() > half {
                    v[j] = floating.signum() * half;
                    on[j] = true;
                    reopened = true;
                }
            }
        }
        if reopened {
            v_n = neutral_voltage(&v, &on, &i, u);
        }
        let mut next = i;
        for j in 0..3 {
            if on[j] {
                let di = (v[j] - v_n - u.resistance_ohm[j] * i[j] - u.emf_v[j]) / u.inductance_h[j];
                next[j] = i[j] + dt * di;
            }
        }
        // Diode current of an idle phase cannot reverse: clamp at zero and restore Σi = 0.
        let mut clamped = false;
        for j in 0..3 {
            if table[j] == 0 && i[j] != 0.0 && (next[j] == 0.0 || next[j].signum() != i[j].signum()) {
                next[j] = 0.0;
                on[j] = false;
                clamped = true;
            }
        }
        if clamped {
            let residue: f64 = next.iter().sum();
            let weight: f64 = (0..3).filter(|&j| on[j]).map(|j| 1.0 / u.inductance_h[j]).sum();
            if weight > 0.0 {
                for j in 0..3 {
                    if on[j] {
                        next[j] -= residue * (1.0 / u.inductance_h[j]) / weight;
                    }
                }
            }
        }
        let mut e = ElectricalEnergy::default();
        for j in 0..3 {
            let mid = 0.5 * (i[j] + next[j]);
            if on[j] || i[j] != 0.0 {
                e.terminal_j += (v[j] - v_n) * mid * dt;
            }
            e.copper_j += u.resistance_ohm[j] * i[j] * mid * dt;
            e.conversion_j += u.emf_v[j] * mid * dt;
            e.magnetic_change_j += 0.5 * u.inductance_h[j] * (next[j] * next[j] - i[j] * i[j]);
        }
        self.current_a = next;
        self.terminal_v = v;
        self.neutral_v = v_n;
        self.conducting = on;
        e
    }
}

fn neutral_voltage(v: &[f64; 3], on: &[bool; 3], i: &[f64; 3], u: &ElectricalInputs) -> f64 {
    let mut num = 0.0;
    let mut den = 0.0;
    for j in 0..3 {
        if on[j] {
            num += (v[j] - u.resistance_ohm[j] * i[j] - u.emf_v[j]) / u.inductance_h[j];
            den += 1.0 / u.inductance_h[j];
        }
    }
    if den > 0.0 {
        num / den
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sectors_match_the_table() {
        // Sector centres: 60°, 120°, …, 360°.
        for s in 0..6u8 {
            let centre = PI / 3.0 * (f64::from(s) + 1.0);
            assert_eq!(hall_sector(centre), s);
        }
        assert_eq!(hall_signals(0), [true, false, true]);
        assert_eq!(hall_sector(-1e-18), 5);
    }

    #[test]
    fn trapezoid_shape() {
        let r = PI / 6.0;
        assert!((trapezoid(PI / 12.0, r) - 0.5).abs() < 1e-12);
        assert_eq!(trapezoid(PI / 2.0, r), 1.0);
        assert_eq!(trapezoid(1.5 * PI, r), -1.0);
        assert!((trapezoid(PI, r)).abs() < 1e-12);
        // Each sector's commanded pair sits on the flat tops with the right signs: positive torque.
        for s in 0..6u8 {
            let centre = PI / 3.0 * (f64::from(s) + 1.0);
            for edge in [-0.49, 0.0, 0.49] {
                let th = centre + edge * PI / 3.0;
                let f = emf_shapes(th, r);
                let c = COMMUTATION[usize::from(s)];
                let torque: f64 = (0..3).map(|j| f64::from(c[j]) * f[j]).sum();
                assert!((torque - 2.0).abs() < 1e-9, "sector {s} at {th}: {torque}");
            }
        }
    }
}
