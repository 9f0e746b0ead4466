//! State, command and wind of the F-16 receiver, and the state's flat vector layout.
//!
//! Source: the layout is this project's (the receiver brief); quantities are those of a
//! flat-earth 6-DOF rigid body with engine and actuator states.
//! Invariants: everything is SI and radians; frames are body (x forward, y right, z down) and
//! NED (north, east, down) on a flat, non-rotating earth; [`ReceiverState::to_vector`] and
//! [`ReceiverState::from_vector`] are exact inverses using the order in [`state_index`].

use nalgebra::{SVector, Vector3};
use serde::{Deserialize, Serialize};

/// Length of the state vector.
pub const STATE_DIM: usize = 16;

/// The state (or its time derivative) as a flat vector, order given by [`state_index`].
pub type StateVector = SVector<f64, STATE_DIM>;

/// Positions of each quantity in [`StateVector`].
pub mod state_index {
    /// Ground-relative velocity along body x, m/s.
    pub const U: usize = 0;
    /// Ground-relative velocity along body y, m/s.
    pub const V: usize = 1;
    /// Ground-relative velocity along body z, m/s.
    pub const W: usize = 2;
    /// Roll angle, rad.
    pub const PHI: usize = 3;
    /// Pitch angle, rad.
    pub const THETA: usize = 4;
    /// Yaw (heading) angle, rad.
    pub const PSI: usize = 5;
    /// Roll rate, rad/s.
    pub const P: usize = 6;
    /// Pitch rate, rad/s.
    pub const Q: usize = 7;
    /// Yaw rate, rad/s.
    pub const R: usize = 8;
    /// North position of the CG, m.
    pub const NORTH: usize = 9;
    /// East position of the CG, m.
    pub const EAST: usize = 10;
    /// Down position of the CG, m (= -altitude).
    pub const DOWN: usize = 11;
    /// Engine power state, percent.
    pub const POWER: usize = 12;
    /// Elevator position, rad.
    pub const ELEVATOR: usize = 13;
    /// Aileron position, rad.
    pub const AILERON: usize = 14;
    /// Rudder position, rad.
    pub const RUDDER: usize = 15;
}

/// Control-surface positions (actual, or their rates when part of a derivative), rad.
///
/// Signs follow the data tables: positive elevator is trailing edge down (nose-down moment).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Surfaces {
    /// Elevator, rad.
    pub elevator_rad: f64,
    /// Aileron, rad.
    pub aileron_rad: f64,
    /// Rudder, rad.
    pub rudder_rad: f64,
}

/// Full state of the receiver.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ReceiverState {
    /// Ground-relative (inertial) velocity of the CG, body axes (u, v, w), m/s.
    pub vel_body_mps: Vector3<f64>,
    /// 3-2-1 Euler angles of body relative to NED (roll phi, pitch theta, yaw psi), rad.
    /// Singular at theta = +/-pi/2; psi is not wrapped.
    pub euler_rad: Vector3<f64>,
    /// Body angular rates (p, q, r) relative to NED (inertial on a flat, non-rotating earth), rad/s.
    pub rate_body_radps: Vector3<f64>,
    /// CG position (north, east, down), m; down = -altitude.
    pub pos_ned_m: Vector3<f64>,
    /// Engine power state, percent (0..100).
    pub engine_power_pct: f64,
    /// Actual control-surface positions, rad.
    pub surfaces_rad: Surfaces,
}

impl ReceiverState {
    /// The state as a flat vector in [`state_index`] order.
    pub fn to_vector(&self) -> StateVector {
        let s = &self.surfaces_rad;
        let mut x = StateVector::zeros();
        x.fixed_rows_mut::<3>(state_index::U)
            .copy_from(&self.vel_body_mps);
        x.fixed_rows_mut::<3>(state_index::PHI)
            .copy_from(&self.euler_rad);
        x.fixed_rows_mut::<3>(state_index::P)
            .copy_from(&self.rate_body_radps);
        x.fixed_rows_mut::<3>(state_index::NORTH)
            .copy_from(&self.pos_ned_m);
        x[state_index::POWER] = self.engine_power_pct;
        x[state_index::ELEVATOR] = s.elevator_rad;
        x[state_index::AILERON] = s.aileron_rad;
        x[state_index::RUDDER] = s.rudder_rad;
        x
    }

    /// The state from a flat vector in [`state_index`] order.
    pub fn from_vector(x: &StateVector) -> Self {
        Self {
            vel_body_mps: x.fixed_rows::<3>(state_index::U).into(),
            euler_rad: x.fixed_rows::<3>(state_index::PHI).into(),
            rate_body_radps: x.fixed_rows::<3>(state_index::P).into(),
            pos_ned_m: x.fixed_rows::<3>(state_index::NORTH).into(),
            engine_power_pct: x[state_index::POWER],
            surfaces_rad: Surfaces {
                elevator_rad: x[state_index::ELEVATOR],
                aileron_rad: x[state_index::AILERON],
                rudder_rad: x[state_index::RUDDER],
            },
        }
    }
}

/// Commands to the actuators and the engine, held constant over an integration step.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ReceiverCommand {
    /// Commanded elevator, rad (clamped to the actuator's position limit).
    pub elevator_rad: f64,
    /// Commanded aileron, rad (clamped to the actuator's position limit).
    pub aileron_rad: f64,
    /// Commanded rudder, rad (clamped to the actuator's position limit).
    pub rudder_rad: f64,
    /// Throttle, fraction 0..1 (clamped to the throttle range).
    pub throttle: f64,
}

/// Steady motion of the air mass.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Wind {
    /// Air-mass velocity relative to the ground, NED, m/s (a north wind blowing south is
    /// (-V, 0, 0)).
    pub velocity_ned_mps: Vector3<f64>,
    /// Air-mass rotation rate, NED axes, rad/s (e.g. from the spanwise and lengthwise
    /// gradients of a vortex wake). The aerodynamic damping terms see the body rates relative
    /// to it.
    pub angular_rate_ned_radps: Vector3<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vector_round_trip_uses_documented_order() {
        let x: StateVector = StateVector::from_fn(|i, _| i as f64 + 0.5);
        let state = ReceiverState::from_vector(&x);
        assert_eq!(state.vel_body_mps.y, x[state_index::V]);
        assert_eq!(state.euler_rad.z, x[state_index::PSI]);
        assert_eq!(state.rate_body_radps.x, x[state_index::P]);
        assert_eq!(state.pos_ned_m.z, x[state_index::DOWN]);
        assert_eq!(state.engine_power_pct, x[state_index::POWER]);
        assert_eq!(state.surfaces_rad.rudder_rad, x[state_index::RUDDER]);
        assert_eq!(state.to_vector(), x);
    }
}
