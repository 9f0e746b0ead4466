//! The receiver's plant dispersions: factors on the true F-16 that the controller's design does
//! not know.
//!
//! The controller's gains, trim, estimator and models are designed on the nominal aircraft
//! (every factor 1.0). A [`ReceiverPlant`] scales what a real aircraft has differently from its
//! wind-tunnel tables and its nominal mass, actuators and engine; [`super::F16::with_plant`]
//! flies it. Each factor multiplies one named part of the model (`docs/models.md`,
//! "Receiver plant dispersions", gives the formulas, the ranges and their sources):
//!
//! - `elevator_effectiveness`: the elevator's increments `cx(α, δe) − cx(α, 0)`,
//!   `cm(α, δe) − cm(α, 0)` and `−0.19 δe/25` in `cz`; `aileron_effectiveness`: every
//!   aileron term (`0.021 dail` in `cy`, `dlda dail`, `dnda dail`); `rudder_effectiveness`:
//!   every rudder term (`0.086 drdr`, `dldr drdr`, `dndr drdr`);
//! - `roll_damping_scale`, `pitch_damping_scale`, `yaw_damping_scale`: the direct damping
//!   terms `Clp`, `Cmq`, `Cnr` (the cross terms `Clr`, `Cnp`, `CYp`, `CYr`, `CXq`, `CZq` keep
//!   their tables);
//! - `cm_alpha_scale`: the α-dependence of the pitching moment at zero elevator about the
//!   design trim's angle of attack (6.35 deg), `cm(α, 0) → cm(α₀, 0) + k (cm(α, 0) − cm(α₀, 0))`,
//!   at the tables' reference cg (the cg's own contribution, `cz (xcg_ref − xcg)`, is the
//!   `xcg` key's); `cn_beta_scale`, `cl_beta_scale`: the sideslip tables `cn(α, β)` and
//!   `cl(α, β)`;
//! - `mass_scale`; `jx_scale`, `jy_scale`, `jz_scale` on `Jx`, `Jy`, `Jz`, and `Jxz` by
//!   `sqrt(jx_scale jz_scale)`, which keeps `Jxz² < Jx Jz` (the inertia stays positive
//!   definite);
//! - `*_rate_limit_scale` and `*_bandwidth_scale` on each surface actuator's rate limit and
//!   lag bandwidth (position limits are the installation's and stay);
//! - `engine_time_constant_scale`: every time constant of the engine's power lag (its rates
//!   divided by the factor).
//!
//! Invariants: [`ReceiverPlant::NOMINAL`] (every factor exactly 1.0) is the nominal model bit
//! for bit: each factor enters as a multiplication by it, and a tabulated increment is split
//! from its table only when its factor is not 1.0. A plant the model flies has passed
//! [`ReceiverPlant::validate`]: every factor finite and inside its [`FactorLimits`].

use serde::{Deserialize, Serialize};

use super::data::ModelError;

/// The range a factor may take, both ends included: where the model is meant to be flown.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FactorLimits {
    /// Smallest factor.
    pub min: f64,
    /// Largest factor.
    pub max: f64,
    /// The range as written in errors (`"0.1..=3"`).
    pub text: &'static str,
}

impl FactorLimits {
    /// True when `factor` is finite and inside the limits.
    pub fn contains(&self, factor: f64) -> bool {
        factor.is_finite() && (self.min..=self.max).contains(&factor)
    }
}

/// A surface's effectiveness: a tenth of the nominal to three times it. A dead surface is a
/// fault ([`crate::world::faults`]), not a dispersion.
const EFFECTIVENESS: FactorLimits = FactorLimits {
    min: 0.1,
    max: 3.0,
    text: "0.1..=3",
};
/// Damping and static-stability derivatives: none (0) to three times the nominal; a sign
/// change is not a dispersion.
const DERIVATIVE: FactorLimits = FactorLimits {
    min: 0.0,
    max: 3.0,
    text: "0..=3",
};
/// Mass and inertias: half to twice the nominal.
const MASS: FactorLimits = FactorLimits {
    min: 0.5,
    max: 2.0,
    text: "0.5..=2",
};
/// Actuator rate limits.
const RATE_LIMIT: FactorLimits = FactorLimits {
    min: 0.1,
    max: 3.0,
    text: "0.1..=3",
};
/// Actuator bandwidths: at most twice the nominal 20.2 rad/s, so that the lag stays resolved
/// by the 0.02 s physics step (`actuators.rs`: RK4 keeps a surface inside its limits for steps
/// below about 1/bandwidth, 0.025 s at 40.4 rad/s).
const BANDWIDTH: FactorLimits = FactorLimits {
    min: 0.1,
    max: 2.0,
    text: "0.1..=2",
};
/// The engine's power-lag time constants.
const ENGINE_LAG: FactorLimits = FactorLimits {
    min: 0.25,
    max: 4.0,
    text: "0.25..=4",
};

/// One factor of the plant: its name and its limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FactorInfo {
    /// The field's name, which is also its key in a scenario file's `[receiver]` and
    /// `[dispersion.receiver]` tables.
    pub name: &'static str,
    /// `receiver.<name>`: the key's dotted path in a scenario file (and the name that salts its
    /// dispersion's random stream).
    pub receiver_key: &'static str,
    /// `dispersion.receiver.<name>`: the dotted path of its dispersion range.
    pub dispersion_key: &'static str,
    /// Allowed values.
    pub limits: FactorLimits,
}

/// What a field of [`PlantFactors`] holds: a factor (`f64`, nominal 1.0) or an optional
/// dispersion range (`Option<[f64; 2]>`, absent by default).
pub trait FactorSlot: Sized {
    /// The value of a field not given: 1.0 for a factor, `None` for a range.
    fn nominal() -> Self;
    /// True when the field need not be written out (an absent range; a factor is always
    /// written).
    fn is_absent(&self) -> bool;
}

impl FactorSlot for f64 {
    fn nominal() -> Self {
        1.0
    }
    fn is_absent(&self) -> bool {
        false
    }
}

impl FactorSlot for Option<[f64; 2]> {
    fn nominal() -> Self {
        None
    }
    fn is_absent(&self) -> bool {
        self.is_none()
    }
}

/// Declares [`PlantFactors`] and [`FACTORS`] from one list of fields, so that the struct, the
/// names, the keys and the limits cannot disagree.
macro_rules! plant_factors {
    ($( $(#[doc = $doc:literal])* $field:ident: $limits:expr; )*) => {
        /// One value per plant factor: the factors themselves ([`ReceiverPlant`]) or their
        /// dispersion ranges ([`ReceiverPlantRanges`]). Every factor is dimensionless, 1.0 on the
        /// nominal aircraft; its part of the model is in the module doc.
        #[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
        #[serde(
            deny_unknown_fields,
            default,
            bound(
                serialize = "T: Serialize + FactorSlot",
                deserialize = "T: Deserialize<'de> + FactorSlot"
            )
        )]
        pub struct PlantFactors<T> {
            $(
                $(#[doc = $doc])*
                #[serde(skip_serializing_if = "FactorSlot::is_absent")]
                pub $field: T,
            )*
        }

        /// Number of plant factors.
        pub const FACTOR_COUNT: usize = [$(stringify!($field)),*].len();

        /// Every factor's name, keys and limits, in field order (the order of
        /// [`PlantFactors::values`]).
        pub const FACTORS: [FactorInfo; FACTOR_COUNT] = [$(
            FactorInfo {
                name: stringify!($field),
                receiver_key: concat!("receiver.", stringify!($field)),
                dispersion_key: concat!("dispersion.receiver.", stringify!($field)),
                limits: $limits,
            },
        )*];

        impl<T> PlantFactors<T> {
            /// The fields in [`FACTORS`] order.
            pub fn values(&self) -> [&T; FACTOR_COUNT] {
                [$(&self.$field),*]
            }

            /// The fields in [`FACTORS`] order, to change.
            pub fn values_mut(&mut self) -> [&mut T; FACTOR_COUNT] {
                [$(&mut self.$field),*]
            }
        }

        impl<T: FactorSlot> Default for PlantFactors<T> {
            /// Every factor nominal (1.0), or no range.
            fn default() -> Self {
                Self { $($field: T::nominal(),)* }
            }
        }

        impl PlantFactors<f64> {
            /// The nominal aircraft: every factor 1.0.
            pub const NOMINAL: Self = Self { $($field: 1.0,)* };
        }
    };
}

plant_factors! {
    /// Elevator effectiveness: its increments of `cx`, `cz` and `cm`.
    elevator_effectiveness: EFFECTIVENESS;
    /// Aileron effectiveness: its terms in `cy`, `cl` and `cn`.
    aileron_effectiveness: EFFECTIVENESS;
    /// Rudder effectiveness: its terms in `cy`, `cl` and `cn`.
    rudder_effectiveness: EFFECTIVENESS;
    /// Roll damping `Clp`.
    roll_damping_scale: DERIVATIVE;
    /// Pitch damping `Cmq`.
    pitch_damping_scale: DERIVATIVE;
    /// Yaw damping `Cnr`.
    yaw_damping_scale: DERIVATIVE;
    /// Static pitch stability: `cm`'s α-dependence at zero elevator, about α = 6.35 deg.
    cm_alpha_scale: DERIVATIVE;
    /// Directional stability: the sideslip table `cn(α, β)`.
    cn_beta_scale: DERIVATIVE;
    /// Dihedral effect: the sideslip table `cl(α, β)`.
    cl_beta_scale: DERIVATIVE;
    /// Mass.
    mass_scale: MASS;
    /// Roll inertia `Jx` (and `Jxz` by `sqrt(jx_scale jz_scale)`).
    jx_scale: MASS;
    /// Pitch inertia `Jy`.
    jy_scale: MASS;
    /// Yaw inertia `Jz` (and `Jxz` by `sqrt(jx_scale jz_scale)`).
    jz_scale: MASS;
    /// Elevator actuator's rate limit.
    elevator_rate_limit_scale: RATE_LIMIT;
    /// Aileron actuator's rate limit.
    aileron_rate_limit_scale: RATE_LIMIT;
    /// Rudder actuator's rate limit.
    rudder_rate_limit_scale: RATE_LIMIT;
    /// Elevator actuator's lag bandwidth.
    elevator_bandwidth_scale: BANDWIDTH;
    /// Aileron actuator's lag bandwidth.
    aileron_bandwidth_scale: BANDWIDTH;
    /// Rudder actuator's lag bandwidth.
    rudder_bandwidth_scale: BANDWIDTH;
    /// The engine's power-lag time constants.
    engine_time_constant_scale: ENGINE_LAG;
}

/// The true aircraft's factors: [`PlantFactors`] of `f64`, [`ReceiverPlant::NOMINAL`] by
/// default.
pub type ReceiverPlant = PlantFactors<f64>;

/// Dispersion ranges `[min, max]` of the factors, each optional: [`PlantFactors`] of
/// `Option<[f64; 2]>` (a scenario file's `[dispersion.receiver]`).
pub type ReceiverPlantRanges = PlantFactors<Option<[f64; 2]>>;

impl ReceiverPlant {
    /// True when every factor is exactly 1.0 (the aircraft the controller was designed on).
    pub fn is_nominal(&self) -> bool {
        *self == Self::NOMINAL
    }

    /// Checks every factor against its limits ([`FACTORS`]); the error names the first
    /// factor outside them.
    pub fn validate(&self) -> Result<(), ModelError> {
        for (info, &value) in FACTORS.iter().zip(self.values()) {
            if !info.limits.contains(value) {
                return Err(ModelError::InvalidParameter {
                    name: info.name,
                    value,
                    requirement: info.limits.text,
                });
            }
        }
        Ok(())
    }
}

impl ReceiverPlantRanges {
    /// True when no factor is dispersed.
    pub fn is_empty(&self) -> bool {
        self.values().iter().all(|r| r.is_none())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_are_the_field_names_and_nominal_is_inside_every_limit() {
        let toml = toml::to_string(&ReceiverPlant::NOMINAL).expect("serialises");
        for info in FACTORS {
            assert!(toml.contains(&format!("{} = 1.0", info.name)), "{toml}");
            assert_eq!(info.receiver_key, format!("receiver.{}", info.name));
            assert_eq!(
                info.dispersion_key,
                format!("dispersion.receiver.{}", info.name)
            );
            assert!(info.limits.contains(1.0), "{}", info.name);
        }
        assert_eq!(ReceiverPlant::default(), ReceiverPlant::NOMINAL);
        assert!(ReceiverPlantRanges::default().is_empty());
        ReceiverPlant::NOMINAL.validate().expect("nominal is valid");
    }

    #[test]
    fn validation_names_the_factor_and_its_range() {
        let mut plant = ReceiverPlant::NOMINAL;
        plant.jy_scale = 2.5;
        let e = plant.validate().expect_err("out of range").to_string();
        assert!(e.contains("jy_scale") && e.contains("0.5..=2"), "{e}");
        plant.jy_scale = 1.0;
        plant.elevator_bandwidth_scale = f64::NAN;
        let e = plant.validate().expect_err("not finite").to_string();
        assert!(e.contains("elevator_bandwidth_scale"), "{e}");
        plant.elevator_bandwidth_scale = 2.0;
        plant.yaw_damping_scale = 0.0;
        plant.validate().expect("both ends are allowed");
        plant.yaw_damping_scale = -0.1;
        assert!(plant.validate().is_err());
    }

    #[test]
    fn values_follow_the_factor_order() {
        let mut plant = ReceiverPlant::NOMINAL;
        for (i, v) in plant.values_mut().into_iter().enumerate() {
            *v = i as f64;
        }
        assert_eq!(plant.elevator_effectiveness, 0.0);
        assert_eq!(plant.jx_scale, 10.0);
        assert_eq!(plant.engine_time_constant_scale, (FACTOR_COUNT - 1) as f64);
        let names: Vec<_> = FACTORS.iter().map(|f| f.name).collect();
        assert_eq!(names[10], "jx_scale");
    }
}
