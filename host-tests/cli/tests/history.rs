//! `ema history`: a short degradation series whose remaining useful life is known, its outputs
//! against `docs/output-schema.md`, and its refusals.

mod common;
#[path = "common/schema.rs"]
mod schema;

use common::{contract_status, ema, refused, s, scratch};

/// Runs `ema` expecting success; returns stdout as JSON.
fn json(args: &[&str]) -> serde_json::Value {
    let out = ema(args);
    let expected = contract_status(args, &String::from_utf8_lossy(&out.stdout));
    assert_eq!(out.status.code(), Some(expected), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("JSON on stdout")
}

#[test]
fn six_flights_of_growing_friction_bracket_the_true_rul() {
    // friction 0.05 + 0.04 per flight: severity 0.5 (FAILING) at flight 12.25
    let dir = scratch("history", "friction");
    let out = dir.join("out");
    let args = ["history", "--simulate", "friction=0.05+0.04", "--flights", "6", "--json", "--out", s(&out)];
    let v = json(&args);
    let written: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("history.json")).expect("history.json")).expect("JSON");
    assert_eq!(v, written, "--json prints history.json");
    schema::check_json("`ema history --json` and `history.json`", &[&v]);
    let svg = std::fs::read_to_string(out.join("severity.svg")).expect("severity.svg");
    assert!(svg.contains("friction RUL band") && svg.contains("failing threshold"), "{svg}");

    let flights = v["flights"].as_array().expect("flights");
    assert_eq!(flights.len(), 6);
    // statuses follow the truth: healthy below 0.1 (flight 1), degraded from 0.13 (flight 3) on
    let status: Vec<&str> = flights.iter().map(|f| f["status"].as_str().unwrap()).collect();
    assert_eq!(status[0], "HEALTHY", "{status:?}");
    assert!(status[2..].iter().all(|s| *s == "DEGRADED"), "{status:?}");
    for f in flights {
        assert!(f["err_percent"].as_f64().unwrap() < 2.0, "{f}");
    }
    // the first flight cold, the later ones warm from the previous diagnosis, no probe firing on drift
    let start: Vec<&str> = flights.iter().map(|f| f["start"].as_str().unwrap()).collect();
    assert_eq!(start, ["cold", "warm", "warm", "warm", "warm", "warm"]);
    assert!(flights[1]["evaluations"].as_u64().unwrap() < 300, "{}", flights[1]);
    assert_eq!((&v["campaign"]["probe_false_alarms"], &v["campaign"]["probe_misses"]), (&0.into(), &0.into()));
    // no RUL before three diagnoses, one from the third on
    assert!(flights[1]["remaining_flights"][0].is_null() && flights[2]["remaining_flights"][0].is_number());

    let friction = &v["modes"][0];
    assert_eq!(friction["mode"], "friction");
    let truth = friction["true_crossing_flight"].as_f64().unwrap();
    assert!((truth - 12.25).abs() < 1e-4, "{friction}");
    let (lo, hi) = (friction["crossing_lower_flight"].as_f64().unwrap(), friction["crossing_upper_flight"].as_f64());
    let hi = hi.expect("a significant slope bounds the interval");
    assert!(lo <= truth && truth <= hi, "true crossing {truth} outside [{lo}, {hi}]");
    assert!(hi - lo < 3.0, "[{lo}, {hi}]");
    assert!((friction["slope_per_flight"].as_f64().unwrap() - 0.04).abs() < 0.005, "{friction}");
    assert_eq!((friction["onset_flight"].as_u64(), friction["detected_flight"].as_u64()), (Some(1), Some(1)));
    // the other modes: never reported, no crossing
    for m in v["modes"].as_array().unwrap().iter().skip(1) {
        assert_eq!(m["false_reports"], 0, "{m}");
        assert!(m["crossing_flight"].is_null() && m["true_crossing_flight"].is_null(), "{m}");
    }
    assert!(v["campaign"]["cold_mean_err_percent"].as_f64().unwrap() < 1.0, "{v}");
}

#[test]
fn recordings_of_successive_flights_match_the_schema() {
    let dir = scratch("history", "files");
    let mut files = Vec::new();
    for (n, friction) in ["0.1", "0.15", "0.2"].iter().enumerate() {
        let csv = dir.join(format!("flight{}.csv", n + 1));
        let faults = format!("{friction},0,0,0,0,0,0.5,0.5");
        let seed = (n + 1).to_string();
        let wrote = ema(&["simulate", "--faults", &faults, "--seed", &seed, "--out", s(&csv)]);
        assert!(wrote.status.success(), "{}", String::from_utf8_lossy(&wrote.stderr));
        files.push(csv);
    }
    let mut args = vec!["history", "--json"];
    args.extend(files.iter().map(|f| s(f)));
    let v = json(&args);
    schema::check_json("`ema history --json` and `history.json`", &[&v]);
    assert_eq!(v["flights"][2]["file"], s(&files[2]));
    assert!(v.get("campaign").is_none() && v["modes"][0].get("true_crossing_flight").is_none(), "{v}");
    // 0.1, 0.15, 0.2: rising 0.05 per flight, failing near flight 9
    let crossing = v["modes"][0]["crossing_flight"].as_f64().expect("a rising friction trend");
    assert!((7.0..=11.0).contains(&crossing), "{crossing}");
}

#[test]
fn refusals_name_the_flag() {
    refused(&["history"], &["required"]);
    refused(&["history", "--simulate", "wear=0.1"], &["--simulate", "unknown mode 'wear'"]);
    refused(&["history", "--simulate", "friction=0.1+2"], &["--simulate", "rate 2 is outside [0, 1]"]);
    refused(&["history", "a.csv", "--simulate", "friction=0.1"], &["cannot be used with"]);
}

/// The first flight at which `mode` is declared by pooled evidence or reported by the flight's own
/// diagnosis, and the flights declaring or reporting any mode, of a simulated series.
fn series_detection(law: &str, seed: u64, flights: u32, mode: &str) -> (Option<u64>, Vec<String>) {
    let (seed, flights) = (seed.to_string(), flights.to_string());
    let v = json(&["history", "--simulate", law, "--flights", &flights, "--seed", &seed, "--json", "--quiet"]);
    schema::check_json("`ema history --json` and `history.json`", &[&v]);
    let m = v["modes"].as_array().unwrap().iter().find(|m| m["mode"] == mode).expect("mode").clone();
    let first = [m["declared_flight"].as_u64(), m["detected_flight"].as_u64()].into_iter().flatten().min();
    let mut raised = Vec::new();
    for f in v["flights"].as_array().unwrap() {
        for d in f["declared"].as_array().unwrap() {
            raised.push(format!("flight {}: {d} declared", f["flight"]));
        }
    }
    for m in v["modes"].as_array().unwrap() {
        if m["false_reports"].as_u64().unwrap_or(0) > 0 && m["mode"] != "gain drift" {
            raised.push(format!("{} reported", m["mode"]));
        }
    }
    (first, raised)
}

#[test]
fn pooled_evidence_declares_a_low_eccentricity_and_keeps_healthy_series_healthy() {
    // eccentricity 0.08 at the minimum gap's 0°: below what one flight's model selection keeps
    // (detectable from about 0.11); the per-mode sums declare it within 5 flights in at least 3 of
    // 4 series (seeds 1–6 measured: declared at flights 1, 3, 4, 3, 2, 2), while 4 healthy series
    // of 5 flights declare nothing (the gain's own small reports, k8 ≈ 0.498, are the flight's
    // model selection, not the sums, and excluded here)
    let seeds = [1u64, 2, 3, 4];
    let found = seeds
        .iter()
        .filter(|&&seed| {
            let (first, raised) = series_detection("eccentricity=0.08", seed, 5, "eccentricity");
            assert!(raised.iter().all(|r| r.contains("eccentricity")), "seed {seed}: {raised:?}");
            first.is_some_and(|f| f <= 5)
        })
        .count();
    assert!(found >= 3, "eccentricity 0.08 declared in {found} of {} series", seeds.len());
    for seed in seeds {
        let (_, raised) = series_detection("friction=0", seed, 5, "friction");
        assert!(raised.is_empty(), "healthy series, seed {seed}: {raised:?}");
    }
}
