//! Helpers shared by the fuzzing tests (`fuzz_measurement.rs`, `fuzz_step.rs`): the case
//! count of a property from the environment, and arbitrary `f32` bit patterns.

use proptest::prelude::*;
use proptest::test_runner::Config;

/// A proptest configuration of `var` cases (the environment variable, when set and a
/// number) or `default`; failures are not persisted (CI runs from a clean tree).
pub fn cases(var: &str, default: u32) -> Config {
    let n = std::env::var(var)
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default);
    Config {
        cases: n,
        failure_persistence: None,
        ..Config::default()
    }
}

/// Any `f32` bit pattern: NaNs of every payload, infinities, subnormals, both zeros.
pub fn bits() -> impl Strategy<Value = f32> {
    any::<u32>().prop_map(f32::from_bits)
}
