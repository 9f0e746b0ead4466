//! Development tool: is the drogue estimator consistent with the truth it estimates?
//!
//! `cargo run --release -p host-sim --example estimator_consistency -- PRESET [RUNS] [FIRST]`
//!
//! Flies `RUNS` (default 200) dispersed sorties of the preset from run index `FIRST`
//! (default 0) with the controller in-process, and after every step reads the drogue
//! estimator's state and covariance (`Controller::drogue_estimator`) beside the simulator's
//! truth: the drogue centre minus the probe tip in tanker axes, and the drogue's velocity
//! relative to the tanker (central difference of its position over the control steps). Steps
//! counted: the estimator started, the procedure engaged (pre-contact, approach, capture,
//! missed approach), from `SETTLE_S` after the estimator's start.
//!
//! Per state (offset right and down, drogue velocity right and down) it prints the error's
//! mean and RMS, the filter's mean one-sigma, the normalised estimation-error square (NEES,
//! `e² / P`: 1 on average for a consistent filter), the fraction of steps with `|e| <= σ`
//! (68.3 % for a consistent Gaussian filter), and the Monte Carlo band test of Bar-Shalom, Li
//! and Kirubarajan (*Estimation with Applications to Tracking and Navigation*, 2001, 5.4):
//! at each step since the estimator's start, the NEES averaged over the runs there must lie in
//! the two-sided 95 % band of `chi²(M) / M` for `M` runs; printed is the fraction of steps
//! (with at least `MIN_RUNS` runs) inside it, 95 % for a consistent filter.
use host_sim::scenario::ScenarioFile;
use host_sim::sim::{self, FlightComputer};
use ibvs_core::{Controller, ControllerInput, ControllerOutput, Mode};
use rayon::prelude::*;

/// Time after the estimator's start before steps are counted, s (its initial transient).
const SETTLE_S: f64 = 2.0;

/// Least number of runs at a step for its band test.
const MIN_RUNS: usize = 30;

/// The controller, and the estimator's variances after each step (`None`: not started):
/// offset right, down; velocity right, down.
struct Recorder {
    ctl: Controller,
    variances: Vec<Option<[f64; 4]>>,
}

impl FlightComputer for Recorder {
    fn step(&mut self, input: &ControllerInput) -> ControllerOutput {
        let out = FlightComputer::step(&mut self.ctl, input);
        let e = self.ctl.drogue_estimator();
        self.variances.push(e.started().then(|| {
            let o = e.offset_variance_m2();
            let v = e.velocity_variance_m2ps2();
            [o[0], o[1], v[0], v[1]].map(f64::from)
        }));
        out
    }
}

/// One counted step: steps since the estimator's start, error and variance per state.
struct Point {
    since_start: usize,
    error: [f64; 4],
    variance: [f64; 4],
}

fn fly(base: &ScenarioFile, index: u64) -> Vec<Point> {
    let f = base.dispersed(index);
    let mut rec = Recorder {
        ctl: Controller::new(f.controller_config()).expect("valid configuration"),
        variances: Vec::new(),
    };
    let run = sim::run(&f.scenario(), &mut rec).expect("run");
    let s = &run.samples;
    let dt = s[1].time_s - s[0].time_s;
    let settle = (SETTLE_S / dt).round() as usize;
    let mut start = None;
    let mut points = Vec::new();
    for k in 1..s.len().saturating_sub(1) {
        let Some(variance) = rec.variances[k] else {
            start = None;
            continue;
        };
        let started = *start.get_or_insert(k);
        let engaged = matches!(
            s[k].output.mode,
            Mode::PreContact | Mode::Approach | Mode::Terminal | Mode::MissedApproach
        );
        if !engaged || k < started + settle {
            continue;
        }
        let truth_v = (s[k + 1].drogue_tanker_m - s[k - 1].drogue_tanker_m) / (2.0 * dt);
        let e = &s[k].output.estimate;
        let t = &s[k].drogue_from_tip_m;
        points.push(Point {
            since_start: k - started,
            error: [
                f64::from(e.offset_m[0]) - t.y,
                f64::from(e.offset_m[1]) - t.z,
                f64::from(e.drogue_velocity_mps[0]) - truth_v.y,
                f64::from(e.drogue_velocity_mps[1]) - truth_v.z,
            ],
            variance,
        });
    }
    points
}

/// The `p` quantile of chi-square with `n` degrees of freedom (Wilson and Hilferty's cube).
fn chi2_quantile(n: f64, z: f64) -> f64 {
    let a = 2.0 / (9.0 * n);
    n * (1.0 - a + z * a.sqrt()).powi(3)
}

fn main() {
    let mut args = std::env::args().skip(1);
    let preset = args.next().expect("a preset or scenario file");
    let runs: u64 = args.next().map_or(200, |s| s.parse().expect("runs"));
    let first: u64 = args.next().map_or(0, |s| s.parse().expect("first run"));
    let base = ScenarioFile::load(&preset).expect("scenario");
    let all: Vec<Vec<Point>> = (first..first + runs)
        .into_par_iter()
        .map(|i| fly(&base, i))
        .collect();
    let names = [
        "offset right",
        "offset down",
        "velocity right",
        "velocity down",
    ];
    println!(
        "{preset}: runs {first}..{}, {} steps counted",
        first + runs,
        all.iter().map(Vec::len).sum::<usize>()
    );
    println!(
        "| state | error mean | error RMS | filter σ (mean) | NEES mean | within 1σ | band test |"
    );
    println!("|---|---|---|---|---|---|---|");
    let longest = all
        .iter()
        .flat_map(|r| r.iter().map(|p| p.since_start))
        .max()
        .unwrap_or(0);
    for (i, name) in names.iter().enumerate() {
        let pts: Vec<&Point> = all.iter().flatten().collect();
        let n = pts.len() as f64;
        let mean = pts.iter().map(|p| p.error[i]).sum::<f64>() / n;
        let rms = (pts.iter().map(|p| p.error[i].powi(2)).sum::<f64>() / n).sqrt();
        let sigma = pts.iter().map(|p| p.variance[i].sqrt()).sum::<f64>() / n;
        let nees = pts
            .iter()
            .map(|p| p.error[i].powi(2) / p.variance[i])
            .sum::<f64>()
            / n;
        let within = pts
            .iter()
            .filter(|p| p.error[i].abs() <= p.variance[i].sqrt())
            .count() as f64
            / n;
        // The band test, step by step since the estimator's start.
        let mut sum = vec![0.0; longest + 1];
        let mut count = vec![0usize; longest + 1];
        for p in &pts {
            sum[p.since_start] += p.error[i].powi(2) / p.variance[i];
            count[p.since_start] += 1;
        }
        let (mut tested, mut inside) = (0usize, 0usize);
        for (s, &m) in sum.iter().zip(&count) {
            if m < MIN_RUNS {
                continue;
            }
            let mf = m as f64;
            let (lo, hi) = (
                chi2_quantile(mf, -1.959_964) / mf,
                chi2_quantile(mf, 1.959_964) / mf,
            );
            tested += 1;
            inside += usize::from((lo..=hi).contains(&(s / mf)));
        }
        println!(
            "| {name} | {mean:.4} | {rms:.4} | {sigma:.4} | {nees:.2} | {:.1} % | {:.1} % of {tested} steps |",
            100.0 * within,
            100.0 * inside as f64 / tested.max(1) as f64
        );
    }
}
