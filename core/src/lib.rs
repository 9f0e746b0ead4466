//! # ibvs-core: the probe-and-drogue docking controller
//!
//! The flight code of the image-based visual servo (IBVS) docking controller of Quan et al.,
//! "An Image Based Visual Servo Method for Probe-and-Drogue Autonomous Aerial Refueling",
//! read as in `docs/conventions.md` (every deviation from the paper is listed there).
//!
//! One [`Controller`] is stepped at the fixed period [`gains::CONTROL_PERIOD_S`]. The data
//! flow of one step, which is also the module layout:
//!
//! ```text
//! ControllerInput ──► measurement::validate ──┐
//!   (camera frame,     nav::validate        ──┤
//!    navigation,                              ▼
//!    discretes)        estimator: the drogue's position and velocity relative to the probe
//!                                             ▼
//!                      mode + procedure: standby, pre-contact, approach, go/no-go gate,
//!                        capture (terminal), docked, missed approach, breakaway
//!                                             ▼
//!                      outer::{ibvs, pbvs} or the procedure's guidance ─► desired velocity
//!                                             ▼
//!                      inner: LQR + integral action per channel (gains: generated,
//!                        scheduled on the flight condition by `schedule`), or
//!                        attitude: setpoints for the aircraft's autopilot (`inner_loop`)
//!                                             ▼
//!                      actuator: absolute, saturated surface and throttle commands, or
//!                        the autopilot's attitude and throttle setpoints ─► ControllerOutput
//! ```
//!
//! Invariants, for every input including NaN and infinity:
//! - [`Controller::step`] never panics, never allocates and runs in bounded time;
//! - every command it returns is finite and inside [`actuator::ActuatorLimits`] (setpoints:
//!   inside [`attitude::AttitudeLoopConfig`]'s limits);
//! - every rejected input is named ([`measurement::MeasurementError`], [`nav::NavError`]),
//!   counted ([`controller::Counters`]) and answered as `docs/conventions.md` specifies.
//!
//! Build a controller, engage it on a healthy frame and navigation sample, step it and read
//! the command (the default configuration flies the refuelling procedure, which starts by
//! holding the pre-contact station; [`ControllerConfig::paper`] flies the paper's):
//!
//! ```
//! use ibvs_core::measurement::CameraMeasurement;
//! use ibvs_core::nav::NavSample;
//! use ibvs_core::{Controller, ControllerConfig, ControllerInput, Mode, ModeRequest};
//!
//! let mut controller = Controller::new(ControllerConfig::default()).expect("valid defaults");
//! let input = ControllerInput {
//!     measurement: CameraMeasurement {
//!         seq: 1,
//!         tracked: true,
//!         image_x: 0.2, // drogue right of and above the boresight, normalised
//!         image_y: -0.1,
//!         depth_m: 8.0,
//!         probe_tip: None,
//!     },
//!     nav: NavSample::default(), // at trim
//!     probe_contact: false, autopilot_ready: true,
//!     request: ModeRequest::Engage,
//! };
//! let out = controller.step(&input);
//! assert_eq!(out.mode, Mode::PreContact);
//! assert_eq!(out.attempt, 1);
//! assert!(out.command.as_array()[0].is_finite() && out.command.throttle().is_finite());
//! // A NaN depth is rejected, named and counted, and the last command is held.
//! let bad = ControllerInput {
//!     measurement: CameraMeasurement { seq: 2, depth_m: f32::NAN, ..input.measurement },
//!     request: ModeRequest::None,
//!     ..input
//! };
//! let held = controller.step(&bad);
//! assert_eq!(held.measurement_error, Some(ibvs_core::measurement::MeasurementError::NonFinite));
//! assert_eq!(held.mode, Mode::PreContact);
//! ```
//!
//! All arithmetic is `f32`; all sizes are static. Frames and units are carried in names:
//! `_m`, `_mps`, `_rad`, `_radps`; `re` is the camera reference frame (x right, y down,
//! z forward), `body` the receiver body frame, `tanker` the tanker frame (x forward, y right,
//! z down).
#![no_std]
#![forbid(unsafe_code)]

pub mod actuator;
pub mod attitude;
pub mod config;
pub mod controller;
pub mod crc32c;
pub mod design;
pub mod estimator;
pub mod frames;
#[rustfmt::skip] // generated: see the module doc
pub mod gains;
pub mod inner;
pub mod kinematics;
pub mod measurement;
pub mod mode;
pub mod nav;
pub mod num;
pub mod outer;
pub mod predictor;
pub mod procedure;
pub mod schedule;
pub mod wire;

pub use config::{ConfigError, ControllerConfig, OuterLaw};
pub use controller::{Controller, ControllerInput, ControllerOutput, Counters, ReconfigureError};
pub use mode::{BreakawayReason, Mode, ModeRequest, NoGoReason};
pub use procedure::{Procedure, RefuellingConfig};
