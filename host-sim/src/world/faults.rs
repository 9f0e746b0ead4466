//! Fault injection between the world and the flight computer: what the camera, the
//! navigation system and the actuators can do wrong, on a schedule.
//!
//! A [`SimFault`] is a [`FaultKind`], a [`Trigger`] (a time, or the true range to the drogue
//! falling to a value) and a duration (`f64::INFINITY`: to the end of the run). The
//! [`FaultInjector`] applies a list of them to one run, in [`crate::sim::run_with_faults`]:
//!
//! ```text
//! world.capture ─► [occlusion: inside the LED camera] ─► dropout / latency spike / frozen ─► flight computer
//! navigation truth ─► NaN ─► flight computer
//! flight computer ─► stuck / rate-limited actuator ─► receiver
//! ```
//!
//! Measurement faults act on the *stream* of frames the camera delivers (a frame is new when
//! its sequence number changes): a dropout loses the new frames of its window, so the flight
//! computer sees the last frame again (same sequence number, as from a stalled camera); a
//! latency spike delivers the frames that arrive in its window `extra_s` later, in order, so
//! the frames behind them wait too (a stalled pipeline); a frozen measurement repeats the
//! image point and depth of the last frame before the fault with the sequence numbers still
//! advancing (a tracker whose output stuck while its frame counter runs). Occlusion hides LEDs
//! from the LED camera (bit `k` of the mask is LED `k`, the ring numbering of
//! [`super::led_camera`]); it does nothing to the ideal camera. Navigation NaN replaces
//! every field of the sample. A stuck actuator holds its position at the fault's onset (the
//! surface's actual position; for the throttle, the last command applied); a rate-limited
//! one follows its command at no more than `rate_per_s` (rad/s, or throttle fraction per s).
//!
//! Invariants: with no fault the injector passes every input through unchanged (a run with
//! an empty list is bit for bit the run without faults); a fault is active from its onset
//! (inclusive) for its duration (exclusive); the trigger of a range fault fires once, at the
//! first step whose true range is at or below its value.

use std::collections::VecDeque;

use ibvs_core::measurement::CameraMeasurement;
use ibvs_core::nav::NavSample;
use serde::{Deserialize, Serialize};

use crate::receiver::{ReceiverCommand, ReceiverState};

/// Times within this of each other are equal (absorbs rounding in `k * Ts` clocks), s.
const TIME_TOLERANCE_S: f64 = 1e-9;

/// One of the receiver's four actuators.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Actuator {
    /// Elevator, rad.
    Elevator,
    /// Throttle, fraction.
    Throttle,
    /// Aileron, rad.
    Aileron,
    /// Rudder, rad.
    Rudder,
}

impl Actuator {
    /// All four, in command order.
    pub const ALL: [Actuator; 4] = [
        Actuator::Elevator,
        Actuator::Throttle,
        Actuator::Aileron,
        Actuator::Rudder,
    ];

    fn get(self, c: &ReceiverCommand) -> f64 {
        match self {
            Actuator::Elevator => c.elevator_rad,
            Actuator::Throttle => c.throttle,
            Actuator::Aileron => c.aileron_rad,
            Actuator::Rudder => c.rudder_rad,
        }
    }

    fn set(self, c: &mut ReceiverCommand, v: f64) {
        match self {
            Actuator::Elevator => c.elevator_rad = v,
            Actuator::Throttle => c.throttle = v,
            Actuator::Aileron => c.aileron_rad = v,
            Actuator::Rudder => c.rudder_rad = v,
        }
    }

    /// The actuator's actual position in `x` (the throttle has none: `None`).
    fn position(self, x: &ReceiverState) -> Option<f64> {
        let s = &x.surfaces_rad;
        match self {
            Actuator::Elevator => Some(s.elevator_rad),
            Actuator::Throttle => None,
            Actuator::Aileron => Some(s.aileron_rad),
            Actuator::Rudder => Some(s.rudder_rad),
        }
    }
}

/// What goes wrong.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FaultKind {
    /// No new camera frame reaches the flight computer: it sees the last one again.
    ImageDropout,
    /// The LEDs whose bits are set are hidden from the LED camera.
    LedOcclusion {
        /// Bit `k`: LED `k`.
        mask: u32,
    },
    /// Frames arriving in the window are delivered `extra_s` later, in order.
    LatencySpike {
        /// Extra delay, s.
        extra_s: f64,
    },
    /// Image point and depth stay those of the last frame before the fault; sequence numbers
    /// advance.
    FrozenMeasurement,
    /// Every navigation field is NaN.
    NavNaN,
    /// The actuator stays where it was at the onset.
    ActuatorStuck {
        /// Which.
        actuator: Actuator,
    },
    /// The actuator follows its command at a limited rate.
    ActuatorRateLimited {
        /// Which.
        actuator: Actuator,
        /// Largest rate, rad/s (throttle: fraction per s).
        rate_per_s: f64,
    },
    /// The aircraft's autopilot leaves the mode that follows the flight computer's
    /// setpoints (a pilot's or a failsafe's mode change; with the attitude-command inner
    /// loop only): its heartbeat says so, and it flies on alone ([`crate::receiver::Autopilot`]).
    AutopilotModeChange,
}

/// When a fault starts.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Trigger {
    /// At this run time, s.
    AtTime(f64),
    /// At the first step at which the true range to the drogue (drogue centre minus probe
    /// tip, tanker x) is at or below this, m.
    AtRange(f64),
}

/// One scheduled fault.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SimFault {
    /// What.
    pub kind: FaultKind,
    /// When it starts.
    pub start: Trigger,
    /// How long it lasts, s (`f64::INFINITY`: to the end of the run).
    pub duration_s: f64,
}

impl SimFault {
    /// A fault of `kind` from run time `t_s` for `duration_s`.
    pub fn at_time(kind: FaultKind, t_s: f64, duration_s: f64) -> Self {
        Self {
            kind,
            start: Trigger::AtTime(t_s),
            duration_s,
        }
    }

    /// A fault of `kind` from the step at which the range is at most `range_m`, for
    /// `duration_s`.
    pub fn at_range(kind: FaultKind, range_m: f64, duration_s: f64) -> Self {
        Self {
            kind,
            start: Trigger::AtRange(range_m),
            duration_s,
        }
    }

    /// Checks the numbers; the message names the bad one.
    pub fn validate(&self) -> Result<(), &'static str> {
        let start_ok = match self.start {
            Trigger::AtTime(t) => t.is_finite() && t >= 0.0,
            Trigger::AtRange(r) => r.is_finite(),
        };
        if !start_ok {
            return Err("fault trigger must be a finite time >= 0 or a finite range");
        }
        if self.duration_s.is_nan() || self.duration_s < 0.0 {
            return Err("fault duration must be >= 0 (infinity: to the end)");
        }
        match self.kind {
            FaultKind::LatencySpike { extra_s } if !(extra_s.is_finite() && extra_s >= 0.0) => {
                Err("latency spike extra_s must be finite and >= 0")
            }
            FaultKind::ActuatorRateLimited { rate_per_s, .. }
                if !(rate_per_s.is_finite() && rate_per_s >= 0.0) =>
            {
                Err("actuator rate limit must be finite and >= 0")
            }
            _ => Ok(()),
        }
    }
}

/// Applies a list of faults to one run. See the module doc.
#[derive(Debug, Clone)]
pub struct FaultInjector {
    faults: Vec<SimFault>,
    /// Resolved onset time of each fault, s.
    onset: Vec<Option<f64>>,
    /// Which faults are active in the current step.
    active: Vec<bool>,
    /// Sequence number of the last frame the camera delivered (new-frame detection).
    last_raw_seq: Option<u32>,
    /// Frames on their way to the flight computer with their delivery times.
    queue: VecDeque<(f64, CameraMeasurement)>,
    /// The last frame handed to the flight computer before freezing.
    delivered: Option<CameraMeasurement>,
    /// Content held by a frozen measurement.
    frozen: Option<CameraMeasurement>,
    /// The command applied in the last step (rate limits start from it).
    last_applied: Option<ReceiverCommand>,
    /// Position held by each stuck actuator, in [`Actuator::ALL`] order.
    stuck: [Option<f64>; 4],
}

impl FaultInjector {
    /// An injector for `faults` (each validated).
    pub fn new(faults: &[SimFault]) -> Result<Self, &'static str> {
        for f in faults {
            f.validate()?;
        }
        Ok(Self {
            faults: faults.to_vec(),
            onset: vec![None; faults.len()],
            active: vec![false; faults.len()],
            last_raw_seq: None,
            queue: VecDeque::new(),
            delivered: None,
            frozen: None,
            last_applied: None,
            stuck: [None; 4],
        })
    }

    /// True when no fault is scheduled (everything passes through).
    pub fn is_empty(&self) -> bool {
        self.faults.is_empty()
    }

    /// Starts the step at time `t_s` with the true range to the drogue `range_m`: resolves
    /// triggers and decides which faults are active.
    pub fn begin_step(&mut self, t_s: f64, range_m: f64) {
        for (i, f) in self.faults.iter().enumerate() {
            if self.onset[i].is_none() {
                self.onset[i] = match f.start {
                    Trigger::AtTime(t0) => Some(t0),
                    Trigger::AtRange(r) => (range_m <= r).then_some(t_s),
                };
            }
            self.active[i] = self.onset[i].is_some_and(|t0| {
                t_s + TIME_TOLERANCE_S >= t0 && t_s + TIME_TOLERANCE_S < t0 + f.duration_s
            });
        }
    }

    fn active_kinds(&self) -> impl Iterator<Item = &FaultKind> + '_ {
        self.faults
            .iter()
            .zip(&self.active)
            .filter(|(_, a)| **a)
            .map(|(f, _)| &f.kind)
    }

    /// Whether any active fault is of a kind matching `pred`.
    fn any(&self, pred: impl Fn(&FaultKind) -> bool) -> bool {
        self.active_kinds().any(pred)
    }

    /// LEDs hidden this step (bit `k`: LED `k`).
    pub fn occlusion_mask(&self) -> u32 {
        self.active_kinds()
            .filter_map(|k| match k {
                FaultKind::LedOcclusion { mask } => Some(*mask),
                _ => None,
            })
            .fold(0, |a, m| a | m)
    }

    /// What the flight computer receives this step, given the camera's latest frame.
    pub fn measurement(&mut self, t_s: f64, raw: CameraMeasurement) -> CameraMeasurement {
        if self.is_empty() {
            return raw;
        }
        let new_frame = self.last_raw_seq != Some(raw.seq);
        self.last_raw_seq = Some(raw.seq);
        if new_frame && !self.any(|k| matches!(k, FaultKind::ImageDropout)) {
            let extra = self
                .active_kinds()
                .filter_map(|k| match k {
                    FaultKind::LatencySpike { extra_s } => Some(*extra_s),
                    _ => None,
                })
                .fold(0.0, f64::max);
            self.queue.push_back((t_s + extra, raw));
        }
        while let Some(&(due, m)) = self.queue.front() {
            if due > t_s + TIME_TOLERANCE_S {
                break;
            }
            self.queue.pop_front();
            self.delivered = Some(m);
        }
        let out = self.delivered.unwrap_or_default();
        if self.any(|k| matches!(k, FaultKind::FrozenMeasurement)) {
            let held = *self.frozen.get_or_insert(out);
            CameraMeasurement {
                seq: out.seq,
                ..held
            }
        } else {
            self.frozen = None;
            out
        }
    }

    /// True while the autopilot has left the mode that follows the setpoints.
    pub fn autopilot_released(&self) -> bool {
        self.any(|k| matches!(k, FaultKind::AutopilotModeChange))
    }

    /// The navigation sample the flight computer receives this step.
    pub fn nav(&self, nav: NavSample) -> NavSample {
        if self.any(|k| matches!(k, FaultKind::NavNaN)) {
            NavSample::from_array([f32::NAN; 12])
        } else {
            nav
        }
    }

    /// The command the receiver's actuators get this step (held over the step), for the
    /// receiver at `x` and a control period `ts_s`.
    pub fn actuate(
        &mut self,
        cmd: ReceiverCommand,
        x: &ReceiverState,
        ts_s: f64,
    ) -> ReceiverCommand {
        if self.is_empty() {
            return cmd;
        }
        let mut out = cmd;
        let prev = self.last_applied.unwrap_or(cmd);
        for (j, a) in Actuator::ALL.into_iter().enumerate() {
            let mut stuck_now = false;
            let mut rate: Option<f64> = None;
            for k in self.active_kinds() {
                match *k {
                    FaultKind::ActuatorStuck { actuator } if actuator == a => stuck_now = true,
                    FaultKind::ActuatorRateLimited {
                        actuator,
                        rate_per_s,
                    } if actuator == a => {
                        rate = Some(rate.map_or(rate_per_s, |r: f64| r.min(rate_per_s)));
                    }
                    _ => {}
                }
            }
            if stuck_now {
                let held = *self.stuck[j]
                    .get_or_insert_with(|| a.position(x).unwrap_or_else(|| a.get(&prev)));
                a.set(&mut out, held);
            } else {
                self.stuck[j] = None;
                if let Some(r) = rate {
                    let (p, c) = (a.get(&prev), a.get(&cmd));
                    let step = r * ts_s;
                    a.set(&mut out, p + (c - p).clamp(-step, step));
                }
            }
        }
        self.last_applied = Some(out);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(seq: u32, x: f32) -> CameraMeasurement {
        CameraMeasurement {
            seq,
            tracked: true,
            image_x: x,
            image_y: 0.0,
            depth_m: 5.0,
            probe_tip: None,
        }
    }

    /// Feeds one new frame per 20 ms step; returns what came out.
    fn stream(faults: &[SimFault], steps: u32) -> Vec<CameraMeasurement> {
        let mut inj = FaultInjector::new(faults).unwrap();
        (0..steps)
            .map(|k| {
                let t = f64::from(k) * 0.02;
                inj.begin_step(t, 10.0 - t);
                inj.measurement(t, frame(k + 1, k as f32))
            })
            .collect()
    }

    #[test]
    fn without_faults_everything_passes_through() {
        let out = stream(&[], 10);
        assert_eq!(
            out,
            (0..10).map(|k| frame(k + 1, k as f32)).collect::<Vec<_>>()
        );
    }

    #[test]
    fn a_dropout_repeats_the_last_frame_for_its_window() {
        let out = stream(&[SimFault::at_time(FaultKind::ImageDropout, 0.1, 0.1)], 12);
        let seqs: Vec<u32> = out.iter().map(|m| m.seq).collect();
        assert_eq!(seqs, [1, 2, 3, 4, 5, 5, 5, 5, 5, 5, 11, 12]);
    }

    #[test]
    fn a_latency_spike_stalls_then_delivers_late_frames_in_order() {
        // Frames 6 and 7 (t = 0.10, 0.12) are due 0.1 s late; frames 8.. queue behind them and
        // come out with frame 7 (the newest due wins).
        let out = stream(
            &[SimFault::at_time(
                FaultKind::LatencySpike { extra_s: 0.1 },
                0.1,
                0.04,
            )],
            14,
        );
        let seqs: Vec<u32> = out.iter().map(|m| m.seq).collect();
        assert_eq!(seqs, [1, 2, 3, 4, 5, 5, 5, 5, 5, 5, 6, 12, 13, 14]);
    }

    #[test]
    fn a_frozen_measurement_keeps_its_content_with_fresh_numbers() {
        let out = stream(
            &[SimFault::at_range(FaultKind::FrozenMeasurement, 9.91, 0.06)],
            10,
        );
        // Range 10 - t falls below 9.91 at t = 0.1 (step 5): frames 6..8 carry frame 6's content.
        let xs: Vec<f32> = out.iter().map(|m| m.image_x).collect();
        assert_eq!(xs, [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 5.0, 5.0, 8.0, 9.0]);
        assert_eq!(out[7].seq, 8);
    }

    #[test]
    fn nav_nan_and_occlusion_apply_only_in_their_window() {
        let mut inj = FaultInjector::new(&[
            SimFault::at_time(FaultKind::NavNaN, 0.5, 0.5),
            SimFault::at_time(FaultKind::LedOcclusion { mask: 0b11 }, 0.0, f64::INFINITY),
            SimFault::at_time(FaultKind::LedOcclusion { mask: 0b100 }, 0.2, 0.1),
        ])
        .unwrap();
        inj.begin_step(0.48, 1.0);
        assert!(inj.nav(NavSample::default()).as_array()[0].is_finite());
        assert_eq!(inj.occlusion_mask(), 0b11);
        inj.begin_step(0.5, 1.0);
        assert!(
            inj.nav(NavSample::default())
                .as_array()
                .iter()
                .all(|v| v.is_nan())
        );
        inj.begin_step(1.0, 1.0);
        assert!(inj.nav(NavSample::default()).as_array()[0].is_finite());
        inj.begin_step(0.2, 1.0);
        assert_eq!(inj.occlusion_mask(), 0b111);
    }

    #[test]
    fn stuck_and_rate_limited_actuators() {
        let mut x = crate::receiver::F16::new(0.35)
            .unwrap()
            .trim_straight_level(120.0, 3000.0)
            .unwrap()
            .state;
        x.surfaces_rad.aileron_rad = 0.05;
        let mut inj = FaultInjector::new(&[
            SimFault::at_time(
                FaultKind::ActuatorStuck {
                    actuator: Actuator::Aileron,
                },
                0.02,
                0.04,
            ),
            SimFault::at_time(
                FaultKind::ActuatorRateLimited {
                    actuator: Actuator::Throttle,
                    rate_per_s: 0.5,
                },
                0.0,
                f64::INFINITY,
            ),
        ])
        .unwrap();
        let cmd = |a: f64, th: f64| ReceiverCommand {
            elevator_rad: 0.0,
            throttle: th,
            aileron_rad: a,
            rudder_rad: 0.0,
        };
        inj.begin_step(0.0, 5.0);
        let c0 = inj.actuate(cmd(0.1, 0.2), &x, 0.02);
        assert_eq!((c0.aileron_rad, c0.throttle), (0.1, 0.2));
        inj.begin_step(0.02, 5.0);
        let c1 = inj.actuate(cmd(0.2, 1.0), &x, 0.02);
        assert_eq!(c1.aileron_rad, 0.05, "held at the surface's position");
        assert!((c1.throttle - 0.21).abs() < 1e-12, "0.5 per s for 20 ms");
        inj.begin_step(0.04, 5.0);
        x.surfaces_rad.aileron_rad = -0.3;
        assert_eq!(inj.actuate(cmd(0.2, 1.0), &x, 0.02).aileron_rad, 0.05);
        inj.begin_step(0.06, 5.0);
        assert_eq!(
            inj.actuate(cmd(0.2, 1.0), &x, 0.02).aileron_rad,
            0.2,
            "released"
        );
    }

    #[test]
    fn bad_numbers_are_named() {
        let e =
            FaultInjector::new(&[SimFault::at_time(FaultKind::NavNaN, f64::NAN, 1.0)]).unwrap_err();
        assert!(e.contains("trigger"), "{e}");
        let e = FaultInjector::new(&[SimFault::at_time(
            FaultKind::LatencySpike { extra_s: -1.0 },
            0.0,
            1.0,
        )])
        .unwrap_err();
        assert!(e.contains("extra_s"), "{e}");
    }
}
