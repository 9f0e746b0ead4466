//! The camera's lens as it is against the lens as it was calibrated: what a real camera's
//! intrinsics and residual distortion do to the image points the controller receives.
//!
//! A camera renders a point through its *true* lens (focal length, principal point, radial
//! distortion) into pixels, and the flight software turns pixels back into normalised image
//! coordinates with the *calibration* it was given (`docs/models.md`, "Camera"). The two differ
//! by [`IntrinsicsError`]: true minus calibrated focal length and principal point, and the
//! radial distortion the calibration leaves uncorrected (Brown's radial model, the "plumb bob"
//! of Bouguet's calibration toolbox, two terms):
//!
//! ```text
//! x_n = x_c / z_c,  y_n = y_c / z_c,  r^2 = x_n^2 + y_n^2
//! x_d = x_n (1 + k1 r^2 + k2 r^4)                     (and y_d likewise)
//! u = f_true x_d + c_u,true,  v = f_true y_d + c_v,true      (render)
//! reported = ((u - c_u) / f, (v - c_v) / f)                  (calibration)
//! ```
//!
//! So a focal-length error scales every reported point by `f_true / f` (and a depth measured
//! from the ring's size by `f / f_true`), a principal-point error shifts every point by
//! `error / f`, and distortion moves a point at radius `r` radially by `k1 r^3 + k2 r^5`.
//!
//! Field stop (ours): the radial map `r -> r (1 + k1 r^2 + k2 r^4)` stops increasing where
//! `1 + 3 k1 r^2 + 5 k2 r^4` reaches zero (barrel distortion); a point beyond that radius would
//! fold back into the image, which no lens does, so it is outside the lens's field
//! ([`Lens::pixel`] returns `None`). Without distortion there is no such radius.
//!
//! Invariants: with no error ([`IntrinsicsError::NONE`]) a pixel is computed by exactly the
//! arithmetic of the error-free camera (`f x_c / z_c + c`, in that order), so a run without
//! errors is bit for bit the run before this model existed; [`Lens::normalised`] is the
//! calibration's inverse of the error-free render.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// The true lens minus its calibration. Zero everywhere is a perfectly calibrated camera.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IntrinsicsError {
    /// True minus calibrated focal length, px.
    pub focal_px: f64,
    /// True minus calibrated principal point, `[u (right), v (down)]`, px.
    pub principal_px: [f64; 2],
    /// Radial distortion the calibration leaves uncorrected, `[k1, k2]` of
    /// `x_d = x_n (1 + k1 r^2 + k2 r^4)` on normalised coordinates, dimensionless.
    pub radial_k: [f64; 2],
}

impl IntrinsicsError {
    /// No error: the calibration is the lens.
    pub const NONE: Self = Self {
        focal_px: 0.0,
        principal_px: [0.0; 2],
        radial_k: [0.0; 2],
    };

    /// True when every error is zero.
    pub fn is_none(&self) -> bool {
        *self == Self::NONE
    }
}

/// A camera's projection: its true lens renders camera-axes points into pixels, its
/// calibration turns pixels into normalised image coordinates. See the module doc.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lens {
    /// Calibrated focal length, px.
    focal_px: f64,
    /// Calibrated principal point, px.
    principal_px: [f64; 2],
    /// True focal length, px.
    true_focal_px: f64,
    /// True principal point, px.
    true_principal_px: [f64; 2],
    /// Residual radial distortion `[k1, k2]`.
    radial_k: [f64; 2],
    /// Largest squared normalised radius the lens images (the fold of the radial map);
    /// infinite without distortion.
    max_r2: f64,
}

impl Lens {
    /// The lens of a camera calibrated at `focal_px` and `principal_px` (px) whose true lens
    /// differs from that by `error`.
    pub fn new(focal_px: f64, principal_px: [f64; 2], error: IntrinsicsError) -> Self {
        let [k1, k2] = error.radial_k;
        Self {
            focal_px,
            principal_px,
            true_focal_px: focal_px + error.focal_px,
            true_principal_px: [
                principal_px[0] + error.principal_px[0],
                principal_px[1] + error.principal_px[1],
            ],
            radial_k: error.radial_k,
            max_r2: fold_r2(k1, k2),
        }
    }

    /// True focal length, px.
    pub fn true_focal_px(&self) -> f64 {
        self.true_focal_px
    }

    /// True principal point, `[u, v]`, px.
    pub fn true_principal_px(&self) -> [f64; 2] {
        self.true_principal_px
    }

    /// Calibrated over true focal length: the factor on a depth measured from an apparent
    /// size (1 without a focal-length error).
    pub fn focal_ratio(&self) -> f64 {
        self.focal_px / self.true_focal_px
    }

    /// True when the lens has no distortion (its render is the pinhole's).
    fn is_pinhole(&self) -> bool {
        self.radial_k == [0.0; 2]
    }

    /// The pixel `(u, v)` (u right, v down, from the image's top-left corner) of a point at
    /// `p_camera_m` (camera axes, `z > 0`, m) through the true lens, or `None` beyond the
    /// lens's field stop (module doc). Whether the pixel is inside the image is the caller's.
    pub fn pixel(&self, p_camera_m: &Vector3<f64>) -> Option<(f64, f64)> {
        let p = p_camera_m;
        let (f, [cu, cv]) = (self.true_focal_px, self.true_principal_px);
        if self.is_pinhole() {
            // The error-free camera's arithmetic, in its order.
            return Some((f * p.x / p.z + cu, f * p.y / p.z + cv));
        }
        let (x, y) = (p.x / p.z, p.y / p.z);
        let r2 = x * x + y * y;
        // NaN (a point at infinity) is outside too.
        if r2.is_nan() || r2 > self.max_r2 {
            return None;
        }
        let [k1, k2] = self.radial_k;
        let factor = 1.0 + r2 * (k1 + k2 * r2);
        Some((f * (x * factor) + cu, f * (y * factor) + cv))
    }

    /// The normalised image coordinates the calibration gives pixel `(u, v)`:
    /// `((u - c_u) / f, (v - c_v) / f)` with the calibrated `f` and `c`.
    pub fn normalised(&self, u_px: f64, v_px: f64) -> (f64, f64) {
        (
            (u_px - self.principal_px[0]) / self.focal_px,
            (v_px - self.principal_px[1]) / self.focal_px,
        )
    }
}

/// The smallest `r^2 > 0` where `1 + 3 k1 r^2 + 5 k2 r^4` (the radial map's slope) vanishes;
/// infinity where it stays positive for every radius.
fn fold_r2(k1: f64, k2: f64) -> f64 {
    // 5 k2 s^2 + 3 k1 s + 1 = 0, s = r^2 > 0.
    let (a, b) = (5.0 * k2, 3.0 * k1);
    if a == 0.0 {
        return if b < 0.0 { -1.0 / b } else { f64::INFINITY };
    }
    let discriminant = b * b - 4.0 * a;
    if discriminant < 0.0 {
        return f64::INFINITY;
    }
    let root = discriminant.sqrt();
    [(-b - root) / (2.0 * a), (-b + root) / (2.0 * a)]
        .into_iter()
        .filter(|s| *s > 0.0)
        .fold(f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lens(error: IntrinsicsError) -> Lens {
        Lens::new(500.0, [320.0, 240.0], error)
    }

    #[test]
    fn without_error_the_render_is_the_pinhole_and_the_calibration_inverts_it() {
        let l = lens(IntrinsicsError::NONE);
        let p = Vector3::new(0.7, -0.31, 5.3);
        let (u, v) = l.pixel(&p).unwrap();
        assert_eq!(
            (u, v),
            (500.0 * p.x / p.z + 320.0, 500.0 * p.y / p.z + 240.0)
        );
        let (x, y) = l.normalised(u, v);
        assert!((x - p.x / p.z).abs() < 1e-15 && (y - p.y / p.z).abs() < 1e-15);
        assert_eq!(l.focal_ratio(), 1.0);
    }

    #[test]
    fn a_focal_error_scales_and_a_principal_point_error_shifts_every_point() {
        let p = Vector3::new(1.2, 0.4, 6.0);
        let (x, y) = (p.x / p.z, p.y / p.z);
        let scaled = lens(IntrinsicsError {
            focal_px: 5.0,
            ..IntrinsicsError::NONE
        });
        let (u, v) = scaled.pixel(&p).unwrap();
        let (xr, yr) = scaled.normalised(u, v);
        assert!((xr / x - 1.01).abs() < 1e-12 && (yr / y - 1.01).abs() < 1e-12);
        assert!((scaled.focal_ratio() - 500.0 / 505.0).abs() < 1e-15);
        let shifted = lens(IntrinsicsError {
            principal_px: [4.0, -3.0],
            ..IntrinsicsError::NONE
        });
        let (u, v) = shifted.pixel(&p).unwrap();
        let (xr, yr) = shifted.normalised(u, v);
        assert!((xr - x - 4.0 / 500.0).abs() < 1e-12);
        assert!((yr - y + 3.0 / 500.0).abs() < 1e-12);
    }

    #[test]
    fn distortion_moves_a_point_radially_by_k1_r3_plus_k2_r5() {
        let (k1, k2) = (-0.01, 0.02);
        let l = lens(IntrinsicsError {
            radial_k: [k1, k2],
            ..IntrinsicsError::NONE
        });
        // An off-axis point at normalised (0.3, -0.4): r = 0.5.
        let p = Vector3::new(1.5, -2.0, 5.0);
        let (u, v) = l.pixel(&p).unwrap();
        let (xr, yr) = l.normalised(u, v);
        let r = 0.5_f64;
        let moved = (xr * xr + yr * yr).sqrt() - r;
        let predicted = k1 * r.powi(3) + k2 * r.powi(5);
        assert!((moved - predicted).abs() < 1e-14, "{moved} vs {predicted}");
        // Radially: the direction is kept.
        assert!((yr / xr - (-0.4 / 0.3)).abs() < 1e-12);
        // On the axis nothing moves.
        let (u0, v0) = l.pixel(&Vector3::new(0.0, 0.0, 4.0)).unwrap();
        assert_eq!((u0, v0), (320.0, 240.0));
    }

    #[test]
    fn barrel_distortion_has_a_field_stop_where_the_radial_map_folds() {
        // k1 < 0, k2 = 0: the slope 1 + 3 k1 r^2 vanishes at r^2 = -1 / (3 k1).
        let l = lens(IntrinsicsError {
            radial_k: [-0.2, 0.0],
            ..IntrinsicsError::NONE
        });
        let stop = (1.0_f64 / 0.6).sqrt();
        assert!(l.pixel(&Vector3::new(stop - 1e-6, 0.0, 1.0)).is_some());
        assert!(l.pixel(&Vector3::new(stop + 1e-6, 0.0, 1.0)).is_none());
        // Pincushion, and the pinhole: no stop.
        assert_eq!(fold_r2(0.1, 0.05), f64::INFINITY);
        assert_eq!(fold_r2(0.0, 0.0), f64::INFINITY);
        // Both terms: the smallest positive root of 5 k2 s^2 + 3 k1 s + 1.
        let s = fold_r2(0.1, -0.3);
        assert!((1.0 + 3.0 * 0.1 * s + 5.0 * -0.3 * s * s).abs() < 1e-12 && s > 0.0);
    }
}
