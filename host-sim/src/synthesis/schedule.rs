//! The gain schedule's synthesis: the whole design (trim, every procedure's gains, engine and
//! predictor models) at every node of the docking envelope's grid, the data the core's
//! `ibvs_core::schedule` interpolates.
//!
//! The grid (`docs/conventions.md`, "Gain schedule"): true airspeed [`SCHEDULE_SPEEDS_MPS`]
//! by altitude [`SCHEDULE_ALTITUDES_M`]. It holds the single-point design's condition
//! (120 m/s, 3,000 m) as a node, so the paper's experiments fly the design they were
//! measured with. It is as fine as stability needs: with the core's bilinear interpolation,
//! checked on a 5 m/s by 500 m lattice over the envelope (`examples/schedule_grid.rs`), a
//! grid of only the corners leaves the lateral loop unstable inside the envelope (spectral
//! radius 1.013 at 125 m/s, 5,500 m), three nodes a side leave 0.9988, and these four a side
//! 0.9936, the single-point design's own margin (0.9931); a fifth node a side gains nothing
//! (0.9936). The gains are not smooth everywhere: the low-fidelity aerodynamic tables are
//! linear between 5-degree breakpoints in angle of attack, so the derivatives, and the gains,
//! have kinks where the trim crosses one; more nodes would follow kinks, not improve margins.
//!
//! Invariant: a [`Schedule`] exists only if every node's synthesis passed its checks
//! (Riccati residual, stable closed loops, decoupled engine and predictor rows).

use super::{
    CONTROL_PERIOD_S, DesignWeights, PROBE_TIP_BODY_M, Synthesis, SynthesisError, synthesize,
};
use crate::receiver::F16;

/// The grid's true airspeeds, m/s: the docking envelope's range in speed.
pub const SCHEDULE_SPEEDS_MPS: [f64; 4] = [100.0, 120.0, 145.0, 170.0];
/// The grid's altitudes, m: the docking envelope's range in altitude.
pub const SCHEDULE_ALTITUDES_M: [f64; 4] = [500.0, 3000.0, 5500.0, 8000.0];

/// One grid node: the paper's procedure's design and the refuelling procedure's, at the
/// same condition (the refuelling one on the airframe at its design cg; the core's tables
/// take the trim and models from `paper`, the gains from each).
#[derive(Debug, Clone)]
pub struct ScheduleNode {
    /// With [`DesignWeights::default`].
    pub paper: Synthesis,
    /// With [`DesignWeights::refuelling`], at [`super::REFUELLING_DESIGN_XCG`].
    pub refuel: Synthesis,
    /// The same on the light airframe ([`super::LIGHT_REFUELLING_MASS_FACTOR`]).
    pub refuel_light: Synthesis,
}

/// Every node, `nodes[altitude index][speed index]`.
#[derive(Debug, Clone)]
pub struct Schedule {
    /// The nodes.
    pub nodes: Vec<Vec<ScheduleNode>>,
}

/// A node whose synthesis failed, and why.
#[derive(Debug, thiserror::Error)]
#[error("gain schedule node {speed_mps} m/s, {altitude_m} m: {source}")]
pub struct ScheduleError {
    /// The node's true airspeed, m/s.
    pub speed_mps: f64,
    /// The node's altitude, m.
    pub altitude_m: f64,
    /// The synthesis's error.
    pub source: SynthesisError,
}

/// Synthesises every design at one condition: the paper's on the receiver `model`, the
/// refuelling procedure's on `refuel_model` and `light_model` (the airframe at its design
/// cg, [`super::REFUELLING_DESIGN_XCG`], at its two design masses); the node's trim and
/// models are `model`'s.
pub fn node(
    model: &F16,
    refuel_model: &F16,
    light_model: &F16,
    speed_mps: f64,
    altitude_m: f64,
) -> Result<ScheduleNode, ScheduleError> {
    let design = |model: &F16, w: &DesignWeights| {
        synthesize(
            model,
            speed_mps,
            altitude_m,
            CONTROL_PERIOD_S,
            PROBE_TIP_BODY_M,
            w,
        )
        .map_err(|source| ScheduleError {
            speed_mps,
            altitude_m,
            source,
        })
    };
    Ok(ScheduleNode {
        paper: design(model, &DesignWeights::default())?,
        refuel: design(refuel_model, &DesignWeights::refuelling())?,
        refuel_light: design(light_model, &DesignWeights::refuelling())?,
    })
}

/// The schedule for the receiver `model` (the nominal one for the core's tables), the
/// refuelling gains designed on `refuel_model` and `light_model` (see [`node`]).
pub fn synthesize_schedule(
    model: &F16,
    refuel_model: &F16,
    light_model: &F16,
) -> Result<Schedule, ScheduleError> {
    let nodes = SCHEDULE_ALTITUDES_M
        .iter()
        .map(|&h| {
            SCHEDULE_SPEEDS_MPS
                .iter()
                .map(|&v| node(model, refuel_model, light_model, v, h))
                .collect::<Result<Vec<_>, _>>()
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(Schedule { nodes })
}
