//! Translation from the ρ shifts of a few accumulator columns.
//!
//! A translation `t` shifts the column at normal angle ψ by `t·(cos ψ, sin ψ)`
//! in ρ. Given the measured shift `s_j` of a few columns, `t` is the weighted
//! least-squares solution of `n_j · t = s_j`. Where the shifts disagree (a
//! column locked onto the wrong one of parallel walls), the translation best
//! supported by the columns' best and runner-up shifts decides which shift
//! each column contributes. When all normals are nearly parallel
//! (a corridor) the shift along the walls is unobservable: the fit keeps only
//! the observable component and reports the unobservable direction.
//!
//! All in integers (no floating point, so no software float on FPU-less
//! cores): shifts and translations in Q16 pixels, normals in Q15, weights
//! scaled by a power of two so the largest is in `[½, 1]` (the solution does
//! not depend on a common factor of the weights), the normal matrix in Q24.
//! Against an `f64` least squares on the same shifts the translation is
//! within `2⁻¹²` px plus `2⁻¹⁶` of its size (`host-tests/tests/translation_fit.rs`).

use fixed::types::I16F16;

use crate::profile::{Shift, RUNNERS_UP};

/// The shift of one column, as measured by the profile match.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ColumnShift {
    /// Unit normal `(cos ψ, sin ψ)` of the column in image 2, Q15 (each
    /// component is clamped to `[−1, 1]`).
    pub normal_q15: (i32, i32),
    /// The best shift `s` (pixels, Q16) and its weight (`score_q16`: match
    /// score times relative strength, Q16 in [0, 1]; only the ratios of the
    /// weights matter, and a weight of 0 removes the shift).
    pub best: Shift,
    /// The match's runner-up shifts, weighted like `best` (score 0: none):
    /// the fit may pick one where the best shifts disagree.
    pub runners_up: [Shift; RUNNERS_UP],
}

/// The rest of the pose after the rotation: translation `t` (pixels, in the
/// centred, y-up image frame) and scale `s`, such that a point `p` of image 1
/// appears in image 2 at `s·R(α)·p + t`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Pose {
    /// `t_x`, pixels.
    pub x: I16F16,
    /// `t_y`, pixels.
    pub y: I16F16,
    /// Scale `s`: exactly 1 unless the estimator searches a
    /// [`ScaleRange`](crate::ScaleRange).
    pub scale: I16F16,
    /// Weighted RMS of `n_j · t − s_j` over the columns kept, pixels of
    /// image 2 (each term saturates at 64 px): how well the columns agree.
    /// With two columns `t` is exactly determined and the residual is 0
    /// whatever the shifts: see [`columns`](Self::columns).
    pub residual: I16F16,
    /// Columns kept in the fit (1 to [`PROFILE_COLUMNS`](crate::stages::PROFILE_COLUMNS)
    /// from the estimator; a column none of whose shifts lies within 2 px of
    /// the best-supported translation is dropped). Only three or more can
    /// disagree: with one (or one direction) the translation is partly
    /// unobservable, with two a column locked on the wrong one of parallel
    /// walls moves `t` unchecked (real scan pairs: 14.7 % more than 0.3 m
    /// off with two columns, 3.2 % with three or more; README).
    pub columns: u8,
    /// Unit vector along which `t` is not observable (all column normals are
    /// nearly perpendicular to it); `t` has no component along it. Of the
    /// two opposite vectors, the one with `y > 0`, or `x < 0` when `y = 0`.
    pub unobservable: Option<(I16F16, I16F16)>,
}

/// `t` (Q16) without its component along the unit vector `u` (Q16): what a
/// [`Pose`] keeps of a translation along its unobservable direction.
pub(crate) fn without_component(t: (i64, i64), u: (I16F16, I16F16)) -> (i64, i64) {
    let (ux, uy) = (i64::from(u.0.to_bits()), i64::from(u.1.to_bits()));
    let along = (t.0 * ux + t.1 * uy) >> 16;
    (t.0 - ((along * ux) >> 16), t.1 - ((along * uy) >> 16))
}

/// A direction is unobservable when the small eigenvalue of `Σ w n nᵀ` is
/// below 0.05 times the large one (normals within ~13° of each other):
/// `λ₂ < 0.05·λ₁` ⇔ `det / trace² < 0.05 / 1.05² = 20 / 441`.
const UNOBSERVABLE_DET: i64 = 441;
/// See [`UNOBSERVABLE_DET`].
const UNOBSERVABLE_TRACE2: i64 = 20;
/// A shift farther than this from a translation's prediction (2 px, Q16)
/// does not support it.
const OUTLIER_Q16: i64 = 2 << 16;
/// At most this many columns take part in the fit (the estimator gives
/// [`PROFILE_COLUMNS`](crate::stages::PROFILE_COLUMNS)); later ones are ignored.
pub const MAX_FIT_COLUMNS: usize = 8;

/// Which of a column's shifts the fit uses: its best (0), a runner-up
/// (1 + index), or none ([`DROPPED`]).
type Choice = u8;

/// The column takes no part in the fit.
const DROPPED: Choice = u8::MAX;

/// A translation, Q16 pixels.
type Xy = (i32, i32);

/// `a·b` in 64 bits: one `smull` on the Cortex-M3/M4/M7 (the products of
/// this module are formed from `i32`s for that reason).
fn mul(a: i32, b: i32) -> i64 {
    i64::from(a) * i64::from(b)
}

/// Fits `t` to the column shifts; `None` without a usable column (no
/// positive weight, or normals of length ≈ 0). Only the first
/// [`MAX_FIT_COLUMNS`] shifts are used.
///
/// When the best shifts agree (each within 2 px of their least-squares fit)
/// they are the answer. Otherwise a column may have locked onto the wrong
/// one of repeated walls: every translation that two non-parallel columns'
/// candidate shifts (best or runner-up, at least one a best) determine —
/// or, when all normals are nearly parallel, one column's candidate — is
/// scored by the summed weight of the columns with a candidate within 2 px
/// of its prediction, and the best-supported one picks each column's shift
/// (or drops the column) for the final least-squares fit.
///
/// Integer arithmetic throughout; `t` saturates at the range of
/// [`I16F16`] (±32 768 px).
pub fn fit_translation(shifts: &[ColumnShift]) -> Option<Pose> {
    fit(shifts, CANDIDATES)
}

/// [`fit_translation`] on the best shifts alone (runners-up ignored): the
/// scale search scores every scale with it, where weighing the runners-up
/// would cost dearly at scales whose columns disagree anyway.
pub(crate) fn fit_best_shifts(shifts: &[ColumnShift]) -> Option<Pose> {
    fit(shifts, 1)
}

/// The fit over each column's first `candidates` shifts (1: the best only).
#[inline(never)]
fn fit(shifts: &[ColumnShift], candidates: Choice) -> Option<Pose> {
    let shifts = shifts.get(..MAX_FIT_COLUMNS).unwrap_or(shifts);
    let mut choices: [Choice; MAX_FIT_COLUMNS] = [0; MAX_FIT_COLUMNS];
    let mut fit = solve(shifts, &choices)?;
    let agree = shifts
        .iter()
        .zip(choices)
        .all(|(c, k)| residual_of(c, k, fit.t).is_none_or(|r| r.abs() <= OUTLIER_Q16));
    if !agree {
        if let Some(t) = consensus(shifts, candidates) {
            for (choice, c) in choices.iter_mut().zip(shifts) {
                *choice = supporting(c, t, candidates).map_or(DROPPED, |(k, _)| k);
            }
            fit = solve(shifts, &choices)?;
        }
    }
    let (mut sum_w, mut sum_wr2, mut columns) = (0u64, 0u64, 0u8);
    for (c, k) in shifts.iter().zip(choices) {
        if let (Some((_, w)), Some(r)) = (candidate(c, k), residual_of(c, k, fit.t)) {
            let w = u64::from(fit.scale.apply(w));
            // |r| < 2²² (64 px): r² < 2⁴⁴ (Q32), w·r² < 2⁶⁰.
            let r = r.unsigned_abs().min((1 << 22) - 1) as u32;
            sum_w += w;
            sum_wr2 += (w * (u64::from(r) * u64::from(r))) >> 16;
            columns = columns.saturating_add(1);
        }
    }
    // Σ w·r² ≤ Σw · 2⁴⁴ and Σw ≤ 2¹⁹: shifted by 16 it stays below 2⁶³.
    let residual = match sum_w {
        0 => 0,
        _ => ((sum_wr2 << 16) / sum_w).isqrt(),
    };
    let (x, y) = fit.t;
    Some(Pose {
        x: I16F16::from_bits(x),
        y: I16F16::from_bits(y),
        scale: I16F16::ONE,
        residual: I16F16::from_bits(residual as i32),
        columns,
        unobservable: fit
            .unobservable
            .map(|(ux, uy)| (I16F16::from_bits(ux), I16F16::from_bits(uy))),
    })
}

impl Pose {
    /// The ρ shift `n·t` (Q16 pixels) this translation gives a column with
    /// unit normal `n` (Q15), saturated to `i32`.
    pub fn column_shift_q16(&self, normal_q15: (i32, i32)) -> i32 {
        let dot = i64::from(normal_q15.0) * i64::from(self.x.to_bits())
            + i64::from(normal_q15.1) * i64::from(self.y.to_bits());
        (dot >> 15).clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
    }

    /// The pose for column shifts measured on columns re-voted at `ρ / s`
    /// (which measure `n·t / s`): `t` and the residual times `s`, and `s`.
    pub(crate) fn scaled(self, scale_q16: u32) -> Self {
        let s = I16F16::from_bits(scale_q16.min(i32::MAX as u32) as i32);
        Self {
            x: self.x.saturating_mul(s),
            y: self.y.saturating_mul(s),
            scale: s,
            residual: self.residual.saturating_mul(s),
            columns: self.columns,
            unobservable: self.unobservable,
        }
    }
}

/// Candidates a column offers: its best shift, then its runners-up.
const CANDIDATES: Choice = 1 + RUNNERS_UP as Choice;

/// Shift (Q16 pixels) and weight (Q16) of candidate `choice` of column `c`;
/// `None` when dropped, absent or of weight 0.
fn candidate(c: &ColumnShift, choice: Choice) -> Option<(i32, u32)> {
    let shift = match choice {
        0 => c.best,
        k => *c.runners_up.get(usize::from(k).checked_sub(1)?)?,
    };
    (shift.score_q16 > 0).then_some((shift.shift_q16, shift.score_q16))
}

/// The column's normal, Q15, each component clamped to `[−1, 1]`.
fn normal(c: &ColumnShift) -> (i32, i32) {
    let clamp = |v: i32| v.clamp(-(1 << 15), 1 << 15);
    (clamp(c.normal_q15.0), clamp(c.normal_q15.1))
}

/// `n · t` (Q16 pixels, rounded) for a Q15 normal and a Q16 translation.
fn along(n: (i32, i32), t: Xy) -> i64 {
    (mul(n.0, t.0) + mul(n.1, t.1) + (1 << 14)) >> 15
}

/// `n · t − s` (Q16 pixels) for the chosen candidate of `c`.
fn residual_of(c: &ColumnShift, choice: Choice, t: Xy) -> Option<i64> {
    let (shift, _) = candidate(c, choice)?;
    Some(along(normal(c), t) - i64::from(shift))
}

/// Among the first `candidates` of `c`, the one within 2 px of `t`'s
/// prediction with the largest weight (the first of equals), and that weight.
fn supporting(c: &ColumnShift, t: Xy, candidates: Choice) -> Option<(Choice, u32)> {
    (0..candidates)
        .filter_map(|k| {
            let (_, w) = candidate(c, k)?;
            let r = residual_of(c, k, t)?;
            (r.abs() <= OUTLIER_Q16).then_some((k, w))
        })
        .fold(None, |best: Option<(Choice, u32)>, (k, w)| match best {
            Some((_, bw)) if bw >= w => best,
            _ => Some((k, w)),
        })
}

/// Two columns determine a translation when their normals are at least
/// ~20° apart: `|sin| ≥ 0.34`, Q30.
const MIN_PAIR_SINE_Q30: i64 = (0.34 * (1u64 << 30) as f64) as i64;

/// The best-supported translation among those two non-parallel columns'
/// candidates determine (at least one of them a best shift), or, with no
/// such pair, those one column's candidate determines (its shift along the
/// normal). Not inlined: its frame is only on the stack while it runs.
#[inline(never)]
fn consensus(shifts: &[ColumnShift], candidates: Choice) -> Option<Xy> {
    let mut best: Option<(u64, Xy)> = None;
    let mut consider = |t: Xy| {
        let support: u64 = shifts
            .iter()
            .filter_map(|c| supporting(c, t, candidates))
            .map(|(_, w)| u64::from(w))
            .sum();
        if best.is_none_or(|b| support > b.0) {
            best = Some((support, t));
        }
    };
    let mut pairs = false;
    for (i, a) in shifts.iter().enumerate() {
        let (ax, ay) = normal(a);
        for b in shifts.iter().skip(i + 1) {
            let (bx, by) = normal(b);
            // Q30; |det| ≥ 0.34 so 1/det fits Q28 in 31 bits.
            let det = mul(ax, by) - mul(ay, bx);
            if det.abs() < MIN_PAIR_SINE_Q30 {
                continue;
            }
            pairs = true;
            // Never `None`: |det| ≥ 0.34 (the check keeps the division total).
            let Some(inverse_q28) = (1i64 << 58).checked_div(det) else {
                continue;
            };
            // Cramer's rule: t = (s_a·b_y − a_y·s_b, a_x·s_b − s_a·b_x) / det.
            // The numerators are Q31 (< 2⁴⁷); taken to Q15 (< 2³²) they
            // times 1/det (< 2³⁰) stay below 2⁶².
            let solve = |sa: i32, sb: i32| -> Xy {
                let component = |num_q31: i64| saturate(((num_q31 >> 16) * inverse_q28) >> 27);
                (
                    component(mul(sa, by) - mul(ay, sb)),
                    component(mul(ax, sb) - mul(sa, bx)),
                )
            };
            for ka in 0..candidates {
                for kb in (0..candidates).filter(|&kb| ka == 0 || kb == 0) {
                    if let (Some((sa, _)), Some((sb, _))) = (candidate(a, ka), candidate(b, kb)) {
                        consider(solve(sa, sb));
                    }
                }
            }
        }
    }
    if !pairs {
        for c in shifts {
            let (nx, ny) = normal(c);
            for k in 0..candidates {
                if let Some((shift, _)) = candidate(c, k) {
                    consider((
                        saturate(mul(shift, nx) >> 15),
                        saturate(mul(shift, ny) >> 15),
                    ));
                }
            }
        }
    }
    best.map(|(_, t)| t)
}

/// Clamps a Q16 value to the range of `i32` (and so of [`I16F16`]).
fn saturate(v: i64) -> i32 {
    v.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
}

/// The weights of a fit's chosen candidates are multiplied by `2^shift`
/// (or divided, for a negative shift) so that the largest is in
/// `[2¹⁵, 2¹⁶)`: sums of up to [`MAX_FIT_COLUMNS`] terms then keep their
/// precision and stay far from overflow, whatever the weights' scale.
#[derive(Clone, Copy)]
struct WeightScale {
    shift: i32,
}

impl WeightScale {
    /// `w` scaled, in `[0, 2¹⁶)` for any weight up to the largest.
    fn apply(self, w: u32) -> u32 {
        if self.shift >= 0 {
            w << self.shift
        } else {
            w >> -self.shift
        }
    }
}

/// The [`WeightScale`] of the chosen candidates; `None` when none has a
/// positive weight.
fn weight_scale(
    shifts: &[ColumnShift],
    choices: &[Choice; MAX_FIT_COLUMNS],
) -> Option<WeightScale> {
    let largest = shifts
        .iter()
        .zip(choices)
        .filter_map(|(c, &k)| candidate(c, k).map(|(_, w)| w))
        .max()?;
    // 0 < largest < 2³²: its top bit is at 0..=31; move it to bit 15.
    let top = 31 - largest.leading_zeros() as i32;
    Some(WeightScale { shift: 15 - top })
}

/// A solved fit: `t` (Q16 pixels), the unobservable direction, if any
/// (unit vector, Q16), and the scale of the chosen candidates' weights
/// (for the residual).
struct Fit {
    t: Xy,
    unobservable: Option<(i32, i32)>,
    scale: WeightScale,
}

/// Weighted least squares over the chosen candidates; the component along
/// the well-observed direction only when the other is unobservable.
fn solve(shifts: &[ColumnShift], choices: &[Choice; MAX_FIT_COLUMNS]) -> Option<Fit> {
    let scale = weight_scale(shifts, choices)?;
    // Normal matrix [[a, b], [b, c]] = Σ w n nᵀ and right-hand side
    // (u, v) = Σ w s n, all Q24 (rounded). With w ≤ 2¹⁶ (Q16), |n| ≤ 2¹⁵
    // and |s| < 2³¹: w·n ≤ 2³¹ (Q31), w·n·n ≤ 2⁴⁶, w·n·s < 2⁶²; each sum of
    // at most 8 terms: a, b, c ≤ 2²⁷ and u, v < 2⁴².
    let (mut a, mut b, mut c, mut u, mut v) = (0i64, 0i64, 0i64, 0i64, 0i64);
    for (s, &k) in shifts.iter().zip(choices) {
        let Some((shift, w)) = candidate(s, k) else {
            continue;
        };
        // < 2¹⁶, so w·n stays within i32.
        let w = scale.apply(w) as i32;
        let (nx, ny) = normal(s);
        let (wx, wy) = (w * nx, w * ny);
        a += (mul(wx, nx) + (1 << 21)) >> 22;
        b += (mul(wx, ny) + (1 << 21)) >> 22;
        c += (mul(wy, ny) + (1 << 21)) >> 22;
        u += (mul(wx, shift) + (1 << 22)) >> 23;
        v += (mul(wy, shift) + (1 << 22)) >> 23;
    }
    let trace = a + c;
    // The largest weight (≥ ½) times its normal's length²: below 2⁻²⁰ the
    // normals are degenerate (≈ 0).
    if trace < 1 << 4 {
        return None;
    }
    // Q48; a·c < 2⁵⁶ and b² ≤ a·c (rounding aside).
    let det = a * c - b * b;
    // trace ≤ 2²⁸ (|n|² ≤ 2 for a hand-built normal): 20·trace² < 2⁶¹ and
    // 441·det ≤ 441·trace²/4 < 2⁶³.
    if UNOBSERVABLE_DET * det < UNOBSERVABLE_TRACE2 * trace * trace {
        // Only the component along the large eigenvalue's eigenvector e is
        // observable: t = (e·(u, v) / λ₁) e.
        let spread = (((a - c) * (a - c) + 4 * b * b) as u64).isqrt() as i64;
        let large = (trace + spread) / 2;
        // (λ₁ − c, b) and (b, λ₁ − a) are both eigenvectors; the one whose
        // larger component is not a difference of nearly equal values.
        let (ex, ey) = if a >= c {
            unit(large - c, b)
        } else {
            unit(b, large - a)
        };
        // One sign for the reported direction (−e_y, e_x): e_x > 0, or
        // e_x = 0 and e_y > 0.
        let (ex, ey) = if ex < 0 || (ex == 0 && ey < 0) {
            (-ex, -ey)
        } else {
            (ex, ey)
        };
        // e·(u, v) / λ₁: Q48 / Q24 → Q24 pixels.
        let along = dot_over(ex, u, ey, v, large);
        // Only normals far from unit length (hand-built) can make a
        // product with e overflow: saturated.
        let component = |e: i64| saturate(along.saturating_mul(e) >> 32);
        let q16 = |e: i64| ((e + (1 << 7)) >> 8) as i32;
        return Some(Fit {
            t: (component(ex), component(ey)),
            unobservable: Some((q16(-ey), q16(ex))),
            scale,
        });
    }
    // Cramer's rule: t = (c·u − b·v, a·v − b·u) / det; det (Q48) ≥
    // 0.045·trace² ≥ 0.011 here, so in Q24 it keeps 17 bits or more.
    let det_q24 = (det >> 24).max(1);
    Some(Fit {
        t: (
            saturate(dot_over(c, u, -b, v, det_q24) >> 8),
            saturate(dot_over(a, v, -b, u, det_q24) >> 8),
        ),
        unobservable: None,
        scale,
    })
}

/// `(p·u + q·v) / d` for Q24 `p, q` (≤ 2²⁸), Q24 `u, v` (< 2⁴²) and a
/// positive Q24 `d`: Q24. Exact products while they fit 64 bits (right-hand
/// sides below ~2¹² px); beyond, `u, v` lose their last 8 bits first.
fn dot_over(p: i64, u: i64, q: i64, v: i64, d: i64) -> i64 {
    let exact = p
        .checked_mul(u)
        .zip(q.checked_mul(v))
        .and_then(|(pu, qv)| pu.checked_add(qv));
    // `checked_div` keeps it total (`d ≤ 0` gives 0).
    let over = |n: i64| {
        if d > 0 {
            n.checked_div(d).unwrap_or(0)
        } else {
            0
        }
    };
    match exact {
        Some(n) => over(n),
        // |p·(u/2⁸)| < 2⁶², and so is the sum.
        None => over(p * (u >> 8) + q * (v >> 8)).saturating_mul(1 << 8),
    }
}

/// `(x, y)` (Q24, |x|, |y| ≤ 2²⁸) as a unit vector, Q24; `(1, 0)` for 0.
fn unit(x: i64, y: i64) -> (i64, i64) {
    let length = ((x * x + y * y) as u64).isqrt() as i64;
    match length {
        0 => (1 << 24, 0),
        _ => ((x << 24) / length, (y << 24) / length),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn column(deg: f32, t: (f32, f32), noise: f32) -> ColumnShift {
        let (s, c) = deg.to_radians().sin_cos();
        let shift = c * t.0 + s * t.1 + noise;
        ColumnShift {
            normal_q15: ((c * 32768.0) as i32, (s * 32768.0) as i32),
            best: Shift {
                shift_q16: (shift * 65536.0) as i32,
                score_q16: 1 << 16,
            },
            runners_up: [Shift::default(); RUNNERS_UP],
        }
    }

    /// `column` whose best shift is `wrong` pixels off, with the right shift
    /// as its runner-up of weight ¾.
    fn locked_on_wrong_wall(deg: f32, t: (f32, f32), wrong: f32) -> ColumnShift {
        let right = column(deg, t, 0.0);
        ColumnShift {
            runners_up: [
                Shift {
                    shift_q16: right.best.shift_q16,
                    score_q16: 3 << 14,
                },
                Shift::default(),
            ],
            ..column(deg, t, wrong)
        }
    }

    #[test]
    fn recovers_translation_and_drops_an_outlier() {
        let t = (3.25, -1.5);
        let cols = [
            column(0.0, t, 0.0),
            column(90.0, t, 0.0),
            column(45.0, t, 0.0),
            column(130.0, t, 9.0),
        ];
        let fit = fit_translation(&cols).unwrap();
        assert!((fit.x.to_num::<f32>() - 3.25).abs() < 0.01);
        assert!((fit.y.to_num::<f32>() + 1.5).abs() < 0.01);
        assert!(fit.unobservable.is_none());
        assert_eq!(fit.columns, 3);
    }

    #[test]
    fn agreeing_columns_keep_their_best_shifts() {
        let t = (-4.0, 2.5);
        let cols = [
            column(10.0, t, 0.3),
            column(100.0, t, -0.2),
            column(55.0, t, 0.1),
        ];
        let fit = fit_translation(&cols).unwrap();
        assert_eq!(fit.columns, 3);
        assert!(
            fit.residual > 0,
            "three columns with noise disagree a little"
        );
        assert!((fit.x.to_num::<f32>() + 4.0).abs() < 0.5);
        assert!((fit.y.to_num::<f32>() - 2.5).abs() < 0.5);
    }

    #[test]
    fn a_column_locked_on_the_wrong_wall_takes_its_runner_up() {
        // Three columns, one 12 px off (a parallel wall): least squares over
        // the best shifts would be ~4 px off; the runner-up agrees with the
        // other two.
        let t = (6.0, -3.0);
        let cols = [
            column(0.0, t, 0.0),
            column(90.0, t, 0.0),
            locked_on_wrong_wall(45.0, t, 12.0),
        ];
        let fit = fit_translation(&cols).unwrap();
        assert_eq!(fit.columns, 3);
        assert!((fit.x.to_num::<f32>() - 6.0).abs() < 0.01, "{fit:?}");
        assert!((fit.y.to_num::<f32>() + 3.0).abs() < 0.01, "{fit:?}");
        assert!(fit.residual < I16F16::from_num(0.01));
    }

    #[test]
    fn two_columns_fit_exactly_and_say_so() {
        let cols = [column(0.0, (1.0, 2.0), 5.0), column(90.0, (1.0, 2.0), 0.0)];
        let fit = fit_translation(&cols).unwrap();
        assert_eq!(fit.columns, 2);
        assert_eq!(fit.residual, 0);
        assert!((fit.x.to_num::<f32>() - 6.0).abs() < 0.01);
    }

    #[test]
    fn corridor_reports_the_unobservable_direction() {
        let t = (2.0, 5.0);
        let cols = [
            column(90.0, t, 0.0),
            column(92.0, t, 0.0),
            column(88.0, t, 0.0),
        ];
        let fit = fit_translation(&cols).unwrap();
        let (ux, uy) = fit.unobservable.unwrap();
        assert!(ux.to_num::<f32>().abs() > 0.99 && uy.to_num::<f32>().abs() < 0.1);
        assert!((fit.y.to_num::<f32>() - 5.0).abs() < 0.2);
    }
}
