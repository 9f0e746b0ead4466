//! The navigation sample's two checks (`ibvs_core::nav`): `NavSample::check`, the step's
//! branch-free test on the envelope's bit patterns, gives the same answer as
//! `NavSample::validate` for every sample (its doc); and the rules themselves, from the
//! module doc and `docs/conventions.md`, "Input validation and responses": a NaN or
//! infinite state or flight condition is `NonFinite` (before anything else), a state beyond
//! its limit `OutsideEnvelope`, a state exactly on it accepted; only positive finite limits
//! make an `EnvelopeBits`.
//!
//! And the named errors of the navigation check and the gain schedule say what went wrong in
//! their messages (what a ground station or a log shows): each message is its own and names
//! the quantity and the direction its variant's doc states.

use ibvs_core::nav::{EnvelopeBits, NavEnvelope, NavError, NavSample};
use ibvs_core::schedule::ScheduleError;

/// The fourteen quantities a sample carries: the twelve states, then the condition's.
fn with(values: &[(usize, f32)]) -> NavSample {
    let mut a = [0.0_f32; 12];
    let mut s = NavSample::default();
    for &(k, v) in values {
        match k {
            0..=11 => a[k] = v,
            12 => s.condition.true_airspeed_mps = v,
            _ => s.condition.altitude_m = v,
        }
    }
    NavSample {
        condition: s.condition,
        ..NavSample::from_array(a)
    }
}

/// The envelope limit of each state (`NavEnvelope`'s documented grouping), `None` for the
/// positions and the condition, which have none.
fn limit(env: &NavEnvelope, k: usize) -> Option<f32> {
    match k {
        2 | 4 | 7 => Some(env.max_angle_rad),    // theta, alpha, psi
        3 => Some(env.max_speed_mps),            // V
        5 | 10 | 11 => Some(env.max_rate_radps), // q, p, r
        8 => Some(env.max_bank_rad),             // phi
        9 => Some(env.max_sideslip_rad),         // beta
        _ => None,                               // x, h, y; airspeed, altitude
    }
}

#[test]
fn two_bad_quantities_at_once_are_rejected_by_both_checks_alike() {
    // The bit check ORs one term per quantity: two bad ones together must not cancel.
    let env = NavEnvelope::default();
    let bits = EnvelopeBits::new(&env).expect("valid envelope");
    let bad = |k: usize, which: usize| -> f32 {
        match (which, limit(&env, k)) {
            (0, _) => f32::NAN,
            (1, _) => f32::INFINITY,
            (2, _) => f32::NEG_INFINITY,
            (_, Some(l)) => -l.next_up(), // just beyond the limit
            (_, None) => f32::NAN,
        }
    };
    for i in 0..14 {
        for j in i + 1..14 {
            for wi in 0..4 {
                for wj in 0..4 {
                    let s = with(&[(i, bad(i, wi)), (j, bad(j, wj))]);
                    let non_finite = !bad(i, wi).is_finite() || !bad(j, wj).is_finite();
                    let want = Err(if non_finite {
                        NavError::NonFinite
                    } else {
                        NavError::OutsideEnvelope
                    });
                    assert_eq!(s.validate(&env), want, "quantities {i} and {j}");
                    assert_eq!(s.check(&bits), want, "quantities {i} and {j}");
                }
            }
        }
    }
}

#[test]
fn every_state_is_accepted_on_its_limit_and_refused_just_beyond_either_sign() {
    let env = NavEnvelope::default();
    let bits = EnvelopeBits::new(&env).expect("valid envelope");
    for k in 0..12 {
        let Some(l) = limit(&env, k) else {
            // Positions are not limited: any finite value passes.
            let s = with(&[(k, -1e30)]);
            assert_eq!((s.validate(&env), s.check(&bits)), (Ok(()), Ok(())), "{k}");
            continue;
        };
        for sign in [1.0_f32, -1.0] {
            let on = with(&[(k, sign * l)]);
            assert_eq!(
                (on.validate(&env), on.check(&bits)),
                (Ok(()), Ok(())),
                "{k}"
            );
            let beyond = with(&[(k, sign * l.next_up())]);
            let want = Err(NavError::OutsideEnvelope);
            assert_eq!(
                (beyond.validate(&env), beyond.check(&bits)),
                (want, want),
                "{k}"
            );
        }
    }
}

#[test]
fn only_positive_finite_limits_make_envelope_bits() {
    let env = NavEnvelope::default();
    assert!(EnvelopeBits::new(&env).is_some());
    for bad in [0.0, -0.0, -1.0, f32::INFINITY, f32::NAN] {
        for k in 0..5 {
            let mut e = env;
            match k {
                0 => e.max_angle_rad = bad,
                1 => e.max_bank_rad = bad,
                2 => e.max_sideslip_rad = bad,
                3 => e.max_speed_mps = bad,
                _ => e.max_rate_radps = bad,
            }
            assert_eq!(EnvelopeBits::new(&e), None, "limit {k} = {bad}");
        }
    }
    // The smallest positive limit is a limit.
    let tiny = NavEnvelope {
        max_rate_radps: f32::from_bits(1),
        ..env
    };
    assert!(EnvelopeBits::new(&tiny).is_some());
}

fn assert_distinct(texts: &[String]) {
    for (i, t) in texts.iter().enumerate() {
        assert!(!t.is_empty(), "message {i} is empty");
        assert_eq!(
            texts.iter().filter(|u| *u == t).count(),
            1,
            "{t:?} is not unique"
        );
    }
}

#[test]
fn navigation_errors_name_finiteness_and_the_envelope() {
    let non_finite = NavError::NonFinite.to_string();
    let outside = NavError::OutsideEnvelope.to_string();
    assert!(non_finite.contains("not finite"), "{non_finite}");
    assert!(outside.contains("outside the envelope"), "{outside}");
    assert_distinct(&[non_finite, outside]);
}

#[test]
fn schedule_errors_name_the_variable_and_the_side_of_the_envelope() {
    let cases = [
        (ScheduleError::NonFinite, ["not finite", "flight condition"]),
        (ScheduleError::AirspeedLow, ["airspeed", "below"]),
        (ScheduleError::AirspeedHigh, ["airspeed", "above"]),
        (ScheduleError::AltitudeLow, ["altitude", "below"]),
        (ScheduleError::AltitudeHigh, ["altitude", "above"]),
    ];
    let texts: Vec<String> = cases.iter().map(|(e, _)| e.to_string()).collect();
    for ((e, words), t) in cases.iter().zip(&texts) {
        for w in words {
            assert!(t.contains(w), "{e:?}: {t:?} lacks {w:?}");
        }
    }
    assert_distinct(&texts);
}
