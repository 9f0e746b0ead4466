//! The bow wave: the force the receiver's forebody flow field exerts on the drogue as the
//! probe approaches it, from the authors' closed-form fit.
//!
//! Source: docs/models.md, "Bow wave" (\[D\] Dai, Wei & Quan 2016; the closed form used in \[R\]).
//! With `(x, y, z)` = drogue position minus (receiver CG + [3.75, 0, -0.86] m), tanker axes
//! (x forward, y right, z down), m, the force on the drogue in tanker axes, N, is
//!
//! ```text
//! Fx = A                              for 3.0893 < x <= 5.6493, A + B for x <= 3.0893, else 0
//!   A = 91.6170 (1 - 0.3220 (x - 3.8870)^2) exp(-y^2/2.7359) exp(z/2.4939)
//!   B = 309.7709 (1 - 0.3237 x) exp(-y^2/0.3851) exp(z/1.1471)
//! Fy = 223.3210 (1 - 0.2082 x) y exp(-y^2/0.8102) exp(z/0.6555)     for x <= 4.8031, else 0
//! Fz = -173.2021 (1 - 0.2141 x) exp(-y^2/0.5697) exp(z/0.7038)      for x <= 4.6275, else 0
//! ```
//!
//! At the docked geometry (probe tip at `(2.31, 0.54, 0)`) it is about (+53, +44, -52) N:
//! forward, outward, upward. [`bow_wave_fit_n`] is this fit as published.
//!
//! Continuity of the published fit (measured in the tests): at x = 3.0893 (end of `B`), 4.8031
//! (`Fy`) and 5.6493 (`Fx`) the cut-offs sit at the zeros of their polynomial factors to five
//! digits, so the jumps are below 2.0e-3, 4.7e-4 and 3.3e-3 N at `z = 0` (times the
//! `exp(z/..)` factor elsewhere: at most 5 mN in the domain below). At x = 4.6275 `Fz` is cut
//! off before its factor's zero (x = 4.6707): `Fz` jumps from -1.60 N to 0 at `y = z = 0`,
//! -1.60 exp(-y^2/0.5697) exp(z/0.7038) N in general, at most 6.6 N in the domain. We keep
//! the published fit unchanged.
//!
//! Domain (ours): the fit is a smooth model of the flow around the probe and forebody, and it
//! is unbounded outside it (the `exp(z/..)` terms grow without limit below the probe, the
//! polynomials in `x` grow behind the nose). [`bow_wave_force_tanker_n`] evaluates it on the
//! box [`DOMAIN_MIN_M`]..[`DOMAIN_MAX_M`]: `x >= 0` (aft of the nose reference the drogue would
//! be alongside the fuselage; the fit's own cut-offs end it ahead at 5.6493 m), `|y| <= 2.5`
//! and `-2.5 <= z <= 1.0` m (the drogue within 2.5 m of the probe's line; 1 m below it is
//! about the height of the receiver's CG and fuselage centreline, the reference being 0.86 m
//! above the CG: there a drogue ahead of the nose meets the forebody, which the fit does not
//! model and the contact model owns). Outside the box the force is the fit at the nearest box point times a
//! linear taper `max(0, 1 - d / TAPER_M)`, `d` the distance to the box: continuous across the
//! box faces, and exactly zero further than [`TAPER_M`] = 1 m from the box. The result is
//! bounded everywhere by [`FORCE_BOUND_N`] (the fit's maximum on the box, tested).
//!
//! Flight condition: the fit was made at one condition, the refuelling one (120 m/s; its
//! density unstated, taken as our 3000 m air). Its force is that of a potential flow with a
//! viscous correction, whose pressures scale with the dynamic pressure: at another condition
//! the world multiplies it by `rho V^2 / (rho0 V0^2)` (`world/flight.rs`,
//! `FlightCondition::bow_wave_scale`, exactly 1 at the default condition) and keeps the
//! field's geometry (the forebody is the same). The bound below is at the default condition.
//!
//! Invariants: finite inputs give finite forces of norm at most [`FORCE_BOUND_N`]; zero for
//! `x > 5.6493` m and beyond the taper; `NaN` in gives `NaN` out.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// Nose reference point relative to the receiver CG, tanker axes, m (docs/models.md,
/// "Bow wave"; \[R\]).
pub const NOSE_REF_FROM_CG_M: [f64; 3] = [3.75, 0.0, -0.86];

// Fit coefficients (docs/models.md, "Bow wave"). Lengths in m, forces in N.
/// `Fx` is zero ahead of this x, m.
pub const FX_END_X_M: f64 = 5.6493;
/// `Fx` gains the near-field term `B` at and behind this x, m.
pub const FX_NEAR_END_X_M: f64 = 3.0893;
/// `Fy` is zero ahead of this x, m.
pub const FY_END_X_M: f64 = 4.8031;
/// `Fz` is zero ahead of this x, m.
pub const FZ_END_X_M: f64 = 4.6275;

const FX_A_GAIN_N: f64 = 91.6170;
const FX_A_CURVATURE_PER_M2: f64 = 0.3220;
const FX_A_CENTRE_X_M: f64 = 3.8870;
const FX_A_Y_SCALE_M2: f64 = 2.7359;
const FX_A_Z_SCALE_M: f64 = 2.4939;
const FX_B_GAIN_N: f64 = 309.7709;
const FX_B_SLOPE_PER_M: f64 = 0.3237;
const FX_B_Y_SCALE_M2: f64 = 0.3851;
const FX_B_Z_SCALE_M: f64 = 1.1471;
const FY_GAIN_N_PER_M: f64 = 223.3210;
const FY_SLOPE_PER_M: f64 = 0.2082;
const FY_Y_SCALE_M2: f64 = 0.8102;
const FY_Z_SCALE_M: f64 = 0.6555;
const FZ_GAIN_N: f64 = -173.2021;
const FZ_SLOPE_PER_M: f64 = 0.2141;
const FZ_Y_SCALE_M2: f64 = 0.5697;
const FZ_Z_SCALE_M: f64 = 0.7038;

/// Lower corner of the box where the fit is evaluated as is, `(x, y, z)`, m (ours, see the
/// module doc).
pub const DOMAIN_MIN_M: [f64; 3] = [0.0, -2.5, -2.5];
/// Upper corner of the box, m; no upper limit in x (the fit is zero ahead of
/// [`FX_END_X_M`]).
pub const DOMAIN_MAX_M: [f64; 3] = [f64::INFINITY, 2.5, 1.0];
/// Distance over which the force tapers linearly to zero outside the box, m (ours).
pub const TAPER_M: f64 = 1.0;
/// Upper bound on the norm of [`bow_wave_force_tanker_n`], N: the fit's maximum norm on the
/// box (748 N, at `x = 0, y = 0, z = 1`: (212, 0, -717) N) with a margin.
pub const FORCE_BOUND_N: f64 = 800.0;

/// The published fit, unbounded, no domain: force on the drogue, tanker axes, N, for
/// `d = (x, y, z)` = drogue minus nose reference, tanker axes, m. Only meaningful near the
/// nose: use [`bow_wave_force_tanker_n`] in a simulation.
pub fn bow_wave_fit_n(d: &Vector3<f64>) -> Vector3<f64> {
    let (x, y, z) = (d.x, d.y, d.z);
    let y2 = y * y;
    let fx = if x > FX_END_X_M {
        0.0
    } else {
        let dx = x - FX_A_CENTRE_X_M;
        let a = FX_A_GAIN_N
            * (1.0 - FX_A_CURVATURE_PER_M2 * dx * dx)
            * (z / FX_A_Z_SCALE_M - y2 / FX_A_Y_SCALE_M2).exp();
        if x <= FX_NEAR_END_X_M {
            a + FX_B_GAIN_N
                * (1.0 - FX_B_SLOPE_PER_M * x)
                * (z / FX_B_Z_SCALE_M - y2 / FX_B_Y_SCALE_M2).exp()
        } else {
            a
        }
    };
    let fy = if x > FY_END_X_M {
        0.0
    } else {
        FY_GAIN_N_PER_M
            * (1.0 - FY_SLOPE_PER_M * x)
            * y
            * (z / FY_Z_SCALE_M - y2 / FY_Y_SCALE_M2).exp()
    };
    let fz = if x > FZ_END_X_M {
        0.0
    } else {
        FZ_GAIN_N * (1.0 - FZ_SLOPE_PER_M * x) * (z / FZ_Z_SCALE_M - y2 / FZ_Y_SCALE_M2).exp()
    };
    Vector3::new(fx, fy, fz)
}

/// Bow-wave force on the drogue, tanker axes, N, for `drogue_minus_nose_ref_m` = drogue
/// position minus (receiver CG + [`NOSE_REF_FROM_CG_M`]), tanker axes, m.
///
/// The fit inside the domain box, the fit at the nearest box point tapered linearly to zero
/// over [`TAPER_M`] outside it (module doc). Bounded by [`FORCE_BOUND_N`]; `NaN` gives `NaN`.
pub fn bow_wave_force_tanker_n(drogue_minus_nose_ref_m: &Vector3<f64>) -> Vector3<f64> {
    let d = drogue_minus_nose_ref_m;
    if d.iter().any(|c| c.is_nan()) {
        return Vector3::repeat(f64::NAN);
    }
    let clamped = Vector3::new(
        d.x.clamp(DOMAIN_MIN_M[0], DOMAIN_MAX_M[0]),
        d.y.clamp(DOMAIN_MIN_M[1], DOMAIN_MAX_M[1]),
        d.z.clamp(DOMAIN_MIN_M[2], DOMAIN_MAX_M[2]),
    );
    let outside = d - clamped;
    let dist_sq = outside.norm_squared();
    if dist_sq == 0.0 {
        return bow_wave_fit_n(d);
    }
    let taper = 1.0 - dist_sq.sqrt() / TAPER_M;
    if taper > 0.0 {
        bow_wave_fit_n(&clamped) * taper
    } else {
        Vector3::zeros()
    }
}

/// Bow-wave configuration.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BowWaveParams {
    /// When false the force is zero.
    pub enabled: bool,
    /// Nose reference relative to the receiver CG, tanker axes (not rotated with the
    /// receiver's attitude, as in the fit), m.
    pub nose_ref_from_cg_tanker_m: Vector3<f64>,
}

impl Default for BowWaveParams {
    fn default() -> Self {
        Self {
            enabled: true,
            nose_ref_from_cg_tanker_m: Vector3::from(NOSE_REF_FROM_CG_M),
        }
    }
}

impl BowWaveParams {
    /// Force on the drogue at `drogue_tanker_m` from a receiver whose CG is at
    /// `receiver_cg_tanker_m` (both tanker frame, m), tanker axes, N.
    pub fn force_on_drogue_tanker_n(
        &self,
        drogue_tanker_m: &Vector3<f64>,
        receiver_cg_tanker_m: &Vector3<f64>,
    ) -> Vector3<f64> {
        if !self.enabled {
            return Vector3::zeros();
        }
        bow_wave_force_tanker_n(
            &(drogue_tanker_m - receiver_cg_tanker_m - self.nose_ref_from_cg_tanker_m),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f64, y: f64, z: f64) -> Vector3<f64> {
        Vector3::new(x, y, z)
    }

    /// The docked geometry of docs/models.md, "Bow wave": about (+53, +44, -52) N.
    #[test]
    fn docked_value() {
        let f = bow_wave_force_tanker_n(&v(2.31, 0.54, 0.0));
        eprintln!("bow wave at (2.31, 0.54, 0): {:?} N", [f.x, f.y, f.z]);
        assert!((f.x - 53.0).abs() < 0.5, "{f:?}");
        assert!((f.y - 44.0).abs() < 0.5, "{f:?}");
        assert!((f.z + 52.0).abs() < 0.6, "{f:?}");
        // Through the parameters: tip at the drogue, receiver CG from the probe mount.
        let cg = v(-20.41, -0.54, 5.98);
        let drogue = cg + v(6.06, 0.54, -0.86);
        let p = BowWaveParams::default();
        assert!((p.force_on_drogue_tanker_n(&drogue, &cg) - f).norm() < 1e-9);
        let off = BowWaveParams {
            enabled: false,
            ..p
        };
        assert_eq!(off.force_on_drogue_tanker_n(&drogue, &cg), Vector3::zeros());
    }

    /// The jump of each component across each cut-off of the published fit, at
    /// `y = z = 0` (y = 0.6365, the peak of `y exp(-y^2/0.8102)`, for `Fy`).
    #[test]
    fn continuity_report() {
        let eps = 1e-9;
        let jump = |x: f64, y: f64, z: f64| {
            bow_wave_fit_n(&v(x + eps, y, z)) - bow_wave_fit_n(&v(x, y, z))
        };
        let j = jump(FX_NEAR_END_X_M, 0.0, 0.0);
        eprintln!("jump at x = {FX_NEAR_END_X_M}: {:?} N", [j.x, j.y, j.z]);
        assert!((j.x - 1.99e-3).abs() < 0.02e-3 && j.y == 0.0 && j.z.abs() < 1e-6);
        let j = jump(FZ_END_X_M, 0.0, 0.0);
        eprintln!("jump at x = {FZ_END_X_M}: {:?} N", [j.x, j.y, j.z]);
        assert!((j.z - 1.6025).abs() < 1e-3 && j.x.abs() < 1e-6 && j.y == 0.0);
        let j = jump(FY_END_X_M, 0.6365, 0.0);
        eprintln!("jump at x = {FY_END_X_M}: {:?} N", [j.x, j.y, j.z]);
        assert!((j.y - 4.67e-4).abs() < 0.02e-4 && j.x.abs() < 1e-6 && j.z == 0.0);
        let j = jump(FX_END_X_M, 0.0, 0.0);
        eprintln!("jump at x = {FX_END_X_M}: {:?} N", [j.x, j.y, j.z]);
        assert!((j.x - 3.28e-3).abs() < 0.02e-3 && j.y == 0.0 && j.z == 0.0);
        // Largest jumps anywhere in the domain box (the exp(z/..) factors peak at z = 1).
        let zmax = DOMAIN_MAX_M[2];
        assert!(jump(FZ_END_X_M, 0.0, zmax).z < 6.7);
        for x in [FX_NEAR_END_X_M, FY_END_X_M, FX_END_X_M] {
            for y in [0.0, 0.3, 0.6365, 1.0] {
                assert!(jump(x, y, zmax).norm() < 5e-3, "x {x}, y {y}");
            }
        }
        // Elsewhere the fit is continuous (smooth terms): small steps give small changes.
        for x in [0.0, 1.0, 2.31, 3.5, 4.0, 5.0] {
            assert!(jump(x, 0.54, 0.0).norm() < 1e-6, "x {x}");
        }
    }

    /// Zero ahead of the fit's end and beyond the taper; continuous across the box faces.
    #[test]
    fn zero_beyond_range() {
        for d in [
            v(5.65, 0.0, 0.0),
            v(8.31, 2.54, -2.0), // the paper's start: drogue 6 m ahead of the tip
            v(-1.0, 0.0, 0.0),
            v(2.31, 3.5, 0.0),
            v(2.31, -3.5, 0.0),
            v(2.31, 0.0, -3.5),
            v(2.31, 0.54, 2.0),
            v(-50.0, 0.0, 40.0),
            v(f64::NEG_INFINITY, 0.0, 0.0),
            v(2.0, 0.0, f64::INFINITY),
        ] {
            assert_eq!(bow_wave_force_tanker_n(&d), Vector3::zeros(), "{d:?}");
        }
        // Inside the box: the fit itself.
        let p = v(2.0, -0.7, 0.8);
        assert_eq!(bow_wave_force_tanker_n(&p), bow_wave_fit_n(&p));
        // Across each face the force is continuous, and half-way through the taper it is half.
        for (inside, normal) in [
            (v(0.0, 0.3, 0.2), v(-1.0, 0.0, 0.0)),
            (v(2.31, 2.5, 0.0), v(0.0, 1.0, 0.0)),
            (v(2.31, -2.5, 0.0), v(0.0, -1.0, 0.0)),
            (v(2.31, 0.54, -2.5), v(0.0, 0.0, -1.0)),
            (v(2.31, 0.54, 1.0), v(0.0, 0.0, 1.0)),
        ] {
            let at = bow_wave_force_tanker_n(&inside);
            let just_out = bow_wave_force_tanker_n(&(inside + 1e-9 * normal));
            assert!(
                (at - just_out).norm() < 1e-6 * (1.0 + at.norm()),
                "{inside:?}"
            );
            let half = bow_wave_force_tanker_n(&(inside + 0.5 * normal));
            assert!(
                (half - 0.5 * at).norm() < 1e-9 * (1.0 + at.norm()),
                "{inside:?}"
            );
        }
        assert!(bow_wave_force_tanker_n(&v(f64::NAN, 0.0, 0.0)).x.is_nan());
    }

    /// Bounded on a wide grid (including far below, where the raw fit explodes), and the
    /// stated bound is the box maximum.
    #[test]
    fn bounded_on_wide_grid() {
        let axis =
            |lo: f64, hi: f64, n: usize| (0..=n).map(move |i| lo + (hi - lo) * i as f64 / n as f64);
        let mut max_box: f64 = 0.0;
        for x in axis(0.0, 6.0, 60) {
            for y in axis(-2.5, 2.5, 50) {
                for z in axis(-2.5, 1.0, 35) {
                    max_box = max_box.max(bow_wave_fit_n(&v(x, y, z)).norm());
                }
            }
        }
        let peak = bow_wave_fit_n(&v(0.0, 0.0, DOMAIN_MAX_M[2]));
        eprintln!("bow-wave maximum on the domain box: {max_box:.1} N; at (0, 0, 1): {peak:?}");
        assert_eq!(
            max_box,
            peak.norm(),
            "the maximum is at x = 0, y = 0, z = 1"
        );
        assert!(max_box < FORCE_BOUND_N && max_box > 0.9 * FORCE_BOUND_N);
        let mut max_all: f64 = 0.0;
        for x in axis(-100.0, 100.0, 80) {
            for y in axis(-50.0, 50.0, 40) {
                for z in axis(-50.0, 50.0, 40) {
                    let f = bow_wave_force_tanker_n(&v(x, y, z));
                    assert!(f.iter().all(|c| c.is_finite()), "({x}, {y}, {z})");
                    max_all = max_all.max(f.norm());
                }
            }
        }
        assert!(max_all <= FORCE_BOUND_N, "{max_all}");
        // The raw fit is not bounded there: this is what the domain rule is for.
        assert!(bow_wave_fit_n(&v(2.31, 0.0, 10.0)).norm() > 1e6);
    }
}
