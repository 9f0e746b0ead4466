//! Stack high-water mark: how deep the call stack has ever reached since reset.
//!
//! Place in the data flow: diagnostics only. cortex-m-rt's `paint-stack` feature fills the
//! stack region (between `_stack_end`, the end of the statics, and `_stack_start`, the
//! initial stack pointer) with `0xCCCC_CCCC` at reset; [`used_bytes`] scans up from the
//! bottom for the first word that is no longer paint. The qemu board logs it with every
//! event; on the real board a debugger can read the same region.
//!
//! Invariant: a lower bound, exact unless the deepest frame happened to write the paint
//! value itself at its deepest word. The same scan serves flip-link's layout (the stack
//! below the statics: flip-link sets `_stack_end` to the bottom of RAM). `None` only for a
//! layout without a stack region (`_stack_end` not below `_stack_start`).

use cortex_m_rt::STACK_PAINT_VALUE;

// Note(unsafe): declares cortex-m-rt's linker symbols; only their addresses are used.
#[allow(unsafe_code)]
unsafe extern "C" {
    static _stack_end: u32;
    static _stack_start: u32;
}

/// Deepest stack use since reset, bytes; `None` when the layout has no painted region.
pub fn used_bytes() -> Option<u32> {
    // Note(unsafe): the two linker symbols are addresses only (never dereferenced as
    // objects); the words between them are the stack region, always mapped RAM, read
    // volatile one aligned word at a time. Words above the current stack pointer may be
    // written concurrently by this very call chain, which only makes the result larger.
    #[allow(unsafe_code)]
    unsafe {
        let bottom = (&raw const _stack_end) as usize;
        let top = (&raw const _stack_start) as usize;
        if bottom >= top {
            return None;
        }
        let mut p = bottom;
        while p < top && core::ptr::read_volatile(p as *const u32) == STACK_PAINT_VALUE {
            p += 4;
        }
        Some((top - p) as u32)
    }
}
