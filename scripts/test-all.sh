#!/usr/bin/env bash
# Runs every test of the workspace on a fresh machine, installing what it needs first.
#
#   1. the Cortex-M4F target and QEMU (Debian's qemu-system-arm);
#   2. a cross build of the flight-computer binary: the core links for the STM32F405 with
#      no allocator (a use of `alloc` would fail this link);
#   3. that binary run in QEMU's netduinoplus2 (an emulated STM32F405): it steps the
#      controller once and exits through semihosting with 0 only if the step was right;
#   4. formatting check;
#   5. every test, benchmark (run once, as a test) and doc test of the workspace, on the host.
set -euo pipefail
cd "$(dirname "$0")/.."

rustup target add thumbv7em-none-eabihf
rustup component add rustfmt
if ! command -v qemu-system-arm >/dev/null; then
    apt-get update
    apt-get install -y qemu-system-arm
fi

cargo build --locked -p firmware --target thumbv7em-none-eabihf --release
timeout 120 cargo run --locked -p firmware --target thumbv7em-none-eabihf --release
cargo fmt --all -- --check
cargo test --locked --workspace --all-targets
cargo test --locked --workspace --doc
