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

/// The six panels of one docking run.
pub fn write_dock_figure(path: &Path, run: &Run) -> Result<(), OutputError> {
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
        let tracked = |f: fn(&Sample) -> f32| {
            move |s: &Sample| s.measurement.tracked.then(|| f64::from(f(s)))
        };
        lines(
            &p[1],
            "Image error (normalised) while tracked",
            "time, s",
            "e",
            &[
                (
                    "e_x",
                    c[1],
                    over_time(run, tracked(|s| s.measurement.image_x)),
                ),
                (
                    "e_y",
                    c[2],
                    over_time(run, tracked(|s| s.measurement.image_y)),
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
        let deg = |v: f32| Some(f64::from(v).to_degrees());
        lines(
            &p[3],
            "Commands (throttle in %)",
            "time, s",
            "deg, %",
            &[
                (
                    "elevator",
                    c[0],
                    over_time(run, |s| deg(s.output.command.elevator_rad)),
                ),
                (
                    "aileron",
                    c[1],
                    over_time(run, |s| deg(s.output.command.aileron_rad)),
                ),
                (
                    "rudder",
                    c[2],
                    over_time(run, |s| deg(s.output.command.rudder_rad)),
                ),
                (
                    "throttle",
                    BLACK,
                    over_time(run, |s| Some(f64::from(s.output.command.throttle) * 100.0)),
                ),
            ],
        )?;
        cross_track(&p[4], run)?;
        lines(
            &p[5],
            "Mode (0 standby, 1 approach, 2 terminal, 3 docked, 4 breakaway)",
            "time, s",
            "mode",
            &[(
                "mode",
                BLACK,
                over_time(run, |s| Some(f64::from(s.output.mode as u8))),
            )],
        )
    })
}
