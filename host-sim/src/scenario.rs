//! Scenario files: what a user writes to describe a run, the built-in presets, and their
//! validation.
//!
//! A scenario is TOML. Every key is optional (the defaults are the paper's start in calm air
//! with the tanker's wake, the full hose and drogue and the LED camera); an unknown key is an
//! error that names it; a value out of range is an error that names the key and the allowed
//! range. [`ScenarioFile::build`] turns a validated file into the simulator's [`Scenario`]
//! and the controller's [`ControllerConfig`].
//!
//! Invariant: a built scenario only contains values that passed [`ScenarioFile::validate`].

use ibvs_core::{ControllerConfig, OuterLaw};
use serde::{Deserialize, Serialize};

use crate::sim::{PAPER_START_M, Scenario};
use crate::world::turbulence::TurbulencePreset;

/// Which outer loop flies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Law {
    /// Image-based (the paper's).
    #[default]
    Ibvs,
    /// Position-based baseline.
    Pbvs,
}

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

/// `[gains]`: outer-loop gains.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GainsSection {
    /// k1..k5 (paper Table 1 by default), normalised image units.
    pub k: [f64; 5],
    /// Minimum closing speed a, m/s.
    pub min_closing_mps: f64,
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
}

/// A section with just an on/off switch (`[bow_wave]`, `[tanker_wake]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Switch {
    /// On or off.
    pub enabled: bool,
}

/// `[drogue]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DrogueSection {
    /// Model.
    pub model: DrogueModel,
}

/// `[camera]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CameraSection {
    /// Model.
    pub model: CameraModel,
    /// True minus assumed camera position, receiver body axes, m: the controller believes the
    /// camera is at the probe tip minus this.
    pub mount_error_m: [f64; 3],
    /// Error of the camera's boresight pitch, true minus assumed, degrees: the controller
    /// assumes the boresight is level at trim; positive points it further down.
    pub mount_pitch_error_deg: f64,
    /// Pixel noise on each LED centroid (1 sigma), px.
    pub pixel_noise_px: f64,
    /// Frames between capture and delivery.
    pub latency_frames: u32,
    /// Frame rate, Hz.
    pub rate_hz: f64,
    /// Probability that a frame is lost.
    pub drop_probability: f64,
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
    /// Outer loop.
    pub controller: Law,
    /// Outer-loop gains.
    pub gains: GainsSection,
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
}

/// Table 1 of the paper: k1..k5.
pub const TABLE_1: [f64; 5] = [1.0, 2.0, 0.3, 3.0, 1.0];
/// Table 2 of the paper (under the bow wave): k1..k5.
pub const TABLE_2: [f64; 5] = [3.0, 3.0, 0.5, 5.0, 2.0];
/// The paper's camera position error, body axes, m (Sec. IV, experiment 2).
pub const PAPER_MOUNT_ERROR_M: [f64; 3] = [1.0, 0.0, -0.5];

impl Default for ScenarioFile {
    fn default() -> Self {
        let cfg = ControllerConfig::default();
        Self {
            name: "default".into(),
            seed: 1,
            duration_s: 70.0,
            controller: Law::Ibvs,
            gains: GainsSection {
                k: TABLE_1,
                min_closing_mps: f64::from(cfg.velocity_limits.min_closing_mps),
            },
            initial: InitialSection {
                drogue_minus_probe_m: PAPER_START_M,
            },
            turbulence: TurbulenceSection {
                preset: TurbulencePreset::None,
                sigma_mps: None,
            },
            bow_wave: Switch { enabled: false },
            tanker_wake: Switch { enabled: true },
            drogue: DrogueSection {
                model: DrogueModel::Hose,
            },
            camera: CameraSection {
                model: CameraModel::Led,
                mount_error_m: [0.0; 3],
                mount_pitch_error_deg: 0.0,
                pixel_noise_px: 0.5,
                latency_frames: 1,
                rate_hz: 50.0,
                drop_probability: 0.0,
            },
        }
    }
}

impl Default for GainsSection {
    fn default() -> Self {
        ScenarioFile::default().gains
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
    /// Neither a preset name nor a readable file.
    #[error("no preset or file named {0:?} (presets: {presets})", presets = PRESETS.iter().map(|p| p.0).collect::<Vec<_>>().join(", "))]
    NotFound(String),
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

/// Built-in presets: name, description and TOML text (parsed like a user's file).
pub const PRESETS: [(&str, &str, &str); 6] = [
    (
        "calm",
        "paper start, calm air, tanker wake, hose and LED camera (the default)",
        "",
    ),
    (
        "paper-level1",
        "paper start, level I turbulence (0.5 m/s), Table 1 gains",
        "[turbulence]\npreset = \"level1\"\n",
    ),
    (
        "paper-level2",
        "paper start, level II turbulence (0.7 m/s), Table 1 gains",
        "[turbulence]\npreset = \"level2\"\n",
    ),
    (
        "paper-bow-wave",
        "paper start, level I turbulence and the bow wave, Table 2 gains",
        "[gains]\nk = [3.0, 3.0, 0.5, 5.0, 2.0]\n[turbulence]\npreset = \"level1\"\n[bow_wave]\nenabled = true\n",
    ),
    (
        "paper-mount-error-ibvs",
        "paper start, IBVS, camera mount error [1, 0, -0.5] m",
        "controller = \"ibvs\"\n[camera]\nmount_error_m = [1.0, 0.0, -0.5]\n",
    ),
    (
        "paper-mount-error-pbvs",
        "paper start, PBVS, camera mount error [1, 0, -0.5] m",
        "controller = \"pbvs\"\n[camera]\nmount_error_m = [1.0, 0.0, -0.5]\n",
    ),
];

impl ScenarioFile {
    /// Parses and validates TOML text; `source_name` names it in errors.
    pub fn parse(text: &str, source_name: &str) -> Result<Self, ScenarioError> {
        let f: ScenarioFile = toml::from_str(text).map_err(|e| ScenarioError::Parse {
            source_name: source_name.into(),
            message: e.to_string(),
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
        let text = std::fs::read_to_string(path).map_err(|source| ScenarioError::Io {
            path: name_or_path.into(),
            source,
        })?;
        let mut f = Self::parse(&text, name_or_path)?;
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
        let k_names = [
            "gains.k[0] (k1)",
            "gains.k[1] (k2)",
            "gains.k[2] (k3)",
            "gains.k[3] (k4)",
            "gains.k[4] (k5)",
        ];
        for (i, (k, key)) in self.gains.k.iter().zip(k_names).enumerate() {
            let (lo, allowed) = if i < 3 {
                (1e-6, "(0, 100]")
            } else {
                (0.0, "0..=100")
            };
            range(key, *k, lo, 100.0, allowed)?;
        }
        range(
            "gains.min_closing_mps",
            self.gains.min_closing_mps,
            0.05,
            2.0,
            "0.05..=2.0 (at most the closing-speed limit)",
        )?;
        for (v, key) in self.initial.drogue_minus_probe_m.iter().zip([
            "initial.drogue_minus_probe_m[0] (forward)",
            "initial.drogue_minus_probe_m[1] (right)",
            "initial.drogue_minus_probe_m[2] (down)",
        ]) {
            range(key, *v, -30.0, 30.0, "-30..=30")?;
        }
        range(
            "initial.drogue_minus_probe_m[0] (forward)",
            self.initial.drogue_minus_probe_m[0],
            1.5,
            30.0,
            "1.5..=30 (ahead of the probe, outside the blind range)",
        )?;
        if let Some(s) = self.turbulence.sigma_mps {
            range("turbulence.sigma_mps", s, 0.0, 10.0, "0..=10")?;
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
        )
    }

    /// RMS gust speed of the run, m/s.
    pub fn sigma_mps(&self) -> f64 {
        self.turbulence
            .sigma_mps
            .unwrap_or_else(|| self.turbulence.preset.sigma_mps())
    }

    /// The controller's configuration for this scenario.
    pub fn controller_config(&self) -> ControllerConfig {
        let law = match self.controller {
            Law::Ibvs => OuterLaw::Ibvs,
            Law::Pbvs => OuterLaw::Pbvs,
        };
        let mut cfg = ControllerConfig {
            law,
            ..ControllerConfig::default()
        };
        let g = &mut cfg.ibvs;
        let k = self.gains.k.map(|v| v as f32);
        (g.k1_mps, g.k2_mps, g.k3_per_s, g.k4_mps, g.k5_mps) = (k[0], k[1], k[2], k[3], k[4]);
        cfg.velocity_limits.min_closing_mps = self.gains.min_closing_mps as f32;
        // The controller believes the camera is where it was meant to be: true minus error.
        for (b, e) in cfg
            .camera
            .position_body_m
            .iter_mut()
            .zip(self.camera.mount_error_m)
        {
            *b -= e as f32;
        }
        cfg
    }

    /// The simulator's scenario.
    pub fn scenario(&self) -> Scenario {
        Scenario::from_file(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_preset_parses_validates_and_round_trips() {
        for (name, _, _) in PRESETS {
            let f = ScenarioFile::load(name).unwrap();
            assert_eq!(f.name, name);
            let back = ScenarioFile::parse(&f.to_toml(), "round trip").unwrap();
            assert_eq!(back, f, "{name}");
        }
        let bow = ScenarioFile::load("paper-bow-wave").unwrap();
        assert_eq!(bow.gains.k, TABLE_2);
        assert!(bow.bow_wave.enabled);
        assert_eq!(
            ScenarioFile::load("paper-mount-error-pbvs")
                .unwrap()
                .controller,
            Law::Pbvs
        );
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
        let e = ScenarioFile::parse("[gains]\nk = [0.0, 2.0, 0.3, 3.0, 1.0]\n", "bad")
            .unwrap_err()
            .to_string();
        assert!(e.contains("k1"), "{e}");
        let e = ScenarioFile::parse("[turbulence]\npreset = \"hurricane\"\n", "bad")
            .unwrap_err()
            .to_string();
        assert!(e.contains("hurricane"), "{e}");
        let e = ScenarioFile::parse("[initial]\ndrogue_minus_probe_m = [0.5, 0.0, 0.0]\n", "bad")
            .unwrap_err()
            .to_string();
        assert!(e.contains("forward"), "{e}");
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
    fn the_mount_error_goes_into_the_controllers_belief() {
        let f = ScenarioFile::load("paper-mount-error-ibvs").unwrap();
        let cfg = f.controller_config();
        let nominal = ControllerConfig::default().camera.position_body_m;
        assert_eq!(
            cfg.camera.position_body_m,
            [nominal[0] - 1.0, nominal[1], nominal[2] + 0.5]
        );
        assert_eq!(
            cfg.probe_tip_body_m, nominal,
            "the probe tip itself is known"
        );
    }
}
