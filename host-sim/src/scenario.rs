//! Scenario files: what a user writes to describe a run, the built-in presets, and their
//! validation.
//!
//! A scenario is TOML. Every key is optional (the defaults are the paper's start in calm air
//! with the tanker's wake, the full hose and drogue and the LED camera); an unknown key is an
//! error that names it; a value out of range is an error that names the key and the allowed
//! range. [`ScenarioFile::scenario`] and [`ScenarioFile::controller_config`] turn a validated
//! file into the simulator's [`Scenario`] and the controller's [`ControllerConfig`].
//!
//! The controller's settings are one table, `[controller]`, whose keys are
//! [`ControllerConfig`]'s own fields ([`controller`]: no second copy of the configuration's
//! schema lives here); the world decides the two settings that describe the installation
//! (where the camera is believed to be, the navigation's latency) unless that table gives
//! them.
//!
//! The `[dispersion]` table is read only by Monte Carlo campaigns (`host-sim montecarlo`):
//! it gives ranges, and [`ScenarioFile::dispersed`] turns the file and a run index into the
//! file of that run, with every dispersed value drawn uniformly from its range by a generator
//! seeded from the file's seed and the index alone (each value from its own stream, so adding
//! or removing one key leaves the others' draws unchanged).
//!
//! Invariants: a built scenario only contains values that passed [`ScenarioFile::validate`];
//! a dispersed file validates whenever its base file does.

use ibvs_core::ControllerConfig;
use ibvs_core::kinematics::SET_BACK_CAMERA_BODY_M;
use ibvs_core::schedule::MassEnvelope;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::receiver::{AutopilotParams, FACTORS, ReceiverPlant, ReceiverPlantRanges};
use crate::sim::{CameraChoice, PAPER_START_M, Scenario};
use crate::synthesis::{NOMINAL_XCG, PROBE_TIP_BODY_M};
use crate::world::camera::CameraParams;
use crate::world::flight::{FlightCondition, FlightConditionError};
use crate::world::hose::{
    DROGUE_DRAG_COEFFICIENT, DROGUE_MASS_KG, HOSE_LENGTH_M, HOSE_LINEAR_DENSITY_KG_PER_M,
    HoseParams,
};
use crate::world::led_camera::LedCameraParams;
use crate::world::lens::IntrinsicsError;
use crate::world::nav::{InsErrors, InsGrade};
use crate::world::turbulence::TurbulencePreset;
use crate::world::wake::WakeParams;

pub mod controller;
mod input;

pub use input::MAX_SCENARIO_BYTES;

pub use controller::{ControllerKeyError, ControllerSection};

/// Which drogue model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DrogueModel {
    /// Multi-link hose and drogue, dynamic.
    #[default]
    Hose,
    /// Drogue held at its nominal steady-trail position.
    Fixed,
}

/// Which camera model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CameraModel {
    /// LED ring, pixel noise, circle fit, latency, drops.
    #[default]
    Led,
    /// Ideal pinhole: exact image point and depth, no latency.
    Ideal,
}

/// Where the camera sits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CameraPlacement {
    /// Set back from the probe tip on the nose
    /// ([`ibvs_core::kinematics::SET_BACK_CAMERA_BODY_M`]): sees the drogue until contact.
    #[default]
    SetBack,
    /// At the probe tip (the paper's Assumption 3): blind inside about 0.7 m.
    ProbeTip,
}

impl CameraPlacement {
    /// The camera's true position, body axes, m.
    pub fn position_body_m(self) -> nalgebra::Vector3<f64> {
        match self {
            Self::SetBack => SET_BACK_CAMERA_BODY_M.map(f64::from).into(),
            Self::ProbeTip => PROBE_TIP_BODY_M.into(),
        }
    }
}

/// Which navigation model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum NavModel {
    /// A GNSS-aided INS with the errors of `[navigation.ins]`.
    #[default]
    Ins,
    /// Perfect navigation (truth).
    Ideal,
}

/// `[navigation]`. Read through `NavigationKeys`: `ins` is the grade's figures with each
/// figure `[navigation.ins]` gives in its place, so a file is written out whole and reads
/// back the same.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(from = "NavigationKeys")]
pub struct NavigationSection {
    /// Model.
    pub model: NavModel,
    /// The INS's sensor suite, whose figures `ins` starts from (`docs/models.md`,
    /// "Navigation"): `"tactical"` (the default) or `"industrial"`.
    pub grade: InsGrade,
    /// The INS's error figures (`docs/models.md`, "Navigation").
    pub ins: InsErrors,
}

/// `[navigation]` as written: every key optional, `[navigation.ins]` figure by figure.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct NavigationKeys {
    model: NavModel,
    grade: InsGrade,
    ins: InsKeys,
}

/// `[navigation.ins]` as written: the figures given, each replacing the grade's.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct InsKeys {
    attitude_bias_deg: Option<f64>,
    heading_bias_deg: Option<f64>,
    attitude_noise_deg: Option<f64>,
    gyro_bias_deg_per_h: Option<f64>,
    gyro_random_walk_deg_per_rt_h: Option<f64>,
    velocity_bias_mps: Option<f64>,
    velocity_noise_mps: Option<f64>,
    position_noise_m: Option<f64>,
    latency_steps: Option<u32>,
}

impl From<NavigationKeys> for NavigationSection {
    fn from(k: NavigationKeys) -> Self {
        let g = k.grade.errors();
        let i = k.ins;
        Self {
            model: k.model,
            grade: k.grade,
            ins: InsErrors {
                attitude_bias_deg: i.attitude_bias_deg.unwrap_or(g.attitude_bias_deg),
                heading_bias_deg: i.heading_bias_deg.unwrap_or(g.heading_bias_deg),
                attitude_noise_deg: i.attitude_noise_deg.unwrap_or(g.attitude_noise_deg),
                gyro_bias_deg_per_h: i.gyro_bias_deg_per_h.unwrap_or(g.gyro_bias_deg_per_h),
                gyro_random_walk_deg_per_rt_h: i
                    .gyro_random_walk_deg_per_rt_h
                    .unwrap_or(g.gyro_random_walk_deg_per_rt_h),
                velocity_bias_mps: i.velocity_bias_mps.unwrap_or(g.velocity_bias_mps),
                velocity_noise_mps: i.velocity_noise_mps.unwrap_or(g.velocity_noise_mps),
                position_noise_m: i.position_noise_m.unwrap_or(g.position_noise_m),
                latency_steps: i.latency_steps.unwrap_or(g.latency_steps),
            },
        }
    }
}

impl NavigationSection {
    /// The latency the installation data gives the controller (its `nav_latency_steps`
    /// unless `[controller]` states one): the INS's own, 0 with ideal navigation.
    pub fn installed_latency_steps(&self) -> u8 {
        match self.model {
            NavModel::Ins => u8::try_from(self.ins.latency_steps).unwrap_or(u8::MAX),
            NavModel::Ideal => 0,
        }
    }
}

/// `[initial]`: start geometry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct InitialSection {
    /// Drogue centre minus probe tip at t = 0, tanker axes (forward, right, down), m.
    pub drogue_minus_probe_m: [f64; 3],
}

/// `[turbulence]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TurbulenceSection {
    /// Intensity preset.
    pub preset: TurbulencePreset,
    /// RMS gust speed, m/s; overrides the preset when given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sigma_mps: Option<f64>,
    /// Probability of exceedance: the RMS gust speed is MIL-F-8785C's for it at the flight
    /// altitude ([`crate::world::turbulence::mil_f_8785c_sigma_mps`]); overrides the preset,
    /// overridden by `sigma_mps` (so a dispersed intensity wins).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub exceedance_probability: Option<f64>,
    /// Dryden scale length, all axes, m; MIL-F-8785C's at the flight altitude when not given
    /// ([`crate::world::turbulence::mil_f_8785c_scale_lengths_m`]: 533.4 m from 2,000 ft).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scale_length_m: Option<f64>,
}

/// A section with an on/off switch and a strength (`[bow_wave]`, `[tanker_wake]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Switch {
    /// On or off.
    pub enabled: bool,
    /// Factor on the model's effect when on (the bow wave's force, the wake's circulation in
    /// its induced velocity), 1 by default: the model as published.
    #[serde(default = "unit_strength")]
    pub strength: f64,
}

/// The default of [`Switch::strength`].
fn unit_strength() -> f64 {
    1.0
}

/// `[drogue]`: the model, and the hose and drogue's physical parameters (used by the hose
/// model; the fixed drogue holds its nominal trail whatever they are).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DrogueSection {
    /// Model.
    pub model: DrogueModel,
    /// Drogue mass, kg (default 29.484, \\[R\\]).
    pub drogue_mass_kg: f64,
    /// Canopy drag coefficient on `pi D^2 / 4` (default 0.8, \\[R\\]).
    pub drogue_drag_coefficient: f64,
    /// Trailed hose length, exit to drogue centre, m (default 14.3256, \\[R\\]).
    pub hose_length_m: f64,
    /// Hose mass per length, kg/m (default 4.0925, \\[R\\]).
    pub hose_linear_density_kg_per_m: f64,
    /// Factor on the hose links' drag coefficients (default 1).
    pub hose_drag_scale: f64,
}

impl DrogueSection {
    /// The hose model's parameters this section states (the rest the model's defaults).
    pub fn hose_params(&self) -> HoseParams {
        HoseParams {
            drogue_mass_kg: self.drogue_mass_kg,
            drogue_drag_coefficient: self.drogue_drag_coefficient,
            hose_length_m: self.hose_length_m,
            hose_linear_density_kg_per_m: self.hose_linear_density_kg_per_m,
            hose_drag_scale: self.hose_drag_scale,
            ..HoseParams::default()
        }
    }
}

/// `[camera]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CameraSection {
    /// Model.
    pub model: CameraModel,
    /// Where it sits (the controller believes it there, less `mount_error_m`).
    pub placement: CameraPlacement,
    /// True minus assumed camera position, receiver body axes, m: the controller believes the
    /// camera is at the probe tip minus this.
    pub mount_error_m: [f64; 3],
    /// Error of the camera's boresight pitch, true minus assumed, degrees: the controller
    /// assumes the boresight is level at trim; positive points it further down.
    pub mount_pitch_error_deg: f64,
    /// Error of the camera's roll about its boresight, true minus assumed (none), degrees:
    /// positive turns the image's right side down.
    pub mount_roll_error_deg: f64,
    /// Error of the boresight's yaw, true minus assumed (none), degrees: positive points it
    /// right.
    pub mount_yaw_error_deg: f64,
    /// True minus calibrated focal length, px (the controller's image coordinates use the
    /// calibrated 500 px).
    pub focal_error_px: f64,
    /// True minus calibrated principal point, `[u (right), v (down)]`, px.
    pub principal_point_error_px: [f64; 2],
    /// Radial distortion the calibration leaves uncorrected, `k1` of
    /// `x_d = x (1 + k1 r^2 + k2 r^4)` (normalised coordinates).
    pub radial_distortion_k1: f64,
    /// Radial distortion the calibration leaves uncorrected, `k2`.
    pub radial_distortion_k2: f64,
    /// Pixel noise on each LED centroid (1 sigma), px.
    pub pixel_noise_px: f64,
    /// Frames between capture and delivery.
    pub latency_frames: u32,
    /// Frame rate, Hz.
    pub rate_hz: f64,
    /// Probability that a frame is lost.
    pub drop_probability: f64,
}

impl CameraSection {
    /// The true lens minus the calibration this section states.
    pub fn intrinsics_error(&self) -> IntrinsicsError {
        IntrinsicsError {
            focal_px: self.focal_error_px,
            principal_px: self.principal_point_error_px,
            radial_k: [self.radial_distortion_k1, self.radial_distortion_k2],
        }
    }
}

/// `[receiver]`: the true receiver, which the controller's design does not know.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ReceiverSection {
    /// Centre of gravity, fraction of the mean aerodynamic chord (the paper's gains are
    /// designed at 0.35, the refuelling procedure's at 0.40; the receiver trims at this one).
    pub xcg: f64,
    /// Factors on the true aircraft's aerodynamics, mass, inertia, actuators and engine, each
    /// a key of this table (`elevator_effectiveness = 0.9`, ...; every one 1.0 by default:
    /// [`ReceiverPlant`], limits in [`crate::receiver::FACTORS`]).
    #[serde(flatten)]
    pub plant: ReceiverPlant,
}

/// `[flight]`: the flight condition of the tanker and the trimmed receiver
/// ([`crate::world::flight`] gives its limits and what it changes in the world).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FlightSection {
    /// True airspeed, m/s (calm air: also the ground speed). Default 120.
    pub airspeed_mps: f64,
    /// Altitude, m. Default 3000.
    pub altitude_m: f64,
}

impl FlightSection {
    /// The condition this section states.
    pub fn condition(&self) -> FlightCondition {
        FlightCondition {
            airspeed_mps: self.airspeed_mps,
            altitude_m: self.altitude_m,
        }
    }
}

/// `[dispersion]`: ranges `[min, max]` for a Monte Carlo campaign, each drawn uniformly per
/// run (integers: every value of the range equally likely). A missing key is not dispersed:
/// every run flies the file's value. Only `host-sim montecarlo` reads this table.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DispersionSection {
    /// Each run flies its own seed (turbulence, camera noise and drops), drawn from the
    /// file's seed and the run index (default true); false: every run flies the file's seed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vary_seed: Option<bool>,
    /// Start: drogue centre minus probe tip, per tanker axis (forward, right, down), m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drogue_minus_probe_m: Option<[[f64; 2]; 3]>,
    /// RMS gust speed, m/s (overrides the turbulence preset).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub turbulence_sigma_mps: Option<[f64; 2]>,
    /// Pixel noise per LED centroid, px.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pixel_noise_px: Option<[f64; 2]>,
    /// Camera latency, frames (integers, both ends included).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub latency_frames: Option<[u32; 2]>,
    /// Camera mount position error, per body axis, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mount_error_m: Option<[[f64; 2]; 3]>,
    /// Camera boresight pitch error, degrees.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mount_pitch_error_deg: Option<[f64; 2]>,
    /// Receiver centre of gravity, fraction of the mean chord.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub xcg: Option<[f64; 2]>,
    /// Navigation latency, control periods (integers, both ends included).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nav_latency_steps: Option<[u32; 2]>,
    /// True airspeed of the flight condition, m/s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub airspeed_mps: Option<[f64; 2]>,
    /// Altitude of the flight condition, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub altitude_m: Option<[f64; 2]>,
    /// `[dispersion.receiver]`: ranges of the receiver's plant factors, keyed like
    /// `[receiver]`'s (`mass_scale = [0.85, 1.25]`, ...).
    #[serde(skip_serializing_if = "ReceiverPlantRanges::is_empty")]
    pub receiver: ReceiverPlantRanges,
    /// `[dispersion.drogue]`: the hose and drogue's parameters.
    #[serde(skip_serializing_if = "DrogueDispersion::is_empty")]
    pub drogue: DrogueDispersion,
    /// `[dispersion.turbulence]`: the Dryden scale length.
    #[serde(skip_serializing_if = "TurbulenceDispersion::is_empty")]
    pub turbulence: TurbulenceDispersion,
    /// `[dispersion.tanker_wake]`: the wake's strength.
    #[serde(skip_serializing_if = "StrengthDispersion::is_empty")]
    pub tanker_wake: StrengthDispersion,
    /// `[dispersion.bow_wave]`: the bow wave's strength.
    #[serde(skip_serializing_if = "StrengthDispersion::is_empty")]
    pub bow_wave: StrengthDispersion,
    /// `[dispersion.camera]`: the mount's roll and yaw and the lens against its calibration.
    #[serde(skip_serializing_if = "CameraDispersion::is_empty")]
    pub camera: CameraDispersion,
    /// `[dispersion.navigation]`: the INS's grade.
    #[serde(skip_serializing_if = "NavigationDispersion::is_empty")]
    pub navigation: NavigationDispersion,
    /// `[dispersion.abort]`: where the tanker's breakaway call comes.
    #[serde(skip_serializing_if = "AbortDispersion::is_empty")]
    pub abort: AbortDispersion,
    /// `[dispersion.gross_mass]`: the error of the gross mass the controller is told.
    #[serde(skip_serializing_if = "GrossMassDispersion::is_empty")]
    pub gross_mass: GrossMassDispersion,
}

/// `[abort]`: the tanker's breakaway call, which the receiver must fly whatever it was doing
/// (the simulator requests the controller's `Abort`).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AbortSection {
    /// The call comes at the first step at which the true range to the drogue (its centre
    /// minus the probe tip, tanker x) is at or below this, the controller engaged and the
    /// coupling not latched, m, [`ABORT_RANGE_M`]; none by default.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub at_range_m: Option<f64>,
}

/// `[dispersion.abort]`: the range of `[abort] at_range_m`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AbortDispersion {
    /// Range `[min, max]` of the call's range to the drogue, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub at_range_m: Option<[f64; 2]>,
}

/// Allowed `[abort] at_range_m`, m: above 0 (at the plane the coupling decides) and at most
/// the start's farthest forward offset (`[initial]`'s 30 m).
pub const ABORT_RANGE_M: (f64, f64) = (0.01, 30.0);

/// `[dispersion.drogue]`: ranges `[min, max]` of `[drogue]`'s keys.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DrogueDispersion {
    /// Drogue mass, kg.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drogue_mass_kg: Option<[f64; 2]>,
    /// Canopy drag coefficient.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drogue_drag_coefficient: Option<[f64; 2]>,
    /// Hose length, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hose_length_m: Option<[f64; 2]>,
    /// Hose mass per length, kg/m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hose_linear_density_kg_per_m: Option<[f64; 2]>,
    /// Factor on the hose's drag coefficients.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hose_drag_scale: Option<[f64; 2]>,
}

/// `[dispersion.turbulence]`: ranges of `[turbulence]`'s physical keys (its intensity is the
/// flat `turbulence_sigma_mps`).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TurbulenceDispersion {
    /// Dryden scale length, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scale_length_m: Option<[f64; 2]>,
}

/// `[dispersion.gross_mass]`: the range of `[gross_mass]`'s report error.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GrossMassDispersion {
    /// The reported gross mass over the true one, minus 1.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub report_error: Option<[f64; 2]>,
}

impl GrossMassDispersion {
    /// True when not dispersed.
    pub fn is_empty(&self) -> bool {
        *self == Self::default()
    }
}

/// `[gross_mass]`: the receiver's gross mass as its fuel-quantity and stores systems report
/// it to the flight computer, which chooses the refuelling procedure's inner-loop design by
/// it (`controller.mass_factor`, `docs/conventions.md`, "Two designs by mass").
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GrossMassSection {
    /// The reported gross mass over the true one (`receiver.mass_scale` of the data's),
    /// minus 1. Default 0: the controller is told the truth.
    pub report_error: f64,
}

impl GrossMassSection {
    /// True when the report is exact (the section may be left out).
    pub fn is_empty(&self) -> bool {
        *self == Self::default()
    }
}

/// `[dispersion.tanker_wake]`, `[dispersion.bow_wave]`: the range of the section's strength.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct StrengthDispersion {
    /// Factor on the model's effect.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub strength: Option<[f64; 2]>,
}

/// `[dispersion.camera]`: ranges of `[camera]`'s mount and lens keys (its position and pitch
/// errors, noise and latency are the flat `[dispersion]` keys).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CameraDispersion {
    /// Roll error, degrees.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mount_roll_error_deg: Option<[f64; 2]>,
    /// Yaw error, degrees.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mount_yaw_error_deg: Option<[f64; 2]>,
    /// Focal-length error, px.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub focal_error_px: Option<[f64; 2]>,
    /// Principal-point error, per axis (u, v), px.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub principal_point_error_px: Option<[[f64; 2]; 2]>,
    /// Residual radial distortion `k1`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub radial_distortion_k1: Option<[f64; 2]>,
    /// Residual radial distortion `k2`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub radial_distortion_k2: Option<[f64; 2]>,
}

/// `[dispersion.navigation]`: the INS's grade, drawn per run from a list (each equally
/// likely); the run flies that grade's figures.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NavigationDispersion {
    /// The grades to draw from, for example `["tactical", "industrial"]`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub grade: Option<Vec<InsGrade>>,
}

macro_rules! empty_when_default {
    ($($t:ty),*) => {$(
        impl $t {
            /// True when nothing is dispersed.
            pub fn is_empty(&self) -> bool {
                *self == Self::default()
            }
        }
    )*};
}
empty_when_default!(
    DrogueDispersion,
    TurbulenceDispersion,
    StrengthDispersion,
    CameraDispersion,
    NavigationDispersion,
    AbortDispersion
);

impl AbortSection {
    /// True when no call is made.
    pub fn is_empty(&self) -> bool {
        self.at_range_m.is_none()
    }
}

impl DispersionSection {
    /// True when nothing is dispersed and the seed is the default (per run).
    pub fn is_empty(&self) -> bool {
        *self == Self::default()
    }
}

/// A scenario file. See the module doc and `docs/scenarios.md`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ScenarioFile {
    /// Name, for reports.
    pub name: String,
    /// Seed of every random process of the run.
    pub seed: u64,
    /// Time budget, s.
    pub duration_s: f64,
    /// Physics steps per control period (the receiver's and the hose's RK4 steps, the
    /// turbulence's samples and the docking-plane checks), 1..=8: 1 (a 0.02 s step) by
    /// default, 2 (0.01 s) in the `paper-*` presets. See `docs/models.md`, "Physics step".
    pub plant_substeps: u32,
    /// The controller's configuration (`[controller]`: [`ControllerConfig`]'s keys, each
    /// optional over its default, the refuelling procedure).
    pub controller: ControllerSection,
    /// Start geometry.
    pub initial: InitialSection,
    /// Turbulence.
    pub turbulence: TurbulenceSection,
    /// Bow wave on the drogue.
    pub bow_wave: Switch,
    /// Tanker wake at the drogue and the receiver.
    pub tanker_wake: Switch,
    /// Drogue model.
    pub drogue: DrogueSection,
    /// Camera.
    pub camera: CameraSection,
    /// Receiver.
    pub receiver: ReceiverSection,
    /// Flight condition.
    pub flight: FlightSection,
    /// Navigation.
    pub navigation: NavigationSection,
    /// The tanker's breakaway call.
    #[serde(skip_serializing_if = "AbortSection::is_empty")]
    pub abort: AbortSection,
    /// The gross mass the receiver's systems report to the flight computer.
    #[serde(skip_serializing_if = "GrossMassSection::is_empty")]
    pub gross_mass: GrossMassSection,
    /// The aircraft's autopilot (`[autopilot]`), flying the surfaces when the controller
    /// flies through it (`controller.inner_loop = "attitude"`): its parameters, each
    /// optional over ArduPlane's defaults and this airframe's rate gains (`docs/models.md`,
    /// "Autopilot").
    pub autopilot: AutopilotParams,
    /// Monte Carlo ranges (campaigns only).
    #[serde(skip_serializing_if = "DispersionSection::is_empty")]
    pub dispersion: DispersionSection,
}

/// The paper's camera position error, body axes, m (Sec. IV, experiment 2).
pub const PAPER_MOUNT_ERROR_M: [f64; 3] = [1.0, 0.0, -0.5];

impl Default for ScenarioFile {
    fn default() -> Self {
        Self {
            name: "default".into(),
            seed: 1,
            // Longer than the refuelling procedure's 150 s sortie budget plus a breakaway, so
            // that every run ends in a docking, a strike or a breakaway, never in the
            // simulator's own time limit.
            duration_s: 160.0,
            plant_substeps: 1,
            controller: ControllerSection::default(),
            initial: InitialSection {
                drogue_minus_probe_m: PAPER_START_M,
            },
            turbulence: TurbulenceSection {
                preset: TurbulencePreset::None,
                sigma_mps: None,
                exceedance_probability: None,
                scale_length_m: None,
            },
            bow_wave: Switch {
                enabled: false,
                strength: 1.0,
            },
            tanker_wake: Switch {
                enabled: true,
                strength: 1.0,
            },
            drogue: DrogueSection {
                model: DrogueModel::Hose,
                drogue_mass_kg: DROGUE_MASS_KG,
                drogue_drag_coefficient: DROGUE_DRAG_COEFFICIENT,
                hose_length_m: HOSE_LENGTH_M,
                hose_linear_density_kg_per_m: HOSE_LINEAR_DENSITY_KG_PER_M,
                hose_drag_scale: 1.0,
            },
            camera: CameraSection {
                model: CameraModel::Led,
                placement: CameraPlacement::SetBack,
                mount_error_m: [0.0; 3],
                mount_pitch_error_deg: 0.0,
                mount_roll_error_deg: 0.0,
                mount_yaw_error_deg: 0.0,
                focal_error_px: 0.0,
                principal_point_error_px: [0.0; 2],
                radial_distortion_k1: 0.0,
                radial_distortion_k2: 0.0,
                pixel_noise_px: 0.5,
                latency_frames: 1,
                rate_hz: 50.0,
                drop_probability: 0.0,
            },
            receiver: ReceiverSection {
                xcg: NOMINAL_XCG,
                plant: ReceiverPlant::NOMINAL,
            },
            flight: FlightSection {
                airspeed_mps: FlightCondition::DEFAULT.airspeed_mps,
                altitude_m: FlightCondition::DEFAULT.altitude_m,
            },
            navigation: NavigationSection {
                model: NavModel::Ins,
                grade: InsGrade::Tactical,
                ins: InsGrade::Tactical.errors(),
            },
            abort: AbortSection::default(),
            gross_mass: GrossMassSection::default(),
            autopilot: AutopilotParams::default(),
            dispersion: DispersionSection::default(),
        }
    }
}

impl Default for InitialSection {
    fn default() -> Self {
        ScenarioFile::default().initial
    }
}
impl Default for TurbulenceSection {
    fn default() -> Self {
        ScenarioFile::default().turbulence
    }
}
impl Default for DrogueSection {
    fn default() -> Self {
        ScenarioFile::default().drogue
    }
}
impl Default for CameraSection {
    fn default() -> Self {
        ScenarioFile::default().camera
    }
}
impl Default for ReceiverSection {
    fn default() -> Self {
        ScenarioFile::default().receiver
    }
}
impl Default for FlightSection {
    fn default() -> Self {
        ScenarioFile::default().flight
    }
}
impl Default for NavigationSection {
    fn default() -> Self {
        ScenarioFile::default().navigation
    }
}

/// Why a scenario was rejected.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    /// Not valid TOML, an unknown key, or a value of the wrong type (toml names the key).
    #[error("{source_name}: {message}")]
    Parse {
        /// File name or preset.
        source_name: String,
        /// The parser's message, which names the offending key.
        message: String,
    },
    /// A value outside its allowed range.
    #[error("{key} = {value} is out of range: allowed {allowed}")]
    OutOfRange {
        /// Dotted key.
        key: &'static str,
        /// The value given.
        value: String,
        /// The allowed range.
        allowed: &'static str,
    },
    /// A `[min, max]` range whose minimum exceeds its maximum.
    #[error("{key} = [{min}, {max}]: the minimum exceeds the maximum")]
    EmptyRange {
        /// Dotted key.
        key: &'static str,
        /// Minimum given.
        min: String,
        /// Maximum given.
        max: String,
    },
    /// The controller's configuration the file makes is invalid (the core names the field
    /// and the rule).
    #[error(
        "controller.{field} is {problem:?}: the controller requires {requirement}",
        field = .0.field, problem = .0.problem, requirement = .0.requirement
    )]
    Controller(#[from] ibvs_core::ConfigError),
    /// Two keys give the same thing.
    #[error("{0}")]
    Conflict(&'static str),
    /// An `[autopilot]` parameter is invalid (the rule broken).
    #[error("autopilot: {0}")]
    Autopilot(&'static str),
    /// A flight condition outside the models' validity (the key and the limit named).
    #[error(transparent)]
    Flight(#[from] FlightConditionError),
    /// The receiver model's data could not be loaded (for the atmosphere of the flight
    /// condition's limits).
    #[error("the receiver model: {0}")]
    Model(#[from] crate::receiver::ModelError),
    /// An INS error figure outside its range (the key, the value and the range named).
    #[error(transparent)]
    Navigation(#[from] crate::world::nav::InsRangeError),
    /// Neither a preset name nor a readable file.
    #[error("no preset or file named {0:?} (presets: {presets})", presets = PRESETS.iter().map(|p| p.0).collect::<Vec<_>>().join(", "))]
    NotFound(String),
    /// An error found in a file: its name, the line of the key it names (when found).
    #[error("{name}{}: {source}", line.map(|l| format!(":{l}")).unwrap_or_default())]
    InFile {
        /// The file (or preset).
        name: String,
        /// The 1-based line of the key.
        line: Option<usize>,
        /// The error.
        source: Box<ScenarioError>,
    },
    /// A key of the `[controller]` table that is unknown or of the wrong type.
    #[error(transparent)]
    ControllerKey(#[from] ControllerKeyError),
    /// A key in a form that was renamed: what to write instead.
    #[error("{old} is the form before the controller's settings became one table: write {new}")]
    Renamed {
        /// What the file wrote.
        old: String,
        /// The current form.
        new: String,
    },
    /// A file larger than any scenario (not read beyond the limit).
    #[error("{path} is larger than {limit} bytes: not a scenario file")]
    TooLarge {
        /// Path.
        path: String,
        /// The limit, bytes.
        limit: u64,
    },
    /// The file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// Path.
        path: String,
        /// Error.
        source: std::io::Error,
    },
}

/// Checks `lo <= v <= hi` (and finiteness) for `key`.
fn range(
    key: &'static str,
    v: f64,
    lo: f64,
    hi: f64,
    allowed: &'static str,
) -> Result<(), ScenarioError> {
    if v.is_finite() && (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err(ScenarioError::OutOfRange {
            key,
            value: v.to_string(),
            allowed,
        })
    }
}

/// Checks a dispersion range `[min, max]`: both ends inside `lo..=hi` (as the base key) and
/// `min <= max`.
fn range_pair(
    key: &'static str,
    r: [f64; 2],
    lo: f64,
    hi: f64,
    allowed: &'static str,
) -> Result<(), ScenarioError> {
    range(key, r[0], lo, hi, allowed)?;
    range(key, r[1], lo, hi, allowed)?;
    if r[0] > r[1] {
        return Err(ScenarioError::EmptyRange {
            key,
            min: r[0].to_string(),
            max: r[1].to_string(),
        });
    }
    Ok(())
}

/// Allowed receiver cg range, fraction of the mean chord (the F-16 trims at the refuelling
/// condition over all of it; 0.35 is the design cg).
pub const XCG_RANGE: (f64, f64) = (0.25, 0.45);

/// A plant key's allowed range (the world's dispersions: hose and drogue, air, camera): its
/// key, its `[dispersion.<section>]` key, the bounds (inclusive) and the range as an error
/// states it. Each end of a dispersion range is held to the same bounds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlantBound {
    /// Dotted key, `<section>.<key>` (also the name of its dispersion stream, `salt_of`).
    pub key: &'static str,
    /// Dotted key of its dispersion range, `dispersion.<section>.<key>`.
    pub dispersion_key: &'static str,
    /// Smallest allowed value.
    pub min: f64,
    /// Largest allowed value.
    pub max: f64,
    /// The range (and why), as the error states it.
    pub allowed: &'static str,
}

impl PlantBound {
    /// Checks a value of the key.
    fn check(&self, v: f64) -> Result<(), ScenarioError> {
        range(self.key, v, self.min, self.max, self.allowed)
    }

    /// Checks a dispersion range of the key.
    fn check_range(&self, r: [f64; 2]) -> Result<(), ScenarioError> {
        range_pair(self.dispersion_key, r, self.min, self.max, self.allowed)
    }
}

/// A [`PlantBound`] of `<section>.<key>`.
macro_rules! plant_bound {
    ($section:literal, $key:literal, $min:expr, $max:expr, $allowed:literal) => {
        PlantBound {
            key: concat!($section, ".", $key),
            dispersion_key: concat!("dispersion.", $section, ".", $key),
            min: $min,
            max: $max,
            allowed: $allowed,
        }
    };
}

/// The plant keys' ranges (ours: physical limits of the models, wider than any dispersion;
/// `docs/scenario-keys.md`; the refuelling presets' dispersions are in `docs/models.md`).
pub mod plant_bounds {
    use super::PlantBound;

    /// `drogue.drogue_mass_kg`.
    pub const DROGUE_MASS: PlantBound =
        plant_bound!("drogue", "drogue_mass_kg", 5.0, 100.0, "5..=100 kg");
    /// `drogue.drogue_drag_coefficient`.
    pub const DROGUE_DRAG: PlantBound = plant_bound!(
        "drogue",
        "drogue_drag_coefficient",
        0.2,
        2.0,
        "0.2..=2 (on the canopy's frontal area)"
    );
    /// `drogue.hose_length_m`.
    pub const HOSE_LENGTH: PlantBound =
        plant_bound!("drogue", "hose_length_m", 5.0, 30.0, "5..=30 m");
    /// `drogue.hose_linear_density_kg_per_m`.
    pub const HOSE_DENSITY: PlantBound = plant_bound!(
        "drogue",
        "hose_linear_density_kg_per_m",
        0.5,
        10.0,
        "0.5..=10 kg/m"
    );
    /// `drogue.hose_drag_scale`.
    pub const HOSE_DRAG: PlantBound = plant_bound!("drogue", "hose_drag_scale", 0.0, 5.0, "0..=5");
    /// `turbulence.scale_length_m`.
    pub const SCALE_LENGTH: PlantBound = plant_bound!(
        "turbulence",
        "scale_length_m",
        50.0,
        2000.0,
        "50..=2000 m (MIL-F-8785C's lengths are 533.4 m from 2,000 ft, 762 m in its von Karman form)"
    );
    /// `tanker_wake.strength`.
    pub const WAKE_STRENGTH: PlantBound =
        plant_bound!("tanker_wake", "strength", 0.0, 3.0, "0..=3");
    /// `bow_wave.strength`.
    pub const BOW_WAVE_STRENGTH: PlantBound =
        plant_bound!("bow_wave", "strength", 0.0, 3.0, "0..=3");
    /// `gross_mass.report_error`.
    pub const GROSS_MASS_REPORT: PlantBound = plant_bound!(
        "gross_mass",
        "report_error",
        -0.3,
        0.3,
        "-0.3..=0.3 (a fraction of the true mass)"
    );
    /// `camera.mount_roll_error_deg`.
    pub const ROLL: PlantBound =
        plant_bound!("camera", "mount_roll_error_deg", -10.0, 10.0, "-10..=10");
    /// `camera.mount_yaw_error_deg`.
    pub const YAW: PlantBound =
        plant_bound!("camera", "mount_yaw_error_deg", -10.0, 10.0, "-10..=10");
    /// `camera.focal_error_px`.
    pub const FOCAL: PlantBound = plant_bound!(
        "camera",
        "focal_error_px",
        -100.0,
        100.0,
        "-100..=100 px (20 % of the 500 px focal length)"
    );
    /// `camera.principal_point_error_px[0]`.
    pub const PRINCIPAL_U: PlantBound = plant_bound!(
        "camera",
        "principal_point_error_px[0]",
        -100.0,
        100.0,
        "-100..=100 px"
    );
    /// `camera.principal_point_error_px[1]`.
    pub const PRINCIPAL_V: PlantBound = plant_bound!(
        "camera",
        "principal_point_error_px[1]",
        -100.0,
        100.0,
        "-100..=100 px"
    );
    /// `camera.radial_distortion_k1`.
    pub const K1: PlantBound =
        plant_bound!("camera", "radial_distortion_k1", -0.5, 0.5, "-0.5..=0.5");
    /// `camera.radial_distortion_k2`.
    pub const K2: PlantBound =
        plant_bound!("camera", "radial_distortion_k2", -0.5, 0.5, "-0.5..=0.5");
}

/// Every plant key with a `[min, max]` dispersion: its bound, its value in file `$f` (borrowed
/// `&` or `&mut`) and its range in dispersion section `$d`, in one order for validation and
/// draws. (`turbulence.scale_length_m`, optional in its section, is handled beside it.)
macro_rules! plant_keys {
    (@list [$($b:tt)*] $f:ident $d:ident) => {{
        use plant_bounds::*;
        let [principal_u, principal_v] = $($b)* $f.camera.principal_point_error_px;
        [
            (&DROGUE_MASS, $($b)* $f.drogue.drogue_mass_kg, $d.drogue.drogue_mass_kg),
            (&DROGUE_DRAG, $($b)* $f.drogue.drogue_drag_coefficient, $d.drogue.drogue_drag_coefficient),
            (&HOSE_LENGTH, $($b)* $f.drogue.hose_length_m, $d.drogue.hose_length_m),
            (&HOSE_DENSITY, $($b)* $f.drogue.hose_linear_density_kg_per_m, $d.drogue.hose_linear_density_kg_per_m),
            (&HOSE_DRAG, $($b)* $f.drogue.hose_drag_scale, $d.drogue.hose_drag_scale),
            (&WAKE_STRENGTH, $($b)* $f.tanker_wake.strength, $d.tanker_wake.strength),
            (&BOW_WAVE_STRENGTH, $($b)* $f.bow_wave.strength, $d.bow_wave.strength),
            (&GROSS_MASS_REPORT, $($b)* $f.gross_mass.report_error, $d.gross_mass.report_error),
            (&ROLL, $($b)* $f.camera.mount_roll_error_deg, $d.camera.mount_roll_error_deg),
            (&YAW, $($b)* $f.camera.mount_yaw_error_deg, $d.camera.mount_yaw_error_deg),
            (&FOCAL, $($b)* $f.camera.focal_error_px, $d.camera.focal_error_px),
            (&PRINCIPAL_U, principal_u, $d.camera.principal_point_error_px.map(|r| r[0])),
            (&PRINCIPAL_V, principal_v, $d.camera.principal_point_error_px.map(|r| r[1])),
            (&K1, $($b)* $f.camera.radial_distortion_k1, $d.camera.radial_distortion_k1),
            (&K2, $($b)* $f.camera.radial_distortion_k2, $d.camera.radial_distortion_k2),
        ]
    }};
    (mut $f:ident, $d:ident) => { plant_keys!(@list [&mut] $f $d) };
    ($f:ident, $d:ident) => { plant_keys!(@list [] $f $d) };
}

/// The dispersion every preset with turbulence shares: the start, the turbulence intensity
/// `$sigma` (+/-20 % around each preset's), the camera's noise and latency, the cg (see
/// `docs/scenarios.md`, "Dispersion"). The camera's mount follows per family.
macro_rules! common_dispersion {
    ($sigma:literal) => {
        concat!(
            "[dispersion]\n",
            "drogue_minus_probe_m = [[5.5, 6.5], [1.5, 2.5], [-2.5, -1.5]]\n",
            "turbulence_sigma_mps = ",
            $sigma,
            "\n",
            "pixel_noise_px = [0.25, 1.0]\n",
            "latency_frames = [1, 2]\n",
            "xcg = [0.30, 0.40]\n",
        )
    };
}

/// The dispersion of the paper presets with turbulence (`paper-level1`, `paper-level2`,
/// `paper-bow-wave`): the common one and the camera at the tip installed to +/-5 cm and
/// +/-0.5 deg of pitch.
macro_rules! paper_dispersion {
    ($sigma:literal) => {
        concat!(
            common_dispersion!($sigma),
            "mount_error_m = [[-0.05, 0.05], [-0.05, 0.05], [-0.05, 0.05]]\n",
            "mount_pitch_error_deg = [-0.5, 0.5]\n",
        )
    };
}

/// The set-back camera's mount position and pitch dispersion in the refuelling presets:
/// +/-0.2 m per axis and +/-1 deg (roll and yaw in `world_plant_dispersion!`), as a nose
/// camera sits after installation and in service; the controller's stated calibration bound
/// is 0.5 m and 2 deg (`estimator.tip_sight_tolerance`).
macro_rules! set_back_mount_dispersion {
    () => {
        concat!(
            "mount_error_m = [[-0.2, 0.2], [-0.2, 0.2], [-0.2, 0.2]]\n",
            "mount_pitch_error_deg = [-1.0, 1.0]\n",
        )
    };
}

/// What makes a preset fly the paper's experiment as the paper does: its 70 s budget, the
/// 0.01 s physics step its figures were reproduced with, and the paper's procedure
/// (`[controller] procedure`; more `[controller]` keys may follow). Each paper preset also
/// puts the camera at the probe tip (`[camera] placement`) and navigation perfect.
macro_rules! paper_keys {
    () => {
        "duration_s = 70.0\nplant_substeps = 2\n[controller]\nprocedure = \"paper\"\n"
    };
}

/// The dispersion of the refuelling presets: the common one ([`common_dispersion`]), the
/// set-back camera's mount ([`set_back_mount_dispersion`]) and one or two control periods of
/// navigation latency.
macro_rules! refuelling_dispersion {
    ($sigma:literal) => {
        concat!(
            common_dispersion!($sigma),
            set_back_mount_dispersion!(),
            "nav_latency_steps = [1, 2]\n"
        )
    };
}

/// The world's plant dispersion for the refuelling presets: the hose and drogue, the air (the
/// Dryden scale length, the wake's and the bow wave's strengths), the camera (mount roll and
/// yaw, the lens against its calibration) and the INS's grade, each range from a public
/// source or marked ours in `docs/models.md` (each model's "Dispersion" subsection). To be
/// appended after a preset's `[dispersion]` keys (it opens its own sub-tables); part of
/// [`plant_dispersion`], and exported as [`WORLD_PLANT_DISPERSION`].
macro_rules! world_plant_dispersion {
    () => {
        concat!(
            "[dispersion.drogue]\n",
            "drogue_mass_kg = [23.6, 35.4]\n",
            "drogue_drag_coefficient = [0.68, 0.92]\n",
            "hose_length_m = [13.45, 15.2]\n",
            "hose_linear_density_kg_per_m = [3.48, 4.71]\n",
            "hose_drag_scale = [0.5, 2.0]\n",
            "[dispersion.turbulence]\n",
            "scale_length_m = [533.4, 762.0]\n",
            "[dispersion.tanker_wake]\n",
            "strength = [0.75, 1.5]\n",
            "[dispersion.bow_wave]\n",
            "strength = [0.7, 1.3]\n",
            "[dispersion.camera]\n",
            "mount_roll_error_deg = [-1.0, 1.0]\n",
            "mount_yaw_error_deg = [-1.0, 1.0]\n",
            "focal_error_px = [-5.0, 5.0]\n",
            "principal_point_error_px = [[-5.0, 5.0], [-5.0, 5.0]]\n",
            "radial_distortion_k1 = [-0.01, 0.01]\n",
            "radial_distortion_k2 = [-0.02, 0.02]\n",
            "[dispersion.navigation]\n",
            "grade = [\"tactical\", \"industrial\"]\n",
        )
    };
}

/// The world's plant dispersion (`world_plant_dispersion!`'s text), TOML sub-tables of
/// `[dispersion]` to append to a scenario file.
pub const WORLD_PLANT_DISPERSION: &str = world_plant_dispersion!();

/// The flight condition's dispersion of `envelope`: the whole docking envelope the controller
/// accepts (its gain schedule's grid, [`ibvs_core::gains::SCHEDULE_SPEEDS_MPS`] and
/// [`ibvs_core::gains::SCHEDULE_ALTITUDES_M`]; tested against them), to be appended to a
/// `[dispersion]` table.
macro_rules! envelope_dispersion {
    () => {
        "airspeed_mps = [100.0, 170.0]\naltitude_m = [500.0, 8000.0]\n"
    };
}

/// The receiver's plant dispersion of the refuelling presets (`docs/models.md`, "Receiver plant
/// dispersions", gives each range's source): a `[dispersion.receiver]` table, to be appended
/// after the rest of a preset's `[dispersion]` keys. Every range contains the nominal 1.0.
macro_rules! receiver_plant_dispersion {
    () => {
        concat!(
            "[dispersion.receiver]\n",
            "elevator_effectiveness = [0.85, 1.15]\n",
            "aileron_effectiveness = [0.8, 1.2]\n",
            "rudder_effectiveness = [0.8, 1.2]\n",
            "roll_damping_scale = [0.8, 1.2]\n",
            "pitch_damping_scale = [0.7, 1.3]\n",
            "yaw_damping_scale = [0.7, 1.3]\n",
            "cm_alpha_scale = [0.8, 1.2]\n",
            "cn_beta_scale = [0.8, 1.2]\n",
            "cl_beta_scale = [0.8, 1.2]\n",
            "mass_scale = [0.85, 1.25]\n",
            "jx_scale = [0.9, 1.4]\n",
            "jy_scale = [0.9, 1.15]\n",
            "jz_scale = [0.9, 1.15]\n",
            "elevator_rate_limit_scale = [0.8, 1.1]\n",
            "aileron_rate_limit_scale = [0.8, 1.1]\n",
            "rudder_rate_limit_scale = [0.8, 1.1]\n",
            "elevator_bandwidth_scale = [0.75, 1.25]\n",
            "aileron_bandwidth_scale = [0.75, 1.25]\n",
            "rudder_bandwidth_scale = [0.75, 1.25]\n",
            "engine_time_constant_scale = [0.8, 1.5]\n",
            "[dispersion.gross_mass]\n",
            "report_error = [-0.05, 0.05]\n",
        )
    };
}

/// The receiver's plant dispersion of the refuelling presets (the `receiver_plant_dispersion!`
/// macro's TOML): a `[dispersion.receiver]` table to append to a scenario file.
pub const RECEIVER_PLANT_DISPERSION: &str = receiver_plant_dispersion!();

/// The plant dispersion every refuelling preset flies (all but `nominal-level2`): the
/// receiver's ([`receiver_plant_dispersion`]) and the world's ([`world_plant_dispersion`]).
/// Both open `[dispersion]` sub-tables, so this goes after every flat `[dispersion]` key of a
/// preset, the envelope's included.
macro_rules! plant_dispersion {
    () => {
        concat!(receiver_plant_dispersion!(), world_plant_dispersion!())
    };
}

/// The tanker's breakaway call in every sortie of the `*-abort` presets, somewhere in the
/// approach or the capture: from 2.5 m (inside the pre-contact station's depth less its
/// tolerance, 3.0 - 0.3 m, so the approach has begun) to 5 cm before the drogue plane. A
/// `[dispersion.abort]` table, to go after every flat `[dispersion]` key.
macro_rules! abort_dispersion {
    () => {
        "[dispersion.abort]\nat_range_m = [0.05, 2.5]\n"
    };
}

/// The RMS gust intensity range of `mil-level2`: MIL-F-8785C's at probability of
/// exceedance 1e-2 at 3000 m ([`crate::world::turbulence::mil_f_8785c_sigma_mps`], 1.84 m/s)
/// +/-20 %, m/s (tested against the table).
pub const MIL_LEVEL2_SIGMA_RANGE_MPS: [f64; 2] = [1.47, 2.21];

/// Built-in presets: name, description and TOML text (parsed like a user's file).
pub const PRESETS: [(&str, &str, &str); 17] = [
    (
        "calm",
        "paper start, calm air, tanker wake, hose and LED camera, refuelling procedure (the default)",
        "",
    ),
    (
        "paper-level1",
        "the paper's procedure and law: paper start, level I turbulence (0.5 m/s), Table 1 gains",
        concat!(
            paper_keys!(),
            "[camera]\nplacement = \"probe-tip\"\n[navigation]\nmodel = \"ideal\"\n",
            "[turbulence]\npreset = \"level1\"\n",
            paper_dispersion!("[0.4, 0.6]")
        ),
    ),
    (
        "paper-level2",
        "the paper's procedure and law: paper start, level II turbulence (0.7 m/s), Table 1 gains",
        concat!(
            paper_keys!(),
            "[camera]\nplacement = \"probe-tip\"\n[navigation]\nmodel = \"ideal\"\n",
            "[turbulence]\npreset = \"level2\"\n",
            paper_dispersion!("[0.56, 0.84]")
        ),
    ),
    (
        "paper-bow-wave",
        "the paper's procedure and law: paper start, level I turbulence and the bow wave, Table 2 gains",
        concat!(
            paper_keys!(),
            "[camera]\nplacement = \"probe-tip\"\n[navigation]\nmodel = \"ideal\"\n",
            "[controller.ibvs]\nk1_mps = 3.0\nk2_mps = 3.0\nk3_per_s = 0.5\nk4_mps = 5.0\nk5_mps = 2.0\n",
            "[turbulence]\npreset = \"level1\"\n[bow_wave]\nenabled = true\n",
            paper_dispersion!("[0.4, 0.6]")
        ),
    ),
    (
        "paper-mount-error-ibvs",
        "the paper's procedure: paper start, IBVS, camera mount error [1, 0, -0.5] m",
        concat!(
            paper_keys!(),
            "law = \"ibvs\"\n[camera]\nplacement = \"probe-tip\"\nmount_error_m = [1.0, 0.0, -0.5]\n",
            "[navigation]\nmodel = \"ideal\"\n",
        ),
    ),
    (
        "paper-mount-error-pbvs",
        "the paper's procedure: paper start, PBVS, camera mount error [1, 0, -0.5] m",
        concat!(
            paper_keys!(),
            "law = \"pbvs\"\n[camera]\nplacement = \"probe-tip\"\nmount_error_m = [1.0, 0.0, -0.5]\n",
            "[navigation]\nmodel = \"ideal\"\n",
        ),
    ),
    (
        "level1",
        "the refuelling procedure, set-back camera, INS errors: paper start, level I turbulence (0.5 m/s)",
        concat!(
            "[turbulence]\npreset = \"level1\"\n",
            refuelling_dispersion!("[0.4, 0.6]"),
            plant_dispersion!()
        ),
    ),
    (
        "level2",
        "the refuelling procedure, set-back camera, INS errors: paper start, level II turbulence (0.7 m/s)",
        concat!(
            "[turbulence]\npreset = \"level2\"\n",
            refuelling_dispersion!("[0.56, 0.84]"),
            plant_dispersion!()
        ),
    ),
    (
        "nominal-level2",
        "level2 on the design's own plant: no receiver, hose, air, camera or INS-grade dispersion",
        concat!(
            "[turbulence]\npreset = \"level2\"\n",
            refuelling_dispersion!("[0.56, 0.84]")
        ),
    ),
    (
        "bow-wave",
        "the refuelling procedure, set-back camera, INS errors: paper start, level I turbulence and the bow wave",
        concat!(
            "[turbulence]\npreset = \"level1\"\n[bow_wave]\nenabled = true\n",
            refuelling_dispersion!("[0.4, 0.6]"),
            plant_dispersion!()
        ),
    ),
    (
        "mil-level2",
        "the refuelling procedure: MIL-F-8785C intensity at exceedance 1e-2 at 3000 m (1.84 m/s) +/-20 %",
        concat!(
            "[turbulence]\nsigma_mps = 1.84\n",
            refuelling_dispersion!("[1.47, 2.21]"),
            plant_dispersion!()
        ),
    ),
    (
        "level2-abort",
        "level2 with the tanker's breakaway call in every sortie, 2.5 m to 5 cm from the drogue plane",
        concat!(
            "[turbulence]\npreset = \"level2\"\n",
            refuelling_dispersion!("[0.56, 0.84]"),
            plant_dispersion!(),
            abort_dispersion!()
        ),
    ),
    (
        "mil-level2-abort",
        "mil-level2 with the tanker's breakaway call in every sortie, 2.5 m to 5 cm from the drogue plane",
        concat!(
            "[turbulence]\nsigma_mps = 1.84\n",
            refuelling_dispersion!("[1.47, 2.21]"),
            plant_dispersion!(),
            abort_dispersion!()
        ),
    ),
    (
        "autopilot-level2",
        "level2 flown through the aircraft's autopilot: attitude and throttle setpoints, ArduPlane-like attitude loops",
        concat!(
            "[controller]\ninner_loop = \"attitude\"\n",
            "[turbulence]\npreset = \"level2\"\n",
            refuelling_dispersion!("[0.56, 0.84]"),
            plant_dispersion!()
        ),
    ),
    (
        "autopilot-mil-level2",
        "mil-level2 flown through the aircraft's autopilot: attitude and throttle setpoints, ArduPlane-like attitude loops",
        concat!(
            "[controller]\ninner_loop = \"attitude\"\n",
            "[turbulence]\nsigma_mps = 1.84\n",
            refuelling_dispersion!("[1.47, 2.21]"),
            plant_dispersion!()
        ),
    ),
    (
        "wide-start",
        "the refuelling procedure: level II turbulence, start 4.5..12 m ahead, -2..2 m right, -2..1.5 m down",
        concat!(
            "[turbulence]\npreset = \"level2\"\n[dispersion]\n",
            "drogue_minus_probe_m = [[4.5, 12.0], [-2.0, 2.0], [-2.0, 1.5]]\n",
            "turbulence_sigma_mps = [0.56, 0.84]\n",
            "pixel_noise_px = [0.25, 1.0]\n",
            "latency_frames = [1, 2]\n",
            set_back_mount_dispersion!(),
            "xcg = [0.30, 0.40]\n",
            "nav_latency_steps = [1, 2]\n",
            plant_dispersion!()
        ),
    ),
    (
        "envelope",
        "the refuelling procedure: level2 over the whole docking envelope, 100..170 m/s true airspeed, 500..8000 m",
        concat!(
            "[turbulence]\npreset = \"level2\"\n",
            refuelling_dispersion!("[0.56, 0.84]"),
            envelope_dispersion!(),
            plant_dispersion!()
        ),
    ),
];

impl ScenarioFile {
    /// Parses and validates TOML text; `source_name` names it in errors.
    pub fn parse(text: &str, source_name: &str) -> Result<Self, ScenarioError> {
        input::precheck(text, source_name)?;
        let f: ScenarioFile = toml::from_str(text).map_err(|e| ScenarioError::Parse {
            source_name: source_name.into(),
            message: input::clip(&e.to_string()),
        })?;
        f.validate()?;
        Ok(f)
    }

    /// A preset by name, or a TOML file by path.
    pub fn load(name_or_path: &str) -> Result<Self, ScenarioError> {
        if let Some((name, _, text)) = PRESETS.iter().find(|p| p.0 == name_or_path) {
            let mut f = Self::parse(text, name)?;
            f.name = (*name).into();
            return Ok(f);
        }
        let path = std::path::Path::new(name_or_path);
        if !path.exists() {
            return Err(ScenarioError::NotFound(name_or_path.into()));
        }
        let text = input::read_limited(path, name_or_path)?;
        let mut f =
            Self::parse(&text, name_or_path).map_err(|e| input::in_file(e, name_or_path, &text))?;
        if f.name == ScenarioFile::default().name {
            f.name = path
                .file_stem()
                .map_or_else(|| name_or_path.into(), |s| s.to_string_lossy().into_owned());
        }
        Ok(f)
    }

    /// The file as TOML (every key written out).
    pub fn to_toml(&self) -> String {
        toml::to_string(self).unwrap_or_else(|e| format!("# cannot serialise: {e}\n"))
    }

    /// Checks every value against its allowed range.
    pub fn validate(&self) -> Result<(), ScenarioError> {
        range("duration_s", self.duration_s, 0.1, 3600.0, "0.1..=3600")?;
        range(
            "plant_substeps",
            f64::from(self.plant_substeps),
            1.0,
            8.0,
            "1..=8",
        )?;
        range(
            "initial.drogue_minus_probe_m[0] (forward)",
            self.initial.drogue_minus_probe_m[0],
            1.5,
            30.0,
            "1.5..=30 (ahead of the probe, outside the blind range)",
        )?;
        for (v, key) in self.initial.drogue_minus_probe_m[1..].iter().zip([
            "initial.drogue_minus_probe_m[1] (right)",
            "initial.drogue_minus_probe_m[2] (down)",
        ]) {
            range(key, *v, -30.0, 30.0, "-30..=30")?;
        }
        if let Some(s) = self.turbulence.sigma_mps {
            range("turbulence.sigma_mps", s, 0.0, 10.0, "0..=10")?;
        }
        if let Some(p) = self.turbulence.exceedance_probability
            && crate::world::turbulence::mil_f_8785c_sigma_mps(self.flight.altitude_m, p).is_none()
        {
            return Err(ScenarioError::OutOfRange {
                key: "turbulence.exceedance_probability",
                value: p.to_string(),
                allowed: "one of MIL-F-8785C's tabulated 0.2, 0.1, 1e-2, 1e-3, 1e-4, 1e-5",
            });
        }
        range(
            "camera.mount_pitch_error_deg",
            self.camera.mount_pitch_error_deg,
            -10.0,
            10.0,
            "-10..=10",
        )?;
        for (v, key) in self.camera.mount_error_m.iter().zip([
            "camera.mount_error_m[0]",
            "camera.mount_error_m[1]",
            "camera.mount_error_m[2]",
        ]) {
            range(key, *v, -3.0, 3.0, "-3..=3")?;
        }
        range(
            "camera.pixel_noise_px",
            self.camera.pixel_noise_px,
            0.0,
            20.0,
            "0..=20",
        )?;
        range(
            "camera.latency_frames",
            f64::from(self.camera.latency_frames),
            0.0,
            10.0,
            "0..=10",
        )?;
        range(
            "camera.rate_hz",
            self.camera.rate_hz,
            5.0,
            1000.0,
            "5..=1000",
        )?;
        range(
            "camera.drop_probability",
            self.camera.drop_probability,
            0.0,
            0.9,
            "0..=0.9",
        )?;
        range(
            "receiver.xcg",
            self.receiver.xcg,
            XCG_RANGE.0,
            XCG_RANGE.1,
            "0.25..=0.45",
        )?;
        for (info, &factor) in FACTORS.iter().zip(self.receiver.plant.values()) {
            let l = info.limits;
            range(info.receiver_key, factor, l.min, l.max, l.text)?;
        }
        self.validate_flight()?;
        if let Some(r) = self.abort.at_range_m {
            range(
                "abort.at_range_m",
                r,
                ABORT_RANGE_M.0,
                ABORT_RANGE_M.1,
                "0.01..=30 m",
            )?;
        }
        self.navigation.ins.check()?;
        self.autopilot
            .validate()
            .map_err(ScenarioError::Autopilot)?;
        let d = &self.dispersion;
        for (bound, value, _) in plant_keys!(self, d) {
            bound.check(value)?;
        }
        if let Some(l) = self.turbulence.scale_length_m {
            plant_bounds::SCALE_LENGTH.check(l)?;
        }
        // The outer law is the paper procedure's: the refuelling procedure flies its own
        // target law, so PBVS (never the default) would be ignored; refused, not dropped.
        let c = &self.controller.config;
        if c.procedure == ibvs_core::Procedure::Refuelling && c.law == ibvs_core::OuterLaw::Pbvs {
            return Err(ScenarioError::Conflict(
                "controller.law = \"pbvs\" is flown by the paper's procedure only, and this \
                 file flies the refuelling procedure (controller.procedure): set \
                 controller.procedure = \"paper\" to fly PBVS, or remove the law",
            ));
        }
        if self.controller.camera_position_given
            && (self.camera.mount_error_m != [0.0; 3] || self.dispersion.mount_error_m.is_some())
        {
            return Err(ScenarioError::Conflict(
                "controller.camera.position_body_m and camera.mount_error_m (or its dispersion) \
                 both give where the controller believes the camera is: give one",
            ));
        }
        const _: () = assert!(
            ibvs_core::predictor::MAX_NAV_LATENCY_STEPS == 4,
            "the message below"
        );
        // The INS's latency is the controller's unless [controller] gives its own: then it is
        // the latency predictor's to compensate, and bounded by it (named as written).
        if !self.controller.nav_latency_given
            && self.navigation.installed_latency_steps()
                > ibvs_core::predictor::MAX_NAV_LATENCY_STEPS
        {
            return Err(ScenarioError::OutOfRange {
                key: "navigation.ins.latency_steps",
                value: self.navigation.ins.latency_steps.to_string(),
                allowed: "0..=4 (the controller's latency predictor compensates at most 4 \
                          control periods; give [controller] nav_latency_steps to fly a longer \
                          latency uncompensated)",
            });
        }
        self.controller_config().validate()?;
        self.validate_dispersion()
    }

    /// Checks `[flight]` and its dispersion against the limits of [`crate::world::flight`]
    /// (Mach with the receiver model's atmosphere): the file's condition, and every corner of
    /// the dispersed ranges, so that each run's condition is valid (the speed of sound
    /// falls with altitude, then is constant: the fastest airspeed at the highest altitude
    /// is the highest Mach).
    fn validate_flight(&self) -> Result<(), ScenarioError> {
        let model = crate::receiver::F16::new(NOMINAL_XCG)?;
        let air = |h: f64| model.air_at(h);
        self.flight
            .condition()
            .validate(air, "flight.airspeed_mps", "flight.altitude_m")?;
        let d = &self.dispersion;
        if d.airspeed_mps.is_none() && d.altitude_m.is_none() {
            return Ok(());
        }
        let v = d.airspeed_mps.unwrap_or([self.flight.airspeed_mps; 2]);
        let h = d.altitude_m.unwrap_or([self.flight.altitude_m; 2]);
        for (key, r) in [
            ("dispersion.airspeed_mps", d.airspeed_mps),
            ("dispersion.altitude_m", d.altitude_m),
        ] {
            if let Some(r) = r
                && r[0] > r[1]
            {
                return Err(ScenarioError::EmptyRange {
                    key,
                    min: r[0].to_string(),
                    max: r[1].to_string(),
                });
            }
        }
        for (vi, hi) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
            FlightCondition {
                airspeed_mps: v[vi],
                altitude_m: h[hi],
            }
            .validate(air, "dispersion.airspeed_mps", "dispersion.altitude_m")?;
        }
        Ok(())
    }

    /// Checks the `[dispersion]` ranges: each end as the base key, minimum at most maximum.
    fn validate_dispersion(&self) -> Result<(), ScenarioError> {
        let d = &self.dispersion;
        if let Some(r) = d.drogue_minus_probe_m {
            range_pair(
                "dispersion.drogue_minus_probe_m[0] (forward)",
                r[0],
                1.5,
                30.0,
                "1.5..=30 (ahead of the probe, outside the blind range)",
            )?;
            range_pair(
                "dispersion.drogue_minus_probe_m[1] (right)",
                r[1],
                -30.0,
                30.0,
                "-30..=30",
            )?;
            range_pair(
                "dispersion.drogue_minus_probe_m[2] (down)",
                r[2],
                -30.0,
                30.0,
                "-30..=30",
            )?;
        }
        if let Some(r) = d.turbulence_sigma_mps {
            range_pair("dispersion.turbulence_sigma_mps", r, 0.0, 10.0, "0..=10")?;
        }
        if let Some(r) = d.pixel_noise_px {
            range_pair("dispersion.pixel_noise_px", r, 0.0, 20.0, "0..=20")?;
        }
        if let Some(r) = d.latency_frames {
            range_pair(
                "dispersion.latency_frames",
                r.map(f64::from),
                0.0,
                10.0,
                "0..=10",
            )?;
        }
        if let Some(r) = d.mount_error_m {
            for (r, key) in r.into_iter().zip([
                "dispersion.mount_error_m[0]",
                "dispersion.mount_error_m[1]",
                "dispersion.mount_error_m[2]",
            ]) {
                range_pair(key, r, -3.0, 3.0, "-3..=3")?;
            }
        }
        if let Some(r) = d.mount_pitch_error_deg {
            range_pair(
                "dispersion.mount_pitch_error_deg",
                r,
                -10.0,
                10.0,
                "-10..=10",
            )?;
        }
        if let Some(r) = d.xcg {
            range_pair("dispersion.xcg", r, XCG_RANGE.0, XCG_RANGE.1, "0.25..=0.45")?;
        }
        if let Some(r) = d.nav_latency_steps {
            range_pair(
                "dispersion.nav_latency_steps",
                r.map(f64::from),
                0.0,
                50.0,
                "0..=50",
            )?;
        }
        for (info, r) in FACTORS.iter().zip(d.receiver.values()) {
            if let Some(r) = *r {
                let l = info.limits;
                range_pair(info.dispersion_key, r, l.min, l.max, l.text)?;
            }
        }
        for (bound, _, r) in plant_keys!(self, d) {
            if let Some(r) = r {
                bound.check_range(r)?;
            }
        }
        if let Some(r) = d.turbulence.scale_length_m {
            plant_bounds::SCALE_LENGTH.check_range(r)?;
        }
        if let Some(r) = d.abort.at_range_m {
            range_pair(
                "dispersion.abort.at_range_m",
                r,
                ABORT_RANGE_M.0,
                ABORT_RANGE_M.1,
                "0.01..=30 m",
            )?;
        }
        if let Some(grades) = &d.navigation.grade {
            if grades.is_empty() {
                return Err(ScenarioError::OutOfRange {
                    key: "dispersion.navigation.grade",
                    value: "[]".into(),
                    allowed: "a non-empty list of \"tactical\", \"industrial\"",
                });
            }
            let file = self.navigation.ins;
            let grade = InsErrors {
                latency_steps: file.latency_steps,
                ..self.navigation.grade.errors()
            };
            if file != grade {
                return Err(ScenarioError::Conflict(
                    "navigation.ins figures and dispersion.navigation.grade both give the INS's \
                     errors (a run flies its drawn grade's figures): give one",
                ));
            }
        }
        Ok(())
    }

    /// The file of run `index` of a Monte Carlo campaign over this file: every key of
    /// `[dispersion]` replaced by a uniform draw from its range, the seed per run unless
    /// `vary_seed = false`, the name suffixed with the index, and no `[dispersion]` table.
    /// A function of this file and `index` only.
    pub fn dispersed(&self, index: u64) -> ScenarioFile {
        let d = &self.dispersion;
        let run = splitmix64(splitmix64(self.seed ^ CAMPAIGN_SALT) ^ index);
        let stream = |salt: u64| ChaCha8Rng::seed_from_u64(splitmix64(run ^ salt));
        let uniform = |salt: u64, [lo, hi]: [f64; 2]| {
            if lo < hi {
                lo + (hi - lo) * stream(salt).random::<f64>()
            } else {
                lo
            }
        };
        let mut f = self.clone();
        f.name = format!("{}-run{index}", self.name);
        f.dispersion = DispersionSection::default();
        if d.vary_seed.unwrap_or(true) {
            f.seed = stream(SALT_SEED).random::<u64>();
        }
        if let Some(r) = d.drogue_minus_probe_m {
            for (j, r) in r.into_iter().enumerate() {
                f.initial.drogue_minus_probe_m[j] = uniform(SALT_START + j as u64, r);
            }
        }
        if let Some(r) = d.turbulence_sigma_mps {
            f.turbulence.sigma_mps = Some(uniform(SALT_SIGMA, r));
        }
        if let Some(r) = d.pixel_noise_px {
            f.camera.pixel_noise_px = uniform(SALT_NOISE, r);
        }
        if let Some([lo, hi]) = d.latency_frames {
            f.camera.latency_frames = stream(SALT_LATENCY).random_range(lo..=hi);
        }
        if let Some(r) = d.mount_error_m {
            for (j, r) in r.into_iter().enumerate() {
                f.camera.mount_error_m[j] = uniform(SALT_MOUNT + j as u64, r);
            }
        }
        if let Some(r) = d.mount_pitch_error_deg {
            f.camera.mount_pitch_error_deg = uniform(SALT_PITCH, r);
        }
        if let Some(r) = d.xcg {
            f.receiver.xcg = uniform(SALT_XCG, r);
        }
        if let Some([lo, hi]) = d.nav_latency_steps {
            // The INS's latency varies from run to run within the range the installation
            // states; the controller compensates the range's upper end (the file's own
            // figure if larger), the same in every run: a latency predicted short costs the
            // inner loops more margin than one predicted long (`docs/margins.md`), and a
            // controller is configured once, not per sortie. At most what the predictor
            // compensates.
            let c = &mut f.controller;
            if !c.nav_latency_given {
                let upper = u8::try_from(hi)
                    .unwrap_or(u8::MAX)
                    .min(ibvs_core::predictor::MAX_NAV_LATENCY_STEPS);
                c.config.nav_latency_steps = self.navigation.installed_latency_steps().max(upper);
                c.nav_latency_given = true;
            }
            f.navigation.ins.latency_steps = stream(SALT_NAV_LATENCY).random_range(lo..=hi);
        }
        if let Some(r) = d.airspeed_mps {
            f.flight.airspeed_mps = uniform(SALT_AIRSPEED, r);
        }
        if let Some(r) = d.altitude_m {
            f.flight.altitude_m = uniform(SALT_ALTITUDE, r);
        }
        let plant = f.receiver.plant.values_mut();
        for ((info, r), factor) in FACTORS.iter().zip(d.receiver.values()).zip(plant) {
            if let Some(r) = *r {
                *factor = uniform(salt_of(info.receiver_key), r);
            }
        }
        // The plant's keys: each from the stream named by its key.
        for (bound, value, r) in plant_keys!(mut f, d) {
            if let Some(r) = r {
                *value = uniform(salt_of(bound.key), r);
            }
        }
        if let Some(r) = d.turbulence.scale_length_m {
            f.turbulence.scale_length_m = Some(uniform(salt_of(plant_bounds::SCALE_LENGTH.key), r));
        }
        if let Some(r) = d.abort.at_range_m {
            f.abort.at_range_m = Some(uniform(salt_of("abort.at_range_m"), r));
        }
        if let Some(grades) = d.navigation.grade.as_deref().filter(|g| !g.is_empty()) {
            let grade = grades[stream(salt_of("navigation.grade")).random_range(0..grades.len())];
            // The grade's figures, at the file's latency (dispersed on its own, above).
            let latency_steps = f.navigation.ins.latency_steps;
            f.navigation.grade = grade;
            f.navigation.ins = InsErrors {
                latency_steps,
                ..grade.errors()
            };
        }
        if let Some([lo, hi]) = d.airspeed_mps {
            // The tanker flies a speed the receiver can dock at: a dispersed airspeed is drawn
            // over the part of its range inside the receiver's docking envelope at the gross
            // mass it reports (`MassEnvelope`'s lowest airspeed), the same fraction of the way
            // across. Where no speed of the range will do, the draw stands and the controller
            // refuses it.
            let mass = f.controller_config().mass_factor;
            let altitude = f.flight.altitude_m as f32;
            let low = f64::from(MassEnvelope::new(mass).lowest_airspeed_mps(altitude));
            if lo < low && low < hi {
                let across = (f.flight.airspeed_mps - lo) / (hi - lo);
                f.flight.airspeed_mps = low + across * (hi - low);
            }
        }
        f
    }

    /// RMS gust speed of the run, m/s: `turbulence.sigma_mps` as given, else MIL-F-8785C's
    /// for `turbulence.exceedance_probability` at the flight altitude, else the preset's at
    /// the flight altitude ([`TurbulencePreset::sigma_at_mps`]).
    pub fn sigma_mps(&self) -> f64 {
        let h = self.flight.altitude_m;
        let t = &self.turbulence;
        t.sigma_mps
            .or_else(|| {
                t.exceedance_probability
                    .and_then(|p| crate::world::turbulence::mil_f_8785c_sigma_mps(h, p))
            })
            .unwrap_or_else(|| t.preset.sigma_at_mps(h))
    }

    /// The controller's configuration for this scenario: the `[controller]` table over the
    /// default, with what the world decides unless the table gives it: the camera where it
    /// was meant to be (its placement) less the mount error (true minus believed), the
    /// installed navigation's latency ([`NavigationSection::installed_latency_steps`]) and the
    /// reported gross mass ([`ScenarioFile::reported_mass_factor`]).
    pub fn controller_config(&self) -> ControllerConfig {
        let section = &self.controller;
        let mut cfg = section.config;
        if !section.camera_position_given {
            let placed = self.camera.placement.position_body_m();
            for ((b, p), e) in cfg
                .camera
                .position_body_m
                .iter_mut()
                .zip(placed.iter())
                .zip(self.camera.mount_error_m)
            {
                *b = *p as f32 - e as f32;
            }
        }
        if !section.nav_latency_given {
            cfg.nav_latency_steps = self.navigation.installed_latency_steps();
        }
        if !section.mass_given {
            cfg.mass_factor = self.reported_mass_factor() as f32;
        }
        cfg
    }

    /// The gross mass the receiver's systems report, a factor of the model data's: its true
    /// mass (`receiver.mass_scale`) times one plus `gross_mass.report_error`.
    pub fn reported_mass_factor(&self) -> f64 {
        self.receiver.plant.mass_scale * (1.0 + self.gross_mass.report_error)
    }

    /// The simulator's scenario: the one conversion from a scenario file to what a run
    /// flies (every key not named here keeps [`Scenario::ideal`]'s value).
    pub fn scenario(&self) -> Scenario {
        let f = self;
        let c = &f.camera;
        Scenario {
            name: f.name.clone(),
            seed: f.seed,
            start_offset_m: nalgebra::Vector3::from(f.initial.drogue_minus_probe_m),
            duration_s: f.duration_s,
            plant_substeps: f.plant_substeps,
            hose: (f.drogue.model == DrogueModel::Hose).then(|| f.drogue.hose_params()),
            camera: match c.model {
                CameraModel::Ideal => CameraChoice::Ideal(CameraParams {
                    intrinsics_error: c.intrinsics_error(),
                    ..CameraParams::default()
                }),
                CameraModel::Led => CameraChoice::Led(LedCameraParams {
                    pixel_noise_px: c.pixel_noise_px,
                    latency_frames: c.latency_frames,
                    rate_hz: c.rate_hz,
                    drop_probability: c.drop_probability,
                    intrinsics_error: c.intrinsics_error(),
                    ..LedCameraParams::default()
                }),
            },
            turbulence_sigma_mps: f.sigma_mps(),
            turbulence_scale_length_m: f.turbulence.scale_length_m,
            camera_pitch_error_rad: c.mount_pitch_error_deg.to_radians(),
            camera_roll_error_rad: c.mount_roll_error_deg.to_radians(),
            camera_yaw_error_rad: c.mount_yaw_error_deg.to_radians(),
            wake: f.tanker_wake.enabled.then(|| WakeParams {
                strength_scale: f.tanker_wake.strength,
                ..WakeParams::default()
            }),
            bow_wave: f.bow_wave.enabled,
            bow_wave_strength: f.bow_wave.strength,
            xcg: f.receiver.xcg,
            receiver_plant: f.receiver.plant,
            camera_body_m: c.placement.position_body_m(),
            navigation: (f.navigation.model == NavModel::Ins).then_some(f.navigation.ins),
            abort_at_range_m: f.abort.at_range_m,
            autopilot: f.autopilot,
            tanker: crate::world::Tanker {
                speed_mps: f.flight.airspeed_mps,
                altitude_m: f.flight.altitude_m,
            },
            ..Scenario::ideal()
        }
    }
}

impl Default for Scenario {
    /// The default scenario file's: paper start, calm air, wake, hose, LED camera.
    fn default() -> Self {
        ScenarioFile::default().scenario()
    }
}

/// Salts of the dispersion streams: one per dispersed value.
const CAMPAIGN_SALT: u64 = 0x6d6f_6e74_6563_6172; // "montecar"
const SALT_SEED: u64 = 1;
const SALT_START: u64 = 0x10; // + axis
const SALT_SIGMA: u64 = 0x20;
const SALT_NOISE: u64 = 0x30;
const SALT_LATENCY: u64 = 0x40;
const SALT_MOUNT: u64 = 0x50; // + axis
const SALT_PITCH: u64 = 0x60;
const SALT_XCG: u64 = 0x70;
const SALT_NAV_LATENCY: u64 = 0x80;
const SALT_AIRSPEED: u64 = 0x90;
const SALT_ALTITUDE: u64 = 0xa0;

/// The salt of a dispersed value named by its key path (for example
/// `"receiver.elevator_effectiveness"`): 64-bit FNV-1a over the key's bytes. New dispersion
/// keys take their stream from their name, so adding a key renumbers nothing and changes no
/// other key's draw; the numbered salts above are the older keys', kept so that their
/// campaigns stay bit for bit.
const fn salt_of(key: &str) -> u64 {
    let bytes = key.as_bytes();
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    let mut i = 0;
    while i < bytes.len() {
        hash ^= bytes[i] as u64;
        hash = hash.wrapping_mul(0x0000_0100_0000_01b3);
        i += 1;
    }
    hash
}

/// SplitMix64's output function: a bijective mix of 64 bits.
fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::receiver::FACTOR_COUNT;
    use ibvs_core::{OuterLaw, Procedure};

    #[test]
    fn every_preset_parses_validates_and_round_trips() {
        for (name, _, _) in PRESETS {
            let f = ScenarioFile::load(name).unwrap();
            assert_eq!(f.name, name);
            let back = ScenarioFile::parse(&f.to_toml(), "round trip").unwrap();
            assert_eq!(back, f, "{name}");
        }
        // The paper's Table 2 under the bow wave, Table 1 (the default) elsewhere.
        let bow = ScenarioFile::load("paper-bow-wave").unwrap();
        let g = bow.controller_config().ibvs;
        assert_eq!(
            [g.k1_mps, g.k2_mps, g.k3_per_s, g.k4_mps, g.k5_mps],
            [3.0, 3.0, 0.5, 5.0, 2.0]
        );
        assert!(bow.bow_wave.enabled);
        let g = ScenarioFile::load("paper-level2")
            .unwrap()
            .controller_config()
            .ibvs;
        assert_eq!(
            [g.k1_mps, g.k2_mps, g.k3_per_s, g.k4_mps, g.k5_mps],
            [1.0, 2.0, 0.3, 3.0, 1.0]
        );
        let pbvs = ScenarioFile::load("paper-mount-error-pbvs").unwrap();
        assert_eq!(pbvs.controller_config().law, OuterLaw::Pbvs);
    }

    #[test]
    fn mil_level2_is_the_mil_table_at_3000_m_plus_minus_20_percent() {
        let s = crate::world::turbulence::mil_f_8785c_sigma_mps(3000.0, 1e-2).unwrap();
        let f = ScenarioFile::load("mil-level2").unwrap();
        assert!(
            (f.sigma_mps() - s).abs() < 0.005,
            "{} vs {s}",
            f.sigma_mps()
        );
        for (got, k) in MIL_LEVEL2_SIGMA_RANGE_MPS.iter().zip([0.8, 1.2]) {
            assert!((got - k * s).abs() < 0.005, "{got} vs {}", k * s);
        }
    }

    #[test]
    fn the_empty_file_is_the_default() {
        assert_eq!(
            ScenarioFile::parse("", "empty").unwrap(),
            ScenarioFile::default()
        );
    }

    #[test]
    fn an_unknown_key_is_named() {
        let e = ScenarioFile::parse("[camera]\npixel_nois_px = 1.0\n", "typo")
            .unwrap_err()
            .to_string();
        assert!(e.contains("pixel_nois_px"), "{e}");
        let e = ScenarioFile::parse("sede = 3\n", "typo")
            .unwrap_err()
            .to_string();
        assert!(e.contains("sede"), "{e}");
    }

    #[test]
    fn a_bad_value_names_the_key_and_the_range() {
        let e = ScenarioFile::parse("[camera]\npixel_noise_px = -1.0\n", "bad")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("camera.pixel_noise_px") && e.contains("0..=20"),
            "{e}"
        );
        let e = ScenarioFile::parse("[controller.ibvs]\nk1_mps = 0.0\n", "bad")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("controller.ibvs.k1_mps is NotPositive") && e.contains("finite, > 0"),
            "{e}"
        );
        let e = ScenarioFile::parse("[controller.ibvs]\nk1 = 1.0\n", "bad")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("controller.ibvs.k1 is not a controller setting"),
            "{e}"
        );
        let e = ScenarioFile::parse("[turbulence]\npreset = \"hurricane\"\n", "bad")
            .unwrap_err()
            .to_string();
        assert!(e.contains("hurricane"), "{e}");
        let e = ScenarioFile::parse("[initial]\ndrogue_minus_probe_m = [0.5, 0.0, 0.0]\n", "bad")
            .unwrap_err()
            .to_string();
        assert!(e.contains("forward"), "{e}");
        for bad in ["0", "9"] {
            let e = ScenarioFile::parse(&format!("plant_substeps = {bad}\n"), "bad")
                .unwrap_err()
                .to_string();
            assert!(e.contains("plant_substeps") && e.contains("1..=8"), "{e}");
        }
        let e = ScenarioFile::parse("plant_substeps = -1\n", "bad")
            .unwrap_err()
            .to_string();
        assert!(e.contains("plant_substeps"), "{e}");
        let f = ScenarioFile::parse("plant_substeps = 3\n", "three").unwrap();
        assert_eq!(f.scenario().plant_substeps, 3);
        assert_eq!(ScenarioFile::default().scenario().plant_substeps, 1);
    }

    #[test]
    fn a_pitch_error_moves_the_true_camera_only() {
        let f = ScenarioFile::parse("[camera]\nmount_pitch_error_deg = 2.0\n", "pitch").unwrap();
        assert!((f.scenario().camera_pitch_error_rad - 2f64.to_radians()).abs() < 1e-12);
        assert_eq!(
            f.controller_config(),
            ControllerConfig::default(),
            "the controller does not know"
        );
        let e = ScenarioFile::parse("[camera]\nmount_pitch_error_deg = 20.0\n", "bad")
            .unwrap_err()
            .to_string();
        assert!(e.contains("mount_pitch_error_deg"), "{e}");
    }

    #[test]
    fn a_missing_preset_or_file_lists_the_presets() {
        let e = ScenarioFile::load("paper-level9").unwrap_err().to_string();
        assert!(e.contains("paper-level1"), "{e}");
    }

    #[test]
    fn the_turbulence_presets_carry_the_stated_dispersion() {
        for (name, sigma) in [
            ("paper-level1", [0.4, 0.6]),
            ("paper-level2", [0.56, 0.84]),
            ("paper-bow-wave", [0.4, 0.6]),
        ] {
            let d = ScenarioFile::load(name).unwrap().dispersion;
            assert_eq!(d.turbulence_sigma_mps, Some(sigma), "{name}");
            assert_eq!(
                d.drogue_minus_probe_m,
                Some([[5.5, 6.5], [1.5, 2.5], [-2.5, -1.5]])
            );
            assert_eq!(d.pixel_noise_px, Some([0.25, 1.0]));
            assert_eq!(d.latency_frames, Some([1, 2]));
            assert_eq!(d.mount_error_m, Some([[-0.05, 0.05]; 3]));
            assert_eq!(d.mount_pitch_error_deg, Some([-0.5, 0.5]));
            assert_eq!(d.xcg, Some([0.30, 0.40]));
            assert_eq!(d.vary_seed, None);
        }
        for name in ["calm", "paper-mount-error-ibvs", "paper-mount-error-pbvs"] {
            assert!(ScenarioFile::load(name).unwrap().dispersion.is_empty());
        }
        // The refuelling presets: the same, and the navigation's latency.
        for (name, sigma) in [
            ("level1", [0.4, 0.6]),
            ("level2", [0.56, 0.84]),
            ("bow-wave", [0.4, 0.6]),
            ("mil-level2", MIL_LEVEL2_SIGMA_RANGE_MPS),
        ] {
            let f = ScenarioFile::load(name).unwrap();
            assert_eq!(
                f.controller_config().procedure,
                Procedure::Refuelling,
                "{name}"
            );
            assert_eq!(f.navigation.model, crate::scenario::NavModel::Ins, "{name}");
            assert_eq!(f.camera.placement, CameraPlacement::SetBack, "{name}");
            let d = f.dispersion;
            assert_eq!(d.turbulence_sigma_mps, Some(sigma), "{name}");
            assert_eq!(d.nav_latency_steps, Some([1, 2]), "{name}");
            assert_eq!(
                d.drogue_minus_probe_m,
                Some([[5.5, 6.5], [1.5, 2.5], [-2.5, -1.5]])
            );
        }
        let wide = ScenarioFile::load("wide-start").unwrap().dispersion;
        assert_eq!(
            wide.drogue_minus_probe_m,
            Some([[4.5, 12.0], [-2.0, 2.0], [-2.0, 1.5]])
        );
        // The paper's presets fly the paper's procedure at the tip, with perfect navigation.
        for name in PRESETS
            .iter()
            .map(|p| p.0)
            .filter(|n| n.starts_with("paper-"))
        {
            let f = ScenarioFile::load(name).unwrap();
            assert_eq!(f.controller_config().procedure, Procedure::Paper, "{name}");
            assert_eq!(f.camera.placement, CameraPlacement::ProbeTip, "{name}");
            assert_eq!(
                f.navigation.model,
                crate::scenario::NavModel::Ideal,
                "{name}"
            );
            assert_eq!(f.duration_s, 70.0, "{name}");
            assert_eq!(f.plant_substeps, 2, "{name}");
        }
    }

    /// `envelope` is `level2` exactly, with the flight condition dispersed over the gain
    /// schedule's whole grid (the docking envelope), and every run inside it.
    /// A dispersed airspeed is drawn inside the receiver's docking envelope at the gross mass
    /// it reports: every one of `envelope`'s runs is one its controller engages in, and at
    /// the slow, high corner the heavy runs are faster than the light ones.
    #[test]
    fn envelope_draws_airspeeds_inside_the_docking_envelope_of_the_reported_mass() {
        let envelope = ScenarioFile::load("envelope").unwrap();
        let (mut heavy, mut light, mut outside_the_grid_edge) = (Vec::new(), Vec::new(), 0);
        for i in 0..2000 {
            let f = envelope.dispersed(i);
            let cfg = f.controller_config();
            let c = f.flight.condition();
            let condition = ibvs_core::schedule::FlightCondition {
                true_airspeed_mps: c.airspeed_mps as f32,
                altitude_m: c.altitude_m as f32,
            };
            let docking = MassEnvelope::new(cfg.mass_factor);
            assert_eq!(docking.check(condition), Ok(()), "run {i}: {c:?}, {cfg:?}");
            let low = docking.lowest_airspeed_mps(condition.altitude_m);
            outside_the_grid_edge += usize::from(low > 100.0);
            if c.altitude_m > 7000.0 {
                match cfg.mass_factor {
                    m if m > 1.15 => heavy.push(c.airspeed_mps),
                    m if m < 0.95 => light.push(c.airspeed_mps),
                    _ => {}
                }
            }
        }
        // The slow edge is drawn against in a good share of the runs.
        assert!(outside_the_grid_edge > 200, "{outside_the_grid_edge}");
        let min = |x: &[f64]| x.iter().copied().fold(f64::MAX, f64::min);
        assert!(
            min(&heavy) > 120.0 && min(&light) < 110.0,
            "{heavy:?} {light:?}"
        );
    }

    #[test]
    fn envelope_is_level2_over_the_whole_docking_envelope() {
        use ibvs_core::gains::{SCHEDULE_ALTITUDES_M, SCHEDULE_SPEEDS_MPS};
        let level2 = ScenarioFile::load("level2").unwrap();
        let envelope = ScenarioFile::load("envelope").unwrap();
        let ends = |g: &[f32]| match (g.first(), g.last()) {
            (Some(&lo), Some(&hi)) => Some([f64::from(lo), f64::from(hi)]),
            _ => None,
        };
        let expected = ScenarioFile {
            name: "envelope".into(),
            dispersion: DispersionSection {
                airspeed_mps: ends(&SCHEDULE_SPEEDS_MPS),
                altitude_m: ends(&SCHEDULE_ALTITUDES_M),
                ..level2.dispersion.clone()
            },
            ..level2
        };
        assert_eq!(envelope, expected);
        let (v, h) = (
            ends(&SCHEDULE_SPEEDS_MPS).unwrap(),
            ends(&SCHEDULE_ALTITUDES_M).unwrap(),
        );
        let (mut speeds, mut heights) = (Vec::new(), Vec::new());
        for i in 0..200 {
            let f = envelope.dispersed(i);
            f.validate().unwrap();
            let c = f.flight.condition();
            assert!((v[0]..=v[1]).contains(&c.airspeed_mps), "run {i}: {c:?}");
            assert!((h[0]..=h[1]).contains(&c.altitude_m), "run {i}: {c:?}");
            speeds.push(c.airspeed_mps);
            heights.push(c.altitude_m);
        }
        // Spread over the envelope, not stuck at one condition.
        for (x, [lo, hi]) in [(speeds, v), (heights, h)] {
            let (min, max) = x
                .iter()
                .fold((f64::MAX, f64::MIN), |(a, b), &x| (a.min(x), b.max(x)));
            assert!(
                min < lo + 0.05 * (hi - lo) && max > hi - 0.05 * (hi - lo),
                "{min}..{max}"
            );
        }
    }

    #[test]
    fn the_controller_is_told_the_reported_gross_mass_unless_the_file_gives_its_own() {
        // Each run's controller believes the drawn mass times one plus the drawn report
        // error (within the preset's 5 %), so both designs are flown across the campaign.
        let base = ScenarioFile::load("level2").unwrap();
        assert_eq!(base.controller_config().mass_factor, 1.0);
        let (mut light, mut first) = (0, 0);
        for i in 0..200 {
            let f = base.dispersed(i);
            let (truth, told) = (
                f.receiver.plant.mass_scale,
                f64::from(f.controller_config().mass_factor),
            );
            let e = f.gross_mass.report_error;
            assert!((-0.05..=0.05).contains(&e), "run {i}: {e}");
            assert!(
                (told - truth * (1.0 + e)).abs() < 1e-6,
                "run {i}: {told} {truth} {e}"
            );
            if told < f64::from(ibvs_core::config::LIGHT_DESIGN_BELOW_MASS_FACTOR) {
                light += 1;
            } else {
                first += 1;
            }
        }
        assert!(light > 10 && first > 100, "{light} light, {first} first");
        // Stated in [controller]: believed whatever the receiver weighs.
        let level2 = PRESETS.iter().find(|p| p.0 == "level2").unwrap().2;
        let stated =
            ScenarioFile::parse(&format!("{level2}[controller]\nmass_factor = 1.1\n"), "s")
                .unwrap();
        for i in [0, 3, 9] {
            assert_eq!(stated.dispersed(i).controller_config().mass_factor, 1.1);
        }
        // A report the controller refuses is the scenario's named error.
        let heavy = ScenarioFile::parse(
            "[receiver]\nmass_scale = 2.0\n[gross_mass]\nreport_error = 0.3\n",
            "heavy",
        );
        let e = heavy
            .expect_err("2.6 of the design mass is refused")
            .to_string();
        assert!(e.contains("mass_factor"), "{e}");
    }

    /// The INS's latency is dispersed; the latency the controller compensates is the
    /// dispersed range's upper end in every run, whatever the run's INS does (the file's
    /// own figure without the dispersion).
    #[test]
    fn a_dispersed_ins_latency_is_compensated_at_the_ranges_upper_end() {
        let base = ScenarioFile::load("level2").unwrap();
        assert_eq!(base.controller_config().nav_latency_steps, 1);
        let mut seen = std::collections::BTreeSet::new();
        for i in 0..50 {
            let f = base.dispersed(i);
            seen.insert(f.navigation.ins.latency_steps);
            assert_eq!(f.controller_config().nav_latency_steps, 2, "run {i}");
        }
        assert_eq!(seen, [1, 2].into());
        // A range beyond what the predictor compensates: its largest.
        let long = ScenarioFile::parse(
            &PRESETS
                .iter()
                .find(|p| p.0 == "level2")
                .map_or(String::new(), |p| {
                    p.2.replace("nav_latency_steps = [1, 2]", "nav_latency_steps = [1, 9]")
                }),
            "long",
        )
        .unwrap();
        assert_eq!(long.dispersed(3).controller_config().nav_latency_steps, 4);
        // Ideal navigation compensates nothing; a stated figure wins over the INS's own.
        let paper = ScenarioFile::load("paper-level2").unwrap();
        assert_eq!(paper.controller_config().nav_latency_steps, 0);
        let stated = ScenarioFile::parse(
            &format!(
                "{}\n[controller]\nnav_latency_steps = 3\n",
                PRESETS.iter().find(|p| p.0 == "level2").map_or("", |p| p.2)
            ),
            "stated",
        )
        .unwrap();
        assert_eq!(stated.controller_config().nav_latency_steps, 3);
        assert_eq!(stated.dispersed(7).controller_config().nav_latency_steps, 3);
    }

    #[test]
    fn a_named_salt_is_fnv1a_and_differs_from_the_numbered_ones() {
        // FNV-1a's published test vectors (the empty string and "a").
        assert_eq!(salt_of(""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(salt_of("a"), 0xaf63_dc4c_8601_ec8c);
        let numbered = [
            SALT_SEED,
            SALT_START,
            SALT_SIGMA,
            SALT_NOISE,
            SALT_LATENCY,
            SALT_MOUNT,
            SALT_PITCH,
            SALT_XCG,
            SALT_NAV_LATENCY,
            SALT_AIRSPEED,
            SALT_ALTITUDE,
        ];
        let named = salt_of("receiver.elevator_effectiveness");
        assert!(numbered.iter().all(|s| (named ^ s) > 0xff), "{named:#x}");
        assert_ne!(named, salt_of("receiver.aileron_effectiveness"));
    }

    #[test]
    fn dispersed_runs_depend_on_the_seed_and_the_index_only_and_stay_in_range() {
        let base = ScenarioFile::load("paper-level2").unwrap();
        let d = base.dispersion.clone();
        let within = |v: f64, [lo, hi]: [f64; 2]| lo <= v && v <= hi;
        let mut seeds = std::collections::BTreeSet::new();
        let mut latencies = std::collections::BTreeSet::new();
        for i in 0..200 {
            let f = base.dispersed(i);
            assert_eq!(f, base.dispersed(i), "a function of the index");
            f.validate().unwrap();
            assert!(f.dispersion.is_empty());
            assert_eq!(f.name, format!("paper-level2-run{i}"));
            seeds.insert(f.seed);
            latencies.insert(f.camera.latency_frames);
            let r = d.drogue_minus_probe_m.unwrap();
            for (j, r) in r.into_iter().enumerate() {
                assert!(within(f.initial.drogue_minus_probe_m[j], r));
                assert!(within(f.camera.mount_error_m[j], [-0.05, 0.05]));
            }
            assert!(within(f.sigma_mps(), [0.56, 0.84]));
            assert!(within(f.camera.pixel_noise_px, [0.25, 1.0]));
            assert!(within(f.camera.mount_pitch_error_deg, [-0.5, 0.5]));
            assert!(within(f.receiver.xcg, [0.30, 0.40]));
            // What is not dispersed is the base file's.
            assert_eq!(f.controller, base.controller);
            assert_eq!(f.camera.rate_hz, base.camera.rate_hz);
        }
        assert_eq!(seeds.len(), 200, "a seed per run");
        assert_eq!(latencies, [1, 2].into(), "both ends of an integer range");
        let mut other = base.clone();
        other.seed = 2;
        assert_ne!(other.dispersed(0).seed, base.dispersed(0).seed);
        assert_ne!(
            other.dispersed(0).initial,
            base.dispersed(0).initial,
            "the campaign seed changes every draw"
        );
    }

    #[test]
    fn each_dispersed_value_has_its_own_stream() {
        let base = ScenarioFile::load("paper-level2").unwrap();
        let mut fewer = base.clone();
        fewer.dispersion.pixel_noise_px = None;
        fewer.dispersion.drogue_minus_probe_m = None;
        fewer.dispersion.vary_seed = Some(false);
        for i in [0, 7, 1000] {
            let (a, b) = (base.dispersed(i), fewer.dispersed(i));
            assert_eq!(a.sigma_mps(), b.sigma_mps());
            assert_eq!(a.receiver, b.receiver);
            assert_eq!(a.camera.mount_error_m, b.camera.mount_error_m);
            assert_eq!(b.camera.pixel_noise_px, base.camera.pixel_noise_px);
            assert_eq!(b.initial, base.initial);
            assert_eq!(b.seed, base.seed, "vary_seed = false");
        }
    }

    #[test]
    fn a_bad_dispersion_names_the_key() {
        for (text, key, what) in [
            (
                "[dispersion]\nturbulence_sigma_mps = [0.9, 0.5]\n",
                "dispersion.turbulence_sigma_mps",
                "minimum exceeds",
            ),
            (
                "[dispersion]\npixel_noise_px = [-1.0, 0.5]\n",
                "dispersion.pixel_noise_px",
                "0..=20",
            ),
            (
                "[dispersion]\ndrogue_minus_probe_m = [[1.0, 6.0], [0.0, 0.0], [0.0, 0.0]]\n",
                "dispersion.drogue_minus_probe_m[0] (forward)",
                "1.5..=30",
            ),
            (
                "[dispersion]\nlatency_frames = [2, 11]\n",
                "dispersion.latency_frames",
                "0..=10",
            ),
            (
                "[dispersion]\nmount_error_m = [[0.0, 0.0], [0.0, 0.0], [0.1, -0.1]]\n",
                "dispersion.mount_error_m[2]",
                "minimum exceeds",
            ),
            (
                "[dispersion]\nxcg = [0.2, 0.3]\n",
                "dispersion.xcg",
                "0.25..=0.45",
            ),
            (
                "[dispersion]\nmount_pitch_error_deg = [-11.0, 0.0]\n",
                "dispersion.mount_pitch_error_deg",
                "-10..=10",
            ),
            (
                "[dispersion]\nxcg_range = [0.3, 0.4]\n",
                "xcg_range",
                "unknown field",
            ),
            ("[receiver]\nxcg = 0.6\n", "receiver.xcg", "0.25..=0.45"),
        ] {
            let e = ScenarioFile::parse(text, "bad").unwrap_err().to_string();
            assert!(e.contains(key) && e.contains(what), "{text}: {e}");
        }
        let ok = ScenarioFile::parse(
            "[dispersion]\nvary_seed = false\nxcg = [0.35, 0.35]\n[receiver]\nxcg = 0.3\n",
            "ok",
        )
        .unwrap();
        assert_eq!(
            ok.dispersed(3).receiver.xcg,
            0.35,
            "an empty-width range is its value"
        );
        assert_eq!(ok.scenario().xcg, 0.3);
    }

    #[test]
    fn the_mount_error_goes_into_the_controllers_belief() {
        let f = ScenarioFile::load("paper-mount-error-ibvs").unwrap();
        let cfg = f.controller_config();
        let nominal = ControllerConfig::paper().camera.position_body_m;
        assert_eq!(
            cfg.camera.position_body_m,
            [nominal[0] - 1.0, nominal[1], nominal[2] + 0.5]
        );
        assert_eq!(
            cfg.probe_tip_body_m, nominal,
            "the probe tip itself is known"
        );
    }

    /// `level2`, which flies the receiver's plant dispersion.
    fn level2_with_plant_dispersion() -> ScenarioFile {
        ScenarioFile::load("level2").unwrap()
    }

    /// Every refuelling preset flies both plant dispersions, exactly the exported ranges;
    /// `nominal-level2` and the paper presets fly the design's plant.
    /// The abort presets are their air's preset plus the call, drawn in every run inside
    /// its range, from its own stream (every other draw as the preset's); a bad range is
    /// named.
    #[test]
    fn the_abort_presets_call_a_breakaway_in_every_run_and_nothing_else_changes() {
        for (base, with) in [
            ("level2", "level2-abort"),
            ("mil-level2", "mil-level2-abort"),
        ] {
            let (b, a) = (
                ScenarioFile::load(base).unwrap(),
                ScenarioFile::load(with).unwrap(),
            );
            assert_eq!(a.dispersion.abort.at_range_m, Some([0.05, 2.5]), "{with}");
            assert!(b.dispersion.abort.is_empty(), "{base}");
            for i in [0, 5, 1_000_000] {
                let (x, mut y) = (b.dispersed(i), a.dispersed(i));
                let r = y.abort.at_range_m.expect("called");
                assert!((0.05..=2.5).contains(&r), "{with} run {i}: {r}");
                assert_eq!(y.scenario().abort_at_range_m, Some(r));
                y.abort = AbortSection::default();
                y.name = x.name.clone();
                assert_eq!(x, y, "{with} run {i}: only the call differs");
            }
        }
        for (text, key) in [
            ("[abort]\nat_range_m = 0.0\n", "abort.at_range_m"),
            ("[abort]\nat_range_m = nan\n", "abort.at_range_m"),
            ("[abort]\nat_range_m = 31.0\n", "abort.at_range_m"),
            (
                "[dispersion.abort]\nat_range_m = [2.0, 1.0]\n",
                "dispersion.abort.at_range_m",
            ),
            (
                "[dispersion.abort]\nat_range_m = [0.0, 1.0]\n",
                "dispersion.abort.at_range_m",
            ),
        ] {
            let e = ScenarioFile::parse(text, "f").unwrap_err().to_string();
            assert!(e.contains(key), "{text}: {e}");
        }
        let f = ScenarioFile::parse("[abort]\nat_range_m = 1.5\n", "f").unwrap();
        assert_eq!(f.scenario().abort_at_range_m, Some(1.5));
        assert_eq!(ScenarioFile::parse(&f.to_toml(), "again").unwrap(), f);
        assert_eq!(ScenarioFile::default().scenario().abort_at_range_m, None);
    }

    #[test]
    fn the_autopilot_table_reaches_the_run_and_a_bad_parameter_is_named() {
        let f = ScenarioFile::parse(
            "[controller]\ninner_loop = \"attitude\"\n[autopilot]\nroll_time_constant_s = 0.4\n",
            "f",
        )
        .unwrap();
        assert_eq!(f.scenario().autopilot.roll_time_constant_s, 0.4);
        assert_eq!(
            f.controller_config().inner_loop,
            ibvs_core::attitude::InnerLoop::Attitude
        );
        assert_eq!(ScenarioFile::parse(&f.to_toml(), "again").unwrap(), f);
        let e = ScenarioFile::parse("[autopilot]\npitch_rate_p = -1.0\n", "f")
            .unwrap_err()
            .to_string();
        assert!(e.contains("autopilot") && e.contains(">= 0"), "{e}");
        let e = ScenarioFile::parse("[autopilot]\nroll_rate_q = 1.0\n", "f")
            .unwrap_err()
            .to_string();
        assert!(e.contains("roll_rate_q"), "{e}");
    }

    #[test]
    fn a_law_the_refuelling_procedure_does_not_fly_is_refused() {
        let e = ScenarioFile::parse("[controller]\nlaw = \"pbvs\"\n", "f")
            .unwrap_err()
            .to_string();
        assert!(e.contains("controller.law") && e.contains("paper"), "{e}");
        let paper = "[controller]\nprocedure = \"paper\"\nlaw = \"pbvs\"\n";
        assert_eq!(
            ScenarioFile::parse(paper, "f")
                .unwrap()
                .controller_config()
                .law,
            OuterLaw::Pbvs
        );
        // The default law under the refuelling procedure is accepted (it is the default).
        assert!(ScenarioFile::parse("[controller]\nlaw = \"ibvs\"\n", "f").is_ok());
    }

    #[test]
    fn the_refuelling_presets_fly_the_plant_dispersions_and_the_others_do_not() {
        let receiver = ScenarioFile::parse(RECEIVER_PLANT_DISPERSION, "r").unwrap();
        let world = ScenarioFile::parse(WORLD_PLANT_DISPERSION, "w").unwrap();
        let refuelling = [
            "level1",
            "level2",
            "bow-wave",
            "mil-level2",
            "wide-start",
            "envelope",
            "level2-abort",
            "mil-level2-abort",
            "autopilot-level2",
            "autopilot-mil-level2",
        ];
        for (name, _, _) in PRESETS {
            let d = ScenarioFile::load(name).unwrap().dispersion;
            if refuelling.contains(&name) {
                assert_eq!(d.receiver, receiver.dispersion.receiver, "{name}");
                assert_eq!(d.gross_mass, receiver.dispersion.gross_mass, "{name}");
                assert_eq!(d.drogue, world.dispersion.drogue, "{name}");
                assert_eq!(d.turbulence, world.dispersion.turbulence, "{name}");
                assert_eq!(d.tanker_wake, world.dispersion.tanker_wake, "{name}");
                assert_eq!(d.bow_wave, world.dispersion.bow_wave, "{name}");
                assert_eq!(d.camera, world.dispersion.camera, "{name}");
                assert_eq!(d.navigation, world.dispersion.navigation, "{name}");
            } else {
                assert!(d.receiver.is_empty() && d.gross_mass.is_empty(), "{name}");
                assert!(
                    d.drogue.is_empty()
                        && d.turbulence.is_empty()
                        && d.tanker_wake.is_empty()
                        && d.bow_wave.is_empty()
                        && d.camera.is_empty()
                        && d.navigation.is_empty(),
                    "{name}"
                );
            }
        }
        // nominal-level2 is level2 but for the plant.
        let mut plant = ScenarioFile::load("level2").unwrap();
        plant.dispersion.receiver = ReceiverPlantRanges::default();
        plant.dispersion.gross_mass = GrossMassDispersion::default();
        let nominal = ScenarioFile::load("nominal-level2").unwrap();
        plant.dispersion.drogue = nominal.dispersion.drogue.clone();
        plant.dispersion.turbulence = nominal.dispersion.turbulence.clone();
        plant.dispersion.tanker_wake = nominal.dispersion.tanker_wake.clone();
        plant.dispersion.bow_wave = nominal.dispersion.bow_wave.clone();
        plant.dispersion.camera = nominal.dispersion.camera.clone();
        plant.dispersion.navigation = nominal.dispersion.navigation.clone();
        plant.name = nominal.name.clone();
        assert_eq!(plant, nominal);
        // The plant's draws take streams of their own: the runs of the two presets share
        // every other draw (start, air, camera noise and latency, mount, cg, INS latency).
        let level2 = ScenarioFile::load("level2").unwrap();
        for i in [0, 3, 999, 1_000_000] {
            let (a, b) = (level2.dispersed(i), nominal.dispersed(i));
            assert_eq!(a.initial, b.initial, "run {i}");
            assert_eq!(a.turbulence.sigma_mps, b.turbulence.sigma_mps, "run {i}");
            assert_eq!(a.receiver.xcg, b.receiver.xcg, "run {i}");
            assert_eq!(a.camera.pixel_noise_px, b.camera.pixel_noise_px, "run {i}");
            assert_eq!(a.camera.latency_frames, b.camera.latency_frames, "run {i}");
            assert_eq!(a.camera.mount_error_m, b.camera.mount_error_m, "run {i}");
            assert_eq!(
                a.camera.mount_pitch_error_deg, b.camera.mount_pitch_error_deg,
                "run {i}"
            );
            assert_eq!(
                a.navigation.ins.latency_steps, b.navigation.ins.latency_steps,
                "run {i}"
            );
            assert_ne!(a.receiver.plant, b.receiver.plant, "run {i}");
        }
    }

    #[test]
    fn receiver_plant_keys_reach_the_scenario_and_round_trip() {
        let f = ScenarioFile::parse(
            "[receiver]\nxcg = 0.3\nmass_scale = 1.1\nelevator_effectiveness = 0.9\njy_scale = 1\n",
            "plant",
        )
        .unwrap();
        let plant = f.scenario().receiver_plant;
        assert_eq!(
            (
                plant.mass_scale,
                plant.elevator_effectiveness,
                plant.jy_scale
            ),
            (1.1, 0.9, 1.0)
        );
        assert_eq!(
            plant.aileron_effectiveness, 1.0,
            "a key not given is nominal"
        );
        assert_eq!(f.scenario().xcg, 0.3);
        let back = ScenarioFile::parse(&f.to_toml(), "round trip").unwrap();
        assert_eq!(back, f);
        assert!(
            ScenarioFile::default()
                .scenario()
                .receiver_plant
                .is_nominal()
        );
        // Every factor is written out.
        let text = ScenarioFile::default().to_toml();
        for info in FACTORS {
            assert!(
                text.contains(&format!("{} = 1.0", info.name)),
                "{}",
                info.name
            );
        }
    }

    #[test]
    fn a_bad_receiver_plant_key_names_the_key_and_the_range() {
        for (text, key, what) in [
            (
                "[receiver]\nelevator_effectiveness = 5.0\n",
                "receiver.elevator_effectiveness",
                "0.1..=3",
            ),
            (
                "[receiver]\nmass_scale = nan\n",
                "receiver.mass_scale",
                "0.5..=2",
            ),
            (
                "[receiver]\nelevator_bandwidth_scale = 2.5\n",
                "receiver.elevator_bandwidth_scale",
                "0.1..=2",
            ),
            (
                "[receiver]\nyaw_damping_scale = -0.5\n",
                "receiver.yaw_damping_scale",
                "0..=3",
            ),
            ("[receiver]\nmass = 1.1\n", "mass", "unknown field"),
            (
                "[dispersion.receiver]\nmass_scale = [1.3, 0.9]\n",
                "dispersion.receiver.mass_scale",
                "minimum exceeds",
            ),
            (
                "[dispersion.receiver]\njy_scale = [0.4, 1.0]\n",
                "dispersion.receiver.jy_scale",
                "0.5..=2",
            ),
            (
                "[dispersion.receiver]\nengine_time_constant_scale = [1.0, 4.5]\n",
                "dispersion.receiver.engine_time_constant_scale",
                "0.25..=4",
            ),
            (
                "[dispersion.receiver]\nmass = [1.0, 1.1]\n",
                "mass",
                "unknown field",
            ),
        ] {
            let e = ScenarioFile::parse(text, "bad").unwrap_err().to_string();
            assert!(e.contains(key) && e.contains(what), "{text}: {e}");
        }
    }

    /// The refuelling presets' plant dispersion: every factor, each range around the nominal,
    /// every draw inside its range, a function of the file and the run index, spread over the
    /// range.
    #[test]
    fn the_plant_dispersion_draws_every_factor_in_its_range() {
        let f = level2_with_plant_dispersion();
        let ranges = f.dispersion.receiver;
        let mut seen = vec![Vec::new(); FACTOR_COUNT];
        for i in 0..200 {
            let run = f.dispersed(i);
            assert_eq!(run, f.dispersed(i), "a function of the index");
            run.validate().unwrap();
            let plant = run.scenario().receiver_plant;
            for (j, (r, &v)) in ranges.values().into_iter().zip(plant.values()).enumerate() {
                let [lo, hi] = r.expect("every factor dispersed");
                assert!(lo <= 1.0 && 1.0 <= hi && lo < hi, "{}", FACTORS[j].name);
                assert!((lo..=hi).contains(&v), "run {i}: {} = {v}", FACTORS[j].name);
                seen[j].push(v);
            }
        }
        for (j, draws) in seen.iter().enumerate() {
            let [lo, hi] = ranges.values()[j].unwrap();
            let (min, max) = draws
                .iter()
                .fold((f64::MAX, f64::MIN), |(a, b), &x| (a.min(x), b.max(x)));
            let spread = 0.05 * (hi - lo);
            assert!(
                min < lo + spread && max > hi - spread,
                "{}: {min}..{max}",
                FACTORS[j].name
            );
        }
        // Distinct streams: no two factors draw the same sequence.
        for a in 0..FACTOR_COUNT {
            for b in a + 1..FACTOR_COUNT {
                assert_ne!(seen[a], seen[b], "{} {}", FACTORS[a].name, FACTORS[b].name);
            }
        }
    }

    /// Adding the plant's table changes no other draw; removing one factor's range changes
    /// no other factor's draw and leaves that factor at the file's value.
    #[test]
    fn each_plant_factor_has_its_own_stream() {
        let with_plant = level2_with_plant_dispersion();
        let mut level2 = ScenarioFile::load("level2").unwrap();
        level2.dispersion.receiver = ReceiverPlantRanges::default();
        let mut fewer = with_plant.clone();
        fewer.dispersion.receiver.mass_scale = None;
        fewer.receiver.plant.mass_scale = 1.1;
        for i in [0, 7, 1000] {
            let (a, b) = (with_plant.dispersed(i), level2.dispersed(i));
            assert_eq!(
                ScenarioFile {
                    receiver: b.receiver.clone(),
                    name: b.name.clone(),
                    ..a.clone()
                },
                b,
                "run {i}: only the receiver's plant differs"
            );
            assert!(b.receiver.plant.is_nominal());
            let c = fewer.dispersed(i);
            assert_eq!(c.receiver.plant.mass_scale, 1.1);
            for (j, (x, y)) in a
                .receiver
                .plant
                .values()
                .into_iter()
                .zip(c.receiver.plant.values())
                .enumerate()
            {
                if FACTORS[j].name != "mass_scale" {
                    assert_eq!(x, y, "run {i}: {}", FACTORS[j].name);
                }
            }
        }
    }

    /// Every plant key (value and dispersion) with its bound, for the range tests.
    fn plant_bound_list() -> Vec<PlantBound> {
        let f = ScenarioFile::default();
        let d = &f.dispersion;
        let mut all: Vec<PlantBound> = plant_keys!(f, d).iter().map(|(b, _, _)| **b).collect();
        all.push(plant_bounds::SCALE_LENGTH);
        all
    }

    /// The TOML of key `bound.key` (or its dispersion, `range`) set to `text`.
    fn plant_toml(bound: &PlantBound, text: &str, range: bool) -> String {
        let (section, key) = bound.key.split_once('.').unwrap();
        let (name, index) = match key.split_once('[') {
            Some((name, i)) => (name, i.trim_end_matches(']').parse::<usize>().ok()),
            None => (key, None),
        };
        let value = match index {
            // The other axis at a valid value.
            Some(0) => format!("[{text}, {}]", if range { "[0.0, 0.0]" } else { "0.0" }),
            Some(_) => format!("[{}, {text}]", if range { "[0.0, 0.0]" } else { "0.0" }),
            None => text.to_string(),
        };
        let switch = match section {
            "tanker_wake" | "bow_wave" if !range => "enabled = true\n",
            _ => "",
        };
        if range {
            format!("[dispersion.{section}]\n{name} = {value}\n")
        } else {
            format!("[{section}]\n{switch}{name} = {value}\n")
        }
    }

    #[test]
    fn every_plant_key_is_accepted_at_its_limits_and_named_with_its_range_beyond() {
        for b in plant_bound_list() {
            let step = 1e-6 * (b.max - b.min);
            for v in [b.min, b.max] {
                let f = ScenarioFile::parse(&plant_toml(&b, &v.to_string(), false), "limit")
                    .unwrap_or_else(|e| panic!("{} = {v}: {e}", b.key));
                f.scenario();
                ScenarioFile::parse(&plant_toml(&b, &format!("[{v}, {v}]"), true), "limit")
                    .unwrap_or_else(|e| panic!("{} = [{v}, {v}]: {e}", b.dispersion_key));
            }
            for v in [b.min - step, b.max + step] {
                let e = ScenarioFile::parse(&plant_toml(&b, &v.to_string(), false), "bad")
                    .unwrap_err()
                    .to_string();
                assert!(e.contains(b.key) && e.contains(b.allowed), "{e}");
                let e =
                    ScenarioFile::parse(&plant_toml(&b, &format!("[{v}, {}]", b.max), true), "bad")
                        .unwrap_err()
                        .to_string();
                assert!(e.contains(b.dispersion_key) && e.contains(b.allowed), "{e}");
            }
            let e = ScenarioFile::parse(
                &plant_toml(&b, &format!("[{}, {}]", b.max, b.min), true),
                "bad",
            )
            .unwrap_err()
            .to_string();
            assert!(
                e.contains(b.dispersion_key) && e.contains("minimum exceeds"),
                "{e}"
            );
        }
    }

    #[test]
    fn every_ins_figure_is_accepted_at_its_limit_and_named_with_its_range_beyond() {
        use crate::world::nav::INS_LIMITS;
        for limit in INS_LIMITS {
            let name = limit.key.rsplit('.').next().unwrap();
            let integer = name == "latency_steps";
            let text = |v: f64| {
                if integer {
                    format!("{}", v as i64)
                } else {
                    format!("{v:?}")
                }
            };
            // The controller's compensated latency stated apart: its own limit is not the INS's.
            let file = |v: f64| {
                format!(
                    "[controller]\nnav_latency_steps = 1\n[navigation.ins]\n{name} = {}\n",
                    text(v)
                )
            };
            for v in [limit.min, limit.max] {
                ScenarioFile::parse(&file(v), "limit")
                    .unwrap_or_else(|e| panic!("{} = {v}: {e}", limit.key));
            }
            let beyond = if integer {
                limit.max + 1.0
            } else {
                limit.max * (1.0 + 1e-9)
            };
            let e = ScenarioFile::parse(&file(beyond), "bad")
                .unwrap_err()
                .to_string();
            assert!(e.contains(limit.key) && e.contains(limit.allowed), "{e}");
            if !integer {
                let e = ScenarioFile::parse(&file(-1e-9), "bad")
                    .unwrap_err()
                    .to_string();
                assert!(e.contains(limit.key) && e.contains(limit.allowed), "{e}");
            }
        }
        // The figure that used to fly.
        let e = ScenarioFile::parse("[navigation.ins]\ngyro_bias_deg_per_h = 1e30\n", "bad")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("navigation.ins.gyro_bias_deg_per_h") && e.contains("0..=3600"),
            "{e}"
        );
    }

    #[test]
    fn the_plant_keys_reach_the_world_and_nominal_is_todays_world() {
        let nominal = ScenarioFile::default().scenario();
        assert_eq!(nominal.hose, Some(HoseParams::default()));
        assert_eq!(nominal.wake, Some(WakeParams::default()));
        assert_eq!(
            (nominal.bow_wave_strength, nominal.turbulence_scale_length_m),
            (1.0, None)
        );
        assert_eq!(
            (nominal.camera_roll_error_rad, nominal.camera_yaw_error_rad),
            (0.0, 0.0)
        );
        assert!(matches!(nominal.camera, CameraChoice::Led(p) if p == LedCameraParams::default()));
        assert_eq!(nominal.navigation, Some(InsErrors::default()));
        let f = ScenarioFile::parse(
            "[drogue]\ndrogue_mass_kg = 31.0\ndrogue_drag_coefficient = 0.7\nhose_length_m = 15.0\n\
             hose_linear_density_kg_per_m = 3.9\nhose_drag_scale = 1.5\n\
             [turbulence]\nscale_length_m = 700.0\n\
             [tanker_wake]\nenabled = true\nstrength = 1.2\n\
             [bow_wave]\nenabled = true\nstrength = 0.8\n\
             [camera]\nmount_roll_error_deg = 0.3\nmount_yaw_error_deg = -0.2\n\
             focal_error_px = 4.0\nprincipal_point_error_px = [2.0, -3.0]\n\
             radial_distortion_k1 = -0.01\nradial_distortion_k2 = 0.02\n\
             [navigation]\ngrade = \"industrial\"\n",
            "plant",
        )
        .unwrap();
        let s = f.scenario();
        let h = s.hose.unwrap();
        assert_eq!(
            [
                h.drogue_mass_kg,
                h.drogue_drag_coefficient,
                h.hose_length_m,
                h.hose_linear_density_kg_per_m,
                h.hose_drag_scale
            ],
            [31.0, 0.7, 15.0, 3.9, 1.5]
        );
        assert_eq!(s.turbulence_scale_length_m, Some(700.0));
        assert_eq!(s.wake.unwrap().strength_scale, 1.2);
        assert_eq!(s.bow_wave_strength, 0.8);
        assert!((s.camera_roll_error_rad - 0.3f64.to_radians()).abs() < 1e-15);
        assert!((s.camera_yaw_error_rad + 0.2f64.to_radians()).abs() < 1e-15);
        let CameraChoice::Led(p) = s.camera else {
            panic!("{:?}", s.camera)
        };
        assert_eq!(
            p.intrinsics_error,
            IntrinsicsError {
                focal_px: 4.0,
                principal_px: [2.0, -3.0],
                radial_k: [-0.01, 0.02]
            }
        );
        assert_eq!(s.navigation, Some(InsGrade::Industrial.errors()));
        // The controller does not know any of it.
        assert_eq!(f.controller_config(), ControllerConfig::default());
        // Written out and read back, the same file.
        assert_eq!(ScenarioFile::parse(&f.to_toml(), "back").unwrap(), f);
    }

    #[test]
    fn a_bare_switch_section_is_still_a_file_and_its_strength_defaults_to_one() {
        let f = ScenarioFile::parse(
            "[bow_wave]\nenabled = true\n[tanker_wake]\nenabled = false\n",
            "old",
        )
        .unwrap();
        assert_eq!((f.bow_wave.strength, f.tanker_wake.strength), (1.0, 1.0));
        assert!(f.bow_wave.enabled && !f.tanker_wake.enabled);
    }

    #[test]
    fn an_ins_figure_given_replaces_its_grades_and_the_rest_are_the_grades() {
        let f = ScenarioFile::parse(
            "[navigation]\ngrade = \"industrial\"\n[navigation.ins]\ngyro_bias_deg_per_h = 3.0\n",
            "mixed",
        )
        .unwrap();
        assert_eq!(
            f.navigation.ins,
            InsErrors {
                gyro_bias_deg_per_h: 3.0,
                ..InsGrade::Industrial.errors()
            }
        );
        assert_eq!(ScenarioFile::parse(&f.to_toml(), "back").unwrap(), f);
        let e = ScenarioFile::parse("[navigation]\ngrade = \"consumer\"\n", "bad")
            .unwrap_err()
            .to_string();
        assert!(e.contains("consumer"), "{e}");
        let e = ScenarioFile::parse("[navigation.ins]\ngyro_bias = 1.0\n", "bad")
            .unwrap_err()
            .to_string();
        assert!(e.contains("gyro_bias"), "{e}");
    }

    /// The world's plant dispersion: on `level2` and `mil-level2` every run is valid, in
    /// range, a function of its index, and the draws of one key do not depend on the others.
    #[test]
    fn the_plant_dispersion_draws_are_deterministic_in_range_and_independent() {
        for name in ["level2", "mil-level2"] {
            let base = ScenarioFile::load(name).unwrap();
            let d = base.dispersion.clone();
            let mut grades = std::collections::BTreeSet::new();
            let mut lows = [false; 15];
            let mut highs = [false; 15];
            // Each run's draws, as fractions of their ranges, for the correlations.
            let mut fractions: Vec<[f64; 15]> = Vec::new();
            for i in 0..400 {
                let f = base.dispersed(i);
                assert_eq!(f, base.dispersed(i), "{name} run {i}");
                f.validate().unwrap();
                let mut fraction = [0.0; 15];
                for (k, (b, v, _)) in plant_keys!(f, d).into_iter().enumerate() {
                    let r = plant_keys!(base, d)[k].2.unwrap();
                    assert!(r[0] <= v && v <= r[1], "{} = {v} outside {r:?}", b.key);
                    lows[k] |= v < r[0] + 0.1 * (r[1] - r[0]);
                    highs[k] |= v > r[1] - 0.1 * (r[1] - r[0]);
                    fraction[k] = (v - r[0]) / (r[1] - r[0]);
                }
                fractions.push(fraction);
                let l = f.turbulence.scale_length_m.unwrap();
                assert!((533.4..=762.0).contains(&l), "{l}");
                grades.insert(format!("{:?}", f.navigation.grade));
                assert_eq!(
                    f.navigation.ins,
                    InsErrors {
                        latency_steps: f.navigation.ins.latency_steps,
                        ..f.navigation.grade.errors()
                    }
                );
                assert!([1, 2].contains(&f.navigation.ins.latency_steps));
            }
            assert!(lows.iter().chain(&highs).all(|x| *x), "{lows:?} {highs:?}");
            // Independent streams: no two keys' draws correlate (|r| < 0.2 over 400 runs,
            // about four standard errors).
            let n = fractions.len() as f64;
            for a in 0..15 {
                for b in a + 1..15 {
                    let (ma, mb) = (
                        fractions.iter().map(|x| x[a]).sum::<f64>() / n,
                        fractions.iter().map(|x| x[b]).sum::<f64>() / n,
                    );
                    let cov = |i: usize, j: usize, mi: f64, mj: f64| {
                        fractions
                            .iter()
                            .map(|x| (x[i] - mi) * (x[j] - mj))
                            .sum::<f64>()
                            / n
                    };
                    let r = cov(a, b, ma, mb) / (cov(a, a, ma, ma) * cov(b, b, mb, mb)).sqrt();
                    assert!(r.abs() < 0.2, "keys {a} and {b} correlate: {r}");
                }
            }
            assert_eq!(grades.len(), 2, "both grades flown");
            // Removing plant keys changes neither the others' draws nor the old keys'.
            let mut fewer = base.clone();
            fewer.dispersion.drogue.hose_length_m = None;
            fewer.dispersion.camera = CameraDispersion {
                focal_error_px: d.camera.focal_error_px,
                ..CameraDispersion::default()
            };
            fewer.dispersion.navigation = NavigationDispersion::default();
            let mut none = base.clone();
            none.dispersion = ScenarioFile::load(name).unwrap().dispersion;
            for i in [0, 7, 1000] {
                let (a, b, c) = (base.dispersed(i), fewer.dispersed(i), none.dispersed(i));
                assert_eq!(a.drogue.drogue_mass_kg, b.drogue.drogue_mass_kg);
                assert_eq!(b.drogue.hose_length_m, HOSE_LENGTH_M);
                assert_eq!(a.camera.focal_error_px, b.camera.focal_error_px);
                assert_eq!(b.camera.mount_roll_error_deg, 0.0);
                assert_eq!(a.tanker_wake, b.tanker_wake);
                assert_eq!(b.navigation.grade, base.navigation.grade);
                assert_eq!(
                    b.navigation.ins,
                    InsErrors {
                        latency_steps: b.navigation.ins.latency_steps,
                        ..base.navigation.ins
                    }
                );
                // The older keys draw as they did without the plant dispersion.
                assert_eq!(
                    (a.seed, a.initial.clone(), a.sigma_mps(), a.receiver.clone()),
                    (c.seed, c.initial.clone(), c.sigma_mps(), c.receiver.clone())
                );
                assert_eq!(a.camera.mount_error_m, c.camera.mount_error_m);
                assert_eq!(
                    a.navigation.ins.latency_steps,
                    c.navigation.ins.latency_steps
                );
            }
        }
    }

    #[test]
    fn a_grade_dispersion_is_named_when_empty_or_against_given_figures() {
        let e = ScenarioFile::parse("[dispersion.navigation]\ngrade = []\n", "bad")
            .unwrap_err()
            .to_string();
        assert!(e.contains("dispersion.navigation.grade"), "{e}");
        let e = ScenarioFile::parse(
            "[navigation.ins]\nheading_bias_deg = 2.0\n[dispersion.navigation]\ngrade = [\"industrial\"]\n",
            "bad",
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("dispersion.navigation.grade") && e.contains("give one"),
            "{e}"
        );
        // The latency is the file's either way.
        let f = ScenarioFile::parse(
            "[navigation.ins]\nlatency_steps = 3\n[dispersion.navigation]\ngrade = [\"industrial\"]\n",
            "ok",
        )
        .unwrap();
        let r = f.dispersed(5);
        assert_eq!(r.navigation.grade, InsGrade::Industrial);
        assert_eq!(r.navigation.ins.latency_steps, 3);
    }
}
