//! What the board found at reset, and what the application does about it.
//!
//! Place in the data flow: at boot, before the application exists. The board reads why the
//! MCU reset (the STM32F4's reset flags in RCC_CSR, decoded by [`reset_cause_from_rcc_csr`],
//! then cleared), which clock it runs on, and whether a fault record survived the reset
//! (`crate::board::fault`); it hands them to [`crate::app::App::new`] as a [`BootReport`].
//! The application puts the cause and the clock in every telemetry frame
//! ([`Telemetry::reset_cause`], [`Telemetry::clock`]) and, after an abnormal reset, keeps the
//! controller in standby until the peer acknowledges ([`BootReport::needs_acknowledgement`]).
//!
//! Invariant: after any reset the controller starts in standby with the trim commands; it
//! never resumes the mode it had. After a watchdog, brown-out, low-power or unknown reset,
//! or with a fault record from before it, `Engage` requests are not passed to the
//! controller (they are counted, `LinkCounters::engage_inhibited`) until a `Reset` request
//! arrives: a peer that keeps asking to engage while it sees standby (as the simulator's
//! does) does not re-engage the flight computer without noticing that it reset.
//!
//! The same holds on the internal-oscillator fallback ([`ClockSource::InternalFallback`]),
//! whatever the reset: the link's bit timing then rests on the HSI, whose error over the
//! board's temperature range (-8..+4.5 %, the STM32F405xx datasheet's HSI characteristics)
//! can exceed what a 16x-oversampled receiver tolerates (RM0090, "USART receiver tolerance
//! to clock deviation": 3.41 % with the baud-rate register's fraction in use), and a lower
//! baud rate would not help (the error is a ratio). The peer's `Reset` request is the
//! verification: it arrives only if the peer decoded this board's frames (the telemetry
//! that says `InternalFallback`) and this board decoded the peer's, both at this clock.

use ibvs_core::wire::{ClockSource, ResetCause};

#[cfg(doc)]
use ibvs_core::wire::Telemetry;

/// Reset flags of the STM32F4's RCC_CSR (RM0090, "RCC clock control & status register"),
/// set by hardware, cleared together by writing [`rcc_csr::RMVF`].
pub mod rcc_csr {
    /// Low-power management reset.
    pub const LPWRRSTF: u32 = 1 << 31;
    /// Window watchdog reset.
    pub const WWDGRSTF: u32 = 1 << 30;
    /// Independent watchdog reset.
    pub const IWDGRSTF: u32 = 1 << 29;
    /// Software reset (the core's SYSRESETREQ).
    pub const SFTRSTF: u32 = 1 << 28;
    /// Power-on / power-down reset.
    pub const PORRSTF: u32 = 1 << 27;
    /// Reset from the NRST pin. The internal resets drive the pin too, so it comes with
    /// them: it means the pin alone only when no other flag is set.
    pub const PINRSTF: u32 = 1 << 26;
    /// Brown-out reset; a power-on reset sets it as well.
    pub const BORRSTF: u32 = 1 << 25;
    /// Write 1 to clear every reset flag.
    pub const RMVF: u32 = 1 << 24;
}

/// The reset's cause from RCC_CSR's flags. Several flags come together (every internal
/// reset pulses NRST, a power-on also sets the brown-out flag), so the most specific wins:
/// low-power, window watchdog, independent watchdog, software, power-on, brown-out, pin.
/// No flag: [`ResetCause::Unknown`].
pub const fn reset_cause_from_rcc_csr(csr: u32) -> ResetCause {
    use rcc_csr::*;
    if csr & LPWRRSTF != 0 {
        ResetCause::LowPower
    } else if csr & WWDGRSTF != 0 {
        ResetCause::WindowWatchdog
    } else if csr & IWDGRSTF != 0 {
        ResetCause::IndependentWatchdog
    } else if csr & SFTRSTF != 0 {
        ResetCause::Software
    } else if csr & PORRSTF != 0 {
        ResetCause::PowerOn
    } else if csr & BORRSTF != 0 {
        ResetCause::BrownOut
    } else if csr & PINRSTF != 0 {
        ResetCause::Pin
    } else {
        ResetCause::Unknown
    }
}

/// What the board found at reset.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct BootReport {
    /// Why the MCU reset.
    pub reset_cause: ResetCause,
    /// The clock it runs on.
    pub clock: ClockSource,
    /// A fault record (panic, HardFault, clock failure) survived the reset.
    pub previous_fault: bool,
}

impl BootReport {
    /// A clean power-on (the `qemu` board: every QEMU run starts from power-on, and its
    /// board never resets itself: a fault ends QEMU).
    pub const fn power_on() -> Self {
        Self {
            reset_cause: ResetCause::PowerOn,
            clock: ClockSource::NotReported,
            previous_fault: false,
        }
    }

    /// True when the peer must acknowledge the boot (a `Reset` request) before an `Engage`
    /// request reaches the controller: the cause needs it
    /// ([`ResetCause::needs_acknowledgement`]), a fault preceded the reset, or the board
    /// runs on the internal oscillator (module doc).
    pub const fn needs_acknowledgement(&self) -> bool {
        self.previous_fault
            || self.reset_cause.needs_acknowledgement()
            || matches!(self.clock, ClockSource::InternalFallback)
    }
}

#[cfg(test)]
mod tests {
    use super::rcc_csr::*;
    use super::*;

    #[test]
    fn the_most_specific_reset_flag_names_the_cause() {
        // As the hardware sets them: internal resets pulse NRST; a power-on sets BOR too.
        let cases = [
            (PORRSTF | BORRSTF | PINRSTF, ResetCause::PowerOn),
            (BORRSTF | PINRSTF, ResetCause::BrownOut),
            (PINRSTF, ResetCause::Pin),
            (SFTRSTF | PINRSTF, ResetCause::Software),
            (IWDGRSTF | PINRSTF, ResetCause::IndependentWatchdog),
            (WWDGRSTF | PINRSTF, ResetCause::WindowWatchdog),
            (LPWRRSTF | PINRSTF, ResetCause::LowPower),
            // A watchdog reset of a board whose flags were never cleared since power-on.
            (
                IWDGRSTF | PORRSTF | BORRSTF | PINRSTF,
                ResetCause::IndependentWatchdog,
            ),
            (0, ResetCause::Unknown),
            // RMVF and the oscillator bits (LSION, LSIRDY) are not reset flags.
            (RMVF | 0b11, ResetCause::Unknown),
        ];
        for (csr, want) in cases {
            assert_eq!(reset_cause_from_rcc_csr(csr), want, "{csr:#010x}");
        }
    }

    #[test]
    fn only_a_deliberate_start_without_a_fault_engages_at_once() {
        let report = |reset_cause, previous_fault| BootReport {
            reset_cause,
            clock: ClockSource::Crystal,
            previous_fault,
        };
        for cause in [ResetCause::PowerOn, ResetCause::Pin, ResetCause::Software] {
            assert!(!report(cause, false).needs_acknowledgement(), "{cause:?}");
            assert!(report(cause, true).needs_acknowledgement(), "{cause:?}");
        }
        for cause in [
            ResetCause::Unknown,
            ResetCause::BrownOut,
            ResetCause::IndependentWatchdog,
            ResetCause::WindowWatchdog,
            ResetCause::LowPower,
        ] {
            assert!(report(cause, false).needs_acknowledgement(), "{cause:?}");
        }
        assert!(!BootReport::power_on().needs_acknowledgement());
        // On the HSI, whatever the reset: the link is verified by the acknowledgement.
        for cause in [ResetCause::PowerOn, ResetCause::Pin, ResetCause::Software] {
            let on_hsi = BootReport {
                clock: ClockSource::InternalFallback,
                ..report(cause, false)
            };
            assert!(on_hsi.needs_acknowledgement(), "{cause:?}");
        }
    }
}
