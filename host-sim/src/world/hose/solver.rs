//! The symmetric tridiagonal solve (Thomas algorithm) behind the link tensions and the
//! constraint projections of the hose.
//!
//! Place in the data flow: `dynamics` builds `J M^-1 J^T` for the current link vectors (one
//! row per link) and solves it here for the multipliers of the acceleration, position and
//! velocity constraints.
//!
//! Invariants: O(n), in place, no allocation and no pivoting: the matrices it is given are
//! symmetric positive definite and diagonally dominant, so every pivot is positive.

/// Solves the symmetric tridiagonal system with diagonal `diag` and off-diagonal `off`
/// (`off[k]` couples unknowns k and k + 1) in place of `rhs` (Thomas algorithm, O(n), no
/// pivoting: the matrices here are symmetric positive definite and diagonally dominant).
pub(super) fn solve_tridiagonal(diag: &[f64], off: &[f64], rhs: &mut [f64], scratch: &mut [f64]) {
    let n = rhs.len();
    // Cut to the lengths used, so that the loops carry no bounds checks.
    let (diag, off, scratch) = (&diag[..n], &off[..n.saturating_sub(1)], &mut scratch[..n]);
    let mut pivot = diag[0];
    rhs[0] /= pivot;
    for k in 1..n {
        scratch[k - 1] = off[k - 1] / pivot;
        pivot = diag[k] - off[k - 1] * scratch[k - 1];
        rhs[k] = (rhs[k] - off[k - 1] * rhs[k - 1]) / pivot;
    }
    for k in (0..n.saturating_sub(1)).rev() {
        rhs[k] -= scratch[k] * rhs[k + 1];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tridiagonal_solver_matches_a_dense_solve() {
        let diag = [4.0, 5.0, 3.0, 6.0];
        let off = [-1.0, 2.0, -0.5];
        let x = [1.0, -2.0, 0.5, 3.0];
        let mut rhs = [0.0; 4];
        for k in 0..4 {
            rhs[k] = diag[k] * x[k];
            if k > 0 {
                rhs[k] += off[k - 1] * x[k - 1];
            }
            if k < 3 {
                rhs[k] += off[k] * x[k + 1];
            }
        }
        let mut scratch = [0.0; 4];
        solve_tridiagonal(&diag, &off, &mut rhs, &mut scratch);
        for k in 0..4 {
            assert!((rhs[k] - x[k]).abs() < 1e-14, "{rhs:?}");
        }
    }
}
