//! Sine and cosine of a binary angle (2³² = one turn) for the scan
//! rasterizer: a full-circle table with linear interpolation, integer only
//! (no soft float on the Cortex-M0, no quadrant logic, no per-`N_θ` table as
//! in `trig`). 1025 entries of 4 bytes.
//!
//! Error bound, against the true value, for any angle: below 2.0·10⁻⁵
//! (in units of 1; the values are Q16). Its parts: the entries are rounded
//! to Q16 (2⁻¹⁷), the interpolation is rounded to Q16 (2⁻¹⁷), the chord of
//! a segment of 2π/1024 rad departs from the sine by at most
//! (2π/1024)²/8 < 4.8·10⁻⁶, and the angle is used to 2⁻²⁶ turn
//! (< 9.4·10⁻⁸ rad; the sine's slope is at most 1). Checked on a dense
//! sweep by the tests below.

use crate::math::{sin_f64, PI};

/// Fraction bits of the values (Q16: 1.0 is 65 536).
pub(crate) const SINE_FRACTION_BITS: u32 = 16;

/// Table segments per turn.
const SEGMENTS: usize = 1024;
/// Bits of a binary angle below the segment index.
const SEGMENT_BITS: u32 = 32 - SEGMENTS.trailing_zeros();
/// Bits of the interpolation fraction.
const FRACTION_BITS: u32 = 16;
/// A quarter turn, binary.
const QUARTER: u32 = 1 << 30;

/// `round(2¹⁶ · sin(2πk/1024))` for `k ∈ [0, 1024]` (ties away from zero,
/// so the table is odd-symmetric); the last entry closes the circle so that
/// the interpolation needs no wrap.
static TABLE: [i32; SEGMENTS + 1] = build();

const fn build() -> [i32; SEGMENTS + 1] {
    let mut t = [0i32; SEGMENTS + 1];
    let mut k = 0;
    // sin over [0, π] from the const series; the second half is the exact
    // negation of the first.
    while k <= SEGMENTS / 2 {
        let theta = 2.0 * PI * (k as f64) / (SEGMENTS as f64);
        let v = sin_f64(theta) * (1u32 << SINE_FRACTION_BITS) as f64;
        t[k] = (v + 0.5) as i32;
        if k > 0 && k < SEGMENTS / 2 {
            t[SEGMENTS - k] = -t[k];
        }
        k += 1;
    }
    t[SEGMENTS / 2] = 0;
    t[SEGMENTS] = 0;
    t
}

/// `sin` of the binary angle `a`, Q16.
#[inline(always)]
fn sine(a: u32) -> i32 {
    let index = (a >> SEGMENT_BITS) as usize;
    let fraction = ((a >> (SEGMENT_BITS - FRACTION_BITS)) & ((1 << FRACTION_BITS) - 1)) as i32;
    // `index < 1024`, so both reads are inside the table.
    let low = TABLE.get(index).copied().unwrap_or(0);
    let high = TABLE.get(index + 1).copied().unwrap_or(0);
    // |high − low| ≤ 403 and fraction < 2¹⁶: no overflow.
    low + (((high - low) * fraction + (1 << (FRACTION_BITS - 1))) >> FRACTION_BITS)
}

/// `(sin, cos)` of the binary angle `a` (2³² = one turn), Q16, within
/// 2.0·10⁻⁵ of the true values (see the module doc).
#[inline(always)]
pub(crate) fn sin_cos(a: u32) -> (i32, i32) {
    (sine(a), sine(a.wrapping_add(QUARTER)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sweep_is_within_the_bound() {
        let scale = f64::from(1u32 << SINE_FRACTION_BITS);
        let mut worst = 0.0f64;
        // 2¹⁶ angles per turn, off the table's nodes.
        for k in 0..(1u64 << 16) {
            let a = ((k << 16) as u32).wrapping_add(12_345);
            let phi = f64::from(a) / 4_294_967_296.0 * 2.0 * PI;
            let (s, c) = sin_cos(a);
            let es = (f64::from(s) / scale - sin_any(phi)).abs();
            let ec = (f64::from(c) / scale - sin_any(phi + PI / 2.0)).abs();
            worst = worst.max(es).max(ec);
        }
        assert!(worst < 2.0e-5, "{worst}");
        assert_eq!(sin_cos(0), (0, 65_536));
        assert_eq!(sin_cos(1 << 30), (65_536, 0));
        assert_eq!(sin_cos(1 << 31), (0, -65_536));
        assert_eq!(sin_cos(3 << 30), (-65_536, 0));
    }

    /// `sin` in f64 without std: the crate's series after reduction to [0, π].
    fn sin_any(phi: f64) -> f64 {
        let mut x = phi % (2.0 * PI);
        if x < 0.0 {
            x += 2.0 * PI;
        }
        if x <= PI {
            sin_f64(x)
        } else {
            -sin_f64(x - PI)
        }
    }
}
