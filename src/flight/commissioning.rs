//! Commissioning as a mode of the flight API: the unit's own baseline fitted over its first
//! flights after a maintenance reset ([`HealthMonitor::with_commissioning`]), then every later
//! flight diagnosed against it.
//!
//! A commissioning of `N` flights ([`MAX_ONBOARD_COMMISSIONING_FLIGHTS`] at most):
//! - flights `1 … N−1` keep their conditioned window in flash ([`FlightHooks::keep_window`]) and
//!   report `INCONCLUSIVE (commissioning)`: no diagnosis is made against parameters the unit is
//!   about to replace. A flight whose acquisition cannot be used (a sensor fault, a rate that is
//!   not the control rate) keeps nothing and does not count;
//! - flight `N` reads the kept windows back ([`FlightHooks::load_window`]) and fits the baseline
//!   to all `N` flights at once, each at its own temperature ([`crate::commissioning::commission`],
//!   the fit `ema commission` runs on the host), then diagnoses itself against it. The baseline
//!   is kept in the health record only when no resolved parameter lies beyond its tolerance
//!   ([`crate::commissioning::Baseline::out_of_tolerance`]) and the flight reads HEALTHY
//!   against it: a fault present at commissioning is never baked into the baseline. Otherwise
//!   the record says why ([`CommissioningRefusal`]) and the unit is diagnosed against the
//!   parameters as given, from this flight on.
//!
//! The windows are fitted jointly, not one flight at a time: a single flight's valley over the
//! unit parameters is not quadratic, and a Gaussian carried from flight to flight held the fit
//! beyond the tolerance on a healthy unit (`docs/decisions/0029-…`).

use super::{Flight, FlightHooks, HealthMonitor};
use crate::commissioning::{commission, Baseline, BaselineFit, CommissioningFlight, SWARM_ITERATIONS, SWARM_PARTICLES};
use crate::conditioning::ConditionedWindow;
use crate::diagnosis::{configured_fit, ColdReason, MonitorError, Start};
use crate::faults::FaultVector;
use crate::flight::Acquired;
use crate::health::{Abstain, HealthReport, Status};
use crate::persist::{Commissioning, CommissioningRefusal, HealthRecord, UnitBaseline};

/// Most flights an on-board commissioning fits: all but the last are held on the stack as
/// windows while the baseline is fitted (17.6 KB each at the on-board window).
pub const MAX_ONBOARD_COMMISSIONING_FLIGHTS: u8 = 3;

/// Windows read back from flash at the last commissioning flight, at most.
const KEPT: usize = MAX_ONBOARD_COMMISSIONING_FLIGHTS as usize - 1;

impl<'c, const W: usize, const P: usize> HealthMonitor<'c, W, P> {
    /// One flight of a commissioning that has kept `kept` of `planned` windows (module doc). Not
    /// inlined: its frame stays off an ordinary flight's stack.
    #[inline(never)]
    pub(super) fn commissioning_flight(
        &self,
        trace: &ConditionedWindow<W>,
        acquired: &Acquired,
        record: &mut HealthRecord,
        hooks: &mut impl FlightHooks,
        planned: u8,
        kept: u8,
    ) -> Result<Flight, MonitorError> {
        let usable = !acquired.summary.is_sensor_fault() && acquired.rate_ok(&self.params);
        if usable && kept.saturating_add(1) >= planned {
            return self.last_commissioning_flight(trace, acquired, record, hooks, kept);
        }
        let next = if !usable {
            Commissioning::Collecting { planned, kept }
        } else if hooks.keep_window(kept, trace, acquired.temperature_c) {
            Commissioning::Collecting { planned, kept: kept + 1 }
        } else {
            Commissioning::Refused(CommissioningRefusal::Failed)
        };
        // a sensor fault outranks either abstention, as in an ordinary flight
        let reason = if acquired.rate_ok(&self.params) { Abstain::Commissioning } else { Abstain::RateMismatch };
        let report = HealthReport::new(FaultVector::HEALTHY, &self.params, f32::NAN, 0, 0, None)
            .with_acquisition(&acquired.summary)
            .abstaining(Status::Inconclusive(reason));
        let number = record.flights().saturating_add(1);
        record.new_flight(&report, true);
        record.set_commissioning(next);
        Ok(Flight {
            number,
            temperature_c: acquired.temperature_c,
            sensors: acquired.summary.sensors,
            start: Start::Cold(ColdReason::NoPrior),
            cold: true,
            report,
            warm: None,
            pooled: None,
            commissioning: Some(next),
        })
    }

    /// The last commissioning flight: the joint fit, then the flight diagnosed against the
    /// baseline, which is kept when the flight reads HEALTHY (module doc).
    fn last_commissioning_flight(
        &self,
        trace: &ConditionedWindow<W>,
        acquired: &Acquired,
        record: &mut HealthRecord,
        hooks: &mut impl FlightHooks,
        kept: u8,
    ) -> Result<Flight, MonitorError> {
        hooks.commissioning_start();
        let fitted = self.fit_baseline(trace, acquired.temperature_c, kept, hooks);
        hooks.commissioning_end();
        let (base, candidate) = match fitted {
            Some(b) => match b.out_of_tolerance() {
                Some((param, z)) => {
                    let refusal = CommissioningRefusal::OutOfTolerance { param: param as u8, z };
                    (self.params, Err(refusal))
                }
                None => (b.params, Ok(UnitBaseline { z: b.z, sigma_z: b.sigma_z, resolved: b.resolved })),
            },
            None => (self.params, Err(CommissioningRefusal::Failed)),
        };
        let mut flight = self.fly(trace, acquired, record, hooks, &base)?;
        let state = match candidate {
            Ok(baseline) if flight.report.status == Status::Healthy => Commissioning::Commissioned(baseline),
            Ok(_) => Commissioning::Refused(CommissioningRefusal::NotHealthy(flight.report.status)),
            Err(refusal) => Commissioning::Refused(refusal),
        };
        record.set_commissioning(state);
        flight.commissioning = Some(state);
        Ok(flight)
    }

    /// The baseline fitted to the `kept` windows read back through `hooks` and to `trace`;
    /// `None` when a window cannot be read or the fit is refused. Not inlined: the windows read
    /// back live in this frame alone, not beside the identification's.
    #[inline(never)]
    fn fit_baseline(
        &self,
        trace: &ConditionedWindow<W>,
        temperature_c: f32,
        kept: u8,
        hooks: &mut impl FlightHooks,
    ) -> Option<Baseline> {
        let n = usize::from(kept);
        if n > KEPT {
            return None;
        }
        let mut windows: [ConditionedWindow<W>; KEPT] = core::array::from_fn(|_| ConditionedWindow::new());
        // the current flight first, then the windows read back
        let mut temperatures = [temperature_c; KEPT + 1];
        for (slot, (window, t)) in windows.iter_mut().zip(temperatures.iter_mut().skip(1)).enumerate().take(n) {
            *t = hooks.load_window(slot as u8, window)?;
        }
        let fit = |t| configured_fit(t, self.params, self.command, &self.config).ok();
        let [w0, w1] = &windows;
        let current = fit(trace)?;
        // a window not read back has no fit; its place in the array below is filled by the
        // current flight's and sliced off
        let first = if n > 0 { Some(fit(w0)?) } else { None };
        let second = if n > 1 { Some(fit(w1)?) } else { None };
        let flights = [
            CommissioningFlight { fit: &current, temperature_c: temperatures[0] },
            CommissioningFlight { fit: first.as_ref().unwrap_or(&current), temperature_c: temperatures[1] },
            CommissioningFlight { fit: second.as_ref().unwrap_or(&current), temperature_c: temperatures[2] },
        ];
        let flights = flights.get(..=n)?;
        let mut objective =
            BaselineFit::new(flights, self.params, self.tolerances, self.config.independent_frames_per_block).ok()?;
        commission::<W, SWARM_PARTICLES>(&mut objective, SWARM_ITERATIONS, self.config.seed, &mut || {
            hooks.commissioning_tick()
        })
        .ok()
    }
}
