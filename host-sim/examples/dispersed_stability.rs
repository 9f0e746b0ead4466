//! Whether the inner loops as flown are stable on a campaign's dispersed airframes, by the
//! linear analysis of `host_sim::synthesis::margins` (`docs/margins.md`): for each run of a
//! preset, the receiver as that run disperses it (aerodynamics, mass, inertia, each surface
//! actuator's bandwidth, cg; the linear loop has no rate limits) trimmed and linearised at
//! the run's flight condition, the controller the run configures flying its design there, at
//! the run's true navigation latency. Prints one line per run (the closed loop's spectral
//! radius, the elevator's and all four inputs' disk margins) and the count of unstable
//! loops; given the campaign's `runs.jsonl` of the same runs, how the linear verdict meets
//! the referee's upsets.
//!
//! ```sh
//! cargo run --release -p host-sim --example dispersed_stability -- PRESET FIRST COUNT [RUNS_JSONL]
//! ```

use host_sim::scenario::ScenarioFile;
use host_sim::synthesis::margins::run_margins;
use rayon::prelude::*;

/// One run's linear verdict.
struct Verdict {
    index: u64,
    mass: f64,
    xcg: f64,
    latency: usize,
    radius: f64,
    elevator_alpha: f64,
    all_alpha: f64,
}

fn verdict(
    f: &ScenarioFile,
    index: u64,
) -> Result<Verdict, Box<dyn std::error::Error + Send + Sync>> {
    let r = f.dispersed(index);
    let m = run_margins(&r).map_err(|e| format!("run {index}: {e}"))?;
    Ok(Verdict {
        index,
        mass: r.receiver.plant.mass_scale,
        xcg: r.receiver.xcg,
        latency: usize::from(r.navigation.installed_latency_steps()),
        radius: m.spectral_radius,
        elevator_alpha: m.input[0].alpha,
        all_alpha: m.all.alpha,
    })
}

/// The runs of a campaign's `runs.jsonl` that the referee found upset, by index.
fn upsets(path: &str) -> Result<std::collections::HashSet<u64>, Box<dyn std::error::Error>> {
    let mut out = std::collections::HashSet::new();
    for line in std::fs::read_to_string(path)?.lines() {
        let run: serde_json::Value = serde_json::from_str(line)?;
        let upset = run["hazards"]
            .as_array()
            .is_some_and(|h| h.iter().any(|z| z["kind"] == "upset"));
        if upset {
            out.insert(run["index"].as_u64().ok_or("a run without an index")?);
        }
    }
    Ok(out)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [preset, first, count, rest @ ..] = args.as_slice() else {
        return Err("usage: dispersed_stability PRESET FIRST COUNT [RUNS_JSONL]".into());
    };
    let (first, count): (u64, u64) = (first.parse()?, count.parse()?);
    let f = ScenarioFile::load(preset)?;
    let verdicts: Vec<Verdict> = (first..first + count)
        .into_par_iter()
        .map(|i| verdict(&f, i))
        .collect::<Result<_, _>>()
        .map_err(|e| e.to_string())?;
    println!("run,mass,xcg,latency,spectral_radius,elevator_alpha,all_alpha");
    for v in &verdicts {
        println!(
            "{},{:.3},{:.3},{},{:.5},{:.3},{:.3}",
            v.index, v.mass, v.xcg, v.latency, v.radius, v.elevator_alpha, v.all_alpha
        );
    }
    let unstable: Vec<u64> = verdicts
        .iter()
        .filter(|v| v.radius >= 1.0)
        .map(|v| v.index)
        .collect();
    eprintln!(
        "{preset} runs {first}..{}: {} of {} loops unstable",
        first + count - 1,
        unstable.len(),
        verdicts.len()
    );
    if let Some(path) = rest.first() {
        let upset: std::collections::HashSet<u64> = upsets(path)?
            .into_iter()
            .filter(|i| (first..first + count).contains(i))
            .collect();
        let both = unstable.iter().filter(|i| upset.contains(i)).count();
        eprintln!(
            "upset by the referee: {}; of them linearly unstable: {both}; unstable but not \
             upset: {}",
            upset.len(),
            unstable.len() - both
        );
    }
    Ok(())
}
