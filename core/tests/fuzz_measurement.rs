//! Fuzzing the measurement validation (a proptest stand-in for cargo-fuzz, which needs a
//! nightly toolchain): frames with every field an arbitrary bit pattern (NaN payloads,
//! infinities, subnormals, signed zeros, huge values) mixed with plausible ones, arbitrary
//! frame numbers, against the rules of `docs/conventions.md`, "Input validation".
//!
//! - [`CameraMeasurement::validate`] never panics (any limits, even invalid ones) and, for
//!   any limits a valid configuration can hold, returns exactly the documented verdict, in
//!   the documented order (not tracked, non-finite, depth not positive, depth too large,
//!   outside the field of view); what it accepts is finite, in `(0, max_depth]` and in view;
//! - [`SequenceTracker`] classifies any sequence of frame numbers as a wrapping model does
//!   (new with the count of skipped frames, repeated, or late);
//! - the controller reports for every step exactly the sequence verdict, else the content
//!   verdict, and counts every frame once.
//!
//! CI runs `IBVS_FUZZ_CASES` cases per property (default 2048). The `#[ignore]`d `long_*`
//! tests are the long fuzzing mode: `IBVS_FUZZ_LONG_CASES` cases each (default 1,000,000),
//! `cargo test --release -p ibvs-core --test fuzz_measurement -- --ignored`.

use ibvs_core::measurement::{
    CameraMeasurement, MeasurementError, MeasurementLimits, SequenceCheck, SequenceTracker,
};
use ibvs_core::nav::NavSample;
use ibvs_core::{Controller, ControllerConfig, ControllerInput, ModeRequest};
use proptest::prelude::*;

mod common;
use common::{bits, cases};

/// A field: an arbitrary bit pattern, a boundary value, or an ordinary value in `lo..=hi`.
fn field(lo: f32, hi: f32) -> impl Strategy<Value = f32> {
    prop_oneof![
        2 => bits(),
        1 => prop::sample::select(vec![
            0.0_f32, -0.0, f32::NAN, f32::INFINITY, f32::NEG_INFINITY, f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE, f32::MAX, f32::MIN, 0.64, -0.64, 0.48, -0.48, 50.0, 1e-45,
        ]),
        3 => lo..=hi,
    ]
}

fn frame() -> impl Strategy<Value = CameraMeasurement> {
    (
        any::<u32>(),
        prop::bool::weighted(0.85),
        field(-0.8, 0.8),
        field(-0.6, 0.6),
        field(-5.0, 60.0),
    )
        .prop_map(|(seq, tracked, x, y, z)| CameraMeasurement {
            seq,
            tracked,
            image_x: x,
            image_y: y,
            depth_m: z,
            probe_tip: None,
        })
}

/// Limits a valid configuration can hold (positive, finite, depth at most 1000 m).
fn valid_limits() -> impl Strategy<Value = MeasurementLimits> {
    prop_oneof![
        3 => Just(MeasurementLimits::default()),
        1 => (1e-3_f32..=1000.0, 1e-3_f32..=10.0, 1e-3_f32..=10.0).prop_map(|(d, x, y)| {
            MeasurementLimits {
                max_depth_m: d,
                half_fov_x: x,
                half_fov_y: y,
                ..MeasurementLimits::default()
            }
        }),
    ]
}

/// The documented verdict, computed independently of the implementation.
fn reference(m: &CameraMeasurement, l: &MeasurementLimits) -> Result<[f32; 3], MeasurementError> {
    let v = [m.image_x, m.image_y, m.depth_m];
    if !m.tracked {
        Err(MeasurementError::NotTracked)
    } else if v.iter().any(|x| x.is_nan() || x.is_infinite()) {
        Err(MeasurementError::NonFinite)
    } else if m.depth_m <= 0.0 {
        Err(MeasurementError::DepthNotPositive)
    } else if m.depth_m > l.max_depth_m {
        Err(MeasurementError::DepthTooLarge)
    } else if m.image_x.abs() > l.half_fov_x || m.image_y.abs() > l.half_fov_y {
        Err(MeasurementError::OutsideFieldOfView)
    } else {
        Ok(v)
    }
}

fn check_validation(m: CameraMeasurement, l: MeasurementLimits) -> Result<(), TestCaseError> {
    let got = m.validate(&l);
    let want = reference(&m, &l);
    match (got, want) {
        (Ok(f), Ok(v)) => {
            // Bit for bit the frame's values.
            prop_assert_eq!(
                [f.image_x, f.image_y, f.depth_m].map(f32::to_bits),
                v.map(f32::to_bits)
            );
            prop_assert!(f.image_x.is_finite() && f.image_y.is_finite());
            prop_assert!(f.depth_m > 0.0 && f.depth_m <= l.max_depth_m);
            prop_assert!(f.image_x.abs() <= l.half_fov_x && f.image_y.abs() <= l.half_fov_y);
        }
        (Err(a), Err(b)) => prop_assert_eq!(a, b, "{:?} {:?}", m, l),
        (a, b) => prop_assert!(false, "{:?} {:?}: got {:?}, documented {:?}", m, l, a, b),
    }
    Ok(())
}

/// Frame-number steps: next, repeat, small gaps, the half-range boundary, anything.
fn seq_step() -> impl Strategy<Value = u32> {
    prop_oneof![
        6 => Just(1_u32),
        2 => Just(0_u32),
        2 => 2_u32..10,
        1 => prop::sample::select(vec![(1 << 31) - 1, 1 << 31, (1 << 31) + 1, u32::MAX]),
        1 => any::<u32>(),
    ]
}

fn seq_numbers() -> impl Strategy<Value = Vec<u32>> {
    (any::<u32>(), prop::collection::vec(seq_step(), 1..200)).prop_map(|(start, steps)| {
        let mut s = start;
        steps
            .into_iter()
            .map(|d| {
                s = s.wrapping_add(d);
                s
            })
            .collect()
    })
}

/// A wrapping model of the frame-number check: `(verdict, last accepted)`.
fn sequence_model(last: Option<u32>, seq: u32) -> (SequenceCheck, Option<u32>) {
    match last {
        None => (SequenceCheck::New { dropped: 0 }, Some(seq)),
        Some(l) => {
            let forward = seq.wrapping_sub(l);
            if forward == 0 {
                (SequenceCheck::Rejected(MeasurementError::Repeated), last)
            } else if forward > u32::MAX / 2 {
                (SequenceCheck::Rejected(MeasurementError::OutOfOrder), last)
            } else {
                (
                    SequenceCheck::New {
                        dropped: forward - 1,
                    },
                    Some(seq),
                )
            }
        }
    }
}

fn check_sequence(seqs: &[u32]) -> Result<(), TestCaseError> {
    let mut t = SequenceTracker::default();
    let mut last = None;
    for &s in seqs {
        let (want, next) = sequence_model(last, s);
        prop_assert_eq!(t.observe(s), want, "seq {} after {:?}", s, last);
        last = next;
    }
    Ok(())
}

/// Every step's error is the sequence verdict, else the content verdict; every frame is
/// counted once; the skipped frames are counted.
fn check_controller(frames: &[CameraMeasurement]) -> Result<(), TestCaseError> {
    let cfg = ControllerConfig::default();
    let mut ctl = Controller::new(cfg).expect("valid configuration");
    let mut last = None;
    let (mut valid, mut dropped) = (0_u32, 0_u32);
    for (k, m) in frames.iter().enumerate() {
        let out = ctl.step(&ControllerInput {
            measurement: *m,
            nav: NavSample::default(),
            probe_contact: false,
            autopilot_ready: true,
            // Engage once (Reset, which forgets the sequence, is never sent here).
            request: if k == 0 {
                ModeRequest::Engage
            } else {
                ModeRequest::None
            },
        });
        let (check, next) = sequence_model(last, m.seq);
        last = next;
        let want = match check {
            SequenceCheck::Rejected(e) => Err(e),
            SequenceCheck::New { dropped: d } => {
                dropped = dropped.saturating_add(d);
                reference(m, &cfg.measurement).map(|_| ())
            }
        };
        prop_assert_eq!(out.measurement_error, want.err(), "step {}: {:?}", k, m);
        if want.is_ok() {
            valid += 1;
        }
        let c = ctl.counters();
        prop_assert_eq!(c.frames_valid, valid);
        prop_assert_eq!(c.frames_dropped, dropped);
        for v in out.command.as_array() {
            prop_assert!(v.is_finite());
        }
    }
    Ok(())
}

fn frame_sequence() -> impl Strategy<Value = Vec<CameraMeasurement>> {
    (seq_numbers(), prop::collection::vec(frame(), 200)).prop_map(|(seqs, frames)| {
        seqs.into_iter()
            .zip(frames)
            .map(|(seq, f)| CameraMeasurement { seq, ..f })
            .collect()
    })
}

/// Limits with arbitrary bits (what no valid configuration holds): still no panic.
fn any_limits() -> impl Strategy<Value = MeasurementLimits> {
    (bits(), bits(), bits()).prop_map(|(d, x, y)| MeasurementLimits {
        max_depth_m: d,
        half_fov_x: x,
        half_fov_y: y,
        ..MeasurementLimits::default()
    })
}

proptest! {
    #![proptest_config(cases("IBVS_FUZZ_CASES", 2048))]

    #[test]
    fn validation_gives_the_documented_verdict(m in frame(), l in valid_limits()) {
        check_validation(m, l)?;
    }

    #[test]
    fn validation_never_panics_whatever_the_limits(m in frame(), l in any_limits()) {
        let _ = m.validate(&l);
    }

    #[test]
    fn frame_numbers_are_classified_as_the_wrapping_model(seqs in seq_numbers()) {
        check_sequence(&seqs)?;
    }

    #[test]
    fn the_controller_reports_the_sequence_then_the_content_verdict(
        frames in frame_sequence()
    ) {
        check_controller(&frames)?;
    }
}

mod long {
    use super::*;

    proptest! {
        #![proptest_config(cases("IBVS_FUZZ_LONG_CASES", 1_000_000))]

        #[test]
        #[ignore = "long fuzzing run: cargo test --release -- --ignored"]
        fn long_validation(m in frame(), l in valid_limits(), a in any_limits()) {
            check_validation(m, l)?;
            let _ = m.validate(&a);
        }

        #[test]
        #[ignore = "long fuzzing run: cargo test --release -- --ignored"]
        fn long_sequence_and_controller(frames in frame_sequence()) {
            let seqs: Vec<u32> = frames.iter().map(|f| f.seq).collect();
            check_sequence(&seqs)?;
            check_controller(&frames)?;
        }
    }
}
