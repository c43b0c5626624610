//! Puts this board's `memory.x` on the linker's search path (`link.x` includes it by name; the link
//! scripts themselves are `.cargo/config.toml`'s link arguments). The core's build script puts the
//! QEMU `memory.x` on the path too; cargo lists the package's own directory first, so this one is
//! found, and `scripts/check-board` checks the result (the vector table at 0x0800_0000). The
//! on-target tests also link embedded-test's script.
use std::{env, fs, path::PathBuf};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    fs::copy("memory.x", out.join("memory.x")).expect("memory.x is readable");
    println!("cargo:rustc-link-search={}", out.display());
    // the on-target tests (tests/on_target.rs) only: embedded-test's section of test cases, which
    // probe-rs reads from the ELF (the script is on the search path through embedded-test)
    println!("cargo:rustc-link-arg-tests=-Tembedded-test.x");
    // embedded-test's macro marks each test for rust-analyzer under this cfg
    println!("cargo::rustc-check-cfg=cfg(rust_analyzer)");
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rerun-if-changed=build.rs");
}
