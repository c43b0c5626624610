//! `ema_cli::pooled`: the pooled identification of `ema identify A.csv B.csv …`
//! ([`crate::identify::pooled`]) at the path the tests and the flights-to-detection measurement
//! use.

pub use crate::identify::pooled::*;
