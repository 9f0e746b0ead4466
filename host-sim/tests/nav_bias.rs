//! The navigation's velocity bias, estimated at the station from the drogue's mean estimated
//! velocity (`EstimatorConfig::nav_bias_time_constant_s`, `docs/conventions.md`, "Navigation
//! bias"), judged on the simulator's truth: whether the probe docked and nothing hazardous
//! happened (the referee's verdict), never on the controller's modes or its own estimate.
//!
//! Calm air, the default procedure, an INS whose velocity bias is 0.3 m/s per axis (one
//! sigma, drawn per seed: three times the industrial grade's): with the estimate every seed
//! docks at its first attempt; with it off, the receiver holds the velocity the INS reports
//! and none docks (it overruns the station or times out there), so the check can fail.

use host_sim::scenario::ScenarioFile;
use host_sim::sim::{Run, run};
use ibvs_core::Controller;

const SEEDS: std::ops::RangeInclusive<u64> = 1..=6;

/// Flies `calm` with the INS's velocity bias at 0.3 m/s (one sigma) and seed `seed`, the
/// bias estimate's time constant `tau_s` (0: off).
fn fly(seed: u64, tau_s: f32) -> Run {
    let mut f = ScenarioFile::load("calm").expect("preset");
    f.seed = seed;
    f.duration_s = 90.0;
    f.navigation.ins.velocity_bias_mps = 0.3;
    f.controller.config.estimator.nav_bias_time_constant_s = tau_s;
    let mut c = Controller::new(f.controller_config()).expect("config");
    run(&f.scenario(), &mut c).expect("runs")
}

#[test]
fn with_the_bias_estimated_every_biased_sortie_docks_at_the_first_attempt() {
    for seed in SEEDS {
        let r = fly(seed, 20.0);
        assert!(
            r.verdict.success(),
            "seed {seed}: {:?}, hazards {:?}",
            r.summary,
            r.verdict.hazards
        );
        assert_eq!(r.summary.attempts, 1, "seed {seed}: {:?}", r.summary);
    }
}

#[test]
fn without_the_estimate_the_same_sorties_do_not_dock() {
    for seed in SEEDS {
        let r = fly(seed, 0.0);
        assert!(!r.verdict.docked(), "seed {seed}: {:?}", r.summary);
    }
}
