//! Cheap replacements, exact or within a stated error, for the library calls the control
//! step used to make.
//!
//! Place in the data flow: none of its own; every stage of the step uses these instead of
//! `f32::min`/`f32::max` (a library call on the Cortex-M4, `fminf`/`fmaxf`) and
//! `libm::hypotf` (double-precision arithmetic, in software on the Cortex-M4's
//! single-precision FPU).
//!
//! - [`min_to`] and [`max_to`]: one comparison and a select. They equal `f32::min` and
//!   `f32::max` for every `x` (NaN included) when the bound is not NaN, which holds at every
//!   call site (bounds come from a validated configuration). Ties between `+0` and `-0`
//!   return `x` on every target; `f32::min`/`max` leave the sign of such a tie unspecified
//!   (on the host it differs between debug and release builds, and the Cortex-M4's
//!   `fminf`/`fmaxf` returned the bound), so the builds could differ there.
//! - [`HypotLimit`]: `libm::hypotf(a, b) > limit`, bit-exact for every input, in integer and
//!   single-precision arithmetic: the square root is replaced by thresholds found once, at
//!   construction, and `hypotf`'s double-precision sum of squares is rounded exactly as the
//!   FPU would, in 64-bit integers.
//!
//! - [`sin_cos`]: sine and cosine by their Taylor series for the angles the controller
//!   meets (attitude, flow angles, mount pitch: at most [`SIN_COS_MAX_RAD`], which the
//!   configuration's validation enforces): `libm`'s `sinf`/`cosf` with their argument
//!   reduction took 11 KB of flash.
//! - [`sqrt`] and [`exp_neg`]: not bit-exact but within one and 2.5 units in the last place
//!   of `libm`'s: `libm::sqrtf` computes in integers (about 50 instructions; `core` has no
//!   safe way to the FPU's square root) and `libm::expf` reduces its argument (53), where
//!   these take about 14 and 26 on the step's path (the gate's figure and prediction).
//!
//! Invariant: no data-dependent loops, no recursion, no panics, no allocation (the
//! construction of a [`HypotLimit`] loops a fixed 32 times per threshold, [`exp_neg`]'s
//! Horner scheme a fixed 11 times).

/// Largest angle [`sin_cos`] is used for, rad (46 degrees).
pub const SIN_COS_MAX_RAD: f32 = 0.8;

/// `(sin x, cos x)` by their Taylor series (to `x^9` and `x^10`, Horner's scheme: ten
/// multiply-adds, no division), for `|x| <=` [`SIN_COS_MAX_RAD`] within `1.2e-7` of the
/// exact values (tested against `libm`'s double precision), about one unit in the last place
/// of `f32`: the truncation (the next term, `x^11 / 11!`, 2e-9 at 0.8 rad) is below the
/// rounding. It grows quickly beyond (`7e-8` at 1.1 rad); the configuration's validation
/// keeps every angle the step meets within [`SIN_COS_MAX_RAD`].
#[inline]
pub fn sin_cos(x: f32) -> (f32, f32) {
    const S: [f32; 4] = [-1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0, 1.0 / 362_880.0];
    const C: [f32; 5] = [
        -1.0 / 2.0,
        1.0 / 24.0,
        -1.0 / 720.0,
        1.0 / 40_320.0,
        -1.0 / 3_628_800.0,
    ];
    let x2 = x * x;
    let s = x + x * x2 * (S[0] + x2 * (S[1] + x2 * (S[2] + x2 * S[3])));
    let c = 1.0 + x2 * (C[0] + x2 * (C[1] + x2 * (C[2] + x2 * (C[3] + x2 * C[4]))));
    (s, c)
}

/// `sqrt(x)` for a normal `x >= 0` (a subnormal one, below 1.2e-38, gives a root below 1.1e-20
/// but not within an ulp of it): Newton's iteration from the exponent halved (a bit shift of
/// the representation, within 3.5 % of the root), three steps (each squares the relative
/// error: 6e-4, 2e-7, then the rounding), within one unit in the last place of the correctly
/// rounded root (tested against `libm`'s double precision). `libm::sqrtf` is that rounded
/// root in integer arithmetic, about 50 instructions on the Cortex-M4 (which has a square
/// root instruction, but `core` gives no safe way to it); this is about 14. Zero and
/// infinity are their own roots (as IEEE 754 has them); a negative or NaN argument gives NaN.
#[inline]
pub fn sqrt(x: f32) -> f32 {
    if x > 0.0 && x < f32::INFINITY {
        // Halving the biased exponent (and the mantissa with it): the classic initial guess.
        let g = f32::from_bits((x.to_bits() >> 1) + 0x1FBD_1DF5);
        let g = 0.5 * (g + x / g);
        let g = 0.5 * (g + x / g);
        0.5 * (g + x / g)
    } else if x >= 0.0 {
        // Zero (either sign) and infinity are their own roots.
        x
    } else {
        f32::NAN
    }
}

/// Largest argument [`exp_neg`] is used for (the gate's horizon over the drogue model's
/// correlation time, which the configuration's validation keeps within 1.5).
pub const EXP_NEG_MAX: f32 = 1.5;

/// `exp(-x)` for `0 <= x <=` [`EXP_NEG_MAX`]: one over `exp(x)` by its Taylor series to the
/// twelfth power (Horner's scheme; all terms positive, so no cancellation; the truncation,
/// `1.5^13 / 13!`, is 7e-9 of the value), within 2.5 units in the last place (2.17 measured:
/// the rounding of twelve multiply-adds and the division; tested against
/// `libm`'s double precision). About 26 instructions where `libm::expf`, with its range
/// reduction, takes 53 on the Cortex-M4.
#[inline]
pub fn exp_neg(x: f32) -> f32 {
    const C: [f32; 12] = [
        1.0,
        1.0 / 2.0,
        1.0 / 6.0,
        1.0 / 24.0,
        1.0 / 120.0,
        1.0 / 720.0,
        1.0 / 5040.0,
        1.0 / 40_320.0,
        1.0 / 362_880.0,
        1.0 / 3_628_800.0,
        1.0 / 39_916_800.0,
        1.0 / 479_001_600.0,
    ];
    let mut acc = C[11];
    for k in (0..11).rev() {
        acc = C[k] + x * acc;
    }
    1.0 / (1.0 + x * acc)
}

/// `x.min(bound)` for a `bound` that is not NaN: one comparison, no call.
#[inline(always)]
pub fn min_to(x: f32, bound: f32) -> f32 {
    if x <= bound { x } else { bound }
}

/// `x.max(bound)` for a `bound` that is not NaN: one comparison, no call.
#[inline(always)]
pub fn max_to(x: f32, bound: f32) -> f32 {
    if x >= bound { x } else { bound }
}

/// `x.max(-limit).min(limit)` for a `limit` that is not negative or NaN. Inside the limit
/// (the common case) one integer comparison of magnitudes decides, without the FPU's
/// compare-and-transfer-flags pairs.
#[inline(always)]
pub fn clamp_sym(x: f32, limit: f32) -> f32 {
    let a = abs_bits(x);
    if a <= limit.to_bits() {
        x
    } else if (x.to_bits() as i32) < 0 || a > INF_BITS {
        // Below -limit, or NaN (which `max` replaces by -limit).
        -limit
    } else {
        limit
    }
}

/// Bits of `f32::INFINITY`: a magnitude's bits at or above it are not finite.
pub const INF_BITS: u32 = 0x7F80_0000;
/// Mask of everything but the sign bit.
pub const ABS_MASK: u32 = 0x7FFF_FFFF;

/// The bits of `|x|`: for finite or infinite values they order as the magnitudes do.
#[inline(always)]
pub fn abs_bits(x: f32) -> u32 {
    x.to_bits() & ABS_MASK
}

/// 2^90 and 2^-90: `hypotf`'s scalings of very large and very small arguments.
const X1P90: f32 = f32::from_bits(0x6c80_0000);
const X1P_90: f32 = f32::from_bits(0x1280_0000);

/// The scalings `hypotf` applies, in the order of [`HypotLimit`]'s thresholds.
const SCALES: [f32; 3] = [1.0, X1P90, X1P_90];

/// `libm::hypotf(a, b) > limit`, answered without `hypotf`.
///
/// `hypotf(x, y)` (x >= y >= 0 after taking magnitudes and sorting) returns, outside its
/// special cases, `z * sqrtf((x² + y²) computed in f64, rounded to f32)`, with `x` and `y`
/// first scaled by `1 / z` (`z` is 1, 2^90 or 2^-90). Both `sqrtf` and the multiplication by
/// `z` round monotonically, so `z * sqrtf(s) > limit` holds exactly when `s` exceeds a
/// threshold, one per scaling, found here once by bisection over the `f32` values. At run
/// time only the sum of squares is computed: the products of the 24-bit significands are
/// exact in 64-bit integers, and their sum is rounded to 53 bits and then to 24, each to
/// nearest-even, as the double-precision addition and the conversion to `f32` do.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HypotLimit {
    limit: f32,
    /// Per scaling: the bits of the smallest `s` (a positive `f32`) with
    /// `z * sqrtf(s) > limit`; `u32::MAX` when there is none.
    first_above: [u32; 3],
}

impl HypotLimit {
    /// The comparison with `limit` (any value, NaN and infinities included).
    pub fn new(limit: f32) -> Self {
        let first_above = SCALES.map(|z| {
            let above = |bits: u32| z * libm::sqrtf(f32::from_bits(bits)) > limit;
            if !above(INF_BITS) {
                return u32::MAX;
            }
            // Bisection over the non-negative floats, ordered as their bits: the predicate is
            // monotone; invariant: !above(lo) or lo == 0 untested, above(hi).
            if above(0) {
                return 0;
            }
            let (mut lo, mut hi) = (0u32, INF_BITS);
            for _ in 0..32 {
                if hi - lo <= 1 {
                    break;
                }
                let mid = lo + (hi - lo) / 2;
                if above(mid) {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            hi
        });
        Self { limit, first_above }
    }

    /// The limit compared with.
    pub fn limit(&self) -> f32 {
        self.limit
    }

    /// True exactly when `libm::hypotf(a, b) > self.limit()`.
    #[inline]
    pub fn exceeded_by(&self, a: f32, b: f32) -> bool {
        let (mut ux, mut uy) = (abs_bits(a), abs_bits(b));
        if ux < uy {
            core::mem::swap(&mut ux, &mut uy);
        }
        let (x, y) = (f32::from_bits(ux), f32::from_bits(uy));
        // hypotf's special cases: an infinity, a NaN, a zero, or magnitudes 2^25 apart.
        if uy == INF_BITS {
            return f32::INFINITY > self.limit;
        }
        if ux >= INF_BITS || uy == 0 || ux - uy >= 25 << 23 {
            return x + y > self.limit;
        }
        let (k, x, y) = if ux >= (0x7f + 60) << 23 {
            (1, x * X1P_90, y * X1P_90)
        } else if uy < (0x7f - 60) << 23 {
            (2, x * X1P90, y * X1P90)
        } else {
            (0, x, y)
        };
        sum_of_squares_bits(x, y) >= self.first_above[k]
    }
}

/// Whether `(my² << 15) >> d` drops set bits, for a significand `my` (24 bits, leading bit
/// set) and `d < 64`: `my²` ends in twice `my`'s trailing zeros, so the lowest set bit of
/// `my² << 15` is bit `15 + 2 tz`.
#[inline(always)]
fn shifts_out_set_bits(my: u32, d: u32) -> bool {
    15 + 2 * my.trailing_zeros() < d
}

/// The bits of `(x as f64 * x as f64 + y as f64 * y as f64) as f32` for normal `x >= y > 0`
/// whose squares and their sum lie in the normal range of `f32` (what `hypotf` computes
/// after its special cases and scaling), in integer arithmetic.
#[inline(always)]
fn sum_of_squares_bits(x: f32, y: f32) -> u32 {
    let (bx, by) = (x.to_bits(), y.to_bits());
    let (ex, ey) = (bx >> 23, by >> 23); // biased exponents, ex >= ey
    let mx = (bx & 0x007F_FFFF) | 0x0080_0000;
    let my = (by & 0x007F_FFFF) | 0x0080_0000;
    // x² = mx² 2^(2 ex - 300), exactly; likewise y². mx², my² lie in [2^46, 2^48).
    let (a, b) = (u64::from(mx) * u64::from(mx), u64::from(my) * u64::from(my));
    // Both squares on x²'s scale times 2^15 (the sum then fits 64 bits). The bits of y²
    // shifted out only matter as a sticky bit: they are non-zero exactly when y²'s trailing
    // zeros (twice my's) are fewer than the shift. d is 0..=50, except when y was subnormal
    // before hypotf scaled it up (then up to 96).
    let d = 2 * (ex - ey);
    let (t, sticky) = if d < 64 {
        ((a << 15) + ((b << 15) >> d), shifts_out_set_bits(my, d))
    } else {
        (a << 15, true)
    };
    // t has 61 to 64 bits: normalise it to 64, then round to 53 (double precision),
    // nearest-even, the sticky bit breaking ties.
    let n = t.leading_zeros(); // 0..=3
    let tn = t << n;
    let keep = tn >> 11;
    let rem = tn & 0x7FF;
    let up = rem > 0x400 || (rem == 0x400 && (sticky || keep & 1 == 1));
    let d53 = keep + u64::from(up); // 2^52..=2^53: exact in double precision
    // Round the double to 24 bits, nearest-even (no sticky: the double is exact).
    let m0 = d53 >> 29;
    let rem2 = d53 & 0x1FFF_FFFF;
    let up2 = rem2 > 0x1000_0000 || (rem2 == 0x1000_0000 && m0 & 1 == 1);
    let m = (m0 + u64::from(up2)) as u32; // 2^23..=2^24
    // Value: m 2^(2 ex - 300 - 15 + (11 - n) + 29). A significand of 2^24 carries into the
    // exponent, which the addition below does by itself (0x0080_0000 is the exponent's
    // lowest bit).
    let exponent = 2 * ex - 125 - n;
    (exponent << 23) + (m - 0x0080_0000)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_series_are_sine_and_cosine_over_their_range() {
        let n = 1600;
        for k in -n..=n {
            let x = SIN_COS_MAX_RAD * k as f32 / n as f32;
            let (s, c) = sin_cos(x);
            let (ws, wc) = (libm::sin(f64::from(x)), libm::cos(f64::from(x)));
            assert!(
                (f64::from(s) - ws).abs() < 1.2e-7 && (f64::from(c) - wc).abs() < 1.2e-7,
                "{x}: {s} {c}"
            );
            // "About one unit in the last place": the series' truncation is below the
            // rounding, so the error stays within 1.5 ulp of the exact value (1.04 measured;
            // a wrong sign of the last cosine term, x^10 / 10!, makes it 1.7).
            let ulp = |w: f64| {
                let v = (w as f32).abs();
                f64::from(v.next_up() - v)
            };
            assert!(
                (f64::from(s) - ws).abs() <= 1.5 * ulp(ws)
                    && (f64::from(c) - wc).abs() <= 1.5 * ulp(wc),
                "{x}: {s} {c}, {} and {} ulp",
                (f64::from(s) - ws).abs() / ulp(ws),
                (f64::from(c) - wc).abs() / ulp(wc)
            );
        }
    }

    #[test]
    fn the_square_root_is_within_an_ulp_of_the_rounded_root() {
        // Every 97th representable value from the smallest normal to 2^64, and the squares
        // of small integers (exact roots).
        let mut bits = f32::MIN_POSITIVE.to_bits();
        let mut worst = 0.0f64;
        while bits < 0x5F80_0000 {
            let x = f32::from_bits(bits);
            let want = libm::sqrt(f64::from(x));
            let ulp = f64::from((want as f32).next_up() - want as f32);
            let err = (f64::from(sqrt(x)) - want).abs() / ulp;
            assert!(err <= 1.0, "{x}: {} against {want}, {err} ulp", sqrt(x));
            worst = worst.max(err);
            bits += 97;
        }
        assert!(
            worst > 0.4,
            "the check saw no rounding error at all: {worst}"
        );
        for n in 0..=1000u16 {
            let n = f32::from(n);
            assert_eq!(sqrt(n * n), n);
        }
        assert_eq!(sqrt(0.0).to_bits(), 0.0f32.to_bits());
        assert_eq!(sqrt(-0.0).to_bits(), (-0.0f32).to_bits());
        assert_eq!(sqrt(f32::INFINITY), f32::INFINITY);
        assert!(sqrt(-1.0).is_nan() && sqrt(f32::NAN).is_nan());
    }

    #[test]
    fn exp_neg_is_the_exponential_over_its_range() {
        let n = 3000;
        let mut worst = 0.0f64;
        for k in 0..=n {
            let x = EXP_NEG_MAX * k as f32 / n as f32;
            let want = libm::exp(-f64::from(x));
            let ulp = f64::from((want as f32).next_up() - want as f32);
            let err = (f64::from(exp_neg(x)) - want).abs() / ulp;
            worst = worst.max(err);
            assert!(err <= 2.5, "{x}: {} against {want}, {err} ulp", exp_neg(x));
        }
        assert!(worst > 0.4, "no rounding seen: {worst}");
        assert_eq!(exp_neg(0.0), 1.0);
    }

    fn check(h: &HypotLimit, a: f32, b: f32) {
        assert_eq!(
            h.exceeded_by(a, b),
            libm::hypotf(a, b) > h.limit(),
            "hypotf({a:e}, {b:e}) = {:e} vs {:e}",
            libm::hypotf(a, b),
            h.limit()
        );
    }

    /// A small deterministic generator (xorshift), so the test needs no dependency.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> u32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 16) as u32
        }
    }

    #[test]
    fn min_max_match_the_std_ones_for_non_nan_bounds() {
        let v = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MIN_POSITIVE,
            3.5,
        ];
        for x in v {
            for b in v.into_iter().filter(|b| !b.is_nan()) {
                if x == 0.0 && b == 0.0 {
                    // A tie of zeros: std's sign is unspecified; ours is x's.
                    assert_eq!(min_to(x, b).to_bits(), x.to_bits(), "min({x}, {b})");
                    assert_eq!(max_to(x, b).to_bits(), x.to_bits(), "max({x}, {b})");
                } else {
                    assert_eq!(min_to(x, b).to_bits(), x.min(b).to_bits(), "min({x}, {b})");
                    assert_eq!(max_to(x, b).to_bits(), x.max(b).to_bits(), "max({x}, {b})");
                }
            }
        }
    }

    #[test]
    fn clamp_sym_matches_std_for_non_negative_limits() {
        let v = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            2.0,
            -2.0,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            1e-45,
            -1e-45,
        ];
        for x in v {
            for limit in [0.0, 1e-45, 1.0, 2.0, f32::INFINITY] {
                let got = clamp_sym(x, limit);
                if x.max(-limit).min(limit) == 0.0 {
                    // std's zero may come from a tie of zeros, whose sign it leaves
                    // unspecified; ours: x inside the limit, -limit for NaN (as `max` gives),
                    // else the limit with x's sign.
                    let want = if x.abs() <= limit {
                        x
                    } else if x.is_nan() {
                        -limit
                    } else {
                        limit.copysign(x)
                    };
                    assert_eq!(got.to_bits(), want.to_bits(), "clamp_sym({x}, {limit})");
                } else {
                    assert_eq!(
                        got.to_bits(),
                        x.max(-limit).min(limit).to_bits(),
                        "clamp_sym({x}, {limit})"
                    );
                }
            }
        }
    }

    #[test]
    fn sum_of_squares_rounds_as_double_then_single_precision() {
        let mut r = Rng(0x9E37_79B9_7F4A_7C15);
        for _ in 0..200_000 {
            let ex = 127 - 60 + r.next() % 120;
            let x = f32::from_bits((ex << 23) | (r.next() & 0x7F_FFFF));
            let y = f32::from_bits(
                (ex.saturating_sub(r.next() % 26).max(67) << 23) | (r.next() & 0x7F_FFFF),
            );
            let (x, y) = if y > x { (y, x) } else { (x, y) };
            let want = (f64::from(x) * f64::from(x) + f64::from(y) * f64::from(y)) as f32;
            assert_eq!(sum_of_squares_bits(x, y), want.to_bits(), "{x:e} {y:e}");
        }
        // hypotf's up-scaling of a subnormal y (and an x less than 2^25 ulps above it).
        for _ in 0..50_000 {
            let uy = 1 + r.next() % 0x007F_FFFF;
            let ux = uy + r.next() % (25 << 23);
            let (x, y) = (f32::from_bits(ux) * X1P90, f32::from_bits(uy) * X1P90);
            let want = (f64::from(x) * f64::from(x) + f64::from(y) * f64::from(y)) as f32;
            assert_eq!(sum_of_squares_bits(x, y), want.to_bits(), "{x:e} {y:e}");
        }
    }

    /// Whether `x² + y²` (exact, on a common integer scale) lies halfway between two
    /// doubles, and whether the double it rounds to lies halfway between two floats: the
    /// ties of the two roundings.
    fn ties(x: f32, y: f32) -> (bool, bool) {
        let (bx, by) = (x.to_bits(), y.to_bits());
        let m = |b: u32| u128::from((b & 0x007F_FFFF) | 0x0080_0000);
        let d = 2 * ((bx >> 23) - (by >> 23));
        let exact = ((m(bx) * m(bx)) << d) + m(by) * m(by);
        let width = 128 - exact.leading_zeros();
        let t53 = width > 53 && exact & ((1 << (width - 53)) - 1) == 1 << (width - 54);
        let double = f64::from(x) * f64::from(x) + f64::from(y) * f64::from(y);
        let t24 = double.to_bits() & 0x1FFF_FFFF == 0x1000_0000;
        (t53, t24)
    }

    #[test]
    fn sum_of_squares_rounds_ties_as_double_then_single_precision() {
        // Significands with at most two bits below the leading one make sums whose bits are
        // sparse: many of them fall exactly halfway at the rounding to 53 bits, or at the
        // rounding of the double to 24, where random significands (above) almost never do.
        // Every such pair, for gaps of exponent 0..=40, against the double-precision
        // reference; the ties are counted so that the test shows it reached them.
        let mut sparse = [0u32; 1 + 23 + 23 * 22 / 2];
        let mut n = 1;
        for i in 0..23 {
            sparse[n] = 1 << i;
            n += 1;
            for j in 0..i {
                sparse[n] = 1 << i | 1 << j;
                n += 1;
            }
        }
        assert_eq!(n, sparse.len());
        let (mut ties53, mut ties24) = (0u32, 0u32);
        for &fx in &sparse {
            let x = f32::from_bits(127 << 23 | fx);
            for gap in 0..=40u32 {
                for &fy in &sparse {
                    let y = f32::from_bits((127 - gap) << 23 | fy);
                    if y > x {
                        continue;
                    }
                    let want = (f64::from(x) * f64::from(x) + f64::from(y) * f64::from(y)) as f32;
                    assert_eq!(sum_of_squares_bits(x, y), want.to_bits(), "{x:e} {y:e}");
                    let (t53, t24) = ties(x, y);
                    ties53 += u32::from(t53);
                    ties24 += u32::from(t24);
                }
            }
        }
        assert!(ties53 > 1000 && ties24 > 1000, "ties {ties53} / {ties24}");
    }

    #[test]
    fn the_sticky_bit_is_set_exactly_when_the_shift_drops_a_set_bit() {
        // Every trailing-zero count of a significand, and the shifts the sum uses (even:
        // twice a difference of exponents), against the bits the shift really drops.
        for tz in 0..24 {
            for my in [0x0080_0000 | 1 << tz, 0x00FF_FFFF & !((1 << tz) - 1)] {
                let b = (u64::from(my) * u64::from(my)) << 15;
                for d in (0..64).step_by(2) {
                    let dropped = b & ((1u64 << d) - 1) != 0;
                    assert_eq!(shifts_out_set_bits(my, d), dropped, "{my:#x} >> {d}");
                }
            }
        }
        // End to end: x² = 1 + 2^-11 + 2^-24 lies halfway between two floats, and a y² just
        // above 2^-53 (a significand just above the square root of 2) puts the sum's bit
        // 2^-53 halfway between two doubles with set bits below it, shifted out of the
        // 64-bit sum: the double rounds up (sticky), and the float up from there. Without
        // the sticky bit both roundings would go to even, one float lower.
        let x = f32::from_bits(127 << 23 | 1 << 11);
        for m in 11_863_284u32..11_863_300 {
            let y = f32::from_bits((127 - 27) << 23 | (m & 0x007F_FFFF));
            let want = (f64::from(x) * f64::from(x) + f64::from(y) * f64::from(y)) as f32;
            assert_eq!(sum_of_squares_bits(x, y), want.to_bits(), "{x:e} {y:e}");
        }
        let y = f32::from_bits((127 - 27) << 23 | (11_863_284 & 0x007F_FFFF));
        assert_eq!(
            sum_of_squares_bits(x, y),
            f32::from_bits(127 << 23 | 1 << 12 | 1).to_bits()
        );
    }

    /// The four square roots of `c` modulo `2^bits` (`c` = 1 mod 8, `3 < bits < 64`): a root
    /// mod 8 lifted one bit at a time (if `r` is a root mod `2^k`, `r` or `r + 2^(k-1)` is one
    /// mod `2^(k+1)`), then its negation and both shifted by `2^(bits-1)`.
    fn square_roots_mod_2k(c: u64, bits: u32) -> [u64; 4] {
        let mut r = 1u64;
        for k in 3..bits {
            if r.wrapping_mul(r).wrapping_sub(c) & ((1 << (k + 1)) - 1) != 0 {
                r += 1 << (k - 1);
            }
        }
        let (m, half) = (1u64 << bits, 1u64 << (bits - 1));
        [r, m - r, (r + half) % m, (m - r + half) % m]
    }

    #[test]
    fn a_tie_at_53_bits_that_rounds_down_onto_a_tie_at_24_goes_to_even_twice() {
        // x² + y² exactly halfway between two doubles, the lower of which is exactly halfway
        // between two floats whose lower one is even: double rounding goes down both times.
        // With significands mx, my and y 2^-g below x, the sum is mx² 4^g + my² on an
        // integer scale; it has that shape when it is Q 2^30 + 2^29 + 1 with Q an even
        // 24-bit number. Pick mx, solve my² = 2^29 + 1 - mx² 4^g (mod 2^30) by lifting a
        // square root bit by bit, and keep the roots that are 24-bit significands.
        let mut found = 0;
        for g in [3u32, 4] {
            for mx in (0x0080_0000u64..0x0100_0000).step_by(4099) {
                let c = ((1u64 << 29) + 1).wrapping_sub((mx * mx) << (2 * g)) & ((1 << 30) - 1);
                for my in square_roots_mod_2k(c, 30) {
                    let p = ((mx * mx) << (2 * g)) + my * my;
                    let shape = p >> 30 & 1 == 0 && p & ((1 << 30) - 1) == (1 << 29) + 1;
                    if !(0x0080_0000..0x0100_0000).contains(&my) || p >> 53 != 1 || !shape {
                        continue;
                    }
                    let x = f32::from_bits(127 << 23 | (mx as u32 & 0x007F_FFFF));
                    let y = f32::from_bits((127 - g) << 23 | (my as u32 & 0x007F_FFFF));
                    assert_eq!(ties(x, y), (true, true), "{x:e} {y:e}");
                    let want = (f64::from(x) * f64::from(x) + f64::from(y) * f64::from(y)) as f32;
                    assert_eq!(sum_of_squares_bits(x, y), want.to_bits(), "{x:e} {y:e}");
                    found += 1;
                }
            }
        }
        assert!(found >= 20, "{found} cases (23 when written)");
    }

    #[test]
    fn a_double_rounded_down_onto_a_tie_at_24_bits_goes_to_the_even_float_above() {
        // x² + y² = Q 2^(30+j) + 2^(29+j) + 1 with Q odd: its double drops the final 1
        // (less than half a unit) and lies halfway between two floats, the lower one odd, so
        // the float rounds up to even. (A tie reached exactly, without the rounding to 53
        // bits, is always on an even float: the odd part of mx² 4^g + my² is 1 mod 4.) Solved
        // as the other ties are: my² = 2^(29+j) + 1 - mx² 4^g (mod 2^(30+j)).
        let mut found = 0;
        for g in 4u32..=6 {
            for j in 0u32..=8 {
                let bits = 30 + j;
                let target = (1u64 << (29 + j)) + 1;
                for mx in (0x0080_0000u64..0x0100_0000).step_by(8191) {
                    let c = target.wrapping_sub((mx * mx) << (2 * g)) & ((1 << bits) - 1);
                    for my in square_roots_mod_2k(c, bits) {
                        if !(0x0080_0000..0x0100_0000).contains(&my) {
                            continue;
                        }
                        let p = u128::from((mx * mx) << (2 * g)) + u128::from(my * my);
                        let shape = 128 - p.leading_zeros() == 54 + j
                            && p & ((1 << bits) - 1) == u128::from(target)
                            && (p >> bits) & 1 == 1;
                        if !shape {
                            continue;
                        }
                        let x = f32::from_bits(127 << 23 | (mx as u32 & 0x007F_FFFF));
                        let y = f32::from_bits((127 - g) << 23 | (my as u32 & 0x007F_FFFF));
                        assert_eq!(ties(x, y), (false, true), "{x:e} {y:e}");
                        let want =
                            (f64::from(x) * f64::from(x) + f64::from(y) * f64::from(y)) as f32;
                        assert_eq!(sum_of_squares_bits(x, y), want.to_bits(), "{x:e} {y:e}");
                        found += 1;
                    }
                }
            }
        }
        assert!(found >= 10, "{found} cases (11 when written)");
    }

    #[test]
    fn equals_hypotf_comparison_everywhere() {
        let mut r = Rng(0x2545_F491_4F6C_DD1D);
        let specials = [
            0.0,
            -0.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            f32::MAX,
            f32::MIN_POSITIVE,
            1e-45,
            0.3,
            -0.3,
            0.2121,
            1e30,
            1e-30,
            3e18,
            2e-19,
        ];
        let limits = [
            0.3,
            0.0,
            -1.0,
            1e-40,
            1e-30,
            1e20,
            f32::MAX,
            f32::INFINITY,
            f32::NAN,
        ];
        let random_limits: [f32; 40] =
            core::array::from_fn(|_| f32::from_bits(r.next() & ABS_MASK));
        for limit in limits.into_iter().chain(random_limits) {
            let h = HypotLimit::new(limit);
            for a in specials {
                for b in specials {
                    check(&h, a, b);
                }
            }
            for _ in 0..4_000 {
                check(&h, f32::from_bits(r.next()), f32::from_bits(r.next()));
                // Near the limit: points on (and about) the circle of radius `limit`.
                let t = (r.next() % 1000) as f32 / 1000.0;
                let (s, c) = (libm::sinf(t), libm::cosf(t));
                let l = if limit.is_finite() { limit } else { 1.0 };
                let (a, b) = (l * c, l * s);
                let nudge = |v: f32, k: u32| {
                    f32::from_bits(v.to_bits().wrapping_add(k % 5).wrapping_sub(2))
                };
                check(&h, nudge(a, r.next()), nudge(b, r.next()));
                check(&h, l, f32::from_bits(r.next() % 0x0200_0000));
            }
        }
    }
}
