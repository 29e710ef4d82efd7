//! Scoring poses on the beams, for the check of [`judge`](super::judge):
//! how well a pose lays each scan's end points onto the other's walls
//! ([`Raster::agreement_on_beams`]), and every listed rotation scored at
//! its best pose ([`Raster::check_on_beams`]: the grid's translation and the
//! strongest bins of a translation vote on the end points, the best of them
//! refined on the beams). What the scores mean and how they decide is in
//! `judge`'s module doc; the numbers (integer per beam, one 32-bit
//! arctangent per end point, a 41 × 41 byte vote on the stack) there too.

use super::beam::{BeamEnd, ScanBeams};
use super::judge::{
    q16_score, BeamAgreement, BeamCheck, BeamPose, BEAM_MATCH_M, BEAM_RIVAL_MAX_ROTATION_DEG,
    BEAM_SEEN_THROUGH_M,
};
use super::refine::{for_each_end, FitPose, MAX_TURN};
use super::segments::Segments;
use super::sine::sin_cos;
use super::{Raster, Scan};
use crate::angle::Angle;
use crate::pose::Pose;
use crate::{Estimate, Score};
use fixed::types::I16F16;
use heapless::Vec;

impl Raster {
    /// How well the pose `(alpha, t)` (the estimator's convention,
    /// `p₂ = R(α)·p₁ + t`, cells of this raster) lays `current`'s end points
    /// onto `reference`'s walls and the reverse, and how many of them land
    /// where the other sensor saw through (see the module doc). `None` when
    /// either scan's geometry is not finite or its sensor is far from the
    /// robot, or a scan has no valid end point.
    pub fn agreement_on_beams(
        &self,
        reference: &Scan<'_>,
        current: &Scan<'_>,
        alpha: Angle,
        t: (I16F16, I16F16),
    ) -> Option<BeamAgreement> {
        self.agreement_on(reference, current, alpha, t, Ends::All)
    }

    /// [`Self::agreement_on_beams`] over `ends` of each scan.
    fn agreement_on(
        &self,
        reference: &Scan<'_>,
        current: &Scan<'_>,
        alpha: Angle,
        t: (I16F16, I16F16),
        ends: Ends,
    ) -> Option<BeamAgreement> {
        let q16 = |metres: f32| self.metres_q16(metres);
        // τ between 1/256 cell and 256 cells: τ² below 2⁴⁸.
        let tau = q16(BEAM_MATCH_M).clamp(1 << 8, 1 << 24);
        // At least 32 units (cells below 200 m): `seen_through` needs it.
        let margin = q16(BEAM_SEEN_THROUGH_M).clamp(32, 1 << 30);
        let (tx, ty) = (i64::from(t.0.to_bits()), i64::from(t.1.to_bits()));
        // As the refinement: a translation beyond the beams' reach.
        if tx.abs().max(ty.abs()) >= 1 << 30 {
            return None;
        }
        // current → reference: p = R(θ)·q + d, θ = −α, d = −R(θ)·t;
        // reference → current: q = R(α)·p + t.
        let theta = alpha.0.wrapping_neg();
        let (s, c) = sin_cos(theta);
        let (c, s) = (i64::from(c), i64::from(s));
        let forward = FitPose {
            theta,
            d: (-((c * tx - s * ty) >> 16), -((s * tx + c * ty) >> 16)),
        };
        let backward = FitPose {
            theta: alpha.0,
            d: (tx, ty),
        };
        let mut into_reference = Segments::new(self, reference)?;
        let mut into_current = Segments::new(self, current)?;
        let a = one_way(
            &mut into_reference,
            &ScanBeams::new(current, self),
            current.ranges,
            &forward,
            (tau, margin),
            ends,
        )?;
        let b = one_way(
            &mut into_current,
            &ScanBeams::new(reference, self),
            reference.ranges,
            &backward,
            (tau, margin),
            ends,
        )?;
        let mean = |x: i64, y: i64| Score::from_bits(((x + y) / 2) as i32);
        Some(BeamAgreement {
            explained: mean(a.0, b.0),
            seen_through: mean(a.1, b.1),
            in_view: mean(a.2, b.2),
        })
    }

    /// Judges `estimate` on the beams: each listed rotation with a
    /// translation (the candidates and the runner-up, the chosen one
    /// included) is scored at its grid translation and at the
    /// three strongest translations of a vote on the end points;
    /// the best of these starts is refined on the beams (no direction held:
    /// every rotation gets the same treatment, and the reported translation
    /// drops its unobservable component, which the check must not) and kept
    /// if it scores better. `None` when no listed rotation within 5° of
    /// `estimate.alpha` has a translation or the beams cannot score it.
    ///
    /// Cost per listed rotation (at most five): one vote (96 × 96 end-point
    /// pairs), four starts scored on a sample of 96 end points a scan, two
    /// [`agreement_on_beams`](Self::agreement_on_beams) (the best start,
    /// then refined) and one refinement (choosing the start on all end
    /// points as well cost the check 12 % more, M4F real pairs median
    /// 8.32 → 7.44 M instructions, and changed 2 of 4 730 shared pairs from
    /// confident to flagged). The chosen rotation goes first; a rival whose
    /// best start trails it by 0.2 or more is not refined (its score is the
    /// start's; on the shared real pairs this changed no answer, only the
    /// reported scores of such rivals).
    pub fn check_on_beams(
        &self,
        reference: &Scan<'_>,
        current: &Scan<'_>,
        estimate: &Estimate,
    ) -> Option<BeamCheck> {
        // Other rotations: 5° apart, the estimator's separation of candidates
        // (evaluated at compile time: no floating point on the target).
        const SEPARATION: Angle = Angle::from_degrees(5.0);
        let mut chosen: Option<BeamPose> = None;
        let mut rival: Option<BeamPose> = None;
        let listed = estimate
            .candidates
            .iter()
            .chain(estimate.runner_up.as_ref());
        // The chosen rotation first: a rival that cannot come near it is not
        // refined.
        let in_order = listed
            .clone()
            .filter(|c| c.translation.is_some() && c.alpha.distance(estimate.alpha) < SEPARATION)
            .take(1)
            .chain(listed.filter(|c| c.alpha.distance(estimate.alpha) >= SEPARATION));
        for candidate in in_order {
            let Some((x, y)) = candidate.translation else {
                continue;
            };
            let is_chosen = candidate.alpha.distance(estimate.alpha) < SEPARATION;
            let grid = Pose {
                x,
                y,
                scale: I16F16::ONE,
                residual: I16F16::ZERO,
                columns: 0,
                unobservable: None,
            };
            let voted = voted_translations(self, reference, current, candidate.alpha);
            let starts = core::iter::once((x, y)).chain(voted.iter().copied());
            // Each start scored on a sample of the end points; the best one
            // scored on all of them, then refined and scored again (the
            // better of the two is kept).
            let score = |alpha: Angle, translation: (I16F16, I16F16), ends: Ends| {
                let agreement = self.agreement_on(reference, current, alpha, translation, ends)?;
                Some(BeamPose {
                    listed: candidate.alpha,
                    alpha,
                    translation,
                    agreement,
                })
            };
            let Some(best_start) = starts
                .filter_map(|t| score(candidate.alpha, t, Ends::Sampled))
                .max_by_key(|p| p.agreement.score())
                .and_then(|p| score(p.alpha, p.translation, Ends::All))
            else {
                continue;
            };
            let hopeless = chosen.is_some_and(|c| {
                best_start
                    .agreement
                    .score()
                    .saturating_add(q16_score(BEAM_REFINE_REACH))
                    < c.agreement.score()
            });
            let (bx, by) = best_start.translation;
            let start = Pose {
                x: bx,
                y: by,
                ..grid
            };
            let max_turn = if is_chosen { MAX_TURN } else { RIVAL_MAX_TURN };
            let refined = (!hopeless)
                .then(|| {
                    self.refine_on_beams_within(
                        reference,
                        current,
                        candidate.alpha,
                        &start,
                        max_turn,
                    )
                })
                .and_then(Result::ok)
                .filter(|f| is_chosen || f.alpha.distance(estimate.alpha) >= SEPARATION)
                .and_then(|f| score(f.alpha, (f.translation.x, f.translation.y), Ends::All));
            let scored = match refined {
                Some(r) if r.agreement.score() >= best_start.agreement.score() => r,
                _ => best_start,
            };
            if is_chosen {
                chosen = Some(scored);
            } else if rival.is_none_or(|r| scored.agreement.score() > r.agreement.score()) {
                rival = Some(scored);
            }
        }
        Some(BeamCheck {
            chosen: chosen?,
            rival,
        })
    }
}

/// [`BEAM_RIVAL_MAX_ROTATION_DEG`] as a binary angle (2³² = one turn).
const RIVAL_MAX_TURN: Angle = Angle::from_degrees(BEAM_RIVAL_MAX_ROTATION_DEG);

/// A rival whose best start scores this much below the chosen pose is not
/// refined: the refinement does not lift it that far.
const BEAM_REFINE_REACH: f32 = 0.2;

/// Bins of the translation vote per axis (odd: one is centred on 0).
const VOTE_BINS: usize = 41;
/// Width of a vote bin, metres: the votes cover ±4 m.
const VOTE_BIN_M: f32 = 0.2;
/// End points of each scan that vote (every k-th beam).
const VOTE_POINTS: usize = 96;
/// Translations taken from the vote.
const VOTE_PEAKS: usize = 3;

/// The translations (estimator convention, cells) that lay the most end
/// points of `current`, turned by `alpha`, onto end points of `reference`:
/// every pair of (subsampled) end points votes for the translation that
/// would join them, in bins of [`VOTE_BIN_M`] over ±4 m, and the
/// [`VOTE_PEAKS`] strongest bins (each clearing its 3 × 3 neighbourhood)
/// are returned, strongest first. Starts for the refinement that do not
/// depend on the grid search's small sample.
/// Calls `f` with (Q16 cells) at most [`VOTE_POINTS`] of the scan's near
/// end points, spread evenly over them (not over the beams: a full circle
/// of bins with returns over half of it keeps as many points), and placed
/// alike from either end, so that a scan written in reverse order (a
/// clockwise sensor) gives the same sample: every `stride`-th return from
/// the middle of the leftover. Two passes over the beams.
fn for_each_sampled_end(beams: &ScanBeams, ranges: &[f32], mut f: impl FnMut(i64, i64)) {
    let near = |(i, &range): (usize, &f32)| match beams.end(i, range) {
        BeamEnd::Near { x, y } => Some((i64::from(x), i64::from(y))),
        _ => None,
    };
    let count = ranges.iter().enumerate().filter_map(near).count();
    let stride = count.div_ceil(VOTE_POINTS).max(1);
    let first = (count.saturating_sub(1) % stride) / 2;
    for (x, y) in ranges
        .iter()
        .enumerate()
        .filter_map(near)
        .skip(first)
        .step_by(stride)
    {
        f(x, y);
    }
}

fn voted_translations(
    raster: &Raster,
    reference: &Scan<'_>,
    current: &Scan<'_>,
    alpha: Angle,
) -> Vec<(I16F16, I16F16), VOTE_PEAKS> {
    let mut peaks = Vec::new();
    let bin = raster.metres_q16(VOTE_BIN_M).max(1);
    let (s, c) = sin_cos(alpha.0.wrapping_neg());
    let (c, s) = (i64::from(c), i64::from(s));
    // Coordinates in bins to 1/256 (one division per point, none per pair).
    let in_bins = |v: i64| (v << 8).div_euclid(bin);
    let mut turned: Vec<(i64, i64), VOTE_POINTS> = Vec::new();
    let cur = ScanBeams::new(current, raster);
    for_each_sampled_end(&cur, current.ranges, |x, y| {
        let _ = turned.push((
            in_bins((c * x - s * y) >> 16),
            in_bins((s * x + c * y) >> 16),
        ));
    });
    let half = (VOTE_BINS / 2) as i64;
    let mut votes = [[0u8; VOTE_BINS]; VOTE_BINS];
    let refs = ScanBeams::new(reference, raster);
    for_each_sampled_end(&refs, reference.ranges, |x, y| {
        let (x, y) = (in_bins(x), in_bins(y));
        for &(qx, qy) in &turned {
            let d = |p: i64, q: i64| ((p - q + 128) >> 8) + half;
            let (bx, by) = (d(x, qx), d(y, qy));
            let cell = usize::try_from(by)
                .ok()
                .and_then(|by| votes.get_mut(by))
                .zip(usize::try_from(bx).ok())
                .and_then(|(row, bx)| row.get_mut(bx));
            if let Some(v) = cell {
                *v = v.saturating_add(1);
            }
        }
    });
    while !peaks.is_full() {
        let mut best = (0u8, 0usize, 0usize);
        for (by, row) in votes.iter().enumerate() {
            for (bx, &v) in row.iter().enumerate() {
                if v > best.0 {
                    best = (v, bx, by);
                }
            }
        }
        let (v, bx, by) = best;
        if v == 0 {
            break;
        }
        for row in votes.iter_mut().skip(by.saturating_sub(1)).take(3) {
            for v in row.iter_mut().skip(bx.saturating_sub(1)).take(3) {
                *v = 0;
            }
        }
        // d = the bin's centre; t = −R(α)·d.
        let (dx, dy) = ((bx as i64 - half) * bin, (by as i64 - half) * bin);
        let t = (-((c * dx + s * dy) >> 16), -((c * dy - s * dx) >> 16));
        let clamp =
            |v: i64| I16F16::from_bits(v.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32);
        let _ = peaks.push((clamp(t.0), clamp(t.1)));
    }
    peaks
}

/// Which end points of a scan a pose is scored on.
#[derive(Clone, Copy)]
enum Ends {
    /// Every near end point.
    All,
    /// At most [`VOTE_POINTS`] of them ([`for_each_sampled_end`]): how the
    /// check picks the best of its starts, at a quarter of the work on a
    /// 360-beam scan.
    Sampled,
}

/// One direction of [`Raster::agreement_on_beams`]: `from`'s end points
/// (`ends` of them) moved by `pose` into the frame of `into`, with the match
/// distance τ and the seen-through margin (Q16 cells). Returns the
/// explained, the seen-through and the in-view shares (Q16), `None` without
/// end points.
fn one_way(
    into: &mut Segments<'_>,
    from: &ScanBeams,
    ranges: &[f32],
    pose: &FitPose,
    (tau, margin): (i64, i64),
    sample: Ends,
) -> Option<(i64, i64, i64)> {
    let (s, c) = sin_cos(pose.theta);
    let rot = (i64::from(c), i64::from(s));
    let tau_sq = tau * tau;
    // Σ (τ² − r²), divided once at the end (τ² < 2⁴⁸: the sum in 128 bits).
    let (mut explained, mut seen, mut in_view, mut count) = (0i128, 0i64, 0i64, 0i64);
    let mut score_end = |q: (i32, i32)| {
        count += 1;
        let p = pose.apply(rot, q);
        let Some(beam) = into.beam_of(p) else {
            return;
        };
        // In view: one of the two beams its bearing lies between has a
        // return (a full circle of bins without returns behind a 180°
        // sensor sees nothing there; the same two beams in either order).
        if into.end(beam).is_none() && into.end(beam + 1).is_none() {
            return;
        }
        in_view += 1;
        let ends = into.ends_around(beam);
        if let Some((r, _)) = into.nearest_among(p, &ends) {
            let r = r.abs().min(tau);
            explained += i128::from(tau_sq - r * r);
        }
        seen += i64::from(into.seen_through(p, &ends, margin));
    };
    match sample {
        Ends::All => for_each_end(from, ranges, score_end),
        // The sample's coordinates are the ends' own (`i32`).
        Ends::Sampled => for_each_sampled_end(from, ranges, |x, y| {
            score_end((x as i32, y as i32));
        }),
    }
    // The mean of 1 − (r/τ)², Q16: at most 2¹⁶.
    let explained = (explained << 16)
        .checked_div(i128::from(tau_sq) * i128::from(count))
        .unwrap_or(0) as i64;
    (count > 0).then(|| (explained, (seen << 16) / count, (in_view << 16) / count))
}

impl Segments<'_> {
    /// `p` (Q16 cells) lies nearer to the sensor than each of the four
    /// returns around its bearing (`ends`: [`Segments::ends_around`])
    /// measured, by more than `margin` (Q16
    /// cells, at least 32) plus 1/32 of that range; false where fewer than
    /// four near returns are around.
    fn seen_through(&self, p: (i64, i64), ends: &[Option<(i32, i32)>; 4], margin: i64) -> bool {
        let (dx, dy) = (
            p.0 - i64::from(self.origin.0),
            p.1 - i64::from(self.origin.1),
        );
        // Ranges are below 2³⁰ Q16 cells: farther points are behind them.
        if dx.abs().max(dy.abs()) >= 1 << 30 {
            return false;
        }
        // The nearest of the four ranges, squared.
        let mut nearest_sq = u64::MAX;
        for end in ends {
            let Some(e) = end else {
                return false;
            };
            let (ex, ey) = (
                i64::from(e.0) - i64::from(self.origin.0),
                i64::from(e.1) - i64::from(self.origin.1),
            );
            nearest_sq = nearest_sq.min((ex * ex + ey * ey) as u64);
        }
        let distance_sq = (dx * dx + dy * dy) as u64;
        // Without a root first: the limit below is at most 31/32 of the
        // range when the margin is at least one unit, and (31/32)² =
        // 0.93848 < 1 − 1/16 + 1/512; below 32² the margin of 32 leaves
        // no limit at all.
        if distance_sq >= nearest_sq - nearest_sq / 16 + nearest_sq / 512 {
            return false;
        }
        let nearest = nearest_sq.isqrt() as i64;
        let limit = nearest - nearest / 32 - margin;
        limit > 0 && distance_sq < (limit * limit) as u64
    }
}
