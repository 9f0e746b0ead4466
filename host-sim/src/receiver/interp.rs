//! Table lookup for the F-16 data: linear interpolation in each axis on a strictly increasing
//! grid, extrapolated linearly from the nearest edge cell outside the grid.
//!
//! Source: the lookup rule stated at the top of `data/f16-lofi-data.toml`.
//! Invariants: grids have at least two nodes (checked at compile time) and are finite and strictly
//! increasing (checked when the data file is loaded); value and grid lengths agree by type.
//! Lookups never allocate; a NaN query gives NaN, never a panic.

/// Cell `grid[i]..grid[i + 1]` used for `x` and the position of `x` in it: 0 at the lower node,
/// 1 at the upper, below 0 or above 1 when extrapolating from an edge cell.
fn cell<const N: usize>(grid: &[f64; N], x: f64) -> (usize, f64) {
    const { assert!(N >= 2, "a lookup grid needs at least two nodes") };
    let i = grid
        .partition_point(|&node| node <= x)
        .saturating_sub(1)
        .min(N - 2);
    (i, (x - grid[i]) / (grid[i + 1] - grid[i]))
}

/// `values` (sampled at `grid`) interpolated at `x`.
pub(crate) fn interp1<const N: usize>(grid: &[f64; N], values: &[f64; N], x: f64) -> f64 {
    let (i, t) = cell(grid, x);
    blend(values[i], values[i + 1], t)
}

/// `(1 - t) a + t b`: this form returns `a` and `b` exactly at `t` = 0 and 1 (grid nodes).
fn blend(a: f64, b: f64, t: f64) -> f64 {
    (1.0 - t) * a + t * b
}

/// Bilinear lookup of `table[row][col]`, rows sampled at `row_grid`, columns at `col_grid`.
pub(crate) fn interp2<const R: usize, const C: usize>(
    row_grid: &[f64; R],
    col_grid: &[f64; C],
    table: &[[f64; C]; R],
    row_x: f64,
    col_x: f64,
) -> f64 {
    let (i, t) = cell(row_grid, row_x);
    blend(
        interp1(col_grid, &table[i], col_x),
        interp1(col_grid, &table[i + 1], col_x),
        t,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const GRID: [f64; 4] = [-10.0, 0.0, 5.0, 20.0];
    const VALUES: [f64; 4] = [3.0, -1.0, 4.0, 1.0];
    const COLS: [f64; 3] = [0.0, 1.0, 3.0];
    const TABLE: [[f64; 3]; 4] = [
        [0.0, 1.0, 2.0],
        [5.0, -2.0, 7.0],
        [1.0, 1.0, 1.0],
        [-4.0, 8.0, 0.5],
    ];

    #[test]
    fn exact_at_nodes() {
        for (node, value) in GRID.iter().zip(VALUES) {
            assert_eq!(interp1(&GRID, &VALUES, *node), value);
        }
        for (row, row_values) in GRID.iter().zip(TABLE) {
            for (col, value) in COLS.iter().zip(row_values) {
                assert_eq!(interp2(&GRID, &COLS, &TABLE, *row, *col), value);
            }
        }
    }

    #[test]
    fn linear_between_nodes() {
        // A quarter of the way from 5 (value 4) to 20 (value 1).
        assert!((interp1(&GRID, &VALUES, 8.75) - 3.25).abs() < 1e-12);
        // Centre of the cell rows 0..5, cols 1..3: mean of its four corners.
        let centre = interp2(&GRID, &COLS, &TABLE, 2.5, 2.0);
        assert!((centre - (-2.0 + 7.0 + 1.0 + 1.0) / 4.0).abs() < 1e-12);
    }

    #[test]
    fn extrapolates_from_edge_cells() {
        // Below: slope of the first cell is (-1 - 3)/10 = -0.4 per unit.
        assert!((interp1(&GRID, &VALUES, -15.0) - 5.0).abs() < 1e-12);
        // Above: slope of the last cell is (1 - 4)/15 = -0.2 per unit.
        assert!((interp1(&GRID, &VALUES, 30.0) - (-1.0)).abs() < 1e-12);
        // Column extrapolation in the last row: slope (0.5 - 8)/2 beyond col 3.
        assert!((interp2(&GRID, &COLS, &TABLE, 20.0, 5.0) - (0.5 - 7.5)).abs() < 1e-12);
    }

    proptest! {
        /// A table sampled from a bilinear function reproduces it everywhere, in and outside
        /// the grid: the lookup is exactly bilinear with edge-cell extrapolation.
        #[test]
        fn reproduces_bilinear_functions(
            a in -5.0..5.0f64, b in -5.0..5.0f64, c in -5.0..5.0f64, d in -5.0..5.0f64,
            x in -40.0..60.0f64, y in -5.0..8.0f64,
        ) {
            let f = |x: f64, y: f64| a + b * x + c * y + d * x * y;
            let table = GRID.map(|row| COLS.map(|col| f(row, col)));
            let looked_up = interp2(&GRID, &COLS, &table, x, y);
            prop_assert!((looked_up - f(x, y)).abs() < 1e-9 * (1.0 + f(x, y).abs()));
        }
    }
}
