//! Processor-in-the-loop docking: the firmware in QEMU's emulated STM32F405 flies the
//! simulated receiver over its serial link, and must fly it exactly as the controller does
//! in-process.
//!
//! Needs `qemu-system-arm` and the firmware ELF ([`firmware_elf`]: `IBVS_FIRMWARE_ELF`, as
//! `scripts/test-all.sh` sets it, or the default build path; it is not built here). The processor-in-the-loop acceptance check: same outcome,
//! miss within 2 cm, same mode sequence. Since the Cortex-M4F and the host both compute the
//! core's `f32` arithmetic in IEEE single precision without fused or flushed operations, the
//! outputs are in fact identical bit for bit, and that is checked too.

use host_sim::pil::{PilFlightComputer, firmware_elf};
use host_sim::scenario::ScenarioFile;
use host_sim::sim::{Outcome, Run, Scenario, run};
use ibvs_core::wire::CostUnit;
use ibvs_core::{Controller, ControllerConfig, Mode};

/// The mode sequence of a run (consecutive repeats removed).
fn modes(r: &Run) -> Vec<Mode> {
    let mut m: Vec<Mode> = r.samples.iter().map(|s| s.output.mode).collect();
    m.dedup();
    m
}

/// Flies `scenario` in-process and through PIL, checks they match; the in-process run.
fn pil_matches_in_process(scenario: &Scenario) -> Run {
    let mut controller = Controller::new(ControllerConfig::default()).expect("default config");
    let reference = run(scenario, &mut controller).expect("in-process run");

    let elf = firmware_elf().expect("firmware ELF");
    let mut pil = PilFlightComputer::spawn(&elf).expect("QEMU with the firmware");
    let got = run(scenario, &mut pil).expect("PIL run");
    let failure = pil.last_error().map(ToString::to_string);
    let (stats, log) = pil.shutdown();
    eprintln!(
        "{}: {:?}\nPIL stats: {stats:#?}",
        scenario.name, got.summary
    );
    assert_eq!(failure, None, "link failure; firmware log:\n{log}");

    let (s, r) = (&got.summary, &reference.summary);
    assert_eq!(s.outcome, r.outcome);
    match (s.miss_m, r.miss_m) {
        (Some(a), Some(b)) => assert!((a - b).abs() <= 0.02, "miss {a} m vs {b} m"),
        (a, b) => assert_eq!(a.is_some(), b.is_some(), "plane reached: {a:?} vs {b:?}"),
    }
    assert_eq!(modes(&got), modes(&reference));
    assert_eq!(got.samples.len(), reference.samples.len());
    for (k, (a, b)) in got.samples.iter().zip(&reference.samples).enumerate() {
        assert_eq!(a.output, b.output, "step {k}");
    }

    // Every step went through the link once, nothing was lost or rejected.
    let steps = got.samples.len() as u64;
    assert_eq!(stats.steps, steps);
    assert_eq!(stats.host.failed_steps + stats.host.timeouts, 0);
    assert_eq!(u64::from(stats.firmware_link.frames_ok), steps);
    assert_eq!(stats.firmware_link.rejected_frames(), 0);
    assert_eq!(stats.firmware_counters.steps as usize, got.samples.len());
    let cost = stats.step_cost.expect("step costs");
    assert_eq!(cost.unit, CostUnit::Instructions);
    assert!(0 < cost.min && cost.min <= cost.median && cost.median <= cost.max);
    reference
}

/// The default scenario (the full environment): identical through PIL.
#[test]
fn pil_flies_the_default_scenario_like_the_in_process_controller() {
    let r = pil_matches_in_process(&Scenario::default());
    assert_eq!(r.summary.outcome, Outcome::Docked, "{:?}", r.summary);
}

/// The vertical slice's scenario (calm air, ideal camera): docks, identically through PIL.
#[test]
fn pil_docks_the_ideal_scenario_like_the_in_process_controller() {
    let s = Scenario::ideal();
    let r = pil_matches_in_process(&s);
    assert_eq!(r.summary.outcome, Outcome::Docked, "{:?}", r.summary);
}

/// The default scenario at another flight condition (137 m/s, 4,100 m: inside a cell of the
/// gain schedule): the firmware loads the interpolated design after its first step, as the
/// in-process flight computer does, and docks identically.
#[test]
fn pil_flies_the_gain_schedule_off_its_grid_like_the_in_process_controller() {
    let text = "name = \"off-grid\"\n[flight]\nairspeed_mps = 137.0\naltitude_m = 4100.0\n";
    let file = ScenarioFile::parse(text, "off-grid").expect("scenario");
    assert_eq!(
        file.controller_config(),
        ControllerConfig::default(),
        "the firmware's"
    );
    let r = pil_matches_in_process(&file.scenario());
    assert_eq!(r.summary.outcome, Outcome::Docked, "{:?}", r.summary);
    let first = r.samples.first().expect("steps");
    assert_eq!(first.output.envelope_error, None);
}
