//! The hose's equations of motion: the constants derived from the parameters (node masses,
//! drag factors), the node accelerations with the link tensions as constraint multipliers,
//! classical RK4, and the projections back onto the link-length constraints.
//!
//! Place in the data flow: `HoseDrogue::step` calls [`Model::rk4`] then the two projections
//! per internal step, and [`Model::accelerations`] once more for the tensions it stores;
//! `steady` calls [`Model::accelerations`] to check its equilibrium. Forces come from `drag`,
//! the tridiagonal solves from `solver`.
//!
//! Invariants: nothing here allocates (all scratch space is in [`Workspace`], sized at
//! construction); node 0 (the hose exit) has zero inverse mass, so neither RK4 nor the
//! projections move it; the arithmetic is in a fixed order, so the same inputs give
//! bit-identical states.

use nalgebra::Vector3;

use super::params::{HoseDragLaw, HoseParams};
use super::solver::solve_tridiagonal;

/// Position projection: relative constraint error (`|C_k| / l^2`) below which it stops.
const PROJECTION_TOLERANCE: f64 = 1e-14;

/// Position projection: Gauss-Newton iterations at most (one or two are used in practice).
const PROJECTION_MAX_ITERATIONS: usize = 6;

/// Derived constants of the model, computed once from the parameters.
#[derive(Debug, Clone)]
pub(super) struct Model {
    pub(super) links: usize,
    pub(super) link_len: f64,
    /// Node masses, kg, nodes 0..=N (node 0 carries the fixed exit's share; unused).
    pub(super) node_mass: Vec<f64>,
    /// Inverse node masses, 1/kg; node 0 is fixed (0).
    pub(super) inv_mass: Vec<f64>,
    pub(super) max_inv_mass: f64,
    pub(super) total_mass: f64,
    pub(super) gravity: f64,
    /// `0.5 rho pi d l s`, skin friction: force = k Cf v_t |v_t| (`s` the drag scale).
    pub(super) skin_k: f64,
    /// `0.5 rho d l s`, cross flow: force = k Cd |v_n| v_n (`s` the drag scale).
    pub(super) normal_k: f64,
    /// `0.5 rho (pi D^2 / 4) Cd`, drogue: force = k |v| v.
    pub(super) drogue_k: f64,
    /// Logarithm of the diameter over the kinematic viscosity (s/m):
    /// `ln Re_d = ln |v| + this`.
    pub(super) ln_re_d_per_speed: f64,
    /// Logarithm of the half circumference over the kinematic viscosity (s/m):
    /// `ln Re_f = ln |v| + this`.
    pub(super) ln_re_f_per_speed: f64,
    pub(super) law: HoseDragLaw,
}

impl Model {
    pub(super) fn new(p: &HoseParams) -> Self {
        let n = p.link_count;
        let l = p.hose_length_m / n as f64;
        let link_mass = p.hose_linear_density_kg_per_m * l;
        let mut node_mass = vec![link_mass; n + 1];
        node_mass[0] = 0.5 * link_mass;
        node_mass[n] = 0.5 * link_mass + p.drogue_mass_kg;
        let mut inv_mass: Vec<f64> = node_mass.iter().map(|m| 1.0 / m).collect();
        inv_mass[0] = 0.0;
        let max_inv_mass = inv_mass.iter().copied().fold(0.0, f64::max);
        let total_mass = node_mass[1..].iter().sum();
        let rho = p.air_density_kg_per_m3;
        let diameter = 2.0 * p.hose_outer_radius_m;
        let nu = p.air_dynamic_viscosity_pa_s / rho;
        let drogue_area = std::f64::consts::PI * p.drogue_canopy_diameter_m.powi(2) / 4.0;
        Self {
            links: n,
            link_len: l,
            node_mass,
            inv_mass,
            max_inv_mass,
            total_mass,
            gravity: p.gravity_mps2,
            // The scale is 1 by default, and `x * 1.0` is `x`: the default model is unchanged.
            skin_k: 0.5 * rho * std::f64::consts::PI * diameter * l * p.hose_drag_scale,
            normal_k: 0.5 * rho * diameter * l * p.hose_drag_scale,
            drogue_k: 0.5 * rho * drogue_area * p.drogue_drag_coefficient,
            ln_re_d_per_speed: (diameter / nu).ln(),
            ln_re_f_per_speed: (std::f64::consts::PI * p.hose_outer_radius_m / nu).ln(),
            law: p.hose_drag_law,
        }
    }

    /// Node accelerations (into `ws.acc`) and constraint multipliers (into `ws.mu`) for the
    /// given state, air samples and drogue force.
    ///
    /// One pass over the links computes the geometry, the aerodynamic forces, the matrix
    /// `J M^-1 J^T` and the right-hand side, and runs the forward sweep of the Thomas
    /// algorithm a row behind (each row is complete once the next link's force is known), so
    /// that the sweep's chain of divisions overlaps the drag laws' `pow` calls instead of
    /// waiting for them; then the back substitution and the accelerations. The slices are cut
    /// to their lengths up front, so the loops carry no bounds checks. Every value is computed
    /// by the same operations in the same order as the plain formulation kept in the tests
    /// (`accelerations_reference`: forces, right-hand side, matrix, then
    /// [`solve_tridiagonal`]), which checks that the two agree bit for bit.
    pub(super) fn accelerations(
        &self,
        pos: &[Vector3<f64>],
        vel: &[Vector3<f64>],
        air: &[Vector3<f64>],
        force: Vector3<f64>,
        ws: &mut Workspace,
    ) {
        let n = self.links;
        let g = Vector3::new(0.0, 0.0, self.gravity);
        let (pos, vel, air) = (&pos[..=n], &vel[..=n], &air[..=n]);
        let (mass, inv) = (&self.node_mass[..=n], &self.inv_mass[..=n]);
        let f = &mut ws.f[..=n];
        let d_out = &mut ws.d[..n];
        let mu = &mut ws.mu[..n];
        let diag = &mut ws.diag[..n];
        let off = &mut ws.off[..n - 1];
        let scratch = &mut ws.scratch[..n];
        // `carry` is node k + 1's weight plus link k's half of its force, to which link k + 1's
        // half is added next: f_k = (g m_k + half_k-1) + half_k. `a_prev` is node k - 1's free
        // acceleration f / m, `pivot` the Thomas pivot of row k - 1. `mu` holds the right-hand
        // side, forward-eliminated row by row, then the multipliers.
        let mut carry = g * mass[0];
        let mut a_prev = Vector3::zeros();
        let mut pivot = 0.0;
        for k in 0..n {
            let d = pos[k + 1] - pos[k];
            let w = vel[k + 1] - vel[k];
            let d_sq = d.norm_squared();
            let e = d * (1.0 / d_sq.sqrt());
            let mid_vel = (vel[k] + vel[k + 1]) * 0.5;
            let half = self.link_aero(air[k] - mid_vel, e) * 0.5;
            f[k] = carry + half;
            carry = g * mass[k + 1] + half;
            // Row k: -(d . (a_free[k+1] - a_free[k]) + |w|^2); |w|^2 here, the rest at k + 1.
            mu[k] = -w.norm_squared();
            diag[k] = d_sq * (inv[k + 1] + inv[k]);
            let a_k = f[k] * inv[k];
            if k == 0 {
                pivot = diag[0];
            } else {
                // Row k - 1 is complete: finish it, eliminate it, and the next pivot.
                mu[k - 1] -= d_out[k - 1].dot(&(a_k - a_prev));
                Self::eliminate(k - 1, off, mu, pivot);
                let o = -d_out[k - 1].dot(&d) * inv[k];
                off[k - 1] = o;
                scratch[k - 1] = o / pivot;
                pivot = diag[k] - o * scratch[k - 1];
            }
            d_out[k] = d;
            a_prev = a_k;
        }
        f[n] = carry + (self.drogue_drag(air[n] - vel[n]) + force);
        mu[n - 1] -= d_out[n - 1].dot(&(f[n] * inv[n] - a_prev));
        Self::eliminate(n - 1, off, mu, pivot);
        for k in (0..n - 1).rev() {
            mu[k] -= scratch[k] * mu[k + 1];
        }
        // Node accelerations, the tensions pulling along the links.
        let (d, mu, f) = (&ws.d[..n], &ws.mu[..n], &ws.f[..=n]);
        let acc = &mut ws.acc[..=n];
        acc[0] = (f[0] + d[0] * (-mu[0])) * inv[0];
        for j in 1..n {
            acc[j] = ((f[j] + d[j - 1] * mu[j - 1]) + d[j] * (-mu[j])) * inv[j];
        }
        acc[n] = (f[n] + d[n - 1] * mu[n - 1]) * inv[n];
    }

    /// The forward sweep of [`solve_tridiagonal`] on row `k` of `rhs`, with that row's pivot.
    #[inline(always)]
    fn eliminate(k: usize, off: &[f64], rhs: &mut [f64], pivot: f64) {
        if k == 0 {
            rhs[0] /= pivot;
        } else {
            rhs[k] = (rhs[k] - off[k - 1] * rhs[k - 1]) / pivot;
        }
    }

    /// The tridiagonal `J M^-1 J^T` for the link vectors in `ws.d`.
    pub(super) fn build_matrix(&self, ws: &mut Workspace) {
        let n = self.links;
        for k in 0..n {
            let d = ws.d[k];
            ws.diag[k] = d.norm_squared() * (self.inv_mass[k + 1] + self.inv_mass[k]);
            if k + 1 < n {
                ws.off[k] = -d.dot(&ws.d[k + 1]) * self.inv_mass[k + 1];
            }
        }
    }

    /// Applies `M^-1 J^T mu` (multipliers in `ws.rhs`) to `x` (positions or velocities).
    pub(super) fn apply_correction(&self, x: &mut [Vector3<f64>], ws: &Workspace) {
        let n = self.links;
        for (j, xj) in x.iter_mut().enumerate().skip(1) {
            let mut c = ws.d[j - 1] * ws.rhs[j - 1];
            if j < n {
                c += ws.d[j] * (-ws.rhs[j]);
            }
            *xj += c * self.inv_mass[j];
        }
    }

    /// One classical RK4 step of length `h`.
    pub(super) fn rk4(
        &self,
        h: f64,
        pos: &mut [Vector3<f64>],
        vel: &mut [Vector3<f64>],
        air: &[Vector3<f64>],
        force: Vector3<f64>,
        ws: &mut Workspace,
    ) {
        const STAGE_FRACTION: [f64; 4] = [0.0, 0.5, 0.5, 1.0];
        const STAGE_WEIGHT: [f64; 4] = [1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0];
        let m = self.links + 1;
        let (pos, vel) = (&mut pos[..m], &mut vel[..m]);
        // The stage states live outside `ws` while `accelerations` works in it.
        let (mut ps_buf, mut vs_buf) = (std::mem::take(&mut ws.ps), std::mem::take(&mut ws.vs));
        let (ps, vs) = (&mut ps_buf[..m], &mut vs_buf[..m]);
        // Stage 1 at the start state; the sums start from zero (`0 + x`, as first written).
        self.accelerations(pos, vel, air, force, ws);
        let wgt = STAGE_WEIGHT[0] * h;
        let (sum_p, sum_v, acc) = (&mut ws.sum_p[..m], &mut ws.sum_v[..m], &ws.acc[..m]);
        for j in 0..m {
            sum_p[j] = Vector3::zeros() + vel[j] * wgt;
            sum_v[j] = Vector3::zeros() + acc[j] * wgt;
        }
        for stage in 1..4 {
            // From the previous stage's velocity (the position derivative) and acceleration.
            let c = STAGE_FRACTION[stage] * h;
            let acc = &ws.acc[..m];
            for j in 0..m {
                let previous_vel = if stage == 1 { vel[j] } else { vs[j] };
                ps[j] = pos[j] + previous_vel * c;
                vs[j] = vel[j] + acc[j] * c;
            }
            self.accelerations(ps, vs, air, force, ws);
            let wgt = STAGE_WEIGHT[stage] * h;
            let (sum_p, sum_v, acc) = (&mut ws.sum_p[..m], &mut ws.sum_v[..m], &ws.acc[..m]);
            for j in 0..m {
                sum_p[j] += vs[j] * wgt;
                sum_v[j] += acc[j] * wgt;
            }
        }
        let (sum_p, sum_v) = (&ws.sum_p[..m], &ws.sum_v[..m]);
        for j in 1..m {
            pos[j] += sum_p[j];
            vel[j] += sum_v[j];
        }
        ws.ps = ps_buf;
        ws.vs = vs_buf;
    }

    /// Mass-weighted projection of the positions onto `|p_k+1 - p_k| = l` (Gauss-Newton).
    pub(super) fn project_positions(&self, pos: &mut [Vector3<f64>], ws: &mut Workspace) {
        let n = self.links;
        let l2 = self.link_len * self.link_len;
        for _ in 0..PROJECTION_MAX_ITERATIONS {
            let mut worst = 0.0_f64;
            for k in 0..n {
                let d = pos[k + 1] - pos[k];
                ws.d[k] = d;
                let c = 0.5 * (d.norm_squared() - l2);
                worst = worst.max(c.abs());
                ws.rhs[k] = -c;
            }
            if worst <= PROJECTION_TOLERANCE * l2 {
                return;
            }
            self.build_matrix(ws);
            solve_tridiagonal(&ws.diag, &ws.off, &mut ws.rhs, &mut ws.scratch);
            self.apply_correction(pos, ws);
        }
    }

    /// Mass-weighted projection of the velocities onto `(p_k+1 - p_k) . (v_k+1 - v_k) = 0`.
    pub(super) fn project_velocities(
        &self,
        pos: &[Vector3<f64>],
        vel: &mut [Vector3<f64>],
        ws: &mut Workspace,
    ) {
        let n = self.links;
        for k in 0..n {
            let d = pos[k + 1] - pos[k];
            ws.d[k] = d;
            ws.rhs[k] = -d.dot(&(vel[k + 1] - vel[k]));
        }
        self.build_matrix(ws);
        solve_tridiagonal(&ws.diag, &ws.off, &mut ws.rhs, &mut ws.scratch);
        self.apply_correction(vel, ws);
    }
}

/// Preallocated scratch space, so that `step` does not allocate.
#[derive(Debug, Clone)]
pub(super) struct Workspace {
    /// Link vectors `p_k+1 - p_k` (also the link directions in the static solve).
    pub(super) d: Vec<Vector3<f64>>,
    /// Node forces other than the constraints, N.
    pub(super) f: Vec<Vector3<f64>>,
    /// Node accelerations, m/s^2.
    pub(super) acc: Vec<Vector3<f64>>,
    /// Constraint multipliers of the last acceleration solve (tension = -mu l).
    pub(super) mu: Vec<f64>,
    /// Tridiagonal matrix: diagonal and off-diagonal.
    pub(super) diag: Vec<f64>,
    pub(super) off: Vec<f64>,
    /// Right-hand side, overwritten by the solution.
    pub(super) rhs: Vec<f64>,
    pub(super) scratch: Vec<f64>,
    /// RK4 stage state and accumulators.
    pub(super) ps: Vec<Vector3<f64>>,
    pub(super) vs: Vec<Vector3<f64>>,
    pub(super) sum_p: Vec<Vector3<f64>>,
    pub(super) sum_v: Vec<Vector3<f64>>,
}

impl Workspace {
    pub(super) fn new(links: usize) -> Self {
        let nodes = links + 1;
        Self {
            d: vec![Vector3::zeros(); links],
            f: vec![Vector3::zeros(); nodes],
            acc: vec![Vector3::zeros(); nodes],
            mu: vec![0.0; links],
            diag: vec![0.0; links],
            off: vec![0.0; links.saturating_sub(1).max(1)],
            rhs: vec![0.0; links],
            scratch: vec![0.0; links],
            ps: vec![Vector3::zeros(); nodes],
            vs: vec![Vector3::zeros(); nodes],
            sum_p: vec![Vector3::zeros(); nodes],
            sum_v: vec![Vector3::zeros(); nodes],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{Model, Workspace};
    use crate::world::hose::solver::solve_tridiagonal;
    use crate::world::hose::test_support::*;
    use crate::world::hose::*;
    use nalgebra::Vector3;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// `Model::accelerations` as first written: one loop per quantity, the matrix built from
    /// the stored link vectors. The model's results are defined by this order of operations.
    fn accelerations_reference(
        m: &Model,
        pos: &[Vector3<f64>],
        vel: &[Vector3<f64>],
        air: &[Vector3<f64>],
        force: Vector3<f64>,
        ws: &mut Workspace,
    ) {
        let n = m.links;
        let g = Vector3::new(0.0, 0.0, m.gravity);
        for j in 0..=n {
            ws.f[j] = g * m.node_mass[j];
        }
        for k in 0..n {
            let d = pos[k + 1] - pos[k];
            let w = vel[k + 1] - vel[k];
            ws.d[k] = d;
            let e = d * (1.0 / d.norm());
            let mid_vel = (vel[k] + vel[k + 1]) * 0.5;
            let half = m.link_aero(air[k] - mid_vel, e) * 0.5;
            ws.f[k] += half;
            ws.f[k + 1] += half;
            ws.rhs[k] = -w.norm_squared();
        }
        ws.f[n] += m.drogue_drag(air[n] - vel[n]) + force;
        for k in 0..n {
            let d = ws.d[k];
            let free = ws.f[k + 1] * m.inv_mass[k + 1] - ws.f[k] * m.inv_mass[k];
            ws.rhs[k] -= d.dot(&free);
        }
        m.build_matrix(ws);
        solve_tridiagonal(&ws.diag, &ws.off, &mut ws.rhs, &mut ws.scratch);
        std::mem::swap(&mut ws.mu, &mut ws.rhs);
        for j in 0..=n {
            let mut c = ws.f[j];
            if j >= 1 {
                c += ws.d[j - 1] * ws.mu[j - 1];
            }
            if j < n {
                c += ws.d[j] * (-ws.mu[j]);
            }
            ws.acc[j] = c * m.inv_mass[j];
        }
    }

    /// `Model::rk4` as first written, on [`accelerations_reference`].
    fn rk4_reference(
        m: &Model,
        h: f64,
        pos: &mut [Vector3<f64>],
        vel: &mut [Vector3<f64>],
        air: &[Vector3<f64>],
        force: Vector3<f64>,
        ws: &mut Workspace,
    ) {
        const STAGE_FRACTION: [f64; 4] = [0.0, 0.5, 0.5, 1.0];
        const STAGE_WEIGHT: [f64; 4] = [1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0];
        let n = m.links;
        let mut vs_prev = vec![Vector3::zeros(); n + 1];
        for j in 0..=n {
            ws.sum_p[j] = Vector3::zeros();
            ws.sum_v[j] = Vector3::zeros();
            ws.ps[j] = pos[j];
            ws.vs[j] = vel[j];
        }
        for stage in 0..4 {
            if stage > 0 {
                let c = STAGE_FRACTION[stage] * h;
                for j in 0..=n {
                    ws.ps[j] = pos[j] + vs_prev[j] * c;
                    ws.vs[j] = vel[j] + ws.acc[j] * c;
                }
            }
            let ps = std::mem::take(&mut ws.ps);
            let vs = std::mem::take(&mut ws.vs);
            accelerations_reference(m, &ps, &vs, air, force, ws);
            ws.ps = ps;
            ws.vs = vs;
            let wgt = STAGE_WEIGHT[stage] * h;
            for j in 0..=n {
                ws.sum_p[j] += ws.vs[j] * wgt;
                ws.sum_v[j] += ws.acc[j] * wgt;
            }
            vs_prev.copy_from_slice(&ws.vs);
        }
        for j in 1..=n {
            pos[j] += ws.sum_p[j];
            vel[j] += ws.sum_v[j];
        }
    }

    #[test]
    fn rk4_steps_equal_the_plain_formulation_bit_for_bit() {
        let gusts = Gusts::new(13, 1.8);
        for links in [1, 20] {
            let params = HoseParams {
                link_count: links,
                ..HoseParams::default()
            };
            let model = Model::new(&params);
            let (mut fast, mut plain) = (Workspace::new(links), Workspace::new(links));
            let link = Vector3::new(-0.95, 0.0, 0.31) * model.link_len;
            let mut pos: Vec<_> = (0..=links).map(|j| link * j as f64).collect();
            let mut vel = vec![Vector3::zeros(); links + 1];
            let (mut pos_plain, mut vel_plain) = (pos.clone(), vel.clone());
            for i in 0..200 {
                let t = i as f64 * DT_S;
                let air: Vec<_> = (0..=links)
                    .map(|j| gusts.air(t, &(link * j as f64)))
                    .collect();
                let force = Vector3::new(40.0 * (3.0 * t).sin(), 15.0, -8.0);
                model.rk4(DT_S, &mut pos, &mut vel, &air, force, &mut fast);
                rk4_reference(
                    &model,
                    DT_S,
                    &mut pos_plain,
                    &mut vel_plain,
                    &air,
                    force,
                    &mut plain,
                );
                assert_eq!(bits(&pos), bits(&pos_plain), "{links} links, step {i}");
                assert_eq!(bits(&vel), bits(&vel_plain), "{links} links, step {i}");
            }
            // The hose moved: the comparison is not of a state at rest.
            assert!(vel[links].norm() > 0.1, "{:?}", vel[links]);
        }
    }

    fn bits(v: &[Vector3<f64>]) -> Vec<u64> {
        v.iter()
            .flat_map(|x| x.iter().map(|c| c.to_bits()))
            .collect()
    }

    #[test]
    fn accelerations_equal_the_plain_formulation_bit_for_bit() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let laws = [
            HoseDragLaw::ReynoldsDependent,
            HoseDragLaw::Constant {
                cross_flow_cd: 1.2,
                skin_friction_cf: 0.0049,
            },
        ];
        let mut compared = 0;
        for links in [1, 2, 3, 20, 40] {
            for law in laws {
                let params = HoseParams {
                    link_count: links,
                    hose_drag_law: law,
                    ..HoseParams::default()
                };
                let model = Model::new(&params);
                let (mut fast, mut plain) = (Workspace::new(links), Workspace::new(links));
                for _ in 0..50 {
                    // A straight hose trailing aft and down, shaken: positions off by
                    // centimetres, velocities of metres per second, gusty air and a force on
                    // the drogue.
                    let mut jitter = |scale: f64| {
                        Vector3::new(
                            scale * rng.random_range(-1.0..1.0),
                            scale * rng.random_range(-1.0..1.0),
                            scale * rng.random_range(-1.0..1.0),
                        )
                    };
                    let link = Vector3::new(-0.95, 0.0, 0.31) * model.link_len;
                    let pos: Vec<_> = (0..=links)
                        .map(|j| link * j as f64 + jitter(0.05))
                        .collect();
                    let vel: Vec<_> = (0..=links).map(|_| jitter(3.0)).collect();
                    let air: Vec<_> = (0..=links)
                        .map(|_| Vector3::new(-V_MPS, 0.0, 0.0) + jitter(4.0))
                        .collect();
                    let force = jitter(300.0);
                    model.accelerations(&pos, &vel, &air, force, &mut fast);
                    accelerations_reference(&model, &pos, &vel, &air, force, &mut plain);
                    assert_eq!(bits(&fast.acc), bits(&plain.acc), "{links} links, {law:?}");
                    let mu_bits =
                        |w: &Workspace| w.mu.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(mu_bits(&fast), mu_bits(&plain), "{links} links, {law:?}");
                    assert!(fast.acc.iter().skip(1).all(|a| a.norm() > 0.0));
                    compared += 1;
                }
            }
        }
        assert_eq!(compared, 500);
    }

    #[test]
    fn link_lengths_hold_for_60_s_in_turbulence() {
        let gusts = Gusts::new(7, 1.8);
        let mut h = calm_trail(HoseParams::default());
        let mut max_dev = 0.0_f64;
        let start = h.drogue_centre_tanker_m();
        let steps = (60.0 / DT_S).round() as usize;
        for i in 0..steps {
            let t = i as f64 * DT_S;
            h.step(DT_S, &|p| gusts.air(t, p), &Vector3::zeros());
            max_dev = max_dev.max((h.drogue_centre_tanker_m() - start).norm());
        }
        let err = max_link_error(&h);
        println!(
            "60 s in turbulence (sigma 1.8 m/s): link length error {err:.1e}, largest drogue excursion {max_dev:.3} m, \
             smallest tension {:.0} N",
            h.link_tensions_n()
                .iter()
                .fold(f64::INFINITY, |a, &b| a.min(b))
        );
        assert!(err < 1e-6, "relative link length error {err}");
        assert!(h.node_positions_tanker_m()[0] == Vector3::zeros());
        // Bounded, finite, in tension: it rides the gusts without blowing up.
        assert!(
            max_dev.is_finite() && max_dev > 0.05 && max_dev < 3.0,
            "{max_dev}"
        );
        assert!(h.link_tensions_n().iter().all(|&t| t > 0.0));
    }

    #[test]
    fn one_rk4_step_per_call_is_accurate_in_turbulence() {
        // Same inputs (the air is sampled once per call either way); only the internal step
        // differs: 0.01 s (one step per call) against 0.001 s.
        let gusts = Gusts::new(5, 1.8);
        let fine = HoseParams {
            max_internal_step_s: 0.001,
            ..HoseParams::default()
        };
        let mut coarse = calm_trail(HoseParams::default());
        let mut reference = calm_trail(fine);
        let mut worst = 0.0_f64;
        for i in 0..(5.0 / DT_S).round() as usize {
            let t = i as f64 * DT_S;
            let air = |p: &Vector3<f64>| gusts.air(t, p);
            coarse.step(DT_S, &air, &Vector3::zeros());
            reference.step(DT_S, &air, &Vector3::zeros());
            worst = worst
                .max((coarse.drogue_centre_tanker_m() - reference.drogue_centre_tanker_m()).norm());
        }
        let excursion = (reference.drogue_centre_tanker_m()
            - calm_trail(HoseParams::default()).drogue_centre_tanker_m())
        .norm();
        println!(
            "5 s in turbulence: dt 0.01 vs 0.001 internal step, drogue differs by at most {worst:.1e} m \
             (excursion {excursion:.3} m)"
        );
        assert!(worst < 1e-4, "{worst}");
    }

    #[test]
    fn a_push_beyond_the_drag_leaves_the_state_finite_and_the_links_rigid() {
        // 2500 N forward (more than the drogue's drag): the hose goes into compression and
        // folds, outside the model's validity, but the integration must stay well defined.
        let mut h = calm_trail(HoseParams::default());
        let push = Vector3::new(2500.0, 0.0, 0.0);
        for _ in 0..(2.0 / DT_S).round() as usize {
            h.step(DT_S, &calm, &push);
        }
        let p = h.drogue_centre_tanker_m();
        println!(
            "2 s of a 2500 N push: drogue {p:?} m, smallest tension {:.0} N",
            h.link_tensions_n()
                .iter()
                .fold(f64::INFINITY, |a, &b| a.min(b))
        );
        assert!(p.iter().all(|x| x.is_finite()));
        assert!(max_link_error(&h) < 1e-6);
        assert!(p.x > -13.0, "it moved forward: {p:?}");
    }

    #[test]
    fn steady_trail_stays_put_for_10_s() {
        let mut h = calm_trail(HoseParams::default());
        let start = h.drogue_centre_tanker_m();
        let mut worst = 0.0_f64;
        for _ in 0..(10.0 / DT_S).round() as usize {
            h.step(DT_S, &calm, &Vector3::zeros());
            worst = worst.max((h.drogue_centre_tanker_m() - start).norm());
        }
        println!("10 s in calm air from the steady trail: drogue moved at most {worst:.2e} m");
        assert!(worst < 1e-6, "{worst}");
    }

    #[test]
    fn lateral_gust_step_settles_at_the_drag_balance() {
        const GUST_MPS: f64 = 2.0;
        let gust = |_: &Vector3<f64>| Vector3::new(-V_MPS, GUST_MPS, 0.0);
        let mut h = calm_trail(HoseParams::default());
        let x0 = h.drogue_centre_tanker_m().x;
        // Aerodynamic forces scale with |v|^2 and turn with the wind, gravity does not move:
        // the trail turns about z by the wind's heading change, so y = -x0 sin(atan(2/120)).
        let y_rotation = -x0 * (GUST_MPS / V_MPS).atan().sin();
        let y_static = HoseDrogue::steady_trail(HoseParams::default(), &gust)
            .expect("settles")
            .drogue_centre_tanker_m()
            .y;
        let window = (10.0 / DT_S).round() as usize;
        let mut peaks = [0.0_f64; 4]; // largest |y - y_static| in each 10 s window
        for i in 0..4 * window {
            h.step(DT_S, &gust, &Vector3::zeros());
            let y = h.drogue_centre_tanker_m().y;
            peaks[i / window] = peaks[i / window].max((y - y_static).abs());
        }
        let y = h.drogue_centre_tanker_m().y;
        println!(
            "2 m/s lateral gust: y after 40 s {y:.4} m, static {y_static:.4} m, rotation estimate \
             {y_rotation:.4} m, peak |y - y_static| per 10 s window {peaks:.4?} m"
        );
        assert!(
            (y_static - y_rotation).abs() < 0.01 * y_rotation,
            "{y_static}"
        );
        assert!(y > 0.0 && (y - y_static).abs() < 0.02 * y_static, "{y}");
        // The response starts near the full offset and decays window by window.
        assert!(peaks[0] > 0.5 * y_static);
        for w in peaks.windows(2) {
            assert!(w[1] < 0.7 * w[0], "{peaks:?}");
        }
    }

    #[test]
    fn forward_force_on_the_drogue_moves_it_forward() {
        const FORCE_N: f64 = 50.0;
        let force = Vector3::new(FORCE_N, 0.0, 0.0);
        let mut h = calm_trail(HoseParams::default());
        let p0 = h.drogue_centre_tanker_m();
        let p_static = HoseDrogue::steady_trail_with_force(HoseParams::default(), &calm, &force)
            .expect("settles")
            .drogue_centre_tanker_m();
        for _ in 0..(30.0 / DT_S).round() as usize {
            h.step(DT_S, &calm, &force);
        }
        let p = h.drogue_centre_tanker_m();
        let moved = p - p0;
        let expected = p_static - p0;
        println!(
            "+50 N forward on the drogue: moved {moved:?} m after 30 s, static solution {expected:?} m"
        );
        // Forward (and down: the hose angle steepens as the drag it balances drops), by a few
        // centimetres: 50 N is 3 % of the drogue drag.
        assert!(moved.x > 0.02 && moved.x < 0.1, "{moved:?}");
        assert!(moved.z > 0.0);
        assert!(
            (moved - expected).norm() < 0.05 * expected.norm(),
            "{moved:?} vs {expected:?}"
        );
    }

    #[test]
    fn identical_inputs_give_bit_identical_results() {
        let run = || {
            let gusts = Gusts::new(11, 1.8);
            let mut h = calm_trail(HoseParams::default());
            for i in 0..300 {
                let t = i as f64 * DT_S;
                let force = Vector3::new(30.0 * (t * 2.0).sin(), 10.0, -5.0);
                h.step(DT_S, &|p| gusts.air(t, p), &force);
            }
            h
        };
        let (a, b) = (run(), run());
        let bits = |h: &HoseDrogue| -> Vec<u64> {
            h.node_positions_tanker_m()
                .iter()
                .flat_map(|p| p.iter().map(|x| x.to_bits()).collect::<Vec<_>>())
                .chain(h.drogue_velocity_tanker_mps().iter().map(|x| x.to_bits()))
                .collect()
        };
        assert_eq!(bits(&a), bits(&b));
        assert_ne!(
            a.drogue_centre_tanker_m(),
            calm_trail(HoseParams::default()).drogue_centre_tanker_m()
        );
    }
}
