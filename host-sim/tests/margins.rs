//! Disk margins of the inner loops as flown (`host_sim::synthesis::margins`, docs/margins.md):
//! first that the loop analysed is the loop the core flies (the core's own controller
//! stepping the linearised plant, sample by sample against the analysed state-space loop),
//! then the margins over every schedule node, true cg 0.30..0.40 and true navigation latency
//! 0..2 periods, and the design loop's own for comparison; on light airframes, the light
//! design against the first.

use std::collections::VecDeque;

use host_sim::scenario::ScenarioFile;
use host_sim::synthesis::linalg::spectral_radius;
use host_sim::synthesis::margins::{
    ALPHA_45_DEG, FIGURES, FlownController, FlownLoop, LoopMatrices, TruePlant,
    design_loop_margins, flown_config, grid, grid_on, margins_of, node_design, node_worst,
};
use host_sim::synthesis::nominal_refuelling;
use ibvs_core::estimator::{TipGeometry, TipSight};
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
/// p, r]`, then the three surfaces at trim. Small: no command reaches a limit, and the
/// refuelling integrators' exact kinematics stay linear to within the agreement (their
/// third-order terms: 2.7e-4 of the peak command measured at this size, 6.7e-4 at three
/// times it; the second order cancels in `core_against_model`).
const X0: [f64; 13] = [
    1e-4, 5e-3, 1e-4, 2e-4, 0.0, 1e-4, 2e-4, 1e-4, 3e-4, -1e-4, 0.0, 0.0, 0.0,
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

/// The frame that puts the drogue exactly at the station (`station_depth_m` ahead of the
/// probe tip, on its axis) for the controller `cfg` at the trim pitch `theta_rad`: its image
/// point and camera depth, solved from the estimator's own geometry (affine in the image
/// point times the depth, and the depth).
fn station_frame(cfg: &ControllerConfig, theta_rad: f32) -> ([f32; 2], f32) {
    let g = TipGeometry::new(&cfg.camera, cfg.probe_tip_body_m, theta_rad);
    let tip_image = TipSight::new(&g).image();
    let f = |u: [f64; 3]| {
        let z = u[2] as f32;
        let r = g.drogue_from_tip([u[0] as f32 / z, u[1] as f32 / z], z, [0.0; 3], tip_image);
        nalgebra::Vector3::new(f64::from(r[0]), f64::from(r[1]), f64::from(r[2]))
    };
    let u0 = [0.0, 0.0, 6.0];
    let f0 = f(u0);
    let m = nalgebra::Matrix3::from_fn(|r, c| {
        let mut u = u0;
        u[c] += 1.0;
        f(u)[r] - f0[r]
    });
    let want = nalgebra::Vector3::new(0.0, 0.0, f64::from(cfg.refuelling.station_depth_m));
    let du = m.try_inverse().expect("the geometry is invertible") * (want - f0);
    let z = u0[2] + du[2];
    ([(du[0] / z) as f32, (du[1] / z) as f32], z as f32)
}

/// A healthy frame of the drogue at `at` (image point, camera depth), a little different
/// each step (the frozen-frame check refuses repeats) by a millionth of the image.
fn frame(seq: u32, at: ([f32; 2], f32)) -> CameraMeasurement {
    let t = seq as f32 * 0.05;
    CameraMeasurement {
        seq,
        tracked: true,
        image_x: at.0[0] + 1e-6 * t.sin(),
        image_y: at.0[1] + 1e-6 * t.cos(),
        depth_m: at.1,
        probe_tip: None,
    }
}

/// The core's controller (`cfg`) flying the discrete linear plant of `lp` from `sign X0`
/// with the loop's true latency, the drogue held at the station: per step, the commands
/// sent (perturbations from trim) and the desired velocity it reported `[down, fwd, right]`.
fn core_flight(lp: &FlownLoop<'_>, cfg: &ControllerConfig, sign: f64) -> Vec<([f64; 4], [f64; 3])> {
    let (speed, altitude) = (lp.plant.speed_mps, lp.plant.altitude_m);
    let condition = FlightCondition {
        true_airspeed_mps: speed as f32,
        altitude_m: altitude as f32,
    };
    let node = node_design(speed, altitude).expect("a schedule node");
    let trim = node.trim.command();
    // The navigation's perturbations are from the schedule's trim: the true airframe's own
    // (another cg) is a constant offset, which the core's exact kinematics see (the
    // analysed loop linearises them there) and which cancels in the flights' odd part. The
    // drogue is at the station as the aircraft at its own trim sees it.
    let mut offset = [0.0; 9];
    offset[0] = lp.plant.trim_theta_rad - f64::from(node.trim.theta_rad);
    offset[2] = lp.plant.trim_alpha_rad - f64::from(node.trim.alpha_rad);
    let with_offset = |m: &[f64; 9]| -> [f64; 9] { core::array::from_fn(|i| m[i] + offset[i]) };
    let at = station_frame(cfg, lp.plant.trim_theta_rad as f32);
    let mut ctl = Controller::new(*cfg).expect("a valid configuration");
    // Standby at the node: the flight loop loads the node's design after the step.
    let standby = ControllerInput {
        measurement: frame(1, at),
        nav: nav_sample(&offset, condition),
        probe_contact: false,
        autopilot_ready: true,
        request: ModeRequest::None,
    };
    ctl.step(&standby);
    ctl.follow_schedule();
    // Engaged at the trim: the refuelling procedure's bumpless engage then preloads nothing
    // (the preload answers the state at engage, which the analysed loop, started from `X0`
    // with its integrators at zero, does not have). What the engaged step adds (the desired
    // velocity's first slew, integrated) is the same in both flights and cancels in their
    // odd part.
    let engage = ControllerInput {
        measurement: frame(2, at),
        request: ModeRequest::Engage,
        ..standby
    };
    let out = ctl.step(&engage);
    ctl.follow_schedule();
    if offset == [0.0; 9] {
        // (At another cg the offset is a constant the engaged loop answers; it cancels.)
        assert_eq!(
            out.command.as_array(),
            trim,
            "engaged at the trim, the trim"
        );
    }

    let measured = |x: &DVector<f64>| -> [f64; 9] { core::array::from_fn(|k| x[MEASURED[k]]) };
    let mut x = DVector::from_column_slice(&X0) * sign;
    let mut line: VecDeque<[f64; 9]> = std::iter::repeat_n(measured(&x), lp.true_latency).collect();
    let mut flown = Vec::with_capacity(STEPS);
    for k in 0..STEPS {
        line.push_back(measured(&x));
        let late = line.pop_front().expect("the sample just pushed");
        let input = ControllerInput {
            measurement: frame(3 + k as u32, at),
            nav: nav_sample(&with_offset(&late), condition),
            probe_contact: false,
            autopilot_ready: true,
            request: ModeRequest::None,
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
        let v = out.v_des;
        let r = [v.y_down_mps, v.z_fwd_mps, v.x_right_mps].map(f64::from);
        flown.push((u, r));
        x = &lp.plant.pd * &x + &lp.plant.pb * DVector::from_column_slice(&u);
    }
    flown
}

/// The core's loop against the analysed loop `model` (its matrices driven by the desired
/// velocity the core reports). The refuelling procedure's integrators hold the tip's
/// velocity by exact kinematics, which the analysed loop has linearised
/// (`margins::tracked_output`): their products of states (the bank times the sideslip
/// velocity, and the like) are of the second order. The core therefore flies from `X0` and
/// from `-X0`, and half the difference of the two flights, in which every even order
/// cancels (the second order, and the rounding's common offset), is compared with the
/// analysed loop's response to `X0`. Returns, per input, the largest difference of the
/// commands over the largest command.
fn core_against_model(
    lp: &FlownLoop<'_>,
    model: &FlownLoop<'_>,
    cfg: &ControllerConfig,
) -> [f64; 4] {
    let m: LoopMatrices = model.matrices();
    let (plus, minus) = (core_flight(lp, cfg, 1.0), core_flight(lp, cfg, -1.0));
    let mut s = DVector::from_vec(model.initial_state(&X0));
    let (mut diff, mut peak) = ([0.0f64; 4], [0.0f64; 4]);
    for ((up, rp), (um, rm)) in plus.iter().zip(&minus) {
        let u_model = &m.c_u * &s;
        for i in 0..4 {
            let odd = 0.5 * (up[i] - um[i]);
            diff[i] = diff[i].max((odd - u_model[i]).abs());
            peak[i] = peak[i].max(odd.abs());
        }
        let r: [f64; 3] = core::array::from_fn(|i| 0.5 * (rp[i] - rm[i]));
        s = &m.a * &s + &m.b_r * DVector::from_column_slice(&r);
    }
    core::array::from_fn(|i| diff[i] / peak[i])
}

/// The relative difference accepted between the core's commands (`f32`, its navigation
/// sample rounded to `f32`; the odd part of the two flights, `core_against_model`) and the
/// analysed loop's (`f64`): about five times the largest measured over the points below
/// (2.5e-4, the refuelling procedure's: its exact kinematics' third-order terms and the
/// rounding; the paper's procedure, linear, 6.1e-5), and under a tenth of what a mis-wired
/// loop gives (checked below: 0.10 at the least).
const AGREEMENT: f64 = 1e-3;

#[test]
fn the_analysed_loop_is_the_flown_loop() {
    let refuel = ControllerConfig::default();
    let paper = ControllerConfig::paper();
    // Points inside the design mass's docking envelope (its slow edge keeps the core from
    // engaging at 100 m/s and 8,000 m).
    for (cfg, speed, altitude, xcg, latency) in [
        (&refuel, 145.0, 5500.0, 0.30, 2),
        (&refuel, 100.0, 5500.0, 0.40, 0),
        (&refuel, 170.0, 500.0, 0.35, 1),
        (&refuel, 120.0, 3000.0, 0.40, 2),
        (&paper, 145.0, 3000.0, 0.30, 1),
    ] {
        let plant = TruePlant::new(xcg, speed, altitude).unwrap();
        let controller = FlownController::new(&node_design(speed, altitude).unwrap(), cfg, &plant);
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
        // later than flown, is far outside the agreement (0.116 of the peak at the least).
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

/// Each schedule node's smallest disk margin `alpha` over true cg 0.30, 0.35, 0.40 and true
/// navigation latency 0, 1, 2 periods, per figure (`FIGURES`: elevator, throttle, aileron,
/// rudder loop at a time; the longitudinal and lateral channels' `mu`; the four inputs'
/// `sigma_max` bound), of the refuelling procedure's controller as the campaigns fly it
/// (`flown_config`: predictor for 2 periods): docs/margins.md's table, rounded down to 0.001. Nodes in the
/// schedule's order (`[altitude][speed]`, speed fastest). 45 deg needs 0.828.
const DOCUMENTED_WORST: [[f64; 7]; 16] = [
    // 100 m/s, 500 m
    [0.511, 0.635, 0.612, 1.316, 0.511, 0.599, 0.494],
    // 120 m/s, 500 m
    [0.479, 0.636, 0.627, 1.182, 0.479, 0.578, 0.462],
    // 145 m/s, 500 m
    [0.446, 0.637, 0.739, 1.060, 0.446, 0.597, 0.422],
    // 170 m/s, 500 m
    [0.421, 0.637, 0.812, 0.956, 0.421, 0.636, 0.384],
    // 100 m/s, 3000 m
    [0.523, 0.641, 0.625, 1.405, 0.522, 0.587, 0.419],
    // 120 m/s, 3000 m
    [0.497, 0.644, 0.589, 1.261, 0.497, 0.583, 0.467],
    // 145 m/s, 3000 m
    [0.462, 0.643, 0.620, 1.134, 0.462, 0.560, 0.436],
    // 170 m/s, 3000 m
    [0.435, 0.644, 0.728, 1.031, 0.435, 0.594, 0.405],
    // 100 m/s, 5500 m
    [0.492, 0.652, 0.618, 1.470, 0.492, 0.595, 0.479],
    // 120 m/s, 5500 m
    [0.509, 0.653, 0.594, 1.354, 0.508, 0.568, 0.464],
    // 145 m/s, 5500 m
    [0.484, 0.655, 0.571, 1.211, 0.484, 0.560, 0.438],
    // 170 m/s, 5500 m
    [0.452, 0.652, 0.603, 1.110, 0.452, 0.548, 0.412],
    // 100 m/s, 8000 m
    [0.528, 0.658, 0.537, 1.499, 0.527, 0.522, 0.498],
    // 120 m/s, 8000 m
    [0.478, 0.668, 0.597, 1.438, 0.477, 0.578, 0.460],
    // 145 m/s, 8000 m
    [0.497, 0.667, 0.568, 1.306, 0.496, 0.552, 0.432],
    // 170 m/s, 8000 m
    [0.477, 0.667, 0.554, 1.191, 0.477, 0.544, 0.410],
];

/// The 6 dB / 45 deg requirement where it holds, and a regression guard where it does not:
/// at every node, every figure's worst over the cg and latency grid is at least the
/// documented one (docs/margins.md), and where that is 0.828 or more, every point of the
/// node meets 6 dB and 45 deg. Most figures are short of the requirement (the refuelling
/// design's elevator loop above all: 0.313, 17.8 deg and 2.7 dB at 170 m/s, 500 m, cg 0.40,
/// two periods of latency); this test keeps them from getting worse unnoticed.
#[test]
fn disk_margins_over_the_schedule_cg_and_latency_grid() {
    let cfg = flown_config();
    // The figures are the campaigns': their predictor is the refuelling presets'.
    let preset = ScenarioFile::load("level2").unwrap().dispersed(0);
    assert_eq!(
        cfg.nav_latency_steps,
        preset.controller_config().nav_latency_steps,
        "the documented figures are for the refuelling presets' predictor"
    );
    let points = grid(&cfg).unwrap();
    assert_eq!(points.len(), 16 * 3 * 3);
    let nodes = node_worst(&points);
    assert_eq!(nodes.len(), DOCUMENTED_WORST.len());
    let mut short = Vec::new();
    for (n, documented) in nodes.iter().zip(DOCUMENTED_WORST) {
        for (k, ((m, xcg, d), doc)) in n.worst.iter().zip(documented).enumerate() {
            let at = format!(
                "{} m/s, {} m, {}: alpha {:.4} (cg {xcg}, latency {d})",
                n.speed_mps, n.altitude_m, FIGURES[k], m.alpha
            );
            if doc >= ALPHA_45_DEG {
                // The requirement: every point of the node meets 6 dB and 45 deg.
                assert!(m.meets_6db_45deg(), "requirement lost: {at}");
            } else {
                short.push(at.clone());
            }
            // The regression guard (and, above 0.828, the requirement's own figure).
            assert!(m.alpha >= doc, "worse than documented ({doc}): {at}");
        }
    }
    eprintln!("{} node figures short of 6 dB / 45 deg", short.len());
}

/// The disk margin's promise checked on the loop itself: each input's gain scaled to just
/// inside the disk's gain range, every other loop closed, the loop stays stable (a pure
/// gain is one of the perturbations the disk covers).
#[test]
fn the_loop_is_stable_across_each_inputs_disk_gain_range() {
    let cfg = flown_config();
    for (speed, altitude, xcg, latency) in [(170.0, 500.0, 0.40, 2), (120.0, 3000.0, 0.35, 1)] {
        let plant = TruePlant::new(xcg, speed, altitude).unwrap();
        let controller = FlownController::new(&node_design(speed, altitude).unwrap(), &cfg, &plant);
        let lp = FlownLoop {
            plant: &plant,
            controller: &controller,
            true_latency: latency,
        };
        let m = lp.matrices();
        let margins = margins_of(&m);
        for (i, dm) in margins.input.iter().enumerate() {
            let h = dm.alpha / 2.0;
            let (lo, hi) = (
                (1.0 - h) / (1.0 + h),
                if h < 1.0 { (1.0 + h) / (1.0 - h) } else { 1e3 },
            );
            for g in [lo * 1.001, hi * 0.999] {
                // The plant's input i receives g u_i: w_i = (g - 1) u_i.
                let a = &m.a + (g - 1.0) * m.b_w.column(i) * m.c_u.row(i);
                let r = spectral_radius(&a);
                assert!(
                    r < 1.0,
                    "{speed} m/s {altitude} m input {i}: gain {g:.3}, radius {r}"
                );
            }
        }
    }
}

/// docs/margins.md, "Why the margins are short": the refuelling design's own LQR loop (its
/// design model, true actuator deflections and engine power fed back, no latency) meets
/// 45 deg at all four inputs (elevator 0.847, throttle 0.978, aileron 1.018, rudder 1.691);
/// flown, the elevator's and the throttle's fall short (the deflections and the engine power
/// fed back are the controller's open-loop models of its own commands): the throttle's to
/// about 0.70, the elevator's at this node and cg 0.40 below 0.828 even without latency.
#[test]
fn the_design_loop_meets_45_deg_and_the_flown_loop_does_not() {
    let s = nominal_refuelling().unwrap();
    let lon = design_loop_margins(&s.lon);
    let lat = design_loop_margins(&s.lat);
    let measured = [lon.input[0], lon.input[1], lat.input[0], lat.input[1]].map(|m| m.alpha);
    for (got, documented) in measured.iter().zip([0.847, 0.978, 1.018, 1.691]) {
        assert!((got - documented).abs() < 5e-4, "{measured:?}");
    }
    for input in lon.input.iter().chain(lat.input.iter()) {
        assert!(input.meets_6db_45deg(), "{measured:?}");
    }
    let plant = TruePlant::new(0.40, 120.0, 3000.0).unwrap();
    let flown = FlownLoop {
        plant: &plant,
        controller: &FlownController::new(
            &node_design(120.0, 3000.0).unwrap(),
            &ControllerConfig::default(),
            &plant,
        ),
        true_latency: 0,
    }
    .margins();
    assert!(
        flown.input[1].alpha < 0.75,
        "flown throttle {}",
        flown.input[1].alpha
    );
    assert!(
        !flown.input[0].meets_6db_45deg(),
        "flown elevator {}",
        flown.input[0].alpha
    );
}

/// On the light airframes the refuelling procedure flies its light design because, in the
/// linear loop as flown, the first design is not stable there everywhere and the light one
/// is. Measured over the grid (16 nodes, cg 0.30..0.40, latency 0..2; points with a spectral
/// radius of at least 1, the largest radius): mass 0.85, first design 21 points and 1.0121
/// (at the slow, high nodes, cg 0.40: an oscillation near 1.8 rad/s), light design none
/// (0.9960; worst elevator disk margin 0.364, lateral channel 0.268); mass 0.90, first 3
/// points and 1.0048, light none (0.9950). On the design's own mass the first design has
/// none (0.9951).
#[test]
fn on_light_airframes_the_light_design_is_stable_at_every_point_and_the_first_is_not() {
    let stats = |airframe: f64, configured: f32| {
        let mut cfg = flown_config();
        cfg.mass_factor = configured;
        let points = grid_on(&cfg, airframe).unwrap();
        let radii: Vec<f64> = points.iter().map(|p| p.margins.spectral_radius).collect();
        (
            radii.iter().filter(|r| **r >= 1.0).count(),
            radii.iter().copied().fold(0.0, f64::max),
        )
    };
    for airframe in [0.85, 0.9] {
        let (first, light) = (stats(airframe, 1.0), stats(airframe, airframe as f32));
        eprintln!("mass {airframe}: first design {first:?}, light design {light:?}");
        assert_eq!(light.0, 0, "mass {airframe}: light design {light:?}");
        assert!(first.0 > 0, "mass {airframe}: first design {first:?}");
    }
    let (unstable, largest) = stats(1.0, 1.0);
    assert_eq!(
        unstable, 0,
        "the design's own mass: largest radius {largest}"
    );
}

/// The loops as flown on the airframes a campaign disperses (aerodynamics, mass, inertia,
/// each surface actuator's bandwidth, cg), each at its run's flight condition and true
/// navigation latency (`margins::run_margins`, `examples/dispersed_stability.rs`):
/// `mil-level2`'s first 200 runs (the refuelling presets' airframe dispersions at the
/// design's condition) are every one stable. Measured over its runs 0..1,999: none unstable,
/// the elevator's disk margin 0.186 at worst (median 0.613), all four inputs' 0.041 (median
/// 0.457). Not asserted, and why: over `envelope` runs 0..1,999, 5 loops are unstable
/// (spectral radius 1.0001..1.0021, a divergence over 10 s and more, all on light airframes
/// flying the light design between the schedule's nodes), none of them upset in the campaign;
/// and the linear verdict does not predict the campaigns' upsets (`docs/margins.md`, "On the
/// campaigns' dispersed airframes").
#[test]
fn the_loops_are_stable_on_every_dispersed_airframe_of_the_strong_air_campaigns_first_runs() {
    use host_sim::synthesis::margins::run_margins;
    use rayon::prelude::*;
    let f = ScenarioFile::load("mil-level2").unwrap();
    let radii: Vec<(u64, f64, f64)> = (0..200u64)
        .into_par_iter()
        .map(|i| {
            let m = run_margins(&f.dispersed(i)).unwrap();
            (i, m.spectral_radius, m.all.alpha)
        })
        .collect();
    let unstable: Vec<&(u64, f64, f64)> = radii.iter().filter(|(_, r, _)| *r >= 1.0).collect();
    let worst = radii.iter().copied().fold(
        (0, 0.0, f64::INFINITY),
        |w, p| if p.2 < w.2 { p } else { w },
    );
    eprintln!(
        "worst all-four disk margin {:.3} (run {}, radius {:.5})",
        worst.2, worst.0, worst.1
    );
    assert!(
        unstable.is_empty(),
        "unstable loops (run, radius, margin): {unstable:?}"
    );
}
