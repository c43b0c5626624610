//! The model configuration file on arbitrary input: the core's [`parse_model_config`] on any
//! UTF-8 text (the parser of the firmware build's `EMA_MODEL_CONFIG` and of `ema identify
//! --model-config`), and the CLI's bounded file reader [`read_model_config_from`] on any bytes.
//! Every input gives a value, never a panic. An accepted file has every severity in
//! `[0, MAX_SEVERITY]` and writes back (`effect ID SEVERITY` lines) to the same effects; a refused
//! one names a line of the file and text found in it.
#![no_main]

use std::path::Path;

use ema_cli::identify::{read_model_config_from, MAX_MODEL_CONFIG_BYTES};
use ema_monitor::effects::{parse_model_config, EffectId, ModelEffects, MAX_SEVERITY};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let from_reader = read_model_config_from(data, Path::new("fuzz.config"));
    let Ok(text) = std::str::from_utf8(data) else {
        assert!(from_reader.is_err(), "bytes that are not UTF-8 are refused");
        return;
    };
    let parsed = parse_model_config(text);
    if data.len() <= MAX_MODEL_CONFIG_BYTES {
        assert_eq!(parsed.is_ok(), from_reader.is_ok());
    } else {
        assert!(from_reader.is_err(), "a file beyond the limit is refused");
    }
    match parsed {
        Ok(effects) => {
            let mut written = String::new();
            for id in EffectId::ALL {
                let s = effects.get(id);
                assert!((0.0..=MAX_SEVERITY).contains(&s), "{} {s}", id.id());
                written.push_str(&format!("effect {} {s}\n", id.id()));
            }
            let back: ModelEffects = parse_model_config(&written).expect("written back, read back");
            assert_eq!(back, effects);
        }
        Err(e) => {
            assert!(e.line >= 1 && e.line <= text.lines().count(), "line {} of {}", e.line, text.lines().count());
            assert!(text.contains(e.found), "{:?}", e.found);
            let _ = e.to_string();
        }
    }
    if let Ok(from_reader) = from_reader {
        assert_eq!(Ok(from_reader), parse_model_config(text).map_err(|_| ()));
    }
});
