//! Property tests of [`Controller::step`] on arbitrary input sequences.
//!
//! Every `f32` field of the input is drawn from a mix of ordinary values, huge values, ±0,
//! subnormals, NaN and ±inf; sequence numbers, discretes and operator requests are arbitrary.
//! For every step of every sequence, under the refuelling procedure (the default) and the
//! paper's procedure with IBVS and with PBVS:
//! - `step` does not panic and every command is finite and inside `cfg.actuators` (the
//!   attitude-command loop's setpoints inside `cfg.attitude`'s limits and the throttle's);
//! - the desired velocity is finite and inside the velocity limits (breakaway included);
//! - the integrators are finite and inside `integrator_limit_m`;
//! - the counters are consistent: one step counted per call, every frame counted exactly once
//!   (valid or under one error), and the output's error matches the counter that moved.
//!
//! And with a plausible frame, plausible navigation and `Engage`, a fresh controller is in
//! approach (paper) or pre-contact (refuelling) after its first step.
//!
//! Arbitrary inputs come in runs (one input repeated for up to 40 steps, its sequence number
//! advancing) so that the hold limits, the terminal phase and docking of the paper's
//! procedure are reached, not only standby (checked by `the_generated_sequences_reach_...`);
//! the navigation's flight condition moves inside and outside the docking envelope, and the
//! gain schedule's follow-up runs after every step, as in the flight loop. Arbitrary inputs
//! never take the refuelling procedure past its station (its dwell wants a second of steady,
//! consistent frames), so it is also driven through refuelling sorties (the generator of
//! `common/sortie.rs`, shared with `fuzz_step.rs`) with arbitrary inputs of the runs above
//! dropped in at random steps: every engaged mode is flown, each checked to be reached
//! (`refuelling_sorties_reach_every_engaged_mode`).
//! 256 cases per property by default (under a second in a debug build); set `PROPTEST_CASES`
//! for a longer run.

use ibvs_core::attitude::Command;
use ibvs_core::config::largest_schedule_trim_angle_rad;
use ibvs_core::controller::StatusFlags;
use ibvs_core::measurement::{CameraMeasurement, MeasurementError};
use ibvs_core::nav::{FlightCondition, NavSample};
use ibvs_core::schedule::MassEnvelope;
use ibvs_core::{
    Controller, ControllerConfig, ControllerInput, Counters, Mode, ModeRequest, OuterLaw, Procedure,
};
use proptest::prelude::*;
use proptest::test_runner::Config;

#[path = "common/sortie.rs"]
mod sortie;

/// Longest generated input sequence.
const MAX_STEPS: usize = 300;

fn config() -> Config {
    let cases = std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(256);
    Config::with_cases(cases)
}

fn refuelling_config() -> ControllerConfig {
    ControllerConfig::default()
}

fn ibvs_config() -> ControllerConfig {
    ControllerConfig::paper()
}

fn attitude_config() -> ControllerConfig {
    ControllerConfig {
        inner_loop: ibvs_core::attitude::InnerLoop::Attitude,
        ..ControllerConfig::default()
    }
}

fn pbvs_config() -> ControllerConfig {
    ControllerConfig {
        law: OuterLaw::Pbvs,
        ..ControllerConfig::paper()
    }
}

/// Positive and negative subnormals.
fn subnormal() -> impl Strategy<Value = f32> {
    (1u32..0x0080_0000, any::<bool>()).prop_map(|(bits, negative)| {
        let v = f32::from_bits(bits);
        if negative { -v } else { v }
    })
}

/// Values that break naive arithmetic: non-finite, signed zeros, subnormals, huge.
fn special() -> impl Strategy<Value = f32> {
    prop_oneof![
        Just(f32::NAN),
        Just(-f32::NAN),
        Just(f32::INFINITY),
        Just(f32::NEG_INFINITY),
        Just(0.0_f32),
        Just(-0.0_f32),
        subnormal(),
        Just(f32::MAX),
        Just(f32::MIN),
        prop_oneof![1e6_f32..1e38, -1e38_f32..-1e6],
        any::<f32>(),
    ]
}

/// A field whose ordinary values lie in `ordinary`, mixed with [`special`] ones.
fn field(lo: f32, hi: f32) -> impl Strategy<Value = f32> {
    prop_oneof![3 => lo..=hi, 1 => special()]
}

/// Navigation inside the default envelope: mostly the small perturbations of formation
/// flight (speed within 1.5 m/s of the tanker's, rates within 0.1 rad/s, so that approaches
/// run on to the terminal phase and docking), sometimes anything the envelope accepts (up to
/// 25 m/s and 1.4 rad/s: overspeed breakaways), at the design's flight condition or another
/// inside the docking envelope (at the design's gross mass, the configurations').
fn plausible_nav() -> impl Strategy<Value = NavSample> {
    let small = (
        (
            -100.0_f32..100.0,
            -50.0_f32..50.0,
            -0.1_f32..0.1,
            -1.5_f32..1.5,
            -0.1_f32..0.1,
            -0.1_f32..0.1,
        ),
        (
            -50.0_f32..50.0,
            -0.1_f32..0.1,
            -0.2_f32..0.2,
            -0.05_f32..0.05,
            -0.1_f32..0.1,
            -0.1_f32..0.1,
        ),
    );
    let large = (
        (
            -100.0_f32..100.0,
            -50.0_f32..50.0,
            -0.3_f32..0.3,
            -25.0_f32..25.0,
            -0.3_f32..0.3,
            -1.4_f32..1.4,
        ),
        (
            -50.0_f32..50.0,
            -0.3_f32..0.3,
            -0.7_f32..0.7,
            -0.15_f32..0.15,
            -1.4_f32..1.4,
            -1.4_f32..1.4,
        ),
    );
    let at = |(true_airspeed_mps, altitude_m)| FlightCondition {
        true_airspeed_mps,
        altitude_m,
    };
    // Inside the docking envelope of the configurations' gross mass (the design's): above
    // its slow edge.
    let docking = MassEnvelope::new(1.0);
    let condition = prop_oneof![
        8 => Just(FlightCondition::default()),
        1 => (100.0_f32..=170.0, 500.0_f32..=8000.0)
            .prop_map(at)
            .prop_filter("inside the docking envelope", move |c| docking.check(*c).is_ok()),
    ];
    (prop_oneof![4 => small, 1 => large], condition).prop_map(|((lon, lat), condition)| NavSample {
        condition,
        ..NavSample::from_array([
            lon.0, lon.1, lon.2, lon.3, lon.4, lon.5, lat.0, lat.1, lat.2, lat.3, lat.4, lat.5,
        ])
    })
}

/// [`plausible_nav`] at a flight condition anywhere from 50 to 250 m/s and -1,000 to
/// 12,000 m: mostly outside the docking envelope.
fn nav_anywhere() -> impl Strategy<Value = NavSample> {
    (plausible_nav(), 50.0_f32..250.0, -1000.0_f32..12_000.0).prop_map(|(n, v, h)| NavSample {
        condition: FlightCondition {
            true_airspeed_mps: v,
            altitude_m: h,
        },
        ..n
    })
}

/// Navigation with every field drawn from [`field`], the flight condition too (inside or
/// outside the docking envelope, or not a number): often invalid.
fn wild_nav() -> impl Strategy<Value = NavSample> {
    let f = || field(-2.0, 2.0);
    (
        (f(), f(), f(), f(), f(), f()),
        (f(), f(), f(), f(), f(), f()),
        (field(50.0, 250.0), field(-1000.0, 12_000.0)),
    )
        .prop_map(|(lon, lat, (true_airspeed_mps, altitude_m))| NavSample {
            condition: FlightCondition {
                true_airspeed_mps,
                altitude_m,
            },
            ..NavSample::from_array([
                lon.0, lon.1, lon.2, lon.3, lon.4, lon.5, lat.0, lat.1, lat.2, lat.3, lat.4, lat.5,
            ])
        })
}

/// Frame content `(tracked, image_x, image_y, depth_m)`: a plausible tracked frame (depth
/// reaching into the terminal range) or one with every field arbitrary.
fn frame_content() -> impl Strategy<Value = (bool, f32, f32, f32)> {
    prop_oneof![
        2 => (Just(true), -0.6_f32..0.6, -0.45_f32..0.45, 0.2_f32..12.0),
        1 => (
            prop::bool::weighted(0.8),
            field(-0.8, 0.8),
            field(-0.6, 0.6),
            field(-5.0, 60.0),
        ),
    ]
}

/// Sequence-number step from the previous frame: mostly the next frame, also repeats, gaps
/// and arbitrary jumps (half of which are "late" frames).
fn seq_step() -> impl Strategy<Value = u32> {
    prop_oneof![8 => Just(1_u32), 2 => Just(0_u32), 1 => 2_u32..6, 1 => any::<u32>()]
}

fn request() -> impl Strategy<Value = ModeRequest> {
    prop_oneof![
        12 => Just(ModeRequest::None),
        3 => Just(ModeRequest::Engage),
        1 => Just(ModeRequest::Abort),
        1 => Just(ModeRequest::Reset),
    ]
}

/// One step's input with the sequence number still relative (a step from the last one),
/// and how many consecutive steps it is repeated for (so that long runs of bad frames or bad
/// navigation, which the hold limits are about, are common).
fn relative_input() -> impl Strategy<Value = (u32, ControllerInput, usize)> {
    (
        seq_step(),
        frame_content(),
        prop_oneof![15 => plausible_nav(), 1 => nav_anywhere(), 10 => wild_nav()],
        (prop::bool::weighted(0.3), prop::bool::weighted(0.95)),
        request(),
        prop_oneof![6 => Just(1_usize), 1 => 2_usize..40],
    )
        .prop_map(
            |(
                step,
                (tracked, x, y, depth),
                nav,
                (probe_contact, autopilot_ready),
                request,
                repeat,
            )| {
                let input = ControllerInput {
                    measurement: CameraMeasurement {
                        seq: 0,
                        tracked,
                        image_x: x,
                        image_y: y,
                        depth_m: depth,
                        probe_tip: None,
                    },
                    nav,
                    probe_contact,
                    autopilot_ready,
                    request,
                };
                (step, input, repeat)
            },
        )
}

/// An arbitrary input sequence of at most [`MAX_STEPS`] steps, with absolute, wrapping
/// sequence numbers (a repeated input advances its sequence number by its step each time).
fn input_sequence() -> impl Strategy<Value = Vec<ControllerInput>> {
    (
        any::<u32>(),
        prop::collection::vec(relative_input(), 1..=MAX_STEPS / 2),
    )
        .prop_map(|(start, runs)| {
            let mut seq = start;
            runs.into_iter()
                .flat_map(|(step, input, repeat)| core::iter::repeat_n((step, input), repeat))
                .take(MAX_STEPS)
                .map(|(step, mut input)| {
                    seq = seq.wrapping_add(step);
                    input.measurement.seq = seq;
                    input
                })
                .collect()
        })
}

/// A refuelling sortie ([`sortie::sortie_sequence`] for `cfg`'s camera) with up to 8 of its
/// steps replaced by arbitrary inputs of [`relative_input`] (special values in the frame and
/// the navigation, requests), each keeping the frame number of the step it replaces (an
/// arbitrary jump would leave every later frame of the sortie out of order: the arbitrary
/// numbering is the other properties'): the invariants must hold in whatever mode they land.
fn wild_sortie(cfg: ControllerConfig) -> impl Strategy<Value = Vec<ControllerInput>> {
    (
        sortie::sortie_sequence(cfg),
        prop::collection::vec((any::<prop::sample::Index>(), relative_input()), 0..8),
    )
        .prop_map(|(mut inputs, wild)| {
            for (at, (_, input, _)) in wild {
                let k = at.index(inputs.len());
                inputs[k] = ControllerInput {
                    measurement: CameraMeasurement {
                        seq: inputs[k].measurement.seq,
                        ..input.measurement
                    },
                    ..input
                };
            }
            inputs
        })
}

/// Per-error measurement counters, in [`MeasurementError`] declaration order.
fn error_counters(c: &Counters) -> [u32; 8] {
    [
        c.not_tracked,
        c.non_finite,
        c.depth_not_positive,
        c.depth_too_large,
        c.outside_fov,
        c.repeated,
        c.out_of_order,
        c.frozen,
    ]
}

fn error_index(e: MeasurementError) -> usize {
    match e {
        MeasurementError::NotTracked => 0,
        MeasurementError::NonFinite => 1,
        MeasurementError::DepthNotPositive => 2,
        MeasurementError::DepthTooLarge => 3,
        MeasurementError::OutsideFieldOfView => 4,
        MeasurementError::Repeated => 5,
        MeasurementError::OutOfOrder => 6,
        MeasurementError::Frozen => 7,
    }
}

/// Runs `inputs` through a controller built from `cfg`, checking every invariant after every
/// step.
fn check_invariants(
    cfg: ControllerConfig,
    inputs: &[ControllerInput],
) -> Result<(), TestCaseError> {
    let mut ctl = Controller::new(cfg).expect("valid configuration");
    let (act, vl, md) = (cfg.actuators, cfg.velocity_limits, cfg.modes);
    let mut before = *ctl.counters();
    for (k, input) in inputs.iter().enumerate() {
        let out = ctl.step(input);
        // The flight loop's follow-up (the gain schedule), as the firmware runs it.
        ctl.follow_schedule();
        let after = *ctl.counters();
        let at = format!("step {k}, input {input:?}, output {out:?}");

        match out.command {
            Command::Surfaces(c) => {
                for (i, v) in c.as_array().into_iter().enumerate() {
                    prop_assert!(v.is_finite(), "command {i} not finite: {at}");
                    prop_assert!(
                        act.min[i] <= v && v <= act.max[i],
                        "command {i} = {v} outside [{}, {}]: {at}",
                        act.min[i],
                        act.max[i]
                    );
                }
            }
            Command::Attitude(a) => {
                let att = &cfg.attitude;
                for v in [a.roll_rad, a.pitch_rad, a.yaw_rad, a.throttle] {
                    prop_assert!(v.is_finite(), "setpoint not finite: {at}");
                }
                prop_assert!(a.roll_rad.abs() <= att.max_bank_rad, "bank: {at}");
                prop_assert!(
                    a.pitch_rad.abs()
                        <= largest_schedule_trim_angle_rad() + att.max_pitch_offset_rad,
                    "pitch: {at}"
                );
                prop_assert!(
                    act.min[1] <= a.throttle && a.throttle <= act.max[1],
                    "throttle: {at}"
                );
            }
        }
        prop_assert_eq!(
            matches!(out.command, Command::Attitude(_)),
            cfg.inner_loop == ibvs_core::attitude::InnerLoop::Attitude,
            "the configured inner loop's command: {}",
            at
        );
        prop_assert!(
            !out.status.contains(StatusFlags::NON_FINITE_COMMAND),
            "a computed command was not finite: {at}"
        );

        let v = out.v_des;
        prop_assert!(v.is_finite(), "v_des not finite: {at}");
        prop_assert!(v.x_right_mps.abs() <= vl.max_lateral_mps, "v_des.x: {at}");
        prop_assert!(v.y_down_mps.abs() <= vl.max_vertical_mps, "v_des.y: {at}");
        // Backing off: the breakaway's speed, or (refuelling) at most the closing limit.
        let aft = md.breakaway_aft_mps.max(vl.max_closing_mps);
        prop_assert!(
            -aft <= v.z_fwd_mps && v.z_fwd_mps <= vl.max_closing_mps,
            "v_des.z: {at}"
        );

        for q in ctl.integrators_m() {
            prop_assert!(
                q.is_finite() && q.abs() <= cfg.integrator_limit_m,
                "integrator {q}: {at}"
            );
        }

        prop_assert_eq!(out.mode, ctl.mode());
        prop_assert_eq!(
            out.breakaway_reason.is_some(),
            out.mode == Mode::Breakaway,
            "breakaway iff a reason: {}",
            at
        );

        let steps = u32::try_from(k + 1).expect("short sequence");
        prop_assert_eq!(after.steps, steps);
        prop_assert_eq!(out.step, steps);
        let errors = error_counters(&after);
        prop_assert_eq!(
            errors.iter().sum::<u32>() + after.frames_valid,
            after.steps,
            "every frame counted once: {:?}",
            after
        );
        let moved: Vec<usize> = (0..errors.len())
            .filter(|&i| errors[i] != error_counters(&before)[i])
            .collect();
        match out.measurement_error {
            Some(e) => {
                prop_assert_eq!(&moved, &vec![error_index(e)], "{}", at);
                prop_assert_eq!(
                    errors[error_index(e)],
                    error_counters(&before)[error_index(e)] + 1
                );
                prop_assert_eq!(after.frames_valid, before.frames_valid);
            }
            None => {
                prop_assert!(moved.is_empty(), "{}", at);
                prop_assert_eq!(after.frames_valid, before.frames_valid + 1);
            }
        }
        before = after;
    }
    Ok(())
}

/// A frame a tracker could produce with the drogue in view between 2 and 10 m.
fn plausible_frame() -> impl Strategy<Value = CameraMeasurement> {
    (any::<u32>(), -0.6_f32..0.6, -0.45_f32..0.45, 2.0_f32..10.0).prop_map(|(seq, x, y, z)| {
        CameraMeasurement {
            seq,
            tracked: true,
            image_x: x,
            image_y: y,
            depth_m: z,
            probe_tip: None,
        }
    })
}

fn engages_on_first_step(
    cfg: ControllerConfig,
    measurement: CameraMeasurement,
    nav: NavSample,
) -> Result<(), TestCaseError> {
    let mut ctl = Controller::new(cfg).expect("valid configuration");
    let out = ctl.step(&ControllerInput {
        measurement,
        nav,
        probe_contact: false,
        autopilot_ready: true,
        request: ModeRequest::Engage,
    });
    let engaged = match cfg.procedure {
        Procedure::Paper => Mode::Approach,
        Procedure::Refuelling => Mode::PreContact,
    };
    prop_assert_eq!(out.mode, engaged, "{:?}", out);
    prop_assert_eq!(out.measurement_error, None);
    prop_assert_eq!(out.nav_error, None);
    prop_assert!(!out.status.contains(StatusFlags::ENGAGE_REFUSED));
    prop_assert_eq!(ctl.counters().engage_refused, 0);
    Ok(())
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn refuelling_step_keeps_its_invariants_on_arbitrary_inputs(inputs in input_sequence()) {
        check_invariants(refuelling_config(), &inputs)?;
    }

    #[test]
    fn refuelling_sorties_keep_their_invariants_in_every_mode(
        inputs in wild_sortie(refuelling_config()),
    ) {
        check_invariants(refuelling_config(), &inputs)?;
    }

    #[test]
    fn refuelling_engages_on_the_first_plausible_step(
        m in plausible_frame(),
        nav in plausible_nav(),
    ) {
        engages_on_first_step(refuelling_config(), m, nav)?;
    }

    #[test]
    fn attitude_step_keeps_its_invariants_on_arbitrary_inputs(inputs in input_sequence()) {
        check_invariants(attitude_config(), &inputs)?;
    }

    #[test]
    fn attitude_sorties_keep_their_invariants_in_every_mode(
        inputs in wild_sortie(attitude_config()),
    ) {
        check_invariants(attitude_config(), &inputs)?;
    }

    #[test]
    fn ibvs_step_keeps_its_invariants_on_arbitrary_inputs(inputs in input_sequence()) {
        check_invariants(ibvs_config(), &inputs)?;
    }

    #[test]
    fn pbvs_step_keeps_its_invariants_on_arbitrary_inputs(inputs in input_sequence()) {
        check_invariants(pbvs_config(), &inputs)?;
    }

    #[test]
    fn ibvs_engages_on_the_first_plausible_step(m in plausible_frame(), nav in plausible_nav()) {
        engages_on_first_step(ibvs_config(), m, nav)?;
    }

    #[test]
    fn pbvs_engages_on_the_first_plausible_step(m in plausible_frame(), nav in plausible_nav()) {
        engages_on_first_step(pbvs_config(), m, nav)?;
    }
}

/// What the generated sequences reach under the paper's IBVS law: the modes, how many
/// sequences end in an overspeed breakaway, how many leave the docking envelope. The header's promise (the hold limits, the
/// terminal phase and docking are reached, not only standby and early breakaways) checked.
#[test]
fn the_generated_sequences_reach_the_terminal_phase_and_docking_not_mostly_overspeed() {
    use ibvs_core::BreakawayReason;
    use proptest::strategy::ValueTree;
    use proptest::test_runner::{RngAlgorithm, TestRng, TestRunner};
    let mut runner = TestRunner::new_with_rng(
        Config::default(),
        TestRng::from_seed(RngAlgorithm::ChaCha, &[3; 32]),
    );
    let strategy = input_sequence();
    let (cases, mut terminal, mut docked, mut overspeed, mut outside) = (256, 0, 0, 0, 0);
    for _ in 0..cases {
        let inputs = strategy.new_tree(&mut runner).expect("a case").current();
        let mut ctl = Controller::new(ibvs_config()).expect("valid configuration");
        let (mut t, mut d, mut e, mut last) = (false, false, false, None);
        for input in &inputs {
            let out = ctl.step(input);
            ctl.follow_schedule();
            t |= out.mode == Mode::Terminal;
            d |= out.mode == Mode::Docked;
            e |= out.envelope_error.is_some();
            last = out.breakaway_reason;
        }
        terminal += usize::from(t);
        docked += usize::from(d);
        overspeed += usize::from(last == Some(BreakawayReason::Overspeed));
        outside += usize::from(e);
    }
    // Measured with this seed: terminal 33, docked 22, overspeed 17, outside the envelope
    // 196 of 256 (with speeds of up to 25 m/s in every plausible sample, 167 of 256 ended in
    // an overspeed breakaway).
    println!(
        "of {cases}: terminal {terminal}, docked {docked}, overspeed {overspeed}, outside the envelope {outside}"
    );
    assert!(
        terminal >= 10 && docked >= 5,
        "terminal {terminal}, docked {docked} of {cases}"
    );
    assert!(
        overspeed < cases / 4,
        "{overspeed} of {cases} end in an overspeed breakaway"
    );
    assert!(
        outside >= 10,
        "{outside} of {cases} sequences leave the docking envelope"
    );
}

/// The refuelling sorties of the invariants' property (with their arbitrary steps) fly every
/// engaged mode of the procedure: the property checks the invariants in pre-contact, the
/// contact approach, the capture, docked, the missed approach and breakaway, not only at the
/// station. 256 sequences from a fixed seed, as the property draws them.
#[test]
fn refuelling_sorties_reach_every_engaged_mode() {
    use proptest::strategy::ValueTree;
    use proptest::test_runner::{RngAlgorithm, TestRng, TestRunner};
    let mut runner = TestRunner::new_with_rng(
        Config::default(),
        TestRng::from_seed(RngAlgorithm::ChaCha, &[5; 32]),
    );
    let strategy = wild_sortie(refuelling_config());
    let engaged = [
        Mode::PreContact,
        Mode::Approach,
        Mode::Terminal,
        Mode::Docked,
        Mode::MissedApproach,
        Mode::Breakaway,
    ];
    let cases = 256;
    let mut reached = [0_usize; 6];
    for _ in 0..cases {
        let inputs = strategy.new_tree(&mut runner).expect("a case").current();
        let mut ctl = Controller::new(refuelling_config()).expect("valid configuration");
        let mut seen = [false; 6];
        for input in &inputs {
            let out = ctl.step(input);
            ctl.follow_schedule();
            for (s, m) in seen.iter_mut().zip(engaged) {
                *s |= out.mode == m;
            }
        }
        for (r, s) in reached.iter_mut().zip(seen) {
            *r += usize::from(s);
        }
    }
    let counts: Vec<(Mode, usize)> = engaged.into_iter().zip(reached).collect();
    println!("sequences reaching each mode, of {cases}: {counts:?}");
    // Measured with this seed: pre-contact 254 (two sequences lose their engage to an
    // arbitrary step), approach 132, capture 84, docked 44, missed approach 54, breakaway 225.
    // The floor is the rarest's (docked, 17 %) less four standard deviations of its binomial
    // spread over 256 sequences (6.0): a generator or a controller that stops flying a mode
    // fails, not a reshuffle of the draws.
    for (mode, n) in counts {
        assert!(n >= 20, "only {n} of {cases} sequences reach {mode:?}");
    }
}
