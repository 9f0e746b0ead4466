//! The paper's experiments (Sec. IV), run over several seeds, with their figures, data and a
//! summary table.
//!
//! Experiments: aerodynamic disturbance at level I and at level II (Table 1 gains, the paper's
//! Fig. 4); the bow wave with level I turbulence (Table 2 gains, Fig. 5); a camera position
//! error of [1, 0, -0.5] m flown by IBVS and by PBVS (Fig. 6). Each run is a built-in
//! scenario with its seed replaced. Output per experiment: `image_error.png` (image tracking
//! error against time, every run), `paths.png` (probe tip and drogue, side and top views),
//! one CSV per run; and one `summary.md` table for all runs.
//!
//! Invariant: the result depends only on the presets and the seeds (runs are independent and
//! run in parallel; their order in the output is fixed).

use std::fmt::Write as _;
use std::path::Path;

use ibvs_core::Controller;
use rayon::prelude::*;

use crate::output::{self, OutputError};
use crate::plot::{self, PALETTE, Series};
use crate::scenario::{ScenarioError, ScenarioFile};
use crate::sim::{self, Run, SimError};

/// Seeds per experiment by default.
pub const DEFAULT_SEEDS: u64 = 5;

/// One experiment: an id (its directory), a title and the presets it runs.
pub struct Experiment {
    /// Directory name.
    pub id: &'static str,
    /// Title for figures and the table.
    pub title: &'static str,
    /// Built-in scenarios, each run over every seed.
    pub presets: &'static [&'static str],
}

/// The paper's experiments.
pub const EXPERIMENTS: [Experiment; 4] = [
    Experiment {
        id: "level1",
        title: "Aerodynamic disturbance, level I (Table 1)",
        presets: &["paper-level1"],
    },
    Experiment {
        id: "level2",
        title: "Aerodynamic disturbance, level II (Table 1)",
        presets: &["paper-level2"],
    },
    Experiment {
        id: "bow-wave",
        title: "Bow wave and level I turbulence (Table 2)",
        presets: &["paper-bow-wave"],
    },
    Experiment {
        id: "mount-error",
        title: "Camera position error [1, 0, -0.5] m: IBVS and PBVS",
        presets: &["paper-mount-error-ibvs", "paper-mount-error-pbvs"],
    },
];

/// Why the experiments could not be run or written.
#[derive(Debug, thiserror::Error)]
pub enum PaperError {
    /// A preset failed to load.
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    /// A run could not start.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// Output.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// The controller rejected its configuration.
    #[error(transparent)]
    Config(#[from] ibvs_core::ConfigError),
    /// Directory creation.
    #[error("{path}: {source}")]
    Io {
        /// Path.
        path: String,
        /// Error.
        source: std::io::Error,
    },
}

/// One finished run of an experiment.
pub struct PaperRun {
    /// Preset name.
    pub preset: &'static str,
    /// Seed.
    pub seed: u64,
    /// The run.
    pub run: Run,
}

/// Runs one preset with one seed.
pub fn run_preset(preset: &str, seed: u64) -> Result<Run, PaperError> {
    let mut f = ScenarioFile::load(preset)?;
    f.seed = seed;
    let mut c = Controller::new(f.controller_config())?;
    Ok(sim::run(&f.scenario(), &mut c)?)
}

/// Runs every experiment's presets over seeds `1..=seeds`, in parallel.
pub fn run_experiment(e: &Experiment, seeds: u64) -> Result<Vec<PaperRun>, PaperError> {
    let jobs: Vec<(&'static str, u64)> = e
        .presets
        .iter()
        .flat_map(|&p| (1..=seeds).map(move |s| (p, s)))
        .collect();
    jobs.par_iter()
        .map(|&(preset, seed)| {
            Ok(PaperRun {
                preset,
                seed,
                run: run_preset(preset, seed)?,
            })
        })
        .collect()
}

fn image_error_figure(path: &Path, e: &Experiment, runs: &[PaperRun]) -> Result<(), OutputError> {
    let label: Vec<String> = runs
        .iter()
        .map(|r| format!("{} #{}", r.preset.trim_start_matches("paper-"), r.seed))
        .collect();
    let pick = |axis: usize| -> Vec<Series<'_>> {
        runs.iter()
            .enumerate()
            .map(|(i, r)| {
                let pts = plot::over_time(&r.run, |s| {
                    let m = &s.measurement;
                    m.tracked
                        .then(|| f64::from(if axis == 0 { m.image_x } else { m.image_y }))
                });
                (label[i].as_str(), PALETTE[i % PALETTE.len()], pts)
            })
            .collect()
    };
    plot::figure(path, (1400, 1000), |root| {
        let p = root.split_evenly((2, 1));
        plot::lines(
            &p[0],
            &format!("{}: image error e_x", e.title),
            "time, s",
            "e_x (normalised)",
            &pick(0),
        )?;
        plot::lines(
            &p[1],
            &format!("{}: image error e_y", e.title),
            "time, s",
            "e_y (normalised)",
            &pick(1),
        )
    })
}

fn paths_figure(path: &Path, e: &Experiment, runs: &[PaperRun]) -> Result<(), OutputError> {
    // The first seed of each preset: probe tip and drogue, side (x, up) and top (x, right) views.
    let firsts: Vec<&PaperRun> = runs.iter().filter(|r| r.seed == runs[0].seed).collect();
    let mut names = Vec::new();
    for r in &firsts {
        let short = r.preset.trim_start_matches("paper-");
        names.push((format!("probe tip, {short}"), format!("drogue, {short}")));
    }
    let view = |vertical: bool| -> Vec<Series<'_>> {
        let mut v = Vec::new();
        for (i, r) in firsts.iter().enumerate() {
            let coord = |p: &nalgebra::Vector3<f64>| (p.x, if vertical { -p.z } else { p.y });
            let tip = r
                .run
                .samples
                .iter()
                .map(|s| coord(&s.tip_tanker_m))
                .collect();
            let drogue = r
                .run
                .samples
                .iter()
                .map(|s| coord(&s.drogue_tanker_m))
                .collect();
            v.push((names[i].0.as_str(), PALETTE[(2 * i) % PALETTE.len()], tip));
            v.push((
                names[i].1.as_str(),
                PALETTE[(2 * i + 1) % PALETTE.len()],
                drogue,
            ));
        }
        v
    };
    plot::figure(path, (1400, 1000), |root| {
        let p = root.split_evenly((2, 1));
        plot::lines(
            &p[0],
            &format!("{}: side view (tanker frame)", e.title),
            "forward x, m",
            "up (-z), m",
            &view(true),
        )?;
        plot::lines(
            &p[1],
            &format!("{}: top view (tanker frame)", e.title),
            "forward x, m",
            "right y, m",
            &view(false),
        )
    })
}

/// Runs all experiments, writes everything under `out`, and returns the summary table
/// (also written to `out/summary.md`).
pub fn run_all(out: &Path, seeds: u64) -> Result<String, PaperError> {
    let mut table = String::from(
        "| experiment | scenario | seed | outcome | miss, m | closing speed, m/s | time, s | breakaway |\n\
         |---|---|---|---|---|---|---|---|\n",
    );
    for e in &EXPERIMENTS {
        let dir = out.join(e.id);
        std::fs::create_dir_all(&dir).map_err(|source| PaperError::Io {
            path: dir.display().to_string(),
            source,
        })?;
        let runs = run_experiment(e, seeds)?;
        for r in &runs {
            output::write_csv(
                &dir.join(format!("{}-seed{}.csv", r.preset, r.seed)),
                &r.run,
            )?;
            let s = &r.run.summary;
            let num = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.3}"));
            let _ = writeln!(
                table,
                "| {} | {} | {} | {:?} | {} | {} | {:.2} | {} |",
                e.id,
                r.preset,
                r.seed,
                s.outcome,
                num(s.miss_m),
                num(s.closure_mps),
                s.time_s,
                s.breakaway_reason.as_deref().unwrap_or("-")
            );
        }
        image_error_figure(&dir.join("image_error.png"), e, &runs)?;
        paths_figure(&dir.join("paths.png"), e, &runs)?;
    }
    let path = out.join("summary.md");
    std::fs::write(&path, &table).map_err(|source| PaperError::Io {
        path: path.display().to_string(),
        source,
    })?;
    Ok(table)
}
