//! The STM32F405's embedded flash as the configuration store uses it: embedded-storage NOR
//! flash over the flash interface's registers, erasing and writing only the store's two
//! sectors, with the accelerator's caches flushed after every change.
//!
//! Place in the data flow: below `crate::store::ConfigStore` (board-independent). The board
//! (`crate::board::flash`, `f405`) supplies the registers ([`FlashRegisters`]); every decision
//! is here, so that it is tested on the host against a model of the flash interface with
//! its data cache (`tests::Stm32Flash`) and covered by the no-panic link check
//! (`src/bin/nopanic.rs`). Its own driver rather than the HAL's `LockedFlash`, whose read
//! slices the whole flash (a panic path on a bad offset), whose unlock asserts and which does
//! not flush the caches: this one answers every bad request with a named [`FlashError`].
//!
//! RM0090, "Embedded flash memory interface": unlock with the two keys of FLASH_KEYR; a
//! sector erase sets SER, the sector number (SNB) and the parallelism (PSIZE), then STRT,
//! and waits for BSY to clear; programming sets PG and PSIZE = x8 and writes bytes, waiting
//! for BSY after each; the error flags of FLASH_SR (PGSERR, PGPERR, PGAERR, WRPERR, OPERR) are
//! cleared before and checked after each operation; the interface is locked again at the end.
//!
//! - **Caches**: the flash accelerator's instruction and data caches (FLASH_ACR's ICEN and
//!   DCEN, on since boot) are not coherent with erase and program: a line read before an
//!   erase is served again after it. So after every erase and every program each enabled
//!   cache is disabled, reset (ICRST / DCRST, writable only while the cache is off) and
//!   enabled again, as ST's STM32CubeF4 HAL does after an erase (`FLASH_FlushCaches`); the
//!   store's read-back check then reads the flash, not the cache.
//! - **Erase parallelism**: x32 when the brown-out reset is at level 3 (FLASH_OPTCR's BOR_LEV
//!   read when the driver is made): RM0090's "Program/erase parallelism" allows x32 from
//!   2.7 V, and level 3 holds the MCU in reset below its threshold ("Brownout reset (BOR)":
//!   level 3 is for the 2.70 to 3.60 V range); x8 otherwise (any supply from 1.8 V). The
//!   programming stays x8 (byte writes: a record is a few hundred bytes).
//! - **Blackout**: while a sector erases, every fetch from flash stalls, interrupts included:
//!   the CPU stops for [`EraseTime`] (a 128 KiB sector, STM32F405xx datasheet, "Flash memory
//!   programming" characteristics: x8 2 s typical, 4 s at most; x32 1 s typical, 2 s at
//!   most), then the record's programming (about [`PROGRAM_BYTE_MAX_US`] a byte at most).
//!   The board's long watchdog timeout covers the longest ([`SAVE_MAX_MS`], checked at
//!   compile time there), and the store skips the erase when the record is unchanged.
//! - **Flash size**: the part's flash size (F_SIZE, RM0090 "Device electronic signature")
//!   bounds every read; on a 512 KiB part there are no sectors 10 and 11, so the store's
//!   layout is refused at boot instead of read.
//!
//! Invariants: only the store's sectors (10 and 11, [`STORE_SLOTS`]) can be erased or
//! written: any other offset is refused ([`FlashError::Protected`]), so no bug in the store
//! can erase the program; every read is bounds-checked against the part's flash; nothing
//! here panics or waits unboundedly except on BSY, which the hardware clears (and the
//! watchdog bounds).

use embedded_storage::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};

/// Offsets in flash of the configuration store's two slots: sectors 10 and 11
/// (0x080C_0000 and 0x080E_0000), 128 KiB each, outside the program (`memory.x` links the
/// program into sectors 0 to 9).
pub const STORE_SLOTS: [u32; 2] = [0x000C_0000, 0x000E_0000];

/// Length of each slot, bytes: one 128 KiB sector.
pub const STORE_SLOT_LEN: u32 = SECTOR_LEN;

/// The main flash's address.
pub const FLASH_BASE: u32 = 0x0800_0000;
/// The largest main flash of the STM32F405, bytes (the xG parts).
pub const FLASH_MAX_LEN: u32 = 1024 * 1024;
/// The size of sectors 5 to 11, bytes.
const SECTOR_LEN: u32 = 128 * 1024;
/// The first sector that may be erased or written (sector 10), and its number.
const FIRST_WRITABLE: u32 = STORE_SLOTS[0];
const FIRST_WRITABLE_SECTOR: u32 = 10;

/// FLASH_KEYR's unlock sequence.
pub const KEY1: u32 = 0x4567_0123;
/// FLASH_KEYR's second key.
pub const KEY2: u32 = 0xCDEF_89AB;

/// FLASH_ACR (RM0090): LATENCY 2:0, PRFTEN 8, ICEN 9, DCEN 10, ICRST 11, DCRST 12.
pub mod acr {
    /// Instruction cache enable.
    pub const ICEN: u32 = 1 << 9;
    /// Data cache enable.
    pub const DCEN: u32 = 1 << 10;
    /// Instruction cache reset (writable only while ICEN is clear).
    pub const ICRST: u32 = 1 << 11;
    /// Data cache reset (writable only while DCEN is clear).
    pub const DCRST: u32 = 1 << 12;
}

/// FLASH_SR (RM0090): EOP 0, OPERR 1, WRPERR 4, PGAERR 5, PGPERR 6, PGSERR 7, BSY 16.
pub mod sr {
    /// Operation error.
    pub const OPERR: u32 = 1 << 1;
    /// Write protection error.
    pub const WRPERR: u32 = 1 << 4;
    /// Programming alignment error.
    pub const PGAERR: u32 = 1 << 5;
    /// Programming parallelism error.
    pub const PGPERR: u32 = 1 << 6;
    /// Programming sequence error.
    pub const PGSERR: u32 = 1 << 7;
    /// Busy.
    pub const BSY: u32 = 1 << 16;
    /// Every error flag (cleared by writing 1).
    pub const ERRORS: u32 = PGSERR | PGPERR | PGAERR | WRPERR | OPERR;
}

/// FLASH_CR (RM0090): PG 0, SER 1, MER 2, SNB 6:3, PSIZE 9:8, STRT 16, LOCK 31.
pub mod cr {
    /// Programming.
    pub const PG: u32 = 1 << 0;
    /// Sector erase.
    pub const SER: u32 = 1 << 1;
    /// The sector number's field.
    pub const SNB_SHIFT: u32 = 3;
    /// SNB's mask.
    pub const SNB: u32 = 0xF << SNB_SHIFT;
    /// PSIZE's field.
    pub const PSIZE_SHIFT: u32 = 8;
    /// PSIZE's mask.
    pub const PSIZE: u32 = 0b11 << PSIZE_SHIFT;
    /// Start (an erase).
    pub const STRT: u32 = 1 << 16;
    /// Locked.
    pub const LOCK: u32 = 1 << 31;
}

/// FLASH_OPTCR (RM0090): OPTLOCK 0, OPTSTRT 1, BOR_LEV 3:2, user bits 7:5, RDP 15:8,
/// nWRP 27:16.
pub mod optcr {
    /// The option register is locked.
    pub const OPTLOCK: u32 = 1 << 0;
    /// Start the option bytes' programming.
    pub const OPTSTRT: u32 = 1 << 1;
    /// The brown-out reset level's field: `00` level 3 (2.70 V) .. `11` off (the factory's).
    /// (The PAC's names for these values run the other way round: RM0090's bits are used.)
    pub const BOR_LEV: u32 = 0b11 << 2;
    /// The read protection byte's shift.
    pub const RDP_SHIFT: u32 = 8;
    /// RDP's value for level 0 (no read protection).
    pub const RDP_LEVEL_0: u8 = 0xAA;
}

/// The program/erase parallelism (FLASH_CR's PSIZE), by the supply it needs (RM0090,
/// "Program/erase parallelism").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(all(target_os = "none", feature = "f405"), derive(defmt::Format))]
pub enum Parallelism {
    /// Byte: 1.8 to 3.6 V.
    X8,
    /// Word: 2.7 to 3.6 V.
    X32,
}

impl Parallelism {
    /// PSIZE's value.
    pub const fn psize(self) -> u32 {
        match self {
            Self::X8 => 0b00,
            Self::X32 => 0b10,
        }
    }

    /// The x32 erase when FLASH_OPTCR (`optcr`) holds brown-out level 3, else x8.
    pub const fn for_optcr(optcr: u32) -> Self {
        if optcr & optcr::BOR_LEV == 0 {
            Self::X32
        } else {
            Self::X8
        }
    }

    /// How long a 128 KiB sector erase stalls the CPU at this parallelism.
    pub const fn erase_time(self) -> EraseTime {
        match self {
            Self::X8 => EraseTime {
                typical_ms: 2_000,
                max_ms: 4_000,
            },
            Self::X32 => EraseTime {
                typical_ms: 1_000,
                max_ms: 2_000,
            },
        }
    }
}

/// A 128 KiB sector erase's duration (the datasheet's figures), milliseconds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(all(target_os = "none", feature = "f405"), derive(defmt::Format))]
pub struct EraseTime {
    /// Typical.
    pub typical_ms: u32,
    /// At most.
    pub max_ms: u32,
}

/// One byte's programming at most, microseconds (the datasheet's word programming time).
pub const PROGRAM_BYTE_MAX_US: u32 = 100;

/// The longest save the store makes, milliseconds: one sector erase at x8 and the largest
/// record programmed a byte at a time. The board's watchdog must outlast it.
pub const SAVE_MAX_MS: u32 = Parallelism::X8.erase_time().max_ms
    + (crate::store::MAX_RECORD_LEN as u32 * PROGRAM_BYTE_MAX_US).div_ceil(1000);

/// The flash interface's registers and the flash's memory, as the driver uses them (the
/// board implements it over the peripheral; the tests over a model).
pub trait FlashRegisters {
    /// Reads FLASH_ACR.
    fn acr(&mut self) -> u32;
    /// Writes FLASH_ACR.
    fn set_acr(&mut self, value: u32);
    /// Reads FLASH_SR.
    fn sr(&mut self) -> u32;
    /// Writes FLASH_SR (1 clears an error flag).
    fn set_sr(&mut self, value: u32);
    /// Reads FLASH_CR.
    fn cr(&mut self) -> u32;
    /// Writes FLASH_CR.
    fn set_cr(&mut self, value: u32);
    /// Writes FLASH_KEYR.
    fn set_keyr(&mut self, key: u32);
    /// Reads FLASH_OPTCR.
    fn optcr(&mut self) -> u32;
    /// Writes FLASH_OPTCR's low byte (BOR_LEV, the user bits, OPTSTRT, OPTLOCK) alone, as
    /// ST's library does: the read and write protections (bytes 1 to 3) are not written.
    fn set_optcr_byte0(&mut self, value: u8);
    /// Writes FLASH_OPTKEYR.
    fn set_optkeyr(&mut self, key: u32);
    /// The part's flash size (F_SIZE), KiB.
    fn flash_size_kib(&mut self) -> u16;
    /// Reads the flash byte at `offset` from [`FLASH_BASE`] (the caller checked it lies in
    /// the part's flash).
    fn read_byte(&mut self, offset: u32) -> u8;
    /// Writes `byte` at `offset` from [`FLASH_BASE`] (a programming access; the caller
    /// checked it lies in the store's sectors).
    fn write_byte(&mut self, offset: u32, byte: u8);
}

/// Why a flash operation was refused or failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(all(target_os = "none", feature = "f405"), derive(defmt::Format))]
pub enum FlashError {
    /// The range is outside the part's flash.
    OutOfBounds,
    /// The range is outside the store's sectors (erasing or writing there is refused).
    Protected,
    /// An erase range that is not whole sectors.
    NotAligned,
    /// The interface stayed locked after the unlock sequence (a wrong sequence earlier
    /// locks it until reset).
    Locked,
    /// The operation ended with error flags set in FLASH_SR (its bits).
    Failed(u32),
}

impl NorFlashError for FlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            Self::OutOfBounds | Self::Protected => NorFlashErrorKind::OutOfBounds,
            Self::NotAligned => NorFlashErrorKind::NotAligned,
            Self::Locked | Self::Failed(_) => NorFlashErrorKind::Other,
        }
    }
}

/// The flash, read anywhere in the part, erased and written only in the store's sectors.
pub struct StoreFlash<R> {
    regs: R,
    /// The part's flash, bytes (F_SIZE, at most [`FLASH_MAX_LEN`]).
    len: u32,
    /// The erase parallelism the supply allows.
    erase: Parallelism,
}

impl<R: FlashRegisters> StoreFlash<R> {
    /// The driver over the flash interface: reads the part's flash size and the brown-out
    /// level (for the erase parallelism).
    pub fn new(mut regs: R) -> Self {
        let len = (u32::from(regs.flash_size_kib()) * 1024).min(FLASH_MAX_LEN);
        let erase = Parallelism::for_optcr(regs.optcr());
        Self { regs, len, erase }
    }

    /// The registers, back (for a test).
    pub fn into_registers(self) -> R {
        self.regs
    }

    /// The erase parallelism in use.
    pub fn erase_parallelism(&self) -> Parallelism {
        self.erase
    }

    /// The part's flash, bytes.
    pub fn len(&self) -> u32 {
        self.len
    }

    /// True on a part without flash (F_SIZE read 0).
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    fn wait_ready(&mut self) {
        // Bounded by the hardware (an erase is seconds at most), and a hang by the board's
        // independent watchdog. While an erase runs, fetching this loop from flash stalls.
        while self.regs.sr() & sr::BSY != 0 {}
    }

    fn check_errors(&mut self) -> Result<(), FlashError> {
        match self.regs.sr() & sr::ERRORS {
            0 => Ok(()),
            e => Err(FlashError::Failed(e)),
        }
    }

    /// Flushes the accelerator's caches (module doc): each enabled one disabled, reset and
    /// enabled again; the reset bit is written only while its cache is off, as RM0090
    /// requires.
    fn flush_caches(&mut self) {
        for (enable, reset) in [(acr::ICEN, acr::ICRST), (acr::DCEN, acr::DCRST)] {
            let a = self.regs.acr();
            if a & enable != 0 {
                self.regs.set_acr(a & !enable);
                self.regs.set_acr((a & !enable) | reset);
                self.regs.set_acr(a & !enable & !reset);
                self.regs.set_acr((a & !reset) | enable);
            }
        }
    }

    /// Runs `op` with the interface unlocked and no flag left from before; locks it and
    /// flushes the caches after, whatever `op` did.
    fn unlocked(
        &mut self,
        op: impl FnOnce(&mut Self) -> Result<(), FlashError>,
    ) -> Result<(), FlashError> {
        self.wait_ready();
        self.regs.set_keyr(KEY1);
        self.regs.set_keyr(KEY2);
        if self.regs.cr() & cr::LOCK != 0 {
            return Err(FlashError::Locked);
        }
        self.regs.set_sr(sr::ERRORS);
        let r = op(self);
        let c = self.regs.cr();
        self.regs.set_cr((c & !(cr::PG | cr::SER)) | cr::LOCK);
        self.flush_caches();
        r
    }

    /// `[offset, offset + len)` when it lies inside the part's flash.
    fn in_flash(&self, offset: u32, len: usize) -> Result<(), FlashError> {
        let end = u32::try_from(len)
            .ok()
            .and_then(|n| offset.checked_add(n))
            .ok_or(FlashError::OutOfBounds)?;
        if end > self.len {
            Err(FlashError::OutOfBounds)
        } else {
            Ok(())
        }
    }

    /// `[offset, offset + len)` when it lies inside the store's sectors.
    fn writable(&self, offset: u32, len: usize) -> Result<(), FlashError> {
        self.in_flash(offset, len)?;
        if offset < FIRST_WRITABLE {
            Err(FlashError::Protected)
        } else {
            Ok(())
        }
    }
}

impl<R> ErrorType for StoreFlash<R> {
    type Error = FlashError;
}

impl<R: FlashRegisters> ReadNorFlash for StoreFlash<R> {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), FlashError> {
        self.in_flash(offset, bytes.len())?;
        for (at, b) in (offset..).zip(bytes.iter_mut()) {
            *b = self.regs.read_byte(at);
        }
        Ok(())
    }

    fn capacity(&self) -> usize {
        self.len as usize
    }
}

impl<R: FlashRegisters> NorFlash for StoreFlash<R> {
    const WRITE_SIZE: usize = 1;
    const ERASE_SIZE: usize = SECTOR_LEN as usize;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), FlashError> {
        if !from.is_multiple_of(SECTOR_LEN) || !to.is_multiple_of(SECTOR_LEN) || to < from {
            return Err(FlashError::NotAligned);
        }
        self.writable(from, (to - from) as usize)?;
        let psize = self.erase.psize();
        self.unlocked(|f| {
            let mut at = from;
            while at < to {
                // 10 or 11: `writable` keeps `at` inside sectors 10 and 11.
                let sector = FIRST_WRITABLE_SECTOR + (at - FIRST_WRITABLE) / SECTOR_LEN;
                let c = f.regs.cr() & !(cr::PG | cr::SNB | cr::PSIZE);
                let c = c
                    | cr::SER
                    | ((sector << cr::SNB_SHIFT) & cr::SNB)
                    | (psize << cr::PSIZE_SHIFT);
                f.regs.set_cr(c);
                f.regs.set_cr(c | cr::STRT);
                f.wait_ready();
                f.check_errors()?;
                at += SECTOR_LEN;
            }
            Ok(())
        })
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), FlashError> {
        self.writable(offset, bytes.len())?;
        self.unlocked(|f| {
            let c = f.regs.cr() & !(cr::SER | cr::PSIZE);
            f.regs
                .set_cr(c | (Parallelism::X8.psize() << cr::PSIZE_SHIFT) | cr::PG);
            for (at, &b) in (offset..).zip(bytes) {
                f.regs.write_byte(at, b);
                f.wait_ready();
                f.check_errors()?;
            }
            Ok(())
        })
    }
}

/// A model of the STM32F405's flash interface for the host tests (here and in
/// `crate::option_bytes`): RM0090's register rules and the accelerator's data cache.
#[cfg(test)]
pub mod model {
    use std::vec::Vec;

    use super::*;

    /// The data cache's lines (RM0090, "Adaptive real-time memory accelerator": 8 lines of
    /// 128 bits), least recently used first.
    const DCACHE_LINES: usize = 8;
    const LINE: u32 = 16;

    /// The factory's FLASH_OPTCR: BOR off, RDP level 0, no write protection, locked.
    pub const FACTORY_OPTCR: u32 = 0x0FFF_AAED;

    /// The flash interface and the flash behind it.
    #[derive(Debug, Clone)]
    pub struct Stm32Flash {
        /// The flash array.
        pub mem: Vec<u8>,
        /// F_SIZE, KiB.
        pub size_kib: u16,
        /// FLASH_ACR.
        pub acr: u32,
        /// FLASH_SR.
        pub sr: u32,
        /// FLASH_CR.
        pub cr: u32,
        /// KEYR's sequence: the first key seen.
        key1_seen: bool,
        /// A wrong key locked the interface until reset.
        pub locked_until_reset: bool,
        /// Cached lines: (line address, its bytes), least recently used first.
        dcache: Vec<(u32, [u8; LINE as usize])>,
        /// Bytes read through the data cache that it served (hits), and from the array.
        pub hits: u32,
        /// Each erase: the sector and the PSIZE it used.
        pub erases: Vec<(u32, u32)>,
        /// The option bytes as stored (loaded into FLASH_OPTCR at reset).
        pub option_bytes: u32,
        /// FLASH_OPTCR.
        pub optcr: u32,
        opt_key1_seen: bool,
        /// The next option programming fails with these FLASH_SR flags (nothing stored).
        pub fail_option_program: Option<u32>,
        /// The next option programming loses power after the option sector's erase: the
        /// stored option bytes read all ones (RDP 0xFF: read protection level 1).
        pub cut_option_program: bool,
        /// Option programmings started.
        pub option_programs: u32,
        /// Every byte programmed from now on fails with these FLASH_SR flags.
        pub program_error: Option<u32>,
    }

    impl Stm32Flash {
        /// A part with `size_kib` KiB of erased flash, caches on, the factory's options,
        /// after a reset.
        pub fn new(size_kib: u16) -> Self {
            let mut f = Self {
                mem: vec![0xFF; usize::from(size_kib) * 1024],
                size_kib,
                acr: acr::ICEN | acr::DCEN | 5,
                sr: 0,
                cr: cr::LOCK,
                key1_seen: false,
                locked_until_reset: false,
                dcache: Vec::new(),
                hits: 0,
                erases: Vec::new(),
                option_bytes: FACTORY_OPTCR,
                optcr: 0,
                opt_key1_seen: false,
                fail_option_program: None,
                cut_option_program: false,
                option_programs: 0,
                program_error: None,
            };
            f.reset();
            f
        }

        /// A system reset: registers to their reset values, FLASH_OPTCR loaded from the option
        /// bytes, the caches emptied (the boot enables them again).
        pub fn reset(&mut self) {
            self.cr = cr::LOCK;
            self.sr = 0;
            self.key1_seen = false;
            self.opt_key1_seen = false;
            self.locked_until_reset = false;
            self.dcache.clear();
            self.optcr = self.option_bytes | optcr::OPTLOCK;
        }

        fn sector_of(offset: u32) -> Option<(u32, core::ops::Range<usize>)> {
            let (n, start, len) = match offset {
                0..0x1_0000 => (offset / 0x4000, offset / 0x4000 * 0x4000, 0x4000),
                0x1_0000..0x2_0000 => (4, 0x1_0000, 0x1_0000),
                _ => {
                    let n = 5 + (offset - 0x2_0000) / SECTOR_LEN;
                    (n, 0x2_0000 + (n - 5) * SECTOR_LEN, SECTOR_LEN)
                }
            };
            (n <= 11).then(|| (n, start as usize..(start + len) as usize))
        }

        fn sector_range(&self, sector: u32) -> Option<core::ops::Range<usize>> {
            (0..FLASH_MAX_LEN)
                .step_by(0x4000)
                .filter_map(Self::sector_of)
                .find(|(n, _)| *n == sector)
                .map(|(_, r)| r)
                .filter(|r| r.end <= self.mem.len())
        }
    }

    impl FlashRegisters for Stm32Flash {
        fn acr(&mut self) -> u32 {
            self.acr
        }

        fn set_acr(&mut self, value: u32) {
            // ICRST and DCRST take effect only while their cache is disabled (RM0090).
            if value & acr::DCRST != 0 && self.acr & acr::DCEN == 0 && value & acr::DCEN == 0 {
                self.dcache.clear();
            }
            self.acr = value;
        }

        fn sr(&mut self) -> u32 {
            self.sr
        }

        fn set_sr(&mut self, value: u32) {
            self.sr &= !(value & sr::ERRORS);
        }

        fn cr(&mut self) -> u32 {
            self.cr
        }

        fn set_cr(&mut self, value: u32) {
            if self.cr & cr::LOCK != 0 {
                return; // FLASH_CR cannot be written while locked.
            }
            self.cr = value & !cr::STRT;
            if value & cr::STRT != 0 && value & cr::SER != 0 {
                let sector = (value & cr::SNB) >> cr::SNB_SHIFT;
                let psize = (value & cr::PSIZE) >> cr::PSIZE_SHIFT;
                match self.sector_range(sector) {
                    Some(r) => {
                        self.mem[r].fill(0xFF); // The cache is not told.
                        self.erases.push((sector, psize));
                    }
                    None => self.sr |= sr::OPERR,
                }
            }
        }

        fn set_keyr(&mut self, key: u32) {
            match (self.key1_seen, key) {
                (false, KEY1) => self.key1_seen = true,
                (true, KEY2) if !self.locked_until_reset => {
                    self.cr &= !cr::LOCK;
                    self.key1_seen = false;
                }
                _ => self.locked_until_reset = true,
            }
        }

        fn optcr(&mut self) -> u32 {
            self.optcr
        }

        fn set_optcr_byte0(&mut self, value: u8) {
            if self.optcr & optcr::OPTLOCK != 0 {
                return; // Locked: the write is ignored.
            }
            self.optcr = (self.optcr & !0xFF) | u32::from(value & !(optcr::OPTSTRT as u8));
            if value & optcr::OPTSTRT as u8 != 0 {
                self.option_programs += 1;
                if self.cut_option_program {
                    self.option_bytes = !(optcr::OPTLOCK | optcr::OPTSTRT);
                } else if let Some(e) = self.fail_option_program.take() {
                    self.sr |= e;
                } else {
                    // The register reads what was written whatever happens; the stored
                    // options change only here.
                    self.option_bytes = self.optcr & !(optcr::OPTLOCK | optcr::OPTSTRT);
                }
            }
        }

        fn set_optkeyr(&mut self, key: u32) {
            match (self.opt_key1_seen, key) {
                (false, 0x0819_2A3B) => self.opt_key1_seen = true,
                (true, 0x4C5D_6E7F) => {
                    self.optcr &= !optcr::OPTLOCK;
                    self.opt_key1_seen = false;
                }
                _ => self.opt_key1_seen = false,
            }
        }

        fn flash_size_kib(&mut self) -> u16 {
            self.size_kib
        }

        fn read_byte(&mut self, offset: u32) -> u8 {
            assert!(
                (offset as usize) < self.mem.len(),
                "a read past the part's flash (a bus fault on the MCU): {offset:#x}"
            );
            if self.acr & acr::DCEN == 0 {
                return self.mem[offset as usize];
            }
            let line = offset / LINE * LINE;
            let at = (offset - line) as usize;
            if let Some(i) = self.dcache.iter().position(|(a, _)| *a == line) {
                let entry = self.dcache.remove(i);
                let b = entry.1[at];
                self.dcache.push(entry);
                self.hits += 1;
                return b;
            }
            let mut bytes = [0u8; LINE as usize];
            bytes.copy_from_slice(&self.mem[line as usize..(line + LINE) as usize]);
            if self.dcache.len() == DCACHE_LINES {
                self.dcache.remove(0);
            }
            self.dcache.push((line, bytes));
            bytes[at]
        }

        fn write_byte(&mut self, offset: u32, byte: u8) {
            if self.cr & cr::PG == 0 {
                self.sr |= sr::PGSERR;
                return;
            }
            if (self.cr & cr::PSIZE) >> cr::PSIZE_SHIFT != Parallelism::X8.psize() {
                self.sr |= sr::PGPERR; // A byte access under another parallelism.
                return;
            }
            if let Some(e) = self.program_error {
                self.sr |= e;
                return;
            }
            self.mem[offset as usize] &= byte; // The cache is not told.
        }
    }
}

#[cfg(test)]
mod tests {
    use super::model::{FACTORY_OPTCR, Stm32Flash};
    use super::*;

    #[test]
    fn only_the_store_sectors_of_the_part_are_erased_or_written() {
        let mut f = StoreFlash::new(Stm32Flash::new(1024));
        assert_eq!(f.len(), FLASH_MAX_LEN);
        assert_eq!(f.erase(0, SECTOR_LEN), Err(FlashError::Protected));
        assert_eq!(f.write(0x8_0000, &[0]), Err(FlashError::Protected));
        assert_eq!(f.erase(0xC_0000, 0xC_0100), Err(FlashError::NotAligned));
        assert_eq!(f.write(0xF_FFFF, &[0, 0]), Err(FlashError::OutOfBounds));
        assert_eq!(f.erase(0xC_0000, 0x10_0000), Ok(()));
        assert_eq!(f.write(0xE_0000, &[0x12, 0x34]), Ok(()));
        let mut b = [0u8; 2];
        assert_eq!(f.read(0xE_0000, &mut b), Ok(()));
        assert_eq!(b, [0x12, 0x34]);
        assert_eq!(
            f.read(0xF_FFFF, &mut [0u8; 2]),
            Err(FlashError::OutOfBounds)
        );
        // Locked again after each operation.
        let FlashErase { cr, erases } = state(f);
        assert!(cr & cr::LOCK != 0);
        assert_eq!(
            erases,
            [(10, 0), (11, 0)],
            "sectors 10 and 11, x8 without BOR level 3"
        );
    }

    struct FlashErase {
        cr: u32,
        erases: Vec<(u32, u32)>,
    }

    fn state(f: StoreFlash<Stm32Flash>) -> FlashErase {
        let m = f.regs;
        FlashErase {
            cr: m.cr,
            erases: m.erases,
        }
    }

    /// The cache's part: a line read before an erase or a write is not what the flash holds
    /// after it until the caches are flushed; the driver flushes after each, so a read after
    /// a change reads the flash.
    #[test]
    fn a_read_after_an_erase_or_a_write_sees_the_flash_not_the_cache() {
        let mut f = StoreFlash::new(Stm32Flash::new(1024));
        f.write(0xC_0000, &[0x5A; 32]).expect("write");
        let mut b = [0u8; 32];
        f.read(0xC_0000, &mut b).expect("read");
        assert_eq!(b, [0x5A; 32]);
        // Now cached: erase and read again.
        f.read(0xC_0000, &mut b).expect("read");
        assert!(f.regs.hits > 0, "the model's cache serves repeated reads");
        f.erase(0xC_0000, 0xE_0000).expect("erase");
        f.read(0xC_0000, &mut b).expect("read");
        assert_eq!(b, [0xFF; 32], "erased, not the cached pre-erase line");
        f.read(0xC_0000, &mut b).expect("cache the erased line");
        f.write(0xC_0008, &[0x00; 4]).expect("write");
        f.read(0xC_0000, &mut b).expect("read");
        assert_eq!(&b[4..14], &[0xFF, 0xFF, 0xFF, 0xFF, 0, 0, 0, 0, 0xFF, 0xFF]);
        // The caches stay enabled after a flush.
        assert_eq!(f.regs.acr & (acr::ICEN | acr::DCEN), acr::ICEN | acr::DCEN);
    }

    #[test]
    fn the_erase_is_x32_only_with_brown_out_level_3_and_programming_stays_x8() {
        let mut m = Stm32Flash::new(1024);
        m.option_bytes = FACTORY_OPTCR & !optcr::BOR_LEV;
        m.reset();
        let mut f = StoreFlash::new(m);
        assert_eq!(f.erase_parallelism(), Parallelism::X32);
        f.erase(0xE_0000, 0x10_0000).expect("erase");
        f.write(0xE_0000, &[1, 2, 3])
            .expect("a byte program under x8");
        assert_eq!(f.regs.erases, [(11, Parallelism::X32.psize())]);
        assert_eq!(f.regs.sr & sr::ERRORS, 0);
        // Every other level erases at x8.
        for bor in 1..=3 {
            let mut m = Stm32Flash::new(1024);
            m.option_bytes = (FACTORY_OPTCR & !optcr::BOR_LEV) | (bor << 2);
            m.reset();
            assert_eq!(StoreFlash::new(m).erase_parallelism(), Parallelism::X8);
        }
    }

    #[test]
    fn a_512_kib_part_has_no_store_sectors() {
        let mut f = StoreFlash::new(Stm32Flash::new(512));
        assert_eq!(f.len(), 512 * 1024);
        assert_eq!(f.erase(0xC_0000, 0xE_0000), Err(FlashError::OutOfBounds));
        assert_eq!(
            f.read(0xC_0000, &mut [0u8; 1]),
            Err(FlashError::OutOfBounds)
        );
        assert_eq!(f.read(0x7_FFFF, &mut [0u8; 1]), Ok(()));
    }

    #[test]
    fn a_failed_operation_is_reported_with_its_flags_and_leaves_the_interface_locked() {
        // A wrong key earlier locks the interface until reset.
        let mut m = Stm32Flash::new(1024);
        m.set_keyr(0);
        let mut f = StoreFlash::new(m);
        assert_eq!(f.write(0xC_0000, &[0]), Err(FlashError::Locked));
        // A programming error is the operation's error, with its flags.
        let mut m = Stm32Flash::new(1024);
        m.program_error = Some(sr::PGAERR);
        let mut f = StoreFlash::new(m);
        assert_eq!(f.write(0xC_0000, &[0]), Err(FlashError::Failed(sr::PGAERR)));
        assert!(f.regs.cr & cr::LOCK != 0, "locked again");
        // Flags left from before an operation are cleared first, not reported as its own.
        f.regs.program_error = None;
        assert_eq!(f.write(0xC_0000, &[0]), Ok(()));
        assert_eq!(f.regs.mem[0xC_0000], 0);
    }
}
