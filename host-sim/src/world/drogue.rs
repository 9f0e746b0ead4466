//! The ideal world's drogue: held at its nominal steady trail position. The full world's
//! drogue is the last node of the multi-link hose (`world::hose`), behind the same interface.
//!
//! Invariant: positions are in the tanker frame (x forward, y right, z down), metres.

use nalgebra::Vector3;

/// Nominal drogue position behind the tanker (steady trail of the hose), tanker frame, m
/// (docs/models.md, "Flight condition and frames"; from the authors' simulation).
pub const NOMINAL_DROGUE_TANKER_M: [f64; 3] = [-14.35, 0.0, 5.12];

/// Capture radius of the drogue around its centre, m (the authors' docking check).
pub const CAPTURE_RADIUS_M: f64 = 0.3;

/// A drogue fixed in the tanker frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FixedDrogue {
    /// Drogue centre (the capture plane's centre), tanker frame, m.
    pub centre_tanker_m: Vector3<f64>,
}

impl Default for FixedDrogue {
    fn default() -> Self {
        Self {
            centre_tanker_m: Vector3::from(NOMINAL_DROGUE_TANKER_M),
        }
    }
}

impl FixedDrogue {
    /// Drogue centre at time `t_s`, tanker frame, m.
    pub fn centre_tanker_m(&self, _t_s: f64) -> Vector3<f64> {
        self.centre_tanker_m
    }
}
