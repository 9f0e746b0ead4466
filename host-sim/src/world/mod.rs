//! The world around the receiver: the tanker and its frame, the air (turbulence, wake), the
//! hose and drogue (with the bow wave on it), the camera that sees the drogue and the
//! navigation system that measures the receiver. [`World`] composes them for one run.
//!
//! Frames (`docs/conventions.md`): NED is the inertial frame of the simulation; the tanker
//! flies north, level, at constant speed, so the tanker frame has NED's axes and its origin
//! (the hose exit) moves north at the tanker speed. Air-mass velocities (gusts, wake) are in
//! tanker axes, which are NED axes, so they are the receiver's wind as they are.
//!
//! Invariant: each model here is a pure function of the truth it is given plus its own
//! seeded state, so a run is reproducible.

pub mod bow_wave;
pub mod camera;
pub mod drogue;
pub mod faults;
pub mod flight;
pub mod hose;
pub mod led_camera;
pub mod lens;
pub mod nav;
pub mod turbulence;
pub mod wake;

use ibvs_core::measurement::CameraMeasurement;
use nalgebra::{Matrix3, Rotation3, Vector3};

use crate::receiver::{ReceiverState, Wind};
use camera::PinholeCamera;
use drogue::FixedDrogue;
use hose::HoseDrogue;
use led_camera::{CameraPose, LedCamera};
use turbulence::{GustField, samples_per_step};
use wake::TankerWake;

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

/// Rotation from camera axes (x right, y down, z boresight) to body axes for a boresight
/// pitched down by `pitch_down_rad` (the same mount as [`ibvs_core::kinematics::body_from_camera`]).
pub fn body_from_camera(pitch_down_rad: f64) -> Rotation3<f64> {
    let (s, c) = pitch_down_rad.sin_cos();
    Rotation3::from_matrix_unchecked(Matrix3::new(0.0, -s, c, 1.0, 0.0, 0.0, 0.0, c, s))
}

/// The camera's true mount on the receiver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mount {
    /// Optical centre relative to the CG, body axes, m.
    pub position_body_m: Vector3<f64>,
    /// Boresight pitched down from the body x axis, rad.
    pub pitch_down_rad: f64,
}

/// The drogue model of a run.
#[derive(Debug, Clone)]
pub enum Drogue {
    /// Held at its nominal trail.
    Fixed(FixedDrogue),
    /// Multi-link hose and drogue.
    Hose(Box<HoseDrogue>),
}

/// The camera model of a run.
#[derive(Debug, Clone)]
pub enum Camera {
    /// Ideal pinhole, exact image point and depth.
    Ideal(PinholeCamera),
    /// LED ring, noise, circle fit, latency.
    Led(Box<LedCamera>),
}

/// Bow-wave reference point: the receiver's nose, relative to its CG, tanker axes, m
/// (docs/models.md, "Bow wave").
pub const BOW_WAVE_NOSE_FROM_CG_M: [f64; 3] = [3.75, 0.0, -0.86];

/// Receiver span and length for the wake's rotation rates (F-16: 9.45 m, 15.0 m).
const RECEIVER_SPAN_M: f64 = 9.45;
const RECEIVER_LENGTH_M: f64 = 15.0;

/// Gust plus wake at a tanker-frame point, tanker axes, m/s (zero for what is off).
fn disturbance(
    gusts: Option<&GustField>,
    wake: Option<&TankerWake>,
    p: &Vector3<f64>,
) -> Vector3<f64> {
    let gust = gusts.map_or_else(Vector3::zeros, |g| g.gust_at_tanker_mps(p.x));
    gust + wake.map_or_else(Vector3::zeros, |w| w.velocity_tanker_mps(p))
}

/// Everything around the receiver during one run.
#[derive(Debug, Clone)]
pub struct World {
    /// The tanker.
    pub tanker: Tanker,
    /// The drogue.
    pub drogue: Drogue,
    /// The camera.
    pub camera: Camera,
    /// Where the camera really is.
    pub mount: Mount,
    /// Turbulence, when on.
    pub gusts: Option<GustField>,
    /// Tanker wake, when on.
    pub wake: Option<TankerWake>,
    /// Bow wave on the drogue, when on.
    pub bow_wave: bool,
    /// Factor on the bow wave's force: the dynamic pressure over the default condition's
    /// ([`flight::FlightCondition::bow_wave_scale`]; 1 there).
    pub bow_wave_scale: f64,
}

impl World {
    /// Air-mass velocity at a tanker-frame point now (gust plus wake), tanker axes, m/s.
    pub fn disturbance_tanker_mps(&self, p: &Vector3<f64>) -> Vector3<f64> {
        disturbance(self.gusts.as_ref(), self.wake.as_ref(), p)
    }

    /// The wind the receiver flies in: the disturbance at its CG, and the wake's rotation.
    pub fn receiver_wind(&self, x: &ReceiverState, t_s: f64) -> Wind {
        let cg = point_in_tanker_m(&self.tanker, x, &Vector3::zeros(), t_s);
        let rotation = self.wake.as_ref().map_or_else(Vector3::zeros, |w| {
            w.angular_rate_tanker_radps(&cg, RECEIVER_SPAN_M, RECEIVER_LENGTH_M)
        });
        Wind {
            velocity_ned_mps: self.disturbance_tanker_mps(&cg),
            angular_rate_ned_radps: rotation,
        }
    }

    /// Drogue centre, tanker frame, m.
    pub fn drogue_centre_tanker_m(&self) -> Vector3<f64> {
        match &self.drogue {
            Drogue::Fixed(d) => d.centre_tanker_m,
            Drogue::Hose(h) => h.drogue_centre_tanker_m(),
        }
    }

    /// Drogue axis (from the hose toward the drogue), tanker frame, unit.
    pub fn drogue_axis_tanker(&self) -> Vector3<f64> {
        match &self.drogue {
            Drogue::Fixed(_) => -Vector3::x(),
            Drogue::Hose(h) => h.drogue_axis_tanker(),
        }
    }

    /// Bow-wave force on the drogue for the receiver at `x`, tanker axes, N (zero when off).
    pub fn bow_wave_force_n(&self, x: &ReceiverState, t_s: f64) -> Vector3<f64> {
        if !self.bow_wave {
            return Vector3::zeros();
        }
        let nose = point_in_tanker_m(&self.tanker, x, &Vector3::zeros(), t_s)
            + Vector3::from(BOW_WAVE_NOSE_FROM_CG_M);
        let force = bow_wave::bow_wave_force_tanker_n(&(self.drogue_centre_tanker_m() - nose));
        // At the default condition the scale is 1 and the force is the fit's, bit for bit.
        if self.bow_wave_scale == 1.0 {
            force
        } else {
            force * self.bow_wave_scale
        }
    }

    /// Advances the air and the hose by `dt_s` (the receiver at `x` for the bow wave), ending
    /// at time `t_s + dt_s`: the gusts by [`samples_per_step`] samples (their field was built
    /// at that fraction of the step), then the hose in the air at the step's end.
    pub fn step(&mut self, dt_s: f64, x: &ReceiverState, t_s: f64) {
        let force = self.bow_wave_force_n(x, t_s);
        if let Some(g) = self.gusts.as_mut() {
            for _ in 0..samples_per_step(dt_s) {
                g.advance();
            }
        }
        if let Drogue::Hose(h) = &mut self.drogue {
            let (gusts, wake, free_stream) = (
                self.gusts.as_ref(),
                self.wake.as_ref(),
                Vector3::new(-self.tanker.speed_mps, 0.0, 0.0),
            );
            let air = |p: &Vector3<f64>| free_stream + disturbance(gusts, wake, p);
            h.step(dt_s, &air, &force);
        }
    }

    /// The camera's pose for the receiver at `x`.
    pub fn camera_pose(&self, x: &ReceiverState, t_s: f64) -> CameraPose {
        CameraPose {
            position_tanker_m: point_in_tanker_m(&self.tanker, x, &self.mount.position_body_m, t_s),
            tanker_from_camera: ned_from_body(x) * body_from_camera(self.mount.pitch_down_rad),
        }
    }

    /// Hides the LEDs whose bits are set in `mask` from the LED camera (fault injection;
    /// the ideal camera has no LEDs and ignores it).
    pub fn set_led_occlusion(&mut self, mask: u32) {
        if let Camera::Led(c) = &mut self.camera {
            c.set_occlusion(mask);
        }
    }

    /// What the flight computer receives from the camera at control time `t_s`.
    pub fn capture(&mut self, x: &ReceiverState, t_s: f64) -> CameraMeasurement {
        let pose = self.camera_pose(x, t_s);
        let (centre, axis) = (self.drogue_centre_tanker_m(), self.drogue_axis_tanker());
        match &mut self.camera {
            Camera::Ideal(c) => c.capture(&pose, &centre),
            Camera::Led(c) => {
                c.update(t_s, &pose, &centre, &axis);
                c.latest()
            }
        }
    }
}
