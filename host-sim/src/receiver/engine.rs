//! The F-16 low-fidelity engine: throttle gearing, first-order power lag with an afterburner
//! regime, and thrust interpolated in Mach and altitude between idle, military and maximum tables.
//!
//! Source: `[engine]` of `data/f16-lofi-data.toml`, whose power-lag wording follows the book's
//! listing (functions TGEAR, PDOT, RTAU of Stevens, Lewis & Johnson App. A): (1) whenever the
//! actual power is at or above 50 % the rate is 5 /s, also when the command is below 50 % (target
//! then 40 %); (2) RTAU takes the signed difference `target - actual`, so a decrease always uses
//! 1/tau = 1 /s. (An earlier wording of the data file's comment stated both differently.)
//! Invariants: power state and commands in percent (0..100), throttle as a fraction (0..1),
//! thrust out in newtons along body x; English units (lbf, ft) only inside [`Engine::thrust_n`].

use super::data::{EngineData, Grids, N_ALTITUDE, N_MACH};
use super::interp::interp2;
use super::units::{M_PER_FT, N_PER_LBF};

/// Throttle fraction at which the gearing switches to the afterburner slope.
const THROTTLE_AFTERBURNER_BREAK: f64 = 0.77;
/// Power command per unit throttle below the break, percent.
const GEARING_DRY_PCT: f64 = 64.94;
/// Power command per unit throttle above the break, percent.
const GEARING_AFTERBURNER_PCT: f64 = 217.38;
/// Offset of the afterburner gearing line, percent.
const GEARING_AFTERBURNER_OFFSET_PCT: f64 = 117.38;
/// Power at which thrust reaches military (dry maximum) and the afterburner regime starts, percent.
const MILITARY_POWER_PCT: f64 = 50.0;
/// Fraction of the thrust interval per percent of power (1/50: each regime spans 50 %).
const THRUST_FRACTION_PER_PCT: f64 = 0.02;
/// Reciprocal time constant while the actual power is in the afterburner regime, 1/s.
const AFTERBURNER_RATE_PER_S: f64 = 5.0;
/// Target power while lighting the afterburner (actual < 50 %, command >= 50 %), percent.
const AFTERBURNER_ENTRY_TARGET_PCT: f64 = 60.0;
/// Target power while leaving the afterburner (actual >= 50 %, command < 50 %), percent.
const AFTERBURNER_EXIT_TARGET_PCT: f64 = 40.0;
/// Power rise up to which the core responds fastest, percent.
const FAST_RESPONSE_MAX_RISE_PCT: f64 = 25.0;
/// Power rise from which the core responds slowest, percent.
const SLOW_RESPONSE_MIN_RISE_PCT: f64 = 50.0;
/// Fastest core reciprocal time constant, 1/s.
const FAST_RESPONSE_RATE_PER_S: f64 = 1.0;
/// Slowest core reciprocal time constant, 1/s.
const SLOW_RESPONSE_RATE_PER_S: f64 = 0.1;
/// Intercept of the linear blend between the fast and slow responses, 1/s.
const RESPONSE_BLEND_INTERCEPT_PER_S: f64 = 1.9;
/// Slope of that blend, 1/s per percent of power rise.
const RESPONSE_BLEND_SLOPE_PER_S_PCT: f64 = 0.036;

/// Steady-state power commanded by `throttle` (fraction, already clamped to 0..1), percent.
pub(crate) fn commanded_power_pct(throttle: f64) -> f64 {
    if throttle <= THROTTLE_AFTERBURNER_BREAK {
        GEARING_DRY_PCT * throttle
    } else {
        GEARING_AFTERBURNER_PCT * throttle - GEARING_AFTERBURNER_OFFSET_PCT
    }
}

/// Reciprocal time constant of the core for a power rise of `rise_pct` (negative: a decrease).
fn core_rate_per_s(rise_pct: f64) -> f64 {
    if rise_pct <= FAST_RESPONSE_MAX_RISE_PCT {
        FAST_RESPONSE_RATE_PER_S
    } else if rise_pct >= SLOW_RESPONSE_MIN_RISE_PCT {
        SLOW_RESPONSE_RATE_PER_S
    } else {
        RESPONSE_BLEND_INTERCEPT_PER_S - RESPONSE_BLEND_SLOPE_PER_S_PCT * rise_pct
    }
}

/// Rate of change of the power state, percent/s, for actual power `actual_pct` and
/// commanded power `commanded_pct`.
pub(crate) fn power_rate_pct_per_s(actual_pct: f64, commanded_pct: f64) -> f64 {
    let afterburner_actual = actual_pct >= MILITARY_POWER_PCT;
    let afterburner_commanded = commanded_pct >= MILITARY_POWER_PCT;
    let (target_pct, rate_per_s) = match (afterburner_actual, afterburner_commanded) {
        (true, true) => (commanded_pct, AFTERBURNER_RATE_PER_S),
        (true, false) => (AFTERBURNER_EXIT_TARGET_PCT, AFTERBURNER_RATE_PER_S),
        (false, true) => (
            AFTERBURNER_ENTRY_TARGET_PCT,
            core_rate_per_s(AFTERBURNER_ENTRY_TARGET_PCT - actual_pct),
        ),
        (false, false) => (commanded_pct, core_rate_per_s(commanded_pct - actual_pct)),
    };
    rate_per_s * (target_pct - actual_pct)
}

/// Thrust tables over Mach (rows) and altitude (columns), lbf as published.
#[derive(Debug, Clone)]
pub(crate) struct Engine {
    mach: [f64; N_MACH],
    altitude_ft: [f64; N_ALTITUDE],
    tables_lbf: EngineData,
}

impl Engine {
    /// Engine from the data file's grids and thrust tables.
    pub(crate) fn new(grids: &Grids, tables_lbf: EngineData) -> Self {
        Self {
            mach: grids.mach,
            altitude_ft: grids.altitude_ft,
            tables_lbf,
        }
    }

    /// Thrust along body x, N, at power state `power_pct`, Mach `mach` and altitude `altitude_m`.
    pub(crate) fn thrust_n(&self, power_pct: f64, mach: f64, altitude_m: f64) -> f64 {
        let altitude_ft = altitude_m / M_PER_FT;
        let lookup = |table| interp2(&self.mach, &self.altitude_ft, table, mach, altitude_ft);
        let military_lbf = lookup(&self.tables_lbf.thrust_mil);
        let thrust_lbf = if power_pct < MILITARY_POWER_PCT {
            let idle_lbf = lookup(&self.tables_lbf.thrust_idle);
            idle_lbf + (military_lbf - idle_lbf) * power_pct * THRUST_FRACTION_PER_PCT
        } else {
            let maximum_lbf = lookup(&self.tables_lbf.thrust_max);
            military_lbf
                + (maximum_lbf - military_lbf)
                    * (power_pct - MILITARY_POWER_PCT)
                    * THRUST_FRACTION_PER_PCT
        };
        thrust_lbf * N_PER_LBF
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::receiver::data::ModelData;

    fn engine() -> Engine {
        let data = ModelData::embedded().expect("embedded data file must load");
        Engine::new(&data.grid, data.engine)
    }

    #[test]
    fn gearing_spans_idle_to_maximum() {
        assert_eq!(commanded_power_pct(0.0), 0.0);
        assert!((commanded_power_pct(0.5) - 32.47).abs() < 1e-12);
        assert!((commanded_power_pct(1.0) - 100.0).abs() < 1e-12);
        // The two published lines nearly meet at the break (50.00 vs 49.91 %).
        let jump = commanded_power_pct(0.770_001) - commanded_power_pct(0.77);
        assert!(jump.abs() < 0.1);
    }

    #[test]
    fn thrust_at_nodes_and_power_levels() {
        let engine = engine();
        let sea_level_static = |power_pct| engine.thrust_n(power_pct, 0.0, 0.0) / N_PER_LBF;
        assert!((sea_level_static(0.0) - 1060.0).abs() < 1e-9);
        assert!((sea_level_static(50.0) - 12680.0).abs() < 1e-9);
        assert!((sea_level_static(100.0) - 20000.0).abs() < 1e-9);
        assert!((sea_level_static(25.0) - (1060.0 + 12680.0) / 2.0).abs() < 1e-9);
        // Mach 0.8 at 40 000 ft, maximum power: table node 6860 lbf.
        let node = engine.thrust_n(100.0, 0.8, 40_000.0 * M_PER_FT) / N_PER_LBF;
        assert!((node - 6860.0).abs() < 1e-9);
    }

    #[test]
    fn power_lag_regimes() {
        // Small rise in the core: 1/tau = 1.
        assert!((power_rate_pct_per_s(20.0, 30.0) - 10.0).abs() < 1e-12);
        // Rise between 25 and 50 %: linear blend of 1/tau.
        assert!((power_rate_pct_per_s(0.0, 49.0) - (1.9 - 0.036 * 49.0) * 49.0).abs() < 1e-12);
        // Rise of 50 % or more (toward the 60 % afterburner entry target): 1/tau = 0.1.
        assert!((power_rate_pct_per_s(5.0, 90.0) - 0.1 * 55.0).abs() < 1e-12);
        // Decrease in the core: always 1/tau = 1.
        assert!((power_rate_pct_per_s(45.0, 5.0) + 40.0).abs() < 1e-12);
        // Lighting the afterburner: target 60 %, rise 30 % gives 1/tau = 0.82.
        assert!((power_rate_pct_per_s(30.0, 90.0) - 0.82 * 30.0).abs() < 1e-12);
        // In the afterburner: 5 /s toward the command, or toward 40 % when leaving it.
        assert!((power_rate_pct_per_s(60.0, 80.0) - 100.0).abs() < 1e-12);
        assert!((power_rate_pct_per_s(60.0, 10.0) + 100.0).abs() < 1e-12);
        // Steady at the command.
        assert_eq!(power_rate_pct_per_s(17.0, 17.0), 0.0);
    }
}
