//! Development tool: the figures `docs/faults.md` quotes as "measured", flown as
//! `host-sim/tests/faults.rs` flies its cases.
//!
//! The tests assert the responses (outcome, breakaway reason, counters); the page also quotes
//! times, ranges, misses and speeds that no test asserts. This tool flies every case of the page
//! through the public API exactly as the tests do ([`fly`], [`fly_paper`] and the constants are
//! copies of the tests' own; the faults and triggers are the tests', case by case), plus the cases
//! the page's "Known gaps and margins" names, and prints for each one line with the page's wording
//! of the case: the outcome, the breakaway (reason, time, true range then, the probe tip's speed
//! toward the tanker over the last control step), any no-go, every crossing of the drogue plane
//! (time, miss with its direction, closing speed, mode; after a breakaway, how far the tip climbed
//! since), the counters the page cites (for the actuator faults the rejected frames and navigation
//! samples, which say why the controller broke away), and `UNSAFE` with the hazards when the
//! referee (`host_sim::referee`) saw any (the tests assert that it never does). A `MeasurementLost` breakaway also shows when the
//! coasting that it ended began. Sections follow the page: the reference runs, the range triggers,
//! the table's rows, the known gaps.
//!
//! Ranges are the true range, drogue centre minus probe tip along tanker x, at the control
//! step. Times are control-step times, except contacts (the simulator's interpolated
//! crossing). Each run checks, as the tests do, that every command is finite and inside the
//! actuator limits, and stops with an error if not. Deterministic: the same build prints
//! the same figures.
//!
//! `cargo run --release -p host-sim --example fault_figures`

use std::error::Error;
use std::fmt::Write as _;

use host_sim::scenario::{CameraPlacement, NavModel, ScenarioFile};
use host_sim::sim::{Outcome, PlaneEvent, Run, run_with_faults};
use host_sim::world::faults::{Actuator, FaultKind, SimFault};
use ibvs_core::controller::StatusFlags;
use ibvs_core::{Controller, ControllerConfig, Counters, Mode, Procedure};

type Res<T> = Result<T, Box<dyn Error>>;

/// In the calm run's pre-contact station, s (the tests' `ONSET_S`).
const ONSET_S: f64 = 5.0;
/// Inside the capture, m (the tests' `CAPTURE_RANGE_M`).
const CAPTURE_RANGE_M: f64 = 0.8;
/// Control period, s.
const TS: f64 = 0.02;

/// Consecutive invalid steps bridged by a hold (the default configuration's).
fn hold_limit() -> u32 {
    u32::from(ControllerConfig::default().modes.hold_limit_steps)
}

/// Repeats of a frame's content accepted before `Frozen` (the default configuration's).
fn frozen_limit() -> u32 {
    u32::from(ControllerConfig::default().measurement.frozen_frame_limit)
}

struct Flown {
    run: Run,
    counters: Counters,
    paper: bool,
}

/// The tests' `fly()`: the `calm` preset (refuelling procedure).
fn fly(faults: &[SimFault]) -> Res<Flown> {
    fly_file(&ScenarioFile::load("calm")?, faults)
}

/// The tests' `fly_paper()`: the calm world, the paper's procedure, its camera at the probe
/// tip, perfect navigation.
fn fly_paper(faults: &[SimFault]) -> Res<Flown> {
    let mut f = ScenarioFile::load("calm")?;
    f.controller.config.procedure = Procedure::Paper;
    f.camera.placement = CameraPlacement::ProbeTip;
    f.navigation.model = NavModel::Ideal;
    f.duration_s = 70.0;
    fly_file(&f, faults)
}

fn fly_file(f: &ScenarioFile, faults: &[SimFault]) -> Res<Flown> {
    let mut c = Controller::new(f.controller_config())?;
    let run = run_with_faults(&f.scenario(), &mut c, faults)?;
    let lim = ControllerConfig::default().actuators;
    for s in &run.samples {
        for (i, c) in s.output.command.as_array().iter().enumerate() {
            if !(c.is_finite() && (lim.min[i]..=lim.max[i]).contains(c)) {
                return Err(format!("t = {}: command {i} = {c}", s.time_s).into());
            }
        }
    }
    Ok(Flown {
        counters: *c.counters(),
        paper: f.controller.config.procedure == Procedure::Paper,
        run,
    })
}

fn steps(n: u32) -> f64 {
    f64::from(n) * TS
}

/// The page's name of a mode.
fn mode_name(m: Mode, paper: bool) -> &'static str {
    match (m, paper) {
        (Mode::Standby, _) => "standby",
        (Mode::PreContact, _) => "pre-contact",
        (Mode::Approach, false) => "contact approach",
        (Mode::Approach, true) => "approach",
        (Mode::Terminal, false) => "capture",
        (Mode::Terminal, true) => "blind phase",
        (Mode::Docked, _) => "docked",
        (Mode::MissedApproach, _) => "missed approach",
        (Mode::Breakaway, _) => "breakaway",
    }
}

/// Index of the first step in `mode`.
fn first_in(run: &Run, mode: Mode) -> Option<usize> {
    run.samples.iter().position(|s| s.output.mode == mode)
}

/// Index of the first step whose true range is at or below `range_m` (a range trigger's
/// onset).
fn first_within(run: &Run, range_m: f64) -> Option<usize> {
    run.samples
        .iter()
        .position(|s| s.drogue_from_tip_m.x <= range_m)
}

/// Height of the probe tip (tanker axes, up) at the step of `time_s`, m.
fn tip_up_m(run: &Run, time_s: f64) -> f64 {
    run.samples
        .iter()
        .rposition(|p| p.time_s <= time_s)
        .map_or(f64::NAN, |k| -run.samples[k].tip_tanker_m.z)
}

fn crossing(f: &Flown, e: &PlaneEvent, breakaway_s: Option<f64>) -> String {
    let c = &e.contact;
    let [right, up] = e.crossing.offset_m;
    let mut out = format!(
        "plane at {:.2} s ({}{}): {:.3} m from the centre (right {:+.2}, up {:+.2}) at {:.3} m/s",
        c.time_s,
        mode_name(e.mode, f.paper),
        if e.pushing { ", pushing" } else { "" },
        c.miss_m,
        right,
        up,
        c.closure_mps,
    );
    if let Some(b) = breakaway_s.filter(|b| *b < c.time_s) {
        let climb = tip_up_m(&f.run, c.time_s) - tip_up_m(&f.run, b);
        let _ = write!(out, ", tip {climb:+.2} m up since the breakaway");
    }
    out
}

/// The outcome, the breakaway, the no-go and every crossing of the drogue plane.
fn describe(f: &Flown) -> String {
    let s = &f.run.summary;
    let mut out = match s.outcome {
        Outcome::Docked => format!(
            "docked at {:.2} s: miss {:.3} m, closing {:.3} m/s",
            s.time_s,
            s.miss_m.unwrap_or(f64::NAN),
            s.closure_mps.unwrap_or(f64::NAN)
        ),
        o => format!("{o:?}"),
    };
    for a in f.run.attempts.iter().filter(|a| a.end.starts_with("no-go")) {
        let _ = write!(
            out,
            "; attempt {} {} at {:.2} s",
            a.attempt, a.end, a.time_s
        );
        if let Some(k) = f.run.samples.iter().position(|p| p.time_s >= a.time_s) {
            let _ = write!(out, " ({:.2} m)", f.run.samples[k].drogue_from_tip_m.x);
        }
    }
    let b = first_in(&f.run, Mode::Breakaway);
    if let Some(k) = b {
        let p = &f.run.samples[k];
        let _ = write!(
            out,
            "; breakaway {} at {:.2} s, {:.2} m from the drogue, tip closing {:.2} m/s",
            s.breakaway_reason.as_deref().unwrap_or("?"),
            p.time_s,
            p.drogue_from_tip_m.x,
            p.tip_velocity_mps.x
        );
    }
    if let Some(k) = b.filter(|_| s.breakaway_reason.as_deref() == Some("MeasurementLost")) {
        let held = &f.run.samples[..k];
        let run_len = held
            .iter()
            .rev()
            .take_while(|p| p.output.status.contains(StatusFlags::MEASUREMENT_HELD))
            .count();
        if run_len > 0 {
            let _ = write!(
                out,
                " (coasted from {:.2} s)",
                held[held.len() - run_len].time_s
            );
        }
    }
    let b_s = b.map(|k| f.run.samples[k].time_s);
    let docked_at = (s.outcome == Outcome::Docked).then_some(s.time_s);
    let others: Vec<_> = f
        .run
        .crossings
        .iter()
        .filter(|e| Some(e.contact.time_s) != docked_at)
        .collect();
    if others.is_empty() && s.outcome != Outcome::Docked {
        out.push_str("; never reaches the drogue plane");
    }
    for e in others {
        let _ = write!(out, "; {}", crossing(f, e, b_s));
    }
    if !f.run.verdict.safe() {
        let what: Vec<String> = f
            .run
            .verdict
            .hazards
            .iter()
            .map(|h| format!("{} at {:.2} s: {}", h.kind.name(), h.time_s, h.what))
            .collect();
        let _ = write!(out, "; UNSAFE ({})", what.join("; "));
    }
    out
}

/// The nonzero counters of rejected frames and navigation samples.
fn rejections(c: &Counters) -> String {
    let all = [
        ("not_tracked", c.not_tracked),
        ("non_finite", c.non_finite),
        ("depth_not_positive", c.depth_not_positive),
        ("depth_too_large", c.depth_too_large),
        ("outside_fov", c.outside_fov),
        ("repeated", c.repeated),
        ("out_of_order", c.out_of_order),
        ("frozen", c.frozen),
        ("nav_non_finite", c.nav_non_finite),
        ("nav_outside_envelope", c.nav_outside_envelope),
        ("estimator_rejected", c.estimator_rejected),
    ];
    let named: Vec<_> = all
        .iter()
        .filter(|(_, n)| *n > 0)
        .map(|(k, n)| format!("{k} {n}"))
        .collect();
    format!(
        "rejected: {}",
        if named.is_empty() {
            "none".to_string()
        } else {
            named.join(", ")
        }
    )
}

fn flagged(f: &Flown, flag: u16) -> usize {
    f.run
        .samples
        .iter()
        .filter(|s| s.output.status.contains(flag))
        .count()
}

fn main() -> Res<()> {
    reference_runs()?;
    faults_and_responses()?;
    Ok(())
}

fn reference_runs() -> Res<()> {
    println!("== The reference runs");
    let f = fly(&[])?;
    let at = |k: Option<usize>| {
        k.map_or_else(
            || "never".to_string(),
            |k| {
                let p = &f.run.samples[k];
                format!("{:.2} s ({:.2} m)", p.time_s, p.drogue_from_tip_m.x)
            },
        )
    };
    println!(
        "fly(): engages at {}; station left (contact approach) at {}; capture at {}; {}",
        at(f.run
            .samples
            .iter()
            .position(|s| s.output.mode != Mode::Standby)),
        at(first_in(&f.run, Mode::Approach)),
        at(first_in(&f.run, Mode::Terminal)),
        describe(&f)
    );
    let p = fly_paper(&[])?;
    let k = first_in(&p.run, Mode::Terminal);
    println!(
        "fly_paper(): blind phase at {}; {}",
        k.map_or_else(
            || "never".to_string(),
            |k| {
                let s = &p.run.samples[k];
                format!("{:.2} s ({:.2} m)", s.time_s, s.drogue_from_tip_m.x)
            }
        ),
        describe(&p)
    );
    if let Some(s) = f
        .run
        .samples
        .iter()
        .find(|s| (s.time_s - ONSET_S).abs() < 1e-9)
    {
        println!(
            "time-triggered faults at {ONSET_S} s: {}, {:.2} m from the drogue",
            mode_name(s.output.mode, false),
            s.drogue_from_tip_m.x
        );
    }
    println!("range triggers (range | time | mode):");
    for r in [5.5, 5.0, 4.0, 3.0, 2.5, CAPTURE_RANGE_M] {
        if let Some(k) = first_within(&f.run, r) {
            let s = &f.run.samples[k];
            println!(
                "  {r} m | {:.2} s | {}",
                s.time_s,
                mode_name(s.output.mode, false)
            );
        }
    }
    println!("(the paper's 0.6 m trigger: {})", {
        first_within(&p.run, 0.6).map_or("never".to_string(), |k| {
            let s = &p.run.samples[k];
            format!("{:.2} s, {}", s.time_s, mode_name(s.output.mode, true))
        })
    });
    Ok(())
}

fn faults_and_responses() -> Res<()> {
    println!("\n== Faults and responses");
    let base = fly(&[])?;

    println!("-- image dropout before the commit (at {ONSET_S} s)");
    for n in [1, 5, 10, 20, hold_limit(), hold_limit() + 1, 30, 50, 150] {
        let f = fly(&[SimFault::at_time(
            FaultKind::ImageDropout,
            ONSET_S,
            steps(n),
        )])?;
        println!(
            "{n} steps: {}; repeated {}, measurement_held_steps {}",
            describe(&f),
            f.counters.repeated,
            f.counters.measurement_held_steps
        );
    }

    println!("-- image dropout in the capture (from {CAPTURE_RANGE_M} m)");
    let mut capture_lost = None;
    for (what, duration_s) in [
        ("10 steps", steps(10)),
        ("26 steps", steps(hold_limit() + 1)),
        ("to the end", f64::INFINITY),
    ] {
        let f = fly(&[SimFault::at_range(
            FaultKind::ImageDropout,
            CAPTURE_RANGE_M,
            duration_s,
        )])?;
        println!(
            "{what}: {}; repeated {}, flagged {}, measurement_held_steps {}",
            describe(&f),
            f.counters.repeated,
            flagged(&f, StatusFlags::MEASUREMENT_HELD),
            f.counters.measurement_held_steps
        );
        capture_lost = Some(describe(&f));
    }

    println!("-- paper: image dropout in the blind phase (from 0.6 m, 3 s)");
    let p0 = fly_paper(&[])?;
    let p = fly_paper(&[SimFault::at_range(FaultKind::ImageDropout, 0.6, 3.0)])?;
    let commands = |r: &Run| -> Vec<_> { r.samples.iter().map(|s| s.output.command).collect() };
    println!(
        "{}; repeated {}; commands identical to the run without the fault: {}; contact identical: {}",
        describe(&p),
        p.counters.repeated,
        commands(&p.run) == commands(&p0.run),
        p.run.contact == p0.run.contact
    );

    println!("-- LED occlusion (from 4 m)");
    let not_tracked = base.counters.not_tracked;
    for (what, mask, duration_s) in [
        ("5 of 8 hidden for 1 s", 0b1_1111, 1.0),
        ("6 hidden for 15 steps", 0b11_1111, steps(15)),
        ("all hidden for 1 s", 0xff, 1.0),
        ("5 hidden to the end", 0b1_1111, f64::INFINITY),
    ] {
        let f = fly(&[SimFault::at_range(
            FaultKind::LedOcclusion { mask },
            4.0,
            duration_s,
        )])?;
        println!(
            "{what}: {}; untracked frames {} (beyond the calm run's), measurement_held_steps {}, estimator_rejected {} (calm run: {})",
            describe(&f),
            f.counters.not_tracked - not_tracked,
            f.counters.measurement_held_steps,
            f.counters.estimator_rejected,
            base.counters.estimator_rejected
        );
    }

    println!("-- measurement latency spike (at {ONSET_S} s)");
    for (extra_s, window_s) in [(0.2, 0.1), (0.45, 0.3), (0.6, 0.1)] {
        let f = fly(&[SimFault::at_time(
            FaultKind::LatencySpike { extra_s },
            ONSET_S,
            window_s,
        )])?;
        println!(
            "+{extra_s} s for {window_s} s: {}; measurement_held_steps {}, frames_dropped {}",
            describe(&f),
            f.counters.measurement_held_steps,
            f.counters.frames_dropped
        );
    }

    println!("-- frozen measurement, stuck tracker");
    let frames = 1 + frozen_limit() + hold_limit();
    for range_m in [5.0, 3.0, 2.5] {
        for (what, duration_s) in [
            (format!("{frames} frames"), steps(frames) - TS / 2.0),
            (
                format!("{} frames", frames + 1),
                steps(frames + 1) - TS / 2.0,
            ),
            ("to the end".to_string(), f64::INFINITY),
        ] {
            let f = fly(&[SimFault::at_range(
                FaultKind::FrozenMeasurement,
                range_m,
                duration_s,
            )])?;
            let after = match (
                first_within(&f.run, range_m),
                first_in(&f.run, Mode::Breakaway),
            ) {
                (Some(on), Some(b)) => format!(
                    " (onset {:.2} s, breakaway {:.2} s after it)",
                    f.run.samples[on].time_s,
                    f.run.samples[b].time_s - f.run.samples[on].time_s
                ),
                _ => String::new(),
            };
            println!(
                "from {range_m} m, {what}: {}{after}; frozen {}",
                describe(&f),
                f.counters.frozen
            );
        }
    }
    let frozen_capture = fly(&[SimFault::at_range(
        FaultKind::FrozenMeasurement,
        CAPTURE_RANGE_M,
        f64::INFINITY,
    )])?;
    println!(
        "from {CAPTURE_RANGE_M} m to the end: {}; frozen {}",
        describe(&frozen_capture),
        frozen_capture.counters.frozen
    );

    println!("-- NaN from navigation (at {ONSET_S} s)");
    for n in [hold_limit(), hold_limit() + 1, 100] {
        let f = fly(&[SimFault::at_time(FaultKind::NavNaN, ONSET_S, steps(n))])?;
        println!(
            "{n} steps: {}; nav_non_finite {}, nav_held_steps {}, open-loop steps {}",
            describe(&f),
            f.counters.nav_non_finite,
            f.counters.nav_held_steps,
            flagged(&f, StatusFlags::OPEN_LOOP)
        );
    }

    let stuck = |actuator, range_m| {
        fly(&[SimFault::at_range(
            FaultKind::ActuatorStuck { actuator },
            range_m,
            f64::INFINITY,
        )])
    };
    let slow = |actuator, rate_per_s| {
        [SimFault::at_time(
            FaultKind::ActuatorRateLimited {
                actuator,
                rate_per_s,
            },
            0.0,
            f64::INFINITY,
        )]
    };
    println!("-- actuator stuck (from 5.5 m, to the end)");
    let mut stuck_throttle = None;
    for a in [
        Actuator::Rudder,
        Actuator::Elevator,
        Actuator::Aileron,
        Actuator::Throttle,
    ] {
        let f = stuck(a, 5.5)?;
        println!("{a:?}: {}; {}", describe(&f), rejections(&f.counters));
        if a == Actuator::Throttle {
            stuck_throttle = Some(describe(&f));
        }
    }

    println!("-- surface rate-limited (from the start)");
    for (a, rate, paper) in [
        (Actuator::Rudder, 0.01, false),
        (Actuator::Aileron, 0.05, false),
        (Actuator::Aileron, 0.05, true),
        (Actuator::Elevator, 0.05, false),
        (Actuator::Aileron, 0.01, false),
    ] {
        let f = if paper {
            fly_paper(&slow(a, rate))?
        } else {
            fly(&slow(a, rate))?
        };
        let who = if paper { "paper, " } else { "" };
        println!(
            "{who}{a:?} at {rate} rad/s: {}; {}",
            describe(&f),
            rejections(&f.counters)
        );
    }

    println!("-- throttle rate-limited (from the start)");
    let mut slow_throttle = None;
    for rate in [0.01, 0.05] {
        let f = fly(&slow(Actuator::Throttle, rate))?;
        println!("at {rate}/s: {}", describe(&f));
        slow_throttle = Some(describe(&f));
    }

    println!("\n== Known gaps and margins");
    println!("-- stuck from 2.5 m (contact approach), to the end");
    for a in [Actuator::Elevator, Actuator::Aileron] {
        let f = stuck(a, 2.5)?;
        println!("{a:?}: {}; {}", describe(&f), rejections(&f.counters));
    }
    println!("-- stuck from 1.2 m or 0.8 m, and the throttle from 2.5 m, to the end");
    let (mut worst_miss_m, mut worst_closure_mps) = (0.0_f64, 0.0_f64);
    let mut cases = Vec::new();
    for range_m in [1.2, CAPTURE_RANGE_M] {
        for a in [Actuator::Elevator, Actuator::Aileron, Actuator::Throttle] {
            cases.push((a, range_m));
        }
    }
    cases.push((Actuator::Throttle, 2.5));
    for (a, range_m) in cases {
        let f = stuck(a, range_m)?;
        println!("{a:?} from {range_m} m: {}", describe(&f));
        if f.run.summary.outcome == Outcome::Docked {
            worst_miss_m = worst_miss_m.max(f.run.summary.miss_m.unwrap_or(f64::NAN));
            worst_closure_mps =
                worst_closure_mps.max(f.run.summary.closure_mps.unwrap_or(f64::NAN));
        }
    }
    println!(
        "  of those docked: miss at most {worst_miss_m:.3} m, closing at up to {worst_closure_mps:.3} m/s"
    );
    println!("-- a stuck or slow throttle (the table's cases again)");
    println!(
        "Throttle stuck from 5.5 m: {}",
        stuck_throttle.unwrap_or_default()
    );
    println!("Throttle at 0.05/s: {}", slow_throttle.unwrap_or_default());
    println!(
        "paper, Throttle at 0.05/s: {}",
        describe(&fly_paper(&slow(Actuator::Throttle, 0.05))?)
    );
    println!("-- NaN navigation to the end, close in");
    for range_m in [1.2, CAPTURE_RANGE_M] {
        let f = fly(&[SimFault::at_range(
            FaultKind::NavNaN,
            range_m,
            f64::INFINITY,
        )])?;
        println!("from {range_m} m: {}", describe(&f));
    }
    println!("-- a camera that fails in the capture (the table's cases again)");
    println!(
        "lost from {CAPTURE_RANGE_M} m: {}",
        capture_lost.unwrap_or_default()
    );
    println!(
        "frozen from {CAPTURE_RANGE_M} m: {}",
        describe(&frozen_capture)
    );
    Ok(())
}
