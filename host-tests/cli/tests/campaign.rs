//! `ema campaign`: plan determinism, CSV contents, the paper's table, charts, bad flags.

mod common;
use common::{refused, s as path_str, scratch};

use ema_cli::campaign::{
    self, bar_chart, identify_config, plan, run_all, runs_csv, summarize, CampaignArgs, AUDIT_SEED, PAPER_TABLE_II,
};
use ema_cli::identify::AlgorithmArg;
use ema_monitor::{FaultVector, Profile};
use ema_reference::{simulate, SimConfig};

fn args(runs: u32, modes: &[&str]) -> CampaignArgs {
    CampaignArgs {
        runs,
        algorithms: vec![AlgorithmArg::Pso],
        multi: 0,
        multi_low: 0,
        flights: 1,
        noise: ema_cli::simulate::Noise::On,
        max_iterations: 2,
        paper_only: false,
        fast_regime_weight: None,
        profile: "standard".to_string(),
        seed: 2018,
        audit: false,
        threads: Some(1),
        modes: modes.iter().map(|m| m.to_string()).collect(),
        json: false,
        output: Default::default(),
        progress: Default::default(),
        params: Default::default(),
    }
}

#[test]
fn the_paper_table_is_table_ii() {
    let total = |alg: &str, level: &str| {
        PAPER_TABLE_II
            .iter()
            .find(|r| r.algorithm == alg && r.level == level)
            .map(|r| r.total_err_percent)
            .expect("row")
    };
    assert_eq!(total("pso", "low"), 0.711);
    assert_eq!(total("pso", "high"), 1.761);
    assert_eq!(total("ga", "low"), 2.813);
    assert_eq!(total("ga", "high"), 3.144);
    // the paper's totals are the means of its five modes (to its 3 decimals)
    for r in PAPER_TABLE_II {
        let mean = r.err_percent.iter().sum::<f64>() / 5.0;
        assert!(
            (mean - r.total_err_percent).abs() < 2e-3,
            "{} {}: {mean} vs {}",
            r.algorithm,
            r.level,
            r.total_err_percent
        );
    }
}

#[test]
fn plans_follow_the_protocol_and_are_deterministic() {
    let a = args(3, &[]);
    let p = plan(&a).expect("valid");
    assert_eq!(p.len(), 5 * 2 * 3);
    for run in &p {
        let sev: Vec<f32> = match run.mode.as_str() {
            "friction" => vec![run.truth.0[0]],
            "backlash" => vec![run.truth.0[1]],
            "short" => run.truth.0[2..5].iter().copied().filter(|k| *k > 0.0).collect(),
            "eccentricity" => vec![run.truth.0[5]],
            _ => vec![2.0 * (run.truth.0[7] - 0.5).abs()],
        };
        assert_eq!(sev.len(), 1, "one faulty parameter: {run:?}");
        let (lo, hi) = if run.level == "low" { (0.05, 0.25) } else { (0.70, 0.95) };
        assert!(sev[0] >= lo - 1e-6 && sev[0] <= hi + 1e-6, "{run:?}");
    }
    let again = plan(&a).expect("valid");
    assert!(p.iter().zip(&again).all(|(x, y)| x.truth == y.truth && x.seed == y.seed));
    let other = plan(&CampaignArgs { seed: 7, ..a.clone() }).expect("valid");
    assert!(p.iter().zip(&other).any(|(x, y)| x.truth != y.truth));
    let multi = plan(&CampaignArgs { multi: 4, ..a }).expect("valid");
    for m in multi.iter().filter(|r| r.level == "multi") {
        let faulty = m.mode.split('+').count();
        assert!((2..=3).contains(&faulty), "{m:?}");
    }
}

/// `--multi-low` draws every fault mode at once at low severity; `--audit` draws other faults
/// than any `--seed` a test uses.
#[test]
fn small_simultaneous_faults_and_audit_draws() {
    let a = args(1, &["friction"]);
    let low = plan(&CampaignArgs { multi_low: 3, ..a.clone() }).expect("valid");
    let small: Vec<_> = low.iter().filter(|r| r.level == "multi-low").collect();
    assert_eq!(small.len(), 3);
    for r in small {
        let k = r.truth.0;
        let shorts: Vec<f32> = k[2..5].iter().copied().filter(|x| *x > 0.0).collect();
        let sev = [k[0], k[1], shorts[0], k[5], 2.0 * (k[7] - 0.5).abs()];
        assert_eq!(shorts.len(), 1, "{r:?}");
        assert!(sev.iter().all(|s| (0.05 - 1e-6..=0.15 + 1e-6).contains(s)), "{r:?}");
    }
    let audit = plan(&CampaignArgs { audit: true, ..a.clone() }).expect("valid");
    assert_eq!(ema_cli::campaign::master_seed(&CampaignArgs { audit: true, ..a.clone() }), AUDIT_SEED);
    for seed in [1, 2, 7, 2018, 2019] {
        let other = plan(&CampaignArgs { seed, ..a.clone() }).expect("valid");
        assert!(audit.iter().zip(&other).all(|(x, y)| x.truth != y.truth), "seed {seed}");
    }
}

#[test]
fn runs_csv_matches_the_results_and_does_not_depend_on_threads() {
    // the global search alone, so every run spends exactly its budget
    let a = CampaignArgs { paper_only: true, ..args(1, &["friction", "gain"]) };
    let plans = plan(&a).expect("valid");
    let one =
        run_all(&plans, &identify_config(&a), &ema_monitor::EmaParams::NOMINAL, &Profile::STANDARD, true, 1, false)
            .expect("runs");
    let two =
        run_all(&plans, &identify_config(&a), &ema_monitor::EmaParams::NOMINAL, &Profile::STANDARD, true, 2, false)
            .expect("runs");
    // every column but `identification_s` (column 22), which is wall time
    let strip = |csv: String| -> Vec<Vec<String>> {
        csv.lines()
            .map(|l| {
                let mut f: Vec<String> = l.split(',').map(str::to_string).collect();
                f.remove(22);
                f
            })
            .collect()
    };
    assert_eq!(strip(runs_csv(&one)), strip(runs_csv(&two)), "same runs, any thread count (seconds aside)");
    let csv = runs_csv(&one);
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    assert_eq!(header.len(), 5 + 16 + 4 + 8 + 2 + 2 + 1);
    assert_eq!(header[35..], ["bound_covers_truth", "bound_at_or_below_truth", "flights"]);
    assert_eq!(header[21..25], ["err_percent", "identification_s", "evaluations", "floor_err_percent"]);
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), plans.len());
    for row in rows {
        let f: Vec<&str> = row.split(',').collect();
        let k = |off: usize| -> [f32; 8] { std::array::from_fn(|i| f[off + i].parse().expect("number")) };
        let (truth, est) = (FaultVector(k(5)), FaultVector(k(13)));
        let err: f64 = f[21].parse().expect("number");
        assert!((f64::from(est.paper_error_percent(&truth)) - err).abs() < 1e-6, "{row}");
        assert_eq!(f[23], "100", "2 iterations × 50 particles");
        let floor: f64 = f[24].parse().expect("number");
        assert!(floor == 0.0, "high faults and low friction and gain are visible at the truth: {row}");
        let not_found: u32 = f[35].parse::<u32>().expect("count") + f[36].parse::<u32>().expect("count");
        assert!(not_found <= 1, "one faulted mode a run: {row}");
    }
    // model selection and the polish come on top of the global search's budget
    let refined = run_all(
        &plans,
        &identify_config(&CampaignArgs { paper_only: false, ..a.clone() }),
        &ema_monitor::EmaParams::NOMINAL,
        &Profile::STANDARD,
        true,
        2,
        false,
    )
    .expect("runs");
    assert!(
        refined.iter().all(|r| r.evaluations > 100),
        "{:?}",
        refined.iter().map(|r| r.evaluations).collect::<Vec<_>>()
    );
    let summary = summarize(&one);
    let svg = bar_chart("t", "Err (%)", &summary, |c| c.mean_err_percent).expect("draws");
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>") && svg.contains("<rect"));
    assert_eq!(svg.matches("<svg").count(), 1);
    // the legend names every series, the axis its unit
    for needle in ["pso low", "pso high", "Err (%)", "friction", "gain"] {
        assert!(svg.contains(needle), "{needle} missing from the chart");
    }
}

/// The floor drops exactly the faults too weak to pass model selection's criterion at the truth.
/// The reference model's noisy recording (seed 5) of `faults`, conditioned on the nominal actuator.
fn conditioned(
    faults: FaultVector,
) -> Box<ema_monitor::conditioning::ConditionedWindow<{ ema_cli::identify::HOST_WINDOW }>> {
    let rec = simulate(&SimConfig { faults, seed: 5, ..SimConfig::default() }).expect("sim");
    let recording = ema_cli::recording::Recording::from_reference(&rec, Vec::new());
    ema_cli::identify::condition_recording(
        &recording,
        std::path::Path::new("t"),
        &ema_monitor::EmaParams::NOMINAL,
        &Profile::STANDARD,
    )
    .expect("conditions")
}

#[test]
fn the_detectability_floor_drops_only_what_the_recording_cannot_show() {
    let truth = FaultVector([0.7, 0.0, 0.0, 0.0, 0.0, 0.02, 0.3, 0.5]);
    let trace = conditioned(truth);
    let config = identify_config(&args(1, &[]));
    // a high friction stays, a 0.02 eccentricity goes (its phase with it)
    let floor =
        campaign::detectability_floor(&trace, &ema_monitor::EmaParams::NOMINAL, &Profile::STANDARD, &config, &truth);
    assert_eq!(floor, FaultVector([0.7, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]));
    let strong = FaultVector([0.7, 0.0, 0.0, 0.0, 0.0, 0.8, 0.3, 0.5]);
    let trace = conditioned(strong);
    assert_eq!(
        campaign::detectability_floor(&trace, &ema_monitor::EmaParams::NOMINAL, &Profile::STANDARD, &config, &strong),
        strong
    );
}

#[test]
fn differential_evolution_runs_on_the_same_recordings_and_gets_its_own_rows() {
    let a = CampaignArgs { algorithms: vec![AlgorithmArg::Pso, AlgorithmArg::De], ..args(1, &["gain"]) };
    let plans = plan(&a).expect("valid");
    assert_eq!(plans.len(), 2 * 2);
    let (pso, de): (Vec<_>, Vec<_>) = plans.iter().partition(|p| p.algorithm == AlgorithmArg::Pso);
    // Same faults for every algorithm; the optimizer seed differs.
    for (p, d) in pso.iter().zip(&de) {
        assert_eq!((p.truth, &p.mode, p.level), (d.truth, &d.mode, d.level));
        assert_ne!(p.seed, d.seed);
    }
    let table = campaign::run(&a).expect("runs");
    let row = |alg: &str, level: &str| {
        table
            .lines()
            .find(|l| l.starts_with(&format!("| {alg} | {level} |")))
            .unwrap_or_else(|| panic!("no {alg} {level} row in\n{table}"))
            .to_string()
    };
    for level in ["low", "high"] {
        // The paper has no DE: its two columns are dashes; the PSO row keeps the paper's numbers.
        assert!(row("de", level).ends_with("| – | – |"), "{}", row("de", level));
        assert!(!row("pso", level).ends_with("| – | – |"), "{}", row("pso", level));
    }
    assert!(!table.contains("| ga |"), "{table}");
}

/// `--flights 2`: every run records its truth twice (the second flight's noise seeded apart),
/// identifies both recordings together, and the outputs say 2 flights.
#[test]
fn two_flights_are_pooled_and_the_summary_says_so() {
    let dir = scratch("campaign", "flights");
    let a = CampaignArgs {
        flights: 2,
        output: ema_cli::output::OutputArgs { out: Some(dir.clone()), force: true },
        ..args(1, &["gain"])
    };
    assert!(plan(&a).expect("valid").iter().all(|p| p.flights == 2));
    assert_eq!(campaign::flight_seed(7, 0), 7, "the first flight is the single-recording protocol");
    assert_ne!(campaign::flight_seed(7, 1), campaign::flight_seed(7, 2));
    let table = campaign::run(&a).expect("runs");
    assert!(table.contains("2 flights per run (pooled identification)"), "{table}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).expect("written")).expect("json");
    assert_eq!(json["flights"], 2, "{json}");
    let runs = std::fs::read_to_string(dir.join("runs.csv")).expect("written");
    let mut lines = runs.lines();
    assert!(lines.next().expect("header").ends_with(",flights"));
    for row in lines {
        assert!(row.ends_with(",2"), "{row}");
        let evaluations: u32 = row.split(',').nth(23).expect("evaluations").parse().expect("integer");
        assert!(evaluations > 0, "{row}");
    }
}

/// `--profile FILE`: every run flies that manoeuvre (its length) and is identified under it,
/// exactly as `ema simulate --profile` + `ema identify --profile` would do it (identification
/// refuses a recording whose command is not the profile's).
#[test]
fn a_profile_file_drives_every_run() {
    let dir = scratch("campaign", "profile");
    let file = dir.join("short.profile");
    std::fs::write(&file, "hold 0 0\nramp 0.01 0 0.3\nsine 0.2 0.057 0.02 6\nend 0.5\n").expect("writable");
    let profile = ema_cli::simulate::resolve_profile(path_str(&file)).expect("a valid profile");
    let a = CampaignArgs { paper_only: true, profile: path_str(&file).to_string(), ..args(1, &["friction"]) };
    let plans = plan(&a).expect("valid");
    let config = identify_config(&a);
    let flown = run_all(&plans, &config, &ema_monitor::EmaParams::NOMINAL, &profile, true, 1, false).expect("runs");
    for (p, r) in plans.iter().zip(&flown) {
        let rec = simulate(&SimConfig { faults: p.truth, seed: p.seed, profile, ..SimConfig::default() }).expect("sim");
        let samples = profile.duration_s() / ema_monitor::EmaParams::NOMINAL.control_period_s;
        assert!((rec.samples.len() as f32 - samples).abs() <= 1.0, "{} samples for {samples}", rec.samples.len());
        let recording = ema_cli::recording::Recording::from_reference(&rec, Vec::new());
        let by_hand = ema_cli::identify::identify_recording(
            &recording,
            std::path::Path::new("by hand"),
            &ema_monitor::EmaParams::NOMINAL,
            &profile,
            &ema_monitor::diagnosis::IdentifyConfig { seed: p.seed, ..config },
        )
        .expect("identifies");
        assert_eq!((r.estimate, r.evaluations), (by_hand.report.faults, by_hand.report.evaluations), "{}", p.mode);
    }
    let table = campaign::run(&a).expect("runs");
    assert!(table.contains(&format!("profile {}", path_str(&file))), "{table}");
}

#[test]
fn bad_flags_are_refused() {
    refused(
        &["campaign", "--profile", "no-such.profile", "--runs", "1", "--modes", "gain"],
        &["--profile", "no-such.profile"],
    );
    refused(&["campaign", "--runs", "0"], &["--runs"]);
    refused(&["campaign", "--algorithms", "sa"], &["sa"]);
    refused(&["campaign", "--modes", "bogus", "--runs", "1"], &["--modes", "bogus"]);
    refused(&["campaign", "--threads", "0", "--runs", "1", "--modes", "gain"], &["--threads"]);
}
