//! A scenario file's `[controller]` table: the flight computer's [`ControllerConfig`] itself,
//! key for key, each key optional.
//!
//! Place in the data flow: a scenario file's `[controller]` table is read over
//! [`ControllerConfig::default`] (the refuelling procedure) into a [`ControllerSection`];
//! [`super::ScenarioFile::controller_config`] completes it with what the world decides unless
//! the table gives it (the camera's believed position, the navigation's latency) and
//! validates it with the core's own rules. There is no second copy of the configuration's
//! schema here: the keys are the struct's field names (`host-sim config schema` prints them
//! with their units, rules and defaults), so a field added to the core is a key at once.
//!
//! Invariants: an unknown key, or a value of the wrong type, is an error naming its dotted
//! path under `controller.`; writing a section out and reading it back gives the same
//! section (keys the world derives are written only when the file gave them).

use ibvs_core::ControllerConfig;
use serde::de::Error as _;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// Keys of [`ControllerConfig`] that a scenario derives from its world unless the
/// `[controller]` table gives them: the camera's believed position (where `[camera]` places
/// it, less the mount error), the navigation's latency (the INS's; 0 with ideal navigation)
/// and the gross mass (the receiver's, as `[gross_mass]` says it is reported).
pub const DERIVED_KEYS: [&str; 3] = ["camera.position_body_m", "nav_latency_steps", "mass_factor"];

/// `[controller]`: the configuration the file gives, and which derived keys it gave.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ControllerSection {
    /// Every key of the table over [`ControllerConfig::default`]. Its camera position,
    /// navigation latency and gross mass are the file's only where
    /// [`ControllerSection::camera_position_given`], [`ControllerSection::nav_latency_given`]
    /// and [`ControllerSection::mass_given`] say so; otherwise the scenario decides them.
    pub config: ControllerConfig,
    /// The table gave `camera.position_body_m`: the controller believes that, whatever
    /// `[camera]` says.
    pub camera_position_given: bool,
    /// The table gave `nav_latency_steps`: the controller compensates that, whatever the
    /// INS's latency.
    pub nav_latency_given: bool,
    /// The table gave `mass_factor`: the controller believes that, whatever the receiver's
    /// mass.
    pub mass_given: bool,
}

impl ControllerSection {
    /// True when nothing differs from the default (the table may be left out).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }
}

/// Why a `[controller]` table was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ControllerKeyError {
    /// A key that is not a field of the configuration.
    #[error("controller.{path} is not a controller setting (`host-sim config schema` lists them)")]
    Unknown {
        /// Dotted path of the key.
        path: String,
    },
    /// A value of the wrong type or shape.
    #[error("controller.{path}: {message}")]
    Value {
        /// Dotted path of the key.
        path: String,
        /// What was wrong.
        message: String,
    },
}

/// The default configuration as a TOML table (every key).
fn default_table() -> toml::Table {
    table_of(&ControllerConfig::default())
}

/// A configuration as a TOML table (every key).
pub fn table_of(config: &ControllerConfig) -> toml::Table {
    match toml::Value::try_from(config) {
        Ok(toml::Value::Table(t)) => t,
        // A struct of numbers, arrays, enums and nested structs: always a table.
        _ => toml::Table::new(),
    }
}

/// A configuration's number (an `f32`, exact in TOML's `f64`) as the shortest decimal that
/// reads back to the same `f32`: `0.3`, not `0.30000001192092896`.
fn shortest(x: f64) -> f64 {
    format!("{}", x as f32).parse().unwrap_or(x)
}

/// Every float of `v` (recursively) written as [`shortest`].
fn tidy(v: &mut toml::Value) {
    match v {
        toml::Value::Float(x) => *x = shortest(*x),
        toml::Value::Array(a) => a.iter_mut().for_each(tidy),
        toml::Value::Table(t) => t.iter_mut().for_each(|(_, v)| tidy(v)),
        _ => {}
    }
}

/// A setting's value as TOML text, its numbers as the configuration's `f32`s read them.
pub fn text_of(v: &toml::Value) -> String {
    let mut v = v.clone();
    tidy(&mut v);
    v.to_string()
}

/// Writes `over` onto `base`, key by key (tables recursively); a key `base` lacks is
/// [`ControllerKeyError::Unknown`], a table where `base` has a value (or the reverse) is
/// [`ControllerKeyError::Value`].
fn overlay(
    base: &mut toml::Table,
    over: &toml::Table,
    prefix: &str,
) -> Result<(), ControllerKeyError> {
    for (key, value) in over {
        let path = if prefix.is_empty() {
            key.clone()
        } else {
            format!("{prefix}.{key}")
        };
        match (base.get_mut(key), value) {
            (None, _) => return Err(ControllerKeyError::Unknown { path }),
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => overlay(b, o, &path)?,
            (Some(toml::Value::Table(_)), _) => {
                return Err(ControllerKeyError::Value {
                    path,
                    message: "expected a table of settings".into(),
                });
            }
            (Some(_), toml::Value::Table(_)) => {
                return Err(ControllerKeyError::Value {
                    path,
                    message: "expected a value, found a table".into(),
                });
            }
            (Some(slot), v) => *slot = v.clone(),
        }
    }
    Ok(())
}

/// True when the dotted `path` is given in `table`.
fn given(table: &toml::Table, path: &str) -> bool {
    let mut t = table;
    let mut keys = path.split('.').peekable();
    while let Some(k) = keys.next() {
        match (t.get(k), keys.peek()) {
            (Some(_), None) => return true,
            (Some(toml::Value::Table(inner)), Some(_)) => t = inner,
            _ => return false,
        }
    }
    false
}

/// Removes the dotted `path` from `table` (and a table it leaves empty).
fn remove(table: &mut toml::Table, path: &str) {
    match path.split_once('.') {
        None => {
            table.remove(path);
        }
        Some((head, rest)) => {
            if let Some(toml::Value::Table(inner)) = table.get_mut(head) {
                remove(inner, rest);
                if inner.is_empty() {
                    table.remove(head);
                }
            }
        }
    }
}

impl ControllerSection {
    /// Reads a `[controller]` table over the default configuration.
    pub fn from_table(table: &toml::Table) -> Result<Self, ControllerKeyError> {
        let mut merged = default_table();
        overlay(&mut merged, table, "")?;
        let config: ControllerConfig = serde_path_to_error::deserialize(toml::Value::Table(merged))
            .map_err(|e| ControllerKeyError::Value {
                path: e.path().to_string(),
                message: e.inner().to_string(),
            })?;
        Ok(Self {
            config,
            camera_position_given: given(table, DERIVED_KEYS[0]),
            nav_latency_given: given(table, DERIVED_KEYS[1]),
            mass_given: given(table, DERIVED_KEYS[2]),
        })
    }

    /// The section as a table: every key of the configuration, but the derived ones only
    /// when the file gave them; numbers as their shortest decimals (they read back the same).
    pub fn to_table(&self) -> toml::Table {
        let mut t = table_of(&self.config);
        t.iter_mut().for_each(|(_, v)| tidy(v));
        for (key, given) in DERIVED_KEYS.into_iter().zip([
            self.camera_position_given,
            self.nav_latency_given,
            self.mass_given,
        ]) {
            if !given {
                remove(&mut t, key);
            }
        }
        t
    }
}

impl Serialize for ControllerSection {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.to_table().serialize(s)
    }
}

impl<'de> Deserialize<'de> for ControllerSection {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let table = toml::Table::deserialize(d)?;
        Self::from_table(&table).map_err(D::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ibvs_core::{OuterLaw, Procedure};

    fn parse(text: &str) -> Result<ControllerSection, ControllerKeyError> {
        ControllerSection::from_table(&text.parse::<toml::Table>().expect("TOML"))
    }

    #[test]
    fn an_empty_table_is_the_default_and_keys_override_it() {
        assert_eq!(parse(""), Ok(ControllerSection::default()));
        let s = parse(
            "law = \"pbvs\"\nprocedure = \"paper\"\n[ibvs]\nk1_mps = 3\nk3_per_s = 0.5\n\
             [refuelling]\nmax_attempts = 2\n",
        )
        .expect("valid");
        let d = ControllerConfig::default();
        assert_eq!(s.config.law, OuterLaw::Pbvs);
        assert_eq!(s.config.procedure, Procedure::Paper);
        assert_eq!(
            (
                s.config.ibvs.k1_mps,
                s.config.ibvs.k2_mps,
                s.config.ibvs.k3_per_s
            ),
            (3.0, d.ibvs.k2_mps, 0.5),
            "an integer is a float's value; untouched keys keep the default"
        );
        assert_eq!(s.config.refuelling.max_attempts, 2);
        assert_eq!(s.config.estimator, d.estimator);
        assert!(!s.camera_position_given && !s.nav_latency_given);
    }

    #[test]
    fn unknown_keys_and_wrong_types_name_their_path() {
        for (text, says) in [
            (
                "[ibvs]\nk9_mps = 1.0\n",
                "controller.ibvs.k9_mps is not a controller setting",
            ),
            (
                "gains = 1.0\n",
                "controller.gains is not a controller setting",
            ),
            (
                "[ibvs]\nk1_mps = \"fast\"\n",
                "controller.ibvs.k1_mps: invalid type",
            ),
            ("law = \"lqr\"\n", "controller.law: unknown variant `lqr`"),
            ("ibvs = 2.0\n", "controller.ibvs: expected a table"),
            (
                "[refuelling.station_depth_m]\nx = 1\n",
                "controller.refuelling.station_depth_m: expected a value",
            ),
            (
                "[camera]\nposition_body_m = [1.0, 2.0]\n",
                "controller.camera.position_body_m",
            ),
            (
                "[refuelling]\nmax_attempts = 300\n",
                "controller.refuelling.max_attempts",
            ),
        ] {
            let e = parse(text).expect_err(text).to_string();
            assert!(e.contains(says), "{text}: {e}");
        }
    }

    #[test]
    fn derived_keys_are_written_only_when_given_and_round_trip() {
        let plain = parse("[ibvs]\nk2_mps = 2.5\n").expect("valid");
        let t = plain.to_table();
        assert!(!given(&t, "nav_latency_steps") && !given(&t, "camera.position_body_m"));
        assert!(given(&t, "camera.pitch_down_rad") && given(&t, "estimator.gate_sigmas"));
        assert_eq!(ControllerSection::from_table(&t), Ok(plain));
        let stated = parse("nav_latency_steps = 3\n[camera]\nposition_body_m = [9.0, 0.0, 0.5]\n")
            .expect("valid");
        assert!(stated.nav_latency_given && stated.camera_position_given);
        assert_eq!(stated.config.nav_latency_steps, 3);
        assert_eq!(
            ControllerSection::from_table(&stated.to_table()),
            Ok(stated)
        );
    }
}
