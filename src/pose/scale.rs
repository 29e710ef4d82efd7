//! Scale of the scene between the two images: a bounded 1-D search.
//!
//! A scale `s` about the image centre stretches every accumulator column:
//! the line `ρ` of image 1 lies at `s·ρ + n·t` in image 2. Re-voting the
//! columns of image 2 at `ρ / s` undoes the stretch, so the score of a
//! candidate `s` is how well the reference profiles match those re-voted
//! columns (at their best shift). [`search`] scans the range on a coarse
//! grid, then halves the step three times around the best point and ends
//! with a parabola through the best point and its two nearest neighbours.

use crate::accumulator::{vote_profile_column, Column};
use crate::error::Error;
use crate::grid::Grid;
use crate::math::parabola_vertex;
use crate::pose::translation::{fit_best_shifts, ColumnShift};
use crate::profile::{match_curve, MatchCurve, ProfileMatch, Shift};
use crate::reference::PROFILE_COLUMNS;
use crate::Score;
use heapless::Vec;

/// The scales the estimator searches, `min ≤ s ≤ max`, with
/// `0.5 ≤ min ≤ max ≤ 2`.
///
/// Cost: one evaluation re-votes the reference's profile columns (at most
/// [`PROFILE_COLUMNS`](crate::stages::PROFILE_COLUMNS)) and matches them; a search
/// makes at most `MAX_COARSE_STEPS + 1 + 9 = 26` evaluations (17 + 9 for the
/// default range 0.8–1.25), the coarse ones over the whole shift window.
/// Below `s` = 1 the re-voted columns stretch by `1/s`: lines farther than
/// `s · RHO/2` pixels from the centre fall outside them and are dropped (a
/// scene filling a 128² image, `RHO` = 256, loses its outermost lines below
/// `s ≈ 0.72`); the estimate degrades, it does not fail.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ScaleRange {
    min: Score,
    max: Score,
}

/// Largest number of coarse steps of a search (the step grows beyond
/// `COARSE_STEP` for wide ranges).
pub const MAX_COARSE_STEPS: u32 = 16;

/// Preferred coarse step of the scale search: 2.5 %, about one bin at 40 px
/// from the centre, so the coarse grid cannot step over a match peak.
const COARSE_STEP: Score = Score::from_bits(1638);

impl ScaleRange {
    /// 0.8 to 1.25 (a camera whose height changes by ±20 %).
    pub const DEFAULT: ScaleRange = ScaleRange {
        min: Score::from_bits(52_429), // 0.8
        max: Score::from_bits(81_920), // 1.25
    };

    /// `min ≤ s ≤ max`.
    ///
    /// # Errors
    /// [`Error::InvalidScaleRange`] unless `0.5 ≤ min ≤ max ≤ 2`.
    pub fn new(min: Score, max: Score) -> Result<Self, Error> {
        let (lowest, highest) = (Score::from_num(0.5), Score::from_num(2));
        if lowest <= min && min <= max && max <= highest {
            Ok(Self { min, max })
        } else {
            Err(Error::InvalidScaleRange)
        }
    }

    /// Smallest scale searched.
    pub const fn min(&self) -> Score {
        self.min
    }

    /// Largest scale searched.
    pub const fn max(&self) -> Score {
        self.max
    }
}

impl Default for ScaleRange {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Which shifts an evaluation of the search must try.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Window {
    /// The whole shift window (coarse grid: the shifts are not known yet).
    Full,
    /// Near the shifts of the best coarse evaluation (refinement).
    Near,
}

/// The scale (Q16) in `range` maximising `score(s_q16, window)`.
///
/// `score` is evaluated at most `MAX_COARSE_STEPS + 1 + 9` times: the coarse
/// grid with [`Window::Full`], then six refinements, the two neighbours of
/// the final parabola and its vertex with [`Window::Near`]. The caller keeps the shifts of the best
/// [`Window::Full`] evaluation as the centres of the later ones; the last
/// call is always at the returned scale, so the caller's last shifts belong
/// to it.
pub(crate) fn search(range: ScaleRange, mut score: impl FnMut(u32, Window) -> u64) -> u32 {
    let (min, max) = (range.min.to_bits() as u32, range.max.to_bits() as u32);
    let width = max - min;
    let steps = width
        .div_ceil(COARSE_STEP.to_bits() as u32)
        .clamp(1, MAX_COARSE_STEPS);
    let step = (width / steps).max(1);
    let mut best = (0u64, min);
    for i in 0..=steps {
        let s = if i == steps { max } else { min + i * step };
        let value = score(s, Window::Full);
        if value > best.0 {
            best = (value, s);
        }
    }
    // Three halvings around the best point, each keeping the best of three.
    let (mut value, mut s) = best;
    let mut half = step / 2;
    for _ in 0..3 {
        let below = s.saturating_sub(half).max(min);
        let above = (s + half).min(max);
        let (v_below, v_above) = (score(below, Window::Near), score(above, Window::Near));
        if v_below > value && v_below >= v_above {
            (value, s) = (v_below, below);
        } else if v_above > value {
            (value, s) = (v_above, above);
        }
        half /= 2;
    }
    // A parabola through the best point and its neighbours at `half`.
    let (before, after) = (
        score(s.saturating_sub(half).max(min), Window::Near) as i64,
        score((s + half).min(max), Window::Near) as i64,
    );
    // Scores are at most a few 2¹⁶ (Q16 weights of ≤ 4 columns) and the
    // spacing below 2¹⁶, so nothing here comes near the i64 range (the
    // vertex is exact and panic-free for any inputs anyway).
    let spacing = i64::from(half);
    let offset = parabola_vertex(before, value as i64, after, spacing, spacing);
    let refined = (i64::from(s) + offset)
        .max(i64::from(min))
        .min(i64::from(max)) as u32;
    // The caller's last shifts must belong to the returned scale.
    score(refined, Window::Near);
    refined
}

/// A reference column that locates the pose: its profile, the column `m` of
/// image 2 it lands on, that column's normal and its relative strength.
pub(crate) struct PoseColumn<'a, const RHO: usize> {
    pub(crate) counts: &'a [u8; RHO],
    pub(crate) m: usize,
    pub(crate) normal_q15: (i32, i32),
    pub(crate) relative_q16: u64,
}

impl<const RHO: usize> PoseColumn<'_, RHO> {
    /// The column's shift for the translation fit, weighted by the match
    /// score times the relative strength (both Q16).
    pub(crate) fn shift(&self, m: ProfileMatch) -> ColumnShift {
        ColumnShift {
            normal_q15: self.normal_q15,
            best: self.weighted(m.best),
            runners_up: m.runners_up.map(|r| self.weighted(r)),
        }
    }

    /// Match score (Q16) times relative strength, Q16.
    fn weighted(&self, shift: Shift) -> Shift {
        Shift {
            shift_q16: shift.shift_q16,
            score_q16: ((u64::from(shift.score_q16) * self.relative_q16) >> 16) as u32,
        }
    }
}

/// What the scale search needs besides the columns.
pub(crate) struct PoseSearch {
    pub(crate) range: ScaleRange,
    pub(crate) mirrored: bool,
    pub(crate) max_shift: usize,
}

/// Searches the scale (Q16) over `search.range`. Each candidate `s` re-votes
/// the pose columns of `grid` at `ρ / s` and matches them; the translation
/// fitted to their best shifts predicts a shift per column, and the score of
/// `s` is the columns' match at those predicted shifts, weighted by relative
/// strength. A column holding a single line matches at every scale (the
/// stretch of one peak looks like a shift); only at the right scale do three
/// or more columns agree on one translation. Returns the column shifts at
/// the chosen scale (they measure `n·t / s`) and the scale. `column` is
/// scratch.
///
/// The coarse evaluations search the whole shift window: a window around
/// the shifts found at `s = 1` was measured to lose corridors (at the wrong
/// scale the two walls of a column cannot both align, and the `s = 1` match
/// may lock one wall onto the other, a jump of their separation; 10 % of
/// 256² corridors).
///
/// Not inlined: its locals stay off the stack of estimates without the
/// scale search.
#[inline(never)]
pub(crate) fn search_scale<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const HALF: usize,
    const RHO: usize,
>(
    grid: &Grid<W, H, RW>,
    columns: &[PoseColumn<'_, RHO>],
    search: PoseSearch,
    column: &mut Column<RHO>,
) -> (Vec<ColumnShift, PROFILE_COLUMNS>, u32) {
    // Between the best coarse scale and the final one the shift `n·t / s`
    // moves by at most a coarse step (≤ 3 %) of the largest shift.
    let radius = 2 + search.max_shift / 16;
    let mut centres = [0i32; PROFILE_COLUMNS];
    let mut best_full = 0u64;
    let mut shifts: Vec<ColumnShift, PROFILE_COLUMNS> = Vec::new();
    let scale_q16 = self::search(search.range, |s_q16, window| {
        let inv_scale_q16 =
            ((1u64 << 32) / u64::from(s_q16.max(1))).min(u64::from(u32::MAX)) as u32;
        shifts.clear();
        let mut curves = [MatchCurve::default(); PROFILE_COLUMNS];
        for ((pose, centre), curve) in columns.iter().zip(centres).zip(curves.iter_mut()) {
            vote_profile_column::<W, H, RW, N, HALF, RHO>(grid, pose.m, inv_scale_q16, column);
            let (centre, radius) = match window {
                Window::Full => (0, search.max_shift),
                Window::Near => (centre, radius),
            };
            let (m, c) = match_curve(pose.counts, column, centre, radius, search.mirrored);
            *curve = c;
            let _ = shifts.push(pose.shift(m));
        }
        // Scored on the best shifts alone; the pose itself, fitted to the
        // shifts of the chosen scale, weighs the runners-up too.
        let total = fit_best_shifts(&shifts).map_or(0, |t| {
            columns
                .iter()
                .zip(curves)
                .map(|(pose, curve)| {
                    let predicted = t.column_shift_q16(pose.normal_q15);
                    (u64::from(curve.score_at(predicted)) * pose.relative_q16) >> 16
                })
                .sum()
        });
        if window == Window::Full && total > best_full {
            best_full = total;
            for (centre, shift) in centres.iter_mut().zip(&shifts) {
                *centre = (shift.best.shift_q16 + (1 << 15)) >> 16;
            }
        }
        total
    });
    (shifts, scale_q16)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth single-peaked score with its maximum at `peak` (Q16).
    fn peaked(peak: u32) -> impl FnMut(u32, Window) -> u64 {
        move |s, _| {
            let d = (i64::from(s) - i64::from(peak)).unsigned_abs();
            1_000_000_000u64.saturating_sub(d * d / 8)
        }
    }

    #[test]
    fn finds_a_smooth_peak_to_a_fraction_of_a_percent() {
        for peak in [0.8, 0.83, 0.97, 1.0, 1.013, 1.1, 1.25] {
            let p = (peak * 65536.0) as u32;
            let s = search(ScaleRange::DEFAULT, peaked(p));
            let error = (f64::from(s) / 65536.0 - peak).abs();
            assert!(
                error < 0.001,
                "peak {peak}: found {}",
                f64::from(s) / 65536.0
            );
        }
    }

    #[test]
    fn evaluations_are_bounded_and_the_last_is_the_answer() {
        let (mut calls, mut last) = (0u32, None);
        let range = ScaleRange::new(Score::from_num(0.5), Score::from_num(2)).unwrap();
        let s = search(range, |s, w| {
            calls += 1;
            last = Some((s, w));
            peaked(70_000)(s, w)
        });
        assert!(calls <= MAX_COARSE_STEPS + 1 + 9);
        assert_eq!(last, Some((s, Window::Near)));
        assert!((i64::from(s) - 70_000).abs() < 65);
    }

    #[test]
    fn invalid_ranges_are_refused() {
        let n = Score::from_num;
        assert_eq!(
            ScaleRange::new(n(1.2), n(1.1)),
            Err(Error::InvalidScaleRange)
        );
        assert_eq!(
            ScaleRange::new(n(0.4), n(1.1)),
            Err(Error::InvalidScaleRange)
        );
        assert_eq!(
            ScaleRange::new(n(0.9), n(2.5)),
            Err(Error::InvalidScaleRange)
        );
        assert!(ScaleRange::new(n(1.0), n(1.0)).is_ok());
    }
}
