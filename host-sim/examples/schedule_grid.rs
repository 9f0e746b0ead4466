//! How fine the gain schedule's grid must be: for candidate grids over the docking envelope,
//! the design is synthesised at the nodes, interpolated bilinearly (as the core does) on a
//! 5 m/s by 500 m lattice, and applied to the receiver linearised at each lattice point.
//! Printed per grid and design: the largest closed-loop spectral radius, the largest relative
//! gain error and the largest trim angle-of-attack error, with where they occur.
//!
//! `cargo run --release -p host-sim --example schedule_grid`

use host_sim::receiver::F16;
use host_sim::synthesis::schedule::{ScheduleNode, node};
use host_sim::synthesis::{
    LIGHT_REFUELLING_MASS_FACTOR, NOMINAL_XCG, Synthesis, linalg::spectral_radius,
    refuelling_airframe,
};
use nalgebra::DMatrix;

/// The cell of `axis` that holds `x` and the fraction across it (a shared node belongs to
/// the lower cell), as in the core.
fn cell(axis: &[f64], x: f64) -> (usize, f64) {
    let mut i = 0;
    while i + 2 < axis.len() && x > axis[i + 1] {
        i += 1;
    }
    (i, (x - axis[i]) / (axis[i + 1] - axis[i]))
}

/// Worst value and where: `(value, speed, altitude)`.
type Worst = (f64, f64, f64);

fn keep(w: &mut Worst, value: f64, v: f64, h: f64) {
    if value > w.0 {
        *w = (value, v, h);
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let model = F16::new(NOMINAL_XCG)?;
    let refuel_model = refuelling_airframe(1.0)?;
    let light_model = refuelling_airframe(LIGHT_REFUELLING_MASS_FACTOR)?;
    let grids: [(&[f64], &[f64]); 4] = [
        (&[100.0, 170.0], &[500.0, 8000.0]),
        (&[100.0, 120.0, 170.0], &[500.0, 3000.0, 8000.0]),
        (
            &[100.0, 120.0, 145.0, 170.0],
            &[500.0, 3000.0, 5500.0, 8000.0],
        ),
        (
            &[100.0, 110.0, 120.0, 145.0, 170.0],
            &[500.0, 3000.0, 5000.0, 6500.0, 8000.0],
        ),
    ];
    let lattice_v: Vec<f64> = (0..=14).map(|i| 100.0 + 5.0 * f64::from(i)).collect();
    let lattice_h: Vec<f64> = (0..=15).map(|i| 500.0 + 500.0 * f64::from(i)).collect();
    let truth: Vec<Vec<ScheduleNode>> = lattice_h
        .iter()
        .map(|&h| {
            lattice_v
                .iter()
                .map(|&v| node(&model, &refuel_model, &light_model, v, h))
                .collect()
        })
        .collect::<Result<_, _>>()?;
    for (gv, gh) in grids {
        let nodes: Vec<Vec<ScheduleNode>> = gh
            .iter()
            .map(|&h| {
                gv.iter()
                    .map(|&v| node(&model, &refuel_model, &light_model, v, h))
                    .collect()
            })
            .collect::<Result<_, _>>()?;
        for (design, pick) in [
            (
                "paper",
                (|n: &ScheduleNode| &n.paper) as fn(&ScheduleNode) -> &Synthesis,
            ),
            ("refuelling", |n: &ScheduleNode| &n.refuel),
            ("refuelling light", |n: &ScheduleNode| &n.refuel_light),
        ] {
            let (mut radius, mut k_err, mut alpha_err) =
                ([(0.0, 0.0, 0.0); 2], [(0.0, 0.0, 0.0); 2], (0.0, 0.0, 0.0));
            for (ih, &h) in lattice_h.iter().enumerate() {
                for (iv, &v) in lattice_v.iter().enumerate() {
                    let ((i, s), (j, t)) = (cell(gv, v), cell(gh, h));
                    let blend = |f: &dyn Fn(&Synthesis) -> DMatrix<f64>| {
                        let n = |jj: usize, ii: usize| f(pick(&nodes[jj][ii]));
                        (n(j, i) * (1.0 - s) + n(j, i + 1) * s) * (1.0 - t)
                            + (n(j + 1, i) * (1.0 - s) + n(j + 1, i + 1) * s) * t
                    };
                    let here = pick(&truth[ih][iv]);
                    let channels = [
                        (&here.lon, blend(&|x| x.lon.k.clone())),
                        (&here.lat, blend(&|x| x.lat.k.clone())),
                    ];
                    for (c, (d, k)) in channels.into_iter().enumerate() {
                        keep(&mut radius[c], spectral_radius(&(&d.a - &d.b * &k)), v, h);
                        keep(&mut k_err[c], (&k - &d.k).norm() / d.k.norm(), v, h);
                    }
                    let alpha = blend(&|x| DMatrix::from_element(1, 1, x.trim.alpha_rad))[(0, 0)];
                    keep(
                        &mut alpha_err,
                        (alpha - here.trim.alpha_rad).abs().to_degrees(),
                        v,
                        h,
                    );
                }
            }
            println!(
                "{design:>10} grid {gv:?} x {gh:?}\n    spectral radius lon {:.5} at {:?}, lat {:.5} at {:?}\n    \
                 relative gain error lon {:.3} at {:?}, lat {:.3} at {:?}\n    trim alpha error {:.3} deg at {:?}",
                radius[0].0,
                (radius[0].1, radius[0].2),
                radius[1].0,
                (radius[1].1, radius[1].2),
                k_err[0].0,
                (k_err[0].1, k_err[0].2),
                k_err[1].0,
                (k_err[1].1, k_err[1].2),
                alpha_err.0,
                (alpha_err.1, alpha_err.2),
            );
        }
    }
    Ok(())
}
