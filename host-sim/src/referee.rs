//! The referee: judges a run from the simulator's truth alone.
//!
//! It reads what the world and the receiver really did (the probe tip, the drogue, every
//! hose node, the receiver's position, attitude, angle of attack and load factor, the tanker's
//! hose exit) and never the controller's mode, outputs or counters. It decides the docking
//! (the coupling latches when the probe tip crosses the drogue plane inside the capture
//! radius, closing inside the band, without sliding across the drogue faster than the lateral
//! limit) and records every hazard with its time, place and speed:
//!
//! | hazard | when |
//! |---|---|
//! | [`HazardKind::BasketStrike`] | the probe tip crosses the drogue plane (either way) without latching, within the canopy's radius plus the probe head's |
//! | [`HazardKind::HardContact`] | the probe tip enters the coupling (inside the capture radius) closing faster or slower than the band, or sliding across faster than the lateral limit |
//! | [`HazardKind::DrogueOnAirframe`] | the canopy's rim or the coupling comes within the clearance of the receiver's radome or cockpit canopy |
//! | [`HazardKind::HoseContact`] | the probe, radome or cockpit canopy comes within the clearance of the hose |
//! | [`HazardKind::TankerProximity`] | any of them enters the keep-out sphere around the tanker's hose exit |
//! | [`HazardKind::Upset`] | bank, pitch, angle of attack or load factor beyond their limits within the upset distance of the drogue |
//!
//! The limits, the airframe's shapes and their sources are [`Limits::default`] and
//! [`Airframe::f16`] (`docs/models.md`, "The referee"). A run is unsafe if any hazard occurred.
//!
//! A continuing condition (the hose within the clearance for a second, say) is one hazard:
//! recorded at its onset and updated to its worst value until it clears. A crossing of the
//! drogue plane is a discrete event: each is recorded ([`CrossingRecord`]) with its verdict.
//!
//! Invariants: the verdict is a function of the truth fed to it, in order; [`Referee::observe`]
//! never allocates except to record a crossing or a hazard; the drogue plane is the plane
//! through the drogue centre normal to the tanker's x axis (as `crate::docking`'s).

use nalgebra::{Rotation3, Vector3};
use serde::{Deserialize, Serialize};

use crate::docking::{CLOSING_BAND_MPS, PlaneCrossing};
use crate::world::drogue::CAPTURE_RADIUS_M;
use crate::world::hose::DROGUE_CANOPY_DIAMETER_M;

/// The probe nozzle's head radius, m (ours: a head about 10 cm across, the size of the
/// nozzles that NATO STANAG 3447 standardises; we had no dimensioned drawing). A crossing
/// this close outside the canopy's rim puts the head on the rim.
pub const PROBE_HEAD_RADIUS_M: f64 = 0.05;

/// The largest speed of the probe tip relative to the drogue across the drogue's axis when
/// the probe enters the coupling, m/s (ours: 1 m/s, about 2 kt: at the band's typical 1 m/s
/// closing, an entry more than 45 degrees off the drogue's axis; faster, the drogue is
/// swinging across the probe and the canopy's ribs take the load, not the coupling. We found
/// no published limit).
pub const MAX_LATERAL_MPS: f64 = 1.0;

/// Clearance between the drogue (its canopy's rim, the coupling) and the receiver's radome or
/// cockpit canopy, m (ours: the hazard is the drogue on the airframe; the shapes are already
/// generous envelopes, so a small margin).
pub const AIRFRAME_CLEARANCE_M: f64 = 0.15;

/// Clearance between the hose's surface and the surfaces of the probe, radome and cockpit
/// canopy, m (ours).
pub const HOSE_CLEARANCE_M: f64 = 0.10;

/// Length of the hose's end taken up by the drogue assembly (the coupling the hose ends in),
/// m, not counted as hose in the hose-contact check (ours: the model's last node is the
/// drogue centre; the coupling in front of the canopy is about this long).
pub const DROGUE_ASSEMBLY_LENGTH_M: f64 = 0.6;

/// Radius of the keep-out sphere around the tanker's hose exit, m (ours: the receiver's
/// forward airframe 5.5 m or more ahead of the drogue's steady trail, 13.55 m behind the
/// exit in calm air, is beyond any push-in of a refuelling contact).
pub const TANKER_KEEP_OUT_M: f64 = 8.0;

/// The largest bank angle, rad: 45 degrees, the FAA's definition of an aeroplane upset
/// (Advisory Circular AC 120-111, "Upset Prevention and Recovery Training", 2015).
pub const MAX_BANK_RAD: f64 = 45.0 * std::f64::consts::PI / 180.0;

/// The pitch attitude range, rad: 10 degrees nose down to 25 degrees nose up (AC 120-111, as
/// [`MAX_BANK_RAD`]).
pub const PITCH_RANGE_RAD: (f64, f64) = (
    -10.0 * std::f64::consts::PI / 180.0,
    25.0 * std::f64::consts::PI / 180.0,
);

/// The angle-of-attack range, rad (ours: -5..20 degrees; the F-16's flight-control system
/// limits the angle of attack to 25 degrees in its cruise configuration, and the refuelling
/// trim is 6.4 degrees).
pub const ALPHA_RANGE_RAD: (f64, f64) = (
    -5.0 * std::f64::consts::PI / 180.0,
    20.0 * std::f64::consts::PI / 180.0,
);

/// The normal load factor range (ours: 0..2 g, one g either side of level flight; light
/// turbulence moves it by about a tenth of a g at the refuelling condition).
pub const LOAD_FACTOR_RANGE: (f64, f64) = (0.0, 2.0);

/// Within this distance of the drogue (receiver CG to drogue centre), an upset is a hazard,
/// m (ours: about two hose lengths, the whole of the procedure and of its breakaway).
pub const UPSET_DISTANCE_M: f64 = 30.0;

/// Every limit the referee judges by. [`Limits::default`] holds the stated figures.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Limits {
    /// The coupling captures the probe tip within this radius of the drogue centre, m.
    pub capture_radius_m: f64,
    /// Closing speeds that latch the coupling without damage, m/s.
    pub closing_band_mps: (f64, f64),
    /// The largest speed across the drogue's axis at entry, m/s.
    pub max_lateral_mps: f64,
    /// The canopy's radius, m.
    pub canopy_radius_m: f64,
    /// The probe head's radius, m.
    pub probe_head_radius_m: f64,
    /// Drogue to radome or cockpit canopy, m.
    pub airframe_clearance_m: f64,
    /// Hose radius, m (from the hose model).
    pub hose_radius_m: f64,
    /// Hose surface to probe, radome or cockpit canopy surface, m.
    pub hose_clearance_m: f64,
    /// The hose's end inside the drogue assembly, m.
    pub drogue_assembly_length_m: f64,
    /// Keep-out sphere around the hose exit, m.
    pub tanker_keep_out_m: f64,
    /// Largest bank, rad.
    pub max_bank_rad: f64,
    /// Pitch range, rad.
    pub pitch_range_rad: (f64, f64),
    /// Angle-of-attack range, rad.
    pub alpha_range_rad: (f64, f64),
    /// Normal load factor range, g.
    pub load_factor_range: (f64, f64),
    /// Upsets count within this distance of the drogue, m.
    pub upset_distance_m: f64,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            capture_radius_m: CAPTURE_RADIUS_M,
            closing_band_mps: CLOSING_BAND_MPS,
            max_lateral_mps: MAX_LATERAL_MPS,
            canopy_radius_m: DROGUE_CANOPY_DIAMETER_M / 2.0,
            probe_head_radius_m: PROBE_HEAD_RADIUS_M,
            airframe_clearance_m: AIRFRAME_CLEARANCE_M,
            hose_radius_m: crate::world::hose::HOSE_OUTER_RADIUS_M,
            hose_clearance_m: HOSE_CLEARANCE_M,
            drogue_assembly_length_m: DROGUE_ASSEMBLY_LENGTH_M,
            tanker_keep_out_m: TANKER_KEEP_OUT_M,
            max_bank_rad: MAX_BANK_RAD,
            pitch_range_rad: PITCH_RANGE_RAD,
            alpha_range_rad: ALPHA_RANGE_RAD,
            load_factor_range: LOAD_FACTOR_RANGE,
            upset_distance_m: UPSET_DISTANCE_M,
        }
    }
}

impl Limits {
    /// A crossing closer to the drogue centre than this puts the probe head on the canopy, m.
    pub fn strike_radius_m(&self) -> f64 {
        self.canopy_radius_m + self.probe_head_radius_m
    }
}

/// A segment with a radius, fixed on the receiver: body axes from the CG, m.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Capsule {
    /// What it is (`"probe"`, `"radome"`, `"cockpit canopy"`).
    pub name: &'static str,
    /// One end, body axes from the CG, m.
    pub a_body_m: [f64; 3],
    /// The other end, body axes from the CG, m.
    pub b_body_m: [f64; 3],
    /// Radius, m.
    pub radius_m: f64,
}

/// The receiver's forward airframe as the referee sees it: the probe and two envelopes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Airframe {
    /// The probe tip, body axes from the CG, m.
    pub probe_tip_body_m: [f64; 3],
    /// The probe's mast from its root to the tip.
    pub probe: Capsule,
    /// The radome and forward fuselage.
    pub radome: Capsule,
    /// The cockpit canopy.
    pub canopy: Capsule,
}

/// The simulation's nose reference, body axes from the CG, m: the point the bow-wave model
/// is referred to ([R]'s; `crate::world::BOW_WAVE_NOSE_FROM_CG_M`, at the probe's height).
const NOSE_X_M: f64 = 3.75;

impl Airframe {
    /// The F-16 receiver of the simulation with its probe tip at `probe_tip_body_m` (ours:
    /// envelopes sized from the F-16's published overall dimensions, USAF fact sheet, length
    /// 15.0 m, fuselage about 1.2 m across at the cockpit, placed on the simulation's own
    /// nose reference: the probe's mast runs from the nose reference's station to the tip;
    /// the radome is a 0.55 m capsule from the nose reference back 2.5 m; the cockpit canopy
    /// a 0.45 m capsule 2.6 m long whose top is 1.45 m above the CG's waterline).
    pub fn f16(probe_tip_body_m: [f64; 3]) -> Self {
        let [tx, ty, tz] = probe_tip_body_m;
        Self {
            probe_tip_body_m,
            probe: Capsule {
                name: "probe",
                a_body_m: [NOSE_X_M.min(tx), ty, tz],
                b_body_m: [tx, ty, tz],
                radius_m: 0.05,
            },
            radome: Capsule {
                name: "radome",
                a_body_m: [NOSE_X_M, 0.0, -0.3],
                b_body_m: [NOSE_X_M - 2.5, 0.0, -0.3],
                radius_m: 0.55,
            },
            canopy: Capsule {
                name: "cockpit canopy",
                a_body_m: [1.5, 0.0, -1.0],
                b_body_m: [-1.1, 0.0, -1.0],
                radius_m: 0.45,
            },
        }
    }

    fn capsules(&self) -> [&Capsule; 3] {
        [&self.probe, &self.radome, &self.canopy]
    }
}

/// What the world and the receiver are at one instant, tanker frame (x forward, y right,
/// z down; origin the hose exit), SI.
#[derive(Debug, Clone, Copy)]
pub struct Truth<'a> {
    /// Time, s.
    pub time_s: f64,
    /// The probe tip, m (the airframe's tip point, as the simulation computes it).
    pub probe_tip_tanker_m: Vector3<f64>,
    /// Receiver CG, m.
    pub cg_tanker_m: Vector3<f64>,
    /// Receiver CG velocity relative to the tanker, m/s.
    pub cg_velocity_tanker_mps: Vector3<f64>,
    /// Receiver attitude: tanker (= NED) axes from body axes.
    pub tanker_from_body: Rotation3<f64>,
    /// Receiver body rates, rad/s.
    pub rate_body_radps: Vector3<f64>,
    /// Drogue centre, m.
    pub drogue_centre_tanker_m: Vector3<f64>,
    /// Drogue velocity, m/s.
    pub drogue_velocity_tanker_mps: Vector3<f64>,
    /// Drogue axis, from the hose toward the drogue (aft), unit.
    pub drogue_axis_tanker: Vector3<f64>,
    /// Hose nodes from the exit (index 0) to the drogue centre (last); empty when the drogue
    /// is held fixed (no hose modelled).
    pub hose_tanker_m: &'a [Vector3<f64>],
}

impl Truth<'_> {
    /// A point fixed on the receiver, tanker frame, m.
    fn point(&self, body_m: &[f64; 3]) -> Vector3<f64> {
        self.cg_tanker_m + self.tanker_from_body * Vector3::from(*body_m)
    }

    /// The velocity of a point fixed on the receiver relative to the tanker, m/s.
    fn point_velocity(&self, body_m: &[f64; 3]) -> Vector3<f64> {
        self.cg_velocity_tanker_mps
            + self.tanker_from_body * self.rate_body_radps.cross(&Vector3::from(*body_m))
    }
}

/// The receiver's flight at one control step, for the upset check.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlightTruth {
    /// Time, s.
    pub time_s: f64,
    /// Bank (roll) angle, rad.
    pub bank_rad: f64,
    /// Pitch attitude, rad.
    pub pitch_rad: f64,
    /// Angle of attack to the air (gusts and wake included), rad.
    pub alpha_rad: f64,
    /// Normal load factor, g: minus the aerodynamic and thrust force along body z over weight.
    pub load_factor: f64,
    /// Receiver CG, tanker frame, m.
    pub cg_tanker_m: Vector3<f64>,
    /// Receiver CG velocity relative to the tanker, m/s.
    pub cg_velocity_tanker_mps: Vector3<f64>,
    /// Drogue centre, tanker frame, m.
    pub drogue_centre_tanker_m: Vector3<f64>,
}

/// The kinds of hazard (module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HazardKind {
    /// The probe through or onto the basket without a latch.
    BasketStrike,
    /// Into the coupling outside its closing band or lateral limit.
    HardContact,
    /// The drogue on the radome or cockpit canopy.
    DrogueOnAirframe,
    /// The hose on the probe, radome or cockpit canopy.
    HoseContact,
    /// Inside the keep-out sphere around the hose exit.
    TankerProximity,
    /// Bank, pitch, angle of attack or load factor beyond their limits near the tanker.
    Upset,
}

impl HazardKind {
    /// Every kind, in the order reports list them.
    pub const ALL: [HazardKind; 6] = [
        HazardKind::BasketStrike,
        HazardKind::HardContact,
        HazardKind::DrogueOnAirframe,
        HazardKind::HoseContact,
        HazardKind::TankerProximity,
        HazardKind::Upset,
    ];

    /// The name used in files (`basket_strike`, ...).
    pub fn name(self) -> &'static str {
        match self {
            Self::BasketStrike => "basket_strike",
            Self::HardContact => "hard_contact",
            Self::DrogueOnAirframe => "drogue_on_airframe",
            Self::HoseContact => "hose_contact",
            Self::TankerProximity => "tanker_proximity",
            Self::Upset => "upset",
        }
    }

    fn index(self) -> usize {
        self as usize
    }
}

/// One hazard: what, when, where, how fast, and the judged quantity against its limit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Hazard {
    /// Which.
    pub kind: HazardKind,
    /// Onset, s.
    pub time_s: f64,
    /// Where, tanker frame, m: the probe tip at a crossing; the receiver's point nearest the
    /// drogue, hose or exit at a contact; the CG at an upset.
    pub position_tanker_m: [f64; 3],
    /// How fast, m/s: the probe tip relative to the drogue at a crossing; the receiver's
    /// point relative to the tanker at a contact; the CG relative to the tanker at an upset.
    pub speed_mps: f64,
    /// The judged quantity at its worst during the hazard (a distance in m, a speed in m/s,
    /// an angle in degrees, a load factor in g).
    pub measure: f64,
    /// The limit it was judged against, in the same unit.
    pub limit: f64,
    /// What exactly: the part, or the quantity (`"closing 2.91 m/s above 2.6"`).
    pub what: String,
}

/// Which way the probe tip crossed the drogue plane.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Direction {
    /// From behind the drogue to ahead of it (the way in).
    Inbound,
    /// From ahead back to behind (backing out past it).
    Outbound,
}

/// The referee's verdict on one crossing of the drogue plane.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CrossingVerdict {
    /// Inside the capture radius, closing in the band, across within the lateral limit: the
    /// coupling latched.
    Docked,
    /// Inside the capture radius outside the band or the lateral limit.
    HardContact,
    /// Outside the capture radius within the canopy plus the probe head, or backing out
    /// through it.
    BasketStrike,
    /// Clear of the canopy.
    FlyBy,
}

/// One crossing of the drogue plane, as the referee saw it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CrossingRecord {
    /// Time of the crossing (interpolated between physics steps), s.
    pub time_s: f64,
    /// Which way.
    pub direction: Direction,
    /// Probe tip relative to the drogue centre in the plane, seen from behind: right, up, m.
    pub offset_m: [f64; 2],
    /// Radial offset, m.
    pub miss_m: f64,
    /// Closing speed along the tanker x axis (negative outbound), m/s.
    pub closing_mps: f64,
    /// Speed of the probe tip relative to the drogue across the x axis, m/s.
    pub lateral_mps: f64,
    /// The verdict.
    pub verdict: CrossingVerdict,
}

/// What the referee concluded about a run.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Verdict {
    /// The crossing that latched, if any.
    pub docking: Option<CrossingRecord>,
    /// Every crossing of the drogue plane, in time order.
    pub crossings: Vec<CrossingRecord>,
    /// Every hazard, in order of onset.
    pub hazards: Vec<Hazard>,
}

impl Verdict {
    /// The coupling latched.
    pub fn docked(&self) -> bool {
        self.docking.is_some()
    }

    /// No hazard occurred.
    pub fn safe(&self) -> bool {
        self.hazards.is_empty()
    }

    /// Docked and safe: the run's success.
    pub fn success(&self) -> bool {
        self.docked() && self.safe()
    }

    /// How many hazards of `kind`.
    pub fn count(&self, kind: HazardKind) -> usize {
        self.hazards.iter().filter(|h| h.kind == kind).count()
    }
}

/// The continuing hazards' kinds, whose episodes are tracked.
const CONTINUING: [HazardKind; 4] = [
    HazardKind::DrogueOnAirframe,
    HazardKind::HoseContact,
    HazardKind::TankerProximity,
    HazardKind::Upset,
];

/// Points sampled on the canopy's rim for the airframe check.
const RIM_POINTS: usize = 12;

/// The referee of one run. Feed it the truth of every physics step ([`Referee::observe`]) and
/// of every control step ([`Referee::observe_flight`]); read [`Referee::verdict`] at the end.
#[derive(Debug, Clone)]
pub struct Referee {
    limits: Limits,
    airframe: Airframe,
    plane: PlaneCrossing,
    verdict: Verdict,
    /// For each kind, the index in `verdict.hazards` of its open episode.
    open: [Option<usize>; 6],
}

/// A candidate hazard found in one step: its quantity, its limit and where.
struct Finding {
    measure: f64,
    limit: f64,
    at: Vector3<f64>,
    speed_mps: f64,
    what: String,
    /// Larger measure is worse (a speed, an angle), or smaller (a distance).
    larger_is_worse: bool,
}

/// The airframe's capsules placed in the tanker frame for one step, and a sphere that holds
/// them all (a cheap first test: a hazard farther than the sphere's radius cannot be one).
struct Placed<'a> {
    capsules: [(Vector3<f64>, Vector3<f64>, &'a Capsule); 3],
    centre: Vector3<f64>,
    radius_m: f64,
}

impl<'a> Placed<'a> {
    fn new(airframe: &'a Airframe, t: &Truth<'_>) -> Self {
        let capsules = airframe
            .capsules()
            .map(|c| (t.point(&c.a_body_m), t.point(&c.b_body_m), c));
        let centre = capsules
            .iter()
            .fold(Vector3::zeros(), |s, (a, b, _)| s + a + b)
            / 6.0;
        let radius_m = capsules.iter().fold(0.0_f64, |r, (a, b, c)| {
            r.max((a - centre).norm() + c.radius_m)
                .max((b - centre).norm() + c.radius_m)
        });
        Self {
            capsules,
            centre,
            radius_m,
        }
    }

    /// Whether a point can be within `reach` of any capsule's surface.
    fn may_reach(&self, p: &Vector3<f64>, reach: f64) -> bool {
        (p - self.centre).norm() <= self.radius_m + reach
    }
}

impl Referee {
    /// A referee with these limits for this airframe.
    pub fn new(limits: Limits, airframe: Airframe) -> Self {
        Self {
            limits,
            airframe,
            plane: PlaneCrossing::default(),
            verdict: Verdict::default(),
            open: [None; 6],
        }
    }

    /// The limits judged by.
    pub fn limits(&self) -> &Limits {
        &self.limits
    }

    /// The crossing that latched, once it has.
    pub fn docking(&self) -> Option<&CrossingRecord> {
        self.verdict.docking.as_ref()
    }

    /// The verdict so far.
    pub fn verdict(&self) -> &Verdict {
        &self.verdict
    }

    /// The verdict, at the end of the run.
    pub fn into_verdict(self) -> Verdict {
        self.verdict
    }

    /// Judges one physics step's truth: the drogue plane, the drogue against the airframe,
    /// the hose against the airframe, the tanker's keep-out sphere. Returns the crossing of
    /// the drogue plane in this step, if there was one. After a docking nothing more is
    /// judged (the probe is in the coupling).
    pub fn observe(&mut self, t: &Truth<'_>) -> Option<CrossingRecord> {
        if self.verdict.docked() {
            return None;
        }
        let crossing = self.judge_plane(t, &t.probe_tip_tanker_m);
        let placed = Placed::new(&self.airframe, t);
        let airframe = self.drogue_on_airframe(t, &placed);
        let hose = self.hose_contact(t, &placed);
        let tanker = self.tanker_proximity(t, &placed);
        self.track(HazardKind::DrogueOnAirframe, t.time_s, airframe);
        self.track(HazardKind::HoseContact, t.time_s, hose);
        self.track(HazardKind::TankerProximity, t.time_s, tanker);
        crossing
    }

    /// Judges one control step's flight (upsets near the tanker).
    pub fn observe_flight(&mut self, f: &FlightTruth) {
        if self.verdict.docked() {
            return;
        }
        let l = &self.limits;
        let near = (f.drogue_centre_tanker_m - f.cg_tanker_m).norm() <= l.upset_distance_m;
        let deg = f64::to_degrees;
        let finding = near
            .then(|| {
                let excess = [
                    (
                        f.bank_rad.abs() - l.max_bank_rad,
                        "bank",
                        deg(f.bank_rad.abs()),
                        deg(l.max_bank_rad),
                    ),
                    (
                        f.pitch_rad - l.pitch_range_rad.1,
                        "pitch up",
                        deg(f.pitch_rad),
                        deg(l.pitch_range_rad.1),
                    ),
                    (
                        l.pitch_range_rad.0 - f.pitch_rad,
                        "pitch down",
                        deg(f.pitch_rad),
                        deg(l.pitch_range_rad.0),
                    ),
                    (
                        f.alpha_rad - l.alpha_range_rad.1,
                        "angle of attack high",
                        deg(f.alpha_rad),
                        deg(l.alpha_range_rad.1),
                    ),
                    (
                        l.alpha_range_rad.0 - f.alpha_rad,
                        "angle of attack low",
                        deg(f.alpha_rad),
                        deg(l.alpha_range_rad.0),
                    ),
                    // Each quantity against its own limit, in its own unit.
                    (
                        f.load_factor - l.load_factor_range.1,
                        "load factor high",
                        f.load_factor,
                        l.load_factor_range.1,
                    ),
                    (
                        l.load_factor_range.0 - f.load_factor,
                        "load factor low",
                        f.load_factor,
                        l.load_factor_range.0,
                    ),
                ];
                excess
                    .into_iter()
                    .find(|(e, ..)| *e > 0.0)
                    .map(|(_, what, measure, limit)| Finding {
                        measure,
                        limit,
                        at: f.cg_tanker_m,
                        speed_mps: f.cg_velocity_tanker_mps.norm(),
                        what: what.into(),
                        // Beyond an upper limit larger is worse; beyond a lower one smaller.
                        larger_is_worse: measure >= limit,
                    })
            })
            .flatten();
        self.track(HazardKind::Upset, f.time_s, finding);
    }

    /// The drogue plane: a crossing this step, judged.
    fn judge_plane(&mut self, t: &Truth<'_>, tip: &Vector3<f64>) -> Option<CrossingRecord> {
        let c = self
            .plane
            .observe(t.time_s, t.drogue_centre_tanker_m - tip)?;
        let l = self.limits;
        let relative =
            t.point_velocity(&self.airframe.probe_tip_body_m) - t.drogue_velocity_tanker_mps;
        let lateral_mps = relative.y.hypot(relative.z);
        let direction = if c.closing_mps > 0.0 {
            Direction::Inbound
        } else {
            Direction::Outbound
        };
        let in_band = (l.closing_band_mps.0..=l.closing_band_mps.1).contains(&c.closing_mps);
        let verdict = match direction {
            Direction::Inbound if c.miss_m < l.capture_radius_m => {
                if in_band && lateral_mps <= l.max_lateral_mps {
                    CrossingVerdict::Docked
                } else {
                    CrossingVerdict::HardContact
                }
            }
            _ if c.miss_m < l.strike_radius_m() => CrossingVerdict::BasketStrike,
            _ => CrossingVerdict::FlyBy,
        };
        let record = CrossingRecord {
            time_s: c.time_s,
            direction,
            offset_m: c.offset_right_up_m,
            miss_m: c.miss_m,
            closing_mps: c.closing_mps,
            lateral_mps,
            verdict,
        };
        self.verdict.crossings.push(record);
        let tip_at = [tip.x, tip.y, tip.z];
        let speed_mps = relative.norm();
        match verdict {
            CrossingVerdict::Docked => self.verdict.docking = Some(record),
            CrossingVerdict::HardContact => {
                let (measure, limit, what) = if c.closing_mps > l.closing_band_mps.1 {
                    (
                        c.closing_mps,
                        l.closing_band_mps.1,
                        format!(
                            "closing {:.2} m/s above {}",
                            c.closing_mps, l.closing_band_mps.1
                        ),
                    )
                } else if c.closing_mps < l.closing_band_mps.0 {
                    (
                        c.closing_mps,
                        l.closing_band_mps.0,
                        format!(
                            "closing {:.2} m/s below {}: no latch",
                            c.closing_mps, l.closing_band_mps.0
                        ),
                    )
                } else {
                    (
                        lateral_mps,
                        l.max_lateral_mps,
                        format!("lateral {lateral_mps:.2} m/s above {}", l.max_lateral_mps),
                    )
                };
                self.verdict.hazards.push(Hazard {
                    kind: HazardKind::HardContact,
                    time_s: c.time_s,
                    position_tanker_m: tip_at,
                    speed_mps,
                    measure,
                    limit,
                    what,
                });
            }
            CrossingVerdict::BasketStrike => self.verdict.hazards.push(Hazard {
                kind: HazardKind::BasketStrike,
                time_s: c.time_s,
                position_tanker_m: tip_at,
                speed_mps,
                measure: c.miss_m,
                limit: l.strike_radius_m(),
                what: format!(
                    "{} {:.3} m from the centre",
                    match direction {
                        Direction::Inbound => "through the canopy",
                        Direction::Outbound => "backing out through the canopy",
                    },
                    c.miss_m
                ),
            }),
            CrossingVerdict::FlyBy => {}
        }
        Some(record)
    }

    /// The drogue's rim and centre against the radome and the cockpit canopy.
    fn drogue_on_airframe(&self, t: &Truth<'_>, placed: &Placed<'_>) -> Option<Finding> {
        let l = &self.limits;
        let centre = t.drogue_centre_tanker_m;
        if !placed.may_reach(&centre, l.canopy_radius_m + l.airframe_clearance_m) {
            return None;
        }
        let axis = t.drogue_axis_tanker;
        // Two unit vectors across the axis, for the rim.
        let helper = if axis.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::z()
        };
        let u = axis.cross(&helper).normalize();
        let v = axis.cross(&u);
        let rim = (0..RIM_POINTS).map(|k| {
            let a = std::f64::consts::TAU * k as f64 / RIM_POINTS as f64;
            centre + (u * a.cos() + v * a.sin()) * l.canopy_radius_m
        });
        let mut worst: Option<(f64, Vector3<f64>, &Capsule)> = None;
        // The probe is not judged against the drogue here: that is the crossing's verdict.
        for (a, b, cap) in placed.capsules.iter().skip(1) {
            for p in std::iter::once(centre).chain(rim.clone()) {
                let (d, q) = point_segment(&p, a, b);
                let gap = d - cap.radius_m;
                if worst.is_none_or(|w| gap < w.0) {
                    worst = Some((gap, q, cap));
                }
            }
        }
        let (gap, q, cap) = worst?;
        (gap < l.airframe_clearance_m).then(|| {
            let body = t
                .tanker_from_body
                .inverse_transform_vector(&(q - t.cg_tanker_m));
            Finding {
                measure: gap,
                limit: l.airframe_clearance_m,
                at: q,
                speed_mps: (t.point_velocity(&[body.x, body.y, body.z])
                    - t.drogue_velocity_tanker_mps)
                    .norm(),
                what: format!("drogue {gap:.3} m from the {}", cap.name),
                larger_is_worse: false,
            }
        })
    }

    /// The hose (less the drogue assembly's end) against the probe, radome and canopy.
    fn hose_contact(&self, t: &Truth<'_>, placed: &Placed<'_>) -> Option<Finding> {
        let l = &self.limits;
        let nodes = t.hose_tanker_m;
        if nodes.len() < 2 {
            return None;
        }
        let reach = l.hose_radius_m + l.hose_clearance_m;
        // The hose's length from the drogue end backwards; the assembly's end is skipped.
        let mut from_drogue = 0.0;
        let mut worst: Option<(f64, Vector3<f64>, &Capsule)> = None;
        for w in nodes.windows(2).rev() {
            let (near_exit, near_drogue) = (w[0], w[1]);
            let len = (near_drogue - near_exit).norm();
            let skip = (l.drogue_assembly_length_m - from_drogue).clamp(0.0, len);
            from_drogue += len;
            if skip >= len || len == 0.0 {
                continue;
            }
            let end = near_drogue + (near_exit - near_drogue) * (skip / len);
            // A link whose nearest point is beyond the sphere's reach is clear of every part.
            if point_segment(&placed.centre, &near_exit, &end).0 > placed.radius_m + reach {
                continue;
            }
            for (a, b, cap) in &placed.capsules {
                let (d, q) = segment_segment(a, b, &near_exit, &end);
                let gap = d - cap.radius_m - l.hose_radius_m;
                if worst.is_none_or(|w| gap < w.0) {
                    worst = Some((gap, q, cap));
                }
            }
        }
        let (gap, q, cap) = worst?;
        (gap < l.hose_clearance_m).then(|| {
            let body = t
                .tanker_from_body
                .inverse_transform_vector(&(q - t.cg_tanker_m));
            Finding {
                measure: gap,
                limit: l.hose_clearance_m,
                at: q,
                speed_mps: t.point_velocity(&[body.x, body.y, body.z]).norm(),
                what: format!("hose {gap:.3} m from the {}", cap.name),
                larger_is_worse: false,
            }
        })
    }

    /// The airframe against the keep-out sphere around the hose exit (the tanker frame's
    /// origin).
    fn tanker_proximity(&self, t: &Truth<'_>, placed: &Placed<'_>) -> Option<Finding> {
        let l = &self.limits;
        let origin = Vector3::zeros();
        if !placed.may_reach(&origin, l.tanker_keep_out_m) {
            return None;
        }
        let (gap, q, cap) = placed
            .capsules
            .iter()
            .map(|(a, b, c)| {
                let (d, q) = point_segment(&origin, a, b);
                // `q` is on the axis; the surface is `radius` nearer.
                (d - c.radius_m, q, *c)
            })
            .min_by(|x, y| x.0.total_cmp(&y.0))?;
        (gap < l.tanker_keep_out_m).then(|| Finding {
            measure: gap,
            limit: l.tanker_keep_out_m,
            at: q,
            speed_mps: t.cg_velocity_tanker_mps.norm(),
            what: format!("the {} {gap:.2} m from the hose exit", cap.name),
            larger_is_worse: false,
        })
    }

    /// Opens, updates or closes the episode of a continuing hazard.
    fn track(&mut self, kind: HazardKind, time_s: f64, finding: Option<Finding>) {
        debug_assert!(CONTINUING.contains(&kind));
        let slot = &mut self.open[kind.index()];
        match (finding, *slot) {
            (None, _) => *slot = None,
            (Some(f), Some(i)) => {
                let h = &mut self.verdict.hazards[i];
                // The same quantity (the limit names it) at a worse value.
                let worse = if f.larger_is_worse {
                    f.measure > h.measure
                } else {
                    f.measure < h.measure
                };
                if f.limit == h.limit && worse {
                    h.measure = f.measure;
                    h.what = f.what;
                }
            }
            (Some(f), None) => {
                *slot = Some(self.verdict.hazards.len());
                self.verdict.hazards.push(Hazard {
                    kind,
                    time_s,
                    position_tanker_m: [f.at.x, f.at.y, f.at.z],
                    speed_mps: f.speed_mps,
                    measure: f.measure,
                    limit: f.limit,
                    what: f.what,
                });
            }
        }
    }
}

/// Distance from `p` to the segment `a`-`b`, and the segment's nearest point.
fn point_segment(p: &Vector3<f64>, a: &Vector3<f64>, b: &Vector3<f64>) -> (f64, Vector3<f64>) {
    let ab = b - a;
    let len2 = ab.norm_squared();
    let s = if len2 > 0.0 {
        ((p - a).dot(&ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let q = a + ab * s;
    ((p - q).norm(), q)
}

/// Distance between the segments `p1`-`q1` and `p2`-`q2`, and the nearest point on the first
/// (Ericson, *Real-Time Collision Detection*, 2005, sec. 5.1.9).
fn segment_segment(
    p1: &Vector3<f64>,
    q1: &Vector3<f64>,
    p2: &Vector3<f64>,
    q2: &Vector3<f64>,
) -> (f64, Vector3<f64>) {
    let (d1, d2, r) = (q1 - p1, q2 - p2, p1 - p2);
    let (a, e, f) = (d1.norm_squared(), d2.norm_squared(), d2.dot(&r));
    const EPS: f64 = 1e-12;
    let (s, t) = if a <= EPS && e <= EPS {
        (0.0, 0.0)
    } else if a <= EPS {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(&r);
        if e <= EPS {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(&d2);
            let denom = a * e - b * b;
            let mut s = if denom > EPS {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let mut t = (b * s + f) / e;
            if t < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, t)
        }
    };
    let (c1, c2) = (p1 + d1 * s, p2 + d2 * t);
    ((c1 - c2).norm(), c1)
}

#[cfg(test)]
mod tests;
