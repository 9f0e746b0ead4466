//! Rigid-body kinematics shared by the controller and the gain synthesis.
//!
//! - The lever-arm part of the camera-velocity output matrices: the camera moves with the
//!   receiver's CG plus `omega x p_cam`, rotated into tanker axes at the trim pitch
//!   (paper eq. (7)-(10), read as paper-notes item 4). The CG part comes from the numerical
//!   linearisation and is generated into [`crate::gains`]; the lever-arm part is computed here
//!   from the camera position the controller *believes*, so a mount error shows up exactly
//!   where the paper's position-error experiment puts it.
//! - The camera mount and the rotations PBVS needs to turn an image point into a position.
//!
//! The functions are generic over the scalar so that the host's `f64` synthesis and the
//! controller's `f32` step use the same formulas. Invariant: pure functions, no state.

use nalgebra::{Matrix3, RealField, Rotation3, Vector3};
use serde::{Deserialize, Serialize};

/// Where the camera sits on the receiver and how it is tilted.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CameraMount {
    /// Camera optical centre relative to the CG, body axes (x forward, y right, z down), m.
    pub position_body_m: [f32; 3],
    /// Boresight pitched down from the body x axis, rad. Set to the trim pitch so that the
    /// boresight is level at trim (paper-notes item 8).
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

/// Rotation from camera axes (x right, y down, z boresight) to body axes for a mount whose
/// boresight is pitched down by `pitch_down_rad`.
pub fn body_from_camera(pitch_down_rad: f32) -> Matrix3<f32> {
    let (s, c) = (libm::sinf(pitch_down_rad), libm::cosf(pitch_down_rad));
    // Columns: camera x -> body y; camera y -> (-s, 0, c); camera z (boresight) -> (c, 0, s).
    Matrix3::new(0.0, -s, c, 1.0, 0.0, 0.0, 0.0, c, s)
}

/// Rotation from body axes to tanker axes for 3-2-1 Euler angles relative to the tanker.
pub fn tanker_from_body(roll_rad: f32, pitch_rad: f32, yaw_rad: f32) -> Matrix3<f32> {
    *Rotation3::from_euler_angles(roll_rad, pitch_rad, yaw_rad).matrix()
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
