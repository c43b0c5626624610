//! Degradation laws (`--simulate MODE=START[+RATE][@ONSET]`): the true fault vector of each
//! simulated flight, and the flight at which a mode truly crosses a threshold.

use ema_monitor::faults::{FaultGroup, FaultMode, FaultParam, GROUP_COUNT};
use ema_monitor::FaultVector;

use crate::error::{num, CliError};

/// A degradation law of one mode (`MODE=START[+RATE][@ONSET]`).
#[derive(Clone, Debug, PartialEq)]
pub struct Law {
    /// The mode's name as given (`friction`, `short_a`, …: [`FaultParam::key`]).
    pub name: String,
    /// The fault parameter it drives.
    pub param: FaultParam,
    /// Severity at the onset flight.
    pub start: f32,
    /// Severity added per flight.
    pub rate: f32,
    /// First faulty flight.
    pub onset: u32,
}

/// The parameters a law can drive, each named by its [`FaultParam::key`]: the severity of each
/// fault group ([`FaultGroup::severity_param`]).
pub const LAW_PARAMS: [FaultParam; GROUP_COUNT] = {
    let mut out = [FaultParam::Friction; GROUP_COUNT];
    let mut g = 0;
    while g < GROUP_COUNT {
        out[g] = FaultGroup::ALL[g].severity_param();
        g += 1;
    }
    out
};

impl Law {
    /// Parses `MODE=START[+RATE][@ONSET]`.
    pub fn parse(text: &str) -> Result<Self, CliError> {
        let bad = |m: String| CliError::flag("--simulate", format!("'{text}': {m}"));
        let (name, rest) = text.split_once('=').ok_or_else(|| bad("not MODE=START[+RATE][@ONSET]".into()))?;
        let name = name.trim();
        let param = LAW_PARAMS.into_iter().find(|p| p.key() == name).ok_or_else(|| {
            let names: Vec<&str> = LAW_PARAMS.iter().map(|p| p.key()).collect();
            bad(format!("unknown mode '{name}' (expected one of {})", names.join(", ")))
        })?;
        let (rest, onset) = match rest.split_once('@') {
            Some((r, o)) => {
                let onset: u32 = o.trim().parse().map_err(|_| bad(format!("onset '{o}' is not a flight number")))?;
                if onset == 0 {
                    return Err(bad("flights count from 1".into()));
                }
                (r, onset)
            }
            None => (rest, 1),
        };
        let (start, rate) = match rest.split_once('+') {
            Some((s, r)) => (s, r),
            None => (rest, "0"),
        };
        let number = |s: &str, what: &str| -> Result<f32, CliError> {
            let v: f32 = s.trim().parse().map_err(|_| bad(format!("{what} '{s}' is not a number")))?;
            if (0.0..=1.0).contains(&v) {
                Ok(v)
            } else {
                Err(bad(format!("{what} {} is outside [0, 1]", num(v))))
            }
        };
        Ok(Self { name: name.to_owned(), param, start: number(start, "start")?, rate: number(rate, "rate")?, onset })
    }

    /// The law's severity at flight `flight` (continuous: the crossing search reads between
    /// flights).
    pub fn severity(&self, flight: f64) -> f64 {
        if flight < f64::from(self.onset) {
            0.0
        } else {
            (f64::from(self.start) + f64::from(self.rate) * (flight - f64::from(self.onset))).min(1.0)
        }
    }
}

/// The true fault vector of flight `flight` under `laws`.
pub fn truth_at(laws: &[Law], flight: u32) -> FaultVector {
    let mut k = FaultVector::HEALTHY;
    for law in laws {
        let s = law.severity(f64::from(flight)) as f32;
        let i = law.param.index();
        match law.param {
            FaultParam::GainDrift => k.0[i] = 0.5 + 0.5 * s,
            _ => k.0[i] = s,
        }
    }
    k
}

/// The first flight at which the laws of mode `mode` reach `threshold` (a law at `START` from
/// `ONSET` reaches it at `ONSET` when `START ≥ threshold`, else at `ONSET + (threshold − START)/RATE`
/// when it rises); `None` when they never do.
pub fn true_crossing(laws: &[Law], mode: FaultMode, threshold: f64) -> Option<f64> {
    laws.iter()
        .filter(|l| l.param.group().mode() == mode)
        .filter_map(|l| {
            let (start, rate, onset) = (f64::from(l.start), f64::from(l.rate), f64::from(l.onset));
            if start >= threshold {
                Some(onset)
            } else if rate > 0.0 && threshold <= 1.0 {
                Some(onset + (threshold - start) / rate)
            } else {
                None
            }
        })
        .min_by(f64::total_cmp)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn laws_parse_and_grow() {
        let l = Law::parse("friction=0.05+0.04").unwrap();
        assert_eq!((l.param, l.start, l.rate, l.onset), (FaultParam::Friction, 0.05, 0.04, 1));
        assert!((l.severity(3.0) - 0.13).abs() < 1e-6);
        let s = Law::parse("short_b=0.3@5").unwrap();
        assert_eq!((s.param, s.rate, s.onset), (FaultParam::ShortB, 0.0, 5));
        assert_eq!(s.severity(4.0), 0.0);
        assert!((s.severity(9.0) - 0.3).abs() < 1e-6);
        let k = truth_at(&[l.clone(), s.clone(), Law::parse("gain=0.2").unwrap()], 5);
        assert!((k.0[0] - 0.21).abs() < 1e-6 && (k.0[3] - 0.3).abs() < 1e-6 && (k.0[7] - 0.6).abs() < 1e-6);
        // friction reaches 0.5 at flight 1 + 0.45/0.04 = 12.25
        assert!((true_crossing(&[l], FaultMode::Friction, 0.5).unwrap() - 12.25).abs() < 1e-4);
        assert_eq!(true_crossing(&[s], FaultMode::ShortCircuit, 0.5), None);
        let keys = LAW_PARAMS.map(FaultParam::key);
        assert_eq!(keys, ["friction", "backlash", "short_a", "short_b", "short_c", "eccentricity", "gain"]);
        for bad in ["friction", "wear=0.1", "friction=1.5", "friction=0.1+x", "friction=0.1@0", "gain=0.1@x"] {
            assert!(Law::parse(bad).is_err(), "{bad}");
        }
    }
}
