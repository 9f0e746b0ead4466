//! Closed-loop, hardware-in-the-loop-style tests: the controller flies the simulated receiver.
//!
//! The tests live in `tests/tests/`; this library holds what they share: the start points
//! and the acceptance criteria of a docking, stated once.
//!
//! Invariant: every helper here only runs the simulator; none relaxes a criterion.

use host_sim::docking::CLOSING_BAND_MPS;
use host_sim::sim::{self, Outcome, Run, Scenario};
use ibvs_core::{Controller, ControllerConfig};
use nalgebra::Vector3;

/// Largest accepted radial miss at the drogue plane for these tests, m (issue 2: 0.1 m, well
/// inside the 0.3 m capture radius).
pub const MAX_MISS_M: f64 = 0.1;

/// Start points (drogue centre minus probe tip, tanker axes: forward, right, down), m:
/// the paper's, then others covering 4..10 m behind and +/-2 m lateral and vertical. At 4 m a
/// 2 m vertical offset is outside the camera's vertical field of view (+/-0.48 in normalised
/// units, i.e. 1.92 m at 4 m), so the 4 m starts use 1.5 m.
pub const STARTS_M: [[f64; 3]; 11] = [
    sim::PAPER_START_M,
    [4.0, 1.5, 1.5],
    [4.0, -2.0, -1.5],
    [5.0, -2.0, 2.0],
    [6.0, -1.0, 1.0],
    [7.0, 0.0, 0.0],
    [8.0, 2.0, -2.0],
    [10.0, 2.0, 2.0],
    [10.0, -2.0, -2.0],
    [10.0, 0.0, 2.0],
    [10.0, 2.0, 0.0],
];

/// Runs one calm-air docking with `cfg` from `start`.
pub fn dock(cfg: ControllerConfig, start: [f64; 3]) -> Run {
    let scenario = Scenario {
        start_offset_m: Vector3::from(start),
        ..Scenario::ideal()
    };
    let mut c = Controller::new(cfg).expect("valid config");
    sim::run(&scenario, &mut c).expect("scenario runs")
}

/// Why a run does not meet the docking criteria, or `None` when it does.
pub fn docking_failure(run: &Run) -> Option<String> {
    let s = &run.summary;
    let (miss, closure) = (s.miss_m?, s.closure_mps?);
    let ok = s.outcome == Outcome::Docked
        && miss < MAX_MISS_M
        && (CLOSING_BAND_MPS.0..=CLOSING_BAND_MPS.1).contains(&closure);
    (!ok).then(|| format!("{s:?}"))
}
