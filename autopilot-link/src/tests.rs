//! Host tests of the MAVLink 2 codec: through the crate and back, and the decoder's
//! counters, freshness and mode rules.
#![allow(clippy::unwrap_used)]

use super::*;
use ::mavlink::dialects::ardupilotmega::SYS_STATUS_DATA;
use ibvs_core::gains::TRIM;

const ABS: f32 = 1e-6;

fn close(a: f32, b: f32, tol: f32) -> bool {
    (a - b).abs() <= tol
}

/// A MAVLink 2 frame of `data` from `sys`/`comp` with sequence `seq`, by the crate.
fn frame_of<D: MessageData>(data: &D, sys: u8, comp: u8, seq: u8) -> Vec<u8> {
    let mut raw = MAVLinkV2MessageRaw::new();
    let header = MavHeader {
        system_id: u32::from(sys),
        component_id: comp,
        sequence: seq,
    };
    raw.serialize_message_data(header, data);
    raw.raw_bytes().to_vec()
}

/// Feeds every byte at `now_ms`; the messages read.
fn feed(d: &mut Decoder, bytes: &[u8], now_ms: u32) -> Vec<Received> {
    bytes.iter().filter_map(|&b| d.push(b, now_ms)).collect()
}

/// Parses one whole frame with the crate (CRC checked) into its header and message.
fn crate_parse(bytes: &[u8]) -> (MAVLinkV2MessageRaw, MavMessage) {
    let mut raw = MAVLinkV2MessageRaw::new();
    raw.as_mut_slice()[..bytes.len()].copy_from_slice(bytes);
    assert!(raw.has_valid_crc::<MavMessage>(), "crate rejects the CRC");
    let msg = MavMessage::parse(MavlinkVersion::V2, raw.message_id(), raw.payload()).unwrap();
    (raw, msg)
}

fn setpoint() -> AttitudeSetpoint {
    AttitudeSetpoint {
        roll_rad: 0.2,
        pitch_rad: 0.1,
        yaw_rad: -0.05,
        throttle: 0.4,
    }
}

#[test]
fn heartbeat_round_trips_through_the_crate() {
    let mut e = Encoder::new(LinkIds::default());
    let mut buf = [0u8; MAX_SENT_FRAME_LEN];
    let n = e.heartbeat(&mut buf).unwrap();
    assert_eq!(buf[0], 0xFD, "MAVLink 2 start byte");
    let (raw, msg) = crate_parse(&buf[..n]);
    assert_eq!((raw.system_id(), raw.component_id()), (1, 191));
    let MavMessage::HEARTBEAT(hb) = msg else {
        panic!("not a heartbeat: {msg:?}")
    };
    assert_eq!(hb.mavtype, MavType::MAV_TYPE_ONBOARD_CONTROLLER);
    assert_eq!(hb.autopilot, MavAutopilot::MAV_AUTOPILOT_INVALID);
    assert_eq!(hb.mavlink_version, 3);
}

#[test]
fn attitude_target_round_trips_with_type_mask_7_and_target_ids() {
    let ids = LinkIds {
        autopilot_system: 7,
        autopilot_component: 9,
        ..LinkIds::default()
    };
    let mut e = Encoder::new(ids);
    let mut buf = [0u8; MAX_SENT_FRAME_LEN];
    let track = 1.0;
    let n = e
        .attitude_target(&setpoint(), track, 123_456, &mut buf)
        .unwrap();
    let (_, msg) = crate_parse(&buf[..n]);
    let MavMessage::SET_ATTITUDE_TARGET(t) = msg else {
        panic!("not SET_ATTITUDE_TARGET: {msg:?}")
    };
    assert_eq!(t.type_mask.bits(), 7);
    assert_eq!(ATTITUDE_TYPE_MASK, 0b111);
    assert_eq!((t.target_system, t.target_component), (7, 9));
    assert_eq!(t.time_boot_ms, 123_456);
    assert_eq!(t.thrust, 0.4);
    assert_eq!(t.q, quaternion_zyx(0.2, 0.1, track - 0.05));
}

#[test]
fn quaternion_of_known_angles() {
    let h = core::f32::consts::FRAC_1_SQRT_2;
    let cases = [
        ((0.0, 0.0, 0.0), [1.0, 0.0, 0.0, 0.0]),
        // 90 deg about each axis alone.
        ((core::f32::consts::FRAC_PI_2, 0.0, 0.0), [h, h, 0.0, 0.0]),
        ((0.0, core::f32::consts::FRAC_PI_2, 0.0), [h, 0.0, h, 0.0]),
        ((0.0, 0.0, core::f32::consts::FRAC_PI_2), [h, 0.0, 0.0, h]),
        // Heading 180 deg.
        ((0.0, 0.0, core::f32::consts::PI), [0.0, 0.0, 0.0, 1.0]),
        // 30 deg bank, 10 deg pitch, 45 deg heading: the quaternion of the rotation matrix
        // Rz(45) Ry(10) Rx(30), worked out in double precision apart from this code.
        (
            (30f32.to_radians(), 10f32.to_radians(), 45f32.to_radians()),
            [0.897_635_7, 0.205_991_1, 0.176_446_6, 0.347_396_7],
        ),
    ];
    for ((r, p, y), want) in cases {
        let q = quaternion_zyx(r, p, y);
        for (a, b) in q.iter().zip(want) {
            assert!(close(*a, b, 2e-6), "{r} {p} {y}: {q:?} != {want:?}");
        }
    }
}

#[test]
fn sequence_increments_per_frame_and_wraps() {
    let mut e = Encoder::new(LinkIds::default());
    let mut buf = [0u8; MAX_SENT_FRAME_LEN];
    for i in 0..=300u32 {
        let n = if i % 2 == 0 {
            e.heartbeat(&mut buf).unwrap()
        } else {
            e.attitude_target(&setpoint(), 0.0, i, &mut buf).unwrap()
        };
        let (raw, _) = crate_parse(&buf[..n]);
        assert_eq!(u32::from(raw.sequence()), i % 256);
    }
    assert_eq!(e.next_sequence(), (301 % 256) as u8);
}

#[test]
fn refused_setpoints_write_nothing_and_use_no_sequence_number() {
    let mut e = Encoder::new(LinkIds::default());
    let mut small = [0u8; 20];
    assert_eq!(
        e.attitude_target(&setpoint(), 0.0, 0, &mut small),
        Err(EncodeError::BufferTooSmall {
            needed: 12 + 39,
            available: 20
        })
    );
    assert_eq!(small, [0u8; 20]);
    let mut buf = [0u8; MAX_SENT_FRAME_LEN];
    let nan = AttitudeSetpoint {
        pitch_rad: f32::NAN,
        ..setpoint()
    };
    assert_eq!(
        e.attitude_target(&nan, 0.0, 0, &mut buf),
        Err(EncodeError::NonFinite)
    );
    assert_eq!(
        e.attitude_target(&setpoint(), f32::INFINITY, 0, &mut buf),
        Err(EncodeError::NonFinite)
    );
    let over = AttitudeSetpoint {
        throttle: 1.01,
        ..setpoint()
    };
    assert_eq!(
        e.attitude_target(&over, 0.0, 0, &mut buf),
        Err(EncodeError::ThrottleOutOfRange)
    );
    assert_eq!(e.next_sequence(), 0);
}

#[test]
fn heartbeat_is_due_once_a_second_across_the_clock_wrap() {
    let mut e = Encoder::new(LinkIds::default());
    let start = u32::MAX - 1500;
    assert!(e.heartbeat_due(start));
    assert!(!e.heartbeat_due(start + 999));
    assert!(e.heartbeat_due(start + 1000));
    assert!(!e.heartbeat_due(start.wrapping_add(1999)));
    assert!(e.heartbeat_due(start.wrapping_add(2000)), "after the wrap");
}

/// The autopilot's messages at a steady level turn onto the track, as frames.
struct Stream {
    seq: u8,
}

impl Stream {
    fn frame<D: MessageData>(&mut self, data: &D) -> Vec<u8> {
        let f = frame_of(data, 1, 1, self.seq);
        self.seq = self.seq.wrapping_add(1);
        f
    }
}

fn attitude() -> ATTITUDE_DATA {
    ATTITUDE_DATA {
        time_boot_ms: 1,
        roll: 0.1,
        pitch: 0.15,
        yaw: 0.6,
        rollspeed: 0.01,
        pitchspeed: -0.02,
        yawspeed: 0.03,
    }
}

fn local() -> LOCAL_POSITION_NED_DATA {
    LOCAL_POSITION_NED_DATA {
        time_boot_ms: 1,
        x: 100.0,
        y: 50.0,
        z: -3000.0,
        vx: 120.0,
        vy: 5.0,
        vz: -2.0,
    }
}

fn hud() -> VFR_HUD_DATA {
    VFR_HUD_DATA {
        airspeed: 103.0,
        groundspeed: 120.1,
        alt: 3000.0,
        climb: 2.0,
        heading: 34,
        throttle: 40,
    }
}

fn aoa() -> AOA_SSA_DATA {
    AOA_SSA_DATA {
        time_usec: 1,
        AOA: 6.0,
        SSA: -1.5,
    }
}

fn all_messages(s: &mut Stream) -> Vec<u8> {
    [
        s.frame(&attitude()),
        s.frame(&local()),
        s.frame(&hud()),
        s.frame(&aoa()),
    ]
    .concat()
}

#[test]
fn a_fresh_set_of_messages_makes_the_documented_sample() {
    let mut d = Decoder::new(LinkIds::default());
    let mut s = Stream { seq: 0 };
    let got = feed(&mut d, &all_messages(&mut s), 1000);
    assert_eq!(
        got,
        [
            Received::Attitude,
            Received::LocalPositionNed,
            Received::VfrHud,
            Received::AoaSsa
        ]
    );
    let cfg = NavConfig {
        track_rad: 0.5,
        tanker_speed_mps: 118.0,
        ..NavConfig::default()
    };
    let fix = d.nav_sample(1050, &cfg).unwrap();
    let n = fix.sample;
    // EAS 103 m/s at 3000 m ISA (sigma 0.7421): TAS 119.57 m/s.
    assert!(close(n.condition.true_airspeed_mps, 119.57, 0.02), "{n:?}");
    assert_eq!(n.condition.altitude_m, 3000.0);
    let trim = schedule::design_at(n.condition).unwrap().trim;
    assert!(close(n.lat.psi_rad, 0.1, ABS));
    assert!(close(n.lat.phi_rad, 0.1, ABS));
    assert!(close(n.lon.theta_rad, 0.15 - trim.theta_rad, ABS));
    assert!(close(
        n.lon.alpha_rad,
        6f32.to_radians() - trim.alpha_rad,
        ABS
    ));
    assert!(close(n.lat.beta_rad, (-1.5f32).to_radians(), ABS));
    assert!(close(n.lon.v_mps, libm::hypotf(120.0, 5.0) - 118.0, 1e-4));
    assert_eq!(
        [n.lat.p_radps, n.lon.q_radps, n.lat.r_radps],
        [0.01, -0.02, 0.03]
    );
    assert!(close(n.lon.h_up_m, 3000.0, ABS));
    let (st, ct) = (0.5f32.sin(), 0.5f32.cos());
    assert!(close(n.lon.x_fwd_m, 100.0 * ct + 50.0 * st, 1e-3));
    assert!(close(n.lat.y_right_m, -100.0 * st + 50.0 * ct, 1e-3));
    assert_eq!(
        (fix.alpha, fix.beta),
        (AlphaSource::AoaSsa, BetaSource::AoaSsa)
    );
    assert_eq!(d.counters().frames_used, 4);
    assert_eq!(d.counters().dropped, 0);
}

#[test]
fn without_aoa_ssa_alpha_is_pitch_minus_path_angle_and_beta_zero() {
    let mut d = Decoder::new(LinkIds::default());
    let mut s = Stream { seq: 0 };
    feed(&mut d, &all_messages(&mut s), 0);
    let cfg = NavConfig::default();
    // AOA_SSA older than its 200 ms; the others refreshed.
    let rest = [s.frame(&attitude()), s.frame(&local()), s.frame(&hud())].concat();
    feed(&mut d, &rest, 250);
    let fix = d.nav_sample(260, &cfg).unwrap();
    assert_eq!(
        (fix.alpha, fix.beta),
        (AlphaSource::PitchMinusPathAngle, BetaSource::AssumedZero)
    );
    let trim = schedule::design_at(fix.sample.condition).unwrap().trim;
    let gamma = libm::atan2f(2.0, libm::hypotf(120.0, 5.0));
    assert!(close(
        fix.sample.lon.alpha_rad,
        0.15 - gamma - trim.alpha_rad,
        ABS
    ));
    assert_eq!(fix.sample.lat.beta_rad, 0.0);
}

#[test]
fn global_position_int_serves_when_local_position_is_absent() {
    let mut d = Decoder::new(LinkIds::default());
    let mut s = Stream { seq: 0 };
    let global = GLOBAL_POSITION_INT_DATA {
        relative_alt: 2_500_000,
        vx: 12_000,
        vy: 500,
        vz: 200,
        ..GLOBAL_POSITION_INT_DATA::DEFAULT
    };
    let bytes = [s.frame(&attitude()), s.frame(&global), s.frame(&hud())].concat();
    feed(&mut d, &bytes, 0);
    let fix = d.nav_sample(10, &NavConfig::default()).unwrap();
    let n = fix.sample;
    assert!(close(
        n.lon.v_mps,
        libm::hypotf(120.0, 5.0) - TRIM.speed_mps,
        1e-4
    ));
    assert!(close(n.lon.h_up_m, 2500.0, ABS));
    assert_eq!((n.lon.x_fwd_m, n.lat.y_right_m), (0.0, 0.0));
    // vz 2 m/s down: the path angle is negative, alpha larger than pitch.
    let gamma = libm::atan2f(-2.0, libm::hypotf(120.0, 5.0));
    let trim = schedule::design_at(n.condition).unwrap().trim;
    assert!(close(n.lon.alpha_rad, 0.15 - gamma - trim.alpha_rad, ABS));
}

#[test]
fn a_missing_or_stale_message_is_a_named_counted_error() {
    let mut d = Decoder::new(LinkIds::default());
    let cfg = NavConfig::default();
    assert_eq!(
        d.nav_sample(0, &cfg),
        Err(NavBuildError::Missing(NavSource::Attitude))
    );
    let mut s = Stream { seq: 0 };
    feed(&mut d, &s.frame(&attitude()), 0);
    assert_eq!(
        d.nav_sample(0, &cfg),
        Err(NavBuildError::Missing(NavSource::Velocity))
    );
    feed(&mut d, &s.frame(&local()), 0);
    assert_eq!(
        d.nav_sample(0, &cfg),
        Err(NavBuildError::Missing(NavSource::AirData))
    );
    feed(&mut d, &s.frame(&hud()), 0);
    assert!(d.nav_sample(100, &cfg).is_ok(), "every age at its limit");
    assert_eq!(
        d.nav_sample(101, &cfg),
        Err(NavBuildError::Stale(NavSource::Attitude))
    );
    feed(&mut d, &s.frame(&attitude()), 101);
    assert_eq!(
        d.nav_sample(101, &cfg),
        Err(NavBuildError::Stale(NavSource::Velocity))
    );
    feed(&mut d, &s.frame(&local()), 501);
    feed(&mut d, &s.frame(&attitude()), 501);
    assert_eq!(
        d.nav_sample(501, &cfg),
        Err(NavBuildError::Stale(NavSource::AirData))
    );
    let c = d.counters();
    assert_eq!((c.nav_missing, c.nav_stale), (3, 3));
}

#[test]
fn a_condition_outside_the_schedule_is_refused_and_counted() {
    let mut d = Decoder::new(LinkIds::default());
    let mut s = Stream { seq: 0 };
    let slow = VFR_HUD_DATA {
        airspeed: 40.0,
        ..hud()
    };
    let bytes = [s.frame(&attitude()), s.frame(&local()), s.frame(&slow)].concat();
    feed(&mut d, &bytes, 0);
    assert_eq!(
        d.nav_sample(0, &NavConfig::default()),
        Err(NavBuildError::Schedule(ScheduleError::AirspeedLow))
    );
    assert_eq!(d.counters().nav_schedule, 1);
}

#[test]
fn a_bad_crc_is_counted_and_the_next_frame_still_read() {
    let mut d = Decoder::new(LinkIds::default());
    let mut s = Stream { seq: 0 };
    let mut bad = s.frame(&attitude());
    bad[14] ^= 0x40; // a payload byte
    let good = s.frame(&hud());
    let got = feed(&mut d, &[bad, good].concat(), 0);
    assert_eq!(got, [Received::VfrHud]);
    assert_eq!(d.counters().bad_crc, 1);
    assert_eq!(d.counters().frames_used, 1);
    assert!(d.latest.attitude.is_none());
}

#[test]
fn other_systems_other_components_unknown_and_unused_ids_are_counted() {
    let mut d = Decoder::new(LinkIds::default());
    let from_gcs = frame_of(&attitude(), 255, 190, 0);
    let from_gimbal = frame_of(&attitude(), 1, 154, 0);
    let unused = frame_of(&SYS_STATUS_DATA::DEFAULT, 1, 1, 0);
    let mut unknown = frame_of(&attitude(), 1, 1, 1);
    unknown[7..10].copy_from_slice(&[0x34, 0x12, 0x00]); // message id 0x1234: not defined
    let noise = [0x00, 0x55, 0xFE];
    let got = feed(
        &mut d,
        &[&noise[..], &from_gcs, &from_gimbal, &unused, &unknown].concat(),
        0,
    );
    assert!(got.is_empty());
    let c = d.counters();
    assert_eq!(c.noise_bytes, 3);
    assert_eq!(c.other_system, 1);
    assert_eq!(c.other_component, 1);
    assert_eq!(c.unused, 1);
    assert_eq!(c.unknown_id, 1);
    assert_eq!(c.frames_used, 0);
    assert!(d.latest.attitude.is_none());
}

#[test]
fn unsupported_flags_are_counted_and_signed_frames_flagged() {
    let mut d = Decoder::new(LinkIds::default());
    let mut sysid32 = frame_of(&attitude(), 1, 1, 0);
    sysid32[2] = 0x02;
    feed(&mut d, &sysid32, 0);
    assert_eq!(d.counters().bad_flags, 1);
    // A signed frame: flag set, CRC over the header with the flag, 13 signature bytes.
    let mut raw = MAVLinkV2MessageRaw::new();
    *raw.incompatibility_flags_mut() = consts::v2::IFLAG_SIGNED;
    let header = MavHeader {
        system_id: 1,
        component_id: 1,
        sequence: 1,
    };
    raw.serialize_message_data(header, &attitude());
    let signed = raw.raw_bytes().to_vec();
    assert_eq!(signed.len(), 12 + 28 + 13);
    assert_eq!(feed(&mut d, &signed, 0), [Received::Attitude]);
    assert_eq!(d.counters().signed_unverified, 1);
}

#[test]
fn sequence_gaps_are_counted_per_component() {
    let mut d = Decoder::new(LinkIds::default());
    let frames = [
        frame_of(&attitude(), 1, 1, 254),
        frame_of(&attitude(), 1, 1, 255),
        frame_of(&attitude(), 1, 1, 2), // 0 and 1 lost across the wrap
        frame_of(&attitude(), 1, 154, 10),
        frame_of(&attitude(), 1, 154, 11),
        frame_of(&attitude(), 1, 1, 3),
        frame_of(&attitude(), 1, 154, 15), // 12..14 lost
    ]
    .concat();
    feed(&mut d, &frames, 0);
    assert_eq!(d.counters().dropped, 5);
}

/// A heartbeat of `autopilot` and `mavtype` in `custom_mode`.
fn heartbeat(autopilot: MavAutopilot, mavtype: MavType, custom_mode: u32) -> HEARTBEAT_DATA {
    HEARTBEAT_DATA {
        custom_mode,
        mavtype,
        autopilot,
        base_mode: MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
            | MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED,
        system_status: MavState::MAV_STATE_ACTIVE,
        mavlink_version: 3,
    }
}

#[test]
fn mode_decode_for_arduplane_and_px4() {
    use MavAutopilot::{MAV_AUTOPILOT_ARDUPILOTMEGA as APM, MAV_AUTOPILOT_PX4 as PX4};
    use MavType::{MAV_TYPE_FIXED_WING as PLANE, MAV_TYPE_QUADROTOR as QUAD};
    let mode = |a, t, m| AutopilotMode::from_heartbeat(&heartbeat(a, t, m));
    assert_eq!(mode(APM, PLANE, 15), AutopilotMode::Guided);
    assert_eq!(mode(APM, PLANE, 10), AutopilotMode::Other(10)); // AUTO
    assert_eq!(mode(APM, QUAD, 15), AutopilotMode::Unknown); // Copter's numbers differ
    // PX4: main mode in bits 16..23, sub mode in 24..31.
    assert_eq!(mode(PX4, PLANE, 6 << 16), AutopilotMode::Offboard);
    assert_eq!(mode(PX4, QUAD, 6 << 16), AutopilotMode::Offboard);
    assert_eq!(
        mode(PX4, PLANE, (4 << 16) | (6 << 24)),
        AutopilotMode::Other((4 << 16) | (6 << 24))
    ); // AUTO, sub mode 6 (not OFFBOARD)
    assert_eq!(
        mode(MavAutopilot::MAV_AUTOPILOT_GENERIC, PLANE, 15),
        AutopilotMode::Unknown
    );
    assert!(AutopilotMode::Guided.accepts_setpoints());
    assert!(AutopilotMode::Offboard.accepts_setpoints());
    assert!(!AutopilotMode::Other(15).accepts_setpoints());
    assert!(!AutopilotMode::Unknown.accepts_setpoints());
}

#[test]
fn the_autopilots_heartbeat_gives_its_mode_and_age() {
    let mut d = Decoder::new(LinkIds::default());
    assert_eq!(
        d.autopilot(0),
        AutopilotStatus {
            mode: AutopilotMode::Unknown,
            armed: false,
            age_ms: None
        }
    );
    let hb = heartbeat(
        MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        MavType::MAV_TYPE_FIXED_WING,
        ARDUPLANE_GUIDED,
    );
    assert_eq!(
        feed(&mut d, &frame_of(&hb, 1, 1, 0), 5000),
        [Received::Heartbeat]
    );
    let st = d.autopilot(7000);
    assert_eq!(st.mode, AutopilotMode::Guided);
    assert!(st.armed);
    assert_eq!(st.age_ms, Some(2000));
    assert!(st.accepts_setpoints(3000));
    assert!(
        !d.autopilot(8001).accepts_setpoints(3000),
        "stale heartbeat"
    );
    // Our own heartbeat echoed back (component 191) is not the autopilot's.
    let mut e = Encoder::new(LinkIds::default());
    let mut buf = [0u8; MAX_SENT_FRAME_LEN];
    let n = e.heartbeat(&mut buf).unwrap();
    feed(&mut d, &buf[..n], 7000);
    assert_eq!(d.autopilot(7000).mode, AutopilotMode::Guided);
    assert_eq!(d.counters().other_component, 1);
}

#[test]
fn only_component_information_has_crc_extra_zero() {
    // The decoder takes a CRC extra of 0 to mean "id unknown to the dialect", except for
    // COMPONENT_INFORMATION: check that every other known id has a non-zero CRC extra.
    // MAVLink ids are 24 bits; the dialect's are all below 65,536.
    for id in 0..=0xFFFFu32 {
        if MavMessage::extra_crc(id) == 0 {
            assert!(
                id == CRC_EXTRA_ZERO_ID || MavMessage::default_message_from_id(id).is_none(),
                "id {id} is known with CRC extra 0"
            );
        }
    }
    assert!(MavMessage::default_message_from_id(CRC_EXTRA_ZERO_ID).is_some());
}

#[test]
fn wrap_pi_wraps() {
    let pi = core::f32::consts::PI;
    assert!(close(wrap_pi(3.0 * pi / 2.0), -pi / 2.0, ABS));
    assert!(close(wrap_pi(-3.0 * pi / 2.0), pi / 2.0, ABS));
    assert!(close(wrap_pi(0.3), 0.3, ABS));
}

/// `PARAM_VALUE` of `name` with `value` of `param_type`, from the autopilot.
fn param_value(name: &str, value: f32, param_type: MavParamType) -> PARAM_VALUE_DATA {
    PARAM_VALUE_DATA {
        param_value: value,
        param_count: 900,
        param_index: 17,
        param_id: CharArray::from(name),
        param_type,
    }
}

#[test]
fn param_request_read_round_trips_by_name_to_the_autopilot() {
    let ids = LinkIds {
        autopilot_system: 7,
        autopilot_component: 9,
        ..LinkIds::default()
    };
    let mut e = Encoder::new(ids);
    let mut buf = [0u8; MAX_SENT_FRAME_LEN];
    for (i, kind) in [AutopilotKind::ArduPlane, AutopilotKind::Px4]
        .into_iter()
        .enumerate()
    {
        for (j, name) in kind.time_constant_params().into_iter().enumerate() {
            let n = e.param_request_read(name, &mut buf).unwrap();
            let (raw, msg) = crate_parse(&buf[..n]);
            assert_eq!((raw.system_id(), raw.component_id()), (1, 191));
            assert_eq!(usize::from(raw.sequence()), 2 * i + j);
            let MavMessage::PARAM_REQUEST_READ(r) = msg else {
                panic!("not PARAM_REQUEST_READ: {msg:?}")
            };
            assert_eq!(r.param_index, -1);
            assert_eq!((r.target_system, r.target_component), (7, 9));
            assert_eq!(r.param_id.to_str().unwrap(), name);
        }
    }
    // A 16-character name fills param_id with no NUL.
    let n = e.param_request_read("ABCDEFGHIJKLMNOP", &mut buf).unwrap();
    let (_, msg) = crate_parse(&buf[..n]);
    let MavMessage::PARAM_REQUEST_READ(r) = msg else {
        panic!("not PARAM_REQUEST_READ: {msg:?}")
    };
    assert_eq!(&*r.param_id, b"ABCDEFGHIJKLMNOP");
}

#[test]
fn the_time_constant_names_per_autopilot_kind() {
    assert_eq!(
        AutopilotKind::ArduPlane.time_constant_params(),
        ["PTCH2SRV_TCONST", "RLL2SRV_TCONST"]
    );
    assert_eq!(
        AutopilotKind::Px4.time_constant_params(),
        ["FW_P_TC", "FW_R_TC"]
    );
    let kind = |ap, ty| AutopilotKind::from_heartbeat(&heartbeat(ap, ty, 0));
    use MavAutopilot::{MAV_AUTOPILOT_ARDUPILOTMEGA as APM, MAV_AUTOPILOT_PX4 as PX4};
    use MavType::{MAV_TYPE_FIXED_WING as PLANE, MAV_TYPE_QUADROTOR as QUAD};
    assert_eq!(kind(APM, PLANE), Some(AutopilotKind::ArduPlane));
    assert_eq!(kind(PX4, PLANE), Some(AutopilotKind::Px4));
    assert_eq!(kind(APM, QUAD), None, "ArduCopter is not ArduPlane");
    assert_eq!(kind(MavAutopilot::MAV_AUTOPILOT_GENERIC, PLANE), None);

    let mut d = Decoder::new(LinkIds::default());
    assert_eq!(d.autopilot_kind(), None, "no heartbeat yet");
    let hb = frame_of(&heartbeat(PX4, PLANE, 0), 1, 1, 0);
    feed(&mut d, &hb, 0);
    assert_eq!(d.autopilot_kind(), Some(AutopilotKind::Px4));
}

#[test]
fn bad_param_names_are_refused_and_use_no_sequence_number() {
    let mut e = Encoder::new(LinkIds::default());
    let mut buf = [0xAAu8; MAX_SENT_FRAME_LEN];
    for name in ["", "ABCDEFGHIJKLMNOPQ", "FW\0P_TC"] {
        assert_eq!(
            e.param_request_read(name, &mut buf),
            Err(EncodeError::BadParamName),
            "{name:?}"
        );
    }
    // MAVLink 2 trims the payload's trailing zeros: 12 + 4 + 7 ("FW_P_TC") bytes.
    let mut short = [0u8; 22];
    assert_eq!(
        e.param_request_read(PX4_PITCH_TC, &mut short),
        Err(EncodeError::BufferTooSmall {
            needed: 23,
            available: 22
        })
    );
    assert!(buf.iter().all(|&b| b == 0xAA), "nothing written");
    assert_eq!(e.next_sequence(), 0);
}

#[test]
fn param_value_of_each_time_constant_sets_its_axis() {
    let real = MavParamType::MAV_PARAM_TYPE_REAL32;
    let cases = [
        ("PTCH2SRV_TCONST", Axis::Pitch),
        ("RLL2SRV_TCONST", Axis::Roll),
        ("FW_P_TC", Axis::Pitch),
        ("FW_R_TC", Axis::Roll),
    ];
    for (k, (name, axis)) in cases.into_iter().enumerate() {
        let mut d = Decoder::new(LinkIds::default());
        assert_eq!(
            d.attitude_time_constants(),
            AttitudeTimeConstants::default()
        );
        let value = 0.3 + 0.05 * k as f32;
        let got = feed(
            &mut d,
            &frame_of(&param_value(name, value, real), 1, 1, 0),
            40,
        );
        assert_eq!(got, [Received::TimeConstant(axis)], "{name}");
        let tc = d.attitude_time_constants();
        let (set, at, other) = match axis {
            Axis::Pitch => (tc.pitch_s, tc.pitch_at_ms, tc.roll_s),
            Axis::Roll => (tc.roll_s, tc.roll_at_ms, tc.pitch_s),
        };
        assert_eq!((set, at, other), (Some(value), Some(40), None), "{name}");
        assert!(!tc.complete());
        assert_eq!(d.counters().frames_used, 1);
    }

    // Both, then applied to the loop's configuration: only the two time constants change.
    let mut d = Decoder::new(LinkIds::default());
    let mut s = Stream { seq: 0 };
    let bytes = [
        s.frame(&param_value(ARDUPLANE_PITCH_TC, 0.4, real)),
        s.frame(&param_value(ARDUPLANE_ROLL_TC, 0.45, real)),
        // A later value replaces the earlier one.
        s.frame(&param_value(ARDUPLANE_ROLL_TC, 0.35, real)),
    ]
    .concat();
    feed(&mut d, &bytes, 7);
    let tc = d.attitude_time_constants();
    assert!(tc.complete());
    let base = AttitudeLoopConfig::default();
    let cfg = tc.apply_to(base);
    assert_eq!(
        (cfg.pitch_time_constant_s, cfg.roll_time_constant_s),
        (0.4, 0.35)
    );
    assert_eq!(
        AttitudeLoopConfig {
            pitch_time_constant_s: base.pitch_time_constant_s,
            roll_time_constant_s: base.roll_time_constant_s,
            ..cfg
        },
        base
    );
    // None arrived: the configuration is unchanged.
    assert_eq!(AttitudeTimeConstants::default().apply_to(base), base);
}

#[test]
fn other_or_refused_param_values_are_counted_and_ignored() {
    let real = MavParamType::MAV_PARAM_TYPE_REAL32;
    let mut d = Decoder::new(LinkIds::default());
    let mut s = Stream { seq: 0 };
    let bytes = [
        // Another parameter, and names that only start or end like one: unused.
        s.frame(&param_value("PTCH2SRV_RMAX_UP", 0.4, real)),
        s.frame(&param_value("FW_P_TC2", 0.4, real)),
        s.frame(&param_value("_TC", 0.4, real)),
        // Refused values of the right names.
        s.frame(&param_value(PX4_PITCH_TC, f32::NAN, real)),
        s.frame(&param_value(PX4_ROLL_TC, f32::INFINITY, real)),
        s.frame(&param_value(ARDUPLANE_PITCH_TC, 0.0, real)),
        s.frame(&param_value(ARDUPLANE_ROLL_TC, -0.5, real)),
        s.frame(&param_value(
            ARDUPLANE_ROLL_TC,
            0.5,
            MavParamType::MAV_PARAM_TYPE_INT32,
        )),
    ]
    .concat();
    assert!(feed(&mut d, &bytes, 0).is_empty());
    let c = *d.counters();
    assert_eq!((c.unused, c.param_refused), (3, 5));
    assert_eq!((c.frames_used, c.parse_errors, c.bad_crc), (0, 0, 0));
    assert_eq!(
        d.attitude_time_constants(),
        AttitudeTimeConstants::default()
    );

    // A good value is kept; a refused one after it leaves it in place.
    let good = s.frame(&param_value(PX4_ROLL_TC, 0.6, real));
    let zero = s.frame(&param_value(PX4_ROLL_TC, 0.0, real));
    feed(&mut d, &[good, zero].concat(), 5);
    assert_eq!(d.attitude_time_constants().roll_s, Some(0.6));
    assert_eq!(d.counters().param_refused, 6);

    // From another component of the autopilot's system: not read.
    let gimbal = frame_of(&param_value(PX4_PITCH_TC, 0.6, real), 1, 154, 0);
    feed(&mut d, &gimbal, 6);
    assert_eq!(d.attitude_time_constants().pitch_s, None);
    assert_eq!(d.counters().other_component, 1);
}

#[test]
fn sin_cos_is_within_2e7_of_the_exact_values_over_two_turns_each_way() {
    let mut worst = 0.0_f64;
    let n = 200_000;
    for i in 0..=n {
        let x = -4.0 * core::f32::consts::PI + 8.0 * core::f32::consts::PI * i as f32 / n as f32;
        let (s, c) = sin_cos(x);
        let (es, ec) = (f64::from(x).sin(), f64::from(x).cos());
        worst = worst
            .max((f64::from(s) - es).abs())
            .max((f64::from(c) - ec).abs());
    }
    assert!(worst < 2e-7, "worst error {worst:e}");
    // Exact where it must be: zero, and a unit circle.
    assert_eq!(sin_cos(0.0), (0.0, 1.0));
    let (s, c) = sin_cos(0.7);
    assert!((s * s + c * c - 1.0).abs() < 3e-7);
}
