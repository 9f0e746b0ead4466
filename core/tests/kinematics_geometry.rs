//! The rigid-body kinematics of `ibvs_core::kinematics` against their statement in the
//! module docs and `docs/conventions.md`, "Frames", recomputed here in `f64` from the
//! definitions, not from the code:
//! - a point fixed on the receiver moves relative to the tanker at
//!   `R(phi, theta, psi) (v_body(V, alpha, beta) + omega x p) - (V_trim, 0, 0)`, with
//!   `v_body = V (cos a cos b, sin b, sin a cos b)`, `R` the 3-2-1 Euler rotation, the
//!   tanker flying north at the trim speed, reported `[right, down, forward]`;
//! - the camera's axes (x right, y down, z boresight) sit in the body with the boresight
//!   pitched down by the mount's pitch: camera x is body y, the boresight
//!   `(cos p, 0, sin p)`, camera y `(-sin p, 0, cos p)`;
//! - `re = (y_t, z_t, x_t)` (paper eq. (3));
//! - the lever arm's rows are `omega x p_cam` rotated into tanker axes at the trim pitch;
//! - and of the frame-tagged types (`ibvs_core::frames`): `VelocityRe::is_finite` (the oracle
//!   of the step's properties, `v_des` finite) is false as soon as any one component is NaN
//!   or infinite, and a target's radial offset is its distance from the boresight,
//!   `sqrt(right² + down²)`.

use ibvs_core::frames::{TargetEstimate, VelocityRe};
use ibvs_core::gains::TRIM;
use ibvs_core::inner::TrimPoint;
use ibvs_core::kinematics::{
    body_from_camera, lever_arm_lat, lever_arm_lon, point_velocity_tanker_mps, re_from_tanker,
    tanker_from_body,
};
use ibvs_core::nav::NavSample;
use nalgebra::{Rotation3, Vector3};

/// The documented kinematics in double precision: `[right, down, forward]`, m/s.
fn reference_point_velocity(nav: &NavSample, trim: &TrimPoint, p: [f32; 3]) -> [f64; 3] {
    let f = |x: f32| f64::from(x);
    let (lo, la) = (&nav.lon, &nav.lat);
    let v = f(trim.speed_mps) + f(lo.v_mps);
    let alpha = f(trim.alpha_rad) + f(lo.alpha_rad);
    let beta = f(la.beta_rad);
    let v_body = Vector3::new(
        v * alpha.cos() * beta.cos(),
        v * beta.sin(),
        v * alpha.sin() * beta.cos(),
    );
    let omega = Vector3::new(f(la.p_radps), f(lo.q_radps), f(la.r_radps));
    let p = Vector3::new(f(p[0]), f(p[1]), f(p[2]));
    let r = Rotation3::from_euler_angles(
        f(la.phi_rad),
        f(trim.theta_rad) + f(lo.theta_rad),
        f(la.psi_rad),
    );
    let ned = r * (v_body + omega.cross(&p));
    [ned.y, ned.z, ned.x - f(trim.speed_mps)]
}

fn nav(lon: [f32; 6], lat: [f32; 6]) -> NavSample {
    let mut a = [0.0; 12];
    a[..6].copy_from_slice(&lon);
    a[6..].copy_from_slice(&lat);
    NavSample::from_array(a)
}

#[test]
fn a_points_velocity_is_the_rotated_body_velocity_plus_the_lever_arm_minus_the_tankers() {
    // Every state away from zero and with its own size, so that no term can stand in for
    // another: attitude, flow angles, speed, all three rates; a point with all three
    // coordinates non-zero.
    let cases = [
        (
            [0.0, 0.0, 0.05, 3.0, 0.03, 0.2],
            [0.0, 0.15, 0.3, 0.06, 0.4, -0.25],
            [6.06, 0.54, -0.86],
        ),
        (
            [5.0, -2.0, -0.12, -4.5, -0.04, -0.3],
            [1.0, -0.2, -0.6, -0.1, -0.5, 0.35],
            [3.4, -0.7, 1.1],
        ),
        (
            [0.0, 0.0, 0.2, 1.5, 0.1, 0.6],
            [0.0, 0.3, 0.1, 0.15, 1.0, 0.8],
            [-2.0, 1.5, 0.5],
        ),
    ];
    // Off the design trim too: another speed, angle of attack and pitch.
    let other = TrimPoint {
        speed_mps: 150.0,
        alpha_rad: 0.05,
        theta_rad: 0.07,
        ..TRIM
    };
    for trim in [TRIM, other] {
        for (lon, lat, p) in cases {
            let n = nav(lon, lat);
            let got = point_velocity_tanker_mps(&n, &trim, p);
            let want = reference_point_velocity(&n, &trim, p);
            for k in 0..3 {
                // f32 arithmetic on 150 m/s and the series trigonometry (1.2e-7): a few
                // 1e-5 m/s.
                assert!(
                    (f64::from(got[k]) - want[k]).abs() < 1e-4,
                    "component {k}: {got:?} vs {want:?}"
                );
            }
        }
    }
}

#[test]
fn the_position_states_do_not_move_the_point() {
    // x, h and y are positions, not fed back: they cannot change a velocity.
    let lat = [0.0, 0.1, 0.2, 0.05, 0.3, 0.1];
    let lon = [0.0, 0.0, 0.1, 2.0, 0.02, 0.1];
    let p = [6.0, 0.5, -0.9];
    let base = point_velocity_tanker_mps(&nav(lon, lat), &TRIM, p);
    let mut lon_moved = lon;
    lon_moved[0] = 250.0;
    lon_moved[1] = -40.0;
    let mut lat_moved = lat;
    lat_moved[0] = 30.0;
    assert_eq!(
        point_velocity_tanker_mps(&nav(lon_moved, lat_moved), &TRIM, p),
        base
    );
}

#[test]
fn the_cameras_axes_in_the_body_for_a_pitched_down_mount() {
    for pitch in [0.0_f32, 0.11, 0.35, -0.2, 0.8] {
        let m = body_from_camera(pitch);
        let (s, c) = (f64::from(pitch).sin(), f64::from(pitch).cos());
        let columns = [
            [0.0, 1.0, 0.0], // image right: the right wing
            [-s, 0.0, c],    // image down: toward the belly, tilted back by the pitch
            [c, 0.0, s],     // boresight: forward, pitched down
        ];
        for (j, col) in columns.iter().enumerate() {
            for (i, want) in col.iter().enumerate() {
                assert!(
                    (f64::from(m[(i, j)]) - want).abs() < 2e-7,
                    "pitch {pitch}: ({i}, {j}) = {} vs {want}",
                    m[(i, j)]
                );
            }
        }
        // A rotation: orthonormal, right-handed.
        assert!((m.determinant() - 1.0).abs() < 1e-6);
        assert!((m.transpose() * m - nalgebra::Matrix3::identity()).amax() < 1e-6);
    }
}

#[test]
fn the_tanker_from_body_rotation_turns_each_axis_the_right_way() {
    // Pitch up 0.3 rad: the nose points forward and up (-z); yaw 0.3 rad: forward and right;
    // roll 0.3 rad (right wing down): the right wing points right and down.
    let (s, c) = (0.3_f32.sin(), 0.3_f32.cos());
    let close = |a: Vector3<f32>, b: Vector3<f32>| (a - b).amax() < 1e-6;
    assert!(close(
        tanker_from_body(0.0, 0.3, 0.0) * Vector3::x(),
        Vector3::new(c, 0.0, -s)
    ));
    assert!(close(
        tanker_from_body(0.0, 0.0, 0.3) * Vector3::x(),
        Vector3::new(c, s, 0.0)
    ));
    assert!(close(
        tanker_from_body(0.3, 0.0, 0.0) * Vector3::y(),
        Vector3::new(0.0, c, s)
    ));
}

#[test]
fn re_is_the_tankers_axes_reordered_right_down_forward() {
    let v_t = Vector3::new(1.0_f32, 2.0, 3.0); // forward, right, down
    assert_eq!(re_from_tanker(v_t), Vector3::new(2.0, 3.0, 1.0));
}

#[test]
fn the_lever_arm_rows_are_the_pitch_rotated_cross_product_in_single_precision_too() {
    // The controller's f32 instance of the generic rows, at a pitch where sine and cosine
    // both matter, against omega x p rotated by the pitch in f64.
    let p = [3.4_f32, 0.54, -1.1];
    let theta = 0.3_f32;
    let lon = lever_arm_lon(p, theta);
    let lat = lever_arm_lat(p);
    let r = Rotation3::from_euler_angles(0.0, f64::from(theta), 0.0);
    let pv = Vector3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]));
    let q = r * Vector3::y().cross(&pv); // per unit pitch rate
    let roll = Vector3::x().cross(&pv); // per unit roll rate (no rotation laterally)
    let yaw = Vector3::z().cross(&pv);
    let want_lon = [[0.0, 0.0, 0.0, q.z, 0.0], [0.0, 0.0, 0.0, q.x, 0.0]];
    let want_lat = [0.0, 0.0, 0.0, roll.y, yaw.y];
    for (row, want) in lon.iter().zip(&want_lon) {
        for (g, w) in row.iter().zip(want) {
            assert!((f64::from(*g) - w).abs() < 1e-6, "{lon:?} vs {want_lon:?}");
        }
    }
    for (g, w) in lat[0].iter().zip(&want_lat) {
        assert!((f64::from(*g) - w).abs() < 1e-6, "{lat:?} vs {want_lat:?}");
    }
}

#[test]
fn a_velocity_is_finite_only_when_every_component_is() {
    let ok = VelocityRe {
        x_right_mps: 0.5,
        y_down_mps: -1.0,
        z_fwd_mps: 2.0,
    };
    assert!(ok.is_finite());
    assert!(VelocityRe::ZERO.is_finite());
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        for k in 0..3 {
            let mut v = ok;
            match k {
                0 => v.x_right_mps = bad,
                1 => v.y_down_mps = bad,
                _ => v.z_fwd_mps = bad,
            }
            assert!(!v.is_finite(), "component {k} = {bad}: {v:?}");
        }
    }
}

#[test]
fn the_radial_offset_is_the_distance_from_the_boresight() {
    let t = |right_m, down_m| TargetEstimate {
        right_m,
        down_m,
        depth_m: 7.0,
    };
    assert_eq!(t(3.0, 4.0).radial_offset_m(), 5.0);
    assert_eq!(t(-3.0, 4.0).radial_offset_m(), 5.0);
    assert_eq!(t(0.0, -0.25).radial_offset_m(), 0.25);
    assert_eq!(t(0.0, 0.0).radial_offset_m(), 0.0);
}
