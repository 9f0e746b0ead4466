//! The navigation system: the receiver's perturbation state from trim, as the core expects
//! it ([`ibvs_core::nav::NavSample`]), either perfect (truth) or as a GNSS-aided inertial
//! navigation system reports it, with the noise, bias and latency of a stated sensor suite.
//!
//! The sensor suite ([`InsErrors`], `docs/models.md`, "Navigation"): a GNSS-aided INS with a
//! tactical-grade IMU. Body rates carry the gyro's bias and angle random walk (Honeywell
//! HG1700 brochure: 1 deg/h bias, 0.125 deg/sqrt(h) random walk, 1 sigma); the attitude a
//! per-run bias and white noise (0.25 deg 1 sigma in roll and pitch: half the 0.5 deg at 95 %
//! the ACSS T2CAS installation manual asks of an inertial reference's roll; 0.5 deg in
//! heading, our judgement); the velocity (NED) a per-run bias and white noise of a few cm/s
//! (GNSS Doppler velocity; our judgement); the whole sample one control period of latency.
//! Speed, angle of attack and sideslip are computed the way an INS computes them, from its
//! velocity in body axes through its own (erroneous) attitude: a heading error then cancels
//! in the track (`psi + beta`) and a pitch error in the flight path (`theta - alpha`), as
//! they do on an aircraft. Air data (airspeed, vanes) is not used by the controller's
//! kinematic outputs (the camera's velocity relative to the tanker), so it is not modelled
//! here.
//!
//! A second, lower-grade suite ([`InsGrade::Industrial`]): an industrial MEMS GNSS/INS, the
//! Xsens MTi-G-700, with the figures of its user manual (Xsens, "MTi User Manual, MTi
//! 10-series and MTi 100-series", document MT0605P): roll and pitch 0.3 deg (dynamic,
//! 1 sigma RMS), yaw 1.0 deg, velocity 0.1 m/s (1 sigma RMS), position 1.0 m (horizontal
//! STD), gyros of 10 deg/h in-run bias stability and 0.01 deg/s/sqrt(Hz) noise density
//! (0.6 deg/sqrt(h)); its attitude and velocity noise per sample are ours (the tactical
//! suite's scaled by the gyro noise, `docs/models.md`, "Navigation").
//!
//! Every figure has a stated physical range ([`INS_LIMITS`]), checked by
//! [`InsErrors::check`] with the key, the value and the range named.
//!
//! Invariants: angles and speed are perturbations from the trim the gains were designed at;
//! positions are relative to the CG's position in the tanker frame at the start of the run;
//! every random draw comes from the run's seed, the same number per sample, so a run is
//! reproducible and the errors do not depend on what the controller does.

use ibvs_core::nav::{FlightCondition, LatNav, LonNav, NavSample};
use nalgebra::{Rotation3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use super::{Tanker, point_in_tanker_m};
use crate::linearize::{N_DESIGN, design_coordinates};
use crate::receiver::{ReceiverState, Trim};

/// The INS's error figures, one standard deviation each. Biases are drawn once per run;
/// noise once per sample.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct InsErrors {
    /// Attitude bias, roll and pitch, deg.
    pub attitude_bias_deg: f64,
    /// Attitude bias, heading, deg.
    pub heading_bias_deg: f64,
    /// Attitude white noise per sample, deg.
    pub attitude_noise_deg: f64,
    /// Gyro bias, deg/h.
    pub gyro_bias_deg_per_h: f64,
    /// Gyro angle random walk, deg/sqrt(h): white rate noise of `ARW sqrt(f)` at the sample
    /// rate `f`.
    pub gyro_random_walk_deg_per_rt_h: f64,
    /// Velocity bias, each NED axis, m/s.
    pub velocity_bias_mps: f64,
    /// Velocity white noise per sample, each NED axis, m/s.
    pub velocity_noise_mps: f64,
    /// Position white noise per sample, each axis, m (positions are not fed back).
    pub position_noise_m: f64,
    /// Age of a sample when the controller receives it, control periods.
    pub latency_steps: u32,
}

impl Default for InsErrors {
    /// The tactical suite ([`InsGrade::Tactical`]).
    fn default() -> Self {
        InsGrade::Tactical.errors()
    }
}

/// Which sensor suite the INS is: its error figures ([`InsGrade::errors`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum InsGrade {
    /// A GNSS-aided INS on a tactical-grade IMU (Honeywell HG1700 gyros; module doc). The
    /// default.
    #[default]
    Tactical,
    /// An industrial MEMS GNSS/INS (Xsens MTi-G-700; module doc).
    Industrial,
}

impl InsGrade {
    /// Every grade, in order.
    pub const ALL: [Self; 2] = [Self::Tactical, Self::Industrial];

    /// The suite's error figures (module doc and `docs/models.md`, "Navigation").
    pub fn errors(self) -> InsErrors {
        match self {
            Self::Tactical => InsErrors {
                attitude_bias_deg: 0.25,
                heading_bias_deg: 0.5,
                attitude_noise_deg: 0.02,
                gyro_bias_deg_per_h: 1.0,
                gyro_random_walk_deg_per_rt_h: 0.125,
                velocity_bias_mps: 0.03,
                velocity_noise_mps: 0.02,
                position_noise_m: 0.5,
                latency_steps: 1,
            },
            Self::Industrial => InsErrors {
                attitude_bias_deg: 0.3,
                heading_bias_deg: 1.0,
                // Ours: the tactical suite's 0.02 deg times the gyros' noise ratio, 0.6 / 0.125.
                attitude_noise_deg: 0.1,
                gyro_bias_deg_per_h: 10.0,
                gyro_random_walk_deg_per_rt_h: 0.6,
                velocity_bias_mps: 0.1,
                // Ours: in the tactical suite's ratio of noise to bias, about 2 / 3.
                velocity_noise_mps: 0.07,
                position_noise_m: 1.0,
                latency_steps: 1,
            },
        }
    }
}

/// One INS figure's allowed range: key (as in a scenario file), inclusive bounds, and the
/// range as the error states it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InsLimit {
    /// Dotted key, `navigation.ins.<figure>`.
    pub key: &'static str,
    /// Smallest allowed value.
    pub min: f64,
    /// Largest allowed value.
    pub max: f64,
    /// The range and its reason, as the error gives it.
    pub allowed: &'static str,
}

/// The allowed range of every figure of [`InsErrors`], in its field order (ours: physical
/// limits, each above the worst consumer-grade MEMS sensor; `docs/models.md`, "Navigation").
pub const INS_LIMITS: [InsLimit; 9] = [
    InsLimit {
        key: "navigation.ins.attitude_bias_deg",
        min: 0.0,
        max: 5.0,
        allowed: "0..=5 deg (an aided INS levels to better than a few degrees)",
    },
    InsLimit {
        key: "navigation.ins.heading_bias_deg",
        min: 0.0,
        max: 10.0,
        allowed: "0..=10 deg",
    },
    InsLimit {
        key: "navigation.ins.attitude_noise_deg",
        min: 0.0,
        max: 2.0,
        allowed: "0..=2 deg per sample",
    },
    InsLimit {
        key: "navigation.ins.gyro_bias_deg_per_h",
        min: 0.0,
        max: 3600.0,
        allowed: "0..=3600 deg/h (1 deg/s: a consumer MEMS gyro's turn-on bias)",
    },
    InsLimit {
        key: "navigation.ins.gyro_random_walk_deg_per_rt_h",
        min: 0.0,
        max: 10.0,
        allowed: "0..=10 deg/sqrt(h)",
    },
    InsLimit {
        key: "navigation.ins.velocity_bias_mps",
        min: 0.0,
        max: 2.0,
        allowed: "0..=2 m/s",
    },
    InsLimit {
        key: "navigation.ins.velocity_noise_mps",
        min: 0.0,
        max: 2.0,
        allowed: "0..=2 m/s per sample",
    },
    InsLimit {
        key: "navigation.ins.position_noise_m",
        min: 0.0,
        max: 100.0,
        allowed: "0..=100 m per sample",
    },
    InsLimit {
        key: "navigation.ins.latency_steps",
        min: 0.0,
        max: 50.0,
        allowed: "0..=50 control steps",
    },
];

/// An INS figure outside its range ([`INS_LIMITS`]).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("{} = {value} is out of range: allowed {}", limit.key, limit.allowed)]
pub struct InsRangeError {
    /// The figure's limit.
    pub limit: InsLimit,
    /// The value given.
    pub value: f64,
}

impl InsErrors {
    /// The figures in [`INS_LIMITS`]'s order.
    pub fn figures(&self) -> [f64; 9] {
        [
            self.attitude_bias_deg,
            self.heading_bias_deg,
            self.attitude_noise_deg,
            self.gyro_bias_deg_per_h,
            self.gyro_random_walk_deg_per_rt_h,
            self.velocity_bias_mps,
            self.velocity_noise_mps,
            self.position_noise_m,
            f64::from(self.latency_steps),
        ]
    }

    /// Checks every figure against its range ([`INS_LIMITS`]), naming the first outside it
    /// with its value and range (a non-finite value is outside every range).
    pub fn check(&self) -> Result<(), InsRangeError> {
        match INS_LIMITS
            .iter()
            .zip(self.figures())
            .find(|(l, v)| !(v.is_finite() && l.min <= *v && *v <= l.max))
        {
            Some((limit, value)) => Err(InsRangeError {
                limit: *limit,
                value,
            }),
            None => Ok(()),
        }
    }

    /// [`InsErrors::check`], the key of the first figure out of range as the error.
    pub fn validate(&self) -> Result<(), &'static str> {
        self.check().map_err(|e| e.limit.key)
    }
}

/// The navigation system of a run.
#[derive(Debug, Clone)]
pub enum Navigation {
    /// Truth.
    Perfect(PerfectNav),
    /// A GNSS-aided INS with errors.
    Ins(Box<InsNav>),
}

impl Navigation {
    /// The sample the controller receives at time `t_s` for the state `x` (advances the
    /// INS's noise and latency line by one sample).
    pub fn sample(&mut self, tanker: &Tanker, x: &ReceiverState, t_s: f64) -> NavSample {
        match self {
            Self::Perfect(n) => n.sample(tanker, x, t_s),
            Self::Ins(n) => n.sample(tanker, x, t_s),
        }
    }
}

/// Perfect navigation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PerfectNav {
    trim_xi: [f64; N_DESIGN],
    start_cg_tanker_m: Vector3<f64>,
}

/// The sample of design coordinates `xi` and CG position `pos` (tanker frame, relative to the
/// start) against the trim's `trim_xi`, at the flight condition of the tanker's track.
fn nav_sample(
    xi: &[f64; N_DESIGN],
    trim_xi: &[f64; N_DESIGN],
    pos: &Vector3<f64>,
    tanker: &Tanker,
) -> NavSample {
    let d: [f32; N_DESIGN] = core::array::from_fn(|i| (xi[i] - trim_xi[i]) as f32);
    NavSample {
        lon: LonNav {
            x_fwd_m: pos.x as f32,
            h_up_m: -pos.z as f32,
            theta_rad: d[0],
            v_mps: d[1],
            alpha_rad: d[2],
            q_radps: d[3],
        },
        lat: LatNav {
            y_right_m: pos.y as f32,
            psi_rad: d[5],
            phi_rad: d[6],
            beta_rad: d[7],
            p_radps: d[8],
            r_radps: d[9],
        },
        condition: FlightCondition {
            true_airspeed_mps: tanker.speed_mps as f32,
            altitude_m: tanker.altitude_m as f32,
        },
    }
}

impl PerfectNav {
    /// Navigation referenced to `trim`, positions from `start_cg_tanker_m`.
    pub fn new(trim: &Trim, start_cg_tanker_m: Vector3<f64>) -> Self {
        Self {
            trim_xi: design_coordinates(&trim.state),
            start_cg_tanker_m,
        }
    }

    /// The sample for state `x` at time `t_s`.
    pub fn sample(&self, tanker: &Tanker, x: &ReceiverState, t_s: f64) -> NavSample {
        let pos = point_in_tanker_m(tanker, x, &Vector3::zeros(), t_s) - self.start_cg_tanker_m;
        nav_sample(&design_coordinates(x), &self.trim_xi, &pos, tanker)
    }
}

/// Salt of the navigation's random stream within a run's seed.
const NAV_SEED_SALT: u64 = 0x6e61_7669; // "navi"

/// A GNSS-aided INS with the errors of [`InsErrors`].
#[derive(Debug, Clone)]
pub struct InsNav {
    perfect: PerfectNav,
    errors: InsErrors,
    rng: ChaCha8Rng,
    /// Per-run biases: attitude (roll, pitch, heading), rad; rates, rad/s; velocity NED, m/s.
    attitude_bias_rad: Vector3<f64>,
    rate_bias_radps: Vector3<f64>,
    velocity_bias_mps: Vector3<f64>,
    /// White rate noise per sample, rad/s.
    rate_noise_radps: f64,
    /// The last samples, oldest first, for the latency.
    line: std::collections::VecDeque<NavSample>,
}

impl InsNav {
    /// An INS referenced to `trim`, positions from `start_cg_tanker_m`, sampled every
    /// `sample_period_s`, its random processes seeded from `seed`.
    pub fn new(
        trim: &Trim,
        start_cg_tanker_m: Vector3<f64>,
        errors: InsErrors,
        sample_period_s: f64,
        seed: u64,
    ) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ NAV_SEED_SALT);
        let mut normal3 = |sigma: [f64; 3]| {
            Vector3::new(
                sigma[0] * rng.sample::<f64, _>(StandardNormal),
                sigma[1] * rng.sample::<f64, _>(StandardNormal),
                sigma[2] * rng.sample::<f64, _>(StandardNormal),
            )
        };
        let att = errors.attitude_bias_deg.to_radians();
        let attitude_bias_rad = normal3([att, att, errors.heading_bias_deg.to_radians()]);
        let gyro = (errors.gyro_bias_deg_per_h / 3600.0).to_radians();
        let rate_bias_radps = normal3([gyro; 3]);
        let velocity_bias_mps = normal3([errors.velocity_bias_mps; 3]);
        let rate_noise_radps = (errors.gyro_random_walk_deg_per_rt_h / 60.0).to_radians()
            * (1.0 / sample_period_s).sqrt();
        Self {
            perfect: PerfectNav::new(trim, start_cg_tanker_m),
            errors,
            rng,
            attitude_bias_rad,
            rate_bias_radps,
            velocity_bias_mps,
            rate_noise_radps,
            line: std::collections::VecDeque::new(),
        }
    }

    fn normal3(&mut self, sigma: f64) -> Vector3<f64> {
        let mut n = || sigma * self.rng.sample::<f64, _>(StandardNormal);
        Vector3::new(n(), n(), n())
    }

    /// What the INS measures of `x` now (before the latency).
    fn measure(&mut self, tanker: &Tanker, x: &ReceiverState, t_s: f64) -> NavSample {
        let e = self.errors;
        let att_noise = self.normal3(e.attitude_noise_deg.to_radians());
        let rate_noise = self.normal3(self.rate_noise_radps);
        let vel_noise = self.normal3(e.velocity_noise_mps);
        let pos_noise = self.normal3(e.position_noise_m);
        // Truth: velocity in NED; the INS's attitude and its velocity resolved in its body axes.
        let v_ned = super::ned_from_body(x) * x.vel_body_mps;
        let euler = x.euler_rad + self.attitude_bias_rad + att_noise;
        let ins_from_ned = Rotation3::from_euler_angles(euler.x, euler.y, euler.z).inverse();
        let measured = ReceiverState {
            vel_body_mps: ins_from_ned * (v_ned + self.velocity_bias_mps + vel_noise),
            euler_rad: euler,
            rate_body_radps: x.rate_body_radps + self.rate_bias_radps + rate_noise,
            ..*x
        };
        let pos = point_in_tanker_m(tanker, x, &Vector3::zeros(), t_s)
            - self.perfect.start_cg_tanker_m
            + pos_noise;
        nav_sample(
            &design_coordinates(&measured),
            &self.perfect.trim_xi,
            &pos,
            tanker,
        )
    }

    /// The sample the controller receives at `t_s`: the one measured `latency_steps` samples
    /// ago (the first one until the line is full).
    pub fn sample(&mut self, tanker: &Tanker, x: &ReceiverState, t_s: f64) -> NavSample {
        let now = self.measure(tanker, x, t_s);
        self.line.push_back(now);
        while self.line.len() > self.errors.latency_steps as usize + 1 {
            self.line.pop_front();
        }
        self.line.front().copied().unwrap_or(now)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::receiver::F16;
    use crate::synthesis::{NOMINAL_XCG, REFUELLING_ALTITUDE_M, REFUELLING_SPEED_MPS};

    fn trim() -> Trim {
        F16::new(NOMINAL_XCG)
            .expect("model")
            .trim_straight_level(REFUELLING_SPEED_MPS, REFUELLING_ALTITUDE_M)
            .expect("trim")
    }

    fn tanker() -> Tanker {
        Tanker {
            speed_mps: REFUELLING_SPEED_MPS,
            altitude_m: REFUELLING_ALTITUDE_M,
        }
    }

    #[test]
    fn without_errors_the_ins_is_perfect_navigation() {
        let t = trim();
        let none = InsErrors {
            attitude_bias_deg: 0.0,
            heading_bias_deg: 0.0,
            attitude_noise_deg: 0.0,
            gyro_bias_deg_per_h: 0.0,
            gyro_random_walk_deg_per_rt_h: 0.0,
            velocity_bias_mps: 0.0,
            velocity_noise_mps: 0.0,
            position_noise_m: 0.0,
            latency_steps: 0,
        };
        let mut x = t.state;
        x.euler_rad.x = 0.05;
        x.vel_body_mps.y = 1.0;
        let perfect = PerfectNav::new(&t, Vector3::zeros());
        let mut ins = InsNav::new(&t, Vector3::zeros(), none, 0.02, 7);
        let (a, b) = (
            perfect.sample(&tanker(), &x, 0.0),
            ins.sample(&tanker(), &x, 0.0),
        );
        for (u, v) in a.as_array().iter().zip(b.as_array()) {
            assert!((u - v).abs() < 1e-5, "{a:?}\n{b:?}");
        }
    }

    #[test]
    fn a_heading_error_cancels_in_the_track_and_a_pitch_error_in_the_flight_path() {
        let t = trim();
        let biased = InsErrors {
            attitude_noise_deg: 0.0,
            gyro_random_walk_deg_per_rt_h: 0.0,
            velocity_noise_mps: 0.0,
            velocity_bias_mps: 0.0,
            latency_steps: 0,
            attitude_bias_deg: 1.0,
            heading_bias_deg: 2.0,
            ..InsErrors::default()
        };
        let mut ins = InsNav::new(&t, Vector3::zeros(), biased, 0.02, 3);
        // A pitch and a heading error, no roll error (a roll error tilts the body's vertical
        // velocity into the sideslip, as it does on an aircraft).
        ins.attitude_bias_rad = Vector3::new(0.0, 1f64.to_radians(), 2f64.to_radians());
        ins.rate_bias_radps = Vector3::zeros();
        let n = ins.sample(&tanker(), &t.state, 0.0);
        // The attitude is off by its bias; the track and the flight path are not.
        assert!(
            (f64::from(n.lat.psi_rad) - 2f64.to_radians()).abs() < 1e-5,
            "{n:?}"
        );
        assert!(
            (f64::from(n.lon.theta_rad) - 1f64.to_radians()).abs() < 1e-5,
            "{n:?}"
        );
        assert!((n.lat.psi_rad + n.lat.beta_rad).abs() < 1e-5, "{n:?}");
        assert!((n.lon.theta_rad - n.lon.alpha_rad).abs() < 2e-4, "{n:?}");
        assert!(n.lon.v_mps.abs() < 1e-4, "{n:?}");
    }

    #[test]
    fn the_latency_delays_the_sample_and_the_seed_fixes_the_errors() {
        let t = trim();
        let errors = InsErrors::default();
        let mut a = InsNav::new(&t, Vector3::zeros(), errors, 0.02, 11);
        let mut b = InsNav::new(&t, Vector3::zeros(), errors, 0.02, 11);
        let mut c = InsNav::new(&t, Vector3::zeros(), errors, 0.02, 12);
        let mut x = t.state;
        let mut first = None;
        for k in 0..3 {
            x.rate_body_radps.y = 0.1 * f64::from(k);
            let (sa, sb, sc) = (
                a.sample(&tanker(), &x, 0.0),
                b.sample(&tanker(), &x, 0.0),
                c.sample(&tanker(), &x, 0.0),
            );
            assert_eq!(sa, sb, "same seed, same errors");
            assert_ne!(sa, sc, "another seed, other errors");
            if k == 0 {
                first = Some(sa);
            }
            if k == 1 {
                // One step of latency: the second sample is the first measured.
                assert_eq!(Some(sa), first);
            }
            if k == 2 {
                assert!((sa.lon.q_radps - 0.1).abs() < 0.01, "{sa:?}");
            }
        }
    }

    #[test]
    fn the_figures_are_checked() {
        assert_eq!(InsErrors::default().validate(), Ok(()));
        let bad = InsErrors {
            velocity_noise_mps: -1.0,
            ..InsErrors::default()
        };
        assert_eq!(bad.validate(), Err("navigation.ins.velocity_noise_mps"));
    }

    /// RMS error of the attitude (rad), the body rates (rad/s) and the speed (m/s) the INS
    /// reports of a receiver held at trim, over `n` samples and `seeds` runs.
    fn rms_errors(grade: InsGrade, n: usize, seeds: u64) -> [f64; 3] {
        let t = trim();
        let errors = InsErrors {
            latency_steps: 0,
            ..grade.errors()
        };
        let mut sum = [0.0; 3];
        for seed in 0..seeds {
            let mut ins = InsNav::new(&t, Vector3::zeros(), errors, 0.02, seed);
            for k in 0..n {
                let s = ins.sample(&tanker(), &t.state, k as f64 * 0.02);
                let (lon, lat) = (s.lon, s.lat);
                let att = [lon.theta_rad, lat.phi_rad, lat.psi_rad];
                let rate = [lon.q_radps, lat.p_radps, lat.r_radps];
                sum[0] += att.iter().map(|a| f64::from(*a).powi(2)).sum::<f64>();
                sum[1] += rate.iter().map(|a| f64::from(*a).powi(2)).sum::<f64>();
                sum[2] += f64::from(lon.v_mps).powi(2);
            }
        }
        sum.map(|x| (x / (n as f64 * seeds as f64)).sqrt())
    }

    /// The industrial suite's attitude, rates and speed are worse than the tactical's, by
    /// about the ratio of their figures.
    #[test]
    fn the_industrial_ins_errs_more_than_the_tactical() {
        let tactical = rms_errors(InsGrade::Tactical, 500, 40);
        let industrial = rms_errors(InsGrade::Industrial, 500, 40);
        println!(
            "rms attitude, rate, speed errors: tactical {tactical:?}, industrial {industrial:?}"
        );
        for (name, t, i) in [
            ("attitude", tactical[0], industrial[0]),
            ("rates", tactical[1], industrial[1]),
            ("speed", tactical[2], industrial[2]),
        ] {
            assert!(i > 1.5 * t, "{name}: industrial {i} vs tactical {t}");
        }
        // Rate noise: ARW sqrt(f), 0.6 against 0.125 deg/sqrt(h) at 50 Hz.
        let ratio = industrial[1] / tactical[1];
        assert!((ratio / (0.6 / 0.125) - 1.0).abs() < 0.1, "{ratio}");
    }

    #[test]
    fn both_grades_are_inside_every_limit_and_the_limits_name_their_figure() {
        for g in InsGrade::ALL {
            assert_eq!(g.errors().check(), Ok(()), "{g:?}");
        }
        assert_eq!(INS_LIMITS.len(), InsErrors::default().figures().len());
        for (i, limit) in INS_LIMITS.iter().enumerate() {
            // Each key is its figure's: spoil figure i alone and the error names key i.
            let mut e = InsErrors::default();
            match i {
                0 => e.attitude_bias_deg = f64::NAN,
                1 => e.heading_bias_deg = -1.0,
                2 => e.attitude_noise_deg = 2.5,
                3 => e.gyro_bias_deg_per_h = 1e30,
                4 => e.gyro_random_walk_deg_per_rt_h = 11.0,
                5 => e.velocity_bias_mps = 3.0,
                6 => e.velocity_noise_mps = f64::INFINITY,
                7 => e.position_noise_m = 101.0,
                _ => e.latency_steps = 51,
            }
            let err = e.check().unwrap_err();
            assert_eq!(err.limit.key, limit.key);
            assert!(err.to_string().contains(limit.allowed), "{err}");
        }
    }
}
