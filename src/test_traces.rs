//! The unit tests' recordings: the monitor model's own output under the standard manoeuvre with
//! the nominal actuator's noise on every frame (the measured envelope's: 0.29 A of controller
//! jitter on the pair current, 0.02 A on each sensor), from a seeded generator.

use crate::conditioning::{ConditionedWindow, DECIMATION, ONBOARD_WINDOW};
use crate::faults::FaultVector;
use crate::fitness::simulate_window;
use crate::optimizer::rng::Rng;
use crate::params::EmaParams;
use crate::profile::Profile;

/// Hands each frame `[ia, ib, ic]` (A) of the model with `params` and faults `truth` to `frame`,
/// the noise drawn from the generator `seed`.
pub(crate) fn noisy_frames(params: &EmaParams, truth: &FaultVector, seed: u64, mut frame: impl FnMut([f32; 3])) {
    let n = (Profile::STANDARD.duration_s() / params.control_period_s) as usize / DECIMATION;
    let mut rng = Rng::new(seed);
    simulate_window(params, &Profile::STANDARD, truth, n, |_, i, _| {
        for _ in 0..DECIMATION {
            let pair = i + 0.29 * rng.normal();
            let [na, nb, nc] = [0.02 * rng.normal(), 0.02 * rng.normal(), 0.02 * rng.normal()];
            frame([pair + na, -pair + nb, nc]);
        }
        true
    });
}

/// The closed window of [`noisy_frames`].
pub(crate) fn noisy_trace(params: &EmaParams, truth: &FaultVector, seed: u64) -> ConditionedWindow<ONBOARD_WINDOW> {
    let mut t = ConditionedWindow::<ONBOARD_WINDOW>::new();
    noisy_frames(params, truth, seed, |[a, b, c]| t.push(a, b, c).unwrap());
    t.finish().unwrap();
    t
}
