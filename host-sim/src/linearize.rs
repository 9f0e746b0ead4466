//! Numerical linearisation of the nonlinear receiver at a trim point, in the paper's states.
//!
//! The design coordinates are `[theta, V, alpha, q, P | psi, phi, beta, p, r]`: paper eq. (1)
//! without the position states, plus the engine power state `P` (percent), whose lag (about
//! 1 s at refuelling power) is too slow to leave out of the speed loop; see
//! `docs/conventions.md`. Inputs `[elevator, throttle | aileron, rudder]`. The surface
//! actuators (20 rad/s) are taken as quasi-static: surfaces at their commands.
//!
//! Outputs: the camera velocity relative to the tanker in tanker axes, split into the part
//! from the CG's motion (`C_cg`, numerical) and the lever-arm part `omega x p_cam`
//! (analytic, [`ibvs_core::kinematics`]); `tests` checks that they add up to the numerical
//! Jacobian of the full camera velocity (docs/paper.md, item 4).
//!
//! Invariant: calm air; the tanker flies north, level, at the trim speed, so tanker axes are
//! NED axes and the velocity relative to the tanker is `v_ned - (V0, 0, 0)`.

use nalgebra::{DMatrix, Rotation3, Vector3};

use crate::receiver::{F16, ReceiverCommand, ReceiverState, Trim, Wind};
use crate::synthesis::linalg::jacobian;

/// Number of design coordinates (both channels).
pub const N_DESIGN: usize = 10;
/// Longitudinal design coordinates in the full design vector.
pub const LON: std::ops::Range<usize> = 0..5;
/// Lateral design coordinates in the full design vector.
pub const LAT: std::ops::Range<usize> = 5..10;

/// Design coordinates of a state: `[theta, V, alpha, q, P, psi, phi, beta, p, r]`, absolute,
/// with V, alpha, beta from the ground-relative velocity (equal to air data in calm air).
pub fn design_coordinates(x: &ReceiverState) -> [f64; N_DESIGN] {
    let v = x.vel_body_mps;
    let speed = v.norm();
    let alpha = v.z.atan2(v.x);
    let beta = if speed > 0.0 {
        (v.y / speed).asin()
    } else {
        0.0
    };
    let (e, w) = (x.euler_rad, x.rate_body_radps);
    [
        e.y,
        speed,
        alpha,
        w.y,
        x.engine_power_pct,
        e.z,
        e.x,
        beta,
        w.x,
        w.z,
    ]
}

/// The state with design coordinates `xi`, everything else (position, surfaces) taken from
/// `base`.
pub fn state_from_design_coordinates(xi: &[f64], base: &ReceiverState) -> ReceiverState {
    let [theta, speed, alpha, q, power, psi, phi, beta, p, r] = [
        xi[0], xi[1], xi[2], xi[3], xi[4], xi[5], xi[6], xi[7], xi[8], xi[9],
    ];
    ReceiverState {
        vel_body_mps: Vector3::new(
            speed * alpha.cos() * beta.cos(),
            speed * beta.sin(),
            speed * alpha.sin() * beta.cos(),
        ),
        euler_rad: Vector3::new(phi, theta, psi),
        rate_body_radps: Vector3::new(p, q, r),
        engine_power_pct: power,
        ..*base
    }
}

/// Velocity of the CG relative to the tanker, tanker (= NED) axes.
pub fn cg_velocity_rel_tanker(x: &ReceiverState, tanker_speed_mps: f64) -> Vector3<f64> {
    let e = x.euler_rad;
    Rotation3::from_euler_angles(e.x, e.y, e.z) * x.vel_body_mps
        - Vector3::new(tanker_speed_mps, 0.0, 0.0)
}

/// Velocity of a point `p_body_m` fixed on the receiver relative to the tanker, tanker axes.
pub fn point_velocity_rel_tanker(
    x: &ReceiverState,
    p_body_m: &Vector3<f64>,
    tanker_speed_mps: f64,
) -> Vector3<f64> {
    let e = x.euler_rad;
    let lever = Rotation3::from_euler_angles(e.x, e.y, e.z) * x.rate_body_radps.cross(p_body_m);
    cg_velocity_rel_tanker(x, tanker_speed_mps) + lever
}

/// The linear model at a trim point.
#[derive(Debug, Clone)]
pub struct LinearModel {
    /// `d(xi)/dt = A xi + B u`, 10x10, design coordinates (perturbations).
    pub a: DMatrix<f64>,
    /// 10x4, inputs `[elevator_rad, throttle, aileron_rad, rudder_rad]`.
    pub b: DMatrix<f64>,
    /// Camera velocity from CG motion, rows `[down, forward, right]` (tanker axes), 3x10.
    pub c_cg: DMatrix<f64>,
}

/// Central-difference steps for the design coordinates and the inputs.
const XI_STEPS: [f64; N_DESIGN] = [1e-5, 1e-3, 1e-5, 1e-5, 1e-3, 1e-5, 1e-5, 1e-5, 1e-5, 1e-5];
const U_STEPS: [f64; 4] = [1e-5, 1e-5, 1e-5, 1e-5];

/// The state and command for design perturbation `dxi` and input perturbation `du` from
/// `trim`, with the surfaces at their commands.
fn perturbed(model_trim: &Trim, dxi: &[f64], du: &[f64]) -> (ReceiverState, ReceiverCommand) {
    let base = design_coordinates(&model_trim.state);
    let xi: Vec<f64> = base.iter().zip(dxi).map(|(b, d)| b + d).collect();
    let c = &model_trim.command;
    let cmd = ReceiverCommand {
        elevator_rad: c.elevator_rad + du[0],
        throttle: c.throttle + du[1],
        aileron_rad: c.aileron_rad + du[2],
        rudder_rad: c.rudder_rad + du[3],
    };
    let mut x = state_from_design_coordinates(&xi, &model_trim.state);
    x.surfaces_rad.elevator_rad = cmd.elevator_rad;
    x.surfaces_rad.aileron_rad = cmd.aileron_rad;
    x.surfaces_rad.rudder_rad = cmd.rudder_rad;
    (x, cmd)
}

/// Time derivative of the design coordinates at a state: the state derivative mapped through
/// [`design_coordinates`] by a central difference along the flow.
fn design_rates(model: &F16, x: &ReceiverState, cmd: &ReceiverCommand) -> Vec<f64> {
    const EPS_S: f64 = 1e-6;
    let wind = Wind::default();
    let xv = x.to_vector();
    let dx = model.derivatives(x, cmd, &wind);
    let plus = design_coordinates(&ReceiverState::from_vector(&(xv + dx * EPS_S)));
    let minus = design_coordinates(&ReceiverState::from_vector(&(xv - dx * EPS_S)));
    plus.iter()
        .zip(minus)
        .map(|(p, m)| (p - m) / (2.0 * EPS_S))
        .collect()
}

/// Linearises `model` about `trim` (calm air).
pub fn linearize(model: &F16, trim: &Trim) -> LinearModel {
    let zero_u = [0.0; 4];
    let zero_xi = [0.0; N_DESIGN];
    let a = jacobian(
        |dxi| {
            let (x, c) = perturbed(trim, dxi, &zero_u);
            design_rates(model, &x, &c)
        },
        &zero_xi,
        &XI_STEPS,
    );
    let b = jacobian(
        |du| {
            let (x, c) = perturbed(trim, &zero_xi, du);
            design_rates(model, &x, &c)
        },
        &zero_u,
        &U_STEPS,
    );
    let c_cg = jacobian(
        |dxi| {
            let (x, _) = perturbed(trim, dxi, &zero_u);
            let v = cg_velocity_rel_tanker(&x, trim.speed_mps);
            vec![v.z, v.x, v.y]
        },
        &zero_xi,
        &XI_STEPS,
    );
    LinearModel {
        a,
        b,
        c_cg: c_cg.map(|v| if v.abs() < C_NOISE_FLOOR { 0.0 } else { v }),
    }
}

/// Output-matrix entries below this are central-difference noise (the exact value is zero);
/// they are zeroed so that the generated gains module does not carry rounding noise.
const C_NOISE_FLOOR: f64 = 1e-7;

#[cfg(test)]
mod tests {
    use super::*;
    use ibvs_core::kinematics::{lever_arm_lat, lever_arm_lon};

    fn setup() -> (F16, Trim, LinearModel) {
        let model = F16::new(0.35).unwrap();
        let trim = model.trim_straight_level(120.0, 3000.0).unwrap();
        let lin = linearize(&model, &trim);
        (model, trim, lin)
    }

    #[test]
    fn design_coordinates_round_trip() {
        let (_, trim, _) = setup();
        let xi = [0.1, 118.0, 0.09, 0.01, 12.0, 0.02, -0.1, 0.01, 0.03, -0.02];
        let back = design_coordinates(&state_from_design_coordinates(&xi, &trim.state));
        for (a, b) in xi.iter().zip(back) {
            assert!((a - b).abs() < 1e-12);
        }
    }

    #[test]
    fn channels_decouple_at_level_trim() {
        let (_, _, lin) = setup();
        // The only coupling left is the engine's gyroscopic moment between q and r (and p);
        // everything else is zero at level, wings-level trim, and that is small.
        let (q, p, r) = (3, 8, 9);
        for i in 0..N_DESIGN {
            for j in 0..N_DESIGN {
                if LON.contains(&i) != LON.contains(&j) {
                    let gyro = (i, j) == (q, r) || (i, j) == (p, q) || (i, j) == (r, q);
                    let bound = if gyro { 5e-3 } else { 1e-7 };
                    assert!(
                        lin.a[(i, j)].abs() < bound,
                        "A[{i}][{j}] = {}",
                        lin.a[(i, j)]
                    );
                }
            }
        }
        let b_cross = lin.b.view((LON.start, 2), (LON.len(), 2)).norm()
            + lin.b.view((LAT.start, 0), (LAT.len(), 2)).norm();
        assert!(b_cross < 1e-6 * lin.b.norm(), "input coupling {b_cross}");
    }

    #[test]
    fn kinematic_rows_hold_the_dominant_terms() {
        // docs/paper.md, item 4: climb rate V0 (theta - alpha) and side velocity V0 (psi + beta).
        let (_, trim, lin) = setup();
        let v0 = trim.speed_mps;
        let down = lin.c_cg.row(0);
        assert!(
            (down[0] + v0).abs() < 1e-4 && (down[2] - v0).abs() < 1e-4,
            "{down}"
        );
        let right = lin.c_cg.row(2);
        assert!(
            (right[5] - v0).abs() < 1e-4 && (right[7] - v0).abs() < 1e-4,
            "{right}"
        );
        assert!((lin.c_cg[(1, 1)] - 1.0).abs() < 1e-6, "forward speed row");
    }

    #[test]
    fn cg_rows_plus_lever_arm_equal_the_full_camera_velocity() {
        let (_, trim, lin) = setup();
        let p_cam = Vector3::new(6.06, 0.54, -0.86);
        let full = jacobian(
            |dxi| {
                let (x, _) = perturbed(&trim, dxi, &[0.0; 4]);
                let v = point_velocity_rel_tanker(&x, &p_cam, trim.speed_mps);
                vec![v.z, v.x, v.y]
            },
            &[0.0; N_DESIGN],
            &XI_STEPS,
        );
        let lon = lever_arm_lon([p_cam.x, p_cam.y, p_cam.z], trim.theta_rad);
        let lat = lever_arm_lat([p_cam.x, p_cam.y, p_cam.z]);
        let mut sum = lin.c_cg.clone();
        for j in LON {
            sum[(0, j)] += lon[0][j];
            sum[(1, j)] += lon[1][j];
        }
        for j in 0..LAT.len() {
            sum[(2, LAT.start + j)] += lat[0][j];
        }
        // Only lon rows over lon states and the lat row over lat states are kept in the design;
        // what is dropped must be exactly the roll/yaw-rate lever-arm terms through the
        // camera's lateral offset y (the paper's decoupling), nothing else.
        let mut kept = full.clone();
        for j in LAT {
            kept[(0, j)] = 0.0;
            kept[(1, j)] = 0.0;
        }
        for j in LON {
            kept[(2, j)] = 0.0;
        }
        assert!(
            (&kept - &sum).norm() < 1e-6,
            "analytic lever arm differs:\n{kept}\n{sum}"
        );
        let (s, c, y) = (trim.theta_rad.sin(), trim.theta_rad.cos(), p_cam.y);
        let mut dropped = DMatrix::zeros(3, N_DESIGN);
        let (p, r) = (LAT.start + 3, LAT.start + 4);
        dropped[(0, p)] = y * c;
        dropped[(0, r)] = y * s;
        dropped[(1, p)] = y * s;
        dropped[(1, r)] = -y * c;
        assert!(
            (&full - &kept - dropped).norm() < 1e-6,
            "unexpected cross terms:\n{}",
            &full - &kept
        );
    }
}
