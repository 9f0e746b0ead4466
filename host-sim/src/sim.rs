//! The closed loop: the flight computer flies the nonlinear receiver toward the drogue.
//!
//! One control step of period `Ts` (the core's): the camera takes a frame and the navigation
//! a sample of the current truth, the flight computer computes its commands, and the plant
//! is integrated over `Ts` in `plant_substeps` RK4 steps with the commands held (zero-order
//! hold), the docking plane checked after every substep.
//!
//! The flight computer is a trait, so the same run drives the core in-process or the firmware
//! inside an emulated MCU.
//!
//! Invariant: a run is a pure function of its [`Scenario`] and the flight computer's
//! behaviour; it records one [`Sample`] per control step.

use ibvs_core::controller::{ControllerInput, ControllerOutput};
use ibvs_core::measurement::CameraMeasurement;
use ibvs_core::{Controller, Mode, ModeRequest};
use nalgebra::Vector3;
use serde::Serialize;

use crate::docking::{Contact, PlaneCrossing};
use crate::receiver::{F16, ModelError, ReceiverCommand, ReceiverState, Trim, TrimError, Wind};
use crate::synthesis::{
    CONTROL_PERIOD_S, NOMINAL_XCG, PROBE_TIP_BODY_M, REFUELLING_ALTITUDE_M, REFUELLING_SPEED_MPS,
};
use crate::world::camera::{CameraParams, PinholeCamera};
use crate::world::drogue::{CAPTURE_RADIUS_M, FixedDrogue};
use crate::world::nav::PerfectNav;
use crate::world::{Tanker, ned_from_body, point_in_tanker_m};

/// Something that turns one step's input into one step's output: the core in-process, or
/// the firmware behind a serial link.
pub trait FlightComputer {
    /// Runs one control step.
    fn step(&mut self, input: &ControllerInput) -> ControllerOutput;
}

impl FlightComputer for Controller {
    fn step(&mut self, input: &ControllerInput) -> ControllerOutput {
        Controller::step(self, input)
    }
}

/// The paper's start: drogue minus probe tip, tanker axes (6 m ahead, 2 m right, 2 m up), m.
pub const PAPER_START_M: [f64; 3] = [6.0, 2.0, -2.0];

/// What to simulate.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// Drogue centre minus probe tip at t = 0, tanker axes, m.
    pub start_offset_m: Vector3<f64>,
    /// Time budget, s (the authors': 70 s).
    pub duration_s: f64,
    /// RK4 substeps per control step.
    pub plant_substeps: u32,
    /// Time simulated after a miss or a breakaway (to record the response), s.
    pub after_event_s: f64,
    /// The tanker.
    pub tanker: Tanker,
    /// Receiver cg, fraction of the mean chord.
    pub xcg: f64,
    /// Camera intrinsics and limits.
    pub camera: CameraParams,
    /// True camera position (the probe tip, paper Assumption 3), body axes, m.
    pub camera_body_m: Vector3<f64>,
    /// Probe tip, body axes, m.
    pub probe_tip_body_m: Vector3<f64>,
}

impl Default for Scenario {
    fn default() -> Self {
        Self {
            start_offset_m: Vector3::from(PAPER_START_M),
            duration_s: 70.0,
            plant_substeps: 2,
            after_event_s: 2.0,
            tanker: Tanker {
                speed_mps: REFUELLING_SPEED_MPS,
                altitude_m: REFUELLING_ALTITUDE_M,
            },
            xcg: NOMINAL_XCG,
            camera: CameraParams::default(),
            camera_body_m: Vector3::from(PROBE_TIP_BODY_M),
            probe_tip_body_m: Vector3::from(PROBE_TIP_BODY_M),
        }
    }
}

/// How a run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Outcome {
    /// The probe reached the drogue plane inside the capture radius and the closing band.
    Docked,
    /// The probe reached the drogue plane outside the radius or the band.
    Missed,
    /// Neither contact nor breakaway within the time budget.
    Timeout,
    /// The controller broke away before reaching the plane.
    Aborted,
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
    /// Drogue centre minus probe tip, tanker axes, m.
    pub drogue_from_tip_m: Vector3<f64>,
    /// Probe-tip velocity relative to the tanker, tanker axes, m/s.
    pub tip_velocity_mps: Vector3<f64>,
    /// Receiver truth.
    pub state: ReceiverState,
}

/// Summary of a run (the `dock --json` output).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
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
}

/// A finished run.
#[derive(Debug, Clone)]
pub struct Run {
    /// Summary.
    pub summary: Summary,
    /// The plane crossing, if any.
    pub contact: Option<Contact>,
    /// One record per control step.
    pub samples: Vec<Sample>,
    /// The trim the receiver started from.
    pub trim: Trim,
}

/// Why a run could not start.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// Model construction failed.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// No trim at the tanker's flight condition.
    #[error(transparent)]
    Trim(#[from] TrimError),
    /// Bad scenario value.
    #[error("invalid scenario: {0}")]
    Scenario(&'static str),
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
    if !(s.duration_s.is_finite()
        && s.duration_s > 0.0
        && s.plant_substeps > 0
        && s.after_event_s >= 0.0)
    {
        return Err(SimError::Scenario(
            "duration, substeps and after_event_s must be positive",
        ));
    }
    let model = F16::new(s.xcg)?;
    let trim = model.trim_straight_level(s.tanker.speed_mps, s.tanker.altitude_m)?;
    let drogue = FixedDrogue::default();
    let mut x = initial_state(s, &trim, &drogue.centre_tanker_m(0.0));
    let nav = PerfectNav::new(
        &trim,
        point_in_tanker_m(&s.tanker, &x, &Vector3::zeros(), 0.0),
    );
    let mut camera = PinholeCamera::new(s.camera, s.camera_body_m, trim.theta_rad);
    let (ts, wind) = (CONTROL_PERIOD_S, Wind::default());
    let dt = ts / f64::from(s.plant_substeps);
    let steps = (s.duration_s / ts).ceil() as usize;

    let tip = |x: &ReceiverState, t: f64| point_in_tanker_m(&s.tanker, x, &s.probe_tip_body_m, t);
    let mut crossing = PlaneCrossing::default();
    crossing.observe(
        0.0,
        drogue.centre_tanker_m(0.0) - tip(&x, 0.0),
        CAPTURE_RADIUS_M,
    );
    let mut contact: Option<Contact> = None;
    let mut event: Option<(Outcome, f64)> = None;
    let mut samples = Vec::with_capacity(steps);
    let mut reason = None;
    let mut prev_tip = tip(&x, 0.0);

    for k in 0..steps {
        let t = k as f64 * ts;
        let drogue_t = drogue.centre_tanker_m(t);
        let measurement = camera.capture(&s.tanker, &x, &drogue_t, t);
        let engaged_before = samples
            .last()
            .is_some_and(|p: &Sample| p.output.mode != Mode::Standby);
        let input = ControllerInput {
            measurement,
            nav: nav.sample(&s.tanker, &x, t),
            probe_contact: contact.is_some_and(|c| c.docked),
            request: if engaged_before || event.is_some() {
                ModeRequest::None
            } else {
                ModeRequest::Engage
            },
        };
        let output = fc.step(&input);
        let tip_now = tip(&x, t);
        samples.push(Sample {
            time_s: t,
            measurement,
            output,
            drogue_from_tip_m: drogue_t - tip_now,
            tip_velocity_mps: if k == 0 {
                Vector3::zeros()
            } else {
                (tip_now - prev_tip) / ts
            },
            state: x,
        });
        prev_tip = tip_now;
        if output.mode == Mode::Breakaway && reason.is_none() {
            reason = output.breakaway_reason.map(|r| format!("{r:?}"));
            event.get_or_insert((Outcome::Aborted, t));
        }
        if let Some((outcome, at)) = event
            && (outcome == Outcome::Docked || t >= at + s.after_event_s)
        {
            break;
        }
        let cmd = ReceiverCommand {
            elevator_rad: f64::from(output.command.elevator_rad),
            throttle: f64::from(output.command.throttle),
            aileron_rad: f64::from(output.command.aileron_rad),
            rudder_rad: f64::from(output.command.rudder_rad),
        };
        for i in 1..=s.plant_substeps {
            model.step_rk4(&mut x, &cmd, &wind, dt);
            let ti = t + f64::from(i) * dt;
            if let Some(c) = crossing.observe(
                ti,
                drogue.centre_tanker_m(ti) - tip(&x, ti),
                CAPTURE_RADIUS_M,
            ) {
                contact = Some(c);
                event.get_or_insert((
                    if c.docked {
                        Outcome::Docked
                    } else {
                        Outcome::Missed
                    },
                    c.time_s,
                ));
            }
        }
    }
    let (outcome, time_s) = event.unwrap_or((Outcome::Timeout, s.duration_s));
    // A crossing after a breakaway (while backing off) is not the approach's result.
    let reached = contact.filter(|c| c.time_s <= time_s);
    Ok(Run {
        summary: Summary {
            outcome,
            docked: outcome == Outcome::Docked,
            miss_m: reached.map(|c| c.miss_m),
            closure_mps: reached.map(|c| c.closure_mps),
            time_s,
            breakaway_reason: reason,
        },
        contact,
        samples,
        trim,
    })
}
