//! The configuration store: the controller's configuration kept in flash across resets, in two
//! copies, so that a power loss in the middle of a write leaves the previous one.
//!
//! Place in the data flow: at boot the board reads the store ([`ConfigStore::load`]) and
//! builds the application with the newest valid configuration in it, or with the built-in
//! default when there is none (the boot frame says which, [`LinkStatus::STORED_CONFIG`]); a
//! configuration write the controller applied is then written here
//! ([`ConfigStore::save`]) and the report says whether it was
//! ([`ConfigStorage`]). Board-independent: it sees the flash only through
//! embedded-storage's [`NorFlash`], so it is tested on the host against a model of NOR
//! flash that loses power at every possible point of a write.
//!
//! Layout: two slots, each at least one erase unit, each holding at most one record:
//!
//! ```text
//! offset 0   magic "IBCF" (u32 LE 0x4643_4249)
//!        4   protocol version (u8, ibvs_core::wire::PROTOCOL_VERSION), 3 bytes 0xFF
//!        8   generation (u32 LE): +1 per save, the newest valid record wins
//!       12   body length (u32 LE), at most MAX_BODY_LEN
//!       16   body: the ControllerConfig, postcard (as in a configuration-write frame)
//!   16 + n   CRC-32C of bytes 0 .. 16 + n (u32 LE)
//! ```
//!
//! A save writes the slot that does not hold the newest valid record: erase it, then write
//! the record in one pass; the other slot is not touched. A configuration whose encoding is
//! the newest record's body byte for byte is not written again (no erase: on the `f405`
//! board an erase stalls the CPU for one to four seconds and wears a sector rated for
//! 10,000 cycles, and the host sends the configuration before every run); it is reported
//! stored with the generation it already has. A record is valid only if its
//! magic, version, length and CRC are right, its body deserialises into exactly that many
//! bytes and the configuration passes [`ControllerConfig::validate`]. A write cut off
//! anywhere (in the erase or in the programming) leaves a slot that fails its CRC (or is
//! erased), so the load falls back to the other slot: the previous configuration (tested at
//! every byte of a save). The protocol version makes a configuration of another layout (a
//! firmware update that changed `ControllerConfig`) invalid rather than misread.
//!
//! Invariants: no allocation; no panic for any flash content (every offset is checked
//! against the slot before the flash is read); the slots never overlap (checked at
//! construction).

use embedded_storage::nor_flash::{NorFlash, NorFlashError, NorFlashErrorKind};
use ibvs_core::ControllerConfig;
use ibvs_core::wire::{
    ConfigStorage, MAX_BODY_LEN, PROTOCOL_VERSION, config_from_bytes, config_to_bytes, crc32c,
};

#[cfg(doc)]
use ibvs_core::wire::LinkStatus;

/// Where a board keeps an applied configuration for its next boot.
pub trait Persist {
    /// Stores `cfg`; what happened.
    fn persist(&mut self, cfg: &ControllerConfig) -> ConfigStorage;
}

/// A board without a configuration store (QEMU's netduinoplus2: its flash is read-only).
#[derive(Debug, Clone, Copy, Default)]
pub struct NoStore;

impl Persist for NoStore {
    fn persist(&mut self, _: &ControllerConfig) -> ConfigStorage {
        ConfigStorage::Unavailable
    }
}

impl<F: NorFlash> Persist for ConfigStore<F> {
    fn persist(&mut self, cfg: &ControllerConfig) -> ConfigStorage {
        match self.save(cfg) {
            Ok(generation) => ConfigStorage::Stored { generation },
            Err(_) => ConfigStorage::Failed,
        }
    }
}

/// The record's magic number, "IBCF" in little-endian bytes.
pub const MAGIC: u32 = u32::from_le_bytes(*b"IBCF");

/// Header bytes before the body.
const HEADER_LEN: usize = 16;

/// Largest record: header, the largest body, CRC.
pub const MAX_RECORD_LEN: usize = HEADER_LEN + MAX_BODY_LEN + 4;

/// Scratch for one record, rounded up for a flash that writes in units of up to 16 bytes.
const RECORD_BUF_LEN: usize = MAX_RECORD_LEN.div_ceil(16) * 16;

/// Why the store could not be used or written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(all(target_os = "none", feature = "f405"), derive(defmt::Format))]
pub enum StoreError {
    /// The slots overlap, are not erase-aligned, are smaller than the largest record or lie
    /// outside the flash.
    Layout,
    /// The flash driver failed (its kind).
    Flash(FlashFault),
    /// The configuration did not serialise (never expected: every configuration fits).
    Encode,
    /// The record read back after the write is not the record written.
    Verify,
}

/// embedded-storage's [`NorFlashErrorKind`], as this crate logs it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(all(target_os = "none", feature = "f405"), derive(defmt::Format))]
pub enum FlashFault {
    /// An operation not aligned to the flash's write or erase size.
    NotAligned,
    /// An operation outside the flash.
    OutOfBounds,
    /// Anything else the driver reports (a programming or erase error, a lost supply).
    Other,
}

impl<E: NorFlashError> From<E> for StoreError {
    fn from(e: E) -> Self {
        Self::Flash(match e.kind() {
            NorFlashErrorKind::NotAligned => FlashFault::NotAligned,
            NorFlashErrorKind::OutOfBounds => FlashFault::OutOfBounds,
            _ => FlashFault::Other,
        })
    }
}

/// What a slot holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(all(target_os = "none", feature = "f405"), derive(defmt::Format))]
pub enum SlotState {
    /// Erased (no record started).
    Erased,
    /// A valid record of this generation.
    Valid {
        /// Its generation.
        generation: u32,
    },
    /// Something that is not a valid record: a cut-off write, another layout, a configuration
    /// that fails validation.
    Invalid,
}

/// The store's contents: the newest valid configuration and each slot's state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Loaded {
    /// The newest valid configuration and its generation, if any slot holds one.
    pub newest: Option<(ControllerConfig, u32)>,
    /// Each slot's state.
    pub slots: [SlotState; 2],
}

impl Loaded {
    /// The slot holding the newest valid record.
    fn newest_slot(&self) -> Option<usize> {
        let generation = |s: SlotState| match s {
            SlotState::Valid { generation } => Some(generation),
            _ => None,
        };
        match (generation(self.slots[0]), generation(self.slots[1])) {
            (Some(a), Some(b)) => Some(if b > a { 1 } else { 0 }),
            (Some(_), None) => Some(0),
            (None, Some(_)) => Some(1),
            (None, None) => None,
        }
    }
}

/// Two slots of a NOR flash holding the configuration (module doc).
#[derive(Debug)]
pub struct ConfigStore<F> {
    flash: F,
    /// Offset of each slot in the flash.
    slots: [u32; 2],
    /// Length of each slot, bytes (a multiple of the erase size).
    slot_len: u32,
}

impl<F: NorFlash> ConfigStore<F> {
    /// A store in `flash` with slots at `slots` of `slot_len` bytes each.
    pub fn new(flash: F, slots: [u32; 2], slot_len: u32) -> Result<Self, StoreError> {
        let erase = F::ERASE_SIZE as u32;
        let cap = flash.capacity() as u64;
        let fits = |o: u32| u64::from(o) + u64::from(slot_len) <= cap;
        let apart = slots[0].abs_diff(slots[1]) >= slot_len;
        let aligned = erase > 0
            && slots.iter().all(|o| o.is_multiple_of(erase))
            && slot_len.is_multiple_of(erase);
        let big = slot_len as usize >= RECORD_BUF_LEN && F::WRITE_SIZE <= 16;
        if !(fits(slots[0]) && fits(slots[1]) && apart && aligned && big) {
            return Err(StoreError::Layout);
        }
        Ok(Self {
            flash,
            slots,
            slot_len,
        })
    }

    /// The flash, back (for a test or another user).
    pub fn into_flash(self) -> F {
        self.flash
    }

    /// Reads both slots. (Not inlined, like the other functions here: boot and the
    /// application's store path share one copy.)
    #[inline(never)]
    pub fn load(&mut self) -> Loaded {
        let mut buf = [0u8; RECORD_BUF_LEN];
        let mut newest: Option<(ControllerConfig, u32)> = None;
        let mut slots = [SlotState::Erased; 2];
        for (i, state) in slots.iter_mut().enumerate() {
            let (s, cfg) = self.read_slot(self.slots[i], &mut buf);
            *state = s;
            if let (SlotState::Valid { generation }, Some(cfg)) = (s, cfg)
                && newest.is_none_or(|(_, g)| generation > g)
            {
                newest = Some((cfg, generation));
            }
        }
        Loaded { newest, slots }
    }

    /// Reads the record at `offset` into `buf`.
    #[inline(never)]
    fn read_slot(
        &mut self,
        offset: u32,
        buf: &mut [u8; RECORD_BUF_LEN],
    ) -> (SlotState, Option<ControllerConfig>) {
        let Some(header) = buf.get_mut(..HEADER_LEN) else {
            return (SlotState::Invalid, None);
        };
        if self.flash.read(offset, header).is_err() {
            return (SlotState::Invalid, None);
        }
        if header.iter().all(|&b| b == 0xFF) {
            return (SlotState::Erased, None);
        }
        let word = |h: &[u8], at: usize| {
            let mut w = [0u8; 4];
            if let Some(src) = h.get(at..at + 4) {
                w.copy_from_slice(src);
            }
            u32::from_le_bytes(w)
        };
        let (magic, version) = (word(header, 0), header[4]);
        let (generation, len) = (word(header, 8), word(header, 12) as usize);
        if magic != MAGIC || version != PROTOCOL_VERSION || len > MAX_BODY_LEN {
            return (SlotState::Invalid, None);
        }
        let Some(rest) = buf.get_mut(HEADER_LEN..HEADER_LEN + len + 4) else {
            return (SlotState::Invalid, None);
        };
        if self.flash.read(offset + HEADER_LEN as u32, rest).is_err() {
            return (SlotState::Invalid, None);
        }
        let Some(data) = buf.get(..HEADER_LEN + len) else {
            return (SlotState::Invalid, None);
        };
        if crc32c(data) != word(buf, HEADER_LEN + len) {
            return (SlotState::Invalid, None);
        }
        let cfg = match buf.get(HEADER_LEN..HEADER_LEN + len).map(config_from_bytes) {
            Some(Ok(cfg)) => cfg,
            _ => return (SlotState::Invalid, None),
        };
        if cfg.validate().is_err() {
            return (SlotState::Invalid, None);
        }
        (SlotState::Valid { generation }, Some(cfg))
    }

    /// Writes `cfg` as the newest record, into the slot that does not hold the newest valid
    /// one; returns its generation. When the newest record already holds `cfg` (the same
    /// bytes), writes nothing and returns that record's generation. On any error the other
    /// slot is untouched, so the previous configuration is still the one loaded.
    #[inline(never)]
    pub fn save(&mut self, cfg: &ControllerConfig) -> Result<u32, StoreError> {
        let before = self.load();
        let newest = before.newest_slot();
        let target = match newest {
            Some(0) => 1,
            _ => 0,
        };
        let generation = before.newest.map_or(1, |(_, g)| g.wrapping_add(1));
        let mut buf = [0xFFu8; RECORD_BUF_LEN];
        let n = encode_record(cfg, generation, &mut buf)?;
        if let (Some(slot), Some((_, current))) = (newest, before.newest)
            && let Some(body) = buf.get(HEADER_LEN..n.saturating_sub(4))
            && self.holds_body(self.slots[slot], body)
        {
            return Ok(current);
        }
        let len = n.div_ceil(F::WRITE_SIZE.max(1)) * F::WRITE_SIZE.max(1);
        let offset = self.slots[target];
        self.flash.erase(offset, offset + self.slot_len)?;
        self.flash
            .write(offset, buf.get(..len).ok_or(StoreError::Encode)?)?;
        let mut check = [0u8; RECORD_BUF_LEN];
        match self.read_slot(offset, &mut check) {
            (SlotState::Valid { generation: g }, Some(c)) if g == generation && c == *cfg => {
                Ok(generation)
            }
            _ => Err(StoreError::Verify),
        }
    }
}

impl<F: NorFlash> ConfigStore<F> {
    /// True when the slot at `offset` holds a valid record whose body is `body`.
    #[inline(never)]
    fn holds_body(&mut self, offset: u32, body: &[u8]) -> bool {
        let mut stored = [0u8; RECORD_BUF_LEN];
        let valid = matches!(
            self.read_slot(offset, &mut stored),
            (SlotState::Valid { .. }, Some(_))
        );
        valid
            && stored.get(12..16) == Some(&(body.len() as u32).to_le_bytes()[..])
            && stored.get(HEADER_LEN..HEADER_LEN + body.len()) == Some(body)
    }
}

/// Encodes the record of `cfg` at `generation` into `buf`; returns its length.
fn encode_record(
    cfg: &ControllerConfig,
    generation: u32,
    buf: &mut [u8; RECORD_BUF_LEN],
) -> Result<usize, StoreError> {
    let body = buf
        .get_mut(HEADER_LEN..HEADER_LEN + MAX_BODY_LEN)
        .ok_or(StoreError::Encode)?;
    let len = config_to_bytes(cfg, body)
        .map_err(|_| StoreError::Encode)?
        .len();
    let header = buf.get_mut(..HEADER_LEN).ok_or(StoreError::Encode)?;
    header[..4].copy_from_slice(&MAGIC.to_le_bytes());
    header[4..8].copy_from_slice(&[PROTOCOL_VERSION, 0xFF, 0xFF, 0xFF]);
    header[8..12].copy_from_slice(&generation.to_le_bytes());
    header[12..16].copy_from_slice(&(len as u32).to_le_bytes());
    let data = buf.get(..HEADER_LEN + len).ok_or(StoreError::Encode)?;
    let crc = crc32c(data);
    buf.get_mut(HEADER_LEN + len..HEADER_LEN + len + 4)
        .ok_or(StoreError::Encode)?
        .copy_from_slice(&crc.to_le_bytes());
    Ok(HEADER_LEN + len + 4)
}

#[cfg(test)]
mod tests {
    use std::vec::Vec;

    use embedded_storage::nor_flash::{ErrorType, ReadNorFlash};

    use super::*;

    /// NOR flash in RAM: erase sets bytes to 0xFF, programming can only clear bits. With a
    /// power budget, every byte erased or programmed spends one unit; when it runs out the
    /// operation stops where it is (a prefix done, the rest as it was) and fails, and the
    /// flash takes no further change until it is "rebooted" with a new budget.
    #[derive(Debug, Clone)]
    struct Nor {
        mem: Vec<u8>,
        budget: Option<usize>,
        /// Bytes erased or programmed so far (to size the cut points).
        spent: usize,
    }

    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    struct PowerLost;

    impl NorFlashError for PowerLost {
        fn kind(&self) -> NorFlashErrorKind {
            NorFlashErrorKind::Other
        }
    }

    impl ErrorType for Nor {
        type Error = PowerLost;
    }

    impl Nor {
        const ERASE: usize = 1024;

        fn new() -> Self {
            Self {
                mem: vec![0xFF; 4 * Self::ERASE],
                budget: None,
                spent: 0,
            }
        }

        /// One unit of power for one byte; false when it ran out.
        fn spend(&mut self) -> bool {
            self.spent += 1;
            match &mut self.budget {
                None => true,
                Some(0) => false,
                Some(b) => {
                    *b -= 1;
                    true
                }
            }
        }
    }

    impl ReadNorFlash for Nor {
        const READ_SIZE: usize = 1;

        fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), PowerLost> {
            let o = offset as usize;
            bytes.copy_from_slice(&self.mem[o..o + bytes.len()]);
            Ok(())
        }

        fn capacity(&self) -> usize {
            self.mem.len()
        }
    }

    impl NorFlash for Nor {
        const WRITE_SIZE: usize = 1;
        const ERASE_SIZE: usize = Self::ERASE;

        fn erase(&mut self, from: u32, to: u32) -> Result<(), PowerLost> {
            for i in from as usize..to as usize {
                if !self.spend() {
                    return Err(PowerLost);
                }
                self.mem[i] = 0xFF;
            }
            Ok(())
        }

        fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), PowerLost> {
            for (i, &b) in bytes.iter().enumerate() {
                if !self.spend() {
                    return Err(PowerLost);
                }
                self.mem[offset as usize + i] &= b;
            }
            Ok(())
        }
    }

    const SLOTS: [u32; 2] = [Nor::ERASE as u32, 2 * Nor::ERASE as u32];

    fn store(flash: Nor) -> ConfigStore<Nor> {
        ConfigStore::new(flash, SLOTS, Nor::ERASE as u32).expect("layout")
    }

    fn other() -> ControllerConfig {
        let mut c = ControllerConfig::paper();
        c.ibvs.k1_mps = 1.5;
        c
    }

    #[test]
    fn an_empty_flash_has_no_configuration_and_a_save_loads_back() {
        let mut s = store(Nor::new());
        let l = s.load();
        assert_eq!(l.newest, None);
        assert_eq!(l.slots, [SlotState::Erased; 2]);
        assert_eq!(s.save(&other()), Ok(1));
        assert_eq!(s.load().newest, Some((other(), 1)));
        // Saves alternate slots, the newest generation wins.
        assert_eq!(s.save(&ControllerConfig::default()), Ok(2));
        let l = s.load();
        assert_eq!(l.newest, Some((ControllerConfig::default(), 2)));
        assert_eq!(
            l.slots,
            [
                SlotState::Valid { generation: 1 },
                SlotState::Valid { generation: 2 }
            ]
        );
        assert_eq!(s.save(&other()), Ok(3));
        assert_eq!(s.load().slots[0], SlotState::Valid { generation: 3 });
        assert_eq!(s.load().newest, Some((other(), 3)));
    }

    /// The property the store exists for: power lost at any byte of a save leaves, after the
    /// reboot, either the previous configuration or (once the record is whole) the new one;
    /// never nothing, never anything else.
    #[test]
    fn a_save_cut_off_at_any_byte_keeps_the_previous_configuration() {
        let mut s = store(Nor::new());
        s.save(&ControllerConfig::default()).expect("first save");
        s.save(&other()).expect("second save");
        let base = s.into_flash();
        // The bytes a third save spends, to try every cut point.
        let mut full = store(Nor {
            spent: 0,
            ..base.clone()
        });
        let third = ControllerConfig::default();
        full.save(&third).expect("uncut save");
        let total = full.into_flash().spent;
        assert!(total > Nor::ERASE, "erase and program: {total}");
        let mut first_new = None;
        for cut in 0..=total {
            let mut s = store(Nor {
                budget: Some(cut),
                spent: 0,
                ..base.clone()
            });
            let r = s.save(&third);
            // Reboot: full power, same memory.
            let mut after = store(Nor {
                budget: None,
                ..s.into_flash()
            });
            let (cfg, generation) = after.load().newest.expect("a configuration survives");
            if cut >= total {
                assert_eq!(r, Ok(3));
            } else {
                assert_eq!(r, Err(StoreError::Flash(FlashFault::Other)), "cut {cut}");
            }
            match generation {
                2 => {
                    assert_eq!(cfg, other(), "cut {cut}");
                    assert_eq!(first_new, None, "cut {cut}: back to the old one");
                }
                3 => {
                    assert_eq!(cfg, third, "cut {cut}");
                    first_new.get_or_insert(cut);
                }
                g => panic!("cut {cut}: generation {g}"),
            }
        }
        // Only a whole record is taken: the new one appears with its CRC's last bytes (a byte
        // that happens to equal the erased 0xFF needs no programming), not before.
        let first_new = first_new.expect("the uncut save");
        assert!(first_new + 4 > total, "new at {first_new} of {total}");
    }

    #[test]
    fn a_record_that_is_not_a_valid_configuration_is_not_loaded() {
        let mut s = store(Nor::new());
        s.save(&other()).expect("save");
        let good = s.into_flash();
        let slot = SLOTS[0] as usize;
        // One bit flipped in the body: the CRC fails.
        let mut flash = good.clone();
        flash.mem[slot + HEADER_LEN + 5] ^= 0x04;
        let l = store(flash).load();
        assert_eq!((l.newest, l.slots[0]), (None, SlotState::Invalid));
        // Another protocol version: not read as this layout.
        let mut flash = good.clone();
        flash.mem[slot + 4] = PROTOCOL_VERSION.wrapping_add(1);
        assert_eq!(store(flash).load().slots[0], SlotState::Invalid);
        // A whole, CRC-correct record of a configuration that fails validation.
        let mut bad = other();
        bad.ibvs.k3_per_s = -1.0;
        let mut buf = [0xFFu8; RECORD_BUF_LEN];
        let n = encode_record(&bad, 7, &mut buf).expect("encodes");
        let mut flash = Nor::new();
        flash.mem[slot..slot + n].copy_from_slice(&buf[..n]);
        let l = store(flash).load();
        assert_eq!((l.newest, l.slots[0]), (None, SlotState::Invalid));
        // A length past the largest body.
        let mut flash = good;
        flash.mem[slot + 12..slot + 16].copy_from_slice(&u32::MAX.to_le_bytes());
        assert_eq!(store(flash).load().slots[0], SlotState::Invalid);
    }

    #[test]
    fn an_unchanged_configuration_is_not_written_again() {
        let mut s = store(Nor::new());
        assert_eq!(s.save(&other()), Ok(1));
        let written = s.flash.spent;
        assert_eq!(s.save(&other()), Ok(1), "the generation it already has");
        assert_eq!(s.flash.spent, written, "no byte erased or programmed");
        // A changed one is, and the previous one after it again.
        assert_eq!(s.save(&ControllerConfig::default()), Ok(2));
        assert!(s.flash.spent > written + Nor::ERASE);
        let written = s.flash.spent;
        assert_eq!(
            s.save(&other()),
            Ok(3),
            "the older slot's copy is not the newest"
        );
        assert!(s.flash.spent > written);
        // Only a valid newest record counts: one cut off is written again.
        let mut s = store(Nor::new());
        s.save(&other()).expect("save");
        let mut flash = s.into_flash();
        flash.mem[SLOTS[0] as usize + HEADER_LEN + 3] ^= 0x01;
        let mut s = store(flash);
        assert_eq!(
            s.save(&other()),
            Ok(1),
            "no valid record: a first save again"
        );
        assert_eq!(s.load().newest, Some((other(), 1)));
    }

    /// The store over the `f405` board's flash driver and a model of its flash interface
    /// whose data cache is not coherent with erase and program (`crate::flash::model`): every
    /// save's read-back check reads what was written, not a line cached before the erase,
    /// and a reboot (caches emptied) loads the newest.
    #[test]
    fn saves_through_the_f405_driver_are_checked_against_the_flash_not_its_cache() {
        use crate::flash::model::Stm32Flash;
        use crate::flash::{STORE_SLOT_LEN, STORE_SLOTS, StoreFlash};

        let mut s = ConfigStore::new(
            StoreFlash::new(Stm32Flash::new(1024)),
            STORE_SLOTS,
            STORE_SLOT_LEN,
        )
        .expect("layout");
        let mut third = other();
        third.ibvs.k1_mps = 0.75;
        let configs = [other(), ControllerConfig::default(), third, other()];
        for (g, cfg) in (1..).zip(configs) {
            assert_eq!(s.save(&cfg), Ok(g), "save {g}");
            assert_eq!(s.load().newest, Some((cfg, g)), "save {g}");
        }
        // The last save found slot 0 holding generation 3 in the cache's lines and erased it.
        let mut regs = s.into_flash().into_registers();
        assert!(regs.hits > 0, "the cache served reads");
        assert_eq!(regs.erases.len(), 4);
        regs.reset();
        let mut s =
            ConfigStore::new(StoreFlash::new(regs), STORE_SLOTS, STORE_SLOT_LEN).expect("layout");
        assert_eq!(s.load().newest, Some((other(), 4)));
        // A part without sectors 10 and 11: the layout is refused, nothing is read there.
        assert_eq!(
            ConfigStore::new(
                StoreFlash::new(Stm32Flash::new(512)),
                STORE_SLOTS,
                STORE_SLOT_LEN
            )
            .err(),
            Some(StoreError::Layout)
        );
    }

    #[test]
    fn a_layout_that_cannot_hold_two_records_is_refused() {
        let e = Nor::ERASE as u32;
        let refused = |slots, len| ConfigStore::new(Nor::new(), slots, len).err();
        assert_eq!(refused([e, e], e), Some(StoreError::Layout), "overlap");
        assert_eq!(
            refused([e, 2 * e + 1], e),
            Some(StoreError::Layout),
            "unaligned"
        );
        assert_eq!(refused([e, 4 * e], e), Some(StoreError::Layout), "outside");
        assert_eq!(
            refused([0, e], e / 2),
            Some(StoreError::Layout),
            "too small"
        );
        assert_eq!(refused([0, 3 * e], e), None);
    }
}
