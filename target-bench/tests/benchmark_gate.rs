//! The regression gate of the target benchmarks (docs/benchmarks.md, "The gate"), both ways:
//! the control step's maximum instructions, the codec's, the control path's stack, each
//! board's flash and static RAM, and the static bounds (the step's in instructions and
//! cycles, the whole control task's in instructions, cycles and microseconds at 168 MHz,
//! which must exist) must stay within the checked-in expectations
//! (`benchmarks/expected.json`): not above by more than its `tolerance_percent`, not below by
//! more than its `margin_percent` (an improvement is written into the file); every static
//! bound at least the figure it bounds as measured on the same ELF; every budget kept.
//!
//! It runs the benchmark runner (`target-bench --check`): every recorded docking workload
//! replayed through the `qemu` firmware in QEMU (exact instruction counts), the ELFs' sizes.
//! The firmware ELFs: `IBVS_FIRMWARE_ELF` (qemu board) and `IBVS_FIRMWARE_F405_ELF` (f405
//! board) when set, as `scripts/test-all.sh` does; otherwise the default build paths
//! (`target/qemu/thumbv7em-none-eabihf/release/firmware`, `target/thumbv7em-none-eabihf/...`),
//! which must exist: the runner builds nothing. Needs `qemu-system-arm`, like the PIL tests,
//! and the ARM binutils (`arm-none-eabi-objdump`, `arm-none-eabi-addr2line`) for the static
//! bounds.
//!
//! When a change moves a figure on purpose, update the expectation in the same change
//! (`docs/benchmarks.md`, "Updating the expectations"): that is the reviewed decision.

use std::path::Path;
use std::process::Command;

#[test]
fn step_instructions_cycle_bounds_stack_and_flash_stay_within_the_expectations() {
    let expected = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join("benchmarks")
        .join("expected.json");
    let out = Command::new(env!("CARGO_BIN_EXE_target-bench"))
        .arg("--check")
        .arg(&expected)
        .output()
        .expect("running target-bench");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    eprintln!("{stderr}\n{stdout}");
    assert!(
        out.status.success(),
        "target-bench --check {} failed ({}): a figure left its expectation's band, a static \
         bound fell under its measured figure, or the benchmark could not run; see its output \
         above",
        expected.display(),
        out.status
    );
}
