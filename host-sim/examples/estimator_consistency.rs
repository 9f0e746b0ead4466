//! Development tool: is the drogue estimator consistent with the truth it estimates?
//! (`host_sim::consistency` measures; this prints its table.)
//!
//! `cargo run --release -p host-sim --example estimator_consistency -- PRESET [RUNS] [FIRST]`
//!
//! Flies `RUNS` (default 200) dispersed sorties of the preset or scenario file from run index
//! `FIRST` (default 0) and prints, per state, the error's mean and RMS, the filter's mean
//! sigma, the mean NEES, the fraction within one sigma and the Monte Carlo band test's.
use host_sim::consistency::{self, STATES};
use host_sim::scenario::ScenarioFile;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let preset = args.next().ok_or("a preset or scenario file")?;
    let runs: u64 = args.next().map_or(Ok(200), |s| s.parse())?;
    let first: u64 = args.next().map_or(Ok(0), |s| s.parse())?;
    let base = ScenarioFile::load(&preset)?;
    let c = consistency::measure(&base, first..first + runs)?;
    println!(
        "{preset}: runs {first}..{}, {} steps counted",
        first + runs,
        c.steps
    );
    println!(
        "| state | error mean | error RMS | filter σ (mean) | NEES mean | within 1σ | band test |"
    );
    println!("|---|---|---|---|---|---|---|");
    for (name, s) in STATES.iter().zip(&c.states) {
        println!(
            "| {name} | {:.4} | {:.4} | {:.4} | {:.2} | {:.1} % | {:.1} % of {} steps |",
            s.error_mean,
            s.error_rms,
            s.sigma_mean,
            s.nees_mean,
            100.0 * s.within_one_sigma,
            100.0 * s.band_fraction,
            s.band_steps
        );
    }
    Ok(())
}
