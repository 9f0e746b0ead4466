//! The few 3-vector operations of the hose model that nalgebra does not spell the way the
//! model needs them, on `nalgebra::Vector3<f64>`.
//!
//! Place in the data flow: used by `steady` (directions of the links) and `mod`'s input
//! checks; the arithmetic of `dynamics` and `drag` is nalgebra's own operators.
//!
//! Invariants: the hose's results are bit-for-bit those of the model as first written with
//! its own 3-vector type, whose dot product was `x x' + y y' + z z'` summed left to right and
//! whose norm was the square root of that. nalgebra's `dot`, `norm_squared` and `norm` on a
//! `Vector3<f64>` round exactly so (the tests below pin it, so that a nalgebra upgrade that
//! reorders them is caught); its `normalize` divides by the norm where the model multiplies by
//! the reciprocal, so the model keeps `v * (1.0 / v.norm())` written out.

use nalgebra::Vector3;

/// The unit vector along `v` (`v * (1 / |v|)`), or `fallback` if `v` has no direction (zero
/// or non-finite length).
pub(super) fn unit_or(v: &Vector3<f64>, fallback: Vector3<f64>) -> Vector3<f64> {
    let n = v.norm();
    if n > 0.0 && n.is_finite() {
        v * (1.0 / n)
    } else {
        fallback
    }
}

/// Whether every component of `v` is finite.
pub(super) fn all_finite(v: &Vector3<f64>) -> bool {
    v.x.is_finite() && v.y.is_finite() && v.z.is_finite()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A vector with components of random sign and of magnitudes spread over 1e-8..1e8, so
    /// that a different summation order rounds differently for many samples.
    fn random_vector(rng: &mut ChaCha8Rng) -> Vector3<f64> {
        let mut c = || {
            let magnitude = 10f64.powf(rng.random_range(-8.0..8.0));
            let mantissa: f64 = rng.random_range(1.0..2.0);
            if rng.random::<bool>() {
                magnitude * mantissa
            } else {
                -magnitude * mantissa
            }
        };
        Vector3::new(c(), c(), c())
    }

    #[test]
    fn nalgebra_dot_and_norm_round_as_the_left_to_right_sum() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut reordered_differs = 0;
        for _ in 0..100_000 {
            let (a, b) = (random_vector(&mut rng), random_vector(&mut rng));
            let dot = a.x * b.x + a.y * b.y + a.z * b.z;
            assert_eq!(a.dot(&b).to_bits(), dot.to_bits(), "{a:?} . {b:?}");
            let sq = a.x * a.x + a.y * a.y + a.z * a.z;
            assert_eq!(a.norm_squared().to_bits(), sq.to_bits(), "{a:?}");
            assert_eq!(a.norm().to_bits(), sq.sqrt().to_bits(), "{a:?}");
            // The samples are sensitive to the order: another one rounds differently often.
            if (a.x * b.x + (a.y * b.y + a.z * b.z)).to_bits() != dot.to_bits() {
                reordered_differs += 1;
            }
        }
        assert!(reordered_differs > 1000, "{reordered_differs}");
    }

    #[test]
    fn unit_or_multiplies_by_the_reciprocal_and_falls_back() {
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let mut divide_differs = 0;
        for _ in 0..10_000 {
            let v = random_vector(&mut rng);
            let u = unit_or(&v, Vector3::zeros());
            let r = 1.0 / v.norm();
            for i in 0..3 {
                assert_eq!(u[i].to_bits(), (v[i] * r).to_bits());
            }
            if v.normalize() != u {
                divide_differs += 1;
            }
        }
        // nalgebra's `normalize` is not a drop-in replacement (it divides).
        assert!(divide_differs > 100, "{divide_differs}");
        let fallback = Vector3::new(0.0, 0.0, 1.0);
        assert_eq!(unit_or(&Vector3::zeros(), fallback), fallback);
        assert_eq!(
            unit_or(&Vector3::new(f64::NAN, 0.0, 0.0), fallback),
            fallback
        );
        assert_eq!(
            unit_or(&Vector3::new(f64::INFINITY, 0.0, 0.0), fallback),
            fallback
        );
        assert!(all_finite(&Vector3::new(1.0, -2.0, 0.0)));
        assert!(!all_finite(&Vector3::new(1.0, f64::NAN, 0.0)));
        assert!(!all_finite(&Vector3::new(1.0, 0.0, f64::NEG_INFINITY)));
    }
}
