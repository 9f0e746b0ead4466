//! Development tool: how far ahead the refuelling approach must feed the drogue's velocity
//! forward (`RefuellingConfig::feedforward_lead_s`) for the probe tip to move in phase with
//! the drogue's swing, at every node of the gain schedule (`host_sim::synthesis::lead`: the
//! inner loops' lag behind their command at the swing's frequency, and the estimator's
//! advance on the drogue's true velocity).
//!
//! Per node: the swing's period there; the lateral (right) and vertical (down) loops' lag
//! over cg 0.30, 0.35, 0.40 and one and two periods of navigation latency (the campaigns'
//! range; the predictor set for two), least..most and the mean; the estimator's advance at
//! the lead; the lead whose advance matches each mean lag ("capped" where even the longest
//! the estimator carries falls short: its advance in brackets); the longest lead.
//!
//! `cargo run --release -p host-sim --example feedforward_lead [-- LEAD_S [MASS_FACTOR]]`
//! (the lead whose advance is printed, default the configuration's; the airframe's mass as a
//! factor of the design's, default 1, told to the controller, which flies the design it
//! picks).
use host_sim::synthesis::lead::{
    estimator_advance_s, grid_lags_s, longest_lead_s, matching_lead_s,
};
use host_sim::synthesis::margins::flown_config;
use ibvs_core::estimator::swing_period_s;
use ibvs_core::gains::{SCHEDULE_ALTITUDES_M, SCHEDULE_SPEEDS_MPS};
use ibvs_core::nav::FlightCondition;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut cfg = flown_config();
    let lead_s: f32 = match std::env::args().nth(1) {
        Some(a) => a.parse()?,
        None => cfg.refuelling.feedforward_lead_s,
    };
    let mass_factor: f64 = match std::env::args().nth(2) {
        Some(a) => a.parse()?,
        None => 1.0,
    };
    cfg.mass_factor = mass_factor as f32;
    println!("lead {lead_s} s, mass factor {mass_factor}");
    println!(
        "| node | period | lag right | lag down | advance | lead for right / down | longest lead |"
    );
    println!("|---|---|---|---|---|---|---|");
    for &h in &SCHEDULE_ALTITUDES_M {
        for &v in &SCHEDULE_SPEEDS_MPS {
            let condition = FlightCondition {
                true_airspeed_mps: v,
                altitude_m: h,
            };
            let period = swing_period_s(&cfg.estimator, condition);
            let lags = grid_lags_s(&cfg, condition, mass_factor)?;
            let right: Vec<f64> = lags.iter().map(|l| l[0]).collect();
            let down: Vec<f64> = lags.iter().map(|l| l[1]).collect();
            let span = |x: &[f64]| {
                let lo = x.iter().copied().fold(f64::MAX, f64::min);
                let hi = x.iter().copied().fold(f64::MIN, f64::max);
                (lo, x.iter().sum::<f64>() / x.len() as f64, hi)
            };
            let (r, d) = (span(&right), span(&down));
            let longest = longest_lead_s(&cfg.estimator, condition);
            let matching = |lag: f64| match matching_lead_s(&cfg.estimator, condition, lag) {
                Some(l) => format!("{l:.2}"),
                None => format!(
                    "capped ({:.2})",
                    estimator_advance_s(&cfg.estimator, condition, longest)
                ),
            };
            println!(
                "| {v:.0} m/s, {h:.0} m | {period:.2} s | {:.2}..{:.2} (mean {:.2}) | {:.2}..{:.2} (mean {:.2}) | {:.2} s | {} / {} s | {longest:.2} s |",
                r.0,
                r.2,
                r.1,
                d.0,
                d.2,
                d.1,
                estimator_advance_s(&cfg.estimator, condition, lead_s),
                matching(r.1),
                matching(d.1),
            );
        }
    }
    Ok(())
}
