//! Fixed-point sin/cos tables over the full circle, built at compile time.
//!
//! Entry `k` holds `round(2¹⁵ · cos(2πk/N))` (Q15 in an `i32`, so `1.0` is
//! exactly `32768`). The second half is the exact negation of the first
//! (`table[k + N/2] == −table[k]`), which makes the accumulator's half-turn
//! symmetry bit-exact. Maximum error against the true value: `2⁻¹⁶ ≈ 1.5e-5`
//! (half an LSB; the f64 evaluation adds < 1e-15), checked for every entry by
//! the host tests.

use crate::config::PI;

/// Fraction bits of the tables (Q15).
pub const TRIG_FRACTION_BITS: u32 = 15;

/// cos and sin of `θ_k = 2πk/N`, `k ∈ [0, N)`, in Q15.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TrigTable<const N: usize> {
    cos: [i32; N],
    sin: [i32; N],
}

impl<const N: usize> TrigTable<N> {
    /// The table for `N` steps, evaluated at compile time.
    pub const TABLE: Self = Self::build();

    const fn build() -> Self {
        assert!(N >= 4 && N % 2 == 0, "N_THETA must be even and at least 4");
        let mut cos = [0i32; N];
        let mut sin = [0i32; N];
        let half = N / 2;
        let mut k = 0;
        while k < half {
            let theta = 2.0 * PI * (k as f64) / (N as f64);
            cos[k] = round_q15(cos_f64(theta));
            sin[k] = round_q15(sin_f64(theta));
            cos[k + half] = -cos[k];
            sin[k + half] = -sin[k];
            k += 1;
        }
        Self { cos, sin }
    }

    /// `cos(2πk/N)` in Q15; `k` is taken modulo `N`.
    pub const fn cos(&self, k: usize) -> i32 {
        self.cos[k % N]
    }

    /// `sin(2πk/N)` in Q15; `k` is taken modulo `N`.
    pub const fn sin(&self, k: usize) -> i32 {
        self.sin[k % N]
    }
}

/// Rounds to the nearest Q15 integer, ties away from zero (symmetric, so
/// `round_q15(−v) == −round_q15(v)`).
const fn round_q15(v: f64) -> i32 {
    let scaled = v * (1u32 << TRIG_FRACTION_BITS) as f64;
    if scaled >= 0.0 {
        (scaled + 0.5) as i32
    } else {
        -((-scaled + 0.5) as i32)
    }
}

/// `sin(θ)` for `θ ∈ [0, π]` in const context: folded to `[0, π/2]`, then a
/// 14-term Taylor series (error < 1e-16).
const fn sin_f64(theta: f64) -> f64 {
    let t = if theta > PI / 2.0 { PI - theta } else { theta };
    let t2 = t * t;
    let mut term = t;
    let mut sum = 0.0;
    let mut k = 1u32;
    while k < 28 {
        sum += term;
        term *= -t2 / ((k + 1) * (k + 2)) as f64;
        k += 2;
    }
    sum
}

/// `cos(θ)` for `θ ∈ [0, π]` in const context: `sin(π/2 − θ)` with the sign of
/// the quadrant.
const fn cos_f64(theta: f64) -> f64 {
    if theta <= PI / 2.0 {
        sin_f64(PI / 2.0 - theta)
    } else {
        -sin_f64(theta - PI / 2.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_table<const N: usize>() {
        let t = TrigTable::<N>::TABLE;
        let lsb = 1.0 / (1u32 << TRIG_FRACTION_BITS) as f64;
        for k in 0..N {
            let theta = core::f64::consts::TAU * k as f64 / N as f64;
            assert!(
                (t.cos(k) as f64 * lsb - theta.cos()).abs() <= 0.5 * lsb + 1e-12,
                "cos {k}/{N}"
            );
            assert!(
                (t.sin(k) as f64 * lsb - theta.sin()).abs() <= 0.5 * lsb + 1e-12,
                "sin {k}/{N}"
            );
            assert_eq!(t.cos(k + N / 2), -t.cos(k));
            assert_eq!(t.sin(k + N / 2), -t.sin(k));
        }
    }

    #[test]
    fn tables_are_within_half_an_lsb_and_half_turn_exact() {
        check_table::<8>();
        check_table::<128>();
        check_table::<360>();
        check_table::<512>();
        check_table::<720>();
    }

    #[test]
    fn exact_at_the_axes() {
        let t = TrigTable::<360>::TABLE;
        assert_eq!((t.cos(0), t.sin(0)), (32768, 0));
        assert_eq!((t.cos(90), t.sin(90)), (0, 32768));
    }
}
