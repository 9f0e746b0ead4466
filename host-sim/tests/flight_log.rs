//! The flight-test log and the animation of a docking: recording does not change the run;
//! the MCAP file opens with the `mcap` crate's reader and holds the documented channels, one
//! message per control step each, whose values are the run's (the whole controller output
//! read back); each channel's schema is the checked-in one (`host-sim/tests/schemas/`, one
//! file per schema name) and every message validates against it with a JSON Schema
//! validator (the `jsonschema` crate), so a field that changes its type, appears or goes
//! fails here until its schema file is updated (`IBVS_BLESS_SCHEMAS=1` rewrites the files
//! from the log, for a reviewed change); the GIF has one frame per five control steps (and the last), of the stated
//! size, and is the same bytes every time; its overlay follows the refuelling procedure
//! (attempt, mode, estimate, the gate's decision).
//! Processor in the loop (needs QEMU and the firmware ELF, `host_sim::pil::firmware_elf`: it
//! is not built here): the link channels carry the raw frames, which decode to what the run
//! flew.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;

use host_sim::animate::{self, AnimationOptions, HEIGHT_PX, WIDTH_PX};
use host_sim::flight_log;
use host_sim::pil::{PilFlightComputer, firmware_elf};
use host_sim::record::{self, Recording};
use host_sim::sim::{self, Run, Scenario};
use ibvs_core::controller::ControllerOutput;
use ibvs_core::wire::{LinkStatus, decode_downlink, decode_uplink};
use ibvs_core::{Controller, ControllerConfig, Mode};
use serde_json::Value;

/// The channels of an in-process run with the LED camera.
const IN_PROCESS_TOPICS: [&str; 9] = [
    "/truth/receiver",
    "/truth/probe_tip",
    "/truth/drogue",
    "/truth/hose",
    "/camera/measurement",
    "/camera/image",
    "/nav/sample",
    "/controller/input",
    "/controller/output",
];

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("ibvs-flight-log-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("scratch directory");
    dir
}

fn controller() -> Controller {
    Controller::new(ControllerConfig::default()).expect("default config")
}

/// The default scenario (hose, wake, LED camera set back on the nose, the refuelling
/// procedure), flown and recorded.
fn recorded() -> (Run, Recording) {
    record::run(&Scenario::default(), &mut controller(), &[]).expect("recorded run")
}

/// Every message of an MCAP file: topic to (sequence, log time, JSON), in file order.
type Messages = BTreeMap<String, Vec<(u32, u64, Value)>>;

/// One channel as the file declares it.
struct Channel {
    message_encoding: String,
    schema_name: String,
    schema_encoding: String,
    schema: Value,
}

/// Per topic, its channel.
type Channels = BTreeMap<String, Channel>;

/// The checked-in schemas: one file per schema name.
fn schema_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests")
        .join("schemas")
}

/// Every channel's schema is the checked-in file of its name, and every message of the
/// channel validates against that file's schema (not the one in the log). With
/// `IBVS_BLESS_SCHEMAS` set, a schema that differs rewrites its file instead (the change is
/// then the diff of the files, for review).
fn assert_schemas_are_the_checked_in_ones(channels: &Channels, messages: &Messages) {
    let bless = std::env::var_os("IBVS_BLESS_SCHEMAS").is_some();
    let mut problems = Vec::new();
    for (topic, c) in channels {
        let path = schema_dir().join(format!("{}.json", c.schema_name));
        let text = std::fs::read_to_string(&path).unwrap_or_default();
        let checked_in: Value = serde_json::from_str(&text).unwrap_or(Value::Null);
        if checked_in != c.schema {
            if bless {
                std::fs::create_dir_all(schema_dir()).expect("schema directory");
                let pretty = serde_json::to_string_pretty(&c.schema).expect("JSON");
                std::fs::write(&path, pretty + "\n").expect("schema file written");
                continue;
            }
            problems.push(format!(
                "{topic}: the log's schema {} differs from {} (run with IBVS_BLESS_SCHEMAS=1 \
                 to rewrite it after a deliberate change):\n  log:        {}\n  checked in: {}",
                c.schema_name,
                path.display(),
                c.schema,
                checked_in
            ));
            continue;
        }
        let validator = jsonschema::validator_for(&checked_in)
            .unwrap_or_else(|e| panic!("{}: not a valid JSON Schema: {e}", path.display()));
        for (k, (_, _, m)) in messages[topic].iter().enumerate() {
            if let Some(e) = validator.iter_errors(m).next() {
                problems.push(format!("{topic} message {k}: {e} at {}", e.instance_path()));
                break;
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

fn read_mcap(path: &Path) -> (Messages, Channels, Vec<u8>) {
    let bytes = std::fs::read(path).expect("log written");
    let mut messages = Messages::new();
    let mut channels = BTreeMap::new();
    for m in mcap::MessageStream::new(&bytes).expect("an MCAP file") {
        let m = m.expect("a readable message");
        let schema = m
            .channel
            .schema
            .as_ref()
            .expect("every channel has a schema");
        channels
            .entry(m.channel.topic.clone())
            .or_insert_with(|| Channel {
                message_encoding: m.channel.message_encoding.clone(),
                schema_name: schema.name.clone(),
                schema_encoding: schema.encoding.clone(),
                schema: serde_json::from_slice(&schema.data).expect("schema is JSON"),
            });
        messages.entry(m.channel.topic.clone()).or_default().push((
            m.sequence,
            m.log_time,
            serde_json::from_slice(&m.data).expect("message is JSON"),
        ));
    }
    (messages, channels, bytes)
}

/// Checks that `schema` is an object schema Foxglove's JSON Schema reader takes: every
/// property has exactly one type of boolean, string, number, integer, object (recursively) or
/// array of one of those; no unions, no `null`.
fn assert_foxglove_readable(schema: &Value, path: &str) {
    assert_eq!(schema["type"], "object", "{path}: {schema}");
    let props = schema["properties"]
        .as_object()
        .unwrap_or_else(|| panic!("{path}: properties"));
    for (name, field) in props {
        let here = format!("{path}.{name}");
        let ty = field["type"]
            .as_str()
            .unwrap_or_else(|| panic!("{here}: one type: {field}"));
        match ty {
            "boolean" | "string" | "number" | "integer" => {}
            "object" => assert_foxglove_readable(field, &here),
            "array" => match field["items"]["type"].as_str() {
                Some("boolean" | "string" | "number" | "integer") => {}
                Some("object") => assert_foxglove_readable(&field["items"], &here),
                other => panic!("{here}: array items {other:?}"),
            },
            other => panic!("{here}: type {other}"),
        }
    }
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

#[test]
fn recording_does_not_change_the_run() {
    let s = Scenario::default();
    let plain = sim::run(&s, &mut controller()).expect("run");
    let (recorded, rec) = record::run(&s, &mut controller(), &[]).expect("recorded run");
    assert_eq!(plain.summary, recorded.summary);
    assert_eq!(plain.samples, recorded.samples);
    assert_eq!(rec.steps.len(), recorded.samples.len());
    // The tap kept what the flight computer was given: the sample's measurement.
    for (k, (sample, step)) in recorded.samples.iter().zip(&rec.steps).enumerate() {
        assert_eq!(sample.measurement, step.input.measurement, "step {k}");
        assert_eq!(
            step.world.hose_tanker_m.last(),
            Some(&sample.drogue_tanker_m),
            "step {k}: the hose ends at the drogue"
        );
    }
}

#[test]
fn the_log_has_one_typed_message_per_step_per_channel_with_the_runs_values() {
    let (run, rec) = recorded();
    assert!(run.summary.docked, "{:?}", run.summary);
    let dir = scratch("log");
    let path = dir.join("run.mcap");
    let stats = flight_log::write_mcap(&path, &run, &rec).expect("log written");
    let (messages, channels, bytes) = read_mcap(&path);
    let n = run.samples.len();
    assert_schemas_are_the_checked_in_ones(&channels, &messages);

    // The channels, their encodings and their counts.
    let topics: BTreeSet<&str> = messages.keys().map(String::as_str).collect();
    assert_eq!(topics, IN_PROCESS_TOPICS.into_iter().collect());
    assert_eq!(stats.bytes, bytes.len() as u64);
    for (topic, msgs) in &messages {
        assert_eq!(msgs.len(), n, "{topic}");
        assert_eq!(stats.messages[topic], n as u64, "{topic}");
        let c = &channels[topic];
        assert_eq!(
            (c.message_encoding.as_str(), c.schema_encoding.as_str()),
            ("json", "jsonschema")
        );
        let schema = &c.schema;
        assert_foxglove_readable(schema, topic);
        for (k, (seq, t, m)) in msgs.iter().enumerate() {
            assert_eq!(*seq as usize, k, "{topic}");
            // Log time: the step's simulation time in nanoseconds (20 ms steps from 0).
            let expected_ns = (run.samples[k].time_s * 1e9).round() as u64;
            assert_eq!(*t, expected_ns, "{topic} step {k}");
            assert_eq!(*t, k as u64 * 20_000_000, "{topic} step {k}");
            // Every field of every message is in the schema.
            for key in m.as_object().expect("an object").keys() {
                assert!(
                    schema["properties"].get(key).is_some(),
                    "{topic}: {key} not in {schema}"
                );
            }
        }
    }
    // The summary section agrees.
    let summary = mcap::Summary::read(&bytes)
        .expect("summary readable")
        .expect("summary present");
    let stats_record = summary.stats.expect("statistics");
    assert_eq!(
        stats_record.message_count,
        (n * IN_PROCESS_TOPICS.len()) as u64
    );
    let index = summary
        .metadata_indexes
        .iter()
        .find(|i| i.name == "run")
        .expect("run metadata");
    let meta = mcap::read::metadata(&bytes, index).expect("metadata");
    let outcome: Value = serde_json::from_str(&meta.metadata["summary"]).expect("JSON");
    assert_eq!(outcome["outcome"], "docked");
    assert_eq!(meta.metadata["control_steps"], n.to_string());

    // One value per channel, against the run (a step mid-run, at the pre-contact station, and
    // the last).
    let k = n / 2;
    assert_eq!(run.samples[k].output.mode, Mode::PreContact);
    let (s, r) = (&run.samples[k], &rec.steps[k]);
    let at = |topic: &str| &messages[topic][k].2;
    assert_eq!(
        f(&at("/truth/receiver")["cg_ned_m"]["x"]),
        s.state.pos_ned_m.x
    );
    assert_eq!(
        f(&at("/truth/receiver")["euler_rad"]["pitch"]),
        s.state.euler_rad.y
    );
    assert_eq!(
        f(&at("/truth/probe_tip")["position_tanker_m"]["y"]),
        s.tip_tanker_m.y
    );
    assert_eq!(
        f(&at("/truth/drogue")["centre_tanker_m"]["z"]),
        s.drogue_tanker_m.z
    );
    let nodes = at("/truth/hose")["nodes_tanker_m"]
        .as_array()
        .expect("nodes");
    assert_eq!(nodes.len(), r.world.hose_tanker_m.len());
    assert!(nodes.len() > 2);
    assert_eq!(f(&nodes[nodes.len() - 1]["x"]), s.drogue_tanker_m.x);
    let m = at("/camera/measurement");
    assert_eq!(f(&m["depth_m"]) as f32, s.measurement.depth_m);
    assert_eq!(m["tracked"], s.measurement.tracked);
    assert_eq!(m["seq"], s.measurement.seq);
    // The set-back camera sees the probe tip's marker; the image error is from the aim, the
    // drogue dead ahead of the tip at the frame's depth.
    let tip = s.measurement.probe_tip.expect("the tip's marker in view");
    assert_eq!(f(&m["probe_tip"]["x"]) as f32, tip[0]);
    assert_eq!(f(&m["probe_tip"]["y"]) as f32, tip[1]);
    let [ax, ay] = rec.aim(f64::from(s.measurement.depth_m));
    let near = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs().max(1.0);
    assert!(near(f(&m["aim_x"]), ax) && near(f(&m["aim_y"]), ay), "{m}");
    assert!(
        near(
            f(&m["image_error_y"]),
            f64::from(s.measurement.image_y) - ay
        ),
        "{m}"
    );
    // Parallax: farther out than the tip, the drogue dead ahead of it appears nearer the
    // image centre than the tip's marker.
    assert!(
        ay.signum() == f64::from(tip[1]).signum() && ay.abs() < f64::from(tip[1]).abs(),
        "aim {ay}, tip {tip:?}"
    );
    let image = at("/camera/image");
    let circle = &image["circle"];
    assert!(s.measurement.tracked, "at the station the ring is tracked");
    // The measurement is the circle's: depth = f R / r.
    let depth = rec.image.focal_px * rec.image.ring_radius_m / f(&circle["radius_px"]);
    assert!(
        (depth - f64::from(s.measurement.depth_m)).abs() < 1e-5 * depth,
        "{depth} {:?}",
        s.measurement
    );
    assert_eq!(
        image["centroids_px"].as_array().expect("centroids").len() as u64,
        image["visible_leds"].as_u64().expect("count")
    );
    assert_eq!(
        f(&at("/nav/sample")["lon"]["v_mps"]) as f32,
        r.input.nav.lon.v_mps
    );
    assert_eq!(at("/controller/input")["request"], "None");
    // The whole controller output comes back from its JSON: at the station the gate predicts
    // nothing (infinite, left out), in the contact approach and at docking it does.
    let approach = run
        .samples
        .iter()
        .rposition(|s| s.output.mode == Mode::Approach)
        .expect("a contact approach");
    for j in [k, approach, n - 1] {
        let message = &messages["/controller/output"][j].2;
        let o: ControllerOutput = flight_log::controller_output(message).expect("an output");
        assert_eq!(o, run.samples[j].output, "step {j}");
        assert_eq!(
            message.get("predicted_miss_m").is_some(),
            o.predicted_miss_m.is_finite(),
            "step {j}"
        );
        assert_eq!(message["attempt"], 1, "step {j}");
        assert_eq!(
            f(&message["estimate"]["depth_m"]) as f32,
            o.estimate.depth_m,
            "step {j}"
        );
    }
    assert!(run.samples[k].output.predicted_miss_m.is_infinite());
    assert!(run.samples[approach].output.predicted_miss_m.is_finite());
    let schema = &channels["/controller/output"].schema;
    for field in ["attempt", "estimate", "predicted_miss_m"] {
        assert!(schema["properties"].get(field).is_some(), "{field}");
    }
    assert_eq!(messages["/controller/output"][n - 1].2["mode"], "Docked");
    assert_eq!(run.samples[n - 1].output.mode, Mode::Docked);
    assert_eq!(messages["/controller/input"][0].2["request"], "Engage");
    std::fs::remove_dir_all(&dir).ok();
}

/// One GIF frame: left, top, width, height, delay.
type GifFrame = (u16, u16, u16, u16, u16);

/// Frames of a GIF, and its screen size.
fn gif_frames(path: &Path) -> ((u16, u16), Vec<GifFrame>) {
    let mut opts = gif::DecodeOptions::new();
    opts.set_color_output(gif::ColorOutput::Indexed);
    let file = std::fs::File::open(path).expect("GIF written");
    let mut d = opts.read_info(file).expect("a GIF");
    let screen = (d.width(), d.height());
    let mut frames = Vec::new();
    while let Some(fr) = d.read_next_frame().expect("a readable frame") {
        frames.push((fr.left, fr.top, fr.width, fr.height, fr.delay));
    }
    (screen, frames)
}

#[test]
fn the_animation_has_a_frame_every_five_steps_of_the_stated_size_and_is_deterministic() {
    let (run, rec) = recorded();
    let dir = scratch("gif");
    let opts = AnimationOptions::default();
    let a = animate::write_gif(&dir.join("a.gif"), &run, &rec, &opts).expect("GIF");
    let b = animate::write_gif(&dir.join("b.gif"), &run, &rec, &opts).expect("GIF");
    let n = run.samples.len();
    // Steps 0, 5, 10, ... and the last one.
    let expected = n.div_ceil(5) + usize::from((n - 1) % 5 != 0);
    let (screen, frames) = gif_frames(&dir.join("a.gif"));
    assert_eq!(frames.len(), expected, "{n} steps");
    assert_eq!(a.frames, expected);
    assert_eq!(screen, (a.width_px as u16, a.height_px as u16));
    assert_eq!((a.width_px, a.height_px), (WIDTH_PX, HEIGHT_PX));
    let bytes = std::fs::read(dir.join("a.gif")).expect("read");
    assert_eq!(a.bytes, bytes.len() as u64);
    assert!(
        a.bytes < 2_000_000,
        "the GIF stays small: {} bytes",
        a.bytes
    );
    // The first frame is the whole canvas; all stay inside it; 0.1 s each (5 steps of
    // 20 ms: real time), the last held.
    assert_eq!(frames[0], (0, 0, screen.0, screen.1, 10));
    for (i, fr) in frames.iter().enumerate() {
        assert!(
            fr.0 + fr.2 <= screen.0 && fr.1 + fr.3 <= screen.1,
            "frame {i}: {fr:?}"
        );
        let delay = if i + 1 == frames.len() {
            opts.hold_last_cs
        } else {
            10
        };
        assert_eq!(fr.4, delay, "frame {i}");
    }
    assert_eq!(
        bytes,
        std::fs::read(dir.join("b.gif")).expect("read"),
        "same run, same bytes"
    );
    assert_eq!(a, b);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_overlay_follows_the_refuelling_procedure() {
    let (run, rec) = recorded();
    let rc = rec.config.refuelling;
    let first = |mode: Mode| {
        run.samples
            .iter()
            .position(|s| s.output.mode == mode)
            .unwrap_or_else(|| panic!("{mode:?} flown"))
    };
    let text =
        |k: usize| animate::overlay_lines(&run, &rec, k, k + 1 == run.samples.len()).join("\n");
    // At the station: the attempt, the mode, the estimator's belief, the gate's rule.
    let k = first(Mode::PreContact) + 50;
    let o = &run.samples[k].output;
    assert_eq!(o.mode, Mode::PreContact);
    let t = text(k);
    assert!(t.contains("attempt 1    mode PreContact"), "{t}");
    assert!(
        t.contains(&format!("estimate: fwd {:.2},", o.estimate.depth_m)),
        "{t}"
    );
    assert!(
        t.contains(&format!("go if predicted miss ≤ {:.2} m", rc.gate_radius_m)),
        "{t}"
    );
    // In the contact approach: the gate's prediction and what it would decide.
    let k = first(Mode::Terminal) - 1;
    let o = &run.samples[k].output;
    assert_eq!(o.mode, Mode::Approach);
    let t = text(k);
    assert!(t.contains("mode Approach (contact)"), "{t}");
    assert!(
        t.contains(&format!("predicted miss {:.2} m, go", o.predicted_miss_m)),
        "{t}"
    );
    // Docked: the go, when and on what prediction.
    let go = &run.samples[first(Mode::Terminal)];
    let t = text(run.samples.len() - 1);
    assert!(t.contains("mode Docked"), "{t}");
    assert!(
        t.contains(&format!(
            "go at {:.2} s: predicted miss {:.2} ≤ {:.2} m",
            go.time_s, go.output.predicted_miss_m, rc.gate_radius_m
        )),
        "{t}"
    );
}

#[test]
fn dock_animate_and_log_on_defaults_writes_both() {
    let dir = scratch("cli");
    let log = dir.join("nested").join("run.mcap");
    let out = Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(["dock", "--animate", "--out"])
        .arg(&dir)
        .arg("--log")
        .arg(&log)
        .output()
        .expect("run host-sim");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(String::from_utf8_lossy(&out.stdout).starts_with("Docked"));
    let (screen, frames) = gif_frames(&dir.join("dock.gif"));
    assert_eq!(screen, (WIDTH_PX as u16, HEIGHT_PX as u16));
    assert!(
        stderr.contains(&format!("{} frames", frames.len())),
        "{stderr}"
    );
    let (messages, _, bytes) = read_mcap(&log);
    assert_eq!(messages.len(), IN_PROCESS_TOPICS.len());
    assert!(
        stderr.contains(&format!("{} bytes", bytes.len())),
        "{stderr}"
    );
    // --animate needs files; --still-s needs --animate.
    let refused = Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(["dock", "--animate", "--no-files"])
        .output()
        .expect("run host-sim");
    assert!(!refused.status.success());
    std::fs::remove_dir_all(&dir).ok();
}

fn unhex(s: &str) -> Vec<u8> {
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).expect("hex"))
        .collect()
}

#[test]
fn a_pil_log_carries_the_raw_link_frames() {
    let elf = firmware_elf().expect("firmware ELF");
    let mut pil = PilFlightComputer::spawn(&elf).expect("QEMU with the firmware");
    let (run, rec) = record::run_pil(&Scenario::default(), &mut pil, &[]).expect("PIL run");
    let failure = pil.last_error().map(ToString::to_string);
    let (stats, firmware_log) = pil.shutdown();
    assert_eq!(failure, None, "link failure; firmware log:\n{firmware_log}");
    let dir = scratch("pil");
    let path = dir.join("pil.mcap");
    flight_log::write_mcap(&path, &run, &rec).expect("log written");
    let (messages, channels, _) = read_mcap(&path);
    assert_schemas_are_the_checked_in_ones(&channels, &messages);
    let n = run.samples.len();
    let topics: BTreeSet<&str> = messages.keys().map(String::as_str).collect();
    let mut expected: BTreeSet<&str> = IN_PROCESS_TOPICS.into_iter().collect();
    expected.extend(["/link/uplink_frame", "/link/downlink_frame"]);
    assert_eq!(topics, expected);
    assert_eq!(messages["/link/uplink_frame"].len(), n);
    assert_eq!(messages["/link/downlink_frame"].len(), n, "no step failed");
    for k in [0, n / 2, n - 1] {
        let up = &messages["/link/uplink_frame"][k].2;
        let frame = unhex(up["frame_hex"].as_str().expect("hex"));
        assert_eq!(
            frame.len() as u64,
            up["length_bytes"].as_u64().expect("length")
        );
        assert_eq!(frame.last(), Some(&0), "the frame's zero delimiter is kept");
        let decoded = decode_uplink(&frame).expect("a measurement frame");
        assert_eq!(decoded.input, rec.steps[k].input, "step {k}");
        assert_eq!(up["seq"].as_u64(), Some(u64::from(decoded.seq)));

        let down = &messages["/link/downlink_frame"][k].2;
        let frame = unhex(down["frame_hex"].as_str().expect("hex"));
        let decoded = decode_downlink(&frame).expect("a command frame");
        assert_eq!(decoded.output, run.samples[k].output, "step {k}");
        assert_eq!(
            down["echo_seq"], up["seq"],
            "step {k}: the answer to this frame"
        );
        assert_eq!(
            down["cost"]["step"].as_u64(),
            Some(u64::from(decoded.cost.step))
        );
        assert_eq!(down["cost"]["unit"], "Instructions");
        assert!(decoded.cost.step > 0);
        let status = down["link_status"].as_u64().expect("link status bits");
        assert_eq!(status, u64::from(decoded.link_status.0), "step {k}");
        assert!(
            !decoded.link_status.contains(LinkStatus::RETRANSMIT)
                && !decoded.link_status.contains(LinkStatus::STALE),
            "step {k}: a new step on a current measurement, status {status:#010b}"
        );
    }
    // The counters travel in telemetry frames: the last one, fetched at shutdown, counts
    // every measurement frame of the run as accepted.
    assert_eq!(u64::from(stats.firmware_link.frames_ok), n as u64);
    assert_eq!(
        (stats.firmware_link.corrupt, stats.firmware_link.malformed),
        (0, 0)
    );
    std::fs::remove_dir_all(&dir).ok();
}
