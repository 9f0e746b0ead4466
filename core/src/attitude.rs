//! Attitude-command inner loop: velocity tracking through an autopilot's attitude loops.
//!
//! Where the aircraft's own autopilot (ArduPlane, PX4) keeps the surfaces and accepts only
//! attitude and throttle setpoints from an outside computer, this loop replaces the surface
//! LQR ([`crate::inner`]): the outer loop and the whole procedure above it are unchanged,
//! and the desired velocity is tracked by commanding bank, pitch and throttle.
//!
//! Design model, per channel, the aircraft *as closed by the autopilot*
//! (`docs/conventions.md`, "Attitude-command inner loop"):
//!
//! ```text
//! down:     d/dt theta = (theta_sp - theta) / tau_pitch      (the autopilot's pitch loop)
//!           d/dt w     = -(w + V theta) / T_path              (flight path lags pitch)
//! right:    d/dt phi   = (phi_sp - phi) / tau_roll            (the autopilot's roll loop)
//!           d/dt v     = g phi                                (a coordinated turn)
//! forward:  d/dt a     = (k_thr dthrottle - a) / tau_engine   (thrust acceleration)
//!           d/dt u     = a
//! ```
//!
//! each with the integral of its velocity error, and full state feedback placing the three
//! closed-loop poles at `-omega` and `omega (-zeta +/- j sqrt(1 - zeta^2))` (closed form,
//! [`ChannelDesign`]). Angles are perturbations from the scheduled trim; the setpoints sent
//! are absolute (pitch and bank from the horizon, heading from the tanker's track).
//!
//! Invariant: every setpoint returned is finite and inside the configured limits; the
//! integrators are finite and bounded by `integrator_limit_m`.

use serde::{Deserialize, Serialize};

/// Which inner loop flies the desired velocity (`"surfaces"` or `"attitude"` in text formats).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[serde(rename_all = "lowercase")]
pub enum InnerLoop {
    /// The LQR inner loops command elevator, throttle, aileron and rudder ([`crate::inner`]).
    #[default]
    Surfaces,
    /// Attitude and throttle setpoints for the aircraft's autopilot (this module).
    Attitude,
}

/// Attitude and throttle setpoints for an autopilot's attitude loops (what MAVLink's
/// `SET_ATTITUDE_TARGET` carries, its body rates ignored).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AttitudeSetpoint {
    /// Bank angle, right wing down positive, rad (absolute).
    pub roll_rad: f32,
    /// Pitch angle, nose up positive, rad (absolute, from the horizon).
    pub pitch_rad: f32,
    /// Heading relative to the tanker's track, right positive, rad.
    pub yaw_rad: f32,
    /// Throttle lever, 0 (idle) .. 1 (full), as the surface loop's.
    pub throttle: f32,
}

/// Standard gravity, m/s^2 (the coordinated turn's lateral acceleration per radian of bank).
pub const GRAVITY_MPS2: f32 = 9.806_65;

/// The attitude-command loop's settings: the autopilot as the design sees it, the
/// closed-loop bandwidths asked of each channel, and the setpoints' limits.
///
/// Defaults: the autopilot's attitude time constants are ArduPlane's `PTCH2SRV_TCONST` and
/// `RLL2SRV_TCONST` defaults (0.5 s; PX4's `FW_P_TC` and `FW_R_TC` default to 0.4 s); the
/// airframe's lags and the throttle's authority are the F-16 design model's at the default
/// flight condition (`docs/conventions.md`, "Attitude-command inner loop", where each is read
/// from the discrete design plant); the bandwidths are our choice (a decade below the
/// attitude loops' corner would be too slow to follow the drogue; a third of it, stated
/// there); the limits keep the receiver within gentle formation manoeuvres.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AttitudeLoopConfig {
    /// Time constant of the autopilot's pitch-angle loop, s.
    pub pitch_time_constant_s: f32,
    /// Time constant of the autopilot's roll-angle loop, s.
    pub roll_time_constant_s: f32,
    /// Lag of the flight path behind the pitch attitude, `V / Z_alpha`, s.
    pub flight_path_lag_s: f32,
    /// Time constant of the engine's thrust, s.
    pub engine_time_constant_s: f32,
    /// Steady longitudinal acceleration per unit of throttle, m/s^2.
    pub throttle_accel_mps2: f32,
    /// Closed-loop natural frequency of the vertical velocity channel, rad/s.
    pub vertical_bandwidth_radps: f32,
    /// Of the lateral channel, rad/s.
    pub lateral_bandwidth_radps: f32,
    /// Of the forward channel, rad/s.
    pub forward_bandwidth_radps: f32,
    /// Damping ratio of each channel's complex closed-loop pair.
    pub damping: f32,
    /// Largest bank setpoint, rad.
    pub max_bank_rad: f32,
    /// Largest pitch setpoint's distance from the trim pitch, rad.
    pub max_pitch_offset_rad: f32,
}

impl Default for AttitudeLoopConfig {
    fn default() -> Self {
        Self {
            pitch_time_constant_s: 0.5,
            roll_time_constant_s: 0.5,
            flight_path_lag_s: 1.68,
            engine_time_constant_s: 1.0,
            throttle_accel_mps2: 5.65,
            vertical_bandwidth_radps: 2.2,
            lateral_bandwidth_radps: 1.6,
            forward_bandwidth_radps: 1.4,
            damping: 0.7,
            max_bank_rad: 20.0_f32.to_radians(),
            max_pitch_offset_rad: 10.0_f32.to_radians(),
        }
    }
}

/// One channel's full-state feedback on `[integral of the velocity error, velocity error,
/// attitude (or thrust) perturbation]`: `du = k_integral eta + k_error e + k_state x`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ChannelDesign {
    /// Gain on the integral of the velocity error (a position error), per m.
    pub k_integral: f32,
    /// Gain on the velocity error, per m/s.
    pub k_error: f32,
    /// Gain on the channel's own state (attitude, rad per rad; or thrust acceleration, per
    /// m/s^2).
    pub k_state: f32,
}

/// The coefficients `[c2, c1, c0]` of `(s + w)(s^2 + 2 zeta w s + w^2)`.
fn characteristic(omega: f32, zeta: f32) -> [f32; 3] {
    let (w, z) = (omega, zeta);
    [w + 2.0 * z * w, w * w + 2.0 * z * w * w, w * w * w]
}

impl ChannelDesign {
    /// Vertical: `d theta = (u - theta) / tau`, `d w = -(w + V theta) / T` (`w` down), with
    /// `u = a eta + b w + c theta`, whose characteristic polynomial is
    /// `s^3 + (1/T + (1 - c)/tau) s^2 + ((1 - c) + b V)/(T tau) s + a V / (T tau)`.
    pub fn vertical(cfg: &AttitudeLoopConfig, speed_mps: f32) -> Self {
        let [c2, c1, c0] = characteristic(cfg.vertical_bandwidth_radps, cfg.damping);
        let (tau, t) = (cfg.pitch_time_constant_s, cfg.flight_path_lag_s);
        let c = 1.0 - tau * (c2 - 1.0 / t);
        Self {
            k_integral: c0 * t * tau / speed_mps,
            k_error: (t * tau * c1 - (1.0 - c)) / speed_mps,
            k_state: c,
        }
    }

    /// Lateral: `d phi = (u - phi) / tau`, `d v = g phi` (`v` right), characteristic
    /// polynomial `s^3 + (1 - c)/tau s^2 - g b / tau s - g a / tau`.
    pub fn lateral(cfg: &AttitudeLoopConfig) -> Self {
        let [c2, c1, c0] = characteristic(cfg.lateral_bandwidth_radps, cfg.damping);
        let tau = cfg.roll_time_constant_s;
        Self {
            k_integral: -c0 * tau / GRAVITY_MPS2,
            k_error: -c1 * tau / GRAVITY_MPS2,
            k_state: 1.0 - tau * c2,
        }
    }

    /// Forward: `d a = (k u - a) / tau`, `d v = a` (`v` forward, `u` the throttle's
    /// perturbation), characteristic polynomial `s^3 + (1 - k c)/tau s^2 - k b / tau s -
    /// k a / tau`.
    pub fn forward(cfg: &AttitudeLoopConfig) -> Self {
        let [c2, c1, c0] = characteristic(cfg.forward_bandwidth_radps, cfg.damping);
        let (tau, k) = (cfg.engine_time_constant_s, cfg.throttle_accel_mps2);
        Self {
            k_integral: -c0 * tau / k,
            k_error: -c1 * tau / k,
            k_state: (1.0 - tau * c2) / k,
        }
    }

    /// The law's perturbation for integral `eta`, error `e` and state `x`.
    #[inline(always)]
    fn law(&self, eta: f32, e: f32, x: f32) -> f32 {
        self.k_integral * eta + self.k_error * e + self.k_state * x
    }
}

/// The three channels' designs, in the order `[down, forward, right]`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AttitudeDesign {
    /// Down: pitch.
    pub down: ChannelDesign,
    /// Forward: throttle.
    pub forward: ChannelDesign,
    /// Right: bank.
    pub right: ChannelDesign,
    /// `exp(-Ts / tau_engine)`: the thrust model's discrete pole.
    engine_pole: f32,
}

impl AttitudeDesign {
    /// The design for the configuration at true airspeed `speed_mps` and period `ts_s`.
    pub fn new(cfg: &AttitudeLoopConfig, speed_mps: f32, ts_s: f32) -> Self {
        Self {
            down: ChannelDesign::vertical(cfg, speed_mps),
            forward: ChannelDesign::forward(cfg),
            right: ChannelDesign::lateral(cfg),
            engine_pole: libm::expf(-ts_s / cfg.engine_time_constant_s),
        }
    }
}

/// What the loop reads each step: the tracked velocities, their desired values and the
/// attitude, each a perturbation from the scheduled trim where it is an angle.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AttitudeInputs {
    /// Tracked velocity `[down, forward, right]` relative to the tanker, m/s.
    pub velocity_mps: [f32; 3],
    /// Desired velocity, same order, m/s.
    pub desired_mps: [f32; 3],
    /// Pitch from the trim pitch, rad.
    pub theta_rad: f32,
    /// Bank, rad.
    pub phi_rad: f32,
    /// Heading relative to the tanker's track, rad.
    pub psi_rad: f32,
}

/// Which setpoints hit a limit in a step, `[pitch, throttle, bank]`: `+1`, `-1` or `0`.
pub type SetpointSaturation = [i8; 3];

/// What one step of the loop gives: the setpoint and what it did to get it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AttitudeStep {
    /// The saturated setpoint.
    pub setpoint: AttitudeSetpoint,
    /// Which setpoints hit a limit.
    pub side: SetpointSaturation,
    /// Which integrators `[down, forward, right]` were frozen (their update would have
    /// pushed a limited setpoint further).
    pub frozen: [bool; 3],
    /// The law's result was not finite (the trim's setpoint flown instead).
    pub non_finite: bool,
}

/// The loop's state: three integrators and the thrust model.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AttitudeLoop {
    /// Integrals of the velocity errors `[down, forward, right]`, m.
    eta_m: [f32; 3],
    /// The thrust acceleration the throttle commanded so far has built up, m/s^2.
    thrust_accel_mps2: f32,
}

/// `x` clamped to `[lo, hi]` and the side it was clamped on; a value that is not finite is
/// `fallback` (inside the limits), side 0, as the surface loops' saturation has it.
#[inline(always)]
fn limit(x: f32, lo: f32, hi: f32, fallback: f32) -> (f32, i8) {
    if !x.is_finite() {
        (fallback, 0)
    } else if x > hi {
        (hi, 1)
    } else if x < lo {
        (lo, -1)
    } else {
        (x, 0)
    }
}

impl AttitudeLoop {
    /// Integrators `[down, forward, right]`, m.
    pub fn integrators_m(&self) -> [f32; 3] {
        self.eta_m
    }

    /// Back to zero integrators and trim thrust.
    pub fn reset(&mut self) {
        *self = Self::default();
    }

    /// The perturbations `[pitch, throttle, bank]` the law asks for.
    #[inline(always)]
    fn law(&self, d: &AttitudeDesign, i: &AttitudeInputs) -> [f32; 3] {
        let e = error(i);
        [
            d.down.law(self.eta_m[0], e[0], i.theta_rad),
            d.forward.law(self.eta_m[1], e[1], self.thrust_accel_mps2),
            d.right.law(self.eta_m[2], e[2], i.phi_rad),
        ]
    }

    /// Bumpless engage: the integrators that make the law return the receiver's present
    /// pitch and bank and the trim throttle, each clamped to `+/- limit_m`.
    pub fn preload(&mut self, d: &AttitudeDesign, i: &AttitudeInputs, limit_m: f32) {
        self.eta_m = [0.0; 3];
        let without = self.law(d, i);
        let want = [i.theta_rad, 0.0, i.phi_rad];
        let k = [d.down.k_integral, d.forward.k_integral, d.right.k_integral];
        for c in 0..3 {
            let eta = (want[c] - without[c]) / k[c];
            self.eta_m[c] = if eta.is_finite() {
                crate::num::clamp_sym(eta, limit_m)
            } else {
                0.0
            };
        }
    }

    /// One step: the saturated setpoint for the scheduled trim `(trim_pitch_rad,
    /// trim_throttle)` and the throttle's limits, then the integrators advanced (each frozen
    /// while its setpoint is saturated and the update would push it further) and the thrust
    /// model. Returns the setpoint, which setpoints saturated, which integrators froze, and
    /// whether the law's result was not finite (the trim's setpoint then, as the surface
    /// loops' fallback).
    #[allow(clippy::too_many_arguments)]
    pub fn step(
        &mut self,
        d: &AttitudeDesign,
        cfg: &AttitudeLoopConfig,
        i: &AttitudeInputs,
        trim: (f32, f32),
        throttle_limits: (f32, f32),
        ts_s: f32,
        limit_m: f32,
        integrate: bool,
    ) -> AttitudeStep {
        let [dp, dt, db] = self.law(d, i);
        // A NaN (not reached with a validated navigation sample: defence in depth) is the
        // trim's setpoint, flagged.
        let non_finite = !(dp.is_finite() && dt.is_finite() && db.is_finite());
        let (pitch, sp) = limit(dp, -cfg.max_pitch_offset_rad, cfg.max_pitch_offset_rad, 0.0);
        let (throttle, st) = limit(trim.1 + dt, throttle_limits.0, throttle_limits.1, trim.1);
        let (bank, sb) = limit(db, -cfg.max_bank_rad, cfg.max_bank_rad, 0.0);
        let side = [sp, st, sb];
        let mut frozen = [false; 3];
        if integrate {
            let e = error(i);
            let k = [d.down.k_integral, d.forward.k_integral, d.right.k_integral];
            for c in 0..3 {
                let de = e[c] * ts_s;
                frozen[c] = f32::from(side[c]) * k[c] * de > 0.0;
                if de.is_finite() && !frozen[c] {
                    self.eta_m[c] = crate::num::clamp_sym(self.eta_m[c] + de, limit_m);
                }
            }
        }
        // The thrust model follows the throttle actually sent.
        let p = d.engine_pole;
        self.thrust_accel_mps2 =
            p * self.thrust_accel_mps2 + (1.0 - p) * cfg.throttle_accel_mps2 * (throttle - trim.1);
        let setpoint = AttitudeSetpoint {
            roll_rad: bank,
            pitch_rad: trim.0 + pitch,
            yaw_rad: i.psi_rad,
            throttle,
        };
        AttitudeStep {
            setpoint,
            side,
            frozen,
            non_finite,
        }
    }
}

/// The velocity errors `[down, forward, right]`, tracked minus desired, m/s.
#[inline(always)]
fn error(i: &AttitudeInputs) -> [f32; 3] {
    core::array::from_fn(|c| i.velocity_mps[c] - i.desired_mps[c])
}

/// What the controller commands in a step: the surfaces and throttle itself, or attitude
/// and throttle setpoints to the autopilot (as configured: [`InnerLoop`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Command {
    /// Saturated absolute surface and throttle commands ([`InnerLoop::Surfaces`]).
    Surfaces(crate::actuator::ActuatorCommand),
    /// Saturated attitude and throttle setpoints ([`InnerLoop::Attitude`]).
    Attitude(AttitudeSetpoint),
}

impl Default for Command {
    fn default() -> Self {
        Self::Surfaces(crate::actuator::ActuatorCommand::default())
    }
}

impl Command {
    /// The surface commands, when the controller flies the surfaces.
    pub fn surfaces(&self) -> Option<&crate::actuator::ActuatorCommand> {
        match self {
            Self::Surfaces(c) => Some(c),
            Self::Attitude(_) => None,
        }
    }

    /// The attitude setpoint, when the controller flies through the autopilot.
    pub fn attitude(&self) -> Option<&AttitudeSetpoint> {
        match self {
            Self::Surfaces(_) => None,
            Self::Attitude(a) => Some(a),
        }
    }

    /// The four values in channel order: the surfaces' `[elevator, throttle, aileron,
    /// rudder]`, or the setpoints' `[pitch, throttle, roll, yaw]` (each attitude in the slot
    /// of the surface that mainly flies it).
    pub fn as_array(&self) -> [f32; 4] {
        match self {
            Self::Surfaces(c) => c.as_array(),
            Self::Attitude(a) => [a.pitch_rad, a.throttle, a.roll_rad, a.yaw_rad],
        }
    }

    /// The throttle commanded, either way, 0..1.
    pub fn throttle(&self) -> f32 {
        match self {
            Self::Surfaces(c) => c.throttle,
            Self::Attitude(a) => a.throttle,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closed loop's matrix of one channel's design model, state `[eta, e, x]` (its
    /// velocity error integral, the error and its attitude or thrust), law `u = k . state`.
    fn closed_loop(a: [[f32; 3]; 3], b: [f32; 3], k: &ChannelDesign) -> [[f64; 3]; 3] {
        let k = [k.k_integral, k.k_error, k.k_state];
        core::array::from_fn(|r| core::array::from_fn(|c| f64::from(a[r][c] + b[r] * k[c])))
    }

    /// Coefficients `[c2, c1, c0]` of `det(sI - M)` for a 3x3 `M`.
    fn char_poly(m: &[[f64; 3]; 3]) -> [f64; 3] {
        let tr = m[0][0] + m[1][1] + m[2][2];
        let minors = m[0][0] * m[1][1] - m[0][1] * m[1][0] + m[0][0] * m[2][2] - m[0][2] * m[2][0]
            + m[1][1] * m[2][2]
            - m[1][2] * m[2][1];
        let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
        [-tr, minors, -det]
    }

    fn assert_poles(m: &[[f64; 3]; 3], omega: f32, zeta: f32) {
        let got = char_poly(m);
        let want = characteristic(omega, zeta).map(f64::from);
        for (g, w) in got.iter().zip(want) {
            assert!(
                (g - w).abs() < 1e-4 * w.abs().max(1.0),
                "{got:?} vs {want:?}"
            );
        }
    }

    /// Each channel's gains place the design model's three closed-loop poles where the
    /// configuration asks, checked on the model's own matrices (written here from the
    /// equations of the module doc, not from the design's closed forms).
    #[test]
    fn each_channel_places_its_poles_on_the_design_model() {
        let cfg = AttitudeLoopConfig::default();
        let v = 120.0;
        let d = AttitudeDesign::new(&cfg, v, 0.02);
        let (tp, t) = (cfg.pitch_time_constant_s, cfg.flight_path_lag_s);
        // Vertical: d eta = e, d e = -(e + V theta)/T, d theta = (u - theta)/tau.
        let vert = closed_loop(
            [
                [0.0, 1.0, 0.0],
                [0.0, -1.0 / t, -v / t],
                [0.0, 0.0, -1.0 / tp],
            ],
            [0.0, 0.0, 1.0 / tp],
            &d.down,
        );
        assert_poles(&vert, cfg.vertical_bandwidth_radps, cfg.damping);
        // Lateral: d eta = e, d e = g phi, d phi = (u - phi)/tau.
        let tr = cfg.roll_time_constant_s;
        let lat = closed_loop(
            [
                [0.0, 1.0, 0.0],
                [0.0, 0.0, GRAVITY_MPS2],
                [0.0, 0.0, -1.0 / tr],
            ],
            [0.0, 0.0, 1.0 / tr],
            &d.right,
        );
        assert_poles(&lat, cfg.lateral_bandwidth_radps, cfg.damping);
        // Forward: d eta = e, d e = a, d a = (k u - a)/tau.
        let (te, k) = (cfg.engine_time_constant_s, cfg.throttle_accel_mps2);
        let fwd = closed_loop(
            [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0 / te]],
            [0.0, 0.0, k / te],
            &d.forward,
        );
        assert_poles(&fwd, cfg.forward_bandwidth_radps, cfg.damping);
    }

    /// The signs a pilot would expect: sinking below the desired velocity pitches up, drifting
    /// right banks left, too fast pulls the throttle back.
    #[test]
    fn errors_ask_for_the_corrections_a_pilot_would_make() {
        let cfg = AttitudeLoopConfig::default();
        let d = AttitudeDesign::new(&cfg, 120.0, 0.02);
        let run = |velocity_mps| {
            let mut l = AttitudeLoop::default();
            let i = AttitudeInputs {
                velocity_mps,
                ..AttitudeInputs::default()
            };
            l.step(&d, &cfg, &i, (0.1, 0.3), (0.0, 1.0), 0.02, 10.0, true)
                .setpoint
        };
        let sinking = run([0.5, 0.0, 0.0]);
        assert!(sinking.pitch_rad > 0.1, "{sinking:?}");
        let drifting_right = run([0.0, 0.0, 0.5]);
        assert!(drifting_right.roll_rad < 0.0, "{drifting_right:?}");
        let fast = run([0.0, 0.5, 0.0]);
        assert!(fast.throttle < 0.3, "{fast:?}");
    }

    /// Setpoints are limited, the side reported, and the integrator of a limited setpoint
    /// is not wound further into the limit (it still unwinds).
    #[test]
    fn limited_setpoints_freeze_their_integrators() {
        let cfg = AttitudeLoopConfig::default();
        let d = AttitudeDesign::new(&cfg, 120.0, 0.02);
        let mut l = AttitudeLoop::default();
        let big = AttitudeInputs {
            velocity_mps: [50.0, -50.0, 50.0],
            ..AttitudeInputs::default()
        };
        let AttitudeStep {
            setpoint: sp,
            side,
            frozen,
            ..
        } = l.step(&d, &cfg, &big, (0.1, 0.3), (0.0, 1.0), 0.02, 10.0, true);
        assert_eq!(side, [1, 1, -1]);
        assert_eq!(frozen, [true; 3]);
        assert_eq!(sp.pitch_rad, 0.1 + cfg.max_pitch_offset_rad);
        assert_eq!(sp.throttle, 1.0);
        assert_eq!(sp.roll_rad, -cfg.max_bank_rad);
        assert_eq!(l.integrators_m(), [0.0; 3], "frozen into the limit");
        let back = AttitudeInputs {
            velocity_mps: [-50.0, 50.0, -50.0],
            ..AttitudeInputs::default()
        };
        let mut l2 = l;
        let AttitudeStep { side, .. } =
            l2.step(&d, &cfg, &back, (0.1, 0.3), (0.0, 1.0), 0.02, 10.0, true);
        assert_eq!(side, [-1, -1, 1]);
        // Saturated the other way and pushing further: frozen again.
        assert_eq!(l2.integrators_m(), [0.0; 3]);
        // Inside the limits the integrators move.
        let small = AttitudeInputs {
            velocity_mps: [0.01, 0.01, 0.01],
            ..AttitudeInputs::default()
        };
        let AttitudeStep { side, .. } =
            l.step(&d, &cfg, &small, (0.1, 0.3), (0.0, 1.0), 0.02, 10.0, true);
        assert_eq!(side, [0, 0, 0]);
        assert!(l.integrators_m().iter().all(|e| *e > 0.0));
    }

    /// A law that is not finite (a NaN velocity: defence in depth, a validated sample has
    /// none) gives the trim's setpoint, flagged, and leaves the integrators as they were.
    #[test]
    fn a_non_finite_law_flies_the_trim_and_says_so() {
        let cfg = AttitudeLoopConfig::default();
        let d = AttitudeDesign::new(&cfg, 120.0, 0.02);
        let mut l = AttitudeLoop::default();
        let nan = AttitudeInputs {
            velocity_mps: [f32::NAN, f32::INFINITY, f32::NAN],
            ..AttitudeInputs::default()
        };
        let AttitudeStep {
            setpoint: sp,
            side,
            non_finite,
            ..
        } = l.step(&d, &cfg, &nan, (0.1, 0.3), (0.0, 1.0), 0.02, 10.0, true);
        assert!(non_finite);
        assert_eq!(side, [0, 0, 0]);
        assert_eq!((sp.pitch_rad, sp.roll_rad, sp.throttle), (0.1, 0.0, 0.3));
        assert_eq!(l.integrators_m(), [0.0; 3]);
        let non_finite = l
            .step(
                &d,
                &cfg,
                &AttitudeInputs::default(),
                (0.1, 0.3),
                (0.0, 1.0),
                0.02,
                10.0,
                true,
            )
            .non_finite;
        assert!(!non_finite);
    }

    /// The bumpless engage returns the receiver's own pitch and bank and the trim throttle.
    #[test]
    fn the_engage_preload_returns_the_present_attitude() {
        let cfg = AttitudeLoopConfig::default();
        let d = AttitudeDesign::new(&cfg, 120.0, 0.02);
        let mut l = AttitudeLoop::default();
        let i = AttitudeInputs {
            velocity_mps: [0.3, -0.2, 0.1],
            desired_mps: [0.0, 0.4, -0.1],
            theta_rad: 0.02,
            phi_rad: -0.05,
            psi_rad: 0.01,
        };
        l.preload(&d, &i, 10.0);
        let sp = l
            .step(&d, &cfg, &i, (0.1, 0.3), (0.0, 1.0), 0.02, 10.0, false)
            .setpoint;
        assert!((sp.pitch_rad - 0.12).abs() < 1e-6, "{sp:?}");
        assert!((sp.roll_rad + 0.05).abs() < 1e-6, "{sp:?}");
        assert!((sp.throttle - 0.3).abs() < 1e-6, "{sp:?}");
        assert_eq!(sp.yaw_rad, 0.01);
    }
}
