//! The docking check: when the probe tip reaches the drogue's capture plane, was it a dock?
//!
//! Definition (docs/paper.md, "What "docked" means"; docs/models.md, "Docking check"): at the
//! first instant the probe tip reaches the drogue plane (depth, drogue x minus probe-tip x in the
//! tanker frame, crosses zero), the run docks when the radial offset of the tip from the
//! drogue centre is below the capture radius and the closing speed is inside the band that
//! opens the coupling without damage. Anything else is a miss.
//!
//! The crossing instant is found by linear interpolation between two simulation samples, so
//! the check is exact to the integration step, not to the control step.
//!
//! Invariant: [`PlaneCrossing::observe`] reports each crossing from ahead of the plane to at
//! or behind it once (a probe that backs off and comes again crosses again).

use nalgebra::Vector3;
use serde::Serialize;

/// The closing-speed band that opens the coupling without damage, m/s (about 1 to 5 knots).
pub const CLOSING_BAND_MPS: (f64, f64) = (0.5, 2.6);

/// Clearance from the drogue centre below which passing the drogue plane faster than the
/// closing band is unsafe even after a breakaway, m: one canopy diameter (0.6096 m,
/// docs/models.md, "Hose and drogue"), so the probe passes clear of the canopy's rim.
pub const FAST_PASS_CLEARANCE_M: f64 = 0.6096;

/// What happened at the drogue plane.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Contact {
    /// Time of the crossing, s.
    pub time_s: f64,
    /// Radial offset of the probe tip from the drogue centre in the plane, m.
    pub miss_m: f64,
    /// Closing speed of the probe tip relative to the drogue along the tanker x axis, m/s.
    pub closure_mps: f64,
    /// Whether it docked (offset inside the capture radius and closing speed in the band).
    pub docked: bool,
}

/// Watches the drogue-minus-probe-tip vector for crossings of the drogue plane.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PlaneCrossing {
    previous: Option<(f64, Vector3<f64>)>,
}

impl PlaneCrossing {
    /// Feeds one sample (`time`, drogue centre minus probe tip in tanker axes); returns the
    /// contact at every sample whose depth is at or below zero after a positive one.
    pub fn observe(
        &mut self,
        time_s: f64,
        drogue_from_tip_m: Vector3<f64>,
        capture_radius_m: f64,
    ) -> Option<Contact> {
        let prev = self.previous.replace((time_s, drogue_from_tip_m));
        let (t0, r0) = prev?;
        if !(r0.x > 0.0 && drogue_from_tip_m.x <= 0.0) {
            return None;
        }
        let f = r0.x / (r0.x - drogue_from_tip_m.x);
        let at = r0 + (drogue_from_tip_m - r0) * f;
        let miss_m = at.y.hypot(at.z);
        let closure_mps = (r0.x - drogue_from_tip_m.x) / (time_s - t0);
        let docked = miss_m < capture_radius_m
            && (CLOSING_BAND_MPS.0..=CLOSING_BAND_MPS.1).contains(&closure_mps);
        Some(Contact {
            time_s: t0 + f * (time_s - t0),
            miss_m,
            closure_mps,
            docked,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolates_the_crossing() {
        let mut c = PlaneCrossing::default();
        assert_eq!(c.observe(0.0, Vector3::new(0.01, 0.1, 0.0), 0.3), None);
        let hit = c.observe(0.01, Vector3::new(-0.01, 0.3, 0.0), 0.3).unwrap();
        assert!((hit.time_s - 0.005).abs() < 1e-12);
        assert!((hit.miss_m - 0.2).abs() < 1e-12);
        assert!((hit.closure_mps - 2.0).abs() < 1e-9);
        assert!(hit.docked);
        assert_eq!(
            c.observe(0.015, Vector3::new(-0.02, 0.3, 0.0), 0.3),
            None,
            "staying behind the plane is not another crossing"
        );
        assert_eq!(c.observe(0.02, Vector3::new(0.01, 0.0, 0.0), 0.3), None);
        let again = c.observe(0.03, Vector3::new(-0.01, 0.0, 0.0), 0.3);
        assert!(
            again.is_some_and(|a| a.docked && (a.time_s - 0.025).abs() < 1e-12),
            "backed off and came again: a second crossing"
        );
    }

    #[test]
    fn outside_the_radius_or_the_band_is_a_miss() {
        let wide = PlaneCrossing::default().observe(0.0, Vector3::new(0.01, 0.31, 0.0), 0.3);
        assert_eq!(wide, None);
        let mut c = PlaneCrossing::default();
        c.observe(0.0, Vector3::new(0.01, 0.31, 0.0), 0.3);
        assert!(
            !c.observe(0.01, Vector3::new(-0.01, 0.31, 0.0), 0.3)
                .unwrap()
                .docked
        );
        let mut fast = PlaneCrossing::default();
        fast.observe(0.0, Vector3::new(0.02, 0.0, 0.0), 0.3);
        assert!(
            !fast
                .observe(0.01, Vector3::new(-0.02, 0.0, 0.0), 0.3)
                .unwrap()
                .docked,
            "4 m/s"
        );
        let mut slow = PlaneCrossing::default();
        slow.observe(0.0, Vector3::new(0.002, 0.0, 0.0), 0.3);
        assert!(
            !slow
                .observe(0.01, Vector3::new(-0.002, 0.0, 0.0), 0.3)
                .unwrap()
                .docked,
            "0.4 m/s"
        );
    }
}
