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
