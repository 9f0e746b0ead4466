//! `host-sim`: trim the receiver, synthesise the gains, fly a docking.
//!
//! ```text
//! host-sim trim  [--speed-mps V] [--altitude-m H] [--xcg X] [--json]
//! host-sim gains [--json] [--write-core PATH]
//! host-sim dock  [--controller ibvs|pbvs] [--start FWD,RIGHT,DOWN] [--json] [--out DIR] [--no-files]
//! ```
//!
//! Exit status: 0 on success (for `dock`: the run completed, whatever its outcome), 1 on an
//! error, which is printed to stderr.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand, ValueEnum};
use host_sim::receiver::F16;
use host_sim::sim::{self, Scenario};
use host_sim::synthesis::{
    self, NOMINAL_XCG, REFUELLING_ALTITUDE_M, REFUELLING_SPEED_MPS, codegen,
};
use host_sim::{output, plot};
use ibvs_core::{Controller, ControllerConfig, OuterLaw};
use nalgebra::Vector3;

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

#[derive(Clone, Copy, ValueEnum)]
enum Law {
    Ibvs,
    Pbvs,
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
    /// Fly one docking from trim in calm air.
    Dock {
        /// Outer loop.
        #[arg(long, value_enum, default_value_t = Law::Ibvs)]
        controller: Law,
        /// Drogue centre minus probe tip at the start, tanker axes (forward, right, down), m.
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true, default_values_t = sim::PAPER_START_M)]
        start: Vec<f64>,
        /// Time budget, s.
        #[arg(long, default_value_t = 70.0)]
        duration_s: f64,
        /// IBVS outer gains k1,k2,k3,k4,k5 (normalised image units; default: the controller's).
        #[arg(long, value_delimiter = ',')]
        ibvs_gains: Option<Vec<f32>>,
        /// Minimum closing speed a, m/s (default: the controller's).
        #[arg(long)]
        min_closing_mps: Option<f32>,
        /// Print the summary as JSON.
        #[arg(long)]
        json: bool,
        /// Directory for run.csv, summary.json and dock.png.
        #[arg(long, value_name = "DIR", default_value = "out/dock")]
        out: PathBuf,
        /// Write no files.
        #[arg(long)]
        no_files: bool,
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

fn run(cli: Cli) -> Result<(), AnyError> {
    match cli.command {
        Command::Trim {
            speed_mps,
            altitude_m,
            xcg,
            json,
        } => trim(speed_mps, altitude_m, xcg, json),
        Command::Gains { json, write_core } => gains(json, write_core),
        Command::Dock {
            controller,
            start,
            duration_s,
            ibvs_gains,
            min_closing_mps,
            json,
            out,
            no_files,
        } => {
            let mut cfg = ControllerConfig {
                law: match controller {
                    Law::Ibvs => OuterLaw::Ibvs,
                    Law::Pbvs => OuterLaw::Pbvs,
                },
                ..ControllerConfig::default()
            };
            if start.len() != 3 {
                return Err("--start takes three values: forward,right,down".into());
            }
            if let Some(k) = ibvs_gains {
                if k.len() != 5 {
                    return Err("--ibvs-gains takes five values: k1,k2,k3,k4,k5".into());
                }
                let g = &mut cfg.ibvs;
                (g.k1_mps, g.k2_mps, g.k3_per_s, g.k4_mps, g.k5_mps) =
                    (k[0], k[1], k[2], k[3], k[4]);
            }
            if let Some(a) = min_closing_mps {
                cfg.velocity_limits.min_closing_mps = a;
            }
            dock(cfg, &start, duration_s, json, (!no_files).then_some(out))
        }
    }
}

fn trim(speed_mps: f64, altitude_m: f64, xcg: f64, json: bool) -> Result<(), AnyError> {
    let t = F16::new(xcg)?.trim_straight_level(speed_mps, altitude_m)?;
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
            "trim at {speed_mps} m/s, {altitude_m} m, xcg {xcg}: alpha = theta = {:.4} deg, throttle {:.4}, \
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

fn gains(json: bool, write_core: Option<PathBuf>) -> Result<(), AnyError> {
    let s = synthesis::nominal()?;
    if let Some(path) = &write_core {
        std::fs::write(path, codegen::render(&s))
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

fn dock(
    cfg: ControllerConfig,
    start: &[f64],
    duration_s: f64,
    json: bool,
    out: Option<PathBuf>,
) -> Result<(), AnyError> {
    let scenario = Scenario {
        start_offset_m: Vector3::from_column_slice(start),
        duration_s,
        ..Scenario::default()
    };
    let mut controller = Controller::new(cfg)?;
    let run = sim::run(&scenario, &mut controller)?;
    if let Some(dir) = &out {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        output::write_csv(&dir.join("run.csv"), &run)?;
        output::write_summary(&dir.join("summary.json"), &run)?;
        plot::write_dock_figure(&dir.join("dock.png"), &run)?;
        eprintln!(
            "wrote {0}/run.csv, {0}/summary.json, {0}/dock.png",
            dir.display()
        );
    }
    let s = &run.summary;
    if json {
        println!("{}", serde_json::to_string(s)?);
    } else {
        let num =
            |v: Option<f64>, unit: &str| v.map_or("n/a".to_string(), |v| format!("{v:.3} {unit}"));
        println!(
            "{:?}: miss {}, closure {}, at {:.2} s{}",
            s.outcome,
            num(s.miss_m, "m"),
            num(s.closure_mps, "m/s"),
            s.time_s,
            s.breakaway_reason
                .as_ref()
                .map_or(String::new(), |r| format!(", breakaway: {r}")),
        );
    }
    Ok(())
}
