//! The drogue estimator's filter (`ibvs_core::estimator::DrogueEstimator`) against a
//! reference written here, in `f64`, from its model in the module doc and
//! `docs/conventions.md`, "Drogue estimator": per axis the state `[r, v]`,
//! `r' = v - u`, `v' = -v / τ + w` (white, PSD `q`), discretised exactly at the period
//! (transition `[[1, g], [0, f]]`, `f = exp(-Ts / τ)`, `g = τ (1 - f)`, input `[-Ts, 0]`,
//! process noise the integrals of `q (τ (1 - e))²`, `q τ (1 - e) e`, `q e²`,
//! `e = exp(-s / τ)` over a step, computed here by quadrature); a frame corrects the offset
//! with variance `(σ0 + σ1 z)²` (depth: `(σd0 + σd2 z²)²`); the lateral axes' step takes
//! the PSD `4 ζ ω` times the measured activity (at least `4 ζ ω` times the floor speed's
//! square; `ω = 2π / P`, the hose's swing), the forward axis its configured one; a
//! prediction `h` ahead adds the process noise over `h` at the measured PSD `2 / τ` times
//! the activity (at the start, the configured one).

use ibvs_core::estimator::{DrogueEstimator, EstimatorConfig, EstimatorModel, Restart, TipFrame};

const TS: f32 = 0.02;
/// The feed-forward's lead the models are built with (the refuelling default).
const LEAD_S: f32 = 0.8;

/// The process noise `[rr, rv, vv]` over `h` for `tau`, `psd`, by Simpson's rule.
fn process_noise(tau: f64, psd: f64, h: f64) -> [f64; 3] {
    let n = 2000;
    let dh = h / n as f64;
    let mut acc = [0.0; 3];
    for i in 0..=n {
        let w = if i == 0 || i == n {
            1.0
        } else if i % 2 == 1 {
            4.0
        } else {
            2.0
        };
        let e = (-(i as f64) * dh / tau).exp();
        let a = tau * (1.0 - e);
        for (acc, v) in acc.iter_mut().zip([a * a, a * e, e * e]) {
            *acc += w * v;
        }
    }
    acc.map(|v| psd * v * dh / 3.0)
}

/// One axis of the reference filter.
#[derive(Clone, Copy, Debug)]
struct RefAxis {
    x: [f64; 2],
    /// `[rr, rv, vv]`.
    p: [f64; 3],
}

impl RefAxis {
    fn predict(&mut self, tau: f64, psd: f64, h: f64, u: f64) {
        let f = (-h / tau).exp();
        let g = tau * (1.0 - f);
        let q = process_noise(tau, psd, h);
        let [r, v] = self.x;
        self.x = [r + g * v - h * u, f * v];
        let [rr, rv, vv] = self.p;
        self.p = [
            rr + 2.0 * g * rv + g * g * vv + q[0],
            f * rv + f * g * vv + q[1],
            f * f * vv + q[2],
        ];
    }

    fn correct(&mut self, z: f64, var: f64) {
        let [rr, rv, vv] = self.p;
        let s = rr + var;
        let k = [rr / s, rv / s];
        let nu = z - self.x[0];
        self.x = [self.x[0] + k[0] * nu, self.x[1] + k[1] * nu];
        // (I - K H) P.
        self.p = [(1.0 - k[0]) * rr, (1.0 - k[0]) * rv, vv - k[1] * rv];
    }
}

fn close(got: f32, want: f64, rel: f64, what: &str) {
    let err = (f64::from(got) - want).abs();
    assert!(
        err <= rel * want.abs().max(1e-3),
        "{what}: {got} vs {want} (error {err})"
    );
}

#[test]
fn the_filter_is_the_documented_kalman_filter() {
    against_the_reference(TS);
}

#[test]
fn the_discretisation_is_exact_at_a_period_beyond_one_and_a_half_time_constants() {
    // 3.2 s: 2.5 lateral and 1.6 forward time constants, where the process noise is the
    // closed form (below 1.5 its series); the filter must still be the reference.
    against_the_reference(3.2);
}

/// Runs the estimator and the reference side by side at the period `ts_s`: every estimate,
/// variance, average and prediction must agree.
fn against_the_reference(ts_s: f32) {
    let cfg = EstimatorConfig::default();
    let m = EstimatorModel::new(&cfg, ts_s, LEAD_S);
    let (tau, psd) = (
        f64::from(cfg.drogue_time_constant_s),
        f64::from(cfg.drogue_accel_psd_m2ps3),
    );
    let (tau_f, psd_f) = (
        f64::from(cfg.drogue_fwd_time_constant_s),
        f64::from(cfg.drogue_fwd_accel_psd_m2ps3),
    );
    // A drogue 0.4 m right, 0.2 m up, 3 m ahead, drifting; the tip moving; frames every
    // step but every fifth (coasting).
    let frame = |k: usize| {
        let t = k as f32 * TS;
        TipFrame {
            drogue_from_tip_m: [
                0.4 + 0.3 * t + 0.01 * (k % 3) as f32,
                -0.2 - 0.1 * t,
                3.0 - 0.5 * t,
            ],
            camera_depth_m: 3.0 - 0.5 * t,
        }
    };
    // The tip's velocity, scaled so that it moves as far in a period whatever the period.
    let per = 0.02 / ts_s;
    let tip = |k: usize| [0.05 * (k % 4) as f32 * per, -0.02 * per, 0.4 * per];
    let noise = |z: f64| {
        let r = f64::from(cfg.offset_noise_m) + f64::from(cfg.offset_noise_per_m) * z;
        let d = f64::from(cfg.depth_noise_m) + f64::from(cfg.depth_noise_per_m2) * z * z;
        (r * r, d * d)
    };
    let mut e = DrogueEstimator::default();
    let f0 = frame(0);
    e.start(&f0, &cfg);
    let (r0, d0) = noise(f64::from(f0.camera_depth_m));
    let v0 = f64::from(cfg.initial_velocity_sigma_mps).powi(2);
    let mut reference: [RefAxis; 3] = core::array::from_fn(|i| RefAxis {
        x: [f64::from(f0.drogue_from_tip_m[i]), 0.0],
        p: [if i < 2 { r0 } else { d0 }, 0.0, v0],
    });
    // The averages (module doc): after each prediction, the drogue velocity's square into
    // the activity over `activity_time_constant_s` (from q τ / 2), the offset into the mean
    // offset over `mean_time_constant_s` (from the first frame).
    let ts = f64::from(ts_s);
    let activity_step = ts / f64::from(cfg.activity_time_constant_s);
    let mean_step = ts / f64::from(cfg.mean_time_constant_s);
    let mut activity = [psd * tau / 2.0; 2];
    let mut mean = [
        f64::from(f0.drogue_from_tip_m[0]),
        f64::from(f0.drogue_from_tip_m[1]),
    ];
    // The filter's PSD per unit activity: the swing's `4 ζ ω`.
    let swing = 4.0 * f64::from(cfg.drogue_swing_damping_ratio) * 2.0 * std::f64::consts::PI
        / f64::from(cfg.drogue_swing_period_s);
    let floor = swing * f64::from(cfg.drogue_speed_floor_mps).powi(2);
    for k in 1..40 {
        let u = tip(k);
        e.predict(u, &m);
        let lateral = activity.map(|a| (swing * a).max(floor));
        for (i, a) in reference.iter_mut().enumerate() {
            let (t, q) = if i < 2 {
                (tau, lateral[i])
            } else {
                (tau_f, psd_f)
            };
            a.predict(t, q, ts, f64::from(u[i]));
        }
        for i in 0..2 {
            let a = &reference[i];
            activity[i] += activity_step * (a.x[1] * a.x[1] - activity[i]);
            mean[i] += mean_step * (a.x[0] - mean[i]);
        }
        if k % 5 != 0 {
            let f = frame(k);
            let c = e.correct(&f, &cfg);
            assert!(!c.rejected && c.restarted.is_none(), "step {k}");
            let (rv, dv) = noise(f64::from(f.camera_depth_m));
            for (i, a) in reference.iter_mut().enumerate() {
                a.correct(
                    f64::from(f.drogue_from_tip_m[i]),
                    if i < 2 { rv } else { dv },
                );
            }
        }
        let est = e.estimate();
        let what = |s: &str| format!("period {ts_s} s, step {k}: {s}");
        close(est.offset_m[0], reference[0].x[0], 1e-4, &what("right"));
        close(est.offset_m[1], reference[1].x[0], 1e-4, &what("down"));
        close(est.depth_m, reference[2].x[0], 1e-4, &what("depth"));
        for (v, a) in est.drogue_velocity_mps.iter().zip(&reference) {
            close(*v, a.x[1], 1e-3, &what("velocity"));
        }
        close(est.mean_offset_m[0], mean[0], 1e-4, &what("mean right"));
        close(est.mean_offset_m[1], mean[1], 1e-4, &what("mean down"));
        let psd_measured = e.measured_accel_psd_m2ps3(&m);
        for i in 0..2 {
            close(
                psd_measured[i],
                2.0 / tau * activity[i],
                1e-3,
                &what("measured PSD"),
            );
        }
        let var = e.offset_variance_m2();
        close(var[0], reference[0].p[0], 1e-3, &what("right variance"));
        close(var[1], reference[1].p[0], 1e-3, &what("down variance"));
        close(
            e.depth_variance_m2(),
            reference[2].p[0],
            1e-3,
            &what("depth variance"),
        );
    }
    // The offset's error variance: the filter's plus the considered angular bias's,
    // `(σ_b D)²` at the estimated depth.
    let depth = reference[2].x[0];
    let bias = cfg
        .bearing_bias_sigma_rad
        .map(|b| (f64::from(b) * depth).powi(2));
    let err = e.offset_error_variance_m2(&m);
    for i in 0..2 {
        close(
            err[i],
            reference[i].p[0] + bias[i],
            1e-3,
            &format!("axis {i}: error variance"),
        );
    }
    // Predicted 0.3 s and 3 s ahead (below and beyond 1.5 τ) with the tip moving
    // 0.2 m/s right and 0.1 m/s down: the reference carried over the horizon, at the
    // measured PSD (the configured one at the start, q τ / 2 of stationary variance,
    // moved by the average of the estimated velocity's square since), plus the considered
    // bias at the present depth.
    let psd_now = activity.map(|a| 2.0 / tau * a);
    for h in [0.3_f32, 3.0] {
        let p = e.predict_offset(h, [0.2, 0.1], &m);
        for i in 0..2 {
            let mut a = reference[i];
            a.predict(tau, psd_now[i], f64::from(h), [0.2, 0.1][i]);
            close(
                p[i].mean_m,
                a.x[0],
                1e-4,
                &format!("{h} s ahead, axis {i}: mean"),
            );
            close(
                p[i].variance_m2,
                a.p[0] + bias[i],
                3e-3,
                &format!("{h} s ahead, axis {i}: variance"),
            );
        }
        // And without a swing configured the velocity ahead decays as exp(-h / τ).
        let no_swing = EstimatorConfig {
            drogue_swing_period_s: 0.0,
            ..cfg
        };
        let v = e.drogue_velocity_ahead(&EstimatorModel::new(&no_swing, ts_s, h));
        let decay = (-f64::from(h) / tau).exp();
        close(
            v[0],
            reference[0].x[1] * decay,
            1e-3,
            "velocity ahead, right",
        );
        close(
            v[1],
            reference[1].x[1] * decay,
            1e-3,
            "velocity ahead, down",
        );
    }
}

#[test]
fn the_measured_psd_starts_at_the_configured_one() {
    // At the start the activity is the configured PSD's stationary velocity variance,
    // q τ / 2, so the measured PSD, 2 E[v²] / τ, is q.
    let cfg = EstimatorConfig::default();
    let m = EstimatorModel::new(&cfg, TS, LEAD_S);
    let mut e = DrogueEstimator::default();
    e.start(
        &TipFrame {
            drogue_from_tip_m: [0.1, 0.1, 3.0],
            camera_depth_m: 3.0,
        },
        &cfg,
    );
    for q in e.measured_accel_psd_m2ps3(&m) {
        close(
            q,
            f64::from(cfg.drogue_accel_psd_m2ps3),
            1e-5,
            "measured PSD",
        );
    }
}

#[test]
fn started_until_stopped_and_stopped_it_reads_zero() {
    let cfg = EstimatorConfig::default();
    let mut e = DrogueEstimator::default();
    assert!(!e.started());
    e.start(
        &TipFrame {
            drogue_from_tip_m: [0.3, -0.2, 3.0],
            camera_depth_m: 3.0,
        },
        &cfg,
    );
    assert!(e.started());
    assert_eq!(e.estimate().depth_m, 3.0);
    e.stop();
    assert!(!e.started());
    assert_eq!(e.estimate(), Default::default());
}

#[test]
fn the_innovation_gate_is_gate_sigmas_standard_deviations() {
    // The innovation's variance is the predicted offset's plus the frame's; a frame 5σ off
    // (inside the 6σ gate) is used, 7σ off is rejected.
    let cfg = EstimatorConfig::default();
    assert_eq!(cfg.gate_sigmas, 6.0);
    let m = EstimatorModel::new(&cfg, TS, LEAD_S);
    let z = 3.0_f32;
    let start = TipFrame {
        drogue_from_tip_m: [0.0, 0.0, z],
        camera_depth_m: z,
    };
    let r = cfg.offset_noise_m + cfg.offset_noise_per_m * z;
    for (sigmas, rejected) in [(5.0_f32, false), (-5.0, false), (7.0, true), (-7.0, true)] {
        let mut e = DrogueEstimator::default();
        e.start(&start, &cfg);
        e.predict([0.0; 3], &m);
        let s = e.offset_variance_m2()[0] + r * r;
        let c = e.correct(
            &TipFrame {
                drogue_from_tip_m: [sigmas * s.sqrt(), 0.0, z],
                camera_depth_m: z,
            },
            &cfg,
        );
        assert_eq!(c.rejected, rejected, "{sigmas} sigma");
    }
}

#[test]
fn after_max_rejections_in_a_row_the_next_rejected_frame_restarts_the_filter() {
    // A drogue that jumped 2 m: the frames are rejected, `max_rejections` (5) of them
    // without a restart; the one after restarts the filter from it.
    let cfg = EstimatorConfig::default();
    assert_eq!(cfg.max_rejections, 5);
    let m = EstimatorModel::new(&cfg, TS, LEAD_S);
    let mut e = DrogueEstimator::default();
    e.start(
        &TipFrame {
            drogue_from_tip_m: [0.0, 0.0, 3.0],
            camera_depth_m: 3.0,
        },
        &cfg,
    );
    let jumped = TipFrame {
        drogue_from_tip_m: [2.0, 0.0, 3.0],
        camera_depth_m: 3.0,
    };
    for k in 1..=5 {
        e.predict([0.0; 3], &m);
        let c = e.correct(&jumped, &cfg);
        assert!(c.rejected && c.restarted.is_none(), "frame {k}: {c:?}");
    }
    e.predict([0.0; 3], &m);
    let c = e.correct(&jumped, &cfg);
    assert_eq!(c.restarted, Some(Restart::Rejections));
    assert_eq!(e.estimate().offset_m[0], 2.0);
}

#[test]
fn a_non_finite_update_restarts_the_filter() {
    // The invariant of the module doc: the state stays finite; an update that is not (a NaN
    // in the frame: the controller's validation lets none through) restarts it.
    let cfg = EstimatorConfig::default();
    let m = EstimatorModel::new(&cfg, TS, LEAD_S);
    let mut e = DrogueEstimator::default();
    e.start(
        &TipFrame {
            drogue_from_tip_m: [0.0, 0.0, 3.0],
            camera_depth_m: 3.0,
        },
        &cfg,
    );
    e.predict([0.0; 3], &m);
    let c = e.correct(
        &TipFrame {
            drogue_from_tip_m: [f32::NAN, 0.0, 3.0],
            camera_depth_m: 3.0,
        },
        &cfg,
    );
    assert!(!c.rejected);
    assert_eq!(c.restarted, Some(Restart::NonFinite));
}

#[test]
fn an_innovation_exactly_on_the_gate_is_used() {
    // "Beyond gate_sigmas standard deviations" is strict: an innovation whose square is
    // exactly gate_sigmas² times its variance is used. From a start at zero offset (the
    // prediction keeps it at zero exactly: the drogue at rest, the tip still), the innovation
    // is the frame's offset itself; search the floats near 6σ for one whose square is the
    // threshold, exactly as the filter computes both.
    let cfg = EstimatorConfig::default();
    let m = EstimatorModel::new(&cfg, TS, LEAD_S);
    let g2 = cfg.gate_sigmas * cfg.gate_sigmas;
    let mut found = 0;
    for z in [2.0_f32, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0, 5.5] {
        let mut e = DrogueEstimator::default();
        e.start(
            &TipFrame {
                drogue_from_tip_m: [0.0, 0.0, z],
                camera_depth_m: z,
            },
            &cfg,
        );
        e.predict([0.0; 3], &m);
        assert_eq!(e.estimate().offset_m[0], 0.0);
        let r = cfg.offset_noise_m + cfg.offset_noise_per_m * z;
        let limit = g2 * (e.offset_variance_m2()[0] + r * r);
        let centre = limit.sqrt().to_bits();
        let Some(nu) = (centre - 64..centre + 64)
            .map(f32::from_bits)
            .find(|nu| nu * nu == limit)
        else {
            continue;
        };
        found += 1;
        let c = e.correct(
            &TipFrame {
                drogue_from_tip_m: [nu, 0.0, z],
                camera_depth_m: z,
            },
            &cfg,
        );
        assert!(!c.rejected, "z {z}: on the gate");
        // One float beyond is rejected (a fresh filter in the same state).
        let mut e2 = DrogueEstimator::default();
        e2.start(
            &TipFrame {
                drogue_from_tip_m: [0.0, 0.0, z],
                camera_depth_m: z,
            },
            &cfg,
        );
        e2.predict([0.0; 3], &m);
        let beyond = f32::from_bits(nu.to_bits() + 1);
        let c = e2.correct(
            &TipFrame {
                drogue_from_tip_m: [beyond, 0.0, z],
                camera_depth_m: z,
            },
            &cfg,
        );
        assert!(c.rejected, "z {z}: beyond the gate");
    }
    assert!(
        found > 0,
        "no depth gave an exactly representable threshold"
    );
}
