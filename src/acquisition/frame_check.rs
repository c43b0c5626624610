//! [`FrameCheck`]: the checks of one frame (range and saturation, stuck channel, sum) with their
//! history, and the sensors' zero points measured on the frames before the trigger; the one
//! implementation behind the ADC readers and the recordings given in amperes (module doc of
//! `acquisition`).

use super::detect::{StuckDetector, SumDetector};
use super::self_calibration::RestEstimator;
use super::{
    AcquisitionConfig, AcquisitionError, Calibration, ConfigError, Phase, PhaseFrame, SensorCheck, ZeroSource,
};
use crate::trace::ADC_MAX;

/// The checks of one frame (range and saturation, stuck channel, sum; module doc), with their
/// history: the one implementation behind the ADC reader ([`FrameCheck::codes`]) and recordings
/// given in amperes ([`FrameCheck::amps`], `ema identify`'s CSV path).
#[derive(Clone, Copy, Debug)]
pub struct FrameCheck {
    calibration: Calibration,
    config: AcquisitionConfig,
    zero_codes: [u16; 3],
    stuck: StuckDetector,
    sum: SumDetector,
    /// The calibration declared for the sensors (the zero points' reference).
    declared: Calibration,
    rest: RestEstimator,
    sensors: SensorCheck,
}

impl FrameCheck {
    /// Checks of frames read through `calibration`, with the checked `config`.
    pub fn new(calibration: Calibration, config: AcquisitionConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        let zero_codes = Phase::ALL.map(|p| calibration.phase(p).zero_code());
        Ok(Self {
            calibration,
            config,
            zero_codes,
            stuck: StuckDetector::new(),
            sum: SumDetector::new(),
            declared: calibration,
            rest: RestEstimator::new(),
            sensors: SensorCheck::DECLARED,
        })
    }

    /// The calibration in use (the measured zero points once [`FrameCheck::start_recording`] has
    /// fixed them).
    pub const fn calibration(&self) -> &Calibration {
        &self.calibration
    }

    /// The check settings.
    pub const fn config(&self) -> &AcquisitionConfig {
        &self.config
    }

    /// Adds the codes of one frame before the trigger to the zero points' estimate.
    pub fn rest(&mut self, codes: [u16; 3]) {
        self.rest.add(codes);
    }

    /// As [`FrameCheck::rest`] for a frame given in amperes through the declared calibration
    /// (a recording's rows before its manoeuvre): each current mapped to the code the declared
    /// sensor would give, as [`FrameCheck::amps`] does; a non-finite current leaves the frame out.
    pub fn rest_amps(&mut self, currents_a: [f32; 3]) {
        if let Some(codes) = declared_codes(&self.declared, currents_a) {
            self.rest.add(codes);
        }
    }

    /// The manoeuvre starts: with self-calibration configured, the zero points are measured on
    /// the rest frames since [`FrameCheck::rearm`] (or refused, the declared ones kept); the
    /// stuck and sum history starts afresh. Without it, nothing changes. A trigger that turns
    /// out a glitch calls it again later, on the rest frames gathered meanwhile as well.
    pub fn start_recording(&mut self) {
        if let Some(config) = self.config.self_calibration {
            let (calibration, sensors) = self.rest.zero_points(&self.declared, &config);
            self.calibration = calibration;
            self.zero_codes = Phase::ALL.map(|p| calibration.phase(p).zero_code());
            self.sensors = sensors;
            self.reset();
        }
    }

    /// A new acquisition is armed: its zero points come from its own rest frames.
    pub fn rearm(&mut self) {
        self.rest = RestEstimator::new();
    }

    /// What the sensors' self-calibration found ([`SensorCheck::DECLARED`] before
    /// [`FrameCheck::start_recording`] or without self-calibration).
    pub const fn sensor_check(&self) -> SensorCheck {
        self.sensors
    }

    /// Forgets the stuck and sum history.
    pub fn reset(&mut self) {
        self.stuck = StuckDetector::new();
        self.sum = SumDetector::new();
    }

    /// Checks the ADC codes `[a, b, c]` of the next frame and converts them to amperes.
    pub fn codes(&mut self, codes: [u16; 3]) -> Result<PhaseFrame, AcquisitionError> {
        for phase in Phase::ALL {
            let code = codes[phase.index()];
            if code > ADC_MAX {
                return Err(AcquisitionError::OutOfRange { phase, code });
            }
        }
        let stuck = self.stuck.update(codes, self.zero_codes, &self.config);
        for phase in Phase::ALL {
            let code = codes[phase.index()];
            if code == 0 || code == ADC_MAX {
                return Err(AcquisitionError::Saturated { phase, code });
            }
        }
        let [a, b, c] = codes;
        let frame = PhaseFrame {
            ia_a: self.calibration.phase(Phase::A).to_amps(a),
            ib_a: self.calibration.phase(Phase::B).to_amps(b),
            ic_a: self.calibration.phase(Phase::C).to_amps(c),
            codes,
        };
        let sum_a = frame.ia_a + frame.ib_a + frame.ic_a;
        let peak_a = libm::fabsf(frame.ia_a).max(libm::fabsf(frame.ib_a)).max(libm::fabsf(frame.ic_a));
        let inconsistent = self.sum.update(sum_a, peak_a, &self.config);
        if let Some((phase, code)) = stuck {
            return Err(AcquisitionError::Stuck { phase, code });
        }
        if inconsistent {
            // |sum| ≤ 3·4095 A·gain < 12 300 A: the cast cannot saturate in practice (and `as` saturates)
            return Err(AcquisitionError::InconsistentSum { sum_ma: libm::roundf(sum_a * 1000.0) as i32 });
        }
        Ok(frame)
    }

    /// Checks a frame given in amperes `[ia, ib, ic]`: each current is mapped to the code the
    /// calibrated sensor would give (`code = round(i/gain + offset)`, clipped to `[0, ADC_MAX]`, so
    /// a current beyond the sensor's range reads as saturated, a NaN as out of range), then
    /// checked as [`FrameCheck::codes`] does. The returned frame keeps the given currents.
    ///
    /// The currents are taken as converted through the declared calibration; with measured zero
    /// points, each phase's returned current is the given one less its zero shift
    /// (`shift_counts·gain`, exactly the given current when the zero points are the declared ones).
    pub fn amps(&mut self, currents_a: [f32; 3]) -> Result<PhaseFrame, AcquisitionError> {
        for phase in Phase::ALL {
            if !currents_a[phase.index()].is_finite() {
                return Err(AcquisitionError::OutOfRange { phase, code: u16::MAX });
            }
        }
        let codes = declared_codes(&self.declared, currents_a).unwrap_or([u16::MAX; 3]);
        let frame = self.codes(codes)?;
        let corrected: [f32; 3] = core::array::from_fn(|j| match self.sensors.source {
            ZeroSource::Declared => currents_a[j],
            ZeroSource::Rest => {
                let gain = self.declared.phase(Phase::ALL[j]).gain_a_per_count().to_num::<f32>();
                currents_a[j] - self.sensors.zero_shift_counts[j] * gain
            }
        });
        Ok(PhaseFrame { ia_a: corrected[0], ib_a: corrected[1], ic_a: corrected[2], codes: frame.codes })
    }
}

/// The codes `calibration`'s sensors give for `currents_a` (`round(i/gain + offset)`, clipped to
/// `[0, ADC_MAX]`); `None` when a current is not finite.
fn declared_codes(calibration: &Calibration, currents_a: [f32; 3]) -> Option<[u16; 3]> {
    let mut codes = [0u16; 3];
    for phase in Phase::ALL {
        let cal = calibration.phase(phase);
        let gain = cal.gain_a_per_count().to_num::<f32>();
        let offset = cal.offset_counts().to_num::<f32>();
        let i = currents_a[phase.index()];
        if !i.is_finite() {
            return None;
        }
        let code = libm::roundf(i / gain + offset);
        codes[phase.index()] = code.clamp(0.0, f32::from(ADC_MAX)) as u16;
    }
    Some(codes)
}
