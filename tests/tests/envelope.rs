//! Docking across the docking envelope: the refuelling procedure, as the default scenario
//! flies it (hose and drogue in the tanker's wake, LED camera set back on the nose, INS with
//! its errors, calm air), at flight conditions that are neither nodes of the gain schedule
//! nor the centres of its cells, one in each corner cell, one either side of the middle.

use closed_loop_tests::summary_failure;
use host_sim::scenario::ScenarioFile;
use host_sim::sim;
use ibvs_core::Controller;

/// `(true airspeed m/s, altitude m)`: the slow and fast ends at low and high altitude (the
/// corner cells), and two points off the cells' centres inside.
const OFF_GRID: [(f64, f64); 6] = [
    (103.0, 700.0),
    (168.0, 600.0),
    (104.0, 7700.0),
    (165.0, 7800.0),
    (131.0, 2200.0),
    (152.0, 6400.0),
];

#[test]
fn the_refuelling_procedure_docks_in_calm_air_off_the_gain_schedules_grid_within_0_1_m() {
    // Measured: misses 0.008..0.050 m, the largest at 104 m/s, 7,700 m (the slow, high
    // corner, trimmed at 15 degrees with the camera mounted for 6).
    let mut failures = Vec::new();
    for (v, h) in OFF_GRID {
        let text = format!("name = \"off-grid\"\n[flight]\nairspeed_mps = {v}\naltitude_m = {h}\n");
        let file = ScenarioFile::parse(&text, "off-grid").expect("scenario");
        let mut c = Controller::new(file.controller_config()).expect("valid configuration");
        let run = sim::run(&file.scenario(), &mut c).expect("scenario runs");
        if let Some(why) = summary_failure(&run.summary) {
            failures.push(format!("{v} m/s, {h} m: {why}"));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}
