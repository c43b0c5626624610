//! Actuator parameter files (`ema params`, `--params FILE`): the template reads back to the
//! nominal set exactly, bad files are refused with their file, line and key, and a recording of a
//! non-nominal actuator is identified correctly with its parameters and measurably worse without.

mod common;

use common::{contract_status, ema, refused, s, scratch};
use ema_cli::params::read_params;
use ema_cli::params_file::{parse_params, template};
use ema_monitor::params::FIELDS;
use ema_monitor::{EmaParams, FaultVector};

#[test]
fn the_template_reads_back_to_the_nominal_set_exactly() {
    let out = ema(&["params"]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).expect("utf-8");
    let params = parse_params(&text).expect("the template parses");
    for f in FIELDS.iter() {
        assert_eq!(f.get(&params).to_bits(), f.get(&EmaParams::NOMINAL).to_bits(), "{}", f.name);
        // every key has its comment line: meaning, unit and range
        let at = text.find(&format!("\n{} = ", f.name)).unwrap_or_else(|| panic!("{} missing", f.name));
        let comment = text[..at].lines().last().expect("a comment line");
        assert!(comment.starts_with("# ") && comment.contains("Unit: ") && comment.contains("Range: "), "{comment}");
    }
    assert!(text.contains("A key left out keeps the nominal value"), "{text}");
    // a non-nominal set round-trips too
    let other = EmaParams { phase_resistance_ohm: 0.65, kp_a_per_rad: 595.0, ..EmaParams::NOMINAL };
    assert_eq!(parse_params(&template(&other)), Ok(other));
    // missing keys are nominal; an empty file is the nominal set
    assert_eq!(parse_params(""), Ok(EmaParams::NOMINAL));
    assert_eq!(parse_params("gear_ratio = 400\n"), Ok(EmaParams { gear_ratio: 400.0, ..EmaParams::NOMINAL }));
}

#[test]
fn bad_files_name_the_file_line_and_key() {
    let dir = scratch("params", "errors");
    let cases: [(&str, &str, &[&str]); 7] = [
        (
            "unknown.toml",
            "gear_ratio = 500\n\nphase_resistence_ohm = 0.6\n",
            &["unknown.toml", "line 3", "phase_resistence_ohm", "did you mean phase_resistance_ohm"],
        ),
        (
            "range.toml",
            "# mOhm by mistake\nphase_resistance_ohm = 650\n",
            &["range.toml", "line 2", "phase_resistance_ohm = 650", "[0.001, 100]", "ohm"],
        ),
        ("string.toml", "gear_ratio = \"500\"\n", &["string.toml", "line 1", "gear_ratio", "is not a number"]),
        ("whole.toml", "\npole_pairs = 3.5\n", &["line 2", "pole_pairs", "whole number"]),
        ("syntax.toml", "gear_ratio = 500\nkp_a_per_rad 700\n", &["syntax.toml", "line 2", "not valid TOML"]),
        ("relation.toml", "static_friction_n_m = 0.05\n", &["line 0", "dynamic_friction_n_m"]),
        ("period.toml", "control_period_s = 0.01\n", &["line 1", "control_period_s", "[0.00001, 0.001]"]),
    ];
    for (name, text, needles) in cases {
        let path = dir.join(name);
        std::fs::write(&path, text).expect("writes");
        let e = read_params(&path).expect_err(name).to_string();
        for n in needles {
            if *n == "line 0" {
                // a relation broken by a nominal value: no line, said so
                assert!(!e.contains("line ") && e.contains("not in the file"), "{name}: {e}");
            } else if n.starts_with("[0.00001") {
                assert!(e.contains("outside its range"), "{name}: {e}");
            } else {
                assert!(e.contains(n), "{name}: '{n}' missing from {e}");
            }
        }
    }
    // through the command line: one error line naming the file
    let bad = dir.join("unknown.toml");
    refused(&["identify", "--params", s(&bad), "x.csv"], &["unknown.toml", "line 3", "phase_resistence_ohm"]);
    refused(&["simulate", "--params", s(&dir.join("absent.toml")), "--out", s(&dir.join("o.csv"))], &["absent.toml"]);
}

/// A plausible other actuator: a hotter, weaker motor (phase resistance +30 %, EMF constant
/// −10 %), a heavier rotor (+25 %) and a softer position loop (Kp −15 %).
const OTHER_ACTUATOR: &str = "\
phase_resistance_ohm = 0.65
phase_emf_constant_v_s_per_rad = 0.117
motor_inertia_kg_m2 = 1.875e-4
kp_a_per_rad = 595.0
";

/// Err%, status and fitness of `ema identify FILE [--params P]`.
fn identify(file: &str, params: Option<&str>, truth: &FaultVector) -> (f32, String, f64) {
    let mut args = vec!["identify", file, "--json"];
    if let Some(p) = params {
        args.extend(["--params", p]);
    }
    let out = ema(&args);
    let expected = contract_status(&args, &String::from_utf8_lossy(&out.stdout));
    assert_eq!(out.status.code(), Some(expected), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    let k = v.get("k").or_else(|| v.get("k_not_a_diagnosis")).expect("a fault vector");
    let mut est = [0.0f32; 8];
    for (i, x) in est.iter_mut().enumerate() {
        *x = k[i].as_f64().expect("number") as f32;
    }
    let status = v["status"].as_str().expect("status").to_owned();
    (FaultVector(est).paper_error_percent(truth), status, v["fitness_A2"].as_f64().expect("fitness_A2"))
}

#[test]
fn a_non_nominal_actuator_is_identified_with_its_parameters_and_worse_without() {
    let dir = scratch("params", "must-show");
    let params = dir.join("other.toml");
    std::fs::write(&params, OTHER_ACTUATOR).expect("writes");
    assert!(read_params(&params).is_ok());
    let p = s(&params);
    let cases = [("0.4,0,0,0,0,0,0.5,0.5", "11"), ("0,0,0.3,0,0,0,0.5,0.5", "12"), ("0,0,0,0,0,0.6,0.3,0.5", "13")];
    let mut passes = 0;
    let mut lines = Vec::new();
    for (faults, seed) in cases {
        let truth = ema_cli::simulate::parse_faults(faults).expect("valid");
        let nominal = dir.join(format!("nominal-{seed}.csv"));
        let other = dir.join(format!("other-{seed}.csv"));
        let sim = |out: &std::path::Path, params: Option<&str>| {
            let mut args = vec!["simulate", "--faults", faults, "--seed", seed, "--out", s(out)];
            if let Some(p) = params {
                args.extend(["--params", p]);
            }
            let r = ema(&args);
            assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        };
        sim(&nominal, None);
        sim(&other, Some(p));
        // the recording's sidecar names its actuator: the file and every value
        let side: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(other.with_extension("json")).expect("reads")).expect("json");
        assert_eq!(side["params_file"].as_str(), Some(p), "{side}");
        assert_eq!(side["params"]["phase_resistance_ohm"].as_f64(), Some(0.65), "{side}");
        let (err_nominal, status_nominal, _) = identify(s(&nominal), None, &truth);
        let (err_with, status_with, fit_with) = identify(s(&other), Some(p), &truth);
        let (err_without, _, fit_without) = identify(s(&other), None, &truth);
        let correct = status_with == status_nominal && err_with <= err_nominal.max(1.0) * 2.0 + 1.0;
        let worse = err_without >= 3.0 * err_with.max(1.0) || fit_without >= 3.0 * fit_with;
        lines.push(format!(
            "{faults}: nominal {err_nominal:.2} % {status_nominal}; with --params {err_with:.2} % {status_with} \
             (fitness {fit_with:.3e}); without {err_without:.2} % (fitness {fit_without:.3e})"
        ));
        passes += usize::from(correct && worse);
    }
    println!("{}", lines.join("\n"));
    assert_eq!(passes, cases.len(), "{passes} of {} passed:\n{}", cases.len(), lines.join("\n"));
}
