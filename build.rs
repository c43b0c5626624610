//! Build script.
//!
//! 1. Puts `memory.x` on the link path and adds the Cortex-M link scripts (`link.x`, and
//!    `defmt.x`, without which defmt links but logs nothing), only for the thumb target. They are
//!    `rustc-link-arg`, not `-arg-bins`, so the QEMU test binary links with them too.
//! 2. With the `firmware` feature, writes `$OUT_DIR/model_config.rs` for `src/main.rs`:
//!    - `MODEL_EFFECTS`: the monitor model's effect terms, from the model configuration file named
//!      by `EMA_MODEL_CONFIG` (parsed by `parse_model_config` of the build dependency
//!      `ema-model-config`, the core's `ema_monitor::effects`); unset → `ModelEffects::NONE` (the
//!      paper's model);
//!    - `PARAMS`: the actuator's parameters, from the TOML parameter file named by `EMA_PARAMS`
//!      (read by the build dependency `ema-params-file`, the `ema` command line's reader, with the
//!      `toml` crate, which never reaches the MCU binary, and checked by `EmaParams::check` of
//!      `ema-model-config`); unset → `EmaParams::NOMINAL`;
//!    - `PROFILE`: the manoeuvre the monitor model is driven by, named by `EMA_PROFILE`:
//!      `standard` (`Profile::STANDARD`, the default) or `pbit` (`Profile::PBIT`, the pre-flight
//!      built-in test); `PROFILE_NAME` is its name, for the log;
//!    - `TRACE`: the built-in phase-current trace, `include_bytes!` of `EMA_TRACE` (default
//!      `traces/standard.ematrace`, or `traces/pbit.ematrace` with `EMA_PROFILE=pbit`), checked
//!      here to be a packed trace (magic and length; its checksum is the firmware's to check);
//!    - `MODEL_CONFIG_SOURCE`, `PARAMS_SOURCE` and `TRACE_SOURCE`: the paths, for the log.
//!
//!    Relative paths resolve from the repository root (`CARGO_MANIFEST_DIR`). A bad file stops the
//!    build with its path, line and field.
use std::{env, fs, path::Path, path::PathBuf};

use ema_model_config::effects::{parse_model_config, EffectId, ModelEffects};
use ema_model_config::params::FIELDS;

/// Default built-in trace, relative to the repository root.
const DEFAULT_TRACE: &str = "traces/standard.ematrace";

/// Default built-in trace with `EMA_PROFILE=pbit`.
const PBIT_TRACE: &str = "traces/pbit.ematrace";

/// The manoeuvre named by `EMA_PROFILE`: its Rust expression, its name and its default trace.
fn profile_constant() -> Result<(&'static str, &'static str, &'static str), String> {
    println!("cargo:rerun-if-env-changed=EMA_PROFILE");
    match env::var("EMA_PROFILE").as_deref() {
        Ok("") | Ok("standard") | Err(env::VarError::NotPresent) => {
            Ok(("Profile::STANDARD", "standard", DEFAULT_TRACE))
        }
        Ok("pbit") => Ok(("Profile::PBIT", "pbit", PBIT_TRACE)),
        Ok(other) => Err(format!("EMA_PROFILE: '{other}' is neither 'standard' nor 'pbit'")),
        Err(env::VarError::NotUnicode(_)) => Err("EMA_PROFILE: not UTF-8; expected 'standard' or 'pbit'".into()),
    }
}

fn main() {
    let target = env::var("TARGET").unwrap_or_default();
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rerun-if-changed=build.rs");
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    if env::var_os("CARGO_FEATURE_FIRMWARE").is_some() {
        if let Err(message) = write_model_config(&out) {
            // one readable line; `cargo:warning` repeats it above cargo's own build-script dump
            println!("cargo:warning={message}");
            eprintln!("error: {message}");
            std::process::exit(1);
        }
    }
    if !target.starts_with("thumb") {
        return;
    }
    fs::copy("memory.x", out.join("memory.x")).expect("memory.x is readable");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg=-Tlink.x");
    if env::var_os("CARGO_FEATURE_DEFMT").is_some() {
        println!("cargo:rustc-link-arg=-Tdefmt.x");
    }
}

/// A path from the environment, relative ones resolved from the repository root.
fn resolve(value: &str) -> PathBuf {
    let root = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    root.join(value)
}

/// A Rust string literal of a path (which must be UTF-8 to be `include_bytes!`-ed).
fn literal(path: &Path, var: &str) -> Result<String, String> {
    path.to_str().map(|p| format!("{p:?}")).ok_or_else(|| format!("{var}: path '{}' is not UTF-8", path.display()))
}

/// The Rust expression of the parameter set named by `EMA_PARAMS` (every field as the exact bits
/// of its `f32`), and the path as given; unset → `EmaParams::NOMINAL` itself.
fn params_constant() -> Result<(String, String), String> {
    println!("cargo:rerun-if-env-changed=EMA_PARAMS");
    let value = match env::var("EMA_PARAMS") {
        Ok(value) if !value.is_empty() => value,
        Ok(_) | Err(env::VarError::NotPresent) => return Ok(("EmaParams::NOMINAL".to_owned(), String::new())),
        Err(env::VarError::NotUnicode(v)) => {
            return Err(format!("EMA_PARAMS: path '{}' is not UTF-8", PathBuf::from(v).display()))
        }
    };
    let path = resolve(&value);
    println!("cargo:rerun-if-changed={}", path.display());
    let text = fs::read_to_string(&path).map_err(|e| format!("EMA_PARAMS: cannot read '{}': {e}", path.display()))?;
    let params = ema_params_file::parse_params(&text).map_err(|e| format!("EMA_PARAMS: {}: {e}", path.display()))?;
    let fields: Vec<String> = FIELDS
        .iter()
        .map(|f| {
            format!("\n    {}: f32::from_bits({:#010x}), // {:?}", f.name, f.get(&params).to_bits(), f.get(&params))
        })
        .collect();
    Ok((format!("EmaParams {{{}\n}}", fields.concat()), value))
}

/// Writes `$OUT_DIR/model_config.rs` from `EMA_MODEL_CONFIG`, `EMA_PARAMS` and `EMA_TRACE`.
fn write_model_config(out: &Path) -> Result<(), String> {
    println!("cargo:rerun-if-env-changed=EMA_MODEL_CONFIG");
    println!("cargo:rerun-if-env-changed=EMA_TRACE");

    // model configuration
    let (effects, config_source) = match env::var("EMA_MODEL_CONFIG") {
        Ok(value) if !value.is_empty() => {
            let path = resolve(&value);
            println!("cargo:rerun-if-changed={}", path.display());
            let text = fs::read_to_string(&path)
                .map_err(|e| format!("EMA_MODEL_CONFIG: cannot read '{}': {e}", path.display()))?;
            let effects =
                parse_model_config(&text).map_err(|e| format!("EMA_MODEL_CONFIG: {}: {e}", path.display()))?;
            (effects, value)
        }
        Ok(_) | Err(env::VarError::NotPresent) => (ModelEffects::NONE, String::new()),
        Err(env::VarError::NotUnicode(v)) => {
            return Err(format!("EMA_MODEL_CONFIG: path '{}' is not UTF-8", PathBuf::from(v).display()))
        }
    };

    let (params, params_source) = params_constant()?;
    let (profile, profile_name, default_trace) = profile_constant()?;

    // trace
    let trace_value = match env::var("EMA_TRACE") {
        Ok(value) if !value.is_empty() => value,
        Ok(_) | Err(env::VarError::NotPresent) => default_trace.to_owned(),
        Err(env::VarError::NotUnicode(v)) => {
            return Err(format!("EMA_TRACE: path '{}' is not UTF-8", PathBuf::from(v).display()))
        }
    };
    let trace = resolve(&trace_value);
    println!("cargo:rerun-if-changed={}", trace.display());
    let bytes = fs::read(&trace).map_err(|e| format!("EMA_TRACE: cannot read '{}': {e}", trace.display()))?;
    check_trace(&bytes).map_err(|m| format!("EMA_TRACE: '{}': {m}", trace.display()))?;

    let severities: Vec<String> = EffectId::ALL.iter().map(|&e| format!("{:?}_f32", effects.get(e))).collect();
    let code = format!(
        "// Generated by build.rs from EMA_MODEL_CONFIG, EMA_PARAMS, EMA_PROFILE and EMA_TRACE; do not edit.\n\
         \n\
         /// The monitor model's effect terms (`EMA_MODEL_CONFIG`; none when unset), in `EffectId::ALL` order.\n\
         const MODEL_EFFECTS: ModelEffects = match ModelEffects::from_severities([{severities}]) {{\n\
         \x20   Some(e) => e,\n\
         \x20   None => panic!(\"EMA_MODEL_CONFIG: severity outside [0, 1]\"),\n\
         }};\n\
         \n\
         /// The model configuration file as given (empty: none).\n\
         const MODEL_CONFIG_SOURCE: &str = {config_source:?};\n\
         \n\
         /// The actuator's parameters (`EMA_PARAMS`, checked by `EmaParams::check`; nominal when unset).\n\
         const PARAMS: EmaParams = {params};\n\
         \n\
         /// The parameter file as given (empty: none, the nominal actuator).\n\
         const PARAMS_SOURCE: &str = {params_source:?};\n\
         \n\
         /// The manoeuvre (`EMA_PROFILE`, default `standard`).\n\
         const PROFILE: Profile = {profile};\n\
         \n\
         /// The manoeuvre's name: `standard` or `pbit`.\n\
         const PROFILE_NAME: &str = {profile_name:?};\n\
         \n\
         /// The built-in trace as given (`EMA_TRACE`, default `{default_trace}`).\n\
         const TRACE_SOURCE: &str = {trace_value:?};\n\
         \n\
         /// The built-in trace: a packed phase-current recording (`ema_monitor::trace`), in flash.\n\
         static TRACE: &[u8] = include_bytes!({trace_path});\n",
        severities = severities.join(", "),
        trace_path = literal(&trace, "EMA_TRACE")?,
    );
    let file = out.join("model_config.rs");
    // only rewrite on change, so an unchanged configuration does not rebuild the firmware
    if fs::read_to_string(&file).ok().as_deref() != Some(code.as_str()) {
        fs::write(&file, code).map_err(|e| format!("cannot write '{}': {e}", file.display()))?;
    }
    Ok(())
}

/// The packed-trace header checks that need no decoding (magic `EMA1`, `EMA2` or `EMA3`, non-zero
/// rate, trigger frame within the frames, exact length); the firmware re-checks everything with
/// `PackedTrace::parse` at start-up, the `EMA3` checksum included: a corrupted trace builds, and
/// the firmware refuses it as it would on a board (`summary: REFUSED trace Checksum`, which
/// `scripts/parity` compares with the host's).
fn check_trace(bytes: &[u8]) -> Result<(), String> {
    if bytes.len() < 12 {
        return Err(format!("{} bytes, shorter than the 12-byte packed-trace header", bytes.len()));
    }
    let (header, checksum) = match &bytes[..4] {
        b"EMA1" => (12, 0),
        b"EMA2" if bytes.len() >= 16 => (16, 0),
        b"EMA3" if bytes.len() >= 20 => (16, 4),
        b"EMA2" => return Err(format!("{} bytes, shorter than the 16-byte EMA2 header", bytes.len())),
        b"EMA3" => return Err(format!("{} bytes, shorter than the 16-byte EMA3 header and its checksum", bytes.len())),
        _ => {
            return Err("not a packed trace (does not start with EMA1, EMA2 or EMA3); pack a recording with \
                 `ema firmware-trace --from`"
                .into())
        }
    };
    let word = |at: usize| u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]) as usize;
    let (frames, rate) = (word(4), word(8));
    if rate == 0 {
        return Err("sample rate 0 in the header".into());
    }
    if header == 16 && word(12) > frames {
        return Err(format!("trigger frame {} past the last of {frames} frames", word(12)));
    }
    let expected = header + (3 * frames).div_ceil(2) * 3 + checksum;
    if bytes.len() != expected {
        return Err(format!("{} bytes, but {frames} frames need {expected}", bytes.len()));
    }
    Ok(())
}
