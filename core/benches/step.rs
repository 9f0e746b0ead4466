//! Criterion benchmark of one [`Controller::step`] on the host.
//!
//! What is measured is the wall time of a single control step (validation, outer loop, mode
//! logic, slew, both inner loops, saturation, status and counters), in four situations:
//! - `step/ibvs_approach_valid_frame`: steady approach under the paper's IBVS law and
//!   procedure ([`ControllerConfig::paper`]). The controller is engaged and warmed up first;
//!   the timed steps then replay a stretch of 256 steps from that state (a clone per stretch,
//!   made outside the timed region), each with the next frame (advancing sequence number) and
//!   a slowly varying image point, depth and navigation sample, so the step is neither
//!   constant-folded nor cached, and every step of the stretch is checked beforehand to be in
//!   the mode named. There is no plant in the loop, so the steady state reached has some
//!   actuators saturated and integrators frozen (the same code path: saturation and
//!   anti-windup are evaluated every step);
//! - `step/ibvs_approach_hold_invalid_frame`: the hold path, an approach step whose frame is
//!   rejected (not tracked) so the last valid command is held. A hold may only last
//!   `hold_limit_steps` steps, so every iteration steps a fresh clone of a controller that is
//!   already a few steps into a hold; the clone is made outside the timed region;
//! - `step/pbvs_approach_valid_frame`: as the first, under the PBVS law (3-D reconstruction
//!   through the camera mount and the navigation attitude);
//! - `step/refuelling_pre_contact_valid_frame`: the refuelling procedure (the default
//!   configuration) holding its pre-contact station, with the drogue estimator and the
//!   station-keeping outer loop running on every frame. The drogue of these inputs sits off
//!   the station, so the dwell never completes and every step of the stretch is a
//!   pre-contact step (stepped on for long enough, the sortie budget would end the station
//!   in a breakaway: the replayed stretch keeps every timed step inside it).
//!
//! Run with `cargo bench -p ibvs-core --bench step`. The numbers are host numbers (the bench
//! profile: optimised, LTO), a relative measure only; the flight target is not measured here.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::measurement::WallTime;
use criterion::{BatchSize, BenchmarkGroup, Criterion, criterion_group, criterion_main};
use ibvs_core::controller::StatusFlags;
use ibvs_core::measurement::CameraMeasurement;
use ibvs_core::nav::NavSample;
use ibvs_core::{Controller, ControllerConfig, ControllerInput, Mode, ModeRequest, OuterLaw};

/// Number of precomputed input variations cycled through (a power of two).
const VARIATIONS: usize = 1024;

/// Slowly varying healthy inputs around a mid-range approach (drogue 5.5..6.5 m ahead, a little
/// right and above, small navigation perturbations). Sequence numbers are set when stepping.
fn varying_inputs() -> Vec<ControllerInput> {
    (0..VARIATIONS)
        .map(|k| {
            let phase = k as f32 * core::f32::consts::TAU / VARIATIONS as f32;
            let (s, c) = (phase.sin(), phase.cos());
            let mut nav = NavSample::default();
            nav.lon.theta_rad = 0.002 * s;
            nav.lon.v_mps = 0.05 * c;
            nav.lon.alpha_rad = -0.001 * s;
            nav.lon.q_radps = 0.002 * c;
            nav.lat.phi_rad = 0.03 * s;
            nav.lat.beta_rad = 0.002 * c;
            nav.lat.r_radps = -0.01 * s;
            ControllerInput {
                measurement: CameraMeasurement {
                    seq: 0,
                    tracked: true,
                    image_x: 0.2 + 0.05 * s,
                    image_y: -0.1 + 0.03 * c,
                    depth_m: 6.0 + 0.5 * s,
                    probe_tip: None,
                },
                nav,
                probe_contact: false,
                autopilot_ready: true,
                request: ModeRequest::None,
            }
        })
        .collect()
}

/// A controller engaged on `inputs[0]` and stepped once through every input, checked to be in
/// `mode` after the warm-up; returns it with the last sequence number used.
fn engaged(cfg: ControllerConfig, inputs: &[ControllerInput], mode: Mode) -> (Controller, u32) {
    let mut ctl = Controller::new(cfg).expect("valid configuration");
    let mut seq = 0_u32;
    let engage = ControllerInput {
        request: ModeRequest::Engage,
        ..inputs[0]
    };
    ctl.step(&engage);
    for input in inputs {
        seq += 1;
        let mut i = *input;
        i.measurement.seq = seq;
        ctl.step(&i);
    }
    assert_eq!(ctl.mode(), mode, "the warm-up must end in {mode:?}");
    (ctl, seq)
}

/// Steps in a replayed stretch: each stretch starts from the warmed-up controller (cloned
/// outside the timed region) and steps it through the next [`STRETCH`] inputs, so however
/// many steps criterion asks for, every timed step is one of the same stretch, all checked
/// to be in the mode named. (Stepping one controller on and on, as criterion's millions of
/// iterations would, leaves the mode: the refuelling procedure's sortie budget ends its
/// pre-contact station in a breakaway.)
const STRETCH: usize = 256;

/// Steady steps in `mode` with valid frames under `cfg`.
fn bench_valid(
    group: &mut BenchmarkGroup<'_, WallTime>,
    name: &str,
    cfg: ControllerConfig,
    mode: Mode,
) {
    let inputs = varying_inputs();
    let (warm, last_seq) = engaged(cfg, &inputs, mode);
    // The stretch: the inputs after the warm-up's last (the variations are periodic, so the
    // first follows the last smoothly), with the sequence numbers after its last.
    let stretch: Vec<ControllerInput> = (0..STRETCH)
        .map(|k| {
            let mut i = inputs[k % VARIATIONS];
            i.measurement.seq = last_seq.wrapping_add(1 + k as u32);
            i
        })
        .collect();
    let mut probe = warm.clone();
    for (k, input) in stretch.iter().enumerate() {
        let out = probe.step(input);
        assert_eq!(out.mode, mode, "step {k} of the stretch leaves {mode:?}");
        assert_eq!(
            out.measurement_error, None,
            "step {k} of the stretch: a valid frame"
        );
    }
    group.bench_function(name, |b| {
        b.iter_custom(|iters| {
            let mut spent = Duration::ZERO;
            let mut left = iters;
            while left > 0 {
                let n = left.min(STRETCH as u64) as usize;
                let mut ctl = warm.clone();
                let t0 = Instant::now();
                for input in &stretch[..n] {
                    black_box(ctl.step(black_box(input)));
                }
                spent += t0.elapsed();
                left -= n as u64;
            }
            spent
        });
    });
}

/// Approach steps on the hold path (frame not tracked, last valid command held).
fn bench_hold(group: &mut BenchmarkGroup<'_, WallTime>) {
    let inputs = varying_inputs();
    let (mut ctl, mut seq) = engaged(ControllerConfig::paper(), &inputs, Mode::Approach);
    let lost = |seq: u32, k: usize| {
        let mut i = inputs[k];
        i.measurement.seq = seq;
        i.measurement.tracked = false;
        i
    };
    for k in 0..5 {
        seq += 1;
        ctl.step(&lost(seq, k));
    }
    let snapshot = ctl;
    let probe = snapshot.clone().step(&lost(seq + 1, 0));
    assert!(
        probe.mode == Mode::Approach && probe.status.contains(StatusFlags::MEASUREMENT_HELD),
        "the benchmarked step must be a hold: {probe:?}"
    );
    let mut k = 0_usize;
    group.bench_function("ibvs_approach_hold_invalid_frame", |b| {
        b.iter_batched_ref(
            || {
                seq = seq.wrapping_add(1);
                k = (k + 1) & (VARIATIONS - 1);
                (snapshot.clone(), lost(seq, k))
            },
            |(ctl, input)| ctl.step(black_box(input)),
            BatchSize::SmallInput,
        );
    });
}

fn benches(c: &mut Criterion) {
    let mut group = c.benchmark_group("step");
    bench_valid(
        &mut group,
        "ibvs_approach_valid_frame",
        ControllerConfig::paper(),
        Mode::Approach,
    );
    bench_hold(&mut group);
    bench_valid(
        &mut group,
        "pbvs_approach_valid_frame",
        ControllerConfig {
            law: OuterLaw::Pbvs,
            ..ControllerConfig::paper()
        },
        Mode::Approach,
    );
    bench_valid(
        &mut group,
        "refuelling_pre_contact_valid_frame",
        ControllerConfig::default(),
        Mode::PreContact,
    );
    group.finish();
}

criterion_group!(step, benches);
criterion_main!(step);
