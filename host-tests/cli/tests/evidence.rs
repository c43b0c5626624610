//! The sequential test over flights (`ema_monitor::diagnosis::evidence`) on reference-model series
//! with sensor noise: a small eccentricity, below model selection's price in most single flights,
//! is found within a few flights in most series, and healthy series raise nothing. Pass rates over
//! seeds are asserted, not one seed's value.

use ema_cli::flights::{flight_seed, flight_trace, fly};
use ema_monitor::diagnosis::evidence::{Decision, Evidence};
use ema_monitor::faults::FaultMode;
use ema_monitor::FaultVector;
use rayon::prelude::*;

/// Flights until the sequential test declares `mode` present (`None`: not within `flights`),
/// and whether it declared another mode on the way.
fn series(truth: &FaultVector, mode: Option<FaultMode>, key: u64, flights: usize) -> (Option<usize>, bool) {
    let mut evidence = Evidence::NONE;
    let mut other = false;
    for f in 0..flights {
        let trace = flight_trace(truth, flight_seed(key, f)).expect("simulation");
        let r = fly(&trace, flight_seed(key, f) ^ 0x55, &mut evidence).expect("identification");
        other |= FaultMode::ALL.into_iter().any(|m| Some(m) != mode && r.decisions[m.index()] == Decision::Present);
        if mode.is_some_and(|m| r.decisions[m.index()] == Decision::Present) {
            return (Some(f + 1), other);
        }
    }
    (None, other)
}

#[test]
fn a_small_eccentricity_is_found_within_six_flights_and_healthy_series_stay_quiet() {
    let mut truth = FaultVector::HEALTHY;
    (truth.0[5], truth.0[6]) = (0.12, 0.35);
    let seeds: Vec<u64> = (0..5).collect();
    let found: Vec<(Option<usize>, bool)> =
        seeds.par_iter().map(|&s| series(&truth, Some(FaultMode::Eccentricity), 7000 + s, 6)).collect();
    let detected = found.iter().filter(|(at, _)| at.is_some()).count();
    assert!(detected * 5 >= seeds.len() * 4, "found in {detected} of {} series: {found:?}", seeds.len());
    assert!(found.iter().all(|(_, other)| !other), "another mode declared: {found:?}");
    let healthy: Vec<(Option<usize>, bool)> =
        (0..3u64).collect::<Vec<_>>().par_iter().map(|&s| series(&FaultVector::HEALTHY, None, 8000 + s, 4)).collect();
    assert!(healthy.iter().all(|(_, other)| !other), "a healthy series raised a fault: {healthy:?}");
}
