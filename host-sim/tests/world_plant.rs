//! The world's plant dispersions as a run builds them (`host_sim::sim::build_world`): each
//! scenario key reaches the world it should change (the gusts' scale length and so their
//! correlation time, the wake's and the bow wave's strengths, the camera's mount), and the
//! hose settles to a steady trail, and stays in it, at every corner of the refuelling
//! presets' ranges (`host_sim::scenario::WORLD_PLANT_DISPERSION`) across the docking
//! envelope (100..170 m/s, 500..8,000 m).

use host_sim::receiver::{F16, Trim};
use host_sim::scenario::{ScenarioFile, WORLD_PLANT_DISPERSION};
use host_sim::sim::{Scenario, build_world};
use host_sim::synthesis::NOMINAL_XCG;
use host_sim::world::hose::HoseParams;
use host_sim::world::turbulence::GustField;
use host_sim::world::wake::WakeParams;
use host_sim::world::{Drogue, World};
use nalgebra::Vector3;

fn model() -> F16 {
    F16::new(NOMINAL_XCG).expect("model")
}

fn trim(m: &F16, s: &Scenario) -> Trim {
    m.trim_straight_level(s.tanker.speed_mps, s.tanker.altitude_m)
        .expect("trim")
}

/// The world of scenario file `text`, at the refuelling presets' 0.02 s step.
fn world(text: &str) -> World {
    let s = ScenarioFile::parse(text, "test").expect("file").scenario();
    let m = model();
    build_world(&s, &m, &trim(&m, &s), 0.02).expect("world")
}

/// Sample autocorrelation of `x` at lag `lag` samples.
fn autocorrelation(x: &[f64], lag: usize) -> f64 {
    let n = x.len() - lag;
    let mean = x.iter().sum::<f64>() / x.len() as f64;
    let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / x.len() as f64;
    (0..n)
        .map(|i| (x[i] - mean) * (x[i + lag] - mean))
        .sum::<f64>()
        / n as f64
        / var
}

/// The scale length sets the gusts' time constant `L / V`: the longitudinal gust's
/// correlation at a lag `tau` is `exp(-tau V / L)`, the vertical's
/// `(1 - tau V / (2 L)) exp(-tau V / L)` (Dryden), measured on 100,000 s of each field.
#[test]
fn the_scale_length_sets_the_gusts_correlation_time() {
    let (tau, v) = (2.0, 120.0);
    let mut measured = Vec::new();
    for length in [533.4, 762.0] {
        let w = world(&format!(
            "[turbulence]\nsigma_mps = 1.0\nscale_length_m = {length:?}\n"
        ));
        let params = *w.gusts.as_ref().expect("gusts").params();
        assert_eq!((params.length_m, params.airspeed_mps), (length, v));
        // The same field, sampled every 0.1 s (its discretisation is exact at any step).
        let dt = 0.1;
        let mut g = GustField::new(params, dt, 7).expect("field");
        let n = 1_000_000;
        let (mut u, mut wz) = (Vec::with_capacity(n), Vec::with_capacity(n));
        for _ in 0..n {
            g.advance();
            let s = g.gust_reference_mps();
            u.push(s.x);
            wz.push(s.z);
        }
        let lag = (tau / dt) as usize;
        let s = tau * v / length;
        let (ru, rw) = (autocorrelation(&u, lag), autocorrelation(&wz, lag));
        let (eu, ew) = ((-s).exp(), (1.0 - s / 2.0) * (-s).exp());
        println!(
            "L = {length} m: correlation at {tau} s, u {ru:.3} (Dryden {eu:.3}), w {rw:.3} \
             (Dryden {ew:.3})"
        );
        assert!((ru - eu).abs() < 0.03 && (rw - ew).abs() < 0.03, "{length}");
        measured.push((ru, rw));
    }
    // The longer length's gusts stay correlated longer, by more than the estimates' error.
    assert!(measured[1].0 > measured[0].0 + 0.06 && measured[1].1 > measured[0].1 + 0.06);
    // Without the key, MIL-F-8785C's length at the altitude.
    let w = world("[turbulence]\nsigma_mps = 1.0\n");
    assert_eq!(w.gusts.as_ref().unwrap().params().length_m, 533.4);
}

#[test]
fn the_strengths_and_the_mount_reach_the_world() {
    let w = world(
        "[tanker_wake]\nenabled = true\nstrength = 1.5\n[bow_wave]\nenabled = true\n\
         strength = 0.7\n[camera]\nmount_roll_error_deg = 0.5\nmount_yaw_error_deg = -0.25\n",
    );
    assert_eq!(w.bow_wave_scale, 0.7);
    let nominal = world("");
    let p = Vector3::new(-14.0, 0.3, 5.0);
    let (strong, base) = (
        w.wake.as_ref().unwrap().velocity_tanker_mps(&p),
        nominal.wake.as_ref().unwrap().velocity_tanker_mps(&p),
    );
    assert!((strong - base * 1.5).norm() < 1e-12, "{strong} vs {base}");
    assert!((w.mount.roll_error_rad - 0.5f64.to_radians()).abs() < 1e-15);
    assert!((w.mount.yaw_error_rad + 0.25f64.to_radians()).abs() < 1e-15);
    assert_eq!(
        (nominal.mount.roll_error_rad, nominal.mount.yaw_error_rad),
        (0.0, 0.0)
    );
    assert_eq!(nominal.bow_wave_scale, 1.0);
    // A stronger wake trails the drogue lower (more downwash along the hose).
    assert!(w.drogue_centre_tanker_m().z > nominal.drogue_centre_tanker_m().z + 0.05);
}

/// Every corner of the refuelling presets' hose and drogue ranges, with the wake at both ends
/// of its strength, at the four corners of the docking envelope: the hose settles to its
/// steady trail, in tension everywhere, and stays there over a second of the dynamic model
/// in the same steady air.
#[test]
fn the_hose_settles_at_the_corners_of_the_plant_ranges_across_the_envelope() {
    let d = ScenarioFile::parse(WORLD_PLANT_DISPERSION, "plant")
        .expect("the plant dispersion parses")
        .dispersion;
    let r = |x: Option<[f64; 2]>| x.expect("every hose range is given");
    let ranges = [
        r(d.drogue.drogue_mass_kg),
        r(d.drogue.drogue_drag_coefficient),
        r(d.drogue.hose_length_m),
        r(d.drogue.hose_linear_density_kg_per_m),
        r(d.drogue.hose_drag_scale),
    ];
    let wake = r(d.tanker_wake.strength);
    let m = model();
    let (mut lowest, mut highest, mut worst_drift, mut least_tension) =
        (f64::MAX, f64::MIN, 0.0_f64, f64::MAX);
    let mut built = 0;
    for (speed, altitude) in [
        (100.0, 500.0),
        (100.0, 8000.0),
        (170.0, 500.0),
        (170.0, 8000.0),
    ] {
        let base = ScenarioFile::parse(
            &format!("[flight]\nairspeed_mps = {speed:?}\naltitude_m = {altitude:?}\n"),
            "corner",
        )
        .expect("condition")
        .scenario();
        let t = trim(&m, &base);
        for corner in 0..(1 << 6) {
            let end = |i: usize, r: [f64; 2]| r[(corner >> i) & 1];
            let s = Scenario {
                hose: Some(HoseParams {
                    drogue_mass_kg: end(0, ranges[0]),
                    drogue_drag_coefficient: end(1, ranges[1]),
                    hose_length_m: end(2, ranges[2]),
                    hose_linear_density_kg_per_m: end(3, ranges[3]),
                    hose_drag_scale: end(4, ranges[4]),
                    ..HoseParams::default()
                }),
                wake: Some(WakeParams {
                    strength_scale: end(5, wake),
                    ..WakeParams::default()
                }),
                ..base.clone()
            };
            let mut w = build_world(&s, &m, &t, 0.02)
                .unwrap_or_else(|e| panic!("{speed} m/s, {altitude} m, corner {corner:06b}: {e}"));
            let Drogue::Hose(h) = &w.drogue else {
                panic!("a hose")
            };
            let tension = h.link_tensions_n().into_iter().fold(f64::MAX, f64::min);
            let start = w.drogue_centre_tanker_m();
            for k in 0..50 {
                w.step(0.02, &t.state, f64::from(k) * 0.02);
            }
            let drift = (w.drogue_centre_tanker_m() - start).norm();
            assert!(
                tension > 0.0 && drift < 1e-3,
                "{speed} m/s, {altitude} m, corner {corner:06b}: tension {tension} N, drift {drift} m"
            );
            lowest = lowest.min(start.z);
            highest = highest.max(start.z);
            worst_drift = worst_drift.max(drift);
            least_tension = least_tension.min(tension);
            built += 1;
        }
    }
    println!(
        "{built} steady trails: drogue z {lowest:.2}..{highest:.2} m, largest drift over 1 s \
         {worst_drift:.1e} m, least link tension {least_tension:.0} N"
    );
}
