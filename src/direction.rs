//! α versus α + π: the two half-turn tests, one shape. Both take a
//! correlation peak and return its rotation α, a [`HalfTurnTest`] (the
//! scores of α and α + π and the choice) and, for the improved test, the
//! pose the profile shifts imply.
//!
//! * [`paper`]: the paper's section 8 — Pearson correlation of the
//!   asymmetry maps `S1(θ)` and `S2(θ + α)` versus `S2(θ + α + π) = −S2(θ + α)`
//!   ([`paper_asymmetry`]). `l` and `u` are set by stray pixels, so this flips
//!   about half the time with 10 % outliers (DESIGN.md §3).
//! * [`improved`]: the ρ-profile of each strong θ column of image 1 against
//!   the column at θ + α of image 2, direct versus mirrored
//!   ([`match_profile`]), each at its best ρ shift. The mirrored profile wins
//!   when the rotation is α + π; the shifts give the translation (and the
//!   scale, when searched).

use crate::accumulator::{vote_profile_column, Column, UNIT_SCALE_Q16};
use crate::angle::Angle;
use crate::correlation::Peak;
use crate::grid::Grid;
use crate::pose::scale::{search_scale, PoseColumn, PoseSearch, ScaleRange};
use crate::pose::{fit_translation, ColumnShift, Pose};
use crate::profile::match_profile;
use crate::reference::{Reference, PROFILE_COLUMNS};
use crate::signature::Signature;
use crate::trig::TrigTable;
use crate::Score;
use heapless::Vec;

/// The paper's direction score: Pearson correlation of `S1(θ)` and
/// `S2(θ + k·Δθ)` over the full circle, in Q16 ([−1, 1]). The score of
/// α + π is its negation. 0 when either map is identically zero.
pub fn paper_asymmetry<const HALF: usize>(
    s1: &Signature<HALF>,
    s2: &Signature<HALF>,
    k: usize,
) -> i32 {
    // Over the full circle S has mean 0 (S(θ + π) = −S(θ)) and both halves
    // contribute the same products, so the half circle gives the same value.
    // i16 products ≤ 2³⁰, HALF ≤ 2¹¹ terms: every sum ≤ 2⁴¹, each root ≤ 2²¹,
    // so `dot · 2¹⁶ ≤ 2⁵⁷` fits i64.
    let mut dot = 0i64;
    let mut sq1 = 0i64;
    let mut sq2 = 0i64;
    let k = k % (2 * HALF).max(1);
    for (i, &a) in s1.asymmetries().iter().enumerate() {
        let b = s2.asymmetry(i + k);
        dot += i64::from(a) * i64::from(b);
        sq1 += i64::from(a) * i64::from(a);
        sq2 += i64::from(b) * i64::from(b);
    }
    let norm =
        i64::from(sq1.unsigned_abs().isqrt() as u32) * i64::from(sq2.unsigned_abs().isqrt() as u32);
    if norm == 0 {
        return 0;
    }
    ((dot << 16) / norm).clamp(-(1 << 16), 1 << 16) as i32
}

/// Which member of the pair α, α + π the direction test chose.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum HalfTurn {
    /// α (the correlation shift as is).
    Direct,
    /// α + π.
    Flipped,
}

/// The direction test's two scores (in [−1, 1]; paper mode: `flipped =
/// −direct`) and its choice.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HalfTurnTest {
    /// The chosen member.
    pub chosen: HalfTurn,
    /// Score of α.
    pub direct: Score,
    /// Score of α + π.
    pub flipped: Score,
}

impl HalfTurnTest {
    /// How clearly the chosen member won, in [0, 1] (Q16.16; 0: a tie):
    /// `(winner − loser) / max(|winner|, |loser|)` (improved mode, both
    /// scores in [0, 1]), or `|direct|` when `flipped = −direct` (paper
    /// mode), clamped to [0, 1].
    ///
    /// Total on any scores (the fields are public): negation, `abs`,
    /// difference and quotient saturate, so no input overflows. The clamp
    /// leaves every value the library's own scores give as it is (paper:
    /// `flipped = −direct` in [−1, 1]; improved: both in [0, 1]); it binds
    /// only on hand-built scores: beyond [−1, 1], or of opposite signs
    /// without being each other's negation (0.9 against −0.5 would give
    /// 1.4 / 0.9 ≈ 1.56), which read 1.
    pub fn margin(&self) -> Score {
        let (hi, lo) = if self.direct >= self.flipped {
            (self.direct, self.flipped)
        } else {
            (self.flipped, self.direct)
        };
        let margin = if lo == hi.saturating_neg() {
            hi.saturating_abs()
        } else {
            let scale = hi.saturating_abs().max(lo.saturating_abs());
            if scale == Score::ZERO {
                Score::ZERO
            } else {
                hi.saturating_sub(lo).saturating_div(scale)
            }
        };
        // Already ≥ 0 (hi ≥ lo, and `abs` saturates to a non-negative value).
        margin.clamp(Score::ZERO, Score::ONE)
    }
}

/// The paper's test of correlation peak `peak` (whole θ steps):
/// α = `peak.shift` steps, scored by [`paper_asymmetry`] (`flipped =
/// −direct`); no pose.
pub(crate) fn paper<const N: usize, const HALF: usize>(
    reference: &Signature<HALF>,
    current: &Signature<HALF>,
    peak: &Peak,
) -> (Angle, HalfTurnTest, Option<Pose>) {
    let alpha = Angle::from_steps_q16((peak.shift as i64) << 16, N);
    let direct = Score::from_bits(paper_asymmetry(reference, current, peak.shift));
    let chosen = if direct >= Score::ZERO {
        HalfTurn::Direct
    } else {
        HalfTurn::Flipped
    };
    (
        alpha,
        HalfTurnTest {
            chosen,
            direct,
            flipped: -direct,
        },
        None,
    )
}

/// The improved test of rotation `alpha` (a correlation peak, sub-step):
/// every reference profile column θ against column θ + α of `grid`, direct
/// and mirrored, within ±`max_shift` bins; the half with the larger mean
/// match score wins. The columns at least 30 % as strong as the strongest
/// give the pose: the translation fitted to their shifts, and the scale
/// when `scale` is set. `column` is scratch.
pub(crate) fn improved<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const HALF: usize,
    const RHO: usize,
>(
    reference: &Reference<W, H, RW, HALF, RHO>,
    grid: &Grid<W, H, RW>,
    alpha: Angle,
    scale: Option<ScaleRange>,
    max_shift: usize,
    column: &mut Column<RHO>,
) -> (Angle, HalfTurnTest, Option<Pose>) {
    let table = &TrigTable::<N>::TABLE;
    let mut pose_columns: Vec<PoseColumn<'_, RHO>, PROFILE_COLUMNS> = Vec::new();
    let mut direct_shifts: Vec<ColumnShift, PROFILE_COLUMNS> = Vec::new();
    let mut flipped_shifts: Vec<ColumnShift, PROFILE_COLUMNS> = Vec::new();
    let (mut direct_sum, mut flipped_sum) = (0u64, 0u64);
    // For the pose, columns count by their strength D(θ): a weak column's
    // shift is mostly clutter. For the direction every column counts the
    // same (measured: weighting by strength flips more real scan pairs,
    // strong walls are often mirror-symmetric corridors).
    let strongest = reference
        .profiles()
        .first()
        .map_or(1, |p| u64::from(reference.signature().peak(p.theta)).max(1));
    for profile in reference.profiles() {
        // Column of image 2 where the reference column θ lands under α.
        let theta = Angle::from_steps_q16((profile.theta as i64) << 16, N);
        let m = (theta + alpha).nearest_step(N);
        vote_profile_column::<W, H, RW, N, HALF, RHO>(grid, m, UNIT_SCALE_Q16, column);
        let direct = match_profile(&profile.counts, column, max_shift, false);
        let flipped = match_profile(&profile.counts, column, max_shift, true);
        let strength = u64::from(reference.signature().peak(profile.theta));
        direct_sum += u64::from(direct.best.score_q16);
        flipped_sum += u64::from(flipped.best.score_q16);
        // Only columns at least 30 % as strong as the strongest locate
        // the pose, weighted by score × relative strength.
        if 10 * strength >= 3 * strongest {
            let pose = PoseColumn {
                counts: &profile.counts,
                m,
                normal_q15: (table.cos(m), table.sin(m)),
                relative_q16: (strength << 16) / strongest,
            };
            let _ = direct_shifts.push(pose.shift(direct));
            let _ = flipped_shifts.push(pose.shift(flipped));
            let _ = pose_columns.push(pose);
        }
    }
    let count = reference.profiles().len().max(1) as u64;
    let direct = Score::from_bits((direct_sum / count).min(1 << 16) as i32);
    let flipped = Score::from_bits((flipped_sum / count).min(1 << 16) as i32);
    let chosen = if direct >= flipped {
        HalfTurn::Direct
    } else {
        HalfTurn::Flipped
    };
    let mirrored = chosen == HalfTurn::Flipped;
    let translation = match scale {
        None => fit_translation(if mirrored {
            &flipped_shifts
        } else {
            &direct_shifts
        }),
        Some(range) => {
            let (shifts, scale_q16) = search_scale::<W, H, RW, N, HALF, RHO>(
                grid,
                &pose_columns,
                PoseSearch {
                    range,
                    mirrored,
                    max_shift,
                },
                column,
            );
            fit_translation(&shifts).map(|t| t.scaled(scale_q16))
        }
    };
    (
        alpha,
        HalfTurnTest {
            chosen,
            direct,
            flipped,
        },
        translation,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn margin_by_hand() {
        let t = HalfTurnTest {
            chosen: HalfTurn::Direct,
            direct: Score::from_num(0.8),
            flipped: Score::from_num(0.6),
        };
        assert!((t.margin().to_num::<f32>() - 0.25).abs() < 1e-3);
        let p = HalfTurnTest {
            chosen: HalfTurn::Flipped,
            direct: Score::from_num(-0.3),
            flipped: Score::from_num(0.3),
        };
        assert!((p.margin().to_num::<f32>() - 0.3).abs() < 1e-3);
    }

    /// Total on any scores (the fields are public): the extremes of
    /// `Score` saturate instead of overflowing in `−hi` or `abs`, and scores
    /// outside [−1, 1] give a margin in [0, 1].
    #[test]
    fn margin_is_total() {
        let s = |v: f64| Score::from_num(v);
        let delta = Score::DELTA;
        for (direct, flipped, expected) in [
            (Score::MIN, Score::MIN, Score::ZERO),
            (Score::MIN, Score::MAX, Score::ONE),
            (Score::MAX, Score::MIN, Score::ONE),
            (Score::MAX, Score::MAX, Score::ZERO),
            (Score::ZERO, Score::ZERO, Score::ZERO),
            // Negations beyond 1 (`|direct|`, was 3 and 32 768 − 2⁻¹⁶).
            (s(3.0), s(-3.0), Score::ONE),
            (Score::MAX, -Score::MAX, Score::ONE),
            (Score::MIN + delta, Score::MAX, Score::ONE),
            // Opposite signs beyond 1 (was 1.5 and 2).
            (s(-2.0), s(1.0), Score::ONE),
            (s(-4.0), s(4.0) + delta, Score::ONE),
            (Score::MIN, Score::ZERO, Score::ONE),
            // Same signs beyond 1: within [0, 1] already, as before.
            (s(5.0), s(1.0), s(0.8)),
            (s(-100.0), s(-300.0), s(2.0 / 3.0)),
            (s(2.0), s(2.0), Score::ZERO),
            (Score::MAX, Score::ONE, Score::ONE - Score::ONE / Score::MAX),
        ] {
            let t = HalfTurnTest {
                chosen: HalfTurn::Direct,
                direct,
                flipped,
            };
            let margin = t.margin();
            assert!(
                (Score::ZERO..=Score::ONE).contains(&margin),
                "{direct} {flipped}: {margin}"
            );
            assert!(
                (margin - expected).abs() <= 2 * delta,
                "{direct} {flipped}: {margin}, expected {expected}"
            );
        }
    }

    /// The margin before the clamp (the former body of `margin`).
    fn unclamped(direct: Score, flipped: Score) -> Score {
        let (hi, lo) = if direct >= flipped {
            (direct, flipped)
        } else {
            (flipped, direct)
        };
        if lo == hi.saturating_neg() {
            return hi.saturating_abs();
        }
        let scale = hi.saturating_abs().max(lo.saturating_abs());
        if scale == Score::ZERO {
            Score::ZERO
        } else {
            hi.saturating_sub(lo).saturating_div(scale)
        }
    }

    /// Over a grid of scores in [−1, 1] (every 1 237th Q16 value and the
    /// ends): the margin is the documented formula, computed in `f64`,
    /// within 2⁻¹⁵; it equals the former value wherever that was at most 1,
    /// which covers every pair the library builds (`flipped = −direct`;
    /// both in [0, 1]). The former value exceeded 1 only for opposite signs
    /// that are not each other's negation, and these now read exactly 1.
    #[test]
    fn margin_in_range_matches_the_formula() {
        let mut grid: Vec<Score, 128> = (-(1 << 16)..=1 << 16)
            .step_by(1237)
            .map(Score::from_bits)
            .collect();
        for end in [Score::ONE, -Score::ONE, Score::DELTA, -Score::DELTA] {
            grid.push(end).unwrap();
        }
        let (mut same, mut clamped) = (0, 0);
        for &direct in &grid {
            for &flipped in &grid {
                let t = HalfTurnTest {
                    chosen: HalfTurn::Direct,
                    direct,
                    flipped,
                };
                let margin = t.margin();
                let (d, f) = (direct.to_num::<f64>(), flipped.to_num::<f64>());
                let (hi, lo) = (d.max(f), d.min(f));
                let raw = if lo == -hi {
                    hi.abs()
                } else if hi == 0.0 && lo == 0.0 {
                    0.0
                } else {
                    (hi - lo) / hi.abs().max(lo.abs())
                };
                let expected = raw.min(1.0);
                assert!(
                    (margin.to_num::<f64>() - expected).abs() <= 1.0 / 32768.0,
                    "{direct} {flipped}: {margin}, expected {expected}"
                );
                let before = unclamped(direct, flipped);
                if before <= Score::ONE {
                    assert_eq!(margin, before, "{direct} {flipped}");
                    same += 1;
                } else {
                    assert!(hi > 0.0 && lo < 0.0 && lo != -hi, "{direct} {flipped}");
                    assert_eq!(margin, Score::ONE, "{direct} {flipped}");
                    clamped += 1;
                }
                // The pairs the library builds are never clamped.
                if lo == -hi || lo >= 0.0 {
                    assert!(before <= Score::ONE, "{direct} {flipped}: {before}");
                }
            }
        }
        assert!(same > 0 && clamped > 0, "{same} {clamped}");
    }
}
