//! Renders a [`Synthesis`] and the gain [`Schedule`] as the core's generated gains module
//! (`core/src/gains.rs`).
//!
//! Invariant: the output is a pure function of the synthesis (no time stamps, no paths), so
//! a fresh synthesis reproduces the checked-in file byte for byte; the test
//! `gains_file_is_fresh` relies on that.

use std::fmt::Write as _;

use nalgebra::DMatrix;

use super::schedule::{SCHEDULE_ALTITUDES_M, SCHEDULE_SPEEDS_MPS, Schedule};
use super::{ChannelDesign, PredictorModel, Synthesis};
use crate::receiver::Trim;

/// Path of the generated module, relative to the workspace root.
pub const CORE_GAINS_PATH: &str = "core/src/gains.rs";

/// The command that regenerates the module.
pub const REGENERATE: &str =
    "cargo run --release -p host-sim -- gains --write-core core/src/gains.rs";

/// An `f32` literal: shortest representation that round-trips.
fn lit(v: f64) -> String {
    format!("{:?}", v as f32)
}

fn matrix(m: &DMatrix<f64>, cols: std::ops::Range<usize>) -> String {
    block(m, 0..m.nrows(), cols)
}

fn block(m: &DMatrix<f64>, rows: std::ops::Range<usize>, cols: std::ops::Range<usize>) -> String {
    let rows: Vec<String> = rows
        .map(|i| m.row(i))
        .map(|r| {
            let v: Vec<String> = cols.clone().map(|c| lit(r[c])).collect();
            format!("[{}]", v.join(", "))
        })
        .collect();
    format!("[{}]", rows.join(", "))
}

/// A channel's gains as a `ChannelGains` expression.
fn channel_expr(d: &ChannelDesign, indent: &str) -> String {
    let nx = d.c_cg.ncols();
    let ny = d.c_cg.nrows();
    let na = d.actuated.iter().filter(|&&a| a).count();
    // Column `j` of `k_actuator` is input j's actuator, zero for an input the design does
    // not carry one for.
    let mut k_act = nalgebra::DMatrix::zeros(d.k.nrows(), d.actuated.len());
    let carried = (0..d.actuated.len()).filter(|&j| d.actuated[j]);
    for (slot, j) in (nx..).zip(carried) {
        k_act.set_column(j, &d.k.column(slot));
    }
    format!(
        "ChannelGains {{\n{indent}    k_state: {kx},\n{indent}    k_actuator: {ka},\n{indent}    k_integral: {kq},\n{indent}    c_cg: {c},\n{indent}}}",
        kx = matrix(&d.k, 0..nx),
        ka = matrix(&k_act, 0..d.actuated.len()),
        kq = matrix(&d.k, nx + na..nx + na + ny),
        c = matrix(&d.c_cg, 0..nx),
    )
}

fn channel(name: &str, doc: &str, d: &ChannelDesign) -> String {
    let (nx, ny, nu) = (d.c_cg.ncols(), d.c_cg.nrows(), d.k.nrows());
    format!(
        "/// {doc}\n///\n/// States {states:?}; inputs {inputs:?}; outputs {outputs:?}.\n\
         /// Closed-loop spectral radius {radius:.6}, Riccati residual {res:.1e}.\n\
         pub const {name}: ChannelGains<{nx}, {ny}, {nu}> = {expr};\n",
        states = d.states,
        inputs = d.inputs,
        outputs = d.outputs,
        radius = d.closed_loop_spectral_radius,
        res = d.riccati_residual,
        expr = channel_expr(d, ""),
    )
}

/// A predictor model as a `PlantModel` expression.
fn predictor_expr(p: &PredictorModel, indent: &str) -> String {
    let (nm, n, nu) = (p.measured, p.phi.nrows(), p.gamma.ncols());
    format!(
        "PlantModel {{\n{indent}    delta_mm: {mm},\n{indent}    phi_me: {me},\n{indent}    phi_ee: {ee},\n\
         {indent}    gamma_m: {gm},\n{indent}    gamma_e: {ge},\n{indent}}}",
        mm = block(
            &(p.phi.view((0, 0), (nm, nm)) - DMatrix::<f64>::identity(nm, nm)),
            0..nm,
            0..nm
        ),
        me = block(&p.phi, 0..nm, nm..n),
        ee = block(&p.phi, nm..n, nm..n),
        gm = block(&p.gamma, 0..nm, 0..nu),
        ge = block(&p.gamma, nm..n, 0..nu),
    )
}

fn predictor(name: &str, doc: &str, p: &PredictorModel) -> String {
    let (nm, n, nu) = (p.measured, p.phi.nrows(), p.gamma.ncols());
    format!(
        "/// {doc}\n///\n/// Measured states first ({nm}), then the unmeasured ones ({ne}).\n\
         pub const {name}: PlantModel<{nm}, {ne}, {nu}> = {expr};\n",
        ne = n - nm,
        expr = predictor_expr(p, ""),
    )
}

/// A trim point as a `TrimPoint` expression.
fn trim_expr(t: &Trim, indent: &str) -> String {
    format!(
        "TrimPoint {{\n{indent}    speed_mps: {v},\n{indent}    altitude_m: {h},\n{indent}    \
         alpha_rad: {alpha},\n{indent}    theta_rad: {theta},\n{indent}    throttle: {thr},\n{indent}    \
         elevator_rad: {el},\n{indent}    aileron_rad: {ail},\n{indent}    rudder_rad: {rud},\n{indent}}}",
        v = lit(t.speed_mps),
        h = lit(t.altitude_m),
        alpha = lit(t.alpha_rad),
        theta = lit(t.theta_rad),
        thr = lit(t.throttle),
        el = lit(t.elevator_rad),
        ail = lit(t.aileron_rad),
        rud = lit(t.rudder_rad),
    )
}

/// An engine model as an `EngineModel` expression.
fn engine_expr(s: &Synthesis) -> String {
    let (pole, gain) = s.engine_model;
    format!(
        "EngineModel {{ pole: {}, gain_pct: {} }}",
        lit(pole),
        lit(gain)
    )
}

/// The schedule: its axes and every node's design.
fn schedule_text(schedule: &Schedule) -> String {
    let axis = |a: &[f64]| a.iter().map(|&v| lit(v)).collect::<Vec<_>>().join(", ");
    let (nv, nh) = (SCHEDULE_SPEEDS_MPS.len(), SCHEDULE_ALTITUDES_M.len());
    let mut out = format!(
        "\n/// The gain schedule's true airspeeds, m/s (`crate::schedule`).\n\
         pub const SCHEDULE_SPEEDS_MPS: [f32; {nv}] = [{}];\n\n\
         /// The gain schedule's altitudes, m.\n\
         pub const SCHEDULE_ALTITUDES_M: [f32; {nh}] = [{}];\n\n\
         /// The whole design at every node of the grid, `[altitude][speed]`: the same synthesis\n\
         /// as above, at each node's condition.\n\
         pub static SCHEDULE: [[DesignPoint; {nv}]; {nh}] = [\n",
        axis(&SCHEDULE_SPEEDS_MPS),
        axis(&SCHEDULE_ALTITUDES_M),
    );
    let i = "        ";
    for row in &schedule.nodes {
        out.push_str("    [\n");
        for n in row {
            let (p, r, l) = (&n.paper, &n.refuel, &n.refuel_light);
            let _ = write!(
                out,
                "        // {v} m/s, {h} m: trim residual {res:.1e}; closed-loop spectral radii lon {pl:.6}, \
                 lat {pa:.6}, refuelling lon {rl:.6}, lat {ra:.6}, light lon {ll:.6}, lat {la:.6}.\n        \
                 DesignPoint {{\n{i}    trim: {trim},\n\
                 {i}    engine: {engine},\n{i}    lon: {lon},\n{i}    lat: {lat},\n{i}    refuel_lon: {rlon},\n\
                 {i}    refuel_lat: {rlat},\n{i}    refuel_light_lon: {llon},\n{i}    refuel_light_lat: {llat},\n\
                 {i}    predict_lon: {plon},\n{i}    predict_lat: {plat},\n{i}}},\n",
                v = p.trim.speed_mps,
                h = p.trim.altitude_m,
                res = p.trim.residual,
                pl = p.lon.closed_loop_spectral_radius,
                pa = p.lat.closed_loop_spectral_radius,
                rl = r.lon.closed_loop_spectral_radius,
                ra = r.lat.closed_loop_spectral_radius,
                ll = l.lon.closed_loop_spectral_radius,
                la = l.lat.closed_loop_spectral_radius,
                trim = trim_expr(&p.trim, "            "),
                engine = engine_expr(p),
                lon = channel_expr(&p.lon, "            "),
                lat = channel_expr(&p.lat, "            "),
                rlon = channel_expr(&r.lon, "            "),
                rlat = channel_expr(&r.lat, "            "),
                llon = channel_expr(&l.lon, "            "),
                llat = channel_expr(&l.lat, "            "),
                plon = predictor_expr(&p.predictor_lon, "            "),
                plat = predictor_expr(&p.predictor_lat, "            "),
            );
        }
        out.push_str("    ],\n");
    }
    out.push_str("];\n");
    out
}

/// The module's full text: the paper's procedure's design `s`, the refuelling procedure's
/// `refuel` (other weights, on the airframe at its design cg; the tables keep `s`'s trim,
/// engine and predictor models) and `light` (the same on the light airframe,
/// [`super::LIGHT_REFUELLING_MASS_FACTOR`]), and the gain schedule over the docking envelope.
pub fn render(s: &Synthesis, refuel: &Synthesis, light: &Synthesis, schedule: &Schedule) -> String {
    let t = &s.trim;
    let w = &s.weights;
    let mut out = String::new();
    let _ = write!(
        out,
        "//! Inner-loop gains and design data at the refuelling trim, and the same design at every\n\
         //! node of the gain schedule over the docking envelope (`crate::schedule`).\n//!\n\
         //! GENERATED by\n//! `{REGENERATE}`.\n\
         //! Do not edit: change the design in `host-sim/src/synthesis/` and regenerate. The test\n\
         //! `gains_file_is_fresh` fails when this file differs from a fresh synthesis.\n//!\n\
         //! Design: nonlinear F-16 (low-fidelity data) trimmed at {v} m/s, {h} m, linearised,\n\
         //! discretised by zero-order hold at Ts = {ts} s, integrators as forward sums, discrete LQR.\n\
         //! Weights (diagonal): lon Q {lq:?}, R {lr:?}; lat Q {aq:?}, R {ar:?}.\n\n\
         use crate::inner::{{ChannelGains, EngineModel, TrimPoint}};\nuse crate::predictor::PlantModel;\nuse crate::design::DesignPoint;\n\n\
         /// Control period the gains were synthesised for, s.\n\
         pub const CONTROL_PERIOD_S: f32 = {ts_lit};\n\n\
         /// Trim point of the design (residual {res:.1e}).\n\
         pub const TRIM: TrimPoint = {trim};\n\n\
         /// Camera (probe tip) position the design's lever-arm terms assumed, body axes, m.\n\
         pub const DESIGN_CAMERA_BODY_M: [f32; 3] = [{cx}, {cy}, {cz}];\n\n",
        v = t.speed_mps,
        h = t.altitude_m,
        ts = s.lon.ts,
        lq = w.lon_q,
        lr = w.lon_r,
        aq = w.lat_q,
        ar = w.lat_r,
        ts_lit = lit(s.lon.ts),
        res = t.residual,
        trim = trim_expr(t, ""),
        cx = lit(s.camera_body_m[0]),
        cy = lit(s.camera_body_m[1]),
        cz = lit(s.camera_body_m[2]),
    );
    let _ = write!(
        out,
        "/// Engine model of the design (power perturbation in percent per step, from the throttle).\n\
         pub const ENGINE_MODEL: EngineModel = {};\n\n",
        engine_expr(s)
    );
    out.push_str(&channel(
        "LON",
        "Longitudinal channel: elevator and throttle.",
        &s.lon,
    ));
    out.push('\n');
    out.push_str(&channel(
        "LAT",
        "Lateral channel: aileron and rudder.",
        &s.lat,
    ));
    out.push('\n');
    out.push_str(&predictor(
        "PREDICT_LON",
        "Latency predictor's longitudinal model: states theta, V, alpha, q; engine power, \
         elevator actuator (first-order lag); inputs elevator, throttle (perturbations).",
        &s.predictor_lon,
    ));
    out.push('\n');
    out.push_str(&predictor(
        "PREDICT_LAT",
        "Latency predictor's lateral model: states psi, phi, beta, p, r; aileron and rudder \
         actuators (first-order lags); inputs aileron, rudder (perturbations).",
        &s.predictor_lat,
    ));
    let (rw, _) = (&refuel.weights, ());
    let _ = write!(
        out,
        "\n/// The refuelling procedure's design, on the airframe at cg {} (the paper's design: {}), \
         weights (diagonal): lon Q {:?}, R {:?}; lat Q {:?}, R {:?}{}.\n",
        refuel.xcg,
        s.xcg,
        rw.lon_q,
        rw.lon_r,
        rw.lat_q,
        rw.lat_r,
        if rw.actuator_states {
            "; the surface actuators carried as states (unweighted)"
        } else {
            ""
        }
    );
    out.push_str(&channel(
        "REFUEL_LON",
        "Longitudinal channel of the refuelling procedure: elevator and throttle.",
        &refuel.lon,
    ));
    out.push('\n');
    out.push_str(&channel(
        "REFUEL_LAT",
        "Lateral channel of the refuelling procedure: aileron and rudder.",
        &refuel.lat,
    ));
    let _ = write!(
        out,
        "\n/// The gross mass of the refuelling procedure's light design, a factor of the model \
         data's (the design above: 1).\n\
         pub const REFUEL_LIGHT_MASS_FACTOR: f32 = {};\n\n\
         /// The refuelling procedure's light design: the same weights and cg on the airframe at \
         `REFUEL_LIGHT_MASS_FACTOR` of the mass.\n",
        lit(super::LIGHT_REFUELLING_MASS_FACTOR)
    );
    out.push_str(&channel(
        "REFUEL_LIGHT_LON",
        "Longitudinal channel of the refuelling procedure's light design.",
        &light.lon,
    ));
    out.push('\n');
    out.push_str(&channel(
        "REFUEL_LIGHT_LAT",
        "Lateral channel of the refuelling procedure's light design.",
        &light.lat,
    ));
    // The lift's zero angle: the 1 g trim angle's line through the two designs' masses,
    // extended to zero mass (the lift, and so the angle from the zero-lift angle, grows with
    // the weight it carries).
    let (a1, al) = (refuel.trim.alpha_rad, light.trim.alpha_rad);
    let zero_lift = a1 - (a1 - al) / (1.0 - super::LIGHT_REFUELLING_MASS_FACTOR);
    let _ = write!(
        out,
        "\n/// The lift's zero angle of attack on the refuelling design's airframe at its \
         condition, rad: the 1 g trim angle's line through the two designs' masses (1 and \
         `REFUEL_LIGHT_MASS_FACTOR`), extended to zero mass. The docking envelope's \
         angle-of-attack rule scales the trim's angle from it by the mass \
         (`crate::schedule::MassEnvelope`).\n\
         pub const ZERO_LIFT_ALPHA_RAD: f32 = {};\n",
        lit(zero_lift)
    );
    out.push_str(&schedule_text(schedule));
    out
}
