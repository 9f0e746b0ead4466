//! The `f405` board: a real STM32F405 flight computer.
//!
//! Place in the data flow: start-up and logging on hardware. In order, at reset:
//! 1. the reset cause: RCC_CSR's flags read, decoded (`crate::boot`) and cleared (RMVF);
//! 2. debug: with a debugger attached (the core's DHCSR.C_DEBUGEN) or in a debug build,
//!    DBGMCU_CR's DBG_SLEEP, DBG_STOP and DBG_STANDBY set, so a probe can reach a core that
//!    sleeps in WFI almost always, and DBGMCU_APB1_FZ's DBG_IWDG_STOP, so the watchdog stops
//!    while a debugger halts the core; otherwise all four cleared. DBGMCU is reset only by
//!    a power-on, so a bit a bench session left set would otherwise survive every later
//!    reset, and with DBG_SLEEP or DBG_STOP set ES0182's "Debugging Sleep/Stop mode with
//!    WFE/WFI entry" erratum applies (`super`, "Sleeping");
//! 3. the independent watchdog started with its long timeout ([`super::watchdog`]);
//! 4. the power-on self-test (on the 16 MHz HSI the MCU resets to);
//! 5. the clock ([`super::rcc`]): the crystal the build names (8 MHz, or the `hse-12mhz`,
//!    `hse-16mhz`, `hse-25mhz` feature's; `crate::clock`) given 100 ms to start, measured
//!    against the HSI, and fed to the PLL only if it is that crystal; else the PLL from the
//!    HSI. SYSCLK = HCLK = 168 MHz, APB2 84 MHz (USART1), APB1 42 MHz either way; the clock
//!    security system watches the crystal. On the HSI the telemetry says
//!    `ClockSource::InternalFallback`, and the peer must acknowledge before an engage
//!    (`crate::boot`: the link's timing rests on the HSI's accuracy). An HSE failure later
//!    raises the CSS's NMI: the reason is recorded and the board resets
//!    ([`super::fault::clock_failure_reset`]);
//! 6. the brown-out reset level read from the option bytes and logged (never written here:
//!    the `provision-bor` build programs it, `crate::option_bytes`);
//! 7. USART1 at 921,600 baud 8N1 on PA9 (TX) / PA10 (RX, pull-up), alternate function 7, or on
//!    PB6 / PB7 with the `usart1-pb6-pb7` feature (the STM32F4DISCOVERY, whose PA9 is USB
//!    VBUS with a capacitor on it); USART2, the autopilot's MAVLink link, at 460,800 baud on
//!    PA2 (TX) / PA3 (RX, pull-up); the DWT cycle counter measures costs ([`DwtCounter`]);
//! 8. SysTick at 50 Hz in both schedules (free-running, the flight default, steps on it;
//!    lockstep, the `lockstep` feature for hardware in the loop, only wakes on it, so the
//!    loop feeds the watchdog while the peer is silent);
//! 9. the configuration store (sectors 10 and 11, `crate::flash`, erased at x32 when the
//!    brown-out level is 3), the application, the watchdog set to its flight timeout, and
//!    the main loop.
//!
//! The `provision-bor` build stops after step 2: it programs the brown-out level (once, on
//! purpose), resets to confirm it, logs the outcome and halts ([`provision_bor`]).
//!
//! Logs are defmt over RTT in non-blocking mode (`disable-blocking-mode`: with no probe
//! reading, old log bytes are overwritten instead of the core spinning), read with
//! `probe-rs run` (firmware/README.md).
//!
//! Built from RM0090, the datasheet, ES0182 and the HAL; not yet run on a board.

use defmt_rtt as _;
use ibvs_core::wire::{ClockSource, ConfigStorage, CostUnit};
use stm32f4xx_hal::pac::{self, USART1, USART2};
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::{Enable, Reset};

use super::fault::{FaultRecord, send_safe_frame};
use super::flash::Registers;
use super::rcc::Started;
use super::watchdog::{Timeout, Watchdog};
use super::{McuBoard, Services};
use crate::app::{App, BootReport, CostCounter, Event, Schedule};
use crate::boot::reset_cause_from_rcc_csr;
use crate::clock::{PCLK1_HZ, PCLK2_HZ, SYSCLK_HZ};
use crate::flash::{STORE_SLOT_LEN, STORE_SLOTS, StoreFlash};
use crate::one_step;
use crate::option_bytes::BorLevel;
use crate::store::{ConfigStore, Persist};

/// Link baud rate, bit/s.
pub const BAUD_BPS: u32 = 921_600;

/// The autopilot link's (MAVLink, USART2) baud rate, bit/s (ArduPilot's `SERIALn_BAUD` 460).
pub const AUTOPILOT_BAUD_BPS: u32 = 460_800;

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

/// Start-up (the module doc's order): reset cause and debug, then the flight build's
/// watchdog, self-test, clocks, brown-out level, pins, link, tick, store and application, or
/// the provisioning build's option-byte step.
pub fn start() -> ! {
    let (Some(dp), Some(mut cp)) = (pac::Peripherals::take(), cortex_m::Peripherals::take()) else {
        defmt::error!("firmware: peripherals already taken");
        super::fault::halt()
    };
    // 1. Why the MCU reset; the flags are sticky until cleared, so clear them for the next.
    let csr = dp.RCC.csr().read().bits();
    dp.RCC.csr().modify(|_, w| w.rmvf().set_bit());
    // 2. Debug in sleep and a frozen watchdog with a debugger only (module doc).
    let debugger = cortex_m::peripheral::DCB::is_debugger_attached() || cfg!(debug_assertions);
    dp.DBGMCU.cr().modify(|_, w| {
        w.dbg_sleep().bit(debugger);
        w.dbg_stop().bit(debugger);
        w.dbg_standby().bit(debugger)
    });
    dp.DBGMCU
        .apb1_fz()
        .modify(|_, w| w.dbg_iwdg_stop().bit(debugger));
    cp.DCB.enable_trace();
    cp.DWT.enable_cycle_counter();
    if cfg!(feature = "provision-bor") {
        provision_bor(dp.FLASH, csr, debugger)
    } else {
        fly(dp, cp, csr, debugger)
    }
}

/// The flight build's start-up from step 3 (the module doc's order), then the application.
fn fly(dp: pac::Peripherals, cp: cortex_m::Peripherals, csr: u32, debugger: bool) -> ! {
    let reset_cause = reset_cause_from_rcc_csr(csr);
    // 3. From here a hang resets the board.
    let mut watchdog = Watchdog::start(dp.IWDG, Timeout::LONG);

    if let Err(e) = one_step::run() {
        defmt::error!(
            "firmware: power-on self-test FAILED: {}",
            defmt::Display2Format(&e)
        );
        send_safe_frame();
        super::fault::halt()
    }

    // 5. The crystal if it starts in time and is the expected one, else the HSI, through
    // the PLL either way.
    let clock = match super::rcc::start(&dp.RCC, &dp.FLASH, &dp.TIM11, &dp.DBGMCU) {
        Ok(Started::Crystal(_)) => ClockSource::Crystal,
        Ok(Started::Fallback(_)) => ClockSource::InternalFallback,
        Err(super::rcc::NoClock) => super::fault::clock_failure_reset("clock: no PLL lock"),
    };
    let mut rcc = dp.RCC.constrain();
    #[cfg(feature = "bench")]
    {
        let c = crate::bench::measure::<DwtBenchCounter>();
        defmt::info!(
            "firmware bench: {}",
            defmt::Display2Format(&crate::bench::Json(&c, "cycles"))
        );
        // The longest a log frame keeps interrupts masked (defmt-rtt's critical section
        // spans the frame's encoding): one of the longest events, timed.
        let t0 = cortex_m::peripheral::DWT::cycle_count();
        log(Event::DeadlineOverrun {
            elapsed: u32::MAX,
            deadline: u32::MAX,
            step: u32::MAX,
        });
        let cycles = cortex_m::peripheral::DWT::cycle_count().wrapping_sub(t0);
        defmt::info!("firmware bench: one log frame took {} cycles", cycles);
    }

    // 6. The brown-out level the flash's wait states need: read, never written here.
    let optcr = dp.FLASH.optcr().read().bits();
    let bor = BorLevel::of(optcr);

    // 7. USART1's pins, the peripheral, the link.
    let gpioa = dp.GPIOA.split(&mut rcc);
    #[cfg(not(feature = "usart1-pb6-pb7"))]
    {
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
    // 91 at 84 MHz, which gives 84 MHz / 91 = 923,077 baud, +0.16 % from 921,600. With a
    // fraction, RM0090 ("USART receiver tolerance to clock deviation") gives the receiver
    // 3.41 % of total deviation: the +0.16 % and the clock's own error (the crystal's is
    // parts per million; the HSI's is up to -8..+4.5 %, hence the acknowledgement asked on
    // the fallback, `crate::boot`) must stay inside it.
    const BRR: u16 = ((PCLK2_HZ + BAUD_BPS / 2) / BAUD_BPS) as u16;
    let link = super::usart1::init(dp.USART1, Some(BRR));
    // 7b. USART2, the autopilot's MAVLink link, on PA2 (TX) / PA3 (RX, pull-up), alternate
    // function 7, at 460,800 baud from APB1: 42 MHz / 460,800 rounds to 91, which gives
    // 461,538 baud, +0.16 %. Half the peer link's speed: a step's MAVLink (158 bytes in, 72
    // out) takes 17 % of it, and its interrupts land on the control task half as often.
    let _ap_tx = gpioa.pa2.into_alternate::<7>();
    let _ap_rx = gpioa.pa3.into_alternate::<7>().internal_pull_up(true);
    USART2::enable(&mut rcc);
    USART2::reset(&mut rcc);
    const AUTOPILOT_BRR: u16 = ((PCLK1_HZ + AUTOPILOT_BAUD_BPS / 2) / AUTOPILOT_BAUD_BPS) as u16;
    let autopilot = super::usart2::init(dp.USART2, Some(AUTOPILOT_BRR));

    let previous = super::fault::take_previous();
    if let Some(r) = &previous {
        log_fault("before the last reset", r);
    }
    // 8. The tick, in both schedules.
    if super::systick::start(cp.SYST, SYSCLK_HZ).is_err() {
        defmt::error!("firmware: SysTick reload out of range");
        super::fault::halt()
    }
    // 9. The configuration store in flash sectors 10 and 11 (memory.x keeps the program out
    // of them): the newest valid configuration in it, or the default. The layout is refused
    // on a part without those sectors (F_SIZE below 1 MiB).
    let flash = StoreFlash::new(Registers::new(dp.FLASH));
    let (flash_len, erase) = (flash.len(), flash.erase_parallelism());
    let mut store = match ConfigStore::new(flash, STORE_SLOTS, STORE_SLOT_LEN) {
        Ok(s) => Some(s),
        Err(e) => {
            defmt::error!(
                "firmware: configuration store unusable ({} B of flash): {}",
                flash_len,
                e
            );
            None
        }
    };
    let loaded = store.as_mut().map(ConfigStore::load);
    if let Some(l) = &loaded {
        defmt::info!(
            "firmware: configuration store: slots {}, {}; newest generation {}; erase {} ({} ms at most)",
            l.slots[0],
            l.slots[1],
            l.newest.map(|(_, g)| g),
            erase,
            erase.erase_time().max_ms
        );
    }
    let stored = loaded.and_then(|l| l.newest).map(|(cfg, _)| cfg);
    let boot = BootReport {
        reset_cause,
        clock,
        previous_fault: previous.is_some(),
    };
    defmt::info!(
        "firmware: reset cause {} (RCC_CSR {=u32:#010x}), clock {}, brown-out level {} (FLASH_OPTCR {=u32:#010x}), debugger {}",
        reset_cause,
        csr,
        clock,
        bor,
        optcr,
        debugger
    );
    if bor != BorLevel::Level3 {
        defmt::warn!(
            "firmware: brown-out reset not at level 3: 5 flash wait states need 2.7 V; provision it once with the `provision-bor` build (firmware/README.md)"
        );
    }
    if boot.needs_acknowledgement() {
        defmt::warn!(
            "firmware: engage refused until the peer sends Reset (an abnormal reset, or the HSI fallback)"
        );
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
        SYSCLK_HZ,
        BAUD_BPS,
        SCHEDULE == Schedule::FreeRunning,
        Timeout::FLIGHT.millis_at(32_000),
        updated
    );
    app.run(&mut McuBoard::<DwtCounter, _>::new(
        link,
        autopilot,
        BoardServices { store, watchdog },
    ))
}

/// The provisioning build (`provision-bor`): programs the brown-out reset to level 3 once,
/// resets to read it back, logs the outcome and halts (`crate::option_bytes`, the state
/// machine; firmware/README.md, the steps). Runs on the HSI, before the watchdog.
fn provision_bor(flash: pac::FLASH, csr: u32, debugger: bool) -> ! {
    use crate::option_bytes::{Attempt, Next, provision};
    /// Polls of FLASH_SR's BSY: at least 1 s at the HSI's 16 MHz.
    const BUSY_POLLS: u32 = 16_000_000;
    let attempt = take_provision_attempt();
    let mut regs = Registers::new(flash);
    let at_boot = crate::flash::FlashRegisters::optcr(&mut regs);
    let (found, next) = provision(&mut regs, attempt, BUSY_POLLS);
    defmt::info!(
        "provision-bor: reset cause {}, FLASH_OPTCR at boot {=u32:#010x} (brown-out level {}), attempt before this reset {}, debugger {}: {}",
        reset_cause_from_rcc_csr(csr),
        at_boot,
        BorLevel::of(at_boot),
        attempt == Attempt::Programmed,
        debugger,
        found
    );
    if next == Next::Reset {
        record_provision_attempt();
        cortex_m::peripheral::SCB::sys_reset()
    }
    defmt::info!("provision-bor: done; flash the flight build now");
    super::fault::halt()
}

/// The provisioning's attempt, kept across the reset that confirms it (`.uninit`: a reset
/// neither loads nor zeroes it; a power cycle loses it, which reads as no attempt).
// Note(unsafe): `link_section` only places the static in `.uninit`; only the provisioning
// build's boot reads and writes it, before interrupts are enabled.
#[allow(unsafe_code)]
#[unsafe(link_section = ".uninit.PROVISION_ATTEMPT")]
static mut PROVISION_ATTEMPT: core::mem::MaybeUninit<u32> = core::mem::MaybeUninit::uninit();

/// [`PROVISION_ATTEMPT`]'s value for `Attempt::Programmed` ("BOR3").
const ATTEMPT_PROGRAMMED: u32 = u32::from_le_bytes(*b"BOR3");

/// The attempt recorded before this reset; clears it.
fn take_provision_attempt() -> crate::option_bytes::Attempt {
    // Note(unsafe): read and written only here and in `record_provision_attempt`, at boot,
    // with interrupts not yet enabled; any bit pattern is a u32.
    #[allow(unsafe_code)]
    let v = unsafe {
        let v = core::ptr::read_volatile(&raw const PROVISION_ATTEMPT).assume_init();
        core::ptr::write_volatile(&raw mut PROVISION_ATTEMPT, core::mem::MaybeUninit::new(0));
        v
    };
    if v == ATTEMPT_PROGRAMMED {
        crate::option_bytes::Attempt::Programmed
    } else {
        crate::option_bytes::Attempt::None
    }
}

/// Records `Attempt::Programmed` for the boot after the reset.
fn record_provision_attempt() {
    // Note(unsafe): as in `take_provision_attempt`.
    #[allow(unsafe_code)]
    unsafe {
        core::ptr::write_volatile(
            &raw mut PROVISION_ATTEMPT,
            core::mem::MaybeUninit::new(ATTEMPT_PROGRAMMED),
        );
    }
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

/// The board's services: the configuration store (or none when its layout was refused at
/// boot: then every write is `Failed`) and the watchdog.
struct BoardServices {
    store: Option<ConfigStore<StoreFlash<Registers>>>,
    watchdog: Watchdog,
}

impl Services for BoardServices {
    /// Stores with the watchdog at its long timeout: the sector erase stalls the CPU for up
    /// to 4 s (`crate::flash::SAVE_MAX_MS`, which the long timeout outlasts at the fastest
    /// LSI: checked in `super::watchdog`); the flight timeout is set back (and the counter
    /// restarted) after it.
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
            "engage refused until the peer sends Reset (reset cause {}; asked on the HSI fallback too)",
            cause
        ),
        Event::ResetAcknowledged => defmt::info!("reset acknowledged: engage allowed"),
    }
}

fn log_fault(when: &str, r: &FaultRecord) {
    let s = &r.status;
    defmt::error!(
        "FAULT {}: {} at {}:{} pc {=u32:#010x} CFSR {=u32:#010x} HFSR {=u32:#010x} MMFAR {=u32:#010x} BFAR {=u32:#010x}",
        when,
        FaultRecord::text(&r.message),
        FaultRecord::text(&r.file),
        r.line,
        r.pc,
        s.cfsr,
        s.hfsr,
        s.mmfar,
        s.bfar
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
