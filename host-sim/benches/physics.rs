//! Criterion benchmark of one physics step of the simulator: what `host_sim::sim::run`
//! integrates `plant_substeps` times per control period.
//!
//! - `physics/receiver_rk4`: the nonlinear F-16 alone, one RK4 step of 0.01 s at trim, calm
//!   air (four evaluations of the aerodynamic tables, the engine and the actuators);
//! - `physics/full_world_substep`: the same step inside the full environment of the
//!   `paper-level2` preset: the air at the receiver (Dryden turbulence, tanker wake), the
//!   20-link hose and drogue advanced (RK4 with projection, tridiagonal tension solve), then
//!   the receiver;
//! - `physics/full_world_step_refuelling`: one physics step of the refuelling presets, 0.02 s
//!   (one per control period: the hose in one RK4 step, the gusts in two samples), in the
//!   `level2` preset's environment;
//! - `physics/camera_frame`: one LED-camera frame of the drogue (projection, noise, circle
//!   fit), once per control period;
//! - `physics/receiver_rk4_dispersed`: `receiver_rk4` for a receiver whose plant factors are
//!   not 1.0 (the elevator's and static stability's split from their tables: two lookups more
//!   per evaluation), the per-step cost of a plant dispersion;
//! - `physics/receiver_trim` and `physics/receiver_trim_dispersed`: the straight-and-level
//!   trim of the nominal and of that dispersed receiver at the refuelling condition, the
//!   per-run cost (a run trims the true receiver, and the nominal one when the two differ).
//! - `physics/build_world_level2` and `physics/build_world_plant_corner`: building a run's
//!   world, once per run (the hose's steady trail in the wake, the gust field's history, the
//!   camera), for `level2` and for `level2` at the corner of the world's plant dispersion
//!   (`WORLD_PLANT_DISPERSION`) with the most tension in the hose (the draggiest drogue, the
//!   longest and heaviest hose with twice its drag, the strongest wake);
//!   `physics/full_world_step_plant_corner` is a refuelling physics step in that world.
//!
//! Each iteration starts from the same state (a clone made outside the timed region), so the
//! figures do not drift with the simulated time. Run with
//! `cargo bench -p host-sim --bench physics`; whole dockings are in `--bench docking`.

use std::hint::black_box;

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use host_sim::receiver::{F16, FACTORS, ReceiverPlant, Wind};
use host_sim::scenario::{ScenarioFile, WORLD_PLANT_DISPERSION};
use host_sim::sim::build_world;
use host_sim::synthesis::{NOMINAL_XCG, REFUELLING_ALTITUDE_M, REFUELLING_SPEED_MPS};
use host_sim::world::World;

/// One physics step of the `paper-*` presets, s (two per 20 ms control period).
const DT_S: f64 = 0.01;
/// One physics step of the refuelling presets, s (one per control period).
const REFUELLING_DT_S: f64 = 0.02;

fn benches(c: &mut Criterion) {
    let model = F16::new(NOMINAL_XCG).expect("F-16 data");
    let trim = model
        .trim_straight_level(REFUELLING_SPEED_MPS, REFUELLING_ALTITUDE_M)
        .expect("trim");
    let scenario = ScenarioFile::load("paper-level2")
        .expect("preset")
        .scenario();
    let world = build_world(&scenario, &model, &trim, DT_S).expect("world");
    let refuelling = ScenarioFile::load("level2").expect("preset").scenario();
    assert_eq!(
        refuelling.plant_substeps, 1,
        "level2 steps once per control period"
    );
    let refuelling_world = build_world(&refuelling, &model, &trim, REFUELLING_DT_S).expect("world");
    let x0 = trim.state;
    let cmd = trim.command;
    // Every factor off 1.0: the middle of the upper half of its limits' span near 1.
    let mut plant = ReceiverPlant::NOMINAL;
    for (info, factor) in FACTORS.iter().zip(plant.values_mut()) {
        *factor = 1.0 + 0.1 * (info.limits.max - 1.0).min(1.0);
    }
    let dispersed = F16::with_plant(NOMINAL_XCG, &plant).expect("valid plant");
    let dispersed_trim = dispersed
        .trim_straight_level(REFUELLING_SPEED_MPS, REFUELLING_ALTITUDE_M)
        .expect("trim");

    let mut group = c.benchmark_group("physics");
    group.bench_function("receiver_rk4", |b| {
        b.iter_batched_ref(
            || x0,
            |x| model.step_rk4(x, black_box(&cmd), &Wind::default(), DT_S),
            BatchSize::SmallInput,
        );
    });
    // One physics step of `dt_s` in `world`, as `host_sim::sim::run` makes it: the air at the
    // receiver, the world (gusts, hose), then the receiver.
    let mut full_step = |name: &str, world: &World, dt_s: f64| {
        group.bench_function(name, |b| {
            b.iter_batched_ref(
                || (world.clone(), x0),
                |(w, x)| {
                    let t = 1.0;
                    let wind = w.receiver_wind(x, t);
                    w.step(dt_s, x, t);
                    model.step_rk4(x, black_box(&cmd), &wind, dt_s);
                },
                BatchSize::SmallInput,
            );
        });
    };
    full_step("full_world_substep", &world, DT_S);
    full_step(
        "full_world_step_refuelling",
        &refuelling_world,
        REFUELLING_DT_S,
    );
    let corner = ScenarioFile::parse(
        &format!(
            "[turbulence]\npreset = \"level2\"\n[drogue]\ndrogue_drag_coefficient = 0.92\n\
             hose_length_m = 15.2\nhose_linear_density_kg_per_m = 4.71\nhose_drag_scale = 2.0\n\
             [tanker_wake]\nenabled = true\nstrength = 1.5\n{WORLD_PLANT_DISPERSION}"
        ),
        "plant corner",
    )
    .expect("plant corner")
    .scenario();
    let corner_world = build_world(&corner, &model, &trim, REFUELLING_DT_S).expect("world");
    full_step(
        "full_world_step_plant_corner",
        &corner_world,
        REFUELLING_DT_S,
    );
    for (name, s) in [
        ("build_world_level2", &refuelling),
        ("build_world_plant_corner", &corner),
    ] {
        group.bench_function(name, |b| {
            b.iter(|| build_world(black_box(s), &model, &trim, REFUELLING_DT_S).expect("world"));
        });
    }
    group.bench_function("camera_frame", |b| {
        b.iter_batched_ref(
            || world.clone(),
            |w| w.capture(black_box(&x0), 1.0),
            BatchSize::SmallInput,
        );
    });
    group.bench_function("receiver_rk4_dispersed", |b| {
        b.iter_batched_ref(
            || dispersed_trim.state,
            |x| {
                dispersed.step_rk4(
                    x,
                    black_box(&dispersed_trim.command),
                    &Wind::default(),
                    DT_S,
                )
            },
            BatchSize::SmallInput,
        );
    });
    for (name, receiver) in [
        ("receiver_trim", &model),
        ("receiver_trim_dispersed", &dispersed),
    ] {
        group.bench_function(name, |b| {
            b.iter(|| {
                receiver.trim_straight_level(black_box(REFUELLING_SPEED_MPS), REFUELLING_ALTITUDE_M)
            });
        });
    }
    group.finish();
}

criterion_group!(physics, benches);
criterion_main!(physics);
