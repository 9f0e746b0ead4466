//! What the control step and the link cost on the MCU, path by path, read from a
//! [`CostCounter`]: the same code on both boards (instructions under QEMU, DWT cycles on the
//! `f405` board).
//!
//! Place in the data flow: none; the `qemu` board runs this when its semihosting command line
//! says `bench`, the `f405` board at boot when built with the `bench` feature, and each logs
//! the result as one JSON line (`docs/benchmarks.md`, "On hardware").
//!
//! The controller (the default configuration: the refuelling procedure, set-back camera)
//! steps through one scripted sortie that visits every path of the step: engage, the
//! pre-contact station, the contact approach, a held frame, a commit with the gate's
//! prediction that is a no-go, the missed approach, back at the station, a commit that goes
//! (capture entry), the capture, contact, contact lost (breakaway with navigation),
//! breakaway without navigation (open loop). Each path's largest cost is kept,
//! with the largest stack any step used (where the counter measures it:
//! [`CostCounter::stack_of`]). Then the link: one measurement frame decoded (and again with
//! the navigation at exactly zero: each zero byte is a COBS block boundary, dearer than a
//! data byte), the CRC-32C alone, one command frame encoded. And the gain schedule's
//! follow-up (`Controller::follow_schedule`) at a condition off the grid.
//!
//! Invariant: the figures are of the measured calls only (the counter is read right before
//! and after each; one count of each pair is the read itself, under QEMU).

use core::hint::black_box;

use ibvs_core::estimator::TipGeometry;
use ibvs_core::gains::TRIM;
use ibvs_core::nav::{FlightCondition, NavSample};
use ibvs_core::procedure;
use ibvs_core::wire::{
    Downlink, FrameDecoder, LinkCounters, MAX_FRAME_LEN, Telemetry, Uplink, WireError, config_id,
    crc32c, encode_config_write, encode_downlink, encode_telemetry, encode_uplink,
};
use ibvs_core::{
    Controller, ControllerConfig, ControllerInput, ControllerOutput, Mode, ModeRequest,
};

use autopilot_link::peer::{AutopilotTelemetry, MAX_TELEMETRY_LEN, Peer, read_setpoint};
use autopilot_link::session::{MAX_BURST_LEN, Session, SessionConfig};
use autopilot_link::{LinkIds, NavConfig, quaternion_zyx};
use ibvs_core::attitude::{AttitudeSetpoint, Command};

use crate::app::CostCounter;
use crate::app::{RX_CHUNK_LEN, Received, receive};
use crate::one_step::engage_input;

/// The paths of the step the script visits, in order.
pub const PATHS: [&str; 10] = [
    "engage",
    "pre_contact",
    "approach",
    "hold",
    "missed_approach",
    "capture_entry",
    "capture",
    "docked",
    "breakaway",
    "breakaway_open_loop",
];

/// Costs in the counter's unit, the stack, and the frame sizes, bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Costs {
    /// The largest step cost of each path of [`PATHS`].
    pub step: [u32; 10],
    /// The largest stack a step used, bytes (`None`: the counter does not measure it).
    pub step_stack_bytes: Option<u32>,
    /// Steps the script ran.
    pub steps: u32,
    /// The script ended where it should (breakaway, open loop); false means the figures
    /// are not of the paths named.
    pub script_ok: bool,
    /// Measurement frame on the wire, bytes.
    pub measurement_frame_len: usize,
    /// Command frame on the wire, bytes.
    pub command_frame_len: usize,
    /// Decoding the measurement frame: every byte through [`FrameDecoder::feed`] (COBS, CRC,
    /// header check) and the postcard deserialisation.
    pub decode_measurement: u32,
    /// The same with the navigation sample at exactly zero (48 zero payload bytes).
    pub decode_measurement_zero_nav: u32,
    /// The CRC-32C over the measurement frame's payload alone (part of the decode).
    pub crc_measurement: u32,
    /// Encoding the command frame: postcard, CRC, COBS.
    pub encode_command: u32,
    /// Telemetry frame on the wire (the script's counters), bytes.
    pub telemetry_frame_len: usize,
    /// Encoding it (after the command frame, outside the control task's deadline).
    pub encode_telemetry: u32,
    /// The gain schedule's follow-up after a step at a new flight condition inside the
    /// envelope (off the grid): the interpolation of the whole design and its loading
    /// (`Controller::follow_schedule`, outside the step).
    pub follow_schedule: u32,
    /// Configuration write frame on the wire (the paper's configuration), bytes.
    pub config_frame_len: usize,
    /// Decoding it: every byte through [`FrameDecoder::feed`] and the configuration's
    /// deserialisation.
    pub decode_config: u32,
    /// Applying it: [`Controller::reconfigure`] (validation, the controller rebuilt) and the
    /// configuration's id (`config_id`), as the application does in standby.
    pub apply_config: u32,
    /// Through the autopilot (MAVLink): one step's frames from the simulated ArduPlane at
    /// their longest (a heartbeat, the two attitude time constants' `PARAM_VALUE`s,
    /// `LOCAL_POSITION_NED`, `VFR_HUD`, `AOA_SSA`, `ATTITUDE`), bytes.
    pub mavlink_rx_len: usize,
    /// Decoding them: every byte through the session's decoder (framing, CRC with the CRC
    /// extra, payload).
    pub mavlink_decode: u32,
    /// The step's input from them (`Session::input`: the navigation sample, the mode).
    pub mavlink_nav: u32,
    /// Our longest burst: the heartbeat, two parameter requests and the setpoint, bytes.
    pub mavlink_tx_len: usize,
    /// Encoding them (`Session::send` with the heartbeat due, the time constants unknown).
    pub mavlink_encode: u32,
    /// The setpoint's quaternion alone (part of the encoding).
    pub mavlink_quaternion: u32,
}

impl Costs {
    /// The largest step cost of any path.
    pub fn step_max(&self) -> u32 {
        self.step.iter().copied().max().unwrap_or(0)
    }
}

/// [`Costs`] as one JSON object (the unit named), through integer formatting only.
pub struct Json<'a>(pub &'a Costs, pub &'static str);

impl core::fmt::Display for Json<'_> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let c = self.0;
        write!(f, "{{\"unit\": \"{}\", \"step\": {{", self.1)?;
        for (i, (path, cost)) in PATHS.iter().zip(c.step).enumerate() {
            let sep = if i == 0 { "" } else { ", " };
            write!(f, "{sep}\"{path}\": {cost}")?;
        }
        write!(
            f,
            "}}, \"step_max\": {}, \"step_stack_bytes\": ",
            c.step_max()
        )?;
        match c.step_stack_bytes {
            Some(b) => write!(f, "{b}")?,
            None => f.write_str("null")?,
        }
        write!(
            f,
            ", \"steps\": {}, \"script_ok\": {}, \"measurement_frame_bytes\": {}, \
             \"decode_measurement\": {}, \"decode_measurement_zero_nav\": {}, \
             \"crc_measurement\": {}, \"command_frame_bytes\": {}, \"encode_command\": {}, \
             \"telemetry_frame_bytes\": {}, \"encode_telemetry\": {}, \
             \"follow_schedule\": {}, \"config_frame_bytes\": {}, \"decode_config\": {}, \
             \"apply_config\": {}, \"mavlink_rx_bytes\": {}, \"mavlink_decode\": {}, \
             \"mavlink_nav\": {}, \"mavlink_tx_bytes\": {}, \"mavlink_encode\": {}, \
             \"mavlink_quaternion\": {}}}",
            c.steps,
            c.script_ok,
            c.measurement_frame_len,
            c.decode_measurement,
            c.decode_measurement_zero_nav,
            c.crc_measurement,
            c.command_frame_len,
            c.encode_command,
            c.telemetry_frame_len,
            c.encode_telemetry,
            c.follow_schedule,
            c.config_frame_len,
            c.decode_config,
            c.apply_config,
            c.mavlink_rx_len,
            c.mavlink_decode,
            c.mavlink_nav,
            c.mavlink_tx_len,
            c.mavlink_encode,
            c.mavlink_quaternion
        )
    }
}

/// A plausible navigation sample near trim (every state non-zero).
fn perturbed_nav() -> NavSample {
    NavSample::from_array([
        0.3, -0.2, 0.012, 0.4, 0.008, 0.003, 0.5, 0.004, -0.01, 0.002, 0.003, -0.002,
    ])
}

/// Decodes `frame` through a fresh decoder as the application does (the message the
/// flight computer takes); the cost and the message.
fn decode_timed<C: CostCounter>(
    frame: &[u8],
) -> (u32, Option<Result<Received, WireError>>, ControllerConfig) {
    let mut decoder = FrameDecoder::new();
    let mut config_in = ControllerConfig::default();
    let mut decoded = None;
    let mut rest = black_box(frame);
    let t0 = C::now();
    // In the receive queue's chunks (`RX_CHUNK_LEN` bytes), through the application's own decode.
    while !rest.is_empty() {
        let chunk = rest.get(..RX_CHUNK_LEN).unwrap_or(rest);
        let (taken, r) = receive(&mut decoder, &mut config_in, chunk);
        if r.is_some() {
            decoded = r;
        }
        rest = rest.get(taken.max(1)..).unwrap_or(&[]);
    }
    let cost = C::now().wrapping_sub(t0);
    (cost, black_box(decoded), config_in)
}

/// The cost of decoding `frame` ([`decode_timed`]).
fn decode_cost<C: CostCounter>(frame: &[u8]) -> u32 {
    decode_timed::<C>(frame).0
}

/// A frame of the drogue `right`, `down` of the probe tip and `depth` ahead of it, as the
/// configuration's (set-back) camera sees it, with the probe tip's marker; `k` adds a
/// tracker's noise of a ten-thousandth (the frozen-frame check rejects identical frames).
fn frame(
    input: &mut ControllerInput,
    cfg: &ControllerConfig,
    [right, down, depth]: [f32; 3],
    k: u32,
) {
    let tip = TipGeometry::new(&cfg.camera, cfg.probe_tip_body_m, TRIM.theta_rad);
    let t = tip.tip_from_camera_m();
    let z = depth + t[2];
    let m = &mut input.measurement;
    m.image_x = (right + t[0]) / z + 1e-4 * (k % 3) as f32;
    m.image_y = (down + t[1]) / z;
    m.depth_m = z;
    m.probe_tip = Some(tip.tip_image());
}

/// Runs the scripted sortie; the step costs per path and the last output.
fn steps<C: CostCounter>(
    costs: &mut Costs,
) -> Option<(Controller, ControllerInput, ControllerOutput)> {
    let cfg = ControllerConfig::default();
    let mut controller = Controller::new(cfg).ok()?;
    let mut input = engage_input();
    let mut last = ControllerOutput::default();
    let mut k = 0u32;
    let mut run = |path: usize, input: &mut ControllerInput, controller: &mut Controller| {
        input.measurement.seq = input.measurement.seq.wrapping_add(1);
        let ((out, cost), stack) = C::stack_of(|| {
            let t0 = C::now();
            let out = controller.step(black_box(input));
            (out, C::now().wrapping_sub(t0))
        });
        costs.step[path] = costs.step[path].max(cost);
        if let Some(b) = stack {
            costs.step_stack_bytes = Some(costs.step_stack_bytes.unwrap_or(0).max(b));
        }
        costs.steps += 1;
        input.request = ModeRequest::None;
        out
    };
    // Engage at the station, then hold it until stable (1 s) and the approach starts.
    let station = cfg.refuelling.station_depth_m;
    frame(&mut input, &cfg, [0.02, -0.01, station], k);
    run(0, &mut input, &mut controller);
    for _ in 0..60 {
        k += 1;
        frame(&mut input, &cfg, [0.02, -0.01, station], k);
        run(1, &mut input, &mut controller);
    }
    let approached = controller.mode() == Mode::Approach;
    // The gate's depth at the approach's closing speed (the air here is calm).
    let commit = procedure::commit_depth(cfg.refuelling.contact_speed_mps, &cfg.refuelling);
    // Close at 1 m/s (the navigation says so) with the drogue drifting off: a frame lost on
    // the way, and at the commit depth the drogue 0.4 m off: a no-go.
    input.nav.lon.v_mps = 1.0;
    let mut depth = station;
    while depth > commit + 0.01 {
        depth -= 0.02;
        k += 1;
        let off = 0.4 * (station - depth) / (station - commit);
        frame(&mut input, &cfg, [off.min(0.4), 0.0, depth], k);
        run(2, &mut input, &mut controller);
        if k == 80 {
            input.measurement.tracked = false;
            run(3, &mut input, &mut controller);
            input.measurement.tracked = true;
        }
    }
    k += 1;
    frame(&mut input, &cfg, [0.4, 0.0, commit - 0.01], k);
    run(2, &mut input, &mut controller);
    let no_go = controller.mode() == Mode::MissedApproach;
    // The missed approach: back to the station, and the next attempt's pre-contact.
    input.nav = NavSample::default();
    for _ in 0..400 {
        k += 1;
        frame(&mut input, &cfg, [0.02, -0.01, station], k);
        let path = if controller.mode() == Mode::MissedApproach {
            4
        } else {
            1
        };
        run(path, &mut input, &mut controller);
        if controller.mode() == Mode::Approach {
            break;
        }
    }
    // Close on a centred drogue through the commit depth into the capture.
    input.nav.lon.v_mps = 1.0;
    let mut depth = station;
    let mut entered = false;
    while depth > 0.02 {
        depth -= 0.02;
        k += 1;
        frame(&mut input, &cfg, [0.01, 0.0, depth], k);
        let path = match controller.mode() {
            Mode::Approach if depth <= commit + 0.02 => 5,
            Mode::Approach => 2,
            _ => 6,
        };
        run(path, &mut input, &mut controller);
        entered |= controller.mode() == Mode::Terminal;
    }
    // Contact, docked, contact lost.
    input.nav = NavSample::default();
    input.probe_contact = true;
    for _ in 0..5 {
        k += 1;
        frame(&mut input, &cfg, [0.01, 0.0, 0.0], k);
        run(7, &mut input, &mut controller);
    }
    input.probe_contact = false;
    for _ in 0..10 {
        k += 1;
        frame(&mut input, &cfg, [0.01, 0.0, 0.0], k);
        run(8, &mut input, &mut controller);
    }
    // The navigation lost in breakaway: open loop.
    input.nav = NavSample::from_array([f32::NAN; 12]);
    for _ in 0..5 {
        last = run(9, &mut input, &mut controller);
    }
    costs.script_ok = approached
        && no_go
        && entered
        && controller.mode() == Mode::Breakaway
        && last.status.0 != 0;
    Some((controller, input, last))
}

/// The follow-up's cost at 137 m/s, 4,100 m (inside a cell, on no grid line), after one
/// step there; `None` if it loaded no design.
fn follow_schedule<C: CostCounter>() -> Option<u32> {
    let mut controller = Controller::new(ControllerConfig::default()).ok()?;
    let mut input = engage_input();
    input.nav.condition = FlightCondition {
        true_airspeed_mps: 137.0,
        altitude_m: 4100.0,
    };
    controller.step(&input);
    let t0 = C::now();
    let loaded = black_box(&mut controller).follow_schedule();
    let cost = C::now().wrapping_sub(t0);
    loaded.then_some(cost)
}

/// The configuration path's costs: `(frame bytes, decode, apply)`, on a controller in
/// standby given the paper's configuration; `None` if the frame was not taken or applied.
fn config_path<C: CostCounter>() -> Option<(usize, u32, u32)> {
    let mut controller = Controller::new(ControllerConfig::default()).ok()?;
    let cfg = ControllerConfig::paper();
    let mut buf = [0u8; MAX_FRAME_LEN];
    let frame = encode_config_write(&cfg, &mut buf).ok()?;
    let len = frame.len();
    let (decode, decoded, got) = decode_timed::<C>(frame);
    let Some(Ok(Received::ConfigWrite(Ok(())))) = decoded else {
        return None;
    };
    let t0 = C::now();
    let applied = black_box(&mut controller).reconfigure(black_box(got));
    let id = config_id(controller.config());
    let apply = C::now().wrapping_sub(t0);
    black_box(id);
    applied.ok().map(|()| (len, decode, apply))
}

/// Measures the costs once (the figures are deterministic under QEMU).
pub fn measure<C: CostCounter>() -> Costs {
    let mut costs = Costs::default();
    // First, on its own controller (not alive beside the script's: the stack stays that of
    // one controller at a time).
    let follow = follow_schedule::<C>();
    let config = config_path::<C>();
    let Some((controller, mut input, output)) = steps::<C>(&mut costs) else {
        return costs;
    };
    match follow {
        Some(cost) => costs.follow_schedule = cost,
        None => costs.script_ok = false,
    }
    match config {
        Some((len, decode, apply)) => {
            (
                costs.config_frame_len,
                costs.decode_config,
                costs.apply_config,
            ) = (len, decode, apply);
        }
        None => costs.script_ok = false,
    }
    input.nav = perturbed_nav();
    let up = Uplink {
        seq: input.measurement.seq,
        input,
    };
    let down = Downlink {
        seq: up.seq,
        echo_seq: Some(up.seq),
        output,
        ..Downlink::default()
    };
    let telemetry = Telemetry {
        seq: up.seq,
        counters: *controller.counters(),
        link: LinkCounters {
            frames_ok: up.seq,
            ..LinkCounters::default()
        },
        ..Telemetry::default()
    };

    let mut up_buf = [0u8; MAX_FRAME_LEN];
    let up_len = encode_uplink(&up, &mut up_buf).map_or(0, <[u8]>::len);
    costs.measurement_frame_len = up_len;
    let (decode, decoded, _) = decode_timed::<C>(&up_buf[..up_len]);
    costs.decode_measurement = decode;
    if !matches!(decoded, Some(Ok(Received::Measurement(got))) if got == up) {
        costs.script_ok = false;
    }

    let mut zero_nav = up;
    zero_nav.input.nav = NavSample::default();
    let mut zero_buf = [0u8; MAX_FRAME_LEN];
    let zero_len = encode_uplink(&zero_nav, &mut zero_buf).map_or(0, <[u8]>::len);
    costs.decode_measurement_zero_nav = decode_cost::<C>(&zero_buf[..zero_len]);

    // The CRC over a payload of the same length (frame minus COBS code and zero).
    let payload = [0x5Au8; MAX_FRAME_LEN];
    let t0 = C::now();
    black_box(crc32c(black_box(&payload[..up_len.saturating_sub(2)])));
    costs.crc_measurement = C::now().wrapping_sub(t0);

    let mut down_buf = [0u8; MAX_FRAME_LEN];
    let t0 = C::now();
    let down_len = encode_downlink(black_box(&down), &mut down_buf).map_or(0, <[u8]>::len);
    costs.encode_command = C::now().wrapping_sub(t0);
    costs.command_frame_len = down_len;
    let t0 = C::now();
    let telemetry_len =
        encode_telemetry(black_box(&telemetry), &mut down_buf).map_or(0, <[u8]>::len);
    costs.encode_telemetry = C::now().wrapping_sub(t0);
    costs.telemetry_frame_len = telemetry_len;
    mavlink::<C>(&mut costs, &up.input, &output);
    costs
}

/// The MAVLink link's costs for one step through the autopilot (heartbeats due both ways).
fn mavlink<C: CostCounter>(costs: &mut Costs, uplink: &ControllerInput, out: &ControllerOutput) {
    let ids = LinkIds::default();
    let mut peer = Peer::new(ids, [0.5, 0.5]);
    // A track other than north: the sample's rotation into the track's axes computed.
    let nav = NavConfig {
        track_rad: 1.0,
        ..NavConfig::default()
    };
    let mut session = Session::new(SessionConfig {
        nav,
        ..SessionConfig::default()
    });
    let Ok(t) = AutopilotTelemetry::of_sample(&perturbed_nav(), &nav) else {
        costs.script_ok = false;
        return;
    };
    // The autopilot's first heartbeat says what it is; our answer, measured: a heartbeat, the
    // two time constants asked for and a setpoint (the longest burst).
    let mut rx = [0u8; MAX_TELEMETRY_LEN];
    let n = peer.telemetry(&t, true, 0, &mut rx);
    rx[..n].iter().for_each(|&b| session.push(b, 0));
    let command = Command::Attitude(AttitudeSetpoint {
        roll_rad: 0.1,
        pitch_rad: 0.05,
        yaw_rad: -0.02,
        throttle: out.command.throttle().clamp(0.0, 1.0),
    });
    let mut tx = [0u8; MAX_BURST_LEN];
    let t0 = C::now();
    let len = session.send(0, black_box(&command), &mut tx);
    costs.mavlink_encode = C::now().wrapping_sub(t0);
    costs.mavlink_tx_len = len;
    peer.hear(&read_setpoint(&tx[..len], nav.track_rad));
    // A second later, the longest burst the autopilot sends: its heartbeat, the two time
    // constants and the step's four messages, measured; then the step's input.
    let n = peer.telemetry(&t, true, 1000, &mut rx);
    costs.mavlink_rx_len = n;
    let t0 = C::now();
    for &b in black_box(&rx[..n]) {
        session.push(b, 1000);
    }
    costs.mavlink_decode = C::now().wrapping_sub(t0);
    let t0 = C::now();
    let input = session.input(1000, black_box(uplink));
    costs.mavlink_nav = C::now().wrapping_sub(t0);
    if !(input.autopilot_ready && input.nav.as_array().iter().all(|v| v.is_finite())) {
        costs.script_ok = false;
    }
    let t0 = C::now();
    black_box(quaternion_zyx(
        black_box(0.1),
        black_box(0.05),
        black_box(-0.02),
    ));
    costs.mavlink_quaternion = C::now().wrapping_sub(t0);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::app::NoCounter;

    /// The line parses as JSON (a JSON parser, not a look at its braces) into one object whose
    /// every field has the value and the JSON type of the figure it carries: the paths by
    /// name in `PATHS` order, the largest step, `null` for a stack not measured, the flag a
    /// boolean, the rest numbers. A field that changes type, a missing comma or an unquoted
    /// name fails.
    #[test]
    fn json_line_is_json() {
        use serde_json::{Value, json};
        let mut c = Costs {
            step: [1, 2, 3, 4, 5, 6, 7, 8, 9, 10],
            step_stack_bytes: Some(200),
            steps: 321,
            script_ok: true,
            measurement_frame_len: 90,
            command_frame_len: 120,
            decode_measurement: 11,
            decode_measurement_zero_nav: 12,
            crc_measurement: 13,
            encode_command: 14,
            telemetry_frame_len: 60,
            encode_telemetry: 15,
            follow_schedule: 16,
            config_frame_len: 467,
            decode_config: 17,
            apply_config: 18,
            mavlink_rx_len: 161,
            mavlink_decode: 19,
            mavlink_nav: 20,
            mavlink_tx_len: 72,
            mavlink_encode: 21,
            mavlink_quaternion: 22,
        };
        let parse = |c: &Costs, unit| -> Value {
            let text = Json(c, unit).to_string();
            assert!(!text.contains('\n'), "one line: {text}");
            serde_json::from_str(&text).unwrap_or_else(|e| panic!("not JSON ({e}): {text}"))
        };
        let v = parse(&c, "cycles");
        let step: serde_json::Map<String, Value> = PATHS
            .iter()
            .zip(c.step)
            .map(|(p, n)| ((*p).to_string(), json!(n)))
            .collect();
        assert_eq!(
            v,
            json!({
                "unit": "cycles",
                "step": step,
                "step_max": 10,
                "step_stack_bytes": 200,
                "steps": 321,
                "script_ok": true,
                "measurement_frame_bytes": 90,
                "decode_measurement": 11,
                "decode_measurement_zero_nav": 12,
                "crc_measurement": 13,
                "command_frame_bytes": 120,
                "encode_command": 14,
                "telemetry_frame_bytes": 60,
                "encode_telemetry": 15,
                "follow_schedule": 16,
                "config_frame_bytes": 467,
                "decode_config": 17,
                "apply_config": 18,
                "mavlink_rx_bytes": 161,
                "mavlink_decode": 19,
                "mavlink_nav": 20,
                "mavlink_tx_bytes": 72,
                "mavlink_encode": 21,
                "mavlink_quaternion": 22,
            })
        );
        // Every path once, by its name.
        let names: Vec<&str> = v["step"]
            .as_object()
            .expect("step is an object")
            .keys()
            .map(String::as_str)
            .collect();
        let mut sorted = PATHS.to_vec();
        sorted.sort_unstable();
        assert_eq!(names, sorted, "every path once");
        assert_eq!(PATHS.len(), c.step.len());
        // A stack the counter does not measure is JSON's null, and the flag false is false.
        c.step_stack_bytes = None;
        c.script_ok = false;
        let v = parse(&c, "instructions");
        assert_eq!(v["unit"], "instructions");
        assert_eq!(v["step_stack_bytes"], Value::Null);
        assert_eq!(v["script_ok"], false);
    }

    #[test]
    fn the_script_visits_every_path_and_measures_real_frames() {
        let c = measure::<NoCounter>();
        assert!(c.script_ok, "{c:?}");
        assert!(c.steps > 300, "{c:?}");
        assert!((83..=99).contains(&c.measurement_frame_len), "{c:?}");
        assert!((102..=138).contains(&c.command_frame_len), "{c:?}");
        assert!((86..=359).contains(&c.telemetry_frame_len), "{c:?}");
        // The longest bursts each way (MAVLink 2 drops a payload's trailing zeros: at most
        // the longest).
        assert!(
            (200..=MAX_TELEMETRY_LEN).contains(&c.mavlink_rx_len),
            "{c:?}"
        );
        assert!((120..=MAX_BURST_LEN).contains(&c.mavlink_tx_len), "{c:?}");
        assert_eq!(c.decode_measurement, 0); // no counter on the host
        // The default configuration's write: 540 bytes of postcard (`core/src/wire.rs`) in a
        // 548-byte frame.
        assert_eq!(c.config_frame_len, 548, "{c:?}");
        assert_eq!(c.step_stack_bytes, None);
    }
}
