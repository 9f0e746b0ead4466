//! The refuelling hose and its drogue: a multi-link model that trails from the tanker's hose
//! exit in the relative wind, carries gravity and aerodynamic drag, and moves the drogue the
//! receiver has to hit.
//!
//! # Source
//!
//! Ro & Kamman, "Modeling and simulation of hose-paradrogue aerial refueling systems", JGCD
//! 2010 (\[RK\]): a chain of rigid links with the hose mass lumped at the joints, link tensions
//! from a tridiagonal solve along the hose, per-link skin-friction and cross-flow drag with
//! Reynolds-number dependent coefficients, gravity, and the drogue's drag at the end. The
//! parameter values and the coefficient laws are those of the paper authors' public
//! simulation (\[R\], RflySim/RflySimAAR, `Origin_Paper_Figure_Sim/Ch11`), as collected in
//! `docs/models.md` ("Hose and drogue"); the few places where we depart from it are listed on
//! [`HoseDragLaw`] and [`HoseParams`]. The formulation and the code are ours.
//!
//! # Formulation
//!
//! - Nodes 0..=N at the link ends; node 0 is the hose exit, fixed at the origin. Each link's
//!   mass (linear density times link length) is split equally between its two end nodes (the
//!   half at the exit goes into the tanker); the drogue's mass is added to node N, which *is*
//!   the drogue centre.
//! - The aerodynamic force of each link is computed from the air velocity at its midpoint
//!   minus the mean of its end nodes' velocities, split into the component along the link
//!   (skin friction, on the wetted area `pi d l`) and normal to it (cross flow, on the
//!   projected area `d l`), and shared equally by its end nodes. The drogue's drag,
//!   `0.5 rho |v_rel|^2 (pi D^2 / 4) Cd` along the relative air velocity, and the external
//!   force act on node N.
//! - The links are inextensible: distance constraints `|p_k+1 - p_k| = l`. Their multipliers
//!   (the tensions) solve the tridiagonal system `J M^-1 J^T mu = -(J M^-1 F + Jdot v)` by the
//!   Thomas algorithm, O(N) and without pivoting (the matrix is symmetric and diagonally
//!   dominant).
//! - Classical RK4 on node positions and velocities, followed after every internal step by a
//!   mass-weighted projection back onto the position and velocity constraints, so the link
//!   lengths hold to round-off indefinitely. Internal steps are at most
//!   [`HoseParams::max_internal_step_s`] and short enough that the fastest transverse wave of
//!   the tensioned chain turns by at most [`MAX_WAVE_PHASE_PER_STEP_RAD`] per step (one
//!   internal step per 0.02 s call at the defaults).
//! - The air velocity field is sampled once per call of [`HoseDrogue::step`], at the link
//!   midpoints and the drogue centre of the state at the start of the step (N + 1 calls), and
//!   held over the step together with the external force.
//! - The wave limit on the internal step needs the largest link tension at the start of a
//!   call (the state the last call ended in, with that call's air and force). The tensions
//!   of the last RK4 stage, at a state one stage away with the same air and force, estimate
//!   it; the exact tension solve (one more evaluation of the accelerations, a fifth of a
//!   step's cost) is made only when 1.5 times the estimate (`TENSION_ESTIMATE_MARGIN`)
//!   could need more internal steps than the step length alone. The number of internal
//!   steps, and so every state, is then the one the exact tensions give, as long as they are
//!   below 1.5 times the estimate (they are within 1e-4 of it in strong gusts with a jumping
//!   drogue force, tested; debug builds check the count at every step that skips the solve).
//!
//! # Frame and units
//!
//! Everything is in the tanker frame (`docs/conventions.md`): origin at the hose exit, x
//! forward, y right, z down, metres, seconds, newtons. The tanker flies straight and level
//! at constant speed, so the frame is inertial; gravity is `(0, 0, +g)`. Calm air moves at
//! `(-V, 0, 0)` relative to this frame.
//!
//! # Invariants
//!
//! - After construction and after every step, every link has its nominal length to round-off
//!   (relative error below 1e-12 in practice; the tests demand 1e-6 after 60 s) and the node
//!   velocities satisfy the velocity constraints.
//! - Node 0 is at the origin with zero velocity.
//! - `step` does not allocate; the same inputs give bit-identical states.
//! - Links carry compression if they are pushed (no slack or buckling model): the model is
//!   meant for a hose in tension, which [`HoseDrogue::link_tensions_n`] lets a caller check.
//!
//! # Layout
//!
//! The data flow of a step is `HoseDrogue::step` (this file: samples the air, picks the
//! internal step) -> `dynamics` (RK4 on the node states, the accelerations from the forces of
//! `drag` and the tensions of `solver`, then the constraint projections) -> the state and
//! tensions stored here. Construction goes through `steady` (the static equilibrium, checked
//! against `dynamics`).
//!
//! - `params`: the physical and numerical parameters, their defaults and validation, errors.
//! - `steady`: the steady trail (static equilibrium) the hose starts in.
//! - `dynamics`: the derived model constants, node accelerations, RK4 and the projections.
//! - `drag`: the aerodynamic forces on a link and on the drogue, and the coefficient laws.
//! - `solver`: the tridiagonal (Thomas) solve for the link tensions.
//! - `vector`: the few 3-vector helpers on `nalgebra::Vector3<f64>` the others use, and the
//!   tests that pin nalgebra's rounding to the arithmetic order the model was written in.

mod drag;
mod dynamics;
mod params;
mod solver;
mod steady;
#[cfg(test)]
mod test_support;
mod vector;

use nalgebra::Vector3;

use dynamics::{Model, Workspace};
pub use params::*;
use vector::all_finite;

/// Upper bound on internal steps per call, so that absurd inputs cannot hang the simulator.
const MAX_INTERNAL_STEPS_PER_CALL: usize = 10_000;

/// The largest link tension at the end of a step is taken to be below this many times the
/// largest of the step's last RK4 stage (same air and force, a state one stage away): while
/// this bound keeps the wave limit at or below the step-length limit, the exact tensions are
/// not solved for (see the module doc; debug builds check the count at every step that skips
/// the solve).
const TENSION_ESTIMATE_MARGIN: f64 = 1.5;

/// The largest link tension magnitude at the current state, N: exact (from a tension solve at
/// the state), or estimated from the last RK4 stage of the step that led to it.
#[derive(Debug, Clone, Copy, PartialEq)]
enum MaxTension {
    Exact(f64),
    Estimate(f64),
}

/// The hose and drogue state: node positions and velocities, tanker frame.
#[derive(Debug, Clone)]
pub struct HoseDrogue {
    params: HoseParams,
    model: Model,
    /// Node positions, m, nodes 0..=N (node 0 the fixed exit).
    pos: Vec<Vector3<f64>>,
    /// Node velocities, m/s.
    vel: Vec<Vector3<f64>>,
    /// The largest link tension magnitude at the current state with the last step's air and
    /// force, N (for the wave limit on the internal step).
    max_tension: MaxTension,
    /// Air velocity at the link midpoints (0..N) and the drogue (N), held over a step, m/s.
    air: Vec<Vector3<f64>>,
    /// External force on the drogue of the last step (of construction), N.
    force: Vector3<f64>,
    ws: Workspace,
}

impl HoseDrogue {
    /// Advances the state by `dt_s` seconds (positive and finite; a call with anything else
    /// does nothing). The air velocity field (m/s, relative to the tanker frame, as a
    /// function of the tanker-frame position in m) is sampled at the start of the step at the
    /// link midpoints and the drogue centre, and held over the step with the external force
    /// on the drogue (N, tanker axes: bow wave, turbulence force, contact).
    ///
    /// Non-finite air or force is a caller error: the state becomes non-finite (checked by
    /// a debug assertion).
    pub fn step(
        &mut self,
        dt_s: f64,
        air_velocity_tanker_mps: &dyn Fn(&Vector3<f64>) -> Vector3<f64>,
        drogue_force_tanker_n: &Vector3<f64>,
    ) {
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return;
        }
        // Before the air is resampled: an exact tension solve is at the last step's air.
        let substeps = self.substeps(dt_s);
        self.sample_air(air_velocity_tanker_mps);
        let force = *drogue_force_tanker_n;
        self.force = force;
        debug_assert!(
            all_finite(&force) && self.air.iter().all(all_finite),
            "non-finite air velocity or drogue force"
        );
        let h = dt_s / substeps as f64;
        for _ in 0..substeps {
            let Self {
                model,
                pos,
                vel,
                air,
                ws,
                ..
            } = self;
            model.rk4(h, pos, vel, air, force, ws);
            model.project_positions(pos, ws);
            model.project_velocities(pos, vel, ws);
        }
        // The multipliers of the last RK4 stage are still in the workspace.
        let estimate = self.ws.mu[..self.model.links]
            .iter()
            .fold(0.0_f64, |m, mu| m.max(mu.abs()))
            * self.model.link_len;
        self.max_tension = MaxTension::Estimate(estimate);
    }

    /// Drogue centre (node N), tanker frame, m.
    pub fn drogue_centre_tanker_m(&self) -> Vector3<f64> {
        self.pos[self.model.links]
    }

    /// Drogue velocity, tanker frame, m/s.
    pub fn drogue_velocity_tanker_mps(&self) -> Vector3<f64> {
        self.vel[self.model.links]
    }

    /// Unit vector along the drogue's axis: from the last hose node toward the drogue centre
    /// (aft and down in the steady trail), tanker axes. The capture plane is perpendicular to
    /// it through the drogue centre.
    pub fn drogue_axis_tanker(&self) -> Vector3<f64> {
        let n = self.model.links;
        let d = self.pos[n] - self.pos[n - 1];
        d * (1.0 / d.norm())
    }

    /// Node positions, tanker frame, m: N + 1 nodes from the hose exit (index 0, always the
    /// origin) to the drogue centre (index N).
    pub fn node_positions_tanker_m(&self) -> &[Vector3<f64>] {
        &self.pos
    }

    /// Link tensions, N, from the exit (index 0) to the drogue (index N - 1), at the current
    /// state with the air and drogue force of the last step (of the steady trail after
    /// construction). Negative means compression: the model is then outside its validity.
    /// Solved for on each call (the steps themselves need only the largest, and mostly not
    /// even that).
    pub fn link_tensions_n(&self) -> Vec<f64> {
        let mut ws = self.ws.clone();
        self.model
            .accelerations(&self.pos, &self.vel, &self.air, self.force, &mut ws);
        self.tensions_from(&ws)
    }

    /// The parameters the hose was built with.
    pub fn params(&self) -> &HoseParams {
        &self.params
    }

    /// Samples the air field at the link midpoints and the drogue centre.
    fn sample_air(&mut self, air: &dyn Fn(&Vector3<f64>) -> Vector3<f64>) {
        let n = self.model.links;
        for k in 0..n {
            let mid = (self.pos[k] + self.pos[k + 1]) * 0.5;
            self.air[k] = air(&mid);
        }
        self.air[n] = air(&self.pos[n]);
    }

    /// Internal steps for a call of `dt_s`: at most `max_internal_step_s` each, and short
    /// enough for the fastest transverse wave at the current tensions. With only an estimate
    /// of the largest tension, the exact one is solved for unless the margin over the
    /// estimate keeps the wave limit at or below the step-length limit: the count is the one
    /// the exact tension gives either way (the count grows with the tension).
    fn substeps(&mut self, dt_s: f64) -> usize {
        let by_step = (dt_s / self.params.max_internal_step_s).ceil();
        let max_tension = match self.max_tension {
            MaxTension::Exact(t) => t,
            MaxTension::Estimate(t)
                if self.by_wave(dt_s, TENSION_ESTIMATE_MARGIN * t) <= by_step.max(1.0) =>
            {
                if cfg!(debug_assertions) {
                    let exact = self.solve_max_tension();
                    assert!(
                        self.by_wave(dt_s, exact) <= by_step.max(1.0),
                        "the largest link tension {exact} N is above {TENSION_ESTIMATE_MARGIN} \
                         times its estimate {t} N and needs more internal steps"
                    );
                }
                return Self::substep_count(by_step.max(1.0));
            }
            MaxTension::Estimate(_) => {
                let exact = self.solve_max_tension();
                self.max_tension = MaxTension::Exact(exact);
                exact
            }
        };
        let by_wave = self.by_wave(dt_s, max_tension);
        Self::substep_count(by_step.max(by_wave).max(1.0))
    }

    /// Internal steps the fastest transverse wave needs in `dt_s` at the largest link tension
    /// `max_tension_n` (not rounded to a count; grows with the tension).
    fn by_wave(&self, dt_s: f64, max_tension_n: f64) -> f64 {
        // Highest eigenfrequency of a chain of masses m joined by links of length l under
        // tension T is below 2 sqrt(T / (m l)).
        let omega_max =
            2.0 * (max_tension_n * self.model.max_inv_mass / self.model.link_len).sqrt();
        (dt_s * omega_max / MAX_WAVE_PHASE_PER_STEP_RAD).ceil()
    }

    /// The count for `n` internal steps, capped.
    fn substep_count(n: f64) -> usize {
        if n.is_finite() {
            (n as usize).min(MAX_INTERNAL_STEPS_PER_CALL)
        } else {
            MAX_INTERNAL_STEPS_PER_CALL
        }
    }

    /// The largest link tension magnitude at the current state with the last step's air and
    /// force, N, solved for (in the workspace, which holds nothing between steps).
    fn solve_max_tension(&mut self) -> f64 {
        let Self {
            model,
            pos,
            vel,
            air,
            force,
            ws,
            ..
        } = self;
        model.accelerations(pos, vel, air, *force, ws);
        self.max_tension_of(&self.ws)
    }

    /// The largest link tension magnitude of the multipliers of the last acceleration solve
    /// in `ws`, made at the current state, N.
    fn max_tension_of(&self, ws: &Workspace) -> f64 {
        (0..self.model.links).fold(0.0_f64, |m, k| m.max(self.tension_of(ws, k).abs()))
    }

    /// The tensions of the multipliers of the last acceleration solve in `ws`, made at the
    /// current state, N.
    fn tensions_from(&self, ws: &Workspace) -> Vec<f64> {
        (0..self.model.links)
            .map(|k| self.tension_of(ws, k))
            .collect()
    }

    /// Link `k`'s tension for the multipliers in `ws`, N.
    fn tension_of(&self, ws: &Workspace, k: usize) -> f64 {
        let len = (self.pos[k + 1] - self.pos[k]).norm();
        -ws.mu[k] * len
    }
}

#[cfg(test)]
mod tests {
    use super::test_support::*;
    use super::*;

    fn max_abs(values: &[f64]) -> f64 {
        values.iter().fold(0.0_f64, |m, t| m.max(t.abs()))
    }

    #[test]
    fn the_end_of_step_tension_estimate_is_close_to_the_exact_tension() {
        // Strong gusts and a drogue force that oscillates and jumps by 600 N every 0.5 s (a
        // contact made and released): the force is held over a step, so the last RK4 stage
        // and the end of the step see the same one.
        let gusts = Gusts::new(17, 3.0);
        let mut h = calm_trail(HoseParams::default());
        let (mut lowest, mut highest) = (f64::INFINITY, 0.0_f64);
        for i in 0..3000 {
            let t = i as f64 * DT_S;
            let push_n = if (i / 50) % 2 == 0 { 0.0 } else { 600.0 };
            let force = Vector3::new(push_n, 80.0 * (7.0 * t).sin(), -50.0);
            h.step(DT_S, &|p| gusts.air(t, p), &force);
            let MaxTension::Estimate(estimate) = h.max_tension else {
                panic!("a step leaves an estimate: {:?}", h.max_tension);
            };
            let ratio = max_abs(&h.link_tensions_n()) / estimate;
            lowest = lowest.min(ratio);
            highest = highest.max(ratio);
        }
        println!("largest link tension over its end-of-step estimate: {lowest:.5}..{highest:.5}");
        assert!(
            lowest > 0.95 && highest < 1.05,
            "{lowest}..{highest}: the margin of {TENSION_ESTIMATE_MARGIN} is not wide"
        );
    }

    #[test]
    fn tensions_near_the_wave_limit_are_solved_for_exactly() {
        // At the refuelling condition the estimate with its margin keeps the wave limit at
        // one internal step of the refuelling presets' 0.02 s; in a 140 m/s airflow the
        // tensions are within the margin of the limit, so the next step solves for them (and
        // still takes one internal step).
        let dt_s = PRESET_STEP_S;
        for (speed_mps, solved) in [(V_MPS, false), (140.0, true)] {
            let air = move |_: &Vector3<f64>| Vector3::new(-speed_mps, 0.0, 0.0);
            let mut h = HoseDrogue::steady_trail(HoseParams::default(), &air).expect("settles");
            h.step(dt_s, &air, &Vector3::zeros());
            let exact = max_abs(&h.link_tensions_n());
            let substeps = h.substeps(dt_s);
            assert_eq!(
                matches!(h.max_tension, MaxTension::Exact(_)),
                solved,
                "{speed_mps} m/s: {:?}, exact {exact} N",
                h.max_tension
            );
            assert_eq!(substeps, 1, "{speed_mps} m/s");
            if let MaxTension::Exact(t) = h.max_tension {
                assert_eq!(t.to_bits(), exact.to_bits());
            }
        }
    }

    /// The refuelling presets' 0.02 s step against a 0.005 s one, in strong gusts (3 m/s rms,
    /// wavelengths down to 4 m) with a jumping drogue force, over 30 s: the drogue's paths
    /// agree to a tenth of the capture radius. Measured: 1.4 cm at most, over excursions of
    /// 1.5 m (0.47 cm for the `paper-*` presets' 0.01 s). The difference is first order in
    /// the step: the air is held over each call, which delays it by half a step.
    #[test]
    fn the_presets_step_follows_a_fine_step() {
        let gusts = Gusts::new(17, 3.0);
        let fly = |dt_s: f64| {
            let mut h = calm_trail(HoseParams::default());
            let calls = (30.0 / dt_s).round() as usize;
            let per_sample = (PRESET_STEP_S / dt_s).round() as usize;
            let mut path = Vec::new();
            for i in 0..calls {
                let t = i as f64 * dt_s;
                // The force holds over 0.02 s windows, so both steps see the same force; the
                // push comes and goes every 25 windows (0.5 s).
                let window = (t / PRESET_STEP_S + 1e-9).floor() as usize;
                let w = window as f64 * PRESET_STEP_S;
                let push_n = if (window / 25).is_multiple_of(2) {
                    0.0
                } else {
                    600.0
                };
                let force = Vector3::new(push_n, 80.0 * (7.0 * w).sin(), -50.0);
                h.step(dt_s, &|p| gusts.air(t, p), &force);
                if (i + 1) % per_sample == 0 {
                    path.push(h.drogue_centre_tanker_m());
                }
            }
            path
        };
        let (coarse, fine) = (fly(PRESET_STEP_S), fly(0.005));
        let worst = coarse
            .iter()
            .zip(&fine)
            .map(|(a, b)| (a - b).norm())
            .fold(0.0_f64, f64::max);
        let excursion = fine
            .iter()
            .map(|p| (p - fine[0]).norm())
            .fold(0.0_f64, f64::max);
        println!(
            "drogue path, 0.02 s against 0.005 s: largest difference {worst:.5} m (excursion {excursion:.3} m)"
        );
        assert!(
            worst < 0.1 * crate::world::drogue::CAPTURE_RADIUS_M,
            "{worst} m"
        );
    }

    #[test]
    #[ignore = "sensitivity table and timing: cargo test --release -p host-sim hose -- --ignored --nocapture"]
    fn report_sensitivity_and_step_cost() {
        let cases: [(&str, HoseParams); 6] = [
            ("default", HoseParams::default()),
            ("authors' rho, nu, g", HoseParams::authors()),
            (
                "rho 0.8443, rest default",
                HoseParams {
                    air_density_kg_per_m3: AUTHORS_AIR_DENSITY_KG_PER_M3,
                    ..HoseParams::default()
                },
            ),
            (
                "Cd 1.2 (independence principle), Cf 0.0049",
                HoseParams {
                    hose_drag_law: HoseDragLaw::Constant {
                        cross_flow_cd: 1.2,
                        skin_friction_cf: 0.0049,
                    },
                    ..HoseParams::default()
                },
            ),
            (
                "Cd 0.206, Cf 0.0041 ([R]'s Re_f / sin)",
                HoseParams {
                    hose_drag_law: HoseDragLaw::Constant {
                        cross_flow_cd: 0.206,
                        skin_friction_cf: 0.0041,
                    },
                    ..HoseParams::default()
                },
            ),
            (
                "40 links",
                HoseParams {
                    link_count: 40,
                    ..HoseParams::default()
                },
            ),
        ];
        for (name, p) in cases {
            let h = calm_trail(p);
            let d = h.drogue_centre_tanker_m();
            println!(
                "{name:48} drogue [{:.3}, {:.3}, {:.3}] m, exit tension {:.0} N",
                d.x,
                d.y,
                d.z,
                h.link_tensions_n()[0]
            );
        }
        let gusts = Gusts::new(3, 1.8);
        let mut h = calm_trail(HoseParams::default());
        let steps = 20_000;
        let start = std::time::Instant::now();
        for i in 0..steps {
            let t = i as f64 * DT_S;
            h.step(DT_S, &|p| gusts.air(t, p), &Vector3::zeros());
        }
        let turb = start.elapsed().as_secs_f64() / steps as f64;
        let mut h = calm_trail(HoseParams::default());
        let start = std::time::Instant::now();
        for _ in 0..steps {
            h.step(DT_S, &calm, &Vector3::zeros());
        }
        let calm_cost = start.elapsed().as_secs_f64() / steps as f64;
        println!(
            "step(0.01): {:.2} us calm air, {:.2} us with the 36-mode gust field (its own cost included)",
            calm_cost * 1e6,
            turb * 1e6
        );
    }
}
