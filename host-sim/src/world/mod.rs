//! The world around the receiver: the tanker and its frame, the drogue, the camera that sees
//! it and the navigation system that measures the receiver.
//!
//! Frames (`docs/conventions.md`): NED is the inertial frame of the simulation; the tanker
//! flies north, level, at constant speed, so the tanker frame has NED's axes and its origin
//! (the hose exit) moves north at the tanker speed.
//!
//! Invariant: each model here is a pure function of the truth it is given plus its own
//! seeded state, so a run is reproducible.

pub mod bow_wave;
pub mod camera;
pub mod drogue;
pub mod hose;
pub mod led_camera;
pub mod nav;
pub mod turbulence;
pub mod wake;

use nalgebra::{Rotation3, Vector3};

use crate::receiver::ReceiverState;

/// The tanker: straight and level northward flight.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tanker {
    /// Ground speed (north), m/s.
    pub speed_mps: f64,
    /// Altitude of the tanker frame origin (the hose exit), m.
    pub altitude_m: f64,
}

impl Tanker {
    /// Origin of the tanker frame in NED at time `t_s` (north = 0 at t = 0).
    pub fn origin_ned_m(&self, t_s: f64) -> Vector3<f64> {
        Vector3::new(self.speed_mps * t_s, 0.0, -self.altitude_m)
    }

    /// A NED position expressed in the tanker frame at time `t_s`.
    pub fn to_tanker_m(&self, p_ned_m: &Vector3<f64>, t_s: f64) -> Vector3<f64> {
        p_ned_m - self.origin_ned_m(t_s)
    }

    /// A tanker-frame position expressed in NED at time `t_s`.
    pub fn to_ned_m(&self, p_tanker_m: &Vector3<f64>, t_s: f64) -> Vector3<f64> {
        p_tanker_m + self.origin_ned_m(t_s)
    }
}

/// Rotation from body axes to NED (= tanker) axes for the receiver's attitude.
pub fn ned_from_body(x: &ReceiverState) -> Rotation3<f64> {
    let e = x.euler_rad;
    Rotation3::from_euler_angles(e.x, e.y, e.z)
}

/// Position of a point fixed on the receiver (`p_body_m`, from the CG) in the tanker frame.
pub fn point_in_tanker_m(
    tanker: &Tanker,
    x: &ReceiverState,
    p_body_m: &Vector3<f64>,
    t_s: f64,
) -> Vector3<f64> {
    tanker.to_tanker_m(&(x.pos_ned_m + ned_from_body(x) * p_body_m), t_s)
}
