//! Development tool: how the inner loops' damping falls with navigation latency, and what
//! the latency predictor (`ibvs_core::predictor`) gives back.
//!
//! For the paper's design (at the nominal cg) and the refuelling procedure's (at the aft
//! cg, `REFUELLING_DESIGN_XCG`; the predictor's model the nominal cg's either way), it
//! closes each channel's linear plant at cg 0.30, 0.35 and 0.40 with first-order actuators
//! (20.2 rad/s, inside the zero-order hold) and the measured states reaching the controller
//! `d` control periods late (the INS latency), as the core runs it: the engine
//! power is the controller's own estimate, never late; the integrators integrate the late
//! output; the state feedback acts on the late sample (`plain`) or on the sample predicted
//! over the latency with the generated nominal-cg model (`predicted`). It prints, for
//! d = 0..=3, each loop's spectral radius and its least-damped mode above 0.25 Hz
//! (frequency, damping ratio).
//!
//! `cargo run --release -p host-sim --example delay_margin`
use host_sim::receiver::F16;
use host_sim::synthesis::latency::{channel_loop, least_damped};
use host_sim::synthesis::linalg::spectral_radius;
use host_sim::synthesis::{self, DesignWeights};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let designs = [
        ("paper", DesignWeights::default(), synthesis::NOMINAL_XCG),
        (
            "refuelling",
            DesignWeights::refuelling(),
            synthesis::REFUELLING_DESIGN_XCG,
        ),
    ];
    let model = F16::new(synthesis::NOMINAL_XCG)?;
    let bandwidth = model.actuators().bandwidth_radps;
    let design_at = |xcg: f64, w: &DesignWeights| {
        synthesis::synthesize(
            &F16::new(xcg)?,
            synthesis::REFUELLING_SPEED_MPS,
            synthesis::REFUELLING_ALTITUDE_M,
            synthesis::CONTROL_PERIOD_S,
            synthesis::PROBE_TIP_BODY_M,
            w,
        )
    };
    for (name, w, design_xcg) in &designs {
        // As the core flies it: the gains designed at `design_xcg`, the predictor's model
        // the nominal cg's.
        let model_only = design_at(synthesis::NOMINAL_XCG, w)?;
        let mut nominal = design_at(*design_xcg, w)?;
        nominal.predictor_lon = model_only.predictor_lon;
        nominal.predictor_lat = model_only.predictor_lat;
        for xcg in [0.30, 0.35, 0.40] {
            let truth = design_at(xcg, w)?;
            for (ch, lateral) in [("lon", false), ("lat", true)] {
                for d in 0..=3 {
                    let mut line = format!("{name:10} xcg {xcg:.2} {ch} d={d}:");
                    for predict in [false, true] {
                        let m =
                            channel_loop(&truth, &nominal, lateral, bandwidth, d, predict).matrix();
                        let mode = least_damped(&m)
                            .map(|(f, z)| format!("{f:.2} Hz damping {z:.3}"))
                            .unwrap_or_default();
                        let label = if predict { "predicted" } else { "plain" };
                        line += &format!("  {label}: radius {:.4}, {mode}", spectral_radius(&m));
                    }
                    println!("{line}");
                }
            }
        }
    }
    Ok(())
}
