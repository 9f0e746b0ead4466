//! Gate calibration (development tool): per attempt, the predicted miss at commit and the
//! actual miss at the plane.
use host_sim::scenario::ScenarioFile;
use host_sim::sim;
use ibvs_core::{Controller, Mode};
fn main() {
    let path = std::env::args().nth(1).expect("scenario");
    let n: u64 = std::env::args()
        .nth(2)
        .map_or(100, |s| s.parse().expect("n"));
    let base = ScenarioFile::load(&path).expect("scenario");
    for i in 0..n {
        let f = base.dispersed(i);
        let mut c = Controller::new(f.controller_config()).expect("cfg");
        let run = sim::run(&f.scenario(), &mut c).expect("run");
        let s = &run.samples;
        for k in 1..s.len() {
            let (a, b) = (&s[k - 1].output, &s[k].output);
            if a.mode == Mode::Approach && b.mode != Mode::Approach {
                let att = b.attempt;
                let cross = run.crossings.iter().find(|e| e.attempt == att);
                let e = b.estimate;
                println!(
                    "{i} {att} {:?} pm {:.3} off {:.3} {:.3} vd {:.3} {:.3} tipv {:.3} {:.3} miss {} pushing {}",
                    b.mode,
                    b.predicted_miss_m,
                    e.offset_m[0],
                    e.offset_m[1],
                    e.drogue_velocity_mps[0],
                    e.drogue_velocity_mps[1],
                    s[k].tip_velocity_mps.y,
                    s[k].tip_velocity_mps.z,
                    cross.map_or("none".to_string(), |c| format!("{:.3}", c.contact.miss_m)),
                    cross.is_some_and(|c| c.pushing)
                );
            }
        }
    }
}
