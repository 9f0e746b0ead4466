//! Whole-step fuzzing (a proptest stand-in for cargo-fuzz, which needs a nightly toolchain):
//! arbitrary sequences of controller inputs, directly and as bytes through the serial link's
//! frame decoder, against two properties:
//!
//! - every command is finite and inside the actuator limits, whatever the input (every
//!   `f32` of a frame and of the navigation an arbitrary bit pattern or a plausible value,
//!   arbitrary frame numbers, contact discretes and operator requests);
//! - every mode transition is one of the documented graph's (`ibvs_core::mode`, module doc,
//!   and `docs/conventions.md`, "Modes"): an independent model of the transition table is
//!   stepped beside the controller and must agree on the mode, the breakaway reason and the
//!   refused-engage bit at every step. (The model cannot know the dead-reckoned depth of the
//!   blind phase, so it accepts `PassedDroguePlane` from terminal at any step; everything
//!   else it predicts exactly.)
//!
//! The byte-level test feeds garbage, valid measurement frames and frames with a flipped byte
//! into [`FrameDecoder`] and steps the controller on every frame it accepts, as the firmware
//! does.
//!
//! CI runs `IBVS_FUZZ_CASES` sequences per property (default 256, each up to 600 steps or 40
//! chunks). The `#[ignore]`d `long_*` tests are the long fuzzing mode:
//! `IBVS_FUZZ_LONG_CASES` sequences each (default 1,000,000),
//! `cargo test --release -p ibvs-core --test fuzz_step -- --ignored`.

use ibvs_core::controller::StatusFlags;
use ibvs_core::gains::{LON, TRIM};
use ibvs_core::kinematics::lever_arm_lon;
use ibvs_core::measurement::CameraMeasurement;
use ibvs_core::mode::ModeConfig;
use ibvs_core::nav::NavSample;
use ibvs_core::wire::{FrameDecoder, MAX_FRAME_LEN, Uplink, encode_uplink};
use ibvs_core::{
    BreakawayReason, Controller, ControllerConfig, ControllerInput, ControllerOutput, Mode,
    ModeRequest, OuterLaw,
};
use proptest::prelude::*;

mod common;
use common::{bits, cases};

/// Longest input sequence, steps (longer than the blind phase's 250-step limit).
const MAX_STEPS: usize = 600;

/// `(tracked, image_x, image_y, depth_m)`: plausible, near the drogue (terminal entries with
/// small and large offsets), or arbitrary bits.
fn frame_content() -> impl Strategy<Value = (bool, f32, f32, f32)> {
    prop_oneof![
        3 => (Just(true), -0.6_f32..0.6, -0.45_f32..0.45, 0.2_f32..12.0),
        2 => (Just(true), -0.6_f32..0.6, -0.45_f32..0.45, 0.3_f32..0.75),
        2 => (any::<bool>(), bits(), bits(), bits()),
    ]
}

/// Navigation: trim (the blind phase then neither closes nor passes the plane, so its time
/// limit is reached), small perturbations, closing around the overspeed limit, or arbitrary
/// bits.
fn nav() -> impl Strategy<Value = NavSample> {
    prop_oneof![
        3 => Just(NavSample::default()),
        2 => prop::array::uniform12(-0.2_f32..0.2).prop_map(NavSample::from_array),
        1 => (1.5_f32..3.5, -0.3_f32..0.3).prop_map(|(v_mps, q_radps)| {
            let mut n = NavSample::default();
            n.lon.v_mps = v_mps;
            n.lon.q_radps = q_radps;
            n
        }),
        1 => prop::array::uniform12(bits()).prop_map(NavSample::from_array),
    ]
}

fn request() -> impl Strategy<Value = ModeRequest> {
    prop_oneof![
        20 => Just(ModeRequest::None),
        4 => Just(ModeRequest::Engage),
        1 => Just(ModeRequest::Abort),
        1 => Just(ModeRequest::Reset),
    ]
}

fn seq_step() -> impl Strategy<Value = u32> {
    prop_oneof![10 => Just(1_u32), 2 => Just(0_u32), 1 => 2_u32..6, 1 => any::<u32>()]
}

/// One input, its frame-number step and how many consecutive steps it lasts (long runs
/// reach the hold limits and the blind phase's time limit).
fn run_of_inputs() -> impl Strategy<Value = (u32, ControllerInput, usize)> {
    (
        seq_step(),
        frame_content(),
        nav(),
        prop::bool::weighted(0.2),
        request(),
        prop_oneof![8 => Just(1_usize), 3 => 2_usize..30, 1 => 240_usize..300],
    )
        .prop_map(
            |(step, (tracked, x, y, z), nav, contact, request, repeat)| {
                let input = ControllerInput {
                    measurement: CameraMeasurement {
                        seq: 0,
                        tracked,
                        image_x: x,
                        image_y: y,
                        depth_m: z,
                    },
                    nav,
                    probe_contact: contact,
                    request,
                };
                (step, input, repeat)
            },
        )
}

fn input_sequence() -> impl Strategy<Value = Vec<ControllerInput>> {
    (any::<u32>(), prop::collection::vec(run_of_inputs(), 1..60)).prop_map(|(start, runs)| {
        let mut seq = start;
        runs.into_iter()
            .flat_map(|(step, input, n)| (0..n).map(move |i| (i, step, input)))
            .take(MAX_STEPS)
            .map(|(i, step, mut input)| {
                seq = seq.wrapping_add(step);
                input.measurement.seq = seq;
                // A run's request is sent once, at its start.
                if i > 0 {
                    input.request = ModeRequest::None;
                }
                input
            })
            .collect()
    })
}

/// What the transition table allows after one step.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Allowed {
    /// Exactly this mode and reason.
    Exactly(Mode, Option<BreakawayReason>),
    /// Terminal continues, or it passed the plane (dead-reckoned depth, unknown here).
    TerminalOrPassed,
    /// The time limit, or it passed the plane first.
    TimeoutOrPassed,
}

/// An independent model of the mode table of `ibvs_core::mode`.
#[derive(Debug, Default)]
struct ModeModel {
    mode: Mode,
    reason: Option<BreakawayReason>,
    meas_invalid: u16,
    nav_invalid: u16,
    terminal_steps: u32,
    /// The last valid navigation sample (the controller flies on it while navigation is bad).
    last_nav: NavSample,
}

impl ModeModel {
    /// Checks one step of the controller against the table and follows it.
    fn step(
        &mut self,
        input: &ControllerInput,
        out: &ControllerOutput,
        cfg: &ModeConfig,
        timeout_steps: u32,
    ) -> Result<(), String> {
        use Allowed::*;
        let (nav_ok, meas_ok) = (out.nav_error.is_none(), out.measurement_error.is_none());
        if nav_ok {
            self.last_nav = input.nav;
        }
        self.nav_invalid = if nav_ok {
            0
        } else {
            self.nav_invalid.saturating_add(1)
        };
        let before = self.mode;
        let engaged = matches!(before, Mode::Approach | Mode::Terminal | Mode::Docked);
        let mut refused = false;
        let stay = Exactly(before, self.reason);
        let brk = |r| Exactly(Mode::Breakaway, Some(r));
        let allowed = if input.request == ModeRequest::Reset && before != Mode::Standby {
            Exactly(Mode::Standby, None)
        } else if engaged && input.request == ModeRequest::Abort {
            brk(BreakawayReason::Abort)
        } else if engaged && self.nav_invalid > cfg.hold_limit_steps {
            brk(BreakawayReason::NavLost)
        } else if matches!(before, Mode::Approach | Mode::Terminal)
            && camera_fwd_mps(&self.last_nav) > cfg.overspeed_mps
        {
            brk(BreakawayReason::Overspeed)
        } else {
            match before {
                Mode::Standby if input.request == ModeRequest::Engage => {
                    if meas_ok && nav_ok {
                        Exactly(Mode::Approach, None)
                    } else {
                        refused = true;
                        stay
                    }
                }
                Mode::Standby | Mode::Breakaway => stay,
                Mode::Approach if !meas_ok => {
                    self.meas_invalid = self.meas_invalid.saturating_add(1);
                    if self.meas_invalid > cfg.hold_limit_steps {
                        brk(BreakawayReason::MeasurementLost)
                    } else {
                        stay
                    }
                }
                Mode::Approach => {
                    self.meas_invalid = 0;
                    let t = out.target;
                    if t.depth_m <= cfg.terminal_depth_m {
                        if t.radial_offset_m() > cfg.terminal_max_offset_m {
                            brk(BreakawayReason::PredictedMiss)
                        } else {
                            Exactly(Mode::Terminal, None)
                        }
                    } else {
                        stay
                    }
                }
                Mode::Terminal => {
                    self.terminal_steps += 1;
                    if input.probe_contact {
                        Exactly(Mode::Docked, None)
                    } else if self.terminal_steps > timeout_steps {
                        TimeoutOrPassed
                    } else {
                        TerminalOrPassed
                    }
                }
                Mode::Docked if !input.probe_contact => brk(BreakawayReason::ContactLost),
                Mode::Docked => stay,
            }
        };
        let got = (out.mode, out.breakaway_reason);
        let passed = (Mode::Breakaway, Some(BreakawayReason::PassedDroguePlane));
        let ok = match allowed {
            Exactly(m, r) => got == (m, r),
            TerminalOrPassed => got == (Mode::Terminal, None) || got == passed,
            TimeoutOrPassed => {
                got == (Mode::Breakaway, Some(BreakawayReason::TerminalTimeout)) || got == passed
            }
        };
        if !ok {
            return Err(format!(
                "{before:?} -> {got:?}, the table allows {allowed:?} (model {self:?})"
            ));
        }
        if out.status.contains(StatusFlags::ENGAGE_REFUSED) != refused {
            return Err(format!("engage refused bit: expected {refused}"));
        }
        if out.mode != before {
            self.meas_invalid = 0;
            self.terminal_steps = 0;
        }
        (self.mode, self.reason) = got;
        Ok(())
    }
}

/// The camera's forward speed relative to the tanker for a navigation sample, m/s: the
/// airspeed perturbation plus the pitch rate times the lever arm of the default camera
/// position (`docs/conventions.md`; the generated output row is `[0, 1, 0, 0, 0]` at the CG).
/// Single-precision, one rounding, as the controller's `C x` gives it.
fn camera_fwd_mps(nav: &NavSample) -> f32 {
    let cam = ControllerConfig::default().camera.position_body_m;
    let fwd_per_q = lever_arm_lon(cam, TRIM.theta_rad)[1][3];
    assert_eq!(LON.c_cg[1], [0.0, 1.0, 0.0, 0.0, 0.0], "output row changed");
    nav.lon.v_mps + fwd_per_q * nav.lon.q_radps
}

/// Steps of the blind phase's time limit, as the core rounds it.
fn timeout_steps(cfg: &ControllerConfig) -> u32 {
    (cfg.modes.terminal_timeout_s / Controller::PERIOD_S).round() as u32
}

fn check_output(
    cfg: &ControllerConfig,
    model: &mut ModeModel,
    k: usize,
    input: &ControllerInput,
    out: &ControllerOutput,
) -> Result<(), TestCaseError> {
    let act = cfg.actuators;
    for (i, v) in out.command.as_array().into_iter().enumerate() {
        prop_assert!(
            v.is_finite() && act.min[i] <= v && v <= act.max[i],
            "step {}: command {} = {} for {:?}",
            k,
            i,
            v,
            input
        );
    }
    prop_assert!(!out.status.contains(StatusFlags::NON_FINITE_COMMAND));
    prop_assert!(out.v_des.is_finite());
    model
        .step(input, out, &cfg.modes, timeout_steps(cfg))
        .map_err(|e| TestCaseError::fail(format!("step {k}: {e}; input {input:?}")))
}

fn check_sequence(cfg: ControllerConfig, inputs: &[ControllerInput]) -> Result<(), TestCaseError> {
    let mut ctl = Controller::new(cfg).expect("valid configuration");
    let mut model = ModeModel::default();
    for (k, input) in inputs.iter().enumerate() {
        let out = ctl.step(input);
        check_output(&cfg, &mut model, k, input, &out)?;
    }
    Ok(())
}

/// What goes on the wire: garbage, a measurement frame, or one with a byte changed.
#[derive(Debug, Clone)]
enum Chunk {
    Garbage(Vec<u8>),
    Frame(Uplink),
    Flipped(Uplink, usize, u8),
}

fn chunks() -> impl Strategy<Value = Vec<Chunk>> {
    fn frame() -> impl Strategy<Value = Uplink> {
        (any::<u32>(), run_of_inputs()).prop_map(|(seq, (_, input, _))| Uplink {
            seq,
            input: ControllerInput {
                measurement: CameraMeasurement {
                    seq,
                    ..input.measurement
                },
                ..input
            },
        })
    }
    let chunk = prop_oneof![
        1 => prop::collection::vec(any::<u8>(), 0..80).prop_map(Chunk::Garbage),
        4 => frame().prop_map(Chunk::Frame),
        1 => (frame(), any::<usize>(), 1_u8..=255).prop_map(|(u, i, m)| Chunk::Flipped(u, i, m)),
    ];
    prop::collection::vec(chunk, 1..40)
}

fn bytes_of(chunks: &[Chunk]) -> Vec<u8> {
    let mut out = Vec::new();
    for c in chunks {
        let mut buf = [0_u8; MAX_FRAME_LEN];
        match c {
            Chunk::Garbage(g) => out.extend_from_slice(g),
            Chunk::Frame(u) => out.extend_from_slice(encode_uplink(u, &mut buf).expect("fits")),
            Chunk::Flipped(u, i, m) => {
                let mut f = encode_uplink(u, &mut buf).expect("fits").to_vec();
                let at = i % f.len();
                f[at] ^= m;
                out.extend_from_slice(&f);
            }
        }
    }
    out
}

/// Feeds the bytes to the decoder and steps the controller on every accepted frame.
fn check_wire(cfg: ControllerConfig, bytes: &[u8]) -> Result<(), TestCaseError> {
    let mut ctl = Controller::new(cfg).expect("valid configuration");
    let mut model = ModeModel::default();
    let mut decoder = FrameDecoder::new();
    let mut k = 0;
    for &b in bytes {
        let uplink = match decoder.feed(b) {
            Some(Ok(payload)) => payload.uplink().ok(),
            _ => None,
        };
        if let Some(u) = uplink {
            let out = ctl.step(&u.input);
            check_output(&cfg, &mut model, k, &u.input, &out)?;
            k += 1;
        }
    }
    Ok(())
}

fn pbvs() -> ControllerConfig {
    ControllerConfig {
        law: OuterLaw::Pbvs,
        ..ControllerConfig::default()
    }
}

proptest! {
    #![proptest_config(cases("IBVS_FUZZ_CASES", 256))]

    #[test]
    fn ibvs_commands_stay_in_limits_and_modes_follow_the_table(inputs in input_sequence()) {
        check_sequence(ControllerConfig::default(), &inputs)?;
    }

    #[test]
    fn pbvs_commands_stay_in_limits_and_modes_follow_the_table(inputs in input_sequence()) {
        check_sequence(pbvs(), &inputs)?;
    }

    #[test]
    fn bytes_through_the_link_decoder_into_the_step(c in chunks()) {
        check_wire(ControllerConfig::default(), &bytes_of(&c))?;
    }
}

mod long {
    use super::*;

    proptest! {
        #![proptest_config(cases("IBVS_FUZZ_LONG_CASES", 1_000_000))]

        #[test]
        #[ignore = "long fuzzing run: cargo test --release -- --ignored"]
        fn long_step_sequences(inputs in input_sequence()) {
            check_sequence(ControllerConfig::default(), &inputs)?;
            check_sequence(pbvs(), &inputs)?;
        }

        #[test]
        #[ignore = "long fuzzing run: cargo test --release -- --ignored"]
        fn long_link_bytes(c in chunks()) {
            check_wire(ControllerConfig::default(), &bytes_of(&c))?;
        }
    }
}
