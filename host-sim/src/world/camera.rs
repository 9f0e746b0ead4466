//! The camera at the probe tip: an ideal pinhole in this slice (no noise, no latency, no
//! drops), with a field of view and a minimum range inside which it cannot see the drogue.
//!
//! Invariant: the measurement is the drogue centre in normalised image coordinates
//! `(x_c / z_c, y_c / z_c)` and its depth `z_c`, camera axes x right, y down, z boresight;
//! `tracked` is false exactly when the drogue is behind the camera, outside the field of view
//! or closer than the minimum range.

use ibvs_core::measurement::CameraMeasurement;
use nalgebra::{Matrix3, Vector3};

use super::{Tanker, ned_from_body};
use crate::receiver::ReceiverState;

/// Camera intrinsics and visibility limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraParams {
    /// Image width, px.
    pub width_px: f64,
    /// Image height, px.
    pub height_px: f64,
    /// Focal length, px.
    pub focal_px: f64,
    /// Depth below which the LED ring can no longer be fitted, m (judgement: the ring
    /// leaves the field of view and the fit degrades inside about a metre; paper-notes item 7).
    pub min_range_m: f64,
}

impl Default for CameraParams {
    /// 640 x 480 px, f = 500 px (model-data.md, "Camera"), blind inside 0.5 m.
    fn default() -> Self {
        Self {
            width_px: 640.0,
            height_px: 480.0,
            focal_px: 500.0,
            min_range_m: 0.5,
        }
    }
}

/// The camera as mounted on the receiver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PinholeCamera {
    /// Intrinsics and limits.
    pub params: CameraParams,
    /// True optical centre relative to the CG, body axes, m.
    pub position_body_m: Vector3<f64>,
    /// True boresight pitch-down from the body x axis, rad.
    pub pitch_down_rad: f64,
    seq: u32,
}

impl PinholeCamera {
    /// A camera at `position_body_m`, boresight pitched down by `pitch_down_rad`.
    pub fn new(params: CameraParams, position_body_m: Vector3<f64>, pitch_down_rad: f64) -> Self {
        Self {
            params,
            position_body_m,
            pitch_down_rad,
            seq: 0,
        }
    }

    /// Rotation from camera axes to body axes.
    fn body_from_camera(&self) -> Matrix3<f64> {
        let (s, c) = self.pitch_down_rad.sin_cos();
        Matrix3::new(0.0, -s, c, 1.0, 0.0, 0.0, 0.0, c, s)
    }

    /// The drogue centre in camera axes, m.
    pub fn drogue_in_camera_m(
        &self,
        tanker: &Tanker,
        x: &ReceiverState,
        drogue_tanker_m: &Vector3<f64>,
        t_s: f64,
    ) -> Vector3<f64> {
        let cam_tanker = super::point_in_tanker_m(tanker, x, &self.position_body_m, t_s);
        let body = ned_from_body(x).inverse() * (drogue_tanker_m - cam_tanker);
        self.body_from_camera().transpose() * body
    }

    /// Takes one frame (the sequence number advances every call).
    pub fn capture(
        &mut self,
        tanker: &Tanker,
        x: &ReceiverState,
        drogue_tanker_m: &Vector3<f64>,
        t_s: f64,
    ) -> CameraMeasurement {
        self.seq = self.seq.wrapping_add(1);
        let p = self.drogue_in_camera_m(tanker, x, drogue_tanker_m, t_s);
        let (ix, iy) = (p.x / p.z, p.y / p.z);
        let half_x = self.params.width_px / 2.0 / self.params.focal_px;
        let half_y = self.params.height_px / 2.0 / self.params.focal_px;
        let visible = p.z >= self.params.min_range_m && ix.abs() <= half_x && iy.abs() <= half_y;
        if visible {
            CameraMeasurement {
                seq: self.seq,
                tracked: true,
                image_x: ix as f32,
                image_y: iy as f32,
                depth_m: p.z as f32,
            }
        } else {
            CameraMeasurement {
                seq: self.seq,
                tracked: false,
                image_x: 0.0,
                image_y: 0.0,
                depth_m: 0.0,
            }
        }
    }
}
