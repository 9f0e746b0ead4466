//! The checked-in generated gains module must be exactly what a fresh synthesis produces.

use host_sim::receiver::F16;
use host_sim::synthesis::schedule::synthesize_schedule;
use host_sim::synthesis::{
    NOMINAL_XCG, REFUELLING_DESIGN_XCG, codegen, nominal, nominal_refuelling,
};

#[test]
fn gains_file_is_fresh() {
    let fresh = codegen::render(
        &nominal().expect("nominal synthesis"),
        &nominal_refuelling().expect("refuelling synthesis"),
        &synthesize_schedule(
            &F16::new(NOMINAL_XCG).expect("model"),
            &F16::new(REFUELLING_DESIGN_XCG).expect("model"),
        )
        .expect("schedule"),
    );
    let checked_in = include_str!("../../core/src/gains.rs");
    assert!(
        fresh == checked_in,
        "core/src/gains.rs is stale: regenerate it with `{}`\n--- fresh ---\n{fresh}",
        codegen::REGENERATE
    );
}
