//! # target-bench: what the flight controller costs on its MCU, as one JSON document
//!
//! ```sh
//! cargo run --release -p target-bench                 # the JSON document
//! cargo run --release -p target-bench -- --detail     # plus every workload
//! cargo run --release -p target-bench -- --check benchmarks/expected.json
//! cargo run --release -p target-bench -- --loops      # the loops and their bounds
//! cargo run --release -p target-bench -- --path-cycles BENCH_ELF # per path
//! cargo run --release -p target-bench -- --qemu-elf A --f405-elf B   # other builds
//! ```
//!
//! A tool of its own, beside the simulator: it reads the firmware's ELFs and flies them. The
//! simulator (`host-sim`) only lends it the docking runs it records and the link to the
//! firmware in QEMU (`host_sim::pil`).
//!
//! # What it assumes of an ELF
//!
//! Any build of this workspace's `firmware` crate can be pointed at (`--qemu-elf`,
//! `--f405-elf`, or the environment variables below): another compiler, other optimisation
//! settings, a changed core. What it relies on:
//! - **The firmware's names.** The step is the function `ibvs_core::controller::Controller::step`
//!   and the control task is what `firmware::app::App::on_bytes` (lockstep) and
//!   `App::on_periods` (free-running) reach, less what [`task`] leaves out by name (the other
//!   frame kinds, the PBVS law); the symbols are read demangled
//!   (`arm-none-eabi-objdump -d -C`), so an ELF without them (or stripped) has no static
//!   bound: the figures are `null` and the gate fails.
//! - **Its loops declared.** Every loop of the control task's machine code needs a bound in
//!   [`task`]'s table, keyed by function and source line (`arm-none-eabi-addr2line`, so the
//!   ELF keeps its debug line information); an undeclared loop, recursion or an indirect call
//!   leaves the bound `null`, and `--loops` lists what to declare.
//! - **The machine.** Thumb-2 for a Cortex-M4F, the STM32F405's memory map (flash at
//!   `0x0800_0000`, SRAM and CCM as `memory.x` places them) and its timing at 168 MHz with
//!   5 flash wait states ([`cycles`], [`memory`]; the assumptions are written into the report's
//!   `assumptions`); another MCU needs another cycle model.
//! - **The `qemu` board's protocol** for the replay: it boots in QEMU's `netduinoplus2`
//!   (`qemu-system-arm`, `-icount shift=0`: TIM2 counts instructions), speaks the core's wire
//!   protocol on its serial port in lockstep (`host_sim::pil`) and logs its stack high-water
//!   marks by semihosting. The `f405` board's ELF is only read (sizes, static bounds): its clock
//!   setup waits for a crystal QEMU does not emulate.
//! - **The tools on `PATH`**: `qemu-system-arm`, `arm-none-eabi-objdump`,
//!   `arm-none-eabi-addr2line` (or the binutils named by `OBJDUMP` and `ADDR2LINE`).
//!
//! # Method (`docs/benchmarks.md`)
//!
//! 1. Record: the in-process controller (default configuration, the one the firmware runs)
//!    flies several docking scenarios in the simulator (calm air with the wake, hose and LED
//!    camera; the ideal world; level II turbulence (a missed approach and a docking);
//!    the bow wave; 50 % frame loss; three runs
//!    that break away: 90 % frame loss, a frozen tracker, a slow throttle (overspeed)), and
//!    every step's [`ControllerInput`] is kept; each must end as named, and together they
//!    must fly every mode of the procedure, or the run fails. Two more input
//!    sequences are derived from recorded ones: the navigation lost mid-approach (hold, then
//!    breakaway open loop) and a docking held then lost (docked, then breakaway).
//! 2. Replay: each sequence goes through the `qemu` firmware in QEMU's emulated STM32F405
//!    (`host_sim::pil`, lockstep, `-icount shift=0`: TIM2 counts instructions exactly), one
//!    measurement frame per step. Every command frame must equal the in-process controller's
//!    output for the same input (bit for bit on every field); its `Cost` gives the step's,
//!    the frame decode's and the previous frame encode's instructions. The firmware paints
//!    the stack below the stack pointer before each step and scans it after, and logs each
//!    new maximum (the control path's stack high-water mark).
//! 3. Sizes: flash (vector table, code, read-only data, initial values of `.data`) and static
//!    RAM (`.data`, `.bss`, `.uninit`) read from the section headers of both boards' ELFs.
//!
//! The `f405` board cannot run under QEMU (its clock setup waits for a crystal QEMU does not
//! emulate): its step, codec and stack figures are `null` here and are measured on the board
//! in DWT cycles (`docs/benchmarks.md`, "On hardware").
//!
//! Firmware ELFs: `--qemu-elf` / `IBVS_FIRMWARE_ELF` and `--f405-elf` /
//! `IBVS_FIRMWARE_F405_ELF`; otherwise the default release builds' paths under the workspace's
//! target directory (`target/qemu/thumbv7em-none-eabihf/release/firmware` and
//! `target/thumbv7em-none-eabihf/release/firmware`, as `scripts/test-all.sh` builds them),
//! which must exist: nothing is built here, and a missing ELF is an error naming the command
//! that builds it.
//!
//! Static bounds (when `arm-none-eabi-objdump` and `arm-none-eabi-addr2line` are installed,
//! [`wcet`], [`cycles`], [`task`]), from each ELF's machine code, `null` when they cannot be
//! had (the reason on stderr):
//! - the longest path through `Controller::step`, callees included, the PBVS law excluded
//!   (the firmware flies IBVS): `step_instructions_bound`, and in Cortex-M4 cycles at
//!   168 MHz with 5 flash wait states, every flash access a miss: `step_cycles_bound`,
//!   `step_us_bound`;
//! - the whole control task, from the last byte of a measurement frame to the command frame
//!   in the buffer handed to the UART, for the board's schedule (`qemu`: lockstep, `f405`:
//!   free-running): the decode, the step, the gain schedule's follow-up and the encode,
//!   their loops bounded by declared iteration counts (`task::LOOPS`): instructions
//!   (`cycle_instructions_bound`), and cycles and microseconds with the USART1 and SysTick
//!   interrupts that can land on it (`cycle_cycles_bound`, `cycle_us_bound`); what they
//!   assume is under `assumptions`. `--loops` lists every loop and its bound, and fails
//!   when one is undeclared or stale.
//! - `--path-cycles` ([`paths`]): the cycle model applied to the step as it ran, path by path,
//!   in the `bench` build's scripted sortie (QEMU's execution log), each within the bound.
//!
//! `--check FILE` compares the step's maximum instructions, its static bounds (which must
//! exist: a loop without a declared bound, recursion or an indirect call makes them `null`
//! and fails the check), the whole control task's instruction and cycle bounds, the codec's
//! maxima, the control-path stack and the flash of each board with the expectations in FILE
//! (`benchmarks/expected.json`) and exits with status 1 when one grew past its expectation
//! plus the file's tolerance, when a figure exceeds its hard budget (the file's `budgets`:
//! the flash, static RAM and stack targets set when the firmware was first benchmarked,
//! docs/benchmarks.md), or when a declared loop bound matches no loop (stale).

mod cycles;
mod elf;
mod memory;
mod paths;
mod task;
mod wcet;

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use autopilot_link::session::{MAX_BURST_LEN, Session, SessionConfig};
use clap::Parser;
use host_sim::pil::{self, PilFlightComputer};
use host_sim::scenario::ScenarioFile;
use host_sim::sim::{self, FlightComputer, Scenario};
use host_sim::world::faults::{Actuator, FaultKind, SimFault};
use ibvs_core::nav::NavSample;
use ibvs_core::wire::CostUnit;
use ibvs_core::{Controller, ControllerConfig, ControllerInput, ControllerOutput, Mode};
use serde::Serialize;
use serde_json::{Value, json};

/// Environment variable naming a prebuilt `f405` firmware ELF.
const F405_ELF_ENV: &str = "IBVS_FIRMWARE_F405_ELF";

/// The semihosting log line of a new control-path stack maximum (firmware `board::qemu`).
const CONTROL_STACK_MARK: &str = "control-path stack high-water mark ";
/// The semihosting log line fragment of the whole firmware's stack high-water mark.
const FIRMWARE_STACK_MARK: &str = "; stack high-water mark ";

#[derive(Parser)]
#[command(
    name = "target-bench",
    about = "Target benchmarks of the flight controller (QEMU's STM32F405, both boards' sizes) as JSON"
)]
struct Args {
    /// The `qemu` board's ELF (default: `IBVS_FIRMWARE_ELF`, or build it).
    #[arg(long, value_name = "PATH")]
    qemu_elf: Option<PathBuf>,
    /// The `f405` board's ELF (default: `IBVS_FIRMWARE_F405_ELF`, or build it).
    #[arg(long, value_name = "PATH")]
    f405_elf: Option<PathBuf>,
    /// Add every workload's figures (per scenario and per mode) under `"detail"`.
    #[arg(long)]
    detail: bool,
    /// Sizes and static bounds only: no replay through QEMU (quick; step, codec and stack
    /// figures are `null`).
    #[arg(long, conflicts_with = "check")]
    no_pil: bool,
    /// Compare with the expectations in this file; exit 1 on a regression.
    #[arg(long, value_name = "FILE")]
    check: Option<PathBuf>,
    /// List every loop of the control task's machine code in both ELFs, with its declared
    /// bound or `UNDECLARED` / `STALE` (for updating the table in `task.rs`), and exit.
    #[arg(long, conflicts_with_all = ["check", "detail"])]
    loops: bool,
    /// Run this `qemu` ELF built with the `bench` feature in QEMU with its execution log,
    /// cost every path of its scripted sortie's steps as they ran with the cycle model, print
    /// the figures and exit (a development measurement: `docs/benchmarks.md`).
    #[arg(long, value_name = "BENCH_ELF", conflicts_with_all = ["check", "detail", "loops"])]
    path_cycles: Option<PathBuf>,
}

/// One input sequence to replay through the firmware.
struct Workload {
    name: &'static str,
    what: String,
    /// The configuration flown (written to the firmware before the replay when it is not
    /// the default).
    config: ControllerConfig,
    inputs: Vec<ControllerInput>,
    /// Through the autopilot: the autopilot's MAVLink bytes of each step, sent to the
    /// firmware's autopilot port before the step's measurement frame (empty otherwise).
    autopilot: Vec<Vec<u8>>,
}

/// Records every input the controller sees while it flies (through the autopilot: the
/// uplink's input and the autopilot's bytes).
struct Recorder {
    controller: Controller,
    inputs: Vec<ControllerInput>,
    autopilot: Vec<Vec<u8>>,
}

impl FlightComputer for Recorder {
    fn step(&mut self, input: &ControllerInput) -> ControllerOutput {
        self.inputs.push(*input);
        self.controller.step(input)
    }

    fn autopilot_design(&self) -> Option<ibvs_core::attitude::AttitudeLoopConfig> {
        self.controller.autopilot_design()
    }

    fn step_through_autopilot(&mut self, link: sim::AutopilotStep<'_>) -> ControllerOutput {
        self.inputs.push(*link.input);
        self.autopilot.push(link.from_autopilot.to_vec());
        sim::step_through_session(&mut self.controller, link)
    }
}

/// What a recorded flight gives a workload: the inputs, the autopilot's bytes, the outcome.
type Recorded = (Vec<ControllerInput>, Vec<Vec<u8>>, String);

type Error = Box<dyn std::error::Error>;

/// Flies `scenario` in-process with `config` and `faults` injected; its inputs and outcome.
fn record(
    scenario: &Scenario,
    config: ControllerConfig,
    faults: &[SimFault],
) -> Result<Recorded, Error> {
    let mut rec = Recorder {
        controller: Controller::new(config)?,
        inputs: Vec::new(),
        autopilot: Vec::new(),
    };
    let run = sim::run_with_faults(scenario, &mut rec, faults)?;
    let s = &run.summary;
    let outcome = match (&s.breakaway_reason, s.miss_m) {
        (Some(r), _) => format!("{:?} ({r})", s.outcome),
        (None, Some(m)) => format!("{:?}, miss {m:.3} m", s.outcome),
        (None, None) => format!("{:?}", s.outcome),
    };
    Ok((rec.inputs, rec.autopilot, outcome.to_lowercase()))
}

/// A preset scenario flown with the firmware's configuration (the default: the refuelling
/// procedure; the paper's outer gains set to Table 1 and a = 0.8 m/s, as the default has
/// them); `edit` adjusts the file first.
fn preset(name: &str, seed: u64, edit: impl FnOnce(&mut ScenarioFile)) -> Result<Scenario, Error> {
    let mut f = ScenarioFile::load(name)?;
    f.seed = seed;
    let d = ControllerConfig::default();
    let c = &mut f.controller.config;
    c.ibvs = d.ibvs;
    c.velocity_limits.min_closing_mps = d.velocity_limits.min_closing_mps;
    edit(&mut f);
    if f.controller_config() != ControllerConfig::default() {
        return Err(format!(
            "scenario {name}: the firmware runs the default controller configuration only"
        )
        .into());
    }
    Ok(f.scenario())
}

/// The workloads: recorded dockings and two derived input sequences.
fn workloads() -> Result<Vec<Workload>, Error> {
    let mut out = Vec::new();
    // (name, what, scenario, faults, the outcome it must have: a workload that no longer
    // takes the path it is named for fails the benchmark rather than measure something else).
    let throttle_slow = SimFault::at_time(
        FaultKind::ActuatorRateLimited {
            actuator: Actuator::Throttle,
            rate_per_s: 0.05,
        },
        0.0,
        f64::INFINITY,
    );
    let frozen = SimFault::at_range(FaultKind::FrozenMeasurement, 3.0, f64::INFINITY);
    let flown: [(&'static str, &str, Scenario, Vec<SimFault>, &str); 8] = [
        (
            "calm",
            "default scenario: calm air, tanker wake, hose and drogue, LED camera",
            Scenario::default(),
            vec![],
            "docked",
        ),
        (
            "ideal",
            "calm air, drogue at its trail, ideal camera",
            Scenario::ideal(),
            vec![],
            "docked",
        ),
        (
            "turbulence",
            "mil-level2 seed 4: MIL-F-8785C 10^-2 turbulence, a no-go on the first approach, a missed approach, docks on the second",
            preset("mil-level2", 4, |_| {})?,
            vec![],
            "docked",
        ),
        (
            "bow-wave",
            "bow-wave seed 1: bow wave, level I turbulence",
            preset("bow-wave", 1, |_| {})?,
            vec![],
            "docked",
        ),
        (
            "image-loss",
            "level1 seed 1, half of the camera frames lost",
            preset("level1", 1, |f| f.camera.drop_probability = 0.5)?,
            vec![],
            "docked",
        ),
        (
            "breakaway-image-lost",
            "level1 seed 1, 90 % of the frames lost: measurement lost, breaks away",
            preset("level1", 1, |f| f.camera.drop_probability = 0.9)?,
            vec![],
            "measurementlost",
        ),
        (
            "breakaway-frozen",
            "default scenario, the tracker frozen from 3 m: frozen frames held, breaks away",
            Scenario::default(),
            vec![frozen],
            "measurementlost",
        ),
        (
            "breakaway-overspeed",
            "default scenario, throttle slewing at 5 %/s: closes too fast, breaks away",
            Scenario::default(),
            vec![throttle_slow],
            "overspeed",
        ),
    ];
    let mut calm = Vec::new();
    let mut ideal = Vec::new();
    for (name, what, scenario, faults, expected) in flown {
        let config = ControllerConfig::default();
        let (inputs, autopilot, outcome) = record(&scenario, config, &faults)?;
        if !outcome.contains(expected) {
            return Err(format!("workload {name}: expected {expected}, flew {outcome}").into());
        }
        match name {
            "calm" => calm.clone_from(&inputs),
            "ideal" => ideal.clone_from(&inputs),
            _ => {}
        }
        out.push(Workload {
            name,
            what: format!("{what}; {outcome}"),
            config,
            inputs,
            autopilot,
        });
    }

    // The attitude-command inner loop (through the autopilot): the one workload flown with
    // another configuration, written to the firmware before its replay.
    let file = ScenarioFile::load("autopilot-level2")?;
    let config = file.controller_config();
    let autopilot = Scenario {
        seed: 1,
        ..file.scenario()
    };
    let (inputs, autopilot_bytes, outcome) = record(&autopilot, config, &[])?;
    if !outcome.contains("docked") {
        return Err(format!("workload autopilot: expected docked, flew {outcome}").into());
    }
    out.push(Workload {
        name: "autopilot",
        what: format!(
            "autopilot-level2 seed 1: level II turbulence flown through the autopilot over MAVLink (its telemetry in, attitude and throttle setpoints out); {outcome}"
        ),
        config,
        inputs,
        autopilot: autopilot_bytes,
    });

    // The calm docking's inputs with the navigation invalid (NaN) from step 200 on: 25 held
    // steps, then breakaway without navigation, open loop.
    let mut nav_lost = calm;
    for input in nav_lost.iter_mut().skip(200) {
        input.nav = NavSample::from_array([f32::NAN; 12]);
    }
    out.push(Workload {
        name: "nav-loss",
        what: "the calm docking's inputs, navigation NaN from step 200: hold, breakaway open loop"
            .into(),
        config: ControllerConfig::default(),
        inputs: nav_lost,
        autopilot: Vec::new(),
    });

    // The ideal docking's inputs, then 50 steps docked and 100 with the contact lost.
    let mut docked = ideal;
    let last = *docked.last().ok_or("the ideal docking recorded no step")?;
    for k in 1..=150u32 {
        let mut input = last;
        input.measurement.seq = last.measurement.seq.wrapping_add(k);
        input.measurement.tracked = false;
        input.probe_contact = k <= 50;
        docked.push(input);
    }
    out.push(Workload {
        name: "docked-contact-lost",
        what: "the ideal docking's inputs, 50 steps docked, then contact lost: breakaway".into(),
        config: ControllerConfig::default(),
        inputs: docked,
        autopilot: Vec::new(),
    });
    Ok(out)
}

/// The JSON document (the per-board figures of docs/benchmarks.md, and the static bound).
#[derive(Serialize)]
struct Report {
    qemu: BoardReport,
    f405: BoardReport,
    #[serde(skip_serializing_if = "Option::is_none")]
    detail: Option<Value>,
}

/// One board's figures; `null` where the board cannot be measured here.
#[derive(Serialize)]
struct BoardReport {
    /// Over every step of every workload.
    step_instructions: Option<Spread>,
    /// The longest path through the step's machine code (`null` without objdump).
    step_instructions_bound: Option<u64>,
    /// The step's longest path in Cortex-M4 cycles at 168 MHz, every flash access a miss
    /// (`null` without objdump).
    step_cycles_bound: Option<u64>,
    /// The same in microseconds at 168 MHz.
    step_us_bound: Option<f64>,
    /// The schedule the control task's bound is for (the board's own).
    schedule: Option<task::Schedule>,
    /// The whole control task's longest path in instructions (interrupts aside).
    cycle_instructions_bound: Option<u64>,
    /// The whole control task in cycles, the interrupts that can land on it included.
    cycle_cycles_bound: Option<u64>,
    /// The same in microseconds at 168 MHz.
    cycle_us_bound: Option<f64>,
    /// The step and the task at zero wait states (every flash access an ART hit): not
    /// bounds at 168 MHz, what the memory system adds.
    step_cycles_zero_wait: Option<u64>,
    cycle_cycles_zero_wait: Option<u64>,
    /// What the cycle figures assume.
    assumptions: Option<Value>,
    /// The dearest measurement frame decode.
    decode_instructions: Option<u32>,
    /// The dearest command frame encode.
    encode_instructions: Option<u32>,
    /// The control cycle's worst case over the recorded dockings: the dearest decode, step
    /// and encode added (each the maximum over every frame, so at least any one frame's).
    /// The workloads of the peer's link alone (the surface loops).
    control_instructions: Option<u32>,
    /// Through the autopilot (the `autopilot` workload): the dearest decode (the measurement
    /// frame, the autopilot's MAVLink bytes since the last step and the navigation sample
    /// built from them), encode (the command frame and the MAVLink frames) and their cycle
    /// with the step.
    #[serde(skip_serializing_if = "Option::is_none")]
    autopilot_decode_instructions: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    autopilot_encode_instructions: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    autopilot_control_instructions: Option<u32>,
    /// The control path's stack high-water mark, bytes.
    stack_bytes: Option<u32>,
    /// The step's stack from its machine code: its frame and its deepest callee's (`null`
    /// without objdump).
    stack_bytes_bound: Option<u64>,
    flash_bytes: u64,
    ram_bytes: u64,
}

/// Min, median (upper for an even count) and max.
#[derive(Debug, Clone, Copy, Serialize)]
struct Spread {
    min: u32,
    median: u32,
    max: u32,
}

impl Spread {
    fn of(v: &[u32]) -> Option<Self> {
        let mut s = v.to_vec();
        s.sort_unstable();
        Some(Self {
            min: *s.first()?,
            median: s[s.len() / 2],
            max: *s.last()?,
        })
    }
}

/// What one replay measured.
struct Replay {
    step: Vec<u32>,
    decode: Vec<u32>,
    encode: Vec<u32>,
    by_mode: BTreeMap<String, Vec<u32>>,
    /// The modes the controller was in after a step.
    modes: BTreeSet<&'static str>,
    control_stack: Option<u32>,
    firmware_stack: Option<u32>,
}

fn mode_name(m: Mode) -> &'static str {
    match m {
        Mode::Standby => "standby",
        Mode::PreContact => "pre-contact",
        Mode::Approach => "approach",
        Mode::Terminal => "terminal",
        Mode::Docked => "docked",
        Mode::MissedApproach => "missed-approach",
        Mode::Breakaway => "breakaway",
    }
}

/// The largest `N` of the log lines containing `mark` followed by `N B`.
fn max_mark(log: &str, mark: &str) -> Option<u32> {
    log.lines()
        .filter_map(|l| {
            let rest = &l[l.find(mark)? + mark.len()..];
            rest.split(' ').next()?.parse::<u32>().ok()
        })
        .max()
}

/// Replays `inputs` through the firmware at `elf`, checking every output against the
/// in-process controller's.
fn replay(elf: &Path, w: &Workload) -> Result<Replay, Error> {
    let mut reference = Controller::new(w.config)?;
    let mut fw = PilFlightComputer::spawn(elf)?;
    if w.config != ControllerConfig::default() {
        fw.configure(&w.config)
            .map_err(|e| format!("{}: configuration: {e}", w.name))?;
    }
    let mut r = Replay {
        step: Vec::new(),
        decode: Vec::new(),
        encode: Vec::new(),
        by_mode: BTreeMap::new(),
        modes: BTreeSet::new(),
        control_stack: None,
        firmware_stack: None,
    };
    // Through the autopilot: the in-process side of the link beside the reference.
    let mut session = Session::new(SessionConfig::default());
    for (k, input) in w.inputs.iter().enumerate() {
        let before = reference.mode();
        let d = match w.autopilot.get(k) {
            Some(bytes) => {
                let now = 20 * k as u32;
                bytes.iter().for_each(|&b| session.push(b, now));
                let linked = session.input(now, input);
                let want = reference.step(&linked);
                let mut burst = [0u8; MAX_BURST_LEN];
                session.send(now, &want.command, &mut burst);
                let mut to_autopilot = Vec::new();
                let d = fw
                    .try_step_through_autopilot(input, bytes, &mut to_autopilot)
                    .map_err(|e| format!("{}: step {k}: {e}", w.name))?;
                (want, d)
            }
            None => {
                let want = reference.step(input);
                let d = fw
                    .try_step(input)
                    .map_err(|e| format!("{}: step {k}: {e}", w.name))?;
                (want, d)
            }
        };
        let (want, d) = d;
        if d.output != want {
            return Err(format!(
                "{}: step {k}: the firmware's output differs from the in-process controller's:\n\
                 firmware {:?}\nin-process {want:?}",
                w.name, d.output
            )
            .into());
        }
        if d.cost.unit != CostUnit::Instructions {
            return Err(format!(
                "{}: the firmware reports {:?}, not instructions",
                w.name, d.cost.unit
            )
            .into());
        }
        r.step.push(d.cost.step);
        r.decode.push(d.cost.decode);
        if k > 0 {
            // The first frame carries the boot frame's encoding.
            r.encode.push(d.cost.encode_prev);
        }
        let key = if before == want.mode {
            mode_name(want.mode).to_string()
        } else {
            format!("{} -> {}", mode_name(before), mode_name(want.mode))
        };
        r.by_mode.entry(key).or_default().push(d.cost.step);
        r.modes.insert(mode_name(want.mode));
    }
    let (_, log) = fw.shutdown();
    r.control_stack = max_mark(&log, CONTROL_STACK_MARK);
    r.firmware_stack = max_mark(&log, FIRMWARE_STACK_MARK);
    if r.control_stack.is_none() {
        return Err(format!(
            "{}: the firmware logged no control-path stack mark:\n{log}",
            w.name
        )
        .into());
    }
    Ok(r)
}

/// The command that builds the `f405` board's ELF where [`f405_elf`] looks by default.
const F405_BUILD_COMMAND: &str = "cargo build -p firmware --target thumbv7em-none-eabihf --release";

fn qemu_elf(arg: Option<PathBuf>) -> Result<PathBuf, Error> {
    match arg {
        Some(p) => Ok(p),
        None => Ok(pil::firmware_elf()?),
    }
}

/// The `f405` board's ELF: `--f405-elf`, else `IBVS_FIRMWARE_F405_ELF`, else
/// `<target>/thumbv7em-none-eabihf/release/firmware` (the default build); it must exist (nothing is built
/// here), and a missing one is an error naming [`F405_BUILD_COMMAND`].
fn f405_elf(arg: Option<PathBuf>) -> Result<PathBuf, Error> {
    let p = arg
        .or_else(|| std::env::var_os(F405_ELF_ENV).map(PathBuf::from))
        .unwrap_or_else(|| {
            pil::target_dir()
                .join(pil::FIRMWARE_TARGET)
                .join("release")
                .join("firmware")
        });
    if p.is_file() {
        Ok(p)
    } else {
        Err(format!(
            "f405 firmware ELF not found: {} (build it with `{F405_BUILD_COMMAND}`, or name one in {F405_ELF_ENV})",
            p.display()
        )
        .into())
    }
}

/// The control cycle's figure ([`BoardReport::control_instructions`]): the maxima of the
/// decodes, the steps and the encodes added; `None` when any is missing.
fn control_instructions(decode: &[u32], step: &[u32], encode: &[u32]) -> Option<u32> {
    let max = |v: &[u32]| v.iter().max().copied();
    Some(max(decode)? + max(step)? + max(encode)?)
}

/// The hard budgets the expectations file must hold (`BOARD.METRIC`): flash and static RAM on
/// both boards, the control path's stack measured (`qemu`) and bounded (both), and the
/// control cycle (decode + step + encode) at the cost of the same cycle in plain C
/// (docs/benchmarks.md, "The codec").
const BUDGETS: [&str; 8] = [
    "qemu.control_instructions",
    "qemu.flash_bytes",
    "f405.flash_bytes",
    "qemu.ram_bytes",
    "f405.ram_bytes",
    "qemu.stack_bytes",
    "qemu.stack_bytes_bound",
    "f405.stack_bytes_bound",
];

/// The figures the gate guards against their expectations (`BOARD`, `METRIC`, the path to
/// the figure in the report): each must be in both the expectations file and the report
/// (either missing is an error, not a pass) and must not grow past its expectation plus the
/// tolerance.
const GUARDED: &[(&str, &str, &[&str])] = &[
    (
        "qemu",
        "step_instructions_max",
        &["step_instructions", "max"],
    ),
    // The static bound must exist (a loop, recursion or an indirect call in the step's
    // code makes it `null`, and the check fails) and must not grow.
    (
        "qemu",
        "step_instructions_bound",
        &["step_instructions_bound"],
    ),
    (
        "f405",
        "step_instructions_bound",
        &["step_instructions_bound"],
    ),
    // The codec's worst case over the workloads: a measurement frame's decode (whole, once
    // its end is queued) and a command frame's encode, each repeatable (the run replays one
    // workload twice and fails unless every figure is identical).
    ("qemu", "decode_instructions", &["decode_instructions"]),
    ("qemu", "encode_instructions", &["encode_instructions"]),
    ("qemu", "control_instructions", &["control_instructions"]),
    (
        "qemu",
        "autopilot_decode_instructions",
        &["autopilot_decode_instructions"],
    ),
    (
        "qemu",
        "autopilot_encode_instructions",
        &["autopilot_encode_instructions"],
    ),
    (
        "qemu",
        "autopilot_control_instructions",
        &["autopilot_control_instructions"],
    ),
    ("qemu", "stack_bytes", &["stack_bytes"]),
    // The step's static stack (its frame and its deepest callee's: the f405 board's only
    // stack figure), which must exist like the other static bounds.
    ("qemu", "stack_bytes_bound", &["stack_bytes_bound"]),
    ("f405", "stack_bytes_bound", &["stack_bytes_bound"]),
    ("qemu", "flash_bytes", &["flash_bytes"]),
    ("f405", "flash_bytes", &["flash_bytes"]),
    // Static RAM (`.data`, `.bss`, `.uninit`).
    ("qemu", "ram_bytes", &["ram_bytes"]),
    ("f405", "ram_bytes", &["ram_bytes"]),
    // The cycle bounds (wcet.rs, task.rs): the step's and the whole control task's, in
    // cycles and microseconds at 168 MHz, and the task's instructions; each must exist
    // (an undeclared or stale loop, an unknown instruction or an unbounded call makes it
    // `null`, and the check fails).
    ("qemu", "step_cycles_bound", &["step_cycles_bound"]),
    ("f405", "step_cycles_bound", &["step_cycles_bound"]),
    ("qemu", "step_us_bound", &["step_us_bound"]),
    ("f405", "step_us_bound", &["step_us_bound"]),
    (
        "qemu",
        "cycle_instructions_bound",
        &["cycle_instructions_bound"],
    ),
    (
        "f405",
        "cycle_instructions_bound",
        &["cycle_instructions_bound"],
    ),
    ("qemu", "cycle_cycles_bound", &["cycle_cycles_bound"]),
    ("f405", "cycle_cycles_bound", &["cycle_cycles_bound"]),
    ("qemu", "cycle_us_bound", &["cycle_us_bound"]),
    ("f405", "cycle_us_bound", &["cycle_us_bound"]),
];

/// Every static bound must be at least the figure measured on the same ELF that it bounds
/// (`BOARD`, the bound's metric, the measured figure's path in the report): a bound under a
/// run seen in QEMU is an analysis that under-counts, and fails the check naming both. A
/// cycle costs at least one instruction on the Cortex-M4, so the cycle bounds must cover the
/// instruction counts too. The control task's bounds cover the control cycle's figure (the
/// dearest decode, step and encode added: no more than the longest task). Only the `qemu`
/// board runs here (the `f405` board's figures are measured on the board, in DWT cycles).
const COVERS: &[(&str, &str, &[&str])] = &[
    (
        "qemu",
        "step_instructions_bound",
        &["step_instructions", "max"],
    ),
    ("qemu", "step_cycles_bound", &["step_instructions", "max"]),
    (
        "qemu",
        "cycle_instructions_bound",
        &["control_instructions"],
    ),
    ("qemu", "cycle_cycles_bound", &["control_instructions"]),
    ("qemu", "stack_bytes_bound", &["stack_bytes"]),
];

/// The figure at `path` under `board` in a report.
fn figure(report: &Value, board: &str, path: &[&str]) -> Option<f64> {
    path.iter().fold(&report[board], |v, k| &v[*k]).as_f64()
}

/// Compares `report` with the expectations file; the regressions (empty: none). A figure
/// fails above its expectation plus `tolerance_percent`, and below it minus `margin_percent`
/// (an improvement that must be written into the file: the expectations stay within the
/// margin of the truth, so a later regression cannot hide in an unrecorded gain); a static
/// bound fails under the figure it bounds ([`COVERS`]); a figure fails over its budget.
fn check(report: &Value, expected_path: &Path) -> Result<Vec<String>, Error> {
    let text = std::fs::read_to_string(expected_path)
        .map_err(|e| format!("{}: {e}", expected_path.display()))?;
    let expected: Value = serde_json::from_str(&text)?;
    let tolerance = expected["tolerance_percent"]
        .as_f64()
        .ok_or("expectations: tolerance_percent missing")?;
    let margin = expected["margin_percent"]
        .as_f64()
        .ok_or("expectations: margin_percent missing")?;
    let mut regressions = Vec::new();
    for &(board, metric, path) in GUARDED {
        let want = expected[board][metric]
            .as_f64()
            .ok_or_else(|| format!("expectations: {board}.{metric} missing"))?;
        let got = figure(report, board, path)
            .ok_or_else(|| format!("measured: {board}.{metric} missing"))?;
        let limit = want * (1.0 + tolerance / 100.0);
        let floor = want * (1.0 - margin / 100.0);
        let verdict = if got > limit {
            regressions.push(format!(
                "{board}.{metric}: {got} > expected {want} + {tolerance} % ({limit:.0})"
            ));
            "REGRESSION"
        } else if got < floor {
            regressions.push(format!(
                "{board}.{metric}: {got} < expected {want} - {margin} % ({floor:.0}): lower the \
                 expectation in {} (docs/benchmarks.md, \"Updating the expectations\")",
                expected_path.display()
            ));
            "BELOW THE EXPECTATION: lower it"
        } else {
            "ok"
        };
        eprintln!(
            "check {board}.{metric}: measured {got}, expected {want} (+{tolerance} %, \
             -{margin} %): {verdict}"
        );
    }
    for &(board, bound, measured) in COVERS {
        let b = figure(report, board, &[bound])
            .ok_or_else(|| format!("measured: {board}.{bound} missing"))?;
        let m = figure(report, board, measured)
            .ok_or_else(|| format!("measured: {board}.{} missing", measured.join(".")))?;
        let name = format!("{board}.{}", measured.join("."));
        let verdict = if b < m {
            regressions.push(format!(
                "{board}.{bound}: {b} < measured {name} {m}: the static analysis under-counts"
            ));
            "UNDER THE MEASURED FIGURE"
        } else {
            "ok"
        };
        eprintln!("bound {board}.{bound}: {b} >= measured {name} {m}: {verdict}");
    }
    // Hard budgets (the targets set when the firmware was first benchmarked): a figure over
    // its budget fails whatever its expectation says, so raising an expectation cannot hide
    // it. Every budget the gate stands for must be in the file: a file without them would
    // pass silently.
    let budgets = expected["budgets"]
        .as_object()
        .ok_or("expectations: the `budgets` object is missing")?;
    for key in BUDGETS {
        if !budgets.contains_key(key) {
            return Err(format!("expectations: budgets.{key} missing").into());
        }
    }
    for (key, budget) in budgets {
        let budget = budget
            .as_f64()
            .ok_or_else(|| format!("expectations: budgets.{key} is not a number"))?;
        let (board, metric) = key
            .split_once('.')
            .ok_or_else(|| format!("expectations: budgets.{key}: want BOARD.METRIC"))?;
        let got = report[board][metric]
            .as_f64()
            .ok_or_else(|| format!("measured: {key} missing"))?;
        let verdict = if got > budget {
            regressions.push(format!("{key}: {got} > budget {budget}"));
            "OVER BUDGET"
        } else {
            "ok"
        };
        eprintln!("budget {key}: measured {got}, budget {budget}: {verdict}");
    }
    Ok(regressions)
}

/// A board's static analysis: the step's bound and the control task's (each `Err` with why
/// when it could not be bounded).
struct Static {
    step: Result<wcet::Bound, String>,
    task: Result<task::BoardBounds, String>,
    schedule: task::Schedule,
}

impl Static {
    fn of(elf: &Path, schedule: task::Schedule) -> Self {
        match wcet::Disassembly::of(elf) {
            Ok(d) => Self {
                step: d.bound(
                    task::STEP,
                    wcet::Rules {
                        exclude: &[task::PBVS],
                        ..wcet::Rules::default()
                    },
                    wcet::Metric::Instructions,
                ),
                task: task::analyse(&d, schedule),
                schedule,
            },
            Err(e) => Self {
                step: Err(e.clone()),
                task: Err(e),
                schedule,
            },
        }
    }

    fn errors(&self) -> Vec<String> {
        let mut out = Vec::new();
        if let Err(e) = &self.step {
            out.push(format!("no static bound of the step: {e}"));
        }
        if let Err(e) = &self.task {
            out.push(format!("no cycle bound: {e}"));
        }
        out
    }

    /// The static figures of a board's report (the measured ones left empty).
    fn report(&self) -> BoardReport {
        let t = self.task.as_ref().ok();
        BoardReport {
            step_instructions: None,
            step_instructions_bound: self.step.as_ref().ok().map(|b| b.longest_path),
            step_cycles_bound: t.map(|t| t.step.cycles),
            step_us_bound: t.map(|t| task::micros(t.step.cycles)),
            schedule: Some(self.schedule),
            cycle_instructions_bound: t.map(|t| t.task.instructions),
            cycle_cycles_bound: t.map(|t| t.task_with_interrupts.cycles),
            cycle_us_bound: t.map(|t| task::micros(t.task_with_interrupts.cycles)),
            step_cycles_zero_wait: t.map(|t| t.step.cycles_zero_wait),
            cycle_cycles_zero_wait: t.map(|t| t.task_with_interrupts.cycles_zero_wait),
            assumptions: t.map(|_| task::assumptions(self.schedule)),
            decode_instructions: None,
            encode_instructions: None,
            control_instructions: None,
            autopilot_decode_instructions: None,
            autopilot_encode_instructions: None,
            autopilot_control_instructions: None,
            stack_bytes: None,
            stack_bytes_bound: self.step.as_ref().ok().map(|b| b.stack_bytes),
            flash_bytes: 0,
            ram_bytes: 0,
        }
    }

    fn detail(&self) -> Value {
        json!({
            "step": self.step.as_ref().map_err(String::as_str).ok(),
            "task": self.task.as_ref().map_err(String::as_str).ok(),
            "errors": self.errors(),
        })
    }
}

/// `--loops`: every loop of both ELFs' control task, declared or not.
fn list_loops(qemu: &Path, f405: &Path) -> Result<bool, Error> {
    let mut ok = true;
    for (board, elf) in [("qemu", qemu), ("f405", f405)] {
        let loops = task::list_loops(&wcet::Disassembly::of(elf)?)?;
        for l in &loops {
            ok &= !(l.reason == "UNDECLARED" || l.reason.starts_with("STALE"));
        }
        println!(
            "{}",
            serde_json::to_string_pretty(&json!({ "board": board, "loops": loops }))?
        );
    }
    Ok(ok)
}

fn run(args: Args) -> Result<bool, Error> {
    if let Some(elf) = &args.path_cycles {
        let dir = pil::target_dir().join("target-bench-paths");
        let r = paths::path_cycles(elf, &dir)?;
        println!("{}", serde_json::to_string_pretty(&r)?);
        return Ok(true);
    }
    let qemu = qemu_elf(
        args.qemu_elf
            .or_else(|| std::env::var_os(pil::FIRMWARE_ELF_ENV).map(PathBuf::from)),
    )?;
    let f405 = f405_elf(args.f405_elf)?;
    if args.loops {
        return list_loops(&qemu, &f405);
    }

    let mut all_step = Vec::new();
    let mut all_decode = Vec::new();
    let mut all_encode = Vec::new();
    // Through the autopilot: its own cycle (a second protocol's decode and encode in it).
    let (mut ap_step, mut ap_decode, mut ap_encode) = (Vec::new(), Vec::new(), Vec::new());
    let mut control_stack = 0u32;
    let mut detail = Vec::new();
    let workloads = if args.no_pil {
        Vec::new()
    } else {
        workloads()?
    };
    // The shortest workload is replayed twice: every figure must be the same both times
    // (exact instruction counts are the point of the emulated target).
    let shortest = (0..workloads.len()).min_by_key(|&i| workloads[i].inputs.len());
    let mut first_replay = None;
    let mut visited: BTreeSet<&str> = BTreeSet::new();
    for (i, w) in workloads.iter().enumerate() {
        eprintln!(
            "target-bench: {} ({} steps): {}",
            w.name,
            w.inputs.len(),
            w.what
        );
        let r = replay(&qemu, w)?;
        if Some(i) == shortest {
            first_replay = Some((r.step.clone(), r.decode.clone(), r.encode.clone()));
        }
        visited.extend(&r.modes);
        all_step.extend_from_slice(&r.step);
        if w.autopilot.is_empty() {
            all_decode.extend_from_slice(&r.decode);
            all_encode.extend_from_slice(&r.encode);
        } else {
            ap_step.extend_from_slice(&r.step);
            ap_decode.extend_from_slice(&r.decode);
            ap_encode.extend_from_slice(&r.encode);
        }
        control_stack = control_stack.max(r.control_stack.unwrap_or(0));
        let by_mode: BTreeMap<&String, Value> = r
            .by_mode
            .iter()
            .map(|(k, v)| {
                (
                    k,
                    json!({ "steps": v.len(), "instructions": Spread::of(v) }),
                )
            })
            .collect();
        detail.push(json!({
            "workload": w.name,
            "what": w.what,
            "steps": w.inputs.len(),
            "step_instructions": Spread::of(&r.step),
            "step_instructions_by_mode": by_mode,
            "decode_instructions": Spread::of(&r.decode),
            "encode_instructions": Spread::of(&r.encode),
            "control_stack_bytes": r.control_stack,
            "firmware_stack_bytes": r.firmware_stack,
        }));
    }
    // The workloads stand for the procedure only while they fly all of it.
    if !workloads.is_empty() {
        let all = [
            Mode::Standby,
            Mode::PreContact,
            Mode::Approach,
            Mode::Terminal,
            Mode::Docked,
            Mode::MissedApproach,
            Mode::Breakaway,
        ];
        if let Some(m) = all
            .into_iter()
            .map(mode_name)
            .find(|m| !visited.contains(m))
        {
            return Err(format!(
                "the workloads never fly the {m} mode: a workload that did no longer does (main.rs, workloads)"
            )
            .into());
        }
    }
    if let (Some(i), Some(first)) = (shortest, first_replay) {
        let w = &workloads[i];
        let again = replay(&qemu, w)?;
        if (again.step, again.decode, again.encode) != first {
            return Err(format!(
                "the figures of workload {} differ between two replays of one ELF: not repeatable",
                w.name
            )
            .into());
        }
        eprintln!(
            "target-bench: {} replayed again: every step, decode and encode figure identical",
            w.name
        );
    }
    let qemu_sizes = elf::sizes(&qemu)?;
    let f405_sizes = elf::sizes(&f405)?;
    let qemu_static = Static::of(&qemu, task::Schedule::Lockstep);
    let f405_static = Static::of(&f405, task::Schedule::FreeRunning);
    for (board, s) in [("qemu", &qemu_static), ("f405", &f405_static)] {
        for e in s.errors() {
            eprintln!("target-bench: {board}: {e}");
        }
    }
    let report = Report {
        qemu: BoardReport {
            step_instructions: Spread::of(&all_step),
            decode_instructions: all_decode.iter().max().copied(),
            encode_instructions: all_encode.iter().max().copied(),
            control_instructions: control_instructions(&all_decode, &all_step, &all_encode),
            autopilot_decode_instructions: ap_decode.iter().max().copied(),
            autopilot_encode_instructions: ap_encode.iter().max().copied(),
            autopilot_control_instructions: control_instructions(&ap_decode, &ap_step, &ap_encode),
            stack_bytes: (!args.no_pil).then_some(control_stack),
            flash_bytes: qemu_sizes.flash_bytes,
            ram_bytes: qemu_sizes.ram_bytes,
            ..qemu_static.report()
        },
        f405: BoardReport {
            step_instructions: None,
            decode_instructions: None,
            encode_instructions: None,
            control_instructions: None,
            autopilot_decode_instructions: None,
            autopilot_encode_instructions: None,
            autopilot_control_instructions: None,
            stack_bytes: None,
            flash_bytes: f405_sizes.flash_bytes,
            ram_bytes: f405_sizes.ram_bytes,
            ..f405_static.report()
        },
        detail: args.detail.then(|| {
            json!({
                "steps": all_step.len(),
                "decode_instructions": Spread::of(&all_decode),
                "encode_instructions": Spread::of(&all_encode),
                "workloads": detail,
                "static_bound": {
                    "qemu": qemu_static.detail(),
                    "f405": f405_static.detail(),
                },
                "elves": { "qemu": qemu, "f405": f405 },
            })
        }),
    };
    println!("{}", serde_json::to_string_pretty(&report)?);
    let report = serde_json::to_value(&report)?;
    // A declared loop bound no loop of either board used is stale (the code it was for is
    // gone, or its key moved).
    let unused = match (&qemu_static.task, &f405_static.task) {
        (Ok(q), Ok(f)) => {
            let used: Vec<wcet::LoopUse> = q
                .parts
                .iter()
                .chain(&f.parts)
                .flat_map(|b| b.loops.iter().cloned())
                .collect();
            task::unused_loop_bounds(&used)
        }
        _ => Vec::new(),
    };
    for u in &unused {
        eprintln!("target-bench: a declared loop bound matches no loop: {u}");
    }
    match args.check {
        None => Ok(true),
        Some(path) => {
            let mut regressions = check(&report, &path)?;
            regressions.extend(
                unused
                    .iter()
                    .map(|u| format!("stale loop bound (task.rs, LOOPS): {u}")),
            );
            for r in &regressions {
                eprintln!("target-bench: regression: {r}");
            }
            Ok(regressions.is_empty())
        }
    }
}

fn main() -> ExitCode {
    match run(Args::parse()) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("target-bench: {e}");
            ExitCode::from(2)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A report as `run` writes it, with the figures the gate reads.
    fn report(step_max: u64, bound: Option<u64>, flash: u64) -> Value {
        let board = |step: Value| {
            json!({
                "step_instructions": step,
                "step_instructions_bound": bound,
                "step_cycles_bound": 5000,
                "step_us_bound": 29.8,
                "cycle_instructions_bound": 20000,
                "cycle_cycles_bound": 80000,
                "cycle_us_bound": 476.2,
                "decode_instructions": 4000,
                "encode_instructions": 6000,
                "control_instructions": 10800,
                "autopilot_decode_instructions": 9000,
                "autopilot_encode_instructions": 3000,
                "autopilot_control_instructions": 14800,
                "stack_bytes": 276,
                "stack_bytes_bound": 300,
                "flash_bytes": flash,
                "ram_bytes": 704,
            })
        };
        json!({
            "qemu": board(json!({"min": 1, "median": 2, "max": step_max})),
            "f405": board(Value::Null),
        })
    }

    /// The expectations file the report above meets, with `flash_budget` on both boards.
    fn expectations_value(flash_budget: u64) -> Value {
        json!({
            "tolerance_percent": 2,
            "margin_percent": 2,
            "qemu": {
                "step_instructions_max": 800,
                "step_instructions_bound": 1100,
                "decode_instructions": 4000,
                "encode_instructions": 6000,
                "control_instructions": 10800,
                "autopilot_decode_instructions": 9000,
                "autopilot_encode_instructions": 3000,
                "autopilot_control_instructions": 14800,
                "stack_bytes": 276,
                "stack_bytes_bound": 300,
                "flash_bytes": 60000,
                "ram_bytes": 704,
                "step_cycles_bound": 5000,
                "step_us_bound": 29.8,
                "cycle_instructions_bound": 20000,
                "cycle_cycles_bound": 80000,
                "cycle_us_bound": 476.2,
            },
            "f405": {
                "step_instructions_bound": 1100,
                "stack_bytes_bound": 300,
                "flash_bytes": 60000,
                "ram_bytes": 704,
                "step_cycles_bound": 5000,
                "step_us_bound": 29.8,
                "cycle_instructions_bound": 20000,
                "cycle_cycles_bound": 80000,
                "cycle_us_bound": 476.2,
            },
            "budgets": {
                "qemu.control_instructions": 12000,
                "qemu.flash_bytes": flash_budget,
                "f405.flash_bytes": flash_budget,
                "qemu.ram_bytes": 16384,
                "f405.ram_bytes": 16384,
                "qemu.stack_bytes": 2048,
                "qemu.stack_bytes_bound": 2048,
                "f405.stack_bytes_bound": 2048,
            },
        })
    }

    fn expectations(flash_budget: u64) -> tempfile_path::TempPath {
        tempfile_path::write(&expectations_value(flash_budget))
    }

    /// A file in the system's temporary directory, removed when dropped.
    mod tempfile_path {
        use std::path::PathBuf;

        pub struct TempPath(pub PathBuf);

        impl Drop for TempPath {
            fn drop(&mut self) {
                let _ = std::fs::remove_file(&self.0);
            }
        }

        pub fn write(v: &serde_json::Value) -> TempPath {
            use std::sync::atomic::{AtomicU32, Ordering};
            static N: AtomicU32 = AtomicU32::new(0);
            let path = std::env::temp_dir().join(format!(
                "target-bench-expected-{}-{}.json",
                std::process::id(),
                N.fetch_add(1, Ordering::Relaxed)
            ));
            std::fs::write(&path, v.to_string()).expect("writing the expectations");
            TempPath(path)
        }
    }

    #[test]
    fn within_tolerance_and_budget_passes() {
        let e = expectations(65536);
        // 2 % over 800 is 816; 1122 is within 2 % of 1100.
        let got = check(&report(816, Some(1122), 61200), &e.0).expect("check");
        assert!(got.is_empty(), "{got:?}");
    }

    #[test]
    fn growth_past_the_tolerance_is_a_regression() {
        let e = expectations(65536);
        let got = check(&report(817, Some(1100), 60000), &e.0).expect("check");
        assert_eq!(got.len(), 1, "{got:?}");
        assert!(got[0].starts_with("qemu.step_instructions_max"), "{got:?}");
        let got = check(&report(800, Some(1123), 60000), &e.0).expect("check");
        assert_eq!(got.len(), 2, "both boards' bounds: {got:?}");
    }

    #[test]
    fn a_missing_static_bound_fails_the_check() {
        let e = expectations(65536);
        assert!(check(&report(800, None, 60000), &e.0).is_err());
    }

    #[test]
    fn a_missing_cycle_bound_fails_the_check() {
        let e = expectations(65536);
        assert!(check(&report(800, Some(1100), 60000), &e.0).is_ok());
        for key in [
            "step_cycles_bound",
            "step_us_bound",
            "cycle_instructions_bound",
            "cycle_cycles_bound",
            "cycle_us_bound",
        ] {
            for board in ["qemu", "f405"] {
                let mut r = report(800, Some(1100), 60000);
                r[board][key] = Value::Null;
                let e = check(&r, &e.0).expect_err(key);
                assert!(e.to_string().contains(key), "{e}");
            }
        }
    }

    #[test]
    fn a_cycle_bound_grown_past_the_tolerance_is_a_regression() {
        let e = expectations(65536);
        // 2 % over 80,000 cycles is 81,600.
        let mut r = report(800, Some(1100), 60000);
        r["f405"]["cycle_cycles_bound"] = json!(81600);
        assert!(check(&r, &e.0).expect("check").is_empty());
        r["f405"]["cycle_cycles_bound"] = json!(81601);
        let got = check(&r, &e.0).expect("check");
        assert_eq!(got.len(), 1, "{got:?}");
        assert!(got[0].starts_with("f405.cycle_cycles_bound"), "{got:?}");
    }

    #[test]
    fn static_ram_and_the_static_stack_are_guarded_on_both_boards() {
        let e = expectations(65536);
        // 2 % over 704 B is 718.08; over 300 B, 306.
        for board in ["qemu", "f405"] {
            let mut r = report(800, Some(1100), 60000);
            r[board]["ram_bytes"] = json!(718);
            r[board]["stack_bytes_bound"] = json!(306);
            assert!(check(&r, &e.0).expect("check").is_empty(), "{board}");
            r[board]["ram_bytes"] = json!(719);
            r[board]["stack_bytes_bound"] = json!(307);
            let got = check(&r, &e.0).expect("check");
            assert_eq!(got.len(), 2, "{got:?}");
            assert!(
                got[0].starts_with(&format!("{board}.stack_bytes_bound")),
                "{got:?}"
            );
            assert!(got[1].starts_with(&format!("{board}.ram_bytes")), "{got:?}");
            // The static stack must exist, like the other static bounds.
            r[board]["stack_bytes_bound"] = Value::Null;
            let err = check(&r, &e.0).expect_err("no static stack");
            assert!(err.to_string().contains("stack_bytes_bound"), "{err}");
        }
        // Static RAM over its 16 KiB budget fails even when the expectation was raised.
        let mut high = expectations_value(65536);
        high["f405"]["ram_bytes"] = json!(16500);
        let high = tempfile_path::write(&high);
        let mut r = report(800, Some(1100), 60000);
        r["f405"]["ram_bytes"] = json!(16385);
        let got = check(&r, &high.0).expect("check");
        assert_eq!(got, ["f405.ram_bytes: 16385 > budget 16384"]);
    }

    #[test]
    fn the_control_cycle_adds_the_dearest_decode_step_and_encode() {
        assert_eq!(
            control_instructions(&[10, 30, 20], &[5, 7], &[100, 1]),
            Some(30 + 7 + 100)
        );
        assert_eq!(control_instructions(&[], &[5], &[1]), None);
        // Over its budget, the cycle fails whatever its expectation says.
        let mut r = report(800, Some(1100), 60_000);
        r["qemu"]["control_instructions"] = json!(12_001);
        let mut e = expectations_value(131_072);
        e["qemu"]["control_instructions"] = json!(12_100);
        let got = check(&r, &tempfile_path::write(&e).0).expect("checked");
        assert_eq!(got, ["qemu.control_instructions: 12001 > budget 12000"]);
    }

    #[test]
    fn missing_budgets_are_an_error_not_a_pass() {
        let r = report(800, Some(1100), 60000);
        let mut none = expectations_value(65536);
        none.as_object_mut().expect("an object").remove("budgets");
        let none = tempfile_path::write(&none);
        let err = check(&r, &none.0).expect_err("no budgets");
        assert!(err.to_string().contains("budgets"), "{err}");
        for key in BUDGETS {
            let mut v = expectations_value(65536);
            v["budgets"].as_object_mut().expect("budgets").remove(key);
            let f = tempfile_path::write(&v);
            let err = check(&r, &f.0).expect_err(key);
            assert!(err.to_string().contains(key), "{key}: {err}");
        }
    }

    /// Every guarded figure, one at a time: missing from the expectations file, missing
    /// from the report, or grown past its tolerance, the check fails naming it.
    #[test]
    fn every_guarded_figure_fails_the_check_when_missing_or_grown() {
        let e = expectations_value(1 << 20);
        let ok = report(800, Some(1100), 60000);
        let file = tempfile_path::write(&e);
        assert!(check(&ok, &file.0).expect("check").is_empty());
        assert!(GUARDED.iter().any(|g| g.1 == "decode_instructions"));
        assert!(GUARDED.iter().any(|g| g.1 == "encode_instructions"));
        for &(board, metric, path) in GUARDED {
            let name = format!("{board}.{metric}");
            // Not expected: an error, not a pass.
            let mut v = e.clone();
            v[board].as_object_mut().expect("a board").remove(metric);
            let f = tempfile_path::write(&v);
            let err = check(&ok, &f.0).expect_err(&name);
            assert!(err.to_string().contains(&name), "{name}: {err}");
            // Not measured: likewise.
            let mut r = ok.clone();
            let (last, parents) = path.split_last().expect("a path");
            let at = parents.iter().fold(&mut r[board], |v, k| &mut v[*k]);
            at[*last] = Value::Null;
            let err = check(&r, &file.0).expect_err(&name);
            assert!(err.to_string().contains(&name), "{name}: {err}");
            // Over its expectation by more than the tolerance: a regression naming it.
            let mut r = ok.clone();
            let want = e[board][metric].as_f64().expect("expected");
            let at = parents.iter().fold(&mut r[board], |v, k| &mut v[*k]);
            at[*last] = json!(want * 1.03);
            let got = check(&r, &file.0).expect("check");
            assert_eq!(got.len(), 1, "{name}: {got:?}");
            assert!(got[0].starts_with(&format!("{name}:")), "{name}: {got:?}");
        }
    }

    /// Every guarded figure more than the margin below its expectation fails naming it, until
    /// the expectation is lowered; within the margin it passes.
    #[test]
    fn a_figure_more_than_the_margin_below_its_expectation_fails() {
        let e = expectations_value(1 << 20);
        let file = tempfile_path::write(&e);
        let ok = report(800, Some(1100), 60000);
        for &(board, metric, path) in GUARDED {
            let name = format!("{board}.{metric}");
            let want = e[board][metric].as_f64().expect("expected");
            let (last, parents) = path.split_last().expect("a path");
            for (factor, fails) in [(0.985, false), (0.97, true)] {
                let mut r = ok.clone();
                let at = parents.iter().fold(&mut r[board], |v, k| &mut v[*k]);
                at[*last] = json!(want * factor);
                let got = check(&r, &file.0).expect("check");
                if fails {
                    assert_eq!(got.len(), 1, "{name}: {got:?}");
                    assert!(
                        got[0].starts_with(&format!("{name}:")) && got[0].contains("lower"),
                        "{name}: {got:?}"
                    );
                } else {
                    assert!(got.is_empty(), "{name} at {factor}: {got:?}");
                }
            }
        }
        // The margin must be stated.
        let mut none = e.clone();
        none.as_object_mut()
            .expect("an object")
            .remove("margin_percent");
        let err = check(&ok, &tempfile_path::write(&none).0).expect_err("no margin");
        assert!(err.to_string().contains("margin_percent"), "{err}");
    }

    /// A static bound under the figure measured on the same ELF fails naming both, whatever
    /// the expectations say (here they are the report's own figures).
    #[test]
    fn a_static_bound_under_its_measured_figure_fails() {
        for &(board, bound, measured) in COVERS {
            let mut r = report(800, Some(1100), 60000);
            let m = figure(&r, board, measured).expect("measured");
            r[board][bound] = json!(m - 1.0);
            // Expectations equal to every figure of the report: only the bound's check fires.
            let mut e = expectations_value(1 << 20);
            for &(b, metric, path) in GUARDED {
                e[b][metric] = json!(figure(&r, b, path).expect("a figure"));
            }
            let got = check(&r, &tempfile_path::write(&e).0).expect("check");
            let name = format!("{board}.{bound}");
            assert_eq!(got.len(), 1, "{name}: {got:?}");
            assert!(
                got[0].starts_with(&format!("{name}:"))
                    && got[0].contains(&measured.join("."))
                    && got[0].contains("under-counts"),
                "{name}: {got:?}"
            );
            // Equal is sound.
            r[board][bound] = json!(m);
            e[board][bound] = json!(m);
            let got = check(&r, &tempfile_path::write(&e).0).expect("check");
            assert!(got.is_empty(), "{name} equal to its figure: {got:?}");
        }
    }

    #[test]
    fn over_budget_fails_even_within_the_expectation() {
        // Flash within 2 % of its expectation, but over the budget on both boards.
        let e = expectations(61000);
        let got = check(&report(800, Some(1100), 61100), &e.0).expect("check");
        assert_eq!(got.len(), 2, "{got:?}");
        assert!(got.iter().all(|r| r.contains("budget")), "{got:?}");
    }
}
