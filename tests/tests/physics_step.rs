//! The refuelling presets' physics step (one 0.02 s step per control period) against finer
//! ones: the air is the same at 0.02 s as at the `paper-*` presets' 0.01 s (the gusts are
//! sampled at 0.01 s either way), and in calm air the same sorties fly as at 0.005 s (below
//! 0.01 s the gusts' samples follow the step, so the comparison with 0.005 s is made without
//! them: `docs/models.md`, "Physics step").

use closed_loop_tests::STARTS_M;
use host_sim::scenario::ScenarioFile;
use host_sim::sim::{self, Run};
use host_sim::world::turbulence::TurbulencePreset;
use ibvs_core::Controller;
use nalgebra::Vector3;
use rayon::prelude::*;

/// Largest accepted difference of the miss at the drogue plane between the two steps, m: a
/// thirtieth of the 0.3 m capture radius (measured over 300 `level2` sorties in calm air: at
/// most 1.1 mm from 0.005 s at 0.02 s, 1.9 mm at 0.01 s; `docs/models.md`).
const MAX_MISS_DIFFERENCE_M: f64 = 0.01;

/// `level2` (the wake, the hose, the LED camera, INS errors) in calm air, from `start`, with
/// `seed` and `plant_substeps` physics steps per control period.
fn fly(start: [f64; 3], seed: u64, plant_substeps: u32) -> Run {
    let mut f = ScenarioFile::load("level2").expect("preset");
    f.turbulence.preset = TurbulencePreset::None;
    f.turbulence.sigma_mps = None;
    f.initial.drogue_minus_probe_m = start;
    f.seed = seed;
    f.plant_substeps = plant_substeps;
    f.validate().expect("valid scenario");
    sim::run(
        &f.scenario(),
        &mut Controller::new(f.controller_config()).expect("config"),
    )
    .expect("runs")
}

#[test]
fn the_presets_physics_step_flies_the_sorties_of_a_fine_step() {
    assert_eq!(
        ScenarioFile::load("level2").expect("preset").plant_substeps,
        1
    );
    let failures: Vec<String> = STARTS_M[..6]
        .par_iter()
        .enumerate()
        .filter_map(|(i, &start)| {
            let seed = i as u64 + 1;
            let (coarse, fine) = (fly(start, seed, 1), fly(start, seed, 4));
            let (c, f) = (&coarse.summary, &fine.summary);
            println!(
                "{start:?}: {:?} and {:?}, miss {:?} and {:?} m, at {:.2} and {:.2} s",
                c.outcome, f.outcome, c.miss_m, f.miss_m, c.time_s, f.time_s
            );
            let same = c.outcome == f.outcome
                && c.attempts == f.attempts
                && match (c.miss_m, f.miss_m) {
                    (Some(a), Some(b)) => (a - b).abs() < MAX_MISS_DIFFERENCE_M,
                    _ => false,
                };
            (!same).then(|| format!("{start:?} seed {seed}: 0.02 s {c:?}\n  0.005 s {f:?}"))
        })
        .collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The air (gusts and wake) at three tanker-frame points along the approach, at every control
/// step of a `level2` sortie flown with `plant_substeps` physics steps per control period.
fn air_of_a_sortie(plant_substeps: u32) -> Vec<[Vector3<f64>; 3]> {
    let mut f = ScenarioFile::load("level2").expect("preset");
    f.plant_substeps = plant_substeps;
    let points = [
        Vector3::new(-14.0, 0.0, 5.0),
        Vector3::new(-20.0, -1.0, 6.0),
        Vector3::new(-25.0, 2.0, 4.0),
    ];
    let mut air = Vec::new();
    sim::run_observed(
        &f.scenario(),
        &mut Controller::new(f.controller_config()).expect("config"),
        &[],
        &mut |world, _| air.push(points.map(|p| world.disturbance_tanker_mps(&p))),
    )
    .expect("runs");
    air
}

#[test]
fn the_presets_physics_step_flies_the_air_of_the_paper_presets_step() {
    let (coarse, fine) = (air_of_a_sortie(1), air_of_a_sortie(2));
    let steps = coarse.len().min(fine.len());
    assert!(steps > 500, "{steps} control steps");
    let gusty = coarse[..steps]
        .iter()
        .zip(&coarse[1..steps])
        .filter(|(a, b)| a != b)
        .count();
    assert!(
        gusty > steps / 2,
        "the air changes: {gusty} of {steps} steps"
    );
    for (k, (a, b)) in coarse[..steps].iter().zip(&fine[..steps]).enumerate() {
        assert_eq!(a, b, "control step {k}");
    }
}
