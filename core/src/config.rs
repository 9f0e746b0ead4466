//! Controller configuration: every runtime parameter, its default and its validation.
//!
//! The defaults are the paper's where it gives a number (Table 1 outer gains, in normalised
//! image units), the F-16's airframe facts where they apply, and our stated judgement
//! elsewhere (each documented on its field and in `docs/conventions.md`).
//!
//! Invariant: a [`crate::Controller`] is only built from a configuration that passed
//! [`ControllerConfig::validate`]; the step relies on it (positive gains and limits,
//! `min_closing <= max_closing`, trim inside the actuator limits).

use serde::{Deserialize, Serialize};

use crate::actuator::ActuatorLimits;
use crate::estimator::EstimatorConfig;
use crate::gains;
use crate::kinematics::{CameraMount, SET_BACK_CAMERA_BODY_M};
use crate::measurement::MeasurementLimits;
use crate::mode::ModeConfig;
use crate::nav::NavEnvelope;
use crate::num::{SIN_COS_MAX_RAD, max_to};
use crate::outer::{IbvsGains, PbvsGains, PbvsGeometry, VelocityLimits};
use crate::predictor::MAX_NAV_LATENCY_STEPS;
use crate::procedure::{Procedure, RefuellingConfig};

/// Which outer loop flies the approach.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OuterLaw {
    /// Image-based visual servo (the paper's method).
    #[default]
    Ibvs,
    /// Position-based baseline.
    Pbvs,
}

/// Every runtime parameter of the controller.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ControllerConfig {
    /// The procedure flown: the paper's single shot or the refuelling procedure.
    pub procedure: Procedure,
    /// Outer loop of the paper's procedure.
    pub law: OuterLaw,
    /// IBVS gains.
    pub ibvs: IbvsGains,
    /// PBVS gains.
    pub pbvs: PbvsGains,
    /// Limits on the desired velocity, both laws.
    pub velocity_limits: VelocityLimits,
    /// Where the controller believes the camera is (may differ from the truth: paper Sec. IV).
    pub camera: CameraMount,
    /// Probe tip relative to the CG, body axes, m.
    pub probe_tip_body_m: [f32; 3],
    /// Measurement plausibility limits.
    pub measurement: MeasurementLimits,
    /// Navigation envelope.
    pub nav_envelope: NavEnvelope,
    /// Mode logic.
    pub modes: ModeConfig,
    /// Actuator position limits.
    pub actuators: ActuatorLimits,
    /// Bound on each inner-loop integrator (a position error), m.
    pub integrator_limit_m: f32,
    /// Latency of the navigation sample, control periods: the installed INS's, from its
    /// installation data. The inner loops see the state predicted forward over it
    /// ([`crate::predictor`]); 0 feeds the sample back as it is. At most
    /// [`MAX_NAV_LATENCY_STEPS`].
    pub nav_latency_steps: u8,
    /// The refuelling procedure.
    pub refuelling: RefuellingConfig,
    /// The drogue estimator (refuelling procedure).
    pub estimator: EstimatorConfig,
}

/// What is wrong with a configuration value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ConfigProblem {
    /// NaN or infinite.
    NotFinite,
    /// Must be strictly positive.
    NotPositive,
    /// Must not be negative.
    Negative,
    /// Inconsistent with another value (named in the field).
    Inconsistent,
}

/// A rejected configuration: the field and what is wrong with it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ConfigError {
    /// Dotted path of the offending field.
    pub field: &'static str,
    /// The problem.
    pub problem: ConfigProblem,
}

impl core::fmt::Display for ConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "invalid controller configuration: {} is {:?}",
            self.field, self.problem
        )
    }
}

impl core::error::Error for ConfigError {}

impl Default for ControllerConfig {
    fn default() -> Self {
        Self {
            procedure: Procedure::Refuelling,
            law: OuterLaw::Ibvs,
            ibvs: IbvsGains {
                k1_mps: 1.0,
                k2_mps: 2.0,
                k3_per_s: 0.3,
                k4_mps: 3.0,
                k5_mps: 1.0,
                convergence_point: [0.0, 0.0],
                max_cartesian_gain_per_s: 0.7,
            },
            pbvs: PbvsGains {
                k_lat_per_s: 0.4,
                k_vert_per_s: 0.4,
                k_close_per_s: 0.3,
                k_slow_lat_per_s: 0.5,
                k_slow_vert_per_s: 0.5,
            },
            velocity_limits: VelocityLimits {
                min_closing_mps: 0.8,
                max_closing_mps: 2.0,
                max_lateral_mps: 2.0,
                max_vertical_mps: 2.0,
                max_accel_mps2: 0.5,
            },
            camera: CameraMount {
                position_body_m: SET_BACK_CAMERA_BODY_M,
                pitch_down_rad: gains::TRIM.theta_rad,
            },
            probe_tip_body_m: gains::DESIGN_CAMERA_BODY_M,
            measurement: MeasurementLimits::default(),
            nav_envelope: NavEnvelope::default(),
            modes: ModeConfig::default(),
            actuators: ActuatorLimits::default(),
            integrator_limit_m: 20.0,
            // The stated sensor suite's INS: one control period (docs/models.md,
            // "Navigation").
            nav_latency_steps: 1,
            refuelling: RefuellingConfig::default(),
            estimator: EstimatorConfig::default(),
        }
    }
}

fn check(field: &'static str, v: f32, positive: bool) -> Result<(), ConfigError> {
    let problem = if !v.is_finite() {
        ConfigProblem::NotFinite
    } else if positive && v <= 0.0 {
        ConfigProblem::NotPositive
    } else if v < 0.0 {
        ConfigProblem::Negative
    } else {
        return Ok(());
    };
    Err(ConfigError { field, problem })
}

fn require(field: &'static str, ok: bool) -> Result<(), ConfigError> {
    if ok {
        Ok(())
    } else {
        Err(ConfigError {
            field,
            problem: ConfigProblem::Inconsistent,
        })
    }
}

impl ControllerConfig {
    /// The default configuration flying the paper's procedure (approach, blind terminal
    /// phase, docked or breakaway) with the paper's camera at the probe tip, instead of the
    /// refuelling procedure with the set-back camera.
    pub fn paper() -> Self {
        let d = Self::default();
        Self {
            procedure: Procedure::Paper,
            camera: CameraMount {
                position_body_m: gains::DESIGN_CAMERA_BODY_M,
                ..d.camera
            },
            // The paper's navigation is perfect.
            nav_latency_steps: 0,
            ..d
        }
    }

    /// What PBVS believes about the geometry.
    pub fn pbvs_geometry(&self) -> PbvsGeometry {
        PbvsGeometry {
            camera: self.camera,
            probe_tip_body_m: self.probe_tip_body_m,
            trim_pitch_rad: gains::TRIM.theta_rad,
        }
    }

    /// Checks every value; the first problem found is returned.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let g = &self.ibvs;
        check("ibvs.k1_mps", g.k1_mps, true)?;
        check("ibvs.k2_mps", g.k2_mps, true)?;
        check("ibvs.k3_per_s", g.k3_per_s, true)?;
        check("ibvs.k4_mps", g.k4_mps, false)?;
        check("ibvs.k5_mps", g.k5_mps, false)?;
        require(
            "ibvs.max_cartesian_gain_per_s (positive; infinity allowed)",
            g.max_cartesian_gain_per_s > 0.0,
        )?;
        for v in g.convergence_point {
            require(
                "ibvs.convergence_point (finite, inside the field of view)",
                v.is_finite(),
            )?;
        }
        require(
            "ibvs.convergence_point (finite, inside the field of view)",
            libm::fabsf(g.convergence_point[0]) < self.measurement.half_fov_x
                && libm::fabsf(g.convergence_point[1]) < self.measurement.half_fov_y,
        )?;
        let p = &self.pbvs;
        check("pbvs.k_lat_per_s", p.k_lat_per_s, true)?;
        check("pbvs.k_vert_per_s", p.k_vert_per_s, true)?;
        check("pbvs.k_close_per_s", p.k_close_per_s, true)?;
        check("pbvs.k_slow_lat_per_s", p.k_slow_lat_per_s, false)?;
        check("pbvs.k_slow_vert_per_s", p.k_slow_vert_per_s, false)?;
        let l = &self.velocity_limits;
        check("velocity_limits.min_closing_mps", l.min_closing_mps, true)?;
        check("velocity_limits.max_closing_mps", l.max_closing_mps, true)?;
        check("velocity_limits.max_lateral_mps", l.max_lateral_mps, true)?;
        check("velocity_limits.max_vertical_mps", l.max_vertical_mps, true)?;
        check("velocity_limits.max_accel_mps2", l.max_accel_mps2, true)?;
        require(
            "velocity_limits.min_closing_mps (<= max_closing_mps)",
            l.min_closing_mps <= l.max_closing_mps,
        )?;
        for v in self
            .camera
            .position_body_m
            .into_iter()
            .chain(self.probe_tip_body_m)
        {
            require(
                "camera.position_body_m / probe_tip_body_m (finite)",
                v.is_finite(),
            )?;
        }
        require(
            "camera.pitch_down_rad (finite, at most 0.8 rad either way)",
            libm::fabsf(self.camera.pitch_down_rad) <= SIN_COS_MAX_RAD,
        )?;
        let m = &self.measurement;
        check("measurement.max_depth_m", m.max_depth_m, true)?;
        require(
            "measurement.max_depth_m (<= 1000 m)",
            m.max_depth_m <= 1000.0,
        )?;
        check("measurement.half_fov_x", m.half_fov_x, true)?;
        check("measurement.half_fov_y", m.half_fov_y, true)?;
        let n = &self.nav_envelope;
        check("nav_envelope.max_angle_rad", n.max_angle_rad, true)?;
        check("nav_envelope.max_bank_rad", n.max_bank_rad, true)?;
        check("nav_envelope.max_sideslip_rad", n.max_sideslip_rad, true)?;
        check("nav_envelope.max_speed_mps", n.max_speed_mps, true)?;
        check("nav_envelope.max_rate_radps", n.max_rate_radps, true)?;
        // Every angle of the step's trigonometry (`num::sin_cos`) stays within its range, at
        // every trim of the gain schedule (interpolated trims lie between the nodes').
        let mut trim = 0.0;
        for row in &gains::SCHEDULE {
            for d in row {
                trim = max_to(trim, libm::fabsf(d.trim.theta_rad));
                trim = max_to(trim, libm::fabsf(d.trim.alpha_rad));
            }
        }
        require(
            "nav_envelope.max_angle_rad (plus the largest trim pitch and angle of attack, <= 0.8 rad)",
            n.max_angle_rad + trim <= SIN_COS_MAX_RAD,
        )?;
        require(
            "nav_envelope.max_bank_rad / max_sideslip_rad (<= 0.8 rad)",
            n.max_bank_rad <= SIN_COS_MAX_RAD && n.max_sideslip_rad <= SIN_COS_MAX_RAD,
        )?;
        let md = &self.modes;
        check("modes.terminal_depth_m", md.terminal_depth_m, true)?;
        check(
            "modes.terminal_max_offset_m",
            md.terminal_max_offset_m,
            true,
        )?;
        check("modes.terminal_overshoot_m", md.terminal_overshoot_m, true)?;
        check("modes.terminal_timeout_s", md.terminal_timeout_s, true)?;
        require(
            "modes.terminal_timeout_s (< 1 hour)",
            md.terminal_timeout_s < 3600.0,
        )?;
        check("modes.breakaway_aft_mps", md.breakaway_aft_mps, false)?;
        check("modes.breakaway_down_mps", md.breakaway_down_mps, false)?;
        check(
            "modes.breakaway_throttle_cut",
            md.breakaway_throttle_cut,
            false,
        )?;
        require(
            "modes.breakaway_down_mps (<= velocity_limits.max_vertical_mps)",
            md.breakaway_down_mps <= l.max_vertical_mps,
        )?;
        check("modes.overspeed_mps", md.overspeed_mps, true)?;
        check("modes.breakaway_accel_mps2", md.breakaway_accel_mps2, true)?;
        check("modes.terminal_accel_mps2", md.terminal_accel_mps2, true)?;
        check("modes.drogue_rate_filter", md.drogue_rate_filter, true)?;
        require(
            "modes.drogue_rate_filter (<= 1)",
            md.drogue_rate_filter <= 1.0,
        )?;
        require(
            "modes.overspeed_mps (> velocity_limits.max_closing_mps)",
            md.overspeed_mps > l.max_closing_mps,
        )?;
        require(
            "modes.breakaway_aft_mps (<= velocity_limits.max_closing_mps)",
            md.breakaway_aft_mps <= l.max_closing_mps,
        )?;
        let a = &self.actuators;
        let trim = trim_command();
        for ((lo, hi), t) in a.min.iter().zip(a.max).zip(trim) {
            require(
                "actuators (finite, min < max)",
                lo.is_finite() && hi.is_finite() && *lo < hi,
            )?;
            require("actuators (trim inside the limits)", *lo <= t && t <= hi)?;
        }
        check("integrator_limit_m", self.integrator_limit_m, true)?;
        require(
            "nav_latency_steps (at most predictor::MAX_NAV_LATENCY_STEPS)",
            self.nav_latency_steps <= MAX_NAV_LATENCY_STEPS,
        )?;
        self.validate_refuelling()?;
        self.validate_estimator()
    }

    fn validate_refuelling(&self) -> Result<(), ConfigError> {
        let r = &self.refuelling;
        let l = &self.velocity_limits;
        for (field, v) in [
            ("refuelling.station_depth_m", r.station_depth_m),
            ("refuelling.station_gain_per_s", r.station_gain_per_s),
            ("refuelling.station_max_speed_mps", r.station_max_speed_mps),
            ("refuelling.station_offset_tol_m", r.station_offset_tol_m),
            ("refuelling.station_depth_tol_m", r.station_depth_tol_m),
            ("refuelling.station_overrun_m", r.station_overrun_m),
            (
                "refuelling.station_drogue_speed_tol_mps",
                r.station_drogue_speed_tol_mps,
            ),
            (
                "refuelling.station_relative_speed_tol_mps",
                r.station_relative_speed_tol_mps,
            ),
            ("refuelling.track_gain_per_s", r.track_gain_per_s),
            ("refuelling.max_correction_mps", r.max_correction_mps),
            ("refuelling.track_accel_mps2", r.track_accel_mps2),
            ("refuelling.contact_speed_mps", r.contact_speed_mps),
            ("refuelling.abort_offset_m", r.abort_offset_m),
            ("refuelling.commit_depth_m", r.commit_depth_m),
            ("refuelling.gate_radius_m", r.gate_radius_m),
            ("refuelling.late_gate_radius_m", r.late_gate_radius_m),
            (
                "refuelling.late_gate_final_radius_m",
                r.late_gate_final_radius_m,
            ),
            ("refuelling.late_gate_taper_m", r.late_gate_taper_m),
            ("refuelling.gate_max_horizon_s", r.gate_max_horizon_s),
            ("refuelling.capture_timeout_s", r.capture_timeout_s),
            (
                "refuelling.capture_min_time_to_go_s",
                r.capture_min_time_to_go_s,
            ),
            ("refuelling.overshoot_m", r.overshoot_m),
            ("refuelling.missed_aft_mps", r.missed_aft_mps),
            ("refuelling.missed_clear_s", r.missed_clear_s),
            ("refuelling.missed_accel_mps2", r.missed_accel_mps2),
            ("refuelling.reacquire_limit_s", r.reacquire_limit_s),
            ("refuelling.sortie_budget_s", r.sortie_budget_s),
        ] {
            check(field, v, true)?;
        }
        for (field, v) in [
            ("refuelling.station_dwell_s", r.station_dwell_s),
            ("refuelling.feedforward_lead_s", r.feedforward_lead_s),
            ("refuelling.feedforward_gain", r.feedforward_gain),
            ("refuelling.gate_sigmas", r.gate_sigmas),
            ("refuelling.missed_down_mps", r.missed_down_mps),
        ] {
            check(field, v, false)?;
        }
        require(
            "refuelling.feedforward_lead_s (<= 5 s)",
            r.feedforward_lead_s <= 5.0,
        )?;
        require(
            "refuelling.gate_max_horizon_s (<= 1.5 x estimator.drogue_time_constant_s)",
            r.gate_max_horizon_s <= 1.5 * self.estimator.drogue_time_constant_s,
        )?;
        require(
            "refuelling.contact_speed_mps (<= velocity_limits.max_closing_mps)",
            r.contact_speed_mps <= l.max_closing_mps,
        )?;
        require(
            "refuelling.missed_aft_mps (<= velocity_limits.max_closing_mps)",
            r.missed_aft_mps <= l.max_closing_mps,
        )?;
        require(
            "refuelling.missed_down_mps (<= velocity_limits.max_vertical_mps)",
            r.missed_down_mps <= l.max_vertical_mps,
        )?;
        require(
            "refuelling.late_gate_final_radius_m (<= late_gate_radius_m)",
            r.late_gate_final_radius_m <= r.late_gate_radius_m,
        )?;
        require(
            "refuelling.commit_depth_m (< station_depth_m)",
            r.commit_depth_m < r.station_depth_m,
        )?;
        require(
            "refuelling.station_overrun_m (station_depth_m - station_overrun_m > commit_depth_m)",
            r.station_depth_m - r.station_overrun_m > r.commit_depth_m,
        )?;
        require(
            "refuelling.station_overrun_m (> station_depth_tol_m)",
            r.station_overrun_m > r.station_depth_tol_m,
        )?;
        require("refuelling.max_attempts (>= 1)", r.max_attempts >= 1)?;
        require(
            "refuelling.feedforward_gain (<= 1)",
            r.feedforward_gain <= 1.0,
        )?;
        for (field, t) in [
            ("refuelling.station_dwell_s (< 1 hour)", r.station_dwell_s),
            (
                "refuelling.capture_timeout_s (< 1 hour)",
                r.capture_timeout_s,
            ),
            ("refuelling.missed_clear_s (< 1 hour)", r.missed_clear_s),
            (
                "refuelling.reacquire_limit_s (< 1 hour)",
                r.reacquire_limit_s,
            ),
            (
                "refuelling.sortie_budget_s (< 1 day)",
                r.sortie_budget_s / 24.0,
            ),
        ] {
            require(field, t < 3600.0)?;
        }
        Ok(())
    }

    fn validate_estimator(&self) -> Result<(), ConfigError> {
        let e = &self.estimator;
        for (field, v) in [
            ("estimator.drogue_time_constant_s", e.drogue_time_constant_s),
            ("estimator.drogue_accel_psd_m2ps3", e.drogue_accel_psd_m2ps3),
            (
                "estimator.drogue_fwd_time_constant_s",
                e.drogue_fwd_time_constant_s,
            ),
            ("estimator.offset_noise_m", e.offset_noise_m),
            ("estimator.depth_noise_m", e.depth_noise_m),
            (
                "estimator.initial_velocity_sigma_mps",
                e.initial_velocity_sigma_mps,
            ),
            ("estimator.gate_sigmas", e.gate_sigmas),
            ("estimator.tip_sight_tolerance", e.tip_sight_tolerance),
            ("estimator.tip_sight_filter", e.tip_sight_filter),
            ("estimator.mean_time_constant_s", e.mean_time_constant_s),
            (
                "estimator.activity_time_constant_s",
                e.activity_time_constant_s,
            ),
        ] {
            check(field, v, true)?;
        }
        for (field, v) in [
            (
                "estimator.drogue_fwd_accel_psd_m2ps3",
                e.drogue_fwd_accel_psd_m2ps3,
            ),
            ("estimator.offset_noise_per_m", e.offset_noise_per_m),
            ("estimator.depth_noise_per_m2", e.depth_noise_per_m2),
        ] {
            check(field, v, false)?;
        }
        require(
            "estimator.tip_sight_filter (<= 1)",
            e.tip_sight_filter <= 1.0,
        )?;
        // Time constants of at least a control period (the discrete models' poles stay away
        // from zero and the averages from a single step).
        for (field, t) in [
            (
                "estimator.drogue_time_constant_s (>= the control period)",
                e.drogue_time_constant_s,
            ),
            (
                "estimator.drogue_fwd_time_constant_s (>= the control period)",
                e.drogue_fwd_time_constant_s,
            ),
            (
                "estimator.activity_time_constant_s (>= the control period)",
                e.activity_time_constant_s,
            ),
            (
                "estimator.mean_time_constant_s (>= the control period)",
                e.mean_time_constant_s,
            ),
        ] {
            require(field, t >= gains::CONTROL_PERIOD_S)?;
        }
        Ok(())
    }
}

/// The trim command `[elevator, throttle, aileron, rudder]` of the single-point design (the
/// gain schedule's node at the default flight condition).
pub fn trim_command() -> [f32; 4] {
    gains::TRIM.command()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_is_valid() {
        assert_eq!(ControllerConfig::default().validate(), Ok(()));
    }

    #[test]
    fn names_the_bad_field() {
        let mut c = ControllerConfig::default();
        c.ibvs.k3_per_s = 0.0;
        assert_eq!(
            c.validate(),
            Err(ConfigError {
                field: "ibvs.k3_per_s",
                problem: ConfigProblem::NotPositive
            })
        );
        let mut c = ControllerConfig::default();
        c.pbvs.k_slow_lat_per_s = f32::NAN;
        assert_eq!(
            c.validate().map_err(|e| e.problem),
            Err(ConfigProblem::NotFinite)
        );
        let mut c = ControllerConfig::default();
        c.velocity_limits.min_closing_mps = 5.0;
        assert_eq!(
            c.validate().map_err(|e| e.problem),
            Err(ConfigProblem::Inconsistent)
        );
        let mut c = ControllerConfig::default();
        c.actuators.max[1] = 0.01;
        assert_eq!(
            c.validate().map_err(|e| e.problem),
            Err(ConfigProblem::Inconsistent)
        );
        let mut c = ControllerConfig::default();
        c.modes.breakaway_down_mps = c.velocity_limits.max_vertical_mps + 0.1;
        assert_eq!(
            c.validate().map_err(|e| e.problem),
            Err(ConfigProblem::Inconsistent)
        );
        let mut c = ControllerConfig::default();
        c.measurement.max_depth_m = f32::MAX;
        assert_eq!(
            c.validate().map_err(|e| e.problem),
            Err(ConfigProblem::Inconsistent)
        );
        let mut c = ControllerConfig::default();
        c.modes.terminal_accel_mps2 = 0.0;
        assert_eq!(
            c.validate(),
            Err(ConfigError {
                field: "modes.terminal_accel_mps2",
                problem: ConfigProblem::NotPositive
            })
        );
        let mut c = ControllerConfig::default();
        c.modes.drogue_rate_filter = f32::INFINITY;
        assert_eq!(
            c.validate(),
            Err(ConfigError {
                field: "modes.drogue_rate_filter",
                problem: ConfigProblem::NotFinite
            })
        );
        c.modes.drogue_rate_filter = 0.0;
        assert_eq!(
            c.validate().map_err(|e| e.problem),
            Err(ConfigProblem::NotPositive)
        );
        c.modes.drogue_rate_filter = 1.5;
        assert_eq!(
            c.validate(),
            Err(ConfigError {
                field: "modes.drogue_rate_filter (<= 1)",
                problem: ConfigProblem::Inconsistent
            })
        );
        c.modes.drogue_rate_filter = 1.0;
        assert_eq!(c.validate(), Ok(()));
        let mut c = ControllerConfig::default();
        c.modes.breakaway_down_mps = -1.0;
        assert_eq!(
            c.validate().map_err(|e| e.problem),
            Err(ConfigProblem::Negative)
        );
    }
}
