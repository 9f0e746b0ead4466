//! The flight condition as a scenario setting (`[flight]`, `host_sim::world::flight`): the
//! table parses and reaches the run, disperses from the campaign's seed, is refused outside
//! the models' validity with named errors, and at 150 m/s and 6,000 m the receiver trims,
//! the tanker flies at 150 m/s and the hose flies in the atmosphere's air there.
//!
//! Nothing here expects a docking away from the default condition: the controller keeps its
//! 120 m/s design until the gains are scheduled.

use host_sim::montecarlo::RunInputs;
use host_sim::receiver::{F16, Wind};
use host_sim::scenario::{ScenarioError, ScenarioFile};
use host_sim::sim::{Scenario, SimError, build_world, run, run_observed};
use host_sim::synthesis::NOMINAL_XCG;
use host_sim::world::flight::{FlightCondition, FlightConditionError};
use host_sim::world::{Drogue, World};
use ibvs_core::Controller;

const AT_150_6000: &str = "[flight]\nairspeed_mps = 150.0\naltitude_m = 6000.0\n";

fn model() -> F16 {
    F16::new(NOMINAL_XCG).expect("model")
}

fn parse(text: &str) -> Result<ScenarioFile, ScenarioError> {
    ScenarioFile::parse(text, "test")
}

/// The world of `s` as a run builds it (nominal cg, trimmed at its condition).
fn world(s: &Scenario) -> World {
    let m = model();
    let trim = m
        .trim_straight_level(s.tanker.speed_mps, s.tanker.altitude_m)
        .expect("trim");
    build_world(s, &m, &trim, 0.01).expect("world")
}

#[test]
fn a_flight_table_parses_and_reaches_the_scenario() {
    let d = parse("").unwrap();
    assert_eq!(d.flight.condition(), FlightCondition::DEFAULT);
    assert_eq!(
        (
            d.scenario().tanker.speed_mps,
            d.scenario().tanker.altitude_m
        ),
        (120.0, 3000.0)
    );
    let f = parse(AT_150_6000).unwrap();
    assert_eq!(
        (f.flight.airspeed_mps, f.flight.altitude_m),
        (150.0, 6000.0)
    );
    let s = f.scenario();
    assert_eq!((s.tanker.speed_mps, s.tanker.altitude_m), (150.0, 6000.0));
    assert_eq!(s.flight(), f.flight.condition());
    // Written out and read back.
    let back = parse(&f.to_toml()).unwrap();
    assert_eq!(back, f);
    assert!(f.to_toml().contains("[flight]"));
    // Unknown keys refused as everywhere.
    let e = parse("[flight]\nairspeed = 150.0\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("airspeed"), "{e}");
    let e = parse("[dispersion]\naltitude = [3000.0, 4000.0]\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("altitude"), "{e}");
}

#[test]
fn the_flight_condition_disperses_from_the_seed_each_value_in_its_own_stream() {
    let text = "[dispersion]\nairspeed_mps = [110.0, 160.0]\naltitude_m = [2000.0, 8000.0]\n";
    let base = parse(text).unwrap();
    let mut speeds = std::collections::BTreeSet::new();
    for i in 0..100 {
        let f = base.dispersed(i);
        assert_eq!(f, base.dispersed(i), "same seed and index, same draw");
        f.validate().unwrap();
        let (v, h) = (f.flight.airspeed_mps, f.flight.altitude_m);
        assert!((110.0..=160.0).contains(&v), "{v}");
        assert!((2000.0..=8000.0).contains(&h), "{h}");
        assert_eq!(f.scenario().flight(), f.flight.condition());
        let inputs = RunInputs::of(&f);
        assert_eq!((inputs.airspeed_mps, inputs.altitude_m), (v, h), "recorded");
        speeds.insert(v.to_bits());
    }
    assert_eq!(speeds.len(), 100, "a draw per run");
    // Another campaign seed, other draws.
    let mut other = base.clone();
    other.seed = 2;
    assert_ne!(
        other.dispersed(0).flight.airspeed_mps,
        base.dispersed(0).flight.airspeed_mps
    );
    // Own streams: the altitude's draws do not depend on the airspeed's key, and adding the
    // flight keys leaves every other draw (here the seed) as it was.
    let only_altitude = parse("[dispersion]\naltitude_m = [2000.0, 8000.0]\n").unwrap();
    let none = parse("").unwrap();
    for i in [0, 3, 77] {
        let (a, b) = (base.dispersed(i), only_altitude.dispersed(i));
        assert_eq!(a.flight.altitude_m, b.flight.altitude_m);
        assert_eq!(b.flight.airspeed_mps, 120.0, "not dispersed: the file's");
        assert_eq!(a.seed, none.dispersed(i).seed);
    }
    // The JSON record names them.
    let json = serde_json::to_string(&RunInputs::of(&base.dispersed(5))).unwrap();
    assert!(
        json.contains("\"airspeed_mps\"") && json.contains("\"altitude_m\""),
        "{json}"
    );
}

#[test]
fn conditions_outside_validity_are_refused_with_named_errors() {
    let a = model().air_at(3000.0).speed_of_sound_mps;
    // Mach 0.6 is the limit: just under flies, just over is refused, naming key and limit.
    let at = |v: f64| parse(&format!("[flight]\nairspeed_mps = {v}\n"));
    assert!(at(0.6 * a - 0.01).is_ok());
    let e = at(0.6 * a + 0.01).unwrap_err();
    assert!(
        matches!(
            e,
            ScenarioError::Flight(FlightConditionError::MachAboveLimit { .. })
        ),
        "{e}"
    );
    let msg = e.to_string();
    assert!(
        msg.contains("flight.airspeed_mps") && msg.contains("Mach 0.6"),
        "{msg}"
    );
    // Higher up the speed of sound is lower: 190 m/s is Mach 0.58 at 3000 m, 0.64 at 12 km.
    assert!(parse("[flight]\nairspeed_mps = 190.0\naltitude_m = 3000.0\n").is_ok());
    assert!(parse("[flight]\nairspeed_mps = 190.0\naltitude_m = 12000.0\n").is_err());
    // The docking envelope's floor, 500 m, is above the turbulence model's (1,000 ft).
    assert!(parse("[flight]\nairspeed_mps = 100.0\naltitude_m = 500.0\n").is_ok());
    // Non-finite, non-positive, outside the altitude range.
    for (text, key) in [
        ("[flight]\nairspeed_mps = 0.0\n", "flight.airspeed_mps"),
        ("[flight]\nairspeed_mps = -120.0\n", "flight.airspeed_mps"),
        ("[flight]\nairspeed_mps = nan\n", "flight.airspeed_mps"),
        ("[flight]\naltitude_m = inf\n", "flight.altitude_m"),
        ("[flight]\naltitude_m = -5.0\n", "flight.altitude_m"),
        ("[flight]\naltitude_m = 300.0\n", "flight.altitude_m"),
        ("[flight]\naltitude_m = 16000.0\n", "flight.altitude_m"),
        (
            "[dispersion]\naltitude_m = [3000.0, 20000.0]\n",
            "dispersion.altitude_m",
        ),
        (
            "[dispersion]\nairspeed_mps = [150.0, 200.0]\n",
            "dispersion.airspeed_mps",
        ),
        (
            "[dispersion]\nairspeed_mps = [160.0, 150.0]\n",
            "dispersion.airspeed_mps",
        ),
    ] {
        let e = parse(text).unwrap_err();
        assert!(
            matches!(
                e,
                ScenarioError::Flight(_) | ScenarioError::EmptyRange { .. }
            ),
            "{text}: {e}"
        );
        assert!(e.to_string().contains(key), "{text}: {e}");
    }
    // A scenario built in code is checked by the run too.
    let mut s = Scenario::ideal();
    s.tanker.speed_mps = 250.0;
    let mut c = Controller::new(Default::default()).unwrap();
    let e = run(&s, &mut c).unwrap_err();
    assert!(
        matches!(
            e,
            SimError::Flight(FlightConditionError::MachAboveLimit { .. })
        ),
        "{e}"
    );
    // A valid condition without a trim inside the limits: the error names the condition.
    let f = parse("[flight]\nairspeed_mps = 90.0\naltitude_m = 15000.0\n").unwrap();
    let mut c = Controller::new(f.controller_config()).unwrap();
    let e = run(&f.scenario(), &mut c).unwrap_err();
    assert!(matches!(e, SimError::Trim { .. }), "{e}");
    let msg = e.to_string();
    assert!(msg.contains("90 m/s") && msg.contains("15000 m"), "{msg}");
}

#[test]
fn turbulence_by_probability_of_exceedance_follows_the_altitude() {
    use host_sim::world::turbulence::mil_f_8785c_sigma_mps;
    let at = |h: f64| {
        parse(&format!(
            "[flight]\naltitude_m = {h}\n[turbulence]\nexceedance_probability = 1e-2\n"
        ))
        .unwrap()
        .sigma_mps()
    };
    for h in [3000.0, 6000.0, 10_000.0] {
        assert_eq!(at(h), mil_f_8785c_sigma_mps(h, 1e-2).unwrap(), "{h}");
    }
    assert!(
        at(6000.0) < at(3000.0),
        "light turbulence thins with altitude"
    );
    // `sigma_mps` (and so a dispersed intensity) wins; a probability not in the table is
    // refused, naming the key.
    let both = parse("[turbulence]\nexceedance_probability = 1e-2\nsigma_mps = 0.5\n").unwrap();
    assert_eq!(both.sigma_mps(), 0.5);
    let e = parse("[turbulence]\nexceedance_probability = 0.05\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("turbulence.exceedance_probability"), "{e}");
    // The `moderate` preset (the 1e-2 intensity read at 3000 m as 1.8 m/s) follows the table.
    let moderate = |h: f64| {
        parse(&format!(
            "[flight]\naltitude_m = {h}\n[turbulence]\npreset = \"moderate\"\n"
        ))
        .unwrap()
        .sigma_mps()
    };
    assert_eq!(moderate(3000.0), 1.8);
    assert!((moderate(6000.0) - 1.8 * at(6000.0) / at(3000.0)).abs() < 1e-12);
}

#[test]
fn at_150_mps_and_6000_m_the_world_flies_there() {
    let m = model();
    let default_trim = m.trim_straight_level(120.0, 3000.0).unwrap();
    let trim = m.trim_straight_level(150.0, 6000.0).unwrap();
    println!(
        "trim at 150 m/s, 6000 m: alpha = theta = {:.4} deg, throttle {:.4}, elevator {:.4} deg \
         (at 120 m/s, 3000 m: {:.4} deg, {:.4})",
        trim.alpha_rad.to_degrees(),
        trim.throttle,
        trim.elevator_rad.to_degrees(),
        default_trim.alpha_rad.to_degrees(),
        default_trim.throttle,
    );
    let air = m.air_data(&trim.state, &Wind::default());
    assert!((air.airspeed_mps - 150.0).abs() < 1e-9);
    assert_eq!(air.density_kg_m3, m.air_at(6000.0).density_kg_m3);
    // Higher dynamic pressure (0.661 kg/m^3 at 150 m/s against 0.910 at 120): less alpha.
    assert!(trim.alpha_rad < default_trim.alpha_rad - 0.005);
    assert_eq!(trim.theta_rad, trim.alpha_rad);

    let f = parse(AT_150_6000).unwrap();
    let s = f.scenario();
    let mut c = Controller::new(f.controller_config()).unwrap();
    let short = Scenario {
        duration_s: 1.0,
        ..s.clone()
    };
    let mut seen: Option<(f64, f64, f64, f64)> = None;
    let r = run_observed(&short, &mut c, &[], &mut |w, _| {
        if let (Drogue::Hose(h), Some(wake), None) = (&w.drogue, &w.wake, seen) {
            seen = Some((
                w.tanker.speed_mps,
                h.params().air_density_kg_per_m3,
                wake.params().air_density_kgpm3,
                wake.params().airspeed_mps,
            ));
        }
    })
    .unwrap();
    assert_eq!(r.trim, trim, "the run trims at the scenario's condition");
    assert_eq!(r.summary.airspeed_mps, 150.0);
    assert_eq!(r.summary.altitude_m, 6000.0);
    let (tanker_speed, hose_rho, wake_rho, wake_v) = seen.expect("hose and wake");
    let rho = m.air_at(6000.0).density_kg_m3;
    println!("air density at 6000 m (the model's atmosphere): {rho:.6} kg/m^3");
    assert_eq!(tanker_speed, 150.0);
    assert_eq!(hose_rho, rho, "the hose flies in the atmosphere at 6000 m");
    assert_eq!((wake_rho, wake_v), (rho, 150.0));
    // The receiver starts at 150 m/s north with the tanker: the relative velocity is zero.
    let x0 = r.samples[0].state;
    let v_ned = host_sim::world::ned_from_body(&x0) * x0.vel_body_mps;
    assert!(
        (v_ned.x - 150.0).abs() < 1e-9 && v_ned.z.abs() < 1e-9,
        "{v_ned}"
    );

    // The steady trail differs from the default's (more drag: rho V^2 is 13 % higher).
    let here = world(&s).drogue_centre_tanker_m();
    let default = world(&parse("").unwrap().scenario()).drogue_centre_tanker_m();
    println!(
        "steady trail: [{:.3}, {:.3}, {:.3}] m at 150 m/s, 6000 m; [{:.3}, {:.3}, {:.3}] m at \
         the default",
        here.x, here.y, here.z, default.x, default.y, default.z
    );
    assert!((here - default).norm() > 0.02, "{here} vs {default}");

    // The bow wave scales with the dynamic pressure, the gusts convect at 150 m/s.
    let gusty = parse(&format!(
        "{AT_150_6000}[bow_wave]\nenabled = true\n[turbulence]\npreset = \"level1\"\n"
    ))
    .unwrap()
    .scenario();
    let w = world(&gusty);
    let q = rho * 150.0 * 150.0 / (m.air_at(3000.0).density_kg_m3 * 120.0 * 120.0);
    assert!((w.bow_wave_scale - q).abs() < 1e-12, "{}", w.bow_wave_scale);
    let g = w.gusts.as_ref().expect("gusts").params();
    assert_eq!(g.airspeed_mps, 150.0);
    let default_world = world(
        &parse("[bow_wave]\nenabled = true\n[turbulence]\npreset = \"level1\"\n")
            .unwrap()
            .scenario(),
    );
    assert_eq!(default_world.bow_wave_scale, 1.0);
}
