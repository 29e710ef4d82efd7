//! The maths helpers every stage shares: roots, the parabolic vertex, the
//! sorted insert, the dot product, and the `const` series that build the
//! tables. Each states its error bound and has test vectors. This module is the ground floor: it imports nothing of the crate.

use heapless::Vec;

/// π, for the `const` tables.
pub(crate) const PI: f64 = core::f64::consts::PI;
/// 2π, for the `const` tables.
pub(crate) const TAU: f64 = 2.0 * PI;

/// `⌈√v⌉`, exact.
pub(crate) const fn isqrt_ceil(v: u64) -> u64 {
    let r = v.isqrt();
    if r * r == v {
        r
    } else {
        r + 1
    }
}

/// `√(a·b)` without 128-bit arithmetic (whose routines cost the Cortex-M0
/// dearly and took 220 B of stack): each factor is shifted left by an even
/// amount to just below 2⁶², rooted (≥ 2³⁰ unless it is 0), and the product
/// of the roots shifted back. Relative error below 2⁻²⁹, never above the
/// exact root; 0 when either is 0.
pub(crate) fn sqrt_of_product(a: u64, b: u64) -> u64 {
    let root = |v: u64| -> (u64, u32) {
        let shift = v.leading_zeros().saturating_sub(2) & !1;
        ((v << shift).isqrt(), shift / 2)
    };
    let ((root_a, half_a), (root_b, half_b)) = (root(a), root(b));
    root_a.saturating_mul(root_b) >> (half_a + half_b).min(63)
}

/// `√v` for `v ≥ 0` in const context by Newton iteration (64 steps: f64
/// precision for the sizes the configuration meets); 0 for `v ≤ 0`.
pub(crate) const fn sqrt_f64(v: f64) -> f64 {
    if v <= 0.0 {
        return 0.0;
    }
    let mut r = if v > 1.0 { v } else { 1.0 };
    let mut i = 0;
    while i < 64 {
        r = 0.5 * (r + v / r);
        i += 1;
    }
    r
}

/// `atan(x)` for `x ≥ 0` in const context: two argument halvings
/// (`atan x = 2 atan(x / (1 + sqrt(1 + x²)))`) then a Taylor series; error
/// below 1e-15 for `x ≤ 1`.
pub(crate) const fn atan_f64(x: f64) -> f64 {
    let x1 = x / (1.0 + sqrt_f64(1.0 + x * x));
    let x2 = x1 / (1.0 + sqrt_f64(1.0 + x1 * x1));
    // |x2| ≤ tan(π/16) ≈ 0.199: 20 terms reach f64 precision.
    let x2sq = x2 * x2;
    let mut term = x2;
    let mut sum = 0.0;
    let mut k = 0;
    while k < 20 {
        sum += term / (2 * k + 1) as f64;
        term *= -x2sq;
        k += 1;
    }
    4.0 * sum
}

/// `sin(θ)` for `θ ∈ [0, π]` in const context: folded to `[0, π/2]`, then a
/// 14-term Taylor series (error < 1e-16). Builds the trig tables.
pub(crate) const fn sin_f64(theta: f64) -> f64 {
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
/// the quadrant (error < 1e-16).
pub(crate) const fn cos_f64(theta: f64) -> f64 {
    if theta <= PI / 2.0 {
        sin_f64(PI / 2.0 - theta)
    } else {
        -sin_f64(theta - PI / 2.0)
    }
}

/// `sin(x)`, `cos(x)` of any `|x| < 10⁴` at run time, to about 1e-7
/// (rounding to f32); `None` for non-finite or larger `x` (beam angles are
/// a few radians). Quadrant reduction with a two-part π/2, then
/// degree-9/10 Taylor polynomials on `|r| ≤ π/4` (truncation error < 2e-9).
/// Unlike [`sin_f64`] it takes any argument and is evaluated at run time.
pub(crate) fn sin_cos_f32(x: f32) -> Option<(f32, f32)> {
    if !(x.is_finite() && x > -1.0e4 && x < 1.0e4) {
        return None;
    }
    const FRAC_2_PI: f64 = core::f64::consts::FRAC_2_PI;
    const PIO2: f64 = core::f64::consts::FRAC_PI_2;
    let x = f64::from(x);
    let q = x * FRAC_2_PI;
    // Round to nearest without std: |q| < 7000.
    let k = if q >= 0.0 {
        (q + 0.5) as i64
    } else {
        (q - 0.5) as i64
    };
    let r = x - k as f64 * PIO2;
    let r2 = r * r;
    let s = r * (1.0 - r2 / 6.0 * (1.0 - r2 / 20.0 * (1.0 - r2 / 42.0 * (1.0 - r2 / 72.0))));
    let c = 1.0
        - r2 / 2.0 * (1.0 - r2 / 12.0 * (1.0 - r2 / 30.0 * (1.0 - r2 / 56.0 * (1.0 - r2 / 90.0))));
    let (s, c) = match k.rem_euclid(4) {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    };
    Some((s as f32, c as f32))
}

/// Vertex of the parabola through `(−1, before)`, `(0, peak)`, `(1, after)`
/// (abscissae in units of `spacing`): `(before − after)·spacing /
/// (2·curvature)`, rounded toward zero (exact integer division) and clamped
/// to `±|limit|`; 0 where the three do not bend down (`curvature ≥ 0`).
///
/// `spacing = 2¹⁶, limit = 2¹⁵` gives the sub-step offset in Q16 within
/// ±½. Exact for any inputs: the arithmetic is `i64` while every step fits
/// and `i128` otherwise, in a separate function (so the callers' frames hold
/// no 128-bit temporaries: they cost the Cortex-M0 stack and cycles).
#[inline]
pub(crate) fn parabola_vertex(before: i64, peak: i64, after: i64, spacing: i64, limit: i64) -> i64 {
    let narrow = || -> Option<i64> {
        let curvature = before
            .checked_sub(peak.checked_mul(2)?)?
            .checked_add(after)?;
        if curvature >= 0 {
            return Some(0);
        }
        let numerator = before.checked_sub(after)?.checked_mul(spacing)?;
        numerator.checked_div(curvature.checked_mul(2)?)
    };
    let limit = limit.saturating_abs();
    match narrow() {
        Some(offset) => offset.max(-limit).min(limit),
        None => parabola_vertex_wide(before, peak, after, spacing, limit),
    }
}

/// [`parabola_vertex`] in `i128` (no intermediate can overflow: every
/// factor is below 2⁶⁴), clamped to `±limit` (`limit ≥ 0`).
#[cold]
#[inline(never)]
fn parabola_vertex_wide(before: i64, peak: i64, after: i64, spacing: i64, limit: i64) -> i64 {
    let curvature = i128::from(before) - 2 * i128::from(peak) + i128::from(after);
    if curvature >= 0 {
        return 0;
    }
    let numerator = (i128::from(before) - i128::from(after)) * i128::from(spacing);
    let offset = numerator.checked_div(2 * curvature).unwrap_or(0);
    let limit = i128::from(limit);
    offset.max(-limit).min(limit) as i64
}

/// Inserts `item` into `items`, kept sorted strongest first, before the
/// first element it is `stronger` than (after any equals: ties keep their
/// arrival order); when full, the weakest is dropped, and an item weaker
/// than every kept one is not inserted. Cost: one scan and one shift of at
/// most `N` items.
pub(crate) fn insert_sorted<T, const N: usize>(
    items: &mut Vec<T, N>,
    item: T,
    stronger: impl Fn(&T, &T) -> bool,
) {
    let at = items
        .iter()
        .position(|kept| stronger(&item, kept))
        .unwrap_or(items.len());
    if at >= N {
        return;
    }
    if items.is_full() {
        items.pop();
    }
    // Pushed last, then rotated into place: the same as `insert(at, item)`
    // (`at ≤ len`), but with no index check for the optimiser to keep
    // (`heapless::Vec::insert`'s survived at opt-level "s", issue 14 item 2).
    // The push cannot fail: there is room after the pop.
    if items.push(item).is_err() {
        return;
    }
    if let Some((last, before)) = items.get_mut(at..).and_then(|tail| tail.split_last_mut()) {
        for kept in before {
            core::mem::swap(kept, last);
        }
    }
}

/// Sorts `items` by `key`, largest first, stable (insertion sort: a few
/// items, and no panic path, unlike `sort_unstable_by`'s order-violation
/// check).
pub(crate) fn sort_descending<T: Copy>(items: &mut [T], key: impl Fn(&T) -> u32) {
    for i in 1..items.len() {
        let mut j = i;
        while j > 0 && key(&items[j - 1]) < key(&items[j]) {
            items.swap(j - 1, j);
            j -= 1;
        }
    }
}

/// `Σ p·q` in `u32`, wrapping: exact when the caller has bounded the sum
/// below 2³² (the correlation: `HALF ≤ 2¹¹` products of two-bin peaks
/// bounded by the configuration). The 4-lane [`Lanes`] was measured slower
/// here on the Cortex-M0 (188 k → 252 k instructions a correlation).
#[inline]
pub(crate) fn dot_u32<'a, P: Copy + Into<u32> + 'a>(
    p: impl Iterator<Item = &'a P>,
    q: &[u16],
) -> u32 {
    p.zip(q)
        .map(|(&x, &y)| x.into() * u32::from(y))
        .fold(0u32, u32::wrapping_add)
}

/// Shifts per pass of [`Lanes`].
pub(crate) const LANES: usize = 4;

/// [`LANES`] dot products in one pass: `Σ_i p[i]·q[i + j]` for the
/// consecutive offsets `j = 0..LANES` of `q` (a block of shifts of a
/// cross-correlation). Each value of `q` is loaded once and kept in a
/// sliding window, so a step costs one load of `p`, one of `q` and
/// `LANES` multiply-adds, where separate dot products load both values for
/// every multiply-add.
///
/// The sums are `u32`, wrapping: exact while the caller bounds each below
/// 2³² (the profile match: at most 256 products of a `u8` and a `u16`
/// between two [`Lanes::take`]s).
#[derive(Clone, Copy)]
pub(crate) struct Lanes {
    /// `q[i + j]` for `j < LANES − 1` before the step of `i`.
    window: [u32; LANES - 1],
    /// The partial sums.
    sums: [u32; LANES],
}

impl Lanes {
    /// Lanes about to step through `i = i0, i0 + 1, …`: `lead(j)` is
    /// `q[i0 + j]` for `j < LANES − 1` (0 where `q` has no such index).
    #[inline(always)]
    pub(crate) fn starting(lead: impl Fn(usize) -> u32) -> Self {
        Self {
            window: [lead(0), lead(1), lead(2)],
            sums: [0; LANES],
        }
    }

    /// One step: `p = p[i]`, `q = q[i + LANES − 1]`. By value, so that the
    /// lanes live in registers.
    #[inline(always)]
    #[must_use]
    pub(crate) fn step(self, p: u32, q: u32) -> Self {
        let [w0, w1, w2] = self.window;
        let [s0, s1, s2, s3] = self.sums;
        let mac = |s: u32, w: u32| s.wrapping_add(p.wrapping_mul(w));
        Self {
            window: [w1, w2, q],
            sums: [mac(s0, w0), mac(s1, w1), mac(s2, w2), mac(s3, q)],
        }
    }

    /// Steps through `p` (backwards when `REVERSED`) and `q`
    /// (`q[i + LANES − 1]` in step with the `i`-th value of `p`) until
    /// either ends. Unrolled by 2 (by 4, or not at all, measured up to 1 %
    /// apart on the Cortex-M4F; the lanes then spill to the stack).
    #[inline(always)]
    pub(crate) fn feed<P: Copy + Into<u32>, const REVERSED: bool>(&mut self, p: &[P], q: &[u16]) {
        let n = p.len().min(q.len());
        let p = if REVERSED {
            p.get(p.len() - n..)
        } else {
            p.get(..n)
        };
        let (Some(p), Some(q)) = (p, q.get(..n)) else {
            return;
        };
        let mut lanes = *self;
        let q2 = q.chunks_exact(2);
        let q_rest = q2.remainder();
        if REVERSED {
            let p2 = p.rchunks_exact(2);
            let p_rest = p2.remainder();
            for (p, q) in p2.zip(q2) {
                if let (&[p1, p0], &[q0, q1]) = (p, q) {
                    lanes = lanes.step(p0.into(), q0.into());
                    lanes = lanes.step(p1.into(), q1.into());
                }
            }
            for (&p, &q) in p_rest.iter().rev().zip(q_rest) {
                lanes = lanes.step(p.into(), q.into());
            }
        } else {
            let p2 = p.chunks_exact(2);
            let p_rest = p2.remainder();
            for (p, q) in p2.zip(q2) {
                if let (&[p0, p1], &[q0, q1]) = (p, q) {
                    lanes = lanes.step(p0.into(), q0.into());
                    lanes = lanes.step(p1.into(), q1.into());
                }
            }
            for (&p, &q) in p_rest.iter().zip(q_rest) {
                lanes = lanes.step(p.into(), q.into());
            }
        }
        *self = lanes;
    }

    /// The sums so far; they restart from 0 (the window is kept).
    #[inline(always)]
    pub(crate) fn take(&mut self) -> [u32; LANES] {
        core::mem::replace(&mut self.sums, [0; LANES])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn isqrt_ceil_vectors() {
        for (v, r) in [
            (0u64, 0u64),
            (1, 1),
            (2, 2),
            (4, 2),
            (5, 3),
            (16_129, 127),
            (16_130, 128),
        ] {
            assert_eq!(isqrt_ceil(v), r, "{v}");
        }
    }

    #[test]
    fn sqrt_of_product_is_within_its_bound() {
        for (a, b) in [
            (1u64, 1u64),
            (2, 3),
            (65_025, 7),
            (1 << 29, (1 << 41) - 1),
            (123_456_789, 987_654),
            (0, 5),
        ] {
            let exact = ((a as f64) * (b as f64)).sqrt();
            let got = sqrt_of_product(a, b) as f64;
            assert!(got <= exact + 1e-9, "{a} {b}: {got} > {exact}");
            assert!(
                got >= exact * (1.0 - 1e-8) - 1.0,
                "{a} {b}: {got} ≪ {exact}"
            );
        }
    }

    #[test]
    fn float_roots_are_accurate() {
        for v in [1e-6f32, 0.25, 2.0, 9.0, 1234.5, 1e6] {
            let exact = f64::from(v).sqrt();
            assert!((sqrt_f64(f64::from(v)) - exact).abs() <= 1e-15 * exact.max(1.0));
        }
        assert_eq!(sqrt_f64(-2.0), 0.0);
    }

    #[test]
    fn const_series_are_accurate() {
        for i in 0..=100 {
            let x = f64::from(i) / 100.0;
            assert!((atan_f64(x) - x.atan()).abs() < 1e-15, "atan {x}");
            let t = PI * x;
            assert!((sin_f64(t) - t.sin()).abs() < 1e-15, "sin {t}");
            assert!((cos_f64(t) - t.cos()).abs() < 1e-15, "cos {t}");
        }
    }

    #[test]
    fn sin_cos_f32_is_accurate() {
        for i in -2000..=2000 {
            let x = i as f32 * 0.01;
            let (s, c) = sin_cos_f32(x).unwrap();
            let (es, ec) = (f64::from(x).sin(), f64::from(x).cos());
            assert!((f64::from(s) - es).abs() < 2e-7, "sin {x}");
            assert!((f64::from(c) - ec).abs() < 2e-7, "cos {x}");
        }
        assert!(sin_cos_f32(f32::NAN).is_none());
        assert!(sin_cos_f32(f32::INFINITY).is_none());
    }

    #[test]
    fn parabola_vertex_vectors() {
        // −(x − 0.25)² at −1, 0, 1 (scaled by 10⁴): vertex +0.25 = 2¹⁴ in Q16.
        assert_eq!(
            parabola_vertex(-15_625, -625, -5_625, 1 << 16, 1 << 15),
            1 << 14
        );
        // Symmetric: 0; flat or bending up: 0.
        assert_eq!(parabola_vertex(3, 5, 3, 1 << 16, 1 << 15), 0);
        assert_eq!(parabola_vertex(5, 5, 5, 1 << 16, 1 << 15), 0);
        assert_eq!(parabola_vertex(9, 1, 9, 1 << 16, 1 << 15), 0);
        // A neighbour above the peak: clamped to the limit.
        assert_eq!(parabola_vertex(0, 10, 12, 1 << 16, 1 << 15), 1 << 15);
        assert_eq!(parabola_vertex(0, 10, 12, 100, 50), 50);
        assert_eq!(parabola_vertex(0, 10, 12, 100, 100), 75);
        // Spacing in other units: vertex −⅓·spacing.
        assert_eq!(parabola_vertex(4, 5, 0, 300, 300), -100);
        // Values beyond i64 products take the wide path, still exact.
        assert_eq!(
            parabola_vertex(1 << 50, 1 << 51, 0, 1 << 16, 1 << 15),
            -10_922
        );
    }

    #[test]
    fn insert_sorted_keeps_the_strongest() {
        let mut v: Vec<u32, 3> = Vec::new();
        for x in [5, 9, 1, 7, 9, 0] {
            insert_sorted(&mut v, x, |a, b| a > b);
        }
        assert_eq!(v.as_slice(), &[9, 9, 7]);
        // Ties keep arrival order.
        let mut w: Vec<(u32, char), 4> = Vec::new();
        for x in [(2, 'a'), (3, 'b'), (2, 'c')] {
            insert_sorted(&mut w, x, |a, b| a.0 > b.0);
        }
        assert_eq!(w.as_slice(), &[(3, 'b'), (2, 'a'), (2, 'c')]);
    }

    /// Against an independent model (append, stable sort strongest first,
    /// keep the first `N`) on every sequence of 5 values from 0..4.
    #[test]
    fn insert_sorted_matches_a_stable_sort() {
        for code in 0..4u32.pow(5) {
            let xs: [(u32, u32); 5] =
                core::array::from_fn(|i| ((code / 4u32.pow(i as u32)) % 4, i as u32));
            let mut v: Vec<(u32, u32), 3> = Vec::new();
            let mut model = [(0u32, 0u32); 5];
            for (i, &x) in xs.iter().enumerate() {
                insert_sorted(&mut v, x, |a, b| a.0 > b.0);
                model[i] = x;
                let kept = &mut model[..=i];
                // Insertion by hand: stable, strongest first.
                for j in (1..kept.len()).rev() {
                    if kept[j].0 > kept[j - 1].0 {
                        kept.swap(j, j - 1);
                    }
                }
                let n = kept.len().min(3);
                assert_eq!(v.as_slice(), &kept[..n], "{xs:?} after {i}");
            }
        }
    }

    #[test]
    fn sort_descending_is_stable() {
        let mut v = [(1u32, 'a'), (3, 'b'), (1, 'c'), (2, 'd')];
        sort_descending(&mut v, |x| x.0);
        assert_eq!(v, [(3, 'b'), (2, 'd'), (1, 'a'), (1, 'c')]);
    }

    #[test]
    fn dot_u32_vectors() {
        assert_eq!(dot_u32([1u8, 2, 3].iter(), &[4, 5, 6]), 32);
        assert_eq!(dot_u32([1u16, 2].iter(), &[7, 8, 9]), 23);
        assert_eq!(dot_u32([255u8; 4].iter(), &[65_535; 4]), 4 * 255 * 65_535);
    }

    #[test]
    fn lanes_vectors() {
        // q = [4, 5, 6, 7, 8, 9, 10, 11, 12]: offsets 0..4 of p = [1, 2, 3]
        // and of p = [1, 2, 3, 1, 1, 2] (unrolled rounds, backwards).
        let q = [4u16, 5, 6, 7, 8, 9, 10, 11, 12];
        let mut lanes = Lanes::starting(|j| u32::from(q[j]));
        lanes.feed::<_, false>(&[1u8, 2, 3], &q[3..]);
        assert_eq!(lanes.take(), [32, 38, 44, 50]);
        assert_eq!(lanes.take(), [0; 4]);
        let mut lanes = Lanes::starting(|j| u32::from(q[j]));
        lanes.feed::<_, true>(&[2u8, 1, 1, 3, 2, 1], &q[3..]);
        assert_eq!(lanes.take(), [65, 75, 85, 95]);
        // The window carries over; steps past the end of q read 0.
        let mut lanes = Lanes::starting(|j| u32::from(q[j + 5]));
        lanes.feed::<u16, false>(&[1], &q[8..]);
        lanes = lanes.step(2, 0);
        assert_eq!(lanes.take(), [9 + 20, 10 + 22, 11 + 24, 12]);
        let mut lanes = Lanes::starting(|_| 65_535);
        lanes.feed::<_, false>(&[255u8; 5], &[65_535; 5]);
        assert_eq!(lanes.take(), [5 * 255 * 65_535; 4]);
    }
}
