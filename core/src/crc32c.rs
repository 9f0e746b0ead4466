//! CRC-32C (Castagnoli: polynomial 0x1EDC6F41 reflected, 0x82F63B78; initial value and final
//! XOR 0xFFFFFFFF; the `CRC-32/ISCSI` of the CRC catalogue, check value 0xE3069283 for
//! `"123456789"`), the checksum of every link frame ([`crate::wire`]), of the configuration's
//! id and of the board's configuration store.
//!
//! Place in the data flow: both ends of the link run it over every frame, so it is on the
//! control task's deadline twice a step (the measurement frame's check, the command frame's
//! encode).
//!
//! One 256-entry table (1 KiB of flash, built at compile time), read a word at a time: each
//! 4-byte word of the input is XORed into the register whole and then shifted through the
//! table a byte at a time, so a byte costs its table step and no load or XOR of its own
//! (about 4 instructions a byte on a Cortex-M4, where the `crc` crate's byte loop on the same
//! table costs about 6.3; its 16-table variant would take 16 KiB of flash). The 0..3 bytes
//! after the last whole word go a byte at a time.
//!
//! Invariant: [`crc32c`] equals the `crc` crate's `CRC_32_ISCSI` on every input (tested
//! against it, property-tested over lengths and contents).

/// The byte table of the reflected polynomial: entry `i` is `i` shifted through eight
/// rounds of the bitwise division.
const TABLE: [u32; 256] = table(0x82F6_3B78);

const fn table(reflected_poly: u32) -> [u32; 256] {
    let mut t = [0u32; 256];
    let mut i = 0;
    while i < 256 {
        let mut r = i as u32;
        let mut bit = 0;
        while bit < 8 {
            r = if r & 1 != 0 {
                (r >> 1) ^ reflected_poly
            } else {
                r >> 1
            };
            bit += 1;
        }
        t[i] = r;
        i += 1;
    }
    t
}

/// One byte of the register through the table: the low byte of `crc` is the byte's
/// remainder index (the input byte is already XORed into it).
#[inline(always)]
fn step(crc: u32) -> u32 {
    TABLE[(crc & 0xFF) as usize] ^ (crc >> 8)
}

/// The CRC-32C of `bytes`.
pub fn crc32c(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    let (words, tail) = bytes.as_chunks::<4>();
    for &w in words {
        crc = step(step(step(step(crc ^ u32::from_le_bytes(w)))));
    }
    // The 0..3 bytes left, written out: straight-line code, no loop to bound.
    if let Some(&b) = tail.first() {
        crc = step(crc ^ u32::from(b));
    }
    if let Some(&b) = tail.get(1) {
        crc = step(crc ^ u32::from(b));
    }
    if let Some(&b) = tail.get(2) {
        crc = step(crc ^ u32::from(b));
    }
    !crc
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::vec::Vec;

    use super::*;
    use crc::{CRC_32_ISCSI, Crc};
    use proptest::prelude::*;

    const REFERENCE: Crc<u32> = Crc::<u32>::new(&CRC_32_ISCSI);

    #[test]
    fn check_value_of_the_catalogue() {
        assert_eq!(crc32c(b"123456789"), 0xE306_9283);
        assert_eq!(crc32c(b""), 0);
    }

    #[test]
    fn agrees_with_the_crc_crate_at_every_tail_length() {
        let bytes: Vec<u8> = (0..64u32).map(|i| (i * 37 + 11) as u8).collect();
        for n in 0..=bytes.len() {
            assert_eq!(
                crc32c(&bytes[..n]),
                REFERENCE.checksum(&bytes[..n]),
                "{n} bytes"
            );
        }
    }

    proptest! {
        #[test]
        fn agrees_with_the_crc_crate(bytes in proptest::collection::vec(any::<u8>(), 0..700)) {
            prop_assert_eq!(crc32c(&bytes), REFERENCE.checksum(&bytes));
        }
    }
}
