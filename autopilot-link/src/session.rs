//! The flight computer's session with its autopilot: what one control step takes from the
//! link and gives to it, the same for the firmware's application and for the simulator's
//! in-process flight computer (so that a processor-in-the-loop run over MAVLink can be
//! compared with an in-process one bit for bit).
//!
//! Data flow, per control step:
//!
//! ```text
//! autopilot bytes ─► push (Decoder, stamped with the link clock)
//! uplink input ────► input: nav = the autopilot's sample, autopilot_ready = its mode ─► step
//! step's command ──► send: HEARTBEAT when due, SET_ATTITUDE_TARGET ─► autopilot bytes
//! ```
//!
//! - **The clock** is the caller's, in milliseconds: one control period per step (the
//!   firmware counts its periods; in lockstep, one per new measurement frame). Messages are
//!   stamped with it as they arrive, ages are measured with it.
//! - **The input.** The measurement, the probe contact and the operator's request are the
//!   uplink's; the navigation sample is built from the autopilot's latest messages
//!   ([`crate::Decoder::nav_sample`]); when it cannot be (missing, stale, outside the
//!   schedule, not finite: counted) the navigation is fed as invalid (NaN), so the core
//!   freezes its integrators and holds, then breaks away open loop, as with a stale link.
//!   `autopilot_ready` is whether the autopilot's latest heartbeat, no older than
//!   [`SessionConfig::heartbeat_max_age_ms`], reports a mode that flies setpoints
//!   (ArduPlane GUIDED, PX4 OFFBOARD), **and** whether its pitch and roll attitude time
//!   constants, read from its parameters, are those the attitude loop was designed on
//!   ([`SessionConfig::design`]) within [`TIME_CONSTANT_TOLERANCE`]: the loop's poles are
//!   placed on them, and flown against other values it strikes the basket or upsets the
//!   aircraft (measured: `docs/conventions.md`, "Attitude-command inner loop"). A step not
//!   ready for want of them is counted (unknown, or mismatched). The uplink's own
//!   navigation sample and `autopilot_ready` are not used.
//! - **The lockstep barrier.** A simulated autopilot sends its messages for a step ending
//!   with `ATTITUDE` ([`crate::peer`]); [`Session::attitude_arrived`] says whether one has
//!   arrived since the last input, so a lockstep schedule can wait for it (real autopilots
//!   stream `ATTITUDE` at their own rate, and a free-running schedule does not wait).
//! - **The output.** Our `HEARTBEAT` when due (1 Hz on the link clock), with it a
//!   `PARAM_REQUEST_READ` for each attitude time constant not yet read once the autopilot's
//!   heartbeat has said what it is (ArduPlane `PTCH2SRV_TCONST` / `RLL2SRV_TCONST`, PX4
//!   `FW_P_TC` / `FW_R_TC`), and the step's
//!   attitude setpoint as `SET_ATTITUDE_TARGET`, stamped `time_boot_ms` = the link clock. A
//!   surface command (the surface loops do not fly through an autopilot) sends no setpoint;
//!   a setpoint the encoder refuses is counted, not sent.
//!
//! Invariants: nothing here panics or allocates; every byte written is a whole frame; every
//! refusal is counted in [`Session::counters`].

use ibvs_core::ControllerInput;
use ibvs_core::attitude::{AttitudeLoopConfig, Command};
use ibvs_core::nav::NavSample;

use crate::{
    Counters, Decoder, Encoder, HEARTBEAT_DATA_LEN, LinkIds, MAX_SENT_FRAME_LEN, NavConfig,
    PARAM_REQUEST_FRAME_LEN, Received, TimeConstantCheck,
};

/// Longest burst [`Session::send`] writes for one step, bytes: a heartbeat, two parameter
/// requests and a setpoint.
pub const MAX_BURST_LEN: usize =
    HEARTBEAT_DATA_LEN + 12 + 2 * PARAM_REQUEST_FRAME_LEN + MAX_SENT_FRAME_LEN;

/// How far the autopilot's attitude time constants may be from the design's, relative:
/// 10 %, half the smallest difference measured to do harm (the autopilot 20 % faster than
/// the design: nine upsets in 500 sorties of `autopilot-level2`; 20 % slower: none; 50 % and
/// 100 % slower: 2 and 10 basket strikes).
pub const TIME_CONSTANT_TOLERANCE: f32 = 0.1;

/// The session's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SessionConfig {
    /// System and component ids.
    pub ids: LinkIds,
    /// The navigation sample's settings (the tanker's track and speed, message ages).
    pub nav: NavConfig,
    /// Oldest autopilot heartbeat whose mode is believed, ms. 2,500 ms: both autopilots send
    /// theirs at 1 Hz, so two may be lost before the mode is no longer known.
    pub heartbeat_max_age_ms: u32,
    /// The attitude loop flown (its time constants are checked against the autopilot's).
    pub design: AttitudeLoopConfig,
}

impl Default for SessionConfig {
    fn default() -> Self {
        Self {
            ids: LinkIds::default(),
            nav: NavConfig::default(),
            heartbeat_max_age_ms: 2_500,
            design: AttitudeLoopConfig::default(),
        }
    }
}

/// The flight computer's side of the link, between two control steps.
#[derive(Debug, Clone)]
pub struct Session {
    cfg: SessionConfig,
    decoder: Decoder,
    encoder: Encoder,
    attitude_arrived: bool,
    setpoints_refused: u32,
    tx_dropped: u32,
    rx_errors: u32,
    time_constants_unknown: u32,
    time_constants_mismatch: u32,
}

impl Session {
    /// A session with nothing received yet.
    pub fn new(cfg: SessionConfig) -> Self {
        Self {
            cfg,
            decoder: Decoder::new(cfg.ids),
            encoder: Encoder::new(cfg.ids),
            attitude_arrived: false,
            setpoints_refused: 0,
            tx_dropped: 0,
            rx_errors: 0,
            time_constants_unknown: 0,
            time_constants_mismatch: 0,
        }
    }

    /// The attitude loop now flown (after a configuration change).
    pub fn set_design(&mut self, design: AttitudeLoopConfig) {
        self.cfg.design = design;
    }

    /// Takes one byte from the autopilot, arrived at `now_ms`.
    pub fn push(&mut self, byte: u8, now_ms: u32) {
        if let Some(Received::Attitude) = self.decoder.push(byte, now_ms) {
            self.attitude_arrived = true;
        }
    }

    /// Whether an `ATTITUDE` arrived since the last [`Session::input`] (the lockstep barrier).
    pub fn attitude_arrived(&self) -> bool {
        self.attitude_arrived
    }

    /// The step's input at `now_ms`: `uplink`'s with the autopilot's navigation and mode.
    pub fn input(&mut self, now_ms: u32, uplink: &ControllerInput) -> ControllerInput {
        self.attitude_arrived = false;
        let nav = match self.decoder.nav_sample(now_ms, &self.cfg.nav) {
            Ok(fix) => fix.sample,
            Err(_) => NavSample::from_array([f32::NAN; 12]),
        };
        let mode = self
            .decoder
            .autopilot(now_ms)
            .accepts_setpoints(self.cfg.heartbeat_max_age_ms);
        let time_constants = self
            .decoder
            .attitude_time_constants()
            .check(&self.cfg.design, TIME_CONSTANT_TOLERANCE);
        let c = match time_constants {
            TimeConstantCheck::Match => None,
            TimeConstantCheck::Unknown => Some(&mut self.time_constants_unknown),
            TimeConstantCheck::Mismatch => Some(&mut self.time_constants_mismatch),
        };
        if let Some(c) = c {
            *c = c.saturating_add(1);
        }
        let autopilot_ready = mode && time_constants == TimeConstantCheck::Match;
        ControllerInput {
            nav,
            autopilot_ready,
            ..*uplink
        }
    }

    /// The frames for the autopilot after a step whose command is `command`, at `now_ms`,
    /// into `buf`: the bytes written (a heartbeat when due, the setpoint).
    pub fn send(&mut self, now_ms: u32, command: &Command, buf: &mut [u8; MAX_BURST_LEN]) -> usize {
        let mut n = 0;
        if self.encoder.heartbeat_due(now_ms) {
            // The buffer holds a heartbeat, two requests and a setpoint: never refused.
            if let Some(rest) = buf.get_mut(n..) {
                n += self.encoder.heartbeat(rest).unwrap_or(0);
            }
            // The time constants not read yet, once the autopilot has said what it is.
            let have = self.decoder.attitude_time_constants();
            if let Some(kind) = self.decoder.autopilot_kind() {
                let [pitch, roll] = kind.time_constant_params();
                for (name, missing) in [
                    (pitch, have.pitch_s.is_none()),
                    (roll, have.roll_s.is_none()),
                ] {
                    if missing && let Some(rest) = buf.get_mut(n..) {
                        n += self.encoder.param_request_read(name, rest).unwrap_or(0);
                    }
                }
            }
        }
        if let Command::Attitude(sp) = command
            && let Some(rest) = buf.get_mut(n..)
        {
            match self
                .encoder
                .attitude_target(sp, self.cfg.nav.track_rad, now_ms, rest)
            {
                Ok(len) => n += len,
                Err(_) => self.setpoints_refused = self.setpoints_refused.saturating_add(1),
            }
        }
        n
    }

    /// Counts a burst the transmit queue could not take whole.
    pub fn count_tx_dropped(&mut self) {
        self.tx_dropped = self.tx_dropped.saturating_add(1);
    }

    /// Counts `n` bytes the serial port lost (its receiver errors).
    pub fn count_rx_errors(&mut self, n: u32) {
        self.rx_errors = self.rx_errors.saturating_add(n);
    }

    /// The link's counters: the decoder's, the setpoints refused, the bursts dropped and the
    /// serial port's receiver errors.
    pub fn counters(&self) -> Counters {
        Counters {
            setpoints_refused: self.setpoints_refused,
            tx_dropped: self.tx_dropped,
            rx_errors: self.rx_errors,
            time_constants_unknown: self.time_constants_unknown,
            time_constants_mismatch: self.time_constants_mismatch,
            ..*self.decoder.counters()
        }
    }

    /// The decoder (the autopilot's mode, kind and time constants).
    pub fn decoder(&self) -> &Decoder {
        &self.decoder
    }
}
