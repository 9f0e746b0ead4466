//! The F-16 low-fidelity data file, embedded at build time and parsed into typed tables.
//!
//! Source: `host-sim/data/f16-lofi-data.toml`, a transcription of Stevens, Lewis & Johnson,
//! *Aircraft Control and Simulation*, App. A (NASA TP-1538), parsed with `toml` + serde.
//! Invariants (established by [`ModelData::embedded`], which every model constructor calls):
//! every table has its grids' shape (the fixed-size array types make a row of the wrong length a
//! parse error), every grid is finite and strictly increasing, every table entry is finite, the
//! damping rows come in [`DAMPING_ORDER`] and the airframe constants are physical. Numbers stay in
//! the file's units here (degrees, lbf, slug, ft); they are converted to SI where the model is
//! assembled.

use std::sync::OnceLock;

use serde::Deserialize;
use thiserror::Error;

/// Nodes of the angle-of-attack grid (columns of every aerodynamic table).
pub(crate) const N_ALPHA: usize = 12;
/// Nodes of the elevator grid (rows of `cx` and `cm`).
pub(crate) const N_ELEVATOR: usize = 5;
/// Nodes of the |sideslip| grid (rows of `cl` and `cn`).
pub(crate) const N_BETA_ABS: usize = 7;
/// Nodes of the signed sideslip grid (rows of the control-derivative tables).
pub(crate) const N_BETA: usize = 7;
/// Nodes of the altitude grid (columns of the thrust tables).
pub(crate) const N_ALTITUDE: usize = 6;
/// Nodes of the Mach grid (rows of the thrust tables).
pub(crate) const N_MACH: usize = 6;
/// Number of damping-derivative rows.
pub(crate) const N_DAMPING: usize = 9;
/// Required order of the damping rows (the file's `damping_order`).
pub(crate) const DAMPING_ORDER: [&str; N_DAMPING] = [
    "CXq", "CYr", "CYp", "CZq", "Clr", "Clp", "Cmq", "Cnr", "Cnp",
];

/// The data file, embedded so the model cannot run with tables from elsewhere.
const EMBEDDED_DATA_TOML: &str = include_str!("../../data/f16-lofi-data.toml");

/// One row over the angle-of-attack grid.
pub(crate) type AlphaRow = [f64; N_ALPHA];

/// Why the receiver model could not be built or reconfigured.
#[derive(Debug, Error)]
pub enum ModelError {
    /// The embedded data file is not valid TOML or does not have the expected fields and shapes.
    #[error("F-16 data file does not parse: {0}")]
    Parse(#[from] toml::de::Error),
    /// A lookup grid is not finite and strictly increasing.
    #[error("grid `{grid}` must be finite and strictly increasing")]
    GridNotIncreasing {
        /// Name of the grid in the data file.
        grid: &'static str,
    },
    /// The damping rows are not in the order the model reads them.
    #[error("damping_order is {found:?}, expected {DAMPING_ORDER:?}")]
    DampingOrder {
        /// The order found in the file.
        found: Vec<String>,
    },
    /// A parameter or table entry violates its stated requirement.
    #[error("`{name}` = {value} violates: {requirement}")]
    InvalidParameter {
        /// Name of the parameter (data-file key or API argument).
        name: &'static str,
        /// The offending value, in the units of that name.
        value: f64,
        /// What the value must satisfy.
        requirement: &'static str,
    },
}

/// Check that `value` is finite and strictly positive.
pub(crate) fn require_positive(name: &'static str, value: f64) -> Result<f64, ModelError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(ModelError::InvalidParameter {
            name,
            value,
            requirement: "finite and > 0",
        })
    }
}

/// Check that every value in `values` is finite.
fn require_finite(name: &'static str, values: &[f64]) -> Result<(), ModelError> {
    match values.iter().find(|value| !value.is_finite()) {
        Some(&value) => Err(ModelError::InvalidParameter {
            name,
            value,
            requirement: "finite",
        }),
        None => Ok(()),
    }
}

/// The whole data file. Field names mirror the file's keys; units are in the names.
#[derive(Debug, Clone, Deserialize)]
pub(crate) struct ModelData {
    pub(crate) grid: Grids,
    pub(crate) aero: AeroData,
    pub(crate) engine: EngineData,
    pub(crate) airframe: AirframeData,
    pub(crate) atmosphere: AtmosphereData,
    pub(crate) actuators: ActuatorData,
}

/// `[grid]`: the lookup grids.
#[derive(Debug, Clone, Deserialize)]
pub(crate) struct Grids {
    pub(crate) alpha_deg: AlphaRow,
    pub(crate) elevator_deg: [f64; N_ELEVATOR],
    pub(crate) beta_abs_deg: [f64; N_BETA_ABS],
    pub(crate) beta_deg: [f64; N_BETA],
    pub(crate) altitude_ft: [f64; N_ALTITUDE],
    pub(crate) mach: [f64; N_MACH],
}

/// `[aero]`: dimensionless coefficient tables, one row per node of the named row grid.
#[derive(Debug, Clone, Deserialize)]
pub(crate) struct AeroData {
    pub(crate) cx: [AlphaRow; N_ELEVATOR],
    pub(crate) cz_alpha: AlphaRow,
    pub(crate) cm: [AlphaRow; N_ELEVATOR],
    pub(crate) cl: [AlphaRow; N_BETA_ABS],
    pub(crate) cn: [AlphaRow; N_BETA_ABS],
    pub(crate) dlda: [AlphaRow; N_BETA],
    pub(crate) dldr: [AlphaRow; N_BETA],
    pub(crate) dnda: [AlphaRow; N_BETA],
    pub(crate) dndr: [AlphaRow; N_BETA],
    pub(crate) damping_order: [String; N_DAMPING],
    pub(crate) damping: [AlphaRow; N_DAMPING],
}

/// `[engine]`: thrust in lbf, one row per Mach node, one column per altitude node.
#[derive(Debug, Clone, Deserialize)]
pub(crate) struct EngineData {
    pub(crate) thrust_idle: [[f64; N_ALTITUDE]; N_MACH],
    pub(crate) thrust_mil: [[f64; N_ALTITUDE]; N_MACH],
    pub(crate) thrust_max: [[f64; N_ALTITUDE]; N_MACH],
}

/// `[airframe]`: mass properties and reference geometry, English units as published.
#[derive(Debug, Clone, Deserialize)]
pub(crate) struct AirframeData {
    pub(crate) wing_area_ft2: f64,
    pub(crate) span_ft: f64,
    pub(crate) mean_chord_ft: f64,
    pub(crate) mass_slug: f64,
    pub(crate) jx_slugft2: f64,
    pub(crate) jy_slugft2: f64,
    pub(crate) jz_slugft2: f64,
    pub(crate) jxz_slugft2: f64,
    pub(crate) engine_angular_momentum_slugft2_per_s: f64,
    pub(crate) xcg_ref: f64,
    pub(crate) g_ftps2: f64,
}

/// `[atmosphere]`: the numeric part of the model's air-data computer (its formulas are
/// implemented in `atmosphere.rs`).
#[derive(Debug, Clone, Deserialize)]
pub(crate) struct AtmosphereData {
    pub(crate) rho0_slug_ft3: f64,
}

/// `[actuators]`: position limits (deg), rate limits (deg/s), servo bandwidth (rad/s) and the
/// throttle range (fraction).
#[derive(Debug, Clone, Deserialize)]
pub(crate) struct ActuatorData {
    pub(crate) elevator_limit_deg: f64,
    pub(crate) elevator_rate_deg_s: f64,
    pub(crate) aileron_limit_deg: f64,
    pub(crate) aileron_rate_deg_s: f64,
    pub(crate) rudder_limit_deg: f64,
    pub(crate) rudder_rate_deg_s: f64,
    pub(crate) servo_bandwidth_rad_s: f64,
    pub(crate) throttle_range: [f64; 2],
}

impl ModelData {
    /// Parse and check the embedded data file. The parse is done once per process and the
    /// result copied (a campaign builds a model per run, and parsing the TOML cost more than a
    /// hundred simulated steps); a failed parse is not kept, so every call reports it.
    pub(crate) fn embedded() -> Result<Self, ModelError> {
        static PARSED: OnceLock<ModelData> = OnceLock::new();
        if let Some(data) = PARSED.get() {
            return Ok(data.clone());
        }
        let data = Self::parse(EMBEDDED_DATA_TOML)?;
        Ok(PARSED.get_or_init(|| data).clone())
    }

    fn parse(text: &str) -> Result<Self, ModelError> {
        let data: Self = toml::from_str(text)?;
        data.check()?;
        Ok(data)
    }

    fn check(&self) -> Result<(), ModelError> {
        let g = &self.grid;
        let grids: [(&'static str, &[f64]); 6] = [
            ("alpha_deg", &g.alpha_deg),
            ("elevator_deg", &g.elevator_deg),
            ("beta_abs_deg", &g.beta_abs_deg),
            ("beta_deg", &g.beta_deg),
            ("altitude_ft", &g.altitude_ft),
            ("mach", &g.mach),
        ];
        for (grid, nodes) in grids {
            let increasing = nodes.windows(2).all(|pair| pair[0] < pair[1]);
            if !increasing || nodes.iter().any(|node| !node.is_finite()) {
                return Err(ModelError::GridNotIncreasing { grid });
            }
        }
        let (a, e) = (&self.aero, &self.engine);
        let tables: [(&'static str, &[f64]); 13] = [
            ("cx", a.cx.as_flattened()),
            ("cz_alpha", &a.cz_alpha),
            ("cm", a.cm.as_flattened()),
            ("cl", a.cl.as_flattened()),
            ("cn", a.cn.as_flattened()),
            ("dlda", a.dlda.as_flattened()),
            ("dldr", a.dldr.as_flattened()),
            ("dnda", a.dnda.as_flattened()),
            ("dndr", a.dndr.as_flattened()),
            ("damping", a.damping.as_flattened()),
            ("thrust_idle", e.thrust_idle.as_flattened()),
            ("thrust_mil", e.thrust_mil.as_flattened()),
            ("thrust_max", e.thrust_max.as_flattened()),
        ];
        for (name, values) in tables {
            require_finite(name, values)?;
        }
        if a.damping_order != DAMPING_ORDER {
            return Err(ModelError::DampingOrder {
                found: a.damping_order.to_vec(),
            });
        }
        let f = &self.airframe;
        for (name, value) in [
            ("wing_area_ft2", f.wing_area_ft2),
            ("span_ft", f.span_ft),
            ("mean_chord_ft", f.mean_chord_ft),
            ("mass_slug", f.mass_slug),
            ("jx_slugft2", f.jx_slugft2),
            ("jy_slugft2", f.jy_slugft2),
            ("jz_slugft2", f.jz_slugft2),
            ("g_ftps2", f.g_ftps2),
            ("rho0_slug_ft3", self.atmosphere.rho0_slug_ft3),
        ] {
            require_positive(name, value)?;
        }
        for (name, value) in [
            ("jxz_slugft2", f.jxz_slugft2),
            (
                "engine_angular_momentum_slugft2_per_s",
                f.engine_angular_momentum_slugft2_per_s,
            ),
            ("xcg_ref", f.xcg_ref),
        ] {
            require_finite(name, &[value])?;
        }
        if f.jxz_slugft2 * f.jxz_slugft2 >= f.jx_slugft2 * f.jz_slugft2 {
            return Err(ModelError::InvalidParameter {
                name: "jxz_slugft2",
                value: f.jxz_slugft2,
                requirement: "jxz^2 < jx*jz (positive-definite inertia)",
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embedded_file_parses_with_grid_shapes() {
        let data = ModelData::embedded().expect("embedded data file must load");
        // The array types fix the shapes; check them against the grids the file declares.
        let g = &data.grid;
        assert_eq!(
            g.alpha_deg,
            [
                -10.0, -5.0, 0.0, 5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0, 40.0, 45.0
            ]
        );
        assert_eq!(data.aero.cx.len(), g.elevator_deg.len());
        assert_eq!(data.aero.cl.len(), g.beta_abs_deg.len());
        assert_eq!(data.aero.dndr.len(), g.beta_deg.len());
        assert_eq!(data.engine.thrust_max.len(), g.mach.len());
        assert_eq!(data.engine.thrust_max[0].len(), g.altitude_ft.len());
        // Spot values from the file, one per table family.
        assert_eq!(data.aero.cm[2][0], -0.046);
        assert_eq!(data.aero.damping[6][0], -7.21);
        assert_eq!(data.engine.thrust_max[5][5], 5057.0);
        assert_eq!(data.airframe.jxz_slugft2, 982.0);
    }

    #[test]
    fn short_row_is_a_parse_error() {
        let text = EMBEDDED_DATA_TOML.replacen("[-0.099, -0.081, ", "[-0.081, ", 1);
        assert_ne!(text, EMBEDDED_DATA_TOML);
        assert!(matches!(ModelData::parse(&text), Err(ModelError::Parse(_))));
    }

    #[test]
    fn unsorted_grid_is_rejected() {
        let text = EMBEDDED_DATA_TOML.replacen("mach = [0.0, 0.2, 0.4", "mach = [0.0, 0.4, 0.2", 1);
        assert_ne!(text, EMBEDDED_DATA_TOML);
        assert!(matches!(
            ModelData::parse(&text),
            Err(ModelError::GridNotIncreasing { grid: "mach" })
        ));
    }
}
