//! The configuration store's flash on the STM32F405 (`f405` board): embedded-storage NOR
//! flash over the flash interface's registers, confined to the store's two sectors.
//!
//! Place in the data flow: below `crate::store::ConfigStore` (board-independent, host-tested
//! against a NOR-flash model): the store reads its records at boot and erases and writes a
//! slot when an applied configuration is saved. Its own driver rather than the HAL's
//! `LockedFlash`, whose read slices the whole flash (a panic path on a bad offset) and whose
//! unlock asserts: this one answers every bad request with a named [`FlashError`], so the
//! store's flash path is in the no-panic link check (`src/bin/nopanic.rs`).
//!
//! RM0090, "Embedded flash memory interface": unlock with the two keys of FLASH_KEYR; a
//! sector erase sets SER and the sector number (SNB), then STRT, and waits for BSY to clear;
//! programming sets PG and writes bytes at x8 parallelism (PSIZE = 0: any supply from
//! 1.8 V), waiting for BSY after each; the error flags of FLASH_SR (PGSERR, PGPERR, PGAERR,
//! WRPERR, OPERR) are cleared before and checked after each operation; the interface is
//! locked again at the end. A 128 KiB sector erase at x8 takes seconds (the datasheet
//! gives up to 4 s), during which every fetch from flash stalls, interrupts included: the
//! board extends its watchdog around a save (`super::f405`).
//!
//! Invariants: only the store's sectors (10 and 11, [`STORE_SLOTS`]) can be erased or
//! written: any other offset is refused ([`FlashError::Protected`]), so no bug in the store
//! can erase the program; every read is bounds-checked against the 1 MiB of flash; nothing
//! here panics.

use embedded_storage::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};
use stm32f4xx_hal::pac::FLASH;

/// Offsets in flash of the configuration store's two slots: sectors 10 and 11
/// (0x080C_0000 and 0x080E_0000), 128 KiB each, outside the program (`memory.x` links the
/// program into sectors 0 to 9).
pub const STORE_SLOTS: [u32; 2] = [0x000C_0000, 0x000E_0000];

/// Length of each slot, bytes: one 128 KiB sector.
pub const STORE_SLOT_LEN: u32 = SECTOR_LEN;

/// The main flash's address.
const FLASH_BASE: usize = 0x0800_0000;
/// The main flash's size, bytes (the STM32F405xG).
const FLASH_LEN: u32 = 1024 * 1024;
/// The size of sectors 5 to 11, bytes.
const SECTOR_LEN: u32 = 128 * 1024;
/// The first sector that may be erased or written (sector 10), and its number.
const FIRST_WRITABLE: u32 = STORE_SLOTS[0];
const FIRST_WRITABLE_SECTOR: u8 = 10;

/// FLASH_KEYR's unlock sequence.
const KEY1: u32 = 0x4567_0123;
const KEY2: u32 = 0xCDEF_89AB;

/// FLASH_SR's error flags: PGSERR, PGPERR, PGAERR, WRPERR, OPERR.
const SR_ERRORS: u32 = (1 << 7) | (1 << 6) | (1 << 5) | (1 << 4) | (1 << 1);

/// Why a flash operation was refused or failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "f405", derive(defmt::Format))]
pub enum FlashError {
    /// The range is outside the flash.
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

/// The flash, read anywhere, erased and written only in the store's sectors.
pub struct StoreFlash {
    flash: FLASH,
}

impl StoreFlash {
    /// The driver over the flash interface.
    pub fn new(flash: FLASH) -> Self {
        Self { flash }
    }

    fn wait_ready(&self) {
        // Bounded by the hardware (an erase is seconds at most), and a hang by the board's
        // independent watchdog. While an erase runs, fetching this loop from flash stalls.
        while self.flash.sr().read().bsy().bit_is_set() {}
    }

    fn clear_errors(&self) {
        // Note(unsafe): FLASH_SR's error flags are cleared by writing 1 to them; the other
        // bits are 0 here (write-ignored or status).
        #[allow(unsafe_code)]
        self.flash.sr().write(|w| unsafe { w.bits(SR_ERRORS) });
    }

    fn check_errors(&self) -> Result<(), FlashError> {
        match self.flash.sr().read().bits() & SR_ERRORS {
            0 => Ok(()),
            e => Err(FlashError::Failed(e)),
        }
    }

    /// Runs `op` with the interface unlocked and no flag left from before; locks it after.
    fn unlocked(
        &mut self,
        op: impl FnOnce(&Self) -> Result<(), FlashError>,
    ) -> Result<(), FlashError> {
        self.wait_ready();
        self.flash.keyr().write(|w| w.key().set(KEY1));
        self.flash.keyr().write(|w| w.key().set(KEY2));
        if self.flash.cr().read().lock().bit_is_set() {
            return Err(FlashError::Locked);
        }
        self.clear_errors();
        let r = op(self);
        self.flash.cr().modify(|_, w| {
            w.pg().clear_bit();
            w.ser().clear_bit();
            w.lock().set_bit()
        });
        r
    }

    /// `[offset, offset + len)` when it lies inside the store's sectors.
    fn writable(offset: u32, len: usize) -> Result<(), FlashError> {
        let end = u32::try_from(len)
            .ok()
            .and_then(|n| offset.checked_add(n))
            .ok_or(FlashError::OutOfBounds)?;
        if end > FLASH_LEN {
            Err(FlashError::OutOfBounds)
        } else if offset < FIRST_WRITABLE {
            Err(FlashError::Protected)
        } else {
            Ok(())
        }
    }
}

impl ErrorType for StoreFlash {
    type Error = FlashError;
}

impl ReadNorFlash for StoreFlash {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), FlashError> {
        let end = u32::try_from(bytes.len())
            .ok()
            .and_then(|n| offset.checked_add(n))
            .ok_or(FlashError::OutOfBounds)?;
        if end > FLASH_LEN {
            return Err(FlashError::OutOfBounds);
        }
        for (at, b) in (FLASH_BASE + offset as usize..).zip(bytes.iter_mut()) {
            // Note(unsafe): `at` lies inside the 1 MiB of main flash (checked above), which
            // is always mapped and readable; a byte read has no alignment requirement.
            #[allow(unsafe_code)]
            {
                *b = unsafe { core::ptr::read_volatile(at as *const u8) };
            }
        }
        Ok(())
    }

    fn capacity(&self) -> usize {
        FLASH_LEN as usize
    }
}

impl NorFlash for StoreFlash {
    const WRITE_SIZE: usize = 1;
    const ERASE_SIZE: usize = SECTOR_LEN as usize;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), FlashError> {
        if !from.is_multiple_of(SECTOR_LEN) || !to.is_multiple_of(SECTOR_LEN) || to < from {
            return Err(FlashError::NotAligned);
        }
        Self::writable(from, (to - from) as usize)?;
        self.unlocked(|f| {
            let mut at = from;
            while at < to {
                let sector = FIRST_WRITABLE_SECTOR + ((at - FIRST_WRITABLE) / SECTOR_LEN) as u8;
                f.flash.cr().modify(|_, w| {
                    w.pg().clear_bit();
                    w.ser().set_bit();
                    w.psize().psize8();
                    // Note(unsafe): SNB takes a sector number; `sector` is 10 or 11
                    // (`writable` keeps `at` inside sectors 10 and 11).
                    #[allow(unsafe_code)]
                    unsafe {
                        w.snb().bits(sector)
                    }
                });
                f.flash.cr().modify(|_, w| w.strt().set_bit());
                f.wait_ready();
                f.check_errors()?;
                at += SECTOR_LEN;
            }
            Ok(())
        })
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), FlashError> {
        Self::writable(offset, bytes.len())?;
        self.unlocked(|f| {
            f.flash.cr().modify(|_, w| {
                w.ser().clear_bit();
                w.psize().psize8();
                w.pg().set_bit()
            });
            for (at, &b) in (FLASH_BASE + offset as usize..).zip(bytes) {
                // Note(unsafe): `at` lies inside sectors 10 and 11 (checked by `writable`),
                // mapped flash; with PG set and x8 parallelism a byte write programs it.
                #[allow(unsafe_code)]
                unsafe {
                    core::ptr::write_volatile(at as *mut u8, b);
                }
                f.wait_ready();
                f.check_errors()?;
            }
            Ok(())
        })
    }
}
