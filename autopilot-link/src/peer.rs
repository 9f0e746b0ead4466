//! The autopilot's side of the link, for simulators and tests: a simulated ArduPlane's
//! telemetry out, the flight computer's setpoints in. Not flown (the firmware never calls
//! it, so its flight image does not contain it).
//!
//! - [`AutopilotTelemetry::of_sample`] is the inverse of the decoder's navigation sample
//!   (`crate`'s module doc, "The navigation sample, field by field"): the attitude, velocity,
//!   position, air data and air angles whose decoded sample is the given one, up to `f32`
//!   rounding. The velocity is along the aircraft's heading at the ground speed
//!   `V_tanker + v`, climbing at the flight-path angle `theta - alpha` (absolute); the
//!   airspeed is the condition's true airspeed made equivalent with the ISA density the
//!   decoder uses.
//! - [`Peer::telemetry`] writes one step's frames, as ArduPlane in GUIDED (or in another
//!   mode) streams them: `HEARTBEAT` at 1 Hz on the caller's clock (`MAV_TYPE_FIXED_WING`,
//!   `MAV_AUTOPILOT_ARDUPILOTMEGA`, `custom_mode` GUIDED or FBWA, armed), then
//!   `LOCAL_POSITION_NED`, `VFR_HUD`, `AOA_SSA`, and `ATTITUDE` last (the flight computer's
//!   lockstep barrier, [`crate::session`]); after the heartbeat, a `PARAM_VALUE` (`REAL32`)
//!   for each attitude time constant the flight computer asked for since the last step
//!   ([`Peer::hear`]; ArduPlane's names, its own values, [`Peer::new`]).
//! - [`read_setpoint`] reads the flight computer's bytes for a step: the last
//!   `SET_ATTITUDE_TARGET` among them, turned back into an [`AttitudeSetpoint`] (ZYX Euler
//!   angles of its quaternion, heading relative to the track, throttle = thrust), the
//!   attitude time constants it asked for (`PARAM_REQUEST_READ` by name), and the frames
//!   counted.
//!
//! Invariants: nothing here panics or allocates; every frame written is whole, with a valid
//! CRC; a frame read is used only when its CRC (with the dialect's CRC extra) is good.

use ::mavlink::dialects::ardupilotmega::{
    AOA_SSA_DATA, ATTITUDE_DATA, HEARTBEAT_DATA, LOCAL_POSITION_NED_DATA, MavAutopilot, MavMessage,
    MavModeFlag, MavParamType, MavState, MavType, PARAM_VALUE_DATA, VFR_HUD_DATA,
};
use ::mavlink::types::CharArray;
use ::mavlink::{MAVLinkV2MessageRaw, MavlinkVersion, Message, MessageData, consts};
use ibvs_core::attitude::AttitudeSetpoint;
use ibvs_core::nav::NavSample;
use ibvs_core::schedule::{self, ScheduleError};

use crate::{
    ARDUPLANE_GUIDED, ARDUPLANE_PITCH_TC, ARDUPLANE_ROLL_TC, Axis, Encoder, LinkIds, NavConfig,
    isa_density_ratio, param_name, sin_cos, wrap_pi,
};

/// ArduPlane's `custom_mode` for FBWA (fly by wire A: the pilot's or its own attitude
/// hold), the mode the simulated autopilot reports when it does not follow setpoints.
pub const ARDUPLANE_FBWA: u32 = 5;

/// Longest burst [`Peer::telemetry`] writes, bytes.
pub const MAX_TELEMETRY_LEN: usize = 7 * 12
    + HEARTBEAT_DATA::ENCODED_LEN
    + 2 * PARAM_VALUE_DATA::ENCODED_LEN
    + LOCAL_POSITION_NED_DATA::ENCODED_LEN
    + VFR_HUD_DATA::ENCODED_LEN
    + AOA_SSA_DATA::ENCODED_LEN
    + ATTITUDE_DATA::ENCODED_LEN;

/// What the autopilot reports, in its own frames and units (angles rad unless named).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AutopilotTelemetry {
    /// `ATTITUDE`: roll, pitch, yaw (true north), rad.
    pub attitude_rad: [f32; 3],
    /// `ATTITUDE`: roll, pitch, yaw rates, rad/s.
    pub rates_radps: [f32; 3],
    /// `LOCAL_POSITION_NED`: north, east, down, m.
    pub position_ned_m: [f32; 3],
    /// `LOCAL_POSITION_NED`: velocity north, east, down, m/s.
    pub velocity_ned_mps: [f32; 3],
    /// `VFR_HUD.airspeed`: equivalent airspeed, m/s.
    pub eas_mps: f32,
    /// `VFR_HUD.alt`: altitude above mean sea level, m.
    pub altitude_m: f32,
    /// `AOA_SSA`: angle of attack and sideslip, rad (sent in degrees).
    pub aoa_ssa_rad: [f32; 2],
}

impl AutopilotTelemetry {
    /// The telemetry whose decoded navigation sample (with `cfg`) is `nav`, up to rounding.
    pub fn of_sample(nav: &NavSample, cfg: &NavConfig) -> Result<Self, ScheduleError> {
        let trim = schedule::trim_at(nav.condition)?;
        let (lon, lat) = (&nav.lon, &nav.lat);
        let pitch = lon.theta_rad + trim.theta_rad;
        let alpha = lon.alpha_rad + trim.alpha_rad;
        let yaw = wrap_pi(lat.psi_rad + cfg.track_rad);
        let ground_speed = lon.v_mps + cfg.tanker_speed_mps;
        let (sy, cy) = sin_cos(yaw);
        let (st, ct) = sin_cos(cfg.track_rad);
        let (x, y) = (lon.x_fwd_m, lat.y_right_m);
        let rho = isa_density_ratio(nav.condition.altitude_m);
        Ok(Self {
            attitude_rad: [lat.phi_rad, pitch, yaw],
            rates_radps: [lat.p_radps, lon.q_radps, lat.r_radps],
            position_ned_m: [x * ct - y * st, x * st + y * ct, -lon.h_up_m],
            velocity_ned_mps: [
                ground_speed * cy,
                ground_speed * sy,
                -ground_speed * libm::tanf(pitch - alpha),
            ],
            eas_mps: nav.condition.true_airspeed_mps * libm::sqrtf(rho),
            altitude_m: nav.condition.altitude_m,
            aoa_ssa_rad: [alpha, lat.beta_rad],
        })
    }
}

/// A simulated ArduPlane's end of the link.
#[derive(Debug, Clone)]
pub struct Peer {
    /// Frames from the autopilot's ids, its sequence and heartbeat period: the flight
    /// computer's encoder with the roles swapped.
    encoder: Encoder,
    /// Its pitch and roll attitude time constants, s (`PTCH2SRV_TCONST`, `RLL2SRV_TCONST`).
    time_constants_s: [f32; 2],
    /// Which of them the flight computer asked for since the last answer.
    asked: [bool; 2],
}

impl Peer {
    /// The autopilot of `ids` (its system and component) with the pitch and roll attitude
    /// time constants `time_constants_s`, its first frame numbered 0.
    pub const fn new(ids: LinkIds, time_constants_s: [f32; 2]) -> Self {
        Self {
            encoder: Encoder::new(LinkIds {
                system_id: ids.autopilot_system,
                component_id: ids.autopilot_component,
                ..ids
            }),
            time_constants_s,
            asked: [false; 2],
        }
    }

    /// Takes note of the parameters the flight computer asked for in `read` (answered in
    /// the next [`Peer::telemetry`]).
    pub fn hear(&mut self, read: &SetpointRead) {
        for (asked, now) in self.asked.iter_mut().zip(read.time_constants_asked) {
            *asked |= now;
        }
    }

    /// One step's frames at `time_boot_ms` into `buf` (module doc): the bytes written.
    /// `guided`: the mode its heartbeat reports (GUIDED, else FBWA).
    pub fn telemetry(
        &mut self,
        t: &AutopilotTelemetry,
        guided: bool,
        time_boot_ms: u32,
        buf: &mut [u8; MAX_TELEMETRY_LEN],
    ) -> usize {
        let mut n = 0;
        if self.encoder.heartbeat_due(time_boot_ms) {
            let hb = HEARTBEAT_DATA {
                custom_mode: if guided {
                    ARDUPLANE_GUIDED
                } else {
                    ARDUPLANE_FBWA
                },
                mavtype: MavType::MAV_TYPE_FIXED_WING,
                autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
                base_mode: MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
                    | MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED,
                system_status: MavState::MAV_STATE_ACTIVE,
                mavlink_version: 3,
            };
            n += self.frame(&hb, &mut buf[n..]);
        }
        let names = [ARDUPLANE_PITCH_TC, ARDUPLANE_ROLL_TC];
        let asked = core::mem::take(&mut self.asked);
        for ((asked, value), name) in asked.into_iter().zip(self.time_constants_s).zip(names) {
            if asked {
                let param = PARAM_VALUE_DATA {
                    param_value: value,
                    param_count: 1,
                    param_index: u16::MAX,
                    param_id: CharArray::from(name),
                    param_type: MavParamType::MAV_PARAM_TYPE_REAL32,
                };
                n += self.frame(&param, &mut buf[n..]);
            }
        }
        let [pn, pe, pd] = t.position_ned_m;
        let [vn, ve, vd] = t.velocity_ned_mps;
        let local = LOCAL_POSITION_NED_DATA {
            time_boot_ms,
            x: pn,
            y: pe,
            z: pd,
            vx: vn,
            vy: ve,
            vz: vd,
        };
        n += self.frame(&local, &mut buf[n..]);
        let heading = t.attitude_rad[2].to_degrees();
        let hud = VFR_HUD_DATA {
            airspeed: t.eas_mps,
            groundspeed: libm::hypotf(vn, ve),
            alt: t.altitude_m,
            climb: -vd,
            heading: libm::roundf(heading + if heading < 0.0 { 360.0 } else { 0.0 }) as i16,
            throttle: 0,
        };
        n += self.frame(&hud, &mut buf[n..]);
        let aoa = AOA_SSA_DATA {
            time_usec: u64::from(time_boot_ms) * 1000,
            AOA: t.aoa_ssa_rad[0].to_degrees(),
            SSA: t.aoa_ssa_rad[1].to_degrees(),
        };
        n += self.frame(&aoa, &mut buf[n..]);
        let [roll, pitch, yaw] = t.attitude_rad;
        let [p, q, r] = t.rates_radps;
        let att = ATTITUDE_DATA {
            time_boot_ms,
            roll,
            pitch,
            yaw,
            rollspeed: p,
            pitchspeed: q,
            yawspeed: r,
        };
        n += self.frame(&att, &mut buf[n..]);
        n
    }

    /// One frame of `data` into `buf`: its length (0 if `buf` is too short, which the burst
    /// buffer's length rules out).
    fn frame<D: MessageData>(&mut self, data: &D, buf: &mut [u8]) -> usize {
        self.encoder.frame(data, buf).unwrap_or(0)
    }
}

/// What [`read_setpoint`] found in a step's bytes from the flight computer.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SetpointRead {
    /// The last `SET_ATTITUDE_TARGET`'s setpoint (heading relative to the track).
    pub setpoint: Option<AttitudeSetpoint>,
    /// Its `time_boot_ms`.
    pub time_boot_ms: Option<u32>,
    /// Whole frames with a good CRC.
    pub frames: u32,
    /// Heartbeats among them.
    pub heartbeats: u32,
    /// The pitch and roll attitude time constants asked for (`PARAM_REQUEST_READ` by
    /// ArduPlane's or PX4's name).
    pub time_constants_asked: [bool; 2],
    /// Bytes not in a good frame (noise, a bad CRC, a cut frame).
    pub bad_bytes: u32,
}

/// ZYX Euler angles (roll, pitch, yaw), rad, of the unit quaternion `[w, x, y, z]`.
pub fn euler_zyx(q: [f32; 4]) -> [f32; 3] {
    let [w, x, y, z] = q;
    let roll = libm::atan2f(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y));
    let pitch = libm::asinf((2.0 * (w * y - z * x)).clamp(-1.0, 1.0));
    let yaw = libm::atan2f(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z));
    [roll, pitch, yaw]
}

/// Reads the flight computer's frames in `bytes` (module doc), the track `track_rad`
/// (true north, rad) taken out of the heading.
pub fn read_setpoint(bytes: &[u8], track_rad: f32) -> SetpointRead {
    let mut out = SetpointRead::default();
    let mut rest = bytes;
    while let Some((&first, tail)) = rest.split_first() {
        let header_len = consts::STX_SIZE + consts::v2::MIN_HEADER_SIZE;
        let whole = (first == ::mavlink::MAV_STX_V2)
            .then(|| rest.get(1).map(|&len| header_len + usize::from(len) + 2))
            .flatten()
            .filter(|&len| len <= rest.len());
        let Some(len) = whole else {
            out.bad_bytes += 1;
            rest = tail;
            continue;
        };
        let mut raw = MAVLinkV2MessageRaw::new();
        raw.as_mut_slice()[..len].copy_from_slice(&rest[..len]);
        let parsed = raw
            .has_valid_crc::<MavMessage>()
            .then(|| MavMessage::parse(MavlinkVersion::V2, raw.message_id(), raw.payload()).ok())
            .flatten();
        let Some(msg) = parsed else {
            out.bad_bytes += 1;
            rest = tail;
            continue;
        };
        out.frames += 1;
        match msg {
            MavMessage::SET_ATTITUDE_TARGET(d) => {
                let [roll, pitch, yaw] = euler_zyx(d.q);
                out.setpoint = Some(AttitudeSetpoint {
                    roll_rad: roll,
                    pitch_rad: pitch,
                    yaw_rad: wrap_pi(yaw - track_rad),
                    throttle: d.thrust,
                });
                out.time_boot_ms = Some(d.time_boot_ms);
            }
            MavMessage::HEARTBEAT(_) => out.heartbeats += 1,
            MavMessage::PARAM_REQUEST_READ(r) => {
                match Axis::of_time_constant(param_name(&r.param_id)) {
                    Some(Axis::Pitch) => out.time_constants_asked[0] = true,
                    Some(Axis::Roll) => out.time_constants_asked[1] = true,
                    None => {}
                }
            }
            _ => {}
        }
        rest = &rest[len..];
    }
    out
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;
    use crate::session::{MAX_BURST_LEN, Session, SessionConfig};
    use crate::{Decoder, quaternion_zyx};
    use ibvs_core::attitude::{AttitudeLoopConfig, Command};
    use ibvs_core::measurement::CameraMeasurement;
    use ibvs_core::nav::{FlightCondition, LatNav, LonNav};
    use ibvs_core::{ControllerInput, ModeRequest};

    fn sample() -> NavSample {
        NavSample {
            lon: LonNav {
                x_fwd_m: 12.0,
                h_up_m: -1.5,
                theta_rad: 0.02,
                v_mps: 1.3,
                alpha_rad: -0.01,
                q_radps: 0.03,
            },
            lat: LatNav {
                y_right_m: -2.0,
                psi_rad: 0.05,
                phi_rad: -0.1,
                beta_rad: 0.004,
                p_radps: 0.02,
                r_radps: -0.01,
            },
            condition: FlightCondition::default(),
        }
    }

    #[test]
    fn the_decoder_reads_the_telemetry_back_into_the_sample_it_came_from() {
        for track in [0.0_f32, 1.0, -2.5] {
            let cfg = NavConfig {
                track_rad: track,
                ..NavConfig::default()
            };
            let t = AutopilotTelemetry::of_sample(&sample(), &cfg).unwrap();
            let mut peer = Peer::new(LinkIds::default(), [0.5, 0.5]);
            let mut buf = [0; MAX_TELEMETRY_LEN];
            let n = peer.telemetry(&t, true, 40, &mut buf);
            let mut d = Decoder::new(LinkIds::default());
            let got: Vec<_> = buf[..n].iter().filter_map(|&b| d.push(b, 40)).collect();
            assert_eq!(
                got.len(),
                5,
                "heartbeat, position, air data, air angles, attitude"
            );
            assert_eq!(
                got.last(),
                Some(&crate::Received::Attitude),
                "attitude last"
            );
            assert!(d.autopilot(40).accepts_setpoints(0));
            let fix = d.nav_sample(40, &cfg).unwrap();
            let (a, b) = (fix.sample.as_array(), sample().as_array());
            for (i, (x, y)) in a.iter().zip(b.iter()).enumerate() {
                assert!((x - y).abs() < 2e-4, "track {track}: field {i}: {x} vs {y}");
            }
            let c = fix.sample.condition;
            assert!((c.true_airspeed_mps - sample().condition.true_airspeed_mps).abs() < 1e-3);
            assert_eq!(c.altitude_m, sample().condition.altitude_m);
            assert_eq!(d.counters().frames_used, 5);
        }
    }

    #[test]
    fn heartbeats_come_at_one_hertz_and_say_the_mode() {
        let t = AutopilotTelemetry::of_sample(&sample(), &NavConfig::default()).unwrap();
        let mut peer = Peer::new(LinkIds::default(), [0.5, 0.5]);
        let mut d = Decoder::new(LinkIds::default());
        let mut buf = [0; MAX_TELEMETRY_LEN];
        let mut beats = 0;
        for k in 0..100u32 {
            let now = 20 * k;
            let n = peer.telemetry(&t, k < 60, now, &mut buf);
            for &b in &buf[..n] {
                if d.push(b, now) == Some(crate::Received::Heartbeat) {
                    beats += 1;
                }
            }
        }
        assert_eq!(beats, 2, "at 0 and 1000 ms");
        assert!(
            d.autopilot(1980).accepts_setpoints(2500),
            "GUIDED at 1000 ms"
        );
        let n = peer.telemetry(&t, false, 2000, &mut buf);
        buf[..n].iter().for_each(|&b| _ = d.push(b, 2000));
        assert!(
            !d.autopilot(2000).accepts_setpoints(2500),
            "FBWA at 2000 ms"
        );
        assert_eq!(d.counters().dropped, 0);
    }

    #[test]
    fn the_setpoint_read_back_is_the_one_sent() {
        let sp = AttitudeSetpoint {
            roll_rad: 0.3,
            pitch_rad: -0.12,
            yaw_rad: 0.4,
            throttle: 0.62,
        };
        let cfg = SessionConfig {
            nav: NavConfig {
                track_rad: 2.0,
                ..NavConfig::default()
            },
            ..SessionConfig::default()
        };
        let mut s = Session::new(cfg);
        let mut buf = [0; MAX_BURST_LEN];
        let n = s.send(1000, &Command::Attitude(sp), &mut buf);
        let read = read_setpoint(&buf[..n], 2.0);
        assert_eq!((read.frames, read.heartbeats, read.bad_bytes), (2, 1, 0));
        assert_eq!(read.time_boot_ms, Some(1000));
        let got = read.setpoint.unwrap();
        for (a, b) in [
            (got.roll_rad, sp.roll_rad),
            (got.pitch_rad, sp.pitch_rad),
            (got.yaw_rad, sp.yaw_rad),
            (got.throttle, sp.throttle),
        ] {
            assert!((a - b).abs() < 1e-5, "{a} vs {b}");
        }
        // A corrupted byte loses the frame, counted.
        let mut bad = buf;
        bad[n - 3] ^= 0x40;
        let read = read_setpoint(&bad[..n], 2.0);
        assert_eq!(read.setpoint, None);
        assert!(read.bad_bytes > 0);
        // Euler angles back from the quaternion.
        let e = euler_zyx(quaternion_zyx(0.2, -0.3, 2.9));
        assert!((e[0] - 0.2).abs() < 1e-6 && (e[1] + 0.3).abs() < 1e-6);
        assert!((e[2] - 2.9).abs() < 1e-5);
    }

    #[test]
    fn the_session_flies_the_autopilots_navigation_and_mode_or_none() {
        let cfg = SessionConfig::default();
        let mut s = Session::new(cfg);
        let uplink = ControllerInput {
            measurement: CameraMeasurement::default(),
            nav: NavSample::default(),
            probe_contact: false,
            autopilot_ready: true,
            request: ModeRequest::Engage,
        };
        // Nothing received: invalid navigation, not ready, counted.
        let i = s.input(0, &uplink);
        assert!(i.nav.as_array().iter().all(|v| v.is_nan()));
        assert!(!i.autopilot_ready);
        assert_eq!(i.request, ModeRequest::Engage);
        assert_eq!(s.counters().nav_missing, 1);
        assert!(!s.attitude_arrived());
        // One step's telemetry: the sample and the mode are the autopilot's, but its
        // attitude time constants are not known yet: not ready, counted.
        let t = AutopilotTelemetry::of_sample(&sample(), &cfg.nav).unwrap();
        let mut peer = Peer::new(cfg.ids, [0.5, 0.5]);
        let mut buf = [0; MAX_TELEMETRY_LEN];
        let n = peer.telemetry(&t, true, 20, &mut buf);
        buf[..n].iter().for_each(|&b| s.push(b, 20));
        assert!(s.attitude_arrived());
        let i = s.input(20, &uplink);
        assert!(!s.attitude_arrived(), "the barrier resets with each input");
        assert!(!i.autopilot_ready, "time constants unknown");
        assert_eq!(s.counters().time_constants_unknown, 2, "both steps so far");
        assert!((i.nav.lon.v_mps - 1.3).abs() < 1e-4);
        // The flight computer asks for them with its heartbeat; the autopilot answers.
        let sp = AttitudeSetpoint {
            roll_rad: 0.0,
            pitch_rad: 0.0,
            yaw_rad: 0.0,
            throttle: 0.5,
        };
        let mut out = [0; MAX_BURST_LEN];
        let n = s.send(20, &Command::Attitude(sp), &mut out);
        let read = read_setpoint(&out[..n], 0.0);
        assert_eq!((read.frames, read.heartbeats), (4, 1));
        assert_eq!(read.time_constants_asked, [true, true]);
        peer.hear(&read);
        let n = peer.telemetry(&t, true, 40, &mut buf);
        let mut mismatched = Session::new(SessionConfig {
            design: AttitudeLoopConfig {
                pitch_time_constant_s: 0.4,
                ..AttitudeLoopConfig::default()
            },
            ..cfg
        });
        for &b in &buf[..n] {
            s.push(b, 40);
            mismatched.push(b, 40);
        }
        assert!(s.input(40, &uplink).autopilot_ready, "0.5 s, as designed");
        // Designed on 0.4 s, flown with 0.5 s: 25 % off, not ready, counted.
        assert!(!mismatched.input(40, &uplink).autopilot_ready);
        assert_eq!(mismatched.counters().time_constants_mismatch, 1);
        // Asked for once only.
        let n = s.send(40, &Command::Attitude(sp), &mut out);
        assert_eq!(
            read_setpoint(&out[..n], 0.0).time_constants_asked,
            [false; 2]
        );
        // 200 ms later the attitude is stale: invalid again, counted.
        let i = s.input(240, &uplink);
        assert!(i.nav.lon.theta_rad.is_nan());
        assert_eq!(s.counters().nav_stale, 1);
        // A setpoint that cannot be encoded is counted, not sent.
        let bad = AttitudeSetpoint {
            roll_rad: f32::NAN,
            ..sp
        };
        let n = s.send(240, &Command::Attitude(bad), &mut out);
        let read = read_setpoint(&out[..n], 0.0);
        assert_eq!((read.frames, read.heartbeats, read.setpoint), (0, 0, None));
        assert_eq!(s.counters().setpoints_refused, 1);
        s.count_tx_dropped();
        assert_eq!(s.counters().tx_dropped, 1);
    }
}
