//! English-to-SI conversion factors, applied where the receiver model meets its SI interface.
//!
//! Source: exact definitions (NIST SP 811): 1 ft = 0.3048 m, 1 lbf = 4.448 221 615 260 5 N;
//! 1 slug = 1 lbf s^2 / ft by definition of the slug.
//! Invariant: every English-unit number from the data file passes through one of these factors
//! before it appears in a public type; nothing public carries English units.

/// Metres per foot (exact).
pub(crate) const M_PER_FT: f64 = 0.3048;
/// Newtons per pound-force (exact).
pub(crate) const N_PER_LBF: f64 = 4.448_221_615_260_5;
/// Kilograms per slug (1 slug = 1 lbf s^2/ft).
pub(crate) const KG_PER_SLUG: f64 = N_PER_LBF / M_PER_FT;
/// kg m^2 per slug ft^2 (moments of inertia, and angular momentum per second).
pub(crate) const KG_M2_PER_SLUG_FT2: f64 = KG_PER_SLUG * M_PER_FT * M_PER_FT;
/// kg/m^3 per slug/ft^3 (density).
pub(crate) const KG_M3_PER_SLUG_FT3: f64 = KG_PER_SLUG / (M_PER_FT * M_PER_FT * M_PER_FT);
