//! A static bound on a function's instructions: the longest path through its machine code.
//!
//! Reads `arm-none-eabi-objdump -d` of the ELF, builds the control-flow graph of the root
//! function instruction by instruction (fall-through, direct and conditional branches,
//! `cbz`/`cbnz`, `tbb`/`tbh` jump tables read from the table words, returns by `pop`/`ldm`
//! of `pc` or `bx lr`, tail calls by `b.w` out of the function) and takes the longest path
//! from the entry to a return. A call (`bl`) adds the callee's own longest path, found the
//! same way. What it refuses, as an error naming the address: a cycle (a loop, whose
//! iterations the graph cannot bound), an indirect branch or call, a recursive call.
//!
//! The bound is an over-estimate: every path the graph allows counts, including paths no
//! input can take (two exclusive modes, all error branches at once), and every instruction
//! of an IT block counts whether or not its condition holds (QEMU's `-icount` counts them
//! too). It is in instructions, the unit of the measured figures; cycles on the board also
//! depend on the flash wait states and on 14-cycle divisions (`docs/benchmarks.md`).

use std::collections::{BTreeMap, HashMap};
use std::path::Path;
use std::process::Command;

use serde::Serialize;

/// One decoded line of the disassembly.
#[derive(Debug, Clone)]
struct Line {
    addr: u64,
    mnemonic: String,
    operands: String,
}

/// The disassembly, by function.
pub struct Disassembly {
    functions: HashMap<String, Vec<Line>>,
    by_addr: BTreeMap<u64, String>,
}

/// The bound of one function.
#[derive(Debug, Clone, Serialize)]
pub struct Bound {
    /// The function.
    pub function: String,
    /// Instructions on the longest path, callees included.
    pub longest_path_instructions: u64,
    /// Instructions in the function's own code (not its callees).
    pub code_instructions: usize,
    /// Callees on some path, with their own bounds.
    pub calls: BTreeMap<String, u64>,
    /// Callees left out of the bound (the caller's configuration never reaches them).
    pub excluded_calls: Vec<String>,
    /// Stack the function and its deepest chain of callees reserve, bytes: the sum of each
    /// one's pushes and `sub sp` (static; the paint-and-scan figure is measured).
    pub stack_bytes: u64,
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

impl Disassembly {
    /// Disassembles `elf` with `objdump` (`arm-none-eabi-objdump`, or the `OBJDUMP`
    /// environment variable).
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
        Ok(Self::parse(&String::from_utf8_lossy(&out.stdout)))
    }

    fn parse(text: &str) -> Self {
        let mut functions: HashMap<String, Vec<Line>> = HashMap::new();
        let mut by_addr = BTreeMap::new();
        let mut current: Option<String> = None;
        for raw in text.lines() {
            let l = raw.trim_end();
            if let Some(name) = l
                .strip_suffix(">:")
                .and_then(|h| h.split_once(" <"))
                .map(|(addr, name)| (addr, name.to_string()))
            {
                if let Ok(addr) = u64::from_str_radix(name.0, 16) {
                    by_addr.insert(addr, name.1.clone());
                    functions.entry(name.1.clone()).or_default();
                    current = Some(name.1);
                }
                continue;
            }
            let Some(f) = &current else { continue };
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
            if let Some(lines) = functions.get_mut(f) {
                lines.push(Line {
                    addr,
                    mnemonic: mnemonic.to_string(),
                    operands,
                });
            }
        }
        Self { functions, by_addr }
    }

    fn function_at(&self, addr: u64) -> Option<&String> {
        self.by_addr.get(&addr)
    }

    /// The longest path through `root`; callees whose names start with one of `exclude` are
    /// counted as their call instruction only.
    pub fn bound(&self, root: &str, exclude: &[&str]) -> Result<Bound, String> {
        let mut memo = HashMap::new();
        let mut excluded = Vec::new();
        let mut calls = BTreeMap::new();
        let total = self.function_bound(
            root,
            exclude,
            &mut memo,
            &mut Vec::new(),
            &mut excluded,
            &mut calls,
        )?;
        excluded.sort();
        excluded.dedup();
        let stack_bytes = self.stack_bound(root, exclude, &mut Vec::new())?;
        Ok(Bound {
            stack_bytes,
            function: root.to_string(),
            longest_path_instructions: total,
            code_instructions: self.functions.get(root).map_or(0, |l| {
                l.iter().filter(|x| !x.mnemonic.starts_with('.')).count()
            }),
            calls,
            excluded_calls: excluded,
        })
    }

    fn function_bound(
        &self,
        name: &str,
        exclude: &[&str],
        memo: &mut HashMap<String, u64>,
        active: &mut Vec<String>,
        excluded: &mut Vec<String>,
        calls: &mut BTreeMap<String, u64>,
    ) -> Result<u64, String> {
        if let Some(&b) = memo.get(name) {
            return Ok(b);
        }
        if active.iter().any(|a| a == name) {
            return Err(format!("recursion through {name}"));
        }
        let lines = self
            .functions
            .get(name)
            .ok_or_else(|| format!("function {name} not in the disassembly"))?;
        let index: HashMap<u64, usize> =
            lines.iter().enumerate().map(|(i, l)| (l.addr, i)).collect();
        let (start, end) = match (lines.first(), lines.last()) {
            (Some(a), Some(b)) => (a.addr, b.addr),
            _ => return Err(format!("function {name} is empty")),
        };
        active.push(name.to_string());

        // Successors and call costs of the instructions reachable from the entry (only
        // those: padding after the last return may decode as anything). Data words are not
        // instructions.
        let mut succ: Vec<Vec<usize>> = vec![Vec::new(); lines.len()];
        let mut cost: Vec<u64> = vec![1; lines.len()];
        let is_data: Vec<bool> = lines.iter().map(|l| l.mnemonic.starts_with('.')).collect();
        let code = |addr: u64| index.get(&addr).copied().filter(|&j| !is_data[j]);
        let mut reached = vec![false; lines.len()];
        let mut work = vec![0usize];
        reached[0] = true;
        while let Some(i) = work.pop() {
            let line = &lines[i];
            let next = (i + 1..lines.len()).find(|&j| !lines[j].mnemonic.starts_with('.'));
            let table = || {
                // Halfwords (tbh) or bytes (tbb) from the `.word`s that follow; targets are
                // the table's address plus twice the entry. Entries landing elsewhere than on
                // an instruction of this function are padding.
                let base = line.addr + 4;
                let mut entries = Vec::new();
                for w in lines[i + 1..]
                    .iter()
                    .take_while(|l| l.mnemonic.starts_with('.'))
                {
                    let v =
                        u64::from_str_radix(w.operands.trim_start_matches("0x"), 16).unwrap_or(0);
                    if line.mnemonic.starts_with("tbh") {
                        entries.extend([v & 0xFFFF, v >> 16]);
                    } else {
                        entries.extend((0..4).map(|k| (v >> (8 * k)) & 0xFF));
                    }
                }
                entries.into_iter().map(|e| base + 2 * e).collect()
            };
            let to = |addr: u64, succ: &mut Vec<usize>| -> Result<(), String> {
                match code(addr) {
                    Some(j) => {
                        succ.push(j);
                        Ok(())
                    }
                    None => Err(format!(
                        "{name}: branch at {:#x} to {addr:#x}, not an instruction",
                        line.addr
                    )),
                }
            };
            match flow(line, table) {
                Flow::Data => {}
                Flow::Next => {
                    if let Some(j) = next {
                        succ[i].push(j);
                    }
                }
                Flow::Branch {
                    target,
                    conditional,
                } => {
                    if (start..=end).contains(&target) {
                        to(target, &mut succ[i])?;
                    } else {
                        // A tail call: the callee, then its return.
                        let callee = self
                            .function_at(target)
                            .ok_or_else(|| {
                                format!(
                                    "{name}: branch at {:#x} out of the function to {target:#x}",
                                    line.addr
                                )
                            })?
                            .clone();
                        cost[i] += self.callee(&callee, exclude, memo, active, excluded, calls)?;
                    }
                    if conditional && let Some(j) = next {
                        succ[i].push(j);
                    }
                }
                Flow::Call(target) => {
                    let callee = self
                        .function_at(target)
                        .ok_or_else(|| {
                            format!(
                                "{name}: call at {:#x} to {target:#x}, not a function",
                                line.addr
                            )
                        })?
                        .clone();
                    cost[i] += self.callee(&callee, exclude, memo, active, excluded, calls)?;
                    if let Some(j) = next {
                        succ[i].push(j);
                    }
                }
                Flow::Return { conditional } => {
                    if conditional && let Some(j) = next {
                        succ[i].push(j);
                    }
                }
                Flow::Table(targets) => {
                    succ[i].extend(targets.into_iter().filter_map(code));
                    if succ[i].is_empty() {
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
            for &j in &succ[i] {
                if !reached[j] {
                    reached[j] = true;
                    work.push(j);
                }
            }
        }

        // Longest path from the entry, by depth-first search; a node met again on the current
        // path closes a cycle.
        const UNSEEN: u8 = 0;
        const OPEN: u8 = 1;
        const DONE: u8 = 2;
        let mut state = vec![UNSEEN; lines.len()];
        let mut best = vec![0u64; lines.len()];
        let mut stack: Vec<(usize, usize)> = vec![(0, 0)];
        state[0] = OPEN;
        while let Some(top) = stack.len().checked_sub(1) {
            let (node, k) = stack[top];
            if k < succ[node].len() {
                let s = succ[node][k];
                stack[top].1 += 1;
                match state[s] {
                    UNSEEN => {
                        state[s] = OPEN;
                        stack.push((s, 0));
                    }
                    OPEN => {
                        active.pop();
                        return Err(format!(
                            "{name}: a loop: the branch at {:#x} goes back to {:#x}",
                            lines[node].addr, lines[s].addr
                        ));
                    }
                    _ => {}
                }
            } else {
                let tail = succ[node].iter().map(|&s| best[s]).max().unwrap_or(0);
                best[node] = cost[node] + tail;
                state[node] = DONE;
                stack.pop();
            }
        }
        active.pop();
        memo.insert(name.to_string(), best[0]);
        Ok(best[0])
    }

    /// The function's own stack reservation plus its deepest callee's (calls and tail calls
    /// to functions not excluded), bytes.
    fn stack_bound(
        &self,
        name: &str,
        exclude: &[&str],
        active: &mut Vec<String>,
    ) -> Result<u64, String> {
        if active.iter().any(|a| a == name) {
            return Err(format!("recursion through {name}"));
        }
        let lines = self
            .functions
            .get(name)
            .ok_or_else(|| format!("function {name} not in the disassembly"))?;
        let own: u64 = lines.iter().map(stack_reserved).sum();
        active.push(name.to_string());
        let mut deepest = 0;
        for line in lines {
            let m = strip_width(&line.mnemonic);
            if m != "bl" && m != "b" {
                continue;
            }
            let Some(callee) = hex_target(&line.operands).and_then(|t| self.function_at(t)) else {
                continue;
            };
            if callee == name || exclude.iter().any(|e| callee.starts_with(e)) {
                continue;
            }
            let callee = callee.clone();
            deepest = deepest.max(self.stack_bound(&callee, exclude, active)?);
        }
        active.pop();
        Ok(own + deepest)
    }

    fn callee(
        &self,
        callee: &str,
        exclude: &[&str],
        memo: &mut HashMap<String, u64>,
        active: &mut Vec<String>,
        excluded: &mut Vec<String>,
        calls: &mut BTreeMap<String, u64>,
    ) -> Result<u64, String> {
        if exclude.iter().any(|e| callee.starts_with(e)) {
            excluded.push(callee.to_string());
            return Ok(0);
        }
        let b = self.function_bound(callee, exclude, memo, active, excluded, calls)?;
        calls.insert(callee.to_string(), b);
        Ok(b)
    }
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

    #[test]
    fn longest_path_takes_calls_and_tables() {
        let d = Disassembly::parse(SAMPLE);
        assert_eq!(
            d.bound("leaf", &[])
                .expect("leaf")
                .longest_path_instructions,
            6
        );
        // push, cbz, bl (+6), tbb, then the table's targets (0x11a, 0x11c, 0x118: only 0x11c
        // is an instruction): movs, pop.
        let b = d.bound("root", &[]).expect("root");
        assert_eq!(b.longest_path_instructions, 1 + 1 + (1 + 6) + 1 + 1 + 1);
        assert_eq!(b.calls.get("leaf"), Some(&6));
        let without = d.bound("root", &["leaf"]).expect("root");
        assert_eq!(without.excluded_calls, ["leaf"]);
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
        assert_eq!(d.bound("leaf", &[]).expect("leaf").stack_bytes, 16 + 16 + 8);
        assert_eq!(d.bound("root", &[]).expect("root").stack_bytes, 8 + 8 + 40);
    }

    #[test]
    fn a_loop_is_refused() {
        let looped = "
08000100 <spin>:
 8000100:	subs	r0, #1
 8000102:	bne.n	8000100 <spin>
 8000104:	bx	lr
";
        let d = Disassembly::parse(looped);
        let e = d.bound("spin", &[]).expect_err("a loop");
        assert!(e.contains("loop"), "{e}");
    }
}
