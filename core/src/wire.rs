//! The serial link protocol between the flight computer and its peer (the simulator over
//! processor-in-the-loop, or the avionics): messages, frame format, encoder and a streaming
//! decoder. Both ends use this module, so there is one definition of the bytes.
//!
//! Place in the data flow: measurement frames ([`Uplink`]: the step's [`ControllerInput`] and
//! a link sequence number) come in; the firmware steps the controller and sends a command
//! frame ([`Downlink`]: the [`ControllerOutput`], the echo of the measurement frame's sequence
//! number, status bits, the [`Cost`] of the step and the configuration's id). What changes
//! rarely travels apart, in telemetry frames ([`Telemetry`]: the controller's [`Counters`], the
//! link's own [`LinkCounters`], why the flight computer last reset and what clock it runs on):
//! the flight computer sends one after its boot frame, on request, and in the free-running
//! schedule whenever a counter changed (at most every [`TELEMETRY_MIN_PERIODS`] control
//! periods) and at least every [`TELEMETRY_MAX_PERIODS`]. The counters only grow, so a later
//! telemetry frame carries everything an earlier one did: nothing is lost by sending them
//! less often than every step, and the command frame of every step stays small (its encoding
//! is on the control task's deadline; a telemetry frame's is not).
//!
//! # Frame layout
//!
//! ```text
//! payload  = version (u8, PROTOCOL_VERSION) | kind (u8, FrameKind) | body (postcard, at most
//!            MAX_BODY_LEN = 694 bytes)
//!          | CRC-32C of version..body (Castagnoli, CRC_32_ISCSI: poly 0x1EDC6F41 reflected,
//!            init and xorout 0xFFFFFFFF), 4 bytes little-endian
//! on wire  = COBS(payload) | 0x00            at most MAX_FRAME_LEN = 704 bytes
//! ```
//!
//! | kind byte | direction | body | answer |
//! |---|---|---|---|
//! | `M` 0x4D measurement | peer to flight computer | [`Uplink`] | a `C` frame |
//! | `C` 0x43 command | flight computer to peer | [`Downlink`] | - |
//! | `W` 0x57 configuration write | peer to flight computer | [`ControllerConfig`] | a `K` frame |
//! | `R` 0x52 configuration read | peer to flight computer | empty | a `K` frame |
//! | `K` 0x4B configuration report | flight computer to peer | [`ConfigReport`] | - |
//! | `Q` 0x51 telemetry request | peer to flight computer | empty | a `T` frame |
//! | `T` 0x54 telemetry | flight computer to peer | [`Telemetry`] | - |
//!
//! # Configuration
//!
//! The controller's configuration travels whole: a `W` frame carries a complete
//! [`ControllerConfig`] (540 bytes of postcard for the default), and the flight computer
//! answers with a [`ConfigReport`]: what it did ([`ConfigStatus`]: applied, rejected by
//! validation with the field and problem, refused because the controller is not in standby,
//! or malformed) and the configuration it now flies, with that configuration's
//! [`config_id`]. Whole rather than by field path, because validation relates fields to one
//! another (a closing-speed band, a gate radius inside another): a whole configuration is
//! validated and applied in one piece between two steps, so no step ever flies half of one.
//! Every command frame carries the active configuration's id ([`Downlink::config_id`]), so a
//! log says which configuration flew each step.
//!
//! postcard writes unsigned integers wider than a byte as LEB128 varints (1 to 5 bytes for a
//! `u32`), `u8` and `bool` as one byte, `f32` as 4 bytes little-endian, an enum's variant
//! index as a varint, `Option` as a tag byte and the value.
//! Every frame's size, smallest and largest, derived from the types, is in
//! `docs/interface.md` (the link's interface control document, which a test keeps equal to
//! these types: field order, encodings, enum numbers, bits and sizes).
//!
//! COBS makes the payload free of zeros, so `0x00` only ever ends a frame: a receiver that
//! lost sync (garbage, a cut frame) resynchronises at the next zero. An empty frame (two zeros
//! in a row) is idle fill, not an error; a sender may send a zero before a frame to end any
//! garbage the receiver holds.
//!
//! # Invariants
//! - Every message fits: the largest [`Downlink`] (every field at its longest encoding) is
//!   under [`MAX_BODY_LEN`] (tested).
//! - [`FrameDecoder::feed`] takes any byte sequence, one byte at a time, in a fixed buffer,
//!   never panics and never allocates (property-tested); every frame it rejects is named by a
//!   [`WireError`], which [`LinkCounters::count`] maps to exactly one counter.
//! - A frame with any single byte changed (other than into a zero) is rejected: either its
//!   COBS structure or the CRC catches it (property-tested).

use serde::{Deserialize, Serialize};

use crate::config::{ConfigError, ConfigProblem, ControllerConfig};
#[cfg(doc)]
use crate::controller::Controller;
use crate::controller::{ControllerInput, ControllerOutput, Counters, ReconfigureError};
pub use crate::crc32c::crc32c;
use crate::measurement::{MeasurementError, SequenceCheck};
use crate::mode::Mode;

/// Protocol version carried in every frame's first byte; bumped on any layout change.
pub const PROTOCOL_VERSION: u8 = 19;

/// Largest frame on the wire, bytes: COBS-encoded payload plus the terminating zero.
pub const MAX_FRAME_LEN: usize = 704;

/// Largest payload (header, body and CRC) before COBS encoding, bytes. COBS adds one code
/// byte per block of at most 254 data bytes, so at most 3 to a payload of up to 762 bytes;
/// with the terminating zero such a frame is at most [`MAX_FRAME_LEN`].
pub const MAX_PAYLOAD_LEN: usize = MAX_FRAME_LEN - 4;

/// Largest payload of a measurement or command frame (the frames of every step), bytes (the
/// largest of each, every field at its longest encoding, is under it: tested). At most one
/// COBS block (254 bytes), so these frames are encoded in place.
pub const STEP_PAYLOAD_LEN: usize = 200;

/// Header bytes before the body: version and kind.
pub const HEADER_LEN: usize = 2;

/// CRC bytes after the body.
pub const CRC_LEN: usize = 4;

/// Largest postcard body, bytes.
pub const MAX_BODY_LEN: usize = MAX_PAYLOAD_LEN - HEADER_LEN - CRC_LEN;

/// What a frame carries (its second byte).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameKind {
    /// [`Uplink`]: peer to flight computer.
    Measurement,
    /// [`Downlink`]: flight computer to peer.
    Command,
    /// [`ControllerConfig`]: peer to flight computer, to fly from now on (standby only).
    ConfigWrite,
    /// Empty body: peer to flight computer, asking for the configuration flown.
    ConfigRead,
    /// [`ConfigReport`]: flight computer to peer, the answer to a write or a read.
    ConfigReport,
    /// Empty body: peer to flight computer, asking for a telemetry frame now.
    TelemetryRequest,
    /// [`Telemetry`]: flight computer to peer.
    Telemetry,
}

impl FrameKind {
    /// The kind byte on the wire.
    pub const fn byte(self) -> u8 {
        match self {
            Self::Measurement => b'M',
            Self::Command => b'C',
            Self::ConfigWrite => b'W',
            Self::ConfigRead => b'R',
            Self::ConfigReport => b'K',
            Self::TelemetryRequest => b'Q',
            Self::Telemetry => b'T',
        }
    }

    /// The kind of a kind byte, if it is one.
    pub const fn from_byte(b: u8) -> Option<Self> {
        match b {
            b'M' => Some(Self::Measurement),
            b'C' => Some(Self::Command),
            b'W' => Some(Self::ConfigWrite),
            b'R' => Some(Self::ConfigRead),
            b'K' => Some(Self::ConfigReport),
            b'Q' => Some(Self::TelemetryRequest),
            b'T' => Some(Self::Telemetry),
            _ => None,
        }
    }
}

/// Measurement frame: one step's input for the controller.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Uplink {
    /// Link sequence number of this frame, +1 per new frame (wraps). Independent of the
    /// camera's frame counter inside `input`: a retransmission repeats this number.
    pub seq: u32,
    /// The step's input.
    pub input: ControllerInput,
}

/// Link status bits of one command frame ([`Downlink::link_status`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LinkStatus(pub u8);

impl LinkStatus {
    /// Sent once after reset, before any step: the link is up. Output is the standby trim.
    pub const BOOT: u8 = 1 << 0;
    /// Answer to a repeated measurement frame: the previous answer again, no new step.
    pub const RETRANSMIT: u8 = 1 << 1;
    /// The firmware runs the free-running fixed-rate schedule (else lockstep).
    pub const FREE_RUNNING: u8 = 1 << 2;
    /// Free-running: no new measurement frame arrived since the previous step; this step
    /// reused the previous input (the core rejects its camera frame as repeated).
    pub const INPUT_HELD: u8 = 1 << 3;
    /// No current measurement: in the free-running schedule no new measurement frame for
    /// longer than the link timeout (the step ran with the navigation marked invalid), or
    /// none received yet (boot frame, standby trim without a step).
    pub const STALE: u8 = 1 << 4;
    /// Sent by the panic handler: commands are trim, the controller is stopped.
    pub const PANIC: u8 = 1 << 5;
    /// A panic record from before the last reset was found at boot.
    pub const PREVIOUS_PANIC: u8 = 1 << 6;
    /// Boot frame: the configuration flown is the one found in the board's configuration
    /// store (else the built-in default: none stored, none valid, or a board without one).
    pub const STORED_CONFIG: u8 = 1 << 7;

    /// True when every bit of `mask` is set.
    pub fn contains(self, mask: u8) -> bool {
        self.0 & mask == mask
    }
}

/// Unit of the [`Cost`] figures.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CostUnit {
    /// No counter on this platform (a host build): the figures are zero.
    #[default]
    Unavailable,
    /// Executed instructions (QEMU with `-icount shift=0`: TIM2 counts one per instruction).
    Instructions,
    /// CPU clock cycles (the DWT cycle counter on hardware).
    Cycles,
}

/// What the flight computer spent, in [`Cost::unit`], each figure read from the same counter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Cost {
    /// Unit of the figures below.
    pub unit: CostUnit,
    /// The controller step of this frame (`Controller::step` only).
    pub step: u32,
    /// Decoding the measurement frame this step used: every byte through the streaming
    /// decoder and the deserialisation, summed over the bytes (each byte's figure includes
    /// the counter read, one instruction). 0 when the step reused an earlier frame. Through
    /// the autopilot (the attitude-command loop), also the autopilot's MAVLink bytes decoded
    /// since the last step and the navigation sample built from them.
    pub decode: u32,
    /// Encoding the previous command frame (this one's is not known until it is encoded);
    /// through the autopilot, also that step's MAVLink frames (heartbeat, setpoint).
    pub encode_prev: u32,
}

/// The MAVLink link to an autopilot (the `autopilot-link` crate, flying the attitude-command
/// inner loop), since reset: everything its decoder received and did not use, and why; the
/// navigation samples it could not build; the setpoints it could not encode and the frames
/// its transmit queue refused. Each counter saturates at `u32::MAX`. All zero when the link
/// is not used.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AutopilotLinkCounters {
    /// Frames used: from the autopilot, CRC good, a message this module reads, decoded.
    pub frames_used: u32,
    /// Bytes outside any MAVLink 2 frame (line noise, MAVLink 1 frames, a lost start).
    pub noise_bytes: u32,
    /// Frames with incompatibility flags other than signing (dropped whole).
    pub bad_flags: u32,
    /// Frames whose message id the dialect does not know (their CRC cannot be checked).
    pub unknown_id: u32,
    /// Frames of a known message whose CRC is wrong.
    pub bad_crc: u32,
    /// Signed frames accepted with their signature unchecked.
    pub signed_unverified: u32,
    /// Good frames from a system other than the autopilot's.
    pub other_system: u32,
    /// Good frames from another component of the autopilot's system.
    pub other_component: u32,
    /// Good frames of messages of the dialect this module does not read.
    pub unused: u32,
    /// Good frames of a message this module reads whose payload the crate refused (an enum
    /// value it does not know).
    pub parse_errors: u32,
    /// `PARAM_VALUE`s of an attitude time constant (`autopilot-link`, "Attitude time constants")
    /// refused: not `MAV_PARAM_TYPE_REAL32`, not finite, or not positive.
    pub param_refused: u32,
    /// Frames missing from the autopilot system's components' sequence numbers.
    pub dropped: u32,
    /// Navigation samples refused because a required message never arrived.
    pub nav_missing: u32,
    /// Navigation samples refused because a required message was too old.
    pub nav_stale: u32,
    /// Navigation samples refused because the condition is outside the schedule.
    pub nav_schedule: u32,
    /// Navigation samples refused because a value was not finite.
    pub nav_non_finite: u32,
    /// Setpoints not sent: the command was not finite or its throttle outside 0..1 (never
    /// from the core, whose commands are checked; counted rather than assumed).
    pub setpoints_refused: u32,
    /// Frames to the autopilot its transmit queue could not take whole (dropped, never sent
    /// in part).
    pub tx_dropped: u32,
    /// Receiver errors on the autopilot's serial port (hardware overrun, noise, framing;
    /// receive queue full): bytes lost before the decoder.
    pub rx_errors: u32,
    /// Steps not ready because the autopilot's pitch and roll attitude time constants had
    /// not both arrived (requested from it at 1 Hz until they have).
    pub time_constants_unknown: u32,
    /// Steps not ready because the autopilot's attitude time constants differ from those the
    /// attitude loop was designed on by more than the tolerance (10 %).
    pub time_constants_mismatch: u32,
}

/// Running counts of the link's receive side and schedule, since reset (saturating).
/// Nothing received is dropped without a count.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LinkCounters {
    /// Measurement frames accepted (valid, new sequence number).
    pub frames_ok: u32,
    /// Frames with a COBS error, shorter than header and CRC, or a CRC mismatch.
    pub corrupt: u32,
    /// Frames longer than [`MAX_FRAME_LEN`] (discarded up to the next zero).
    pub oversize: u32,
    /// Frames with a good CRC whose body is not a valid message (or has trailing bytes).
    pub malformed: u32,
    /// Frames of another protocol version or of the wrong kind.
    pub wrong_version: u32,
    /// Measurement frames never received: the sum of the sequence gaps.
    pub seq_gap: u32,
    /// Measurement frames received again (same sequence number as the last one).
    pub seq_repeat: u32,
    /// Measurement frames older than the last one (discarded).
    pub seq_old: u32,
    /// Free-running: times the link went stale (no new frame for longer than the timeout).
    pub timeouts: u32,
    /// Free-running: steps run on a stale link.
    pub stale_steps: u32,
    /// Free-running: steps that reused the previous input (no new frame that period).
    pub held_steps: u32,
    /// Free-running: control periods that passed without their step (deadline missed).
    pub deadline_missed: u32,
    /// Command frames of a step handed to the transmit queue later than the control task's
    /// deadline after their trigger (the period tick, free-running; the measurement frame's
    /// last byte, lockstep). The frame is still sent; this frame counts it in the next.
    pub deadline_overruns: u32,
    /// Receiver hardware errors (overrun, noise, framing) and receive-buffer overflows.
    pub rx_errors: u32,
    /// Command frames that could not be encoded (never expected; not sent).
    pub tx_errors: u32,
    /// Frames not sent because the transmit queue could not take them whole (never sent in
    /// part).
    pub tx_dropped: u32,
    /// Configuration writes applied.
    pub config_applied: u32,
    /// Configuration writes refused: invalid, malformed, or not in standby (each answered
    /// with its [`ConfigStatus`]).
    pub config_refused: u32,
    /// Applied configurations the board's store failed to write ([`ConfigStorage::Failed`]).
    pub config_store_failed: u32,
    /// `Engage` requests not passed to the controller because the reset before this boot was
    /// abnormal ([`ResetCause::needs_acknowledgement`], or a fault record) and the peer has
    /// not yet acknowledged it with a `Reset` request.
    pub engage_inhibited: u32,
}

/// Why the flight computer last reset, as its board read it at boot (one byte on the wire).
/// Every telemetry frame carries it ([`Telemetry::reset_cause`]), so a peer that connects
/// late (hardware in the loop opens the link after the boot frame) still learns it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ResetCause {
    /// The board could not tell (no reset flag set, or a board that does not read them).
    #[default]
    Unknown,
    /// Power-on or power-down reset: the supply came up.
    PowerOn,
    /// Brown-out reset: the supply fell below the brown-out level and came back.
    BrownOut,
    /// The reset pin (NRST) alone: a button or a debug probe.
    Pin,
    /// A software reset (the core's system reset request: the firmware itself, or a debug
    /// probe's reset).
    Software,
    /// The independent watchdog expired: the main loop stopped completing its passes.
    IndependentWatchdog,
    /// The window watchdog expired.
    WindowWatchdog,
    /// Low-power management reset (entering Stop or Standby when the option bytes forbid it).
    LowPower,
}

impl ResetCause {
    /// True for a cause that is not an operator's deliberate start (a watchdog, a brown-out,
    /// a low-power reset, or one the board could not tell): after it the flight computer
    /// stays in standby until the peer acknowledges the reset with a `Reset` request, so a
    /// peer that keeps asking to engage does not re-engage it unawares.
    pub const fn needs_acknowledgement(self) -> bool {
        matches!(
            self,
            Self::Unknown
                | Self::BrownOut
                | Self::IndependentWatchdog
                | Self::WindowWatchdog
                | Self::LowPower
        )
    }
}

/// The clock the flight computer runs on, as its board set it up at boot (one byte on the
/// wire, [`Telemetry::clock`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ClockSource {
    /// Not reported (a board without a clock tree to set up: QEMU's).
    #[default]
    NotReported,
    /// The external crystal through the PLL (the design).
    Crystal,
    /// The crystal did not start within the boot's bounded wait: the internal RC oscillator
    /// through the PLL, at the same frequencies but with the RC's accuracy (1 % at 25 °C,
    /// -8..+4.5 % over the temperature range: the STM32F405xx datasheet's HSI
    /// characteristics), and the serial link's timing with it: the controller stays in
    /// standby until the peer's `Reset` shows the link works (the firmware's boot module).
    InternalFallback,
}

fn bump(c: &mut u32, by: u32) {
    *c = c.saturating_add(by);
}

impl LinkCounters {
    /// Counts one rejected frame under its counter.
    pub fn count(&mut self, e: WireError) {
        let c = match e {
            WireError::Cobs | WireError::TooShort | WireError::Crc => &mut self.corrupt,
            WireError::Oversize => &mut self.oversize,
            WireError::Malformed => &mut self.malformed,
            WireError::VersionMismatch | WireError::WrongKind => &mut self.wrong_version,
            WireError::BufferTooSmall | WireError::TooLarge => &mut self.tx_errors,
        };
        bump(c, 1);
    }

    /// Counts a measurement frame's sequence check (from a
    /// [`crate::measurement::SequenceTracker`] of link sequence numbers); true when the frame
    /// is new and is to be used.
    pub fn count_sequence(&mut self, check: SequenceCheck) -> bool {
        match check {
            SequenceCheck::New { dropped } => {
                bump(&mut self.seq_gap, dropped);
                bump(&mut self.frames_ok, 1);
                true
            }
            SequenceCheck::Rejected(MeasurementError::Repeated) => {
                bump(&mut self.seq_repeat, 1);
                false
            }
            SequenceCheck::Rejected(_) => {
                bump(&mut self.seq_old, 1);
                false
            }
        }
    }

    /// Frames rejected before their sequence number was read (every error counter of the
    /// receive side: corrupt, oversize, malformed, wrong version).
    pub fn rejected_frames(&self) -> u32 {
        self.corrupt
            .saturating_add(self.oversize)
            .saturating_add(self.malformed)
            .saturating_add(self.wrong_version)
    }
}

/// Command frame: one step's output (every control period).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Downlink {
    /// Frame counter, 0 for the boot frame, +1 per frame the flight computer sends (command,
    /// telemetry and configuration report frames share it; wraps).
    pub seq: u32,
    /// [`Uplink::seq`] of the measurement frame the step used; `None` before the first.
    pub echo_seq: Option<u32>,
    /// Link status bits ([`LinkStatus`] constants).
    pub link_status: LinkStatus,
    /// The step's output: commands, mode, breakaway reason, status bits, errors.
    pub output: ControllerOutput,
    /// What the step cost.
    pub cost: Cost,
    /// [`config_id`] of the configuration the controller flies.
    pub config_id: u32,
}

/// Telemetry frame: the counters of the controller and of the link, and what the flight
/// computer found at boot. Sent after the boot frame, on request ([`FrameKind::TelemetryRequest`]),
/// and in the free-running schedule whenever a counter changed (at most every
/// [`TELEMETRY_MIN_PERIODS`]) and at least every [`TELEMETRY_MAX_PERIODS`] control periods.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Telemetry {
    /// Frame counter, shared with the command frames ([`Downlink::seq`]).
    pub seq: u32,
    /// The controller's counters after its latest step ([`Counters::steps`] says which).
    pub counters: Counters,
    /// The link's counters, every rejected frame and transmit failure included.
    pub link: LinkCounters,
    /// [`config_id`] of the configuration the controller flies.
    pub config_id: u32,
    /// Why the flight computer last reset (read at boot).
    pub reset_cause: ResetCause,
    /// The clock it runs on (set at boot).
    pub clock: ClockSource,
    /// Refuelling: the camera's calibration as learned in flight, the probe tip's image point
    /// the drogue's offset is taken from, normalised ([`Controller::probe_tip_image`];
    /// [`Counters::tip_sight_used`] says from how many sightings). A calibration changes
    /// over minutes, not steps: it travels here, not in every command frame.
    pub probe_tip_image: [f32; 2],
    /// The MAVLink link to the autopilot (all zero unless the attitude-command inner loop
    /// flies through it).
    pub autopilot: AutopilotLinkCounters,
}

/// Free-running: a changed counter is sent at most this often, control periods (10 = 200 ms,
/// 5 Hz): the telemetry frame's encoding and bytes are not spent every step.
pub const TELEMETRY_MIN_PERIODS: u32 = 10;

/// Free-running: a telemetry frame at least this often, control periods (50 = 1 s), changed or
/// not, so a peer that joins late (hardware in the loop) learns the counters and the boot's
/// findings within a second.
pub const TELEMETRY_MAX_PERIODS: u32 = 50;

/// A field path inside a [`ConfigReport`], with the validation's note on the rule broken
/// (the longest the validation names is 88 bytes; a longer one would be cut, never dropped).
pub type FieldPath = heapless::String<96>;

/// What the flight computer did with a configuration frame.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ConfigStatus {
    /// Answer to a read: the configuration flown, nothing changed.
    #[default]
    Active,
    /// The written configuration passed validation and is flown from the next step.
    Applied,
    /// The written configuration failed validation: the field (dotted path) and the
    /// problem. The previous configuration is still flown.
    Rejected {
        /// Dotted path of the offending field, as [`ConfigError::field`].
        field: FieldPath,
        /// What is wrong with it.
        problem: ConfigProblem,
    },
    /// Refused: the controller was not in standby (its mode). The previous configuration is
    /// still flown.
    NotStandby(Mode),
    /// The frame's body is not a configuration (its CRC was good). Nothing changed.
    Malformed,
}

impl ConfigStatus {
    /// The status of a validation failure.
    pub fn rejected(e: ConfigError) -> Self {
        let mut field = FieldPath::new();
        // A path longer than the string is cut at a character boundary, never dropped.
        for c in e.field.chars() {
            if field.push(c).is_err() {
                break;
            }
        }
        Self::Rejected {
            field,
            problem: e.problem,
        }
    }

    /// The status of a refused [`crate::Controller::reconfigure`].
    pub fn refused(e: ReconfigureError) -> Self {
        match e {
            ReconfigureError::NotStandby(m) => Self::NotStandby(m),
            ReconfigureError::Invalid(e) => Self::rejected(e),
        }
    }
}

/// Whether an applied configuration was written to the board's configuration store.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ConfigStorage {
    /// Nothing was to be written (a read, or a write not applied).
    #[default]
    NotWritten,
    /// Written; the board boots with it. Its record's generation (+1 per write).
    Stored {
        /// The record's generation.
        generation: u32,
    },
    /// The board has no configuration store (QEMU's): it boots with the built-in default.
    Unavailable,
    /// The write failed; the configuration is flown but the board boots with the previous
    /// stored one (counted, [`LinkCounters::config_store_failed`]).
    Failed,
}

/// Configuration report: the flight computer's answer to a configuration write or read.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ConfigReport {
    /// Frame counter, shared with the command frames ([`Downlink::seq`]).
    pub seq: u32,
    /// What was done with the frame answered.
    pub status: ConfigStatus,
    /// Whether an applied configuration was stored for the next boot.
    pub storage: ConfigStorage,
    /// [`config_id`] of `config`.
    pub config_id: u32,
    /// The configuration the controller flies after the frame answered. (The link's
    /// counters of configuration frames, [`LinkCounters::config_applied`] and
    /// [`LinkCounters::config_refused`], come in the next command frame.)
    pub config: ControllerConfig,
}

/// A frame the flight computer takes: what the peer sends.
#[allow(
    clippy::large_enum_variant,
    reason = "no allocator to box the configuration; a message lives on the stack for one frame"
)]
#[derive(Debug, Clone, PartialEq)]
pub enum PeerMessage {
    /// A measurement frame.
    Measurement(Uplink),
    /// A configuration write.
    ConfigWrite(ControllerConfig),
    /// A configuration read.
    ConfigRead,
    /// A telemetry request.
    TelemetryRequest,
}

/// A frame the peer takes: what the flight computer sends.
#[allow(
    clippy::large_enum_variant,
    reason = "no allocator to box the configuration; a message lives on the stack for one frame"
)]
#[derive(Debug, Clone, PartialEq)]
pub enum FlightComputerMessage {
    /// A command frame.
    Command(Downlink),
    /// A configuration report.
    ConfigReport(ConfigReport),
    /// A telemetry frame.
    Telemetry(Telemetry),
}

/// The identifier of a configuration: CRC-32C of its postcard encoding. Equal
/// configurations have equal ids; a changed field changes the id except with probability
/// about 2^-32.
pub fn config_id(cfg: &ControllerConfig) -> u32 {
    let mut buf = [0u8; MAX_BODY_LEN];
    match config_to_bytes(cfg, &mut buf) {
        Ok(bytes) => crc32c(bytes),
        // Every configuration fits (tested); 0 would still be a stated, constant id.
        Err(_) => 0,
    }
}

/// The postcard encoding of `cfg` in `buf` (a configuration write's body; the firmware's
/// configuration store keeps the same bytes). Not inlined: one copy of the serialiser of
/// the whole configuration serves every caller (it is several kilobytes of flash).
#[inline(never)]
pub fn config_to_bytes<'a>(
    cfg: &ControllerConfig,
    buf: &'a mut [u8],
) -> Result<&'a [u8], WireError> {
    match postcard::to_slice(cfg, buf) {
        Ok(bytes) => Ok(bytes),
        Err(_) => Err(WireError::TooLarge),
    }
}

/// The configuration whose postcard encoding is exactly `bytes` ([`WireError::Malformed`]
/// otherwise, trailing bytes included). Not inlined, as [`config_to_bytes`].
#[inline(never)]
pub fn config_from_bytes(bytes: &[u8]) -> Result<ControllerConfig, WireError> {
    match postcard::take_from_bytes(bytes) {
        Ok((cfg, [])) => Ok(cfg),
        _ => Err(WireError::Malformed),
    }
}

/// Why a frame could not be encoded or decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WireError {
    /// Encoder: the output buffer is too small for the frame.
    BufferTooSmall,
    /// Encoder: the message body is longer than [`MAX_BODY_LEN`].
    TooLarge,
    /// A COBS block runs past the end of the frame.
    Cobs,
    /// More than [`MAX_FRAME_LEN`] bytes before the terminating zero.
    Oversize,
    /// The payload is shorter than header and CRC.
    TooShort,
    /// The CRC does not match.
    Crc,
    /// Another protocol version.
    VersionMismatch,
    /// Not the kind of frame expected (or an unknown kind byte).
    WrongKind,
    /// The body does not deserialise into the message, or has bytes left over.
    Malformed,
}

impl core::fmt::Display for WireError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::BufferTooSmall => "output buffer too small",
            Self::TooLarge => "message body too large",
            Self::Cobs => "COBS block runs past the frame end",
            Self::Oversize => "frame longer than MAX_FRAME_LEN",
            Self::TooShort => "frame shorter than header and CRC",
            Self::Crc => "CRC mismatch",
            Self::VersionMismatch => "protocol version mismatch",
            Self::WrongKind => "wrong frame kind",
            Self::Malformed => "body does not deserialise",
        })
    }
}

impl core::error::Error for WireError {}

/// COBS-encodes `src` into `dst`; returns the encoded length (no terminating zero). Minimal
/// encoding: `src.len() + 1` bytes for up to 254 bytes, one more per further block of 254.
fn cobs_encode(src: &[u8], dst: &mut [u8]) -> Result<usize, WireError> {
    let mut put = |i: usize, b: u8| -> Result<(), WireError> {
        *dst.get_mut(i).ok_or(WireError::BufferTooSmall)? = b;
        Ok(())
    };
    let (mut code_at, mut out, mut code) = (0usize, 1usize, 1u8);
    for (i, &b) in src.iter().enumerate() {
        if b != 0 {
            put(out, b)?;
            out += 1;
            code += 1;
        }
        if b == 0 || (code == 0xFF && i + 1 < src.len()) {
            put(code_at, code)?;
            code_at = out;
            out += 1;
            code = 1;
        }
    }
    put(code_at, code)?;
    Ok(out)
}

/// postcard's output over a slice, by index: a push or a copy checks its bounds once, and a
/// copy of a known small size (an `f32`'s four bytes) compiles to plain stores.
struct Cursor<'a> {
    buf: &'a mut [u8],
    len: usize,
}

impl postcard::ser_flavors::Flavor for Cursor<'_> {
    type Output = usize;

    #[inline(always)]
    fn try_push(&mut self, b: u8) -> postcard::Result<()> {
        let slot = self
            .buf
            .get_mut(self.len)
            .ok_or(postcard::Error::SerializeBufferFull)?;
        *slot = b;
        self.len += 1;
        Ok(())
    }

    #[inline(always)]
    fn try_extend(&mut self, data: &[u8]) -> postcard::Result<()> {
        let end = self.len + data.len();
        self.buf
            .get_mut(self.len..end)
            .ok_or(postcard::Error::SerializeBufferFull)?
            .copy_from_slice(data);
        self.len = end;
        Ok(())
    }

    fn finalize(self) -> postcard::Result<usize> {
        Ok(self.len)
    }
}

/// Largest payload encoded in place ([`cobs_in_place`]): one COBS block, bytes. Every
/// measurement and command frame's payload is at most [`STEP_PAYLOAD_LEN`], under it (tested).
const IN_PLACE_PAYLOAD_LEN: usize = 254;
const _: () = assert!(STEP_PAYLOAD_LEN <= IN_PLACE_PAYLOAD_LEN);

/// COBS in place: `frame[1..=n]` holds the payload (`n` at most [`IN_PLACE_PAYLOAD_LEN`], so
/// no block is full and no code byte is inserted); each zero of the payload becomes the
/// distance to the next zero (or to the end), `frame[0]` the distance to the first, and
/// `frame[n + 1]` the terminating zero. One pass over the payload from its end, so that each
/// zero is written as it is found, with the distance to the one after it; no copy.
fn cobs_in_place(frame: &mut [u8], n: usize) -> Result<(), WireError> {
    if n > IN_PLACE_PAYLOAD_LEN {
        return Err(WireError::TooLarge);
    }
    let frame = frame.get_mut(..n + 2).ok_or(WireError::BufferTooSmall)?;
    let (code, rest) = frame.split_at_mut(1);
    let (payload, end) = rest.split_at_mut(n);
    // Where the block after the byte being looked at ends: the next zero, or the end.
    let mut next = n + 1;
    for (i, byte) in payload.iter_mut().enumerate().rev() {
        if *byte == 0 {
            *byte = (next - (i + 1)) as u8;
            next = i + 1;
        }
    }
    if let Some(c) = code.first_mut() {
        *c = next as u8;
    }
    if let Some(z) = end.first_mut() {
        *z = 0;
    }
    Ok(())
}

/// Writes `msg`'s payload as a `kind` frame's (version, kind, postcard body, CRC) at
/// `out[1..]`, where COBS leaves it, and returns its length: at most `max_payload` bytes
/// ([`WireError::TooLarge`] past it; [`WireError::BufferTooSmall`] when `out` is the limit).
fn write_payload<T: Serialize>(
    kind: FrameKind,
    msg: &T,
    out: &mut [u8],
    max_payload: usize,
) -> Result<usize, WireError> {
    let (head, rest) = out
        .split_at_mut_checked(1 + HEADER_LEN)
        .ok_or(WireError::BufferTooSmall)?;
    head[1] = PROTOCOL_VERSION;
    head[2] = kind.byte();
    let max_body = max_payload - HEADER_LEN - CRC_LEN;
    let room = rest.len().min(max_body + CRC_LEN).saturating_sub(CRC_LEN);
    let body = rest.get_mut(..room).ok_or(WireError::BufferTooSmall)?;
    let body_len =
        postcard::serialize_with_flavor(msg, Cursor { buf: body, len: 0 }).map_err(|_| {
            if room < max_body {
                WireError::BufferTooSmall
            } else {
                WireError::TooLarge
            }
        })?;
    let data_len = HEADER_LEN + body_len;
    let crc = crc32c(out.get(1..=data_len).ok_or(WireError::TooLarge)?);
    out.get_mut(1 + data_len..1 + data_len + CRC_LEN)
        .ok_or(WireError::BufferTooSmall)?
        .copy_from_slice(&crc.to_le_bytes());
    Ok(data_len + CRC_LEN)
}

/// Encodes `msg` as a `kind` frame of any size (COBS, ending in its zero) into `out`; returns
/// its length. A payload of at most [`IN_PLACE_PAYLOAD_LEN`] bytes is COBS-encoded where it
/// lies ([`cobs_in_place`]); a longer one (a configuration) is copied out and encoded back
/// block by block ([`cobs_encode`]).
fn encode_frame<T: Serialize>(
    kind: FrameKind,
    msg: &T,
    out: &mut [u8],
) -> Result<usize, WireError> {
    let payload_len = write_payload(kind, msg, out, MAX_PAYLOAD_LEN)?;
    if payload_len <= IN_PLACE_PAYLOAD_LEN {
        cobs_in_place(out, payload_len)?;
        return Ok(payload_len + 2);
    }
    let mut payload = [0u8; MAX_PAYLOAD_LEN];
    let payload = payload.get_mut(..payload_len).ok_or(WireError::TooLarge)?;
    payload.copy_from_slice(out.get(1..=payload_len).ok_or(WireError::TooLarge)?);
    let n = cobs_encode(payload, out)?;
    *out.get_mut(n).ok_or(WireError::BufferTooSmall)? = 0;
    Ok(n + 1)
}

/// Encodes `msg` as a frame of one COBS block (a payload of at most
/// [`IN_PLACE_PAYLOAD_LEN`] bytes, [`WireError::TooLarge`] past it), in place: the encoder of
/// the frames of every step (measurement, command), with no copy and no general path in its
/// code.
fn encode_step_frame<'a, T: Serialize>(
    kind: FrameKind,
    msg: &T,
    out: &'a mut [u8],
) -> Result<&'a [u8], WireError> {
    let payload_len = write_payload(kind, msg, out, IN_PLACE_PAYLOAD_LEN)?;
    cobs_in_place(out, payload_len)?;
    framed(out, payload_len + 2)
}

/// The first `n` bytes of `out`: the frame [`encode_frame`] wrote (`n` fits, as that
/// function checked; `get` keeps a panic path out of callers that cannot see it).
fn framed(out: &[u8], n: usize) -> Result<&[u8], WireError> {
    out.get(..n).ok_or(WireError::BufferTooSmall)
}

/// Encodes any serialisable `body` as a frame of `kind` into `out`; returns the frame, ending
/// in its `0x00`. The typed encoders below are this with the body their kind carries; this
/// one lets a test or a tool build a frame whose body does not match its kind.
pub fn encode_message<'a, T: Serialize>(
    kind: FrameKind,
    body: &T,
    out: &'a mut [u8],
) -> Result<&'a [u8], WireError> {
    let n = encode_frame(kind, body, out)?;
    framed(out, n)
}

/// Encodes a configuration write into `out` (at least [`MAX_FRAME_LEN`] bytes suffice);
/// returns the frame, ending in its `0x00`.
pub fn encode_config_write<'a>(
    cfg: &ControllerConfig,
    out: &'a mut [u8],
) -> Result<&'a [u8], WireError> {
    encode_message(FrameKind::ConfigWrite, cfg, out)
}

/// Encodes a configuration read into `out`; returns the frame, ending in its `0x00`.
pub fn encode_config_read(out: &mut [u8]) -> Result<&[u8], WireError> {
    encode_message(FrameKind::ConfigRead, &(), out)
}

/// Encodes a configuration report into `out` (at least [`MAX_FRAME_LEN`] bytes suffice);
/// returns the frame, ending in its `0x00`.
pub fn encode_config_report<'a>(
    r: &ConfigReport,
    out: &'a mut [u8],
) -> Result<&'a [u8], WireError> {
    encode_message(FrameKind::ConfigReport, r, out)
}

/// Encodes a measurement frame into `out` (at least [`MAX_FRAME_LEN`] bytes suffice); returns
/// the frame, ending in its `0x00`.
pub fn encode_uplink<'a>(msg: &Uplink, out: &'a mut [u8]) -> Result<&'a [u8], WireError> {
    encode_step_frame(FrameKind::Measurement, msg, out)
}

/// Encodes a command frame into `out` (at least [`MAX_FRAME_LEN`] bytes suffice); returns the
/// frame, ending in its `0x00`.
pub fn encode_downlink<'a>(msg: &Downlink, out: &'a mut [u8]) -> Result<&'a [u8], WireError> {
    encode_step_frame(FrameKind::Command, msg, out)
}

/// Encodes a telemetry frame into `out` (at least [`MAX_FRAME_LEN`] bytes suffice); returns
/// the frame, ending in its `0x00`. Its largest (every counter at its largest, the MAVLink
/// link's included) is more than one COBS block, so it takes the general encoder: it is
/// sent after the step's command frame, outside the control task's deadline. Out of line:
/// the control task's static bound (target-bench) leaves it out by this name.
#[inline(never)]
pub fn encode_telemetry<'a>(t: &Telemetry, out: &'a mut [u8]) -> Result<&'a [u8], WireError> {
    encode_message(FrameKind::Telemetry, t, out)
}

/// Encodes a telemetry request into `out`; returns the frame, ending in its `0x00`.
pub fn encode_telemetry_request(out: &mut [u8]) -> Result<&[u8], WireError> {
    encode_message(FrameKind::TelemetryRequest, &(), out)
}

/// A frame that passed COBS, length, CRC and version checks: its kind and postcard body.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Payload<'a> {
    /// The frame's kind byte.
    pub kind: FrameKind,
    /// The postcard body.
    pub body: &'a [u8],
}

impl Payload<'_> {
    fn parse<'de, T: Deserialize<'de>>(
        body: &'de [u8],
        kind: FrameKind,
        want: FrameKind,
    ) -> Result<T, WireError> {
        if kind != want {
            return Err(WireError::WrongKind);
        }
        match postcard::take_from_bytes(body) {
            Ok((m, [])) => Ok(m),
            _ => Err(WireError::Malformed),
        }
    }

    /// An empty body, as a read or a request carries ([`WireError::Malformed`] otherwise).
    pub fn empty(&self) -> Result<(), WireError> {
        if self.body.is_empty() {
            Ok(())
        } else {
            Err(WireError::Malformed)
        }
    }

    /// The measurement message, or why not.
    pub fn uplink(&self) -> Result<Uplink, WireError> {
        Self::parse(self.body, self.kind, FrameKind::Measurement)
    }

    /// The command message, or why not.
    pub fn downlink(&self) -> Result<Downlink, WireError> {
        Self::parse(self.body, self.kind, FrameKind::Command)
    }

    /// The message of a frame the flight computer takes (measurement, configuration write or
    /// read), or why not; a frame of a kind the flight computer sends is
    /// [`WireError::WrongKind`].
    pub fn peer_message(&self) -> Result<PeerMessage, WireError> {
        match self.kind {
            FrameKind::Measurement => self.uplink().map(PeerMessage::Measurement),
            FrameKind::ConfigWrite => config_from_bytes(self.body).map(PeerMessage::ConfigWrite),
            FrameKind::ConfigRead => Self::parse::<()>(self.body, self.kind, FrameKind::ConfigRead)
                .map(|()| PeerMessage::ConfigRead),
            FrameKind::TelemetryRequest => {
                Self::parse::<()>(self.body, self.kind, FrameKind::TelemetryRequest)
                    .map(|()| PeerMessage::TelemetryRequest)
            }
            FrameKind::Command | FrameKind::ConfigReport | FrameKind::Telemetry => {
                Err(WireError::WrongKind)
            }
        }
    }

    /// The message of a frame the peer takes (command or configuration report), or why not.
    pub fn flight_computer_message(&self) -> Result<FlightComputerMessage, WireError> {
        match self.kind {
            FrameKind::Command => self.downlink().map(FlightComputerMessage::Command),
            FrameKind::ConfigReport => Self::parse(self.body, self.kind, FrameKind::ConfigReport)
                .map(FlightComputerMessage::ConfigReport),
            FrameKind::Telemetry => Self::parse(self.body, self.kind, FrameKind::Telemetry)
                .map(FlightComputerMessage::Telemetry),
            _ => Err(WireError::WrongKind),
        }
    }
}

/// Checks a decoded payload: length, CRC, version, kind.
fn check_payload(p: &[u8]) -> Result<Payload<'_>, WireError> {
    if p.len() < HEADER_LEN + CRC_LEN {
        return Err(WireError::TooShort);
    }
    let (data, crc) = p.split_at(p.len() - CRC_LEN);
    let mut sent = [0u8; CRC_LEN];
    sent.copy_from_slice(crc);
    if crc32c(data) != u32::from_le_bytes(sent) {
        return Err(WireError::Crc);
    }
    let (header, body) = data.split_at(HEADER_LEN);
    if header[0] != PROTOCOL_VERSION {
        return Err(WireError::VersionMismatch);
    }
    let kind = FrameKind::from_byte(header[1]).ok_or(WireError::WrongKind)?;
    Ok(Payload { kind, body })
}

/// What a pass of the decoder ends with: nothing yet (inside a frame, or an empty frame), or
/// at a frame's zero where its payload lies in the buffer (start and end) or why it was
/// rejected.
type FrameEnd = Option<Result<(usize, usize), WireError>>;

/// Streaming frame decoder: feed received bytes one at a time or in slices; a zero ends a
/// frame and yields its payload or the reason it was rejected.
///
/// The frame's bytes are kept as they arrive, in a fixed [`MAX_FRAME_LEN`]-byte buffer (no
/// allocation); at its zero the frame is COBS-decoded where it lies. A frame with no full
/// block followed by another (every frame of a payload up to 254 bytes, so every
/// measurement frame) decodes by turning each code byte after the first into the zero it
/// stands for: one step per block, and the payload is the buffer after the first code byte.
/// A longer frame is decoded byte by byte, out of line (`decode_long_frame`). A frame
/// that grows past [`MAX_FRAME_LEN`] is discarded up to the next zero and reported once,
/// as [`WireError::Oversize`], when that zero arrives.
#[derive(Debug, Clone)]
pub struct FrameDecoder {
    buf: [u8; MAX_FRAME_LEN],
    /// Bytes of this frame so far (its encoding, before the terminating zero).
    len: usize,
    /// The frame has already failed; the rest up to the next zero is skipped.
    discard: Option<WireError>,
}

impl Default for FrameDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameDecoder {
    /// An idle decoder (at a frame boundary).
    pub const fn new() -> Self {
        Self {
            buf: [0; MAX_FRAME_LEN],
            len: 0,
            discard: None,
        }
    }

    /// True between frames (nothing of a frame received yet).
    pub fn is_idle(&self) -> bool {
        self.len == 0 && self.discard.is_none()
    }

    /// Feeds one byte. Returns `None` inside a frame and for empty frames; at a frame's
    /// terminating zero, its checked payload or the reason it was rejected.
    pub fn feed(&mut self, byte: u8) -> Option<Result<Payload<'_>, WireError>> {
        self.feed_slice(core::slice::from_ref(&byte)).1
    }

    /// Feeds received bytes up to the end of the first frame among them: how many it took,
    /// and (when a terminating zero among them ended a frame) that frame's checked payload or
    /// the reason it was rejected. Bytes after that zero are left for the next call; an empty
    /// frame (an idle zero) ends the call with nothing. The same as [`FrameDecoder::feed`]
    /// byte by byte.
    pub fn feed_slice(&mut self, bytes: &[u8]) -> (usize, Option<Result<Payload<'_>, WireError>>) {
        let (taken, ended) = self.take(bytes);
        let frame = ended.map(|r| {
            r.and_then(|(start, end)| {
                self.buf
                    .get(start..end)
                    .map_or(Err(WireError::Oversize), check_payload)
            })
        });
        (taken, frame)
    }

    /// [`FrameDecoder::feed_slice`] up to the payload's check: how many bytes it took and,
    /// at a frame's end, where its payload lies in the buffer (or the rejection). The bytes
    /// up to the first zero are copied as they are, a byte an iteration. Out of line: one copy
    /// of its loops, the same on every board, for the static bound (`target-bench`).
    #[inline(never)]
    fn take(&mut self, bytes: &[u8]) -> (usize, FrameEnd) {
        if self.discard.is_some() {
            return self.skip(bytes);
        }
        let room = self.buf.get_mut(self.len..).unwrap_or_default();
        let mut copied = 0;
        for (slot, &byte) in room.iter_mut().zip(bytes) {
            if byte == 0 {
                break;
            }
            *slot = byte;
            copied += 1;
        }
        self.len += copied;
        match bytes.get(copied) {
            Some(0) => (copied + 1, self.finish()),
            // The buffer is full and the frame goes on: it is over MAX_FRAME_LEN.
            Some(_) => {
                self.discard = Some(WireError::Oversize);
                let (taken, ended) = self.skip(bytes.get(copied..).unwrap_or_default());
                (copied + taken, ended)
            }
            None => (copied, None),
        }
    }

    /// A rejected frame's bytes, skipped up to its zero. Out of line: a rare path, and one
    /// copy of its loop for the static bound (`target-bench`).
    #[inline(never)]
    fn skip(&mut self, bytes: &[u8]) -> (usize, FrameEnd) {
        match bytes.iter().position(|&b| b == 0) {
            Some(z) => (z + 1, self.finish()),
            None => (bytes.len(), None),
        }
    }

    /// The terminating zero: where the frame's payload lies, its rejection, or `None` for an
    /// empty frame (idle fill). The decoder is at a frame boundary after it (its buffer still
    /// holds the payload).
    fn finish(&mut self) -> FrameEnd {
        let (len, discard) = (self.len, self.discard);
        self.len = 0;
        self.discard = None;
        match discard {
            Some(e) => Some(Err(e)),
            None if len == 0 => None,
            None => Some(
                self.buf
                    .get_mut(..len)
                    .map_or(Err(WireError::Oversize), decode_frame),
            ),
        }
    }
}

/// COBS-decodes `frame` (its bytes without the terminating zero; none of them zero) where
/// it lies and returns where the payload is: `frame[1..]`, each code byte after the first
/// turned into the zero it stands for, one step per block. From a full block (code 0xFF, no
/// zero after it) followed by another, the bytes after it must move; [`decode_long_frame`]
/// goes on from there. A block that runs past the frame's end is [`WireError::Cobs`], a
/// payload over [`MAX_PAYLOAD_LEN`] [`WireError::Oversize`] (that first).
fn decode_frame(frame: &mut [u8]) -> Result<(usize, usize), WireError> {
    let n = frame.len();
    let mut at = 0;
    let mut code = frame.first().copied().unwrap_or(1);
    loop {
        let next = at + usize::from(code);
        if next >= n {
            break;
        }
        if code == 0xFF {
            return decode_long_frame(frame, at);
        }
        let Some(slot) = frame.get_mut(next) else {
            return Err(WireError::Cobs);
        };
        code = *slot;
        *slot = 0;
        at = next;
    }
    // Every byte after the first is the payload's, decoded or not: too many is the first
    // error (as when the bytes arrive one at a time), a block past the end the second.
    if n - 1 > MAX_PAYLOAD_LEN {
        Err(WireError::Oversize)
    } else if at + usize::from(code) > n {
        Err(WireError::Cobs)
    } else {
        Ok((1, n))
    }
}

/// [`decode_frame`] from the full block whose code byte is at `at` (0xFF; its place in
/// `frame` already holds the zero before it, or the first code byte at 0): the rest a byte
/// at a time, each moved to where its decoding puts it, `frame[1..]` as the payload so far
/// (never after where it was read, so in place). Only a payload over 254 bytes (a
/// configuration, never a measurement frame) comes here: out of line, off the measurement
/// frame's path.
#[inline(never)]
fn decode_long_frame(frame: &mut [u8], at: usize) -> Result<(usize, usize), WireError> {
    // The payload so far is frame[1..=at]; the block at `at` is full (no zero after it).
    let (mut out, mut remaining, mut zero_pending) = (at + 1, 0xFEu8, false);
    for i in at + 1..frame.len() {
        let byte = frame.get(i).copied().unwrap_or(0);
        let value = if remaining != 0 {
            remaining -= 1;
            byte
        } else {
            remaining = byte.wrapping_sub(1);
            let pending = zero_pending;
            zero_pending = byte != 0xFF;
            if !pending {
                continue;
            }
            0
        };
        if let Some(slot) = frame.get_mut(out) {
            *slot = value;
        }
        out += 1;
    }
    if out - 1 > MAX_PAYLOAD_LEN {
        Err(WireError::Oversize)
    } else if remaining != 0 {
        Err(WireError::Cobs)
    } else {
        Ok((1, out))
    }
}

/// Decodes exactly one frame: `frame`'s bytes up to its first zero (a missing terminating
/// zero is implied). An empty frame is [`WireError::TooShort`].
fn decode_one<T>(
    frame: &[u8],
    parse: impl Fn(&Payload<'_>) -> Result<T, WireError>,
) -> Result<T, WireError> {
    let mut d = FrameDecoder::new();
    for &b in frame.iter().chain(core::iter::once(&0)) {
        if let Some(r) = d.feed(b) {
            return r.and_then(|p| parse(&p));
        }
        if b == 0 {
            break;
        }
    }
    Err(WireError::TooShort)
}

/// Decodes one frame the flight computer takes (with or without its terminating zero).
pub fn decode_peer_message(frame: &[u8]) -> Result<PeerMessage, WireError> {
    decode_one(frame, |p| p.peer_message())
}

/// Decodes one frame the peer takes (with or without its terminating zero).
pub fn decode_flight_computer_message(frame: &[u8]) -> Result<FlightComputerMessage, WireError> {
    decode_one(frame, |p| p.flight_computer_message())
}

/// Decodes one measurement frame (with or without its terminating zero).
pub fn decode_uplink(frame: &[u8]) -> Result<Uplink, WireError> {
    decode_one(frame, |p| p.uplink())
}

/// Decodes one command frame (with or without its terminating zero).
pub fn decode_downlink(frame: &[u8]) -> Result<Downlink, WireError> {
    decode_one(frame, |p| p.downlink())
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::vec::Vec;

    use super::*;
    use crate::actuator::ActuatorCommand;
    use crate::controller::StatusFlags;
    use crate::estimator::DrogueEstimate;
    use crate::frames::{TargetEstimate, VelocityRe};
    use crate::measurement::{CameraMeasurement, MeasurementError};
    use crate::mode::{BreakawayReason, Mode, ModeRequest, NoGoReason};
    use crate::nav::{FlightCondition, NavError, NavSample};
    use crate::schedule::ScheduleError;
    use proptest::prelude::*;

    fn uplink() -> Uplink {
        let mut input = ControllerInput {
            measurement: CameraMeasurement {
                seq: u32::MAX,
                tracked: true,
                image_x: -0.3,
                image_y: 0.2,
                depth_m: 6.5,
                probe_tip: None,
            },
            probe_contact: true,
            autopilot_ready: true,
            request: ModeRequest::Engage,
            ..Default::default()
        };
        input.nav.lon.v_mps = f32::NAN; // must survive the trip bit for bit
        input.nav.lat.r_radps = -1e-30;
        Uplink {
            seq: u32::MAX,
            input,
        }
    }

    /// A command and a telemetry frame with every field at its longest postcard encoding.
    fn largest_frames() -> (Downlink, Telemetry) {
        let m = u32::MAX;
        let counters = Counters {
            steps: m,
            frames_valid: m,
            frames_dropped: m,
            not_tracked: m,
            non_finite: m,
            depth_not_positive: m,
            depth_too_large: m,
            outside_fov: m,
            repeated: m,
            out_of_order: m,
            frozen: m,
            nav_non_finite: m,
            nav_outside_envelope: m,
            outside_docking_envelope: m,
            measurement_held_steps: m,
            nav_held_steps: m,
            engage_refused: m,
            saturated_steps: m,
            integrator_frozen_steps: m,
            non_finite_commands: m,
            estimator_rejected: m,
            estimator_restarts: m,
            tip_sight_rejected: m,
            tip_sight_used: m,
            tip_sight_missing: m,
        };
        let link = LinkCounters {
            frames_ok: m,
            corrupt: m,
            oversize: m,
            malformed: m,
            wrong_version: m,
            seq_gap: m,
            seq_repeat: m,
            seq_old: m,
            timeouts: m,
            stale_steps: m,
            held_steps: m,
            deadline_missed: m,
            deadline_overruns: m,
            rx_errors: m,
            tx_errors: m,
            tx_dropped: m,
            config_applied: m,
            config_refused: m,
            config_store_failed: m,
            engage_inhibited: m,
        };
        let output = ControllerOutput {
            command: crate::attitude::Command::Surfaces(ActuatorCommand::from_array([-1.0; 4])),
            mode: Mode::Breakaway,
            breakaway_reason: Some(BreakawayReason::ContactLost),
            status: StatusFlags(u16::MAX),
            measurement_error: Some(MeasurementError::OutOfOrder),
            nav_error: Some(NavError::OutsideEnvelope),
            v_des: VelocityRe {
                x_right_mps: 1.0,
                y_down_mps: 1.0,
                z_fwd_mps: 1.0,
            },
            target: TargetEstimate {
                right_m: 1.0,
                down_m: 1.0,
                depth_m: 1.0,
            },
            step: m,
            attempt: u8::MAX,
            no_go: Some(NoGoReason::CaptureTimeout),
            estimate: DrogueEstimate {
                offset_m: [1.0; 2],
                mean_offset_m: [1.0; 2],
                drogue_velocity_mps: [1.0; 3],
                depth_m: 1.0,
            },
            predicted_miss_m: 1.0,
            envelope_error: Some(ScheduleError::AltitudeHigh),
        };
        (
            Downlink {
                seq: m,
                echo_seq: Some(m),
                link_status: LinkStatus(u8::MAX),
                output,
                cost: Cost {
                    unit: CostUnit::Cycles,
                    step: m,
                    decode: m,
                    encode_prev: m,
                },
                config_id: m,
            },
            Telemetry {
                seq: m,
                counters,
                link,
                config_id: m,
                reset_cause: ResetCause::LowPower,
                clock: ClockSource::InternalFallback,
                probe_tip_image: [f32::MAX; 2],
                autopilot: largest_autopilot_counters(),
            },
        )
    }

    /// Every MAVLink link counter at its largest (each field, so none is forgotten).
    fn largest_autopilot_counters() -> AutopilotLinkCounters {
        let m = u32::MAX;
        AutopilotLinkCounters {
            frames_used: m,
            noise_bytes: m,
            bad_flags: m,
            unknown_id: m,
            bad_crc: m,
            signed_unverified: m,
            other_system: m,
            other_component: m,
            unused: m,
            parse_errors: m,
            param_refused: m,
            dropped: m,
            nav_missing: m,
            nav_stale: m,
            nav_schedule: m,
            nav_non_finite: m,
            setpoints_refused: m,
            tx_dropped: m,
            rx_errors: m,
            time_constants_unknown: m,
            time_constants_mismatch: m,
        }
    }

    /// Every field at its longest postcard encoding.
    fn largest_downlink() -> Downlink {
        largest_frames().0
    }

    /// Every counter at its largest.
    fn largest_telemetry() -> Telemetry {
        largest_frames().1
    }

    /// A configuration report at its longest: the longest field path, every counter at its
    /// largest, the default configuration (its floats are fixed-size; its integers are
    /// small and the tests below measure the margin).
    fn largest_config_report() -> ConfigReport {
        let mut field = FieldPath::new();
        while field.push('x').is_ok() {}
        ConfigReport {
            seq: u32::MAX,
            status: ConfigStatus::Rejected {
                field,
                problem: ConfigProblem::Inconsistent,
            },
            storage: ConfigStorage::Stored {
                generation: u32::MAX,
            },
            config_id: u32::MAX,
            config: ControllerConfig::default(),
        }
    }

    #[test]
    fn cobs_matches_the_published_examples() {
        // Cheshire & Baker's examples (as in the Wikipedia table), without the delimiter.
        let cases: &[(&[u8], &[u8])] = &[
            (&[0x00], &[0x01, 0x01]),
            (&[0x00, 0x00], &[0x01, 0x01, 0x01]),
            (&[0x00, 0x11, 0x00], &[0x01, 0x02, 0x11, 0x01]),
            (&[0x11, 0x22, 0x00, 0x33], &[0x03, 0x11, 0x22, 0x02, 0x33]),
            (&[0x11, 0x22, 0x33, 0x44], &[0x05, 0x11, 0x22, 0x33, 0x44]),
            (&[0x11, 0x00, 0x00, 0x00], &[0x02, 0x11, 0x01, 0x01, 0x01]),
        ];
        for (src, want) in cases {
            let mut out = [0u8; 16];
            let n = cobs_encode(src, &mut out).unwrap();
            assert_eq!(&out[..n], *want, "{src:02x?}");
        }
        // 254 non-zero bytes: one full block, no trailing code.
        let src: Vec<u8> = (1..=254u8).collect();
        let mut out = [0u8; 300];
        let n = cobs_encode(&src, &mut out).unwrap();
        assert_eq!(n, 255);
        assert_eq!(out[0], 0xFF);
        // 255 non-zero bytes: a full block, then a block of one.
        let src: Vec<u8> = (0..255u32).map(|i| (i % 255) as u8 + 1).collect();
        let n = cobs_encode(&src, &mut out).unwrap();
        assert_eq!((n, out[0], out[255]), (257, 0xFF, 0x02));
    }

    /// Feeds `bytes` and collects every frame result (payload copied out).
    fn feed_all(
        d: &mut FrameDecoder,
        bytes: &[u8],
    ) -> Vec<Result<(FrameKind, Vec<u8>), WireError>> {
        bytes
            .iter()
            .filter_map(|&b| d.feed(b).map(|r| r.map(|p| (p.kind, p.body.to_vec()))))
            .collect()
    }

    /// COBS bytes a frame may have before its terminating zero.
    const MAX_ENCODED_LEN: usize = MAX_FRAME_LEN - 1;

    /// Bytes a COBS decoder outputs from `frame` (no zero in it) before it ends or fails:
    /// a block's data bytes, present or not, and the zero between two blocks.
    fn decoded_before_error(frame: &[u8]) -> usize {
        let (mut at, mut out) = (0, 0);
        while let Some(&code) = frame.get(at) {
            let data = (usize::from(code) - 1).min(frame.len() - at - 1);
            at += 1 + data;
            out += data + usize::from(code != 0xFF && at < frame.len());
        }
        out
    }

    #[test]
    fn uplink_round_trips_bit_for_bit() {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let m = uplink();
        let frame = encode_uplink(&m, &mut buf).unwrap();
        assert_eq!(frame.last(), Some(&0));
        assert!(!frame[..frame.len() - 1].contains(&0));
        let back = decode_uplink(frame).unwrap();
        assert_eq!(
            back.input.nav.lon.v_mps.to_bits(),
            m.input.nav.lon.v_mps.to_bits()
        );
        assert_eq!(back.input.measurement, m.input.measurement);
        assert_eq!((back.seq, back.input.request), (m.seq, ModeRequest::Engage));
        assert_eq!(decode_uplink(&frame[..frame.len() - 1]).unwrap().seq, m.seq);
    }

    #[test]
    fn largest_downlink_fits_and_round_trips() {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let m = largest_downlink();
        let body = postcard::to_slice(&m, &mut [0u8; 1024]).unwrap().len();
        assert!(body <= MAX_BODY_LEN, "body {body} > {MAX_BODY_LEN}");
        let payload = HEADER_LEN + body + CRC_LEN;
        assert!(
            payload + 8 <= STEP_PAYLOAD_LEN,
            "payload {payload}: STEP_PAYLOAD_LEN's margin"
        );
        let frame = encode_downlink(&m, &mut buf).unwrap();
        assert!(frame.len() <= MAX_FRAME_LEN);
        assert_eq!(decode_downlink(frame).unwrap(), m);
        // The measurement frame's too: both are encoded in place (one COBS block).
        let mut up = uplink();
        up.input.measurement.probe_tip = Some([f32::MAX; 2]);
        let up_body = postcard::to_slice(&up, &mut [0u8; 1024]).unwrap().len();
        assert!(
            HEADER_LEN + up_body + CRC_LEN <= STEP_PAYLOAD_LEN,
            "{up_body}"
        );
        // Telemetry, every counter at its largest: one frame.
        let t = largest_telemetry();
        let frame = encode_telemetry(&t, &mut buf).unwrap();
        let telemetry_len = frame.len();
        assert_eq!(
            decode_flight_computer_message(frame).unwrap(),
            FlightComputerMessage::Telemetry(t)
        );
        // The documented sizes (module doc): the extremes of both kinds.
        let small = encode_downlink(&Downlink::default(), &mut [0u8; MAX_FRAME_LEN])
            .unwrap()
            .len();
        let up_small = encode_uplink(&Uplink::default(), &mut [0u8; MAX_FRAME_LEN])
            .unwrap()
            .len();
        let mut big_up = uplink();
        big_up.input.request = ModeRequest::Reset;
        let up_big = encode_uplink(&big_up, &mut [0u8; MAX_FRAME_LEN])
            .unwrap()
            .len();
        let big = encode_downlink(&m, &mut buf).unwrap().len();
        let telemetry_small = encode_telemetry(&Telemetry::default(), &mut [0u8; MAX_FRAME_LEN])
            .unwrap()
            .len();
        assert_eq!(
            (up_small, up_big, small, big, telemetry_small, telemetry_len),
            (83, 91, 102, 138, 86, 359),
            "update the module doc"
        );
    }

    #[test]
    fn configuration_frames_fit_and_round_trip() {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let r = largest_config_report();
        let frame = encode_config_report(&r, &mut buf).unwrap();
        assert!(frame.len() <= MAX_FRAME_LEN);
        let got = decode_flight_computer_message(frame).unwrap();
        assert_eq!(got, FlightComputerMessage::ConfigReport(r));
        let report_len = frame.len();
        // The write: the configuration bit for bit, NaN-free but with its extreme integers.
        let mut cfg = ControllerConfig::paper();
        cfg.nav_latency_steps = u8::MAX;
        cfg.ibvs.k1_mps = -0.0;
        let frame = encode_config_write(&cfg, &mut buf).unwrap();
        let write_len = frame.len();
        match decode_peer_message(frame).unwrap() {
            PeerMessage::ConfigWrite(c) => {
                assert_eq!(c, cfg);
                assert!(c.ibvs.k1_mps.is_sign_negative(), "bits, not only value");
            }
            other => panic!("{other:?}"),
        }
        let frame = encode_config_read(&mut buf).unwrap();
        assert_eq!(decode_peer_message(frame).unwrap(), PeerMessage::ConfigRead);
        let frame = encode_telemetry_request(&mut buf).unwrap();
        assert_eq!(
            decode_peer_message(frame).unwrap(),
            PeerMessage::TelemetryRequest
        );
        assert_eq!(
            decode_flight_computer_message(frame),
            Err(WireError::WrongKind)
        );
        // The documented size of the default configuration, and the report's margin.
        let body = postcard::to_slice(&ControllerConfig::default(), &mut [0u8; 1024])
            .unwrap()
            .len();
        assert_eq!(body, 540, "update the module doc");
        assert!(
            write_len < report_len && report_len + 16 <= MAX_FRAME_LEN,
            "{report_len}"
        );
    }

    #[test]
    fn each_side_takes_only_its_own_frames() {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let up = encode_uplink(&uplink(), &mut buf).unwrap().to_vec();
        assert_eq!(
            decode_flight_computer_message(&up),
            Err(WireError::WrongKind)
        );
        let down = encode_downlink(&Downlink::default(), &mut buf)
            .unwrap()
            .to_vec();
        assert_eq!(decode_peer_message(&down), Err(WireError::WrongKind));
        let report = encode_config_report(&largest_config_report(), &mut buf)
            .unwrap()
            .to_vec();
        assert_eq!(decode_peer_message(&report), Err(WireError::WrongKind));
        let telemetry = encode_telemetry(&Telemetry::default(), &mut buf)
            .unwrap()
            .to_vec();
        assert_eq!(decode_peer_message(&telemetry), Err(WireError::WrongKind));
        // A read with a body, and a write whose body is not a configuration: malformed.
        let read_with_body = {
            let n = encode_frame(FrameKind::ConfigRead, &7u8, &mut buf).unwrap();
            buf[..n].to_vec()
        };
        assert_eq!(
            decode_peer_message(&read_with_body),
            Err(WireError::Malformed)
        );
        let short_write = {
            let n = encode_frame(FrameKind::ConfigWrite, &[1u8; 3], &mut buf).unwrap();
            buf[..n].to_vec()
        };
        assert_eq!(decode_peer_message(&short_write), Err(WireError::Malformed));
    }

    #[test]
    fn the_configuration_id_follows_every_field() {
        let base = ControllerConfig::default();
        assert_eq!(config_id(&base), config_id(&base.clone()));
        assert_ne!(config_id(&base), config_id(&ControllerConfig::paper()));
        let mut c = base;
        c.refuelling.gate_max_horizon_s += 1e-6;
        assert_ne!(config_id(&base), config_id(&c));
        let mut c = base;
        c.nav_latency_steps ^= 1;
        assert_ne!(config_id(&base), config_id(&c));
        let mut c = base;
        c.mass_factor = 0.9;
        assert_ne!(config_id(&base), config_id(&c));
    }

    #[test]
    fn a_rejection_carries_the_path_the_validation_named() {
        let mut bad = ControllerConfig::default();
        bad.modes.drogue_rate_filter = 1.5;
        let Err(e) = bad.validate() else {
            panic!("a filter of 1.5 is refused")
        };
        assert_eq!(e.field, "modes.drogue_rate_filter");
        match ConfigStatus::rejected(e) {
            ConfigStatus::Rejected { field, problem } => {
                assert_eq!(field.as_str(), e.field);
                assert_eq!(problem, e.problem);
            }
            other => panic!("{other:?}"),
        }
        let long = "a.very.long.path.that.does.not.fit.in.the.ninety.six.bytes.of.the.wire.field.path.string.at.all.not.at.all";
        match ConfigStatus::rejected(ConfigError {
            field: long,
            problem: ConfigProblem::NotFinite,
            requirement: "finite",
        }) {
            ConfigStatus::Rejected { field, .. } => assert_eq!(field.as_str(), &long[..96]),
            other => panic!("{other:?}"),
        }
        // Every path a rule can name fits on the wire whole.
        for rule in crate::config::RULES {
            let ConfigStatus::Rejected { field, .. } = ConfigStatus::rejected(ConfigError {
                field: rule.field,
                problem: ConfigProblem::Inconsistent,
                requirement: rule.requirement,
            }) else {
                panic!("a rejection")
            };
            assert_eq!(field.as_str(), rule.field);
        }
        assert_eq!(
            ConfigStatus::refused(ReconfigureError::NotStandby(Mode::Approach)),
            ConfigStatus::NotStandby(Mode::Approach)
        );
    }

    #[test]
    fn names_bad_frames() {
        let mut small = [0u8; 8];
        assert_eq!(
            encode_downlink(&largest_downlink(), &mut small).unwrap_err(),
            WireError::BufferTooSmall
        );
        // A block code that runs past the zero.
        assert_eq!(decode_uplink(&[0x05, 0x01, 0x00]), Err(WireError::Cobs));
        assert_eq!(decode_uplink(&[0x03, 0x01, 0x02]), Err(WireError::TooShort));
        assert_eq!(decode_uplink(&[]), Err(WireError::TooShort));

        let mut buf = [0u8; MAX_FRAME_LEN];
        let frame = encode_uplink(&uplink(), &mut buf).unwrap().to_vec();
        assert_eq!(decode_downlink(&frame), Err(WireError::WrongKind));
        let mut flipped = frame.clone();
        flipped[5] ^= 0x40;
        assert_eq!(decode_uplink(&flipped), Err(WireError::Crc));

        // Right CRC, wrong version / unknown kind / body that is not an Uplink.
        let raw = |payload: &[u8]| {
            let mut p = payload.to_vec();
            p.extend_from_slice(&crc32c(payload).to_le_bytes());
            let mut out = [0u8; 300];
            let n = cobs_encode(&p, &mut out).unwrap();
            out[..n].to_vec()
        };
        assert_eq!(
            decode_uplink(&raw(&[PROTOCOL_VERSION.wrapping_add(1), b'M', 1, 2])),
            Err(WireError::VersionMismatch)
        );
        assert_eq!(
            decode_uplink(&raw(&[PROTOCOL_VERSION, b'X', 1, 2])),
            Err(WireError::WrongKind)
        );
        assert_eq!(
            decode_uplink(&raw(&[PROTOCOL_VERSION, b'M', 1, 2])),
            Err(WireError::Malformed)
        );
        // A valid uplink body with a byte left over.
        let mut body = [0u8; 128];
        let n = postcard::to_slice(&uplink(), &mut body).unwrap().len();
        let mut p = std::vec![PROTOCOL_VERSION, b'M'];
        p.extend_from_slice(&body[..n]);
        p.push(7);
        assert_eq!(decode_uplink(&raw(&p)), Err(WireError::Malformed));

        // Oversize: reported once, at the zero, then the next frame decodes.
        let mut d = FrameDecoder::new();
        let mut stream = std::vec![0x55u8; 1000];
        stream.push(0);
        stream.extend_from_slice(&frame);
        let got = feed_all(&mut d, &stream);
        assert_eq!(got.len(), 2);
        assert_eq!(got[0], Err(WireError::Oversize));
        assert!(got[1].is_ok());
    }

    #[test]
    fn counters_map_every_error_to_one_counter() {
        use WireError::*;
        let all = [
            BufferTooSmall,
            TooLarge,
            Cobs,
            Oversize,
            TooShort,
            Crc,
            VersionMismatch,
            WrongKind,
            Malformed,
        ];
        let mut c = LinkCounters::default();
        for e in all {
            c.count(e);
        }
        assert_eq!(
            (c.corrupt, c.oversize, c.malformed, c.wrong_version),
            (3, 1, 1, 2)
        );
        assert_eq!((c.tx_errors, c.rejected_frames()), (2, 7));
        assert!(c.count_sequence(SequenceCheck::New { dropped: 3 }));
        assert!(!c.count_sequence(SequenceCheck::Rejected(MeasurementError::Repeated)));
        assert!(!c.count_sequence(SequenceCheck::Rejected(MeasurementError::OutOfOrder)));
        assert_eq!(
            (c.frames_ok, c.seq_gap, c.seq_repeat, c.seq_old),
            (1, 3, 1, 1)
        );
    }

    #[test]
    fn empty_frames_are_idle_fill() {
        let mut d = FrameDecoder::new();
        assert!(feed_all(&mut d, &[0, 0, 0]).is_empty());
        assert!(d.is_idle());
    }

    fn any_f32() -> impl Strategy<Value = f32> {
        any::<u32>().prop_map(f32::from_bits)
    }

    prop_compose! {
        fn any_uplink()(seq in any::<u32>(), cam_seq in any::<u32>(), tracked in any::<bool>(),
                        img in [any_f32(), any_f32(), any_f32()],
                        nav in proptest::array::uniform12(any_f32()),
                        condition in [any_f32(), any_f32()],
                        contact in any::<bool>(), ready in any::<bool>(),
                        req in 0u8..4) -> Uplink {
            Uplink {
                seq,
                input: ControllerInput {
                    measurement: CameraMeasurement {
                        seq: cam_seq, tracked, image_x: img[0], image_y: img[1], depth_m: img[2],
                        probe_tip: None,
                    },
                    nav: NavSample {
                        condition: FlightCondition {
                            true_airspeed_mps: condition[0],
                            altitude_m: condition[1],
                        },
                        ..NavSample::from_array(nav)
                    },
                    probe_contact: contact,
                    autopilot_ready: ready,
                    request: [ModeRequest::None, ModeRequest::Engage, ModeRequest::Abort,
                              ModeRequest::Reset][usize::from(req)],
                },
            }
        }
    }

    /// The bytes of a message (NaN-safe equality).
    fn bytes_of<T: Serialize>(m: &T) -> Vec<u8> {
        postcard::to_slice(m, &mut [0u8; 512]).unwrap().to_vec()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(512))]

        /// Any byte sequence: no panic, at most one result per zero, idle after a zero.
        #[test]
        fn decoder_takes_any_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..2000)) {
            let mut d = FrameDecoder::new();
            let zeros = bytes.iter().filter(|&&b| b == 0).count();
            let results = feed_all(&mut d, &bytes);
            prop_assert!(results.len() <= zeros);
            if bytes.last() == Some(&0) {
                prop_assert!(d.is_idle());
            }
        }

        /// In slices of any sizes, the same frames as byte by byte: garbage, long runs, good
        /// frames and idle zeros mixed.
        #[test]
        fn slices_decode_as_bytes_do(
            parts in proptest::collection::vec(
                prop_oneof![
                    proptest::collection::vec(any::<u8>(), 0..300),
                    any_uplink().prop_map(|m| {
                        encode_uplink(&m, &mut [0u8; MAX_FRAME_LEN]).unwrap().to_vec()
                    }),
                    Just(std::vec![0x42u8; MAX_FRAME_LEN + 5]),
                ],
                0..6,
            ),
            cuts in proptest::collection::vec(1usize..80, 1..40),
        ) {
            let bytes: Vec<u8> = parts.concat();
            let by_byte = feed_all(&mut FrameDecoder::new(), &bytes);
            let mut d = FrameDecoder::new();
            let mut by_slice = Vec::new();
            let (mut at, mut k) = (0, 0);
            while at < bytes.len() {
                let end = (at + cuts[k % cuts.len()]).min(bytes.len());
                k += 1;
                while at < end {
                    let (n, r) = d.feed_slice(&bytes[at..end]);
                    prop_assert!(n > 0 && at + n <= end);
                    at += n;
                    if let Some(r) = r {
                        by_slice.push(r.map(|p| (p.kind, p.body.to_vec())));
                    }
                }
            }
            prop_assert_eq!(by_slice, by_byte);
        }

        /// Byte by byte, the frames a reference decoder finds: split at the zeros, empty
        /// frames skipped, a frame over the limits rejected as oversize, COBS undone by the
        /// `cobs` crate, then the payload's checks.
        #[test]
        fn the_decoder_agrees_with_a_reference_cobs_decoder(
            parts in proptest::collection::vec(
                prop_oneof![
                    proptest::collection::vec(any::<u8>(), 0..300),
                    proptest::collection::vec(prop_oneof![Just(0u8), Just(1), Just(0xFF)], 0..700),
                    any_uplink().prop_map(|m| {
                        encode_uplink(&m, &mut [0u8; MAX_FRAME_LEN]).unwrap().to_vec()
                    }),
                    // Checked frames with long runs of non-zero bytes (full 254-byte COBS
                    // blocks), some over the limits, encoded by the reference.
                    proptest::collection::vec(prop_oneof![200 => 1u8..=255, 1 => Just(0u8)], 0..700)
                        .prop_map(|body| {
                            let mut payload = std::vec![PROTOCOL_VERSION, FrameKind::ConfigWrite.byte()];
                            payload.extend(&body);
                            let crc = crc32c(&payload);
                            payload.extend(crc.to_le_bytes());
                            let mut frame = cobs::encode_vec(&payload);
                            frame.push(0);
                            frame
                        }),
                    Just(std::vec![0x42u8; MAX_FRAME_LEN + 5]),
                ],
                0..6,
            ),
        ) {
            let bytes: Vec<u8> = parts.concat();
            let mut segments: Vec<&[u8]> = bytes.split(|&b| b == 0).collect();
            segments.pop(); // after the last zero: no frame yet
            let reference: Vec<_> = segments
                .into_iter()
                .filter(|s| !s.is_empty())
                .map(|s| {
                    let mut out = std::vec![0u8; s.len()];
                    match cobs::decode(s, &mut out) {
                        _ if s.len() > MAX_ENCODED_LEN => Err(WireError::Oversize),
                        // Oversize first when the bytes decoded before the error outgrow
                        // the buffer (possible only for encodings over MAX_PAYLOAD_LEN + 1).
                        _ if decoded_before_error(s) > MAX_PAYLOAD_LEN => Err(WireError::Oversize),
                        Ok(n) => check_payload(&out[..n]).map(|p| (p.kind, p.body.to_vec())),
                        Err(_) => Err(WireError::Cobs),
                    }
                })
                .collect();
            prop_assert_eq!(feed_all(&mut FrameDecoder::new(), &bytes), reference);
        }

        /// Any garbage, then a zero, then a frame: the frame decodes.
        #[test]
        fn decoder_resynchronises_after_garbage(
            garbage in proptest::collection::vec(any::<u8>(), 0..600),
            m in any_uplink(),
        ) {
            let mut buf = [0u8; MAX_FRAME_LEN];
            let frame = encode_uplink(&m, &mut buf).unwrap();
            let mut d = FrameDecoder::new();
            let mut stream = garbage.clone();
            stream.push(0);
            stream.extend_from_slice(frame);
            let results = feed_all(&mut d, &stream);
            let (kind, body) = results.last().unwrap().clone().unwrap();
            let back = Payload { kind, body: &body }.uplink().unwrap();
            prop_assert_eq!(bytes_of(&back), bytes_of(&m));
        }

        /// Every uplink round-trips bit for bit and fits.
        #[test]
        fn uplinks_round_trip(m in any_uplink()) {
            let mut buf = [0u8; MAX_FRAME_LEN];
            let frame = encode_uplink(&m, &mut buf).unwrap();
            prop_assert!(frame.len() <= 91);
            prop_assert_eq!(bytes_of(&decode_uplink(frame).unwrap()), bytes_of(&m));
        }

        /// One byte changed anywhere (not into a zero, which would cut the frame) is caught.
        #[test]
        fn a_changed_byte_is_rejected(m in any_uplink(), at in any::<usize>(), mask in 1u8..=255) {
            let mut buf = [0u8; MAX_FRAME_LEN];
            let mut frame = encode_uplink(&m, &mut buf).unwrap().to_vec();
            let i = at % (frame.len() - 1);
            prop_assume!(frame[i] ^ mask != 0);
            frame[i] ^= mask;
            let r = decode_uplink(&frame);
            prop_assert!(r.is_err(), "accepted a corrupted frame: {:?}", r);
        }

        /// In place or through a copy, the same COBS: every payload of one block (any bytes,
        /// half of them zeros, so words of every zero pattern; up to 254) encodes as the
        /// general encoder does.
        #[test]
        fn cobs_in_place_is_cobs(
            payload in proptest::collection::vec(prop_oneof![Just(0u8), any::<u8>()], 0..=254)
        ) {
            let n = payload.len();
            let mut general = [0u8; 300];
            let m = cobs_encode(&payload, &mut general).unwrap();
            let mut frame = std::vec![0xAAu8; n + 3];
            frame[1..=n].copy_from_slice(&payload);
            cobs_in_place(&mut frame, n).unwrap();
            prop_assert_eq!(&frame[..=n], &general[..m]);
            prop_assert_eq!(frame[n + 1], 0, "the terminating zero");
            prop_assert_eq!(frame[n + 2], 0xAA, "nothing written past it");
        }
    }
}
