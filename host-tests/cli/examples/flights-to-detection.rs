//! Flights-to-detection of small faults, by the sequential test over flights and by the pooled
//! fit, and false detections on healthy series (`docs/identification.md`, "Evidence over flights"):
//!
//! ```text
//! cd host-tests && cargo run --release -p ema-cli --example flights-to-detection -- \
//!     [--seeds 4] [--flights 10] [--healthy 20] [--healthy-flights 10] [--pool 3,10]
//!     [--pool-cases 0,1,…] [--pool-seeds 2] [--verbose]
//! ```
//!
//! Each series is one actuator flown `--flights` times (reference model, standard manoeuvre, sensor
//! noise with a new seed every flight), identified with the on-board settings; a series stops at
//! its detection. Each series is reported on stderr as it ends. Prints a Markdown
//! table: per case, the flights whose own diagnosis holds the fault, the series the sequential
//! test finds it in and after how many flights, and the pooled fits over the first N flights.

use std::process::ExitCode;

use ema_cli::flights::{flight_seed, flight_trace, fly, pooled};
use ema_monitor::conditioning::ConditionedWindow;
use ema_monitor::diagnosis::evidence::{mode_present, Decision, Evidence};
use ema_monitor::faults::FaultMode;
use ema_monitor::FaultVector;
use rayon::prelude::*;

/// A case: its label, the true faults, and the mode whose detection is counted (`None`: healthy).
fn cases() -> Vec<(&'static str, FaultVector, Option<FaultMode>)> {
    let k = |i: usize, v: f32, phase: f32| {
        let mut x = FaultVector::HEALTHY;
        x.0[i] = v;
        if i == 5 {
            x.0[6] = phase;
        }
        x
    };
    vec![
        ("eccentricity 0.06, phase 0.2", k(5, 0.06, 0.2), Some(FaultMode::Eccentricity)),
        ("eccentricity 0.06, phase 0.7", k(5, 0.06, 0.7), Some(FaultMode::Eccentricity)),
        ("eccentricity 0.10, phase 0.35", k(5, 0.10, 0.35), Some(FaultMode::Eccentricity)),
        ("eccentricity 0.10, phase 0.85", k(5, 0.10, 0.85), Some(FaultMode::Eccentricity)),
        ("eccentricity 0.15, phase 0.5", k(5, 0.15, 0.5), Some(FaultMode::Eccentricity)),
        ("short B 2 % (k4 0.04)", k(3, 0.04, 0.0), Some(FaultMode::ShortCircuit)),
        ("short B 5 % (k4 0.10)", k(3, 0.10, 0.0), Some(FaultMode::ShortCircuit)),
        ("gain drift -3 % (k8 0.47)", k(7, 0.47, 0.0), Some(FaultMode::GainDrift)),
        ("friction +6 % (k1 0.03)", k(0, 0.03, 0.0), Some(FaultMode::Friction)),
    ]
}

struct Options {
    seeds: u64,
    flights: usize,
    healthy: u64,
    healthy_flights: usize,
    pool_cases: Vec<usize>,
    pool: Vec<usize>,
    pool_seeds: u64,
    verbose: bool,
}

fn parse() -> Result<Options, String> {
    let mut o = Options {
        seeds: 4,
        flights: 10,
        healthy: 20,
        healthy_flights: 10,
        pool_cases: (0..cases().len()).collect(),
        pool: vec![3, 10],
        pool_seeds: 2,
        verbose: false,
    };
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut value = || args.next().ok_or(format!("{a} needs a value"));
        match a.as_str() {
            "--seeds" => o.seeds = value()?.parse().map_err(|e| format!("--seeds: {e}"))?,
            "--flights" => o.flights = value()?.parse().map_err(|e| format!("--flights: {e}"))?,
            "--healthy" => o.healthy = value()?.parse().map_err(|e| format!("--healthy: {e}"))?,
            "--healthy-flights" => {
                o.healthy_flights = value()?.parse().map_err(|e| format!("--healthy-flights: {e}"))?
            }
            "--pool-cases" => {
                o.pool_cases = value()?
                    .split(',')
                    .map(|n| n.parse().map_err(|e| format!("--pool-cases: {e}")))
                    .collect::<Result<_, _>>()?
            }
            "--pool-seeds" => o.pool_seeds = value()?.parse().map_err(|e| format!("--pool-seeds: {e}"))?,
            "--pool" => {
                let v = value()?;
                o.pool = if v.is_empty() {
                    Vec::new()
                } else {
                    v.split(',').map(|n| n.parse().map_err(|e| format!("--pool: {e}"))).collect::<Result<_, _>>()?
                }
            }
            "--verbose" => o.verbose = true,
            _ => return Err(format!("unexpected argument '{a}'")),
        }
    }
    Ok(o)
}

/// One series: flights to detection by the sequential test (`None`: not within the flights),
/// flights whose own diagnosis holds the mode, any false mode found, and the pooled results.
struct Series {
    detected_at: Option<usize>,
    single_hits: usize,
    flown: usize,
    false_modes: Vec<(FaultMode, usize)>,
    pooled: Vec<(usize, bool, bool)>,
    lines: Vec<String>,
}

fn series(truth: &FaultVector, mode: Option<FaultMode>, key: u64, flights: usize, o: &Options, pool: bool) -> Series {
    let mut traces: Vec<Box<ConditionedWindow<8192>>> = Vec::new();
    let trace = |traces: &mut Vec<Box<ConditionedWindow<8192>>>, f: usize| {
        while traces.len() <= f {
            traces.push(flight_trace(truth, flight_seed(key, traces.len())).expect("simulation"));
        }
    };
    let mut evidence = Evidence::NONE;
    let mut s = Series {
        detected_at: None,
        single_hits: 0,
        flown: 0,
        false_modes: Vec::new(),
        pooled: Vec::new(),
        lines: Vec::new(),
    };
    for f in 0..flights {
        trace(&mut traces, f);
        let r = fly(&traces[f], flight_seed(key, f) ^ 0x55, &mut evidence).expect("identification");
        s.flown += 1;
        if let Some(m) = mode {
            s.single_hits += usize::from(r.single[m.index()]);
        }
        for m in FaultMode::ALL {
            if r.decisions[m.index()] == Decision::Present && Some(m) != mode && !s.false_modes.iter().any(|x| x.0 == m)
            {
                s.false_modes.push((m, f + 1));
            }
        }
        if o.verbose {
            let l = r.evidence.map_or([f32::NAN; 5], |e| e.llr);
            let n = r.evidence.map_or(f32::NAN, |e| e.effective_samples);
            s.lines.push(format!(
                "  flight {:2}: {} n {n:6.0} λ {:?} S {:?} {:?}",
                f + 1,
                r.report.status.label(),
                l.map(|x| (x * 100.0).round() / 100.0),
                r.accumulated.llr.map(|x| (x * 100.0).round() / 100.0),
                r.decisions.map(Decision::label)
            ));
        }
        if let Some(m) = mode {
            if r.decisions[m.index()] == Decision::Present {
                s.detected_at = Some(f + 1);
                break; // flights-to-detection: the series stops at its detection
            }
        }
    }
    if pool {
        for &n in &o.pool {
            trace(&mut traces, n - 1);
            let refs: Vec<&ConditionedWindow<8192>> = traces.iter().take(n).map(|t| &**t).collect();
            let report = pooled(&refs, key ^ 0x77).expect("pooled identification");
            let hit = mode.is_some_and(|m| mode_present(&report.faults, m));
            let false_hit = FaultMode::ALL.into_iter().any(|m| Some(m) != mode && mode_present(&report.faults, m));
            if o.verbose {
                s.lines.push(format!("  pooled {n}: {:?} {}", report.faults.0, report.status.label()));
            }
            s.pooled.push((n, hit, false_hit));
        }
    }
    let label = mode.map_or("healthy", FaultMode::name);
    eprintln!(
        "done: {label} key {key}: detected at {:?}, own diagnosis {}/{}, false {:?}, pooled {:?}",
        s.detected_at, s.single_hits, s.flown, s.false_modes, s.pooled
    );
    s.lines.iter().for_each(|l| eprintln!("{l}"));
    s
}

fn main() -> ExitCode {
    let o = match parse() {
        Ok(o) => o,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let mut jobs: Vec<(usize, u64)> = Vec::new();
    let all = cases();
    for c in 0..all.len() {
        for seed in 0..o.seeds {
            jobs.push((c, seed));
        }
    }
    let healthy_jobs: Vec<u64> = (0..o.healthy).collect();
    let results: Vec<((usize, u64), Series)> = jobs
        .par_iter()
        .map(|&(c, seed)| {
            let (_, truth, mode) = &all[c];
            let pool = seed < o.pool_seeds && o.pool_cases.contains(&c);
            ((c, seed), series(truth, *mode, 1000 * c as u64 + seed, o.flights, &o, pool))
        })
        .collect();
    let healthy: Vec<(u64, Series)> = healthy_jobs
        .par_iter()
        .map(|&seed| {
            (seed, series(&FaultVector::HEALTHY, None, 900_000 + seed, o.healthy_flights, &o, seed < o.pool_seeds))
        })
        .collect();
    println!(
        "| case | flights whose own diagnosis has it | series detected by the sequential test (flights to detection) | false modes | {} |",
        o.pool.iter().map(|n| format!("pooled fit, N = {n}")).collect::<Vec<_>>().join(" | ")
    );
    println!("|---|---|---|---|{}", "---|".repeat(o.pool.len()));
    for (c, (label, _, _)) in all.iter().enumerate() {
        let rs: Vec<&Series> = results.iter().filter(|((cc, _), _)| *cc == c).map(|(_, s)| s).collect();
        let single: usize = rs.iter().map(|s| s.single_hits).sum();
        let detected: Vec<usize> = rs.iter().filter_map(|s| s.detected_at).collect();
        let falses: usize = rs.iter().filter(|s| !s.false_modes.is_empty()).count();
        let pooled: Vec<String> = o
            .pool
            .iter()
            .map(|&n| {
                let hits: Vec<bool> =
                    rs.iter().flat_map(|s| s.pooled.iter().filter(|p| p.0 == n).map(|p| p.1)).collect();
                format!("{}/{}", hits.iter().filter(|h| **h).count(), hits.len())
            })
            .collect();
        println!(
            "| {label} | {single}/{} | {}/{} ({:?}) | {falses} | {} |",
            rs.iter().map(|s| s.flown).sum::<usize>(),
            detected.len(),
            rs.len(),
            detected,
            pooled.join(" | ")
        );
    }
    let false_series = healthy.iter().filter(|(_, s)| !s.false_modes.is_empty()).count();
    let pooled_false: Vec<String> = o
        .pool
        .iter()
        .map(|&n| {
            let f: Vec<bool> =
                healthy.iter().flat_map(|(_, s)| s.pooled.iter().filter(|p| p.0 == n).map(|p| p.2)).collect();
            format!("{}/{} false", f.iter().filter(|h| **h).count(), f.len())
        })
        .collect();
    let which: Vec<String> = healthy
        .iter()
        .flat_map(|(seed, s)| {
            s.false_modes.iter().map(move |(m, f)| format!("series {seed}: {} at flight {f}", m.name()))
        })
        .collect();
    println!(
        "| healthy ({} series) | – | {false_series}/{} series with a false detection {which:?} | – | {} |",
        healthy.len(),
        healthy.len(),
        pooled_false.join(" | ")
    );
    ExitCode::SUCCESS
}
