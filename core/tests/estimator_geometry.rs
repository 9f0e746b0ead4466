//! The drogue estimator's geometry (`ibvs_core::estimator::TipGeometry`) against rotations
//! built here from the frames of `docs/conventions.md`: the camera's axes in body axes for a
//! boresight pitched down by `p` (right = body y, down = `(-sin p, 0, cos p)`, boresight =
//! `(cos p, 0, sin p)`), the body's attitude as the 3-2-1 Euler rotation of nalgebra; the
//! tip sight's tolerance and running average, and the closing speed, against their
//! statements in the module doc and `docs/conventions.md`.

use ibvs_core::estimator::{DrogueEstimate, EstimatorConfig, TipGeometry, TipSight, TipSighting};
use ibvs_core::kinematics::CameraMount;
use nalgebra::{Matrix3, Rotation3, Vector3};

/// Body from camera axes for a boresight pitched down by `p` (columns: camera right, down,
/// boresight in body axes).
fn body_from_camera(p: f32) -> Matrix3<f32> {
    let (s, c) = (p.sin(), p.cos());
    Matrix3::from_columns(&[
        Vector3::new(0.0, 1.0, 0.0),
        Vector3::new(-s, 0.0, c),
        Vector3::new(c, 0.0, s),
    ])
}

#[test]
fn the_geometrys_tip_image_is_the_tip_seen_through_the_mount() {
    // A camera 2 m behind, 0.3 m left of and 0.4 m below the tip, level: the tip appears at
    // (0.3 / 2, -0.4 / 2).
    let camera = CameraMount {
        position_body_m: [1.0, -0.3, 0.4],
        pitch_down_rad: 0.0,
    };
    let g = TipGeometry::new(&camera, [3.0, 0.0, 0.0], 0.0);
    let t = g.tip_image();
    assert!(
        (t[0] - 0.15).abs() < 1e-6 && (t[1] + 0.2).abs() < 1e-6,
        "{t:?}"
    );
    // The refuelling camera, set back 2.66 m and 0.24 m above the tip, its boresight pitched
    // down by 0.11 rad: the tip minus the camera in camera axes is R^T d.
    let (p, d) = (0.11_f32, Vector3::new(2.66_f32, 0.0, 0.24));
    let camera = CameraMount {
        position_body_m: [3.40, 0.54, -1.10],
        pitch_down_rad: p,
    };
    let g = TipGeometry::new(&camera, [6.06, 0.54, -0.86], p);
    let c = body_from_camera(p).transpose() * d;
    let t = g.tip_image();
    assert!(
        t[0].abs() < 1e-6 && (t[1] - c.y / c.z).abs() < 1e-5,
        "{t:?} vs {c:?}"
    );
}

#[test]
fn the_attitudes_de_rotation_is_the_first_order_of_the_body_rotation() {
    // A camera at the tip, level at a trim pitch of 0.5 rad (large, so that the roll axis,
    // the body x axis pitched up by it, is far from the boresight). A drogue at (x z, y z, z)
    // in camera axes is, in tanker axes, R(phi, trim + theta, psi) B(trim) (x z, y z, z);
    // the geometry must invert the attitude to first order: within the second-order
    // remainder, half the angle's square times the range (at most 1.5e-4 * 10 m here).
    let trim = 0.5_f32;
    let tip = [6.0, 0.5, -0.8];
    let camera = CameraMount {
        position_body_m: tip,
        pitch_down_rad: trim,
    };
    let g = TipGeometry::new(&camera, tip, trim);
    let (x, y, z) = (0.5_f32, -0.4_f32, 8.0_f32);
    let cam = Vector3::new(x * z, y * z, z);
    for (phi, theta, psi) in [
        (0.01_f32, 0.0, 0.0),
        (0.0, 0.01, 0.0),
        (0.0, 0.0, 0.01),
        (0.01, -0.01, 0.01),
    ] {
        let r = Rotation3::from_euler_angles(phi, trim + theta, psi).matrix()
            * body_from_camera(trim)
            * cam;
        let want = [r.y, r.z, r.x]; // right, down, forward
        let got = g.drogue_from_tip([x, y], z, [phi, theta, psi], g.tip_image());
        for i in 0..3 {
            assert!(
                (got[i] - want[i]).abs() < 2e-3,
                "{phi} {theta} {psi}: axis {i}: {got:?} vs {want:?}"
            );
        }
        // The attitude matters (the check is not met by ignoring it): at least 3 cm.
        let level = g.drogue_from_tip([x, y], z, [0.0; 3], g.tip_image());
        let moved = (0..3)
            .map(|i| (level[i] - want[i]).abs())
            .fold(0.0, f32::max);
        assert!(moved > 0.03, "{phi} {theta} {psi}: {moved}");
    }
}

/// The level camera of the first test: the tip appears at (0.15, -0.2).
fn level_camera() -> TipGeometry {
    let camera = CameraMount {
        position_body_m: [1.0, -0.3, 0.4],
        pitch_down_rad: 0.0,
    };
    TipGeometry::new(&camera, [3.0, 0.0, 0.0], 0.0)
}

#[test]
fn the_tip_sight_accepts_within_the_tolerance_of_the_geometry_and_averages() {
    // docs/conventions.md, "Endpoint aiming": a running average of the tip's
    // measured image point, within the tolerance (radial, 0.06 here) of where the geometry
    // puts it, else rejected. Average: image += k (measured - image), k = 0.25 here.
    let cfg = EstimatorConfig {
        tip_sight_tolerance: 0.06,
        tip_sight_filter: 0.25,
        ..EstimatorConfig::default()
    };
    let g = level_camera();
    let b = g.tip_image();
    // 0.05 off in x only, or in y only: inside.
    for d in [[0.05, 0.0], [0.0, 0.05], [-0.05, 0.0], [0.0, -0.05]] {
        let mut s = TipSight::new(&g);
        assert_eq!(
            s.observe(Some([b[0] + d[0], b[1] + d[1]]), &cfg),
            TipSighting::Used,
            "{d:?}"
        );
    }
    // 0.05 and 0.04: 0.064 radially, outside (each alone is inside).
    for d in [[0.05, 0.04], [-0.04, 0.05]] {
        let mut s = TipSight::new(&g);
        assert_eq!(
            s.observe(Some([b[0] + d[0], b[1] + d[1]]), &cfg),
            TipSighting::Rejected,
            "{d:?}"
        );
        assert_eq!(s.image(), b, "a rejection leaves the average");
    }
    // The average: from b toward m = b + (0.04, -0.02) by a quarter, twice.
    let mut s = TipSight::new(&g);
    let m = [b[0] + 0.04, b[1] - 0.02];
    s.observe(Some(m), &cfg);
    let once = [b[0] + 0.25 * 0.04, b[1] - 0.25 * 0.02];
    assert!(
        (s.image()[0] - once[0]).abs() < 1e-6 && (s.image()[1] - once[1]).abs() < 1e-6,
        "{:?}",
        s.image()
    );
    s.observe(Some(m), &cfg);
    let twice = [
        b[0] + 0.04 * (1.0 - 0.75 * 0.75),
        b[1] - 0.02 * (1.0 - 0.75 * 0.75),
    ];
    assert!(
        (s.image()[0] - twice[0]).abs() < 1e-6 && (s.image()[1] - twice[1]).abs() < 1e-6,
        "{:?}",
        s.image()
    );
    assert_eq!(s.observe(None, &cfg), TipSighting::None);
}

#[test]
fn the_closing_speed_is_the_tips_forward_speed_less_the_drogues() {
    let e = DrogueEstimate {
        drogue_velocity_mps: [0.0, 0.0, 0.3],
        ..DrogueEstimate::default()
    };
    assert!((e.closing_mps(1.0) - 0.7).abs() < 1e-6);
    assert!((e.closing_mps(-0.2) + 0.5).abs() < 1e-6);
}
