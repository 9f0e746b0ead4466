//! The drogue plane: where and how fast the probe tip crosses it.
//!
//! The drogue plane passes through the drogue centre normal to the tanker's x axis; the tip's
//! depth is the drogue's x minus the tip's. [`PlaneCrossing`] finds each crossing, either way,
//! by linear interpolation between two simulation samples (exact to the integration step, not
//! to the control step). Whether a crossing docked is the referee's decision
//! ([`crate::referee`]; definition in docs/paper.md, "What "docked" means", and
//! docs/models.md, "Docking check").
//!
//! Invariant: [`PlaneCrossing::observe`] reports each change of side once: from ahead of the
//! plane to at or behind it (inbound), and from behind it back to ahead (outbound).

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::referee::{CrossingRecord, CrossingVerdict};

/// The closing-speed band that opens the coupling without damage, m/s (about 1 to 5 knots).
pub const CLOSING_BAND_MPS: (f64, f64) = (0.5, 2.6);

/// Where and how fast the probe tip crossed the drogue plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Crossing {
    /// Time of the crossing, s.
    pub time_s: f64,
    /// Radial offset of the probe tip from the drogue centre in the plane, m.
    pub miss_m: f64,
    /// The tip relative to the drogue centre in the plane, seen from behind: right, up, m.
    pub offset_right_up_m: [f64; 2],
    /// Closing speed along the tanker x axis, m/s: positive inbound, negative outbound.
    pub closing_mps: f64,
}

/// What happened at the drogue plane, in short (a crossing and whether it docked).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Contact {
    /// Time of the crossing, s.
    pub time_s: f64,
    /// Radial offset of the probe tip from the drogue centre in the plane, m.
    pub miss_m: f64,
    /// Closing speed of the probe tip relative to the drogue along the tanker x axis, m/s.
    pub closure_mps: f64,
    /// The referee judged it a docking.
    pub docked: bool,
}

impl From<&CrossingRecord> for Contact {
    fn from(c: &CrossingRecord) -> Self {
        Self {
            time_s: c.time_s,
            miss_m: c.miss_m,
            closure_mps: c.closing_mps,
            docked: c.verdict == CrossingVerdict::Docked,
        }
    }
}

/// Watches the drogue-minus-probe-tip vector for crossings of the drogue plane.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PlaneCrossing {
    previous: Option<(f64, Vector3<f64>)>,
}

impl PlaneCrossing {
    /// Feeds one sample (`time`, drogue centre minus probe tip in tanker axes); returns the
    /// crossing when the depth went from positive to zero or below (inbound), or from zero or
    /// below to positive (outbound).
    pub fn observe(&mut self, time_s: f64, drogue_from_tip_m: Vector3<f64>) -> Option<Crossing> {
        let prev = self.previous.replace((time_s, drogue_from_tip_m));
        let (t0, r0) = prev?;
        let r1 = drogue_from_tip_m;
        let inbound = r0.x > 0.0 && r1.x <= 0.0;
        let outbound = r0.x <= 0.0 && r1.x > 0.0;
        if !(inbound || outbound) {
            return None;
        }
        let f = r0.x / (r0.x - r1.x);
        let at = r0 + (r1 - r0) * f;
        // The tip relative to the drogue is minus `at`: right is +y, up is -z.
        Some(Crossing {
            time_s: t0 + f * (time_s - t0),
            miss_m: at.y.hypot(at.z),
            offset_right_up_m: [-at.y, at.z],
            closing_mps: (r0.x - r1.x) / (time_s - t0),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolates_the_crossing_both_ways() {
        let mut c = PlaneCrossing::default();
        assert_eq!(c.observe(0.0, Vector3::new(0.01, 0.1, 0.0)), None);
        let hit = c.observe(0.01, Vector3::new(-0.01, 0.3, 0.0)).unwrap();
        assert!((hit.time_s - 0.005).abs() < 1e-12);
        assert!((hit.miss_m - 0.2).abs() < 1e-12);
        assert!((hit.closing_mps - 2.0).abs() < 1e-9);
        // Drogue 0.2 m right of the tip: the tip is 0.2 m left of the drogue.
        assert!((hit.offset_right_up_m[0] + 0.2).abs() < 1e-12);
        assert_eq!(
            c.observe(0.015, Vector3::new(-0.02, 0.3, 0.0)),
            None,
            "staying behind the plane is not another crossing"
        );
        let back = c.observe(0.025, Vector3::new(0.02, 0.0, -0.4)).unwrap();
        assert!(back.closing_mps < 0.0, "backing out: {back:?}");
        assert!((back.time_s - 0.02).abs() < 1e-12);
        // Drogue above the tip (z negative): the tip is below, `up` negative.
        assert!(back.offset_right_up_m[1] < 0.0);
        let again = c.observe(0.035, Vector3::new(-0.01, 0.0, 0.0));
        assert!(
            again
                .is_some_and(|a| a.closing_mps > 0.0
                    && (a.time_s - (0.025 + 0.01 * 2.0 / 3.0)).abs() < 1e-12),
            "came again: a second inbound crossing {again:?}"
        );
    }

    #[test]
    fn no_crossing_on_one_side() {
        let mut c = PlaneCrossing::default();
        for (k, x) in [3.0, 2.0, 1.0, 0.5, 0.1].into_iter().enumerate() {
            assert_eq!(c.observe(k as f64, Vector3::new(x, 0.0, 0.0)), None);
        }
    }
}
