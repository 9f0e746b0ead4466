//! Reading a scenario file as a user's input: a bounded read, the line a key is on, the
//! `[controller]` table checked key by key before the whole file (so that an error points at
//! the key, not the table's header), the old forms of renamed keys recognised with a hint at
//! the current one, and long input never echoed whole.
//!
//! Invariants: no more than [`MAX_SCENARIO_BYTES`] (+1) bytes are read from any file; no line
//! of an error message is longer than [`MAX_ECHO_CHARS`] characters plus a note of what was
//! cut.

use std::io::Read;

use super::ScenarioError;
use super::controller::{ControllerKeyError, ControllerSection};
use crate::world::flight::FlightConditionError;

/// The largest scenario file read, bytes (the largest preset is under 2 KiB; a whole
/// `[controller]` table written out is under 8 KiB).
pub const MAX_SCENARIO_BYTES: u64 = 1 << 20;

/// The longest line of input an error message repeats, characters.
pub const MAX_ECHO_CHARS: usize = 200;

/// Reads the file at `path`, refusing one over [`MAX_SCENARIO_BYTES`] (a device such as
/// `/dev/zero` included) or not UTF-8, by name.
pub fn read_limited(path: &std::path::Path, name: &str) -> Result<String, ScenarioError> {
    let io = |source| ScenarioError::Io {
        path: name.into(),
        source,
    };
    let file = std::fs::File::open(path).map_err(io)?;
    let mut bytes = Vec::new();
    file.take(MAX_SCENARIO_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(io)?;
    if bytes.len() as u64 > MAX_SCENARIO_BYTES {
        return Err(ScenarioError::TooLarge {
            path: name.into(),
            limit: MAX_SCENARIO_BYTES,
        });
    }
    String::from_utf8(bytes).map_err(|e| ScenarioError::Parse {
        source_name: name.into(),
        message: format!(
            "not UTF-8 text (byte {} is not valid UTF-8): a scenario is a TOML file",
            e.utf8_error().valid_up_to()
        ),
    })
}

/// `text` with every line longer than [`MAX_ECHO_CHARS`] cut, and a note of how much was.
pub fn clip(text: &str) -> String {
    text.lines()
        .map(|l| match l.char_indices().nth(MAX_ECHO_CHARS) {
            Some((at, _)) => format!("{}... ({} more bytes not shown)", &l[..at], l.len() - at),
            None => l.to_string(),
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The 1-based line of `text` where the dotted `key` is given (`a.b.c`: `c = ...` under
/// `[a.b]`, or `b.c = ...` under `[a]`, or `a.b.c = ...` at the top), ignoring an index or a
/// note after the key (`key[0] (forward)`); `None` when it is not found.
pub fn line_of(text: &str, key: &str) -> Option<usize> {
    let key = key.split(['[', ' ']).next().unwrap_or(key);
    let mut table = String::new();
    for (n, line) in text.lines().enumerate() {
        let l = line.trim();
        if let Some(h) = l.strip_prefix('[') {
            table = h
                .trim_start_matches('[')
                .split(']')
                .next()
                .unwrap_or_default()
                .replace(' ', "");
            continue;
        }
        let Some((lhs, _)) = l.split_once('=') else {
            continue;
        };
        let lhs = lhs.trim().replace(['"', ' '], "");
        let full = if table.is_empty() {
            lhs
        } else {
            format!("{table}.{lhs}")
        };
        if full == key {
            return Some(n + 1);
        }
    }
    None
}

/// The key an error names, as the file writes it.
pub fn key_of(e: &ScenarioError) -> Option<String> {
    match e {
        ScenarioError::OutOfRange { key, .. } | ScenarioError::EmptyRange { key, .. } => {
            Some((*key).to_string())
        }
        ScenarioError::Controller(c) => Some(format!("controller.{}", c.field)),
        ScenarioError::Navigation(e) => Some(e.limit.key.to_string()),
        ScenarioError::Flight(
            FlightConditionError::NotPositive { key, .. }
            | FlightConditionError::AltitudeOutOfRange { key, .. }
            | FlightConditionError::MachAboveLimit { key, .. },
        ) => Some((*key).to_string()),
        _ => None,
    }
}

/// `e`, found in the file `name` whose text is `text`: with the file's name and the line of
/// the key it names.
pub fn in_file(e: ScenarioError, name: &str, text: &str) -> ScenarioError {
    match e {
        ScenarioError::Parse { .. } | ScenarioError::InFile { .. } => e,
        e => ScenarioError::InFile {
            name: name.into(),
            line: key_of(&e).and_then(|k| line_of(text, &k)),
            source: Box::new(e),
        },
    }
}

/// Checks what the whole file's parse would report badly: the old form of the controller's
/// choice (`controller = "ibvs"`), and the `[controller]` table key by key (an unknown key or
/// a value of the wrong type at its own line). Text that is not TOML is left to the parse.
pub fn precheck(text: &str, name: &str) -> Result<(), ScenarioError> {
    let Ok(doc) = text.parse::<toml::Table>() else {
        return Ok(());
    };
    match doc.get("controller") {
        Some(toml::Value::String(law)) => Err(ScenarioError::InFile {
            name: name.into(),
            line: line_of(text, "controller"),
            source: Box::new(ScenarioError::Renamed {
                old: format!("controller = {:?}", clip(law)),
                new: format!(
                    "a [controller] table: [controller] with law = {:?} (the outer loop of \
                     the paper's procedure; add procedure = \"paper\" to fly it, the \
                     refuelling procedure being the default)",
                    clip(law)
                ),
            }),
        }),
        Some(toml::Value::Table(t)) => match ControllerSection::from_table(t) {
            Ok(_) => Ok(()),
            Err(e) => {
                let path = match &e {
                    ControllerKeyError::Unknown { path }
                    | ControllerKeyError::Value { path, .. } => path.clone(),
                };
                Err(ScenarioError::InFile {
                    name: name.into(),
                    line: line_of(text, &format!("controller.{path}")),
                    source: Box::new(ScenarioError::ControllerKey(e)),
                })
            }
        },
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_key_is_found_on_its_line_in_every_form() {
        let text = "name = \"x\"\n[flight]\naltitude_m = 3000.0\n\n[controller.ibvs]\nk1_mps = 1\n\
                    [navigation]\nins.latency_steps = 5\n";
        assert_eq!(line_of(text, "name"), Some(1));
        assert_eq!(line_of(text, "flight.altitude_m"), Some(3));
        assert_eq!(line_of(text, "controller.ibvs.k1_mps"), Some(6));
        assert_eq!(line_of(text, "navigation.ins.latency_steps"), Some(8));
        assert_eq!(
            line_of(text, "initial.drogue_minus_probe_m[0] (forward)"),
            None
        );
        assert_eq!(
            line_of(
                "[initial]\ndrogue_minus_probe_m = [1, 2, 3]\n",
                "initial.drogue_minus_probe_m[0] (forward)"
            ),
            Some(2)
        );
    }

    #[test]
    fn long_lines_are_cut_with_a_note() {
        let long = "x".repeat(10_000);
        let c = clip(&format!("short\n{long}\n"));
        assert!(c.len() < 300, "{}", c.len());
        assert!(
            c.starts_with("short\nxxx") && c.ends_with("(9800 more bytes not shown)"),
            "{c}"
        );
    }
}
