//! Behaviour tests of the docking controller through its public API only, flying the
//! paper's procedure. The refuelling procedure's transitions are checked step by step
//! against an independent model of its table in `fuzz_step.rs` (with a test that the
//! generated sorties reach every row of the table), and closed loop in `host-sim/tests/faults.rs`
//! and `tests/tests/docking.rs`.
//!
//! Each test drives [`Controller::step`] through one behaviour of the response specification
//! in the `controller` module doc and the transition table in the `mode` module doc: engaging,
//! holding through invalid frames and navigation, dropped frames, the blind terminal phase,
//! docking, breakaway, reset, anti-windup, configuration rejection and the wire messages.
//!
//! Several tests compare a controller with a clone of itself (a "twin") fed the input a
//! healthy sensor would have produced: the specified response to a bad input is then an exact
//! equality, not a tolerance.

use ibvs_core::config::{ConfigProblem, LIGHT_DESIGN_BELOW_MASS_FACTOR};
use ibvs_core::controller::StatusFlags;
use ibvs_core::estimator::swing_period_s;
use ibvs_core::frames::{TargetEstimate, VelocityRe};
use ibvs_core::gains::{REFUEL_LIGHT_MASS_FACTOR, TRIM};
use ibvs_core::measurement::{CameraMeasurement, MeasurementError};
use ibvs_core::nav::{FlightCondition, NavError, NavSample};
use ibvs_core::schedule::{ScheduleError, design_at};
use ibvs_core::wire::{
    Downlink, FlightComputerMessage, LinkCounters, MAX_FRAME_LEN, Telemetry, Uplink,
    decode_downlink, decode_flight_computer_message, decode_uplink, encode_downlink,
    encode_telemetry, encode_uplink,
};
use ibvs_core::{
    BreakawayReason, ConfigError, Controller, ControllerConfig, ControllerInput, ControllerOutput,
    Mode, ModeRequest, OuterLaw, ReconfigureError,
};

/// The trim command `[elevator, throttle, aileron, rudder]`.
fn trim() -> [f32; 4] {
    [
        TRIM.elevator_rad,
        TRIM.throttle,
        TRIM.aileron_rad,
        TRIM.rudder_rad,
    ]
}

/// The default configuration with the frozen-measurement check off (its limit at the largest
/// value, 22 minutes at 50 Hz): most tests here show the drogue at one fixed image point for
/// many steps, which a working tracker's noise never produces. The check has its own tests
/// (`frozen_frames_...`), on the default configuration.
fn config() -> ControllerConfig {
    let mut cfg = ControllerConfig::paper();
    cfg.measurement.frozen_frame_limit = u16::MAX;
    cfg
}

/// Largest change of the desired velocity per step, each axis.
fn max_slew_step(cfg: &ControllerConfig) -> f32 {
    cfg.velocity_limits.max_accel_mps2 * Controller::PERIOD_S
}

/// A small, valid navigation perturbation, so the inner loops have something to do.
fn perturbed_nav() -> NavSample {
    let mut n = NavSample::default();
    n.lon.theta_rad = 0.002;
    n.lon.v_mps = 0.05;
    n.lon.alpha_rad = -0.001;
    n.lon.q_radps = 0.002;
    n.lat.phi_rad = 0.03;
    n.lat.beta_rad = 0.002;
    n.lat.r_radps = -0.01;
    n
}

/// Image point and depth of a frame.
#[derive(Debug, Clone, Copy)]
struct Seen {
    x: f32,
    y: f32,
    depth_m: f32,
}

/// The drogue a little right of and above the boresight at mid range.
const MID: Seen = Seen {
    x: 0.2,
    y: -0.1,
    depth_m: 6.0,
};

/// A controller with its camera sequence and navigation source.
#[derive(Debug, Clone)]
struct Rig {
    ctl: Controller,
    /// Sequence number of the last frame sent.
    seq: u32,
    nav: NavSample,
}

impl Rig {
    fn new(cfg: ControllerConfig) -> Self {
        Self {
            ctl: Controller::new(cfg).expect("valid configuration"),
            seq: 100,
            nav: NavSample::default(),
        }
    }

    /// A rig in approach, engaged on a valid frame of `seen`.
    fn engaged(cfg: ControllerConfig, nav: NavSample, seen: Seen) -> Self {
        let mut rig = Self {
            nav,
            ..Self::new(cfg)
        };
        let out = rig.step_with(seen, |i| i.request = ModeRequest::Engage);
        assert_eq!(out.mode, Mode::Approach, "engage refused: {out:?}");
        rig
    }

    /// The input of a healthy step: the next frame, showing `seen`, and the rig's navigation.
    fn healthy_input(&mut self, seen: Seen) -> ControllerInput {
        self.seq = self.seq.wrapping_add(1);
        ControllerInput {
            measurement: CameraMeasurement {
                seq: self.seq,
                tracked: true,
                image_x: seen.x,
                image_y: seen.y,
                depth_m: seen.depth_m,
                probe_tip: None,
            },
            nav: self.nav,
            probe_contact: false,
            autopilot_ready: true,
            request: ModeRequest::None,
        }
    }

    /// Steps a healthy input changed by `edit`.
    fn step_with(
        &mut self,
        seen: Seen,
        edit: impl FnOnce(&mut ControllerInput),
    ) -> ControllerOutput {
        let mut input = self.healthy_input(seen);
        edit(&mut input);
        self.ctl.step(&input)
    }

    /// Steps a healthy input.
    fn step(&mut self, seen: Seen) -> ControllerOutput {
        self.step_with(seen, |_| {})
    }
}

fn has(out: &ControllerOutput, flag: u16) -> bool {
    out.status.contains(flag)
}

fn v_array(v: &VelocityRe) -> [f32; 3] {
    [v.x_right_mps, v.y_down_mps, v.z_fwd_mps]
}

/// Asserts that `now` is one slew step from `prev` toward `target` on every axis.
fn assert_slews_toward(prev: &VelocityRe, now: &VelocityRe, target: &VelocityRe, step: f32) {
    for ((p, n), t) in v_array(prev)
        .into_iter()
        .zip(v_array(now))
        .zip(v_array(target))
    {
        let expected = p + (t - p).clamp(-step, step);
        assert!(
            (n - expected).abs() <= 1e-6,
            "axis moved {p} -> {n}, expected {expected} (target {t}, step {step})"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Engage

#[test]
fn engage_is_refused_without_a_valid_frame_and_accepted_with_one() {
    let mut rig = Rig::new(config());
    let engage = |i: &mut ControllerInput| i.request = ModeRequest::Engage;

    let out = rig.step_with(MID, |i| {
        engage(i);
        i.measurement.tracked = false;
    });
    assert_eq!(out.mode, Mode::Standby);
    assert!(has(&out, StatusFlags::ENGAGE_REFUSED));
    assert_eq!(out.measurement_error, Some(MeasurementError::NotTracked));
    assert_eq!(rig.ctl.counters().engage_refused, 1);
    assert_eq!(out.command.as_array(), trim(), "standby flies trim");

    // A valid frame but no valid navigation is refused too.
    let out = rig.step_with(MID, |i| {
        engage(i);
        i.nav.lat.p_radps = f32::NAN;
    });
    assert_eq!(out.mode, Mode::Standby);
    assert!(has(&out, StatusFlags::ENGAGE_REFUSED));
    assert_eq!(out.nav_error, Some(NavError::NonFinite));
    assert_eq!(rig.ctl.counters().engage_refused, 2);

    // Without a request nothing is refused.
    let out = rig.step_with(MID, |i| i.measurement.tracked = false);
    assert!(!has(&out, StatusFlags::ENGAGE_REFUSED));
    assert_eq!(rig.ctl.counters().engage_refused, 2);

    let out = rig.step_with(MID, engage);
    assert_eq!(out.mode, Mode::Approach);
    assert!(!has(&out, StatusFlags::ENGAGE_REFUSED));
    assert_eq!(out.measurement_error, None);
    assert_eq!(rig.ctl.counters().engage_refused, 2);
}

/// The IBVS law's output for `seen` (inside the velocity limits for the frames used here).
fn ibvs_law(cfg: &ControllerConfig, seen: Seen) -> VelocityRe {
    let (g, lim) = (&cfg.ibvs, &cfg.velocity_limits);
    let close = g.k3_per_s * seen.depth_m - g.k4_mps * seen.x.abs() - g.k5_mps * seen.y.abs();
    VelocityRe {
        x_right_mps: g.k1_mps * seen.x,
        y_down_mps: g.k2_mps * seen.y,
        z_fwd_mps: close.clamp(lim.min_closing_mps, lim.max_closing_mps),
    }
}

#[test]
fn engaging_slews_the_desired_velocity_from_rest_to_the_law() {
    let cfg = config();
    let law = ibvs_law(&cfg, MID);
    let mut rig = Rig::new(cfg);
    let out = rig.step_with(MID, |i| i.request = ModeRequest::Engage);
    assert_eq!(out.mode, Mode::Approach);
    assert_slews_toward(&VelocityRe::ZERO, &out.v_des, &law, max_slew_step(&cfg));
    let mut prev = out.v_des;
    for _ in 0..300 {
        let out = rig.step(MID);
        assert_slews_toward(&prev, &out.v_des, &law, max_slew_step(&cfg));
        prev = out.v_des;
    }
    for (got, want) in v_array(&prev).into_iter().zip(v_array(&law)) {
        assert!((got - want).abs() < 1e-5, "{prev:?} vs {law:?}");
    }
}

// ---------------------------------------------------------------------------------------------
// Invalid frames in approach: hold, then break away

/// The frame following `last` (the last one sent) that provokes `kind`.
fn bad_frame(
    kind: MeasurementError,
    last: &CameraMeasurement,
    cfg: &ControllerConfig,
) -> CameraMeasurement {
    let next = CameraMeasurement {
        seq: last.seq.wrapping_add(1),
        ..*last
    };
    let lim = &cfg.measurement;
    match kind {
        MeasurementError::NotTracked => CameraMeasurement {
            tracked: false,
            ..next
        },
        MeasurementError::NonFinite => CameraMeasurement {
            image_x: f32::NAN,
            ..next
        },
        MeasurementError::DepthNotPositive => CameraMeasurement {
            depth_m: -0.0,
            ..next
        },
        MeasurementError::DepthTooLarge => CameraMeasurement {
            depth_m: lim.max_depth_m * 1.01,
            ..next
        },
        MeasurementError::OutsideFieldOfView => CameraMeasurement {
            image_y: -lim.half_fov_y * 1.01,
            ..next
        },
        MeasurementError::Repeated => *last,
        MeasurementError::OutOfOrder => CameraMeasurement {
            seq: last.seq.wrapping_sub(1),
            ..*last
        },
        // The same content with a fresh frame number (the test's frames already repeat it).
        MeasurementError::Frozen => next,
    }
}

fn error_count(c: &ibvs_core::Counters, kind: MeasurementError) -> u32 {
    match kind {
        MeasurementError::NotTracked => c.not_tracked,
        MeasurementError::NonFinite => c.non_finite,
        MeasurementError::DepthNotPositive => c.depth_not_positive,
        MeasurementError::DepthTooLarge => c.depth_too_large,
        MeasurementError::OutsideFieldOfView => c.outside_fov,
        MeasurementError::Repeated => c.repeated,
        MeasurementError::OutOfOrder => c.out_of_order,
        MeasurementError::Frozen => c.frozen,
    }
}

/// Engages, flies a few valid frames, then feeds frames provoking `kind`: the controller must
/// fly exactly as a twin that kept receiving the last valid frame's content (same desired
/// velocity, target and commands), flagged MEASUREMENT_HELD, for `hold_limit_steps` steps,
/// and break away (MeasurementLost) on the next.
fn invalid_frames_are_held_then_break_away(kind: MeasurementError) {
    let cfg = config();
    let mut held = Rig::engaged(cfg, perturbed_nav(), MID);
    for _ in 0..3 {
        held.step(MID);
    }
    let mut twin = held.clone();
    let mut last = held.healthy_input(MID);
    let mut prev = held.ctl.step(&last).v_des;
    let law = ibvs_law(&cfg, MID);
    twin.step(MID);
    let limit = u32::from(cfg.modes.hold_limit_steps);
    let valid_frames = held.ctl.counters().frames_valid;

    for k in 1..=limit {
        let good = twin.step(MID);
        let input = ControllerInput {
            measurement: bad_frame(kind, &last.measurement, &cfg),
            ..last
        };
        if kind != MeasurementError::Repeated && kind != MeasurementError::OutOfOrder {
            last = input;
        }
        let out = held.ctl.step(&input);
        assert_eq!(out.mode, Mode::Approach, "step {k} of the hold");
        assert_eq!(out.measurement_error, Some(kind));
        assert!(has(&out, StatusFlags::MEASUREMENT_HELD), "step {k}");
        assert!(!has(&good, StatusFlags::MEASUREMENT_HELD));
        assert_eq!(out.v_des, good.v_des, "step {k}: not the held command");
        assert_eq!(out.target, good.target, "step {k}");
        assert_eq!(out.command, good.command, "step {k}");
        // Still slewing toward the held command: a hold is not a freeze of the command.
        assert_slews_toward(&prev, &out.v_des, &law, max_slew_step(&cfg));
        prev = out.v_des;
        let c = held.ctl.counters();
        assert_eq!(error_count(c, kind), k);
        assert_eq!(c.measurement_held_steps, k);
        assert_eq!(c.frames_valid, valid_frames);
    }
    let out = held.ctl.step(&ControllerInput {
        measurement: bad_frame(kind, &last.measurement, &cfg),
        ..last
    });
    assert_eq!(out.mode, Mode::Breakaway);
    assert_eq!(out.breakaway_reason, Some(BreakawayReason::MeasurementLost));
    assert!(!has(&out, StatusFlags::MEASUREMENT_HELD));
    assert_eq!(out.measurement_error, Some(kind));
    let c = held.ctl.counters();
    assert_eq!(error_count(c, kind), limit + 1);
    assert_eq!(c.measurement_held_steps, limit);
}

#[test]
fn untracked_frames_hold_the_last_command_then_break_away() {
    invalid_frames_are_held_then_break_away(MeasurementError::NotTracked);
}

#[test]
fn non_finite_frames_hold_the_last_command_then_break_away() {
    invalid_frames_are_held_then_break_away(MeasurementError::NonFinite);
}

#[test]
fn non_positive_depth_frames_hold_the_last_command_then_break_away() {
    invalid_frames_are_held_then_break_away(MeasurementError::DepthNotPositive);
}

#[test]
fn too_deep_frames_hold_the_last_command_then_break_away() {
    invalid_frames_are_held_then_break_away(MeasurementError::DepthTooLarge);
}

#[test]
fn out_of_view_frames_hold_the_last_command_then_break_away() {
    invalid_frames_are_held_then_break_away(MeasurementError::OutsideFieldOfView);
}

#[test]
fn repeated_frames_hold_the_last_command_then_break_away() {
    invalid_frames_are_held_then_break_away(MeasurementError::Repeated);
}

#[test]
fn late_frames_hold_the_last_command_then_break_away() {
    invalid_frames_are_held_then_break_away(MeasurementError::OutOfOrder);
}

/// A stuck tracker: new frame numbers, the same image point and depth bit for bit. The
/// default configuration accepts `frozen_frame_limit` repeats of a frame's content, rejects
/// the next ones as `Frozen` (held, as any invalid frame) and breaks away when the hold runs
/// out.
#[test]
fn frozen_frames_are_accepted_up_to_the_limit_then_held_then_break_away() {
    let cfg = ControllerConfig::paper();
    let repeats = u32::from(cfg.measurement.frozen_frame_limit);
    let hold = u32::from(cfg.modes.hold_limit_steps);
    assert!(repeats > 0 && hold > 0);
    // Engaged on a frame showing MID: its content's first frame.
    let mut rig = Rig::engaged(cfg, perturbed_nav(), MID);
    for k in 1..=repeats {
        let out = rig.step(MID);
        assert_eq!(out.measurement_error, None, "repeat {k} of {repeats}");
        assert!(!has(&out, StatusFlags::MEASUREMENT_HELD));
    }
    for k in 1..=hold {
        let out = rig.step(MID);
        assert_eq!(out.mode, Mode::Approach, "held step {k}");
        assert_eq!(out.measurement_error, Some(MeasurementError::Frozen));
        assert!(has(&out, StatusFlags::MEASUREMENT_HELD));
        let c = rig.ctl.counters();
        assert_eq!((c.frozen, c.measurement_held_steps), (k, k));
        assert_eq!(c.frames_valid, 1 + repeats);
    }
    let out = rig.step(MID);
    assert_eq!(out.mode, Mode::Breakaway);
    assert_eq!(out.breakaway_reason, Some(BreakawayReason::MeasurementLost));
}

/// Any change of the content restarts the count; a frame whose number did not advance is
/// `Repeated`, not a repeat of content, and does not count toward `Frozen`.
#[test]
fn a_changed_frame_restarts_the_frozen_count_and_repeated_numbers_do_not_count() {
    let cfg = ControllerConfig::paper();
    let repeats = cfg.measurement.frozen_frame_limit;
    let moved = Seen {
        depth_m: f32::from_bits(MID.depth_m.to_bits() + 1),
        ..MID
    };
    let mut rig = Rig::engaged(cfg, perturbed_nav(), MID);
    for _ in 0..3 {
        for _ in 0..repeats {
            assert_eq!(rig.step(MID).measurement_error, None);
        }
        // One ulp of depth is a different frame.
        assert_eq!(rig.step(moved).measurement_error, None);
        assert_eq!(rig.step(MID).measurement_error, None);
    }
    // The same frame number again, many times: Repeated, and the content count stays.
    let again = rig.healthy_input(MID);
    assert_eq!(rig.ctl.step(&again).measurement_error, None);
    for _ in 0..2 * repeats {
        assert_eq!(
            rig.ctl.step(&again).measurement_error,
            Some(MeasurementError::Repeated)
        );
    }
    for _ in 1..repeats {
        assert_eq!(rig.step(MID).measurement_error, None);
    }
    assert_eq!(
        rig.step(MID).measurement_error,
        Some(MeasurementError::Frozen)
    );
    assert_eq!(rig.ctl.counters().frozen, 1);
    assert_eq!(rig.ctl.mode(), Mode::Approach);
}

#[test]
fn one_valid_frame_restarts_the_hold_count() {
    let cfg = config();
    let limit = cfg.modes.hold_limit_steps;
    let mut rig = Rig::engaged(cfg, NavSample::default(), MID);
    for _ in 0..3 {
        for _ in 0..limit {
            let out = rig.step_with(MID, |i| i.measurement.tracked = false);
            assert!(has(&out, StatusFlags::MEASUREMENT_HELD));
        }
        let out = rig.step(MID);
        assert_eq!(out.mode, Mode::Approach);
        assert!(!has(&out, StatusFlags::MEASUREMENT_HELD));
    }
    assert_eq!(
        rig.ctl.counters().measurement_held_steps,
        3 * u32::from(limit)
    );
}

#[test]
fn a_sequence_gap_counts_the_dropped_frames_and_uses_the_frame() {
    let cfg = config();
    for start in [100_u32, u32::MAX - 1] {
        let mut rig = Rig {
            seq: start.wrapping_sub(1),
            ..Rig::new(cfg)
        };
        rig.step_with(MID, |i| i.request = ModeRequest::Engage);
        assert_eq!(rig.ctl.mode(), Mode::Approach);
        let moved = Seen {
            x: -0.3,
            y: 0.25,
            depth_m: 4.0,
        };
        let n = 4;
        rig.seq = rig.seq.wrapping_add(n);
        let out = rig.step(moved);
        assert_eq!(out.measurement_error, None, "start {start}");
        assert!(!has(&out, StatusFlags::MEASUREMENT_HELD));
        let c = rig.ctl.counters();
        assert_eq!(c.frames_dropped, n, "start {start}");
        assert_eq!(c.frames_valid, 2);
        // The gap frame was used: the target is the new one.
        assert!((out.target.right_m - moved.x * moved.depth_m).abs() < 1e-6);
        assert!((out.target.depth_m - moved.depth_m).abs() < 1e-6);
        // The next consecutive frame drops nothing more.
        rig.step(moved);
        assert_eq!(rig.ctl.counters().frames_dropped, n);
    }
}

// ---------------------------------------------------------------------------------------------
// Invalid navigation

#[test]
fn invalid_navigation_flies_the_held_sample_with_frozen_integrators_then_breaks_away() {
    let cfg = config();
    let mut rig = Rig::engaged(cfg, perturbed_nav(), MID);
    for _ in 0..20 {
        rig.step(MID);
    }
    let q0 = rig.ctl.integrators_m();
    assert!(q0.iter().all(|q| *q != 0.0), "integrators moved: {q0:?}");

    // First held step: the command is the one the held sample would give.
    let mut twin = rig.clone();
    let good = twin.step(MID);
    let nan = |i: &mut ControllerInput| i.nav.lon.q_radps = f32::NAN;
    let out = rig.step_with(MID, nan);
    assert_eq!(out.nav_error, Some(NavError::NonFinite));
    assert!(has(&out, StatusFlags::NAV_HELD));
    assert!(!has(&out, StatusFlags::OPEN_LOOP));
    assert_eq!(out.command, good.command, "inner loops on the held sample");
    assert_eq!(rig.ctl.integrators_m(), q0, "integrators frozen");
    assert_ne!(twin.ctl.integrators_m(), q0, "the twin integrates");
    let lateral = [out.command.as_array()[2], out.command.as_array()[3]];

    let limit = u32::from(cfg.modes.hold_limit_steps);
    for k in 2..=limit {
        let out = rig.step_with(MID, nan);
        assert_eq!(out.mode, Mode::Approach, "step {k}");
        assert!(has(&out, StatusFlags::NAV_HELD));
        assert_eq!(rig.ctl.integrators_m(), q0, "step {k}");
        // Held lateral state and frozen integrator: the lateral command cannot move.
        assert_eq!(
            [out.command.as_array()[2], out.command.as_array()[3]],
            lateral
        );
        let c = rig.ctl.counters();
        assert_eq!((c.nav_non_finite, c.nav_held_steps), (k, k));
    }

    let open_loop = {
        let mut t = trim();
        t[1] -= cfg.modes.breakaway_throttle_cut;
        t
    };
    for _ in 0..5 {
        let out = rig.step_with(MID, nan);
        assert_eq!(out.mode, Mode::Breakaway);
        assert_eq!(out.breakaway_reason, Some(BreakawayReason::NavLost));
        assert!(has(&out, StatusFlags::OPEN_LOOP));
        assert_eq!(out.command.as_array(), open_loop);
        assert_eq!(rig.ctl.integrators_m(), q0);
    }

    // Navigation back: the breakaway is flown closed loop again.
    let out = rig.step(MID);
    assert_eq!(out.mode, Mode::Breakaway);
    assert!(!has(&out, StatusFlags::OPEN_LOOP));
    assert!(!has(&out, StatusFlags::NAV_HELD));
    assert_ne!(out.command.as_array(), open_loop);
}

#[test]
fn navigation_outside_the_envelope_is_held_and_counted() {
    let cfg = config();
    let mut rig = Rig::engaged(cfg, perturbed_nav(), MID);
    rig.step(MID);
    let q0 = rig.ctl.integrators_m();
    let out = rig.step_with(MID, |i| {
        i.nav.lat.phi_rad = cfg.nav_envelope.max_bank_rad * 1.1;
    });
    assert_eq!(out.nav_error, Some(NavError::OutsideEnvelope));
    assert!(has(&out, StatusFlags::NAV_HELD));
    assert_eq!(rig.ctl.integrators_m(), q0);
    let c = rig.ctl.counters();
    assert_eq!((c.nav_outside_envelope, c.nav_non_finite), (1, 0));
}

#[test]
fn an_aborted_approach_without_navigation_flies_open_loop_at_once() {
    let cfg = config();
    let mut rig = Rig::engaged(cfg, perturbed_nav(), MID);
    rig.step(MID);
    let out = rig.step_with(MID, |i| {
        i.request = ModeRequest::Abort;
        i.nav.lon.v_mps = f32::INFINITY;
    });
    assert_eq!(out.breakaway_reason, Some(BreakawayReason::Abort));
    assert!(has(&out, StatusFlags::OPEN_LOOP));
    let mut want = trim();
    want[1] -= cfg.modes.breakaway_throttle_cut;
    assert_eq!(out.command.as_array(), want);
}

// ---------------------------------------------------------------------------------------------
// Terminal phase, docking, breakaway

/// Closes from 3 m to just outside the terminal depth, centred.
fn approach_to_terminal_depth(cfg: ControllerConfig, nav: NavSample) -> (Rig, ControllerOutput) {
    let start = Seen {
        x: 0.02,
        y: 0.01,
        depth_m: 3.0,
    };
    let mut rig = Rig::engaged(cfg, nav, start);
    let mut out = rig.step(start);
    for depth in [2.5, 2.0, 1.5, 1.2, cfg.modes.terminal_depth_m + 0.01] {
        out = rig.step(Seen {
            depth_m: depth,
            ..start
        });
        assert_eq!(out.mode, Mode::Approach, "depth {depth}");
    }
    (rig, out)
}

/// A frame at the terminal depth, offset by (about) `offset_m` to the right and a little down.
fn at_terminal_depth(cfg: &ControllerConfig, offset_m: f32) -> Seen {
    let z = cfg.modes.terminal_depth_m;
    Seen {
        x: offset_m / z,
        y: 0.01,
        depth_m: z,
    }
}

/// Largest change of the desired velocity per step in the blind phase, each axis.
fn terminal_slew_step(cfg: &ControllerConfig) -> f32 {
    cfg.modes.terminal_accel_mps2 * Controller::PERIOD_S
}

/// An independent model of the drogue-velocity estimate of the approach (`docs/conventions.md`,
/// "Modes"): first-order filter of the target offset's change per step, every frame valid.
struct RateModel {
    last: [f32; 2],
    rate: [f32; 2],
}

impl RateModel {
    fn observe(&mut self, cfg: &ControllerConfig, t: &TargetEstimate) {
        let now = [t.right_m, t.down_m];
        for ((rate, last), now) in self.rate.iter_mut().zip(self.last).zip(now) {
            let raw = (now - last) / Controller::PERIOD_S;
            *rate += cfg.modes.drogue_rate_filter * (raw - *rate);
        }
        self.last = now;
    }
}

#[test]
fn terminal_is_entered_at_the_terminal_depth_and_aims_at_the_drogue() {
    let cfg = config();
    // An approach on which the drogue drifts right and up in the image.
    let start = Seen {
        x: 0.02,
        y: 0.01,
        depth_m: 3.0,
    };
    let mut rig = Rig::new(cfg);
    let out = rig.step_with(start, |i| i.request = ModeRequest::Engage);
    assert_eq!(out.mode, Mode::Approach);
    let mut model = RateModel {
        last: [out.target.right_m, out.target.down_m],
        rate: [0.0; 2],
    };
    let mut last = out;
    for (k, depth) in [2.5, 2.0, 1.5, 1.2, cfg.modes.terminal_depth_m + 0.01]
        .into_iter()
        .enumerate()
    {
        last = rig.step(Seen {
            x: 0.02 + 0.01 * k as f32,
            y: 0.01 - 0.01 * k as f32,
            depth_m: depth,
        });
        assert_eq!(last.mode, Mode::Approach, "depth {depth}");
        model.observe(&cfg, &last.target);
    }
    let entry = at_terminal_depth(&cfg, 0.1);
    let out = rig.step(entry);
    assert_eq!(out.mode, Mode::Terminal);
    assert_eq!(out.breakaway_reason, None);
    model.observe(&cfg, &out.target);

    // The aim: offset × a / depth plus the drogue's velocity (the offset's filtered rate plus
    // the command the receiver was tracking), saturated; closing at the minimum speed.
    let (a, lim) = (cfg.velocity_limits.min_closing_mps, cfg.velocity_limits);
    let t = out.target;
    let aim = VelocityRe {
        x_right_mps: (t.right_m * a / t.depth_m + model.rate[0] + last.v_des.x_right_mps)
            .clamp(-lim.max_lateral_mps, lim.max_lateral_mps),
        y_down_mps: (t.down_m * a / t.depth_m + model.rate[1] + last.v_des.y_down_mps)
            .clamp(-lim.max_vertical_mps, lim.max_vertical_mps),
        z_fwd_mps: a,
    };
    assert!(
        (aim.x_right_mps - last.v_des.x_right_mps).abs() > 0.1,
        "the test must tell aiming from holding: {aim:?}, {:?}",
        last.v_des
    );
    let step = terminal_slew_step(&cfg);
    assert_slews_toward(&last.v_des, &out.v_des, &aim, step);

    // Blind: whatever the camera says (valid or not, for longer than the hold limit), the
    // desired velocity slews (at the blind phase's rate) to the aim fixed at entry.
    let mut prev = out.v_des;
    for k in 0..2 * cfg.modes.hold_limit_steps {
        let seen = Seen {
            x: 0.5,
            y: -0.4,
            depth_m: 5.0,
        };
        let out = rig.step_with(seen, |i| i.measurement.tracked = k % 2 == 0);
        assert_eq!(out.mode, Mode::Terminal, "step {k}");
        assert!(!has(&out, StatusFlags::MEASUREMENT_HELD));
        assert_slews_toward(&prev, &out.v_des, &aim, step);
        prev = out.v_des;
    }
    for (got, want) in v_array(&prev).into_iter().zip(v_array(&aim)) {
        assert!((got - want).abs() < 1e-5, "{prev:?} {aim:?}");
    }
}

#[test]
fn a_large_offset_at_the_terminal_depth_predicts_a_miss() {
    let cfg = config();
    let (mut rig, _) = approach_to_terminal_depth(cfg, NavSample::default());
    // 1.1 times the limit, diagonally (0.8 × 1.1 limit right, 0.6 × 1.1 limit up): still
    // inside the field of view at the terminal depth.
    let (r, z) = (
        1.1 * cfg.modes.terminal_max_offset_m,
        cfg.modes.terminal_depth_m,
    );
    let seen = Seen {
        x: 0.8 * r / z,
        y: -0.6 * r / z,
        depth_m: z,
    };
    assert!(seen.x < cfg.measurement.half_fov_x && -seen.y < cfg.measurement.half_fov_y);
    let out = rig.step(seen);
    assert_eq!(out.measurement_error, None);
    assert_eq!(out.mode, Mode::Breakaway);
    assert_eq!(out.breakaway_reason, Some(BreakawayReason::PredictedMiss));
}

#[test]
fn terminal_dead_reckons_the_navigation_speed_past_the_drogue_plane() {
    let cfg = config();
    let mut nav = NavSample::default();
    nav.lon.v_mps = 1.0; // closing on the tanker at 1 m/s: the camera's forward speed
    let (mut rig, _) = approach_to_terminal_depth(cfg, nav);
    assert_eq!(rig.step(at_terminal_depth(&cfg, 0.0)).mode, Mode::Terminal);
    // (terminal depth + overshoot) / 1 m/s, in steps.
    let expected = (cfg.modes.terminal_depth_m + cfg.modes.terminal_overshoot_m)
        / (nav.lon.v_mps * Controller::PERIOD_S);
    let mut steps = 0;
    let out = loop {
        let out = rig.step(MID);
        steps += 1;
        if out.mode != Mode::Terminal || steps >= 1000 {
            break out;
        }
    };
    assert_eq!(
        out.breakaway_reason,
        Some(BreakawayReason::PassedDroguePlane)
    );
    assert!(
        (steps as f32 - expected).abs() <= 2.0,
        "{steps} steps, expected about {expected}"
    );
}

#[test]
fn contact_docks_and_losing_it_breaks_away_aft_and_down() {
    let cfg = config();
    let (mut rig, _) = approach_to_terminal_depth(cfg, NavSample::default());
    assert_eq!(rig.step(at_terminal_depth(&cfg, 0.1)).mode, Mode::Terminal);
    let contact = |i: &mut ControllerInput| i.probe_contact = true;
    let mut prev = rig.step(MID).v_des;
    for k in 0..300 {
        let out = rig.step_with(MID, contact);
        assert_eq!(out.mode, Mode::Docked, "step {k}");
        assert_slews_toward(&prev, &out.v_des, &VelocityRe::ZERO, max_slew_step(&cfg));
        prev = out.v_des;
    }
    assert_eq!(prev, VelocityRe::ZERO, "docked: hold station");

    let away = VelocityRe {
        x_right_mps: 0.0,
        y_down_mps: cfg.modes.breakaway_down_mps,
        z_fwd_mps: -cfg.modes.breakaway_aft_mps,
    };
    // The breakaway slews at its own, faster rate.
    let away_step = cfg.modes.breakaway_accel_mps2 * Controller::PERIOD_S;
    let out = rig.step(MID);
    assert_eq!(out.breakaway_reason, Some(BreakawayReason::ContactLost));
    assert_slews_toward(&prev, &out.v_des, &away, away_step);
    prev = out.v_des;
    for _ in 0..300 {
        // Latched: contact, engage and valid frames change nothing.
        let out = rig.step_with(MID, |i| {
            i.probe_contact = true;
            i.request = ModeRequest::Engage;
        });
        assert_eq!(out.breakaway_reason, Some(BreakawayReason::ContactLost));
        assert_slews_toward(&prev, &out.v_des, &away, away_step);
        prev = out.v_des;
    }
    for (got, want) in v_array(&prev).into_iter().zip(v_array(&away)) {
        assert!((got - want).abs() < 1e-5, "{prev:?}");
    }
}

// ---------------------------------------------------------------------------------------------
// Operator requests

#[test]
fn reset_returns_to_standby_with_the_trim_command_exactly() {
    let cfg = config();
    let mut rig = Rig::engaged(cfg, perturbed_nav(), MID);
    for _ in 0..30 {
        rig.step(MID);
    }
    assert_ne!(rig.step(MID).command.as_array(), trim());
    let out = rig.step_with(MID, |i| i.request = ModeRequest::Reset);
    assert_eq!(out.mode, Mode::Standby);
    assert_eq!(out.breakaway_reason, None);
    assert_eq!(out.command.as_array(), trim());
    assert_eq!(out.v_des, VelocityRe::ZERO);
    assert_eq!(rig.ctl.integrators_m(), [0.0; 3]);
    // Standby stays at trim whatever the navigation says.
    let out = rig.step(MID);
    assert_eq!(out.command.as_array(), trim());

    // And from a breakaway.
    rig.step_with(MID, |i| i.request = ModeRequest::Engage);
    for _ in 0..10 {
        rig.step(MID);
    }
    rig.step_with(MID, |i| i.request = ModeRequest::Abort);
    let out = rig.step_with(MID, |i| i.request = ModeRequest::Reset);
    assert_eq!(out.mode, Mode::Standby);
    assert_eq!(out.command.as_array(), trim());
}

#[test]
fn abort_breaks_away_from_approach_and_only_reset_leaves_it() {
    let cfg = config();
    let mut rig = Rig::engaged(cfg, perturbed_nav(), MID);
    rig.step(MID);
    let out = rig.step_with(MID, |i| i.request = ModeRequest::Abort);
    assert_eq!(out.mode, Mode::Breakaway);
    assert_eq!(out.breakaway_reason, Some(BreakawayReason::Abort));
    assert!(!has(&out, StatusFlags::OPEN_LOOP), "navigation is valid");
    for req in [ModeRequest::Engage, ModeRequest::None, ModeRequest::Abort] {
        let out = rig.step_with(MID, |i| i.request = req);
        assert_eq!(
            out.breakaway_reason,
            Some(BreakawayReason::Abort),
            "{req:?}"
        );
    }
    assert_eq!(
        rig.step_with(MID, |i| i.request = ModeRequest::Reset).mode,
        Mode::Standby
    );
    assert_eq!(
        rig.step_with(MID, |i| i.request = ModeRequest::Engage).mode,
        Mode::Approach
    );
}

#[test]
fn abort_in_standby_is_ignored() {
    let mut rig = Rig::new(config());
    let out = rig.step_with(MID, |i| i.request = ModeRequest::Abort);
    assert_eq!(out.mode, Mode::Standby);
    assert_eq!(out.breakaway_reason, None);
}

// ---------------------------------------------------------------------------------------------
// Anti-windup

/// Flies `steps` steps of a large, persistent demand (drogue far and off the boresight) with
/// the navigation stuck at trim, so that the aircraft never responds and the integrators
/// would wind up. Returns the controller and the union of the status bits seen.
fn wind_up(cfg: ControllerConfig, steps: usize) -> (Rig, u16) {
    let far_off = Seen {
        x: 0.5,
        y: 0.4,
        depth_m: 10.0,
    };
    let mut rig = Rig::engaged(cfg, NavSample::default(), far_off);
    let mut seen_bits = 0;
    for _ in 0..steps {
        seen_bits |= rig.step(far_off).status.0;
    }
    assert_eq!(rig.ctl.mode(), Mode::Approach);
    (rig, seen_bits)
}

fn wide_limits() -> ControllerConfig {
    let mut cfg = config();
    cfg.actuators.min = [-1e3; 4];
    cfg.actuators.max = [1e3; 4];
    cfg
}

#[test]
fn saturation_freezes_the_integrators_and_limits_wind_up() {
    const STEPS: usize = 400;
    let (half, _) = wind_up(config(), STEPS / 2);
    let (constrained, bits) = wind_up(config(), STEPS);
    let (free, free_bits) = wind_up(wide_limits(), STEPS);

    let c = constrained.ctl.counters();
    assert!(c.saturated_steps > 0);
    assert!(
        c.integrator_frozen_steps > half.ctl.counters().integrator_frozen_steps,
        "still freezing in the second half"
    );
    let saturated = StatusFlags::SATURATED_ELEVATOR
        | StatusFlags::SATURATED_THROTTLE
        | StatusFlags::SATURATED_AILERON
        | StatusFlags::SATURATED_RUDDER;
    assert_ne!(bits & saturated, 0, "no SATURATED_* bit: {bits:#x}");
    assert_ne!(bits & StatusFlags::LON_INTEGRATOR_FROZEN, 0, "{bits:#x}");
    assert_ne!(bits & StatusFlags::LAT_INTEGRATOR_FROZEN, 0, "{bits:#x}");

    let f = free.ctl.counters();
    assert_eq!((f.saturated_steps, f.integrator_frozen_steps), (0, 0));
    assert_eq!(free_bits & saturated, 0);

    let q = constrained.ctl.integrators_m();
    let q_free = free.ctl.integrators_m();
    assert_eq!(
        half.ctl.integrators_m(),
        q,
        "saturated throughout the second half: no further wind-up"
    );
    let lon = |q: [f32; 3]| q[0].hypot(q[1]);
    assert!(
        lon(q) < 0.5 * lon(q_free),
        "lon wound up: {q:?} vs {q_free:?}"
    );
    assert!(
        q[2].abs() < 0.5 * q_free[2].abs(),
        "lat wound up: {q:?} vs {q_free:?}"
    );
    assert!(
        q_free.iter().all(|v| v.abs() < config().integrator_limit_m),
        "the comparison run must not be clamped instead: {q_free:?}"
    );
}

// ---------------------------------------------------------------------------------------------
// Configuration

/// What `Controller::new` says about the default configuration changed by `spoil`.
/// The field and problem of the rejection of `config()` spoilt by `spoil` (`None`: accepted).
fn rejection(spoil: impl FnOnce(&mut ControllerConfig)) -> Option<(&'static str, ConfigProblem)> {
    let mut cfg = config();
    spoil(&mut cfg);
    Controller::new(cfg).err().map(|e| (e.field, e.problem))
}

#[test]
fn reconfigure_applies_in_standby_only_keeps_the_counters_and_is_atomic() {
    let mut rig = Rig::new(config());
    // Count something first: an engage refused on an untracked frame.
    rig.step_with(MID, |i| {
        i.request = ModeRequest::Engage;
        i.measurement.tracked = false;
    });
    let counted = *rig.ctl.counters();
    assert_eq!(counted.engage_refused, 1);

    // Invalid: refused, named, and the controller unchanged (config and counters).
    let mut bad = config();
    bad.ibvs.k3_per_s = 0.0;
    assert_eq!(
        rig.ctl.reconfigure(bad),
        Err(ReconfigureError::Invalid(ConfigError {
            field: "ibvs.k3_per_s",
            problem: ConfigProblem::NotPositive,
            requirement: "finite, > 0",
        }))
    );
    assert_eq!(*rig.ctl.config(), config());

    // Valid in standby: applied, counters carried over, and it flies the new gains.
    let mut next = config();
    next.ibvs.k1_mps *= 2.0;
    assert_eq!(rig.ctl.reconfigure(next), Ok(()));
    assert_eq!(*rig.ctl.config(), next);
    assert_eq!(*rig.ctl.counters(), counted);
    let mut twin = Rig {
        ctl: Controller::new(next).unwrap(),
        ..rig.clone()
    };
    let engage = |i: &mut ControllerInput| i.request = ModeRequest::Engage;
    let out = rig.step_with(MID, engage);
    assert_eq!(out.mode, Mode::Approach);
    let twin_out = twin.step_with(MID, engage);
    assert_eq!(out.command, twin_out.command, "flies as if built with it");
    assert_eq!(out.v_des, twin_out.v_des);

    // Engaged: refused with the mode, nothing changed.
    let mut untouched = rig.clone();
    assert_eq!(
        rig.ctl.reconfigure(config()),
        Err(ReconfigureError::NotStandby(Mode::Approach))
    );
    assert_eq!(*rig.ctl.config(), next);
    assert_eq!(rig.step(MID), untouched.step(MID));
}

#[test]
fn new_rejects_an_invalid_config_naming_the_field() {
    let named = |field, problem| Some((field, problem));
    assert_eq!(
        rejection(|c| c.ibvs.k3_per_s = 0.0),
        named("ibvs.k3_per_s", ConfigProblem::NotPositive)
    );
    assert_eq!(
        rejection(|c| c.integrator_limit_m = f32::NAN),
        named("integrator_limit_m", ConfigProblem::NotFinite)
    );
    assert_eq!(
        rejection(|c| c.velocity_limits.max_accel_mps2 = -0.5),
        named("velocity_limits.max_accel_mps2", ConfigProblem::NotPositive)
    );
    assert_eq!(
        rejection(|c| c.modes.terminal_accel_mps2 = f32::NAN),
        named("modes.terminal_accel_mps2", ConfigProblem::NotFinite)
    );
    assert_eq!(
        rejection(|c| c.modes.drogue_rate_filter = 2.0),
        named("modes.drogue_rate_filter", ConfigProblem::Inconsistent)
    );
    assert_eq!(
        rejection(|c| c.modes.breakaway_aft_mps = -2.0),
        named("modes.breakaway_aft_mps", ConfigProblem::Negative)
    );
    assert_eq!(
        rejection(|c| c.nav_latency_steps = 5),
        named("nav_latency_steps", ConfigProblem::Inconsistent)
    );
    assert_eq!(rejection(|c| c.nav_latency_steps = 4), None);
    assert_eq!(
        rejection(|c| c.refuelling.late_gate_final_radius_m = 0.55),
        named(
            "refuelling.late_gate_final_radius_m",
            ConfigProblem::Inconsistent
        )
    );
    assert_eq!(
        rejection(|c| c.refuelling.late_gate_taper_m = 0.0),
        named("refuelling.late_gate_taper_m", ConfigProblem::NotPositive)
    );
    assert_eq!(rejection(|_| {}), None);
    assert_eq!(rejection(|c| c.law = OuterLaw::Pbvs), None);
}

#[test]
fn new_rejects_angles_outside_the_range_of_the_steps_trigonometry() {
    let inconsistent = |field| Some((field, ConfigProblem::Inconsistent));
    let pitch = "camera.pitch_down_rad";
    assert_eq!(
        rejection(|c| c.camera.pitch_down_rad = 0.81),
        inconsistent(pitch)
    );
    assert_eq!(
        rejection(|c| c.camera.pitch_down_rad = -0.81),
        inconsistent(pitch)
    );
    assert_eq!(
        rejection(|c| c.camera.pitch_down_rad = f32::NAN),
        inconsistent(pitch)
    );
    assert_eq!(rejection(|c| c.camera.pitch_down_rad = 0.8), None);
    assert_eq!(
        rejection(|c| c.nav_envelope.max_angle_rad = 0.75),
        inconsistent("nav_envelope.max_angle_rad")
    );
    assert_eq!(
        rejection(|c| c.nav_envelope.max_bank_rad = 0.9),
        inconsistent("nav_envelope.max_bank_rad")
    );
    assert_eq!(rejection(|c| c.nav_envelope.max_bank_rad = 0.8), None);
}

// ---------------------------------------------------------------------------------------------
// Wire

#[test]
fn uplink_of_a_real_input_round_trips_and_steps_identically() {
    let mut rig = Rig::engaged(config(), perturbed_nav(), MID);
    let mut twin = rig.clone();
    let mut input = rig.healthy_input(MID);
    input.request = ModeRequest::Abort;
    input.nav.lat.y_right_m = -1e-40; // subnormal, must survive bit for bit
    let sent = Uplink { seq: 7, input };
    let mut buf = [0u8; MAX_FRAME_LEN];
    let frame = encode_uplink(&sent, &mut buf).expect("fits");
    let received = decode_uplink(frame).expect("decodes");
    assert_eq!(received, sent);
    assert_eq!(rig.ctl.step(&input), twin.ctl.step(&received.input));
}

#[test]
fn downlink_of_a_real_step_fits_a_frame_and_round_trips() {
    let cfg = config();
    let mut rig = Rig::engaged(cfg, perturbed_nav(), MID);
    for _ in 0..100 {
        rig.step(MID);
    }
    // A busy step: breakaway with a reason, both errors, many status bits and counters.
    for _ in 0..=cfg.modes.hold_limit_steps {
        rig.step_with(MID, |i| {
            i.measurement.depth_m = f32::NAN;
            i.nav.lon.q_radps = 9.0;
        });
    }
    let output = rig.step_with(MID, |i| {
        i.measurement.tracked = false;
        i.nav.lon.q_radps = f32::NAN;
    });
    assert!(output.breakaway_reason.is_some() && output.measurement_error.is_some());
    assert!(output.nav_error.is_some());
    let sent = Downlink {
        seq: u32::MAX,
        echo_seq: Some(u32::MAX),
        output,
        ..Downlink::default()
    };
    let mut buf = [0u8; MAX_FRAME_LEN];
    let frame = encode_downlink(&sent, &mut buf).expect("fits MAX_FRAME_LEN");
    assert!(frame.len() <= MAX_FRAME_LEN);
    assert_eq!(decode_downlink(frame).expect("decodes"), sent);
    // The counters travel in a telemetry frame.
    let telemetry = Telemetry {
        seq: 7,
        counters: *rig.ctl.counters(),
        link: LinkCounters {
            corrupt: 3,
            ..LinkCounters::default()
        },
        ..Telemetry::default()
    };
    let frame = encode_telemetry(&telemetry, &mut buf).expect("fits MAX_FRAME_LEN");
    assert_eq!(
        decode_flight_computer_message(frame).expect("decodes"),
        FlightComputerMessage::Telemetry(telemetry)
    );
}

// ---------------------------------------------------------------------------------------------
// Reset returns the controller to a fresh engage (found as discrepancies, now fixed)

/// `docs/conventions.md`, "Modes": in standby the integrators and the engine model are at
/// zero, so after a reset the next engage flies exactly like the first one.
#[test]
fn a_re_engage_after_reset_flies_like_the_first_engage() {
    let cfg = config();
    let (mut used, _) = wind_up(cfg, 300);
    let out = used.step_with(MID, |i| i.request = ModeRequest::Reset);
    assert_eq!(out.mode, Mode::Standby);
    assert_eq!(used.ctl.integrators_m(), [0.0; 3]);
    let mut fresh = Rig::new(cfg);
    fresh.seq = used.seq;
    let engage = |i: &mut ControllerInput| i.request = ModeRequest::Engage;
    let again = used.step_with(MID, engage);
    let first = fresh.step_with(MID, engage);
    assert_eq!((again.mode, first.mode), (Mode::Approach, Mode::Approach));
    assert_eq!(again.v_des, first.v_des);
    assert_eq!(
        again.command, first.command,
        "the engine model was not reset in standby"
    );
}

/// A reset forgets the frame sequence: a camera (tracker) that restarted its numbering can
/// engage at once instead of being rejected as `OutOfOrder`.
#[test]
fn reset_forgets_the_frame_sequence_so_a_restarted_camera_can_engage() {
    let mut rig = Rig::engaged(config(), NavSample::default(), MID);
    rig.step(MID);
    rig.step_with(MID, |i| i.request = ModeRequest::Reset);
    assert_eq!(rig.ctl.mode(), Mode::Standby);
    rig.seq = u32::MAX; // the camera restarted: the next frame is number 0
    let out = rig.step_with(MID, |i| i.request = ModeRequest::Engage);
    assert_eq!(out.measurement_error, None);
    assert_eq!(out.mode, Mode::Approach);
}

/// A flight condition.
fn condition(v: f32, h: f32) -> FlightCondition {
    FlightCondition {
        true_airspeed_mps: v,
        altitude_m: h,
    }
}

#[test]
fn the_controller_flies_the_gain_schedules_design_at_the_navigations_flight_condition() {
    // In standby the command is the trim command: the scheduled trim's at 150 m/s, 6,000 m
    // from the step after the follow-up loaded it, not the single-point design's; back at
    // the default condition, the design's again.
    let mut rig = Rig::new(config());
    assert_eq!(rig.step_with(MID, |_| {}).command.as_array(), trim());
    assert!(!rig.ctl.follow_schedule(), "nothing new: nothing loaded");
    let elsewhere = condition(150.0, 6000.0);
    let design = design_at(elsewhere).expect("inside the envelope");
    assert_ne!(design.trim.command(), trim(), "another trim there");
    rig.nav.condition = elsewhere;
    let out = rig.step_with(MID, |_| {});
    assert_eq!(
        out.command.as_array(),
        trim(),
        "the step flies the design it has"
    );
    assert_eq!(out.envelope_error, None);
    assert!(
        rig.ctl.follow_schedule(),
        "the new condition's design loaded"
    );
    assert!(!rig.ctl.follow_schedule(), "once");
    assert_eq!(
        rig.step_with(MID, |_| {}).command.as_array(),
        design.trim.command()
    );
    // Engaged there, the loops run on the scheduled gains: the same state and frame give
    // another command than the single-point design's.
    let engaged_at = |c: FlightCondition| {
        let mut nav = perturbed_nav();
        nav.condition = c;
        let mut rig = Rig::new(config());
        rig.nav = nav;
        rig.step_with(MID, |_| {});
        rig.ctl.follow_schedule();
        let out = rig.step_with(MID, |i| i.request = ModeRequest::Engage);
        assert_eq!(out.mode, Mode::Approach);
        rig.step_with(MID, |_| {}).command.as_array()
    };
    let (here, there) = (
        engaged_at(FlightCondition::default()),
        engaged_at(elsewhere),
    );
    assert!(
        here.iter().zip(&there).all(|(a, b)| a != b),
        "{here:?} vs {there:?}"
    );
    rig.nav.condition = FlightCondition::default();
    rig.step_with(MID, |_| {});
    assert!(rig.ctl.follow_schedule());
    assert_eq!(rig.step_with(MID, |_| {}).command.as_array(), trim());
}

#[test]
fn the_drogue_models_swing_follows_the_flight_condition_with_the_design() {
    // The hose swings faster at a higher dynamic pressure: where the follow-up loads a new
    // condition's design, the estimator's model of the swing is that condition's (the
    // feed-forward's lead and the filter's noise with it), and back at the design's
    // condition the configured one.
    let mut rig = Rig::new(ControllerConfig::default());
    let configured = rig.ctl.config().estimator.drogue_swing_period_s;
    assert_eq!(rig.ctl.drogue_model().swing_period_s(), configured);
    let fast_low = condition(170.0, 500.0);
    rig.nav.condition = fast_low;
    rig.step_with(MID, |_| {});
    assert_eq!(
        rig.ctl.drogue_model().swing_period_s(),
        configured,
        "the step flies the model it has"
    );
    assert!(rig.ctl.follow_schedule());
    let there = swing_period_s(&rig.ctl.config().estimator, fast_low);
    assert!(there < 0.75 * configured, "{there}");
    assert_eq!(rig.ctl.drogue_model().swing_period_s(), there);
    rig.nav.condition = FlightCondition::default();
    rig.step_with(MID, |_| {});
    assert!(rig.ctl.follow_schedule());
    assert_eq!(rig.ctl.drogue_model().swing_period_s(), configured);
}

#[test]
fn outside_the_envelope_the_follow_up_loads_nothing_and_the_design_in_use_stays() {
    let mut rig = Rig::new(config());
    rig.nav.condition = condition(120.0, 9000.0);
    rig.step_with(MID, |_| {});
    assert!(!rig.ctl.follow_schedule());
    assert_eq!(rig.step_with(MID, |_| {}).command.as_array(), trim());
    // A non-finite condition is not even taken (the navigation is rejected).
    rig.nav.condition = condition(f32::NAN, 3000.0);
    assert_eq!(
        rig.step_with(MID, |_| {}).nav_error,
        Some(NavError::NonFinite)
    );
    assert!(!rig.ctl.follow_schedule());
}

#[test]
fn outside_the_docking_envelope_an_engage_is_refused_with_the_limit_named() {
    for (c, why) in [
        (condition(95.0, 3000.0), ScheduleError::AirspeedLow),
        (condition(175.0, 3000.0), ScheduleError::AirspeedHigh),
        (condition(120.0, 400.0), ScheduleError::AltitudeLow),
        (condition(120.0, 8100.0), ScheduleError::AltitudeHigh),
    ] {
        let mut rig = Rig::new(config());
        rig.nav.condition = c;
        let out = rig.step_with(MID, |i| i.request = ModeRequest::Engage);
        assert_eq!(
            (out.mode, out.envelope_error),
            (Mode::Standby, Some(why)),
            "{c:?}"
        );
        assert!(out.status.contains(StatusFlags::ENGAGE_REFUSED), "{c:?}");
        let n = rig.ctl.counters();
        assert_eq!(
            (n.engage_refused, n.outside_docking_envelope),
            (1, 1),
            "{c:?}"
        );
        // The trim flown is the last design's (here the single-point design's).
        assert_eq!(out.command.as_array(), trim());
    }
}

#[test]
fn the_slow_edge_of_the_docking_envelope_follows_the_configured_gross_mass() {
    // At 110 m/s and 8,000 m the design's airframe flies level at about 14 deg of angle of
    // attack, above the 12.9 deg from which a pull of 1.5 g reaches the 20 deg limit; at 0.85
    // of the mass, at about 11.7 deg. The heavier receiver is refused, the lighter engages.
    let slow_high = condition(110.0, 8000.0);
    for (mass, refused) in [(1.0, true), (0.85, false)] {
        let mut cfg = config();
        cfg.mass_factor = mass;
        let mut rig = Rig::new(cfg);
        rig.nav.condition = slow_high;
        let out = rig.step_with(MID, |i| i.request = ModeRequest::Engage);
        let expected = if refused {
            (Mode::Standby, Some(ScheduleError::AngleOfAttackHigh))
        } else {
            (Mode::Approach, None)
        };
        assert_eq!((out.mode, out.envelope_error), expected, "mass {mass}");
        assert_eq!(
            out.status.contains(StatusFlags::ENGAGE_REFUSED),
            refused,
            "mass {mass}"
        );
    }
    // Engaged at 120 m/s (inside at the design's mass), the tanker slowing to 110 m/s breaks
    // the receiver away, the limit named: engaged, the slow edge is the follow-up's to check,
    // so one step after the condition arrives (as its design would be loaded).
    let mut rig = Rig::engaged(config(), perturbed_nav(), MID);
    rig.nav.condition = condition(120.0, 8000.0);
    assert_eq!(rig.step_with(MID, |_| {}).mode, Mode::Approach);
    assert!(rig.ctl.follow_schedule());
    rig.nav.condition = slow_high;
    let out = rig.step_with(MID, |_| {});
    assert_eq!((out.mode, out.envelope_error), (Mode::Approach, None));
    assert!(
        rig.ctl.follow_schedule(),
        "below the edge the grid's design is flown"
    );
    let out = rig.step_with(MID, |_| {});
    assert_eq!(
        (out.mode, out.breakaway_reason, out.envelope_error),
        (
            Mode::Breakaway,
            Some(BreakawayReason::OutsideDockingEnvelope),
            Some(ScheduleError::AngleOfAttackHigh)
        )
    );
}

#[test]
fn leaving_the_docking_envelope_engaged_breaks_away_on_the_last_design() {
    let mut rig = Rig::engaged(config(), perturbed_nav(), MID);
    rig.nav.condition = condition(120.0, 8500.0);
    let out = rig.step_with(MID, |_| {});
    assert_eq!(
        (out.mode, out.breakaway_reason, out.envelope_error),
        (
            Mode::Breakaway,
            Some(BreakawayReason::OutsideDockingEnvelope),
            Some(ScheduleError::AltitudeHigh)
        )
    );
    // Navigation is valid: the breakaway is flown closed loop, not open loop.
    assert!(!out.status.contains(StatusFlags::OPEN_LOOP));
    assert!(out.command.as_array().iter().all(|v| v.is_finite()));
}

#[test]
fn a_non_finite_flight_condition_is_a_navigation_error_held_then_a_breakaway() {
    let cfg = config();
    let mut rig = Rig::engaged(cfg, perturbed_nav(), MID);
    rig.nav.condition = condition(f32::NAN, 3000.0);
    for _ in 0..cfg.modes.hold_limit_steps {
        let out = rig.step_with(MID, |_| {});
        assert_eq!(
            (out.mode, out.nav_error),
            (Mode::Approach, Some(NavError::NonFinite))
        );
        assert!(out.status.contains(StatusFlags::NAV_HELD));
        assert_eq!(
            out.envelope_error, None,
            "the schedule keeps the last valid condition"
        );
    }
    let out = rig.step_with(MID, |_| {});
    assert_eq!(
        (out.mode, out.breakaway_reason),
        (Mode::Breakaway, Some(BreakawayReason::NavLost))
    );
}

/// The attitude-command loop flies only through an autopilot that follows its setpoints: an
/// engage without it is refused (named, counted); an engaged receiver whose autopilot leaves
/// that mode breaks away, named. The surface loops ignore the discrete.
#[test]
fn the_attitude_loop_engages_only_with_the_autopilot_following_and_breaks_away_when_it_leaves() {
    use ibvs_core::attitude::{Command, InnerLoop};
    let attitude = ControllerConfig {
        inner_loop: InnerLoop::Attitude,
        ..config()
    };
    let mut rig = Rig::new(attitude);
    let out = rig.step_with(MID, |i| {
        i.request = ModeRequest::Engage;
        i.autopilot_ready = false;
    });
    assert_eq!(out.mode, Mode::Standby);
    assert!(out.status.contains(StatusFlags::ENGAGE_REFUSED));
    assert_eq!(rig.ctl.counters().engage_refused, 1);
    assert!(matches!(out.command, Command::Attitude(_)));
    let engaged = |m: Mode| !matches!(m, Mode::Standby | Mode::Breakaway);
    let out = rig.step_with(MID, |i| i.request = ModeRequest::Engage);
    assert!(engaged(out.mode), "{:?}", out.mode);
    for _ in 0..10 {
        let out = rig.step_with(MID, |_| {});
        assert!(engaged(out.mode), "{:?}", out.mode);
    }
    let out = rig.step_with(MID, |i| i.autopilot_ready = false);
    assert_eq!(
        (out.mode, out.breakaway_reason),
        (Mode::Breakaway, Some(BreakawayReason::AutopilotMode))
    );
    // The surface loops do not depend on an autopilot.
    let mut rig = Rig::new(config());
    let out = rig.step_with(MID, |i| {
        i.request = ModeRequest::Engage;
        i.autopilot_ready = false;
    });
    assert!(engaged(out.mode), "{:?}", out.mode);
    let out = rig.step_with(MID, |i| i.autopilot_ready = false);
    assert!(engaged(out.mode), "{:?}", out.mode);
}

/// The command of the first engaged step of the refuelling procedure configured with gross
/// mass `mass_factor` (the same state and frame for every mass).
fn refuelling_command_at_mass(mass_factor: f32) -> [f32; 4] {
    let mut cfg = ControllerConfig::default();
    cfg.measurement.frozen_frame_limit = u16::MAX;
    cfg.mass_factor = mass_factor;
    let mut rig = Rig::new(cfg);
    rig.nav = perturbed_nav();
    rig.step_with(MID, |_| {});
    let out = rig.step_with(MID, |i| i.request = ModeRequest::Engage);
    assert_eq!(out.mode, Mode::PreContact);
    rig.step_with(MID, |_| {}).command.as_array()
}

#[test]
fn the_refuelling_procedure_flies_its_light_design_below_the_switch_mass_and_its_first_above() {
    let switch = LIGHT_DESIGN_BELOW_MASS_FACTOR;
    assert!(switch > REFUEL_LIGHT_MASS_FACTOR && switch < 1.0);
    let first = refuelling_command_at_mass(1.0);
    assert_eq!(refuelling_command_at_mass(switch), first, "at the switch");
    assert_eq!(refuelling_command_at_mass(1.25), first, "heavier");
    let light = refuelling_command_at_mass(switch.next_down());
    assert_eq!(refuelling_command_at_mass(0.85), light, "lighter still");
    assert_ne!(
        light[0], first[0],
        "another elevator gain: {light:?} vs {first:?}"
    );
    assert_ne!(
        light[2], first[2],
        "another aileron gain: {light:?} vs {first:?}"
    );
    // The paper's procedure flies its one design at any mass.
    let paper_at = |m: f32| {
        let mut cfg = config();
        cfg.mass_factor = m;
        let mut rig = Rig::new(cfg);
        rig.nav = perturbed_nav();
        rig.step_with(MID, |_| {});
        rig.step_with(MID, |i| i.request = ModeRequest::Engage);
        rig.step_with(MID, |_| {}).command.as_array()
    };
    assert_eq!(paper_at(0.85), paper_at(1.0));
}
