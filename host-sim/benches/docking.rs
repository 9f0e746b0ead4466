//! Criterion benchmark of whole dockings from the paper's start, and their real-time factors.
//!
//! Two worlds: `ideal_calm` (the vertical slice: calm air, drogue held at its trail, ideal
//! camera) and `full_level2` (the `paper-level2` preset, seed 1: Dryden turbulence at 0.7 m/s,
//! tanker wake, 20-link hose and drogue, LED camera with circle fit). What is timed is
//! `host_sim::sim::run` with a fresh controller per run: trim, world construction (the hose's
//! static trail), then the closed loop until contact.
//!
//! Real-time factor = simulated seconds / wall seconds per run, the simulated seconds being the
//! last sample's time. Each run is timed on its own (`iter_custom`) and the factor is printed
//! after criterion's report from the median of those per-run times.
//!
//! Invariant: every timed run must dock (the bench aborts otherwise): a benchmark of a broken
//! run measures nothing useful.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{Criterion, criterion_group, criterion_main};
use host_sim::scenario::ScenarioFile;
use host_sim::sim::{self, Scenario};
use ibvs_core::{Controller, ControllerConfig};

/// One docking; returns the simulated time, s.
fn docking(scenario: &Scenario, cfg: ControllerConfig) -> f64 {
    let mut controller = Controller::new(cfg).expect("valid controller configuration");
    let run = sim::run(black_box(scenario), &mut controller).expect("docking run");
    assert!(
        run.summary.docked,
        "{}: did not dock: {:?}",
        scenario.name, run.summary
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
    let level2 = ScenarioFile::load("paper-level2").expect("preset");
    let cases = [
        ("ideal_calm", Scenario::ideal(), ControllerConfig::default()),
        ("full_level2", level2.scenario(), level2.controller_config()),
    ];
    let mut group = c.benchmark_group("docking");
    // One run takes milliseconds to tens of milliseconds: ten samples keep `cargo bench`
    // short on a two-core machine while still giving a median.
    group.sample_size(10);
    for (name, scenario, cfg) in &cases {
        let simulated_s = docking(scenario, *cfg);
        let mut per_run: Vec<Duration> = Vec::new();
        group.bench_function(*name, |b| {
            b.iter_custom(|iters| {
                let mut total = Duration::ZERO;
                for _ in 0..iters {
                    let t0 = Instant::now();
                    black_box(docking(scenario, *cfg));
                    let dt = t0.elapsed();
                    per_run.push(dt);
                    total += dt;
                }
                total
            });
        });
        // Under `cargo test --benches` criterion runs the body once in test mode: no timing.
        if per_run.len() >= 3 {
            let wall = median(&mut per_run);
            println!(
                "docking/{name}: simulated {simulated_s:.2} s, median wall {:.3} ms per run over {} runs, \
                 real-time factor {:.0}x",
                wall.as_secs_f64() * 1e3,
                per_run.len(),
                simulated_s / wall.as_secs_f64()
            );
        }
    }
    group.finish();
}

criterion_group!(benches, bench_docking);
criterion_main!(benches);
