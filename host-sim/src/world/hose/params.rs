//! The hose and drogue's parameters: the physical constants of \[R\] and the air of the flight
//! condition ([`HoseParams`], [`HoseDragLaw`]), their validation, and the model's errors
//! ([`HoseError`]).
//!
//! Place in the data flow: a scenario (or `world/flight.rs` for another flight condition)
//! fills a [`HoseParams`]; `steady` validates it and `dynamics` derives the model's constants
//! from it once. Sources and our departures from \[R\] are in the parent module's doc and on
//! the items.
//!
//! Invariants: `Default` is docs/models.md ("Hose and drogue") with the receiver model's air
//! at 3000 m; [`HoseParams::validate`] accepts exactly the parameters the model is defined for
//! (at least one link, positive lengths, masses, densities, viscosity and step; finite,
//! non-negative coefficients and gravity) and names the first it refuses.

use serde::{Deserialize, Serialize};

/// Standard gravity, m/s^2 (CGPM 1901). The receiver model uses its data's 32.17 ft/s^2
/// (9.805 m/s^2), which would move the drogue by under a millimetre; \[R\] uses 10 m/s^2.
pub const STANDARD_GRAVITY_MPS2: f64 = 9.80665;

/// Number of rigid links, \[R\] (`N = 20` in the authors' hose S-function).
pub const DEFAULT_LINK_COUNT: usize = 20;

/// Trailed hose length, m: 47 ft, \[R\].
pub const HOSE_LENGTH_M: f64 = 14.3256;

/// Hose linear density, kg/m, \[R\].
pub const HOSE_LINEAR_DENSITY_KG_PER_M: f64 = 4.0925;

/// Hose outer radius, m, \[R\].
pub const HOSE_OUTER_RADIUS_M: f64 = 0.0336;

/// Drogue mass, kg, \[R\].
pub const DROGUE_MASS_KG: f64 = 29.484;

/// Drogue canopy diameter, m: 24 in, \[R\]. (The authors' "32-inch basket" elsewhere is a
/// different drogue; docs/models.md, "Hose and drogue".)
pub const DROGUE_CANOPY_DIAMETER_M: f64 = 0.6096;

/// Drogue drag coefficient on the canopy's frontal area, \[R\].
pub const DROGUE_DRAG_COEFFICIENT: f64 = 0.8;

/// Air density at 3000 m in the receiver model's own atmosphere (`docs/conventions.md`),
/// kg/m^3; the default, so that the receiver and the hose fly in the same air. At another
/// flight condition the run replaces it by that atmosphere's density at the altitude
/// (`world/flight.rs`, `FlightCondition::hose_params`).
pub const AIR_DENSITY_3000M_KG_PER_M3: f64 = 0.9104;

/// Air density the authors used for the hose, kg/m^3 (\[R\], `0.844323529538532`); ISA at
/// 3000 m is 0.9093. Kept for comparison runs.
pub const AUTHORS_AIR_DENSITY_KG_PER_M3: f64 = 0.844_323_529_538_532;

/// Dynamic viscosity of air at 3000 m, Pa s: Sutherland's law (`1.458e-6 T^1.5 / (T + 110.4)`,
/// the ISA/US Standard Atmosphere 1976 form) at the ISA temperature 268.65 K. At another
/// flight condition the run uses the same law at the receiver model's atmosphere's
/// temperature at the altitude (`world/flight.rs`).
pub const AIR_DYNAMIC_VISCOSITY_3000M_PA_S: f64 = 1.6938e-5;

/// Kinematic viscosity the authors used, m^2/s (\[R\]: `1.7894e-5`, the sea-level *dynamic*
/// viscosity used as a kinematic one). With \[R\]'s density it corresponds to a dynamic
/// viscosity of `1.7894e-5 * 0.8443` Pa s. Kept for comparison runs.
pub const AUTHORS_KINEMATIC_VISCOSITY_M2_PER_S: f64 = 1.7894e-5;

/// Default upper bound on the internal integration step, s: the refuelling presets' physics
/// step, so a call with `dt = 0.02` s (or `0.01` s, the `paper-*` presets') takes a single
/// RK4 step unless the wave bound asks for more.
pub const DEFAULT_MAX_INTERNAL_STEP_S: f64 = 0.02;

/// Largest phase, rad, that the fastest transverse wave of the chain may turn through in one
/// internal RK4 step (our judgement). RK4's stability limit on the imaginary axis is 2.83 rad;
/// at 1.5 rad it damps that wave by 5.9 % per step (|R(1.5i)| = 0.941) and slows its phase by
/// 1.4 %. The wave is the chain's shortest (two links long, about 10 Hz at the defaults),
/// which carries no physics of interest: the drogue's motion that matters is below 2 Hz. At
/// the defaults it turns 0.6 rad per 0.01 s, so a 0.02 s step is one RK4 step (1.2 rad, 1.7 %
/// per step) up to about 1.56 times the default tension (at 3,000 m, about 150 m/s), and two
/// steps above.
pub const MAX_WAVE_PHASE_PER_STEP_RAD: f64 = 1.5;

/// Cross-flow and skin-friction coefficient laws of the hose links.
///
/// Both laws of \[R\] (attributed there to \[RK\]) are functions of a Reynolds number based on
/// the *total* relative air speed at the link, `|v_rel|`, and the kinematic viscosity
/// `nu = mu / rho`:
///
/// - cross flow, `Re_d = |v_rel| 2 r / nu`: `10 Re^-0.801` (Re <= 1), `10 Re^-0.4083`
///   (up to 180), 1.2 (subcritical), `0.002128 Re^0.3522` (supercritical, from 4e5), 0.45
///   (above 4e6);
/// - skin friction, `Re_f = |v_rel| pi r / nu`: `4.6409 Re^-0.6667` (laminar, up to 1e4),
///   `0.0464 Re^-0.1667` (turbulent, up to 1e10), 0.001 beyond.
///
/// Our departures, all to make the force a continuous function of the state (well-posed):
/// \[R\] drops the cross-flow coefficient from 1.2 to 0.20 in a jump at `Re_d = 4e5`; we bridge
/// it log-linearly from 2e5 (the start of the drag crisis of a smooth circular cylinder in
/// the classic data, e.g. Achenbach, JFM 1968) to 4e5. Each branch is joined to the next
/// where the two meet (max/min of the neighbouring laws), which moves the breakpoints by
/// less than 1 %. Below `Re = 0.01` \[R\] sets the coefficients to zero; we hold their values at
/// 0.01 (the force vanishes with the speed either way). \[R\] divides `Re_f` by the sine of
/// the link's angle to the wind, which makes it infinite for a link aligned with the wind; we
/// do not (our judgement): at the nominal trail `Cf` is 0.0049 instead of 0.0041.
///
/// At the default flight condition (120 m/s, 3000 m) `Re_d` = 4.3e5, just past the drag
/// crisis: `Cd` = 0.206. Using the normal velocity component instead (the cross-flow
/// "independence principle") would put the hose in the subcritical range, `Cd` = 1.2, and
/// trail the drogue 1.1 m higher (the ignored module test `report_sensitivity_and_step_cost`
/// prints the numbers).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum HoseDragLaw {
    /// The Reynolds-number dependent laws of \[R\] / \[RK\], made continuous (above).
    ReynoldsDependent,
    /// Constant coefficients, for sensitivity studies.
    Constant {
        /// Cross-flow drag coefficient on the projected area `d l`, dimensionless.
        cross_flow_cd: f64,
        /// Skin-friction coefficient on the wetted area `pi d l`, dimensionless.
        skin_friction_cf: f64,
    },
}

/// Every physical and numerical parameter of the hose and drogue. `Default` is docs/models.md
/// ("Hose and drogue"), with the receiver model's air at 3000 m.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HoseParams {
    /// Number of rigid links, at least 1. Default 20 \[R\].
    pub link_count: usize,
    /// Hose length from the exit to the drogue centre, m. Default 14.3256 m (47 ft) \[R\].
    pub hose_length_m: f64,
    /// Hose linear density, kg/m. Default 4.0925 kg/m \[R\].
    pub hose_linear_density_kg_per_m: f64,
    /// Hose outer radius, m. Default 0.0336 m \[R\].
    pub hose_outer_radius_m: f64,
    /// Drogue mass, kg, lumped at the drogue centre. Default 29.484 kg \[R\].
    pub drogue_mass_kg: f64,
    /// Drogue canopy diameter, m; the drag area is `pi D^2 / 4`. Default 0.6096 m (24 in)
    /// \[R\].
    pub drogue_canopy_diameter_m: f64,
    /// Drogue drag coefficient, dimensionless. Default 0.8 \[R\].
    pub drogue_drag_coefficient: f64,
    /// Air density, kg/m^3. Default 0.9104 kg/m^3, the receiver model's atmosphere at 3000 m;
    /// the authors used 0.8443 kg/m^3 for the hose ([`AUTHORS_AIR_DENSITY_KG_PER_M3`]).
    pub air_density_kg_per_m3: f64,
    /// Air dynamic viscosity, Pa s, for the Reynolds numbers. Default 1.6938e-5 Pa s (ISA,
    /// 3000 m, Sutherland's law).
    pub air_dynamic_viscosity_pa_s: f64,
    /// Gravitational acceleration, m/s^2, along +z. Default 9.80665 m/s^2 (\[R\] uses 10).
    pub gravity_mps2: f64,
    /// Drag coefficient laws of the hose links. Default [`HoseDragLaw::ReynoldsDependent`].
    pub hose_drag_law: HoseDragLaw,
    /// Factor on both of the links' coefficients (cross flow and skin friction), for their
    /// uncertainty (finite, not negative). Default 1: the laws as they are.
    #[serde(default = "default_hose_drag_scale")]
    pub hose_drag_scale: f64,
    /// Largest internal integration step, s. Default 0.01 s.
    pub max_internal_step_s: f64,
}

impl Default for HoseParams {
    fn default() -> Self {
        Self {
            link_count: DEFAULT_LINK_COUNT,
            hose_length_m: HOSE_LENGTH_M,
            hose_linear_density_kg_per_m: HOSE_LINEAR_DENSITY_KG_PER_M,
            hose_outer_radius_m: HOSE_OUTER_RADIUS_M,
            drogue_mass_kg: DROGUE_MASS_KG,
            drogue_canopy_diameter_m: DROGUE_CANOPY_DIAMETER_M,
            drogue_drag_coefficient: DROGUE_DRAG_COEFFICIENT,
            air_density_kg_per_m3: AIR_DENSITY_3000M_KG_PER_M3,
            air_dynamic_viscosity_pa_s: AIR_DYNAMIC_VISCOSITY_3000M_PA_S,
            gravity_mps2: STANDARD_GRAVITY_MPS2,
            hose_drag_law: HoseDragLaw::ReynoldsDependent,
            hose_drag_scale: DEFAULT_HOSE_DRAG_SCALE,
            max_internal_step_s: DEFAULT_MAX_INTERNAL_STEP_S,
        }
    }
}

/// Factor on the hose links' drag coefficients by default: the laws as they are.
pub const DEFAULT_HOSE_DRAG_SCALE: f64 = 1.0;

/// [`DEFAULT_HOSE_DRAG_SCALE`], for parameters stored before the scale existed.
fn default_hose_drag_scale() -> f64 {
    DEFAULT_HOSE_DRAG_SCALE
}

impl HoseParams {
    /// The parameter values of the authors' simulation \[R\] where they differ from ours: air
    /// density 0.8443 kg/m^3, kinematic viscosity 1.7894e-5 m^2/s, gravity 10 m/s^2.
    pub fn authors() -> Self {
        Self {
            air_density_kg_per_m3: AUTHORS_AIR_DENSITY_KG_PER_M3,
            air_dynamic_viscosity_pa_s: AUTHORS_KINEMATIC_VISCOSITY_M2_PER_S
                * AUTHORS_AIR_DENSITY_KG_PER_M3,
            gravity_mps2: AUTHORS_GRAVITY_MPS2,
            ..Self::default()
        }
    }

    /// Checks every parameter; the error names the first invalid one.
    pub fn validate(&self) -> Result<(), HoseError> {
        if self.link_count == 0 {
            return Err(HoseError::InvalidParameter {
                name: "link_count",
                value: 0.0,
                requirement: "at least 1",
            });
        }
        let positive = [
            ("hose_length_m", self.hose_length_m),
            (
                "hose_linear_density_kg_per_m",
                self.hose_linear_density_kg_per_m,
            ),
            ("hose_outer_radius_m", self.hose_outer_radius_m),
            ("drogue_mass_kg", self.drogue_mass_kg),
            ("drogue_canopy_diameter_m", self.drogue_canopy_diameter_m),
            ("air_density_kg_per_m3", self.air_density_kg_per_m3),
            (
                "air_dynamic_viscosity_pa_s",
                self.air_dynamic_viscosity_pa_s,
            ),
            ("max_internal_step_s", self.max_internal_step_s),
        ];
        for (name, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(HoseError::InvalidParameter {
                    name,
                    value,
                    requirement: "finite and positive",
                });
            }
        }
        let mut non_negative = vec![
            ("drogue_drag_coefficient", self.drogue_drag_coefficient),
            ("gravity_mps2", self.gravity_mps2),
            ("hose_drag_scale", self.hose_drag_scale),
        ];
        if let HoseDragLaw::Constant {
            cross_flow_cd,
            skin_friction_cf,
        } = self.hose_drag_law
        {
            non_negative.push(("hose_drag_law.cross_flow_cd", cross_flow_cd));
            non_negative.push(("hose_drag_law.skin_friction_cf", skin_friction_cf));
        }
        for (name, value) in non_negative {
            if !(value.is_finite() && value >= 0.0) {
                return Err(HoseError::InvalidParameter {
                    name,
                    value,
                    requirement: "finite and not negative",
                });
            }
        }
        Ok(())
    }
}

/// Gravity in the authors' simulation, m/s^2 (\[R\]).
const AUTHORS_GRAVITY_MPS2: f64 = 10.0;

/// Errors of the hose model.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HoseError {
    /// A parameter is out of its domain.
    #[error("invalid hose parameter {name} = {value}: must be {requirement}")]
    InvalidParameter {
        /// Field name in [`HoseParams`].
        name: &'static str,
        /// The offending value (a count is converted to `f64`).
        value: f64,
        /// What it must be.
        requirement: &'static str,
    },
    /// The air velocity field returned a non-finite value while the steady trail was sought.
    #[error("the air velocity field is not finite at {at_tanker_m:?} m")]
    NonFiniteAir {
        /// Where it was sampled, tanker frame, m.
        at_tanker_m: [f64; 3],
    },
    /// The steady-trail iteration did not converge (e.g. an air field with strong gradients
    /// along the hose), or its result is not an equilibrium of the dynamic model.
    #[error(
        "the hose did not settle: after {iterations} iterations the nodes still move {residual_m} m \
         per iteration, largest acceleration {residual_accel_mps2} m/s^2"
    )]
    DidNotSettle {
        /// Outer iterations performed.
        iterations: usize,
        /// Largest node displacement in the last iteration, m.
        residual_m: f64,
        /// Largest node acceleration of the dynamic model at the result, m/s^2 (NaN when the
        /// iteration itself failed).
        residual_accel_mps2: f64,
    },
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::hose::HoseDrogue;
    use crate::world::hose::test_support::calm;
    use nalgebra::Vector3;

    #[test]
    fn invalid_parameters_are_named_errors() {
        type Spoil = fn(&mut HoseParams);
        let cases: [(&str, Spoil); 14] = [
            ("link_count", |p| p.link_count = 0),
            ("hose_length_m", |p| p.hose_length_m = 0.0),
            ("hose_linear_density_kg_per_m", |p| {
                p.hose_linear_density_kg_per_m = -1.0
            }),
            ("hose_outer_radius_m", |p| p.hose_outer_radius_m = f64::NAN),
            ("drogue_mass_kg", |p| p.drogue_mass_kg = 0.0),
            ("drogue_canopy_diameter_m", |p| {
                p.drogue_canopy_diameter_m = f64::INFINITY
            }),
            ("drogue_drag_coefficient", |p| {
                p.drogue_drag_coefficient = -0.1
            }),
            ("air_density_kg_per_m3", |p| p.air_density_kg_per_m3 = 0.0),
            ("air_dynamic_viscosity_pa_s", |p| {
                p.air_dynamic_viscosity_pa_s = -1e-5
            }),
            ("gravity_mps2", |p| p.gravity_mps2 = f64::NAN),
            ("max_internal_step_s", |p| p.max_internal_step_s = 0.0),
            ("hose_drag_scale", |p| p.hose_drag_scale = -0.5),
            ("hose_drag_law.cross_flow_cd", |p| {
                p.hose_drag_law = HoseDragLaw::Constant {
                    cross_flow_cd: -1.0,
                    skin_friction_cf: 0.0,
                }
            }),
            ("hose_drag_law.skin_friction_cf", |p| {
                p.hose_drag_law = HoseDragLaw::Constant {
                    cross_flow_cd: 1.0,
                    skin_friction_cf: f64::NAN,
                }
            }),
        ];
        for (name, spoil) in cases {
            let mut p = HoseParams::default();
            spoil(&mut p);
            match HoseDrogue::steady_trail(p, &calm) {
                Err(HoseError::InvalidParameter { name: got, .. }) => assert_eq!(got, name),
                other => panic!("{name}: {other:?}"),
            }
        }
        assert!(HoseParams::default().validate().is_ok());
        // A non-finite air field is refused too.
        let bad = |_: &Vector3<f64>| Vector3::new(f64::NAN, 0.0, 0.0);
        assert!(matches!(
            HoseDrogue::steady_trail(HoseParams::default(), &bad),
            Err(HoseError::NonFiniteAir { .. })
        ));
    }
}
