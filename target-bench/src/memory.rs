//! Where each load and store of a function goes: the core registers' values tracked through
//! its machine code, so that the cycle model charges each data access for the memory it
//! reaches (SRAM, a peripheral bus, flash) instead of the dearest.
//!
//! Place in the data flow: [`crate::wcet`] runs [`places`] over each function it bounds (its
//! control-flow graph, every call assumed to return) and charges each load and store with
//! [`crate::cycles::data_cycles`] for the [`Region`] found; `paths.rs` uses the same places
//! for the step as it ran.
//!
//! Method: a forward data-flow analysis over the graph. Each register holds a [`Value`]:
//! unknown, an unsigned range `[lo, hi]`, or an address in the stack. Understood: immediates
//! (`mov`, `movw`, `mvn`), `movt` over a known low half, register copies, add and subtract of
//! immediates and of known registers (a shifted one too), `and` with a known value, `bfc` of
//! the top bits, `ubfx`, `uxtb`/`uxth`, shifts by an immediate, byte and halfword loads
//! (their width), a word loaded from the function's own literal pool (its `.word`), and the
//! stack pointer plus or minus an immediate (an address in the stack). Whatever else an
//! instruction writes is unknown; a call makes every register but the stack pointer unknown
//! (no calling convention is assumed); an instruction under a condition (in an IT block)
//! joins its result with the register's old value; where paths meet, the ranges' hull, and
//! after [`WIDEN_AFTER`] changes of one instruction's input the registers still changing
//! become unknown (so every loop's analysis ends). An access's address is its base
//! register's value plus its offset (an immediate, or an index register's value, shifted);
//! its [`Region`] is the one memory region ([`region_of`]) holding every byte that every
//! address of the range can touch, else [`Region::Unknown`].
//!
//! Invariants: a value is never more precise than every path into the instruction allows
//! (sound: the analysis only ever forgets); an address it cannot place is
//! [`Region::Unknown`], which the cycle model charges the conservative default (a load as a
//! flash read that misses the ART accelerator). Assumed, as the cycle model did before this
//! tracking for addresses on the stack pointer: an address the stack pointer gives, plus or
//! minus an immediate or an index, is in the stack (a frame's offsets stay inside the stack,
//! which is in SRAM).

use std::collections::HashMap;

use crate::cycles;
use crate::wcet::{Line, Write, writes};

/// The changes of an instruction's input state after which the registers still changing are
/// made unknown (widening: a counter incremented in a loop would otherwise grow its range
/// once per pass).
pub const WIDEN_AFTER: u32 = 4;

/// What the analysis knows of a register's value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Value {
    /// Nothing.
    Unknown,
    /// An unsigned 32-bit value within `[lo, hi]`.
    Range(u32, u32),
    /// An address in the stack (the stack pointer, a copy of it, it plus or minus an
    /// immediate).
    Stack,
}

impl Value {
    fn exact(v: i64) -> Self {
        Self::range(v, v)
    }

    /// `[lo, hi]` if it is a range of 32-bit unsigned values, else unknown (no wrap-around
    /// is modelled).
    fn range(lo: i64, hi: i64) -> Self {
        match (u32::try_from(lo), u32::try_from(hi)) {
            (Ok(l), Ok(h)) if l <= h => Self::Range(l, h),
            _ => Self::Unknown,
        }
    }

    /// The largest value it may have.
    fn max(self) -> i64 {
        match self {
            Self::Range(_, h) => i64::from(h),
            _ => i64::from(u32::MAX),
        }
    }

    fn join(self, other: Self, widen: bool) -> Self {
        match (self, other) {
            (a, b) if a == b => a,
            (Self::Range(a, b), Self::Range(c, d)) if !widen => Self::Range(a.min(c), b.max(d)),
            _ => Self::Unknown,
        }
    }

    fn plus(self, other: Self) -> Self {
        match (self, other) {
            (Self::Range(a, b), Self::Range(c, d)) => {
                Self::range(i64::from(a) + i64::from(c), i64::from(b) + i64::from(d))
            }
            _ => Self::Unknown,
        }
    }

    fn minus(self, other: Self) -> Self {
        match (self, other) {
            (Self::Range(a, b), Self::Range(c, d)) => {
                Self::range(i64::from(a) - i64::from(d), i64::from(b) - i64::from(c))
            }
            _ => Self::Unknown,
        }
    }

    fn shl(self, n: u32) -> Self {
        match self {
            Self::Range(a, b) if n < 32 => Self::range(i64::from(a) << n, i64::from(b) << n),
            _ => Self::Unknown,
        }
    }

    fn shr(self, n: u32) -> Self {
        match self {
            Self::Range(a, b) if n < 32 => Self::Range(a >> n, b >> n),
            _ if n < 32 => Self::Range(0, u32::MAX >> n),
            _ => Self::Range(0, 0),
        }
    }

    /// At most `max` (an unsigned result no larger than either operand, as AND's).
    fn at_most(self, max: i64) -> Self {
        Self::range(0, self.max().min(max))
    }
}

/// A memory region of the STM32F405 (RM0090, the memory map), by what an access to it costs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Region {
    /// The stack (SRAM1): no wait state.
    Stack,
    /// SRAM1 and SRAM2, `0x2000_0000..=0x2001_FFFF`: no wait state (RM0090: the embedded
    /// SRAM is read and written at CPU speed with 0 wait states, over the bus matrix's S-bus).
    Sram,
    /// The core-coupled data RAM, `0x1000_0000..=0x1000_FFFF`: no wait state (D-bus).
    Ccm,
    /// The flash (`0x0800_0000..=0x080F_FFFF`, its boot alias at 0, and the system memory,
    /// OTP and option bytes at `0x1FFF_0000..=0x1FFF_FFFF`): the wait states of a read.
    Flash,
    /// The APB1 peripherals, `0x4000_0000..=0x4000_7FFF` (42 MHz).
    Apb1,
    /// The APB2 peripherals, `0x4001_0000..=0x4001_57FF` (84 MHz).
    Apb2,
    /// Another peripheral (AHB1, AHB2, the core's private peripheral bus): charged as APB1,
    /// the slowest.
    Peripheral,
    /// Not placed: the cycle model's conservative default.
    Unknown,
}

impl Region {
    /// Its name in reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::Stack => "stack",
            Self::Sram => "sram",
            Self::Ccm => "ccm",
            Self::Flash => "flash",
            Self::Apb1 => "apb1",
            Self::Apb2 => "apb2",
            Self::Peripheral => "other peripheral",
            Self::Unknown => "unknown",
        }
    }
}

/// The region holding every address of `[lo, hi]`, or [`Region::Unknown`].
pub fn region_of(lo: u64, hi: u64) -> Region {
    const MAP: [(u64, u64, Region); 9] = [
        (0x0000_0000, 0x000F_FFFF, Region::Flash),
        (0x0800_0000, 0x080F_FFFF, Region::Flash),
        (0x1000_0000, 0x1000_FFFF, Region::Ccm),
        (0x1FFF_0000, 0x1FFF_FFFF, Region::Flash),
        (0x2000_0000, 0x2001_FFFF, Region::Sram),
        (0x4000_0000, 0x4000_7FFF, Region::Apb1),
        (0x4001_0000, 0x4001_57FF, Region::Apb2),
        (0x4002_0000, 0x5FFF_FFFF, Region::Peripheral),
        (0xE000_0000, 0xE00F_FFFF, Region::Peripheral),
    ];
    MAP.iter()
        .find(|&&(a, b, _)| a <= lo && hi <= b)
        .map_or(Region::Unknown, |&(_, _, r)| r)
}

/// The registers as objdump names them (r10..r12 as `sl`, `fp`, `ip`), by number.
const NAMES: [&str; 16] = [
    "r0", "r1", "r2", "r3", "r4", "r5", "r6", "r7", "r8", "r9", "sl", "fp", "ip", "sp", "lr", "pc",
];
/// Other names a register may be printed with.
const ALIASES: [(usize, &str); 7] = [
    (9, "sb"),
    (10, "r10"),
    (11, "r11"),
    (12, "r12"),
    (13, "r13"),
    (14, "r14"),
    (15, "r15"),
];
const SP: usize = 13;
const PC: usize = 15;

fn register(name: &str) -> Option<usize> {
    let n = name.trim();
    NAMES
        .iter()
        .position(|r| *r == n)
        .or_else(|| ALIASES.iter().find(|(_, a)| *a == n).map(|(k, _)| *k))
}

/// The registers' values before an instruction.
type State = [Value; 16];

/// The state at a function's entry: the stack pointer in the stack, nothing else known.
fn entry() -> State {
    let mut s = [Value::Unknown; 16];
    s[SP] = Value::Stack;
    s
}

/// An immediate operand (`#12`, `#-4`, `#0x1f`).
fn immediate(op: &str) -> Option<i64> {
    let t = op.trim().strip_prefix('#')?.trim();
    let (negative, t) = match t.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, t),
    };
    let v = match t.strip_prefix("0x") {
        Some(hex) => i64::from_str_radix(hex, 16).ok()?,
        None => t.parse::<i64>().ok()?,
    };
    Some(if negative { -v } else { v })
}

/// The operands at the top level: `r0, [r1, #4]!` is `r0` and `[r1, #4]!`.
fn operands(text: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let (mut depth, mut start) = (0i32, 0usize);
    for (i, ch) in text.char_indices() {
        match ch {
            '[' | '{' => depth += 1,
            ']' | '}' => depth -= 1,
            ',' if depth == 0 => {
                out.push(text[start..i].trim());
                start = i + 1;
            }
            _ => {}
        }
    }
    let last = text[start..].trim();
    if !last.is_empty() {
        out.push(last);
    }
    out
}

/// A shift operand (`lsl #2`): its kind and amount.
fn shift(op: &str) -> Option<(&str, u32)> {
    let (kind, amount) = op.trim().split_once(' ')?;
    Some((kind, u32::try_from(immediate(amount)?).ok()?))
}

fn shifted(v: Value, op: &str) -> Value {
    match shift(op) {
        Some(("lsl", n)) => v.shl(n),
        Some(("lsr", n)) => v.shr(n),
        _ => Value::Unknown,
    }
}

/// The value of an operand: an immediate or a register (the PC is not tracked).
fn operand(s: &State, op: &str) -> Value {
    if let Some(v) = immediate(op) {
        return Value::exact(v);
    }
    match register(op) {
        Some(PC) | None => Value::Unknown,
        Some(r) => s[r],
    }
}

/// `a + b` where `b` is an immediate added to a stack address (still in the stack), or a
/// sum of ranges.
fn add(a: Value, b: Value, b_immediate: bool) -> Value {
    match (a, b) {
        (Value::Stack, _) if b_immediate => Value::Stack,
        _ => a.plus(b),
    }
}

fn sub(a: Value, b: Value, b_immediate: bool) -> Value {
    match (a, b) {
        (Value::Stack, _) if b_immediate => Value::Stack,
        _ => a.minus(b),
    }
}

fn is_immediate(op: &str) -> bool {
    op.trim().starts_with('#')
}

/// The address a pc-relative load reads: `Align(PC, 4) + offset`, PC the instruction's
/// address plus 4.
fn pc_relative(addr: u64, offset: i64) -> Option<u64> {
    u64::try_from(i64::try_from((addr + 4) & !3).ok()? + offset).ok()
}

/// The value `line` leaves in register `d` (which it writes), from the state before it;
/// `literal`: the word at an address of the function's literal pool.
fn eval(line: &Line, d: usize, s: &State, literal: &dyn Fn(u64) -> Option<u32>) -> Value {
    let Some((base, _)) = cycles::base(&line.mnemonic) else {
        return Value::Unknown;
    };
    let ops = operands(&line.operands);
    let is_dest = ops.first().and_then(|o| register(o)) == Some(d);
    if !is_dest {
        // A second destination or a written-back base: not tracked.
        return Value::Unknown;
    }
    let o = |k: usize| ops.get(k).copied().unwrap_or("");
    match (base, ops.len()) {
        ("mov" | "movw", 2) => operand(s, o(1)),
        ("mov", 3) => shifted(operand(s, o(1)), o(2)),
        ("mvn", 2) => match immediate(o(1)) {
            Some(v) => Value::exact(i64::from(!(v as u32))),
            None => Value::Unknown,
        },
        ("movt", 2) => match (s[d], immediate(o(1))) {
            // MOVT writes the top half and keeps the bottom one.
            (Value::Range(lo, hi), Some(top)) if (0..=0xFFFF).contains(&top) => {
                if hi <= 0xFFFF {
                    Value::range((top << 16) + i64::from(lo), (top << 16) + i64::from(hi))
                } else if lo == hi {
                    Value::exact((top << 16) + i64::from(lo & 0xFFFF))
                } else {
                    Value::Unknown
                }
            }
            _ => Value::Unknown,
        },
        ("add" | "addw", 2) => add(s[d], operand(s, o(1)), is_immediate(o(1))),
        ("add" | "addw", 3) => add(operand(s, o(1)), operand(s, o(2)), is_immediate(o(2))),
        ("add", 4) => operand(s, o(1)).plus(shifted(operand(s, o(2)), o(3))),
        ("sub" | "subw", 2) => sub(s[d], operand(s, o(1)), is_immediate(o(1))),
        ("sub" | "subw", 3) => sub(operand(s, o(1)), operand(s, o(2)), is_immediate(o(2))),
        ("sub", 4) => operand(s, o(1)).minus(shifted(operand(s, o(2)), o(3))),
        ("and", 2) => s[d].at_most(operand(s, o(1)).max()),
        ("and", 3) => operand(s, o(1)).at_most(operand(s, o(2)).max()),
        ("bfc", 3) => match (immediate(o(1)), immediate(o(2))) {
            // The bits from `lsb` to the top cleared: below 2^lsb.
            (Some(lsb), Some(width)) if lsb + width == 32 => s[d].at_most((1i64 << lsb) - 1),
            _ => Value::Unknown,
        },
        ("ubfx", 4) => match immediate(o(3)) {
            Some(width) if (1..32).contains(&width) => Value::range(0, (1i64 << width) - 1),
            _ => Value::Unknown,
        },
        ("uxtb", 2) => operand(s, o(1)).at_most(0xFF),
        ("uxth", 2) => operand(s, o(1)).at_most(0xFFFF),
        ("uxtb", _) => Value::range(0, 0xFF),
        ("uxth", _) => Value::range(0, 0xFFFF),
        ("lsr", 2) => shifted(s[d], &format!("lsr {}", o(1))),
        ("lsr", 3) if is_immediate(o(2)) => shifted(operand(s, o(1)), &format!("lsr {}", o(2))),
        ("lsl", 2) => shifted(s[d], &format!("lsl {}", o(1))),
        ("lsl", 3) if is_immediate(o(2)) => shifted(operand(s, o(1)), &format!("lsl {}", o(2))),
        ("ldrb" | "ldrexb", _) => Value::range(0, 0xFF),
        ("ldrh" | "ldrexh", _) => Value::range(0, 0xFFFF),
        ("ldr", 2) => {
            let m = memory_operand(o(1));
            match m {
                Some(Memory {
                    base: PC,
                    offset: Offset::Immediate(off),
                    ..
                }) => pc_relative(line.addr, off)
                    .and_then(literal)
                    .map_or(Value::Unknown, |w| Value::exact(i64::from(w))),
                _ => Value::Unknown,
            }
        }
        _ => Value::Unknown,
    }
}

/// The state after `line`, from the state before it.
fn transfer(line: &Line, s: &State, literal: &dyn Fn(u64) -> Option<u32>) -> State {
    let m = line.mnemonic.split('.').next().unwrap_or("");
    if m == "bl" || m.starts_with("blx") {
        // A call: nothing is known of what the callee leaves.
        return entry();
    }
    let conditional = cycles::base(&line.mnemonic).is_some_and(|(_, c)| c);
    let mut out = *s;
    for (r, name) in NAMES.iter().enumerate() {
        let written = std::iter::once(*name)
            .chain(ALIASES.iter().filter(|(k, _)| *k == r).map(|(_, a)| *a))
            .any(|n| !matches!(writes(line, n), Write::No));
        if r == SP || r == PC || !written {
            continue;
        }
        let v = eval(line, r, s, literal);
        out[r] = if conditional { s[r].join(v, false) } else { v };
    }
    out
}

/// A memory operand's offset.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Offset {
    Immediate(i64),
    /// An index register, shifted left by this much.
    Register(usize, u32),
}

/// A memory operand `[base, offset]` (its address: post-indexed ones use the base alone).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Memory {
    base: usize,
    offset: Offset,
}

fn memory_operand(op: &str) -> Option<Memory> {
    let inner = op.trim().strip_prefix('[')?;
    let (inner, _) = inner.split_once(']')?;
    let parts: Vec<&str> = inner.split(',').map(str::trim).collect();
    let base = register(parts.first()?)?;
    let offset = match parts.get(1) {
        None => Offset::Immediate(0),
        Some(p) if is_immediate(p) => Offset::Immediate(immediate(p)?),
        Some(p) => {
            let index = register(p)?;
            let by = match parts.get(2) {
                None => 0,
                Some(s) => match shift(s)? {
                    ("lsl", n) => n,
                    _ => return None,
                },
            };
            Offset::Register(index, by)
        }
    };
    Some(Memory { base, offset })
}

/// Bytes a single load or store moves (`ldrb` 1, `ldrh` 2, `ldrd` and a doubleword `vldr` 8,
/// else 4).
fn access_bytes(base: &str, operands: &[&str]) -> u64 {
    if base.ends_with('d') || operands.first().is_some_and(|o| o.starts_with('d')) {
        8
    } else if base.starts_with("ldrb")
        || base.starts_with("strb")
        || base.starts_with("ldrsb")
        || base.ends_with("exb")
    {
        1
    } else if base.starts_with("ldrh")
        || base.starts_with("strh")
        || base.starts_with("ldrsh")
        || base.ends_with("exh")
    {
        2
    } else {
        4
    }
}

/// Where the data access of `line` goes, from the state before it; `None` when it makes none.
fn place(line: &Line, s: &State) -> Option<Region> {
    let (base, _) = cycles::base(&line.mnemonic)?;
    let ops = operands(&line.operands);
    let in_range = |v: Value, lo_off: i64, hi_off: i64| match v {
        Value::Stack => Region::Stack,
        Value::Range(lo, hi) => {
            let (lo, hi) = (i64::from(lo) + lo_off, i64::from(hi) + hi_off);
            match (u64::try_from(lo), u64::try_from(hi)) {
                (Ok(lo), Ok(hi)) if lo <= hi => region_of(lo, hi),
                _ => Region::Unknown,
            }
        }
        Value::Unknown => Region::Unknown,
    };
    match base {
        "push" | "pop" | "vpush" | "vpop" => Some(Region::Stack),
        "tbb" | "tbh" => Some(Region::Flash),
        "ldm" | "ldmia" | "ldmfd" | "ldmdb" | "ldmea" | "stm" | "stmia" | "stmea" | "stmdb"
        | "stmfd" | "vldm" | "vldmia" | "vldmdb" | "vstm" | "vstmia" | "vstmdb" => {
            let b = register(ops.first()?.trim_end_matches('!'))?;
            let bytes = 4 * i64::try_from(crate::cycles::list_words(ops.get(1)?)).ok()?;
            let down = base.ends_with("db") || base == "ldmea" || base == "stmfd";
            Some(if b == SP {
                Region::Stack
            } else if down {
                in_range(s[b], -bytes, -1)
            } else {
                in_range(s[b], 0, bytes - 1)
            })
        }
        _ => {
            let (k, m) = ops
                .iter()
                .enumerate()
                .find_map(|(k, o)| memory_operand(o).map(|m| (k, m)))?;
            let bytes = i64::try_from(access_bytes(base, &ops)).ok()?;
            if m.base == PC {
                return Some(Region::Flash);
            }
            if m.base == SP || s[m.base] == Value::Stack {
                return Some(Region::Stack);
            }
            // Post-indexed (`[r1], #4`): the base alone is the address.
            let post = ops.len() > k + 1 && !ops[k].ends_with('!');
            let offset = match (m.offset, post) {
                (_, true) => Some((0, 0)),
                (Offset::Immediate(v), false) => Some((v, v)),
                (Offset::Register(r, by), false) => match s[r].shl(by) {
                    Value::Range(lo, hi) => Some((i64::from(lo), i64::from(hi))),
                    _ => None,
                },
            };
            Some(match offset {
                Some((lo, hi)) => in_range(s[m.base], lo, hi + bytes - 1),
                None => Region::Unknown,
            })
        }
    }
}

/// Each instruction's data access region (`None`: no access, or not reached) in the function
/// `lines` with successors `succ` (every reached instruction has its list; index 0 is the
/// entry).
pub(crate) fn places(lines: &[Line], succ: &[Vec<usize>]) -> Vec<Option<Region>> {
    let n = lines.len();
    let words: HashMap<u64, u32> = lines
        .iter()
        .filter(|l| l.mnemonic == ".word")
        .filter_map(|l| {
            let v = l.operands.trim().trim_start_matches("0x");
            u32::from_str_radix(v, 16).ok().map(|w| (l.addr, w))
        })
        .collect();
    let literal = |a: u64| words.get(&a).copied();
    let mut input: Vec<Option<State>> = vec![None; n];
    let mut changes = vec![0u32; n];
    let mut queued = vec![false; n];
    let mut work = Vec::new();
    if n > 0 {
        input[0] = Some(entry());
        work.push(0);
        queued[0] = true;
    }
    while let Some(i) = work.pop() {
        queued[i] = false;
        let Some(s) = input[i] else { continue };
        let out = transfer(&lines[i], &s, &literal);
        for &j in succ.get(i).map_or(&[][..], Vec::as_slice) {
            let next = match input[j] {
                None => out,
                Some(old) => {
                    let widen = changes[j] >= WIDEN_AFTER;
                    let mut joined = old;
                    for r in 0..16 {
                        joined[r] = old[r].join(out[r], widen);
                    }
                    if joined == old {
                        continue;
                    }
                    changes[j] += 1;
                    joined
                }
            };
            input[j] = Some(next);
            if !queued[j] {
                queued[j] = true;
                work.push(j);
            }
        }
    }
    lines
        .iter()
        .zip(&input)
        .map(|(l, s)| s.as_ref().and_then(|s| place(l, s)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wcet::Disassembly;

    /// The places of a one-function listing's instructions, by address.
    fn placed(text: &str) -> Vec<(u64, Option<Region>)> {
        let d = Disassembly::parse_for_tests(text);
        let (addr, _) = d.first_function().expect("a function");
        let p = d.places(addr).expect("places");
        d.lines_of(addr)
            .iter()
            .map(|l| l.addr)
            .zip(p.iter().copied())
            .collect()
    }

    fn at(p: &[(u64, Option<Region>)], addr: u64) -> Option<Region> {
        p.iter().find(|(a, _)| *a == addr).and_then(|(_, r)| *r)
    }

    #[test]
    fn a_movw_movt_address_is_placed_in_its_region() {
        let p = placed(
            "
08000100 <f>:
 8000100:	movw	r2, #62788	@ 0xf544
 8000104:	movt	r2, #8193	@ 0x2001
 8000108:	ldr.w	r3, [r2, #512]	@ 0x200
 800010c:	movw	lr, #4100	@ 0x1004
 8000110:	movt	lr, #16385	@ 0x4001
 8000114:	ldrh.w	r1, [lr, #-4]
 8000118:	strh.w	r1, [lr]
 800011c:	movw	r0, #0
 8000120:	movt	r0, #16384	@ 0x4000
 8000124:	ldr	r1, [r0, #36]	@ 0x24
 8000126:	ldr	r1, [r5, #4]
 8000128:	ldr	r1, [pc, #8]
 800012a:	ldr	r1, [sp, #8]
 800012c:	bx	lr
",
        );
        assert_eq!(at(&p, 0x800_0108), Some(Region::Sram), "0x2001f744");
        assert_eq!(
            at(&p, 0x800_0114),
            Some(Region::Apb2),
            "USART1 SR, 0x40011000"
        );
        assert_eq!(at(&p, 0x800_0118), Some(Region::Apb2), "USART1 DR, a store");
        assert_eq!(
            at(&p, 0x800_0124),
            Some(Region::Apb1),
            "TIM2 CNT, 0x40000024"
        );
        assert_eq!(
            at(&p, 0x800_0126),
            Some(Region::Unknown),
            "an argument's pointer"
        );
        assert_eq!(at(&p, 0x800_0128), Some(Region::Flash), "the literal pool");
        assert_eq!(at(&p, 0x800_012a), Some(Region::Stack));
        assert_eq!(at(&p, 0x800_0100), None, "no access");
    }

    #[test]
    fn paths_that_disagree_leave_the_register_unknown_and_a_call_forgets_everything() {
        let p = placed(
            "
08000100 <f>:
 8000100:	movw	r2, #0
 8000104:	movt	r2, #8192	@ 0x2000
 8000108:	cbz	r0, 8000114 <f+0x14>
 800010a:	movw	r2, #0
 800010e:	movt	r2, #2048	@ 0x800
 8000112:	nop
 8000114:	ldr	r3, [r2, #0]
 8000116:	movw	r4, #0
 800011a:	movt	r4, #8192	@ 0x2000
 800011e:	bl	8000100 <f>
 8000122:	ldr	r3, [r4, #0]
 8000124:	bx	lr
",
        );
        // SRAM on one path, flash on the other: the hull spans both, no one region.
        assert_eq!(at(&p, 0x800_0114), Some(Region::Unknown));
        // After the call r4 is forgotten (no calling convention assumed).
        assert_eq!(at(&p, 0x800_0122), Some(Region::Unknown));
    }

    #[test]
    fn a_masked_index_stays_inside_its_array_and_an_unmasked_one_does_not() {
        let p = placed(
            "
08000100 <f>:
 8000100:	movw	r1, #62788	@ 0xf544
 8000104:	movt	r1, #8193	@ 0x2001
 8000108:	bfc	r3, #10, #22
 800010c:	add	r3, r1
 800010e:	ldrb.w	r2, [r3, #520]	@ 0x208
 8000112:	strb.w	r2, [r1, r3]
 8000116:	strb.w	r2, [r1, r5]
 800011a:	uxtb	r6, r5
 800011c:	ldrb	r0, [r1, r6]
 800011e:	bx	lr
",
        );
        // 0x2001f544 + 520 + 1023 is inside SRAM.
        assert_eq!(at(&p, 0x800_010e), Some(Region::Sram));
        // r3 is now base + index: base + that again is 0x4003_xxxx, exactly (an AHB1
        // peripheral's address, were it ever used).
        assert_eq!(at(&p, 0x800_0112), Some(Region::Peripheral));
        assert_eq!(at(&p, 0x800_0116), Some(Region::Unknown), "r5 unbounded");
        assert_eq!(at(&p, 0x800_011c), Some(Region::Sram), "a byte index");
    }

    #[test]
    fn a_counter_in_a_loop_is_widened_and_the_analysis_ends() {
        let p = placed(
            "
08000100 <f>:
 8000100:	movw	r1, #0
 8000104:	movt	r1, #8192	@ 0x2000
 8000108:	ldr	r2, [r1, #0]
 800010a:	adds	r1, #4
 800010c:	subs	r0, #1
 800010e:	bne.n	8000108 <f+0x8>
 8000110:	bx	lr
",
        );
        // r1 grows by 4 each pass, without a bound the analysis can see: unknown.
        assert_eq!(at(&p, 0x800_0108), Some(Region::Unknown));
    }

    #[test]
    fn stack_addresses_and_literal_words_are_followed() {
        let p = placed(
            "
08000100 <f>:
 8000100:	add	r0, sp, #16
 8000102:	ldr	r1, [r0, #4]
 8000104:	ldr	r2, [pc, #4]	@ (800010c <f+0xc>)
 8000106:	ldr	r3, [r2, #8]
 8000108:	vldr	s0, [r2]
 800010a:	bx	lr
 800010c:	.word	0x20001000
",
        );
        assert_eq!(at(&p, 0x800_0102), Some(Region::Stack));
        assert_eq!(
            at(&p, 0x800_0104),
            Some(Region::Flash),
            "the literal itself"
        );
        assert_eq!(
            at(&p, 0x800_0106),
            Some(Region::Sram),
            "through the literal's address"
        );
        assert_eq!(at(&p, 0x800_0108), Some(Region::Sram));
    }

    #[test]
    fn conditional_writes_join_and_write_back_forgets_the_base() {
        let p = placed(
            "
08000100 <f>:
 8000100:	movw	r1, #0
 8000104:	movt	r1, #8192	@ 0x2000
 8000108:	cmp	r0, #0
 800010a:	it	ne
 800010c:	movne	r1, #0
 800010e:	ldr	r2, [r1, #0]
 8000110:	movw	r3, #0
 8000114:	movt	r3, #8192	@ 0x2000
 8000118:	ldr.w	r2, [r3, #4]!
 800011c:	ldr	r2, [r3, #0]
 800011e:	bx	lr
",
        );
        // r1 is 0x20000000 or 0 (the flash alias): no one region.
        assert_eq!(at(&p, 0x800_010e), Some(Region::Unknown));
        assert_eq!(
            at(&p, 0x800_0118),
            Some(Region::Sram),
            "pre-indexed: base + 4"
        );
        assert_eq!(
            at(&p, 0x800_011c),
            Some(Region::Unknown),
            "the base written back"
        );
    }

    #[test]
    fn the_memory_map_places_whole_ranges_only() {
        assert_eq!(region_of(0x2001_FFFC, 0x2001_FFFF), Region::Sram);
        assert_eq!(region_of(0x2001_FFFC, 0x2002_0003), Region::Unknown);
        assert_eq!(region_of(0x4001_1000, 0x4001_1003), Region::Apb2);
        assert_eq!(region_of(0x4000_0024, 0x4000_0027), Region::Apb1);
        assert_eq!(
            region_of(0x4002_3800, 0x4002_3803),
            Region::Peripheral,
            "RCC on AHB1"
        );
        assert_eq!(
            region_of(0xE000_E100, 0xE000_E103),
            Region::Peripheral,
            "NVIC"
        );
        assert_eq!(region_of(0x0800_4000, 0x0800_4003), Region::Flash);
        assert_eq!(region_of(0x3000_0000, 0x3000_0003), Region::Unknown);
    }
}
