//! Aerodynamic force and moment coefficients of the F-16 low-fidelity model, with rate damping
//! and the centre-of-gravity correction.
//!
//! Source: `[aero]` and `[formulas]` of `data/f16-lofi-data.toml` (Stevens, Lewis & Johnson
//! App. A, NASA TP-1538): table lookups in alpha, elevator and sideslip, the closed-form `cy` and
//! `cz` terms, damping derivatives scaled by `cbar q/(2 Vt)` and `b/(2 Vt)`, and the moment
//! transfer from the reference CG (`xcg_ref`) to the actual one (`xcg`).
//! Invariants: angles enter in degrees (the tables' unit), rates in rad/s, airspeed in m/s and
//! must be > 0; the coefficients are dimensionless, body axes (x forward, y right, z down), with
//! moments about the actual CG. Evaluation never allocates.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::data::{AeroData, AlphaRow, Grids, N_BETA, N_BETA_ABS, N_ELEVATOR};
use super::interp::{interp1, interp2};

/// Side-force coefficient per degree of sideslip.
const CY_PER_BETA_DEG: f64 = -0.02;
/// Side-force coefficient per unit normalised aileron.
const CY_PER_AILERON_NORM: f64 = 0.021;
/// Side-force coefficient per unit normalised rudder.
const CY_PER_RUDDER_NORM: f64 = 0.086;
/// The model's own degrees-per-radian constant in the sideslip factor of `cz` (published as 57.3).
const CZ_BETA_DEG_PER_RAD: f64 = 57.3;
/// Normal-force coefficient per unit normalised elevator.
const CZ_PER_ELEVATOR_NORM: f64 = -0.19;
/// Elevator deflection that normalises the elevator in `cz`, deg.
const ELEVATOR_NORM_DEG: f64 = 25.0;
/// Aileron deflection that normalises the aileron (`dail`), deg.
const AILERON_NORM_DEG: f64 = 20.0;
/// Rudder deflection that normalises the rudder (`drdr`), deg.
const RUDDER_NORM_DEG: f64 = 30.0;

/// Wing reference geometry.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ReferenceGeometry {
    /// Wing reference area S, m^2.
    pub wing_area_m2: f64,
    /// Wing span b, m.
    pub span_m: f64,
    /// Mean aerodynamic chord cbar, m.
    pub mean_chord_m: f64,
}

/// Rows of the damping table, in [`super::data::DAMPING_ORDER`] (checked at load).
const CXQ: usize = 0;
const CYR: usize = 1;
const CYP: usize = 2;
const CZQ: usize = 3;
const CLR: usize = 4;
const CLP: usize = 5;
const CMQ: usize = 6;
const CNR: usize = 7;
const CNP: usize = 8;

/// Flow and control state the coefficients depend on.
#[derive(Debug, Clone, Copy)]
pub(crate) struct AeroInput {
    /// Angle of attack, deg.
    pub(crate) alpha_deg: f64,
    /// Sideslip, deg.
    pub(crate) beta_deg: f64,
    /// Elevator, deg (positive trailing edge down).
    pub(crate) elevator_deg: f64,
    /// Aileron, deg (the table's sign convention).
    pub(crate) aileron_deg: f64,
    /// Rudder, deg (the table's sign convention).
    pub(crate) rudder_deg: f64,
    /// Airspeed, m/s, > 0.
    pub(crate) airspeed_mps: f64,
    /// Body rates (p, q, r), rad/s.
    pub(crate) rate_body_radps: Vector3<f64>,
}

/// Dimensionless coefficients, body axes, moments about the actual CG.
#[derive(Debug, Clone, Copy)]
pub(crate) struct AeroCoefficients {
    /// (cx, cy, cz): force / (qbar S).
    pub(crate) force: Vector3<f64>,
    /// (cl, cm, cn): rolling / (qbar S b), pitching / (qbar S cbar), yawing / (qbar S b).
    pub(crate) moment: Vector3<f64>,
}

/// The coefficient tables with their grids, the reference geometry and the CG offset.
#[derive(Debug, Clone)]
pub(crate) struct AeroModel {
    alpha_deg: AlphaRow,
    elevator_deg: [f64; N_ELEVATOR],
    beta_abs_deg: [f64; N_BETA_ABS],
    beta_deg: [f64; N_BETA],
    tables: AeroData,
    geometry: ReferenceGeometry,
    /// `xcg_ref - xcg`, fraction of the mean chord (positive: CG ahead of the reference).
    cg_ahead_of_reference: f64,
}

impl AeroModel {
    /// Aerodynamic model with the CG at `xcg` and the tables' reference CG at `xcg_ref`
    /// (fractions of the mean chord).
    pub(crate) fn new(
        grids: &Grids,
        tables: AeroData,
        geometry: ReferenceGeometry,
        xcg_ref: f64,
        xcg: f64,
    ) -> Self {
        Self {
            alpha_deg: grids.alpha_deg,
            elevator_deg: grids.elevator_deg,
            beta_abs_deg: grids.beta_abs_deg,
            beta_deg: grids.beta_deg,
            tables,
            geometry,
            cg_ahead_of_reference: xcg_ref - xcg,
        }
    }

    /// Total coefficients for `input`.
    pub(crate) fn coefficients(&self, input: &AeroInput) -> AeroCoefficients {
        let t = &self.tables;
        let alpha = input.alpha_deg;
        let elevator = input.elevator_deg;
        let beta = input.beta_deg;
        let aileron_norm = input.aileron_deg / AILERON_NORM_DEG;
        let rudder_norm = input.rudder_deg / RUDDER_NORM_DEG;
        let [p, q, r] = [0, 1, 2].map(|axis| input.rate_body_radps[axis]);

        let damping = |row: usize| interp1(&self.alpha_deg, &t.damping[row], alpha);
        let by_elevator =
            |table| interp2(&self.elevator_deg, &self.alpha_deg, table, elevator, alpha);
        let by_beta = |table| interp2(&self.beta_deg, &self.alpha_deg, table, beta, alpha);
        // cl and cn are tabulated for |beta| and odd in beta (both are zero at beta = 0).
        let odd_in_beta = |table| {
            beta.signum()
                * interp2(
                    &self.beta_abs_deg,
                    &self.alpha_deg,
                    table,
                    beta.abs(),
                    alpha,
                )
        };

        let ReferenceGeometry {
            span_m,
            mean_chord_m,
            ..
        } = self.geometry;
        let pitch_rate_factor = mean_chord_m * q / (2.0 * input.airspeed_mps);
        let lateral_rate_factor = span_m / (2.0 * input.airspeed_mps);

        let cx = by_elevator(&t.cx) + pitch_rate_factor * damping(CXQ);
        let cy = CY_PER_BETA_DEG * beta
            + CY_PER_AILERON_NORM * aileron_norm
            + CY_PER_RUDDER_NORM * rudder_norm
            + lateral_rate_factor * (damping(CYR) * r + damping(CYP) * p);
        let sideslip_factor = 1.0 - (beta / CZ_BETA_DEG_PER_RAD).powi(2);
        let cz = interp1(&self.alpha_deg, &t.cz_alpha, alpha) * sideslip_factor
            + CZ_PER_ELEVATOR_NORM * elevator / ELEVATOR_NORM_DEG
            + pitch_rate_factor * damping(CZQ);
        let cl = odd_in_beta(&t.cl)
            + by_beta(&t.dlda) * aileron_norm
            + by_beta(&t.dldr) * rudder_norm
            + lateral_rate_factor * (damping(CLR) * r + damping(CLP) * p);
        let cm =
            by_elevator(&t.cm) + pitch_rate_factor * damping(CMQ) + cz * self.cg_ahead_of_reference;
        let cn = odd_in_beta(&t.cn)
            + by_beta(&t.dnda) * aileron_norm
            + by_beta(&t.dndr) * rudder_norm
            + lateral_rate_factor * (damping(CNR) * r + damping(CNP) * p)
            - cy * self.cg_ahead_of_reference * mean_chord_m / span_m;

        AeroCoefficients {
            force: Vector3::new(cx, cy, cz),
            moment: Vector3::new(cl, cm, cn),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::receiver::data::{DAMPING_ORDER, ModelData};

    const GEOMETRY: ReferenceGeometry = ReferenceGeometry {
        wing_area_m2: 27.87,
        span_m: 9.144,
        mean_chord_m: 3.45,
    };

    fn model(xcg: f64) -> AeroModel {
        let data = ModelData::embedded().expect("embedded data file must load");
        AeroModel::new(&data.grid, data.aero, GEOMETRY, 0.35, xcg)
    }

    fn level(alpha_deg: f64, elevator_deg: f64) -> AeroInput {
        AeroInput {
            alpha_deg,
            beta_deg: 0.0,
            elevator_deg,
            aileron_deg: 0.0,
            rudder_deg: 0.0,
            airspeed_mps: 150.0,
            rate_body_radps: Vector3::zeros(),
        }
    }

    #[test]
    fn damping_rows_match_their_names() {
        let rows = [CXQ, CYR, CYP, CZQ, CLR, CLP, CMQ, CNR, CNP];
        let names = [
            "CXq", "CYr", "CYp", "CZq", "Clr", "Clp", "Cmq", "Cnr", "Cnp",
        ];
        for (row, name) in rows.into_iter().zip(names) {
            assert_eq!(DAMPING_ORDER[row], name);
        }
    }

    #[test]
    fn table_values_at_nodes() {
        let c = model(0.35).coefficients(&level(10.0, -12.0));
        assert!((c.force.x - 0.016).abs() < 1e-12);
        assert!((c.force.z - (-0.731 - 0.19 * -12.0 / 25.0)).abs() < 1e-12);
        assert!((c.moment.y - 0.110).abs() < 1e-12);
        assert_eq!((c.force.y, c.moment.x, c.moment.z), (0.0, 0.0, 0.0));
    }

    #[test]
    fn roll_and_yaw_are_odd_in_sideslip() {
        let model = model(0.35);
        let sideslip = |beta_deg| {
            model.coefficients(&AeroInput {
                beta_deg,
                ..level(12.5, 0.0)
            })
        };
        let (right, left) = (sideslip(7.0), sideslip(-7.0));
        assert!(right.moment.x < 0.0 && right.moment.z > 0.0);
        assert!((right.moment.x + left.moment.x).abs() < 1e-15);
        assert!((right.moment.z + left.moment.z).abs() < 1e-15);
        assert!((right.force.y + left.force.y).abs() < 1e-15);
    }

    #[test]
    fn pitch_damping_and_cg_shift() {
        let reference = model(0.35);
        let base = level(5.0, 0.0);
        let pitching = AeroInput {
            rate_body_radps: Vector3::new(0.0, 0.1, 0.0),
            ..base
        };
        let cq = GEOMETRY.mean_chord_m * 0.1 / (2.0 * base.airspeed_mps);
        let delta_cm =
            reference.coefficients(&pitching).moment.y - reference.coefficients(&base).moment.y;
        assert!((delta_cm - cq * -5.26).abs() < 1e-12);
        // CG 5 % chord aft of the reference: cm gains cz * (0.35 - 0.40), nose up for cz < 0.
        let aft = model(0.40).coefficients(&base);
        let c = reference.coefficients(&base);
        assert!((aft.moment.y - c.moment.y - c.force.z * -0.05).abs() < 1e-15);
        assert!(aft.moment.y > c.moment.y);
    }
}
