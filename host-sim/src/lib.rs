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
//! The modules, in the order of the data flow:
//!
//! - the aircraft and its design: [`receiver`] (the F-16 model, trim), [`linearize`],
//!   [`synthesis`] (discretisation, Riccati, the core's generated gains module);
//! - the world: [`world`] (hose and drogue, Dryden turbulence, tanker wake, bow wave, the LED
//!   and ideal cameras, the INS, fault injection);
//! - a run: [`scenario`] (scenario files, presets, dispersion; the controller's settings
//!   are its `[controller]` table, whose schema is [`config_schema`]), [`sim`] (the closed loop),
//!   [`docking`] (the drogue plane), [`referee`] (the run judged from truth alone:
//!   the docking and every hazard), [`pil`] (the flight computer inside QEMU over its
//!   serial link);
//! - what a run gives: [`output`] (CSV, JSON), [`plot`], [`record`] (a run recorded in full:
//!   inputs, hose, camera image, link frames) and from it [`flight_log`] (the MCAP
//!   flight-test log) and [`animate`] (the GIF), [`paper`] (the paper's experiments),
//!   [`montecarlo`] (campaigns, shards, merge);
//!
//! The target benchmarks (the firmware's instruction counts in QEMU, its static bounds) are a
//! crate of their own, `target-bench/`, which uses this one's runs and its QEMU link.
//!
//! One crate, for now: its modules import each other in one direction only (no cycle; the
//! list above is that order), so they could become library crates nested under `host-sim/`
//! along the same cuts (aircraft and design; world; a run; the flight computer in QEMU) with
//! the command-line program on top. Not done yet: it would buy parallel compilation and
//! enforced boundaries, and costs a manifest per cut and a re-export layer for the tests and
//! `target-bench`; the cycle-free order is the precondition, kept.
//!
//! Invariant: every random process takes a seed (turbulence, camera noise, INS errors,
//! dispersion, link faults); the same scenario file gives the same run, bit for bit.

pub mod animate;
pub mod config_schema;
pub mod consistency;
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
pub mod referee;
pub mod scenario;
pub mod sim;
pub mod synthesis;
pub mod world;
