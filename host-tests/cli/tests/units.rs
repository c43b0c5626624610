//! Every unit its own baseline: the tolerance table (`ema params --tolerances`, `--tolerances
//! FILE`) and the units `ema simulate --unit SEED` draws from it — one unit per seed, recorded in
//! the sidecar, simulated as drawn, and deviations that are independent standard normals.

mod common;

use std::path::Path;

use common::{accepted, ema, refused, s, scratch};
use ema_cli::params_file::parse_params;
use ema_cli::recording::read_recording;
use ema_cli::recording::sidecar::Sidecar;
use ema_cli::tolerances_file::{parse_tolerances, read_tolerances, template};
use ema_cli::unit_draw::draw_unit;
use ema_monitor::params::FIELDS;
use ema_monitor::unit::{unit_name, UNIT_PARAM_COUNT};
use ema_monitor::{EmaParams, Tolerances};
use ema_reference::{simulate, SimConfig};

/// A non-nominal base actuator: a hotter, weaker motor and a softer loop (as `tests/params.rs`).
const OTHER_ACTUATOR: &str = "\
phase_resistance_ohm = 0.65
phase_emf_constant_v_s_per_rad = 0.117
motor_inertia_kg_m2 = 1.875e-4
kp_a_per_rad = 595.0
";

/// A table wider than the typical one on friction and the hinge, narrower on the resistance.
const WIDE_FRICTION: &str = "\
# wider friction spread, a well-matched winding
static_friction_n_m = 0.2
dynamic_friction_n_m = 0.2
viscous_friction_n_m_s_per_rad = 0.25
phase_resistance_ohm = 0.01
hinge_stiffness_n_m_per_rad = 0.1
";

#[test]
fn the_tolerance_template_reads_back_to_the_typical_table() {
    let text = accepted(&["params", "--tolerances"]);
    let read = parse_tolerances(&text).expect("the template parses");
    for i in 0..UNIT_PARAM_COUNT {
        let name = unit_name(i);
        assert_eq!(read.relative_sigma[i].to_bits(), Tolerances::TYPICAL.relative_sigma[i].to_bits(), "{name}");
        // every key has its comment line: meaning, the parameter's unit, what the value is
        let at = text.find(&format!("\n{name} = ")).unwrap_or_else(|| panic!("{name} missing"));
        let comment = text[..at].lines().last().expect("a comment line");
        assert!(comment.starts_with("# ") && comment.contains("Relative 1-sigma (unit-less)"), "{comment}");
    }
    assert!(text.contains("0.03 means 3 %") && text.contains("ema simulate --unit SEED --tolerances FILE"), "{text}");
    // a non-typical table round-trips; plain `ema params` is still the parameter template
    let wide = parse_tolerances(WIDE_FRICTION).expect("valid");
    assert_ne!(wide, Tolerances::TYPICAL);
    assert_eq!(parse_tolerances(&template(&wide)), Ok(wide));
    assert_eq!(parse_params(&accepted(&["params"])), Ok(EmaParams::NOMINAL));
}

#[test]
fn bad_tolerance_files_name_the_file_line_and_key() {
    let dir = scratch("units", "bad-tolerances");
    let out = dir.join("out.csv");
    let cases: [(&str, &str, &[&str]); 5] = [
        (
            "misspelt.toml",
            "phase_inductance_h = 0.05\n\nstatic_friction = 0.1\n",
            &["line 3", "did you mean static_friction_n_m"],
        ),
        ("fixed.toml", "gear_ratio = 0.01\n", &["line 1", "gear_ratio", "does not vary from unit to unit"]),
        ("text.toml", "# σ\nefficiency_aiding = \"2 %\"\n", &["line 2", "efficiency_aiding", "is not a number"]),
        (
            "wide.toml",
            "\nhinge_stiffness_n_m_per_rad = 0.5\n",
            &["line 2", "hinge_stiffness_n_m_per_rad = 0.5", "[0, 0.3]"],
        ),
        ("negative.toml", "motor_inertia_kg_m2 = -0.05\n", &["line 1", "motor_inertia_kg_m2", "[0, 0.3]"]),
    ];
    for (name, text, needles) in cases {
        let path = dir.join(name);
        std::fs::write(&path, text).expect("writes");
        let mut all = vec![name];
        all.extend(needles);
        refused(&["simulate", "--unit", "1", "--tolerances", s(&path), "--out", s(&out)], &all);
        let e = read_tolerances(&path).expect_err(name).to_string();
        assert!(e.starts_with(&format!("'{}' line ", s(&path))), "{e}");
    }
    refused(
        &["simulate", "--unit", "1", "--tolerances", s(&dir.join("absent.toml")), "--out", s(&out)],
        &["absent.toml"],
    );
    refused(&["simulate", "--tolerances", s(&dir.join("wide.toml")), "--out", s(&out)], &["--unit"]);
    refused(&["simulate", "--unit", "x", "--out", s(&out)], &["'x'", "--unit"]);
    assert!(!out.exists(), "no output on refusal");
}

/// The parameters of a sidecar (every field).
fn params_of(side: &Sidecar) -> EmaParams {
    let mut p = EmaParams::NOMINAL;
    for f in FIELDS.iter() {
        f.set(&mut p, side.params[f.name]);
    }
    p
}

/// `ema simulate --unit UNIT` of the other actuator under the wide table, noise seed 2; the CSV's
/// bytes and the sidecar.
fn unit_file(dir: &Path, name: &str, unit: &str, base: &Path, tolerances: &Path) -> (Vec<u8>, Sidecar) {
    let out = dir.join(name);
    let args = ["simulate", "--unit", unit, "--params", s(base), "--tolerances", s(tolerances), "--seed", "2"];
    let mut args = args.to_vec();
    args.extend(["--out", s(&out), "--force"]);
    let printed = accepted(&args);
    assert!(printed.contains(&format!("of unit {unit} ({} tolerances)", s(tolerances))), "{printed}");
    let side = Sidecar::for_recording(&out).expect("readable").expect("a sidecar");
    (std::fs::read(&out).expect("written"), side)
}

#[test]
fn a_seed_is_one_unit_and_the_sidecar_holds_it() {
    let dir = scratch("units", "seed");
    let (base_path, tol_path) = (dir.join("other.toml"), dir.join("wide.toml"));
    std::fs::write(&base_path, OTHER_ACTUATOR).expect("writes");
    std::fs::write(&tol_path, WIDE_FRICTION).expect("writes");
    let base = parse_params(OTHER_ACTUATOR).expect("valid");
    let tolerances = parse_tolerances(WIDE_FRICTION).expect("valid");

    let (csv, side) = unit_file(&dir, "a.csv", "5", &base_path, &tol_path);
    assert_eq!(unit_file(&dir, "a.csv", "5", &base_path, &tol_path), (csv.clone(), side.clone()), "same seed");
    let (csv_b, side_b) = unit_file(&dir, "b.csv", "6", &base_path, &tol_path);
    assert_ne!(csv, csv_b, "another seed, another recording");

    let unit = side.unit.clone().expect("the unit is recorded");
    let other = side_b.unit.clone().expect("the unit is recorded");
    assert_eq!((unit.seed, other.seed), (5, 6));
    assert_eq!(unit.tolerances_file, s(&tol_path));
    assert_eq!((side.params_file.as_str(), side.temperature_c), (s(&base_path), None));
    let z: [f32; UNIT_PARAM_COUNT] =
        unit.parameters.iter().map(|p| p.z).collect::<Vec<_>>().try_into().expect("eleven parameters");
    let z_b: Vec<f32> = other.parameters.iter().map(|p| p.z).collect();
    assert!(z.iter().zip(&z_b).all(|(a, b)| a != b), "another seed draws every deviation anew: {z:?} {z_b:?}");
    // the recorded values are Tolerances::apply of the recorded deviations to the base
    let drawn = tolerances.apply(&base, &z);
    assert_ne!(drawn, base);
    for (i, p) in unit.parameters.iter().enumerate() {
        let field = ema_monitor::unit::unit_field(i).expect("a field");
        assert_eq!(p.name, unit_name(i));
        assert_eq!(p.relative_sigma.to_bits(), tolerances.relative_sigma[i].to_bits(), "{}", p.name);
        assert_eq!(p.base.to_bits(), field.get(&base).to_bits(), "{}", p.name);
        assert_eq!(p.value.to_bits(), field.get(&drawn).to_bits(), "{}", p.name);
    }
    // `params` is the whole unit: its drawn values and the base's others (Kp of the other actuator)
    assert_eq!(params_of(&side), drawn);
    assert_eq!(side.params["kp_a_per_rad"], 595.0);
    assert_eq!(drawn.check(), Ok(()));
    // the reference model ran that unit: the file is its simulation, row for row
    let run = simulate(&SimConfig { params: drawn, seed: 2, ..SimConfig::default() }).expect("simulates");
    let rec = read_recording(dir.join("a.csv")).expect("reads");
    assert_eq!(rec.temperature_c, None);
    assert_eq!(rec.len(), run.samples.len());
    for (k, x) in run.samples.iter().enumerate() {
        assert_eq!([rec.position_rad[k], rec.ia_a[k]], [x.position_rad, x.phase_current_a[0]], "row {k}");
    }
}

/// Mean and standard deviation of `x`.
fn moments(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    (mean, (x.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1.0)).sqrt())
}

/// Over 200 seeds the deviations of each parameter have mean 0 and standard deviation 1, and no
/// two parameters are correlated, each within four standard errors; every seed is another unit.
#[test]
fn drawn_deviations_are_independent_standard_normals() {
    let seeds = 200;
    let units: Vec<[f32; UNIT_PARAM_COUNT]> =
        (0..seeds).map(|seed| draw_unit(&EmaParams::NOMINAL, &Tolerances::TYPICAL, seed).expect("a unit").z).collect();
    for (i, a) in units.iter().enumerate() {
        assert!(units[..i].iter().all(|b| b != a), "seed {i} repeats a unit");
    }
    let n = seeds as f64;
    let column = |i: usize| units.iter().map(|z| f64::from(z[i])).collect::<Vec<f64>>();
    let (mean_limit, sd_limit) = (4.0 / n.sqrt(), 4.0 / (2.0 * n).sqrt());
    let mut lines = Vec::new();
    for i in 0..UNIT_PARAM_COUNT {
        let (mean, sd) = moments(&column(i));
        lines.push(format!("{}: mean {mean:+.3}, sd {sd:.3}", unit_name(i)));
        assert!(mean.abs() < mean_limit && (sd - 1.0).abs() < sd_limit, "{}", lines.join("\n"));
    }
    let all: Vec<f64> = (0..UNIT_PARAM_COUNT).flat_map(column).collect();
    let (mean, sd) = moments(&all);
    let m = all.len() as f64;
    assert!(mean.abs() < 4.0 / m.sqrt() && (sd - 1.0).abs() < 4.0 / (2.0 * m).sqrt(), "pooled: {mean} {sd}");
    for i in 0..UNIT_PARAM_COUNT {
        for j in 0..i {
            let (a, b) = (column(i), column(j));
            let ((ma, sa), (mb, sb)) = (moments(&a), moments(&b));
            let r = a.iter().zip(&b).map(|(x, y)| (x - ma) * (y - mb)).sum::<f64>() / ((n - 1.0) * sa * sb);
            assert!(r.abs() < 4.0 / n.sqrt(), "{} and {}: correlation {r}", unit_name(i), unit_name(j));
        }
    }
    // through the command line, the same draw: unit 17's sidecar holds draw_unit's deviations
    let dir = scratch("units", "cli-draw");
    let out = dir.join("u.csv");
    let printed = ema(&["simulate", "--unit", "17", "--noise", "off", "--out", s(&out)]);
    assert!(printed.status.success(), "{}", String::from_utf8_lossy(&printed.stderr));
    let side = Sidecar::for_recording(&out).expect("readable").expect("a sidecar");
    let z: Vec<f32> = side.unit.expect("a unit").parameters.iter().map(|p| p.z).collect();
    assert_eq!(z, draw_unit(&EmaParams::NOMINAL, &Tolerances::TYPICAL, 17).expect("a unit").z.to_vec());
}
