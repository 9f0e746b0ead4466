//! Mode logic of both procedures: the paper's single shot (standby, approach, blind terminal,
//! docked, breakaway) and the refuelling procedure (standby, pre-contact, contact approach,
//! capture, docked, missed approach and retry, breakaway; [`crate::procedure`]).
//!
//! The transition tables (also in `docs/conventions.md`, "Modes"), evaluated once per step in
//! the order listed; the first transition that applies wins. Common to both:
//!
//! | from | condition | to |
//! |---|---|---|
//! | any but standby | `Reset` request | Standby |
//! | engaged (any but standby and breakaway) | `Abort` request | Breakaway(Abort); refuelling capture (terminal): the capture goes on and breaks away at its end (contact, or a no-go) |
//! | engaged | navigation invalid for more than `hold_limit_steps` steps | Breakaway(NavLost) |
//! | engaged | the latest valid navigation's flight condition outside the docking envelope | Breakaway(OutsideDockingEnvelope) |
//! | standby | `Engage` request with the flight condition outside the docking envelope | Standby (refused) |
//! | engaged | attitude-command loop: the autopilot not following setpoints | Breakaway(AutopilotMode) |
//! | standby | `Engage` request, attitude-command loop, the autopilot not following setpoints | Standby (refused) |
//! | pre-contact, approach, terminal, missed approach | camera (refuelling: probe tip) forward speed relative to the tanker > `overspeed_mps` | Breakaway(Overspeed) |
//!
//! The paper's procedure ([`Procedure::Paper`]):
//!
//! | from | condition | to |
//! |---|---|---|
//! | standby | `Engage` request with a valid measurement and valid navigation | Approach |
//! | approach | measurement invalid for more than `hold_limit_steps` steps | Breakaway(MeasurementLost) |
//! | approach | valid measurement with depth <= `terminal_depth_m`, offset > `terminal_max_offset_m` | Breakaway(PredictedMiss) |
//! | approach | valid measurement with depth <= `terminal_depth_m` | Terminal |
//! | terminal | probe contact | Docked |
//! | terminal | dead-reckoned depth < `-terminal_overshoot_m` | Breakaway(PassedDroguePlane) |
//! | terminal | `terminal_timeout_s` elapsed | Breakaway(TerminalTimeout) |
//! | docked | probe contact lost | Breakaway(ContactLost) |
//!
//! The refuelling procedure ([`Procedure::Refuelling`]; the numbers are
//! [`RefuellingConfig`]'s; "estimate" is the drogue estimator's belief, "predicted miss" the
//! gate's radial offset at the drogue plane plus `gate_sigmas` standard deviations):
//!
//! | from | condition | to |
//! |---|---|---|
//! | standby | `Engage` request with a valid measurement and valid navigation | PreContact (attempt 1) |
//! | pre-contact, approach | measurement invalid for more than `hold_limit_steps` steps | Breakaway(MeasurementLost) |
//! | missed approach | measurement invalid for longer than `reacquire_limit_s` | Breakaway(MeasurementLost) |
//! | pre-contact, missed approach | `sortie_budget_s` elapsed since engage | Breakaway(SortieTimeout) |
//! | pre-contact | estimated depth < `station_depth_m - station_overrun_m` | Breakaway(StationOverrun) |
//! | pre-contact | stable (estimate inside the station limits) on `station_dwell_s` worth of consecutive valid frames (lost frames between them neither count nor restart the dwell), and on a valid frame the drogue itself within `station_clear_offset_m` of the tip | Approach |
//! | approach | estimated radial offset > `abort_offset_m` | MissedApproach(OffsetTooLarge), or Breakaway(AttemptsExhausted) on the last attempt |
//! | approach | estimated depth <= the commit depth (`procedure::commit_depth`: where a no-go still stops short of the plane, at least `commit_depth_m`), predicted miss > `gate_radius_m` | MissedApproach(PredictedMiss), or Breakaway(AttemptsExhausted) on the last attempt |
//! | approach | estimated depth <= the commit depth | Terminal (capture) |
//! | terminal | probe contact | Docked |
//! | terminal | estimated depth < `-overshoot_m` | MissedApproach(PassedDroguePlane), or Breakaway(AttemptsExhausted) |
//! | terminal | `capture_timeout_s` elapsed | MissedApproach(CaptureTimeout), or Breakaway(AttemptsExhausted) |
//! | terminal | valid measurement, estimated depth <= `late_gate_depth_m` and predicted miss > the late gate's radius (`late_gate_final_radius_m` at the plane, rising over `late_gate_taper_m` of depth to `late_gate_radius_m`) | MissedApproach(LateNoGo), or Breakaway(AttemptsExhausted) |
//! | terminal | valid measurement, estimated depth <= `late_gate_depth_m` and estimated closing speed < `capture_min_closing_mps` | MissedApproach(ClosingTooSlow), or Breakaway(AttemptsExhausted) |
//! | missed approach | `missed_clear_s` elapsed, valid measurement, estimated depth within `station_depth_tol_m` of the station | PreContact (next attempt) |
//! | docked | probe contact lost | Breakaway(ContactLost) |
//!
//! Breakaway is latched: only `Reset` leaves it. A no-go is never a breakaway, except on the
//! last attempt, where it ends the sortie.
//!
//! Behaviour in the paper's blind phase (not a transition): at terminal entry the lateral and
//! vertical command is fixed to aim at the drogue: `offset × a / depth` (the offset closed
//! in the time the blind phase takes at the closing speed `a`) plus the drogue's estimated
//! velocity (the low-pass filtered rate of the target's offset over the approach's valid
//! frames plus the receiver's own tracked command), saturated to the velocity limits; the
//! closing speed is `a`. The paper holds the last commands instead (docs/paper.md, item 7; we
//! deviate, `docs/conventions.md`, "Modes").
//!
//! Invariant: the machine only changes mode through [`ModeMachine::advance`], and every
//! breakaway carries its reason, every missed approach its [`NoGoReason`].

use serde::{Deserialize, Serialize};

use crate::estimator::DrogueEstimate;
use crate::frames::{TargetEstimate, VelocityRe};
use crate::num::{HypotLimit, clamp_sym, max_to, min_to};
use crate::outer::VelocityLimits;
use crate::procedure::{self, Procedure, RefuellingConfig};

/// Controller mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Mode {
    /// Not in control: commands are the trim values, integrators are held at zero.
    #[default]
    Standby,
    /// Refuelling: hold the station behind the drogue until stable.
    PreContact,
    /// Visual tracking: the outer loop closes on the drogue (refuelling: the contact
    /// approach, at the contact speed).
    Approach,
    /// Final phase. Paper: blind, lateral and vertical commands fixed at entry to aim at the
    /// drogue, closing at the minimum speed, depth dead-reckoned. Refuelling: the capture,
    /// committed after the go/no-go gate, on the estimator (which coasts while the camera is
    /// blind).
    Terminal,
    /// Probe contact: hold position relative to the tanker.
    Docked,
    /// Refuelling: a no-go; back off, descend and return to the station for the next attempt.
    MissedApproach,
    /// Back off and descend; latched until reset.
    Breakaway,
}

/// Operator request carried with each input.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ModeRequest {
    /// Nothing requested.
    #[default]
    None,
    /// Start the approach (from standby).
    Engage,
    /// Break away now.
    Abort,
    /// Return to standby from any mode.
    Reset,
}

/// Why the controller broke away.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BreakawayReason {
    /// Operator abort.
    Abort,
    /// No valid measurement for longer than the hold limit during the approach.
    MeasurementLost,
    /// No valid navigation for longer than the hold limit.
    NavLost,
    /// At the start of the blind phase the drogue was too far off the boresight to capture.
    PredictedMiss,
    /// Dead-reckoned past the drogue plane without contact: a miss.
    PassedDroguePlane,
    /// The blind phase lasted longer than its limit without contact.
    TerminalTimeout,
    /// Contact was lost while docked.
    ContactLost,
    /// Closing on the drogue faster than [`ModeConfig::overspeed_mps`]: a contact at that
    /// speed could damage the probe, the drogue or the hose.
    Overspeed,
    /// Refuelling: a no-go on the last allowed attempt ([`RefuellingConfig::max_attempts`]).
    AttemptsExhausted,
    /// Refuelling: the sortie's time budget ([`RefuellingConfig::sortie_budget_s`]) ran out
    /// before a docking.
    SortieTimeout,
    /// Refuelling: in pre-contact the receiver ran through its station toward the drogue
    /// ([`RefuellingConfig::station_overrun_m`]) without being cleared to close.
    StationOverrun,
    /// The flight condition left the docking envelope (the gain schedule has no design
    /// there; [`crate::schedule::ScheduleError`] says which limit).
    OutsideDockingEnvelope,
    /// Attitude-command inner loop: the autopilot left the mode that follows the flight
    /// computer's setpoints (a pilot's or its own failsafe's mode change): the setpoints no
    /// longer fly the aircraft.
    AutopilotMode,
}

/// Why an approach of the refuelling procedure was abandoned for a missed approach.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NoGoReason {
    /// In the contact approach the drogue moved further off than
    /// [`RefuellingConfig::abort_offset_m`].
    OffsetTooLarge,
    /// At the commit depth the predicted miss exceeded [`RefuellingConfig::gate_radius_m`].
    PredictedMiss,
    /// In the capture, a valid frame's predicted miss exceeded
    /// [`RefuellingConfig::late_gate_radius_m`].
    LateNoGo,
    /// In the capture the estimated depth passed the drogue plane without contact.
    PassedDroguePlane,
    /// The capture lasted longer than [`RefuellingConfig::capture_timeout_s`].
    CaptureTimeout,
    /// In the capture, a valid frame's estimated closing speed was below
    /// [`RefuellingConfig::capture_min_closing_mps`]: the contact would not latch.
    ClosingTooSlow,
}

/// Parameters of the mode logic.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ModeConfig {
    /// Depth at which the camera is considered blind and the terminal phase starts, m.
    pub terminal_depth_m: f32,
    /// Largest radial offset of the drogue at terminal entry that can still be captured, m.
    /// Default 0.45 m, above the 0.3 m capture radius: the blind phase aims at the drogue and
    /// closes the offset (was 0.3 m while it held the commands; with the 1,000-run campaigns,
    /// `docs/conventions.md`, "Modes").
    pub terminal_max_offset_m: f32,
    /// Dead-reckoned depth below minus this value means the probe has passed the drogue, m.
    pub terminal_overshoot_m: f32,
    /// Longest blind phase, s.
    pub terminal_timeout_s: f32,
    /// Consecutive steps an invalid measurement or navigation sample is bridged by holding
    /// the last valid value before breaking away.
    pub hold_limit_steps: u16,
    /// Breakaway: speed aft relative to the tanker, m/s (positive backs off).
    pub breakaway_aft_mps: f32,
    /// Breakaway: speed down relative to the tanker, m/s (positive descends).
    pub breakaway_down_mps: f32,
    /// Breakaway without navigation: throttle reduction from trim, open loop.
    pub breakaway_throttle_cut: f32,
    /// Largest camera (refuelling: probe-tip) forward speed relative to the tanker, from
    /// navigation, in every engaged mode but docked; above it the controller breaks away (`Overspeed`), m/s. Must
    /// exceed `velocity_limits.max_closing_mps`. Default 2.3 m/s: 0.3 m/s above the largest
    /// commanded closing speed (2.0), and below 2.6 m/s (5 kt, the upper end of the
    /// operational contact band; docs/models.md, "Docking check"), so that the breakaway
    /// starts before the speed leaves the band. The closing speed at the drogue plane of the
    /// 10,000-run `level2` campaign is at most 1.28 m/s (docs/scenarios.md).
    pub overspeed_mps: f32,
    /// Breakaway: largest change of the desired velocity, m/s², each axis (the approach's
    /// is `velocity_limits.max_accel_mps2`). A breakaway is the manoeuvre that must not be
    /// gentle: at the approach's 0.5 m/s² the descent takes 2 s to build up.
    pub breakaway_accel_mps2: f32,
    /// Blind phase: largest change of the desired velocity, m/s², each axis (the approach's
    /// is `velocity_limits.max_accel_mps2`). Default 2.0 m/s², as the breakaway's: the
    /// aiming command must be reached early in a blind phase of about 0.9 s (0.7 m at
    /// 0.8 m/s); at 0.5 m/s² a 0.3 m/s change takes 0.6 s. Chosen with the 1,000-run
    /// campaigns (`docs/scenarios.md`, "Monte Carlo campaigns").
    pub terminal_accel_mps2: f32,
    /// Coefficient of the first-order low-pass filter of the target offset's rate (the
    /// drogue's motion relative to the camera), applied once per valid frame in approach:
    /// `rate += k (raw - rate)`, `raw` the offset's change since the last valid frame over
    /// the time since it. Dimensionless, in (0, 1]; default 0.2 (a time constant of about
    /// 5 frames, 0.1 s at 50 Hz: smooths the pixel noise's differences, follows the
    /// drogue's swing of about 1 Hz). Chosen with the 1,000-run campaigns.
    pub drogue_rate_filter: f32,
}

impl Default for ModeConfig {
    fn default() -> Self {
        Self {
            terminal_depth_m: 0.7,
            terminal_max_offset_m: 0.45,
            terminal_overshoot_m: 0.5,
            terminal_timeout_s: 5.0,
            hold_limit_steps: 25,
            breakaway_aft_mps: 2.0,
            breakaway_down_mps: 1.0,
            breakaway_throttle_cut: 0.05,
            overspeed_mps: 2.3,
            breakaway_accel_mps2: 2.0,
            terminal_accel_mps2: 2.0,
            drogue_rate_filter: 0.2,
        }
    }
}

/// What the mode logic sees in one step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModeInputs {
    /// Operator request.
    pub request: ModeRequest,
    /// The target estimate from this step's measurement, when it was valid.
    pub target: Option<TargetEstimate>,
    /// True when this step's navigation sample was valid.
    pub nav_valid: bool,
    /// True when the flight condition of the latest valid navigation sample is inside the
    /// docking envelope (the gain schedule has a design there, [`crate::schedule`]).
    pub in_envelope: bool,
    /// Probe contact discrete.
    pub probe_contact: bool,
    /// The inner loop can fly: the surface loops always, the attitude-command loop while the
    /// autopilot follows its setpoints ([`crate::ControllerInput::autopilot_ready`]).
    pub autopilot_ready: bool,
    /// Camera forward speed relative to the tanker from navigation, m/s.
    pub camera_fwd_mps: f32,
    /// The desired velocity the inner loops were tracking (slewed): the receiver's own
    /// motion relative to the drogue's estimate at terminal entry.
    pub v_des: VelocityRe,
    /// What the refuelling procedure decides with (ignored by the paper's).
    pub refuel: RefuelInputs,
}

/// What the refuelling procedure's transitions see in one step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RefuelInputs {
    /// The drogue estimator's belief after this step (meaningful once engaged).
    pub estimate: DrogueEstimate,
    /// The probe tip's lateral velocity relative to the tanker, `[right, down]`, from
    /// navigation, m/s.
    pub tip_lateral_mps: [f32; 2],
    /// The drogue's RMS lateral speed as the estimator measures it
    /// ([`crate::estimator::DrogueEstimator::drogue_speed_rms_mps`]): above
    /// `rough_air_drogue_speed_mps` the station is judged with the rough-air offset
    /// tolerance, m/s.
    pub drogue_speed_rms_mps: f32,
    /// The gate's predicted radial miss at the drogue plane plus `gate_sigmas` standard
    /// deviations, m (computed in approach and terminal only).
    pub predicted_miss_m: f32,
    /// The estimated closing speed on the drogue: the probe tip's forward velocity (from
    /// navigation) minus the drogue's (estimated), both relative to the tanker, m/s.
    pub closing_mps: f32,
    /// The go/no-go gate's depth for the approach being flown
    /// ([`crate::procedure::commit_depth`] at its closing speed), m.
    pub commit_depth_m: f32,
}

/// State of the blind phase.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TerminalState {
    /// The desired velocity of the blind phase, fixed at entry: lateral and vertical aim at
    /// the drogue (`offset × a / depth` plus its estimated velocity, saturated), forward `a`.
    pub aim: VelocityRe,
    /// Dead-reckoned depth to the drogue plane, m.
    pub depth_m: f32,
    /// Steps spent in the blind phase.
    pub steps: u32,
}

/// The blind-phase limit in whole steps (rounded to the nearest step).
fn timeout_steps(cfg: &ModeConfig, ts_s: f32) -> u32 {
    // `as` saturates; a validated config has a positive, finite timeout.
    libm::roundf(cfg.terminal_timeout_s / ts_s) as u32
}

/// What the transitions need from a [`ModeConfig`], the velocity limits and the step period,
/// derived once: the blind-phase limit in steps, the terminal-entry offset check
/// (`libm::hypotf` of the target's offset against `terminal_max_offset_m`, as [`HypotLimit`]
/// answers it), and what the drogue-rate filter and the aiming command need.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModeLimits {
    /// The procedure whose table applies.
    procedure: Procedure,
    /// The refuelling procedure's limits in steps and squares.
    refuel: RefuelLimits,
    timeout_steps: u32,
    max_offset: HypotLimit,
    /// Closing speed of the blind phase `a` (`min_closing_mps`), m/s.
    closing_mps: f32,
    /// Saturation of the aiming command (`max_lateral_mps`, `max_vertical_mps`), m/s.
    max_right_down_mps: [f32; 2],
    /// `1 / ts_s`, 1/s.
    per_step_s: f32,
    /// [`ModeConfig::drogue_rate_filter`].
    rate_filter: f32,
}

/// What the refuelling procedure's transitions need from its [`RefuellingConfig`], derived
/// once: times in whole steps (rounded), radial limits as squares (compared with the sum of
/// squares, no square root).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RefuelLimits {
    dwell_steps: u32,
    capture_timeout_steps: u32,
    clear_steps: u32,
    reacquire_steps: u32,
    sortie_steps: u32,
    station_offset_sq: f32,
    rough_station_offset_sq: f32,
    station_clear_offset_sq: f32,
    station_drogue_speed_sq: f32,
    station_relative_speed_sq: f32,
    abort_offset_sq: f32,
    /// Growth of the late gate's radius with the depth, m/m.
    late_gate_slope: f32,
}

/// `t_s` in whole steps of `ts_s`, rounded (`as` saturates; validated times are finite).
fn steps(t_s: f32, ts_s: f32) -> u32 {
    libm::roundf(t_s / ts_s) as u32
}

impl RefuelLimits {
    /// Derives the limits of `cfg` at the period `ts_s`.
    pub fn new(cfg: &RefuellingConfig, ts_s: f32) -> Self {
        let sq = |v: f32| v * v;
        Self {
            dwell_steps: steps(cfg.station_dwell_s, ts_s),
            capture_timeout_steps: steps(cfg.capture_timeout_s, ts_s),
            clear_steps: steps(cfg.missed_clear_s, ts_s),
            reacquire_steps: steps(cfg.reacquire_limit_s, ts_s),
            sortie_steps: steps(cfg.sortie_budget_s, ts_s),
            station_offset_sq: sq(cfg.station_offset_tol_m),
            rough_station_offset_sq: sq(cfg.rough_air_station_offset_tol_m),
            station_clear_offset_sq: sq(cfg.station_clear_offset_m),
            station_drogue_speed_sq: sq(cfg.station_drogue_speed_tol_mps),
            station_relative_speed_sq: sq(cfg.station_relative_speed_tol_mps),
            abort_offset_sq: sq(cfg.abort_offset_m),
            late_gate_slope: (cfg.late_gate_radius_m - cfg.late_gate_final_radius_m)
                / cfg.late_gate_taper_m,
        }
    }

    /// The late gate's radius at the estimated depth `depth_m`: `late_gate_final_radius_m`
    /// at the plane (and past it), rising linearly to `late_gate_radius_m` at
    /// `late_gate_taper_m`, m.
    #[inline(always)]
    pub fn late_gate_radius_m(&self, cfg: &RefuellingConfig, depth_m: f32) -> f32 {
        min_to(
            cfg.late_gate_final_radius_m + self.late_gate_slope * max_to(depth_m, 0.0),
            cfg.late_gate_radius_m,
        )
    }
}

impl ModeLimits {
    /// Derives the limits of `cfg` and `vel` at the period `ts_s`, for the paper's procedure.
    pub fn new(cfg: &ModeConfig, vel: &VelocityLimits, ts_s: f32) -> Self {
        Self {
            procedure: Procedure::Paper,
            refuel: RefuelLimits::default(),
            timeout_steps: timeout_steps(cfg, ts_s),
            max_offset: HypotLimit::new(cfg.terminal_max_offset_m),
            closing_mps: vel.min_closing_mps,
            max_right_down_mps: [vel.max_lateral_mps, vel.max_vertical_mps],
            per_step_s: 1.0 / ts_s,
            rate_filter: cfg.drogue_rate_filter,
        }
    }

    /// The limits for `procedure`, with the refuelling procedure's from `refuel`.
    pub fn for_procedure(
        cfg: &ModeConfig,
        vel: &VelocityLimits,
        procedure: Procedure,
        refuel: &RefuellingConfig,
        ts_s: f32,
    ) -> Self {
        Self {
            procedure,
            refuel: RefuelLimits::new(refuel, ts_s),
            ..Self::new(cfg, vel, ts_s)
        }
    }

    /// The procedure whose table applies.
    pub fn procedure(&self) -> Procedure {
        self.procedure
    }

    /// Steps of the missed approach's clearing phase.
    pub fn clear_steps(&self) -> u32 {
        self.refuel.clear_steps
    }
}

/// Low-pass estimate of the rate of the target's offset (right, down) over the approach's
/// valid frames: the drogue's velocity relative to the camera.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct OffsetRate {
    /// Offset of the last valid frame, m.
    last_m: [f32; 2],
    /// The filtered rate, m/s.
    rate_mps: [f32; 2],
}

impl OffsetRate {
    /// Starts from the frame `t` at rest.
    fn start(t: &TargetEstimate) -> Self {
        Self {
            last_m: [t.right_m, t.down_m],
            rate_mps: [0.0; 2],
        }
    }

    /// Takes the valid frame `t`, `missed` invalid steps after the last valid one: the raw
    /// rate is the change over `missed + 1` steps. Two multiply-adds per axis; the one
    /// division only after invalid steps.
    #[inline(always)]
    fn observe(&mut self, t: &TargetEstimate, missed: u16, lim: &ModeLimits) {
        let per_s = if missed == 0 {
            lim.per_step_s
        } else {
            lim.per_step_s / (f32::from(missed) + 1.0)
        };
        let k = lim.rate_filter;
        let now = [t.right_m, t.down_m];
        let [r0, r1] = self.rate_mps;
        let [l0, l1] = self.last_m;
        self.rate_mps = [
            r0 + k * ((now[0] - l0) * per_s - r0),
            r1 + k * ((now[1] - l1) * per_s - r1),
        ];
        self.last_m = now;
    }

    /// The filtered rate `[right, down]`, m/s.
    pub fn rate_mps(&self) -> [f32; 2] {
        self.rate_mps
    }
}

/// The blind phase's desired velocity for the target `t` at entry: lateral and vertical
/// `offset × a / depth + drogue velocity` (the drogue's velocity: the offset's filtered rate
/// plus the receiver's tracked command `v_des`), each saturated to its velocity limit;
/// forward `a`. A valid target's depth is positive; a non-positive one aims at the drogue's
/// velocity alone. Never panics; finite for finite inputs (saturated, NaN to the limit).
#[inline]
pub fn terminal_aim(
    t: &TargetEstimate,
    rate_mps: [f32; 2],
    v_des: &VelocityRe,
    lim: &ModeLimits,
) -> VelocityRe {
    let a = lim.closing_mps;
    // 1 / (blind-phase duration): the one division, once per blind phase.
    let per_s = if t.depth_m > 0.0 { a / t.depth_m } else { 0.0 };
    let [max_right, max_down] = lim.max_right_down_mps;
    VelocityRe {
        x_right_mps: clamp_sym(
            t.right_m * per_s + rate_mps[0] + v_des.x_right_mps,
            max_right,
        ),
        y_down_mps: clamp_sym(t.down_m * per_s + rate_mps[1] + v_des.y_down_mps, max_down),
        z_fwd_mps: a,
    }
}

/// The mode state machine.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ModeMachine {
    mode: Mode,
    reason: Option<BreakawayReason>,
    meas_invalid_steps: u16,
    nav_invalid_steps: u16,
    terminal: TerminalState,
    drogue_rate: OffsetRate,
    /// Refuelling: the approach being flown, 1-based (0 before engage).
    attempt: u8,
    /// Refuelling: why the last approach was abandoned (cleared when the next starts).
    no_go: Option<NoGoReason>,
    /// Refuelling: consecutive steps stable at the station.
    stable_steps: u32,
    /// Refuelling: steps in the current mode.
    mode_steps: u32,
    /// Refuelling: steps since engage.
    sortie_steps: u32,
    /// Refuelling: an `Abort` came during the capture, inside the stopping distance, and
    /// waits for the capture's end (contact or a no-go), where it breaks away.
    abort_pending: bool,
}

impl ModeMachine {
    /// Current mode.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// Why the controller broke away, while in breakaway.
    pub fn breakaway_reason(&self) -> Option<BreakawayReason> {
        self.reason
    }

    /// The blind-phase state (meaningful in [`Mode::Terminal`]).
    pub fn terminal(&self) -> &TerminalState {
        &self.terminal
    }

    /// The drogue-rate estimate (updated in approach, on valid frames).
    pub fn drogue_rate(&self) -> &OffsetRate {
        &self.drogue_rate
    }

    /// True when this step has no valid measurement and the controller flies on without one
    /// (paper: the approach holds the outer loop's last command; refuelling: the estimator
    /// coasts, in every engaged mode but docked). The paper's blind terminal phase does not
    /// use the camera, so it never holds.
    pub fn holding_measurement(&self) -> bool {
        matches!(
            self.mode,
            Mode::Approach | Mode::PreContact | Mode::MissedApproach | Mode::Terminal
        ) && self.meas_invalid_steps > 0
    }

    /// Refuelling: the approach being flown, 1-based (0 in standby).
    pub fn attempt(&self) -> u8 {
        self.attempt
    }

    /// Refuelling: why the last approach was abandoned, until the next one starts.
    pub fn no_go(&self) -> Option<NoGoReason> {
        self.no_go
    }

    /// Steps spent in the current mode (refuelling; the paper's terminal counts its own).
    pub fn mode_steps(&self) -> u32 {
        self.mode_steps
    }

    fn enter(&mut self, mode: Mode) {
        self.mode = mode;
        self.reason = None;
        self.meas_invalid_steps = 0;
        self.mode_steps = 0;
        self.stable_steps = 0;
    }

    /// A no-go: a missed approach, or on the last attempt the end of the sortie (or, with
    /// an abort waiting for the capture's end, the breakaway it asked for).
    fn no_go_to(&mut self, why: NoGoReason, refuel: &RefuellingConfig) {
        self.no_go = Some(why);
        if self.abort_pending {
            self.break_away(BreakawayReason::Abort);
        } else if self.attempt >= refuel.max_attempts {
            self.break_away(BreakawayReason::AttemptsExhausted);
        } else {
            self.enter(Mode::MissedApproach);
        }
    }

    fn break_away(&mut self, why: BreakawayReason) {
        self.enter(Mode::Breakaway);
        self.reason = Some(why);
        self.abort_pending = false;
    }

    /// True while an `Abort` waits for the capture's end (refuelling; [`ModeMachine::advance`]).
    pub fn abort_pending(&self) -> bool {
        self.abort_pending
    }

    /// Advances the machine by one step of `ts_s` seconds, for the paper's procedure (the
    /// unit tests' entry point, compiled for them only; the controller calls
    /// [`ModeMachine::advance`]). Returns true when
    /// `Engage` was requested in standby but refused (no valid measurement or navigation).
    /// `vel`: the velocity limits (the blind phase's closing speed and the saturation of its
    /// aiming command).
    #[cfg(test)]
    pub(crate) fn update(
        &mut self,
        inp: &ModeInputs,
        cfg: &ModeConfig,
        vel: &VelocityLimits,
        ts_s: f32,
    ) -> bool {
        let refuel = RefuellingConfig::default();
        self.advance(inp, cfg, &refuel, ts_s, &ModeLimits::new(cfg, vel, ts_s))
    }

    /// Advances the machine by one step of `ts_s` seconds with the limits derived beforehand
    /// (the controller derives them at construction: [`ModeLimits::for_procedure`]), for the
    /// procedure they name. Returns true when `Engage` was requested in standby but refused.
    #[inline]
    pub fn advance(
        &mut self,
        inp: &ModeInputs,
        cfg: &ModeConfig,
        refuel: &RefuellingConfig,
        ts_s: f32,
        limits: &ModeLimits,
    ) -> bool {
        self.nav_invalid_steps = if inp.nav_valid {
            0
        } else {
            self.nav_invalid_steps.saturating_add(1)
        };
        let engaged = !matches!(self.mode, Mode::Standby | Mode::Breakaway);
        if inp.request == ModeRequest::Reset && self.mode != Mode::Standby {
            self.enter(Mode::Standby);
            self.attempt = 0;
            self.no_go = None;
            self.abort_pending = false;
            return false;
        }
        if engaged && inp.request == ModeRequest::Abort {
            // In the refuelling procedure's capture the receiver is inside its stopping
            // distance (the gate committed it where a no-go could no longer stop short of
            // the plane): backing off now would carry the probe through the basket's rim.
            // The capture goes on, and the abort breaks away at its end: at contact (the
            // disconnect) or at a no-go. In rough air (the drogue's activity above the
            // rough-air switch) the capture itself strikes often, so there the call is
            // deferred only within the forward loop's lag of the plane (`closing *
            // forward_lag_s`: nothing commanded takes effect before the plane); further
            // out the breakaway's turn down and away clears the basket.
            let r = &inp.refuel;
            let within_lag = r.estimate.depth_m < r.closing_mps * refuel.forward_lag_s;
            if limits.procedure == Procedure::Refuelling
                && self.mode == Mode::Terminal
                && (within_lag || !procedure::rough_air(r.drogue_speed_rms_mps, refuel))
            {
                self.abort_pending = true;
            } else {
                self.break_away(BreakawayReason::Abort);
                return false;
            }
        }
        if engaged && self.nav_invalid_steps > cfg.hold_limit_steps {
            self.break_away(BreakawayReason::NavLost);
            return false;
        }
        if !inp.in_envelope {
            if engaged {
                self.break_away(BreakawayReason::OutsideDockingEnvelope);
                return false;
            }
            // In standby an engage is refused; in breakaway the receiver flies on.
            return self.mode == Mode::Standby && inp.request == ModeRequest::Engage;
        }
        if !inp.autopilot_ready {
            if engaged {
                self.break_away(BreakawayReason::AutopilotMode);
                return false;
            }
            return self.mode == Mode::Standby && inp.request == ModeRequest::Engage;
        }
        if matches!(
            self.mode,
            Mode::PreContact | Mode::Approach | Mode::Terminal | Mode::MissedApproach
        ) && inp.camera_fwd_mps > cfg.overspeed_mps
        {
            self.break_away(BreakawayReason::Overspeed);
            return false;
        }
        match limits.procedure {
            Procedure::Paper => self.advance_paper(inp, cfg, ts_s, limits),
            Procedure::Refuelling => self.advance_refuelling(inp, cfg, refuel, &limits.refuel),
        }
    }

    /// The paper's table after the common rows.
    #[inline(always)]
    fn advance_paper(
        &mut self,
        inp: &ModeInputs,
        cfg: &ModeConfig,
        ts_s: f32,
        limits: &ModeLimits,
    ) -> bool {
        match self.mode {
            Mode::Standby => {
                if inp.request == ModeRequest::Engage {
                    match inp.target {
                        Some(t) if inp.nav_valid => {
                            self.enter(Mode::Approach);
                            self.drogue_rate = OffsetRate::start(&t);
                        }
                        _ => return true,
                    }
                }
            }
            Mode::Approach => match inp.target {
                None => {
                    self.meas_invalid_steps = self.meas_invalid_steps.saturating_add(1);
                    if self.meas_invalid_steps > cfg.hold_limit_steps {
                        self.break_away(BreakawayReason::MeasurementLost);
                    }
                }
                Some(t) => {
                    self.drogue_rate
                        .observe(&t, self.meas_invalid_steps, limits);
                    self.meas_invalid_steps = 0;
                    if t.depth_m <= cfg.terminal_depth_m {
                        // t.radial_offset_m() > cfg.terminal_max_offset_m, exactly.
                        if limits.max_offset.exceeded_by(t.right_m, t.down_m) {
                            self.break_away(BreakawayReason::PredictedMiss);
                        } else {
                            self.enter(Mode::Terminal);
                            self.terminal = TerminalState {
                                aim: terminal_aim(
                                    &t,
                                    self.drogue_rate.rate_mps,
                                    &inp.v_des,
                                    limits,
                                ),
                                depth_m: t.depth_m,
                                steps: 0,
                            };
                        }
                    }
                }
            },
            Mode::Terminal => {
                let t = &mut self.terminal;
                t.depth_m -= ts_s * inp.camera_fwd_mps;
                t.steps = t.steps.saturating_add(1);
                if inp.probe_contact {
                    self.enter(Mode::Docked);
                } else if t.depth_m < -cfg.terminal_overshoot_m {
                    self.break_away(BreakawayReason::PassedDroguePlane);
                } else if t.steps > limits.timeout_steps {
                    self.break_away(BreakawayReason::TerminalTimeout);
                }
            }
            Mode::Docked => {
                if !inp.probe_contact {
                    self.break_away(BreakawayReason::ContactLost);
                }
            }
            // Not in the paper's procedure (reached only through a configuration change
            // while engaged, which the controller does not allow): hold.
            Mode::Breakaway | Mode::PreContact | Mode::MissedApproach => {}
        }
        false
    }

    /// The refuelling procedure's table after the common rows.
    #[inline(always)]
    fn advance_refuelling(
        &mut self,
        inp: &ModeInputs,
        cfg: &ModeConfig,
        rc: &RefuellingConfig,
        rl: &RefuelLimits,
    ) -> bool {
        let e = &inp.refuel.estimate;
        let valid = inp.target.is_some();
        let sq = |v: [f32; 2]| v[0] * v[0] + v[1] * v[1];
        if !matches!(self.mode, Mode::Standby | Mode::Breakaway) {
            self.sortie_steps = self.sortie_steps.saturating_add(1);
            self.mode_steps = self.mode_steps.saturating_add(1);
        }
        if matches!(
            self.mode,
            Mode::PreContact | Mode::Approach | Mode::Terminal | Mode::MissedApproach
        ) {
            self.meas_invalid_steps = if valid {
                0
            } else {
                self.meas_invalid_steps.saturating_add(1)
            };
        }
        let lost = self.meas_invalid_steps > cfg.hold_limit_steps;
        let out_of_time = self.sortie_steps > rl.sortie_steps;
        match self.mode {
            Mode::Standby => {
                if inp.request == ModeRequest::Engage {
                    if !(valid && inp.nav_valid) {
                        return true;
                    }
                    self.enter(Mode::PreContact);
                    self.attempt = 1;
                    self.no_go = None;
                    self.sortie_steps = 0;
                }
            }
            Mode::PreContact => {
                if lost {
                    self.break_away(BreakawayReason::MeasurementLost);
                } else if out_of_time {
                    self.break_away(BreakawayReason::SortieTimeout);
                } else if e.depth_m < rc.station_depth_m - rc.station_overrun_m {
                    self.break_away(BreakawayReason::StationOverrun);
                } else {
                    // Judged on valid frames only: a lost frame (held) neither counts toward
                    // the dwell nor restarts it (at 50 % frame loss a dwell that restarted on
                    // every lost frame was never reached).
                    let offset_sq = if procedure::rough_air(inp.refuel.drogue_speed_rms_mps, rc) {
                        rl.rough_station_offset_sq
                    } else {
                        rl.station_offset_sq
                    };
                    let stable = sq(e.mean_offset_m) <= offset_sq
                        && libm::fabsf(e.depth_m - rc.station_depth_m) <= rc.station_depth_tol_m
                        && sq([e.drogue_velocity_mps[0], e.drogue_velocity_mps[1]])
                            <= rl.station_drogue_speed_sq
                        && sq(inp.refuel.tip_lateral_mps) <= rl.station_relative_speed_sq;
                    if valid {
                        self.stable_steps = if stable {
                            self.stable_steps.saturating_add(1)
                        } else {
                            0
                        };
                    }
                    if self.stable_steps >= rl.dwell_steps
                        && valid
                        && sq(e.offset_m) <= rl.station_clear_offset_sq
                    {
                        self.enter(Mode::Approach);
                        self.no_go = None;
                    }
                }
            }
            Mode::Approach => {
                if lost {
                    self.break_away(BreakawayReason::MeasurementLost);
                } else if sq(e.offset_m) > rl.abort_offset_sq {
                    self.no_go_to(NoGoReason::OffsetTooLarge, rc);
                } else if e.depth_m <= inp.refuel.commit_depth_m {
                    if inp.refuel.predicted_miss_m > rc.gate_radius_m {
                        self.no_go_to(NoGoReason::PredictedMiss, rc);
                    } else {
                        self.enter(Mode::Terminal);
                    }
                }
            }
            Mode::Terminal => {
                if inp.probe_contact {
                    self.enter(Mode::Docked);
                } else if e.depth_m < -rc.overshoot_m {
                    self.no_go_to(NoGoReason::PassedDroguePlane, rc);
                } else if self.mode_steps > rl.capture_timeout_steps {
                    self.no_go_to(NoGoReason::CaptureTimeout, rc);
                } else if valid
                    && e.depth_m <= rc.late_gate_depth_m
                    && e.depth_m >= rc.late_gate_min_depth_m
                    && inp.refuel.predicted_miss_m > rl.late_gate_radius_m(rc, e.depth_m)
                {
                    self.no_go_to(NoGoReason::LateNoGo, rc);
                } else if valid
                    && e.depth_m <= rc.late_gate_depth_m
                    && e.depth_m >= rc.late_gate_min_depth_m
                    && inp.refuel.closing_mps < rc.capture_min_closing_mps
                {
                    self.no_go_to(NoGoReason::ClosingTooSlow, rc);
                }
            }
            Mode::MissedApproach => {
                if u32::from(self.meas_invalid_steps) > rl.reacquire_steps {
                    self.break_away(BreakawayReason::MeasurementLost);
                } else if out_of_time {
                    self.break_away(BreakawayReason::SortieTimeout);
                } else if self.mode_steps >= rl.clear_steps
                    && valid
                    && libm::fabsf(e.depth_m - rc.station_depth_m) <= rc.station_depth_tol_m
                {
                    self.enter(Mode::PreContact);
                    self.attempt = self.attempt.saturating_add(1);
                }
            }
            Mode::Docked => {
                if self.abort_pending {
                    self.break_away(BreakawayReason::Abort);
                } else if !inp.probe_contact {
                    self.break_away(BreakawayReason::ContactLost);
                }
            }
            Mode::Breakaway => {}
        }
        false
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;

    const TS: f32 = 0.02;
    /// A depth just inside the default terminal threshold (0.7 m), m.
    const NEAR_M: f32 = 0.6;

    fn vel() -> VelocityLimits {
        crate::ControllerConfig::default().velocity_limits
    }

    fn inputs() -> ModeInputs {
        ModeInputs {
            request: ModeRequest::None,
            target: Some(TargetEstimate {
                right_m: 0.5,
                down_m: 0.0,
                depth_m: 6.0,
            }),
            nav_valid: true,
            in_envelope: true,
            probe_contact: false,
            autopilot_ready: true,
            camera_fwd_mps: 1.0,
            v_des: VelocityRe {
                x_right_mps: 0.1,
                y_down_mps: -0.2,
                z_fwd_mps: 1.0,
            },
            refuel: RefuelInputs::default(),
        }
    }

    fn engaged() -> ModeMachine {
        let mut m = ModeMachine::default();
        assert!(!m.update(
            &ModeInputs {
                request: ModeRequest::Engage,
                ..inputs()
            },
            &ModeConfig::default(),
            &vel(),
            TS
        ));
        assert_eq!(m.mode(), Mode::Approach);
        m
    }

    fn near(offset_m: f32) -> ModeInputs {
        ModeInputs {
            target: Some(TargetEstimate {
                right_m: offset_m,
                down_m: 0.0,
                depth_m: NEAR_M,
            }),
            ..inputs()
        }
    }

    fn terminal() -> ModeMachine {
        let mut m = engaged();
        m.update(&near(0.05), &ModeConfig::default(), &vel(), TS);
        assert_eq!(m.mode(), Mode::Terminal);
        m
    }

    #[test]
    fn engage_needs_valid_measurement_and_navigation() {
        let cfg = ModeConfig::default();
        let mut m = ModeMachine::default();
        assert!(m.update(
            &ModeInputs {
                request: ModeRequest::Engage,
                target: None,
                ..inputs()
            },
            &cfg,
            &vel(),
            TS
        ));
        assert!(m.update(
            &ModeInputs {
                request: ModeRequest::Engage,
                nav_valid: false,
                ..inputs()
            },
            &cfg,
            &vel(),
            TS
        ));
        assert_eq!(m.mode(), Mode::Standby);
        assert!(
            !m.update(&inputs(), &cfg, &vel(), TS),
            "no request, nothing refused"
        );
        assert_eq!(m.mode(), Mode::Standby);
    }

    #[test]
    fn outside_the_docking_envelope_an_engage_is_refused_and_an_engaged_receiver_breaks_away() {
        let (cfg, rc) = (ModeConfig::default(), RefuellingConfig::default());
        let outside = ModeInputs {
            in_envelope: false,
            ..inputs()
        };
        for procedure in [Procedure::Paper, Procedure::Refuelling] {
            let lim = ModeLimits::for_procedure(&cfg, &vel(), procedure, &rc, TS);
            let mut m = ModeMachine::default();
            let engage = ModeInputs {
                request: ModeRequest::Engage,
                ..outside
            };
            assert!(
                m.advance(&engage, &cfg, &rc, TS, &lim),
                "{procedure:?}: refused"
            );
            assert_eq!(m.mode(), Mode::Standby);
            assert!(
                !m.advance(&outside, &cfg, &rc, TS, &lim),
                "no request, nothing refused"
            );
            // Inside, the same request engages.
            let inside = ModeInputs {
                in_envelope: true,
                ..engage
            };
            assert!(!m.advance(&inside, &cfg, &rc, TS, &lim));
            let engaged_mode = m.mode();
            assert_ne!(engaged_mode, Mode::Standby, "{procedure:?}");
            // Leaving the envelope engaged breaks away at once, with the reason named.
            m.advance(&outside, &cfg, &rc, TS, &lim);
            assert_eq!(
                (m.mode(), m.breakaway_reason()),
                (
                    Mode::Breakaway,
                    Some(BreakawayReason::OutsideDockingEnvelope)
                ),
                "{procedure:?} from {engaged_mode:?}"
            );
            // The breakaway is latched: back inside, it stays until a reset.
            m.advance(&inputs(), &cfg, &rc, TS, &lim);
            assert_eq!(m.mode(), Mode::Breakaway);
        }
        // From the capture, too.
        let mut m = terminal();
        m.update(&outside, &cfg, &vel(), TS);
        assert_eq!(
            m.breakaway_reason(),
            Some(BreakawayReason::OutsideDockingEnvelope)
        );
    }

    #[test]
    fn measurement_is_held_for_the_limit_then_breaks_away() {
        let cfg = ModeConfig::default();
        let mut m = engaged();
        let lost = ModeInputs {
            target: None,
            ..inputs()
        };
        for _ in 0..cfg.hold_limit_steps {
            m.update(&lost, &cfg, &vel(), TS);
            assert_eq!(m.mode(), Mode::Approach);
            assert!(m.holding_measurement());
        }
        m.update(&lost, &cfg, &vel(), TS);
        assert_eq!(m.mode(), Mode::Breakaway);
        assert_eq!(m.breakaway_reason(), Some(BreakawayReason::MeasurementLost));
    }

    #[test]
    fn a_valid_frame_resets_the_hold_count() {
        let cfg = ModeConfig::default();
        let mut m = engaged();
        let lost = ModeInputs {
            target: None,
            ..inputs()
        };
        for _ in 0..2 {
            for _ in 0..cfg.hold_limit_steps {
                m.update(&lost, &cfg, &vel(), TS);
            }
            m.update(&inputs(), &cfg, &vel(), TS);
            assert!(!m.holding_measurement());
        }
        assert_eq!(m.mode(), Mode::Approach);
    }

    #[test]
    fn closing_faster_than_the_overspeed_limit_breaks_away_in_approach_and_terminal() {
        let cfg = ModeConfig::default();
        let at = |m: &mut ModeMachine, inp: ModeInputs, fwd: f32| {
            m.update(
                &ModeInputs {
                    camera_fwd_mps: fwd,
                    ..inp
                },
                &cfg,
                &vel(),
                TS,
            );
            m.mode()
        };
        let limit = cfg.overspeed_mps;
        let above = f32::from_bits(limit.to_bits() + 1);
        // At the limit: no breakaway; just above: Overspeed, in approach and in terminal.
        let mut m = engaged();
        assert_eq!(at(&mut m, inputs(), limit), Mode::Approach);
        assert_eq!(at(&mut m, inputs(), above), Mode::Breakaway);
        assert_eq!(m.breakaway_reason(), Some(BreakawayReason::Overspeed));
        let mut m = terminal();
        assert_eq!(at(&mut m, inputs(), limit), Mode::Terminal);
        assert_eq!(at(&mut m, inputs(), above), Mode::Breakaway);
        assert_eq!(m.breakaway_reason(), Some(BreakawayReason::Overspeed));
        // Not checked in standby or while docked (the receiver moves with the drogue).
        let mut m = ModeMachine::default();
        assert_eq!(at(&mut m, inputs(), 10.0), Mode::Standby);
        let mut m = terminal();
        let contact = ModeInputs {
            probe_contact: true,
            autopilot_ready: true,
            ..inputs()
        };
        assert_eq!(at(&mut m, contact, 1.0), Mode::Docked);
        assert_eq!(at(&mut m, contact, 10.0), Mode::Docked);
    }

    #[test]
    fn navigation_loss_breaks_away_after_the_limit() {
        let cfg = ModeConfig::default();
        let mut m = engaged();
        let bad = ModeInputs {
            nav_valid: false,
            ..inputs()
        };
        for _ in 0..cfg.hold_limit_steps {
            m.update(&bad, &cfg, &vel(), TS);
        }
        assert_eq!(m.mode(), Mode::Approach);
        m.update(&bad, &cfg, &vel(), TS);
        assert_eq!(m.breakaway_reason(), Some(BreakawayReason::NavLost));
    }

    /// Engages on `first` with the tracked command `v_des`, then feeds `frames` (None:
    /// invalid) in approach; returns the machine.
    fn fly(
        first: TargetEstimate,
        v_des: VelocityRe,
        frames: &[Option<TargetEstimate>],
    ) -> ModeMachine {
        let cfg = ModeConfig::default();
        let mut m = ModeMachine::default();
        let base = ModeInputs {
            target: Some(first),
            v_des,
            ..inputs()
        };
        m.update(
            &ModeInputs {
                request: ModeRequest::Engage,
                ..base
            },
            &cfg,
            &vel(),
            TS,
        );
        for f in frames {
            m.update(&ModeInputs { target: *f, ..base }, &cfg, &vel(), TS);
        }
        m
    }

    fn at(right_m: f32, down_m: f32, depth_m: f32) -> TargetEstimate {
        TargetEstimate {
            right_m,
            down_m,
            depth_m,
        }
    }

    #[test]
    fn terminal_entry_aims_at_a_stationary_drogue_or_predicts_a_miss() {
        // Drogue at rest relative to the camera (rate 0), no command being tracked: the aim
        // closes the offset in the blind phase's duration, depth / a.
        let (right, down, depth) = (0.2, -0.1, 0.5);
        let a = vel().min_closing_mps;
        let first = at(right, down, 2.0);
        let m = fly(first, VelocityRe::ZERO, &[Some(at(right, down, depth))]);
        assert_eq!(m.mode(), Mode::Terminal);
        assert_eq!(m.drogue_rate().rate_mps(), [0.0, 0.0]);
        let aim = m.terminal().aim;
        assert_eq!(aim.x_right_mps, right * (a / depth));
        assert_eq!(aim.y_down_mps, down * (a / depth));
        assert!((aim.x_right_mps - 0.32).abs() < 1e-6 && (aim.y_down_mps + 0.16).abs() < 1e-6);
        assert_eq!(aim.z_fwd_mps, a);
        assert_eq!(m.terminal().depth_m, depth);
        // On the limit (0.45 m) still enters; just outside it predicts a miss.
        let cfg = ModeConfig::default();
        assert_eq!(cfg.terminal_max_offset_m, 0.45);
        let m = fly(first, VelocityRe::ZERO, &[Some(at(0.45, 0.0, NEAR_M))]);
        assert_eq!(m.mode(), Mode::Terminal);
        let mut miss = engaged();
        miss.update(&near(0.46), &cfg, &vel(), TS);
        assert_eq!(
            miss.breakaway_reason(),
            Some(BreakawayReason::PredictedMiss)
        );
    }

    #[test]
    fn terminal_entry_adds_the_drogues_estimated_velocity() {
        // The offset grows 0.5 m/s to the right and 0.25 m/s up while the receiver tracks
        // 0.1 m/s right and 0.2 m/s up: the drogue moves 0.6 m/s right, 0.45 m/s up.
        let v_des = VelocityRe {
            x_right_mps: 0.1,
            y_down_mps: -0.2,
            z_fwd_mps: 1.0,
        };
        let (r0, d0) = (0.0, 0.0);
        let n = 10;
        let frame = |k: i32, depth: f32| at(r0 + 0.01 * k as f32, d0 - 0.005 * k as f32, depth);
        let frames: std::vec::Vec<_> = (1..=n)
            .map(|k| Some(frame(k, if k == n { NEAR_M } else { 2.0 })))
            .collect();
        let m = fly(frame(0, 2.0), v_des, &frames);
        assert_eq!(m.mode(), Mode::Terminal);
        // First-order filter of a constant raw rate from zero: rate (1 - (1 - k)^n).
        let gain = 1.0 - 0.8f32.powi(n);
        let rate = m.drogue_rate().rate_mps();
        assert!((rate[0] - 0.5 * gain).abs() < 1e-4, "{rate:?}");
        assert!((rate[1] + 0.25 * gain).abs() < 1e-4, "{rate:?}");
        let a = vel().min_closing_mps;
        let t = frame(n, NEAR_M);
        let aim = m.terminal().aim;
        assert_eq!(aim.x_right_mps, t.right_m * (a / NEAR_M) + rate[0] + 0.1);
        assert_eq!(aim.y_down_mps, t.down_m * (a / NEAR_M) + rate[1] - 0.2);
        // Not the held command any more: 0.133 + 0.446 + 0.1 m/s right.
        assert!((aim.x_right_mps - 0.679).abs() < 1e-3, "{aim:?}");
    }

    #[test]
    fn the_aim_is_saturated_to_the_velocity_limits() {
        let lim = vel();
        // 0.3 m right and 0.3 m up of a 0.1 m deep drogue: 2.4 and -2.4 m/s before the limits.
        let m = fly(
            at(0.3, -0.3, 2.0),
            VelocityRe::ZERO,
            &[Some(at(0.3, -0.3, 0.1))],
        );
        assert_eq!(m.mode(), Mode::Terminal);
        let aim = m.terminal().aim;
        assert_eq!(aim.x_right_mps, lim.max_lateral_mps);
        assert_eq!(aim.y_down_mps, -lim.max_vertical_mps);
        // And through the drogue's velocity: a fast-moving offset plus the tracked command.
        let v_des = VelocityRe {
            x_right_mps: -1.9,
            y_down_mps: 1.9,
            z_fwd_mps: 1.0,
        };
        let m = fly(at(0.0, 0.0, 2.0), v_des, &[Some(at(-0.2, 0.2, NEAR_M))]);
        let aim = m.terminal().aim;
        assert_eq!(aim.x_right_mps, -lim.max_lateral_mps);
        assert_eq!(aim.y_down_mps, lim.max_vertical_mps);
        // A non-positive depth (never valid) aims at the drogue's velocity alone.
        let t = at(0.1, 0.1, 0.0);
        let aim = terminal_aim(
            &t,
            [0.3, -0.2],
            &VelocityRe::ZERO,
            &ModeLimits::new(&ModeConfig::default(), &lim, TS),
        );
        assert_eq!((aim.x_right_mps, aim.y_down_mps), (0.3, -0.2));
    }

    #[test]
    fn the_rate_filter_holds_over_invalid_frames_and_scales_by_the_steps_since_the_last() {
        // One valid frame 0.01 m right: rate 0.2 × 0.5 m/s.
        let first = at(0.0, 0.0, 3.0);
        let m = fly(first, VelocityRe::ZERO, &[Some(at(0.01, 0.0, 3.0))]);
        let r1 = m.drogue_rate().rate_mps();
        assert!((r1[0] - 0.1).abs() < 1e-6 && r1[1] == 0.0, "{r1:?}");
        // Then 4 invalid frames: the estimate is held.
        let mut frames = std::vec![Some(at(0.01, 0.0, 3.0))];
        frames.extend([None; 4]);
        let m = fly(first, VelocityRe::ZERO, &frames);
        assert_eq!(m.drogue_rate().rate_mps(), r1);
        assert!(m.holding_measurement());
        // A valid frame 0.05 m further right, 5 steps after the last: raw 0.05 / 0.1 s =
        // 0.5 m/s (not 0.05 / 0.02 s = 2.5 m/s), filtered: 0.1 + 0.2 (0.5 - 0.1) = 0.18.
        frames.push(Some(at(0.06, 0.0, 3.0)));
        let m = fly(first, VelocityRe::ZERO, &frames);
        let r = m.drogue_rate().rate_mps();
        assert!((r[0] - 0.18).abs() < 1e-5, "{r:?}");
        assert_eq!(m.mode(), Mode::Approach);
        // Every consecutive valid frame is one step apart again.
        frames.push(Some(at(0.07, 0.0, 3.0)));
        let m = fly(first, VelocityRe::ZERO, &frames);
        let r = m.drogue_rate().rate_mps();
        assert!((r[0] - (0.18 + 0.2 * (0.5 - 0.18))).abs() < 1e-4, "{r:?}");
    }

    #[test]
    fn terminal_docks_on_contact() {
        let mut m = terminal();
        m.update(
            &ModeInputs {
                probe_contact: true,
                autopilot_ready: true,
                target: None,
                ..inputs()
            },
            &ModeConfig::default(),
            &vel(),
            TS,
        );
        assert_eq!(m.mode(), Mode::Docked);
    }

    #[test]
    fn terminal_dead_reckons_past_the_plane_into_a_miss() {
        let cfg = ModeConfig::default();
        let mut m = terminal();
        // 0.6 m + 0.5 m overshoot at 0.8 m/s: 1.375 s, i.e. past the limit on step 69.
        let blind = ModeInputs {
            target: None,
            camera_fwd_mps: 0.8,
            ..inputs()
        };
        for _ in 0..68 {
            m.update(&blind, &cfg, &vel(), TS);
            assert_eq!(m.mode(), Mode::Terminal, "depth {}", m.terminal().depth_m);
        }
        m.update(&blind, &cfg, &vel(), TS);
        assert_eq!(
            m.breakaway_reason(),
            Some(BreakawayReason::PassedDroguePlane)
        );
    }

    #[test]
    fn terminal_times_out_when_not_closing() {
        let cfg = ModeConfig::default();
        let mut m = terminal();
        let stalled = ModeInputs {
            target: None,
            camera_fwd_mps: 0.0,
            ..inputs()
        };
        let steps = (cfg.terminal_timeout_s / TS) as usize;
        for _ in 0..steps {
            m.update(&stalled, &cfg, &vel(), TS);
        }
        assert_eq!(m.mode(), Mode::Terminal);
        m.update(&stalled, &cfg, &vel(), TS);
        assert_eq!(m.breakaway_reason(), Some(BreakawayReason::TerminalTimeout));
    }

    #[test]
    fn docked_breaks_away_when_contact_is_lost() {
        let cfg = ModeConfig::default();
        let mut m = terminal();
        m.update(
            &ModeInputs {
                probe_contact: true,
                autopilot_ready: true,
                ..inputs()
            },
            &cfg,
            &vel(),
            TS,
        );
        m.update(
            &ModeInputs {
                probe_contact: true,
                autopilot_ready: true,
                ..inputs()
            },
            &cfg,
            &vel(),
            TS,
        );
        assert_eq!(m.mode(), Mode::Docked);
        m.update(&inputs(), &cfg, &vel(), TS);
        assert_eq!(m.breakaway_reason(), Some(BreakawayReason::ContactLost));
    }

    #[test]
    fn abort_from_every_engaged_mode_and_breakaway_is_latched_until_reset() {
        let cfg = ModeConfig::default();
        let abort = ModeInputs {
            request: ModeRequest::Abort,
            ..inputs()
        };
        for mut m in [engaged(), terminal()] {
            m.update(&abort, &cfg, &vel(), TS);
            assert_eq!(m.breakaway_reason(), Some(BreakawayReason::Abort));
            for req in [ModeRequest::None, ModeRequest::Engage, ModeRequest::Abort] {
                m.update(
                    &ModeInputs {
                        request: req,
                        probe_contact: true,
                        autopilot_ready: true,
                        ..near(0.0)
                    },
                    &cfg,
                    &vel(),
                    TS,
                );
                assert_eq!(m.mode(), Mode::Breakaway);
            }
            m.update(
                &ModeInputs {
                    request: ModeRequest::Reset,
                    ..inputs()
                },
                &cfg,
                &vel(),
                TS,
            );
            assert_eq!(m.mode(), Mode::Standby);
            assert_eq!(m.breakaway_reason(), None);
        }
    }

    #[test]
    fn abort_in_standby_does_nothing() {
        let mut m = ModeMachine::default();
        m.update(
            &ModeInputs {
                request: ModeRequest::Abort,
                ..inputs()
            },
            &ModeConfig::default(),
            &vel(),
            TS,
        );
        assert_eq!(m.mode(), Mode::Standby);
    }

    /// The refuelling procedure's inputs for a drogue `offset_m` right of the tip at
    /// `depth_m`, predicted to be missed by `predicted_miss_m`, with a valid frame.
    fn refuel_inputs(offset_m: f32, depth_m: f32, predicted_miss_m: f32) -> ModeInputs {
        ModeInputs {
            refuel: RefuelInputs {
                estimate: DrogueEstimate {
                    offset_m: [offset_m, 0.0],
                    mean_offset_m: [offset_m, 0.0],
                    drogue_velocity_mps: [0.0; 3],
                    depth_m,
                },
                tip_lateral_mps: [0.0; 2],
                drogue_speed_rms_mps: 0.0,
                predicted_miss_m,
                closing_mps: 1.0,
                commit_depth_m: RefuellingConfig::default().commit_depth_m,
            },
            ..inputs()
        }
    }

    /// A refuelling machine flown through engage and the station's dwell into the contact
    /// approach, with its configuration and limits.
    fn refuelling_approach() -> (ModeMachine, RefuellingConfig, ModeLimits) {
        let (cfg, rc) = (ModeConfig::default(), RefuellingConfig::default());
        let lim = ModeLimits::for_procedure(&cfg, &vel(), Procedure::Refuelling, &rc, TS);
        let mut m = ModeMachine::default();
        let go = |m: &mut ModeMachine, inp: ModeInputs| m.advance(&inp, &cfg, &rc, TS, &lim);
        let station = refuel_inputs(0.0, rc.station_depth_m, f32::INFINITY);
        go(
            &mut m,
            ModeInputs {
                request: ModeRequest::Engage,
                ..station
            },
        );
        assert_eq!(m.mode(), Mode::PreContact);
        for _ in 0..=steps(rc.station_dwell_s, TS) {
            go(&mut m, station);
        }
        assert_eq!(m.mode(), Mode::Approach);
        (m, rc, lim)
    }

    /// A refuelling machine flown on from [`refuelling_approach`] through the commit gate
    /// into the capture (terminal).
    fn refuelling_capture() -> (ModeMachine, RefuellingConfig, ModeLimits) {
        let (mut m, rc, lim) = refuelling_approach();
        m.advance(
            &refuel_inputs(0.0, rc.commit_depth_m, 0.0),
            &ModeConfig::default(),
            &rc,
            TS,
            &lim,
        );
        assert_eq!(m.mode(), Mode::Terminal);
        (m, rc, lim)
    }

    #[test]
    fn the_approach_is_cleared_only_with_the_drogue_itself_near_the_tip() {
        // Stable at the station on the drogue's mean position, the drogue itself half a
        // swing away: the dwell completes, the approach waits; it starts on the first valid
        // frame with the drogue within the clearance (inclusive), not on an invalid one.
        let (cfg, rc) = (ModeConfig::default(), RefuellingConfig::default());
        let lim = ModeLimits::for_procedure(&cfg, &vel(), Procedure::Refuelling, &rc, TS);
        let mut m = ModeMachine::default();
        let go = |m: &mut ModeMachine, inp: &ModeInputs| m.advance(inp, &cfg, &rc, TS, &lim);
        let swung = |offset_m: f32| {
            let mut inp = refuel_inputs(0.0, rc.station_depth_m, f32::INFINITY);
            inp.refuel.estimate.offset_m = [0.0, offset_m];
            inp
        };
        let away = swung(above(rc.station_clear_offset_m));
        go(
            &mut m,
            &ModeInputs {
                request: ModeRequest::Engage,
                ..away
            },
        );
        for _ in 0..=2 * steps(rc.station_dwell_s, TS) {
            go(&mut m, &away);
            assert_eq!(m.mode(), Mode::PreContact);
        }
        let near = swung(rc.station_clear_offset_m);
        go(
            &mut m,
            &ModeInputs {
                target: None,
                ..near
            },
        );
        assert_eq!(
            m.mode(),
            Mode::PreContact,
            "an invalid frame does not clear"
        );
        go(&mut m, &near);
        assert_eq!(m.mode(), Mode::Approach);
    }

    #[test]
    fn rough_air_judges_the_station_with_its_own_offset_tolerance() {
        // The drogue's mean position between the two tolerances: in calm air (its RMS
        // speed at the rough-air threshold, inclusive) the dwell never completes; above
        // the threshold it does, and the approach starts. Beyond the rough-air tolerance
        // it does not either way.
        let (cfg, rc) = (ModeConfig::default(), RefuellingConfig::default());
        assert!(rc.station_offset_tol_m < rc.rough_air_station_offset_tol_m);
        let lim = ModeLimits::for_procedure(&cfg, &vel(), Procedure::Refuelling, &rc, TS);
        let fly = |mean_m: f32, rms_mps: f32| {
            let mut m = ModeMachine::default();
            let mut inp = refuel_inputs(0.0, rc.station_depth_m, f32::INFINITY);
            inp.refuel.estimate.mean_offset_m = [0.0, mean_m];
            inp.refuel.drogue_speed_rms_mps = rms_mps;
            let engage = ModeInputs {
                request: ModeRequest::Engage,
                ..inp
            };
            m.advance(&engage, &cfg, &rc, TS, &lim);
            for _ in 0..=2 * steps(rc.station_dwell_s, TS) {
                m.advance(&inp, &cfg, &rc, TS, &lim);
            }
            m.mode()
        };
        let between = above(rc.station_offset_tol_m);
        let calm = rc.rough_air_drogue_speed_mps;
        let rough = above(calm);
        assert_eq!(fly(rc.station_offset_tol_m, calm), Mode::Approach);
        assert_eq!(fly(between, calm), Mode::PreContact);
        assert_eq!(fly(between, rough), Mode::Approach);
        assert_eq!(
            fly(rc.rough_air_station_offset_tol_m, rough),
            Mode::Approach
        );
        assert_eq!(
            fly(above(rc.rough_air_station_offset_tol_m), rough),
            Mode::PreContact
        );
    }

    /// The tanker's breakaway call in the capture (inside the stopping distance) does not
    /// reverse the receiver into the basket's rim: the capture goes on, and the call breaks
    /// away at its end, a one-shot request included: at contact (the disconnect) and at a
    /// no-go. Before the capture (the approach) it breaks away at once.
    #[test]
    fn an_abort_in_the_capture_waits_for_its_end() {
        let cfg = ModeConfig::default();
        let abort = |depth_m: f32| ModeInputs {
            request: ModeRequest::Abort,
            ..refuel_inputs(0.0, depth_m, 0.0)
        };
        // Contact after a one-shot call.
        let (mut m, rc, lim) = refuelling_capture();
        m.advance(&abort(0.5), &cfg, &rc, TS, &lim);
        assert_eq!(m.mode(), Mode::Terminal);
        assert!(m.abort_pending());
        m.advance(&refuel_inputs(0.3, 0.3, 0.0), &cfg, &rc, TS, &lim);
        assert_eq!(m.mode(), Mode::Terminal, "the capture goes on");
        let contact = ModeInputs {
            probe_contact: true,
            ..refuel_inputs(0.0, 0.0, 0.0)
        };
        m.advance(&contact, &cfg, &rc, TS, &lim);
        assert_eq!(m.mode(), Mode::Docked);
        m.advance(&contact, &cfg, &rc, TS, &lim);
        assert_eq!(
            (m.mode(), m.breakaway_reason()),
            (Mode::Breakaway, Some(BreakawayReason::Abort))
        );
        assert!(!m.abort_pending());
        // A no-go after the call (past the plane): the breakaway, not a missed approach.
        let (mut m, rc, lim) = refuelling_capture();
        m.advance(&abort(0.5), &cfg, &rc, TS, &lim);
        m.advance(
            &refuel_inputs(0.0, -rc.overshoot_m - 0.01, 0.0),
            &cfg,
            &rc,
            TS,
            &lim,
        );
        assert_eq!(
            (m.mode(), m.breakaway_reason(), m.no_go()),
            (
                Mode::Breakaway,
                Some(BreakawayReason::Abort),
                Some(NoGoReason::PassedDroguePlane)
            )
        );
        // In the approach (before the commit) the call breaks away at once.
        let (mut m, rc, lim) = refuelling_approach();
        m.advance(&abort(3.0), &cfg, &rc, TS, &lim);
        assert_eq!(
            (m.mode(), m.breakaway_reason()),
            (Mode::Breakaway, Some(BreakawayReason::Abort))
        );
        // In rough air the capture defers the call only within the forward loop's lag of the
        // plane (closing at 1 m/s: 1.7 m); further out it breaks away at once.
        let rough_abort = |depth_m: f32, rms: f32| {
            let mut inp = abort(depth_m);
            inp.refuel.drogue_speed_rms_mps = rms;
            inp
        };
        let lag_m = rc.forward_lag_s; // at 1 m/s
        let rough = rc.rough_air_drogue_speed_mps + 0.1;
        for (depth_m, rms, deferred) in [
            (lag_m + 0.1, rough, false),
            (lag_m - 0.1, rough, true),
            (lag_m + 0.1, rc.rough_air_drogue_speed_mps, true),
        ] {
            let (mut m, rc, lim) = refuelling_capture();
            m.advance(&rough_abort(depth_m, rms), &cfg, &rc, TS, &lim);
            assert_eq!(
                (m.mode() == Mode::Terminal, m.abort_pending()),
                (deferred, deferred),
                "{depth_m} m, {rms} m/s"
            );
        }
    }

    #[test]
    fn a_capture_closing_too_slowly_is_a_no_go_on_a_valid_frame() {
        // At the band's edge (inclusive) the capture goes on; just below it, a valid frame
        // turns it away; an invalid frame decides nothing.
        let (mut m, rc, lim) = refuelling_capture();
        let cfg = ModeConfig::default();
        let closing = |v: f32, valid: bool| {
            let mut inp = refuel_inputs(0.0, rc.late_gate_min_depth_m, 0.0);
            inp.refuel.closing_mps = v;
            if !valid {
                inp.target = None;
            }
            inp
        };
        let slow = f32::from_bits(rc.capture_min_closing_mps.to_bits() - 1);
        m.advance(
            &closing(rc.capture_min_closing_mps, true),
            &cfg,
            &rc,
            TS,
            &lim,
        );
        assert_eq!(m.mode(), Mode::Terminal);
        m.advance(&closing(slow, false), &cfg, &rc, TS, &lim);
        assert_eq!(m.mode(), Mode::Terminal);
        m.advance(&closing(slow, true), &cfg, &rc, TS, &lim);
        assert_eq!(
            (m.mode(), m.no_go()),
            (Mode::MissedApproach, Some(NoGoReason::ClosingTooSlow))
        );
    }

    #[test]
    fn a_capture_that_loses_its_frames_times_out() {
        // Frames lost in the capture decide nothing until `capture_timeout_s` has passed.
        let (mut m, rc, lim) = refuelling_capture();
        let cfg = ModeConfig::default();
        let lost = ModeInputs {
            target: None,
            ..refuel_inputs(0.0, 0.5, 0.0)
        };
        for _ in 0..steps(rc.capture_timeout_s, TS) {
            m.advance(&lost, &cfg, &rc, TS, &lim);
            assert_eq!(m.mode(), Mode::Terminal);
        }
        m.advance(&lost, &cfg, &rc, TS, &lim);
        assert_eq!(
            (m.mode(), m.no_go()),
            (Mode::MissedApproach, Some(NoGoReason::CaptureTimeout))
        );
    }

    /// The next float above a positive `x`.
    fn above(x: f32) -> f32 {
        f32::from_bits(x.to_bits() + 1)
    }

    #[test]
    fn each_refuelling_limit_is_inclusive_and_the_next_float_beyond_it_decides() {
        // The table's conditions are strict: "offset > abort_offset_m", "predicted miss >
        // gate_radius_m", "depth < -overshoot_m", "predicted miss > the late gate's radius".
        let cfg = ModeConfig::default();
        let run = |m: &mut ModeMachine, rc: &RefuellingConfig, lim: &ModeLimits, i: ModeInputs| {
            m.advance(&i, &cfg, rc, TS, lim);
            (m.mode(), m.no_go())
        };
        // Contact approach, 2 m out: the offset on the abort limit flies on; beyond it, a no-go.
        let (mut m, rc, lim) = refuelling_approach();
        let on = refuel_inputs(rc.abort_offset_m, 2.0, 0.0);
        assert_eq!(run(&mut m, &rc, &lim, on), (Mode::Approach, None));
        let beyond = refuel_inputs(above(rc.abort_offset_m), 2.0, 0.0);
        assert_eq!(
            run(&mut m, &rc, &lim, beyond),
            (Mode::MissedApproach, Some(NoGoReason::OffsetTooLarge))
        );
        // At the commit depth: a predicted miss on the gate's radius is a go.
        let (mut m, rc, lim) = refuelling_approach();
        let on = refuel_inputs(0.0, rc.commit_depth_m, rc.gate_radius_m);
        assert_eq!(run(&mut m, &rc, &lim, on), (Mode::Terminal, None));
        let (mut m, rc, lim) = refuelling_approach();
        let beyond = refuel_inputs(0.0, rc.commit_depth_m, above(rc.gate_radius_m));
        assert_eq!(
            run(&mut m, &rc, &lim, beyond),
            (Mode::MissedApproach, Some(NoGoReason::PredictedMiss))
        );
        // In the capture, on the plane (the late gate judging to the plane): the late gate's
        // radius is the final one exactly.
        let (mut m, rc, lim) = refuelling_capture();
        let rc = RefuellingConfig {
            late_gate_min_depth_m: 0.0,
            ..rc
        };
        let on = refuel_inputs(0.0, 0.0, rc.late_gate_final_radius_m);
        assert_eq!(run(&mut m, &rc, &lim, on), (Mode::Terminal, None));
        let beyond = refuel_inputs(0.0, 0.0, above(rc.late_gate_final_radius_m));
        assert_eq!(
            run(&mut m, &rc, &lim, beyond),
            (Mode::MissedApproach, Some(NoGoReason::LateNoGo))
        );
        // Past the plane by the overshoot exactly: still the capture; a float further, a miss.
        let (mut m, rc, lim) = refuelling_capture();
        let on = refuel_inputs(0.0, -rc.overshoot_m, 0.0);
        assert_eq!(run(&mut m, &rc, &lim, on), (Mode::Terminal, None));
        let beyond = refuel_inputs(0.0, -above(rc.overshoot_m), 0.0);
        assert_eq!(
            run(&mut m, &rc, &lim, beyond),
            (Mode::MissedApproach, Some(NoGoReason::PassedDroguePlane))
        );
    }

    #[test]
    fn mode_steps_counts_the_steps_in_the_current_mode() {
        // Engaged at the station but not stable (0.5 m off): the machine stays pre-contact and
        // counts; the approach restarts the count.
        let (cfg, rc) = (ModeConfig::default(), RefuellingConfig::default());
        let lim = ModeLimits::for_procedure(&cfg, &vel(), Procedure::Refuelling, &rc, TS);
        let mut m = ModeMachine::default();
        let off = refuel_inputs(0.5, rc.station_depth_m, 0.0);
        let engage = ModeInputs {
            request: ModeRequest::Engage,
            ..off
        };
        m.advance(&engage, &cfg, &rc, TS, &lim);
        assert_eq!((m.mode(), m.mode_steps()), (Mode::PreContact, 0));
        for k in 1..=7 {
            m.advance(&off, &cfg, &rc, TS, &lim);
            assert_eq!((m.mode(), m.mode_steps()), (Mode::PreContact, k));
        }
        let (mut m, rc, lim) = refuelling_approach();
        // The helper flies dwell + 1 stable steps after engage: the approach is entered on the
        // dwell's last step and has run one.
        assert_eq!(m.mode_steps(), 1);
        m.advance(&refuel_inputs(0.0, 2.0, 0.0), &cfg, &rc, TS, &lim);
        m.advance(&refuel_inputs(0.0, 2.0, 0.0), &cfg, &rc, TS, &lim);
        assert_eq!((m.mode(), m.mode_steps()), (Mode::Approach, 3));
    }

    #[test]
    fn the_paper_blind_phase_passes_the_plane_strictly_beyond_the_overshoot() {
        // Steps of 1/32 s at 2 m/s dead-reckon 1/16 m each, exactly: from 0.5 m the depth is
        // -0.5 m (minus the overshoot) after 16 steps, still terminal; -0.5625 after 17, a miss.
        let cfg = ModeConfig::default();
        assert_eq!(cfg.terminal_overshoot_m, 0.5);
        let ts = 1.0 / 32.0;
        let mut m = engaged();
        m.update(
            &ModeInputs {
                target: Some(at(0.0, 0.0, 0.5)),
                ..inputs()
            },
            &cfg,
            &vel(),
            ts,
        );
        assert_eq!(m.mode(), Mode::Terminal);
        let blind = ModeInputs {
            target: None,
            camera_fwd_mps: 2.0,
            ..inputs()
        };
        for _ in 0..16 {
            m.update(&blind, &cfg, &vel(), ts);
        }
        assert_eq!(m.terminal().depth_m, -0.5);
        assert_eq!(m.mode(), Mode::Terminal);
        m.update(&blind, &cfg, &vel(), ts);
        assert_eq!(
            m.breakaway_reason(),
            Some(BreakawayReason::PassedDroguePlane)
        );
    }

    #[test]
    fn the_limits_name_their_procedure_and_count_the_clearing_phase_in_steps() {
        let (cfg, vel) = (ModeConfig::default(), vel());
        let rc = RefuellingConfig {
            missed_clear_s: 1.234,
            ..RefuellingConfig::default()
        };
        for procedure in [Procedure::Paper, Procedure::Refuelling] {
            let lim = ModeLimits::for_procedure(&cfg, &vel, procedure, &rc, TS);
            assert_eq!(lim.procedure(), procedure);
            // 1.234 s at 50 Hz: 61.7 steps, rounded to 62 (not truncated to 61).
            assert_eq!(lim.clear_steps(), 62);
        }
        assert_eq!(
            ModeLimits::new(&cfg, &vel, TS).procedure(),
            Procedure::Paper
        );
    }

    #[test]
    fn the_late_gates_radius_tapers_from_the_late_radius_to_the_final_one_at_the_plane() {
        let rc = RefuellingConfig::default();
        let rl = RefuelLimits::new(&rc, TS);
        let r = |d: f32| rl.late_gate_radius_m(&rc, d);
        assert_eq!(r(0.0), rc.late_gate_final_radius_m);
        assert_eq!(r(-0.2), rc.late_gate_final_radius_m, "past the plane");
        assert_eq!(r(rc.late_gate_taper_m), rc.late_gate_radius_m);
        assert_eq!(r(2.0 * rc.late_gate_taper_m), rc.late_gate_radius_m);
        let mid = 0.5 * (rc.late_gate_radius_m + rc.late_gate_final_radius_m);
        assert!((r(0.5 * rc.late_gate_taper_m) - mid).abs() < 1e-6, "linear");
        // The late no-go cannot stop short of the plane: it turns away only from a miss
        // predicted outside the radius within which a crossing strikes the basket (the
        // canopy's 0.305 m plus the probe head's 0.05 m), and leaves nearer ones to the
        // capture.
        assert!(
            rc.late_gate_final_radius_m > 0.305 + 0.05,
            "outside the basket's strike radius"
        );
    }

    #[test]
    fn a_predicted_miss_the_late_gate_passes_far_out_is_a_late_no_go_close_in() {
        // Between the final and the late radius: a go at the taper depth, a no-go close in
        // (the late gate judging to the plane).
        let (mut m, rc, lim) = refuelling_capture();
        let rc = RefuellingConfig {
            late_gate_min_depth_m: 0.0,
            ..rc
        };
        let cfg = ModeConfig::default();
        let p = 0.5 * (rc.late_gate_radius_m + rc.late_gate_final_radius_m) + 0.01;
        m.advance(
            &refuel_inputs(0.1, rc.late_gate_taper_m, p),
            &cfg,
            &rc,
            TS,
            &lim,
        );
        assert_eq!(
            m.mode(),
            Mode::Terminal,
            "far out the capture can still correct it"
        );
        m.advance(
            &refuel_inputs(0.1, 0.45 * rc.late_gate_taper_m, p),
            &cfg,
            &rc,
            TS,
            &lim,
        );
        assert_eq!(m.mode(), Mode::MissedApproach);
        assert_eq!(m.no_go(), Some(NoGoReason::LateNoGo));
        // Without a valid frame the late gate does not judge.
        let (mut m, rc, lim) = refuelling_capture();
        let blind = ModeInputs {
            target: None,
            ..refuel_inputs(0.1, 0.05, p)
        };
        m.advance(&blind, &cfg, &rc, TS, &lim);
        assert_eq!(m.mode(), Mode::Terminal);
    }

    #[test]
    fn the_capture_turns_away_only_inside_its_late_gates_window() {
        // A predicted miss far beyond any radius, on valid frames, at depths just outside,
        // on and inside the window's edges: judged only from `late_gate_depth_m` down to
        // `late_gate_min_depth_m`, both inclusive; closer in the capture goes on.
        let rc = RefuellingConfig::default();
        let cfg = ModeConfig::default();
        for (depth, turns) in [
            (above(rc.late_gate_depth_m), false),
            (rc.late_gate_depth_m, true),
            (rc.late_gate_min_depth_m, true),
            (
                f32::from_bits(rc.late_gate_min_depth_m.to_bits() - 1),
                false,
            ),
            (0.0, false),
        ] {
            let (mut m, rc, lim) = refuelling_capture();
            m.advance(&refuel_inputs(0.0, depth, 10.0), &cfg, &rc, TS, &lim);
            let want = if turns {
                Mode::MissedApproach
            } else {
                Mode::Terminal
            };
            assert_eq!(m.mode(), want, "at {depth} m");
        }
    }
}
