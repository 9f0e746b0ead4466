//! The control-period tick: SysTick, a core peripheral, so the same on both boards.
//!
//! Place in the data flow: the SysTick exception counts elapsed control periods and stamps
//! the latest with the board's cost counter; the main loop takes both ([`take_periods`]):
//! free-running, it runs one step when the count is at least one, counts the excess as
//! missed periods (`LinkCounters::deadline_missed`) and measures the step's deadline from
//! the stamp; lockstep, it only takes them. The `f405` board runs the tick in both
//! schedules, so that its main loop wakes (and feeds the watchdog) every period even while
//! a lockstep peer is silent; the `qemu` board runs it in free-running only (an exception in
//! the middle of a timed lockstep step would make the reported instruction counts differ
//! run to run).
//!
//! Invariant: the period is the core's `Controller::PERIOD_S` (checked at compile time).
//! The handler is two atomic operations and a counter read: nothing in it can panic or
//! block.

use core::sync::atomic::{AtomicU32, Ordering};

use crate::app::{CostCounter, Periods};

use cortex_m::peripheral::SYST;
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m_rt::exception;
use ibvs_core::Controller;

/// Control steps per second.
pub const TICK_HZ: u32 = 50;
const _: () = assert!(1.0 / TICK_HZ as f32 == Controller::PERIOD_S);

static PERIODS: AtomicU32 = AtomicU32::new(0);
/// The cost counter at the latest tick.
static TICK_AT: AtomicU32 = AtomicU32::new(0);

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

/// Control periods elapsed since the last call, and the cost counter at the latest tick
/// (read together, with the tick masked for the two reads).
pub fn take_periods() -> Periods {
    cortex_m::interrupt::free(|_| Periods {
        count: PERIODS.swap(0, Ordering::Relaxed),
        last_tick_at: TICK_AT.load(Ordering::Relaxed),
    })
}

/// True when at least one period is waiting to be taken.
pub fn pending() -> bool {
    PERIODS.load(Ordering::Relaxed) > 0
}

#[exception]
fn SysTick() {
    TICK_AT.store(super::Counter::now(), Ordering::Relaxed);
    PERIODS.fetch_add(1, Ordering::Relaxed);
}
