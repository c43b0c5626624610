//! The planned runs of a campaign and their seeded draws: the fault of each run, the seed of its
//! sensor noise and optimizer, and the noise seed of each of its flights.

use ema_monitor::faults::{FaultMode, FaultParam, MODE_COUNT};
use ema_monitor::optimizer::rng::splitmix64;
use ema_monitor::FaultVector;

use super::args::{master_seed, CampaignArgs};
use crate::error::CliError;
use crate::identify::args::AlgorithmArg;

/// The five fault modes' keys ([`FaultMode::key`]), in the paper's order.
pub const MODES: [&str; MODE_COUNT] = {
    let mut out = [""; MODE_COUNT];
    let mut m = 0;
    while m < MODE_COUNT {
        out[m] = FaultMode::ALL[m].key();
        m += 1;
    }
    out
};

/// One planned run.
#[derive(Clone, Debug)]
pub struct Plan {
    /// Algorithm.
    pub algorithm: AlgorithmArg,
    /// Fault mode name (`MODES`) or `multi`.
    pub mode: String,
    /// `low`, `high` or `multi`.
    pub level: &'static str,
    /// Run index within its cell.
    pub run: u32,
    /// Seed of the reference model's noise and of the optimizer.
    pub seed: u64,
    /// The injected fault vector.
    pub truth: FaultVector,
    /// Recordings of the truth identified together (`--flights`).
    pub flights: u32,
}

/// SplitMix64 (Steele, Lea, Flood, OOPSLA 2014), the core's ([`splitmix64`]), as a stream: the
/// campaign's seeded generator (one stream per run key), also the tests' generator of fault
/// vectors. The field is the generator's state.
pub struct SplitMix(pub u64);

impl SplitMix {
    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        splitmix64(&mut self.0)
    }
    /// Uniform in `[0, 1)` from the top 24 bits.
    pub fn unit(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.unit()
    }
}

/// Sets mode `mode` to `severity` in `k` (drawing the phase/direction it needs from `rng`).
fn inject(k: &mut FaultVector, mode: FaultMode, severity: f32, rng: &mut SplitMix) {
    match mode {
        FaultMode::Friction => k.0[FaultParam::Friction.index()] = severity,
        FaultMode::Backlash => k.0[FaultParam::Backlash.index()] = severity,
        FaultMode::ShortCircuit => k.0[FaultParam::ShortA.index() + (rng.next_u64() % 3) as usize] = severity,
        FaultMode::Eccentricity => {
            k.0[FaultParam::Eccentricity.index()] = severity;
            k.0[FaultParam::EccentricityPhase.index()] = rng.unit();
        }
        FaultMode::GainDrift => {
            k.0[FaultParam::GainDrift.index()] =
                if rng.next_u64().is_multiple_of(2) { 0.5 - 0.5 * severity } else { 0.5 + 0.5 * severity }
        }
    }
}

/// The planned runs of a campaign, in a fixed order.
pub fn plan(args: &CampaignArgs) -> Result<Vec<Plan>, CliError> {
    let master = master_seed(args);
    let modes: Vec<usize> = if args.modes.is_empty() {
        (0..MODES.len()).collect()
    } else {
        args.modes
            .iter()
            .map(|m| {
                MODES.iter().position(|x| x == m).ok_or_else(|| {
                    CliError::flag("--modes", format!("unknown mode '{m}' (expected one of {})", MODES.join(", ")))
                })
            })
            .collect::<Result<_, _>>()?
    };
    let mut out = Vec::new();
    for &algorithm in &args.algorithms {
        let alg_key = match algorithm {
            AlgorithmArg::Pso => 1u64,
            AlgorithmArg::Ga => 2,
            AlgorithmArg::De => 3,
        };
        for &mode in &modes {
            for (level_key, level, lo, hi) in [(1u64, "low", 0.05f32, 0.25f32), (2, "high", 0.70, 0.95)] {
                for run in 0..args.runs {
                    // The fault depends on (mode, level, run) only, so every algorithm sees the
                    // same faults; the seed of the noise and of the optimizer adds the algorithm.
                    let key = (mode as u64 + 1) << 40 | level_key << 32 | u64::from(run);
                    let mut rng = SplitMix(master ^ key.wrapping_mul(0xD1B5_4A32_D192_ED03));
                    let mut truth = FaultVector::HEALTHY;
                    let severity = rng.range(lo, hi);
                    inject(&mut truth, FaultMode::ALL[mode], severity, &mut rng);
                    let seed = rng.next_u64() ^ alg_key;
                    out.push(Plan {
                        algorithm,
                        mode: MODES[mode].to_string(),
                        level,
                        run,
                        seed,
                        truth,
                        flights: args.flights,
                    });
                }
            }
        }
        for run in 0..args.multi {
            let key = 7u64 << 40 | u64::from(run);
            let mut rng = SplitMix(master ^ key.wrapping_mul(0xD1B5_4A32_D192_ED03));
            let count = 2 + (rng.next_u64() % 2) as usize;
            let mut chosen: Vec<usize> = Vec::new();
            while chosen.len() < count {
                let m = (rng.next_u64() % MODES.len() as u64) as usize;
                if !chosen.contains(&m) {
                    chosen.push(m);
                }
            }
            chosen.sort_unstable();
            let mut truth = FaultVector::HEALTHY;
            for &m in &chosen {
                let severity = rng.range(0.05, 0.95);
                inject(&mut truth, FaultMode::ALL[m], severity, &mut rng);
            }
            let names: Vec<&str> = chosen.iter().map(|&m| MODES[m]).collect();
            let seed = rng.next_u64() ^ alg_key;
            out.push(Plan {
                algorithm,
                mode: names.join("+"),
                level: "multi",
                run,
                seed,
                truth,
                flights: args.flights,
            });
        }
        for run in 0..args.multi_low {
            let key = 8u64 << 40 | u64::from(run);
            let mut rng = SplitMix(master ^ key.wrapping_mul(0xD1B5_4A32_D192_ED03));
            let mut truth = FaultVector::HEALTHY;
            for m in 0..MODES.len() {
                let severity = rng.range(0.05, 0.15);
                inject(&mut truth, FaultMode::ALL[m], severity, &mut rng);
            }
            let seed = rng.next_u64() ^ alg_key;
            out.push(Plan {
                algorithm,
                mode: "all-low".to_string(),
                level: "multi-low",
                run,
                seed,
                truth,
                flights: args.flights,
            });
        }
    }
    Ok(out)
}

/// Seed of the sensor noise of flight `flight` of a run seeded `seed`: `seed` itself for the
/// first flight (so one flight is the single-recording protocol), an independent SplitMix64
/// draw for the others.
pub fn flight_seed(seed: u64, flight: u32) -> u64 {
    if flight == 0 {
        seed
    } else {
        SplitMix(seed ^ u64::from(flight).wrapping_mul(0x9FB2_1C65_1E98_DF25)).next_u64()
    }
}
