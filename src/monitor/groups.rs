//! The fault groups: the parameters of the fault vector that appear and disappear together
//! (friction, backlash, a short per phase, eccentricity with its phase, gain), what model
//! selection tests, the probes of a warm start look for and the uncertainty reports on.

use super::config::PHASE_INDEX;
use crate::faults::{FaultGroup, FaultVector, FAULT_COUNT, GROUP_COUNT};

/// The fault groups model selection tests, as `(first, last)` indices into the fault vector, in
/// the order of [`FaultGroup::ALL`] ([`FaultGroup::params`]).
pub const FAULT_GROUPS: [(usize, usize); GROUP_COUNT] = {
    let mut out = [(0, 0); GROUP_COUNT];
    let mut g = 0;
    while g < GROUP_COUNT {
        out[g] = FaultGroup::ALL[g].params();
        g += 1;
    }
    out
};

/// Names of the fault groups of [`FAULT_GROUPS`], in order ([`FaultGroup::name`]).
pub const GROUP_NAMES: [&str; GROUP_COUNT] = {
    let mut out = [""; GROUP_COUNT];
    let mut g = 0;
    while g < GROUP_COUNT {
        out[g] = FaultGroup::ALL[g].name();
        g += 1;
    }
    out
};

/// A group counts as present when one of its parameters is this far from healthy (the phase of
/// eccentricity only counts through its magnitude).
pub(super) const PRESENT_ABOVE: f32 = 1e-4;

/// `true` when the group `(first, last)` of [`FAULT_GROUPS`] differs in `k` from the healthy
/// vector (indices outside the vector count as healthy).
pub fn group_present(k: &[f32; FAULT_COUNT], (first, last): (usize, usize)) -> bool {
    if first == PHASE_INDEX - 1 {
        return k.get(first).is_some_and(|&x| x > PRESENT_ABOVE);
    }
    let healthy = FaultVector::HEALTHY.0;
    (first..=last)
        .any(|i| matches!((k.get(i), healthy.get(i)), (Some(x), Some(h)) if libm::fabsf(x - h) > PRESENT_ABOVE))
}

/// `k` with the group `(first, last)` of [`FAULT_GROUPS`] set back to healthy (indices outside
/// the vector are ignored).
pub fn without_group(k: &[f32; FAULT_COUNT], (first, last): (usize, usize)) -> [f32; FAULT_COUNT] {
    let mut out = *k;
    for (x, h) in out.iter_mut().zip(FaultVector::HEALTHY.0).skip(first).take((last + 1).saturating_sub(first)) {
        *x = h;
    }
    out
}

/// The parameters of the groups present in `k` free, the others fixed.
pub(super) fn present_free(k: &[f32; FAULT_COUNT]) -> [bool; FAULT_COUNT] {
    let mut free = [false; FAULT_COUNT];
    for &(first, last) in FAULT_GROUPS.iter() {
        let present = group_present(k, (first, last));
        free.iter_mut().enumerate().filter(|(i, _)| (first..=last).contains(i)).for_each(|(_, f)| *f = present);
    }
    free
}
