//! `host-sim`: trim the receiver, synthesise the gains, fly dockings, reproduce the paper.
//!
//! ```text
//! host-sim trim      [--speed-mps V] [--altitude-m H] [--xcg X] [--json]
//! host-sim gains     [--json] [--write-core PATH]
//! host-sim margins   [--paper] [--design-latency D] [--by-node]
//! host-sim dock      [--scenario NAME|PATH] [--controller ibvs|pbvs] [--start F,R,D] [--seed N]
//!                    [--ibvs-gains k1,..,k5] [--min-closing-mps A] [--duration-s T]
//!                    [--json] [--out DIR] [--no-files] [--pil [--firmware ELF]]
//!                    [--hil --serial PATH [--baud B]]
//!                    [--animate [--still-s T]] [--log PATH.mcap]
//! host-sim scenarios
//! host-sim scenario show NAME|PATH
//! host-sim config    schema [--json] | show [--scenario NAME|PATH] [--json]
//! host-sim paper     [--out DIR] [--seeds N]
//! host-sim montecarlo --scenario NAME|PATH --runs N [--jobs J] [--shard K/M | --shards M] [--pil [--firmware ELF]] [--out DIR]
//! host-sim montecarlo --scenario NAME|PATH --show-run I
//! host-sim montecarlo merge DIR... [--out DIR]
//! ```
//!
//! Exit status: 0 on success (for `dock`: the run completed, whatever its outcome), 1 on an
//! error, which is printed to stderr, 2 on an argument clap refuses (a malformed value, or a
//! count, a time or a number of jobs outside its stated range, named with the range).
//!
//! Every input is bounded and named: counts at least 1 (`--runs`, `--seeds` at most 10,000,
//! `--shards`), `--jobs` 1 to 256, times finite and not negative, a flight condition inside
//! the models' range (`trim`), scenario files read with a size limit and their errors named
//! by file, line and key (`host_sim::scenario`), a firmware file checked to be the `qemu`
//! board's ARM ELF before QEMU starts, an option the scenario's procedure would ignore
//! refused, a shard merged twice refused.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use host_sim::animate::{self, AnimationOptions};
use host_sim::config_schema;
use host_sim::montecarlo::{self, CampaignComputer, CampaignMeta, Shard};
use host_sim::receiver::{F16, ReceiverPlant};
use host_sim::record::{self, Recording};
use host_sim::scenario::{ControllerSection, PRESETS, ScenarioFile};

use host_sim::sim::{self, Run};
use host_sim::synthesis::{self, NOMINAL_XCG, REFUELLING_ALTITUDE_M, REFUELLING_SPEED_MPS};
use host_sim::world::flight::FlightCondition;
use host_sim::{flight_log, output, paper, pil, plot};
use ibvs_core::wire::CostUnit;
use ibvs_core::{Controller, ControllerConfig, OuterLaw, Procedure};
use serde::Deserialize as _;

#[derive(Parser)]
#[command(
    name = "host-sim",
    version,
    about = "Simulator and gain synthesis for the IBVS probe-and-drogue docking controller"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Trim the F-16 for straight and level flight.
    Trim {
        /// True airspeed, m/s.
        #[arg(long, default_value_t = REFUELLING_SPEED_MPS)]
        speed_mps: f64,
        /// Altitude, m.
        #[arg(long, default_value_t = REFUELLING_ALTITUDE_M)]
        altitude_m: f64,
        /// Centre of gravity, fraction of the mean chord.
        #[arg(long, default_value_t = NOMINAL_XCG)]
        xcg: f64,
        /// The receiver's gross mass over the design's (the plant's `mass_scale`).
        #[arg(long, default_value_t = 1.0, value_parser = parse_mass_factor)]
        mass_factor: f64,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Synthesise the inner-loop gains at the refuelling trim.
    Gains {
        /// Print the discrete augmented A, B, Q, R, K of both channels as JSON.
        #[arg(long)]
        json: bool,
        /// Write the core's generated gains module to this path.
        #[arg(long, value_name = "PATH")]
        write_core: Option<PathBuf>,
    },
    /// Disk margins at the actuator inputs of the inner loops as flown, at every schedule
    /// node, true cg 0.30/0.35/0.40 and true navigation latency 0/1/2 periods
    /// (docs/margins.md).
    Margins {
        /// The paper's procedure's controller (default: the refuelling procedure's).
        #[arg(long)]
        paper: bool,
        /// The latency the controller's predictor compensates, control periods (default: the
        /// refuelling campaigns', 2; the paper's configuration's, 0).
        #[arg(long, value_parser = clap::value_parser!(u8).range(0..=4))]
        design_latency: Option<u8>,
        /// Print each node's worst figures (over the cgs and latencies) instead of every point.
        #[arg(long)]
        by_node: bool,
        /// The airframe's gross mass, a factor of the design's, and the configuration's
        /// (`mass_factor`: the refuelling procedure flies its light design below 0.95).
        #[arg(long, default_value_t = 1.0, value_parser = parse_mass_factor)]
        mass_factor: f64,
        /// The configuration's gross mass when it is not the airframe's (a mass set wrong):
        /// which design flies the airframe of `--mass-factor`.
        #[arg(long, value_parser = parse_mass_factor)]
        configured_mass_factor: Option<f64>,
    },
    /// Fly one docking. Options given here override the scenario's values.
    Dock {
        /// A built-in scenario (`host-sim scenarios` lists them) or a TOML file.
        #[arg(long, value_name = "NAME|PATH", default_value = "calm")]
        scenario: String,
        /// Outer loop of the paper's procedure (`controller.law`): ibvs or pbvs; refused under
        /// the refuelling procedure, which does not fly it.
        #[arg(long, value_parser = parse_law)]
        controller: Option<OuterLaw>,
        /// Drogue centre minus probe tip at the start, tanker axes (forward, right, down), m.
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
        start: Option<Vec<f64>>,
        /// Seed of every random process.
        #[arg(long)]
        seed: Option<u64>,
        /// IBVS outer gains k1,k2,k3,k4,k5 (`controller.ibvs.k1_mps` ..), m/s and 1/s.
        #[arg(long, value_delimiter = ',')]
        ibvs_gains: Option<Vec<f64>>,
        /// Minimum closing speed a (`controller.velocity_limits.min_closing_mps`), m/s.
        #[arg(long)]
        min_closing_mps: Option<f64>,
        /// Time budget, s.
        #[arg(long)]
        duration_s: Option<f64>,
        /// Print the summary as JSON.
        #[arg(long)]
        json: bool,
        /// Directory for run.csv, summary.json and dock.png.
        #[arg(long, value_name = "DIR", default_value = "out/dock")]
        out: PathBuf,
        /// Write no files.
        #[arg(long)]
        no_files: bool,
        /// Processor in the loop: fly the controller inside QEMU's emulated STM32F405 over
        /// the serial link (adds `step_instructions` and link counts to `--json`).
        #[arg(long)]
        pil: bool,
        /// Firmware ELF for `--pil` (default: `IBVS_FIRMWARE_ELF`, or the default build path).
        #[arg(long, value_name = "PATH", requires = "pil")]
        firmware: Option<PathBuf>,
        /// Hardware in the loop: fly the controller on a board (lockstep firmware) behind the
        /// serial device of `--serial` (firmware/README.md, "Hardware in the loop").
        #[arg(long, requires = "serial", conflicts_with = "pil")]
        hil: bool,
        /// The serial device of `--hil` (e.g. /dev/ttyUSB0).
        #[arg(long, value_name = "PATH", requires = "hil")]
        serial: Option<PathBuf>,
        /// The serial link's speed for `--hil`, bit/s (8N1, no flow control).
        #[arg(long, value_name = "B", default_value_t = 921_600, requires = "hil")]
        baud: u32,
        /// Also write dock.gif: chase views and the camera's image, animated (docs/logs.md).
        #[arg(long, conflicts_with = "no_files")]
        animate: bool,
        /// With `--animate`, also write dock-still.png: the animation's frame at this time, s
        /// (finite, at least 0; past the run's end, its last frame).
        #[arg(long, value_name = "T", requires = "animate", value_parser = parse_time_s)]
        still_s: Option<f64>,
        /// Write the flight-test log, MCAP with typed JSON channels, to this file (docs/logs.md).
        #[arg(long, value_name = "PATH.mcap")]
        log: Option<PathBuf>,
    },
    /// List the built-in scenarios.
    Scenarios,
    /// Work with one scenario.
    Scenario {
        #[command(subcommand)]
        action: ScenarioAction,
    },
    /// The controller's configuration: its schema, or the one a scenario flies.
    Config {
        #[command(subcommand)]
        action: ConfigAction,
    },
    /// Run the paper's four experiments and write their figures, data and summary table.
    Paper {
        /// Output directory.
        #[arg(long, value_name = "DIR", default_value = "out/paper")]
        out: PathBuf,
        /// Seeds per experiment (1 to 10,000).
        #[arg(long, default_value_t = paper::DEFAULT_SEEDS,
              value_parser = clap::value_parser!(u64).range(1..=MAX_SEEDS))]
        seeds: u64,
    },
    /// Monte Carlo campaign: many dockings of one scenario, dispersed per run by its
    /// `[dispersion]` table; statistics, per-run records and plots (docs/scenarios.md).
    Montecarlo(MonteCarloArgs),
}

#[derive(clap::Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
struct MonteCarloArgs {
    #[command(subcommand)]
    action: Option<MonteCarloAction>,
    /// A built-in scenario or a TOML file; its seed is the campaign's.
    #[arg(long, value_name = "NAME|PATH", required = true)]
    scenario: Option<String>,
    /// Runs in the whole campaign, at least 1 (run i flies the dispersion drawn for index i).
    #[arg(long, required_unless_present = "show_run",
          value_parser = clap::value_parser!(u64).range(1..))]
    runs: Option<u64>,
    /// The campaign's first run index: runs FIRST..FIRST+RUNS. A campaign reported on should
    /// not share runs with the ones its thresholds were chosen on (docs/scenarios.md,
    /// "Evaluation protocol").
    #[arg(long, value_name = "FIRST", default_value_t = 0)]
    first_run: u64,
    /// Parallel runs, 1 to 256 (default: one per core).
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=MAX_JOBS))]
    jobs: Option<u64>,
    /// Run only part K of M (1-based; the runs at positions K - 1, K - 1 + M, ... of the
    /// campaign), to merge later. Without it, a Slurm array task takes its part from
    /// SLURM_ARRAY_TASK_ID, and a Kubernetes Indexed Job from JOB_COMPLETION_INDEX with
    /// --shards.
    #[arg(long, value_name = "K/M")]
    shard: Option<Shard>,
    /// Number of parts of a Kubernetes Indexed Job (its completions), whose environment gives
    /// the part's 0-based index in JOB_COMPLETION_INDEX.
    #[arg(long, value_name = "M", conflicts_with = "shard",
          value_parser = clap::value_parser!(u64).range(1..))]
    shards: Option<u64>,
    /// Output directory.
    #[arg(long, value_name = "DIR", default_value = "out/montecarlo")]
    out: PathBuf,
    /// Processor in the loop: fly every run with the firmware inside QEMU's emulated
    /// STM32F405 (one emulator per run, at most --jobs at once); the records equal the
    /// in-process campaign's.
    #[arg(long)]
    pil: bool,
    /// Firmware ELF for `--pil` (default: `IBVS_FIRMWARE_ELF`, or the default build path).
    #[arg(long, value_name = "PATH", requires = "pil")]
    firmware: Option<PathBuf>,
    /// Print the scenario file of run I (dispersion applied) instead, to fly it with `dock`
    /// (with `--animate` and `--log` to watch or log it).
    #[arg(long, value_name = "I", conflicts_with_all = ["runs", "jobs", "shard", "shards"])]
    show_run: Option<u64>,
}

#[derive(Subcommand)]
enum MonteCarloAction {
    /// Merge the output directories of a campaign's shards into one.
    Merge {
        /// Shard output directories.
        #[arg(required = true, num_args = 1..)]
        dirs: Vec<PathBuf>,
        /// Output directory of the merged campaign.
        #[arg(long, value_name = "DIR", default_value = "out/montecarlo")]
        out: PathBuf,
    },
}

#[derive(Subcommand)]
enum ScenarioAction {
    /// Print a scenario as TOML, every key written out, to copy and edit.
    Show {
        /// Preset name or file.
        name: String,
    },
}

#[derive(Subcommand)]
enum ConfigAction {
    /// Every setting (a scenario's `[controller]` key, a configuration frame's field): unit,
    /// default, the paper's default where it differs, and the rules it must satisfy.
    Schema {
        /// As JSON.
        #[arg(long)]
        json: bool,
    },
    /// The whole configuration a scenario's controller flies, every key (the world's
    /// derived ones included), as TOML under `[controller]` or as JSON.
    Show {
        /// A built-in scenario or a TOML file.
        #[arg(long, value_name = "NAME|PATH", default_value = "calm")]
        scenario: String,
        /// As JSON.
        #[arg(long)]
        json: bool,
    },
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("host-sim: {e}");
            ExitCode::FAILURE
        }
    }
}

type AnyError = Box<dyn std::error::Error>;

/// The most parallel runs `--jobs` takes: a thread each (rayon's pool), far more than any
/// machine's cores; a larger pool only costs memory and start-up time.
const MAX_JOBS: u64 = 256;

/// The most seeds per experiment `paper --seeds` takes.
const MAX_SEEDS: u64 = 10_000;

/// A time of a run, s: finite and not negative.
fn parse_time_s(s: &str) -> Result<f64, String> {
    let t: f64 = s.trim().parse().map_err(|e| format!("{e}"))?;
    if t.is_finite() && t >= 0.0 {
        Ok(t)
    } else {
        Err(format!(
            "{t} s is not a time of the run: finite, at least 0"
        ))
    }
}

fn run(cli: Cli) -> Result<(), AnyError> {
    match cli.command {
        Command::Trim {
            speed_mps,
            altitude_m,
            xcg,
            mass_factor,
            json,
        } => trim(speed_mps, altitude_m, xcg, mass_factor, json),
        Command::Gains { json, write_core } => gains(json, write_core),
        Command::Margins {
            paper,
            design_latency,
            by_node,
            mass_factor,
            configured_mass_factor,
        } => margins(
            paper,
            design_latency,
            by_node,
            mass_factor,
            configured_mass_factor.unwrap_or(mass_factor),
        ),
        Command::Dock {
            scenario,
            controller,
            start,
            seed,
            ibvs_gains,
            min_closing_mps,
            duration_s,
            json,
            out,
            no_files,
            pil,
            firmware,
            hil,
            serial,
            baud,
            animate,
            still_s,
            log,
        } => {
            let given = Overrides {
                start: start.is_some(),
                duration: duration_s.is_some(),
                gains: ibvs_gains.is_some(),
                min_closing: min_closing_mps.is_some(),
            };
            let mut f = ScenarioFile::load(&scenario)?;
            let cfg = &mut f.controller.config;
            if let Some(c) = controller {
                // The law is the paper procedure's outer loop: under the refuelling procedure
                // it would be ignored, so it is refused rather than silently dropped.
                if cfg.procedure != Procedure::Paper {
                    return Err(format!(
                        "--controller {}: the outer law (controller.law) is flown by the \
                         paper's procedure only, and scenario {scenario} flies the {} \
                         procedure (controller.procedure); fly a paper scenario (`host-sim \
                         scenarios` lists them, e.g. --scenario paper-level1)",
                        law_name(c),
                        procedure_name(cfg.procedure),
                    )
                    .into());
                }
                cfg.law = c;
            }
            if let Some(v) = start {
                f.initial.drogue_minus_probe_m = v
                    .try_into()
                    .map_err(|_| "--start takes three values: forward,right,down")?;
            }
            if let Some(v) = seed {
                f.seed = v;
            }
            if let Some(k) = ibvs_gains {
                let [k1, k2, k3, k4, k5]: [f64; 5] = k
                    .try_into()
                    .map_err(|_| "--ibvs-gains takes five values: k1,k2,k3,k4,k5")?;
                let g = &mut cfg.ibvs;
                (g.k1_mps, g.k2_mps, g.k3_per_s, g.k4_mps, g.k5_mps) =
                    (k1 as f32, k2 as f32, k3 as f32, k4 as f32, k5 as f32);
            }
            if let Some(a) = min_closing_mps {
                cfg.velocity_limits.min_closing_mps = a as f32;
            }
            if let Some(t) = duration_s {
                f.duration_s = t;
            }
            // An error in what an option set names the option, as the user wrote it.
            f.validate().map_err(|e| -> AnyError {
                let key = e.to_string();
                let by_option = [
                    ("--start", given.start, "initial.drogue_minus_probe_m"),
                    ("--duration-s", given.duration, "duration_s"),
                    ("--ibvs-gains", given.gains, "controller.ibvs.k"),
                    (
                        "--min-closing-mps",
                        given.min_closing,
                        "controller.velocity_limits.min_closing_mps",
                    ),
                ];
                match by_option
                    .iter()
                    .find(|(_, set, k)| *set && key.starts_with(k))
                {
                    Some((option, _, _)) => format!("{option}: {key}").into(),
                    None => e.into(),
                }
            })?;
            let computer = match (pil, hil.then_some(serial).flatten()) {
                (true, _) => Computer::Pil(firmware),
                (false, Some(path)) => Computer::Hil { path, baud },
                (false, None) => Computer::InProcess,
            };
            let record = Record {
                animate,
                still_s,
                log,
            };
            dock(&f, computer, json, (!no_files).then_some(out), &record)
        }
        Command::Scenarios => {
            for (name, description, _) in PRESETS {
                println!("{name:<24} {description}");
            }
            Ok(())
        }
        Command::Scenario {
            action: ScenarioAction::Show { name },
        } => {
            print!("{}", ScenarioFile::load(&name)?.to_toml());
            Ok(())
        }
        Command::Config {
            action: ConfigAction::Schema { json },
        } => {
            let schema = config_schema::schema();
            if json {
                println!("{}", serde_json::to_string_pretty(&schema)?);
            } else {
                print!("{}", config_schema::to_text(&schema));
            }
            Ok(())
        }
        Command::Config {
            action: ConfigAction::Show { scenario, json },
        } => {
            let cfg = ScenarioFile::load(&scenario)?.controller_config();
            if json {
                println!("{}", serde_json::to_string_pretty(&cfg)?);
            } else {
                let section = ControllerSection {
                    config: cfg,
                    camera_position_given: true,
                    nav_latency_given: true,
                    mass_given: true,
                };
                let mut doc = toml::Table::new();
                doc.insert("controller".into(), toml::Value::Table(section.to_table()));
                print!("{}", toml::to_string(&doc)?);
            }
            Ok(())
        }
        Command::Paper { out, seeds } => {
            let report = paper::run_all(&out, seeds)?;
            print!("{report}");
            Ok(())
        }
        Command::Montecarlo(args) => monte_carlo(args),
    }
}

fn monte_carlo(args: MonteCarloArgs) -> Result<(), AnyError> {
    if let Some(MonteCarloAction::Merge { dirs, out }) = args.action {
        for (k, d) in dirs.iter().enumerate() {
            let same = |a: &Path, b: &Path| match (a.canonicalize(), b.canonicalize()) {
                (Ok(a), Ok(b)) => a == b,
                _ => a == b,
            };
            if let Some(first) = dirs[..k].iter().find(|e| same(e, d)) {
                return Err(format!(
                    "montecarlo merge: the shard {} is given twice ({} and {}): name each \
                     shard's directory once",
                    d.display(),
                    first.display(),
                    d.display()
                )
                .into());
            }
        }
        let summary = montecarlo::merge(&dirs, &out)?;
        println!("{}", montecarlo::one_line(&summary));
        eprintln!("merged {} directories into {}", dirs.len(), out.display());
        return Ok(());
    }
    let name = args.scenario.ok_or("--scenario is required")?;
    let f = ScenarioFile::load(&name)?;
    if let Some(i) = args.show_run {
        print!("{}", f.dispersed(i).to_toml());
        return Ok(());
    }
    let runs = args.runs.ok_or("--runs is required")?;
    let shard = match args.shard {
        Some(s) => Some(s),
        None => {
            let from_env = montecarlo::shard_from_env(|v| std::env::var(v).ok(), args.shards)?;
            if let Some((s, source)) = from_env {
                eprintln!("shard {s} from {source}");
            }
            from_env.map(|(s, _)| s)
        }
    };
    let indices = montecarlo::indices(args.first_run, runs, shard);
    let started = std::time::Instant::now();
    let computer = if args.pil {
        let elf = match args.firmware {
            Some(p) => p,
            None => pil::firmware_elf()?,
        };
        // Checked once, before any run starts an emulator.
        pil::check_firmware_elf(&elf)?;
        CampaignComputer::Pil(elf)
    } else {
        CampaignComputer::InProcess
    };
    let jobs = args.jobs.map(|j| j as usize);
    let lines = montecarlo::run_campaign_on(&f, &indices, jobs, &computer)?;
    let wall_s = started.elapsed().as_secs_f64();
    let meta = CampaignMeta::new(&f, runs, shard)
        .from_run(args.first_run)
        .on(&computer);
    let summary = montecarlo::write_campaign(&args.out, &meta, &lines)?;
    println!("{}", montecarlo::one_line(&summary));
    eprintln!(
        "{} runs in {wall_s:.1} s on {} threads; wrote {}/{{runs.jsonl, campaign.json, summary.json, miss_scatter.png, hazards.png, success_vs_turbulence.png, success_vs_condition.png}}",
        indices.len(),
        jobs.unwrap_or_else(rayon::current_num_threads),
        args.out.display()
    );
    Ok(())
}

fn trim(
    speed_mps: f64,
    altitude_m: f64,
    xcg: f64,
    mass_factor: f64,
    json: bool,
) -> Result<(), AnyError> {
    let mut factors = ReceiverPlant::NOMINAL;
    factors.mass_scale = mass_factor;
    let model = F16::with_plant(xcg, &factors)?;
    // The models' range, as a scenario's flight condition (the key as the user wrote it).
    FlightCondition {
        airspeed_mps: speed_mps,
        altitude_m,
    }
    .validate(|h| model.air_at(h), "--speed-mps", "--altitude-m")?;
    let t = model
        .trim_straight_level(speed_mps, altitude_m)
        .map_err(|e| {
            format!(
                "no trim at {speed_mps} m/s, {altitude_m} m, xcg {xcg}, mass factor {mass_factor}: {e}"
            )
        })?;
    if json {
        let v = serde_json::json!({
            "alpha_rad": t.alpha_rad,
            "theta_rad": t.theta_rad,
            "throttle": t.throttle,
            "elevator_deg": t.elevator_rad.to_degrees(),
            "aileron_deg": t.aileron_rad.to_degrees(),
            "rudder_deg": t.rudder_rad.to_degrees(),
            "residual": t.residual,
        });
        println!("{v}");
    } else {
        println!(
            "trim at {speed_mps} m/s, {altitude_m} m, xcg {xcg}, mass factor {mass_factor}: alpha = theta = {:.4} deg, throttle {:.4}, \
             elevator {:.4} deg, aileron {:.4} deg, rudder {:.4} deg (residual {:.1e})",
            t.alpha_rad.to_degrees(),
            t.throttle,
            t.elevator_rad.to_degrees(),
            t.aileron_rad.to_degrees(),
            t.rudder_rad.to_degrees(),
            t.residual
        );
    }
    Ok(())
}

fn margins(
    paper: bool,
    design_latency: Option<u8>,
    by_node: bool,
    mass_factor: f64,
    configured_mass_factor: f64,
) -> Result<(), AnyError> {
    let mut cfg = if paper {
        ControllerConfig::paper()
    } else {
        synthesis::margins::flown_config()
    };
    if let Some(d) = design_latency {
        cfg.nav_latency_steps = d;
    }
    cfg.mass_factor = configured_mass_factor as f32;
    cfg.validate()?;
    let grid = synthesis::margins::grid_on(&cfg, mass_factor)?;
    if by_node {
        print!("{}", synthesis::margins::node_table(&grid));
    } else {
        print!("{}", synthesis::margins::table(&grid));
    }
    Ok(())
}

/// A gross-mass factor the receiver's plant factors accept (`receiver.mass_scale`'s limits).
fn parse_mass_factor(s: &str) -> Result<f64, String> {
    let m: f64 = s.parse().map_err(|e| format!("{e}"))?;
    let limits = host_sim::receiver::FACTORS
        .iter()
        .find(|f| f.name == "mass_scale")
        .map(|f| f.limits)
        .ok_or("the plant has no mass factor")?;
    if limits.contains(m) {
        Ok(m)
    } else {
        Err(format!(
            "{m} is outside {} (a factor of the design's mass)",
            limits.text
        ))
    }
}

fn gains(json: bool, write_core: Option<PathBuf>) -> Result<(), AnyError> {
    let s = synthesis::nominal()?;
    if let Some(path) = &write_core {
        std::fs::write(path, synthesis::core_gains_module()?)
            .map_err(|e| format!("{}: {e}", path.display()))?;
        eprintln!("wrote {}", path.display());
    }
    if json {
        println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({ "lon": s.lon, "lat": s.lat }))?
        );
    } else if write_core.is_none() {
        for (name, d) in [("lon", &s.lon), ("lat", &s.lat)] {
            println!(
                "{name}: K ({}x{}), closed-loop spectral radius {:.6}, Riccati residual {:.1e}",
                d.k.nrows(),
                d.k.ncols(),
                d.closed_loop_spectral_radius,
                d.riccati_residual
            );
        }
    }
    Ok(())
}

/// Writes a run (flown with `cfg`)'s CSV, summary and figure into `dir`.
fn write_run(dir: &Path, run: &Run, cfg: &ControllerConfig) -> Result<(), AnyError> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    output::write_csv(&dir.join("run.csv"), run)?;
    output::write_summary(&dir.join("summary.json"), run)?;
    plot::write_dock_figure(&dir.join("dock.png"), run, cfg)?;
    Ok(())
}

/// What `dock` records beyond its usual files.
struct Record {
    /// Write dock.gif.
    animate: bool,
    /// Write dock-still.png, the frame at this time.
    still_s: Option<f64>,
    /// Write the MCAP log here.
    log: Option<PathBuf>,
}

impl Record {
    fn any(&self) -> bool {
        self.animate || self.log.is_some()
    }

    /// Writes the animation and the log of a recorded run; reports what was written.
    fn write(&self, dir: Option<&Path>, run: &Run, rec: &Recording) -> Result<(), AnyError> {
        if let (true, Some(dir)) = (self.animate, dir) {
            let path = dir.join("dock.gif");
            let started = std::time::Instant::now();
            let a = animate::write_gif(&path, run, rec, &AnimationOptions::default())?;
            eprintln!(
                "wrote {}: {} frames of {} x {} px at {} ms, {} bytes, in {:.1} s",
                path.display(),
                a.frames,
                a.width_px,
                a.height_px,
                u32::from(a.frame_delay_cs) * 10,
                a.bytes,
                started.elapsed().as_secs_f64()
            );
            if let Some(t) = self.still_s {
                let k = run
                    .samples
                    .iter()
                    .rposition(|s| s.time_s <= t)
                    .unwrap_or_default();
                let still = dir.join("dock-still.png");
                animate::write_frame_png(&still, run, rec, k)?;
                eprintln!(
                    "wrote {} (t = {:.2} s)",
                    still.display(),
                    run.samples[k].time_s
                );
            }
        }
        if let Some(path) = &self.log {
            if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
                std::fs::create_dir_all(parent)
                    .map_err(|e| format!("{}: {e}", parent.display()))?;
            }
            let l = flight_log::write_mcap(path, run, rec)?;
            eprintln!(
                "wrote {}: {} messages on {} channels, {} bytes",
                path.display(),
                l.total_messages(),
                l.messages.len(),
                l.bytes
            );
        }
        Ok(())
    }
}

/// Where the controller runs.
enum Computer {
    /// `ibvs_core::Controller` in this process.
    InProcess,
    /// The firmware in QEMU (optionally a given ELF).
    Pil(Option<PathBuf>),
    /// A board behind a serial device.
    Hil {
        /// The device.
        path: PathBuf,
        /// Its speed, bit/s.
        baud: u32,
    },
}

fn dock(
    f: &ScenarioFile,
    computer: Computer,
    json: bool,
    out: Option<PathBuf>,
    record: &Record,
) -> Result<(), AnyError> {
    let cfg = f.controller_config();
    let scenario = f.scenario();
    let mut recording = None;
    let (run, pil) = match computer {
        Computer::InProcess if record.any() => {
            let (run, rec) = record::run(&scenario, &mut Controller::new(cfg)?, &[])?;
            recording = Some(rec);
            (run, None)
        }
        Computer::InProcess => (sim::run(&scenario, &mut Controller::new(cfg)?)?, None),
        Computer::Pil(_) | Computer::Hil { .. } => {
            let (mut fc, flag) = if let Computer::Hil { path, baud } = computer {
                let opts = pil::PilOptions::default();
                (
                    pil::PilFlightComputer::open_serial(&path, baud, opts)?,
                    "--hil",
                )
            } else {
                let elf = match computer {
                    Computer::Pil(Some(p)) => p,
                    _ => pil::firmware_elf()?,
                };
                (pil::PilFlightComputer::spawn(&elf)?, "--pil")
            };
            // The scenario's controller configuration, over the link, before the first step.
            fc.configure(&cfg)?;
            let run = if record.any() {
                let (run, rec) = record::run_pil(&scenario, &mut fc, &[])?;
                recording = Some(rec);
                run
            } else {
                sim::run(&scenario, &mut fc)?
            };
            let failure = fc.last_error().map(ToString::to_string);
            let (stats, log) = fc.shutdown();
            if let Some(e) = failure {
                return Err(
                    format!("{flag}: the serial link failed: {e}\nfirmware log:\n{log}").into(),
                );
            }
            (run, Some(stats))
        }
    };
    if let Some(dir) = &out {
        write_run(dir, &run, &cfg)?;
        eprintln!(
            "wrote {0}/run.csv, {0}/summary.json, {0}/dock.png",
            dir.display()
        );
    }
    if let Some(rec) = recording {
        let rec = rec.with_config(cfg);
        record.write(out.as_deref(), &run, &rec)?;
    }
    let s = &run.summary;
    if json {
        let mut v = serde_json::to_value(s)?;
        if let (Some(stats), Some(obj)) = (&pil, v.as_object_mut()) {
            let cost = stats
                .step_cost
                .ok_or("the firmware reported no step cost")?;
            // Instructions under QEMU, cycles on a board (its DWT counter).
            let key = match cost.unit {
                CostUnit::Cycles => "step_cycles",
                _ => "step_instructions",
            };
            obj.insert(
                key.into(),
                serde_json::json!({ "min": cost.min, "median": cost.median, "max": cost.max }),
            );
            obj.insert(
                "link".into(),
                serde_json::json!({ "firmware": stats.firmware_link, "host": stats.host }),
            );
        }
        println!("{v}");
    } else {
        println!("{}", output::one_line(s));
        if let Some(cost) = pil.as_ref().and_then(|p| p.step_cost) {
            println!(
                "step on the MCU: {} / {} / {} {} (min / median / max over {} steps)",
                cost.min,
                cost.median,
                cost.max,
                match cost.unit {
                    CostUnit::Cycles => "cycles",
                    _ => "instructions",
                },
                cost.samples
            );
        }
    }
    Ok(())
}

/// Which of `dock`'s options override the scenario's values.
struct Overrides {
    /// `--start`.
    start: bool,
    /// `--duration-s`.
    duration: bool,
    /// `--ibvs-gains`.
    gains: bool,
    /// `--min-closing-mps`.
    min_closing: bool,
}

/// An outer law's name in scenario files.
fn law_name(l: OuterLaw) -> String {
    serde_json::to_value(l)
        .ok()
        .and_then(|v| v.as_str().map(str::to_owned))
        .unwrap_or_else(|| format!("{l:?}"))
}

/// A procedure's name in scenario files.
fn procedure_name(p: Procedure) -> String {
    serde_json::to_value(p)
        .ok()
        .and_then(|v| v.as_str().map(str::to_owned))
        .unwrap_or_else(|| format!("{p:?}"))
}

/// `--controller`: an outer law by its name in scenario files (`ibvs`, `pbvs`).
fn parse_law(s: &str) -> Result<OuterLaw, String> {
    OuterLaw::deserialize(serde::de::value::StrDeserializer::<serde::de::value::Error>::new(s))
        .map_err(|e| format!("{e} (ibvs or pbvs)"))
}
