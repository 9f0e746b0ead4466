//! The ideal camera: a pinhole with no noise, no latency and no drops, a field of view and a
//! minimum range inside which it cannot see the drogue. The realistic one is
//! [`super::led_camera`].
//!
//! Invariant: with a perfectly calibrated lens ([`IntrinsicsError::NONE`]) the measurement is
//! the drogue centre in normalised image coordinates `(x_c / z_c, y_c / z_c)` and its depth
//! `z_c`, camera axes x right, y down, z boresight; `tracked` is false exactly when the drogue
//! is behind the camera, outside the field of view or closer than the minimum range. With a
//! lens error ([`super::lens`]) the point is rendered through the true lens and reported
//! through the calibration, and the depth is `z_c f / f_true`, the depth a range from the
//! drogue's apparent size would give (the distortion's effect on that size is the LED
//! camera's, which fits the ring; here it is left out).

use ibvs_core::measurement::CameraMeasurement;
use nalgebra::Vector3;

use super::led_camera::CameraPose;
use super::lens::{IntrinsicsError, Lens};

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
    /// The true lens minus the calibration above ([`super::lens`]; none by default).
    pub intrinsics_error: IntrinsicsError,
}

impl Default for CameraParams {
    /// 640 x 480 px, f = 500 px (docs/models.md, "Camera"), blind inside 0.5 m.
    fn default() -> Self {
        Self {
            width_px: 640.0,
            height_px: 480.0,
            focal_px: 500.0,
            min_range_m: 0.5,
            intrinsics_error: IntrinsicsError::NONE,
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
        if !self.params.intrinsics_error.is_none() {
            return self.capture_through_lens(&p);
        }
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

    /// The frame of a drogue at `p` (camera axes, m) through the true lens and the
    /// calibration (module doc); the sequence number is already advanced.
    fn capture_through_lens(&self, p: &Vector3<f64>) -> CameraMeasurement {
        let c = &self.params;
        let lens = Lens::new(
            c.focal_px,
            [c.width_px / 2.0, c.height_px / 2.0],
            c.intrinsics_error,
        );
        let image = |q: &Vector3<f64>| {
            lens.pixel(q)
                .filter(|&(u, v)| {
                    (0.0..=c.width_px).contains(&u) && (0.0..=c.height_px).contains(&v)
                })
                .map(|(u, v)| lens.normalised(u, v))
        };
        let seen = (p.z >= c.min_range_m).then(|| image(p)).flatten();
        match seen {
            Some((ix, iy)) => CameraMeasurement {
                seq: self.seq,
                tracked: true,
                image_x: ix as f32,
                image_y: iy as f32,
                depth_m: (p.z * lens.focal_ratio()) as f32,
                probe_tip: self
                    .probe_tip_camera_m
                    .and_then(|t| image(&t))
                    .map(|(x, y)| [x as f32, y as f32]),
            },
            None => CameraMeasurement {
                seq: self.seq,
                ..CameraMeasurement::default()
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3, Rotation3};

    /// A camera at the origin whose axes are the tanker's (the pose does not matter here).
    fn pose() -> CameraPose {
        CameraPose {
            position_tanker_m: Vector3::zeros(),
            tanker_from_camera: Rotation3::from_matrix_unchecked(Matrix3::identity()),
        }
    }

    fn capture(error: IntrinsicsError, p: &Vector3<f64>) -> CameraMeasurement {
        let mut c = PinholeCamera::new(CameraParams {
            intrinsics_error: error,
            ..CameraParams::default()
        });
        c.set_probe_tip(Some(Vector3::new(0.1, 0.2, 2.66)));
        c.capture(&pose(), p)
    }

    /// A focal-length error scales the image point by `f_true / f` and the depth by
    /// `f / f_true`; a principal-point error shifts the point by `error / f`.
    #[test]
    fn a_miscalibrated_ideal_camera_scales_and_shifts_its_point_and_depth() {
        let p = Vector3::new(0.9, -0.6, 6.0);
        let nominal = capture(IntrinsicsError::NONE, &p);
        assert_eq!(
            [nominal.image_x, nominal.image_y, nominal.depth_m],
            [0.15, -0.1, 6.0]
        );
        let long = capture(
            IntrinsicsError {
                focal_px: -5.0,
                ..IntrinsicsError::NONE
            },
            &p,
        );
        let k = 495.0 / 500.0;
        assert!(
            (f64::from(long.image_x) - 0.15 * k).abs() < 1e-7,
            "{long:?}"
        );
        assert!((f64::from(long.image_y) + 0.1 * k).abs() < 1e-7, "{long:?}");
        assert!((f64::from(long.depth_m) - 6.0 / k).abs() < 1e-5, "{long:?}");
        let tip = long.probe_tip.unwrap();
        assert!((f64::from(tip[0]) - 0.1 / 2.66 * k).abs() < 1e-7, "{tip:?}");
        let shifted = capture(
            IntrinsicsError {
                principal_px: [5.0, 2.5],
                ..IntrinsicsError::NONE
            },
            &p,
        );
        assert!(
            (f64::from(shifted.image_x) - 0.16).abs() < 1e-7,
            "{shifted:?}"
        );
        assert!(
            (f64::from(shifted.image_y) + 0.095).abs() < 1e-7,
            "{shifted:?}"
        );
        assert_eq!(shifted.depth_m, 6.0);
        // A point the shift moves out of the image is lost.
        let edge = Vector3::new(0.639 * 6.0, 0.0, 6.0);
        assert!(capture(IntrinsicsError::NONE, &edge).tracked);
        assert!(
            !capture(
                IntrinsicsError {
                    principal_px: [5.0, 0.0],
                    ..IntrinsicsError::NONE
                },
                &edge
            )
            .tracked
        );
    }
}
