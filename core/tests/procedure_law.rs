//! The refuelling procedure's law (`ibvs_core::procedure::desired_velocity`), mode by mode,
//! against its statement in the module doc and `docs/conventions.md`, "The refuelling
//! procedure": lateral and vertical `v = ff v_ahead + clamp(k r, ±max_correction)` (the
//! drogue's predicted velocity fed forward while closing, the station's integral while
//! holding it, nothing while clearing; the instantaneous offset closing, the mean offset
//! holding the station or clearing), `k` the tracking gain or, in the
//! capture, `max(k, 1 / max(t_go, t_min))` with `t_go = depth / contact speed`; forward: the
//! contact speed relative to the drogue's own forward velocity while closing, and relative to
//! the tanker (the drogue's fore-and-aft swing left out) the station's depth hold
//! `clamp(k_s (depth - station), ±v_s)` or the missed approach's back-off (with its descent
//! added to the vertical); everything saturated to the velocity limits.
//!
//! Every expected value is computed by hand from those equations and the defaults of
//! `RefuellingConfig` (track gain 0.5/s, correction at most 0.5 m/s, station 3.6 m at 0.4/s
//! within 0.55 m/s, contact 1 m/s, capture time to go at least 0.4 s, missed approach 1 m/s
//! aft and 0.5 m/s down) and `ControllerConfig`'s velocity limits (2 m/s each axis).

use ibvs_core::ControllerConfig;
use ibvs_core::estimator::DrogueEstimate;
use ibvs_core::frames::VelocityRe;
use ibvs_core::outer::VelocityLimits;
use ibvs_core::procedure::{self, Forward, RefuellingConfig, desired_velocity};

fn limits() -> VelocityLimits {
    ControllerConfig::default().velocity_limits
}

/// An estimate: instantaneous offset `offset`, mean offset `mean`, the drogue's forward
/// velocity `drogue_fwd_mps`, at `depth_m`.
fn estimate(offset: [f32; 2], mean: [f32; 2], drogue_fwd_mps: f32, depth_m: f32) -> DrogueEstimate {
    DrogueEstimate {
        offset_m: offset,
        mean_offset_m: mean,
        drogue_velocity_mps: [0.7, -0.7, drogue_fwd_mps],
        depth_m,
    }
}

fn assert_velocity(got: VelocityRe, want: [f32; 3], what: &str) {
    let g = [got.x_right_mps, got.y_down_mps, got.z_fwd_mps];
    for (axis, (g, w)) in g.iter().zip(want).enumerate() {
        assert!(
            (g - w).abs() < 1e-5,
            "{what}: axis {axis}: {g} vs {w} ({got:?})"
        );
    }
}

#[test]
fn the_station_holds_depth_and_follows_the_mean_offset_plus_its_integral() {
    let (rc, lim) = (RefuellingConfig::default(), limits());
    // The instantaneous offset, the drogue's velocity and its forward swing must not enter:
    // only the mean offset, the station's integral (given whole, whatever the
    // feed-forward gain) and the depth.
    let e = |behind: f32| estimate([1.0, 1.0], [0.2, -0.4], 0.1, rc.station_depth_m + behind);
    let integral = [0.03, 0.05];
    let c = rc.contact_speed_mps;
    let half = RefuellingConfig {
        feedforward_gain: 0.5,
        ..rc
    };
    // 1 m behind the station: close at 0.4 m/s; right 0.03 + 0.5 * 0.2, up 0.05 - 0.5 * 0.4.
    let v = desired_velocity(&e(1.0), integral, Forward::Station, c, &half, &lim);
    assert_velocity(v, [0.13, -0.15, 0.4], "1 m behind");
    // 1 m inside the station: open at 0.4 m/s.
    let v = desired_velocity(&e(-1.0), integral, Forward::Station, c, &rc, &lim);
    assert_velocity(v, [0.13, -0.15, -0.4], "1 m inside");
    // 7 m behind: 2.8 m/s limited to the station's 0.55 m/s.
    let v = desired_velocity(&e(7.0), integral, Forward::Station, c, &rc, &lim);
    assert_velocity(v, [0.13, -0.15, 0.55], "far behind");
    // A large mean offset is closed at the correction limit, 0.5 m/s, beside the integral.
    let far_off = estimate([0.0, 0.0], [-3.0, 2.0], 0.0, rc.station_depth_m);
    let v = desired_velocity(&far_off, integral, Forward::Station, c, &rc, &lim);
    assert_velocity(v, [-0.47, 0.55, 0.0], "far off the axis, on station");
}

#[test]
fn the_contact_approach_closes_at_the_contact_speed_on_the_offset_with_feed_forward() {
    let (rc, lim) = (RefuellingConfig::default(), limits());
    // Offset right 0.4 (0.2 m/s), 2 m up (limited to 0.5 m/s up); the drogue predicted to
    // move 0.3 right and 0.1 up; its forward speed 0.1 adds to the 1 m/s contact speed. The
    // mean offset must not enter.
    let e = estimate([0.4, -2.0], [5.0, 5.0], 0.1, 2.0);
    let v = desired_velocity(&e, [0.3, -0.1], Forward::Contact, 1.0, &rc, &lim);
    assert_velocity(v, [0.5, -0.6, 1.1], "contact");
    // The rough-air contact speed, 1.3 m/s, is the one given.
    let v = desired_velocity(&e, [0.3, -0.1], Forward::Contact, 1.3, &rc, &lim);
    assert_velocity(v, [0.5, -0.6, 1.4], "contact, rough air");
    // Half the feed-forward: 0.15 right, 0.05 up from the prediction.
    let half = RefuellingConfig {
        feedforward_gain: 0.5,
        ..rc
    };
    let v = desired_velocity(&e, [0.3, -0.1], Forward::Contact, 1.0, &half, &lim);
    assert_velocity(v, [0.35, -0.55, 1.1], "half feed-forward");
}

#[test]
fn the_capture_gain_rises_to_one_over_the_time_to_go_within_its_floor() {
    // Contact speed 0.8 m/s so that depth / speed differs from depth * speed.
    let rc = RefuellingConfig {
        contact_speed_mps: 0.8,
        ..RefuellingConfig::default()
    };
    let lim = limits();
    let offset = [0.2, -0.1];
    let capture = |depth: f32| {
        desired_velocity(
            &estimate(offset, [0.0; 2], 0.0, depth),
            [0.0; 2],
            Forward::Capture,
            0.8,
            &rc,
            &lim,
        )
    };
    // 0.8 m at 0.8 m/s: t_go 1 s, gain 1/s (above the tracking gain's 0.5).
    assert_velocity(capture(0.8), [0.2, -0.1, 0.8], "t_go 1 s");
    // 0.4 m: t_go 0.5 s, gain 2/s.
    assert_velocity(capture(0.4), [0.4, -0.2, 0.8], "t_go 0.5 s");
    // 0.16 m: t_go 0.2 s, below the 0.4 s floor: gain 2.5/s, 0.5 m/s right (the limit).
    assert_velocity(capture(0.16), [0.5, -0.25, 0.8], "t_go floored");
    // Past the plane: the time to go is zero, floored: still 2.5/s.
    assert_velocity(capture(-0.1), [0.5, -0.25, 0.8], "past the plane");
    // 4 m: t_go 5 s, 0.2/s is below the tracking gain: 0.5/s.
    assert_velocity(capture(4.0), [0.1, -0.05, 0.8], "far: the tracking gain");
    // The contact approach at the same 0.4 m keeps the tracking gain.
    let v = desired_velocity(
        &estimate(offset, [0.0; 2], 0.0, 0.4),
        [0.0; 2],
        Forward::Contact,
        0.8,
        &rc,
        &lim,
    );
    assert_velocity(v, [0.1, -0.05, 0.8], "contact at 0.4 m");
}

#[test]
fn the_missed_approach_backs_straight_out_and_descends_whatever_the_drogue_does() {
    let (rc, lim) = (RefuellingConfig::default(), limits());
    // 1 m/s aft relative to the tanker (the drogue's 0.2 m/s forward left out); 0.5 m/s
    // down; neither the mean offset nor the feed-forward steers it: no chase of the drogue.
    let e = estimate([1.0, 1.0], [-0.2, 0.4], 0.2, 2.0);
    let clear = |descend| Forward::Clear { descend };
    let v = desired_velocity(&e, [0.3, 0.3], clear(true), 1.0, &rc, &lim);
    assert_velocity(v, [0.0, 0.5, -1.0], "clear");
    // After the clearing time, still inside the plane's margin: straight back, level.
    let v = desired_velocity(&e, [0.3, 0.3], clear(false), 1.0, &rc, &lim);
    assert_velocity(v, [0.0, 0.0, -1.0], "clear, level");
}

#[test]
fn the_gate_lies_where_a_no_go_still_stops_short_of_the_plane() {
    let rc = RefuellingConfig::default();
    // From 1 m/s: 1 m/s x 1.7 s of lag, then 1 m/s / (2 x 1 m/s^2): 2.2 m; 0.3 m clear.
    let d = procedure::stopping_distance_m(1.0, &rc);
    assert!((d - 2.2).abs() < 1e-5, "{d}");
    assert!((procedure::commit_depth(1.0, &rc) - 2.5).abs() < 1e-5);
    // Slowly, the configured least depth governs.
    let slow = procedure::commit_depth(0.1, &rc);
    assert!((slow - rc.commit_depth_m).abs() < 1e-6, "{slow}");
    // A faster approach commits farther out: quadratically.
    assert!(procedure::commit_depth(1.3, &rc) > 3.3);
}

#[test]
fn every_axis_is_saturated_to_the_velocity_limits() {
    let (rc, lim) = (RefuellingConfig::default(), limits());
    // A drogue predicted to move 3 m/s right and 3 m/s up, and surging 1.5 m/s forward on
    // top of the 1 m/s contact speed: each axis at its 2 m/s limit.
    let e = estimate([0.0; 2], [0.0; 2], 1.5, 10.0);
    let v = desired_velocity(&e, [3.0, -3.0], Forward::Contact, 1.0, &rc, &lim);
    assert_velocity(v, [2.0, -2.0, 2.0], "contact, saturated");
    // On station the surge is left out: the station's own 0.55 m/s; an integral of 3 m/s
    // (beyond any configured limit) is saturated too.
    let v = desired_velocity(&e, [3.0, -3.0], Forward::Station, 1.0, &rc, &lim);
    assert_velocity(v, [2.0, -2.0, 0.55], "station, its own limit");
    // Clearing at a configured 3 m/s aft: limited to -2.
    let fast = RefuellingConfig {
        missed_aft_mps: 3.0,
        ..rc
    };
    let clear = Forward::Clear { descend: true };
    let v = desired_velocity(&e, [0.0; 2], clear, 1.0, &fast, &lim);
    assert_velocity(v, [0.0, 0.5, -2.0], "clear, saturated aft");
}
