//! The Cortex-M4F cycle model of the static bound: what one instruction costs, in core clock
//! cycles, on the STM32F405 at 168 MHz with its flash's wait states.
//!
//! Place in the data flow: [`crate::wcet`] asks [`cost`] for every instruction of the
//! machine code it walks and adds the costs along the longest path; the per-edge costs (branch
//! refill, flash line fetches, the FPU's result latency) come from [`Model`], and each load's
//! and store's memory cost from [`data_cycles`] for the region `memory.rs` places it in.
//!
//! Sources (the numbers are in the table below, each with its row):
//! - ARM Cortex-M4 Technical Reference Manual (r0p1), "Processor instruction timings" (the
//!   integer instruction set summary, cycles at zero wait states): P is the pipeline refill
//!   of a taken branch, 1 to 3 cycles, taken as 3; N the registers moved by a load or store
//!   multiple; B a barrier's own time.
//! - The same manual's FPU chapter ("FPU instruction set" table): issue cycles of the FPU's
//!   instructions. A data-processing FPU instruction's result reaches the next instruction one
//!   cycle after its issue cycles (VADD 2, VMLA 4, VDIV 15 as result latencies, as compilers'
//!   Cortex-M4 pipeline descriptions give them): the model charges that cycle when the
//!   instruction that follows names the result's register ([`fp_stall`]).
//! - STM32F405 reference manual (RM0090), "Relation between CPU clock frequency and flash
//!   memory read time": 5 wait states at 168 MHz and 2.7..3.6 V ([`WAIT_STATES`]); a flash
//!   read delivers 128 bits.
//! - RM0090, "Memory and bus architecture": the core's S-bus reaches SRAM1, SRAM2 and the
//!   peripherals through the bus matrix, its D-bus the flash's data and literals and the CCM
//!   RAM; the embedded SRAM is read and written at CPU speed with 0 wait states; APB1 and APB2
//!   hang off AHB1 through AHB/APB bridges, clocked on the `f405` board at 42 and 84 MHz (the
//!   core at 168). The manual gives no bridge latency in cycles: an APB transfer takes at
//!   least two bus clock cycles (the AMBA APB protocol's setup and access phases), and the
//!   model adds one more for the bridge to meet the slower clock's edge: 3 bus cycles,
//!   [`APB2_ACCESS`] = 6 and [`APB1_ACCESS`] = 12 core cycles a transfer, on top of the load's
//!   or store's own cycles. No other bus master runs (the firmware uses no DMA), so the bus
//!   matrix never makes the core wait for another master.
//!
//! Invariants: every mnemonic has a cost or is an error naming it ([`cost`]: never silently
//! 1); conditional suffixes, the `s` flag suffix and the `.n`/`.w` width never change a cost;
//! every choice within a range the manual gives is its upper end; a data access the analysis
//! cannot place is charged the default ([`data_cycles`]: a load as a flash read that misses).

/// Flash wait states of the STM32F405 at 168 MHz (RM0090: 5 WS for 150 < HCLK <= 168 MHz at
/// 2.7..3.6 V): a flash read that misses the ART accelerator takes 1 + 5 cycles.
pub const WAIT_STATES: u64 = 5;
/// The core clock the firmware runs at on the `f405` board, Hz.
pub const CORE_HZ: u64 = 168_000_000;
/// P, the pipeline refill after a taken branch: 1..3 cycles (TRM), taken as 3.
pub const REFILL: u64 = 3;
/// Bytes of one flash line (a flash read and an ART cache line: 128 bits).
pub const FLASH_LINE: u64 = 16;
/// A transfer to an APB2 peripheral (84 MHz, half the core clock): 3 bus cycles (two of the
/// APB protocol, one to meet the bus clock's edge), in core cycles.
pub const APB2_ACCESS: u64 = 3 * 2;
/// A transfer to an APB1 peripheral (42 MHz, a quarter of the core clock): 3 bus cycles, in
/// core cycles. Also charged for the other peripherals (AHB1, AHB2, the core's private
/// peripheral bus), which the model does not time apart.
pub const APB1_ACCESS: u64 = 3 * 4;
/// B of `dsb`/`dmb`: the outstanding write to complete. A store to a peripheral is charged
/// its bus's whole latency where it is made ([`data_cycles`]), as if the core waited for it
/// there, so what a barrier can still wait for is a write to SRAM (or to an address the
/// analysis cannot place, taken as SRAM): an AHB write of zero wait states through the bus
/// matrix, its address and data phases, 2 cycles.
pub const BARRIER_DRAIN: u64 = 2;

/// What the model assumes of the memory system.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Model {
    /// Cycles added to every flash access the model charges (a line of code entered, a
    /// conditional branch's speculative fetch, a data load that may read flash): the wait
    /// states when every access misses the ART accelerator, 0 when every access hits it.
    pub flash_wait: u64,
}

impl Model {
    /// Every flash access misses the ART (safe whatever the caches hold).
    pub const ALL_MISS: Self = Self {
        flash_wait: WAIT_STATES,
    };
    /// Every flash access hits the ART (zero wait states: not a bound at 168 MHz, the
    /// instruction timings alone).
    pub const ALL_HIT: Self = Self { flash_wait: 0 };
}

use crate::memory::Region;

/// The cost of one instruction, before the edges (refill, fetch) it leaves by and the memory
/// its data access reaches ([`data_cycles`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Cost {
    /// Cycles at zero wait states when it does not branch (a taken branch adds
    /// [`Cost::taken`]).
    pub cycles: u64,
    /// Cycles added when it branches (the refill P; 0 for instructions that never branch or
    /// whose `cycles` already include it: calls, returns, table branches).
    pub taken: u64,
    /// Its data access (a load, a store, a table branch's read), if any.
    pub access: Option<Access>,
    /// The FPU register a data-processing FPU instruction writes (for [`fp_stall`]).
    pub fp_result: Option<String>,
}

/// A data access: what its memory costs depends on where it goes ([`data_cycles`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Access {
    /// A store (else a load).
    pub store: bool,
    /// Bytes moved.
    pub bytes: u64,
    /// Bus transfers (32-bit words; one for a byte or a halfword).
    pub transfers: u64,
}

/// Cycles a data access adds to its instruction's for the memory `region` it reaches:
/// nothing for the stack, SRAM and the CCM RAM (0 wait states); a peripheral its bus's
/// latency per transfer ([`APB2_ACCESS`], [`APB1_ACCESS`]), a load or a store; a load from
/// flash the wait states of every line it may touch; a load the analysis cannot place the same
/// as from flash (the dearest memory a load through a pointer reaches in this firmware: it
/// reaches peripherals only through their constant register addresses, which `memory.rs`
/// places); a store it cannot place nothing, as a store to SRAM (the only memory the
/// firmware writes through pointers). A store to flash is an error ([`DataError`]):
/// programming has no bounded time.
pub fn data_cycles(model: Model, access: &Access, region: Region) -> Result<u64, DataError> {
    Ok(match (region, access.store) {
        (Region::Stack | Region::Sram | Region::Ccm, _) => 0,
        (Region::Apb2, _) => access.transfers * APB2_ACCESS,
        (Region::Apb1 | Region::Peripheral, _) => access.transfers * APB1_ACCESS,
        (Region::Flash, true) => return Err(DataError::FlashStore),
        (Region::Unknown, true) => 0,
        (Region::Flash | Region::Unknown, false) => lines_touched(access.bytes) * model.flash_wait,
    })
}

/// A data access the model cannot time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DataError {
    /// A store to a flash address: programming, whose time is the flash's.
    FlashStore,
}

impl std::fmt::Display for DataError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::FlashStore => write!(f, "a store to flash (programming) has no bounded time"),
        }
    }
}

/// Why a mnemonic has no bound.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CostError {
    /// Not in the table: the model must be extended (with its source) before it is used.
    Unknown(String),
    /// In the table, but its time is not bounded by the core (sleep, debug, supervisor call).
    Unbounded(String, &'static str),
}

impl std::fmt::Display for CostError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Unknown(m) => write!(
                f,
                "mnemonic `{m}` is not in the Cortex-M4 cycle table (cycles.rs): add it with its source"
            ),
            Self::Unbounded(m, why) => write!(f, "`{m}` has no bounded time: {why}"),
        }
    }
}

const CONDITIONS: [&str; 16] = [
    "eq", "ne", "cs", "hs", "cc", "lo", "mi", "pl", "vs", "vc", "hi", "ls", "ge", "lt", "gt", "le",
];

/// How an instruction's cycles are counted (Cortex-M4 TRM unless said otherwise).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// A fixed number of cycles; `flags`: takes the `s` suffix.
    Fixed { cycles: u64, flags: bool },
    /// A single load of `bytes` (2 cycles; `ldrd` 1 + N = 3).
    Load { cycles: u64, bytes: u64 },
    /// A single store (2 cycles; `strd` 3).
    Store { cycles: u64 },
    /// Load multiple (`ldm`, `pop`; FPU `vldm`, `vpop`): 1 + N, + P with the PC.
    LoadMultiple,
    /// Store multiple (`stm`, `push`; FPU `vstm`, `vpush`): 1 + N.
    StoreMultiple,
    /// A branch that may fall through (`b<c>`, `cbz`): 1, taken 1 + P.
    Branch,
    /// A branch that always leaves (`bl`, `bx`, `blx`): 1 + P.
    AlwaysBranch,
    /// `tbb`/`tbh`: 2 + P, and the table read (in the code, so in flash).
    TableBranch,
    /// An `it` block's head: 1 (its folding onto the instruction before is not credited).
    It,
    /// VMOV: 1 between FPU registers or for an immediate; 2 with a core register (the
    /// manual's 1..2, taken as 2 for any transfer).
    Vmov,
    /// An FPU data-processing instruction of `cycles` issue cycles that writes its first
    /// operand (its result is one cycle later for a dependent instruction).
    FpArith { cycles: u64 },
    /// No bounded time.
    Unbounded(&'static str),
}

/// The cycle table. Rows: the TRM's "Processor instruction timings" (integer) and its FPU
/// instruction table; the choices within ranges are the upper ends.
fn kind(base: &str) -> Option<Kind> {
    use Kind::*;
    let alu = Fixed {
        cycles: 1,
        flags: true,
    };
    let one = Fixed {
        cycles: 1,
        flags: false,
    };
    Some(match base {
        // Move, add, subtract, logical, shift, multiply (MUL 1): 1 cycle; `neg` is `rsb`.
        "mov" | "mvn" | "add" | "adc" | "sub" | "sbc" | "rsb" | "neg" | "and" | "orr" | "eor"
        | "bic" | "orn" | "lsl" | "lsr" | "asr" | "ror" | "rrx" | "mul" => alu,
        // 16-bit immediates, wide add/sub, address, compare and test: 1 cycle.
        "movw" | "movt" | "addw" | "subw" | "adr" | "cmp" | "cmn" | "tst" | "teq" => one,
        // Extend, bit field, reverse, count leading zeros, saturate: 1 cycle.
        "uxtb" | "uxth" | "sxtb" | "sxth" | "uxtb16" | "sxtb16" | "uxtab" | "uxtah" | "sxtab"
        | "sxtah" | "bfi" | "bfc" | "ubfx" | "sbfx" | "rev" | "rev16" | "revsh" | "rbit"
        | "clz" | "ssat" | "usat" => one,
        // DSP extension (SIMD add/subtract, saturating arithmetic, halfword multiplies): 1.
        "uqadd8" | "uqadd16" | "uqsub8" | "uqsub16" | "qadd" | "qsub" | "qadd8" | "qadd16"
        | "qsub8" | "qsub16" | "sadd8" | "sadd16" | "uadd8" | "uadd16" | "ssub8" | "usub8"
        | "sel" | "smulbb" | "smulbt" | "smultb" | "smultt" | "smlabb" | "smlabt" | "smlatb"
        | "smlatt" | "smulwb" | "smulwt" | "smlawb" | "smlawt" | "smmul" | "smmla" | "usad8"
        | "usada8" => one,
        // Multiply-accumulate and -subtract: 2 (the r0p0 manual's figure; r0p1 gives 1).
        "mla" | "mls" => Fixed {
            cycles: 2,
            flags: false,
        },
        // Long multiplies on the Cortex-M4: 1 cycle.
        "umull" | "smull" | "umlal" | "smlal" | "umaal" => one,
        // Divide: 2..12 cycles, taken as 12.
        "udiv" | "sdiv" => Fixed {
            cycles: 12,
            flags: false,
        },
        // Loads: 2 cycles (pipelining of neighbouring loads and stores not credited);
        // exclusive loads 2.
        "ldr" | "ldrt" | "ldrex" => Load {
            cycles: 2,
            bytes: 4,
        },
        "ldrh" | "ldrsh" | "ldrht" | "ldrsht" | "ldrexh" => Load {
            cycles: 2,
            bytes: 2,
        },
        "ldrb" | "ldrsb" | "ldrbt" | "ldrsbt" | "ldrexb" => Load {
            cycles: 2,
            bytes: 1,
        },
        // Load doubleword: 1 + N, N = 2.
        "ldrd" => Load {
            cycles: 3,
            bytes: 8,
        },
        // Stores: 2 cycles; store doubleword 1 + N = 3; exclusive stores 2.
        "str" | "strb" | "strh" | "strt" | "strbt" | "strht" | "strex" | "strexb" | "strexh" => {
            Store { cycles: 2 }
        }
        "strd" => Store { cycles: 3 },
        // Load and store multiple, push and pop: 1 + N (+ P when the PC is loaded).
        "ldm" | "ldmia" | "ldmfd" | "ldmdb" | "ldmea" | "pop" => LoadMultiple,
        "stm" | "stmia" | "stmea" | "stmdb" | "stmfd" | "push" => StoreMultiple,
        // Branches: conditional 1 or 1 + P; compare and branch 1 or 1 + P.
        "b" | "cbz" | "cbnz" => Branch,
        // Branch with link, branch and exchange (both forms): 1 + P.
        "bl" | "bx" | "blx" => AlwaysBranch,
        // Table branch: 2 + P.
        "tbb" | "tbh" => TableBranch,
        // If-then: 1 (folding not credited).
        "it" | "itt" | "ite" | "ittt" | "itte" | "itet" | "itee" | "itttt" | "ittte" | "ittet"
        | "ittee" | "itett" | "itete" | "iteet" | "iteee" => It,
        // Status register moves and interrupt masking: 1 or 2, taken as 2.
        "mrs" | "msr" | "cpsid" | "cpsie" => Fixed {
            cycles: 2,
            flags: false,
        },
        // ISB: 1 + B, B a pipeline refill (P = 3).
        "isb" => Fixed {
            cycles: 1 + REFILL,
            flags: false,
        },
        // DSB, DMB: 1 + B, B the outstanding write's completion ([`BARRIER_DRAIN`]).
        "dsb" | "dmb" => Fixed {
            cycles: 1 + BARRIER_DRAIN,
            flags: false,
        },
        "nop" | "yield" | "sev" | "clrex" => one,
        "wfi" | "wfe" => Unbounded("it waits for an event or interrupt"),
        "bkpt" => Unbounded("a breakpoint (semihosting): the debugger's or host's time"),
        "svc" => Unbounded("a supervisor call: its handler is not analysed"),
        "udf" => Unbounded("an undefined instruction: a fault"),
        // FPU (TRM FPU instruction table): add, subtract, multiply, negated multiply 1;
        // multiply-accumulate (chained and fused) 3; divide and square root 14; convert 1.
        "vadd" | "vsub" | "vmul" | "vnmul" | "vcvt" | "vcvtr" => FpArith { cycles: 1 },
        "vmla" | "vmls" | "vnmla" | "vnmls" | "vfma" | "vfms" | "vfnma" | "vfnms" => {
            FpArith { cycles: 3 }
        }
        "vdiv" | "vsqrt" => FpArith { cycles: 14 },
        // Absolute value, negate, compare, status moves: 1.
        "vabs" | "vneg" | "vcmp" | "vcmpe" | "vmrs" | "vmsr" => one,
        "vmov" => Vmov,
        // FPU loads and stores: VLDR, VSTR 2 (a doubleword 1 + N = 3); VLDM, VSTM, VPUSH, VPOP 1 + N.
        "vldr" => Load {
            cycles: 2,
            bytes: 4,
        },
        "vstr" => Store { cycles: 2 },
        "vldm" | "vldmia" | "vldmdb" | "vpop" => LoadMultiple,
        "vstm" | "vstmia" | "vstmdb" | "vpush" => StoreMultiple,
        _ => return None,
    })
}

/// The table row's base of a mnemonic (`movseq` -> `mov`) and whether it is conditional
/// (carries a condition code, as inside an IT block); `None` if it is not in the table.
pub fn base(mnemonic: &str) -> Option<(&str, bool)> {
    let (b, _) = row(mnemonic)?;
    let m = mnemonic.split('.').next().unwrap_or(mnemonic);
    let rest = &m[b.len()..];
    let rest = rest
        .strip_prefix('s')
        .filter(|_| !CONDITIONS.contains(&rest))
        .unwrap_or(rest);
    Some((b, CONDITIONS.contains(&rest)))
}

/// Splits a mnemonic as objdump prints it (`addseq.w`, `vmovhi.f32`, `vcvt.f32.s32`) into
/// its table row: the base, then an optional `s` (rows that take it) and condition; the width
/// and data-type qualifiers after the first dot do not change a cost.
fn row(mnemonic: &str) -> Option<(&str, Kind)> {
    let m = mnemonic.split('.').next().unwrap_or(mnemonic);
    if let Some(k) = kind(m) {
        return Some((m, k));
    }
    fn strip_cond(m: &str) -> Option<&str> {
        CONDITIONS
            .iter()
            .find_map(|c| m.strip_suffix(c).filter(|b| !b.is_empty()))
    }
    let candidates = [
        strip_cond(m).map(|b| (b, false)),
        m.strip_suffix('s').map(|b| (b, true)),
        strip_cond(m)
            .and_then(|b| b.strip_suffix('s'))
            .map(|b| (b, true)),
    ];
    candidates.into_iter().flatten().find_map(|(b, s)| {
        let k = kind(b)?;
        let takes_s = matches!(k, Kind::Fixed { flags: true, .. });
        (!s || takes_s).then_some((b, k))
    })
}

/// The registers of a `{...}` list: 32-bit words (a `d` register is two).
pub fn list_words(operands: &str) -> u64 {
    let list = operands
        .split('{')
        .nth(1)
        .and_then(|r| r.split('}').next())
        .unwrap_or("");
    list.split(',')
        .map(str::trim)
        .filter(|r| !r.is_empty())
        .map(|r| {
            let words = if r.starts_with('d') { 2 } else { 1 };
            let count = match r.split_once('-') {
                Some((a, b)) => {
                    let n = |x: &str| x.get(1..).and_then(|d| d.parse::<u64>().ok()).unwrap_or(0);
                    n(b).saturating_sub(n(a)) + 1
                }
                None => 1,
            };
            words * count
        })
        .sum()
}

/// A load or store of `bytes`: one bus transfer per word, at least one.
fn access(store: bool, bytes: u64) -> Option<Access> {
    Some(Access {
        store,
        bytes,
        transfers: bytes.div_ceil(4).max(1),
    })
}

/// Bytes a single store moves (`strb` 1, `strh` 2, `strd` 8, else 4; a doubleword `vstr`
/// is found by the caller).
fn store_bytes(base: &str) -> u64 {
    if base.starts_with("strb") || base == "strexb" {
        1
    } else if base.starts_with("strh") || base == "strexh" {
        2
    } else if base == "strd" {
        8
    } else {
        4
    }
}

/// Flash lines an aligned read of `bytes` may touch: 1 for a word or less, 1 + ceil((bytes -
/// 4) / 16) for more (a word-aligned run may start in the last word of a line).
fn lines_touched(bytes: u64) -> u64 {
    if bytes <= 4 {
        1
    } else {
        1 + (bytes - 4).div_ceil(FLASH_LINE)
    }
}

/// A `vldr`/`vstr` of a doubleword register.
fn double_fp(base: &str, operands: &str) -> bool {
    matches!(base, "vldr" | "vstr") && operands.trim_start().starts_with('d')
}

/// True when an operand list names the PC.
fn names_pc(operands: &str) -> bool {
    operands
        .split(['{', '}', ',', ' ', '[', ']', '!'])
        .any(|r| r.trim() == "pc")
}

/// The cost of one instruction (edges aside): its cycles, the refill it adds when it
/// branches, its data access. An unknown mnemonic is an error naming it.
pub fn cost(mnemonic: &str, operands: &str) -> Result<Cost, CostError> {
    let (base, k) = row(mnemonic).ok_or_else(|| CostError::Unknown(mnemonic.to_string()))?;
    let plain = |cycles| Cost {
        cycles,
        taken: 0,
        access: None,
        fp_result: None,
    };
    Ok(match k {
        Kind::Fixed { cycles, .. } => plain(cycles),
        Kind::It => plain(1),
        Kind::Load { cycles, bytes } => {
            // A doubleword FPU load (`vldr d0, ...`) moves two words: 1 + N = 3.
            let (cycles, bytes) = if double_fp(base, operands) {
                (3, 8)
            } else {
                (cycles, bytes)
            };
            let mut c = plain(cycles);
            // A load into the PC branches: + P.
            if operands.trim_start().starts_with("pc") {
                c.cycles += REFILL;
            }
            c.access = access(false, bytes);
            c
        }
        Kind::Store { cycles } => {
            let (cycles, bytes) = if double_fp(base, operands) {
                (3, 8)
            } else {
                (cycles, store_bytes(base))
            };
            Cost {
                access: access(true, bytes),
                ..plain(cycles)
            }
        }
        Kind::LoadMultiple => {
            let n = list_words(operands);
            let mut c = plain(1 + n);
            if names_pc(operands.split('{').nth(1).unwrap_or("")) {
                c.cycles += REFILL;
            }
            c.access = access(false, 4 * n);
            c
        }
        Kind::StoreMultiple => {
            let n = list_words(operands);
            Cost {
                access: access(true, 4 * n),
                ..plain(1 + n)
            }
        }
        Kind::Branch => Cost {
            taken: REFILL,
            ..plain(1)
        },
        Kind::AlwaysBranch => plain(1 + REFILL),
        // The table's entry, read from the code: a byte or a halfword of flash.
        Kind::TableBranch => Cost {
            access: access(false, if base == "tbh" { 2 } else { 1 }),
            ..plain(2 + REFILL)
        },
        Kind::Vmov => {
            let core = operands
                .split([',', ' '])
                .map(str::trim)
                .any(|r| r.starts_with('r') || matches!(r, "sp" | "lr" | "ip" | "fp" | "sl"));
            plain(if core { 2 } else { 1 })
        }
        Kind::FpArith { cycles } => Cost {
            fp_result: operands
                .split([',', ' '])
                .find(|t| !t.is_empty())
                .map(str::to_string),
            ..plain(cycles)
        },
        Kind::Unbounded(why) => return Err(CostError::Unbounded(mnemonic.to_string(), why)),
    })
}

/// One cycle when `next` names the register `previous` (an FPU data-processing instruction)
/// writes: the result is one cycle later than the issue cycles (a conservative reading: any
/// mention counts, as a source or as the next result).
pub fn fp_stall(previous: &Cost, next_operands: &str) -> u64 {
    let Some(reg) = &previous.fp_result else {
        return 0;
    };
    let named = next_operands
        .split([',', ' ', '{', '}', '[', ']'])
        .any(|t| t.trim() == reg);
    u64::from(named)
}

/// How control passes from one instruction to the next.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pass {
    /// To the next instruction in memory; `after_conditional`: a conditional branch not taken
    /// (whose target the core fetched speculatively).
    Fall { after_conditional: bool },
    /// A branch (or jump table entry) taken.
    Taken,
    /// Back from a call, to the instruction after it (fetched anew).
    AfterCall,
}

/// The flash lines (first, last) an instruction at `addr` of `size` bytes spans.
pub fn lines_of(addr: u64, size: u64) -> (u64, u64) {
    (addr / FLASH_LINE, (addr + size.max(1) - 1) / FLASH_LINE)
}

/// The fetch of an instruction reached by a branch, a call or a return, or at a function's
/// entry: its lines, each a flash access.
pub fn fetch(model: Model, addr: u64, size: u64) -> u64 {
    let (first, last) = lines_of(addr, size);
    (last - first + 1) * model.flash_wait
}

/// The cycles control adds passing from instruction `from` (at `from_addr`, `from_size`
/// bytes, costing `from_cost`) to `to` (at `to_addr`, `to_size` bytes, with `to_operands`):
/// a taken branch's refill and the target's fetch; on a fall-through, the lines newly
/// entered, a not-taken conditional branch's speculative fetch and an FPU result's latency.
pub fn transition(
    model: Model,
    (from_addr, from_size, from_cost): (u64, u64, &Cost),
    (to_addr, to_size, to_operands): (u64, u64, &str),
    pass: Pass,
) -> u64 {
    let w = model.flash_wait;
    match pass {
        Pass::Taken => from_cost.taken + fetch(model, to_addr, to_size),
        Pass::AfterCall => fetch(model, to_addr, to_size),
        Pass::Fall { after_conditional } => {
            let (_, last_from) = lines_of(from_addr, from_size);
            let (first_to, last_to) = lines_of(to_addr, to_size);
            let new = if last_to > last_from {
                last_to - first_to.max(last_from + 1) + 1
            } else {
                0
            };
            new * w + if after_conditional { w } else { 0 } + fp_stall(from_cost, to_operands)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suffixes_do_not_change_the_row() {
        for (m, base) in [
            ("movs", "mov"),
            ("movseq", "mov"),
            ("addseq.w", "add"),
            ("bls.n", "b"),
            ("bcs", "b"),
            ("bxeq", "bx"),
            ("mls", "mls"),
            ("lsls", "lsl"),
            ("ldrhpl", "ldrh"),
            ("popcc", "pop"),
            ("vmovhi.f32", "vmov"),
            ("vcvt.f32.s32", "vcvt"),
            ("ldrsb.w", "ldrsb"),
            ("smlabb", "smlabb"),
        ] {
            assert_eq!(row(m).map(|r| r.0), Some(base), "{m}");
        }
        // `bl` takes no `s`: `bls` is a branch if lower or same, `bics` a flag-setting BIC.
        assert_eq!(row("bics").map(|r| r.0), Some("bic"));
        assert!(row("cmps").is_none(), "CMP has no `s` form");
    }

    #[test]
    fn costs_follow_the_manual() {
        let c = |m: &str, o: &str| cost(m, o).expect(m);
        assert_eq!(c("adds", "r0, #1").cycles, 1);
        assert_eq!(c("udiv", "r0, r1, r2").cycles, 12);
        assert_eq!(c("mla", "r0, r1, r2, r3").cycles, 2);
        assert_eq!(c("umull", "r0, r1, r2, r3").cycles, 1);
        // Loads and stores: 2 cycles, their access's bytes and bus transfers.
        let l = c("ldr", "r0, [sp, #4]");
        assert_eq!(l.cycles, 2);
        let load = |bytes, transfers| {
            Some(Access {
                store: false,
                bytes,
                transfers,
            })
        };
        assert_eq!(c("ldr.w", "r0, [r1, #4]").access, load(4, 1));
        assert_eq!(c("ldrb", "r0, [r1, #4]").access, load(1, 1));
        assert_eq!(c("ldrd", "r0, r1, [r2]").access, load(8, 2));
        assert_eq!(
            c("strh.w", "r0, [r1]").access,
            Some(Access {
                store: true,
                bytes: 2,
                transfers: 1
            })
        );
        assert_eq!(c("tbh", "[pc, r1, lsl #1]").access, load(2, 1));
        assert_eq!(c("cmp", "r0, #1").access, None);
        // 1 + N, + P when the PC is popped; d registers are two words.
        assert_eq!(c("push", "{r4, r5, r7, lr}").cycles, 5);
        assert_eq!(c("pop", "{r4, r5, r7, pc}").cycles, 5 + REFILL);
        assert_eq!(c("vpush", "{d8-d15}").cycles, 17);
        assert_eq!(c("ldmia.w", "r0, {r1, r2, r3}").access, load(12, 3));
        // Branches.
        let b = c("bne.n", "8000100");
        assert_eq!((b.cycles, b.taken), (1, REFILL));
        assert_eq!(c("bl", "8000100").cycles, 1 + REFILL);
        assert_eq!(c("tbb", "[pc, r1]").cycles, 2 + REFILL);
        // FPU.
        assert_eq!(c("vdiv.f32", "s0, s1, s2").cycles, 14);
        assert_eq!(c("vsqrt.f32", "s0, s1").cycles, 14);
        assert_eq!(c("vfma.f32", "s0, s1, s2").cycles, 3);
        assert_eq!(c("vmov", "r0, s1").cycles, 2);
        assert_eq!(c("vmov.f32", "s0, #1.0").cycles, 1);
        assert_eq!(c("vldr", "s0, [r0, #8]").access, load(4, 1));
        // Doublewords: two words, 1 + N.
        let d = c("vldr", "d0, [pc, #932]");
        assert_eq!((d.cycles, d.access), (3, load(8, 2)));
        assert_eq!(c("vstr", "d8, [sp, #16]").cycles, 3);
    }

    #[test]
    fn each_region_charges_its_memory() {
        let word = |store| Access {
            store,
            bytes: 4,
            transfers: 1,
        };
        let w = WAIT_STATES;
        let d = |a: Access, r| data_cycles(Model::ALL_MISS, &a, r);
        // SRAM, the stack and the CCM RAM: no wait state, loads and stores.
        for r in [Region::Sram, Region::Stack, Region::Ccm] {
            assert_eq!(d(word(false), r), Ok(0), "{r:?}");
            assert_eq!(d(word(true), r), Ok(0), "{r:?}");
        }
        // Peripherals: the bus's latency per transfer, loads and stores alike.
        assert_eq!(d(word(false), Region::Apb2), Ok(6));
        assert_eq!(d(word(true), Region::Apb2), Ok(6));
        assert_eq!(d(word(false), Region::Apb1), Ok(12));
        assert_eq!(d(word(true), Region::Peripheral), Ok(12));
        let double = Access {
            store: false,
            bytes: 8,
            transfers: 2,
        };
        assert_eq!(d(double, Region::Apb2), Ok(12));
        // Flash and the unplaced: a load the lines it may touch (a doubleword may straddle
        // two); an unplaced store nothing; a store to flash no bound.
        assert_eq!(d(word(false), Region::Flash), Ok(w));
        assert_eq!(d(word(false), Region::Unknown), Ok(w));
        assert_eq!(d(double, Region::Unknown), Ok(2 * w));
        assert_eq!(d(word(true), Region::Unknown), Ok(0));
        assert_eq!(d(word(true), Region::Flash), Err(DataError::FlashStore));
        // At zero wait states the flash is free, the peripherals are not.
        assert_eq!(
            data_cycles(Model::ALL_HIT, &word(false), Region::Unknown),
            Ok(0)
        );
        assert_eq!(
            data_cycles(Model::ALL_HIT, &word(false), Region::Apb1),
            Ok(12)
        );
    }

    #[test]
    fn a_dependent_fpu_instruction_waits_one_cycle() {
        let add = cost("vadd.f32", "s0, s1, s2").expect("vadd");
        assert_eq!(fp_stall(&add, "s3, s0, s4"), 1);
        assert_eq!(fp_stall(&add, "s3, s10, s4"), 0);
        let load = cost("vldr", "s0, [r0]").expect("vldr");
        assert_eq!(fp_stall(&load, "s3, s0, s4"), 0);
    }

    #[test]
    fn unknown_and_unbounded_mnemonics_are_errors() {
        match cost("frobnicate", "r0") {
            Err(CostError::Unknown(m)) => assert_eq!(m, "frobnicate"),
            other => panic!("{other:?}"),
        }
        assert!(matches!(
            cost("wfi", ""),
            Err(CostError::Unbounded(m, _)) if m == "wfi"
        ));
        assert!(cost("bkpt", "0x00ab").is_err());
    }
}
