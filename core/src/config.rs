//! Controller configuration: every runtime parameter, its default and its validation.
//!
//! The defaults are the paper's where it gives a number (Table 1 outer gains, in normalised
//! image units), the F-16's airframe facts where they apply, and our stated judgement
//! elsewhere (each documented on its field and in `docs/conventions.md`).
//!
//! [`ControllerConfig`] is the configuration's one schema: the simulator's scenario files
//! read their `[controller]` table into it key for key, the flight computer receives it whole
//! in a configuration frame, and `host-sim config schema` prints every field with its unit,
//! default and rules. The rules are written once ([`RULES`], generated with the checks from
//! one list), each naming its field by the tokens that read it, so an error's path cannot
//! drift from the struct. Why not quartiq's `miniconf` (a settings tree with a path per field,
//! as stabilizer uses it): its strength is setting one field at a time, and here the rules
//! relate fields to one another (the closing band, the gate radii, the station against the
//! commit depth), so a configuration is validated and swapped whole, between two steps.
//!
//! Invariant: a [`crate::Controller`] is only built from a configuration that passed
//! [`ControllerConfig::validate`]; the step relies on it (positive gains and limits,
//! `min_closing <= max_closing`, trim inside the actuator limits).

use core::borrow::Borrow;

use serde::{Deserialize, Serialize};

use crate::actuator::ActuatorLimits;
use crate::attitude::{AttitudeLoopConfig, InnerLoop};
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

/// Which outer loop flies the approach (`"ibvs"` or `"pbvs"` in text formats).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[serde(rename_all = "lowercase")]
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
    /// installation data; where those give a range, its upper end (a latency predicted
    /// short costs the inner loops more margin than one predicted long: `docs/margins.md`).
    /// The inner loops see the state predicted forward over it ([`crate::predictor`]); 0
    /// feeds the sample back as it is. At most [`MAX_NAV_LATENCY_STEPS`].
    pub nav_latency_steps: u8,
    /// The receiver's gross mass as a factor of the design airframe's (the model data's
    /// 9,295 kg), from its fuel quantity and stores (`docs/conventions.md`, "Two designs by
    /// mass"). It chooses the refuelling procedure's inner-loop design: below
    /// [`LIGHT_DESIGN_BELOW_MASS_FACTOR`] the light airframe's
    /// ([`gains::REFUEL_LIGHT_MASS_FACTOR`]), else the first. Between
    /// [`MIN_MASS_FACTOR`] and [`MAX_MASS_FACTOR`]. The paper's procedure flies its one
    /// design at any mass.
    pub mass_factor: f32,
    /// The refuelling procedure.
    pub refuelling: RefuellingConfig,
    /// The drogue estimator (refuelling procedure).
    pub estimator: EstimatorConfig,
    /// Which inner loop flies the desired velocity: the surfaces (this controller flies the
    /// aircraft) or attitude setpoints to the aircraft's own autopilot.
    pub inner_loop: InnerLoop,
    /// The attitude-command inner loop (when `inner_loop` is `attitude`).
    pub attitude: AttitudeLoopConfig,
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

/// A rejected configuration: the field, what is wrong with it and the rule it broke.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ConfigError {
    /// Dotted path of the offending field (generated from the field access: [`RULES`]).
    pub field: &'static str,
    /// The problem.
    pub problem: ConfigProblem,
    /// The rule broken, as in [`RULES`]: "finite, > 0", "finite, >= 0", "finite (every
    /// element)", or a condition in the configuration's field names.
    pub requirement: &'static str,
}

impl core::fmt::Display for ConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "invalid controller configuration: {} is {:?} (requires {})",
            self.field, self.problem, self.requirement
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
            // The design airframe's: the first design, as before the second existed.
            mass_factor: 1.0,
            refuelling: RefuellingConfig::default(),
            estimator: EstimatorConfig::default(),
            inner_loop: InnerLoop::Surfaces,
            attitude: AttitudeLoopConfig::default(),
        }
    }
}

/// How a value must be, for [`RULES`] and the schema.
const POSITIVE: &str = "finite, > 0";
const NON_NEGATIVE: &str = "finite, >= 0";
const FINITE: &str = "finite (every element)";

/// `v` is finite and positive (`positive`) or not negative.
fn check(field: &'static str, v: f32, positive: bool) -> Result<(), ConfigError> {
    let (problem, requirement) = if !v.is_finite() {
        (
            ConfigProblem::NotFinite,
            if positive { POSITIVE } else { NON_NEGATIVE },
        )
    } else if positive && v <= 0.0 {
        (ConfigProblem::NotPositive, POSITIVE)
    } else if v < 0.0 {
        (ConfigProblem::Negative, NON_NEGATIVE)
    } else {
        return Ok(());
    };
    Err(ConfigError {
        field,
        problem,
        requirement,
    })
}

/// `ok`, else `field` is [`ConfigProblem::Inconsistent`] with `requirement`.
fn require(field: &'static str, requirement: &'static str, ok: bool) -> Result<(), ConfigError> {
    if ok {
        Ok(())
    } else {
        Err(ConfigError {
            field,
            problem: ConfigProblem::Inconsistent,
            requirement,
        })
    }
}

/// A number, by value or by reference (the rules' bindings are references to the
/// configuration's fields).
fn num(v: impl Borrow<f32>) -> f32 {
    *v.borrow()
}

/// Every element of an array is finite.
fn all_finite<const N: usize>(v: impl Borrow<[f32; N]>) -> bool {
    v.borrow().iter().all(|x| x.is_finite())
}

/// The rules of the configuration, written once: each names its field by the same tokens
/// that read it, so the path in a [`ConfigError`] and in [`RULES`] is generated from the
/// field access and cannot drift from the struct (a renamed field fails to compile).
///
/// `let PATTERN = CONFIG;` binds the top-level fields; then one rule per line:
/// - `positive a.b;` finite and > 0 ([`ConfigProblem::NotFinite`] / [`ConfigProblem::NotPositive`]);
/// - `non_negative a.b;` finite and >= 0 ([`ConfigProblem::NotFinite`] / [`ConfigProblem::Negative`]);
/// - `finite a.b;` every element of an array finite ([`ConfigProblem::NotFinite`]);
/// - `holds a.b if CONDITION;` [`ConfigProblem::Inconsistent`] unless the condition holds;
///   the condition's text is the rule's requirement.
///
/// It generates [`RULES`] and `check_rules`, which checks them in order and returns the
/// first broken one.
macro_rules! config_rules {
    (
        let $pat:pat = $cfg:ident;
        $( $kind:ident $first:ident $(. $rest:ident)* $(if $cond:expr)? ; )*
    ) => {
        /// Every rule [`ControllerConfig::validate`] checks, in order: the field (its dotted
        /// path, generated from the field access) and what it requires (for the schema,
        /// `host-sim config schema`).
        pub const RULES: &[Rule] = &[$(
            Rule {
                field: concat!(stringify!($first) $(, ".", stringify!($rest))*),
                requirement: config_rules!(@requirement $kind $(, $cond)?),
            },
        )*];

        fn check_rules($cfg: &ControllerConfig) -> Result<(), ConfigError> {
            let $pat = $cfg;
            $(
                config_rules!(
                    @check $kind,
                    concat!(stringify!($first) $(, ".", stringify!($rest))*),
                    ($first $(. $rest)*)
                    $(, $cond)?
                )?;
            )*
            Ok(())
        }
    };
    (@requirement positive) => { POSITIVE };
    (@requirement non_negative) => { NON_NEGATIVE };
    (@requirement finite) => { FINITE };
    (@requirement holds, $cond:expr) => { stringify!($cond) };
    (@check positive, $path:expr, ($($v:tt)*)) => { check($path, num($($v)*), true) };
    (@check non_negative, $path:expr, ($($v:tt)*)) => { check($path, num($($v)*), false) };
    (@check finite, $path:expr, ($($v:tt)*)) => {
        if all_finite($($v)*) {
            Ok(())
        } else {
            Err(ConfigError {
                field: $path,
                problem: ConfigProblem::NotFinite,
                requirement: FINITE,
            })
        }
    };
    (@check holds, $path:expr, ($($v:tt)*), $cond:expr) => {
        require($path, stringify!($cond), $cond)
    };
}

/// One rule of the configuration ([`RULES`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rule {
    /// Dotted path of the field the rule names (as in [`ConfigError::field`]).
    pub field: &'static str,
    /// What it requires: "finite, > 0", "finite, >= 0", "finite (every element)", or the
    /// condition, in the configuration's field names.
    pub requirement: &'static str,
}

/// The image point is finite and inside the field of view.
fn in_view(point: [f32; 2], m: &MeasurementLimits) -> bool {
    point.iter().all(|v| v.is_finite())
        && libm::fabsf(point[0]) < m.half_fov_x
        && libm::fabsf(point[1]) < m.half_fov_y
}

/// The largest trim pitch or angle of attack over the gain schedule's nodes, rad
/// (interpolated trims lie between the nodes').
pub fn largest_schedule_trim_angle_rad() -> f32 {
    let mut trim = 0.0;
    for row in &gains::SCHEDULE {
        for d in row {
            trim = max_to(trim, libm::fabsf(d.trim.theta_rad));
            trim = max_to(trim, libm::fabsf(d.trim.alpha_rad));
        }
    }
    trim
}

/// Every channel's limits are finite with min < max.
fn ordered(a: &ActuatorLimits) -> bool {
    a.min
        .iter()
        .zip(a.max)
        .all(|(lo, hi)| lo.is_finite() && hi.is_finite() && *lo < hi)
}

/// Every surface's rate limit is finite and positive.
fn rates_positive(a: &ActuatorLimits) -> bool {
    a.rate_radps.iter().all(|r| r.is_finite() && *r > 0.0)
}

/// Largest angular bias the estimator's consider term takes, rad (11°): its error is the
/// angle times the depth, a small-angle statement.
pub const MAX_BEARING_BIAS_SIGMA_RAD: f32 = 0.2;

/// Each angular bias sigma is finite, at least 0 and at most [`MAX_BEARING_BIAS_SIGMA_RAD`].
fn bearing_bias_bounded(e: &EstimatorConfig) -> bool {
    e.bearing_bias_sigma_rad
        .iter()
        .all(|b| (0.0..=MAX_BEARING_BIAS_SIGMA_RAD).contains(b))
}

/// Every channel's trim command lies inside its limits.
fn holds_trim(a: &ActuatorLimits) -> bool {
    let trim = trim_command();
    a.min
        .iter()
        .zip(a.max)
        .zip(trim)
        .all(|((lo, hi), t)| *lo <= t && t <= hi)
}

/// The gross-mass factor below which the refuelling procedure flies its light design:
/// midway between the two designs' masses ([`gains::REFUEL_LIGHT_MASS_FACTOR`] and 1), where
/// either design's model is as far from the aircraft as the other's.
pub const LIGHT_DESIGN_BELOW_MASS_FACTOR: f32 = 0.5 * (gains::REFUEL_LIGHT_MASS_FACTOR + 1.0);

/// The smallest gross-mass factor accepted: well below any airframe of the type (an F-16C
/// without fuel is about 0.96 of the design's 20,500 lb: `docs/models.md`, "Receiver plant
/// dispersions"); a value under it is a unit or entry mistake.
pub const MIN_MASS_FACTOR: f32 = 0.5;
/// The largest gross-mass factor accepted: above any airframe of the type (its maximum
/// take-off mass, 37,500 lb, is about 1.83 of the design's).
pub const MAX_MASS_FACTOR: f32 = 2.5;

/// One hour, s: the longest dwell, timeout or limit a configuration may give.
pub const HOUR_S: f32 = 3600.0;
/// One day, s: the longest sortie budget.
pub const DAY_S: f32 = 86_400.0;

config_rules! {
    let ControllerConfig {
        procedure: _,
        law: _,
        ibvs,
        pbvs,
        velocity_limits,
        camera,
        probe_tip_body_m,
        measurement,
        nav_envelope,
        modes,
        actuators,
        integrator_limit_m,
        nav_latency_steps,
        mass_factor,
        refuelling,
        estimator,
        inner_loop: _,
        attitude,
    } = cfg;
    positive ibvs.k1_mps;
    positive ibvs.k2_mps;
    positive ibvs.k3_per_s;
    non_negative ibvs.k4_mps;
    non_negative ibvs.k5_mps;
    holds ibvs.max_cartesian_gain_per_s if ibvs.max_cartesian_gain_per_s > 0.0;
    positive pbvs.k_lat_per_s;
    positive pbvs.k_vert_per_s;
    positive pbvs.k_close_per_s;
    non_negative pbvs.k_slow_lat_per_s;
    non_negative pbvs.k_slow_vert_per_s;
    positive velocity_limits.min_closing_mps;
    positive velocity_limits.max_closing_mps;
    positive velocity_limits.max_lateral_mps;
    positive velocity_limits.max_vertical_mps;
    positive velocity_limits.max_accel_mps2;
    holds velocity_limits.min_closing_mps
        if velocity_limits.min_closing_mps <= velocity_limits.max_closing_mps;
    finite camera.position_body_m;
    finite probe_tip_body_m;
    holds camera.pitch_down_rad if libm::fabsf(camera.pitch_down_rad) <= SIN_COS_MAX_RAD;
    positive measurement.max_depth_m;
    holds measurement.max_depth_m if measurement.max_depth_m <= 1000.0;
    positive measurement.half_fov_x;
    positive measurement.half_fov_y;
    holds ibvs.convergence_point if in_view(ibvs.convergence_point, measurement);
    positive nav_envelope.max_angle_rad;
    positive nav_envelope.max_bank_rad;
    positive nav_envelope.max_sideslip_rad;
    positive nav_envelope.max_speed_mps;
    positive nav_envelope.max_rate_radps;
    // Every angle of the step's trigonometry (`num::sin_cos`) stays within its range, at
    // every trim of the gain schedule.
    holds nav_envelope.max_angle_rad
        if nav_envelope.max_angle_rad + largest_schedule_trim_angle_rad() <= SIN_COS_MAX_RAD;
    holds nav_envelope.max_bank_rad if nav_envelope.max_bank_rad <= SIN_COS_MAX_RAD;
    holds nav_envelope.max_sideslip_rad if nav_envelope.max_sideslip_rad <= SIN_COS_MAX_RAD;
    positive modes.terminal_depth_m;
    positive modes.terminal_max_offset_m;
    positive modes.terminal_overshoot_m;
    positive modes.terminal_timeout_s;
    holds modes.terminal_timeout_s if modes.terminal_timeout_s < HOUR_S;
    non_negative modes.breakaway_aft_mps;
    non_negative modes.breakaway_down_mps;
    non_negative modes.breakaway_throttle_cut;
    holds modes.breakaway_down_mps
        if modes.breakaway_down_mps <= velocity_limits.max_vertical_mps;
    positive modes.overspeed_mps;
    positive modes.breakaway_accel_mps2;
    positive modes.terminal_accel_mps2;
    positive modes.drogue_rate_filter;
    holds modes.drogue_rate_filter if modes.drogue_rate_filter <= 1.0;
    holds modes.overspeed_mps if modes.overspeed_mps > velocity_limits.max_closing_mps;
    holds modes.breakaway_aft_mps if modes.breakaway_aft_mps <= velocity_limits.max_closing_mps;
    holds actuators.min if ordered(actuators);
    holds actuators.max if holds_trim(actuators);
    holds actuators.rate_radps if rates_positive(actuators);
    positive integrator_limit_m;
    holds nav_latency_steps if *nav_latency_steps <= MAX_NAV_LATENCY_STEPS;
    holds mass_factor if (MIN_MASS_FACTOR..=MAX_MASS_FACTOR).contains(mass_factor);
    positive estimator.drogue_time_constant_s;
    positive estimator.drogue_accel_psd_m2ps3;
    positive estimator.drogue_fwd_time_constant_s;
    positive estimator.offset_noise_m;
    positive estimator.depth_noise_m;
    positive estimator.initial_velocity_sigma_mps;
    positive estimator.gate_sigmas;
    positive estimator.tip_sight_tolerance;
    positive estimator.tip_sight_filter;
    positive estimator.mean_time_constant_s;
    positive estimator.activity_time_constant_s;
    non_negative estimator.drogue_fwd_accel_psd_m2ps3;
    non_negative estimator.offset_noise_per_m;
    non_negative estimator.depth_noise_per_m2;
    holds estimator.tip_sight_filter if estimator.tip_sight_filter <= 1.0;
    holds estimator.bearing_bias_sigma_rad if bearing_bias_bounded(estimator);
    // Time constants of at least a control period (the discrete models' poles stay away
    // from zero and the averages from a single step).
    holds estimator.drogue_time_constant_s
        if estimator.drogue_time_constant_s >= gains::CONTROL_PERIOD_S;
    holds estimator.drogue_fwd_time_constant_s
        if estimator.drogue_fwd_time_constant_s >= gains::CONTROL_PERIOD_S;
    holds estimator.activity_time_constant_s
        if estimator.activity_time_constant_s >= gains::CONTROL_PERIOD_S;
    holds estimator.mean_time_constant_s
        if estimator.mean_time_constant_s >= gains::CONTROL_PERIOD_S;
    non_negative estimator.nav_bias_time_constant_s;
    holds estimator.nav_bias_time_constant_s
        if estimator.nav_bias_time_constant_s >= gains::CONTROL_PERIOD_S
            || estimator.nav_bias_time_constant_s == 0.0;
    positive refuelling.station_depth_m;
    positive refuelling.station_gain_per_s;
    positive refuelling.station_max_speed_mps;
    non_negative refuelling.station_integral_gain_per_s2;
    non_negative refuelling.station_max_integral_mps;
    positive refuelling.station_offset_tol_m;
    positive refuelling.rough_air_station_offset_tol_m;
    positive refuelling.station_clear_offset_m;
    positive refuelling.station_depth_tol_m;
    positive refuelling.station_overrun_m;
    positive refuelling.station_drogue_speed_tol_mps;
    positive refuelling.station_relative_speed_tol_mps;
    positive refuelling.track_gain_per_s;
    positive refuelling.max_correction_mps;
    positive refuelling.track_accel_mps2;
    positive refuelling.contact_speed_mps;
    positive refuelling.rough_air_drogue_speed_mps;
    positive refuelling.rough_air_contact_speed_mps;
    positive refuelling.abort_offset_m;
    holds refuelling.station_clear_offset_m
        if refuelling.station_clear_offset_m < refuelling.abort_offset_m;
    positive refuelling.commit_depth_m;
    positive refuelling.gate_radius_m;
    positive refuelling.late_gate_radius_m;
    positive refuelling.late_gate_final_radius_m;
    positive refuelling.late_gate_taper_m;
    positive refuelling.late_gate_depth_m;
    non_negative refuelling.late_gate_min_depth_m;
    positive refuelling.gate_max_horizon_s;
    positive refuelling.capture_timeout_s;
    positive refuelling.capture_min_time_to_go_s;
    positive refuelling.overshoot_m;
    positive refuelling.capture_min_closing_mps;
    holds refuelling.capture_min_closing_mps
        if refuelling.capture_min_closing_mps < refuelling.contact_speed_mps
            && refuelling.capture_min_closing_mps < refuelling.rough_air_contact_speed_mps;
    positive refuelling.missed_aft_mps;
    positive refuelling.missed_clear_s;
    positive refuelling.missed_accel_mps2;
    positive refuelling.reacquire_limit_s;
    positive refuelling.sortie_budget_s;
    non_negative refuelling.station_dwell_s;
    non_negative refuelling.feedforward_lead_s;
    non_negative refuelling.feedforward_gain;
    non_negative refuelling.gate_sigmas;
    non_negative refuelling.missed_down_mps;
    non_negative refuelling.forward_lag_s;
    holds refuelling.forward_lag_s if refuelling.forward_lag_s <= 10.0;
    non_negative refuelling.stop_clearance_m;
    holds refuelling.feedforward_lead_s if refuelling.feedforward_lead_s <= 5.0;
    non_negative estimator.drogue_swing_period_s;
    non_negative estimator.drogue_swing_damping_ratio;
    holds estimator.drogue_swing_damping_ratio if estimator.drogue_swing_damping_ratio < 1.0;
    positive estimator.drogue_speed_floor_mps;
    non_negative estimator.drogue_swing_period_exponent;
    holds estimator.drogue_swing_period_exponent
        if estimator.drogue_swing_period_exponent <= 1.0;
    positive estimator.drogue_accel_time_constant_s;
    holds estimator.drogue_accel_time_constant_s
        if estimator.drogue_accel_time_constant_s >= gains::CONTROL_PERIOD_S;
    // The swing's phase over the lead within a quarter swing (and `sin_cos`'s range).
    holds refuelling.feedforward_lead_s
        if refuelling.feedforward_lead_s * 2.0 * core::f32::consts::PI
            <= crate::estimator::MAX_SWING_LEAD_RAD * estimator.drogue_swing_period_s
            || estimator.drogue_swing_period_s == 0.0;
    holds refuelling.gate_max_horizon_s
        if refuelling.gate_max_horizon_s
            <= crate::num::EXP_NEG_MAX * estimator.drogue_time_constant_s;
    holds refuelling.contact_speed_mps
        if refuelling.contact_speed_mps <= velocity_limits.max_closing_mps;
    holds refuelling.rough_air_contact_speed_mps
        if refuelling.rough_air_contact_speed_mps <= velocity_limits.max_closing_mps;
    holds refuelling.missed_aft_mps
        if refuelling.missed_aft_mps <= velocity_limits.max_closing_mps;
    holds refuelling.missed_down_mps
        if refuelling.missed_down_mps <= velocity_limits.max_vertical_mps;
    holds refuelling.late_gate_final_radius_m
        if refuelling.late_gate_final_radius_m <= refuelling.late_gate_radius_m;
    holds refuelling.commit_depth_m if refuelling.commit_depth_m < refuelling.station_depth_m;
    // The gate lies where a no-go still stops short of the plane, at either closing speed:
    // inside the station's overrun limit (before any approach is cleared) it would be
    // passed unawares.
    holds refuelling.station_overrun_m
        if refuelling.station_depth_m - refuelling.station_overrun_m
            > crate::procedure::commit_depth(refuelling.contact_speed_mps, refuelling)
            && refuelling.station_depth_m - refuelling.station_overrun_m
                > crate::procedure::commit_depth(
                    refuelling.rough_air_contact_speed_mps,
                    refuelling,
                );
    holds refuelling.station_overrun_m
        if refuelling.station_overrun_m > refuelling.station_depth_tol_m;
    // The depth hold's largest speed run on over the forward loop's lag stays within the
    // station's overrun limit: the receiver stops on the station, not through it.
    holds refuelling.station_max_speed_mps
        if refuelling.station_max_speed_mps * refuelling.forward_lag_s
            <= refuelling.station_overrun_m;
    holds refuelling.max_attempts if refuelling.max_attempts >= 1;
    holds refuelling.feedforward_gain if refuelling.feedforward_gain <= 1.0;
    holds refuelling.station_dwell_s if refuelling.station_dwell_s < HOUR_S;
    holds refuelling.capture_timeout_s if refuelling.capture_timeout_s < HOUR_S;
    holds refuelling.missed_clear_s if refuelling.missed_clear_s < HOUR_S;
    holds refuelling.reacquire_limit_s if refuelling.reacquire_limit_s < HOUR_S;
    holds refuelling.sortie_budget_s if refuelling.sortie_budget_s < DAY_S;
    positive attitude.pitch_time_constant_s;
    positive attitude.roll_time_constant_s;
    positive attitude.flight_path_lag_s;
    positive attitude.engine_time_constant_s;
    positive attitude.throttle_accel_mps2;
    positive attitude.vertical_bandwidth_radps;
    positive attitude.lateral_bandwidth_radps;
    positive attitude.forward_bandwidth_radps;
    positive attitude.damping;
    positive attitude.max_bank_rad;
    positive attitude.max_pitch_offset_rad;
    // The attitude loop's time constants of at least a control period (its discrete thrust
    // model's pole away from zero) and under a minute (a slower one is no autopilot).
    holds attitude.engine_time_constant_s
        if attitude.engine_time_constant_s >= gains::CONTROL_PERIOD_S
            && attitude.engine_time_constant_s <= 60.0;
    holds attitude.pitch_time_constant_s if attitude.pitch_time_constant_s <= 60.0;
    holds attitude.roll_time_constant_s if attitude.roll_time_constant_s <= 60.0;
    holds attitude.flight_path_lag_s if attitude.flight_path_lag_s <= 60.0;
    // Bandwidths below the discrete loop's Nyquist tenth (the closed form is continuous).
    holds attitude.vertical_bandwidth_radps
        if attitude.vertical_bandwidth_radps <= 0.1 * core::f32::consts::PI / gains::CONTROL_PERIOD_S;
    holds attitude.lateral_bandwidth_radps
        if attitude.lateral_bandwidth_radps <= 0.1 * core::f32::consts::PI / gains::CONTROL_PERIOD_S;
    holds attitude.forward_bandwidth_radps
        if attitude.forward_bandwidth_radps <= 0.1 * core::f32::consts::PI / gains::CONTROL_PERIOD_S;
    holds attitude.damping if attitude.damping <= 2.0;
    // Bank and pitch setpoints inside the navigation envelope (the receiver flown to a
    // setpoint the envelope rejects would break away on its own navigation).
    holds attitude.max_bank_rad if attitude.max_bank_rad < nav_envelope.max_bank_rad;
    holds attitude.max_pitch_offset_rad
        if attitude.max_pitch_offset_rad < nav_envelope.max_angle_rad;
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

    /// The attitude-command loop, when this configuration flies through the aircraft's
    /// autopilot ([`InnerLoop::Attitude`]); `None` when it flies the surfaces.
    pub fn autopilot_loop(&self) -> Option<AttitudeLoopConfig> {
        (self.inner_loop == InnerLoop::Attitude).then_some(self.attitude)
    }

    /// Checks every value against [`RULES`], in order; the first rule broken is returned.
    pub fn validate(&self) -> Result<(), ConfigError> {
        check_rules(self)
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

    /// The field, problem and requirement of `edit`'s rejection (`None`: accepted).
    fn rejection(
        edit: impl FnOnce(&mut ControllerConfig),
    ) -> Option<(&'static str, ConfigProblem, &'static str)> {
        let mut c = ControllerConfig::default();
        edit(&mut c);
        c.validate()
            .err()
            .map(|e| (e.field, e.problem, e.requirement))
    }

    #[test]
    fn default_and_paper_are_valid() {
        assert_eq!(ControllerConfig::default().validate(), Ok(()));
        assert_eq!(ControllerConfig::paper().validate(), Ok(()));
    }

    #[test]
    fn names_the_bad_field_its_problem_and_the_rule() {
        use ConfigProblem::*;
        assert_eq!(
            rejection(|c| c.ibvs.k3_per_s = 0.0),
            Some(("ibvs.k3_per_s", NotPositive, "finite, > 0"))
        );
        assert_eq!(
            rejection(|c| c.pbvs.k_slow_lat_per_s = f32::NAN),
            Some(("pbvs.k_slow_lat_per_s", NotFinite, "finite, >= 0"))
        );
        assert_eq!(
            rejection(|c| c.velocity_limits.min_closing_mps = 5.0),
            Some((
                "velocity_limits.min_closing_mps",
                Inconsistent,
                "velocity_limits.min_closing_mps <= velocity_limits.max_closing_mps"
            ))
        );
        assert_eq!(
            rejection(|c| c.actuators.max[1] = 0.01),
            Some(("actuators.max", Inconsistent, "holds_trim(actuators)"))
        );
        assert_eq!(
            rejection(|c| c.actuators.min[0] = f32::NAN),
            Some(("actuators.min", Inconsistent, "ordered(actuators)"))
        );
        assert_eq!(
            rejection(|c| c.modes.breakaway_down_mps = c.velocity_limits.max_vertical_mps + 0.1)
                .map(|r| (r.0, r.1)),
            Some(("modes.breakaway_down_mps", Inconsistent))
        );
        assert_eq!(
            rejection(|c| c.measurement.max_depth_m = f32::MAX),
            Some((
                "measurement.max_depth_m",
                Inconsistent,
                "measurement.max_depth_m <= 1000.0"
            ))
        );
        assert_eq!(
            rejection(|c| c.modes.terminal_accel_mps2 = 0.0),
            Some(("modes.terminal_accel_mps2", NotPositive, "finite, > 0"))
        );
        assert_eq!(
            rejection(|c| c.modes.drogue_rate_filter = f32::INFINITY),
            Some(("modes.drogue_rate_filter", NotFinite, "finite, > 0"))
        );
        assert_eq!(
            rejection(|c| c.modes.drogue_rate_filter = 1.5),
            Some((
                "modes.drogue_rate_filter",
                Inconsistent,
                "modes.drogue_rate_filter <= 1.0"
            ))
        );
        assert_eq!(rejection(|c| c.modes.drogue_rate_filter = 1.0), None);
        assert_eq!(
            rejection(|c| c.modes.breakaway_down_mps = -1.0),
            Some(("modes.breakaway_down_mps", Negative, "finite, >= 0"))
        );
        assert_eq!(
            rejection(|c| c.camera.position_body_m[2] = f32::INFINITY),
            Some((
                "camera.position_body_m",
                NotFinite,
                "finite (every element)"
            ))
        );
        assert_eq!(
            rejection(|c| c.integrator_limit_m = -1.0),
            Some(("integrator_limit_m", NotPositive, "finite, > 0"))
        );
        assert_eq!(
            rejection(|c| c.refuelling.max_attempts = 0),
            Some((
                "refuelling.max_attempts",
                Inconsistent,
                "refuelling.max_attempts >= 1"
            ))
        );
    }

    #[test]
    fn every_rule_names_a_dotted_path_and_holds_rules_quote_their_condition() {
        // (host-sim's schema tests break every rule's field through its path and check the
        // report names it.)
        for rule in RULES {
            let f = rule.field;
            assert!(
                !f.is_empty()
                    && !f.starts_with('.')
                    && !f.ends_with('.')
                    && f.chars().all(|c| c.is_ascii_lowercase()
                        || c.is_ascii_digit()
                        || c == '_'
                        || c == '.'),
                "{rule:?}"
            );
        }
        let late: heapless::Vec<_, 4> = RULES
            .iter()
            .filter(|r| r.field == "refuelling.late_gate_final_radius_m")
            .map(|r| r.requirement)
            .collect();
        assert_eq!(
            late.as_slice(),
            [
                "finite, > 0",
                "refuelling.late_gate_final_radius_m <= refuelling.late_gate_radius_m"
            ]
        );
    }

    #[test]
    fn the_error_says_the_rule_it_broke() {
        let e = ControllerConfig {
            integrator_limit_m: 0.0,
            ..ControllerConfig::default()
        }
        .validate()
        .err();
        let mut text = heapless::String::<160>::new();
        if let Some(e) = e {
            core::fmt::write(&mut text, format_args!("{e}")).ok();
        }
        assert_eq!(
            text.as_str(),
            "invalid controller configuration: integrator_limit_m is NotPositive (requires finite, > 0)"
        );
    }
}
