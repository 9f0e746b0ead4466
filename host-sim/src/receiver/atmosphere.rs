//! The F-16 model's own air-data computer: density and speed of sound versus altitude.
//!
//! Source: `[atmosphere]` of `data/f16-lofi-data.toml` (Stevens, Lewis & Johnson App. A):
//! `tfac = 1 - 0.703e-5 h_ft`, `T = 519 tfac` Rankine below 35 000 ft and 390 R at or above,
//! `rho = rho0 tfac^4.14`, `a = sqrt(1.4 * 1716.3 * T)` ft/s. This is the model's fit, not ISA
//! (at 3000 m it gives 0.9104 kg/m^3 where ISA gives 0.9093).
//! Invariants: altitude in and SI out; English units live only inside [`Atmosphere::at`].
//! Valid while `tfac > 0`, i.e. below about 43 km; the tables stop at 50 000 ft (15.2 km).
//! [`F16::air_at`](super::F16::air_at) gives the same properties to the world models (hose,
//! wake), so that one atmosphere serves the whole simulation.

use super::units::{KG_M3_PER_SLUG_FT3, M_PER_FT};

/// Temperature-ratio decrease per foot of altitude.
const TEMPERATURE_RATIO_LAPSE_PER_FT: f64 = 0.703e-5;
/// Sea-level temperature, degrees Rankine.
const SEA_LEVEL_TEMPERATURE_R: f64 = 519.0;
/// Altitude from which the temperature is constant, ft.
const ISOTHERMAL_FROM_FT: f64 = 35_000.0;
/// Temperature at and above [`ISOTHERMAL_FROM_FT`], degrees Rankine.
const ISOTHERMAL_TEMPERATURE_R: f64 = 390.0;
/// Exponent of the temperature ratio in the density law.
const DENSITY_EXPONENT: f64 = 4.14;
/// Ratio of specific heats of air.
const GAMMA_AIR: f64 = 1.4;
/// Gas constant of air, ft^2/(s^2 R).
const GAS_CONSTANT_FT2_PER_S2_R: f64 = 1716.3;

/// Air properties at one altitude, SI (the F-16 model's atmosphere, not ISA).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AirProperties {
    /// Air density, kg/m^3.
    pub density_kg_m3: f64,
    /// Speed of sound, m/s.
    pub speed_of_sound_mps: f64,
    /// Static temperature, K (the model's `T`, converted from Rankine).
    pub temperature_k: f64,
}

/// Kelvin per degree Rankine.
const K_PER_R: f64 = 5.0 / 9.0;

/// The air-data computer, holding the sea-level density from the data file.
#[derive(Debug, Clone)]
pub(crate) struct Atmosphere {
    sea_level_density_slug_ft3: f64,
}

impl Atmosphere {
    /// Air-data computer with sea-level density `sea_level_density_slug_ft3` (validated > 0).
    pub(crate) fn new(sea_level_density_slug_ft3: f64) -> Self {
        Self {
            sea_level_density_slug_ft3,
        }
    }

    /// Air properties at `altitude_m` (metres above the flat-earth origin, positive up).
    pub(crate) fn at(&self, altitude_m: f64) -> AirProperties {
        let altitude_ft = altitude_m / M_PER_FT;
        let temperature_ratio = 1.0 - TEMPERATURE_RATIO_LAPSE_PER_FT * altitude_ft;
        let temperature_r = if altitude_ft < ISOTHERMAL_FROM_FT {
            SEA_LEVEL_TEMPERATURE_R * temperature_ratio
        } else {
            ISOTHERMAL_TEMPERATURE_R
        };
        let density_slug_ft3 =
            self.sea_level_density_slug_ft3 * temperature_ratio.powf(DENSITY_EXPONENT);
        let speed_of_sound_ftps = (GAMMA_AIR * GAS_CONSTANT_FT2_PER_S2_R * temperature_r).sqrt();
        AirProperties {
            density_kg_m3: density_slug_ft3 * KG_M3_PER_SLUG_FT3,
            speed_of_sound_mps: speed_of_sound_ftps * M_PER_FT,
            temperature_k: temperature_r * K_PER_R,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const RHO0_SLUG_FT3: f64 = 2.377e-3;

    #[test]
    fn sea_level_and_refuelling_altitude() {
        let atmosphere = Atmosphere::new(RHO0_SLUG_FT3);
        let sea_level = atmosphere.at(0.0);
        assert!((sea_level.density_kg_m3 - 1.2251).abs() < 1e-4);
        assert!((sea_level.speed_of_sound_mps - 340.376).abs() < 1e-3);
        let refuelling = atmosphere.at(3000.0);
        assert!((refuelling.density_kg_m3 - 0.9104).abs() < 1e-4);
        assert!((refuelling.speed_of_sound_mps - 328.389).abs() < 1e-3);
    }

    #[test]
    fn temperature_constant_above_35000_ft() {
        let atmosphere = Atmosphere::new(RHO0_SLUG_FT3);
        let at = |altitude_ft: f64| atmosphere.at(altitude_ft * M_PER_FT);
        assert_eq!(
            at(36_000.0).speed_of_sound_mps,
            at(45_000.0).speed_of_sound_mps
        );
        assert!(at(34_999.0).speed_of_sound_mps > at(35_000.0).speed_of_sound_mps);
        assert!(at(45_000.0).density_kg_m3 < at(36_000.0).density_kg_m3);
    }
}
