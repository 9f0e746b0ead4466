#!/usr/bin/env bash
# Runs every test of the workspace on a fresh machine, installing what it needs first.
#
#   0. the pinned compiler (rust-toolchain.toml);
#   1. the Cortex-M4F target, flip-link (the firmware's linker: a stack overflow becomes a
#      fault), QEMU (Debian's qemu-system-arm), the ARM binutils (objdump and addr2line,
#      for the static bounds of the control step and task in the benchmark gate) and
#      pymavlink (the MAVLink codec's cross-check);
#   2. both firmware boards cross-built (the real board is the default build, the QEMU board
#      an explicit feature): the core links for the STM32F405 with no allocator
#      (a use of `alloc` would fail this link);
#   3. the qemu board run in QEMU's netduinoplus2 (an emulated STM32F405): its power-on
#      self-test steps the controller once and exits 0 only if the step was right; then the
#      qemu board built with the path benchmark, whose scripted sortie must visit every path;
#   4. formatting, lints (clippy on every target, warnings denied) and the API docs (rustdoc,
#      warnings denied: a broken intra-doc link fails);
#   5. every test, benchmark (run once, as a test) and doc test of the workspace on the host,
#      the processor-in-the-loop tests flying the ELF of step 2 inside QEMU.
set -euo pipefail
cd "$(dirname "$0")/.."

# The pinned compiler (rust-toolchain.toml: the gate's figures were measured with it). rustup
# installs it with its components and target on first use; where nothing can be downloaded
# but the machine's stable is that very release, stable serves under the pinned name.
pinned=$(sed -n 's/^channel = "\(.*\)"$/\1/p' rust-toolchain.toml)
if ! rustup toolchain list | grep -q "^$pinned-"; then
    if ! rustup toolchain install "$pinned" --profile minimal \
        --component rustfmt,clippy --target thumbv7em-none-eabihf; then
        stable_rustc=$(rustc +stable --version)
        case "$stable_rustc" in
            "rustc $pinned "*)
                host=$(rustc +stable -vV | sed -n 's/^host: //p')
                ln -s "$(rustc +stable --print sysroot)" \
                    "${RUSTUP_HOME:-$HOME/.rustup}/toolchains/$pinned-$host" ;;
            *) echo "cannot install Rust $pinned, and stable is $stable_rustc" >&2; exit 1 ;;
        esac
    fi
fi
rustup target add thumbv7em-none-eabihf
rustup component add rustfmt clippy
command -v flip-link >/dev/null || cargo install flip-link --locked
if ! command -v qemu-system-arm >/dev/null || ! command -v arm-none-eabi-objdump >/dev/null \
    || ! command -v arm-none-eabi-addr2line >/dev/null; then
    apt-get update
    apt-get install -y --no-install-recommends qemu-system-arm binutils-arm-none-eabi
fi
# pymavlink: the MAVLink codec's cross-check (autopilot-link/tests/mavlink_check.py). Debian's
# python3 is "externally managed" (PEP 668), so pip is retried with --break-system-packages.
if ! python3 -c 'import pymavlink' 2>/dev/null; then
    if ! command -v python3 >/dev/null || ! python3 -m pip --version >/dev/null 2>&1; then
        apt-get update
        apt-get install -y --no-install-recommends python3 python3-pip
    fi
    python3 -m pip install pymavlink \
        || python3 -m pip install --break-system-packages pymavlink
fi

# The real board (the default build) and the QEMU board (chosen explicitly, its own target dir).
cargo build --locked -p firmware --target thumbv7em-none-eabihf --release
cargo build --locked -p firmware --target thumbv7em-none-eabihf --release \
    --no-default-features --features qemu --target-dir target/qemu
timeout 120 cargo run --locked -p firmware --target thumbv7em-none-eabihf --release \
    --no-default-features --features qemu --target-dir target/qemu
# The path benchmark (the `bench` feature, off in the flight build): its scripted sortie must
# visit every path of the step on the emulated MCU ("script_ok": true).
cargo build --locked -p firmware --target thumbv7em-none-eabihf --release \
    --no-default-features --features qemu,bench --target-dir target/qemu-bench
timeout 120 qemu-system-arm -machine netduinoplus2 -cpu cortex-m4 -icount shift=0 \
    -display none -monitor none -serial null \
    -semihosting-config enable=on,target=native,arg=firmware,arg=bench \
    -kernel target/qemu-bench/thumbv7em-none-eabihf/release/firmware | tee target/qemu-bench/bench.txt
grep -q '"script_ok": true' target/qemu-bench/bench.txt
cargo fmt --all -- --check
cargo clippy --locked --workspace --all-targets -- -D warnings
RUSTDOCFLAGS="-D warnings" cargo doc --locked --workspace --no-deps
export IBVS_FIRMWARE_ELF="$PWD/target/qemu/thumbv7em-none-eabihf/release/firmware"
export IBVS_FIRMWARE_F405_ELF="$PWD/target/thumbv7em-none-eabihf/release/firmware"
cargo test --locked --workspace --all-targets
cargo test --locked --workspace --doc
# The cycle model applied to every path of the path benchmark's sortie as it ran (QEMU's
# execution log), each path within the same ELF's static bound: a modelled run above the
# bound fails (docs/benchmarks.md, "The cycle bound"). The binary the test build above made
# (`cargo run` would build it again with other features: 90 s on 2 cores).
target/debug/target-bench \
    --path-cycles target/qemu-bench/thumbv7em-none-eabihf/release/firmware
