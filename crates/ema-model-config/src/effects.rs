//! Optional effect terms of the monitor model (equations in `docs/model.md`), all off by default.
//!
//! The reference model can play ten "library" effects the paper's monitor model does not know
//! (`host-tests/reference`, same IDs). Each has a severity `s` mapped to a physical magnitude by
//! the **same** table as there ([`maxima`]; `s = 1` is the documented maximum, and the model
//! accepts up to [`MAX_SEVERITY`]), so an effect named by the discrepancy
//! workflow (`ema discover`) can be switched on here with the severity it estimated, on the host
//! and on board alike. Storage is one fixed array of severities: no allocation, `Copy`.
//!
//! A model built with [`ModelEffects::NONE`] runs exactly (bit for bit) the paper's model: every
//! term is guarded by its severity being non-zero.
//!
//! [`parse_model_config`] reads the model configuration file (`monitor-model.conf`, written by
//! `ema discover`) that switches effects on; the firmware's `build.rs` calls it to parse the same
//! file with the same code at build time (this crate is one of its build dependencies, without the
//! `defmt` feature).

/// Number of library effects the monitor model can add.
pub const EFFECT_COUNT: usize = 10;

/// Largest severity the model accepts: a quarter beyond the documented maximum (`s = 1`,
/// [`maxima`]), where every term's physics still holds (the magnitudes scale linearly). A fit
/// needs room beyond the maximum to tell an effect *at* its maximum (fitted about 1) from one
/// stronger than, or different from, the library's (fitted at this bound): with the bound at 1
/// the two would be the same verdict and an effect at its maximum refused (`ema discover`).
pub const MAX_SEVERITY: f32 = 1.25;

/// One library effect, by the ID the reference model and the command line use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EffectId {
    /// Cogging torque `A·sin(24·θ_m)`, `A = s·0.04 N·m`.
    Cogging,
    /// Velocity-weakening friction: breakaway `FSJ·(1+s)`, sliding
    /// `FDJ + s·(2·FSJ − FDJ)·exp(−(ω/ω_s)²)`, `ω_s = 5 rad/s` (motor side).
    Stribeck,
    /// Extra viscous friction at the motor, `ΔC = s·5e-4 N·m·s/rad`.
    Viscous,
    /// Winding temperature rise `ΔT = s·100 K`: `R×(1 + 3.93e-3·ΔT)`, `k_e×(1 − 1.1e-3·ΔT)`.
    WindingTemperature,
    /// Back-EMF flat top narrowed from 120° to `120° − s·40°` electrical.
    EmfHarmonics,
    /// Inverter dead time and device drops, `−sign(i_j)·ΔV` per conducting phase, `ΔV = s·8 V`.
    DeadTime,
    /// Current-sensor error `i_meas = (1 + g_j)·i_j + o_j`, `o = s·(0.2, −0.1, 0.15) A`,
    /// `g = s·(0.02, −0.02, 0.01)`.
    SensorOffset,
    /// Hinge stiffness above nominal, `K_h×(1 + s)`.
    HingeStiffness,
    /// Magnetic saturation `k_j/(1 + (I/I_sat)²)`, `I_sat = 30 A / s`.
    Saturation,
    /// Hall-sensor misalignment `δ_H = s·10°` electrical.
    HallMisalignment,
}

/// What severity 1 means, per effect (the reference model's documented maxima).
pub mod maxima {
    /// Cogging torque amplitude (N·m).
    pub const COGGING_TORQUE_N_M: f32 = 0.04;
    /// Cogging cycles per mechanical revolution (12 slots, 8 poles).
    pub const COGGING_CYCLES_PER_REV: f32 = 24.0;
    /// Breakaway gain of the Stribeck effect: `FSJ×(1 + s·gain)`.
    pub const STRIBECK_STICTION_GAIN: f32 = 1.0;
    /// Stribeck speed at the motor (rad/s).
    pub const STRIBECK_SPEED_RAD_PER_S: f32 = 5.0;
    /// Extra viscous friction (N·m·s/rad).
    pub const VISCOUS_N_M_S_PER_RAD: f32 = 5e-4;
    /// Winding temperature rise (K).
    pub const WINDING_TEMPERATURE_RISE_K: f32 = 100.0;
    /// Copper resistance coefficient (1/K).
    pub const COPPER_ALPHA_PER_K: f32 = 3.93e-3;
    /// NdFeB flux coefficient (1/K).
    pub const MAGNET_BETA_PER_K: f32 = -1.1e-3;
    /// Narrowing of the back-EMF flat top (degrees electrical).
    pub const EMF_FLAT_TOP_NARROWING_DEG: f32 = 40.0;
    /// Dead-time voltage per conducting phase (V).
    pub const DEAD_TIME_V: f32 = 8.0;
    /// Current-sensor offsets per phase (A).
    pub const SENSOR_OFFSET_A: [f32; 3] = [0.2, -0.1, 0.15];
    /// Current-sensor gain errors per phase.
    pub const SENSOR_GAIN: [f32; 3] = [0.02, -0.02, 0.01];
    /// Relative hinge stiffness increase.
    pub const HINGE_STIFFNESS_GAIN: f32 = 1.0;
    /// Saturation current at `s = 1` (A).
    pub const SATURATION_CURRENT_A: f32 = 30.0;
    /// Hall offset (degrees electrical).
    pub const HALL_OFFSET_DEG: f32 = 10.0;
}

impl EffectId {
    /// Every library effect, in catalogue order (the index order of [`ModelEffects`]).
    pub const ALL: [EffectId; EFFECT_COUNT] = [
        EffectId::Cogging,
        EffectId::Stribeck,
        EffectId::Viscous,
        EffectId::WindingTemperature,
        EffectId::EmfHarmonics,
        EffectId::DeadTime,
        EffectId::SensorOffset,
        EffectId::HingeStiffness,
        EffectId::Saturation,
        EffectId::HallMisalignment,
    ];

    /// The ID (`cogging`, `stribeck`, …), as on the command line and in the reference model.
    pub const fn id(self) -> &'static str {
        match self {
            EffectId::Cogging => "cogging",
            EffectId::Stribeck => "stribeck",
            EffectId::Viscous => "viscous",
            EffectId::WindingTemperature => "winding_temperature",
            EffectId::EmfHarmonics => "emf_harmonics",
            EffectId::DeadTime => "dead_time",
            EffectId::SensorOffset => "sensor_offset",
            EffectId::HingeStiffness => "hinge_stiffness",
            EffectId::Saturation => "saturation",
            EffectId::HallMisalignment => "hall_misalignment",
        }
    }

    /// The effect of an ID, `None` when it is not a library effect.
    pub fn from_id(id: &str) -> Option<Self> {
        Self::ALL.iter().copied().find(|e| e.id() == id)
    }

    /// Position in [`EffectId::ALL`].
    pub const fn index(self) -> usize {
        self as usize
    }
}

/// A severity outside `[0, MAX_SEVERITY]` (or not a number).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SeverityOutOfRange {
    /// The effect.
    pub effect: EffectId,
    /// The refused severity.
    pub severity: f32,
}

impl core::fmt::Display for SeverityOutOfRange {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "effect {}: severity {} is outside [0, {MAX_SEVERITY}]", self.effect.id(), self.severity)
    }
}

impl core::error::Error for SeverityOutOfRange {}

/// The effect terms switched on in a monitor model: one severity per library effect (0 = off).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ModelEffects {
    severity: [f32; EFFECT_COUNT],
}

impl ModelEffects {
    /// No effect: the paper's monitor model.
    pub const NONE: Self = Self { severity: [0.0; EFFECT_COUNT] };

    /// The effects of one severity per library effect, in [`EffectId::ALL`] order; `None` when one
    /// is outside `[0, MAX_SEVERITY]` or NaN. A `const fn`, so a configuration generated at build time is
    /// checked at compile time (`match … { Some(e) => e, None => panic!(…) }` in a `const`).
    pub const fn from_severities(severity: [f32; EFFECT_COUNT]) -> Option<Self> {
        let mut k = 0;
        while k < EFFECT_COUNT {
            let s = severity[k];
            // written so that NaN fails too
            if !(s >= 0.0 && s <= MAX_SEVERITY) {
                return None;
            }
            k += 1;
        }
        Some(Self { severity })
    }

    /// Sets `effect` to `severity` (0 switches it off).
    pub fn set(&mut self, effect: EffectId, severity: f32) -> Result<(), SeverityOutOfRange> {
        if !(0.0..=MAX_SEVERITY).contains(&severity) {
            return Err(SeverityOutOfRange { effect, severity });
        }
        if let Some(slot) = self.severity.get_mut(effect.index()) {
            *slot = severity;
        }
        Ok(())
    }

    /// These effects with `effect` at `severity`.
    pub fn with(mut self, effect: EffectId, severity: f32) -> Result<Self, SeverityOutOfRange> {
        self.set(effect, severity)?;
        Ok(self)
    }

    /// The same effects with `effect` switched off (always in range, so no error to handle).
    pub fn without(mut self, effect: EffectId) -> Self {
        if let Some(slot) = self.severity.get_mut(effect.index()) {
            *slot = 0.0;
        }
        self
    }

    /// Severity of `effect` (0 when off).
    pub fn get(&self, effect: EffectId) -> f32 {
        self.severity.get(effect.index()).copied().unwrap_or(0.0)
    }

    /// `true` when no effect is on.
    pub fn is_none(&self) -> bool {
        self.severity.iter().all(|&s| s == 0.0)
    }

    /// The effects that are on, with their severities, in catalogue order.
    pub fn active(&self) -> impl Iterator<Item = (EffectId, f32)> + '_ {
        EffectId::ALL.iter().copied().zip(self.severity).filter(|&(_, s)| s != 0.0)
    }
}

// ---- model configuration file ------------------------------------------------------------------

/// Keyword that opens an effect line of a model configuration file.
pub const MODEL_CONFIG_EFFECT_KEYWORD: &str = "effect";

/// What is wrong on one line of a model configuration file (see [`parse_model_config`]).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ModelConfigErrorKind {
    /// The line does not start with `effect`.
    UnknownKeyword,
    /// `effect` without an effect ID.
    MissingEffect,
    /// The ID is not one of the ten library effects.
    UnknownEffect,
    /// No severity after the ID.
    MissingSeverity,
    /// The severity is not a number.
    BadSeverity,
    /// The severity is outside `[0, MAX_SEVERITY]` (or NaN).
    SeverityOutOfRange(f32),
    /// The effect was already set on an earlier line (the line number).
    DuplicateEffect(usize),
    /// Something after the severity.
    TrailingField,
}

/// A model configuration file that cannot be used: where (1-based line, field) and what.
///
/// `found` borrows the offending text of the file (the field, or the whole line when a field is
/// missing), so the error needs no allocation.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ModelConfigError<'a> {
    /// Line of the file, 1-based.
    pub line: usize,
    /// The field: `keyword`, `effect` or `severity` (`end of line` for a trailing field).
    pub field: &'static str,
    /// What is wrong.
    pub kind: ModelConfigErrorKind,
    /// The offending text.
    pub found: &'a str,
}

impl core::fmt::Display for ModelConfigError<'_> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "line {}, field {}: ", self.line, self.field)?;
        match self.kind {
            ModelConfigErrorKind::UnknownKeyword => {
                write!(f, "'{}' is not a known keyword (expected 'effect ID SEVERITY')", self.found)
            }
            ModelConfigErrorKind::MissingEffect => write!(f, "missing effect ID in '{}'", self.found),
            ModelConfigErrorKind::UnknownEffect => {
                write!(f, "'{}' is not a library effect (one of:", self.found)?;
                for e in EffectId::ALL {
                    write!(f, " {}", e.id())?;
                }
                f.write_str(")")
            }
            ModelConfigErrorKind::MissingSeverity => write!(f, "missing severity in '{}'", self.found),
            ModelConfigErrorKind::BadSeverity => write!(f, "'{}' is not a number", self.found),
            ModelConfigErrorKind::SeverityOutOfRange(_) => {
                write!(f, "severity '{}' is outside [0, {MAX_SEVERITY}]", self.found)
            }
            ModelConfigErrorKind::DuplicateEffect(first) => {
                write!(f, "effect '{}' is already set on line {first}", self.found)
            }
            ModelConfigErrorKind::TrailingField => {
                write!(f, "unexpected '{}' after the severity", self.found)
            }
        }
    }
}

impl core::error::Error for ModelConfigError<'_> {}

/// Parses a model configuration file: the effect terms the monitor model runs with.
///
/// ```text
/// # ema-monitor model configuration (written by `ema discover`)
/// effect dead_time 0.48
/// effect viscous 0.30
/// ```
///
/// One `effect ID SEVERITY` per line, fields separated by spaces or tabs; `ID` is a library effect
/// ([`EffectId::id`]), `SEVERITY` a decimal number in `[0, MAX_SEVERITY]` (0 = off; 1 the documented maximum). `#` starts a comment up to
/// the end of the line; blank lines are skipped; an empty file (or comments only) is
/// [`ModelEffects::NONE`]. Refused, with the line and field: any other keyword, a missing or unknown
/// ID, a missing, non-numeric or out-of-range severity, a field after the severity, and an effect
/// set twice (an error, not "last wins": a file that contradicts itself is not guessed at).
pub fn parse_model_config(text: &str) -> Result<ModelEffects, ModelConfigError<'_>> {
    let mut effects = ModelEffects::NONE;
    let mut set_on = [0usize; EFFECT_COUNT];
    for (k, raw) in text.lines().enumerate() {
        let line = k + 1;
        let content = match raw.split_once('#') {
            Some((before, _)) => before,
            None => raw,
        }
        .trim();
        let mut fields = content.split_ascii_whitespace();
        let Some(keyword) = fields.next() else { continue };
        let err = |field, kind, found| ModelConfigError { line, field, kind, found };
        if keyword != MODEL_CONFIG_EFFECT_KEYWORD {
            return Err(err("keyword", ModelConfigErrorKind::UnknownKeyword, keyword));
        }
        let id = fields.next().ok_or(err("effect", ModelConfigErrorKind::MissingEffect, content))?;
        let effect = EffectId::from_id(id).ok_or(err("effect", ModelConfigErrorKind::UnknownEffect, id))?;
        let text = fields.next().ok_or(err("severity", ModelConfigErrorKind::MissingSeverity, content))?;
        let severity: f32 = text.parse().map_err(|_| err("severity", ModelConfigErrorKind::BadSeverity, text))?;
        if let Some(extra) = fields.next() {
            return Err(err("end of line", ModelConfigErrorKind::TrailingField, extra));
        }
        if effects.set(effect, severity).is_err() {
            return Err(err("severity", ModelConfigErrorKind::SeverityOutOfRange(severity), text));
        }
        if let Some(first) = set_on.get_mut(effect.index()) {
            if *first != 0 {
                return Err(err("effect", ModelConfigErrorKind::DuplicateEffect(*first), id));
            }
            *first = line;
        }
    }
    Ok(effects)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_round_trip_and_unknown_ids_are_refused() {
        for (k, e) in EffectId::ALL.iter().enumerate() {
            assert_eq!(e.index(), k);
            assert_eq!(EffectId::from_id(e.id()), Some(*e));
        }
        assert_eq!(EffectId::from_id("compliance"), None);
        assert_eq!(EffectId::from_id(""), None);
    }

    #[test]
    fn without_switches_one_effect_off() {
        let e = ModelEffects::NONE.with(EffectId::Viscous, 0.3).and_then(|e| e.with(EffectId::DeadTime, 0.5)).unwrap();
        let off = e.without(EffectId::Viscous);
        assert_eq!((off.get(EffectId::Viscous), off.get(EffectId::DeadTime)), (0.0, 0.5));
        assert_eq!(ModelEffects::NONE.without(EffectId::Cogging), ModelEffects::NONE);
    }

    #[test]
    fn severities_outside_the_unit_interval_are_refused() {
        let mut e = ModelEffects::NONE;
        assert!(e.is_none());
        assert!(e.set(EffectId::DeadTime, 1.5).is_err());
        assert!(e.set(EffectId::DeadTime, -0.1).is_err());
        assert!(e.set(EffectId::DeadTime, f32::NAN).is_err());
        assert!(e.is_none());
        e.set(EffectId::DeadTime, 0.5).unwrap();
        assert_eq!(e.get(EffectId::DeadTime), 0.5);
        assert_eq!(e.active().collect::<heapless::Vec<_, 10>>().as_slice(), &[(EffectId::DeadTime, 0.5)]);
    }

    #[test]
    fn from_severities_checks_the_range_in_const_context() {
        const E: Option<ModelEffects> =
            ModelEffects::from_severities([0.0, 0.0, 0.3, 0.0, 0.0, 0.48, 0.0, 0.0, 0.0, MAX_SEVERITY]);
        let e = E.unwrap();
        assert_eq!(e.get(EffectId::Viscous), 0.3);
        assert_eq!(e.get(EffectId::DeadTime), 0.48);
        assert_eq!(e.get(EffectId::HallMisalignment), MAX_SEVERITY);
        assert_eq!(ModelEffects::from_severities([0.0; EFFECT_COUNT]), Some(ModelEffects::NONE));
        let mut bad = [0.0; EFFECT_COUNT];
        for v in [-0.01, MAX_SEVERITY + 0.01, f32::NAN, f32::INFINITY] {
            bad[4] = v;
            assert_eq!(ModelEffects::from_severities(bad), None, "{v}");
        }
    }

    #[test]
    fn model_config_good_file_with_comments_and_blank_lines() {
        let text = "# ema-monitor model configuration (written by `ema discover`)\n\
                    \n\
                    effect dead_time 0.48\n\
                    \teffect   viscous\t0.30   # trailing comment\n\
                    effect cogging 0\r\n\
                    # effect saturation 0.9\n\
                    \x20\x20\n";
        let e = parse_model_config(text).unwrap();
        assert_eq!(e.get(EffectId::DeadTime), 0.48);
        assert_eq!(e.get(EffectId::Viscous), 0.30);
        assert_eq!(e.get(EffectId::Cogging), 0.0);
        assert_eq!(e.get(EffectId::Saturation), 0.0);
        let active: heapless::Vec<_, 10> = e.active().collect();
        assert_eq!(active.as_slice(), &[(EffectId::Viscous, 0.30), (EffectId::DeadTime, 0.48)]);
        // every ID is accepted, and nothing at all is the paper's model
        for id in EffectId::ALL {
            let mut line = heapless::String::<64>::new();
            core::fmt::write(&mut line, format_args!("effect {} 1", id.id())).unwrap();
            assert_eq!(parse_model_config(&line).unwrap().get(id), 1.0);
        }
        assert_eq!(parse_model_config(""), Ok(ModelEffects::NONE));
        assert_eq!(parse_model_config("# nothing\n\n"), Ok(ModelEffects::NONE));
    }

    fn error(text: &str) -> ModelConfigError<'_> {
        parse_model_config(text).unwrap_err()
    }

    #[test]
    fn model_config_errors_name_line_field_and_text() {
        use ModelConfigErrorKind as K;
        let e = error("# c\neffect compliance 0.5\n");
        assert_eq!((e.line, e.field, e.kind, e.found), (2, "effect", K::UnknownEffect, "compliance"));
        let e = error("effect dead_time 0,48");
        assert_eq!((e.line, e.field, e.kind, e.found), (1, "severity", K::BadSeverity, "0,48"));
        let e = error("\n\neffect viscous 1.5");
        assert_eq!((e.line, e.field, e.kind, e.found), (3, "severity", K::SeverityOutOfRange(1.5), "1.5"));
        assert_eq!(error("effect viscous -0.1").kind, K::SeverityOutOfRange(-0.1));
        assert_eq!(error("effect viscous NaN").field, "severity");
        assert_eq!(error("effect viscous inf").field, "severity");
        let e = error("effect viscous");
        assert_eq!((e.field, e.kind, e.found), ("severity", K::MissingSeverity, "effect viscous"));
        let e = error("effect");
        assert_eq!((e.field, e.kind), ("effect", K::MissingEffect));
        let e = error("effects viscous 0.3");
        assert_eq!((e.field, e.kind, e.found), ("keyword", K::UnknownKeyword, "effects"));
        let e = error("viscous = 0.3");
        assert_eq!((e.field, e.kind, e.found), ("keyword", K::UnknownKeyword, "viscous"));
        let e = error("effect viscous 0.3 0.4");
        assert_eq!((e.field, e.kind, e.found), ("end of line", K::TrailingField, "0.4"));
        // the ID is case-sensitive, as on the command line
        assert_eq!(error("effect Dead_Time 0.1").kind, K::UnknownEffect);
    }

    #[test]
    fn model_config_duplicate_effect_is_an_error_not_last_wins() {
        let e = error("effect dead_time 0.4\n# again\neffect dead_time 0.5\n");
        assert_eq!(
            (e.line, e.field, e.kind, e.found),
            (3, "effect", ModelConfigErrorKind::DuplicateEffect(1), "dead_time")
        );
        // also when the first one switched it off
        assert_eq!(error("effect cogging 0\neffect cogging 0.2").kind, ModelConfigErrorKind::DuplicateEffect(1));
    }

    #[test]
    fn model_config_messages_read_well() {
        let mut msg = heapless::String::<256>::new();
        core::fmt::write(&mut msg, format_args!("{}", error("\neffect viscous 2"))).unwrap();
        assert_eq!(msg.as_str(), "line 2, field severity: severity '2' is outside [0, 1.25]");
        msg.clear();
        core::fmt::write(&mut msg, format_args!("{}", error("effect friction 0.1"))).unwrap();
        assert!(
            msg.starts_with("line 1, field effect: 'friction' is not a library effect (one of: cogging stribeck"),
            "{msg}"
        );
        assert!(msg.ends_with("hall_misalignment)"), "{msg}");
    }
}
