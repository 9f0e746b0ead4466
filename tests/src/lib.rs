//! Closed-loop tests (placeholder).
