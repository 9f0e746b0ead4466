//! The control task's static bounds on the firmware: which machine code the control step and
//! the whole control task are, what the analysis leaves out and why, the loops' declared
//! bounds, the interrupts that can land on the task, and the figures in instructions, cycles
//! and microseconds with their assumptions.
//!
//! Place in the data flow: `main.rs` calls [`analyse`] on each board's ELF (disassembled by
//! [`crate::wcet`], costed by [`crate::cycles`]); the figures go into the JSON report
//! (`step_cycles_bound`, `cycle_cycles_bound`, ...) and the gate (`benchmarks/expected.json`).
//!
//! The control task, from the last byte of a measurement frame to the command frame handed
//! to the UART:
//! - lockstep (the `qemu` board's processor-in-the-loop schedule): `App::on_bytes` of the
//!   received bytes, handed over once the frame's end is queued: the decoder's `feed_slice`
//!   decoding the frame (COBS, CRC-32C, header),
//!   the measurement's postcard deserialisation, `accept`, the step (`control_step`), the gain
//!   schedule's follow-up (`Controller::follow_schedule`) and the command frame's encode
//!   (`encode_downlink`: postcard, CRC-32C, COBS);
//! - free-running (the `f405` board's flight schedule): `App::on_bytes` of the frame
//!   (decode and `accept`, which only keeps the frame) plus `App::on_periods` of the next
//!   control period (step, follow-up, encode).
//!
//! Both `on_bytes` and `on_periods` are out of line in the firmware for this (`firmware/src/
//! app.rs`). The bound stops where the frame is in the buffer: its transmission (polled, one
//! byte per UART character time) is the link's time, not computation. The wake-up from the
//! idle wait and the read of the receive queue before `on_bytes` are not in it either.
//!
//! Invariant: every figure of a board comes from its own ELF; a loop without a matching
//! declaration in [`LOOPS`] makes the bound an error naming the loop, never a guess.

use serde::Serialize;

use crate::cycles::{self, Model};
use crate::wcet::{
    Bound, Disassembly, LoopBound, Metric, Rules, SizedCall, SizedCallee, SizedLoop,
};

/// The control step.
pub const STEP: &str = "ibvs_core::controller::Controller::step";
/// One received byte (out of line in the firmware for this analysis).
pub const ON_BYTES: &str = "firmware::app::App::on_bytes";
/// One control period of the free-running schedule (out of line likewise).
pub const ON_PERIODS: &str = "firmware::app::App::on_periods";
/// The receive interrupt.
pub const USART1: &str = "USART1";
/// The autopilot link's (MAVLink) interrupt: the same driver on USART2.
pub const USART2: &str = "USART2";
/// The control-period tick.
pub const SYSTICK: &str = "SysTick";

/// The PBVS law: the firmware flies IBVS (`ControllerConfig::default`), the step never calls
/// it.
pub const PBVS: &str = "ibvs_core::outer::pbvs";

/// Out of the control task: the paths of the other frame kinds, chosen by the frame's kind
/// byte before any of them runs. A configuration write or read is deserialised by
/// `config_from_bytes`, applied by `App::configure`, answered by `encode_config_report`; a
/// telemetry request is answered by `encode_telemetry`. The control task is a measurement
/// frame's.
const OTHER_FRAMES: [&str; 4] = [
    "firmware::app::App::configure",
    "ibvs_core::wire::config_from_bytes",
    "ibvs_core::wire::encode_config_report",
    "ibvs_core::wire::encode_telemetry",
];

/// Out of the control task's bound: the attitude-command loop's MAVLink work in the step's
/// window (the navigation sample from the autopilot's messages, the setpoint's encoding).
/// The firmware flies the surface loops by default, which never call them; through the
/// autopilot its cost is measured (the `autopilot` workload's control cycle,
/// `docs/benchmarks.md`), not bounded. The autopilot's bytes are decoded outside the task,
/// in the main loop's pass before it.
const AUTOPILOT_LINK: [&str; 2] = [
    "autopilot_link::session::Session::input",
    "autopilot_link::session::Session::send",
];

/// Out of the control task: the decode of a frame with a full COBS block followed by another
/// (a payload over 254 bytes). A measurement frame's payload is at most
/// `STEP_PAYLOAD_LEN` = 200 bytes (tested), so it never has one: `decode_frame` decodes it
/// block by block and never calls this.
const LONG_FRAMES: [&str; 1] = ["ibvs_core::wire::decode_long_frame"];

/// Code the task's machine code calls but never reaches: libm's general argument reduction
/// (`rem_pio2f`), which `sinf`/`cosf` call only for |x| > 9 pi / 4 (about 7.07 rad). The
/// task's only libm sine and cosine are of the gain schedule's trim pitch in
/// `Controller::follow_schedule` (the lever arm); the configuration's validation keeps every
/// node's trim pitch within 0.8 rad, and an interpolated trim lies between its nodes' (the
/// test `the_schedule_never_reaches_libm_argument_reduction` checks the table).
const UNREACHED: [&str; 1] = ["libm::math::rem_pio2f::rem_pio2f"];

/// Out of `on_bytes` in the free-running schedule: `accept` keeps the frame there, the step,
/// the follow-up and the encode run in `on_periods` (lockstep `on_bytes` calls them).
const LOCKSTEP_ONLY: [&str; 3] = [
    "firmware::app::control_step",
    "ibvs_core::controller::Controller::follow_schedule",
    "ibvs_core::wire::encode_downlink",
];

/// Calls that do not return: a panic ends the task (the fault path sends the safe frame and
/// resets); it is not a way to complete it. The application's loop and the USART1 handler
/// have no panic path (the firmware's no-panic link); library code may.
const DIVERGING: [&str; 6] = [
    "core::panicking::",
    "core::cell::panic_already",
    "core::slice::index::",
    "core::option::unwrap_failed",
    "core::result::unwrap_failed",
    "__rustc::rust_begin_unwind",
];

/// Library calls costed by the byte count at the call site (each of their loops iterates at
/// most once per byte: compiler_builtins' copy and fill loops advance by a byte or a word).
const SIZED: [SizedCall; 15] = [
    SizedCall {
        symbol: "compiler_builtins::mem::memcpy",
        size_register: "r2",
    },
    SizedCall {
        symbol: "__aeabi_memcpy",
        size_register: "r2",
    },
    SizedCall {
        symbol: "__aeabi_memcpy4",
        size_register: "r2",
    },
    SizedCall {
        symbol: "__aeabi_memcpy8",
        size_register: "r2",
    },
    SizedCall {
        symbol: "memcpy",
        size_register: "r2",
    },
    SizedCall {
        symbol: "__aeabi_memmove",
        size_register: "r2",
    },
    SizedCall {
        symbol: "__aeabi_memmove4",
        size_register: "r2",
    },
    SizedCall {
        symbol: "memmove",
        size_register: "r2",
    },
    SizedCall {
        symbol: "__aeabi_memclr",
        size_register: "r1",
    },
    SizedCall {
        symbol: "__aeabi_memclr4",
        size_register: "r1",
    },
    SizedCall {
        symbol: "__aeabi_memclr8",
        size_register: "r1",
    },
    SizedCall {
        symbol: "__aeabi_memset",
        size_register: "r1",
    },
    SizedCall {
        symbol: "__aeabi_memset4",
        size_register: "r1",
    },
    SizedCall {
        symbol: "memset",
        size_register: "r2",
    },
    SizedCall {
        symbol: "memcmp",
        size_register: "r2",
    },
];

/// The loops of the sized library functions on the task, bounded by the call's byte count
/// (compiler_builtins' `memcpy` and `memset` as the toolchain builds them: unrolled four
/// times, head and tail bytes apart). Found and checked like [`LOOPS`] (no source check:
/// the library has no line information).
pub const SIZED_LOOPS: &[SizedLoop] = &[
    SizedLoop {
        function: "__aeabi_memcpy8",
        ordinal: 0,
        instructions: 13,
        bytes_per_iteration: 16,
        at_most_bytes: None,
        reason: "four words an iteration while at least 4 bytes are left (__aeabi_memcpy4's loop, inlined into it: the application's copies of a measurement frame waiting for the autopilot's attitude)",
    },
    SizedLoop {
        function: "__aeabi_memcpy4",
        ordinal: 0,
        instructions: 13,
        bytes_per_iteration: 16,
        at_most_bytes: None,
        reason: "four words an iteration while at least 4 bytes are left",
    },
    SizedLoop {
        function: "compiler_builtins::mem::memcpy",
        ordinal: 0,
        instructions: 11,
        bytes_per_iteration: 4,
        at_most_bytes: Some(3),
        reason: "the bytes up to the destination's word alignment (0..3), four an iteration",
    },
    SizedLoop {
        function: "compiler_builtins::mem::memcpy",
        ordinal: 1,
        instructions: 17,
        bytes_per_iteration: 16,
        at_most_bytes: None,
        reason: "aligned words, four an iteration",
    },
    SizedLoop {
        function: "compiler_builtins::mem::memcpy",
        ordinal: 2,
        instructions: 11,
        bytes_per_iteration: 4,
        at_most_bytes: Some(15),
        reason: "the bytes after the words (0..3), or all of a copy under 16 bytes, four an iteration",
    },
    SizedLoop {
        function: "compiler_builtins::mem::memcpy",
        ordinal: 3,
        instructions: 56,
        bytes_per_iteration: 16,
        at_most_bytes: None,
        reason: "misaligned words (shifted pairs), four an iteration",
    },
    SizedLoop {
        function: "__aeabi_memclr",
        ordinal: 0,
        instructions: 4,
        bytes_per_iteration: 4,
        at_most_bytes: Some(3),
        reason: "the bytes up to the destination's word alignment (0..3)",
    },
    SizedLoop {
        function: "__aeabi_memclr",
        ordinal: 1,
        instructions: 12,
        bytes_per_iteration: 16,
        at_most_bytes: None,
        reason: "aligned words, four an iteration",
    },
    SizedLoop {
        function: "__aeabi_memclr",
        ordinal: 2,
        instructions: 4,
        bytes_per_iteration: 4,
        at_most_bytes: Some(15),
        reason: "the bytes after the words, or all of a fill under 16 bytes, a word an iteration",
    },
    // The word-aligned fill, which the compiler now builds on its own (inlined, not calling
    // `__aeabi_memclr`).
    SizedLoop {
        function: "__aeabi_memclr4",
        ordinal: 0,
        instructions: 6,
        bytes_per_iteration: 16,
        at_most_bytes: None,
        reason: "aligned words, four an iteration (two STRD)",
    },
    SizedLoop {
        function: "__aeabi_memclr4",
        ordinal: 1,
        instructions: 4,
        bytes_per_iteration: 4,
        at_most_bytes: Some(15),
        reason: "the words after the four-word loop (fewer than 16 bytes), a word an iteration",
    },
];

/// The sized library functions' calls with a smaller count.
pub const SIZED_CALLEES: &[SizedCallee] = &[
    SizedCallee {
        function: "__aeabi_memcpy4",
        callee: "compiler_builtins::mem::memcpy",
        at_most_bytes: 3,
        reason: "what is left after its 4-byte copies (fewer than 4 bytes)",
    },
    SizedCallee {
        function: "__aeabi_memcpy8",
        callee: "compiler_builtins::mem::memcpy",
        at_most_bytes: 3,
        reason: "what is left after its 4-byte copies (fewer than 4 bytes), as __aeabi_memcpy4's",
    },
];

/// The loops of the control task's machine code and their bounds. Each is found by its
/// function and its ordinal among that function's loops (by header address), and checked
/// against its source (inlined functions `addr2line` finds among its instructions) and its
/// size in instructions: a code change that moves, adds or reshapes a loop fails the bound
/// naming the loop, and `target-bench --loops` lists every loop with what it is now.
pub const LOOPS: &[LoopBound] = &[
    // The interrupt handlers' atomic increments (LDREX/STREX retry loops).
    LoopBound {
        function: "SysTick",
        ordinal: 0,
        source: &["systick::__cortex_m_rt_SysTick", "fetch_add"],
        instructions: 5,
        iterations: 1,
        reason: "PERIODS.fetch_add: the exclusive store fails only when an exception comes between LDREX and STREX, and nothing preempts SysTick (every exception at the reset priority)",
    },
    LoopBound {
        function: "USART1",
        ordinal: 0,
        source: &["usart1::__cortex_m_rt_USART1", "fetch_add"],
        instructions: 5,
        iterations: 1,
        reason: "rx_errors.fetch_add (a receive error or the queue full, once a run): as SysTick's, nothing preempts USART1",
    },
    LoopBound {
        function: "USART2",
        ordinal: 0,
        source: &["usart2::__cortex_m_rt_USART2", "fetch_add"],
        instructions: 5,
        iterations: 1,
        reason: "rx_errors.fetch_add, as USART1's (the same driver): nothing preempts USART2",
    },
    LoopBound {
        function: "USART2",
        ordinal: 1,
        source: &["serial::SerialQueues", "serial::Reader"],
        instructions: 12,
        iterations: 1,
        reason: "the transmit loop, as USART1's (the same driver): at most 2 bytes a run, the data register then full for a byte time (10 bits at 461,538 baud, 3,640 cycles), longer than the run (checked); on QEMU the queue is empty inside the task (the step's MAVLink frames are queued after the task's window, in the pass's send)",
    },
    LoopBound {
        function: "USART1",
        ordinal: 1,
        source: &["serial::SerialQueues", "serial::Reader"],
        instructions: 12,
        iterations: 1,
        reason: "the transmit loop, a byte a pass while the data register is empty, tested at its bottom (the first byte's tests come before it): at most 2 bytes a run, so back to its top at most once. On the MCU a write clears TXE, the register passes its byte to an idle shift register and takes one more, then stays full for a byte time (10 bits, 1,820 cycles), longer than the run (the analysis checks the handler's bound is under a byte time); on QEMU a write is immediate and one run empties the queue, but the queue is empty inside the task (the frame queued before it was sent by the run its queuing pended, before the task's first byte could arrive)",
    },
    // The frame decoder, on the receive queue's chunk that ends the frame.
    LoopBound {
        function: "ibvs_core::wire::FrameDecoder::take",
        ordinal: 0,
        source: &["wire::FrameDecoder::take"],
        instructions: 24,
        iterations: 128,
        reason: "the frame's bytes copied up to its zero, 4 bytes an iteration (the compiler unrolled it): App::poll hands on_bytes at most RX_CHUNK_LEN = 512 bytes, the whole receive queue, which the boards let it read once a frame's end is in it (so the whole frame is decoded after its last byte)",
    },
    LoopBound {
        function: "ibvs_core::wire::FrameDecoder::take",
        ordinal: 1,
        source: &["wire::decode_frame"],
        instructions: 32,
        iterations: 176,
        reason: "COBS decoding where the frame lies, a block a step, 4 steps an iteration (unrolled): a block is at least its code byte and the decoder holds at most MAX_FRAME_LEN = 704 bytes, so at most 704 blocks",
    },
    LoopBound {
        function: "ibvs_core::wire::FrameDecoder::skip",
        ordinal: 0,
        source: &["wire::FrameDecoder::skip", "position"],
        instructions: 22,
        iterations: 128,
        reason: "a rejected frame's bytes skipped up to its zero, 4 bytes an iteration (the compiler unrolled it): at most the chunk's RX_CHUNK_LEN = 512 bytes",
    },
    LoopBound {
        function: "ibvs_core::wire::FrameDecoder::skip",
        ordinal: 1,
        source: &["wire::decode_frame"],
        instructions: 32,
        iterations: 176,
        reason: "decode_frame inlined into skip's end of a frame (never with a frame to decode: skip ends only rejected frames; bounded as in take): at most 704 blocks, 4 an iteration",
    },
    LoopBound {
        function: "firmware::app::App::on_bytes",
        ordinal: 0,
        source: &["wire::check_payload", "crc32c::crc32c"],
        instructions: 59,
        iterations: 39,
        reason: "the CRC-32C of a received frame (check_payload), a word a step, 4 words an iteration (unrolled): decode_frame passes at most MAX_PAYLOAD_LEN = 636 bytes and the CRC covers all but the last 4, 632 bytes, 39 whole iterations; the 0..3 words and 0..3 bytes left are straight-line code",
    },
    // The `qemu` board's stack probe around the step (paint, scan).
    LoopBound {
        function: "firmware::app::control_step",
        ordinal: 0,
        source: &["stack::first_used", "stack::probe"],
        instructions: 26,
        iterations: 256,
        reason: "qemu board: the probe's scan of its window before the step, 4 words an iteration: PROBE_WINDOW_BYTES = 4,096 bytes, 1,024 words",
    },
    LoopBound {
        function: "firmware::app::control_step",
        ordinal: 1,
        source: &["stack::probe", "fetch_min"],
        instructions: 7,
        iterations: 1,
        reason: "qemu board: DEEPEST_SEEN.fetch_min; it repeats only when an exception came between LDREX and STREX, and each interrupt on the task is charged one more iteration of the dearest such loop",
    },
    LoopBound {
        function: "firmware::app::control_step",
        ordinal: 2,
        source: &["stack::first_used", "stack::probe"],
        instructions: 26,
        iterations: 256,
        reason: "qemu board: the probe's scan after the step, as before it",
    },
    LoopBound {
        function: "firmware::app::control_step",
        ordinal: 3,
        source: &["stack::probe", "fetch_min"],
        instructions: 7,
        iterations: 1,
        reason: "qemu board: DEEPEST_SEEN.fetch_min, as the other",
    },
    LoopBound {
        function: "firmware::app::control_step",
        ordinal: 4,
        source: &["stack::probe", "fetch_min"],
        instructions: 7,
        iterations: 1,
        reason: "qemu board: DEEPEST_SEEN.fetch_min, as the other",
    },
    LoopBound {
        function: "firmware::app::control_step",
        ordinal: 5,
        source: &["stack::probe", "write_volatile"],
        instructions: 12,
        iterations: 256,
        reason: "qemu board: the probe paints its window, 4 words an iteration: 1,024 words",
    },
    // The gain schedule's follow-up.
    LoopBound {
        function: "ibvs_core::controller::Controller::follow_schedule",
        ordinal: 0,
        source: &["schedule::Blend", "PlantModel"],
        instructions: 80,
        iterations: 5,
        reason: "the blend of a 5 x 5 matrix of the lateral predictor's plant model (PlantModel<5, 2, 2>), a row of five an iteration (the index steps 20 bytes up to 100)",
    },
    // The command frame's encode.
    LoopBound {
        function: "ibvs_core::wire::encode_downlink",
        ordinal: 0,
        source: &["wire::write_payload", "crc32c::crc32c"],
        instructions: 59,
        iterations: 15,
        reason: "the CRC-32C of the command frame's header and body, a word a step, 4 words an iteration (unrolled): a step frame's payload is at most IN_PLACE_PAYLOAD_LEN = 254 bytes (the code checks it), its CRC covers at most 250, 15 whole iterations; the 0..3 words and 0..3 bytes left are straight-line code",
    },
    LoopBound {
        function: "ibvs_core::wire::encode_downlink",
        ordinal: 1,
        source: &["wire::cobs_in_place"],
        instructions: 45,
        iterations: 64,
        reason: "COBS in place over the payload from its end, 4 bytes an iteration (the compiler unrolled it; the 0..3 left are straight-line code): at most IN_PLACE_PAYLOAD_LEN = 254 bytes",
    },
];

/// Control-period interrupts: one per 20 ms at 168 MHz.
const SYSTICK_PERIOD_CYCLES: u64 = cycles::CORE_HZ / 50;
/// APB2 (USART1's bus clock) on the `f405` board.
const PCLK2_HZ: u64 = 84_000_000;
/// The link's nominal baud rate (the `f405` board's `BAUD_BPS`).
const BAUD_BPS: u64 = 921_600;
/// APB1 (USART2's bus clock) on the `f405` board.
const PCLK1_HZ: u64 = 42_000_000;
/// Core cycles between two received bytes at the fastest: 10 bits (8N1) at the baud rate the
/// divider gives (BRR = round(PCLK2 / baud) = 91: 923,077 baud), in core cycles.
pub fn byte_period_cycles() -> u64 {
    let brr = (PCLK2_HZ + BAUD_BPS / 2) / BAUD_BPS;
    10 * brr * (cycles::CORE_HZ / PCLK2_HZ)
}
/// The autopilot link's baud rate (the `f405` board's `AUTOPILOT_BAUD_BPS`).
const AUTOPILOT_BAUD_BPS: u64 = 460_800;
/// The same for the autopilot's link on USART2 (BRR = round(PCLK1 / baud) = 91: 461,538
/// baud): 3,640 core cycles.
pub fn autopilot_byte_period_cycles() -> u64 {
    let brr = (PCLK1_HZ + AUTOPILOT_BAUD_BPS / 2) / AUTOPILOT_BAUD_BPS;
    10 * brr * (cycles::CORE_HZ / PCLK1_HZ)
}
/// Exception entry (stacking eight words, the vector fetch overlapped): 12 cycles (TRM's
/// interrupt latency); exit (unstacking) taken as the same.
const EXCEPTION_ENTRY: u64 = 12;
const EXCEPTION_EXIT: u64 = 12;
/// Lazy FP stacking (S0..S15, FPSCR) when a handler uses the FPU: 1 + 17.
const FP_LAZY_STACKING: u64 = 18;

/// Which schedule a bound is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Schedule {
    /// One step per measurement frame, answered at once (`on_bytes`).
    Lockstep,
    /// One step per control period on the latest frame (`on_bytes` + `on_periods`).
    FreeRunning,
}

/// One path's figures.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct Figures {
    /// Instructions on the longest path.
    pub instructions: u64,
    /// Cycles, every flash access a miss (the bound).
    pub cycles: u64,
    /// Cycles at zero wait states (every access hits the ART): not a bound at 168 MHz.
    pub cycles_zero_wait: u64,
    /// The dearest iteration of an exclusive-access retry loop on the path, cycles (every
    /// miss; at zero wait states): what one interrupt can add by making its store fail.
    pub retry: u64,
    pub retry_zero_wait: u64,
}

impl Figures {
    fn plus(self, o: Self) -> Self {
        Self {
            instructions: self.instructions + o.instructions,
            cycles: self.cycles + o.cycles,
            cycles_zero_wait: self.cycles_zero_wait + o.cycles_zero_wait,
            retry: self.retry.max(o.retry),
            retry_zero_wait: self.retry_zero_wait.max(o.retry_zero_wait),
        }
    }
}

/// An interrupt's cost per occurrence and how often it can come.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Interrupt {
    /// Cycles per occurrence (entry, handler, exit; flash misses), the bound.
    pub cycles: u64,
    /// The same at zero wait states.
    pub cycles_zero_wait: u64,
    /// Its sources each come at most once per this many cycles.
    pub period_cycles: u64,
    /// Its independent sources (each may come once a period, at any phase of the other's).
    pub per_period: u64,
    /// Occurrences within the task's bound (response-time iteration).
    pub count: u64,
}

/// A board's static figures.
#[derive(Debug, Clone, Serialize)]
pub struct BoardBounds {
    /// The schedule the task bound is for.
    pub schedule: Schedule,
    /// `Controller::step`.
    pub step: Figures,
    /// The control task without interrupts.
    pub task: Figures,
    /// The control task with the interrupts that can land on it: cycles (bound) and at zero
    /// wait states.
    pub task_with_interrupts: Figures,
    /// USART1 (received bytes at the link's rate).
    pub usart1: Interrupt,
    /// USART2 (the autopilot's MAVLink bytes at its link's rate).
    pub usart2: Interrupt,
    /// SysTick (the control period).
    pub systick: Interrupt,
    /// The task's parts on their own (each its own longest path: they add up to more than
    /// the task's).
    pub components: Vec<Component>,
    /// The code the task and its interrupts can run, bytes: what running it from SRAM would
    /// take (its constants aside).
    pub code_bytes: u64,
    /// The analyses behind the task's figures (cycles, every access a miss).
    pub parts: Vec<Bound>,
}

/// One part of the control task, bounded on its own.
#[derive(Debug, Clone, Serialize)]
pub struct Component {
    /// The function.
    pub function: &'static str,
    /// What it is.
    pub what: &'static str,
    /// Its figures.
    pub figures: Figures,
}

/// Cycles to microseconds at the core clock, to 0.1 us (rounded up).
pub fn micros(cycles: u64) -> f64 {
    let tenths = (cycles * 10).div_ceil(cycles::CORE_HZ / 1_000_000);
    tenths as f64 / 10.0
}

/// The assumptions behind the cycle figures, for the JSON and the docs.
pub fn assumptions(schedule: Schedule) -> serde_json::Value {
    let task = match schedule {
        Schedule::Lockstep => {
            "lockstep: App::on_bytes of the measurement frame, whole once its last byte is queued (decode: COBS, CRC-32C, postcard; accept; Controller::step; Controller::follow_schedule; encode_downlink: postcard, CRC-32C, COBS), until the command frame is in the buffer handed to the UART (its polled transmission not counted)"
        }
        Schedule::FreeRunning => {
            "free-running: App::on_bytes of the measurement frame, whole once its last byte is queued (decode, accept, which keeps the frame: the step, follow-up and encode it calls in lockstep only are left out) plus App::on_periods of the next period (Controller::step, Controller::follow_schedule, encode_downlink), until the command frame is in the buffer handed to the UART (its polled transmission not counted)"
        }
    };
    serde_json::json!({
        "clock": "168 MHz core clock, 5 flash wait states (STM32F405 reference manual, 2.7..3.6 V)",
        "instruction_timings": "Cortex-M4 TRM instruction timings and its FPU's, the upper end of every range (P = 3, UDIV/SDIV 12, MRS/MSR/CPS 2, VMOV with a core register 2, MLA 2), IT folding and load/store pipelining not credited; an FPU result one cycle later for a dependent next instruction (docs/benchmarks.md, the table)",
        "memory": format!(
            "every flash access misses the ART accelerator and costs 5 wait states, serialised: each 128-bit line of code the path enters (sequentially or by a branch), each conditional branch's speculative target fetch, each load from flash (a literal, a constant table) or from an address the analysis cannot place; safe whatever the ART's caches and prefetch hold. Each load's and store's address is tracked through its function (constants built by movw/movt, immediates added, register copies, masked indices, the stack pointer; a call forgets every register): SRAM1/SRAM2, the stack and the CCM RAM cost no wait state (RM0090: the SRAM at CPU speed with 0 wait states, over the bus matrix's S-bus; no other bus master runs, no DMA); an APB2 register {} core cycles a transfer and an APB1 one {} (3 bus cycles at 84 and 42 MHz: the AMBA APB protocol's setup and access, and one to meet the bus clock's edge; RM0090 gives the bridges no latency in cycles), another peripheral as APB1; a store the analysis cannot place costs no wait state (the firmware writes peripherals only through constant register addresses, which it places); a DSB/DMB waits {} more cycles for a pending write (to SRAM: a peripheral store is charged its whole latency where it is made). The *_zero_wait figures assume every flash access hits (no wait states; the peripherals' latency stays): the instruction timings alone, not a bound at 168 MHz",
            cycles::APB2_ACCESS,
            cycles::APB1_ACCESS,
            cycles::BARRIER_DRAIN
        ),
        "task": task,
        "left_out": "the configuration frames' path (App::configure, config_from_bytes, encode_config_report: another frame kind); the PBVS law (the firmware flies IBVS); libm's argument reduction rem_pio2f (sinf/cosf reach it only beyond 9 pi / 4 rad; the follow-up's are of trim pitches within 0.8 rad); panics (they end the task: safe frame, reset)",
        "loops": "every loop has a declared bound with its reason (the passes back to its header per entry), checked against the loop's source and size (target-bench's task.rs, LOOPS and SIZED_LOOPS; listed by --loops); a loop costs its bound x its dearest pass around plus its dearest last pass out of it (for a loop tested at its top, the test); memcpy and memset are costed for the byte count their call passes (traced back to constants), their loops bounded by the bytes each iteration moves",
        "interrupts": format!(
            "USART1 from two independent sources, a received byte and the transmit register emptying, each at most once per {} cycles (10 bits a byte at 923,077 baud: BRR 91 at 84 MHz for 921,600), so up to 2 x ceil(R / {}) runs in a window R; its transmit loop sends at most 2 bytes a run (the second write leaves the data register full for a byte time, longer than the handler's bound, which the analysis checks); USART2 (the autopilot's MAVLink, the same driver) likewise once per {} cycles each way (461,538 baud: BRR 91 at 42 MHz for 460,800); SysTick once per {} cycles (20 ms); all at the same priority (none preempts another); each costs its handler's bound, entry {EXCEPTION_ENTRY} and exit {EXCEPTION_EXIT} cycles, two flash accesses (vector, return) and one more pass of the task's dearest LDREX/STREX retry loop (the exclusive store it can make fail); counted by response-time iteration over the task's own bound, the link assumed saturated",
            byte_period_cycles(),
            byte_period_cycles(),
            autopilot_byte_period_cycles(),
            SYSTICK_PERIOD_CYCLES
        ),
    })
}

/// The rules of an analysis of the control task; `extra_exclude`: more callees left out.
fn rules<'a>(exclude: &'a [&'a str], discover: bool) -> Rules<'a> {
    Rules {
        exclude,
        diverging: &DIVERGING,
        loops: LOOPS,
        sized: &SIZED,
        sized_loops: SIZED_LOOPS,
        sized_callees: SIZED_CALLEES,
        discover,
    }
}

/// One function's figures under `rules`; its cycle analysis (all misses) for the detail.
fn figures(d: &Disassembly, root: &str, r: Rules<'_>) -> Result<(Figures, Bound), String> {
    let instructions = d.bound(root, r, Metric::Instructions)?.longest_path;
    let miss = d.bound(root, r, Metric::Cycles(Model::ALL_MISS))?;
    let hit = d.bound(root, r, Metric::Cycles(Model::ALL_HIT))?;
    let retry = |b: &Bound| {
        b.loops
            .iter()
            .filter(|l| l.exclusive)
            .map(|l| l.iteration)
            .max()
            .unwrap_or(0)
    };
    Ok((
        Figures {
            instructions,
            cycles: miss.longest_path,
            cycles_zero_wait: hit.longest_path,
            retry: retry(&miss),
            retry_zero_wait: retry(&hit),
        },
        miss,
    ))
}

/// An interrupt handler's cost per occurrence: entry, handler, exit, the vector fetch and the
/// return's refetch (one flash access each), lazy FP stacking if it uses the FPU, and one
/// more iteration of the task's dearest exclusive-access retry loop (`task`: the store it
/// may make fail).
fn interrupt(
    d: &Disassembly,
    handler: &str,
    period_cycles: u64,
    per_period: u64,
    task: &Figures,
) -> Result<(Interrupt, Bound), String> {
    let (f, b) = figures(d, handler, rules(&[], false))?;
    let fp = if b.uses_fpu { FP_LAZY_STACKING } else { 0 };
    let overhead = EXCEPTION_ENTRY + EXCEPTION_EXIT + fp;
    Ok((
        Interrupt {
            cycles: f.cycles + overhead + 2 * cycles::WAIT_STATES + task.retry,
            cycles_zero_wait: f.cycles_zero_wait + overhead + task.retry_zero_wait,
            period_cycles,
            per_period,
            count: 0,
        },
        b,
    ))
}

/// The task's bound with interrupts: the smallest `r` with `r = task + sum(sources x
/// ceil(r / period) x cost)` over the interrupts `(cost, period, sources)` (response-time
/// analysis); `None` if it does not converge below a second.
fn response(task: u64, interrupts: &[(u64, u64, u64)]) -> Option<(u64, Vec<u64>)> {
    let mut r = task;
    loop {
        let counts: Vec<u64> = interrupts
            .iter()
            .map(|&(_, period, sources)| sources * r.div_ceil(period))
            .collect();
        let next = task
            + interrupts
                .iter()
                .zip(&counts)
                .map(|(&(cost, _, _), &n)| n * cost)
                .sum::<u64>();
        if next == r {
            return Some((r, counts));
        }
        if next > cycles::CORE_HZ {
            return None;
        }
        r = next;
    }
}

/// The static figures of a board's ELF for `schedule`.
pub fn analyse(d: &Disassembly, schedule: Schedule) -> Result<BoardBounds, String> {
    let step_rules = [PBVS];
    let (step, _) = figures(d, STEP, rules(&step_rules, false))?;
    let lockstep_exclude: Vec<&str> = [PBVS]
        .into_iter()
        .chain(OTHER_FRAMES)
        .chain(LONG_FRAMES)
        .chain(UNREACHED)
        .chain(AUTOPILOT_LINK)
        .collect();
    let mut parts = Vec::new();
    let task = match schedule {
        Schedule::Lockstep => {
            let (f, b) = figures(d, ON_BYTES, rules(&lockstep_exclude, false))?;
            parts.push(b);
            f
        }
        Schedule::FreeRunning => {
            let byte_exclude: Vec<&str> = lockstep_exclude
                .iter()
                .copied()
                .chain(LOCKSTEP_ONLY)
                .collect();
            let (a, ba) = figures(d, ON_BYTES, rules(&byte_exclude, false))?;
            let (b, bb) = figures(d, ON_PERIODS, rules(&lockstep_exclude, false))?;
            parts.extend([ba, bb]);
            a.plus(b)
        }
    };
    // USART1 runs for a received byte and for the transmit register emptying, each at most
    // once a byte time, independently: two sources of one byte time each (in a window of R
    // cycles up to 2 x ceil(R / byte time) runs; one source of half the period would count
    // one run too few in a window shorter than half a byte time).
    let (mut usart1, bu) = interrupt(d, USART1, byte_period_cycles(), 2, &task)?;
    let (mut usart2, bu2) = interrupt(d, USART2, autopilot_byte_period_cycles(), 2, &task)?;
    let (mut systick, bs) = interrupt(d, SYSTICK, SYSTICK_PERIOD_CYCLES, 1, &task)?;
    // The transmit loop's declared bound (2 bytes a run) holds only while a run is shorter
    // than the byte time the second byte keeps the data register full.
    if usart1.cycles >= byte_period_cycles() {
        return Err(format!(
            "the USART1 handler's bound ({} cycles) is not under a byte time ({} cycles): its transmit loop's bound of 2 bytes a run (task.rs, LOOPS) assumes it is",
            usart1.cycles,
            byte_period_cycles()
        ));
    }
    if usart2.cycles >= autopilot_byte_period_cycles() {
        return Err(format!(
            "the USART2 handler's bound ({} cycles) is not under a byte time ({} cycles): its transmit loop's bound of 2 bytes a run (task.rs, LOOPS) assumes it is",
            usart2.cycles,
            autopilot_byte_period_cycles()
        ));
    }
    parts.extend([bu, bu2, bs]);
    let sources = |f: fn(&Interrupt) -> u64| {
        [usart1, usart2, systick].map(|i| (f(&i), i.period_cycles, i.per_period))
    };
    let (cycles, counts) = response(task.cycles, &sources(|i| i.cycles))
        .ok_or("the interrupts' load does not leave the task a bound under a second")?;
    let (zero_wait, _) = response(task.cycles_zero_wait, &sources(|i| i.cycles_zero_wait))
        .ok_or("the interrupts' load does not leave the task a bound under a second")?;
    usart1.count = counts[0];
    usart2.count = counts[1];
    systick.count = counts[2];
    let byte_exclude: Vec<&str> = lockstep_exclude
        .iter()
        .copied()
        .chain(LOCKSTEP_ONLY)
        .collect();
    let mut components = Vec::new();
    for (function, what, exclude) in [
        (
            ON_BYTES,
            "the frame whole, once its end is queued, without the step, follow-up and encode (lockstep calls them from here): feed_slice (COBS, CRC-32C, header), postcard, accept",
            &byte_exclude,
        ),
        (
            "firmware::app::control_step",
            "the step with the board's measurement around it (the qemu board's stack probe)",
            &lockstep_exclude,
        ),
        (STEP, "Controller::step", &lockstep_exclude),
        (
            "ibvs_core::controller::Controller::follow_schedule",
            "the gain schedule's follow-up (a new design interpolated and loaded)",
            &lockstep_exclude,
        ),
        (
            "ibvs_core::wire::encode_downlink",
            "the command frame's encode: postcard, CRC-32C, COBS",
            &lockstep_exclude,
        ),
    ] {
        let (figures, _) = figures(d, function, rules(exclude, false))?;
        components.push(Component {
            function,
            what,
            figures,
        });
    }
    Ok(BoardBounds {
        schedule,
        step,
        task,
        task_with_interrupts: Figures {
            cycles,
            cycles_zero_wait: zero_wait,
            ..task
        },
        usart1,
        usart2,
        systick,
        components,
        code_bytes: d.code_bytes(
            &parts
                .iter()
                .flat_map(|b| b.functions.iter().copied())
                .collect(),
        ),
        parts,
    })
}

/// Every loop of the control task's code, declared or not (`--loops`): for keeping
/// [`LOOPS`] up to date.
pub fn list_loops(d: &Disassembly) -> Result<Vec<crate::wcet::LoopUse>, String> {
    let exclude: Vec<&str> = [PBVS]
        .into_iter()
        .chain(OTHER_FRAMES)
        .chain(LONG_FRAMES)
        .chain(UNREACHED)
        .chain(AUTOPILOT_LINK)
        .collect();
    let mut out = Vec::new();
    for root in [STEP, ON_BYTES, ON_PERIODS, USART1, USART2, SYSTICK] {
        let b = d.bound(root, rules(&exclude, true), Metric::Instructions)?;
        out.extend(b.loops);
    }
    out.sort_by(|x, y| (&x.function, x.ordinal).cmp(&(&y.function, y.ordinal)));
    out.dedup();
    Ok(out)
}

/// The declarations of [`LOOPS`] no analysed loop used (`used`: the loops the bounds went
/// through, on every board): stale entries, to remove or re-key.
pub fn unused_loop_bounds(used: &[crate::wcet::LoopUse]) -> Vec<String> {
    LOOPS
        .iter()
        .filter(|b| {
            !used
                .iter()
                .any(|u| u.function == b.function && u.ordinal == b.ordinal)
        })
        .map(|b| format!("loop {} of {} ({})", b.ordinal, b.function, b.reason))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_schedule_never_reaches_libm_argument_reduction() {
        // sinf/cosf call rem_pio2f only beyond 9 pi / 4 (0x40e231d5); every trim pitch of the
        // schedule is far inside (and the follow-up interpolates between nodes).
        let limit = f32::from_bits(0x40e2_31d5);
        for row in &ibvs_core::gains::SCHEDULE {
            for d in row {
                assert!(d.trim.theta_rad.abs() < limit, "{}", d.trim.theta_rad);
            }
        }
    }

    #[test]
    fn every_loop_bound_names_its_source_and_reason() {
        for b in LOOPS {
            assert!(
                !b.source.is_empty() && b.iterations > 0 && !b.reason.is_empty(),
                "{b:?}"
            );
        }
        // One declaration per loop.
        for (i, a) in LOOPS.iter().enumerate() {
            assert!(
                LOOPS[i + 1..]
                    .iter()
                    .all(|b| (b.function, b.ordinal) != (a.function, a.ordinal)),
                "{a:?}"
            );
        }
    }

    #[test]
    fn a_byte_arrives_at_most_every_1820_cycles() {
        // 84 MHz / 91 = 923,077 baud; 10 bits; 168 MHz core: 10 x 91 x 2.
        assert_eq!(byte_period_cycles(), 1820);
    }

    #[test]
    fn microseconds_round_up_to_a_tenth() {
        assert_eq!(micros(168), 1.0);
        assert_eq!(micros(169), 1.1);
        assert_eq!(micros(3_360_000), 20_000.0);
    }

    #[test]
    fn response_time_counts_the_interrupts_that_land_on_the_task() {
        // 1000 cycles of task, an interrupt of 100 every 500: 1000 -> 1200 (2) -> 1300 (3)
        // -> 1300.
        assert_eq!(response(1000, &[(100, 500, 1)]), Some((1300, vec![3])));
        // An interrupt that takes its whole period leaves nothing: no bound.
        assert_eq!(response(1000, &[(500, 500, 1)]), None);
        // Two independent sources of one period: a short task can meet both, where one
        // source of half the period would count one.
        assert_eq!(response(10, &[(5, 1000, 2)]), Some((20, vec![2])));
        assert_eq!(response(10, &[(5, 500, 1)]), Some((15, vec![1])));
    }
}
