//! Development tool: the statistics of the drogue's motion that the core's drogue estimator
//! (`core/src/estimator.rs`) is built on, measured from the simulator's own hose and drogue.
//!
//! `cargo run --release -p host-sim --example drogue_model [-- SPEED_MPS ALTITUDE_M]`
//!
//! The world is the scenarios' (`sim::build_world`): tanker at the refuelling condition
//! (120 m/s, 3,000 m) or at the true airspeed and altitude given (the hose's and the wake's
//! air at that condition, as the envelope's runs fly them), the multi-link hose settled in
//! its steady trail, the tanker wake on,
//! Dryden turbulence of the given RMS intensity, no bow wave and no receiver near the drogue.
//! It is stepped as a run steps it (`World::step` at the plant step of 0.01 s, two per
//! control period) and the drogue's velocity relative to the tanker (right, down, forward;
//! tanker axes) is sampled every control period of 0.02 s, for `RECORD_S` after `SETTLE_S`,
//! for each of the fixed `SEEDS` (repeatable bit for bit).
//!
//! Per intensity and axis it prints:
//! - the RMS velocity (about the record's mean), and per m/s of RMS gust (pooled, and the
//!   smallest and largest of the seeds);
//! - the normalised autocorrelation (biased estimate, pooled over the seeds): the lag where
//!   it first falls to 1/e (the estimator's Gauss-Markov correlation time `tau`), its first
//!   zero crossing, and the swing period as twice the lag of its first negative peak (the
//!   seeds' smallest and largest 1/e lag too);
//! - the damping ratio from the decay between the first negative and the next positive peak
//!   of the autocorrelation (successive extrema of a damped mode's autocorrelation are half a
//!   damped period apart, in the ratio `exp(-pi zeta / sqrt(1 - zeta^2))`);
//! - the Gauss-Markov PSD that matches the variance and `tau`, `q = 2 E[v^2] / tau`, per
//!   (m/s of RMS gust)^2 (the estimator's `drogue_accel_psd_m2ps3` is scaled from it);
//! - the period of the velocity spectrum's peak (Welch: Hann-windowed 100 s segments, half
//!   overlapping, plain DFT on a 0.0025 Hz grid from 0.02 to 1 Hz, pooled over the seeds).
//!
//! A seed gives the same gust path at every intensity, scaled by it: the rows of one axis
//! differ only by what is not linear in the hose's response, and the seeds' spread, not the
//! rows', is the statistical uncertainty.
use host_sim::receiver::F16;
use host_sim::sim::{self, Scenario};
use host_sim::synthesis::{CONTROL_PERIOD_S, NOMINAL_XCG};
use host_sim::world::hose::HoseParams;
use host_sim::world::wake::WakeParams;

/// RMS gust intensities, m/s: light, the estimator's design intensity, MIL-F-8785C's 10^-2.
const SIGMAS_MPS: [f64; 3] = [0.7, 1.45, 1.8];
/// Seeds of the runs of each intensity.
const SEEDS: [u64; 6] = [1, 2, 3, 4, 5, 6];
/// Time simulated before the record starts (the hose leaves its steady trail), s.
const SETTLE_S: f64 = 30.0;
/// Length of each record, s.
const RECORD_S: f64 = 300.0;
/// Plant steps per control period, as the scenarios fly.
const PLANT_SUBSTEPS: u32 = 2;
/// Longest autocorrelation lag computed, s.
const MAX_LAG_S: f64 = 16.0;
/// Welch segment length, s.
const SEGMENT_S: f64 = 100.0;
/// Axis names, in the order of the printed rows.
const AXES: [&str; 3] = ["right", "down", "forward"];

fn main() {
    let start = std::time::Instant::now();
    let model = F16::new(NOMINAL_XCG).expect("F-16 model");
    let args: Vec<f64> = std::env::args()
        .skip(1)
        .map(|a| a.parse().expect("SPEED_MPS ALTITUDE_M: numbers"))
        .collect();
    let mut base = Scenario {
        hose: Some(HoseParams::default()),
        wake: Some(WakeParams::default()),
        bow_wave: false,
        plant_substeps: PLANT_SUBSTEPS,
        ..Scenario::ideal()
    };
    match args[..] {
        [] => {}
        [speed_mps, altitude_m] => {
            base.tanker.speed_mps = speed_mps;
            base.tanker.altitude_m = altitude_m;
        }
        _ => panic!("usage: drogue_model [SPEED_MPS ALTITUDE_M]"),
    }
    let trim = model
        .trim_straight_level(base.tanker.speed_mps, base.tanker.altitude_m)
        .expect("trim");
    let dt_s = CONTROL_PERIOD_S / f64::from(PLANT_SUBSTEPS);
    let settle = (SETTLE_S / CONTROL_PERIOD_S).round() as usize;
    let samples = (RECORD_S / CONTROL_PERIOD_S).round() as usize;
    let max_lag = (MAX_LAG_S / CONTROL_PERIOD_S).round() as usize;

    println!(
        "drogue velocity relative to the tanker at {} m/s, {} m: {} seeds x {RECORD_S} s after \
         {SETTLE_S} s, sampled every {CONTROL_PERIOD_S} s; wake on, bow wave off, no receiver",
        base.tanker.speed_mps,
        base.tanker.altitude_m,
        SEEDS.len()
    );
    let header = |cells: [&str; 12]| {
        println!(
            "{:>5} {:>7} | {:>7} {:>7} {:>13} | {:>5} {:>11} {:>5} {:>6} {:>5} | {:>7} | {:>5}",
            cells[0],
            cells[1],
            cells[2],
            cells[3],
            cells[4],
            cells[5],
            cells[6],
            cells[7],
            cells[8],
            cells[9],
            cells[10],
            cells[11]
        );
    };
    header([
        "sigma", "axis", "rms", "rms/sig", "seeds", "1/e", "seeds", "zero", "period", "zeta",
        "q/sig^2", "peak",
    ]);
    header([
        "m/s", "", "m/s", "", "rms/sig", "s", "1/e s", "s", "s", "", "m2/s3", "s",
    ]);
    for sigma_mps in SIGMAS_MPS {
        // Per axis: pooled autocovariance sums, sample count, and Welch power sums.
        let mut acov = [
            vec![0.0_f64; max_lag + 1],
            vec![0.0; max_lag + 1],
            vec![0.0; max_lag + 1],
        ];
        let mut count = 0usize;
        // Per axis: the seeds' smallest and largest RMS per m/s of gust and 1/e time.
        let mut spread = [[(f64::INFINITY, f64::NEG_INFINITY); 2]; 3];
        let mut power: [Vec<f64>; 3] = Default::default();
        for seed in SEEDS {
            let s = Scenario {
                seed,
                turbulence_sigma_mps: sigma_mps,
                ..base.clone()
            };
            let mut world = sim::build_world(&s, &model, &trim, dt_s).expect("world");
            let mut record = [
                Vec::with_capacity(samples),
                Vec::with_capacity(samples),
                Vec::with_capacity(samples),
            ];
            for k in 0..settle + samples {
                for i in 0..PLANT_SUBSTEPS {
                    let t_s = k as f64 * CONTROL_PERIOD_S + f64::from(i) * dt_s;
                    world.step(dt_s, &trim.state, t_s);
                }
                if k >= settle {
                    let host_sim::world::Drogue::Hose(h) = &world.drogue else {
                        unreachable!("the scenario has a hose");
                    };
                    let v = h.drogue_velocity_tanker_mps();
                    for (axis, r) in record.iter_mut().enumerate() {
                        // Tanker axes are x forward, y right, z down.
                        r.push(v[[1, 2, 0][axis]]);
                    }
                }
            }
            count += samples;
            for (axis, r) in record.iter_mut().enumerate() {
                let mean = r.iter().sum::<f64>() / r.len() as f64;
                r.iter_mut().for_each(|v| *v -= mean);
                let own: Vec<f64> = (0..=max_lag)
                    .map(|lag| r.iter().zip(&r[lag..]).map(|(a, b)| a * b).sum::<f64>())
                    .collect();
                let rms = (own[0] / samples as f64).sqrt() / sigma_mps;
                let tau_s = first_below(&normalised(&own), (-1.0_f64).exp())
                    .map_or(f64::NAN, |k| k * CONTROL_PERIOD_S);
                for (range, x) in spread[axis].iter_mut().zip([rms, tau_s]) {
                    *range = (range.0.min(x), range.1.max(x));
                }
                acov[axis].iter_mut().zip(own).for_each(|(a, b)| *a += b);
                let p = welch(r);
                if power[axis].is_empty() {
                    power[axis] = p;
                } else {
                    power[axis].iter_mut().zip(p).for_each(|(a, b)| *a += b);
                }
            }
        }
        for axis in 0..3 {
            let c = &acov[axis];
            let variance = c[0] / count as f64;
            let rms = variance.sqrt();
            let rho = normalised(c);
            let lag_s = |k: f64| k * CONTROL_PERIOD_S;
            let tau_s = first_below(&rho, (-1.0_f64).exp()).map(lag_s);
            let zero_s = first_below(&rho, 0.0).map(lag_s);
            let extrema = extrema(&rho);
            let period_s = extrema.first().map(|&(k, _)| 2.0 * lag_s(k as f64));
            let zeta = match extrema.as_slice() {
                [(_, neg), (_, pos), ..] if *neg < 0.0 && *pos > 0.0 => {
                    let d = (-neg / pos).ln();
                    Some(d / (std::f64::consts::PI.powi(2) + d * d).sqrt())
                }
                _ => None,
            };
            let q = tau_s.map(|t| 2.0 * variance / t / (sigma_mps * sigma_mps));
            let peak_s = {
                let (i, _) = power[axis]
                    .iter()
                    .enumerate()
                    .fold((0, f64::MIN), |m, (i, &p)| if p > m.1 { (i, p) } else { m });
                1.0 / frequency_hz(i)
            };
            let show = |x: Option<f64>, prec: usize| {
                x.map_or_else(|| "-".to_string(), |v| format!("{v:.prec$}"))
            };
            let [(rms_lo, rms_hi), (tau_lo, tau_hi)] = spread[axis];
            println!(
                "{:>5.2} {:>7} | {:>7.4} {:>7.4} {:>13} | {:>5} {:>11} {:>5} {:>6} {:>5} | {:>7} | {:>5.2}",
                sigma_mps,
                AXES[axis],
                rms,
                rms / sigma_mps,
                format!("{rms_lo:.3}..{rms_hi:.3}"),
                show(tau_s, 2),
                format!("{tau_lo:.2}..{tau_hi:.2}"),
                show(zero_s, 2),
                show(period_s, 2),
                show(zeta, 3),
                show(q, 4),
                peak_s
            );
        }
    }
    println!("runtime {:.1} s", start.elapsed().as_secs_f64());
}

/// The autocovariance sums `c` normalised by their value at lag 0.
fn normalised(c: &[f64]) -> Vec<f64> {
    c.iter().map(|x| x / c[0]).collect()
}

/// The first lag (fractional, in samples, linearly interpolated) at which `rho` falls to or
/// below `level`.
fn first_below(rho: &[f64], level: f64) -> Option<f64> {
    rho.windows(2)
        .enumerate()
        .find_map(|(k, w)| (w[1] <= level).then(|| k as f64 + (w[0] - level) / (w[0] - w[1])))
}

/// The interior extrema of `rho` after lag 0 (local minima and maxima, alternating by
/// construction for a smooth curve), as (lag in samples, value).
fn extrema(rho: &[f64]) -> Vec<(usize, f64)> {
    (1..rho.len() - 1)
        .filter(|&k| {
            let (a, b, c) = (rho[k - 1], rho[k], rho[k + 1]);
            (b < a && b <= c) || (b > a && b >= c)
        })
        .map(|k| (k, rho[k]))
        .collect()
}

/// Frequency of the spectrum's `i`-th bin, Hz.
fn frequency_hz(i: usize) -> f64 {
    0.02 + 0.0025 * i as f64
}

/// Welch power estimate of the zero-mean record `r` on the grid of [`frequency_hz`] up to
/// 1 Hz: the sum over Hann-windowed, half-overlapping segments of `SEGMENT_S` of the squared
/// magnitude of their DFT (unnormalised: only the peak's place is used).
fn welch(r: &[f64]) -> Vec<f64> {
    let n = (SEGMENT_S / CONTROL_PERIOD_S).round() as usize;
    let bins = ((1.0 - 0.02) / 0.0025) as usize + 1;
    let window: Vec<f64> = (0..n)
        .map(|i| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / n as f64).cos())
        .collect();
    let mut power = vec![0.0; bins];
    let mut start = 0;
    while start + n <= r.len() {
        let segment = &r[start..start + n];
        for (i, p) in power.iter_mut().enumerate() {
            // The phasor turned by a rotation per sample (exact enough over a segment).
            let (s, c) =
                (2.0 * std::f64::consts::PI * frequency_hz(i) * CONTROL_PERIOD_S).sin_cos();
            let (mut re, mut im, mut pr, mut pi) = (0.0, 0.0, 1.0, 0.0);
            for (x, w) in segment.iter().zip(&window) {
                re += x * w * pr;
                im -= x * w * pi;
                (pr, pi) = (pr * c - pi * s, pr * s + pi * c);
            }
            *p += re * re + im * im;
        }
        start += n / 2;
    }
    power
}
