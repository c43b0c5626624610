//! The actuator's temperature from one ADC channel: a sensor whose output voltage is linear in
//! temperature, `V = V₀ + S·T` (a silicon sensor such as the TMP36, or a PT1000 behind a linear
//! bridge amplifier), read once per flight through the same embedded-hal `OneShot` trait as the
//! phase currents.
//!
//! A reading outside the range the actuator's parameters declare (with [`PLAUSIBLE_MARGIN_C`] on
//! either side) is not used: an open input reads near 0 V, a short to the supply near full
//! scale, and both would give a winding resistance far from the unit's. The flight is then
//! diagnosed at the parameters' 20 °C, as one flown without a sensor ([`TemperatureReading`]).

use embedded_hal::adc::{Channel, OneShot};

use crate::params::EmaParams;
use crate::trace::ADC_MAX;

/// Degrees beyond the parameters' declared range that a reading may still be (the sensor's own
/// accuracy, ±2 °C for a TMP36, with a margin) before it is taken for a broken input: narrow
/// enough that an open TMP36 input (0 V, −50 °C) is refused below the usual −40 °C.
pub const PLAUSIBLE_MARGIN_C: f32 = 5.0;

/// A linear temperature sensor on an ADC channel of reference `reference_v` and full scale
/// [`ADC_MAX`].
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TemperatureSensor {
    /// Output at 0 °C (V).
    pub volts_at_0_c: f32,
    /// Slope (V/°C), non-zero.
    pub volts_per_c: f32,
    /// The ADC's reference voltage (V): [`ADC_MAX`] reads this.
    pub reference_v: f32,
}

impl TemperatureSensor {
    /// A TMP36-type sensor (0.5 V at 0 °C, 10 mV/°C) on a 3.3 V ADC.
    pub const TMP36_3V3: Self = Self { volts_at_0_c: 0.5, volts_per_c: 0.01, reference_v: 3.3 };

    /// The temperature (°C) of the 12-bit `code`; NaN when the sensor's slope is zero or a value
    /// is not finite.
    pub fn celsius(&self, code: u16) -> f32 {
        let volts = f32::from(code) * self.reference_v / f32::from(ADC_MAX);
        let t = (volts - self.volts_at_0_c) / self.volts_per_c;
        if t.is_finite() {
            t
        } else {
            f32::NAN
        }
    }

    /// One reading of `pin` through `adc`, judged against the range `params` declare
    /// ([`TemperatureReading`]). The conversion is polled at most `max_polls` times.
    pub fn read<A, M, P>(&self, adc: &mut M, pin: &mut P, params: &EmaParams, max_polls: u32) -> TemperatureReading
    where
        M: OneShot<A, u16, P>,
        P: Channel<A>,
    {
        for _ in 0..max_polls {
            match adc.read(pin) {
                Ok(code) if code > ADC_MAX => return TemperatureReading::Unavailable,
                Ok(code) => return self.judge(self.celsius(code), params),
                Err(nb::Error::WouldBlock) => {}
                Err(nb::Error::Other(_)) => return TemperatureReading::Unavailable,
            }
        }
        TemperatureReading::Unavailable
    }

    /// `celsius` judged against the range `params` declare.
    pub fn judge(&self, celsius: f32, params: &EmaParams) -> TemperatureReading {
        let low = params.temperature_min_c - PLAUSIBLE_MARGIN_C;
        let high = params.temperature_max_c + PLAUSIBLE_MARGIN_C;
        if (low..=high).contains(&celsius) {
            TemperatureReading::Celsius(celsius)
        } else {
            TemperatureReading::Implausible(celsius)
        }
    }
}

/// What one temperature reading gives.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TemperatureReading {
    /// A temperature within the declared range and its margin (°C).
    Celsius(f32),
    /// A temperature outside it (°C; NaN when not a number): a broken input, not used.
    Implausible(f32),
    /// The ADC failed, or did not convert in time.
    Unavailable,
}

impl TemperatureReading {
    /// The temperature the flight is diagnosed at: the reading when it is plausible, NaN (the
    /// parameters' 20 °C) otherwise.
    pub fn celsius_or_nan(&self) -> f32 {
        match self {
            TemperatureReading::Celsius(t) => *t,
            _ => f32::NAN,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A one-shot ADC that answers `WouldBlock` `busy` times, then `answer`.
    struct Adc {
        busy: u32,
        answer: Result<u16, ()>,
    }
    struct Pin;
    impl Channel<Adc> for Pin {
        type ID = u8;
        fn channel() -> u8 {
            8
        }
    }
    impl OneShot<Adc, u16, Pin> for Adc {
        type Error = ();
        fn read(&mut self, _pin: &mut Pin) -> nb::Result<u16, ()> {
            if self.busy > 0 {
                self.busy -= 1;
                return Err(nb::Error::WouldBlock);
            }
            self.answer.map_err(nb::Error::Other)
        }
    }

    fn code_of(celsius: f32) -> u16 {
        let s = TemperatureSensor::TMP36_3V3;
        libm::roundf((s.volts_at_0_c + s.volts_per_c * celsius) / s.reference_v * f32::from(ADC_MAX)) as u16
    }

    #[test]
    fn a_code_reads_as_its_temperature_within_one_step() {
        let s = TemperatureSensor::TMP36_3V3;
        let step_c = s.reference_v / f32::from(ADC_MAX) / s.volts_per_c;
        for t in [-40.0f32, -12.5, 0.0, 20.0, 55.0, 70.0] {
            assert!((s.celsius(code_of(t)) - t).abs() <= step_c, "{t}");
        }
    }

    #[test]
    fn a_broken_input_or_adc_is_no_temperature() {
        let s = TemperatureSensor::TMP36_3V3;
        let p = EmaParams::NOMINAL;
        let read = |busy, answer| s.read(&mut Adc { busy, answer }, &mut Pin, &p, 10);
        assert!(matches!(read(3, Ok(code_of(-30.0))), TemperatureReading::Celsius(t) if (t + 30.0).abs() < 0.1));
        // open input (0 V: −50 °C) and a short to the supply (280 °C)
        assert!(matches!(read(0, Ok(0)), TemperatureReading::Implausible(t) if t < -45.0));
        assert!(matches!(read(0, Ok(ADC_MAX)), TemperatureReading::Implausible(t) if t > 250.0));
        assert_eq!(read(0, Err(())), TemperatureReading::Unavailable);
        assert_eq!(read(20, Ok(code_of(20.0))), TemperatureReading::Unavailable, "never converted");
        assert_eq!(read(0, Ok(ADC_MAX + 1)), TemperatureReading::Unavailable);
        assert!(read(0, Ok(0)).celsius_or_nan().is_nan());
        assert!(read(0, Err(())).celsius_or_nan().is_nan());
        let flat = TemperatureSensor { volts_per_c: 0.0, ..s };
        assert!(flat.celsius(1000).is_nan());
        assert!(matches!(flat.judge(flat.celsius(1000), &p), TemperatureReading::Implausible(t) if t.is_nan()));
    }
}
