//! The drogue estimator's offset sigma describes its error against the simulator's truth, in
//! the air the refuelling presets fly (`host_sim::consistency`; `docs/conventions.md`,
//! "Drogue estimator", consistency).
//!
//! Asserted: over 200 dispersed sorties of `level2` and of `mil-level2`, the mean normalised
//! estimation-error square of the offset (right and down) lies between 0.25 and 4, its sigma
//! within a factor of two of its error. Before the filter considered the angular biases it
//! does not estimate (navigation heading and pitch, camera mount and principal point, times
//! the depth) it was 78 and 38. Not asserted, and why: the Monte Carlo band test step by step
//! (the runs' NEES in the 95 % band of chi²), which the offset passes at 0..74 % of the steps,
//! and the drogue velocity's NEES (0.2..0.8: its sigma up to 2.2 times its error, an
//! underconfidence that makes the gate cautious, not bold); both are reported, not met.

use host_sim::consistency::{self, STATES};
use host_sim::scenario::ScenarioFile;

/// Runs per preset.
const RUNS: u64 = 200;

/// The accepted mean NEES of the offset: sigma within a factor of two of the error.
const NEES_BAND: std::ops::RangeInclusive<f64> = 0.25..=4.0;

fn offset_nees_failures(preset: &str) -> Vec<String> {
    let base = ScenarioFile::load(preset).expect("preset");
    let c = consistency::measure(&base, 0..RUNS).expect("runs");
    assert!(c.steps > 100 * RUNS as usize, "{preset}: {} steps", c.steps);
    STATES
        .iter()
        .zip(&c.states)
        .take(2)
        .filter(|(_, s)| !NEES_BAND.contains(&s.nees_mean))
        .map(|(name, s)| format!("{preset}, {name}: {s:?}"))
        .collect()
}

#[test]
fn in_level_two_air_the_offset_sigma_is_within_a_factor_of_two_of_its_error() {
    let f = offset_nees_failures("level2");
    assert!(f.is_empty(), "\n{}", f.join("\n"));
}

#[test]
fn in_mil_spec_air_the_offset_sigma_is_within_a_factor_of_two_of_its_error() {
    let f = offset_nees_failures("mil-level2");
    assert!(f.is_empty(), "\n{}", f.join("\n"));
}
