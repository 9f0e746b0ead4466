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
//! ControllerInput ──► measurement::validate ──► ┐
//!   (camera frame,     nav::validate        ──► ├─► mode (standby/approach/terminal/docked/breakaway)
//!    navigation,                                │
//!    discretes)                                 ▼
//!                      outer::{ibvs, pbvs}: image error + depth ─► desired camera velocity
//!                                                 ▼
//!                      inner: LQR + integral action per channel (gains: generated)
//!                                                 ▼
//!                      actuator: absolute, saturated surface and throttle commands ─► ControllerOutput
//! ```
//!
//! Invariants, for every input including NaN and infinity:
//! - [`Controller::step`] never panics, never allocates and runs in bounded time;
//! - every command it returns is finite and inside [`actuator::ActuatorLimits`];
//! - every rejected input is named ([`measurement::MeasurementError`], [`nav::NavError`]),
//!   counted ([`controller::Counters`]) and answered as `docs/conventions.md` specifies.
//!
//! All arithmetic is `f32`; all sizes are static. Frames and units are carried in names:
//! `_m`, `_mps`, `_rad`, `_radps`; `re` is the camera reference frame (x right, y down,
//! z forward), `body` the receiver body frame, `tanker` the tanker frame (x forward, y right,
//! z down).
#![no_std]
#![forbid(unsafe_code)]

pub mod actuator;
pub mod config;
pub mod controller;
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
pub mod procedure;
pub mod wire;

pub use config::{ConfigError, ControllerConfig, OuterLaw};
pub use controller::{Controller, ControllerInput, ControllerOutput, Counters};
pub use mode::{BreakawayReason, Mode, ModeRequest, NoGoReason};
pub use procedure::{Procedure, RefuellingConfig};
