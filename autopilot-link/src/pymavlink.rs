//! The codec checked by an implementation we did not write: pymavlink
//! (`autopilot-link/tests/mavlink_check.py`). Our frames decoded by pymavlink's `common` dialect,
//! field by field (and the parameter requests' CRC extra compared with ours); pymavlink's
//! frames (`ardupilotmega` dialect) decoded by ours into a navigation sample, the autopilot's
//! mode and its attitude time constants. pymavlink missing fails the tests, saying how
//! to install it (`pip install pymavlink`; `scripts/test-all.sh` does).
#![allow(clippy::unwrap_used)]

use super::*;
use serde_json::{Value, json};
use std::path::PathBuf;
use std::process::Command;

/// The checker script.
const SCRIPT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/mavlink_check.py");

/// Fails (not skips) when python3 or pymavlink is missing.
fn require_pymavlink() {
    let ok = Command::new("python3")
        .args(["-c", "import pymavlink"])
        .status()
        .is_ok_and(|s| s.success());
    assert!(
        ok,
        "python3 with pymavlink is required by the MAVLink cross-check: pip install pymavlink \
         (scripts/test-all.sh installs it; on Debian: apt-get install -y python3-pip, then \
         pip install --break-system-packages pymavlink)"
    );
}

/// A fresh path in the temporary directory for this test's `name`.
fn temp(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("ibvs-mavlink-{}-{name}", std::process::id()))
}

/// Runs the script with `args`; its status, stdout and stderr.
fn run(args: &[&std::ffi::OsStr]) -> (bool, String) {
    let out = Command::new("python3")
        .arg(SCRIPT)
        .args(args)
        .output()
        .unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    (out.status.success(), text)
}

/// Our stream: heartbeats and setpoints, 300 frames (the sequence wraps), with what
/// pymavlink must read from each.
fn our_stream() -> (Vec<u8>, Vec<Value>) {
    let ids = LinkIds::default();
    let mut e = Encoder::new(ids);
    let (mut bytes, mut expected) = (Vec::new(), Vec::new());
    let mut buf = [0u8; MAX_SENT_FRAME_LEN];
    let track = 2.5_f32;
    for i in 0..300u32 {
        let seq = e.next_sequence();
        let header = |name: &str, fields: Value| {
            json!({"name": name, "seq": seq, "src_system": 1, "src_component": 191,
                   "fields": fields})
        };
        if i % 50 == 0 {
            let n = e.heartbeat(&mut buf).unwrap();
            bytes.extend_from_slice(&buf[..n]);
            expected.push(header(
                "HEARTBEAT",
                json!({"type": 18, "autopilot": 8, "base_mode": 0, "custom_mode": 0,
                       "system_status": 4, "mavlink_version": 3}),
            ));
            continue;
        }
        let k = i as f32;
        let sp = AttitudeSetpoint {
            roll_rad: 0.5 * libm::sinf(0.1 * k),
            pitch_rad: 0.2 * libm::cosf(0.07 * k),
            yaw_rad: 0.3 * libm::sinf(0.05 * k),
            throttle: (k / 300.0).clamp(0.0, 1.0),
        };
        let time_boot_ms = 1_000 + 20 * i;
        let n = e
            .attitude_target(&sp, track, time_boot_ms, &mut buf)
            .unwrap();
        bytes.extend_from_slice(&buf[..n]);
        let q = quaternion_zyx(sp.roll_rad, sp.pitch_rad, wrap_pi(track + sp.yaw_rad));
        expected.push(header(
            "SET_ATTITUDE_TARGET",
            json!({"time_boot_ms": time_boot_ms, "target_system": 1, "target_component": 1,
                   "type_mask": 7, "q": q, "thrust": sp.throttle,
                   "body_roll_rate": 0.0, "body_pitch_rate": 0.0, "body_yaw_rate": 0.0}),
        ));
    }
    (bytes, expected)
}

/// Writes our stream and its expectations; runs the check on `bytes` (maybe altered).
fn check_stream(name: &str, bytes: &[u8], expected: &[Value]) -> (bool, String) {
    let (frames, want) = (temp(&format!("{name}.bin")), temp(&format!("{name}.json")));
    std::fs::write(&frames, bytes).unwrap();
    std::fs::write(&want, serde_json::to_vec(expected).unwrap()).unwrap();
    let result = run(&["check".as_ref(), frames.as_os_str(), want.as_os_str()]);
    let _ = (std::fs::remove_file(frames), std::fs::remove_file(want));
    result
}

#[test]
fn pymavlink_decodes_our_heartbeats_and_setpoints() {
    require_pymavlink();
    let (bytes, expected) = our_stream();
    let (ok, text) = check_stream("ours", &bytes, &expected);
    assert!(ok, "pymavlink check failed:\n{text}");
    assert!(text.contains("300 messages checked, 0 errors"), "{text}");
}

#[test]
fn the_pymavlink_check_fails_on_a_bad_crc_or_a_wrong_value() {
    // The check can fail: one payload bit flipped, and a field expected wrong.
    require_pymavlink();
    let (bytes, expected) = our_stream();
    let mut corrupt = bytes.clone();
    corrupt[21 + 15] ^= 0x01; // the second frame's payload
    let (ok, text) = check_stream("corrupt", &corrupt, &expected);
    assert!(!ok && text.contains("CRC"), "a bad CRC passed:\n{text}");
    let mut wrong = expected.clone();
    wrong[1]["fields"]["type_mask"] = json!(6);
    let (ok, text) = check_stream("wrong", &bytes, &wrong);
    assert!(
        !ok && text.contains("type_mask"),
        "a wrong value passed:\n{text}"
    );
}

/// The autopilot's messages pymavlink encodes, and the values they carry.
fn autopilot_values() -> Value {
    json!({
        "src_system": 1, "src_component": 1,
        "messages": [
            {"name": "HEARTBEAT", "fields": {"type": 1, "autopilot": 3, "base_mode": 217,
                "custom_mode": 15, "system_status": 4}},
            {"name": "ATTITUDE", "fields": {"time_boot_ms": 5000, "roll": -0.12,
                "pitch": 0.13, "yaw": 1.9, "rollspeed": 0.02, "pitchspeed": -0.01,
                "yawspeed": 0.04}},
            {"name": "LOCAL_POSITION_NED", "fields": {"time_boot_ms": 5000, "x": 1200.0,
                "y": -300.0, "z": -4500.0, "vx": -40.0, "vy": 130.0, "vz": 1.5}},
            {"name": "VFR_HUD", "fields": {"airspeed": 110.0, "groundspeed": 136.0,
                "heading": 107, "throttle": 45, "alt": 4500.0, "climb": -1.5}},
            {"name": "AOA_SSA", "fields": {"time_usec": 5_000_000u64, "AOA": 5.5,
                "SSA": 0.8}},
            // A message the decoder does not read: counted as unused.
            {"name": "SYSTEM_TIME", "fields": {"time_unix_usec": 1u64, "time_boot_ms": 5000}},
        ]
    })
}

/// pymavlink's frames of `values` (the script's `make`), written under this test's `name`.
fn pymavlink_frames(name: &str, values: &Value) -> Vec<u8> {
    let (values_path, out) = (temp(&format!("{name}.json")), temp(&format!("{name}.bin")));
    std::fs::write(&values_path, serde_json::to_vec(values).unwrap()).unwrap();
    let (ok, text) = run(&["make".as_ref(), values_path.as_os_str(), out.as_os_str()]);
    assert!(ok, "pymavlink could not encode:\n{text}");
    let bytes = std::fs::read(&out).unwrap();
    let _ = (std::fs::remove_file(values_path), std::fs::remove_file(out));
    bytes
}

#[test]
fn our_decoder_reads_pymavlinks_frames_into_a_nav_sample_and_mode() {
    require_pymavlink();
    let bytes = pymavlink_frames("autopilot", &autopilot_values());
    let mut d = Decoder::new(LinkIds::default());
    let got: Vec<_> = bytes.iter().filter_map(|&b| d.push(b, 5000)).collect();
    assert_eq!(
        got,
        [
            Received::Heartbeat,
            Received::Attitude,
            Received::LocalPositionNed,
            Received::VfrHud,
            Received::AoaSsa
        ]
    );
    let c = *d.counters();
    assert_eq!(
        (c.frames_used, c.unused, c.bad_crc, c.noise_bytes),
        (5, 1, 0, 0)
    );
    assert_eq!((c.dropped, c.unknown_id), (0, 0));

    let st = d.autopilot(5400);
    assert_eq!(st.mode, AutopilotMode::Guided);
    assert!(st.armed, "base_mode 217 has SAFETY_ARMED");
    assert_eq!(st.age_ms, Some(400));

    let track = 1.8_f32;
    let cfg = NavConfig {
        track_rad: track,
        tanker_speed_mps: 135.0,
        ..NavConfig::default()
    };
    let fix = d.nav_sample(5050, &cfg).unwrap();
    let n = fix.sample;
    let sigma = libm::powf(1.0 - 2.255_77e-5 * 4500.0, 4.255_88);
    let tas = 110.0 / libm::sqrtf(sigma);
    assert!((n.condition.true_airspeed_mps - tas).abs() < 1e-3, "{n:?}");
    assert_eq!(n.condition.altitude_m, 4500.0);
    let trim = schedule::design_at(n.condition).unwrap().trim;
    let near = |a: f32, b: f32| (a - b).abs() < 1e-5;
    assert!(near(n.lat.psi_rad, 1.9 - track));
    assert!(near(n.lat.phi_rad, -0.12));
    assert!(near(n.lon.theta_rad, 0.13 - trim.theta_rad));
    assert!(near(n.lon.alpha_rad, 5.5f32.to_radians() - trim.alpha_rad));
    assert!(near(n.lat.beta_rad, 0.8f32.to_radians()));
    assert!(near(n.lon.v_mps, libm::hypotf(-40.0, 130.0) - 135.0));
    assert_eq!(
        [n.lat.p_radps, n.lon.q_radps, n.lat.r_radps],
        [0.02, -0.01, 0.04]
    );
    assert!(near(n.lon.h_up_m, 4500.0));
    assert_eq!(
        (fix.alpha, fix.beta),
        (AlphaSource::AoaSsa, BetaSource::AoaSsa)
    );
}

/// Our `PARAM_REQUEST_READ`s of both autopilots' time constants, with what pymavlink must
/// read from each (its CRC extra ours).
fn our_param_requests() -> (Vec<u8>, Vec<Value>) {
    let mut e = Encoder::new(LinkIds::default());
    let (mut bytes, mut expected) = (Vec::new(), Vec::new());
    let mut buf = [0u8; MAX_SENT_FRAME_LEN];
    let crc_extra = MavMessage::extra_crc(PARAM_REQUEST_READ_DATA::ID);
    for kind in [AutopilotKind::ArduPlane, AutopilotKind::Px4] {
        for name in kind.time_constant_params() {
            let seq = e.next_sequence();
            let n = e.param_request_read(name, &mut buf).unwrap();
            bytes.extend_from_slice(&buf[..n]);
            expected.push(
                json!({"name": "PARAM_REQUEST_READ", "seq": seq, "src_system": 1,
                "src_component": 191, "crc_extra": crc_extra,
                "fields": {"target_system": 1, "target_component": 1, "param_id": name,
                           "param_index": -1}}),
            );
        }
    }
    (bytes, expected)
}

#[test]
fn pymavlink_decodes_our_param_requests() {
    require_pymavlink();
    let (bytes, expected) = our_param_requests();
    let (ok, text) = check_stream("params", &bytes, &expected);
    assert!(ok, "pymavlink check failed:\n{text}");
    assert!(text.contains("4 messages checked, 0 errors"), "{text}");
    // The check can fail: a CRC extra, a name or the index expected wrong.
    for (field, wrong) in [
        ("crc_extra", json!(215)),
        ("param_id", json!("PTCH2SRV_TCONS")),
        ("param_index", json!(0)),
    ] {
        let mut bad = expected.clone();
        if field == "crc_extra" {
            bad[0][field] = wrong;
        } else {
            bad[0]["fields"][field] = wrong;
        }
        let (ok, text) = check_stream("params-wrong", &bytes, &bad);
        let said = if field == "crc_extra" {
            "CRC extra"
        } else {
            field
        };
        assert!(
            !ok && text.contains(said),
            "a wrong {field} passed:\n{text}"
        );
    }
}

#[test]
fn our_decoder_reads_pymavlinks_param_values_into_the_time_constants() {
    require_pymavlink();
    let param = |id: &str, value: f32, param_type: u8| {
        json!({"name": "PARAM_VALUE", "fields": {"param_id": id, "param_value": value,
            "param_type": param_type, "param_count": 1200, "param_index": 300}})
    };
    let values = json!({
        "src_system": 1, "src_component": 1,
        "messages": [
            param("RLL2SRV_TCONST", 0.42, 9),
            param("PTCH2SRV_TCONST", 0.38, 9),
            // Another parameter: unused; a zero time constant: refused.
            param("RLL2SRV_RMAX", 75.0, 9),
            param("PTCH2SRV_TCONST", 0.0, 9),
        ]
    });
    let bytes = pymavlink_frames("params", &values);
    let mut d = Decoder::new(LinkIds::default());
    let got: Vec<_> = bytes.iter().filter_map(|&b| d.push(b, 900)).collect();
    assert_eq!(
        got,
        [
            Received::TimeConstant(Axis::Roll),
            Received::TimeConstant(Axis::Pitch)
        ]
    );
    let c = *d.counters();
    assert_eq!(
        (
            c.frames_used,
            c.unused,
            c.param_refused,
            c.bad_crc,
            c.noise_bytes
        ),
        (2, 1, 1, 0, 0)
    );
    let tc = d.attitude_time_constants();
    assert_eq!((tc.pitch_s, tc.roll_s), (Some(0.38), Some(0.42)));
    assert_eq!((tc.pitch_at_ms, tc.roll_at_ms), (Some(900), Some(900)));
    let cfg = tc.apply_to(ibvs_core::attitude::AttitudeLoopConfig::default());
    assert_eq!(
        (cfg.pitch_time_constant_s, cfg.roll_time_constant_s),
        (0.38, 0.42)
    );
}
