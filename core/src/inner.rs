//! Inner loops: camera-velocity tracking by discrete LQR with integral action, per channel.
//!
//! Longitudinal: design state `[theta, V, alpha, q, P]`, outputs (camera down, camera forward
//! velocity), inputs (elevator, throttle). `P`, the engine power perturbation, is not
//! measured: [`EngineModel`] predicts it from the throttle commands actually sent, with the
//! same discrete model the design used. Lateral: `[psi, phi, beta, p, r]`, output camera
//! right velocity, inputs (aileron, rudder). (Paper eq. (25)-(35), with the input labels of
//! docs/paper.md, item 1, and the one lateral integrator of item 5.)
//!
//! Each channel computes, at step k,
//!
//! ```text
//! u[k]   = u_trim - K_x x[k] - K_a a[k] - K_q q[k]     (then saturated)
//! q[k+1] = q[k] + Ts (C x[k] - v_des[k])                (unless frozen by anti-windup)
//! ```
//!
//! which is exactly the augmented discrete plant the gains were synthesised for: the plant
//! discretised by zero-order hold at Ts, the integrator as this forward sum (docs/paper.md,
//! item 9). `a` are the surface actuators' deflections from trim, as the controller's own
//! model of its commands has them ([`crate::predictor`]): the refuelling design carries the
//! actuators' lag as states and feeds them back; the paper's does not (`K_a = 0`). `C = C_cg + C_lever(p_cam)`: the CG part is generated, the lever-arm part is
//! computed from the believed camera position ([`crate::kinematics`]).
//!
//! Engage: under the refuelling procedure the integrators are preloaded at the first engaged
//! step so that the law returns the trim inputs ([`Channel::preload`]): a bumpless transfer
//! from the Standby command. The paper's procedure starts them at zero.
//!
//! Anti-windup: conditional integration. An integrator is frozen in a step when any actuator
//! of its channel is saturated and that integrator's update would push the actuator further
//! into its limit. Integrators are also clamped to `+/- integrator_limit_m`.
//!
//! Invariant: for finite `x` and `v_des` the integrators stay finite and bounded.

use nalgebra::SVector;

use crate::num::clamp_sym;

/// Names of the longitudinal design states, in order.
pub const LON_STATES: [&str; 5] = [
    "theta_rad",
    "v_mps",
    "alpha_rad",
    "q_radps",
    "engine_power_pct",
];
/// Names of the longitudinal tracked outputs (camera velocity, tanker axes), in order.
pub const LON_OUTPUTS: [&str; 2] = ["cam_down_mps", "cam_fwd_mps"];
/// Names of the longitudinal inputs, in order.
pub const LON_INPUTS: [&str; 2] = ["elevator_rad", "throttle"];
/// Names of the lateral design states, in order.
pub const LAT_STATES: [&str; 5] = ["psi_rad", "phi_rad", "beta_rad", "p_radps", "r_radps"];
/// Names of the lateral tracked outputs, in order.
pub const LAT_OUTPUTS: [&str; 1] = ["cam_right_mps"];
/// Names of the lateral inputs, in order.
pub const LAT_INPUTS: [&str; 2] = ["aileron_rad", "rudder_rad"];

/// Generated design data of one channel (see [`crate::gains`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChannelGains<const NX: usize, const NY: usize, const NU: usize> {
    /// State-feedback gain `K_x`, one row per input.
    pub k_state: [[f32; NX]; NU],
    /// Gain `K_a` on the surface actuators' deflections (perturbations from trim), one row
    /// per input, column `j` input `j`'s actuator; zero where the design does not carry
    /// that actuator (the paper's design carries none; the throttle has none: the engine
    /// is a design state).
    pub k_actuator: [[f32; NU]; NU],
    /// Integral gain `K_q`, one row per input.
    pub k_integral: [[f32; NY]; NU],
    /// Camera-velocity output matrix from CG motion alone, one row per output.
    pub c_cg: [[f32; NX]; NY],
}

/// The trim point the design is linearised about.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrimPoint {
    /// True airspeed = ground speed = tanker speed, m/s.
    pub speed_mps: f32,
    /// Altitude, m.
    pub altitude_m: f32,
    /// Angle of attack, rad.
    pub alpha_rad: f32,
    /// Pitch angle, rad (equal to alpha in level flight).
    pub theta_rad: f32,
    /// Throttle, 0..1.
    pub throttle: f32,
    /// Elevator, rad.
    pub elevator_rad: f32,
    /// Aileron, rad.
    pub aileron_rad: f32,
    /// Rudder, rad.
    pub rudder_rad: f32,
}

impl TrimPoint {
    /// The trim command `[elevator, throttle, aileron, rudder]`.
    pub fn command(&self) -> [f32; 4] {
        [
            self.elevator_rad,
            self.throttle,
            self.aileron_rad,
            self.rudder_rad,
        ]
    }
}

/// Discrete first-order engine model of the design: `P[k+1] = pole P[k] + gain dthrottle[k]`
/// with `P` the power perturbation (percent) and `dthrottle` the throttle perturbation from
/// trim; the engine row of the zero-order-hold discretised design plant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EngineModel {
    /// Discrete pole, `exp(-Ts / tau)`.
    pub pole: f32,
    /// Power per unit throttle over one step, percent.
    pub gain_pct: f32,
}

/// The controller's running estimate of the engine power perturbation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EngineEstimate {
    model: EngineModel,
    power_pct: f32,
}

impl EngineEstimate {
    /// An estimate at trim power.
    pub fn new(model: EngineModel) -> Self {
        Self {
            model,
            power_pct: 0.0,
        }
    }

    /// Takes another model (the gain schedule's), keeping the power estimate.
    pub fn set_model(&mut self, model: EngineModel) {
        self.model = model;
    }

    /// Power perturbation, percent.
    pub fn power_pct(&self) -> f32 {
        self.power_pct
    }

    /// Advances by one step for the throttle perturbation actually commanded this step.
    pub fn advance(&mut self, throttle_perturbation: f32) {
        self.power_pct =
            self.model.pole * self.power_pct + self.model.gain_pct * throttle_perturbation;
    }

    /// Back to trim power.
    pub fn reset(&mut self) {
        self.power_pct = 0.0;
    }
}

/// One channel's controller state and matrices.
///
/// Plain arrays: the products are written out, so that the step's arithmetic is exactly
/// the design's and nothing else (no generic matrix machinery, no bounds checks). Each
/// product sums left to right starting from its first term, as nalgebra's matrix-vector
/// product does, so the results are those of the nalgebra formulation bit for bit.
#[derive(Debug, Clone, PartialEq)]
pub struct Channel<const NX: usize, const NY: usize, const NU: usize> {
    k_x: [[f32; NX]; NU],
    k_a: [[f32; NU]; NU],
    k_q: [[f32; NY]; NU],
    c: [[f32; NX]; NY],
    u_trim: [f32; NU],
    q: SVector<f32, NY>,
}

/// `row . x`, summed left to right from `row[0] x[0]` (nalgebra's `gemv` order). `N >= 1`.
#[inline(always)]
pub(crate) fn dot<const N: usize>(row: &[f32; N], x: &[f32; N]) -> f32 {
    let mut s = row[0] * x[0];
    for j in 1..N {
        s += row[j] * x[j];
    }
    s
}

impl<const NX: usize, const NY: usize, const NU: usize> Channel<NX, NY, NU> {
    /// Builds a channel from its generated gains, the lever-arm rows for the believed camera
    /// position and the trim inputs.
    pub fn new(g: &ChannelGains<NX, NY, NU>, c_lever: &[[f32; NX]; NY], u_trim: [f32; NU]) -> Self {
        Self {
            k_x: g.k_state,
            k_a: g.k_actuator,
            k_q: g.k_integral,
            c: core::array::from_fn(|r| core::array::from_fn(|c| g.c_cg[r][c] + c_lever[r][c])),
            u_trim,
            q: SVector::zeros(),
        }
    }

    /// Takes another design (the gain schedule's at a new flight condition), keeping the
    /// integrators: they hold the position error, which the design does not change.
    pub fn set_design(
        &mut self,
        g: &ChannelGains<NX, NY, NU>,
        c_lever: &[[f32; NX]; NY],
        u_trim: [f32; NU],
    ) {
        let q = self.q;
        *self = Self::new(g, c_lever, u_trim);
        self.q = q;
    }

    /// Camera velocity relative to the tanker predicted from the design state, `C x`.
    #[inline(always)]
    pub fn output(&self, x: &[f32; NX]) -> [f32; NY] {
        core::array::from_fn(|i| dot(&self.c[i], x))
    }

    /// Integrator states (integral of the velocity error: a position error), m.
    pub fn integrators(&self) -> &SVector<f32, NY> {
        &self.q
    }

    /// Zeroes the integrators.
    pub fn reset(&mut self) {
        self.q = SVector::zeros();
    }

    /// The control law: absolute requested inputs for state `x`, the actuators' deflections
    /// `a` (perturbations from trim, per input) and the current integrators,
    /// `u_trim - (K_x x + K_a a + K_q q)`. With `K_a = 0` (a design without actuator states)
    /// the result is that of `u_trim - (K_x x + K_q q)` bit for bit: the added term is a
    /// signed zero.
    #[inline(always)]
    pub fn control(&self, x: &[f32; NX], a: &[f32; NU]) -> [f32; NU] {
        let q: [f32; NY] = self.q.into();
        core::array::from_fn(|i| {
            self.u_trim[i] - (dot(&self.k_x[i], x) + dot(&self.k_a[i], a) + dot(&self.k_q[i], &q))
        })
    }

    /// Advances the integrators by one step given the output `y = C x` (computed once per step:
    /// the mode logic needs it too), the desired velocity and the saturation side (`+1`, `-1`,
    /// `0`) of each input this step. Returns true when any integrator froze. `limit_m` must
    /// not be NaN.
    #[inline(always)]
    pub fn integrate(
        &mut self,
        y: &[f32; NY],
        v_des: &[f32; NY],
        sat_side: &[i8; NU],
        ts_s: f32,
        limit_m: f32,
    ) -> bool {
        let mut frozen = false;
        let any_saturated = sat_side.iter().any(|&s| s != 0);
        for i in 0..NY {
            let dq = (y[i] - v_des[i]) * ts_s;
            // The update changes input j by -K_q[j, i] dq; freeze if that deepens a limit.
            // (No saturated input: nothing to deepen, `0 * p > 0` is false for every `p`.)
            let mut deepens = false;
            if any_saturated {
                for (side, k) in sat_side.iter().zip(&self.k_q) {
                    deepens |= f32::from(*side) * (-k[i] * dq) > 0.0;
                }
            }
            if deepens {
                frozen = true;
            } else {
                self.q[i] = clamp_sym(self.q[i] + dq, limit_m);
            }
        }
        frozen
    }
}

/// `-(K_x x + K_a a)`: what the integrators' term `K_q q` must be for the law to return the
/// trim inputs (a bumpless engage).
#[inline(always)]
fn engage_residual<const NX: usize, const NY: usize, const NU: usize>(
    ch: &Channel<NX, NY, NU>,
    x: &[f32; NX],
    a: &[f32; NU],
) -> [f32; NU] {
    core::array::from_fn(|i| -(dot(&ch.k_x[i], x) + dot(&ch.k_a[i], a)))
}

impl<const NX: usize> Channel<NX, 2, 2> {
    /// Bumpless engage: sets the integrators so that [`Channel::control`] of `x` and `a`
    /// returns the trim inputs, `K_q q = -(K_x x + K_a a)` (solved exactly: two integrators,
    /// two inputs), each clamped to `+/- limit_m`. The receiver engages trimmed as it is, not
    /// as the design's airframe would be (another mass or cg, the navigation's attitude
    /// error): the state's offset from the design trim is then no error to correct in one
    /// step, and the integrators start where their steady state will have them. A singular
    /// `K_q` (or a non-finite result) leaves the integrators at zero.
    pub fn preload(&mut self, x: &[f32; NX], a: &[f32; 2], limit_m: f32) {
        let d = engage_residual(self, x, a);
        let k = &self.k_q;
        let det = k[0][0] * k[1][1] - k[0][1] * k[1][0];
        let q = [
            (d[0] * k[1][1] - k[0][1] * d[1]) / det,
            (k[0][0] * d[1] - k[1][0] * d[0]) / det,
        ];
        let finite = q.iter().all(|v| v.is_finite());
        self.q = SVector::from(q.map(|v| if finite { clamp_sym(v, limit_m) } else { 0.0 }));
    }
}

impl<const NX: usize> Channel<NX, 1, 2> {
    /// Bumpless engage with one integrator and two inputs: the integrator that brings the
    /// law's two inputs nearest the trim (least squares, `q = K_q^T d / K_q^T K_q` with
    /// `d = -(K_x x + K_a a)`), clamped to `+/- limit_m`; zero if `K_q` is zero or the
    /// result not finite. See the two-integrator [`Channel::preload`].
    pub fn preload(&mut self, x: &[f32; NX], a: &[f32; 2], limit_m: f32) {
        let d = engage_residual(self, x, a);
        let (k0, k1) = (self.k_q[0][0], self.k_q[1][0]);
        let q = (k0 * d[0] + k1 * d[1]) / (k0 * k0 + k1 * k1);
        self.q = SVector::from([if q.is_finite() {
            clamp_sym(q, limit_m)
        } else {
            0.0
        }]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v1(v: f32) -> [f32; 1] {
        [v]
    }

    #[test]
    fn engine_estimate_follows_its_discrete_model() {
        let mut e = EngineEstimate::new(EngineModel {
            pole: 0.98,
            gain_pct: 1.3,
        });
        e.advance(0.1);
        assert!((e.power_pct() - 0.13).abs() < 1e-7);
        e.advance(0.0);
        assert!((e.power_pct() - 0.98 * 0.13).abs() < 1e-7);
        e.reset();
        assert_eq!(e.power_pct(), 0.0);
    }

    #[test]
    fn a_new_engine_model_keeps_the_power_and_runs_on_from_it() {
        // The gain schedule's follow-up at a new flight condition: the estimate keeps its
        // power and the next step is the new model's, p' = pole p + gain u.
        let mut e = EngineEstimate::new(EngineModel {
            pole: 0.5,
            gain_pct: 2.0,
        });
        e.advance(1.0);
        assert_eq!(e.power_pct(), 2.0);
        e.set_model(EngineModel {
            pole: 0.9,
            gain_pct: 10.0,
        });
        assert_eq!(e.power_pct(), 2.0);
        e.advance(0.5);
        assert!((e.power_pct() - (0.9 * 2.0 + 10.0 * 0.5)).abs() < 1e-6);
    }

    fn channel() -> Channel<1, 1, 1> {
        let g = ChannelGains {
            k_state: [[2.0]],
            k_actuator: [[0.0]],
            k_integral: [[0.5]],
            c_cg: [[1.0]],
        };
        Channel::new(&g, &[[0.0]], [0.1])
    }

    #[test]
    fn the_actuators_deflections_are_fed_back_through_their_gain() {
        let g = ChannelGains {
            k_state: [[2.0]],
            k_actuator: [[3.0]],
            k_integral: [[0.5]],
            c_cg: [[1.0]],
        };
        let ch = Channel::new(&g, &[[0.0]], [0.1]);
        let x = v1(0.2);
        assert!((ch.control(&x, &[0.05])[0] - (0.1 - 2.0 * 0.2 - 3.0 * 0.05)).abs() < 1e-7);
        // Without actuator gains the deflection changes nothing, to the bit.
        assert_eq!(
            channel().control(&x, &[0.05])[0].to_bits(),
            channel().control(&x, &[0.0])[0].to_bits()
        );
    }

    #[test]
    fn law_and_integrator_follow_the_design_equations() {
        let mut ch = channel();
        let x = v1(0.2);
        assert!((ch.control(&x, &[0.0])[0] - (0.1 - 2.0 * 0.2)).abs() < 1e-7);
        ch.integrate(&ch.output(&x), &v1(1.0), &[0], 0.02, 10.0);
        assert!((ch.integrators()[0] - 0.02 * (0.2 - 1.0)).abs() < 1e-7);
        let q = ch.integrators()[0];
        assert!((ch.control(&x, &[0.0])[0] - (0.1 - 2.0 * 0.2 - 0.5 * q)).abs() < 1e-7);
    }

    #[test]
    fn anti_windup_freezes_only_when_the_update_deepens_saturation() {
        let mut ch = channel();
        let x = v1(0.0);
        // Error -1 per step: dq < 0, so u = -K_q q grows: deepens an upper limit.
        assert!(ch.integrate(&ch.output(&x), &v1(1.0), &[1], 0.02, 10.0));
        assert_eq!(ch.integrators()[0], 0.0);
        // The same update against a lower limit unwinds it: allowed.
        assert!(!ch.integrate(&ch.output(&x), &v1(1.0), &[-1], 0.02, 10.0));
        assert!(ch.integrators()[0] < 0.0);
    }

    #[test]
    fn a_free_input_or_a_zero_update_never_freezes_an_integrator() {
        // Two inputs on one integrator, K_q = 0.5 each. The update dq changes input j by
        // -K_q[j] dq: it deepens a limit only when that change points into it (the module
        // doc's anti-windup), so an input inside its limits never freezes, and neither does an
        // update of zero.
        let g = ChannelGains {
            k_state: [[0.0], [0.0]],
            k_actuator: [[0.0, 0.0], [0.0, 0.0]],
            k_integral: [[0.5], [0.5]],
            c_cg: [[1.0]],
        };
        let mut ch = Channel::<1, 1, 2>::new(&g, &[[0.0]], [0.0, 0.0]);
        // y = v_des: dq = 0 with input 0 at its lower limit: nothing deepens.
        assert!(!ch.integrate(&v1(1.0), &v1(1.0), &[-1, 0], 0.02, 10.0));
        assert_eq!(ch.integrators()[0], 0.0);
        // y - v_des = 1: dq = 0.02 moves input 0 down, away from its upper limit; input 1 is
        // free. It integrates.
        assert!(!ch.integrate(&v1(1.0), &v1(0.0), &[1, 0], 0.02, 10.0));
        assert!((ch.integrators()[0] - 0.02).abs() < 1e-7);
        // The same update with input 0 at its lower limit deepens it: frozen.
        assert!(ch.integrate(&v1(1.0), &v1(0.0), &[-1, 0], 0.02, 10.0));
        assert!((ch.integrators()[0] - 0.02).abs() < 1e-7);
    }

    fn two_by_two() -> Channel<2, 2, 2> {
        let g = ChannelGains {
            k_state: [[-45.0, 39.0], [15.0, -16.0]],
            k_actuator: [[0.5, 0.0], [0.002, 0.0]],
            k_integral: [[0.9, 0.066], [-0.18, 0.97]],
            c_cg: [[1.0, 0.0], [0.0, 1.0]],
        };
        Channel::new(&g, &[[0.0; 2]; 2], [-0.01, 0.16])
    }

    #[test]
    fn a_preloaded_channel_commands_the_trim_at_engage() {
        // A receiver trimmed 1 deg below the design's angle of attack and pitch, its
        // elevator 0.02 rad off: without the preload the law kicks the elevator by 0.06 rad.
        let (x, a) = ([-0.0175, -0.0175], [0.02, 0.0]);
        let mut ch = two_by_two();
        let kick = ch.control(&x, &a);
        assert!((kick[0] - (-0.01)).abs() > 0.05, "{kick:?}");
        ch.preload(&x, &a, 20.0);
        let u = ch.control(&x, &a);
        assert!(
            (u[0] - (-0.01)).abs() < 1e-6 && (u[1] - 0.16).abs() < 1e-6,
            "{u:?}"
        );
        // The integrators are what the law needs, within their clamp.
        ch.preload(&x, &a, 1e-3);
        assert!(ch.integrators().iter().all(|q| q.abs() <= 1e-3));
        assert!(ch.integrators().iter().any(|q| q.abs() == 1e-3));
    }

    #[test]
    fn a_one_integrator_preload_is_the_least_squares_one() {
        let g = ChannelGains {
            k_state: [[2.0], [1.0]],
            k_actuator: [[0.0, 0.0], [0.0, 0.0]],
            k_integral: [[0.5], [-1.0]],
            c_cg: [[1.0]],
        };
        let mut ch = Channel::<1, 1, 2>::new(&g, &[[0.0]], [0.0, 0.0]);
        ch.preload(&[0.3], &[0.0, 0.0], 20.0);
        // d = [-0.6, -0.3]; q = (0.5 (-0.6) + (-1) (-0.3)) / 1.25 = 0.
        assert_eq!(ch.integrators()[0], 0.0);
        ch.preload(&[0.3], &[0.1, 0.0], 20.0);
        assert_eq!(
            ch.integrators()[0],
            0.0,
            "no actuator gain: the deflection is ignored"
        );
        let g2 = ChannelGains {
            k_integral: [[0.5], [1.0]],
            ..g
        };
        let mut ch = Channel::<1, 1, 2>::new(&g2, &[[0.0]], [0.0, 0.0]);
        ch.preload(&[0.3], &[0.0, 0.0], 20.0);
        // q = (0.5 (-0.6) + 1 (-0.3)) / 1.25 = -0.48: the residual is orthogonal to K_q.
        let q = ch.integrators()[0];
        assert!((q + 0.48).abs() < 1e-6, "{q}");
        let u = ch.control(&[0.3], &[0.0, 0.0]);
        assert!((0.5 * u[0] + 1.0 * u[1]).abs() < 1e-6, "{u:?}");
    }

    #[test]
    fn a_singular_or_non_finite_preload_leaves_the_integrators_at_zero() {
        let g = ChannelGains {
            k_state: [[1.0], [1.0]],
            k_actuator: [[0.0, 0.0], [0.0, 0.0]],
            k_integral: [[1.0, 2.0], [2.0, 4.0]],
            c_cg: [[1.0], [1.0]],
        };
        let mut ch = Channel::<1, 2, 2>::new(&g, &[[0.0], [0.0]], [0.0, 0.0]);
        ch.preload(&[0.3], &[0.0, 0.0], 20.0);
        assert_eq!(*ch.integrators(), SVector::<f32, 2>::zeros());
        let mut ch = two_by_two();
        ch.preload(&[f32::NAN, 0.0], &[0.0, 0.0], 20.0);
        assert_eq!(*ch.integrators(), SVector::<f32, 2>::zeros());
    }

    #[test]
    fn integrators_are_clamped() {
        let mut ch = channel();
        for _ in 0..1000 {
            ch.integrate(&ch.output(&v1(100.0)), &v1(0.0), &[0], 0.02, 5.0);
        }
        assert_eq!(ch.integrators()[0], 5.0);
    }
}
