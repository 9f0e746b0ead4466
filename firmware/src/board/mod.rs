//! Board code (bare metal only): everything that touches the MCU, behind one module boundary.
//!
//! Place in the data flow: the reset entry selects the board (cargo feature `f405`, the
//! default, or `qemu`), runs the power-on self-test ([`crate::one_step::run`]), brings up the
//! serial link and the timers, and hands a [`crate::app::Board`] to the board-independent
//! [`crate::app::App::run`]. The parts both boards share live here:
//! - [`usart1`]: USART1, the peer's link, with an interrupt-fed receive queue and an
//!   interrupt-drained transmit queue ([`usart1::SerialLink`]; the queues and the
//!   interrupt's logic are `crate::serial`, the driver [`usart`]);
//! - [`usart2`]: USART2, the autopilot's MAVLink link, the same driver;
//! - [`systick`]: the control-period tick (SysTick at `Ts` = 20 ms of the core clock,
//!   168 MHz on both boards), stamped with the cost counter for the control task's deadline;
//! - [`fault`]: the panic, HardFault (on a fresh stack) and clock-failure handlers (safe
//!   state, recorded reason);
//! - [`stack`]: the stack's high-water mark (painted at reset).
//!
//! The `f405` board adds `rcc` (the clock start: the crystal measured before the PLL runs
//! from it), `flash` (the configuration store's sectors, without the HAL's panicking read)
//! and `watchdog` (the independent watchdog).
//!
//! | | `qemu` (netduinoplus2) | `f405` (real STM32F405) |
//! |---|---|---|
//! | clocks | none: QEMU 7.2 does not emulate the RCC | crystal (8, 12, 16 or 25 MHz, chosen at build time, measured at boot) or HSI, PLL to 168 MHz |
//! | link | USART1, QEMU's first `-serial` | USART1 on PA9/PA10, 921,600 baud 8N1 |
//! | autopilot (MAVLink) | USART2, QEMU's second `-serial` | USART2 on PA2/PA3, 921,600 baud 8N1 |
//! | cost counter | TIM2, one count per instruction (`-icount shift=0`) | DWT CYCCNT, cycles |
//! | schedule | lockstep; `free-running` on the semihosting command line | free-running; `lockstep` feature |
//! | logs | semihosting text (QEMU's stdout/stderr) | defmt over RTT |
//!
//! # Scheduling: interrupts and a superloop, not RTIC
//!
//! One periodic control task (the main loop's pass after a period tick or a measurement
//! frame), three interrupts (USART1 and USART2: a received byte or the transmit register empty; SysTick:
//! the period), and a configuration write that blocks for seconds in standby. What can
//! preempt what: the two interrupts preempt the main loop; they run at the same NVIC
//! priority (the reset default), so they never preempt each other. Each is short and
//! bounded: SysTick two atomic operations; USART1 one received byte and, on the MCU, one or
//! two transmitted bytes (under QEMU, whose writes are immediate, a whole queued frame). They
//! share with the main loop only lock-free single-producer single-consumer queues and
//! atomics (`crate::serial`), so there is no lock and no priority inversion. The critical
//! sections are a few instructions each (taking the period count with its stamp; the check
//! before WFI) plus, on the `qemu` board only, each received byte's timed decode window.
//! Worst-case blocking of the control task: the interrupts' own time (at 921,600 baud in
//! both directions, one interrupt per byte time of 10.8 us each way, each on the order of a
//! hundred cycles of the 1,814 a byte time holds: under 15 % of the CPU at full line rate
//! both ways, an estimate), and nothing else. The configuration write stalls the whole CPU, interrupts
//! included, because the code runs from the flash being erased: no scheduler can run the
//! control task then, which is why a write is refused unless the controller is in standby.
//! RTIC 2 would give the same guarantees (static priorities, stack-resource policy) for
//! this structure; it would add a framework and a dependency without removing a lock,
//! because there is none to remove.
//!
//! # Sleeping: one WFI, alone in its flash line
//!
//! Both boards sleep in [`sleep_until_interrupt`]: a WFI at the start of a 16-byte-aligned
//! block (one 128-bit line of the flash accelerator) followed by three NOPs, the return and
//! three more NOPs, all 16-bit instructions filling that line. ES0182's erratum "Debugging
//! Sleep/Stop mode with WFE/WFI entry" concerns the code after a WFI on wake-up while
//! DBGMCU_CR's DBG_SLEEP or DBG_STOP is set; the bring-up review found the old loop in the
//! pattern reported to mis-fetch there (a WFI not 8-byte aligned, interrupts masked, a 32-bit
//! branch straddling a flash line after it: an intermittent HardFault or wild branch). The
//! `f405` board now sets those bits only with a debugger attached (`f405`, step 2), so a
//! flight without a probe runs outside the erratum's conditions, and the placement covers a
//! bench session with one. Alignment was chosen over running the WFI from RAM (a RAM
//! function and its copy for one instruction) and over an ISB after it (a 32-bit instruction
//! itself, fetched right after the wake-up).
//!
//! Invariant: `unsafe` appears only in this module tree, each use with a
//! `// Note(unsafe): ...` saying why it is sound.

#[cfg(all(feature = "qemu", feature = "f405"))]
compile_error!(
    "select exactly one board: `--no-default-features --features qemu` for the QEMU board"
);
#[cfg(not(any(feature = "qemu", feature = "f405")))]
compile_error!("select a board feature: `f405` (default) or `qemu`");

pub mod fault;
pub mod stack;
pub mod systick;
pub mod usart;
pub mod usart1;
pub mod usart2;

#[cfg(all(feature = "qemu", feature = "usart1-pb6-pb7"))]
compile_error!("`usart1-pb6-pb7` selects the `f405` board's USART1 pins; QEMU has no pins");
#[cfg(all(
    feature = "qemu",
    any(
        feature = "hse-12mhz",
        feature = "hse-16mhz",
        feature = "hse-25mhz",
        feature = "provision-bor"
    )
))]
compile_error!("the `hse-*` and `provision-bor` features are the `f405` board's; QEMU has no RCC");

#[cfg(feature = "f405")]
mod f405;
#[cfg(feature = "f405")]
pub mod flash;
#[cfg(feature = "qemu")]
mod qemu;
#[cfg(feature = "f405")]
pub mod rcc;
#[cfg(feature = "f405")]
pub mod watchdog;

#[cfg(feature = "f405")]
use f405 as selected;
#[cfg(feature = "qemu")]
use qemu as selected;

/// The selected board's cost counter (the tick stamps periods with it).
pub use selected::Counter;

use cortex_m_rt::entry;

use crate::app::{Board, Event, Periods, QueueFull};
use crate::store::NoStore;
use ibvs_core::ControllerConfig;
use ibvs_core::wire::ConfigStorage;

// The sleep (module doc, "Sleeping"): `.balign 16` starts the block on a flash line (the
// assembler raises the section's alignment to 16, which the linker keeps); WFI, three NOPs,
// the return and three NOPs after it are 16-bit instructions filling that line exactly.
// Note(unsafe): `global_asm!` is unsafe by nature; the function takes no argument, touches no
// memory and no register but the ones WFI, NOP and BX LR define, and returns to its caller.
#[allow(unsafe_code)]
mod sleep {
    core::arch::global_asm!(
        ".section .text.ibvs_sleep_until_interrupt, \"ax\", %progbits",
        ".balign 16",
        ".global ibvs_sleep_until_interrupt",
        ".type ibvs_sleep_until_interrupt, %function",
        ".thumb_func",
        "ibvs_sleep_until_interrupt:",
        "wfi",
        "nop",
        "nop",
        "nop",
        "bx lr",
        // The rest of the line: never executed, but what the core may fetch after the
        // return is not a branch either.
        "nop",
        "nop",
        "nop",
        ".size ibvs_sleep_until_interrupt, . - ibvs_sleep_until_interrupt",
    );

    unsafe extern "C" {
        pub fn ibvs_sleep_until_interrupt();
    }
}

/// WFI, alone in a 16-byte-aligned flash line (module doc, "Sleeping"): the core sleeps until
/// an interrupt is pending (even a masked one).
#[inline(always)]
pub fn sleep_until_interrupt() {
    // Note(unsafe): the function above: no argument, no memory access, returns (AAPCS:
    // it clobbers nothing the caller keeps).
    #[allow(unsafe_code)]
    unsafe {
        sleep::ibvs_sleep_until_interrupt();
    }
}

/// Reset entry (after cortex-m-rt has initialised .data and .bss): the selected board's
/// start-up, then the application, forever.
#[entry]
fn main() -> ! {
    selected::start()
}

/// What a board adds to the shared link and tick: its configuration store and its
/// watchdog.
pub trait Services {
    /// Stores an applied configuration for the next boot (`crate::store`).
    fn persist(&mut self, cfg: &ControllerConfig) -> ConfigStorage;
    /// The main loop completed a pass: feed the watchdog.
    fn feed_watchdog(&mut self);
}

/// The `qemu` board's services: no store (QEMU's flash is read-only), no watchdog (QEMU
/// 7.2's netduinoplus2 does not model the IWDG).
impl Services for NoStore {
    fn persist(&mut self, cfg: &ControllerConfig) -> ConfigStorage {
        crate::store::Persist::persist(self, cfg)
    }

    fn feed_watchdog(&mut self) {}
}

/// The board the application runs on: the shared link and tick, the board's counter,
/// logger and services (configuration store, watchdog).
pub struct McuBoard<C, S> {
    link: usart1::SerialLink,
    autopilot: usart2::SerialLink,
    services: S,
    _counter: core::marker::PhantomData<C>,
}

impl<C, S> McuBoard<C, S> {
    /// The board around its initialised links (the peer's, the autopilot's) and its services.
    pub fn new(link: usart1::SerialLink, autopilot: usart2::SerialLink, services: S) -> Self {
        Self {
            link,
            autopilot,
            services,
            _counter: core::marker::PhantomData,
        }
    }
}

impl<C: crate::app::CostCounter, S: Services> Board for McuBoard<C, S> {
    type Link = usart1::SerialLink;
    type Autopilot = usart2::SerialLink;
    type Counter = C;

    fn link(&mut self) -> &mut usart1::SerialLink {
        &mut self.link
    }

    fn transmit(&mut self, frame: &[u8]) -> Result<(), QueueFull> {
        self.link.transmit(frame)
    }

    fn autopilot(&mut self) -> &mut usart2::SerialLink {
        &mut self.autopilot
    }

    fn transmit_autopilot(&mut self, frames: &[u8]) -> Result<(), QueueFull> {
        self.autopilot.transmit(frames)
    }

    fn take_autopilot_rx_errors(&mut self) -> u32 {
        usart2::take_rx_errors()
    }

    fn take_periods(&mut self) -> Periods {
        systick::take_periods()
    }

    fn pass_completed(&mut self) {
        self.services.feed_watchdog();
    }

    fn take_rx_errors(&mut self) -> u32 {
        usart1::take_rx_errors()
    }

    fn wait_for_event(&mut self) {
        // Sleep only if nothing is pending, with interrupts masked between the check and the
        // WFI so that an interrupt in between cannot be missed: WFI wakes on a pending
        // interrupt even while PRIMASK masks it, which then runs once unmasked.
        cortex_m::interrupt::disable();
        if !usart1::rx_frame_ready() && !usart2::rx_pending() && !systick::pending() {
            sleep_until_interrupt();
        }
        // Note(unsafe): re-enabling interrupts is sound here: we are not inside a critical
        // section (the main loop holds no borrow of interrupt-shared state at this point).
        #[allow(unsafe_code)]
        unsafe {
            cortex_m::interrupt::enable();
        }
    }

    fn log(&mut self, event: Event) {
        selected::log(event);
    }

    fn persist(&mut self, cfg: &ControllerConfig) -> ConfigStorage {
        self.services.persist(cfg)
    }
}
