//! The gain schedule between its nodes: the core's interpolated gains, applied to the
//! receiver linearised where they are interpolated, keep every channel of both procedures
//! (the refuelling procedure's two designs by mass) stable with margin.

use host_sim::receiver::F16;
use host_sim::synthesis::schedule::{SCHEDULE_ALTITUDES_M, SCHEDULE_SPEEDS_MPS, node};
use host_sim::synthesis::{
    ChannelDesign, LIGHT_REFUELLING_MASS_FACTOR, NOMINAL_XCG, linalg::spectral_radius,
    refuelling_airframe,
};
use ibvs_core::inner::ChannelGains;
use ibvs_core::schedule::{FlightCondition, design_at};
use nalgebra::DMatrix;

/// The largest closed-loop spectral radius accepted: the single-point design's own is
/// 0.9934 (refuelling lateral channel); a lattice over the envelope measured at most 0.9942
/// with the interpolated gains.
const MAX_RADIUS: f64 = 0.995;

/// `[K_x | K_a | K_q]` of the core's gains, in the design's `u = -K [x; a; q]` form: `K_a`
/// has a column for each input whose actuator the design carries (`actuated`), in order.
fn gain_matrix<const NX: usize, const NY: usize, const NU: usize>(
    g: &ChannelGains<NX, NY, NU>,
    actuated: &[bool],
) -> DMatrix<f64> {
    let carried: Vec<usize> = (0..NU).filter(|&j| actuated[j]).collect();
    let na = carried.len();
    DMatrix::from_fn(NU, NX + na + NY, |r, c| {
        f64::from(if c < NX {
            g.k_state[r][c]
        } else if c < NX + na {
            g.k_actuator[r][carried[c - NX]]
        } else {
            g.k_integral[r][c - NX - na]
        })
    })
}

fn radius(d: &ChannelDesign, k: &DMatrix<f64>) -> f64 {
    spectral_radius(&(&d.a - &d.b * k))
}

/// Cell centres and the middles of every cell edge (inner and outer), none a node.
fn off_grid_points() -> Vec<(f64, f64)> {
    let mid = |a: &[f64]| {
        a.windows(2)
            .map(|w| 0.5 * (w[0] + w[1]))
            .collect::<Vec<_>>()
    };
    let (mv, mh) = (mid(&SCHEDULE_SPEEDS_MPS), mid(&SCHEDULE_ALTITUDES_M));
    let mut points = Vec::new();
    for &v in &mv {
        for &h in &mh {
            points.push((v, h));
        }
        for &h in &SCHEDULE_ALTITUDES_M {
            points.push((v, h));
        }
    }
    for &h in &mh {
        for &v in &SCHEDULE_SPEEDS_MPS {
            points.push((v, h));
        }
    }
    points
}

#[test]
fn interpolated_gains_keep_every_channel_stable_with_spectral_radius_below_0_995_between_nodes() {
    let model = F16::new(NOMINAL_XCG).expect("model");
    let refuel_model = refuelling_airframe(1.0).expect("model");
    let light_model = refuelling_airframe(LIGHT_REFUELLING_MASS_FACTOR).expect("model");
    let points = off_grid_points();
    assert_eq!(
        points.len(),
        9 + 12 + 12,
        "centres and edge middles of a 4 x 4 grid"
    );
    let mut worst = (0.0, String::new());
    for (v, h) in points {
        let truth =
            node(&model, &refuel_model, &light_model, v, h).expect("synthesis at the point");
        let d = design_at(FlightCondition {
            true_airspeed_mps: v as f32,
            altitude_m: h as f32,
        })
        .expect("inside the envelope");
        for (name, design, k) in [
            (
                "paper lon",
                &truth.paper.lon,
                gain_matrix(&d.lon, &truth.paper.lon.actuated),
            ),
            (
                "paper lat",
                &truth.paper.lat,
                gain_matrix(&d.lat, &truth.paper.lat.actuated),
            ),
            (
                "refuelling lon",
                &truth.refuel.lon,
                gain_matrix(&d.refuel_lon, &truth.refuel.lon.actuated),
            ),
            (
                "refuelling lat",
                &truth.refuel.lat,
                gain_matrix(&d.refuel_lat, &truth.refuel.lat.actuated),
            ),
            (
                "refuelling light lon",
                &truth.refuel_light.lon,
                gain_matrix(&d.refuel_light_lon, &truth.refuel_light.lon.actuated),
            ),
            (
                "refuelling light lat",
                &truth.refuel_light.lat,
                gain_matrix(&d.refuel_light_lat, &truth.refuel_light.lat.actuated),
            ),
        ] {
            let r = radius(design, &k);
            assert!(
                r < MAX_RADIUS,
                "{name} at {v} m/s, {h} m: spectral radius {r:.5} (limit {MAX_RADIUS}; the \
                 point's own design {:.5})",
                design.closed_loop_spectral_radius
            );
            if r > worst.0 {
                worst = (r, format!("{name} at {v} m/s, {h} m"));
            }
        }
    }
    println!("largest spectral radius {:.5}: {}", worst.0, worst.1);
}

#[test]
fn the_interpolated_trim_is_within_half_a_degree_and_0_06_throttle_of_the_true_trim_between_nodes()
{
    // Measured at these points: at most 0.45 degrees of angle of attack and 0.052 of throttle
    // (at 110 m/s, 6,750 m, where the throttle needed rises fastest towards the slow, high
    // corner). A trim error is a bias the integrators take out: half a degree is a few tenths
    // of a metre per second of climb rate, 0.05 throttle about 2 % of thrust, before they do.
    let model = F16::new(NOMINAL_XCG).expect("model");
    let refuel_model = refuelling_airframe(1.0).expect("model");
    let light_model = refuelling_airframe(LIGHT_REFUELLING_MASS_FACTOR).expect("model");
    let (mut worst_alpha, mut worst_throttle) = (0.0_f64, 0.0_f64);
    for (v, h) in off_grid_points() {
        let truth = node(&model, &refuel_model, &light_model, v, h)
            .expect("synthesis")
            .paper
            .trim;
        let d = design_at(FlightCondition {
            true_airspeed_mps: v as f32,
            altitude_m: h as f32,
        })
        .expect("inside")
        .trim;
        let err_deg = (f64::from(d.alpha_rad) - truth.alpha_rad)
            .abs()
            .to_degrees();
        assert!(
            err_deg < 0.5,
            "{v} m/s, {h} m: alpha off by {err_deg:.3} deg"
        );
        let err_thr = (f64::from(d.throttle) - truth.throttle).abs();
        assert!(
            err_thr < 0.06,
            "{v} m/s, {h} m: throttle off by {err_thr:.3}"
        );
        worst_alpha = worst_alpha.max(err_deg);
        worst_throttle = worst_throttle.max(err_thr);
    }
    println!("largest trim errors: alpha {worst_alpha:.3} deg, throttle {worst_throttle:.4}");
}
