//! The docking as an animated GIF: a chase view of receiver, probe, hose and drogue (side and
//! top, tanker frame) beside the camera's own image (LED centroids, fitted circle, the probe
//! tip's marker, the aim point, image error), with time, attempt, mode, depth, the drogue
//! estimator's belief, the go/no-go gate and commands written out.
//!
//! Frames are drawn with plotters into an RGB buffer (axes, titles and the camera frame once,
//! as a background; each frame copies it and draws what moves) and encoded here with the `gif`
//! crate: one fixed global palette (the 216 colours of the 6-level RGB cube and a 39-step grey
//! ramp; every pixel maps to its nearest entry by rounding, no per-frame quantiser) and, after
//! the first frame, only the rectangle that changed, with unchanged pixels transparent.
//!
//! Layout ([`WIDTH_PX`] x [`HEIGHT_PX`]): side view (forward x, up −z) top left, top view
//! (forward x, right y) below it, on the same fixed scale (metres per pixel equal on both axes
//! and both views, bounds fitted once to the whole run); the camera image top right (scaled
//! from its pixel size, u right, v down); the numbers below it. One frame every
//! [`AnimationOptions::steps_per_frame`] control steps and the run's last step, shown at
//! `steps_per_frame * Ts` each (real time by default), the last held
//! [`AnimationOptions::hold_last_cs`].
//!
//! The receiver is a schematic outline (fuselage, wings, tails, probe) placed by the true CG
//! and attitude; its probe tip is the run's. The overlay ([`overlay_lines`]) is what the
//! controller reports in its `ControllerOutput`: the mode and, in the refuelling procedure, the
//! attempt, the drogue estimator's estimate (also drawn in the chase views, where the
//! controller believes the drogue is) and the gate: the predicted miss against the gate radius
//! while it is being decided, the go or no-go (when, with what prediction, why) once it was.
//! The aim in the camera's image is where the controller steers the drogue's image
//! ([`Recording::aim`]).
//!
//! Invariants: a GIF is a pure function of the run, the recording and the options (no clock,
//! no randomness, the same bytes every time); it has exactly [`frame_steps`]`(n, k).len()`
//! frames of [`WIDTH_PX`] x [`HEIGHT_PX`]; every error is returned.

use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

use gif::{DisposalMethod, Encoder, Frame, Repeat};
use ibvs_core::controller::StatusFlags;
use ibvs_core::estimator::DrogueEstimate;
use ibvs_core::mode::RefuelLimits;
use ibvs_core::procedure::Procedure;
use ibvs_core::{Controller, Mode};
use nalgebra::Vector3;
use plotters::prelude::*;

use crate::output::{self, OutputError};
use crate::plot::{self, Area, dbg};
use crate::record::{ImageGeometry, Recording, StepRecord};
use crate::sim::{Run, Sample};
use crate::synthesis::CONTROL_PERIOD_S;
use crate::world::drogue::CAPTURE_RADIUS_M;
use crate::world::ned_from_body;

/// Width of every frame, px.
pub const WIDTH_PX: u32 = 960;
/// Height of every frame, px.
pub const HEIGHT_PX: u32 = 540;
/// Width of the chase views (left column), px.
const VIEW_W: i32 = 540;
/// Height of each chase view, px.
const VIEW_H: i32 = 270;
/// Height of the camera panel (right column, top), px.
const CAMERA_H: i32 = 290;
/// Line spacing of the numbers, px.
const LINE_H: i32 = 20;
/// Palette index of "unchanged since the previous frame".
const TRANSPARENT: u8 = 255;
/// Grey-ramp entries after the 216-colour cube.
const GREYS: u8 = 39;

/// Schematic receiver outline, body axes from the CG, m: nose (the bow-wave reference,
/// 3.75 m ahead) to tail 15 m aft, 9.45 m span (the F-16's length and span).
const FUSELAGE_BODY_M: [[f64; 3]; 2] = [[3.75, 0.0, 0.0], [-11.25, 0.0, 0.0]];
/// Right wing and right horizontal tail (mirrored for the left), body axes, m.
const WING_BODY_M: [[f64; 3]; 4] = [
    [1.0, 0.5, 0.0],
    [-3.0, 4.72, 0.0],
    [-4.6, 4.72, 0.0],
    [-4.6, 0.5, 0.0],
];
const TAIL_BODY_M: [[f64; 3]; 4] = [
    [-8.6, 0.5, 0.0],
    [-10.6, 2.8, 0.0],
    [-11.4, 2.8, 0.0],
    [-11.2, 0.5, 0.0],
];
/// Vertical fin, body axes, m (z up is negative).
const FIN_BODY_M: [[f64; 3]; 4] = [
    [-7.4, 0.0, -0.8],
    [-10.6, 0.0, -3.6],
    [-11.4, 0.0, -3.6],
    [-11.2, 0.0, -0.8],
];
/// Probe root, body axes, m (the probe runs from here to the probe tip).
const PROBE_ROOT_BODY_M: [f64; 3] = [2.5, 0.54, -0.86];

const INK: RGBColor = RGBColor(0, 0, 0);
const RECEIVER: RGBColor = RGBColor(0, 51, 153);
const RECEIVER_FILL: RGBColor = RGBColor(153, 204, 255);
const HOSE: RGBColor = RGBColor(102, 102, 102);
const DROGUE: RGBColor = RGBColor(204, 0, 0);
const TIP: RGBColor = RGBColor(0, 102, 204);
const TIP_TRAIL: RGBColor = RGBColor(102, 153, 255);
const DROGUE_TRAIL: RGBColor = RGBColor(255, 153, 153);
const SKY: RGBColor = RGBColor(17, 17, 17);
const LED: RGBColor = RGBColor(255, 255, 0);
const FIT: RGBColor = RGBColor(0, 255, 0);
const AIM: RGBColor = RGBColor(0, 204, 255);
const ERROR: RGBColor = RGBColor(255, 51, 51);
const TRUTH: RGBColor = RGBColor(255, 0, 255);
const ESTIMATE: RGBColor = RGBColor(255, 153, 0);
const TIP_MARKER: RGBColor = RGBColor(102, 153, 255);

/// How to animate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AnimationOptions {
    /// Control steps per frame (5: a frame every 0.1 s of simulated time).
    pub steps_per_frame: usize,
    /// How long the last frame is shown, 1/100 s.
    pub hold_last_cs: u16,
}

impl Default for AnimationOptions {
    fn default() -> Self {
        Self {
            steps_per_frame: 5,
            hold_last_cs: 200,
        }
    }
}

/// What was written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct AnimationStats {
    /// Frames.
    pub frames: usize,
    /// Frame width, px.
    pub width_px: u32,
    /// Frame height, px.
    pub height_px: u32,
    /// Delay of every frame but the last, 1/100 s.
    pub frame_delay_cs: u16,
    /// File size, bytes.
    pub bytes: u64,
}

/// The control steps drawn, for a run of `samples` steps and `steps_per_frame`: every
/// `steps_per_frame`-th from 0, and the last.
pub fn frame_steps(samples: usize, steps_per_frame: usize) -> Vec<usize> {
    let mut v: Vec<usize> = (0..samples).step_by(steps_per_frame.max(1)).collect();
    if let Some(last) = samples.checked_sub(1)
        && v.last() != Some(&last)
    {
        v.push(last);
    }
    v
}

/// A chase view: where it is on the canvas, what it shows, on a fixed scale.
#[derive(Debug, Clone, Copy)]
struct View {
    /// Plotting rectangle, canvas px: left, top, right, bottom.
    px: (i32, i32, i32, i32),
    /// Data range shown, m: horizontal and vertical.
    x: (f64, f64),
    y: (f64, f64),
    /// Vertical coordinate of a tanker-frame point: up (−z) or right (y).
    vertical: fn(&Vector3<f64>) -> f64,
}

impl View {
    fn map(&self, x: f64, y: f64) -> (i32, i32) {
        let (l, t, r, b) = self.px;
        let u = f64::from(l) + (x - self.x.0) / (self.x.1 - self.x.0) * f64::from(r - l);
        let v = f64::from(b) - (y - self.y.0) / (self.y.1 - self.y.0) * f64::from(b - t);
        (u.round() as i32, v.round() as i32)
    }

    fn project(&self, p: &Vector3<f64>) -> (f64, f64) {
        (p.x, (self.vertical)(p))
    }

    /// The part of segment `a`-`b` (data coordinates) inside the view (Liang-Barsky).
    fn clip(&self, a: (f64, f64), b: (f64, f64)) -> Option<((f64, f64), (f64, f64))> {
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        for (p, q) in [
            (-dx, a.0 - self.x.0),
            (dx, self.x.1 - a.0),
            (-dy, a.1 - self.y.0),
            (dy, self.y.1 - a.1),
        ] {
            if p == 0.0 {
                if q < 0.0 {
                    return None;
                }
            } else {
                let r = q / p;
                if p < 0.0 {
                    t0 = t0.max(r);
                } else {
                    t1 = t1.min(r);
                }
            }
        }
        (t0 <= t1).then_some((
            (a.0 + t0 * dx, a.1 + t0 * dy),
            (a.0 + t1 * dx, a.1 + t1 * dy),
        ))
    }

    fn contains(&self, p: (f64, f64)) -> bool {
        (self.x.0..=self.x.1).contains(&p.0) && (self.y.0..=self.y.1).contains(&p.1)
    }

    /// Draws the polyline through `points` (tanker frame), clipped to the view.
    fn polyline(
        &self,
        area: &Area<'_>,
        points: &[Vector3<f64>],
        style: ShapeStyle,
    ) -> Result<(), String> {
        for w in points.windows(2) {
            if let Some((a, b)) = self.clip(self.project(&w[0]), self.project(&w[1])) {
                area.draw(&PathElement::new(
                    vec![self.map(a.0, a.1), self.map(b.0, b.1)],
                    style,
                ))
                .map_err(dbg)?;
            }
        }
        Ok(())
    }

    /// Fills the polygon through `points` (tanker frame), clipped to the view
    /// (Sutherland-Hodgman against each edge of the view).
    fn polygon(
        &self,
        area: &Area<'_>,
        points: &[Vector3<f64>],
        style: ShapeStyle,
    ) -> Result<(), String> {
        let mut poly: Vec<(f64, f64)> = points.iter().map(|p| self.project(p)).collect();
        let edges: [(Coordinate, f64, bool); 4] = [
            (|p| p.0, self.x.0, true),
            (|p| p.0, self.x.1, false),
            (|p| p.1, self.y.0, true),
            (|p| p.1, self.y.1, false),
        ];
        for (coord, limit, above) in edges {
            let inside = |p: (f64, f64)| (coord(p) >= limit) == above || coord(p) == limit;
            let mut out = Vec::with_capacity(poly.len() + 2);
            for (i, &b) in poly.iter().enumerate() {
                let a = poly[(i + poly.len() - 1) % poly.len()];
                let cut = |a: (f64, f64), b: (f64, f64)| {
                    let t = (limit - coord(a)) / (coord(b) - coord(a));
                    (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1))
                };
                match (inside(a), inside(b)) {
                    (true, true) => out.push(b),
                    (true, false) => out.push(cut(a, b)),
                    (false, true) => {
                        out.push(cut(a, b));
                        out.push(b);
                    }
                    (false, false) => {}
                }
            }
            poly = out;
            if poly.is_empty() {
                return Ok(());
            }
        }
        let px: Vec<(i32, i32)> = poly.iter().map(|p| self.map(p.0, p.1)).collect();
        area.draw(&Polygon::new(px, style)).map_err(dbg)
    }

    /// Draws a dot of `radius_px` at `p` (tanker frame) if it is in view.
    fn dot(
        &self,
        area: &Area<'_>,
        p: &Vector3<f64>,
        radius_px: i32,
        style: ShapeStyle,
    ) -> Result<(), String> {
        let q = self.project(p);
        if self.contains(q) {
            area.draw(&Circle::new(self.map(q.0, q.1), radius_px, style))
                .map_err(dbg)?;
        }
        Ok(())
    }
}

/// One coordinate of a view point (for clipping against one edge).
type Coordinate = fn((f64, f64)) -> f64;

fn up(p: &Vector3<f64>) -> f64 {
    -p.z
}

fn right(p: &Vector3<f64>) -> f64 {
    p.y
}

/// Data bounds of both views on one scale: every probe-tip and drogue position of the run,
/// 10 m aft of the tip (the receiver's nose and wings) and 4 m ahead of the drogue (the hose's
/// last links), padded, widened so that metres per pixel are equal on both axes.
fn fit_views(run: &Run, plot_w_px: f64, plot_h_px: f64) -> [((f64, f64), (f64, f64)); 2] {
    let mut x = (f64::INFINITY, f64::NEG_INFINITY);
    let mut ys = [(f64::INFINITY, f64::NEG_INFINITY); 2];
    for s in &run.samples {
        for p in [&s.tip_tanker_m, &s.drogue_tanker_m] {
            x = (x.0.min(p.x), x.1.max(p.x));
            for (y, v) in ys.iter_mut().zip([up(p), right(p)]) {
                *y = (y.0.min(v), y.1.max(v));
            }
        }
    }
    if !x.0.is_finite() {
        x = (-20.0, -10.0);
        ys = [(-6.0, -4.0), (-1.0, 1.0)];
    }
    let x = (x.0 - 10.0, x.1 + 4.0);
    let ys = ys.map(|(lo, hi)| (lo - 2.0, hi + 2.0));
    // One scale, m/px, for both views: the largest any range needs.
    let scale = ys
        .iter()
        .map(|y| (y.1 - y.0) / plot_h_px)
        .fold((x.1 - x.0) / plot_w_px, f64::max);
    let widen = |(lo, hi): (f64, f64), px: f64| {
        let mid = (lo + hi) / 2.0;
        (mid - scale * px / 2.0, mid + scale * px / 2.0)
    };
    let x = widen(x, plot_w_px);
    ys.map(|y| (x, widen(y, plot_h_px)))
}

/// The camera panel: image pixel `(u, v)` to canvas px.
#[derive(Debug, Clone, Copy)]
struct CameraPanel {
    left: f64,
    top: f64,
    scale: f64,
    geometry: ImageGeometry,
}

impl CameraPanel {
    fn map(&self, u: f64, v: f64) -> (i32, i32) {
        (
            (self.left + u * self.scale).round() as i32,
            (self.top + v * self.scale).round() as i32,
        )
    }

    fn map_normalised(&self, x: f64, y: f64) -> (i32, i32) {
        let (u, v) = self.geometry.to_px(x, y);
        self.map(u, v)
    }

    fn inside(&self, u: f64, v: f64) -> bool {
        (0.0..=self.geometry.width_px).contains(&u) && (0.0..=self.geometry.height_px).contains(&v)
    }
}

/// Static layout and background of every frame.
struct Layout {
    views: [View; 2],
    camera: CameraPanel,
    /// Top-left corner of the numbers, canvas px.
    text: (i32, i32),
    background: Vec<u8>,
}

const CHART_MARGIN: i32 = 6;
const X_LABELS: i32 = 30;
const Y_LABELS: i32 = 44;
const TITLE_H: i32 = 22;

fn layout(run: &Run, rec: &Recording) -> Result<Layout, String> {
    plot::fonts()?;
    let (w, h) = (WIDTH_PX, HEIGHT_PX);
    let mut background = vec![0u8; (w * h * 3) as usize];
    let plot_w = f64::from(VIEW_W - 2 * CHART_MARGIN - Y_LABELS);
    let plot_h = f64::from(VIEW_H - 2 * CHART_MARGIN - X_LABELS - TITLE_H);
    let bounds = fit_views(run, plot_w, plot_h);
    let titles = [
        ("Side view, tanker frame", "forward x, m", "up −z, m"),
        ("Top view, tanker frame", "forward x, m", "right y, m"),
    ];
    let mut views = Vec::new();
    let camera;
    {
        let root = BitMapBackend::with_buffer(&mut background, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(dbg)?;
        let (left, right_col) = root.split_horizontally(VIEW_W);
        let halves = left.split_evenly((2, 1));
        for (i, (area, (title, xl, yl))) in halves.iter().zip(titles).enumerate() {
            area.draw_text(
                title,
                &("sans-serif", 16).into_font().color(&INK),
                (Y_LABELS, 4),
            )
            .map_err(dbg)?;
            let body = area.margin(TITLE_H, 0, 0, 0);
            let (x, y) = bounds[i];
            let mut chart = ChartBuilder::on(&body)
                .margin(CHART_MARGIN)
                .x_label_area_size(X_LABELS)
                .y_label_area_size(Y_LABELS)
                .build_cartesian_2d(x.0..x.1, y.0..y.1)
                .map_err(dbg)?;
            chart
                .configure_mesh()
                .x_desc(xl)
                .y_desc(yl)
                .light_line_style(WHITE)
                .bold_line_style(RGBColor(235, 235, 235))
                .label_style(("sans-serif", 12))
                .axis_desc_style(("sans-serif", 12))
                .draw()
                .map_err(dbg)?;
            let (xr, yr) = chart.plotting_area().get_pixel_range();
            views.push(View {
                px: (xr.start, yr.start, xr.end - 1, yr.end - 1),
                x,
                y,
                vertical: if i == 0 { up } else { right },
            });
        }
        // The camera: its image scaled into the right column, below a title.
        let g = rec.image;
        let (cw, _) = right_col.dim_in_pixel();
        let avail_w = f64::from(cw) - 20.0;
        let avail_h = f64::from(CAMERA_H - TITLE_H - 8);
        let scale = (avail_w / g.width_px).min(avail_h / g.height_px);
        let img_w = g.width_px * scale;
        let left_px = f64::from(VIEW_W) + (f64::from(cw) - img_w) / 2.0;
        let top_px = f64::from(TITLE_H + 4);
        camera = CameraPanel {
            left: left_px,
            top: top_px,
            scale,
            geometry: g,
        };
        root.draw_text(
            &format!(
                "Camera, {} x {} px: LEDs, fit, tip, aim +, error",
                g.width_px, g.height_px
            ),
            &("sans-serif", 16).into_font().color(&INK),
            (VIEW_W + 10, 4),
        )
        .map_err(dbg)?;
        let (x0, y0) = camera.map(0.0, 0.0);
        let (x1, y1) = camera.map(g.width_px, g.height_px);
        root.draw(&Rectangle::new([(x0, y0), (x1, y1)], SKY.filled()))
            .map_err(dbg)?;
        // The principal point's cross hairs, faint.
        let (pu, pv) = camera.map(g.principal_u_px, g.principal_v_px);
        let faint = RGBColor(51, 51, 51);
        root.draw(&PathElement::new(vec![(x0, pv), (x1, pv)], faint))
            .map_err(dbg)?;
        root.draw(&PathElement::new(vec![(pu, y0), (pu, y1)], faint))
            .map_err(dbg)?;
        draw_legend(&root)?;
    }
    let views = [views[0], views[1]];
    Ok(Layout {
        views,
        camera,
        text: (VIEW_W + 10, CAMERA_H + 6),
        background,
    })
}

/// Receiver outline polygons (closed) and the fuselage line in the tanker frame, for one
/// sample: wings and tails first, fuselage last.
fn receiver_outline(s: &Sample, r: &StepRecord) -> Vec<Vec<Vector3<f64>>> {
    let rot = ned_from_body(&s.state);
    let cg = r.world.receiver_cg_tanker_m;
    let at = |b: &[f64; 3]| cg + rot * Vector3::from(*b);
    let mirror = |b: &[f64; 3]| [b[0], -b[1], b[2]];
    let mut shapes = Vec::new();
    for shape in [&WING_BODY_M, &TAIL_BODY_M] {
        shapes.push(shape.iter().map(at).collect());
        shapes.push(shape.iter().map(|b| at(&mirror(b))).collect());
    }
    shapes.push(FIN_BODY_M.iter().map(at).collect());
    shapes.push(FUSELAGE_BODY_M.iter().map(at).collect());
    shapes
}

/// The drogue ring's in-plane unit vectors (right-ish, down-ish) for its axis.
fn ring_basis(axis: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let a = axis.try_normalize(1e-9).unwrap_or(-Vector3::x());
    let e2 = (Vector3::z() - a * a.z)
        .try_normalize(1e-6)
        .unwrap_or(Vector3::x());
    (a.cross(&e2), e2)
}

fn draw_views(
    area: &Area<'_>,
    l: &Layout,
    run: &Run,
    rec: &Recording,
    k: usize,
) -> Result<(), String> {
    let (s, r) = (&run.samples[k], &rec.steps[k]);
    let trail_tip: Vec<Vector3<f64>> = run.samples[..=k].iter().map(|s| s.tip_tanker_m).collect();
    let trail_drogue: Vec<Vector3<f64>> = run.samples[..=k]
        .iter()
        .map(|s| s.drogue_tanker_m)
        .collect();
    let (e1, e2) = ring_basis(&r.world.drogue_axis_tanker);
    let radius = CAPTURE_RADIUS_M;
    let ring: Vec<Vector3<f64>> = (0..=24)
        .map(|i| {
            let a = f64::from(i) * std::f64::consts::TAU / 24.0;
            s.drogue_tanker_m + (e1 * a.cos() + e2 * a.sin()) * radius
        })
        .collect();
    let probe = vec![
        r.world.receiver_cg_tanker_m + ned_from_body(&s.state) * Vector3::from(PROBE_ROOT_BODY_M),
        s.tip_tanker_m,
    ];
    let estimate = estimated_drogue(s, rec);
    for v in &l.views {
        v.polyline(area, &trail_drogue, DROGUE_TRAIL.stroke_width(1))?;
        v.polyline(area, &trail_tip, TIP_TRAIL.stroke_width(1))?;
        let outline = receiver_outline(s, r);
        if let Some((fuselage, surfaces)) = outline.split_last() {
            for shape in surfaces {
                v.polygon(area, shape, RECEIVER_FILL.filled())?;
                let mut closed = shape.clone();
                closed.extend(shape.first().copied());
                v.polyline(area, &closed, RECEIVER.stroke_width(1))?;
            }
            v.polyline(area, fuselage, RECEIVER.stroke_width(4))?;
        }
        v.polyline(area, &probe, INK.stroke_width(3))?;
        v.polyline(area, &r.world.hose_tanker_m, HOSE.stroke_width(3))?;
        for node in &r.world.hose_tanker_m {
            v.dot(area, node, 2, HOSE.filled())?;
        }
        v.polyline(area, &ring, DROGUE.stroke_width(2))?;
        v.dot(area, &s.drogue_tanker_m, 3, DROGUE.filled())?;
        v.dot(area, &s.tip_tanker_m, 3, TIP.filled())?;
        if let Some(e) = &estimate {
            v.dot(area, e, 5, ESTIMATE.stroke_width(2))?;
        }
    }
    Ok(())
}

/// Where the controller believes the drogue centre is, tanker frame: the true probe tip plus
/// the drogue estimator's offset and depth (refuelling procedure, once it has an estimate).
fn estimated_drogue(s: &Sample, rec: &Recording) -> Option<Vector3<f64>> {
    let e = &s.output.estimate;
    (rec.config.procedure == Procedure::Refuelling && *e != DrogueEstimate::default()).then(|| {
        s.tip_tanker_m
            + Vector3::new(
                f64::from(e.depth_m),
                f64::from(e.offset_m[0]),
                f64::from(e.offset_m[1]),
            )
    })
}

fn draw_camera(
    area: &Area<'_>,
    c: &CameraPanel,
    s: &Sample,
    r: &StepRecord,
    rec: &Recording,
) -> Result<(), String> {
    let m = &s.measurement;
    let [ax, ay] = rec.aim(f64::from(m.depth_m));
    let (au, av) = c.map_normalised(ax, ay);
    let cross = |(x, y): (i32, i32), d: i32, color: RGBColor| -> Result<(), String> {
        area.draw(&PathElement::new(
            vec![(x - d, y), (x + d, y)],
            color.stroke_width(2),
        ))
        .map_err(dbg)?;
        area.draw(&PathElement::new(
            vec![(x, y - d), (x, y + d)],
            color.stroke_width(2),
        ))
        .map_err(dbg)
    };
    cross((au, av), 8, AIM)?;
    if let Some([x, y]) = m.probe_tip {
        let (u, v) = c.geometry.to_px(f64::from(x), f64::from(y));
        if c.inside(u, v) {
            let (x, y) = c.map(u, v);
            area.draw(&Rectangle::new(
                [(x - 4, y - 4), (x + 4, y + 4)],
                TIP_MARKER.stroke_width(2),
            ))
            .map_err(dbg)?;
        }
    }
    let led = r.world.led.as_ref();
    if let Some(image) = led.and_then(|l| l.image.as_ref()) {
        for p in image.centroids_px() {
            area.draw(&Circle::new(c.map(p.x, p.y), 3, LED.filled()))
                .map_err(dbg)?;
        }
    }
    if let Some(t) = led.and_then(|l| l.truth)
        && t.depth_m > 0.0
    {
        let (u, v) = c.geometry.to_px(t.image_x, t.image_y);
        if c.inside(u, v) {
            let (x, y) = c.map(u, v);
            area.draw(&PathElement::new(
                vec![(x - 4, y - 4), (x + 4, y + 4)],
                TRUTH,
            ))
            .map_err(dbg)?;
            area.draw(&PathElement::new(
                vec![(x - 4, y + 4), (x + 4, y - 4)],
                TRUTH,
            ))
            .map_err(dbg)?;
        }
    }
    if m.tracked && m.depth_m > 0.0 {
        let (x, y) = (f64::from(m.image_x), f64::from(m.image_y));
        // The fitted circle: the LED camera's own fit, or for the ideal camera the ring the
        // depth implies (radius f R / depth).
        let (centre_px, radius_px) = led
            .and_then(|l| l.image.and_then(|i| i.circle))
            .map_or_else(
                || {
                    (
                        c.geometry.to_px(x, y),
                        c.geometry.focal_px * c.geometry.ring_radius_m / f64::from(m.depth_m),
                    )
                },
                |circle| ((circle.centre_px.x, circle.centre_px.y), circle.radius_px),
            );
        let ring: Vec<(i32, i32)> = (0..=48)
            .filter_map(|i| {
                let a = f64::from(i) * std::f64::consts::TAU / 48.0;
                let (u, v) = (
                    centre_px.0 + radius_px * a.cos(),
                    centre_px.1 + radius_px * a.sin(),
                );
                c.inside(u, v).then(|| c.map(u, v))
            })
            .collect();
        area.draw(&PathElement::new(ring, FIT.stroke_width(1)))
            .map_err(dbg)?;
        let (u, v) = c.geometry.to_px(x, y);
        if c.inside(u, v) {
            let (px, py) = c.map(u, v);
            area.draw(&PathElement::new(
                vec![(au, av), (px, py)],
                ERROR.stroke_width(2),
            ))
            .map_err(dbg)?;
            area.draw(&Circle::new((px, py), 3, FIT.filled()))
                .map_err(dbg)?;
        }
    } else {
        let (x, y) = c.map(10.0, 10.0);
        area.draw(&Text::new(
            "not tracked",
            (x, y),
            ("sans-serif", 16).into_font().color(&ERROR),
        ))
        .map_err(dbg)?;
    }
    Ok(())
}

/// Names of the status bits set in `flags`.
fn status_names(flags: StatusFlags) -> Vec<&'static str> {
    [
        (StatusFlags::MEASUREMENT_HELD, "measurement held"),
        (StatusFlags::NAV_HELD, "nav held"),
        (StatusFlags::SATURATED_ELEVATOR, "elevator sat."),
        (StatusFlags::SATURATED_THROTTLE, "throttle sat."),
        (StatusFlags::SATURATED_AILERON, "aileron sat."),
        (StatusFlags::SATURATED_RUDDER, "rudder sat."),
        (StatusFlags::LON_INTEGRATOR_FROZEN, "lon. integrator frozen"),
        (StatusFlags::LAT_INTEGRATOR_FROZEN, "lat. integrator frozen"),
        (StatusFlags::ENGAGE_REFUSED, "engage refused"),
        (StatusFlags::NON_FINITE_COMMAND, "non-finite command"),
        (StatusFlags::OPEN_LOOP, "open loop"),
        (StatusFlags::SATURATED_PITCH, "pitch setpoint sat."),
        (StatusFlags::SATURATED_BANK, "bank setpoint sat."),
    ]
    .into_iter()
    .filter(|(bit, _)| flags.contains(*bit))
    .map(|(_, name)| name)
    .collect()
}

/// The mode as the overlay names it: its name, and what it is in the procedure flown.
fn mode_name(mode: Mode, procedure: Procedure) -> String {
    let what = match (mode, procedure) {
        (Mode::PreContact, _) => " (station)",
        (Mode::Approach, Procedure::Refuelling) => " (contact)",
        (Mode::Terminal, Procedure::Refuelling) => " (capture)",
        (Mode::Terminal, Procedure::Paper) => " (blind)",
        _ => "",
    };
    format!("{mode:?}{what}")
}

/// A predicted miss in metres, without the unit ("none" where the gate predicts nothing:
/// infinite).
fn miss(m: f32) -> String {
    if m.is_finite() {
        format!("{m:.2}")
    } else {
        "none".to_string()
    }
}

/// The refuelling procedure's go/no-go gate at step `k`: while the contact approach runs, the
/// prediction against the gate radius and what the gate would decide with it now; in the
/// capture and docked, the go (when, on what prediction), in the capture with the late gate's
/// prediction; after a no-go, when, why and on what prediction; before the first approach, the
/// gate's rule. `None` for the paper's procedure.
fn gate_line(run: &Run, rec: &Recording, k: usize) -> Option<String> {
    if rec.config.procedure != Procedure::Refuelling {
        return None;
    }
    let rc = &rec.config.refuelling;
    let o = &run.samples[k].output;
    let samples = &run.samples[..=k];
    // The step the last approach went to the capture (the gate's go), and the step the last
    // no-go was declared: each carries the prediction the decision was taken on.
    let go = samples
        .windows(2)
        .rposition(|w| w[0].output.mode == Mode::Approach && w[1].output.mode == Mode::Terminal)
        .map(|j| &samples[j + 1]);
    let no_go = samples
        .windows(2)
        .rposition(|w| w[1].output.no_go.is_some() && w[0].output.no_go != w[1].output.no_go)
        .map(|j| &samples[j + 1]);
    let went = |g: &Sample| {
        format!(
            "go at {:.2} s: predicted miss {} ≤ {:.2} m",
            g.time_s,
            miss(g.output.predicted_miss_m),
            rc.gate_radius_m
        )
    };
    Some(match (o.mode, o.no_go, go) {
        (Mode::Approach, _, _) => {
            let p = o.predicted_miss_m;
            let verdict = if p <= rc.gate_radius_m { "go" } else { "no-go" };
            if p.is_finite() {
                format!(
                    "gate at {:.1} m: predicted miss {p:.2} m, {verdict} (≤ {:.2} m)",
                    rc.commit_depth_m, rc.gate_radius_m
                )
            } else {
                format!("gate at {:.1} m: no prediction yet", rc.commit_depth_m)
            }
        }
        (Mode::Terminal, _, Some(g)) => format!(
            "go at {:.2} s ({} ≤ {:.2} m); late gate {} ≤ {:.2} m",
            g.time_s,
            miss(g.output.predicted_miss_m),
            rc.gate_radius_m,
            miss(o.predicted_miss_m),
            RefuelLimits::new(rc, Controller::PERIOD_S).late_gate_radius_m(rc, o.estimate.depth_m)
        ),
        (_, Some(reason), _) => match no_go {
            Some(n) => format!(
                "no-go at {:.2} s: {reason:?}, predicted {} m",
                n.time_s,
                miss(n.output.predicted_miss_m)
            ),
            None => format!("no-go: {reason:?}"),
        },
        _ => match go {
            Some(g) => went(g),
            None => format!(
                "gate at {:.1} m: go if predicted miss ≤ {:.2} m",
                rc.commit_depth_m, rc.gate_radius_m
            ),
        },
    })
}

/// The numbers written beside the camera for step `k` (`last`: the run's final frame).
pub fn overlay_lines(run: &Run, rec: &Recording, k: usize, last: bool) -> Vec<String> {
    let (s, r) = (&run.samples[k], &rec.steps[k]);
    let (o, m) = (&s.output, &s.measurement);
    let procedure = rec.config.procedure;
    let deg = |v: f32| f64::from(v).to_degrees();
    let d = &s.drogue_from_tip_m;
    let attempt = match procedure {
        Procedure::Refuelling => format!("attempt {}    ", o.attempt),
        Procedure::Paper => String::new(),
    };
    let mut lines = vec![
        format!(
            "t {:5.2} s    {attempt}mode {}",
            s.time_s,
            mode_name(o.mode, procedure)
        ),
        if m.tracked {
            let [ax, ay] = rec.aim(f64::from(m.depth_m));
            let leds = r
                .world
                .led
                .and_then(|l| l.image)
                .map_or(String::new(), |i| {
                    format!(", {} LEDs", i.centroids_px().len())
                });
            format!(
                "depth {:.2} m, error x {:+.3} y {:+.3}{leds}",
                m.depth_m,
                f64::from(m.image_x) - ax,
                f64::from(m.image_y) - ay
            )
        } else {
            "camera: not tracked".to_string()
        },
        format!(
            "drogue − tip: fwd {:.2}, right {:+.2}, down {:+.2} m",
            d.x, d.y, d.z
        ),
    ];
    if procedure == Procedure::Refuelling {
        let e = &o.estimate;
        lines.push(if *e == DrogueEstimate::default() {
            "estimate: none".to_string()
        } else {
            format!(
                "estimate: fwd {:.2}, right {:+.2}, down {:+.2} m",
                e.depth_m, e.offset_m[0], e.offset_m[1]
            )
        });
    }
    lines.extend(gate_line(run, rec, k));
    lines.extend([
        format!(
            "v_des: right {:+.2}, down {:+.2}, fwd {:.2} m/s",
            o.v_des.x_right_mps, o.v_des.y_down_mps, o.v_des.z_fwd_mps
        ),
        format!(
            "elev {:+.2}°  ail {:+.2}°  rud {:+.2}°  thr {:.0} %",
            s.surfaces_commanded.elevator_rad.to_degrees(),
            s.surfaces_commanded.aileron_rad.to_degrees(),
            s.surfaces_commanded.rudder_rad.to_degrees(),
            s.surfaces_commanded.throttle * 100.0
        ),
    ]);
    if let Some(a) = o.command.attitude() {
        lines.push(format!(
            "setpoint: bank {:+.2}°  pitch {:+.2}°  (to the autopilot)",
            deg(a.roll_rad),
            deg(a.pitch_rad)
        ));
    }
    let status = status_names(o.status);
    lines.push(if status.is_empty() {
        "status: nominal".to_string()
    } else {
        format!("status: {}", status.join(", "))
    });
    if let Some(reason) = o.breakaway_reason {
        lines.push(format!("breakaway: {reason:?}"));
    }
    lines.push(if last {
        output::one_line(&run.summary)
    } else {
        format!("{} seed {} ({})", rec.scenario, rec.seed, rec.computer)
    });
    lines
}

/// The colour key, at the bottom right.
fn draw_legend(area: &Area<'_>) -> Result<(), String> {
    let rows: [&[(RGBColor, &str)]; 2] = [
        &[
            (RECEIVER, "receiver"),
            (INK, "probe"),
            (TIP, "tip"),
            (HOSE, "hose"),
            (DROGUE, "drogue, capture ring"),
            (ESTIMATE, "estimate"),
        ],
        &[
            (LED, "LEDs"),
            (FIT, "fit"),
            (AIM, "aim"),
            (ERROR, "error"),
            (TRUTH, "true centre"),
            (TIP_MARKER, "tip marker"),
        ],
    ];
    let font = ("sans-serif", 12).into_font().color(&INK);
    for (i, row) in rows.iter().enumerate() {
        let y = HEIGHT_PX as i32 - 34 + 17 * i as i32;
        let mut x = VIEW_W + 10;
        for (color, label) in row.iter() {
            area.draw(&Rectangle::new(
                [(x, y + 2), (x + 10, y + 12)],
                color.filled(),
            ))
            .map_err(dbg)?;
            area.draw_text(label, &font, (x + 14, y)).map_err(dbg)?;
            let (w, _) = area.estimate_text_size(label, &font).map_err(dbg)?;
            x += 14 + w as i32 + 12;
        }
    }
    Ok(())
}

fn draw_text(area: &Area<'_>, at: (i32, i32), lines: &[String]) -> Result<(), String> {
    let font = ("sans-serif", 15).into_font().color(&INK);
    for (i, line) in lines.iter().enumerate() {
        area.draw_text(line, &font, (at.0, at.1 + LINE_H * i as i32))
            .map_err(dbg)?;
    }
    Ok(())
}

/// Renders step `k` into `buffer` (RGB, [`WIDTH_PX`] x [`HEIGHT_PX`]).
fn render(
    buffer: &mut [u8],
    l: &Layout,
    run: &Run,
    rec: &Recording,
    k: usize,
    last: bool,
) -> Result<(), String> {
    buffer.copy_from_slice(&l.background);
    let root = BitMapBackend::with_buffer(buffer, (WIDTH_PX, HEIGHT_PX)).into_drawing_area();
    draw_views(&root, l, run, rec, k)?;
    draw_camera(&root, &l.camera, &run.samples[k], &rec.steps[k], rec)?;
    draw_text(&root, l.text, &overlay_lines(run, rec, k, last))?;
    root.present().map_err(dbg)
}

/// The fixed palette: 216-colour cube, then the grey ramp, then (unused) the transparent
/// entry; 256 RGB triples.
fn palette() -> Vec<u8> {
    let mut p = Vec::with_capacity(768);
    for r in 0..6u8 {
        for g in 0..6u8 {
            for b in 0..6u8 {
                p.extend([r * 51, g * 51, b * 51]);
            }
        }
    }
    for i in 0..GREYS {
        let v = (u16::from(i) * 255 / u16::from(GREYS - 1)) as u8;
        p.extend([v, v, v]);
    }
    p.resize(768, 255);
    p
}

/// The palette index nearest (by rounding) to an RGB pixel: the grey ramp for near-greys,
/// else the cube.
fn index_of(rgb: &[u8]) -> u8 {
    let (r, g, b) = (rgb[0], rgb[1], rgb[2]);
    let (lo, hi) = (r.min(g).min(b), r.max(g).max(b));
    if hi - lo <= 12 {
        let mean = (u16::from(r) + u16::from(g) + u16::from(b)) / 3;
        216 + ((mean * u16::from(GREYS - 1) + 127) / 255) as u8
    } else {
        let q = |c: u8| (u16::from(c) + 25) / 51;
        (q(r) * 36 + q(g) * 6 + q(b)) as u8
    }
}

/// The frame of `current` (palette indices) after `previous`: the bounding box of what
/// changed, unchanged pixels transparent; `None` previous: the whole frame, opaque.
fn frame_after<'a>(current: &[u8], previous: Option<&[u8]>, delay_cs: u16) -> Frame<'a> {
    let (w, h) = (WIDTH_PX as usize, HEIGHT_PX as usize);
    let Some(prev) = previous else {
        return Frame {
            delay: delay_cs,
            dispose: DisposalMethod::Keep,
            width: w as u16,
            height: h as u16,
            buffer: current.to_vec().into(),
            ..Frame::default()
        };
    };
    let (mut x0, mut y0, mut x1, mut y1) = (w, h, 0, 0);
    for y in 0..h {
        let row = y * w..(y + 1) * w;
        let (c, p) = (&current[row.clone()], &prev[row]);
        if let Some(first) = c.iter().zip(p).position(|(a, b)| a != b) {
            let last = w
                - 1
                - c.iter()
                    .rev()
                    .zip(p.iter().rev())
                    .position(|(a, b)| a != b)
                    .unwrap_or(0);
            (x0, x1, y0, y1) = (x0.min(first), x1.max(last), y0.min(y), y1.max(y));
        }
    }
    if x0 > x1 {
        // Nothing changed: one transparent pixel carries the delay.
        (x0, y0, x1, y1) = (0, 0, 0, 0);
    }
    let mut buffer = Vec::with_capacity((x1 - x0 + 1) * (y1 - y0 + 1));
    for y in y0..=y1 {
        for x in x0..=x1 {
            let i = y * w + x;
            buffer.push(if current[i] == prev[i] {
                TRANSPARENT
            } else {
                current[i]
            });
        }
    }
    Frame {
        delay: delay_cs,
        dispose: DisposalMethod::Keep,
        transparent: Some(TRANSPARENT),
        left: x0 as u16,
        top: y0 as u16,
        width: (x1 - x0 + 1) as u16,
        height: (y1 - y0 + 1) as u16,
        buffer: buffer.into(),
        ..Frame::default()
    }
}

/// Writes the animation of `run` (recorded as `rec`) to `path`.
pub fn write_gif(
    path: &Path,
    run: &Run,
    rec: &Recording,
    opts: &AnimationOptions,
) -> Result<AnimationStats, OutputError> {
    let plot_err = |reason: String| OutputError::Plot {
        path: path.display().to_string(),
        reason,
    };
    let io = |source| OutputError::Io {
        path: path.display().to_string(),
        source,
    };
    if rec.steps.len() != run.samples.len() {
        return Err(OutputError::Mismatch {
            what: "recording and run",
            left: rec.steps.len(),
            right: run.samples.len(),
        });
    }
    let steps = frame_steps(run.samples.len(), opts.steps_per_frame);
    let layout = layout(run, rec).map_err(plot_err)?;
    let delay_cs = (opts.steps_per_frame as f64 * CONTROL_PERIOD_S * 100.0).round() as u16;
    let file = File::create(path).map_err(io)?;
    let mut enc = Encoder::new(
        BufWriter::new(file),
        WIDTH_PX as u16,
        HEIGHT_PX as u16,
        &palette(),
    )?;
    enc.set_repeat(Repeat::Infinite)?;
    let mut rgb = vec![0u8; (WIDTH_PX * HEIGHT_PX * 3) as usize];
    let mut previous: Option<Vec<u8>> = None;
    for (n, &k) in steps.iter().enumerate() {
        let last = n + 1 == steps.len();
        render(&mut rgb, &layout, run, rec, k, last).map_err(plot_err)?;
        let indices: Vec<u8> = rgb.chunks_exact(3).map(index_of).collect();
        let delay = if last { opts.hold_last_cs } else { delay_cs };
        enc.write_frame(&frame_after(&indices, previous.as_deref(), delay))?;
        previous = Some(indices);
    }
    enc.into_inner()?;
    let bytes = std::fs::metadata(path).map_err(io)?.len();
    Ok(AnimationStats {
        frames: steps.len(),
        width_px: WIDTH_PX,
        height_px: HEIGHT_PX,
        frame_delay_cs: delay_cs,
        bytes,
    })
}

/// Writes step `k`'s frame (as drawn in the animation) as a PNG, e.g. for documentation.
pub fn write_frame_png(
    path: &Path,
    run: &Run,
    rec: &Recording,
    k: usize,
) -> Result<(), OutputError> {
    let plot_err = |reason: String| OutputError::Plot {
        path: path.display().to_string(),
        reason,
    };
    if k >= run.samples.len() || rec.steps.len() != run.samples.len() {
        return Err(OutputError::Mismatch {
            what: "frame step and run",
            left: k,
            right: run.samples.len(),
        });
    }
    let layout = layout(run, rec).map_err(plot_err)?;
    let mut rgb = vec![0u8; (WIDTH_PX * HEIGHT_PX * 3) as usize];
    render(&mut rgb, &layout, run, rec, k, k + 1 == run.samples.len()).map_err(plot_err)?;
    let mut png = BitMapBackend::new(path, (WIDTH_PX, HEIGHT_PX));
    png.blit_bitmap((0, 0), (WIDTH_PX, HEIGHT_PX), &rgb)
        .map_err(dbg)
        .map_err(plot_err)?;
    png.present().map_err(dbg).map_err(plot_err)
}
