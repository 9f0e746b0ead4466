//! Trim of the F-16 receiver for straight and level flight in calm air.
//!
//! Source: the trim problem of Stevens, Lewis & Johnson sec. 3.6, posed here as a square
//! nonlinear system solved by Newton's method with a central-difference Jacobian and a
//! backtracking line search.
//! Condition: heading north, wings level, rates zero, flight-path angle zero (theta = alpha,
//! which gives zero climb for any sideslip when wings are level), engine power at the steady
//! state of the throttle, surfaces at their commands, calm air.
//! Unknowns: alpha, beta (rad), throttle (fraction), elevator, aileron, rudder (rad).
//! Residuals: the six accelerations (du/dt, dv/dt, dw/dt) in m/s^2 and (dp/dt, dq/dt, dr/dt) in
//! rad/s^2; the residual norm is the 2-norm of that 6-vector. Power and surface derivatives are
//! zero by construction.
//! Invariants: a returned [`Trim`] has residual norm below [`TRIM_RESIDUAL_TOLERANCE`], throttle
//! and surfaces inside the model's actuator limits, and `state`/`command` that reproduce it.

use nalgebra::{SMatrix, SVector, Vector3};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::engine::commanded_power_pct;
use super::model::F16;
use super::state::{ReceiverCommand, ReceiverState, Surfaces, Wind, state_index};

/// Residual norm (m/s^2 and rad/s^2 mixed, see the module doc) below which trim has converged.
pub const TRIM_RESIDUAL_TOLERANCE: f64 = 1e-10;
/// Newton iterations allowed before giving up.
const MAX_NEWTON_ITERATIONS: usize = 50;
/// Central-difference step for every unknown (rad or throttle fraction).
const JACOBIAN_STEP: f64 = 1e-7;
/// Smallest line-search step fraction tried before giving up.
const MIN_STEP_FRACTION: f64 = 1.0 / 1024.0;
/// Armijo sufficient-decrease constant of the line search.
const SUFFICIENT_DECREASE: f64 = 1e-4;
/// Initial angle of attack, rad (other angles and surfaces start at zero).
const INITIAL_ALPHA_RAD: f64 = 5.0_f64.to_radians();
/// Initial throttle, fraction.
const INITIAL_THROTTLE: f64 = 0.2;

/// Positions of the unknowns in the Newton vector.
const ALPHA: usize = 0;
const BETA: usize = 1;
const THROTTLE: usize = 2;
const ELEVATOR: usize = 3;
const AILERON: usize = 4;
const RUDDER: usize = 5;

/// Newton unknowns (alpha, beta, throttle, elevator, aileron, rudder).
type Unknowns = SVector<f64, 6>;
/// Accelerations (du, dv, dw in m/s^2; dp, dq, dr in rad/s^2).
type Residual = SVector<f64, 6>;

/// A straight-and-level trim point and the state and command that hold it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Trim {
    /// Angle of attack, rad.
    pub alpha_rad: f64,
    /// Pitch angle, rad (equal to alpha: zero flight-path angle).
    pub theta_rad: f64,
    /// Sideslip, rad.
    pub beta_rad: f64,
    /// Throttle, fraction 0..1.
    pub throttle: f64,
    /// Elevator, rad.
    pub elevator_rad: f64,
    /// Aileron, rad.
    pub aileron_rad: f64,
    /// Rudder, rad.
    pub rudder_rad: f64,
    /// Engine power state (the throttle's steady state), percent.
    pub engine_power_pct: f64,
    /// Residual norm at the solution (module doc), below [`TRIM_RESIDUAL_TOLERANCE`].
    pub residual: f64,
    /// True airspeed (= ground speed, calm air), m/s.
    pub speed_mps: f64,
    /// Altitude, m.
    pub altitude_m: f64,
    /// Trimmed state at north = east = 0, down = -altitude, heading north.
    pub state: ReceiverState,
    /// Command that holds the trimmed state (surfaces in `state` equal it).
    pub command: ReceiverCommand,
}

/// Why no trim was found.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum TrimError {
    /// Speed not finite and positive, or altitude not finite.
    #[error("no trim for speed {speed_mps} m/s at altitude {altitude_m} m: invalid condition")]
    InvalidCondition {
        /// Requested speed, m/s.
        speed_mps: f64,
        /// Requested altitude, m.
        altitude_m: f64,
    },
    /// Newton's method stalled or ran out of iterations.
    #[error("trim did not converge: residual {residual} after {iterations} iterations")]
    DidNotConverge {
        /// Residual norm at the last iterate.
        residual: f64,
        /// Newton iterations done.
        iterations: usize,
    },
    /// The equilibrium needs a throttle or surface beyond its limits.
    #[error("trim needs {control} = {value}, beyond its limit {limit}")]
    OutOfLimits {
        /// Which control: "throttle", "elevator_rad", "aileron_rad" or "rudder_rad".
        control: &'static str,
        /// The value it would need (fraction or rad).
        value: f64,
        /// Its limit (rad for surfaces, the violated end of the range for the throttle).
        limit: f64,
    },
}

impl F16 {
    /// Trim for straight and level flight at airspeed `speed_mps` and altitude `altitude_m` in
    /// calm air (see the module doc for the condition, unknowns and residual norm).
    pub fn trim_straight_level(&self, speed_mps: f64, altitude_m: f64) -> Result<Trim, TrimError> {
        if !(speed_mps.is_finite() && speed_mps > 0.0 && altitude_m.is_finite()) {
            return Err(TrimError::InvalidCondition {
                speed_mps,
                altitude_m,
            });
        }
        let mut initial = Unknowns::zeros();
        initial[ALPHA] = INITIAL_ALPHA_RAD;
        initial[THROTTLE] = INITIAL_THROTTLE;
        let (z, residual) = solve_newton(
            |z: &Unknowns| self.trim_residual(z, speed_mps, altitude_m),
            initial,
        )?;
        self.check_limits(&z)?;
        let state = trim_state(&z, speed_mps, altitude_m);
        Ok(Trim {
            alpha_rad: z[ALPHA],
            theta_rad: state.euler_rad.y,
            beta_rad: z[BETA],
            throttle: z[THROTTLE],
            elevator_rad: z[ELEVATOR],
            aileron_rad: z[AILERON],
            rudder_rad: z[RUDDER],
            engine_power_pct: state.engine_power_pct,
            residual,
            speed_mps,
            altitude_m,
            state,
            command: trim_command(&z),
        })
    }

    /// The six accelerations at the trim candidate `z`.
    fn trim_residual(&self, z: &Unknowns, speed_mps: f64, altitude_m: f64) -> Residual {
        let xdot = self.derivatives(
            &trim_state(z, speed_mps, altitude_m),
            &trim_command(z),
            &Wind::default(),
        );
        let indices = [
            state_index::U,
            state_index::V,
            state_index::W,
            state_index::P,
            state_index::Q,
            state_index::R,
        ];
        Residual::from_fn(|i, _| xdot[indices[i]])
    }

    fn check_limits(&self, z: &Unknowns) -> Result<(), TrimError> {
        let limits = self.actuators();
        for (control, value, limit) in [
            (
                "elevator_rad",
                z[ELEVATOR],
                limits.elevator.position_limit_rad,
            ),
            ("aileron_rad", z[AILERON], limits.aileron.position_limit_rad),
            ("rudder_rad", z[RUDDER], limits.rudder.position_limit_rad),
        ] {
            if value.abs() > limit {
                return Err(TrimError::OutOfLimits {
                    control,
                    value,
                    limit,
                });
            }
        }
        let throttle = z[THROTTLE];
        let limit = limits.clamp_throttle(throttle);
        if limit == throttle {
            Ok(())
        } else {
            Err(TrimError::OutOfLimits {
                control: "throttle",
                value: throttle,
                limit,
            })
        }
    }
}

/// Newton's method from `z` with a central-difference Jacobian and a backtracking (Armijo) line
/// search; returns the solution and its residual norm once that is below
/// [`TRIM_RESIDUAL_TOLERANCE`].
fn solve_newton(
    residual: impl Fn(&Unknowns) -> Residual,
    mut z: Unknowns,
) -> Result<(Unknowns, f64), TrimError> {
    let mut r = residual(&z);
    let mut iterations = 0;
    loop {
        let norm = r.norm();
        if norm < TRIM_RESIDUAL_TOLERANCE {
            return Ok((z, norm));
        }
        let stalled = TrimError::DidNotConverge {
            residual: norm,
            iterations,
        };
        if iterations == MAX_NEWTON_ITERATIONS {
            return Err(stalled);
        }
        iterations += 1;
        let mut jacobian = SMatrix::<f64, 6, 6>::zeros();
        for k in 0..6 {
            let step = Unknowns::ith(k, JACOBIAN_STEP);
            let slope = (residual(&(z + step)) - residual(&(z - step))) / (2.0 * JACOBIAN_STEP);
            jacobian.set_column(k, &slope);
        }
        let newton_step = jacobian.lu().solve(&-r).ok_or(stalled)?;
        (z, r) = line_search(&residual, &z, &newton_step, norm).ok_or(stalled)?;
    }
}

/// First point along `z + fraction * step` (fraction 1, 1/2, 1/4, ...) whose residual norm
/// decreases sufficiently from `norm`, with its residual; `None` below [`MIN_STEP_FRACTION`].
fn line_search(
    residual: &impl Fn(&Unknowns) -> Residual,
    z: &Unknowns,
    step: &Unknowns,
    norm: f64,
) -> Option<(Unknowns, Residual)> {
    let mut fraction = 1.0;
    while fraction >= MIN_STEP_FRACTION {
        let candidate = z + step * fraction;
        let candidate_residual = residual(&candidate);
        if candidate_residual.norm() <= (1.0 - SUFFICIENT_DECREASE * fraction) * norm {
            return Some((candidate, candidate_residual));
        }
        fraction /= 2.0;
    }
    None
}

/// State for the trim candidate `z`: wings level, theta = alpha, heading north.
fn trim_state(z: &Unknowns, speed_mps: f64, altitude_m: f64) -> ReceiverState {
    let (alpha, beta) = (z[ALPHA], z[BETA]);
    let command = trim_command(z);
    ReceiverState {
        vel_body_mps: Vector3::new(
            alpha.cos() * beta.cos(),
            beta.sin(),
            alpha.sin() * beta.cos(),
        ) * speed_mps,
        euler_rad: Vector3::new(0.0, alpha, 0.0),
        rate_body_radps: Vector3::zeros(),
        pos_ned_m: Vector3::new(0.0, 0.0, -altitude_m),
        // Unclamped, so that a trim needing more throttle than allowed is still found, then
        // reported by the limit check.
        engine_power_pct: commanded_power_pct(command.throttle),
        surfaces_rad: Surfaces {
            elevator_rad: command.elevator_rad,
            aileron_rad: command.aileron_rad,
            rudder_rad: command.rudder_rad,
        },
    }
}

/// Command holding the trim candidate `z`.
fn trim_command(z: &Unknowns) -> ReceiverCommand {
    ReceiverCommand {
        elevator_rad: z[ELEVATOR],
        aileron_rad: z[AILERON],
        rudder_rad: z[RUDDER],
        throttle: z[THROTTLE],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::receiver::actuators::ActuatorParams;
    use crate::receiver::units::M_PER_FT;

    const XCG_NOMINAL: f64 = 0.35;

    fn model() -> F16 {
        F16::new(XCG_NOMINAL).expect("model must build")
    }

    #[test]
    fn trims_at_the_refuelling_condition() {
        let model = model();
        let trim = model
            .trim_straight_level(120.0, 3000.0)
            .expect("trim must converge");
        assert!(trim.residual < TRIM_RESIDUAL_TOLERANCE);
        assert!(
            (0.10..0.14).contains(&trim.alpha_rad),
            "alpha {}",
            trim.alpha_rad
        );
        assert_eq!(trim.theta_rad, trim.alpha_rad);
        assert!(trim.throttle > 0.0 && trim.throttle < 1.0);
        assert!(trim.elevator_rad.abs() < model.actuators().elevator.position_limit_rad);
        assert!(
            trim.beta_rad.abs() < 1e-9
                && trim.aileron_rad.abs() < 1e-9
                && trim.rudder_rad.abs() < 1e-9
        );
        assert_eq!(
            trim.state.surfaces_rad.elevator_rad,
            trim.command.elevator_rad
        );
        assert_eq!(trim.state.pos_ned_m, Vector3::new(0.0, 0.0, -3000.0));
        let air = model.air_data(&trim.state, &Wind::default());
        assert!((air.airspeed_mps - 120.0).abs() < 1e-12);
    }

    #[test]
    fn holding_the_trim_command_keeps_the_state() {
        let model = model();
        let trim = model
            .trim_straight_level(120.0, 3000.0)
            .expect("trim must converge");
        let mut x = trim.state;
        let dt_s = 0.01;
        for _ in 0..1000 {
            model.step_rk4(&mut x, &trim.command, &Wind::default(), dt_s);
        }
        let air = model.air_data(&x, &Wind::default());
        assert!(
            (air.airspeed_mps - trim.speed_mps).abs() < 1e-6,
            "speed {}",
            air.airspeed_mps
        );
        assert!(
            (x.pos_ned_m.z - trim.state.pos_ned_m.z).abs() < 1e-4,
            "down {}",
            x.pos_ned_m.z
        );
        assert!((x.euler_rad - trim.state.euler_rad).norm() < 1e-7);
        // It flew 1200 m north.
        assert!((x.pos_ned_m.x - 1200.0).abs() < 1e-3);
    }

    /// Stevens & Lewis (2nd ed.) Table 3.6-3: Vt = 502 ft/s, h = 0, xcg = 0.35 trims at throttle
    /// 0.1385, alpha 0.03691 rad (2.115 deg), elevator -0.7588 deg.
    #[test]
    fn matches_the_published_low_fidelity_trim() {
        let trim = model()
            .trim_straight_level(502.0 * M_PER_FT, 0.0)
            .expect("trim must converge");
        let within = |value: f64, published: f64, fraction: f64| {
            ((value - published) / published).abs() < fraction
        };
        assert!(
            within(trim.throttle, 0.1385, 0.03),
            "throttle {}",
            trim.throttle
        );
        assert!(
            within(trim.alpha_rad, 0.03691, 0.03),
            "alpha {}",
            trim.alpha_rad
        );
        assert!(
            within(trim.elevator_rad.to_degrees(), -0.7588, 0.03),
            "elevator {}",
            trim.elevator_rad.to_degrees()
        );
    }

    #[test]
    fn rejects_bad_conditions_and_unreachable_trims() {
        let model = model();
        assert!(matches!(
            model.trim_straight_level(-5.0, 3000.0),
            Err(TrimError::InvalidCondition { .. })
        ));
        assert!(matches!(
            model.trim_straight_level(120.0, f64::NAN),
            Err(TrimError::InvalidCondition { .. })
        ));
        // 40 m/s at 3000 m would need a lift coefficient near 4.5: no trim inside the limits
        // (Newton may find one far out in the extrapolated tables; the limit check rejects it).
        assert!(matches!(
            model.trim_straight_level(40.0, 3000.0),
            Err(TrimError::DidNotConverge { .. } | TrimError::OutOfLimits { .. })
        ));
    }

    #[test]
    fn reports_controls_beyond_their_limits() {
        let mut model = model();
        let nominal = *model.actuators();
        let mut tight = nominal;
        tight.elevator.position_limit_rad = 0.1_f64.to_radians();
        model.set_actuators(tight).expect("valid limits");
        assert!(matches!(
            model.trim_straight_level(120.0, 3000.0),
            Err(TrimError::OutOfLimits {
                control: "elevator_rad",
                ..
            })
        ));
        let weak_engine = ActuatorParams {
            throttle_max: 0.1,
            ..nominal
        };
        model.set_actuators(weak_engine).expect("valid limits");
        assert!(matches!(
            model.trim_straight_level(120.0, 3000.0),
            Err(TrimError::OutOfLimits {
                control: "throttle",
                limit: 0.1,
                ..
            })
        ));
    }
}
