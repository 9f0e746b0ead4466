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
    /// The airspeed is below the docking envelope's lowest for the receiver's configured gross
    /// mass: its 1 g angle of attack there leaves less than [`LOAD_FACTOR_RESERVE`] to
    /// [`ANGLE_OF_ATTACK_LIMIT_RAD`] ([`MassEnvelope`]).
    AngleOfAttackHigh,
}

impl core::fmt::Display for ScheduleError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::NonFinite => "the flight condition is not finite",
            Self::AirspeedLow => "the airspeed is below the docking envelope",
            Self::AirspeedHigh => "the airspeed is above the docking envelope",
            Self::AltitudeLow => "the altitude is below the docking envelope",
            Self::AltitudeHigh => "the altitude is above the docking envelope",
            Self::AngleOfAttackHigh => {
                "the airspeed is too low for the receiver's gross mass: its angle of attack at 1 g \
                 leaves too little to the limit"
            }
        })
    }
}

impl core::error::Error for ScheduleError {}

/// The largest angle of attack the refuelling procedure may fly, rad: 20 degrees (ours: the
/// F-16's flight-control system limits the angle of attack to 25 degrees in its cruise
/// configuration, and the limiter itself overshoots by a few degrees in a sharp pull; the
/// same figure the simulator's referee judges by, reasoned independently).
pub const ANGLE_OF_ATTACK_LIMIT_RAD: f32 = 20.0 * core::f32::consts::PI / 180.0;

/// The load factor the receiver must be able to pull at the docking condition before its
/// angle of attack reaches [`ANGLE_OF_ATTACK_LIMIT_RAD`] (ours: 1 g of level flight, the
/// vertical gust of three standard deviations of the strongest air the campaigns fly,
/// MIL-F-8785C's light turbulence at high altitude, 2.2 m/s: 3.8 degrees, about 0.3 g at the
/// envelope's slowest docking speed, and 0.2 g for the procedure's own manoeuvres;
/// `docs/conventions.md`, "The docking envelope by gross mass").
pub const LOAD_FACTOR_RESERVE: f32 = 1.5;

/// The receiver's angle of attack in level flight (1 g) at a trim of the schedule when its
/// gross mass is `mass_factor` times the design's, rad: the lift, and so the angle from the
/// lift's zero angle ([`crate::gains::ZERO_LIFT_ALPHA_RAD`]), grows with the weight carried.
#[inline]
pub fn level_angle_of_attack_rad(trim_alpha_rad: f32, mass_factor: f32) -> f32 {
    let zero = gains::ZERO_LIFT_ALPHA_RAD;
    zero + mass_factor * (trim_alpha_rad - zero)
}

/// The largest 1 g angle of attack the docking envelope admits, rad: the one from which a
/// pull of [`LOAD_FACTOR_RESERVE`] reaches [`ANGLE_OF_ATTACK_LIMIT_RAD`] (the angle from the
/// lift's zero angle grows with the load factor).
#[inline]
pub fn max_level_angle_of_attack_rad() -> f32 {
    let zero = gains::ZERO_LIFT_ALPHA_RAD;
    zero + (ANGLE_OF_ATTACK_LIMIT_RAD - zero) / LOAD_FACTOR_RESERVE
}

/// The docking envelope of a receiver of a stated gross mass: the grid's rectangle
/// ([`check`]) less its slow end, where the receiver's level-flight angle of attack
/// ([`level_angle_of_attack_rad`] on the schedule's trim) is above
/// [`max_level_angle_of_attack_rad`]. A heavy receiver at the slow, high corner trims close
/// to the angle-of-attack limit before the procedure asks anything of it; no design can
/// dock there.
///
/// Found as the lowest airspeed at each altitude node, on the node's row of trims (linear
/// between speed nodes, as the schedule blends them; so exact at the nodes' altitudes), and
/// held per altitude cell as a line between its two nodes: built once per configuration
/// ([`MassEnvelope::new`]), checked in a few comparisons and one multiply-add (no search
/// and no division: the controller checks it on the step's path in standby, and in the
/// schedule's follow-up when engaged, `crate::controller`).
///
/// Invariants: at the design's mass (1) the whole grid's rectangle but its slow, high
/// corner; the lowest airspeed does not fall as the mass grows; in an altitude cell where
/// either node admits no speed of the grid, the lowest airspeed is infinite (every condition
/// there refused, the cell's nodes included).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassEnvelope {
    /// Per altitude cell (between nodes `j` and `j + 1` of [`SCHEDULE_ALTITUDES_M`]): the
    /// lowest true airspeed at its lower node, m/s, and its rise per metre of altitude, m/s
    /// per m; infinite and 0 where a node of the cell admits no speed.
    cells: [(f32, f32); ALTITUDE_CELLS],
}

/// The altitude cells of the grid.
const ALTITUDE_CELLS: usize = SCHEDULE_ALTITUDES_M.len() - 1;

impl MassEnvelope {
    /// The envelope of a receiver `mass_factor` times the design's mass (finite and
    /// positive: [`crate::config::ControllerConfig::validate`] holds it to its range).
    pub fn new(mass_factor: f32) -> Self {
        let limit = max_level_angle_of_attack_rad();
        let mut lowest = [f32::INFINITY; SCHEDULE_ALTITUDES_M.len()];
        for (low, row) in lowest.iter_mut().zip(SCHEDULE.iter()) {
            let mut previous: Option<(f32, f32)> = None;
            for (node, &v) in row.iter().zip(SCHEDULE_SPEEDS_MPS.iter()) {
                let a = level_angle_of_attack_rad(node.trim.alpha_rad, mass_factor);
                if a <= limit {
                    *low = match previous {
                        // The crossing on the line between the two speed nodes.
                        Some((v0, a0)) => v0 + (a0 - limit) / (a0 - a) * (v - v0),
                        None => v,
                    };
                    break;
                }
                previous = Some((v, a));
            }
        }
        let mut cells = [(f32::INFINITY, 0.0); ALTITUDE_CELLS];
        for (k, cell) in cells.iter_mut().enumerate() {
            let (a, b) = (lowest.get(k), lowest.get(k + 1));
            let (h0, h1) = (SCHEDULE_ALTITUDES_M.get(k), SCHEDULE_ALTITUDES_M.get(k + 1));
            if let (Some(&a), Some(&b), Some(&h0), Some(&h1)) = (a, b, h0, h1)
                && a.is_finite()
                && b.is_finite()
            {
                *cell = (a, (b - a) / (h1 - h0));
            }
        }
        Self { cells }
    }

    /// The lowest true airspeed of the envelope at `altitude_m` (inside the grid's altitudes),
    /// m/s: linear in its altitude cell between the nodes' figures (a node shared by two
    /// cells belongs to the lower one); infinite where a node of the cell admits none.
    #[inline]
    pub fn lowest_airspeed_mps(&self, altitude_m: f32) -> f32 {
        // The cell: how many of the inner nodes lie below the altitude (no loop: the control
        // task's static bound declares every loop it meets).
        let [_, h1, h2, _] = SCHEDULE_ALTITUDES_M;
        let j = usize::from(altitude_m > h1) + usize::from(altitude_m > h2);
        match (self.cells.get(j), SCHEDULE_ALTITUDES_M.get(j)) {
            (Some(&(low, rise)), Some(&h0)) => low + rise * (altitude_m - h0),
            _ => f32::INFINITY,
        }
    }

    /// Whether `condition` is inside this receiver's docking envelope: [`check`], then
    /// [`ScheduleError::AngleOfAttackHigh`] below the lowest airspeed.
    #[inline]
    pub fn check(&self, condition: FlightCondition) -> Result<(), ScheduleError> {
        check(condition)?;
        if condition.true_airspeed_mps < self.lowest_airspeed_mps(condition.altitude_m) {
            Err(ScheduleError::AngleOfAttackHigh)
        } else {
            Ok(())
        }
    }
}

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

    /// A condition at `v` m/s and `h` m.
    fn cond(v: f32, h: f32) -> FlightCondition {
        FlightCondition {
            true_airspeed_mps: v,
            altitude_m: h,
        }
    }

    #[test]
    fn at_the_design_mass_only_the_slow_high_corner_leaves_the_envelope() {
        let e = MassEnvelope::new(1.0);
        let (v, _) = envelope();
        for h in [500.0, 3000.0, 5500.0] {
            assert_eq!(e.lowest_airspeed_mps(h), v[0], "{h} m");
        }
        let top = e.lowest_airspeed_mps(8000.0);
        assert!(v[0] < top && top < SCHEDULE_SPEEDS_MPS[1], "{top}");
    }

    #[test]
    fn at_each_altitude_nodes_lowest_airspeed_the_level_angle_of_attack_is_the_limit() {
        let limit = max_level_angle_of_attack_rad();
        // A pull of the reserve from the level angle reaches the limit.
        let zero = gains::ZERO_LIFT_ALPHA_RAD;
        let pulled = zero + LOAD_FACTOR_RESERVE * (limit - zero);
        assert!((pulled - ANGLE_OF_ATTACK_LIMIT_RAD).abs() < 1e-6);
        let (v, _) = envelope();
        let mut interior = 0;
        for mass in [0.85, 1.0, 1.1, 1.25, 1.5, 2.0] {
            let e = MassEnvelope::new(mass);
            for &h in &SCHEDULE_ALTITUDES_M {
                let low = e.lowest_airspeed_mps(h);
                if low > v[0] && low < v[1] {
                    interior += 1;
                    let level =
                        |v| level_angle_of_attack_rad(trim_at(cond(v, h)).unwrap().alpha_rad, mass);
                    assert!((level(low) - limit).abs() < 2e-5, "mass {mass}, {h} m");
                    assert!(level(low - 0.5) > limit, "mass {mass}, {h} m");
                    assert_eq!(
                        e.check(cond(low - 0.01, h)),
                        Err(ScheduleError::AngleOfAttackHigh)
                    );
                    assert_eq!(e.check(cond(low + 0.01, h)), Ok(()));
                } else if low == v[0] {
                    // The whole row: even the slowest node is below the limit.
                    assert!(
                        level_angle_of_attack_rad(trim_at(cond(low, h)).unwrap().alpha_rad, mass)
                            <= limit
                    );
                }
            }
        }
        assert!(
            interior >= 8,
            "the masses above cross the grid's rows: {interior}"
        );
    }

    #[test]
    fn a_heavier_receiver_never_has_a_lower_slow_edge_and_where_none_will_do_all_is_refused() {
        let (v, h) = envelope();
        let masses = [0.5, 0.85, 1.0, 1.25, 1.5, 2.0, 2.5];
        for k in 0..=14 {
            let alt = h[0] + (h[1] - h[0]) * k as f32 / 14.0;
            let lows = masses.map(|m| MassEnvelope::new(m).lowest_airspeed_mps(alt));
            assert!(lows.windows(2).all(|w| w[0] <= w[1]), "{alt} m: {lows:?}");
        }
        // At 2.5 times the mass no speed of the grid will do at the top altitude.
        let heavy = MassEnvelope::new(2.5);
        assert_eq!(heavy.lowest_airspeed_mps(h[1]), f32::INFINITY);
        assert_eq!(
            heavy.check(cond(v[1], h[1])),
            Err(ScheduleError::AngleOfAttackHigh)
        );
        // The grid's own limits come first.
        assert_eq!(
            heavy.check(cond(v[0] - 1.0, h[1])),
            Err(ScheduleError::AirspeedLow)
        );
        assert_eq!(
            heavy.check(cond(f32::NAN, h[1])),
            Err(ScheduleError::NonFinite)
        );
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
