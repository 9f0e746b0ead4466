//! The independent watchdog (IWDG) of the `f405` board: a hung main loop resets the MCU.
//!
//! Place in the data flow: outside it. Started first thing at boot with the long timeout
//! ([`Timeout::LONG`]), which covers the boot (the crystal's bounded start and
//! measurement, the PLL's bounded lock, the store's load); set to the flight timeout ([`Timeout::FLIGHT`]) just before the
//! main loop, which feeds it once per completed pass (`crate::app::Board::pass_completed`:
//! at least once per 20 ms period, the tick waking the loop in both schedules); set to the
//! long timeout again around a configuration store write (a 128 KiB flash erase stalls the
//! CPU for up to 4 s) and back after it. Nothing else feeds it: not the fault path (a
//! panic or HardFault repeats the safe frame until the watchdog resets the board), not an
//! interrupt.
//!
//! Timeouts (RM0090, "Independent watchdog": the counter runs on the LSI, nominally 32 kHz
//! but 17 to 47 kHz over parts and temperature per the datasheet, so each timeout spans
//! that range):
//!
//! | | prescaler | reload | at 32 kHz | 47 kHz .. 17 kHz |
//! |---|---|---|---|---|
//! | [`Timeout::FLIGHT`] | /32 | 99 | 100 ms | 68 .. 188 ms |
//! | [`Timeout::LONG`] | /256 | 999 | 8.0 s | 5.4 .. 15 s |
//!
//! The flight timeout is at least 3 periods at the fastest LSI (a pass is about 1 ms, so
//! only a loop stuck for 3 periods or more resets) and at most 188 ms, well inside the
//! core's 0.5 s hold before a breakaway. The long one outlasts the longest save
//! (`crate::flash::SAVE_MAX_MS`: a 4 s erase at x8 parallelism and the record's programming)
//! even with the fastest LSI (checked at compile time below).
//!
//! PR and RLR are write-protected; writing 0x5555 to KR opens them. RM0090 ("IWDG status
//! register"): a prescaler or reload value can be written only while its update flag (SR's
//! PVU, RVU) is clear, and the update completes when it clears again (up to five LSI
//! cycles); the next reload (0xAAAA) then counts from the new reload value. So each is
//! written only after its flag was seen clear (bounded), and the update awaited after.
//! A debugger halting the core freezes the counter (DBGMCU_APB1_FZ.DBG_IWDG_STOP, set at
//! boot with a debugger attached), so breakpoints do not reset the board.
//!
//! Invariant: nothing here waits unboundedly or panics.

use stm32f4xx_hal::pac::IWDG;

/// A watchdog timeout: IWDG_PR's prescaler code and IWDG_RLR's reload value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub struct Timeout {
    /// IWDG_PR: the LSI divided by 4 << code.
    prescaler_code: u8,
    /// IWDG_RLR: the counter's start, 0..=0xFFF.
    reload: u16,
}

impl Timeout {
    /// 100 ms at the nominal LSI (/32, 100 counts of 1 ms).
    pub const FLIGHT: Self = Self {
        prescaler_code: 3,
        reload: 99,
    };
    /// 8 s at the nominal LSI (/256, 1,000 counts of 8 ms).
    pub const LONG: Self = Self {
        prescaler_code: 6,
        reload: 999,
    };

    /// The timeout at an LSI of `lsi_hz`, milliseconds.
    pub const fn millis_at(self, lsi_hz: u32) -> u32 {
        let divider = 4u32 << self.prescaler_code;
        ((self.reload as u32 + 1) * divider * 1000) / lsi_hz
    }
}

/// The IWDG's keys (IWDG_KR).
const KEY_ACCESS: u16 = 0x5555;

/// Polls of IWDG_SR for a PR/RLR update: five LSI cycles at 17 kHz are about 300 us, which
/// is about 5,000 polls at 16 MHz (the boot's clock) and more at 168 MHz.
const UPDATE_POLLS: u32 = 200_000;

/// The running watchdog.
pub struct Watchdog {
    iwdg: IWDG,
}

impl Watchdog {
    /// Starts the watchdog (it cannot be stopped until reset) with `timeout`.
    pub fn start(iwdg: IWDG, timeout: Timeout) -> Self {
        iwdg.kr().write(|w| w.key().start());
        let mut w = Self { iwdg };
        w.set(timeout);
        w
    }

    /// Reloads the counter.
    pub fn feed(&mut self) {
        self.iwdg.kr().write(|w| w.key().feed());
    }

    /// Waits (at most [`UPDATE_POLLS`] polls) until the flags `busy` picks from IWDG_SR are
    /// clear; true when they are.
    fn settled(&self, busy: impl Fn(&stm32f4xx_hal::pac::iwdg::sr::R) -> bool) -> bool {
        (0..UPDATE_POLLS).any(|_| !busy(&self.iwdg.sr().read()))
    }

    /// Changes the timeout: feeds first (the old timeout restarts), writes PR once PVU is
    /// clear and RLR once RVU is clear, waits for both updates, then feeds, so the counter
    /// restarts at the new reload value. True when every flag was seen clear in time; false
    /// if one was not within the bound (a value not written then keeps the old one, and the
    /// next `set` tries again).
    pub fn set(&mut self, timeout: Timeout) -> bool {
        self.feed();
        // Note(unsafe): 0x5555 is IWDG_KR's documented access key (the PAC names only the
        // reload and start keys); the write opens PR and RLR, nothing else.
        #[allow(unsafe_code)]
        self.iwdg
            .kr()
            .write(|w| unsafe { w.key().bits(KEY_ACCESS) });
        let pr_free = self.settled(|sr| sr.pvu().bit_is_set());
        if pr_free {
            self.iwdg
                .pr()
                .write(|w| w.pr().set(timeout.prescaler_code & 0b111));
        }
        let rlr_free = self.settled(|sr| sr.rvu().bit_is_set());
        if rlr_free {
            self.iwdg
                .rlr()
                .write(|w| w.rl().set(timeout.reload & 0xFFF));
        }
        let done = self.settled(|sr| sr.pvu().bit_is_set() || sr.rvu().bit_is_set());
        self.feed();
        pr_free && rlr_free && done
    }
}

// What the module doc states, checked at build time: the flight timeout is at least three
// 20 ms periods at the fastest LSI and under the core's 0.5 s hold at the slowest; the long
// one outlasts the longest save (a 4 s erase at x8 and the record's programming) at the
// fastest LSI.
const _: () = assert!(Timeout::FLIGHT.millis_at(32_000) == 100);
const _: () = assert!(Timeout::FLIGHT.millis_at(47_000) >= 60);
const _: () = assert!(Timeout::FLIGHT.millis_at(17_000) <= 200);
const _: () = assert!(Timeout::LONG.millis_at(32_000) == 8_000);
const _: () = assert!(Timeout::LONG.millis_at(47_000) >= 5_000);
const _: () = assert!(Timeout::LONG.millis_at(47_000) > crate::flash::SAVE_MAX_MS);
