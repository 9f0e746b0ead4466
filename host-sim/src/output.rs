//! What a run leaves behind: the CSV time series, the JSON summary and the SVG plots.
//!
//! CSV: one row per control step, columns named with their frame and unit (the header is the
//! documentation; `docs/conventions.md` defines the frames). Plots: one SVG with the probe-tip
//! offset, the image error, the cross-track view at the drogue and the commands.
//!
//! Invariant: writing output never changes a run; every write error is returned, not ignored.

use std::path::Path;

use plotters::prelude::*;
use serde::Serialize;

use crate::linearize::design_coordinates;
use crate::sim::{Run, Sample};
use crate::world::drogue::CAPTURE_RADIUS_M;

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
    #[error("plot: {0}")]
    Plot(String),
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
    v_des_right_mps: f32,
    v_des_down_mps: f32,
    v_des_fwd_mps: f32,
    status_bits: u16,
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
            cmd_elevator_rad: o.command.elevator_rad,
            cmd_throttle: o.command.throttle,
            cmd_aileron_rad: o.command.aileron_rad,
            cmd_rudder_rad: o.command.rudder_rad,
            v_des_right_mps: o.v_des.x_right_mps,
            v_des_down_mps: o.v_des.y_down_mps,
            v_des_fwd_mps: o.v_des.z_fwd_mps,
            status_bits: o.status.0,
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

/// Writes the summary as pretty JSON.
pub fn write_summary(path: &Path, run: &Run) -> Result<(), OutputError> {
    let text = serde_json::to_string_pretty(&run.summary)?;
    std::fs::write(path, text + "\n").map_err(|source| OutputError::Io {
        path: path.display().to_string(),
        source,
    })
}

fn plot_err<E: std::fmt::Debug>(e: E) -> OutputError {
    OutputError::Plot(format!("{e:?}"))
}

type Series<'a> = (&'a str, RGBColor, Vec<(f64, f64)>);

fn time_panel(
    area: &DrawingArea<SVGBackend<'_>, plotters::coord::Shift>,
    title: &str,
    y_label: &str,
    series: &[Series<'_>],
) -> Result<(), OutputError> {
    let points = series.iter().flat_map(|s| s.2.iter());
    let (mut t1, mut lo, mut hi) = (1e-3_f64, f64::INFINITY, f64::NEG_INFINITY);
    for &(t, v) in points {
        t1 = t1.max(t);
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        (lo, hi) = (-1.0, 1.0);
    }
    let pad = ((hi - lo) * 0.05).max(1e-3);
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 18))
        .margin(8)
        .x_label_area_size(30)
        .y_label_area_size(55)
        .build_cartesian_2d(0.0..t1, (lo - pad)..(hi + pad))
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .x_desc("time, s")
        .y_desc(y_label)
        .draw()
        .map_err(plot_err)?;
    for (name, color, pts) in series {
        let c = *color;
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), c.stroke_width(2)))
            .map_err(plot_err)?
            .label(*name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], c.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(plot_err)?;
    Ok(())
}

/// The probe tip seen from behind, relative to the drogue centre (tanker right and up), with
/// the capture circle.
fn cross_track_panel(
    area: &DrawingArea<SVGBackend<'_>, plotters::coord::Shift>,
    run: &Run,
) -> Result<(), OutputError> {
    let pts: Vec<(f64, f64)> = run
        .samples
        .iter()
        .map(|s| (-s.drogue_from_tip_m.y, s.drogue_from_tip_m.z))
        .collect();
    let reach = pts.iter().fold(CAPTURE_RADIUS_M * 1.5, |m, p| {
        m.max(p.0.abs()).max(p.1.abs())
    }) * 1.05;
    let mut chart = ChartBuilder::on(area)
        .caption(
            "Probe tip relative to the drogue, seen from behind",
            ("sans-serif", 18),
        )
        .margin(8)
        .x_label_area_size(30)
        .y_label_area_size(55)
        .build_cartesian_2d(-reach..reach, -reach..reach)
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .x_desc("right, m")
        .y_desc("up, m")
        .draw()
        .map_err(plot_err)?;
    let circle = (0..=72).map(|i| {
        let a = f64::from(i) * std::f64::consts::TAU / 72.0;
        (CAPTURE_RADIUS_M * a.cos(), CAPTURE_RADIUS_M * a.sin())
    });
    chart
        .draw_series(LineSeries::new(circle, BLACK.stroke_width(1)))
        .map_err(plot_err)?;
    chart
        .draw_series(LineSeries::new(pts, BLUE.stroke_width(2)))
        .map_err(plot_err)?;
    if let Some(c) = run.contact {
        let last = run.samples.iter().rev().find(|s| s.time_s <= c.time_s);
        if let Some(s) = last {
            let p = (-s.drogue_from_tip_m.y, s.drogue_from_tip_m.z);
            chart
                .draw_series(std::iter::once(Circle::new(p, 5, RED.filled())))
                .map_err(plot_err)?;
        }
    }
    Ok(())
}

/// Writes the plots of a run as one SVG.
pub fn write_plots(path: &Path, run: &Run) -> Result<(), OutputError> {
    let root = SVGBackend::new(path, (1400, 1350)).into_drawing_area();
    root.fill(&WHITE).map_err(plot_err)?;
    let panels = root.split_evenly((3, 2));
    let ser = |f: &dyn Fn(&Sample) -> Option<f64>| -> Vec<(f64, f64)> {
        run.samples
            .iter()
            .filter_map(|s| f(s).map(|v| (s.time_s, v)))
            .collect()
    };
    time_panel(
        &panels[0],
        "Drogue centre minus probe tip (tanker axes)",
        "m",
        &[
            ("forward", BLUE, ser(&|s| Some(s.drogue_from_tip_m.x))),
            ("right", RED, ser(&|s| Some(s.drogue_from_tip_m.y))),
            ("down", GREEN, ser(&|s| Some(s.drogue_from_tip_m.z))),
        ],
    )?;
    let tracked = |f: fn(&Sample) -> f64| move |s: &Sample| s.measurement.tracked.then(|| f(s));
    time_panel(
        &panels[1],
        "Image error (normalised) while tracked",
        "e",
        &[
            (
                "e_x",
                RED,
                ser(&tracked(|s| f64::from(s.measurement.image_x))),
            ),
            (
                "e_y",
                GREEN,
                ser(&tracked(|s| f64::from(s.measurement.image_y))),
            ),
        ],
    )?;
    time_panel(
        &panels[2],
        "Desired (pale: actual) probe velocity, re axes",
        "m/s",
        &[
            (
                "v_des right",
                RED,
                ser(&|s| Some(f64::from(s.output.v_des.x_right_mps))),
            ),
            (
                "v_des down",
                GREEN,
                ser(&|s| Some(f64::from(s.output.v_des.y_down_mps))),
            ),
            (
                "v_des fwd",
                BLUE,
                ser(&|s| Some(f64::from(s.output.v_des.z_fwd_mps))),
            ),
            (
                "right",
                RGBColor(255, 150, 150),
                ser(&|s| Some(s.tip_velocity_mps.y)),
            ),
            (
                "down",
                RGBColor(150, 220, 150),
                ser(&|s| Some(s.tip_velocity_mps.z)),
            ),
            (
                "fwd",
                RGBColor(150, 150, 255),
                ser(&|s| Some(s.tip_velocity_mps.x)),
            ),
        ],
    )?;
    let deg = |v: f32| f64::from(v).to_degrees();
    time_panel(
        &panels[3],
        "Commands (throttle in %)",
        "deg, %",
        &[
            (
                "elevator",
                BLUE,
                ser(&|s| Some(deg(s.output.command.elevator_rad))),
            ),
            (
                "aileron",
                RED,
                ser(&|s| Some(deg(s.output.command.aileron_rad))),
            ),
            (
                "rudder",
                GREEN,
                ser(&|s| Some(deg(s.output.command.rudder_rad))),
            ),
            (
                "throttle",
                BLACK,
                ser(&|s| Some(f64::from(s.output.command.throttle) * 100.0)),
            ),
        ],
    )?;
    cross_track_panel(&panels[4], run)?;
    time_panel(
        &panels[5],
        "Mode (0 standby, 1 approach, 2 terminal, 3 docked, 4 breakaway)",
        "mode",
        &[(
            "mode",
            BLACK,
            ser(&|s| Some(f64::from(s.output.mode as u8))),
        )],
    )?;
    root.present().map_err(plot_err)?;
    Ok(())
}
