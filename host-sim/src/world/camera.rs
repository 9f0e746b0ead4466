//! The ideal camera: a pinhole with no noise, no latency and no drops, a field of view and a
//! minimum range inside which it cannot see the drogue. The realistic one is
//! [`super::led_camera`].
//!
//! Invariant: the measurement is the drogue centre in normalised image coordinates
//! `(x_c / z_c, y_c / z_c)` and its depth `z_c`, camera axes x right, y down, z boresight;
//! `tracked` is false exactly when the drogue is behind the camera, outside the field of view
//! or closer than the minimum range.

use ibvs_core::measurement::CameraMeasurement;
use nalgebra::Vector3;

use super::led_camera::CameraPose;

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
    /// leaves the field of view and the fit degrades inside about a metre; docs/paper.md,
    /// item 7).
    pub min_range_m: f64,
}

impl Default for CameraParams {
    /// 640 x 480 px, f = 500 px (docs/models.md, "Camera"), blind inside 0.5 m.
    fn default() -> Self {
        Self {
            width_px: 640.0,
            height_px: 480.0,
            focal_px: 500.0,
            min_range_m: 0.5,
        }
    }
}

/// The ideal camera. Its pose comes from the caller ([`super::World::camera_pose`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PinholeCamera {
    /// Intrinsics and limits.
    pub params: CameraParams,
    /// The probe tip's marker in camera axes, m, when in view.
    probe_tip_camera_m: Option<Vector3<f64>>,
    seq: u32,
}

impl PinholeCamera {
    /// A camera with `params`; its first frame is number 1.
    pub fn new(params: CameraParams) -> Self {
        Self {
            params,
            probe_tip_camera_m: None,
            seq: 0,
        }
    }

    /// Shows the probe tip's marker, fixed at `tip_camera_m` in camera axes (m), in every
    /// frame (exactly, as the ideal camera sees everything); `None`: not in view.
    pub fn set_probe_tip(&mut self, tip_camera_m: Option<Vector3<f64>>) {
        self.probe_tip_camera_m = tip_camera_m.filter(|t| t.z > 0.0);
    }

    /// Takes one frame (the sequence number advances every call).
    pub fn capture(
        &mut self,
        pose: &CameraPose,
        drogue_tanker_m: &Vector3<f64>,
    ) -> CameraMeasurement {
        self.seq = self.seq.wrapping_add(1);
        let p = pose
            .tanker_from_camera
            .inverse_transform_vector(&(drogue_tanker_m - pose.position_tanker_m));
        let (ix, iy) = (p.x / p.z, p.y / p.z);
        let half_x = self.params.width_px / 2.0 / self.params.focal_px;
        let half_y = self.params.height_px / 2.0 / self.params.focal_px;
        let visible = p.z >= self.params.min_range_m && ix.abs() <= half_x && iy.abs() <= half_y;
        CameraMeasurement {
            seq: self.seq,
            tracked: visible,
            image_x: if visible { ix as f32 } else { 0.0 },
            image_y: if visible { iy as f32 } else { 0.0 },
            depth_m: if visible { p.z as f32 } else { 0.0 },
            probe_tip: self
                .probe_tip_camera_m
                .filter(|_| visible)
                .map(|t| [(t.x / t.z) as f32, (t.y / t.z) as f32]),
        }
    }
}
