//! Flash and static RAM of a firmware ELF, from its section headers (no binutils needed).

use std::path::Path;

use serde::Serialize;

type Error = Box<dyn std::error::Error>;

/// Flash and static RAM of an ELF, bytes.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Sizes {
    /// Vector table, code, read-only data and the initial values of `.data`.
    pub flash_bytes: u64,
    /// `.data`, `.bss` and `.uninit`.
    pub ram_bytes: u64,
}

/// Reads an ELF32 little-endian file's allocated sections: flash = sections in the flash
/// region (0x0800_0000..0x0810_0000: vector table, code, read-only data) plus the initial
/// values of `.data` (stored in flash); RAM = allocated sections in SRAM (0x2000_0000..),
/// `.data`, `.bss` and `.uninit`.
pub fn sizes(path: &Path) -> Result<Sizes, Error> {
    const SHF_ALLOC: u32 = 2;
    const SHT_NOBITS: u32 = 8;
    let b = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let u16_at = |o: usize| -> Result<u32, Error> {
        Ok(u32::from(u16::from_le_bytes(
            b.get(o..o + 2).ok_or("truncated ELF")?.try_into()?,
        )))
    };
    let u32_at = |o: usize| -> Result<u32, Error> {
        Ok(u32::from_le_bytes(
            b.get(o..o + 4).ok_or("truncated ELF")?.try_into()?,
        ))
    };
    if b.get(0..6) != Some(&[0x7f, b'E', b'L', b'F', 1, 1][..]) {
        return Err(format!("{}: not a 32-bit little-endian ELF", path.display()).into());
    }
    let shoff = u32_at(0x20)? as usize;
    let shentsize = u16_at(0x2e)? as usize;
    let shnum = u16_at(0x30)? as usize;
    let (mut flash, mut ram) = (0u64, 0u64);
    for i in 0..shnum {
        let h = shoff + i * shentsize;
        let (kind, flags, addr, size) = (
            u32_at(h + 4)?,
            u32_at(h + 8)?,
            u32_at(h + 12)?,
            u32_at(h + 20)?,
        );
        if flags & SHF_ALLOC == 0 || size == 0 {
            continue;
        }
        let size = u64::from(size);
        match addr {
            0x0800_0000..0x0810_0000 => flash += size,
            0x2000_0000..0x2002_0000 => {
                ram += size;
                if kind != SHT_NOBITS {
                    flash += size; // .data's initial values
                }
            }
            _ => {}
        }
    }
    Ok(Sizes {
        flash_bytes: flash,
        ram_bytes: ram,
    })
}
