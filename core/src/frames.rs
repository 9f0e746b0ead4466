//! Frame-tagged quantities that cross module boundaries.
//!
//! The frames (full definitions and figures in `docs/conventions.md`):
//! - **tanker** `t`: origin at the hose exit, x forward, y right, z down; moves with the tanker
//!   in straight and level flight, so it is inertial.
//! - **camera reference** `re`: axes of the camera at trim, x right, y down, z forward, so
//!   `re = (y_t, z_t, x_t)` (the paper's `R_c/t`, eq. (3)).
//! - **body** `b`: receiver body axes, x forward, y right, z down, origin at the CG.
//! - **image**: normalised image coordinates `(x_c / z_c, y_c / z_c)`, dimensionless.
//!
//! Invariant: a type's name says its frame; its fields say their units.

use serde::{Deserialize, Serialize};

/// A velocity in the camera reference frame `re` (x right, y down, z forward), m/s.
///
/// As a desired velocity it is the velocity of the camera *relative to the drogue*
/// (the paper's `v_d^c`); the inner loop tracks it with the camera velocity relative to the
/// tanker, treating the drogue's own motion as a disturbance (paper, after eq. (24)).
/// `z_fwd_mps > 0` closes on the drogue: depth obeys `dz/dt = -z_fwd_mps`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct VelocityRe {
    /// Toward the receiver's right (tanker +y), m/s.
    pub x_right_mps: f32,
    /// Downward (tanker +z), m/s.
    pub y_down_mps: f32,
    /// Forward, toward the drogue (tanker +x), m/s.
    pub z_fwd_mps: f32,
}

impl VelocityRe {
    /// Zero velocity: hold position relative to the tanker.
    pub const ZERO: Self = Self {
        x_right_mps: 0.0,
        y_down_mps: 0.0,
        z_fwd_mps: 0.0,
    };

    /// True when every component is finite.
    pub fn is_finite(&self) -> bool {
        self.x_right_mps.is_finite() && self.y_down_mps.is_finite() && self.z_fwd_mps.is_finite()
    }
}

/// Where the controller believes the drogue centre is, relative to the camera, in `re` axes.
///
/// IBVS derives it from the image error and depth (`offset = e * depth`); PBVS from its 3-D
/// reconstruction. The mode logic uses it for the terminal-phase entry and miss prediction.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TargetEstimate {
    /// Lateral offset of the drogue centre, positive to the right, m.
    pub right_m: f32,
    /// Vertical offset of the drogue centre, positive down, m.
    pub down_m: f32,
    /// Depth: distance from the camera (probe tip) to the drogue plane, forward, m.
    pub depth_m: f32,
}

impl TargetEstimate {
    /// Radial offset of the drogue centre from the camera boresight, m.
    pub fn radial_offset_m(&self) -> f32 {
        libm::hypotf(self.right_m, self.down_m)
    }
}
