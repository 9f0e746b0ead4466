//! The checked-in generated gains module must be exactly what a fresh synthesis produces.

use host_sim::synthesis::{codegen, nominal, nominal_refuelling};

#[test]
fn gains_file_is_fresh() {
    let fresh = codegen::render(
        &nominal().expect("nominal synthesis"),
        &nominal_refuelling().expect("refuelling synthesis"),
    );
    let checked_in = include_str!("../../core/src/gains.rs");
    assert!(
        fresh == checked_in,
        "core/src/gains.rs is stale: regenerate it with `{}`\n--- fresh ---\n{fresh}",
        codegen::REGENERATE
    );
}
