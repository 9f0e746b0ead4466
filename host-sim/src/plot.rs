//! Figures as PNG: the dock run's panels and the paper's experiment figures.
//!
//! Rendering is pure Rust (plotters' bitmap backend); text uses DejaVu Sans embedded in the
//! binary (`host-sim/assets/fonts`, Bitstream Vera licence, notice beside the font), so no
//! system font library is needed.
//!
//! Invariant: a figure is a pure function of the runs it is given; every error is returned.

use std::path::Path;
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::{FontStyle, register_font};

use ibvs_core::estimator::{TipGeometry, TipSight};
use ibvs_core::schedule::DESIGN;
use ibvs_core::{ControllerConfig, Mode, Procedure};
use serde::Deserialize;

use crate::output::OutputError;
use crate::sim::{Run, Sample};
use crate::world::drogue::CAPTURE_RADIUS_M;

/// DejaVu Sans, registered as plotters' "sans-serif".
const FONT_TTF: &[u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");

/// Registers the embedded font (once per process).
pub(crate) fn fonts() -> Result<(), String> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            register_font("sans-serif", FontStyle::Normal, FONT_TTF)
                .map_err(|_| "embedded font is invalid".to_string())
        })
        .clone()
}

/// An area of a figure.
pub type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

/// A named line: label, colour, points.
pub type Series<'a> = (&'a str, RGBColor, Vec<(f64, f64)>);

/// Line colours for successive runs or components.
pub const PALETTE: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
];

fn err(path: &Path) -> impl Fn(String) -> OutputError + '_ {
    move |reason| OutputError::Plot {
        path: path.display().to_string(),
        reason,
    }
}

/// A plotting backend's error as text (the backends' error types are not `std::error::Error`
/// in every version; their `Debug` form names the cause).
pub(crate) fn dbg<E: std::fmt::Debug>(e: E) -> String {
    format!("{e:?}")
}

/// Draws `draw` into a new PNG of `size` pixels at `path`.
pub fn figure(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(&Area<'_>) -> Result<(), String>,
) -> Result<(), OutputError> {
    fonts().map_err(err(path))?;
    let root = BitMapBackend::new(path, size).into_drawing_area();
    root.fill(&WHITE).map_err(dbg).map_err(err(path))?;
    draw(&root).map_err(err(path))?;
    root.present().map_err(dbg).map_err(err(path))
}

fn bounds<'a>(points: impl Iterator<Item = &'a (f64, f64)>) -> ((f64, f64), (f64, f64)) {
    let (mut x, mut y) = (
        (f64::INFINITY, f64::NEG_INFINITY),
        (f64::INFINITY, f64::NEG_INFINITY),
    );
    for &(a, b) in points {
        (x.0, x.1, y.0, y.1) = (x.0.min(a), x.1.max(a), y.0.min(b), y.1.max(b));
    }
    if !x.0.is_finite() {
        return ((0.0, 1.0), (-1.0, 1.0));
    }
    let pad = |(lo, hi): (f64, f64)| {
        let p = ((hi - lo) * 0.05).max(1e-3);
        (lo - p, hi + p)
    };
    (pad(x), pad(y))
}

/// A line chart: `series` against x, with axis labels and a legend.
pub fn lines(
    area: &Area<'_>,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series<'_>],
) -> Result<(), String> {
    let ((x0, x1), (y0, y1)) = bounds(series.iter().flat_map(|s| s.2.iter()));
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(60)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(dbg)?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(dbg)?;
    for (name, color, pts) in series {
        let c = *color;
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), c.stroke_width(2)))
            .map_err(dbg)?
            .label(*name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .label_font(("sans-serif", 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(dbg)
}

/// Time series of one quantity of every sample.
pub fn over_time(run: &Run, f: impl Fn(&Sample) -> Option<f64>) -> Vec<(f64, f64)> {
    run.samples
        .iter()
        .filter_map(|s| f(s).map(|v| (s.time_s, v)))
        .collect()
}

/// The probe tip seen from behind relative to the drogue centre, with the capture circle.
fn cross_track(area: &Area<'_>, run: &Run) -> Result<(), String> {
    let pts: Vec<(f64, f64)> = run
        .samples
        .iter()
        .map(|s| (-s.drogue_from_tip_m.y, s.drogue_from_tip_m.z))
        .collect();
    let reach = pts.iter().fold(CAPTURE_RADIUS_M * 1.5, |m, p| {
        m.max(p.0.abs()).max(p.1.abs())
    }) * 1.05;
    let (w, h) = area.dim_in_pixel();
    let side_margin = (w.saturating_sub(h) / 2) as i32;
    let square = area.margin(0, 0, side_margin, side_margin);
    let mut chart = ChartBuilder::on(&square)
        .caption(
            "Probe tip relative to the drogue, from behind",
            ("sans-serif", 20),
        )
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(60)
        .build_cartesian_2d(-reach..reach, -reach..reach)
        .map_err(dbg)?;
    chart
        .configure_mesh()
        .x_desc("right, m")
        .y_desc("up, m")
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(dbg)?;
    let circle = (0..=72).map(|i| {
        let a = f64::from(i) * std::f64::consts::TAU / 72.0;
        (CAPTURE_RADIUS_M * a.cos(), CAPTURE_RADIUS_M * a.sin())
    });
    chart
        .draw_series(LineSeries::new(circle, BLACK.stroke_width(1)))
        .map_err(dbg)?;
    chart
        .draw_series(LineSeries::new(pts, PALETTE[0].stroke_width(2)))
        .map_err(dbg)?;
    if let Some(s) = run
        .contact
        .and_then(|c| run.samples.iter().rev().find(|s| s.time_s <= c.time_s))
    {
        let p = (-s.drogue_from_tip_m.y, s.drogue_from_tip_m.z);
        chart
            .draw_series(std::iter::once(Circle::new(p, 6, PALETTE[1].filled())))
            .map_err(dbg)?;
    }
    Ok(())
}

/// Every controller mode with its name, in the order of the type's variants (read from
/// [`Mode`]'s own serde form: a mode added to the type appears here by itself).
pub fn mode_names() -> Vec<(Mode, String)> {
    (0u32..)
        .map_while(|i| {
            let m = Mode::deserialize(
                serde::de::value::U32Deserializer::<serde::de::value::Error>::new(i),
            )
            .ok()?;
            Some((m, format!("{m:?}")))
        })
        .collect()
}

/// The image error the controller steers to zero, at every step whose frame it accepted:
/// the drogue's image point minus its aim, and the aim's name. The paper's IBVS law aims at
/// its configured convergence point. The refuelling procedure steers the drogue's offset from
/// the probe tip to zero, so its aim is where the drogue appears when dead ahead of the tip
/// at the frame's depth: the tip's image point scaled by the tip's depth over the drogue's
/// (as `TipGeometry::drogue_from_tip` reads a frame at trim attitude), the tip's image point
/// being the running average of its measured ones the step keeps ([`TipSight`], replayed here
/// over the run's frames exactly as the step does it, from the configured geometry).
pub fn steered_image_error(
    samples: &[Sample],
    cfg: &ControllerConfig,
) -> (&'static str, Vec<(f64, [f64; 2])>) {
    let accepted = samples
        .iter()
        .filter(|s| s.output.measurement_error.is_none());
    let error = |s: &Sample, aim: [f32; 2]| {
        (
            s.time_s,
            [
                f64::from(s.measurement.image_x - aim[0]),
                f64::from(s.measurement.image_y - aim[1]),
            ],
        )
    };
    match cfg.procedure {
        Procedure::Paper => {
            let aim = cfg.ibvs.convergence_point;
            (
                "the convergence point",
                accepted.map(|s| error(s, aim)).collect(),
            )
        }
        Procedure::Refuelling => {
            let geometry =
                TipGeometry::new(&cfg.camera, cfg.probe_tip_body_m, DESIGN.trim.theta_rad);
            let tip_depth_m = geometry.tip_from_camera_m()[2];
            let mut sight = TipSight::new(&geometry);
            let e = accepted
                .map(|s| {
                    sight.observe(s.measurement.probe_tip, &cfg.estimator);
                    // An accepted frame's depth is positive.
                    let scale = tip_depth_m / s.measurement.depth_m;
                    error(s, sight.image().map(|t| t * scale))
                })
                .collect();
            ("the point dead ahead of the probe tip", e)
        }
    }
}

/// The controller's mode over time, on an axis labelled with the modes' names.
fn modes(area: &Area<'_>, run: &Run) -> Result<(), String> {
    let names = mode_names();
    let index = |m: Mode| names.iter().position(|(n, _)| *n == m).unwrap_or_default() as f64;
    let pts = over_time(run, |s| Some(index(s.output.mode)));
    let t_end = pts.last().map_or(1.0, |p| p.0.max(1e-3));
    let top = names.len() as f64 - 0.5;
    let mut chart = ChartBuilder::on(area)
        .caption("Mode", ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(120)
        .build_cartesian_2d(0.0..t_end, -0.5..top)
        .map_err(dbg)?;
    let label = |v: &f64| {
        let k = v.round();
        if (v - k).abs() < 1e-6 && k >= 0.0 {
            names
                .get(k as usize)
                .map(|(_, n)| n.clone())
                .unwrap_or_default()
        } else {
            String::new()
        }
    };
    chart
        .configure_mesh()
        .x_desc("time, s")
        .y_labels(names.len() * 2 + 1)
        .y_label_formatter(&label)
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(dbg)?;
    // A step line: each mode holds until the next sample.
    let mut step = Vec::with_capacity(pts.len() * 2);
    for w in pts.windows(2) {
        step.push(w[0]);
        step.push((w[1].0, w[0].1));
    }
    step.extend(pts.last());
    chart
        .draw_series(LineSeries::new(step, BLACK.stroke_width(2)))
        .map_err(dbg)?;
    Ok(())
}

/// The six panels of one docking run flown with `cfg`.
pub fn write_dock_figure(
    path: &Path,
    run: &Run,
    cfg: &ControllerConfig,
) -> Result<(), OutputError> {
    figure(path, (1500, 1400), |root| {
        let p = root.split_evenly((3, 2));
        let c = PALETTE;
        lines(
            &p[0],
            "Drogue centre minus probe tip (tanker axes)",
            "time, s",
            "m",
            &[
                (
                    "forward",
                    c[0],
                    over_time(run, |s| Some(s.drogue_from_tip_m.x)),
                ),
                (
                    "right",
                    c[1],
                    over_time(run, |s| Some(s.drogue_from_tip_m.y)),
                ),
                (
                    "down",
                    c[2],
                    over_time(run, |s| Some(s.drogue_from_tip_m.z)),
                ),
            ],
        )?;
        let (aim_name, errors) = steered_image_error(&run.samples, cfg);
        lines(
            &p[1],
            &format!("Image error the controller steers: drogue minus {aim_name}"),
            "time, s",
            "e (normalised image)",
            &[
                (
                    "e_x",
                    c[1],
                    errors.iter().map(|&(t, e)| (t, e[0])).collect(),
                ),
                (
                    "e_y",
                    c[2],
                    errors.iter().map(|&(t, e)| (t, e[1])).collect(),
                ),
            ],
        )?;
        let pale = |k: RGBColor| RGBColor(k.0 / 2 + 128, k.1 / 2 + 128, k.2 / 2 + 128);
        lines(
            &p[2],
            "Desired (pale: actual) probe velocity, re axes",
            "time, s",
            "m/s",
            &[
                (
                    "v_des right",
                    c[1],
                    over_time(run, |s| Some(f64::from(s.output.v_des.x_right_mps))),
                ),
                (
                    "v_des down",
                    c[2],
                    over_time(run, |s| Some(f64::from(s.output.v_des.y_down_mps))),
                ),
                (
                    "v_des fwd",
                    c[0],
                    over_time(run, |s| Some(f64::from(s.output.v_des.z_fwd_mps))),
                ),
                (
                    "right",
                    pale(c[1]),
                    over_time(run, |s| Some(s.tip_velocity_mps.y)),
                ),
                (
                    "down",
                    pale(c[2]),
                    over_time(run, |s| Some(s.tip_velocity_mps.z)),
                ),
                (
                    "fwd",
                    pale(c[0]),
                    over_time(run, |s| Some(s.tip_velocity_mps.x)),
                ),
            ],
        )?;
        let rad_deg = |v: f64| Some(v.to_degrees());
        lines(
            &p[3],
            "Commands (throttle in %)",
            "time, s",
            "deg, %",
            &[
                (
                    "elevator",
                    c[0],
                    over_time(run, |s| rad_deg(s.surfaces_commanded.elevator_rad)),
                ),
                (
                    "aileron",
                    c[1],
                    over_time(run, |s| rad_deg(s.surfaces_commanded.aileron_rad)),
                ),
                (
                    "rudder",
                    c[2],
                    over_time(run, |s| rad_deg(s.surfaces_commanded.rudder_rad)),
                ),
                (
                    "throttle",
                    BLACK,
                    over_time(run, |s| Some(s.surfaces_commanded.throttle * 100.0)),
                ),
            ],
        )?;
        cross_track(&p[4], run)?;
        modes(&p[5], run)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::receiver::{ReceiverState, StateVector};
    use ibvs_core::measurement::{CameraMeasurement, MeasurementError};
    use nalgebra::Vector3;

    fn sample(t: f64, image: [f32; 2], depth_m: f32, probe_tip: Option<[f32; 2]>) -> Sample {
        Sample {
            time_s: t,
            measurement: CameraMeasurement {
                seq: 1,
                tracked: true,
                image_x: image[0],
                image_y: image[1],
                depth_m,
                probe_tip,
            },
            output: ibvs_core::ControllerOutput::default(),
            drogue_tanker_m: Vector3::zeros(),
            tip_tanker_m: Vector3::zeros(),
            drogue_from_tip_m: Vector3::zeros(),
            tip_velocity_mps: Vector3::zeros(),
            state: ReceiverState::from_vector(&StateVector::zeros()),
            probe_tip_image: None,
            surfaces_commanded: crate::receiver::ReceiverCommand::default(),
        }
    }

    #[test]
    fn the_mode_axis_names_every_mode_of_the_type_in_its_order() {
        let names = mode_names();
        let got: Vec<&str> = names.iter().map(|(_, n)| n.as_str()).collect();
        assert_eq!(
            got,
            [
                "Standby",
                "PreContact",
                "Approach",
                "Terminal",
                "Docked",
                "MissedApproach",
                "Breakaway"
            ]
        );
        for (k, (m, _)) in names.iter().enumerate() {
            assert_eq!(*m as usize, k, "{m:?} plotted at its own number");
        }
    }

    /// The refuelling procedure's aim: a drogue dead ahead of the probe tip has no error
    /// (its raw image point is well off the centre: the set-back camera's parallax); a tip
    /// sighting moves the aim as the step's running average does; a rejected frame is not
    /// plotted. The paper's: the image point minus the convergence point.
    #[test]
    fn the_image_error_is_measured_from_the_aim_the_controller_steers_to() {
        let cfg = ControllerConfig::default();
        let g = TipGeometry::new(&cfg.camera, cfg.probe_tip_body_m, DESIGN.trim.theta_rad);
        let (tip, tz) = (g.tip_image(), g.tip_from_camera_m()[2]);
        let depth = 4.0_f32;
        let ahead = tip.map(|t| t * (tz / depth));
        assert!(
            ahead[1].abs() > 0.01,
            "the raw image point is off the centre: {ahead:?}"
        );
        let seen = [tip[0] + 0.01, tip[1]];
        let mut rejected = sample(0.02, [0.3, 0.3], depth, None);
        rejected.output.measurement_error = Some(MeasurementError::NotTracked);
        let samples = [
            sample(0.0, ahead, depth, None),
            rejected,
            sample(0.04, ahead, depth, Some(seen)),
        ];
        let (name, e) = steered_image_error(&samples, &cfg);
        assert_eq!(name, "the point dead ahead of the probe tip");
        assert_eq!(e.len(), 2, "the rejected frame is left out");
        assert_eq!(e[0], (0.0, [0.0, 0.0]));
        let k = cfg.estimator.tip_sight_filter;
        let moved = (tip[0] + k * (seen[0] - tip[0])) * (tz / depth);
        assert_eq!(e[1], (0.04, [f64::from(ahead[0] - moved), 0.0]));
        assert!(e[1].1[0] < 0.0);

        let mut paper = ControllerConfig::paper();
        paper.ibvs.convergence_point = [0.1, -0.05];
        let (name, e) = steered_image_error(&[sample(0.0, [0.25, 0.05], depth, None)], &paper);
        assert_eq!(name, "the convergence point");
        assert_eq!(
            e,
            [(0.0, [f64::from(0.25_f32 - 0.1), f64::from(0.05_f32 + 0.05)])]
        );
    }
}
