//! The `f405` board's clock start: the crystal started, measured against the HSI and, if it
//! is the one the build expects, fed to the PLL; otherwise the PLL from the HSI. Every wait is
//! bounded.
//!
//! Place in the data flow: at boot, after the power-on self-test, before USART1 and SysTick
//! (both run from the clocks set here: SYSCLK = HCLK = [`SYSCLK_HZ`], APB1 [`PCLK1_HZ`], APB2
//! [`PCLK2_HZ`] whichever source). The numbers (the crystal, the PLL's factors and their
//! limits, the measurement's judgement) are `crate::clock`'s, host-tested; this is the
//! register sequence (RM0090, "Reset and clock control (RCC)"), with the core running on the
//! 16 MHz HSI it reset to, the DWT cycle counter bounding each wait:
//! 1. HSEON, then HSERDY within [`HSE_STARTUP_S`] (100 ms, ST's usual start-up timeout);
//! 2. the crystal measured: TIM11's input capture counts edges of HSE_RTC (the crystal / 31,
//!    RCC_CFGR.RTCPRE) in HSI ticks (TIM11_OR.TI1_RMP = HSE_RTC: RM0090, "Internal/external
//!    clock measurement using TIM5/TIM11"); a crystal that is not the expected one (an
//!    8 MHz build on a 25 MHz board) is turned off and not used;
//! 3. flash: 5 wait states (RM0090, "Relation between CPU clock frequency and Flash memory
//!    read time": 150 < HCLK <= 168 MHz at 2.7..3.6 V), instruction and data caches on, and
//!    prefetch on except on revision A silicon (DBGMCU_IDCODE REV_ID 0x1000), which does not
//!    support it (ES0182; ST's STM32CubeF4 examples enable it on revision Z only);
//! 4. RCC_PLLCFGR from `crate::clock`, then one log line naming the source and the factors
//!    (written before the switch, so a board that hangs after it has said what it tried);
//! 5. PLLON, then PLLRDY within [`PLL_LOCK_S`]; a PLL that does not lock from the crystal is
//!    turned off and started again from the HSI;
//! 6. AHB /1, APB1 /4, APB2 /2, then SW = PLL and SWS read back (bounded);
//! 7. the clock security system on when the crystal runs the PLL.
//!
//! Invariant: the PLL is only ever fed from a source whose factors passed
//! `crate::clock::PllConfig::check` (at compile time) and, for the crystal, whose measured
//! frequency is the expected one.

use stm32f4xx_hal::pac;

use crate::clock::{
    HSE_HZ, HSI_HZ, HseCheck, HseMeasurement, PLL_FROM_HSE, PLL_FROM_HSI, PLLCFGR_FIELDS, PllConfig,
};
#[cfg(doc)]
use crate::clock::{PCLK1_HZ, PCLK2_HZ, SYSCLK_HZ};

/// How long the crystal is given to start, seconds.
pub const HSE_STARTUP_S: f32 = 0.1;
/// How long the PLL is given to lock, seconds (the datasheet's lock time is at most
/// 200 us).
pub const PLL_LOCK_S: f32 = 0.001;
/// How long the measurement of the crystal may take, seconds (it takes about 2 ms at 8 MHz).
const MEASURE_S: f32 = 0.02;

/// Seconds in cycles of the HSI, the clock the core runs on while it waits.
const fn hsi_cycles(s: f32) -> u32 {
    (s * HSI_HZ as f32) as u32
}

/// RCC_CFGR.RTCPRE: HSE_RTC = the crystal / 31 (at most 806 kHz with the stated crystals,
/// slow enough for a capture every 8 edges to be polled).
const RTCPRE: u8 = 31;
/// Edges per capture (TIM11's input prescaler, IC1PSC = 0b11).
const EDGES_PER_CAPTURE: u32 = 8;
/// Captures summed: 64 x 8 x 31 = 15,872 crystal cycles, about 2 ms at 8 MHz, 0.6 ms at
/// 25 MHz (over 10,000 HSI ticks: a resolution better than 0.01 %).
const CAPTURES: u32 = 64;

/// Why the board runs on the HSI.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum Fallback {
    /// The crystal did not start within [`HSE_STARTUP_S`].
    NoCrystal,
    /// The crystal started but its divided clock was not counted.
    NoSignal,
    /// The crystal is not the build's (its measured frequency, Hz).
    Unexpected(u32),
    /// The PLL did not lock from the crystal.
    PllNoLock,
}

/// What the clock start did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum Started {
    /// The crystal (measured frequency, Hz) through the PLL, the clock security system on.
    Crystal(u32),
    /// The HSI through the PLL, and why.
    Fallback(Fallback),
}

/// The PLL did not lock even from the HSI: the board cannot run at its clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub struct NoClock;

/// Bounded wait: polls `ready` until it holds or `cycles` cycles of the DWT counter passed.
fn wait(cycles: u32, mut ready: impl FnMut() -> bool) -> bool {
    let t0 = cortex_m::peripheral::DWT::cycle_count();
    loop {
        if ready() {
            return true;
        }
        if cortex_m::peripheral::DWT::cycle_count().wrapping_sub(t0) > cycles {
            return false;
        }
    }
}

/// Starts the clocks (module doc); the DWT cycle counter must be running.
pub fn start(
    rcc: &pac::RCC,
    flash: &pac::FLASH,
    tim11: &pac::TIM11,
    dbgmcu: &pac::DBGMCU,
) -> Result<Started, NoClock> {
    // 1. The crystal.
    rcc.cr().modify(|_, w| w.hseon().set_bit());
    let crystal = if wait(hsi_cycles(HSE_STARTUP_S), || {
        rcc.cr().read().hserdy().bit_is_set()
    }) {
        // 2. Is it the expected one?
        let m = measure_hse(rcc, tim11);
        let check = m.judge(HSE_HZ);
        defmt::info!(
            "clock: crystal counted {} cycles in {} HSI ticks: {} (the build expects {} Hz)",
            m.hse_cycles,
            m.hsi_ticks,
            defmt::Debug2Format(&check),
            HSE_HZ
        );
        match check {
            HseCheck::Expected(hz) => Ok(hz),
            HseCheck::Unexpected(hz) => Err(Fallback::Unexpected(hz)),
            HseCheck::NoSignal => Err(Fallback::NoSignal),
        }
    } else {
        Err(Fallback::NoCrystal)
    };
    // 3. The flash's wait states for 168 MHz, before the clock rises.
    let rev_id = dbgmcu.idcode().read().rev_id().bits();
    let rev_a = rev_id == 0x1000;
    flash.acr().modify(|_, w| {
        w.latency().ws5();
        w.icen().set_bit();
        w.dcen().set_bit();
        w.prften().bit(!rev_a)
    });
    if !wait(hsi_cycles(PLL_LOCK_S), || {
        flash.acr().read().latency().is_ws5()
    }) {
        defmt::error!("clock: the flash did not take 5 wait states");
        return Err(NoClock);
    }
    // 4.-5. The PLL from the crystal, or from the HSI.
    let started = match crystal {
        Ok(hz) => {
            if run_pll(rcc, &PLL_FROM_HSE, true, rev_id) {
                Started::Crystal(hz)
            } else {
                Started::Fallback(Fallback::PllNoLock)
            }
        }
        Err(why) => Started::Fallback(why),
    };
    if let Started::Fallback(why) = started {
        rcc.cr().modify(|_, w| w.hseon().clear_bit());
        defmt::warn!("clock: on the HSI: {}", why);
        if !run_pll(rcc, &PLL_FROM_HSI, false, rev_id) {
            defmt::error!("clock: the PLL does not lock from the HSI either");
            return Err(NoClock);
        }
    }
    // 6. The buses' dividers, then SYSCLK from the PLL.
    rcc.cfgr().modify(|_, w| {
        w.hpre().div1();
        w.ppre1().div4();
        w.ppre2().div2()
    });
    // "The clocks are divided with the new prescaler factor from 1 to 16 AHB cycles after
    // write" (RM0090, RCC_CFGR).
    cortex_m::asm::delay(16);
    rcc.cfgr().modify(|_, w| w.sw().pll());
    if !wait(hsi_cycles(PLL_LOCK_S), || rcc.cfgr().read().sws().is_pll()) {
        defmt::error!("clock: SYSCLK did not switch to the PLL");
        return Err(NoClock);
    }
    // 7. The clock security system watches the crystal (its NMI: `super::f405`).
    if matches!(started, Started::Crystal(_)) {
        rcc.cr().modify(|_, w| w.csson().set_bit());
    }
    Ok(started)
}

/// Programs the PLL with `pll` from the crystal (`from_hse`) or the HSI, logs it (with the
/// silicon's revision, `rev_id`, for the prefetch), starts it and waits for the lock; true
/// when locked (false: turned off again).
fn run_pll(rcc: &pac::RCC, pll: &PllConfig, from_hse: bool, rev_id: u16) -> bool {
    rcc.cr().modify(|_, w| w.pllon().clear_bit());
    let fields = pll.pllcfgr(from_hse);
    // Note(unsafe): RCC_PLLCFGR's PLLM, PLLN and PLLQ have no safe writer in the PAC; the
    // value is a configuration `PllConfig::check` passed (at compile time), confined to the
    // register's fields, the reserved bits kept as read; the PLL is off while it is written.
    #[allow(unsafe_code)]
    rcc.pllcfgr()
        .modify(|r, w| unsafe { w.bits((r.bits() & !PLLCFGR_FIELDS) | fields) });
    defmt::info!(
        "clock: switching to the PLL from the {} at {} Hz: M {} N {} P {} Q {}, SYSCLK {} Hz; flash 5 wait states, REV_ID {=u16:#06x}, prefetch {}",
        if from_hse { "crystal" } else { "HSI" },
        pll.source_hz,
        pll.m,
        pll.n,
        pll.p,
        pll.q,
        pll.sysclk_hz(),
        rev_id,
        if rev_id == 0x1000 {
            "off (revision A)"
        } else {
            "on"
        }
    );
    rcc.cr().modify(|_, w| w.pllon().set_bit());
    if wait(hsi_cycles(PLL_LOCK_S), || {
        rcc.cr().read().pllrdy().bit_is_set()
    }) {
        true
    } else {
        rcc.cr().modify(|_, w| w.pllon().clear_bit());
        false
    }
}

/// Counts [`CAPTURES`] captures of every 8th edge of HSE_RTC with TIM11 (clocked by APB2,
/// the HSI at this point), each within its share of [`MEASURE_S`]; the interval summed
/// capture to capture (each well under the 16-bit counter's 4 ms wrap). Leaves TIM11 off
/// and its clock disabled. No count (`hsi_ticks` 0) when an edge did not come in time or one
/// was missed (overcapture).
fn measure_hse(rcc: &pac::RCC, tim11: &pac::TIM11) -> HseMeasurement {
    rcc.cfgr().modify(|_, w| w.rtcpre().set(RTCPRE));
    rcc.apb2enr().modify(|_, w| w.tim11en().set_bit());
    tim11.psc().write(|w| w.psc().set(0));
    tim11.arr().write(|w| w.arr().set(0xFFFF));
    tim11.ccmr1_input().write(|w| {
        w.cc1s().ti1();
        w.ic1psc().eight_events()
    });
    // TI1_RMP = 0b10: TIM11's channel 1 input is HSE_RTC.
    // Note(unsafe): TIM11_OR's remap field has no safe writer in the PAC; 0b10 is RM0090's
    // value for HSE_RTC, and the timer is stopped while it is written.
    #[allow(unsafe_code)]
    tim11.or().write(|w| unsafe { w.rmp().bits(0b10) });
    tim11.ccer().write(|w| w.cc1e().set_bit());
    tim11.egr().write(|w| w.ug().set_bit());
    tim11.sr().write(|w| w);
    tim11.cr1().write(|w| w.cen().set_bit());

    let per_capture = hsi_cycles(MEASURE_S) / (CAPTURES + 1);
    let capture = || -> Option<u16> {
        if !wait(per_capture, || tim11.sr().read().cc1if().bit_is_set()) {
            return None;
        }
        // Reading CCR1 clears CC1IF.
        Some(tim11.ccr(0).read().ccr().bits())
    };
    let mut ticks = 0u32;
    let mut ok = true;
    if let Some(mut prev) = capture() {
        for _ in 0..CAPTURES {
            let Some(t) = capture() else {
                ok = false;
                break;
            };
            ticks += u32::from(t.wrapping_sub(prev));
            prev = t;
        }
    } else {
        ok = false;
    }
    ok &= tim11.sr().read().cc1of().bit_is_clear();

    tim11.cr1().write(|w| w);
    tim11.or().write(|w| w);
    rcc.apb2enr().modify(|_, w| w.tim11en().clear_bit());
    rcc.cfgr().modify(|_, w| w.rtcpre().set(0));
    HseMeasurement {
        hse_cycles: CAPTURES * EDGES_PER_CAPTURE * RTCPRE as u32,
        hsi_ticks: if ok { ticks } else { 0 },
    }
}
