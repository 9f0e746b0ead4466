//! Navigation input: the receiver's perturbation state from trim, and its validation.
//!
//! The states are those of the paper's eq. (1), split into the longitudinal and lateral
//! channels, each a perturbation from the receiver's trim at the sample's
//! [`FlightCondition`] (the refuelling track's true airspeed and altitude; at the default
//! condition, the trim point in [`crate::gains::TRIM`]). Angles are relative to the trim
//! attitude (heading relative to the tanker's track); speed relative to the trim (= tanker)
//! speed. The condition selects the inner loops' design from the gain schedule.
//!
//! Invariant: a sample that passes [`NavSample::validate`] is finite (its condition too) and
//! inside the envelope where the linear design is meaningful ([`NavEnvelope`]); whether the
//! condition is inside the docking envelope is the schedule's question, not this one.

use serde::{Deserialize, Serialize};

/// Longitudinal perturbation states `[x, h, theta, V, alpha, q]` (paper eq. (1)).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LonNav {
    /// Position along the tanker x axis (forward), m. Not fed back (see `docs/conventions.md`).
    pub x_fwd_m: f32,
    /// Altitude, up positive, m. Not fed back.
    pub h_up_m: f32,
    /// Pitch angle, rad.
    pub theta_rad: f32,
    /// Ground speed, m/s.
    pub v_mps: f32,
    /// Angle of attack, rad.
    pub alpha_rad: f32,
    /// Body pitch rate, rad/s.
    pub q_radps: f32,
}

/// Lateral perturbation states `[y, psi, phi, beta, p, r]` (paper eq. (1)).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LatNav {
    /// Position along the tanker y axis (right), m. Not fed back.
    pub y_right_m: f32,
    /// Heading relative to the tanker's track, rad.
    pub psi_rad: f32,
    /// Bank angle, rad.
    pub phi_rad: f32,
    /// Sideslip angle, rad.
    pub beta_rad: f32,
    /// Body roll rate, rad/s.
    pub p_radps: f32,
    /// Body yaw rate, rad/s.
    pub r_radps: f32,
}

/// The flight condition the receiver is trimmed at: the refuelling track's (the tanker's)
/// true airspeed and altitude, the gain schedule's variables ([`crate::schedule`]).
///
/// True airspeed and altitude, because the docking envelope is stated in them, the tanker's
/// refuelling track is flown at them, and air data gives both directly. The gains vary
/// mostly with dynamic pressure, but a grid in dynamic pressure is not rectangular in the
/// envelope, and the kinematic terms of the output matrix follow the true airspeed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FlightCondition {
    /// True airspeed, m/s.
    pub true_airspeed_mps: f32,
    /// Altitude, m.
    pub altitude_m: f32,
}

impl Default for FlightCondition {
    /// The single-point design's condition ([`crate::gains::TRIM`]).
    fn default() -> Self {
        Self {
            true_airspeed_mps: crate::gains::TRIM.speed_mps,
            altitude_m: crate::gains::TRIM.altitude_m,
        }
    }
}

/// One navigation sample: both channels' perturbation states from the receiver's trim at
/// the flight condition it carries.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NavSample {
    /// Longitudinal channel.
    pub lon: LonNav,
    /// Lateral channel.
    pub lat: LatNav,
    /// The flight condition the perturbations are from (the gain schedule's variables).
    pub condition: FlightCondition,
}

/// Why a navigation sample was not used.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NavError {
    /// A state or the flight condition is NaN or infinite.
    NonFinite,
    /// A state is outside [`NavEnvelope`]: the linear design does not hold there.
    OutsideEnvelope,
}

impl core::fmt::Display for NavError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::NonFinite => "a navigation state is not finite",
            Self::OutsideEnvelope => "a navigation state is outside the envelope",
        })
    }
}

impl core::error::Error for NavError {}

/// Largest perturbations from trim the controller accepts (absolute values).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NavEnvelope {
    /// Pitch, angle of attack and heading perturbation limit, rad.
    pub max_angle_rad: f32,
    /// Bank angle limit, rad.
    pub max_bank_rad: f32,
    /// Sideslip limit, rad.
    pub max_sideslip_rad: f32,
    /// Speed perturbation limit, m/s.
    pub max_speed_mps: f32,
    /// Body-rate limit, rad/s.
    pub max_rate_radps: f32,
}

impl Default for NavEnvelope {
    /// Generous limits: 20 deg in pitch, alpha and heading, 45 deg of bank, 10 deg of
    /// sideslip, 30 m/s and 1.5 rad/s. A docking approach stays far inside them.
    fn default() -> Self {
        Self {
            max_angle_rad: 0.35,
            max_bank_rad: 0.785,
            max_sideslip_rad: 0.175,
            max_speed_mps: 30.0,
            max_rate_radps: 1.5,
        }
    }
}

/// A validated [`NavEnvelope`] as the bit patterns of its limits, for the step's check.
///
/// For a finite `v` and a positive finite limit, `|v| <= limit` exactly when the bits of
/// `|v|` do not exceed the limit's (IEEE 754 orders non-negative floats as their bit
/// patterns), so the check is integer arithmetic without branches.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EnvelopeBits {
    angle: u32,
    bank: u32,
    sideslip: u32,
    speed: u32,
    rate: u32,
}

impl EnvelopeBits {
    /// The envelope's limits; `None` unless every one is positive and finite.
    pub fn new(env: &NavEnvelope) -> Option<Self> {
        let bits = |v: f32| (v > 0.0 && v.is_finite()).then_some(v.to_bits());
        Some(Self {
            angle: bits(env.max_angle_rad)?,
            bank: bits(env.max_bank_rad)?,
            sideslip: bits(env.max_sideslip_rad)?,
            speed: bits(env.max_speed_mps)?,
            rate: bits(env.max_rate_radps)?,
        })
    }
}

/// Bits of the largest finite `f32`: a magnitude's bits above it are not finite.
const MAX_FINITE_BITS: u32 = 0x7F7F_FFFF;
/// The sign bit.
const SIGN: u32 = 0x8000_0000;

impl NavSample {
    /// [`NavSample::validate`] against an envelope whose limits are positive and finite,
    /// with the same answer for every sample, in integer arithmetic: `limit - |v|` (as
    /// bits) is negative exactly when `|v| > limit`, and the sign bits are OR-ed together.
    /// A state inside its (finite) limit is finite, so a sample passes with one test per
    /// state; which error a failing one has is worked out only then.
    #[inline]
    pub fn check(&self, env: &EnvelopeBits) -> Result<(), NavError> {
        let a = self.as_array().map(crate::num::abs_bits);
        let outside = env.angle.wrapping_sub(a[2]) // theta
            | env.speed.wrapping_sub(a[3]) // V
            | env.angle.wrapping_sub(a[4]) // alpha
            | env.rate.wrapping_sub(a[5]) // q
            | env.angle.wrapping_sub(a[7]) // psi
            | env.bank.wrapping_sub(a[8]) // phi
            | env.sideslip.wrapping_sub(a[9]) // beta
            | env.rate.wrapping_sub(a[10]) // p
            | env.rate.wrapping_sub(a[11]); // r
        let c = &self.condition;
        let unchecked_non_finite = MAX_FINITE_BITS.wrapping_sub(a[0]) // x
            | MAX_FINITE_BITS.wrapping_sub(a[1]) // h
            | MAX_FINITE_BITS.wrapping_sub(a[6]) // y
            | MAX_FINITE_BITS.wrapping_sub(crate::num::abs_bits(c.true_airspeed_mps))
            | MAX_FINITE_BITS.wrapping_sub(crate::num::abs_bits(c.altitude_m));
        if (outside | unchecked_non_finite) & SIGN == 0 {
            Ok(())
        } else {
            Err(self.rejection())
        }
    }

    /// Why a sample that failed [`NavSample::check`] fails: non-finite before out of the
    /// envelope. Out of line: the check's common path keeps nothing for it.
    #[cold]
    #[inline(never)]
    fn rejection(&self) -> NavError {
        let c = &self.condition;
        let non_finite = self
            .as_array()
            .iter()
            .chain(&[c.true_airspeed_mps, c.altitude_m])
            .fold(0, |acc, &v| {
                acc | MAX_FINITE_BITS.wrapping_sub(crate::num::abs_bits(v))
            });
        if non_finite & SIGN != 0 {
            NavError::NonFinite
        } else {
            NavError::OutsideEnvelope
        }
    }

    /// All twelve states in the paper's order (lon then lat).
    pub fn as_array(&self) -> [f32; 12] {
        let (lo, la) = (&self.lon, &self.lat);
        [
            lo.x_fwd_m,
            lo.h_up_m,
            lo.theta_rad,
            lo.v_mps,
            lo.alpha_rad,
            lo.q_radps,
            la.y_right_m,
            la.psi_rad,
            la.phi_rad,
            la.beta_rad,
            la.p_radps,
            la.r_radps,
        ]
    }

    /// The inverse of [`NavSample::as_array`], at the default [`FlightCondition`].
    pub fn from_array(a: [f32; 12]) -> Self {
        let [x_fwd_m, h_up_m, theta_rad, v_mps, alpha_rad, q_radps] =
            [a[0], a[1], a[2], a[3], a[4], a[5]];
        let [y_right_m, psi_rad, phi_rad, beta_rad, p_radps, r_radps] =
            [a[6], a[7], a[8], a[9], a[10], a[11]];
        Self {
            lon: LonNav {
                x_fwd_m,
                h_up_m,
                theta_rad,
                v_mps,
                alpha_rad,
                q_radps,
            },
            lat: LatNav {
                y_right_m,
                psi_rad,
                phi_rad,
                beta_rad,
                p_radps,
                r_radps,
            },
            condition: FlightCondition::default(),
        }
    }

    /// Checks the sample is finite and inside `env`.
    pub fn validate(&self, env: &NavEnvelope) -> Result<(), NavError> {
        let c = &self.condition;
        if !(self.as_array().iter().all(|v| v.is_finite())
            && c.true_airspeed_mps.is_finite()
            && c.altitude_m.is_finite())
        {
            return Err(NavError::NonFinite);
        }
        let (lo, la) = (&self.lon, &self.lat);
        let within = |v: f32, lim: f32| libm::fabsf(v) <= lim;
        let ok = within(lo.theta_rad, env.max_angle_rad)
            && within(lo.alpha_rad, env.max_angle_rad)
            && within(la.psi_rad, env.max_angle_rad)
            && within(la.phi_rad, env.max_bank_rad)
            && within(la.beta_rad, env.max_sideslip_rad)
            && within(lo.v_mps, env.max_speed_mps)
            && within(lo.q_radps, env.max_rate_radps)
            && within(la.p_radps, env.max_rate_radps)
            && within(la.r_radps, env.max_rate_radps);
        if ok {
            Ok(())
        } else {
            Err(NavError::OutsideEnvelope)
        }
    }

    /// Longitudinal design state `[theta, V, alpha, q, P]` ([`crate::inner::LON_STATES`]).
    /// The engine power perturbation `P` is not navigation: it comes from the controller's
    /// engine model ([`crate::inner::EngineModel`]).
    #[inline(always)]
    pub fn lon_design_state(&self, engine_power_pct: f32) -> [f32; 5] {
        let l = &self.lon;
        [
            l.theta_rad,
            l.v_mps,
            l.alpha_rad,
            l.q_radps,
            engine_power_pct,
        ]
    }

    /// Lateral design state `[psi, phi, beta, p, r]` ([`crate::inner::LAT_STATES`]).
    #[inline(always)]
    pub fn lat_design_state(&self) -> [f32; 5] {
        let l = &self.lat;
        [l.psi_rad, l.phi_rad, l.beta_rad, l.p_radps, l.r_radps]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_non_finite_and_out_of_envelope() {
        let env = NavEnvelope::default();
        let ok = NavSample::default();
        assert_eq!(ok.validate(&env), Ok(()));
        let mut nan = ok;
        nan.lat.r_radps = f32::NAN;
        assert_eq!(nan.validate(&env), Err(NavError::NonFinite));
        let mut inf = ok;
        inf.lon.x_fwd_m = f32::NEG_INFINITY;
        assert_eq!(inf.validate(&env), Err(NavError::NonFinite));
        let mut bank = ok;
        bank.lat.phi_rad = 1.0;
        assert_eq!(bank.validate(&env), Err(NavError::OutsideEnvelope));
        let mut fast = ok;
        fast.lon.v_mps = -31.0;
        assert_eq!(fast.validate(&env), Err(NavError::OutsideEnvelope));
        // The scheduling variables are checked for finiteness (by both checks), not for
        // the docking envelope: that is the schedule's answer.
        let bits = EnvelopeBits::new(&env).unwrap();
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let mut s = ok;
            s.condition.true_airspeed_mps = bad;
            assert_eq!(
                (s.validate(&env), s.check(&bits)),
                (Err(NavError::NonFinite), Err(NavError::NonFinite))
            );
            let mut s = ok;
            s.condition.altitude_m = bad;
            assert_eq!(
                (s.validate(&env), s.check(&bits)),
                (Err(NavError::NonFinite), Err(NavError::NonFinite))
            );
        }
        let mut far = ok;
        far.condition = FlightCondition {
            true_airspeed_mps: 900.0,
            altitude_m: -50.0,
        };
        assert_eq!((far.validate(&env), far.check(&bits)), (Ok(()), Ok(())));
    }

    #[test]
    fn the_bit_check_answers_as_validate() {
        let env = NavEnvelope::default();
        let bits = EnvelopeBits::new(&env).expect("valid envelope");
        let values = [
            0.0,
            -0.0,
            0.1,
            -0.1,
            0.35,
            -0.35,
            f32::from_bits(0.35_f32.to_bits() + 1),
            0.785,
            1.5,
            -1.5000001,
            29.9,
            30.0,
            -30.000002,
            1e-40,
            f32::MAX,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ];
        let mut k = 0usize;
        for _ in 0..20_000 {
            let a: [f32; 12] = core::array::from_fn(|i| {
                k = k
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407 + i);
                // mostly in range, sometimes anything
                let v = values[(k >> 33) % values.len()];
                if (k >> 20).is_multiple_of(4) {
                    v
                } else {
                    v * 0.1
                }
            });
            let s = NavSample::from_array(a);
            assert_eq!(s.check(&bits), s.validate(&env), "{a:?}");
        }
        assert_eq!(
            EnvelopeBits::new(&NavEnvelope {
                max_rate_radps: f32::NAN,
                ..env
            }),
            None
        );
    }

    #[test]
    fn array_round_trips() {
        let a: [f32; 12] = core::array::from_fn(|i| i as f32);
        assert_eq!(NavSample::from_array(a).as_array(), a);
    }

    #[test]
    fn design_states_pick_the_fed_back_states_in_order() {
        let s = NavSample {
            lon: LonNav {
                x_fwd_m: 9.0,
                h_up_m: 9.0,
                theta_rad: 1.0,
                v_mps: 2.0,
                alpha_rad: 3.0,
                q_radps: 4.0,
            },
            lat: LatNav {
                y_right_m: 9.0,
                psi_rad: 1.0,
                phi_rad: 2.0,
                beta_rad: 3.0,
                p_radps: 4.0,
                r_radps: 5.0,
            },
            condition: FlightCondition::default(),
        };
        assert_eq!(s.lon_design_state(7.0), [1.0, 2.0, 3.0, 4.0, 7.0]);
        assert_eq!(s.lat_design_state(), [1.0, 2.0, 3.0, 4.0, 5.0]);
    }
}
