//! The feed-forward's lead (`RefuellingConfig::feedforward_lead_s`) from two lags at the
//! hose's swing frequency: how late the inner loops move the probe tip after its desired
//! velocity, and how far ahead of the drogue's true velocity the estimator's prediction is.
//! The tip moves in phase with the swing when the two are equal (`docs/conventions.md`,
//! "Drogue estimator", "The lead, from the loops' lag"; printed per schedule node by
//! `examples/feedforward_lead.rs`).
//!
//! - [`loop_lag_s`]: the closed loop of [`super::margins`] (the receiver linearised at the
//!   node with its true cg and mass, its actuators, the navigation's true latency, the
//!   latency predictor and the node's gains), the tip's true velocity against a desired
//!   velocity at angular frequency `w`: `-arg T(e^{jwTs}) / w`, right and down.
//! - [`estimator_advance_s`]: the core's own drogue estimator fed frames of a drogue
//!   swinging sinusoidally at the swing's frequency (the tip at rest), its velocity `lead`
//!   ahead (`DrogueEstimator::drogue_velocity_ahead`) against the true velocity once settled,
//!   as a time; negative when it is behind.
//!
//! Invariant: both are small-signal, deterministic figures (no noise, no random draw): the
//! same inputs give the same numbers.

use std::f64::consts::PI;

use ibvs_core::Controller;
use ibvs_core::ControllerConfig;
use ibvs_core::estimator::{DrogueEstimator, EstimatorConfig, EstimatorModel, TipFrame};
use ibvs_core::nav::FlightCondition;

use super::margins::{FlownLoop, MarginsError, flown_on};
use crate::receiver::ReceiverPlant;

/// The drogue's swing velocity amplitude the estimator is fed, m/s: the RMS 0.19 m/s of the
/// simulated hose in level II air (1 m/s of gust) times √2.
pub const SWING_SPEED_MPS: f64 = 0.27;
/// The camera's depth to the drogue, m (the capture's start: 1 m to go, the camera set back
/// 2.7 m).
pub const CAMERA_DEPTH_M: f32 = 3.7;
/// The frames' latency, control periods (the campaigns' camera: one frame at 50 Hz).
pub const FRAME_LATENCY_STEPS: u32 = 1;

/// The inner loops' lag behind the desired velocity at `omega_radps`, `[right, down]`, s:
/// at the schedule node `(speed, altitude)`, the airframe at cg `xcg` and `mass_factor` of
/// the design's mass, the navigation `true_latency` periods late, the controller `cfg`
/// (which picks its design by its own `mass_factor`).
pub fn loop_lag_s(
    cfg: &ControllerConfig,
    speed_mps: f64,
    altitude_m: f64,
    xcg: f64,
    mass_factor: f64,
    true_latency: usize,
    omega_radps: f64,
) -> Result<[f64; 2], MarginsError> {
    let mut factors = ReceiverPlant::NOMINAL;
    factors.mass_scale = mass_factor;
    let (plant, controller) = flown_on(cfg, xcg, &factors, speed_mps, altitude_m)?;
    let l = FlownLoop {
        plant: &plant,
        controller: &controller,
        true_latency,
    };
    let t = l.velocity_response(&l.matrices(), omega_radps);
    Ok([-t[2].arg() / omega_radps, -t[0].arg() / omega_radps])
}

/// How far ahead of the drogue's true velocity the estimator's velocity `lead_s` ahead is,
/// on the swing of `condition` (the model the controller builds there), s; negative behind.
/// 60 s to settle, then the phase by least squares over 60 s (right axis; the down axis is
/// the same filter).
pub fn estimator_advance_s(cfg: &EstimatorConfig, condition: FlightCondition, lead_s: f32) -> f64 {
    let ts = f64::from(Controller::PERIOD_S);
    let model = EstimatorModel::at(cfg, Controller::PERIOD_S, lead_s, condition);
    let w = 2.0 * PI / f64::from(model.swing_period_s());
    let amplitude = SWING_SPEED_MPS / w;
    let offset =
        |k: u32| amplitude * (w * (f64::from(k) - f64::from(FRAME_LATENCY_STEPS)) * ts).sin();
    let frame = |k: u32| TipFrame {
        drogue_from_tip_m: [offset(k) as f32, offset(k) as f32, CAMERA_DEPTH_M - 2.7],
        camera_depth_m: CAMERA_DEPTH_M,
    };
    let mut est = DrogueEstimator::default();
    est.start(&frame(0), cfg);
    let steps = (120.0 / ts) as u32;
    // ahead = c cos(wt) + s sin(wt); the truth is `a w cos(wt)`.
    let (mut c, mut s) = (0.0, 0.0);
    for k in 1..steps {
        est.predict([0.0; 3], &model);
        est.correct(&frame(k), cfg);
        if k >= steps / 2 {
            let t = f64::from(k) * ts;
            let v = f64::from(est.drogue_velocity_ahead(&model)[0]);
            c += v * (w * t).cos();
            s += v * (w * t).sin();
        }
    }
    // `cos(wt + phi) = cos(phi) cos(wt) - sin(phi) sin(wt)`.
    (-s).atan2(c) / w
}

/// The lead whose advance equals `lag_s` on the swing of `condition`, s, by bisection up
/// to the longest the estimator carries; `None` when even that is behind `lag_s`.
pub fn matching_lead_s(
    cfg: &EstimatorConfig,
    condition: FlightCondition,
    lag_s: f64,
) -> Option<f32> {
    let longest = longest_lead_s(cfg, condition);
    let at = |h: f32| estimator_advance_s(cfg, condition, h);
    if at(longest) < lag_s {
        return None;
    }
    let (mut lo, mut hi) = (0.0_f32, longest);
    for _ in 0..24 {
        let mid = 0.5 * (lo + hi);
        if at(mid) < lag_s {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(0.5 * (lo + hi))
}

/// The longest lead the estimator carries on the swing of `condition`, s
/// (`ibvs_core::estimator::MAX_SWING_LEAD_RAD` of its phase).
pub fn longest_lead_s(cfg: &EstimatorConfig, condition: FlightCondition) -> f32 {
    let period = ibvs_core::estimator::swing_period_s(cfg, condition);
    ibvs_core::estimator::MAX_SWING_LEAD_RAD * period / (2.0 * core::f32::consts::PI)
}

/// The loops' lag `[right, down]` at the node `condition`, at its swing's frequency, for
/// every true cg of [`super::margins::GRID_XCG`] and one and two periods of navigation
/// latency (the campaigns' range), on the airframe at `mass_factor` of the design's mass
/// flown by the controller `cfg`, s.
pub fn grid_lags_s(
    cfg: &ControllerConfig,
    condition: FlightCondition,
    mass_factor: f64,
) -> Result<Vec<[f64; 2]>, MarginsError> {
    let period = ibvs_core::estimator::swing_period_s(&cfg.estimator, condition);
    let w = 2.0 * PI / f64::from(period);
    let (v, h) = (
        f64::from(condition.true_airspeed_mps),
        f64::from(condition.altitude_m),
    );
    let mut lags = Vec::new();
    for &xcg in &super::margins::GRID_XCG {
        for latency in [1, 2] {
            lags.push(loop_lag_s(cfg, v, h, xcg, mass_factor, latency, w)?);
        }
    }
    Ok(lags)
}

/// The default lead's reason, checked: on the design's condition, the lead that matches the
/// lateral loop's mean lag ([`grid_lags_s`]) on an airframe of `mass_factor` told to the
/// controller, s (`None`: beyond the longest).
pub fn design_matching_lead_s(mass_factor: f64) -> Result<Option<f32>, MarginsError> {
    let mut cfg = super::margins::flown_config();
    cfg.mass_factor = mass_factor as f32;
    let condition = FlightCondition::default();
    let lags = grid_lags_s(&cfg, condition, mass_factor)?;
    let mean = lags.iter().map(|l| l[0]).sum::<f64>() / lags.len() as f64;
    Ok(matching_lead_s(&cfg.estimator, condition, mean))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The configured lead (the default's).
    fn default_lead_s() -> f32 {
        ibvs_core::RefuellingConfig::default().feedforward_lead_s
    }

    /// The estimator's prediction gains on the truth one for one with the lead, less its
    /// own lag: behind with no lead, ahead with the default's, and more ahead with more.
    #[test]
    fn the_estimators_advance_grows_with_the_lead() {
        let cfg = EstimatorConfig::default();
        let c = FlightCondition::default();
        let none = estimator_advance_s(&cfg, c, 0.0);
        let some = estimator_advance_s(&cfg, c, 0.5);
        let default = estimator_advance_s(&cfg, c, default_lead_s());
        assert!(none < 0.0 && none > -0.5, "{none}");
        assert!(some > none && default > some, "{none} {some} {default}");
        // What the filter takes back is a fraction of a second, not the whole lead.
        let taken_back = f64::from(default_lead_s()) - default;
        assert!((0.1..0.6).contains(&taken_back), "{taken_back}");
    }

    /// The closed loop follows a slow command one for one (its integrators) and lags a
    /// swing's by a fraction of its period.
    #[test]
    fn the_loops_follow_a_slow_command_and_lag_the_swing() {
        let cfg = super::super::margins::flown_config();
        let (plant, controller) =
            flown_on(&cfg, 0.35, &ReceiverPlant::NOMINAL, 120.0, 3000.0).expect("loop");
        let l = FlownLoop {
            plant: &plant,
            controller: &controller,
            true_latency: 1,
        };
        let m = l.matrices();
        for t in l.velocity_response(&m, 1e-3) {
            assert!((t.norm() - 1.0).abs() < 1e-3 && t.arg().abs() < 1e-2, "{t}");
        }
        let w = 2.0 * PI / 3.9;
        let swing = loop_lag_s(&cfg, 120.0, 3000.0, 0.35, 1.0, 2, w).expect("loop");
        for lag in swing {
            assert!((0.2..1.0).contains(&lag), "{swing:?}");
        }
    }

    /// The default lead is bracketed by the airframes it serves: at least the lead that
    /// matches the lateral loop's lag on the design's airframe, at most what the campaigns'
    /// middle airframe (1.05 of the design's mass, the middle of 0.85..1.25) needs (or the
    /// longest the estimator carries, where that airframe needs more), and lighter
    /// airframes need less.
    #[test]
    fn the_default_lead_serves_the_design_and_the_middle_airframe() {
        let cfg = EstimatorConfig::default();
        let longest = longest_lead_s(&cfg, FlightCondition::default());
        let lead = default_lead_s();
        let design = design_matching_lead_s(1.0).expect("loop").expect("inside");
        assert!(
            design <= lead && lead <= longest,
            "{design} {lead} {longest}"
        );
        let middle = design_matching_lead_s(1.05)
            .expect("loop")
            .unwrap_or(longest);
        assert!(lead <= middle, "{lead} {middle}");
        let light = design_matching_lead_s(0.85).expect("loop").expect("inside");
        assert!(light < design, "{light} {design}");
    }
}
