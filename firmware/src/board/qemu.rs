//! The `qemu` board: QEMU's `netduinoplus2` machine, an emulated STM32F405.
//!
//! Place in the data flow: start-up and logging for the processor-in-the-loop runs
//! (`host_sim::pil`). QEMU 7.2 does not emulate the RCC, so there is no clock setup (the
//! peripherals run as soon as they are enabled; SysTick runs at QEMU's 168 MHz SYSCLK). With
//! `-icount shift=0` one instruction is one nanosecond of emulated time and TIM2, free-running
//! at PSC = 0, counts it: [`Tim2Counter`] is an exact instruction counter.
//!
//! The semihosting command line (`-semihosting-config ...,arg=firmware,arg=WORD`) selects:
//! - nothing: lockstep schedule (processor-in-the-loop);
//! - `free-running`: the free-running schedule (SysTick at 50 Hz);
//! - `self-test`: the power-on self-test only, its result as QEMU's exit status
//!   (what `cargo run --target thumbv7em-none-eabihf` does, see `.cargo/config.toml`);
//! - `bench` (a build with the `bench` feature; otherwise exit 1 saying so): print what each path of the control step, a frame decode and a frame encode
//!   cost ([`crate::bench`], one JSON line), exit 0;
//! - `panic-test`: panic once the link is up, to test the fault path (`super::fault`);
//! - `stack-overflow-test`: recurse until the stack overflows once the link is up, to test
//!   the HardFault trampoline (the safe frame must still come out).
//!
//! The boot frame reports a power-on ([`crate::boot::BootReport::power_on`]): QEMU starts
//! every run from power-on and this board never resets itself (a fault ends QEMU); QEMU 7.2
//! does not model the RCC's reset flags nor the independent watchdog, so this board has no
//! watchdog. Its tick runs in the free-running schedule only (`super::systick`).
//!
//! Logs are semihosting text on QEMU's stdout/stderr, never on the serial link (its own
//! chardev). Invariant: no clock or RCC access on this path.

use cortex_m_semihosting::{debug, hprintln};
use ibvs_core::wire::CostUnit;
use stm32f4xx_hal::pac;

use super::McuBoard;
use super::fault::{FaultRecord, halt};
use crate::app::{App, BootReport, CostCounter, Event, Schedule};
#[cfg(feature = "bench")]
use crate::bench;
use crate::one_step;
use crate::one_step::Micro;
use crate::store::NoStore;

/// The stack high-water mark, as text ("4628 B" or "unknown").
struct StackMark;

impl core::fmt::Display for StackMark {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match super::stack::used_bytes() {
            Some(b) => write!(f, "{b} B"),
            None => f.write_str("unknown"),
        }
    }
}

/// QEMU's SYSCLK for netduinoplus2, Hz: SysTick's clock with CLKSOURCE = processor.
const CORE_HZ: u32 = 168_000_000;

/// TIM2's counter: instructions executed under `-icount shift=0`.
pub struct Tim2Counter;

/// The cost counter of this board.
pub type Counter = Tim2Counter;

impl CostCounter for Tim2Counter {
    const UNIT: CostUnit = CostUnit::Instructions;
    /// 1 ms at 168 MHz if every instruction took one cycle (none takes fewer on a
    /// Cortex-M4): an overrun here is one on the board too (QEMU's own clock, 1 ns per
    /// instruction, is not the board's).
    const DEADLINE: u32 = 168_000;
    fn now() -> u32 {
        // Note(unsafe): a read of TIM2_CNT, a free-running counter: no side effect, no
        // shared state; TIM2 is started in `start` before any read matters.
        #[allow(unsafe_code)]
        unsafe {
            (*pac::TIM2::ptr()).cnt().read().bits()
        }
    }

    #[inline(always)]
    fn uninterrupted<R>(f: impl FnOnce() -> R) -> R {
        cortex_m::interrupt::free(|_| f())
    }

    #[inline(always)]
    fn stack_of<R>(f: impl FnOnce() -> R) -> (R, Option<u32>) {
        super::stack::probe(f)
    }
}

/// The semihosting command line, as words (at most 128 bytes).
struct CommandLine {
    buf: [u8; 128],
    len: usize,
}

impl CommandLine {
    fn read() -> Self {
        let mut buf = [0u8; 128];
        // SYS_GET_CMDLINE's parameter block: buffer address and length (the host writes the
        // length of the command line back into it).
        let mut block = [buf.as_mut_ptr() as usize, buf.len() - 1];
        // Note(unsafe): the host writes at most `block[1]` bytes and a NUL into `buf`, and the
        // length into `block`; both live across the call and are passed as pointers derived
        // from exclusive borrows, not otherwise used meanwhile.
        #[allow(unsafe_code)]
        let status = unsafe {
            cortex_m_semihosting::syscall1(
                cortex_m_semihosting::nr::GET_CMDLINE,
                block.as_mut_ptr() as usize,
            )
        };
        let len = if status == 0 {
            buf.iter().position(|&b| b == 0).unwrap_or(buf.len())
        } else {
            0
        };
        Self { buf, len }
    }

    fn has(&self, word: &str) -> bool {
        self.buf[..self.len]
            .split(|&b| b == b' ')
            .any(|w| w == word.as_bytes())
    }
}

/// Start-up: self-test, timers, link, application.
pub fn start() -> ! {
    let args = CommandLine::read();
    let (Some(dp), Some(cp)) = (pac::Peripherals::take(), cortex_m::Peripherals::take()) else {
        hprintln!("firmware: peripherals already taken");
        debug::exit(debug::EXIT_FAILURE);
        halt()
    };
    // TIM2 free-running at PSC = 0 over the full 32 bits: the instruction counter.
    dp.TIM2.psc().write(|w| w.psc().set(0));
    dp.TIM2.arr().write(|w| w.arr().set(u32::MAX));
    dp.TIM2.cr1().write(|w| w.cen().set_bit());

    match one_step::run() {
        Ok(out) => {
            if args.has("self-test") {
                let c = out.command.as_array();
                hprintln!(
                    "firmware: one step ok: mode {:?}, command [{}, {}, {}, {}]",
                    out.mode,
                    Micro(c[0]),
                    Micro(c[1]),
                    Micro(c[2]),
                    Micro(c[3])
                );
                debug::exit(debug::EXIT_SUCCESS);
                halt()
            }
        }
        Err(e) => {
            hprintln!("firmware: one step FAILED: {}", e);
            debug::exit(debug::EXIT_FAILURE);
            halt()
        }
    }
    if args.has("bench") {
        #[cfg(feature = "bench")]
        {
            let c = bench::measure::<Tim2Counter>();
            hprintln!("firmware bench: {}", bench::Json(&c, "instructions"));
            hprintln!("firmware bench: stack high-water mark {}", StackMark);
            debug::exit(debug::EXIT_SUCCESS);
        }
        #[cfg(not(feature = "bench"))]
        {
            hprintln!("firmware: built without the bench feature (--features bench)");
            debug::exit(debug::EXIT_FAILURE);
        }
        halt()
    }

    let schedule = if args.has("free-running") {
        Schedule::FreeRunning
    } else {
        Schedule::Lockstep
    };
    let previous = super::fault::take_previous();
    if let Some(r) = &previous {
        log_fault("before the last reset", r);
    }
    let link = super::usart1::init(dp.USART1, None);
    let autopilot = super::usart2::init(dp.USART2, None);
    if schedule == Schedule::FreeRunning && super::systick::start(cp.SYST, CORE_HZ).is_err() {
        hprintln!("firmware: SysTick reload out of range");
        debug::exit(debug::EXIT_FAILURE);
        halt()
    }
    if args.has("panic-test") {
        // Exercises the fault path (safe frame, record, exit 1) from a test; reachable only
        // through QEMU's semihosting command line.
        panic!("panic-test requested on the semihosting command line");
    }
    if args.has("stack-overflow-test") {
        // Exercises the HardFault trampoline: the stack runs into the unmapped memory
        // below RAM (flip-link), the fault handler must still send the safe frame.
        hprintln!("firmware: stack-overflow-test: recursing");
        overflow_the_stack(0);
    }
    let boot = BootReport {
        previous_fault: previous.is_some(),
        ..BootReport::power_on()
    };
    hprintln!(
        "firmware: reset cause {:?}, clock {:?}",
        boot.reset_cause,
        boot.clock
    );
    let app = match App::new(schedule, boot, None) {
        Ok(app) => app,
        Err(e) => {
            hprintln!("firmware: configuration rejected: {}", e);
            debug::exit(debug::EXIT_FAILURE);
            halt()
        }
    };
    hprintln!(
        "firmware: qemu board, {:?} schedule, link on USART1, autopilot on USART2",
        schedule
    );
    // QEMU's flash is read-only: no configuration store, the default at every boot.
    app.run(&mut McuBoard::<Tim2Counter, _>::new(
        link, autopilot, NoStore,
    ))
}

/// Recurses forever, each frame 256 bytes the optimiser cannot remove (the
/// `stack-overflow-test`).
#[inline(never)]
#[allow(
    unconditional_recursion,
    reason = "the test overflows the stack on purpose"
)]
fn overflow_the_stack(depth: u32) -> u32 {
    let mut frame = [depth; 64];
    core::hint::black_box(&mut frame);
    overflow_the_stack(depth.wrapping_add(1)).wrapping_add(frame[(depth % 64) as usize])
}

/// Logs an application event as a semihosting line.
#[inline(never)]
pub fn log(event: Event) {
    match event {
        Event::ModeChanged { mode, reason, step } => hprintln!(
            "firmware: step {}: mode {:?} ({:?}); stack high-water mark {}",
            step,
            mode,
            reason,
            StackMark
        ),
        Event::LinkStale => hprintln!("firmware: link stale: navigation treated as invalid"),
        Event::LinkRecovered => hprintln!("firmware: link recovered"),
        Event::Configured { id } => hprintln!("firmware: configuration {:#010x} applied", id),
        Event::ControlStack { bytes, step } => hprintln!(
            "firmware: step {}: control-path stack high-water mark {} B",
            step,
            bytes
        ),
        Event::DeadlineOverrun {
            elapsed,
            deadline,
            step,
        } => hprintln!(
            "firmware: step {}: command frame queued {} instructions after its trigger (deadline {})",
            step,
            elapsed,
            deadline
        ),
        Event::EngageInhibited { cause } => hprintln!(
            "firmware: engage refused: the reset ({:?}) is not acknowledged (send Reset)",
            cause
        ),
        Event::ResetAcknowledged => hprintln!("firmware: reset acknowledged: engage allowed"),
    }
}

fn log_fault(when: &str, r: &FaultRecord) {
    let s = &r.status;
    hprintln!(
        "firmware: FAULT {}: {} at {}:{} pc {:#010x} CFSR {:#010x} HFSR {:#010x} MMFAR {:#010x} BFAR {:#010x}",
        when,
        FaultRecord::text(&r.message),
        FaultRecord::text(&r.file),
        r.line,
        r.pc,
        s.cfsr,
        s.hfsr,
        s.mmfar,
        s.bfar
    );
}

/// The end of the fault path under QEMU: log and exit with status 1.
pub fn on_fault(r: &FaultRecord) -> ! {
    log_fault("(safe frame sent)", r);
    debug::exit(debug::EXIT_FAILURE);
    halt()
}
