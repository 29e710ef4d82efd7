//! Matching ρ-profiles: a strong θ column of the reference (its counts
//! scaled to `u8`) against a column of the second image, at every ρ shift
//! in a window, direct or mirrored (`ρ → −ρ`, the column of θ + π). A
//! translation `t` shifts column θ by `t·(cos θ, sin θ)`, so the best shift
//! measures `t` along the column's normal; the mirrored profile wins when
//! the rotation is α + π. The improved direction test, the translation and
//! the scale search all match profiles.

use crate::accumulator::Column;
use crate::math::{parabola_vertex, sqrt_of_product, Lanes, LANES};

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
///
/// Each dot product in the window is computed once, [`LANES`] shifts per
/// pass ([`Overlap::dots`]); the scan keeps the dots it later needs (around
/// the best shift and around each kept maximum) and computes again only
/// those outside the window.
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
    let norm = sqrt_of_product(
        squares(profile_body.get(body_l..=body_u)),
        squares(column.get(ql..=qu)),
    );
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
    let mut scan = Scan::default();
    let mut s = s_min;
    while s <= s_max {
        let dots = overlap.dots(profile, column, s);
        for (t, &d) in (s..=s_max).zip(&dots) {
            scan.push(d, t);
        }
        s += LANES as isize;
    }
    // 0 after the window closes the last maximum.
    scan.push(0, s_max + 1);
    let (peak, s) = scan.best;
    if peak == 0 {
        return none;
    }
    // Dots the scan did not see: those outside the window.
    let dot_at = |shift: isize, seen: u64| {
        if (s_min..=s_max).contains(&shift) {
            seen
        } else {
            overlap.dots(profile, column, shift)[0]
        }
    };
    let mut runners_up = [Shift::default(); RUNNERS_UP];
    let others = scan
        .maxima
        .iter()
        .filter(|m| m.dot > 0 && (m.shift - s).abs() > RUNNER_UP_SEPARATION as isize);
    for (slot, m) in runners_up.iter_mut().zip(others) {
        let (before, after) = (dot_at(m.shift - 1, m.before), dot_at(m.shift + 1, m.after));
        *slot = Shift {
            score_q16: normalised(m.dot, norm),
            shift_q16: ((m.shift as i64) << 16).saturating_add(parabola_vertex(
                before as i64,
                m.dot as i64,
                after as i64,
                1 << 16,
                1 << 15,
            )) as i32,
        };
    }
    // The dot products at s − 2 ..= s + 2 (the middle one is the peak).
    let mut near = scan.near;
    for (k, d) in near.iter_mut().enumerate() {
        *d = dot_at(s + k as isize - CURVE_RADIUS as isize, *d);
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

/// `Σ v²` of a profile's or a column's support (0 for `None`).
fn squares<T: Copy + Into<u32>>(values: Option<&[T]>) -> u64 {
    values.map_or(0, |values| {
        values
            .iter()
            .map(|&v| {
                let v: u32 = v.into();
                u64::from(v * v)
            })
            .sum()
    })
}

/// A local maximum of the match with the dots at its neighbouring shifts
/// (as the scan saw them: 0 outside the window).
#[derive(Clone, Copy, Default)]
struct Maximum {
    dot: u64,
    shift: isize,
    before: u64,
    after: u64,
}

/// The state of the scan over the window of shifts, fed one dot at a time
/// in increasing shift order.
#[derive(Default)]
struct Scan {
    /// The largest dot and its shift (the first one on ties).
    best: (u64, isize),
    /// The dots at the best shift − 2 ..= + 2 seen so far (0 outside the
    /// window).
    near: [u64; 2 * CURVE_RADIUS + 1],
    /// The strongest local maxima, strongest first.
    maxima: [Maximum; RUNNERS_UP + 1],
    /// Dots at the previous two shifts (0 before the window).
    previous: (u64, u64),
}

impl Scan {
    /// Feeds the dot `d` at shift `t` (the one after the last fed).
    fn push(&mut self, d: u64, t: isize) {
        let (d2, d1) = self.previous;
        if d > self.best.0 {
            self.best = (d, t);
            self.near = [d2, d1, d, 0, 0];
        } else if let Some(slot) = usize::try_from(t - self.best.1)
            .ok()
            .and_then(|k| self.near.get_mut(k + CURVE_RADIUS))
        {
            *slot = d;
        }
        if d1 > d2 && d1 >= d {
            keep_maximum(
                &mut self.maxima,
                Maximum {
                    dot: d1,
                    shift: t - 1,
                    before: d2,
                    after: d,
                },
            );
        }
        self.previous = (d1, d);
    }
}

/// Inserts local maximum `candidate` into `maxima` (strongest first) if it
/// is stronger than the weakest kept.
fn keep_maximum(maxima: &mut [Maximum], mut candidate: Maximum) {
    for slot in maxima.iter_mut() {
        if candidate.dot > slot.dot {
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
    /// `Σ_b P[b]·Q[b + s + j]` (or with `P'`) for the [`LANES`] shifts
    /// `s + j`, over the bins where both hold votes; 0 where they do not
    /// overlap. In one pass over the profile ([`Lanes`]): each bin of `P`
    /// and `Q` is read once for all the shifts. Exact: `u64` sums of `u32`
    /// partial sums of at most [`DOT_CHUNK`] products. Not inlined: the
    /// match calls it from several places and each inlined copy grew the
    /// caller's stack.
    #[inline(never)]
    fn dots<const RHO: usize>(
        &self,
        profile: &[u8; RHO],
        column: &Column<RHO>,
        s: isize,
    ) -> [u64; LANES] {
        let mut totals = [0u64; LANES];
        let ((pl, pu), (ql, qu)) = (self.profile, self.column);
        let last = LANES as isize - 1;
        // b ∈ [pl, pu] with b + s + j ∈ [ql, qu] for some lane j. For the
        // other lanes, the bins of Q it reads outside [ql, qu] hold 0.
        let lo = (pl as isize).max(ql as isize - s - last);
        let hi = (pu as isize).min(qu as isize - s);
        if lo > hi {
            return totals;
        }
        let (lo, hi) = (lo as usize, hi as usize);
        // The window starts at Q[lo + s] (0 left of the column).
        let start = lo as isize + s;
        let mut lanes = Lanes::starting(|j| {
            usize::try_from(start + j as isize)
                .ok()
                .and_then(|i| column.get(i))
                .map_or(0, |&v| u32::from(v))
        });
        // Q[b + s + last] for b = lo ..= hi, as far as the column goes
        // (`start + last ≥ ql`); the bins beyond it read 0.
        let bins = hi - lo + 1;
        let q = column.get((start + last) as usize..).unwrap_or(&[]);
        let q = q.get(..bins).unwrap_or(q);
        let p = if self.mirrored {
            // P'[lo..=hi] is P[RHO − hi ..= RHO − lo] reversed.
            profile.get(RHO - hi..=RHO - lo)
        } else {
            profile.get(lo..=hi)
        };
        let Some(p) = p else {
            return totals;
        };
        // The bins of P in step with those of Q (the first `q.len()`),
        // DOT_CHUNK at a time, then those in step with the end of Q.
        let tail = p.len().saturating_sub(q.len());
        let (mut head, mut rest) = (p, q);
        if self.mirrored {
            while let (Some((p_rest, p)), Some((q, q_rest))) = (
                head.split_at_checked(head.len().saturating_sub(DOT_CHUNK).max(tail)),
                rest.split_at_checked(rest.len().min(DOT_CHUNK)),
            ) {
                if q.is_empty() {
                    break;
                }
                lanes.feed::<_, true>(p, q);
                add(&mut totals, lanes.take());
                (head, rest) = (p_rest, q_rest);
            }
            for &p in head.iter().rev() {
                lanes = lanes.step(u32::from(p), 0);
            }
        } else {
            while let (Some((p, p_rest)), Some((q, q_rest))) = (
                head.split_at_checked(head.len().saturating_sub(tail).min(DOT_CHUNK)),
                rest.split_at_checked(rest.len().min(DOT_CHUNK)),
            ) {
                if q.is_empty() {
                    break;
                }
                lanes.feed::<_, false>(p, q);
                add(&mut totals, lanes.take());
                (head, rest) = (p_rest, q_rest);
            }
            for &p in head {
                lanes = lanes.step(u32::from(p), 0);
            }
        }
        add(&mut totals, lanes.take());
        totals
    }
}

/// Adds partial sums to the totals.
fn add(totals: &mut [u64; LANES], sums: [u32; LANES]) {
    for (total, sum) in totals.iter_mut().zip(sums) {
        *total += u64::from(sum);
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

    /// `Σ_b P[b]·Q[b + s]` (or with `P'[b] = P[RHO − b]`) over every bin
    /// `b ∈ 1..RHO` with `b + s` in the column: the straightforward loop.
    fn plain_dot<const RHO: usize>(p: &[u8; RHO], q: &[u16; RHO], s: isize, mirrored: bool) -> u64 {
        (1..RHO)
            .filter_map(|b| {
                let i = usize::try_from(b as isize + s).ok().filter(|&i| i < RHO)?;
                let pb = if mirrored { p[RHO - b] } else { p[b] };
                Some(u64::from(pb) * u64::from(q[i]))
            })
            .sum()
    }

    /// The match as first written: every dot by [`plain_dot`], the ones
    /// around the best shift and the runners-up computed again.
    fn plain_match<const RHO: usize>(
        p: &[u8; RHO],
        q: &[u16; RHO],
        centre: i32,
        radius: usize,
        mirrored: bool,
    ) -> (ProfileMatch, MatchCurve) {
        let none = (ProfileMatch::default(), MatchCurve::default());
        let body = |b: usize| if mirrored { p[RHO - b] } else { p[b] };
        let Some(pl) = (1..RHO).find(|&b| body(b) != 0) else {
            return none;
        };
        let pu = (1..RHO).rev().find(|&b| body(b) != 0).unwrap();
        let Some(ql) = (0..RHO).find(|&i| q[i] != 0) else {
            return none;
        };
        let qu = (0..RHO).rev().find(|&i| q[i] != 0).unwrap();
        let p_sq = (1..RHO).map(|b| u64::from(p[b]).pow(2)).sum();
        let q_sq = q.iter().map(|&v| u64::from(v).pow(2)).sum();
        let norm = sqrt_of_product(p_sq, q_sq);
        let radius = radius.min(RHO) as isize;
        let centre = (centre as isize).clamp(-(RHO as isize), RHO as isize);
        let s_min = (ql as isize - pu as isize).max(centre - radius);
        let s_max = (qu as isize - pl as isize).min(centre + radius);
        let dot = |s: isize| plain_dot(p, q, s, mirrored);
        let mut best = (0u64, 0isize);
        let mut maxima = [(0u64, 0isize); RUNNERS_UP + 1];
        let (mut d2, mut d1) = (0u64, 0u64);
        for s in s_min..=s_max + 1 {
            let d = if s <= s_max { dot(s) } else { 0 };
            if d > best.0 {
                best = (d, s);
            }
            if d1 > d2 && d1 >= d {
                let mut candidate = (d1, s - 1);
                for slot in maxima.iter_mut() {
                    if candidate.0 > slot.0 {
                        core::mem::swap(slot, &mut candidate);
                    }
                }
            }
            (d2, d1) = (d1, d);
        }
        let (peak, s) = best;
        if peak == 0 {
            return none;
        }
        let vertex = |before: u64, at: u64, after: u64| {
            parabola_vertex(before as i64, at as i64, after as i64, 1 << 16, 1 << 15)
        };
        let mut runners_up = [Shift::default(); RUNNERS_UP];
        let others = maxima
            .iter()
            .filter(|m| m.0 > 0 && (m.1 - s).abs() > RUNNER_UP_SEPARATION as isize);
        for (slot, &(at, shift)) in runners_up.iter_mut().zip(others) {
            *slot = Shift {
                score_q16: normalised(at, norm),
                shift_q16: ((shift as i64) << 16).saturating_add(vertex(
                    dot(shift - 1),
                    at,
                    dot(shift + 1),
                )) as i32,
            };
        }
        let near: [u64; 2 * CURVE_RADIUS + 1] =
            core::array::from_fn(|k| dot(s + k as isize - CURVE_RADIUS as isize));
        (
            ProfileMatch {
                best: Shift {
                    shift_q16: ((s as i64) << 16).saturating_add(vertex(near[1], peak, near[3]))
                        as i32,
                    score_q16: normalised(peak, norm),
                },
                runners_up,
            },
            MatchCurve {
                best: s as i32,
                scores_q16: near.map(|d| normalised(d, norm)),
            },
        )
    }

    /// xorshift64: reproducible test data without a dependency.
    struct Rng(u64);

    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            self.0
        }

        fn below(&mut self, n: u64) -> u64 {
            self.next() % n.max(1)
        }
    }

    /// Random values in a random sub-range of the bins, with zero runs;
    /// sometimes the largest values, sometimes none at all.
    fn random_bins<const RHO: usize>(rng: &mut Rng, max: u64) -> [u64; RHO] {
        let mut v = [0u64; RHO];
        let (a, b) = (
            rng.below(RHO as u64) as usize,
            rng.below(RHO as u64) as usize,
        );
        let density = rng.below(4);
        let top = [max, max, 3, 1][rng.below(4) as usize];
        for x in v.iter_mut().take(a.max(b) + 1).skip(a.min(b)) {
            if rng.below(4) >= density {
                *x = if rng.below(8) == 0 {
                    top
                } else {
                    rng.below(top + 1)
                };
            }
        }
        if rng.below(16) == 0 {
            v = [0; RHO];
        }
        v
    }

    fn agrees<const RHO: usize>(rng: &mut Rng, p: &[u8; RHO], q: &[u16; RHO]) {
        for mirrored in [false, true] {
            let overlap_of = || {
                let body = |b: usize| if mirrored { p[RHO - b] } else { p[b] };
                let pl = (1..RHO).find(|&b| body(b) != 0)?;
                let pu = (1..RHO).rev().find(|&b| body(b) != 0)?;
                Some(Overlap {
                    profile: (pl, pu),
                    column: support(q)?,
                    mirrored,
                })
            };
            if let Some(overlap) = overlap_of() {
                for s in -(RHO as isize) - 5..RHO as isize + 5 {
                    let dots = overlap.dots(p, q, s);
                    for (j, &d) in dots.iter().enumerate() {
                        let t = s + j as isize;
                        assert_eq!(d, plain_dot(p, q, t, mirrored), "{RHO} {mirrored} {t}");
                    }
                }
            }
            let r = RHO as u64;
            for (centre, radius) in [
                (0, RHO / 4),
                (0, RHO),
                (0, 0),
                (0, 1),
                (rng.below(2 * r) as i32 - r as i32, rng.below(r) as usize),
                (
                    rng.below(4 * r) as i32 - 2 * r as i32,
                    rng.below(3 * r) as usize,
                ),
                (i32::MIN, usize::MAX),
                (i32::MAX, 3),
            ] {
                assert_eq!(
                    match_curve(p, q, centre, radius, mirrored),
                    plain_match(p, q, centre, radius, mirrored),
                    "{RHO} {mirrored} {centre} {radius}\n{p:?}\n{q:?}"
                );
            }
        }
    }

    fn agrees_on_random<const RHO: usize>(cases: usize) {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15 ^ RHO as u64);
        for _ in 0..cases {
            let p = random_bins::<RHO>(&mut rng, 255).map(|v| v as u8);
            let q = random_bins::<RHO>(&mut rng, 65_535).map(|v| v as u16);
            agrees(&mut rng, &p, &q);
        }
    }

    /// Every dot, best shift, runner-up and curve value equals the plain
    /// double loop's, direct and mirrored, on random profiles and columns
    /// (zero runs, saturated values, empty ones; `RHO` 512 takes more
    /// than one `u32` partial sum).
    #[test]
    fn agrees_with_the_plain_loop() {
        agrees_on_random::<4>(300);
        agrees_on_random::<32>(300);
        agrees_on_random::<64>(200);
        agrees_on_random::<256>(40);
        agrees_on_random::<512>(8);
    }

    /// The edges: empty, a single bin, support at bin 0 (ignored in the
    /// profile) and at `RHO − 1`, windows beyond the column.
    #[test]
    fn agrees_with_the_plain_loop_at_the_edges() {
        const RHO: usize = 16;
        let mut rng = Rng(7);
        agrees(&mut rng, &[0; RHO], &[0; RHO]);
        agrees(&mut rng, &[255; RHO], &[65_535; RHO]);
        for (pb, qb) in [
            (0, 0),
            (1, 0),
            (RHO - 1, RHO - 1),
            (1, RHO - 1),
            (RHO - 1, 0),
            (8, 8),
        ] {
            for (pv, qv) in [(1, 1), (255, 65_535)] {
                let (mut p, mut q) = ([0u8; RHO], [0u16; RHO]);
                p[pb] = pv;
                q[qb] = qv;
                agrees(&mut rng, &p, &q);
                agrees(&mut rng, &[pv; RHO], &q);
                agrees(&mut rng, &p, &[qv; RHO]);
                // A second bin next to it.
                p[(pb + 1) % RHO] = 3;
                q[(qb + RHO - 1) % RHO] = 2;
                agrees(&mut rng, &p, &q);
            }
        }
    }

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
