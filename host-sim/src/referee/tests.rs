//! The referee on hand-built trajectories: each hazard at its limit (safe) and just beyond it
//! (unsafe), the dockings it must accept and refuse, and a missed approach through the canopy.

use super::*;
use nalgebra::{Rotation3, Vector3};

/// The drogue's centre in these worlds, tanker frame, m (its calm-air trail).
const DROGUE: [f64; 3] = [-13.55, 0.0, 4.54];
/// The probe tip on the receiver, body axes from the CG, m (the simulation's).
const TIP_BODY: [f64; 3] = [6.06, 0.54, -0.86];
/// The physics step of the trajectories, s.
const DT: f64 = 0.01;

/// A straight hose from the exit to the drogue, 20 links.
fn hose() -> Vec<Vector3<f64>> {
    let d = Vector3::from(DROGUE);
    (0..=20).map(|k| d * (k as f64 / 20.0)).collect()
}

fn referee() -> Referee {
    Referee::new(Limits::default(), Airframe::f16(TIP_BODY))
}

/// A level receiver flying north whose probe tip is at `tip` with velocity `v` (tanker frame),
/// the drogue at `drogue` moving at `drogue_v`.
fn truth<'a>(
    time_s: f64,
    tip: Vector3<f64>,
    v: Vector3<f64>,
    drogue: Vector3<f64>,
    drogue_v: Vector3<f64>,
    hose: &'a [Vector3<f64>],
) -> Truth<'a> {
    Truth {
        time_s,
        probe_tip_tanker_m: tip,
        cg_tanker_m: tip - Vector3::from(TIP_BODY),
        cg_velocity_tanker_mps: v,
        tanker_from_body: Rotation3::identity(),
        rate_body_radps: Vector3::zeros(),
        drogue_centre_tanker_m: drogue,
        drogue_velocity_tanker_mps: drogue_v,
        drogue_axis_tanker: -Vector3::x(),
        hose_tanker_m: hose,
    }
}

/// Flies the probe tip through the drogue plane at `offset` (right, down) from the drogue
/// centre, at `closing` m/s along x (negative: backing out from ahead), the tip's lateral
/// position held while the drogue moves across at `drogue_v` (its offset at the plane is
/// `offset`); returns the verdict.
fn pass(offset: [f64; 2], closing: f64, drogue_v: Vector3<f64>) -> Verdict {
    let hose = hose();
    let mut r = referee();
    let d = Vector3::from(DROGUE);
    // Start 0.105 m from the plane on the side it comes from; cross at `tc`.
    let tc = 0.105 / closing.abs();
    let steps = (2.0 * tc / DT) as usize + 2;
    for k in 0..steps {
        let t = k as f64 * DT;
        let tip = d + Vector3::new(
            -0.105 * closing.signum() + closing * t,
            offset[0],
            offset[1],
        );
        let drogue = d + drogue_v * (t - tc);
        let v = Vector3::new(closing, 0.0, 0.0);
        r.observe(&truth(t, tip, v, drogue, drogue_v, &hose));
    }
    r.into_verdict()
}

#[test]
fn a_centred_docking_in_the_band_latches_and_is_safe() {
    let v = pass([0.05, 0.0], 1.0, Vector3::zeros());
    assert!(v.docked() && v.safe() && v.success(), "{v:?}");
    let c = v.docking.unwrap();
    assert_eq!(c.verdict, CrossingVerdict::Docked);
    assert_eq!(c.direction, Direction::Inbound);
    assert!((c.miss_m - 0.05).abs() < 1e-9 && (c.closing_mps - 1.0).abs() < 1e-9);
    assert_eq!(v.crossings.len(), 1, "nothing is judged after the latch");
}

#[test]
fn the_closing_band_at_its_ends_and_beyond() {
    let (lo, hi) = CLOSING_BAND_MPS;
    for closing in [lo, hi] {
        assert!(
            pass([0.0, 0.1], closing, Vector3::zeros()).success(),
            "{closing}"
        );
    }
    let fast = pass([0.0, 0.1], hi + 0.05, Vector3::zeros());
    assert!(!fast.docked() && !fast.safe(), "{fast:?}");
    assert_eq!(fast.hazards[0].kind, HazardKind::HardContact);
    assert!(
        fast.hazards[0].what.contains("above"),
        "{:?}",
        fast.hazards[0]
    );
    let slow = pass([0.0, 0.1], lo - 0.05, Vector3::zeros());
    assert!(!slow.docked() && !slow.safe(), "{slow:?}");
    assert!(
        slow.hazards[0].what.contains("no latch"),
        "{:?}",
        slow.hazards[0]
    );
}

#[test]
fn the_lateral_limit_at_its_value_and_beyond() {
    // The drogue slides across (to the right) while the tip closes at 1 m/s.
    let at = pass([0.1, 0.0], 1.0, Vector3::new(0.0, MAX_LATERAL_MPS, 0.0));
    assert!(at.success(), "{at:?}");
    assert!((at.crossings[0].lateral_mps - MAX_LATERAL_MPS).abs() < 1e-9);
    let beyond = pass(
        [0.1, 0.0],
        1.0,
        Vector3::new(0.0, MAX_LATERAL_MPS + 0.05, 0.0),
    );
    assert!(!beyond.docked(), "{beyond:?}");
    assert_eq!(beyond.hazards.len(), 1);
    assert_eq!(beyond.hazards[0].kind, HazardKind::HardContact);
    assert!(
        beyond.hazards[0].what.contains("lateral"),
        "{:?}",
        beyond.hazards[0]
    );
}

#[test]
fn the_capture_radius_and_the_strike_radius() {
    let l = Limits::default();
    // Just inside the capture radius: a docking.
    assert!(pass([l.capture_radius_m - 0.001, 0.0], 1.0, Vector3::zeros()).success());
    // Just outside the capture radius, inside the canopy and the probe head: a strike.
    let strike = pass([0.0, l.capture_radius_m + 1e-6], 1.0, Vector3::zeros());
    assert!(!strike.docked() && !strike.safe(), "{strike:?}");
    assert_eq!(strike.hazards[0].kind, HazardKind::BasketStrike);
    // Just inside the strike radius: a strike; at it: a fly-by.
    let rim = l.strike_radius_m();
    assert_eq!(
        pass([rim - 0.001, 0.0], 1.0, Vector3::zeros()).hazards[0].kind,
        HazardKind::BasketStrike
    );
    let by = pass([rim + 1e-6, 0.0], 1.0, Vector3::zeros());
    assert!(by.safe() && !by.docked(), "{by:?}");
    assert_eq!(by.crossings[0].verdict, CrossingVerdict::FlyBy);
}

#[test]
fn a_missed_approach_through_the_canopy_is_unsafe_and_one_0_7_m_off_is_safe() {
    // Decelerating through the plane 0.32 m from the centre (inside the canopy and the probe
    // head, outside the capture radius), at 1.3 m/s: the probe through the basket, whatever
    // the controller calls it.
    let through = pass([0.2, 0.25], 1.3, Vector3::zeros());
    assert!(!through.safe(), "{through:?}");
    assert_eq!(through.hazards[0].kind, HazardKind::BasketStrike);
    // The same closing speed inside the capture radius but below the band: no latch, a hard
    // contact.
    let slow = pass([0.1, 0.1], 0.3, Vector3::zeros());
    assert_eq!(slow.hazards[0].kind, HazardKind::HardContact);
    // Backing out through the canopy from ahead of the drogue.
    let out = pass([0.0, 0.2], -0.8, Vector3::zeros());
    assert!(!out.safe(), "{out:?}");
    assert_eq!(out.crossings[0].direction, Direction::Outbound);
    assert_eq!(out.hazards[0].kind, HazardKind::BasketStrike);
    // 0.7 m off, fast: clear of the canopy and of the hose.
    let clear = pass([0.5, -0.49], 1.8, Vector3::zeros());
    assert!(clear.safe() && !clear.docked(), "{clear:?}");
}

/// The truth of a receiver standing still with its CG at `cg` and the drogue at `drogue`.
fn still<'a>(cg: Vector3<f64>, drogue: Vector3<f64>, hose: &'a [Vector3<f64>]) -> Truth<'a> {
    Truth {
        time_s: 0.0,
        probe_tip_tanker_m: cg + Vector3::from(TIP_BODY),
        cg_tanker_m: cg,
        cg_velocity_tanker_mps: Vector3::zeros(),
        tanker_from_body: Rotation3::identity(),
        rate_body_radps: Vector3::zeros(),
        drogue_centre_tanker_m: drogue,
        drogue_velocity_tanker_mps: Vector3::zeros(),
        drogue_axis_tanker: -Vector3::x(),
        hose_tanker_m: hose,
    }
}

#[test]
fn the_drogue_on_the_radome_at_the_clearance_and_inside_it() {
    let a = Airframe::f16(TIP_BODY);
    let l = Limits::default();
    let cg = Vector3::new(-30.0, 0.0, 5.0);
    // Straight ahead of the radome's front end on its axis: the drogue centre is its nearest
    // point (the rim is farther).
    let front = cg + Vector3::from(a.radome.a_body_m);
    let gap_at = |gap: f64| {
        let drogue = front + Vector3::new(a.radome.radius_m + gap, 0.0, 0.0);
        let mut r = referee();
        r.observe(&still(cg, drogue, &[]));
        r.into_verdict()
    };
    assert!(gap_at(l.airframe_clearance_m + 1e-9).safe());
    let inside = gap_at(l.airframe_clearance_m - 0.001);
    assert_eq!(inside.hazards.len(), 1, "{inside:?}");
    assert_eq!(inside.hazards[0].kind, HazardKind::DrogueOnAirframe);
    assert!(inside.hazards[0].what.contains("radome"));
    // The cockpit canopy: the rim (0.305 m above the centre) is the nearest point.
    let top = cg + Vector3::from(a.canopy.a_body_m);
    let rim_gap = |gap: f64| {
        let drogue = top + Vector3::new(-0.5, 0.0, -(a.canopy.radius_m + gap) - l.canopy_radius_m);
        let mut r = referee();
        r.observe(&still(cg, drogue, &[]));
        r.into_verdict()
    };
    assert!(rim_gap(l.airframe_clearance_m + 1e-6).safe());
    let on = rim_gap(l.airframe_clearance_m - 0.001);
    assert_eq!(on.hazards[0].kind, HazardKind::DrogueOnAirframe, "{on:?}");
    assert!(on.hazards[0].what.contains("cockpit canopy"));
}

#[test]
fn the_hose_on_the_probe_at_the_clearance_and_inside_it_but_not_the_coupling() {
    let a = Airframe::f16(TIP_BODY);
    let l = Limits::default();
    let cg = Vector3::new(-30.0, 0.0, 5.0);
    let mast = cg + (Vector3::from(a.probe.a_body_m) + Vector3::from(a.probe.b_body_m)) / 2.0;
    // A hose running across above the probe's mast, drogue far to the right.
    let hose_at = |gap: f64| {
        let z = mast.z - (a.probe.radius_m + l.hose_radius_m + gap);
        let nodes: Vec<_> = (0..=20)
            .map(|k| Vector3::new(mast.x, -10.0 + k as f64, z))
            .collect();
        let drogue = *nodes.last().unwrap();
        let mut r = referee();
        r.observe(&still(cg, drogue, &nodes));
        r.into_verdict()
    };
    assert!(hose_at(l.hose_clearance_m + 1e-9).safe());
    let on = hose_at(l.hose_clearance_m - 0.001);
    assert_eq!(on.hazards.len(), 1, "{on:?}");
    assert_eq!(on.hazards[0].kind, HazardKind::HoseContact);
    assert!(on.hazards[0].what.contains("probe"));
    // The probe tip at the drogue centre (docking): the hose's end in the coupling is not a
    // contact.
    let nodes = hose();
    let drogue = *nodes.last().unwrap();
    let mut r = referee();
    r.observe(&still(drogue - Vector3::from(TIP_BODY), drogue, &nodes));
    assert!(r.verdict().safe(), "{:?}", r.verdict());
}

#[test]
fn the_keep_out_sphere_at_its_radius_and_inside_it() {
    let a = Airframe::f16(TIP_BODY);
    let l = Limits::default();
    // The probe tip's capsule end nearest the exit, straight behind it.
    let at = |gap: f64| {
        let tip = Vector3::new(-(l.tanker_keep_out_m + a.probe.radius_m + gap), 0.0, 0.0);
        // The probe's axis on the tanker's x axis, the tip nearest the exit.
        let cg = tip - Vector3::from(TIP_BODY);
        let mut r = referee();
        r.observe(&still(cg, Vector3::from(DROGUE), &[]));
        r.into_verdict()
    };
    assert!(at(1e-9).safe(), "{:?}", at(1e-9));
    let inside = at(-0.01);
    assert_eq!(
        inside.hazards[0].kind,
        HazardKind::TankerProximity,
        "{inside:?}"
    );
}

fn flight(bank_deg: f64, pitch_deg: f64, alpha_deg: f64, n: f64, distance_m: f64) -> Verdict {
    let mut r = referee();
    r.observe_flight(&FlightTruth {
        time_s: 1.0,
        bank_rad: bank_deg.to_radians(),
        pitch_rad: pitch_deg.to_radians(),
        alpha_rad: alpha_deg.to_radians(),
        load_factor: n,
        cg_tanker_m: Vector3::from(DROGUE) - Vector3::new(distance_m, 0.0, 0.0),
        cg_velocity_tanker_mps: Vector3::zeros(),
        drogue_centre_tanker_m: Vector3::from(DROGUE),
    });
    r.into_verdict()
}

#[test]
fn upsets_at_their_limits_and_beyond_near_the_tanker_only() {
    let near = 10.0;
    assert!(flight(0.0, 6.4, 6.4, 1.0, near).safe(), "refuelling trim");
    // At each limit: safe.
    assert!(flight(45.0 - 1e-9, 6.4, 6.4, 1.0, near).safe());
    assert!(flight(-45.0 + 1e-9, 6.4, 6.4, 1.0, near).safe());
    assert!(flight(0.0, 25.0 - 1e-9, 6.4, 1.0, near).safe());
    assert!(flight(0.0, -10.0 + 1e-9, 6.4, 1.0, near).safe());
    assert!(flight(0.0, 6.4, 20.0 - 1e-9, 1.0, near).safe());
    assert!(flight(0.0, 6.4, -5.0 + 1e-9, 1.0, near).safe());
    assert!(flight(0.0, 6.4, 6.4, 2.0, near).safe());
    assert!(flight(0.0, 6.4, 6.4, 0.0, near).safe());
    // Beyond each: an upset, named.
    for (v, what) in [
        (flight(-45.1, 6.4, 6.4, 1.0, near), "bank"),
        (flight(0.0, 25.1, 6.4, 1.0, near), "pitch up"),
        (flight(0.0, -10.1, 6.4, 1.0, near), "pitch down"),
        (flight(0.0, 6.4, 20.1, 1.0, near), "angle of attack high"),
        (flight(0.0, 6.4, -5.1, 1.0, near), "angle of attack low"),
        (flight(0.0, 6.4, 6.4, 2.01, near), "load factor high"),
        (flight(0.0, 6.4, 6.4, -0.01, near), "load factor low"),
    ] {
        assert_eq!(v.hazards.len(), 1, "{what}: {v:?}");
        assert_eq!(v.hazards[0].kind, HazardKind::Upset);
        assert_eq!(v.hazards[0].what, what);
    }
    // The same upset farther than the upset distance from the drogue is not a hazard here.
    assert!(flight(60.0, 6.4, 6.4, 1.0, UPSET_DISTANCE_M + 0.1).safe());
    assert!(!flight(60.0, 6.4, 6.4, 1.0, UPSET_DISTANCE_M - 0.1).safe());
}

#[test]
fn a_continuing_hazard_is_one_record_at_its_worst_and_a_new_one_after_it_clears() {
    let mut r = referee();
    let f = |t: f64, bank: f64| FlightTruth {
        time_s: t,
        bank_rad: bank.to_radians(),
        pitch_rad: 0.1,
        alpha_rad: 0.1,
        load_factor: 1.0,
        cg_tanker_m: Vector3::from(DROGUE),
        cg_velocity_tanker_mps: Vector3::zeros(),
        drogue_centre_tanker_m: Vector3::from(DROGUE),
    };
    for (k, bank) in [10.0, 50.0, 70.0, 55.0, 30.0, 48.0].into_iter().enumerate() {
        r.observe_flight(&f(k as f64, bank));
    }
    let v = r.into_verdict();
    assert_eq!(v.hazards.len(), 2, "{v:?}");
    assert_eq!(v.hazards[0].time_s, 1.0);
    assert!((v.hazards[0].measure - 70.0).abs() < 1e-9, "worst kept");
    assert_eq!(v.hazards[1].time_s, 5.0);
}

#[test]
fn segment_distances_match_hand_computed_cases() {
    let v = |x: f64, y: f64, z: f64| Vector3::new(x, y, z);
    // Crossing segments 1 m apart in z.
    let (d, q) = segment_segment(
        &v(-1.0, 0.0, 0.0),
        &v(1.0, 0.0, 0.0),
        &v(0.0, -1.0, 1.0),
        &v(0.0, 1.0, 1.0),
    );
    assert!((d - 1.0).abs() < 1e-12 && q.norm() < 1e-12);
    // Parallel, overlapping.
    let (d, _) = segment_segment(
        &v(0.0, 0.0, 0.0),
        &v(2.0, 0.0, 0.0),
        &v(1.0, 0.5, 0.0),
        &v(3.0, 0.5, 0.0),
    );
    assert!((d - 0.5).abs() < 1e-12);
    // End to end.
    let (d, q) = segment_segment(
        &v(0.0, 0.0, 0.0),
        &v(1.0, 0.0, 0.0),
        &v(2.0, 0.0, 0.0),
        &v(3.0, 1.0, 0.0),
    );
    assert!((d - 1.0).abs() < 1e-12 && (q - v(1.0, 0.0, 0.0)).norm() < 1e-12);
    // A point beyond a segment's end.
    let (d, _) = point_segment(&v(3.0, 4.0, 0.0), &v(-1.0, 0.0, 0.0), &v(0.0, 0.0, 0.0));
    assert!((d - 5.0).abs() < 1e-12);
}
