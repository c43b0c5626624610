//! `ema commission`: units drawn from the tolerance table (`ema simulate --unit`), commissioned on
//! three healthy flights at three temperatures, then diagnosed on a fourth healthy flight and on
//! faulty ones against their own parameters; a unit with a fault at commissioning gets no
//! baseline; and without commissioning, a unit off nominal never reads DEGRADED or FAILING.

mod common;

use std::path::{Path, PathBuf};

use common::{accepted, ema, refused, s, scratch};

/// `ema simulate --unit UNIT --seed SEED --temperature T [--faults K] --out DIR/NAME`.
fn flight(dir: &Path, name: &str, unit: &str, seed: &str, temperature: &str, faults: Option<&str>) -> PathBuf {
    let out = dir.join(name);
    let mut args = vec!["simulate", "--unit", unit, "--seed", seed, "--temperature", temperature, "--out", s(&out)];
    if let Some(k) = faults {
        args.extend(["--faults", k]);
    }
    accepted(&args);
    out
}

/// `ema identify ARGS --json`: the status and the fault vector (reported or withheld).
fn identify(args: &[&str]) -> (String, Vec<f64>) {
    let mut all = vec!["identify", "--json", "--quiet", "--max-iterations", "60"];
    all.extend(args);
    let v: serde_json::Value = serde_json::from_str(accepted(&all).trim()).expect("JSON");
    let k = v.get("k").or_else(|| v.get("k_not_a_diagnosis")).expect("a vector");
    let k = k.as_array().expect("array").iter().map(|x| x.as_f64().expect("number")).collect();
    (v["status"].as_str().expect("status").to_owned(), k)
}

#[test]
fn commissioned_units_read_healthy_and_their_faults_are_found() {
    let dir = scratch("commission", "units");
    for (unit, short) in [("11", "0,0,0,0.3,0,0,0.5,0.5"), ("23", "0,0,0.3,0,0,0,0.5,0.5")] {
        let healthy: Vec<PathBuf> = ["5", "20", "35"]
            .iter()
            .enumerate()
            .map(|(r, t)| flight(&dir, &format!("u{unit}-{r}.csv"), unit, &format!("{}", r + 1), t, None))
            .collect();
        let out = dir.join(format!("u{unit}.toml"));
        let mut args = vec!["commission", "--quiet", "--out", s(&out)];
        args.extend(healthy.iter().map(|p| s(p)));
        let printed = accepted(&args);
        assert!(printed.contains("phase_emf_constant_v_s_per_rad") && printed.contains("wrote"), "{printed}");
        let posterior = dir.join(format!("u{unit}.tolerances.toml"));
        assert!(posterior.exists());
        let own = ["--params", s(&out), "--tolerances", s(&posterior)];
        let fourth = flight(&dir, &format!("u{unit}-4.csv"), unit, "9", "20", None);
        let (status, _) = identify(&[&own[..], &[s(&fourth)]].concat());
        assert_eq!(status, "HEALTHY", "unit {unit}, fourth flight against its own parameters");
        // a cold flight, its temperature in the recording
        let cold = flight(&dir, &format!("u{unit}-cold.csv"), unit, "10", "-40", None);
        let (status, _) = identify(&[&own[..], &[s(&cold)]].concat());
        assert_eq!(status, "HEALTHY", "unit {unit} at -40 °C");
        // the same rows without the column: the temperature estimated as a nuisance parameter
        let text = std::fs::read_to_string(&cold).expect("reads");
        let stripped: String = text.lines().map(|l| format!("{}\n", &l[..l.rfind(',').expect("a comma")])).collect();
        let bare = dir.join(format!("u{unit}-cold-bare.csv"));
        std::fs::write(&bare, stripped).expect("writes");
        let v: serde_json::Value = serde_json::from_str(
            accepted(
                &[&["identify", "--json", "--quiet", "--estimate-temperature"][..], &own[..], &[s(&bare)]].concat(),
            )
            .trim(),
        )
        .expect("JSON");
        let t = v["temperature_c"].as_f64().expect("an estimated temperature");
        assert!(v["status"] == "HEALTHY" && (t + 40.0).abs() < 5.0, "unit {unit} without its column: {t} °C, {v}");
        // a short circuit and a friction fault at 0.3
        for (name, k) in [("short", short), ("friction", "0.3,0,0,0,0,0,0.5,0.5")] {
            let faulty = flight(&dir, &format!("u{unit}-{name}.csv"), unit, "12", "20", Some(k));
            let (status, found) = identify(&[&own[..], &[s(&faulty)]].concat());
            let truth: Vec<f64> = k.split(',').map(|x| x.parse().expect("number")).collect();
            let miss = found.iter().zip(&truth).take(6).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
            assert!(status == "DEGRADED" && miss < 0.03, "unit {unit}, {name}: {status} {found:?}");
        }
    }
}

#[test]
fn a_unit_with_a_fault_at_commissioning_gets_no_baseline() {
    let dir = scratch("commission", "faulty");
    for (name, k) in [("friction", "0.3,0,0,0,0,0,0.5,0.5"), ("short", "0,0,0,0,0.3,0,0.5,0.5")] {
        let recordings: Vec<PathBuf> =
            (1..=3).map(|r| flight(&dir, &format!("{name}-{r}.csv"), "31", &r.to_string(), "20", Some(k))).collect();
        let out = dir.join(format!("{name}.toml"));
        let mut args = vec!["commission", "--quiet", "--out", s(&out)];
        args.extend(recordings.iter().map(|p| s(p)));
        let message = refused(&args, &["nothing written"]);
        assert!(message.contains("healthy unit"), "{name}: {message}");
        assert!(!out.exists() && !dir.join(format!("{name}.tolerances.toml")).exists(), "{name}: a file was written");
    }
}

#[test]
fn without_commissioning_units_off_nominal_never_read_degraded() {
    let dir = scratch("commission", "uncommissioned");
    // units whose drawing-based diagnosis has read phantom faults, and others
    for unit in ["3", "4", "6", "11", "17", "23"] {
        let rec = flight(&dir, &format!("u{unit}.csv"), unit, "2", "20", None);
        let (status, k) = identify(&[s(&rec)]);
        assert!(status == "HEALTHY" || status == "INCONCLUSIVE", "unit {unit}: {status} {k:?}");
    }
}

#[test]
fn commission_refuses_bad_input_and_keeps_existing_files() {
    let dir = scratch("commission", "refusals");
    let rec = flight(&dir, "a.csv", "5", "1", "20", None);
    let out = dir.join("unit.toml");
    std::fs::write(&out, "old").expect("writes");
    refused(&["commission", s(&rec), "--out", s(&out)], &["unit.toml", "--force"]);
    assert_eq!(std::fs::read_to_string(&out).expect("kept"), "old");
    let nine: Vec<&str> = std::iter::repeat_n(s(&rec), 9).collect();
    let mut args = vec!["commission", "--out", "/nonexistent/x.toml"];
    args.extend(nine);
    refused(&args, &["at most 8"]);
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, "phase_resistance_ohm = 0.9\n").expect("writes");
    refused(
        &["commission", s(&rec), "--tolerances", s(&bad), "--out", s(&dir.join("b.toml"))],
        &["bad.toml", "line 1"],
    );
    assert!(!ema(&["commission", "--out", s(&dir.join("c.toml"))]).status.success());
}
