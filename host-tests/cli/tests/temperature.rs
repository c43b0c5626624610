//! The actuator's temperature: `ema simulate --temperature C` runs the reference model at `C` and
//! writes the `temperature_C` column; `ema identify` (one recording or pooled) and `ema history`
//! build the monitor model at the recording's temperature. A cold unit identified at its
//! temperature reads healthy, and the same rows without the column fit worse.

mod common;

use std::path::{Path, PathBuf};

use common::{accepted, ema, refused, s, scratch, unit_params_file};
use ema_cli::recording::read_recording;
use ema_cli::recording::sidecar::Sidecar;
use ema_monitor::params::FIELDS;
use ema_monitor::EmaParams;
use ema_reference::{simulate, SimConfig};

/// `ema simulate --unit UNIT --seed SEED [--temperature T] --out DIR/NAME`; the file's path.
fn unit_at(dir: &Path, name: &str, unit: &str, seed: &str, temperature: Option<&str>) -> PathBuf {
    let out = dir.join(name);
    let mut args = vec!["simulate", "--unit", unit, "--seed", seed, "--out", s(&out)];
    if let Some(t) = temperature {
        args.extend(["--temperature", t]);
    }
    let printed = accepted(&args);
    if let Some(t) = temperature {
        assert!(printed.contains(&format!("at {t} °C")), "{printed}");
    }
    out
}

/// The recording without its last column (the temperature).
fn without_temperature(recording: &Path) -> PathBuf {
    let text = std::fs::read_to_string(recording).expect("reads");
    let stripped: String = text.lines().map(|l| format!("{}\n", &l[..l.rfind(',').expect("a comma")])).collect();
    assert!(stripped.starts_with("time_s,command_rad,position_rad,ia_A,ib_A,ic_A\n"), "{}", &stripped[..80]);
    let path = recording
        .with_file_name(format!("{}-stripped.csv", recording.file_stem().and_then(|x| x.to_str()).unwrap_or("r")));
    std::fs::write(&path, stripped).expect("writes");
    path
}

/// `ema identify ARGS --json` as JSON.
fn identify_json(args: &[&str]) -> serde_json::Value {
    let mut all = vec!["identify", "--json", "--quiet"];
    all.extend(args);
    serde_json::from_str(accepted(&all).trim()).expect("JSON")
}

#[test]
fn the_temperature_flag_is_checked_and_twenty_degrees_change_nothing_but_the_column() {
    let dir = scratch("temperature", "flag");
    let out = dir.join("out.csv");
    for bad in ["250", "-150", "NaN", "inf"] {
        refused(&["simulate", "--temperature", bad, "--out", s(&out)], &["--temperature", bad]);
    }
    refused(&["simulate", "--temperature", "cold", "--out", s(&out)], &["'cold'", "--temperature"]);
    // at -100 °C the nominal actuator's mechanical time constant is below ten control periods
    refused(
        &["simulate", "--temperature", "-100", "--out", s(&out)],
        &["--temperature", "at -100 °C the actuator's parameters are refused", "motor_inertia_kg_m2"],
    );
    assert!(!out.exists(), "no output on refusal");
    // at 20 °C the parameters are the file's: the same rows, one more column, and the sidecar says so
    let plain = dir.join("plain.csv");
    accepted(&["simulate", "--seed", "4", "--out", s(&plain)]);
    let warm = unit_at(&dir, "twenty.csv", "3", "4", Some("20"));
    let unit = unit_at(&dir, "unit.csv", "3", "4", None);
    let (a, b, c) = (read_recording(&plain).unwrap(), read_recording(&warm).unwrap(), read_recording(&unit).unwrap());
    assert_eq!(b.temperature_c, Some(vec![20.0; b.len()]));
    assert_eq!((a.temperature_c.as_ref(), c.temperature_c.as_ref()), (None, None));
    assert_eq!((&b.ia_a, &b.position_rad), (&c.ia_a, &c.position_rad), "20 °C is the unit's own parameters");
    assert_ne!(a.ia_a, c.ia_a, "the unit is not the nominal actuator");
    let side = Sidecar::for_recording(&warm).unwrap().unwrap();
    assert_eq!((side.temperature_c, side.columns.last().map(String::as_str)), (Some(20.0), Some("temperature_C")));
    assert!(Sidecar::for_recording(&plain).unwrap().unwrap().unit.is_none());
}

/// The unit simulated at -40 °C is the reference model run with its parameters at -40 °C.
#[test]
fn a_cold_unit_is_simulated_with_its_parameters_at_the_temperature() {
    let dir = scratch("temperature", "cold-sim");
    let cold = unit_at(&dir, "cold.csv", "9", "5", Some("-40"));
    let side = Sidecar::for_recording(&cold).unwrap().unwrap();
    let mut unit = EmaParams::NOMINAL;
    for f in FIELDS.iter() {
        f.set(&mut unit, side.params[f.name]);
    }
    let run = simulate(&SimConfig { params: unit.at_temperature(-40.0), seed: 5, ..SimConfig::default() }).unwrap();
    let rec = read_recording(&cold).unwrap();
    let currents: Vec<f64> = run.samples.iter().map(|x| x.phase_current_a[1]).collect();
    assert_eq!(rec.ib_a, currents);
    assert_eq!(rec.mean_temperature_c(), Some(-40.0));
}

#[test]
fn a_cold_unit_reads_healthy_at_its_temperature_and_fits_worse_without() {
    let dir = scratch("temperature", "identify");
    let mut lines = Vec::new();
    for (unit, seed) in [("7", "3"), ("21", "8")] {
        let cold = unit_at(&dir, &format!("unit{unit}.csv"), unit, seed, Some("-40"));
        let params = unit_params_file(&cold);
        let stripped = without_temperature(&cold);
        let common = ["--params", s(&params), "--max-iterations", "30"];
        let mut args = vec![s(&cold)];
        args.extend(common);
        let with = identify_json(&args);
        let mut args = vec![s(&stripped)];
        args.extend(common);
        let without = identify_json(&args);
        let fitness = |v: &serde_json::Value| v["fitness_A2"].as_f64().expect("fitness_A2");
        lines.push(format!(
            "unit {unit}: with the temperature {} (fitness {:.4e}), without {} (fitness {:.4e})",
            with["status"],
            fitness(&with),
            without["status"],
            fitness(&without)
        ));
        assert_eq!((&with["status"], &with["temperature_c"]), (&"HEALTHY".into(), &(-40.0).into()), "{with}");
        assert!(without["temperature_c"].is_null() && without["status"] != "HEALTHY", "{without}");
        assert!(fitness(&without) > 1.5 * fitness(&with), "{}", lines.join("\n"));
    }
    println!("{}", lines.join("\n"));
    // the text report names the temperature; a named temperature column the file lacks is refused
    let cold = dir.join("unit7.csv");
    let text = accepted(&["identify", s(&cold), "--max-iterations", "2", "--quiet"]);
    assert!(text.contains("\n  temperature: -40.0 °C (recording)\n"), "{text}");
    refused(
        &["identify", s(&cold), "--column", "temperature=nonexistent"],
        &["unit7.csv", "line 1", "no column 'nonexistent' for the temperature channel"],
    );
}

#[test]
fn recordings_identified_together_share_a_temperature() {
    let dir = scratch("temperature", "pooled");
    let a = unit_at(&dir, "a.csv", "4", "3", Some("-40"));
    let b = unit_at(&dir, "b.csv", "4", "4", Some("-38"));
    let c = unit_at(&dir, "c.csv", "4", "5", Some("-30"));
    let d = unit_at(&dir, "d.csv", "4", "6", None);
    let params = unit_params_file(&a);
    let p = s(&params);
    let v = identify_json(&[s(&a), s(&b), "--params", p, "--max-iterations", "2"]);
    assert_eq!((&v["pooled_recordings"], &v["temperature_c"]), (&2.into(), &(-39.0).into()), "{v}");
    refused(
        &["identify", s(&a), s(&c), "--params", p],
        &["c.csv': mean temperature -30.0 °C, 10.0 K above the -40.0 °C of", "a.csv", "within 5 K"],
    );
    refused(&["identify", s(&a), s(&d), "--params", p], &["d.csv': no temperature column, but", "a.csv", "has one"]);
    // ema history models each flight at its own temperature
    let v: serde_json::Value =
        serde_json::from_str(accepted(&["history", s(&a), s(&c), s(&d), "--params", p, "--json", "--quiet"]).trim())
            .expect("JSON");
    let t: Vec<&serde_json::Value> = (0..3).map(|i| &v["flights"][i]["temperature_c"]).collect();
    assert_eq!(t, [&(-40.0).into(), &(-30.0).into(), &serde_json::Value::Null], "{v}");
    let ok = ema(&["identify", s(&a), s(&b), "--params", p, "--max-iterations", "2", "--quiet"]);
    let text = String::from_utf8_lossy(&ok.stdout);
    assert!(
        text.starts_with("pooled over 2 recordings") && text.contains("temperature: -39.0 °C (recording)"),
        "{text}"
    );
}
