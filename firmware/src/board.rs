//! Board code (bare metal only): the reset entry point and the panic handler.
//!
//! Place in the data flow: none yet; the entry runs [`crate::one_step::run`] once and reports
//! the result through the semihosting exit status, which QEMU (`-semihosting-config
//! enable=on,target=native`) passes on as its own: `EXIT_SUCCESS` when the step entered
//! approach with finite commands, `EXIT_FAILURE` otherwise or on any panic.
//!
//! No clock setup: QEMU 7.2 does not emulate the STM32 RCC (ready bits never set), and the
//! HSI default (16 MHz) is enough for one step. On a board without a debugger attached, a
//! semihosting call is a breakpoint that ends in the HardFault handler, which loops: the
//! firmware then halts, as panic-halt would.
//!
//! Invariants: no `unsafe` in this crate (the workspace's `forbid(unsafe_code)` holds here);
//! no allocator; the happy path does not panic.

use core::panic::PanicInfo;

use cortex_m_rt::entry;
use cortex_m_semihosting::debug::{self, EXIT_FAILURE, EXIT_SUCCESS};
use cortex_m_semihosting::hprintln;

use crate::one_step;

/// Reset entry (after cortex-m-rt has initialised .data and .bss): one step, then exit.
#[entry]
fn main() -> ! {
    match one_step::run() {
        Ok(out) => {
            let c = out.command;
            hprintln!(
                "firmware: one step ok: mode {:?}, elevator {} rad, throttle {}, aileron {} rad, rudder {} rad",
                out.mode,
                c.elevator_rad,
                c.throttle,
                c.aileron_rad,
                c.rudder_rad
            );
            debug::exit(EXIT_SUCCESS);
        }
        Err(e) => {
            hprintln!("firmware: one step FAILED: {}", e);
            debug::exit(EXIT_FAILURE);
        }
    }
    // Only reached when no debugger or emulator handled the exit request.
    halt()
}

/// Any panic is a failure: report it (under QEMU: exit status 1) and halt.
#[panic_handler]
fn panic(info: &PanicInfo<'_>) -> ! {
    hprintln!("firmware: panic: {}", info);
    debug::exit(EXIT_FAILURE);
    halt()
}

/// Parks the core (what panic-halt does), for when no host took the semihosting exit.
fn halt() -> ! {
    loop {
        cortex_m::asm::wfi();
    }
}
