//! The receiver's plant dispersions in a run (`host_sim::receiver::ReceiverPlant`, the
//! scenario file's `[receiver]` factors and `[dispersion.receiver]` ranges): the dispersed
//! aircraft trims over the refuelling presets' ranges at the refuelling condition and at the
//! docking envelope's corners, and a run trims and flies the true aircraft while its design
//! side (the navigation's reference trim) stays the nominal aircraft's.

use host_sim::receiver::{F16, FACTORS, ReceiverPlant, ReceiverPlantRanges};
use host_sim::scenario::{RECEIVER_PLANT_DISPERSION, ScenarioFile};
use host_sim::sim::{FlightComputer, Scenario, run};
use host_sim::synthesis::NOMINAL_XCG;
use ibvs_core::controller::{ControllerInput, ControllerOutput};

/// The refuelling presets' plant ranges.
fn refuelling_ranges() -> ReceiverPlantRanges {
    ScenarioFile::parse(RECEIVER_PLANT_DISPERSION, "plant")
        .expect("the fragment parses")
        .dispersion
        .receiver
}

/// The factors that move the straight-and-level trim: with no rates, no sideslip and the
/// lateral controls at zero, only the elevator's effectiveness, the pitching moment's
/// α-dependence and the mass enter it (the others multiply terms that are zero there, or
/// act on dynamics only; `the_other_factors_leave_the_trim` checks it).
const TRIM_FACTORS: [&str; 3] = ["elevator_effectiveness", "cm_alpha_scale", "mass_scale"];

/// The refuelling condition and the docking envelope's corners (true airspeed m/s, m).
const CONDITIONS: [(f64, f64); 5] = [
    (120.0, 3000.0),
    (100.0, 500.0),
    (100.0, 8000.0),
    (170.0, 500.0),
    (170.0, 8000.0),
];

/// The refuelling presets' cg range (`xcg = [0.30, 0.40]`).
const XCG_CORNERS: [f64; 2] = [0.30, 0.40];

/// The plant with every trim factor at the corner `bits` selects (bit j: factor j at its
/// maximum) and every other factor at its minimum (`others_high` false) or maximum.
fn corner(ranges: &ReceiverPlantRanges, bits: usize, others_high: bool) -> ReceiverPlant {
    let mut plant = ReceiverPlant::NOMINAL;
    for ((info, r), factor) in FACTORS.iter().zip(ranges.values()).zip(plant.values_mut()) {
        let [lo, hi] = r.expect("every factor dispersed");
        let high = match TRIM_FACTORS.iter().position(|&n| n == info.name) {
            Some(j) => bits & (1 << j) != 0,
            None => others_high,
        };
        *factor = if high { hi } else { lo };
    }
    plant
}

#[test]
fn the_dispersed_receiver_trims_at_every_corner_of_the_refuelling_ranges() {
    let ranges = refuelling_ranges();
    let mut trims = 0;
    for bits in 0..1 << TRIM_FACTORS.len() {
        for others_high in [false, true] {
            let plant = corner(&ranges, bits, others_high);
            for xcg in XCG_CORNERS {
                let model = F16::with_plant(xcg, &plant).expect("valid plant");
                for (speed, altitude) in CONDITIONS {
                    let trim = model
                        .trim_straight_level(speed, altitude)
                        .unwrap_or_else(|e| {
                            panic!(
                                "no trim at {speed} m/s, {altitude} m, xcg {xcg}, {plant:?}: {e}"
                            )
                        });
                    // With a fifth of the elevator's travel left for control. (The throttle
                    // has no such margin at the slow, high corner: the heaviest aircraft
                    // trims at 100 m/s, 8,000 m at α 22 deg and throttle 0.90, in
                    // afterburner; the trim checks only that it is inside its range.)
                    let limit_rad = model.actuators().elevator.position_limit_rad;
                    assert!(
                        trim.elevator_rad.abs() < 0.8 * limit_rad,
                        "elevator {} deg at {speed} m/s, {altitude} m",
                        trim.elevator_rad.to_degrees()
                    );
                    trims += 1;
                }
            }
        }
    }
    assert_eq!(trims, 8 * 2 * 2 * 5);
}

#[test]
fn the_other_factors_leave_the_trim() {
    let ranges = refuelling_ranges();
    let nominal = F16::new(NOMINAL_XCG)
        .expect("model")
        .trim_straight_level(120.0, 3000.0)
        .expect("trim");
    for others_high in [false, true] {
        // The trim factors nominal: their bits select the maximum, so set them back.
        let mut plant = corner(&ranges, 0, others_high);
        plant.elevator_effectiveness = 1.0;
        plant.cm_alpha_scale = 1.0;
        plant.mass_scale = 1.0;
        assert!(!plant.is_nominal());
        let trim = F16::with_plant(NOMINAL_XCG, &plant)
            .expect("valid plant")
            .trim_straight_level(120.0, 3000.0)
            .expect("trim");
        for (got, want) in [
            (trim.alpha_rad, nominal.alpha_rad),
            (trim.elevator_rad, nominal.elevator_rad),
            (trim.throttle, nominal.throttle),
        ] {
            assert!((got - want).abs() < 1e-9, "{got} vs {want}");
        }
    }
    // And the trim factors do move it: heavier needs more lift, so more α.
    let mut heavy = ReceiverPlant::NOMINAL;
    heavy.mass_scale = 1.25;
    let trim = F16::with_plant(NOMINAL_XCG, &heavy)
        .expect("valid plant")
        .trim_straight_level(120.0, 3000.0)
        .expect("trim");
    assert!(
        trim.alpha_rad > nominal.alpha_rad + 0.01,
        "{}",
        trim.alpha_rad
    );
}

/// Records what the flight computer was given and commands nothing.
#[derive(Default)]
struct Recorder(Vec<ControllerInput>);

impl FlightComputer for Recorder {
    fn step(&mut self, input: &ControllerInput) -> ControllerOutput {
        self.0.push(*input);
        ControllerOutput::default()
    }

    fn autopilot_design(&self) -> Option<ibvs_core::attitude::AttitudeLoopConfig> {
        None
    }
}

/// The run starts from the true aircraft's trim and the navigation reports perturbations from
/// the nominal aircraft's: a heavier receiver flies at a higher α, which the controller sees;
/// the nominal one starts at zero perturbation.
#[test]
fn a_run_trims_the_true_aircraft_and_keeps_the_nominal_design() {
    let first_alpha = |plant: ReceiverPlant| {
        let s = Scenario {
            receiver_plant: plant,
            duration_s: 0.04,
            ..Scenario::ideal()
        };
        let mut fc = Recorder::default();
        let r = run(&s, &mut fc).expect("runs");
        let own_trim = F16::with_plant(s.xcg, &plant)
            .expect("model")
            .trim_straight_level(s.tanker.speed_mps, s.tanker.altitude_m)
            .expect("trim");
        assert_eq!(
            r.trim.alpha_rad, own_trim.alpha_rad,
            "the true aircraft's trim"
        );
        (fc.0[0].nav.lon.alpha_rad, own_trim.alpha_rad)
    };
    let (nominal_alpha, nominal_trim) = first_alpha(ReceiverPlant::NOMINAL);
    assert_eq!(nominal_alpha, 0.0);
    let mut heavy = ReceiverPlant::NOMINAL;
    heavy.mass_scale = 1.2;
    let (heavy_alpha, heavy_trim) = first_alpha(heavy);
    let expected = (heavy_trim - nominal_trim) as f32;
    assert!(expected > 0.01, "{expected}");
    assert!(
        (heavy_alpha - expected).abs() < 1e-5,
        "{heavy_alpha} vs {expected}"
    );
}
