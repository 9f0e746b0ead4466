//! A fixed-wing autopilot's attitude controller, of the kind ArduPlane and PX4 fly, flying
//! the F-16 from the flight computer's attitude and throttle setpoints.
//!
//! Structure (ArduPlane's `AP_RollController`, `AP_PitchController`, `AP_YawController`;
//! PX4's `FixedwingAttitudeControl` is the same cascade): each attitude error becomes a
//! desired body rate through the loop's time constant (`RLL2SRV_TCONST`,
//! `PTCH2SRV_TCONST`), and a rate loop of feed-forward plus P and I on the rate error turns
//! it into a surface deflection, with the gains scaled by the dynamic pressure's ratio to the
//! tuning point (ArduPlane's airspeed scaler). The pitch loop adds the turn's pitch rate
//! (`PTCH2SRV_RLL`); the rudder coordinates the turn (`YAW2SRV_RLL`) and damps yaw
//! (`YAW2SRV_DAMP`). The throttle passes through. Setpoints are limited to
//! `ROLL_LIMIT_DEG`, `PTCH_LIM_MAX_DEG`, `PTCH_LIM_MIN_DEG`. Without a new setpoint for
//! `GUIDED_TIMEOUT`, or out of the mode that follows setpoints, the autopilot flies on
//! alone: wings level, the trim pitch and its cruise airspeed held with the throttle
//! (ArduPlane returns to its own guidance there, TECS holding `AIRSPEED_CRUISE`; in a
//! formation that is flying straight on at the formation's speed).
//!
//! The time constants, limits and the timeout are the autopilots' public defaults
//! (`docs/models.md`, "Autopilot"); the rate gains are this airframe's (an autotune's job on
//! a real aircraft: the defaults are for model aircraft), derived there from the F-16's
//! linear model at the tuning point. The autopilot reads the true attitude and rates (its own
//! AHRS's errors are not modelled).
//!
//! Invariants: the commands it returns are finite for finite inputs; the integrators are
//! bounded by the surfaces' position limits.

use serde::{Deserialize, Serialize};

use ibvs_core::attitude::AttitudeSetpoint;

use super::state::{ReceiverCommand, ReceiverState};
use crate::world::hose::STANDARD_GRAVITY_MPS2 as G_MPS2;

/// The autopilot's parameters (the ArduPlane parameter each stands for in brackets).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AutopilotParams {
    /// Roll-angle loop time constant, s (`RLL2SRV_TCONST`, default 0.5).
    pub roll_time_constant_s: f64,
    /// Pitch-angle loop time constant, s (`PTCH2SRV_TCONST`, default 0.5).
    pub pitch_time_constant_s: f64,
    /// Largest bank, rad (`ROLL_LIMIT_DEG`, formerly `LIM_ROLL_CD`: 45 deg).
    pub max_roll_rad: f64,
    /// Largest pitch, rad (`PTCH_LIM_MAX_DEG`, formerly `LIM_PITCH_MAX`: 20 deg).
    pub max_pitch_rad: f64,
    /// Smallest pitch, rad (`PTCH_LIM_MIN_DEG`, formerly `LIM_PITCH_MIN`: -25 deg).
    pub min_pitch_rad: f64,
    /// Roll rate loop: feed-forward, rad of aileron per rad/s (`RLL_RATE_FF`).
    pub roll_rate_ff: f64,
    /// Roll rate loop: proportional gain (`RLL_RATE_P`).
    pub roll_rate_p: f64,
    /// Roll rate loop: integral gain, per s (`RLL_RATE_I`).
    pub roll_rate_i: f64,
    /// Pitch rate loop: feed-forward, rad of elevator per rad/s (`PTCH_RATE_FF`).
    pub pitch_rate_ff: f64,
    /// Pitch rate loop: proportional gain (`PTCH_RATE_P`).
    pub pitch_rate_p: f64,
    /// Pitch rate loop: integral gain, per s (`PTCH_RATE_I`).
    pub pitch_rate_i: f64,
    /// Turn coordination in pitch, fraction of the turn's pitch rate (`PTCH2SRV_RLL`, 1).
    pub pitch_turn_coordination: f64,
    /// Rudder per rad/s of the coordinated turn's yaw rate (`YAW2SRV_RLL` times the
    /// airframe's rudder feed-forward).
    pub yaw_turn_coordination: f64,
    /// Yaw damper, rad of rudder per rad/s of yaw-rate error (`YAW2SRV_DAMP`).
    pub yaw_damping: f64,
    /// True airspeed the rate gains were tuned at, m/s (the scaler's reference).
    pub tuning_speed_mps: f64,
    /// Without a new setpoint for this long the autopilot flies on alone, s
    /// (`GUIDED_TIMEOUT`, default 3).
    pub setpoint_timeout_s: f64,
    /// Flying on alone, the airspeed it holds, m/s (`AIRSPEED_CRUISE`: the formation's,
    /// the tanker's speed at the tuning point).
    pub cruise_speed_mps: f64,
    /// Flying on alone, throttle per m/s of airspeed error (the speed hold of its own
    /// guidance, TECS's part; ours: a 2 s speed loop on the F-16's 5.65 m/s² per unit of
    /// throttle).
    pub speed_hold_gain: f64,
    /// Surface position limits `[elevator, aileron, rudder]`, rad (the servos' throw).
    pub surface_limits_rad: [f64; 3],
}

impl Default for AutopilotParams {
    fn default() -> Self {
        Self {
            roll_time_constant_s: 0.5,
            pitch_time_constant_s: 0.5,
            max_roll_rad: 45f64.to_radians(),
            max_pitch_rad: 20f64.to_radians(),
            min_pitch_rad: -25f64.to_radians(),
            roll_rate_ff: 0.108,
            roll_rate_p: 0.43,
            roll_rate_i: 0.2,
            pitch_rate_ff: 0.175,
            pitch_rate_p: 1.6,
            pitch_rate_i: 0.8,
            pitch_turn_coordination: 1.0,
            yaw_turn_coordination: 0.19,
            yaw_damping: 0.5,
            tuning_speed_mps: 120.0,
            setpoint_timeout_s: 3.0,
            cruise_speed_mps: 120.0,
            speed_hold_gain: 0.09,
            surface_limits_rad: [25f64.to_radians(), 21.5f64.to_radians(), 30f64.to_radians()],
        }
    }
}

impl AutopilotParams {
    /// Checks every parameter: finite, positive where a time, gain or limit must be.
    pub fn validate(&self) -> Result<(), &'static str> {
        let positive = [
            self.roll_time_constant_s,
            self.pitch_time_constant_s,
            self.max_roll_rad,
            self.max_pitch_rad,
            self.tuning_speed_mps,
            self.setpoint_timeout_s,
            self.cruise_speed_mps,
        ];
        let non_negative = [
            self.roll_rate_ff,
            self.roll_rate_p,
            self.roll_rate_i,
            self.pitch_rate_ff,
            self.pitch_rate_p,
            self.pitch_rate_i,
            self.pitch_turn_coordination,
            self.yaw_turn_coordination,
            self.yaw_damping,
            self.speed_hold_gain,
        ];
        if !positive.iter().all(|v| v.is_finite() && *v > 0.0)
            || !self
                .surface_limits_rad
                .iter()
                .all(|v| v.is_finite() && *v > 0.0)
        {
            return Err("autopilot time constants, limits and tuning speed must be finite and > 0");
        }
        if !non_negative.iter().all(|v| v.is_finite() && *v >= 0.0) {
            return Err("autopilot gains must be finite and >= 0");
        }
        if !(self.min_pitch_rad.is_finite() && self.min_pitch_rad < 0.0) {
            return Err("autopilot min_pitch_rad must be finite and < 0");
        }
        Ok(())
    }
}

/// The autopilot's state: the latest setpoint and its time, and the rate loops'
/// integrators (surface deflections, rad).
#[derive(Debug, Clone, PartialEq)]
pub struct Autopilot {
    params: AutopilotParams,
    setpoint: Option<(AttitudeSetpoint, f64)>,
    /// `[elevator, aileron, rudder]` integrators, rad.
    integrator_rad: [f64; 3],
    /// The throttle last passed through.
    throttle: f64,
    /// The trim throttle (its speed hold's base).
    trim_throttle: f64,
    /// The trim pitch it holds when on its own, rad.
    trim_pitch_rad: f64,
    /// Setpoints it stopped following on a timeout.
    timeouts: u32,
    /// In the mode that follows the flight computer (GUIDED).
    following: bool,
}

impl Autopilot {
    /// An autopilot flying the receiver trimmed at `trim` (its integrators hold the trim
    /// surfaces: it was flying the aircraft before the flight computer's first setpoint).
    pub fn new(
        params: AutopilotParams,
        trim_state: &ReceiverState,
        trim: &ReceiverCommand,
    ) -> Self {
        Self {
            params,
            setpoint: None,
            integrator_rad: [trim.elevator_rad, trim.aileron_rad, trim.rudder_rad],
            throttle: trim.throttle,
            trim_throttle: trim.throttle,
            trim_pitch_rad: trim_state.euler_rad.y,
            timeouts: 0,
            following: true,
        }
    }

    /// Leaves (false) or re-enters (true) the mode that follows the setpoints. Out of it the
    /// autopilot flies on alone (wings level, the trim pitch, the last throttle) and ignores
    /// setpoints.
    pub fn set_following(&mut self, following: bool) {
        if !following {
            self.setpoint = None;
        }
        self.following = following;
    }

    /// In the mode that follows the setpoints (what its heartbeat reports).
    pub fn follows_setpoints(&self) -> bool {
        self.following
    }

    /// Times it stopped following the flight computer for want of a setpoint.
    pub fn timeouts(&self) -> u32 {
        self.timeouts
    }

    /// A setpoint received at `t_s`. Non-finite setpoints are refused (kept out; the
    /// previous one ages toward the timeout), and so is every setpoint out of the following
    /// mode.
    pub fn receive(&mut self, sp: &AttitudeSetpoint, t_s: f64) -> bool {
        let ok = self.following
            && [sp.roll_rad, sp.pitch_rad, sp.yaw_rad, sp.throttle]
                .iter()
                .all(|v| v.is_finite());
        if ok {
            self.setpoint = Some((*sp, t_s));
        }
        ok
    }

    /// The surface and throttle commands at `t_s` for state `x`, advancing the rate loops'
    /// integrators by `dt_s`.
    pub fn command(&mut self, x: &ReceiverState, t_s: f64, dt_s: f64) -> ReceiverCommand {
        let p = self.params;
        let speed = x.vel_body_mps.norm().max(1.0);
        let alone = |ap: &mut Self| {
            // Its own guidance: wings level, the trim pitch, the cruise airspeed held.
            ap.throttle = ap.trim_throttle + p.speed_hold_gain * (p.cruise_speed_mps - speed);
            (0.0, ap.trim_pitch_rad)
        };
        let (roll_sp, pitch_sp) = match self.setpoint {
            Some((sp, at)) if t_s - at <= p.setpoint_timeout_s => {
                self.throttle = f64::from(sp.throttle);
                (f64::from(sp.roll_rad), f64::from(sp.pitch_rad))
            }
            Some(_) => {
                self.timeouts += 1;
                self.setpoint = None;
                alone(self)
            }
            None => alone(self),
        };
        let roll_sp = roll_sp.clamp(-p.max_roll_rad, p.max_roll_rad);
        let pitch_sp = pitch_sp.clamp(p.min_pitch_rad, p.max_pitch_rad);
        let (phi, theta) = (x.euler_rad.x, x.euler_rad.y);
        let [rate_p, rate_q, rate_r] = [
            x.rate_body_radps.x,
            x.rate_body_radps.y,
            x.rate_body_radps.z,
        ];
        // Dynamic pressure's ratio: surfaces are (V_ref / V)^2 as effective per radian.
        let scale = (p.tuning_speed_mps / speed).powi(2);
        let turn_rate = G_MPS2 / speed * phi.sin();

        // Roll: desired roll rate, then the rate loop (positive aileron rolls left).
        let p_des = (roll_sp - phi) / p.roll_time_constant_s;
        let aileron = -self.rate_loop(
            1,
            p_des,
            rate_p,
            p.roll_rate_ff,
            p.roll_rate_p,
            p.roll_rate_i,
            scale,
            dt_s,
        );
        // Pitch: desired pitch rate with the turn's, then the rate loop (positive elevator
        // pitches down).
        let q_des = (pitch_sp - theta) / p.pitch_time_constant_s
            + p.pitch_turn_coordination * G_MPS2 / speed * phi.tan() * phi.sin();
        let elevator = -self.rate_loop(
            0,
            q_des,
            rate_q,
            p.pitch_rate_ff,
            p.pitch_rate_p,
            p.pitch_rate_i,
            scale,
            dt_s,
        );
        // Yaw: the coordinated turn's body yaw rate, damped (positive rudder yaws left).
        let r_des = turn_rate;
        let rudder = self.integrator_rad[2]
            - scale * (p.yaw_turn_coordination * r_des + p.yaw_damping * (r_des - rate_r));
        let lim = p.surface_limits_rad;
        ReceiverCommand {
            elevator_rad: elevator.clamp(-lim[0], lim[0]),
            aileron_rad: aileron.clamp(-lim[1], lim[1]),
            rudder_rad: rudder.clamp(-lim[2], lim[2]),
            throttle: self.throttle.clamp(0.0, 1.0),
        }
    }

    /// One rate loop, axis `i` (0 pitch, 1 roll): `scale (ff w_des + kp (w_des - w)) +
    /// integrator`, the integrator advanced by `scale ki (w_des - w) dt` and held within the
    /// surface's throw. Returns the deflection in the rate's sense (the caller signs it).
    #[allow(clippy::too_many_arguments)]
    fn rate_loop(
        &mut self,
        i: usize,
        w_des: f64,
        w: f64,
        ff: f64,
        kp: f64,
        ki: f64,
        scale: f64,
        dt_s: f64,
    ) -> f64 {
        // The integrator is kept in the surface's sense; the rate's sense is its negative.
        let lim = self.params.surface_limits_rad[[0, 1][i]];
        let e = w_des - w;
        let acc = (-self.integrator_rad[i]) + scale * ki * e * dt_s;
        self.integrator_rad[i] = -acc.clamp(-lim, lim);
        scale * (ff * w_des + kp * e) + acc.clamp(-lim, lim)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::receiver::{F16, Wind};

    const DT: f64 = 0.02;

    /// The F-16 trimmed at 120 m/s and 3000 m, flown `seconds` by the autopilot holding
    /// `sp` (sent every step while `send` says so); the final state and the autopilot.
    fn fly(
        sp: AttitudeSetpoint,
        seconds: f64,
        send: impl Fn(f64) -> bool,
    ) -> (ReceiverState, Autopilot) {
        let model = F16::new(0.35).expect("model");
        let trim = model.trim_straight_level(120.0, 3000.0).expect("trim");
        let mut x = trim.state;
        let mut ap = Autopilot::new(AutopilotParams::default(), &trim.state, &trim.command);
        let steps = (seconds / DT).round() as usize;
        for k in 0..steps {
            let t = k as f64 * DT;
            if send(t) {
                assert!(ap.receive(&sp, t));
            }
            let cmd = ap.command(&x, t, DT);
            model.step_rk4(&mut x, &cmd, &Wind::default(), DT);
        }
        (x, ap)
    }

    fn trim_pitch_rad() -> f64 {
        let model = F16::new(0.35).expect("model");
        model
            .trim_straight_level(120.0, 3000.0)
            .expect("trim")
            .theta_rad
    }

    /// The attitude loops hold what they are asked, in the asked sense, within a few time
    /// constants, on the nonlinear airframe (bank 10 deg right, pitch 2 deg above trim).
    #[test]
    fn it_flies_the_bank_and_pitch_it_is_asked() {
        let theta0 = trim_pitch_rad();
        let sp = AttitudeSetpoint {
            roll_rad: 10f32.to_radians(),
            pitch_rad: (theta0 + 2f64.to_radians()) as f32,
            yaw_rad: 0.0,
            throttle: 0.5,
        };
        let (x, ap) = fly(sp, 4.0, |_| true);
        let (phi, theta) = (x.euler_rad.x, x.euler_rad.y);
        assert!(
            (phi - 10f64.to_radians()).abs() < 1f64.to_radians(),
            "bank {}",
            phi.to_degrees()
        );
        assert!(
            (theta - theta0 - 2f64.to_radians()).abs() < 0.5f64.to_radians(),
            "pitch {} vs {}",
            theta.to_degrees(),
            (theta0 + 2f64.to_radians()).to_degrees()
        );
        // A coordinated turn: the sideslip stays small.
        let beta = (x.vel_body_mps.y / x.vel_body_mps.norm()).asin();
        assert!(
            beta.abs() < 1f64.to_radians(),
            "sideslip {}",
            beta.to_degrees()
        );
        assert_eq!(ap.timeouts(), 0);
    }

    /// Without a new setpoint for `GUIDED_TIMEOUT` it stops following: wings level at the
    /// trim pitch (the last setpoint asked for a 10 deg bank), and counts it once.
    #[test]
    fn without_setpoints_it_times_out_and_levels_the_wings() {
        let theta0 = trim_pitch_rad();
        let sp = AttitudeSetpoint {
            roll_rad: 10f32.to_radians(),
            pitch_rad: theta0 as f32,
            yaw_rad: 0.0,
            throttle: 0.2,
        };
        // One setpoint at t = 0, then silence for 12 s.
        let (x, ap) = fly(sp, 12.0, |t| t == 0.0);
        assert_eq!(ap.timeouts(), 1);
        assert!(
            x.euler_rad.x.abs() < 1f64.to_radians(),
            "bank {}",
            x.euler_rad.x.to_degrees()
        );
        // Still following at 2.9 s (within the timeout): banked.
        let (x, ap) = fly(sp, 2.9, |t| t == 0.0);
        assert_eq!(ap.timeouts(), 0);
        assert!(
            x.euler_rad.x > 5f64.to_radians(),
            "bank {}",
            x.euler_rad.x.to_degrees()
        );
    }

    /// A setpoint that is not finite is refused and does not reach the surfaces.
    #[test]
    fn a_non_finite_setpoint_is_refused() {
        let model = F16::new(0.35).expect("model");
        let trim = model.trim_straight_level(120.0, 3000.0).expect("trim");
        let mut ap = Autopilot::new(AutopilotParams::default(), &trim.state, &trim.command);
        let bad = AttitudeSetpoint {
            roll_rad: f32::NAN,
            ..AttitudeSetpoint::default()
        };
        assert!(!ap.receive(&bad, 0.0));
        let cmd = ap.command(&trim.state, 0.0, DT);
        for v in [
            cmd.elevator_rad,
            cmd.aileron_rad,
            cmd.rudder_rad,
            cmd.throttle,
        ] {
            assert!(v.is_finite());
        }
        assert!((cmd.elevator_rad - trim.command.elevator_rad).abs() < 1e-3);
    }

    #[test]
    fn invalid_parameters_are_named() {
        let p = AutopilotParams {
            pitch_rate_p: -1.0,
            ..AutopilotParams::default()
        };
        assert_eq!(p.validate(), Err("autopilot gains must be finite and >= 0"));
        let p = AutopilotParams {
            setpoint_timeout_s: 0.0,
            ..AutopilotParams::default()
        };
        assert!(p.validate().is_err());
        assert_eq!(AutopilotParams::default().validate(), Ok(()));
    }
}
