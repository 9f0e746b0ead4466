//! The flight-computer application, board-independent: serial link in, controller, serial
//! link out.
//!
//! Place in the data flow: bytes from the link go one at a time through the core's streaming
//! [`FrameDecoder`]; an accepted measurement frame ([`Uplink`]) feeds [`Controller::step`];
//! the step's output, the counters and the step's cost go back as a command frame
//! ([`Downlink`]). The board (`crate::board`, bare metal only) supplies the receive side of
//! the link (embedded-io [`Read`] + [`ReadReady`]), a transmit queue that takes a whole frame
//! without waiting ([`Board::transmit`]), a cost counter ([`CostCounter`]), the
//! control-period ticks, the watchdog and the idle wait, through the [`Board`] trait; this
//! module never touches hardware and is unit-tested on the host.
//!
//! Two schedules ([`Schedule`]):
//! - **Lockstep** (simulation, processor-in-the-loop): every new measurement frame runs one
//!   step and is answered by one command frame at once. A repeated frame (same link sequence
//!   number: the peer retransmits after losing the answer) is answered by the previous
//!   command frame again, marked [`LinkStatus::RETRANSMIT`], without a step. There is no
//!   timeout on this side: time is the peer's (its lockstep timeout).
//! - **Free-running** (flight): the control task runs once per control period (ticks from
//!   the board's timer) on the latest accepted measurement frame and sends one command frame
//!   per step. A period without a new frame reuses the last input with its request cleared
//!   ([`LinkStatus::INPUT_HELD`]; the core sees its camera frame as repeated and holds, then
//!   breaks away after its hold limit). After [`LINK_TIMEOUT_PERIODS`] periods without a new
//!   frame the link is stale ([`LinkStatus::STALE`], [`LinkCounters::timeouts`]): the
//!   navigation is then fed as invalid (NaN), so the core freezes its integrators and a
//!   breakaway flies open loop (trim surfaces, throttle cut) instead of closing the loop on
//!   stale navigation. Periods that passed without their step are counted
//!   ([`LinkCounters::deadline_missed`]). Before the first measurement frame the commands are
//!   the standby trim and the controller is not stepped. When two frames arrive within one
//!   period the later one is used (the core counts the camera frame it skipped as dropped);
//!   an operator request (engage, abort, reset) of the skipped frame is carried over unless
//!   the later frame has its own, so no request is lost.
//!
//! Configuration frames (both schedules): a configuration write is applied through
//! [`Controller::reconfigure`] (standby only, validated, atomic) between two steps, and every
//! write or read is answered at once with a configuration report ([`ConfigReport`]: what was
//! done, the configuration flown and its id); the id is in every command frame after it.
//!
//! Every rejected byte sequence is counted in [`LinkCounters`] (by the core's
//! [`LinkCounters::count`]) and so reported in the next telemetry frame; so is every frame the
//! transmit queue could not take whole ([`LinkCounters::tx_dropped`]: dropped, never sent in
//! part).
//!
//! # The control task's deadline
//!
//! The command frame of every step is handed to the transmit queue within
//! [`CONTROL_DEADLINE_S`] (1 ms) of the step's trigger: the period tick (free-running; the
//! board's timer interrupt stamps it with the cost counter, [`Periods::last_tick_at`]) or
//! the start of the decode of the measurement frame's last byte (lockstep). The window holds
//! the rest of the loop's pass before the step (bytes waiting in the receive queue), the
//! step, the gain schedule's follow-up, the encoding and the copy into the transmit queue;
//! the logging comes after it. Each step is measured against it in the board's cost counter
//! ([`CostCounter::DEADLINE`]: 168,000 cycles at 168 MHz on the `f405` board; 168,000
//! instructions under QEMU, where an instruction takes at least one cycle, so an overrun
//! counted there is one on the board too); an overrun is counted
//! ([`LinkCounters::deadline_overruns`], in the next frame) and logged, and the frame is still
//! sent. Whole periods without their step are the other counter,
//! [`LinkCounters::deadline_missed`]. By design only a configuration write (in standby: the
//! flash erase stalls the CPU for seconds) overruns.
//!
//! # After a reset
//!
//! The application starts in standby with the trim commands whatever the reset, and every
//! frame says why the board reset and which clock it runs on ([`BootReport`]). After an
//! abnormal reset ([`BootReport::needs_acknowledgement`]: a watchdog, a brown-out, a fault
//! record; or a boot on the internal oscillator, whose link timing the acknowledgement
//! verifies) it passes no `Engage` request to the controller (each one counted,
//! [`LinkCounters::engage_inhibited`], the first logged) until the peer sends a `Reset`
//! request, which acknowledges the reset (logged): it is never re-engaged automatically.
//!
//! Invariants: nothing here panics or allocates for any byte sequence (tested on the host
//! with a pseudo-random byte stream; the decoder underneath is property-tested in the core;
//! the no-panic link check covers [`App::run`]); every command sent is the core's (finite,
//! inside the actuator limits) or the trim.

use autopilot_link::session::{MAX_BURST_LEN, Session, SessionConfig};
use embedded_io::{Read, ReadReady};
use ibvs_core::Counters;
use ibvs_core::actuator::ActuatorCommand;
use ibvs_core::attitude::Command;
use ibvs_core::config::trim_command;
use ibvs_core::gains::CONTROL_PERIOD_S;
use ibvs_core::measurement::SequenceTracker;
use ibvs_core::nav::NavSample;
use ibvs_core::wire::{
    AutopilotLinkCounters, ClockSource, ConfigReport, ConfigStatus, ConfigStorage, Cost, CostUnit,
    Downlink, FrameDecoder, FrameKind, LinkCounters, LinkStatus, MAX_FRAME_LEN, ResetCause,
    TELEMETRY_MAX_PERIODS, TELEMETRY_MIN_PERIODS, Telemetry, Uplink, WireError, config_from_bytes,
    config_id, encode_config_report, encode_downlink, encode_telemetry,
};
use ibvs_core::{
    BreakawayReason, ConfigError, Controller, ControllerConfig, ControllerInput, ControllerOutput,
    Mode, ModeRequest,
};

pub use crate::boot::BootReport;
pub use crate::serial::QueueFull;

/// How control steps are triggered (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Schedule {
    /// One step and one command frame per new measurement frame.
    Lockstep,
    /// One step and one command frame per control period, on the latest measurement.
    FreeRunning,
}

/// Free-running link timeout, control periods: after this many periods without a new
/// measurement frame (5 x 20 ms = 100 ms) the link is stale and the navigation is treated as
/// invalid. Shorter than the core's hold limit (25 periods), so the core's own
/// hold-then-breakaway logic still decides when to break away (`MeasurementLost`).
pub const LINK_TIMEOUT_PERIODS: u32 = 5;

/// The control task's deadline, seconds: from a step's trigger to its command frame handed
/// to the transmit queue (module doc, "The control task's deadline"). 5 % of the 20 ms
/// period, so the frame (up to 354 bytes, 3.8 ms at 921,600 baud) is on the wire by a
/// quarter of the period. The window's parts, each at its maximum measured under QEMU
/// (a measurement frame's decode 4,330 instructions, the step 2,595, the schedule's
/// follow-up 6,881, the encoding 6,728), add up to about 21,000 instructions, an eighth of
/// it; the whole pass is not measured as one figure, only checked against the deadline.
pub const CONTROL_DEADLINE_S: f32 = 1e-3;

/// Control periods the board's timer counted, and when the latest one began.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Periods {
    /// Periods elapsed since the last call (0: none due).
    pub count: u32,
    /// The cost counter ([`CostCounter::now`]) at the latest period's tick.
    pub last_tick_at: u32,
}

/// A free-running counter read to measure costs (instructions under QEMU, cycles on
/// hardware); wraps.
pub trait CostCounter {
    /// What one count is.
    const UNIT: CostUnit;
    /// [`CONTROL_DEADLINE_S`] in counts.
    const DEADLINE: u32;
    /// The counter now.
    fn now() -> u32;
    /// Runs `f`; returns its result and, on boards that measure it, the stack `f` used below
    /// the caller's stack pointer, bytes (the `qemu` board paints and scans; the default
    /// measures nothing).
    #[inline(always)]
    fn stack_of<R>(f: impl FnOnce() -> R) -> (R, Option<u32>) {
        (f(), None)
    }
    /// Runs `f` with interrupts masked on the boards (the default just runs it), so that a
    /// short timed window counts only its own work: an interrupt landing inside it (a
    /// received byte, under QEMU at a host-timing-dependent instruction) would otherwise be
    /// counted too, and the figure would differ run to run. On an MCU only for windows far
    /// shorter than a byte time at the link's speed (10.8 us at 921,600 baud), or bytes are
    /// lost; QEMU's serial model holds a byte back while the one before waits unread.
    #[inline(always)]
    fn uninterrupted<R>(f: impl FnOnce() -> R) -> R {
        f()
    }
}

/// No counter (host builds): every cost reads 0.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoCounter;

impl CostCounter for NoCounter {
    const UNIT: CostUnit = CostUnit::Unavailable;
    /// Nothing is measured (every reading is 0), so nothing overruns.
    const DEADLINE: u32 = u32::MAX;
    fn now() -> u32 {
        0
    }
}

/// Something worth a log line (the board decides how: semihosting under QEMU, defmt on the
/// board).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Event {
    /// The controller changed mode in the last step.
    ModeChanged {
        /// The new mode.
        mode: Mode,
        /// Why, for a breakaway.
        reason: Option<BreakawayReason>,
        /// Controller step number.
        step: u32,
    },
    /// Free-running: the link went stale (no new frame for [`LINK_TIMEOUT_PERIODS`]).
    LinkStale,
    /// Free-running: a new frame arrived after the link was stale.
    LinkRecovered,
    /// A configuration write was applied: the controller flies the configuration with this
    /// [`config_id`] from the next step.
    Configured {
        /// Its id.
        id: u32,
    },
    /// A control step used more stack than any before it (boards that measure it).
    ControlStack {
        /// Bytes below the caller's stack pointer, the step's frames and anything they call.
        bytes: u32,
        /// Controller step number.
        step: u32,
    },
    /// A step's command frame reached the transmit queue after the deadline
    /// ([`CONTROL_DEADLINE_S`]).
    DeadlineOverrun {
        /// From the trigger to the frame queued, in the cost counter's unit.
        elapsed: u32,
        /// The deadline in the same unit ([`CostCounter::DEADLINE`]).
        deadline: u32,
        /// Controller step number.
        step: u32,
    },
    /// The first `Engage` request after an abnormal reset was not passed on: the peer must
    /// acknowledge the reset with a `Reset` request first (later ones are only counted).
    EngageInhibited {
        /// Why the board reset.
        cause: ResetCause,
    },
    /// The peer acknowledged the abnormal reset (a `Reset` request): `Engage` is passed on
    /// again.
    ResetAcknowledged,
}

/// What the application needs from a board.
pub trait Board {
    /// The receive side of the serial link to the peer.
    type Link: Read + ReadReady;
    /// The receive side of the serial link to the autopilot (MAVLink 2).
    type Autopilot: Read + ReadReady;
    /// The cost counter.
    type Counter: CostCounter;
    /// The link's receive side.
    fn link(&mut self) -> &mut Self::Link;
    /// Hands a whole frame to the link's transmit queue and returns at once (the board sends
    /// it in the background); [`QueueFull`] when the queue cannot take all of it, and then
    /// none of it is sent.
    fn transmit(&mut self, frame: &[u8]) -> Result<(), QueueFull>;
    /// The autopilot link's receive side.
    fn autopilot(&mut self) -> &mut Self::Autopilot;
    /// Hands whole MAVLink frames to the autopilot link's transmit queue, as
    /// [`Board::transmit`] does for the peer's.
    fn transmit_autopilot(&mut self, frames: &[u8]) -> Result<(), QueueFull>;
    /// Receiver errors on the autopilot link since the last call.
    fn take_autopilot_rx_errors(&mut self) -> u32;
    /// Writes an applied configuration to the board's configuration store, for the next
    /// boot (`crate::store`); a board without one answers [`ConfigStorage::Unavailable`].
    fn persist(&mut self, cfg: &ControllerConfig) -> ConfigStorage;
    /// Control periods elapsed since the last call, and when the latest began. A board with
    /// a watchdog runs the tick in both schedules, so that its loop wakes (and feeds the
    /// watchdog) at least once a period; lockstep takes and ignores the periods.
    fn take_periods(&mut self) -> Periods;
    /// Receiver errors (hardware overrun, noise, framing; buffer overflow) since the last
    /// call.
    fn take_rx_errors(&mut self) -> u32;
    /// The main loop completed a pass (every byte received so far handled, a due period
    /// stepped): the board feeds its watchdog here, and only here.
    fn pass_completed(&mut self);
    /// Sleeps until something may be pending (an interrupt), or returns at once.
    fn wait_for_event(&mut self);
    /// Logs an event.
    fn log(&mut self, event: Event);
}

/// Bytes [`App::poll`] takes from the receive queue at a time and hands to
/// [`App::on_bytes`]: the boards' whole receive queue (`board::usart1::RX_QUEUE_LEN`), which
/// they let the loop read once a frame's end is in it (or it is half full), so a frame is
/// decoded whole in one call. The most the decoder walks in one call: the control task's
/// static bound counts its loop by it.
pub const RX_CHUNK_LEN: usize = 512;

/// Bytes [`App::poll`] takes from the autopilot link's receive queue at a time.
pub const AUTOPILOT_CHUNK_LEN: usize = 256;

/// Feeds `bytes` to the decoder up to the end of the first frame among them: how many it
/// took, and what that frame asks for (a configuration write's body deserialised into
/// `config_in`) or why it was rejected. The application's decode ([`App::on_bytes`]; the path
/// benchmark times the same function).
#[inline(always)]
pub(crate) fn receive(
    decoder: &mut FrameDecoder,
    config_in: &mut ControllerConfig,
    bytes: &[u8],
) -> (usize, Option<Result<Received, WireError>>) {
    let (taken, r) = decoder.feed_slice(bytes);
    let r = r.map(|r| {
        r.and_then(|p| match p.kind {
            FrameKind::Measurement => p.uplink().map(Received::Measurement),
            FrameKind::ConfigWrite => Ok(Received::ConfigWrite(
                config_from_bytes(p.body).map(|c| *config_in = c),
            )),
            FrameKind::ConfigRead => p.empty().map(|()| Received::ConfigRead),
            FrameKind::TelemetryRequest => p.empty().map(|()| Received::TelemetryRequest),
            FrameKind::Command | FrameKind::ConfigReport | FrameKind::Telemetry => {
                Err(WireError::WrongKind)
            }
        })
    });
    (taken, r)
}

/// One controller step, with its cost in `C`'s unit (the call and the step) and the stack it
/// used, bytes, where the board measures it. Out of line, once in the binary.
#[inline(never)]
fn control_step<C: CostCounter>(
    controller: &mut Controller,
    input: &ControllerInput,
) -> (ControllerOutput, u32, Option<u32>) {
    let ((out, cost), stack) = C::stack_of(|| {
        let t0 = C::now();
        let out = step_out_of_line(controller, input);
        (out, C::now().wrapping_sub(t0))
    });
    (out, cost, stack)
}

/// [`Controller::step`], never inlined into its caller: its frames lie below the caller's
/// stack pointer, where [`CostCounter::stack_of`] finds them.
#[inline(never)]
fn step_out_of_line(controller: &mut Controller, input: &ControllerInput) -> ControllerOutput {
    controller.step(input)
}

/// The standby output: trim commands, nothing else (boot, panic, no link yet).
pub fn trim_output() -> ControllerOutput {
    ControllerOutput {
        command: Command::Surfaces(ActuatorCommand::from_array(trim_command())),
        ..ControllerOutput::default()
    }
}

/// Bytes of the safe-state frame the fault path sends (trim commands, `LinkStatus::PANIC`),
/// written into `buf`: a `0x00` first, then the command frame. The fault can come in the
/// middle of a frame the link was sending; the leading zero ends that frame on the
/// receiver's side (it fails its check and is counted), so the safe frame decodes whole. A
/// zero with nothing before it is idle fill, not an error. `None` if it did not encode.
pub fn safe_frame(buf: &mut [u8; MAX_FRAME_LEN + 1]) -> Option<&[u8]> {
    let d = Downlink {
        seq: u32::MAX,
        link_status: LinkStatus(LinkStatus::PANIC),
        output: trim_output(),
        ..Downlink::default()
    };
    let (zero, rest) = buf.split_first_mut()?;
    *zero = 0;
    let n = encode_downlink(&d, rest).ok()?.len();
    buf.get(..=n)
}

/// The application state: the controller and both ends of the link protocol.
#[derive(Debug, Clone)]
pub struct App {
    controller: Controller,
    schedule: Schedule,
    decoder: FrameDecoder,
    link: LinkCounters,
    rx_seq: SequenceTracker,
    /// The latest accepted measurement frame.
    latest: Option<Uplink>,
    /// Free-running: `latest` arrived after the previous step.
    fresh: bool,
    /// Free-running: periods since the latest new frame.
    periods_since_fresh: u32,
    stale: bool,
    /// Decode cost of the frame being received, and of `latest`.
    decode_acc: u32,
    decode_latest: u32,
    encode_prev: u32,
    tx_seq: u32,
    /// The last command frame sent (retransmitted on a repeated measurement frame).
    last: Downlink,
    /// Status bits set in every frame (schedule, previous panic).
    base_status: u8,
    /// Status bits of the boot frame only (the configuration's origin).
    boot_status: u8,
    /// What the board found at reset (in every telemetry frame).
    reset_cause: ResetCause,
    clock: ClockSource,
    /// After an abnormal reset: `Engage` requests are held back until a `Reset` request.
    awaiting_acknowledgement: bool,
    /// The first held-back `Engage` was logged.
    inhibit_logged: bool,
    /// When the trigger of the step whose frame is being sent happened (cost counter).
    trigger_at: Option<u32>,
    /// Largest stack a control step used (boards that measure it), bytes.
    control_stack_max: u32,
    /// Events to log after the one [`App::on_bytes`] or [`App::on_periods`] returned (a new
    /// control-stack maximum; a held-back `Engage` or its acknowledgement): at most two come
    /// from one step.
    pending: [Option<Event>; 2],
    /// [`config_id`] of the controller's configuration.
    config_id: u32,
    /// An applied configuration the board is still to store (then the report is sent).
    to_persist: Option<ControllerConfig>,
    /// A configuration write's body, deserialised straight here (a message enum carrying it
    /// would be copied whole for every measurement frame).
    config_in: ControllerConfig,
    /// The counters the latest telemetry frame carried (free-running: a change is sent).
    telemetry_sent: (Counters, LinkCounters, AutopilotLinkCounters),
    /// Free-running: control periods since the latest telemetry frame.
    periods_since_telemetry: u32,
    buf: [u8; MAX_FRAME_LEN],
    /// The MAVLink session with the autopilot (flown with the attitude-command loop).
    autopilot: Session,
    /// The autopilot link's clock, ms: one control period per step (module doc, "Through the
    /// autopilot").
    autopilot_ms: u32,
    /// The step's frames for the autopilot, and their length (0: none to send).
    autopilot_burst: [u8; MAX_BURST_LEN],
    autopilot_len: usize,
    /// Lockstep through the autopilot: a new measurement frame waiting for the autopilot's
    /// `ATTITUDE` of its step, with its decode cost and arrival.
    waiting: Option<(Uplink, u32, u32)>,
    /// Cost of the autopilot's bytes decoded since the last step and of the step's
    /// navigation sample (in the step's `Cost::decode`), and of the step's MAVLink frames'
    /// encoding (in the next frame's `Cost::encode_prev`).
    autopilot_decode: u32,
    autopilot_encode: u32,
}

/// One control period, ms (the autopilot link's clock step).
const PERIOD_MS: u32 = (CONTROL_PERIOD_S * 1000.0 + 0.5) as u32;

/// What a received frame asks for (a configuration write's body is in `App::config_in`).
pub(crate) enum Received {
    /// A measurement frame.
    Measurement(Uplink),
    /// A configuration write: whether its body deserialised.
    ConfigWrite(Result<(), WireError>),
    /// A configuration read.
    ConfigRead,
    /// A telemetry request.
    TelemetryRequest,
}

impl App {
    /// The application in standby, before the boot frame, after the reset the board
    /// describes (`boot`: its cause and the clock go in every telemetry frame, a fault record sets
    /// [`LinkStatus::PREVIOUS_PANIC`]), flying `stored` (the board's stored configuration,
    /// if it has a valid one) or else the built-in default; the boot frame says which
    /// ([`LinkStatus::STORED_CONFIG`]).
    pub fn new(
        schedule: Schedule,
        boot: BootReport,
        stored: Option<ControllerConfig>,
    ) -> Result<Self, ConfigError> {
        let mut base_status = 0;
        if schedule == Schedule::FreeRunning {
            base_status |= LinkStatus::FREE_RUNNING;
        }
        if boot.previous_fault {
            base_status |= LinkStatus::PREVIOUS_PANIC;
        }
        // A stored configuration was validated when it was loaded; one that fails here all
        // the same is not flown, and the default is (said in the boot frame).
        let from_store = stored.and_then(|c| Controller::new(c).ok().map(|k| (c, k)));
        let boot_status = if from_store.is_some() {
            LinkStatus::STORED_CONFIG
        } else {
            0
        };
        let (cfg, controller) = match from_store {
            Some(pair) => pair,
            None => {
                let cfg = ControllerConfig::default();
                (cfg, Controller::new(cfg)?)
            }
        };
        Ok(Self {
            controller,
            config_id: config_id(&cfg),
            to_persist: None,
            config_in: cfg,
            telemetry_sent: Default::default(),
            periods_since_telemetry: 0,
            boot_status,
            reset_cause: boot.reset_cause,
            clock: boot.clock,
            awaiting_acknowledgement: boot.needs_acknowledgement(),
            inhibit_logged: false,
            trigger_at: None,
            schedule,
            decoder: FrameDecoder::new(),
            link: LinkCounters::default(),
            rx_seq: SequenceTracker::default(),
            latest: None,
            fresh: false,
            periods_since_fresh: 0,
            stale: false,
            decode_acc: 0,
            decode_latest: 0,
            encode_prev: 0,
            tx_seq: 0,
            last: Downlink::default(),
            base_status,
            control_stack_max: 0,
            pending: [None; 2],
            buf: [0; MAX_FRAME_LEN],
            autopilot: Session::new(SessionConfig {
                design: cfg.attitude,
                ..SessionConfig::default()
            }),
            autopilot_ms: 0,
            autopilot_burst: [0; MAX_BURST_LEN],
            autopilot_len: 0,
            waiting: None,
            autopilot_decode: 0,
            autopilot_encode: 0,
        })
    }

    /// The schedule.
    pub fn schedule(&self) -> Schedule {
        self.schedule
    }

    /// The link counters so far.
    pub fn link_counters(&self) -> &LinkCounters {
        &self.link
    }

    /// The boot frame: standby trim, [`LinkStatus::BOOT`], sequence 0. Send it once the link
    /// is up; it tells the peer the firmware is listening.
    pub fn boot_frame<C: CostCounter>(&mut self) -> Option<&[u8]> {
        let d = self.frame::<C>(
            None,
            LinkStatus::BOOT | LinkStatus::STALE | self.boot_status,
            trim_output(),
            Cost::default(),
        );
        self.encode::<C>(d)
    }

    fn frame<C: CostCounter>(
        &self,
        echo_seq: Option<u32>,
        status: u8,
        output: ControllerOutput,
        cost: Cost,
    ) -> Downlink {
        Downlink {
            seq: self.tx_seq,
            echo_seq,
            link_status: LinkStatus(self.base_status | status),
            output,
            cost: Cost {
                unit: C::UNIT,
                encode_prev: self.encode_prev,
                ..cost
            },
            config_id: self.config_id,
        }
    }

    /// The telemetry frame now: the counters, the configuration's id, the boot's findings;
    /// its length in the frame buffer (`None`: it did not encode, counted). Remembered as
    /// the latest sent.
    pub fn telemetry_frame(&mut self) -> Option<usize> {
        let counters = *self.controller.counters();
        let t = Telemetry {
            seq: self.tx_seq,
            counters,
            link: self.link,
            config_id: self.config_id,
            reset_cause: self.reset_cause,
            clock: self.clock,
            probe_tip_image: self.controller.probe_tip_image(),
            autopilot: self.autopilot.counters(),
        };
        self.telemetry_sent = (counters, self.link, t.autopilot);
        self.periods_since_telemetry = 0;
        match encode_telemetry(&t, &mut self.buf) {
            Ok(frame) => {
                let n = frame.len();
                self.tx_seq = self.tx_seq.wrapping_add(1);
                Some(n)
            }
            Err(e) => {
                self.link.count(e);
                None
            }
        }
    }

    /// Free-running, after a period's command frame: a telemetry frame is due when a counter
    /// changed since the latest one and [`TELEMETRY_MIN_PERIODS`] have passed, or after
    /// [`TELEMETRY_MAX_PERIODS`] whatever changed.
    fn telemetry_due(&self) -> bool {
        let p = self.periods_since_telemetry;
        p >= TELEMETRY_MAX_PERIODS
            || (p >= TELEMETRY_MIN_PERIODS
                && self.telemetry_sent
                    != (
                        *self.controller.counters(),
                        self.link,
                        self.autopilot.counters(),
                    ))
    }

    /// Encodes `d` into the frame buffer and remembers it; `None` (counted) if it failed.
    fn encode<C: CostCounter>(&mut self, d: Downlink) -> Option<&[u8]> {
        let t0 = C::now();
        let n = encode_downlink(&d, &mut self.buf).map(<[u8]>::len);
        // Through the autopilot, the step's MAVLink frames' encoding too.
        self.encode_prev = C::now()
            .wrapping_sub(t0)
            .saturating_add(core::mem::take(&mut self.autopilot_encode));
        match n {
            Ok(n) if n <= self.buf.len() => {
                self.last = d;
                self.tx_seq = self.tx_seq.wrapping_add(1);
                Some(&self.buf[..n])
            }
            // Never: the frame was written into this buffer. Counted, not sent.
            Ok(_) => {
                self.link.tx_errors = self.link.tx_errors.saturating_add(1);
                None
            }
            Err(e) => {
                self.link.count(e);
                None
            }
        }
    }

    /// Runs one controller step on `input` and builds its command frame.
    fn step<C: CostCounter>(
        &mut self,
        input: &ControllerInput,
        echo_seq: Option<u32>,
        status: u8,
        decode: u32,
    ) -> (Downlink, Option<Event>) {
        let before = self.controller.mode();
        let gated;
        let input = match self.gate_request(input.request) {
            Some(request) => {
                gated = ControllerInput { request, ..*input };
                &gated
            }
            None => input,
        };
        let (out, step, stack) = control_step::<C>(&mut self.controller, input);
        if self.through_autopilot() {
            // The setpoint first: it is this step's command.
            let t0 = C::now();
            self.autopilot_len =
                self.autopilot
                    .send(self.autopilot_ms, &out.command, &mut self.autopilot_burst);
            self.autopilot_encode = C::now().wrapping_sub(t0);
        }
        // The gain schedule's follow-up, outside the step's timed window (a new flight
        // condition is flown from the next step; `Controller::follow_schedule`).
        self.controller.follow_schedule();
        if let Some(bytes) = stack
            && bytes > self.control_stack_max
        {
            self.control_stack_max = bytes;
            self.defer(Event::ControlStack {
                bytes,
                step: out.step,
            });
        }
        let event = (out.mode != before).then_some(Event::ModeChanged {
            mode: out.mode,
            reason: out.breakaway_reason,
            step: out.step,
        });
        let cost = Cost {
            step,
            decode,
            ..Cost::default()
        };
        (self.frame::<C>(echo_seq, status, out, cost), event)
    }

    /// After an abnormal reset not yet acknowledged: the request to pass to the controller
    /// instead of `request` (`Engage` held back and counted; `Reset` acknowledges and is
    /// passed on); `None` to pass it unchanged.
    fn gate_request(&mut self, request: ModeRequest) -> Option<ModeRequest> {
        if !self.awaiting_acknowledgement {
            return None;
        }
        match request {
            ModeRequest::Engage => {
                self.link.engage_inhibited = self.link.engage_inhibited.saturating_add(1);
                if !self.inhibit_logged {
                    self.inhibit_logged = true;
                    self.defer(Event::EngageInhibited {
                        cause: self.reset_cause,
                    });
                }
                Some(ModeRequest::None)
            }
            ModeRequest::Reset => {
                self.awaiting_acknowledgement = false;
                self.defer(Event::ResetAcknowledged);
                None
            }
            ModeRequest::None | ModeRequest::Abort => None,
        }
    }

    /// Keeps an event to log after the current one (two slots: a step defers at most two;
    /// a third would replace the second).
    fn defer(&mut self, event: Event) {
        match &mut self.pending {
            [slot @ None, _] | [Some(_), slot] => *slot = Some(event),
        }
    }

    /// Feeds received bytes up to the end of the first frame among them: how many it took,
    /// and the length of a frame to send (in [`App::frame_bytes`]) when that frame is answered
    /// at once (lockstep's command frame, a configuration report, a telemetry frame).
    // Out of line: the static bound of the control task (target-bench) starts here.
    #[inline(never)]
    pub fn on_bytes<C: CostCounter>(
        &mut self,
        bytes: &[u8],
    ) -> (usize, Option<usize>, Option<Event>) {
        // The decode of these bytes (a frame's last ones: its whole deserialisation), timed
        // without interrupts where the board's counter needs that for a repeatable figure
        // (the qemu board, whose serial model holds bytes back meanwhile; the f405 board
        // decodes with interrupts on).
        let (decoder, config_in) = (&mut self.decoder, &mut self.config_in);
        let (taken, result, t0, spent) = C::uninterrupted(|| {
            let t0 = C::now();
            let (taken, r) = receive(decoder, config_in, bytes);
            (taken, r, t0, C::now().wrapping_sub(t0))
        });
        self.decode_acc = self.decode_acc.saturating_add(spent);
        let Some(result) = result else {
            return (taken, None, None);
        };
        let decode = core::mem::take(&mut self.decode_acc);
        let (len, event) = match result {
            Ok(Received::Measurement(up)) => self.accept::<C>(up, decode, t0),
            Ok(Received::ConfigWrite(body)) => self.configure(body),
            Ok(Received::ConfigRead) => {
                self.report(ConfigStatus::Active, ConfigStorage::NotWritten)
            }
            Ok(Received::TelemetryRequest) => (self.telemetry_frame(), None),
            Err(e) => {
                self.link.count(e);
                (None, None)
            }
        };
        (taken, len, event)
    }

    /// A configuration write (or one whose body did not deserialise): applied through
    /// [`Controller::reconfigure`] (standby only, validated, atomic: the next step flies it),
    /// counted, and answered with a report either way.
    // Out of line: another frame's path than the control task's, which its static bound
    // (target-bench) leaves out by this name.
    #[inline(never)]
    fn configure(&mut self, body: Result<(), WireError>) -> (Option<usize>, Option<Event>) {
        let cfg = self.config_in;
        let status = match body {
            Err(e) => {
                self.link.count(e);
                ConfigStatus::Malformed
            }
            Ok(()) => match self.controller.reconfigure(cfg) {
                Ok(()) => {
                    self.config_id = config_id(&cfg);
                    self.autopilot.set_design(cfg.attitude);
                    self.link.config_applied = self.link.config_applied.saturating_add(1);
                    // Answered once the board has stored it (`App::persisted`).
                    self.to_persist = Some(cfg);
                    return (None, Some(Event::Configured { id: self.config_id }));
                }
                Err(e) => ConfigStatus::refused(e),
            },
        };
        self.link.config_refused = self.link.config_refused.saturating_add(1);
        self.report(status, ConfigStorage::NotWritten)
    }

    /// An applied configuration waiting for the board's store ([`Board::persist`]).
    pub fn take_to_persist(&mut self) -> Option<ControllerConfig> {
        self.to_persist.take()
    }

    /// The board stored (or could not store) the applied configuration: the length of its
    /// report, to send.
    pub fn persisted(&mut self, storage: ConfigStorage) -> Option<usize> {
        if storage == ConfigStorage::Failed {
            self.link.config_store_failed = self.link.config_store_failed.saturating_add(1);
        }
        self.report(ConfigStatus::Applied, storage).0
    }

    /// Answers a configuration frame with a report of `status` and the configuration flown.
    fn report(
        &mut self,
        status: ConfigStatus,
        storage: ConfigStorage,
    ) -> (Option<usize>, Option<Event>) {
        let r = ConfigReport {
            seq: self.tx_seq,
            status,
            storage,
            config_id: self.config_id,
            config: *self.controller.config(),
        };
        match encode_config_report(&r, &mut self.buf) {
            Ok(frame) => {
                let n = frame.len();
                self.tx_seq = self.tx_seq.wrapping_add(1);
                (Some(n), None)
            }
            Err(e) => {
                self.link.count(e);
                (None, None)
            }
        }
    }

    /// A measurement frame whose last byte began decoding at `arrived` (cost counter).
    fn accept<C: CostCounter>(
        &mut self,
        up: Uplink,
        decode: u32,
        arrived: u32,
    ) -> (Option<usize>, Option<Event>) {
        let check = self.rx_seq.observe(up.seq);
        let new = self.link.count_sequence(check);
        match (self.schedule, new) {
            (Schedule::Lockstep, true) => {
                if self.through_autopilot() && !self.autopilot.attitude_arrived() {
                    // Its step waits for the autopilot's `ATTITUDE` (`App::poll`).
                    self.waiting = Some((up, decode, arrived));
                    return (None, None);
                }
                self.lockstep_step::<C>(up, decode, arrived)
            }
            (Schedule::Lockstep, false) if self.last.echo_seq == Some(up.seq) => {
                let mut d = self.last;
                d.seq = self.tx_seq;
                d.link_status.0 |= LinkStatus::RETRANSMIT;
                (self.encode::<C>(d).map(<[u8]>::len), None)
            }
            (Schedule::Lockstep, false) => (None, None),
            (Schedule::FreeRunning, true) => {
                let mut up = up;
                if let Some(prev) = self.latest.filter(|_| self.fresh)
                    && up.input.request == ModeRequest::None
                {
                    // `prev` is superseded before its step: keep its operator request.
                    up.input.request = prev.input.request;
                }
                self.latest = Some(up);
                self.fresh = true;
                self.decode_latest = decode;
                let event = self.stale.then_some(Event::LinkRecovered);
                self.stale = false;
                (None, event)
            }
            (Schedule::FreeRunning, false) => (None, None),
        }
    }

    /// Lockstep: the step of the new measurement frame `up` (decoded at the cost `decode`, its
    /// last byte at `arrived`) and its command frame.
    fn lockstep_step<C: CostCounter>(
        &mut self,
        up: Uplink,
        decode: u32,
        arrived: u32,
    ) -> (Option<usize>, Option<Event>) {
        self.latest = Some(up);
        let input = self.input_of::<C>(&up.input);
        let decode = decode.saturating_add(self.take_autopilot_decode());
        let (d, event) = self.step::<C>(&input, Some(up.seq), 0, decode);
        self.autopilot_ms = self.autopilot_ms.wrapping_add(PERIOD_MS);
        let len = self.encode::<C>(d).map(<[u8]>::len);
        self.trigger_at = len.map(|_| arrived);
        (len, event)
    }

    /// Whether the configuration flown flies through the autopilot (the attitude-command
    /// inner loop): navigation and mode from the autopilot, setpoints to it.
    fn through_autopilot(&self) -> bool {
        self.controller.config().autopilot_loop().is_some()
    }

    /// The step's input from the uplink's: through the autopilot, with its navigation and
    /// mode ([`Session::input`], its cost counted with the autopilot's decoding); otherwise
    /// the uplink's as it is.
    fn input_of<C: CostCounter>(&mut self, uplink: &ControllerInput) -> ControllerInput {
        if !self.through_autopilot() {
            return *uplink;
        }
        let t0 = C::now();
        let input = self.autopilot.input(self.autopilot_ms, uplink);
        let spent = C::now().wrapping_sub(t0);
        self.autopilot_decode = self.autopilot_decode.saturating_add(spent);
        input
    }

    /// The autopilot link's decoding since the last step, for the step's `Cost::decode`
    /// through the autopilot; 0 otherwise (bytes from an autopilot the configuration does
    /// not fly through are decoded and counted, not charged to the step).
    fn take_autopilot_decode(&mut self) -> u32 {
        let spent = core::mem::take(&mut self.autopilot_decode);
        if self.through_autopilot() { spent } else { 0 }
    }

    /// Lockstep through the autopilot: the waiting measurement frame's step once the
    /// autopilot's `ATTITUDE` has arrived. Its deadline's trigger is then the later of the
    /// frame's arrival and `pass_at`, the start of the pass that read the autopilot's bytes
    /// (their decode inside the window).
    fn release_waiting<C: CostCounter>(&mut self, pass_at: u32) -> (Option<usize>, Option<Event>) {
        match self.waiting {
            Some((up, decode, _)) if self.autopilot.attitude_arrived() => {
                self.waiting = None;
                self.lockstep_step::<C>(up, decode, pass_at)
            }
            _ => (None, None),
        }
    }

    /// Free-running: `ticks.count` control periods elapsed (at least one is due). Runs one
    /// step on the latest input and returns the length of its command frame, due
    /// [`CONTROL_DEADLINE_S`] after `ticks.last_tick_at`.
    // Out of line: the static bound of the control task (target-bench) starts here.
    #[inline(never)]
    pub fn on_periods<C: CostCounter>(&mut self, ticks: Periods) -> (Option<usize>, Option<Event>) {
        let periods = ticks.count;
        if periods == 0 {
            return (None, None);
        }
        self.link.deadline_missed = self.link.deadline_missed.saturating_add(periods - 1);
        self.periods_since_telemetry = self.periods_since_telemetry.saturating_add(periods);
        self.autopilot_ms = self
            .autopilot_ms
            .wrapping_add(periods.wrapping_mul(PERIOD_MS));
        let Some(latest) = self.latest else {
            // No measurement frame yet: standby trim, no step.
            let d = self.frame::<C>(None, LinkStatus::STALE, trim_output(), Cost::default());
            let len = self.encode::<C>(d).map(<[u8]>::len);
            self.trigger_at = len.map(|_| ticks.last_tick_at);
            return (len, None);
        };
        let mut input = self.input_of::<C>(&latest.input);
        let mut status = 0;
        let mut decode = self.take_autopilot_decode();
        let mut event = None;
        if self.fresh {
            self.fresh = false;
            self.periods_since_fresh = 0;
            decode = decode.saturating_add(self.decode_latest);
        } else {
            self.periods_since_fresh = self.periods_since_fresh.saturating_add(periods);
            input.request = ModeRequest::None;
            status |= LinkStatus::INPUT_HELD;
            self.link.held_steps = self.link.held_steps.saturating_add(1);
            if self.periods_since_fresh > LINK_TIMEOUT_PERIODS {
                if !self.stale {
                    self.stale = true;
                    self.link.timeouts = self.link.timeouts.saturating_add(1);
                    event = Some(Event::LinkStale);
                }
                status |= LinkStatus::STALE;
                self.link.stale_steps = self.link.stale_steps.saturating_add(1);
                input.nav = NavSample::from_array([f32::NAN; 12]);
            }
        }
        let (d, mode_event) = self.step::<C>(&input, Some(latest.seq), status, decode);
        if let (Some(stale), Some(mode)) = (event, mode_event) {
            // Both: the stale link first, the mode change after it.
            self.defer(mode);
            event = Some(stale);
        } else {
            event = event.or(mode_event);
        }
        let len = self.encode::<C>(d).map(<[u8]>::len);
        self.trigger_at = len.map(|_| ticks.last_tick_at);
        (len, event)
    }

    /// An event left to log after the one [`App::on_bytes`] or [`App::on_periods`] returned.
    pub fn take_pending_event(&mut self) -> Option<Event> {
        match &mut self.pending {
            [first @ Some(_), second] => {
                let e = first.take();
                *first = second.take();
                e
            }
            [None, second] => second.take(),
        }
    }

    /// The frame buffer: the first `len` bytes are the frame [`App::on_bytes`] or
    /// [`App::on_periods`] returned.
    pub fn frame_bytes(&self, len: usize) -> &[u8] {
        &self.buf[..len.min(MAX_FRAME_LEN)]
    }

    /// Hands the first `len` bytes of the frame buffer to the transmit queue (a frame it
    /// cannot take whole is dropped and counted). For a step's frame, then checks the
    /// deadline: an overrun is counted and returned, to log.
    fn send<B: Board>(&mut self, board: &mut B, len: usize) -> Option<Event> {
        let burst = core::mem::take(&mut self.autopilot_len);
        if burst > 0 {
            let frames = &self.autopilot_burst[..burst.min(MAX_BURST_LEN)];
            if board.transmit_autopilot(frames).is_err() {
                self.autopilot.count_tx_dropped();
            }
        }
        let frame = &self.buf[..len.min(MAX_FRAME_LEN)];
        if board.transmit(frame).is_err() {
            self.link.tx_dropped = self.link.tx_dropped.saturating_add(1);
        }
        let trigger = self.trigger_at.take()?;
        let elapsed = B::Counter::now().wrapping_sub(trigger);
        if elapsed <= B::Counter::DEADLINE {
            return None;
        }
        self.link.deadline_overruns = self.link.deadline_overruns.saturating_add(1);
        Some(Event::DeadlineOverrun {
            elapsed,
            deadline: B::Counter::DEADLINE,
            step: self.last.output.step,
        })
    }

    /// Sends the boot frame, then a telemetry frame (the boot's findings, the counters).
    pub fn boot<B: Board>(&mut self, board: &mut B) {
        if let Some(len) = self.boot_frame::<B::Counter>().map(<[u8]>::len) {
            self.send(board, len);
        }
        if let Some(len) = self.telemetry_frame() {
            self.send(board, len);
        }
    }

    /// Logs `first` (an event a frame's handling returned) and every event deferred.
    fn log_events<B: Board>(&mut self, board: &mut B, first: Option<Event>) {
        if let Some(e) = first {
            board.log(e);
        }
        while let Some(e) = self.take_pending_event() {
            board.log(e);
        }
    }

    /// Services the link once: every byte available (answering frames in lockstep), then the
    /// periods the tick counted (a due step, free-running; taken and ignored, lockstep).
    /// Returns the number of frames handed to the transmit queue (one it refused included:
    /// counted in `tx_dropped`).
    pub fn poll<B: Board>(&mut self, board: &mut B) -> u32 {
        let mut sent = 0;
        let errors = board.take_rx_errors();
        self.link.rx_errors = self.link.rx_errors.saturating_add(errors);
        self.receive_autopilot(board);
        let mut chunk = [0u8; RX_CHUNK_LEN];
        loop {
            let link = board.link();
            match link.read_ready() {
                Ok(true) => {}
                Ok(false) => break,
                Err(_) => {
                    self.link.rx_errors = self.link.rx_errors.saturating_add(1);
                    break;
                }
            }
            let n = match link.read(&mut chunk) {
                Ok(0) => break,
                Ok(n) => n,
                Err(_) => {
                    self.link.rx_errors = self.link.rx_errors.saturating_add(1);
                    break;
                }
            };
            let mut rest = &chunk[..n.min(chunk.len())];
            while !rest.is_empty() {
                let (taken, len, event) = self.on_bytes::<B::Counter>(rest);
                rest = rest.get(taken.max(1)..).unwrap_or(&[]);
                // An applied configuration: stored first (in standby; the store's time is
                // the board's), then answered with the outcome.
                let len = match self.take_to_persist() {
                    Some(cfg) => {
                        let storage = board.persist(&cfg);
                        self.persisted(storage)
                    }
                    None => len,
                };
                sent += self.answer(board, len, event);
            }
        }
        if self.waiting.is_some() {
            // The autopilot's bytes may have come after the measurement frame.
            let pass_at = B::Counter::now();
            self.receive_autopilot(board);
            let (len, event) = self.release_waiting::<B::Counter>(pass_at);
            sent += self.answer(board, len, event);
        }
        // Taken in both schedules (a board may tick in lockstep too, to wake the loop);
        // lockstep ignores the periods.
        let periods = board.take_periods();
        if self.schedule == Schedule::FreeRunning {
            let (len, event) = self.on_periods::<B::Counter>(periods);
            let late = match len {
                Some(len) => {
                    sent += 1;
                    self.send(board, len)
                }
                None => None,
            };
            // Telemetry after the command frame, outside the deadline's window.
            if len.is_some()
                && self.telemetry_due()
                && let Some(len) = self.telemetry_frame()
            {
                sent += 1;
                self.send(board, len);
            }
            self.log_events(board, event);
            self.log_events(board, late);
        }
        sent
    }

    /// Sends the frame of length `len` if there is one, then logs `event` and a deadline
    /// overrun (outside the deadline's window); the frames sent (0 or 1).
    fn answer<B: Board>(&mut self, board: &mut B, len: Option<usize>, event: Option<Event>) -> u32 {
        let late = len.and_then(|len| self.send(board, len));
        self.log_events(board, event);
        self.log_events(board, late);
        u32::from(len.is_some())
    }

    /// Every byte the autopilot link has received, into the session (stamped with the link's
    /// clock); its receiver errors counted.
    fn receive_autopilot<B: Board>(&mut self, board: &mut B) {
        let errors = board.take_autopilot_rx_errors();
        self.autopilot.count_rx_errors(errors);
        let mut chunk = [0u8; AUTOPILOT_CHUNK_LEN];
        loop {
            let port = board.autopilot();
            if !matches!(port.read_ready(), Ok(true)) {
                break;
            }
            let n = match port.read(&mut chunk) {
                Ok(n) if n > 0 => n,
                Ok(_) => break,
                Err(_) => {
                    self.autopilot.count_rx_errors(1);
                    break;
                }
            };
            // Timed as the peer's frames are (uninterrupted where the board's counter needs
            // it): the cost goes into the next step's decode.
            let (session, now) = (&mut self.autopilot, self.autopilot_ms);
            let spent = B::Counter::uninterrupted(|| {
                let t0 = B::Counter::now();
                for &b in chunk.get(..n).unwrap_or(&[]) {
                    session.push(b, now);
                }
                B::Counter::now().wrapping_sub(t0)
            });
            self.autopilot_decode = self.autopilot_decode.saturating_add(spent);
        }
    }

    /// The main loop: boot frame, then poll, report the pass complete (the watchdog is fed)
    /// and sleep, forever.
    pub fn run<B: Board>(mut self, board: &mut B) -> ! {
        self.boot(board);
        loop {
            self.poll(board);
            board.pass_completed();
            board.wait_for_event();
        }
    }
}

#[cfg(test)]
mod tests {
    use std::collections::VecDeque;
    use std::vec::Vec;

    use ibvs_core::attitude::InnerLoop;
    use ibvs_core::config::ConfigProblem;
    use ibvs_core::measurement::CameraMeasurement;
    use ibvs_core::wire::{
        FlightComputerMessage, MAX_FRAME_LEN, encode_config_read, encode_config_write,
        encode_message, encode_telemetry_request, encode_uplink,
    };

    use super::*;
    use crate::one_step::engage_input;
    use autopilot_link::peer::{AutopilotTelemetry, MAX_TELEMETRY_LEN, Peer, read_setpoint};
    use autopilot_link::{LinkIds, NavConfig};
    use ibvs_core::controller::StatusFlags;

    #[test]
    fn the_safe_frame_decodes_whole_after_a_frame_cut_off_mid_way() {
        let mut safe = [0u8; MAX_FRAME_LEN + 1];
        let safe = safe_frame(&mut safe).expect("encodes");
        assert_eq!(safe[0], 0, "a delimiter first");
        // Half of an ordinary command frame (the fault cut it off), then the safe frame.
        let mut buf = [0u8; MAX_FRAME_LEN];
        let other = encode_downlink(&Downlink::default(), &mut buf).expect("encodes");
        let mut stream: Vec<u8> = other[..other.len() / 2].to_vec();
        stream.extend_from_slice(safe);
        let mut decoder = FrameDecoder::new();
        let results: Vec<_> = stream
            .iter()
            .filter_map(|&b| decoder.feed(b).map(|r| r.and_then(|p| p.downlink())))
            .collect();
        assert_eq!(
            results.len(),
            2,
            "the cut frame, then the safe one: {results:?}"
        );
        assert!(results[0].is_err(), "the cut frame fails its check");
        let d = results[1].as_ref().expect("the safe frame decodes");
        assert_eq!(d.link_status, LinkStatus(LinkStatus::PANIC));
        assert_eq!(d.output.command.as_array(), trim_command());
        // Without the delimiter the two would run together into one bad frame.
        let mut joined: Vec<u8> = other[..other.len() / 2].to_vec();
        joined.extend_from_slice(&safe[1..]);
        let mut decoder = FrameDecoder::new();
        let bad: Vec<_> = joined
            .iter()
            .filter_map(|&b| decoder.feed(b).map(|r| r.and_then(|p| p.downlink())))
            .collect();
        assert!(bad.len() == 1 && bad[0].is_err(), "{bad:?}");
    }

    /// An in-memory board: bytes in, frames out, periods on demand; its cost counter `C`.
    struct Mock<C = NoCounter> {
        rx: VecDeque<u8>,
        tx: Vec<u8>,
        /// The transmit queue's free room, bytes (`None`: unbounded): a longer frame is
        /// refused.
        tx_room: Option<usize>,
        periods: u32,
        /// The counter's reading at the latest tick.
        tick_at: u32,
        rx_errors: u32,
        events: Vec<Event>,
        /// What `persist` was asked to store, and what it answers.
        stored: Vec<ControllerConfig>,
        storage: ConfigStorage,
        passes: u32,
        /// The autopilot link: bytes for the application, bytes it sent.
        ap: AutopilotPort,
        ap_tx: Vec<u8>,
        ap_rx_errors: u32,
        _counter: core::marker::PhantomData<C>,
    }

    /// The autopilot link's receive side.
    #[derive(Default)]
    struct AutopilotPort {
        rx: VecDeque<u8>,
    }

    impl embedded_io::ErrorType for AutopilotPort {
        type Error = MockError;
    }

    impl Read for AutopilotPort {
        fn read(&mut self, buf: &mut [u8]) -> Result<usize, MockError> {
            let n = buf.len().min(self.rx.len());
            for (slot, b) in buf.iter_mut().zip(self.rx.drain(..n)) {
                *slot = b;
            }
            Ok(n)
        }
    }

    impl ReadReady for AutopilotPort {
        fn read_ready(&mut self) -> Result<bool, MockError> {
            Ok(!self.rx.is_empty())
        }
    }

    impl<C> Default for Mock<C> {
        fn default() -> Self {
            Self {
                rx: VecDeque::new(),
                tx: Vec::new(),
                tx_room: None,
                periods: 0,
                tick_at: 0,
                rx_errors: 0,
                events: Vec::new(),
                stored: Vec::new(),
                storage: ConfigStorage::default(),
                passes: 0,
                ap: AutopilotPort::default(),
                ap_tx: Vec::new(),
                ap_rx_errors: 0,
                _counter: core::marker::PhantomData,
            }
        }
    }

    std::thread_local! {
        /// The [`Clock`] counter's reading, and how much each reading advances it.
        static CLOCK: core::cell::Cell<(u32, u32)> = const { core::cell::Cell::new((0, 0)) };
    }

    /// A cost counter the test drives: each reading advances it by a set stride (a slow
    /// MCU), and the test can set it; its deadline is 10,000 counts.
    struct Clock;

    impl Clock {
        fn set(now: u32, stride: u32) {
            CLOCK.with(|c| c.set((now, stride)));
        }
        fn peek() -> u32 {
            CLOCK.with(|c| c.get().0)
        }
    }

    impl CostCounter for Clock {
        const UNIT: CostUnit = CostUnit::Cycles;
        const DEADLINE: u32 = 10_000;
        fn now() -> u32 {
            CLOCK.with(|c| {
                let (now, stride) = c.get();
                c.set((now.wrapping_add(stride), stride));
                now
            })
        }
    }

    #[derive(Debug)]
    struct MockError;

    impl core::fmt::Display for MockError {
        fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
            f.write_str("mock link error")
        }
    }

    impl std::error::Error for MockError {}

    impl embedded_io::Error for MockError {
        fn kind(&self) -> embedded_io::ErrorKind {
            embedded_io::ErrorKind::Other
        }
    }

    impl<C> embedded_io::ErrorType for Mock<C> {
        type Error = MockError;
    }

    impl<C> Read for Mock<C> {
        fn read(&mut self, buf: &mut [u8]) -> Result<usize, MockError> {
            let n = buf.len().min(self.rx.len());
            for (slot, b) in buf.iter_mut().zip(self.rx.drain(..n)) {
                *slot = b;
            }
            Ok(n)
        }
    }

    impl<C> ReadReady for Mock<C> {
        fn read_ready(&mut self) -> Result<bool, MockError> {
            Ok(!self.rx.is_empty())
        }
    }

    impl<C: CostCounter> Board for Mock<C> {
        type Link = Self;
        type Autopilot = AutopilotPort;
        fn autopilot(&mut self) -> &mut AutopilotPort {
            &mut self.ap
        }
        fn transmit_autopilot(&mut self, frames: &[u8]) -> Result<(), QueueFull> {
            self.ap_tx.extend_from_slice(frames);
            Ok(())
        }
        fn take_autopilot_rx_errors(&mut self) -> u32 {
            core::mem::take(&mut self.ap_rx_errors)
        }
        type Counter = C;
        fn link(&mut self) -> &mut Self {
            self
        }
        fn transmit(&mut self, frame: &[u8]) -> Result<(), QueueFull> {
            if self.tx_room.is_some_and(|room| frame.len() > room) {
                return Err(QueueFull);
            }
            self.tx.extend_from_slice(frame);
            Ok(())
        }
        fn take_periods(&mut self) -> Periods {
            Periods {
                count: core::mem::take(&mut self.periods),
                last_tick_at: self.tick_at,
            }
        }
        fn take_rx_errors(&mut self) -> u32 {
            core::mem::take(&mut self.rx_errors)
        }
        fn pass_completed(&mut self) {
            self.passes += 1;
        }
        fn wait_for_event(&mut self) {}
        fn log(&mut self, event: Event) {
            self.events.push(event);
        }
        fn persist(&mut self, cfg: &ControllerConfig) -> ConfigStorage {
            self.stored.push(*cfg);
            self.storage
        }
    }

    impl<C: CostCounter> Mock<C> {
        fn send(&mut self, seq: u32, input: ControllerInput) {
            let mut buf = [0u8; MAX_FRAME_LEN];
            let f = encode_uplink(&Uplink { seq, input }, &mut buf).expect("fits");
            self.rx.extend(f.iter().copied());
        }
        /// Every command frame sent so far (telemetry frames skipped; clears the output).
        fn frames(&mut self) -> Vec<Downlink> {
            self.messages()
                .into_iter()
                .filter_map(|m| match m {
                    FlightComputerMessage::Command(d) => Some(d),
                    FlightComputerMessage::Telemetry(_) => None,
                    other => panic!("not a command frame: {other:?}"),
                })
                .collect()
        }

        /// Asks for a telemetry frame and returns it (the output must hold nothing else).
        fn telemetry(&mut self, app: &mut App) -> Telemetry {
            let mut buf = [0u8; MAX_FRAME_LEN];
            self.rx.extend(
                encode_telemetry_request(&mut buf)
                    .expect("fits")
                    .iter()
                    .copied(),
            );
            assert_eq!(app.poll(self), 1, "one answer");
            match self.messages().as_slice() {
                [FlightComputerMessage::Telemetry(t)] => *t,
                other => panic!("not one telemetry frame: {other:?}"),
            }
        }

        /// Every frame sent so far, of either kind (and clears the output).
        fn messages(&mut self) -> Vec<FlightComputerMessage> {
            let mut d = FrameDecoder::new();
            let out = self
                .tx
                .iter()
                .filter_map(|&b| {
                    d.feed(b)
                        .map(|r| r.and_then(|p| p.flight_computer_message()))
                })
                .map(|r| r.expect("valid frame"))
                .collect();
            self.tx.clear();
            out
        }

        /// Sends a configuration write and returns the one report it must be answered by.
        fn configure(&mut self, app: &mut App, cfg: &ControllerConfig) -> ConfigReport {
            let mut buf = [0u8; MAX_FRAME_LEN];
            self.rx.extend(
                encode_config_write(cfg, &mut buf)
                    .expect("fits")
                    .iter()
                    .copied(),
            );
            assert_eq!(app.poll(self), 1, "one answer");
            match self.messages().as_slice() {
                [FlightComputerMessage::ConfigReport(r)] => r.clone(),
                other => panic!("not one report: {other:?}"),
            }
        }
    }

    /// Frame `cam_seq` of a drogue closing slowly (the content changes every frame, as a
    /// working tracker's does: the core rejects a frozen one).
    fn input(cam_seq: u32, request: ModeRequest) -> ControllerInput {
        let mut i = engage_input();
        i.measurement.seq = cam_seq;
        i.measurement.depth_m -= 0.001 * cam_seq as f32;
        i.request = request;
        i
    }

    fn lockstep() -> (App, Mock) {
        let mut app = App::new(Schedule::Lockstep, BootReport::power_on(), None).expect("config");
        let mut board: Mock = Mock::default();
        app.boot(&mut board);
        (app, board)
    }

    #[test]
    fn boots_with_a_trim_frame() {
        let (_, mut board) = lockstep();
        let f = board.frames();
        assert_eq!(f.len(), 1);
        assert!(f[0].link_status.contains(LinkStatus::BOOT));
        assert_eq!(f[0].output.command.as_array(), trim_command());
        assert_eq!(
            (f[0].seq, f[0].echo_seq, f[0].output.mode),
            (0, None, Mode::Standby)
        );
    }

    #[test]
    fn lockstep_answers_each_frame_like_the_core_in_process() {
        let (mut app, mut board) = lockstep();
        board.frames();
        let mut twin = Controller::new(ControllerConfig::default()).expect("config");
        for k in 1..=50u32 {
            let i = input(
                k,
                if k == 1 {
                    ModeRequest::Engage
                } else {
                    ModeRequest::None
                },
            );
            board.send(k, i);
            assert_eq!(app.poll(&mut board), 1);
            let f = board.frames();
            assert_eq!(f.len(), 1);
            assert_eq!(f[0].output, twin.step(&i));
            // The boot frame is 0 and its telemetry 1; every 10th step a telemetry frame.
            assert_eq!((f[0].seq, f[0].echo_seq), (k + 1 + (k - 1) / 10, Some(k)));
            if k % 10 == 0 {
                let t = board.telemetry(&mut app);
                assert_eq!(t.counters, *twin.counters());
                assert_eq!(t.probe_tip_image, twin.probe_tip_image());
                assert_eq!(t.link.frames_ok, k);
                assert_eq!(t.seq, f[0].seq + 1, "one frame counter for every frame");
            }
        }
        assert_eq!(
            board.events,
            [Event::ModeChanged {
                mode: Mode::PreContact,
                reason: None,
                step: 1
            }]
        );
    }

    #[test]
    fn lockstep_counts_every_bad_input_and_reports_it_next() {
        let (mut app, mut board) = lockstep();
        board.frames();
        board.send(1, input(1, ModeRequest::Engage));
        // Garbage with zeros (two corrupt frames), an oversize run, a frame with a bad CRC.
        board.rx.extend([0x11, 0x22, 0x00, 0x05, 0x01, 0x00]);
        board
            .rx
            .extend(core::iter::repeat_n(0x42, MAX_FRAME_LEN + 40));
        board.rx.push_back(0);
        let mut buf = [0u8; MAX_FRAME_LEN];
        let mut bad = encode_uplink(
            &Uplink {
                seq: 2,
                input: input(2, ModeRequest::None),
            },
            &mut buf,
        )
        .expect("fits")
        .to_vec();
        bad[10] ^= 0x01;
        board.rx.extend(bad);
        board.rx_errors = 2;
        // The next good frame skips sequence 2 (its frame was lost): a gap of one.
        board.send(3, input(3, ModeRequest::None));
        assert_eq!(app.poll(&mut board), 2);
        assert_eq!(board.frames().len(), 2);
        let t = board.telemetry(&mut app);
        let l = t.link;
        assert_eq!(
            (l.corrupt, l.oversize, l.seq_gap, l.rx_errors),
            (3, 1, 1, 2)
        );
        assert_eq!((l.frames_ok, t.counters.frames_dropped), (2, 1));
    }

    #[test]
    fn a_configuration_write_in_standby_is_applied_reported_and_flown() {
        let (mut app, mut board) = lockstep();
        let boot = board.frames();
        assert_eq!(boot[0].config_id, config_id(&ControllerConfig::default()));
        let cfg = ControllerConfig::paper();
        let r = board.configure(&mut app, &cfg);
        assert_eq!(r.status, ConfigStatus::Applied);
        assert_eq!((r.config, r.config_id), (cfg, config_id(&cfg)));
        assert_eq!(
            board.events,
            [Event::Configured {
                id: config_id(&cfg)
            }]
        );
        // A read answers with the same, and changes nothing.
        let mut buf = [0u8; MAX_FRAME_LEN];
        board
            .rx
            .extend(encode_config_read(&mut buf).expect("fits").iter().copied());
        assert_eq!(app.poll(&mut board), 1);
        match board.messages().as_slice() {
            [FlightComputerMessage::ConfigReport(read)] => {
                assert_eq!(read.status, ConfigStatus::Active);
                assert_eq!((read.config, read.config_id), (cfg, r.config_id));
                assert_eq!(read.seq, r.seq + 1, "one frame counter for every frame");
            }
            other => panic!("{other:?}"),
        }
        // The steps fly it exactly as a controller built with it, and say so.
        let mut twin = Controller::new(cfg).expect("valid");
        for seq in 1..=5 {
            let i = input(seq, ModeRequest::Engage);
            board.send(seq, i);
            app.poll(&mut board);
            let f = board.frames();
            let want = twin.step(&i);
            twin.follow_schedule();
            assert_eq!(f[0].output, want);
            assert_eq!(f[0].config_id, config_id(&cfg));
        }
        let t = board.telemetry(&mut app);
        assert_eq!((t.link.config_applied, t.config_id), (1, config_id(&cfg)));
    }

    #[test]
    fn an_applied_configuration_is_stored_before_it_is_reported_and_boots_next_time() {
        let (mut app, mut board) = lockstep();
        board.frames();
        board.storage = ConfigStorage::Stored { generation: 4 };
        let cfg = ControllerConfig::paper();
        let r = board.configure(&mut app, &cfg);
        assert_eq!(board.stored, [cfg], "stored once, before the answer");
        assert_eq!(
            (r.status, r.storage),
            (ConfigStatus::Applied, board.storage)
        );
        // A store that fails: still applied and flown, said and counted.
        board.storage = ConfigStorage::Failed;
        let mut next = cfg;
        next.ibvs.k2_mps = 2.5;
        let r = board.configure(&mut app, &next);
        assert_eq!(
            (r.status, r.storage),
            (ConfigStatus::Applied, ConfigStorage::Failed)
        );
        assert_eq!(r.config, next);
        // A refused write stores nothing.
        let mut bad = next;
        bad.integrator_limit_m = f32::NAN;
        let r = board.configure(&mut app, &bad);
        assert_eq!(r.storage, ConfigStorage::NotWritten);
        assert_eq!(board.stored, [cfg, next]);
        let l = board.telemetry(&mut app).link;
        assert_eq!(
            (l.config_applied, l.config_refused, l.config_store_failed),
            (2, 1, 1)
        );

        // The next boot with what the store holds: flown, and the boot frame says so.
        let mut app =
            App::new(Schedule::Lockstep, BootReport::power_on(), Some(next)).expect("valid");
        let mut board: Mock = Mock::default();
        app.boot(&mut board);
        let boot = board.frames();
        assert!(boot[0].link_status.contains(LinkStatus::STORED_CONFIG));
        assert_eq!(boot[0].config_id, config_id(&next));
        // Without one (or with one that does not validate), the default, and no bit.
        for stored in [None, Some(bad)] {
            let mut app =
                App::new(Schedule::Lockstep, BootReport::power_on(), stored).expect("default");
            let mut board: Mock = Mock::default();
            app.boot(&mut board);
            let boot = board.frames();
            assert!(!boot[0].link_status.contains(LinkStatus::STORED_CONFIG));
            assert_eq!(boot[0].config_id, config_id(&ControllerConfig::default()));
        }
    }

    #[test]
    fn a_configuration_write_is_refused_named_and_counted_unless_valid_in_standby() {
        let (mut app, mut board) = lockstep();
        board.frames();
        let default = ControllerConfig::default();
        // Invalid: the field and the problem, and the default still flown.
        let mut bad = default;
        bad.ibvs.k3_per_s = -1.0;
        let r = board.configure(&mut app, &bad);
        match &r.status {
            ConfigStatus::Rejected { field, problem } => {
                assert_eq!(
                    (field.as_str(), *problem),
                    ("ibvs.k3_per_s", ConfigProblem::NotPositive)
                );
            }
            other => panic!("{other:?}"),
        }
        assert_eq!((r.config, r.config_id), (default, config_id(&default)));
        // Malformed: a write whose body is a measurement, its CRC good.
        let mut buf = [0u8; MAX_FRAME_LEN];
        let frame = encode_message(FrameKind::ConfigWrite, &Uplink::default(), &mut buf)
            .expect("fits")
            .to_vec();
        board.rx.extend(frame);
        assert_eq!(app.poll(&mut board), 1);
        match board.messages().as_slice() {
            [FlightComputerMessage::ConfigReport(r)] => {
                assert_eq!(r.status, ConfigStatus::Malformed)
            }
            other => panic!("{other:?}"),
        }
        // Engaged: refused with the mode, whatever the configuration.
        board.send(1, input(1, ModeRequest::Engage));
        app.poll(&mut board);
        let engaged = board.frames()[0].output.mode;
        assert_eq!(
            engaged,
            Mode::PreContact,
            "the default procedure's first mode"
        );
        let r = board.configure(&mut app, &ControllerConfig::paper());
        assert_eq!(r.status, ConfigStatus::NotStandby(engaged));
        assert_eq!(r.config, default);
        let l = board.telemetry(&mut app).link;
        assert_eq!((l.config_applied, l.config_refused, l.malformed), (0, 3, 1));
        assert!(
            board
                .events
                .iter()
                .all(|e| !matches!(e, Event::Configured { .. }))
        );
    }

    #[test]
    fn telemetry_says_why_the_board_reset_and_which_clock_it_runs_on() {
        let boot = BootReport {
            reset_cause: ResetCause::BrownOut,
            clock: ClockSource::InternalFallback,
            previous_fault: false,
        };
        let mut app = App::new(Schedule::Lockstep, boot, None).expect("config");
        let mut board: Mock = Mock::default();
        app.boot(&mut board);
        // The boot frame, then the boot's telemetry; again on request.
        let found = (ResetCause::BrownOut, ClockSource::InternalFallback);
        match board.messages().as_slice() {
            [
                FlightComputerMessage::Command(d),
                FlightComputerMessage::Telemetry(t),
            ] => {
                assert!(d.link_status.contains(LinkStatus::BOOT));
                assert!(!d.link_status.contains(LinkStatus::PREVIOUS_PANIC));
                assert_eq!((t.reset_cause, t.clock), found);
            }
            other => panic!("{other:?}"),
        }
        board.send(1, input(1, ModeRequest::None));
        app.poll(&mut board);
        assert_eq!(board.frames().len(), 1);
        let t = board.telemetry(&mut app);
        assert_eq!((t.reset_cause, t.clock), found);
        // The qemu board's report: a power-on, no clock to report.
        let (mut app, mut board) = lockstep();
        board.frames();
        let t = board.telemetry(&mut app);
        assert_eq!(
            (t.reset_cause, t.clock),
            (ResetCause::PowerOn, ClockSource::NotReported)
        );
    }

    /// Sends frame `seq` with `request` and runs the pass that answers it (lockstep) or the
    /// period after it (free-running); the one command frame sent.
    fn exchange(app: &mut App, board: &mut Mock, seq: u32, request: ModeRequest) -> Downlink {
        board.send(seq, input(seq, request));
        if app.schedule() == Schedule::FreeRunning {
            board.periods = 1;
        }
        assert_eq!(app.poll(board), 1);
        let f = board.frames();
        assert_eq!(f.len(), 1);
        f[0]
    }

    #[test]
    fn after_a_watchdog_reset_it_stays_in_standby_until_the_peer_acknowledges() {
        let trim = trim_command();
        let after_watchdog = BootReport {
            reset_cause: ResetCause::IndependentWatchdog,
            clock: ClockSource::Crystal,
            previous_fault: false,
        };
        // A fault record before an ordinary reset counts as abnormal too.
        let after_fault = BootReport {
            reset_cause: ResetCause::Software,
            previous_fault: true,
            ..after_watchdog
        };
        // So does a power-on on the internal oscillator (the link's timing unverified).
        let on_hsi = BootReport {
            reset_cause: ResetCause::PowerOn,
            clock: ClockSource::InternalFallback,
            previous_fault: false,
        };
        for (schedule, boot) in [
            (Schedule::Lockstep, after_watchdog),
            (Schedule::FreeRunning, after_watchdog),
            (Schedule::Lockstep, after_fault),
            (Schedule::FreeRunning, on_hsi),
        ] {
            let mut app = App::new(schedule, boot, None).expect("config");
            let mut board: Mock = Mock::default();
            app.boot(&mut board);
            let (b, t) = match board.messages().as_slice() {
                [
                    FlightComputerMessage::Command(b),
                    FlightComputerMessage::Telemetry(t),
                ] => (*b, *t),
                other => panic!("{other:?}"),
            };
            assert!(b.link_status.contains(LinkStatus::BOOT));
            assert_eq!(
                (b.output.mode, t.reset_cause),
                (Mode::Standby, boot.reset_cause)
            );
            assert_eq!(b.output.command.as_array(), trim);
            assert_eq!(
                b.link_status.contains(LinkStatus::PREVIOUS_PANIC),
                boot.previous_fault
            );
            // A peer that asks to engage in every frame while it sees standby, as the
            // simulator's does: held back, counted, logged once.
            for seq in 1..=5 {
                let d = exchange(&mut app, &mut board, seq, ModeRequest::Engage);
                assert_eq!(d.output.mode, Mode::Standby, "{schedule:?} frame {seq}");
                assert_eq!(d.output.command.as_array(), trim);
                let t = board.telemetry(&mut app);
                assert_eq!(t.link.engage_inhibited, seq);
                assert_eq!(t.counters.engage_refused, 0, "never reached the controller");
            }
            assert_eq!(
                board.events,
                [Event::EngageInhibited {
                    cause: boot.reset_cause
                }]
            );
            // The acknowledgement, then an engage that engages.
            let d = exchange(&mut app, &mut board, 6, ModeRequest::Reset);
            assert_eq!(d.output.mode, Mode::Standby);
            assert_eq!(board.events.last(), Some(&Event::ResetAcknowledged));
            let d = exchange(&mut app, &mut board, 7, ModeRequest::Engage);
            assert_eq!(d.output.mode, Mode::PreContact, "{schedule:?}");
            assert_eq!(board.telemetry(&mut app).link.engage_inhibited, 5);
        }
        // After a power-on the first engage engages (no acknowledgement asked).
        let (mut app, mut board) = lockstep();
        board.frames();
        let d = exchange(&mut app, &mut board, 1, ModeRequest::Engage);
        let t = board.telemetry(&mut app);
        assert_eq!(
            (d.output.mode, t.link.engage_inhibited),
            (Mode::PreContact, 0)
        );
    }

    #[test]
    fn a_step_past_its_deadline_is_counted_logged_and_still_sent() {
        // Lockstep on a slow MCU: every counter reading 10,000 counts after the previous,
        // so from the last byte to the queued frame (several readings) is past the
        // 10,000-count deadline.
        Clock::set(0, 0);
        let mut app = App::new(Schedule::Lockstep, BootReport::power_on(), None).expect("config");
        let mut board: Mock<Clock> = Mock::default();
        app.boot(&mut board);
        board.frames();
        let mut overruns = Vec::new();
        let mut sent = Vec::new();
        board.send(1, input(1, ModeRequest::Engage));
        app.poll(&mut board);
        sent.extend(board.frames());
        overruns.push(board.telemetry(&mut app).link.deadline_overruns);
        Clock::set(0, 10_000);
        board.send(2, input(2, ModeRequest::None));
        app.poll(&mut board);
        sent.extend(board.frames());
        // A configuration report or a telemetry frame is not a step: not measured, however
        // slow.
        let mut buf = [0u8; MAX_FRAME_LEN];
        board
            .rx
            .extend(encode_config_read(&mut buf).expect("fits").iter().copied());
        app.poll(&mut board);
        board.messages();
        overruns.push(board.telemetry(&mut app).link.deadline_overruns);
        Clock::set(0, 0);
        board.send(3, input(3, ModeRequest::None));
        app.poll(&mut board);
        sent.extend(board.frames());
        overruns.push(board.telemetry(&mut app).link.deadline_overruns);
        // Frame 1 on time, frame 2 late (sent, counted), frame 3 on time.
        assert_eq!(overruns, [0, 1, 1]);
        assert_eq!(sent[1].echo_seq, Some(2), "the late frame was sent");
        let late: Vec<&Event> = board
            .events
            .iter()
            .filter(|e| matches!(e, Event::DeadlineOverrun { .. }))
            .collect();
        match late.as_slice() {
            [
                Event::DeadlineOverrun {
                    elapsed,
                    deadline,
                    step,
                },
            ] => {
                assert!(*elapsed > *deadline && *deadline == 10_000, "{elapsed}");
                assert_eq!(*step, 2);
            }
            other => panic!("{other:?}"),
        }

        // Free-running: measured from the period's tick, whatever the pass did before.
        let mut app =
            App::new(Schedule::FreeRunning, BootReport::power_on(), None).expect("config");
        let mut board: Mock<Clock> = Mock::default();
        app.boot(&mut board);
        board.frames();
        let mut period = |board: &mut Mock<Clock>, now: u32, tick_at: u32| {
            Clock::set(now, 0);
            board.tick_at = tick_at;
            board.periods = 1;
            app.poll(board);
            assert_eq!(board.frames().len(), 1);
            board.telemetry(&mut app).link.deadline_overruns
        };
        assert_eq!(
            period(&mut board, 50_000, 41_000),
            0,
            "9,000 after the tick"
        );
        assert_eq!(
            period(&mut board, 50_000, 39_999),
            1,
            "10,001: late, counted"
        );
        assert_eq!(
            period(&mut board, 5, u32::MAX - 10),
            1,
            "16 across the wrap"
        );
        assert_eq!(period(&mut board, 7, 7), 1);
        assert_eq!(Clock::peek(), 7);
        assert!(board.events.contains(&Event::DeadlineOverrun {
            elapsed: 10_001,
            deadline: 10_000,
            step: 0,
        }));
    }

    #[test]
    fn a_frame_the_transmit_queue_cannot_take_whole_is_dropped_and_counted() {
        let (mut app, mut board) = lockstep();
        board.frames();
        board.tx_room = Some(100); // less than any command frame
        board.send(1, input(1, ModeRequest::Engage));
        app.poll(&mut board);
        assert!(board.tx.is_empty(), "nothing of it sent");
        board.tx_room = None;
        board.send(2, input(2, ModeRequest::None));
        app.poll(&mut board);
        let f = board.frames();
        assert_eq!(f.len(), 1);
        let t = board.telemetry(&mut app);
        assert_eq!((f[0].echo_seq, t.link.tx_dropped), (Some(2), 1));
        assert_eq!(t.link.tx_errors, 0);
    }

    #[test]
    fn lockstep_takes_the_tick_and_sends_nothing_for_it() {
        let (mut app, mut board) = lockstep();
        board.frames();
        board.periods = 3;
        assert_eq!(app.poll(&mut board), 0);
        assert_eq!(board.periods, 0, "taken, so the loop sleeps until the next");
        assert!(board.frames().is_empty());
        assert_eq!(app.link_counters().deadline_missed, 0);
    }

    #[test]
    fn lockstep_retransmits_on_a_repeat_without_stepping() {
        let (mut app, mut board) = lockstep();
        board.send(1, input(1, ModeRequest::Engage));
        board.send(1, input(1, ModeRequest::Engage));
        board.send(0, input(0, ModeRequest::None)); // older: dropped silently, counted
        app.poll(&mut board);
        let f = board.frames();
        assert_eq!(f.len(), 3); // boot, answer, retransmission
        assert!(f[2].link_status.contains(LinkStatus::RETRANSMIT));
        assert_eq!(f[2].output, f[1].output);
        let t = board.telemetry(&mut app);
        assert_eq!((t.counters.steps, t.link.seq_repeat), (1, 1));
        assert_eq!(app.link_counters().seq_old, 1);
    }

    #[test]
    fn free_running_holds_then_goes_stale_then_breaks_away_open_loop() {
        let mut app =
            App::new(Schedule::FreeRunning, BootReport::power_on(), None).expect("config");
        let mut board: Mock = Mock::default();
        app.boot(&mut board);
        // A period before any frame: trim, no step.
        board.periods = 1;
        app.poll(&mut board);
        // Frames for 10 periods, then silence.
        for k in 1..=10u32 {
            board.send(
                k,
                input(
                    k,
                    if k == 1 {
                        ModeRequest::Engage
                    } else {
                        ModeRequest::None
                    },
                ),
            );
            board.periods = 1;
            app.poll(&mut board);
        }
        for _ in 0..40 {
            board.periods = 1;
            app.poll(&mut board);
        }
        board.periods = 3; // two deadlines missed
        app.poll(&mut board);
        // Telemetry came with the boot frame, then after a command frame whenever a
        // counter had changed, never within 10 periods of the one before.
        let messages = board.messages();
        let mut f = Vec::new();
        let mut telemetry_at = Vec::new();
        for m in messages {
            match m {
                FlightComputerMessage::Command(d) => f.push(d),
                FlightComputerMessage::Telemetry(_) => telemetry_at.push(f.len()),
                other => panic!("{other:?}"),
            }
        }
        assert_eq!(f.len(), 1 + 1 + 10 + 40 + 1);
        assert_eq!(telemetry_at[0], 1, "right after the boot frame");
        let gaps: Vec<usize> = telemetry_at.windows(2).map(|w| w[1] - w[0]).collect();
        assert!(
            !gaps.is_empty() && gaps.iter().all(|&g| g == TELEMETRY_MIN_PERIODS as usize),
            "counters change every period: one every {TELEMETRY_MIN_PERIODS}: {telemetry_at:?}"
        );
        assert_eq!(f[1].output.command.as_array(), trim_command());
        assert_eq!(f[1].output.step, 0);
        assert_eq!(f[2].output.mode, Mode::PreContact);
        let last = f[f.len() - 1];
        assert_eq!(last.output.mode, Mode::Breakaway);
        assert_eq!(
            last.output.breakaway_reason,
            Some(BreakawayReason::MeasurementLost)
        );
        assert!(
            last.output
                .status
                .contains(ibvs_core::controller::StatusFlags::OPEN_LOOP)
        );
        assert!(
            last.link_status
                .contains(LinkStatus::STALE | LinkStatus::FREE_RUNNING)
        );
        let l = board.telemetry(&mut app).link;
        assert_eq!((l.timeouts, l.held_steps, l.deadline_missed), (1, 41, 2));
        assert_eq!(l.stale_steps, 41 - LINK_TIMEOUT_PERIODS);
        assert!(board.events.contains(&Event::LinkStale));
        // The link comes back: recovered, still in (latched) breakaway.
        board.send(11, input(11, ModeRequest::None));
        board.periods = 1;
        app.poll(&mut board);
        let f = board.frames();
        assert!(!f[0].link_status.contains(LinkStatus::STALE));
        assert_eq!(f[0].output.mode, Mode::Breakaway);
        assert_eq!(board.events.last(), Some(&Event::LinkRecovered));
    }

    #[test]
    fn a_request_in_a_superseded_frame_is_not_lost() {
        let mut app =
            App::new(Schedule::FreeRunning, BootReport::power_on(), None).expect("config");
        let mut board: Mock = Mock::default();
        board.send(1, input(1, ModeRequest::Engage));
        board.send(2, input(2, ModeRequest::None));
        board.periods = 1;
        app.poll(&mut board);
        // Two more in one period: the core sees camera frame 3 skipped.
        board.send(3, input(3, ModeRequest::None));
        board.send(4, input(4, ModeRequest::None));
        board.periods = 1;
        app.poll(&mut board);
        let f = board.frames();
        assert_eq!(
            (f[0].output.mode, f[0].echo_seq),
            (Mode::PreContact, Some(2))
        );
        assert_eq!(f[1].echo_seq, Some(4));
        assert_eq!(board.telemetry(&mut app).counters.frames_dropped, 1);
    }

    #[test]
    fn a_held_input_does_not_repeat_the_request() {
        let mut app =
            App::new(Schedule::FreeRunning, BootReport::power_on(), None).expect("config");
        let mut board: Mock = Mock::default();
        board.send(1, input(1, ModeRequest::Engage));
        board.periods = 1;
        app.poll(&mut board);
        board.send(2, input(2, ModeRequest::Reset));
        board.periods = 1;
        app.poll(&mut board);
        board.send(3, input(3, ModeRequest::Engage));
        for _ in 0..2 {
            board.periods = 1;
            app.poll(&mut board);
        }
        // Engaged again once, then the held input (Engage cleared) keeps it engaged.
        let f = board.frames();
        let modes: Vec<Mode> = f.iter().map(|d| d.output.mode).collect();
        assert_eq!(
            modes,
            [
                Mode::PreContact,
                Mode::Standby,
                Mode::PreContact,
                Mode::PreContact
            ]
        );
        assert_eq!(
            f[3].output.measurement_error,
            Some(ibvs_core::measurement::MeasurementError::Repeated)
        );
    }

    /// The configuration flying the attitude-command loop through the autopilot.
    fn through_autopilot() -> ControllerConfig {
        ControllerConfig {
            inner_loop: InnerLoop::Attitude,
            ..ControllerConfig::default()
        }
    }

    /// The autopilot's frames for step `k` (GUIDED when `guided`), its navigation that of
    /// `input`'s sample.
    fn autopilot_frames(peer: &mut Peer, i: &ControllerInput, k: u32, guided: bool) -> Vec<u8> {
        let t = AutopilotTelemetry::of_sample(&i.nav, &NavConfig::default()).expect("in envelope");
        let mut buf = [0u8; MAX_TELEMETRY_LEN];
        let n = peer.telemetry(&t, guided, k * PERIOD_MS, &mut buf);
        buf[..n].to_vec()
    }

    #[test]
    fn lockstep_through_the_autopilot_waits_for_its_attitude_and_flies_like_the_in_process_twin() {
        let cfg = through_autopilot();
        let mut app = App::new(Schedule::Lockstep, BootReport::power_on(), Some(cfg)).expect("ok");
        let mut board: Mock = Mock::default();
        app.boot(&mut board);
        board.frames();
        let mut twin = Controller::new(cfg).expect("config");
        let mut twin_link = Session::new(SessionConfig::default());
        let mut peer = Peer::new(LinkIds::default(), [0.5, 0.5]);
        let mut engaged = false;
        for k in 0..40u32 {
            // Engage asked until flown (the time constants come in the second step).
            let request = if engaged {
                ModeRequest::None
            } else {
                ModeRequest::Engage
            };
            let i = input(k + 1, request);
            let mav = autopilot_frames(&mut peer, &i, k, true);
            // The measurement frame first (its autopilot bytes are late): no step yet.
            board.send(k + 1, i);
            assert_eq!(app.poll(&mut board), 0, "step {k} waits for the attitude");
            assert!(board.ap_tx.is_empty());
            board.ap.rx.extend(mav.iter().copied());
            assert_eq!(app.poll(&mut board), 1, "step {k} once the attitude is in");
            let f = board.frames();
            // The twin: the same session and controller in process.
            mav.iter().for_each(|&b| twin_link.push(b, k * PERIOD_MS));
            let ti = twin_link.input(k * PERIOD_MS, &i);
            let out = twin.step(&ti);
            twin.follow_schedule();
            let mut burst = [0u8; MAX_BURST_LEN];
            let n = twin_link.send(k * PERIOD_MS, &out.command, &mut burst);
            assert_eq!(f[0].output, out, "step {k}");
            assert_eq!(board.ap_tx, burst[..n], "step {k}: the setpoint's bytes");
            let read = read_setpoint(&board.ap_tx, 0.0);
            assert_eq!(read.time_boot_ms, Some(k * PERIOD_MS));
            assert_eq!(read.heartbeats, u32::from(k % 50 == 0), "1 Hz");
            // The attitude time constants asked for with the first heartbeat only.
            assert_eq!(read.time_constants_asked, [k == 0; 2]);
            peer.hear(&read);
            board.ap_tx.clear();
            engaged |= out.mode != Mode::Standby;
            assert!(matches!(out.command, Command::Attitude(_)));
        }
        assert!(engaged, "the autopilot's navigation and mode let it engage");
        let t = board.telemetry(&mut app);
        assert_eq!(t.autopilot, twin_link.counters());
        assert_eq!(
            t.autopilot.frames_used,
            40 * 4 + 1 + 2,
            "four a step, a heartbeat, the two time constants"
        );
        assert_eq!(t.autopilot.nav_missing + t.autopilot.nav_stale, 0);
    }

    #[test]
    fn free_running_through_the_autopilot_needs_its_navigation_and_mode() {
        let cfg = through_autopilot();
        let mut app =
            App::new(Schedule::FreeRunning, BootReport::power_on(), Some(cfg)).expect("ok");
        let mut board: Mock = Mock::default();
        app.boot(&mut board);
        board.frames();
        let mut peer = Peer::new(LinkIds::default(), [0.5, 0.5]);
        // Measurement frames and the autopilot's telemetry each period, in FBWA: the engage
        // is refused (the autopilot does not follow setpoints).
        for k in 1..=5u32 {
            let i = input(k, ModeRequest::Engage);
            board.send(k, i);
            board
                .ap
                .rx
                .extend(autopilot_frames(&mut peer, &i, k, false));
            board.periods = 1;
            app.poll(&mut board);
            peer.hear(&read_setpoint(&core::mem::take(&mut board.ap_tx), 0.0));
            let f = board.frames();
            assert_eq!(f[0].output.mode, Mode::Standby, "period {k}: not in GUIDED");
            assert!(f[0].output.status.contains(StatusFlags::ENGAGE_REFUSED));
        }
        // GUIDED: it engages.
        let mut mode = Mode::Standby;
        for k in 6..=60u32 {
            let i = input(k, ModeRequest::Engage);
            board.send(k, i);
            board.ap.rx.extend(autopilot_frames(&mut peer, &i, k, true));
            board.periods = 1;
            app.poll(&mut board);
            peer.hear(&read_setpoint(&core::mem::take(&mut board.ap_tx), 0.0));
            mode = board.frames()[0].output.mode;
            if mode != Mode::Standby {
                break;
            }
        }
        assert_ne!(
            mode,
            Mode::Standby,
            "engaged once the heartbeat says GUIDED"
        );
        // The autopilot goes quiet: its navigation goes stale (counted) and the controller
        // holds, then breaks away.
        let mut last = mode;
        for k in 61..=140u32 {
            board.send(k, input(k, ModeRequest::None));
            board.periods = 1;
            app.poll(&mut board);
            last = board.frames()[0].output.mode;
        }
        assert_eq!(last, Mode::Breakaway, "no navigation from the autopilot");
        let t = board.telemetry(&mut app);
        assert!(t.autopilot.nav_stale > 0, "{:?}", t.autopilot);
        assert!(!board.ap_tx.is_empty(), "setpoints went to the autopilot");
    }

    #[test]
    fn never_panics_and_sends_only_valid_frames_on_random_bytes() {
        // A deterministic pseudo-random byte stream (xorshift), with valid frames mixed in.
        let (mut app, mut board) = lockstep();
        let mut x = 0x2545_F491_4F6C_DD1Du64;
        let mut seq = 0;
        for round in 0..200 {
            for _ in 0..(round % 37) * 7 {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                board
                    .rx
                    .push_back((x >> 24) as u8 & if round % 3 == 0 { 0xFF } else { 0x7F });
            }
            if round % 4 == 0 {
                board.rx.push_back(0);
                seq += 1;
                board.send(
                    seq,
                    ControllerInput {
                        measurement: CameraMeasurement {
                            seq,
                            ..engage_input().measurement
                        },
                        ..engage_input()
                    },
                );
            }
            app.poll(&mut board);
        }
        for f in board.frames() {
            assert!(f.output.command.as_array().iter().all(|c| c.is_finite()));
        }
        assert!(app.link_counters().frames_ok >= 40);
        assert!(app.link_counters().rejected_frames() > 0);
    }
}
