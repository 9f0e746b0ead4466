//! The drogue estimator's sigmas describe its errors against the simulator's truth, in the
//! air the refuelling presets fly (`host_sim::consistency`; `docs/conventions.md`, "Drogue
//! estimator", consistency).
//!
//! Asserted: over 200 dispersed sorties of `level2` and of `mil-level2`, the mean normalised
//! estimation-error square of the offset (right and down) lies between 0.25 and 4, its sigma
//! within a factor of two of its error; and the drogue velocity's between 0.5 and 2, its
//! sigma within a factor of 1.41 of its error (0.60 in `level2`, where the floor of its
//! process noise, the camera calibration's drift while closing, binds; 1.32 in
//! `mil-level2`). Before the filter considered the angular
//! biases it does not estimate (navigation heading and pitch, camera mount and principal
//! point, times the depth) the offset's was 78 and 38; before its process noise followed the
//! measured activity through the hose's swing the velocity's was 0.21 in `level2` (its sigma
//! twice its error) and 0.65 in `mil-level2`: one fixed noise cannot fit both airs. Not
//! asserted, and why: the Monte Carlo band test step by step (the runs' NEES in the 95 %
//! band of chi²), which the offset passes at 0..70 % of the steps and the velocity at
//! 4..49 %: what the filter's model leaves out is correlated in time (navigation and mount
//! biases, the LED fit, the swing's phase, the calibration's drift), which a per-step band
//! test of white errors cannot accept; reported, not met.

use host_sim::consistency::{self, STATES};
use host_sim::scenario::ScenarioFile;

/// Runs per preset.
const RUNS: u64 = 200;

/// The accepted mean NEES of the offset: sigma within a factor of two of the error.
const NEES_BAND: std::ops::RangeInclusive<f64> = 0.25..=4.0;

/// The accepted mean NEES of the drogue's velocity: sigma within a factor of 1.41 of the
/// error.
const VELOCITY_NEES_BAND: std::ops::RangeInclusive<f64> = 0.5..=2.0;

/// Each state (offset right, down; velocity right, down) whose mean NEES is outside its band.
fn nees_failures(preset: &str) -> Vec<String> {
    let base = ScenarioFile::load(preset).expect("preset");
    let c = consistency::measure(&base, 0..RUNS).expect("runs");
    assert!(c.steps > 100 * RUNS as usize, "{preset}: {} steps", c.steps);
    STATES
        .iter()
        .zip(&c.states)
        .zip([
            &NEES_BAND,
            &NEES_BAND,
            &VELOCITY_NEES_BAND,
            &VELOCITY_NEES_BAND,
        ])
        .filter(|((_, s), band)| !band.contains(&s.nees_mean))
        .map(|((name, s), _)| format!("{preset}, {name}: {s:?}"))
        .collect()
}

#[test]
fn in_level_two_air_the_sigmas_describe_the_errors() {
    let f = nees_failures("level2");
    assert!(f.is_empty(), "\n{}", f.join("\n"));
}

#[test]
fn in_mil_spec_air_the_sigmas_describe_the_errors() {
    let f = nees_failures("mil-level2");
    assert!(f.is_empty(), "\n{}", f.join("\n"));
}
