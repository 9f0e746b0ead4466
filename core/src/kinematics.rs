//! Rigid-body kinematics shared by the controller and the gain synthesis.
//!
//! - The lever-arm part of the camera-velocity output matrices: the camera moves with the
//!   receiver's CG plus `omega x p_cam`, rotated into tanker axes at the trim pitch
//!   (paper eq. (7)-(10), read as in docs/paper.md, item 4). The CG part comes from the numerical
//!   linearisation and is generated into [`crate::gains`]; the lever-arm part is computed here
//!   from the camera position the controller *believes*, so a mount error shows up exactly
//!   where the paper's position-error experiment puts it.
//! - The camera mount and the rotations PBVS needs to turn an image point into a position.
//!
//! The functions are generic over the scalar so that the host's `f64` synthesis and the
//! controller's `f32` step use the same formulas. Invariant: pure functions, no state.

use nalgebra::{Matrix3, RealField, Vector3};

use crate::num::sin_cos;
use serde::{Deserialize, Serialize};

/// The refuelling procedure's camera: set back 2.66 m behind the probe tip and 0.24 m above
/// it, on the nose beside the probe's mast, body axes (x forward, y right, z down), m. It
/// sees the drogue until contact (at the tip the LED ring leaves the image inside about
/// 0.7 m); the paper's authors mount theirs about 2.7 m behind the tip (`docs/models.md`,
/// "Camera"). The probe itself is not modelled as an obstruction of the view.
pub const SET_BACK_CAMERA_BODY_M: [f32; 3] = [3.40, 0.54, -1.10];

/// Where the camera sits on the receiver and how it is tilted.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CameraMount {
    /// Camera optical centre relative to the CG, body axes (x forward, y right, z down), m.
    pub position_body_m: [f32; 3],
    /// Boresight pitched down from the body x axis, rad. Set to the trim pitch so that the
    /// boresight is level at trim (docs/paper.md, item 8).
    pub pitch_down_rad: f32,
}

/// Rows of the longitudinal output matrix from the lever arm, over the design state
/// `[theta, V, alpha, q, P]`; row 0 is the camera's down velocity, row 1 its forward velocity
/// (tanker axes), in m/s per unit state.
pub fn lever_arm_lon<T: RealField + Copy>(p_cam_body_m: [T; 3], trim_pitch_rad: T) -> [[T; 5]; 2] {
    let [x, _, z] = p_cam_body_m;
    let (s, c) = (trim_pitch_rad.sin(), trim_pitch_rad.cos());
    let zero = T::zero();
    // omega x p for omega = (0, q, 0) is q (z, 0, -x); rotate body -> tanker by the trim pitch.
    let down_per_q = -(s * z) - c * x;
    let fwd_per_q = c * z - s * x;
    [
        [zero, zero, zero, down_per_q, zero],
        [zero, zero, zero, fwd_per_q, zero],
    ]
}

/// Row of the lateral output matrix from the lever arm, over the design state
/// `[psi, phi, beta, p, r]`: the camera's rightward velocity (tanker axes), m/s per unit state.
pub fn lever_arm_lat<T: RealField + Copy>(p_cam_body_m: [T; 3]) -> [[T; 5]; 1] {
    let [x, _, z] = p_cam_body_m;
    let zero = T::zero();
    // omega x p for omega = (p, 0, r) has y component r x - p z; body y is tanker y at trim.
    [[zero, zero, zero, -z, x]]
}

/// The velocity of a point fixed on the receiver (`p_body_m` from the CG) relative to the
/// tanker, `[right, down, forward]` in tanker axes, m/s, from the navigation's state: exact
/// kinematics (`R(phi, theta, psi) (v_body(V, alpha, beta) + omega x p)` minus the tanker's
/// velocity), not the linear output `C x` of the design. The states are perturbations from
/// `trim` (its pitch, angle of attack and speed added back); the tanker flies at the trim
/// speed on the heading zero.
///
/// Why: `C x` drops products such as the vertical velocity's change times the bank, which
/// reach 0.5 m/s while the receiver manoeuvres (measured against the simulator's truth:
/// 0.8 m/s RMS laterally over a level II approach); this is within 0.01 m/s of the truth.
#[inline(always)]
pub fn point_velocity_tanker_mps(
    nav: &crate::nav::NavSample,
    trim: &crate::inner::TrimPoint,
    p_body_m: [f32; 3],
) -> [f32; 3] {
    let (lo, la) = (&nav.lon, &nav.lat);
    let v = trim.speed_mps + lo.v_mps;
    let (sa, ca) = sin_cos(trim.alpha_rad + lo.alpha_rad);
    let (sb, cb) = sin_cos(la.beta_rad);
    let (sf, cf) = sin_cos(la.phi_rad);
    let (st, ct) = sin_cos(trim.theta_rad + lo.theta_rad);
    let (sp, cp) = sin_cos(la.psi_rad);
    let [x, y, z] = p_body_m;
    let (p, q, r) = (la.p_radps, lo.q_radps, la.r_radps);
    // Body velocity of the point: the CG's plus omega x p.
    let u = v * ca * cb + (q * z - r * y);
    let w_side = v * sb + (r * x - p * z);
    let w = v * sa * cb + (p * y - q * x);
    // Body to tanker (3-2-1 Euler angles).
    let north = ct * cp * u + (sf * st * cp - cf * sp) * w_side + (cf * st * cp + sf * sp) * w;
    let east = ct * sp * u + (sf * st * sp + cf * cp) * w_side + (cf * st * sp - sf * cp) * w;
    let down = -st * u + sf * ct * w_side + cf * ct * w;
    [east, down, north - trim.speed_mps]
}

/// Rotation from camera axes (x right, y down, z boresight) to body axes for a mount whose
/// boresight is pitched down by `pitch_down_rad`.
pub fn body_from_camera(pitch_down_rad: f32) -> Matrix3<f32> {
    let (s, c) = sin_cos(pitch_down_rad);
    // Columns: camera x -> body y; camera y -> (-s, 0, c); camera z (boresight) -> (c, 0, s).
    Matrix3::new(0.0, -s, c, 1.0, 0.0, 0.0, 0.0, c, s)
}

/// Rotation from body axes to tanker axes for 3-2-1 Euler angles relative to the tanker
/// (nalgebra's `Rotation3::from_euler_angles(roll, pitch, yaw)`, with the series sine and
/// cosine: every angle at most [`crate::num::SIN_COS_MAX_RAD`]).
pub fn tanker_from_body(roll_rad: f32, pitch_rad: f32, yaw_rad: f32) -> Matrix3<f32> {
    let ((sf, cf), (st, ct), (sp, cp)) = (sin_cos(roll_rad), sin_cos(pitch_rad), sin_cos(yaw_rad));
    Matrix3::new(
        ct * cp,
        sf * st * cp - cf * sp,
        cf * st * cp + sf * sp,
        ct * sp,
        sf * st * sp + cf * cp,
        cf * st * sp - sf * cp,
        -st,
        sf * ct,
        cf * ct,
    )
}

/// Reorders a tanker-axes vector into the camera reference frame `re` (paper eq. (3)).
pub fn re_from_tanker(v: Vector3<f32>) -> Vector3<f32> {
    Vector3::new(v.y, v.z, v.x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn level_boresight_at_trim_pitch() {
        let theta = 0.11_f32;
        let boresight_t =
            tanker_from_body(0.0, theta, 0.0) * body_from_camera(theta) * Vector3::z();
        assert!(
            (boresight_t - Vector3::x()).norm() < 1e-6,
            "{boresight_t:?}"
        );
        let down_t = tanker_from_body(0.0, theta, 0.0) * body_from_camera(theta) * Vector3::y();
        assert!((down_t - Vector3::z()).norm() < 1e-6);
    }

    #[test]
    fn tanker_from_body_is_the_3_2_1_rotation() {
        for (f, t, p) in [
            (0.3_f32, -0.2_f32, 0.1_f32),
            (-0.78, 0.45, -0.35),
            (0.0, 0.8, 0.0),
        ] {
            let want = *nalgebra::Rotation3::from_euler_angles(f, t, p).matrix();
            let got = tanker_from_body(f, t, p);
            assert!((got - want).amax() < 1e-6, "{got} {want}");
        }
    }

    #[test]
    fn point_velocity_is_the_exact_kinematics() {
        use crate::gains::TRIM;
        use crate::nav::NavSample;
        // At trim: the point moves with the tanker.
        let tip = [6.06_f32, 0.54, -0.86];
        let v = point_velocity_tanker_mps(&NavSample::default(), &TRIM, tip);
        assert!(v.iter().all(|c| c.abs() < 1e-4), "{v:?}");
        // Banked 0.3 rad, angle of attack up 0.02 rad: the body's vertical velocity tilts
        // sideways, -V sin(alpha) sin(phi) to the right (the term the linear output drops).
        let mut n = NavSample::default();
        n.lat.phi_rad = 0.3;
        n.lon.alpha_rad = 0.02;
        n.lon.theta_rad = 0.02;
        let v = point_velocity_tanker_mps(&n, &TRIM, [0.0; 3]);
        let (a, f) = (TRIM.alpha_rad + 0.02, 0.3_f32);
        let want_right = -TRIM.speed_mps * libm::sinf(a) * libm::sinf(f);
        assert!((v[0] - want_right).abs() < 1e-3, "{v:?} vs {want_right}");
        // A yaw rate swings a point ahead of the CG to the right: r x.
        let mut n = NavSample::default();
        n.lat.r_radps = 0.1;
        let v = point_velocity_tanker_mps(&n, &TRIM, [6.0, 0.0, 0.0]);
        assert!((v[0] - 0.6).abs() < 1e-4, "{v:?}");
    }

    #[test]
    fn lever_arm_matches_cross_product() {
        let p = [6.06_f64, 0.54, -0.86];
        let th = 0.1_f64;
        let lon = lever_arm_lon(p, th);
        let lat = lever_arm_lat(p);
        let r = nalgebra::Rotation3::from_euler_angles(0.0, th, 0.0);
        let pv = nalgebra::Vector3::from(p);
        for (w, probe) in [
            (nalgebra::Vector3::new(0.0, 1.0, 0.0), 0usize),
            (nalgebra::Vector3::new(1.0, 0.0, 0.0), 1),
            (nalgebra::Vector3::new(0.0, 0.0, 1.0), 2),
        ] {
            let v_t = r * w.cross(&pv);
            match probe {
                0 => {
                    assert!((lon[0][3] - v_t.z).abs() < 1e-12);
                    assert!((lon[1][3] - v_t.x).abs() < 1e-12);
                }
                1 => assert!((lat[0][3] - v_t.y).abs() < 1e-12),
                _ => assert!((lat[0][4] - v_t.y).abs() < 1e-12),
            }
        }
    }
}
