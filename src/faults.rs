//! The normalized fault vector `k` and its physical meaning: the one place the mapping lives.
//!
//! Same vector, same order and same mapping as the paper (Dalla Vedova, Berri, Re, ICSRS 2018,
//! §VI), used by the monitor model, the reference model and the health report:
//!
//! | i | name | healthy | physical parameter | mapping |
//! |---|------|---------|--------------------|---------|
//! | k1 | dry friction | 0 | `FSJ, FDJ` | `FSJ = FSJ_0·(1 + 2 k1)`, same for `FDJ` (1× to 3× nominal, paper) |
//! | k2 | backlash | 0 | total free play `BL` at the surface | `BL = BL_0·(1 + 99 k2)` (1× to 100× nominal, paper; 0.05 to 5 mrad) |
//! | k3, k4, k5 | partial short circuit, phases A, B, C | 0 | shorted fraction of turns `s_j` | `s_j = 0.5·k_j` (up to 50 % of the turns) |
//! | k6 | rotor static eccentricity, magnitude | 0 | `ζ = e_0/g_0` | `ζ = 0.5·k6` (0.5: rub beyond) |
//! | k7 | eccentricity phase (not a severity) | 0.5 | angle of the minimum air gap `φ` | `φ = 2π·k7 − π` (paper), periodic |
//! | k8 | proportional gain drift | 0.5 | `Kp` | `Kp = Kp_0·(0.5 + k8)` (50 % to 150 % of nominal, paper) |
//!
//! Effect of a short circuit on phase j (`docs/model.md`): `R_j = R_0·(1−s_j)`, `L_j = L_0·(1−s_j)²`,
//! `k_j = k_0·(1−s_j)`. Eccentricity (first-order, per-phase form, `docs/model.md`):
//! `k_j(θ_m) = k_0·(1−s_j)·[1 + ζ·cos(θ_m − φ − j·2π/3)]`.
//!
//! Three index spaces name the faults, each a type with its names: a [`FaultParam`] is one
//! element of `k`; a [`FaultGroup`] is the parameters that appear and disappear together (what
//! model selection tests: each parameter alone, the eccentricity's magnitude with its phase); a
//! [`FaultMode`] is what the health report gives a condition (the three phases' shorts are one
//! short circuit). Every name and key the reports, files and command line use is here.

use crate::params::EmaParams;

/// Number of fault parameters in the vector.
pub const FAULT_COUNT: usize = 8;

/// One parameter of the fault vector `k`, in vector order: [`FaultParam::index`] is its index
/// in `k` (and in every per-parameter array).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FaultParam {
    /// `k1`, dry friction.
    Friction,
    /// `k2`, backlash.
    Backlash,
    /// `k3`, partial short circuit of phase A.
    ShortA,
    /// `k4`, partial short circuit of phase B.
    ShortB,
    /// `k5`, partial short circuit of phase C.
    ShortC,
    /// `k6`, rotor static eccentricity, magnitude.
    Eccentricity,
    /// `k7`, the eccentricity's phase (not a severity).
    EccentricityPhase,
    /// `k8`, proportional gain drift.
    GainDrift,
}

impl FaultParam {
    /// All parameters in vector order.
    pub const ALL: [FaultParam; FAULT_COUNT] = [
        FaultParam::Friction,
        FaultParam::Backlash,
        FaultParam::ShortA,
        FaultParam::ShortB,
        FaultParam::ShortC,
        FaultParam::Eccentricity,
        FaultParam::EccentricityPhase,
        FaultParam::GainDrift,
    ];

    /// The parameter's index in the fault vector.
    pub const fn index(self) -> usize {
        self as usize
    }

    /// Machine key, as CSV columns, JSON fields and `--simulate` laws spell it: `friction`,
    /// `backlash`, `short_a`, `short_b`, `short_c`, `eccentricity`, `ecc_phase`, `gain`.
    pub const fn key(self) -> &'static str {
        match self {
            FaultParam::Friction => "friction",
            FaultParam::Backlash => "backlash",
            FaultParam::ShortA => "short_a",
            FaultParam::ShortB => "short_b",
            FaultParam::ShortC => "short_c",
            FaultParam::Eccentricity => "eccentricity",
            FaultParam::EccentricityPhase => "ecc_phase",
            FaultParam::GainDrift => "gain",
        }
    }

    /// The group the parameter appears and disappears with.
    pub const fn group(self) -> FaultGroup {
        match self {
            FaultParam::Friction => FaultGroup::Friction,
            FaultParam::Backlash => FaultGroup::Backlash,
            FaultParam::ShortA => FaultGroup::ShortA,
            FaultParam::ShortB => FaultGroup::ShortB,
            FaultParam::ShortC => FaultGroup::ShortC,
            FaultParam::Eccentricity | FaultParam::EccentricityPhase => FaultGroup::Eccentricity,
            FaultParam::GainDrift => FaultGroup::GainDrift,
        }
    }
}

/// The parameters of the fault vector that appear and disappear together: what model selection
/// tests, the probes of a warm start look for and the uncertainty reports on. Each group is one
/// parameter, except the eccentricity: its magnitude and its phase.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FaultGroup {
    /// Dry friction, `k1`.
    Friction,
    /// Backlash, `k2`.
    Backlash,
    /// Short circuit of phase A, `k3`.
    ShortA,
    /// Short circuit of phase B, `k4`.
    ShortB,
    /// Short circuit of phase C, `k5`.
    ShortC,
    /// Eccentricity, magnitude and phase, `k6` and `k7`.
    Eccentricity,
    /// Gain drift, `k8`.
    GainDrift,
}

/// Number of fault groups.
pub const GROUP_COUNT: usize = 7;

impl FaultGroup {
    /// All groups, in the order of their parameters in the vector.
    pub const ALL: [FaultGroup; GROUP_COUNT] = [
        FaultGroup::Friction,
        FaultGroup::Backlash,
        FaultGroup::ShortA,
        FaultGroup::ShortB,
        FaultGroup::ShortC,
        FaultGroup::Eccentricity,
        FaultGroup::GainDrift,
    ];

    /// The group's index in [`FaultGroup::ALL`] (and in every per-group array and bit set).
    pub const fn index(self) -> usize {
        self as usize
    }

    /// The group of index `i` in [`FaultGroup::ALL`].
    pub const fn from_index(i: usize) -> Option<FaultGroup> {
        if i < GROUP_COUNT {
            Some(FaultGroup::ALL[i])
        } else {
            None
        }
    }

    /// The group's parameters, as `(first, last)` indices into the fault vector.
    pub const fn params(self) -> (usize, usize) {
        // One table, indexed, rather than a match: a match inlined into each caller becomes a
        // switch table of its own in each, on a flash-bound board.
        const PARAMS: [(usize, usize); GROUP_COUNT] = [(0, 0), (1, 1), (2, 2), (3, 3), (4, 4), (5, 6), (7, 7)];
        PARAMS[self as usize]
    }

    /// The parameter that carries the group's severity (the eccentricity's magnitude, not its
    /// phase).
    pub const fn severity_param(self) -> FaultParam {
        FaultParam::ALL[self.params().0]
    }

    /// The fault mode the group belongs to.
    pub const fn mode(self) -> FaultMode {
        match self {
            FaultGroup::Friction => FaultMode::Friction,
            FaultGroup::Backlash => FaultMode::Backlash,
            FaultGroup::ShortA | FaultGroup::ShortB | FaultGroup::ShortC => FaultMode::ShortCircuit,
            FaultGroup::Eccentricity => FaultMode::Eccentricity,
            FaultGroup::GainDrift => FaultMode::GainDrift,
        }
    }

    /// Name, for reports: `friction`, `backlash`, `short circuit A`, `short circuit B`, `short
    /// circuit C`, `eccentricity`, `gain drift`.
    pub const fn name(self) -> &'static str {
        match self {
            FaultGroup::Friction => "friction",
            FaultGroup::Backlash => "backlash",
            FaultGroup::ShortA => "short circuit A",
            FaultGroup::ShortB => "short circuit B",
            FaultGroup::ShortC => "short circuit C",
            FaultGroup::Eccentricity => "eccentricity",
            FaultGroup::GainDrift => "gain drift",
        }
    }
}

/// The five fault modes of the paper: what the health report gives a condition, the evidence
/// accumulates over flights and the health record keeps a history of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FaultMode {
    /// Dry friction growth (bearing and transmission wear).
    Friction,
    /// Backlash growth (gear and joint wear).
    Backlash,
    /// Partial turn-to-turn short circuit of a stator phase.
    ShortCircuit,
    /// Rotor static eccentricity (support bearing degradation).
    Eccentricity,
    /// Drift of the position loop's proportional gain (control electronics).
    GainDrift,
}

/// Number of fault modes.
pub const MODE_COUNT: usize = 5;

impl FaultMode {
    /// All modes in report order.
    pub const ALL: [FaultMode; MODE_COUNT] = [
        FaultMode::Friction,
        FaultMode::Backlash,
        FaultMode::ShortCircuit,
        FaultMode::Eccentricity,
        FaultMode::GainDrift,
    ];

    /// The mode's index in [`FaultMode::ALL`] (and in every per-mode array).
    pub const fn index(self) -> usize {
        self as usize
    }

    /// Name, for reports: `friction`, `backlash`, `short circuit`, `eccentricity`, `gain drift`.
    pub const fn name(self) -> &'static str {
        match self {
            FaultMode::Friction => "friction",
            FaultMode::Backlash => "backlash",
            FaultMode::ShortCircuit => "short circuit",
            FaultMode::Eccentricity => "eccentricity",
            FaultMode::GainDrift => "gain drift",
        }
    }

    /// Machine key, as the board's report line, campaign cells and `--modes` spell it:
    /// `friction`, `backlash`, `short`, `eccentricity`, `gain`.
    pub const fn key(self) -> &'static str {
        match self {
            FaultMode::Friction => "friction",
            FaultMode::Backlash => "backlash",
            FaultMode::ShortCircuit => "short",
            FaultMode::Eccentricity => "eccentricity",
            FaultMode::GainDrift => "gain",
        }
    }

    /// The mode's groups, as `(first, last)` of [`FaultGroup::ALL`] (the three phases' shorts for
    /// the short circuit, one group for every other mode).
    pub const fn groups(self) -> (FaultGroup, FaultGroup) {
        match self {
            FaultMode::Friction => (FaultGroup::Friction, FaultGroup::Friction),
            FaultMode::Backlash => (FaultGroup::Backlash, FaultGroup::Backlash),
            FaultMode::ShortCircuit => (FaultGroup::ShortA, FaultGroup::ShortC),
            FaultMode::Eccentricity => (FaultGroup::Eccentricity, FaultGroup::Eccentricity),
            FaultMode::GainDrift => (FaultGroup::GainDrift, FaultGroup::GainDrift),
        }
    }
}

/// Largest shorted fraction of a phase's turns (`k_j = 1`).
pub const MAX_SHORTED_FRACTION: f32 = 0.5;
/// Largest normalized eccentricity `ζ` (`k6 = 1`).
pub const MAX_ECCENTRICITY: f32 = 0.5;
/// Friction multiplier span: `1 + FRICTION_SPAN·k1`.
pub const FRICTION_SPAN: f32 = 2.0;
/// Backlash multiplier span: `1 + BACKLASH_SPAN·k2`.
pub const BACKLASH_SPAN: f32 = 99.0;

/// Normalized fault vector `k ∈ [0, 1]^8` (paper §VI).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FaultVector(pub [f32; FAULT_COUNT]);

impl FaultVector {
    /// The healthy actuator: no fault, eccentricity phase and gain at their nominal 0.5.
    pub const HEALTHY: Self = Self([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]);

    /// `true` when every element is finite and inside `[0, 1]`.
    pub fn is_valid(&self) -> bool {
        self.0.iter().all(|k| k.is_finite() && (0.0..=1.0).contains(k))
    }

    /// The physical parameters this vector stands for, on top of `nominal`.
    pub fn physical(&self, nominal: &EmaParams) -> FaultPhysics {
        let k = &self.0;
        let friction_scale = 1.0 + FRICTION_SPAN * k[0];
        FaultPhysics {
            static_friction_n_m: nominal.static_friction_n_m * friction_scale,
            dynamic_friction_n_m: nominal.dynamic_friction_n_m * friction_scale,
            backlash_rad: nominal.nominal_backlash_rad * (1.0 + BACKLASH_SPAN * k[1]),
            shorted_fraction: [MAX_SHORTED_FRACTION * k[2], MAX_SHORTED_FRACTION * k[3], MAX_SHORTED_FRACTION * k[4]],
            eccentricity: MAX_ECCENTRICITY * k[5],
            eccentricity_phase_rad: 2.0 * core::f32::consts::PI * k[6] - core::f32::consts::PI,
            kp_a_per_rad: nominal.kp_a_per_rad * (0.5 + k[7]),
        }
    }

    /// The paper's identification error (§VII), in percent, of `self` (estimate) against `truth`:
    /// `Err% = 100·sqrt( Σ_{i=1..6}(k_i − k̂_i)² + k̂_6·d(k_7, k̂_7)² + (k_8 − k̂_8)² )`
    /// where `k̂` is the reference (true) vector. The phase term is weighted by the true magnitude
    /// because the phase means nothing without eccentricity. `d` is the distance on the circle,
    /// `min(|k_7 − k̂_7|, 1 − |k_7 − k̂_7|)`: `k_7` = 0 and 1 are the same phase (−π ≡ π), as the
    /// optimizers treat it (periodic bounds); the paper's plain difference would score a phase
    /// found at 0.998 for a true 0.021 as a 74 % error.
    pub fn paper_error_percent(&self, truth: &FaultVector) -> f32 {
        let (k, t) = (&self.0, &truth.0);
        let mut sum = 0.0;
        for i in 0..6 {
            sum += (k[i] - t[i]) * (k[i] - t[i]);
        }
        let phase = libm::fabsf(k[6] - t[6]);
        let phase = phase.min(1.0 - phase);
        sum += t[5] * phase * phase;
        sum += (k[7] - t[7]) * (k[7] - t[7]);
        100.0 * libm::sqrtf(sum)
    }
}

impl Default for FaultVector {
    fn default() -> Self {
        Self::HEALTHY
    }
}

/// Physical parameters that a fault vector changes (the rest stay at [`EmaParams`]).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FaultPhysics {
    /// Breakaway dry friction at the motor shaft, `FSJ`.
    pub static_friction_n_m: f32,
    /// Sliding dry friction at the motor shaft, `FDJ`.
    pub dynamic_friction_n_m: f32,
    /// Total free play at the surface, `BL`.
    pub backlash_rad: f32,
    /// Shorted fraction of the turns of phases A, B, C, `s_j`.
    pub shorted_fraction: [f32; 3],
    /// Normalized static eccentricity `ζ`.
    pub eccentricity: f32,
    /// Angle of the minimum air gap `φ`, in `[−π, π]`.
    pub eccentricity_phase_rad: f32,
    /// Proportional gain after drift, `Kp`.
    pub kp_a_per_rad: f32,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn healthy_maps_to_nominal() {
        let p = EmaParams::NOMINAL;
        let f = FaultVector::HEALTHY.physical(&p);
        assert_eq!(f.static_friction_n_m, p.static_friction_n_m);
        assert_eq!(f.backlash_rad, p.nominal_backlash_rad);
        assert_eq!(f.shorted_fraction, [0.0; 3]);
        assert_eq!(f.eccentricity, 0.0);
        assert_eq!(f.eccentricity_phase_rad, 0.0);
        assert_eq!(f.kp_a_per_rad, p.kp_a_per_rad);
    }

    #[test]
    fn full_scale_ends_of_the_ranges() {
        let p = EmaParams::NOMINAL;
        let f = FaultVector([1.0; 8]).physical(&p);
        assert!((f.static_friction_n_m - 3.0 * p.static_friction_n_m).abs() < 1e-6);
        assert!((f.backlash_rad - 100.0 * p.nominal_backlash_rad).abs() < 1e-9);
        assert_eq!(f.shorted_fraction, [0.5; 3]);
        assert!((f.kp_a_per_rad - 1.5 * p.kp_a_per_rad).abs() < 1e-3);
        let f0 = FaultVector([0.0; 8]).physical(&p);
        assert!((f0.kp_a_per_rad - 0.5 * p.kp_a_per_rad).abs() < 1e-3);
        assert!((f0.eccentricity_phase_rad + core::f32::consts::PI).abs() < 1e-6);
    }

    #[test]
    fn paper_error_matches_table_one() {
        // Table I (GA, small friction fault): estimates printed to 4 decimals and their Err%.
        // Rounding each printed k to ±5e-5 moves Err% by up to ~0.01 points, hence the bound.
        let truth = FaultVector([0.25, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]);
        let rows: [([f32; 8], f32); 3] = [
            ([0.2446, 0.0009, 0.0030, 0.0023, 0.0003, 0.0015, 0.7045, 0.4851], 1.6358),
            ([0.2378, 0.0033, 0.0099, 0.0059, 0.0060, 0.0095, 0.3734, 0.4685], 3.7595),
            ([0.2460, 0.0005, 0.0004, 0.0009, 0.0024, 0.0019, 0.3378, 0.4861], 1.4846),
        ];
        for (est, expected) in rows {
            let e = FaultVector(est).paper_error_percent(&truth);
            assert!((e - expected).abs() < 0.01, "{est:?}: {e} vs {expected}");
        }
    }

    #[test]
    fn the_phase_error_wraps_around_the_circle() {
        let truth = FaultVector([0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.02, 0.5]);
        let across = FaultVector([0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.99, 0.5]).paper_error_percent(&truth);
        let same_side = FaultVector([0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.05, 0.5]).paper_error_percent(&truth);
        // both 0.03 of a turn away: 100·sqrt(0.5·0.03²)
        let expected = 100.0 * libm::sqrtf(0.5 * 0.03 * 0.03);
        assert!((across - expected).abs() < 1e-3, "{across} vs {expected}");
        assert!((same_side - expected).abs() < 1e-3, "{same_side} vs {expected}");
    }

    #[test]
    fn the_three_index_spaces_agree() {
        // every parameter in exactly its group's range, the groups tiling the vector in order
        let mut next = 0;
        for (g, group) in FaultGroup::ALL.iter().enumerate() {
            assert_eq!(group.index(), g);
            assert_eq!(FaultGroup::from_index(g), Some(*group));
            let (first, last) = group.params();
            assert_eq!(first, next, "{group:?}");
            for param in &FaultParam::ALL[first..=last] {
                assert_eq!(param.group(), *group);
            }
            next = last + 1;
        }
        assert_eq!(next, FAULT_COUNT);
        assert_eq!(FaultGroup::from_index(GROUP_COUNT), None);
        // every group in exactly its mode's range
        for mode in FaultMode::ALL {
            let (first, last) = mode.groups();
            for group in &FaultGroup::ALL[first.index()..=last.index()] {
                assert_eq!(group.mode(), mode);
            }
        }
        assert!(FaultGroup::ALL.iter().all(|g| FaultMode::ALL[g.mode().index()] == g.mode()));
        assert_eq!(
            FaultParam::ALL.iter().map(|p| p.index()).collect::<std::vec::Vec<_>>(),
            (0..FAULT_COUNT).collect::<std::vec::Vec<_>>()
        );
    }

    #[test]
    fn names_and_keys_are_distinct() {
        let distinct = |names: &[&str]| names.iter().enumerate().all(|(i, a)| names[..i].iter().all(|b| a != b));
        assert!(distinct(&FaultParam::ALL.map(FaultParam::key)));
        assert!(distinct(&FaultGroup::ALL.map(FaultGroup::name)));
        assert!(distinct(&FaultMode::ALL.map(FaultMode::name)));
        assert!(distinct(&FaultMode::ALL.map(FaultMode::key)));
        // keys are single tokens (a report line's fields, a CSV column, a flag's value)
        let token = |k: &str| !k.is_empty() && k.bytes().all(|b| b.is_ascii_lowercase() || b == b'_');
        assert!(FaultParam::ALL.iter().all(|p| token(p.key())));
        assert!(FaultMode::ALL.iter().all(|m| token(m.key())));
    }

    #[test]
    fn validity() {
        assert!(FaultVector::HEALTHY.is_valid());
        assert!(!FaultVector([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 1.5]).is_valid());
        assert!(!FaultVector([f32::NAN, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]).is_valid());
    }
}
