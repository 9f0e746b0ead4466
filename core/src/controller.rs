//! The controller: one fixed-period step from inputs to saturated actuator commands.
//!
//! [`Controller::step`] runs the data flow of the crate docs once. It is called every
//! [`crate::gains::CONTROL_PERIOD_S`] seconds; the gains are only valid at that period.
//!
//! Responses to bad input (specified in `docs/conventions.md`, "Input validation"):
//! - invalid measurement in approach: the last valid outer-loop command is held, for at most
//!   `modes.hold_limit_steps` consecutive steps, then breakaway (`MeasurementLost`);
//! - invalid navigation: the last valid navigation sample is used with the integrators frozen,
//!   for at most `modes.hold_limit_steps` steps, then breakaway (`NavLost`); a breakaway
//!   without valid navigation flies open loop: trim surfaces, throttle cut;
//! - every rejection is counted in [`Counters`] and reported in the step's output.
//!
//! In the blind phase (terminal) the camera is not used: the desired velocity slews at
//! `modes.terminal_accel_mps2` to the aim fixed at entry (`offset × a / depth` plus the
//! drogue's estimated velocity, closing at `a`; [`crate::mode`]); in breakaway at
//! `modes.breakaway_accel_mps2`; otherwise at `velocity_limits.max_accel_mps2`.
//!
//! The inner loops fly the gain schedule's design at the navigation's flight condition
//! ([`crate::schedule`]): the step checks the condition against the docking envelope every
//! step (outside it an engage is refused and an engaged receiver breaks away), and
//! [`Controller::follow_schedule`], which the flight loop calls after each step, loads the
//! design of a new condition for the next step. The envelope's slow edge, which follows the
//! configured gross mass, the step checks itself in standby (where an engage is decided);
//! engaged, the follow-up checks each new condition against it, one step after it arrives.
//!
//! Invariants: `step` never panics and returns finite commands inside the actuator limits
//! for every input (property-tested in `tests/properties.rs`).

use serde::{Deserialize, Serialize};

use crate::actuator::{ActuatorCommand, Saturation};
use crate::attitude::{
    AttitudeDesign, AttitudeInputs, AttitudeLoop, AttitudeSetpoint, Command, InnerLoop,
};
use crate::config::{
    ConfigError, ConfigProblem, ControllerConfig, LIGHT_DESIGN_BELOW_MASS_FACTOR, OuterLaw,
};
use crate::estimator::{
    DrogueEstimate, DrogueEstimator, EstimatorModel, TipFrame, TipGeometry, TipSight, TipSighting,
};
use crate::frames::{TargetEstimate, VelocityRe};
use crate::gains::CONTROL_PERIOD_S;
use crate::inner::TrimPoint;
use crate::inner::{Channel, ChannelGains, EngineEstimate};
use crate::kinematics::{lever_arm_lat, lever_arm_lon, point_velocity_tanker_mps};
use crate::measurement::{
    CameraMeasurement, FreezeDetector, ImageFeature, LimitBits, MeasurementError, SequenceCheck,
    SequenceTracker,
};
use crate::mode::{
    BreakawayReason, Mode, ModeInputs, ModeLimits, ModeMachine, ModeRequest, NoGoReason,
    RefuelInputs,
};
use crate::nav::{EnvelopeBits, NavError, NavSample};
use crate::num::{self, clamp_sym, max_to, min_to};
use crate::outer::{self, OuterOutput};
use crate::predictor::LatencyPredictor;
use crate::procedure::{self, Forward, Procedure};
use crate::schedule::{self, DesignPoint, FlightCondition, MassEnvelope, ScheduleError};

/// Everything the controller reads in one step.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ControllerInput {
    /// Latest frame from the drogue tracker.
    pub measurement: CameraMeasurement,
    /// Latest navigation sample (perturbations from trim).
    pub nav: NavSample,
    /// Probe contact discrete (coupling latched / fuel pressure).
    pub probe_contact: bool,
    /// Attitude-command inner loop: the aircraft's autopilot is in a mode that follows the
    /// flight computer's setpoints (ArduPlane GUIDED, PX4 OFFBOARD; from its heartbeat).
    /// Without it an engage is refused and an engaged receiver breaks away
    /// ([`BreakawayReason::AutopilotMode`]). The surface loops ignore it.
    pub autopilot_ready: bool,
    /// Operator request.
    pub request: ModeRequest,
}

/// Status bits of one step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StatusFlags(pub u16);

impl StatusFlags {
    /// No valid measurement this step: the paper's approach ran on its held outer-loop
    /// command, the refuelling procedure on its estimator's prediction.
    pub const MEASUREMENT_HELD: u16 = 1 << 0;
    /// The inner loops ran on the held navigation sample.
    pub const NAV_HELD: u16 = 1 << 1;
    /// Elevator, throttle, aileron, rudder saturated (bits 2..5, channel order).
    pub const SATURATED_ELEVATOR: u16 = 1 << 2;
    /// Throttle saturated.
    pub const SATURATED_THROTTLE: u16 = 1 << 3;
    /// Aileron saturated.
    pub const SATURATED_AILERON: u16 = 1 << 4;
    /// Rudder saturated.
    pub const SATURATED_RUDDER: u16 = 1 << 5;
    /// A longitudinal integrator was frozen by anti-windup.
    pub const LON_INTEGRATOR_FROZEN: u16 = 1 << 6;
    /// The lateral integrator was frozen by anti-windup.
    pub const LAT_INTEGRATOR_FROZEN: u16 = 1 << 7;
    /// An engage request was refused (no valid measurement or navigation).
    pub const ENGAGE_REFUSED: u16 = 1 << 8;
    /// A computed command was not finite and was replaced by trim (must never happen).
    pub const NON_FINITE_COMMAND: u16 = 1 << 9;
    /// Breakaway without navigation: open-loop command.
    pub const OPEN_LOOP: u16 = 1 << 10;
    /// Attitude-command loop: the pitch setpoint was limited this step.
    pub const SATURATED_PITCH: u16 = 1 << 11;
    /// Attitude-command loop: the bank setpoint was limited this step.
    pub const SATURATED_BANK: u16 = 1 << 12;

    /// True when every bit of `mask` is set.
    pub fn contains(self, mask: u16) -> bool {
        self.0 & mask == mask
    }
}

/// Running counts since construction (saturating). Nothing is rejected without a count.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Counters {
    /// Steps run.
    pub steps: u32,
    /// Frames that passed validation.
    pub frames_valid: u32,
    /// Frames the camera numbered that never arrived (sequence gaps).
    pub frames_dropped: u32,
    /// [`MeasurementError::NotTracked`] frames.
    pub not_tracked: u32,
    /// [`MeasurementError::NonFinite`] frames.
    pub non_finite: u32,
    /// [`MeasurementError::DepthNotPositive`] frames.
    pub depth_not_positive: u32,
    /// [`MeasurementError::DepthTooLarge`] frames.
    pub depth_too_large: u32,
    /// [`MeasurementError::OutsideFieldOfView`] frames.
    pub outside_fov: u32,
    /// [`MeasurementError::Repeated`] frames.
    pub repeated: u32,
    /// [`MeasurementError::OutOfOrder`] frames.
    pub out_of_order: u32,
    /// [`MeasurementError::Frozen`] frames.
    pub frozen: u32,
    /// [`NavError::NonFinite`] samples.
    pub nav_non_finite: u32,
    /// [`NavError::OutsideEnvelope`] samples.
    pub nav_outside_envelope: u32,
    /// Steps whose latest valid navigation put the flight condition outside the docking
    /// envelope ([`ControllerOutput::envelope_error`]).
    pub outside_docking_envelope: u32,
    /// Steps flagged [`StatusFlags::MEASUREMENT_HELD`].
    pub measurement_held_steps: u32,
    /// Engaged steps flown on a held navigation sample.
    pub nav_held_steps: u32,
    /// Engage requests refused.
    pub engage_refused: u32,
    /// Steps with at least one actuator saturated.
    pub saturated_steps: u32,
    /// Steps with at least one integrator frozen by anti-windup.
    pub integrator_frozen_steps: u32,
    /// Steps where a computed command was not finite (replaced by trim).
    pub non_finite_commands: u32,
    /// Valid frames the drogue estimator's innovation gate rejected (refuelling).
    pub estimator_rejected: u32,
    /// Restarts of the drogue estimator from a frame after rejections or a non-finite update.
    pub estimator_restarts: u32,
    /// Probe-tip sightings rejected (not finite, or too far from where the geometry puts it).
    pub tip_sight_rejected: u32,
    /// Probe-tip sightings averaged into the learned tip ([`Controller::probe_tip_image`]).
    pub tip_sight_used: u32,
    /// Valid frames without the probe tip's marker although the configured geometry puts the
    /// tip in the camera's view (the learned tip is held).
    pub tip_sight_missing: u32,
}

impl Counters {
    fn count_measurement(&mut self, e: MeasurementError) {
        let c = match e {
            MeasurementError::NotTracked => &mut self.not_tracked,
            MeasurementError::NonFinite => &mut self.non_finite,
            MeasurementError::DepthNotPositive => &mut self.depth_not_positive,
            MeasurementError::DepthTooLarge => &mut self.depth_too_large,
            MeasurementError::OutsideFieldOfView => &mut self.outside_fov,
            MeasurementError::Repeated => &mut self.repeated,
            MeasurementError::OutOfOrder => &mut self.out_of_order,
            MeasurementError::Frozen => &mut self.frozen,
        };
        *c = c.saturating_add(1);
    }
}

/// Adds one to `c` (saturating) when `when`, without a branch.
#[inline(always)]
fn bump(c: &mut u32, when: bool) {
    *c = c.saturating_add(u32::from(when));
}

/// Everything the controller produces in one step.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ControllerOutput {
    /// The command: saturated absolute surface and throttle commands, or attitude and
    /// throttle setpoints for the autopilot (as configured: `inner_loop`).
    pub command: Command,
    /// Mode after this step.
    pub mode: Mode,
    /// Why, when the mode is breakaway.
    pub breakaway_reason: Option<BreakawayReason>,
    /// Status bits.
    pub status: StatusFlags,
    /// This step's measurement rejection, if any.
    pub measurement_error: Option<MeasurementError>,
    /// This step's navigation rejection, if any.
    pub nav_error: Option<NavError>,
    /// Desired camera velocity relative to the drogue that the inner loops tracked, `re` axes.
    pub v_des: VelocityRe,
    /// Where the controller believes the drogue is: paper, the outer loop's latest target
    /// (held while the measurement is invalid); refuelling, the estimator's offset and depth.
    pub target: TargetEstimate,
    /// Steps run, this one included (saturates, like [`Counters::steps`]).
    pub step: u32,
    /// Refuelling: the approach being flown, 1-based (0 in standby and in the paper's
    /// procedure).
    pub attempt: u8,
    /// Refuelling: why the last approach was abandoned, until the next one starts.
    pub no_go: Option<NoGoReason>,
    /// Refuelling: the drogue estimator's belief (zero in the paper's procedure).
    pub estimate: DrogueEstimate,
    /// Refuelling: the go/no-go gate's predicted radial miss at the drogue plane plus its
    /// margin of standard deviations, m (approach and terminal; infinite elsewhere).
    pub predicted_miss_m: f32,
    /// Why the latest valid navigation's flight condition has no design (outside the
    /// docking envelope), when it has none: an engage is refused, an engaged receiver breaks
    /// away (`BreakawayReason::OutsideDockingEnvelope`).
    pub envelope_error: Option<ScheduleError>,
}

/// What the step needs from the configuration, derived once at construction (the step
/// never re-derives or re-validates anything that depends on the configuration alone).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Derived {
    /// The navigation envelope as bit patterns.
    envelope: EnvelopeBits,
    /// The measurement limits as bit patterns.
    measurement: LimitBits,
    /// The mode logic's limits at the control period.
    modes: ModeLimits,
    /// Largest change of the desired velocity per step, each axis, m/s.
    slew_step_mps: f32,
    /// The same in breakaway, m/s.
    breakaway_slew_step_mps: f32,
    /// The same in the blind phase, m/s.
    terminal_slew_step_mps: f32,
    /// The refuelling procedure's slew, per axis (right, down, forward), m/s per step.
    refuel_slew_step_mps: [f32; 3],
    /// The same in a missed approach, m/s.
    missed_slew_step_mps: f32,
    /// The navigation's velocity-bias estimate's memory, control periods
    /// (`nav_bias_time_constant_s / Ts`; 0: off).
    nav_bias_memory_steps: f32,
    /// Its memory at the first step learnt, control periods (the drogue estimator's
    /// velocity correlation time `drogue_time_constant_s`: before it, the estimated
    /// velocity says little).
    nav_bias_first_steps: f32,
    /// The drogue estimator's discrete model.
    estimator: EstimatorModel,
    /// The probe tip seen from the believed camera.
    tip: TipGeometry,
    /// The attitude-command loop's design at the scheduled trim's speed.
    attitude: AttitudeDesign,
    /// The docking envelope at the configured gross mass.
    docking_envelope: MassEnvelope,
}

impl Derived {
    fn new(cfg: &ControllerConfig) -> Result<Self, ConfigError> {
        // `validate` has accepted every limit as positive and finite already.
        let inconsistent = |field| ConfigError {
            field,
            problem: ConfigProblem::Inconsistent,
            requirement: "every limit finite, > 0",
        };
        Ok(Self {
            envelope: EnvelopeBits::new(&cfg.nav_envelope)
                .ok_or_else(|| inconsistent("nav_envelope"))?,
            measurement: LimitBits::new(&cfg.measurement)
                .ok_or_else(|| inconsistent("measurement"))?,
            modes: ModeLimits::for_procedure(
                &cfg.modes,
                &cfg.velocity_limits,
                cfg.procedure,
                &cfg.refuelling,
                Controller::PERIOD_S,
            ),
            slew_step_mps: cfg.velocity_limits.max_accel_mps2 * Controller::PERIOD_S,
            breakaway_slew_step_mps: cfg.modes.breakaway_accel_mps2 * Controller::PERIOD_S,
            terminal_slew_step_mps: cfg.modes.terminal_accel_mps2 * Controller::PERIOD_S,
            nav_bias_memory_steps: cfg.estimator.nav_bias_time_constant_s / Controller::PERIOD_S,
            nav_bias_first_steps: cfg.estimator.drogue_time_constant_s / Controller::PERIOD_S,
            refuel_slew_step_mps: {
                let track = cfg.refuelling.track_accel_mps2 * Controller::PERIOD_S;
                [
                    track,
                    track,
                    cfg.velocity_limits.max_accel_mps2 * Controller::PERIOD_S,
                ]
            },
            missed_slew_step_mps: cfg.refuelling.missed_accel_mps2 * Controller::PERIOD_S,
            estimator: EstimatorModel::new(
                &cfg.estimator,
                Controller::PERIOD_S,
                cfg.refuelling.feedforward_lead_s,
            ),
            tip: TipGeometry::new(
                &cfg.camera,
                cfg.probe_tip_body_m,
                schedule::DESIGN.trim.theta_rad,
            ),
            attitude: AttitudeDesign::new(
                &cfg.attitude,
                schedule::DESIGN.trim.speed_mps,
                Controller::PERIOD_S,
            ),
            docking_envelope: MassEnvelope::new(cfg.mass_factor),
        })
    }
}

/// The gain schedule's state: the design in use and the condition it was asked for.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Scheduled {
    /// The flight condition of the latest valid navigation sample.
    condition: FlightCondition,
    /// The condition of the design in use: when `condition` is another inside the
    /// envelope, the next [`Controller::follow_schedule`] loads its design.
    design_condition: FlightCondition,
    /// The trim of the design in use (the last condition inside the envelope).
    trim: TrimPoint,
    /// Why `condition` has no design, when it has none.
    error: Option<ScheduleError>,
    /// The condition the follow-up last checked against the docking envelope's slow edge.
    edge_condition: FlightCondition,
    /// `edge_condition` below the slow edge: [`ScheduleError::AngleOfAttackHigh`].
    slow_edge: Option<ScheduleError>,
}

impl Scheduled {
    /// The slow edge's verdict on `condition`: below it, [`ScheduleError::AngleOfAttackHigh`]
    /// (the grid's own limits are the step's).
    fn below_slow_edge(
        envelope: &MassEnvelope,
        condition: FlightCondition,
    ) -> Option<ScheduleError> {
        envelope
            .check(condition)
            .err()
            .filter(|e| *e == ScheduleError::AngleOfAttackHigh)
    }
}

/// Why [`Controller::reconfigure`] refused a configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ReconfigureError {
    /// Only a controller in standby takes a new configuration; this is the mode it was in.
    NotStandby(Mode),
    /// The configuration failed validation.
    Invalid(ConfigError),
}

impl core::fmt::Display for ReconfigureError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NotStandby(m) => write!(
                f,
                "configuration refused: the controller is in {m:?}, not Standby"
            ),
            Self::Invalid(e) => e.fmt(f),
        }
    }
}

impl core::error::Error for ReconfigureError {}

/// The docking controller.
#[derive(Debug, Clone)]
pub struct Controller {
    cfg: ControllerConfig,
    derived: Derived,
    lon: Channel<5, 2, 2>,
    engine: EngineEstimate,
    lat: Channel<5, 1, 2>,
    predict_lon: LatencyPredictor<4, 2, 2>,
    predict_lat: LatencyPredictor<5, 2, 2>,
    /// The attitude-command inner loop's state (`inner_loop = attitude`).
    attitude: AttitudeLoop,
    modes: ModeMachine,
    estimator: DrogueEstimator,
    tip_sight: TipSight,
    sequence: SequenceTracker,
    freeze: FreezeDetector,
    last_nav: NavSample,
    scheduled: Scheduled,
    last_outer: OuterOutput,
    v_cmd: VelocityRe,
    /// Refuelling: the closing speed of the approach flown (or last flown), m/s, chosen as
    /// it starts from the air the estimator measured ([`procedure::contact_speed`]).
    contact_mps: f32,
    /// Refuelling: the go/no-go gate's depth for that closing speed, where a no-go still
    /// stops short of the drogue plane ([`procedure::commit_depth`]), m.
    commit_depth_m: f32,
    /// Refuelling: the station's integral on the drogue's mean offset, `[right, down]`, m/s
    /// (reset at engage, kept over the attempts: what it takes out, the navigation's
    /// velocity bias, stays).
    station_integral_mps: [f32; 2],
    /// Refuelling: the navigation's velocity bias `[right, down, forward]` as the station
    /// estimates it from the drogue's mean estimated velocity, m/s (reset at engage, kept
    /// over the attempts; `EstimatorConfig::nav_bias_time_constant_s`).
    nav_bias_mps: [f32; 3],
    /// Refuelling: steps the bias has been learnt since engage.
    nav_bias_steps: u32,
    counters: Counters,
}

/// The inner loops' gains that configuration `cfg` flies from design `d`: each procedure its
/// own (`gains`), the refuelling procedure one of two by the receiver's gross mass, the light
/// airframe's below [`LIGHT_DESIGN_BELOW_MASS_FACTOR`]. The one choice of them, for the
/// controller and for the simulator's analysis of the loop it flies.
pub fn inner_gains<'a>(
    d: &'a DesignPoint,
    cfg: &ControllerConfig,
) -> (&'a ChannelGains<5, 2, 2>, &'a ChannelGains<5, 1, 2>) {
    match cfg.procedure {
        Procedure::Paper => (&d.lon, &d.lat),
        Procedure::Refuelling if cfg.mass_factor < LIGHT_DESIGN_BELOW_MASS_FACTOR => {
            (&d.refuel_light_lon, &d.refuel_light_lat)
        }
        Procedure::Refuelling => (&d.refuel_lon, &d.refuel_lat),
    }
}

impl Controller {
    /// Control period, s: the one the generated gains were synthesised for.
    pub const PERIOD_S: f32 = CONTROL_PERIOD_S;

    /// Builds a controller in standby from a validated configuration.
    pub fn new(cfg: ControllerConfig) -> Result<Self, ConfigError> {
        cfg.validate()?;
        let derived = Derived::new(&cfg)?;
        let d = &schedule::DESIGN;
        let u = d.trim.command();
        let rate = cfg.actuators.rate_radps;
        let mut c = Self {
            // Replaced by `set_design` below: one place builds the loops from a design.
            lon: Channel::new(&d.lon, &[[0.0; 5]; 2], [u[0], u[1]]),
            lat: Channel::new(&d.lat, &[[0.0; 5]; 1], [u[2], u[3]]),
            engine: EngineEstimate::new(d.engine),
            // The unmeasured states: lon [engine power (its own lag, no rate limit), elevator],
            // lat [aileron, rudder].
            predict_lon: LatencyPredictor::new(
                d.predict_lon,
                cfg.nav_latency_steps,
                [f32::INFINITY, rate[0] * CONTROL_PERIOD_S],
            ),
            predict_lat: LatencyPredictor::new(
                d.predict_lat,
                cfg.nav_latency_steps,
                [rate[1] * CONTROL_PERIOD_S, rate[2] * CONTROL_PERIOD_S],
            ),
            attitude: AttitudeLoop::default(),
            cfg,
            derived,
            modes: ModeMachine::default(),
            estimator: DrogueEstimator::default(),
            tip_sight: TipSight::new(&derived.tip),
            sequence: SequenceTracker::default(),
            freeze: FreezeDetector::default(),
            last_nav: NavSample::default(),
            scheduled: Scheduled {
                condition: FlightCondition::default(),
                design_condition: FlightCondition::default(),
                trim: d.trim,
                error: None,
                edge_condition: FlightCondition::default(),
                slow_edge: Scheduled::below_slow_edge(
                    &derived.docking_envelope,
                    FlightCondition::default(),
                ),
            },
            last_outer: OuterOutput::default(),
            v_cmd: VelocityRe::ZERO,
            contact_mps: cfg.refuelling.contact_speed_mps,
            commit_depth_m: procedure::commit_depth(
                cfg.refuelling.contact_speed_mps,
                &cfg.refuelling,
            ),
            station_integral_mps: [0.0; 2],
            nav_bias_mps: [0.0; 3],
            nav_bias_steps: 0,
            counters: Counters::default(),
        };
        c.set_design(d);
        Ok(c)
    }

    /// Replaces the configuration (the flight computer's configuration frame), in
    /// [`Mode::Standby`] only: the controller is rebuilt from `cfg` as [`Controller::new`]
    /// builds it, and keeps its [`Counters`] (nothing counted before is lost). Atomic: on any
    /// error the controller is unchanged and flies the configuration it had.
    pub fn reconfigure(&mut self, cfg: ControllerConfig) -> Result<(), ReconfigureError> {
        let mode = self.mode();
        if mode != Mode::Standby {
            return Err(ReconfigureError::NotStandby(mode));
        }
        let mut next = Self::new(cfg).map_err(ReconfigureError::Invalid)?;
        next.counters = self.counters;
        *self = next;
        Ok(())
    }

    /// Flies the design `d` from the next command on (the integrators, the engine estimate
    /// and the predictors' records carry over: they are perturbations from trim).
    fn set_design(&mut self, d: &DesignPoint) {
        let cfg = &self.cfg;
        // The point whose velocity the inner loops track: the camera in the paper's
        // procedure (its lever arm is where the paper's camera-position experiment acts), the
        // probe tip in the refuelling procedure (the point that must meet the drogue).
        let tracked = match cfg.procedure {
            Procedure::Paper => cfg.camera.position_body_m,
            Procedure::Refuelling => cfg.probe_tip_body_m,
        };
        let (lon, lat) = inner_gains(d, cfg);
        let u = d.trim.command();
        self.lon
            .set_design(lon, &lever_arm_lon(tracked, d.trim.theta_rad), [u[0], u[1]]);
        self.lat
            .set_design(lat, &lever_arm_lat(tracked), [u[2], u[3]]);
        self.engine.set_model(d.engine);
        self.predict_lon.set_model(d.predict_lon);
        self.predict_lat.set_model(d.predict_lat);
        self.derived.tip = TipGeometry::new(&cfg.camera, cfg.probe_tip_body_m, d.trim.theta_rad);
        self.derived.attitude =
            AttitudeDesign::new(&cfg.attitude, d.trim.speed_mps, Self::PERIOD_S);
        self.scheduled.trim = d.trim;
    }

    /// Follows the gain schedule: when the latest valid navigation sample put the flight
    /// condition somewhere new, checks it against the docking envelope's slow edge (the
    /// engaged step's verdict from the next step on) and, inside the grid, interpolates the
    /// design there and flies it from the next step on, with the drogue estimator's model of
    /// the hose's swing at that condition ([`EstimatorModel::at`]). Returns true when it loaded a
    /// design.
    ///
    /// Not part of [`Controller::step`]: the interpolation (every number of the design, a
    /// few thousand instructions) would sit on the control path's deadline for a condition
    /// that changes over tens of seconds. The flight loop calls it after each step, once the
    /// command is out (the firmware's control task, the simulator's flight computer), so a
    /// new condition is flown one step after it arrives. Until it is called the step flies
    /// the design it has; whether the condition is inside the envelope the step decides
    /// itself, every step.
    ///
    /// Never inlined: one copy in the binary, and a function of its own for the control
    /// task's static bound (its loops are declared by function).
    #[inline(never)]
    pub fn follow_schedule(&mut self) -> bool {
        let s = &mut self.scheduled;
        if s.condition != s.edge_condition {
            s.edge_condition = s.condition;
            s.slow_edge = Scheduled::below_slow_edge(&self.derived.docking_envelope, s.condition);
        }
        // Below the slow edge the grid still has a design, and it is flown (the trim held in
        // standby, a breakaway flown on it): the edge refuses the docking, not the flight.
        if schedule::check(s.condition).is_err() || s.condition == s.design_condition {
            return false;
        }
        match schedule::design_at(s.condition) {
            Ok(d) => {
                s.design_condition = s.condition;
                let condition = s.condition;
                self.set_design(&d);
                // The hose swings faster at a higher dynamic pressure: the feed-forward's
                // lead and the filter's process noise follow the condition with the gains.
                self.derived.estimator = EstimatorModel::at(
                    &self.cfg.estimator,
                    Self::PERIOD_S,
                    self.cfg.refuelling.feedforward_lead_s,
                    condition,
                );
                true
            }
            // The step checked the condition inside; not reached, and refused rather than
            // flown if it were.
            Err(_) => false,
        }
    }

    /// Why `condition` is outside the docking envelope, if it is: the grid's limits, and the
    /// slow edge (the configured gross mass's). In standby, where an engage is decided, the
    /// edge is checked on this very condition; engaged, the follow-up's verdict on the last
    /// condition it checked counts (a new one is checked one step after it arrives, as its
    /// design is loaded), which keeps the edge's check off the capture's dearest steps.
    ///
    /// Never inlined: its branches inside the step let the compiler merge control flow into
    /// a loop the static bound cannot take apart (a loop with several entries).
    #[inline(never)]
    fn envelope_error(&self, condition: FlightCondition) -> Option<ScheduleError> {
        if self.modes.mode() == Mode::Standby {
            self.derived.docking_envelope.check(condition).err()
        } else {
            schedule::check(condition)
                .err()
                .or(self.scheduled.slow_edge)
        }
    }

    /// The configuration in use.
    pub fn config(&self) -> &ControllerConfig {
        &self.cfg
    }

    /// Current mode.
    pub fn mode(&self) -> Mode {
        self.modes.mode()
    }

    /// Counters since construction.
    pub fn counters(&self) -> &Counters {
        &self.counters
    }

    /// Refuelling: the drogue estimator's model at the flight condition in use (the hose's
    /// swing there; [`EstimatorModel::at`]).
    pub fn drogue_model(&self) -> &EstimatorModel {
        &self.derived.estimator
    }

    /// Refuelling: the drogue estimator, its state and covariance (for the simulator's
    /// consistency measurements; the step's own use of it is unchanged by reading it).
    pub fn drogue_estimator(&self) -> &DrogueEstimator {
        &self.estimator
    }

    /// Refuelling: the probe tip's image point the drogue's offset is taken from, normalised
    /// `(x right, y down)`: the running average of the tip marker's sightings, inside the
    /// calibration window around the configured geometry's point (`docs/conventions.md`,
    /// "Endpoint aiming"); the geometry's point until the first sighting
    /// ([`Counters::tip_sight_used`] says how many it has seen). Kept across approaches and
    /// sorties (the camera has not moved); a reconfiguration starts it again from the new
    /// geometry.
    pub fn probe_tip_image(&self) -> [f32; 2] {
        self.tip_sight.image()
    }

    /// Refuelling: the navigation's velocity bias `[right, down, forward]` as the station
    /// has estimated it, m/s (zero before engage, under the paper's procedure, or with
    /// `estimator.nav_bias_time_constant_s` 0).
    pub fn nav_bias_mps(&self) -> [f32; 3] {
        self.nav_bias_mps
    }

    /// The drogue's RMS lateral speed as the estimator measures it, m/s: above
    /// `refuelling.rough_air_drogue_speed_mps` the air is rough (the approach's closing
    /// speed and the station's offset tolerance). It starts at the configured drogue PSD's
    /// level when the procedure engages (0.25 m/s with the defaults, rough) and settles to
    /// the air's own over `estimator.activity_time_constant_s`; it keeps its last value
    /// after a reset until the next engage.
    pub fn drogue_speed_rms_mps(&self) -> f32 {
        self.estimator.drogue_speed_rms_mps()
    }

    /// Integrator states `[lon down, lon forward, lat right]`, m.
    pub fn integrators_m(&self) -> [f32; 3] {
        let (lo, la) = (self.lon.integrators(), self.lat.integrators());
        [lo[0], lo[1], la[0]]
    }

    #[inline(always)]
    fn observe_measurement(
        &mut self,
        m: &CameraMeasurement,
    ) -> Result<ImageFeature, MeasurementError> {
        let checked = match self.sequence.observe(m.seq) {
            SequenceCheck::New { dropped } => {
                if dropped != 0 {
                    self.counters.frames_dropped =
                        self.counters.frames_dropped.saturating_add(dropped);
                }
                m.check(&self.derived.measurement).and_then(|f| {
                    self.freeze
                        .observe(f, self.cfg.measurement.frozen_frame_limit)
                })
            }
            SequenceCheck::Rejected(e) => Err(e),
        };
        match checked {
            Ok(_) => bump(&mut self.counters.frames_valid, true),
            Err(e) => self.counters.count_measurement(e),
        }
        checked
    }

    #[inline(always)]
    fn outer_law(&self, f: &ImageFeature) -> OuterOutput {
        let c = &self.cfg;
        match c.law {
            OuterLaw::Ibvs => outer::ibvs(f, &c.ibvs, &c.velocity_limits),
            OuterLaw::Pbvs => outer::pbvs(
                f,
                &self.last_nav,
                &outer::PbvsGeometry {
                    trim_pitch_rad: self.scheduled.trim.theta_rad,
                    ..c.pbvs_geometry()
                },
                &c.pbvs,
                &c.velocity_limits,
            ),
        }
    }

    /// The desired velocity relative to the drogue for the current mode, before slewing.
    #[inline(always)]
    fn mode_velocity(&self, est: &DrogueEstimate) -> VelocityRe {
        let md = &self.cfg.modes;
        let track = |fwd| {
            let feedforward = match fwd {
                Forward::Contact | Forward::Capture => self
                    .estimator
                    .drogue_velocity_ahead(&self.derived.estimator),
                Forward::Station => self.station_integral_mps,
                Forward::Clear { .. } => [0.0; 2],
            };
            let v = procedure::desired_velocity(
                est,
                feedforward,
                fwd,
                self.contact_mps,
                &self.cfg.refuelling,
                &self.cfg.velocity_limits,
            );
            // The inner loops hold the velocity the navigation reports: ask for the bias too.
            let b = &self.nav_bias_mps;
            VelocityRe {
                x_right_mps: v.x_right_mps + b[0],
                y_down_mps: v.y_down_mps + b[1],
                z_fwd_mps: v.z_fwd_mps + b[2],
            }
        };
        match self.modes.mode() {
            Mode::Standby | Mode::Docked => VelocityRe::ZERO,
            Mode::Approach if self.cfg.procedure == Procedure::Paper => self.last_outer.v_des,
            // Fixed at entry: aimed at the drogue, closing at the minimum speed.
            Mode::Terminal if self.cfg.procedure == Procedure::Paper => self.modes.terminal().aim,
            Mode::PreContact => track(Forward::Station),
            Mode::Approach => track(Forward::Contact),
            Mode::Terminal => track(Forward::Capture),
            // Clearing (descending) for the clearing time, and straight back on until the
            // tip is `stop_clearance_m` behind the plane; then back to the station.
            Mode::MissedApproach => {
                let descend = self.modes.mode_steps() < self.derived.modes.clear_steps();
                track(
                    if descend || est.depth_m < self.cfg.refuelling.stop_clearance_m {
                        Forward::Clear { descend }
                    } else {
                        Forward::Station
                    },
                )
            }
            Mode::Breakaway => VelocityRe {
                x_right_mps: 0.0,
                y_down_mps: md.breakaway_down_mps,
                z_fwd_mps: -md.breakaway_aft_mps,
            },
        }
    }

    /// Refuelling: the drogue estimator's step (predict with the probe tip's velocity
    /// `tip_mps` `[right, down, forward]`, correct with a valid frame, the drogue's offset
    /// taken from the probe tip's measured image point `probe_tip` when the frame carries it)
    /// and what the mode logic decides with. Before engage the "estimate" is the frame itself.
    #[inline(always)]
    fn observe_drogue(
        &mut self,
        feature: &Result<ImageFeature, MeasurementError>,
        probe_tip: Option<[f32; 2]>,
        tip_mps: [f32; 3],
    ) -> (RefuelInputs, Option<TargetEstimate>, Option<TipFrame>) {
        let nav = &self.last_nav;
        if feature.is_ok() {
            let sighting = self.tip_sight.observe(probe_tip, &self.cfg.estimator);
            let k = &mut self.counters;
            bump(&mut k.tip_sight_rejected, sighting == TipSighting::Rejected);
            bump(&mut k.tip_sight_used, sighting == TipSighting::Used);
            bump(
                &mut k.tip_sight_missing,
                sighting == TipSighting::None && self.derived.tip.tip_in_view(),
            );
        }
        let tip_image = self.tip_sight.image();
        let frame = feature.as_ref().ok().map(|f| TipFrame {
            drogue_from_tip_m: self.derived.tip.drogue_from_tip(
                [f.image_x, f.image_y],
                f.depth_m,
                [nav.lat.phi_rad, nav.lon.theta_rad, nav.lat.psi_rad],
                tip_image,
            ),
            camera_depth_m: f.depth_m,
        });
        let est = if self.estimator.started() {
            self.estimator.predict(tip_mps, &self.derived.estimator);
            if let Some(fr) = &frame {
                let c = self.estimator.correct(fr, &self.cfg.estimator);
                let k = &mut self.counters;
                bump(&mut k.estimator_rejected, c.rejected);
                bump(&mut k.estimator_restarts, c.restarted.is_some());
            }
            self.estimator.estimate()
        } else {
            frame.map_or_else(DrogueEstimate::default, |fr| {
                let [r, d, z] = fr.drogue_from_tip_m;
                DrogueEstimate {
                    offset_m: [r, d],
                    mean_offset_m: [r, d],
                    drogue_velocity_mps: [0.0; 3],
                    depth_m: z,
                }
            })
        };
        let closing_mps = est.closing_mps(tip_mps[2]);
        let predicted_miss_m = if matches!(self.modes.mode(), Mode::Approach | Mode::Terminal) {
            self.predicted_miss_m(&est, closing_mps, [tip_mps[0], tip_mps[1]])
        } else {
            f32::INFINITY
        };
        let target = frame.map(|_| TargetEstimate {
            right_m: est.offset_m[0],
            down_m: est.offset_m[1],
            depth_m: est.depth_m,
        });
        let inputs = RefuelInputs {
            estimate: est,
            tip_lateral_mps: [tip_mps[0], tip_mps[1]],
            drogue_speed_rms_mps: self.estimator.drogue_speed_rms_mps(),
            predicted_miss_m,
            closing_mps,
            commit_depth_m: self.commit_depth_m,
        };
        (inputs, target, frame)
    }

    /// The go/no-go gate's figure: the radial offset predicted at the drogue plane (horizon
    /// the time to go at the present closing speed, at most `gate_max_horizon_s`; the tip
    /// keeping its lateral velocity, no further correction) plus `gate_sigmas` standard
    /// deviations of the larger axis, m; `closing` the estimated closing speed, m/s, and
    /// `tip_lateral_mps` the tip's `[right, down]` velocity.
    #[inline(always)]
    fn predicted_miss_m(
        &self,
        est: &DrogueEstimate,
        closing: f32,
        tip_lateral_mps: [f32; 2],
    ) -> f32 {
        let rc = &self.cfg.refuelling;
        let to_go = max_to(est.depth_m, 0.0);
        // Not closing (or barely): the longest horizon. One division per step.
        let h = if to_go < closing * rc.gate_max_horizon_s {
            to_go / closing
        } else {
            rc.gate_max_horizon_s
        };
        let [a, b] = self
            .estimator
            .predict_offset(h, tip_lateral_mps, &self.derived.estimator);
        let mean = num::sqrt(a.mean_m * a.mean_m + b.mean_m * b.mean_m);
        let var = if a.variance_m2 >= b.variance_m2 {
            a.variance_m2
        } else {
            b.variance_m2
        };
        mean + rc.gate_sigmas * num::sqrt(max_to(var, 0.0))
    }

    /// The status bits of a step with something to flag, and the counts of it.
    #[inline(always)]
    fn flag_and_count(&mut self, sat: &Saturation, flags: [bool; 6]) -> u16 {
        let [held, nav_held, lon_frozen, lat_frozen, refused, open_loop] = flags;
        // `flag` is a single bit: the product is a shift, no branch.
        let bit = |on: bool, flag: u16| u16::from(on) * flag;
        let [s0, s1, s2, s3] = sat.side.map(|s| s != 0);
        // The saturation's slots are the surface loop's commands, or the attitude loop's
        // `[pitch, throttle, bank, -]`.
        let saturated = match self.cfg.inner_loop {
            InnerLoop::Surfaces => {
                bit(s0, StatusFlags::SATURATED_ELEVATOR)
                    | bit(s1, StatusFlags::SATURATED_THROTTLE)
                    | bit(s2, StatusFlags::SATURATED_AILERON)
                    | bit(s3, StatusFlags::SATURATED_RUDDER)
            }
            InnerLoop::Attitude => {
                bit(s0, StatusFlags::SATURATED_PITCH)
                    | bit(s1, StatusFlags::SATURATED_THROTTLE)
                    | bit(s2, StatusFlags::SATURATED_BANK)
            }
        };
        let bits = saturated
            | bit(held, StatusFlags::MEASUREMENT_HELD)
            | bit(nav_held, StatusFlags::NAV_HELD)
            | bit(lon_frozen, StatusFlags::LON_INTEGRATOR_FROZEN)
            | bit(lat_frozen, StatusFlags::LAT_INTEGRATOR_FROZEN)
            | bit(refused, StatusFlags::ENGAGE_REFUSED)
            | bit(sat.non_finite, StatusFlags::NON_FINITE_COMMAND)
            | bit(open_loop, StatusFlags::OPEN_LOOP);
        let c = &mut self.counters;
        bump(&mut c.measurement_held_steps, held);
        bump(&mut c.nav_held_steps, nav_held);
        bump(&mut c.engage_refused, refused);
        bump(&mut c.saturated_steps, saturated != 0);
        bump(&mut c.integrator_frozen_steps, lon_frozen || lat_frozen);
        bump(&mut c.non_finite_commands, sat.non_finite);
        bits
    }

    /// The surface inner loops (`inner`): the command, its saturation and whether each
    /// channel's integrators froze. `flags` are (open loop, integrate, bumpless engage).
    #[inline(always)]
    fn surface_loops(
        &mut self,
        mode: Mode,
        flags: (bool, bool, bool),
        x: (&[f32; 5], &[f32; 5]),
        v_des: &VelocityRe,
        tracked: (&[f32; 2], &[f32; 1]),
    ) -> (Command, Saturation, bool, bool) {
        let (open_loop, integrate, engage) = flags;
        let (x_lon, x_lat) = x;
        let trim = self.scheduled.trim.command();
        let requested = if mode == Mode::Standby {
            // Standby: integrators and engine model at zero, the trim commanded (the
            // refuelling procedure preloads its integrators at engage, below).
            self.lon.reset();
            self.lat.reset();
            self.engine.reset();
            self.predict_lon.reset();
            self.predict_lat.reset();
            trim
        } else if open_loop {
            [
                trim[0],
                trim[1] - self.cfg.modes.breakaway_throttle_cut,
                trim[2],
                trim[3],
            ]
        } else {
            // The state feedback acts on the (late) sample predicted over the INS latency;
            // the integrators and the mode logic read the sample itself (`predictor`).
            let [theta, v, alpha, q] = self
                .predict_lon
                .predict([x_lon[0], x_lon[1], x_lon[2], x_lon[3]]);
            // The actuators' deflections from the predictors' models of the commands sent
            // (longitudinal: engine, elevator; lateral: aileron, rudder; `gains`).
            let x_lon = [theta, v, alpha, q, x_lon[4]];
            let a_lon = [self.predict_lon.unmeasured()[1], 0.0];
            let x_lat = self.predict_lat.predict(*x_lat);
            let a_lat = self.predict_lat.unmeasured();
            if engage {
                // Bumpless engage (`inner`): the first engaged command is the Standby
                // command, the integrators taking up the receiver's offset from the design
                // trim.
                let lim = self.cfg.integrator_limit_m;
                self.lon.preload(&x_lon, &a_lon, lim);
                self.lat.preload(&x_lat, a_lat, lim);
            }
            let [e, th] = self.lon.control(&x_lon, &a_lon);
            let [a, r] = self.lat.control(&x_lat, a_lat);
            [e, th, a, r]
        };
        let (command, sat) = self.cfg.actuators.saturate(requested, trim);
        let du: [f32; 4] = core::array::from_fn(|i| command[i] - trim[i]);
        self.engine.advance(du[1]);
        self.predict_lon.record([du[0], du[1]]);
        self.predict_lat.record([du[2], du[3]]);
        let (lon_frozen, lat_frozen) = if integrate {
            let (ts, lim, s) = (Self::PERIOD_S, self.cfg.integrator_limit_m, sat.side);
            let (y_lon, y_lat) = tracked;
            let lon = self.lon.integrate(
                y_lon,
                &[v_des.y_down_mps, v_des.z_fwd_mps],
                &[s[0], s[1]],
                ts,
                lim,
            );
            let lat = self
                .lat
                .integrate(y_lat, &[v_des.x_right_mps], &[s[2], s[3]], ts, lim);
            (lon, lat)
        } else {
            (false, false)
        };
        (
            Command::Surfaces(ActuatorCommand::from_array(command)),
            sat,
            lon_frozen,
            lat_frozen,
        )
    }

    /// The attitude-command inner loop (`attitude`): the setpoint, its saturation (in the
    /// slots `[pitch, throttle, bank, -]`) and whether the longitudinal (pitch, throttle) or
    /// lateral (bank) integrators froze. `flags` as [`Controller::surface_loops`]'.
    #[inline(always)]
    fn attitude_loop(
        &mut self,
        mode: Mode,
        flags: (bool, bool, bool),
        v_des: &VelocityRe,
        tracked: (&[f32; 2], &[f32; 1]),
    ) -> (Command, Saturation, bool, bool) {
        let (open_loop, integrate, engage) = flags;
        let trim = &self.scheduled.trim;
        let nav = &self.last_nav;
        let level = |throttle| AttitudeSetpoint {
            roll_rad: 0.0,
            pitch_rad: trim.theta_rad,
            yaw_rad: nav.lat.psi_rad,
            throttle,
        };
        let mut sat = Saturation::default();
        let (setpoint, frozen) = if mode == Mode::Standby {
            // Standby: wings level at the trim pitch and throttle, integrators at zero.
            self.attitude.reset();
            (level(trim.throttle), [false; 3])
        } else if open_loop {
            let cut = trim.throttle - self.cfg.modes.breakaway_throttle_cut;
            let lim = &self.cfg.actuators;
            (level(max_to(cut, lim.min[1])), [false; 3])
        } else {
            let (y_lon, y_lat) = tracked;
            let inputs = AttitudeInputs {
                velocity_mps: [y_lon[0], y_lon[1], y_lat[0]],
                desired_mps: [v_des.y_down_mps, v_des.z_fwd_mps, v_des.x_right_mps],
                theta_rad: nav.lon.theta_rad,
                phi_rad: nav.lat.phi_rad,
                psi_rad: nav.lat.psi_rad,
            };
            let lim = self.cfg.integrator_limit_m;
            if engage {
                self.attitude.preload(&self.derived.attitude, &inputs, lim);
            }
            let a = &self.cfg.actuators;
            let out = self.attitude.step(
                &self.derived.attitude,
                &self.cfg.attitude,
                &inputs,
                (trim.theta_rad, trim.throttle),
                (a.min[1], a.max[1]),
                Self::PERIOD_S,
                lim,
                integrate,
            );
            let [p, t, b] = out.side;
            sat.side = [p, t, b, 0];
            sat.non_finite = out.non_finite;
            (out.setpoint, out.frozen)
        };
        (
            Command::Attitude(setpoint),
            sat,
            frozen[0] || frozen[1],
            frozen[2],
        )
    }

    /// Runs one control step. Never panics; the command is always finite and within limits.
    ///
    /// Bounded time: no loop depends on the data, nothing recurses, nothing allocates, and no
    /// library call remains on the IBVS path (`docs/benchmarks.md`, "Worst case").
    pub fn step(&mut self, input: &ControllerInput) -> ControllerOutput {
        let ts = Self::PERIOD_S;
        let c = &mut self.counters;
        c.steps = c.steps.saturating_add(1);

        // 1. Navigation: hold the last valid sample when this one is bad.
        let nav_error = input.nav.check(&self.derived.envelope).err();
        match nav_error {
            None => self.last_nav = input.nav,
            Some(NavError::NonFinite) => bump(&mut c.nav_non_finite, true),
            Some(NavError::OutsideEnvelope) => bump(&mut c.nav_outside_envelope, true),
        }
        let nav_valid = nav_error.is_none();
        if nav_valid {
            self.scheduled.condition = input.nav.condition;
        }
        // Judged every step on the latest valid condition, held or new: the follow-up's
        // verdict on the slow edge applies at once, also while the navigation is held.
        self.scheduled.error = self.envelope_error(self.scheduled.condition);
        let in_envelope = self.scheduled.error.is_none();
        let c = &mut self.counters;
        bump(&mut c.outside_docking_envelope, !in_envelope);
        let x_lon = self.last_nav.lon_design_state(self.engine.power_pct());
        let x_lat = self.last_nav.lat_design_state();

        // 2. Measurement, 3. outer loop: the paper's law (its output is kept, i.e. held, until
        // the next valid one), or the refuelling procedure's drogue estimator. The mode
        // logic's overspeed check uses the design output `C x` of the tracked point (the
        // camera's, or the probe tip's in the refuelling procedure), and so do the paper's
        // integrators; under the refuelling procedure the estimator and the integrators take
        // the probe tip's velocity by exact kinematics instead (the linear output is off by up
        // to 0.5 m/s while the receiver manoeuvres, which the estimator's drogue velocity
        // would inherit, and it turns the INS's attitude errors into a steady velocity error
        // the integrators cannot see; `kinematics::point_velocity_tanker_mps`).
        let feature = self.observe_measurement(&input.measurement);
        let paper = self.cfg.procedure == Procedure::Paper;
        let (y_lon, y_lat) = (self.lon.output(&x_lon), self.lat.output(&x_lat));
        let (refuel, target, frame, tracked) = if paper {
            let fresh = feature.ok().map(|f| self.outer_law(&f));
            if let Some(o) = fresh
                && matches!(self.modes.mode(), Mode::Standby | Mode::Approach)
            {
                self.last_outer = o;
            }
            let none = RefuelInputs {
                predicted_miss_m: f32::INFINITY,
                ..RefuelInputs::default()
            };
            (none, fresh.map(|o| o.target), None, (y_lon, y_lat))
        } else {
            let nav_tip = point_velocity_tanker_mps(
                &self.last_nav,
                &self.scheduled.trim,
                self.cfg.probe_tip_body_m,
            );
            // The tip's velocity relative to the tanker, the navigation's estimated bias
            // taken out: what the estimator and the gates reason with.
            let b = &self.nav_bias_mps;
            let tip = [nav_tip[0] - b[0], nav_tip[1] - b[1], nav_tip[2] - b[2]];
            let (refuel, target, frame) =
                self.observe_drogue(&feature, input.measurement.probe_tip, tip);
            // The integrators hold the tip's velocity as the exact kinematics have it from
            // the navigation (the estimator's, before the bias is taken out), not the design's
            // linear output, which leaves out the products of states (a steady bank times the
            // sideslip velocity, when the receiver flies crabbed and banked), the roll and yaw
            // rates' coupling through the tip's lateral offset, and takes the bank's term at
            // the design's trim (`docs/conventions.md`, "Inner loops for refuelling").
            (
                refuel,
                target,
                frame,
                ([nav_tip[1], nav_tip[2]], [nav_tip[0]]),
            )
        };
        let (y_lon_held, y_lat_held) = tracked;

        // 4. Mode logic.
        let before = self.modes.mode();
        let refused = self.modes.advance(
            &ModeInputs {
                request: input.request,
                target,
                nav_valid,
                in_envelope,
                probe_contact: input.probe_contact,
                autopilot_ready: self.cfg.inner_loop == InnerLoop::Surfaces
                    || input.autopilot_ready,
                camera_fwd_mps: y_lon[1],
                v_des: self.v_cmd,
                refuel,
            },
            &self.cfg.modes,
            &self.cfg.refuelling,
            ts,
            &self.derived.modes,
        );
        let mode = self.modes.mode();
        if mode == Mode::Standby && before != Mode::Standby {
            // Reset: the next engage starts afresh, from any camera numbering.
            self.sequence.reset();
            self.freeze.reset();
        }
        if !paper {
            match (before, mode) {
                (_, Mode::Standby) => self.estimator.stop(),
                (Mode::Standby, Mode::PreContact) => {
                    if let Some(fr) = &frame {
                        self.estimator.start(fr, &self.cfg.estimator);
                    }
                    self.station_integral_mps = [0.0; 2];
                    self.nav_bias_mps = [0.0; 3];
                    self.nav_bias_steps = 0;
                }
                // Each approach closes at the speed the air it starts in asks for, kept to
                // its end (docs/conventions.md, "The refuelling procedure").
                (Mode::PreContact, Mode::Approach) => {
                    self.contact_mps = procedure::contact_speed(
                        self.estimator.drogue_speed_rms_mps(),
                        &self.cfg.refuelling,
                    );
                    self.commit_depth_m =
                        procedure::commit_depth(self.contact_mps, &self.cfg.refuelling);
                }
                _ => {}
            }
        }
        let estimate = if paper {
            DrogueEstimate::default()
        } else {
            refuel.estimate
        };
        if !paper && mode == Mode::PreContact {
            let rc = &self.cfg.refuelling;
            for (b, r) in self
                .station_integral_mps
                .iter_mut()
                .zip(estimate.mean_offset_m)
            {
                *b = clamp_sym(
                    *b + ts * rc.station_integral_gain_per_s2 * r,
                    rc.station_max_integral_mps,
                );
            }
            // The navigation's velocity bias: what remains of the drogue's estimated velocity
            // (the tip's velocity already has the estimate taken out) is its error; the
            // drogue's own mean velocity relative to the tanker is zero. Learnt at the
            // station only, where the receiver holds still behind the drogue for seconds
            // (closing, the drogue's swing is followed and does not average out): the
            // running mean since engage, its memory growing from the estimator's
            // correlation time to `nav_bias_time_constant_s`, then fading at that.
            let memory = self.derived.nav_bias_memory_steps;
            if memory > 0.0 {
                self.nav_bias_steps = self.nav_bias_steps.saturating_add(1);
                let learnt = self.nav_bias_steps as f32 + self.derived.nav_bias_first_steps;
                let a = 1.0 / min_to(learnt, memory);
                for (b, v) in self
                    .nav_bias_mps
                    .iter_mut()
                    .zip(estimate.drogue_velocity_mps)
                {
                    *b += a * v;
                }
            }
        }
        self.v_cmd = if mode == Mode::Standby {
            VelocityRe::ZERO
        } else if paper || matches!(mode, Mode::Breakaway | Mode::MissedApproach) {
            outer::slew(
                &self.v_cmd,
                &self.mode_velocity(&estimate),
                match mode {
                    Mode::Breakaway => self.derived.breakaway_slew_step_mps,
                    Mode::MissedApproach => self.derived.missed_slew_step_mps,
                    Mode::Terminal => self.derived.terminal_slew_step_mps,
                    _ => self.derived.slew_step_mps,
                },
            )
        } else {
            outer::slew_axes(
                &self.v_cmd,
                &self.mode_velocity(&estimate),
                self.derived.refuel_slew_step_mps,
            )
        };
        let v_des = self.v_cmd;

        // 5. Inner loops and saturation.
        let open_loop = mode == Mode::Breakaway && !nav_valid;
        let integrate = mode != Mode::Standby && nav_valid;
        let engage = before == Mode::Standby && !paper;
        let (command, sat, lon_frozen, lat_frozen) = match self.cfg.inner_loop {
            InnerLoop::Surfaces => self.surface_loops(
                mode,
                (open_loop, integrate, engage),
                (&x_lon, &x_lat),
                &v_des,
                (&y_lon_held, &y_lat_held),
            ),
            InnerLoop::Attitude => self.attitude_loop(
                mode,
                (open_loop, integrate, engage),
                &v_des,
                (&y_lon_held, &y_lat_held),
            ),
        };

        // 6. Status and counters: nothing to flag or count in most steps.
        let held = self.modes.holding_measurement();
        let nav_held = !nav_valid && mode != Mode::Standby && !open_loop;
        let saturated = u32::from_ne_bytes(sat.side.map(|s| s as u8)) != 0;
        let frozen = lon_frozen || lat_frozen;
        let bits = if held | nav_held | saturated | frozen | refused | sat.non_finite | open_loop {
            self.flag_and_count(
                &sat,
                [held, nav_held, lon_frozen, lat_frozen, refused, open_loop],
            )
        } else {
            0
        };
        let c = &self.counters;

        ControllerOutput {
            command,
            mode,
            breakaway_reason: self.modes.breakaway_reason(),
            status: StatusFlags(bits),
            measurement_error: feature.err(),
            nav_error,
            v_des,
            target: if paper {
                self.last_outer.target
            } else {
                TargetEstimate {
                    right_m: estimate.offset_m[0],
                    down_m: estimate.offset_m[1],
                    depth_m: estimate.depth_m,
                }
            },
            step: c.steps,
            attempt: self.modes.attempt(),
            no_go: self.modes.no_go(),
            estimate,
            predicted_miss_m: refuel.predicted_miss_m,
            envelope_error: self.scheduled.error,
        }
    }
}
