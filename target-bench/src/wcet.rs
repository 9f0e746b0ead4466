//! A static bound on a function's cost: the longest path through its machine code, in
//! instructions or in Cortex-M4 cycles, callees and bounded loops included.
//!
//! Place in the data flow: `main.rs` disassembles each firmware ELF ([`Disassembly::of`],
//! `arm-none-eabi-objdump -d`) and asks for the bound of the control step and of the whole
//! control task ([`Disassembly::bound`]) under the firmware's [`Rules`] (`task.rs`: which
//! callees are left out, which never return, the loops' declared bounds, the library calls
//! costed by size); the figures go to the JSON report and the gate.
//!
//! Method: the control-flow graph of each function, instruction by instruction (fall-through,
//! direct and conditional branches, `cbz`/`cbnz`, `tbb`/`tbh` jump tables read from the table
//! words, returns by `pop`/`ldm` of `pc` or `bx lr`, tail calls by a branch out of the
//! function); a call (`bl`) adds the callee's own bound, found the same way. Loops are the
//! strongly connected components of the graph, nested ones found inside each loop's body with
//! its back edges removed; each must have one entry (its header) and a declared bound
//! ([`LoopBound`]: the function, the loop's ordinal among the function's loops by header
//! address, checked against its source (the inlined functions `addr2line` names for its
//! instructions) and its size in instructions, so a table gone stale fails naming the loop).
//! A loop with the bound n costs n times its dearest pass around (from its header back to
//! it) plus its dearest last pass (from its header to an exit, and on from there): the path
//! through it returns to the header at most n times, then leaves. (It used to cost (n + 1)
//! times the dearest pass plus the exit: for a loop tested at its top, whose last pass is the
//! test alone, one whole body too many.) Library
//! calls whose cost depends on a size ([`SizedCall`]: `memcpy`, `memset`) are analysed for the
//! size the call site passes, found by following the size register back through every path to
//! constants; each of their loops iterates at most once per byte.
//!
//! Metric: instructions (the unit of QEMU's `-icount`; every instruction of an IT block counts
//! whether or not its condition holds, as QEMU counts them) or cycles under a memory
//! [`Model`] (`cycles.rs`: the instruction's cycles, a taken branch's refill, the flash wait
//! states of every flash line the path enters and of every conditional branch's speculative
//! fetch, and each load's and store's memory: `memory.rs` tracks the registers' values
//! through each function and places each access in SRAM, a peripheral bus, flash or nowhere
//! known, and `cycles.rs` charges it for that).
//!
//! What it refuses, as an error naming the function and address: an indirect branch or call,
//! recursion, a loop without a declared bound (or whose declaration no longer matches), a loop
//! with more than one entry, a library call whose size it cannot bound, an instruction the
//! cycle table does not know.
//!
//! The bound over-estimates: every path the graph allows counts, including paths no input can
//! take together, and each loop iteration counts as its dearest.

use std::cell::RefCell;
use std::collections::{BTreeMap, BTreeSet, HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::rc::Rc;

use serde::Serialize;

use crate::cycles::{self, Model};
use crate::memory::{self, Region};

/// One decoded line of the disassembly.
#[derive(Debug, Clone)]
pub(crate) struct Line {
    pub(crate) addr: u64,
    /// Bytes, from the next line's address.
    pub(crate) size: u64,
    pub(crate) mnemonic: String,
    pub(crate) operands: String,
}

impl Line {
    pub(crate) fn is_data(&self) -> bool {
        self.mnemonic.starts_with('.')
    }
}

/// One function of the disassembly.
struct Function {
    name: String,
    lines: Vec<Line>,
}

/// The disassembly, by function start address.
pub struct Disassembly {
    functions: BTreeMap<u64, Function>,
    names: HashMap<String, Vec<u64>>,
    /// The ELF, for `addr2line` (none: sources are empty).
    elf: Option<PathBuf>,
    /// Inlined function names at each address, innermost first (from `addr2line`).
    chains: RefCell<HashMap<u64, Vec<String>>>,
    /// Each function's data access regions, by instruction (`memory.rs`), once found.
    places: RefCell<HashMap<u64, Rc<Vec<Option<Region>>>>>,
}

/// What a bound counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Metric {
    /// Instructions executed.
    Instructions,
    /// Core clock cycles under a memory model.
    Cycles(Model),
}

/// A declared bound on one loop.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct LoopBound {
    /// The function whose machine code holds the loop (demangled symbol).
    pub function: &'static str,
    /// The loop's place among the function's loops, by header address (0 first).
    pub ordinal: usize,
    /// Names (or parts of names) of inlined functions `addr2line` must find among the loop's
    /// instructions: what the loop is in the source.
    pub source: &'static [&'static str],
    /// Instructions in the loop (nested loops included) when the bound was declared: a
    /// change means the code changed, and the bound must be checked again.
    pub instructions: usize,
    /// At most this many passes back to the loop's header per entry into it: for a loop
    /// tested at its top, its body's runs; for one tested at its bottom, one fewer.
    pub iterations: u64,
    /// Why.
    pub reason: &'static str,
}

/// A library function whose cost depends on a byte count passed in a register.
#[derive(Debug, Clone, Copy)]
pub struct SizedCall {
    /// Its symbol.
    pub symbol: &'static str,
    /// The register holding the byte count at the call.
    pub size_register: &'static str,
}

/// A declared bound on a loop of a sized library function, as a function of the call's byte
/// count `n`: at most ceil(min(n, `at_most_bytes`) / `bytes_per_iteration`) iterations.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct SizedLoop {
    /// The library function.
    pub function: &'static str,
    /// The loop's ordinal among the function's loops, by header address.
    pub ordinal: usize,
    /// Instructions in the loop when the bound was declared (a change fails the bound).
    pub instructions: usize,
    /// Bytes of the count each iteration handles, at least.
    pub bytes_per_iteration: u64,
    /// At most this many of the count's bytes go through the loop (`None`: all of them).
    pub at_most_bytes: Option<u64>,
    /// Why.
    pub reason: &'static str,
}

/// A sized library function's call to another with a smaller count: the callee gets at most
/// `at_most_bytes` of the caller's.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct SizedCallee {
    /// The calling library function.
    pub function: &'static str,
    /// The one it calls.
    pub callee: &'static str,
    /// The most bytes it passes on.
    pub at_most_bytes: u64,
    /// Why.
    pub reason: &'static str,
}

/// What a bound assumes of the code around the functions it walks.
#[derive(Debug, Clone, Copy, Default)]
pub struct Rules<'a> {
    /// Callees (name prefixes) left out: the call instruction counts, the callee does not.
    pub exclude: &'a [&'a str],
    /// Callees (name prefixes) that do not return: a path ends at the call.
    pub diverging: &'a [&'a str],
    /// The loops' bounds.
    pub loops: &'a [LoopBound],
    /// Library calls costed by their size.
    pub sized: &'a [SizedCall],
    /// Their loops' bounds.
    pub sized_loops: &'a [SizedLoop],
    /// Their calls to each other with smaller counts.
    pub sized_callees: &'a [SizedCallee],
    /// List loops instead of refusing the undeclared ones (they count one iteration, and are
    /// reported with the reason `UNDECLARED`): for updating the table, never for a figure.
    pub discover: bool,
}

/// A loop the bound went through, and the bound it used.
#[derive(Debug, Clone, Serialize, PartialEq, Eq)]
pub struct LoopUse {
    /// The function.
    pub function: String,
    /// Its ordinal among the function's loops.
    pub ordinal: usize,
    /// The header's address.
    pub header: String,
    /// The header's offset from the function's start, bytes.
    pub offset: u64,
    /// Instructions in the loop.
    pub instructions: usize,
    /// The inlined functions at the header, innermost first, outside `core`.
    pub source: String,
    /// The iterations bound used.
    pub iterations: u64,
    /// Why.
    pub reason: String,
    /// The dearest iteration, in the bound's metric.
    pub iteration: u64,
    /// An exclusive-access retry loop (it holds a `strex`: it repeats only when an exception
    /// came between its `ldrex` and `strex`).
    pub exclusive: bool,
}

/// The bound of one function.
#[derive(Debug, Clone, Serialize)]
pub struct Bound {
    /// The function.
    pub function: String,
    /// The metric's value on the longest path, callees and loops included.
    pub longest_path: u64,
    /// Instructions in the function's own code (not its callees).
    pub code_instructions: usize,
    /// Callees on some path, with their own bounds.
    pub calls: BTreeMap<String, u64>,
    /// Callees left out of the bound (the rules' `exclude`).
    pub excluded_calls: Vec<String>,
    /// Callees that end a path (the rules' `diverging`).
    pub diverging_calls: Vec<String>,
    /// Library calls costed by size: `callee (n B)` with its bound.
    pub sized_calls: BTreeMap<String, u64>,
    /// Loops on some path, with their bounds.
    pub loops: Vec<LoopUse>,
    /// Stack the function and its deepest chain of callees reserve, bytes: the sum of each
    /// one's pushes and `sub sp` (static; the paint-and-scan figure is measured).
    pub stack_bytes: u64,
    /// Some instruction on a path is the FPU's (an interrupt handler's FP context is then
    /// stacked).
    pub uses_fpu: bool,
    /// The instructions with a data access in the functions walked (each function once,
    /// reached code only; cycle bounds only), by the region `memory.rs` places them in.
    pub data_accesses: BTreeMap<String, u64>,
    /// The functions the bound walked (start addresses): the code the path can run.
    #[serde(skip)]
    pub functions: BTreeSet<u64>,
    /// Their code, bytes (what running them from SRAM would take).
    pub code_bytes: u64,
}

/// Bytes an instruction moves the stack pointer down by (`push`, `stmdb sp!`, `vpush`,
/// `sub sp, #n`); 0 for anything else.
fn stack_reserved(line: &Line) -> u64 {
    let m = strip_width(&line.mnemonic);
    let ops = line.operands.as_str();
    let registers = |ops: &str| -> u64 {
        let list = ops
            .split('{')
            .nth(1)
            .and_then(|r| r.split('}').next())
            .unwrap_or("");
        list.split(',')
            .map(str::trim)
            .filter(|r| !r.is_empty())
            .map(|r| match r.split_once('-') {
                // d8-d15, s16-s31: a range of registers
                Some((a, b)) => {
                    let n = |x: &str| x[1..].parse::<u64>().unwrap_or(0);
                    n(b) - n(a) + 1
                }
                None => 1,
            })
            .sum()
    };
    let width = |ops: &str| if ops.contains("{d") { 8 } else { 4 };
    match m {
        "push" => 4 * registers(ops),
        "vpush" => width(ops) * registers(ops),
        "stmdb" | "stmfd" if ops.starts_with("sp!") => 4 * registers(ops),
        "sub" | "subw" if ops.starts_with("sp, #") || ops.starts_with("sp, sp, #") => ops
            .rsplit('#')
            .next()
            .and_then(|n| n.trim().parse().ok())
            .unwrap_or(0),
        _ => 0,
    }
}

const CONDITIONS: [&str; 16] = [
    "eq", "ne", "cs", "hs", "cc", "lo", "mi", "pl", "vs", "vc", "hi", "ls", "ge", "lt", "gt", "le",
];

fn strip_width(m: &str) -> &str {
    m.strip_suffix(".n")
        .or_else(|| m.strip_suffix(".w"))
        .unwrap_or(m)
}

/// `m` is `base` followed by nothing or by a condition code.
fn conditional_form(m: &str, base: &str) -> Option<bool> {
    let rest = m.strip_prefix(base)?;
    if rest.is_empty() {
        Some(false)
    } else if CONDITIONS.contains(&rest) {
        Some(true)
    } else {
        None
    }
}

fn hex_target(operands: &str) -> Option<u64> {
    let token = operands.split([' ', ',']).find(|t| !t.is_empty())?;
    u64::from_str_radix(token, 16).ok()
}

/// How control leaves an instruction.
#[derive(Debug, PartialEq)]
enum Flow {
    /// To the next instruction.
    Next,
    /// To a target (conditionally: also to the next).
    Branch { target: u64, conditional: bool },
    /// A call, then the next instruction.
    Call(u64),
    /// Out of the function (conditionally: also to the next).
    Return { conditional: bool },
    /// A jump table's targets.
    Table(Vec<u64>),
    /// Cannot be followed statically.
    Indirect,
    /// Data, not code.
    Data,
}

/// The targets of a `tbb` (bytes) or `tbh` (halfwords) jump table at `base`, from the data
/// lines that follow the instruction (`.byte`, `.short`, `.word`: 1, 2, 4 bytes,
/// little-endian): each the table's address plus twice its entry. The table runs from `base`
/// up to its lowest target (its targets follow it), and a Thumb `nop` (0xBF00) at an even
/// address just before that is the alignment padding of the code after it, not two entries.
/// Entries that land elsewhere than on an instruction are dropped by the caller.
fn table_targets(base: u64, halfwords: bool, data: &[&Line]) -> Vec<u64> {
    let mut bytes = Vec::new();
    for w in data {
        let v = u64::from_str_radix(w.operands.trim().trim_start_matches("0x"), 16).unwrap_or(0);
        let width = match w.mnemonic.as_str() {
            ".byte" => 1,
            ".short" | ".hword" | ".2byte" => 2,
            _ => 4,
        };
        bytes.extend((0..width).map(|k| (w.addr + k, (v >> (8 * k)) & 0xFF)));
    }
    let step = if halfwords { 2 } else { 1 };
    let mut entries: Vec<(u64, u64)> = bytes
        .chunks_exact(step)
        .map(|c| (c[0].0, c.iter().rev().fold(0, |e, &(_, b)| (e << 8) | b)))
        .collect();
    let mut end = u64::MAX;
    let mut n = 0;
    for &(at, e) in &entries {
        if at >= end {
            break;
        }
        if e != 0 {
            end = end.min(base + 2 * e);
        }
        n += 1;
    }
    entries.truncate(n);
    let padding = |a: &(u64, u64), b: &(u64, u64)| {
        a.0.is_multiple_of(2) && a.1 == 0x00 && b.1 == 0xBF && b.0 + 1 == end
    };
    if !halfwords
        && let [.., a, b] = entries.as_slice()
        && padding(a, b)
    {
        entries.truncate(entries.len() - 2);
    }
    entries.into_iter().map(|(_, e)| base + 2 * e).collect()
}

fn flow(line: &Line, table: impl Fn() -> Vec<u64>) -> Flow {
    let m = strip_width(&line.mnemonic);
    if m.starts_with('.') {
        return Flow::Data;
    }
    if m == "tbb" || m == "tbh" {
        return Flow::Table(table());
    }
    if m == "bl" {
        return hex_target(&line.operands).map_or(Flow::Indirect, Flow::Call);
    }
    if m.starts_with("blx") {
        return Flow::Indirect;
    }
    if let Some(conditional) = conditional_form(m, "bx") {
        return if line.operands.trim() == "lr" {
            Flow::Return { conditional }
        } else {
            Flow::Indirect
        };
    }
    if m == "cbz" || m == "cbnz" {
        let target = line
            .operands
            .split(',')
            .nth(1)
            .and_then(|t| hex_target(t.trim()));
        return target.map_or(Flow::Indirect, |target| Flow::Branch {
            target,
            conditional: true,
        });
    }
    if let Some(conditional) = conditional_form(m, "b") {
        return hex_target(&line.operands).map_or(Flow::Indirect, |target| Flow::Branch {
            target,
            conditional,
        });
    }
    let writes_pc = line
        .operands
        .split(['{', '}', ',', ' '])
        .any(|r| r.trim() == "pc");
    if writes_pc {
        let pops = conditional_form(m, "pop")
            .or_else(|| conditional_form(m, "ldmia"))
            .or_else(|| conditional_form(m, "ldm"));
        if let Some(conditional) = pops {
            return Flow::Return { conditional };
        }
        if m.starts_with("ldr") && line.operands.trim_start().starts_with("pc") {
            return Flow::Return { conditional: false };
        }
        if line.operands.trim_start().starts_with("pc") {
            return Flow::Indirect;
        }
    }
    Flow::Next
}

// How an edge of the graph is taken (its cost in cycles depends on it).
use cycles::Pass as Edge;

/// What writing a register amounts to, for the size of a library call.
pub(crate) enum Write {
    No,
    Const(u64),
    Copy(String),
    Other,
}

/// How `line` writes `reg` (the call-size trace and `memory.rs`: conservative, anything it
/// does not recognise as a constant or a copy is `Other`).
pub(crate) fn writes(line: &Line, reg: &str) -> Write {
    let Some((base, conditional)) = cycles::base(&line.mnemonic) else {
        return Write::Other;
    };
    let ops: Vec<&str> = line
        .operands
        .split(',')
        .map(str::trim)
        .filter(|o| !o.is_empty())
        .collect();
    let names = |o: &str| {
        o.split(['{', '}', '[', ']', ' ', '!', '-'])
            .any(|t| t.trim() == reg)
    };
    // Register lists (load multiple, pop) and write-back addressing.
    if matches!(
        base,
        "ldm" | "ldmia" | "ldmfd" | "ldmdb" | "ldmea" | "pop" | "vldm" | "vldmia" | "vldmdb"
    ) && line.operands.contains('{')
        && line
            .operands
            .split('{')
            .nth(1)
            .is_some_and(|l| l.split([',', '}']).any(|t| t.trim() == reg))
    {
        return Write::Other;
    }
    // Write-back: `ldm r0!, ...`, post-indexed `[r0], #4`, pre-indexed `[r0, #4]!`.
    let pre_indexed = line.operands.contains("]!")
        && line
            .operands
            .split('[')
            .nth(1)
            .and_then(|m| m.split([',', ']']).next())
            .is_some_and(|b| b.trim() == reg);
    if line.operands.contains(&format!("{reg}!"))
        || line.operands.contains(&format!("[{reg}],"))
        || pre_indexed
    {
        return Write::Other;
    }
    let no_dest = matches!(
        base,
        "str"
            | "strb"
            | "strh"
            | "strd"
            | "strt"
            | "strbt"
            | "strht"
            | "stm"
            | "stmia"
            | "stmea"
            | "stmdb"
            | "stmfd"
            | "push"
            | "cmp"
            | "cmn"
            | "tst"
            | "teq"
            | "b"
            | "bl"
            | "bx"
            | "blx"
            | "cbz"
            | "cbnz"
            | "tbb"
            | "tbh"
            | "vstr"
            | "vstm"
            | "vstmia"
            | "vstmdb"
            | "vpush"
            | "vcmp"
            | "vcmpe"
            | "msr"
            | "vmsr"
            | "cpsid"
            | "cpsie"
            | "nop"
            | "dsb"
            | "dmb"
            | "isb"
            | "pld"
    ) || base.starts_with("it");
    let two_dests = matches!(
        base,
        "ldrd" | "ldrexd" | "umull" | "smull" | "umlal" | "smlal" | "umaal"
    ) || (base == "vmov" && ops.len() >= 3);
    let dest = !no_dest && ops.first().is_some_and(|o| *o == reg);
    let second = two_dests && ops.get(1).is_some_and(|o| *o == reg);
    if second || (dest && two_dests) {
        return Write::Other;
    }
    if !dest {
        return Write::No;
    }
    if conditional {
        return Write::Other;
    }
    match (base, ops.get(1)) {
        ("mov" | "movw", Some(src)) if src.starts_with('#') => {
            src[1..].parse::<u64>().map_or(Write::Other, Write::Const)
        }
        ("mov", Some(src)) if ops.len() == 2 && !src.starts_with('#') && !names(src) => {
            Write::Copy((*src).to_string())
        }
        _ => Write::Other,
    }
}

/// The byte count of a sized library call: at least `min`, at most `max`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
struct Size {
    min: u64,
    max: u64,
}

impl Size {
    /// Whether `count <cond> k` holds for every count in the range (`Some(true)`), for none
    /// (`Some(false)`), or depends (`None`); unsigned conditions and equality only.
    fn decides(self, cond: &str, k: u64) -> Option<bool> {
        let (lt, ge) = (self.max < k, self.min >= k);
        let (gt, le) = (self.min > k, self.max <= k);
        let always = |yes: bool, no: bool| {
            if yes {
                Some(true)
            } else if no {
                Some(false)
            } else {
                None
            }
        };
        match cond {
            "cc" | "lo" => always(lt, ge),
            "cs" | "hs" => always(ge, lt),
            "hi" => always(gt, le),
            "ls" => always(le, gt),
            "eq" => always(self.min == k && self.max == k, k < self.min || k > self.max),
            "ne" => always(k < self.min || k > self.max, self.min == k && self.max == k),
            _ => None,
        }
    }
}

/// The function's graph: reached instructions, edges, callees.
struct Graph {
    /// Successors and how each edge is taken, per instruction index.
    succ: Vec<Vec<(usize, Edge)>>,
    /// Instructions reached from the entry.
    reached: Vec<bool>,
    /// The callee of a call or a tail call (its start address).
    callee: Vec<Option<u64>>,
}

impl Disassembly {
    /// Disassembles `elf` with `objdump` (`arm-none-eabi-objdump`, or the `OBJDUMP`
    /// environment variable); `addr2line` (`arm-none-eabi-addr2line`, or `ADDR2LINE`) is run
    /// on it later for the loops' sources.
    pub fn of(elf: &Path) -> Result<Self, String> {
        let objdump =
            std::env::var("OBJDUMP").unwrap_or_else(|_| "arm-none-eabi-objdump".to_string());
        let out = Command::new(&objdump)
            .args(["-d", "--no-show-raw-insn", "-C"])
            .arg(elf)
            .output()
            .map_err(|e| format!("running {objdump}: {e}"))?;
        if !out.status.success() {
            return Err(format!(
                "{objdump} failed: {}",
                String::from_utf8_lossy(&out.stderr)
            ));
        }
        let mut d = Self::parse(&String::from_utf8_lossy(&out.stdout));
        d.elf = Some(elf.to_path_buf());
        Ok(d)
    }

    /// The disassembly of an objdump text (tests of other modules).
    #[cfg(test)]
    pub fn parse_for_tests(text: &str) -> Self {
        Self::parse(text)
    }

    fn parse(text: &str) -> Self {
        let mut functions: BTreeMap<u64, Function> = BTreeMap::new();
        let mut names: HashMap<String, Vec<u64>> = HashMap::new();
        let mut current: Option<u64> = None;
        for raw in text.lines() {
            let l = raw.trim_end();
            if let Some((addr, name)) = l.strip_suffix(">:").and_then(|h| h.split_once(" <")) {
                if let Ok(addr) = u64::from_str_radix(addr, 16) {
                    functions.insert(
                        addr,
                        Function {
                            name: name.to_string(),
                            lines: Vec::new(),
                        },
                    );
                    names.entry(name.to_string()).or_default().push(addr);
                    current = Some(addr);
                }
                continue;
            }
            let Some(f) = current.and_then(|a| functions.get_mut(&a)) else {
                continue;
            };
            let Some((addr, rest)) = l.trim_start().split_once(':') else {
                continue;
            };
            let Ok(addr) = u64::from_str_radix(addr, 16) else {
                continue;
            };
            let rest = rest.trim();
            let (mnemonic, operands) = rest.split_once(char::is_whitespace).unwrap_or((rest, ""));
            // Drop objdump's comments (`@ 0x..`, `<symbol+off>` stays: it ends the target).
            let operands = operands.split('@').next().unwrap_or("").trim().to_string();
            f.lines.push(Line {
                addr,
                size: 0,
                mnemonic: mnemonic.to_string(),
                operands,
            });
        }
        // Sizes from the next line's address (across functions); the last line of the text
        // by its width suffix.
        let mut all: Vec<&mut Line> = functions
            .values_mut()
            .flat_map(|f| f.lines.iter_mut())
            .collect();
        for i in 0..all.len() {
            let next = all.get(i + 1).map(|l| l.addr);
            let l = &mut all[i];
            l.size = match next {
                Some(n) if n > l.addr && n - l.addr <= 4 => n - l.addr,
                _ if l.mnemonic.ends_with(".n") => 2,
                _ => 4,
            };
        }
        Self {
            functions,
            names,
            elf: None,
            chains: RefCell::new(HashMap::new()),
            places: RefCell::new(HashMap::new()),
        }
    }

    /// The start and name of the first function (tests of other modules).
    #[cfg(test)]
    pub fn first_function(&self) -> Option<(u64, &str)> {
        self.functions
            .iter()
            .next()
            .map(|(a, f)| (*a, f.name.as_str()))
    }

    /// The lines of the function at `addr` (tests of other modules).
    #[cfg(test)]
    pub(crate) fn lines_of(&self, addr: u64) -> &[Line] {
        self.functions
            .get(&addr)
            .map_or(&[], |f| f.lines.as_slice())
    }

    /// The region each instruction of the function at `addr` reaches with its data access
    /// (`memory.rs`, over the function's graph with every call returning: more paths than
    /// any bound's, so never more precise than it allows), by line; `None`: no access, or
    /// not placed.
    pub fn places(&self, addr: u64) -> Result<Rc<Vec<Option<Region>>>, String> {
        if let Some(p) = self.places.borrow().get(&addr) {
            return Ok(Rc::clone(p));
        }
        if !self.functions.contains_key(&addr) {
            return Err(format!("no function at {addr:#x}"));
        }
        let lines = &self.functions[&addr].lines;
        // A graph the bound itself would refuse leaves every access unplaced (the
        // conservative charge); the bound then fails on its own graph anyway.
        let p = Rc::new(match self.graph(addr, &|_| false) {
            Ok(g) => {
                let succ: Vec<Vec<usize>> = g
                    .succ
                    .iter()
                    .map(|s| s.iter().map(|&(j, _)| j).collect())
                    .collect();
                memory::places(lines, &succ)
            }
            Err(_) => vec![None; lines.len()],
        });
        self.places.borrow_mut().insert(addr, Rc::clone(&p));
        Ok(p)
    }

    /// The region the data access of the instruction at `addr` reaches (`None`: it makes
    /// none).
    pub fn region_at(&self, addr: u64) -> Result<Option<Region>, String> {
        let (&start, f) = self
            .functions
            .range(..=addr)
            .next_back()
            .ok_or_else(|| format!("{addr:#x}: in no function"))?;
        let i = f
            .lines
            .iter()
            .position(|l| l.addr == addr)
            .ok_or_else(|| format!("{addr:#x}: not an instruction of {}", f.name))?;
        Ok(self.places(start)?.get(i).copied().flatten())
    }

    /// The start address of the function named `name` (an error if none or several).
    pub fn address_of(&self, name: &str) -> Result<u64, String> {
        match self.names.get(name).map(Vec::as_slice) {
            Some([a]) => Ok(*a),
            Some([]) | None => Err(format!("function {name} not in the disassembly")),
            Some(more) => Err(format!(
                "{} functions are named {name}: the bound needs one",
                more.len()
            )),
        }
    }

    /// The instruction at `addr` (any function's): its size, mnemonic and operands.
    pub fn instruction_at(&self, addr: u64) -> Option<(u64, &str, &str)> {
        let (_, f) = self.functions.range(..=addr).next_back()?;
        let l = f.lines.iter().find(|l| l.addr == addr && !l.is_data())?;
        Some((l.size, l.mnemonic.as_str(), l.operands.as_str()))
    }

    /// Bytes of code (instructions and their literal pools) of the functions at `addrs`.
    pub fn code_bytes(&self, addrs: &BTreeSet<u64>) -> u64 {
        addrs
            .iter()
            .filter_map(|a| {
                let l = self.functions.get(a)?.lines.last()?;
                Some(l.addr + l.size - a)
            })
            .sum()
    }

    /// The name of the function at `addr` (its start).
    fn name_at(&self, addr: u64) -> &str {
        self.functions.get(&addr).map_or("?", |f| f.name.as_str())
    }

    /// Inlined function names at each address (innermost first), from `addr2line`; empty
    /// without an ELF.
    fn chains_of(&self, addrs: &[u64]) -> Result<Vec<Vec<String>>, String> {
        let missing: Vec<u64> = {
            let known = self.chains.borrow();
            addrs
                .iter()
                .copied()
                .filter(|a| !known.contains_key(a))
                .collect()
        };
        if let (Some(elf), false) = (&self.elf, missing.is_empty()) {
            let tool = std::env::var("ADDR2LINE")
                .unwrap_or_else(|_| "arm-none-eabi-addr2line".to_string());
            let out = Command::new(&tool)
                .args(["-a", "-f", "-i", "-C", "-e"])
                .arg(elf)
                .args(missing.iter().map(|a| format!("{a:#x}")))
                .output()
                .map_err(|e| format!("running {tool} (the loops' sources): {e}"))?;
            if !out.status.success() {
                return Err(format!(
                    "{tool} failed: {}",
                    String::from_utf8_lossy(&out.stderr)
                ));
            }
            let text = String::from_utf8_lossy(&out.stdout);
            let mut known = self.chains.borrow_mut();
            let mut at: Option<u64> = None;
            let mut odd = false;
            for l in text.lines() {
                if let Some(hex) = l.strip_prefix("0x") {
                    at = u64::from_str_radix(hex, 16).ok();
                    if let Some(a) = at {
                        known.entry(a).or_default();
                    }
                    odd = false;
                    continue;
                }
                // Function name, then file:line, for each inlined frame.
                if !odd && let Some(a) = at {
                    known.entry(a).or_default().push(l.trim().to_string());
                }
                odd = !odd;
            }
        }
        let known = self.chains.borrow();
        Ok(addrs
            .iter()
            .map(|a| known.get(a).cloned().unwrap_or_default())
            .collect())
    }

    /// The bound of `root` under `rules`, in `metric`.
    pub fn bound(&self, root: &str, rules: Rules<'_>, metric: Metric) -> Result<Bound, String> {
        let addr = self.address_of(root)?;
        let mut a = Analyzer {
            dis: self,
            rules,
            metric,
            memo: HashMap::new(),
            active: Vec::new(),
            calls: BTreeMap::new(),
            excluded: BTreeSet::new(),
            diverging: BTreeSet::new(),
            sized: BTreeMap::new(),
            loops: Vec::new(),
            uses_fpu: false,
            walked: BTreeSet::new(),
            placed: BTreeSet::new(),
            accesses: BTreeMap::new(),
        };
        let total = a.function(addr, None)?;
        let stack_bytes = self.stack_bound(addr, &rules, &mut Vec::new())?;
        let mut loops = a.loops;
        loops.sort_by(|x, y| (&x.function, x.ordinal).cmp(&(&y.function, y.ordinal)));
        loops.dedup();
        Ok(Bound {
            function: root.to_string(),
            longest_path: total,
            code_instructions: self.functions[&addr]
                .lines
                .iter()
                .filter(|l| !l.is_data())
                .count(),
            calls: a.calls,
            excluded_calls: a.excluded.into_iter().collect(),
            diverging_calls: a.diverging.into_iter().collect(),
            sized_calls: a.sized,
            loops,
            stack_bytes,
            uses_fpu: a.uses_fpu,
            data_accesses: a.accesses,
            code_bytes: self.code_bytes(&a.walked),
            functions: a.walked,
        })
    }

    /// The function's own stack reservation plus its deepest callee's (calls and tail calls
    /// to functions neither excluded nor diverging), bytes.
    fn stack_bound(
        &self,
        addr: u64,
        rules: &Rules<'_>,
        active: &mut Vec<u64>,
    ) -> Result<u64, String> {
        let f = &self.functions[&addr];
        if active.contains(&addr) {
            return Err(format!("recursion through {}", f.name));
        }
        let own: u64 = f.lines.iter().map(stack_reserved).sum();
        active.push(addr);
        let mut deepest = 0;
        for line in &f.lines {
            let m = strip_width(&line.mnemonic);
            if m != "bl" && m != "b" {
                continue;
            }
            let Some(callee) =
                hex_target(&line.operands).filter(|t| self.functions.contains_key(t))
            else {
                continue;
            };
            let name = self.name_at(callee);
            if callee == addr
                || rules
                    .exclude
                    .iter()
                    .chain(rules.diverging)
                    .any(|e| name.starts_with(e))
            {
                continue;
            }
            deepest = deepest.max(self.stack_bound(callee, rules, active)?);
        }
        active.pop();
        Ok(own + deepest)
    }

    /// The graph of the function at `addr`: what the entry reaches, and the callees; a call
    /// to a function `diverges` says does not return ends its path.
    fn graph(&self, addr: u64, diverges: &dyn Fn(u64) -> bool) -> Result<Graph, String> {
        let f = &self.functions[&addr];
        let (name, lines) = (&f.name, &f.lines);
        let index: HashMap<u64, usize> =
            lines.iter().enumerate().map(|(i, l)| (l.addr, i)).collect();
        let (start, end) = match (lines.first(), lines.last()) {
            (Some(a), Some(b)) => (a.addr, b.addr),
            _ => return Err(format!("function {name} is empty")),
        };
        let code = |a: u64| index.get(&a).copied().filter(|&j| !lines[j].is_data());
        let n = lines.len();
        let mut g = Graph {
            succ: vec![Vec::new(); n],
            reached: vec![false; n],
            callee: vec![None; n],
        };
        let mut work = vec![0usize];
        g.reached[0] = true;
        while let Some(i) = work.pop() {
            let line = &lines[i];
            let next = (i + 1..n).find(|&j| !lines[j].is_data());
            let table = || {
                let data: Vec<&Line> = lines[i + 1..].iter().take_while(|l| l.is_data()).collect();
                table_targets(line.addr + 4, line.mnemonic.starts_with("tbh"), &data)
            };
            let function_at = |target: u64, what: &str| -> Result<u64, String> {
                if self.functions.contains_key(&target) {
                    Ok(target)
                } else {
                    Err(format!(
                        "{name}: {what} at {:#x} to {target:#x}, not a function",
                        line.addr
                    ))
                }
            };
            let fall = |after_conditional| next.map(|j| (j, Edge::Fall { after_conditional }));
            let mut out: Vec<(usize, Edge)> = Vec::new();
            match flow(line, table) {
                Flow::Data => {}
                Flow::Next => out.extend(fall(false)),
                Flow::Branch {
                    target,
                    conditional,
                } => {
                    if (start..=end).contains(&target) {
                        let j = code(target).ok_or_else(|| {
                            format!(
                                "{name}: branch at {:#x} to {target:#x}, not an instruction",
                                line.addr
                            )
                        })?;
                        out.push((j, Edge::Taken));
                    } else {
                        // A tail call: the callee, then its return to our caller.
                        g.callee[i] = Some(function_at(target, "branch out of the function")?);
                    }
                    if conditional {
                        out.extend(fall(true));
                    }
                }
                Flow::Call(target) => {
                    let callee = function_at(target, "call")?;
                    g.callee[i] = Some(callee);
                    if !diverges(callee) {
                        out.extend(next.map(|j| (j, Edge::AfterCall)));
                    }
                }
                Flow::Return { conditional } => {
                    if conditional {
                        out.extend(fall(false));
                    }
                }
                Flow::Table(targets) => {
                    out.extend(
                        targets
                            .into_iter()
                            .filter_map(code)
                            .map(|j| (j, Edge::Taken)),
                    );
                    if out.is_empty() {
                        return Err(format!(
                            "{name}: jump table at {:#x} without targets",
                            line.addr
                        ));
                    }
                }
                Flow::Indirect => {
                    return Err(format!(
                        "{name}: indirect branch or call at {:#x} ({} {})",
                        line.addr, line.mnemonic, line.operands
                    ));
                }
            }
            for &(j, _) in &out {
                if !g.reached[j] {
                    g.reached[j] = true;
                    work.push(j);
                }
            }
            g.succ[i] = out;
        }
        Ok(g)
    }
}

/// One bound's walk over the call graph.
struct Analyzer<'a> {
    dis: &'a Disassembly,
    rules: Rules<'a>,
    metric: Metric,
    /// Bounds found, by function and size context.
    memo: HashMap<(u64, Option<Size>), u64>,
    /// The call chain being walked (recursion check).
    active: Vec<u64>,
    calls: BTreeMap<String, u64>,
    excluded: BTreeSet<String>,
    diverging: BTreeSet<String>,
    sized: BTreeMap<String, u64>,
    loops: Vec<LoopUse>,
    uses_fpu: bool,
    /// Functions walked.
    walked: BTreeSet<u64>,
    /// Functions whose data accesses are counted in `accesses`.
    placed: BTreeSet<u64>,
    /// Data-accessing instructions on some path, by the region they reach.
    accesses: BTreeMap<String, u64>,
}

impl Analyzer<'_> {
    /// The graph of the function at `addr` under the rules' diverging calls.
    fn graph(&self, addr: u64) -> Result<Graph, String> {
        self.dis.graph(addr, &|callee| self.diverges(callee))
    }

    fn diverges(&self, callee: u64) -> bool {
        let name = self.dis.name_at(callee);
        self.rules.diverging.iter().any(|d| name.starts_with(d))
    }

    /// The bound of the function at `addr`; `size`: the byte count of a sized library call
    /// being analysed (its loops are bounded by it, its first branches on it decided).
    fn function(&mut self, addr: u64, size: Option<Size>) -> Result<u64, String> {
        if let Some(&b) = self.memo.get(&(addr, size)) {
            return Ok(b);
        }
        let name = self.dis.name_at(addr).to_string();
        if self.active.contains(&addr) {
            return Err(format!("recursion through {name}"));
        }
        self.active.push(addr);
        self.walked.insert(addr);
        let result = self.function_inner(addr, size, &name);
        self.active.pop();
        let b = result?;
        self.memo.insert((addr, size), b);
        Ok(b)
    }

    fn function_inner(&mut self, addr: u64, size: Option<Size>, name: &str) -> Result<u64, String> {
        let dis = self.dis;
        let lines = &dis.functions[&addr].lines;
        let mut g = self.graph(addr)?;
        let n = lines.len();
        if let (Some(sz), Some(call)) = (size, self.rules.sized.iter().find(|c| c.symbol == name)) {
            decide_entry_branches(lines, &mut g, call.size_register, sz);
        }
        let mut preds: Vec<Vec<usize>> = vec![Vec::new(); n];
        for (i, s) in g.succ.iter().enumerate() {
            for &(j, _) in s {
                preds[j].push(i);
            }
        }
        let model = match self.metric {
            Metric::Cycles(m) => Some(m),
            Metric::Instructions => None,
        };
        let cycles = model.is_some();
        let places = dis.places(addr)?;
        let first_visit = self.placed.insert(addr);

        // Node costs (the instruction, its data access, its callee) and edge costs.
        let mut cost = vec![0u64; n];
        let mut insn: Vec<Option<cycles::Cost>> = vec![None; n];
        for i in (0..n).filter(|&i| g.reached[i]) {
            let line = &lines[i];
            self.uses_fpu |= line.mnemonic.starts_with('v');
            let region = places.get(i).copied().flatten().unwrap_or(Region::Unknown);
            if let (Some(m), true) = (model, cycles) {
                let c = cycles::cost(&line.mnemonic, &line.operands)
                    .map_err(|e| format!("{name}: at {:#x}: {e}", line.addr))?;
                let data = match &c.access {
                    Some(a) => cycles::data_cycles(m, a, region)
                        .map_err(|e| format!("{name}: at {:#x}: {e}", line.addr))?,
                    None => 0,
                };
                if first_visit && c.access.is_some() {
                    *self.accesses.entry(region.name().to_string()).or_default() += 1;
                }
                cost[i] = c.cycles + data;
                insn[i] = Some(c);
            } else {
                cost[i] = 1;
            }
            let Some(callee) = g.callee[i] else {
                continue;
            };
            let callee_name = dis.name_at(callee).to_string();
            let is_tail = !strip_width(&line.mnemonic).starts_with("bl");
            if is_tail && cycles {
                // A branch out of the function is always taken when it calls.
                cost[i] += insn[i].as_ref().map_or(0, |c| c.taken);
            }
            if self.diverges(callee) {
                self.diverging.insert(callee_name);
                continue;
            }
            if self
                .rules
                .exclude
                .iter()
                .any(|e| callee_name.starts_with(e))
            {
                self.excluded.insert(callee_name);
                continue;
            }
            let sized = self
                .rules
                .sized
                .iter()
                .find(|s| s.symbol == callee_name)
                .copied();
            let b = match (size, sized) {
                // Inside a sized call, its own callees take the same size, or the smaller one
                // declared.
                (Some(bytes), _) => {
                    let passed = self
                        .rules
                        .sized_callees
                        .iter()
                        .find(|c| c.function == name && c.callee == callee_name)
                        .map_or(bytes, |c| Size {
                            min: 0,
                            max: bytes.max.min(c.at_most_bytes),
                        });
                    self.function(callee, Some(passed))?
                }
                (None, Some(s)) => {
                    let (min, max) =
                        size_before(lines, &preds, i, s.size_register, &mut HashSet::new(), 0)
                            .ok_or_else(|| {
                                format!(
                                    "{name}: call at {:#x} to {callee_name}: its size ({}) is not a constant the analysis can follow back; bound it",
                                    line.addr, s.size_register
                                )
                            })?;
                    let b = self.function(callee, Some(Size { min, max }))?;
                    let key = if min == max {
                        format!("{callee_name} ({max} B)")
                    } else {
                        format!("{callee_name} ({min}..{max} B)")
                    };
                    self.sized.insert(key, b);
                    b
                }
                (None, None) => {
                    let b = self.function(callee, None)?;
                    // Monomorphised copies share a demangled name: keep them apart.
                    let key = if dis.names.get(&callee_name).is_some_and(|a| a.len() > 1) {
                        format!("{callee_name} @ {callee:#x}")
                    } else {
                        callee_name
                    };
                    self.calls.insert(key, b);
                    b
                }
            };
            cost[i] = cost[i].saturating_add(b);
        }
        let mut succ: Vec<Vec<(usize, u64)>> = vec![Vec::new(); n];
        for i in (0..n).filter(|&i| g.reached[i]) {
            for &(j, e) in &g.succ[i] {
                let c = match (model, insn[i].as_ref()) {
                    (None, _) => 0,
                    (Some(m), Some(here)) => cycles::transition(
                        m,
                        (lines[i].addr, lines[i].size, here),
                        (lines[j].addr, lines[j].size, &lines[j].operands),
                        e,
                    ),
                    (Some(_), None) => {
                        return Err(format!("{name}: at {:#x}: not costed", lines[i].addr));
                    }
                };
                succ[i].push((j, c));
            }
        }
        let entry_fetch = model.map_or(0, |m| cycles::fetch(m, lines[0].addr, lines[0].size));

        // Loops: find them (with their headers), number them by header address, bound them.
        let nodes: Vec<usize> = (0..n).filter(|&i| g.reached[i]).collect();
        let graph = Costed { succ, cost };
        let mut found: Vec<(usize, Vec<usize>)> = Vec::new();
        let anywhere = |_: usize, _: u64| Some(0);
        longest(
            &graph,
            &nodes,
            None,
            0,
            &anywhere,
            &mut |h, s| {
                if !found.iter().any(|(x, _)| *x == h) {
                    found.push((h, s.to_vec()));
                }
                Ok(1)
            },
            &mut Vec::new(),
        )?;
        let mut headers: Vec<usize> = found.iter().map(|(h, _)| *h).collect();
        headers.sort_unstable();
        headers.dedup();
        let mut bounds: HashMap<usize, u64> = HashMap::new();
        let mut uses = Vec::new();
        for (h, body) in &found {
            let ordinal = headers.binary_search(h).unwrap_or(0);
            let mut use_ = self.loop_bound(addr, name, ordinal, *h, body, size)?;
            use_.exclusive = body.iter().any(|&i| lines[i].mnemonic.starts_with("strex"));
            bounds.insert(*h, use_.iterations);
            uses.push((*h, use_));
        }
        let mut iterations = Vec::new();
        let body = longest(
            &graph,
            &nodes,
            None,
            0,
            &anywhere,
            &mut |h, _| {
                bounds.get(&h).copied().ok_or_else(|| {
                    format!("{name}: a loop at {:#x} was not bounded", lines[h].addr)
                })
            },
            &mut iterations,
        )?
        .ok_or_else(|| format!("{name}: no path from its entry ends"))?;
        for (h, mut use_) in uses {
            use_.iteration = iterations
                .iter()
                .filter(|(x, _)| *x == h)
                .map(|(_, v)| *v)
                .max()
                .unwrap_or(0);
            self.loops.push(use_);
        }
        Ok(entry_fetch.saturating_add(body))
    }

    /// The declared bound of loop `ordinal` of the function (or the size of a sized call's
    /// loops), checked against the loop as it is.
    fn loop_bound(
        &self,
        addr: u64,
        name: &str,
        ordinal: usize,
        header: usize,
        body: &[usize],
        size: Option<Size>,
    ) -> Result<LoopUse, String> {
        let lines = &self.dis.functions[&addr].lines;
        let h = &lines[header];
        let mut use_ = LoopUse {
            function: name.to_string(),
            ordinal,
            header: format!("{:#x}", h.addr),
            offset: h.addr - addr,
            instructions: body.len(),
            source: String::new(),
            iterations: 0,
            reason: String::new(),
            iteration: 0,
            exclusive: false,
        };
        if let Some(Size { max: bytes, .. }) = size {
            use_.function = format!("{name} ({bytes} B)");
            let declared = self
                .rules
                .sized_loops
                .iter()
                .find(|b| b.function == name && b.ordinal == ordinal);
            let stale = |d: &SizedLoop| d.instructions != body.len();
            match declared {
                Some(d) if !stale(d) || self.rules.discover => {
                    let handled = d.at_most_bytes.map_or(bytes, |m| bytes.min(m));
                    use_.iterations = handled.div_ceil(d.bytes_per_iteration.max(1));
                    use_.reason = if stale(d) {
                        format!(
                            "STALE (declared for {} instructions): {}",
                            d.instructions, d.reason
                        )
                    } else {
                        d.reason.to_string()
                    };
                    return Ok(use_);
                }
                _ if self.rules.discover => {
                    use_.reason = "UNDECLARED".to_string();
                    return Ok(use_);
                }
                Some(d) => {
                    return Err(format!(
                        "loop {ordinal} of {name} at {} (+{:#x}): {} instructions, its declared bound (task.rs, SIZED_LOOPS) is for {}: stale",
                        use_.header,
                        use_.offset,
                        body.len(),
                        d.instructions
                    ));
                }
                None => {
                    return Err(format!(
                        "loop {ordinal} of {name} at {} (+{:#x}, {} instructions) has no declared bound (task.rs, SIZED_LOOPS)",
                        use_.header,
                        use_.offset,
                        body.len()
                    ));
                }
            }
        }
        let addrs: Vec<u64> = body.iter().map(|&i| lines[i].addr).collect();
        let chains = self.dis.chains_of(&addrs)?;
        let head = self.dis.chains_of(&[h.addr])?;
        use_.source = head
            .first()
            .map(|c| c.iter().take(4).cloned().collect::<Vec<_>>().join(" < "))
            .unwrap_or_default();
        let describe = |u: &LoopUse| {
            format!(
                "loop {} of {name} at {} (+{:#x}, {} instructions; source: {})",
                u.ordinal,
                u.header,
                u.offset,
                u.instructions,
                if u.source.is_empty() { "?" } else { &u.source }
            )
        };
        let Some(declared) = self
            .rules
            .loops
            .iter()
            .find(|b| b.function == name && b.ordinal == ordinal)
        else {
            if self.rules.discover {
                use_.reason = "UNDECLARED".to_string();
                return Ok(use_);
            }
            return Err(format!(
                "{} has no declared bound (task.rs, LOOPS)",
                describe(&use_)
            ));
        };
        let frames: HashSet<&str> = chains.iter().flatten().map(String::as_str).collect();
        let missing: Vec<&str> = declared
            .source
            .iter()
            .copied()
            .filter(|s| !frames.iter().any(|f| f.contains(s)))
            .collect();
        let stale = declared.instructions != body.len() || !missing.is_empty();
        if stale && self.rules.discover {
            use_.iterations = declared.iterations;
            use_.reason = format!(
                "STALE (declared for {} instructions, {:?}): {}",
                declared.instructions, declared.source, declared.reason
            );
            return Ok(use_);
        }
        if stale {
            return Err(format!(
                "{}: its declared bound is stale (declared for {} instructions of {:?}; {}): check the reason ({}) and update task.rs",
                describe(&use_),
                declared.instructions,
                declared.source,
                if missing.is_empty() {
                    "the size changed".to_string()
                } else {
                    format!("not found in its source: {missing:?}")
                },
                declared.reason
            ));
        }
        use_.iterations = declared.iterations;
        use_.reason = declared.reason.to_string();
        Ok(use_)
    }
}

/// The byte count in `reg` just before instruction `at` runs, following it back through every
/// path (a constant, or a copy of another register) to its definitions: the smallest and the
/// largest of them, or `None` when any path gives something else (or loops, or runs too
/// long).
fn size_before(
    lines: &[Line],
    preds: &[Vec<usize>],
    at: usize,
    reg: &str,
    seen: &mut HashSet<(usize, String)>,
    depth: usize,
) -> Option<(u64, u64)> {
    if depth > 256 || !seen.insert((at, reg.to_string())) || preds[at].is_empty() {
        return None;
    }
    let (mut low, mut high) = (u64::MAX, 0);
    for &p in &preds[at] {
        let line = &lines[p];
        let v = if strip_width(&line.mnemonic) == "bl" {
            // A call clobbers the argument registers.
            if ["r0", "r1", "r2", "r3", "ip", "r12", "lr"].contains(&reg) {
                None
            } else {
                size_before(lines, preds, p, reg, seen, depth + 1)
            }
        } else {
            match writes(line, reg) {
                Write::No => size_before(lines, preds, p, reg, seen, depth + 1),
                Write::Const(c) => Some((c, c)),
                Write::Copy(src) => size_before(lines, preds, p, &src, seen, depth + 1),
                Write::Other => None,
            }
        };
        let (a, b) = v?;
        (low, high) = (low.min(a), high.max(b));
    }
    Some((low, high))
}

/// Removes the edges a sized function's first branches on its byte count cannot take: from
/// the entry, along the one path, while `reg` is unchanged, a `cmp reg, #k` directly followed
/// by a conditional branch that the count's range decides.
fn decide_entry_branches(lines: &[Line], g: &mut Graph, reg: &str, size: Size) {
    let mut at = 0;
    let mut compared: Option<u64> = None;
    for _ in 0..32 {
        let line = &lines[at];
        let base = cycles::base(&line.mnemonic);
        let mut next = match g.succ[at].as_slice() {
            [(j, _)] => Some(*j),
            _ => None,
        };
        match base {
            Some(("cmp", false)) => {
                let ops: Vec<&str> = line.operands.split(',').map(str::trim).collect();
                compared = match ops.as_slice() {
                    [r, k] if *r == reg => k.strip_prefix('#').and_then(|k| k.parse().ok()),
                    _ => None,
                };
            }
            Some(("b", true)) => {
                let cond = strip_width(&line.mnemonic).strip_prefix('b').unwrap_or("");
                let decision = compared.and_then(|k| size.decides(cond, k));
                if let Some(taken) = decision {
                    g.succ[at].retain(|&(_, e)| (e == Edge::Taken) == taken);
                    next = match g.succ[at].as_slice() {
                        [(j, _)] => Some(*j),
                        _ => None,
                    };
                }
                compared = None;
            }
            _ => {
                compared = None;
                if !matches!(writes(line, reg), Write::No) {
                    break;
                }
            }
        }
        match next {
            Some(j) => at = j,
            None => break,
        }
    }
    // What the removed edges no longer reach.
    let mut reached = vec![false; lines.len()];
    let mut work = vec![0usize];
    reached[0] = true;
    while let Some(i) = work.pop() {
        for &(j, _) in &g.succ[i] {
            if !reached[j] {
                reached[j] = true;
                work.push(j);
            }
        }
    }
    for (i, r) in reached.into_iter().enumerate() {
        if !r {
            g.succ[i].clear();
        }
        g.reached[i] = r;
    }
}

/// A function's graph with its costs: per node, and per edge.
struct Costed {
    succ: Vec<Vec<(usize, u64)>>,
    cost: Vec<u64>,
}

/// Strongly connected components of `nodes` under `next`, in reverse topological order (a
/// component comes after every component it reaches). Iterative Tarjan.
fn components(nodes: &[usize], n: usize, next: &dyn Fn(usize) -> Vec<usize>) -> Vec<Vec<usize>> {
    const NONE: usize = usize::MAX;
    let mut index = vec![NONE; n];
    let mut low = vec![0usize; n];
    let mut on_stack = vec![false; n];
    let mut stack: Vec<usize> = Vec::new();
    let mut out: Vec<Vec<usize>> = Vec::new();
    let mut counter = 0usize;
    for &root in nodes {
        if index[root] != NONE {
            continue;
        }
        // (node, its successors, the next successor to visit)
        let mut call: Vec<(usize, Vec<usize>, usize)> = Vec::new();
        index[root] = counter;
        low[root] = counter;
        counter += 1;
        stack.push(root);
        on_stack[root] = true;
        call.push((root, next(root), 0));
        while let Some(top) = call.len().checked_sub(1) {
            let (v, k) = (call[top].0, call[top].2);
            if let Some(&w) = call[top].1.get(k) {
                call[top].2 += 1;
                if index[w] == NONE {
                    index[w] = counter;
                    low[w] = counter;
                    counter += 1;
                    stack.push(w);
                    on_stack[w] = true;
                    call.push((w, next(w), 0));
                } else if on_stack[w] {
                    low[v] = low[v].min(index[w]);
                }
            } else {
                call.pop();
                if let Some(parent) = call.last() {
                    let p = parent.0;
                    low[p] = low[p].min(low[v]);
                }
                if low[v] == index[v] {
                    let mut comp = Vec::new();
                    while let Some(w) = stack.pop() {
                        on_stack[w] = false;
                        comp.push(w);
                        if w == v {
                            break;
                        }
                    }
                    comp.sort_unstable();
                    out.push(comp);
                }
            }
        }
    }
    out
}

/// Asked for each loop's header and body: its iterations bound.
type LoopBounder<'a> = dyn FnMut(usize, &[usize]) -> Result<u64, String> + 'a;

/// What an edge `(v, cost)` leaving a region's internal nodes (to its header, or out of the
/// region) adds to the path that takes it; `None`: the path may not end that way.
type Terminal<'a> = dyn Fn(usize, u64) -> Option<u64> + 'a;

/// The longest path from `entry` through `region` (sorted node indices), the edges into
/// `header` and out of the region ending it with the value `terminal` gives (`None`: no path
/// may end there); a node without successors (a return) ends a path with its own cost. Each
/// loop inside (a component with a cycle, entered only at its header) becomes one node: its
/// `bound` n (at most n passes back to its header per entry: iterations of its body) times
/// its dearest pass around (from the header back to it), plus its dearest last pass (from the
/// header to an exit, and on from there). `bound` is asked for each loop's header and body,
/// and each loop's header and dearest pass around go to `iterations`. `None`: no path from
/// the entry ends as allowed.
fn longest(
    g: &Costed,
    region: &[usize],
    header: Option<usize>,
    entry: usize,
    terminal: &Terminal<'_>,
    bound: &mut LoopBounder<'_>,
    iterations: &mut Vec<(usize, u64)>,
) -> Result<Option<u64>, String> {
    let n = g.cost.len();
    let mut inside = vec![false; n];
    for &u in region {
        inside[u] = true;
    }
    let internal_node = |v: usize| inside[v] && Some(v) != header;
    let internal = |u: usize| -> Vec<usize> {
        g.succ[u]
            .iter()
            .map(|&(v, _)| v)
            .filter(|&v| internal_node(v))
            .collect()
    };
    let comps = components(region, n, &internal);
    let mut value: Vec<Option<u64>> = vec![None; n];
    // What taking an edge to `v` of cost `c` adds after the node it leaves.
    let edge = |value: &[Option<u64>], v: usize, c: u64| -> Option<u64> {
        if internal_node(v) {
            value[v].map(|x| c.saturating_add(x))
        } else {
            terminal(v, c)
        }
    };
    let mut comp_of = vec![usize::MAX; n];
    for (k, comp) in comps.iter().enumerate() {
        for &u in comp {
            comp_of[u] = k;
        }
    }
    for (k, comp) in comps.iter().enumerate() {
        let cyclic = comp.len() > 1
            || g.succ[comp[0]]
                .iter()
                .any(|&(v, _)| v == comp[0] && Some(v) != header);
        if !cyclic {
            let u = comp[0];
            let tail = if g.succ[u].is_empty() {
                Some(0)
            } else {
                g.succ[u]
                    .iter()
                    .filter_map(|&(v, c)| edge(&value, v, c))
                    .max()
            };
            value[u] = tail.map(|t| g.cost[u].saturating_add(t));
            continue;
        }
        // The loop's entries: nodes entered from another component of the region, or the
        // region's entry.
        let mut entries: Vec<usize> = comp
            .iter()
            .copied()
            .filter(|&v| {
                v == entry
                    || region.iter().any(|&u| {
                        comp_of[u] != k
                            && Some(v) != header
                            && g.succ[u].iter().any(|&(t, _)| t == v)
                    })
            })
            .collect();
        entries.dedup();
        let h = match entries.as_slice() {
            [h] => *h,
            _ => {
                return Err(format!(
                    "a loop with {} entries (nodes {entries:?}): not a natural loop",
                    entries.len()
                ));
            }
        };
        let count = bound(h, comp)?;
        let mut in_comp = vec![false; n];
        for &u in comp {
            in_comp[u] = true;
        }
        let exits = comp
            .iter()
            .any(|&u| g.succ[u].is_empty() || g.succ[u].iter().any(|&(v, _)| !in_comp[v]));
        if !exits {
            return Err("a loop without an exit".to_string());
        }
        // A pass around: from the header back to it.
        let around = |v: usize, c: u64| (v == h).then_some(c);
        let iteration = longest(g, comp, Some(h), h, &around, bound, iterations)?;
        // The last pass: from the header out of the loop (never back to it), and on.
        let last = {
            let value = &value;
            let out = |v: usize, c: u64| if v == h { None } else { edge(value, v, c) };
            longest(g, comp, Some(h), h, &out, bound, iterations)?
        };
        if let Some(i) = iteration {
            iterations.push((h, i));
        }
        value[h] = last.map(|l| {
            count
                .saturating_mul(iteration.unwrap_or(0))
                .saturating_add(l)
        });
    }
    Ok(value[entry])
}

#[cfg(test)]
mod tests {
    use super::*;

    const SAMPLE: &str = "
08000100 <leaf>:
 8000100:	push	{r7, lr}
 8000102:	cmp	r0, #1
 8000104:	beq.n	800010a <leaf+0xa>
 8000106:	adds	r0, #1
 8000108:	adds	r0, #1
 800010a:	pop	{r7, pc}

0800010c <root>:
 800010c:	push	{r4, lr}
 800010e:	cbz	r0, 800011c <root+0x10>
 8000110:	bl	8000100 <leaf>
 8000114:	tbb	[pc, r1]
 8000118:	.word	0x00000201
 800011c:	movs	r0, #0
 800011e:	pop	{r4, pc}
";

    fn instructions(d: &Disassembly, f: &str, rules: Rules<'_>) -> Result<u64, String> {
        d.bound(f, rules, Metric::Instructions)
            .map(|b| b.longest_path)
    }

    fn cycles(d: &Disassembly, f: &str, rules: Rules<'_>, model: Model) -> Result<u64, String> {
        d.bound(f, rules, Metric::Cycles(model))
            .map(|b| b.longest_path)
    }

    #[test]
    fn longest_path_takes_calls_and_tables() {
        let d = Disassembly::parse(SAMPLE);
        assert_eq!(instructions(&d, "leaf", Rules::default()), Ok(6));
        // push, cbz, bl (+6), tbb, then the table's targets (entries 1 and 2 before the
        // lowest target: 0x11a, 0x11c; only 0x11c is an instruction): movs, pop.
        let b = d
            .bound("root", Rules::default(), Metric::Instructions)
            .expect("root");
        assert_eq!(b.longest_path, 1 + 1 + (1 + 6) + 1 + 1 + 1);
        assert_eq!(b.calls.get("leaf"), Some(&6));
        let without = d
            .bound(
                "root",
                Rules {
                    exclude: &["leaf"],
                    ..Rules::default()
                },
                Metric::Instructions,
            )
            .expect("root");
        assert_eq!(without.excluded_calls, ["leaf"]);
    }

    #[test]
    fn a_jump_table_ends_at_its_lowest_target_and_its_nop_padding_is_no_entry() {
        // A tbb table of four entries (3, 0xdd, 0x6f, 0x99) and the nop (0xbf00) that aligns
        // the code after it, as objdump prints them: a `.short` and a `.word`. Read as four
        // bytes a line, or with the nop as two entries, it would add 0x..60e + 2 * 0xbf.
        let line = |addr, mnemonic: &str, operands: &str| Line {
            addr,
            size: 0,
            mnemonic: mnemonic.to_string(),
            operands: operands.to_string(),
        };
        let short = line(0x800_260e, ".short", "0xdd03");
        let word = line(0x800_2610, ".word", "0xbf00996f");
        let base = 0x800_260e;
        assert_eq!(
            table_targets(base, false, &[&short, &word]),
            [base + 6, base + 2 * 0xdd, base + 2 * 0x6f, base + 2 * 0x99]
        );
        // Without the nop (0x1100 is no instruction of padding), the two bytes before the
        // lowest target are entries too.
        let word = line(0x800_2610, ".word", "0x1100996f");
        assert_eq!(table_targets(base, false, &[&short, &word]).len(), 6);
        // Halfwords: 0x0003, 0x0010, then code from base + 6.
        let word = line(base, ".word", "0x00100003");
        assert_eq!(table_targets(base, true, &[&word]), [base + 6, base + 0x20]);
    }

    #[test]
    fn stack_adds_the_pushes_and_the_deepest_callee() {
        let d = Disassembly::parse(
            "
08000100 <leaf>:
 8000100:	push	{r4, r5, r7, lr}
 8000102:	vpush	{d8-d9}
 8000104:	sub	sp, #8
 8000106:	add	sp, #8
 8000108:	vpop	{d8-d9}
 800010a:	pop	{r4, r5, r7, pc}

0800010c <root>:
 800010c:	push	{r7, lr}
 800010e:	stmdb	sp!, {r8, r9}
 8000112:	bl	8000100 <leaf>
 8000116:	ldmia.w	sp!, {r8, r9}
 800011a:	pop	{r7, pc}
",
        );
        let stack = |f| {
            d.bound(f, Rules::default(), Metric::Instructions)
                .expect(f)
                .stack_bytes
        };
        assert_eq!(stack("leaf"), 16 + 16 + 8);
        assert_eq!(stack("root"), 8 + 8 + 40);
    }

    /// A straight line, a conditional branch, a call and a return, costed by hand.
    #[test]
    fn cycles_of_a_hand_made_snippet() {
        let d = Disassembly::parse(
            "
08000200 <callee>:
 8000200:	bx	lr

08000210 <snippet>:
 8000210:	push	{r4, lr}
 8000212:	ldr	r0, [pc, #12]
 8000214:	vdiv.f32	s0, s1, s2
 8000218:	vadd.f32	s3, s0, s4
 800021c:	cmp	r0, #0
 800021e:	beq.n	8000224 <snippet+0x14>
 8000220:	bl	8000200 <callee>
 8000224:	pop	{r4, pc}
",
        );
        let p = cycles::REFILL;
        // Zero wait states: callee bx lr = 1 + P.
        let callee = 1 + p;
        // push 1+2, ldr 2, vdiv 14 (+1: vadd names s0), vadd 1, cmp 1, beq 1 (not taken),
        // bl 1 + P + callee, pop 1 + 2 + P.
        let zero = 3 + 2 + 14 + 1 + 1 + 1 + 1 + (1 + p + callee) + (3 + p);
        assert_eq!(
            cycles(&d, "snippet", Rules::default(), Model::ALL_HIT),
            Ok(zero)
        );
        // With 5 wait states: the entry's line (0x210), the line at 0x220 entered, the
        // literal (a flash data line), the beq's speculative target fetch, the callee's
        // entry line, and the line re-fetched after the call (0x224): six accesses.
        let w = cycles::WAIT_STATES;
        assert_eq!(
            cycles(&d, "snippet", Rules::default(), Model::ALL_MISS),
            Ok(zero + 6 * w)
        );
        // The taken branch instead (beq to the pop): 1 + P + the target's line, no call;
        // shorter than the call's path.
        assert_eq!(instructions(&d, "snippet", Rules::default()), Ok(8 + 1));
    }

    /// The same load through an address built by movw/movt (SRAM; a USART register) and
    /// through an argument's pointer: only the unplaced one pays the flash miss.
    #[test]
    fn a_load_the_tracking_places_in_sram_costs_no_wait_state() {
        let d = Disassembly::parse(
            "
08000100 <sram>:
 8000100:	movw	r1, #0
 8000104:	movt	r1, #8192	@ 0x2000
 8000108:	ldr	r0, [r1, #4]
 800010a:	bx	lr

08000110 <unplaced>:
 8000110:	movw	r2, #0
 8000114:	movt	r2, #8192	@ 0x2000
 8000118:	ldr	r0, [r1, #4]
 800011a:	bx	lr

08000120 <usart>:
 8000120:	movw	r1, #4096	@ 0x1000
 8000124:	movt	r1, #16385	@ 0x4001
 8000128:	ldr	r0, [r1, #4]
 800012a:	bx	lr
",
        );
        let c = |f, m| cycles(&d, f, Rules::default(), m).expect(f);
        let (w, p) = (cycles::WAIT_STATES, cycles::REFILL);
        // movw 1, movt 1, ldr 2, bx 1 + P; one line entered.
        let base = 1 + 1 + 2 + (1 + p);
        assert_eq!(c("sram", Model::ALL_HIT), base);
        assert_eq!(c("sram", Model::ALL_MISS), base + w);
        assert_eq!(c("unplaced", Model::ALL_HIT), base);
        assert_eq!(
            c("unplaced", Model::ALL_MISS),
            base + w + w,
            "the load's miss"
        );
        // An APB2 register: its bus's latency, with or without the flash's wait states.
        assert_eq!(c("usart", Model::ALL_HIT), base + cycles::APB2_ACCESS);
        assert_eq!(c("usart", Model::ALL_MISS), base + w + cycles::APB2_ACCESS);
        let b = d
            .bound("usart", Rules::default(), Metric::Cycles(Model::ALL_MISS))
            .expect("usart");
        assert_eq!(b.data_accesses.get("apb2"), Some(&1));
    }

    const LOOP: &str = "
08000100 <spin>:
 8000100:	movs	r1, #0
 8000102:	adds	r1, #1
 8000104:	subs	r0, #1
 8000106:	bne.n	8000102 <spin+0x2>
 8000108:	bx	lr
";

    #[test]
    fn a_loop_without_a_declared_bound_is_an_error_naming_it() {
        let d = Disassembly::parse(LOOP);
        let e = instructions(&d, "spin", Rules::default()).expect_err("a loop");
        assert!(
            e.contains("loop 0 of spin at 0x8000102") && e.contains("no declared bound"),
            "{e}"
        );
    }

    #[test]
    fn a_declared_bound_multiplies_the_iteration() {
        let d = Disassembly::parse(LOOP);
        let rules = |iterations, instructions| {
            [LoopBound {
                function: "spin",
                ordinal: 0,
                source: &[],
                instructions,
                iterations,
                reason: "test",
            }]
        };
        // movs, then n passes around (adds, subs, bne back to the header) and the last pass
        // out (the same three, the bne falling through), then bx.
        for n in [1u64, 10, 100] {
            let loops = rules(n, 3);
            let r = Rules {
                loops: &loops,
                ..Rules::default()
            };
            assert_eq!(instructions(&d, "spin", r), Ok(1 + (n + 1) * 3 + 1));
        }
        // Cycles at zero wait states: a pass around is adds 1, subs 1, bne 1 + P (taken); the
        // last pass's bne is not taken.
        let loops = rules(10, 3);
        let r = Rules {
            loops: &loops,
            ..Rules::default()
        };
        let p = cycles::REFILL;
        assert_eq!(
            cycles(&d, "spin", r, Model::ALL_HIT),
            Ok(1 + 10 * (3 + p) + 3 + (1 + p))
        );
        // A declaration for another shape of loop is stale.
        let loops = rules(10, 4);
        let e = instructions(
            &d,
            "spin",
            Rules {
                loops: &loops,
                ..Rules::default()
            },
        )
        .expect_err("stale");
        assert!(e.contains("stale"), "{e}");
    }

    /// A loop tested at its top: its last pass is the test alone, not a whole iteration
    /// (the old (n + 1) x the dearest iteration charged the body once more).
    #[test]
    fn the_last_pass_of_a_loop_tested_at_its_top_is_its_test() {
        let d = Disassembly::parse(
            "
08000100 <top>:
 8000100:	movs	r1, #0
 8000102:	cmp	r0, #0
 8000104:	beq.n	800010e <top+0xe>
 8000106:	adds	r1, #1
 8000108:	adds	r1, #1
 800010a:	subs	r0, #1
 800010c:	b.n	8000102 <top+0x2>
 800010e:	bx	lr
",
        );
        let loops = [LoopBound {
            function: "top",
            ordinal: 0,
            source: &[],
            instructions: 6,
            iterations: 10,
            reason: "test",
        }];
        let r = Rules {
            loops: &loops,
            ..Rules::default()
        };
        // movs, 10 passes of six, the last test (cmp, beq), bx.
        assert_eq!(instructions(&d, "top", r), Ok(1 + 10 * 6 + 2 + 1));
        let p = cycles::REFILL;
        // A pass: cmp 1, beq 1 (not taken), three adds/subs, b 1 + P; the last: cmp, beq taken
        // 1 + P; bx 1 + P.
        assert_eq!(
            cycles(&d, "top", r, Model::ALL_HIT),
            Ok(1 + 10 * (2 + 3 + 1 + p) + (1 + 1 + p) + (1 + p))
        );
        // No pass at all: the test alone.
        let none = [LoopBound {
            iterations: 0,
            ..loops[0]
        }];
        let r = Rules {
            loops: &none,
            ..Rules::default()
        };
        assert_eq!(instructions(&d, "top", r), Ok(1 + 2 + 1));
    }

    #[test]
    fn nested_loops_multiply() {
        let d = Disassembly::parse(
            "
08000100 <nest>:
 8000100:	movs	r2, #4
 8000102:	movs	r3, #8
 8000104:	subs	r3, #1
 8000106:	bne.n	8000104 <nest+0x4>
 8000108:	subs	r2, #1
 800010a:	bne.n	8000102 <nest+0x2>
 800010c:	bx	lr
",
        );
        let loops = [
            LoopBound {
                function: "nest",
                ordinal: 0,
                source: &[],
                instructions: 5,
                iterations: 4,
                reason: "outer",
            },
            LoopBound {
                function: "nest",
                ordinal: 1,
                source: &[],
                instructions: 2,
                iterations: 8,
                reason: "inner",
            },
        ];
        let r = Rules {
            loops: &loops,
            ..Rules::default()
        };
        // Inner: (8 + 1) x 2; outer iteration: movs, inner, subs, bne; (4 + 1) of them.
        let inner = 9 * 2;
        assert_eq!(instructions(&d, "nest", r), Ok(1 + 5 * (1 + inner + 2) + 1));
    }

    #[test]
    fn a_sized_call_is_costed_for_the_size_on_every_path() {
        let d = Disassembly::parse(
            "
08000100 <copy>:
 8000100:	subs	r2, #1
 8000102:	bne.n	8000100 <copy>
 8000104:	bx	lr

08000110 <user>:
 8000110:	push	{r7, lr}
 8000112:	cbz	r0, 800011a <user+0xa>
 8000114:	movs	r5, #3
 8000116:	b.n	800011c <user+0xc>
 8000118:	nop
 800011a:	movs	r5, #5
 800011c:	mov	r2, r5
 800011e:	bl	8000100 <copy>
 8000122:	pop	{r7, pc}
",
        );
        let sized = [SizedCall {
            symbol: "copy",
            size_register: "r2",
        }];
        let sized_loops = [SizedLoop {
            function: "copy",
            ordinal: 0,
            instructions: 2,
            bytes_per_iteration: 1,
            at_most_bytes: None,
            reason: "a byte an iteration",
        }];
        let r = Rules {
            sized: &sized,
            sized_loops: &sized_loops,
            ..Rules::default()
        };
        let b = d.bound("user", r, Metric::Instructions).expect("user");
        // The larger size (5) of the two paths (3 or 5): copy is (5 + 1) x 2 + 1.
        let copy = 6 * 2 + 1;
        assert_eq!(b.sized_calls.get("copy (3..5 B)"), Some(&copy));
        assert_eq!(b.longest_path, 1 + 1 + 1 + 1 + 1 + (1 + copy) + 1);
        // Without a constant on some path, it is an error naming the call.
        let d = Disassembly::parse(
            "
08000100 <copy>:
 8000100:	subs	r2, #1
 8000102:	bne.n	8000100 <copy>
 8000104:	bx	lr

08000110 <user>:
 8000110:	push	{r7, lr}
 8000112:	ldr	r2, [r0]
 8000114:	bl	8000100 <copy>
 8000118:	pop	{r7, pc}
",
        );
        let e = d
            .bound("user", r, Metric::Instructions)
            .expect_err("unbounded size");
        assert!(e.contains("call at 0x8000114 to copy"), "{e}");
    }

    #[test]
    fn a_sized_call_leaves_out_the_branches_its_size_rules_out() {
        // `copy` takes a long path for 16 bytes or more; a 5-byte call never does.
        let d = Disassembly::parse(
            "
08000100 <copy>:
 8000100:	cmp	r2, #16
 8000102:	bcc.n	800010e <copy+0xe>
 8000104:	adds	r0, #1
 8000106:	adds	r0, #1
 8000108:	adds	r0, #1
 800010a:	adds	r0, #1
 800010c:	adds	r0, #1
 800010e:	bx	lr

08000110 <user>:
 8000110:	push	{r7, lr}
 8000112:	movs	r2, #5
 8000114:	bl	8000100 <copy>
 8000118:	movs	r2, #20
 800011a:	bl	8000100 <copy>
 800011e:	pop	{r7, pc}
",
        );
        let sized = [SizedCall {
            symbol: "copy",
            size_register: "r2",
        }];
        let r = Rules {
            sized: &sized,
            ..Rules::default()
        };
        let b = d.bound("user", r, Metric::Instructions).expect("user");
        assert_eq!(b.sized_calls.get("copy (5 B)"), Some(&3), "cmp, bcc, bx");
        assert_eq!(b.sized_calls.get("copy (20 B)"), Some(&8), "the long path");
    }

    #[test]
    fn an_unknown_mnemonic_is_an_error_in_cycles_only() {
        let d = Disassembly::parse(
            "
08000100 <odd>:
 8000100:	frob	r0, r1
 8000104:	bx	lr
",
        );
        assert_eq!(instructions(&d, "odd", Rules::default()), Ok(2));
        let e = cycles(&d, "odd", Rules::default(), Model::ALL_MISS).expect_err("unknown");
        assert!(e.contains("`frob`") && e.contains("0x8000100"), "{e}");
    }

    #[test]
    fn a_diverging_call_ends_the_path() {
        let d = Disassembly::parse(
            "
08000100 <panic>:
 8000100:	b.n	8000100 <panic>

08000110 <guarded>:
 8000110:	cbz	r0, 8000118 <guarded+0x8>
 8000112:	bl	8000100 <panic>
 8000116:	nop
 8000118:	bx	lr
",
        );
        // Without the rule, panic's endless loop is an error; with it, the path ends.
        assert!(instructions(&d, "guarded", Rules::default()).is_err());
        let b = d
            .bound(
                "guarded",
                Rules {
                    diverging: &["panic"],
                    ..Rules::default()
                },
                Metric::Instructions,
            )
            .expect("guarded");
        assert_eq!(b.longest_path, 2);
        assert_eq!(b.diverging_calls, ["panic"]);
    }
}
