//! Development tool: the deceleration idle power can give at each node of the gain
//! schedule, the figure a missed approach's deceleration demand must stay within.
//!
//! At each node (`ibvs_core::gains::SCHEDULE_SPEEDS_MPS` by `SCHEDULE_ALTITUDES_M`) it trims
//! the nominal F-16 (cg 0.35, `F16::new`) straight and level, then sets the throttle and the
//! engine's power to idle with the attitude, angle of attack and surfaces of the trim, and
//! prints the acceleration along the flight path that results: the deceleration drag and idle
//! thrust give before the aircraft pitches or the speed changes. It is an upper bound on what
//! the receiver gets from the throttle: the engine spools down over about a second first (its
//! power lag), and a heavier airframe decelerates less (the force is the same; the campaigns
//! disperse the mass up to 1.3 times).
//!
//! `cargo run --release -p host-sim --example idle_decel`
use host_sim::receiver::F16;
use host_sim::synthesis::NOMINAL_XCG;
use ibvs_core::gains::{SCHEDULE_ALTITUDES_M, SCHEDULE_SPEEDS_MPS};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let model = F16::new(NOMINAL_XCG)?;
    let speeds: String = SCHEDULE_SPEEDS_MPS
        .iter()
        .map(|v| format!(" {v} m/s |"))
        .collect();
    println!("| altitude, m |{speeds}");
    println!("|---|{}", "---|".repeat(SCHEDULE_SPEEDS_MPS.len()));
    for altitude_m in SCHEDULE_ALTITUDES_M {
        let mut row = format!("| {altitude_m:.0} |");
        for speed_mps in SCHEDULE_SPEEDS_MPS {
            let trim = model.trim_straight_level(f64::from(speed_mps), f64::from(altitude_m))?;
            let mut state = trim.state;
            let mut command = trim.command;
            command.throttle = 0.0;
            state.engine_power_pct = 0.0;
            let d = model.derivatives(&state, &command, &Default::default());
            let v = state.vel_body_mps;
            // The body-axis acceleration (u', w') projected on the velocity (v = 0 in trim).
            let along_mps2 = (d[0] * v.x + d[2] * v.z) / v.norm();
            row += &format!(
                " {:.2} m/s² (alpha {:.1}°) |",
                -along_mps2,
                trim.alpha_rad.to_degrees()
            );
        }
        println!("{row}");
    }
    Ok(())
}
