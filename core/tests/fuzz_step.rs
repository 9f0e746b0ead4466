//! Whole-step fuzzing (a proptest stand-in for cargo-fuzz, which needs a nightly toolchain):
//! arbitrary sequences of controller inputs, directly and as bytes through the serial link's
//! frame decoder, against two properties:
//!
//! - every command is finite and inside the actuator limits, whatever the input (every
//!   `f32` of a frame and of the navigation an arbitrary bit pattern or a plausible value,
//!   arbitrary frame numbers, contact discretes and operator requests);
//! - every mode transition is one of the documented graph's (`ibvs_core::mode`, module doc,
//!   and `docs/conventions.md`, "Modes"), for both procedures: an independent model of the
//!   transition tables (`common/mode_model.rs`) is stepped beside the controller and must
//!   agree on the mode, the breakaway reason, the refused-engage bit, the measurement's and
//!   the navigation's errors and (refuelling) the attempt and the no-go reason at every
//!   step. The model reads only the inputs: it computes in `f64`, by its own formulas, the
//!   frame's and the navigation's validity, the docking envelope and the scheduled trim, the
//!   tracked point's forward speed and the probe tip's velocity, the drogue estimator with
//!   its gate, the predicted miss and the drogue's RMS speed. (A decision within a relative
//!   1e-4 of its threshold, where single precision may fall either way, is followed both
//!   ways; so is the paper's blind phase, whose dead-reckoned depth the model does not keep:
//!   from terminal it accepts `PassedDroguePlane` at any step.)
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
use ibvs_core::measurement::CameraMeasurement;
use ibvs_core::nav::{FlightCondition, NavSample};
use ibvs_core::wire::{FrameDecoder, MAX_FRAME_LEN, Uplink, encode_uplink};
use ibvs_core::{
    Controller, ControllerConfig, ControllerInput, ControllerOutput, ModeRequest, OuterLaw,
    RefuellingConfig,
};
use proptest::prelude::*;

mod common;
use common::{bits, cases};
#[path = "common/sortie.rs"]
mod sortie;
use sortie::{request, sortie_sequence};
#[path = "common/mode_model.rs"]
mod mode_model;
use mode_model::Models;

/// Longest input sequence, steps (longer than the blind phase's 250-step limit).
const MAX_STEPS: usize = 600;

/// `(tracked, image_x, image_y, depth_m)`: plausible, near the drogue (terminal entries with
/// small and large offsets), or arbitrary bits.
fn frame_content() -> impl Strategy<Value = (bool, f32, f32, f32)> {
    prop_oneof![
        3 => (Just(true), -0.6_f32..0.6, -0.45_f32..0.45, 0.2_f32..12.0),
        2 => (Just(true), -0.6_f32..0.6, -0.45_f32..0.45, 0.3_f32..0.75),
        // The refuelling procedure's pre-contact station (3.6 m, nearly centred) and the last
        // metre before the drogue.
        2 => (Just(true), -0.04_f32..0.04, -0.04_f32..0.04, 3.4_f32..3.8),
        1 => (Just(true), -0.2_f32..0.2, -0.2_f32..0.2, 0.05_f32..1.0),
        2 => (any::<bool>(), bits(), bits(), bits()),
    ]
}

/// Navigation: trim (the blind phase then neither closes nor passes the plane, so its time
/// limit is reached), small perturbations, closing around the overspeed limit, or arbitrary
/// bits.
fn nav() -> impl Strategy<Value = NavSample> {
    (nav_states(), condition()).prop_map(|(n, condition)| NavSample { condition, ..n })
}

/// The flight condition: mostly the design's, sometimes elsewhere inside the docking
/// envelope, outside it, or arbitrary bits.
fn condition() -> impl Strategy<Value = FlightCondition> {
    let at = |(v, h)| FlightCondition {
        true_airspeed_mps: v,
        altitude_m: h,
    };
    prop_oneof![
        12 => Just(FlightCondition::default()),
        1 => (100.0_f32..170.0, 500.0_f32..8000.0).prop_map(at),
        1 => (0.0_f32..400.0, -1000.0_f32..20_000.0).prop_map(at),
        1 => (bits(), bits()).prop_map(at),
    ]
}

/// The navigation states (at the design's condition).
fn nav_states() -> impl Strategy<Value = NavSample> {
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
        prop_oneof![8 => Just(1_usize), 3 => 2_usize..30, 2 => 50_usize..120, 1 => 240_usize..300],
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
                        probe_tip: None,
                    },
                    nav,
                    probe_contact: contact,
                    autopilot_ready: true,
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
                // A tracker's noise: repeated frames are not bit-identical (the frozen check
                // would reject them after a few), unless the content is not a number.
                let m = &mut input.measurement;
                if m.depth_m.is_finite() {
                    m.depth_m += 1e-4 * (i % 7) as f32;
                }
                // A run's request is sent once, at its start.
                if i > 0 {
                    input.request = ModeRequest::None;
                }
                input
            })
            .collect()
    })
}

fn check_output(
    cfg: &ControllerConfig,
    models: &mut Models,
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
    models
        .step(input, out)
        .map_err(|e| TestCaseError::fail(format!("step {k}: {e}; input {input:?}")))
}

fn check_sequence(cfg: ControllerConfig, inputs: &[ControllerInput]) -> Result<(), TestCaseError> {
    let mut ctl = Controller::new(cfg).expect("valid configuration");
    let mut models = Models::new(cfg);
    for (k, input) in inputs.iter().enumerate() {
        let out = ctl.step(input);
        check_output(&cfg, &mut models, k, input, &out)?;
        ctl.follow_schedule();
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
    let mut models = Models::new(cfg);
    let mut decoder = FrameDecoder::new();
    let mut k = 0;
    for &b in bytes {
        let uplink = match decoder.feed(b) {
            Some(Ok(payload)) => payload.uplink().ok(),
            _ => None,
        };
        if let Some(u) = uplink {
            let out = ctl.step(&u.input);
            check_output(&cfg, &mut models, k, &u.input, &out)?;
            ctl.follow_schedule();
            k += 1;
        }
    }
    Ok(())
}

fn paper_ibvs() -> ControllerConfig {
    ControllerConfig::paper()
}

fn pbvs() -> ControllerConfig {
    ControllerConfig {
        law: OuterLaw::Pbvs,
        ..ControllerConfig::paper()
    }
}

/// The refuelling procedure with two attempts and a 12 s sortie, so that both ends of the
/// sortie are reached, on a heavy receiver (1.2 times the design's mass: its docking
/// envelope's slow edge is another than the paper's configurations').
fn refuelling() -> ControllerConfig {
    ControllerConfig {
        refuelling: RefuellingConfig {
            max_attempts: 2,
            sortie_budget_s: 12.0,
            ..RefuellingConfig::default()
        },
        mass_factor: 1.2,
        ..ControllerConfig::default()
    }
}

proptest! {
    #![proptest_config(cases("IBVS_FUZZ_CASES", 256))]

    #[test]
    fn refuelling_commands_stay_in_limits_and_modes_follow_the_table(inputs in input_sequence()) {
        check_sequence(refuelling(), &inputs)?;
    }

    #[test]
    fn refuelling_sorties_stay_in_limits_and_modes_follow_the_table(inputs in sortie_sequence(refuelling())) {
        check_sequence(refuelling(), &inputs)?;
    }

    #[test]
    fn ibvs_commands_stay_in_limits_and_modes_follow_the_table(inputs in input_sequence()) {
        check_sequence(paper_ibvs(), &inputs)?;
    }

    #[test]
    fn pbvs_commands_stay_in_limits_and_modes_follow_the_table(inputs in input_sequence()) {
        check_sequence(pbvs(), &inputs)?;
    }

    #[test]
    fn bytes_through_the_link_decoder_into_the_step(c in chunks()) {
        check_wire(ControllerConfig::default(), &bytes_of(&c))?;
        check_wire(paper_ibvs(), &bytes_of(&c))?;
    }
}

/// The sortie generator reaches every row of the refuelling table that ends in a mode of its
/// own: every no-go, every breakaway reason, docking. (Without this the property above could
/// pass while exercising only the pre-contact station.) And the model of the tables agrees
/// with the controller on them while rarely unsure: decisions within its band of a threshold
/// (where it follows both outcomes) stay rare, so its verdicts are its own, not a shrug.
#[test]
fn the_sortie_generator_reaches_every_row_of_the_refuelling_table() {
    use proptest::strategy::ValueTree;
    use proptest::test_runner::{RngAlgorithm, TestRng, TestRunner};
    let mut runner = TestRunner::new_with_rng(
        proptest::test_runner::Config::default(),
        TestRng::from_seed(RngAlgorithm::ChaCha, &[7; 32]),
    );
    let strategy = sortie_sequence(refuelling());
    let mut seen = std::collections::BTreeSet::new();
    let (mut steps, mut unsure, mut most) = (0, 0, 0);
    for _ in 0..256 {
        let inputs = strategy.new_tree(&mut runner).expect("a case").current();
        let mut ctl = Controller::new(refuelling()).expect("valid configuration");
        let mut models = Models::new(refuelling());
        for input in &inputs {
            let out = ctl.step(input);
            models.step(input, &out).expect("the model agrees");
            ctl.follow_schedule();
            seen.insert(format!("{:?}", out.mode));
            if let Some(r) = out.breakaway_reason {
                seen.insert(format!("{r:?}"));
            }
            if let Some(r) = out.no_go {
                seen.insert(format!("{r:?}"));
            }
        }
        steps += inputs.len();
        unsure += models.unsure_steps;
        most = most.max(models.most);
    }
    let every = [
        "PreContact",
        "Approach",
        "Terminal",
        "Docked",
        "MissedApproach",
        "OffsetTooLarge",
        "PredictedMiss",
        "LateNoGo",
        "PassedDroguePlane",
        // `CaptureTimeout`: a hold inside the depths where the capture judges its closing
        // speed (0.6 m and closer) lasts until the capture's time is up.
        "CaptureTimeout",
        "ClosingTooSlow",
        "MeasurementLost",
        "NavLost",
        "Overspeed",
        "AttemptsExhausted",
        "SortieTimeout",
        "StationOverrun",
        "OutsideDockingEnvelope",
        "ContactLost",
        "Abort",
    ];
    println!("{unsure} of {steps} steps left the model unsure; at most {most} states at once");
    // Measured with this seed: none of 287,704 steps (the only decisions within the band are
    // the gate's horizon at the plane with no closing speed, 206 of them, settled by the same
    // step's output). A thousandth is the floor: past it the model would be shrugging.
    assert!(
        unsure * 1000 < steps,
        "{unsure} of {steps} steps left the model of the tables unsure"
    );
    let missing: Vec<_> = every.iter().filter(|r| !seen.contains(**r)).collect();
    assert!(
        missing.is_empty(),
        "never reached: {missing:?} (reached {seen:?})"
    );
}

mod long {
    use super::*;

    proptest! {
        #![proptest_config(cases("IBVS_FUZZ_LONG_CASES", 1_000_000))]

        #[test]
        #[ignore = "long fuzzing run: cargo test --release -- --ignored"]
        fn long_sorties(inputs in sortie_sequence(refuelling())) {
            check_sequence(refuelling(), &inputs)?;
        }

        #[test]
        #[ignore = "long fuzzing run: cargo test --release -- --ignored"]
        fn long_step_sequences(inputs in input_sequence()) {
            check_sequence(refuelling(), &inputs)?;
            check_sequence(paper_ibvs(), &inputs)?;
            check_sequence(pbvs(), &inputs)?;
        }

        #[test]
        #[ignore = "long fuzzing run: cargo test --release -- --ignored"]
        fn long_link_bytes(c in chunks()) {
            check_wire(ControllerConfig::default(), &bytes_of(&c))?;
        }
    }
}
