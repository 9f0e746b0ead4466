//! The brown-out reset level in the option bytes: read at every boot, programmed only by the
//! provisioning build, on purpose, and confirmed by reading it back after a reset.
//!
//! Place in the data flow: outside it, at boot. Why level 3: 5 flash wait states at 168 MHz
//! need VDD of at least 2.7 V (RM0090, "Relation between CPU clock frequency and Flash memory
//! read time"), and the factory's option bytes leave the brown-out reset off (BOR_LEV `11`),
//! so below 2.7 V the core could fetch wrong instructions before the power-on reset holds
//! it. Level 3 (BOR_LEV `00`, "Brownout reset (BOR)": the 2.70 to 3.60 V range) holds the MCU
//! in reset below its threshold; it also lets the flash driver erase at x32
//! (`crate::flash::Parallelism`).
//!
//! Why not at every boot (as an earlier firmware did): programming FLASH_OPTCR erases and
//! rewrites the whole user option word, the read protection (RDP) with it. A power cut, a
//! reset or a watchdog in that window can leave RDP erased (0xFF), which is read protection
//! level 1: the debug port can no longer read the flash, and going back to level 0
//! mass-erases the chip. That is a bench operation, done once per board by someone who
//! chose to, on a steady supply: the `provision-bor` build (firmware/README.md, "Bring-up
//! checklist") runs [`provision`] at boot instead of the flight application. The flight
//! build only reads the level ([`BorLevel::of`]) and logs it.
//!
//! The provisioning is a state machine across one reset ([`provision`], host-tested against a
//! model of the flash interface, `crate::flash::model`):
//! - level 3 read at boot, no attempt before the reset: [`Provisioned::AlreadyLevel3`];
//! - a lower level, RDP at level 0, no attempt before: program BOR_LEV (FLASH_OPTCR's low
//!   byte only, the user bits there as read, as ST's library writes it), judge the write by
//!   FLASH_SR's error flags and BSY (FLASH_OPTCR itself reads back what was written, not what
//!   the option bytes hold), then [`Next::Reset`] with an attempt recorded
//!   ([`Attempt::Programmed`]) in RAM that survives the reset;
//! - after that reset, FLASH_OPTCR is loaded from the option bytes (RM0090: at reset): level 3
//!   is [`Provisioned::Confirmed`]; anything else is [`Provisioned::NotConfirmed`], and it is
//!   not tried again (a board whose option bytes do not take the level needs a person);
//! - RDP not at level 0: [`Provisioned::Protected`], nothing written.
//!
//! Invariant: nothing but FLASH_OPTCR's low byte is ever written, only in the provisioning
//! build, at most once per attempt recorded; every wait is bounded.

use crate::flash::{FlashRegisters, optcr, sr};

/// FLASH_OPTKEYR's unlock sequence.
const OPTKEY1: u32 = 0x0819_2A3B;
const OPTKEY2: u32 = 0x4C5D_6E7F;

/// The brown-out reset level (FLASH_OPTCR's BOR_LEV, RM0090's encoding).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(all(target_os = "none", feature = "f405"), derive(defmt::Format))]
pub enum BorLevel {
    /// `00`: level 3, 2.70 to 3.60 V.
    Level3,
    /// `01`: level 2, 2.40 to 2.70 V.
    Level2,
    /// `10`: level 1, 2.10 to 2.40 V.
    Level1,
    /// `11`: off (the factory's): only the power-on reset, down to 1.8 V.
    Off,
}

impl BorLevel {
    /// The level FLASH_OPTCR (`optcr`) holds.
    pub const fn of(optcr: u32) -> Self {
        match (optcr & optcr::BOR_LEV) >> 2 {
            0b00 => Self::Level3,
            0b01 => Self::Level2,
            0b10 => Self::Level1,
            _ => Self::Off,
        }
    }
}

/// What a provisioning boot remembers across the reset that confirms it (the board keeps it
/// in RAM that a reset does not clear).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Attempt {
    /// No attempt before this reset (or a power loss since).
    #[default]
    None,
    /// BOR_LEV was programmed, without an error, before this reset.
    Programmed,
}

/// The provisioning's finding.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(all(target_os = "none", feature = "f405"), derive(defmt::Format))]
pub enum Provisioned {
    /// Level 3 was in the option bytes already: nothing written.
    AlreadyLevel3,
    /// Programmed before the last reset, and read back as level 3 after it.
    Confirmed,
    /// Programmed before the last reset without an error, yet the option bytes hold this
    /// FLASH_OPTCR after it: not tried again.
    NotConfirmed(u32),
    /// Read protection is not at level 0 (the RDP byte read): the option bytes are not
    /// touched.
    Protected(u8),
    /// The option register stayed locked after its unlock sequence (FLASH_OPTCR read).
    Locked(u32),
    /// The programming ended with these FLASH_SR error flags (or BSY still set: the
    /// bound passed), nothing confirmed.
    WriteFailed(u32),
    /// Programmed without an error: reset to read it back.
    Programmed,
}

/// What the board does after [`provision`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Next {
    /// Record `Attempt::Programmed` and reset the MCU (the option bytes are loaded at reset).
    Reset,
    /// Stay: the provisioning is over (its finding logged).
    Halt,
}

/// One provisioning boot (module doc): `attempt` is what the boot before the last reset
/// recorded, `busy_polls` bounds the wait for the programming's end.
pub fn provision<R: FlashRegisters>(
    regs: &mut R,
    attempt: Attempt,
    busy_polls: u32,
) -> (Provisioned, Next) {
    let at_boot = regs.optcr();
    match (BorLevel::of(at_boot), attempt) {
        (BorLevel::Level3, Attempt::None) => return (Provisioned::AlreadyLevel3, Next::Halt),
        (BorLevel::Level3, Attempt::Programmed) => return (Provisioned::Confirmed, Next::Halt),
        (_, Attempt::Programmed) => return (Provisioned::NotConfirmed(at_boot), Next::Halt),
        (_, Attempt::None) => {}
    }
    let rdp = (at_boot >> optcr::RDP_SHIFT) as u8;
    if rdp != optcr::RDP_LEVEL_0 {
        return (Provisioned::Protected(rdp), Next::Halt);
    }
    let mut polls = 0;
    let mut idle = |regs: &mut R| {
        while regs.sr() & sr::BSY != 0 {
            polls += 1;
            if polls >= busy_polls {
                return false;
            }
        }
        true
    };
    if !idle(regs) {
        return (Provisioned::WriteFailed(sr::BSY), Next::Halt);
    }
    regs.set_optkeyr(OPTKEY1);
    regs.set_optkeyr(OPTKEY2);
    let unlocked = regs.optcr();
    if unlocked & optcr::OPTLOCK != 0 {
        return (Provisioned::Locked(unlocked), Next::Halt);
    }
    regs.set_sr(sr::ERRORS);
    // The low byte: BOR_LEV `00` (level 3), the user bits as read, OPTSTRT and OPTLOCK clear;
    // then the same with OPTSTRT.
    let byte0 = (at_boot as u8) & !((optcr::BOR_LEV | optcr::OPTSTRT | optcr::OPTLOCK) as u8);
    regs.set_optcr_byte0(byte0);
    regs.set_optcr_byte0(byte0 | optcr::OPTSTRT as u8);
    let done = idle(regs);
    let errors = regs.sr() & sr::ERRORS;
    regs.set_optcr_byte0(byte0 | optcr::OPTLOCK as u8);
    match (done, errors) {
        (true, 0) => (Provisioned::Programmed, Next::Reset),
        (true, e) => (Provisioned::WriteFailed(e), Next::Halt),
        (false, e) => (Provisioned::WriteFailed(e | sr::BSY), Next::Halt),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flash::model::{FACTORY_OPTCR, Stm32Flash};

    /// Boots the provisioning build on `board` until it halts, resetting it when asked (the
    /// attempt kept across the reset, as the board's RAM keeps it); every finding in order.
    fn boot_until_halt(board: &mut Stm32Flash, mut attempt: Attempt) -> Vec<Provisioned> {
        let mut found = Vec::new();
        for _ in 0..4 {
            let (p, next) = provision(board, attempt, 1000);
            found.push(p);
            match next {
                Next::Halt => return found,
                Next::Reset => {
                    attempt = Attempt::Programmed;
                    board.reset();
                }
            }
        }
        panic!("no halt: {found:?}");
    }

    #[test]
    fn a_factory_board_is_programmed_once_and_confirmed_after_the_reset() {
        let mut board = Stm32Flash::new(1024);
        assert_eq!(BorLevel::of(board.optcr), BorLevel::Off);
        let found = boot_until_halt(&mut board, Attempt::None);
        assert_eq!(found, [Provisioned::Programmed, Provisioned::Confirmed]);
        assert_eq!(board.option_programs, 1);
        // Only BOR_LEV changed: RDP, the write protections and the user bits as they were.
        assert_eq!(
            board.option_bytes,
            FACTORY_OPTCR & !optcr::BOR_LEV & !optcr::OPTLOCK
        );
        assert_eq!(BorLevel::of(board.optcr), BorLevel::Level3);
        assert!(board.optcr & optcr::OPTLOCK != 0, "locked after the reset");
        // Every later boot finds it and writes nothing (the attempt's RAM lost to a power
        // cycle, or kept by a reset: the same).
        board.reset();
        assert_eq!(
            boot_until_halt(&mut board, Attempt::None),
            [Provisioned::AlreadyLevel3]
        );
        assert_eq!(board.option_programs, 1);
    }

    #[test]
    fn a_write_that_does_not_hold_is_reported_and_not_retried() {
        // The register reads back what was written, but the option bytes did not take it:
        // only the reset tells.
        let mut board = Stm32Flash::new(1024);
        board.option_bytes = FACTORY_OPTCR;
        let (p, next) = provision(&mut board, Attempt::None, 1000);
        assert_eq!((p, next), (Provisioned::Programmed, Next::Reset));
        assert_eq!(
            BorLevel::of(board.optcr),
            BorLevel::Level3,
            "what was written"
        );
        board.option_bytes = FACTORY_OPTCR; // lost
        board.reset();
        let (p, next) = provision(&mut board, Attempt::Programmed, 1000);
        assert_eq!(
            (p, next),
            (
                Provisioned::NotConfirmed(FACTORY_OPTCR | optcr::OPTLOCK),
                Next::Halt
            )
        );
        assert_eq!(board.option_programs, 1, "not tried again");
        // An error flag after OPTSTRT: failed, no reset, no confirmation claimed.
        let mut board = Stm32Flash::new(1024);
        board.fail_option_program = Some(sr::WRPERR);
        assert_eq!(
            provision(&mut board, Attempt::None, 1000),
            (Provisioned::WriteFailed(sr::WRPERR), Next::Halt)
        );
        assert!(board.optcr & optcr::OPTLOCK != 0, "locked again");
    }

    /// The risk the explicit step exists for: power lost in the option programming leaves
    /// RDP erased (level 1). The next boot sees it and writes nothing more.
    #[test]
    fn a_protected_board_is_not_touched() {
        let mut board = Stm32Flash::new(1024);
        board.cut_option_program = true;
        assert_eq!(
            provision(&mut board, Attempt::None, 1000).0,
            Provisioned::Programmed
        );
        board.cut_option_program = false;
        board.reset(); // a power cycle: the attempt is lost with the RAM
        assert_eq!(
            boot_until_halt(&mut board, Attempt::None),
            [Provisioned::Protected(0xFF)]
        );
        assert_eq!(board.option_programs, 1);
        let mut board = Stm32Flash::new(1024);
        board.option_bytes = (FACTORY_OPTCR & !(0xFF << 8)) | (0xBB << 8);
        board.reset();
        assert_eq!(
            boot_until_halt(&mut board, Attempt::None),
            [Provisioned::Protected(0xBB)]
        );
        assert_eq!(board.option_programs, 0);
    }

    #[test]
    fn the_levels_are_rm0090s_encoding() {
        let with = |bits: u32| BorLevel::of((FACTORY_OPTCR & !optcr::BOR_LEV) | (bits << 2));
        assert_eq!(
            [with(0), with(1), with(2), with(3)],
            [
                BorLevel::Level3,
                BorLevel::Level2,
                BorLevel::Level1,
                BorLevel::Off
            ]
        );
    }
}
