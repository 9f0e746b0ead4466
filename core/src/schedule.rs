//! Gain schedule: the inner loops' design interpolated over the docking envelope.
//!
//! The design that [`crate::gains`] holds for one flight condition (trim, engine model, both
//! procedures' LQR gains, the latency predictor's plant) is also generated at every node of a
//! rectangular grid of true airspeed by altitude ([`crate::gains::SCHEDULE_SPEEDS_MPS`],
//! [`crate::gains::SCHEDULE_ALTITUDES_M`], [`crate::gains::SCHEDULE`]). [`design_at`]
//! interpolates it bilinearly in the cell that holds the condition: with `s` and `t` the
//! condition's fractions across the cell in speed and altitude, every number is
//!
//! ```text
//! (n00 (1 - s) + n10 s) (1 - t) + (n01 (1 - s) + n11 s) t
//! ```
//!
//! written so that `s` or `t` of exactly 0 or 1 leaves the node's value.
//!
//! The grid and why it is that fine are in `docs/conventions.md`, "Gain schedule": the
//! interpolated gains keep every channel stable at every point of the envelope the synthesis
//! was checked at, with about the design's own margin.
//!
//! Invariants: at a grid node the design is the node's, bit for bit; on a cell's edge both
//! cells give the same design (each blends only the two nodes of that edge); inside the grid
//! every blended number lies between its four nodes' values; a condition that is not finite
//! or is outside the grid (the docking envelope) has no design: a named [`ScheduleError`].

use serde::{Deserialize, Serialize};

pub use crate::design::DesignPoint;
use crate::gains::{self, SCHEDULE, SCHEDULE_ALTITUDES_M, SCHEDULE_SPEEDS_MPS};
use crate::inner::{ChannelGains, EngineModel, TrimPoint};
pub use crate::nav::FlightCondition;
use crate::predictor::PlantModel;

/// Why the schedule has no design for a condition.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ScheduleError {
    /// The airspeed or the altitude is NaN or infinite.
    NonFinite,
    /// The airspeed is below the envelope's lowest.
    AirspeedLow,
    /// The airspeed is above the envelope's highest.
    AirspeedHigh,
    /// The altitude is below the envelope's lowest.
    AltitudeLow,
    /// The altitude is above the envelope's highest.
    AltitudeHigh,
}

impl core::fmt::Display for ScheduleError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::NonFinite => "the flight condition is not finite",
            Self::AirspeedLow => "the airspeed is below the docking envelope",
            Self::AirspeedHigh => "the airspeed is above the docking envelope",
            Self::AltitudeLow => "the altitude is below the docking envelope",
            Self::AltitudeHigh => "the altitude is above the docking envelope",
        })
    }
}

impl core::error::Error for ScheduleError {}

/// The single-point design of [`crate::gains`] as a [`DesignPoint`]: the controller's
/// design until a navigation sample names another condition, and the schedule's node at
/// the default [`FlightCondition`] (tested).
pub const DESIGN: DesignPoint = DesignPoint {
    trim: gains::TRIM,
    engine: gains::ENGINE_MODEL,
    lon: gains::LON,
    lat: gains::LAT,
    refuel_lon: gains::REFUEL_LON,
    refuel_lat: gains::REFUEL_LAT,
    refuel_light_lon: gains::REFUEL_LIGHT_LON,
    refuel_light_lat: gains::REFUEL_LIGHT_LAT,
    predict_lon: gains::PREDICT_LON,
    predict_lat: gains::PREDICT_LAT,
};

impl Default for DesignPoint {
    /// [`DESIGN`], the single-point design.
    fn default() -> Self {
        DESIGN
    }
}

/// A value the schedule can blend: the four corners of a cell and their weights.
trait Blend: Sized {
    /// `n` is `[n00, n10, n01, n11]` (speed index first), `w` the cell fractions `(s, t)`.
    fn blend(n: [&Self; 4], w: (f32, f32)) -> Self;
}

impl Blend for f32 {
    fn blend(n: [&Self; 4], (s, t): (f32, f32)) -> Self {
        let low = *n[0] * (1.0 - s) + *n[1] * s;
        let high = *n[2] * (1.0 - s) + *n[3] * s;
        low * (1.0 - t) + high * t
    }
}

impl<T: Blend, const N: usize> Blend for [T; N] {
    fn blend(n: [&Self; 4], w: (f32, f32)) -> Self {
        core::array::from_fn(|i| T::blend([&n[0][i], &n[1][i], &n[2][i], &n[3][i]], w))
    }
}

/// Blends one field of four structs.
macro_rules! field {
    ($n:expr, $w:expr, $f:ident) => {
        Blend::blend([&$n[0].$f, &$n[1].$f, &$n[2].$f, &$n[3].$f], $w)
    };
}

impl Blend for TrimPoint {
    fn blend(n: [&Self; 4], w: (f32, f32)) -> Self {
        Self {
            speed_mps: field!(n, w, speed_mps),
            altitude_m: field!(n, w, altitude_m),
            alpha_rad: field!(n, w, alpha_rad),
            theta_rad: field!(n, w, theta_rad),
            throttle: field!(n, w, throttle),
            elevator_rad: field!(n, w, elevator_rad),
            aileron_rad: field!(n, w, aileron_rad),
            rudder_rad: field!(n, w, rudder_rad),
        }
    }
}

impl Blend for EngineModel {
    fn blend(n: [&Self; 4], w: (f32, f32)) -> Self {
        Self {
            pole: field!(n, w, pole),
            gain_pct: field!(n, w, gain_pct),
        }
    }
}

impl<const NX: usize, const NY: usize, const NU: usize> Blend for ChannelGains<NX, NY, NU> {
    fn blend(n: [&Self; 4], w: (f32, f32)) -> Self {
        Self {
            k_state: field!(n, w, k_state),
            k_actuator: field!(n, w, k_actuator),
            k_integral: field!(n, w, k_integral),
            c_cg: field!(n, w, c_cg),
        }
    }
}

impl<const NM: usize, const NE: usize, const NU: usize> Blend for PlantModel<NM, NE, NU> {
    fn blend(n: [&Self; 4], w: (f32, f32)) -> Self {
        Self {
            delta_mm: field!(n, w, delta_mm),
            phi_me: field!(n, w, phi_me),
            phi_ee: field!(n, w, phi_ee),
            gamma_m: field!(n, w, gamma_m),
            gamma_e: field!(n, w, gamma_e),
        }
    }
}

impl Blend for DesignPoint {
    fn blend(n: [&Self; 4], w: (f32, f32)) -> Self {
        Self {
            trim: field!(n, w, trim),
            engine: field!(n, w, engine),
            lon: field!(n, w, lon),
            lat: field!(n, w, lat),
            refuel_lon: field!(n, w, refuel_lon),
            refuel_lat: field!(n, w, refuel_lat),
            refuel_light_lon: field!(n, w, refuel_light_lon),
            refuel_light_lat: field!(n, w, refuel_light_lat),
            predict_lon: field!(n, w, predict_lon),
            predict_lat: field!(n, w, predict_lat),
        }
    }
}

/// The cell of a grid axis that holds `x` and `x`'s fraction across it, or which end of the
/// axis `x` is beyond. `x` must be finite. A node shared by two cells belongs to the lower
/// one, at fraction 1.
fn locate<const N: usize>(axis: &[f32; N], x: f32) -> Result<(usize, f32), Beyond> {
    let (Some(first), Some(last)) = (axis.first(), axis.last()) else {
        return Err(Beyond::Low);
    };
    if x < *first {
        return Err(Beyond::Low);
    }
    if x > *last {
        return Err(Beyond::High);
    }
    let mut cell = 0;
    for (k, hi) in axis.iter().enumerate().skip(1) {
        cell = k - 1;
        if x <= *hi {
            break;
        }
    }
    match (axis.get(cell), axis.get(cell + 1)) {
        (Some(lo), Some(hi)) => Ok((cell, (x - lo) / (hi - lo))),
        // A one-node axis: the node itself.
        _ => Ok((0, 0.0)),
    }
}

/// Which end of a grid axis a value is beyond.
enum Beyond {
    Low,
    High,
}

/// The envelope's corners: lowest and highest true airspeed (m/s) and altitude (m).
#[inline]
pub fn envelope() -> ([f32; 2], [f32; 2]) {
    let ends = |a: &[f32]| [a.first().copied(), a.last().copied()].map(|v| v.unwrap_or(f32::NAN));
    (ends(&SCHEDULE_SPEEDS_MPS), ends(&SCHEDULE_ALTITUDES_M))
}

/// Whether `condition` is inside the docking envelope (the grid's rectangle, edges
/// included), and which limit it is beyond if not: a few comparisons, no interpolation (the
/// controller's step asks this every step; [`design_at`] only when the condition changes).
#[inline]
pub fn check(condition: FlightCondition) -> Result<(), ScheduleError> {
    let FlightCondition {
        true_airspeed_mps: v,
        altitude_m: h,
    } = condition;
    let ([v_lo, v_hi], [h_lo, h_hi]) = envelope();
    if !(v.is_finite() && h.is_finite()) {
        Err(ScheduleError::NonFinite)
    } else if v < v_lo {
        Err(ScheduleError::AirspeedLow)
    } else if v > v_hi {
        Err(ScheduleError::AirspeedHigh)
    } else if h < h_lo {
        Err(ScheduleError::AltitudeLow)
    } else if h > h_hi {
        Err(ScheduleError::AltitudeHigh)
    } else {
        Ok(())
    }
}

/// The design at `condition`, interpolated in its cell of the grid.
pub fn design_at(condition: FlightCondition) -> Result<DesignPoint, ScheduleError> {
    let (corners, w) = cell(condition)?;
    Ok(DesignPoint::blend(corners, w))
}

/// The trim alone at `condition`: `design_at(condition)?.trim`, bit for bit, at a tenth of
/// its cost (for a navigation source that reports absolute angles and needs the trim they
/// are perturbations from every sample).
pub fn trim_at(condition: FlightCondition) -> Result<TrimPoint, ScheduleError> {
    let (n, w) = cell(condition)?;
    Ok(TrimPoint::blend(
        [&n[0].trim, &n[1].trim, &n[2].trim, &n[3].trim],
        w,
    ))
}

/// The four nodes of `condition`'s cell (`[n00, n10, n01, n11]`, speed index first) and its
/// fractions in the cell.
fn cell(
    condition: FlightCondition,
) -> Result<([&'static DesignPoint; 4], (f32, f32)), ScheduleError> {
    check(condition)?;
    let FlightCondition {
        true_airspeed_mps: v,
        altitude_m: h,
    } = condition;
    let (i, s) = locate(&SCHEDULE_SPEEDS_MPS, v).map_err(|b| match b {
        Beyond::Low => ScheduleError::AirspeedLow,
        Beyond::High => ScheduleError::AirspeedHigh,
    })?;
    let (j, t) = locate(&SCHEDULE_ALTITUDES_M, h).map_err(|b| match b {
        Beyond::Low => ScheduleError::AltitudeLow,
        Beyond::High => ScheduleError::AltitudeHigh,
    })?;
    let node = |j: usize, i: usize| SCHEDULE.get(j).and_then(|row| row.get(i));
    let i1 = (i + 1).min(SCHEDULE_SPEEDS_MPS.len() - 1);
    let j1 = (j + 1).min(SCHEDULE_ALTITUDES_M.len() - 1);
    match (node(j, i), node(j, i1), node(j1, i), node(j1, i1)) {
        (Some(n00), Some(n10), Some(n01), Some(n11)) => Ok(([n00, n10, n01, n11], (s, t))),
        // `locate` keeps both indices inside the grid; unreachable, refused rather than
        // panicking.
        _ => Err(ScheduleError::NonFinite),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(v: f32, h: f32) -> Result<DesignPoint, ScheduleError> {
        design_at(FlightCondition {
            true_airspeed_mps: v,
            altitude_m: h,
        })
    }

    #[test]
    fn at_every_grid_node_the_design_is_the_nodes_bit_for_bit() {
        for (j, &h) in SCHEDULE_ALTITUDES_M.iter().enumerate() {
            for (i, &v) in SCHEDULE_SPEEDS_MPS.iter().enumerate() {
                assert_eq!(at(v, h), Ok(SCHEDULE[j][i]), "node {v} m/s, {h} m");
            }
        }
    }

    #[test]
    fn the_trim_alone_is_the_designs_trim_bit_for_bit() {
        let (v, h) = envelope();
        for k in 0..=20 {
            for l in 0..=20 {
                let c = FlightCondition {
                    true_airspeed_mps: v[0] + (v[1] - v[0]) * k as f32 / 20.0,
                    altitude_m: h[0] + (h[1] - h[0]) * l as f32 / 20.0,
                };
                assert_eq!(trim_at(c), design_at(c).map(|d| d.trim), "{c:?}");
            }
        }
        let below = FlightCondition {
            true_airspeed_mps: v[0] - 1.0,
            altitude_m: h[0],
        };
        assert_eq!(trim_at(below), Err(ScheduleError::AirspeedLow));
    }

    #[test]
    fn the_single_point_design_is_the_schedules_node_at_its_condition() {
        assert_eq!(design_at(FlightCondition::default()), Ok(DESIGN));
        let d = at(gains::TRIM.speed_mps, gains::TRIM.altitude_m).unwrap();
        assert_eq!(d.trim, gains::TRIM);
        assert_eq!(d.engine, gains::ENGINE_MODEL);
        assert_eq!(d.lon, gains::LON);
        assert_eq!(d.lat, gains::LAT);
        assert_eq!(d.refuel_lon, gains::REFUEL_LON);
        assert_eq!(d.refuel_lat, gains::REFUEL_LAT);
        assert_eq!(d.refuel_light_lon, gains::REFUEL_LIGHT_LON);
        assert_eq!(d.refuel_light_lat, gains::REFUEL_LIGHT_LAT);
        assert_eq!(d.predict_lon, gains::PREDICT_LON);
        assert_eq!(d.predict_lat, gains::PREDICT_LAT);
    }

    /// Largest absolute difference over a few of the design's numbers (the trim, every
    /// gain of both refuelling channels).
    fn distance(a: &DesignPoint, b: &DesignPoint) -> f32 {
        let mut d = [
            a.trim.alpha_rad - b.trim.alpha_rad,
            a.trim.throttle - b.trim.throttle,
            a.trim.elevator_rad - b.trim.elevator_rad,
        ]
        .map(f32::abs)
        .into_iter()
        .fold(0.0, f32::max);
        for (ra, rb) in a.refuel_lon.k_state.iter().zip(&b.refuel_lon.k_state) {
            for (x, y) in ra.iter().zip(rb) {
                d = d.max((x - y).abs());
            }
        }
        for (ra, rb) in a.refuel_lat.k_state.iter().zip(&b.refuel_lat.k_state) {
            for (x, y) in ra.iter().zip(rb) {
                d = d.max((x - y).abs());
            }
        }
        d
    }

    #[test]
    fn the_design_is_continuous_across_every_cell_edge() {
        // Just either side of every inner grid line, at several points along it: the two
        // cells' designs differ by no more than the slope over the step allows. The largest
        // gain changes by about 20 per 1,000 m or per 25 m/s between nodes; a step of one
        // ulp-scaled millimetre or micro-metre-per-second changes it by far less than 1e-3.
        let (speeds, alts) = (SCHEDULE_SPEEDS_MPS, SCHEDULE_ALTITUDES_M);
        for &v in &speeds[1..speeds.len() - 1] {
            for &h in &[600.0, 3000.0, 4321.0, 7900.0] {
                let below = at(v.next_down(), h).unwrap();
                let above = at(v.next_up(), h).unwrap();
                let on = at(v, h).unwrap();
                assert!(
                    distance(&below, &on) < 1e-3 && distance(&above, &on) < 1e-3,
                    "{v} m/s, {h} m"
                );
            }
        }
        for &h in &alts[1..alts.len() - 1] {
            for &v in &[101.0, 120.0, 133.3, 169.0] {
                let below = at(v, h.next_down()).unwrap();
                let above = at(v, h.next_up()).unwrap();
                let on = at(v, h).unwrap();
                assert!(
                    distance(&below, &on) < 1e-3 && distance(&above, &on) < 1e-3,
                    "{v} m/s, {h} m"
                );
            }
        }
    }

    #[test]
    fn inside_a_cell_every_number_lies_between_its_nodes() {
        let d = at(131.0, 4200.0).unwrap();
        let (i, j) = (1, 1); // 120..145 m/s, 3000..5500 m
        let corners = [
            SCHEDULE[j][i],
            SCHEDULE[j][i + 1],
            SCHEDULE[j + 1][i],
            SCHEDULE[j + 1][i + 1],
        ];
        let check = |name: &str, x: f32, c: [f32; 4]| {
            let lo = c.iter().copied().fold(f32::INFINITY, f32::min);
            let hi = c.iter().copied().fold(f32::NEG_INFINITY, f32::max);
            assert!(
                x >= lo - 1e-6 * lo.abs() && x <= hi + 1e-6 * hi.abs(),
                "{name}: {x} outside {lo}..{hi}"
            );
        };
        check("alpha", d.trim.alpha_rad, corners.map(|c| c.trim.alpha_rad));
        check(
            "throttle",
            d.trim.throttle,
            corners.map(|c| c.trim.throttle),
        );
        for r in 0..2 {
            for c in 0..5 {
                check(
                    "refuel lon k",
                    d.refuel_lon.k_state[r][c],
                    corners.map(|n| n.refuel_lon.k_state[r][c]),
                );
                check(
                    "refuel lat k",
                    d.refuel_lat.k_state[r][c],
                    corners.map(|n| n.refuel_lat.k_state[r][c]),
                );
                check(
                    "refuel light lon k",
                    d.refuel_light_lon.k_state[r][c],
                    corners.map(|n| n.refuel_light_lon.k_state[r][c]),
                );
                check(
                    "refuel light lat k",
                    d.refuel_light_lat.k_state[r][c],
                    corners.map(|n| n.refuel_light_lat.k_state[r][c]),
                );
            }
        }
        // And it is not simply a node: the condition is inside the cell.
        assert!(corners.iter().all(|c| c.trim.alpha_rad != d.trim.alpha_rad));
    }

    #[test]
    fn outside_the_envelope_or_not_finite_there_is_no_design_and_the_reason_is_named() {
        let ([v_lo, v_hi], [h_lo, h_hi]) = envelope();
        let (v, h) = (0.5 * (v_lo + v_hi), 0.5 * (h_lo + h_hi));
        assert_eq!(at(v_lo.next_down(), h), Err(ScheduleError::AirspeedLow));
        assert_eq!(at(v_hi.next_up(), h), Err(ScheduleError::AirspeedHigh));
        assert_eq!(at(v, h_lo.next_down()), Err(ScheduleError::AltitudeLow));
        assert_eq!(at(v, h_hi.next_up()), Err(ScheduleError::AltitudeHigh));
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            assert_eq!(at(bad, h), Err(ScheduleError::NonFinite));
            assert_eq!(at(v, bad), Err(ScheduleError::NonFinite));
        }
        // `check` answers as `design_at` does, without interpolating.
        for (v, h) in [
            (v_lo.next_down(), h),
            (v_hi.next_up(), h),
            (v, h_lo.next_down()),
            (v, h_hi.next_up()),
            (f32::NAN, h),
            (v, h),
        ] {
            let c = FlightCondition {
                true_airspeed_mps: v,
                altitude_m: h,
            };
            assert_eq!(check(c), design_at(c).map(|_| ()), "{v} m/s, {h} m");
        }
        // The corners themselves are inside.
        for (v, h) in [(v_lo, h_lo), (v_lo, h_hi), (v_hi, h_lo), (v_hi, h_hi)] {
            assert!(at(v, h).is_ok(), "{v} m/s, {h} m");
        }
    }
}
