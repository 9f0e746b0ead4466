//! # host-sim: the docking controller's simulator
//!
//! Links the same `ibvs-core` the flight computer runs against full models of its world:
//!
//! ```text
//! receiver (nonlinear 6-DOF F-16, actuators, engine) ──► world::nav ──► NavSample ─┐
//!        ▲                      world::drogue ──► world::camera ──► frame ───────┤
//!        │                                                                        ▼
//!        └──── surface and throttle commands ◄── sim::FlightComputer (core, or firmware)
//! ```
//!
//! It also designs the controller: [`receiver`] trims, [`linearize`] linearises,
//! [`synthesis`] discretises and solves the Riccati equations, and writes the core's
//! generated gains module. [`docking`] decides what counts as a dock; [`output`] writes the
//! CSV, JSON and plots of a run; [`record`] records a run in full (inputs, hose, camera image,
//! link frames), from which [`flight_log`] writes the MCAP flight-test log and [`animate`] the
//! GIF.
//!
//! Invariant: every random process takes a seed (none in this slice: calm air, ideal camera).

pub mod animate;
pub mod docking;
pub mod flight_log;
pub mod linearize;
pub mod montecarlo;
pub mod output;
pub mod paper;
pub mod pil;
pub mod plot;
pub mod receiver;
pub mod record;
pub mod scenario;
pub mod sim;
pub mod synthesis;
pub mod world;
