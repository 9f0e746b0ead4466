//! What the controller reports and keeps, against the `controller` module doc and
//! `docs/conventions.md`: the status bits are distinct single bits (the logs and the link
//! carry them as a number; the saturation flags are bits 2..5 in channel order), the
//! accessors give back what the controller flies, and a refused reconfiguration says why;
//! PBVS reconstructs the drogue with the trim pitch of the design the schedule loaded
//! ("Outer loop (PBVS baseline)": the attitude is the trim pitch plus the perturbations);
//! and, flying the refuelling procedure ("The refuelling procedure" table), the desired
//! velocity each mode asks for: closing at the contact speed in the approach and the
//! capture (the forward axis slewing at `velocity_limits.max_accel_mps2`), backing off and
//! descending for `missed_clear_s` of a missed approach, then holding the station; the
//! go/no-go gate's figure ("The go/no-go gate"): the offset predicted by the drogue
//! estimator `t_go` ahead (the depth over the present closing speed, at most
//! `gate_max_horizon_s`), its radial mean plus `gate_sigmas` standard deviations of the
//! larger axis, in the approach and the capture only (infinite elsewhere); the saturation
//! bits name exactly the channels held at a limit.

use ibvs_core::config::ConfigProblem;
use ibvs_core::controller::StatusFlags;
use ibvs_core::estimator::{DrogueEstimator, EstimatorModel, TipFrame, TipGeometry, TipSight};
use ibvs_core::gains::TRIM;
use ibvs_core::kinematics::point_velocity_tanker_mps;
use ibvs_core::measurement::CameraMeasurement;
use ibvs_core::nav::{FlightCondition, NavSample};
use ibvs_core::procedure;
use ibvs_core::schedule::design_at;
use ibvs_core::{
    ConfigError, Controller, ControllerConfig, ControllerInput, ControllerOutput, Mode,
    ModeRequest, OuterLaw, ReconfigureError,
};
use nalgebra::{Rotation3, Vector3};

/// A frame numbered `seq` showing the drogue at `(x, y)` at `depth_m`.
fn frame(seq: u32, x: f32, y: f32, depth_m: f32) -> CameraMeasurement {
    CameraMeasurement {
        seq,
        tracked: true,
        image_x: x,
        image_y: y,
        depth_m,
        probe_tip: None,
    }
}

/// One step's input in the paper's approach: frame `seq` with the drogue a little right of
/// and above the centre at 6 m, moving by 1e-4 from step to step (never a frozen image).
fn approach_input(seq: u32, request: ModeRequest, nav: NavSample) -> ControllerInput {
    ControllerInput {
        measurement: frame(seq, 0.05 + 1e-4 * (seq % 3) as f32, -0.02, 6.0),
        nav,
        probe_contact: false,
        autopilot_ready: true,
        request,
    }
}

const FLAGS: [(&str, u16); 11] = [
    ("MEASUREMENT_HELD", StatusFlags::MEASUREMENT_HELD),
    ("NAV_HELD", StatusFlags::NAV_HELD),
    ("SATURATED_ELEVATOR", StatusFlags::SATURATED_ELEVATOR),
    ("SATURATED_THROTTLE", StatusFlags::SATURATED_THROTTLE),
    ("SATURATED_AILERON", StatusFlags::SATURATED_AILERON),
    ("SATURATED_RUDDER", StatusFlags::SATURATED_RUDDER),
    ("LON_INTEGRATOR_FROZEN", StatusFlags::LON_INTEGRATOR_FROZEN),
    ("LAT_INTEGRATOR_FROZEN", StatusFlags::LAT_INTEGRATOR_FROZEN),
    ("ENGAGE_REFUSED", StatusFlags::ENGAGE_REFUSED),
    ("NON_FINITE_COMMAND", StatusFlags::NON_FINITE_COMMAND),
    ("OPEN_LOOP", StatusFlags::OPEN_LOOP),
];

#[test]
fn every_status_flag_is_a_bit_of_its_own() {
    let mut seen = 0u16;
    for (name, f) in FLAGS {
        assert_eq!(f.count_ones(), 1, "{name} = {f:#x} is not a single bit");
        assert_eq!(seen & f, 0, "{name} = {f:#x} shares its bit");
        seen |= f;
        // `contains` tests exactly its bits.
        assert!(StatusFlags(f).contains(f) && StatusFlags(u16::MAX).contains(f));
        assert!(
            !StatusFlags(!f).contains(f) && !StatusFlags(0).contains(f),
            "{name}"
        );
    }
    // The saturation flags: bits 2..5 in the actuator channels' order (elevator, throttle,
    // aileron, rudder), as their doc states.
    assert_eq!(
        [
            StatusFlags::SATURATED_ELEVATOR,
            StatusFlags::SATURATED_THROTTLE,
            StatusFlags::SATURATED_AILERON,
            StatusFlags::SATURATED_RUDDER,
        ],
        [1 << 2, 1 << 3, 1 << 4, 1 << 5]
    );
}

#[test]
fn the_controller_gives_back_the_configuration_it_flies() {
    let mut cfg = ControllerConfig::paper();
    cfg.modes.hold_limit_steps = 7;
    cfg.integrator_limit_m = 3.5;
    let ctl = Controller::new(cfg).expect("valid configuration");
    assert_eq!(*ctl.config(), cfg);
    assert_ne!(*ctl.config(), ControllerConfig::default());
}

#[test]
fn a_refused_reconfiguration_names_the_mode_or_the_configurations_own_error() {
    let busy = ReconfigureError::NotStandby(Mode::Approach).to_string();
    assert!(
        busy.contains("Approach") && busy.contains("Standby"),
        "{busy}"
    );
    let e = ConfigError {
        field: "velocity_limits",
        problem: ConfigProblem::Inconsistent,
        requirement: "every limit finite, > 0",
    };
    // The configuration's error, as it words it itself.
    assert_eq!(ReconfigureError::Invalid(e).to_string(), e.to_string());
    assert!(e.to_string().contains("velocity_limits"));
}

#[test]
fn pbvs_reconstructs_the_drogue_with_the_trim_pitch_of_the_scheduled_design() {
    let mut cfg = ControllerConfig::paper();
    cfg.law = OuterLaw::Pbvs;
    let mut ctl = Controller::new(cfg).expect("valid configuration");
    // A condition whose trim pitch is not the single-point design's.
    let condition = FlightCondition {
        true_airspeed_mps: 150.0,
        altitude_m: 3000.0,
    };
    let trim_pitch = design_at(condition)
        .expect("inside the envelope")
        .trim
        .theta_rad;
    assert!((trim_pitch - ibvs_core::gains::TRIM.theta_rad).abs() > 0.02);
    let nav = NavSample {
        condition,
        ..NavSample::default()
    };
    let input = |seq| ControllerInput {
        measurement: frame(seq, 0.1, -0.05, 6.0),
        nav,
        probe_contact: false,
        autopilot_ready: true,
        request: ModeRequest::None,
    };
    ctl.step(&input(1));
    assert!(
        ctl.follow_schedule(),
        "the new condition's design was not loaded"
    );
    let out = ctl.step(&input(2));
    // The drogue in camera axes, into body axes by the believed mount, from the probe tip,
    // into tanker axes by the attitude: the trim pitch, no perturbation.
    let f = |x: f32| f64::from(x);
    let (z, m) = (6.0, &cfg.camera);
    let drogue_cam = Vector3::new(0.1 * z, -0.05 * z, z);
    let p = f(m.pitch_down_rad);
    let body_from_camera =
        nalgebra::Matrix3::new(0.0, -p.sin(), p.cos(), 1.0, 0.0, 0.0, 0.0, p.cos(), p.sin());
    let cam = Vector3::from(m.position_body_m.map(f));
    let tip = Vector3::from(cfg.probe_tip_body_m.map(f));
    let r = Rotation3::from_euler_angles(0.0, f(trim_pitch), 0.0)
        * (cam - tip + body_from_camera * drogue_cam);
    let got = [out.target.right_m, out.target.down_m, out.target.depth_m];
    let want = [r.y, r.z, r.x];
    for (g, w) in got.iter().zip(&want) {
        assert!((f(*g) - w).abs() < 1e-4, "{got:?} vs {want:?}");
    }
}

/// A refuelling sortie: the drogue at rest relative to the tanker, seen by the configured
/// (set-back) camera at `(right, down)` m from the probe tip and `depth` m ahead of it;
/// the navigation at trim, or the receiver closing at `closing_mps` relative to the tanker.
struct Sortie {
    ctl: Controller,
    seq: u32,
    /// Probe tip minus camera, camera axes, m.
    tip: [f32; 3],
}

impl Sortie {
    fn new() -> Self {
        Self::with(ControllerConfig::default())
    }

    /// The same with the configuration `cfg`.
    fn with(cfg: ControllerConfig) -> Self {
        let tip =
            TipGeometry::new(&cfg.camera, cfg.probe_tip_body_m, TRIM.theta_rad).tip_from_camera_m();
        Self {
            ctl: Controller::new(cfg).expect("valid configuration"),
            seq: 0,
            tip,
        }
    }

    fn step(&mut self, at: [f32; 3], closing_mps: f32) -> ControllerOutput {
        self.step_seeing_tip(at, closing_mps, None)
    }

    /// A step whose frame also reports the probe tip's image point `probe_tip`.
    fn step_seeing_tip(
        &mut self,
        [x, y, d]: [f32; 3],
        closing_mps: f32,
        probe_tip: Option<[f32; 2]>,
    ) -> ControllerOutput {
        self.seq += 1;
        let z = d + self.tip[2];
        let mut nav = NavSample::default();
        nav.lon.v_mps = closing_mps;
        self.ctl.step(&ControllerInput {
            measurement: CameraMeasurement {
                seq: self.seq,
                tracked: true,
                // A tracker's noise, so the frozen-frame check does not reject the frames.
                image_x: (x + self.tip[0]) / z + 1e-4 * (self.seq % 5) as f32,
                image_y: (y + self.tip[1]) / z,
                depth_m: z,
                probe_tip,
            },
            nav,
            probe_contact: false,
            autopilot_ready: true,
            request: if self.seq == 1 {
                ModeRequest::Engage
            } else {
                ModeRequest::None
            },
        })
    }

    /// Engaged at the station, held there until cleared to the approach.
    fn to_approach() -> Self {
        let mut s = Self::new();
        let station = [
            0.0,
            0.0,
            procedure::RefuellingConfig::default().station_depth_m,
        ];
        assert_eq!(s.step(station, 0.0).mode, Mode::PreContact);
        for _ in 0..200 {
            if s.step(station, 0.0).mode == Mode::Approach {
                return s;
            }
        }
        panic!("not cleared to the approach at a steady station");
    }
}

/// An approach flown after `far_steps` steps held 0.5 m beyond the station (outside its depth
/// tolerance: never cleared), then closing to it at 0.5 m/s and dwelling there until cleared,
/// then closing at 1 m/s to 0.2 m from the drogue, which stays centred and at rest: the
/// contact speed the air at the approach's start asks for, computed here from the drogue
/// estimator's documented model, and every output from the approach's first step on.
///
/// The model (`ibvs_core::estimator`, module doc): the measured activity (the average of the
/// drogue's lateral velocity squared) starts at engage at the configured PSD's stationary
/// variance `q τ / 2` and, the drogue at rest and nothing moving sideways, decays by
/// `1 - Ts / T` (`activity_time_constant_s`) at every step after it; the approach is flown in
/// rough air, at `rough_air_contact_speed_mps`, when its square root at the approach's first
/// step is above `rough_air_drogue_speed_mps`.
fn approach_after(far_steps: usize) -> (f32, Vec<ControllerOutput>) {
    let mut s = Sortie::new();
    let cfg = *s.ctl.config();
    let (est, rc) = (&cfg.estimator, &cfg.refuelling);
    let far = rc.station_depth_m + 0.5;
    assert_eq!(s.step([0.0, 0.0, far], 0.0).mode, Mode::PreContact);
    let mut engaged_steps = 0_i32;
    let mut approach = None;
    let mut depth = far;
    for k in 0..far_steps + 400 {
        let closing = if k >= far_steps && depth > rc.station_depth_m {
            0.5
        } else {
            0.0
        };
        depth = (depth - closing * Controller::PERIOD_S).max(rc.station_depth_m);
        engaged_steps += 1;
        let out = s.step([0.0, 0.0, depth], closing);
        if k < far_steps {
            assert_eq!(out.mode, Mode::PreContact, "cleared outside the station");
        }
        if out.mode == Mode::Approach {
            approach = Some(out);
            break;
        }
    }
    let first = approach.expect("cleared to the approach at a steady station");
    let ts = f64::from(Controller::PERIOD_S);
    let activity = f64::from(est.drogue_accel_psd_m2ps3) * f64::from(est.drogue_time_constant_s)
        / 2.0
        * (1.0 - ts / f64::from(est.activity_time_constant_s)).powi(engaged_steps);
    let rms = activity.sqrt();
    let threshold = f64::from(rc.rough_air_drogue_speed_mps);
    assert!(
        (rms - threshold).abs() > 0.01,
        "the air at the approach's start ({rms} m/s RMS) must be clearly one side of {threshold}"
    );
    let contact = if rms > threshold {
        rc.rough_air_contact_speed_mps
    } else {
        rc.contact_speed_mps
    };
    // The receiver closes at 1 m/s; the drogue, centred, stays where it is.
    let mut outputs = vec![first];
    while depth >= 0.2 {
        depth -= 0.02;
        outputs.push(s.step([0.0, 0.0, depth], 1.0));
    }
    (contact, outputs)
}

/// The approach and the capture close at the contact speed of the air the approach started
/// in, both ways: calm (the estimator's measured activity decayed below the rough-air
/// threshold while the receiver was held off the station) and rough (cleared at once, the
/// activity still near the configured PSD's). The forward command slews up from the
/// station's zero one step of `max_accel_mps2` at a time, never passes that speed, and is
/// at it (plus the drogue's estimated forward velocity) when the capture ends.
#[test]
fn the_approach_and_the_capture_close_at_the_contact_speed() {
    let cfg = ControllerConfig::default();
    let rc = cfg.refuelling;
    let slew = cfg.velocity_limits.max_accel_mps2 * Controller::PERIOD_S;
    let mut speeds = Vec::new();
    for far_steps in [0, 200] {
        let (contact, outputs) = approach_after(far_steps);
        speeds.push(contact);
        let mut last = 0.0_f32;
        let mut terminal_steps = 0;
        for (k, out) in outputs.iter().enumerate() {
            let v = out.v_des.z_fwd_mps;
            let drogue = out.estimate.drogue_velocity_mps[2];
            let at = format!("held off {far_steps} steps, step {k} in {:?}", out.mode);
            assert!(
                matches!(out.mode, Mode::Approach | Mode::Terminal),
                "{at}: left the approach"
            );
            terminal_steps += usize::from(out.mode == Mode::Terminal);
            // Never faster than the contact speed chosen (the drogue at rest: its estimated
            // forward velocity is a few mm/s at most).
            assert!(
                v <= contact + drogue + 1e-4 && drogue.abs() < 0.01,
                "{at}: {v} m/s, contact speed {contact}, drogue {drogue}"
            );
            // Below it, one slew step a step: never stopping short of it.
            if k > 0 && last < contact - slew {
                assert!(
                    (v - last - slew).abs() < 1e-4,
                    "{at}: {last} -> {v} m/s toward {contact}"
                );
            }
            last = v;
        }
        assert!(
            terminal_steps > 20,
            "the capture was flown {terminal_steps} steps"
        );
        let end = outputs.last().expect("outputs");
        assert_eq!(end.mode, Mode::Terminal);
        let want = contact + end.estimate.drogue_velocity_mps[2];
        assert!(
            (end.v_des.z_fwd_mps - want).abs() < 0.01,
            "held off {far_steps} steps: the capture ends at {} m/s, not {want}",
            end.v_des.z_fwd_mps
        );
    }
    // Cleared at once the air reads rough (the estimator starts cautious); held off 4 s, calm.
    assert_eq!(
        speeds,
        [rc.rough_air_contact_speed_mps, rc.contact_speed_mps]
    );
}

#[test]
fn the_station_integrates_a_steady_offset_and_starts_again_from_zero_at_engage() {
    // The drogue held 0.3 m right of the tip at the station (outside the station's
    // tolerance: never cleared), the navigation unbiased: the lateral command is the
    // proportional term on the mean offset plus the integral, which grows at
    // `ki × mean offset` a second, within its limit; a reset and a new engage start it at 0.
    let mut s = Sortie::new();
    let rc = s.ctl.config().refuelling;
    let off = [0.3, 0.0, 3.0];
    let mut v = Vec::new();
    for _ in 0..1500 {
        let out = s.step(off, 0.0);
        assert_eq!(out.mode, Mode::PreContact);
        v.push(out.v_des.x_right_mps);
    }
    // After 30 s, the mean offset settled for 20 of them: the proportional 0.15 m/s and an
    // integral near `ki × 0.3 m × 28 s` (the 2 s average's lag) beyond it.
    let proportional = rc.track_gain_per_s * 0.3;
    let integral = v[1499] - proportional;
    let want = rc.station_integral_gain_per_s2 * 0.3 * 28.0;
    assert!(
        (integral - want).abs() < 0.15 * want,
        "integral {integral} m/s, about {want} expected"
    );
    assert!(v[1499] > v[1000] && v[1000] > v[500], "still growing");
    // The integral's limit, reached after about 70 s (inside the sortie's 150 s).
    for _ in 0..3_000 {
        s.step(off, 0.0);
    }
    let last = s.step(off, 0.0);
    assert_eq!(last.mode, Mode::PreContact);
    let held = last.v_des.x_right_mps;
    assert!(
        (held - proportional - rc.station_max_integral_mps).abs() < 1e-3,
        "{held}"
    );
    // Reset to standby, engage again: from zero.
    s.ctl.step(&ControllerInput {
        request: ModeRequest::Reset,
        ..approach_input(s.seq + 1, ModeRequest::Reset, NavSample::default())
    });
    s.seq = 0;
    let first = s.step(off, 0.0);
    assert_eq!(first.mode, Mode::PreContact);
    for _ in 0..200 {
        s.step(off, 0.0);
    }
    // 202 steps engaged, the mean offset at 0.3 m from the first frame on.
    let fresh = s.step(off, 0.0).v_des.x_right_mps;
    let since_engage = proportional + rc.station_integral_gain_per_s2 * 0.3 * 202.0 * 0.02;
    assert!(
        (fresh - since_engage).abs() < 2e-3,
        "{fresh} vs {since_engage}"
    );
}

#[test]
fn the_station_takes_a_steady_drift_for_the_navigations_bias_and_flies_it_out() {
    // The navigation reports the receiver still; the frames show the drogue moving right of
    // the tip at 0.02 m/s: a receiver drifting left that the INS does not see (a velocity
    // error of +0.02 m/s, right). The drogue has no mean velocity of its own, so the station
    // learns 0.02 m/s as the navigation's bias (`docs/conventions.md`, "Navigation bias"):
    // the running mean since engage, `b = v n / (n + n1)` for `n` steps with the memory
    // starting at the drogue model's `n1` = 1.3 s / 20 ms = 65 steps, until the memory
    // reaches 20 s (1,000 steps), then fading. The desired velocity carries it.
    let drift = 0.02_f32;
    let fly = |tau_s: f32| {
        let mut cfg = ControllerConfig::default();
        cfg.estimator.nav_bias_time_constant_s = tau_s;
        let mut s = Sortie {
            ctl: Controller::new(cfg).expect("valid configuration"),
            ..Sortie::new()
        };
        let mut learnt = Vec::new();
        for k in 0..3000 {
            let out = s.step([0.3 + drift * k as f32 * 0.02, 0.0, 3.6], 0.0);
            assert_eq!(out.mode, Mode::PreContact, "step {k}");
            learnt.push((s.ctl.nav_bias_mps(), out.v_des));
        }
        learnt
    };
    let on = fly(20.0);
    // After 10 s the running mean is near 500 / 565 of the drift; after 60 s the fading
    // memory is within 3 % of it. The filter's velocity takes a few seconds to settle on
    // the drift: in still air its process noise is the floor's (`drogue_speed_floor_mps`),
    // and the running mean's early shortfall fades with the 20 s memory (3.1 % at 40 s,
    // 1.3 % at 60 s; it was under 3 % at 40 s while the process noise was a fixed,
    // stronger air's).
    let (b10, b60) = (on[499].0, on[2999].0);
    let mean10 = drift * 500.0 / 565.0;
    assert!(
        (b10[0] - mean10).abs() < 0.1 * drift,
        "10 s: {b10:?}, about {mean10}"
    );
    assert!((b60[0] - drift).abs() < 0.03 * drift, "60 s: {b60:?}");
    assert!(
        b60[1].abs() < 0.05 * drift && b60[2].abs() < 0.05 * drift,
        "{b60:?}"
    );
    // Off: nothing is learnt, and the same frames ask for less lateral velocity (the bias
    // is what the station adds to fly the drift out).
    let off = fly(0.0);
    assert!(off.iter().all(|(b, _)| *b == [0.0; 3]));
    let (with, without) = (on[2999].1.x_right_mps, off[2999].1.x_right_mps);
    assert!(
        (with - without - b60[0]).abs() < 0.2 * drift,
        "{with} with the bias, {without} without"
    );
}

#[test]
fn a_missed_approach_backs_off_and_descends_for_its_clearing_time_then_holds_the_station() {
    let mut s = Sortie::to_approach();
    let rc = s.ctl.config().refuelling;
    // The drogue swings off to the right, beyond the abort offset, at 3 m of depth (outside
    // the gate's).
    let mut x = 0.0_f32;
    let mut missed = None;
    for _ in 0..300 {
        x = (x + 0.01).min(0.8);
        let out = s.step([x, 0.0, 3.0], 0.0);
        if out.mode == Mode::MissedApproach {
            missed = Some(out);
            break;
        }
        assert_eq!(out.mode, Mode::Approach);
    }
    let first = missed.expect("no missed approach with the drogue 0.8 m off");
    let clear_steps = (rc.missed_clear_s / Controller::PERIOD_S).round() as usize;
    let mut outs = vec![first];
    for _ in 0..clear_steps + 60 {
        let out = s.step([0.8, 0.0, 3.0], 0.0);
        assert_eq!(out.mode, Mode::MissedApproach);
        outs.push(out);
    }
    // Clearing: the descent (0.5 m/s; the drogue is level with the tip, so no vertical
    // correction) is reached at the missed approach's slew, 1 m/s² (25 steps), and kept.
    for (k, out) in outs.iter().enumerate().take(clear_steps - 5).skip(30) {
        assert!(
            (out.v_des.y_down_mps - rc.missed_down_mps).abs() < 0.02,
            "step {k} of the missed approach: {:?}",
            out.v_des
        );
    }
    // For `missed_clear_s` exactly: the first `clear_steps` steps (the entry's included)
    // keep the descent, the next starts back toward the station's level.
    let slew = rc.missed_accel_mps2 * Controller::PERIOD_S;
    let down: Vec<f32> = outs.iter().map(|o| o.v_des.y_down_mps).collect();
    assert!(
        (down[clear_steps - 1] - rc.missed_down_mps).abs() < 0.02,
        "{}",
        down[clear_steps - 1]
    );
    assert!(
        (down[clear_steps - 1] - down[clear_steps] - slew).abs() < 1e-4,
        "clearing ends at step {clear_steps}: {:?}",
        &down[clear_steps - 2..clear_steps + 2]
    );
    // Then the station: no descent (the drogue's mean is level with the tip).
    let held = outs.last().expect("steps flown").v_des;
    assert!(held.y_down_mps.abs() < 0.02, "{held:?}");
}

#[test]
fn every_probe_tip_sighting_is_counted_as_used_missing_or_rejected() {
    let mut s = Sortie::new();
    let est = s.ctl.config().estimator;
    let tol = est.tip_sight_tolerance;
    let station = [0.0, 0.0, 3.0];
    let count = |s: &Sortie| {
        let c = s.ctl.counters();
        (c.tip_sight_used, c.tip_sight_missing, c.tip_sight_rejected)
    };
    // Where the geometry puts the tip: the learned point until a sighting.
    let t = s.tip;
    let tip_image = [t[0] / t[2], t[1] / t[2]];
    assert_eq!(s.ctl.probe_tip_image(), tip_image);
    // A sighting at the geometry's point and one within the tolerance of it: used; a frame
    // without the marker, the tip being in the set-back camera's view: missing.
    s.step_seeing_tip(station, 0.0, Some(tip_image));
    s.step_seeing_tip(station, 0.0, None);
    let inside = [tip_image[0] + 0.5 * tol, tip_image[1]];
    s.step_seeing_tip(station, 0.0, Some(inside));
    assert_eq!(count(&s), (2, 1, 0));
    // The learned point moved toward the sighting by the filter's weight, and no further.
    let learned = s.ctl.probe_tip_image();
    let want = tip_image[0] + est.tip_sight_filter * (inside[0] - tip_image[0]);
    assert!((learned[0] - want).abs() < 1e-6, "{learned:?}, {want}");
    assert_eq!(learned[1], tip_image[1]);
    // Beyond the tolerance, or not finite: rejected, one count each, the learned point kept.
    s.step_seeing_tip(station, 0.0, Some([tip_image[0] + 2.0 * tol, tip_image[1]]));
    s.step_seeing_tip(station, 0.0, Some([f32::NAN, tip_image[1]]));
    assert_eq!(count(&s), (2, 1, 2));
    assert_eq!(s.ctl.probe_tip_image(), learned);
}

#[test]
fn a_camera_at_the_tip_counts_no_missing_marker() {
    // The refuelling procedure with the camera at the probe tip (the paper's place): no
    // marker to see, nothing missing.
    let mut cfg = ControllerConfig::default();
    cfg.camera.position_body_m = cfg.probe_tip_body_m;
    let mut s = Sortie::with(cfg);
    for _ in 0..5 {
        s.step_seeing_tip([0.3, 0.2, 5.0], 0.0, None);
    }
    assert_eq!(s.ctl.counters().tip_sight_missing, 0);
    assert_eq!(s.ctl.counters().steps, 5);
}

#[test]
fn the_gates_figure_is_the_predicted_radial_offset_plus_its_sigmas() {
    // The controller's drogue estimator, fed here the frames the controller takes (a twin:
    // the same public filter, `estimator_filter.rs` tests it), gives the prediction; the
    // gate's figure is then the documented arithmetic on it.
    let mut s = Sortie::new();
    let cfg = *s.ctl.config();
    let rc = &cfg.refuelling;
    let geometry = TipGeometry::new(&cfg.camera, cfg.probe_tip_body_m, TRIM.theta_rad);
    let sight = TipSight::new(&geometry); // no tip sightings: the geometry's image point
    let model = EstimatorModel::new(
        &cfg.estimator,
        Controller::PERIOD_S,
        cfg.refuelling.feedforward_lead_s,
    );
    let mut twin = DrogueEstimator::default();
    // The drogue off the tip on both axes, so that both enter the radial mean.
    let (x, y) = (0.06_f32, -0.04_f32);
    let mut depth = rc.station_depth_m;
    let mut previous = Mode::Standby;
    let (mut checked_far, mut checked_near) = (0, 0);
    let (mut contact, mut last) = (None, ControllerOutput::default());
    for k in 0..900 {
        // At the station, then closing at 0.5 m/s (long enough for the desired velocity to
        // reach the contact speed), and from outside the depth where the capture judges its
        // closing speed at 1.6 m/s (not 1: a horizon `to_go / closing` must not equal
        // `to_go * closing`).
        let closing = match previous {
            Mode::Approach | Mode::Terminal if depth > rc.late_gate_depth_m + 0.1 => 0.5,
            Mode::Approach | Mode::Terminal => 1.6,
            _ => 0.0,
        };
        depth -= closing * Controller::PERIOD_S;
        // The navigation bias the step will take out of the tip's velocity: the one learnt
        // up to the step before (`docs/conventions.md`, "Navigation bias").
        let bias = s.ctl.nav_bias_mps();
        let out = s.step([x, y, depth], closing);
        // The frame the controller saw, as its estimator takes it.
        let z = depth + s.tip[2];
        let image = [
            (x + s.tip[0]) / z + 1e-4 * (s.seq % 5) as f32,
            (y + s.tip[1]) / z,
        ];
        let frame = TipFrame {
            drogue_from_tip_m: geometry.drogue_from_tip(image, z, [0.0; 3], sight.image()),
            camera_depth_m: z,
        };
        let mut nav = NavSample::default();
        nav.lon.v_mps = closing;
        let reported = point_velocity_tanker_mps(&nav, &TRIM, cfg.probe_tip_body_m);
        let tip: [f32; 3] = core::array::from_fn(|i| reported[i] - bias[i]);
        if twin.started() {
            twin.predict(tip, &model);
            twin.correct(&frame, &cfg.estimator);
        }
        if matches!(previous, Mode::Approach | Mode::Terminal) {
            let e = twin.estimate();
            let closing_mps = e.closing_mps(tip[2]);
            let to_go = e.depth_m.max(0.0);
            // Not closing: the longest horizon.
            let h = if closing_mps > 0.0 {
                (to_go / closing_mps).min(rc.gate_max_horizon_s)
            } else {
                rc.gate_max_horizon_s
            };
            let [a, b] = twin.predict_offset(h, [tip[0], tip[1]], &model);
            let sigma = a.variance_m2.max(b.variance_m2).max(0.0).sqrt();
            let want = (a.mean_m * a.mean_m + b.mean_m * b.mean_m).sqrt() + rc.gate_sigmas * sigma;
            assert!(
                (out.predicted_miss_m - want).abs() <= 1e-5 * want,
                "step {k} ({previous:?}, {to_go} m to go, horizon {h} s): {} vs {want}",
                out.predicted_miss_m
            );
            if h < rc.gate_max_horizon_s {
                checked_near += 1;
            } else {
                checked_far += 1;
            }
        } else {
            assert_eq!(
                out.predicted_miss_m,
                f32::INFINITY,
                "step {k} in {previous:?}"
            );
        }
        if !twin.started() && out.mode == Mode::PreContact {
            twin.start(&frame, &cfg.estimator);
        }
        if previous == Mode::PreContact && out.mode == Mode::Approach {
            // The approach's closing speed, chosen from the air as it starts.
            contact = Some(procedure::contact_speed(twin.drogue_speed_rms_mps(), rc));
        }
        last = out;
        previous = out.mode;
        if depth < 0.1 {
            break;
        }
    }
    // Both horizons: the longest far out, the time to go in the capture's last half metre.
    assert!(
        checked_far > 50 && checked_near > 10,
        "{checked_far} far, {checked_near} near"
    );
    // The capture closes at that speed relative to the drogue to its end: the estimator
    // starts from the configured air's activity, rough enough at the approach's start here
    // for the rough-air speed.
    let contact = contact.expect("no approach flown");
    assert_eq!(contact, rc.rough_air_contact_speed_mps);
    assert_eq!(last.mode, Mode::Terminal);
    let want = contact + last.estimate.drogue_velocity_mps[2];
    assert!(
        (last.v_des.z_fwd_mps - want).abs() < 0.02,
        "{:?} vs {want}",
        last.v_des
    );
}

#[test]
fn the_paper_procedure_has_no_gate_figure() {
    let mut ctl = Controller::new(ControllerConfig::paper()).expect("valid configuration");
    for seq in 1..30 {
        let request = if seq == 1 {
            ModeRequest::Engage
        } else {
            ModeRequest::None
        };
        let out = ctl.step(&approach_input(seq, request, NavSample::default()));
        assert_eq!(out.mode, Mode::Approach);
        assert_eq!(out.predicted_miss_m, f32::INFINITY, "step {seq}");
    }
}

#[test]
fn back_in_standby_the_refuelling_estimate_is_the_frame_itself_again() {
    // Engaged and flown for a while, then reset: the drogue estimator stops, and standby
    // reports the frame's own offset and depth with no velocity ("before engage the
    // estimate is the frame itself"), not a filtered one.
    let mut s = Sortie::to_approach();
    for _ in 0..20 {
        s.step([0.05, 0.02, 2.8], 0.0);
    }
    s.seq += 1;
    let reset = s.ctl.step(&ControllerInput {
        request: ModeRequest::Reset,
        ..ControllerInput::default()
    });
    assert_eq!(reset.mode, Mode::Standby);
    // A frame far from what the filter believed: 0.3 m right, 0.2 m up, 4 m ahead.
    let out = s.step([0.3, -0.2, 4.0], 0.0);
    assert_eq!(out.mode, Mode::Standby);
    let e = out.estimate;
    assert_eq!(e.drogue_velocity_mps, [0.0; 3]);
    assert_eq!(e.offset_m, e.mean_offset_m);
    // Within the rig's tracker noise (at most 4e-4 of the image, 2.7 mm at 6.7 m).
    for (got, want) in [e.offset_m[0], e.offset_m[1], e.depth_m]
        .iter()
        .zip([0.3, -0.2, 4.0])
    {
        assert!((got - want).abs() < 3e-3, "{e:?}");
    }
}

#[test]
fn the_saturation_bits_name_exactly_the_channels_held_at_a_limit() {
    let trim = TRIM.command();
    // A small perturbation on both channels: every command moves off trim a little.
    let mut nav = NavSample::default();
    nav.lon.theta_rad = 0.01;
    nav.lon.v_mps = 0.5;
    nav.lat.phi_rad = 0.05;
    nav.lat.r_radps = -0.02;
    // Steps with one integrator frozen and not the other (the count is per step).
    let mut one_frozen = 0;
    for channel in 0..4 {
        // That channel limited to a hair around trim, the others wide open.
        let mut cfg = ControllerConfig::paper();
        cfg.measurement.frozen_frame_limit = u16::MAX;
        cfg.actuators.min[channel] = trim[channel] - 1e-6;
        cfg.actuators.max[channel] = trim[channel] + 1e-6;
        let mut ctl = Controller::new(cfg).expect("valid configuration");
        let mut frozen_steps = 0;
        let input = |seq, request| ControllerInput {
            measurement: frame(seq, 0.05, -0.02, 6.0),
            nav,
            probe_contact: false,
            autopilot_ready: true,
            request,
        };
        for seq in 1..40 {
            let request = if seq == 1 {
                ModeRequest::Engage
            } else {
                ModeRequest::None
            };
            let out = ctl.step(&input(seq, request));
            assert_eq!(out.mode, Mode::Approach);
            let command = out.command.as_array();
            let bits = [
                StatusFlags::SATURATED_ELEVATOR,
                StatusFlags::SATURATED_THROTTLE,
                StatusFlags::SATURATED_AILERON,
                StatusFlags::SATURATED_RUDDER,
            ];
            for (i, bit) in bits.into_iter().enumerate() {
                let at_limit =
                    command[i] == cfg.actuators.min[i] || command[i] == cfg.actuators.max[i];
                assert_eq!(
                    out.status.contains(bit),
                    at_limit,
                    "channel {channel} limited, step {seq}: channel {i} {command:?}, status {:#x}",
                    out.status.0
                );
            }
            let frozen = [
                StatusFlags::LON_INTEGRATOR_FROZEN,
                StatusFlags::LAT_INTEGRATOR_FROZEN,
            ]
            .map(|f| out.status.contains(f));
            frozen_steps += u32::from(frozen[0] || frozen[1]);
            one_frozen += u32::from(frozen[0] != frozen[1]);
            assert!(
                out.status.contains(bits[channel]),
                "step {seq}: {:#x}",
                out.status.0
            );
        }
        // Every one of those steps, the engage included, counted as saturated; the steps
        // with either integrator frozen counted as such, one count a step.
        assert_eq!(ctl.counters().saturated_steps, 39, "channel {channel}");
        assert_eq!(
            ctl.counters().integrator_frozen_steps,
            frozen_steps,
            "channel {channel}"
        );
    }
    assert!(one_frozen > 0, "never only one integrator frozen");
}

#[test]
fn an_open_loop_breakaway_held_at_a_throttle_stop_reports_both() {
    // The open-loop throttle cut (trim less `breakaway_throttle_cut`) below the throttle's
    // lower limit: the command sits at the stop, and the step says both that it flies open
    // loop and that the throttle saturated.
    let mut cfg = ControllerConfig::paper();
    cfg.actuators.min[1] = TRIM.throttle - 0.5 * cfg.modes.breakaway_throttle_cut;
    let mut ctl = Controller::new(cfg).expect("valid configuration");
    let trim_nav = NavSample::default();
    assert_eq!(
        ctl.step(&approach_input(1, ModeRequest::Engage, trim_nav))
            .mode,
        Mode::Approach
    );
    let mut bad_nav = trim_nav;
    bad_nav.lon.v_mps = f32::INFINITY;
    let out = ctl.step(&approach_input(2, ModeRequest::Abort, bad_nav));
    assert_eq!(out.mode, Mode::Breakaway);
    assert_eq!(out.command.throttle(), cfg.actuators.min[1]);
    assert!(
        out.status
            .contains(StatusFlags::OPEN_LOOP | StatusFlags::SATURATED_THROTTLE),
        "{:#x}",
        out.status.0
    );
}

#[test]
fn a_held_navigation_sample_with_a_surface_at_its_stop_reports_both() {
    // The elevator limited to a hair around trim: engaged on a pitched-up sample, it sits at
    // a stop; a bad sample next is held (integrators frozen by the hold, not by
    // anti-windup), and the step reports both the hold and the saturation.
    let trim = TRIM.command();
    let mut cfg = ControllerConfig::paper();
    cfg.actuators.min[0] = trim[0] - 1e-6;
    cfg.actuators.max[0] = trim[0] + 1e-6;
    let mut ctl = Controller::new(cfg).expect("valid configuration");
    let mut nav = NavSample::default();
    nav.lon.theta_rad = 0.01;
    assert_eq!(
        ctl.step(&approach_input(1, ModeRequest::Engage, nav)).mode,
        Mode::Approach
    );
    let mut bad = nav;
    bad.lat.p_radps = f32::NAN;
    let out = ctl.step(&approach_input(2, ModeRequest::None, bad));
    assert_eq!(out.mode, Mode::Approach);
    let both = StatusFlags::NAV_HELD | StatusFlags::SATURATED_ELEVATOR;
    assert!(out.status.contains(both), "{:#x}", out.status.0);
    let frozen = StatusFlags::LON_INTEGRATOR_FROZEN | StatusFlags::LAT_INTEGRATOR_FROZEN;
    assert_eq!(out.status.0 & frozen, 0, "{:#x}", out.status.0);
}

#[test]
fn a_step_holding_both_the_frame_and_the_navigation_reports_both() {
    let mut ctl = Controller::new(ControllerConfig::paper()).expect("valid configuration");
    let input = |seq, tracked, request, nav| ControllerInput {
        measurement: CameraMeasurement {
            tracked,
            ..frame(seq, 0.05, -0.02, 6.0)
        },
        nav,
        probe_contact: false,
        autopilot_ready: true,
        request,
    };
    let nav = NavSample::default();
    assert_eq!(
        ctl.step(&input(1, true, ModeRequest::Engage, nav)).mode,
        Mode::Approach
    );
    let mut bad = nav;
    bad.lon.q_radps = f32::NAN;
    let out = ctl.step(&input(2, false, ModeRequest::None, bad));
    assert_eq!(out.mode, Mode::Approach);
    assert_eq!(
        out.status.0,
        StatusFlags::MEASUREMENT_HELD | StatusFlags::NAV_HELD,
        "{:#x}",
        out.status.0
    );
}

#[test]
fn a_standby_trim_outside_a_limit_is_reported_saturated() {
    // Standby commands the trim of the design in use. The configuration must hold the
    // single-point design's trim, but a scheduled condition's may lie outside a limit: the
    // elevator then sits at that limit, and the step says so (with nothing else to flag:
    // no integrator runs in standby). A condition inside the design mass's docking
    // envelope (at 8,000 m it starts near 116 m/s).
    let condition = FlightCondition {
        true_airspeed_mps: 120.0,
        altitude_m: 8000.0,
    };
    let there = design_at(condition)
        .expect("inside the envelope")
        .trim
        .command();
    let here = TRIM.command();
    assert!((there[0] - here[0]).abs() > 1e-3);
    let mut cfg = ControllerConfig::paper();
    let middle = 0.5 * (here[0] + there[0]);
    if there[0] > here[0] {
        cfg.actuators.max[0] = middle;
    } else {
        cfg.actuators.min[0] = middle;
    }
    let mut ctl = Controller::new(cfg).expect("valid configuration");
    let input = |seq| ControllerInput {
        measurement: frame(seq, 0.05, -0.02, 6.0),
        nav: NavSample {
            condition,
            ..NavSample::default()
        },
        probe_contact: false,
        autopilot_ready: true,
        request: ModeRequest::None,
    };
    assert_eq!(ctl.step(&input(1)).status.0, 0);
    assert!(ctl.follow_schedule());
    let out = ctl.step(&input(2));
    assert_eq!(out.mode, Mode::Standby);
    assert_eq!(out.command.as_array()[0], middle);
    assert_eq!(
        out.status.0,
        StatusFlags::SATURATED_ELEVATOR,
        "{:#x}",
        out.status.0
    );
    assert_eq!(ctl.counters().saturated_steps, 1);
}

#[test]
fn the_refuelling_procedure_engages_bumplessly_and_the_papers_does_not() {
    // A receiver trimmed as the design's airframe is not (another mass or cg, or the
    // navigation's pitch error): 1 deg below the design's pitch and angle of attack, level.
    // Under the refuelling procedure the first engaged command is the Standby command, the
    // trim (the integrators take the offset up, `inner`); the paper's procedure, which starts
    // its integrators at zero, kicks the elevator by the law's `K_x x`.
    let mut nav = NavSample::default();
    nav.lon.theta_rad = -0.0175;
    nav.lon.alpha_rad = -0.0175;
    let mut first = Vec::new();
    for cfg in [ControllerConfig::default(), ControllerConfig::paper()] {
        let mut ctl = Controller::new(cfg).expect("valid configuration");
        let standby = ctl.step(&approach_input(1, ModeRequest::None, nav));
        assert_eq!(standby.mode, Mode::Standby);
        assert_eq!(standby.command.as_array(), TRIM.command());
        let engaged = ctl.step(&approach_input(2, ModeRequest::Engage, nav));
        assert_ne!(engaged.mode, Mode::Standby, "{:?}", cfg.procedure);
        first.push((engaged.command.as_array(), ctl.integrators_m()));
    }
    let trim = TRIM.command();
    let (refuel, q_refuel) = first[0];
    let (paper, q_paper) = first[1];
    // Elevator and throttle: two integrators for two inputs, exact to rounding.
    for i in 0..2 {
        assert!((refuel[i] - trim[i]).abs() < 1e-5, "{refuel:?} vs {trim:?}");
    }
    // Aileron and rudder: level, nothing lateral to take up.
    for i in 2..4 {
        assert!((refuel[i] - trim[i]).abs() < 1e-6, "{refuel:?} vs {trim:?}");
    }
    assert!(q_refuel[..2].iter().any(|q| q.abs() > 1e-3), "{q_refuel:?}");
    // The paper's kick, and its integrators at zero but for the step's own update.
    assert!((paper[0] - trim[0]).abs() > 0.05, "{paper:?} vs {trim:?}");
    assert!(q_paper.iter().all(|q| q.abs() < 1e-3), "{q_paper:?}");
}
