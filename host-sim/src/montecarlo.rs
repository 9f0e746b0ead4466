//! Monte Carlo campaigns: many dockings of one scenario with its `[dispersion]` drawn per
//! run, their statistics and plots; shards of a campaign run anywhere and merge exactly.
//!
//! Run `i` of a campaign flies [`ScenarioFile::dispersed`]`(i)`: its seed and dispersed
//! inputs are a function of the scenario file (its seed included) and `i` alone, so the
//! runs can be split over machines (`--shard K/M`: the runs `i` with `i mod M = K - 1`) and
//! the shards merged ([`merge`]) into exactly the output of one machine. Runs are parallel
//! (rayon); the output is in index order whatever the parallelism.
//!
//! A campaign is runs `first_run .. first_run + runs` (`--first-run`, default 0), so that a
//! campaign reported on can be one that no threshold was chosen on (`docs/scenarios.md`,
//! "Evaluation protocol").
//!
//! Output directory:
//! - `runs.jsonl`: one JSON object per run, in index order: [`RunRecord`] (inputs, outcome,
//!   the referee's docking, every crossing of the drogue plane and every hazard, failure
//!   cause);
//! - `campaign.json`: [`CampaignMeta`] (the scenario as TOML, the campaign's first run and
//!   size, the shard);
//! - `summary.json`: [`CampaignSummary`] (docked and success rates with 95 % Wilson
//!   intervals, each hazard's count with its one-sided 95 % upper bound, the crossings by
//!   verdict, miss, closing and lateral-speed percentiles, failure causes, success against
//!   turbulence intensity, success per cell of the gain schedule's grid of flight conditions
//!   and the runs outside it);
//! - `miss_scatter.png`: every crossing of the drogue plane, seen from behind, one marker per
//!   crossing and a marker shape per verdict (docking, hard contact, basket strike, fly-by),
//!   with the capture and strike circles; `hazards.png`: where every hazard happened, top and
//!   side views in the tanker frame; `success_vs_turbulence.png`: success rate (and its
//!   interval) per turbulence-intensity bin; `success_vs_condition.png`: success rate per cell
//!   of the grid as a heat map of airspeed by altitude.
//!
//! The cells are those of the core's gain schedule ([`ibvs_core::gains::SCHEDULE_SPEEDS_MPS`]
//! by [`ibvs_core::gains::SCHEDULE_ALTITUDES_M`]), taken from the run's true flight
//! condition; a condition on an inner grid line is in the cell below it on that axis, as the
//! core's interpolation takes it ([`condition_cell`]), so every run is in exactly one cell or
//! outside the grid.
//!
//! Definitions (also in `docs/scenarios.md`, "Monte Carlo campaigns"), all from the referee
//! ([`crate::referee`]), which reads the simulator's truth and never the controller:
//! - *docked*: the coupling latched (inside the capture radius, closing in the band, within
//!   the lateral limit), at any attempt;
//! - *unsafe*: any hazard (basket strike, hard contact, drogue on the airframe, hose contact,
//!   tanker proximity, upset near the tanker);
//! - *success*: docked and safe.
//!
//! Invariants: nothing in the files depends on the machine, the number of jobs or the shard
//! split (wall time is printed, not written); the summary is computed from the JSON lines as
//! written, so a merge reproduces it bit for bit.

use std::collections::BTreeMap;
use std::fmt;
use std::io::IsTerminal as _;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use ibvs_core::Controller;

use crate::pil::PilFlightComputer;
use indicatif::{ProgressBar, ProgressStyle};
use plotters::prelude::*;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::docking::CLOSING_BAND_MPS;
use crate::output::OutputError;
use crate::plot::{self, PALETTE, dbg};
use crate::referee::{CrossingVerdict, Direction, Hazard, HazardKind, Limits};
use crate::scenario::{DispersionSection, ScenarioError, ScenarioFile};
use crate::sim::{self, Outcome, Run};
use crate::world::drogue::CAPTURE_RADIUS_M;

/// z of the two-sided 95 % normal interval.
const Z95: f64 = 1.959_963_984_540_054;

/// Why a campaign could not be run, written or merged.
#[derive(Debug, thiserror::Error)]
pub enum McError {
    /// The scenario.
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    /// File system.
    #[error("{path}: {source}")]
    Io {
        /// Path.
        path: String,
        /// Error.
        source: std::io::Error,
    },
    /// JSON encoding or decoding.
    #[error("{path}: {source}")]
    Json {
        /// Path (or what was encoded).
        path: String,
        /// Error.
        source: serde_json::Error,
    },
    /// A plot.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// The thread pool.
    #[error("thread pool: {0}")]
    Pool(String),
    /// Shards that do not belong together or do not make up the campaign.
    #[error("merge: {0}")]
    Merge(String),
}

fn io_err(path: &Path) -> impl Fn(std::io::Error) -> McError + '_ {
    move |source| McError::Io {
        path: path.display().to_string(),
        source,
    }
}

/// Part `k` of `m` (1-based) of a campaign: the runs `i` with `i mod m = k - 1`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// This part, 1..=m.
    pub k: u64,
    /// Number of parts.
    pub m: u64,
}

impl FromStr for Shard {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("--shard takes K/M with 1 <= K <= M, got {s:?}");
        let (k, m) = s.split_once('/').ok_or_else(bad)?;
        let (k, m): (u64, u64) = (
            k.trim().parse().map_err(|_| bad())?,
            m.trim().parse().map_err(|_| bad())?,
        );
        if k == 0 || k > m {
            return Err(bad());
        }
        Ok(Self { k, m })
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.k, self.m)
    }
}

/// Where a shard was taken from when `--shard` was not given.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShardSource {
    /// A Slurm job array: `SLURM_ARRAY_TASK_ID` within `SLURM_ARRAY_TASK_MIN` and
    /// `SLURM_ARRAY_TASK_COUNT`.
    SlurmArray,
    /// A Kubernetes Indexed Job: `JOB_COMPLETION_INDEX` (0-based) of `--shards M`.
    IndexedJob,
}

impl fmt::Display for ShardSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::SlurmArray => "the Slurm job array (SLURM_ARRAY_TASK_ID)",
            Self::IndexedJob => "the Kubernetes Indexed Job (JOB_COMPLETION_INDEX)",
        })
    }
}

/// The shard of a job of a batch system, from its environment (`lookup` reads a variable),
/// for a campaign run without `--shard`. `shards` is `--shards M`, the number of completions
/// of a Kubernetes Indexed Job (whose environment carries the index only).
///
/// - Slurm job arrays (`sbatch --array=A-B`): shard
///   `SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN + 1` of `SLURM_ARRAY_TASK_COUNT`. The array must be a contiguous range of step 1 (a list
///   or a step would leave runs unflown, so it is refused); `--shards`, if given, must equal
///   the count.
/// - Kubernetes Indexed Jobs: shard `JOB_COMPLETION_INDEX + 1` of `--shards M`, which is then
///   required.
/// - Neither: `Ok(None)`, the whole campaign; `--shards` alone is an error, as is an
///   environment that names both.
///
/// Every refusal names the variable and what was wrong, so a batch job fails at once instead
/// of flying the wrong runs.
pub fn shard_from_env(
    lookup: impl Fn(&str) -> Option<String>,
    shards: Option<u64>,
) -> Result<Option<(Shard, ShardSource)>, String> {
    let num = |name: &str| -> Result<Option<u64>, String> {
        lookup(name)
            .map(|v| {
                v.trim()
                    .parse::<u64>()
                    .map_err(|_| format!("{name}={v:?} is not a non-negative integer"))
            })
            .transpose()
    };
    let slurm = num("SLURM_ARRAY_TASK_ID")?;
    let indexed = num("JOB_COMPLETION_INDEX")?;
    match (slurm, indexed) {
        (Some(_), Some(_)) => Err(
            "both SLURM_ARRAY_TASK_ID and JOB_COMPLETION_INDEX are set: say which shard with --shard K/M"
                .into(),
        ),
        (Some(id), None) => {
            let need = |name: &str| {
                num(name)?.ok_or_else(|| format!("SLURM_ARRAY_TASK_ID is set but {name} is not"))
            };
            let (min, max, count) = (
                need("SLURM_ARRAY_TASK_MIN")?,
                need("SLURM_ARRAY_TASK_MAX")?,
                need("SLURM_ARRAY_TASK_COUNT")?,
            );
            if let Some(step) = num("SLURM_ARRAY_TASK_STEP")?
                && step != 1
            {
                return Err(format!(
                    "the Slurm array steps by {step}: use a contiguous range (--array=A-B)"
                ));
            }
            if count == 0 || max < min || max - min + 1 != count {
                return Err(format!(
                    "the Slurm array {min}..={max} of {count} tasks is not a contiguous range: use --array=A-B"
                ));
            }
            if !(min..=max).contains(&id) {
                return Err(format!(
                    "SLURM_ARRAY_TASK_ID={id} is outside the array {min}..={max}"
                ));
            }
            if let Some(m) = shards
                && m != count
            {
                return Err(format!(
                    "--shards {m} differs from SLURM_ARRAY_TASK_COUNT={count}"
                ));
            }
            Ok(Some((
                Shard {
                    k: id - min + 1,
                    m: count,
                },
                ShardSource::SlurmArray,
            )))
        }
        (None, Some(index)) => {
            let m = shards.ok_or(
                "JOB_COMPLETION_INDEX is set: give the Indexed Job's completions as --shards M",
            )?;
            if index >= m {
                return Err(format!(
                    "JOB_COMPLETION_INDEX={index} is not below --shards {m}"
                ));
            }
            Ok(Some((Shard { k: index + 1, m }, ShardSource::IndexedJob)))
        }
        (None, None) => match shards {
            Some(m) => Err(format!(
                "--shards {m} without JOB_COMPLETION_INDEX or SLURM_ARRAY_TASK_ID: give --shard K/M"
            )),
            None => Ok(None),
        },
    }
}

/// The run indices of a campaign of `runs` runs from `first_run` in `shard` (all of them
/// without one): shard `K/M` takes the runs at positions `K - 1, K - 1 + M, ...` of the
/// campaign.
pub fn indices(first_run: u64, runs: u64, shard: Option<Shard>) -> Vec<u64> {
    let end = first_run.saturating_add(runs);
    match shard {
        None => (first_run..end).collect(),
        Some(s) => (first_run.saturating_add(s.k - 1)..end)
            .step_by(s.m as usize)
            .collect(),
    }
}

/// What one run flew (every value a dispersion may change, dispersed or not).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RunInputs {
    /// Start: drogue centre minus probe tip, tanker axes (forward, right, down), m.
    pub drogue_minus_probe_m: [f64; 3],
    /// RMS gust speed, m/s.
    pub turbulence_sigma_mps: f64,
    /// Pixel noise per LED centroid, px.
    pub pixel_noise_px: f64,
    /// Camera latency, frames.
    pub latency_frames: u32,
    /// Camera mount position error (true minus believed), body axes, m.
    pub mount_error_m: [f64; 3],
    /// Camera boresight pitch error, degrees.
    pub mount_pitch_error_deg: f64,
    /// Receiver cg, fraction of the mean chord.
    pub xcg: f64,
    /// Navigation latency, control steps (`None`: perfect navigation).
    pub nav_latency_steps: Option<u32>,
    /// Flight condition: true airspeed, m/s.
    pub airspeed_mps: f64,
    /// Flight condition: altitude, m.
    pub altitude_m: f64,
    /// The plant the run flew, which the controller's design does not know (all nominal
    /// unless the campaign disperses it).
    pub plant: PlantInputs,
    /// The range to the drogue at which the tanker calls a breakaway, m (`None`: no call).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub abort_at_range_m: Option<f64>,
}

/// The true plant of one run: the receiver's factors and the world's physical parameters
/// (docs/models.md, "Receiver plant dispersions" and each model's dispersion).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PlantInputs {
    /// The receiver's factors on its aerodynamics, mass, inertia, actuators and engine.
    pub receiver: crate::receiver::ReceiverPlant,
    /// Drogue mass, kg.
    pub drogue_mass_kg: f64,
    /// Canopy drag coefficient.
    pub drogue_drag_coefficient: f64,
    /// Hose length, m.
    pub hose_length_m: f64,
    /// Hose mass per length, kg/m.
    pub hose_linear_density_kg_per_m: f64,
    /// Factor on the hose's drag coefficients.
    pub hose_drag_scale: f64,
    /// Dryden scale length, m (`None`: the turbulence model's own by altitude).
    pub turbulence_scale_length_m: Option<f64>,
    /// Factor on the tanker wake's circulation.
    pub tanker_wake_strength: f64,
    /// Factor on the bow wave's effect.
    pub bow_wave_strength: f64,
    /// Camera mount roll and yaw errors, degrees.
    pub mount_roll_yaw_error_deg: [f64; 2],
    /// True focal length minus the calibration's, px.
    pub focal_error_px: f64,
    /// True principal point minus the calibration's (u, v), px.
    pub principal_point_error_px: [f64; 2],
    /// Residual radial distortion `k1`, `k2`.
    pub radial_distortion_k: [f64; 2],
    /// The INS's grade.
    pub ins_grade: crate::world::nav::InsGrade,
}

impl PlantInputs {
    /// The plant of a run's scenario file.
    pub fn of(f: &ScenarioFile) -> Self {
        let (d, c) = (&f.drogue, &f.camera);
        Self {
            receiver: f.receiver.plant,
            drogue_mass_kg: d.drogue_mass_kg,
            drogue_drag_coefficient: d.drogue_drag_coefficient,
            hose_length_m: d.hose_length_m,
            hose_linear_density_kg_per_m: d.hose_linear_density_kg_per_m,
            hose_drag_scale: d.hose_drag_scale,
            turbulence_scale_length_m: f.turbulence.scale_length_m,
            tanker_wake_strength: f.tanker_wake.strength,
            bow_wave_strength: f.bow_wave.strength,
            mount_roll_yaw_error_deg: [c.mount_roll_error_deg, c.mount_yaw_error_deg],
            focal_error_px: c.focal_error_px,
            principal_point_error_px: c.principal_point_error_px,
            radial_distortion_k: [c.radial_distortion_k1, c.radial_distortion_k2],
            ins_grade: f.navigation.grade,
        }
    }
}

impl RunInputs {
    /// The inputs of a run's scenario file.
    pub fn of(f: &ScenarioFile) -> Self {
        Self {
            drogue_minus_probe_m: f.initial.drogue_minus_probe_m,
            turbulence_sigma_mps: f.sigma_mps(),
            pixel_noise_px: f.camera.pixel_noise_px,
            latency_frames: f.camera.latency_frames,
            mount_error_m: f.camera.mount_error_m,
            mount_pitch_error_deg: f.camera.mount_pitch_error_deg,
            xcg: f.receiver.xcg,
            nav_latency_steps: match f.navigation.model {
                crate::scenario::NavModel::Ins => Some(f.navigation.ins.latency_steps),
                crate::scenario::NavModel::Ideal => None,
            },
            airspeed_mps: f.flight.airspeed_mps,
            altitude_m: f.flight.altitude_m,
            plant: PlantInputs::of(f),
            abort_at_range_m: f.abort.at_range_m,
        }
    }
}

/// How a campaign run ended ([`Outcome`], or an error before it could start).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RunOutcome {
    /// Docked.
    Docked,
    /// Reached the drogue plane outside the capture radius or the closing band.
    Missed,
    /// Neither contact nor breakaway in the time budget.
    Timeout,
    /// Broke away before reaching the plane.
    Aborted,
    /// The run could not start (the message is the failure cause).
    Error,
}

impl From<Outcome> for RunOutcome {
    fn from(o: Outcome) -> Self {
        match o {
            Outcome::Docked => Self::Docked,
            Outcome::Missed => Self::Missed,
            Outcome::Timeout => Self::Timeout,
            Outcome::Aborted => Self::Aborted,
        }
    }
}

impl RunOutcome {
    fn name(self) -> &'static str {
        match self {
            Self::Docked => "docked",
            Self::Missed => "missed",
            Self::Timeout => "timeout",
            Self::Aborted => "aborted",
            Self::Error => "error",
        }
    }
}

/// A crossing of the drogue plane in `runs.jsonl`: the referee's record, and what the
/// controller was flying then (for the reader: the verdict never reads it).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CrossingLine {
    /// Time, s.
    pub time_s: f64,
    /// The attempt the controller was flying.
    pub attempt: u8,
    /// The controller's mode then.
    pub mode: String,
    /// Which way the probe tip crossed.
    pub direction: Direction,
    /// Probe tip relative to the drogue centre, seen from behind: right, up, m.
    pub offset_m: [f64; 2],
    /// Radial offset, m.
    pub miss_m: f64,
    /// Closing speed (negative outbound), m/s.
    pub closing_mps: f64,
    /// Speed across the drogue's axis relative to it, m/s.
    pub lateral_mps: f64,
    /// The referee's verdict.
    pub verdict: CrossingVerdict,
}

/// One line of `runs.jsonl`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    /// Run index in the campaign.
    pub index: u64,
    /// The run's seed (turbulence, camera).
    pub seed: u64,
    /// What it flew.
    pub inputs: RunInputs,
    /// How the procedure ended ([`Outcome`]: the docking is the referee's, the rest
    /// describes the procedure).
    pub outcome: RunOutcome,
    /// The referee: the coupling latched.
    pub docked: bool,
    /// The referee: no hazard.
    pub safe: bool,
    /// Docked and safe.
    pub success: bool,
    /// Why it did not dock (`None` when it docked).
    pub failure: Option<String>,
    /// Radial miss at the decisive crossing (the docking, or the first miss while the
    /// controller pushed), m.
    pub miss_m: Option<f64>,
    /// Closing speed then, m/s.
    pub closure_mps: Option<f64>,
    /// Speed across the drogue's axis at the docking, m/s.
    pub lateral_mps: Option<f64>,
    /// Time of the decisive event, s.
    pub time_s: f64,
    /// The controller's breakaway reason, if it broke away (before or after the plane).
    pub breakaway_reason: Option<String>,
    /// Attempts flown (1 for the paper's procedure).
    pub attempts: u8,
    /// How each attempt ended, in order (`docked`, `no-go: <reason>`, `breakaway: <reason>`,
    /// `unfinished`; `struck` appended when the probe crossed without docking while the
    /// controller pushed).
    pub attempt_ends: Vec<String>,
    /// Docked at the first attempt.
    pub first_attempt_docked: bool,
    /// Every crossing of the drogue plane, in time order.
    pub crossings: Vec<CrossingLine>,
    /// Every hazard, in order of onset.
    pub hazards: Vec<Hazard>,
    /// When the tanker's breakaway call was made, s (`None`: none, or its range was never
    /// reached).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub abort_called_s: Option<f64>,
}

/// The record of a finished run.
fn classify(index: u64, f: &ScenarioFile, run: &Run) -> RunRecord {
    let s = &run.summary;
    let v = &run.verdict;
    let reached = s.miss_m.zip(s.closure_mps);
    let failure = match s.outcome {
        Outcome::Docked => None,
        Outcome::Aborted => Some(format!(
            "breakaway: {}",
            s.breakaway_reason.as_deref().unwrap_or("unknown")
        )),
        Outcome::Timeout => Some("timeout".into()),
        Outcome::Missed => Some(
            match reached {
                Some((m, _)) if m >= CAPTURE_RADIUS_M => "missed: outside the capture radius",
                Some((_, c)) if c > CLOSING_BAND_MPS.1 => "missed: closing faster than the band",
                Some((_, c)) if c >= CLOSING_BAND_MPS.0 => "missed: sliding across too fast",
                _ => "missed: closing slower than the band",
            }
            .into(),
        ),
    };
    RunRecord {
        index,
        seed: f.seed,
        inputs: RunInputs::of(f),
        outcome: s.outcome.into(),
        docked: v.docked(),
        safe: v.safe(),
        success: v.success(),
        failure,
        miss_m: s.miss_m,
        closure_mps: s.closure_mps,
        lateral_mps: v.docking.map(|d| d.lateral_mps),
        time_s: s.time_s,
        breakaway_reason: s.breakaway_reason.clone(),
        attempts: s.attempts,
        attempt_ends: run
            .attempts
            .iter()
            .map(|a| {
                if a.struck {
                    format!("{} (struck)", a.end)
                } else {
                    a.end.clone()
                }
            })
            .collect(),
        first_attempt_docked: run.attempts.first().is_some_and(|a| a.end == "docked"),
        crossings: run
            .crossings
            .iter()
            .map(|e| CrossingLine {
                time_s: e.crossing.time_s,
                attempt: e.attempt,
                mode: format!("{:?}", e.mode),
                direction: e.crossing.direction,
                offset_m: e.crossing.offset_m,
                miss_m: e.crossing.miss_m,
                closing_mps: e.crossing.closing_mps,
                lateral_mps: e.crossing.lateral_mps,
                verdict: e.crossing.verdict,
            })
            .collect(),
        hazards: v.hazards.clone(),
        abort_called_s: run.abort_called_s,
    }
}

/// What flies a campaign's runs.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum CampaignComputer {
    /// The core's controller in this process.
    #[default]
    InProcess,
    /// The firmware at this ELF in QEMU, one emulator per run (booted for the run, sent the
    /// run's configuration over the link, stopped after it): each run starts from power-on,
    /// as an in-process run starts from `Controller::new`, so the records are the same.
    Pil(PathBuf),
}

impl CampaignComputer {
    /// Its name in `campaign.json`.
    pub fn name(&self) -> &'static str {
        match self {
            Self::InProcess => "in-process",
            Self::Pil(_) => "pil",
        }
    }
}

/// Flies `f` on `computer`.
fn fly(f: &ScenarioFile, computer: &CampaignComputer) -> Result<Run, String> {
    let cfg = f.controller_config();
    match computer {
        CampaignComputer::InProcess => Controller::new(cfg)
            .map_err(|e| e.to_string())
            .and_then(|mut c| sim::run(&f.scenario(), &mut c).map_err(|e| e.to_string())),
        CampaignComputer::Pil(elf) => {
            let mut fc = PilFlightComputer::spawn(elf).map_err(|e| e.to_string())?;
            fc.configure(&cfg).map_err(|e| e.to_string())?;
            let run = sim::run(&f.scenario(), &mut fc).map_err(|e| e.to_string());
            let failure = fc.last_error().map(|e| format!("serial link: {e}"));
            fc.shutdown();
            match failure {
                Some(e) => Err(e),
                None => run,
            }
        }
    }
}

/// Flies run `index` of a campaign over `base`, in process.
pub fn run_one(base: &ScenarioFile, index: u64) -> RunRecord {
    run_one_on(base, index, &CampaignComputer::InProcess)
}

/// Flies run `index` of a campaign over `base` on `computer`. A run that could not be flown
/// (an invalid configuration, a failed serial link) is a record with outcome `error` and the
/// reason, never a missing line.
pub fn run_one_on(base: &ScenarioFile, index: u64, computer: &CampaignComputer) -> RunRecord {
    let f = base.dispersed(index);
    match fly(&f, computer) {
        Ok(run) => classify(index, &f, &run),
        Err(e) => RunRecord {
            index,
            seed: f.seed,
            inputs: RunInputs::of(&f),
            outcome: RunOutcome::Error,
            docked: false,
            safe: false,
            success: false,
            failure: Some(format!("error: {e}")),
            miss_m: None,
            closure_mps: None,
            lateral_mps: None,
            time_s: 0.0,
            breakaway_reason: None,
            attempts: 0,
            attempt_ends: Vec::new(),
            first_attempt_docked: false,
            crossings: Vec::new(),
            hazards: Vec::new(),
            abort_called_s: None,
        },
    }
}

/// `campaign.json`: what the runs are runs of.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct CampaignMeta {
    /// Scenario name.
    pub scenario: String,
    /// The scenario file, every key written out (its `[dispersion]` included).
    pub scenario_toml: String,
    /// The campaign's first run index (`--first-run`).
    #[serde(default)]
    pub first_run: u64,
    /// Runs in the whole campaign.
    pub runs: u64,
    /// The shard these runs are (`"K/M"`), none for a whole or merged campaign.
    pub shard: Option<String>,
    /// The simulator's version (shards of different versions are not merged).
    pub host_sim_version: String,
    /// What flew the runs: `in-process` or `pil` ([`CampaignComputer::name`]).
    #[serde(default = "in_process")]
    pub flight_computer: String,
}

fn in_process() -> String {
    CampaignComputer::InProcess.name().into()
}

impl CampaignMeta {
    /// The meta of a campaign of `runs` runs of `f` from run 0 (`shard` of it), flown in
    /// process.
    pub fn new(f: &ScenarioFile, runs: u64, shard: Option<Shard>) -> Self {
        Self {
            scenario: f.name.clone(),
            scenario_toml: f.to_toml(),
            first_run: 0,
            runs,
            shard: shard.map(|s| s.to_string()),
            host_sim_version: env!("CARGO_PKG_VERSION").into(),
            flight_computer: in_process(),
        }
    }

    /// The same campaign starting at run `first_run`.
    pub fn from_run(self, first_run: u64) -> Self {
        Self { first_run, ..self }
    }

    /// The run indices of the whole campaign.
    pub fn run_range(&self) -> std::ops::Range<u64> {
        self.first_run..self.first_run.saturating_add(self.runs)
    }

    /// The same, flown on `computer`.
    pub fn on(self, computer: &CampaignComputer) -> Self {
        Self {
            flight_computer: computer.name().into(),
            ..self
        }
    }
}

/// Runs `indices` of a campaign over `base` on `jobs` threads (all cores by default), with a
/// progress bar on stderr when it is a terminal; returns the JSON lines in index order.
pub fn run_campaign(
    base: &ScenarioFile,
    indices: &[u64],
    jobs: Option<usize>,
) -> Result<Vec<String>, McError> {
    run_campaign_on(base, indices, jobs, &CampaignComputer::InProcess)
}

/// [`run_campaign`] on `computer` (with [`CampaignComputer::Pil`], at most `jobs` emulators at
/// once).
pub fn run_campaign_on(
    base: &ScenarioFile,
    indices: &[u64],
    jobs: Option<usize>,
    computer: &CampaignComputer,
) -> Result<Vec<String>, McError> {
    base.validate()?;
    let bar = if std::io::stderr().is_terminal() {
        let b = ProgressBar::new(indices.len() as u64);
        if let Ok(style) = ProgressStyle::with_template(
            "{prefix} [{elapsed_precise}] {wide_bar} {pos}/{len} runs, eta {eta}",
        ) {
            b.set_style(style);
        }
        b.set_prefix(base.name.clone());
        b
    } else {
        ProgressBar::hidden()
    };
    let work = || {
        indices
            .par_iter()
            .map(|&i| {
                let line =
                    serde_json::to_string(&run_one_on(base, i, computer)).map_err(|source| {
                        McError::Json {
                            path: format!("run {i}"),
                            source,
                        }
                    });
                bar.inc(1);
                line
            })
            .collect::<Result<Vec<String>, McError>>()
    };
    let lines = match jobs {
        None => work(),
        Some(j) => rayon::ThreadPoolBuilder::new()
            .num_threads(j.max(1))
            .build()
            .map_err(|e| McError::Pool(e.to_string()))?
            .install(work),
    };
    bar.finish_and_clear();
    lines
}

/// A 95 % confidence interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Interval {
    /// Lower end.
    pub lower: f64,
    /// Upper end.
    pub upper: f64,
}

/// The Wilson score interval (95 %) of a proportion of `k` in `n` (`[0, 1]` for `n = 0`).
pub fn wilson(k: u64, n: u64) -> Interval {
    if n == 0 {
        return Interval {
            lower: 0.0,
            upper: 1.0,
        };
    }
    let (k, n) = (k as f64, n as f64);
    let p = k / n;
    let z2 = Z95 * Z95;
    let denom = 1.0 + z2 / n;
    let centre = (p + z2 / (2.0 * n)) / denom;
    let half = Z95 * (p * (1.0 - p) / n + z2 / (4.0 * n * n)).sqrt() / denom;
    Interval {
        lower: (centre - half).max(0.0),
        upper: (centre + half).min(1.0),
    }
}

/// The exact one-sided 95 % upper confidence bound (Clopper-Pearson) on a proportion of `k`
/// events in `n` trials: the `p` at which `k` or fewer events have probability 5 %. For
/// `k = 0` it is `1 - 0.05^(1/n)` (about `3 / n`, the "rule of three"); 1 for `n = 0` or
/// `k >= n`.
pub fn upper95(k: u64, n: u64) -> f64 {
    if n == 0 || k >= n {
        return 1.0;
    }
    if k == 0 {
        return 1.0 - 0.05_f64.powf(1.0 / n as f64);
    }
    // P(X <= k) for X ~ Binomial(n, p), summed from i = 0 in logarithms (each term from the
    // last: a ratio), so that it neither overflows nor underflows for large n.
    let cdf = |p: f64| {
        let (lp, lq) = (p.ln(), (-p).ln_1p());
        let mut log_term = n as f64 * lq;
        let mut sum = log_term.exp();
        for i in 0..k {
            log_term += ((n - i) as f64).ln() - ((i + 1) as f64).ln() + lp - lq;
            sum += log_term.exp();
        }
        sum
    };
    // The CDF falls as p rises: bisect for the p where it is 0.05, from k / n up.
    let (mut lo, mut hi) = (k as f64 / n as f64, 1.0);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if cdf(mid) > 0.05 {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo < 1e-12 {
            break;
        }
    }
    hi
}

/// The `p`-quantile (0..=1) of sorted values, linear between order statistics (Hyndman and
/// Fan type 7, as numpy's default); `None` when empty.
pub fn quantile(sorted: &[f64], p: f64) -> Option<f64> {
    let n = sorted.len();
    if n == 0 {
        return None;
    }
    let h = (n - 1) as f64 * p.clamp(0.0, 1.0);
    let lo = h.floor() as usize;
    let hi = (lo + 1).min(n - 1);
    Some(sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo]))
}

/// Distribution of one quantity over the runs that have it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Percentiles {
    /// Runs with a value.
    pub count: usize,
    /// Smallest.
    pub min: f64,
    /// 5th percentile.
    pub p5: f64,
    /// Median.
    pub p50: f64,
    /// 95th percentile.
    pub p95: f64,
    /// 99th percentile.
    pub p99: f64,
    /// Largest.
    pub max: f64,
    /// Mean.
    pub mean: f64,
}

impl Percentiles {
    fn of(values: impl Iterator<Item = f64>) -> Option<Self> {
        let mut v: Vec<f64> = values.collect();
        v.sort_by(f64::total_cmp);
        let q = |p| quantile(&v, p);
        Some(Self {
            count: v.len(),
            min: q(0.0)?,
            p5: q(0.05)?,
            p50: q(0.5)?,
            p95: q(0.95)?,
            p99: q(0.99)?,
            max: q(1.0)?,
            mean: v.iter().sum::<f64>() / v.len() as f64,
        })
    }
}

/// Success rate in one turbulence-intensity bin.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TurbulenceBin {
    /// Bin, RMS gust speed, m/s (the last bin includes its upper end).
    pub sigma_lo_mps: f64,
    /// Upper end of the bin, m/s.
    pub sigma_hi_mps: f64,
    /// Runs in the bin.
    pub runs: u64,
    /// Of which successful (docked and safe).
    pub success: u64,
    /// Their fraction (null for an empty bin).
    pub success_rate: Option<f64>,
    /// Its 95 % Wilson interval (null for an empty bin).
    pub success_ci95: Option<Interval>,
}

/// One kind of hazard over a campaign.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HazardCount {
    /// Runs with at least one.
    pub runs: u64,
    /// Hazards in all (a run may have several).
    pub events: u64,
    /// One-sided 95 % upper bound on the fraction of runs with one ([`upper95`]).
    pub runs_upper95: f64,
}

/// `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CampaignSummary {
    /// Scenario name.
    pub scenario: String,
    /// The campaign's first run index.
    pub first_run: u64,
    /// Runs in the whole campaign.
    pub campaign_runs: u64,
    /// The shard summarised (none: the whole campaign).
    pub shard: Option<String>,
    /// Runs summarised here.
    pub runs: u64,
    /// Of which docked (the referee's latch, within the sortie, at any attempt).
    pub docked: u64,
    /// Docked fraction.
    pub docked_rate: f64,
    /// Its 95 % confidence interval (Wilson score).
    pub docked_ci95: Interval,
    /// Of which successful: docked and safe.
    pub success: u64,
    /// Successful fraction.
    pub success_rate: f64,
    /// Its 95 % confidence interval (Wilson score).
    pub success_ci95: Interval,
    /// Runs that docked at their first attempt.
    pub first_attempt_docked: u64,
    /// Their fraction's 95 % Wilson interval.
    pub first_attempt_ci95: Interval,
    /// Runs per number of attempts flown.
    pub attempts_histogram: BTreeMap<u8, u64>,
    /// Attempts per way an attempt ended, over all runs.
    pub attempt_ends: BTreeMap<String, u64>,
    /// Runs with any hazard.
    pub unsafe_runs: u64,
    /// One-sided 95 % upper bound on their fraction.
    pub unsafe_upper95: f64,
    /// Each kind of hazard (every kind listed, zero or not).
    pub hazards: BTreeMap<String, HazardCount>,
    /// Crossings of the drogue plane per verdict (every verdict listed).
    pub crossings: BTreeMap<String, u64>,
    /// Dockings the referee judged while the controller was in a missed approach or a
    /// breakaway (the coupling latches whatever the controller intends: a reader's figure, not
    /// a judgement).
    pub docked_while_backing_off: u64,
    /// Runs in which the tanker called a breakaway (`[abort]`; 0 without the key).
    pub aborts_called: u64,
    /// Of those, the runs the referee found safe.
    pub aborts_safe: u64,
    /// Exact one-sided 95 % upper bound on the unsafe fraction of the called aborts (`null`
    /// with no call).
    pub aborts_unsafe_upper95: Option<f64>,
    /// Runs per outcome.
    pub outcomes: BTreeMap<String, u64>,
    /// Runs per failure cause (breakaway reason, kind of miss, timeout, error).
    pub failure_causes: BTreeMap<String, u64>,
    /// Miss at the decisive crossing (the docking, or the first miss while pushing), m.
    pub miss_m: Option<Percentiles>,
    /// Closing speed then, m/s.
    pub closure_mps: Option<Percentiles>,
    /// Speed across the drogue's axis at the docking, m/s.
    pub lateral_mps: Option<Percentiles>,
    /// Success rate per turbulence-intensity bin.
    pub success_by_turbulence: Vec<TurbulenceBin>,
    /// Success per cell of the gain schedule's grid of flight conditions ([`condition_cell`]
    /// says which cell a run belongs to): altitude bands from the lowest, in each the
    /// airspeed bands from the slowest. Every run is in one cell or in
    /// `outside_condition_grid`.
    #[serde(default)]
    pub success_by_condition: Vec<ConditionCell>,
    /// Runs whose flight condition is outside the grid (not in any cell).
    #[serde(default)]
    pub outside_condition_grid: u64,
    /// The dispersion flown.
    pub dispersion: DispersionSection,
    /// The referee's limits (the canopy and hose radii are the nominal drogue's).
    pub referee_limits: Limits,
    /// Definitions of the numbers above.
    pub definitions: BTreeMap<String, String>,
}

/// Success in one cell of the gain schedule's grid of flight conditions.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ConditionCell {
    /// True airspeed range of the cell, m/s: `[lower, upper]` edges of the grid.
    pub airspeed_mps: [f64; 2],
    /// Altitude range of the cell, m.
    pub altitude_m: [f64; 2],
    /// Runs in the cell.
    pub runs: u64,
    /// Of which successful (docked and safe).
    pub success: u64,
    /// Their fraction (null for an empty cell).
    pub success_rate: Option<f64>,
    /// Its 95 % Wilson interval (null for an empty cell).
    pub success_ci95: Option<Interval>,
    /// Of which docked at the first attempt.
    pub first_attempt_docked: u64,
    /// Runs in the cell with a hazard.
    pub unsafe_runs: u64,
}

/// A proportion and its interval, none when nothing was counted.
fn rate(k: u64, n: u64) -> (Option<f64>, Option<Interval>) {
    if n == 0 {
        (None, None)
    } else {
        (Some(k as f64 / n as f64), Some(wilson(k, n)))
    }
}

/// The edges of the gain schedule's grid, true airspeed (m/s) and altitude (m), from the
/// core's generated grid (so that the cells follow it when it is regenerated).
pub fn condition_grid() -> (Vec<f64>, Vec<f64>) {
    use ibvs_core::gains::{SCHEDULE_ALTITUDES_M, SCHEDULE_SPEEDS_MPS};
    (
        SCHEDULE_SPEEDS_MPS.iter().map(|&v| f64::from(v)).collect(),
        SCHEDULE_ALTITUDES_M.iter().map(|&h| f64::from(h)).collect(),
    )
}

/// The band of `edges` (ascending) that holds `x`: band `k` is `edges[k]..=edges[k + 1]`,
/// and a value on an inner edge belongs to the band below it (as the core's schedule
/// interpolates: a node shared by two cells is the lower cell's). `None` when `x` is not
/// finite, is outside `edges[0]..=edges[last]`, or there are fewer than two edges.
fn band(edges: &[f64], x: f64) -> Option<usize> {
    let (first, last) = (*edges.first()?, *edges.last()?);
    if edges.len() < 2 || !x.is_finite() || x < first || x > last {
        return None;
    }
    edges.iter().skip(1).position(|&hi| x <= hi)
}

/// The cell of the gain schedule's grid ([`condition_grid`]) that holds a flight condition:
/// `(airspeed band, altitude band)`, each 0 for the lowest. Cell `(i, j)` is
/// `speeds[i]..=speeds[i + 1]` by `altitudes[j]..=altitudes[j + 1]`; a condition on an inner
/// grid line belongs to the cell below it on that axis (the lower speed, the lower altitude;
/// at an inner node, the cell whose upper corner it is), as the core's interpolation takes
/// it, so that every condition of the envelope is in exactly one cell. `None` outside the
/// grid or when not finite.
pub fn condition_cell(airspeed_mps: f64, altitude_m: f64) -> Option<(usize, usize)> {
    let (speeds, altitudes) = condition_grid();
    Some((band(&speeds, airspeed_mps)?, band(&altitudes, altitude_m)?))
}

/// The per-cell table of `records` over the grid ([`condition_cell`]) and the number of runs
/// outside it.
fn condition_table(records: &[RunRecord]) -> (Vec<ConditionCell>, u64) {
    let (speeds, altitudes) = condition_grid();
    let ns = speeds.len().saturating_sub(1);
    let mut cells: Vec<ConditionCell> = altitudes
        .windows(2)
        .flat_map(|h| {
            speeds.windows(2).map(move |v| ConditionCell {
                airspeed_mps: [v[0], v[1]],
                altitude_m: [h[0], h[1]],
                runs: 0,
                success: 0,
                success_rate: None,
                success_ci95: None,
                first_attempt_docked: 0,
                unsafe_runs: 0,
            })
        })
        .collect();
    let mut outside = 0;
    for r in records {
        let cell = condition_cell(r.inputs.airspeed_mps, r.inputs.altitude_m)
            .and_then(|(i, j)| cells.get_mut(j * ns + i));
        match cell {
            Some(c) => {
                c.runs += 1;
                c.success += u64::from(r.success);
                c.first_attempt_docked += u64::from(r.first_attempt_docked);
                c.unsafe_runs += u64::from(!r.safe);
            }
            None => outside += 1,
        }
    }
    for c in &mut cells {
        (c.success_rate, c.success_ci95) = rate(c.success, c.runs);
    }
    (cells, outside)
}

/// Bins of the turbulence intensity: equal widths over the dispersed range (one bin per 50
/// runs, 1..=10), or the one intensity flown.
fn turbulence_bins(records: &[RunRecord], d: &DispersionSection) -> Vec<TurbulenceBin> {
    let (lo, hi) = match d.turbulence_sigma_mps {
        Some([lo, hi]) if lo < hi => (lo, hi),
        _ => {
            let s = records
                .first()
                .map_or(0.0, |r| r.inputs.turbulence_sigma_mps);
            (s, s)
        }
    };
    let nb = if hi > lo {
        (records.len() / 50).clamp(1, 10)
    } else {
        1
    };
    let edge = |b: usize| lo + (hi - lo) * b as f64 / nb as f64;
    (0..nb)
        .map(|b| {
            let inside: Vec<&RunRecord> = records
                .iter()
                .filter(|r| {
                    let s = r.inputs.turbulence_sigma_mps;
                    let j = if hi > lo {
                        (((s - lo) / (hi - lo) * nb as f64).floor().max(0.0) as usize).min(nb - 1)
                    } else {
                        0
                    };
                    j == b
                })
                .collect();
            let (n, k) = (
                inside.len() as u64,
                inside.iter().filter(|r| r.success).count() as u64,
            );
            let (success_rate, success_ci95) = rate(k, n);
            TurbulenceBin {
                sigma_lo_mps: edge(b),
                sigma_hi_mps: edge(b + 1),
                runs: n,
                success: k,
                success_rate,
                success_ci95,
            }
        })
        .collect()
}

/// The definitions written into every summary.
fn definitions() -> BTreeMap<String, String> {
    [
        (
            "docked",
            "the referee (truth only, never the controller's modes): the probe tip crossed the drogue plane inside the capture radius (0.3 m), closing inside 0.5..2.6 m/s and sliding across the drogue's axis no faster than 1 m/s, whatever the controller was doing; the coupling latched",
        ),
        (
            "success",
            "docked and safe: no hazard of any kind in the run",
        ),
        (
            "first_attempt_docked",
            "the run docked at its first attempt (the paper's procedure has only one)",
        ),
        (
            "hazards",
            "basket_strike: the probe tip crossed the drogue plane (either way) without latching within the canopy's radius plus the probe head's (0.355 m); hard_contact: into the coupling (inside the capture radius) outside the closing band or faster across than 1 m/s; drogue_on_airframe: the canopy's rim or the coupling within 0.15 m of the radome or the cockpit canopy; hose_contact: the hose within 0.1 m of the probe, radome or cockpit canopy (its last 0.6 m, in the drogue assembly, excepted); tanker_proximity: the airframe within 8 m of the hose exit; upset: bank beyond 45 deg, pitch beyond -10..25 deg, angle of attack beyond -5..20 deg or load factor beyond 0..2 g within 30 m of the drogue (referee_limits holds every figure; docs/models.md, \"The referee\", their sources)",
        ),
        (
            "unsafe_upper95",
            "exact one-sided 95 % upper confidence bound (Clopper-Pearson) on the fraction; with no events, 1 - 0.05^(1/n), about 3/n",
        ),
        (
            "observation",
            "a run goes on 15 s after the controller breaks away, the controller still flying its breakaway, and the referee watches all of it",
        ),
        (
            "success_by_condition",
            "runs per cell of the gain schedule's grid of true airspeed by altitude (the run's true condition); a run on an inner grid line is in the cell below it on that axis (lower speed, lower altitude), as the controller's schedule interpolates; runs outside the grid are counted in outside_condition_grid; an empty cell's rate is null",
        ),
        (
            "ci95",
            "Wilson score interval, 95 % (z = 1.96)",
        ),
        (
            "percentiles",
            "linear between order statistics (Hyndman-Fan type 7); miss and closing speed over the runs with a decisive crossing (the docking, or the first miss while the controller pushed), lateral speed over the dockings",
        ),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v.to_string()))
    .collect()
}

/// The names of the crossing verdicts in files.
fn verdict_name(v: CrossingVerdict) -> &'static str {
    match v {
        CrossingVerdict::Docked => "docked",
        CrossingVerdict::HardContact => "hard_contact",
        CrossingVerdict::BasketStrike => "basket_strike",
        CrossingVerdict::FlyBy => "fly_by",
    }
}

/// Summarises `records` (in index order) of the campaign `meta`.
pub fn summarise(
    meta: &CampaignMeta,
    dispersion: &DispersionSection,
    records: &[RunRecord],
) -> CampaignSummary {
    let n = records.len() as u64;
    let count = |f: &dyn Fn(&RunRecord) -> bool| records.iter().filter(|r| f(r)).count() as u64;
    let docked = count(&|r| r.docked);
    let success = count(&|r| r.success);
    let first = count(&|r| r.first_attempt_docked);
    let unsafe_n = count(&|r| !r.safe);
    let mut outcomes = BTreeMap::new();
    let mut causes = BTreeMap::new();
    let mut attempts = BTreeMap::new();
    let mut ends = BTreeMap::new();
    let mut hazards: BTreeMap<String, HazardCount> = HazardKind::ALL
        .iter()
        .map(|k| {
            (
                k.name().to_string(),
                HazardCount {
                    runs: 0,
                    events: 0,
                    runs_upper95: 0.0,
                },
            )
        })
        .collect();
    let mut crossings: BTreeMap<String, u64> = [
        CrossingVerdict::Docked,
        CrossingVerdict::HardContact,
        CrossingVerdict::BasketStrike,
        CrossingVerdict::FlyBy,
    ]
    .into_iter()
    .map(|v| (verdict_name(v).to_string(), 0))
    .collect();
    let mut backing_off = 0;
    for r in records {
        *outcomes.entry(r.outcome.name().to_string()).or_insert(0) += 1;
        if let Some(c) = &r.failure {
            *causes.entry(c.clone()).or_insert(0) += 1;
        }
        *attempts.entry(r.attempts).or_insert(0) += 1;
        for e in &r.attempt_ends {
            *ends.entry(e.clone()).or_insert(0) += 1;
        }
        for c in &r.crossings {
            *crossings
                .entry(verdict_name(c.verdict).to_string())
                .or_insert(0) += 1;
            backing_off += u64::from(
                c.verdict == CrossingVerdict::Docked
                    && matches!(c.mode.as_str(), "MissedApproach" | "Breakaway"),
            );
        }
        for k in HazardKind::ALL {
            let events = r.hazards.iter().filter(|h| h.kind == k).count() as u64;
            if let Some(h) = hazards.get_mut(k.name()) {
                h.events += events;
                h.runs += u64::from(events > 0);
            }
        }
    }
    for h in hazards.values_mut() {
        h.runs_upper95 = upper95(h.runs, n);
    }
    let called = || records.iter().filter(|r| r.abort_called_s.is_some());
    let (aborts_called, aborts_safe) = (
        called().count() as u64,
        called().filter(|r| r.safe).count() as u64,
    );
    let (cells, outside) = condition_table(records);
    let fraction = |k: u64| if n > 0 { k as f64 / n as f64 } else { 0.0 };
    CampaignSummary {
        scenario: meta.scenario.clone(),
        first_run: meta.first_run,
        campaign_runs: meta.runs,
        shard: meta.shard.clone(),
        runs: n,
        docked,
        docked_rate: fraction(docked),
        docked_ci95: wilson(docked, n),
        success,
        success_rate: fraction(success),
        success_ci95: wilson(success, n),
        first_attempt_docked: first,
        first_attempt_ci95: wilson(first, n),
        attempts_histogram: attempts,
        attempt_ends: ends,
        unsafe_runs: unsafe_n,
        unsafe_upper95: upper95(unsafe_n, n),
        hazards,
        crossings,
        docked_while_backing_off: backing_off,
        aborts_called,
        aborts_safe,
        aborts_unsafe_upper95: (aborts_called > 0)
            .then(|| upper95(aborts_called - aborts_safe, aborts_called)),
        outcomes,
        failure_causes: causes,
        miss_m: Percentiles::of(records.iter().filter_map(|r| r.miss_m)),
        closure_mps: Percentiles::of(records.iter().filter_map(|r| r.closure_mps)),
        lateral_mps: Percentiles::of(records.iter().filter_map(|r| r.lateral_mps)),
        success_by_turbulence: turbulence_bins(records, dispersion),
        success_by_condition: cells,
        outside_condition_grid: outside,
        dispersion: dispersion.clone(),
        referee_limits: Limits::default(),
        definitions: definitions(),
    }
}

/// A class of points in a scatter plot: label, colour, points.
type Group<'a> = (&'a str, RGBColor, Vec<(f64, f64)>);

/// A circle of `radius` about the origin, as a polyline.
fn circle(radius: f64) -> impl Iterator<Item = (f64, f64)> {
    (0..=120).map(move |i| {
        let a = f64::from(i) * std::f64::consts::TAU / 120.0;
        (radius * a.cos(), radius * a.sin())
    })
}

/// The farthest the miss scatter reaches from the drogue centre, m: the crossings that matter
/// are within a metre or so; a fly-by metres off would shrink them to a dot.
const SCATTER_REACH_M: f64 = 1.2;

/// Every crossing of the drogue plane, from behind, one marker per crossing and a shape per
/// verdict, with the capture and strike circles.
fn miss_scatter(path: &Path, title: &str, records: &[RunRecord]) -> Result<(), OutputError> {
    let mut groups: [Group<'_>; 4] = [
        ("docked", PALETTE[2], Vec::new()),
        ("hard contact", PALETTE[1], Vec::new()),
        ("basket strike", PALETTE[3], Vec::new()),
        ("fly-by, clear of the canopy", PALETTE[0], Vec::new()),
    ];
    for c in records.iter().flat_map(|r| &r.crossings) {
        let g = match c.verdict {
            CrossingVerdict::Docked => 0,
            CrossingVerdict::HardContact => 1,
            CrossingVerdict::BasketStrike => 2,
            CrossingVerdict::FlyBy => 3,
        };
        groups[g].2.push((c.offset_m[0], c.offset_m[1]));
    }
    let limits = Limits::default();
    // The view reaches the farthest crossing up to SCATTER_REACH_M; those beyond are counted
    // in the title, not drawn off the scale.
    let reach = groups
        .iter()
        .flat_map(|g| g.2.iter())
        .fold(limits.strike_radius_m() * 1.5, |m, p| {
            m.max(p.0.abs()).max(p.1.abs())
        })
        .min(SCATTER_REACH_M)
        * 1.05;
    let beyond = groups
        .iter()
        .flat_map(|g| g.2.iter())
        .filter(|p| p.0.abs() > reach || p.1.abs() > reach)
        .count();
    let title = if beyond > 0 {
        format!("{title} ({beyond} beyond {reach:.2} m not drawn)")
    } else {
        title.to_string()
    };
    let title = title.as_str();
    for g in &mut groups {
        g.2.retain(|p| p.0.abs() <= reach && p.1.abs() <= reach);
    }
    plot::figure(path, (900, 900), |root| {
        let mut chart = ChartBuilder::on(root)
            .caption(title, ("sans-serif", 20))
            .margin(15)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(-reach..reach, -reach..reach)
            .map_err(dbg)?;
        chart
            .configure_mesh()
            .x_desc("probe tip right of the drogue centre, m")
            .y_desc("probe tip above the drogue centre, m")
            .label_style(("sans-serif", 14))
            .draw()
            .map_err(dbg)?;
        for (radius, what, style) in [
            (
                limits.capture_radius_m,
                "capture radius",
                BLACK.stroke_width(2),
            ),
            (
                limits.strike_radius_m(),
                "canopy + probe head (strike)",
                PALETTE[3].stroke_width(1),
            ),
        ] {
            chart
                .draw_series(LineSeries::new(circle(radius), style))
                .map_err(dbg)?
                .label(format!("{what} {radius:.3} m"))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], style));
        }
        let [docked, hard, strike, by] = &groups;
        let label = |g: &Group<'_>| format!("{} ({})", g.0, g.2.len());
        let (c0, c1, c2, c3) = (docked.1, hard.1, strike.1, by.1);
        chart
            .draw_series(docked.2.iter().map(|&p| Circle::new(p, 3, c0.filled())))
            .map_err(dbg)?
            .label(label(docked))
            .legend(move |(x, y)| Circle::new((x + 9, y), 4, c0.filled()));
        chart
            .draw_series(by.2.iter().map(|&p| Circle::new(p, 4, c3.stroke_width(1))))
            .map_err(dbg)?
            .label(label(by))
            .legend(move |(x, y)| Circle::new((x + 9, y), 4, c3.stroke_width(1)));
        chart
            .draw_series(hard.2.iter().map(|&p| Cross::new(p, 5, c1.stroke_width(2))))
            .map_err(dbg)?
            .label(label(hard))
            .legend(move |(x, y)| Cross::new((x + 9, y), 5, c1.stroke_width(2)));
        chart
            .draw_series(
                strike
                    .2
                    .iter()
                    .map(|&p| TriangleMarker::new(p, 6, c2.filled())),
            )
            .map_err(dbg)?
            .label(label(strike))
            .legend(move |(x, y)| TriangleMarker::new((x + 9, y), 6, c2.filled()));
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .label_font(("sans-serif", 14))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(dbg)
    })
}

/// A panel of the hazards plot: the vertical axis's label, the coordinate it shows (of a
/// tanker-frame point), the value it is centred on.
type View<'a> = (&'a str, fn(&[f64; 3]) -> f64, f64);

/// Where every hazard happened: top view (forward, right) and side view (forward, up) in the
/// tanker frame, the hose exit at the origin and the drogue's nominal trail marked, a colour
/// per kind.
fn hazards_plot(path: &Path, title: &str, records: &[RunRecord]) -> Result<(), OutputError> {
    let kinds = HazardKind::ALL;
    let colours = [
        PALETTE[3], PALETTE[1], PALETTE[4], PALETTE[0], PALETTE[5], PALETTE[2],
    ];
    let points: Vec<(usize, [f64; 3])> = records
        .iter()
        .flat_map(|r| &r.hazards)
        .filter_map(|h| {
            kinds
                .iter()
                .position(|k| *k == h.kind)
                .map(|i| (i, h.position_tanker_m))
        })
        .collect();
    let trail = crate::world::drogue::NOMINAL_DROGUE_TANKER_M;
    let (mut x0, mut x1) = (trail[0] - 20.0, 6.0_f64);
    let mut half = 6.0_f64;
    for (_, p) in &points {
        x0 = x0.min(p[0] - 1.0);
        x1 = x1.max(p[0] + 1.0);
        half = half
            .max(p[1].abs() + 1.0)
            .max((p[2] - trail[2]).abs() + 1.0);
    }
    plot::figure(path, (1400, 700), |root| {
        let root = root.titled(title, ("sans-serif", 20)).map_err(dbg)?;
        let panels = root.split_evenly((1, 2));
        let views: [View<'_>; 2] = [
            ("right of the hose exit, m (top view)", |p| p[1], 0.0),
            ("above the hose exit, m (side view)", |p| -p[2], -trail[2]),
        ];
        for (panel, (y_desc, vertical, centre)) in panels.iter().zip(views) {
            let mut chart = ChartBuilder::on(panel)
                .margin(15)
                .x_label_area_size(40)
                .y_label_area_size(60)
                .build_cartesian_2d(x0..x1, (centre - half)..(centre + half))
                .map_err(dbg)?;
            chart
                .configure_mesh()
                .x_desc("forward of the hose exit, m")
                .y_desc(y_desc)
                .label_style(("sans-serif", 14))
                .draw()
                .map_err(dbg)?;
            let landmarks = [("hose exit", [0.0, 0.0, 0.0]), ("drogue trail", trail)];
            chart
                .draw_series(landmarks.iter().map(|(name, p)| {
                    EmptyElement::at((p[0], vertical(p)))
                        + Cross::new((0, 0), 6, BLACK.stroke_width(2))
                        + Text::new(name.to_string(), (8, -8), ("sans-serif", 13))
                }))
                .map_err(dbg)?;
            for (i, kind) in kinds.iter().enumerate() {
                let c = colours[i];
                let pts: Vec<(f64, f64)> = points
                    .iter()
                    .filter(|(k, _)| *k == i)
                    .map(|(_, p)| (p[0], vertical(p)))
                    .collect();
                let n = pts.len();
                chart
                    .draw_series(pts.into_iter().map(|p| Circle::new(p, 4, c.filled())))
                    .map_err(dbg)?
                    .label(format!("{} ({n})", kind.name()))
                    .legend(move |(x, y)| Circle::new((x + 9, y), 4, c.filled()));
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperLeft)
                .label_font(("sans-serif", 13))
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .draw()
                .map_err(dbg)?;
        }
        Ok(())
    })
}

/// Success rate (dots) and its 95 % interval (bars) per turbulence bin.
fn success_plot(path: &Path, title: &str, bins: &[TurbulenceBin]) -> Result<(), OutputError> {
    let used: Vec<&TurbulenceBin> = bins.iter().filter(|b| b.runs > 0).collect();
    let (x0, x1) = match (bins.first(), bins.last()) {
        (Some(a), Some(b)) if b.sigma_hi_mps > a.sigma_lo_mps => {
            let pad = (b.sigma_hi_mps - a.sigma_lo_mps) * 0.05;
            (a.sigma_lo_mps - pad, b.sigma_hi_mps + pad)
        }
        (Some(a), _) => (a.sigma_lo_mps - 0.1, a.sigma_lo_mps + 0.1),
        _ => (0.0, 1.0),
    };
    let y0 = used
        .iter()
        .filter_map(|b| b.success_ci95.map(|c| c.lower))
        .fold(1.0_f64, f64::min);
    let y0 = ((y0 - 0.02) * 20.0).floor() / 20.0;
    plot::figure(path, (1000, 650), |root| {
        let mut chart = ChartBuilder::on(root)
            .caption(title, ("sans-serif", 20))
            .margin(15)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(x0..x1, y0.max(0.0)..1.005)
            .map_err(dbg)?;
        chart
            .configure_mesh()
            .x_desc("turbulence intensity (RMS gust speed), m/s")
            .y_desc("success rate, docked and safe (95 % Wilson interval)")
            .label_style(("sans-serif", 14))
            .draw()
            .map_err(dbg)?;
        let mid = |b: &TurbulenceBin| 0.5 * (b.sigma_lo_mps + b.sigma_hi_mps);
        // The bins with runs, each with its rate and interval.
        let shown: Vec<(f64, f64, Interval, String)> = used
            .iter()
            .filter_map(|b| {
                Some((
                    mid(b),
                    b.success_rate?,
                    b.success_ci95?,
                    format!("{}/{}", b.success, b.runs),
                ))
            })
            .collect();
        chart
            .draw_series(shown.iter().map(|(x, _, ci, _)| {
                PathElement::new(
                    vec![(*x, ci.lower), (*x, ci.upper)],
                    PALETTE[0].stroke_width(2),
                )
            }))
            .map_err(dbg)?;
        chart
            .draw_series(
                shown
                    .iter()
                    .map(|(x, r, _, _)| Circle::new((*x, *r), 5, PALETTE[0].filled())),
            )
            .map_err(dbg)?;
        chart
            .draw_series(
                shown
                    .iter()
                    .map(|(x, _, ci, t)| Text::new(t.clone(), (*x, ci.lower), ("sans-serif", 13))),
            )
            .map_err(dbg)?;
        Ok(())
    })
}

/// The heat map's colour of a success rate: red at 90 % and below, yellow at 98 %, green at
/// 100 % (linear between), so that a cell under 98 % stands out.
fn success_colour(rate: f64) -> RGBColor {
    const STOPS: [(f64, (f64, f64, f64)); 3] = [
        (0.90, (214.0, 39.0, 40.0)),
        (0.98, (255.0, 221.0, 87.0)),
        (1.00, (44.0, 160.0, 44.0)),
    ];
    let r = if rate.is_finite() { rate } else { 0.0 };
    let (lo, hi) = match STOPS.windows(2).find(|w| r <= w[1].0) {
        Some(w) => (w[0], w[1]),
        None => (STOPS[1], STOPS[2]),
    };
    let f = ((r - lo.0) / (hi.0 - lo.0)).clamp(0.0, 1.0);
    let mix = |a: f64, b: f64| (a + (b - a) * f).round().clamp(0.0, 255.0) as u8;
    RGBColor(
        mix(lo.1.0, hi.1.0),
        mix(lo.1.1, hi.1.1),
        mix(lo.1.2, hi.1.2),
    )
}

/// Success rate per cell of the gain schedule's grid as a heat map of airspeed by altitude,
/// each cell labelled with its rate, docked and run counts (and unsafe end states if any), a
/// colour bar, and the runs outside the grid in a note.
fn condition_plot(
    path: &Path,
    title: &str,
    cells: &[ConditionCell],
    outside: u64,
) -> Result<(), OutputError> {
    use plotters::style::text_anchor::{HPos, Pos, VPos};
    let (speeds, altitudes) = condition_grid();
    let (x0, x1) = (
        speeds.first().copied().unwrap_or(0.0),
        speeds.last().copied().unwrap_or(1.0),
    );
    let (y0, y1) = (
        altitudes.first().copied().unwrap_or(0.0),
        altitudes.last().copied().unwrap_or(1.0),
    );
    let (x1, y1) = (x1.max(x0 + 1.0), y1.max(y0 + 1.0));
    let centred = |size: u32| {
        TextStyle::from(("sans-serif", size).into_font()).pos(Pos::new(HPos::Center, VPos::Center))
    };
    plot::figure(path, (1000, 720), |root| {
        let (main, note) = root.split_vertically(670);
        let (chart_area, bar_area) = main.split_horizontally(870);
        let mut chart = ChartBuilder::on(&chart_area)
            .caption(title, ("sans-serif", 20))
            .margin(15)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(dbg)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("true airspeed, m/s")
            .y_desc("altitude, m")
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| format!("{v:.0}"))
            .label_style(("sans-serif", 14))
            .draw()
            .map_err(dbg)?;
        chart
            .draw_series(cells.iter().map(|c| {
                let fill = if let Some(rate) = c.success_rate {
                    success_colour(rate)
                } else {
                    RGBColor(225, 225, 225)
                };
                Rectangle::new(
                    [
                        (c.airspeed_mps[0], c.altitude_m[0]),
                        (c.airspeed_mps[1], c.altitude_m[1]),
                    ],
                    fill.filled(),
                )
            }))
            .map_err(dbg)?;
        chart
            .draw_series(cells.iter().map(|c| {
                Rectangle::new(
                    [
                        (c.airspeed_mps[0], c.altitude_m[0]),
                        (c.airspeed_mps[1], c.altitude_m[1]),
                    ],
                    BLACK.stroke_width(1),
                )
            }))
            .map_err(dbg)?;
        let labels = cells.iter().flat_map(|c| {
            let at = (
                0.5 * (c.airspeed_mps[0] + c.airspeed_mps[1]),
                0.5 * (c.altitude_m[0] + c.altitude_m[1]),
            );
            let lines = if let Some(rate) = c.success_rate {
                let mut l = vec![
                    format!("{:.1} %", 100.0 * rate),
                    format!("{}/{} runs", c.success, c.runs),
                ];
                if c.unsafe_runs > 0 {
                    l.push(format!("unsafe {}", c.unsafe_runs));
                }
                l
            } else {
                vec!["no runs".to_string()]
            };
            let top = -11 * (lines.len() as i32 - 1);
            lines.into_iter().enumerate().map(move |(k, l)| {
                let size = if k == 0 { 20 } else { 15 };
                EmptyElement::at(at) + Text::new(l, (0, top + 22 * k as i32), centred(size))
            })
        });
        chart.draw_series(labels).map_err(dbg)?;
        // The colour bar: 90..100 %.
        let mut bar = ChartBuilder::on(&bar_area)
            .margin_top(50)
            .margin_bottom(55)
            .margin_right(15)
            .y_label_area_size(55)
            .build_cartesian_2d(0.0..1.0, 0.9..1.0)
            .map_err(dbg)?;
        bar.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .y_labels(6)
            .y_label_formatter(&|v| format!("{:.0} %", 100.0 * v))
            .label_style(("sans-serif", 13))
            .draw()
            .map_err(dbg)?;
        bar.draw_series((0..100).map(|k| {
            let (a, b) = (0.9 + 0.001 * f64::from(k), 0.9 + 0.001 * f64::from(k + 1));
            Rectangle::new([(0.0, a), (1.0, b)], success_colour(0.5 * (a + b)).filled())
        }))
        .map_err(dbg)?;
        note.draw(&Text::new(
            format!(
                "colour: success rate (90 % and below red, 98 % yellow). Runs outside the grid: {outside}. \
                 A run on an inner grid line is in the cell below it (lower speed, lower altitude)."
            ),
            (20, 15),
            ("sans-serif", 14),
        ))
        .map_err(dbg)?;
        Ok(())
    })
}

fn write_text(path: &Path, text: &str) -> Result<(), McError> {
    std::fs::write(path, text).map_err(io_err(path))
}

fn to_json_pretty<T: Serialize>(path: &Path, v: &T) -> Result<String, McError> {
    serde_json::to_string_pretty(v)
        .map(|s| s + "\n")
        .map_err(|source| McError::Json {
            path: path.display().to_string(),
            source,
        })
}

fn parse_lines(path: &Path, text: &str) -> Result<Vec<RunRecord>, McError> {
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            serde_json::from_str(l).map_err(|source| McError::Json {
                path: path.display().to_string(),
                source,
            })
        })
        .collect()
}

/// Writes a campaign's output into `dir` from its JSON lines (index order) and returns the
/// summary.
pub fn write_campaign(
    dir: &Path,
    meta: &CampaignMeta,
    lines: &[String],
) -> Result<CampaignSummary, McError> {
    std::fs::create_dir_all(dir).map_err(io_err(dir))?;
    let runs_path = dir.join("runs.jsonl");
    let mut text = lines.join("\n");
    if !text.is_empty() {
        text.push('\n');
    }
    write_text(&runs_path, &text)?;
    // The summary is computed from the lines as written, so a merge of shards reproduces it.
    let records = parse_lines(&runs_path, &text)?;
    let scenario = ScenarioFile::parse(&meta.scenario_toml, &meta.scenario)?;
    let summary = summarise(meta, &scenario.dispersion, &records);
    let meta_path = dir.join("campaign.json");
    write_text(&meta_path, &to_json_pretty(&meta_path, meta)?)?;
    let summary_path = dir.join("summary.json");
    write_text(&summary_path, &to_json_pretty(&summary_path, &summary)?)?;
    let part = meta
        .shard
        .as_ref()
        .map_or(String::new(), |s| format!(", shard {s}"));
    miss_scatter(
        &dir.join("miss_scatter.png"),
        &format!(
            "{}: every crossing of the drogue plane, {} runs{part}",
            meta.scenario, summary.runs
        ),
        &records,
    )?;
    hazards_plot(
        &dir.join("hazards.png"),
        &format!(
            "{}: where the referee's hazards were, {} runs{part}",
            meta.scenario, summary.runs
        ),
        &records,
    )?;
    success_plot(
        &dir.join("success_vs_turbulence.png"),
        &format!(
            "{}: success rate against turbulence, {} runs{part}",
            meta.scenario, summary.runs
        ),
        &summary.success_by_turbulence,
    )?;
    condition_plot(
        &dir.join("success_vs_condition.png"),
        &format!(
            "{}: success rate per cell of the gain schedule, {} runs{part}",
            meta.scenario, summary.runs
        ),
        &summary.success_by_condition,
        summary.outside_condition_grid,
    )?;
    Ok(summary)
}

/// Reads one campaign output directory: its meta and its JSON lines with their indices.
fn read_dir(dir: &Path) -> Result<(CampaignMeta, Vec<(u64, String)>), McError> {
    let meta_path = dir.join("campaign.json");
    let text = std::fs::read_to_string(&meta_path).map_err(io_err(&meta_path))?;
    let meta: CampaignMeta = serde_json::from_str(&text).map_err(|source| McError::Json {
        path: meta_path.display().to_string(),
        source,
    })?;
    let runs_path = dir.join("runs.jsonl");
    let text = std::fs::read_to_string(&runs_path).map_err(io_err(&runs_path))?;
    let lines: Vec<&str> = text.lines().filter(|l| !l.trim().is_empty()).collect();
    let records = parse_lines(&runs_path, &text)?;
    Ok((
        meta,
        records
            .iter()
            .zip(lines)
            .map(|(r, l)| (r.index, l.to_string()))
            .collect(),
    ))
}

/// Merges the outputs of shards (`dirs`) of one campaign into `out`: the same files, bit for
/// bit, as one machine running the whole campaign. The shards must be of the same scenario,
/// campaign size and simulator version, and together hold every run exactly once (a run
/// present twice with the same line is taken once).
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<CampaignSummary, McError> {
    let mut meta: Option<CampaignMeta> = None;
    let mut all: BTreeMap<u64, (String, PathBuf)> = BTreeMap::new();
    for dir in dirs {
        let (m, lines) = read_dir(dir)?;
        let whole = CampaignMeta {
            shard: None,
            ..m.clone()
        };
        match &meta {
            None => meta = Some(whole),
            Some(first) if *first != whole => {
                let what = if first.scenario_toml != whole.scenario_toml {
                    "scenario"
                } else if first.runs != whole.runs {
                    "campaign size"
                } else if first.first_run != whole.first_run {
                    "first run"
                } else {
                    "simulator version"
                };
                return Err(McError::Merge(format!(
                    "{} is a shard of another campaign ({what} differs from {})",
                    dir.display(),
                    dirs[0].display()
                )));
            }
            Some(_) => {}
        }
        for (i, line) in lines {
            if let Some((old, from)) = all.get(&i) {
                if *old != line {
                    return Err(McError::Merge(format!(
                        "run {i} differs between {} and {}",
                        from.display(),
                        dir.display()
                    )));
                }
            } else {
                all.insert(i, (line, dir.clone()));
            }
        }
    }
    let meta = meta.ok_or_else(|| McError::Merge("no directories given".into()))?;
    let range = meta.run_range();
    if let Some(&i) = all.keys().find(|&&i| !range.contains(&i)) {
        return Err(McError::Merge(format!(
            "run {i} is outside the campaign of runs {}..{}",
            range.start, range.end
        )));
    }
    let missing: Vec<u64> = range.filter(|i| !all.contains_key(i)).collect();
    if !missing.is_empty() {
        let first: Vec<String> = missing.iter().take(10).map(u64::to_string).collect();
        return Err(McError::Merge(format!(
            "{} of {} runs missing (first: {})",
            missing.len(),
            meta.runs,
            first.join(", ")
        )));
    }
    let lines: Vec<String> = all.into_values().map(|(l, _)| l).collect();
    write_campaign(out, &meta, &lines)
}

/// One line for the terminal.
pub fn one_line(s: &CampaignSummary) -> String {
    let pct = |v: f64| format!("{:.2} %", 100.0 * v);
    let hazards: Vec<String> = s
        .hazards
        .iter()
        .filter(|(_, h)| h.runs > 0)
        .map(|(k, h)| format!("{k} {}", h.runs))
        .collect();
    format!(
        "{}: {} runs{}{}, success {} ({}, 95 % CI {}..{}), docked {}, unsafe {} (95 % upper bound {}){}, miss p50/p95/max {}{}",
        s.scenario,
        s.runs,
        if s.first_run > 0 {
            format!(" from run {}", s.first_run)
        } else {
            String::new()
        },
        s.shard
            .as_ref()
            .map_or(String::new(), |k| format!(" (shard {k})")),
        s.success,
        pct(s.success_rate),
        pct(s.success_ci95.lower),
        pct(s.success_ci95.upper),
        s.docked,
        s.unsafe_runs,
        pct(s.unsafe_upper95),
        if hazards.is_empty() {
            String::new()
        } else {
            format!(": {}", hazards.join(", "))
        },
        s.miss_m.map_or("-".into(), |m| format!(
            "{:.3}/{:.3}/{:.3} m",
            m.p50, m.p95, m.max
        )),
        if s.aborts_called > 0 {
            format!(
                ", tanker's breakaway calls {}, safe {}",
                s.aborts_called, s.aborts_safe
            )
        } else {
            String::new()
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wilson_matches_published_values() {
        // Newcombe (1998), Table I: 81/263 -> 0.2553..0.3662; 0/10 -> 0..0.2775.
        let w = wilson(81, 263);
        assert!(
            (w.lower - 0.2553).abs() < 5e-5 && (w.upper - 0.3662).abs() < 5e-5,
            "{w:?}"
        );
        let w = wilson(0, 10);
        assert!(w.lower == 0.0 && (w.upper - 0.2775).abs() < 5e-5, "{w:?}");
        let w = wilson(1000, 1000);
        assert!(
            (w.lower - 0.99617).abs() < 5e-5 && (w.upper - 1.0).abs() < 1e-12,
            "{w:?}"
        );
        assert_eq!(
            wilson(0, 0),
            Interval {
                lower: 0.0,
                upper: 1.0
            }
        );
    }

    #[test]
    fn quantiles_interpolate_between_order_statistics() {
        let v = [1.0, 2.0, 3.0, 4.0];
        assert_eq!(quantile(&v, 0.0), Some(1.0));
        assert_eq!(quantile(&v, 0.5), Some(2.5));
        assert_eq!(quantile(&v, 1.0), Some(4.0));
        assert!((quantile(&v, 0.95).unwrap() - 3.85).abs() < 1e-12);
        assert_eq!(quantile(&[], 0.5), None);
    }

    #[test]
    fn a_run_record_carries_the_plant_it_flew() {
        let f = ScenarioFile::load("level2").expect("preset");
        let mut grades = std::collections::BTreeSet::new();
        for i in 0..20 {
            let run = f.dispersed(i);
            let p = RunInputs::of(&run).plant;
            assert_eq!(p.receiver, run.receiver.plant, "run {i}");
            assert!(!p.receiver.is_nominal(), "run {i}");
            assert_eq!(p.hose_length_m, run.drogue.hose_length_m, "run {i}");
            assert_eq!(p.tanker_wake_strength, run.tanker_wake.strength, "run {i}");
            assert_eq!(
                p.radial_distortion_k[1], run.camera.radial_distortion_k2,
                "run {i}"
            );
            grades.insert(format!("{:?}", p.ins_grade));
        }
        assert_eq!(grades.len(), 2, "both INS grades among 20 runs: {grades:?}");
        let nominal = ScenarioFile::load("nominal-level2")
            .expect("preset")
            .dispersed(3);
        assert!(RunInputs::of(&nominal).plant.receiver.is_nominal());
    }

    #[test]
    fn a_run_record_carries_the_navigation_latency_it_flew() {
        let f = ScenarioFile::load("level2").expect("preset");
        let seen: std::collections::BTreeSet<Option<u32>> = (0..20)
            .map(|i| RunInputs::of(&f.dispersed(i)).nav_latency_steps)
            .collect();
        assert_eq!(seen, [Some(1), Some(2)].into_iter().collect());
        let paper = ScenarioFile::load("paper-level2").expect("preset");
        assert_eq!(RunInputs::of(&paper.dispersed(0)).nav_latency_steps, None);
    }

    #[test]
    fn shards_partition_the_campaign() {
        assert_eq!("2/3".parse::<Shard>().unwrap(), Shard { k: 2, m: 3 });
        for bad in ["0/3", "4/3", "1", "a/b", "1/0"] {
            let e = bad.parse::<Shard>().unwrap_err();
            assert!(e.contains("K/M"), "{e}");
        }
        for first in [0, 1_000_000] {
            let mut all: Vec<u64> = (1..=3)
                .flat_map(|k| indices(first, 10, Some(Shard { k, m: 3 })))
                .collect();
            all.sort_unstable();
            assert_eq!(all, indices(first, 10, None));
            assert_eq!(all, (first..first + 10).collect::<Vec<_>>());
        }
        assert_eq!(indices(0, 2, Some(Shard { k: 3, m: 3 })), Vec::<u64>::new());
        assert_eq!(indices(7, 5, Some(Shard { k: 2, m: 2 })), vec![8, 10]);
    }

    #[test]
    fn the_upper_bound_matches_published_clopper_pearson_values() {
        // No events: 1 - 0.05^(1/n), about 3/n.
        assert!(
            (upper95(0, 10_000) - 2.9953e-4).abs() < 1e-8,
            "{}",
            upper95(0, 10_000)
        );
        assert!((upper95(0, 10) - 0.2589).abs() < 1e-4);
        // One-sided 95 % exact bounds, the beta quantile Beta(0.95; k + 1, n - k), computed
        // independently by bisection on exact binomial sums in Python's integers:
        // 1 of 10 -> 0.39416, 5 of 100 -> 0.10225, 12 of 1000 -> 0.019370.
        assert!(
            (upper95(1, 10) - 0.39416).abs() < 1e-5,
            "{}",
            upper95(1, 10)
        );
        assert!(
            (upper95(5, 100) - 0.10225).abs() < 1e-5,
            "{}",
            upper95(5, 100)
        );
        assert!(
            (upper95(12, 1000) - 0.019370).abs() < 1e-5,
            "{}",
            upper95(12, 1000)
        );
        assert_eq!(upper95(3, 3), 1.0);
        assert_eq!(upper95(0, 0), 1.0);
        // It grows with the count and falls with the trials.
        assert!(upper95(2, 1000) > upper95(1, 1000));
        assert!(upper95(1, 2000) < upper95(1, 1000));
    }

    /// A batch system's environment as `shard_from_env` reads it.
    fn env(vars: &[(&str, &str)]) -> impl Fn(&str) -> Option<String> + use<> {
        let vars: Vec<(String, String)> = vars
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        move |name| vars.iter().find(|(k, _)| k == name).map(|(_, v)| v.clone())
    }

    #[test]
    fn a_batch_job_takes_its_shard_from_the_environment() {
        let slurm = |id: &'static str| {
            env(&[
                ("SLURM_ARRAY_TASK_ID", id),
                ("SLURM_ARRAY_TASK_MIN", "3"),
                ("SLURM_ARRAY_TASK_MAX", "6"),
                ("SLURM_ARRAY_TASK_COUNT", "4"),
                ("SLURM_ARRAY_TASK_STEP", "1"),
            ])
        };
        let shard = |k, m| Shard { k, m };
        assert_eq!(
            shard_from_env(slurm("3"), None),
            Ok(Some((shard(1, 4), ShardSource::SlurmArray)))
        );
        assert_eq!(
            shard_from_env(slurm("6"), Some(4)),
            Ok(Some((shard(4, 4), ShardSource::SlurmArray)))
        );
        let k8s = env(&[("JOB_COMPLETION_INDEX", "0")]);
        assert_eq!(
            shard_from_env(&k8s, Some(5)),
            Ok(Some((shard(1, 5), ShardSource::IndexedJob)))
        );
        assert_eq!(shard_from_env(env(&[]), None), Ok(None));
        // Refusals name what is wrong.
        let refused = |lookup: &dyn Fn(&str) -> Option<String>, shards, what: &str| {
            let e = shard_from_env(lookup, shards).unwrap_err();
            assert!(e.contains(what), "{e}");
        };
        refused(&slurm("7"), None, "outside the array");
        refused(&slurm("4"), Some(3), "differs from SLURM_ARRAY_TASK_COUNT");
        refused(&k8s, None, "--shards M");
        refused(&env(&[("JOB_COMPLETION_INDEX", "5")]), Some(5), "not below");
        refused(&env(&[("JOB_COMPLETION_INDEX", "x")]), Some(5), "integer");
        refused(&env(&[]), Some(5), "without JOB_COMPLETION_INDEX");
        refused(
            &env(&[("SLURM_ARRAY_TASK_ID", "1"), ("JOB_COMPLETION_INDEX", "1")]),
            Some(2),
            "both",
        );
        refused(
            &env(&[("SLURM_ARRAY_TASK_ID", "1")]),
            None,
            "SLURM_ARRAY_TASK_MIN is not",
        );
        let stepped = env(&[
            ("SLURM_ARRAY_TASK_ID", "0"),
            ("SLURM_ARRAY_TASK_MIN", "0"),
            ("SLURM_ARRAY_TASK_MAX", "6"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
            ("SLURM_ARRAY_TASK_STEP", "2"),
        ]);
        refused(&stepped, None, "steps by 2");
        let list = env(&[
            ("SLURM_ARRAY_TASK_ID", "1"),
            ("SLURM_ARRAY_TASK_MIN", "1"),
            ("SLURM_ARRAY_TASK_MAX", "9"),
            ("SLURM_ARRAY_TASK_COUNT", "3"),
        ]);
        refused(&list, None, "not a contiguous range");
    }
}
