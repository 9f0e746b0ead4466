//! # autopilot-link: MAVLink 2 to an autopilot: attitude and throttle setpoints out, navigation in.
//!
//! For docking through an existing autopilot (ArduPlane in GUIDED, PX4 in OFFBOARD) that
//! accepts only attitude and thrust setpoints from an outside computer
//! ([`ibvs_core::attitude`]). Board-independent: bytes in, bytes out, a millisecond clock
//! from the caller; nothing here touches a UART. The firmware's application and the
//! simulator's in-process flight computer both use it, so that processor-in-the-loop runs
//! can be compared with in-process ones bit for bit.
//!
//! Layout: this module is the codec (the [`Encoder`] of our frames, the [`Decoder`] of the
//! autopilot's, the navigation sample built from them); [`session`] is what one control step
//! takes from the link and gives to it (the firmware's application and the simulator's
//! in-process flight computer call only it); [`peer`] is the autopilot's end, for the
//! simulator and the tests (never in the flight image).
//!
//! The messages are the `mavlink` crate's (rust-mavlink, `no_std`, its `ardupilotmega`
//! dialect: `common` plus ArduPilot's messages, because `AOA_SSA` is ArduPilot's): their
//! payload layout, CRC extra bytes and CRC are the crate's. This module finds frame
//! boundaries byte by byte (so that it can count what it drops), asks the crate to check
//! each frame's CRC and to decode the payloads it uses, and encodes only the three messages
//! it sends (`peer` encodes the autopilot's).
//!
//! # Sent (flight computer to autopilot), [`Encoder`]
//!
//! - `HEARTBEAT` at 1 Hz ([`HEARTBEAT_PERIOD_MS`], [`Encoder::heartbeat_due`]): type
//!   `MAV_TYPE_ONBOARD_CONTROLLER`, autopilot `MAV_AUTOPILOT_INVALID`, from our system id
//!   (default 1, the autopilot's own, as companion computers do) and component id
//!   `MAV_COMP_ID_ONBOARD_COMPUTER` (191).
//! - `SET_ATTITUDE_TARGET` from an [`AttitudeSetpoint`], to the autopilot (default system
//!   1, component 1): the quaternion of the ZYX Euler angles (roll = bank, pitch, yaw) of the
//!   body in NED, yaw absolute = the tanker's track (true north, rad) + the setpoint's
//!   heading; `thrust` = throttle (0..1); `type_mask` = 7 (the three body rates ignored,
//!   attitude and thrust used); `time_boot_ms` from the caller.
//! - `PARAM_REQUEST_READ` of a parameter by name ([`Encoder::param_request_read`]:
//!   `param_id` the name, at most [`PARAM_ID_LEN`] bytes, `param_index` -1), to the
//!   autopilot's system and component: the autopilot's attitude time constants ("Attitude
//!   time constants" below), whose names [`AutopilotKind::time_constant_params`] gives.
//!
//! Every frame is MAVLink 2, unsigned, with the link's sequence number, which increments
//! (wrapping at 255) per frame sent; a message that is refused (a named [`EncodeError`])
//! uses no sequence number, so the autopilot sees no gap.
//!
//! # Read (autopilot to flight computer), [`Decoder`]
//!
//! Bytes are pushed one at a time ([`Decoder::push`]). Every byte and frame that is not
//! used is counted in [`Counters`], never silently lost: bytes outside a frame (noise,
//! MAVLink 1), frames with unsupported incompatibility flags, frames whose message id the
//! dialect does not know (their CRC cannot be checked without its CRC extra), bad CRCs,
//! frames from another system or another component of the autopilot's system, messages of
//! the dialect this module does not use (a `PARAM_VALUE` of another parameter among them),
//! payloads the crate refuses, refused attitude time constants, and sequence gaps per
//! source component of the autopilot's system (frames dropped on the way). A frame with a
//! bad CRC or bad flags is dropped whole and the parser looks for the next start byte (as
//! MAVLink's C library does). Signed frames are accepted with their CRC checked and their
//! signature **not** checked, and counted.
//!
//! From the autopilot (system and component ids of [`LinkIds`]) the latest `HEARTBEAT`,
//! `ATTITUDE`, `LOCAL_POSITION_NED`, `GLOBAL_POSITION_INT`, `VFR_HUD` and `AOA_SSA` are kept
//! with the time they arrived. [`Decoder::nav_sample`] builds an [`NavSample`] from them,
//! perturbations from the trim at the sample's flight condition
//! ([`ibvs_core::schedule::trim_at`]), and [`Decoder::autopilot`] reports the autopilot's
//! mode ([`AutopilotMode`]) and its age, [`Decoder::autopilot_kind`] its software
//! ([`AutopilotKind`]), and [`Decoder::attitude_time_constants`] the time constants read
//! from its `PARAM_VALUE`s.
//!
//! # The navigation sample, field by field
//!
//! With `roll`, `pitch`, `yaw` (rad) and `rollspeed`, `pitchspeed`, `yawspeed` (rad/s) from
//! `ATTITUDE`; the NED velocity `vn`, `ve`, `vd` (m/s, down positive) and position from
//! `LOCAL_POSITION_NED` (preferred when fresh) or else `GLOBAL_POSITION_INT` (cm/s); `trim`
//! the schedule's trim at the condition; `track` and `V_tanker` the [`NavConfig`]'s tanker
//! track (rad, true north) and speed (m/s):
//!
//! | field | from | units, sign |
//! |---|---|---|
//! | `condition.true_airspeed_mps` | `VFR_HUD.airspeed`, taken as equivalent airspeed (ArduPlane sends its EAS estimate; PX4 sends indicated, which equals EAS to within the position error), times `1/sqrt(sigma)` of the ISA density ratio at `VFR_HUD.alt` | m/s |
//! | `condition.altitude_m` | `VFR_HUD.alt` (above mean sea level in both autopilots) | m, up |
//! | `lat.psi_rad` | `yaw - track`, wrapped to `[-pi, pi]` | rad, right + |
//! | `lat.phi_rad` | `roll` (the trim is wings level) | rad, right wing down + |
//! | `lat.beta_rad` | `AOA_SSA.SSA` (deg) when fresh, else **0** ([`BetaSource::AssumedZero`]) | rad |
//! | `lat.p_radps`, `lon.q_radps`, `lat.r_radps` | `rollspeed`, `pitchspeed`, `yawspeed` (body rates; trim 0) | rad/s |
//! | `lon.theta_rad` | `pitch - trim.theta_rad` | rad, nose up + |
//! | `lon.alpha_rad` | `AOA_SSA.AOA` (deg) when fresh, else the estimate `pitch - gamma` with the flight-path angle `gamma = atan2(-vd, sqrt(vn^2 + ve^2))` (no wind, wings near level: [`AlphaSource::PitchMinusPathAngle`]); minus `trim.alpha_rad` | rad |
//! | `lon.v_mps` | ground speed `sqrt(vn^2 + ve^2)` minus the tanker's speed (the design's trim speed is the tanker's, [`ibvs_core::nav`]) | m/s |
//! | `lon.x_fwd_m`, `lat.y_right_m` | `LOCAL_POSITION_NED` north/east rotated into the track axes (from the autopilot's local origin, not the tanker); 0 with `GLOBAL_POSITION_INT` | m (not fed back) |
//! | `lon.h_up_m` | `-LOCAL_POSITION_NED.z` or `GLOBAL_POSITION_INT.relative_alt` | m, up (not fed back) |
//!
//! A sample is built only when `ATTITUDE`, a velocity message and `VFR_HUD` are each younger
//! than their ages in [`NavConfig`]; otherwise a named [`NavBuildError`] (missing or stale,
//! and which), counted in [`Counters`]. `AOA_SSA` is optional: older than its age, the
//! estimate and the zero are used and the [`NavFix`] says so.
//!
//! # Autopilot mode
//!
//! From the autopilot's `HEARTBEAT`: ArduPlane (`MAV_AUTOPILOT_ARDUPILOTMEGA`,
//! `MAV_TYPE_FIXED_WING`) accepts setpoints in GUIDED (`custom_mode` 15); PX4
//! (`MAV_AUTOPILOT_PX4`) in OFFBOARD (main mode 6 in bits 16..23 of `custom_mode`). Any other
//! autopilot or ArduPilot vehicle type is [`AutopilotMode::Unknown`].
//!
//! # Attitude time constants
//!
//! The attitude-command inner loop ([`ibvs_core::attitude::AttitudeLoopConfig`]) is designed
//! on the autopilot's pitch and roll attitude-loop time constants, so it must be told the
//! autopilot's real ones. The caller requests them by name and the decoder keeps each
//! `PARAM_VALUE` answer, with the time it arrived:
//!
//! | autopilot ([`AutopilotKind`], from its `HEARTBEAT`) | pitch, s | roll, s |
//! |---|---|---|
//! | ArduPlane (`MAV_AUTOPILOT_ARDUPILOTMEGA`, `MAV_TYPE_FIXED_WING`) | `PTCH2SRV_TCONST` | `RLL2SRV_TCONST` |
//! | PX4 (`MAV_AUTOPILOT_PX4`) | `FW_P_TC` | `FW_R_TC` |
//!
//! A `PARAM_VALUE` from the autopilot whose `param_id` (up to its first NUL) is one of the
//! four names is kept as that axis's time constant when its `param_type` is
//! `MAV_PARAM_TYPE_REAL32` and its value is finite and positive (a later one replaces it);
//! otherwise it is counted in [`Counters::param_refused`] and the value kept before, if any,
//! stays. A `PARAM_VALUE` of any other parameter is counted as unused.
//! [`AttitudeTimeConstants::apply_to`] puts the values into an
//! [`AttitudeLoopConfig`]; the caller validates the whole
//! [`ibvs_core::config::ControllerConfig`] as for any other configuration change.
//!
//! Invariants: nothing here panics or allocates; every frame written is a whole MAVLink 2
//! frame with a valid CRC, or nothing is written; every received byte is either part of a
//! frame that was used or is counted; counters saturate rather than wrap; a [`NavSample`]
//! returned was built only from messages younger than their configured ages, and is finite.

#![cfg_attr(not(test), no_std)]

use ::mavlink::dialects::ardupilotmega::{
    AOA_SSA_DATA, ATTITUDE_DATA, AttitudeTargetTypemask, GLOBAL_POSITION_INT_DATA, HEARTBEAT_DATA,
    LOCAL_POSITION_NED_DATA, MavAutopilot, MavMessage, MavModeFlag, MavParamType, MavState,
    MavType, PARAM_REQUEST_READ_DATA, PARAM_VALUE_DATA, SET_ATTITUDE_TARGET_DATA, VFR_HUD_DATA,
};
use ::mavlink::types::CharArray;
use ::mavlink::{MAVLinkV2MessageRaw, MavHeader, MavlinkVersion, Message, MessageData, consts};
use ibvs_core::attitude::{AttitudeLoopConfig, AttitudeSetpoint};
use ibvs_core::nav::{FlightCondition, LatNav, LonNav, NavSample};
use ibvs_core::schedule::{self, ScheduleError};

pub mod peer;
pub mod session;

/// Period of our `HEARTBEAT`, ms (1 Hz).
pub const HEARTBEAT_PERIOD_MS: u32 = 1000;

/// Length of a `HEARTBEAT`'s payload, bytes.
pub const HEARTBEAT_DATA_LEN: usize = HEARTBEAT_DATA::ENCODED_LEN;

/// Length of a `PARAM_REQUEST_READ` frame, bytes.
pub const PARAM_REQUEST_FRAME_LEN: usize = 12 + PARAM_REQUEST_READ_DATA::ENCODED_LEN;

/// `MAV_COMP_ID_ONBOARD_COMPUTER`: our component id.
pub const COMP_ID_ONBOARD_COMPUTER: u8 = 191;

/// `ATTITUDE_TARGET_TYPEMASK` of our `SET_ATTITUDE_TARGET`: body roll, pitch and yaw rates
/// ignored (bits 0..2); attitude and thrust used.
pub const ATTITUDE_TYPE_MASK: u8 = 7;

/// ArduPlane's `custom_mode` for GUIDED.
pub const ARDUPLANE_GUIDED: u32 = 15;

/// PX4's main mode OFFBOARD (bits 16..23 of `custom_mode`).
pub const PX4_MAIN_MODE_OFFBOARD: u32 = 6;

/// Longest frame this module writes, bytes (`SET_ATTITUDE_TARGET`: 12 of header and CRC,
/// 39 of payload). A buffer this long always holds one frame.
pub const MAX_SENT_FRAME_LEN: usize = 12 + SET_ATTITUDE_TARGET_DATA::ENCODED_LEN;

/// The one message of the dialect whose CRC extra is 0 (`COMPONENT_INFORMATION`, deprecated
/// but defined): the dialect's CRC-extra table answers 0 for ids it does not know too.
#[allow(deprecated)]
pub const CRC_EXTRA_ZERO_ID: u32 =
    ::mavlink::dialects::ardupilotmega::COMPONENT_INFORMATION_DATA::ID;

/// Longest parameter name, bytes (`param_id` is `char[16]`, NUL-terminated when shorter).
pub const PARAM_ID_LEN: usize = 16;

/// ArduPlane's pitch-angle loop time constant parameter, s.
pub const ARDUPLANE_PITCH_TC: &str = "PTCH2SRV_TCONST";
/// ArduPlane's roll-angle loop time constant parameter, s.
pub const ARDUPLANE_ROLL_TC: &str = "RLL2SRV_TCONST";
/// PX4's pitch-angle loop time constant parameter, s.
pub const PX4_PITCH_TC: &str = "FW_P_TC";
/// PX4's roll-angle loop time constant parameter, s.
pub const PX4_ROLL_TC: &str = "FW_R_TC";

/// MAVLink 2's start byte.
const STX_V2: u8 = ::mavlink::MAV_STX_V2;
/// Start byte and the nine header bytes of an 8-bit-system-id MAVLink 2 frame.
const HEADER_LEN: usize = consts::STX_SIZE + consts::v2::MIN_HEADER_SIZE;

/// The system and component ids on the link.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LinkIds {
    /// Our system id (default 1: the autopilot's system, as companion computers use).
    pub system_id: u8,
    /// Our component id (default [`COMP_ID_ONBOARD_COMPUTER`]).
    pub component_id: u8,
    /// The autopilot's system id (default 1): setpoints go to it, navigation comes from it.
    pub autopilot_system: u8,
    /// The autopilot's component id (default 1, `MAV_COMP_ID_AUTOPILOT1`).
    pub autopilot_component: u8,
}

impl Default for LinkIds {
    fn default() -> Self {
        Self {
            system_id: 1,
            component_id: COMP_ID_ONBOARD_COMPUTER,
            autopilot_system: 1,
            autopilot_component: 1,
        }
    }
}

/// Why a message was not encoded (nothing was written, no sequence number was used).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EncodeError {
    /// The caller's buffer is shorter than the frame.
    BufferTooSmall {
        /// The frame's length, bytes.
        needed: usize,
        /// The buffer's length, bytes.
        available: usize,
    },
    /// An angle, the throttle or the tanker's track is NaN or infinite.
    NonFinite,
    /// The throttle is outside 0..1.
    ThrottleOutOfRange,
    /// A parameter name that is empty, longer than [`PARAM_ID_LEN`] bytes or holds a NUL.
    BadParamName,
}

/// The flight computer's side of the link: frames for the autopilot, with the link's
/// sequence number.
#[derive(Debug, Clone)]
pub struct Encoder {
    ids: LinkIds,
    sequence: u8,
    last_heartbeat_ms: Option<u32>,
}

impl Encoder {
    /// An encoder for `ids`, its first frame numbered 0.
    pub const fn new(ids: LinkIds) -> Self {
        Self {
            ids,
            sequence: 0,
            last_heartbeat_ms: None,
        }
    }

    /// The sequence number the next frame will carry.
    pub const fn next_sequence(&self) -> u8 {
        self.sequence
    }

    /// Whether our heartbeat is due at `now_ms` (a wrapping millisecond clock): at the
    /// first call, then [`HEARTBEAT_PERIOD_MS`] after the last time it was due.
    pub fn heartbeat_due(&mut self, now_ms: u32) -> bool {
        let due = self
            .last_heartbeat_ms
            .is_none_or(|last| now_ms.wrapping_sub(last) >= HEARTBEAT_PERIOD_MS);
        if due {
            self.last_heartbeat_ms = Some(now_ms);
        }
        due
    }

    /// Our `HEARTBEAT` (an onboard controller, active) into `buf`; the bytes written.
    pub fn heartbeat(&mut self, buf: &mut [u8]) -> Result<usize, EncodeError> {
        let data = HEARTBEAT_DATA {
            custom_mode: 0,
            mavtype: MavType::MAV_TYPE_ONBOARD_CONTROLLER,
            autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
            base_mode: MavModeFlag::empty(),
            system_status: MavState::MAV_STATE_ACTIVE,
            mavlink_version: 3,
        };
        self.frame(&data, buf)
    }

    /// `SET_ATTITUDE_TARGET` for `setpoint`, its heading relative to the tanker's track
    /// `track_rad` (true north, rad), at `time_boot_ms`; the bytes written.
    pub fn attitude_target(
        &mut self,
        setpoint: &AttitudeSetpoint,
        track_rad: f32,
        time_boot_ms: u32,
        buf: &mut [u8],
    ) -> Result<usize, EncodeError> {
        let s = setpoint;
        let values = [s.roll_rad, s.pitch_rad, s.yaw_rad, s.throttle, track_rad];
        if !values.iter().all(|v| v.is_finite()) {
            return Err(EncodeError::NonFinite);
        }
        if !(0.0..=1.0).contains(&s.throttle) {
            return Err(EncodeError::ThrottleOutOfRange);
        }
        let yaw = wrap_pi(track_rad + s.yaw_rad);
        let data = SET_ATTITUDE_TARGET_DATA {
            time_boot_ms,
            q: quaternion_zyx(s.roll_rad, s.pitch_rad, yaw),
            body_roll_rate: 0.0,
            body_pitch_rate: 0.0,
            body_yaw_rate: 0.0,
            thrust: s.throttle,
            target_system: self.ids.autopilot_system,
            target_component: self.ids.autopilot_component,
            type_mask: AttitudeTargetTypemask::from_bits_retain(ATTITUDE_TYPE_MASK),
        };
        self.frame(&data, buf)
    }

    /// `PARAM_REQUEST_READ` of the parameter `name` (by name: `param_index` -1) to the
    /// autopilot's system and component; the bytes written.
    pub fn param_request_read(&mut self, name: &str, buf: &mut [u8]) -> Result<usize, EncodeError> {
        let bytes = name.as_bytes();
        if bytes.is_empty() || bytes.len() > PARAM_ID_LEN || bytes.contains(&0) {
            return Err(EncodeError::BadParamName);
        }
        let data = PARAM_REQUEST_READ_DATA {
            param_index: -1,
            target_system: self.ids.autopilot_system,
            target_component: self.ids.autopilot_component,
            param_id: CharArray::from(name),
        };
        self.frame(&data, buf)
    }

    /// One MAVLink 2 frame of `data` from our ids into `buf`, then the next sequence number
    /// (also the simulated autopilot's frames, `peer`).
    pub(crate) fn frame<D: MessageData>(
        &mut self,
        data: &D,
        buf: &mut [u8],
    ) -> Result<usize, EncodeError> {
        let header = MavHeader {
            system_id: u32::from(self.ids.system_id),
            component_id: self.ids.component_id,
            sequence: self.sequence,
        };
        let mut raw = MAVLinkV2MessageRaw::new();
        raw.serialize_message_data(header, data);
        let bytes = raw.raw_bytes();
        let available = buf.len();
        let out = buf
            .get_mut(..bytes.len())
            .ok_or(EncodeError::BufferTooSmall {
                needed: bytes.len(),
                available,
            })?;
        out.copy_from_slice(bytes);
        self.sequence = self.sequence.wrapping_add(1);
        Ok(bytes.len())
    }
}

/// The unit quaternion `[w, x, y, z]` of ZYX Euler angles (yaw, then pitch, then roll; the
/// body in NED, as MAVLink's attitude quaternions), rad.
pub fn quaternion_zyx(roll: f32, pitch: f32, yaw: f32) -> [f32; 4] {
    let (sr, cr) = sin_cos(roll / 2.0);
    let (sp, cp) = sin_cos(pitch / 2.0);
    let (sy, cy) = sin_cos(yaw / 2.0);
    [
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    ]
}

/// Sine and cosine of `x` (rad, finite; meant for angles of a few turns at most), in `f32`
/// only, to within 2e-7 of the exact values (tested against `f64`): the quadrant
/// `k = round(x / (pi/2))` taken out with `pi/2` in two parts (Cody and Waite), then the Taylor series of
/// sine to `r^9` and of cosine to `r^10` on `|r| <= pi/4` (truncation under 2e-9). `libm`'s
/// `sincosf` computes in `f64`, which the Cortex-M4F emulates in software: about 2,100
/// instructions a call against some 60 here (the MAVLink setpoint's quaternion needs three).
pub fn sin_cos(x: f32) -> (f32, f32) {
    // pi/2 = PIO2_HI + PIO2_LO, PIO2_HI with 8 significant bits, so that `k * PIO2_HI` is
    // exact for every |k| < 2^16 (Cody and Waite's reduction).
    const PIO2_HI: f32 = 1.570_312_5;
    const PIO2_LO: f32 = 4.838_268e-4;
    let k = libm::roundf(x * core::f32::consts::FRAC_2_PI);
    let r = (x - k * PIO2_HI) - k * PIO2_LO;
    let r2 = r * r;
    let sin = r
        * (1.0
            + r2 * (-1.0 / 6.0
                + r2 * (1.0 / 120.0 + r2 * (-1.0 / 5040.0 + r2 * (1.0 / 362_880.0)))));
    let cos = 1.0
        + r2 * (-0.5
            + r2 * (1.0 / 24.0
                + r2 * (-1.0 / 720.0 + r2 * (1.0 / 40_320.0 + r2 * (-1.0 / 3_628_800.0)))));
    // The quadrant: k mod 4 (k is an integer-valued float; `as` saturates, never panics).
    match (k as i32) & 3 {
        0 => (sin, cos),
        1 => (cos, -sin),
        2 => (-sin, -cos),
        _ => (-cos, sin),
    }
}

/// `angle` wrapped to `[-pi, pi]`, rad.
pub fn wrap_pi(angle: f32) -> f32 {
    libm::remainderf(angle, core::f32::consts::TAU)
}

/// Everything the decoder received and did not use, and why; the navigation samples it
/// could not build; and the session's setpoints refused and frames dropped: the telemetry
/// frame's [`ibvs_core::wire::AutopilotLinkCounters`], filled here.
pub use ibvs_core::wire::AutopilotLinkCounters as Counters;

/// Adds one to a counter, saturating.
fn bump(counter: &mut u32) {
    *counter = counter.saturating_add(1);
}

/// A message the decoder has just taken from the autopilot.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Received {
    /// `HEARTBEAT`.
    Heartbeat,
    /// `ATTITUDE`.
    Attitude,
    /// `LOCAL_POSITION_NED`.
    LocalPositionNed,
    /// `GLOBAL_POSITION_INT`.
    GlobalPositionInt,
    /// `VFR_HUD`.
    VfrHud,
    /// `AOA_SSA`.
    AoaSsa,
    /// `PARAM_VALUE` of the autopilot's pitch or roll attitude time constant, kept.
    TimeConstant(Axis),
}

/// An axis of the autopilot's attitude loop.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axis {
    /// Pitch (`PTCH2SRV_TCONST`, `FW_P_TC`).
    Pitch,
    /// Roll (`RLL2SRV_TCONST`, `FW_R_TC`).
    Roll,
}

impl Axis {
    /// The axis whose attitude time constant the parameter `name` is (any of the four names
    /// of ArduPlane and PX4), or `None`.
    pub fn of_time_constant(name: &[u8]) -> Option<Self> {
        let is = |n: &str| name == n.as_bytes();
        if is(ARDUPLANE_PITCH_TC) || is(PX4_PITCH_TC) {
            Some(Self::Pitch)
        } else if is(ARDUPLANE_ROLL_TC) || is(PX4_ROLL_TC) {
            Some(Self::Roll)
        } else {
            None
        }
    }
}

/// A `param_id`'s name: its bytes up to the first NUL (all 16 when there is none).
pub(crate) fn param_name(id: &[u8; PARAM_ID_LEN]) -> &[u8] {
    let end = id.iter().position(|&b| b == 0).unwrap_or(PARAM_ID_LEN);
    id.get(..end).unwrap_or(id)
}

/// The autopilot's attitude-loop time constants read from its parameters, s, and when each
/// arrived (the caller's wrapping millisecond clock); `None` before a value is kept.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AttitudeTimeConstants {
    /// Pitch-angle loop time constant, s (finite, positive).
    pub pitch_s: Option<f32>,
    /// Roll-angle loop time constant, s (finite, positive).
    pub roll_s: Option<f32>,
    /// When the pitch value arrived, ms.
    pub pitch_at_ms: Option<u32>,
    /// When the roll value arrived, ms.
    pub roll_at_ms: Option<u32>,
}

impl AttitudeTimeConstants {
    /// Whether both time constants have arrived.
    pub const fn complete(&self) -> bool {
        self.pitch_s.is_some() && self.roll_s.is_some()
    }

    /// Whether they are those `design` was made for, each within `tolerance` (relative) of
    /// the design's.
    pub fn check(&self, design: &AttitudeLoopConfig, tolerance: f32) -> TimeConstantCheck {
        let near = |got: f32, want: f32| (got - want).abs() <= tolerance * want;
        match (self.pitch_s, self.roll_s) {
            (Some(p), Some(r)) => {
                if near(p, design.pitch_time_constant_s) && near(r, design.roll_time_constant_s) {
                    TimeConstantCheck::Match
                } else {
                    TimeConstantCheck::Mismatch
                }
            }
            _ => TimeConstantCheck::Unknown,
        }
    }

    /// `cfg` with its `pitch_time_constant_s` and `roll_time_constant_s` replaced by those
    /// that arrived (a missing one keeps `cfg`'s). Only finite positive values are ever kept,
    /// but no range is checked here: the caller puts the result into its
    /// [`ibvs_core::config::ControllerConfig`] and validates the whole configuration
    /// ([`ibvs_core::config::ControllerConfig::validate`]) before flying it, as for any other
    /// configuration change.
    pub fn apply_to(&self, cfg: AttitudeLoopConfig) -> AttitudeLoopConfig {
        AttitudeLoopConfig {
            pitch_time_constant_s: self.pitch_s.unwrap_or(cfg.pitch_time_constant_s),
            roll_time_constant_s: self.roll_s.unwrap_or(cfg.roll_time_constant_s),
            ..cfg
        }
    }
}

/// The autopilot's attitude time constants against a design's
/// ([`AttitudeTimeConstants::check`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TimeConstantCheck {
    /// Both arrived and each is within the tolerance of the design's.
    Match,
    /// Both arrived and one is not.
    Mismatch,
    /// Not both arrived yet.
    Unknown,
}

/// A message and the time it arrived (the caller's wrapping millisecond clock).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Stamped<T> {
    value: T,
    at_ms: u32,
}

/// The latest of each message read from the autopilot.
#[derive(Debug, Clone, Default)]
struct Latest {
    heartbeat: Option<Stamped<HEARTBEAT_DATA>>,
    attitude: Option<Stamped<ATTITUDE_DATA>>,
    local: Option<Stamped<LOCAL_POSITION_NED_DATA>>,
    global: Option<Stamped<GLOBAL_POSITION_INT_DATA>>,
    vfr_hud: Option<Stamped<VFR_HUD_DATA>>,
    aoa_ssa: Option<Stamped<AOA_SSA_DATA>>,
    pitch_tc: Option<Stamped<f32>>,
    roll_tc: Option<Stamped<f32>>,
}

/// The autopilot's flight mode, as far as setpoints are concerned.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AutopilotMode {
    /// ArduPlane in GUIDED: accepts setpoints.
    Guided,
    /// PX4 in OFFBOARD: accepts setpoints.
    Offboard,
    /// ArduPlane or PX4 in another mode (its `custom_mode`): does not accept setpoints.
    Other(u32),
    /// No heartbeat yet, or an autopilot (or ArduPilot vehicle type) this module does not
    /// know the modes of.
    Unknown,
}

/// The autopilot's software, as far as its modes and parameters are concerned.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AutopilotKind {
    /// ArduPlane: `MAV_AUTOPILOT_ARDUPILOTMEGA`, `MAV_TYPE_FIXED_WING`.
    ArduPlane,
    /// PX4: `MAV_AUTOPILOT_PX4`, any vehicle type.
    Px4,
}

impl AutopilotKind {
    /// The kind of an autopilot's heartbeat; `None` for another autopilot or ArduPilot
    /// vehicle type.
    pub fn from_heartbeat(hb: &HEARTBEAT_DATA) -> Option<Self> {
        match (hb.autopilot, hb.mavtype) {
            (MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA, MavType::MAV_TYPE_FIXED_WING) => {
                Some(Self::ArduPlane)
            }
            (MavAutopilot::MAV_AUTOPILOT_PX4, _) => Some(Self::Px4),
            _ => None,
        }
    }

    /// The names of its pitch and roll attitude-loop time constant parameters (seconds),
    /// in that order, for [`Encoder::param_request_read`].
    pub const fn time_constant_params(self) -> [&'static str; 2] {
        match self {
            Self::ArduPlane => [ARDUPLANE_PITCH_TC, ARDUPLANE_ROLL_TC],
            Self::Px4 => [PX4_PITCH_TC, PX4_ROLL_TC],
        }
    }
}

impl AutopilotMode {
    /// The mode of an autopilot's heartbeat.
    pub fn from_heartbeat(hb: &HEARTBEAT_DATA) -> Self {
        match AutopilotKind::from_heartbeat(hb) {
            Some(AutopilotKind::ArduPlane) => {
                if hb.custom_mode == ARDUPLANE_GUIDED {
                    Self::Guided
                } else {
                    Self::Other(hb.custom_mode)
                }
            }
            Some(AutopilotKind::Px4) => {
                if (hb.custom_mode >> 16) & 0xFF == PX4_MAIN_MODE_OFFBOARD {
                    Self::Offboard
                } else {
                    Self::Other(hb.custom_mode)
                }
            }
            None => Self::Unknown,
        }
    }

    /// Whether the autopilot flies attitude setpoints in this mode.
    pub const fn accepts_setpoints(self) -> bool {
        matches!(self, Self::Guided | Self::Offboard)
    }
}

/// What the autopilot's latest heartbeat says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AutopilotStatus {
    /// Its mode.
    pub mode: AutopilotMode,
    /// Whether it is armed (`MAV_MODE_FLAG_SAFETY_ARMED`).
    pub armed: bool,
    /// Age of the heartbeat, ms; `None` before the first.
    pub age_ms: Option<u32>,
}

impl AutopilotStatus {
    /// Whether setpoints would be flown: a mode that accepts them, from a heartbeat no older
    /// than `max_age_ms`.
    pub fn accepts_setpoints(&self, max_age_ms: u32) -> bool {
        self.mode.accepts_setpoints() && self.age_ms.is_some_and(|a| a <= max_age_ms)
    }
}

/// What a navigation sample needs besides the autopilot's messages.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NavConfig {
    /// The tanker's track, true north, rad.
    pub track_rad: f32,
    /// The tanker's ground speed along its track, m/s.
    pub tanker_speed_mps: f32,
    /// Oldest `ATTITUDE` used, ms.
    pub attitude_max_age_ms: u32,
    /// Oldest `LOCAL_POSITION_NED` or `GLOBAL_POSITION_INT` used, ms.
    pub velocity_max_age_ms: u32,
    /// Oldest `VFR_HUD` used, ms.
    pub air_data_max_age_ms: u32,
    /// Oldest `AOA_SSA` used, ms (older, alpha is estimated and beta taken as 0).
    pub aoa_max_age_ms: u32,
}

impl Default for NavConfig {
    /// Track north, the single-point design's speed; 100 ms for attitude and velocity
    /// (autopilots stream them at 10..50 Hz), 500 ms for `VFR_HUD` (4..10 Hz), 200 ms for
    /// `AOA_SSA`.
    fn default() -> Self {
        Self {
            track_rad: 0.0,
            tanker_speed_mps: ibvs_core::gains::TRIM.speed_mps,
            attitude_max_age_ms: 100,
            velocity_max_age_ms: 100,
            air_data_max_age_ms: 500,
            aoa_max_age_ms: 200,
        }
    }
}

/// The messages a navigation sample requires.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NavSource {
    /// `ATTITUDE`.
    Attitude,
    /// `LOCAL_POSITION_NED` or `GLOBAL_POSITION_INT`.
    Velocity,
    /// `VFR_HUD`.
    AirData,
}

/// Why no navigation sample was built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NavBuildError {
    /// The message never arrived.
    Missing(NavSource),
    /// The message is older than its age in [`NavConfig`].
    Stale(NavSource),
    /// The flight condition has no design in the schedule.
    Schedule(ScheduleError),
    /// A value (message or parameter) is NaN or infinite.
    NonFinite,
}

/// Where the sample's angle of attack came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AlphaSource {
    /// `AOA_SSA.AOA` (a vane or an estimate of the autopilot's).
    AoaSsa,
    /// `pitch - flight-path angle` (no wind, wings near level).
    PitchMinusPathAngle,
}

/// Where the sample's sideslip came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BetaSource {
    /// `AOA_SSA.SSA`.
    AoaSsa,
    /// Not measured: taken as 0.
    AssumedZero,
}

/// A navigation sample and where its air angles came from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NavFix {
    /// The sample.
    pub sample: NavSample,
    /// Its angle of attack's source.
    pub alpha: AlphaSource,
    /// Its sideslip's source.
    pub beta: BetaSource,
}

/// Frame boundary state: bytes of the frame so far, and its length once the header is in.
#[derive(Debug, Clone)]
struct Framer {
    raw: MAVLinkV2MessageRaw,
    len: usize,
    frame_len: usize,
}

/// The autopilot-to-flight-computer side: bytes in, messages kept, counters.
#[derive(Debug, Clone)]
pub struct Decoder {
    ids: LinkIds,
    framer: Framer,
    latest: Latest,
    /// Last sequence number per component of the autopilot's system.
    last_sequence: [Option<u8>; 256],
    counters: Counters,
}

impl Decoder {
    /// A decoder that reads from the autopilot of `ids`.
    pub fn new(ids: LinkIds) -> Self {
        Self {
            ids,
            framer: Framer {
                raw: MAVLinkV2MessageRaw::new(),
                len: 0,
                frame_len: HEADER_LEN,
            },
            latest: Latest::default(),
            last_sequence: [None; 256],
            counters: Counters::default(),
        }
    }

    /// The counters.
    pub fn counters(&self) -> &Counters {
        &self.counters
    }

    /// Takes one byte, arrived at `now_ms`; the message it completed, if any was read.
    pub fn push(&mut self, byte: u8, now_ms: u32) -> Option<Received> {
        let f = &mut self.framer;
        if f.len == 0 && byte != STX_V2 {
            bump(&mut self.counters.noise_bytes);
            return None;
        }
        if let Some(slot) = f.raw.as_mut_slice().get_mut(f.len) {
            *slot = byte;
            f.len += 1;
        }
        if f.len == HEADER_LEN && !self.header_in() {
            return None;
        }
        if self.framer.len < self.framer.frame_len {
            return None;
        }
        self.framer.len = 0;
        self.framer.frame_len = HEADER_LEN;
        self.frame_in(now_ms)
    }

    /// The header is in: the frame's length, or the frame dropped (false) for flags other
    /// than signing.
    fn header_in(&mut self) -> bool {
        let raw = &self.framer.raw;
        let flags = raw.incompatibility_flags();
        if flags & !consts::v2::IFLAG_SIGNED != 0 {
            bump(&mut self.counters.bad_flags);
            self.framer.len = 0;
            return false;
        }
        let signature = if flags & consts::v2::IFLAG_SIGNED != 0 {
            consts::v2::SIGNATURE_SIZE
        } else {
            0
        };
        self.framer.frame_len =
            HEADER_LEN + usize::from(raw.payload_length()) + consts::CHECKSUM_SIZE + signature;
        true
    }

    /// A whole frame is in: checked, filtered, counted and decoded.
    fn frame_in(&mut self, now_ms: u32) -> Option<Received> {
        let raw = &self.framer.raw;
        let id = raw.message_id();
        let extra = MavMessage::extra_crc(id);
        // The dialect's table answers 0 for an id it does not know; the one message whose
        // CRC extra really is 0 is COMPONENT_INFORMATION (a test checks every id).
        if extra == 0 && id != CRC_EXTRA_ZERO_ID {
            bump(&mut self.counters.unknown_id);
            return None;
        }
        if !raw.has_valid_crc_with_extra_crc(extra) {
            bump(&mut self.counters.bad_crc);
            return None;
        }
        if raw.incompatibility_flags() & consts::v2::IFLAG_SIGNED != 0 {
            bump(&mut self.counters.signed_unverified);
        }
        if raw.system_id() != u32::from(self.ids.autopilot_system) {
            bump(&mut self.counters.other_system);
            return None;
        }
        self.track_sequence(raw.component_id(), raw.sequence());
        let raw = &self.framer.raw;
        if raw.component_id() != self.ids.autopilot_component {
            bump(&mut self.counters.other_component);
            return None;
        }
        self.decode(id, now_ms)
    }

    /// Counts the frames missing before `sequence` from `component`.
    fn track_sequence(&mut self, component: u8, sequence: u8) {
        if let Some(last) = self.last_sequence.get_mut(usize::from(component)) {
            if let Some(prev) = *last {
                let gap = sequence.wrapping_sub(prev.wrapping_add(1));
                self.counters.dropped = self.counters.dropped.saturating_add(u32::from(gap));
            }
            *last = Some(sequence);
        }
    }

    /// Decodes a good frame from the autopilot and keeps it.
    fn decode(&mut self, id: u32, now_ms: u32) -> Option<Received> {
        if id == PARAM_VALUE_DATA::ID {
            return self.param_value(now_ms);
        }
        let payload = self.framer.raw.payload();
        let l = &mut self.latest;
        let got = match id {
            HEARTBEAT_DATA::ID => keep(&mut l.heartbeat, payload, now_ms, Received::Heartbeat),
            ATTITUDE_DATA::ID => keep(&mut l.attitude, payload, now_ms, Received::Attitude),
            LOCAL_POSITION_NED_DATA::ID => {
                keep(&mut l.local, payload, now_ms, Received::LocalPositionNed)
            }
            GLOBAL_POSITION_INT_DATA::ID => {
                keep(&mut l.global, payload, now_ms, Received::GlobalPositionInt)
            }
            VFR_HUD_DATA::ID => keep(&mut l.vfr_hud, payload, now_ms, Received::VfrHud),
            AOA_SSA_DATA::ID => keep(&mut l.aoa_ssa, payload, now_ms, Received::AoaSsa),
            _ => {
                bump(&mut self.counters.unused);
                return None;
            }
        };
        match got {
            Some(r) => {
                bump(&mut self.counters.frames_used);
                Some(r)
            }
            None => {
                bump(&mut self.counters.parse_errors);
                None
            }
        }
    }

    /// A good `PARAM_VALUE` from the autopilot: an attitude time constant kept, or counted
    /// (unused for another parameter, refused for a value that is not a finite positive
    /// `REAL32`, a parse error for a payload the crate refused).
    fn param_value(&mut self, now_ms: u32) -> Option<Received> {
        let payload = self.framer.raw.payload();
        let Ok(p) = PARAM_VALUE_DATA::deser(MavlinkVersion::V2, payload) else {
            bump(&mut self.counters.parse_errors);
            return None;
        };
        let Some(axis) = Axis::of_time_constant(param_name(&p.param_id)) else {
            bump(&mut self.counters.unused);
            return None;
        };
        let value = p.param_value;
        let real = p.param_type == MavParamType::MAV_PARAM_TYPE_REAL32;
        if !(real && value.is_finite() && value > 0.0) {
            bump(&mut self.counters.param_refused);
            return None;
        }
        let slot = match axis {
            Axis::Pitch => &mut self.latest.pitch_tc,
            Axis::Roll => &mut self.latest.roll_tc,
        };
        *slot = Some(Stamped {
            value,
            at_ms: now_ms,
        });
        bump(&mut self.counters.frames_used);
        Some(Received::TimeConstant(axis))
    }

    /// The autopilot's attitude-loop time constants kept from its `PARAM_VALUE`s.
    pub fn attitude_time_constants(&self) -> AttitudeTimeConstants {
        let (p, r) = (&self.latest.pitch_tc, &self.latest.roll_tc);
        AttitudeTimeConstants {
            pitch_s: p.map(|s| s.value),
            roll_s: r.map(|s| s.value),
            pitch_at_ms: p.map(|s| s.at_ms),
            roll_at_ms: r.map(|s| s.at_ms),
        }
    }

    /// The autopilot's kind from its latest heartbeat; `None` before the first or for an
    /// autopilot this module does not know ([`AutopilotKind::from_heartbeat`]).
    pub fn autopilot_kind(&self) -> Option<AutopilotKind> {
        self.latest
            .heartbeat
            .as_ref()
            .and_then(|hb| AutopilotKind::from_heartbeat(&hb.value))
    }

    /// The autopilot's mode, whether it is armed and the age of its heartbeat at `now_ms`.
    pub fn autopilot(&self, now_ms: u32) -> AutopilotStatus {
        match &self.latest.heartbeat {
            Some(hb) => AutopilotStatus {
                mode: AutopilotMode::from_heartbeat(&hb.value),
                armed: hb
                    .value
                    .base_mode
                    .contains(MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED),
                age_ms: Some(now_ms.wrapping_sub(hb.at_ms)),
            },
            None => AutopilotStatus {
                mode: AutopilotMode::Unknown,
                armed: false,
                age_ms: None,
            },
        }
    }

    /// The navigation sample at `now_ms` from the latest messages (module doc, "The
    /// navigation sample, field by field"); a refusal is counted.
    pub fn nav_sample(&mut self, now_ms: u32, cfg: &NavConfig) -> Result<NavFix, NavBuildError> {
        let result = build_nav(&self.latest, now_ms, cfg);
        if let Err(e) = result {
            let c = &mut self.counters;
            bump(match e {
                NavBuildError::Missing(_) => &mut c.nav_missing,
                NavBuildError::Stale(_) => &mut c.nav_stale,
                NavBuildError::Schedule(_) => &mut c.nav_schedule,
                NavBuildError::NonFinite => &mut c.nav_non_finite,
            });
        }
        result
    }
}

/// Decodes `payload` as `D` into `slot` at `now_ms`: `received`, or `None` if the crate
/// refused the payload.
fn keep<D: MessageData>(
    slot: &mut Option<Stamped<D>>,
    payload: &[u8],
    now_ms: u32,
    received: Received,
) -> Option<Received> {
    let value = D::deser(MavlinkVersion::V2, payload).ok()?;
    *slot = Some(Stamped {
        value,
        at_ms: now_ms,
    });
    Some(received)
}

/// The message in `slot` if it is no older than `max_age_ms` at `now_ms`.
fn fresh<T>(
    slot: &Option<Stamped<T>>,
    now_ms: u32,
    max_age_ms: u32,
    source: NavSource,
) -> Result<&T, NavBuildError> {
    let s = slot.as_ref().ok_or(NavBuildError::Missing(source))?;
    if now_ms.wrapping_sub(s.at_ms) <= max_age_ms {
        Ok(&s.value)
    } else {
        Err(NavBuildError::Stale(source))
    }
}

/// The aircraft's velocity and position from the autopilot, NED.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Kinematics {
    /// North, east, down velocity, m/s.
    v_ned: [f32; 3],
    /// North and east from the local origin, m (0 when only the global position came).
    ne: [f32; 2],
    /// Height above the origin or home, up, m.
    up: f32,
}

/// Velocity and position from `LOCAL_POSITION_NED` when fresh, else `GLOBAL_POSITION_INT`.
fn kinematics(l: &Latest, now_ms: u32, cfg: &NavConfig) -> Result<Kinematics, NavBuildError> {
    let max = cfg.velocity_max_age_ms;
    let local = fresh(&l.local, now_ms, max, NavSource::Velocity);
    if let Ok(p) = local {
        return Ok(Kinematics {
            v_ned: [p.vx, p.vy, p.vz],
            ne: [p.x, p.y],
            up: -p.z,
        });
    }
    match fresh(&l.global, now_ms, max, NavSource::Velocity) {
        Ok(g) => Ok(Kinematics {
            v_ned: [g.vx, g.vy, g.vz].map(|cm| f32::from(cm) / 100.0),
            ne: [0.0, 0.0],
            up: g.relative_alt as f32 / 1000.0,
        }),
        // Stale beats missing: say the one that arrived is old.
        Err(e) => Err(match (local, e) {
            (Err(NavBuildError::Stale(s)), _) => NavBuildError::Stale(s),
            (_, e) => e,
        }),
    }
}

/// ISA density ratio at `altitude_m` (troposphere formula, clamped to -500..11000 m).
pub(crate) fn isa_density_ratio(altitude_m: f32) -> f32 {
    let h = altitude_m.clamp(-500.0, 11_000.0);
    libm::powf(1.0 - 2.255_77e-5 * h, 4.255_88)
}

/// The flight condition from `VFR_HUD`: its airspeed taken as EAS, made true with the ISA
/// density at its altitude.
fn condition(hud: &VFR_HUD_DATA) -> FlightCondition {
    FlightCondition {
        true_airspeed_mps: hud.airspeed / libm::sqrtf(isa_density_ratio(hud.alt)),
        altitude_m: hud.alt,
    }
}

/// The sample from the latest messages (module doc).
fn build_nav(l: &Latest, now_ms: u32, cfg: &NavConfig) -> Result<NavFix, NavBuildError> {
    if !(cfg.track_rad.is_finite() && cfg.tanker_speed_mps.is_finite()) {
        return Err(NavBuildError::NonFinite);
    }
    let att = fresh(
        &l.attitude,
        now_ms,
        cfg.attitude_max_age_ms,
        NavSource::Attitude,
    )?;
    let kin = kinematics(l, now_ms, cfg)?;
    let hud = fresh(
        &l.vfr_hud,
        now_ms,
        cfg.air_data_max_age_ms,
        NavSource::AirData,
    )?;
    let condition = condition(hud);
    let trim = schedule::trim_at(condition).map_err(NavBuildError::Schedule)?;
    let aoa = fresh(&l.aoa_ssa, now_ms, cfg.aoa_max_age_ms, NavSource::AirData).ok();
    let [vn, ve, vd] = kin.v_ned;
    let ground_speed = libm::hypotf(vn, ve);
    let (alpha, alpha_source, beta, beta_source) = match aoa {
        Some(a) => (
            a.AOA.to_radians(),
            AlphaSource::AoaSsa,
            a.SSA.to_radians(),
            BetaSource::AoaSsa,
        ),
        None => (
            att.pitch - libm::atan2f(-vd, ground_speed),
            AlphaSource::PitchMinusPathAngle,
            0.0,
            BetaSource::AssumedZero,
        ),
    };
    let (st, ct) = sin_cos(cfg.track_rad);
    let [n, e] = kin.ne;
    let sample = NavSample {
        lon: LonNav {
            x_fwd_m: n * ct + e * st,
            h_up_m: kin.up,
            theta_rad: att.pitch - trim.theta_rad,
            v_mps: ground_speed - cfg.tanker_speed_mps,
            alpha_rad: alpha - trim.alpha_rad,
            q_radps: att.pitchspeed,
        },
        lat: LatNav {
            y_right_m: -n * st + e * ct,
            psi_rad: wrap_pi(att.yaw - cfg.track_rad),
            phi_rad: att.roll,
            beta_rad: beta,
            p_radps: att.rollspeed,
            r_radps: att.yawspeed,
        },
        condition,
    };
    if !sample.as_array().iter().all(|v| v.is_finite()) {
        return Err(NavBuildError::NonFinite);
    }
    Ok(NavFix {
        sample,
        alpha: alpha_source,
        beta: beta_source,
    })
}

#[cfg(test)]
mod tests;

#[cfg(test)]
mod pymavlink;
