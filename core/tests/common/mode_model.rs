//! An independent model of the controller's mode tables (`ibvs_core::mode`, module doc, and
//! `docs/conventions.md`, "Modes" and "The refuelling procedure"), stepped beside the
//! controller by `fuzz_step.rs`. It reads only the step's input and the configuration, and
//! computes in `f64`, by its own formulas, everything the tables decide on:
//!
//! - whether the frame is valid and why not (its sequence number against the last new one,
//!   its content against the limits, the frozen-frame count), and whether the navigation is
//!   (every state finite and inside its limit, the flight condition finite);
//! - whether the last valid flight condition is inside the docking envelope (the grid, and
//!   above the lowest airspeed of the configured gross mass), and the gain
//!   schedule's design there: the trim and the forward output row, interpolated bilinearly
//!   over the schedule's nodes (`ibvs_core::gains::SCHEDULE`, read as data);
//! - the tracked point's forward speed as the inner loops output it (the output row plus the
//!   lever arm's `q` term) for the overspeed check, and the probe tip's velocity by
//!   rigid-body kinematics (the trim added back, 3-2-1 Euler angles) for the estimator;
//! - the drogue's offset from the probe tip from the frame (the camera's set-back, the
//!   boresight's elevation at the design's trim, the attitude's small-angle de-rotation);
//! - the drogue estimator of `ibvs_core::estimator`'s module doc: per axis the exactly
//!   discretised Kalman filter (process noise in closed form, the lateral PSD the measured
//!   activity through the hose's swing at the flown design's condition, at least the
//!   floor's), the innovation gate and the
//!   restart after too many rejections, the offset's and the activity's averages, the RMS
//!   drogue speed; the go/no-go gate's predicted miss and the closing speed;
//! - the paper's target from the frame (IBVS: the image point times the depth; PBVS: the
//!   drogue reconstructed through the believed mount and the navigation's attitude).
//!
//! Nothing is taken from the controller's outputs or its functions: the outputs (mode,
//! breakaway reason, attempt, no-go, the refused-engage bit, the measurement's and the
//! navigation's errors) are only compared.
//!
//! Single against double precision: a decision on numbers within [`EPS`] (relative) of its
//! threshold may go either way in the controller's `f32`; the model then follows both
//! outcomes ([`Choices`]: a set of model states, each consistent with every output so far)
//! and fails when none agrees with the controller. The same for the paper's blind phase,
//! whose dead-reckoned depth the model does not keep: from terminal it follows both "still
//! terminal" and "passed the drogue plane".

use ibvs_core::controller::StatusFlags;
use ibvs_core::gains::{SCHEDULE, SCHEDULE_ALTITUDES_M, SCHEDULE_SPEEDS_MPS, ZERO_LIFT_ALPHA_RAD};
use ibvs_core::measurement::MeasurementError;
use ibvs_core::nav::{FlightCondition, NavError, NavSample};
use ibvs_core::schedule::{ANGLE_OF_ATTACK_LIMIT_RAD, LOAD_FACTOR_RESERVE};
use ibvs_core::{
    BreakawayReason, Controller, ControllerConfig, ControllerInput, ControllerOutput, Mode,
    ModeRequest, NoGoReason, OuterLaw, Procedure,
};

/// Band around a threshold inside which the model takes both outcomes: relative, and an
/// absolute floor in the compared quantity's unit (every comparison is of metres, metres per
/// second or seconds; the single-precision step carries about 1e-5 m/s of rounding in the
/// tip's velocity, the trim speed of 120 m/s taken back off it).
pub const EPS: f64 = 1e-4;
/// The band's absolute floor ([`EPS`]).
pub const EPS_ABS: f64 = 1e-5;

/// Most model states followed at once (more means the model is too unsure to be a test).
const MAX_STATES: usize = 16;

/// The outcomes of the uncertain decisions of one step: `given` answers the first ones (a
/// branch being explored); the rest are answered `false` and recorded in `taken`.
#[derive(Debug, Default)]
pub struct Choices {
    given: Vec<bool>,
    taken: Vec<bool>,
}

impl Choices {
    fn choose(&mut self) -> bool {
        let c = self.given.get(self.taken.len()).copied().unwrap_or(false);
        self.taken.push(c);
        c
    }

    /// `a <= b`, or a choice when they are within [`EPS`] of each other.
    pub fn le(&mut self, a: f64, b: f64) -> bool {
        if !(a.is_finite() && b.is_finite()) {
            return a <= b;
        }
        let tol = EPS * a.abs().max(b.abs()) + EPS_ABS;
        if a < b - tol {
            true
        } else if a > b + tol {
            false
        } else {
            self.choose()
        }
    }

    /// `a > b`, or a choice near equality.
    pub fn gt(&mut self, a: f64, b: f64) -> bool {
        !self.le(a, b)
    }

    /// `a < b`, or a choice near equality.
    pub fn lt(&mut self, a: f64, b: f64) -> bool {
        !self.le(b, a)
    }

    /// Either way (what the model cannot know).
    pub fn either(&mut self) -> bool {
        self.choose()
    }
}

/// What a step shows of the tables, compared with the controller's output.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observed {
    mode: Mode,
    reason: Option<BreakawayReason>,
    /// Refuelling: the attempt and the last no-go.
    attempt: Option<(u8, Option<NoGoReason>)>,
    refused: bool,
    measurement_error: Option<MeasurementError>,
    nav_error: Option<NavError>,
}

impl Observed {
    /// What the controller's output shows of the same.
    pub fn of(out: &ControllerOutput, procedure: Procedure) -> Self {
        Self {
            mode: out.mode,
            reason: out.breakaway_reason,
            attempt: (procedure == Procedure::Refuelling).then_some((out.attempt, out.no_go)),
            refused: out.status.contains(StatusFlags::ENGAGE_REFUSED),
            measurement_error: out.measurement_error,
            nav_error: out.nav_error,
        }
    }
}

/// The gain schedule's design at a flight condition, as far as the tables need it.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Design {
    speed: f64,
    alpha: f64,
    theta: f64,
    /// The forward row of the flown longitudinal design's output matrix at the CG, over
    /// `[theta, V, alpha, q, P]`.
    fwd_row: [f64; 5],
    /// The hose's swing period the drogue filter takes at this condition, s (0: no swing):
    /// the configured period, shortened as the dynamic pressure's ratio to the design
    /// condition's to the configured exponent, never lengthened.
    swing_period: f64,
}

/// The cell of `axis` holding `x` (inside it) and the fraction across it.
fn cell(axis: &[f32], x: f64) -> (usize, f64) {
    let i = (0..axis.len() - 1)
        .find(|&i| x <= f64::from(axis[i + 1]))
        .unwrap_or(axis.len() - 2);
    let (lo, hi) = (f64::from(axis[i]), f64::from(axis[i + 1]));
    (i, (x - lo) / (hi - lo))
}

impl Design {
    /// Bilinear over the schedule's nodes at `(airspeed, altitude)` (inside the grid).
    fn at(airspeed: f32, altitude: f32, cfg: &ControllerConfig) -> Self {
        let procedure = cfg.procedure;
        let (i, s) = cell(&SCHEDULE_SPEEDS_MPS, f64::from(airspeed));
        let (j, t) = cell(&SCHEDULE_ALTITUDES_M, f64::from(altitude));
        let blend = |f: &dyn Fn(usize, usize) -> f32| {
            let n = |jj: usize, ii: usize| f64::from(f(jj, ii));
            (n(j, i) * (1.0 - s) + n(j, i + 1) * s) * (1.0 - t)
                + (n(j + 1, i) * (1.0 - s) + n(j + 1, i + 1) * s) * t
        };
        let fwd = |jj: usize, ii: usize, k: usize| {
            let d = &SCHEDULE[jj][ii];
            match procedure {
                Procedure::Paper => d.lon.c_cg[1][k],
                Procedure::Refuelling => d.refuel_lon.c_cg[1][k],
            }
        };
        let fwd_row = [0, 1, 2, 3, 4].map(|k| blend(&|jj, ii| fwd(jj, ii, k)));
        // The engine's power column is zero at every node: the model needs no engine.
        assert_eq!(
            fwd_row[4], 0.0,
            "the forward output row reads the engine power"
        );
        Self {
            speed: blend(&|jj, ii| SCHEDULE[jj][ii].trim.speed_mps),
            alpha: blend(&|jj, ii| SCHEDULE[jj][ii].trim.alpha_rad),
            theta: blend(&|jj, ii| SCHEDULE[jj][ii].trim.theta_rad),
            fwd_row,
            swing_period: swing_period(cfg, f64::from(airspeed), f64::from(altitude)),
        }
    }
}

/// The swing's period at `(airspeed, altitude)` (the troposphere's density, ISA).
fn swing_period(cfg: &ControllerConfig, airspeed: f64, altitude: f64) -> f64 {
    let e = &cfg.estimator;
    if e.drogue_swing_period_s <= 0.0 {
        return 0.0;
    }
    let dynamic_pressure = |v: f64, h: f64| (1.0 - 2.255_77e-5 * h).powf(4.255_88) * v * v;
    let design = NavSample::default().condition;
    let ratio = dynamic_pressure(airspeed, altitude)
        / dynamic_pressure(
            f64::from(design.true_airspeed_mps),
            f64::from(design.altitude_m),
        );
    f64::from(e.drogue_swing_period_s)
        * ratio
            .powf(-f64::from(e.drogue_swing_period_exponent))
            .min(1.0)
}

fn f3(v: [f32; 3]) -> [f64; 3] {
    v.map(f64::from)
}

/// The forward speed relative to the tanker of the point `p` (body axes, from the CG) as the
/// inner loops' output gives it: the design's row at the CG plus the lever arm's `q` term
/// (`omega x p` turned into tanker axes at the trim pitch), on the navigation's state.
fn tracked_fwd_mps(nav: &NavSample, d: &Design, p: [f64; 3]) -> f64 {
    let l = &nav.lon;
    let x = [l.theta_rad, l.v_mps, l.alpha_rad, l.q_radps, 0.0].map(f64::from);
    let fwd_per_q = d.theta.cos() * p[2] - d.theta.sin() * p[0];
    let row = d.fwd_row;
    (0..5).map(|k| row[k] * x[k]).sum::<f64>() + fwd_per_q * x[3]
}

/// The velocity of the point `p` (body axes, from the CG) relative to the tanker,
/// `[right, down, forward]` in tanker axes: the receiver's body velocity (trim speed, angle
/// of attack and pitch added back to the navigation's perturbations) plus `omega x p`,
/// turned by the 3-2-1 Euler angles; less the tanker's velocity (the trim speed, north).
fn point_velocity_mps(nav: &NavSample, d: &Design, p: [f64; 3]) -> [f64; 3] {
    let (lo, la) = (&nav.lon, &nav.lat);
    let f = f64::from;
    let v = d.speed + f(lo.v_mps);
    let (alpha, beta) = (d.alpha + f(lo.alpha_rad), f(la.beta_rad));
    let (phi, theta, psi) = (f(la.phi_rad), d.theta + f(lo.theta_rad), f(la.psi_rad));
    let (pr, qr, rr) = (f(la.p_radps), f(lo.q_radps), f(la.r_radps));
    let [x, y, z] = p;
    let u = v * alpha.cos() * beta.cos() + (qr * z - rr * y);
    let side = v * beta.sin() + (rr * x - pr * z);
    let w = v * alpha.sin() * beta.cos() + (pr * y - qr * x);
    let [north, east, down] = rotate(&tanker_from_body(phi, theta, psi), [u, side, w]);
    [east, down, north - d.speed]
}

/// Tanker axes (north, east, down) from body axes for the 3-2-1 Euler angles.
fn tanker_from_body(phi: f64, theta: f64, psi: f64) -> [[f64; 3]; 3] {
    let (sf, cf, st, ct, sp, cp) = (
        phi.sin(),
        phi.cos(),
        theta.sin(),
        theta.cos(),
        psi.sin(),
        psi.cos(),
    );
    [
        [ct * cp, sf * st * cp - cf * sp, cf * st * cp + sf * sp],
        [ct * sp, sf * st * sp + cf * cp, cf * st * sp - sf * cp],
        [-st, sf * ct, cf * ct],
    ]
}

/// `m v`.
fn rotate(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    m.map(|row| row[0] * v[0] + row[1] * v[1] + row[2] * v[2])
}

/// Camera axes (right, down, boresight) from body axes for a boresight pitched down by `p`:
/// rows of the body-from-camera rotation (`docs/conventions.md`).
fn body_from_camera(p: f64) -> [[f64; 3]; 3] {
    let (s, c) = (p.sin(), p.cos());
    [[0.0, -s, c], [1.0, 0.0, 0.0], [0.0, c, s]]
}

/// The probe tip minus the camera in the camera's axes, m.
fn tip_from_camera(cfg: &ControllerConfig) -> [f64; 3] {
    let (tip, cam) = (f3(cfg.probe_tip_body_m), f3(cfg.camera.position_body_m));
    let d = [0, 1, 2].map(|i| tip[i] - cam[i]);
    let r = body_from_camera(f64::from(cfg.camera.pitch_down_rad));
    [0, 1, 2].map(|c| (0..3).map(|i| r[i][c] * d[i]).sum())
}

/// The drogue centre minus the probe tip, `[right, down, forward]` in tanker axes, from a
/// frame's image point and depth at the design's trim pitch `theta_d` and the navigation's
/// attitude perturbation `[phi, theta, psi]`, the tip's image point `tip_image`.
fn drogue_from_tip(
    cfg: &ControllerConfig,
    image: [f64; 2],
    depth: f64,
    att: [f64; 3],
    theta_d: f64,
    tip_image: [f64; 2],
) -> [f64; 3] {
    let tz = tip_from_camera(cfg)[2];
    let t = [tip_image[0] * tz, tip_image[1] * tz, tz];
    // Drogue minus tip along (boresight, right, down), then the boresight raised by its
    // elevation above the tanker's axis at trim (the trim pitch less the mount's pitch-down).
    let c = [
        depth - t[2],
        image[0] * depth - t[0],
        image[1] * depth - t[1],
    ];
    let e = theta_d - f64::from(cfg.camera.pitch_down_rad);
    let a = [
        e.cos() * c[0] + e.sin() * c[2],
        c[1],
        e.cos() * c[2] - e.sin() * c[0],
    ];
    // The attitude's small rotation: roll about the body x axis (pitched up by the trim
    // pitch), pitch, heading.
    let [phi, theta, psi] = att;
    let w = [phi * theta_d.cos(), theta, psi - phi * theta_d.sin()];
    [
        a[1] + w[2] * a[0] - w[0] * a[2],
        a[2] + w[0] * a[1] - w[1] * a[0],
        a[0] + w[1] * a[2] - w[2] * a[1],
    ]
}

/// Process noise `[rr, rv, vv]` over `h` of `v' = -v / tau + w` (PSD `psd`) with
/// `r' = v - u`, in closed form.
fn process_noise(tau: f64, psd: f64, h: f64) -> [f64; 3] {
    let one_f = -(-h / tau).exp_m1();
    let one_f2 = -(-2.0 * h / tau).exp_m1();
    [
        psd * tau * tau * (h - 2.0 * tau * one_f + tau * one_f2 / 2.0),
        psd * tau * tau * (one_f - one_f2 / 2.0),
        psd * tau * one_f2 / 2.0,
    ]
}

/// One axis of the estimator: state `[r, v]`, covariance `[rr, rv, vv]`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Axis {
    x: [f64; 2],
    p: [f64; 3],
}

impl Axis {
    /// One step `h` of the Gauss-Markov model (`tau`, `psd`) with the tip's velocity `u`.
    fn predict(&mut self, tau: f64, psd: f64, h: f64, u: f64) {
        let f = (-h / tau).exp();
        let g = tau * (1.0 - f);
        let q = process_noise(tau, psd, h);
        let [r, v] = self.x;
        let [rr, rv, vv] = self.p;
        self.x = [r + g * v - h * u, f * v];
        self.p = [
            rr + 2.0 * g * rv + g * g * vv + q[0],
            f * (rv + g * vv) + q[1],
            f * f * vv + q[2],
        ];
    }
}

/// The drogue estimator, started.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Filter {
    axes: [Axis; 3],
    activity: [f64; 2],
    mean: [f64; 2],
    rejections: u16,
}

impl Filter {
    /// Within `tol` of `other` in every number (two outcomes of an unsure gate converge).
    fn near(&self, other: &Self, tol: f64) -> bool {
        let flat = |f: &Self| {
            let mut v: Vec<f64> = f
                .axes
                .iter()
                .flat_map(|a| a.x.into_iter().chain(a.p))
                .collect();
            v.extend(f.activity);
            v.extend(f.mean);
            v
        };
        self.rejections == other.rejections
            && flat(self)
                .iter()
                .zip(flat(other))
                .all(|(a, b)| (a - b).abs() <= tol * a.abs().max(b.abs()).max(1.0))
    }

    fn variances(cfg: &ControllerConfig, z: f64) -> [f64; 3] {
        let e = &cfg.estimator;
        let r = f64::from(e.offset_noise_m) + f64::from(e.offset_noise_per_m) * z;
        let d = f64::from(e.depth_noise_m) + f64::from(e.depth_noise_per_m2) * z * z;
        [r * r, r * r, d * d]
    }

    /// From a frame, the drogue at rest: the activity and the mean kept from `before`.
    fn restart(cfg: &ControllerConfig, r: [f64; 3], z: f64, before: Option<&Self>) -> Self {
        let var = Self::variances(cfg, z);
        let v0 = f64::from(cfg.estimator.initial_velocity_sigma_mps).powi(2);
        let e = &cfg.estimator;
        let stationary =
            f64::from(e.drogue_accel_psd_m2ps3) * f64::from(e.drogue_time_constant_s) / 2.0;
        Self {
            axes: [0, 1, 2].map(|i| Axis {
                x: [r[i], 0.0],
                p: [var[i], 0.0, v0],
            }),
            activity: before.map_or([stationary; 2], |b| b.activity),
            mean: before.map_or([r[0], r[1]], |b| b.mean),
            rejections: 0,
        }
    }

    /// One step: `swing_period` is the flown design's (0: no swing).
    fn predict(&mut self, cfg: &ControllerConfig, swing_period: f64, tip: [f64; 3]) {
        let e = &cfg.estimator;
        let ts = f64::from(Controller::PERIOD_S);
        // The lateral axes' PSD: the measured activity through the hose's swing, `4 ζ ω`
        // per unit velocity variance, at least the floor speed's (`2 / τ` with no swing).
        let tau = f64::from(e.drogue_time_constant_s);
        let per_variance = if swing_period > 0.0 && e.drogue_swing_damping_ratio > 0.0 {
            4.0 * f64::from(e.drogue_swing_damping_ratio) * 2.0 * std::f64::consts::PI
                / swing_period
        } else {
            2.0 / tau
        };
        let floor = per_variance * f64::from(e.drogue_speed_floor_mps).powi(2);
        let psd = self.activity.map(|a| (per_variance * a).max(floor));
        self.axes[0].predict(tau, psd[0], ts, tip[0]);
        self.axes[1].predict(tau, psd[1], ts, tip[1]);
        self.axes[2].predict(
            f64::from(e.drogue_fwd_time_constant_s),
            f64::from(e.drogue_fwd_accel_psd_m2ps3),
            ts,
            tip[2],
        );
        let (ka, km) = (
            ts / f64::from(e.activity_time_constant_s),
            ts / f64::from(e.mean_time_constant_s),
        );
        for i in 0..2 {
            let ax = &self.axes[i];
            self.activity[i] += ka * (ax.x[1] * ax.x[1] - self.activity[i]);
            self.mean[i] += km * (ax.x[0] - self.mean[i]);
        }
    }

    /// The frame `r` at camera depth `z`: gated on the three axes together, then the scalar
    /// update of each axis; after `max_rejections` rejections in a row, the next restarts.
    fn correct(&mut self, cfg: &ControllerConfig, r: [f64; 3], z: f64, o: &mut Choices) {
        let var = Self::variances(cfg, z);
        let g = f64::from(cfg.estimator.gate_sigmas);
        let nu: [f64; 3] = [0, 1, 2].map(|i| r[i] - self.axes[i].x[0]);
        let s: [f64; 3] = [0, 1, 2].map(|i| self.axes[i].p[0] + var[i]);
        // The core compares squares; the model compares metres (the same order).
        let outside = (0..3).any(|i| o.gt(nu[i].abs(), g * s[i].sqrt()));
        if outside {
            self.rejections = self.rejections.saturating_add(1);
            if self.rejections > cfg.estimator.max_rejections {
                *self = Self::restart(cfg, r, z, Some(self));
            }
            return;
        }
        self.rejections = 0;
        for (ax, (nu, s)) in self.axes.iter_mut().zip(nu.into_iter().zip(s)) {
            let [rr, rv, vv] = ax.p;
            let k = [rr / s, rv / s];
            ax.x = [ax.x[0] + k[0] * nu, ax.x[1] + k[1] * nu];
            ax.p = [rr - k[0] * rr, rv - k[0] * rv, vv - k[1] * rv];
        }
    }

    fn rms_mps(&self) -> f64 {
        self.activity[0].max(self.activity[1]).max(0.0).sqrt()
    }

    /// The go/no-go gate's figure: the radial offset predicted at the drogue plane (horizon
    /// the time to go at `closing`, at most `gate_max_horizon_s`, the tip keeping its lateral
    /// velocity `tip`) plus `gate_sigmas` standard deviations of the larger axis (the
    /// prediction's variance with the considered angular bias's, `(σ_b D)²`).
    ///
    /// The horizon jumps from the time to go to the longest when the closing speed falls
    /// through zero at the plane (no time to go): that comparison is a choice near equality.
    fn predicted_miss_m(
        &self,
        cfg: &ControllerConfig,
        closing: f64,
        tip: [f64; 2],
        o: &mut Choices,
    ) -> f64 {
        let (rc, e) = (&cfg.refuelling, &cfg.estimator);
        let to_go = self.axes[2].x[0].max(0.0);
        let hmax = f64::from(rc.gate_max_horizon_s);
        let h = if o.lt(to_go, closing * hmax) {
            to_go / closing
        } else {
            hmax
        };
        let tau = f64::from(e.drogue_time_constant_s);
        let (f, psd_per_variance) = ((-h / tau).exp(), 2.0 / tau);
        let g = tau * (1.0 - f);
        // The angular bias the estimator considers, at the present depth.
        let depth = self.axes[2].x[0];
        let [a, b] = [0, 1].map(|i| {
            let ax = &self.axes[i];
            let q = process_noise(tau, psd_per_variance * self.activity[i], h);
            let [rr, rv, vv] = ax.p;
            let bias = (f64::from(e.bearing_bias_sigma_rad[i]) * depth).powi(2);
            (
                ax.x[0] + g * ax.x[1] - h * tip[i],
                rr + 2.0 * g * rv + g * g * vv + q[0] + bias,
            )
        });
        a.0.hypot(b.0) + f64::from(rc.gate_sigmas) * a.1.max(b.1).max(0.0).sqrt()
    }
}

/// A model of the controller's tables, started with the controller.
#[derive(Debug, Clone, PartialEq)]
pub struct Model {
    cfg: ControllerConfig,
    last_seq: Option<u32>,
    /// The last valid frame's content bits, and how many new frames in a row repeated them.
    frozen: Option<([u32; 3], u16)>,
    last_nav: NavSample,
    nav_invalid: u16,
    design: Design,
    /// Whether the condition the follow-up last checked was below the slow edge (inside the
    /// grid): the engaged step's verdict.
    edge_below: bool,
    /// Whether this step found the condition inside the docking envelope.
    inside: bool,
    mode: Mode,
    reason: Option<BreakawayReason>,
    meas_invalid: u16,
    terminal_steps: u32,
    attempt: u8,
    no_go: Option<NoGoReason>,
    stable: u32,
    mode_steps: u32,
    sortie_steps: u32,
    /// An abort in the refuelling capture, waiting for its end.
    abort_pending: bool,
    /// The gate's depth of the approach flown (`procedure::commit_depth` at its closing
    /// speed, chosen from the air as it starts), m.
    commit_depth: f64,
    filter: Option<Filter>,
    /// The navigation's velocity bias as the station has learnt it (`docs/conventions.md`,
    /// "Navigation bias"), m/s, and the steps it has been learnt since engage.
    nav_bias: [f64; 3],
    nav_bias_steps: u32,
}

impl Model {
    /// The same state as `other` but for numbers within a relative 1e-9 of each other (far
    /// inside [`EPS`]): two branches that have converged are followed as one.
    fn same_as(&self, other: &Self) -> bool {
        // In breakaway the estimator's state (its filter, the bias learnt) decides nothing
        // until the next engage restarts it: two breakaways differing only there are one.
        let dead = self.mode == Mode::Breakaway && other.mode == Mode::Breakaway;
        let filters = dead
            || match (&self.filter, &other.filter) {
                (Some(a), Some(b)) => a.near(b, 1e-9),
                (None, None) => true,
                _ => false,
            };
        let discrete = |m: &Self| {
            (
                m.last_seq,
                m.frozen,
                m.last_nav,
                m.nav_invalid,
                m.design,
                m.mode,
                m.reason,
                (m.meas_invalid, m.terminal_steps, m.attempt, m.no_go),
                (m.stable, m.mode_steps, m.sortie_steps, m.abort_pending),
                m.commit_depth.to_bits(),
            )
        };
        // The bias is a running mean with a 20 s memory: two branches whose filters
        // differed for a step keep slightly different biases for minutes. Within a
        // micrometre per second they are one (a hundredth of the decision band's floor,
        // `EPS_ABS`, on the speeds the bias enters).
        let bias = self
            .nav_bias
            .iter()
            .zip(&other.nav_bias)
            .all(|(a, b)| (a - b).abs() <= 1e-2 * EPS_ABS);
        let learnt = dead || (bias && self.nav_bias_steps == other.nav_bias_steps);
        filters && learnt && discrete(self) == discrete(other)
    }
}

/// The gate's depth for an approach closing at `contact_mps`: where a no-go still stops
/// `stop_clearance_m` short of the plane after the forward loop's lag and the missed
/// approach's deceleration, or `commit_depth_m` if deeper, m.
fn commit_depth(cfg: &ControllerConfig, contact_mps: f32) -> f64 {
    let rc = &cfg.refuelling;
    let v = f64::from(contact_mps);
    let stop = v * f64::from(rc.forward_lag_s) + v * v / (2.0 * f64::from(rc.missed_accel_mps2));
    f64::from(rc.commit_depth_m).max(stop + f64::from(rc.stop_clearance_m))
}

/// Steps of a time, as the core rounds it.
fn steps(t: f32) -> u32 {
    (f64::from(t) / f64::from(Controller::PERIOD_S)).round() as u32
}

impl Model {
    /// The controller's state after construction: standby, the single-point design.
    pub fn new(cfg: ControllerConfig) -> Self {
        let default = NavSample::default().condition;
        let mut model = Self {
            cfg,
            last_seq: None,
            frozen: None,
            last_nav: NavSample::default(),
            nav_invalid: 0,
            design: Design::at(default.true_airspeed_mps, default.altitude_m, &cfg),
            edge_below: false,
            inside: true,
            mode: Mode::Standby,
            reason: None,
            meas_invalid: 0,
            terminal_steps: 0,
            attempt: 0,
            no_go: None,
            stable: 0,
            mode_steps: 0,
            sortie_steps: 0,
            abort_pending: false,
            commit_depth: commit_depth(&cfg, cfg.refuelling.contact_speed_mps),
            filter: None,
            nav_bias: [0.0; 3],
            nav_bias_steps: 0,
        };
        model.edge_below = model.in_grid(&default) && model.below_slow_edge(&default);
        model
    }

    /// The frame's error, if any (its sequence number, then its content, then frozen).
    fn frame_error(&mut self, input: &ControllerInput) -> Option<MeasurementError> {
        let m = &input.measurement;
        if let Some(last) = self.last_seq {
            let step = m.seq.wrapping_sub(last);
            if step == 0 {
                return Some(MeasurementError::Repeated);
            }
            if step >= 1 << 31 {
                return Some(MeasurementError::OutOfOrder);
            }
        }
        self.last_seq = Some(m.seq);
        let lim = &self.cfg.measurement;
        let (x, y, z) = (
            f64::from(m.image_x),
            f64::from(m.image_y),
            f64::from(m.depth_m),
        );
        let error = if !m.tracked {
            Some(MeasurementError::NotTracked)
        } else if !(x.is_finite() && y.is_finite() && z.is_finite()) {
            Some(MeasurementError::NonFinite)
        } else if z <= 0.0 {
            Some(MeasurementError::DepthNotPositive)
        } else if z > f64::from(lim.max_depth_m) {
            Some(MeasurementError::DepthTooLarge)
        } else if x.abs() > f64::from(lim.half_fov_x) || y.abs() > f64::from(lim.half_fov_y) {
            Some(MeasurementError::OutsideFieldOfView)
        } else {
            None
        };
        if error.is_some() {
            return error;
        }
        let bits = [m.image_x, m.image_y, m.depth_m].map(f32::to_bits);
        match &mut self.frozen {
            Some((last, repeats)) if *last == bits => {
                *repeats = repeats.saturating_add(1);
                (*repeats > lim.frozen_frame_limit).then_some(MeasurementError::Frozen)
            }
            _ => {
                self.frozen = Some((bits, 0));
                None
            }
        }
    }

    /// The navigation's error, if any: a state or the condition not finite, else a state
    /// outside its limit.
    fn nav_error(&self, nav: &NavSample) -> Option<NavError> {
        let a = nav.as_array().map(f64::from);
        let c = [nav.condition.true_airspeed_mps, nav.condition.altitude_m].map(f64::from);
        if !a.iter().chain(&c).all(|v| v.is_finite()) {
            return Some(NavError::NonFinite);
        }
        let e = &self.cfg.nav_envelope;
        let (angle, bank, slip, speed, rate) = (
            f64::from(e.max_angle_rad),
            f64::from(e.max_bank_rad),
            f64::from(e.max_sideslip_rad),
            f64::from(e.max_speed_mps),
            f64::from(e.max_rate_radps),
        );
        // [x, h, theta, V, alpha, q, y, psi, phi, beta, p, r]: positions unchecked.
        let limits = [
            (2, angle),
            (3, speed),
            (4, angle),
            (5, rate),
            (7, angle),
            (8, bank),
            (9, slip),
            (10, rate),
            (11, rate),
        ];
        limits
            .iter()
            .any(|&(i, limit)| a[i].abs() > limit)
            .then_some(NavError::OutsideEnvelope)
    }

    /// Whether the last valid condition is inside the docking envelope as the step sees it:
    /// the grid, and the slow edge: in standby this condition's, engaged the verdict on the
    /// last condition the follow-up checked (it checks each new one after the step).
    fn in_envelope(&self) -> bool {
        let c = &self.last_nav.condition;
        let below = if self.mode == Mode::Standby {
            self.below_slow_edge(c)
        } else {
            self.edge_below
        };
        self.in_grid(c) && !below
    }

    /// Whether `c` is inside the gain schedule's grid.
    fn in_grid(&self, c: &FlightCondition) -> bool {
        let (v, h) = (&SCHEDULE_SPEEDS_MPS, &SCHEDULE_ALTITUDES_M);
        (v[0]..=v[v.len() - 1]).contains(&c.true_airspeed_mps)
            && (h[0]..=h[h.len() - 1]).contains(&c.altitude_m)
    }

    /// Whether `c` is below the docking envelope's slow edge at the configured mass.
    fn below_slow_edge(&self, c: &FlightCondition) -> bool {
        f64::from(c.true_airspeed_mps) < self.lowest_airspeed(f64::from(c.altitude_m))
    }

    /// The docking envelope's lowest airspeed at altitude `h` (inside the grid) for the
    /// configured gross mass: at each altitude node, the speed where the level-flight angle
    /// of attack (the lift's zero angle plus the mass factor times the trim's angle from it,
    /// the trim linear in speed along the node's row) falls to the angle from which the load
    /// factor reserve reaches the limit, found by bisection; linear in altitude between the
    /// nodes; infinite in a cell where either node admits no speed of the grid.
    fn lowest_airspeed(&self, h: f64) -> f64 {
        let zero = f64::from(ZERO_LIFT_ALPHA_RAD);
        let limit =
            zero + (f64::from(ANGLE_OF_ATTACK_LIMIT_RAD) - zero) / f64::from(LOAD_FACTOR_RESERVE);
        let m = f64::from(self.cfg.mass_factor);
        let speeds = &SCHEDULE_SPEEDS_MPS;
        let row_lowest = |j: usize| {
            let level = |v: f64| {
                let (i, s) = cell(speeds, v);
                let a = |ii: usize| f64::from(SCHEDULE[j][ii].trim.alpha_rad);
                zero + m * (a(i) * (1.0 - s) + a(i + 1) * s - zero)
            };
            let (mut lo, mut hi) = (f64::from(speeds[0]), f64::from(speeds[speeds.len() - 1]));
            if level(lo) <= limit {
                return lo;
            }
            if level(hi) > limit {
                return f64::INFINITY;
            }
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if level(mid) > limit {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            hi
        };
        let (j, t) = cell(&SCHEDULE_ALTITUDES_M, h);
        let (a, b) = (row_lowest(j), row_lowest(j + 1));
        if a.is_finite() && b.is_finite() {
            a + (b - a) * t
        } else {
            f64::INFINITY
        }
    }

    /// One step of the model on `input`, the uncertain decisions answered by `o`: what the
    /// controller's output must show.
    pub fn step(&mut self, input: &ControllerInput, o: &mut Choices) -> Observed {
        let nav_error = self.nav_error(&input.nav);
        if nav_error.is_none() {
            self.last_nav = input.nav;
            self.nav_invalid = 0;
        } else {
            self.nav_invalid = self.nav_invalid.saturating_add(1);
        }
        let in_envelope = self.in_envelope();
        self.inside = in_envelope;
        // The follow-up after the step: a new condition checked against the slow edge, and
        // the design loaded where the condition is inside the grid (below the edge too).
        let c = self.last_nav.condition;
        let edge_below = self.in_grid(&c) && self.below_slow_edge(&c);
        let next_design = self.in_grid(&c).then(|| {
            let c = self.last_nav.condition;
            Design::at(c.true_airspeed_mps, c.altitude_m, &self.cfg)
        });
        let measurement_error = self.frame_error(input);
        let before = self.mode;
        let (refused, attempt) = match self.cfg.procedure {
            Procedure::Paper => (
                self.step_paper(input, measurement_error.is_none(), nav_error.is_none(), o),
                None,
            ),
            Procedure::Refuelling => {
                let refused = self.step_refuelling(
                    input,
                    measurement_error.is_none(),
                    nav_error.is_none(),
                    o,
                );
                (refused, Some((self.attempt, self.no_go)))
            }
        };
        if self.mode == Mode::Standby && before != Mode::Standby {
            self.last_seq = None;
            self.frozen = None;
        }
        if self.mode != Mode::Breakaway {
            self.reason = None;
        }
        if self.mode != before {
            (self.meas_invalid, self.mode_steps, self.stable) = (0, 0, 0);
            self.terminal_steps = 0;
        }
        // The flight loop's follow-up after the step: the next step flies this design, and
        // an engaged step judges the slow edge by this verdict.
        if let Some(d) = next_design {
            self.design = d;
        }
        self.edge_below = edge_below;
        Observed {
            mode: self.mode,
            reason: self.reason,
            attempt,
            refused,
            measurement_error,
            nav_error,
        }
    }

    fn break_away(&mut self, r: BreakawayReason) {
        (self.mode, self.reason) = (Mode::Breakaway, Some(r));
        self.abort_pending = false;
    }

    /// The rows both tables start with (a reset, an abort, the navigation lost, outside the
    /// docking envelope, the autopilot not following), `engaged` as the procedure counts it: `Some(refused)` when one of
    /// them decided the step.
    fn common_rows(
        &mut self,
        input: &ControllerInput,
        engaged: bool,
        capture_defers: bool,
    ) -> Option<bool> {
        // The refuelling capture defers an abort to its end (the core's `ModeMachine`) when
        // `capture_defers`: in smooth air, or within the forward loop's lag of the plane.
        let defer = engaged
            && input.request == ModeRequest::Abort
            && self.cfg.procedure == Procedure::Refuelling
            && self.mode == Mode::Terminal
            && capture_defers;
        if defer && input.request != ModeRequest::Reset {
            self.abort_pending = true;
        }
        if input.request == ModeRequest::Reset && self.mode != Mode::Standby {
            (self.mode, self.reason, self.attempt, self.no_go) = (Mode::Standby, None, 0, None);
            self.abort_pending = false;
        } else if engaged && input.request == ModeRequest::Abort && !defer {
            self.break_away(BreakawayReason::Abort);
        } else if engaged && self.nav_invalid > self.cfg.modes.hold_limit_steps {
            self.break_away(BreakawayReason::NavLost);
        } else if !self.inside {
            if engaged {
                self.break_away(BreakawayReason::OutsideDockingEnvelope);
            } else {
                return Some(self.mode == Mode::Standby && input.request == ModeRequest::Engage);
            }
        } else if self.cfg.inner_loop == ibvs_core::attitude::InnerLoop::Attitude
            && !input.autopilot_ready
        {
            if engaged {
                self.break_away(BreakawayReason::AutopilotMode);
            } else {
                return Some(self.mode == Mode::Standby && input.request == ModeRequest::Engage);
            }
        } else {
            return None;
        }
        Some(false)
    }

    /// The paper's target from a valid frame: IBVS the image point times the depth; PBVS the
    /// drogue through the believed mount and the navigation's attitude. `(right, down)` and
    /// the depth, m.
    fn paper_target(&self, input: &ControllerInput) -> ([f64; 2], f64) {
        let m = &input.measurement;
        let (x, y, z) = (
            f64::from(m.image_x),
            f64::from(m.image_y),
            f64::from(m.depth_m),
        );
        match self.cfg.law {
            OuterLaw::Ibvs => ([x * z, y * z], z),
            OuterLaw::Pbvs => {
                let cam = f3(self.cfg.camera.position_body_m);
                let tip = f3(self.cfg.probe_tip_body_m);
                let r = body_from_camera(f64::from(self.cfg.camera.pitch_down_rad));
                let seen = [x * z, y * z, z];
                let b: [f64; 3] = [0, 1, 2]
                    .map(|i| cam[i] - tip[i] + (0..3).map(|c| r[i][c] * seen[c]).sum::<f64>());
                let l = &self.last_nav;
                let (phi, theta, psi) = (
                    f64::from(l.lat.phi_rad),
                    self.design.theta + f64::from(l.lon.theta_rad),
                    f64::from(l.lat.psi_rad),
                );
                let v = rotate(&tanker_from_body(phi, theta, psi), b);
                ([v[1], v[2]], v[0])
            }
        }
    }

    /// The paper's table; whether an engage was refused.
    fn step_paper(
        &mut self,
        input: &ControllerInput,
        meas_ok: bool,
        nav_ok: bool,
        o: &mut Choices,
    ) -> bool {
        let md = self.cfg.modes;
        let before = self.mode;
        let engaged = matches!(before, Mode::Approach | Mode::Terminal | Mode::Docked);
        let brk = |m: &mut Self, r| m.break_away(r);
        let camera = f3(self.cfg.camera.position_body_m);
        let mut refused = false;
        if let Some(r) = self.common_rows(input, engaged, true) {
            refused = r;
        } else if matches!(before, Mode::Approach | Mode::Terminal)
            && o.gt(
                tracked_fwd_mps(&self.last_nav, &self.design, camera),
                f64::from(md.overspeed_mps),
            )
        {
            brk(self, BreakawayReason::Overspeed);
        } else {
            match before {
                Mode::Standby if input.request == ModeRequest::Engage => {
                    if meas_ok && nav_ok {
                        self.mode = Mode::Approach;
                    } else {
                        refused = true;
                    }
                }
                Mode::Approach if !meas_ok => {
                    self.meas_invalid = self.meas_invalid.saturating_add(1);
                    if self.meas_invalid > md.hold_limit_steps {
                        brk(self, BreakawayReason::MeasurementLost);
                    }
                }
                Mode::Approach => {
                    self.meas_invalid = 0;
                    let ([right, down], depth) = self.paper_target(input);
                    if o.le(depth, f64::from(md.terminal_depth_m)) {
                        if o.gt(right.hypot(down), f64::from(md.terminal_max_offset_m)) {
                            brk(self, BreakawayReason::PredictedMiss);
                        } else {
                            self.mode = Mode::Terminal;
                        }
                    }
                }
                Mode::Terminal => {
                    self.terminal_steps += 1;
                    if input.probe_contact {
                        self.mode = Mode::Docked;
                    } else if o.either() {
                        // The dead-reckoned depth passed the drogue plane.
                        brk(self, BreakawayReason::PassedDroguePlane);
                    } else if self.terminal_steps > steps(md.terminal_timeout_s) {
                        brk(self, BreakawayReason::TerminalTimeout);
                    }
                }
                Mode::Docked if !input.probe_contact => {
                    brk(self, BreakawayReason::ContactLost);
                }
                _ => {}
            }
        }
        refused
    }

    /// The refuelling procedure's table; whether an engage was refused.
    fn step_refuelling(
        &mut self,
        input: &ControllerInput,
        meas_ok: bool,
        nav_ok: bool,
        o: &mut Choices,
    ) -> bool {
        let cfg = self.cfg;
        let (md, rc) = (&cfg.modes, &cfg.refuelling);
        let f = f64::from;
        let engaged = !matches!(self.mode, Mode::Standby | Mode::Breakaway);
        let mut refused = false;

        // The drogue estimator's step: predict with the probe tip's velocity, correct with
        // a valid frame (turned into the drogue's offset from the tip).
        let tip_body = f3(cfg.probe_tip_body_m);
        // The tip's velocity with the navigation's learnt bias taken out.
        let reported = point_velocity_mps(&self.last_nav, &self.design, tip_body);
        let tip: [f64; 3] = std::array::from_fn(|i| reported[i] - self.nav_bias[i]);
        let frame = meas_ok.then(|| {
            let (m, n) = (&input.measurement, &self.last_nav);
            let t = tip_from_camera(&cfg);
            let tip_image = if t[2] > 0.0 {
                [t[0] / t[2], t[1] / t[2]]
            } else {
                [0.0; 2]
            };
            let att = [n.lat.phi_rad, n.lon.theta_rad, n.lat.psi_rad].map(f64::from);
            let image = [f(m.image_x), f(m.image_y)];
            let z = f(m.depth_m);
            let r = drogue_from_tip(&cfg, image, z, att, self.design.theta, tip_image);
            (r, z)
        });
        if let Some(filter) = &mut self.filter {
            filter.predict(&cfg, self.design.swing_period, tip);
            if let Some((r, z)) = frame {
                filter.correct(&cfg, r, z, o);
            }
        }
        let (offset, mean, velocity, depth, rms) = match &self.filter {
            Some(fl) => (
                [fl.axes[0].x[0], fl.axes[1].x[0]],
                fl.mean,
                [0, 1, 2].map(|i| fl.axes[i].x[1]),
                fl.axes[2].x[0],
                fl.rms_mps(),
            ),
            None => ([0.0; 2], [0.0; 2], [0.0; 3], 0.0, 0.0),
        };
        let closing = tip[2] - velocity[2];
        let predicted_miss = match (&self.filter, self.mode) {
            (Some(fl), Mode::Approach | Mode::Terminal) => {
                fl.predicted_miss_m(&cfg, closing, [tip[0], tip[1]], o)
            }
            _ => f64::INFINITY,
        };
        // The core compares squared norms with squared limits; the model compares norms
        // with limits (the same order, in the quantities' own units).
        let norm = |v: [f64; 2]| v[0].hypot(v[1]);
        let late_gate = |d: f64| {
            let slope = (f(rc.late_gate_radius_m) - f(rc.late_gate_final_radius_m))
                / f(rc.late_gate_taper_m);
            (f(rc.late_gate_final_radius_m) + slope * d.max(0.0)).min(f(rc.late_gate_radius_m))
        };
        let brk = |m: &mut Self, r| m.break_away(r);
        let no_go = |m: &mut Self, r| {
            m.no_go = Some(r);
            if m.abort_pending {
                m.break_away(BreakawayReason::Abort);
            } else if m.attempt >= rc.max_attempts {
                (m.mode, m.reason) = (Mode::Breakaway, Some(BreakawayReason::AttemptsExhausted));
            } else {
                m.mode = Mode::MissedApproach;
            }
        };
        let before = self.mode;
        let capture_defers = o.lt(depth, closing * f(rc.forward_lag_s))
            || !o.gt(rms, f(rc.rough_air_drogue_speed_mps));
        if let Some(r) = self.common_rows(input, engaged, capture_defers) {
            refused = r;
        } else if matches!(
            self.mode,
            Mode::PreContact | Mode::Approach | Mode::Terminal | Mode::MissedApproach
        ) && o.gt(
            tracked_fwd_mps(&self.last_nav, &self.design, tip_body),
            f(md.overspeed_mps),
        ) {
            brk(self, BreakawayReason::Overspeed);
        } else {
            if engaged {
                self.sortie_steps += 1;
                self.mode_steps += 1;
            }
            if matches!(
                self.mode,
                Mode::PreContact | Mode::Approach | Mode::Terminal | Mode::MissedApproach
            ) {
                self.meas_invalid = if meas_ok {
                    0
                } else {
                    self.meas_invalid.saturating_add(1)
                };
            }
            let lost = self.meas_invalid > md.hold_limit_steps;
            let late = self.sortie_steps > steps(rc.sortie_budget_s);
            let at_station = |o: &mut Choices| {
                o.le(
                    (depth - f(rc.station_depth_m)).abs(),
                    f(rc.station_depth_tol_m),
                )
            };
            match self.mode {
                Mode::Standby if input.request == ModeRequest::Engage => {
                    if meas_ok && nav_ok {
                        (self.mode, self.attempt, self.no_go) = (Mode::PreContact, 1, None);
                        self.sortie_steps = 0;
                    } else {
                        refused = true;
                    }
                }
                Mode::Standby | Mode::Breakaway => {}
                Mode::PreContact if lost => brk(self, BreakawayReason::MeasurementLost),
                Mode::PreContact if late => brk(self, BreakawayReason::SortieTimeout),
                Mode::PreContact
                    if o.lt(depth, f(rc.station_depth_m) - f(rc.station_overrun_m)) =>
                {
                    brk(self, BreakawayReason::StationOverrun)
                }
                Mode::PreContact => {
                    // Rough air (the drogue's measured RMS speed above the threshold) has
                    // its own offset tolerance.
                    let offset_tol = if o.gt(rms, f(rc.rough_air_drogue_speed_mps)) {
                        rc.rough_air_station_offset_tol_m
                    } else {
                        rc.station_offset_tol_m
                    };
                    let stable = o.le(norm(mean), f(offset_tol))
                        && at_station(o)
                        && o.le(
                            norm([velocity[0], velocity[1]]),
                            f(rc.station_drogue_speed_tol_mps),
                        )
                        && o.le(norm([tip[0], tip[1]]), f(rc.station_relative_speed_tol_mps));
                    if meas_ok {
                        self.stable = if stable { self.stable + 1 } else { 0 };
                    }
                    if self.stable >= steps(rc.station_dwell_s)
                        && meas_ok
                        && o.le(norm(offset), f(rc.station_clear_offset_m))
                    {
                        (self.mode, self.no_go) = (Mode::Approach, None);
                        let contact = if o.gt(rms, f(rc.rough_air_drogue_speed_mps)) {
                            rc.rough_air_contact_speed_mps
                        } else {
                            rc.contact_speed_mps
                        };
                        self.commit_depth = commit_depth(&cfg, contact);
                    }
                }
                Mode::Approach if lost => brk(self, BreakawayReason::MeasurementLost),
                Mode::Approach if o.gt(norm(offset), f(rc.abort_offset_m)) => {
                    no_go(self, NoGoReason::OffsetTooLarge)
                }
                Mode::Approach if o.le(depth, self.commit_depth) => {
                    if o.gt(predicted_miss, f(rc.gate_radius_m)) {
                        no_go(self, NoGoReason::PredictedMiss);
                    } else {
                        self.mode = Mode::Terminal;
                    }
                }
                Mode::Approach => {}
                Mode::Terminal if input.probe_contact => self.mode = Mode::Docked,
                Mode::Terminal if o.lt(depth, -f(rc.overshoot_m)) => {
                    no_go(self, NoGoReason::PassedDroguePlane)
                }
                Mode::Terminal if self.mode_steps > steps(rc.capture_timeout_s) => {
                    no_go(self, NoGoReason::CaptureTimeout)
                }
                // The late gate and the closing speed are judged between two depths only.
                Mode::Terminal
                    if meas_ok
                        && o.le(depth, f(rc.late_gate_depth_m))
                        && !o.lt(depth, f(rc.late_gate_min_depth_m))
                        && o.gt(predicted_miss, late_gate(depth)) =>
                {
                    no_go(self, NoGoReason::LateNoGo)
                }
                Mode::Terminal
                    if meas_ok
                        && o.le(depth, f(rc.late_gate_depth_m))
                        && !o.lt(depth, f(rc.late_gate_min_depth_m))
                        && o.lt(closing, f(rc.capture_min_closing_mps)) =>
                {
                    no_go(self, NoGoReason::ClosingTooSlow)
                }
                Mode::Terminal => {}
                Mode::MissedApproach
                    if u32::from(self.meas_invalid) > steps(rc.reacquire_limit_s) =>
                {
                    brk(self, BreakawayReason::MeasurementLost)
                }
                Mode::MissedApproach if late => brk(self, BreakawayReason::SortieTimeout),
                Mode::MissedApproach => {
                    if self.mode_steps >= steps(rc.missed_clear_s) && meas_ok && at_station(o) {
                        self.mode = Mode::PreContact;
                        self.attempt += 1;
                    }
                }
                Mode::Docked if self.abort_pending => brk(self, BreakawayReason::Abort),
                Mode::Docked if !input.probe_contact => brk(self, BreakawayReason::ContactLost),
                Mode::Docked => {}
            }
        }
        // The estimator stops in standby and starts from the engaging step's frame.
        match (before, self.mode) {
            (_, Mode::Standby) => self.filter = None,
            (Mode::Standby, Mode::PreContact) => {
                self.filter = frame.map(|(r, z)| Filter::restart(&cfg, r, z, None));
                (self.nav_bias, self.nav_bias_steps) = ([0.0; 3], 0);
            }
            _ => {}
        }
        // Holding the station, the bias is learnt from the drogue's estimated velocity (as
        // it was before this step's mode change): the running mean since engage, its memory
        // growing from the drogue model's correlation time to the bias's time constant.
        let memory = f(cfg.estimator.nav_bias_time_constant_s) / f(Controller::PERIOD_S);
        if self.mode == Mode::PreContact && memory > 0.0 {
            self.nav_bias_steps += 1;
            let first = f(cfg.estimator.drogue_time_constant_s) / f(Controller::PERIOD_S);
            let a = 1.0 / (f64::from(self.nav_bias_steps) + first).min(memory);
            for (b, v) in self.nav_bias.iter_mut().zip(velocity) {
                *b += a * v;
            }
        }
        refused
    }
}

/// The set of model states consistent with every output so far.
#[derive(Debug)]
pub struct Models {
    procedure: Procedure,
    states: Vec<Model>,
    /// The most states followed at once.
    pub most: usize,
    /// Steps after which more than one state agreed with the controller.
    pub unsure_steps: usize,
}

impl Models {
    /// One state: the controller just built with `cfg`.
    pub fn new(cfg: ControllerConfig) -> Self {
        Self {
            procedure: cfg.procedure,
            states: vec![Model::new(cfg)],
            most: 1,
            unsure_steps: 0,
        }
    }

    /// Steps every state on `input` along every way its uncertain decisions can go, and keeps
    /// those that show what the controller's output `out` shows; an error naming what the
    /// tables give when none does.
    pub fn step(&mut self, input: &ControllerInput, out: &ControllerOutput) -> Result<(), String> {
        let want = Observed::of(out, self.procedure);
        let mut next: Vec<Model> = Vec::new();
        let mut other = Vec::new();
        for state in &self.states {
            let mut branches = vec![Vec::new()];
            while let Some(given) = branches.pop() {
                let mut o = Choices {
                    given: given.clone(),
                    taken: Vec::new(),
                };
                let mut m = state.clone();
                let got = m.step(input, &mut o);
                for j in given.len()..o.taken.len() {
                    let mut b = o.taken[..j].to_vec();
                    b.push(true);
                    branches.push(b);
                }
                if got == want {
                    if !next.iter().any(|n| n.same_as(&m)) {
                        next.push(m);
                    }
                } else {
                    other.push(got);
                }
            }
        }
        if next.is_empty() {
            return Err(format!(
                "the controller shows {want:?}, the tables give {other:?} (from {:?})",
                self.states
                    .iter()
                    .map(|m| (m.mode, m.attempt, m.stable, m.meas_invalid))
                    .collect::<Vec<_>>()
            ));
        }
        if next.len() > MAX_STATES {
            return Err(format!(
                "{} model states agree with the controller: the decisions are too close to \
                 their thresholds for the model",
                next.len()
            ));
        }
        self.most = self.most.max(next.len());
        self.unsure_steps += usize::from(next.len() > 1);
        self.states = next;
        Ok(())
    }
}
