//! The refuelling sortie generator shared by the whole-step tests (`fuzz_step.rs`,
//! `properties.rs`): an engage at the pre-contact station, then segments of what a camera and
//! a navigation system could report through a sortie (holding the station, closing on the
//! drogue, the drogue off to one side, frames or navigation lost, overspeed, another flight
//! condition, probe contact, operator requests), so that every mode of the refuelling
//! procedure is flown, not only the station (each test checks that its cases reach them).
//!
//! Invariant: a pure function of proptest's random source; frames are what the configured
//! camera would see of the drogue at the stated offset from the probe tip (the tracker's
//! noise added so that the frozen-frame check does not reject them).

use ibvs_core::estimator::TipGeometry;
use ibvs_core::gains::TRIM;
use ibvs_core::measurement::CameraMeasurement;
use ibvs_core::nav::{FlightCondition, NavSample};
use ibvs_core::{ControllerConfig, ControllerInput, ModeRequest};
use proptest::prelude::*;

/// Longest sortie, steps (48 s: long enough for the pre-contact dwell, approaches, captures
/// and retries, and longer than the blind phase's 250-step limit).
pub const MAX_SORTIE_STEPS: usize = 2400;

/// Where the sorties hold the station, m from the probe tip: the default station (3.6 m) plus
/// 3.7 mm, so that the depths a closing segment steps through (0.02 m apart) miss the
/// table's depth thresholds (the station's limits, the overrun, the commit depth, the
/// overshoot: multiples of 0.1 m) by millimetres rather than landing on them to the last
/// bit, where single precision decides and the `f64` model of `fuzz_step.rs` could only
/// take both outcomes. (The thresholds' own edges are the mode's unit tests'.)
pub const STATION_M: f32 = 3.6037;

/// An operator request: mostly none, sometimes engage, rarely abort or reset.
pub fn request() -> impl Strategy<Value = ModeRequest> {
    prop_oneof![
        20 => Just(ModeRequest::None),
        4 => Just(ModeRequest::Engage),
        1 => Just(ModeRequest::Abort),
        1 => Just(ModeRequest::Reset),
    ]
}

/// One segment of a refuelling sortie as a camera and a navigation system could report it:
/// the drogue held near the station, the receiver closing on it (depth falling 0.02 m a
/// step, 1 m/s, from wherever it is), the drogue off to one side, frames lost, navigation
/// lost, probe contact, or an operator request. Offsets and depths are the drogue's from the
/// probe tip; the frames are what the configured (set-back) camera sees of that.
#[derive(Debug, Clone, Copy)]
enum Segment {
    /// Near the station ([`STATION_M`]), offset `(right, down)` m, for `n` steps.
    Station(f32, f32, usize),
    /// Closing from the current depth at 1 m/s toward `end` m with the offset `(right, down)`.
    Close(f32, f32, f32),
    /// The drogue far off the probe's line for `n` steps.
    Off(usize),
    /// Untracked frames for `n` steps.
    Lost(usize),
    /// The same depth and offset for `n` steps (the receiver stopped closing).
    Hold(usize),
    /// Non-finite navigation for `n` steps.
    NavBad(usize),
    /// Navigation reporting the receiver 2.5 m/s faster than the tanker for `n` steps.
    NavFast(usize),
    /// Navigation at another flight condition `(airspeed, altitude)` for `n` steps: inside
    /// the docking envelope or not.
    Condition(f32, f32, usize),
    /// The probe-contact discrete for `n` steps (with the last frame content).
    Contact(usize),
    /// A whole docking: 60 steps at the station with the offset `(right, down)` m, closing at
    /// 1 m/s to 0.1 m, then the probe-contact discrete for `n` steps.
    Dock(f32, f32, usize),
    /// A request, once.
    Request(ModeRequest),
}

fn segment() -> impl Strategy<Value = Segment> {
    let small = || -0.06_f32..0.06;
    prop_oneof![
        6 => (small(), small(), 30_usize..120).prop_map(|(x, y, n)| Segment::Station(x, y, n)),
        // Ends inside the capture's judging depths (0.6..1.3 m) too, where a hold is a
        // `ClosingTooSlow`.
        4 => (-0.3_f32..1.2, small(), small()).prop_map(|(end, x, y)| Segment::Close(end, x, y)),
        2 => (-0.6_f32..0.0, -0.4_f32..0.4, -0.4_f32..0.4)
            .prop_map(|(end, x, y)| Segment::Close(end, x, y)),
        1 => (1_usize..40).prop_map(Segment::Off),
        1 => (100_usize..200).prop_map(Segment::Hold),
        1 => prop_oneof![1_usize..10, 20_usize..200].prop_map(Segment::Lost),
        1 => prop_oneof![1_usize..5, 20_usize..40].prop_map(Segment::NavBad),
        1 => (1_usize..5).prop_map(Segment::NavFast),
        1 => (prop_oneof![95.0_f32..175.0, Just(150.0)], prop_oneof![400.0_f32..8100.0, Just(6000.0)], 1_usize..60)
            .prop_map(|(v, h, n)| Segment::Condition(v, h, n)),
        2 => (1_usize..80).prop_map(Segment::Contact),
        2 => (small(), small(), 1_usize..80).prop_map(|(x, y, n)| Segment::Dock(x, y, n)),
        1 => request().prop_map(Segment::Request),
    ]
}

/// A refuelling sortie for the configuration `cfg`'s camera: engage at the station, then
/// segments; at most [`MAX_SORTIE_STEPS`] steps.
pub fn sortie_sequence(cfg: ControllerConfig) -> impl Strategy<Value = Vec<ControllerInput>> {
    let tip =
        TipGeometry::new(&cfg.camera, cfg.probe_tip_body_m, TRIM.theta_rad).tip_from_camera_m();
    (any::<u32>(), prop::collection::vec(segment(), 1..30)).prop_map(move |(start, segs)| {
        let mut out = Vec::new();
        let mut seq = start;
        let (mut depth, mut x, mut y) = (STATION_M, 0.0_f32, 0.0_f32);
        // A frame of the drogue at `(x, y)` right and down of the tip, `d` ahead of it.
        let mut push = |out: &mut Vec<ControllerInput>, tracked: bool, x: f32, y: f32, d: f32| {
            seq = seq.wrapping_add(1);
            let k = out.len();
            let z = d + tip[2];
            out.push(ControllerInput {
                measurement: CameraMeasurement {
                    seq,
                    tracked: tracked && z > 0.05,
                    // A tracker's noise, so the frozen check does not reject the frames.
                    image_x: (x + tip[0]) / z + 1e-4 * (k % 5) as f32,
                    image_y: (y + tip[1]) / z,
                    depth_m: z.max(0.05),
                    probe_tip: None,
                },
                nav: NavSample::default(),
                probe_contact: false,
                autopilot_ready: true,
                request: if k == 0 {
                    ModeRequest::Engage
                } else {
                    ModeRequest::None
                },
            });
        };
        push(&mut out, true, 0.0, 0.0, depth);
        for seg in segs {
            let edit = |out: &mut Vec<ControllerInput>, f: &dyn Fn(&mut ControllerInput)| {
                if let Some(last) = out.last_mut() {
                    f(last);
                }
            };
            match seg {
                Segment::Station(sx, sy, n) => {
                    (x, y, depth) = (sx, sy, STATION_M);
                    (0..n).for_each(|_| push(&mut out, true, x, y, depth));
                }
                Segment::Close(end, cx, cy) => {
                    (x, y) = (cx, cy);
                    while depth > end && out.len() < MAX_SORTIE_STEPS {
                        depth -= 0.02;
                        // The navigation has the receiver 1 m/s faster than the tanker.
                        push(&mut out, true, x, y, depth);
                        edit(&mut out, &|i| i.nav.lon.v_mps = 1.0);
                    }
                }
                Segment::Off(n) => (0..n).for_each(|_| push(&mut out, true, 1.0, 0.8, depth)),
                Segment::Lost(n) => (0..n).for_each(|_| push(&mut out, false, x, y, depth)),
                Segment::Hold(n) => (0..n).for_each(|_| push(&mut out, true, x, y, depth)),
                Segment::NavBad(n) => {
                    for _ in 0..n {
                        push(&mut out, true, x, y, depth);
                        edit(&mut out, &|i| i.nav.lon.v_mps = f32::NAN);
                    }
                }
                Segment::NavFast(n) => {
                    for _ in 0..n {
                        push(&mut out, true, x, y, depth);
                        edit(&mut out, &|i| i.nav.lon.v_mps = 2.5);
                    }
                }
                Segment::Condition(v, h, n) => {
                    for _ in 0..n {
                        push(&mut out, true, x, y, depth);
                        edit(&mut out, &|i| {
                            i.nav.condition = FlightCondition {
                                true_airspeed_mps: v,
                                altitude_m: h,
                            }
                        });
                    }
                }
                Segment::Contact(n) => {
                    for _ in 0..n {
                        push(&mut out, true, x, y, depth);
                        edit(&mut out, &|i| i.probe_contact = true);
                    }
                }
                Segment::Dock(dx, dy, n) => {
                    (x, y, depth) = (dx, dy, STATION_M);
                    (0..60).for_each(|_| push(&mut out, true, x, y, depth));
                    while depth > 0.1 && out.len() < MAX_SORTIE_STEPS {
                        depth -= 0.02;
                        push(&mut out, true, x, y, depth);
                        edit(&mut out, &|i| i.nav.lon.v_mps = 1.0);
                    }
                    for _ in 0..n {
                        push(&mut out, true, x, y, depth);
                        edit(&mut out, &|i| i.probe_contact = true);
                    }
                }
                Segment::Request(r) => {
                    push(&mut out, true, x, y, depth);
                    edit(&mut out, &|i| i.request = r);
                }
            }
        }
        out.truncate(MAX_SORTIE_STEPS);
        out
    })
}
