//! Navigation-latency compensation: the inner loops' state predicted forward over the INS's
//! latency from the commands the controller itself sent.
//!
//! The navigation sample that reaches the step at `k` was measured `d` control periods
//! earlier (`ControllerConfig::nav_latency_steps`, the installed INS's latency). Fed back as
//! it is, two periods of it take the short-period damping of the refuelling design from 0.38
//! to 0.19 and bring a 1.8 Hz lateral mode down to 0.17 (cg 0.30), and the receiver loses
//! control in strong air; predicted, every loop keeps within 0.04 of its design damping at
//! cg 0.30..0.40 and up to three periods (`examples/delay_margin.rs`). The step therefore runs, per channel, the
//! design plant with its actuators, discretised by zero-order hold at the control period
//! (generated in [`crate::gains`]):
//!
//! ```text
//! m[j+1] = m[j] + (Phi_mm - I) m[j] + Phi_me e[j] + Gamma_m u[j]    measured states
//! e[j+1] =                            Phi_ee e[j] + Gamma_e u[j]    actuators, engine
//! ```
//!
//! from the late sample `m[k-d]` and its own record of the commands `u[k-d] .. u[k-1]` it
//! sent (perturbations from trim, after saturation) and of `e[k-d] .. e[k-1]`, `d` times,
//! to `m[k]`. The unmeasured rows do not depend on the measured states (checked when the
//! model is generated), so `e` is a running open-loop model of the controller's own
//! commands, like the engine estimate; each of its steps moves a surface's deflection by
//! at most the surface's rate limit times the period (`ActuatorLimits::rate_radps`), as the
//! surface itself moves, and the prediction reads the recorded `e` rather than stepping a
//! second model of it.
//!
//! What the model does not know (a steady wind in the tanker's wake, a sensor bias, another
//! cg) makes a steady state look like a slow change, and the prediction carries it on: a
//! bias of a few hundredths of a metre per second in the tracked velocity. The controller
//! therefore feeds the prediction to the state feedback only, and its integrators (and the
//! mode logic) keep reading the late sample, unbiased: the integral action then takes the
//! prediction's steady error out with the rest of the trim (integrating the prediction
//! instead left the tip 0.1..0.2 m off the drogue at station in calm air, measured).
//!
//! A held sample (the navigation rejected, `nav_held_steps`) is predicted as a fresh one of
//! the same latency would be: the hold is short (the hold-then-breakaway limit), and the
//! commands it flies are recorded as usual.
//!
//! Invariants: the latency is at most [`MAX_NAV_LATENCY_STEPS`] (the configuration is
//! validated); with latency 0 the prediction is the sample itself, bit for bit, and no
//! command is kept (the unmeasured states still follow the commands: the refuelling design
//! feeds the actuators' deflections back); for finite samples and commands every value
//! stays finite (the model is stable: its eigenvalues are the airframe's and the
//! actuators', the heading's at 1).

use crate::inner::dot;
use crate::num::clamp_sym;

/// Largest navigation latency the predictor compensates, control periods (80 ms at 50 Hz).
pub const MAX_NAV_LATENCY_STEPS: u8 = 4;

const RING: usize = MAX_NAV_LATENCY_STEPS as usize;

/// One channel's discrete plant-and-actuator model, split into the measured states `m`
/// (`NM`), the unmeasured ones `e` (`NE`) and the inputs (`NU`), row-major blocks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlantModel<const NM: usize, const NE: usize, const NU: usize> {
    /// `Phi_mm - I`: measured states to the measured states' change over one step.
    pub delta_mm: [[f32; NM]; NM],
    /// `Phi_me`: unmeasured states to measured states.
    pub phi_me: [[f32; NE]; NM],
    /// `Phi_ee`: unmeasured states to themselves.
    pub phi_ee: [[f32; NE]; NE],
    /// `Gamma_m`: inputs to measured states.
    pub gamma_m: [[f32; NU]; NM],
    /// `Gamma_e`: inputs to unmeasured states.
    pub gamma_e: [[f32; NU]; NE],
}

/// `a x` for a row-major `a`, each row by [`dot`] (the inner loops' product).
#[inline(always)]
fn mul<const R: usize, const C: usize>(a: &[[f32; C]; R], x: &[f32; C]) -> [f32; R] {
    core::array::from_fn(|i| dot(&a[i], x))
}

#[inline(always)]
fn add<const N: usize>(a: [f32; N], b: [f32; N]) -> [f32; N] {
    core::array::from_fn(|i| a[i] + b[i])
}

/// One channel's predictor: the model, the latency and the record of the last
/// [`MAX_NAV_LATENCY_STEPS`] steps.
#[derive(Debug, Clone, PartialEq)]
pub struct LatencyPredictor<const NM: usize, const NE: usize, const NU: usize> {
    model: PlantModel<NM, NE, NU>,
    latency: usize,
    /// Unmeasured states now, `e[k]`.
    e_now: [f32; NE],
    /// `(e[j], u[j])` of the last steps; `ring[(head + RING - 1 - i) % RING]` is step `k-1-i`.
    ring: [([f32; NE], [f32; NU]); RING],
    head: usize,
    /// Steps recorded since the last reset, at most RING: older entries read as trim (the
    /// reset does not clear the ring, so that the step calls no library fill).
    recorded: usize,
    /// Largest change of each unmeasured state in one step (the actuators' rate limits).
    rate_step: [f32; NE],
}

impl<const NM: usize, const NE: usize, const NU: usize> LatencyPredictor<NM, NE, NU> {
    /// A predictor at trim for `latency_steps` (clamped to [`MAX_NAV_LATENCY_STEPS`]; the
    /// configuration's validation refuses more), each unmeasured state moving by at most
    /// `rate_step[i]` per step (the surfaces' rate limits times the period; infinite for the
    /// engine, whose power lag is its own limit; not NaN).
    pub fn new(model: PlantModel<NM, NE, NU>, latency_steps: u8, rate_step: [f32; NE]) -> Self {
        Self {
            model,
            latency: usize::from(latency_steps.min(MAX_NAV_LATENCY_STEPS)),
            e_now: [0.0; NE],
            ring: [([0.0; NE], [0.0; NU]); RING],
            head: 0,
            recorded: 0,
            rate_step,
        }
    }

    /// Takes another model (the gain schedule's at a new flight condition), keeping the
    /// recorded commands and unmeasured states: they are perturbations from trim, and the
    /// models differ little between neighbouring conditions.
    pub fn set_model(&mut self, model: PlantModel<NM, NE, NU>) {
        self.model = model;
    }

    /// The latency compensated, control periods.
    pub fn latency_steps(&self) -> usize {
        self.latency
    }

    /// The measured states now, predicted from the sample `m_late` measured `latency`
    /// steps ago.
    #[inline(always)]
    pub fn predict(&self, m_late: [f32; NM]) -> [f32; NM] {
        let d = self.latency;
        if d == 0 {
            return m_late;
        }
        // A fixed sequence of calls, not a loop: the step's static time bound admits no
        // data-dependent loop, and one out-of-line body keeps the flash small.
        let mut m = m_late;
        if d > 3 {
            m = self.advance(m, 3);
        }
        if d > 2 {
            m = self.advance(m, 2);
        }
        if d > 1 {
            m = self.advance(m, 1);
        }
        self.advance(m, 0)
    }

    /// The ring's entry `i` (step k-1-i); before the last reset, trim (all zero).
    #[inline(always)]
    fn entry(&self, i: usize) -> ([f32; NE], [f32; NU]) {
        if i < self.recorded {
            self.ring[(self.head + RING - 1 - i) % RING]
        } else {
            ([0.0; NE], [0.0; NU])
        }
    }

    /// The measured states' model step from `m` under entry `i`'s record: the command sent
    /// and the unmeasured states when it was sent (the running model's, rate limits
    /// included: the prediction sees the deflections [`Self::record`] had).
    #[inline(never)]
    fn advance(&self, m: [f32; NM], i: usize) -> [f32; NM] {
        let mdl = &self.model;
        let (e, u) = self.entry(i);
        let dm = add(
            add(mul(&mdl.delta_mm, &m), mul(&mdl.phi_me, &e)),
            mul(&mdl.gamma_m, &u),
        );
        add(m, dm)
    }

    /// The unmeasured states now, `e[k]` (perturbations from trim): the model's engine
    /// power and actuator deflections under the commands recorded so far. The refuelling
    /// design feeds the actuators' back ([`crate::inner`]).
    #[inline(always)]
    pub fn unmeasured(&self) -> &[f32; NE] {
        &self.e_now
    }

    /// Records the command sent this step (perturbation from trim) and advances the
    /// unmeasured states by it. Without latency nothing is kept for the prediction, but
    /// the unmeasured states still advance.
    #[inline(always)]
    pub fn record(&mut self, u: [f32; NU]) {
        if self.latency > 0 {
            // `head` is always below RING; the modulo says so to the bounds check too.
            self.ring[self.head % RING] = (self.e_now, u);
            self.head = (self.head + 1) % RING;
            if self.recorded < RING {
                self.recorded += 1;
            }
        }
        // The model's step, each state's change clamped to its rate limit: the surfaces move
        // at most that fast, and a model without the limit runs ahead of a rate-limited
        // surface (the deflection fed back is then one the surface never reached). Where no
        // limit acts the step is the model's to the bit.
        let mdl = &self.model;
        let mut next = add(mul(&mdl.phi_ee, &self.e_now), mul(&mdl.gamma_e, &u));
        for ((n, e), r) in next.iter_mut().zip(self.e_now).zip(self.rate_step) {
            let change = *n - e;
            if change > r || change < -r {
                *n = e + clamp_sym(change, r);
            }
        }
        self.e_now = next;
    }

    /// Back to trim: no command sent, actuators at trim.
    pub fn reset(&mut self) {
        self.e_now = [0.0; NE];
        self.recorded = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// No rate limit on the unmeasured state.
    const FREE: [f32; 1] = [f32::INFINITY];

    /// A scalar plant `m' = 0.9 m + 0.5 e + 0.1 u`, `e' = 0.8 e + 0.2 u`.
    fn model() -> PlantModel<1, 1, 1> {
        PlantModel {
            delta_mm: [[-0.1]],
            phi_me: [[0.5]],
            phi_ee: [[0.8]],
            gamma_m: [[0.1]],
            gamma_e: [[0.2]],
        }
    }

    /// The plant's `m` from rest under inputs `u(k)`: element `k` is `m[k]`, before the
    /// input of step `k`.
    fn truth<const N: usize>(u: impl Fn(usize) -> f32) -> [f32; N] {
        let p = model();
        let (mut m, mut e, mut out) = (0.0f32, 0.0f32, [0.0; N]);
        for (k, slot) in out.iter_mut().enumerate() {
            *slot = m;
            let uk = u(k);
            let m1 = (1.0 + p.delta_mm[0][0]) * m + p.phi_me[0][0] * e + p.gamma_m[0][0] * uk;
            e = p.phi_ee[0][0] * e + p.gamma_e[0][0] * uk;
            m = m1;
        }
        out
    }

    #[test]
    fn a_late_sample_is_predicted_to_the_present_exactly_for_a_known_plant() {
        let u = |k: usize| ((k as f32) * 0.7).sin();
        let m: [f32; 30] = truth(u);
        for d in 1..=MAX_NAV_LATENCY_STEPS {
            let mut p = LatencyPredictor::new(model(), d, FREE);
            let d = usize::from(d);
            for k in 0..30 {
                let late = if k >= d { m[k - d] } else { 0.0 };
                let now = p.predict([late]);
                if k >= d {
                    assert!(
                        (now[0] - m[k]).abs() < 1e-5,
                        "d {d} k {k}: {} vs {}",
                        now[0],
                        m[k]
                    );
                }
                p.record([u(k)]);
            }
        }
    }

    #[test]
    fn without_latency_the_sample_passes_unchanged_and_only_the_model_advances() {
        let mut p = LatencyPredictor::new(model(), 0, FREE);
        p.record([3.0]);
        assert_eq!(p.predict([0.25]), [0.25]);
        // e' = 0.8 e + 0.2 u from trim.
        assert_eq!(p.unmeasured(), &[0.2 * 3.0]);
        assert_eq!(p.recorded, 0);
        p.reset();
        assert_eq!(p, LatencyPredictor::new(model(), 0, FREE));
    }

    #[test]
    fn the_unmeasured_states_follow_the_commands_at_any_latency() {
        let u = |k: usize| ((k as f32) * 0.3).cos();
        for d in 0..=MAX_NAV_LATENCY_STEPS {
            let mut p = LatencyPredictor::new(model(), d, FREE);
            let mut e = 0.0f32;
            for k in 0..12 {
                assert!((p.unmeasured()[0] - e).abs() < 1e-6, "d {d} k {k}");
                p.record([u(k)]);
                e = 0.8 * e + 0.2 * u(k);
            }
        }
    }

    #[test]
    fn reset_forgets_the_commands_sent() {
        let mut p = LatencyPredictor::new(model(), 2, FREE);
        p.record([1.0]);
        p.record([1.0]);
        assert_ne!(p.predict([0.0]), [0.0]);
        p.reset();
        assert_eq!(p.predict([0.0]), [0.0]);
    }

    #[test]
    fn after_a_reset_the_predictor_is_as_new() {
        let mut used = LatencyPredictor::new(model(), 3, FREE);
        for k in 0..7 {
            used.record([k as f32]);
        }
        used.reset();
        let mut fresh = LatencyPredictor::new(model(), 3, FREE);
        for k in 0..5 {
            assert_eq!(used.predict([0.5]), fresh.predict([0.5]), "step {k}");
            used.record([0.3 * k as f32]);
            fresh.record([0.3 * k as f32]);
        }
    }

    #[test]
    fn a_new_model_predicts_from_the_recorded_commands() {
        // One step of latency: the prediction is one step of the model from the late sample
        // under the command recorded, m + (Phi_mm - I) m + Phi_me e + Gamma_m u with e = 0
        // (the actuators at trim when the command was sent). After the gain schedule's
        // follow-up the new model makes it: 2 - 0.5 * 2 + 0.3 * 1 = 1.3 (the old one: 1.9).
        let mut p = LatencyPredictor::new(model(), 1, FREE);
        p.record([1.0]);
        p.set_model(PlantModel {
            delta_mm: [[-0.5]],
            phi_me: [[0.7]],
            phi_ee: [[0.6]],
            gamma_m: [[0.3]],
            gamma_e: [[0.4]],
        });
        assert!((p.predict([2.0])[0] - 1.3).abs() < 1e-6);
    }

    #[test]
    fn a_latency_above_the_maximum_is_clamped() {
        let p = LatencyPredictor::new(model(), 200, FREE);
        assert_eq!(p.latency_steps(), usize::from(MAX_NAV_LATENCY_STEPS));
    }

    #[test]
    fn the_unmeasured_states_move_no_faster_than_their_rate_limit() {
        // e' = 0.8 e + 0.2 u: a command of 1 asks for 0.2 in the first step; limited to 0.05
        // per step the state ramps 0.05, 0.10, .. until the model's own step is smaller
        // (0.8 e + 0.2 - e < 0.05 from e = 0.75), then follows the model exactly.
        let mut p = LatencyPredictor::new(model(), 1, [0.05]);
        let mut e = 0.0f32;
        for k in 0..40 {
            p.record([1.0]);
            let model_step = 0.8 * e + 0.2;
            e = if model_step - e > 0.05 {
                e + 0.05
            } else {
                model_step
            };
            assert!(
                (p.unmeasured()[0] - e).abs() < 1e-6,
                "k {k}: {} vs {e}",
                p.unmeasured()[0]
            );
        }
        assert!((e - 1.0).abs() < 1e-3, "settled at {e}");
        // The prediction over the latency steps the state the same way: from the late
        // sample 0, one step under the recorded command 1 with the recorded e.
        let mut q = LatencyPredictor::new(model(), 2, [0.05]);
        q.record([1.0]);
        q.record([1.0]);
        // m1 = 0.9*0 + 0.5*0 + 0.1*1 = 0.1 (e[k-2] = 0); e1 = 0.05 (limited from 0.2);
        // m2 = 0.9*0.1 + 0.5*0.05 + 0.1*1 = 0.215.
        assert!(
            (q.predict([0.0])[0] - 0.215).abs() < 1e-6,
            "{:?}",
            q.predict([0.0])
        );
    }
}
