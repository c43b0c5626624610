//! The fault groups ([`FaultGroup`]): the parameters of the fault vector that appear and
//! disappear together (friction, backlash, a short per phase, eccentricity with its phase, gain),
//! what model selection tests, the probes of a warm start look for and the uncertainty reports on.

use crate::faults::{FaultGroup, FaultVector, FAULT_COUNT};

/// A group counts as present when one of its parameters is this far from healthy (the phase of
/// eccentricity only counts through its magnitude).
pub(super) const PRESENT_ABOVE: f32 = 1e-4;

/// `true` when `group` differs in `k` from the healthy vector (the eccentricity through its
/// magnitude only).
pub fn group_present(k: &[f32; FAULT_COUNT], group: FaultGroup) -> bool {
    let (first, last) = group.params();
    if group == FaultGroup::Eccentricity {
        return k.get(first).is_some_and(|&x| x > PRESENT_ABOVE);
    }
    let healthy = FaultVector::HEALTHY.0;
    (first..=last)
        .any(|i| matches!((k.get(i), healthy.get(i)), (Some(x), Some(h)) if libm::fabsf(x - h) > PRESENT_ABOVE))
}

/// `k` with the parameters of `group` set back to healthy.
pub fn without_group(k: &[f32; FAULT_COUNT], group: FaultGroup) -> [f32; FAULT_COUNT] {
    let (first, last) = group.params();
    let mut out = *k;
    for (x, h) in out.iter_mut().zip(FaultVector::HEALTHY.0).skip(first).take((last + 1).saturating_sub(first)) {
        *x = h;
    }
    out
}

/// Number of parameters of `group` (two for the eccentricity, one for every other group).
pub fn group_size(group: FaultGroup) -> usize {
    let (first, last) = group.params();
    last + 1 - first
}

/// The parameters of the groups present in `k` free, the others fixed.
pub(super) fn present_free(k: &[f32; FAULT_COUNT]) -> [bool; FAULT_COUNT] {
    let mut free = [false; FAULT_COUNT];
    for group in FaultGroup::ALL {
        let (first, last) = group.params();
        let present = group_present(k, group);
        free.iter_mut().enumerate().filter(|(i, _)| (first..=last).contains(i)).for_each(|(_, f)| *f = present);
    }
    free
}
