//! Stack high-water marks: how deep the call stack has ever reached since reset, and how
//! much one call (the control step) uses.
//!
//! Place in the data flow: diagnostics only. cortex-m-rt's `paint-stack` feature fills the
//! stack region (between `_stack_end`, the end of the statics, and `_stack_start`, the
//! initial stack pointer) with `0xCCCC_CCCC` at reset; [`used_bytes`] scans up from the
//! bottom for the first word that is no longer paint. The qemu board logs it with every
//! event; on the real board a debugger can read the same region.
//!
//! [`probe`] measures one call: it paints the [`PROBE_WINDOW_BYTES`] below the current stack
//! pointer again, runs the call, and scans that window up from its bottom for the deepest
//! overwritten word. Painting happens in the caller's frame ([`probe`] is always inlined), so
//! only memory below the stack pointer, unused at that moment, is written. The marks other
//! code had left in the window are scanned first and kept ([`used_bytes`] still reports the
//! deepest point since reset).
//!
//! Invariant: lower bounds, exact unless the deepest frame happened to write the paint
//! value itself at its deepest word; an interrupt taken during the probed call adds its
//! frame (under lockstep none arrives during a step: the peer waits for the answer). The
//! same scan serves flip-link's layout (the stack below the statics: flip-link sets
//! `_stack_end` to the bottom of RAM). `None` only for a layout without a stack region
//! (`_stack_end` not below `_stack_start`).

use core::sync::atomic::{AtomicUsize, Ordering};

use cortex_m_rt::STACK_PAINT_VALUE;

// Note(unsafe): declares cortex-m-rt's linker symbols; only their addresses are used.
#[allow(unsafe_code)]
unsafe extern "C" {
    static _stack_end: u32;
    static _stack_start: u32;
}

/// Bytes below the stack pointer that [`probe`] repaints and scans: the most one probed call
/// can be seen to use.
#[cfg_attr(not(any(feature = "qemu", feature = "bench")), allow(dead_code))]
pub const PROBE_WINDOW_BYTES: usize = 4096;

/// Lowest address found overwritten inside a probe window before it was repainted (the
/// marks of earlier, deeper calls); `usize::MAX` for none.
static DEEPEST_SEEN: AtomicUsize = AtomicUsize::new(usize::MAX);

fn region() -> Option<(usize, usize)> {
    let bottom = (&raw const _stack_end) as usize;
    let top = (&raw const _stack_start) as usize;
    (bottom < top).then_some((bottom, top))
}

/// The first address at or above `from` (word-aligned, below `to`) that is not paint; `to`
/// when all is paint.
#[inline(always)]
fn first_used(from: usize, to: usize) -> usize {
    let mut p = from;
    // Note(unsafe): callers pass word-aligned bounds inside the stack region (mapped RAM);
    // read volatile one word at a time, never written here.
    #[allow(unsafe_code)]
    while p < to && unsafe { core::ptr::read_volatile(p as *const u32) } == STACK_PAINT_VALUE {
        p += 4;
    }
    p
}

/// Deepest stack use since reset, bytes; `None` when the layout has no painted region.
pub fn used_bytes() -> Option<u32> {
    let (bottom, top) = region()?;
    let scanned = first_used(bottom, top);
    let deepest = scanned.min(DEEPEST_SEEN.load(Ordering::Relaxed));
    Some((top - deepest) as u32)
}

/// Runs `f` and returns its result and the stack it used below the caller's stack pointer,
/// bytes (at most [`PROBE_WINDOW_BYTES`]; `None` without a painted region).
#[cfg_attr(not(any(feature = "qemu", feature = "bench")), allow(dead_code))]
#[inline(always)]
pub fn probe<R>(f: impl FnOnce() -> R) -> (R, Option<u32>) {
    let Some((bottom, _)) = region() else {
        return (f(), None);
    };
    let sp = cortex_m::register::msp::read() as usize & !3;
    let low = sp.saturating_sub(PROBE_WINDOW_BYTES).max(bottom);
    // Keep the marks earlier calls left in the window, then repaint it.
    DEEPEST_SEEN.fetch_min(first_used(low, sp), Ordering::Relaxed);
    let mut p = low;
    while p < sp {
        // Note(unsafe): `[low, sp)` is stack memory below the stack pointer, unused now: this
        // function is inlined into its caller, whose frame lies above `sp`, and it calls
        // nothing before `f`. Word-aligned, mapped RAM.
        #[allow(unsafe_code)]
        unsafe {
            core::ptr::write_volatile(p as *mut u32, STACK_PAINT_VALUE);
        }
        p += 4;
    }
    let r = f();
    let deepest = first_used(low, sp);
    DEEPEST_SEEN.fetch_min(deepest, Ordering::Relaxed);
    (r, Some((sp - deepest) as u32))
}
