//! Flight-computer binary (placeholder).
fn main() {}
