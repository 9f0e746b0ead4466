//! The refuelling procedure: what the receiver flies in each of its modes, and the numbers
//! its mode logic decides with.
//!
//! Place in the data flow: after the drogue estimator ([`crate::estimator`]), in place of
//! the paper's outer loop when [`Procedure::Refuelling`] is configured. The paper's
//! procedure ([`Procedure::Paper`]: approach, blind terminal phase, docked or breakaway) and
//! its law ([`crate::outer::ibvs`]) stay as they are; this is what goes beyond it, as
//! receivers fly it (`docs/conventions.md`, "The refuelling procedure"):
//!
//! ```text
//! standby ─engage─► pre-contact ──stable for the dwell──► contact approach ──go──► capture ──contact──► docked
//!                      ▲  (station behind the drogue)       │ (close at a stated speed)   │ (commit: camera
//!                      │                                    │                             │  blind if at the tip)
//!                      └───────── missed approach ◄── no-go ┴─────────────── miss ────────┘
//!                                 (back off, descend, return to the station; next attempt)
//! faults (navigation or measurement lost, overspeed, abort), attempts or time used up ─► breakaway (latched)
//! ```
//!
//! The law, in every engaged mode of the procedure, acts on the estimator's belief:
//! lateral and vertical `v = v̂_drogue(t + lead) + clamp(k r̂, ±max_correction)` while
//! closing (the drogue's velocity predicted a lead time ahead along the hose's swing, which
//! covers the inner loops' lag, plus a proportional correction of the offset `r̂` of the
//! drogue from the probe tip, limited in speed: an image-based law, since `r̂` is the image
//! point times depth, set back to the tip and filtered); at the station the same on the
//! drogue's mean offset, with a slow integral of it instead of the feed-forward; forward: a
//! depth-hold at the pre-contact station, a constant closing speed in the contact approach
//! and the capture, a back-off in the missed approach.
//!
//! Invariant: the functions here are pure; the outputs are finite and inside the velocity
//! limits for finite inputs (saturated).

use serde::{Deserialize, Serialize};

use crate::estimator::DrogueEstimate;
use crate::frames::VelocityRe;
use crate::num::{clamp_sym, max_to, min_to};
use crate::outer::VelocityLimits;

/// Which procedure the controller flies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[serde(rename_all = "lowercase")]
pub enum Procedure {
    /// The paper's single shot: approach on the outer law, blind terminal phase, docked, or a
    /// latched breakaway on any miss (`docs/paper.md`).
    Paper,
    /// The refuelling procedure of this module: pre-contact, contact approach, go/no-go,
    /// capture, docked; missed approach and retry; breakaway for faults and the end of the
    /// sortie.
    #[default]
    Refuelling,
}

/// Parameters of the refuelling procedure (defaults: our choices, each measured with the
/// campaigns of `docs/scenarios.md`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
// Scenario files name only what they change; an unknown key is an error that names it.
#[serde(default, deny_unknown_fields)]
pub struct RefuellingConfig {
    /// Pre-contact station: probe tip to drogue plane, m. Default 3.6 m (about 12 ft: the
    /// receiver stabilises a few feet behind the basket before it is cleared to contact),
    /// outside the gate ([`commit_depth`], 2.5 m at 1 m/s) by more than the station's
    /// overrun limit; it was 3 m while the gate was at a fixed 1 m.
    pub station_depth_m: f32,
    /// Gain of the pre-contact depth hold, 1/s.
    pub station_gain_per_s: f32,
    /// Integral gain of the station's lateral and vertical hold on the drogue's mean offset,
    /// 1/s²: the proportional `track_gain_per_s` alone leaves a steady offset of
    /// `bias / gain` where the navigation's velocity is biased (the inner loops hold the
    /// velocity the INS reports): 0.07 m/s left 0.22 m, outside `station_offset_tol_m`,
    /// and the sortie timed out at the station (9 of 10,000 `level1` sorties, 11 of
    /// `bow-wave`, 4 of `level2`, the same INS draws). Default 0.01/s² (a 50 s integral
    /// time, slow beside the swing): those 9 dock in 19 to 25 s; at 0.05/s² they dock too,
    /// but in MIL-F-8785C 10⁻² air the station then holds less steadily (1,000 sorties:
    /// 86.9 % docked, `SortieTimeout` 52, against 91.0 % and 24 without the integral; at
    /// 0.02/s² 89.8 %, at 0.01/s² 90.4 %, `SortieTimeout` 21; `docs/scenarios.md`). 0
    /// turns it off.
    pub station_integral_gain_per_s2: f32,
    /// Largest speed the station's integral may add, m/s.
    pub station_max_integral_mps: f32,
    /// Largest closing or opening speed of the depth hold, m/s. The receiver must be able
    /// to stop on the station without running through its overrun limit: after the depth
    /// hold's command comes down, the tip runs on for the forward loop's lag at the speed it
    /// had (`forward_lag_s`, 1.7 s), so the speed times that lag must stay within
    /// `station_overrun_m` (a validated rule): 1.0 m / 1.7 s = 0.59 m/s. Default 0.55 m/s.
    /// It was 1.5 m/s: the hold, asking about 1 m/s from the engage 6 m out, overshot to
    /// 1.36 m/s and ran 1.1 m through the station (`StationOverrun`). Measured on tuning runs
    /// 0..1,999 (1.5 → 0.55 m/s; sortie successes, `StationOverrun` breakaways): `level1`
    /// 1,973 → 1,993, 20 → 0; `level2` 1,964 → 1,988, 26 → 0; `envelope` 1,929 → 1,950,
    /// 22 → 0; `mil-level2` 1,570 → 1,659, 123 → 21; unsafe runs 8 → 7, 11 → 12, 49 → 50,
    /// 299 → 301; the mean time to dock unchanged (21.1 s in `level2`).
    pub station_max_speed_mps: f32,
    /// Stable at the station: radial offset of the drogue's mean position (its swing
    /// averaged, [`crate::estimator::DrogueEstimate::mean_offset_m`]) from the probe tip at
    /// most this, m.
    pub station_offset_tol_m: f32,
    /// Stable in rough air (the drogue's measured RMS speed above
    /// `rough_air_drogue_speed_mps`, judged on every frame at the station): the
    /// [`Self::station_offset_tol_m`] there, m. Default 0.30 m: in MIL-F-8785C's 10⁻² air
    /// the receiver and the drogue's mean position wander more than 0.15 m, the dwell was
    /// seldom met and sorties timed out at the station (1,000 `mil-level2` sorties:
    /// 92.9 % docked, `SortieTimeout` 31, at 0.15 m; 94.5 % at 0.20 m, 94.7 % at 0.25 m,
    /// 95.4 % and `SortieTimeout` 3 at 0.30 m; over 10,000 sorties 91.74 % → 94.76 %,
    /// `SortieTimeout` 412 → 26). The go/no-go gates, not the station, keep the approach
    /// safe: none of those sorties ended unsafe. Calm and level II air keep the tighter
    /// tolerance (the same 0.30 m everywhere: `level2` 994 of 1,000 docked at the first
    /// attempt against 996; `docs/scenarios.md`).
    pub rough_air_station_offset_tol_m: f32,
    /// Stable: depth within this of the station depth, m.
    pub station_depth_tol_m: f32,
    /// Stable: the drogue's estimated speed (right and down, radial) at most this, m/s.
    pub station_drogue_speed_tol_mps: f32,
    /// Stable: the probe tip's lateral speed relative to the tanker (radial) at most this:
    /// the receiver is not manoeuvring, m/s.
    pub station_relative_speed_tol_mps: f32,
    /// Stable for this long before the contact approach starts, s, counted in valid frames
    /// (a lost frame neither counts nor restarts the dwell).
    pub station_dwell_s: f32,
    /// Cleared to close only on a valid frame where the drogue itself (not its mean
    /// position) is at most this far from the probe tip (radial), once the dwell is
    /// complete, m. The station holds the drogue's mean position, and an approach cleared
    /// with the drogue half a swing away starts with an offset it must first catch up with:
    /// without this condition 12 of 1,000 level II approaches turned away as
    /// `OffsetTooLarge` at the first attempt, 9 of them within 0.3 s of the start. Default
    /// 0.35 m (measured before the swing feed-forward; 1,000 `level2` sorties: 957
    /// first-attempt dockings without it, 961 at 0.35 m,
    /// 965 at 0.25 m; 300 `mil-level2` sorties: 243 docked without it and at 0.35 m, 230 at
    /// 0.25 m and 212 at 0.15 m, the dwell's end waiting longer for the drogue in strong air:
    /// `docs/scenarios.md`). Below `abort_offset_m`.
    pub station_clear_offset_m: f32,
    /// Pre-contact: the estimated depth falling more than this inside the station (before
    /// the approach is cleared) breaks away (`StationOverrun`), m. The station's depth hold
    /// closes at most `station_max_speed_mps`; a receiver that runs through its station
    /// cannot slow down (a throttle fault, measured: a stuck throttle passed the drogue
    /// plane 1.5 m off the drogue, still pre-contact), and nobody cleared it to close.
    /// Default 1 m (the breakaway then starts 2 m out). Must leave the station outside the
    /// commit depth: `station_depth_m - station_overrun_m > commit_depth_m`.
    pub station_overrun_m: f32,
    /// Cartesian gain of the lateral and vertical tracking law, 1/s: well below the inner
    /// loops' bandwidth (their lateral velocity step rises in about 1.2 s).
    pub track_gain_per_s: f32,
    /// Largest lateral and vertical correction speed of the tracking law (beside the
    /// feed-forward of the drogue's velocity), m/s: a large offset is closed at this speed.
    pub max_correction_mps: f32,
    /// Largest change of the lateral and vertical desired velocity, m/s² (the forward
    /// axis slews at `velocity_limits.max_accel_mps2`): fast enough to follow the drogue's
    /// swing (its acceleration reaches about 0.6 m/s² RMS in the strongest campaign air).
    pub track_accel_mps2: f32,
    /// How far ahead the drogue's velocity is predicted for the feed-forward, s, along the
    /// hose's swing ([`crate::estimator::EstimatorConfig::drogue_swing_period_s`]): the inner
    /// loops' lag at the swing's frequency plus what the estimator's own lag takes back of
    /// the lead (about 0.4 s); at most 5 s, and at most a quarter swing. Default 0.95 s: the
    /// lateral loop's lag at the design condition grows with the airframe's mass (0.45 s at
    /// 0.85 of the design's, 0.51 s at 1.0, 1.04 s at 1.25), and 0.95 s lies between the
    /// lead that matches it on the design's airframe (0.92 s) and the longest the estimator
    /// carries (0.99 s at 3.9 s), which the heavier airframes need and more:
    /// `docs/conventions.md`, "Drogue estimator", and `host-sim/examples/feedforward_lead.rs`.
    pub feedforward_lead_s: f32,
    /// Fraction of the drogue's estimated velocity fed forward, 0..=1.
    pub feedforward_gain: f32,
    /// Closing speed of the contact approach and the capture, relative to the drogue, m/s:
    /// inside the 0.5..2.6 m/s (1 to 5 kt) band that opens the coupling.
    pub contact_speed_mps: f32,
    /// The drogue's RMS lateral speed (the estimator's measured activity, the larger of its
    /// right and down axes) above which an approach is flown in rough air: at the
    /// `rough_air_contact_speed_mps`, decided when the approach starts and kept to its end,
    /// m/s. Default 0.2 m/s: the simulated hose swings at about 0.175 m/s per m/s of RMS
    /// gust, so level II air (0.56..0.84 m/s) drives it at 0.10..0.15 m/s and
    /// MIL-F-8785C's 10⁻² air at 3,000 m (1.47..2.21 m/s) at 0.26..0.39 m/s.
    pub rough_air_drogue_speed_mps: f32,
    /// Closing speed of the contact approach and the capture in rough air, m/s. Default
    /// 1.0 m/s, the calm air's. It was 1.3 m/s (in MIL-F-8785C's 10⁻² air the drogue moves
    /// less in the shorter capture: 300 sorties, 76.7 % docked at 1.0 m/s, 80.3 % at
    /// 1.3 m/s); but the receiver must be able to stop short of the plane at the gate
    /// ([`commit_depth`]), and from 1.3 m/s it needs 3.06 m against 2.2 m from 1.0 m/s:
    /// the gate would then sit inside the station's overrun limit (`station_depth_m -
    /// station_overrun_m`, 2.6 m), where no approach has been cleared yet.
    pub rough_air_contact_speed_mps: f32,
    /// In the contact approach, a drogue offset beyond this (radial) is a no-go at once, m.
    pub abort_offset_m: f32,
    /// The least depth at which the receiver commits: the go/no-go gate, and the start of
    /// the capture phase (the tip camera goes blind inside about 0.7 m), m. The gate is
    /// taken at [`commit_depth`]: this, or where the receiver can still stop short of the
    /// drogue plane at the approach's closing speed, whichever is deeper.
    pub commit_depth_m: f32,
    /// How late the probe tip's forward velocity follows a deceleration command, s: the
    /// stopping distance's first term ([`stopping_distance_m`]). Default 1.7 s, measured on
    /// the design plant: a no-go from 1.06 m/s in calm air, the command slewed down at
    /// `missed_accel_mps2` (1 m/s²), stopped the tip 1.79 m later; in level II air, from
    /// 0.92 m/s with the receiver still gathering speed, 1.99 m (`(1.99 − 0.92² / 2) /
    /// 0.92`). The throttle's idle and the engine's spool-down, not the slew, take most of
    /// it: a slew of 2 or 3 m/s² shortened the stop by 0.07 m and 0.15 m only.
    pub forward_lag_s: f32,
    /// The receiver must be able to stop this far short of the drogue plane when it turns
    /// away at the gate, m: the estimated depth's error at 2 m (a few centimetres) and the
    /// slower deceleration of a heavier or draggier airframe than the design's (mass up to
    /// 1.3 times: the stop grows by up to about 0.25 m at 1 m/s). Default 0.3 m.
    pub stop_clearance_m: f32,
    /// Go: the predicted radial offset at the drogue plane plus `gate_sigmas` standard
    /// deviations is at most this, m.
    pub gate_radius_m: f32,
    /// Standard deviations of the prediction added to its mean by the gates. Default 1 (it
    /// was 2, which turned away most approaches in strong air that would have docked:
    /// MIL-F-8785C 10⁻² air, 1,000 sorties, 58 % → 71 % docked, none unsafe; the late gate's
    /// taper to `late_gate_final_radius_m` keeps the plane safe; `docs/conventions.md`).
    pub gate_sigmas: f32,
    /// In the capture, on every valid frame: the same prediction beyond this is a late
    /// no-go, m. Default 0.50 m, the final radius's 0.40 m plus 0.1 m tapered over
    /// `late_gate_taper_m` (the prediction's error grows with the time to go). It was
    /// 0.40 m: `late_gate_final_radius_m` says why it moved.
    pub late_gate_radius_m: f32,
    /// The late no-go's radius at the drogue plane, m: the late gate's radius falls from
    /// `late_gate_radius_m` at `late_gate_taper_m` (and more) of estimated depth to this at
    /// the plane, linearly. Default 0.40 m: the radius within which a crossing strikes the
    /// basket (the canopy's 0.305 m plus the probe head's 0.05 m) plus 5 cm of the
    /// prediction's error. Why: the late gate's window (`late_gate_depth_m` 1.3 m to
    /// `late_gate_min_depth_m` 0.6 m) lies inside the stopping distance (1.7 m at 1 m/s
    /// over the forward loop's lag, `forward_lag_s`), so a late no-go cannot stop short of
    /// the plane; it changes only how the tip crosses it: it stops steering at the drogue
    /// and descends. A miss predicted inside the strike radius is better left to the
    /// capture, which keeps steering at the centre (it docks or crosses near it); turned
    /// away, the tip crossed in the basket's ring (tuning runs 0..9,999 of `level2`: 13 of
    /// 15 basket strikes followed a no-go taken inside 1.3 m, 12 of them the late gate's).
    /// A miss predicted beyond it is
    /// a crossing outside the basket, where the turn away's descent keeps the drogue off
    /// the airframe and the hose. Measured on tuning runs (success, unsafe runs; radii far /
    /// at the plane): `level2` 0..9,999, 0.40 / 0.25 m: 9,976, 24 (basket strikes 15);
    /// 0.50 / 0.40 m: 9,986, 14 (5); 0.60 / 0.50 m: 9,985, 15; no late gate: 9,986, 14.
    /// `mil-level2` 0..1,999: 1,672, 279; 1,716, 247 (drogue on the airframe 2 → 5, hose
    /// contacts 72 → 86, hard contacts 69 → 45); 1,710, 258 (airframe 17, hose 112); no late
    /// gate 1,679, 287 (airframe 33, hose 153). It was 0.25 m, inside the capture radius,
    /// when the late no-go was taken to stop short of the plane.
    pub late_gate_final_radius_m: f32,
    /// Depth inside which the capture judges its late no-go and its closing speed, m:
    /// farther out the capture still has more than its lag to correct, and the gate's
    /// half-second prediction is not the miss at the plane. Default 1.3 m: chosen with
    /// `late_gate_min_depth_m` on tuning runs 0..1,999 of `level2` with the gate at 1.96 m
    /// (successes / basket strikes: the whole capture from the gate to the plane, 1,508 /
    /// 13; 0..1.0 m, 1,656 / 53; 0.5..1.0 m, 1,658 / 49; 0.6..1.3 m, 1,646 / 19;
    /// 0.8..1.5 m, 1,636 / 16; 0.4..1.96 m, 1,576 / 14). With the gate at 2.5 m (the
    /// defaults), the same runs: 1,649 successes and 75 unsafe runs, against 1,724 and 75
    /// with no late gate at all (the capture always pushing on: its near misses, 0.30 to
    /// 0.355 m off, become strikes and passes by the hose); `mil-level2`, 1,159 / 489
    /// against 1,228 / 502.
    pub late_gate_depth_m: f32,
    /// Depth inside which the capture no longer turns away, m: a turn away needs time to
    /// act (the tip's velocity follows a command about 0.6 s late, 0.6 m at the contact
    /// speed), and closer in it only spoils a contact the capture may still make
    /// (measured: late no-gos inside 1 m crossed the plane 0.30 to 0.35 m off, between the
    /// capture radius and the canopy's, still closing at the contact speed). Default 0.6 m
    /// (with `late_gate_depth_m`): the late gate's taper below
    /// `late_gate_taper_m` then no longer acts.
    pub late_gate_min_depth_m: f32,
    /// Depth inside which the late gate's radius tapers to `late_gate_final_radius_m`, m:
    /// about the inner loops' lateral lag (0.5 s) at the contact speed.
    pub late_gate_taper_m: f32,
    /// Longest prediction horizon of the gates, s (at most 1.5 times the estimator's drogue
    /// time constant, where its variance series is accurate). Default 0.5 s, the inner
    /// loops' lateral lag: the gates predict the offset over the part of the time to go the
    /// capture cannot correct, not over the whole of it with no correction (1.2 s, the
    /// earlier default: measured over 1,000 level II sorties, 98.7 % docked, 70.3 % at the
    /// first attempt; at 0.5 s 99.9 % and 87 %, no unsafe end state, the late gate's taper
    /// the backstop; `docs/scenarios.md`).
    pub gate_max_horizon_s: f32,
    /// Longest capture phase, s. Default 5 s: from the gate (2.5 m at the 1 m/s contact
    /// speed) at the capture's least closing speed (`capture_min_closing_mps`, 0.65 m/s),
    /// 3.8 s, and a margin; it was 3 s while the gate was at 1 m.
    pub capture_timeout_s: f32,
    /// The capture's lateral and vertical gain is `1 / time to go`, the time to go taken
    /// as at least this (the inner loops' lag: a shorter one would only excite them), s.
    pub capture_min_time_to_go_s: f32,
    /// In the capture, on every valid frame: an estimated closing speed below this is a
    /// no-go (`ClosingTooSlow`), m/s. A contact below the coupling's 0.5 m/s does not latch,
    /// and pushed through it is a strike by the campaigns' definition. Default 0.65 m/s: the
    /// band's edge plus the closing estimate's error (about 0.05 m/s) and what the closure
    /// lost in the last tenth of a second in the one sortie that crossed below the band
    /// (MIL-F-8785C 10⁻² air, 10,000 sorties: 0.497 m/s at 0.08 m from the centre, the tip's
    /// forward velocity falling behind its command while it followed the drogue down at
    /// 1 m/s; the slowest docking of those sorties closed at 0.64 m/s, two below 0.7 m/s).
    pub capture_min_closing_mps: f32,
    /// Estimated depth below minus this in the capture: the probe passed the plane, a miss, m.
    pub overshoot_m: f32,
    /// Missed approach: speed aft relative to the drogue, m/s.
    pub missed_aft_mps: f32,
    /// Missed approach: speed down while clearing, m/s.
    pub missed_down_mps: f32,
    /// Missed approach: how long it backs off and descends before returning to the station, s.
    pub missed_clear_s: f32,
    /// Missed approach: largest change of the desired velocity, m/s², each axis. Default
    /// 1 m/s²: it stops a 1 m/s approach in about a metre. The breakaway's 2 m/s² with its
    /// 1.5 m/s aft and 1 m/s down drove the throttle to idle and the elevator to its stops
    /// and lost the receiver in the strongest campaign air (measured).
    pub missed_accel_mps2: f32,
    /// Missed approach: how long the measurement may be invalid (the drogue out of view
    /// while clearing), s; longer is a breakaway (`MeasurementLost`). Default 5 s: a missed
    /// approach that passes the drogue plane loses the drogue from view while it backs off
    /// and returns behind it, for up to 3.48 s in the sorties measured
    /// (MIL-F-8785C 10⁻² air); with the earlier 3 s, 1.2 % of those sorties broke away
    /// there (`MeasurementLost`; 0.04 % with 5 s). The receiver flies the estimate back
    /// towards the station meanwhile, and no approach starts without valid frames
    /// (`docs/scenarios.md`).
    pub reacquire_limit_s: f32,
    /// Approaches allowed in one sortie; a no-go after the last is the end of the sortie
    /// (breakaway, `AttemptsExhausted`).
    pub max_attempts: u8,
    /// Time from engage after which no new approach starts and the sortie ends (breakaway,
    /// `SortieTimeout`), s.
    pub sortie_budget_s: f32,
}

impl Default for RefuellingConfig {
    fn default() -> Self {
        Self {
            station_depth_m: 3.6,
            station_gain_per_s: 0.4,
            station_max_speed_mps: 0.55,
            station_integral_gain_per_s2: 0.01,
            station_max_integral_mps: 0.2,
            station_offset_tol_m: 0.15,
            rough_air_station_offset_tol_m: 0.30,
            station_depth_tol_m: 0.3,
            station_drogue_speed_tol_mps: 0.5,
            station_relative_speed_tol_mps: 0.3,
            station_dwell_s: 1.0,
            station_clear_offset_m: 0.35,
            station_overrun_m: 1.0,
            track_gain_per_s: 0.5,
            max_correction_mps: 0.5,
            track_accel_mps2: 1.0,
            feedforward_lead_s: 0.95,
            feedforward_gain: 1.0,
            contact_speed_mps: 1.0,
            rough_air_drogue_speed_mps: 0.2,
            rough_air_contact_speed_mps: 1.0,
            abort_offset_m: 0.6,
            commit_depth_m: 1.0,
            forward_lag_s: 1.7,
            stop_clearance_m: 0.3,
            gate_radius_m: 0.45,
            gate_sigmas: 1.0,
            late_gate_radius_m: 0.50,
            late_gate_final_radius_m: 0.40,
            late_gate_depth_m: 1.3,
            late_gate_min_depth_m: 0.6,
            late_gate_taper_m: 0.5,
            gate_max_horizon_s: 0.5,
            capture_timeout_s: 5.0,
            capture_min_time_to_go_s: 0.4,
            capture_min_closing_mps: 0.65,
            overshoot_m: 0.3,
            missed_aft_mps: 1.0,
            missed_down_mps: 0.5,
            missed_clear_s: 2.0,
            missed_accel_mps2: 1.0,
            reacquire_limit_s: 5.0,
            max_attempts: 4,
            sortie_budget_s: 150.0,
        }
    }
}

/// The air is rough: the drogue's measured RMS lateral speed `drogue_rms_mps`
/// ([`crate::estimator::DrogueEstimator::drogue_speed_rms_mps`]) is above
/// `rough_air_drogue_speed_mps`. It picks the approach's closing speed
/// ([`contact_speed`]) and the station's offset tolerance (`crate::mode`).
#[inline(always)]
pub fn rough_air(drogue_rms_mps: f32, cfg: &RefuellingConfig) -> bool {
    drogue_rms_mps > cfg.rough_air_drogue_speed_mps
}

/// The closing speed of an approach that starts with the drogue's measured RMS lateral
/// speed `drogue_rms_mps`: the rough-air variant in [`rough_air`], else
/// `contact_speed_mps`, m/s.
pub fn contact_speed(drogue_rms_mps: f32, cfg: &RefuellingConfig) -> f32 {
    if rough_air(drogue_rms_mps, cfg) {
        cfg.rough_air_contact_speed_mps
    } else {
        cfg.contact_speed_mps
    }
}

/// The distance the probe tip runs on towards the drogue after a no-go from the closing
/// speed `closing_mps`: the forward loop's lag at that speed, then the missed approach's
/// deceleration (`closing_mps · forward_lag_s + closing_mps² / (2 · missed_accel_mps2)`), m.
#[inline(always)]
pub fn stopping_distance_m(closing_mps: f32, cfg: &RefuellingConfig) -> f32 {
    closing_mps * cfg.forward_lag_s + closing_mps * closing_mps / (2.0 * cfg.missed_accel_mps2)
}

/// The depth of the go/no-go gate for an approach closing at `contact_mps`: where a no-go
/// still stops `stop_clearance_m` short of the drogue plane ([`stopping_distance_m`]), or
/// `commit_depth_m` if that is deeper, m. Inside it the capture may only go on, or back
/// straight out and down ([`Forward::Clear`]).
#[inline(always)]
pub fn commit_depth(contact_mps: f32, cfg: &RefuellingConfig) -> f32 {
    max_to(
        cfg.commit_depth_m,
        stopping_distance_m(contact_mps, cfg) + cfg.stop_clearance_m,
    )
}

/// What the forward axis does in a mode of the procedure.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Forward {
    /// Hold the pre-contact station's depth.
    Station,
    /// Close at the contact speed.
    Contact,
    /// Close at the contact speed and steer the offset out by contact: the lateral and
    /// vertical gain rises to `1 / time to go` (at most `1 / capture_min_time_to_go_s`).
    Capture,
    /// Back off at the missed approach's speed, straight back along the approach line (no
    /// lateral chase of the drogue), descending at `missed_down_mps` if `descend` (the
    /// clearing time).
    Clear {
        /// Descend at `missed_down_mps`.
        descend: bool,
    },
}

/// The desired velocity of the probe tip relative to the tanker (`re` axes) for the
/// estimate `e`, the lateral and vertical feed-forward `feedforward_mps` (`[right, down]`:
/// closing on the drogue, its velocity predicted `feedforward_lead_s` ahead, taken at
/// `feedforward_gain`; holding the station, the station's integral, taken whole; clearing,
/// unused), the forward mode `fwd` and the approach's closing speed
/// `contact_mps` (`contact_speed_mps`, or `rough_air_contact_speed_mps` in rough air:
/// [`contact_speed`]), saturated to the velocity limits.
#[inline(always)]
pub fn desired_velocity(
    e: &DrogueEstimate,
    feedforward_mps: [f32; 2],
    fwd: Forward,
    contact_mps: f32,
    cfg: &RefuellingConfig,
    lim: &VelocityLimits,
) -> VelocityRe {
    let k = match fwd {
        // Time to go at the contact speed; the gain that removes the offset by contact.
        Forward::Capture => {
            let t_go = max_to(e.depth_m, 0.0) / contact_mps;
            max_to(
                cfg.track_gain_per_s,
                1.0 / max_to(t_go, cfg.capture_min_time_to_go_s),
            )
        }
        _ => cfg.track_gain_per_s,
    };
    // Closing on the drogue, its own forward velocity is added to the tip's command. Holding
    // the station or clearing, it is not: the drogue's mean forward velocity relative to the
    // tanker is zero, and its fore-and-aft swing in strong air (±0.3 m/s at the hose's 3.5 s
    // period) fed forward through the forward channel's second of lag drove the depth hold
    // into a ±0.8 m oscillation that ran through the station (`StationOverrun`, measured in
    // MIL-F-8785C 10⁻² air; `docs/scenarios.md`).
    let drogue_fwd = match fwd {
        Forward::Contact | Forward::Capture => e.drogue_velocity_mps[2],
        Forward::Station | Forward::Clear { .. } => 0.0,
    };
    let (fwd_mps, down_bias) = match fwd {
        Forward::Station => {
            let v = cfg.station_gain_per_s * (e.depth_m - cfg.station_depth_m);
            (clamp_sym(v, cfg.station_max_speed_mps), 0.0)
        }
        Forward::Contact | Forward::Capture => (contact_mps, 0.0),
        Forward::Clear { descend } => (
            -cfg.missed_aft_mps,
            if descend { cfg.missed_down_mps } else { 0.0 },
        ),
    };
    // Holding the station, the receiver follows the drogue's mean position (its swing
    // averaged out) without its velocity: chasing the swing of a drogue in strong air drove
    // the elevator into its stops and the receiver out of control (measured, the strongest
    // campaign); the station adds its integral (the navigation's velocity bias). Closing on
    // it, it follows the drogue itself. Clearing, it follows nothing: it backs straight out
    // (steering towards the drogue's mean position on an estimate coasted out of view put
    // the probe through the basket while backing off, measured).
    let (offset, ff, k) = match fwd {
        Forward::Station => (e.mean_offset_m, 1.0, k),
        Forward::Clear { .. } => ([0.0; 2], 0.0, 0.0),
        Forward::Contact | Forward::Capture => (e.offset_m, cfg.feedforward_gain, k),
    };
    let c = cfg.max_correction_mps;
    VelocityRe {
        x_right_mps: clamp_sym(
            ff * feedforward_mps[0] + clamp_sym(k * offset[0], c),
            lim.max_lateral_mps,
        ),
        y_down_mps: clamp_sym(
            ff * feedforward_mps[1] + clamp_sym(k * offset[1], c) + down_bias,
            lim.max_vertical_mps,
        ),
        z_fwd_mps: min_to(
            max_to(drogue_fwd + fwd_mps, -lim.max_closing_mps),
            lim.max_closing_mps,
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A drogue 3.5 m ahead (0.5 m behind the station's 3 m), swinging forward at 0.3 m/s.
    fn swinging_forward() -> DrogueEstimate {
        DrogueEstimate {
            offset_m: [0.1, -0.1],
            mean_offset_m: [0.0, 0.0],
            drogue_velocity_mps: [0.0, 0.0, 0.3],
            depth_m: 3.5,
        }
    }

    #[test]
    fn the_station_and_the_missed_approach_ignore_the_drogues_forward_swing() {
        let (cfg, lim) = (
            RefuellingConfig::default(),
            crate::ControllerConfig::default().velocity_limits,
        );
        let e = swinging_forward();
        let fwd = |f| desired_velocity(&e, [0.0, 0.0], f, 1.0, &cfg, &lim).z_fwd_mps;
        // Holding the station: the depth hold alone, 0.4/s x 0.5 m.
        let station = cfg.station_gain_per_s * (e.depth_m - cfg.station_depth_m);
        assert!((fwd(Forward::Station) - station).abs() < 1e-6);
        // Clearing: the back-off alone.
        assert!((fwd(Forward::Clear { descend: true }) + cfg.missed_aft_mps).abs() < 1e-6);
        // Closing on it: the drogue's forward velocity is added to the contact speed.
        for f in [Forward::Contact, Forward::Capture] {
            assert!((fwd(f) - (1.0 + 0.3)).abs() < 1e-6);
        }
    }

    #[test]
    fn rough_air_is_flown_at_its_own_contact_speed() {
        let cfg = RefuellingConfig::default();
        let rough = cfg.rough_air_drogue_speed_mps;
        assert_eq!(contact_speed(0.0, &cfg), cfg.contact_speed_mps);
        assert_eq!(contact_speed(rough, &cfg), cfg.contact_speed_mps);
        assert_eq!(
            contact_speed(rough + 0.01, &cfg),
            cfg.rough_air_contact_speed_mps
        );
        // The approach closes at the speed it is given, and the capture steers by it.
        let e = DrogueEstimate {
            offset_m: [0.1, 0.0],
            depth_m: 0.5,
            ..swinging_forward()
        };
        let lim = crate::ControllerConfig::default().velocity_limits;
        let v = |f, c| desired_velocity(&e, [0.0, 0.0], f, c, &cfg, &lim);
        assert!((v(Forward::Contact, 1.3).z_fwd_mps - 1.6).abs() < 1e-6);
        // Capture: gain 1 / max(t_go, 0.4 s); t_go 0.5 s at 1.0 m/s, 0.385 s at 1.3 m/s.
        assert!((v(Forward::Capture, 1.0).x_right_mps - 0.1 / 0.5).abs() < 1e-6);
        assert!((v(Forward::Capture, 1.3).x_right_mps - 0.1 / 0.4).abs() < 1e-6);
    }
}
