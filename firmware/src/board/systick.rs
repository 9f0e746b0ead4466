//! The control-period tick of the free-running schedule: SysTick, a core peripheral, so the
//! same on both boards.
//!
//! Place in the data flow: the SysTick exception counts elapsed control periods; the main
//! loop takes the count ([`take_periods`]) and runs one step when it is at least one, and
//! counts the excess as missed deadlines (`LinkCounters::deadline_missed`).
//!
//! Invariant: the period is the core's `Controller::PERIOD_S` (checked at compile time).

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::SYST;
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m_rt::exception;
use ibvs_core::Controller;

/// Control steps per second.
pub const TICK_HZ: u32 = 50;
const _: () = assert!(1.0 / TICK_HZ as f32 == Controller::PERIOD_S);

static PERIODS: AtomicU32 = AtomicU32::new(0);

/// Why the tick could not start.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TickError {
    /// The reload value does not fit SysTick's 24 bits at this core clock.
    ReloadTooLarge,
}

/// Starts SysTick at [`TICK_HZ`] from the core clock `core_hz` (with its interrupt).
pub fn start(mut syst: SYST, core_hz: u32) -> Result<(), TickError> {
    let reload = core_hz / TICK_HZ - 1;
    if reload > 0x00FF_FFFF {
        return Err(TickError::ReloadTooLarge);
    }
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(reload);
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();
    Ok(())
}

/// Control periods elapsed since the last call.
pub fn take_periods() -> u32 {
    PERIODS.swap(0, Ordering::Relaxed)
}

/// True when at least one period is waiting to be taken.
pub fn pending() -> bool {
    PERIODS.load(Ordering::Relaxed) > 0
}

#[exception]
fn SysTick() {
    PERIODS.fetch_add(1, Ordering::Relaxed);
}
