//! The drogue estimator's consistency against the simulator's truth: does the filter's
//! covariance describe its errors?
//!
//! Dispersed sorties of a scenario are flown with the controller in-process; after every
//! step the estimator's state and covariance (`ibvs_core::Controller::drogue_estimator`; the
//! offset's variance with the angular bias the filter considers,
//! `DrogueEstimator::offset_error_variance_m2`) are read beside the truth: the drogue centre
//! minus the probe tip in tanker axes, and the drogue's velocity relative to the tanker (the
//! central difference of its position over the control steps). Steps counted: the estimator
//! started, the procedure engaged (pre-contact, approach, capture, missed approach), from
//! [`SETTLE_S`] after the estimator's start.
//!
//! Per state (offset right and down, drogue velocity right and down): the error's mean and
//! RMS, the filter's mean sigma, the normalised estimation-error square (NEES, `e² / P`: 1 on
//! average for a consistent filter), the fraction of steps with `|e| <= σ` (68.3 % for a
//! consistent Gaussian filter), and the Monte Carlo band test of Bar-Shalom, Li and
//! Kirubarajan (*Estimation with Applications to Tracking and Navigation*, 2001, sec. 5.4):
//! at each step since the estimator's start, the NEES averaged over the runs there must lie in
//! the two-sided 95 % band of `chi²(M) / M` for `M` runs; reported is the fraction of steps
//! (with at least [`MIN_RUNS`] runs) inside it, 95 % for a consistent filter.
//!
//! Invariants: reading the estimator changes nothing in the run (the same runs as a campaign
//! of the same indices); the result is a pure function of the scenario and the run indices.

use std::ops::Range;

use rayon::prelude::*;

use ibvs_core::estimator::EstimatorModel;
use ibvs_core::gains::CONTROL_PERIOD_S;
use ibvs_core::{Controller, ControllerInput, ControllerOutput, Mode};

use crate::scenario::ScenarioFile;
use crate::sim::{self, FlightComputer, SimError};

/// Why a measurement could not be made.
#[derive(Debug, thiserror::Error)]
pub enum ConsistencyError {
    /// A run's controller configuration was refused.
    #[error("run {index}: the controller's configuration: {source}")]
    Config {
        /// The run's index.
        index: u64,
        /// The refusal.
        source: ibvs_core::config::ConfigError,
    },
    /// A run failed.
    #[error("run {index}: {source}")]
    Run {
        /// The run's index.
        index: u64,
        /// The simulator's error.
        source: SimError,
    },
}

/// Time after the estimator's start before steps are counted, s (its initial transient).
pub const SETTLE_S: f64 = 2.0;

/// Least number of runs at a step for its band test.
pub const MIN_RUNS: usize = 30;

/// The states measured, in the order of [`Consistency::states`].
pub const STATES: [&str; 4] = [
    "offset right",
    "offset down",
    "velocity right",
    "velocity down",
];

/// One state's figures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StateConsistency {
    /// Mean error (estimate minus truth), m or m/s.
    pub error_mean: f64,
    /// RMS error.
    pub error_rms: f64,
    /// The filter's sigma, averaged over the steps.
    pub sigma_mean: f64,
    /// Mean NEES.
    pub nees_mean: f64,
    /// Fraction of steps with the error within one sigma.
    pub within_one_sigma: f64,
    /// Fraction of the band test's steps inside the 95 % band.
    pub band_fraction: f64,
    /// Steps the band test had.
    pub band_steps: usize,
}

/// A measurement's result.
#[derive(Debug, Clone, PartialEq)]
pub struct Consistency {
    /// Steps counted over all runs.
    pub steps: usize,
    /// Per state, in the order of [`STATES`].
    pub states: [StateConsistency; 4],
}

/// The controller, its estimator's model (for the offset's error variance), and the
/// estimator's variances after each step (`None`: not started): offset right, down;
/// velocity right, down.
struct Recorder {
    ctl: Controller,
    model: EstimatorModel,
    variances: Vec<Option<[f64; 4]>>,
}

impl FlightComputer for Recorder {
    fn step(&mut self, input: &ControllerInput) -> ControllerOutput {
        let out = FlightComputer::step(&mut self.ctl, input);
        let e = self.ctl.drogue_estimator();
        self.variances.push(e.started().then(|| {
            let o = e.offset_error_variance_m2(&self.model);
            let v = e.velocity_variance_m2ps2();
            [o[0], o[1], v[0], v[1]].map(f64::from)
        }));
        out
    }

    fn autopilot_design(&self) -> Option<ibvs_core::attitude::AttitudeLoopConfig> {
        self.ctl.autopilot_design()
    }

    fn probe_tip_image(&self) -> Option<[f32; 2]> {
        FlightComputer::probe_tip_image(&self.ctl)
    }
}

/// One counted step: steps since the estimator's start, error and variance per state.
struct Point {
    since_start: usize,
    error: [f64; 4],
    variance: [f64; 4],
}

fn fly(base: &ScenarioFile, index: u64) -> Result<Vec<Point>, ConsistencyError> {
    let f = base.dispersed(index);
    let cfg = f.controller_config();
    let mut rec = Recorder {
        ctl: Controller::new(cfg).map_err(|source| ConsistencyError::Config { index, source })?,
        // The lead only sets the feed-forward's coefficients, not read here.
        model: EstimatorModel::new(&cfg.estimator, CONTROL_PERIOD_S, 0.0),
        variances: Vec::new(),
    };
    let run = sim::run(&f.scenario(), &mut rec)
        .map_err(|source| ConsistencyError::Run { index, source })?;
    let s = &run.samples;
    let mut points = Vec::new();
    if s.len() < 3 {
        return Ok(points);
    }
    let dt = s[1].time_s - s[0].time_s;
    let settle = (SETTLE_S / dt).round() as usize;
    let mut start = None;
    for k in 1..s.len() - 1 {
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
    Ok(points)
}

/// The `p` quantile of chi-square with `n` degrees of freedom for the standard normal's
/// quantile `z` of `p` (Wilson and Hilferty's cube: within 0.1 % for `n` of 30 and more).
fn chi2_quantile(n: f64, z: f64) -> f64 {
    let a = 2.0 / (9.0 * n);
    n * (1.0 - a + z * a.sqrt()).powi(3)
}

/// The standard normal's 97.5 % quantile.
const Z_975: f64 = 1.959_964;

fn state(points: &[&Point], i: usize) -> StateConsistency {
    let n = points.len().max(1) as f64;
    let sum = |f: &dyn Fn(&Point) -> f64| points.iter().map(|p| f(p)).sum::<f64>();
    let nees = |p: &Point| p.error[i].powi(2) / p.variance[i];
    let longest = points.iter().map(|p| p.since_start).max().unwrap_or(0);
    let mut at = vec![(0.0, 0usize); longest + 1];
    for p in points {
        let a = &mut at[p.since_start];
        a.0 += nees(p);
        a.1 += 1;
    }
    let tested: Vec<bool> = at
        .iter()
        .filter(|(_, m)| *m >= MIN_RUNS)
        .map(|&(s, m)| {
            let m = m as f64;
            let band = chi2_quantile(m, -Z_975) / m..=chi2_quantile(m, Z_975) / m;
            band.contains(&(s / m))
        })
        .collect();
    StateConsistency {
        error_mean: sum(&|p| p.error[i]) / n,
        error_rms: (sum(&|p| p.error[i].powi(2)) / n).sqrt(),
        sigma_mean: sum(&|p| p.variance[i].sqrt()) / n,
        nees_mean: sum(&nees) / n,
        within_one_sigma: sum(&|p| f64::from(u8::from(p.error[i].abs() <= p.variance[i].sqrt())))
            / n,
        band_fraction: tested.iter().filter(|&&b| b).count() as f64 / tested.len().max(1) as f64,
        band_steps: tested.len(),
    }
}

/// Flies the runs `runs` of `base` (each [`ScenarioFile::dispersed`]) in parallel and
/// measures the estimator's consistency over them.
pub fn measure(base: &ScenarioFile, runs: Range<u64>) -> Result<Consistency, ConsistencyError> {
    let all: Vec<Vec<Point>> = runs
        .into_par_iter()
        .map(|i| fly(base, i))
        .collect::<Result<_, _>>()?;
    let points: Vec<&Point> = all.iter().flatten().collect();
    Ok(Consistency {
        steps: points.len(),
        states: [0, 1, 2, 3].map(|i| state(&points, i)),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_chi_square_quantiles_are_the_tables() {
        // chi²(30): 16.791 and 46.979 at 2.5 % and 97.5 %; chi²(200): 162.728 and 241.058.
        for (n, lo, hi) in [(30.0, 16.791, 46.979), (200.0, 162.728, 241.058)] {
            assert!(
                (chi2_quantile(n, -Z_975) - lo).abs() < 0.02 * lo / 10.0,
                "{n}"
            );
            assert!(
                (chi2_quantile(n, Z_975) - hi).abs() < 0.02 * hi / 10.0,
                "{n}"
            );
        }
    }

    #[test]
    fn a_filter_whose_sigma_is_its_error_passes_and_an_overconfident_one_does_not() {
        // Errors of exactly +-sigma: NEES 1 everywhere, inside every band.
        let pts: Vec<Point> = (0..40 * 50)
            .map(|j| Point {
                since_start: j % 50,
                error: [if j % 2 == 0 { 0.1 } else { -0.1 }; 4],
                variance: [0.01; 4],
            })
            .collect();
        let refs: Vec<&Point> = pts.iter().collect();
        let s = state(&refs, 0);
        assert!((s.nees_mean - 1.0).abs() < 1e-9, "{s:?}");
        assert_eq!((s.band_fraction, s.band_steps), (1.0, 50));
        assert_eq!(s.within_one_sigma, 1.0);
        // The same errors with a sigma a third as large: NEES 9, no step inside.
        let over: Vec<Point> = pts
            .iter()
            .map(|p| Point {
                variance: [0.01 / 9.0; 4],
                ..*p
            })
            .collect();
        let refs: Vec<&Point> = over.iter().collect();
        let s = state(&refs, 0);
        assert!((s.nees_mean - 9.0).abs() < 1e-6, "{s:?}");
        assert_eq!(s.band_fraction, 0.0);
        assert_eq!(s.within_one_sigma, 0.0);
    }
}
