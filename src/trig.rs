//! Fixed-point sin/cos tables over the full circle, built at compile time.
//!
//! Entry `k` holds `round(2¹⁵ · cos(2πk/N))` (Q15 in an `i32`, so `1.0` is
//! exactly `32768`). The second half is the exact negation of the first
//! (`table[k + N/2] == −table[k]`), which makes the accumulator's half-turn
//! symmetry bit-exact. Maximum error against the true value: `2⁻¹⁶ ≈ 1.5e-5`
//! (half an LSB; the f64 evaluation adds < 1e-15), checked for every entry by
//! the host tests.

use crate::angle::Angle;
use crate::math::{cos_f64, sin_f64, PI};

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
/// `(cos α, sin α)` in Q15 for any binary angle: the nearest entry of the
/// `N`-step table turned by the remainder `δ` (`|δ| ≤ π/N`) with
/// `cos δ ≈ 1 − δ²/2`, `sin δ ≈ δ` (error < 2·10⁻⁵ for `N ≥ 90`).
pub(crate) fn sin_cos_q15<const N: usize>(alpha: Angle) -> (i32, i32) {
    let table = &TrigTable::<N>::TABLE;
    let k = alpha.nearest_step(N);
    let base = Angle::from_steps_q16((k as i64) << 16, N);
    // δ in binary turns (2³² a turn) → Q15 radians: × 2π·2¹⁵/2³² = × π/2¹⁶,
    // with π·2²⁹ = 1 686 629 713 (|δ| ≤ 2³¹/N: the product fits i64).
    let delta = i64::from(alpha.0.wrapping_sub(base.0) as i32);
    let delta_q15 = (delta * 1_686_629_713) >> 45;
    let (c, s) = (i64::from(table.cos(k)), i64::from(table.sin(k)));
    let half_sq = (delta_q15 * delta_q15) >> 16; // δ²/2, Q15
    let cos_d = (1 << 15) - half_sq;
    let cos = (c * cos_d - s * delta_q15) >> 15;
    let sin = (s * cos_d + c * delta_q15) >> 15;
    (cos as i32, sin as i32)
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
    #[test]
    fn sin_cos_between_steps() {
        for deg in [0.0f32, 0.4, 1.3, 45.5, 91.7, 179.9, 200.25, 359.6] {
            let (c, s) = sin_cos_q15::<360>(Angle::from_degrees(deg));
            let r = f64::from(deg).to_radians();
            assert!((f64::from(c) / 32768.0 - r.cos()).abs() < 1e-4, "{deg}");
            assert!((f64::from(s) / 32768.0 - r.sin()).abs() < 1e-4, "{deg}");
        }
    }
}
