//! Development tool: how the inner loops' damping falls with navigation latency.
//!
//! For the paper's and the refuelling procedure's LQR weights, each designed at the nominal
//! cg, it closes each channel's linear plant at cg 0.30, 0.35 and 0.40 with first-order
//! actuators (20.2 rad/s, inside the zero-order hold; the throttle's engine lag is a plant
//! state already) and the plant states reaching the controller `d` control periods late
//! (the INS latency; the integrators integrate the late outputs too), and prints, for
//! d = 0..=3, the closed loop's spectral radius and its least-damped modes above 0.3 Hz
//! (frequency, damping ratio).
//!
//! `cargo run --release -p host-sim --example delay_margin`
use std::f64::consts::TAU;

use host_sim::receiver::F16;
use host_sim::synthesis::linalg::{spectral_radius, zoh};
use host_sim::synthesis::{self, DesignWeights};
use nalgebra::DMatrix;

/// Bandwidth of the surface actuators, rad/s (the F-16 model's).
const ACTUATOR_RADPS: f64 = 20.2;
/// Control period, s.
const TS_S: f64 = synthesis::CONTROL_PERIOD_S;

/// The closed loop of one channel: continuous plant `a`, `b`, tracked outputs `c`, gain `k`
/// on `[x; integrators]`, the state `d` steps late; `actuated[i]`: input `i` goes through a
/// first-order actuator.
fn closed_loop(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    c: &DMatrix<f64>,
    k: &DMatrix<f64>,
    d: usize,
    actuated: &[bool],
) -> DMatrix<f64> {
    let (n, nu, ny) = (a.nrows(), b.ncols(), c.nrows());
    let na = actuated.iter().filter(|&&x| x).count();
    let np = n + na;
    let mut ac = DMatrix::zeros(np, np);
    let mut bc = DMatrix::zeros(np, nu);
    ac.view_mut((0, 0), (n, n)).copy_from(a);
    let mut j = n;
    for (i, &act) in actuated.iter().enumerate() {
        if act {
            ac.view_mut((0, j), (n, 1)).copy_from(&b.column(i));
            ac[(j, j)] = -ACTUATOR_RADPS;
            bc[(j, i)] = ACTUATOR_RADPS;
            j += 1;
        } else {
            bc.view_mut((0, i), (n, 1)).copy_from(&b.column(i));
        }
    }
    let (ad, bd) = zoh(&ac, &bc, TS_S);
    // State: [plant with actuators (np), x[k-1] .. x[k-d] (d n), integrators (ny)].
    let dim = np + d * n + ny;
    let seen = if d == 0 { 0 } else { np + (d - 1) * n };
    let zo = np + d * n;
    let mut m = DMatrix::zeros(dim, dim);
    m.view_mut((0, 0), (np, np)).copy_from(&ad);
    let kx = k.view((0, 0), (nu, n));
    let kz = k.view((0, n), (nu, ny));
    let mut fx = m.view_mut((0, seen), (np, n));
    fx -= &bd * kx;
    let mut fz = m.view_mut((0, zo), (np, ny));
    fz -= &bd * kz;
    for s in 0..d {
        let (dst, src) = (np + s * n, if s == 0 { 0 } else { np + (s - 1) * n });
        for i in 0..n {
            m[(dst + i, src + i)] = 1.0;
        }
    }
    for r in 0..ny {
        m[(zo + r, zo + r)] = 1.0;
    }
    let mut fq = m.view_mut((zo, seen), (ny, n));
    fq += c * TS_S;
    m
}

/// The least-damped modes above 0.3 Hz: (frequency Hz, damping ratio), one per pair.
fn modes(m: &DMatrix<f64>) -> Vec<(f64, f64)> {
    let mut v: Vec<(f64, f64)> = m
        .complex_eigenvalues()
        .iter()
        .filter(|l| l.im >= 0.0)
        .map(|l| {
            let s = l.ln() / TS_S;
            (s.norm() / TAU, -s.re / s.norm())
        })
        .filter(|&(f, _)| f > 0.3)
        .collect();
    v.sort_by(|a, b| a.1.total_cmp(&b.1));
    v.truncate(2);
    v
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let designs = [
        ("paper", DesignWeights::default()),
        ("refuelling", DesignWeights::refuelling()),
    ];
    let design_at = |xcg: f64, w: &DesignWeights| {
        synthesis::synthesize(
            &F16::new(xcg)?,
            synthesis::REFUELLING_SPEED_MPS,
            synthesis::REFUELLING_ALTITUDE_M,
            TS_S,
            synthesis::PROBE_TIP_BODY_M,
            w,
        )
    };
    for (name, w) in &designs {
        let nominal = design_at(synthesis::NOMINAL_XCG, w)?;
        for xcg in [0.30, 0.35, 0.40] {
            let plant = design_at(xcg, w)?;
            let l = &plant.linear;
            let (lon, lat) = (host_sim::linearize::LON, host_sim::linearize::LAT);
            let channels = [
                (
                    "lon",
                    l.a.view((lon.start, lon.start), (lon.len(), lon.len()))
                        .into_owned(),
                    l.b.view((lon.start, 0), (lon.len(), 2)).into_owned(),
                    &plant.lon.c,
                    &nominal.lon.k,
                    [true, false],
                ),
                (
                    "lat",
                    l.a.view((lat.start, lat.start), (lat.len(), lat.len()))
                        .into_owned(),
                    l.b.view((lat.start, 2), (lat.len(), 2)).into_owned(),
                    &plant.lat.c,
                    &nominal.lat.k,
                    [true, true],
                ),
            ];
            for (ch, a, b, c, k, actuated) in &channels {
                for d in 0..=3 {
                    let m = closed_loop(a, b, c, k, d, actuated);
                    let text: Vec<String> = modes(&m)
                        .iter()
                        .map(|(f, z)| format!("{f:.2} Hz damping {z:.3}"))
                        .collect();
                    println!(
                        "{name:10} xcg {xcg:.2} {ch} d={d}: radius {:.4}; {}",
                        spectral_radius(&m),
                        text.join(", ")
                    );
                }
            }
        }
    }
    Ok(())
}
