//! Disk margins at the actuator inputs of the inner loops as the core flies them, measured on
//! the receiver linearised at a schedule node with the TRUE cg and the TRUE navigation
//! latency.
//!
//! **The loop** ([`FlownLoop`]), one control period `Ts` = [`CONTROL_PERIOD_S`] per step, both
//! channels at once:
//! - the plant: the nonlinear F-16 at cg `xcg` trimmed at the node's airspeed and altitude
//!   and linearised there ([`crate::linearize`]: the ten design coordinates, the engine's
//!   power lag among them, the full 10 x 10 matrix, so the small gyroscopic coupling between
//!   the channels stays in), with a first-order lag of each surface's bandwidth on the
//!   elevator, aileron and rudder (the nominal one, or a dispersed airframe's,
//!   [`TruePlant::with_plant`]; the throttle drives the engine state directly), as
//!   [`super::with_actuators_each`] builds it; discretised by zero-order hold at `Ts`;
//! - the navigation: the nine measured states `[theta, V, alpha, q | psi, phi, beta, p, r]`
//!   reach the controller `true_latency` periods late (a delay line);
//! - the controller, read from `core/src/controller.rs` (`Controller::step`),
//!   `core/src/inner.rs` and `core/src/predictor.rs`, with the core's own numbers: the node's
//!   [`DesignPoint`] from `ibvs_core::schedule::design_at` (the node's, bit for bit), the
//!   gains of the configured procedure, the output rows `C = C_cg + C_lever` of the tracked
//!   point of the configuration (the probe tip in the refuelling procedure, the camera in the
//!   paper's), the latency predictor set to the configuration's `nav_latency_steps` (the
//!   DESIGN latency, not the true one), the engine estimate. Per channel,
//!   `u = -(K_x [predicted measured states; P_hat] + K_a a + K_q q)`, `a` the predictor's
//!   own model of the surface deflections (longitudinal: the elevator's, and 0 for the
//!   throttle), the integrators `q += Ts (C x_late - v_des)` on the LATE sample (with
//!   `P_hat` in it), the engine estimate `P_hat` and the predictor's unmeasured states and
//!   record advanced by the command sent.
//!
//! **The margins** (Seiler, Packard & Gahinet, "An Introduction to Disk Margins", IEEE
//! Control Systems Magazine, 2020), balanced disk (skew `sigma = 0`), at the plant input: with
//! `S(z) = I + C_u (zI - A)^-1 B_w`, the input sensitivity (the map from a signal added to the
//! plant's inputs to the inputs the plant receives; the controller keeps recording the
//! commands it SENT: a gain or phase change of the actuators is not seen by its models),
//! `alpha = 1 / sup_w mu(S - I/2)` over `z = exp(j w Ts)`, `0 < w <= pi / Ts`. A disk margin
//! `alpha` guarantees stability for every simultaneous gain in
//! `[(1 - alpha/2)/(1 + alpha/2), (1 + alpha/2)/(1 - alpha/2)]` or phase within
//! `+/- 2 atan(alpha/2)`: 6 dB needs `alpha >= 2/3`, 45 deg `alpha >= 2 tan(22.5 deg) = 0.828`.
//! - loop at a time: input `i` alone perturbed, every other loop closed: `|S_ii - 1/2|` (exact);
//! - one channel's two inputs together (elevator and throttle; aileron and rudder), the other
//!   channel closed: `mu` of the 2 x 2 block of `S - I/2` for two complex scalar
//!   perturbations, computed as `inf_d sigma_max(D M D^-1)`, `D = diag(d, 1)`, which equals
//!   `mu` for two blocks (exact up to the line search);
//! - all four inputs together: `sigma_max(S - I/2)` (an upper bound on `mu`, so the margin
//!   reported is a LOWER bound: conservative).
//!
//! The frequency grid: [`GRID_POINTS`] points spaced logarithmically from
//! [`LOWEST_FREQUENCY_RADPS`] to Nyquist (`pi / Ts` = 157.08 rad/s, included), then the peak
//! of each figure refined by a golden-section search between the grid points either side of
//! it (on the unit circle, exact discrete responses). Below the lowest frequency the
//! integrators hold `S` near 0 (`|S - 1/2|` near 1/2, far from a peak). A closed loop that is
//! not stable (spectral radius >= 1) has margin 0.
//!
//! **Approximated** (small-signal): the saturations (positions), the surfaces' rate limits,
//! the integrators' anti-windup and clamp are ignored; the actuators are the nominal
//! first-order lag (the plant dispersions of their bandwidth are not applied); the
//! predictor's record is full (more than `nav_latency_steps` steps since engage); the
//! navigation's perturbations are taken from the TRUE trim (the design trim's offset is a
//! constant, which the integrators take out); the schedule node's design is flown (between
//! nodes the core blends the designs: not covered here); the controller runs in `f64` (the
//! core in `f32`). The test `the_analysed_loop_is_the_flown_loop` checks the rest against the
//! core's own [`ibvs_core::Controller::step`] sample by sample.
//!
//! Invariants: [`FlownLoop::matrices`] is the exact one-step map of [`FlownLoop::step`] (built
//! column by column from it on unit vectors); every margin is in `[0, 2]`, 0 for an unstable
//! loop.

use std::f64::consts::PI;

use ibvs_core::controller::inner_gains;
use ibvs_core::kinematics::{lever_arm_lat, lever_arm_lon};
use ibvs_core::predictor::PlantModel;
use ibvs_core::schedule::{DesignPoint, FlightCondition, ScheduleError, design_at};
use ibvs_core::{ControllerConfig, Procedure};
use nalgebra::{Complex, DMatrix, DVector};

use super::linalg::{spectral_radius, zoh};
use super::{CONTROL_PERIOD_S, with_actuators_each};
use crate::linearize::linearize;
use crate::receiver::{F16, ModelError, ReceiverPlant, TrimError};

/// The plant's inputs, in order.
pub const INPUTS: [&str; 4] = ["elevator", "throttle", "aileron", "rudder"];
/// Which plant inputs go through a surface actuator (the throttle drives the engine state).
pub const ACTUATED: [bool; 4] = [true, false, true, true];
/// The measured design coordinates (the navigation sample's), in the order the core reads
/// them: longitudinal `theta, V, alpha, q`, lateral `psi, phi, beta, p, r`.
const MEASURED: [usize; 9] = [0, 1, 2, 3, 5, 6, 7, 8, 9];
/// Measured longitudinal states.
const NM_LON: usize = 4;
/// Measured lateral states.
const NM_LAT: usize = 5;

/// Lowest frequency of the grid, rad/s.
pub const LOWEST_FREQUENCY_RADPS: f64 = 1e-3;
/// Points of the logarithmic frequency grid (about 92 a decade over the 5.2 decades).
pub const GRID_POINTS: usize = 480;
/// Golden-section iterations refining each peak (the bracket shrinks by 0.618 each).
const REFINE_ITERATIONS: usize = 40;

/// The disk margin that gives 45 deg of phase, `2 tan(22.5 deg)`; it gives 7.66 dB of gain.
pub const ALPHA_45_DEG: f64 = 0.828_427_124_746_190_1;

/// Why a loop could not be built.
#[derive(Debug, thiserror::Error)]
pub enum MarginsError {
    /// The receiver model could not be built.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// The receiver does not trim at the node with the true cg.
    #[error(transparent)]
    Trim(#[from] TrimError),
    /// The condition is not in the schedule.
    #[error("no design at the condition: {0}")]
    Schedule(ScheduleError),
}

/// The navigation latency the refuelling campaigns' predictor compensates, control periods:
/// the upper end of their INS latency range, 1..2 (`docs/conventions.md`, "Navigation
/// errors"; the presets' dispersion, checked by `host-sim/tests/margins.rs`).
pub const FLOWN_NAV_LATENCY_STEPS: u8 = 2;

/// The refuelling procedure's controller as the refuelling campaigns fly it: the default
/// configuration with the predictor set for [`FLOWN_NAV_LATENCY_STEPS`].
pub fn flown_config() -> ControllerConfig {
    ControllerConfig {
        nav_latency_steps: FLOWN_NAV_LATENCY_STEPS,
        ..ControllerConfig::default()
    }
}

/// A balanced disk margin and the frequency of its worst point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiskMargin {
    /// `alpha`: the disk's size (0 for an unstable loop).
    pub alpha: f64,
    /// Where `|S - I/2|` (or its `mu`) peaks, rad/s.
    pub frequency_radps: f64,
}

impl DiskMargin {
    /// The guaranteed gain margin, dB (the upper end; the lower end is its negative):
    /// `20 log10((1 + alpha/2) / (1 - alpha/2))`, infinite for `alpha >= 2`.
    pub fn gain_margin_db(&self) -> f64 {
        if self.alpha >= 2.0 {
            f64::INFINITY
        } else {
            20.0 * ((1.0 + self.alpha / 2.0) / (1.0 - self.alpha / 2.0)).log10()
        }
    }

    /// The guaranteed phase margin, deg: `2 atan(alpha/2)`.
    pub fn phase_margin_deg(&self) -> f64 {
        (2.0 * (self.alpha / 2.0).atan()).to_degrees()
    }

    /// Whether it guarantees both 6 dB and 45 deg (45 deg is the stricter).
    pub fn meets_6db_45deg(&self) -> bool {
        self.alpha >= ALPHA_45_DEG
    }
}

/// The margins of one loop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Margins {
    /// Loop at a time, per input ([`INPUTS`]).
    pub input: [DiskMargin; 4],
    /// Both inputs of a channel together: longitudinal (elevator, throttle), lateral
    /// (aileron, rudder); `mu` by D-scaling (exact for two blocks).
    pub channel: [DiskMargin; 2],
    /// All four together: `sigma_max` bound, conservative.
    pub all: DiskMargin,
    /// The closed loop's spectral radius.
    pub spectral_radius: f64,
}

impl Margins {
    /// The smallest loop-at-a-time margin and its input's index.
    pub fn worst_input(&self) -> (usize, DiskMargin) {
        let mut w = (0, self.input[0]);
        for (i, m) in self.input.iter().enumerate() {
            if m.alpha < w.1.alpha {
                w = (i, *m);
            }
        }
        w
    }
}

/// The core's controller, in `f64`: the matrices `Controller::step` multiplies.
#[derive(Debug, Clone)]
pub struct FlownController {
    /// Longitudinal `K_x` (2 x 5), `K_a` (2 x 2), `K_q` (2 x 2).
    lon: [DMatrix<f64>; 3],
    /// Lateral `K_x` (2 x 5), `K_a` (2 x 2), `K_q` (2 x 1).
    lat: [DMatrix<f64>; 3],
    /// What the integrators hold, rows `[down, forward, right]` over the ten design states
    /// `[theta, V, alpha, q, P, psi, phi, beta, p, r]` (`tracked_output`).
    c_tracked: DMatrix<f64>,
    /// The longitudinal predictor's `(Phi, Gamma)`: measured 4, then engine and elevator.
    predict_lon: (DMatrix<f64>, DMatrix<f64>),
    /// The lateral predictor's: measured 5, then aileron and rudder.
    predict_lat: (DMatrix<f64>, DMatrix<f64>),
    /// The engine estimate's `(pole, gain)`.
    engine: (f64, f64),
    /// The latency the predictor compensates (the configuration's), periods.
    pub design_latency: usize,
}

fn mat<const R: usize, const C: usize>(a: &[[f32; C]; R]) -> DMatrix<f64> {
    DMatrix::from_fn(R, C, |r, c| f64::from(a[r][c]))
}

/// `(Phi, Gamma)` of the core's predictor model: `Phi = [[I + delta_mm, phi_me], [0, phi_ee]]`.
fn predictor<const NM: usize, const NE: usize, const NU: usize>(
    p: &PlantModel<NM, NE, NU>,
) -> (DMatrix<f64>, DMatrix<f64>) {
    let n = NM + NE;
    let mut phi = DMatrix::zeros(n, n);
    phi.view_mut((0, 0), (NM, NM))
        .copy_from(&(mat(&p.delta_mm) + DMatrix::identity(NM, NM)));
    phi.view_mut((0, NM), (NM, NE)).copy_from(&mat(&p.phi_me));
    phi.view_mut((NM, NM), (NE, NE)).copy_from(&mat(&p.phi_ee));
    let mut gamma = DMatrix::zeros(n, NU);
    gamma.view_mut((0, 0), (NM, NU)).copy_from(&mat(&p.gamma_m));
    gamma
        .view_mut((NM, 0), (NE, NU))
        .copy_from(&mat(&p.gamma_e));
    (phi, gamma)
}

/// What the integrators hold, rows `[down, forward, right]` over the ten design states
/// `[theta, V, alpha, q, P, psi, phi, beta, p, r]`: the paper's procedure's linear output at
/// the trim of `d`; the refuelling procedure's exact kinematics linearised where the aircraft
/// flies, at the true airframe's trim `plant` (the navigation's perturbations are from the
/// schedule's trim, so the kinematics the core evaluates at the schedule's trim plus them are
/// at the true state; an airframe of another mass or cg trims elsewhere: at 100 m/s and
/// 8,000 m, 17.1° of angle of attack for the design's, 13.9° at 0.85 of its mass).
///
/// The paper's procedure integrates the design's output `C x` of the tracked point (the
/// generated `c_cg` with the lever arm), block by block. The refuelling procedure integrates
/// the tip's velocity by exact kinematics (`kinematics::point_velocity_tanker_mps`), whose
/// linearisation differs in two ways: the bank's term of the lateral row is `-V sin(alpha)`
/// at the trim the controller adds the states to (the refuelling design's `c_cg` has it 5 %
/// smaller), and the tip's lateral offset `y` couples the roll and yaw rates into the
/// vertical and forward velocities (`omega x p`: down `+cos(theta) y p + sin(theta) y r`,
/// forward `+sin(theta) y p - cos(theta) y r`), which the channels' design leaves out.
fn tracked_output(
    d: &DesignPoint,
    procedure: Procedure,
    p_body_m: [f32; 3],
    plant: &TruePlant,
) -> DMatrix<f64> {
    let mut c = DMatrix::zeros(3, 10);
    match procedure {
        Procedure::Paper => {
            let lon = mat(&d.lon.c_cg) + mat(&lever_arm_lon(p_body_m, d.trim.theta_rad));
            let lat = mat(&d.lat.c_cg) + mat(&lever_arm_lat(p_body_m));
            c.view_mut((0, 0), (2, 5)).copy_from(&lon);
            c.view_mut((2, 5), (1, 5)).copy_from(&lat);
        }
        Procedure::Refuelling => {
            let (v, th, al) = (plant.speed_mps, plant.trim_theta_rad, plant.trim_alpha_rad);
            let p = p_body_m.map(f64::from);
            let y = p[1];
            let (cg, sg) = ((th - al).cos(), (th - al).sin());
            let (ct, st) = (th.cos(), th.sin());
            // The CG's velocity (the rotation of V, alpha, beta by the attitude), and the
            // lever arm's pitch-rate (longitudinal) and roll- and yaw-rate (lateral) terms
            // as the core computes them for `C x`.
            #[rustfmt::skip]
            let cg_rows = [
                // theta, V, alpha, q, P, psi, phi, beta, p, r
                [-v * cg, -sg, v * cg, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                [-v * sg, cg, v * sg, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                [0.0, 0.0, 0.0, 0.0, 0.0, v * cg, -v * al.sin(), v, 0.0, 0.0],
            ];
            for (r, row) in cg_rows.iter().enumerate() {
                for (j, &e) in row.iter().enumerate() {
                    c[(r, j)] = e;
                }
            }
            for (r, row) in lever_arm_lon(p, th).iter().enumerate() {
                for (j, &e) in row.iter().enumerate() {
                    c[(r, j)] += e;
                }
            }
            for (j, &e) in lever_arm_lat(p)[0].iter().enumerate() {
                c[(2, 5 + j)] += e;
            }
            // The lateral offset's cross terms, which the channels' lever arms leave out.
            c[(0, 8)] = ct * y;
            c[(0, 9)] = st * y;
            c[(1, 8)] = st * y;
            c[(1, 9)] = -ct * y;
        }
    }
    c
}

impl FlownController {
    /// The controller `cfg` configures, flying the design `d` (as `Controller::set_design`
    /// builds its loops) on `plant` (where its refuelling kinematics are linearised).
    pub fn new(d: &DesignPoint, cfg: &ControllerConfig, plant: &TruePlant) -> Self {
        let tracked = match cfg.procedure {
            Procedure::Paper => cfg.camera.position_body_m,
            Procedure::Refuelling => cfg.probe_tip_body_m,
        };
        let (lon, lat) = inner_gains(d, cfg);
        let c_tracked = tracked_output(d, cfg.procedure, tracked, plant);
        Self {
            lon: [
                mat(&lon.k_state),
                mat(&lon.k_actuator),
                mat(&lon.k_integral),
            ],
            lat: [
                mat(&lat.k_state),
                mat(&lat.k_actuator),
                mat(&lat.k_integral),
            ],
            c_tracked,
            predict_lon: predictor(&d.predict_lon),
            predict_lat: predictor(&d.predict_lat),
            engine: (f64::from(d.engine.pole), f64::from(d.engine.gain_pct)),
            design_latency: usize::from(
                cfg.nav_latency_steps
                    .min(ibvs_core::predictor::MAX_NAV_LATENCY_STEPS),
            ),
        }
    }
}

/// The true receiver at one condition: the discrete plant with its actuators.
#[derive(Debug, Clone)]
pub struct TruePlant {
    /// The cg, fraction of the mean chord.
    pub xcg: f64,
    /// True airspeed, m/s.
    pub speed_mps: f64,
    /// Altitude, m.
    pub altitude_m: f64,
    /// Its trim's pitch, rad.
    pub trim_theta_rad: f64,
    /// Its trim's angle of attack, rad.
    pub trim_alpha_rad: f64,
    /// Discrete state matrix: 10 design coordinates, then elevator, aileron, rudder.
    pub pd: DMatrix<f64>,
    /// Discrete input matrix, inputs [`INPUTS`].
    pub pb: DMatrix<f64>,
}

impl TruePlant {
    /// The F-16 at cg `xcg` trimmed straight and level at `speed_mps`, `altitude_m`,
    /// linearised, with its nominal actuators, discretised at the control period.
    pub fn new(xcg: f64, speed_mps: f64, altitude_m: f64) -> Result<Self, MarginsError> {
        Self::with_plant(xcg, &ReceiverPlant::NOMINAL, speed_mps, altitude_m)
    }

    /// [`TruePlant::new`] on a dispersed airframe: the plant factors `factors` (aerodynamics,
    /// mass, inertia, actuators' bandwidths; the linear loop has no rate limits), as a
    /// campaign's run flies it.
    pub fn with_plant(
        xcg: f64,
        factors: &ReceiverPlant,
        speed_mps: f64,
        altitude_m: f64,
    ) -> Result<Self, MarginsError> {
        let model = F16::with_plant(xcg, factors)?;
        let trim = model.trim_straight_level(speed_mps, altitude_m)?;
        let lin = linearize(&model, &trim);
        // Each surface's bandwidth as flown: the data's times its factor (the throttle has no
        // actuator state).
        let base = model.actuators().bandwidth_radps;
        let bandwidths = [
            base * factors.elevator_bandwidth_scale,
            0.0,
            base * factors.aileron_bandwidth_scale,
            base * factors.rudder_bandwidth_scale,
        ];
        let (ac, bc) = with_actuators_each(&lin.a, &lin.b, &ACTUATED, &bandwidths);
        let (pd, pb) = zoh(&ac, &bc, CONTROL_PERIOD_S);
        Ok(Self {
            xcg,
            speed_mps,
            altitude_m,
            trim_theta_rad: trim.theta_rad,
            trim_alpha_rad: trim.alpha_rad,
            pd,
            pb,
        })
    }
}

/// Offsets of the loop's state vector.
#[derive(Debug, Clone, Copy)]
struct Layout {
    /// Plant states.
    np: usize,
    /// Delay line of the measured states: slot `j` is step `k-1-j`.
    delay: usize,
    /// Engine estimate.
    engine: usize,
    /// Predictors' unmeasured states, longitudinal (2) then lateral (2).
    e: usize,
    /// Predictors' records: slot `j` (step `k-1-j`) is `(e_lon, u_lon, e_lat, u_lat)`, 8.
    ring: usize,
    /// Integrators: longitudinal (down, forward), lateral (right).
    q: usize,
    /// Length.
    len: usize,
}

const RING_SLOT: usize = 8;

/// One closed loop: the true plant, the true latency, the flown controller.
#[derive(Debug, Clone)]
pub struct FlownLoop<'a> {
    /// The plant.
    pub plant: &'a TruePlant,
    /// The controller.
    pub controller: &'a FlownController,
    /// The navigation's true latency, control periods.
    pub true_latency: usize,
}

/// The loop's matrices: `s' = A s + B_w w + B_r v_des`, `u = C_u s`; `w` is added to the
/// plant's inputs (after the controller's command), `v_des` is `[down, forward, right]`.
#[derive(Debug, Clone)]
pub struct LoopMatrices {
    /// Closed-loop state matrix.
    pub a: DMatrix<f64>,
    /// Plant-input disturbance.
    pub b_w: DMatrix<f64>,
    /// Desired velocity.
    pub b_r: DMatrix<f64>,
    /// The commands sent (perturbations from trim).
    pub c_u: DMatrix<f64>,
}

fn mul(a: &DMatrix<f64>, x: &[f64]) -> Vec<f64> {
    (0..a.nrows())
        .map(|r| (0..a.ncols()).map(|c| a[(r, c)] * x[c]).sum())
        .collect()
}

fn sub(a: &[f64], b: &[f64]) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| x - y).collect()
}

fn add(a: &[f64], b: &[f64]) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| x + y).collect()
}

impl FlownLoop<'_> {
    fn layout(&self) -> Layout {
        let np = self.plant.pd.nrows();
        let delay = np;
        let engine = delay + self.true_latency * MEASURED.len();
        let e = engine + 1;
        let ring = e + 4;
        let q = ring + self.controller.design_latency * RING_SLOT;
        Layout {
            np,
            delay,
            engine,
            e,
            ring,
            q,
            len: q + 3,
        }
    }

    /// The state vector's length.
    pub fn len(&self) -> usize {
        self.layout().len
    }

    /// Always false: the loop has plant states.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// The state vector with the plant at `x` (perturbations: 10 design coordinates, then
    /// the three surfaces), every late sample equal to `x`'s (as if held there), the
    /// controller at trim (as the core engages).
    pub fn initial_state(&self, x: &[f64]) -> Vec<f64> {
        let l = self.layout();
        let mut s = vec![0.0; l.len];
        s[..l.np].copy_from_slice(x);
        for j in 0..self.true_latency {
            for (k, &i) in MEASURED.iter().enumerate() {
                s[l.delay + j * MEASURED.len() + k] = x[i];
            }
        }
        s
    }

    /// The measured states the controller receives this step (the late sample).
    pub fn late_sample(&self, s: &[f64]) -> [f64; 9] {
        let l = self.layout();
        core::array::from_fn(|k| match self.true_latency {
            0 => s[MEASURED[k]],
            d => s[l.delay + (d - 1) * MEASURED.len() + k],
        })
    }

    /// One channel's state-feedback input: the late measured sample predicted over the
    /// design latency from the record (`Controller::step` through `LatencyPredictor::predict`).
    fn predicted(
        &self,
        s: &[f64],
        m_late: &[f64],
        model: &(DMatrix<f64>, DMatrix<f64>),
        ring_offset: usize,
    ) -> Vec<f64> {
        let d = self.controller.design_latency;
        if d == 0 {
            return m_late.to_vec();
        }
        let l = self.layout();
        let slot = |j: usize| l.ring + j * RING_SLOT + ring_offset;
        let mut z: Vec<f64> = m_late.to_vec();
        z.extend_from_slice(&s[slot(d - 1)..slot(d - 1) + 2]);
        for j in (0..d).rev() {
            let u = &s[slot(j) + 2..slot(j) + 4];
            z = add(&mul(&model.0, &z), &mul(&model.1, u));
        }
        z.truncate(m_late.len());
        z
    }

    /// One control period from state `s` with `w` added to the plant's inputs and the
    /// desired velocity `v_des` (`[down, forward, right]`): the next state and the commands
    /// sent this step (perturbations from trim).
    pub fn step(&self, s: &[f64], w: &[f64; 4], v_des: &[f64; 3]) -> (Vec<f64>, [f64; 4]) {
        let (l, c) = (self.layout(), self.controller);
        let m_late = self.late_sample(s);
        let (lon_late, lat_late) = (&m_late[..NM_LON], &m_late[NM_LON..]);
        let p_hat = s[l.engine];
        let (e_lon, e_lat) = (&s[l.e..l.e + 2], &s[l.e + 2..l.e + 4]);
        let (q_lon, q_lat) = (&s[l.q..l.q + 2], &s[l.q + 2..l.q + 3]);
        // Longitudinal: predicted measured states and the engine estimate; the elevator's
        // modelled deflection (the throttle has no actuator: 0).
        let mut x_lon = self.predicted(s, lon_late, &c.predict_lon, 0);
        x_lon.push(p_hat);
        let a_lon = [e_lon[1], 0.0];
        let u_lon: Vec<f64> = add(
            &add(&mul(&c.lon[0], &x_lon), &mul(&c.lon[1], &a_lon)),
            &mul(&c.lon[2], q_lon),
        )
        .iter()
        .map(|v| -v)
        .collect();
        let x_lat = self.predicted(s, lat_late, &c.predict_lat, 4);
        let u_lat: Vec<f64> = add(
            &add(&mul(&c.lat[0], &x_lat), &mul(&c.lat[1], e_lat)),
            &mul(&c.lat[2], q_lat),
        )
        .iter()
        .map(|v| -v)
        .collect();
        let u = [u_lon[0], u_lon[1], u_lat[0], u_lat[1]];

        let mut o = vec![0.0; l.len];
        let applied: Vec<f64> = u.iter().zip(w).map(|(a, b)| a + b).collect();
        let plant = add(
            &mul(&self.plant.pd, &s[..l.np]),
            &mul(&self.plant.pb, &applied),
        );
        o[..l.np].copy_from_slice(&plant);
        let nm = MEASURED.len();
        for j in (1..self.true_latency).rev() {
            let (from, to) = (l.delay + (j - 1) * nm, l.delay + j * nm);
            o[to..to + nm].copy_from_slice(&s[from..from + nm]);
        }
        if self.true_latency > 0 {
            for (k, &i) in MEASURED.iter().enumerate() {
                o[l.delay + k] = s[i];
            }
        }
        o[l.engine] = c.engine.0 * p_hat + c.engine.1 * u[1];
        // The predictors: record (e, u) as sent, then advance e by the model's lower rows.
        let advance = |model: &(DMatrix<f64>, DMatrix<f64>), nm: usize, e: &[f64], u: &[f64]| {
            let (phi, gamma) = model;
            (0..2)
                .map(|r| {
                    (0..2).map(|j| phi[(nm + r, nm + j)] * e[j]).sum::<f64>()
                        + (0..2).map(|j| gamma[(nm + r, j)] * u[j]).sum::<f64>()
                })
                .collect::<Vec<f64>>()
        };
        o[l.e..l.e + 2].copy_from_slice(&advance(&c.predict_lon, NM_LON, e_lon, &u[..2]));
        o[l.e + 2..l.e + 4].copy_from_slice(&advance(&c.predict_lat, NM_LAT, e_lat, &u[2..]));
        let d = c.design_latency;
        for j in (1..d).rev() {
            let (from, to) = (l.ring + (j - 1) * RING_SLOT, l.ring + j * RING_SLOT);
            o[to..to + RING_SLOT].copy_from_slice(&s[from..from + RING_SLOT]);
        }
        if d > 0 {
            let slot = &mut o[l.ring..l.ring + RING_SLOT];
            slot[..2].copy_from_slice(e_lon);
            slot[2..4].copy_from_slice(&u[..2]);
            slot[4..6].copy_from_slice(e_lat);
            slot[6..8].copy_from_slice(&u[2..]);
        }
        // The integrators read the late sample (with the engine estimate), not the prediction.
        let mut x_lon_late = lon_late.to_vec();
        x_lon_late.push(p_hat);
        let mut x_late = x_lon_late;
        x_late.extend_from_slice(lat_late);
        let y = mul(&c.c_tracked, &x_late);
        let (y_lon, y_lat) = (&y[..2], &y[2..]);
        let ts = CONTROL_PERIOD_S;
        let dq_lon = sub(y_lon, &v_des[..2]);
        o[l.q] = q_lon[0] + ts * dq_lon[0];
        o[l.q + 1] = q_lon[1] + ts * dq_lon[1];
        o[l.q + 2] = q_lat[0] + ts * (y_lat[0] - v_des[2]);
        (o, u)
    }

    /// The loop's matrices, column by column from [`FlownLoop::step`].
    pub fn matrices(&self) -> LoopMatrices {
        let n = self.len();
        let mut m = LoopMatrices {
            a: DMatrix::zeros(n, n),
            b_w: DMatrix::zeros(n, 4),
            b_r: DMatrix::zeros(n, 3),
            c_u: DMatrix::zeros(4, n),
        };
        for j in 0..n {
            let mut s = vec![0.0; n];
            s[j] = 1.0;
            let (next, u) = self.step(&s, &[0.0; 4], &[0.0; 3]);
            m.a.set_column(j, &DVector::from_vec(next));
            m.c_u.set_column(j, &DVector::from_column_slice(&u));
        }
        for j in 0..4 {
            let mut w = [0.0; 4];
            w[j] = 1.0;
            let (next, _) = self.step(&vec![0.0; n], &w, &[0.0; 3]);
            m.b_w.set_column(j, &DVector::from_vec(next));
        }
        for j in 0..3 {
            let mut r = [0.0; 3];
            r[j] = 1.0;
            let (next, _) = self.step(&vec![0.0; n], &[0.0; 4], &r);
            m.b_r.set_column(j, &DVector::from_vec(next));
        }
        m
    }

    /// The disk margins of the loop.
    pub fn margins(&self) -> Margins {
        margins_of(&self.matrices())
    }

    /// The tracked point's true velocity `[down, forward, right]` (the output rows on the
    /// plant's design coordinates now, not on the late sample) over the loop's state.
    pub fn tracked_velocity(&self) -> DMatrix<f64> {
        let c = &self.controller.c_tracked;
        DMatrix::from_fn(
            3,
            self.len(),
            |r, j| {
                if j < c.ncols() { c[(r, j)] } else { 0.0 }
            },
        )
    }

    /// The closed loop's response of the tracked velocity to the desired velocity at
    /// `omega_radps`, axis by axis (`[down, forward, right]`, each to its own desired
    /// velocity): `T(z) = C_y (zI - A)^-1 B_r` at `z = exp(j omega Ts)`.
    pub fn velocity_response(&self, m: &LoopMatrices, omega_radps: f64) -> [C64; 3] {
        let n = m.a.nrows();
        let z = C64::from_polar(1.0, omega_radps * CONTROL_PERIOD_S);
        let resolvent = DMatrix::<C64>::from_fn(n, n, |r, c| {
            let diag = if r == c { z } else { C64::new(0.0, 0.0) };
            diag - C64::new(m.a[(r, c)], 0.0)
        });
        let b = m.b_r.map(|v| C64::new(v, 0.0));
        let c = self.tracked_velocity().map(|v| C64::new(v, 0.0));
        let x = resolvent
            .lu()
            .solve(&b)
            .unwrap_or_else(|| DMatrix::zeros(n, 3));
        let t = c * x;
        [t[(0, 0)], t[(1, 1)], t[(2, 2)]]
    }
}

type C64 = Complex<f64>;

/// The input sensitivity `S(e^{jwTs}) = I + C_u (zI - A)^-1 B_w` by a Hessenberg form of
/// `A`: `A = Q H Q^T` once, then each frequency an `O(n^2)` elimination.
struct Sensitivity {
    h: DMatrix<f64>,
    qb: DMatrix<f64>,
    cq: DMatrix<f64>,
}

impl Sensitivity {
    fn new(m: &LoopMatrices) -> Self {
        let hess = m.a.clone().hessenberg();
        let (q, h) = hess.unpack();
        Self {
            qb: q.transpose() * &m.b_w,
            cq: &m.c_u * &q,
            h,
        }
    }

    /// `S` at `w` rad/s, 4 x 4, row-major.
    fn at(&self, w_radps: f64) -> [[C64; 4]; 4] {
        let n = self.h.nrows();
        let z = C64::from_polar(1.0, w_radps * CONTROL_PERIOD_S);
        // Rows of [zI - H | Q^T B_w], eliminated below the subdiagonal with partial pivoting.
        let width = n + 4;
        let mut m = vec![C64::new(0.0, 0.0); n * width];
        for r in 0..n {
            for c in r.saturating_sub(1)..n {
                m[r * width + c] = C64::from(-self.h[(r, c)]);
            }
            m[r * width + r] += z;
            for c in 0..4 {
                m[r * width + n + c] = C64::from(self.qb[(r, c)]);
            }
        }
        for k in 0..n.saturating_sub(1) {
            let (a, b) = (m[k * width + k], m[(k + 1) * width + k]);
            if b.norm_sqr() > a.norm_sqr() {
                for c in k..width {
                    m.swap(k * width + c, (k + 1) * width + c);
                }
            }
            let piv = m[k * width + k];
            if piv.norm_sqr() == 0.0 {
                continue;
            }
            let f = m[(k + 1) * width + k] / piv;
            for c in k..width {
                let v = m[k * width + c];
                m[(k + 1) * width + c] -= f * v;
            }
        }
        let mut x = vec![C64::new(0.0, 0.0); n * 4];
        for r in (0..n).rev() {
            for c in 0..4 {
                let mut acc = m[r * width + n + c];
                for j in r + 1..n {
                    acc -= m[r * width + j] * x[j * 4 + c];
                }
                x[r * 4 + c] = acc / m[r * width + r];
            }
        }
        core::array::from_fn(|i| {
            core::array::from_fn(|c| {
                let mut acc = C64::from(if i == c { 1.0 } else { 0.0 });
                for j in 0..n {
                    acc += x[j * 4 + c] * self.cq[(i, j)];
                }
                acc
            })
        })
    }
}

/// `sigma_max` of a 2 x 2 complex matrix.
fn sigma_max_2(m: [[C64; 2]; 2]) -> f64 {
    let t: f64 = m.iter().flatten().map(|v| v.norm_sqr()).sum();
    let det = (m[0][0] * m[1][1] - m[0][1] * m[1][0]).norm_sqr();
    ((t + (t * t - 4.0 * det).max(0.0).sqrt()) / 2.0).sqrt()
}

/// `mu` of a 2 x 2 complex matrix for two complex scalar blocks: `inf_d sigma_max(D M D^-1)`,
/// `D = diag(d, 1)` (`log sigma_max` is convex in `log d`; golden section over `d` in
/// `[1e-6, 1e6]`, never above the unscaled value).
fn mu_2(m: [[C64; 2]; 2]) -> f64 {
    let scaled = |ld: f64| {
        let d = ld.exp();
        sigma_max_2([[m[0][0], m[0][1] * d], [m[1][0] / d, m[1][1]]])
    };
    let ten6 = 6.0 * std::f64::consts::LN_10;
    let (_, least) = golden_max(|ld| -scaled(ld), -ten6, ten6, 60);
    (-least).min(scaled(0.0))
}

/// Golden-section search for the largest value of `f` on `[a, b]` in `iterations` steps:
/// `(x, f(x))` of the better of the two last points (`f` unimodal on the bracket for the
/// maximum, otherwise a local one).
fn golden_max(f: impl Fn(f64) -> f64, a: f64, b: f64, iterations: usize) -> (f64, f64) {
    let (mut a, mut b) = (a, b);
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut x1, mut x2) = (b - g * (b - a), a + g * (b - a));
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..iterations {
        if f1 > f2 {
            b = x2;
            (x2, f2) = (x1, f1);
            x1 = b - g * (b - a);
            f1 = f(x1);
        } else {
            a = x1;
            (x1, f1) = (x2, f2);
            x2 = a + g * (b - a);
            f2 = f(x2);
        }
    }
    if f1 > f2 { (x1, f1) } else { (x2, f2) }
}

/// `sigma_max` of a 4 x 4 complex matrix.
fn sigma_max_4(m: &[[C64; 4]; 4]) -> f64 {
    let a = DMatrix::<C64>::from_fn(4, 4, |r, c| m[r][c]);
    a.singular_values().max()
}

/// The figures whose peaks give the margins: `|S_ii - 1/2|` for each input, `mu` of each
/// channel's block, `sigma_max` of the whole.
fn figures(s: &[[C64; 4]; 4]) -> [f64; 7] {
    let mut m = *s;
    for (i, row) in m.iter_mut().enumerate() {
        row[i] -= C64::from(0.5);
    }
    let block = |o: usize| [[m[o][o], m[o][o + 1]], [m[o + 1][o], m[o + 1][o + 1]]];
    [
        m[0][0].norm(),
        m[1][1].norm(),
        m[2][2].norm(),
        m[3][3].norm(),
        mu_2(block(0)),
        mu_2(block(2)),
        sigma_max_4(&m),
    ]
}

/// The frequency grid, rad/s: logarithmic from [`LOWEST_FREQUENCY_RADPS`] to Nyquist.
pub fn frequency_grid() -> Vec<f64> {
    let top = PI / CONTROL_PERIOD_S;
    let (l0, l1) = (LOWEST_FREQUENCY_RADPS.ln(), top.ln());
    (0..GRID_POINTS)
        .map(|i| {
            if i + 1 == GRID_POINTS {
                top
            } else {
                (l0 + (l1 - l0) * i as f64 / (GRID_POINTS - 1) as f64).exp()
            }
        })
        .collect()
}

/// The disk margins of a loop given its matrices.
pub fn margins_of(m: &LoopMatrices) -> Margins {
    let radius = spectral_radius(&m.a);
    let unstable = DiskMargin {
        alpha: 0.0,
        frequency_radps: 0.0,
    };
    // Not below 1 (or NaN): unstable.
    if radius.partial_cmp(&1.0) != Some(std::cmp::Ordering::Less) {
        return Margins {
            input: [unstable; 4],
            channel: [unstable; 2],
            all: unstable,
            spectral_radius: radius,
        };
    }
    let sens = Sensitivity::new(m);
    let grid = frequency_grid();
    let values: Vec<[f64; 7]> = grid.iter().map(|&w| figures(&sens.at(w))).collect();
    let peak = |f: usize| -> DiskMargin {
        let (mut best, mut at) = (f64::MIN, 0);
        for (i, v) in values.iter().enumerate() {
            if v[f] > best {
                (best, at) = (v[f], i);
            }
        }
        // Golden-section maximisation between the neighbours of the grid's peak.
        let (w, v) = golden_max(
            |w| figures(&sens.at(w))[f],
            grid[at.saturating_sub(1)],
            grid[(at + 1).min(grid.len() - 1)],
            REFINE_ITERATIONS,
        );
        let mut w_best = grid[at];
        if v > best {
            (best, w_best) = (v, w);
        }
        DiskMargin {
            alpha: (1.0 / best).min(2.0),
            frequency_radps: w_best,
        }
    };
    Margins {
        input: core::array::from_fn(peak),
        channel: [peak(4), peak(5)],
        all: peak(6),
        spectral_radius: radius,
    }
}

/// The disk margins of a channel's DESIGN loop, for comparison with the flown one: the
/// synthesis's own discrete plant with every design state fed back as it truly is (the
/// actuators' deflections and the engine power measured, no latency), `u = -K [x; a; q]`.
/// The channel's two inputs are `input[0]`, `input[1]` and `channel[0]`; the other two
/// entries are empty loops (`alpha` 2).
pub fn design_loop_margins(d: &super::ChannelDesign) -> Margins {
    let n = d.a.nrows();
    let mut b_w = DMatrix::zeros(n, 4);
    b_w.view_mut((0, 0), (n, 2)).copy_from(&d.b);
    let mut c_u = DMatrix::zeros(4, n);
    c_u.view_mut((0, 0), (2, n)).copy_from(&(-&d.k));
    margins_of(&LoopMatrices {
        a: &d.a - &d.b * &d.k,
        b_w,
        b_r: DMatrix::zeros(n, 3),
        c_u,
    })
}

/// One point of the grid of [`grid`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridPoint {
    /// Node airspeed, m/s.
    pub speed_mps: f64,
    /// Node altitude, m.
    pub altitude_m: f64,
    /// True cg, fraction of the mean chord.
    pub xcg: f64,
    /// True navigation latency, control periods.
    pub true_latency: usize,
    /// The margins.
    pub margins: Margins,
}

/// The loop's two sides at a flight condition: the receiver with the plant factors `factors`
/// at cg `xcg` trimmed at `speed_mps` and `altitude_m` ([`TruePlant::with_plant`]), and the
/// controller `cfg` configures flying its design there (which picks its gains by its own
/// `mass_factor`). Close them with a [`FlownLoop`] at a true latency.
pub fn flown_on(
    cfg: &ControllerConfig,
    xcg: f64,
    factors: &ReceiverPlant,
    speed_mps: f64,
    altitude_m: f64,
) -> Result<(TruePlant, FlownController), MarginsError> {
    let design = node_design(speed_mps, altitude_m)?;
    let plant = TruePlant::with_plant(xcg, factors, speed_mps, altitude_m)?;
    let controller = FlownController::new(&design, cfg, &plant);
    Ok((plant, controller))
}

/// The disk margins of the inner loops as flown on a campaign's run as
/// [`crate::scenario::ScenarioFile::dispersed`] draws it: its airframe's factors and cg
/// trimmed at its flight condition, its configuration, the INS's latency. What the run
/// flies, but for the actuators' rate and position limits and the turbulence.
pub fn run_margins(run: &crate::scenario::ScenarioFile) -> Result<Margins, MarginsError> {
    let (plant, controller) = flown_on(
        &run.controller_config(),
        run.receiver.xcg,
        &run.receiver.plant,
        run.flight.airspeed_mps,
        run.flight.altitude_m,
    )?;
    Ok(FlownLoop {
        plant: &plant,
        controller: &controller,
        true_latency: usize::from(run.navigation.installed_latency_steps()),
    }
    .margins())
}

/// The true cgs of the receiver's range (docs/models.md, "Receiver plant dispersions").
pub const GRID_XCG: [f64; 3] = [0.30, 0.35, 0.40];
/// The true navigation latencies, control periods.
pub const GRID_LATENCY_STEPS: [usize; 3] = [0, 1, 2];

/// The margins at every schedule node (`[altitude][speed]` order flattened, speed fastest),
/// true cg in [`GRID_XCG`], true latency in [`GRID_LATENCY_STEPS`], of the controller `cfg`
/// configures, on the design's airframe (mass factor 1).
pub fn grid(cfg: &ControllerConfig) -> Result<Vec<GridPoint>, MarginsError> {
    grid_on(cfg, 1.0)
}

/// [`grid`] on the airframe at `mass_factor` of the data's mass (the controller flies the
/// design its own `mass_factor` chooses).
pub fn grid_on(cfg: &ControllerConfig, mass_factor: f64) -> Result<Vec<GridPoint>, MarginsError> {
    use rayon::prelude::*;
    let nodes: Vec<(f64, f64, f64)> = super::schedule::SCHEDULE_ALTITUDES_M
        .iter()
        .flat_map(|&h| {
            super::schedule::SCHEDULE_SPEEDS_MPS
                .iter()
                .flat_map(move |&v| GRID_XCG.iter().map(move |&x| (v, h, x)))
        })
        .collect();
    let per: Vec<Vec<GridPoint>> = nodes
        .par_iter()
        .map(|&(v, h, xcg)| {
            let mut factors = ReceiverPlant::NOMINAL;
            factors.mass_scale = mass_factor;
            let (plant, controller) = flown_on(cfg, xcg, &factors, v, h)?;
            Ok(GRID_LATENCY_STEPS
                .iter()
                .map(|&d| GridPoint {
                    speed_mps: v,
                    altitude_m: h,
                    xcg,
                    true_latency: d,
                    margins: FlownLoop {
                        plant: &plant,
                        controller: &controller,
                        true_latency: d,
                    }
                    .margins(),
                })
                .collect())
        })
        .collect::<Result<_, MarginsError>>()?;
    Ok(per.into_iter().flatten().collect())
}

/// The grid as a Markdown table: one row per point, each margin as `alpha` (phase margin
/// deg, gain margin dB), the loop-at-a-time figures per input, then the channels' and the
/// four inputs' together; a `*` marks a figure short of 6 dB / 45 deg.
pub fn table(grid: &[GridPoint]) -> String {
    use std::fmt::Write as _;
    let cell = |m: &DiskMargin| {
        format!(
            "{:.3} ({:.1}°, {:.1} dB){}",
            m.alpha,
            m.phase_margin_deg(),
            m.gain_margin_db(),
            if m.meets_6db_45deg() { "" } else { " *" }
        )
    };
    let mut out = String::from(
        "| V m/s | h m | cg | latency | elevator | throttle | aileron | rudder | lon (mu) | lat (mu) | all four (bound) | radius |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for p in grid {
        let m = &p.margins;
        let _ = writeln!(
            out,
            "| {} | {} | {:.2} | {} | {} | {} | {} | {} | {} | {} | {} | {:.4} |",
            p.speed_mps,
            p.altitude_m,
            p.xcg,
            p.true_latency,
            cell(&m.input[0]),
            cell(&m.input[1]),
            cell(&m.input[2]),
            cell(&m.input[3]),
            cell(&m.channel[0]),
            cell(&m.channel[1]),
            cell(&m.all),
            m.spectral_radius
        );
    }
    out
}

/// The worst of each figure at one schedule node over the true cgs and latencies.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodeWorst {
    /// Node airspeed, m/s.
    pub speed_mps: f64,
    /// Node altitude, m.
    pub altitude_m: f64,
    /// The smallest margin of each figure, [`FIGURES`] order, with its point's true cg and
    /// latency.
    pub worst: [(DiskMargin, f64, usize); 7],
}

/// The seven figures of a point: the four inputs loop at a time, the two channels, all four.
pub const FIGURES: [&str; 7] = [
    "elevator",
    "throttle",
    "aileron",
    "rudder",
    "lon (mu)",
    "lat (mu)",
    "all four (bound)",
];

impl Margins {
    /// The seven figures, [`FIGURES`] order.
    pub fn figures(&self) -> [DiskMargin; 7] {
        let [e, t, a, r] = self.input;
        [e, t, a, r, self.channel[0], self.channel[1], self.all]
    }
}

/// Each node's worst figures over the grid's true cgs and latencies, in the grid's order.
pub fn node_worst(grid: &[GridPoint]) -> Vec<NodeWorst> {
    let mut out: Vec<NodeWorst> = Vec::new();
    for p in grid {
        let f = p.margins.figures();
        let i = match out
            .iter()
            .position(|n| n.speed_mps == p.speed_mps && n.altitude_m == p.altitude_m)
        {
            Some(i) => i,
            None => {
                out.push(NodeWorst {
                    speed_mps: p.speed_mps,
                    altitude_m: p.altitude_m,
                    worst: core::array::from_fn(|k| (f[k], p.xcg, p.true_latency)),
                });
                continue;
            }
        };
        for (w, m) in out[i].worst.iter_mut().zip(f) {
            if m.alpha < w.0.alpha {
                *w = (m, p.xcg, p.true_latency);
            }
        }
    }
    out
}

/// [`node_worst`] as a Markdown table: each node's worst `alpha` per figure (phase margin
/// deg, gain margin dB; at true cg / latency); a `*` marks a figure short of 6 dB / 45 deg.
pub fn node_table(grid: &[GridPoint]) -> String {
    use std::fmt::Write as _;
    let mut out = String::from("| V m/s | h m |");
    for f in FIGURES {
        let _ = write!(out, " {f} |");
    }
    out.push_str("\n|---|---|---|---|---|---|---|---|---|\n");
    for n in node_worst(grid) {
        let _ = write!(out, "| {} | {} |", n.speed_mps, n.altitude_m);
        for (m, xcg, d) in n.worst {
            let _ = write!(
                out,
                " {:.3} ({:.1}°, {:.1} dB; {:.2}/{}){} |",
                m.alpha,
                m.phase_margin_deg(),
                m.gain_margin_db(),
                xcg,
                d,
                if m.meets_6db_45deg() { "" } else { " *" }
            );
        }
        out.push('\n');
    }
    out
}

/// The core's design at a schedule node (the node's own, bit for bit).
pub fn node_design(speed_mps: f64, altitude_m: f64) -> Result<DesignPoint, MarginsError> {
    design_at(FlightCondition {
        true_airspeed_mps: speed_mps as f32,
        altitude_m: altitude_m as f32,
    })
    .map_err(MarginsError::Schedule)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_disk_converts_to_the_stated_gain_and_phase() {
        let m = DiskMargin {
            alpha: ALPHA_45_DEG,
            frequency_radps: 1.0,
        };
        assert!((m.phase_margin_deg() - 45.0).abs() < 1e-9);
        assert!(
            (m.gain_margin_db() - 7.66).abs() < 0.01,
            "{}",
            m.gain_margin_db()
        );
        let six = DiskMargin {
            alpha: 2.0 / 3.0,
            frequency_radps: 1.0,
        };
        assert!((six.gain_margin_db() - 20.0 * 2f64.log10()).abs() < 1e-9);
        assert!(!six.meets_6db_45deg() && m.meets_6db_45deg());
    }

    #[test]
    fn a_scalar_loop_has_its_textbook_margin() {
        // L(z) = k / (z - 1) (an integrator, unity-feedback closed-loop pole at 1 - k):
        // S = (z - 1) / (z - 1 + k). One state, s' = s + w + u... built directly: the
        // closed loop s' = (1 - k) s + w, u = -k s, so S = 1 - k / (z - 1 + k).
        let k = 0.3;
        let mut m = LoopMatrices {
            a: DMatrix::from_element(1, 1, 1.0 - k),
            b_w: DMatrix::zeros(1, 4),
            b_r: DMatrix::zeros(1, 3),
            c_u: DMatrix::zeros(4, 1),
        };
        m.b_w[(0, 0)] = 1.0;
        m.c_u[(0, 0)] = -k;
        let got = margins_of(&m);
        // Brute force over a fine grid of the unit circle.
        let mut worst = 0.0f64;
        for i in 1..=200_000 {
            let th = PI * i as f64 / 200_000.0;
            let z = C64::from_polar(1.0, th);
            let s = C64::from(1.0) - C64::from(k) / (z - 1.0 + k);
            worst = worst.max((s - 0.5).norm());
        }
        assert!(
            (got.input[0].alpha - 1.0 / worst).abs() < 1e-6,
            "{} vs {}",
            got.input[0].alpha,
            1.0 / worst
        );
        // Inputs with no loop: S_ii = 1, |1 - 1/2| = 1/2, alpha = 2.
        assert!((got.input[3].alpha - 2.0).abs() < 1e-12);
    }

    #[test]
    fn mu_of_a_diagonal_matrix_is_its_largest_entry() {
        let m = [
            [C64::new(0.3, 0.1), C64::new(5.0, 0.0)],
            [C64::new(0.0, 0.0), C64::new(-0.2, 0.4)],
        ];
        // Triangular: mu for diagonal perturbations is the largest diagonal modulus; the
        // unscaled sigma_max is above 5.
        assert!(
            (mu_2(m) - C64::new(-0.2, 0.4).norm()).abs() < 1e-3,
            "{}",
            mu_2(m)
        );
        assert!(sigma_max_2(m) > 5.0);
    }
}
