//! Fault handling: the panic handler and the HardFault handler leave the actuators in a safe
//! state and record why; a clock failure is recorded and resets the board.
//!
//! Place in the data flow: outside it. On a panic (which the application is built never to
//! reach: no byte sequence can cause one) or a HardFault, with interrupts masked:
//! 1. the reason (source file, line and message, or the faulting PC) is written to a
//!    [`FaultRecord`] in `.uninit` RAM, which a reset does not clear: the next boot reports
//!    it ([`take_previous`]: log line and `LinkStatus::PREVIOUS_PANIC` in every frame) and a
//!    debugger can read it at `FAULT_RECORD`;
//! 2. a command frame with the trim commands and `LinkStatus::PANIC` is written to USART1 by
//!    polling (the actuator side holds trim on it);
//! 3. the board finishes ([`super::selected::on_fault`]): QEMU logs the reason and exits with
//!    status 1; the real board repeats the safe frame every control period without feeding
//!    its independent watchdog, which resets it (within 68..188 ms in flight, 5..15 s during
//!    boot): it boots in standby with trim, the fault record sets `PREVIOUS_PANIC`, and it
//!    does not engage until the peer acknowledges the reset (`crate::boot`).
//!
//! The HardFault handler is entered through a small assembly trampoline
//! ([`HardFault`](hard_fault_on_fresh_stack)) that moves the stack pointer to the top of the
//! stack region before any Rust code runs: a HardFault from a stack overflow (under
//! flip-link the stack grows down into the unmapped space below RAM) would otherwise fault
//! again on the handler's first push and lock the core up without a safe frame. The stack
//! that faulted is abandoned (the handler never returns); its stacked PC is read only if the
//! exception frame lies in RAM.
//!
//! The trampoline also clears FPCCR's LSPACT first (Cortex-M4 Devices Generic User Guide,
//! "Floating-point Context Control Register"): the flight code uses the FPU, so an exception
//! entry reserves room for the floating-point registers on the faulting stack and defers
//! their save (lazy stacking: LSPACT set, FPCAR pointing at that room) to the handler's first
//! floating-point instruction. After a stack overflow FPCAR points below RAM, and that save
//! would fault inside HardFault: a lock-up. Clearing LSPACT abandons the deferred save (the
//! faulting context is abandoned anyway), so the handler may use the FPU.
//!
//! The record keeps the fault status registers as read in the handler (the Cortex-M4
//! Generic User Guide, "System control block"): CFSR (the MemManage, BusFault and UsageFault
//! status), HFSR (HardFault status: FORCED for an escalated fault, VECTTBL for a vector
//! read), MMFAR and BFAR (the faulting addresses, meaningful when CFSR's MMARVALID and
//! BFARVALID say so); the next boot logs them.
//!
//! A clock failure (the clock security system's NMI, `f405` board) records its reason and
//! resets the board at once ([`clock_failure_reset`]): the link's baud rate depends on the
//! lost clock, so a safe frame could not be sent; the next boot runs on the internal
//! oscillator if the crystal does not start, and says so.
//!
//! Best effort: a fault inside the fault path (a second panic) skips to the halt; a fault
//! before USART1 was enabled sends nothing; the record survives a reset but not a power loss.
//!
//! Invariant: nothing here allocates; the record is plain integers (any bit pattern is a
//! valid value; the magic word and the checksum decide whether it means anything).

use core::fmt::Write as _;
use core::mem::MaybeUninit;
use core::panic::PanicInfo;
use core::sync::atomic::{AtomicBool, Ordering};

use ibvs_core::wire::MAX_FRAME_LEN;
use stm32f4xx_hal::pac::USART1;

/// Marks a written record ("FAUL").
const MAGIC: u32 = 0x4641_554C;
/// Bytes of the message (and of the file name) kept.
pub const TEXT_LEN: usize = 64;

/// Why the firmware stopped, as recorded.
#[derive(Clone, Copy)]
#[repr(C)]
pub struct FaultRecord {
    magic: u32,
    /// Source line of the panic, 0 for a HardFault.
    pub line: u32,
    /// Faulting program counter (HardFault), 0 for a panic.
    pub pc: u32,
    /// The fault status registers when the record was written (module doc).
    pub status: FaultStatus,
    /// Source file of the panic (truncated, NUL-padded).
    pub file: [u8; TEXT_LEN],
    /// Panic message or fault name (truncated, NUL-padded).
    pub message: [u8; TEXT_LEN],
    check: u32,
}

/// The system control block's fault status and address registers (Cortex-M4 Generic User
/// Guide, "System control block").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C)]
pub struct FaultStatus {
    /// Configurable Fault Status Register (0xE000_ED28): MMFSR byte 0, BFSR byte 1, UFSR
    /// bytes 2-3.
    pub cfsr: u32,
    /// HardFault Status Register (0xE000_ED2C): VECTTBL bit 1, FORCED bit 30, DEBUGEVT
    /// bit 31.
    pub hfsr: u32,
    /// MemManage Fault Address Register (0xE000_ED34), valid when CFSR's MMARVALID (bit 7).
    pub mmfar: u32,
    /// BusFault Address Register (0xE000_ED38), valid when CFSR's BFARVALID (bit 15).
    pub bfar: u32,
}

impl FaultStatus {
    const fn empty() -> Self {
        Self {
            cfsr: 0,
            hfsr: 0,
            mmfar: 0,
            bfar: 0,
        }
    }

    /// The registers now.
    pub fn read() -> Self {
        // Note(unsafe): word reads of the system control block's fault registers, always
        // mapped and aligned, without side effects (they clear only when written).
        #[allow(unsafe_code)]
        unsafe {
            Self {
                cfsr: core::ptr::read_volatile(0xE000_ED28 as *const u32),
                hfsr: core::ptr::read_volatile(0xE000_ED2C as *const u32),
                mmfar: core::ptr::read_volatile(0xE000_ED34 as *const u32),
                bfar: core::ptr::read_volatile(0xE000_ED38 as *const u32),
            }
        }
    }
}

impl FaultRecord {
    const fn empty() -> Self {
        Self {
            magic: 0,
            line: 0,
            pc: 0,
            status: FaultStatus::empty(),
            file: [0; TEXT_LEN],
            message: [0; TEXT_LEN],
            check: 0,
        }
    }

    fn checksum(&self) -> u32 {
        let s = &self.status;
        let mut h = self.magic
            ^ self.line.rotate_left(7)
            ^ self.pc.rotate_left(13)
            ^ s.cfsr.rotate_left(3)
            ^ s.hfsr.rotate_left(11)
            ^ s.mmfar.rotate_left(17)
            ^ s.bfar.rotate_left(23);
        for &b in self.file.iter().chain(self.message.iter()) {
            h = h.rotate_left(5) ^ u32::from(b);
        }
        h
    }

    /// A text field as a string (up to its first NUL; invalid UTF-8 gives "?").
    pub fn text(field: &[u8]) -> &str {
        let n = field.iter().position(|&b| b == 0).unwrap_or(field.len());
        core::str::from_utf8(&field[..n]).unwrap_or("?")
    }
}

/// Truncating writer into a fixed field.
struct Field<'a> {
    buf: &'a mut [u8],
    at: usize,
}

impl core::fmt::Write for Field<'_> {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        for &b in s.as_bytes() {
            if let Some(slot) = self.buf.get_mut(self.at) {
                *slot = b;
                self.at += 1;
            }
        }
        Ok(())
    }
}

/// The record, in RAM that cortex-m-rt neither loads nor zeroes.
// Note(unsafe): `link_section` only places the static in `.uninit` (see the module doc) and
// `no_mangle` gives it a fixed symbol name for a debugger; no other symbol has that name.
#[allow(unsafe_code)]
#[unsafe(link_section = ".uninit.FAULT_RECORD")]
#[unsafe(no_mangle)]
static mut FAULT_RECORD: MaybeUninit<FaultRecord> = MaybeUninit::uninit();

static IN_FAULT: AtomicBool = AtomicBool::new(false);

fn store(record: &FaultRecord) {
    // Note(unsafe): only the fault path writes the record, once (IN_FAULT), with interrupts
    // masked on a single core: no other access can overlap. Volatile, so the write is not
    // elided before the halt.
    #[allow(unsafe_code)]
    unsafe {
        core::ptr::write_volatile(&raw mut FAULT_RECORD, MaybeUninit::new(*record));
    }
}

/// The record of a fault before the last reset, if there is a valid one; clears it.
pub fn take_previous() -> Option<FaultRecord> {
    // Note(unsafe): called once at boot, before interrupts are enabled and before any fault
    // path can run, so nothing else accesses the record. The RAM holds some bit pattern
    // after reset (uninitialised to the language, concrete to the hardware); a
    // `FaultRecord` is only integers, so any pattern is a value, and the magic word and the
    // checksum reject the ones that are not a record.
    #[allow(unsafe_code)]
    let r = unsafe { core::ptr::read_volatile(&raw const FAULT_RECORD).assume_init() };
    store(&FaultRecord::empty());
    (r.magic == MAGIC && r.check == r.checksum()).then_some(r)
}

/// Writes `bytes` to USART1 by polling, whatever the state of the link driver.
fn write_raw(bytes: &[u8]) {
    // Note(unsafe): interrupts are masked and the main loop will never run again, so this
    // is the only user of the USART registers from here on (single core).
    #[allow(unsafe_code)]
    let usart = unsafe { USART1::steal() };
    if usart.cr1().read().ue().bit_is_clear() {
        return;
    }
    for &b in bytes {
        while usart.sr().read().txe().bit_is_clear() {}
        usart.dr().write(|w| w.dr().set(u16::from(b)));
    }
}

/// Sends the safe-state command frame (trim commands, `LinkStatus::PANIC`), after a `0x00`
/// that ends any frame the fault cut off ([`crate::app::safe_frame`]).
pub fn send_safe_frame() {
    let mut buf = [0u8; MAX_FRAME_LEN + 1];
    if let Some(bytes) = crate::app::safe_frame(&mut buf) {
        write_raw(bytes);
    }
}

/// Masks interrupts and writes the record `fill` makes; `None` (nothing written) when a
/// fault path is already running.
fn record(fill: impl FnOnce(&mut FaultRecord)) -> Option<FaultRecord> {
    cortex_m::interrupt::disable();
    if IN_FAULT.swap(true, Ordering::Relaxed) {
        return None;
    }
    let mut r = FaultRecord::empty();
    r.magic = MAGIC;
    r.status = FaultStatus::read();
    fill(&mut r);
    r.check = r.checksum();
    store(&r);
    Some(r)
}

fn fault(fill: impl FnOnce(&mut FaultRecord)) -> ! {
    let Some(r) = record(fill) else { halt() };
    send_safe_frame();
    super::selected::on_fault(&r)
}

/// Records `reason` (a clock failure) and resets the board at once, without a safe frame
/// (see the module doc).
#[cfg_attr(not(feature = "f405"), allow(dead_code))]
pub fn clock_failure_reset(reason: &str) -> ! {
    if record(|r| {
        let _ = Field {
            buf: &mut r.message,
            at: 0,
        }
        .write_str(reason);
    })
    .is_none()
    {
        halt()
    }
    cortex_m::peripheral::SCB::sys_reset()
}

/// Parks the core.
pub fn halt() -> ! {
    loop {
        super::sleep_until_interrupt();
    }
}

#[panic_handler]
fn panic(info: &PanicInfo<'_>) -> ! {
    fault(|r| {
        if let Some(loc) = info.location() {
            r.line = loc.line();
            let _ = Field {
                buf: &mut r.file,
                at: 0,
            }
            .write_str(loc.file());
        }
        let _ = write!(
            Field {
                buf: &mut r.message,
                at: 0,
            },
            "{}",
            info.message()
        );
    })
}

// The HardFault vector (cortex-m-rt's `HardFault` symbol, which this definition overrides):
// the faulting stack pointer (MSP or PSP, per EXC_RETURN in LR) into r0, FPCCR's LSPACT
// (bit 0 of 0xE000_EF34) cleared so that no deferred floating-point save targets the
// faulting stack (module doc), the stack pointer set to the top of the stack region
// (`_stack_start`, cortex-m-rt's and flip-link's initial stack pointer), then a branch to
// the Rust handler, which never returns, with FPCCR as found in r1. DSB and ISB complete
// the FPCCR write before any later instruction can use the FPU.
// Note(unsafe): `global_asm!` is unsafe by nature; the entry uses no stack and touches no
// memory but FPCCR (a mapped system register) before the new stack pointer is set, and the
// handler it branches to is an `extern "C" fn(u32, u32) -> !` that takes the old stack
// pointer and FPCCR as plain integers.
#[allow(unsafe_code)]
mod trampoline {
    core::arch::global_asm!(
        ".section .HardFault.user, \"ax\"",
        ".global HardFault",
        ".type HardFault,%function",
        ".thumb_func",
        "HardFault:",
        "tst lr, #4",
        "ite eq",
        "mrseq r0, MSP",
        "mrsne r0, PSP",
        "ldr r1, =0xE000EF34",
        "ldr r2, [r1]",
        "bic r3, r2, #1",
        "str r3, [r1]",
        "dsb",
        "isb",
        "mov r1, r2",
        "ldr r2, =_stack_start",
        "msr MSP, r2",
        "b {handler}",
        ".ltorg",
        ".size HardFault, . - HardFault",
        handler = sym super::hard_fault_on_fresh_stack,
    );
}

/// The SRAM the stack and the exception frames live in (`memory.x`: SRAM1 and SRAM2).
const RAM: core::ops::Range<u32> = 0x2000_0000..0x2002_0000;

/// The HardFault handler proper, on a fresh stack (entered from the `HardFault` trampoline
/// with the stack pointer that faulted and FPCCR as the trampoline found it): records the
/// stacked PC when the exception frame lies in RAM, or names a stack overflow when the stack
/// pointer left RAM, and notes "LSPACT" when a deferred floating-point save was abandoned.
extern "C" fn hard_fault_on_fresh_stack(faulted_sp: u32, fpccr_at_entry: u32) -> ! {
    // The exception frame: r0, r1, r2, r3, r12, lr, pc, xPSR; the PC at offset 24.
    let frame_in_ram = faulted_sp.is_multiple_of(4)
        && RAM.contains(&faulted_sp)
        && faulted_sp.checked_add(32).is_some_and(|end| end <= RAM.end);
    let pc = if frame_in_ram {
        // Note(unsafe): a word-aligned read inside SRAM (checked above), which is always
        // mapped; the old stack is abandoned, nothing else uses it.
        #[allow(unsafe_code)]
        unsafe {
            core::ptr::read_volatile((faulted_sp + 24) as *const u32)
        }
    } else {
        0
    };
    fault(|r| {
        r.pc = pc;
        let mut message = Field {
            buf: &mut r.message,
            at: 0,
        };
        let _ = message.write_str(if frame_in_ram {
            "HardFault"
        } else {
            "HardFault: stack pointer outside RAM (stack overflow)"
        });
        if fpccr_at_entry & 1 != 0 {
            let _ = message.write_str("; LSPACT");
        }
    })
}
