//! Board code (bare metal only): everything that touches the MCU, behind one module boundary.
//!
//! Place in the data flow: the reset entry selects the board (cargo feature `f405`, the
//! default, or `qemu`), runs the power-on self-test ([`crate::one_step::run`]), brings up the
//! serial link and the timers, and hands a [`crate::app::Board`] to the board-independent
//! [`crate::app::App::run`]. The parts both boards share live here:
//! - [`usart1`]: USART1 with an interrupt-fed receive queue and polled transmit, behind the
//!   embedded-io traits ([`usart1::SerialLink`]);
//! - [`systick`]: the control-period tick of the free-running schedule (SysTick at
//!   `Ts` = 20 ms of the core clock, 168 MHz on both boards);
//! - [`fault`]: the panic and HardFault handlers (safe state, recorded reason);
//! - [`stack`]: the stack's high-water mark (painted at reset).
//!
//! | | `qemu` (netduinoplus2) | `f405` (real STM32F405) |
//! |---|---|---|
//! | clocks | none: QEMU 7.2 does not emulate the RCC | HSE 8 MHz, PLL to 168 MHz (HAL) |
//! | link | USART1, QEMU's first `-serial` | USART1 on PA9/PA10, 921,600 baud 8N1 |
//! | cost counter | TIM2, one count per instruction (`-icount shift=0`) | DWT CYCCNT, cycles |
//! | schedule | lockstep; `free-running` on the semihosting command line | free-running; `lockstep` feature |
//! | logs | semihosting text (QEMU's stdout/stderr) | defmt over RTT |
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
pub mod usart1;

#[cfg(feature = "f405")]
mod f405;
#[cfg(feature = "qemu")]
mod qemu;

#[cfg(feature = "f405")]
use f405 as selected;
#[cfg(feature = "qemu")]
use qemu as selected;

use cortex_m_rt::entry;

use crate::app::{Board, Event};
use crate::store::Persist;

/// Reset entry (after cortex-m-rt has initialised .data and .bss): the selected board's
/// start-up, then the application, forever.
#[entry]
fn main() -> ! {
    selected::start()
}

/// The board the application runs on: the shared link and tick, the board's counter,
/// logger and configuration store.
pub struct McuBoard<C, S> {
    link: usart1::SerialLink,
    store: S,
    _counter: core::marker::PhantomData<C>,
}

impl<C, S> McuBoard<C, S> {
    /// The board around an initialised link and its configuration store.
    pub fn new(link: usart1::SerialLink, store: S) -> Self {
        Self {
            link,
            store,
            _counter: core::marker::PhantomData,
        }
    }
}

impl<C: crate::app::CostCounter, S: Persist> Board for McuBoard<C, S> {
    type Link = usart1::SerialLink;
    type Counter = C;

    fn link(&mut self) -> &mut usart1::SerialLink {
        &mut self.link
    }

    fn take_periods(&mut self) -> u32 {
        systick::take_periods()
    }

    fn take_rx_errors(&mut self) -> u32 {
        usart1::take_rx_errors()
    }

    fn wait_for_event(&mut self) {
        // Sleep only if nothing is pending, with interrupts masked between the check and the
        // WFI so that an interrupt in between cannot be missed: WFI wakes on a pending
        // interrupt even while PRIMASK masks it, which then runs once unmasked.
        cortex_m::interrupt::disable();
        if !usart1::rx_pending() && !systick::pending() {
            cortex_m::asm::wfi();
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

    fn persist(&mut self, cfg: &ibvs_core::ControllerConfig) -> ibvs_core::wire::ConfigStorage {
        self.store.persist(cfg)
    }
}
