//! What a run leaves behind: the CSV time series and the JSON summary (plots: [`crate::plot`]).
//!
//! CSV: one row per control step, columns named with their frame and unit (the header is the
//! documentation; `docs/conventions.md` defines the frames).
//!
//! Invariant: writing output never changes a run; every write error is returned, not ignored.

use std::path::Path;

use serde::Serialize;

use crate::linearize::design_coordinates;
use crate::sim::{Run, Sample, Summary};

/// Why output could not be written.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// File system.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The error.
        source: std::io::Error,
    },
    /// CSV encoding.
    #[error(transparent)]
    Csv(#[from] csv::Error),
    /// JSON encoding.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    /// Plotting.
    #[error("plot {path}: {reason}")]
    Plot {
        /// The file.
        path: String,
        /// What went wrong.
        reason: String,
    },
    /// MCAP encoding (the flight-test log).
    #[error("MCAP: {0}")]
    Mcap(#[from] mcap::McapError),
    /// GIF encoding (the animation).
    #[error("GIF: {0}")]
    Gif(#[from] gif::EncodingError),
    /// Two things that must have the same length do not.
    #[error("{what}: {left} against {right}")]
    Mismatch {
        /// What was compared.
        what: &'static str,
        /// One length.
        left: usize,
        /// The other.
        right: usize,
    },
}

/// One CSV row.
#[derive(Debug, Serialize)]
struct Row {
    time_s: f64,
    mode: String,
    tracked: bool,
    image_x: f32,
    image_y: f32,
    depth_m: f32,
    drogue_x_tanker_m: f64,
    drogue_y_tanker_m: f64,
    drogue_z_tanker_m: f64,
    drogue_from_tip_fwd_m: f64,
    drogue_from_tip_right_m: f64,
    drogue_from_tip_down_m: f64,
    tip_vel_fwd_mps: f64,
    tip_vel_right_mps: f64,
    tip_vel_down_mps: f64,
    speed_mps: f64,
    alpha_rad: f64,
    beta_rad: f64,
    phi_rad: f64,
    theta_rad: f64,
    psi_rad: f64,
    p_radps: f64,
    q_radps: f64,
    r_radps: f64,
    cg_north_m: f64,
    cg_east_m: f64,
    altitude_m: f64,
    engine_power_pct: f64,
    elevator_rad: f64,
    aileron_rad: f64,
    rudder_rad: f64,
    cmd_elevator_rad: f32,
    cmd_throttle: f32,
    cmd_aileron_rad: f32,
    cmd_rudder_rad: f32,
    sp_roll_rad: Option<f32>,
    sp_pitch_rad: Option<f32>,
    sp_yaw_rad: Option<f32>,
    v_des_right_mps: f32,
    v_des_down_mps: f32,
    v_des_fwd_mps: f32,
    status_bits: u16,
    attempt: u8,
    no_go: String,
    est_offset_right_m: f32,
    est_offset_down_m: f32,
    est_drogue_vel_right_mps: f32,
    est_drogue_vel_down_mps: f32,
    est_drogue_vel_fwd_mps: f32,
    est_depth_m: f32,
    predicted_miss_m: f32,
    learned_tip_image_x: Option<f32>,
    learned_tip_image_y: Option<f32>,
}

impl From<&Sample> for Row {
    fn from(s: &Sample) -> Self {
        let x = &s.state;
        let [theta, speed, alpha, q, _, psi, phi, beta, p, r] = design_coordinates(x);
        let (o, m) = (&s.output, &s.measurement);
        Row {
            time_s: s.time_s,
            mode: format!("{:?}", o.mode),
            tracked: m.tracked,
            image_x: m.image_x,
            image_y: m.image_y,
            depth_m: m.depth_m,
            drogue_x_tanker_m: s.drogue_tanker_m.x,
            drogue_y_tanker_m: s.drogue_tanker_m.y,
            drogue_z_tanker_m: s.drogue_tanker_m.z,
            drogue_from_tip_fwd_m: s.drogue_from_tip_m.x,
            drogue_from_tip_right_m: s.drogue_from_tip_m.y,
            drogue_from_tip_down_m: s.drogue_from_tip_m.z,
            tip_vel_fwd_mps: s.tip_velocity_mps.x,
            tip_vel_right_mps: s.tip_velocity_mps.y,
            tip_vel_down_mps: s.tip_velocity_mps.z,
            speed_mps: speed,
            alpha_rad: alpha,
            beta_rad: beta,
            phi_rad: phi,
            theta_rad: theta,
            psi_rad: psi,
            p_radps: p,
            q_radps: q,
            r_radps: r,
            cg_north_m: x.pos_ned_m.x,
            cg_east_m: x.pos_ned_m.y,
            altitude_m: -x.pos_ned_m.z,
            engine_power_pct: x.engine_power_pct,
            elevator_rad: x.surfaces_rad.elevator_rad,
            aileron_rad: x.surfaces_rad.aileron_rad,
            rudder_rad: x.surfaces_rad.rudder_rad,
            cmd_elevator_rad: s.surfaces_commanded.elevator_rad as f32,
            cmd_throttle: s.surfaces_commanded.throttle as f32,
            cmd_aileron_rad: s.surfaces_commanded.aileron_rad as f32,
            cmd_rudder_rad: s.surfaces_commanded.rudder_rad as f32,
            sp_roll_rad: o.command.attitude().map(|a| a.roll_rad),
            sp_pitch_rad: o.command.attitude().map(|a| a.pitch_rad),
            sp_yaw_rad: o.command.attitude().map(|a| a.yaw_rad),
            v_des_right_mps: o.v_des.x_right_mps,
            v_des_down_mps: o.v_des.y_down_mps,
            v_des_fwd_mps: o.v_des.z_fwd_mps,
            status_bits: o.status.0,
            attempt: o.attempt,
            no_go: o.no_go.map_or_else(String::new, |r| format!("{r:?}")),
            est_offset_right_m: o.estimate.offset_m[0],
            est_offset_down_m: o.estimate.offset_m[1],
            est_drogue_vel_right_mps: o.estimate.drogue_velocity_mps[0],
            est_drogue_vel_down_mps: o.estimate.drogue_velocity_mps[1],
            est_drogue_vel_fwd_mps: o.estimate.drogue_velocity_mps[2],
            est_depth_m: o.estimate.depth_m,
            predicted_miss_m: o.predicted_miss_m,
            learned_tip_image_x: s.probe_tip_image.map(|p| p[0]),
            learned_tip_image_y: s.probe_tip_image.map(|p| p[1]),
        }
    }
}

/// Writes the time series as CSV.
pub fn write_csv(path: &Path, run: &Run) -> Result<(), OutputError> {
    let mut w = csv::Writer::from_path(path)?;
    for s in &run.samples {
        w.serialize(Row::from(s))?;
    }
    w.flush().map_err(|source| OutputError::Io {
        path: path.display().to_string(),
        source,
    })
}

/// The one-line summary `dock` prints: outcome, miss, closing speed, time, breakaway reason.
pub fn one_line(s: &Summary) -> String {
    let num =
        |v: Option<f64>, unit: &str| v.map_or("n/a".to_string(), |v| format!("{v:.3} {unit}"));
    let attempts = if s.attempts > 1 {
        format!(", attempt {}", s.attempts)
    } else {
        String::new()
    };
    format!(
        "{:?}: miss {}, closure {}, at {:.2} s{attempts}{}",
        s.outcome,
        num(s.miss_m, "m"),
        num(s.closure_mps, "m/s"),
        s.time_s,
        s.breakaway_reason
            .as_ref()
            .map_or(String::new(), |r| format!(", breakaway: {r}")),
    )
}

/// Writes the summary as pretty JSON.
pub fn write_summary(path: &Path, run: &Run) -> Result<(), OutputError> {
    let text = serde_json::to_string_pretty(&run.summary)?;
    std::fs::write(path, text + "\n").map_err(|source| OutputError::Io {
        path: path.display().to_string(),
        source,
    })
}
