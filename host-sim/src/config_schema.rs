//! The controller configuration's schema: every setting of [`ControllerConfig`] with its
//! unit, default and the rules it must satisfy (`host-sim config schema`).
//!
//! Place in the data flow: beside it. What a user may put in a scenario's `[controller]`
//! table, or send to the flight computer in a configuration frame, is exactly
//! [`ControllerConfig`]; this module reads its keys and defaults from the struct itself
//! (through its serde form, [`crate::scenario::controller::table_of`]) and its rules from the
//! core's own rule list ([`ibvs_core::config::RULES`], the same list
//! [`ControllerConfig::validate`] checks), so nothing here is a second copy that could drift.
//! Units come from the project's naming convention (`_m`, `_mps`, `_rad`, `_s`, ...: the unit
//! is the name's suffix), with a stated list for the dimensionless settings.
//!
//! Invariants (tested): every setting has a unit; every real-valued setting has at least one
//! rule (counts may take any value of their type); every rule names a setting, and breaking
//! that setting alone is reported under the rule's name.

use ibvs_core::ControllerConfig;
use ibvs_core::config::{DAY_S, HOUR_S, RULES, largest_schedule_trim_angle_rad};
use serde::Serialize;

use crate::scenario::controller::{DERIVED_KEYS, table_of};

/// One setting.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Setting {
    /// Dotted path (the key under a scenario's `[controller]`, and the path a rejected
    /// configuration names).
    pub key: String,
    /// The unit ("1" for a dimensionless number, with what it is).
    pub unit: &'static str,
    /// Its default (the refuelling procedure's), as TOML text.
    pub default: String,
    /// Its default in the paper's configuration (`ControllerConfig::paper()`), where it
    /// differs.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub paper_default: Option<String>,
    /// What it must satisfy (the core's rules naming it), in the order they are checked.
    pub rules: Vec<&'static str>,
    /// In a scenario file: what decides it unless `[controller]` gives it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scenario_default: Option<&'static str>,
}

/// A name used in the rules, and its value.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Constant {
    /// As the rules write it.
    pub name: &'static str,
    /// What it is, with its value.
    pub value: String,
}

/// The whole schema.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Schema {
    /// Every setting, in key order.
    pub settings: Vec<Setting>,
    /// The constants and helper conditions the rules use.
    pub constants: Vec<Constant>,
}

/// The settings whose name carries no unit suffix: dimensionless, or a choice.
const UNITLESS: [(&str, &str); 19] = [
    ("procedure", "choice: \"refuelling\" | \"paper\""),
    (
        "mass_factor",
        "1 (the gross mass over the design airframe's 9,295 kg)",
    ),
    ("law", "choice: \"ibvs\" | \"pbvs\""),
    ("inner_loop", "choice: \"surfaces\" | \"attitude\""),
    ("attitude.damping", "1 (damping ratio)"),
    ("estimator.drogue_swing_damping_ratio", "1 (damping ratio)"),
    (
        "estimator.drogue_swing_period_exponent",
        "1 (power of the dynamic pressure's ratio)",
    ),
    ("ibvs.convergence_point", "1 (normalised image x, y)"),
    (
        "measurement.half_fov_x",
        "1 (normalised image, tan of the half angle)",
    ),
    (
        "measurement.half_fov_y",
        "1 (normalised image, tan of the half angle)",
    ),
    ("measurement.frozen_frame_limit", "frames"),
    ("modes.breakaway_throttle_cut", "1 (throttle fraction)"),
    (
        "modes.drogue_rate_filter",
        "1 (first-order filter coefficient per step)",
    ),
    (
        "actuators.min",
        "[rad, 1, rad, rad] (elevator, throttle fraction, aileron, rudder)",
    ),
    (
        "actuators.max",
        "[rad, 1, rad, rad] (elevator, throttle fraction, aileron, rudder)",
    ),
    ("refuelling.feedforward_gain", "1"),
    ("refuelling.max_attempts", "approaches"),
    ("estimator.max_rejections", "frames"),
    (
        "estimator.tip_sight_filter",
        "1 (first-order filter coefficient per step)",
    ),
];

/// Unit suffixes, longest first (`_mps2` before `_mps`, `_per_m2` before `_m2`, `_per_s2`
/// before `_per_s`).
const SUFFIXES: [(&str, &str); 14] = [
    ("_m2ps3", "m^2/s^3"),
    ("_mps2", "m/s^2"),
    ("_per_m2", "1/m^2"),
    ("_per_m", "1/m"),
    ("_per_s2", "1/s^2"),
    ("_per_s", "1/s"),
    ("_radps", "rad/s"),
    ("_steps", "control periods (20 ms)"),
    ("_sigmas", "standard deviations"),
    ("_tolerance", "1 (normalised image)"),
    ("_mps", "m/s"),
    ("_rad", "rad"),
    ("_m", "m"),
    ("_s", "s"),
];

/// The unit of a setting, from its name (`None`: not stated: a new setting without a unit
/// suffix must be added to the stated list).
pub fn unit_of(key: &str) -> Option<&'static str> {
    if let Some((_, u)) = UNITLESS.iter().find(|(k, _)| *k == key) {
        return Some(u);
    }
    let name = key.rsplit('.').next().unwrap_or(key);
    SUFFIXES
        .iter()
        .find(|(suffix, _)| name.ends_with(suffix))
        .map(|(_, u)| *u)
}

/// Every leaf of a table: (dotted path, value).
fn leaves(t: &toml::Table, prefix: &str, out: &mut Vec<(String, toml::Value)>) {
    for (k, v) in t {
        let path = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        match v {
            toml::Value::Table(inner) => leaves(inner, &path, out),
            v => out.push((path, v.clone())),
        }
    }
}

/// The leaves of a configuration, in key order.
pub fn settings_of(config: &ControllerConfig) -> Vec<(String, toml::Value)> {
    let mut out = Vec::new();
    leaves(&table_of(config), "", &mut out);
    out.sort_by(|a, b| a.0.cmp(&b.0));
    out
}

/// What a scenario file decides for the derived keys.
fn scenario_default(key: &str) -> Option<&'static str> {
    match key {
        k if k == DERIVED_KEYS[0] => Some("[camera] placement less camera.mount_error_m"),
        k if k == DERIVED_KEYS[1] => Some(
            "[navigation]: the INS's ins.latency_steps; with [dispersion] nav_latency_steps, \
                 that range's upper end; 0 with model = \"ideal\"",
        ),
        k if k == DERIVED_KEYS[2] => Some(
            "[receiver] mass_scale times 1 + [gross_mass] report_error (the mass the \
             receiver's systems report)",
        ),
        _ => None,
    }
}

/// The schema.
pub fn schema() -> Schema {
    let paper: std::collections::BTreeMap<_, _> = settings_of(&ControllerConfig::paper())
        .into_iter()
        .collect();
    let settings = settings_of(&ControllerConfig::default())
        .into_iter()
        .map(|(key, value)| {
            let paper_default = paper
                .get(&key)
                .filter(|p| **p != value)
                .map(crate::scenario::controller::text_of);
            Setting {
                unit: unit_of(&key).unwrap_or("(not stated)"),
                default: crate::scenario::controller::text_of(&value),
                paper_default,
                rules: RULES
                    .iter()
                    .filter(|r| r.field == key)
                    .map(|r| r.requirement)
                    .collect(),
                scenario_default: scenario_default(&key),
                key,
            }
        })
        .collect();
    let constants = vec![
        Constant {
            name: "HOUR_S",
            value: format!("{HOUR_S} s"),
        },
        Constant {
            name: "DAY_S",
            value: format!("{DAY_S} s"),
        },
        Constant {
            name: "SIN_COS_MAX_RAD",
            value: format!(
                "{} rad: the range of the step's sine and cosine",
                ibvs_core::num::SIN_COS_MAX_RAD
            ),
        },
        Constant {
            name: "MAX_NAV_LATENCY_STEPS",
            value: format!(
                "{} control periods: the latency predictor's longest",
                ibvs_core::predictor::MAX_NAV_LATENCY_STEPS
            ),
        },
        Constant {
            name: "gains::CONTROL_PERIOD_S",
            value: format!("{} s", ibvs_core::gains::CONTROL_PERIOD_S),
        },
        Constant {
            name: "largest_schedule_trim_angle_rad()",
            value: format!(
                "{} rad: the largest trim pitch or angle of attack over the gain schedule",
                largest_schedule_trim_angle_rad()
            ),
        },
        Constant {
            name: "in_view(point, measurement)",
            value: "the point is finite and inside the half field of view on both axes".into(),
        },
        Constant {
            name: "ordered(actuators)",
            value: "every channel's min and max are finite, min < max".into(),
        },
        Constant {
            name: "holds_trim(actuators)",
            value: "every channel's trim command lies inside its limits".into(),
        },
    ];
    Schema {
        settings,
        constants,
    }
}

/// The schema as text: one block per setting, then the constants.
pub fn to_text(s: &Schema) -> String {
    let mut out = String::from(
        "# The controller's settings (a scenario's [controller] table; a configuration frame).\n\
         # key = default  # unit; the paper's default where it differs\n\
         #     the rules it must satisfy, checked in order\n\n",
    );
    for x in &s.settings {
        out += &format!("{} = {}  # {}", x.key, x.default, x.unit);
        if let Some(p) = &x.paper_default {
            out += &format!("; paper: {p}");
        }
        out.push('\n');
        if let Some(d) = x.scenario_default {
            out += &format!("    in a scenario, unless given: {d}\n");
        }
        for r in &x.rules {
            out += &format!("    requires {r}\n");
        }
        if x.rules.is_empty() {
            out += "    any value of its type\n";
        }
    }
    out += "\n# Names in the rules\n";
    for c in &s.constants {
        out += &format!("{} = {}\n", c.name, c.value);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::controller::ControllerSection;

    #[test]
    fn every_setting_has_a_unit_and_every_number_a_rule() {
        let s = schema();
        assert!(s.settings.len() > 90, "{}", s.settings.len());
        for x in &s.settings {
            assert!(unit_of(&x.key).is_some(), "{}: no unit", x.key);
            // Floats (TOML writes them with a point) must be checked, if only for NaN;
            // a count may be any value of its type (0 included: "more than 0").
            let float = !x.default.starts_with('"') && x.default.contains('.');
            if float {
                assert!(!x.rules.is_empty(), "{}: no rule", x.key);
            }
        }
        // The stated unitless list names real settings only.
        for (k, _) in UNITLESS {
            assert!(s.settings.iter().any(|x| x.key == k), "{k}");
        }
        let k1 = s.settings.iter().find(|x| x.key == "ibvs.k1_mps");
        assert_eq!(
            k1.map(|x| (x.unit, x.default.as_str(), x.rules.clone())),
            Some(("m/s", "1.0", vec!["finite, > 0"]))
        );
        let proc = s.settings.iter().find(|x| x.key == "procedure");
        assert_eq!(
            proc.and_then(|x| x.paper_default.clone()),
            Some("\"paper\"".into())
        );
    }

    /// The configuration with the setting at dotted `path` set to `value` (through the
    /// table a scenario file writes), everything else default; its validation.
    fn with_setting(path: &str, value: toml::Value) -> Result<(), ibvs_core::ConfigError> {
        let mut table = toml::Table::new();
        let mut keys: Vec<&str> = path.split('.').collect();
        let last = keys.pop().expect("a name");
        let mut t = &mut table;
        for k in keys {
            t = t
                .entry(k)
                .or_insert_with(|| toml::Value::Table(toml::Table::new()))
                .as_table_mut()
                .expect("a table");
        }
        t.insert(last.into(), value);
        ControllerSection::from_table(&table)
            .expect("a number where a number goes")
            .config
            .validate()
    }

    /// The boundaries of the number-shaped rules: "> 0" refuses 0 and takes the least
    /// positive number tried, ">= 0" takes 0 and refuses the least negative tried, each under
    /// its own rule's name.
    #[test]
    fn positive_and_non_negative_rules_hold_at_their_boundary() {
        let breaks = |path: &str, v: f64, requirement: &str| {
            matches!(with_setting(path, toml::Value::Float(v)),
                     Err(e) if e.field == path && e.requirement == requirement)
        };
        let (mut positive, mut non_negative) = (0, 0);
        for rule in RULES {
            match rule.requirement {
                "finite, > 0" => {
                    assert!(
                        breaks(rule.field, 0.0, rule.requirement),
                        "{}: 0 refused",
                        rule.field
                    );
                    assert!(
                        !breaks(rule.field, 1e-6, rule.requirement),
                        "{}: 1e-6 taken",
                        rule.field
                    );
                    positive += 1;
                }
                "finite, >= 0" => {
                    assert!(
                        !breaks(rule.field, 0.0, rule.requirement),
                        "{}: 0 taken",
                        rule.field
                    );
                    assert!(
                        breaks(rule.field, -1e-6, rule.requirement),
                        "{}: -1e-6 refused",
                        rule.field
                    );
                    non_negative += 1;
                }
                _ => {}
            }
        }
        assert!(
            positive > 60 && non_negative > 15,
            "{positive} and {non_negative}"
        );
    }

    /// Every cross-field and range rule (a condition, not a sign): a configuration breaking
    /// it alone (written here, not derived from the rule) is refused under that rule, and
    /// every such rule of the core has its case here.
    #[test]
    fn every_condition_rule_refuses_the_configuration_that_breaks_it() {
        let cases: [(&str, &str); 60] = [
            (
                "ibvs.max_cartesian_gain_per_s",
                "[ibvs]\nmax_cartesian_gain_per_s = 0.0",
            ),
            (
                "velocity_limits.min_closing_mps",
                "[velocity_limits]\nmin_closing_mps = 2.5",
            ),
            ("camera.pitch_down_rad", "[camera]\npitch_down_rad = 10.0"),
            (
                "measurement.max_depth_m",
                "[measurement]\nmax_depth_m = 2000.0",
            ),
            (
                "ibvs.convergence_point",
                "[ibvs]\nconvergence_point = [0.9, 0.0]",
            ),
            (
                "nav_envelope.max_angle_rad",
                "[nav_envelope]\nmax_angle_rad = 3.0",
            ),
            (
                "nav_envelope.max_bank_rad",
                "[nav_envelope]\nmax_bank_rad = 10.0",
            ),
            (
                "nav_envelope.max_sideslip_rad",
                "[nav_envelope]\nmax_sideslip_rad = 10.0",
            ),
            (
                "modes.terminal_timeout_s",
                "[modes]\nterminal_timeout_s = 4000.0",
            ),
            (
                "modes.breakaway_down_mps",
                "[modes]\nbreakaway_down_mps = 3.0",
            ),
            (
                "modes.drogue_rate_filter",
                "[modes]\ndrogue_rate_filter = 1.5",
            ),
            ("modes.overspeed_mps", "[modes]\noverspeed_mps = 1.5"),
            (
                "modes.breakaway_aft_mps",
                "[modes]\nbreakaway_aft_mps = 2.5",
            ),
            ("actuators.min", "[actuators]\nmin = [0.5, 0.0, -0.3, -0.5]"),
            (
                "actuators.max",
                "[actuators]\nmax = [0.43, 0.001, 0.37, 0.52]",
            ),
            (
                "actuators.rate_radps",
                "[actuators]\nrate_radps = [1.0, 0.0, 2.0]",
            ),
            ("nav_latency_steps", "nav_latency_steps = 5"),
            (
                "estimator.tip_sight_filter",
                "[estimator]\ntip_sight_filter = 1.5",
            ),
            (
                "estimator.drogue_time_constant_s",
                "[estimator]\ndrogue_time_constant_s = 0.01",
            ),
            (
                "estimator.drogue_fwd_time_constant_s",
                "[estimator]\ndrogue_fwd_time_constant_s = 0.01",
            ),
            (
                "estimator.activity_time_constant_s",
                "[estimator]\nactivity_time_constant_s = 0.01",
            ),
            (
                "estimator.mean_time_constant_s",
                "[estimator]\nmean_time_constant_s = 0.01",
            ),
            (
                "estimator.nav_bias_time_constant_s",
                "[estimator]\nnav_bias_time_constant_s = 0.01",
            ),
            (
                "refuelling.station_clear_offset_m",
                "[refuelling]\nstation_clear_offset_m = 0.7",
            ),
            (
                "refuelling.capture_min_closing_mps",
                "[refuelling]\ncapture_min_closing_mps = 1.1",
            ),
            (
                "refuelling.feedforward_lead_s",
                "[refuelling]\nfeedforward_lead_s = 6.0",
            ),
            (
                "estimator.drogue_accel_time_constant_s",
                "[estimator]\ndrogue_accel_time_constant_s = 0.01",
            ),
            (
                "refuelling.feedforward_lead_s",
                "[refuelling]\nfeedforward_lead_s = 2.0",
            ),
            (
                "refuelling.gate_max_horizon_s",
                "[refuelling]\ngate_max_horizon_s = 2.0",
            ),
            (
                "refuelling.contact_speed_mps",
                "[refuelling]\ncontact_speed_mps = 2.5",
            ),
            (
                "refuelling.rough_air_contact_speed_mps",
                "[refuelling]\nrough_air_contact_speed_mps = 2.5",
            ),
            (
                "refuelling.missed_aft_mps",
                "[refuelling]\nmissed_aft_mps = 2.5",
            ),
            (
                "refuelling.missed_down_mps",
                "[refuelling]\nmissed_down_mps = 2.5",
            ),
            (
                "refuelling.forward_lag_s",
                "[refuelling]\nforward_lag_s = 11.0",
            ),
            (
                "refuelling.late_gate_final_radius_m",
                "[refuelling]\nlate_gate_final_radius_m = 0.6",
            ),
            (
                "estimator.drogue_swing_damping_ratio",
                "[estimator]\ndrogue_swing_damping_ratio = 1.0",
            ),
            (
                "estimator.drogue_swing_period_exponent",
                "[estimator]\ndrogue_swing_period_exponent = 1.5",
            ),
            (
                "refuelling.commit_depth_m",
                "[refuelling]\ncommit_depth_m = 3.7",
            ),
            (
                "refuelling.station_overrun_m",
                "[refuelling]\nstation_overrun_m = 2.5",
            ),
            (
                "refuelling.station_overrun_m",
                "[refuelling]\nstation_overrun_m = 0.2",
            ),
            (
                "refuelling.station_max_speed_mps",
                "[refuelling]\nstation_max_speed_mps = 1.0",
            ),
            ("refuelling.max_attempts", "[refuelling]\nmax_attempts = 0"),
            (
                "refuelling.feedforward_gain",
                "[refuelling]\nfeedforward_gain = 1.5",
            ),
            (
                "refuelling.station_dwell_s",
                "[refuelling]\nstation_dwell_s = 4000.0",
            ),
            (
                "refuelling.capture_timeout_s",
                "[refuelling]\ncapture_timeout_s = 4000.0",
            ),
            (
                "refuelling.missed_clear_s",
                "[refuelling]\nmissed_clear_s = 4000.0",
            ),
            (
                "refuelling.reacquire_limit_s",
                "[refuelling]\nreacquire_limit_s = 4000.0",
            ),
            (
                "refuelling.sortie_budget_s",
                "[refuelling]\nsortie_budget_s = 100000.0",
            ),
            (
                "estimator.bearing_bias_sigma_rad",
                "[estimator]\nbearing_bias_sigma_rad = [0.01, 0.3]",
            ),
            (
                "attitude.pitch_time_constant_s",
                "[attitude]\npitch_time_constant_s = 61.0",
            ),
            (
                "attitude.roll_time_constant_s",
                "[attitude]\nroll_time_constant_s = 61.0",
            ),
            (
                "attitude.flight_path_lag_s",
                "[attitude]\nflight_path_lag_s = 61.0",
            ),
            (
                "attitude.engine_time_constant_s",
                "[attitude]\nengine_time_constant_s = 0.01",
            ),
            (
                "attitude.vertical_bandwidth_radps",
                "[attitude]\nvertical_bandwidth_radps = 20.0",
            ),
            (
                "attitude.lateral_bandwidth_radps",
                "[attitude]\nlateral_bandwidth_radps = 20.0",
            ),
            (
                "attitude.forward_bandwidth_radps",
                "[attitude]\nforward_bandwidth_radps = 20.0",
            ),
            ("attitude.damping", "[attitude]\ndamping = 2.5"),
            // A mass in kilograms where the factor belongs.
            ("mass_factor", "mass_factor = 9295.0"),
            ("attitude.max_bank_rad", "[attitude]\nmax_bank_rad = 0.8"),
            (
                "attitude.max_pitch_offset_rad",
                "[attitude]\nmax_pitch_offset_rad = 0.4",
            ),
        ];
        let shaped = ["finite, > 0", "finite, >= 0", "finite (every element)"];
        let mut covered = std::collections::BTreeSet::new();
        for (field, text) in cases {
            let table: toml::Table = text.parse().expect("TOML");
            let cfg = ControllerSection::from_table(&table)
                .expect("settings")
                .config;
            let e = cfg.validate().expect_err(text);
            assert_eq!(e.field, field, "{text}: {e}");
            assert!(!shaped.contains(&e.requirement), "{text}: {e}");
            assert!(
                covered.insert((e.field, e.requirement)),
                "{text}: the same rule twice"
            );
        }
        let conditions: std::collections::BTreeSet<_> = RULES
            .iter()
            .filter(|r| !shaped.contains(&r.requirement))
            .map(|r| (r.field, r.requirement))
            .collect();
        assert_eq!(
            covered, conditions,
            "every condition rule has its case above"
        );
    }

    #[test]
    fn every_rule_names_a_setting_and_breaking_it_alone_is_reported_there() {
        let keys: Vec<String> = schema().settings.into_iter().map(|x| x.key).collect();
        for rule in RULES {
            assert!(keys.iter().any(|k| k == rule.field), "{rule:?}");
        }
        // Each number-shaped rule: its setting set to NaN (an array's first element) through
        // the same table a scenario file writes, everything else default.
        let nan = toml::Value::Float(f64::NAN);
        let shaped = ["finite, > 0", "finite, >= 0", "finite (every element)"];
        let mut checked = 0;
        for rule in RULES.iter().filter(|r| shaped.contains(&r.requirement)) {
            let mut table = toml::Table::new();
            let mut value = settings_of(&ControllerConfig::default())
                .into_iter()
                .find(|(k, _)| k == rule.field)
                .map(|(_, v)| v)
                .expect("a setting");
            match &mut value {
                toml::Value::Array(a) => a[0] = nan.clone(),
                v => *v = nan.clone(),
            }
            let mut path: Vec<&str> = rule.field.split('.').collect();
            let last = path.pop().expect("a name");
            let mut t = &mut table;
            for p in path {
                t = t
                    .entry(p)
                    .or_insert_with(|| toml::Value::Table(toml::Table::new()))
                    .as_table_mut()
                    .expect("a table");
            }
            t.insert(last.into(), value);
            let section = ControllerSection::from_table(&table).expect("a NaN is a number");
            let e = section.config.validate().expect_err(rule.field);
            assert_eq!(e.field, rule.field, "{rule:?}");
            checked += 1;
        }
        assert!(checked > 80, "{checked}");
    }

    #[test]
    fn the_text_lists_every_setting_with_its_rules() {
        let text = to_text(&schema());
        assert!(
            text.contains(
                "refuelling.late_gate_final_radius_m = 0.4  # m\n    requires finite, > 0\n    \
             requires refuelling.late_gate_final_radius_m <= refuelling.late_gate_radius_m\n"
            ),
            "{text}"
        );
        assert!(
            text.contains("nav_latency_steps = 1  # control periods (20 ms); paper: 0\n"),
            "{text}"
        );
        assert!(text.contains(
            "modes.hold_limit_steps = 25  # control periods (20 ms)\n    any value of its type\n"
        ));
        assert!(text.contains("HOUR_S = 3600 s\n"));
    }
}
