//! Disk margins of the inner loops as flown (`host_sim::synthesis::margins`, docs/margins.md):
//! first that the loop analysed is the loop the core flies (the core's own controller
//! stepping the linearised plant, sample by sample against the analysed state-space loop),
//! then the margins over every schedule node, true cg 0.30..0.40 and true navigation latency
//! 0..2 periods.

use std::collections::VecDeque;

use host_sim::synthesis::margins::{
    FlownController, FlownLoop, LoopMatrices, TruePlant, node_design,
};
use ibvs_core::measurement::CameraMeasurement;
use ibvs_core::nav::{FlightCondition, LatNav, LonNav, NavSample};
use ibvs_core::{Controller, ControllerConfig, ControllerInput, Mode, ModeRequest};
use nalgebra::DVector;

/// Steps compared (1.6 s: the short-period and lateral modes' transients, the integrators
/// and the predictor's record well under way).
const STEPS: usize = 80;

/// The measured design coordinates, in the navigation sample's order.
const MEASURED: [usize; 9] = [0, 1, 2, 3, 5, 6, 7, 8, 9];

/// The initial perturbation: 10 design coordinates `[theta, V, alpha, q, P, psi, phi, beta,
/// p, r]`, then the three surfaces at trim. Small: no command reaches a limit.
const X0: [f64; 13] = [
    0.001, 0.05, 0.001, 0.002, 0.0, 0.001, 0.002, 0.001, 0.003, -0.001, 0.0, 0.0, 0.0,
];

fn nav_sample(m: &[f64; 9], condition: FlightCondition) -> NavSample {
    let f = |i: usize| m[i] as f32;
    NavSample {
        lon: LonNav {
            x_fwd_m: 0.0,
            h_up_m: 0.0,
            theta_rad: f(0),
            v_mps: f(1),
            alpha_rad: f(2),
            q_radps: f(3),
        },
        lat: LatNav {
            y_right_m: 0.0,
            psi_rad: f(4),
            phi_rad: f(5),
            beta_rad: f(6),
            p_radps: f(7),
            r_radps: f(8),
        },
        condition,
    }
}

/// A healthy frame of the drogue near the station, a little different each step (the
/// frozen-frame check refuses repeats).
fn frame(seq: u32) -> CameraMeasurement {
    let t = seq as f32 * 0.05;
    CameraMeasurement {
        seq,
        tracked: true,
        image_x: 0.01 * t.sin(),
        image_y: 0.01 * t.cos(),
        depth_m: 8.0,
        probe_tip: None,
    }
}

/// The core's controller (`cfg`) flying the discrete linear plant of `lp` from `X0` with the
/// loop's true latency, against the analysed loop `model` (its matrices driven by the desired
/// velocity the core reports). Returns, per input, the largest difference of the commands
/// over the largest command.
fn core_against_model(
    lp: &FlownLoop<'_>,
    model: &FlownLoop<'_>,
    cfg: &ControllerConfig,
) -> [f64; 4] {
    let m: LoopMatrices = model.matrices();
    let (speed, altitude) = (lp.plant.speed_mps, lp.plant.altitude_m);
    let condition = FlightCondition {
        true_airspeed_mps: speed as f32,
        altitude_m: altitude as f32,
    };
    let trim = node_design(speed, altitude).unwrap().trim.command();
    let mut ctl = Controller::new(*cfg).unwrap();
    // Standby at the node: the flight loop loads the node's design after the step.
    let standby = ControllerInput {
        measurement: frame(1),
        nav: nav_sample(&[0.0; 9], condition),
        probe_contact: false,
        request: ModeRequest::None,
    };
    ctl.step(&standby);
    ctl.follow_schedule();

    let measured = |x: &DVector<f64>| -> [f64; 9] { core::array::from_fn(|k| x[MEASURED[k]]) };
    let mut x = DVector::from_column_slice(&X0);
    let mut line: VecDeque<[f64; 9]> = std::iter::repeat_n(measured(&x), lp.true_latency).collect();
    let mut s = DVector::from_vec(model.initial_state(&X0));
    let (mut diff, mut peak) = ([0.0f64; 4], [0.0f64; 4]);
    for k in 0..STEPS {
        line.push_back(measured(&x));
        let late = line.pop_front().unwrap();
        let input = ControllerInput {
            measurement: frame(2 + k as u32),
            nav: nav_sample(&late, condition),
            probe_contact: false,
            request: if k == 0 {
                ModeRequest::Engage
            } else {
                ModeRequest::None
            },
        };
        let out = ctl.step(&input);
        ctl.follow_schedule();
        assert!(
            !matches!(out.mode, Mode::Standby | Mode::Breakaway),
            "step {k}: {:?}",
            out.mode
        );
        assert_eq!(out.status.0, 0, "step {k}: status {:#x}", out.status.0);
        let sent = out.command.as_array();
        let u: [f64; 4] = core::array::from_fn(|i| f64::from(sent[i]) - f64::from(trim[i]));
        let u_model = &m.c_u * &s;
        for i in 0..4 {
            diff[i] = diff[i].max((u[i] - u_model[i]).abs());
            peak[i] = peak[i].max(u[i].abs());
        }
        let v = out.v_des;
        let r = DVector::from_column_slice(&[
            f64::from(v.y_down_mps),
            f64::from(v.z_fwd_mps),
            f64::from(v.x_right_mps),
        ]);
        s = &m.a * &s + &m.b_r * r;
        x = &lp.plant.pd * &x + &lp.plant.pb * DVector::from_column_slice(&u);
    }
    core::array::from_fn(|i| diff[i] / peak[i])
}

/// The relative difference accepted between the core's commands (`f32`, its navigation
/// sample rounded to `f32`) and the analysed loop's (`f64`): about 250 times the largest
/// measured over the points below (3.8e-6), and under a tenth of what a mis-wired loop
/// gives (checked below).
const AGREEMENT: f64 = 1e-3;

#[test]
fn the_analysed_loop_is_the_flown_loop() {
    let refuel = ControllerConfig::default();
    let paper = ControllerConfig::paper();
    for (cfg, speed, altitude, xcg, latency) in [
        (&refuel, 145.0, 5500.0, 0.30, 2),
        (&refuel, 100.0, 8000.0, 0.40, 0),
        (&refuel, 170.0, 500.0, 0.35, 1),
        (&refuel, 120.0, 3000.0, 0.40, 2),
        (&paper, 145.0, 3000.0, 0.30, 1),
    ] {
        let plant = TruePlant::new(xcg, speed, altitude).unwrap();
        let controller = FlownController::new(&node_design(speed, altitude).unwrap(), cfg);
        let lp = FlownLoop {
            plant: &plant,
            controller: &controller,
            true_latency: latency,
        };
        let rel = core_against_model(&lp, &lp, cfg);
        eprintln!(
            "{:?} {speed} {altitude} {xcg} {latency}: {rel:?}",
            cfg.procedure
        );
        for (i, r) in rel.iter().enumerate() {
            assert!(
                *r < AGREEMENT,
                "{:?} {speed} m/s {altitude} m cg {xcg} latency {latency}: input {i} differs by {r:.2e} of its peak",
                cfg.procedure
            );
        }
        // The comparison can fail: the same loop with the predictor set one period off (short,
        // or long when the configuration compensates none), or the navigation one period
        // later than flown, is far outside the agreement (0.099 of the peak at the least).
        let mut off = controller.clone();
        off.design_latency = match controller.design_latency {
            0 => 1,
            d => d - 1,
        };
        let wrong = [
            FlownLoop {
                controller: &off,
                ..lp.clone()
            },
            FlownLoop {
                true_latency: latency + 1,
                ..lp.clone()
            },
        ];
        for w in &wrong {
            let worst = core_against_model(&lp, w, cfg)
                .into_iter()
                .fold(0.0, f64::max);
            eprintln!("  mis-wired: {worst:.3e}");
            assert!(
                worst > 10.0 * AGREEMENT,
                "a mis-wired loop agrees: {worst:.2e}"
            );
        }
    }
}
