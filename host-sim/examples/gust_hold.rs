//! Development tool: the receiver holding the pre-contact station behind a fixed drogue (ideal
//! camera, perfect navigation) in Dryden turbulence of a given intensity for 120 s: how often
//! control is lost (a breakaway or a pitch excursion), with the configuration's gains.
use host_sim::sim::{self, Scenario};
use ibvs_core::{Controller, ControllerConfig, Mode};
use nalgebra::Vector3;
fn main() {
    let sigma: f64 = std::env::args()
        .nth(1)
        .map_or(1.8, |s| s.parse().expect("sigma"));
    let n: u64 = std::env::args()
        .nth(2)
        .map_or(20, |s| s.parse().expect("n"));
    let xcg: f64 = std::env::args()
        .nth(3)
        .map_or(0.35, |s| s.parse().expect("xcg"));
    let mut lost = 0;
    let (mut sat, mut steps) = (0u64, 0u64);
    for seed in 1..=n {
        let s = Scenario {
            turbulence_sigma_mps: sigma,
            seed,
            xcg,
            duration_s: 120.0,
            start_offset_m: Vector3::new(3.0, 0.0, 0.0),
            ..Scenario::ideal()
        };
        let mut cfg = ControllerConfig::default();
        cfg.refuelling.station_dwell_s = 3000.0;
        cfg.refuelling.sortie_budget_s = 80_000.0;
        let mut c = Controller::new(cfg).expect("cfg");
        let run = sim::run(&s, &mut c).expect("run");
        steps += run.samples.len() as u64;
        sat += run
            .samples
            .iter()
            .filter(|p| p.output.status.0 & (1 << 2) != 0)
            .count() as u64;
        if let Some(p) = run
            .samples
            .iter()
            .find(|p| p.output.mode == Mode::Breakaway)
        {
            lost += 1;
            eprintln!(
                "seed {seed}: {:?} at {:.1} s",
                p.output.breakaway_reason, p.time_s
            );
        }
    }
    println!(
        "sigma {sigma} xcg {xcg}: lost {lost}/{n} in 120 s, elevator saturated {:.2} % of steps",
        100.0 * sat as f64 / steps as f64
    );
}
