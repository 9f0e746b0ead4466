//! The flight-test log: a recorded run ([`crate::record`]) as an MCAP file with typed
//! channels, for Foxglove, PlotJuggler and anything else that reads MCAP (`docs/logs.md`).
//!
//! Every message is JSON (`message_encoding` `json`) with a JSON Schema (`schema_encoding`
//! `jsonschema`), so the file opens without a plugin. One message per control step on every
//! channel, stamped with the simulation time of the step's start in nanoseconds (log time and
//! publish time alike; the run starts at 0). Channels (units and frames in the field names,
//! frames as in `docs/conventions.md`):
//!
//! | topic | what |
//! |---|---|
//! | `/truth/receiver` | receiver truth: CG in NED and tanker frame, body velocity, attitude, rates, engine, surfaces |
//! | `/truth/probe_tip` | probe tip, tanker frame; its velocity relative to the tanker; drogue minus tip |
//! | `/truth/drogue` | drogue centre and axis, tanker frame |
//! | `/truth/hose` | hose nodes from the exit to the drogue, tanker frame (fixed drogue: none) |
//! | `/camera/measurement` | the camera frame the flight computer was given (the probe tip's marker included), the aim and the image error from it |
//! | `/camera/image` | LED camera only: the frame's LED centroids, the fitted circle, the true drogue image point |
//! | `/nav/sample` | the navigation sample the flight computer was given |
//! | `/controller/input` | the rest of its input: probe contact, mode request |
//! | `/controller/output` | the whole `ibvs_core::ControllerOutput` (new fields appear by themselves) |
//! | `/link/uplink_frame` | PIL: the raw measurement frame (hex), decoded, the host's link counts |
//! | `/link/downlink_frame` | PIL: the raw command frame (hex), decoded: output, step cost, configuration id (the counters travel in telemetry frames, not per step) |
//!
//! Schemas are inferred from the messages themselves (every field any message of the channel
//! has, with the JSON type it takes), so a field added to a serialised type is in the schema
//! without an edit here. Fields whose value is none (an `Option`'s `None`, a NaN or an
//! infinity, which JSON cannot hold) are left out of the message rather than written as
//! `null`, and each field has one type: Foxglove's JSON Schema reader takes no nullable or
//! union types. [`controller_output`] reads an output message back (the gate's infinite
//! predicted miss restored). A metadata record `run` holds the scenario, seed, flight computer
//! and outcome.
//!
//! Invariants: the file is a pure function of the recording and the run (no wall-clock time,
//! no compression), so the same run gives the same bytes; every channel has exactly one
//! message per [`crate::sim::Sample`] (the link channels one per step with a frame: the
//! downlink one skips steps whose answer never came); writing never changes the run.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

use nalgebra::{Vector2, Vector3};
use serde::Serialize;
use serde_json::{Value, json};

use ibvs_core::controller::ControllerOutput;

use crate::linearize::design_coordinates;
use crate::output::OutputError;
use crate::record::{LinkRecord, Recording, StepRecord};
use crate::sim::{Run, Sample};

/// The MCAP profile field (none of the registered profiles applies).
const PROFILE: &str = "";

/// A 3-vector with named components (frame in the field's name).
#[derive(Debug, Clone, Copy, Serialize)]
struct Xyz {
    x: f64,
    y: f64,
    z: f64,
}

fn xyz(v: &Vector3<f64>) -> Xyz {
    Xyz {
        x: v.x,
        y: v.y,
        z: v.z,
    }
}

/// An image point, px (u right, v down, from the top-left corner).
#[derive(Debug, Clone, Copy, Serialize)]
struct Uv {
    u: f64,
    v: f64,
}

fn uv(p: &Vector2<f64>) -> Uv {
    Uv { u: p.x, v: p.y }
}

/// One channel: topic, schema name, description, and a message per step.
struct ChannelDef {
    topic: &'static str,
    schema: &'static str,
    description: &'static str,
    /// The message of one step, `None` to skip that step.
    message: fn(&Sample, &StepRecord, &Recording) -> Option<Value>,
}

fn to_value(v: impl Serialize) -> Option<Value> {
    serde_json::to_value(v).ok()
}

fn receiver(s: &Sample, r: &StepRecord, _: &Recording) -> Option<Value> {
    let x = &s.state;
    let [_, speed, alpha, _, _, _, _, beta, _, _] = design_coordinates(x);
    Some(json!({
        "time_s": s.time_s,
        "cg_ned_m": xyz(&x.pos_ned_m),
        "cg_tanker_m": xyz(&r.world.receiver_cg_tanker_m),
        "altitude_m": -x.pos_ned_m.z,
        "velocity_body_mps": xyz(&x.vel_body_mps),
        "speed_mps": speed,
        "alpha_rad": alpha,
        "beta_rad": beta,
        "euler_rad": { "roll": x.euler_rad.x, "pitch": x.euler_rad.y, "yaw": x.euler_rad.z },
        "rate_body_radps": { "p": x.rate_body_radps.x, "q": x.rate_body_radps.y, "r": x.rate_body_radps.z },
        "engine_power_pct": x.engine_power_pct,
        "surfaces_rad": x.surfaces_rad,
    }))
}

fn probe_tip(s: &Sample, _: &StepRecord, _: &Recording) -> Option<Value> {
    let d = &s.drogue_from_tip_m;
    Some(json!({
        "position_tanker_m": xyz(&s.tip_tanker_m),
        "velocity_tanker_mps": xyz(&s.tip_velocity_mps),
        "drogue_from_tip_m": xyz(d),
        "radial_offset_m": d.y.hypot(d.z),
    }))
}

fn drogue(s: &Sample, r: &StepRecord, _: &Recording) -> Option<Value> {
    Some(json!({
        "centre_tanker_m": xyz(&s.drogue_tanker_m),
        "axis_tanker": xyz(&r.world.drogue_axis_tanker),
    }))
}

fn hose(_: &Sample, r: &StepRecord, _: &Recording) -> Option<Value> {
    let nodes: Vec<Xyz> = r.world.hose_tanker_m.iter().map(xyz).collect();
    (!nodes.is_empty()).then(|| json!({ "node_count": nodes.len(), "nodes_tanker_m": nodes }))
}

fn measurement(s: &Sample, _: &StepRecord, rec: &Recording) -> Option<Value> {
    let m = &s.measurement;
    let [ax, ay] = rec.aim(f64::from(m.depth_m));
    Some(json!({
        "seq": m.seq,
        "tracked": m.tracked,
        "image_x": m.image_x,
        "image_y": m.image_y,
        "depth_m": m.depth_m,
        "probe_tip": m.probe_tip.map(|[x, y]| json!({ "x": x, "y": y })),
        "learned_probe_tip": s.probe_tip_image.map(|[x, y]| json!({ "x": x, "y": y })),
        "aim_x": ax,
        "aim_y": ay,
        "image_error_x": f64::from(m.image_x) - ax,
        "image_error_y": f64::from(m.image_y) - ay,
    }))
}

fn image(_: &Sample, r: &StepRecord, _: &Recording) -> Option<Value> {
    let led = r.world.led.as_ref()?;
    let centroids: Vec<Uv> = led
        .image
        .as_ref()
        .map_or_else(Vec::new, |i| i.centroids_px().iter().map(uv).collect());
    let circle = led
        .image
        .and_then(|i| i.circle)
        .map(|c| json!({ "centre_px": uv(&c.centre_px), "radius_px": c.radius_px }));
    let truth = led.truth.map(|t| {
        json!({
            "seq": t.seq,
            "capture_time_s": t.capture_time_s,
            "image_x": t.image_x,
            "image_y": t.image_y,
            "depth_m": t.depth_m,
        })
    });
    Some(json!({
        "visible_leds": centroids.len(),
        "centroids_px": centroids,
        "circle": circle,
        "truth": truth,
    }))
}

fn nav(_: &Sample, r: &StepRecord, _: &Recording) -> Option<Value> {
    to_value(r.input.nav)
}

fn input(_: &Sample, r: &StepRecord, _: &Recording) -> Option<Value> {
    Some(json!({
        "probe_contact": r.input.probe_contact,
        "autopilot_ready": r.input.autopilot_ready,
        "request": to_value(r.input.request)?,
    }))
}

fn output(s: &Sample, _: &StepRecord, _: &Recording) -> Option<Value> {
    to_value(s.output)
}

/// A `/controller/output` message read back into the [`ControllerOutput`] it was written
/// from. JSON has no infinity: serde writes an infinite float as `null`, which the log leaves
/// out, and the one field of the output that is infinite by design, `predicted_miss_m` (no
/// prediction), is restored as such when it is missing.
pub fn controller_output(message: &Value) -> serde_json::Result<ControllerOutput> {
    let missing = message.get("predicted_miss_m").is_none();
    let mut v = message.clone();
    if let (true, Some(obj)) = (missing, v.as_object_mut()) {
        // A placeholder JSON can hold, replaced below.
        obj.insert("predicted_miss_m".into(), json!(0.0));
    }
    let mut o: ControllerOutput = serde_json::from_value(v)?;
    if missing {
        o.predicted_miss_m = f32::INFINITY;
    }
    Ok(o)
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn uplink(_: &Sample, r: &StepRecord, _: &Recording) -> Option<Value> {
    let l: &LinkRecord = r.link.as_ref()?;
    Some(json!({
        "length_bytes": l.uplink_frame.len(),
        "frame_hex": hex(&l.uplink_frame),
        "seq": l.uplink.map(|u| u.seq),
        "decoded": to_value(l.uplink)?,
        "host": to_value(l.host)?,
    }))
}

fn downlink(_: &Sample, r: &StepRecord, _: &Recording) -> Option<Value> {
    let (frame, d) = r.link.as_ref()?.downlink.as_ref()?;
    let mut v = json!({
        "length_bytes": frame.len(),
        "frame_hex": hex(frame),
    });
    if let (Some(obj), Value::Object(decoded)) = (v.as_object_mut(), to_value(d)?) {
        obj.extend(decoded);
    }
    Some(v)
}

/// Every channel, in the order they are added to the file.
const CHANNELS: &[ChannelDef] = &[
    ChannelDef {
        topic: "/truth/receiver",
        schema: "ibvs.truth.Receiver",
        description: "Receiver truth at the step's start. cg_ned_m: NED (x north, y east, z down), m; \
             cg_tanker_m: tanker frame (x forward, y right, z down, origin at the hose exit), m; \
             velocity_body_mps: ground-relative, body axes; speed, alpha, beta from it (no wind), \
             as in run.csv; euler_rad: 3-2-1 roll, pitch, yaw; rate_body_radps: p, q, r; \
             surfaces_rad: actual surface positions.",
        message: receiver,
    },
    ChannelDef {
        topic: "/truth/probe_tip",
        schema: "ibvs.truth.ProbeTip",
        description: "Probe tip, tanker frame, m; its velocity relative to the tanker (finite \
             difference over the step), m/s; drogue centre minus tip, tanker axes, m; \
             radial_offset_m: sqrt(y^2 + z^2) of it.",
        message: probe_tip,
    },
    ChannelDef {
        topic: "/truth/drogue",
        schema: "ibvs.truth.Drogue",
        description: "Drogue centre, tanker frame, m; drogue axis (from the hose toward the \
             drogue), tanker frame, unit.",
        message: drogue,
    },
    ChannelDef {
        topic: "/truth/hose",
        schema: "ibvs.truth.Hose",
        description: "Hose nodes from the hose exit (node 0) to the drogue centre (last), \
             tanker frame, m; none when the drogue is held fixed.",
        message: hose,
    },
    ChannelDef {
        topic: "/camera/measurement",
        schema: "ibvs.camera.Measurement",
        description: "The camera frame the flight computer was given (after any injected fault): \
             normalised image point (x right, y down, dimensionless), depth along the boresight, m; \
             probe_tip: the probe tip's marker, normalised (a camera set back from the tip); \
             learned_probe_tip: the flight computer's running average of it, the calibration \
             it aims with (in-process every step, over the link its latest telemetry); \
             aim: where the controller steers the drogue's image (the paper's procedure: the \
             convergence point; the refuelling procedure: the drogue dead ahead of the probe \
             tip at the frame's depth); image_error = image point minus aim.",
        message: measurement,
    },
    ChannelDef {
        topic: "/camera/image",
        schema: "ibvs.camera.LedImage",
        description: "LED camera: the frame behind the measurement. centroids_px: measured LED \
             centroids, px (u right, v down, from the top-left corner); circle: the fit, px \
             (null when untracked); truth: the drogue centre as an ideal camera saw it at that \
             frame's capture (normalised, m).",
        message: image,
    },
    ChannelDef {
        topic: "/nav/sample",
        schema: "ibvs.core.NavSample",
        description: "The navigation sample the flight computer was given: perturbations from \
             the design trim (docs/conventions.md, Navigation), rad, m/s, rad/s, m.",
        message: nav,
    },
    ChannelDef {
        topic: "/controller/input",
        schema: "ibvs.core.InputDiscretes",
        description: "The rest of the flight computer's input: the probe-contact discrete, \
             the autopilot-ready discrete (the attitude-command loop's autopilot follows its \
             setpoints) and the operator's mode request.",
        message: input,
    },
    ChannelDef {
        topic: "/controller/output",
        schema: "ibvs.core.ControllerOutput",
        description: "The step's whole ibvs_core::ControllerOutput: saturated commands (rad, \
             throttle 0..1), mode, breakaway reason, status bits, rejections, desired camera \
             velocity (re axes: x right, y down, z forward, m/s), target estimate (m), step count; \
             refuelling: attempt, no-go reason, the drogue estimator's estimate (offset from the \
             probe tip right and down, tanker axes, m; drogue velocity, m/s; depth, m) and the \
             go/no-go gate's predicted miss, m (left out where it is infinite: no prediction \
             outside the contact approach and the capture).",
        message: output,
    },
    ChannelDef {
        topic: "/link/uplink_frame",
        schema: "ibvs.link.UplinkFrame",
        description: "PIL: the measurement frame sent for the step, COBS-encoded with its zero \
             (hex), decoded, and the host's link counts after the step.",
        message: uplink,
    },
    ChannelDef {
        topic: "/link/downlink_frame",
        schema: "ibvs.link.DownlinkFrame",
        description: "PIL: the command frame that answered the step, COBS-encoded with its zero \
             (hex), decoded: sequence numbers, link status bits, the step's output, its cost \
             (instructions under QEMU) and the configuration's id (the firmware's counters \
             travel in its telemetry frames, not per step).",
        message: downlink,
    },
];

/// What a written log holds.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct LogStats {
    /// File size, bytes.
    pub bytes: u64,
    /// Messages per topic (topics with none are not in the file).
    pub messages: BTreeMap<String, u64>,
}

impl LogStats {
    /// Messages over every channel.
    pub fn total_messages(&self) -> u64 {
        self.messages.values().sum()
    }
}

/// `v` with every null field of every object left out (an `Option`'s `None`, a NaN or an
/// infinity): the schemas then need no nullable types, which Foxglove's JSON Schema reader
/// does not take.
fn without_nulls(v: Value) -> Value {
    match v {
        Value::Object(fields) => Value::Object(
            fields
                .into_iter()
                .filter(|(_, x)| !x.is_null())
                .map(|(k, x)| (k, without_nulls(x)))
                .collect(),
        ),
        Value::Array(items) => Value::Array(items.into_iter().map(without_nulls).collect()),
        other => other,
    }
}

/// Simulation time in nanoseconds (the log's clock).
pub fn log_time_ns(time_s: f64) -> u64 {
    (time_s * 1e9).round().max(0.0) as u64
}

/// Writes `run`, recorded as `rec`, to `path` as MCAP.
pub fn write_mcap(path: &Path, run: &Run, rec: &Recording) -> Result<LogStats, OutputError> {
    let io = |source| OutputError::Io {
        path: path.display().to_string(),
        source,
    };
    if rec.steps.len() != run.samples.len() {
        return Err(OutputError::Mismatch {
            what: "recording and run",
            left: rec.steps.len(),
            right: run.samples.len(),
        });
    }
    // Every message first: the schemas are inferred from them.
    let messages: Vec<Vec<Option<Value>>> = CHANNELS
        .iter()
        .map(|c| {
            run.samples
                .iter()
                .zip(&rec.steps)
                .map(|(s, r)| (c.message)(s, r, rec).map(without_nulls))
                .collect()
        })
        .collect();

    let file = File::create(path).map_err(io)?;
    let mut w = mcap::WriteOptions::new()
        .profile(PROFILE)
        .create(BufWriter::new(file))?;
    let mut counts = BTreeMap::new();
    for (c, msgs) in CHANNELS.iter().zip(&messages) {
        let present: Vec<&Value> = msgs.iter().flatten().collect();
        if present.is_empty() {
            continue;
        }
        let schema = schema::infer(present.iter().copied()).to_json_schema(c.schema, c.description);
        let schema_id = w.add_schema(
            c.schema,
            "jsonschema",
            &serde_json::to_vec(&schema).map_err(OutputError::Json)?,
        )?;
        let channel_id = w.add_channel(schema_id, c.topic, "json", &BTreeMap::new())?;
        let mut sequence = 0u32;
        for (s, m) in run.samples.iter().zip(msgs) {
            let Some(m) = m else { continue };
            let t = log_time_ns(s.time_s);
            w.write_to_known_channel(
                &mcap::records::MessageHeader {
                    channel_id,
                    sequence,
                    log_time: t,
                    publish_time: t,
                },
                &serde_json::to_vec(m)?,
            )?;
            sequence += 1;
        }
        counts.insert(c.topic.to_string(), u64::from(sequence));
    }
    let summary = serde_json::to_string(&run.summary)?;
    let metadata = BTreeMap::from([
        ("scenario".to_string(), rec.scenario.clone()),
        ("seed".to_string(), rec.seed.to_string()),
        ("flight_computer".to_string(), rec.computer.to_string()),
        ("summary".to_string(), summary),
        ("control_steps".to_string(), run.samples.len().to_string()),
    ]);
    w.write_metadata(&mcap::records::Metadata {
        name: "run".into(),
        metadata,
    })?;
    w.finish()?;
    drop(w);
    let bytes = std::fs::metadata(path).map_err(io)?.len();
    Ok(LogStats {
        bytes,
        messages: counts,
    })
}

/// JSON Schema inference from example messages.
mod schema {
    use std::collections::BTreeMap;

    use serde_json::{Map, Value};

    /// The JSON types one value takes over a set of messages.
    #[derive(Debug, Default, Clone)]
    pub struct Shape {
        boolean: bool,
        integer: bool,
        number: bool,
        string: bool,
        array: Option<Box<Shape>>,
        object: Option<BTreeMap<String, Shape>>,
    }

    impl Shape {
        /// Widens `self` to also take `v`.
        fn add(&mut self, v: &Value) {
            match v {
                Value::Null => {}
                Value::Bool(_) => self.boolean = true,
                Value::Number(n) if n.is_i64() || n.is_u64() => self.integer = true,
                Value::Number(_) => self.number = true,
                Value::String(_) => self.string = true,
                Value::Array(items) => {
                    let shape = self.array.get_or_insert_with(Box::default);
                    for i in items {
                        shape.add(i);
                    }
                }
                Value::Object(fields) => {
                    let shape = self.object.get_or_insert_with(BTreeMap::new);
                    for (k, v) in fields {
                        shape.entry(k.clone()).or_default().add(v);
                    }
                }
            }
        }

        /// The shape as a JSON Schema fragment with one type (the first of object, array,
        /// string, number, integer, boolean the value takes: Foxglove reads no type unions);
        /// `None` when no type is known (a field only ever null, an array only ever empty),
        /// and such a field is left out of its object's properties.
        fn to_value(&self) -> Option<Value> {
            let mut out = Map::new();
            let kind = if let Some(fields) = &self.object {
                let props: Map<String, Value> = fields
                    .iter()
                    .filter_map(|(k, s)| s.to_value().map(|v| (k.clone(), v)))
                    .collect();
                out.insert("properties".into(), Value::Object(props));
                "object"
            } else if let Some(items) = &self.array {
                out.insert("items".into(), items.to_value()?);
                "array"
            } else if self.string {
                "string"
            } else if self.number {
                // A field that is sometimes a float and sometimes integral is a number.
                "number"
            } else if self.integer {
                "integer"
            } else if self.boolean {
                "boolean"
            } else {
                return None;
            };
            out.insert("type".into(), kind.into());
            Some(Value::Object(out))
        }

        /// The whole schema document of a channel.
        pub fn to_json_schema(&self, title: &str, description: &str) -> Value {
            let mut v = self.to_value().unwrap_or_else(|| Value::Object(Map::new()));
            if let Some(obj) = v.as_object_mut() {
                obj.insert(
                    "$schema".into(),
                    "https://json-schema.org/draft/2020-12/schema".into(),
                );
                obj.insert("title".into(), title.into());
                obj.insert("description".into(), description.into());
            }
            v
        }
    }

    /// The shape of every value in `values`.
    pub fn infer<'a>(values: impl Iterator<Item = &'a Value>) -> Shape {
        let mut s = Shape::default();
        for v in values {
            s.add(v);
        }
        s
    }

    #[cfg(test)]
    mod tests {
        use super::*;
        use serde_json::json;

        #[test]
        fn unions_types_and_fields_over_messages() {
            let msgs = [
                json!({"a": 1, "b": null, "c": [1.5], "d": {"e": true}}),
                json!({"a": 2.5, "b": "Lost", "c": [], "f": 3}),
            ];
            let s = infer(msgs.iter()).to_value().expect("typed");
            assert_eq!(s["type"], "object");
            assert_eq!(s["properties"]["a"]["type"], "number");
            assert_eq!(s["properties"]["b"]["type"], "string");
            assert_eq!(s["properties"]["c"]["items"]["type"], "number");
            assert_eq!(s["properties"]["d"]["properties"]["e"]["type"], "boolean");
            assert_eq!(s["properties"]["f"]["type"], "integer");
            // Only ever null or empty: no type, left out.
            let s = infer([json!({"g": null, "h": []})].iter())
                .to_value()
                .expect("typed");
            assert_eq!(s["properties"], json!({}));
        }
    }
}
