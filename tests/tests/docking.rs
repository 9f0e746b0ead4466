//! The calm-air acceptance runs: the refuelling procedure (the default), the paper's IBVS and
//! the PBVS baseline fly the nonlinear F-16 into the drogue from the paper's start and ten
//! others, and the same scenario gives the same run.

use closed_loop_tests::{STARTS_M, dock, docking_failure};
use ibvs_core::{ControllerConfig, Mode, OuterLaw};
use rayon::prelude::*;

/// Flies `cfg` from every start and fails naming each start that did not dock within the
/// criteria.
fn assert_docks_from_every_start(cfg: ControllerConfig) {
    let failed: Vec<String> = STARTS_M
        .par_iter()
        .filter_map(|&start| docking_failure(&dock(cfg, start)).map(|f| format!("{start:?}: {f}")))
        .collect();
    assert!(
        failed.is_empty(),
        "runs that did not dock within the criteria:\n{}",
        failed.join("\n")
    );
}

#[test]
fn the_refuelling_procedure_docks_from_the_paper_start_and_ten_others() {
    assert_docks_from_every_start(ControllerConfig::default());
}

#[test]
fn the_refuelling_procedure_holds_the_station_before_the_approach() {
    let run = dock(ControllerConfig::default(), STARTS_M[0]);
    let modes: Vec<Mode> = run.samples.iter().map(|s| s.output.mode).collect();
    let first = |m: Mode| modes.iter().position(|&x| x == m);
    let (pre, approach, capture, docked) = (
        first(Mode::PreContact).expect("pre-contact"),
        first(Mode::Approach).expect("approach"),
        first(Mode::Terminal).expect("capture"),
        first(Mode::Docked).expect("docked"),
    );
    assert!(pre < approach && approach < capture && capture < docked);
    assert!(
        !modes.contains(&Mode::MissedApproach),
        "calm air: one attempt"
    );
    assert_eq!(run.summary.attempts, 1);
}

#[test]
fn paper_ibvs_docks_from_the_paper_start_and_ten_others() {
    assert_docks_from_every_start(ControllerConfig::paper());
}

#[test]
fn pbvs_docks_from_the_paper_start_with_a_correct_camera_position() {
    let cfg = ControllerConfig {
        law: OuterLaw::Pbvs,
        ..ControllerConfig::paper()
    };
    let run = dock(cfg, STARTS_M[0]);
    assert_eq!(docking_failure(&run), None);
}

#[test]
fn the_same_scenario_gives_the_same_run() {
    let (a, b) = (
        dock(ControllerConfig::default(), STARTS_M[0]),
        dock(ControllerConfig::default(), STARTS_M[0]),
    );
    assert_eq!(a.samples.len(), b.samples.len());
    assert!(
        a.samples.iter().zip(&b.samples).all(|(x, y)| x == y),
        "runs differ"
    );
    assert_eq!(a.summary, b.summary);
}
