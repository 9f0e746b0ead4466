//! The F-16 receiver as a nonlinear 6-DOF rigid body over a flat, non-rotating earth.
//!
//! Source: equations of motion in the form of Stevens, Lewis & Johnson ch. 1-3; aerodynamics,
//! engine, atmosphere and mass properties from `data/f16-lofi-data.toml` (their App. A).
//! Equations, body axes unless stated:
//! - air-relative velocity `v_air = v_b - C_bn w_ned`; airspeed, alpha, beta from `v_air`;
//! - `m (dv_b/dt + w x v_b) = F_aero + F_thrust + m C_bn [0, 0, g]` (thrust along body x through
//!   the CG);
//! - `J dw/dt = M_aero - w x (J w + h_engine)`, `J = [[Jx,0,-Jxz],[0,Jy,0],[-Jxz,0,Jz]]`,
//!   `h_engine` along body x;
//! - 3-2-1 Euler-angle kinematics; `dp_ned/dt = C_nb v_b`;
//! - engine power lag and surface actuators as in `engine.rs` and `actuators.rs`;
//! - the true aircraft's [`ReceiverPlant`] factors (`plant.rs`) on the aerodynamics, the mass
//!   and inertia, the actuators and the engine lag ([`F16::with_plant`]; [`F16::new`] is the
//!   nominal aircraft).
//!
//! Invariants: SI at every public item; constant mass; the data file is parsed once, in
//! [`F16::with_plant`]; evaluating [`F16::derivatives`] or [`F16::step_rk4`] never allocates.
//! [`F16::derivatives`] assumes a finite state with airspeed > 0 and |theta| < pi/2.

use nalgebra::{Matrix3, Rotation3, Vector3};
use serde::{Deserialize, Serialize};

use super::actuators::{ActuatorParams, FlownSurfaces};
use super::aero::{AeroInput, AeroModel, ReferenceGeometry};
use super::atmosphere::{AirProperties, Atmosphere};
use super::data::{ModelData, ModelError};
use super::engine::{Engine, commanded_power_pct, power_rate_pct_per_s};
use super::plant::ReceiverPlant;
use super::state::{ReceiverCommand, ReceiverState, StateVector, Wind};
use super::units::{KG_M2_PER_SLUG_FT2, KG_PER_SLUG, M_PER_FT};

/// Air data of the receiver, from its air-relative velocity and altitude.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AirData {
    /// True airspeed Vt, m/s.
    pub airspeed_mps: f64,
    /// Angle of attack, atan2(w_air, u_air), rad.
    pub alpha_rad: f64,
    /// Sideslip, asin(v_air / Vt), rad (0 at zero airspeed).
    pub beta_rad: f64,
    /// Mach number.
    pub mach: f64,
    /// Dynamic pressure 0.5 rho Vt^2, Pa.
    pub dynamic_pressure_pa: f64,
    /// Air density, kg/m^3 (the model's atmosphere, not ISA).
    pub density_kg_m3: f64,
}

/// Aerodynamic plus thrust loads on the receiver, body axes, about the CG.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BodyLoads {
    /// Force, N.
    pub force_body_n: Vector3<f64>,
    /// Moment, N m.
    pub moment_body_nm: Vector3<f64>,
}

/// Range of the CG position accepted by [`F16::new`], fraction of the mean chord.
const XCG_RANGE: std::ops::RangeInclusive<f64> = 0.0..=1.0;

/// The nonlinear F-16 receiver model (low-fidelity data set).
#[derive(Debug, Clone)]
pub struct F16 {
    aero: AeroModel,
    engine: Engine,
    atmosphere: Atmosphere,
    actuators: ActuatorParams,
    /// The actuators as flown: `actuators` with the plant's rate-limit and bandwidth factors.
    surfaces: FlownSurfaces,
    plant: ReceiverPlant,
    geometry: ReferenceGeometry,
    xcg: f64,
    mass_kg: f64,
    inertia_kgm2: Matrix3<f64>,
    inertia_inv_per_kgm2: Matrix3<f64>,
    engine_momentum_body_kgm2ps: Vector3<f64>,
    gravity_mps2: f64,
}

impl F16 {
    /// Build the nominal model with the CG at `xcg` (fraction of the mean chord, 0.35
    /// nominal; the tables are referred to 0.35): [`F16::with_plant`] with
    /// [`ReceiverPlant::NOMINAL`]. Fails if the embedded data file is malformed or `xcg` is
    /// outside 0..=1.
    pub fn new(xcg: f64) -> Result<Self, ModelError> {
        Self::with_plant(xcg, &ReceiverPlant::NOMINAL)
    }

    /// Build the model of a true aircraft with the CG at `xcg` and the factors of `plant`
    /// (`plant.rs`): mass `m_data * mass_scale`; inertia `Jx`, `Jy`, `Jz` times `jx_scale`,
    /// `jy_scale`, `jz_scale` and `Jxz` times `sqrt(jx_scale * jz_scale)`; the aerodynamic,
    /// actuator and engine factors where those are computed. Fails if the data file is
    /// malformed, `xcg` is outside 0..=1 or a factor is outside its limits
    /// ([`ReceiverPlant::validate`]).
    pub fn with_plant(xcg: f64, plant: &ReceiverPlant) -> Result<Self, ModelError> {
        plant.validate()?;
        if !XCG_RANGE.contains(&xcg) {
            return Err(ModelError::InvalidParameter {
                name: "xcg",
                value: xcg,
                requirement: "0 <= xcg <= 1 (fraction of the mean chord)",
            });
        }
        let data = ModelData::embedded()?;
        let a = &data.airframe;
        let geometry = ReferenceGeometry {
            wing_area_m2: a.wing_area_ft2 * M_PER_FT * M_PER_FT,
            span_m: a.span_ft * M_PER_FT,
            mean_chord_m: a.mean_chord_ft * M_PER_FT,
        };
        let (kx, ky, kz) = (plant.jx_scale, plant.jy_scale, plant.jz_scale);
        // With positive factors, (Jxz sqrt(kx kz))^2 < (Jx kx)(Jz kz) whenever Jxz^2 < Jx Jz.
        let kxz = (kx * kz).sqrt();
        let (jx, jy, jz, jxz) = (
            a.jx_slugft2 * kx,
            a.jy_slugft2 * ky,
            a.jz_slugft2 * kz,
            a.jxz_slugft2 * kxz,
        );
        let inertia_kgm2 =
            Matrix3::new(jx, 0.0, -jxz, 0.0, jy, 0.0, -jxz, 0.0, jz) * KG_M2_PER_SLUG_FT2;
        // The data check makes J positive definite; this guards the inversion regardless.
        let inertia_inv_per_kgm2 =
            inertia_kgm2
                .try_inverse()
                .ok_or(ModelError::InvalidParameter {
                    name: "jxz_slugft2",
                    value: jxz,
                    requirement: "invertible inertia",
                })?;
        let actuators = ActuatorParams::from_data(&data.actuators)?;
        Ok(Self {
            actuators,
            surfaces: FlownSurfaces::new(&actuators, plant),
            plant: *plant,
            atmosphere: Atmosphere::new(data.atmosphere.rho0_slug_ft3),
            engine: Engine::new(&data.grid, data.engine),
            geometry,
            xcg,
            mass_kg: a.mass_slug * KG_PER_SLUG * plant.mass_scale,
            inertia_kgm2,
            inertia_inv_per_kgm2,
            engine_momentum_body_kgm2ps: Vector3::x()
                * (a.engine_angular_momentum_slugft2_per_s * KG_M2_PER_SLUG_FT2),
            gravity_mps2: a.g_ftps2 * M_PER_FT,
            aero: AeroModel::new(&data.grid, data.aero, geometry, a.xcg_ref, xcg, plant),
        })
    }

    /// The model's own atmosphere at `altitude_m` (m, positive up): density, speed of sound
    /// and temperature, as its air data use them (`atmosphere.rs`).
    pub fn air_at(&self, altitude_m: f64) -> AirProperties {
        self.atmosphere.at(altitude_m)
    }

    /// CG position, fraction of the mean chord.
    pub fn xcg(&self) -> f64 {
        self.xcg
    }

    /// The true aircraft's factors ([`ReceiverPlant::NOMINAL`] for [`F16::new`]).
    pub fn plant(&self) -> &ReceiverPlant {
        &self.plant
    }

    /// Mass, kg (the plant's `mass_scale` applied).
    pub fn mass_kg(&self) -> f64 {
        self.mass_kg
    }

    /// Inertia matrix about the CG, body axes, kg m^2 (`J` in the module doc; the plant's
    /// factors applied).
    pub fn inertia_kgm2(&self) -> Matrix3<f64> {
        self.inertia_kgm2
    }

    /// Wing reference geometry, m.
    pub fn geometry(&self) -> ReferenceGeometry {
        self.geometry
    }

    /// Gravitational acceleration of the model, m/s^2 (32.17 ft/s^2).
    pub fn gravity_mps2(&self) -> f64 {
        self.gravity_mps2
    }

    /// Actuator and throttle parameters in use, before the plant's factors: each surface's
    /// rate limit and bandwidth as flown are these times its `*_rate_limit_scale` and
    /// `*_bandwidth_scale` ([`F16::plant`]).
    pub fn actuators(&self) -> &ActuatorParams {
        &self.actuators
    }

    /// Replace the actuator and throttle parameters (the plant's factors still apply);
    /// rejects invalid ones and keeps the old.
    pub fn set_actuators(&mut self, params: ActuatorParams) -> Result<(), ModelError> {
        params.validate()?;
        self.actuators = params;
        self.surfaces = FlownSurfaces::new(&params, &self.plant);
        Ok(())
    }

    /// Air data for state `x` in `wind`.
    pub fn air_data(&self, x: &ReceiverState, wind: &Wind) -> AirData {
        self.air_data_with(x, &ned_from_body(x), wind)
    }

    /// Aerodynamic and thrust loads for state `x` in `wind` (body axes, about the CG).
    pub fn body_loads(&self, x: &ReceiverState, wind: &Wind) -> BodyLoads {
        let ned_from_body = ned_from_body(x);
        self.body_loads_with(
            x,
            &self.air_data_with(x, &ned_from_body, wind),
            &ned_from_body,
            wind,
        )
    }

    /// Time derivative of state `x` under `cmd` in `wind`, in [`super::state_index`] order
    /// (m/s^2, rad/s, rad/s^2, m/s, percent/s, rad/s).
    pub fn derivatives(
        &self,
        x: &ReceiverState,
        cmd: &ReceiverCommand,
        wind: &Wind,
    ) -> StateVector {
        let ned_from_body = ned_from_body(x);
        let loads = self.body_loads_with(
            x,
            &self.air_data_with(x, &ned_from_body, wind),
            &ned_from_body,
            wind,
        );
        let omega = x.rate_body_radps;
        let gravity_body =
            ned_from_body.inverse_transform_vector(&(Vector3::z() * self.gravity_mps2));
        let angular_momentum = self.inertia_kgm2 * omega + self.engine_momentum_body_kgm2ps;
        // The derivative has the state's layout, so it is assembled as one.
        ReceiverState {
            vel_body_mps: loads.force_body_n / self.mass_kg + gravity_body
                - omega.cross(&x.vel_body_mps),
            euler_rad: euler_rates_radps(&x.euler_rad, &omega),
            rate_body_radps: self.inertia_inv_per_kgm2
                * (loads.moment_body_nm - omega.cross(&angular_momentum)),
            pos_ned_m: ned_from_body * x.vel_body_mps,
            engine_power_pct: power_rate_pct_per_s(
                x.engine_power_pct,
                commanded_power_pct(self.actuators.clamp_throttle(cmd.throttle)),
            ) / self.plant.engine_time_constant_scale,
            surfaces_rad: self.surfaces.rates_radps(cmd, &x.surfaces_rad),
        }
        .to_vector()
    }

    /// Advance `x` by `dt_s` seconds with classic fixed-step fourth-order Runge-Kutta, `cmd` and
    /// `wind` held over the step.
    pub fn step_rk4(&self, x: &mut ReceiverState, cmd: &ReceiverCommand, wind: &Wind, dt_s: f64) {
        let f = |v: &StateVector| self.derivatives(&ReceiverState::from_vector(v), cmd, wind);
        let x0 = x.to_vector();
        let k1 = f(&x0);
        let k2 = f(&(x0 + k1 * (dt_s / 2.0)));
        let k3 = f(&(x0 + k2 * (dt_s / 2.0)));
        let k4 = f(&(x0 + k3 * dt_s));
        *x = ReceiverState::from_vector(&(x0 + (k1 + (k2 + k3) * 2.0 + k4) * (dt_s / 6.0)));
    }

    fn air_data_with(
        &self,
        x: &ReceiverState,
        ned_from_body: &Rotation3<f64>,
        wind: &Wind,
    ) -> AirData {
        let air = x.vel_body_mps - ned_from_body.inverse_transform_vector(&wind.velocity_ned_mps);
        let airspeed_mps = air.norm();
        let properties = self.atmosphere.at(-x.pos_ned_m.z);
        AirData {
            airspeed_mps,
            alpha_rad: air.z.atan2(air.x),
            beta_rad: air.y.atan2(air.x.hypot(air.z)),
            mach: airspeed_mps / properties.speed_of_sound_mps,
            dynamic_pressure_pa: 0.5 * properties.density_kg_m3 * airspeed_mps * airspeed_mps,
            density_kg_m3: properties.density_kg_m3,
        }
    }

    fn body_loads_with(
        &self,
        x: &ReceiverState,
        air: &AirData,
        ned_from_body: &Rotation3<f64>,
        wind: &Wind,
    ) -> BodyLoads {
        let surfaces = &x.surfaces_rad;
        let c = self.aero.coefficients(&AeroInput {
            alpha_deg: air.alpha_rad.to_degrees(),
            beta_deg: air.beta_rad.to_degrees(),
            elevator_deg: surfaces.elevator_rad.to_degrees(),
            aileron_deg: surfaces.aileron_rad.to_degrees(),
            rudder_deg: surfaces.rudder_rad.to_degrees(),
            airspeed_mps: air.airspeed_mps,
            rate_body_radps: x.rate_body_radps
                - ned_from_body.inverse_transform_vector(&wind.angular_rate_ned_radps),
        });
        let g = &self.geometry;
        let qbar_s_n = air.dynamic_pressure_pa * g.wing_area_m2;
        let thrust_n = self
            .engine
            .thrust_n(x.engine_power_pct, air.mach, -x.pos_ned_m.z);
        BodyLoads {
            force_body_n: c.force * qbar_s_n + Vector3::x() * thrust_n,
            moment_body_nm: c.moment.component_mul(&Vector3::new(
                g.span_m,
                g.mean_chord_m,
                g.span_m,
            )) * qbar_s_n,
        }
    }
}

/// Rotation taking body-axis vectors to NED (`C_nb`), from the 3-2-1 Euler angles of `x`.
fn ned_from_body(x: &ReceiverState) -> Rotation3<f64> {
    let [phi, theta, psi] = [0, 1, 2].map(|axis| x.euler_rad[axis]);
    // nalgebra composes yaw * pitch * roll, i.e. the 3-2-1 sequence from NED to body.
    Rotation3::from_euler_angles(phi, theta, psi)
}

/// Euler-angle rates (phi, theta, psi), rad/s, from body rates `omega` (3-2-1 kinematics).
fn euler_rates_radps(euler_rad: &Vector3<f64>, omega: &Vector3<f64>) -> Vector3<f64> {
    let (sin_phi, cos_phi) = euler_rad.x.sin_cos();
    let (p, q, r) = (omega.x, omega.y, omega.z);
    let q_r_yaw_plane = q * sin_phi + r * cos_phi;
    Vector3::new(
        p + euler_rad.y.tan() * q_r_yaw_plane,
        q * cos_phi - r * sin_phi,
        q_r_yaw_plane / euler_rad.y.cos(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::receiver::state::{STATE_DIM, Surfaces, state_index};
    use crate::receiver::trim::Trim;

    const XCG_NOMINAL: f64 = 0.35;
    const REFUEL_SPEED_MPS: f64 = 120.0;
    const REFUEL_ALTITUDE_M: f64 = 3000.0;
    const DT_S: f64 = 0.01;

    fn model_and_trim() -> (F16, Trim) {
        let model = F16::new(XCG_NOMINAL).expect("model must build");
        let trim = model
            .trim_straight_level(REFUEL_SPEED_MPS, REFUEL_ALTITUDE_M)
            .expect("trim must converge");
        (model, trim)
    }

    #[test]
    fn mass_properties_in_si() {
        let model = F16::new(XCG_NOMINAL).expect("model must build");
        assert!((model.mass_kg() - 9295.4).abs() < 0.1);
        assert!((model.inertia_kgm2()[(0, 0)] - 12_874.8).abs() < 0.1);
        assert!((model.inertia_kgm2()[(0, 2)] + 1331.4).abs() < 0.1);
        assert!((model.geometry().span_m - 9.144).abs() < 1e-12);
        assert!((model.gravity_mps2() - 9.8054).abs() < 1e-4);
        assert!(F16::new(1.5).is_err() && F16::new(f64::NAN).is_err());
    }

    #[test]
    fn rejects_invalid_actuator_params() {
        let mut model = F16::new(XCG_NOMINAL).expect("model must build");
        let good = *model.actuators();
        let mut bad = good;
        bad.elevator.rate_limit_radps = -1.0;
        assert!(model.set_actuators(bad).is_err());
        bad = ActuatorParams {
            throttle_min: 0.8,
            throttle_max: 0.2,
            ..good
        };
        assert!(model.set_actuators(bad).is_err());
        assert_eq!(*model.actuators(), good);
    }

    #[test]
    fn euler_kinematics_and_attitude() {
        // Pitched up 10 deg, heading east: forward velocity climbs and goes east.
        let (model, trim) = model_and_trim();
        let mut x = trim.state;
        x.euler_rad = Vector3::new(0.0, 10f64.to_radians(), 90f64.to_radians());
        x.vel_body_mps = Vector3::new(100.0, 0.0, 0.0);
        let xdot = model.derivatives(&x, &trim.command, &Wind::default());
        assert!(xdot[state_index::NORTH].abs() < 1e-12);
        assert!((xdot[state_index::EAST] - 100.0 * 10f64.to_radians().cos()).abs() < 1e-9);
        assert!((xdot[state_index::DOWN] + 100.0 * 10f64.to_radians().sin()).abs() < 1e-9);
        // Banked 90 deg, a body pitch rate turns the heading at the same rate.
        x.euler_rad = Vector3::new(90f64.to_radians(), 0.0, 0.0);
        x.rate_body_radps = Vector3::new(0.0, 0.2, 0.0);
        let xdot = model.derivatives(&x, &trim.command, &Wind::default());
        assert!((xdot[state_index::PSI] - 0.2).abs() < 1e-12);
        assert!(xdot[state_index::THETA].abs() < 1e-12);
    }

    #[test]
    fn air_mass_rotation_acts_like_the_opposite_body_rate() {
        let (model, trim) = model_and_trim();
        let mut spinning = trim.state;
        spinning.rate_body_radps = Vector3::new(0.1, -0.05, 0.02);
        // Air rotating with the body: the damping terms see no relative rate.
        let co_rotating = Wind {
            angular_rate_ned_radps: ned_from_body(&spinning) * spinning.rate_body_radps,
            ..Wind::default()
        };
        let a = model.body_loads(&spinning, &co_rotating);
        let b = model.body_loads(&trim.state, &Wind::default());
        assert!(
            (a.moment_body_nm - b.moment_body_nm).norm() < 1e-6 * b.moment_body_nm.norm().max(1.0)
        );
        assert!((a.force_body_n - b.force_body_n).norm() < 1e-6 * b.force_body_n.norm());
        let plain = model.body_loads(&spinning, &Wind::default());
        assert!(
            (plain.moment_body_nm - b.moment_body_nm).norm() > 1.0,
            "rates do damp"
        );
    }

    #[test]
    fn wind_equals_the_opposite_change_of_ground_velocity() {
        let (model, trim) = model_and_trim();
        let mut with_wind = trim.state;
        with_wind.euler_rad = Vector3::new(0.2, 0.1, 0.7);
        with_wind.rate_body_radps = Vector3::new(0.05, -0.03, 0.02);
        let wind = Wind {
            velocity_ned_mps: Vector3::new(-8.0, 5.0, 1.5),
            ..Wind::default()
        };
        let wind_body = ned_from_body(&with_wind).inverse_transform_vector(&wind.velocity_ned_mps);
        let still_air = ReceiverState {
            vel_body_mps: with_wind.vel_body_mps - wind_body,
            ..with_wind
        };
        let calm = Wind::default();
        assert_eq!(
            model.air_data(&with_wind, &wind),
            model.air_data(&still_air, &calm)
        );
        let (a, b) = (
            model.body_loads(&with_wind, &wind),
            model.body_loads(&still_air, &calm),
        );
        assert!((a.force_body_n - b.force_body_n).norm() < 1e-9);
        assert!((a.moment_body_nm - b.moment_body_nm).norm() < 1e-9);
        // The wind does matter: same ground velocity in calm air gives other loads.
        let calm_loads = model.body_loads(&with_wind, &calm);
        assert!((a.force_body_n - calm_loads.force_body_n).norm() > 100.0);
        // Ground track: position rates differ by exactly the wind.
        let xdot = |x, w| model.derivatives(x, &trim.command, w);
        let drift = xdot(&with_wind, &wind).fixed_rows::<3>(state_index::NORTH)
            - xdot(&still_air, &calm).fixed_rows::<3>(state_index::NORTH);
        assert!((drift - wind.velocity_ned_mps).norm() < 1e-9);
    }

    #[test]
    fn actuators_respect_position_and_rate_limits() {
        let (model, trim) = model_and_trim();
        let limits = *model.actuators();
        let far_beyond_rad = 10.0;
        let cmd = ReceiverCommand {
            elevator_rad: far_beyond_rad,
            aileron_rad: -far_beyond_rad,
            rudder_rad: far_beyond_rad,
            ..trim.command
        };
        let mut x = trim.state;
        let tolerance_rad = 1e-12;
        let surfaces = |s: &Surfaces| [s.elevator_rad, s.aileron_rad, s.rudder_rad];
        let bounds = [limits.elevator, limits.aileron, limits.rudder];
        for _ in 0..100 {
            let before = surfaces(&x.surfaces_rad);
            model.step_rk4(&mut x, &cmd, &Wind::default(), DT_S);
            for ((after, before), bound) in surfaces(&x.surfaces_rad)
                .into_iter()
                .zip(before)
                .zip(bounds)
            {
                assert!(after.abs() <= bound.position_limit_rad + tolerance_rad);
                assert!((after - before).abs() <= bound.rate_limit_radps * DT_S + tolerance_rad);
            }
        }
        // After 1 s every surface sits at its limit, on the commanded side.
        let reached = surfaces(&x.surfaces_rad);
        let targets = [
            limits.elevator.position_limit_rad,
            -limits.aileron.position_limit_rad,
            limits.rudder.position_limit_rad,
        ];
        for (reached, target) in reached.into_iter().zip(targets) {
            assert!((reached - target).abs() < 1e-3, "{reached} vs {target}");
        }
    }

    #[test]
    fn short_period_is_stable_after_an_elevator_doublet() {
        let (model, trim) = model_and_trim();
        let doublet_rad = 1f64.to_radians();
        let half_period_steps = 50; // 0.5 s each way
        let mut x = trim.state;
        let mut peak_q_radps = 0.0f64;
        let mut q_history = Vec::new();
        for step in 0..1000 {
            let offset = match step / half_period_steps {
                0 => doublet_rad,
                1 => -doublet_rad,
                _ => 0.0,
            };
            let cmd = ReceiverCommand {
                elevator_rad: trim.command.elevator_rad + offset,
                ..trim.command
            };
            model.step_rk4(&mut x, &cmd, &Wind::default(), DT_S);
            peak_q_radps = peak_q_radps.max(x.rate_body_radps.y.abs());
            q_history.push(x.rate_body_radps.y);
        }
        assert!(
            peak_q_radps > 0.5f64.to_radians(),
            "doublet must excite the pitch rate"
        );
        // From 5 s to 10 s (4 s after the doublet ends) the pitch rate stays below 5 % of its peak.
        let late_max = q_history[500..].iter().fold(0.0f64, |m, q| m.max(q.abs()));
        assert!(
            late_max < 0.05 * peak_q_radps,
            "late {late_max} vs peak {peak_q_radps}"
        );
    }

    /// The trim state with surfaces off trim (so that every moment is non-zero) and no rates
    /// (so that the gyroscopic terms vanish): the angular acceleration is `J^-1 M`.
    fn deflected(trim: &Trim) -> ReceiverState {
        let mut x = trim.state;
        x.surfaces_rad.elevator_rad += 0.03;
        x.surfaces_rad.aileron_rad = 0.05;
        x.surfaces_rad.rudder_rad = -0.08;
        x
    }

    fn with_plant(change: impl Fn(&mut ReceiverPlant)) -> F16 {
        let mut plant = ReceiverPlant::NOMINAL;
        change(&mut plant);
        F16::with_plant(XCG_NOMINAL, &plant).expect("valid plant")
    }

    #[test]
    fn the_nominal_plant_is_the_model() {
        let (model, trim) = model_and_trim();
        let same = F16::with_plant(XCG_NOMINAL, &ReceiverPlant::NOMINAL).expect("builds");
        let x = deflected(&trim);
        let wind = Wind::default();
        assert_eq!(
            same.derivatives(&x, &trim.command, &wind),
            model.derivatives(&x, &trim.command, &wind)
        );
        assert!(model.plant().is_nominal());
        let mut bad = ReceiverPlant::NOMINAL;
        bad.mass_scale = 3.0;
        let e = F16::with_plant(XCG_NOMINAL, &bad).expect_err("out of limits");
        assert!(e.to_string().contains("mass_scale"), "{e}");
    }

    #[test]
    fn inertia_factors_scale_the_angular_acceleration_for_the_same_moment() {
        let (model, trim) = model_and_trim();
        let x = deflected(&trim);
        let (cmd, wind) = (trim.command, Wind::default());
        let base = model.derivatives(&x, &cmd, &wind);
        let rel = |a: f64, b: f64| (a - b).abs() / b.abs();
        // Pitch inertia twice: the pitch acceleration halves, nothing else changes.
        let heavy_pitch = with_plant(|k| k.jy_scale = 2.0).derivatives(&x, &cmd, &wind);
        assert!(base[state_index::Q].abs() > 0.1, "{}", base[state_index::Q]);
        assert!(rel(heavy_pitch[state_index::Q], 0.5 * base[state_index::Q]) < 1e-12);
        // The other accelerations through the inverse of another J: equal to rounding.
        for i in [state_index::P, state_index::R] {
            assert!(rel(heavy_pitch[i], base[i]) < 1e-13, "state {i}");
        }
        let angular = [state_index::P, state_index::Q, state_index::R];
        for i in (0..STATE_DIM).filter(|i| !angular.contains(i)) {
            assert_eq!(heavy_pitch[i], base[i], "state {i}");
        }
        // Roll and yaw inertias twice (and so Jxz): roll and yaw accelerations halve.
        let heavy_lateral = with_plant(|k| {
            k.jx_scale = 2.0;
            k.jz_scale = 2.0;
        });
        let j = heavy_lateral.inertia_kgm2();
        assert!(rel(j[(0, 2)], 2.0 * model.inertia_kgm2()[(0, 2)]) < 1e-15);
        // One of them alone: Jxz by the geometric mean of the two factors.
        let j = with_plant(|k| k.jx_scale = 1.44).inertia_kgm2();
        assert!(rel(j[(0, 2)], 1.2 * model.inertia_kgm2()[(0, 2)]) < 1e-15);
        assert!(rel(j[(0, 0)], 1.44 * model.inertia_kgm2()[(0, 0)]) < 1e-15);
        let d = heavy_lateral.derivatives(&x, &cmd, &wind);
        for i in [state_index::P, state_index::R] {
            assert!(base[i].abs() > 0.05, "{}", base[i]);
            assert!(rel(d[i], 0.5 * base[i]) < 1e-12, "state {i}");
        }
        assert!(rel(d[state_index::Q], base[state_index::Q]) < 1e-13);
    }

    #[test]
    fn mass_factor_scales_the_acceleration_by_the_loads() {
        let (model, trim) = model_and_trim();
        let x = deflected(&trim);
        let (cmd, wind) = (trim.command, Wind::default());
        let heavy = with_plant(|k| k.mass_scale = 1.25);
        assert!((heavy.mass_kg() - 1.25 * model.mass_kg()).abs() < 1e-9);
        let (base, d) = (
            model.derivatives(&x, &cmd, &wind),
            heavy.derivatives(&x, &cmd, &wind),
        );
        // With no rates, dv/dt = F/m + g: the loads' part shrinks by 1/1.25, gravity's stays.
        let force = model.body_loads(&x, &wind).force_body_n;
        let expected = force / heavy.mass_kg() - force / model.mass_kg();
        let got = d.fixed_rows::<3>(state_index::U) - base.fixed_rows::<3>(state_index::U);
        assert!((got - expected).norm() < 1e-9, "{got} vs {expected}");
        assert!(expected.norm() > 0.1);
        for i in state_index::PHI..STATE_DIM {
            assert_eq!(d[i], base[i], "state {i}");
        }
    }

    #[test]
    fn actuator_factors_scale_each_surfaces_rate_limit_and_bandwidth() {
        let (model, trim) = model_and_trim();
        let nominal = *model.actuators();
        let slow = with_plant(|k| {
            k.elevator_rate_limit_scale = 0.5;
            k.aileron_bandwidth_scale = 1.5;
            k.rudder_rate_limit_scale = 2.0;
        });
        let x = trim.state;
        let rates = |m: &F16, cmd: &ReceiverCommand| {
            let d = m.derivatives(&x, cmd, &Wind::default());
            [
                state_index::ELEVATOR,
                state_index::AILERON,
                state_index::RUDDER,
            ]
            .map(|i| d[i])
        };
        // Far commands: each surface at its rate limit, the elevator's and rudder's scaled.
        let far = ReceiverCommand {
            elevator_rad: 1.0,
            aileron_rad: 1.0,
            rudder_rad: -1.0,
            ..trim.command
        };
        let [e, a, r] = rates(&slow, &far);
        assert!((e - 0.5 * nominal.elevator.rate_limit_radps).abs() < 1e-15);
        assert_eq!(a, nominal.aileron.rate_limit_radps);
        assert!((r + 2.0 * nominal.rudder.rate_limit_radps).abs() < 1e-15);
        // Small commands: the lag, the aileron's bandwidth scaled.
        let error_rad = 1e-3;
        let near = ReceiverCommand {
            elevator_rad: x.surfaces_rad.elevator_rad + error_rad,
            aileron_rad: error_rad,
            rudder_rad: error_rad,
            ..trim.command
        };
        let [e, a, r] = rates(&slow, &near);
        let w = nominal.bandwidth_radps;
        assert!((e - w * error_rad).abs() < 1e-12);
        assert!((a - 1.5 * w * error_rad).abs() < 1e-12);
        assert!((r - w * error_rad).abs() < 1e-12);
        // Stepped: the elevator moves at the scaled rate limit, never faster.
        let mut y = x;
        slow.step_rk4(&mut y, &far, &Wind::default(), DT_S);
        let moved = y.surfaces_rad.elevator_rad - x.surfaces_rad.elevator_rad;
        assert!((moved - 0.5 * nominal.elevator.rate_limit_radps * DT_S).abs() < 1e-12);
    }

    #[test]
    fn engine_factor_scales_the_power_lag() {
        let (model, trim) = model_and_trim();
        let lazy = with_plant(|k| k.engine_time_constant_scale = 2.0);
        let cmd = ReceiverCommand {
            throttle: trim.command.throttle + 0.1,
            ..trim.command
        };
        let rate = |m: &F16| m.derivatives(&trim.state, &cmd, &Wind::default())[state_index::POWER];
        assert!(rate(&model) > 1.0, "{}", rate(&model));
        assert!((rate(&lazy) - 0.5 * rate(&model)).abs() < 1e-12);
    }
}
