//! The `f405` board: a real STM32F405 flight computer.
//!
//! Place in the data flow: start-up and logging on hardware. In order, at reset:
//! 1. the reset cause: RCC_CSR's flags read, decoded (`crate::boot`) and cleared (RMVF);
//! 2. debug: DBGMCU_CR's DBG_SLEEP, DBG_STOP and DBG_STANDBY set, so a probe can attach to a
//!    core that sleeps in WFI almost always; DBGMCU_APB1_FZ's DBG_IWDG_STOP set, so the
//!    watchdog stops while a debugger halts the core;
//! 3. the independent watchdog started with its long timeout ([`super::watchdog`]);
//! 4. the power-on self-test (on the 16 MHz HSI the MCU resets to);
//! 5. the clock: the HSE 8 MHz crystal is given [`HSE_STARTUP_S`] (100 ms) to start; then
//!    the PLL runs from it to SYSCLK = HCLK = 168 MHz (APB2 84 MHz for USART1, APB1 42 MHz)
//!    and the clock security system (CSS) watches it; if it does not start, the PLL runs
//!    from the HSI to the same frequencies (`ClockSource::InternalFallback` in every telemetry frame,
//!    logged). An HSE failure later raises the CSS's NMI: the reason is recorded and the
//!    board resets ([`super::fault::clock_failure_reset`]), and boots on the HSI if the
//!    crystal is still dead;
//! 6. the brown-out reset level: programmed to level 3 (2.7 V) in the option bytes if it is
//!    not already ([`ensure_bor_level_3`]): 5 flash wait states at 168 MHz need VDD of at
//!    least 2.7 V;
//! 7. USART1 at 921,600 baud 8N1 on PA9 (TX) / PA10 (RX, pull-up), alternate function 7, or on
//!    PB6 / PB7 with the `usart1-pb6-pb7` feature (the STM32F4DISCOVERY, whose PA9 is USB
//!    VBUS with a capacitor on it); the DWT cycle counter measures costs ([`DwtCounter`]);
//! 8. SysTick at 50 Hz in both schedules (free-running, the flight default, steps on it;
//!    lockstep, the `lockstep` feature for hardware in the loop, only wakes on it, so the
//!    loop feeds the watchdog while the peer is silent);
//! 9. the configuration store (sectors 10 and 11, [`super::flash`]), the application, the
//!    watchdog set to its flight timeout, and the main loop.
//!
//! Logs are defmt over RTT in non-blocking mode (`disable-blocking-mode`: with no probe
//! reading, old log bytes are overwritten instead of the core spinning), read with
//! `probe-rs run` (firmware/README.md).
//!
//! Built from RM0090, the datasheet and the HAL; not yet run on a board.

use defmt_rtt as _;
use ibvs_core::wire::{ClockSource, ConfigStorage, CostUnit};
use stm32f4xx_hal::pac::{self, USART1};
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::{Config, Enable, Reset};

use super::fault::{FaultRecord, send_safe_frame};
use super::flash::{STORE_SLOT_LEN, STORE_SLOTS, StoreFlash};
use super::watchdog::{Timeout, Watchdog};
use super::{McuBoard, Services};
use crate::app::{App, BootReport, CostCounter, Event, Schedule};
use crate::boot::reset_cause_from_rcc_csr;
use crate::one_step;
use crate::store::{ConfigStore, Persist};

/// Link baud rate, bit/s.
pub const BAUD_BPS: u32 = 921_600;
/// External crystal, Hz.
pub const HSE_HZ: u32 = 8_000_000;
/// The internal RC oscillator the MCU resets to, Hz.
const HSI_HZ: u32 = 16_000_000;
/// Core clock, Hz.
pub const SYSCLK_HZ: u32 = 168_000_000;
/// How long the crystal is given to start at boot, seconds (ST's usual HSE start-up
/// timeout; a crystal typically starts in 2 ms).
pub const HSE_STARTUP_S: f32 = 0.1;
/// [`HSE_STARTUP_S`] in cycles of the HSI, the clock the MCU runs on while it waits.
const HSE_STARTUP_CYCLES: u32 = (HSE_STARTUP_S * HSI_HZ as f32) as u32;

/// The DWT cycle counter.
pub struct DwtCounter;

/// The cost counter of this board.
pub type Counter = DwtCounter;

impl CostCounter for DwtCounter {
    const UNIT: CostUnit = CostUnit::Cycles;
    /// 1 ms at [`SYSCLK_HZ`] (168 MHz; on the HSI fallback the PLL gives the same).
    const DEADLINE: u32 = SYSCLK_HZ / 1000;
    fn now() -> u32 {
        cortex_m::peripheral::DWT::cycle_count()
    }
    // `uninterrupted` keeps its default (interrupts stay enabled): a frame's last byte's
    // window holds its whole deserialisation, thousands of cycles, longer than a byte time at
    // 921,600 baud (10.8 us), and masking it could overrun the receiver. The board's decode
    // figures include any interrupt landing in the window.
}

/// The DWT cycle counter with the stack probe (the `bench` feature only: the flight build
/// does not repaint the stack every step).
#[cfg(feature = "bench")]
pub struct DwtBenchCounter;

#[cfg(feature = "bench")]
impl CostCounter for DwtBenchCounter {
    const UNIT: CostUnit = CostUnit::Cycles;
    const DEADLINE: u32 = SYSCLK_HZ / 1000;
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

/// Start-up (the module doc's order): reset cause, debug, watchdog, self-test, clocks,
/// brown-out level, pins, link, tick, store, application.
pub fn start() -> ! {
    let (Some(dp), Some(mut cp)) = (pac::Peripherals::take(), cortex_m::Peripherals::take()) else {
        defmt::error!("firmware: peripherals already taken");
        super::fault::halt()
    };
    // 1. Why the MCU reset; the flags are sticky until cleared, so clear them for the next.
    let csr = dp.RCC.csr().read().bits();
    dp.RCC.csr().modify(|_, w| w.rmvf().set_bit());
    let reset_cause = reset_cause_from_rcc_csr(csr);
    // 2. A probe can attach to the sleeping core; the watchdog stops under a halted core.
    dp.DBGMCU.cr().modify(|_, w| {
        w.dbg_sleep().set_bit();
        w.dbg_stop().set_bit();
        w.dbg_standby().set_bit()
    });
    dp.DBGMCU
        .apb1_fz()
        .modify(|_, w| w.dbg_iwdg_stop().set_bit());
    // 3. From here a hang resets the board.
    let mut watchdog = Watchdog::start(dp.IWDG, Timeout::LONG);
    cp.DCB.enable_trace();
    cp.DWT.enable_cycle_counter();

    if let Err(e) = one_step::run() {
        defmt::error!(
            "firmware: power-on self-test FAILED: {}",
            defmt::Display2Format(&e)
        );
        send_safe_frame();
        super::fault::halt()
    }

    // 5. The crystal if it starts in time, else the HSI, through the PLL either way.
    let clock = if start_crystal(&dp.RCC) {
        ClockSource::Crystal
    } else {
        ClockSource::InternalFallback
    };
    let source = match clock {
        ClockSource::Crystal => Config::hse(HSE_HZ.Hz()),
        ClockSource::InternalFallback | ClockSource::NotReported => Config::hsi(),
    };
    let mut rcc = dp.RCC.freeze(
        source
            .sysclk(SYSCLK_HZ.Hz())
            .pclk1(42.MHz())
            .pclk2(84.MHz()),
    );
    if clock == ClockSource::Crystal {
        // The clock security system: an HSE failure switches SYSCLK to the HSI and raises
        // the NMI (`NonMaskableInt` below).
        rcc.cr().modify(|_, w| w.csson().set_bit());
    }
    #[cfg(feature = "bench")]
    {
        let c = crate::bench::measure::<DwtBenchCounter>();
        defmt::info!(
            "firmware bench: {}",
            defmt::Display2Format(&crate::bench::Json(&c, "cycles"))
        );
    }

    // 6. The brown-out level the flash's wait states need.
    let bor = ensure_bor_level_3(&dp.FLASH);

    // 7. USART1's pins, the peripheral, the link.
    #[cfg(not(feature = "usart1-pb6-pb7"))]
    {
        let gpioa = dp.GPIOA.split(&mut rcc);
        let _tx = gpioa.pa9.into_alternate::<7>();
        let _rx = gpioa.pa10.into_alternate::<7>().internal_pull_up(true);
    }
    #[cfg(feature = "usart1-pb6-pb7")]
    {
        let gpiob = dp.GPIOB.split(&mut rcc);
        let _tx = gpiob.pb6.into_alternate::<7>();
        let _rx = gpiob.pb7.into_alternate::<7>().internal_pull_up(true);
    }
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
    // 8. The tick, in both schedules.
    if super::systick::start(cp.SYST, rcc.clocks.hclk().raw()).is_err() {
        defmt::error!("firmware: SysTick reload out of range");
        super::fault::halt()
    }
    // 9. The configuration store in flash sectors 10 and 11 (memory.x keeps the program out
    // of them): the newest valid configuration in it, or the default.
    let mut store = match ConfigStore::new(StoreFlash::new(dp.FLASH), STORE_SLOTS, STORE_SLOT_LEN) {
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
    let boot = BootReport {
        reset_cause,
        clock,
        previous_fault: previous.is_some(),
    };
    defmt::info!(
        "firmware: reset cause {} (RCC_CSR {=u32:#010x}), clock {}, brown-out level: {}",
        reset_cause,
        csr,
        clock,
        bor
    );
    if boot.needs_acknowledgement() {
        defmt::warn!("firmware: abnormal reset: engage refused until the peer sends Reset");
    }
    let app = match App::new(SCHEDULE, boot, stored) {
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
    let updated = watchdog.set(Timeout::FLIGHT);
    defmt::info!(
        "firmware: f405 board, sysclk {} Hz, USART1 {} baud, free-running: {}; watchdog {} ms (68..188 ms over the LSI's range), set: {}",
        rcc.clocks.sysclk().raw(),
        BAUD_BPS,
        SCHEDULE == Schedule::FreeRunning,
        Timeout::FLIGHT.millis_at(32_000),
        updated
    );
    app.run(&mut McuBoard::<DwtCounter, _>::new(
        link,
        BoardServices { store, watchdog },
    ))
}

/// Turns the HSE on and waits for it at most [`HSE_STARTUP_S`]; true when it is ready, and
/// false with the HSE turned off again when it did not start (no crystal, a broken one).
fn start_crystal(rcc: &pac::RCC) -> bool {
    rcc.cr().modify(|_, w| w.hseon().set_bit());
    let t0 = cortex_m::peripheral::DWT::cycle_count();
    while rcc.cr().read().hserdy().bit_is_clear() {
        if cortex_m::peripheral::DWT::cycle_count().wrapping_sub(t0) > HSE_STARTUP_CYCLES {
            rcc.cr().modify(|_, w| w.hseon().clear_bit());
            return false;
        }
    }
    true
}

/// The clock security system's NMI (the only NMI source used here): the HSE failed, the
/// hardware switched SYSCLK to the 16 MHz HSI (so USART1's baud rate is now wrong and no
/// frame can be sent). Clears the flag (else the NMI repeats), records the reason, resets.
// Note(unsafe): cortex-m-rt requires the NMI handler to be an `unsafe fn` (an NMI can
// interrupt a critical section); this one shares no state with the code it interrupts and
// does not return. The RCC registers are always mapped; the main loop never writes RCC_CIR.
#[allow(unsafe_code)]
#[cortex_m_rt::exception]
unsafe fn NonMaskableInt() {
    let rcc = unsafe { &*pac::RCC::ptr() };
    let css = rcc.cir().read().cssf().bit_is_set();
    rcc.cir().write(|w| w.cssc().set_bit());
    super::fault::clock_failure_reset(if css {
        "clock security: HSE failed"
    } else {
        "NMI without a clock failure"
    })
}

/// What [`ensure_bor_level_3`] found or did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum BorOutcome {
    /// Level 3 was already programmed.
    AlreadyLevel3,
    /// It was lower (the factory's "off"); now level 3, read back.
    Programmed,
    /// The option bytes could not be unlocked or did not read back level 3 (FLASH_OPTCR).
    Failed(u32),
}

/// FLASH_OPTCR (RM0090): bits 3:2 BOR_LEV, `00` = level 3 (VBOR3, 2.70 V) up to `11` = off
/// (the factory value). The PAC's names for these values run the other way round, so the
/// bits are used here as RM0090 and ST's `OB_BOR_LEVEL3 = 0x00` define them.
const OPTCR_BOR_LEV: u32 = 0b11 << 2;
const OPTCR_OPTSTRT: u8 = 1 << 1;
const OPTCR_OPTLOCK: u8 = 1 << 0;
/// FLASH_OPTKEYR's unlock sequence.
const OPTKEY1: u32 = 0x0819_2A3B;
const OPTKEY2: u32 = 0x4C5D_6E7F;

/// Programs the brown-out reset to level 3 (2.7 V) in the option bytes unless it already is,
/// so the MCU is held in reset whenever VDD is too low for 5 flash wait states at 168 MHz.
///
/// How it is safe: it writes only FLASH_OPTCR's low byte (BOR_LEV, with the watchdog and
/// reset-on-stop/standby user bits it holds as read), as ST's library does, so the read
/// protection and the write protections (bytes 1 to 3) are never written; it runs once per
/// board (afterwards it reads level 3 and writes nothing), at boot, before the link is up,
/// with the watchdog at its long timeout; and it reads the result back. The remaining risk
/// is a power cut in the milliseconds of that first boot's option write, which can leave
/// the option bytes inconsistent (the MCU then loads protective values): it happens on the
/// bench, when a board is first flashed, not in flight.
fn ensure_bor_level_3(flash: &pac::FLASH) -> BorOutcome {
    let optcr = flash.optcr().read().bits();
    if optcr & OPTCR_BOR_LEV == 0 {
        return BorOutcome::AlreadyLevel3;
    }
    while flash.sr().read().bsy().bit_is_set() {}
    flash.optkeyr().write(|w| w.optkeyr().set(OPTKEY1));
    flash.optkeyr().write(|w| w.optkeyr().set(OPTKEY2));
    if flash.optcr().read().optlock().bit_is_set() {
        return BorOutcome::Failed(flash.optcr().read().bits());
    }
    // FLASH_OPTCR's low byte: BOR_LEV cleared (level 3), OPTSTRT and OPTLOCK clear, the
    // other user bits as read.
    let byte0 = (optcr & 0xFF & !OPTCR_BOR_LEV) as u8 & !(OPTCR_OPTSTRT | OPTCR_OPTLOCK);
    let optcr_byte0 = flash.optcr().as_ptr().cast::<u8>();
    // Note(unsafe): byte writes to FLASH_OPTCR's low byte (its address, a mapped
    // register), unlocked above; RM0090's sequence: the new value, then OPTSTRT.
    #[allow(unsafe_code)]
    unsafe {
        core::ptr::write_volatile(optcr_byte0, byte0);
        core::ptr::write_volatile(optcr_byte0, byte0 | OPTCR_OPTSTRT);
    }
    while flash.sr().read().bsy().bit_is_set() {}
    flash.optcr().modify(|_, w| w.optlock().set_bit());
    let after = flash.optcr().read().bits();
    if after & OPTCR_BOR_LEV == 0 {
        BorOutcome::Programmed
    } else {
        BorOutcome::Failed(after)
    }
}

/// The board's services: the configuration store (or none when its layout was refused at
/// boot: then every write is `Failed`) and the watchdog.
struct BoardServices {
    store: Option<ConfigStore<StoreFlash>>,
    watchdog: Watchdog,
}

impl Services for BoardServices {
    /// Stores with the watchdog at its long timeout: the sector erase stalls the CPU for up
    /// to 4 s; the flight timeout is set back (and the counter restarted) after it.
    fn persist(&mut self, cfg: &ibvs_core::ControllerConfig) -> ConfigStorage {
        self.watchdog.set(Timeout::LONG);
        let outcome = match &mut self.store {
            Some(s) => s.persist(cfg),
            None => ConfigStorage::Failed,
        };
        self.watchdog.set(Timeout::FLIGHT);
        outcome
    }

    fn feed_watchdog(&mut self) {
        self.watchdog.feed();
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
        Event::DeadlineOverrun {
            elapsed,
            deadline,
            step,
        } => defmt::warn!(
            "step {}: command frame queued {} cycles after its trigger (deadline {})",
            step,
            elapsed,
            deadline
        ),
        Event::EngageInhibited { cause } => defmt::warn!(
            "engage refused: the reset ({}) is not acknowledged (send Reset)",
            cause
        ),
        Event::ResetAcknowledged => defmt::info!("reset acknowledged: engage allowed"),
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
/// period (busy-wait at 168 MHz) so the actuator side keeps receiving trim with the PANIC
/// bit, until the independent watchdog, not fed here, resets the board.
pub fn on_fault(r: &FaultRecord) -> ! {
    log_fault("(safe frame sent)", r);
    loop {
        cortex_m::asm::delay(SYSCLK_HZ / super::systick::TICK_HZ);
        send_safe_frame();
    }
}
