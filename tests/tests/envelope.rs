//! Docking across the docking envelope: the refuelling procedure, as the default scenario
//! flies it (hose and drogue in the tanker's wake, LED camera set back on the nose, INS with
//! its errors, calm air), at flight conditions that are neither nodes of the gain schedule
//! nor the centres of its cells, one in each corner cell, one either side of the middle.

use closed_loop_tests::summary_failure;
use host_sim::scenario::ScenarioFile;
use host_sim::sim;
use ibvs_core::Controller;

/// `(true airspeed m/s, altitude m)`: the slow and fast ends at low and high altitude (the
/// corner cells; at the slow, high one, just above the design mass's slow edge, 114 m/s at
/// 7,700 m), and two points off the cells' centres inside.
const OFF_GRID: [(f64, f64); 6] = [
    (103.0, 700.0),
    (168.0, 600.0),
    (117.0, 7700.0),
    (165.0, 7800.0),
    (131.0, 2200.0),
    (152.0, 6400.0),
];

#[test]
fn the_refuelling_procedure_docks_in_calm_air_off_the_gain_schedules_grid_within_0_1_m() {
    // Measured (before the slow edge, with the slow, high point at 104 m/s): misses
    // 0.008..0.050 m, the largest at 104 m/s, 7,700 m (trimmed at 15 degrees with the camera
    // mounted for 6).
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

/// Below the slow edge of the docking envelope (the receiver's level-flight angle of attack
/// leaves less than a 1.5 g pull to 20 degrees): the design's airframe at 104 m/s and 7,700 m
/// (14.9 degrees), and an airframe 1.25 times as heavy, configured so, at 125 m/s (13.9
/// degrees), where the design's mass engages. The controller never engages and names the
/// limit; the same heavy airframe 15 m/s faster docks, and the referee finds no hazard. (A
/// receiver never engaged is held at the design's trim open loop, as the simulator has no
/// pilot: the design's airframe holds it without a hazard; the heavy one, trimmed for
/// another mass, sinks into its angle-of-attack limit, which says nothing of the controller.)
#[test]
fn below_the_slow_edge_of_its_gross_mass_a_receiver_is_never_engaged() {
    let fly = |v: f64, mass: f64| {
        let text = format!(
            "name = \"slow-edge\"\nduration_s = 30.0\n[flight]\nairspeed_mps = {v}\n\
             altitude_m = 7700.0\n[receiver]\nmass_scale = {mass}\n"
        );
        let file = ScenarioFile::parse(&text, "slow-edge").expect("scenario");
        let cfg = file.controller_config();
        assert_eq!(
            f64::from(cfg.mass_factor),
            mass,
            "the reported mass is configured"
        );
        let mut c = Controller::new(cfg).expect("valid configuration");
        let run = sim::run(&file.scenario(), &mut c).expect("scenario runs");
        (run, c)
    };
    for (v, mass) in [(104.0, 1.0), (125.0, 1.25)] {
        let (run, c) = fly(v, mass);
        let n = c.counters();
        assert_eq!(
            run.summary.attempts, 0,
            "{v} m/s, mass {mass}: {:?}",
            run.summary
        );
        assert!(
            n.engage_refused > 100 && n.outside_docking_envelope == n.steps,
            "{v} m/s, mass {mass}: {n:?}"
        );
        assert!(!run.verdict.docked(), "{v} m/s, mass {mass}");
        if mass == 1.0 {
            assert!(run.verdict.hazards.is_empty(), "{:?}", run.verdict);
        }
    }
    let (run, _) = fly(140.0, 1.25);
    assert!(run.verdict.docked(), "{:?}", run.summary);
    assert!(run.verdict.hazards.is_empty(), "{:?}", run.verdict.hazards);
}
