//! Criterion benchmark of one controller step on the host (placeholder, filled in below).
fn main() {}
