//! How long the reference model's commutations take against the pair model's formula: sensor
//! noise off, the standard manoeuvre between `T0` and `T1`, every interval in which all three
//! phases carry current (|i| > 0.02 A: the outgoing phase still decaying through its diode while
//! the incoming one rises) is one commutation `t_c`. Beside it, at the speed and current of its
//! start (intervals under 50 µs are the hysteresis loops' brief overlaps, not commutations:
//! counted, not listed), Carlson's `3L·I/(V_dc + 2E)` (the pair model's `t_c`; common phase switched on
//! throughout) and `2L·I/V_dc`, the mean when the common phase's hysteresis chops it: below the
//! dip onset (`4E < V_dc`) the common phase would rise past `I` while its switch is on, and
//! while it is off the outgoing phase decays at `(2V_dc + 2E)/3L` instead of `(V_dc + 2E)/3L`;
//! the duty that holds the common phase at `I` averages these to `V_dc/2L`, whatever the speed.
//! That holds where the common phase's rise would cross its hysteresis band within the
//! commutation; near the onset it rises inside the band unchopped and Carlson's formula applies
//! (README, "the pair model's commutation time").
//!
//! ```text
//! cargo run --release -p ema-cli --example commutation_time -- T0 T1 [EFFECT=S]
//! ```

use ema_cli::simulate::parse_effects;
use ema_monitor::EmaParams;
use ema_reference::sim::Simulator;
use ema_reference::SimConfig;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let usage = "usage: commutation_time T0 T1 [EFFECT=S]";
    let args: Vec<String> = std::env::args().skip(1).collect();
    let t0: f64 = args.first().ok_or(usage)?.parse()?;
    let t1: f64 = args.get(1).ok_or(usage)?.parse()?;
    let effects = parse_effects(args.get(2..3).unwrap_or_default())?;
    let p = EmaParams::NOMINAL;
    let (l, k, v) =
        (f64::from(p.phase_inductance_h), f64::from(p.phase_emf_constant_v_s_per_rad), f64::from(p.supply_voltage_v));
    let mut sim = Simulator::new(&SimConfig { effects, noise: false, ..SimConfig::default() })?;
    let dt = sim.step_s();
    // start of the current three-phase interval: time, speed, current
    let mut three: Option<(f64, f64, f64)> = None;
    let mut overlaps = 0usize;
    println!("start (s)   ω_m (rad/s)   I (A)   t_c (µs)   3LI/(V+2E) (µs)   2LI/V (µs)");
    for _ in 0..sim.sample_count() {
        let (sample, truth) = sim.sample();
        if !(t0..t1).contains(&sample.time_s) {
            sim.advance_period();
            continue;
        }
        let w = truth.motor_speed_rad_per_s;
        for j in 0..sim.steps_per_sample() {
            sim.step();
            let t = sample.time_s + dt * f64::from(j + 1);
            let i = sim.inverter().current_a;
            let conducting = i.iter().filter(|x| x.abs() > 0.02).count();
            match (conducting, three) {
                (3, None) => three = Some((t, w, i.iter().fold(0.0f64, |m, x| m.max(x.abs())))),
                (n, Some((start, _, _))) if n < 3 && t - start < 50e-6 => {
                    overlaps += 1;
                    three = None;
                }
                (n, Some((start, w0, i0))) if n < 3 => {
                    let carlson = 3.0 * l * i0 / (v + 2.0 * k * w0.abs());
                    let chopped = 2.0 * l * i0 / v;
                    println!(
                        "{start:.5}   {w0:11.1}   {i0:5.2}   {:8.1}   {:15.1}   {:10.1}",
                        1e6 * (t - start),
                        1e6 * carlson,
                        1e6 * chopped
                    );
                    three = None;
                }
                _ => {}
            }
        }
    }
    println!("{overlaps} brief three-phase overlaps (< 50 µs) not listed");
    Ok(())
}
