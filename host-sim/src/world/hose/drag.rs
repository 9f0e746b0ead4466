//! The aerodynamic forces of the hose model: the drag of the drogue, the skin-friction and
//! cross-flow force on a link, and their Reynolds-number dependent coefficient laws (see
//! [`HoseDragLaw`] for the laws and our departures from \[R\]).
//!
//! Place in the data flow: `dynamics` (every acceleration evaluation) and `steady` (the
//! equilibrium march) ask [`Model::link_aero`] and [`Model::drogue_drag`] for the force of
//! the air velocity relative to a link or to the drogue.
//!
//! Invariants: each force is a continuous function of the relative velocity (the laws are
//! joined where their branches meet) and vanishes with it; the laws are held constant below
//! `Re = 0.01`.

use nalgebra::Vector3;

use super::dynamics::Model;
use super::params::HoseDragLaw;

impl Model {
    /// Drag of the drogue for the air velocity relative to it, N.
    pub(super) fn drogue_drag(&self, rel: Vector3<f64>) -> Vector3<f64> {
        rel * (self.drogue_k * rel.norm())
    }

    /// Aerodynamic force on a whole link, N, for the air velocity relative to the link `rel`
    /// (m/s) and the unit vector along it `e`.
    #[inline(always)]
    pub(super) fn link_aero(&self, rel: Vector3<f64>, e: Vector3<f64>) -> Vector3<f64> {
        let v_t = rel.dot(&e);
        let v_n = rel - e * v_t;
        let (cd, cf) = match self.law {
            HoseDragLaw::ReynoldsDependent => {
                // Both laws are powers of the speed: one logarithm serves both (and needs
                // no square root), each coefficient then one exponential.
                let ln_speed = 0.5 * rel.norm_squared().ln();
                (
                    cross_flow_cd(ln_speed + self.ln_re_d_per_speed),
                    skin_friction_cf(ln_speed + self.ln_re_f_per_speed),
                )
            }
            HoseDragLaw::Constant {
                cross_flow_cd,
                skin_friction_cf,
            } => (cross_flow_cd, skin_friction_cf),
        };
        e * (self.skin_k * cf * v_t * v_t.abs()) + v_n * (self.normal_k * cd * v_n.norm())
    }
}

// Coefficient laws of [R] (docs/models.md, "Hose and drogue"; attributed there to [RK]); see
// `HoseDragLaw`.

/// Reynolds number below which the coefficient laws are held constant.
const RE_FLOOR: f64 = 1e-2;
/// Cross flow, creeping flow (Re <= 1): `10 Re^-0.801`.
const CD_CREEPING_GAIN: f64 = 10.0;
const CD_CREEPING_EXPONENT: f64 = -0.801;
const CD_CREEPING_MAX_RE: f64 = 1.0;
/// Cross flow, low Re (1 < Re <~ 180): `10 Re^-0.4083`.
const CD_LOW_RE_GAIN: f64 = 10.0;
const CD_LOW_RE_EXPONENT: f64 = -0.4083;
/// Cross flow, subcritical plateau.
const CD_SUBCRITICAL: f64 = 1.2;
/// Cross flow: start of our bridge over the drag crisis (our judgement, see `HoseDragLaw`).
const CD_CRISIS_START_RE: f64 = 2e5;
/// Cross flow: start of the supercritical law of \[R\].
const CD_SUPERCRITICAL_START_RE: f64 = 4e5;
/// Cross flow, supercritical (4e5 < Re <~ 4e6): `0.002128 Re^0.3522`.
const CD_SUPERCRITICAL_GAIN: f64 = 0.002128;
const CD_SUPERCRITICAL_EXPONENT: f64 = 0.3522;
/// Cross flow, transcritical plateau.
const CD_TRANSCRITICAL: f64 = 0.45;
/// Skin friction, laminar: `4.6409 Re^-0.6667`.
const CF_LAMINAR_GAIN: f64 = 4.6409;
const CF_LAMINAR_EXPONENT: f64 = -0.6667;
/// Skin friction, turbulent: `0.0464 Re^-0.1667`.
const CF_TURBULENT_GAIN: f64 = 0.0464;
const CF_TURBULENT_EXPONENT: f64 = -0.1667;
/// Skin friction floor.
const CF_MIN: f64 = 0.001;
/// Skin friction: above this Reynolds number the laminar law (which meets the turbulent one
/// near 1e4) is smaller by more than a factor of 2 and need not be evaluated.
const CF_LAMINAR_BELOW_RE: f64 = 1e5;

/// `gain * Re^exponent` from `ln Re` (the constant logarithms fold at compile time).
#[inline(always)]
fn power_law(gain: f64, exponent: f64, ln_re: f64) -> f64 {
    (gain.ln() + exponent * ln_re).exp()
}

/// Cross-flow drag coefficient of the hose for the natural logarithm of the diameter
/// Reynolds number (continuous).
fn cross_flow_cd(ln_re: f64) -> f64 {
    let ln_re = ln_re.max(RE_FLOOR.ln());
    if ln_re <= CD_CREEPING_MAX_RE.ln() {
        power_law(CD_CREEPING_GAIN, CD_CREEPING_EXPONENT, ln_re)
    } else if ln_re <= CD_CRISIS_START_RE.ln() {
        power_law(CD_LOW_RE_GAIN, CD_LOW_RE_EXPONENT, ln_re).max(CD_SUBCRITICAL)
    } else if ln_re <= CD_SUPERCRITICAL_START_RE.ln() {
        // The bridge is linear in log-log coordinates.
        let ln_end = supercritical_cd(CD_SUPERCRITICAL_START_RE.ln()).ln();
        let s = (ln_re - CD_CRISIS_START_RE.ln())
            / (CD_SUPERCRITICAL_START_RE.ln() - CD_CRISIS_START_RE.ln());
        (CD_SUBCRITICAL.ln() + s * (ln_end - CD_SUBCRITICAL.ln())).exp()
    } else {
        supercritical_cd(ln_re)
    }
}

/// The supercritical branch, capped at the transcritical plateau.
fn supercritical_cd(ln_re: f64) -> f64 {
    power_law(CD_SUPERCRITICAL_GAIN, CD_SUPERCRITICAL_EXPONENT, ln_re).min(CD_TRANSCRITICAL)
}

/// Skin-friction coefficient of the hose for the natural logarithm of its Reynolds number
/// (continuous).
fn skin_friction_cf(ln_re: f64) -> f64 {
    let ln_re = ln_re.max(RE_FLOOR.ln());
    let turbulent = power_law(CF_TURBULENT_GAIN, CF_TURBULENT_EXPONENT, ln_re).max(CF_MIN);
    if ln_re >= CF_LAMINAR_BELOW_RE.ln() {
        // The laminar law is far below the turbulent one here; skip its cost.
        turbulent
    } else {
        turbulent.max(power_law(CF_LAMINAR_GAIN, CF_LAMINAR_EXPONENT, ln_re))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::hose::test_support::V_MPS;
    use crate::world::hose::{
        AIR_DENSITY_3000M_KG_PER_M3, AIR_DYNAMIC_VISCOSITY_3000M_PA_S, HOSE_OUTER_RADIUS_M,
    };

    /// The laws for a Reynolds number (they take its logarithm).
    fn cd(re: f64) -> f64 {
        cross_flow_cd(re.ln())
    }
    fn cf(re: f64) -> f64 {
        skin_friction_cf(re.ln())
    }

    #[test]
    fn coefficient_laws_are_continuous_and_match_the_source_values() {
        // Values of [R]'s branches away from the joins, as [R] writes them (powers of Re).
        assert!((cd(0.5) - 10.0 * 0.5_f64.powf(-0.801)).abs() < 1e-12);
        assert!((cd(50.0) - 10.0 * 50.0_f64.powf(-0.4083)).abs() < 1e-12);
        assert_eq!(cd(1e5), 1.2);
        assert!((cd(1e6) - 0.002128 * 1e6_f64.powf(0.3522)).abs() < 1e-12);
        assert_eq!(cd(1e7), 0.45);
        assert!((cf(100.0) - 4.6409 * 100.0_f64.powf(-0.6667)).abs() < 1e-12);
        assert!((cf(1e6) - 0.0464 * 1e6_f64.powf(-0.1667)).abs() < 1e-12);
        assert_eq!(cf(1e12), 0.001);
        // Held below the floor, and at zero speed (ln 0 = -inf).
        assert_eq!(cd(1e-5), cd(1e-2));
        assert_eq!(cf(0.0), cf(1e-2));
        // No jumps: relative change across every join below 1e-4 for a 1e-6 step in log Re.
        for &re in &[1e-2, 1.0, 179.6, 2e5, 4e5, 3.99e6, 1e4, 1e10] {
            for f in [cd, cf] {
                let (a, b) = (f(re * (1.0 - 1e-6)), f(re * (1.0 + 1e-6)));
                assert!((a - b).abs() < 1e-4 * a, "{re}: {a} vs {b}");
            }
        }
    }

    /// The logarithmic form agrees with the laws written as powers of `Re` (the form of
    /// [R]) to a few units in the last place, on every branch, over 1e-3..1e9.
    #[test]
    fn logarithmic_form_matches_the_power_form_everywhere() {
        fn cd_power(re: f64) -> f64 {
            let re = re.max(RE_FLOOR);
            let supercritical = |re: f64| {
                (CD_SUPERCRITICAL_GAIN * re.powf(CD_SUPERCRITICAL_EXPONENT)).min(CD_TRANSCRITICAL)
            };
            if re <= CD_CREEPING_MAX_RE {
                CD_CREEPING_GAIN * re.powf(CD_CREEPING_EXPONENT)
            } else if re <= CD_CRISIS_START_RE {
                (CD_LOW_RE_GAIN * re.powf(CD_LOW_RE_EXPONENT)).max(CD_SUBCRITICAL)
            } else if re <= CD_SUPERCRITICAL_START_RE {
                let end = supercritical(CD_SUPERCRITICAL_START_RE);
                let s = (re / CD_CRISIS_START_RE).ln()
                    / (CD_SUPERCRITICAL_START_RE / CD_CRISIS_START_RE).ln();
                (CD_SUBCRITICAL.ln() + s * (end.ln() - CD_SUBCRITICAL.ln())).exp()
            } else {
                supercritical(re)
            }
        }
        fn cf_power(re: f64) -> f64 {
            let re = re.max(RE_FLOOR);
            let turbulent = (CF_TURBULENT_GAIN * re.powf(CF_TURBULENT_EXPONENT)).max(CF_MIN);
            turbulent.max(CF_LAMINAR_GAIN * re.powf(CF_LAMINAR_EXPONENT))
        }
        let mut worst = 0.0_f64;
        for i in 0..=120_000 {
            let re = 10f64.powf(-3.0 + 12.0 * f64::from(i) / 120_000.0);
            for (fast, power) in [(cd(re), cd_power(re)), (cf(re), cf_power(re))] {
                worst = worst.max((fast / power - 1.0).abs());
            }
        }
        assert!(worst < 1e-13, "largest relative difference {worst:e}");
    }

    /// The link force from the logarithmic laws is the force of [R]'s laws.
    #[test]
    fn link_force_uses_the_speed_reynolds_numbers() {
        let p = crate::world::hose::HoseParams::default();
        let m = Model::new(&p);
        let nu = p.air_dynamic_viscosity_pa_s / p.air_density_kg_per_m3;
        let e = Vector3::new(0.6, 0.0, 0.8);
        for rel in [
            Vector3::new(-120.0, 3.0, -2.0),
            Vector3::new(0.0, 0.01, 0.0),
        ] {
            let speed = rel.norm();
            let cd_ = cd(speed * 2.0 * p.hose_outer_radius_m / nu);
            let cf_ = cf(speed * std::f64::consts::PI * p.hose_outer_radius_m / nu);
            let v_t = rel.dot(&e);
            let v_n = rel - e * v_t;
            let want =
                e * (m.skin_k * cf_ * v_t * v_t.abs()) + v_n * (m.normal_k * cd_ * v_n.norm());
            let got = m.link_aero(rel, e);
            assert!(
                (got - want).norm() <= 1e-12 * want.norm(),
                "{got} vs {want}"
            );
        }
        assert_eq!(m.link_aero(Vector3::zeros(), e), Vector3::zeros());
    }

    #[test]
    fn operating_point_reynolds_numbers_and_viscosity() {
        // The operating point: 120 m/s at 3000 m.
        let nu = AIR_DYNAMIC_VISCOSITY_3000M_PA_S / AIR_DENSITY_3000M_KG_PER_M3;
        let re_d = V_MPS * 2.0 * HOSE_OUTER_RADIUS_M / nu;
        println!(
            "Re_d {re_d:.0}, Cd {:.4}, Re_f {:.0}, Cf {:.5}",
            cd(re_d),
            re_d * std::f64::consts::FRAC_PI_2,
            cf(re_d * std::f64::consts::FRAC_PI_2)
        );
        // Sutherland's law at the ISA temperature of 3000 m.
        let t: f64 = 288.15 - 6.5e-3 * 3000.0;
        let mu = 1.458e-6 * t.powf(1.5) / (t + 110.4);
        assert!((mu / AIR_DYNAMIC_VISCOSITY_3000M_PA_S - 1.0).abs() < 1e-4);
    }

    /// The drag scale multiplies both of a link's coefficients: the link force scales by it.
    #[test]
    fn the_drag_scale_multiplies_the_link_force() {
        let p = crate::world::hose::HoseParams::default();
        let base = Model::new(&p);
        let e = Vector3::new(-0.95, 0.1, 0.3).normalize();
        for scale in [0.0, 0.5, 2.0] {
            let m = Model::new(&crate::world::hose::HoseParams {
                hose_drag_scale: scale,
                ..p
            });
            for rel in [
                Vector3::new(-120.0, 3.0, -2.0),
                Vector3::new(-80.0, -1.0, 4.0),
            ] {
                let (got, want) = (m.link_aero(rel, e), base.link_aero(rel, e) * scale);
                assert!(
                    (got - want).norm() <= 1e-12 * want.norm().max(1.0),
                    "{scale}: {got} vs {want}"
                );
            }
            // The drogue's drag is the drogue's: not scaled.
            assert_eq!(
                m.drogue_drag(Vector3::new(-120.0, 0.0, 0.0)),
                base.drogue_drag(Vector3::new(-120.0, 0.0, 0.0))
            );
        }
    }
}
