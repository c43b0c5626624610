//! Several monitor models run in lockstep over one recording, each model's current conditioned as
//! the fitness conditions it ([`crate::fitness`]): the measured envelope (or the sensor-error
//! envelope when effect terms are on), block means of [`DECIMATION`] frames, the fast-regime
//! weight `ρ_i` times the trace's weight `w_i`. The finite-difference sensitivities of the fault
//! uncertainty (`diagnosis/uncertainty.rs`) and of commissioning ([`crate::commissioning`]) are
//! both such runs: a base model and one stepped model per parameter, differenced sample by
//! sample, nothing stored per sample.

use crate::command::{AnyCommandCursor, CommandCursor};
use crate::conditioning::{MeasuredEnvelope, SensorErrorEnvelope, DECIMATION};
use crate::fitness::EquivalentCurrentFit;
use crate::model::{ModelState, MonitorModel};
use crate::params::EmaParams;

/// Runs the `M` `models` in lockstep under `fit`'s command (the envelopes of `params` and `fit`'s
/// effect terms) and hands each window sample `i` to `sink(y_i, v_i, means)`: the measured block
/// mean `y_i`, its weight `v_i = ρ_i·w_i` and each model's block mean, in order.
pub(crate) fn lockstep<const M: usize, const W: usize>(
    models: &[MonitorModel; M],
    params: &EmaParams,
    fit: &EquivalentCurrentFit<'_, W>,
    sink: impl FnMut(f32, f32, &[f32; M]),
) {
    let terms = models.first().is_some_and(MonitorModel::has_step_terms);
    let command = AnyCommandCursor::new(fit.command());
    if terms {
        run::<true, M, W>(models, params, command, fit, sink)
    } else {
        run::<false, M, W>(models, params, command, fit, sink)
    }
}

/// [`lockstep`] with or without the models' step terms.
fn run<const TERMS: bool, const M: usize, const W: usize>(
    models: &[MonitorModel; M],
    params: &EmaParams,
    mut command: AnyCommandCursor<'_>,
    fit: &EquivalentCurrentFit<'_, W>,
    mut sink: impl FnMut(f32, f32, &[f32; M]),
) {
    let envelope = MeasuredEnvelope::of(params);
    let sensors = SensorErrorEnvelope::of(&envelope, params, fit.effects());
    let Some(dt) = models.first().map(MonitorModel::dt_s) else { return };
    let mut states = [ModelState::at_rest(); M];
    let trace = fit.trace();
    let mut rho = fit.regime_weights();
    let mut step = 0u32;
    let inv_decimation = 1.0 / DECIMATION as f32;
    for i in 0..trace.len() {
        let Some((y_i, w_i)) = trace.sample(i) else { return };
        let mut block = [0.0f32; M];
        for _ in 0..DECIMATION {
            let theta = command.command_rad(step, step as f32 * dt);
            for ((model, state), b) in models.iter().zip(states.iter_mut()).zip(block.iter_mut()) {
                *b += match &sensors {
                    Some(e) if TERMS => {
                        e.expected_a(model.commutation_sector(state), state.output_current_a, &state.freewheel_shift_a)
                    }
                    _ => envelope.expected_a(state.output_current_a),
                };
                model.step_out_of_line::<TERMS>(state, theta);
            }
            step += 1;
        }
        for b in block.iter_mut() {
            *b *= inv_decimation;
        }
        sink(y_i, rho.at(i) * w_i, &block);
    }
}
