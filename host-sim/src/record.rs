//! A run recorded in full: besides the run's own [`Sample`]s, what the flight computer was
//! given each step, the world's detail a sample does not keep (the hose's nodes, the camera's
//! LED centroids and fitted circle) and, processor-in-the-loop, the raw link frames. The
//! flight-test log ([`crate::flight_log`]) and the animation ([`crate::animate`]) are written
//! from a [`Recording`].
//!
//! Place in the data flow: [`run`] and [`run_pil`] fly [`crate::sim::run_observed`] with an
//! observer that copies the world's detail once per control step, and with the flight
//! computer behind a tap that keeps each step's [`ControllerInput`] (and, for PIL, the link's
//! frames) before passing it on unchanged.
//!
//! Invariants:
//! - Recording never changes a run: the observer only reads the world, and the tap returns
//!   the wrapped flight computer's output untouched (tested: same summary and samples with and
//!   without recording).
//! - A [`Recording`] holds exactly one [`StepRecord`] per [`Sample`] of its run, in the same
//!   order (checked when it is made: [`RecordError::Misaligned`] otherwise).

use ibvs_core::ControllerConfig;
use ibvs_core::controller::{ControllerInput, ControllerOutput};
use ibvs_core::estimator::TipGeometry;
use ibvs_core::gains::TRIM;
use ibvs_core::procedure::Procedure;
use ibvs_core::wire::{Downlink, Uplink, decode_uplink};
use nalgebra::Vector3;

use crate::pil::{HostLinkCounters, PilFlightComputer};
use crate::sim::{
    self, AutopilotStep, CameraChoice, FlightComputer, Run, Sample, Scenario, SimError,
};
use crate::world::faults::SimFault;
use crate::world::led_camera::{DEFAULT_RING_RADIUS_M, LedImage, TrueFeature};
use crate::world::{Camera, Drogue, World};

/// Why a run could not be recorded.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// The run itself failed.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The taps saw a different number of steps than the run recorded (a bug).
    #[error(
        "recording misaligned: {samples} samples, {inputs} inputs, {world} world records, {link} link records"
    )]
    Misaligned {
        /// Samples of the run.
        samples: usize,
        /// Inputs the flight computer was given.
        inputs: usize,
        /// World records taken.
        world: usize,
        /// Link records taken (0 unless processor-in-the-loop).
        link: usize,
    },
}

/// The camera's image geometry (for drawing the image and turning pixels into normalised
/// coordinates).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImageGeometry {
    /// Image width, px.
    pub width_px: f64,
    /// Image height, px.
    pub height_px: f64,
    /// Focal length, px.
    pub focal_px: f64,
    /// Principal point, u (right) from the left edge, px.
    pub principal_u_px: f64,
    /// Principal point, v (down) from the top edge, px.
    pub principal_v_px: f64,
    /// Radius of the drogue's LED ring, m (the ideal camera has none: the LED camera's
    /// default, to draw the ring the depth implies).
    pub ring_radius_m: f64,
}

impl ImageGeometry {
    /// The geometry of a scenario's camera.
    pub fn of(camera: &CameraChoice) -> Self {
        match camera {
            CameraChoice::Ideal(p) => Self {
                width_px: p.width_px,
                height_px: p.height_px,
                focal_px: p.focal_px,
                principal_u_px: p.width_px / 2.0,
                principal_v_px: p.height_px / 2.0,
                ring_radius_m: DEFAULT_RING_RADIUS_M,
            },
            CameraChoice::Led(p) => Self {
                width_px: p.width_px,
                height_px: p.height_px,
                focal_px: p.focal_px,
                principal_u_px: p.principal_u_px,
                principal_v_px: p.principal_v_px,
                ring_radius_m: p.ring_radius_m,
            },
        }
    }

    /// A normalised image point `(x, y)` in pixels `(u, v)`.
    pub fn to_px(&self, x: f64, y: f64) -> (f64, f64) {
        (
            x * self.focal_px + self.principal_u_px,
            y * self.focal_px + self.principal_v_px,
        )
    }
}

/// What the LED camera's frame behind the step's measurement held.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LedRecord {
    /// Centroids and fitted circle; `None` before the first frame was delivered.
    pub image: Option<LedImage>,
    /// The drogue centre as an ideal camera saw it at that frame's capture.
    pub truth: Option<TrueFeature>,
}

/// The world's detail at one control step (at the step's start, as the camera saw it).
#[derive(Debug, Clone, PartialEq)]
pub struct WorldRecord {
    /// Hose nodes from the hose exit (index 0) to the drogue centre, tanker frame, m; empty
    /// when the drogue is held fixed (no hose model).
    pub hose_tanker_m: Vec<Vector3<f64>>,
    /// Drogue axis (from the hose toward the drogue), tanker frame, unit.
    pub drogue_axis_tanker: Vector3<f64>,
    /// Receiver CG, tanker frame, m.
    pub receiver_cg_tanker_m: Vector3<f64>,
    /// Camera optical centre, tanker frame, m.
    pub camera_tanker_m: Vector3<f64>,
    /// The LED camera's image; `None` for the ideal camera.
    pub led: Option<LedRecord>,
}

impl WorldRecord {
    /// Copies the detail of `world` at `sample`'s step.
    pub fn capture(world: &World, sample: &Sample) -> Self {
        Self {
            hose_tanker_m: match &world.drogue {
                Drogue::Hose(h) => h.node_positions_tanker_m().to_vec(),
                Drogue::Fixed(_) => Vec::new(),
            },
            drogue_axis_tanker: world.drogue_axis_tanker(),
            receiver_cg_tanker_m: world
                .tanker
                .to_tanker_m(&sample.state.pos_ned_m, sample.time_s),
            camera_tanker_m: world
                .camera_pose(&sample.state, sample.time_s)
                .position_tanker_m,
            led: match &world.camera {
                Camera::Led(c) => Some(LedRecord {
                    image: c.latest_image().copied(),
                    truth: c.latest_truth(),
                }),
                Camera::Ideal(_) => None,
            },
        }
    }
}

/// One step of the serial link (processor in the loop).
#[derive(Debug, Clone, PartialEq)]
pub struct LinkRecord {
    /// The measurement frame sent for this step, COBS-encoded, zero included.
    pub uplink_frame: Vec<u8>,
    /// That frame decoded (`None` if it does not decode, which would be a bug).
    pub uplink: Option<Uplink>,
    /// The command frame that answered it, raw, and decoded; `None` when the step failed
    /// (no answer: the actuators held the last output).
    pub downlink: Option<(Vec<u8>, Downlink)>,
    /// The host's link counts after the step.
    pub host: HostLinkCounters,
}

/// One control step's full record (beside the run's [`Sample`] of the same index).
#[derive(Debug, Clone, PartialEq)]
pub struct StepRecord {
    /// What the flight computer was given.
    pub input: ControllerInput,
    /// The world's detail.
    pub world: WorldRecord,
    /// The link's frames (processor in the loop only).
    pub link: Option<LinkRecord>,
}

/// A run's full record.
#[derive(Debug, Clone, PartialEq)]
pub struct Recording {
    /// The scenario's name.
    pub scenario: String,
    /// The scenario's seed.
    pub seed: u64,
    /// Where the controller ran: `"in-process"` or `"pil"`.
    pub computer: &'static str,
    /// The camera's image geometry.
    pub image: ImageGeometry,
    /// The configuration of the controller that flew the run (its procedure, the image point
    /// it steers to, its gates): the default configuration unless set with
    /// [`Recording::with_config`].
    pub config: ControllerConfig,
    /// One record per sample of the run.
    pub steps: Vec<StepRecord>,
}

impl Recording {
    /// The recording with the configuration of the controller that flew it.
    pub fn with_config(self, config: ControllerConfig) -> Self {
        Self { config, ..self }
    }

    /// Where the controller steers the drogue's image, normalised `(x right, y down)`, for a
    /// frame at camera depth `depth_m`. The paper's procedure: the IBVS convergence point.
    /// The refuelling procedure: where the drogue appears when it is dead ahead of the probe
    /// tip at that depth, its offset from the tip zero (the configured geometry's tip image
    /// point scaled by the tip's depth over the drogue's, as [`TipGeometry::drogue_from_tip`]
    /// reads a frame at trim attitude); for a camera at the tip, the image centre.
    pub fn aim(&self, depth_m: f64) -> [f64; 2] {
        let c = &self.config;
        match c.procedure {
            Procedure::Paper => c.ibvs.convergence_point.map(f64::from),
            Procedure::Refuelling => {
                let g = TipGeometry::new(&c.camera, c.probe_tip_body_m, TRIM.theta_rad);
                let tip_depth = f64::from(g.tip_from_camera_m()[2]);
                let scale = if depth_m > 0.0 && tip_depth > 0.0 {
                    tip_depth / depth_m
                } else {
                    1.0
                };
                g.tip_image().map(|t| f64::from(t) * scale)
            }
        }
    }
}

/// Where the tap sends each step.
enum Inner<'a> {
    Any(&'a mut dyn FlightComputer),
    Pil(&'a mut PilFlightComputer),
}

/// The flight computer behind a tap that keeps what it is given (and, for PIL, the frames).
struct Tap<'a> {
    inner: Inner<'a>,
    inputs: Vec<ControllerInput>,
    link: Vec<LinkRecord>,
}

/// The link's record of the step the firmware just answered (`answered`: its history's
/// length before the step).
fn link_record(fc: &PilFlightComputer, answered: usize) -> LinkRecord {
    let link = fc.link();
    let frame = link.last_measurement_frame().to_vec();
    LinkRecord {
        uplink: decode_uplink(&frame).ok(),
        uplink_frame: frame,
        downlink: fc
            .history()
            .get(answered)
            .map(|d| (link.last_command_frame().to_vec(), *d)),
        host: *link.host_counters(),
    }
}

impl FlightComputer for Tap<'_> {
    fn step(&mut self, input: &ControllerInput) -> ControllerOutput {
        self.inputs.push(*input);
        match &mut self.inner {
            Inner::Any(fc) => fc.step(input),
            Inner::Pil(fc) => {
                let answered = fc.history().len();
                let output = FlightComputer::step(&mut **fc, input);
                self.link.push(link_record(fc, answered));
                output
            }
        }
    }

    fn autopilot_design(&self) -> Option<ibvs_core::attitude::AttitudeLoopConfig> {
        match &self.inner {
            Inner::Any(fc) => fc.autopilot_design(),
            Inner::Pil(fc) => fc.autopilot_design(),
        }
    }

    /// In process: the session around this tap's step (which records the input the session
    /// built). The firmware: its own session; the input recorded is the uplink's.
    fn step_through_autopilot(&mut self, link: AutopilotStep<'_>) -> ControllerOutput {
        let Inner::Pil(fc) = &mut self.inner else {
            return sim::step_through_session(self, link);
        };
        self.inputs.push(*link.input);
        let answered = fc.history().len();
        let output = fc.step_through_autopilot(link);
        self.link.push(link_record(fc, answered));
        output
    }

    fn probe_tip_image(&self) -> Option<[f32; 2]> {
        match &self.inner {
            Inner::Any(fc) => fc.probe_tip_image(),
            Inner::Pil(fc) => FlightComputer::probe_tip_image(&**fc),
        }
    }
}

fn record(
    s: &Scenario,
    inner: Inner<'_>,
    faults: &[SimFault],
) -> Result<(Run, Recording), RecordError> {
    let computer = match inner {
        Inner::Any(_) => "in-process",
        Inner::Pil(_) => "pil",
    };
    let mut tap = Tap {
        inner,
        inputs: Vec::new(),
        link: Vec::new(),
    };
    let mut world = Vec::new();
    let run = sim::run_observed(s, &mut tap, faults, &mut |w, sample| {
        world.push(WorldRecord::capture(w, sample));
    })?;
    let (inputs, link) = (tap.inputs, tap.link);
    let n = run.samples.len();
    if inputs.len() != n || world.len() != n || !(link.is_empty() || link.len() == n) {
        return Err(RecordError::Misaligned {
            samples: n,
            inputs: inputs.len(),
            world: world.len(),
            link: link.len(),
        });
    }
    let mut link = link.into_iter().map(Some).chain(std::iter::repeat(None));
    let steps = inputs
        .into_iter()
        .zip(world)
        .map(|(input, world)| StepRecord {
            input,
            world,
            link: link.next().flatten(),
        })
        .collect();
    Ok((
        run,
        Recording {
            scenario: s.name.clone(),
            seed: s.seed,
            computer,
            image: ImageGeometry::of(&s.camera),
            config: ControllerConfig::default(),
            steps,
        },
    ))
}

/// Runs `s` with `fc` flying (and `faults` injected, [`sim::run_with_faults`]) and records it.
pub fn run(
    s: &Scenario,
    fc: &mut dyn FlightComputer,
    faults: &[SimFault],
) -> Result<(Run, Recording), RecordError> {
    record(s, Inner::Any(fc), faults)
}

/// Runs `s` with the firmware in QEMU flying and records it, the link's frames included.
pub fn run_pil(
    s: &Scenario,
    fc: &mut PilFlightComputer,
    faults: &[SimFault],
) -> Result<(Run, Recording), RecordError> {
    record(s, Inner::Pil(fc), faults)
}
