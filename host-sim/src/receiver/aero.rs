//! Aerodynamic force and moment coefficients of the F-16 low-fidelity model, with rate damping
//! and the centre-of-gravity correction.
//!
//! Source: `[aero]` and `[formulas]` of `data/f16-lofi-data.toml` (Stevens, Lewis & Johnson
//! App. A, NASA TP-1538): table lookups in alpha, elevator and sideslip, the closed-form `cy` and
//! `cz` terms, damping derivatives scaled by `cbar q/(2 Vt)` and `b/(2 Vt)`, and the moment
//! transfer from the reference CG (`xcg_ref`) to the actual one (`xcg`); the factors of a
//! [`ReceiverPlant`] on the control increments, the direct damping terms and the static
//! stability (`plant.rs` states each one's formula).
//! Invariants: angles enter in degrees (the tables' unit), rates in rad/s, airspeed in m/s and
//! must be > 0; the coefficients are dimensionless, body axes (x forward, y right, z down), with
//! moments about the actual CG. Evaluation never allocates.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::data::{AeroData, AlphaRow, Grids, N_BETA, N_BETA_ABS, N_ELEVATOR};
use super::interp::{interp1, interp2};
use super::plant::ReceiverPlant;

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
/// Angle of attack about which `cm_alpha_scale` scales the pitching moment's α-dependence,
/// deg: the design trim's (120 m/s, 3000 m, cg 0.35: 6.35 deg, `docs/models.md`, "Trim"), so
/// that the factor leaves the design trim's moment balance as it is. (ours)
const CM_ALPHA_PIVOT_DEG: f64 = 6.35;

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
    /// The true aircraft's factors.
    plant: ReceiverPlant,
    /// `cm(α₀, 0)` at [`CM_ALPHA_PIVOT_DEG`], the pivot of `cm_alpha_scale`.
    cm_at_pivot: f64,
}

impl AeroModel {
    /// Aerodynamic model with the CG at `xcg` and the tables' reference CG at `xcg_ref`
    /// (fractions of the mean chord), with the aerodynamic factors of `plant`.
    pub(crate) fn new(
        grids: &Grids,
        tables: AeroData,
        geometry: ReferenceGeometry,
        xcg_ref: f64,
        xcg: f64,
        plant: &ReceiverPlant,
    ) -> Self {
        let cm_at_pivot = interp2(
            &grids.elevator_deg,
            &grids.alpha_deg,
            &tables.cm,
            0.0,
            CM_ALPHA_PIVOT_DEG,
        );
        Self {
            alpha_deg: grids.alpha_deg,
            elevator_deg: grids.elevator_deg,
            beta_abs_deg: grids.beta_abs_deg,
            beta_deg: grids.beta_deg,
            tables,
            geometry,
            cg_ahead_of_reference: xcg_ref - xcg,
            plant: *plant,
            cm_at_pivot,
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

        // The plant's factors multiply each term they scale (a factor of 1.0 leaves the term
        // exactly as it is); the elevator's increments and cm's α-dependence are split from
        // their tables only when their factor is not 1.0, so the nominal aircraft is the tables'
        // bit for bit.
        let k = &self.plant;
        let (k_elevator, k_aileron, k_rudder) = (
            k.elevator_effectiveness,
            k.aileron_effectiveness,
            k.rudder_effectiveness,
        );
        let at_zero_elevator =
            |table| interp2(&self.elevator_deg, &self.alpha_deg, table, 0.0, alpha);
        let cx_table = by_elevator(&t.cx);
        let cx_controlled = if k_elevator == 1.0 {
            cx_table
        } else {
            let cx_clean = at_zero_elevator(&t.cx);
            cx_clean + k_elevator * (cx_table - cx_clean)
        };
        let cm_table = by_elevator(&t.cm);
        let cm_static = if k_elevator == 1.0 && k.cm_alpha_scale == 1.0 {
            cm_table
        } else {
            let cm_clean = at_zero_elevator(&t.cm);
            self.cm_at_pivot
                + k.cm_alpha_scale * (cm_clean - self.cm_at_pivot)
                + k_elevator * (cm_table - cm_clean)
        };

        let cx = cx_controlled + pitch_rate_factor * damping(CXQ);
        let cy = CY_PER_BETA_DEG * beta
            + CY_PER_AILERON_NORM * aileron_norm * k_aileron
            + CY_PER_RUDDER_NORM * rudder_norm * k_rudder
            + lateral_rate_factor * (damping(CYR) * r + damping(CYP) * p);
        let sideslip_factor = 1.0 - (beta / CZ_BETA_DEG_PER_RAD).powi(2);
        let cz = interp1(&self.alpha_deg, &t.cz_alpha, alpha) * sideslip_factor
            + CZ_PER_ELEVATOR_NORM * elevator / ELEVATOR_NORM_DEG * k_elevator
            + pitch_rate_factor * damping(CZQ);
        let cl = odd_in_beta(&t.cl) * k.cl_beta_scale
            + by_beta(&t.dlda) * aileron_norm * k_aileron
            + by_beta(&t.dldr) * rudder_norm * k_rudder
            + lateral_rate_factor * (damping(CLR) * r + damping(CLP) * p * k.roll_damping_scale);
        let cm = cm_static
            + pitch_rate_factor * damping(CMQ) * k.pitch_damping_scale
            + cz * self.cg_ahead_of_reference;
        let cn = odd_in_beta(&t.cn) * k.cn_beta_scale
            + by_beta(&t.dnda) * aileron_norm * k_aileron
            + by_beta(&t.dndr) * rudder_norm * k_rudder
            + lateral_rate_factor * (damping(CNR) * r * k.yaw_damping_scale + damping(CNP) * p)
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
        with_plant(xcg, &ReceiverPlant::NOMINAL)
    }

    fn with_plant(xcg: f64, plant: &ReceiverPlant) -> AeroModel {
        let data = ModelData::embedded().expect("embedded data file must load");
        AeroModel::new(&data.grid, data.aero, GEOMETRY, 0.35, xcg, plant)
    }

    /// Coefficients as one array (cx, cy, cz, cl, cm, cn).
    fn all(c: &AeroCoefficients) -> [f64; 6] {
        [
            c.force.x, c.force.y, c.force.z, c.moment.x, c.moment.y, c.moment.z,
        ]
    }

    /// Off every grid node, every control deflected, every rate non-zero.
    const GENERAL: AeroInput = AeroInput {
        alpha_deg: 8.3,
        beta_deg: 4.1,
        elevator_deg: -3.7,
        aileron_deg: 5.2,
        rudder_deg: -7.9,
        airspeed_mps: 130.0,
        rate_body_radps: Vector3::new(0.21, -0.13, 0.09),
    };

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

    /// Each factor at 2.0 doubles exactly the terms it scales (measured on the nominal model
    /// as the change when the term's input is zeroed) and leaves every other coefficient as it
    /// is, bit for bit. At the reference cg, so that no term reaches another through the cg
    /// transfer.
    #[test]
    fn each_factor_doubles_its_own_terms_and_nothing_else() {
        let nominal = model(0.35);
        let c = |m: &AeroModel, input: &AeroInput| all(&m.coefficients(input));
        let no_rates = AeroInput {
            rate_body_radps: Vector3::zeros(),
            aileron_deg: 0.0,
            rudder_deg: 0.0,
            elevator_deg: 0.0,
            ..GENERAL
        };
        let at_pivot = AeroInput {
            alpha_deg: CM_ALPHA_PIVOT_DEG,
            beta_deg: 0.0,
            ..no_rates
        };
        let zero_beta = AeroInput {
            beta_deg: 0.0,
            ..no_rates
        };
        let rates = |p: f64, q: f64, r: f64| AeroInput {
            rate_body_radps: Vector3::new(p, q, r),
            ..GENERAL
        };
        let [p, q, r] = [0, 1, 2].map(|i| GENERAL.rate_body_radps[i]);
        // (factor, input, the same input without the scaled terms, coefficients it changes).
        type Case = (
            fn(&mut ReceiverPlant) -> &mut f64,
            AeroInput,
            AeroInput,
            [bool; 6],
        );
        let cases: [Case; 9] = [
            (
                |k| &mut k.elevator_effectiveness,
                GENERAL,
                AeroInput {
                    elevator_deg: 0.0,
                    ..GENERAL
                },
                [true, false, true, false, true, false],
            ),
            (
                |k| &mut k.aileron_effectiveness,
                GENERAL,
                AeroInput {
                    aileron_deg: 0.0,
                    ..GENERAL
                },
                [false, true, false, true, false, true],
            ),
            (
                |k| &mut k.rudder_effectiveness,
                GENERAL,
                AeroInput {
                    rudder_deg: 0.0,
                    ..GENERAL
                },
                [false, true, false, true, false, true],
            ),
            (
                |k| &mut k.roll_damping_scale,
                rates(p, 0.0, 0.0),
                rates(0.0, 0.0, 0.0),
                // cy and cn see p too (CYp, Cnp): only cl's term is the roll damping.
                [false, false, false, true, false, false],
            ),
            (
                |k| &mut k.pitch_damping_scale,
                rates(0.0, q, 0.0),
                rates(0.0, 0.0, 0.0),
                [false, false, false, false, true, false],
            ),
            (
                |k| &mut k.yaw_damping_scale,
                rates(0.0, 0.0, r),
                rates(0.0, 0.0, 0.0),
                [false, false, false, false, false, true],
            ),
            (
                |k| &mut k.cm_alpha_scale,
                zero_beta,
                at_pivot,
                [false, false, false, false, true, false],
            ),
            (
                |k| &mut k.cn_beta_scale,
                no_rates,
                zero_beta,
                [false, false, false, false, false, true],
            ),
            (
                |k| &mut k.cl_beta_scale,
                no_rates,
                zero_beta,
                [false, false, false, true, false, false],
            ),
        ];
        for (i, (factor, input, without, changes)) in cases.into_iter().enumerate() {
            let mut plant = ReceiverPlant::NOMINAL;
            *factor(&mut plant) = 2.0;
            let doubled = c(&with_plant(0.35, &plant), &input);
            let (base, term) = (c(&nominal, &input), c(&nominal, &without));
            for j in 0..6 {
                let own = base[j] - term[j];
                if changes[j] {
                    assert!(
                        own.abs() > 1e-4,
                        "case {i}, coefficient {j}: a term to scale"
                    );
                    let got = doubled[j] - base[j];
                    assert!((got - own).abs() < 1e-12, "case {i}, {j}: {got} vs {own}");
                } else {
                    assert_eq!(
                        doubled[j], base[j],
                        "case {i}, coefficient {j} must not change"
                    );
                }
            }
        }
    }

    /// `cm_alpha_scale` pivots about the design trim's α: there it changes nothing, and the
    /// elevator's increment is unchanged by it.
    #[test]
    fn static_stability_pivots_about_the_design_trim() {
        let mut plant = ReceiverPlant::NOMINAL;
        plant.cm_alpha_scale = 0.5;
        let soft = with_plant(0.35, &plant);
        let nominal = model(0.35);
        let at = |alpha_deg, elevator_deg| level(alpha_deg, elevator_deg);
        for elevator in [-10.0, 0.0, 7.0] {
            let pivot = at(CM_ALPHA_PIVOT_DEG, elevator);
            let (a, b) = (soft.coefficients(&pivot), nominal.coefficients(&pivot));
            assert!((a.moment.y - b.moment.y).abs() < 1e-15, "{elevator}");
            // Off the pivot: the elevator's increment is the nominal one.
            let increment = |m: &AeroModel| {
                m.coefficients(&at(12.0, elevator)).moment.y
                    - m.coefficients(&at(12.0, 0.0)).moment.y
            };
            assert!((increment(&soft) - increment(&nominal)).abs() < 1e-15);
        }
        // The slope about the pivot halves.
        let slope = |m: &AeroModel| {
            m.coefficients(&at(20.0, 0.0)).moment.y
                - m.coefficients(&at(CM_ALPHA_PIVOT_DEG, 0.0)).moment.y
        };
        assert!((slope(&soft) - 0.5 * slope(&nominal)).abs() < 1e-15);
        assert!(slope(&nominal).abs() > 1e-3);
    }

    /// The nominal plant is the published formulas (`[formulas]` of the data file) evaluated
    /// as they stand, bit for bit, everywhere: no factor of 1.0 reorders or splits a term.
    #[test]
    fn nominal_plant_is_the_published_formulas_bit_for_bit() {
        let data = ModelData::embedded().expect("embedded data file must load");
        let (g, t) = (&data.grid, &data.aero);
        let cg_ahead = 0.35 - 0.31;
        let m = model(0.31);
        for i in 0..400 {
            let x = f64::from(i);
            let input = AeroInput {
                alpha_deg: -12.0 + (x * 7.31) % 60.0,
                beta_deg: -25.0 + (x * 3.17) % 50.0,
                elevator_deg: -25.0 + (x * 5.03) % 50.0,
                aileron_deg: -21.0 + (x * 2.71) % 42.0,
                rudder_deg: -30.0 + (x * 6.11) % 60.0,
                airspeed_mps: 90.0 + (x * 1.37) % 100.0,
                rate_body_radps: Vector3::new((x * 0.13).sin(), (x * 0.07).cos(), (x * 0.05).sin())
                    * 0.3,
            };
            let (a, b, e) = (input.alpha_deg, input.beta_deg, input.elevator_deg);
            let (dail, drdr) = (input.aileron_deg / 20.0, input.rudder_deg / 30.0);
            let [p, q, r] = [0, 1, 2].map(|k| input.rate_body_radps[k]);
            let d = |row: usize| interp1(&g.alpha_deg, &t.damping[row], a);
            let by_e = |tb| interp2(&g.elevator_deg, &g.alpha_deg, tb, e, a);
            let by_b = |tb| interp2(&g.beta_deg, &g.alpha_deg, tb, b, a);
            let odd = |tb| b.signum() * interp2(&g.beta_abs_deg, &g.alpha_deg, tb, b.abs(), a);
            let cq = GEOMETRY.mean_chord_m * q / (2.0 * input.airspeed_mps);
            let b2v = GEOMETRY.span_m / (2.0 * input.airspeed_mps);
            let cx = by_e(&t.cx) + cq * d(CXQ);
            let cy = -0.02 * b + 0.021 * dail + 0.086 * drdr + b2v * (d(CYR) * r + d(CYP) * p);
            let cz = interp1(&g.alpha_deg, &t.cz_alpha, a) * (1.0 - (b / 57.3).powi(2))
                - 0.19 * e / 25.0
                + cq * d(CZQ);
            let cl = odd(&t.cl)
                + by_b(&t.dlda) * dail
                + by_b(&t.dldr) * drdr
                + b2v * (d(CLR) * r + d(CLP) * p);
            let cm = by_e(&t.cm) + cq * d(CMQ) + cz * cg_ahead;
            let cn = odd(&t.cn)
                + by_b(&t.dnda) * dail
                + by_b(&t.dndr) * drdr
                + b2v * (d(CNR) * r + d(CNP) * p)
                - cy * cg_ahead * GEOMETRY.mean_chord_m / GEOMETRY.span_m;
            let got = all(&m.coefficients(&input));
            let want = [cx, cy, cz, cl, cm, cn];
            for j in 0..6 {
                assert_eq!(
                    got[j].to_bits(),
                    want[j].to_bits(),
                    "input {i}, coefficient {j}"
                );
            }
        }
    }
}
