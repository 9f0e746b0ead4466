//! # firmware: the flight-computer binary (STM32F405, Cortex-M4F)
//!
//! Runs the docking controller (`ibvs-core`) behind the serial link protocol of
//! [`ibvs_core::wire`]: measurement frames in, command frames out.
//!
//! ```text
//! USART1 RX ─► interrupt ─► queue ─► app: FrameDecoder ─► Uplink ─► Controller::step
//!                                         (lockstep: per frame; free-running: per SysTick)
//! USART1 TX ◄──────────────────────── app: encode_downlink ◄─ output, counters, cost ◄┘
//! ```
//!
//! Layout (the quartiq/stabilizer pattern): [`app`] is the board-independent application
//! (embedded-io traits at its boundary, unit-tested on the host); `board` (bare metal only)
//! holds everything that touches the MCU, for two boards selected by cargo feature: `f405`
//! (default; real hardware) and `qemu` (QEMU's netduinoplus2). See `firmware/README.md` for
//! building, flashing, wiring and the processor-in-the-loop runs.
//!
//! At reset the firmware runs a power-on self-test ([`one_step::run`]: one controller step
//! on a canned input must enter approach with finite commands) before the link comes up.
//! On the host the same crate builds and its `main` runs that self-test and prints the
//! result, so `cargo build --workspace` and `cargo test --workspace` stay host builds.
//!
//! Invariant: no global allocator anywhere in this crate or below it (`ibvs-core` is
//! `no_std` without `alloc`); the board build would fail to link if anything allocated.
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

pub mod app;
pub mod boot;
// The `f405` board's clock arithmetic (crystal, PLL limits, crystal check): on the board and
// on the host, for its tests.
#[cfg(any(feature = "f405", not(target_os = "none")))]
pub mod clock;
// The `f405` board's flash driver under the configuration store: on the board and on the
// host, for its tests.
#[cfg(any(feature = "f405", not(target_os = "none")))]
pub mod flash;
// The brown-out level in the option bytes (read at boot; programmed by the provisioning
// build only): on the `f405` board and on the host, for its tests.
#[cfg(any(feature = "f405", not(target_os = "none")))]
pub mod option_bytes;
pub mod serial;
pub mod store;
// The path benchmark: on the boards only with the `bench` feature (it is 7 KB of flash the
// flight build does not carry); on the host always, for its tests.
#[cfg(any(feature = "bench", not(target_os = "none")))]
pub mod bench;
pub mod one_step;

#[cfg(target_os = "none")]
mod board;

/// Host entry point: runs the power-on self-test and prints the result.
#[cfg(not(target_os = "none"))]
fn main() -> std::process::ExitCode {
    match one_step::run() {
        Ok(out) => {
            println!(
                "firmware (host): one step ok: mode {:?}, command {:?}",
                out.mode, out.command
            );
            std::process::ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("firmware (host): one step FAILED: {e}");
            std::process::ExitCode::FAILURE
        }
    }
}
