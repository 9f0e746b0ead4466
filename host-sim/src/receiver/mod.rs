//! Nonlinear 6-DOF model of the F-16 receiver aircraft, with its trim.
//!
//! Source: Stevens, Lewis & Johnson, *Aircraft Control and Simulation*, App. A (low-fidelity
//! F-16 from NASA TP-1538), tables and formulas in `host-sim/data/f16-lofi-data.toml`, embedded
//! at build time; actuator data from `docs/models.md`, "Actuators". Equations of motion:
//! flat, non-rotating earth, constant mass, wind as a steady air-mass velocity (see [`F16`]
//! and `model.rs`).
//! Invariants: every public quantity is SI (m, m/s, rad, rad/s, kg, N, Pa) with body axes
//! x forward, y right, z down and NED position; English units and degrees exist only inside, and
//! are converted with the named constants of `units.rs`. Stepping the model never allocates.
//!
//! Use: [`F16::new`] builds the nominal model ([`F16::with_plant`] a true aircraft whose
//! [`ReceiverPlant`] factors differ from the design's), [`F16::trim_straight_level`] gives a [`Trim`] whose
//! `state` and `command` hold steady flight, [`F16::step_rk4`] integrates, and
//! [`F16::derivatives`] exposes the vector field (order: [`state_index`]).

mod actuators;
mod aero;
mod atmosphere;
mod autopilot;
mod data;
mod engine;
mod interp;
mod model;
mod plant;
mod state;
mod trim;
mod units;

pub use actuators::{ActuatorParams, SurfaceLimits};
pub use aero::ReferenceGeometry;
pub use atmosphere::AirProperties;
pub use autopilot::{Autopilot, AutopilotParams};
pub use data::ModelError;
pub use model::{AirData, BodyLoads, F16};
pub use plant::{
    FACTOR_COUNT, FACTORS, FactorInfo, FactorLimits, FactorSlot, PlantFactors, ReceiverPlant,
    ReceiverPlantRanges,
};
pub use state::{
    ReceiverCommand, ReceiverState, STATE_DIM, StateVector, Surfaces, Wind, state_index,
};
pub use trim::{TRIM_RESIDUAL_TOLERANCE, Trim, TrimError};
