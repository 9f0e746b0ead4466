//! The wire types' layout as the types themselves give it (their serde derives, traced by
//! `serde-reflection`), the same layout as `docs/interface.md`'s machine-readable tables give
//! it, and the conversions the interface tests compare through.
//!
//! The tables' grammar (also what `scripts/wire.py` reads): a section `### `Name` (kind)`
//! followed by a table. A struct's table has the columns field, type, unit, meaning, one row
//! per field in wire order; an enum's has index, variant, content, meaning. Types are written
//! `u8`, `u16`, `u32`, `u64`, `i8`, `i16`, `i32`, `i64`, `f32`, `f64`, `bool`, `()`,
//! `str<=N` (at most N bytes), `Option<T>`, `[T; N]`, `Vec<T, <=N>`, `(T, U)` or a
//! container's name; a variant's content is `-` (none), a type, or `{a: T, b: U}`.

use std::collections::{BTreeMap, BTreeSet};

use ibvs_core::ControllerConfig;
use ibvs_core::attitude::{Command, InnerLoop};
use ibvs_core::config::{ConfigProblem, OuterLaw};
use ibvs_core::measurement::MeasurementError;
use ibvs_core::mode::{BreakawayReason, Mode, ModeRequest, NoGoReason};
use ibvs_core::nav::NavError;
use ibvs_core::procedure::Procedure;
use ibvs_core::schedule::ScheduleError;
use ibvs_core::wire::{
    ClockSource, ConfigReport, ConfigStatus, ConfigStorage, CostUnit, Downlink, FieldPath,
    ResetCause, Telemetry, Uplink,
};
use serde_reflection::{
    ContainerFormat, Format, Named, Registry, Tracer, TracerConfig, Value, VariantFormat,
};

/// The bodies of the frames, in the order the document lists them.
pub const ROOTS: [&str; 5] = [
    "Uplink",
    "Downlink",
    "Telemetry",
    "ConfigReport",
    "ControllerConfig",
];

/// Every container the frames carry, traced from the types (every enum traced on its own, so
/// that all its variants are seen).
pub fn registry() -> Registry {
    let mut t = Tracer::new(TracerConfig::default());
    macro_rules! trace {
        ($($ty:ty),* $(,)?) => {$(
            t.trace_simple_type::<$ty>()
                .unwrap_or_else(|e| panic!("tracing {}: {e}", stringify!($ty)));
        )*};
    }
    trace!(
        Uplink,
        Downlink,
        Telemetry,
        ConfigReport,
        ControllerConfig,
        Mode,
        ModeRequest,
        BreakawayReason,
        NoGoReason,
        MeasurementError,
        NavError,
        ScheduleError,
        CostUnit,
        ConfigStatus,
        ConfigProblem,
        ConfigStorage,
        ResetCause,
        ClockSource,
        Procedure,
        OuterLaw,
        InnerLoop,
        Command,
    );
    t.registry().unwrap_or_else(|e| {
        panic!(
            "the wire types' layout: {e} (a new enum in a message: add it to the traced list in \
             host-sim/tests/interface/layout.rs)"
        )
    })
}

/// The stated capacity of every string on the wire, by where it is (`Container.field`, or
/// `Container.Variant.field`): a `heapless::String<N>` carries N at most, which the serde
/// derive does not say.
pub fn string_capacities() -> BTreeMap<String, usize> {
    BTreeMap::from([(
        "ConfigStatus.Rejected.field".to_string(),
        FieldPath::new().capacity(),
    )])
}

/// One row of a container's table: a struct's field (name, type) or an enum's variant
/// (index, name, content).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Row {
    /// The variant's index (enums only).
    pub index: Option<u32>,
    /// The field's or the variant's name.
    pub name: String,
    /// The field's type, or the variant's content (`-` for none).
    pub ty: String,
}

/// A container's table as the types give it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Container {
    /// Its name.
    pub name: String,
    /// `struct`, `enum`, `newtype`, `tuple struct` or `unit struct`.
    pub kind: &'static str,
    /// Its rows.
    pub rows: Vec<Row>,
}

/// The type string of `f` at `at` (for string capacities).
pub fn render(f: &Format, at: &str, caps: &BTreeMap<String, usize>) -> String {
    match f {
        Format::TypeName(n) => n.clone(),
        Format::Unit => "()".into(),
        Format::Bool => "bool".into(),
        Format::I8 => "i8".into(),
        Format::I16 => "i16".into(),
        Format::I32 => "i32".into(),
        Format::I64 => "i64".into(),
        Format::U8 => "u8".into(),
        Format::U16 => "u16".into(),
        Format::U32 => "u32".into(),
        Format::U64 => "u64".into(),
        Format::F32 => "f32".into(),
        Format::F64 => "f64".into(),
        Format::Str => match caps.get(at) {
            Some(n) => format!("str<={n}"),
            None => {
                panic!("a string at {at} without a stated capacity: add it to string_capacities()")
            }
        },
        Format::Option(t) => format!("Option<{}>", render(t, at, caps)),
        Format::TupleArray { content, size } => format!("[{}; {size}]", render(content, at, caps)),
        Format::Tuple(ts) => format!(
            "({})",
            ts.iter()
                .map(|t| render(t, at, caps))
                .collect::<Vec<_>>()
                .join(", ")
        ),
        other => panic!("{at}: {other:?} has no stated wire form in docs/interface.md"),
    }
}

fn content(v: &VariantFormat, at: &str, caps: &BTreeMap<String, usize>) -> String {
    match v {
        VariantFormat::Unit => "-".into(),
        VariantFormat::NewType(f) => render(f, at, caps),
        VariantFormat::Tuple(fs) => render(&Format::Tuple(fs.clone()), at, caps),
        VariantFormat::Struct(fields) => format!(
            "{{{}}}",
            fields
                .iter()
                .map(|n| format!(
                    "{}: {}",
                    n.name,
                    render(&n.value, &format!("{at}.{}", n.name), caps)
                ))
                .collect::<Vec<_>>()
                .join(", ")
        ),
        VariantFormat::Variable(_) => panic!("{at}: an untraced variant"),
    }
}

/// Every container reached from the roots, depth first in field order (a container listed
/// once, where first reached).
pub fn containers(reg: &Registry) -> Vec<Container> {
    let caps = string_capacities();
    let mut order = Vec::new();
    let mut seen = BTreeSet::new();
    for root in ROOTS {
        visit(reg, root, &mut seen, &mut order);
    }
    order
        .into_iter()
        .map(|name| {
            let (kind, rows) = match &reg[&name] {
                ContainerFormat::UnitStruct => ("unit struct", vec![]),
                ContainerFormat::NewTypeStruct(f) => (
                    "newtype",
                    vec![Row {
                        index: None,
                        name: "0".into(),
                        ty: render(f, &format!("{name}.0"), &caps),
                    }],
                ),
                ContainerFormat::TupleStruct(fs) => (
                    "tuple struct",
                    fs.iter()
                        .enumerate()
                        .map(|(i, f)| Row {
                            index: None,
                            name: i.to_string(),
                            ty: render(f, &format!("{name}.{i}"), &caps),
                        })
                        .collect(),
                ),
                ContainerFormat::Struct(fields) => (
                    "struct",
                    fields
                        .iter()
                        .map(|n| Row {
                            index: None,
                            name: n.name.clone(),
                            ty: render(&n.value, &format!("{name}.{}", n.name), &caps),
                        })
                        .collect(),
                ),
                ContainerFormat::Enum(variants) => (
                    "enum",
                    variants
                        .iter()
                        .map(|(i, n)| Row {
                            index: Some(*i),
                            name: n.name.clone(),
                            ty: content(&n.value, &format!("{name}.{}", n.name), &caps),
                        })
                        .collect(),
                ),
            };
            Container { name, kind, rows }
        })
        .collect()
}

fn names_in(f: &Format, out: &mut Vec<String>) {
    match f {
        Format::TypeName(n) => out.push(n.clone()),
        Format::Option(t) | Format::Seq(t) => names_in(t, out),
        Format::TupleArray { content, .. } => names_in(content, out),
        Format::Tuple(ts) => ts.iter().for_each(|t| names_in(t, out)),
        _ => {}
    }
}

fn visit(reg: &Registry, name: &str, seen: &mut BTreeSet<String>, order: &mut Vec<String>) {
    if !seen.insert(name.to_string()) {
        return;
    }
    order.push(name.to_string());
    let mut refs = Vec::new();
    match &reg[name] {
        ContainerFormat::UnitStruct => {}
        ContainerFormat::NewTypeStruct(f) => names_in(f, &mut refs),
        ContainerFormat::TupleStruct(fs) => fs.iter().for_each(|f| names_in(f, &mut refs)),
        ContainerFormat::Struct(fields) => {
            fields.iter().for_each(|n| names_in(&n.value, &mut refs))
        }
        ContainerFormat::Enum(variants) => {
            for n in variants.values() {
                match &n.value {
                    VariantFormat::NewType(f) => names_in(f, &mut refs),
                    VariantFormat::Tuple(fs) => fs.iter().for_each(|f| names_in(f, &mut refs)),
                    VariantFormat::Struct(fs) => {
                        fs.iter().for_each(|n| names_in(&n.value, &mut refs))
                    }
                    _ => {}
                }
            }
        }
    }
    for r in refs {
        visit(reg, &r, seen, order);
    }
}

/// Smallest and largest postcard encoding of `f`, bytes.
pub fn size(
    f: &Format,
    reg: &Registry,
    at: &str,
    caps: &BTreeMap<String, usize>,
) -> (usize, usize) {
    let varint = |bits: usize| (1, bits.div_ceil(7));
    match f {
        Format::Unit => (0, 0),
        Format::Bool | Format::U8 | Format::I8 => (1, 1),
        Format::U16 | Format::I16 => varint(16),
        Format::U32 | Format::I32 => varint(32),
        Format::U64 | Format::I64 => varint(64),
        Format::F32 => (4, 4),
        Format::F64 => (8, 8),
        Format::Str => {
            let cap = caps[at];
            (1, bytes_of_varint(cap) + cap)
        }
        Format::Option(t) => (1, 1 + size(t, reg, at, caps).1),
        Format::TupleArray { content, size: n } => {
            let (a, b) = size(content, reg, at, caps);
            (a * n, b * n)
        }
        Format::Tuple(ts) => sum(ts.iter().map(|t| size(t, reg, at, caps))),
        Format::TypeName(n) => container_size(n, reg, caps),
        other => panic!("{at}: no size for {other:?}"),
    }
}

fn bytes_of_varint(v: usize) -> usize {
    let mut n = 1;
    let mut v = v >> 7;
    while v > 0 {
        n += 1;
        v >>= 7;
    }
    n
}

fn sum(it: impl Iterator<Item = (usize, usize)>) -> (usize, usize) {
    it.fold((0, 0), |(a, b), (c, d)| (a + c, b + d))
}

fn fields_size(
    name: &str,
    fields: &[Named<Format>],
    reg: &Registry,
    caps: &BTreeMap<String, usize>,
) -> (usize, usize) {
    sum(fields
        .iter()
        .map(|n| size(&n.value, reg, &format!("{name}.{}", n.name), caps)))
}

/// Smallest and largest postcard encoding of the container `name`, bytes.
pub fn container_size(
    name: &str,
    reg: &Registry,
    caps: &BTreeMap<String, usize>,
) -> (usize, usize) {
    match &reg[name] {
        ContainerFormat::UnitStruct => (0, 0),
        ContainerFormat::NewTypeStruct(f) => size(f, reg, &format!("{name}.0"), caps),
        ContainerFormat::TupleStruct(fs) => sum(fs.iter().map(|f| size(f, reg, name, caps))),
        ContainerFormat::Struct(fields) => fields_size(name, fields, reg, caps),
        ContainerFormat::Enum(variants) => {
            let tag = bytes_of_varint(variants.len().saturating_sub(1));
            let sizes: Vec<(usize, usize)> = variants
                .values()
                .map(|n| {
                    let at = format!("{name}.{}", n.name);
                    match &n.value {
                        VariantFormat::Unit => (0, 0),
                        VariantFormat::NewType(f) => size(f, reg, &at, caps),
                        VariantFormat::Tuple(fs) => sum(fs.iter().map(|f| size(f, reg, &at, caps))),
                        VariantFormat::Struct(fs) => fields_size(&at, fs, reg, caps),
                        VariantFormat::Variable(_) => panic!("{at}: untraced"),
                    }
                })
                .collect();
            let min = sizes.iter().map(|s| s.0).min().unwrap_or(0);
            let max = sizes.iter().map(|s| s.1).max().unwrap_or(0);
            (1 + min, tag + max)
        }
    }
}

/// How a generated body fills its fields.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fill {
    /// Every field at its shortest encoding (zeros, `None`, the shortest variant, empty
    /// strings).
    Smallest,
    /// Every field at its longest (all ones, `Some`, the longest variant, full strings).
    Largest,
    /// Distinct values in every field, the variants and options chosen by the seed.
    Distinct(u64),
}

/// A generator of postcard bodies from the layout alone (the tests decode them with the
/// types: the layout is the types' if every body decodes whole and encodes back the same).
pub struct Generator<'a> {
    reg: &'a Registry,
    caps: BTreeMap<String, usize>,
    fill: Fill,
    leaf: u64,
    /// The body so far.
    pub out: Vec<u8>,
}

fn put_varint(out: &mut Vec<u8>, mut v: u64) {
    loop {
        let b = (v & 0x7F) as u8;
        v >>= 7;
        if v == 0 {
            out.push(b);
            return;
        }
        out.push(b | 0x80);
    }
}

impl<'a> Generator<'a> {
    /// A generator over `reg` filling as `fill` says.
    pub fn new(reg: &'a Registry, fill: Fill) -> Self {
        Self {
            reg,
            caps: string_capacities(),
            fill,
            leaf: 0,
            out: Vec::new(),
        }
    }

    /// A number for the next leaf: distinct from leaf to leaf, spread over every length of
    /// varint.
    fn next(&mut self) -> u64 {
        self.leaf += 1;
        let seed = match self.fill {
            Fill::Distinct(s) => s,
            _ => 0,
        };
        let x = (self.leaf + 1000 * seed).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        // Shift by the leaf's index so that small and large numbers alternate.
        x >> (self.leaf * 7 % 64)
    }

    fn choose(&mut self, n: usize) -> usize {
        match self.fill {
            Fill::Smallest | Fill::Largest => unreachable!("chosen by size"),
            Fill::Distinct(s) => ((self.leaf + s) as usize) % n,
        }
    }

    fn uint(&mut self, bits: u32) -> u64 {
        let max = if bits == 64 {
            u64::MAX
        } else {
            (1u64 << bits) - 1
        };
        match self.fill {
            Fill::Smallest => 0,
            Fill::Largest => max,
            Fill::Distinct(_) => self.next() & max,
        }
    }

    fn float_bits(&mut self) -> u32 {
        // Ordinary numbers, and now and then a special one (NaN with a payload, infinities,
        // negative zero, a subnormal) that must survive bit for bit.
        const SPECIAL: [u32; 6] = [
            0x7FC0_0001,
            0xFF80_0000,
            0x7F80_0000,
            0x8000_0000,
            0x0000_0001,
            0x7FA0_0000,
        ];
        match self.fill {
            Fill::Smallest => 0,
            Fill::Largest => 0xFFFF_FFFF,
            Fill::Distinct(_) => {
                let n = self.next();
                if self.leaf.is_multiple_of(11) {
                    SPECIAL[(self.leaf / 11) as usize % SPECIAL.len()]
                } else {
                    // A finite number of modest size with distinct low bits.
                    let v = ((n % 200_000) as f32 - 100_000.0) / 977.0;
                    v.to_bits() ^ (self.leaf as u32 & 0x7)
                }
            }
        }
    }

    /// Appends a value of `f` at `at`.
    pub fn value(&mut self, f: &Format, at: &str) {
        match f {
            Format::Unit => {}
            Format::Bool => {
                let v = match self.fill {
                    Fill::Smallest => 0,
                    Fill::Largest => 1,
                    Fill::Distinct(_) => (self.next() & 1) as u8,
                };
                self.out.push(v);
            }
            Format::U8 | Format::I8 => {
                let v = self.uint(8) as u8;
                self.out.push(v);
            }
            // A signed integer's zigzag is any unsigned value of its width: the varint of one.
            Format::U16 | Format::I16 | Format::U32 | Format::I32 | Format::U64 | Format::I64 => {
                let bits = match f {
                    Format::U16 | Format::I16 => 16,
                    Format::U32 | Format::I32 => 32,
                    _ => 64,
                };
                let v = self.uint(bits);
                put_varint(&mut self.out, v);
            }
            Format::F32 => {
                let b = self.float_bits();
                self.out.extend_from_slice(&b.to_le_bytes());
            }
            Format::F64 => {
                let b = (u64::from(self.float_bits()) << 32) | u64::from(self.float_bits());
                self.out.extend_from_slice(&b.to_le_bytes());
            }
            Format::Str => {
                let cap = self.caps[at];
                let len = match self.fill {
                    Fill::Smallest => 0,
                    Fill::Largest => cap,
                    Fill::Distinct(_) => (self.next() as usize) % (cap + 1),
                };
                put_varint(&mut self.out, len as u64);
                let text: Vec<u8> = (0..len)
                    .map(|i| b'a' + ((i + self.leaf as usize) % 26) as u8)
                    .collect();
                self.out.extend_from_slice(&text);
            }
            Format::Option(t) => {
                let some = match self.fill {
                    Fill::Smallest => false,
                    Fill::Largest => true,
                    Fill::Distinct(_) => !self.next().is_multiple_of(3),
                };
                self.out.push(u8::from(some));
                if some {
                    self.value(t, at);
                }
            }
            Format::TupleArray { content, size } => {
                for _ in 0..*size {
                    self.value(content, at);
                }
            }
            Format::Tuple(ts) => ts.iter().for_each(|t| self.value(t, at)),
            Format::TypeName(n) => self.container(&n.clone()),
            other => panic!("{at}: cannot generate {other:?}"),
        }
    }

    /// Appends a value of the container `name`.
    pub fn container(&mut self, name: &str) {
        let reg = self.reg;
        match &reg[name] {
            ContainerFormat::UnitStruct => {}
            ContainerFormat::NewTypeStruct(f) => self.value(f, &format!("{name}.0")),
            ContainerFormat::TupleStruct(fs) => fs.iter().for_each(|f| self.value(f, name)),
            ContainerFormat::Struct(fields) => {
                for n in fields {
                    self.value(&n.value, &format!("{name}.{}", n.name));
                }
            }
            ContainerFormat::Enum(variants) => {
                let caps = self.caps.clone();
                let sizes: Vec<(u32, usize, usize)> = variants
                    .iter()
                    .map(|(i, n)| {
                        let at = format!("{name}.{}", n.name);
                        let (a, b) = match &n.value {
                            VariantFormat::Unit => (0, 0),
                            VariantFormat::NewType(f) => size(f, reg, &at, &caps),
                            VariantFormat::Tuple(fs) => {
                                sum(fs.iter().map(|f| size(f, reg, &at, &caps)))
                            }
                            VariantFormat::Struct(fs) => fields_size(&at, fs, reg, &caps),
                            VariantFormat::Variable(_) => (0, 0),
                        };
                        (*i, a, b)
                    })
                    .collect();
                let index = match self.fill {
                    // The first of the shortest, the last of the longest (the longest tag).
                    Fill::Smallest => sizes.iter().min_by_key(|s| (s.1, s.0)).map_or(0, |s| s.0),
                    Fill::Largest => sizes.iter().max_by_key(|s| (s.2, s.0)).map_or(0, |s| s.0),
                    Fill::Distinct(_) => {
                        let k = self.choose(variants.len());
                        *variants.keys().nth(k).unwrap_or(&0)
                    }
                };
                put_varint(&mut self.out, u64::from(index));
                let n = &variants[&index];
                let at = format!("{name}.{}", n.name);
                match &n.value {
                    VariantFormat::Unit => {}
                    VariantFormat::NewType(f) => self.value(f, &at),
                    VariantFormat::Tuple(fs) => fs.iter().for_each(|f| self.value(f, &at)),
                    VariantFormat::Struct(fs) => {
                        for f in fs {
                            self.value(&f.value, &format!("{at}.{}", f.name));
                        }
                    }
                    VariantFormat::Variable(_) => {}
                }
            }
        }
    }
}

/// The canonical JSON form of a value the tests compare (`scripts/wire.py` prints the same):
/// a struct is an object of its fields, a newtype its content, a tuple or an array a list,
/// an option `null` or its content, a variant without content its name and one with content
/// `{name: content}`, an `f32` its bits as `"0x%08x"` (NaN payloads and signs kept), an
/// integer a number, a string a string.
pub fn canonical(f: &Format, v: &Value, reg: &Registry) -> serde_json::Value {
    use serde_json::Value as J;
    match (f, v) {
        (Format::TypeName(n), v) => match (&reg[n], v) {
            (ContainerFormat::UnitStruct, _) => J::Null,
            (ContainerFormat::NewTypeStruct(f), v) => canonical(f, v, reg),
            (ContainerFormat::TupleStruct(fs), Value::Seq(vs)) => list(fs, vs, reg),
            (ContainerFormat::Struct(fields), Value::Seq(vs)) => object(fields, vs, reg),
            (ContainerFormat::Enum(variants), Value::Variant(i, inner)) => {
                let n = &variants[i];
                let content = match (&n.value, inner.as_ref()) {
                    (VariantFormat::Unit, _) => return J::String(n.name.clone()),
                    (VariantFormat::NewType(f), v) => canonical(f, v, reg),
                    (VariantFormat::Tuple(fs), Value::Seq(vs)) => list(fs, vs, reg),
                    (VariantFormat::Struct(fs), Value::Seq(vs)) => object(fs, vs, reg),
                    other => panic!("{n:?}: {other:?}"),
                };
                J::Object([(n.name.clone(), content)].into_iter().collect())
            }
            other => panic!("{n}: {other:?}"),
        },
        (Format::Option(_), Value::Option(None)) => J::Null,
        (Format::Option(t), Value::Option(Some(v))) => canonical(t, v, reg),
        (Format::TupleArray { content, .. }, Value::Seq(vs)) => {
            J::Array(vs.iter().map(|v| canonical(content, v, reg)).collect())
        }
        (Format::Tuple(fs), Value::Seq(vs)) => list(fs, vs, reg),
        (_, Value::Unit) => J::Null,
        (_, Value::Bool(b)) => J::Bool(*b),
        (_, Value::U8(x)) => J::from(*x),
        (_, Value::U16(x)) => J::from(*x),
        (_, Value::U32(x)) => J::from(*x),
        (_, Value::U64(x)) => J::from(*x),
        (_, Value::I8(x)) => J::from(*x),
        (_, Value::I16(x)) => J::from(*x),
        (_, Value::I32(x)) => J::from(*x),
        (_, Value::I64(x)) => J::from(*x),
        (_, Value::F32(x)) => J::String(format!("0x{:08x}", x.to_bits())),
        (_, Value::F64(x)) => J::String(format!("0x{:016x}", x.to_bits())),
        (_, Value::Str(s)) => J::String(s.clone()),
        other => panic!("no canonical form for {other:?}"),
    }
}

/// Values of the formats `fs`, as a list.
fn list(fs: &[Format], vs: &[Value], reg: &Registry) -> serde_json::Value {
    serde_json::Value::Array(
        fs.iter()
            .zip(vs)
            .map(|(f, v)| canonical(f, v, reg))
            .collect(),
    )
}

/// Values of the fields `fs`, as an object.
fn object(fs: &[Named<Format>], vs: &[Value], reg: &Registry) -> serde_json::Value {
    serde_json::Value::Object(
        fs.iter()
            .zip(vs)
            .map(|(n, v)| (n.name.clone(), canonical(&n.value, v, reg)))
            .collect(),
    )
}

/// The canonical JSON form of `value`, a `root`.
pub fn canonical_of<T: serde::Serialize>(
    root: &str,
    value: &T,
    reg: &Registry,
) -> serde_json::Value {
    let mut t = Tracer::new(TracerConfig::default());
    let mut samples = serde_reflection::Samples::new();
    let (_, v) = t
        .trace_value(&mut samples, value)
        .expect("a traceable value");
    canonical(&Format::TypeName(root.into()), &v, reg)
}
