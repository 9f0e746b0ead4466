//! IBVS and PBVS fly the nonlinear F-16 into the drogue in calm air (the calm-air acceptance runs).

use hil_tests::{STARTS_M, dock, docking_failure};
use ibvs_core::{ControllerConfig, OuterLaw};
use rayon::prelude::*;

#[test]
fn ibvs_docks_from_the_paper_start_and_ten_others() {
    let failures: Vec<String> = STARTS_M
        .par_iter()
        .filter_map(|&start| {
            docking_failure(&dock(ControllerConfig::default(), start))
                .map(|f| format!("{start:?}: {f}"))
        })
        .collect();
    assert!(
        failures.is_empty(),
        "runs that did not dock within the criteria:\n{}",
        failures.join("\n")
    );
}

#[test]
fn pbvs_docks_from_the_paper_start_with_a_correct_camera_position() {
    let cfg = ControllerConfig {
        law: OuterLaw::Pbvs,
        ..ControllerConfig::default()
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
