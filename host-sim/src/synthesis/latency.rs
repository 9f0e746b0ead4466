//! The inner loops' linear closed loop with navigation latency, as the core runs it: the
//! analysis behind the core's latency predictor (`ibvs_core::predictor`), printed by
//! `examples/delay_margin.rs` and checked by this module's tests.
//!
//! One channel: the true plant (any cg) with first-order actuators, discretised; its
//! measured states reach the controller `d` control periods late; the engine power is the
//! controller's own estimate, never late; the integrators integrate the late output; the
//! state feedback acts on the late sample or on its prediction by the generated model.
//! Invariant: [`LatencyLoop::matrix`] is the exact one-step transition of that linear loop
//! (built column by column from [`LatencyLoop::step`] on unit vectors).

use std::f64::consts::TAU;

use nalgebra::{DMatrix, DVector};

use super::{CONTROL_PERIOD_S, PredictorModel};

const TS_S: f64 = CONTROL_PERIOD_S;

/// One channel's closed loop with `d` periods of navigation latency.
pub struct LatencyLoop<'a> {
    /// True plant, discrete, with actuators: state matrix.
    pub pd: DMatrix<f64>,
    /// True plant: input matrix.
    pub pb: DMatrix<f64>,
    /// The controller's model (the core's generated one).
    pub model: &'a PredictorModel,
    /// The true tracked outputs on the design states.
    pub c: &'a DMatrix<f64>,
    /// The design's gain on `[x; actuators it carries; integrators]`.
    pub k: &'a DMatrix<f64>,
    /// Design states (`model.measured` of them measured, the rest the model's).
    pub n: usize,
    /// Navigation latency, control periods.
    pub d: usize,
    /// Whether the state feedback acts on the prediction (else on the late sample).
    pub predict: bool,
}

impl LatencyLoop<'_> {
    /// `(plant, measured, model-only, inputs, outputs)` sizes.
    fn sizes(&self) -> (usize, usize, usize, usize, usize) {
        let nm = self.model.measured;
        let ne = self.model.phi.nrows() - nm;
        (self.pd.nrows(), nm, ne, self.pb.ncols(), self.c.nrows())
    }

    /// Layout: plant | late measured states d * nm | model's e[k] | (e, u) of the last d
    /// steps | integrators.
    fn len(&self) -> usize {
        let (np, nm, ne, nu, ny) = self.sizes();
        np + self.d * nm + ne + self.d * (ne + nu) + ny
    }

    /// One control period of the loop from state `s`.
    pub fn step(&self, s: &DVector<f64>) -> DVector<f64> {
        let (np, nm, ne, nu, ny) = self.sizes();
        let (n, d) = (self.n, self.d);
        let (ox, oe) = (np, np + d * nm);
        let (or, oq) = (oe + ne, oe + ne + d * (ne + nu));
        let hist_e = |j: usize| s.rows(or + j * (ne + nu), ne).into_owned();
        let hist_u = |j: usize| s.rows(or + j * (ne + nu) + ne, nu).into_owned();
        let p = s.rows(0, np).into_owned();
        let e_now = s.rows(oe, ne).into_owned();
        let m_late = if d == 0 {
            p.rows(0, nm).into_owned()
        } else {
            s.rows(ox + (d - 1) * nm, nm).into_owned()
        };
        let mut m_now = m_late.clone();
        if self.predict && d > 0 {
            let mut z = DVector::zeros(nm + ne);
            z.rows_mut(0, nm).copy_from(&m_late);
            z.rows_mut(nm, ne).copy_from(&hist_e(d - 1));
            for j in (0..d).rev() {
                z = &self.model.phi * &z + &self.model.gamma * hist_u(j);
            }
            m_now = z.rows(0, nm).into_owned();
        }
        // The design state as the core builds it: measured part, then the model's own.
        let design = |m: &DVector<f64>| {
            let mut x = DVector::zeros(n);
            x.rows_mut(0, nm).copy_from(m);
            x.rows_mut(nm, n - nm).copy_from(&e_now.rows(0, n - nm));
            x
        };
        let (x_late, x_now) = (design(&m_late), design(&m_now));
        let q = s.rows(oq, ny).into_owned();
        // A design that carries the actuators feeds back the model's deflections, which
        // follow the design states' model-only part (`e = [engine; actuators]`).
        let na = self.k.ncols() - n - ny;
        let act = e_now.rows(ne - na, na);
        let u = -(self.k.view((0, 0), (nu, n)) * &x_now)
            - self.k.view((0, n), (nu, na)) * act
            - self.k.view((0, n + na), (nu, ny)) * &q;
        let mut o = DVector::zeros(s.len());
        o.rows_mut(0, np)
            .copy_from(&(&self.pd * &p + &self.pb * &u));
        for j in (1..d).rev() {
            let v = s.rows(ox + (j - 1) * nm, nm).into_owned();
            o.rows_mut(ox + j * nm, nm).copy_from(&v);
        }
        if d > 0 {
            o.rows_mut(ox, nm).copy_from(&p.rows(0, nm));
        }
        let mut z = DVector::zeros(nm + ne);
        z.rows_mut(nm, ne).copy_from(&e_now);
        let z = &self.model.phi * z + &self.model.gamma * &u;
        o.rows_mut(oe, ne).copy_from(&z.rows(nm, ne));
        for j in (1..d).rev() {
            let v = s.rows(or + (j - 1) * (ne + nu), ne + nu).into_owned();
            o.rows_mut(or + j * (ne + nu), ne + nu).copy_from(&v);
        }
        if d > 0 {
            o.rows_mut(or, ne).copy_from(&e_now);
            o.rows_mut(or + ne, nu).copy_from(&u);
        }
        o.rows_mut(oq, ny)
            .copy_from(&(&q + self.c * &x_late * TS_S));
        o
    }

    /// The loop's transition matrix, column by column.
    pub fn matrix(&self) -> DMatrix<f64> {
        let l = self.len();
        let mut m = DMatrix::zeros(l, l);
        for j in 0..l {
            let mut e = DVector::zeros(l);
            e[j] = 1.0;
            m.set_column(j, &self.step(&e));
        }
        m
    }
}

/// The least-damped mode above 0.25 Hz (the slow modes of heading, speed and the
/// integrators below): (frequency Hz, damping ratio).
pub fn least_damped(m: &DMatrix<f64>) -> Option<(f64, f64)> {
    m.complex_eigenvalues()
        .iter()
        .filter(|l| l.im >= 0.0 && l.norm() > 1e-9)
        .map(|l| {
            let s = l.ln() / TS_S;
            (s.norm() / TAU, -s.re / s.norm())
        })
        .filter(|&(f, _)| f > 0.25)
        .min_by(|a, b| a.1.total_cmp(&b.1))
}

/// The closed loop of one channel of `design` (gains, predictor model) flying the plant
/// of `truth` (the same design point at another cg), with `d` periods of latency.
pub fn channel_loop<'a>(
    truth: &'a super::Synthesis,
    design: &'a super::Synthesis,
    lateral: bool,
    bandwidth_radps: f64,
    d: usize,
    predict: bool,
) -> LatencyLoop<'a> {
    let (actuated, t, g, model): (&[bool], _, _, _) = if lateral {
        (
            &[true, true],
            &truth.lat,
            &design.lat,
            &design.predictor_lat,
        )
    } else {
        (
            &[true, false],
            &truth.lon,
            &design.lon,
            &design.predictor_lon,
        )
    };
    let (a, b) = super::channel_plant(&truth.linear, lateral);
    let (ac, bc) = super::with_actuators(&a, &b, actuated, bandwidth_radps);
    let (pd, pb) = super::linalg::zoh(&ac, &bc, TS_S);
    LatencyLoop {
        pd,
        pb,
        model,
        c: &t.c,
        k: &g.k,
        n: a.nrows(),
        d,
        predict,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::receiver::F16;
    use crate::synthesis::{self, DesignWeights};

    /// The refuelling design as the core flies it (gains designed at the aft cg, the
    /// predictor's model the nominal cg's) flying the airframe at cg 0.30, 0.35 and 0.40:
    /// with the prediction every channel keeps within 0.04 of its undelayed damping up to
    /// three periods of latency (worst 0.035 below, cg 0.40, longitudinal, three periods).
    /// Fed back late, three periods now leave the longitudinal channel damped above 0.2
    /// (0.245 at cg 0.40): the design carries the actuators' lag, and the lightly damped
    /// actuator mode that late feedback drove unstable before (-0.009 at cg 0.40) is gone.
    #[test]
    fn the_prediction_keeps_the_design_damping_over_three_periods_of_latency() {
        let w = DesignWeights::refuelling();
        let at = |xcg| {
            synthesis::synthesize(
                &F16::new(xcg).unwrap(),
                synthesis::REFUELLING_SPEED_MPS,
                synthesis::REFUELLING_ALTITUDE_M,
                TS_S,
                synthesis::PROBE_TIP_BODY_M,
                &w,
            )
            .unwrap()
        };
        let model = at(synthesis::NOMINAL_XCG);
        let mut nominal = at(synthesis::REFUELLING_DESIGN_XCG);
        nominal.predictor_lon = model.predictor_lon.clone();
        nominal.predictor_lat = model.predictor_lat.clone();
        let bw = F16::new(synthesis::NOMINAL_XCG)
            .unwrap()
            .actuators()
            .bandwidth_radps;
        for xcg in [0.30, 0.35, 0.40] {
            let truth = at(xcg);
            for lateral in [false, true] {
                let damping = |d, predict| {
                    let m = channel_loop(&truth, &nominal, lateral, bw, d, predict).matrix();
                    least_damped(&m).unwrap().1
                };
                let design = damping(0, false);
                for d in 1..=3 {
                    let z = damping(d, true);
                    assert!(
                        (z - design).abs() < 0.04,
                        "cg {xcg} lateral {lateral} d {d}: damping {z:.3}, design {design:.3}"
                    );
                }
                if !lateral {
                    let z = damping(3, false);
                    assert!(z > 0.2, "cg {xcg}: late feedback damping {z:.3}");
                }
            }
        }
    }
}
