//! Build script of the flight-computer binary: puts the workspace's `memory.x` on the linker's
//! search path, and adds defmt's linker script for the `f405` board.
//!
//! cortex-m-rt's `link.x` (passed as `-Tlink.x` by `.cargo/config.toml`) does
//! `INCLUDE memory.x`; the linker looks for it in its search path, so it is copied into
//! `OUT_DIR` and that directory is added. Only the bare-metal target links with `link.x`; on
//! the host the script does nothing but ask to be rerun when `memory.x` changes. The `f405`
//! board logs with defmt, whose `defmt.x` (on the search path through the defmt crate) must
//! be passed to the linker too; the `qemu` board does not link defmt, so it must not be.

use std::env;
use std::fs;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let manifest_dir = PathBuf::from(env::var("CARGO_MANIFEST_DIR")?);
    let memory_x = manifest_dir.join("..").join("memory.x");
    println!("cargo:rerun-if-changed={}", memory_x.display());
    println!("cargo:rerun-if-changed=build.rs");

    if env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none") {
        let out = PathBuf::from(env::var("OUT_DIR")?);
        fs::copy(&memory_x, out.join("memory.x"))
            .map_err(|e| format!("copying {}: {e}", memory_x.display()))?;
        println!("cargo:rustc-link-search={}", out.display());
        if env::var_os("CARGO_FEATURE_F405").is_some() {
            // The flight binary only: the link-time check (`nopanic`) does not use defmt.
            println!("cargo:rustc-link-arg-bin=firmware=-Tdefmt.x");
        }
    }
    Ok(())
}
