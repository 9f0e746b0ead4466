//! Actuator commands: absolute surface deflections and throttle, and their limits.
//!
//! Place in the data flow: last stage. The inner loops compute perturbations from trim; this
//! module turns them into absolute commands and saturates them.
//!
//! Invariant: a command leaving [`ActuatorLimits::saturate`] is finite and inside the limits
//! (a non-finite request is replaced by the trim value and reported).

use serde::{Deserialize, Serialize};

use crate::num::{INF_BITS, abs_bits, max_to, min_to};

/// Absolute commands to the receiver's surfaces and engine.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ActuatorCommand {
    /// Elevator (horizontal tail), trailing edge down positive, rad.
    pub elevator_rad: f32,
    /// Throttle lever, 0 (idle) .. 1 (full afterburner).
    pub throttle: f32,
    /// Aileron, right aileron trailing edge down positive (rolls left), rad.
    pub aileron_rad: f32,
    /// Rudder, trailing edge left positive (yaws left), rad.
    pub rudder_rad: f32,
}

impl ActuatorCommand {
    /// The four commands in channel order `[elevator, throttle, aileron, rudder]`.
    pub fn as_array(&self) -> [f32; 4] {
        [
            self.elevator_rad,
            self.throttle,
            self.aileron_rad,
            self.rudder_rad,
        ]
    }

    /// The inverse of [`ActuatorCommand::as_array`].
    pub fn from_array(a: [f32; 4]) -> Self {
        Self {
            elevator_rad: a[0],
            throttle: a[1],
            aileron_rad: a[2],
            rudder_rad: a[3],
        }
    }
}

/// Position limits of each command, absolute, and the surfaces' rate limits.
///
/// Defaults are the F-16's (Stevens, Lewis & Johnson App. A; docs/models.md, "Actuators"):
/// elevator +/-25 deg and 60 deg/s, aileron +/-21.5 deg and 80 deg/s, rudder +/-30 deg and
/// 120 deg/s, throttle 0..1.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ActuatorLimits {
    /// Lower limits `[elevator_rad, throttle, aileron_rad, rudder_rad]`.
    pub min: [f32; 4],
    /// Upper limits, same order.
    pub max: [f32; 4],
    /// Rate limits of the surfaces `[elevator, aileron, rudder]`, rad/s: the controller's
    /// model of its own actuators (the latency predictor's, whose deflections the refuelling
    /// design feeds back) moves no faster than the surfaces can.
    pub rate_radps: [f32; 3],
}

impl Default for ActuatorLimits {
    fn default() -> Self {
        let (el, ail, rud) = (
            25.0_f32.to_radians(),
            21.5_f32.to_radians(),
            30.0_f32.to_radians(),
        );
        Self {
            min: [-el, 0.0, -ail, -rud],
            max: [el, 1.0, ail, rud],
            rate_radps: [
                60.0_f32.to_radians(),
                80.0_f32.to_radians(),
                120.0_f32.to_radians(),
            ],
        }
    }
}

/// Which commands hit a limit in a step, in channel order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Saturation {
    /// `+1` above the upper limit, `-1` below the lower, `0` inside, per command.
    pub side: [i8; 4],
    /// True when a requested value was not finite and the trim value was used instead.
    pub non_finite: bool,
}

impl ActuatorLimits {
    /// Clamps `requested` into the limits; a non-finite component becomes `fallback`'s
    /// (itself clamped). The limits must be finite (a validated configuration's are).
    #[inline]
    pub fn saturate(&self, requested: [f32; 4], fallback: [f32; 4]) -> ([f32; 4], Saturation) {
        let mut out = [0.0; 4];
        let mut sat = Saturation::default();
        for i in 0..4 {
            let (lo, hi) = (self.min[i], self.max[i]);
            let v = requested[i];
            out[i] = if v <= hi && v >= lo {
                // Inside the limits (and so finite): the common case, two comparisons.
                v
            } else if abs_bits(v) >= INF_BITS {
                sat.non_finite = true;
                min_to(max_to(fallback[i], lo), hi)
            } else if v > hi {
                sat.side[i] = 1;
                hi
            } else if v < lo {
                sat.side[i] = -1;
                lo
            } else {
                v
            };
        }
        (out, sat)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn saturates_and_reports_the_side() {
        let lim = ActuatorLimits::default();
        let (out, sat) = lim.saturate([1.0, -0.5, 0.0, -1.0], [0.0; 4]);
        assert_eq!(out, [lim.max[0], 0.0, 0.0, lim.min[3]]);
        assert_eq!(sat.side, [1, -1, 0, -1]);
        assert!(!sat.non_finite);
    }

    /// The next float above `x` (toward +infinity), for finite `x`.
    fn up(x: f32) -> f32 {
        if x == 0.0 {
            f32::from_bits(1)
        } else if x > 0.0 {
            f32::from_bits(x.to_bits() + 1)
        } else {
            f32::from_bits(x.to_bits() - 1)
        }
    }

    /// The next float below `x`.
    fn down(x: f32) -> f32 {
        -up(-x)
    }

    #[test]
    fn a_limit_itself_is_inside_and_the_next_float_beyond_it_saturates() {
        // Every channel, both limits: exactly on the limit the command passes unchanged and
        // no saturation is reported (the anti-windup must not freeze an integrator there);
        // one float inside, the same; one float beyond, the limit and the side.
        let lim = ActuatorLimits::default();
        for i in 0..4 {
            let (lo, hi) = (lim.min[i], lim.max[i]);
            for (v, want, side) in [
                (hi, hi, 0),
                (down(hi), down(hi), 0),
                (up(hi), hi, 1),
                (lo, lo, 0),
                (up(lo), up(lo), 0),
                (down(lo), lo, -1),
            ] {
                let mut req = [0.0; 4];
                // Other channels inside their limits (the throttle's range is 0..1).
                req[1] = 0.5;
                req[i] = v;
                let (out, sat) = lim.saturate(req, [0.0, 0.5, 0.0, 0.0]);
                assert_eq!(out[i], want, "channel {i}, requested {v}");
                let mut want_side = [0; 4];
                want_side[i] = side;
                assert_eq!(sat.side, want_side, "channel {i}, requested {v}");
                assert!(!sat.non_finite);
            }
        }
    }

    #[test]
    fn replaces_non_finite_by_the_fallback() {
        let lim = ActuatorLimits::default();
        let (out, sat) = lim.saturate([f32::NAN, f32::INFINITY, 0.1, 0.0], [-0.05, 0.2, 0.0, 0.0]);
        assert_eq!(out, [-0.05, 0.2, 0.1, 0.0]);
        assert!(sat.non_finite);
    }
}
