//! Linear-algebra steps of the gain synthesis: zero-order-hold discretisation, the discrete
//! algebraic Riccati equation (DARE) and central-difference Jacobians.
//!
//! All in `f64` on dynamically sized nalgebra matrices (sizes here are at most 8x8).
//! Invariant: functions either return a result that meets its stated accuracy or a named
//! error; nothing is silently approximate.

use nalgebra::DMatrix;

/// Why a Riccati solution could not be found.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum DareError {
    /// `R`, or `I + G H` during the iteration, was singular.
    #[error(
        "singular matrix in the Riccati iteration (R not positive definite, or no stabilising solution)"
    )]
    Singular,
    /// The doubling iteration did not converge.
    #[error("Riccati doubling iteration did not converge after {0} iterations")]
    NoConvergence(usize),
}

/// Zero-order-hold discretisation of `x' = A x + B u` at period `ts_s`:
/// `Ad = e^(A ts)`, `Bd = (integral_0^ts e^(A s) ds) B`, from the exponential of the block
/// matrix `[[A, B], [0, 0]] ts`.
pub fn zoh(a: &DMatrix<f64>, b: &DMatrix<f64>, ts_s: f64) -> (DMatrix<f64>, DMatrix<f64>) {
    let (n, m) = (a.nrows(), b.ncols());
    let mut blk = DMatrix::zeros(n + m, n + m);
    blk.view_mut((0, 0), (n, n)).copy_from(&(a * ts_s));
    blk.view_mut((0, n), (n, m)).copy_from(&(b * ts_s));
    let e = blk.exp();
    (
        e.view((0, 0), (n, n)).into_owned(),
        e.view((0, n), (n, m)).into_owned(),
    )
}

/// Stabilising solution `P` of the DARE
/// `P = A'PA - A'PB (R + B'PB)^-1 B'PA + Q` by the structure-preserving doubling algorithm
/// (quadratic convergence), followed by the optimal gain `K = (R + B'PB)^-1 B'PA` for
/// `u = -K x`.
pub fn dare(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
) -> Result<(DMatrix<f64>, DMatrix<f64>), DareError> {
    const MAX_ITER: usize = 100;
    let n = a.nrows();
    let r_inv = r.clone().try_inverse().ok_or(DareError::Singular)?;
    let (mut ak, mut gk, mut hk) = (a.clone(), b * &r_inv * b.transpose(), q.clone());
    let eye = DMatrix::<f64>::identity(n, n);
    let mut converged = false;
    for _ in 0..MAX_ITER {
        let w = (&eye + &gk * &hk)
            .try_inverse()
            .ok_or(DareError::Singular)?;
        let a_next = &ak * &w * &ak;
        let g_next = &gk + &ak * &w * &gk * ak.transpose();
        let h_next = &hk + ak.transpose() * &hk * &w * &ak;
        let change = (&h_next - &hk).norm() / h_next.norm().max(f64::MIN_POSITIVE);
        (ak, gk, hk) = (a_next, g_next, h_next);
        if change < 1e-15 {
            converged = true;
            break;
        }
    }
    if !converged {
        return Err(DareError::NoConvergence(MAX_ITER));
    }
    let p = (&hk + hk.transpose()) * 0.5;
    let k = (r + b.transpose() * &p * b)
        .try_inverse()
        .ok_or(DareError::Singular)?
        * b.transpose()
        * &p
        * a;
    Ok((p, k))
}

/// Relative residual of a DARE solution: `|A'PA - P - A'PB(R+B'PB)^-1 B'PA + Q| / |P|`
/// (Frobenius norms). Returns infinity when the inverse does not exist.
pub fn dare_residual(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
    p: &DMatrix<f64>,
) -> f64 {
    let Some(s_inv) = (r + b.transpose() * p * b).try_inverse() else {
        return f64::INFINITY;
    };
    let res = a.transpose() * p * a - p - a.transpose() * p * b * s_inv * b.transpose() * p * a + q;
    res.norm() / p.norm()
}

/// Central-difference Jacobian of `f: R^n -> R^m` at `x0`, with step `steps[j]` for input j.
pub fn jacobian(f: impl Fn(&[f64]) -> Vec<f64>, x0: &[f64], steps: &[f64]) -> DMatrix<f64> {
    let m = f(x0).len();
    let mut jac = DMatrix::zeros(m, x0.len());
    let mut x = x0.to_vec();
    for j in 0..x0.len() {
        let h = steps[j];
        x[j] = x0[j] + h;
        let fp = f(&x);
        x[j] = x0[j] - h;
        let fm = f(&x);
        x[j] = x0[j];
        for i in 0..m {
            jac[(i, j)] = (fp[i] - fm[i]) / (2.0 * h);
        }
    }
    jac
}

/// Spectral radius (largest eigenvalue modulus) of a square matrix.
pub fn spectral_radius(a: &DMatrix<f64>) -> f64 {
    a.complex_eigenvalues()
        .iter()
        .map(|e| e.norm())
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zoh_of_a_double_integrator_is_exact() {
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, 0.0]);
        let b = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
        let (ad, bd) = zoh(&a, &b, 0.1);
        assert!((ad - DMatrix::from_row_slice(2, 2, &[1.0, 0.1, 0.0, 1.0])).norm() < 1e-14);
        assert!((bd - DMatrix::from_row_slice(2, 1, &[0.005, 0.1])).norm() < 1e-14);
    }

    #[test]
    fn zoh_of_a_first_order_lag_is_exact() {
        let (ad, bd) = zoh(
            &DMatrix::from_element(1, 1, -2.0),
            &DMatrix::from_element(1, 1, 2.0),
            0.3,
        );
        assert!((ad[(0, 0)] - (-0.6f64).exp()).abs() < 1e-14);
        assert!((bd[(0, 0)] - (1.0 - (-0.6f64).exp())).abs() < 1e-14);
    }

    #[test]
    fn dare_matches_the_scalar_closed_form() {
        // Scalar: p = a^2 p - a^2 p^2 b^2/(r + b^2 p) + q, solved as a quadratic.
        let (a, b, q, r) = (1.2_f64, 0.5, 2.0, 3.0);
        let (p, k) = dare(
            &DMatrix::from_element(1, 1, a),
            &DMatrix::from_element(1, 1, b),
            &DMatrix::from_element(1, 1, q),
            &DMatrix::from_element(1, 1, r),
        )
        .unwrap();
        // b^2 p^2 + (r - a^2 r - q b^2) p - q r = 0
        let (qa, qb, qc) = (b * b, r - a * a * r - q * b * b, -q * r);
        let p_exact = (-qb + (qb * qb - 4.0 * qa * qc).sqrt()) / (2.0 * qa);
        assert!((p[(0, 0)] - p_exact).abs() < 1e-10 * p_exact);
        assert!((a - b * k[(0, 0)]).abs() < 1.0, "closed loop stable");
    }

    #[test]
    fn dare_residual_is_small_on_a_random_system() {
        let a = DMatrix::from_row_slice(3, 3, &[1.01, 0.02, 0.0, 0.0, 0.98, 0.1, 0.05, 0.0, 1.0]);
        let b = DMatrix::from_row_slice(3, 2, &[0.0, 0.1, 0.02, 0.0, 0.1, 0.05]);
        let q = DMatrix::identity(3, 3);
        let r = DMatrix::identity(2, 2) * 0.5;
        let (p, k) = dare(&a, &b, &q, &r).unwrap();
        assert!(dare_residual(&a, &b, &q, &r, &p) < 1e-12);
        assert!(spectral_radius(&(&a - &b * &k)) < 1.0);
    }

    #[test]
    fn jacobian_of_a_known_function() {
        let j = jacobian(
            |x| vec![x[0] * x[1], x[0].sin()],
            &[0.5, 2.0],
            &[1e-6, 1e-6],
        );
        let want = DMatrix::from_row_slice(2, 2, &[2.0, 0.5, 0.5f64.cos(), 0.0]);
        assert!((j - want).norm() < 1e-8);
    }
}
