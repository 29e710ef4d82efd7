//! Sine and cosine of a binary angle (2³² = one turn) for the scan
//! rasterizer: a quarter-wave table with linear interpolation, integer only
//! (no soft float on the Cortex-M0, no per-`N_θ` table as in `trig`).
//!
//! Error bound, against the true value, for any angle: below 2.1·10⁻⁵
//! (in units of 1; the table is Q16). Its parts: the entries are rounded to
//! Q16 (2⁻¹⁷), the interpolation is rounded to Q16 (2⁻¹⁷), the chord of a
//! segment of π/512 rad lies below the sine by at most (π/512)²/8 < 4.8·10⁻⁶,
//! and the angle is used to 2⁻²⁶ turn (< 9.4·10⁻⁸ rad, the sine's slope is at
//! most 1). Checked on a dense sweep by the tests below.

use crate::math::sin_f64;

/// Fraction bits of the values (Q16: 1.0 is 65 536).
pub(crate) const SINE_FRACTION_BITS: u32 = 16;

/// Table segments per quarter turn.
const SEGMENTS: usize = 256;
/// Bits of a binary angle within a quarter turn.
const QUARTER_BITS: u32 = 30;
/// Bits of an in-quarter angle below the segment index.
const SEGMENT_BITS: u32 = QUARTER_BITS - SEGMENTS.trailing_zeros();
/// Bits of the interpolation fraction.
const FRACTION_BITS: u32 = 16;

/// `round(2¹⁶ · sin(k·π/512))` for `k ∈ [0, 257]`: one entry past the
/// quarter so that the interpolation at π/2 (fraction 0) needs no branch.
const TABLE: [u32; SEGMENTS + 2] = build();

const fn build() -> [u32; SEGMENTS + 2] {
    let mut t = [0u32; SEGMENTS + 2];
    let mut k = 0;
    while k < SEGMENTS + 2 {
        let theta = crate::math::PI / 2.0 * (k as f64) / (SEGMENTS as f64);
        let v = sin_f64(theta) * (1u32 << SINE_FRACTION_BITS) as f64;
        t[k] = (v + 0.5) as u32;
        k += 1;
    }
    t
}

/// `sin` of the in-quarter angle `p ∈ [0, 2³⁰]` (2³⁰ = π/2), Q16.
#[inline(always)]
fn quarter_sine(p: u32) -> i32 {
    let index = (p >> SEGMENT_BITS) as usize;
    let fraction = ((p >> (SEGMENT_BITS - FRACTION_BITS)) & ((1 << FRACTION_BITS) - 1)) as i32;
    // `index ≤ 256`, so both reads are inside the table.
    let low = TABLE.get(index).copied().unwrap_or(0) as i32;
    let high = TABLE.get(index + 1).copied().unwrap_or(0) as i32;
    // |high − low| ≤ 403 and fraction < 2¹⁶: no overflow.
    low + (((high - low) * fraction + (1 << (FRACTION_BITS - 1))) >> FRACTION_BITS)
}

/// `(sin, cos)` of the binary angle `a` (2³² = one turn), Q16, within
/// 2.1·10⁻⁵ of the true values (see the module doc).
#[inline(always)]
pub(crate) fn sin_cos(a: u32) -> (i32, i32) {
    let p = a & ((1 << QUARTER_BITS) - 1);
    let s = quarter_sine(p);
    let c = quarter_sine((1 << QUARTER_BITS) - p);
    match a >> QUARTER_BITS {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sweep_is_within_the_bound() {
        let scale = f64::from(1u32 << SINE_FRACTION_BITS);
        let mut worst = 0.0f64;
        // Every 2¹⁹-th binary angle plus an odd offset: 8192 angles per turn,
        // off the table's nodes.
        for k in 0..(1u64 << 13) {
            let a = ((k << 19) as u32).wrapping_add(12_345);
            let phi = f64::from(a) / 4_294_967_296.0 * core::f64::consts::TAU;
            let (s, c) = sin_cos(a);
            let es = (f64::from(s) / scale - libm_sin(phi)).abs();
            let ec = (f64::from(c) / scale - libm_sin(phi + core::f64::consts::FRAC_PI_2)).abs();
            worst = worst.max(es).max(ec);
        }
        assert!(worst < 2.1e-5, "{worst}");
        assert_eq!(sin_cos(0), (0, 65_536));
        assert_eq!(sin_cos(1 << 30), (65_536, 0));
        assert_eq!(sin_cos(1 << 31), (0, -65_536));
        assert_eq!(sin_cos(3 << 30), (-65_536, 0));
    }

    /// `sin` in f64 without std: the crate's series after reduction to [0, π].
    fn libm_sin(phi: f64) -> f64 {
        let tau = core::f64::consts::TAU;
        let mut x = phi % tau;
        if x < 0.0 {
            x += tau;
        }
        if x <= core::f64::consts::PI {
            sin_f64(x)
        } else {
            -sin_f64(x - core::f64::consts::PI)
        }
    }
}
