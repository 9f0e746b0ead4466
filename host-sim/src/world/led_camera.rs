//! A realistic drogue camera: it images the drogue's LED ring, fits a circle to the LED
//! centroids and reports the circle's centre as the image point and `f R / r_px` as the depth,
//! as the paper's authors did (`docs/models.md`, "Camera"), on its own clock, with noise,
//! quantisation, latency, frame drops and field-of-view loss.
//!
//! Source: `docs/models.md`, "Camera" (8 LEDs on a 0.33 m ring, depth = f R / r_px; our
//! defaults 640 x 480 px, f = 500 px, 50 Hz, 0.5 px noise, one frame of latency). Judgement, ours:
//! 0.1 px centroid quantisation (sub-pixel centroiding), LEDs closer than 0.1 m along the
//! boresight are lost, 3 LEDs at least for a fit, and the algebraic (Kasa) circle fit alone:
//! Gauss-Newton refinement of the geometric fit ([`refine_circle_geometric`],
//! `geometric_iterations`) is available but off, because with 8 LEDs and sub-pixel noise it
//! changed neither bias nor spread measurably (radius bias within 0.2 px either way, rms
//! within 3 %, slightly worse on partial rings), while Kasa is closed-form and exact for 3 LEDs.
//!
//! Frames (`docs/conventions.md`): the caller gives the camera pose, the drogue centre and
//! the drogue axis in the tanker frame (x forward, y right, z down, m). Camera axes: x image
//! right, y image down, z boresight. Pixels are `u = f x_c / z_c + c_x`, `v = f y_c / z_c +
//! c_y`, origin at the image's top-left corner; the measurement is normalised,
//! `((u - c_x) / f, (v - c_y) / f)`. Those are the calibration's `f` and `c`: the LEDs and the
//! probe tip's marker are rendered through the true lens, which differs from the calibration
//! by `intrinsics_error` (focal length, principal point, residual radial distortion;
//! [`super::lens`]), so a miscalibrated camera's errors reach the measurement as they would
//! (the depth `f R / r_px` included). Without an error the render is the formula above.
//!
//! The ring: `led_count` LEDs equally spaced on a circle of radius `ring_radius_m` around the
//! drogue centre, in the plane perpendicular to the drogue axis (the axis points from the hose
//! toward the drogue, i.e. aft for a trailing drogue). LED `k` sits at angle
//! `ring_phase_rad + 2 pi k / led_count` from the in-plane direction `e1 = a x e2`, where `e2`
//! is tanker down (+z) made perpendicular to the axis `a`. For a drogue trailing straight aft
//! (`a = -x`) `e1` is tanker right and `e2` tanker down, so LED 0 is at the ring's right and
//! LED 2 (of 8) at its bottom.
//!
//! Bias of the fit (noise-free, measured in the tests): a ring parallel to the image plane
//! images to an exact circle centred on the image of the drogue centre, so the fit is exact at
//! any depth and lateral offset. A ring whose axis (pointing at the camera, `-z_c`) leans by
//! `theta` toward image direction `psi` (0 right, 90 deg down) images to an ellipse. With the
//! drogue centre at normalised `(x, y)`, the relative depth error is about
//! `((1 - cos theta) + sin theta (x cos psi + y sin psi)) / 2` (second-order terms add at most
//! 0.26 points at 2..10 m, 10 deg): +0.76 % on the boresight at 10 deg, but first order in the
//! tilt off the boresight (+5.4 % at 10 deg with `x` = 0.53, -3.8 % leaning the other way;
//! worst 5.9 % over 2..10 m with the ring in view). The image point is shifted by about
//! `-(R / z)^2 sin theta (cos psi, sin psi)` (normalised; 5.2e-4 at 6 m, 4.7e-3 at 2 m for
//! 10 deg, i.e. `R^2 sin theta / z` = 3 mm and 9 mm at the drogue).
//!
//! Noise (default 0.5 px and 0.1 px quantisation, drogue on the boresight, measured): image
//! point spread 5.0e-4 (0.25 px) at any range, bias below 1e-5; depth spread 0.63 % (38 mm) at
//! 6 m and 0.105 % (1 mm) at 1 m, bias -0.04 % and -0.003 %. Closing on a centred drogue, the
//! LEDs leave the image at 0.69 m (top and bottom), 0.52 m (sides) and 0.486 m (diagonals):
//! the ring is tracked down to 0.486 m, with 4 LEDs below 0.52 m.
//!
//! Invariants:
//! - A frame is `tracked` exactly when at least `min_visible_leds` LEDs are visible and the
//!   circle fit of their measured centroids succeeds (not collinear, finite, positive radius).
//! - Frame `seq` counts captured frames from 1, dropped ones included; [`LedCamera::latest`]
//!   returns the newest frame whose delivery time (capture + latency) has passed, the same
//!   frame (same `seq`) until a newer one is delivered, and `seq` 0 untracked before the first.
//! - Every captured frame draws the same number of random numbers (one uniform for the drop,
//!   two normals per LED), so the noise does not depend on which LEDs were visible; a run is
//!   reproducible from the seed.
//! - No allocation per frame: LED arrays are fixed-size ([`MAX_LEDS`]) and the delivery queue
//!   is allocated once, in [`LedCamera::new`].

use std::collections::VecDeque;
use std::f64::consts::TAU;

use ibvs_core::measurement::CameraMeasurement;
use nalgebra::{Matrix3, Rotation3, Vector2, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use super::lens::{IntrinsicsError, Lens};

/// Largest LED count the fixed-size per-frame arrays hold.
pub const MAX_LEDS: usize = 32;
/// Largest latency, frames (bounds the delivery queue allocated at construction).
pub const MAX_LATENCY_FRAMES: u32 = 1000;
/// Fewest points that determine a circle.
pub const MIN_CIRCLE_POINTS: usize = 3;

/// Default LED count on the drogue ring (`docs/models.md`, "Camera").
pub const DEFAULT_LED_COUNT: usize = 8;
/// Default LED ring radius, m (`docs/models.md`, "Camera").
pub const DEFAULT_RING_RADIUS_M: f64 = 0.33;
/// Default image width, px (`docs/models.md`, "Camera", our judgement).
pub const DEFAULT_WIDTH_PX: f64 = 640.0;
/// Default image height, px (`docs/models.md`, "Camera", our judgement).
pub const DEFAULT_HEIGHT_PX: f64 = 480.0;
/// Default focal length, px (`docs/models.md`, "Camera", our judgement).
pub const DEFAULT_FOCAL_PX: f64 = 500.0;
/// Default standard deviation of each LED centroid's pixel noise, per axis, px
/// (`docs/models.md`, "Camera", our judgement).
pub const DEFAULT_PIXEL_NOISE_PX: f64 = 0.5;
/// Default quantisation step of the LED centroids, px (judgement: sub-pixel centroiding of a
/// blob resolves about a tenth of a pixel).
pub const DEFAULT_QUANTISATION_PX: f64 = 0.1;
/// Default depth along the boresight below which an LED is lost, m (judgement: the LED is
/// out of focus and at the lens).
pub const DEFAULT_MIN_LED_DEPTH_M: f64 = 0.1;
/// Default camera frame rate, Hz (`docs/models.md`, "Camera").
pub const DEFAULT_RATE_HZ: f64 = 50.0;
/// Default latency, frames (`docs/models.md`, "Camera", our judgement).
pub const DEFAULT_LATENCY_FRAMES: u32 = 1;
/// Default number of Gauss-Newton iterations of the geometric circle fit after the algebraic
/// fit: none (module doc, "Source").
pub const DEFAULT_GEOMETRIC_ITERATIONS: u32 = 0;

/// Collinearity threshold of the circle fit: the point set is degenerate when
/// `4 det(S) / trace(S)^2` of its centred scatter matrix `S` is below this (1 for points
/// spread evenly round a circle, 0 for collinear points; 1e-6 is a deviation from a line of
/// about 1e-3 of the set's length, i.e. a radius of about 100 times its length).
const COLLINEARITY_TOLERANCE: f64 = 1e-6;
/// Gauss-Newton stops when a step moves the circle by less than this fraction of its radius.
const GEOMETRIC_STEP_TOLERANCE: f64 = 1e-12;
/// Times within this of each other are equal (absorbs rounding in `n * Ts` clocks), s.
const TIME_TOLERANCE_S: f64 = 1e-9;
/// The drogue axis is too close to vertical to take tanker down as the in-plane reference
/// when the reference's component perpendicular to the axis is shorter than this.
const AXIS_REFERENCE_MIN: f64 = 1e-6;

/// A circle in the image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Circle {
    /// Centre, px (u right, v down, from the image's top-left corner).
    pub centre_px: Vector2<f64>,
    /// Radius, px.
    pub radius_px: f64,
}

/// The algebraic (Kasa) circle fit, the one the camera uses: minimises `sum (|p - c|^2 - r^2)^2`, a linear least
/// squares problem, solved in centred and scaled coordinates.
///
/// Returns `None` for fewer than [`MIN_CIRCLE_POINTS`] points, non-finite points, coincident
/// or collinear points (see the collinearity threshold in the module source), or a
/// non-finite result. Exact for three non-collinear points and for points on a circle.
pub fn fit_circle(points_px: &[Vector2<f64>]) -> Option<Circle> {
    let n = points_px.len();
    if n < MIN_CIRCLE_POINTS
        || points_px
            .iter()
            .any(|p| !(p.x.is_finite() && p.y.is_finite()))
    {
        return None;
    }
    let nf = n as f64;
    let mean = points_px.iter().sum::<Vector2<f64>>() / nf;
    let spread = points_px
        .iter()
        .map(|p| (p - mean).norm_squared())
        .sum::<f64>()
        / nf;
    if spread.is_nan() || spread <= 0.0 {
        return None;
    }
    let scale = spread.sqrt();
    let (mut suu, mut suv, mut svv) = (0.0, 0.0, 0.0);
    let (mut suuu, mut suvv, mut suuv, mut svvv) = (0.0, 0.0, 0.0, 0.0);
    for p in points_px {
        let q = (p - mean) / scale;
        let (u, v) = (q.x, q.y);
        suu += u * u;
        suv += u * v;
        svv += v * v;
        suuu += u * u * u;
        suvv += u * v * v;
        suuv += u * u * v;
        svvv += v * v * v;
    }
    let det = suu * svv - suv * suv;
    let trace = suu + svv;
    let isotropy = 4.0 * det / (trace * trace);
    if isotropy.is_nan() || isotropy < COLLINEARITY_TOLERANCE {
        return None;
    }
    let bu = 0.5 * (suuu + suvv);
    let bv = 0.5 * (suuv + svvv);
    let uc = (bu * svv - bv * suv) / det;
    let vc = (suu * bv - suv * bu) / det;
    let radius_sq = uc * uc + vc * vc + trace / nf;
    let circle = Circle {
        centre_px: mean + Vector2::new(uc, vc) * scale,
        radius_px: radius_sq.sqrt() * scale,
    };
    let finite = circle.centre_px.x.is_finite()
        && circle.centre_px.y.is_finite()
        && circle.radius_px.is_finite();
    (finite && circle.radius_px > 0.0).then_some(circle)
}

/// Sum of squared geometric distances of the points from `circle`, px^2.
fn geometric_cost(points_px: &[Vector2<f64>], circle: &Circle) -> f64 {
    points_px
        .iter()
        .map(|p| ((p - circle.centre_px).norm() - circle.radius_px).powi(2))
        .sum()
}

/// Refines `initial` by at most `max_iterations` Gauss-Newton steps of the geometric fit,
/// which minimises `sum (|p - c| - r)^2` (the maximum-likelihood circle for isotropic
/// Gaussian centroid noise).
///
/// A step is accepted only if it is finite, keeps the radius positive and does not increase
/// the cost, so the result is never worse than `initial`; it stops early once a step moves the
/// circle by less than 1e-12 of its radius, or when a point lies at the centre.
pub fn refine_circle_geometric(
    points_px: &[Vector2<f64>],
    initial: &Circle,
    max_iterations: u32,
) -> Circle {
    let mut circle = *initial;
    let mut cost = geometric_cost(points_px, &circle);
    for _ in 0..max_iterations {
        let mut jtj = Matrix3::<f64>::zeros();
        let mut jtr = Vector3::<f64>::zeros();
        for p in points_px {
            let d = p - circle.centre_px;
            let dist = d.norm();
            if dist.is_nan() || dist <= 0.0 {
                return circle;
            }
            let j = Vector3::new(-d.x / dist, -d.y / dist, -1.0);
            jtj += j * j.transpose();
            jtr += j * (dist - circle.radius_px);
        }
        let Some(step) = jtj.cholesky().map(|c| c.solve(&(-jtr))) else {
            break;
        };
        let candidate = Circle {
            centre_px: circle.centre_px + Vector2::new(step.x, step.y),
            radius_px: circle.radius_px + step.z,
        };
        let candidate_cost = geometric_cost(points_px, &candidate);
        if !(candidate.radius_px > 0.0 && candidate_cost <= cost) {
            break;
        }
        circle = candidate;
        cost = candidate_cost;
        if step.norm() <= GEOMETRIC_STEP_TOLERANCE * circle.radius_px {
            break;
        }
    }
    circle
}

/// Everything configurable about the LED camera. Units in the field names.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LedCameraParams {
    /// Image width, px.
    pub width_px: f64,
    /// Image height, px.
    pub height_px: f64,
    /// Focal length, px.
    pub focal_px: f64,
    /// Principal point, u (right), px from the left edge.
    pub principal_u_px: f64,
    /// Principal point, v (down), px from the top edge.
    pub principal_v_px: f64,
    /// LEDs on the ring, 3..=[`MAX_LEDS`].
    pub led_count: usize,
    /// Ring radius, m.
    pub ring_radius_m: f64,
    /// Angle of LED 0 from the ring's in-plane reference `e1` toward `e2`, rad (module doc).
    pub ring_phase_rad: f64,
    /// Standard deviation of each LED centroid's Gaussian noise, per pixel axis, px (0: none).
    pub pixel_noise_px: f64,
    /// Quantisation step of the LED centroids, px (0: none).
    pub quantisation_px: f64,
    /// An LED closer than this along the boresight (or behind the camera) is lost, m.
    pub min_led_depth_m: f64,
    /// Fewest visible LEDs for a tracked frame, 3..=`led_count`.
    pub min_visible_leds: usize,
    /// Geometric (Gauss-Newton) iterations after the algebraic circle fit (0: Kasa only).
    pub geometric_iterations: u32,
    /// Frame rate, Hz.
    pub rate_hz: f64,
    /// Time from the first `update` call to the first capture, s, in `[0, 1 / rate_hz)`:
    /// the phase of the camera's clock against the caller's.
    pub clock_offset_s: f64,
    /// Latency from capture to delivery, frames (`latency_frames / rate_hz` seconds),
    /// at most [`MAX_LATENCY_FRAMES`].
    pub latency_frames: u32,
    /// Probability that a captured frame is never delivered, independently per frame, in
    /// `[0, 1)`.
    pub drop_probability: f64,
    /// The true lens minus the calibration (`focal_px`, `principal_u_px`, `principal_v_px`,
    /// no distortion) the measurement is computed with ([`super::lens`]); none by default.
    pub intrinsics_error: IntrinsicsError,
}

impl Default for LedCameraParams {
    /// 640 x 480 px, f = 500 px, principal point at the centre, 8 LEDs on a 0.33 m ring,
    /// 0.5 px noise, 0.1 px quantisation, 50 Hz, one frame of latency, no drops.
    fn default() -> Self {
        Self {
            width_px: DEFAULT_WIDTH_PX,
            height_px: DEFAULT_HEIGHT_PX,
            focal_px: DEFAULT_FOCAL_PX,
            principal_u_px: DEFAULT_WIDTH_PX / 2.0,
            principal_v_px: DEFAULT_HEIGHT_PX / 2.0,
            led_count: DEFAULT_LED_COUNT,
            ring_radius_m: DEFAULT_RING_RADIUS_M,
            ring_phase_rad: 0.0,
            pixel_noise_px: DEFAULT_PIXEL_NOISE_PX,
            quantisation_px: DEFAULT_QUANTISATION_PX,
            min_led_depth_m: DEFAULT_MIN_LED_DEPTH_M,
            min_visible_leds: MIN_CIRCLE_POINTS,
            geometric_iterations: DEFAULT_GEOMETRIC_ITERATIONS,
            rate_hz: DEFAULT_RATE_HZ,
            clock_offset_s: 0.0,
            latency_frames: DEFAULT_LATENCY_FRAMES,
            drop_probability: 0.0,
            intrinsics_error: IntrinsicsError::NONE,
        }
    }
}

/// An invalid [`LedCameraParams`] field.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum CameraError {
    /// Image width or height not finite and positive.
    #[error("image size must be finite and positive, got {width_px} x {height_px} px")]
    ImageSize {
        /// Width given, px.
        width_px: f64,
        /// Height given, px.
        height_px: f64,
    },
    /// Focal length not finite and positive.
    #[error("focal length must be finite and positive, got {0} px")]
    FocalLength(f64),
    /// Principal point outside the image.
    #[error("principal point ({u_px}, {v_px}) px is outside the image")]
    PrincipalPoint {
        /// u given, px.
        u_px: f64,
        /// v given, px.
        v_px: f64,
    },
    /// LED count outside 3..=[`MAX_LEDS`].
    #[error("LED count must be {MIN_CIRCLE_POINTS}..={MAX_LEDS}, got {0}")]
    LedCount(usize),
    /// Ring radius not finite and positive.
    #[error("ring radius must be finite and positive, got {0} m")]
    RingRadius(f64),
    /// Ring phase not finite.
    #[error("ring phase must be finite, got {0} rad")]
    RingPhase(f64),
    /// Pixel noise not finite and non-negative.
    #[error("pixel noise must be finite and non-negative, got {0} px")]
    PixelNoise(f64),
    /// Quantisation step not finite and non-negative.
    #[error("quantisation step must be finite and non-negative, got {0} px")]
    Quantisation(f64),
    /// Minimum LED depth not finite and non-negative.
    #[error("minimum LED depth must be finite and non-negative, got {0} m")]
    MinLedDepth(f64),
    /// Minimum visible LEDs outside 3..=`led_count`.
    #[error("minimum visible LEDs must be {MIN_CIRCLE_POINTS}..={led_count}, got {min}")]
    MinVisibleLeds {
        /// Value given.
        min: usize,
        /// The LED count it must not exceed.
        led_count: usize,
    },
    /// Frame rate not finite and positive.
    #[error("frame rate must be finite and positive, got {0} Hz")]
    Rate(f64),
    /// Clock offset outside `[0, 1 / rate_hz)`.
    #[error("clock offset must be in [0, one frame period), got {0} s")]
    ClockOffset(f64),
    /// Latency above [`MAX_LATENCY_FRAMES`].
    #[error("latency must be at most {MAX_LATENCY_FRAMES} frames, got {0}")]
    Latency(u32),
    /// Drop probability outside `[0, 1)`.
    #[error("drop probability must be in [0, 1), got {0}")]
    DropProbability(f64),
    /// The true lens (calibration plus `intrinsics_error`) is not a lens: a focal length not
    /// finite and positive, a principal point outside the image, or a distortion not finite.
    #[error(
        "the true lens (calibration plus error {error:?}) must have a finite, positive focal \
         length, its principal point inside the image and finite distortion"
    )]
    TrueLens {
        /// The error given.
        error: IntrinsicsError,
    },
}

impl LedCameraParams {
    /// Checks every field; the first invalid one is named.
    pub fn validate(&self) -> Result<(), CameraError> {
        let positive = |x: f64| x.is_finite() && x > 0.0;
        let non_negative = |x: f64| x.is_finite() && x >= 0.0;
        if !(positive(self.width_px) && positive(self.height_px)) {
            return Err(CameraError::ImageSize {
                width_px: self.width_px,
                height_px: self.height_px,
            });
        }
        if !positive(self.focal_px) {
            return Err(CameraError::FocalLength(self.focal_px));
        }
        let inside = |x: f64, max: f64| x.is_finite() && (0.0..=max).contains(&x);
        if !(inside(self.principal_u_px, self.width_px)
            && inside(self.principal_v_px, self.height_px))
        {
            return Err(CameraError::PrincipalPoint {
                u_px: self.principal_u_px,
                v_px: self.principal_v_px,
            });
        }
        if !(MIN_CIRCLE_POINTS..=MAX_LEDS).contains(&self.led_count) {
            return Err(CameraError::LedCount(self.led_count));
        }
        if !positive(self.ring_radius_m) {
            return Err(CameraError::RingRadius(self.ring_radius_m));
        }
        if !self.ring_phase_rad.is_finite() {
            return Err(CameraError::RingPhase(self.ring_phase_rad));
        }
        if !non_negative(self.pixel_noise_px) {
            return Err(CameraError::PixelNoise(self.pixel_noise_px));
        }
        if !non_negative(self.quantisation_px) {
            return Err(CameraError::Quantisation(self.quantisation_px));
        }
        if !non_negative(self.min_led_depth_m) {
            return Err(CameraError::MinLedDepth(self.min_led_depth_m));
        }
        if !(MIN_CIRCLE_POINTS..=self.led_count).contains(&self.min_visible_leds) {
            return Err(CameraError::MinVisibleLeds {
                min: self.min_visible_leds,
                led_count: self.led_count,
            });
        }
        if !positive(self.rate_hz) {
            return Err(CameraError::Rate(self.rate_hz));
        }
        if !(self.clock_offset_s >= 0.0 && self.clock_offset_s < 1.0 / self.rate_hz) {
            return Err(CameraError::ClockOffset(self.clock_offset_s));
        }
        if self.latency_frames > MAX_LATENCY_FRAMES {
            return Err(CameraError::Latency(self.latency_frames));
        }
        if !(self.drop_probability >= 0.0 && self.drop_probability < 1.0) {
            return Err(CameraError::DropProbability(self.drop_probability));
        }
        let lens = self.lens();
        let [u, v] = lens.true_principal_px();
        if !(positive(lens.true_focal_px())
            && inside(u, self.width_px)
            && inside(v, self.height_px)
            && self.intrinsics_error.radial_k.iter().all(|k| k.is_finite()))
        {
            return Err(CameraError::TrueLens {
                error: self.intrinsics_error,
            });
        }
        Ok(())
    }

    /// Frame period, s.
    pub fn period_s(&self) -> f64 {
        1.0 / self.rate_hz
    }

    /// Latency, s.
    pub fn latency_s(&self) -> f64 {
        f64::from(self.latency_frames) / self.rate_hz
    }

    /// The lens: the calibration of these parameters and the true lens it misses.
    pub fn lens(&self) -> Lens {
        Lens::new(
            self.focal_px,
            [self.principal_u_px, self.principal_v_px],
            self.intrinsics_error,
        )
    }
}

/// The camera's pose in the tanker frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraPose {
    /// Optical centre, tanker frame, m.
    pub position_tanker_m: Vector3<f64>,
    /// Rotation from camera axes (x right, y down, z boresight) to tanker axes.
    pub tanker_from_camera: Rotation3<f64>,
}

/// The truth behind a delivered frame: the drogue centre as an ideal camera saw it at the
/// frame's capture time (no noise, no fit).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrueFeature {
    /// Sequence number of the frame.
    pub seq: u32,
    /// Capture time, s (the caller's clock).
    pub capture_time_s: f64,
    /// Drogue centre, normalised image x (`x_c / z_c`); NaN when `depth_m <= 0`.
    pub image_x: f64,
    /// Drogue centre, normalised image y (`y_c / z_c`); NaN when `depth_m <= 0`.
    pub image_y: f64,
    /// Depth of the drogue centre along the boresight (`z_c`), m.
    pub depth_m: f64,
    /// Drogue centre in camera axes, m.
    pub drogue_camera_m: Vector3<f64>,
}

/// What the camera sees at one instant: its pose and the drogue.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Scene {
    pose: CameraPose,
    drogue_centre_tanker_m: Vector3<f64>,
    drogue_axis_tanker: Vector3<f64>,
}

impl Scene {
    /// Linear interpolation (slerp for the attitude) from `self` at `s = 0` to `other` at
    /// `s = 1`.
    fn interpolate(&self, other: &Scene, s: f64) -> Scene {
        let lerp = |a: &Vector3<f64>, b: &Vector3<f64>| a + (b - a) * s;
        let rotation = self
            .pose
            .tanker_from_camera
            .try_slerp(&other.pose.tanker_from_camera, s, 0.0)
            .unwrap_or(other.pose.tanker_from_camera);
        Scene {
            pose: CameraPose {
                position_tanker_m: lerp(
                    &self.pose.position_tanker_m,
                    &other.pose.position_tanker_m,
                ),
                tanker_from_camera: rotation,
            },
            drogue_centre_tanker_m: lerp(
                &self.drogue_centre_tanker_m,
                &other.drogue_centre_tanker_m,
            ),
            drogue_axis_tanker: lerp(&self.drogue_axis_tanker, &other.drogue_axis_tanker),
        }
    }
}

/// What one frame's image held: the measured centroids of the visible LEDs and the circle
/// fitted to them, from which the frame's measurement was computed (kept for logs and
/// animations; nothing in the loop reads it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LedImage {
    centroids_px: [Vector2<f64>; MAX_LEDS],
    visible: usize,
    /// The fitted circle, px; `None` exactly when the frame is not tracked.
    pub circle: Option<Circle>,
}

impl LedImage {
    /// The visible LEDs' measured centroids (noise and quantisation included), px (u right,
    /// v down, from the image's top-left corner), in LED order.
    pub fn centroids_px(&self) -> &[Vector2<f64>] {
        &self.centroids_px[..self.visible]
    }
}

/// One captured frame on its way to the caller.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Frame {
    delivery_time_s: f64,
    measurement: CameraMeasurement,
    truth: TrueFeature,
    image: LedImage,
}

/// In-plane unit vectors `(e1, e2)` of a ring perpendicular to `axis` (module doc), or `None`
/// for a zero or non-finite axis.
fn ring_basis(axis: &Vector3<f64>) -> Option<(Vector3<f64>, Vector3<f64>)> {
    let norm = axis.norm();
    if !(norm.is_finite() && norm > 0.0) {
        return None;
    }
    let a = axis / norm;
    let perpendicular = |r: Vector3<f64>| r - a * a.dot(&r);
    let mut e2 = perpendicular(Vector3::z());
    if e2.norm() < AXIS_REFERENCE_MIN {
        e2 = perpendicular(Vector3::x());
    }
    let e2 = e2.normalize();
    Some((a.cross(&e2), e2))
}

/// Rounds `x` to the nearest multiple of `step` (no rounding for `step` 0).
fn quantise(x: f64, step: f64) -> f64 {
    if step > 0.0 {
        (x / step).round() * step
    } else {
        x
    }
}

/// The LED ring camera. See the module doc for the model and its invariants.
#[derive(Debug, Clone)]
pub struct LedCamera {
    /// The probe tip's marker in camera axes, m, when it is in view (a set-back camera).
    probe_tip_camera_m: Option<Vector3<f64>>,
    params: LedCameraParams,
    /// The true lens and the calibration (from `params`).
    lens: Lens,
    rng: ChaCha8Rng,
    /// Time of the first `update` call: the camera's clock origin, s.
    clock_origin_s: Option<f64>,
    /// Index of the next capture (0 for the first).
    next_capture: u64,
    /// Sequence number of the last captured frame (0: none yet).
    last_seq: u32,
    /// Frames captured and dropped since construction.
    dropped: u64,
    /// The last `update` call's time and scene, for interpolation.
    previous: Option<(f64, Scene)>,
    /// Captured, not dropped, not yet delivered frames, oldest first.
    in_flight: VecDeque<Frame>,
    /// The newest delivered frame.
    latest: Option<Frame>,
    /// LEDs hidden from the camera (bit `k`: LED `k`; fault injection).
    occluded: u32,
}

impl LedCamera {
    /// A camera with `params`, its noise and drops seeded by `seed`
    /// (`ChaCha8Rng::seed_from_u64`).
    pub fn new(params: LedCameraParams, seed: u64) -> Result<Self, CameraError> {
        params.validate()?;
        // Frames in flight at any time: those captured within the last latency, plus one
        // captured in the same call before the queue is drained.
        let capacity = params.latency_frames as usize + 2;
        Ok(Self {
            params,
            lens: params.lens(),
            rng: ChaCha8Rng::seed_from_u64(seed),
            clock_origin_s: None,
            next_capture: 0,
            last_seq: 0,
            dropped: 0,
            previous: None,
            in_flight: VecDeque::with_capacity(capacity),
            latest: None,
            occluded: 0,
            probe_tip_camera_m: None,
        })
    }

    /// Shows the probe tip's marker, fixed at `tip_camera_m` in camera axes (m), in every
    /// frame from now on (`None`: no marker in view, a camera at the tip). It is imaged
    /// with the LEDs' noise and quantisation and reported with the ring's fit; its noise is
    /// drawn in every frame, marker or not, so the rest of the run's noise does not depend
    /// on it.
    pub fn set_probe_tip(&mut self, tip_camera_m: Option<Vector3<f64>>) {
        self.probe_tip_camera_m = tip_camera_m.filter(|t| t.z > 0.0);
    }

    /// The parameters.
    pub fn params(&self) -> &LedCameraParams {
        &self.params
    }

    /// Hides the LEDs whose bits are set in `mask` (bit `k`: LED `k`) from the frames
    /// captured from now on (fault injection: something between the camera and the ring).
    /// The random draws per frame do not change, so the rest of the run's noise is the same.
    pub fn set_occlusion(&mut self, mask: u32) {
        self.occluded = mask;
    }

    /// Advances the camera to time `t_s` (s, the caller's clock, non-decreasing): captures
    /// every frame due since the last call and delivers every frame whose delivery time has
    /// passed. Call it every control step with the current truth: camera pose, drogue centre
    /// (tanker frame, m) and drogue axis (tanker frame, from hose toward drogue, any non-zero
    /// length).
    ///
    /// The camera's clock starts at the first call (first capture `clock_offset_s` later).
    /// A frame captured between two calls sees the scene interpolated linearly between them
    /// (attitude by slerp, axis by normalised lerp); a call at an earlier time than the
    /// previous one, or at a non-finite time, is ignored.
    pub fn update(
        &mut self,
        t_s: f64,
        pose: &CameraPose,
        drogue_centre_tanker_m: &Vector3<f64>,
        drogue_axis_tanker: &Vector3<f64>,
    ) {
        if !t_s.is_finite() || self.previous.is_some_and(|(t_prev, _)| t_s < t_prev) {
            return;
        }
        let now = Scene {
            pose: *pose,
            drogue_centre_tanker_m: *drogue_centre_tanker_m,
            drogue_axis_tanker: *drogue_axis_tanker,
        };
        let origin = *self.clock_origin_s.get_or_insert(t_s);
        loop {
            let capture_time_s = origin
                + self.params.clock_offset_s
                + self.next_capture as f64 / self.params.rate_hz;
            if capture_time_s > t_s + TIME_TOLERANCE_S {
                break;
            }
            let scene = match self.previous {
                Some((t_prev, prev)) if t_s > t_prev => {
                    let s = ((capture_time_s - t_prev) / (t_s - t_prev)).clamp(0.0, 1.0);
                    prev.interpolate(&now, s)
                }
                _ => now,
            };
            self.next_capture += 1;
            self.last_seq = self.last_seq.wrapping_add(1);
            self.capture(capture_time_s, &scene);
            self.deliver(t_s);
        }
        self.deliver(t_s);
        self.previous = Some((t_s, now));
    }

    /// Moves every frame due by `t_s` from the queue to `latest`.
    fn deliver(&mut self, t_s: f64) {
        while let Some(frame) = self.in_flight.front() {
            if frame.delivery_time_s > t_s + TIME_TOLERANCE_S {
                break;
            }
            self.latest = self.in_flight.pop_front();
        }
    }

    /// Captures frame `self.last_seq` at `capture_time_s` of `scene` and queues it unless it
    /// is dropped.
    fn capture(&mut self, capture_time_s: f64, scene: &Scene) {
        let p = &self.params;
        // Random draws first, always the same number per frame.
        let dropped = self.rng.random::<f64>() < p.drop_probability;
        let mut noise = [Vector2::<f64>::zeros(); MAX_LEDS];
        for n in noise.iter_mut().take(p.led_count) {
            let nu: f64 = self.rng.sample(StandardNormal);
            let nv: f64 = self.rng.sample(StandardNormal);
            *n = Vector2::new(nu, nv) * p.pixel_noise_px;
        }
        let tip_noise = {
            let nu: f64 = self.rng.sample(StandardNormal);
            let nv: f64 = self.rng.sample(StandardNormal);
            Vector2::new(nu, nv) * p.pixel_noise_px
        };
        let lens = self.lens;
        let probe_tip = self.probe_tip_camera_m.and_then(|t| {
            let (u, v) = lens.pixel(&t)?;
            let u = quantise(u + tip_noise.x, p.quantisation_px);
            let v = quantise(v + tip_noise.y, p.quantisation_px);
            ((0.0..=p.width_px).contains(&u) && (0.0..=p.height_px).contains(&v)).then(|| {
                let (x, y) = lens.normalised(u, v);
                [x as f32, y as f32]
            })
        });

        let camera_from_tanker = scene.pose.tanker_from_camera.inverse();
        let to_camera = |x: &Vector3<f64>| camera_from_tanker * (x - scene.pose.position_tanker_m);
        let centre_c = to_camera(&scene.drogue_centre_tanker_m);
        let (image_x, image_y) = if centre_c.z > 0.0 {
            (centre_c.x / centre_c.z, centre_c.y / centre_c.z)
        } else {
            (f64::NAN, f64::NAN)
        };
        let truth = TrueFeature {
            seq: self.last_seq,
            capture_time_s,
            image_x,
            image_y,
            depth_m: centre_c.z,
            drogue_camera_m: centre_c,
        };

        let mut pixels = [Vector2::<f64>::zeros(); MAX_LEDS];
        let mut visible = 0;
        if let Some((e1, e2)) = ring_basis(&scene.drogue_axis_tanker) {
            for (k, n) in noise.iter().enumerate().take(p.led_count) {
                if self.occluded & (1u32 << k) != 0 {
                    continue;
                }
                let angle = p.ring_phase_rad + TAU * k as f64 / p.led_count as f64;
                let (sin, cos) = angle.sin_cos();
                let led_t = scene.drogue_centre_tanker_m + (e1 * cos + e2 * sin) * p.ring_radius_m;
                let led_c = to_camera(&led_t);
                if !(led_c.z >= p.min_led_depth_m && led_c.z > 0.0) {
                    continue;
                }
                let Some((u, v)) = lens.pixel(&led_c) else {
                    continue;
                };
                if !((0.0..=p.width_px).contains(&u) && (0.0..=p.height_px).contains(&v)) {
                    continue;
                }
                pixels[visible] = Vector2::new(
                    quantise(u + n.x, p.quantisation_px),
                    quantise(v + n.y, p.quantisation_px),
                );
                visible += 1;
            }
        }

        let fit = if visible >= p.min_visible_leds {
            let points = &pixels[..visible];
            fit_circle(points).map(|c| refine_circle_geometric(points, &c, p.geometric_iterations))
        } else {
            None
        };
        let measurement = match fit {
            Some(c) => CameraMeasurement {
                seq: self.last_seq,
                tracked: true,
                image_x: lens.normalised(c.centre_px.x, c.centre_px.y).0 as f32,
                image_y: lens.normalised(c.centre_px.x, c.centre_px.y).1 as f32,
                depth_m: (p.focal_px * p.ring_radius_m / c.radius_px) as f32,
                probe_tip,
            },
            None => CameraMeasurement {
                seq: self.last_seq,
                ..CameraMeasurement::default()
            },
        };

        if dropped {
            self.dropped += 1;
        } else {
            self.in_flight.push_back(Frame {
                delivery_time_s: capture_time_s + p.latency_s(),
                measurement,
                truth,
                image: LedImage {
                    centroids_px: pixels,
                    visible,
                    circle: fit,
                },
            });
        }
    }

    /// The newest delivered frame; the same frame (same `seq`) until a newer one is delivered;
    /// untracked with `seq` 0 before the first delivery.
    pub fn latest(&self) -> CameraMeasurement {
        self.latest
            .map_or_else(CameraMeasurement::default, |f| f.measurement)
    }

    /// The truth behind [`Self::latest`] (`None` before the first delivery).
    pub fn latest_truth(&self) -> Option<TrueFeature> {
        self.latest.map(|f| f.truth)
    }

    /// LEDs visible in the frame behind [`Self::latest`] (0 before the first delivery).
    pub fn visible_leds(&self) -> usize {
        self.latest.map_or(0, |f| f.image.visible)
    }

    /// The image behind [`Self::latest`]: centroids and fitted circle (`None` before the
    /// first delivery).
    pub fn latest_image(&self) -> Option<&LedImage> {
        self.latest.as_ref().map(|f| &f.image)
    }

    /// Frames captured since construction (the last `seq` given out, before wrapping).
    pub fn frames_captured(&self) -> u64 {
        self.next_capture
    }

    /// Frames captured and dropped since construction.
    pub fn frames_dropped(&self) -> u64 {
        self.dropped
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Period of the default control loop, s.
    const TS: f64 = 0.02;

    /// Rotation from camera axes to tanker axes for a level camera looking forward
    /// (camera x = tanker y, camera y = tanker z, camera z = tanker x).
    fn level() -> Rotation3<f64> {
        Rotation3::from_matrix_unchecked(Matrix3::new(
            0.0, 0.0, 1.0, //
            1.0, 0.0, 0.0, //
            0.0, 1.0, 0.0,
        ))
    }

    fn level_pose() -> CameraPose {
        CameraPose {
            position_tanker_m: Vector3::new(-20.0, 1.0, 5.0),
            tanker_from_camera: level(),
        }
    }

    /// Drogue axis in camera axes: aft (toward the camera, -z) tilted by `tilt_rad` toward
    /// the in-image direction `dir_rad` (0: image right, pi/2: image down).
    fn axis_camera(tilt_rad: f64, dir_rad: f64) -> Vector3<f64> {
        let (st, ct) = tilt_rad.sin_cos();
        let (sd, cd) = dir_rad.sin_cos();
        Vector3::new(st * cd, st * sd, -ct)
    }

    /// Scene in tanker axes for a drogue at `p_c` (camera axes, m) with axis `a_c`.
    fn scene(
        pose: &CameraPose,
        p_c: &Vector3<f64>,
        a_c: &Vector3<f64>,
    ) -> (Vector3<f64>, Vector3<f64>) {
        (
            pose.position_tanker_m + pose.tanker_from_camera * p_c,
            pose.tanker_from_camera * a_c,
        )
    }

    fn noise_free() -> LedCameraParams {
        LedCameraParams {
            pixel_noise_px: 0.0,
            quantisation_px: 0.0,
            latency_frames: 0,
            ..LedCameraParams::default()
        }
    }

    /// One frame, captured and delivered at t = 0.
    fn snapshot(
        params: LedCameraParams,
        p_c: &Vector3<f64>,
        a_c: &Vector3<f64>,
        seed: u64,
    ) -> (CameraMeasurement, TrueFeature, usize) {
        let params = LedCameraParams {
            latency_frames: 0,
            ..params
        };
        let mut cam = LedCamera::new(params, seed).unwrap();
        let pose = level_pose();
        let (c, a) = scene(&pose, p_c, a_c);
        cam.update(0.0, &pose, &c, &a);
        (
            cam.latest(),
            cam.latest_truth().unwrap(),
            cam.visible_leds(),
        )
    }

    /// Errors (measured minus true) of image x, image y and relative depth.
    fn errors(m: &CameraMeasurement, t: &TrueFeature) -> [f64; 3] {
        [
            f64::from(m.image_x) - t.image_x,
            f64::from(m.image_y) - t.image_y,
            f64::from(m.depth_m) / t.depth_m - 1.0,
        ]
    }

    /// Mean and standard deviation of each error over `n` frames of a static scene.
    fn error_stats(params: LedCameraParams, p_c: &Vector3<f64>, n: usize) -> [(f64, f64); 3] {
        let params = LedCameraParams {
            latency_frames: 0,
            ..params
        };
        let mut cam = LedCamera::new(params, 7).unwrap();
        let pose = level_pose();
        let (c, a) = scene(&pose, p_c, &axis_camera(0.0, 0.0));
        let mut sum = [0.0; 3];
        let mut sum_sq = [0.0; 3];
        for k in 0..n {
            cam.update(k as f64 * TS, &pose, &c, &a);
            let m = cam.latest();
            assert!(m.tracked);
            let e = errors(&m, &cam.latest_truth().unwrap());
            for i in 0..3 {
                sum[i] += e[i];
                sum_sq[i] += e[i] * e[i];
            }
        }
        let nf = n as f64;
        core::array::from_fn(|i| {
            let mean = sum[i] / nf;
            (mean, (sum_sq[i] / nf - mean * mean).max(0.0).sqrt())
        })
    }

    fn ring_points(centre: Vector2<f64>, r: f64, angles_deg: &[f64]) -> Vec<Vector2<f64>> {
        angles_deg
            .iter()
            .map(|a| {
                let (s, c) = a.to_radians().sin_cos();
                centre + Vector2::new(c, s) * r
            })
            .collect()
    }

    /// Standard normal samples from a seeded generator, for the fit tests.
    fn normals(seed: u64) -> impl FnMut() -> f64 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        move || rng.sample(StandardNormal)
    }

    /// Normalised half field of view of the default camera, x and y.
    const HALF_FOV: [f64; 2] = [0.64, 0.48];
    /// Relative error of a noise-free fronto-parallel fit: f32 output rounding.
    const F32_REL: f64 = 1e-6;

    #[test]
    fn fit_recovers_exact_circles() {
        let cases = [
            (
                Vector2::new(320.0, 240.0),
                27.5,
                vec![0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0],
            ),
            (Vector2::new(10.0, -5.0), 165.0, vec![10.0, 100.0, 250.0]),
            (
                Vector2::new(700.0, 900.0),
                3.0,
                vec![0.0, 15.0, 30.0, 45.0, 60.0],
            ),
            (Vector2::new(1e4, 1e4), 1e3, vec![0.0, 30.0, 200.0, 330.0]),
        ];
        for (c, r, angles) in cases {
            let pts = ring_points(c, r, &angles);
            let fit = fit_circle(&pts).unwrap();
            assert!((fit.centre_px - c).norm() < 1e-9 * r, "{fit:?}");
            assert!((fit.radius_px / r - 1.0).abs() < 1e-12, "{fit:?}");
            let refined = refine_circle_geometric(&pts, &fit, 10);
            assert!((refined.centre_px - c).norm() < 1e-9 * r, "{refined:?}");
            assert!((refined.radius_px / r - 1.0).abs() < 1e-12, "{refined:?}");
        }
    }

    #[test]
    fn fit_rejects_degenerate_sets() {
        let p = |x: f64, y: f64| Vector2::new(x, y);
        let rejected: [Vec<Vector2<f64>>; 7] = [
            vec![],
            vec![p(0.0, 0.0), p(1.0, 1.0)],
            vec![p(0.0, 0.0), p(1.0, 1.0), p(2.0, 2.0)],
            vec![p(0.0, 5.0), p(1.0, 5.0), p(3.0, 5.0), p(7.0, 5.0)],
            vec![p(3.0, 4.0); 4],
            // 1e-5 of the length off a line: radius 1e4 times the length.
            vec![p(0.0, 0.0), p(50.0, 5e-4), p(100.0, 0.0)],
            vec![p(0.0, 0.0), p(1.0, f64::NAN), p(0.0, 1.0)],
        ];
        for pts in &rejected {
            assert_eq!(fit_circle(pts), None, "{pts:?}");
        }
        // Three adjacent LEDs of eight (a 90 deg arc) are well conditioned.
        let arc = ring_points(Vector2::new(100.0, 100.0), 20.0, &[0.0, 45.0, 90.0]);
        assert!(fit_circle(&arc).is_some());
    }

    #[test]
    fn fit_of_noisy_points_is_within_stated_error() {
        // The ring at 6 m (27.5 px radius), 8 LEDs, 0.5 px noise per axis. Expected: centre
        // sd per axis sigma / sqrt(n / 2) = 0.25 px, radius sd sigma / sqrt(n) = 0.18 px,
        // radius bias about +sigma^2 / r = 0.009 px (Kasa).
        let (c, r, sigma) = (Vector2::new(320.0, 240.0), 27.5, 0.5);
        let exact = ring_points(c, r, &[0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0]);
        let mut n = normals(3);
        let trials = 4000;
        let (mut sum, mut sum_sq) = ([0.0; 3], [0.0; 3]);
        for _ in 0..trials {
            let pts: Vec<_> = exact
                .iter()
                .map(|p| p + Vector2::new(n(), n()) * sigma)
                .collect();
            let fit = fit_circle(&pts).unwrap();
            let e = [
                fit.centre_px.x - c.x,
                fit.centre_px.y - c.y,
                fit.radius_px - r,
            ];
            for i in 0..3 {
                sum[i] += e[i];
                sum_sq[i] += e[i] * e[i];
            }
        }
        let t = f64::from(trials);
        for i in 0..3 {
            let mean = sum[i] / t;
            let sd = (sum_sq[i] / t - mean * mean).sqrt();
            let want_sd = if i < 2 { 0.25 } else { 0.177 };
            assert!(mean.abs() < 0.03, "component {i}: bias {mean} px");
            assert!(
                (sd / want_sd - 1.0).abs() < 0.1,
                "component {i}: sd {sd} px"
            );
        }
    }

    #[test]
    fn geometric_refinement_converges_and_never_increases_cost() {
        let (c, r) = (Vector2::new(300.0, 200.0), 40.0);
        let exact = ring_points(c, r, &[0.0, 45.0, 90.0, 135.0, 180.0]);
        let start = Circle {
            centre_px: c + Vector2::new(3.0, -2.0),
            radius_px: 35.0,
        };
        let refined = refine_circle_geometric(&exact, &start, 20);
        assert!((refined.centre_px - c).norm() < 1e-9, "{refined:?}");
        assert!((refined.radius_px - r).abs() < 1e-9, "{refined:?}");
        let mut n = normals(5);
        for _ in 0..100 {
            let pts: Vec<_> = exact.iter().map(|p| p + Vector2::new(n(), n())).collect();
            let kasa = fit_circle(&pts).unwrap();
            let geo = refine_circle_geometric(&pts, &kasa, 20);
            assert!(geometric_cost(&pts, &geo) <= geometric_cost(&pts, &kasa));
            // At the geometric optimum the mean distance equals the radius.
            let mean_dist =
                pts.iter().map(|p| (p - geo.centre_px).norm()).sum::<f64>() / pts.len() as f64;
            assert!((mean_dist - geo.radius_px).abs() < 1e-9);
        }
        // Zero iterations return the start unchanged.
        assert_eq!(refine_circle_geometric(&exact, &start, 0), start);
    }

    /// Drogue centres with the whole ring inside the image: depths 2..10 m, offsets 0, 50 %
    /// and 95 % of the room left by the ring, in 8 directions.
    fn in_view_centres() -> Vec<Vector3<f64>> {
        let mut out = Vec::new();
        for z in [2.0, 3.0, 4.5, 6.0, 8.0, 10.0] {
            let room = HALF_FOV.map(|h| h - DEFAULT_RING_RADIUS_M / z);
            for frac in [0.0, 0.5, 0.95] {
                for k in 0..8 {
                    let (s, c) = (f64::from(k) * TAU / 8.0).sin_cos();
                    let (x, y) = (frac * room[0] * c, frac * room[1] * s);
                    out.push(Vector3::new(x * z, y * z, z));
                }
            }
        }
        out
    }

    #[test]
    fn fronto_parallel_ring_is_exact_at_any_depth_and_offset() {
        for p in in_view_centres() {
            let (m, t, visible) = snapshot(noise_free(), &p, &axis_camera(0.0, 0.0), 1);
            assert!(m.tracked && visible == DEFAULT_LED_COUNT, "{p:?}");
            let e = errors(&m, &t);
            assert!(e[0].abs() < F32_REL && e[1].abs() < F32_REL, "{p:?}: {e:?}");
            assert!(e[2].abs() < F32_REL, "{p:?}: {e:?}");
            assert_eq!(t.depth_m, p.z);
        }
    }

    /// Relative depth error of the fit to a tilted ring, first-order model (module doc).
    fn depth_bias_model(x: f64, y: f64, tilt: f64, dir: f64) -> f64 {
        0.5 * ((1.0 - tilt.cos()) + tilt.sin() * (x * dir.cos() + y * dir.sin()))
    }

    #[test]
    fn tilted_ring_bias_is_as_stated() {
        let mut worst = [0.0f64; 4];
        for p in in_view_centres() {
            for tilt_deg in [2.0f64, 5.0, 10.0] {
                for dir_deg in [0.0f64, 45.0, 90.0, 180.0, 270.0] {
                    let (tilt, dir) = (tilt_deg.to_radians(), dir_deg.to_radians());
                    let (m, t, visible) = snapshot(noise_free(), &p, &axis_camera(tilt, dir), 1);
                    assert!(m.tracked && visible == DEFAULT_LED_COUNT, "{p:?}");
                    let e = errors(&m, &t);
                    let model = depth_bias_model(t.image_x, t.image_y, tilt, dir);
                    // Second-order terms (tilt^2 times offset^2 or (R / z)^2) are left out.
                    assert!(
                        (e[2] - model).abs() <= 0.1 * model.abs() + 0.1 * tilt * tilt,
                        "{p:?} tilt {tilt_deg} dir {dir_deg}: depth error {} model {model}",
                        e[2]
                    );
                    let shift = (DEFAULT_RING_RADIUS_M / p.z).powi(2) * tilt.sin();
                    let e_img = Vector2::new(e[0], e[1]);
                    worst[3] = worst[3].max(e_img.norm() / shift);
                    assert!(
                        e_img.norm() <= 1.1 * shift + F32_REL,
                        "{p:?} tilt {tilt_deg}: image error {e_img:?}, model {shift}"
                    );
                    worst[0] = worst[0].max(e[2].abs());
                    worst[1] = worst[1].max(e_img.norm() * p.z);
                    worst[2] = worst[2].max((e[2] - model).abs());
                }
            }
        }
        println!(
            "tilt <= 10 deg, 2..10 m, ring in view: worst depth error {:.2} % (model off by \
             {:.2} % at most), worst image point error at the drogue {:.1} mm ({:.2} of the \
             model)",
            worst[0] * 100.0,
            worst[2] * 100.0,
            worst[1] * 1e3,
            worst[3]
        );
        assert!(worst[0] < 0.07 && worst[1] < 0.012, "{worst:?}");
    }

    #[test]
    fn leds_outside_the_image_are_dropped() {
        let z = 6.0;
        let r_n = DEFAULT_RING_RADIUS_M / z; // ring radius, normalised: 0.055
        // Centre at x = 0.62: LEDs with 0.62 + 0.055 cos(phi) > 0.64 (phi = 0, +-45 deg) lost.
        let p = Vector3::new(0.62 * z, 0.0, z);
        let (m, t, visible) = snapshot(noise_free(), &p, &axis_camera(0.0, 0.0), 1);
        assert_eq!(visible, 5);
        assert!(m.tracked);
        assert!(errors(&m, &t).iter().all(|e| e.abs() < F32_REL));
        // Centre outside the image, 3 LEDs in it: tracked, image point outside the field of
        // view (the controller rejects it).
        let x = HALF_FOV[0] + 0.02;
        assert!(x - r_n * 0.5f64.sqrt() < HALF_FOV[0]);
        let (m, _, visible) = snapshot(
            noise_free(),
            &Vector3::new(x * z, 0.0, z),
            &axis_camera(0.0, 0.0),
            1,
        );
        assert_eq!(visible, 3);
        assert!(m.tracked && (f64::from(m.image_x) - x).abs() < F32_REL);
        // The ring left the top of the image.
        let (m, _, visible) = snapshot(
            noise_free(),
            &Vector3::new(0.0, -(HALF_FOV[1] + r_n + 0.01) * z, z),
            &axis_camera(0.0, 0.0),
            1,
        );
        assert_eq!((visible, m.tracked), (0, false));
    }

    #[test]
    fn the_latest_image_holds_the_centroids_and_circle_behind_the_measurement() {
        let params = LedCameraParams {
            latency_frames: 0,
            ..LedCameraParams::default()
        };
        let mut cam = LedCamera::new(params, 3).unwrap();
        assert!(cam.latest_image().is_none());
        let pose = level_pose();
        // Centre at x = 0.62 (as above): five LEDs in the image.
        let (c, a) = scene(
            &pose,
            &Vector3::new(0.62 * 6.0, 0.0, 6.0),
            &axis_camera(0.0, 0.0),
        );
        cam.update(0.0, &pose, &c, &a);
        let (m, image) = (cam.latest(), *cam.latest_image().unwrap());
        assert_eq!(image.centroids_px().len(), cam.visible_leds());
        assert_eq!(image.centroids_px().len(), 5);
        // The measurement is the circle's centre and f R / r, and the circle is the fit of
        // exactly these centroids.
        let circle = image.circle.unwrap();
        assert_eq!(Some(circle), fit_circle(image.centroids_px()));
        let u = f64::from(m.image_x) * params.focal_px + params.principal_u_px;
        assert!((u - circle.centre_px.x).abs() < 1e-3, "{u} {circle:?}");
        let depth = params.focal_px * params.ring_radius_m / circle.radius_px;
        assert!((f64::from(m.depth_m) - depth).abs() < 1e-5 * depth);
        // An untracked frame keeps its (too few) centroids and no circle.
        let (c, a) = scene(
            &pose,
            &Vector3::new(0.66 * 6.0, -0.47 * 6.0, 6.0),
            &axis_camera(0.0, 0.0),
        );
        cam.update(TS, &pose, &c, &a);
        let image = cam.latest_image().unwrap();
        assert!(!cam.latest().tracked);
        assert_eq!((image.centroids_px().len(), image.circle), (2, None));
    }

    #[test]
    fn fewer_than_min_visible_leds_is_untracked() {
        let z = 6.0;
        // Corner: x = 0.66 keeps phi = 135, 180, 225 deg; y = -0.47 keeps sin(phi) >= -0.18,
        // so only 135 and 180 deg remain.
        let p = Vector3::new(0.66 * z, -0.47 * z, z);
        let (m, t, visible) = snapshot(LedCameraParams::default(), &p, &axis_camera(0.0, 0.0), 1);
        assert_eq!(visible, 2);
        assert_eq!(
            m,
            CameraMeasurement {
                seq: 1,
                ..CameraMeasurement::default()
            }
        );
        assert!((t.image_x - 0.66).abs() < 1e-12);
        // Five visible, six required.
        let params = LedCameraParams {
            min_visible_leds: 6,
            ..LedCameraParams::default()
        };
        let (m, _, visible) = snapshot(
            params,
            &Vector3::new(0.62 * z, 0.0, z),
            &axis_camera(0.0, 0.0),
            1,
        );
        assert_eq!((visible, m.tracked), (5, false));
    }

    #[test]
    fn leds_behind_or_too_close_are_lost() {
        // A wide lens (f = 20 px) so that only depth matters.
        let params = LedCameraParams {
            focal_px: 20.0,
            ..noise_free()
        };
        // Axis along camera x: the ring stands in the plane x_c = 0.1 m, LED k at depth
        // 0.2 + 0.33 cos(45 k deg); those at 135, 180, 225 deg are behind the camera.
        let axis = Vector3::new(1.0, 0.0, 0.0);
        let (m, _, visible) = snapshot(params, &Vector3::new(0.1, 0.0, 0.2), &axis, 1);
        assert_eq!(visible, 5);
        assert!(m.tracked);
        // Ring closer than 0.1 m: all lost.
        let (m, _, visible) = snapshot(
            params,
            &Vector3::new(0.0, 0.0, 0.09),
            &axis_camera(0.0, 0.0),
            1,
        );
        assert_eq!((visible, m.tracked), (0, false));
        let (m, _, visible) = snapshot(
            params,
            &Vector3::new(0.0, 0.0, 0.11),
            &axis_camera(0.0, 0.0),
            1,
        );
        assert_eq!((visible, m.tracked), (8, true));
        // Behind the camera: nothing, and the truth says so.
        let (m, t, visible) = snapshot(
            params,
            &Vector3::new(0.0, 0.0, -2.0),
            &axis_camera(0.0, 0.0),
            1,
        );
        assert_eq!((visible, m.tracked), (0, false));
        assert!(t.image_x.is_nan() && t.depth_m == -2.0);
        // Non-finite or zero axis, non-finite pose: untracked, no panic.
        let centre = Vector3::new(0.0, 0.0, 6.0);
        for axis in [Vector3::zeros(), Vector3::new(f64::NAN, 0.0, -1.0)] {
            let (m, _, visible) = snapshot(params, &centre, &axis, 1);
            assert_eq!((visible, m.tracked), (0, false));
        }
        let mut cam = LedCamera::new(noise_free(), 1).unwrap();
        let pose = CameraPose {
            position_tanker_m: Vector3::new(f64::NAN, 0.0, 0.0),
            ..level_pose()
        };
        cam.update(0.0, &pose, &Vector3::new(6.0, 0.0, 0.0), &-Vector3::x());
        assert_eq!((cam.visible_leds(), cam.latest().tracked), (0, false));
    }

    #[test]
    fn truth_and_fit_follow_a_general_pose() {
        // Camera pitched down 6.35 deg, rolled 3 deg, yawed -2 deg from level, off the origin;
        // ring parallel to the image plane.
        let pose = CameraPose {
            position_tanker_m: Vector3::new(-21.0, 0.54, 6.0),
            tanker_from_camera: Rotation3::from_euler_angles(
                3f64.to_radians(),
                -6.35f64.to_radians(),
                -2f64.to_radians(),
            ) * level(),
        };
        let p_c = Vector3::new(1.2, -0.8, 5.5);
        let (centre, axis) = scene(&pose, &p_c, &axis_camera(0.0, 0.0));
        let mut cam = LedCamera::new(noise_free(), 1).unwrap();
        cam.update(0.0, &pose, &centre, &axis);
        let (m, t) = (cam.latest(), cam.latest_truth().unwrap());
        assert!((t.drogue_camera_m - p_c).norm() < 1e-12);
        assert!((t.image_x - p_c.x / p_c.z).abs() < 1e-12);
        assert!((t.image_y - p_c.y / p_c.z).abs() < 1e-12);
        assert!(
            m.tracked && errors(&m, &t).iter().all(|e| e.abs() < F32_REL),
            "{m:?}"
        );
    }

    #[test]
    fn before_the_first_delivery_the_frame_is_untracked_with_seq_0() {
        let cam = LedCamera::new(LedCameraParams::default(), 1).unwrap();
        assert_eq!(cam.latest(), CameraMeasurement::default());
        assert_eq!((cam.latest_truth(), cam.visible_leds()), (None, 0));
        // One frame of latency: the first update captures frame 1 and delivers nothing.
        let mut cam = LedCamera::new(LedCameraParams::default(), 1).unwrap();
        let pose = level_pose();
        let (c, a) = scene(&pose, &Vector3::new(0.0, 0.0, 6.0), &axis_camera(0.0, 0.0));
        cam.update(0.0, &pose, &c, &a);
        assert_eq!(cam.latest(), CameraMeasurement::default());
        assert_eq!(cam.frames_captured(), 1);
        cam.update(TS, &pose, &c, &a);
        assert_eq!((cam.latest().seq, cam.latest().tracked), (1, true));
    }

    /// Runs `steps` control steps of period `ts` against a static scene and checks at each
    /// that `latest()` is the newest frame whose delivery time has passed.
    fn check_delivery(params: LedCameraParams, ts: f64, t0: f64, steps: usize) -> Vec<u32> {
        let mut cam = LedCamera::new(params, 11).unwrap();
        let capacity = cam.in_flight.capacity();
        let pose = level_pose();
        let (c, a) = scene(&pose, &Vector3::new(0.3, 0.2, 6.0), &axis_camera(0.0, 0.0));
        let (period, latency) = (params.period_s(), params.latency_s());
        let capture = |seq: u32| t0 + params.clock_offset_s + f64::from(seq - 1) * period;
        let mut seqs = Vec::new();
        for n in 0..steps {
            let t = t0 + n as f64 * ts;
            cam.update(t, &pose, &c, &a);
            let m = cam.latest();
            // Newest seq whose delivery time has passed (no drops here).
            let newest = (1..=cam.frames_captured() as u32)
                .rev()
                .find(|&s| capture(s) + latency <= t + TIME_TOLERANCE_S)
                .unwrap_or(0);
            assert_eq!(m.seq, newest, "step {n}, t {t}");
            if let Some(truth) = cam.latest_truth() {
                assert_eq!(truth.seq, m.seq);
                assert!((truth.capture_time_s - capture(m.seq)).abs() < 1e-9);
                assert!(truth.capture_time_s + latency <= t + TIME_TOLERANCE_S);
            }
            // Every frame due by now was captured.
            assert!(capture(cam.frames_captured() as u32 + 1) > t + TIME_TOLERANCE_S);
            seqs.push(m.seq);
        }
        assert_eq!(cam.in_flight.capacity(), capacity, "the queue grew");
        seqs
    }

    #[test]
    fn latency_delivers_each_frame_at_capture_plus_latency() {
        let with = |rate_hz, latency_frames, clock_offset_s| LedCameraParams {
            rate_hz,
            latency_frames,
            clock_offset_s,
            ..LedCameraParams::default()
        };
        // 50 Hz camera and control, 3 frames of latency: frame n - 2 at step n.
        let seqs = check_delivery(with(50.0, 3, 0.0), TS, 0.0, 200);
        for (n, &s) in seqs.iter().enumerate() {
            assert_eq!(s, (n as u32).saturating_sub(2), "step {n}");
        }
        // Default: the previous step's frame.
        let seqs = check_delivery(LedCameraParams::default(), TS, 12.34, 200);
        assert!(seqs.iter().enumerate().all(|(n, &s)| s == n as u32));
        // Rates that are not multiples, clock phases, latency 0.
        check_delivery(with(30.0, 1, 0.0), TS, 0.0, 300);
        check_delivery(with(30.0, 2, 0.013), TS, 3.0, 300);
        check_delivery(with(125.0, 2, 0.0), TS, 0.0, 300);
        check_delivery(with(50.0, 1, 0.011), TS, 0.0, 300);
        check_delivery(with(50.0, 0, 0.0), 0.03, 1.0, 300);
        check_delivery(with(20.0, 0, 0.0), 0.01, 0.0, 300);
    }

    #[test]
    fn the_scene_is_interpolated_to_the_capture_time() {
        let params = LedCameraParams {
            rate_hz: 30.0,
            clock_offset_s: 0.007,
            latency_frames: 0,
            ..noise_free()
        };
        let mut cam = LedCamera::new(params, 1).unwrap();
        let pose0 = level_pose();
        // The drogue closes at 1 m/s and drifts right at 0.5 m/s; the camera climbs 0.2 m/s.
        let drogue = |t: f64| pose0.position_tanker_m + Vector3::new(8.0 - t, 0.5 * t, 0.0);
        let camera = |t: f64| CameraPose {
            position_tanker_m: pose0.position_tanker_m + Vector3::new(0.0, 0.0, -0.2 * t),
            ..pose0
        };
        for n in 0..100 {
            let t = n as f64 * TS;
            cam.update(t, &camera(t), &drogue(t), &-Vector3::x());
            if let Some(truth) = cam.latest_truth() {
                let tc = truth.capture_time_s;
                let want = level().inverse() * (drogue(tc) - camera(tc).position_tanker_m);
                assert!((truth.drogue_camera_m - want).norm() < 1e-12, "t {t}");
            }
        }
    }

    #[test]
    fn drops_leave_gaps_and_repeated_reads_repeat_seq() {
        let params = LedCameraParams {
            drop_probability: 0.3,
            ..LedCameraParams::default()
        };
        let mut cam = LedCamera::new(params, 4).unwrap();
        let pose = level_pose();
        let (c, a) = scene(&pose, &Vector3::new(0.0, 0.0, 6.0), &axis_camera(0.0, 0.0));
        let steps = 5000;
        let (mut gaps, mut repeats, mut last) = (0, 0, 0);
        for n in 0..steps {
            cam.update(n as f64 * TS, &pose, &c, &a);
            let m = cam.latest();
            assert_eq!(m, cam.latest(), "reads without update are identical");
            assert!(m.seq >= last);
            if n > 1 {
                // One frame per step: a repeat is exactly a dropped frame.
                if m.seq == last {
                    repeats += 1;
                } else {
                    gaps += m.seq - last - 1;
                }
            }
            last = m.seq;
        }
        let dropped = cam.frames_dropped();
        // Frames captured after the last delivered one are dropped or still in flight.
        let after_last = cam.frames_captured() - u64::from(last);
        let in_flight = cam.in_flight.len() as u64;
        assert_eq!(u64::from(gaps) + after_last - in_flight, dropped);
        assert!(repeats > 0 && gaps > 0);
        let fraction = dropped as f64 / cam.frames_captured() as f64;
        assert!((fraction - 0.3).abs() < 0.03, "{fraction}");
    }

    #[test]
    fn same_seed_same_output_different_seeds_differ() {
        let run = |seed: u64| {
            let params = LedCameraParams {
                drop_probability: 0.1,
                ..LedCameraParams::default()
            };
            let mut cam = LedCamera::new(params, seed).unwrap();
            let pose = level_pose();
            (0..200)
                .map(|n| {
                    let z = 8.0 - 0.02 * f64::from(n);
                    let (c, a) = scene(&pose, &Vector3::new(0.5, -0.4, z), &axis_camera(0.05, 1.0));
                    cam.update(f64::from(n) * TS, &pose, &c, &a);
                    cam.latest()
                })
                .collect::<Vec<_>>()
        };
        assert_eq!(run(42), run(42));
        assert_ne!(run(42), run(43));
    }

    #[test]
    fn invalid_parameters_are_named() {
        let d = LedCameraParams::default();
        assert_eq!(d.validate(), Ok(()));
        type IsNamed = fn(&CameraError) -> bool;
        let cases: [(LedCameraParams, IsNamed); 16] = [
            (LedCameraParams { width_px: 0.0, ..d }, |e| {
                matches!(e, CameraError::ImageSize { .. })
            }),
            (
                LedCameraParams {
                    height_px: f64::NAN,
                    ..d
                },
                |e| matches!(e, CameraError::ImageSize { .. }),
            ),
            (
                LedCameraParams {
                    focal_px: -1.0,
                    ..d
                },
                |e| matches!(e, CameraError::FocalLength(_)),
            ),
            (
                LedCameraParams {
                    principal_u_px: 641.0,
                    ..d
                },
                |e| matches!(e, CameraError::PrincipalPoint { .. }),
            ),
            (
                LedCameraParams {
                    led_count: 2,
                    min_visible_leds: 2,
                    ..d
                },
                |e| matches!(e, CameraError::LedCount(2)),
            ),
            (
                LedCameraParams {
                    led_count: MAX_LEDS + 1,
                    ..d
                },
                |e| matches!(e, CameraError::LedCount(_)),
            ),
            (
                LedCameraParams {
                    ring_radius_m: 0.0,
                    ..d
                },
                |e| matches!(e, CameraError::RingRadius(_)),
            ),
            (
                LedCameraParams {
                    ring_phase_rad: f64::INFINITY,
                    ..d
                },
                |e| matches!(e, CameraError::RingPhase(_)),
            ),
            (
                LedCameraParams {
                    pixel_noise_px: -0.1,
                    ..d
                },
                |e| matches!(e, CameraError::PixelNoise(_)),
            ),
            (
                LedCameraParams {
                    quantisation_px: f64::NAN,
                    ..d
                },
                |e| matches!(e, CameraError::Quantisation(_)),
            ),
            (
                LedCameraParams {
                    min_led_depth_m: -1.0,
                    ..d
                },
                |e| matches!(e, CameraError::MinLedDepth(_)),
            ),
            (
                LedCameraParams {
                    min_visible_leds: 9,
                    ..d
                },
                |e| {
                    matches!(
                        e,
                        CameraError::MinVisibleLeds {
                            min: 9,
                            led_count: 8
                        }
                    )
                },
            ),
            (LedCameraParams { rate_hz: 0.0, ..d }, |e| {
                matches!(e, CameraError::Rate(_))
            }),
            (
                LedCameraParams {
                    clock_offset_s: 0.02,
                    ..d
                },
                |e| matches!(e, CameraError::ClockOffset(_)),
            ),
            (
                LedCameraParams {
                    latency_frames: MAX_LATENCY_FRAMES + 1,
                    ..d
                },
                |e| matches!(e, CameraError::Latency(_)),
            ),
            (
                LedCameraParams {
                    drop_probability: 1.0,
                    ..d
                },
                |e| matches!(e, CameraError::DropProbability(_)),
            ),
        ];
        for (params, is_named) in cases {
            let err = LedCamera::new(params, 0).unwrap_err();
            assert!(is_named(&err), "{params:?} gave {err}");
        }
    }

    #[test]
    fn fit_error_with_default_noise_at_6_m_and_1_m() {
        // Drogue on the boresight, ring parallel to the image plane, 0.5 px noise, 0.1 px
        // quantisation; 4000 frames each. Expected image point sd 0.25 px / f = 5e-4 at any
        // depth; depth sd 0.18 px / r_px (27.5 px at 6 m, 165 px at 1 m).
        for (z, want_depth_sd, max_depth_bias) in [(6.0, 6.4e-3, 6e-4), (1.0, 1.07e-3, 1e-4)] {
            let s = error_stats(LedCameraParams::default(), &Vector3::new(0.0, 0.0, z), 4000);
            println!(
                "{z} m: image x {:.1e} +- {:.2e}, image y {:.1e} +- {:.2e}, depth {:+.3} % +- \
                 {:.3} % ({:.1} mm)",
                s[0].0,
                s[0].1,
                s[1].0,
                s[1].1,
                s[2].0 * 100.0,
                s[2].1 * 100.0,
                s[2].1 * z * 1e3
            );
            for (mean, sd) in &s[..2] {
                assert!(mean.abs() < 3e-5 && (sd / 5e-4 - 1.0).abs() < 0.1, "{s:?}");
            }
            assert!(s[2].0.abs() < max_depth_bias, "{s:?}");
            assert!((s[2].1 / want_depth_sd - 1.0).abs() < 0.15, "{s:?}");
        }
    }

    #[test]
    fn centred_ring_is_tracked_until_its_leds_leave_the_image() {
        // Closing on a drogue on the boresight: the LEDs at 90/270 deg leave the image at
        // z = R f / (h / 2) = 0.6875 m, those at 0/180 deg at R f / (w / 2) = 0.516 m, the
        // diagonals at R sin(45 deg) f / (h / 2) = 0.486 m: no LED is left below that.
        let r = DEFAULT_RING_RADIUS_M;
        let (f, w2, h2) = (
            DEFAULT_FOCAL_PX,
            DEFAULT_WIDTH_PX / 2.0,
            DEFAULT_HEIGHT_PX / 2.0,
        );
        let thresholds = [r * f / h2, r * f / w2, r * 0.5f64.sqrt() * f / h2];
        let visible_at = |z: f64| {
            let (m, _, visible) = snapshot(
                LedCameraParams::default(),
                &Vector3::new(0.0, 0.0, z),
                &axis_camera(0.0, 0.0),
                1,
            );
            (visible, m.tracked)
        };
        for (threshold, above, below) in [
            (thresholds[0], 8, 6),
            (thresholds[1], 6, 4),
            (thresholds[2], 4, 0),
        ] {
            assert_eq!(visible_at(threshold + 1e-4).0, above, "{threshold}");
            assert_eq!(visible_at(threshold - 1e-4).0, below, "{threshold}");
        }
        println!("centred ring last tracked at {:.4} m", thresholds[2]);
        let mut z = 10.0;
        while z > 0.3 {
            let tracked = visible_at(z).1;
            assert_eq!(tracked, z >= thresholds[2], "z {z}");
            z -= 0.01;
        }
    }

    /// A focal-length error scales the reported image point by `f_true / f` and the depth
    /// by `f / f_true`; a principal-point error shifts the point by `error / f`.
    #[test]
    fn a_miscalibrated_lens_scales_and_shifts_what_the_camera_reports() {
        let p_c = Vector3::new(0.6, -0.4, 6.0);
        let a = axis_camera(0.0, 0.0);
        let (nominal, truth, _) = snapshot(noise_free(), &p_c, &a, 1);
        let with = |error: IntrinsicsError| {
            snapshot(
                LedCameraParams {
                    intrinsics_error: error,
                    ..noise_free()
                },
                &p_c,
                &a,
                1,
            )
            .0
        };
        let long = with(IntrinsicsError {
            focal_px: 5.0,
            ..IntrinsicsError::NONE
        });
        let k = 505.0 / 500.0;
        assert!(
            (f64::from(long.image_x) / (truth.image_x * k) - 1.0).abs() < F32_REL,
            "{long:?}"
        );
        assert!(
            (f64::from(long.image_y) / (truth.image_y * k) - 1.0).abs() < F32_REL,
            "{long:?}"
        );
        assert!(
            (f64::from(long.depth_m) / (6.0 / k) - 1.0).abs() < 1e-5,
            "{long:?}"
        );
        let shifted = with(IntrinsicsError {
            principal_px: [4.0, -3.0],
            ..IntrinsicsError::NONE
        });
        assert!((f64::from(shifted.image_x - nominal.image_x) - 4.0 / 500.0).abs() < 1e-6);
        assert!((f64::from(shifted.image_y - nominal.image_y) + 3.0 / 500.0).abs() < 1e-6);
        assert!((shifted.depth_m / nominal.depth_m - 1.0).abs() < 1e-5);
        // No error: the error-free camera, bit for bit.
        assert_eq!(with(IntrinsicsError::NONE), nominal);
    }

    /// Radial distortion moves an off-axis drogue radially by `k1 r^3 + k2 r^5`, the amount
    /// of a point, and not one on the axis. The ring's LEDs come in opposite pairs, so the fit
    /// finds the distorted centre up to the distortion's curvature across the ring: within
    /// `rho^2 (6 k1 r + 20 k2 r^3)`, `rho = R / z` the ring's angular radius.
    #[test]
    fn distortion_moves_an_off_axis_drogue_by_the_stated_amount() {
        let (k1, k2) = (0.01, 0.02);
        let params = LedCameraParams {
            intrinsics_error: IntrinsicsError {
                radial_k: [k1, k2],
                ..IntrinsicsError::NONE
            },
            ..noise_free()
        };
        let r = 0.5_f64;
        let stated = k1 * r.powi(3) + k2 * r.powi(5);
        for z in [6.0, 20.0] {
            // Normalised (0.3, 0.4): r = 0.5.
            let p_c = Vector3::new(0.3 * z, 0.4 * z, z);
            let (m, t, _) = snapshot(params, &p_c, &axis_camera(0.0, 0.0), 1);
            let reported = f64::from(m.image_x).hypot(f64::from(m.image_y));
            let moved = reported - r;
            let rho = DEFAULT_RING_RADIUS_M / z;
            let curvature = rho * rho * (6.0 * k1 * r + 20.0 * k2 * r.powi(3));
            println!(
                "off-axis drogue at r = 0.5, {z} m: moved {moved:.6} (stated {stated:.6}, \
                 curvature bound {curvature:.1e})"
            );
            assert!(
                (moved - stated).abs() < curvature,
                "{z}: {moved} vs {stated}"
            );
            let direction = f64::from(m.image_y) / f64::from(m.image_x);
            assert!((direction - t.image_y / t.image_x).abs() < 1e-5, "radial");
        }
        let (centred, _, _) = snapshot(
            params,
            &Vector3::new(0.0, 0.0, 6.0),
            &axis_camera(0.0, 0.0),
            1,
        );
        assert!(
            centred.image_x.abs() < 1e-7 && centred.image_y.abs() < 1e-7,
            "{centred:?}"
        );
    }

    #[test]
    fn a_true_lens_outside_the_image_is_named() {
        let err = LedCamera::new(
            LedCameraParams {
                intrinsics_error: IntrinsicsError {
                    principal_px: [400.0, 0.0],
                    ..IntrinsicsError::NONE
                },
                ..LedCameraParams::default()
            },
            0,
        )
        .unwrap_err();
        assert!(matches!(err, CameraError::TrueLens { .. }), "{err}");
        let err = LedCamera::new(
            LedCameraParams {
                intrinsics_error: IntrinsicsError {
                    focal_px: -500.0,
                    ..IntrinsicsError::NONE
                },
                ..LedCameraParams::default()
            },
            0,
        )
        .unwrap_err();
        assert!(matches!(err, CameraError::TrueLens { .. }), "{err}");
    }
}
