//! The checked-in generated gains module must be exactly what a fresh synthesis produces.

use host_sim::synthesis::{codegen, core_gains_module};

#[test]
fn gains_file_is_fresh() {
    let fresh = core_gains_module().expect("synthesis");
    let checked_in = include_str!("../../core/src/gains.rs");
    assert!(
        fresh == checked_in,
        "core/src/gains.rs is stale: regenerate it with `{}`\n--- fresh ---\n{fresh}",
        codegen::REGENERATE
    );
}
