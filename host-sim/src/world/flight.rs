//! The flight condition of a run: the true airspeed and altitude at which the tanker flies and
//! the receiver is trimmed, the limits of the models' validity, and the air data the world
//! models (hose and drogue, wake, bow wave) take from it.
//!
//! One atmosphere serves the whole world: the F-16 model's own
//! ([`F16::air_at`](crate::receiver::F16::air_at),
//! `receiver/atmosphere.rs`). At another condition than [`FlightCondition::DEFAULT`] the hose
//! flies in that atmosphere's density, with the viscosity of Sutherland's law at its
//! temperature; the wake's circulation takes its density and the airspeed; the bow wave's
//! force (a fit made at the default condition) scales with the dynamic pressure.
//!
//! Limits ([`FlightCondition::validate`]): airspeed and altitude finite and positive; Mach at
//! most [`MAX_MACH`] (the F-16 low-fidelity data have no compressibility effects); altitude
//! within [`MIN_ALTITUDE_M`]..=[`MAX_ALTITUDE_M`]: the engine's thrust tables stop at
//! 50,000 ft (above they would be extrapolated), and below 1,000 ft MIL-F-8785C's turbulence
//! is no longer isotropic (different scale lengths and intensities per axis), which the gust
//! generator (`turbulence.rs`) does not model.
//!
//! Invariants: at [`FlightCondition::DEFAULT`] every parameter derived here is the model's
//! own default, bit for bit (the constant path: the hose's 0.9104 kg/m^3 and 1.6938e-5 Pa s,
//! the wake's 0.9104 kg/m^3 and 120 m/s, the bow wave's unit scale), so that a run at the
//! default condition is exactly the run before the condition existed. The atmosphere gives
//! 0.910 405 kg/m^3 at 3000 m, and Sutherland's law at its 268.38 K 1.6924e-5 Pa s: near
//! those constants, not them to the bit. Elsewhere every value is the atmosphere's at the
//! condition's altitude.

use serde::{Deserialize, Serialize};

use crate::receiver::AirProperties;
use crate::synthesis::{REFUELLING_ALTITUDE_M, REFUELLING_SPEED_MPS};
use crate::world::hose::HoseParams;
use crate::world::wake::WakeParams;

/// Highest Mach number accepted: the F-16 low-fidelity aerodynamic data have no
/// compressibility (Stevens, Lewis & Johnson state them for Mach up to about 0.6).
pub const MAX_MACH: f64 = 0.6;
/// Lowest altitude accepted, m: 1,000 ft, the top of MIL-F-8785C's low-altitude turbulence
/// model. From there up its turbulence is isotropic, the only kind the gust generator has: at
/// 1,000 ft the low-altitude scale lengths (`h / (0.177 + 0.000823 h)^1.2` and `h`) and
/// intensity ratios (`1 / (0.177 + 0.000823 h)^0.4`) are all 1,000 ft and 1, and between
/// 1,000 and 2,000 ft the specification interpolates between two isotropic models. Below,
/// the lengths and intensities differ per axis.
pub const MIN_ALTITUDE_M: f64 = 304.8;
/// Highest altitude accepted, m: 50,000 ft, the top of the engine's thrust tables.
pub const MAX_ALTITUDE_M: f64 = 15_240.0;

/// Sutherland's law: reference constant, kg/(m s K^0.5) (US Standard Atmosphere 1976).
const SUTHERLAND_BETA: f64 = 1.458e-6;
/// Sutherland's constant, K.
const SUTHERLAND_S_K: f64 = 110.4;

/// True airspeed and altitude of the tanker and the trimmed receiver (calm air: the true
/// airspeed is the ground speed).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FlightCondition {
    /// True airspeed, m/s.
    pub airspeed_mps: f64,
    /// Altitude, m.
    pub altitude_m: f64,
}

/// A flight condition outside the models' validity.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum FlightConditionError {
    /// A value that must be finite and positive is not.
    #[error("{key} = {value} must be finite and positive")]
    NotPositive {
        /// Dotted key.
        key: &'static str,
        /// The value given.
        value: f64,
    },
    /// The altitude is outside the atmosphere, engine and turbulence models' range.
    #[error(
        "{key} = {value} m is out of range: allowed {MIN_ALTITUDE_M}..={MAX_ALTITUDE_M} m \
         (1,000 ft: below, MIL-F-8785C turbulence is not isotropic; 50,000 ft: the top of the \
         engine's thrust tables)"
    )]
    AltitudeOutOfRange {
        /// Dotted key.
        key: &'static str,
        /// The value given, m.
        value: f64,
    },
    /// The Mach number exceeds [`MAX_MACH`].
    #[error(
        "{key} = {airspeed_mps} m/s at {altitude_m} m is Mach {mach:.3} (speed of sound \
         {speed_of_sound_mps:.2} m/s): above the limit Mach {MAX_MACH} (the F-16 low-fidelity \
         data have no compressibility)"
    )]
    MachAboveLimit {
        /// Dotted key of the airspeed.
        key: &'static str,
        /// Airspeed, m/s.
        airspeed_mps: f64,
        /// Altitude, m.
        altitude_m: f64,
        /// Its Mach number.
        mach: f64,
        /// Speed of sound there, m/s.
        speed_of_sound_mps: f64,
    },
}

/// Sutherland's law: dynamic viscosity of air at `temperature_k`, Pa s.
pub fn sutherland_viscosity_pa_s(temperature_k: f64) -> f64 {
    SUTHERLAND_BETA * temperature_k.powf(1.5) / (temperature_k + SUTHERLAND_S_K)
}

impl Default for FlightCondition {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl FlightCondition {
    /// The refuelling condition the gains are designed at: 120 m/s, 3000 m.
    pub const DEFAULT: Self = Self {
        airspeed_mps: REFUELLING_SPEED_MPS,
        altitude_m: REFUELLING_ALTITUDE_M,
    };

    /// True at exactly [`FlightCondition::DEFAULT`] (the constant path of the module doc).
    pub fn is_default(&self) -> bool {
        *self == Self::DEFAULT
    }

    /// Checks the limits of the module doc, the keys named `airspeed_key` and
    /// `altitude_key` in the error; `air` is the atmosphere (the F-16 model's).
    pub fn validate(
        &self,
        air: impl Fn(f64) -> AirProperties,
        airspeed_key: &'static str,
        altitude_key: &'static str,
    ) -> Result<(), FlightConditionError> {
        for (key, value) in [
            (airspeed_key, self.airspeed_mps),
            (altitude_key, self.altitude_m),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(FlightConditionError::NotPositive { key, value });
            }
        }
        if !(MIN_ALTITUDE_M..=MAX_ALTITUDE_M).contains(&self.altitude_m) {
            return Err(FlightConditionError::AltitudeOutOfRange {
                key: altitude_key,
                value: self.altitude_m,
            });
        }
        let a = air(self.altitude_m).speed_of_sound_mps;
        let mach = self.airspeed_mps / a;
        if mach > MAX_MACH {
            return Err(FlightConditionError::MachAboveLimit {
                key: airspeed_key,
                airspeed_mps: self.airspeed_mps,
                altitude_m: self.altitude_m,
                mach,
                speed_of_sound_mps: a,
            });
        }
        Ok(())
    }

    /// The hose and drogue's parameters at this condition: `base` at the default condition;
    /// elsewhere `base` with the density of `air` (the atmosphere at this altitude) and the
    /// viscosity of Sutherland's law at its temperature. (The free stream, the tanker's speed,
    /// is the world's.)
    pub fn hose_params(&self, base: HoseParams, air: &AirProperties) -> HoseParams {
        if self.is_default() {
            return base;
        }
        HoseParams {
            air_density_kg_per_m3: air.density_kg_m3,
            air_dynamic_viscosity_pa_s: sutherland_viscosity_pa_s(air.temperature_k),
            ..base
        }
    }

    /// The wake's parameters at this condition: `base` at the default condition; elsewhere
    /// `base` with the density of `air` and this airspeed (circulation `m g / (rho V b')` and
    /// wake age `-x / V`, as the model is written).
    pub fn wake_params(&self, base: WakeParams, air: &AirProperties) -> WakeParams {
        if self.is_default() {
            return base;
        }
        WakeParams {
            air_density_kgpm3: air.density_kg_m3,
            airspeed_mps: self.airspeed_mps,
            ..base
        }
    }

    /// Factor on the bow wave's force: 1 at the default condition, where its fit was made;
    /// elsewhere the dynamic pressure over the default's, `rho V^2 / (rho0 V0^2)` with `air`
    /// at this altitude and `reference_air` at the default's (the fit is of a potential flow
    /// with a viscous correction, whose pressures scale with the dynamic pressure; the
    /// geometry of the field is kept).
    pub fn bow_wave_scale(&self, air: &AirProperties, reference_air: &AirProperties) -> f64 {
        if self.is_default() {
            return 1.0;
        }
        let v0 = Self::DEFAULT.airspeed_mps;
        (air.density_kg_m3 * self.airspeed_mps * self.airspeed_mps)
            / (reference_air.density_kg_m3 * v0 * v0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::receiver::F16;
    use crate::world::hose::{AIR_DENSITY_3000M_KG_PER_M3, AIR_DYNAMIC_VISCOSITY_3000M_PA_S};

    fn model() -> F16 {
        F16::new(0.35).unwrap()
    }

    #[test]
    fn the_default_keeps_the_constants_and_the_atmosphere_is_near_them() {
        let m = model();
        let air = m.air_at(3000.0);
        let d = FlightCondition::DEFAULT;
        assert_eq!(
            d.hose_params(HoseParams::default(), &air),
            HoseParams::default()
        );
        assert_eq!(
            d.wake_params(WakeParams::default(), &air),
            WakeParams::default()
        );
        assert_eq!(d.bow_wave_scale(&air, &air), 1.0);
        // The constants are the atmosphere's to their printed digits (not to the bit).
        assert!((air.density_kg_m3 - AIR_DENSITY_3000M_KG_PER_M3).abs() < 5e-5);
        let mu = sutherland_viscosity_pa_s(air.temperature_k);
        assert!((mu - AIR_DYNAMIC_VISCOSITY_3000M_PA_S).abs() < 2e-8, "{mu}");
    }

    #[test]
    fn limits_name_the_key() {
        let m = model();
        let air = |h: f64| m.air_at(h);
        let check = |v: f64, h: f64| {
            FlightCondition {
                airspeed_mps: v,
                altitude_m: h,
            }
            .validate(air, "flight.airspeed_mps", "flight.altitude_m")
        };
        assert!(check(120.0, 3000.0).is_ok());
        assert!(check(150.0, 6000.0).is_ok());
        let a3000 = m.air_at(3000.0).speed_of_sound_mps;
        assert!(check(0.6 * a3000, 3000.0).is_ok());
        let e = check(0.6 * a3000 + 0.01, 3000.0).unwrap_err();
        assert!(matches!(e, FlightConditionError::MachAboveLimit { .. }));
        assert!(e.to_string().contains("flight.airspeed_mps") && e.to_string().contains("0.6"));
        for (v, h, key) in [
            (f64::NAN, 3000.0, "flight.airspeed_mps"),
            (-1.0, 3000.0, "flight.airspeed_mps"),
            (0.0, 3000.0, "flight.airspeed_mps"),
            (120.0, f64::INFINITY, "flight.altitude_m"),
            (120.0, -10.0, "flight.altitude_m"),
        ] {
            let e = check(v, h).unwrap_err();
            assert!(matches!(e, FlightConditionError::NotPositive { .. }), "{e}");
            assert!(e.to_string().contains(key), "{e}");
        }
        for h in [300.0, 15_300.0] {
            let e = check(120.0, h).unwrap_err();
            assert!(
                matches!(e, FlightConditionError::AltitudeOutOfRange { .. }),
                "{e}"
            );
            assert!(e.to_string().contains("flight.altitude_m"), "{e}");
        }
    }

    #[test]
    fn elsewhere_the_world_takes_the_atmosphere() {
        let m = model();
        let c = FlightCondition {
            airspeed_mps: 150.0,
            altitude_m: 6000.0,
        };
        let (air, air0) = (m.air_at(6000.0), m.air_at(3000.0));
        let h = c.hose_params(HoseParams::default(), &air);
        assert_eq!(h.air_density_kg_per_m3, air.density_kg_m3);
        assert!(h.air_density_kg_per_m3 < 0.7);
        let w = c.wake_params(WakeParams::default(), &air);
        assert_eq!(
            (w.air_density_kgpm3, w.airspeed_mps),
            (air.density_kg_m3, 150.0)
        );
        let q = c.bow_wave_scale(&air, &air0);
        let want = air.density_kg_m3 * 150.0 * 150.0 / (air0.density_kg_m3 * 120.0 * 120.0);
        assert!((q - want).abs() < 1e-12 && q != 1.0, "{q}");
    }
}
