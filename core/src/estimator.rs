//! Drogue estimator: where the drogue is relative to the probe tip, how it moves, and where
//! it will be.
//!
//! Place in the data flow: beside the outer loop, in the refuelling procedure
//! ([`crate::procedure`]). Every engaged step it *predicts* with the probe tip's own velocity
//! from navigation (exact kinematics, [`crate::kinematics::point_velocity_tanker_mps`],
//! tanker axes) and, when the step's camera frame is valid,
//! *corrects* with the frame turned into the drogue's offset from the probe tip
//! ([`TipGeometry::drogue_from_tip`]: camera set-back removed, de-rotated by the navigation
//! attitude into tanker axes). Its estimate feeds the outer loop's feed-forward, the go/no-go
//! gate's prediction and the capture phase, where a tip-mounted camera is blind and the
//! estimate runs on prediction alone.
//!
//! # Model (`docs/conventions.md`, "Drogue estimator")
//!
//! Per axis (right, down and forward), tanker axes, a Kalman filter on
//!
//! ```text
//! r' = v - u            r: drogue centre minus probe tip, m (measured); u: tip velocity (navigation)
//! v' = -v / τ + w       v: drogue velocity relative to the tanker, m/s; w: white, PSD q
//! ```
//!
//! the drogue's velocity a first-order Gauss-Markov process whose correlation time `τ` and
//! intensity `q` are fitted to the simulated hose's response to Dryden turbulence (1.3 s,
//! fitted to an earlier hose model; today's falls to 1/e in about 0.75 s,
//! `host-sim/examples/drogue_model.rs`, not refitted yet). The hose's swinging mode (period
//! 3.9 s) would be the better physical model for the filter, but its displacement from the
//! trail's equilibrium is not observable enough: with the few cm/s of error in the
//! navigation's tip velocity, a filter carrying it predicted a swing of 0.24 m at 1.2 s for
//! a drogue at rest in calm air (measured, `docs/conventions.md`). The swing enters where
//! it needs no displacement: the feed-forward's velocity a lead ahead
//! ([`DrogueEstimator::drogue_velocity_ahead`]) carries the estimated velocity and its rate
//! (the drogue's acceleration, the velocity's change low-passed) along a swing of the
//! configured period, the phase a decaying velocity cannot give, and the velocity's average
//! (a drift, which the swing has not: the apparent one of a mount error while closing)
//! unchanged; a drogue at rest has none of them, and nothing is predicted. Discretised
//! exactly at construction (`Ts`-step transition and process noise of the Gauss-Markov
//! process). Measurement noise grows with the camera's depth (`offset_noise_*`,
//! `depth_noise_*`).
//!
//! How hard the drogue is being driven (the air's turbulence) is not configured but measured:
//! an exponential average of the estimated drogue velocity's square over
//! [`EstimatorConfig::activity_time_constant_s`] gives the stationary velocity variance, and
//! with it the PSD the predictions' uncertainty grows with (`q = 2 E[v²] / τ`, the process's
//! stationary relation) and the PSD of the filter's own process noise (`q = 4 ζ ω E[v²]`, the
//! hose's swing's relation, at least a floor speed's; the swing's period follows the flight
//! condition's dynamic pressure, [`EstimatorModel::at`]). It starts at the configured PSD's level
//! (cautious) and settles within a few time constants: calm air makes the gate's margin and
//! the filter's velocity sigma small, strong turbulence large.
//!
//! What the filter cannot estimate it considers: the angular errors that turn the camera's
//! view of the drogue and no frame averages away (the navigation's heading and pitch biases,
//! the mount's attitude, the principal point) rotate the measured offset by their angle, an
//! error of that angle times the depth to the drogue plane. Their variance
//! ([`EstimatorConfig::bearing_bias_sigma_rad`]) times the depth squared is added to the
//! offset's error variance and to the predictions' ([`DrogueEstimator::predict_offset`]),
//! without changing the filter's gain (a consider parameter; measured against truth in
//! `docs/conventions.md`, "Drogue estimator").
//!
//! Innovations beyond [`EstimatorConfig::gate_sigmas`] standard deviations are rejected and
//! counted; after [`EstimatorConfig::max_rejections`] in a row the filter restarts from the
//! frame (counted too): a drogue that really jumped is followed, an outlier is not.
//!
//! Invariants: static memory, no allocation, no loop that depends on the data, every
//! covariance symmetric by construction (only its upper triangle is stored), and the state
//! finite: a non-finite update restarts the filter from the frame.

use serde::{Deserialize, Serialize};

use crate::kinematics::{CameraMount, body_from_camera};
use crate::nav::FlightCondition;
use crate::num::{max_to, min_to, sin_cos};

/// Parameters of the drogue estimator.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
// Scenario files name only what they change; an unknown key is an error that names it.
#[serde(default, deny_unknown_fields)]
pub struct EstimatorConfig {
    /// Correlation time of the drogue's lateral and vertical velocity, s. Default 1.3 s,
    /// fitted to an earlier version of the simulated hose; today's hose measures 0.76 s
    /// right and 0.72 s down (`host-sim/examples/drogue_model.rs`), not refitted yet
    /// (`docs/conventions.md`, "Drogue estimator").
    pub drogue_time_constant_s: f32,
    /// Power spectral density of the white noise driving the drogue's lateral and vertical
    /// velocity at the filter's start, m²/s³: the measured activity starts at its stationary
    /// variance `q τ / 2` (0.255 m/s RMS at the default) and the measurement takes over
    /// within a few `activity_time_constant_s`. Default 0.1: the fit's 0.047 per (m/s of RMS
    /// gust)², at the design intensity of about 1.45 m/s (between the paper's level II and
    /// MIL-F-8785C's 10⁻² intensity at 3,000 m): a cautious start. (The filter's process
    /// noise was this fixed PSD until it followed the measured activity.)
    pub drogue_accel_psd_m2ps3: f32,
    /// Correlation time of the drogue's forward velocity, s.
    pub drogue_fwd_time_constant_s: f32,
    /// Power spectral density of the noise driving the drogue's forward velocity, m²/s³.
    pub drogue_fwd_accel_psd_m2ps3: f32,
    /// Standard deviation of a frame's offset (right, down) at zero depth, m.
    pub offset_noise_m: f32,
    /// Growth of that standard deviation per metre of camera depth, m/m. Default 0.002: a
    /// fifth of a pixel of centroid noise at 500 px of focal length, plus the depth noise
    /// times the image error.
    pub offset_noise_per_m: f32,
    /// Standard deviation of a frame's depth at zero depth, m.
    pub depth_noise_m: f32,
    /// Growth of the depth's standard deviation with the square of the camera depth, 1/m:
    /// the LED ring's radius in pixels falls as 1/depth. Default 0.003.
    pub depth_noise_per_m2: f32,
    /// Initial standard deviation of the drogue's velocity when the filter (re)starts, m/s.
    pub initial_velocity_sigma_mps: f32,
    /// Innovation gate, standard deviations: a frame further from the prediction is rejected.
    pub gate_sigmas: f32,
    /// Time constant of the average of the drogue velocity's square that measures how hard
    /// the air drives the drogue (for the predictions' uncertainty), s.
    pub activity_time_constant_s: f32,
    /// Time constant of the average offset ([`DrogueEstimate::mean_offset_m`]), s: longer
    /// than the drogue's swing's correlation time.
    pub mean_time_constant_s: f32,
    /// Time constant of the navigation's velocity-bias estimate, s; 0 turns it off.
    ///
    /// The drogue is towed: relative to the tanker its mean velocity is zero. Its
    /// estimated velocity comes from the camera's offsets and the probe tip's velocity as
    /// the navigation reports it, so a steady part of it is the navigation's velocity
    /// error. Holding the station, the controller integrates the estimated drogue velocity
    /// over this time into its estimate of that bias, takes the bias out of the tip's
    /// velocity before the estimator and the mode logic use it, and adds it to the velocity
    /// it asks of the inner loops (which hold the velocity the navigation reports). Default
    /// 20 s: five of the hose's 3.9 s swings (the swing's velocity passes through the
    /// average at a thirtieth of its amplitude), short beside the sortie's 150 s. Without
    /// it an industrial-grade INS's velocity bias (0.1 m/s, one sigma) left the receiver off
    /// the drogue at the station or closing, and most of those sorties ended at the station
    /// or after four no-gos (`docs/conventions.md`, "Navigation bias").
    pub nav_bias_time_constant_s: f32,
    /// Consecutive rejected frames after which the filter restarts from the frame.
    pub max_rejections: u16,
    /// Largest distance of the probe tip's measured image point from where the configured
    /// geometry puts it, normalised image units; further is not the tip (rejected, counted).
    /// It is the camera's stated calibration bound seen from the camera: the measured point
    /// is what cancels a mount error from the drogue's offset (endpoint aiming,
    /// `docs/conventions.md`), so the window must hold every mount the installation allows.
    /// Default 0.23: a position error of 0.5 m across the boresight at the set-back camera's
    /// 2.67 m to the tip (0.187) plus an attitude error of 2° (0.035) plus the centroid's
    /// noise (0.001 at 0.5 px of 500 px), rounded up. The running average stays inside it
    /// (every point it averages is), so the learned tip is never further from the geometry
    /// than the bound.
    pub tip_sight_tolerance: f32,
    /// Weight of a new measurement of the tip's image point in its running average (the
    /// tip is fixed in the camera's view: the average only removes the centroid noise).
    pub tip_sight_filter: f32,
    /// Period of the hose's swinging mode at the single-point design's condition (120 m/s,
    /// 3,000 m), s: the feed-forward carries the drogue's estimated velocity and acceleration
    /// over its lead along a swing of this period, scaled to the flight condition by
    /// `drogue_swing_period_exponent` ([`DrogueEstimator::drogue_velocity_ahead`]). Default
    /// 3.9 s, the simulated hose's lateral mode (`docs/conventions.md`, "Drogue estimator").
    /// 0: no swing, the velocity decays over the lead as the Gauss-Markov model says (the
    /// earlier feed-forward).
    pub drogue_swing_period_s: f32,
    /// Damping ratio of the hose's swinging mode. With the period it sets how much of the
    /// measured drogue activity the filter takes as the noise that drives the drogue's
    /// velocity: `4 ζ ω` per unit velocity variance (the swing's stationary relation;
    /// [`DrogueEstimator::predict`]). Default 0.10, the simulated hose's lateral mode
    /// (`docs/conventions.md`, "Drogue estimator"). 0: the Gauss-Markov relation `2 / τ`.
    pub drogue_swing_damping_ratio: f32,
    /// How the swing's period falls with the dynamic pressure: at a flight condition it is
    /// `drogue_swing_period_s` (the single-point design's condition) times the ratio of the
    /// dynamic pressures to the power minus this ([`swing_period_s`]). Default 0.35: fitted
    /// through the configured period on the simulated hose's swing at the gain schedule's
    /// sixteen nodes (right axis; measured 2.56 s at 170 m/s and 500 m, 4.68 s at 100 m/s and
    /// 8,000 m); every node within 15 % (9 % at 170 m/s and 500 m), where the fixed period
    /// was up to 52 % long (`docs/conventions.md`, "Drogue estimator"). Applied only where the
    /// dynamic pressure is above the design's: below it the period stays the configured one,
    /// because there the inner loops are slower and the feed-forward's fixed lead along the
    /// configured (shorter than true) swing carries the extra phase they need; the longer true
    /// period cost docking there (`envelope` tuning runs 0..3,999 below 6 kPa: unsafe runs 3
    /// -> 8). 0: the configured period everywhere.
    pub drogue_swing_period_exponent: f32,
    /// The least RMS speed of the drogue's motion the filter assumes, m/s: its process noise
    /// never falls below that speed's through the swing's relation. It is the apparent
    /// motion the camera's calibration gives the drogue while the receiver closes: a mount
    /// error within the stated bound (0.5 m across the boresight at the set-back camera's
    /// 2.67 m to the tip, 0.19 rad) turns the measured offset by that angle times the
    /// distance to the plane, which shrinks at the closing speed: 0.19 m/s at the 1 m/s
    /// contact speed. Default 0.19 m/s; at 0.05 m/s the filter lagged that drift in calm air
    /// and the paper's mount error cost 5 cm of miss (`docs/conventions.md`, "Drogue
    /// estimator"). A drogue at rest, whose measured activity tends to nothing, is followed
    /// when it moves.
    pub drogue_speed_floor_mps: f32,
    /// Time constant of the low-pass filter that takes the drogue's acceleration from the
    /// change of its estimated velocity, s. Default 0.2 s: a twentieth of the swing, a
    /// tenth of its phase (0.1 s and 0.35 s measured as good, `docs/scenarios.md`).
    pub drogue_accel_time_constant_s: f32,
    /// One standard deviation of the angular errors that turn the camera's view of the drogue
    /// and that no frame averages away, `[right, down]` (about the down and the right axis),
    /// rad: the navigation's heading and pitch biases, the camera mount's attitude error and
    /// its principal point's. Each rotates the drogue's offset from the tip by its angle, an
    /// error of that angle times the depth to the drogue plane, which vanishes at contact
    /// (endpoint aiming, `docs/conventions.md`). The filter does not estimate it (it is not
    /// observable); its variance times the depth squared is added to the offset's
    /// ([`DrogueEstimator::offset_error_variance_m2`]) and to the gate's prediction: a
    /// consider parameter. Default `[0.0145, 0.0124]`: a tactical INS's heading and pitch
    /// biases (0.5° and 0.25°, one sigma), a mount within ±1° (0.58°, uniform) and a
    /// principal point within ±5 px of 500 (0.33°), added in quadrature. 0: none.
    pub bearing_bias_sigma_rad: [f32; 2],
}

impl Default for EstimatorConfig {
    fn default() -> Self {
        Self {
            drogue_time_constant_s: 1.3,
            drogue_accel_psd_m2ps3: 0.1,
            drogue_fwd_time_constant_s: 2.0,
            drogue_fwd_accel_psd_m2ps3: 0.005,
            offset_noise_m: 0.002,
            offset_noise_per_m: 0.002,
            depth_noise_m: 0.005,
            depth_noise_per_m2: 0.003,
            initial_velocity_sigma_mps: 0.5,
            gate_sigmas: 6.0,
            activity_time_constant_s: 4.0,
            mean_time_constant_s: 2.0,
            nav_bias_time_constant_s: 20.0,
            max_rejections: 5,
            tip_sight_tolerance: 0.23,
            tip_sight_filter: 0.05,
            drogue_swing_period_s: 3.9,
            drogue_swing_damping_ratio: 0.10,
            drogue_swing_period_exponent: 0.35,
            drogue_speed_floor_mps: 0.19,
            drogue_accel_time_constant_s: 0.2,
            bearing_bias_sigma_rad: [0.0145, 0.0124],
        }
    }
}

/// Least distance of the probe tip ahead of the camera along the boresight for its marker to
/// be in view, m: a camera closer than this is at the tip (the simulated camera renders the
/// marker beyond the same 0.5 m).
pub const TIP_IN_VIEW_MIN_DEPTH_M: f32 = 0.5;

/// Where the probe tip is, seen from the camera: the part of the geometry the estimator
/// needs to turn a frame into the drogue's offset from the tip. Derived once from the
/// believed camera mount and probe-tip position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TipGeometry {
    /// Probe tip minus camera, camera axes (right, down, boresight), m.
    tip_from_camera_re_m: [f32; 3],
    /// Trim pitch's sine and cosine: body roll is about an axis pitched up by it.
    trim_pitch_sin_cos: [f32; 2],
    /// Sine and cosine of the boresight's elevation above the tanker's axis at trim, the trim
    /// pitch minus the mount's pitch-down: 0 and 1 exactly when the mount is level at trim
    /// (the design condition), so that the rotation below changes nothing there.
    boresight_elevation_sin_cos: [f32; 2],
}

impl TipGeometry {
    /// The geometry of a `camera` mount (boresight level at trim when its pitch-down is the
    /// trim pitch, looking up by the difference otherwise: at another flight condition than
    /// the mount's) and the probe tip, both in body axes, at the trim pitch `trim_pitch_rad`.
    pub fn new(camera: &CameraMount, probe_tip_body_m: [f32; 3], trim_pitch_rad: f32) -> Self {
        let d = [0, 1, 2].map(|i| probe_tip_body_m[i] - camera.position_body_m[i]);
        // Camera axes (x right, y down, z boresight) from body axes: the transpose of the
        // mount's rotation. At trim the camera axes are the reference axes `re`.
        let r = body_from_camera(camera.pitch_down_rad);
        let cam = [0, 1, 2].map(|c| r[(0, c)] * d[0] + r[(1, c)] * d[1] + r[(2, c)] * d[2]);
        Self {
            tip_from_camera_re_m: cam,
            trim_pitch_sin_cos: {
                let (s, c) = sin_cos(trim_pitch_rad);
                [s, c]
            },
            boresight_elevation_sin_cos: {
                let (s, c) = sin_cos(trim_pitch_rad - camera.pitch_down_rad);
                [s, c]
            },
        }
    }

    /// Probe tip minus camera in the camera's axes (right, down, boresight), m.
    pub fn tip_from_camera_m(&self) -> [f32; 3] {
        self.tip_from_camera_re_m
    }

    /// Whether the configured geometry puts the probe tip in front of the camera, where a
    /// set-back camera sees its marker (more than [`TIP_IN_VIEW_MIN_DEPTH_M`] ahead along the
    /// boresight); a camera at the tip does not.
    pub fn tip_in_view(&self) -> bool {
        self.tip_from_camera_re_m[2] > TIP_IN_VIEW_MIN_DEPTH_M
    }

    /// Where the configured geometry puts the probe tip in the image, normalised (the
    /// origin for a camera at the tip).
    pub fn tip_image(&self) -> [f32; 2] {
        let t = &self.tip_from_camera_re_m;
        if t[2] > 0.0 {
            [t[0] / t[2], t[1] / t[2]]
        } else {
            [0.0; 2]
        }
    }

    /// The drogue centre minus the probe tip in tanker axes, `[right, down, forward]`, from a
    /// frame's image point and depth, the probe tip's image point `tip_image` (measured,
    /// [`TipSight`], or the geometry's [`TipGeometry::tip_image`]; its depth is the
    /// geometry's) and the attitude's perturbation from trim (roll `phi`, pitch `theta`,
    /// heading `psi`, rad). Small-angle de-rotation: the perturbations stay within a few
    /// degrees while engaged (their second-order error is below 0.2 % of the range).
    #[inline(always)]
    pub fn drogue_from_tip(
        &self,
        image: [f32; 2],
        depth_m: f32,
        [phi, theta, psi]: [f32; 3],
        tip_image: [f32; 2],
    ) -> [f32; 3] {
        let tz = self.tip_from_camera_re_m[2];
        let t = [tip_image[0] * tz, tip_image[1] * tz, tz];
        // Drogue minus tip in the camera's axes, reordered (boresight, right, down), then
        // turned to the tanker's axes at trim (fwd, right, down): the boresight is raised by
        // the elevation `e` about the right axis.
        let c_axes = [
            depth_m - t[2],
            image[0] * depth_m - t[0],
            image[1] * depth_m - t[1],
        ];
        let [se, ce] = self.boresight_elevation_sin_cos;
        let a = [
            ce * c_axes[0] + se * c_axes[2],
            c_axes[1],
            ce * c_axes[2] - se * c_axes[0],
        ];
        // Small rotation of the camera from its trim attitude, tanker axes: roll about the
        // body x axis (pitched up by the trim pitch), pitch, heading.
        let [s, c] = self.trim_pitch_sin_cos;
        let w = [phi * c, theta, psi - phi * s];
        [
            a[1] + w[2] * a[0] - w[0] * a[2],
            a[2] + w[0] * a[1] - w[1] * a[0],
            a[0] + w[1] * a[2] - w[2] * a[1],
        ]
    }
}

/// The probe tip as the camera sees it: a running average of its measured image point,
/// starting from where the configured geometry puts it. A measurement further than
/// [`EstimatorConfig::tip_sight_tolerance`] from the geometry's point, or not finite, is
/// rejected (counted by the caller); without measurements the average stays where it is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TipSight {
    image: [f32; 2],
    belief: [f32; 2],
}

/// What [`TipSight::observe`] did with a frame's tip measurement.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TipSighting {
    /// The frame had none (a camera at the tip, or the marker not found).
    None,
    /// Averaged in.
    Used,
    /// Not finite, or too far from the geometry's point: not the tip.
    Rejected,
}

impl TipSight {
    /// Starts at the geometry's point.
    pub fn new(g: &TipGeometry) -> Self {
        let p = g.tip_image();
        Self {
            image: p,
            belief: p,
        }
    }

    /// The tip's image point, normalised.
    pub fn image(&self) -> [f32; 2] {
        self.image
    }

    /// Takes a frame's tip measurement.
    #[inline(always)]
    pub fn observe(&mut self, tip: Option<[f32; 2]>, cfg: &EstimatorConfig) -> TipSighting {
        let Some(m) = tip else {
            return TipSighting::None;
        };
        let d = [m[0] - self.belief[0], m[1] - self.belief[1]];
        // Also false for NaN.
        let near = d[0] * d[0] + d[1] * d[1] <= cfg.tip_sight_tolerance * cfg.tip_sight_tolerance;
        if !near {
            return TipSighting::Rejected;
        }
        let k = cfg.tip_sight_filter;
        self.image = [
            self.image[0] + k * (m[0] - self.image[0]),
            self.image[1] + k * (m[1] - self.image[1]),
        ];
        TipSighting::Used
    }
}

/// The estimator's belief, as reported every step.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DrogueEstimate {
    /// Drogue centre minus probe tip, `[right, down]`, tanker axes, m.
    pub offset_m: [f32; 2],
    /// The same averaged over [`EstimatorConfig::mean_time_constant_s`]: where the drogue
    /// is on average, its swing left out, m.
    pub mean_offset_m: [f32; 2],
    /// Drogue velocity relative to the tanker, `[right, down, forward]`, m/s.
    pub drogue_velocity_mps: [f32; 3],
    /// Probe tip to the drogue plane, forward, m.
    pub depth_m: f32,
}

impl DrogueEstimate {
    /// Closing speed on the drogue for the probe tip's forward velocity `tip_fwd_mps`
    /// (relative to the tanker), m/s.
    pub fn closing_mps(&self, tip_fwd_mps: f32) -> f32 {
        tip_fwd_mps - self.drogue_velocity_mps[2]
    }
}

/// A prediction of the drogue's offset from the probe tip, one lateral axis.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AxisPrediction {
    /// Predicted offset, m.
    pub mean_m: f32,
    /// Its variance, m².
    pub variance_m2: f32,
}

/// One axis: state `[r, v]` and covariance `[rr, rv, vv]`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Axis {
    x: [f32; 2],
    p: [f32; 3],
}

/// One axis's discrete model: `x' = [[1, g], [0, f]] x - [Ts, 0] u`, process noise `q`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct AxisModel {
    /// `exp(-Ts / τ)`.
    f: f32,
    /// `τ (1 - f)`: the offset's change per unit drogue velocity over a step.
    g: f32,
    /// Process noise `[rr, rv, vv]` over a step, per unit PSD (the lateral axes) or at the
    /// axis's fixed PSD (the forward axis).
    q: [f32; 3],
}

impl AxisModel {
    /// The exact discretisation of `r' = v - u`, `v' = -v / τ + w` at `ts_s`, its process
    /// noise per unit PSD of `w` (the step's noise is linear in the PSD, which
    /// [`AxisModel::predict`] takes).
    fn new(tau: f32, ts_s: f32) -> Self {
        let f = libm::expf(-ts_s / tau);
        let g = tau * (1.0 - f);
        let q = prediction_noise(tau, 1.0, ts_s, f);
        Self { f, g, q }
    }

    /// [`AxisModel::new`] with the process noise at the fixed PSD `psd` (the forward axis):
    /// [`AxisModel::predict`] takes it at a PSD of 1.
    fn with_psd(tau: f32, ts_s: f32, psd: f32) -> Self {
        let mut m = Self::new(tau, ts_s);
        m.q = m.q.map(|q| psd * q);
        m
    }

    /// One step with the tip's velocity `u` and the driving noise's PSD `psd`, m²/s³.
    #[inline(always)]
    fn predict(&self, a: &mut Axis, u: f32, ts: f32, psd: f32) {
        let [r, v] = a.x;
        a.x = [r + self.g * v - ts * u, self.f * v];
        let [prr, prv, pvv] = a.p;
        let (f, g) = (self.f, self.g);
        a.p = [
            prr + 2.0 * g * prv + g * g * pvv + psd * self.q[0],
            f * (prv + g * pvv) + psd * self.q[1],
            f * f * pvv + psd * self.q[2],
        ];
    }

    /// Scalar update of the offset with measurement `z`, variance `var`.
    fn correct(a: &mut Axis, nu: f32, s: f32) {
        let [prr, prv, pvv] = a.p;
        let inv = 1.0 / s;
        let k = [prr * inv, prv * inv];
        a.x = [a.x[0] + k[0] * nu, a.x[1] + k[1] * nu];
        a.p = [prr - k[0] * prr, prv - k[0] * prv, pvv - k[1] * prv];
    }
}

/// Process noise `[rr, rv, vv]` of the Gauss-Markov model over `h` for PSD `psd`, with
/// `f = exp(-h / τ)`: the integrals of `τ² (1 - e)²`, `τ (1 - e) e` and `e²`,
/// `e = exp(-s / τ)`, over `s` in `[0, h]`, times `psd`. In closed form
/// `rr = psd τ² (h - 2 τ (1 - f) + τ (1 - f²) / 2)`, `rv = psd τ² ((1 - f) - (1 - f²) / 2)`,
/// `vv = psd τ (1 - f²) / 2`; for `h < 1.5 τ` (every step, and the gates' horizons) the
/// closed forms lose most of their digits to cancellation in `f32`, so their Taylor series in
/// `x = h / τ` (to the eleventh power, 0.2 % at `x = 1.5`) are used there.
fn prediction_noise(tau: f32, psd: f32, h: f32, f: f32) -> [f32; 3] {
    let x = h / tau;
    if x >= 1.5 {
        let f2 = f * f;
        return [
            psd * tau * tau * (h - 2.0 * tau * (1.0 - f) + tau * (1.0 - f2) / 2.0),
            psd * tau * tau * ((1.0 - f) - (1.0 - f2) / 2.0),
            psd * tau * (1.0 - f2) / 2.0,
        ];
    }
    // Horner in x of the series' coefficients from the lowest power shown.
    let horner = |c: &[f32]| c.iter().rev().fold(0.0, |acc, &k| acc * x + k);
    let rr = horner(&[
        1.0 / 3.0,
        -1.0 / 4.0,
        7.0 / 60.0,
        -1.0 / 24.0,
        31.0 / 2520.0,
        -1.0 / 320.0,
        127.0 / 181_440.0,
        -17.0 / 120_960.0,
        73.0 / 2_851_200.0,
    ]) * x
        * x
        * x;
    let rv = horner(&[
        1.0 / 2.0,
        -1.0 / 2.0,
        7.0 / 24.0,
        -1.0 / 8.0,
        31.0 / 720.0,
        -1.0 / 80.0,
        127.0 / 40_320.0,
        -17.0 / 24_192.0,
        73.0 / 518_400.0,
        -31.0 / 1_209_600.0,
    ]) * x
        * x;
    let vv = horner(&[
        1.0,
        -1.0,
        2.0 / 3.0,
        -1.0 / 3.0,
        2.0 / 15.0,
        -2.0 / 45.0,
        4.0 / 315.0,
        -1.0 / 315.0,
        2.0 / 2835.0,
        -2.0 / 14_175.0,
        4.0 / 155_925.0,
    ]) * x;
    let t3 = psd * tau * tau * tau;
    [t3 * rr, psd * tau * tau * rv, psd * tau * vv]
}

/// What the estimator needs from its configuration at the control period, derived once.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EstimatorModel {
    lateral: AxisModel,
    forward: AxisModel,
    /// `τ` of the lateral model, s.
    tau_s: f32,
    /// `2 / τ`: the PSD per unit stationary velocity variance of the Gauss-Markov process
    /// (the gates' predictions), 1/s.
    psd_per_variance: f32,
    /// The filter's PSD per unit stationary velocity variance ([`filter_psd_per_variance`]),
    /// 1/s.
    filter_psd_per_variance: f32,
    /// The filter's least PSD, m²/s³: `filter_psd_per_variance` times the square of
    /// [`EstimatorConfig::drogue_speed_floor_mps`].
    filter_psd_floor: f32,
    /// Step of the velocity-variance average, `Ts / activity_time_constant_s`.
    activity_step: f32,
    /// Step of the offset's average, `Ts / mean_time_constant_s`.
    mean_step: f32,
    ts: f32,
    /// Step of the acceleration's low-pass, `1 - exp(-Ts / drogue_accel_time_constant_s)`
    /// (exact: stable at any period).
    accel_step: f32,
    /// The feed-forward's velocity `lead` ahead is `lead[0] v + lead[1] a + lead[2] d`
    /// (`d` the velocity's average, the drift).
    lead: [f32; 3],
    /// [`EstimatorConfig::bearing_bias_sigma_rad`] squared, rad².
    bearing_bias_variance: [f32; 2],
    /// The hose's swing period the model was built for, s (0: none).
    swing_period_s: f32,
}

impl EstimatorModel {
    /// Discretises the model of `cfg` at the period `ts_s`, with the feed-forward's lead
    /// `lead_s` ([`DrogueEstimator::drogue_velocity_ahead`]), at the single-point design's
    /// flight condition (the swing's configured period).
    pub fn new(cfg: &EstimatorConfig, ts_s: f32, lead_s: f32) -> Self {
        Self::at(cfg, ts_s, lead_s, FlightCondition::default())
    }

    /// [`EstimatorModel::new`] at the flight condition `condition`: the hose's swing at its
    /// dynamic pressure ([`swing_period_s`]) for the feed-forward's lead and the filter's
    /// process noise. Not for the step: two powers and a sine (the controller rebuilds it
    /// where it loads the gain schedule's design for a new condition).
    pub fn at(cfg: &EstimatorConfig, ts_s: f32, lead_s: f32, condition: FlightCondition) -> Self {
        let tau = cfg.drogue_time_constant_s;
        let period = if cfg.drogue_swing_period_s > 0.0 {
            swing_period_s(cfg, condition)
        } else {
            0.0
        };
        let filter = filter_psd_per_variance(cfg, period);
        Self {
            lateral: AxisModel::new(tau, ts_s),
            forward: AxisModel::with_psd(
                cfg.drogue_fwd_time_constant_s,
                ts_s,
                cfg.drogue_fwd_accel_psd_m2ps3,
            ),
            tau_s: tau,
            psd_per_variance: 2.0 / tau,
            filter_psd_per_variance: filter,
            filter_psd_floor: filter * cfg.drogue_speed_floor_mps * cfg.drogue_speed_floor_mps,
            activity_step: ts_s / cfg.activity_time_constant_s,
            mean_step: ts_s / cfg.mean_time_constant_s,
            ts: ts_s,
            accel_step: 1.0 - libm::expf(-ts_s / cfg.drogue_accel_time_constant_s),
            lead: swing_lead(cfg, period, lead_s),
            swing_period_s: period,
            bearing_bias_variance: cfg.bearing_bias_sigma_rad.map(|b| b * b),
        }
    }
}

impl EstimatorModel {
    /// The hose's swing period this model carries the feed-forward along, s (0: none).
    pub fn swing_period_s(&self) -> f32 {
        self.swing_period_s
    }
}

/// Why the estimator restarted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Restart {
    /// Too many consecutive frames rejected by the innovation gate.
    Rejections,
    /// An update produced a non-finite value.
    NonFinite,
}

/// What one correction did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Correction {
    /// The frame was rejected by the innovation gate.
    pub rejected: bool,
    /// The filter restarted from the frame.
    pub restarted: Option<Restart>,
}

/// A frame as the estimator takes it: the drogue's offset from the tip in tanker axes
/// (`[right, down, forward]`) and the camera's depth (for the noise model).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TipFrame {
    /// Drogue centre minus probe tip, `[right, down, forward]`, m.
    pub drogue_from_tip_m: [f32; 3],
    /// The camera's depth to the drogue, m.
    pub camera_depth_m: f32,
}

/// The drogue estimator (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DrogueEstimator {
    /// Right, down, forward (the forward axis's offset is the depth).
    axes: [Axis; 3],
    /// Average of the estimated drogue velocity's square, right and down, m²/s².
    activity: [f32; 2],
    /// Average of the offset, right and down, m.
    mean_offset: [f32; 2],
    /// The drogue's acceleration, right and down (the change of the estimated velocity,
    /// low-passed), m/s².
    accel: [f32; 2],
    /// The estimated velocity at the previous step, right and down, m/s.
    velocity_before: [f32; 2],
    /// Average of the estimated velocity, right and down, m/s (the activity's average): the
    /// part of the drogue's apparent motion that is not its swing, which has no mean (a
    /// mount error's apparent drift while closing, a slow relative drift).
    drift: [f32; 2],
    /// Consecutive rejected frames.
    rejections: u16,
    /// The filter holds an estimate (started from a frame).
    started: bool,
}

impl DrogueEstimator {
    /// True once started from a frame (and until [`DrogueEstimator::stop`]).
    pub fn started(&self) -> bool {
        self.started
    }

    /// Forgets the estimate (standby): it reads as zero until the next
    /// [`DrogueEstimator::start`], which sets every field. (Only the flag is cleared:
    /// overwriting the whole filter compiled to a `memclr` loop in the step, which the static
    /// bound of its instructions cannot follow.)
    pub fn stop(&mut self) {
        self.started = false;
    }

    /// Starts from `frame`: offset and depth as measured, the drogue at rest, with the
    /// configured initial uncertainty, and the activity at the configured PSD's level.
    pub fn start(&mut self, frame: &TipFrame, cfg: &EstimatorConfig) {
        self.restart(frame, cfg);
        self.mean_offset = [frame.drogue_from_tip_m[0], frame.drogue_from_tip_m[1]];
        self.drift = [0.0; 2];
        // The configured PSD's stationary velocity variance, q τ / 2.
        self.activity = [cfg.drogue_accel_psd_m2ps3 * cfg.drogue_time_constant_s / 2.0; 2];
    }

    /// [`DrogueEstimator::start`] keeping the measured activity (a restart after rejections
    /// is the same air).
    fn restart(&mut self, frame: &TipFrame, cfg: &EstimatorConfig) {
        let (r_var, z_var) = noise_variances(frame.camera_depth_m, cfg);
        let v0 = cfg.initial_velocity_sigma_mps * cfg.initial_velocity_sigma_mps;
        self.axes = [0, 1, 2].map(|i| Axis {
            x: [frame.drogue_from_tip_m[i], 0.0],
            p: [if i < 2 { r_var } else { z_var }, 0.0, v0],
        });
        self.rejections = 0;
        self.accel = [0.0; 2];
        self.velocity_before = [0.0; 2];
        self.started = true;
    }

    /// Advances the belief by one step with the probe tip's velocity relative to the tanker
    /// `[right, down, forward]`, m/s (from navigation).
    #[inline(always)]
    pub fn predict(&mut self, tip_velocity_mps: [f32; 3], m: &EstimatorModel) {
        for ((a, before), ax) in self
            .accel
            .iter_mut()
            .zip(&mut self.velocity_before)
            .zip(&self.axes)
        {
            *a += m.accel_step * ((ax.x[1] - *before) / m.ts - *a);
            *before = ax.x[1];
        }
        // The air's drive as measured, through the swing's relation, at least the floor.
        let psd = self
            .activity
            .map(|a| max_to(m.filter_psd_per_variance * a, m.filter_psd_floor));
        let [right, down, fwd] = &mut self.axes;
        m.lateral.predict(right, tip_velocity_mps[0], m.ts, psd[0]);
        m.lateral.predict(down, tip_velocity_mps[1], m.ts, psd[1]);
        m.forward.predict(fwd, tip_velocity_mps[2], m.ts, 1.0);
        for (((a, r), d), ax) in self
            .activity
            .iter_mut()
            .zip(&mut self.mean_offset)
            .zip(&mut self.drift)
            .zip(&self.axes)
        {
            *a += m.activity_step * (ax.x[1] * ax.x[1] - *a);
            *r += m.mean_step * (ax.x[0] - *r);
            *d += m.activity_step * (ax.x[1] - *d);
        }
    }

    /// Corrects the belief with a valid frame (after [`DrogueEstimator::predict`]).
    #[inline(always)]
    pub fn correct(&mut self, frame: &TipFrame, cfg: &EstimatorConfig) -> Correction {
        let (r_var, z_var) = noise_variances(frame.camera_depth_m, cfg);
        let var = [r_var, r_var, z_var];
        let g2 = cfg.gate_sigmas * cfg.gate_sigmas;
        // Gate on the three axes together: one outlier frame is one frame.
        let nu: [f32; 3] = core::array::from_fn(|i| frame.drogue_from_tip_m[i] - self.axes[i].x[0]);
        let s: [f32; 3] = core::array::from_fn(|i| self.axes[i].p[0] + var[i]);
        let outside = (0..3).any(|i| nu[i] * nu[i] > g2 * s[i]);
        if outside {
            self.rejections = self.rejections.saturating_add(1);
            let restarted = (self.rejections > cfg.max_rejections).then(|| {
                self.restart(frame, cfg);
                Restart::Rejections
            });
            return Correction {
                rejected: true,
                restarted,
            };
        }
        self.rejections = 0;
        for (ax, (nu, s)) in self.axes.iter_mut().zip(nu.into_iter().zip(s)) {
            AxisModel::correct(ax, nu, s);
        }
        if !self.is_finite() {
            self.start(frame, cfg);
            return Correction {
                rejected: false,
                restarted: Some(Restart::NonFinite),
            };
        }
        Correction::default()
    }

    /// Every state and covariance entry is finite. One sum: it is finite only if every term
    /// is (an infinity or a NaN carries into it, and opposite infinities give NaN); finite
    /// terms could only make it overflow near `f32::MAX`, far beyond any offset, velocity or
    /// variance here, where restarting is right anyway. A sum, not fifteen tests: this runs
    /// on every corrected frame, on the step's dearest path.
    fn is_finite(&self) -> bool {
        self.axes
            .iter()
            .map(|ax| ax.x[0] + ax.x[1] + ax.p[0] + ax.p[1] + ax.p[2])
            .sum::<f32>()
            .is_finite()
    }

    /// The belief now.
    pub fn estimate(&self) -> DrogueEstimate {
        if !self.started {
            return DrogueEstimate::default();
        }
        let [r, d, z] = &self.axes;
        DrogueEstimate {
            offset_m: [r.x[0], d.x[0]],
            mean_offset_m: self.mean_offset,
            drogue_velocity_mps: [r.x[1], d.x[1], z.x[1]],
            depth_m: z.x[0],
        }
    }

    /// Variance of the offset estimate, `[right, down]`, m².
    pub fn offset_variance_m2(&self) -> [f32; 2] {
        [self.axes[0].p[0], self.axes[1].p[0]]
    }

    /// Variance of the offset's error about the truth, `[right, down]`, m²: the filter's
    /// own ([`DrogueEstimator::offset_variance_m2`]) and the angular bias's it does not
    /// estimate, `(σ_b D)²` at the estimated depth `D`
    /// ([`EstimatorConfig::bearing_bias_sigma_rad`]).
    pub fn offset_error_variance_m2(&self, m: &EstimatorModel) -> [f32; 2] {
        let b = self.bearing_bias_variance_m2(m);
        [self.axes[0].p[0] + b[0], self.axes[1].p[0] + b[1]]
    }

    /// The angular bias's variance at the estimated depth, `[right, down]`, m².
    #[inline(always)]
    fn bearing_bias_variance_m2(&self, m: &EstimatorModel) -> [f32; 2] {
        let d2 = self.axes[2].x[0] * self.axes[2].x[0];
        m.bearing_bias_variance.map(|v| v * d2)
    }

    /// Variance of the depth estimate, m².
    pub fn depth_variance_m2(&self) -> f32 {
        self.axes[2].p[0]
    }

    /// Variance of the drogue's velocity estimate, `[right, down]`, m²/s².
    pub fn velocity_variance_m2ps2(&self) -> [f32; 2] {
        [self.axes[0].p[2], self.axes[1].p[2]]
    }

    /// The drogue's RMS lateral speed as measured (the square root of the larger axis's
    /// velocity-variance average), m/s: how hard the air drives it.
    pub fn drogue_speed_rms_mps(&self) -> f32 {
        crate::num::sqrt(max_to(max_to(self.activity[0], self.activity[1]), 0.0))
    }

    /// The PSD the air drives the drogue with, as measured, `[right, down]`, m²/s³.
    pub fn measured_accel_psd_m2ps3(&self, m: &EstimatorModel) -> [f32; 2] {
        self.activity.map(|a| m.psd_per_variance * a)
    }

    /// The drogue's velocity the feed-forward's lead ahead, `[right, down]`, m/s: its
    /// velocity and acceleration now carried along the hose's swing (or, with no swing
    /// configured, its velocity decayed as the model says).
    #[inline(always)]
    pub fn drogue_velocity_ahead(&self, m: &EstimatorModel) -> [f32; 2] {
        [0, 1].map(|i| {
            m.lead[0] * self.axes[i].x[1] + m.lead[1] * self.accel[i] + m.lead[2] * self.drift[i]
        })
    }

    /// The estimated velocity's average, `[right, down]`, m/s: the drift the feed-forward
    /// carries unchanged ([`DrogueEstimator::drogue_velocity_ahead`]).
    pub fn drogue_drift_mps(&self) -> [f32; 2] {
        self.drift
    }

    /// The drogue's acceleration estimate, `[right, down]`, m/s².
    pub fn drogue_accel_mps2(&self) -> [f32; 2] {
        self.accel
    }

    /// The offset `horizon_s` ahead if the probe tip kept the velocity `tip_velocity_mps`
    /// (`[right, down]`) and nothing were measured, with its variance: the estimate's own,
    /// carried over the horizon, plus the drogue's unpredictable motion over it at the
    /// measured PSD, plus the angular bias's at the present depth
    /// ([`DrogueEstimator::offset_error_variance_m2`]). One exponential (`num::exp_neg`) and
    /// one division.
    #[inline(always)]
    pub fn predict_offset(
        &self,
        horizon_s: f32,
        tip_velocity_mps: [f32; 2],
        m: &EstimatorModel,
    ) -> [AxisPrediction; 2] {
        let (h, tau) = (horizon_s, m.tau_s);
        // `h / τ` is within `num::EXP_NEG_MAX`: the horizon is at most `gate_max_horizon_s`,
        // which the configuration's validation keeps within 1.5 τ.
        let f = crate::num::exp_neg(h / tau);
        let g = tau * (1.0 - f);
        let bias = self.bearing_bias_variance_m2(m);
        [0, 1].map(|i| {
            let ax = &self.axes[i];
            let [prr, prv, pvv] = ax.p;
            let q = prediction_noise(tau, m.psd_per_variance * self.activity[i], h, f);
            AxisPrediction {
                mean_m: ax.x[0] + g * ax.x[1] - h * tip_velocity_mps[i],
                variance_m2: prr + 2.0 * g * prv + g * g * pvv + q[0] + bias[i],
            }
        })
    }
}

/// Longest lead along the swing, rad of its phase (a quarter swing: 0.255 of its period):
/// beyond, the velocity now enters with the opposite sign, and a lead of 1 s on a 3.5 s
/// swing (1.8 rad) docked fewer at the first attempt than 0.8 s (`docs/scenarios.md`).
pub const MAX_SWING_LEAD_RAD: f32 = 2.0 * crate::num::SIN_COS_MAX_RAD;

/// The hose's swing period at the flight condition `at`, s: the configured period (at the
/// single-point design's condition, [`FlightCondition::default`]) times the ratio of the two
/// conditions' dynamic pressures to the power `-drogue_swing_period_exponent`, at most the
/// configured period. The hose
/// swings against its drag's tension, which grows with the dynamic pressure; measured on the
/// simulated hose at the gain schedule's sixteen nodes (`docs/conventions.md`, "Drogue
/// estimator"). The air's density is the International Standard Atmosphere's in the
/// troposphere (`ρ ∝ (1 - 2.25577e-5 h)^4.25588`, h in m), which covers the envelope.
/// 0 when no swing is configured.
pub fn swing_period_s(cfg: &EstimatorConfig, at: FlightCondition) -> f32 {
    let q = |c: FlightCondition| {
        libm::powf(1.0 - 2.255_77e-5 * c.altitude_m, 4.255_88)
            * c.true_airspeed_mps
            * c.true_airspeed_mps
    };
    let ratio = q(at) / q(FlightCondition::default());
    // Shorter where the air pulls harder; never longer than configured (below the design's
    // dynamic pressure the loops are slower, and the lead along the configured swing stands
    // in for the longer lead they would need: see the configuration's field).
    cfg.drogue_swing_period_s * min_to(libm::powf(ratio, -cfg.drogue_swing_period_exponent), 1.0)
}

/// The PSD of the noise that drives the drogue's velocity per unit of its stationary
/// variance, as the filter takes it, 1/s. The drogue swings as a lightly damped mode (period
/// `P`, damping ratio `ζ`); such a mode, driven by white noise of PSD `q`, has the
/// stationary velocity variance `q / (4 ζ ω)`, `ω = 2π / P`: so `4 ζ ω` (0.64/s at 3.9 s
/// and 0.10). The Gauss-Markov process's own relation, `2 / τ` (1.54/s at 1.3 s), says the
/// velocity forgets itself 2.4 times faster than the swing does and made the filter's
/// velocity sigma twice its error (`docs/conventions.md`, "Drogue estimator"). With no
/// swing configured (period or damping 0), `2 / τ`. `period_s`: the swing's period at the
/// flight condition ([`swing_period_s`]).
fn filter_psd_per_variance(cfg: &EstimatorConfig, period_s: f32) -> f32 {
    if period_s > 0.0 && cfg.drogue_swing_damping_ratio > 0.0 {
        4.0 * cfg.drogue_swing_damping_ratio * 2.0 * core::f32::consts::PI / period_s
    } else {
        2.0 / cfg.drogue_time_constant_s
    }
}

/// The feed-forward's coefficients `[kv, ka, kd]`: the drogue's velocity `lead_s` ahead is
/// `kv v + ka a + kd d`. On a swing of angular frequency `ω` (the period at the flight
/// condition) a velocity `v` with acceleration `a` is `v cos ωh + (a / ω) sin ωh` after
/// `h`: the swing's phase carried over the lead, which a decaying velocity cannot give (the
/// inner loops' lag is about half a second at the swing's frequency, more on heavy
/// airframes). The swing has no mean, so the velocity's average `d` (a drift: the apparent
/// one a mount error gives while closing) is carried unchanged: `v cos ωh` becomes
/// `d + (v - d) cos ωh`, `kd = 1 - cos ωh`. At most [`MAX_SWING_LEAD_RAD`] of the swing.
/// Without a swing, `kv = exp(-h / τ)`, `ka = kd = 0`.
fn swing_lead(cfg: &EstimatorConfig, period_s: f32, lead_s: f32) -> [f32; 3] {
    if period_s > 0.0 {
        let w = 2.0 * core::f32::consts::PI / period_s;
        // At most a quarter swing ahead: the configuration keeps the lead within it at the
        // configured period; a faster swing (higher dynamic pressure) is carried no further
        // than a quarter of its own. Double angle: `ωh / 2` within `sin_cos`'s range.
        let half = min_to(0.5 * w * lead_s, crate::num::SIN_COS_MAX_RAD);
        let (s, c) = sin_cos(half);
        let kv = c * c - s * s;
        // The swing has no mean: the velocity's average (the drift) is carried unchanged.
        [kv, 2.0 * s * c / w, 1.0 - kv]
    } else {
        [libm::expf(-lead_s / cfg.drogue_time_constant_s), 0.0, 0.0]
    }
}

/// Variances of a frame's lateral offset and depth at camera depth `z`, m².
#[inline(always)]
fn noise_variances(z: f32, cfg: &EstimatorConfig) -> (f32, f32) {
    let r = cfg.offset_noise_m + cfg.offset_noise_per_m * z;
    let d = cfg.depth_noise_m + cfg.depth_noise_per_m2 * z * z;
    (r * r, d * d)
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;

    const TS: f32 = 0.02;
    const LEAD_S: f32 = 0.8;

    fn tip_camera() -> TipGeometry {
        let cam = CameraMount {
            position_body_m: [6.06, 0.54, -0.86],
            pitch_down_rad: 0.11,
        };
        TipGeometry::new(&cam, [6.06, 0.54, -0.86], 0.11)
    }

    #[test]
    fn a_tip_camera_at_trim_sees_the_offset_as_image_point_times_depth() {
        let g = tip_camera();
        assert_eq!(g.tip_from_camera_m(), [0.0, 0.0, 0.0]);
        let r = g.drogue_from_tip([0.25, -0.1], 4.0, [0.0; 3], g.tip_image());
        assert_eq!(r, [1.0, -0.4, 4.0]);
    }

    #[test]
    fn at_another_trim_the_fixed_mount_looks_up_and_the_geometry_turns_it_level() {
        // A tip camera mounted level at 0.11 rad of trim pitch, flown at 0.26 rad: the
        // boresight is 0.15 rad up. A drogue 4 m straight ahead on the tanker's axis is then
        // below the boresight, 4 cos(0.15) m along it and 4 sin(0.15) m down in its axes.
        let cam = CameraMount {
            position_body_m: [6.06, 0.54, -0.86],
            pitch_down_rad: 0.11,
        };
        let g = TipGeometry::new(&cam, [6.06, 0.54, -0.86], 0.26);
        let e = 0.15_f32;
        let (z, y) = (4.0 * libm::cosf(e), 4.0 * libm::sinf(e));
        let r = g.drogue_from_tip([0.0, y / z], z, [0.0; 3], g.tip_image());
        for (got, want) in r.iter().zip([0.0, 0.0, 4.0]) {
            assert!((got - want).abs() < 1e-4, "{r:?}");
        }
        // Unturned (the mount's own trim), the same frame would read 0.6 m low.
        let level = TipGeometry::new(&cam, [6.06, 0.54, -0.86], 0.11);
        let r = level.drogue_from_tip([0.0, y / z], z, [0.0; 3], level.tip_image());
        assert!((r[1] - y).abs() < 1e-4, "{r:?}");
    }

    #[test]
    fn a_set_back_camera_removes_the_tip_offset() {
        // Camera 2.66 m behind the tip and 0.24 m above it: the tip is 2.66 m ahead and
        // 0.24 m below in the camera's trim-level axes.
        let theta = 0.11_f32;
        let cam = CameraMount {
            position_body_m: [3.4, 0.54, -1.10],
            pitch_down_rad: theta,
        };
        let tip = [6.06, 0.54, -0.86];
        let g = TipGeometry::new(&cam, tip, theta);
        let t = g.tip_from_camera_m();
        // Body offset (2.66, 0, 0.24) rotated by the trim pitch into level axes.
        let (s, c) = (libm::sinf(theta), libm::cosf(theta));
        assert!((t[2] - (2.66 * c + 0.24 * s)).abs() < 1e-5, "{t:?}");
        assert!((t[1] - (-2.66 * s + 0.24 * c)).abs() < 1e-5, "{t:?}");
        assert!(t[0].abs() < 1e-6);
        // A drogue exactly ahead of the tip, 1 m beyond it: offset zero, depth 1 m.
        let z = t[2] + 1.0;
        let r = g.drogue_from_tip([t[0] / z, t[1] / z], z, [0.0; 3], g.tip_image());
        assert!(r[0].abs() < 1e-6 && r[1].abs() < 1e-6 && (r[2] - 1.0).abs() < 1e-5);
        // A camera believed 5 cm further right than it is sees the drogue (ahead of the tip)
        // and the tip 5 cm further left than the geometry says: with the tip's measured image
        // point the offset is still zero (the belief only scales the tip's depth); with the
        // geometry's it is off by the 5 cm.
        let seen_tip = [(t[0] - 0.05) / t[2], t[1] / t[2]];
        let seen_drogue = [(t[0] - 0.05) / z, t[1] / z];
        let measured = g.drogue_from_tip(seen_drogue, z, [0.0; 3], seen_tip);
        let believed = g.drogue_from_tip(seen_drogue, z, [0.0; 3], g.tip_image());
        assert!(measured[0].abs() < 1e-5, "{measured:?}");
        assert!((believed[0] + 0.05).abs() < 1e-5, "{believed:?}");
    }

    #[test]
    fn de_rotation_removes_the_attitudes_effect_on_the_image() {
        // A drogue 5 m straight ahead of a tip camera; the nose pitched up 2 degrees puts it
        // below the boresight, yawed right 2 degrees to its left. De-rotated: still ahead.
        let g = tip_camera();
        let (a, z) = (2f32.to_radians(), 5.0_f32);
        let tip = g.tip_image();
        let pitched = g.drogue_from_tip([0.0, libm::tanf(a)], z, [0.0, a, 0.0], tip);
        assert!(pitched[1].abs() < 2e-3 * z, "{pitched:?}");
        let yawed = g.drogue_from_tip([-libm::tanf(a), 0.0], z, [0.0, 0.0, a], tip);
        assert!(yawed[0].abs() < 2e-3 * z, "{yawed:?}");
        // Rolled right 2 degrees (about the body axis, pitched up by the trim pitch): a
        // drogue 1 m to the right appears above and right; de-rotated, right and level.
        let roll = g.drogue_from_tip(
            [1.0 * libm::cosf(a) / z, -libm::sinf(a) / z],
            z,
            [a, 0.0, 0.0],
            tip,
        );
        assert!(
            (roll[0] - 1.0).abs() < 0.02 && roll[1].abs() < 0.02,
            "{roll:?}"
        );
    }

    #[test]
    fn the_tip_sight_averages_near_the_geometry_and_rejects_the_rest() {
        let cam = CameraMount {
            position_body_m: [3.4, 0.54, -1.10],
            pitch_down_rad: 0.11,
        };
        let g = TipGeometry::new(&cam, [6.06, 0.54, -0.86], 0.11);
        let cfg = EstimatorConfig::default();
        let mut s = TipSight::new(&g);
        assert_eq!(s.image(), g.tip_image());
        assert_eq!(s.observe(None, &cfg), TipSighting::None);
        let off = [g.tip_image()[0] + 0.02, g.tip_image()[1]];
        for _ in 0..200 {
            assert_eq!(s.observe(Some(off), &cfg), TipSighting::Used);
        }
        assert!((s.image()[0] - off[0]).abs() < 1e-4, "{:?}", s.image());
        // A mount 0.5 m off across the boresight and 2° off is inside; 0.1 beyond is not.
        let bound = 0.5 / g.tip_from_camera_m()[2] + 2.0_f32.to_radians();
        assert!(bound < cfg.tip_sight_tolerance, "{bound}");
        let inside = [g.tip_image()[0], g.tip_image()[1] - bound];
        let mut learned = s;
        assert_eq!(learned.observe(Some(inside), &cfg), TipSighting::Used);
        let far = [
            g.tip_image()[0] + cfg.tip_sight_tolerance + 0.01,
            g.tip_image()[1],
        ];
        assert_eq!(s.observe(Some(far), &cfg), TipSighting::Rejected);
        assert_eq!(
            s.observe(Some([f32::NAN, 0.0]), &cfg),
            TipSighting::Rejected
        );
        assert!((s.image()[0] - off[0]).abs() < 1e-4, "rejections leave it");
    }

    fn model() -> (EstimatorConfig, EstimatorModel) {
        let cfg = EstimatorConfig::default();
        (cfg, EstimatorModel::new(&cfg, TS, LEAD_S))
    }

    #[test]
    fn the_discretisation_is_the_processes_own() {
        // The transition over n steps equals the one over n Ts; the process noise over n
        // steps (propagated) equals the closed form over n Ts.
        let (cfg, m) = model();
        let tau = cfg.drogue_time_constant_s;
        let mut a = Axis {
            x: [0.1, 0.3],
            p: [0.0; 3],
        };
        let n = 50;
        for _ in 0..n {
            m.lateral
                .predict(&mut a, 0.0, TS, cfg.drogue_accel_psd_m2ps3);
        }
        let h = n as f32 * TS;
        let f = libm::expf(-h / tau);
        assert!((a.x[1] - 0.3 * f).abs() < 1e-6, "{a:?}");
        assert!(
            (a.x[0] - (0.1 + 0.3 * tau * (1.0 - f))).abs() < 1e-5,
            "{a:?}"
        );
        let q = prediction_noise(tau, cfg.drogue_accel_psd_m2ps3, h, f);
        for (got, want) in a.p.iter().zip(q) {
            assert!(
                (got - want).abs() < 1e-4 * want.abs().max(1e-6),
                "{a:?} vs {q:?}"
            );
        }
        // Stationary velocity variance: q τ / 2.
        let long = prediction_noise(tau, 1.0, 1000.0, 0.0);
        assert!((long[2] - tau / 2.0).abs() < 1e-6);
        // Short horizons: the double integrator's q h³ / 3, q h² / 2, q h.
        let short = prediction_noise(tau, 1.0, 0.01, libm::expf(-0.01 / tau));
        assert!((short[0] / (1e-6 / 3.0) - 1.0).abs() < 0.01, "{short:?}");
        assert!((short[1] / (1e-4 / 2.0) - 1.0).abs() < 0.01, "{short:?}");
        assert!((short[2] / 1e-2 - 1.0).abs() < 0.01, "{short:?}");
        // The series and the closed form agree where they meet (x = 1.5), computed in f64.
        for x in [0.3_f64, 1.0, 1.49] {
            let t = f64::from(tau);
            let h = x * t;
            let f = (-x).exp();
            let exact = [
                t * t * (h - 2.0 * t * (1.0 - f) + t * (1.0 - f * f) / 2.0),
                t * t * ((1.0 - f) - (1.0 - f * f) / 2.0),
                t * (1.0 - f * f) / 2.0,
            ];
            let got = prediction_noise(tau, 1.0, h as f32, f as f32);
            for (g, e) in got.iter().zip(exact) {
                assert!(
                    (f64::from(*g) / e - 1.0).abs() < 3e-3,
                    "x {x}: {got:?} vs {exact:?}"
                );
            }
        }
    }

    /// A drogue swinging at the hose's 0.25 Hz, seen by a fixed tip: the filter converges on
    /// its offset and velocity, and the feed-forward's velocity a lead ahead is the swing's.
    #[test]
    fn the_filter_tracks_a_swinging_drogue() {
        let (cfg, m) = model();
        let w = 1.6_f32;
        let truth = |t: f32| (0.3 * libm::sinf(w * t), 0.3 * w * libm::cosf(w * t));
        let frame = |t: f32| TipFrame {
            drogue_from_tip_m: [truth(t).0, -truth(t).0, 3.0],
            camera_depth_m: 3.0,
        };
        let mut e = DrogueEstimator::default();
        e.start(&frame(0.0), &cfg);
        let no_swing = EstimatorModel::new(
            &EstimatorConfig {
                drogue_swing_period_s: 0.0,
                ..cfg
            },
            TS,
            LEAD_S,
        );
        let mut worst = (0.0_f32, 0.0_f32);
        // Worst error of the velocity a lead ahead: along the swing, and decayed.
        let mut worst_ahead = (0.0_f32, 0.0_f32);
        for k in 1..500 {
            let t = k as f32 * TS;
            e.predict([0.0; 3], &m);
            let c = e.correct(&frame(t), &cfg);
            assert_eq!(c, Correction::default(), "step {k}");
            if t > 3.0 {
                let est = e.estimate();
                let (r, v) = truth(t);
                worst.0 = worst.0.max((est.offset_m[0] - r).abs());
                worst.1 = worst.1.max((est.drogue_velocity_mps[0] - v).abs());
                assert!((est.offset_m[1] + r).abs() < 0.01);
                let later = truth(t + LEAD_S).1;
                let ahead = e.drogue_velocity_ahead(&m);
                worst_ahead.0 = worst_ahead.0.max((ahead[0] - later).abs());
                assert!((ahead[1] + ahead[0]).abs() < 1e-6, "the down axis mirrors");
                let decayed = e.drogue_velocity_ahead(&no_swing)[0];
                worst_ahead.1 = worst_ahead.1.max((decayed - later).abs());
            }
        }
        // The swing carries the velocity's phase over the lead (ωh = 1.28 rad): off by 0.20
        // of the 0.48 m/s amplitude at worst (measured; the filter's velocity and the
        // acceleration's low-pass lag the truth by about 0.35 s between them), where the
        // decayed velocity, a fraction of the velocity now, is off by 0.50.
        assert!(
            worst_ahead.0 < 0.25 && worst_ahead.0 < 0.5 * worst_ahead.1,
            "worst error a lead ahead: swing, decayed {worst_ahead:?}"
        );
        assert!(
            worst.0 < 0.005 && worst.1 < 0.08,
            "worst offset, velocity error {worst:?}"
        );
        // The measured activity is the swing's: velocity amplitude 0.48 m/s, mean square
        // 0.115 m²/s² (within the average's ripple over a 4 s time constant).
        let q = e.measured_accel_psd_m2ps3(&m)[0];
        let want = 2.0 / cfg.drogue_time_constant_s * 0.5 * (0.3 * w) * (0.3 * w);
        assert!((q / want - 1.0).abs() < 0.3, "{q} vs {want}");
        // ... and its RMS speed, which chooses the rough-air contact speed: 0.48 / √2 m/s.
        let rms = e.drogue_speed_rms_mps();
        let want_rms = 0.3 * w / core::f32::consts::SQRT_2;
        assert!((rms / want_rms - 1.0).abs() < 0.15, "{rms} vs {want_rms}");
        // With no swing, the velocity a lead ahead has decayed by exp(-lead / τ).
        let now = e.estimate().drogue_velocity_mps[0];
        let ahead = e.drogue_velocity_ahead(&no_swing)[0];
        assert!((ahead - now * libm::expf(-LEAD_S / cfg.drogue_time_constant_s)).abs() < 1e-6);
        // Along the swing: `d + (v - d) cos ωh + (a / ω) sin ωh`, with the filtered
        // acceleration and the velocity's average (small: the swing has no mean).
        let wh = 2.0 * core::f32::consts::PI / cfg.drogue_swing_period_s * LEAD_S;
        let a = e.drogue_accel_mps2()[0];
        let d = e.drogue_drift_mps()[0];
        assert!(d.abs() < 0.1, "{d}");
        let along = d + (now - d) * libm::cosf(wh) + a * libm::sinf(wh) * LEAD_S / wh;
        assert!((e.drogue_velocity_ahead(&m)[0] - along).abs() < 1e-5);
    }

    #[test]
    fn a_drift_is_carried_ahead_unchanged() {
        // The drogue's apparent offset drifts at a steady 0.1 m/s right (a mount error seen
        // while closing): a lead ahead it still drifts so. The swing's term alone would carry
        // `cos ωh` of it (0.28 at 0.8 s of a 3.9 s swing).
        let (cfg, m) = model();
        let v0 = 0.1_f32;
        let frame = |t: f32| TipFrame {
            drogue_from_tip_m: [0.2 + v0 * t, 0.0, 3.0],
            camera_depth_m: 3.0,
        };
        let mut e = DrogueEstimator::default();
        e.start(&frame(0.0), &cfg);
        // 60 s: fifteen of the average's time constants, the steady state.
        for k in 1..3000 {
            e.predict([0.0; 3], &m);
            e.correct(&frame(k as f32 * TS), &cfg);
        }
        // The filter's velocity holds the drift within its Gauss-Markov model's steady lag
        // (the velocity decaying with τ between frames: 0.092 m/s measured), and the
        // prediction carries what it holds: the average is of the predicted velocity, one
        // step's decay (1.5 %) below the corrected one.
        let now = e.estimate().drogue_velocity_mps[0];
        assert!((now - v0).abs() < 0.15 * v0, "{now}");
        let step_decay = 1.0 - libm::expf(-TS / cfg.drogue_time_constant_s);
        let ahead = e.drogue_velocity_ahead(&m)[0];
        assert!(
            (ahead - now).abs() < (step_decay + 1e-3) * now,
            "{ahead} {now}"
        );
        assert!(
            (e.drogue_drift_mps()[0] - now).abs() < (step_decay + 1e-3) * now,
            "{:?} {now} {step_decay}",
            e.drogue_drift_mps()
        );
        // Restarted from a frame, the drift is forgotten with the rest.
        e.start(&frame(0.0), &cfg);
        assert_eq!(e.drogue_drift_mps(), [0.0; 2]);
    }

    #[test]
    fn the_tips_own_motion_is_not_taken_for_the_drogues() {
        // The drogue is still; the tip moves right at 0.5 m/s, so the offset shrinks. The
        // filter, told the tip's velocity, finds the drogue at rest.
        let (cfg, m) = model();
        let mut e = DrogueEstimator::default();
        let frame = |t: f32| TipFrame {
            drogue_from_tip_m: [1.0 - 0.5 * t, 0.0, 4.0],
            camera_depth_m: 4.0,
        };
        e.start(&frame(0.0), &cfg);
        for k in 1..200 {
            e.predict([0.5, 0.0, 0.0], &m);
            e.correct(&frame(k as f32 * TS), &cfg);
        }
        let est = e.estimate();
        assert!(est.drogue_velocity_mps[0].abs() < 0.02, "{est:?}");
        assert!(
            (est.offset_m[0] - (1.0 - 0.5 * 199.0 * TS)).abs() < 0.005,
            "{est:?}"
        );
        // And the prediction: the tip keeps closing the offset at 0.5 m/s.
        let p = e.predict_offset(0.4, [0.5, 0.0], &m);
        assert!(
            (p[0].mean_m - (est.offset_m[0] - 0.2)).abs() < 0.01,
            "{p:?}"
        );
    }

    #[test]
    fn an_outlier_is_rejected_and_a_real_jump_restarts_the_filter() {
        let (cfg, m) = model();
        let mut e = DrogueEstimator::default();
        let at = |r: f32| TipFrame {
            drogue_from_tip_m: [r, 0.0, 3.0],
            camera_depth_m: 3.0,
        };
        e.start(&at(0.1), &cfg);
        for _ in 0..100 {
            e.predict([0.0; 3], &m);
            e.correct(&at(0.1), &cfg);
        }
        e.predict([0.0; 3], &m);
        let c = e.correct(&at(2.0), &cfg);
        assert_eq!((c.rejected, c.restarted), (true, None));
        assert!(
            (e.estimate().offset_m[0] - 0.1).abs() < 0.01,
            "outlier ignored"
        );
        // The first jump was rejected; so are the next ones up to the limit...
        for k in 1..cfg.max_rejections {
            e.predict([0.0; 3], &m);
            let c = e.correct(&at(2.0), &cfg);
            assert!(c.rejected && c.restarted.is_none(), "{k}");
        }
        // ... and the one after it restarts the filter there.
        e.predict([0.0; 3], &m);
        let c = e.correct(&at(2.0), &cfg);
        assert_eq!(c.restarted, Some(Restart::Rejections));
        assert_eq!(e.estimate().offset_m[0], 2.0);
    }

    #[test]
    fn without_frames_the_belief_coasts_and_its_uncertainty_grows() {
        let (cfg, m) = model();
        let mut e = DrogueEstimator::default();
        e.start(
            &TipFrame {
                drogue_from_tip_m: [0.2, 0.0, 1.0],
                camera_depth_m: 1.0,
            },
            &cfg,
        );
        let v0 = e.offset_variance_m2()[0];
        let z0 = e.depth_variance_m2();
        // Still air: the measured activity decays from the configured level toward zero.
        let q0 = e.measured_accel_psd_m2ps3(&m)[0];
        // It starts at the configured PSD's RMS speed, sqrt(q τ / 2).
        let rms0 = e.drogue_speed_rms_mps();
        let want = libm::sqrtf(cfg.drogue_accel_psd_m2ps3 * cfg.drogue_time_constant_s / 2.0);
        assert!((rms0 - want).abs() < 1e-6, "{rms0} vs {want}");
        // Closing at 1 m/s for 0.5 s: depth dead-reckons to 0.5 m.
        for _ in 0..25 {
            e.predict([0.0, 0.0, 1.0], &m);
        }
        let est = e.estimate();
        assert!((est.depth_m - 0.5).abs() < 1e-4, "{est:?}");
        assert!((est.closing_mps(1.0) - 1.0).abs() < 1e-6);
        assert!(e.offset_variance_m2()[0] > v0 && e.depth_variance_m2() > z0);
        let q = e.measured_accel_psd_m2ps3(&m)[0];
        assert!(q < q0 * 0.9, "{q} vs {q0}");
        assert!(e.drogue_speed_rms_mps() < rms0);
    }

    #[test]
    fn the_filters_process_noise_is_the_measured_activity_through_the_swings_relation() {
        let (cfg, m) = model();
        // 4 ζ ω at the default swing (3.9 s, 0.10): 0.644/s, not the Gauss-Markov 2 / τ.
        let w = 2.0 * core::f32::consts::PI / cfg.drogue_swing_period_s;
        let k = 4.0 * cfg.drogue_swing_damping_ratio * w;
        let p = cfg.drogue_swing_period_s;
        assert!((filter_psd_per_variance(&cfg, p) - k).abs() < 1e-6);
        assert!((k - 0.644).abs() < 1e-3, "{k}");
        let no_swing = EstimatorConfig {
            drogue_swing_damping_ratio: 0.0,
            ..cfg
        };
        let gm = 2.0 / cfg.drogue_time_constant_s;
        assert!((filter_psd_per_variance(&no_swing, p) - gm).abs() < 1e-6);
        assert!((filter_psd_per_variance(&cfg, 0.0) - gm).abs() < 1e-6);
        // One step's growth of the velocity variance from a known belief: `f² p + psd q_vv`,
        // the PSD the activity's through the relation, or the floor's when the air is still.
        let step = |activity: [f32; 2]| {
            let mut e = DrogueEstimator::default();
            e.start(
                &TipFrame {
                    drogue_from_tip_m: [0.2, 0.1, 3.0],
                    camera_depth_m: 3.0,
                },
                &cfg,
            );
            e.activity = activity;
            let before = e.velocity_variance_m2ps2();
            e.predict([0.0; 3], &m);
            let f2 = m.lateral.f * m.lateral.f;
            [0, 1].map(|i| (e.velocity_variance_m2ps2()[i] - f2 * before[i]) / m.lateral.q[2])
        };
        let strong = step([0.09, 0.04]);
        assert!((strong[0] - k * 0.09).abs() < 1e-3 * k * 0.09, "{strong:?}");
        assert!((strong[1] - k * 0.04).abs() < 1e-3 * k * 0.04, "{strong:?}");
        let floor = k * cfg.drogue_speed_floor_mps * cfg.drogue_speed_floor_mps;
        let still = step([0.0, 1e-6]);
        for got in still {
            assert!((got - floor).abs() < 1e-3 * floor, "{still:?} vs {floor}");
        }
    }

    #[test]
    fn the_swing_period_falls_with_the_dynamic_pressure() {
        let cfg = EstimatorConfig::default();
        let at = |v: f32, h: f32| {
            swing_period_s(
                &cfg,
                FlightCondition {
                    true_airspeed_mps: v,
                    altitude_m: h,
                },
            )
        };
        // The configured period at the single-point design's condition.
        let p0 = swing_period_s(&cfg, FlightCondition::default());
        assert!((p0 - cfg.drogue_swing_period_s).abs() < 1e-6, "{p0}");
        // 170 m/s at 500 m: 2.58 times the dynamic pressure, 0.718 of the period (the
        // hose measured 2.56 s).
        let fast_low = at(170.0, 500.0);
        assert!((fast_low - 2.80).abs() < 0.01, "{fast_low}");
        // Below the design's dynamic pressure (100 m/s at 8,000 m: 0.40 of it, where the law
        // gives 5.37 s and the hose 4.68 s) the configured period stays.
        assert_eq!(at(100.0, 8000.0), p0);
        assert_eq!(at(120.0, 5500.0), p0);
        // Faster or lower, shorter.
        assert!(at(145.0, 3000.0) < p0 && at(120.0, 500.0) < p0);
        // The exponent 0 keeps the configured period everywhere.
        let fixed = EstimatorConfig {
            drogue_swing_period_exponent: 0.0,
            ..cfg
        };
        let c = FlightCondition {
            true_airspeed_mps: 170.0,
            altitude_m: 500.0,
        };
        assert_eq!(swing_period_s(&fixed, c), cfg.drogue_swing_period_s);
        // The model built there carries the feed-forward along that swing: a quarter swing
        // at most (2.80 s: 0.70 s, inside the 0.8 s lead), the filter's noise `4 ζ ω`.
        let m = EstimatorModel::at(&cfg, TS, LEAD_S, c);
        assert!((m.swing_period_s() - fast_low).abs() < 1e-6);
        let w = 2.0 * core::f32::consts::PI / fast_low;
        let quarter = crate::num::SIN_COS_MAX_RAD * 2.0;
        assert!(
            w * LEAD_S > quarter,
            "the lead is beyond a quarter of the fast swing"
        );
        assert!(
            (m.lead[0] - libm::cosf(quarter)).abs() < 1e-3,
            "{:?}",
            m.lead
        );
        assert!(
            (m.lead[1] - libm::sinf(quarter) / w).abs() < 1e-3,
            "{:?}",
            m.lead
        );
        let k = 4.0 * cfg.drogue_swing_damping_ratio * w;
        assert!((m.filter_psd_per_variance - k).abs() < 1e-5);
        // At the design's condition the model is the configured one.
        assert_eq!(
            EstimatorModel::at(&cfg, TS, LEAD_S, FlightCondition::default()),
            EstimatorModel::new(&cfg, TS, LEAD_S)
        );
    }

    #[test]
    fn any_non_finite_entry_makes_the_belief_non_finite() {
        let cfg = EstimatorConfig::default();
        let mut e = DrogueEstimator::default();
        e.start(
            &TipFrame {
                drogue_from_tip_m: [0.2, -0.1, 3.0],
                camera_depth_m: 3.0,
            },
            &cfg,
        );
        assert!(e.is_finite());
        for axis in 0..3 {
            for entry in 0..5 {
                for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
                    let mut f = e;
                    let ax = &mut f.axes[axis];
                    if entry < 2 {
                        ax.x[entry] = bad;
                    } else {
                        ax.p[entry - 2] = bad;
                    }
                    assert!(!f.is_finite(), "axis {axis}, entry {entry}: {bad}");
                }
            }
        }
        // Opposite infinities do not cancel.
        let mut f = e;
        f.axes[0].x[0] = f32::INFINITY;
        f.axes[1].x[0] = f32::NEG_INFINITY;
        assert!(!f.is_finite());
        // Large finite entries, far beyond any real belief, are still finite.
        let mut f = e;
        f.axes[2].p[2] = 1e30;
        assert!(f.is_finite());
    }
}
