//! The closed loop: the flight computer flies the nonlinear receiver toward the drogue.
//!
//! One control step of period `Ts` (the core's): the camera delivers its latest frame and the
//! navigation a sample of the current truth, the flight computer computes its commands, and
//! the receiver and the world (air, hose and drogue) are integrated over `Ts` in
//! `plant_substeps` steps with the commands held (zero-order hold), the docking plane checked
//! after every substep.
//!
//! The flight computer is a trait, so the same run drives the core in-process or the firmware
//! inside an emulated MCU. A flight computer flying the attitude-command inner loop flies
//! through the aircraft's autopilot over MAVLink, in process as in the firmware: each step the
//! simulated autopilot sends its telemetry (the navigation sample as ArduPlane would report
//! it, and its mode; `autopilot_link::peer`), the flight computer's side of the link
//! (`autopilot_link::session`) builds the step's navigation and mode from it, and the
//! setpoint the autopilot flies is the one it decodes from the flight computer's
//! `SET_ATTITUDE_TARGET`. [`run_with_faults`] injects scheduled faults between the world and
//! the flight computer (camera, navigation, actuators; [`crate::world::faults`]).
//!
//! Invariant: a run is a pure function of its [`Scenario`], its faults and the flight computer's
//! behaviour; it records one [`Sample`] per control step.

use ibvs_core::controller::{ControllerInput, ControllerOutput};
use ibvs_core::measurement::CameraMeasurement;
use ibvs_core::{BreakawayReason, Controller, Mode, ModeRequest};
use nalgebra::Vector3;
use serde::Serialize;

use crate::docking::Contact;
use crate::receiver::{
    Autopilot, AutopilotParams, F16, ModelError, ReceiverCommand, ReceiverPlant, ReceiverState,
    Trim, TrimError,
};
use crate::referee::{Airframe, CrossingRecord, FlightTruth, Limits, Referee, Truth, Verdict};
use crate::synthesis::{
    CONTROL_PERIOD_S, NOMINAL_XCG, PROBE_TIP_BODY_M, REFUELLING_ALTITUDE_M, REFUELLING_SPEED_MPS,
};
use crate::world::camera::{CameraParams, PinholeCamera};
use crate::world::drogue::FixedDrogue;
use crate::world::faults::{FaultInjector, SimFault};
use crate::world::flight::{FlightCondition, FlightConditionError};
use crate::world::hose::{HoseDrogue, HoseError, HoseParams};
use crate::world::led_camera::{CameraError, LedCamera, LedCameraParams};
use crate::world::nav::{InsErrors, InsNav, Navigation, PerfectNav};
use crate::world::turbulence::{
    DrydenParams, GustField, TurbulenceError, mil_f_8785c_scale_lengths_m, samples_per_step,
};
use crate::world::wake::{TankerWake, WakeError, WakeParams};
use crate::world::{Camera, Drogue, Mount, Tanker, World, ned_from_body, point_in_tanker_m};
use autopilot_link::peer::{AutopilotTelemetry, MAX_TELEMETRY_LEN, Peer, read_setpoint};
use autopilot_link::session::{MAX_BURST_LEN, Session, SessionConfig};
use ibvs_core::attitude::{AttitudeLoopConfig, Command};
use ibvs_core::estimator::TIP_IN_VIEW_MIN_DEPTH_M;
use ibvs_core::kinematics::SET_BACK_CAMERA_BODY_M;

/// Something that turns one step's input into one step's output: the core in-process, or
/// the firmware behind a serial link.
pub trait FlightComputer {
    /// Runs one control step.
    fn step(&mut self, input: &ControllerInput) -> ControllerOutput;

    /// The attitude-command inner loop it flies, when it flies through the autopilot: then
    /// the run calls [`FlightComputer::step_through_autopilot`] instead of
    /// [`FlightComputer::step`] (and the link checks the autopilot's attitude time
    /// constants against this design's).
    fn autopilot_design(&self) -> Option<AttitudeLoopConfig>;

    /// One control step through the autopilot: the autopilot's MAVLink bytes of the step in,
    /// the flight computer's out. The default is the flight computer in process: `link.session`
    /// (the simulator's copy of the firmware's side of the link) builds the step's input around
    /// [`FlightComputer::step`] and encodes its setpoint; the firmware in the loop runs its own.
    fn step_through_autopilot(&mut self, link: AutopilotStep<'_>) -> ControllerOutput {
        step_through_session(self, link)
    }

    /// The camera calibration the flight computer has learned, the probe tip's image point
    /// (`ibvs_core::Controller::probe_tip_image`), as it last reported it: `None` when it
    /// reports none.
    fn probe_tip_image(&self) -> Option<[f32; 2]> {
        None
    }
}

/// One step through the autopilot (see [`FlightComputer::step_through_autopilot`]).
pub struct AutopilotStep<'a> {
    /// The step's input as the uplink carries it (its navigation and `autopilot_ready` are
    /// replaced by the autopilot's).
    pub input: &'a ControllerInput,
    /// The autopilot's frames of this step.
    pub from_autopilot: &'a [u8],
    /// The link clock, ms (one control period per step).
    pub now_ms: u32,
    /// The flight computer's side of the link, for a flight computer in process.
    pub session: &'a mut Session,
    /// The flight computer's frames of this step, appended.
    pub to_autopilot: &'a mut Vec<u8>,
}

/// [`FlightComputer::step_through_autopilot`] in process: the session around `fc`'s step, as
/// the firmware's application runs it.
pub fn step_through_session<F: FlightComputer + ?Sized>(
    fc: &mut F,
    link: AutopilotStep<'_>,
) -> ControllerOutput {
    let AutopilotStep {
        input,
        from_autopilot,
        now_ms,
        session,
        to_autopilot,
    } = link;
    for &b in from_autopilot {
        session.push(b, now_ms);
    }
    let linked = session.input(now_ms, input);
    let output = fc.step(&linked);
    let mut burst = [0u8; MAX_BURST_LEN];
    let n = session.send(now_ms, &output.command, &mut burst);
    to_autopilot.extend_from_slice(burst.get(..n).unwrap_or(&[]));
    output
}

impl FlightComputer for Controller {
    /// The control task as the firmware runs it: the step, then the gain schedule's
    /// follow-up once the command is out ([`Controller::follow_schedule`]).
    fn step(&mut self, input: &ControllerInput) -> ControllerOutput {
        let output = Controller::step(self, input);
        self.follow_schedule();
        output
    }

    fn autopilot_design(&self) -> Option<AttitudeLoopConfig> {
        self.config().autopilot_loop()
    }

    /// After every step.
    fn probe_tip_image(&self) -> Option<[f32; 2]> {
        Some(Controller::probe_tip_image(self))
    }
}

/// The autopilot link's clock step, ms: one control period.
const LINK_PERIOD_MS: u32 = (CONTROL_PERIOD_S * 1000.0 + 0.5) as u32;

/// The paper's start: drogue minus probe tip, tanker axes (6 m ahead, 2 m right, 2 m up), m.
pub const PAPER_START_M: [f64; 3] = [6.0, 2.0, -2.0];

/// How long a run goes on after the controller breaks away, s: the referee watches the
/// breakaway manoeuvre itself (where the receiver goes, what it hits) for this long.
pub const OBSERVE_AFTER_BREAKAWAY_S: f64 = 15.0;

/// Salts that give each random process of a run its own seed from the run's seed.
const TURBULENCE_SEED_SALT: u64 = 0x7475_7262; // "turb"
const CAMERA_SEED_SALT: u64 = 0x6361_6d65; // "came"

/// What to simulate.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// Name, for reports.
    pub name: String,
    /// Seed of every random process of the run.
    pub seed: u64,
    /// Drogue centre minus probe tip at t = 0, tanker axes, m.
    pub start_offset_m: Vector3<f64>,
    /// Time budget, s (the authors': 70 s).
    pub duration_s: f64,
    /// Physics steps per control step (the receiver's and the hose's RK4 steps, the
    /// docking-plane checks): 2 (0.01 s) in [`Scenario::ideal`], 1 (0.02 s) in a scenario file
    /// by default (`docs/models.md`, "Physics step").
    pub plant_substeps: u32,
    /// Time simulated after the controller breaks away, with the controller still flying its
    /// breakaway, for the referee to watch it, s (15 s: [`OBSERVE_AFTER_BREAKAWAY_S`]).
    pub after_event_s: f64,
    /// The tanker; its speed and altitude are the run's flight condition
    /// ([`Scenario::flight`]): the receiver is trimmed there and the world's air is that
    /// altitude's.
    pub tanker: Tanker,
    /// Receiver cg, fraction of the mean chord.
    pub xcg: f64,
    /// The true receiver's factors on its aerodynamics, mass, inertia, actuators and engine
    /// ([`ReceiverPlant`]; nominal: the aircraft the controller was designed on). The receiver
    /// trims and flies with them; the design side (the gains, the navigation's reference
    /// trim, the camera's mount) stays the nominal aircraft's.
    pub receiver_plant: ReceiverPlant,
    /// Drogue model: `None` holds it at its nominal trail. At another flight condition than
    /// the default its air data (density, viscosity) are replaced by the condition's
    /// ([`FlightCondition::hose_params`]).
    pub hose: Option<HoseParams>,
    /// Camera model.
    pub camera: CameraChoice,
    /// True camera position (the probe tip, paper Assumption 3), body axes, m.
    pub camera_body_m: Vector3<f64>,
    /// True boresight pitch minus the level-at-trim mount the controller assumes, rad.
    pub camera_pitch_error_rad: f64,
    /// True camera roll about its boresight minus the assumed (none), rad: positive turns
    /// the image's right side down ([`crate::world::camera_misalignment`]).
    pub camera_roll_error_rad: f64,
    /// True boresight yaw minus the assumed (none), rad: positive points it right.
    pub camera_yaw_error_rad: f64,
    /// Probe tip, body axes, m.
    pub probe_tip_body_m: Vector3<f64>,
    /// RMS gust speed, m/s (0: calm).
    pub turbulence_sigma_mps: f64,
    /// Dryden scale length, m: `None` is MIL-F-8785C's at the flight altitude
    /// ([`mil_f_8785c_scale_lengths_m`]).
    pub turbulence_scale_length_m: Option<f64>,
    /// Tanker wake: `None` is off. At another flight condition than the default its density
    /// and airspeed are the condition's ([`FlightCondition::wake_params`]).
    pub wake: Option<WakeParams>,
    /// Bow wave on the drogue.
    pub bow_wave: bool,
    /// Factor on the bow wave's force (its strength; 1: the published fit).
    pub bow_wave_strength: f64,
    /// Navigation errors: `None` is perfect navigation.
    pub navigation: Option<InsErrors>,
    /// The tanker's breakaway call: the simulator requests an abort (`ModeRequest::Abort`)
    /// from the first step at which the true range (drogue centre minus probe tip, tanker x)
    /// is at or below this, m, the controller engaged and the coupling not latched; `None`:
    /// never. The call stands until the run ends.
    pub abort_at_range_m: Option<f64>,
    /// The aircraft's autopilot, flying the surfaces from the flight computer's attitude
    /// setpoints when the controller is configured for its attitude-command inner loop
    /// ([`crate::receiver::Autopilot`]; unused when the flight computer commands surfaces).
    pub autopilot: AutopilotParams,
}

/// The camera model and its parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CameraChoice {
    /// Ideal pinhole.
    Ideal(CameraParams),
    /// LED ring with noise, fit, latency and drops.
    Led(LedCameraParams),
}

impl Scenario {
    /// The vertical slice's world: calm air, no wake, the drogue held at its nominal trail, an
    /// ideal camera, perfect navigation; paper start; the camera set back from the probe tip
    /// (the refuelling procedure's, [`ibvs_core::kinematics::SET_BACK_CAMERA_BODY_M`]); the
    /// 0.01 s physics step.
    pub fn ideal() -> Self {
        Self {
            name: "ideal".into(),
            seed: 1,
            start_offset_m: Vector3::from(PAPER_START_M),
            duration_s: 70.0,
            plant_substeps: 2,
            after_event_s: OBSERVE_AFTER_BREAKAWAY_S,
            tanker: Tanker {
                speed_mps: REFUELLING_SPEED_MPS,
                altitude_m: REFUELLING_ALTITUDE_M,
            },
            xcg: NOMINAL_XCG,
            receiver_plant: ReceiverPlant::NOMINAL,
            hose: None,
            camera: CameraChoice::Ideal(CameraParams::default()),
            camera_body_m: SET_BACK_CAMERA_BODY_M.map(f64::from).into(),
            camera_pitch_error_rad: 0.0,
            camera_roll_error_rad: 0.0,
            camera_yaw_error_rad: 0.0,
            probe_tip_body_m: Vector3::from(PROBE_TIP_BODY_M),
            turbulence_sigma_mps: 0.0,
            turbulence_scale_length_m: None,
            wake: None,
            bow_wave: false,
            bow_wave_strength: 1.0,
            navigation: None,
            abort_at_range_m: None,
            autopilot: AutopilotParams::default(),
        }
    }

    /// The run's flight condition: the tanker's speed (the true airspeed, calm air) and
    /// altitude.
    pub fn flight(&self) -> FlightCondition {
        FlightCondition {
            airspeed_mps: self.tanker.speed_mps,
            altitude_m: self.tanker.altitude_m,
        }
    }
}

/// How a run ended, in order of precedence: a docking (the referee's: the coupling latched,
/// whatever the controller was doing); else a miss (the probe crossed the drogue plane without
/// docking while the controller was still pushing, i.e. not in a missed approach or a
/// breakaway); else a breakaway; else the time budget. The docking is judged from truth;
/// the rest describes the procedure (a safety judgement is the referee's [`Verdict`], never
/// this). With the paper's procedure the first decisive event is the outcome (its breakaway
/// is latched); with the refuelling procedure a run may dock at a later attempt after missed
/// approaches.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Outcome {
    /// The coupling latched (the referee's docking).
    Docked,
    /// The probe crossed the drogue plane without docking, the controller pushing.
    Missed,
    /// Neither docking nor miss nor breakaway within the time budget.
    Timeout,
    /// The controller broke away (a fault, or the end of the sortie) without docking.
    Aborted,
}

/// One crossing of the drogue plane by the probe tip: the referee's record, and what the
/// controller was doing then (for the record only: the verdict never reads it).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PlaneEvent {
    /// Where, when and how fast.
    pub contact: Contact,
    /// The referee's record of the crossing.
    pub crossing: CrossingRecord,
    /// The attempt the controller was flying (1 for the paper's single shot).
    pub attempt: u8,
    /// The controller's mode in the control step of the crossing.
    pub mode: Mode,
    /// The controller was still pushing (not in a missed approach or a breakaway).
    pub pushing: bool,
}

/// How one attempt of a run ended.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AttemptRecord {
    /// The attempt, 1-based.
    pub attempt: u8,
    /// `docked`, `no-go: <reason>`, `breakaway: <reason>`, or `unfinished` (the run ended
    /// during it).
    pub end: String,
    /// The probe crossed the plane without docking while the controller pushed in this
    /// attempt.
    pub struck: bool,
    /// Time the attempt ended, s.
    pub time_s: f64,
}

/// One control step's record.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Time at the start of the step, s.
    pub time_s: f64,
    /// The frame the flight computer saw.
    pub measurement: CameraMeasurement,
    /// What the flight computer answered.
    pub output: ControllerOutput,
    /// Drogue centre, tanker frame, m.
    pub drogue_tanker_m: Vector3<f64>,
    /// Probe tip, tanker frame, m.
    pub tip_tanker_m: Vector3<f64>,
    /// Drogue centre minus probe tip, tanker axes, m.
    pub drogue_from_tip_m: Vector3<f64>,
    /// Probe-tip velocity relative to the tanker, tanker axes, m/s.
    pub tip_velocity_mps: Vector3<f64>,
    /// Receiver truth.
    pub state: ReceiverState,
    /// The camera calibration the flight computer reported after the step
    /// ([`FlightComputer::probe_tip_image`]).
    pub probe_tip_image: Option<[f32; 2]>,
    /// The surfaces and throttle commanded to the actuators (before any injected actuator
    /// fault): the flight computer's own, or the autopilot's from its setpoint.
    pub surfaces_commanded: ReceiverCommand,
}

/// Summary of a run (the `dock --json` output).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    /// Attempts flown (1 for the paper's procedure).
    pub attempts: u8,
    /// How it ended.
    pub outcome: Outcome,
    /// Outcome is docked.
    pub docked: bool,
    /// Radial offset at the drogue plane, m, if the plane was reached.
    pub miss_m: Option<f64>,
    /// Closing speed at the drogue plane, m/s, if the plane was reached.
    pub closure_mps: Option<f64>,
    /// Time of the decisive event (contact, breakaway) or the budget, s.
    pub time_s: f64,
    /// The controller's breakaway reason, if it broke away.
    pub breakaway_reason: Option<String>,
    /// The flight condition's true airspeed, m/s.
    pub airspeed_mps: f64,
    /// The flight condition's altitude, m.
    pub altitude_m: f64,
}

/// A finished run.
#[derive(Debug, Clone)]
pub struct Run {
    /// Summary.
    pub summary: Summary,
    /// The referee's verdict: the docking, every crossing, every hazard.
    pub verdict: Verdict,
    /// The first plane crossing, if any (docking, strike, or after a breakaway).
    pub contact: Option<Contact>,
    /// Every crossing of the drogue plane, in time order.
    pub crossings: Vec<PlaneEvent>,
    /// How each attempt ended, in order.
    pub attempts: Vec<AttemptRecord>,
    /// One record per control step.
    pub samples: Vec<Sample>,
    /// The trim the receiver started from.
    pub trim: Trim,
    /// When the tanker's breakaway call ([`Scenario::abort_at_range_m`]) was made, s.
    pub abort_called_s: Option<f64>,
}

/// Follows the controller's attempts through its outputs: the paper's single shot is attempt
/// 1; the refuelling procedure numbers its own.
#[derive(Debug, Clone, Default)]
struct AttemptLog {
    records: Vec<AttemptRecord>,
    /// The attempt in progress and whether it struck.
    open: Option<(u8, bool)>,
    last_mode: Mode,
}

impl AttemptLog {
    /// The attempt in progress (the last one once the run is over), 0 before engage.
    fn current(&self) -> u8 {
        self.open
            .map(|(a, _)| a)
            .or_else(|| self.records.last().map(|r| r.attempt))
            .unwrap_or(0)
    }

    /// Attempts flown.
    fn count(&self) -> u8 {
        self.records.len() as u8 + u8::from(self.open.is_some())
    }

    fn struck(&mut self) {
        if let Some((_, s)) = self.open.as_mut() {
            *s = true;
        }
    }

    fn close(&mut self, end: String, time_s: f64) {
        if let Some((attempt, struck)) = self.open.take() {
            self.records.push(AttemptRecord {
                attempt,
                end,
                struck,
                time_s,
            });
        }
    }

    fn observe(&mut self, out: &ControllerOutput, time_s: f64) {
        let engaged = !matches!(out.mode, Mode::Standby);
        let attempt = out.attempt.max(1);
        if engaged && self.open.is_none() && self.last_mode != out.mode {
            let ended = matches!(out.mode, Mode::Breakaway | Mode::MissedApproach);
            if !ended || self.records.is_empty() {
                self.open = Some((attempt, false));
            }
        }
        if let Some((a, _)) = self.open
            && attempt != a
            && out.mode == Mode::PreContact
        {
            // A retry: the previous attempt ended in its missed approach (closed there).
            self.open = Some((attempt, false));
        }
        if self.last_mode != out.mode {
            let no_go = || {
                out.no_go
                    .map_or_else(|| "no-go".to_string(), |r| format!("no-go: {r:?}"))
            };
            match out.mode {
                Mode::Docked => self.close("docked".into(), time_s),
                Mode::MissedApproach => self.close(no_go(), time_s),
                Mode::Breakaway => {
                    let end = match out.breakaway_reason {
                        Some(BreakawayReason::AttemptsExhausted) => no_go(),
                        Some(r) => format!("breakaway: {r:?}"),
                        None => "breakaway".into(),
                    };
                    self.close(end, time_s);
                }
                _ => {}
            }
        }
        self.last_mode = out.mode;
    }

    fn finish(&mut self, time_s: f64) {
        self.close("unfinished".into(), time_s);
    }
}

/// Why a run could not start.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// Model construction failed.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// No trim at the tanker's flight condition.
    #[error("no trim at the flight condition {airspeed_mps} m/s, {altitude_m} m: {source}")]
    Trim {
        /// True airspeed, m/s.
        airspeed_mps: f64,
        /// Altitude, m.
        altitude_m: f64,
        /// Why.
        source: TrimError,
    },
    /// The flight condition is outside the models' validity.
    #[error(transparent)]
    Flight(#[from] FlightConditionError),
    /// Bad scenario value.
    #[error("invalid scenario: {0}")]
    Scenario(&'static str),
    /// The hose could not be built or did not settle.
    #[error(transparent)]
    Hose(#[from] HoseError),
    /// Bad camera parameters.
    #[error(transparent)]
    Camera(#[from] CameraError),
    /// Bad turbulence parameters.
    #[error(transparent)]
    Turbulence(#[from] TurbulenceError),
    /// Bad wake parameters.
    #[error(transparent)]
    Wake(#[from] WakeError),
}

/// The scenario's flight condition, checked against the models' validity in `model`'s
/// atmosphere.
fn valid_flight(s: &Scenario, model: &F16) -> Result<FlightCondition, SimError> {
    let flight = s.flight();
    flight.validate(
        |h| model.air_at(h),
        "flight.airspeed_mps",
        "flight.altitude_m",
    )?;
    Ok(flight)
}

/// Builds the world of a scenario: the hose settled in its steady trail in the run's steady
/// air (free stream and wake), the camera on the mount level at `trim` (the installation's
/// design trim), seeded random processes;
/// the air of `model`'s atmosphere at the flight condition ([`crate::world::flight`]).
pub fn build_world(s: &Scenario, model: &F16, trim: &Trim, dt_s: f64) -> Result<World, SimError> {
    let flight = valid_flight(s, model)?;
    let air = model.air_at(flight.altitude_m);
    let reference_air = model.air_at(FlightCondition::DEFAULT.altitude_m);
    let wake = s
        .wake
        .map(|w| TankerWake::new(flight.wake_params(w, &air)))
        .transpose()?;
    let gusts = (s.turbulence_sigma_mps > 0.0)
        .then(|| {
            // Isotropic above 2,000 ft, the validity limit of the condition: one length, the
            // scenario's when it states one.
            let length_m = s
                .turbulence_scale_length_m
                .unwrap_or_else(|| mil_f_8785c_scale_lengths_m(flight.altitude_m)[0]);
            let params = DrydenParams {
                sigma_mps: s.turbulence_sigma_mps,
                length_m,
                airspeed_mps: s.tanker.speed_mps,
            };
            // Sampled at the physics step or finer (`samples_per_step`): the same air at
            // 0.02 s as at 0.01 s, so that the physics step does not change the weather.
            GustField::new(
                params,
                dt_s / f64::from(samples_per_step(dt_s)),
                s.seed ^ TURBULENCE_SEED_SALT,
            )
        })
        .transpose()?;
    let drogue = match s.hose {
        None => Drogue::Fixed(FixedDrogue::default()),
        Some(params) => {
            let params = flight.hose_params(params, &air);
            let steady_air = |p: &Vector3<f64>| {
                let w = wake
                    .as_ref()
                    .map_or_else(Vector3::zeros, |w| w.velocity_tanker_mps(p));
                Vector3::new(-s.tanker.speed_mps, 0.0, 0.0) + w
            };
            Drogue::Hose(Box::new(HoseDrogue::steady_trail(params, &steady_air)?))
        }
    };
    // The probe tip's marker as the camera sees it (fixed in its view): in view when the
    // camera is set back from the tip (more than 0.5 m behind it).
    let mount = Mount {
        position_body_m: s.camera_body_m,
        pitch_down_rad: trim.theta_rad + s.camera_pitch_error_rad,
        roll_error_rad: s.camera_roll_error_rad,
        yaw_error_rad: s.camera_yaw_error_rad,
    };
    let tip_camera = mount
        .body_from_camera()
        .inverse_transform_vector(&(s.probe_tip_body_m - s.camera_body_m));
    let tip_in_view = (tip_camera.z > f64::from(TIP_IN_VIEW_MIN_DEPTH_M)).then_some(tip_camera);
    let camera = match s.camera {
        CameraChoice::Ideal(p) => {
            let mut c = PinholeCamera::new(p);
            c.set_probe_tip(tip_in_view);
            Camera::Ideal(c)
        }
        CameraChoice::Led(p) => {
            let mut c = LedCamera::new(p, s.seed ^ CAMERA_SEED_SALT)?;
            c.set_probe_tip(tip_in_view);
            Camera::Led(Box::new(c))
        }
    };
    Ok(World {
        tanker: s.tanker,
        drogue,
        camera,
        mount,
        gusts,
        wake,
        bow_wave: s.bow_wave,
        // At the default condition and strength, exactly 1 (`1.0 * 1.0`).
        bow_wave_scale: flight.bow_wave_scale(&air, &reference_air) * s.bow_wave_strength,
    })
}

/// The receiver at trim, placed so that the drogue minus probe tip is `offset` at t = 0.
fn initial_state(s: &Scenario, trim: &Trim, drogue_tanker_m: &Vector3<f64>) -> ReceiverState {
    let mut x = trim.state;
    let tip_tanker = drogue_tanker_m - s.start_offset_m;
    let cg_tanker = tip_tanker - ned_from_body(&x) * s.probe_tip_body_m;
    x.pos_ned_m = s.tanker.to_ned_m(&cg_tanker, 0.0);
    x
}

/// Runs `scenario` with `fc` flying.
pub fn run(s: &Scenario, fc: &mut dyn FlightComputer) -> Result<Run, SimError> {
    run_with_faults(s, fc, &[])
}

/// Runs `scenario` with `fc` flying and `faults` injected between the world and the flight
/// computer ([`crate::world::faults`]; `docs/faults.md`). With no faults it is [`run`].
pub fn run_with_faults(
    s: &Scenario,
    fc: &mut dyn FlightComputer,
    faults: &[SimFault],
) -> Result<Run, SimError> {
    run_observed(s, fc, faults, &mut |_, _| {})
}

/// [`run_with_faults`], calling `observer` once per control step with the world and the
/// step's [`Sample`] just recorded (the world as the camera saw it, before it is advanced).
/// The observer sees, it cannot change: the run is the same with any observer.
pub fn run_observed(
    s: &Scenario,
    fc: &mut dyn FlightComputer,
    faults: &[SimFault],
    observer: &mut dyn FnMut(&World, &Sample),
) -> Result<Run, SimError> {
    let mut injector = FaultInjector::new(faults).map_err(SimError::Scenario)?;
    if !(s.duration_s.is_finite()
        && s.duration_s > 0.0
        && s.plant_substeps > 0
        && s.after_event_s >= 0.0)
    {
        return Err(SimError::Scenario(
            "duration, substeps and after_event_s must be positive",
        ));
    }
    let model = F16::with_plant(s.xcg, &s.receiver_plant)?;
    let flight = valid_flight(s, &model)?;
    let trim_at = |m: &F16, c: FlightCondition| {
        m.trim_straight_level(c.airspeed_mps, c.altitude_m)
            .map_err(|source| SimError::Trim {
                airspeed_mps: c.airspeed_mps,
                altitude_m: c.altitude_m,
                source,
            })
    };
    let trim = trim_at(&model, flight)?;
    // The navigation reports perturbations from the trim of the design aircraft (the nominal
    // cg and plant) at the run's flight condition: at another cg, or with another plant, the
    // receiver trims at a different attitude, elevator and throttle, which it then sees. The
    // camera is fixed to the airframe, level at the trim of the installation's design (nominal
    // cg and plant, the default condition): at another condition it looks up or down by the
    // difference, which the controller's geometry takes out.
    let design_trim = if s.xcg == NOMINAL_XCG && s.receiver_plant.is_nominal() {
        trim
    } else {
        trim_at(&F16::new(NOMINAL_XCG)?, flight)?
    };
    let mount_trim = if flight == FlightCondition::DEFAULT {
        design_trim
    } else {
        trim_at(&F16::new(NOMINAL_XCG)?, FlightCondition::DEFAULT)?
    };
    let (ts, dt) = (
        CONTROL_PERIOD_S,
        CONTROL_PERIOD_S / f64::from(s.plant_substeps),
    );
    let mut world = build_world(s, &model, &mount_trim, dt)?;
    let mut x = initial_state(s, &trim, &world.drogue_centre_tanker_m());
    let start_cg = point_in_tanker_m(&s.tanker, &x, &Vector3::zeros(), 0.0);
    let mut nav = match s.navigation {
        None => Navigation::Perfect(PerfectNav::new(&design_trim, start_cg)),
        Some(e) => {
            e.validate().map_err(SimError::Scenario)?;
            Navigation::Ins(Box::new(InsNav::new(&design_trim, start_cg, e, ts, s.seed)))
        }
    };
    let steps = (s.duration_s / ts).ceil() as usize;
    s.autopilot.validate().map_err(SimError::Scenario)?;
    let mut autopilot = Autopilot::new(
        s.autopilot,
        &trim.state,
        &ReceiverCommand {
            elevator_rad: trim.elevator_rad,
            throttle: trim.throttle,
            aileron_rad: trim.aileron_rad,
            rudder_rad: trim.rudder_rad,
        },
    );

    let tip = |x: &ReceiverState, t: f64| point_in_tanker_m(&s.tanker, x, &s.probe_tip_body_m, t);
    let mut referee = Referee::new(
        referee_limits(&world),
        Airframe::f16(s.probe_tip_body_m.into()),
    );
    referee.observe(&truth(s, &x, 0.0, &world));
    let mut crossings: Vec<PlaneEvent> = Vec::new();
    let mut attempts = AttemptLog::default();
    let mut latched = false;
    let mut breakaway_at: Option<f64> = None;
    let mut abort_called_s: Option<f64> = None;
    let mut samples = Vec::with_capacity(steps);
    let mut reason = None;
    let mut prev_tip = tip(&x, 0.0);
    // Through the autopilot: its end of the MAVLink link, and the flight computer's in
    // process (unused by the firmware in the loop, which runs its own).
    let design = fc.autopilot_design();
    let through_autopilot = design.is_some();
    let link_cfg = SessionConfig {
        design: design.unwrap_or_default(),
        ..SessionConfig::default()
    };
    let time_constants_s = [
        s.autopilot.pitch_time_constant_s as f32,
        s.autopilot.roll_time_constant_s as f32,
    ];
    let mut autopilot_end = Peer::new(link_cfg.ids, time_constants_s);
    let mut session = Session::new(link_cfg);

    for k in 0..steps {
        let t = k as f64 * ts;
        let (tip_now, drogue_now) = (tip(&x, t), world.drogue_centre_tanker_m());
        let wind_now = world.receiver_wind(&x, t);
        referee.observe_flight(&flight_truth(
            &model, &s.tanker, &x, &wind_now, t, drogue_now,
        ));
        let measurement = if injector.is_empty() {
            world.capture(&x, t)
        } else {
            injector.begin_step(t, drogue_now.x - tip_now.x);
            world.set_led_occlusion(injector.occlusion_mask());
            let raw = world.capture(&x, t);
            injector.measurement(t, raw)
        };
        let engaged_before = samples
            .last()
            .is_some_and(|p: &Sample| p.output.mode != Mode::Standby);
        if abort_called_s.is_none()
            && engaged_before
            && !latched
            && s.abort_at_range_m
                .is_some_and(|r| drogue_now.x - tip_now.x <= r)
        {
            abort_called_s = Some(t);
        }
        autopilot.set_following(!injector.autopilot_released());
        let input = ControllerInput {
            measurement,
            nav: injector.nav(nav.sample(&s.tanker, &x, t)),
            probe_contact: latched,
            autopilot_ready: autopilot.follows_setpoints(),
            request: if abort_called_s.is_some() {
                ModeRequest::Abort
            } else if engaged_before || breakaway_at.is_some() || latched {
                ModeRequest::None
            } else {
                ModeRequest::Engage
            },
        };
        let (output, linked) = if through_autopilot {
            let now_ms = (k as u32).wrapping_mul(LINK_PERIOD_MS);
            let mut frames = [0u8; MAX_TELEMETRY_LEN];
            // Outside the schedule the autopilot's report cannot be made: nothing is sent, and
            // the flight computer's navigation goes stale (counted there).
            let n = AutopilotTelemetry::of_sample(&input.nav, &link_cfg.nav).map_or(0, |t| {
                autopilot_end.telemetry(&t, autopilot.follows_setpoints(), now_ms, &mut frames)
            });
            let mut to_autopilot = Vec::new();
            let output = fc.step_through_autopilot(AutopilotStep {
                input: &input,
                from_autopilot: &frames[..n],
                now_ms,
                session: &mut session,
                to_autopilot: &mut to_autopilot,
            });
            let read = read_setpoint(&to_autopilot, link_cfg.nav.track_rad);
            autopilot_end.hear(&read);
            (output, read.setpoint)
        } else {
            (fc.step(&input), None)
        };
        let surfaces = match &output.command {
            Command::Surfaces(c) => ReceiverCommand {
                elevator_rad: f64::from(c.elevator_rad),
                throttle: f64::from(c.throttle),
                aileron_rad: f64::from(c.aileron_rad),
                rudder_rad: f64::from(c.rudder_rad),
            },
            Command::Attitude(sp) => {
                // Through the link, the setpoint it carried (none: the autopilot flies on
                // its last, then times out).
                match (through_autopilot, &linked) {
                    (false, _) => _ = autopilot.receive(sp, t),
                    (true, Some(sp)) => _ = autopilot.receive(sp, t),
                    (true, None) => {}
                }
                autopilot.command(&x, t, ts)
            }
        };
        samples.push(Sample {
            time_s: t,
            measurement,
            output,
            drogue_tanker_m: drogue_now,
            tip_tanker_m: tip_now,
            drogue_from_tip_m: drogue_now - tip_now,
            tip_velocity_mps: if k == 0 {
                Vector3::zeros()
            } else {
                (tip_now - prev_tip) / ts
            },
            state: x,
            probe_tip_image: fc.probe_tip_image(),
            surfaces_commanded: surfaces,
        });
        if let Some(recorded) = samples.last() {
            observer(&world, recorded);
        }
        prev_tip = tip_now;
        attempts.observe(&output, t);
        if output.mode == Mode::Breakaway && breakaway_at.is_none() {
            reason = output.breakaway_reason.map(|r| format!("{r:?}"));
            breakaway_at = Some(t);
        }
        if latched || breakaway_at.is_some_and(|at| t >= at + s.after_event_s) {
            break;
        }
        let cmd = injector.actuate(surfaces, &x, ts);
        for i in 0..s.plant_substeps {
            let ti = t + f64::from(i) * dt;
            let wind = if i == 0 {
                wind_now
            } else {
                world.receiver_wind(&x, ti)
            };
            world.step(dt, &x, ti);
            model.step_rk4(&mut x, &cmd, &wind, dt);
            let Some(c) = referee.observe(&truth(s, &x, ti + dt, &world)) else {
                continue;
            };
            // What the controller was doing: a record for the reader, not for the verdict.
            let pushing = !matches!(output.mode, Mode::MissedApproach | Mode::Breakaway);
            crossings.push(PlaneEvent {
                contact: Contact::from(&c),
                crossing: c,
                attempt: attempts.current(),
                mode: output.mode,
                pushing,
            });
            if referee.docking().is_some() {
                // The probe is in the coupling: it latches (the contact discrete); the step
                // ends as it would have, the referee judging nothing more.
                latched = true;
            } else if pushing {
                attempts.struck();
            }
        }
    }
    attempts.finish(samples.last().map_or(0.0, |p| p.time_s));
    let docking = crossings.iter().find(|e| e.contact.docked);
    let strike = crossings.iter().find(|e| e.pushing && !e.contact.docked);
    let (outcome, time_s, decisive) = match (docking, strike, breakaway_at) {
        (Some(d), _, _) => (Outcome::Docked, d.contact.time_s, Some(d.contact)),
        (None, Some(m), _) => (Outcome::Missed, m.contact.time_s, Some(m.contact)),
        (None, None, Some(at)) => (Outcome::Aborted, at, None),
        (None, None, None) => (Outcome::Timeout, s.duration_s, None),
    };
    let contact = crossings.first().map(|e| e.contact);
    Ok(Run {
        summary: Summary {
            attempts: attempts.count(),
            outcome,
            docked: outcome == Outcome::Docked,
            miss_m: decisive.map(|c| c.miss_m),
            closure_mps: decisive.map(|c| c.closure_mps),
            time_s,
            breakaway_reason: reason,
            airspeed_mps: flight.airspeed_mps,
            altitude_m: flight.altitude_m,
        },
        verdict: referee.into_verdict(),
        contact,
        crossings,
        attempts: attempts.records,
        samples,
        trim,
        abort_called_s,
    })
}

/// The referee's limits for this world: the stated figures ([`Limits::default`]) with the
/// canopy and the hose of the world's own drogue.
fn referee_limits(world: &World) -> Limits {
    match &world.drogue {
        Drogue::Hose(h) => Limits {
            canopy_radius_m: h.params().drogue_canopy_diameter_m / 2.0,
            hose_radius_m: h.params().hose_outer_radius_m,
            ..Limits::default()
        },
        Drogue::Fixed(_) => Limits::default(),
    }
}

/// The truth of one physics step for the referee: the receiver, the drogue, the hose.
fn truth<'w>(s: &Scenario, x: &ReceiverState, t_s: f64, world: &'w World) -> Truth<'w> {
    let tanker = &s.tanker;
    let tanker_from_body = ned_from_body(x);
    Truth {
        time_s: t_s,
        probe_tip_tanker_m: point_in_tanker_m(tanker, x, &s.probe_tip_body_m, t_s),
        cg_tanker_m: point_in_tanker_m(tanker, x, &Vector3::zeros(), t_s),
        cg_velocity_tanker_mps: tanker_from_body * x.vel_body_mps
            - Vector3::new(tanker.speed_mps, 0.0, 0.0),
        tanker_from_body,
        rate_body_radps: x.rate_body_radps,
        drogue_centre_tanker_m: world.drogue_centre_tanker_m(),
        drogue_velocity_tanker_mps: world.drogue_velocity_tanker_mps(),
        drogue_axis_tanker: world.drogue_axis_tanker(),
        hose_tanker_m: world.hose_nodes_tanker_m(),
    }
}

/// The receiver's flight at a control step for the referee: attitude, the angle of attack in
/// the air it flies (`wind`), the normal load factor from the aerodynamic and thrust loads.
fn flight_truth(
    model: &F16,
    tanker: &Tanker,
    x: &ReceiverState,
    wind: &crate::receiver::Wind,
    t_s: f64,
    drogue_centre_tanker_m: Vector3<f64>,
) -> FlightTruth {
    let loads = model.body_loads(x, wind);
    FlightTruth {
        time_s: t_s,
        bank_rad: x.euler_rad.x,
        pitch_rad: x.euler_rad.y,
        alpha_rad: model.air_data(x, wind).alpha_rad,
        load_factor: -loads.force_body_n.z / (model.mass_kg() * model.gravity_mps2()),
        cg_tanker_m: point_in_tanker_m(tanker, x, &Vector3::zeros(), t_s),
        cg_velocity_tanker_mps: ned_from_body(x) * x.vel_body_mps
            - Vector3::new(tanker.speed_mps, 0.0, 0.0),
        drogue_centre_tanker_m,
    }
}
