//! The cycle model applied to the control step as it ran, path by path: `--path-cycles ELF`.
//!
//! Place in the data flow: a development measurement beside the gate, not in it. It runs the
//! `qemu` firmware built with the `bench` feature (its scripted sortie through every path of
//! the step, `firmware/src/bench.rs`) in QEMU with `-icount shift=0 -d exec,nochain,in_asm`,
//! reads every executed instruction of every `Controller::step` call from QEMU's log, and
//! costs that exact instruction stream with the static bound's cycle model
//! ([`crate::cycles`]: each instruction, each taken or not-taken branch as it went, each flash
//! line entered, the same memory assumptions). The sortie's own report gives each path's
//! largest instruction count; the step calls with that count (less the fixed cost of the
//! benchmark's timing around the call, found from the largest of all) are the path's, and
//! their largest modelled cycles are reported.
//!
//! Invariants: the figures are the model's, on the path the code took: not a measurement of
//! cycles on a board, and each is checked to be within the static bound of the same ELF (a
//! modelled run above it would be a fault of the analysis, and fails). The script's steps
//! are the last calls of the step in the run, and their count must be the sortie's.

use std::collections::HashMap;
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::Command;

use serde::Serialize;
use serde_json::Value;

use crate::cycles::{self, Model, Pass};
use crate::memory::Region;
use crate::task;
use crate::wcet::{Disassembly, Metric, Rules};

type Error = Box<dyn std::error::Error>;

/// One path of the sortie.
#[derive(Debug, Clone, Serialize)]
pub struct PathCycles {
    /// The path (`firmware/src/bench.rs`, `PATHS`).
    pub path: String,
    /// Its largest instruction count as the sortie measured it (TIM2, the timing included).
    pub instructions: u64,
    /// The step calls with that count.
    pub calls: usize,
    /// Their largest modelled cycles, every flash access a miss (the bound's model).
    pub cycles: u64,
    /// The same in microseconds at 168 MHz.
    pub us: f64,
    /// Modelled at zero wait states.
    pub cycles_zero_wait: u64,
    /// The same in microseconds.
    pub us_zero_wait: f64,
    /// The path's arithmetic floor: the floating-point adds, subtracts, multiplies,
    /// multiply-adds, divisions and square roots it executed, one each ([`is_arithmetic`];
    /// the fewest of its calls').
    pub arithmetic: u64,
    /// Its instructions (the step call's own, without the timing) per arithmetic
    /// instruction: how far the path is from its floor.
    pub over_floor: f64,
}

/// What `--path-cycles` reports.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// Per path.
    pub paths: Vec<PathCycles>,
    /// The instructions the sortie's timing adds to a step call's own.
    pub timing_instructions: u64,
    /// The largest of any script step, modelled (every miss; zero wait states).
    pub max_cycles: u64,
    pub max_cycles_zero_wait: u64,
    /// The static bounds of the same ELF's step (instructions; cycles every miss; zero wait).
    pub bound_instructions: u64,
    pub bound_cycles: u64,
    pub bound_cycles_zero_wait: u64,
}

/// One instruction as the model costs it.
struct Costed {
    size: u64,
    operands: String,
    cost: cycles::Cost,
    arithmetic: bool,
    /// Where its data access goes (`memory.rs`, as the bound places it).
    region: Region,
}

/// One step call's figures: instructions, cycles (every miss), cycles (zero wait states),
/// floating-point arithmetic instructions.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
struct Call {
    instructions: u64,
    miss: u64,
    hit: u64,
    arithmetic: u64,
}

/// A floating-point arithmetic instruction: the work the step's equations ask for (add,
/// subtract, multiply, the fused and chained multiply-adds, negated products, divide, square
/// root; one each, whatever its cycles). Loads, stores, moves, compares, conversions,
/// absolute values and negations, branches and integer bookkeeping are the rest.
fn is_arithmetic(mnemonic: &str) -> bool {
    const OPS: [&str; 14] = [
        "vadd", "vsub", "vmul", "vnmul", "vmla", "vmls", "vnmla", "vnmls", "vfma", "vfms", "vfnma",
        "vfnms", "vdiv", "vsqrt",
    ];
    let op = mnemonic.split('.').next().unwrap_or(mnemonic);
    // Condition codes (`vaddeq.f32`, in IT blocks) are not part of the operation.
    OPS.iter().any(|o| {
        op.strip_prefix(o)
            .is_some_and(|cc| cc.is_empty() || cc.len() == 2)
    })
}

/// Costs an executed instruction stream with the model: each instruction, and each passage
/// to the next as it went (fall-through or taken).
struct Meter<'a> {
    dis: &'a Disassembly,
    known: HashMap<u64, Costed>,
}

impl Meter<'_> {
    fn costed(&mut self, addr: u64) -> Result<&Costed, String> {
        if !self.known.contains_key(&addr) {
            let (size, mnemonic, operands) = self
                .dis
                .instruction_at(addr)
                .ok_or_else(|| format!("executed {addr:#x}: not an instruction of the ELF"))?;
            let cost =
                cycles::cost(mnemonic, operands).map_err(|e| format!("at {addr:#x}: {e}"))?;
            let region = self.dis.region_at(addr)?.unwrap_or(Region::Unknown);
            self.known.insert(
                addr,
                Costed {
                    size,
                    operands: operands.to_string(),
                    cost,
                    arithmetic: is_arithmetic(mnemonic),
                    region,
                },
            );
        }
        self.known
            .get(&addr)
            .ok_or_else(|| format!("{addr:#x}: not costed"))
    }

    /// The floating-point arithmetic instructions among `stream`'s ([`is_arithmetic`]).
    fn arithmetic(&mut self, stream: &[u64]) -> Result<u64, String> {
        let mut n = 0;
        for &addr in stream {
            n += u64::from(self.costed(addr)?.arithmetic);
        }
        Ok(n)
    }

    /// The model's cycles of `stream` (executed addresses, in order) for `model`.
    fn cycles(&mut self, stream: &[u64], model: Model) -> Result<u64, String> {
        let mut total = 0;
        let mut prev: Option<(u64, u64, cycles::Cost)> = None;
        for &addr in stream {
            let c = self.costed(addr)?;
            let (size, here, region) = (c.size, c.cost.clone(), c.region);
            let operands = c.operands.clone();
            total += match &prev {
                None => cycles::fetch(model, addr, size),
                Some((pa, ps, pc)) => {
                    let pass = if addr == pa + ps {
                        Pass::Fall {
                            after_conditional: pc.taken > 0,
                        }
                    } else if pc.taken == 0 {
                        // Calls, returns, table branches: the refill is in their cycles.
                        Pass::AfterCall
                    } else {
                        Pass::Taken
                    };
                    cycles::transition(model, (*pa, *ps, pc), (addr, size, &operands), pass)
                }
            };
            let data = match &here.access {
                Some(a) => cycles::data_cycles(model, a, region)
                    .map_err(|e| format!("at {addr:#x}: {e}"))?,
                None => 0,
            };
            total += here.cycles + data;
            prev = Some((addr, size, here));
        }
        Ok(total)
    }
}

/// QEMU's log: the translation blocks' instructions and the order they ran in, calling `each`
/// with every block executed (its instruction addresses). A block logged as entered and then
/// "Stopped execution of TB chain before" it (an exit request or the instruction budget
/// checked at its start, under `-icount`) ran no instruction and is left out.
fn replay_log(log: &Path, mut each: impl FnMut(&[u64]) -> Result<(), String>) -> Result<(), Error> {
    let f = std::fs::File::open(log).map_err(|e| format!("{}: {e}", log.display()))?;
    let mut blocks: HashMap<String, Vec<u64>> = HashMap::new();
    let mut listing: Option<Vec<u64>> = None;
    let mut pending: Option<Vec<u64>> = None;
    // The block last entered, run once the next line shows it was not stopped.
    let mut entered: Option<String> = None;
    let mut run = |key: Option<String>, blocks: &HashMap<String, Vec<u64>>| -> Result<(), String> {
        match key {
            Some(k) => each(blocks.get(&k).map_or(&[][..], Vec::as_slice)),
            None => Ok(()),
        }
    };
    for line in BufReader::new(f).lines() {
        let line = line?;
        if line.starts_with("Stopped execution of TB chain before") {
            entered = None;
            continue;
        }
        if line.starts_with("IN:") {
            listing = Some(Vec::new());
            continue;
        }
        if let Some(l) = listing.as_mut() {
            if let Some(rest) = line.strip_prefix("0x") {
                let hex = rest.split(':').next().unwrap_or("");
                if let Ok(a) = u64::from_str_radix(hex, 16) {
                    l.push(a);
                }
                continue;
            }
            pending = listing.take().filter(|l| !l.is_empty());
        }
        // "Trace N: 0x<host> [<cs_base>/<pc>/<flags>/<cflags>] name": the block's key is the
        // bracket (a block is translated again under other flags); a new key takes the
        // listing just printed.
        let Some(bracket) = line
            .strip_prefix("Trace ")
            .and_then(|r| r.split_once('['))
            .and_then(|(_, r)| r.split_once(']'))
            .map(|(b, _)| b)
        else {
            continue;
        };
        let pc = bracket
            .split('/')
            .nth(1)
            .and_then(|h| u64::from_str_radix(h, 16).ok());
        if !blocks.contains_key(bracket)
            && let Some(p) = pending.take_if(|p| p.first().copied() == pc)
        {
            blocks.insert(bracket.to_string(), p);
        }
        if !blocks.contains_key(bracket) {
            return Err(format!("QEMU log: a block ran before its listing ({bracket})").into());
        }
        run(entered.replace(bracket.to_string()), &blocks)?;
    }
    run(entered, &blocks)?;
    Ok(())
}

/// Runs the `bench` ELF in QEMU with the execution log; the sortie's JSON report (parsed and
/// as printed) and the log's path.
fn run_bench(elf: &Path, dir: &Path) -> Result<(Value, String, std::path::PathBuf), Error> {
    std::fs::create_dir_all(dir)?;
    let log = dir.join("exec.log");
    let out = Command::new("qemu-system-arm")
        .args([
            "-machine",
            "netduinoplus2",
            "-cpu",
            "cortex-m4",
            "-icount",
            "shift=0",
            "-display",
            "none",
            "-monitor",
            "none",
            "-serial",
            "null",
            "-semihosting-config",
            "enable=on,target=native,arg=firmware,arg=bench",
            "-d",
            "exec,nochain,in_asm",
            "-D",
        ])
        .arg(&log)
        .arg("-kernel")
        .arg(elf)
        .output()
        .map_err(|e| format!("running qemu-system-arm: {e}"))?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    let json = stdout
        .lines()
        .find_map(|l| {
            l.strip_prefix("firmware bench: {")
                .map(|r| format!("{{{r}"))
        })
        .ok_or_else(|| {
            format!(
                "no bench report from {} (built with --features qemu,bench?):\n{stdout}",
                elf.display()
            )
        })?;
    let report: Value = serde_json::from_str(&json)?;
    if report["script_ok"] != Value::Bool(true) {
        return Err(format!("the sortie did not visit every path: {json}").into());
    }
    Ok((report, json, log))
}

/// The modelled cycles of every path of the `bench` ELF's sortie (`--path-cycles`).
pub fn path_cycles(elf: &Path, work_dir: &Path) -> Result<Report, Error> {
    let dis = Disassembly::of(elf)?;
    let step = dis.address_of(task::STEP)?;
    let rules = Rules {
        exclude: &[task::PBVS],
        ..Rules::default()
    };
    let bound_instructions = dis
        .bound(task::STEP, rules, Metric::Instructions)?
        .longest_path;
    let bound_cycles = dis
        .bound(task::STEP, rules, Metric::Cycles(Model::ALL_MISS))?
        .longest_path;
    let bound_cycles_zero_wait = dis
        .bound(task::STEP, rules, Metric::Cycles(Model::ALL_HIT))?
        .longest_path;

    let (report, printed, log) = run_bench(elf, work_dir)?;
    // Every step call's executed instructions: from the step's entry to the instruction after
    // the call that entered it.
    let mut meter = Meter {
        dis: &dis,
        known: HashMap::new(),
    };
    let mut calls: Vec<Call> = Vec::new();
    let mut stream: Vec<u64> = Vec::new();
    let mut back_to: Option<u64> = None;
    let mut last: u64 = 0;
    replay_log(&log, |block| {
        let Some(&first) = block.first() else {
            return Ok(());
        };
        if let Some(ret) = back_to {
            if first == ret {
                let instructions = stream.len() as u64;
                let miss = meter.cycles(&stream, Model::ALL_MISS)?;
                let hit = meter.cycles(&stream, Model::ALL_HIT)?;
                let arithmetic = meter.arithmetic(&stream)?;
                calls.push(Call {
                    instructions,
                    miss,
                    hit,
                    arithmetic,
                });
                stream.clear();
                back_to = None;
            } else {
                stream.extend_from_slice(block);
            }
        } else if first == step {
            let (size, _, _) = dis
                .instruction_at(last)
                .ok_or_else(|| format!("the step entered from {last:#x}, not an instruction"))?;
            back_to = Some(last + size);
            stream.extend_from_slice(block);
        }
        last = *block.last().unwrap_or(&first);
        Ok(())
    })?;
    let _ = std::fs::remove_file(&log);
    let _ = std::fs::remove_dir(work_dir);

    let steps = report["steps"].as_u64().ok_or("bench report: no steps")? as usize;
    let script = calls
        .len()
        .checked_sub(steps)
        .map(|k| &calls[k..])
        .ok_or_else(|| format!("{} step calls traced, the sortie ran {steps}", calls.len()))?;
    let step_max = report["step_max"]
        .as_u64()
        .ok_or("bench report: no step_max")?;
    let traced_max = script.iter().map(|c| c.instructions).max().unwrap_or(0);
    let timing = step_max
        .checked_sub(traced_max)
        .filter(|t| *t < 64)
        .ok_or_else(|| {
            format!("the sortie's step maximum {step_max} and the traced {traced_max} do not match")
        })?;
    for c in script {
        if c.instructions > bound_instructions
            || c.miss > bound_cycles
            || c.hit > bound_cycles_zero_wait
        {
            return Err(format!(
                "a step call modelled above the static bound ({c:?}; bounds {bound_instructions} instructions, {bound_cycles} and {bound_cycles_zero_wait} cycles): the analysis is wrong"
            )
            .into());
        }
    }
    let per_path = report["step"]
        .as_object()
        .ok_or("bench report: no step paths")?;
    let mut paths = Vec::new();
    for (path, measured) in per_path {
        let instructions = measured
            .as_u64()
            .ok_or("bench report: a path without a count")?;
        let with: Vec<&Call> = script
            .iter()
            .filter(|c| c.instructions + timing == instructions)
            .collect();
        let miss = with.iter().map(|c| c.miss).max().ok_or_else(|| {
            format!("path {path}: no traced step call of {instructions} instructions")
        })?;
        let hit = with.iter().map(|c| c.hit).max().unwrap_or(0);
        let arithmetic = with.iter().map(|c| c.arithmetic).min().unwrap_or(0);
        paths.push(PathCycles {
            path: path.clone(),
            instructions,
            calls: with.len(),
            cycles: miss,
            us: task::micros(miss),
            cycles_zero_wait: hit,
            us_zero_wait: task::micros(hit),
            arithmetic,
            over_floor: (instructions - timing) as f64 / arithmetic.max(1) as f64,
        });
    }
    // In the sortie's order, as it printed them.
    paths.sort_by_key(|p| printed.find(&format!("\"{}\":", p.path)));
    Ok(Report {
        paths,
        timing_instructions: timing,
        max_cycles: script.iter().map(|c| c.miss).max().unwrap_or(0),
        max_cycles_zero_wait: script.iter().map(|c| c.hit).max().unwrap_or(0),
        bound_instructions,
        bound_cycles,
        bound_cycles_zero_wait,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A step-like function run as a stream: the model's cycles of a straight line, a taken
    /// branch and a not-taken one.
    #[test]
    fn a_traced_stream_is_costed_as_it_went() {
        let dis = Disassembly::parse_for_tests(
            "
08000100 <f>:
 8000100:	cmp	r0, #0
 8000102:	beq.n	8000108 <f+0x8>
 8000104:	adds	r0, #1
 8000106:	adds	r0, #1
 8000108:	bx	lr
",
        );
        let mut m = Meter {
            dis: &dis,
            known: HashMap::new(),
        };
        let p = cycles::REFILL;
        let w = cycles::WAIT_STATES;
        // Taken: cmp 1, beq 1 + P, bx 1 + P; the entry's line only (all in one line).
        let taken = [0x800_0100, 0x800_0102, 0x800_0108];
        assert_eq!(m.cycles(&taken, Model::ALL_HIT), Ok(1 + (1 + p) + (1 + p)));
        // The branch target is fetched again: one more line.
        assert_eq!(
            m.cycles(&taken, Model::ALL_MISS),
            Ok(1 + (1 + p) + (1 + p) + 2 * w)
        );
        // Not taken: cmp, beq, adds, adds, bx; the speculative fetch of the target.
        let fall = [0x800_0100, 0x800_0102, 0x800_0104, 0x800_0106, 0x800_0108];
        assert_eq!(m.cycles(&fall, Model::ALL_HIT), Ok(1 + 1 + 1 + 1 + (1 + p)));
        assert_eq!(
            m.cycles(&fall, Model::ALL_MISS),
            Ok(1 + 1 + 1 + 1 + (1 + p) + 2 * w)
        );
        assert!(m.cycles(&[0x800_0200], Model::ALL_HIT).is_err());
    }

    #[test]
    fn a_block_stopped_before_it_ran_is_left_out() {
        let log = std::env::temp_dir().join(format!("target-bench-log-{}", std::process::id()));
        std::fs::write(
            &log,
            "IN: f
0x08000100:  2000  movs r0, #0
0x08000102:  4770  bx lr

Trace 0: 0x7f00 [00800400/08000100/00000010/ff020200] f
Stopped execution of TB chain before 0x7f00 [08000100] f
Trace 0: 0x7f00 [00800400/08000100/00000010/ff020200] f
----------------
IN: g
0x08000200:  2001  movs r0, #1

Trace 0: 0x7f80 [00800400/08000200/00000010/ff020200] g
Trace 0: 0x7f00 [00800400/08000100/00000010/ff020200] f
",
        )
        .expect("writing the log");
        let mut ran: Vec<Vec<u64>> = Vec::new();
        replay_log(&log, |b| {
            ran.push(b.to_vec());
            Ok(())
        })
        .expect("the log");
        let _ = std::fs::remove_file(&log);
        let f = vec![0x800_0100, 0x800_0102];
        assert_eq!(ran, [f.clone(), vec![0x800_0200], f]);
    }

    #[test]
    fn the_floor_counts_floating_point_arithmetic_only() {
        for m in [
            "vadd.f32",
            "vsub.f32",
            "vmul.f32",
            "vfma.f32",
            "vfms.f32",
            "vnmul.f32",
            "vdiv.f32",
            "vsqrt.f32",
            "vmla.f32",
            "vaddeq.f32",
            "vfnms.f32",
        ] {
            assert!(is_arithmetic(m), "{m}");
        }
        for m in [
            "vldr",
            "vstr",
            "vmov",
            "vmov.f32",
            "vcmp.f32",
            "vcmpe.f32",
            "vcvt.s32.f32",
            "vabs.f32",
            "vneg.f32",
            "vmrs",
            "vpush",
            "add",
            "mul",
            "vsel",
            "vmaxnm.f32",
            "vaddw",
        ] {
            assert!(!is_arithmetic(m), "{m}");
        }
    }
}
