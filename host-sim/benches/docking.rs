//! Criterion benchmark of one whole calm-air docking from the paper's start, and its
//! real-time factor.
//!
//! What is timed: `host_sim::sim::run(&Scenario::default(), ..)` with a fresh
//! `Controller::new(ControllerConfig::default())` per run: trim of the nonlinear receiver,
//! then the closed loop (camera, navigation, one controller step and `plant_substeps` RK4
//! steps per control period) until contact or the time budget. Building the controller is
//! inside the timed region; it is negligible next to the run.
//!
//! Real-time factor = simulated seconds / wall seconds per run, where the simulated seconds
//! are the last sample's time (the plant is integrated up to it; contact itself happens
//! slightly earlier, at `summary.time_s`). Each run is timed on its own (`iter_custom`), and
//! the factor is printed after criterion's report from the median of those per-run times
//! (all runs criterion made, its warm-up included: same workload, and a median is robust).
//! Criterion's own median (of per-sample means) is in
//! `target/criterion/docking/paper_start_calm_air/new/estimates.json`.
//!
//! Invariant: every timed run must dock (the bench aborts otherwise): a benchmark of a
//! broken run measures nothing useful.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{Criterion, criterion_group, criterion_main};
use host_sim::sim::{self, Scenario};
use ibvs_core::{Controller, ControllerConfig};

/// One docking; returns the simulated time, s.
fn docking(scenario: &Scenario) -> f64 {
    let mut controller =
        Controller::new(ControllerConfig::default()).expect("default controller configuration");
    let run = sim::run(black_box(scenario), &mut controller).expect("calm-air docking run");
    assert!(
        run.summary.docked,
        "the paper-start docking did not dock: {:?}",
        run.summary
    );
    run.samples.last().map_or(0.0, |s| s.time_s)
}

fn median(v: &mut [Duration]) -> Duration {
    v.sort_unstable();
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2
    }
}

fn bench_docking(c: &mut Criterion) {
    let scenario = Scenario::default();
    let simulated_s = docking(&scenario);
    let mut per_run: Vec<Duration> = Vec::new();

    let mut group = c.benchmark_group("docking");
    // One run takes tens of milliseconds: ten samples keep `cargo bench` short on a
    // two-core machine while still giving a median.
    group.sample_size(10);
    group.bench_function("paper_start_calm_air", |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                let t0 = Instant::now();
                black_box(docking(&scenario));
                let dt = t0.elapsed();
                per_run.push(dt);
                total += dt;
            }
            total
        });
    });
    group.finish();

    // Under `cargo test --benches` criterion runs the body once in test mode: no timing then.
    if per_run.len() < 3 {
        return;
    }
    let wall = median(&mut per_run);
    println!(
        "docking/paper_start_calm_air: simulated {simulated_s:.2} s, median wall {:.3} ms per \
         run over {} runs, real-time factor {:.0}x",
        wall.as_secs_f64() * 1e3,
        per_run.len(),
        simulated_s / wall.as_secs_f64()
    );
}

criterion_group!(benches, bench_docking);
criterion_main!(benches);
