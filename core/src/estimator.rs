//! Drogue estimator: where the drogue is relative to the probe tip, how it moves, and where
//! it will be.
//!
//! Place in the data flow: beside the outer loop, in the refuelling procedure
//! ([`crate::procedure`]). Every engaged step it *predicts* with the probe tip's own velocity
//! from navigation (`C x`, tanker axes) and, when the step's camera frame is valid,
//! *corrects* with the frame turned into the drogue's offset from the probe tip
//! ([`TipGeometry::drogue_from_tip`]: camera set-back removed, de-rotated by the navigation
//! attitude into tanker axes). Its estimate feeds the outer loop's feed-forward, the go/no-go
//! gate's prediction and the capture phase, where a tip-mounted camera is blind and the
//! estimate runs on prediction alone.
//!
//! # Model (`docs/conventions.md`, "Drogue estimator")
//!
//! Per lateral axis (right, down), tanker axes:
//!
//! ```text
//! r' = v - u                      r: drogue centre minus probe tip, m (measured)
//! v' = -2 ζ ω v - ω² d + w_a      v: drogue velocity, m/s;  u: tip velocity (navigation)
//! d' = v + w_e                    d: drogue displacement from its trail equilibrium, m
//! ```
//!
//! the hose's swinging mode (natural frequency `ω`, damping `ζ`) driven by white acceleration
//! `w_a` (power spectral density `q_a`), with the trail's equilibrium wandering as a random
//! walk `w_e` (`q_e`: the slow, quasi-static response of the trail to the low-frequency gusts).
//! The numbers come from the simulated hose's response to Dryden turbulence, fitted by
//! `host-sim drogue-model`. Depth axis: `z' = w - u_fwd`, `w' = -w / τ + w_w` (the drogue's
//! forward motion is small and slow). Discretised once, at construction: the transition
//! matrix by its series to fourth order in `Ts` (`ω Ts` is 0.03), the process noise to first
//! order. Measurement noise grows with the camera's depth (`offset_noise_*`, `depth_noise_*`).
//!
//! How hard the drogue is being driven (the air's turbulence) is not configured but measured:
//! an exponential average of the estimated drogue velocity's square over
//! [`EstimatorConfig::activity_time_constant_s`] gives the stationary velocity variance, and
//! with it the acceleration PSD the predictions' uncertainty grows with (`q = 4 ζ ω E[v²]`,
//! the oscillator's stationary relation). It starts at the design PSD's level (cautious) and
//! settles within a few time constants: calm air makes the gate's margin small, strong
//! turbulence large.
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

/// Parameters of the drogue estimator.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EstimatorConfig {
    /// Natural frequency of the drogue's swinging mode, rad/s. Default 1.6 rad/s (period
    /// 3.9 s), fitted to the simulated hose (`host-sim drogue-model`).
    pub drogue_freq_radps: f32,
    /// Damping ratio of that mode. Default 0.1 (fitted).
    pub drogue_damping: f32,
    /// Power spectral density of the white acceleration driving the drogue's lateral and
    /// vertical motion, m²/s³. Default 0.04: the fit's 0.019 per (m/s of RMS gust)², at the
    /// design intensity of about 1.45 m/s (between the paper's level II and MIL-F-8785C's
    /// 10⁻² intensity at 3,000 m).
    pub drogue_accel_psd_m2ps3: f32,
    /// Power spectral density of the random walk of the trail's equilibrium, m²/s. Default
    /// 0.01 (the fit's 0.0046 per (m/s)² at the same design intensity).
    pub equilibrium_psd_m2ps: f32,
    /// Time constant of the drogue's forward velocity (first-order Gauss-Markov), s.
    pub drogue_fwd_time_constant_s: f32,
    /// Power spectral density of the drogue's forward acceleration, m²/s³.
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
    /// Initial standard deviation of the drogue's displacement from equilibrium, m.
    pub initial_displacement_sigma_m: f32,
    /// Innovation gate, standard deviations: a frame further from the prediction is rejected.
    pub gate_sigmas: f32,
    /// Time constant of the average of the drogue velocity's square that measures how hard
    /// the air drives the drogue (for the predictions' uncertainty), s.
    pub activity_time_constant_s: f32,
    /// Consecutive rejected frames after which the filter restarts from the frame.
    pub max_rejections: u16,
}

impl Default for EstimatorConfig {
    fn default() -> Self {
        Self {
            drogue_freq_radps: 1.6,
            drogue_damping: 0.1,
            drogue_accel_psd_m2ps3: 0.04,
            equilibrium_psd_m2ps: 0.01,
            drogue_fwd_time_constant_s: 2.0,
            drogue_fwd_accel_psd_m2ps3: 0.005,
            offset_noise_m: 0.002,
            offset_noise_per_m: 0.002,
            depth_noise_m: 0.005,
            depth_noise_per_m2: 0.003,
            initial_velocity_sigma_mps: 0.5,
            initial_displacement_sigma_m: 0.3,
            gate_sigmas: 6.0,
            activity_time_constant_s: 4.0,
            max_rejections: 5,
        }
    }
}

/// Where the probe tip is, seen from the camera: the part of the geometry the estimator
/// needs to turn a frame into the drogue's offset from the tip. Derived once from the
/// believed camera mount and probe-tip position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TipGeometry {
    /// Probe tip minus camera, camera-reference axes at trim (right, down, forward), m.
    tip_from_camera_re_m: [f32; 3],
    /// Trim pitch's sine and cosine: body roll is about an axis pitched up by it.
    trim_pitch_sin_cos: [f32; 2],
}

impl TipGeometry {
    /// The geometry of a `camera` mount (boresight level at trim when its pitch-down is the
    /// trim pitch) and the probe tip, both in body axes, at the trim pitch `trim_pitch_rad`.
    pub fn new(camera: &CameraMount, probe_tip_body_m: [f32; 3], trim_pitch_rad: f32) -> Self {
        let d = [0, 1, 2].map(|i| probe_tip_body_m[i] - camera.position_body_m[i]);
        // Camera axes (x right, y down, z boresight) from body axes: the transpose of the
        // mount's rotation. At trim the camera axes are the reference axes `re`.
        let r = body_from_camera(camera.pitch_down_rad);
        let cam = [0, 1, 2].map(|c| r[(0, c)] * d[0] + r[(1, c)] * d[1] + r[(2, c)] * d[2]);
        Self {
            tip_from_camera_re_m: cam,
            trim_pitch_sin_cos: [libm::sinf(trim_pitch_rad), libm::cosf(trim_pitch_rad)],
        }
    }

    /// Probe tip minus camera in the camera's axes at trim (right, down, forward), m.
    pub fn tip_from_camera_m(&self) -> [f32; 3] {
        self.tip_from_camera_re_m
    }

    /// The drogue centre minus the probe tip in tanker axes, `[right, down, forward]`, from a
    /// frame's image point and depth and the attitude's perturbation from trim (roll `phi`,
    /// pitch `theta`, heading `psi`, rad). Small-angle de-rotation: the perturbations stay
    /// within a few degrees while engaged (their second-order error is below 0.2 % of the
    /// range).
    #[inline(always)]
    pub fn drogue_from_tip(
        &self,
        image: [f32; 2],
        depth_m: f32,
        [phi, theta, psi]: [f32; 3],
    ) -> [f32; 3] {
        let t = &self.tip_from_camera_re_m;
        // Drogue minus tip in the camera's axes, reordered to tanker axes (fwd, right, down).
        let a = [
            depth_m - t[2],
            image[0] * depth_m - t[0],
            image[1] * depth_m - t[1],
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

/// The estimator's belief, as reported every step.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DrogueEstimate {
    /// Drogue centre minus probe tip, `[right, down]`, tanker axes, m.
    pub offset_m: [f32; 2],
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

/// Upper triangle of a symmetric 3x3 matrix: `[00, 01, 02, 11, 12, 22]`.
type Sym3 = [f32; 6];

/// Index of element `(i, j)` in a [`Sym3`].
const fn s3(i: usize, j: usize) -> usize {
    let (i, j) = if i <= j { (i, j) } else { (j, i) };
    match (i, j) {
        (0, 0) => 0,
        (0, 1) => 1,
        (0, 2) => 2,
        (1, 1) => 3,
        (1, 2) => 4,
        _ => 5,
    }
}

/// One lateral axis: state `[r, v, d]` and covariance.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct LateralAxis {
    x: [f32; 3],
    p: Sym3,
}

/// The depth axis: state `[z, w]` and covariance `[zz, zw, ww]`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct DepthAxis {
    x: [f32; 2],
    p: [f32; 3],
}

/// What the estimator needs from its configuration at the control period, derived once.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EstimatorModel {
    /// Lateral transition matrix (row-major 3x3).
    phi: [[f32; 3]; 3],
    /// Lateral process noise.
    q: Sym3,
    /// Continuous lateral model matrix `A` (row-major), for predictions over any horizon.
    a: [[f32; 3]; 3],
    /// Depth transition `[[1, Ts], [0, f]]`: `f`.
    fwd_decay: f32,
    /// Depth process noise `[zz, zw, ww]`.
    q_depth: [f32; 3],
    /// `4 ζ ω`: the acceleration PSD per unit stationary velocity variance, 1/s.
    psd_per_variance: f32,
    /// Step of the velocity-variance average, `Ts / activity_time_constant_s`.
    activity_step: f32,
    /// The stationary velocity variance of the design PSD, m²/s² (the average's start).
    design_variance: f32,
    ts: f32,
}

/// `a b`, 3x3 row-major.
fn mat_mul(a: &[[f32; 3]; 3], b: &[[f32; 3]; 3]) -> [[f32; 3]; 3] {
    core::array::from_fn(|i| core::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

impl EstimatorModel {
    /// Discretises the model of `cfg` at the period `ts_s`.
    pub fn new(cfg: &EstimatorConfig, ts_s: f32) -> Self {
        let (w, z) = (cfg.drogue_freq_radps, cfg.drogue_damping);
        let a = [
            [0.0, 1.0, 0.0],
            [0.0, -2.0 * z * w, -w * w],
            [0.0, 1.0, 0.0],
        ];
        // Φ = I + A Ts + (A Ts)²/2 + (A Ts)³/6 + (A Ts)⁴/24 (Horner).
        let at = a.map(|r| r.map(|v| v * ts_s));
        let eye = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let mut phi = eye;
        for k in [4.0, 3.0, 2.0, 1.0] {
            let m = mat_mul(&at, &phi);
            phi = core::array::from_fn(|i| core::array::from_fn(|j| eye[i][j] + m[i][j] / k));
        }
        let (qa, qe, t) = (cfg.drogue_accel_psd_m2ps3, cfg.equilibrium_psd_m2ps, ts_s);
        // White acceleration on v (a double integrator into r and d, to first order in Ts),
        // random walk on d.
        let (t2, t3) = (t * t / 2.0, t * t * t / 3.0);
        let q = [qa * t3, qa * t2, qa * t3, qa * t, qa * t2, qa * t3 + qe * t];
        let tau = cfg.drogue_fwd_time_constant_s;
        let qf = cfg.drogue_fwd_accel_psd_m2ps3;
        Self {
            phi,
            q,
            a,
            fwd_decay: libm::expf(-ts_s / tau),
            q_depth: [qf * t3, qf * t2, qf * t],
            psd_per_variance: 4.0 * z * w,
            activity_step: ts_s / cfg.activity_time_constant_s,
            design_variance: qa / (4.0 * z * w),
            ts: ts_s,
        }
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

/// The drogue estimator (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DrogueEstimator {
    axes: [LateralAxis; 2],
    depth: DepthAxis,
    /// Average of the estimated drogue velocity's square, per lateral axis, m²/s².
    activity: [f32; 2],
    /// Consecutive rejected frames.
    rejections: u16,
    /// The filter holds an estimate (started from a frame).
    started: bool,
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

impl DrogueEstimator {
    /// True once started from a frame (and until [`DrogueEstimator::stop`]).
    pub fn started(&self) -> bool {
        self.started
    }

    /// Forgets everything (standby).
    pub fn stop(&mut self) {
        *self = Self::default();
    }

    /// Starts from `frame`: offset and depth as measured, the drogue at rest at its
    /// equilibrium, with the configured initial uncertainty.
    pub fn start(&mut self, frame: &TipFrame, cfg: &EstimatorConfig) {
        self.restart(frame, cfg);
        // The design PSD's stationary velocity variance, q / (4 ζ ω).
        let (w, z) = (cfg.drogue_freq_radps, cfg.drogue_damping);
        self.activity = [cfg.drogue_accel_psd_m2ps3 / (4.0 * z * w); 2];
    }

    /// [`DrogueEstimator::start`] keeping the measured activity (a restart after rejections
    /// is the same air).
    fn restart(&mut self, frame: &TipFrame, cfg: &EstimatorConfig) {
        let (r_var, z_var) = noise_variances(frame.camera_depth_m, cfg);
        let (v0, d0) = (
            cfg.initial_velocity_sigma_mps,
            cfg.initial_displacement_sigma_m,
        );
        self.axes = [0, 1].map(|i| LateralAxis {
            x: [frame.drogue_from_tip_m[i], 0.0, 0.0],
            p: [r_var, 0.0, 0.0, v0 * v0, 0.0, d0 * d0],
        });
        self.depth = DepthAxis {
            x: [frame.drogue_from_tip_m[2], 0.0],
            p: [z_var, 0.0, v0 * v0],
        };
        self.rejections = 0;
        self.started = true;
    }

    /// Advances the belief by one step with the probe tip's velocity relative to the tanker
    /// `[right, down, forward]`, m/s (from navigation).
    #[inline(always)]
    pub fn predict(&mut self, tip_velocity_mps: [f32; 3], m: &EstimatorModel) {
        let f = &m.phi;
        for (ax, u) in self.axes.iter_mut().zip(tip_velocity_mps) {
            let x = ax.x;
            ax.x = core::array::from_fn(|i| f[i][0] * x[0] + f[i][1] * x[1] + f[i][2] * x[2]);
            ax.x[0] -= m.ts * u;
            // Φ P Φᵀ + Q, with Φ's first column e₀ (r is not fed back into v or d).
            let p = ax.p;
            let fp: [[f32; 3]; 3] = core::array::from_fn(|i| {
                core::array::from_fn(|j| {
                    f[i][0] * p[s3(0, j)] + f[i][1] * p[s3(1, j)] + f[i][2] * p[s3(2, j)]
                })
            });
            let at = |i: usize, j: usize| {
                fp[i][0] * f[j][0] + fp[i][1] * f[j][1] + fp[i][2] * f[j][2] + m.q[s3(i, j)]
            };
            ax.p = [at(0, 0), at(0, 1), at(0, 2), at(1, 1), at(1, 2), at(2, 2)];
        }
        for (a, ax) in self.activity.iter_mut().zip(&self.axes) {
            *a += m.activity_step * (ax.x[1] * ax.x[1] - *a);
        }
        let d = &mut self.depth;
        let [z, w] = d.x;
        let fd = m.fwd_decay;
        d.x = [z + m.ts * (w - tip_velocity_mps[2]), fd * w];
        let [pzz, pzw, pww] = d.p;
        let t = m.ts;
        d.p = [
            pzz + 2.0 * t * pzw + t * t * pww + m.q_depth[0],
            fd * (pzw + t * pww) + m.q_depth[1],
            fd * fd * pww + m.q_depth[2],
        ];
    }

    /// Corrects the belief with a valid frame (after [`DrogueEstimator::predict`]).
    #[inline(always)]
    pub fn correct(&mut self, frame: &TipFrame, cfg: &EstimatorConfig) -> Correction {
        let (r_var, z_var) = noise_variances(frame.camera_depth_m, cfg);
        let meas = frame.drogue_from_tip_m;
        let g2 = cfg.gate_sigmas * cfg.gate_sigmas;
        // Gate on both lateral axes and the depth together: one outlier frame is one frame.
        let nu = [0, 1].map(|i| meas[i] - self.axes[i].x[0]);
        let s = [0, 1].map(|i| self.axes[i].p[0] + r_var);
        let nu_z = meas[2] - self.depth.x[0];
        let s_z = self.depth.p[0] + z_var;
        let outside =
            nu[0] * nu[0] > g2 * s[0] || nu[1] * nu[1] > g2 * s[1] || nu_z * nu_z > g2 * s_z;
        if outside {
            self.rejections = self.rejections.saturating_add(1);
            if self.rejections > cfg.max_rejections {
                self.restart(frame, cfg);
                return Correction {
                    rejected: true,
                    restarted: Some(Restart::Rejections),
                };
            }
            return Correction {
                rejected: true,
                restarted: None,
            };
        }
        self.rejections = 0;
        for (ax, (nu, s)) in self.axes.iter_mut().zip(nu.into_iter().zip(s)) {
            let p = ax.p;
            let inv = 1.0 / s;
            let k = [p[0] * inv, p[1] * inv, p[2] * inv];
            ax.x = [
                ax.x[0] + k[0] * nu,
                ax.x[1] + k[1] * nu,
                ax.x[2] + k[2] * nu,
            ];
            // P - K P[0, :] (upper triangle).
            ax.p = [
                p[0] - k[0] * p[0],
                p[1] - k[0] * p[1],
                p[2] - k[0] * p[2],
                p[3] - k[1] * p[1],
                p[4] - k[1] * p[2],
                p[5] - k[2] * p[2],
            ];
        }
        let d = &mut self.depth;
        let [pzz, pzw, pww] = d.p;
        let inv = 1.0 / s_z;
        let k = [pzz * inv, pzw * inv];
        d.x = [d.x[0] + k[0] * nu_z, d.x[1] + k[1] * nu_z];
        d.p = [pzz - k[0] * pzz, pzw - k[0] * pzw, pww - k[1] * pzw];
        if !self.is_finite() {
            self.start(frame, cfg);
            return Correction {
                rejected: false,
                restarted: Some(Restart::NonFinite),
            };
        }
        Correction::default()
    }

    fn is_finite(&self) -> bool {
        let a = self
            .axes
            .iter()
            .all(|ax| ax.x.iter().all(|v| v.is_finite()) && ax.p.iter().all(|v| v.is_finite()));
        a && self
            .depth
            .x
            .iter()
            .chain(&self.depth.p)
            .all(|v| v.is_finite())
    }

    /// The belief now.
    pub fn estimate(&self) -> DrogueEstimate {
        let [r, d] = &self.axes;
        DrogueEstimate {
            offset_m: [r.x[0], d.x[0]],
            drogue_velocity_mps: [r.x[1], d.x[1], self.depth.x[1]],
            depth_m: self.depth.x[0],
        }
    }

    /// Variance of the offset estimate, `[right, down]`, m².
    pub fn offset_variance_m2(&self) -> [f32; 2] {
        [self.axes[0].p[0], self.axes[1].p[0]]
    }

    /// Variance of the depth estimate, m².
    pub fn depth_variance_m2(&self) -> f32 {
        self.depth.p[0]
    }

    /// The drogue's velocity `horizon_s` ahead, `[right, down]`, m/s, from the model (no
    /// measurement in between). `horizon_s` in `[0, 2 / ω]` keeps the series accurate.
    #[inline(always)]
    pub fn drogue_velocity_ahead(&self, horizon_s: f32, m: &EstimatorModel) -> [f32; 2] {
        [0, 1].map(|i| propagate(&m.a, &self.axes[i].x, horizon_s)[1])
    }

    /// The acceleration PSD the air drives the drogue with, as measured, per lateral axis,
    /// m²/s³.
    pub fn measured_accel_psd_m2ps3(&self, m: &EstimatorModel) -> [f32; 2] {
        self.activity.map(|a| m.psd_per_variance * a)
    }

    /// The offset `horizon_s` ahead if the probe tip kept the velocity `tip_velocity_mps`
    /// (`[right, down]`) and nothing were measured, with its variance (estimation error plus
    /// the drogue's unpredictable acceleration over the horizon, at the measured PSD).
    /// `horizon_s` in `[0, 2 / ω]`.
    #[inline(always)]
    pub fn predict_offset(
        &self,
        horizon_s: f32,
        tip_velocity_mps: [f32; 2],
        m: &EstimatorModel,
    ) -> [AxisPrediction; 2] {
        let h = horizon_s;
        // First row of Φ(h): the offset's sensitivity to the state now, eᵀ₀ Φ(h).
        let at: [[f32; 3]; 3] = core::array::from_fn(|i| core::array::from_fn(|j| m.a[j][i]));
        let row = propagate(&at, &[1.0, 0.0, 0.0], h);
        [0, 1].map(|i| {
            let ax = &self.axes[i];
            let p = &ax.p;
            let x = ax.x;
            let mean = row[0] * x[0] + row[1] * x[1] + row[2] * x[2] - h * tip_velocity_mps[i];
            let pr: [f32; 3] = core::array::from_fn(|j| {
                p[s3(j, 0)] * row[0] + p[s3(j, 1)] * row[1] + p[s3(j, 2)] * row[2]
            });
            let q = m.psd_per_variance * self.activity[i];
            let var = row[0] * pr[0] + row[1] * pr[1] + row[2] * pr[2] + q * h * h * h / 3.0;
            AxisPrediction {
                mean_m: mean,
                variance_m2: var,
            }
        })
    }
}

/// `exp(A h) x` by its Taylor series to tenth order (Horner): for `ω h <= 2` the remainder is
/// below `2^11 / 11!`, 5e-5 of the state (tested against the oscillator's closed form).
#[inline(always)]
fn propagate(a: &[[f32; 3]; 3], x: &[f32; 3], h: f32) -> [f32; 3] {
    let mut y = *x;
    for k in [10.0_f32, 9.0, 8.0, 7.0, 6.0, 5.0, 4.0, 3.0, 2.0, 1.0] {
        let c = h / k;
        let ay: [f32; 3] =
            core::array::from_fn(|i| a[i][0] * y[0] + a[i][1] * y[1] + a[i][2] * y[2]);
        y = core::array::from_fn(|i| x[i] + c * ay[i]);
    }
    y
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
        let r = g.drogue_from_tip([0.25, -0.1], 4.0, [0.0; 3]);
        assert_eq!(r, [1.0, -0.4, 4.0]);
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
        let r = g.drogue_from_tip([t[0] / z, t[1] / z], z, [0.0; 3]);
        assert!(r[0].abs() < 1e-6 && r[1].abs() < 1e-6 && (r[2] - 1.0).abs() < 1e-5);
    }

    #[test]
    fn de_rotation_removes_the_attitudes_effect_on_the_image() {
        // A drogue 5 m straight ahead of a tip camera; the nose pitched up 2 degrees puts it
        // below the boresight, yawed right 2 degrees to its left. De-rotated: still ahead.
        let g = tip_camera();
        let (a, z) = (2f32.to_radians(), 5.0_f32);
        let pitched = g.drogue_from_tip([0.0, libm::tanf(a)], z, [0.0, a, 0.0]);
        assert!(pitched[1].abs() < 2e-3 * z, "{pitched:?}");
        let yawed = g.drogue_from_tip([-libm::tanf(a), 0.0], z, [0.0, 0.0, a]);
        assert!(yawed[0].abs() < 2e-3 * z, "{yawed:?}");
        // Rolled right 2 degrees (about the body axis, pitched up by the trim pitch): a
        // drogue 1 m to the right appears above and right; de-rotated, right and level.
        let roll = g.drogue_from_tip(
            [1.0 * libm::cosf(a) / z, -libm::sinf(a) / z],
            z,
            [a, 0.0, 0.0],
        );
        assert!(
            (roll[0] - 1.0).abs() < 0.02 && roll[1].abs() < 0.02,
            "{roll:?}"
        );
    }

    fn model() -> (EstimatorConfig, EstimatorModel) {
        let cfg = EstimatorConfig::default();
        (cfg, EstimatorModel::new(&cfg, TS))
    }

    #[test]
    fn the_discrete_model_matches_the_oscillator() {
        // Free swing from d = 0.1 m at rest: after a quarter period the oscillator's exact
        // solution; the series transition over many steps must follow it.
        let (cfg, m) = model();
        let (w, z) = (cfg.drogue_freq_radps, cfg.drogue_damping);
        let mut x = [0.1_f32, 0.0, 0.1];
        // The longest horizon the predictions allow, 2 / ω.
        let n = (2.0 / w / TS) as usize;
        for _ in 0..n {
            x = core::array::from_fn(|i| (0..3).map(|j| m.phi[i][j] * x[j]).sum());
        }
        let t = n as f32 * TS;
        let wd = w * libm::sqrtf(1.0 - z * z);
        let s = z * w;
        let d_exact = 0.1 * libm::expf(-s * t) * (libm::cosf(wd * t) + s / wd * libm::sinf(wd * t));
        assert!((x[2] - d_exact).abs() < 1e-5, "{} vs {d_exact}", x[2]);
        // r - d is constant without tip motion (r - d = equilibrium minus tip).
        assert!((x[0] - x[2]).abs() < 1e-6);
        // The prediction over the same horizon from the start gives the same answer.
        let est = DrogueEstimator {
            axes: [LateralAxis {
                x: [0.1, 0.0, 0.1],
                p: [0.0; 6],
            }; 2],
            depth: DepthAxis::default(),
            activity: [m.design_variance; 2],
            rejections: 0,
            started: true,
        };
        let p = est.predict_offset(t, [0.0, 0.0], &m);
        assert!((p[0].mean_m - d_exact).abs() < 2e-5, "{p:?} vs {d_exact}");
        // At the design activity, the variance grows with the design PSD.
        let q = cfg.drogue_accel_psd_m2ps3;
        assert!(
            (p[0].variance_m2 - q * t * t * t / 3.0).abs() < 1e-6 * q,
            "{p:?}"
        );
    }

    /// A drogue swinging as the model says (no noise), seen by a fixed tip: the filter
    /// converges on its offset and velocity.
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
        let mut worst = (0.0_f32, 0.0_f32);
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
            }
        }
        assert!(
            worst.0 < 0.005 && worst.1 < 0.05,
            "worst offset, velocity error {worst:?}"
        );
        // The measured activity is the swing's: velocity amplitude 0.48 m/s, mean square
        // 0.115 m²/s² (within the average's ripple over a 4 s time constant).
        let q = e.measured_accel_psd_m2ps3(&m)[0];
        let want = 4.0 * cfg.drogue_damping * cfg.drogue_freq_radps * 0.5 * (0.3 * w) * (0.3 * w);
        assert!((q / want - 1.0).abs() < 0.3, "{q} vs {want}");
        // The model predicts the swing: the velocity half a second ahead.
        let t = 499.0 * TS;
        let ahead = e.drogue_velocity_ahead(0.5, &m)[0];
        assert!(
            (ahead - truth(t + 0.5).1).abs() < 0.06,
            "{ahead} vs {}",
            truth(t + 0.5).1
        );
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
        // Still air: the measured activity decays from the design level toward zero.
        let q0 = e.measured_accel_psd_m2ps3(&m)[0];
        let z0 = e.depth_variance_m2();
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
    }
}
