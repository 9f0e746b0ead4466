//! The `f405` board's flash interface registers and flash memory, for the configuration
//! store's driver (`crate::flash`, board-independent and host-tested: every decision is
//! there; here only the accesses).
//!
//! Place in the data flow: below `crate::flash::StoreFlash`, which the store writes through.
//! Reads of the flash are volatile byte reads at `0x0800_0000 + offset` (the driver checked
//! the offset against the part's flash size first); programming accesses are volatile byte
//! writes there (the driver checked they lie in the store's sectors); the part's flash size is
//! read from F_SIZE (RM0090, "Device electronic signature": a 16-bit word at 0x1FFF_7A22,
//! KiB).
//!
//! Invariant: nothing here decides or loops; nothing panics (this file is in the no-panic
//! link check, `src/bin/nopanic.rs`).

use stm32f4xx_hal::pac::FLASH;

use crate::flash::{FLASH_BASE, FlashRegisters};

/// F_SIZE's address.
const F_SIZE: usize = 0x1FFF_7A22;

/// The flash interface's registers and the flash.
pub struct Registers {
    flash: FLASH,
}

impl Registers {
    /// Over the flash interface.
    pub fn new(flash: FLASH) -> Self {
        Self { flash }
    }
}

// Note(unsafe), for the `bits` writes below: FLASH_ACR, FLASH_SR, FLASH_CR, FLASH_KEYR and
// FLASH_OPTKEYR are written whole with values the driver (`crate::flash`) composes from
// RM0090's bit layout; the PAC has no safe whole-register writer for them.
#[allow(unsafe_code)]
impl FlashRegisters for Registers {
    fn acr(&mut self) -> u32 {
        self.flash.acr().read().bits()
    }

    fn set_acr(&mut self, value: u32) {
        self.flash.acr().write(|w| unsafe { w.bits(value) });
    }

    fn sr(&mut self) -> u32 {
        self.flash.sr().read().bits()
    }

    fn set_sr(&mut self, value: u32) {
        self.flash.sr().write(|w| unsafe { w.bits(value) });
    }

    fn cr(&mut self) -> u32 {
        self.flash.cr().read().bits()
    }

    fn set_cr(&mut self, value: u32) {
        self.flash.cr().write(|w| unsafe { w.bits(value) });
    }

    fn set_keyr(&mut self, key: u32) {
        self.flash.keyr().write(|w| w.key().set(key));
    }

    fn optcr(&mut self) -> u32 {
        self.flash.optcr().read().bits()
    }

    fn set_optcr_byte0(&mut self, value: u8) {
        // Note(unsafe): a byte write to FLASH_OPTCR's low byte (its address: a mapped
        // register that takes byte accesses), as ST's library writes it.
        unsafe { core::ptr::write_volatile(self.flash.optcr().as_ptr().cast::<u8>(), value) }
    }

    fn set_optkeyr(&mut self, key: u32) {
        self.flash.optkeyr().write(|w| w.optkeyr().set(key));
    }

    fn flash_size_kib(&mut self) -> u16 {
        // Note(unsafe): F_SIZE is a half-word of the system memory's read-only area,
        // always mapped and aligned.
        unsafe { core::ptr::read_volatile(F_SIZE as *const u16) }
    }

    fn read_byte(&mut self, offset: u32) -> u8 {
        // Note(unsafe): the driver checked `offset` against the part's flash, which is
        // always mapped and readable; a byte read has no alignment requirement.
        unsafe { core::ptr::read_volatile((FLASH_BASE + offset) as usize as *const u8) }
    }

    fn write_byte(&mut self, offset: u32, byte: u8) {
        // Note(unsafe): the driver checked `offset` lies in the store's sectors (mapped
        // flash) and set PG with x8 parallelism: a byte write programs it.
        unsafe { core::ptr::write_volatile((FLASH_BASE + offset) as usize as *mut u8, byte) }
    }
}
