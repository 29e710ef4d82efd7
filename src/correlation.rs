//! Circular Pearson correlation of two signatures (eqs. 11–12), its peaks and
//! their sub-step position.
//!
//! `r(k) = cor(D1(θ), D2(θ + k·Δθ))` over the half circle (`D` has period π, so
//! the shift is α modulo π). Computed exactly in integers:
//! `r(k) = num(k) / den` with `num(k) = n·Σ D1·D2(·+k) − ΣD1·ΣD2` and
//! `den = sqrt((nΣD1² − (ΣD1)²)(nΣD2² − (ΣD2)²))`; only `num` varies with `k`,
//! so peaks are found on `num` and only they are divided.

use crate::math::{dot_u32, insert_sorted, parabola_vertex};
use crate::Score;
use heapless::Vec;

/// How many correlation peaks are kept (the strongest local maxima).
pub const MAX_PEAKS: usize = 6;

/// One local maximum of `num(k)`, with its neighbours for interpolation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Peak {
    /// The shift `k ∈ [0, HALF)`, in θ steps.
    pub shift: usize,
    /// `num(k − 1)`.
    pub before: i64,
    /// `num(k)`.
    pub value: i64,
    /// `num(k + 1)`.
    pub after: i64,
}

impl Peak {
    /// Sub-step offset of the parabola through the peak and its neighbours, in
    /// Q16 steps, within ±½ step.
    pub fn offset_q16(&self) -> i64 {
        parabola_vertex(self.before, self.value, self.after, 1 << 16, 1 << 15)
    }
}

/// The strongest correlation peaks of two signatures.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Correlation {
    /// Local maxima of `num(k)`, strongest first.
    pub peaks: Vec<Peak, MAX_PEAKS>,
    /// `den`; 0 when either signature is constant (no structure).
    pub denominator: u64,
    /// Number of θ steps over the half circle.
    pub half: usize,
}

impl Correlation {
    /// Correlates `d1` with `d2` over every circular shift (`HALF²`
    /// multiply-adds). Sums fit their types for every configuration the crate
    /// accepts: values ≤ 2¹⁶, `HALF ≤ 2048` → `Σ ≤ 2⁴³`, `num ≤ 2⁵⁴`.
    pub fn of<const HALF: usize>(d1: &[u16; HALF], d2: &[u16; HALF]) -> Self {
        const { assert!(HALF <= 2048, "HALF must be at most 2048 (N_THETA ≤ 4096)") };
        let n = HALF as i64;
        let (sum1, sq1) = moments(d1);
        let (sum2, sq2) = moments(d2);
        let var1 = (n as u64 * sq1).saturating_sub(sum1 * sum1);
        let var2 = (n as u64 * sq2).saturating_sub(sum2 * sum2);
        let denominator = (u128::from(var1) * u128::from(var2)).isqrt() as u64;
        let mut peaks = Vec::new();
        if denominator == 0 || HALF < 3 {
            return Self {
                peaks,
                denominator: 0,
                half: HALF,
            };
        }
        let mean_term = (sum1 * sum2) as i64;
        // When every dot product fits 32 bits (always for outlines up to
        // 256²), accumulate in u32: one multiply-accumulate per term.
        let max1 = u64::from(d1.iter().copied().max().unwrap_or(0));
        let max2 = u64::from(d2.iter().copied().max().unwrap_or(0));
        let narrow = max1 * max2 * HALF as u64 <= u64::from(u32::MAX);
        let num = |k: usize| -> i64 {
            // Σ_i d1[i] · d2[(i + k) mod HALF], as two straight runs.
            let (d1_head, d1_tail) = d1.split_at(HALF - k);
            let (d2_head, d2_tail) = d2.split_at(k);
            let dot = if narrow {
                u64::from(dot_u32(d1_head.iter(), d2_tail) + dot_u32(d1_tail.iter(), d2_head))
            } else {
                dot_u64(d1_head, d2_tail) + dot_u64(d1_tail, d2_head)
            };
            n * dot as i64 - mean_term
        };
        let first = num(0);
        let mut before = num(HALF - 1);
        let mut value = first;
        for k in 0..HALF {
            let after = if k + 1 < HALF { num(k + 1) } else { first };
            // A plateau counts once, at its first step.
            if value > before && value >= after {
                insert_sorted(
                    &mut peaks,
                    Peak {
                        shift: k,
                        before,
                        value,
                        after,
                    },
                    |a, b| b.value < a.value,
                );
            }
            before = value;
            value = after;
        }
        Self {
            peaks,
            denominator,
            half: HALF,
        }
    }

    /// Pearson correlation of a peak, in [−1, 1].
    pub fn score(&self, peak: &Peak) -> Score {
        if self.denominator == 0 {
            return Score::ZERO;
        }
        let q16 = (i128::from(peak.value) << 16) / i128::from(self.denominator);
        Score::from_bits(q16.clamp(-(1 << 16), 1 << 16) as i32)
    }

    /// The strongest peak, if the signatures have any structure.
    pub fn best(&self) -> Option<&Peak> {
        self.peaks.first()
    }

    /// The strongest peak at least `separation` steps (circularly, modulo π)
    /// from the best one.
    pub fn rival(&self, separation: usize) -> Option<&Peak> {
        let best = self.best()?;
        self.peaks
            .iter()
            .skip(1)
            .find(|p| circular_distance(p.shift, best.shift, self.half) >= separation)
    }
}

/// Circular distance between two shifts modulo `period` (0 when `period`
/// is 0). A `const fn`: `Reference::from_bytes` checks the stored profile
/// columns' separation with it.
pub(crate) const fn circular_distance(a: usize, b: usize, period: usize) -> usize {
    let d = a.abs_diff(b) % if period == 0 { 1 } else { period };
    // d < period, or d = period = 0.
    let other = period - d;
    if d < other {
        d
    } else {
        other
    }
}

/// `Σ a·b` in `u64`.
fn dot_u64(a: &[u16], b: &[u16]) -> u64 {
    a.iter()
        .zip(b)
        .map(|(&x, &y)| u64::from(u32::from(x) * u32::from(y)))
        .sum()
}

fn moments(d: &[u16]) -> (u64, u64) {
    d.iter().fold((0, 0), |(s, q), &v| {
        let v = u64::from(v);
        (s + v, q + v * v)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_a_circular_shift_with_full_correlation() {
        let mut d1 = [0u16; 12];
        for (i, v) in d1.iter_mut().enumerate() {
            *v = [1, 5, 9, 4, 2, 1, 1, 3, 7, 3, 1, 0][i];
        }
        let mut d2 = [0u16; 12];
        for i in 0..12 {
            d2[(i + 5) % 12] = d1[i];
        }
        let c = Correlation::of(&d1, &d2);
        let best = c.best().unwrap();
        assert_eq!(best.shift, 5);
        assert_eq!(c.score(best), Score::ONE);
        assert!(c.rival(2).is_some_and(|r| c.score(r) < Score::ONE));
    }

    /// The correlation as first written: `num(k)` by the plain circular
    /// double loop, one `k` at a time.
    fn plain<const HALF: usize>(d1: &[u16; HALF], d2: &[u16; HALF]) -> Correlation {
        let n = HALF as i64;
        let (sum1, sq1) = moments(d1);
        let (sum2, sq2) = moments(d2);
        let var1 = (n as u64 * sq1).saturating_sub(sum1 * sum1);
        let var2 = (n as u64 * sq2).saturating_sub(sum2 * sum2);
        let denominator = (u128::from(var1) * u128::from(var2)).isqrt() as u64;
        let mut peaks = Vec::new();
        if denominator == 0 || HALF < 3 {
            return Correlation {
                peaks,
                denominator: 0,
                half: HALF,
            };
        }
        let num = |k: usize| {
            let dot: u64 = (0..HALF)
                .map(|i| u64::from(d1[i]) * u64::from(d2[(i + k) % HALF]))
                .sum();
            n * dot as i64 - (sum1 * sum2) as i64
        };
        for k in 0..HALF {
            let (before, value, after) = (num((k + HALF - 1) % HALF), num(k), num((k + 1) % HALF));
            if value > before && value >= after {
                let peak = Peak {
                    shift: k,
                    before,
                    value,
                    after,
                };
                insert_sorted(&mut peaks, peak, |a, b| b.value < a.value);
            }
        }
        Correlation {
            peaks,
            denominator,
            half: HALF,
        }
    }

    fn agrees_on_random<const HALF: usize>(cases: usize) {
        let mut state = 0x2545_f491_4f6c_dd1d ^ HALF as u64;
        let mut next = move |n: u64| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state % n.max(1)
        };
        for _ in 0..cases {
            // Small values (narrow u32 sums), the largest (wide u64 sums),
            // plateaus of few levels, and constant signatures.
            let top = [3, 40, 2000, 65_535][next(4) as usize];
            let d1: [u16; HALF] = core::array::from_fn(|_| next(top + 1) as u16);
            let d2: [u16; HALF] = core::array::from_fn(|_| next(top + 1) as u16);
            assert_eq!(Correlation::of(&d1, &d2), plain(&d1, &d2), "{d1:?}\n{d2:?}");
            let mut rotated = d1;
            rotated.rotate_right(next(HALF as u64) as usize);
            assert_eq!(Correlation::of(&d1, &rotated), plain(&d1, &rotated));
        }
    }

    /// Every peak (shift, neighbours, order) and the denominator equal the
    /// plain loop's, for `HALF` below, at and above a multiple of the lanes.
    #[test]
    fn agrees_with_the_plain_loop() {
        agrees_on_random::<1>(4);
        agrees_on_random::<3>(200);
        agrees_on_random::<4>(200);
        agrees_on_random::<5>(200);
        agrees_on_random::<7>(200);
        agrees_on_random::<64>(100);
        agrees_on_random::<180>(30);
        agrees_on_random::<181>(10);
    }

    #[test]
    fn constant_signature_has_no_peaks() {
        let c = Correlation::of(&[3u16; 10], &[1, 2, 3, 4, 5, 6, 7, 8, 9, 0]);
        assert!(c.best().is_none());
        assert_eq!(c.denominator, 0);
    }

    #[test]
    fn parabolic_offset_by_hand() {
        // Parabola with vertex at +0.25: values at −1, 0, 1 of −(x−0.25)²: −1.5625, −0.0625, −0.5625.
        let p = Peak {
            shift: 0,
            before: -15625,
            value: -625,
            after: -5625,
        };
        assert_eq!(p.offset_q16(), 1 << 14);
    }
}
