//! # firmware: the flight-computer binary (STM32F405, Cortex-M4F)
//!
//! At this stage a smoke binary: it links `ibvs-core` and runs ONE controller step
//! ([`one_step::run`]), so that the cross build, the link against `memory.x` and the absence
//! of any allocator are checked from the start. The real firmware (control task at the core's
//! period, camera and navigation links, actuator outputs) replaces it later.
//!
//! Layout (the quartiq/stabilizer pattern): everything that needs the board sits in
//! [`board`], compiled only for `target_os = "none"`; its crates are target-only
//! dependencies. On the host the same binary builds and its `main` runs the same step and
//! prints the result, so `cargo build --workspace` and `cargo test --workspace` stay host
//! builds.
//!
//! - target: `cargo run -p firmware --target thumbv7em-none-eabihf --release` runs it in QEMU
//!   (runner in `.cargo/config.toml`); QEMU's exit status is the check's (0 pass, 1 fail).
//! - host: `cargo run -p firmware` prints the step's mode and commands; exit status likewise.
//!
//! Invariant: no global allocator anywhere in this crate or below it (`ibvs-core` is
//! `no_std` without `alloc`); the board build would fail to link if anything allocated.
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

mod one_step;

#[cfg(target_os = "none")]
mod board;

/// Host entry point: runs the same single step as the board and prints the result.
#[cfg(not(target_os = "none"))]
fn main() -> std::process::ExitCode {
    match one_step::run() {
        Ok(out) => {
            let c = out.command;
            println!(
                "firmware (host): one step ok: mode {:?}, elevator {} rad, throttle {}, \
                 aileron {} rad, rudder {} rad",
                out.mode, c.elevator_rad, c.throttle, c.aileron_rad, c.rudder_rad
            );
            std::process::ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("firmware (host): one step FAILED: {e}");
            std::process::ExitCode::FAILURE
        }
    }
}
