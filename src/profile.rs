//! Matching ρ-profiles: a strong θ column of the reference (its counts
//! scaled to `u8`) against a column of the second image, at every ρ shift
//! in a window, direct or mirrored (`ρ → −ρ`, the column of θ + π). A
//! translation `t` shifts column θ by `t·(cos θ, sin θ)`, so the best shift
//! measures `t` along the column's normal; the mirrored profile wins when
//! the rotation is α + π. The improved direction test, the translation and
//! the scale search all match profiles.

use crate::accumulator::Column;
use crate::math::{dot_u32, parabola_vertex, sqrt_of_product};

/// A ρ shift and its score: one local maximum of a profile match, or a
/// column's candidate shift in the translation fit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Shift {
    /// The shift `s` (bins = pixels, Q16, sub-bin by parabolic refinement)
    /// with `Q[b + s] ≈ P[b]` (direct) or `Q[b + s] ≈ P[RHO − b]` (mirrored).
    pub shift_q16: i32,
    /// Q16 in [0, 1]; 0 means no such shift. From a match: the normalised
    /// dot product there (`Σ P·Q / sqrt(ΣP² ΣQ²)`). In a [`ColumnShift`]
    /// (the fit's weight): that times the column's strength relative to the
    /// strongest.
    ///
    /// [`ColumnShift`]: crate::stages::ColumnShift
    pub score_q16: u32,
}

/// The best alignment of a reference profile with a column.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ProfileMatch {
    /// The best shift and its score.
    pub best: Shift,
    /// The next best local maxima of the match, more than
    /// [`RUNNER_UP_SEPARATION`] shifts from the best, strongest first
    /// (score 0: none): where parallel walls repeat, the right shift may be
    /// one of these.
    pub runners_up: [Shift; RUNNERS_UP],
}

/// How many runner-up shifts a [`ProfileMatch`] keeps.
pub const RUNNERS_UP: usize = 2;

/// A runner-up shift must lie more than this many shifts from the best one.
pub const RUNNER_UP_SEPARATION: i32 = 2;

/// Matches reference profile `profile` (counts scaled to `u8`) against
/// `column` of the second image, at every shift `|s| ≤ max_shift`, direct or
/// mirrored. Cost: at most `(2·max_shift + 1) × support` multiply-adds.
pub fn match_profile<const RHO: usize>(
    profile: &[u8; RHO],
    column: &Column<RHO>,
    max_shift: usize,
    mirrored: bool,
) -> ProfileMatch {
    match_profile_near(profile, column, 0, max_shift, mirrored)
}

/// [`match_profile`] over the shifts `|s − centre| ≤ radius` only (the scale
/// search refines around shifts it already knows). Cost: at most
/// `(2·radius + 1) × support` multiply-adds.
pub fn match_profile_near<const RHO: usize>(
    profile: &[u8; RHO],
    column: &Column<RHO>,
    centre: i32,
    radius: usize,
    mirrored: bool,
) -> ProfileMatch {
    match_curve(profile, column, centre, radius, mirrored).0
}

/// Half-width, in shifts, of the [`MatchCurve`] kept around the best shift.
const CURVE_RADIUS: usize = 2;

/// The normalised match score at the integer shifts around the best one, so
/// that the score at any nearby shift can be read without another pass.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct MatchCurve {
    best: i32,
    scores_q16: [u32; 2 * CURVE_RADIUS + 1],
}

impl MatchCurve {
    /// The score (Q16) at `shift_q16`, linear between the integer shifts;
    /// 0 farther than [`CURVE_RADIUS`] from the best integer shift.
    pub(crate) fn score_at(&self, shift_q16: i32) -> u32 {
        let from_first =
            i64::from(shift_q16) - (i64::from(self.best) - CURVE_RADIUS as i64) * 65536;
        if from_first < 0 {
            return 0;
        }
        let (i, f) = ((from_first >> 16) as usize, (from_first & 0xffff) as u64);
        let at = |k: usize| u64::from(self.scores_q16.get(k).copied().unwrap_or(0));
        ((at(i) * (65536 - f) + at(i + 1) * f) >> 16) as u32
    }
}

/// [`match_profile_near`] and the scores around its best integer shift.
/// Not inlined: the direction test calls it twice per column, and each
/// inlined copy would keep its own locals on the caller's stack.
#[inline(never)]
pub(crate) fn match_curve<const RHO: usize>(
    profile: &[u8; RHO],
    column: &Column<RHO>,
    centre: i32,
    radius: usize,
    mirrored: bool,
) -> (ProfileMatch, MatchCurve) {
    let none = (ProfileMatch::default(), MatchCurve::default());
    // The mirrored profile P'[b] = P[RHO − b] is read backwards in place (no
    // copy on the stack); bin 0 is never voted and counts as empty.
    let Some(profile_body) = profile.get(1..) else {
        return none;
    };
    let (Some((body_l, body_u)), Some((ql, qu))) = (support(profile_body), support(column)) else {
        return none;
    };
    // Support of P (or P') in bins.
    let (pl, pu) = if mirrored {
        (RHO - 1 - body_u, RHO - 1 - body_l)
    } else {
        (body_l + 1, body_u + 1)
    };
    let p_sq: u64 = profile_body
        .iter()
        .map(|&v| u64::from(u32::from(v) * u32::from(v)))
        .sum();
    let q_sq: u64 = column
        .iter()
        .map(|&v| u64::from(u32::from(v) * u32::from(v)))
        .sum();
    let norm = sqrt_of_product(p_sq, q_sq);
    if norm == 0 {
        return none;
    }
    // No shift beyond the column can overlap anyway.
    let radius = radius.min(RHO) as isize;
    let centre = (centre as isize).clamp(-(RHO as isize), RHO as isize);
    // Shifts that can overlap at all.
    let s_min = (ql as isize - pu as isize).max(centre - radius);
    let s_max = (qu as isize - pl as isize).min(centre + radius);
    let overlap = Overlap {
        profile: (pl, pu),
        column: (ql, qu),
        mirrored,
    };
    let mut best = (0u64, 0isize);
    // The strongest local maxima (dot, shift), strongest first.
    let mut maxima = [(0u64, 0isize); RUNNERS_UP + 1];
    // Dots at s − 2 and s − 1 (0 before the window).
    let (mut d2, mut d1) = (0u64, 0u64);
    for s in s_min..=s_max + 1 {
        let d = if s <= s_max {
            overlap.dot(profile, column, s)
        } else {
            0
        };
        if d > best.0 {
            best = (d, s);
        }
        if d1 > d2 && d1 >= d {
            keep_maximum(&mut maxima, (d1, s - 1));
        }
        (d2, d1) = (d1, d);
    }
    let (peak, s) = best;
    if peak == 0 {
        return none;
    }
    let mut runners_up = [Shift::default(); RUNNERS_UP];
    let others = maxima
        .iter()
        .filter(|m| m.0 > 0 && (m.1 - s).abs() > RUNNER_UP_SEPARATION as isize);
    for (slot, &(at, shift)) in runners_up.iter_mut().zip(others) {
        let (before, after) = (
            overlap.dot(profile, column, shift - 1),
            overlap.dot(profile, column, shift + 1),
        );
        *slot = Shift {
            score_q16: normalised(at, norm),
            shift_q16: ((shift as i64) << 16).saturating_add(parabola_vertex(
                before as i64,
                at as i64,
                after as i64,
                1 << 16,
                1 << 15,
            )) as i32,
        };
    }
    // The dot products at s − 2 ..= s + 2 (the middle one is the peak).
    let mut near = [0u64; 2 * CURVE_RADIUS + 1];
    for (k, d) in near.iter_mut().enumerate() {
        *d = overlap.dot(profile, column, s + k as isize - CURVE_RADIUS as isize);
    }
    let offset = parabola_vertex(
        near[CURVE_RADIUS - 1] as i64,
        peak as i64,
        near[CURVE_RADIUS + 1] as i64,
        1 << 16,
        1 << 15,
    );
    let curve = MatchCurve {
        best: s as i32,
        scores_q16: near.map(|d| normalised(d, norm)),
    };
    (
        ProfileMatch {
            best: Shift {
                shift_q16: ((s as i64) << 16).saturating_add(offset) as i32,
                score_q16: normalised(peak, norm),
            },
            runners_up,
        },
        curve,
    )
}

/// Inserts local maximum `(dot, shift)` into `maxima` (strongest first)
/// if it is stronger than the weakest kept.
fn keep_maximum(maxima: &mut [(u64, isize)], mut candidate: (u64, isize)) {
    for slot in maxima.iter_mut() {
        if candidate.0 > slot.0 {
            core::mem::swap(slot, &mut candidate);
        }
    }
}

/// Where a profile (or its mirror) and a column hold votes.
struct Overlap {
    /// Support of `P` (or `P'`), bins.
    profile: (usize, usize),
    /// Support of `Q`, bins.
    column: (usize, usize),
    /// `P'[b] = P[RHO − b]` instead of `P`.
    mirrored: bool,
}

impl Overlap {
    /// `Σ_b P[b]·Q[b + s]` (or with `P'`) over the bins where both hold
    /// votes; 0 when they do not overlap. Not inlined: the match calls it
    /// from several places and each inlined copy grew the caller's stack.
    #[inline(never)]
    fn dot<const RHO: usize>(&self, profile: &[u8; RHO], column: &Column<RHO>, s: isize) -> u64 {
        let ((pl, pu), (ql, qu)) = (self.profile, self.column);
        // b ∈ [pl, pu] with b + s ∈ [ql, qu].
        let lo = (pl as isize).max(ql as isize - s);
        let hi = (pu as isize).min(qu as isize - s);
        if lo > hi {
            return 0;
        }
        let (lo, hi) = (lo as usize, hi as usize);
        let q_lo = (lo as isize + s) as usize;
        let Some(q) = column.get(q_lo..=q_lo + (hi - lo)) else {
            return 0;
        };
        // Partial sums of DOT_CHUNK products stay in u32 (one 32-bit
        // multiply-add a bin on every target, no 64-bit multiply).
        if self.mirrored {
            // P'[lo..=hi] is P[RHO − hi ..= RHO − lo] reversed.
            match profile.get(RHO - hi..=RHO - lo) {
                Some(p) => p
                    .rchunks(DOT_CHUNK)
                    .zip(q.chunks(DOT_CHUNK))
                    .map(|(p, q)| u64::from(dot_u32(p.iter().rev(), q)))
                    .sum(),
                None => 0,
            }
        } else {
            match profile.get(lo..=hi) {
                Some(p) => p
                    .chunks(DOT_CHUNK)
                    .zip(q.chunks(DOT_CHUNK))
                    .map(|(p, q)| u64::from(dot_u32(p.iter(), q)))
                    .sum(),
                None => 0,
            }
        }
    }
}

/// Products per `u32` partial sum of the profile match:
/// `256 · 255 · 65 535 < 2³²`.
const DOT_CHUNK: usize = 256;

/// First and last index holding a non-zero value.
fn support<T: Copy + Into<u32>>(values: &[T]) -> Option<(usize, usize)> {
    let first = values.iter().position(|&v| v.into() != 0)?;
    let last = values.iter().rposition(|&v| v.into() != 0)?;
    Some((first, last))
}

/// `d / norm` in Q16, at most 1 (`d ≤ norm` by Cauchy–Schwarz, up to the
/// rounding of [`sqrt_of_product`]). `d < 2⁴⁸` (it is at most
/// `RHO · 255 · 2¹⁶`), so `d · 2¹⁶` fits `u64`.
fn normalised(d: u64, norm: u64) -> u32 {
    ((d.min(u64::MAX >> 16) << 16) / norm.max(1)).min(1 << 16) as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_shift_and_mirror() {
        let mut p = [0u8; 32];
        p[10] = 9;
        p[12] = 3;
        p[20] = 5;
        let mut q = [0u16; 32];
        // Direct, shifted by +3.
        for b in 0..29 {
            q[b + 3] = u16::from(p[b]);
        }
        let direct = match_profile(&p, &q, 8, false);
        let mirrored = match_profile(&p, &q, 8, true);
        assert_eq!(direct.best.shift_q16 >> 16, 3);
        assert_eq!(direct.best.score_q16, 1 << 16);
        assert!(mirrored.best.score_q16 < direct.best.score_q16);
        // Mirrored copy: Q[b] = P[32 − b − 2] → Q[b + (−2)]... matched by the mirrored test.
        let mut m = [0u16; 32];
        for b in 2..32 {
            m[b] = u16::from(p[(32 - b + 2) % 32]);
        }
        assert!(
            match_profile(&p, &m, 8, true).best.score_q16
                > match_profile(&p, &m, 8, false).best.score_q16
        );
    }

    #[test]
    fn repeated_walls_give_a_runner_up() {
        // One wall in the profile (bins 9–11), two parallel walls in the
        // column: 3 bins on (the stronger) and 15 bins on.
        let mut p = [0u8; 48];
        p[9..12].copy_from_slice(&[2, 8, 2]);
        let mut q = [0u16; 48];
        q[12..15].copy_from_slice(&[2, 8, 2]);
        q[24..27].copy_from_slice(&[1, 5, 1]);
        let m = match_profile(&p, &q, 20, false);
        assert_eq!(m.best.shift_q16, 3 << 16);
        let [first, second] = m.runners_up;
        assert_eq!(first.shift_q16, 15 << 16);
        assert!(first.score_q16 > 0 && first.score_q16 < m.best.score_q16);
        // Nothing else more than RUNNER_UP_SEPARATION from the best.
        assert_eq!(second.score_q16, 0);
    }
}
