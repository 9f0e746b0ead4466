//! The `f405` board's clock tree, as numbers: which crystal the build expects, the main PLL's
//! factors for it and the reference manual's limits they must meet, and the judgement of the
//! crystal's frequency measured against the internal RC oscillator at boot.
//!
//! Place in the data flow: at boot, before the application exists. The board
//! (`crate::board`, `f405`) starts the crystal, measures it against the HSI
//! ([`HseMeasurement`], judged by [`HseMeasurement::judge`]), then programs the PLL with
//! [`PLL_FROM_HSE`] (or [`PLL_FROM_HSI`] when the crystal did not start or is not the one the
//! build expects) and switches SYSCLK to it. Board-independent arithmetic, so that it is
//! unit-tested on the host; the register sequence is the board's.
//!
//! Why the crystal is a build-time choice, checked: a flight controller carries an 8, 12, 16
//! or 25 MHz crystal, and the PLL's input divider is computed from the frequency the build
//! assumes. Run from another crystal, the PLL's input and VCO leave RM0090's ranges (an 8 MHz
//! build on a 25 MHz crystal: 6.25 MHz in, 1.05 GHz VCO) or SYSCLK leaves the part's (on a
//! 12 MHz crystal: 252 MHz), and the PLL may never lock. So the build names its crystal from
//! [`CRYSTALS_HZ`] (cargo features `hse-12mhz`, `hse-16mhz`, `hse-25mhz`; 8 MHz without
//! one), the PLL's factors for it are computed and checked against RM0090's limits at compile
//! time ([`PllConfig::check`]), and at boot the crystal is measured before the PLL is fed
//! from it: a crystal that is not the expected one is not used.
//!
//! Limits (RM0090, "RCC PLL configuration register (RCC_PLLCFGR)" and "Clocks"): the PLL's
//! input (source / PLLM, 2 <= PLLM <= 63) from 1 to 2 MHz (2 MHz recommended, less jitter);
//! the VCO (input x PLLN, 50 <= PLLN <= 432) from 100 to 432 MHz; SYSCLK = VCO / PLLP, PLLP
//! one of 2, 4, 6, 8, at most 168 MHz on the STM32F405; the 48 MHz domain = VCO / PLLQ,
//! 2 <= PLLQ <= 15, at most 48 MHz (USB OTG FS needs exactly 48 MHz; SDIO and the RNG at
//! most 48 MHz); AHB at most 168 MHz, APB1 at most 42 MHz, APB2 at most 84 MHz.
//!
//! Invariants: every configuration this module hands out has passed [`PllConfig::check`];
//! nothing here panics (the constants' checks fail the build instead).

/// SYSCLK and HCLK, Hz: the STM32F405's maximum.
pub const SYSCLK_HZ: u32 = 168_000_000;
/// APB1 (PCLK1), Hz: HCLK / 4, its maximum.
pub const PCLK1_HZ: u32 = SYSCLK_HZ / 4;
/// APB2 (PCLK2, USART1's clock), Hz: HCLK / 2, its maximum.
pub const PCLK2_HZ: u32 = SYSCLK_HZ / 2;
/// The internal RC oscillator (HSI), nominal, Hz.
pub const HSI_HZ: u32 = 16_000_000;

/// The crystals a build may name, Hz: those flight controllers carry.
pub const CRYSTALS_HZ: [u32; 4] = [8_000_000, 12_000_000, 16_000_000, 25_000_000];

#[cfg(any(
    all(feature = "hse-12mhz", feature = "hse-16mhz"),
    all(feature = "hse-12mhz", feature = "hse-25mhz"),
    all(feature = "hse-16mhz", feature = "hse-25mhz"),
))]
compile_error!("name one crystal: at most one of `hse-12mhz`, `hse-16mhz`, `hse-25mhz`");

/// The crystal this build expects, Hz: the `hse-*` feature's, or 8 MHz without one.
pub const HSE_HZ: u32 = if cfg!(feature = "hse-25mhz") {
    25_000_000
} else if cfg!(feature = "hse-16mhz") {
    16_000_000
} else if cfg!(feature = "hse-12mhz") {
    12_000_000
} else {
    8_000_000
};

/// The main PLL's factors for one source (RCC_PLLCFGR's PLLM, PLLN, PLLP, PLLQ).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PllConfig {
    /// The source's frequency, Hz (the crystal's or the HSI's).
    pub source_hz: u32,
    /// Input divider PLLM.
    pub m: u32,
    /// VCO multiplier PLLN.
    pub n: u32,
    /// SYSCLK divider PLLP (2, 4, 6 or 8).
    pub p: u32,
    /// 48 MHz-domain divider PLLQ.
    pub q: u32,
}

/// A limit of RM0090's that a PLL configuration breaks (the frequency or factor, Hz or
/// plain number), or a source for which no exact configuration exists.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PllError {
    /// PLLM outside 2..=63.
    DividerM(u32),
    /// The PLL's input (source / PLLM) outside 1..=2 MHz.
    Input(u32),
    /// PLLN outside 50..=432.
    MultiplierN(u32),
    /// The VCO (input x PLLN) outside 100..=432 MHz.
    Vco(u32),
    /// PLLP not 2, 4, 6 or 8.
    DividerP(u32),
    /// SYSCLK (VCO / PLLP) above 168 MHz.
    Sysclk(u32),
    /// PLLQ outside 2..=15.
    DividerQ(u32),
    /// The 48 MHz domain (VCO / PLLQ) above 48 MHz.
    Domain48(u32),
    /// No PLLM gives a 1 or 2 MHz input from this source, or no factors give exactly the
    /// asked SYSCLK from it.
    NoExactConfig(u32),
}

impl PllConfig {
    /// The PLL's input, Hz.
    pub const fn input_hz(&self) -> u32 {
        self.source_hz / self.m
    }

    /// The VCO's output, Hz (computed as the hardware divides: input first).
    pub const fn vco_hz(&self) -> u32 {
        self.input_hz() * self.n
    }

    /// SYSCLK from this configuration, Hz.
    pub const fn sysclk_hz(&self) -> u32 {
        self.vco_hz() / self.p
    }

    /// The 48 MHz domain's clock, Hz.
    pub const fn domain48_hz(&self) -> u32 {
        self.vco_hz() / self.q
    }

    /// The factors that give exactly `sysclk_hz` from `source_hz` with a 2 MHz input (or
    /// 1 MHz when the source is not a multiple of 2 MHz), PLLP = 2 and the 48 MHz domain at
    /// or below 48 MHz; checked ([`PllConfig::check`]).
    pub const fn for_source(source_hz: u32, sysclk_hz: u32) -> Result<Self, PllError> {
        let input_hz = if source_hz.is_multiple_of(2_000_000) {
            2_000_000
        } else if source_hz.is_multiple_of(1_000_000) {
            1_000_000
        } else {
            return Err(PllError::NoExactConfig(source_hz));
        };
        let p = 2;
        let vco_hz = match sysclk_hz.checked_mul(p) {
            Some(v) => v,
            None => return Err(PllError::Sysclk(sysclk_hz)),
        };
        if source_hz < input_hz || !vco_hz.is_multiple_of(input_hz) {
            return Err(PllError::NoExactConfig(source_hz));
        }
        let config = Self {
            source_hz,
            m: source_hz / input_hz,
            n: vco_hz / input_hz,
            p,
            q: vco_hz.div_ceil(48_000_000),
        };
        match config.check() {
            Ok(()) => Ok(config),
            Err(e) => Err(e),
        }
    }

    /// Checks every limit of RM0090's (module doc), in the order the signal meets them; the
    /// first one broken.
    pub const fn check(&self) -> Result<(), PllError> {
        if self.m < 2 || self.m > 63 {
            return Err(PllError::DividerM(self.m));
        }
        let input = self.input_hz();
        if input < 1_000_000 || input > 2_000_000 {
            return Err(PllError::Input(input));
        }
        if self.n < 50 || self.n > 432 {
            return Err(PllError::MultiplierN(self.n));
        }
        let vco = self.vco_hz();
        if vco < 100_000_000 || vco > 432_000_000 {
            return Err(PllError::Vco(vco));
        }
        if !matches!(self.p, 2 | 4 | 6 | 8) {
            return Err(PllError::DividerP(self.p));
        }
        if self.sysclk_hz() > SYSCLK_HZ {
            return Err(PllError::Sysclk(self.sysclk_hz()));
        }
        if self.q < 2 || self.q > 15 {
            return Err(PllError::DividerQ(self.q));
        }
        if self.domain48_hz() > 48_000_000 {
            return Err(PllError::Domain48(self.domain48_hz()));
        }
        Ok(())
    }
}

/// RCC_PLLCFGR's fields (RM0090): PLLM bits 5:0, PLLN 14:6, PLLP 17:16 (`p / 2 - 1`),
/// PLLSRC 22 (1: HSE), PLLQ 27:24. Reserved bits outside it keep their reset values.
pub const PLLCFGR_FIELDS: u32 = 0x3F | (0x1FF << 6) | (0b11 << 16) | (1 << 22) | (0xF << 24);

impl PllConfig {
    /// RCC_PLLCFGR's fields for this configuration ([`PLLCFGR_FIELDS`]), the crystal
    /// (`from_hse`) or the HSI as the source.
    pub const fn pllcfgr(&self, from_hse: bool) -> u32 {
        (self.m & 0x3F)
            | ((self.n & 0x1FF) << 6)
            | (((self.p / 2).saturating_sub(1) & 0b11) << 16)
            | ((from_hse as u32) << 22)
            | ((self.q & 0xF) << 24)
    }
}

/// The PLL from this build's crystal ([`HSE_HZ`]) to [`SYSCLK_HZ`]; a crystal without a
/// valid, exact configuration fails the build here.
pub const PLL_FROM_HSE: PllConfig = match PllConfig::for_source(HSE_HZ, SYSCLK_HZ) {
    Ok(c) => c,
    Err(_) => panic!("no PLL configuration within RM0090's limits for this crystal"),
};

/// The PLL from the HSI to [`SYSCLK_HZ`] (the fallback).
pub const PLL_FROM_HSI: PllConfig = match PllConfig::for_source(HSI_HZ, SYSCLK_HZ) {
    Ok(c) => c,
    Err(_) => panic!("no PLL configuration within RM0090's limits for the HSI"),
};

// Every crystal of the stated set has one, exactly at SYSCLK, so any `hse-*` build links.
const _: () = {
    let mut i = 0;
    while i < CRYSTALS_HZ.len() {
        match PllConfig::for_source(CRYSTALS_HZ[i], SYSCLK_HZ) {
            Ok(c) => assert!(c.sysclk_hz() == SYSCLK_HZ),
            Err(_) => panic!("a stated crystal has no PLL configuration"),
        }
        i += 1;
    }
};

/// The HSI's accuracy over the board's whole temperature range (STM32F405xx/407xx
/// datasheet, "High-speed internal (HSI) RC oscillator" characteristics: within 1 % at
/// 25 °C, -4..+4 % over -10..85 °C, -8..+4.5 % over -40..105 °C), parts per thousand.
pub const HSI_ERROR_PPT: core::ops::RangeInclusive<i32> = -80..=45;

/// What a measured crystal frequency may read, relative to the expected one, parts per
/// thousand: the HSI's error turned into the measurement's (a slow HSI reads the crystal
/// fast, 1 / 0.92 = +8.7 %; a fast one slow, 1 / 1.045 = -4.3 %), widened to -5..+10 %.
/// Crystals of [`CRYSTALS_HZ`] are at least 33 % apart, so the window never takes one for
/// another; it cannot tell apart crystals within about 10 % (24 and 25 MHz).
pub const HSE_WINDOW_PPT: core::ops::RangeInclusive<i32> = -50..=100;

/// The crystal counted against the HSI: `hse_cycles` cycles of the crystal took
/// `hsi_ticks` ticks of the HSI (the board counts edges of HSE_RTC, the crystal divided by
/// RCC_CFGR's RTCPRE, with a timer clocked from the HSI: RM0090, "Internal/external clock
/// measurement using TIM5/TIM11").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HseMeasurement {
    /// Crystal cycles counted.
    pub hse_cycles: u32,
    /// HSI ticks they took (0: no edge seen in the time allowed).
    pub hsi_ticks: u32,
}

/// The judgement of a crystal measurement.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HseCheck {
    /// The crystal is the expected one (within [`HSE_WINDOW_PPT`]): its measured frequency.
    Expected(u32),
    /// Another frequency (Hz, as measured): the PLL must not run from it.
    Unexpected(u32),
    /// No edge of the crystal's divided clock was counted in the time allowed.
    NoSignal,
}

impl HseMeasurement {
    /// The crystal's frequency as measured, Hz, taking the HSI as exact (`None` without a
    /// count).
    pub const fn measured_hz(&self) -> Option<u32> {
        if self.hsi_ticks == 0 || self.hse_cycles == 0 {
            return None;
        }
        let hz = self.hse_cycles as u64 * HSI_HZ as u64 / self.hsi_ticks as u64;
        if hz > u32::MAX as u64 {
            Some(u32::MAX)
        } else {
            Some(hz as u32)
        }
    }

    /// Whether the crystal is the `expected_hz` one.
    pub const fn judge(&self, expected_hz: u32) -> HseCheck {
        let Some(hz) = self.measured_hz() else {
            return HseCheck::NoSignal;
        };
        let deviation_ppt = (hz as i64 - expected_hz as i64) * 1000
            / if expected_hz == 0 {
                1
            } else {
                expected_hz as i64
            };
        if deviation_ppt >= *HSE_WINDOW_PPT.start() as i64
            && deviation_ppt <= *HSE_WINDOW_PPT.end() as i64
        {
            HseCheck::Expected(hz)
        } else {
            HseCheck::Unexpected(hz)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_stated_crystal_and_the_hsi_give_168_mhz_inside_every_limit() {
        for source in CRYSTALS_HZ.into_iter().chain([HSI_HZ]) {
            let c = PllConfig::for_source(source, SYSCLK_HZ).expect("a configuration");
            assert_eq!(c.check(), Ok(()), "{source}");
            assert_eq!(c.sysclk_hz(), SYSCLK_HZ, "{source}");
            assert_eq!(c.domain48_hz(), 48_000_000, "{source}");
            let want_input = if source == 25_000_000 {
                1_000_000
            } else {
                2_000_000
            };
            assert_eq!((c.input_hz(), c.p), (want_input, 2), "{source}");
        }
        // The values ST's own examples use for these crystals.
        let c = PllConfig::for_source(8_000_000, SYSCLK_HZ).expect("8 MHz");
        assert_eq!((c.m, c.n, c.p, c.q), (4, 168, 2, 7));
        let c = PllConfig::for_source(25_000_000, SYSCLK_HZ).expect("25 MHz");
        assert_eq!((c.m, c.n, c.p, c.q), (25, 336, 2, 7));
        assert_eq!(
            PLL_FROM_HSI,
            PllConfig::for_source(HSI_HZ, SYSCLK_HZ).expect("HSI")
        );
        assert_eq!(PLL_FROM_HSE.source_hz, HSE_HZ);
    }

    /// The failure the build-time choice prevents: an 8 MHz build's factors fed by another
    /// crystal break RM0090's limits, and the check names the first one broken.
    #[test]
    fn an_8_mhz_configuration_on_another_crystal_breaks_the_limits() {
        let for_8 = PllConfig::for_source(8_000_000, SYSCLK_HZ).expect("8 MHz");
        let on = |source_hz| PllConfig { source_hz, ..for_8 };
        // 25 MHz: 6.25 MHz into the PLL (and a VCO of 1.05 GHz behind it).
        assert_eq!(on(25_000_000).check(), Err(PllError::Input(6_250_000)));
        assert_eq!(on(25_000_000).vco_hz(), 1_050_000_000);
        // 12 MHz: 3 MHz in, 504 MHz VCO, SYSCLK 252 MHz.
        assert_eq!(on(12_000_000).check(), Err(PllError::Input(3_000_000)));
        assert_eq!(on(12_000_000).sysclk_hz(), 252_000_000);
    }

    #[test]
    fn each_limit_is_checked() {
        let ok = PllConfig::for_source(8_000_000, SYSCLK_HZ).expect("8 MHz");
        let cases = [
            (PllConfig { m: 1, ..ok }, PllError::DividerM(1)),
            (PllConfig { m: 64, ..ok }, PllError::DividerM(64)),
            (PllConfig { m: 16, ..ok }, PllError::Input(500_000)),
            (PllConfig { n: 49, m: 8, ..ok }, PllError::MultiplierN(49)),
            (PllConfig { n: 433, ..ok }, PllError::MultiplierN(433)),
            (PllConfig { n: 60, m: 8, ..ok }, PllError::Vco(60_000_000)),
            (PllConfig { n: 217, ..ok }, PllError::Vco(434_000_000)),
            (PllConfig { p: 3, ..ok }, PllError::DividerP(3)),
            (PllConfig { n: 200, ..ok }, PllError::Sysclk(200_000_000)),
            (PllConfig { q: 1, ..ok }, PllError::DividerQ(1)),
            (PllConfig { q: 16, ..ok }, PllError::DividerQ(16)),
            (PllConfig { q: 6, ..ok }, PllError::Domain48(56_000_000)),
        ];
        for (c, want) in cases {
            assert_eq!(c.check(), Err(want), "{c:?}");
        }
        // Sources with no exact 168 MHz configuration are refused, not approximated.
        assert_eq!(
            PllConfig::for_source(14_745_600, SYSCLK_HZ),
            Err(PllError::NoExactConfig(14_745_600))
        );
        assert_eq!(
            PllConfig::for_source(8_000_000, 180_000_000),
            Err(PllError::Sysclk(180_000_000))
        );
    }

    /// `hse` Hz of crystal counted for 2 ms against an HSI off by `hsi_ppt` per mille.
    fn measure(hse: u32, hsi_ppt: i32) -> HseMeasurement {
        let hsi = (HSI_HZ as f64) * (1.0 + f64::from(hsi_ppt) / 1000.0);
        let hse_cycles = hse / 500;
        HseMeasurement {
            hse_cycles,
            hsi_ticks: (f64::from(hse_cycles) / f64::from(hse) * hsi).round() as u32,
        }
    }

    #[test]
    fn the_expected_crystal_passes_at_any_hsi_error_and_no_other_does() {
        let extremes = [*HSI_ERROR_PPT.start(), 0, *HSI_ERROR_PPT.end()];
        for expected in CRYSTALS_HZ {
            for actual in CRYSTALS_HZ {
                for hsi_ppt in extremes {
                    let check = measure(actual, hsi_ppt).judge(expected);
                    let case = format!("{actual} Hz built for {expected} Hz, HSI {hsi_ppt} ppt");
                    if actual == expected {
                        assert!(matches!(check, HseCheck::Expected(_)), "{case}: {check:?}");
                    } else {
                        assert!(
                            matches!(check, HseCheck::Unexpected(_)),
                            "{case}: {check:?}"
                        );
                    }
                }
            }
        }
        // Exact at a nominal HSI; nothing counted is no signal, not a frequency.
        assert_eq!(
            measure(8_000_000, 0).judge(8_000_000),
            HseCheck::Expected(8_000_000)
        );
        let none = HseMeasurement {
            hse_cycles: 7_936,
            hsi_ticks: 0,
        };
        assert_eq!(none.judge(8_000_000), HseCheck::NoSignal);
        // Just outside the window on either side.
        let at = |hz: u32| HseMeasurement {
            hse_cycles: hz / 1000,
            hsi_ticks: HSI_HZ / 1000,
        };
        for (hz, expected) in [
            (7_590_000, false),
            (7_600_000, true),
            (8_800_000, true),
            (8_810_000, false),
        ] {
            let check = at(hz).judge(8_000_000);
            assert_eq!(
                matches!(check, HseCheck::Expected(_)),
                expected,
                "{hz}: {check:?}"
            );
        }
    }
}
