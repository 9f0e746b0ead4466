//! The paper's experiments (Sec. IV) in the full environment, over ten seeds each: how many
//! runs dock, against what the paper claims (docs/conventions.md, "The paper's experiments").
//!
//! The paper claims IBVS docks under level I and level II turbulence, under the bow wave
//! (Table 2 gains) and with the camera position error, and that PBVS does not dock with the
//! camera position error. In this world all hold, in every seed (level II docked in nine of
//! ten while the paper's blind phase held its last commands; since it aims at the drogue,
//! `docs/paper.md`, in all ten).

use host_sim::paper::run_preset;
use host_sim::sim::Outcome;
use rayon::prelude::*;

const SEEDS: u64 = 10;

/// Seeds of `preset` (1..=SEEDS) that docked, and a line per run for the failure message.
fn docked(preset: &str) -> (usize, String) {
    let runs: Vec<_> = (1..=SEEDS)
        .into_par_iter()
        .map(|seed| (seed, run_preset(preset, seed).expect("run")))
        .collect();
    let n = runs
        .iter()
        .filter(|(_, r)| r.summary.outcome == Outcome::Docked)
        .count();
    let detail = runs
        .iter()
        .map(|(seed, r)| format!("  seed {seed}: {}", host_sim::output::one_line(&r.summary)))
        .collect::<Vec<_>>()
        .join("\n");
    (n, detail)
}

#[test]
fn ibvs_docks_under_level_one_turbulence() {
    let (n, detail) = docked("paper-level1");
    assert_eq!(n, SEEDS as usize, "\n{detail}");
}

#[test]
fn ibvs_docks_under_level_two_turbulence() {
    let (n, detail) = docked("paper-level2");
    assert_eq!(n, SEEDS as usize, "\n{detail}");
}

#[test]
fn ibvs_docks_under_the_bow_wave_with_table_two_gains() {
    let (n, detail) = docked("paper-bow-wave");
    assert_eq!(n, SEEDS as usize, "\n{detail}");
}

#[test]
fn with_a_camera_position_error_ibvs_docks_and_pbvs_does_not() {
    let (ibvs, detail) = docked("paper-mount-error-ibvs");
    assert_eq!(ibvs, SEEDS as usize, "\n{detail}");
    let (pbvs, detail) = docked("paper-mount-error-pbvs");
    assert_eq!(pbvs, 0, "\n{detail}");
}
