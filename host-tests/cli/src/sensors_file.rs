//! The phase-current measurement chain of `ema simulate --sensors PRESET|FILE.toml`
//! ([`ema_reference::SensorChain`]; docs/sensors.md): a preset by name, or a sensor file.
//!
//! A sensor file is a flat TOML table. `preset = "NAME"` names the chain it starts from (the
//! ideal one without it); every other key replaces one of its values:
//!
//! | key | value |
//! |---|---|
//! | `adc_bits` | the ADC's resolution, a whole number of bits (8 to 16) |
//! | `full_scale_a` | the ADC spans `±full_scale_a` amperes, zero at mid-scale |
//! | `offset_a` | zero error of phases a, b, c, A |
//! | `gain_error` | gain error of phases a, b, c, relative (0.01 reads 1 % high) |
//! | `bandwidth_hz` | first-order bandwidth of phases a, b, c, Hz |
//! | `skew_us` | conversion instant of phases a, b, c after the frame instant, µs |
//!
//! A per-phase key holds an array of three numbers `[a, b, c]`, or one number for all three. As
//! in a parameter file ([`crate::params_file`]), an unknown (misspelt) key is refused rather than
//! ignored, and every error names the line and the key (and the phase of an array's element):
//! a value that is not a number, an array of another length, a value outside its range
//! ([`SensorChain::check`]).

use std::fmt::Write as _;
use std::path::Path;

use ema_reference::{SensorChain, SensorChainError};

use crate::error::CliError;
use crate::input::read_text;
use crate::params_file::{distance, flat_entries, FlatEntry, ParamsFileError};

/// Largest sensor file read (a commented one is about 1 kB).
pub const MAX_SENSORS_BYTES: usize = 64 * 1024;

/// The keys of a sensor file besides `preset`, in the order of the table above.
pub const KEYS: [&str; 6] = ["adc_bits", "full_scale_a", "offset_a", "gain_error", "bandwidth_hz", "skew_us"];

/// The phases' names, in the order of an array's elements.
const PHASES: [&str; 3] = ["a", "b", "c"];

/// The names of the presets, comma separated (for messages).
pub fn preset_names() -> String {
    SensorChain::PRESETS.iter().map(|(name, _, _)| *name).collect::<Vec<_>>().join(", ")
}

/// The chain `--sensors` names and how the sidecar records its source: a preset
/// ([`SensorChain::PRESETS`]) by its name, or a sensor file by its path as given; checked against
/// the actuator's control period `control_period_s` (a skew must fall within one).
pub fn resolve_sensors(name: &str, control_period_s: f64) -> Result<SensorChain, CliError> {
    if let Some(chain) = SensorChain::preset(name) {
        return Ok(chain);
    }
    let path = Path::new(name);
    if !path.exists() {
        return Err(CliError::flag(
            "--sensors",
            format!("'{name}' is neither a preset ({}) nor an existing file", preset_names()),
        ));
    }
    read_sensors(path, control_period_s)
}

/// Reads and checks a sensor file; errors name the file, line and key.
pub fn read_sensors(path: &Path, control_period_s: f64) -> Result<SensorChain, CliError> {
    let file =
        std::fs::File::open(path).map_err(|e| CliError::input(path, format!("cannot read the sensor file: {e}")))?;
    let text = read_text(file, MAX_SENSORS_BYTES).map_err(|e| e.at(path))?;
    parse_sensors(&text, control_period_s).map_err(|e| CliError::input_line(path, e.line, e.key.as_deref(), e.message))
}

/// An error at `entry`'s value.
fn at_value(entry: &FlatEntry, message: String) -> ParamsFileError {
    ParamsFileError { line: entry.value_line, key: Some(entry.name.clone()), message }
}

/// A TOML number as `f64` (a float or an integer), or `None`.
fn number(value: &toml::Value) -> Option<f64> {
    match value {
        toml::Value::Float(x) => Some(*x),
        toml::Value::Integer(i) => Some(*i as f64),
        _ => None,
    }
}

/// The three values of a per-phase key: an array `[a, b, c]` or one number for all three.
fn per_phase(entry: &FlatEntry, example: &str) -> Result<[f64; 3], ParamsFileError> {
    let name = &entry.name;
    if let Some(x) = number(&entry.value) {
        return Ok([x; 3]);
    }
    let toml::Value::Array(items) = &entry.value else {
        return Err(at_value(
            entry,
            format!(
                "{name} = {} is neither a number nor an array [a, b, c] (write e.g. {name} = {example})",
                entry.value
            ),
        ));
    };
    if items.len() != 3 {
        return Err(at_value(
            entry,
            format!(
                "{name} has {} values; give one per phase, [a, b, c] (e.g. {name} = {example}), or one number for all three",
                items.len()
            ),
        ));
    }
    let mut out = [0.0; 3];
    for (j, item) in items.iter().enumerate() {
        out[j] = number(item).ok_or_else(|| {
            at_value(
                entry,
                format!("{name}[{j}] (phase {}) = {item} is not a number (e.g. {name} = {example})", PHASES[j]),
            )
        })?;
    }
    Ok(out)
}

/// Reads a sensor file's text (module documentation) and checks the chain it gives against the
/// control period `control_period_s`.
pub fn parse_sensors(text: &str, control_period_s: f64) -> Result<SensorChain, ParamsFileError> {
    let entries = flat_entries(text)?;
    let mut chain = SensorChain::IDEAL;
    let mut base = "ideal".to_owned();
    if let Some(entry) = entries.iter().find(|e| e.name == "preset") {
        let name = entry.value.as_str().unwrap_or_default();
        chain = SensorChain::preset(name).ok_or_else(|| {
            at_value(entry, format!("preset = {} is not a preset; the presets are {}", entry.value, preset_names()))
        })?;
        base = name.to_owned();
    }
    for entry in entries.iter().filter(|e| e.name != "preset") {
        let name = entry.name.as_str();
        match name {
            "adc_bits" => {
                let bits = match &entry.value {
                    toml::Value::Integer(i) => u32::try_from(*i).ok(),
                    _ => None,
                };
                chain.adc.bits = bits.ok_or_else(|| {
                    at_value(
                        entry,
                        format!("adc_bits = {} is not a whole number of bits (e.g. adc_bits = 12)", entry.value),
                    )
                })?;
            }
            "full_scale_a" => {
                chain.adc.full_scale_a = number(&entry.value).ok_or_else(|| {
                    at_value(
                        entry,
                        format!("full_scale_a = {} is not a number (e.g. full_scale_a = 20.0)", entry.value),
                    )
                })?;
            }
            "offset_a" => {
                let v = per_phase(entry, "[0.15, -0.10, 0.12]")?;
                (0..3).for_each(|j| chain.phases[j].offset_a = v[j]);
            }
            "gain_error" => {
                let v = per_phase(entry, "[0.010, -0.008, 0.005]")?;
                (0..3).for_each(|j| chain.phases[j].gain_error = v[j]);
            }
            "bandwidth_hz" => {
                let v = per_phase(entry, "20000")?;
                (0..3).for_each(|j| chain.phases[j].bandwidth_hz = v[j]);
            }
            "skew_us" => {
                let v = per_phase(entry, "[0, 5, 10]")?;
                (0..3).for_each(|j| chain.phases[j].skew_s = v[j] / 1e6);
            }
            _ => {
                let hint = KEYS
                    .iter()
                    .chain(["preset"].iter())
                    .map(|k| (distance(name, k), *k))
                    .filter(|(d, _)| *d <= 4)
                    .min()
                    .map_or_else(
                        || format!(" (the keys are preset, {})", KEYS.join(", ")),
                        |(_, near)| format!(" (did you mean {near}?)"),
                    );
                return Err(ParamsFileError {
                    line: entry.line,
                    key: Some(name.to_owned()),
                    message: format!("unknown key '{name}'{hint}"),
                });
            }
        }
    }
    chain.check(control_period_s).map_err(|e| range_error(&e, &entries, &base))?;
    Ok(chain)
}

/// A range error of the chain, at the line of its key (or naming the preset it came from).
fn range_error(e: &SensorChainError, entries: &[FlatEntry], base: &str) -> ParamsFileError {
    let element = e.phase.map_or_else(String::new, |j| format!("[{j}] (phase {})", PHASES[j.min(2)]));
    let message = format!("{}{element}: {}", e.field, e.message);
    match entries.iter().find(|entry| entry.name == e.field) {
        Some(entry) => at_value(entry, message),
        None => ParamsFileError {
            line: 0,
            key: Some(e.field.to_owned()),
            message: format!("{message} (not in the file: the {base} chain's value)"),
        },
    }
}

/// The chain as a sensor file (every key, the per-phase ones as arrays), which [`parse_sensors`]
/// reads back to exactly `chain`; `source` goes in its opening comment.
pub fn to_toml(chain: &SensorChain, source: &str) -> String {
    let per_phase = |f: &dyn Fn(usize) -> f64| format!("[{:?}, {:?}, {:?}]", f(0), f(1), f(2));
    let mut out = format!("# ema-monitor phase-current sensor chain ({source}; docs/sensors.md)\n");
    let _ = writeln!(out, "adc_bits = {}", chain.adc.bits);
    let _ = writeln!(out, "full_scale_a = {:?}", chain.adc.full_scale_a);
    let _ = writeln!(out, "offset_a = {}", per_phase(&|j| chain.phases[j].offset_a));
    let _ = writeln!(out, "gain_error = {}", per_phase(&|j| chain.phases[j].gain_error));
    let _ = writeln!(out, "bandwidth_hz = {}", per_phase(&|j| chain.phases[j].bandwidth_hz));
    let _ = writeln!(out, "skew_us = {}", per_phase(&|j| chain.phases[j].skew_s * 1e6));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const T: f64 = 1e-4;

    #[test]
    fn presets_and_files_give_the_same_chains() {
        for (name, chain, _) in SensorChain::PRESETS {
            assert_eq!(resolve_sensors(name, T).ok(), Some(chain), "{name}");
            assert_eq!(parse_sensors(&format!("preset = \"{name}\"\n"), T), Ok(chain), "{name}");
        }
        assert_eq!(parse_sensors("", T), Ok(SensorChain::IDEAL));
        let oneshot = "preset = \"nucleo-f446re\"\nskew_us = [0, 5, 10]\n";
        assert_eq!(parse_sensors(oneshot, T), Ok(SensorChain::NUCLEO_F446RE_ONESHOT));
        // one number for the three phases; integers for floats
        let chain =
            parse_sensors("bandwidth_hz = 5000\noffset_a = 0.1\nadc_bits = 14\nfull_scale_a = 50\n", T).expect("valid");
        assert!(chain.phases.iter().all(|p| p.bandwidth_hz == 5000.0 && p.offset_a == 0.1));
        assert_eq!((chain.adc.bits, chain.adc.full_scale_a), (14, 50.0));
    }

    #[test]
    fn a_written_chain_reads_back() {
        for (name, chain, _) in SensorChain::PRESETS {
            assert_eq!(parse_sensors(&to_toml(&chain, name), T), Ok(chain), "{name}");
        }
        let mut odd = SensorChain::NUCLEO_F446RE_ONESHOT;
        odd.phases[1].skew_s = 3.3e-6;
        odd.phases[2].bandwidth_hz = 12_345.6;
        odd.adc.bits = 16;
        assert_eq!(parse_sensors(&to_toml(&odd, "custom"), T), Ok(odd));
    }

    #[test]
    fn errors_name_the_line_the_key_and_the_phase() {
        for (text, line, key, needle) in [
            ("\nofset_a = [0.1, 0, 0]\n", 2, "ofset_a", "did you mean offset_a"),
            ("zzz = 1\n", 1, "zzz", "the keys are preset, adc_bits"),
            ("# c\noffset_a = [0.1, 0.2]\n", 2, "offset_a", "has 2 values; give one per phase"),
            ("gain_error = [0.01, \"x\", 0]\n", 1, "gain_error", "gain_error[1] (phase b) = \"x\" is not a number"),
            ("skew_us = \"5 us\"\n", 1, "skew_us", "neither a number nor an array"),
            ("adc_bits = 12.5\n", 1, "adc_bits", "not a whole number of bits"),
            ("\n\nadc_bits = 20\n", 3, "adc_bits", "20 bits is outside 8 to 16"),
            ("full_scale_a = -20\n", 1, "full_scale_a", "outside (0, 1000] A"),
            ("offset_a = [0, 0, 25]\n", 1, "offset_a", "offset_a[2] (phase c): 25 A is not inside the full scale"),
            ("gain_error = [0, 0.6, 0]\n", 1, "gain_error", "gain_error[1] (phase b)"),
            ("bandwidth_hz = [20000, 0, 20000]\n", 1, "bandwidth_hz", "not a positive bandwidth"),
            ("skew_us = [0, 5, 100]\n", 1, "skew_us", "skew_us[2] (phase c): 100 µs is outside [0, 100) µs"),
            ("skew_us = [-1, 0, 0]\n", 1, "skew_us", "skew_us[0] (phase a)"),
            ("offset_a = nan\n", 1, "offset_a", "offset_a[0] (phase a)"),
            ("preset = \"nucleo\"\n", 1, "preset", "the presets are ideal, nucleo-f446re"),
        ] {
            let e = parse_sensors(text, T).expect_err(text);
            assert_eq!((e.line, e.key.as_deref()), (line, Some(key)), "{text}: {e}");
            let shown = e.to_string();
            assert!(shown.starts_with(&format!("line {line}: ")) && shown.contains(needle), "{text}: {shown}");
        }
        // a value from the preset that the control period refuses: no line, the preset named
        let e = parse_sensors("preset = \"nucleo-f446re-oneshot\"\n", 8e-6).expect_err("10 µs skew in 8 µs");
        assert!(e.line == 0 && e.message.contains("nucleo-f446re-oneshot chain's value"), "{e}");
        let e = parse_sensors("offset_a 0.1\n", T).expect_err("syntax");
        assert!(e.line == 1 && e.message.contains("not valid TOML"), "{e}");
    }

    #[test]
    fn an_unknown_name_is_neither_preset_nor_file() {
        let e = resolve_sensors("no-such-chain.toml", T).expect_err("refused").to_string();
        assert!(e.starts_with("--sensors") && e.contains("'no-such-chain.toml' is neither a preset"), "{e}");
        assert!(e.contains("ideal, nucleo-f446re, nucleo-f446re-oneshot"), "{e}");
    }
}
