//! Control-surface actuators and throttle limits of the F-16 receiver.
//!
//! Source: `[actuators]` of `data/f16-lofi-data.toml` and `docs/models.md`, "Actuators" (the
//! paper authors' simulation): each surface is a first-order lag of bandwidth 20.2 rad/s
//! toward its command clamped to the position limit, with its rate limited,
//! `d(delta)/dt = clamp(w (clamp(cmd, +/-limit) - delta), +/-rate_limit)`; the throttle is
//! clamped to its range and drives the engine's power lag (see `engine.rs`). The aircraft flies
//! each surface with its rate limit and bandwidth times the plant's factors (`plant.rs`).
//! Invariants: parameters are SI (rad, rad/s) and pass [`ActuatorParams::validate`] before the
//! model uses them, so the clamps cannot panic. A surface that starts inside its limits stays
//! inside them under exact integration; with RK4 this holds for steps below about 1/bandwidth.

use serde::{Deserialize, Serialize};

use super::data::{ActuatorData, ModelError, require_positive};
use super::plant::ReceiverPlant;
use super::state::{ReceiverCommand, Surfaces};

/// Position and rate limits of one control surface.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SurfaceLimits {
    /// Deflection limit, symmetric about zero, rad (> 0).
    pub position_limit_rad: f64,
    /// Rate limit, symmetric about zero, rad/s (> 0).
    pub rate_limit_radps: f64,
}

impl SurfaceLimits {
    /// Rate of a surface at `actual_rad` commanded to `command_rad`, rad/s.
    fn rate_radps(&self, bandwidth_radps: f64, command_rad: f64, actual_rad: f64) -> f64 {
        let target_rad = command_rad.clamp(-self.position_limit_rad, self.position_limit_rad);
        (bandwidth_radps * (target_rad - actual_rad))
            .clamp(-self.rate_limit_radps, self.rate_limit_radps)
    }
}

/// Actuator and throttle parameters. [`crate::receiver::F16::new`] loads the data-file values
/// (elevator 25 deg, 60 deg/s; aileron 21.5 deg, 80 deg/s; rudder 30 deg, 120 deg/s;
/// 20.2 rad/s; throttle 0..1); change them with [`crate::receiver::F16::set_actuators`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ActuatorParams {
    /// First-order lag bandwidth of every surface actuator, rad/s (> 0).
    pub bandwidth_radps: f64,
    /// Elevator limits.
    pub elevator: SurfaceLimits,
    /// Aileron limits.
    pub aileron: SurfaceLimits,
    /// Rudder limits.
    pub rudder: SurfaceLimits,
    /// Lowest throttle, fraction (>= 0).
    pub throttle_min: f64,
    /// Highest throttle, fraction (> throttle_min, <= 1).
    pub throttle_max: f64,
}

impl ActuatorParams {
    /// Parameters from the data file's `[actuators]` table (degrees converted to radians).
    pub(crate) fn from_data(data: &ActuatorData) -> Result<Self, ModelError> {
        let limits = |limit_deg: f64, rate_deg_s: f64| SurfaceLimits {
            position_limit_rad: limit_deg.to_radians(),
            rate_limit_radps: rate_deg_s.to_radians(),
        };
        let params = Self {
            bandwidth_radps: data.servo_bandwidth_rad_s,
            elevator: limits(data.elevator_limit_deg, data.elevator_rate_deg_s),
            aileron: limits(data.aileron_limit_deg, data.aileron_rate_deg_s),
            rudder: limits(data.rudder_limit_deg, data.rudder_rate_deg_s),
            throttle_min: data.throttle_range[0],
            throttle_max: data.throttle_range[1],
        };
        params.validate()?;
        Ok(params)
    }

    /// Check that bandwidth and limits are finite and positive and the throttle range is an
    /// interval inside [0, 1] (the range of the engine's throttle gearing).
    pub fn validate(&self) -> Result<(), ModelError> {
        for (name, value) in [
            ("bandwidth_radps", self.bandwidth_radps),
            (
                "elevator.position_limit_rad",
                self.elevator.position_limit_rad,
            ),
            ("elevator.rate_limit_radps", self.elevator.rate_limit_radps),
            (
                "aileron.position_limit_rad",
                self.aileron.position_limit_rad,
            ),
            ("aileron.rate_limit_radps", self.aileron.rate_limit_radps),
            ("rudder.position_limit_rad", self.rudder.position_limit_rad),
            ("rudder.rate_limit_radps", self.rudder.rate_limit_radps),
        ] {
            require_positive(name, value)?;
        }
        let range_ok =
            (0.0..self.throttle_max).contains(&self.throttle_min) && self.throttle_max <= 1.0;
        if range_ok {
            Ok(())
        } else {
            Err(ModelError::InvalidParameter {
                name: "throttle_min",
                value: self.throttle_min,
                requirement: "0 <= throttle_min < throttle_max <= 1",
            })
        }
    }

    /// Throttle actually applied for a commanded `throttle` (fraction).
    pub fn clamp_throttle(&self, throttle: f64) -> f64 {
        throttle.clamp(self.throttle_min, self.throttle_max)
    }
}

/// One surface's actuator as the aircraft flies it.
#[derive(Debug, Clone, Copy, PartialEq)]
struct SurfaceServo {
    /// Position limit (the data's) and rate limit (the data's times the plant's factor).
    limits: SurfaceLimits,
    /// Lag bandwidth, rad/s (the data's times the plant's factor).
    bandwidth_radps: f64,
}

/// The three surface actuators as the aircraft flies them: the data's ([`ActuatorParams`])
/// with a plant's factors on each rate limit and bandwidth. At the nominal plant they are the
/// data's exactly (each factor multiplies, and 1.0 multiplies exactly).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct FlownSurfaces {
    elevator: SurfaceServo,
    aileron: SurfaceServo,
    rudder: SurfaceServo,
}

impl FlownSurfaces {
    /// The actuators of `params` with the factors of `plant`.
    pub(crate) fn new(params: &ActuatorParams, plant: &ReceiverPlant) -> Self {
        let servo = |limits: SurfaceLimits, rate_scale: f64, bandwidth_scale: f64| SurfaceServo {
            limits: SurfaceLimits {
                rate_limit_radps: limits.rate_limit_radps * rate_scale,
                ..limits
            },
            bandwidth_radps: params.bandwidth_radps * bandwidth_scale,
        };
        Self {
            elevator: servo(
                params.elevator,
                plant.elevator_rate_limit_scale,
                plant.elevator_bandwidth_scale,
            ),
            aileron: servo(
                params.aileron,
                plant.aileron_rate_limit_scale,
                plant.aileron_bandwidth_scale,
            ),
            rudder: servo(
                params.rudder,
                plant.rudder_rate_limit_scale,
                plant.rudder_bandwidth_scale,
            ),
        }
    }

    /// Surface rates for `command` with the surfaces at `actual` (each field in rad/s).
    pub(crate) fn rates_radps(&self, command: &ReceiverCommand, actual: &Surfaces) -> Surfaces {
        let rate = |s: &SurfaceServo, command_rad: f64, actual_rad: f64| {
            s.limits
                .rate_radps(s.bandwidth_radps, command_rad, actual_rad)
        };
        Surfaces {
            elevator_rad: rate(&self.elevator, command.elevator_rad, actual.elevator_rad),
            aileron_rad: rate(&self.aileron, command.aileron_rad, actual.aileron_rad),
            rudder_rad: rate(&self.rudder, command.rudder_rad, actual.rudder_rad),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const LIMITS: SurfaceLimits = SurfaceLimits {
        position_limit_rad: 0.4,
        rate_limit_radps: 1.0,
    };
    const BANDWIDTH_RADPS: f64 = 20.0;

    #[test]
    fn lag_inside_limits_saturates_outside() {
        // Small error: first-order lag, 20 * 0.01 rad/s.
        assert!((LIMITS.rate_radps(BANDWIDTH_RADPS, 0.11, 0.1) - 0.2).abs() < 1e-12);
        // Large error: rate limit, signed.
        assert_eq!(LIMITS.rate_radps(BANDWIDTH_RADPS, 0.3, -0.3), 1.0);
        assert_eq!(LIMITS.rate_radps(BANDWIDTH_RADPS, -0.3, 0.3), -1.0);
        // A command beyond the position limit aims at the limit: at the limit, no motion.
        assert_eq!(LIMITS.rate_radps(BANDWIDTH_RADPS, 5.0, 0.4), 0.0);
        assert!((LIMITS.rate_radps(BANDWIDTH_RADPS, 5.0, 0.39) - 0.2).abs() < 1e-12);
    }
}
