//! Mode logic: standby, approach, terminal (blind), docked, breakaway.
//!
//! The transition table (also in `docs/conventions.md`, "Modes"), evaluated once per step in
//! the order listed; the first transition that applies wins:
//!
//! | from | condition | to |
//! |---|---|---|
//! | any but standby | `Reset` request | Standby |
//! | approach, terminal, docked | `Abort` request | Breakaway(Abort) |
//! | approach, terminal, docked | navigation invalid for more than `hold_limit_steps` steps | Breakaway(NavLost) |
//! | approach, terminal | camera forward speed relative to the tanker > `overspeed_mps` | Breakaway(Overspeed) |
//! | standby | `Engage` request with a valid measurement and valid navigation | Approach |
//! | approach | measurement invalid for more than `hold_limit_steps` steps | Breakaway(MeasurementLost) |
//! | approach | valid measurement with depth <= `terminal_depth_m`, offset > `terminal_max_offset_m` | Breakaway(PredictedMiss) |
//! | approach | valid measurement with depth <= `terminal_depth_m` | Terminal |
//! | terminal | probe contact | Docked |
//! | terminal | dead-reckoned depth < `-terminal_overshoot_m` | Breakaway(PassedDroguePlane) |
//! | terminal | `terminal_timeout_s` elapsed | Breakaway(TerminalTimeout) |
//! | docked | probe contact lost | Breakaway(ContactLost) |
//!
//! Breakaway is latched: only `Reset` leaves it.
//!
//! Invariant: the machine only changes mode through [`ModeMachine::update`], and every
//! breakaway carries its reason.

use serde::{Deserialize, Serialize};

use crate::frames::{TargetEstimate, VelocityRe};
use crate::num::HypotLimit;

/// Controller mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Mode {
    /// Not in control: commands are the trim values, integrators are held at zero.
    #[default]
    Standby,
    /// Visual tracking: the outer loop closes on the drogue.
    Approach,
    /// Blind final phase: lateral and vertical commands held, closing at the minimum speed,
    /// depth dead-reckoned.
    Terminal,
    /// Probe contact: hold position relative to the tanker.
    Docked,
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
}

/// Parameters of the mode logic.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ModeConfig {
    /// Depth at which the camera is considered blind and the terminal phase starts, m.
    pub terminal_depth_m: f32,
    /// Largest radial offset of the drogue at terminal entry that can still be captured, m.
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
    /// Largest camera forward speed relative to the tanker (from navigation, `C x`) in
    /// approach and terminal; above it the controller breaks away (`Overspeed`), m/s. Must
    /// exceed `velocity_limits.max_closing_mps`. Default 2.3 m/s: 0.3 m/s above the largest
    /// commanded closing speed (2.0), and below 2.6 m/s (5 kt, the upper end of the
    /// operational contact band, `../shared/reference/model-data.md`), so that the breakaway
    /// starts before the speed leaves the band. No run of the 1,000-run `paper-level2` and
    /// `paper-bow-wave` campaigns exceeds even 2.05 m/s (docs/faults.md).
    pub overspeed_mps: f32,
    /// Breakaway: largest change of the desired velocity, m/s², each axis (the approach's
    /// is `velocity_limits.max_accel_mps2`). A breakaway is the manoeuvre that must not be
    /// gentle: at the approach's 0.5 m/s² the descent takes 2 s to build up.
    pub breakaway_accel_mps2: f32,
}

impl Default for ModeConfig {
    fn default() -> Self {
        Self {
            terminal_depth_m: 0.7,
            terminal_max_offset_m: 0.3,
            terminal_overshoot_m: 0.5,
            terminal_timeout_s: 5.0,
            hold_limit_steps: 25,
            breakaway_aft_mps: 2.0,
            breakaway_down_mps: 1.0,
            breakaway_throttle_cut: 0.05,
            overspeed_mps: 2.3,
            breakaway_accel_mps2: 2.0,
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
    /// Probe contact discrete.
    pub probe_contact: bool,
    /// Camera forward speed relative to the tanker from navigation, m/s.
    pub camera_fwd_mps: f32,
    /// The desired velocity the inner loops were tracking (slewed), whose lateral and
    /// vertical parts are held when entering the blind phase.
    pub v_des: VelocityRe,
}

/// State of the blind phase.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TerminalState {
    /// Lateral and vertical commands held from the last visual step.
    pub held: VelocityRe,
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

/// What the transitions need from a [`ModeConfig`] and the step period, derived once: the
/// blind-phase limit in steps and the terminal-entry offset check (`libm::hypotf` of the
/// target's offset against `terminal_max_offset_m`, as [`HypotLimit`] answers it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModeLimits {
    timeout_steps: u32,
    max_offset: HypotLimit,
}

impl ModeLimits {
    /// Derives the limits of `cfg` at the period `ts_s`.
    pub fn new(cfg: &ModeConfig, ts_s: f32) -> Self {
        Self {
            timeout_steps: timeout_steps(cfg, ts_s),
            max_offset: HypotLimit::new(cfg.terminal_max_offset_m),
        }
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

    /// True when the last valid measurement is being held this step.
    pub fn holding_measurement(&self) -> bool {
        self.mode == Mode::Approach && self.meas_invalid_steps > 0
    }

    fn enter(&mut self, mode: Mode) {
        self.mode = mode;
        self.reason = None;
        self.meas_invalid_steps = 0;
    }

    fn break_away(&mut self, why: BreakawayReason) {
        self.enter(Mode::Breakaway);
        self.reason = Some(why);
    }

    /// Advances the machine by one step of `ts_s` seconds. Returns true when `Engage` was
    /// requested in standby but refused (no valid measurement or navigation).
    pub fn update(&mut self, inp: &ModeInputs, cfg: &ModeConfig, ts_s: f32) -> bool {
        self.advance(inp, cfg, ts_s, &ModeLimits::new(cfg, ts_s))
    }

    /// [`ModeMachine::update`] with the limits derived beforehand (`ModeLimits::new(cfg,
    /// ts_s)`: the controller derives them at construction).
    #[inline]
    pub fn advance(
        &mut self,
        inp: &ModeInputs,
        cfg: &ModeConfig,
        ts_s: f32,
        limits: &ModeLimits,
    ) -> bool {
        self.nav_invalid_steps = if inp.nav_valid {
            0
        } else {
            self.nav_invalid_steps.saturating_add(1)
        };
        let engaged = matches!(self.mode, Mode::Approach | Mode::Terminal | Mode::Docked);
        if inp.request == ModeRequest::Reset && self.mode != Mode::Standby {
            self.enter(Mode::Standby);
            return false;
        }
        if engaged && inp.request == ModeRequest::Abort {
            self.break_away(BreakawayReason::Abort);
            return false;
        }
        if engaged && self.nav_invalid_steps > cfg.hold_limit_steps {
            self.break_away(BreakawayReason::NavLost);
            return false;
        }
        if matches!(self.mode, Mode::Approach | Mode::Terminal)
            && inp.camera_fwd_mps > cfg.overspeed_mps
        {
            self.break_away(BreakawayReason::Overspeed);
            return false;
        }
        match self.mode {
            Mode::Standby => {
                if inp.request == ModeRequest::Engage {
                    if inp.target.is_some() && inp.nav_valid {
                        self.enter(Mode::Approach);
                    } else {
                        return true;
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
                    self.meas_invalid_steps = 0;
                    if t.depth_m <= cfg.terminal_depth_m {
                        // t.radial_offset_m() > cfg.terminal_max_offset_m, exactly.
                        if limits.max_offset.exceeded_by(t.right_m, t.down_m) {
                            self.break_away(BreakawayReason::PredictedMiss);
                        } else {
                            self.enter(Mode::Terminal);
                            self.terminal = TerminalState {
                                held: inp.v_des,
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
            Mode::Breakaway => {}
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TS: f32 = 0.02;
    /// A depth just inside the default terminal threshold (0.7 m), m.
    const NEAR_M: f32 = 0.6;

    fn inputs() -> ModeInputs {
        ModeInputs {
            request: ModeRequest::None,
            target: Some(TargetEstimate {
                right_m: 0.5,
                down_m: 0.0,
                depth_m: 6.0,
            }),
            nav_valid: true,
            probe_contact: false,
            camera_fwd_mps: 1.0,
            v_des: VelocityRe {
                x_right_mps: 0.1,
                y_down_mps: -0.2,
                z_fwd_mps: 1.0,
            },
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
        m.update(&near(0.05), &ModeConfig::default(), TS);
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
            TS
        ));
        assert!(m.update(
            &ModeInputs {
                request: ModeRequest::Engage,
                nav_valid: false,
                ..inputs()
            },
            &cfg,
            TS
        ));
        assert_eq!(m.mode(), Mode::Standby);
        assert!(
            !m.update(&inputs(), &cfg, TS),
            "no request, nothing refused"
        );
        assert_eq!(m.mode(), Mode::Standby);
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
            m.update(&lost, &cfg, TS);
            assert_eq!(m.mode(), Mode::Approach);
            assert!(m.holding_measurement());
        }
        m.update(&lost, &cfg, TS);
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
                m.update(&lost, &cfg, TS);
            }
            m.update(&inputs(), &cfg, TS);
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
            m.update(&bad, &cfg, TS);
        }
        assert_eq!(m.mode(), Mode::Approach);
        m.update(&bad, &cfg, TS);
        assert_eq!(m.breakaway_reason(), Some(BreakawayReason::NavLost));
    }

    #[test]
    fn terminal_entry_holds_the_commands_or_predicts_a_miss() {
        let m = terminal();
        assert_eq!(m.terminal().held, inputs().v_des);
        assert_eq!(m.terminal().depth_m, NEAR_M);
        let mut miss = engaged();
        miss.update(&near(0.31), &ModeConfig::default(), TS);
        assert_eq!(
            miss.breakaway_reason(),
            Some(BreakawayReason::PredictedMiss)
        );
    }

    #[test]
    fn terminal_docks_on_contact() {
        let mut m = terminal();
        m.update(
            &ModeInputs {
                probe_contact: true,
                target: None,
                ..inputs()
            },
            &ModeConfig::default(),
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
            m.update(&blind, &cfg, TS);
            assert_eq!(m.mode(), Mode::Terminal, "depth {}", m.terminal().depth_m);
        }
        m.update(&blind, &cfg, TS);
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
            m.update(&stalled, &cfg, TS);
        }
        assert_eq!(m.mode(), Mode::Terminal);
        m.update(&stalled, &cfg, TS);
        assert_eq!(m.breakaway_reason(), Some(BreakawayReason::TerminalTimeout));
    }

    #[test]
    fn docked_breaks_away_when_contact_is_lost() {
        let cfg = ModeConfig::default();
        let mut m = terminal();
        m.update(
            &ModeInputs {
                probe_contact: true,
                ..inputs()
            },
            &cfg,
            TS,
        );
        m.update(
            &ModeInputs {
                probe_contact: true,
                ..inputs()
            },
            &cfg,
            TS,
        );
        assert_eq!(m.mode(), Mode::Docked);
        m.update(&inputs(), &cfg, TS);
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
            m.update(&abort, &cfg, TS);
            assert_eq!(m.breakaway_reason(), Some(BreakawayReason::Abort));
            for req in [ModeRequest::None, ModeRequest::Engage, ModeRequest::Abort] {
                m.update(
                    &ModeInputs {
                        request: req,
                        probe_contact: true,
                        ..near(0.0)
                    },
                    &cfg,
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
            TS,
        );
        assert_eq!(m.mode(), Mode::Standby);
    }
}
