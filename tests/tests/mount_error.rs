//! The set-back camera aims with the image, not with its mount: the refuelling procedure docks
//! at the first attempt although the camera is not where the controller believes it is.
//!
//! The controller takes the drogue's offset from the probe tip with the tip's *measured* image
//! point (endpoint aiming, `docs/conventions.md`, "Endpoint aiming"), so a mount error moves
//! the tip and the drogue alike in the image and leaves the offset. Flown here: the camera
//! 0.5 m off along each axis and 2° off about each axis, one at a time, and the paper's
//! [1, 0, -0.5] m, against the same scenario and seed without an error.
//!
//! Calm air is deterministic: every case within [`MISS_MARGIN_M`] of the error-free run.
//! Level II turbulence makes a single run's miss a random draw (a few cm either way): there
//! the mean over [`LEVEL2_SEEDS`] is compared. Not asserted, and why: the paper's case in
//! level II, whose 1 m error along the boresight puts the tip's range, and so the depth to
//! the drogue plane, wrong by 1 m, which a point marker cannot measure (over seeds 1..8 its
//! mean miss is 0.061 m above the error-free one; the metre ahead alone 0.049 m above,
//! `docs/conventions.md`, "Endpoint aiming").

use host_sim::scenario::ScenarioFile;
use host_sim::sim::{self, Outcome, Run, Summary};
use ibvs_core::estimator::TipGeometry;
use ibvs_core::{Controller, ControllerConfig};
use rayon::prelude::*;

/// The requirement: a miss at most this much above the error-free run's, m.
const MISS_MARGIN_M: f64 = 0.05;

/// Seeds of the level II comparison.
const LEVEL2_SEEDS: [u64; 4] = [1, 2, 3, 4];

/// A camera installation error: position (forward, right, down, m) and attitude (pitch,
/// roll, yaw, deg).
#[derive(Debug, Clone, Copy, Default)]
struct MountError {
    position_m: [f64; 3],
    attitude_deg: [f64; 3],
}

/// Position errors of 0.5 m along each axis and attitude errors of 2° about each, both
/// signs, one at a time.
fn one_at_a_time() -> Vec<MountError> {
    let mut v = Vec::new();
    for axis in 0..3 {
        for sign in [-1.0, 1.0] {
            let mut e = MountError::default();
            e.position_m[axis] = 0.5 * sign;
            v.push(e);
            let mut e = MountError::default();
            e.attitude_deg[axis] = 2.0 * sign;
            v.push(e);
        }
    }
    v
}

const PAPER_CASE: MountError = MountError {
    position_m: [1.0, 0.0, -0.5],
    attitude_deg: [0.0; 3],
};

fn fly(preset: &str, seed: u64, e: MountError) -> Summary {
    fly_run(preset, seed, e).0.summary
}

/// The run, and the controller's configuration.
fn fly_run(preset: &str, seed: u64, e: MountError) -> (Run, ControllerConfig) {
    let mut f = ScenarioFile::load(preset).expect("preset");
    f.seed = seed;
    f.camera.mount_error_m = e.position_m;
    let [pitch, roll, yaw] = e.attitude_deg;
    f.camera.mount_pitch_error_deg = pitch;
    f.camera.mount_roll_error_deg = roll;
    f.camera.mount_yaw_error_deg = yaw;
    f.validate().expect("valid scenario");
    let cfg = f.controller_config();
    let mut c = Controller::new(cfg).expect("valid config");
    (sim::run(&f.scenario(), &mut c).expect("run"), cfg)
}

/// Docked at the first attempt: its miss; otherwise why not.
fn first_attempt_miss(s: &Summary) -> Result<f64, String> {
    match (s.outcome, s.attempts, s.miss_m) {
        (Outcome::Docked, 1, Some(m)) => Ok(m),
        _ => Err(format!("{s:?}")),
    }
}

#[test]
fn in_calm_air_a_mount_error_costs_at_most_five_centimetres_of_miss() {
    let reference = first_attempt_miss(&fly("calm", 1, MountError::default())).expect("docks");
    let mut cases = one_at_a_time();
    cases.push(PAPER_CASE);
    let failures: Vec<String> = cases
        .par_iter()
        .filter_map(|&e| match first_attempt_miss(&fly("calm", 1, e)) {
            Ok(m) if m <= reference + MISS_MARGIN_M => None,
            Ok(m) => Some(format!("{e:?}: miss {m:.3} m, error-free {reference:.3} m")),
            Err(s) => Some(format!("{e:?}: {s}")),
        })
        .collect();
    assert!(failures.is_empty(), "\n{}", failures.join("\n"));
}

#[test]
fn in_level_two_air_a_mount_error_costs_at_most_five_centimetres_of_mean_miss() {
    let mean = |e: MountError| -> Result<f64, String> {
        let misses: Result<Vec<f64>, String> = LEVEL2_SEEDS
            .par_iter()
            .map(|&seed| first_attempt_miss(&fly("level2", seed, e)))
            .collect();
        let m = misses?;
        Ok(m.iter().sum::<f64>() / m.len() as f64)
    };
    let reference = mean(MountError::default()).expect("docks");
    let failures: Vec<String> = one_at_a_time()
        .par_iter()
        .filter_map(|&e| match mean(e) {
            Ok(m) if m <= reference + MISS_MARGIN_M => None,
            Ok(m) => Some(format!(
                "{e:?}: mean miss {m:.3} m, error-free {reference:.3} m"
            )),
            Err(s) => Some(format!("{e:?}: {s}")),
        })
        .collect();
    assert!(failures.is_empty(), "\n{}", failures.join("\n"));
}

#[test]
fn the_run_logs_the_calibration_learned_and_it_is_the_mount_error_seen_from_the_camera() {
    // The camera 0.3 m right of where it is believed: the tip appears 0.3 m left at its
    // 2.67 m along the boresight, 0.11 in normalised units; nothing moves it vertically.
    let e = MountError {
        position_m: [0.0, 0.3, 0.0],
        ..MountError::default()
    };
    let (run, cfg) = fly_run("calm", 1, e);
    let g = TipGeometry::new(&cfg.camera, cfg.probe_tip_body_m, cfg.camera.pitch_down_rad);
    let (believed, tz) = (g.tip_image(), g.tip_from_camera_m()[2]);
    let first = run.samples.first().and_then(|s| s.probe_tip_image);
    assert_eq!(
        first,
        Some(believed),
        "the geometry's point before any sighting"
    );
    let learned = run
        .samples
        .last()
        .and_then(|s| s.probe_tip_image)
        .expect("logged");
    let shift = [learned[0] - believed[0], learned[1] - believed[1]];
    let want = -0.3 / tz;
    assert!(
        (shift[0] - want).abs() < 0.1 * want.abs() && shift[1].abs() < 0.01,
        "learned {learned:?}, believed {believed:?}: shift {shift:?}, want x {want}"
    );
}
