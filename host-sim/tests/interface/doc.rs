//! `docs/interface.md`'s machine-readable parts: read, compared with the types, and
//! regenerated (`IBVS_BLESS=1`) with the hand-written columns kept.
//!
//! Regions (each between `<!-- NAME:begin -->` and `<!-- NAME:end -->`):
//! - `layout`: one section per container (see `layout.rs` for the grammar); its type columns
//!   are the types', its unit, meaning and description text hand-written (a new row gets
//!   `TODO`, which fails the test until it is written);
//! - `sizes`: the frame kinds with their bodies and sizes, generated whole;
//! - `history`: the protocol versions, hand-written; its last row must be the current
//!   version with the current layout's fingerprint.

use std::collections::BTreeMap;

use super::layout::{Container, Row};

/// One container's section as the document has it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DocContainer {
    /// The type columns, comparable with the types'.
    pub container: Container,
    /// The text between the heading and the table.
    pub description: String,
    /// Per row: (unit, meaning) for a struct, ("", meaning) for an enum.
    pub notes: Vec<(String, String)>,
}

/// The text between `<!-- name:begin -->` and `<!-- name:end -->`, and where it lies.
pub fn region<'a>(doc: &'a str, name: &str) -> (usize, usize, &'a str) {
    let begin = format!("<!-- {name}:begin -->\n");
    let end = format!("<!-- {name}:end -->");
    let a = doc
        .find(&begin)
        .unwrap_or_else(|| panic!("docs/interface.md has no {begin:?}"))
        + begin.len();
    let b = a + doc[a..]
        .find(&end)
        .unwrap_or_else(|| panic!("docs/interface.md has no {end:?}"));
    (a, b, &doc[a..b])
}

/// The cells of a table row (`| a | b |`) as written.
pub fn raw_cells(line: &str) -> Vec<String> {
    let inner = line.trim().trim_start_matches('|').trim_end_matches('|');
    inner.split(" | ").map(|c| c.trim().to_string()).collect()
}

/// The cells of a table row, backticks around a whole cell removed.
pub fn cells(line: &str) -> Vec<String> {
    raw_cells(line)
        .into_iter()
        .map(|c| {
            c.strip_prefix('`')
                .and_then(|c| c.strip_suffix('`'))
                .map_or(c.clone(), str::to_string)
        })
        .collect()
}

/// The table rows (header and separator skipped) of `lines` from the first table on.
fn table_rows<'a>(lines: &[&'a str]) -> Vec<&'a str> {
    lines
        .iter()
        .skip_while(|l| !l.starts_with('|'))
        .take_while(|l| l.starts_with('|'))
        .skip(2)
        .copied()
        .collect()
}

/// Every container section of the layout region.
pub fn parse_layout(text: &str) -> Vec<DocContainer> {
    let mut out = Vec::new();
    let lines: Vec<&str> = text.lines().collect();
    let starts: Vec<usize> = (0..lines.len())
        .filter(|&i| lines[i].starts_with("### "))
        .collect();
    for (k, &i) in starts.iter().enumerate() {
        let end = starts.get(k + 1).copied().unwrap_or(lines.len());
        let heading = lines[i].trim_start_matches("### ");
        let (name, kind) = heading
            .split_once(" (")
            .unwrap_or_else(|| panic!("heading {heading:?}: want ### `Name` (kind)"));
        let name = name.trim_matches('`').to_string();
        let kind = kind.trim_end_matches(')');
        let kind: &'static str = match kind {
            "struct" => "struct",
            "enum" => "enum",
            "newtype" => "newtype",
            "tuple struct" => "tuple struct",
            "unit struct" => "unit struct",
            other => panic!("{name}: unknown kind {other:?}"),
        };
        let body = &lines[i + 1..end];
        let description = body
            .iter()
            .take_while(|l| !l.starts_with('|'))
            .copied()
            .collect::<Vec<_>>()
            .join("\n")
            .trim()
            .to_string();
        let mut rows = Vec::new();
        let mut notes = Vec::new();
        for line in table_rows(body) {
            // The type columns compared without their backticks; the hand-written ones kept
            // as written.
            let (c, raw) = (cells(line), raw_cells(line));
            if kind == "enum" {
                assert_eq!(c.len(), 4, "{name}: {line}");
                rows.push(Row {
                    index: Some(
                        c[0].parse()
                            .unwrap_or_else(|_| panic!("{name}: index {line}")),
                    ),
                    name: c[1].clone(),
                    ty: c[2].clone(),
                });
                notes.push((String::new(), raw[3].clone()));
            } else {
                assert_eq!(c.len(), 4, "{name}: {line}");
                rows.push(Row {
                    index: None,
                    name: c[0].clone(),
                    ty: c[1].clone(),
                });
                notes.push((raw[2].clone(), raw[3].clone()));
            }
        }
        out.push(DocContainer {
            container: Container { name, kind, rows },
            description,
            notes,
        });
    }
    out
}

/// The unit of a field from its name's suffix (the project's convention), for a new row.
fn unit_guess(name: &str) -> &'static str {
    const SUFFIXES: [(&str, &str); 9] = [
        ("_mps2", "m/s^2"),
        ("_radps", "rad/s"),
        ("_mps", "m/s"),
        ("_rad", "rad"),
        ("_steps", "control periods"),
        ("_per_s", "1/s"),
        ("_m", "m"),
        ("_s", "s"),
        ("seq", "count"),
    ];
    SUFFIXES
        .iter()
        .find(|(s, _)| name.ends_with(s))
        .map_or("TODO", |(_, u)| u)
}

/// The layout region regenerated from `types`, with the document's descriptions, units and
/// meanings kept where the container and row still exist.
pub fn bless_layout(types: &[Container], old: &[DocContainer]) -> String {
    let by_name: BTreeMap<&str, &DocContainer> =
        old.iter().map(|d| (d.container.name.as_str(), d)).collect();
    let mut out = String::new();
    for c in types {
        let prev = by_name.get(c.name.as_str());
        out += &format!("### `{}` ({})\n\n", c.name, c.kind);
        let description = prev.map_or("TODO: what it is.", |d| d.description.as_str());
        if !description.is_empty() {
            out += description;
            out += "\n\n";
        }
        let note = |row: &Row| -> Option<(String, String)> {
            let d = prev?;
            let k = d.container.rows.iter().position(|r| r.name == row.name)?;
            Some(d.notes[k].clone())
        };
        if c.kind == "enum" {
            out += "| index | variant | content | meaning |\n|---|---|---|---|\n";
            for r in &c.rows {
                let (_, meaning) = note(r).unwrap_or_else(|| (String::new(), "TODO".into()));
                out += &format!(
                    "| {} | `{}` | {} | {} |\n",
                    r.index.unwrap_or_default(),
                    r.name,
                    if r.ty == "-" {
                        "-".into()
                    } else {
                        format!("`{}`", r.ty)
                    },
                    meaning
                );
            }
        } else {
            out += "| field | type | unit | meaning |\n|---|---|---|---|\n";
            for r in &c.rows {
                let (unit, meaning) =
                    note(r).unwrap_or_else(|| (unit_guess(&r.name).into(), "TODO".into()));
                out += &format!("| `{}` | `{}` | {} | {} |\n", r.name, r.ty, unit, meaning);
            }
        }
        out += "\n";
    }
    out
}

/// `doc` with region `name` replaced by `text`.
pub fn replace_region(doc: &str, name: &str, text: &str) -> String {
    let (a, b, _) = region(doc, name);
    format!("{}{}{}", &doc[..a], text, &doc[b..])
}
