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
use crate::store::{ConfigStore, Persist};
use embedded_storage::nor_flash::{ErrorType, NorFlash, ReadNorFlash};
use ibvs_core::wire::ConfigStorage;
use stm32f4xx_hal::flash::{FlashExt, LockedFlash};

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
    #[inline(always)]
    fn uninterrupted<R>(f: impl FnOnce() -> R) -> R {
        cortex_m::interrupt::free(|_| f())
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
    // The configuration store in flash sectors 10 and 11 (memory.x keeps the program out of
    // them): the newest valid configuration in it, or the default.
    let mut store = match ConfigStore::new(
        BoardFlash(LockedFlash::new(dp.FLASH)),
        STORE_SLOTS,
        STORE_SLOT_LEN,
    ) {
        Ok(s) => Some(s),
        Err(e) => {
            defmt::error!("firmware: configuration store unusable: {}", e);
            None
        }
    };
    let loaded = store.as_mut().map(ConfigStore::load);
    if let Some(l) = &loaded {
        defmt::info!(
            "firmware: configuration store: slots {}, {}; newest generation {}",
            l.slots[0],
            l.slots[1],
            l.newest.map(|(_, g)| g)
        );
    }
    let stored = loaded.and_then(|l| l.newest).map(|(cfg, _)| cfg);
    let app = match App::new(SCHEDULE, previous.is_some(), stored) {
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
    app.run(&mut McuBoard::<DwtCounter, _>::new(link, BoardStore(store)))
}

/// Offsets in flash of the configuration store's two slots: sectors 10 and 11
/// (0x080C_0000 and 0x080E_0000), 128 KiB each, outside the program (memory.x).
const STORE_SLOTS: [u32; 2] = [0x000C_0000, 0x000E_0000];

/// Length of each slot, bytes: one 128 KiB sector.
const STORE_SLOT_LEN: u32 = 128 * 1024;

/// The board's flash as embedded-storage NOR flash: read while locked, unlocked only for the
/// duration of each erase or write (the HAL relocks when the unlocked handle drops).
/// An erase of a 128 KiB sector takes about 1 to 2 s (RM0090 and the datasheet's sector
/// erase time at x8 parallelism), during which the CPU stalls on flash fetches and serial
/// bytes arriving are lost (counted as receiver overruns); configurations are written in
/// standby only.
struct BoardFlash(LockedFlash);

impl ErrorType for BoardFlash {
    type Error = stm32f4xx_hal::flash::Error;
}

impl ReadNorFlash for BoardFlash {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        ReadNorFlash::read(&mut self.0, offset, bytes)
    }

    fn capacity(&self) -> usize {
        ReadNorFlash::capacity(&self.0)
    }
}

impl NorFlash for BoardFlash {
    const WRITE_SIZE: usize = 1;
    const ERASE_SIZE: usize = 128 * 1024;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        NorFlash::erase(&mut self.0.unlocked(), from, to)
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        NorFlash::write(&mut self.0.unlocked(), offset, bytes)
    }
}

/// The store, or none when its layout was refused at boot (then every write is `Failed`).
struct BoardStore(Option<ConfigStore<BoardFlash>>);

impl Persist for BoardStore {
    fn persist(&mut self, cfg: &ibvs_core::ControllerConfig) -> ConfigStorage {
        match &mut self.0 {
            Some(s) => s.persist(cfg),
            None => ConfigStorage::Failed,
        }
    }
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
