//! The exit statuses of `ema`: the contract a script or a CI pipeline reads without parsing the
//! output (docs/cli.md, "Exit codes").
//!
//! | status | meaning |
//! |---|---|
//! | 0 ([`SUCCESS`]) | a diagnosis (HEALTHY, DEGRADED, FAILING), or a command that is not a diagnosis and succeeded |
//! | 1 ([`RUNTIME_FAILURE`]) | a failure that is not the input's fault: writing an output or stdout failed, no worker thread |
//! | 2 ([`USAGE_ERROR`]) | a usage or input error: a bad flag, a bad or unusable file (the `error:` line says which) |
//! | 3 ([`INCONCLUSIVE`]) | the report is INCONCLUSIVE, whatever the reason |
//! | 4 ([`SENSOR_FAULT`]) | the report is SENSOR_FAULT |
//! | 5 ([`FAIL_ON`]) | `--fail-on LEVEL` was given and the diagnosis is at or above LEVEL |
//!
//! The diagnosing commands are `ema identify` (one recording, several pooled, or
//! `--firmware-trace`: the report's status) and `ema history FILE…` (the last flight's report as
//! the health record keeps it: the actuator's current state; [`crate::history`]). Every other
//! command, and `ema history --simulate` (a measurement of the method, like `ema campaign` and
//! `ema pod`), exits 0 when it succeeds. This module is a leaf: it depends on no other module of the crate.

use clap::ValueEnum;
use ema_monitor::health::Status;

/// A diagnosis, or a command that is not a diagnosis and succeeded.
pub const SUCCESS: u8 = 0;
/// A runtime failure that is not the input's fault (writing an output or stdout failed, or the
/// worker threads could not start).
pub const RUNTIME_FAILURE: u8 = 1;
/// A usage or input error: a bad flag, a bad or unusable file.
pub const USAGE_ERROR: u8 = 2;
/// The report is INCONCLUSIVE (any reason).
pub const INCONCLUSIVE: u8 = 3;
/// The report is SENSOR_FAULT.
pub const SENSOR_FAULT: u8 = 4;
/// `--fail-on LEVEL` was given and the diagnosis is at or above LEVEL.
pub const FAIL_ON: u8 = 5;

/// `--fail-on LEVEL`: the diagnosis from which the command exits [`FAIL_ON`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum FailOn {
    /// DEGRADED or FAILING.
    Degraded,
    /// FAILING.
    Failing,
}

/// The exit status of a report of status `status`, under `--fail-on` when given: 3 for
/// INCONCLUSIVE and 4 for SENSOR_FAULT (with or without `--fail-on`), 5 for a diagnosis at or
/// above the `--fail-on` level, 0 for any other diagnosis.
pub fn status_code(status: Status, fail_on: Option<FailOn>) -> u8 {
    match (status, fail_on) {
        (Status::Inconclusive(_), _) => INCONCLUSIVE,
        (Status::SensorFault, _) => SENSOR_FAULT,
        (Status::Failing, Some(_)) | (Status::Degraded, Some(FailOn::Degraded)) => FAIL_ON,
        (Status::Healthy | Status::Degraded | Status::Failing, _) => SUCCESS,
    }
}

/// What a command that succeeded prints on stdout, and its exit status.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Done {
    /// The text for stdout (`main` adds the final newline).
    pub stdout: String,
    /// The exit status.
    pub code: u8,
}

impl Done {
    /// A command that is not a diagnosis: exit status [`SUCCESS`].
    pub fn success(stdout: String) -> Self {
        Self { stdout, code: SUCCESS }
    }

    /// A report of status `status`: exit status [`status_code`].
    pub fn report(stdout: String, status: Status, fail_on: Option<FailOn>) -> Self {
        Self { stdout, code: status_code(status, fail_on) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ema_monitor::health::Abstain;

    #[test]
    fn every_status_has_its_code() {
        let degraded = Some(FailOn::Degraded);
        let failing = Some(FailOn::Failing);
        for (status, codes) in [
            (Status::Healthy, [0, 0, 0]),
            (Status::Degraded, [0, 5, 0]),
            (Status::Failing, [0, 5, 5]),
            (Status::Inconclusive(Abstain::PoorFit), [3, 3, 3]),
            (Status::SensorFault, [4, 4, 4]),
        ] {
            assert_eq!(
                [status_code(status, None), status_code(status, degraded), status_code(status, failing)],
                codes,
                "{status:?}"
            );
        }
    }
}
