//! `ema simulate --sensors` and `--pre-trigger-ms` on a unit drawn off nominal: each effect of
//! the current sensors' chain where it belongs in the recording, the pre-trigger at rest before
//! the manoeuvre the run without one records, `ema identify` finding the start and the same
//! diagnosis, and `ema firmware-trace --from` packing the pre-trigger into a trace with its
//! trigger frame.

use std::path::{Path, PathBuf};

mod common;
use common::{accepted, refused, s, scratch, unit_params_file};
use ema_cli::recording::read_recording;
use ema_cli::recording::sidecar::Sidecar;
use ema_cli::recording::Recording;
use ema_cli::sensors_file::parse_sensors;
use ema_monitor::trace::{amps_to_counts, PackedTrace};
use ema_reference::SensorChain;

/// The unit every recording here is of (typical tolerances), and the noise seed.
const UNIT: &str = "23";
const SEED: &str = "6";
/// A friction fault, so the manoeuvre draws current and the diagnosis has something to find.
const FAULTS: &str = "0.35,0,0,0,0,0,0.5,0.5";
/// Pre-trigger rows at 10 kHz of `--pre-trigger-ms 50`.
const REST: usize = 500;

/// `ema simulate` of the unit with `extra` flags into `dir/name.csv`: the file and its sidecar.
fn record(dir: &Path, name: &str, extra: &[&str]) -> (PathBuf, Recording, Sidecar) {
    let out = dir.join(format!("{name}.csv"));
    let mut args = vec!["simulate", "--unit", UNIT, "--seed", SEED, "--faults", FAULTS, "--out", s(&out)];
    args.extend_from_slice(extra);
    accepted(&args);
    let rec = read_recording(&out).expect("a valid recording");
    let side = Sidecar::for_recording(&out).expect("readable").expect("a sidecar");
    (out, rec, side)
}

fn phase(r: &Recording, j: usize) -> &[f64] {
    [&r.ia_a, &r.ib_a, &r.ic_a][j]
}

fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len() as f64
}

/// Least squares `y = a + b·x`: `(a, b)`.
fn line(x: &[f64], y: &[f64]) -> (f64, f64) {
    let (mx, my) = (mean(x), mean(y));
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
    let b = sxy / sxx;
    (my - b * mx, b)
}

/// How much later than `reference` the samples of `delayed` are taken, s: the least-squares
/// `d` of `delayed − reference ≈ d·ẏ`, `ẏ` the central difference of `reference` at 10 kHz.
fn delay_s(reference: &[f64], delayed: &[f64]) -> f64 {
    let period = 1e-4;
    let (mut num, mut den) = (0.0, 0.0);
    for k in 1..reference.len() - 1 {
        let slope = (reference[k + 1] - reference[k - 1]) / (2.0 * period);
        num += (delayed[k] - reference[k]) * slope;
        den += slope * slope;
    }
    num / den
}

/// FNV-1a (64 bits) of a file's bytes.
fn digest(path: &Path) -> u64 {
    let bytes = std::fs::read(path).expect("written");
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3))
}

/// The ideal chain is a fixed 20 kHz lag and the 12-bit ±20 A ADC behind the `sensor_offset`
/// effect's error, and records these files byte for byte (their digests and sizes): the nominal
/// actuator, drawn units with that effect, at a temperature and on the pbit manoeuvre
/// (`tests/firmware_trace.rs` checks the built-in trace the same way).
#[test]
fn the_ideal_chain_records_what_the_fixed_path_recorded() {
    let dir = scratch("sensors", "ideal");
    for (name, args, expected, bytes) in [
        ("nominal", vec![], 0x0000_4137_77f5_5f91u64, 673_481u64),
        (
            "unit11",
            vec![
                "--unit",
                "11",
                "--faults",
                "0.3,0.2,0.1,0,0,0.2,0.4,0.6",
                "--effect",
                "sensor_offset=0.7",
                "--seed",
                "5",
            ],
            0xd3c9_c5b6_bf5f_bb11,
            682_084,
        ),
        (
            "unit3",
            vec!["--unit", "3", "--temperature", "60", "--seed", "9", "--profile", "pbit", "--sensors", "ideal"],
            0x3fee_ace5_b627_c8a6,
            730_663,
        ),
    ] {
        let out = dir.join(format!("{name}.csv"));
        let mut all = vec!["simulate", "--out", s(&out)];
        all.extend(args);
        accepted(&all);
        let size = std::fs::metadata(&out).expect("written").len();
        assert_eq!((digest(&out), size), (expected, bytes), "{name}: {all:?}");
    }
}

#[test]
fn each_chain_effect_shows_where_it_belongs() {
    let dir = scratch("sensors", "effects");
    let (_, ideal, _) = record(&dir, "ideal", &["--pre-trigger-ms", "50"]);
    let (_, board, side) = record(&dir, "board", &["--sensors", "nucleo-f446re", "--pre-trigger-ms", "50"]);
    let (_, oneshot, _) = record(&dir, "oneshot", &["--sensors", "nucleo-f446re-oneshot", "--pre-trigger-ms", "50"]);
    let slow_file = dir.join("slow.toml");
    std::fs::write(
        &slow_file,
        "# a slow sensor read by a 10-bit ADC over ±25 A\nadc_bits = 10\nfull_scale_a = 25\nbandwidth_hz = 2000\n",
    )
    .expect("writable");
    let (_, slow, slow_side) = record(&dir, "slow", &["--sensors", s(&slow_file), "--pre-trigger-ms", "50"]);
    let chain = SensorChain::NUCLEO_F446RE;

    // the chain is on the recording path only: the actuator moves the same under every chain
    for other in [&board, &oneshot, &slow] {
        assert_eq!(other.position_rad, ideal.position_rad);
        assert_eq!(other.len(), ideal.len());
    }
    for j in 0..3 {
        // zero error: the rest frames' mean
        let (rest_ideal, rest_board) = (mean(&phase(&ideal, j)[..REST]), mean(&phase(&board, j)[..REST]));
        let o = chain.phases[j].offset_a;
        assert!(rest_ideal.abs() < 0.003, "phase {j}: ideal rest mean {rest_ideal} A");
        assert!((rest_board - o).abs() < 0.003, "phase {j}: rest mean {rest_board} A, zero error {o} A");
        // gain error: the ratio to the ideal chain's currents over the manoeuvre
        let (a, b) = line(&phase(&ideal, j)[REST..], &phase(&board, j)[REST..]);
        let g = chain.phases[j].gain_error;
        assert!((b - (1.0 + g)).abs() < 5e-4, "phase {j}: ratio {b}, gain error {g}");
        assert!((a - o).abs() < 0.003, "phase {j}: intercept {a} A, zero error {o} A");
    }
    // skew: phase a is converted at the frame instant by both, b and c 5 and 10 µs later. The
    // currents bend between frames (hysteresis, commutations), which biases a finite-difference
    // estimate by up to a third; the exact instant is the reference model's unit test
    // `a_skewed_conversion_reads_its_instant`.
    assert_eq!(oneshot.ia_a, board.ia_a);
    let skew = |j: usize| delay_s(&phase(&board, j)[REST..], &phase(&oneshot, j)[REST..]);
    let (b, c) = (skew(1), skew(2));
    for (d, expected) in [(b, 5e-6), (c, 10e-6)] {
        assert!(d > 0.7 * expected && d < 1.6 * expected, "delay {d} s, skew {expected} s");
    }
    assert!(c > 1.5 * b && c < 3.0 * b, "phase c's delay {c} s twice phase b's {b} s");
    // quantisation: each chain's codes, 40 A over 4096 and 50 A over 1024
    let on_grid = |x: &[f64], lsb: f64| x.iter().all(|v| ((v / lsb) - (v / lsb).round()).abs() < 1e-9);
    for j in 0..3 {
        assert!(on_grid(phase(&board, j), 40.0 / 4096.0), "phase {j}");
        assert!(on_grid(phase(&slow, j), 50.0 / 1024.0), "phase {j}");
        assert!(!on_grid(phase(&ideal, j), 50.0 / 1024.0), "phase {j}: the 12-bit codes are finer");
    }
    // bandwidth: a first-order lag of 2 kHz instead of 20 kHz holds the currents back by about
    // the difference of the time constants, 1/(2π·2 kHz) − 1/(2π·20 kHz) = 71.6 µs (less where
    // they change faster than the lag: by a fifth in this estimate)
    let lag = 1.0 / (std::f64::consts::TAU * 2000.0) - 1.0 / (std::f64::consts::TAU * 20000.0);
    for j in 0..3 {
        let d = -delay_s(&phase(&ideal, j)[REST..], &phase(&slow, j)[REST..]);
        assert!(d > 0.65 * lag && d < 1.2 * lag, "phase {j}: held back {d} s, lag difference {lag} s");
    }
    // the sidecars hold the chains
    let sensors = side.sensors.expect("the chain is recorded");
    assert_eq!(sensors.source, "nucleo-f446re");
    assert_eq!(
        (sensors.offset_a, sensors.gain_error, sensors.skew_us),
        ([0.15, -0.1, 0.12], [0.01, -0.008, 0.005], [0.0; 3])
    );
    let slow_sensors = slow_side.sensors.expect("the chain is recorded");
    assert_eq!((slow_sensors.adc_bits, slow_sensors.full_scale_a, slow_sensors.bandwidth_hz), (10, 25.0, [2000.0; 3]));
    assert_eq!(slow_sensors.source, s(&slow_file));
}

#[test]
fn a_pre_trigger_is_the_rest_before_the_same_manoeuvre() {
    let dir = scratch("sensors", "pre-trigger");
    let (_, plain, plain_side) = record(&dir, "plain", &["--sensors", "nucleo-f446re"]);
    let (_, pre, side) = record(&dir, "pre", &["--sensors", "nucleo-f446re", "--pre-trigger-ms", "50"]);
    assert_eq!(pre.len(), plain.len() + REST);
    assert_eq!((pre.time_s[0], pre.time_s[REST]), (0.0, 0.05));
    assert!(pre.command_rad[..REST].iter().all(|&c| c == 0.0), "the standard profile opens at 0 rad");
    // the rest: the position reads its noise about zero, the currents their zero errors
    assert!(pre.position_rad[..REST].iter().all(|p| p.abs() < 1e-4));
    assert!(pre.ia_a[..REST].iter().all(|i| (i - 0.15).abs() < 0.15), "phase a reads its zero error");
    // then, 50 ms later, the recording without a pre-trigger, row for row
    let columns = |r: &Recording, from: usize| {
        [&r.command_rad, &r.position_rad, &r.ia_a, &r.ib_a, &r.ic_a].map(|c| c[from..].to_vec())
    };
    assert_eq!(columns(&pre, REST), columns(&plain, 0));
    assert_eq!((side.pre_trigger_s, plain_side.pre_trigger_s), (Some(0.05), None));
    assert_eq!((side.rows, side.duration_s), (plain.len() + REST, plain_side.duration_s));
}

/// The report of `ema identify`, without the lines that differ from run to run (timing) or by
/// the file's layout (where the manoeuvre starts).
fn diagnosis(out: &str) -> Vec<&str> {
    out.lines().filter(|l| !l.contains("identification took") && !l.contains("recording:")).collect()
}

#[test]
fn identify_finds_the_start_and_the_same_diagnosis() {
    let dir = scratch("sensors", "identify");
    let (plain, ..) = record(&dir, "plain", &[]);
    let (pre, ..) = record(&dir, "pre", &["--pre-trigger-ms", "50"]);
    // the monitor identifies the unit it is told about
    let params = unit_params_file(&plain);
    let without = accepted(&["identify", s(&plain), "--params", s(&params), "--quiet"]);
    let with = accepted(&["identify", s(&pre), "--params", s(&params), "--quiet"]);
    assert!(with.contains("manoeuvre starts at 0.050000 s (aligned); trimmed 0.050000 s before"), "{with}");
    // the pre-trigger's 500 rows give the zero points (within a fraction of a count of the ideal
    // sensors' 0): the same status and the same condition of every mode
    assert!(with.contains("sensors: zero points from 500 rows before the manoeuvre"), "{with}");
    assert!(without.contains("sensors: declared zero points"), "{without}");
    let conditions = |out: &str| -> Vec<String> {
        // the status line, then each mode's name and condition
        diagnosis(out).iter().take(6).map(|l| l.split_whitespace().take(3).collect::<Vec<_>>().join(" ")).collect()
    };
    assert_eq!(conditions(&with), conditions(&without), "{with}\n{without}");
    assert!(without.contains("EMA health: DEGRADED") && without.contains("friction"), "{without}");
}

#[test]
fn a_pre_trigger_recording_packs_to_a_trace_with_its_trigger_frame() {
    let dir = scratch("sensors", "ema2");
    let (plain_csv, ..) = record(&dir, "plain", &["--sensors", "nucleo-f446re"]);
    let (pre_csv, pre, _) = record(&dir, "pre", &["--sensors", "nucleo-f446re", "--pre-trigger-ms", "50"]);
    let (long_csv, ..) = record(&dir, "long", &["--sensors", "nucleo-f446re", "--pre-trigger-ms", "150"]);
    let pack = |csv: &Path| {
        let out = csv.with_extension("ematrace");
        let line = accepted(&["firmware-trace", "--from", s(csv), "--out", s(&out)]);
        (std::fs::read(&out).expect("written"), out, line)
    };
    let (plain_bytes, plain_trace, _) = pack(&plain_csv);
    let (pre_bytes, pre_trace, line) = pack(&pre_csv);
    let (long_bytes, ..) = pack(&long_csv);
    assert!(line.contains("9000 frames") && line.contains("trigger at frame 500 after 50 ms at rest"), "{line}");
    let (plain_t, pre_t, long_t) = (
        PackedTrace::parse(&plain_bytes).expect("valid"),
        PackedTrace::parse(&pre_bytes).expect("valid"),
        PackedTrace::parse(&long_bytes).expect("valid"),
    );
    assert_eq!((&plain_bytes[..4], &pre_bytes[..4]), (&b"EMA3"[..], &b"EMA3"[..]));
    assert_eq!((plain_t.trigger_frame(), pre_t.trigger_frame(), pre_t.frames()), (0, 500, 9000));
    // a longer rest keeps the last 100 ms of it
    assert_eq!((long_t.trigger_frame(), long_t.frames()), (1000, 9500));
    // the rest frames are the recording's, then the manoeuvre's frames are the plain trace's
    for k in 0..REST {
        let codes = [pre.ia_a[k], pre.ib_a[k], pre.ic_a[k]].map(|i| amps_to_counts(i as f32));
        assert_eq!(pre_t.frame(k), Some(codes), "frame {k}");
    }
    assert!(pre_t.iter().skip(REST).eq(plain_t.iter()));
    assert!(long_t.iter().skip(1000).eq(plain_t.iter()));
    // the firmware's path (parity with QEMU) reads the rest frames for the zero points, which are
    // the preset's zero errors (+0.15, −0.10, +0.12 A at 9.77 mA per count), and the manoeuvre
    // from the trigger on; the trace without them keeps the declared zeros
    let sensors = |trace: &Path| {
        let out = accepted(&["identify", "--firmware-trace", s(trace), "--json", "--max-iterations", "2"]);
        serde_json::from_str::<serde_json::Value>(&out).expect("JSON")["sensors"].clone()
    };
    let (measured, declared) = (sensors(&pre_trace), sensors(&plain_trace));
    assert_eq!(
        (&measured["zero_points"], &measured["rest_frames"]),
        (&serde_json::json!("rest"), &serde_json::json!(500))
    );
    for (j, zero_a) in [0.15, -0.10, 0.12].iter().enumerate() {
        let shift = measured["zero_shift_counts"][j].as_f64().expect("a number");
        assert!((shift - zero_a / (40.0 / 4096.0)).abs() < 1.0, "phase {j}: {measured}");
    }
    assert_eq!(declared["zero_points"], "declared", "{declared}");
}

#[test]
fn bad_sensor_flags_are_refused_naming_the_file_line_and_key() {
    let dir = scratch("sensors", "refused");
    let out = dir.join("x.csv");
    refused(&["simulate", "--sensors", "nucleo", "--out", s(&out)], &["--sensors", "'nucleo' is neither a preset"]);
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, "preset = \"nucleo-f446re\"\n\ngain_eror = 0.01\n").expect("writable");
    refused(
        &["simulate", "--sensors", s(&bad), "--out", s(&out)],
        &["bad.toml", "line 3", "unknown key 'gain_eror'", "did you mean gain_error"],
    );
    std::fs::write(&bad, "skew_us = [0, 50, 120]\n").expect("writable");
    refused(&["simulate", "--sensors", s(&bad), "--out", s(&out)], &["bad.toml", "line 1", "skew_us[2] (phase c)"]);
    // the skew is checked against the actuator's control period
    let params = dir.join("fast.toml");
    std::fs::write(&params, "control_period_s = 5e-5\nderivative_filter_s = 1e-3\n").expect("writable");
    std::fs::write(&bad, "skew_us = [0, 0, 60]\n").expect("writable");
    refused(
        &["simulate", "--params", s(&params), "--sensors", s(&bad), "--out", s(&out)],
        &["bad.toml", "line 1", "skew_us[2] (phase c): 60 µs is outside [0, 50) µs"],
    );
    refused(&["simulate", "--pre-trigger-ms", "10001", "--out", s(&out)], &["--pre-trigger-ms", "10000 ms"]);
    assert!(!out.exists());
}

/// The sensor file of docs/sensors.md reads, to the chain the page says it is.
#[test]
fn the_documented_sensor_file_reads() {
    let page = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/sensors.md");
    let text = std::fs::read_to_string(&page).expect("docs/sensors.md");
    let start = text.find("```toml\n").expect("a toml block") + "```toml\n".len();
    let block = &text[start..start + text[start..].find("```").expect("its end")];
    let chain = parse_sensors(block, 1e-4).expect("the documented file is valid");
    let mut expected = SensorChain::NUCLEO_F446RE;
    for (j, skew) in [0.0, 2.5e-6, 5.0e-6].into_iter().enumerate() {
        expected.phases[j].skew_s = skew;
    }
    expected.phases[2].offset_a = 0.2;
    assert_eq!(chain, expected);
}
