//! The `f405` board: a real STM32F405 flight computer.
//!
//! Place in the data flow: start-up and logging on hardware. Clock tree through the HAL
//! (stm32f4xx-hal): HSE 8 MHz crystal, PLL to SYSCLK = HCLK = 168 MHz, APB2 84 MHz (USART1),
//! APB1 42 MHz; USART1 on PA9 (TX) / PA10 (RX, pull-up), alternate function 7, 921,600 baud
//! 8N1; the DWT cycle counter measures costs ([`DwtCounter`], cycles); SysTick at 50 Hz runs
//! the free-running schedule (the flight default; the `lockstep` feature selects lockstep for
//! hardware-in-the-loop). Logs are defmt over RTT (a debug probe reads them:
//! `probe-rs run`, see firmware/README.md).
//!
//! Invariant: the clock setup waits for the HSE and PLL ready bits; without a crystal it
//! hangs here, before the link is up (no frame is ever sent), which the peer sees as a dead
//! flight computer.

use defmt_rtt as _;
use ibvs_core::wire::CostUnit;
use stm32f4xx_hal::pac::{self, USART1};
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::{Config, Enable, Reset};

use super::McuBoard;
use super::fault::{FaultRecord, send_safe_frame};
use crate::app::{App, CostCounter, Event, Schedule};
use crate::one_step;

/// Link baud rate, bit/s.
pub const BAUD_BPS: u32 = 921_600;
/// External crystal, Hz.
pub const HSE_HZ: u32 = 8_000_000;
/// Core clock, Hz.
pub const SYSCLK_HZ: u32 = 168_000_000;

/// The DWT cycle counter.
pub struct DwtCounter;

impl CostCounter for DwtCounter {
    const UNIT: CostUnit = CostUnit::Cycles;
    fn now() -> u32 {
        cortex_m::peripheral::DWT::cycle_count()
    }
}

/// The DWT cycle counter with the stack probe (the `bench` feature only: the flight build
/// does not repaint the stack every step).
#[cfg(feature = "bench")]
pub struct DwtBenchCounter;

#[cfg(feature = "bench")]
impl CostCounter for DwtBenchCounter {
    const UNIT: CostUnit = CostUnit::Cycles;
    fn now() -> u32 {
        cortex_m::peripheral::DWT::cycle_count()
    }
    #[inline(always)]
    fn stack_of<R>(f: impl FnOnce() -> R) -> (R, Option<u32>) {
        super::stack::probe(f)
    }
}

const SCHEDULE: Schedule = if cfg!(feature = "lockstep") {
    Schedule::Lockstep
} else {
    Schedule::FreeRunning
};

/// Start-up: self-test, clocks, pins, link, tick, application.
pub fn start() -> ! {
    let (Some(dp), Some(mut cp)) = (pac::Peripherals::take(), cortex_m::Peripherals::take()) else {
        defmt::error!("firmware: peripherals already taken");
        super::fault::halt()
    };
    if let Err(e) = one_step::run() {
        defmt::error!(
            "firmware: power-on self-test FAILED: {}",
            defmt::Display2Format(&e)
        );
        send_safe_frame();
        super::fault::halt()
    }
    let mut rcc = dp.RCC.freeze(
        Config::hse(HSE_HZ.Hz())
            .sysclk(SYSCLK_HZ.Hz())
            .pclk1(42.MHz())
            .pclk2(84.MHz()),
    );
    cp.DCB.enable_trace();
    cp.DWT.enable_cycle_counter();
    #[cfg(feature = "bench")]
    {
        let c = crate::bench::measure::<DwtBenchCounter>();
        defmt::info!(
            "firmware bench: {}",
            defmt::Display2Format(&crate::bench::Json(&c, "cycles"))
        );
    }

    let gpioa = dp.GPIOA.split(&mut rcc);
    let _tx = gpioa.pa9.into_alternate::<7>();
    let _rx = gpioa.pa10.into_alternate::<7>().internal_pull_up(true);
    USART1::enable(&mut rcc);
    USART1::reset(&mut rcc);
    // BRR = f_pclk2 / baud with 16x oversampling (mantissa and 4-bit fraction), rounded:
    // 91 at 84 MHz, which gives 84 MHz / 91 = 923,077 baud, +0.16 % from 921,600 (a UART
    // receiver samples mid-bit and tolerates a few percent over a 10-bit 8N1 character).
    let pclk2 = rcc.clocks.pclk2().raw();
    let brr = ((pclk2 + BAUD_BPS / 2) / BAUD_BPS) as u16;
    let link = super::usart1::init(dp.USART1, Some(brr));

    let previous = super::fault::take_previous();
    if let Some(r) = &previous {
        log_fault("before the last reset", r);
    }
    if SCHEDULE == Schedule::FreeRunning
        && super::systick::start(cp.SYST, rcc.clocks.hclk().raw()).is_err()
    {
        defmt::error!("firmware: SysTick reload out of range");
        super::fault::halt()
    }
    let app = match App::new(SCHEDULE, previous.is_some()) {
        Ok(app) => app,
        Err(e) => {
            defmt::error!(
                "firmware: configuration rejected: {}",
                defmt::Display2Format(&e)
            );
            send_safe_frame();
            super::fault::halt()
        }
    };
    defmt::info!(
        "firmware: f405 board, sysclk {} Hz, USART1 {} baud, free-running: {}",
        rcc.clocks.sysclk().raw(),
        BAUD_BPS,
        SCHEDULE == Schedule::FreeRunning
    );
    app.run(&mut McuBoard::<DwtCounter>::new(link))
}

/// Logs an application event over defmt.
#[inline(never)]
pub fn log(event: Event) {
    match event {
        Event::ModeChanged { mode, reason, step } => defmt::info!(
            "step {}: mode {} ({}); stack high-water mark {} B (None: unknown)",
            step,
            mode,
            reason,
            super::stack::used_bytes()
        ),
        Event::LinkStale => defmt::warn!("link stale: navigation treated as invalid"),
        Event::LinkRecovered => defmt::info!("link recovered"),
        Event::Configured { id } => defmt::info!("configuration {=u32:#010x} applied", id),
        Event::ControlStack { bytes, step } => defmt::info!(
            "step {}: control-path stack high-water mark {} B",
            step,
            bytes
        ),
    }
}

fn log_fault(when: &str, r: &FaultRecord) {
    defmt::error!(
        "FAULT {}: {} at {}:{} pc {=u32:#010x}",
        when,
        FaultRecord::text(&r.message),
        FaultRecord::text(&r.file),
        r.line,
        r.pc
    );
}

/// The end of the fault path on the board: log, then repeat the safe frame every control
/// period (busy-wait at 168 MHz) so the actuator side keeps receiving trim with the PANIC bit.
pub fn on_fault(r: &FaultRecord) -> ! {
    log_fault("(safe frame sent)", r);
    loop {
        cortex_m::asm::delay(SYSCLK_HZ / super::systick::TICK_HZ);
        send_safe_frame();
    }
}
