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

/// Rotation from the axes of a camera misaligned on its mount to the axes it was meant to
/// have (both camera axes: x right, y down, z boresight): yawed by `yaw_rad` about the
/// intended y axis (positive turns the boresight right), then rolled by `roll_rad` about the
/// resulting boresight (positive turns the image's right side down), the signs of an
/// aircraft's yaw and roll.
pub fn camera_misalignment(roll_rad: f64, yaw_rad: f64) -> Rotation3<f64> {
    Rotation3::from_axis_angle(&Vector3::y_axis(), yaw_rad)
        * Rotation3::from_axis_angle(&Vector3::z_axis(), roll_rad)
}

/// The camera's true mount on the receiver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mount {
    /// Optical centre relative to the CG, body axes, m.
    pub position_body_m: Vector3<f64>,
    /// Boresight pitched down from the body x axis, rad.
    pub pitch_down_rad: f64,
    /// Roll of the camera about its boresight, true minus intended, rad
    /// ([`camera_misalignment`]).
    pub roll_error_rad: f64,
    /// Yaw of the camera's boresight, true minus intended, rad (positive right;
    /// [`camera_misalignment`]).
    pub yaw_error_rad: f64,
}

impl Mount {
    /// Rotation from the camera's true axes to body axes: the pitched mount
    /// ([`body_from_camera`]), then the roll and yaw misalignment. Exactly
    /// [`body_from_camera`] of the pitch when both are zero.
    pub fn body_from_camera(&self) -> Rotation3<f64> {
        let mount = body_from_camera(self.pitch_down_rad);
        if self.roll_error_rad == 0.0 && self.yaw_error_rad == 0.0 {
            mount
        } else {
            mount * camera_misalignment(self.roll_error_rad, self.yaw_error_rad)
        }
    }
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
    /// ([`flight::FlightCondition::bow_wave_scale`]; 1 there) times the scenario's bow-wave
    /// strength (1 by default).
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

    /// Drogue velocity, tanker frame, m/s (zero for a fixed drogue).
    pub fn drogue_velocity_tanker_mps(&self) -> Vector3<f64> {
        match &self.drogue {
            Drogue::Fixed(_) => Vector3::zeros(),
            Drogue::Hose(h) => h.drogue_velocity_tanker_mps(),
        }
    }

    /// The hose's nodes from the exit to the drogue centre, tanker frame, m (none for a fixed
    /// drogue, which has no hose).
    pub fn hose_nodes_tanker_m(&self) -> &[Vector3<f64>] {
        match &self.drogue {
            Drogue::Fixed(_) => &[],
            Drogue::Hose(h) => h.node_positions_tanker_m(),
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
            tanker_from_camera: ned_from_body(x) * self.mount.body_from_camera(),
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

#[cfg(test)]
mod tests {
    use super::*;
    use camera::CameraParams;

    /// Where the ideal camera on `mount`, on a receiver with body axes along the tanker's at
    /// the origin, sees a point that a camera on the intended mount sees at normalised
    /// `(x, y)`, 6 m deep.
    fn seen(mount: &Mount, x: f64, y: f64) -> (f64, f64) {
        let intended = Mount {
            roll_error_rad: 0.0,
            yaw_error_rad: 0.0,
            ..*mount
        };
        let point = intended.body_from_camera() * Vector3::new(x * 6.0, y * 6.0, 6.0);
        let pose = CameraPose {
            position_tanker_m: Vector3::zeros(),
            tanker_from_camera: mount.body_from_camera(),
        };
        let m = PinholeCamera::new(CameraParams::default()).capture(&pose, &point);
        assert!(m.tracked);
        (f64::from(m.image_x), f64::from(m.image_y))
    }

    /// A roll error rotates the image about its centre by minus the roll; a yaw error moves
    /// a point on the intended boresight to `x = -tan(yaw)`; none is the pitched mount.
    #[test]
    fn a_mount_roll_or_yaw_error_rotates_the_image_as_predicted() {
        let mount = |roll_deg: f64, yaw_deg: f64| Mount {
            position_body_m: Vector3::zeros(),
            pitch_down_rad: 0.11,
            roll_error_rad: roll_deg.to_radians(),
            yaw_error_rad: yaw_deg.to_radians(),
        };
        assert_eq!(mount(0.0, 0.0).body_from_camera(), body_from_camera(0.11));
        let (x, y) = (0.2, -0.1);
        for roll in [0.5_f64, -3.0] {
            let (xr, yr) = seen(&mount(roll, 0.0), x, y);
            let (s, c) = roll.to_radians().sin_cos();
            assert!((xr - (x * c + y * s)).abs() < 1e-6, "{roll}: {xr}");
            assert!((yr - (-x * s + y * c)).abs() < 1e-6, "{roll}: {yr}");
        }
        for yaw in [0.5_f64, -2.0] {
            let (xr, yr) = seen(&mount(0.0, yaw), 0.0, 0.0);
            assert!((xr + yaw.to_radians().tan()).abs() < 1e-6, "{yaw}: {xr}");
            assert!(yr.abs() < 1e-7, "{yaw}: {yr}");
        }
        // Both: yaw first, then roll about the yawed boresight.
        let (xr, yr) = seen(&mount(1.0, 1.0), 0.0, 0.0);
        let (s, c) = 1f64.to_radians().sin_cos();
        let t = -1f64.to_radians().tan();
        assert!(
            (xr - t * c).abs() < 1e-6 && (yr + t * s).abs() < 1e-6,
            "{xr}, {yr}"
        );
    }
}
