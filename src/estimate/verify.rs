//! The verification by alignment (improved mode, on by default): both
//! halves of the strongest correlation peaks are scored by their best
//! translation ([`Aligner::search`]), a local angle search runs around the
//! strongest, ICP refines the winner ([`refine`]), and the status says
//! whether a rival comes close or the pose explains too little of the view.

use super::answer::{pick_with_prior, verified_confidence};
use super::seed::{
    angle_search, hint_shift, inverse, peak_alpha, scale_of, seed_at, shift_q8, support_key,
    verified_translation, Seed, SeedStart, ANGLE_SEARCH_SEEDS, SEEDS, VERIFY_PEAKS,
};
use super::{Candidate, Estimate, Estimator, Prior, Status, MAX_CANDIDATES};
use crate::angle::Angle;
use crate::correlation::{circular_distance, Correlation, Peak};
use crate::direction::HalfTurnTest;
use crate::grid::Grid;
use crate::math::sort_descending;
use crate::pose::agreement::agreement;
use crate::pose::icp::refine;
use crate::pose::pyramid::Pyramid;
use crate::pose::search::Aligner;
use crate::pose::Pose;
use crate::reference::Reference;
use crate::scan::FreeSpace;
use crate::Score;
use heapless::Vec;

impl<
        const W: usize,
        const H: usize,
        const RW: usize,
        const N: usize,
        const HALF: usize,
        const RHO: usize,
        const PW: usize,
    > Estimator<W, H, RW, N, HALF, RHO, PW>
{
    /// The scale (Q16) each of `peaks` is verified at: the one the profile
    /// test found for the best peak (`hint`; 1 without a scale search);
    /// with a scale search, each other peak's own (a wrong peak's scale
    /// would handicap the right one: up to 20 % apart over 0.9–1.1; its
    /// translation is not kept: a floor for each peak's search would cost
    /// 168 B more stack on the M0). Out of line, so that the profile tests'
    /// scratch is not on the stack during the verification.
    #[inline(never)]
    fn peak_scales(
        &mut self,
        reference: &Reference<W, H, RW, HALF, RHO>,
        grid: &Grid<W, H, RW>,
        peaks: &[&Peak],
        hint: Option<(Angle, Pose)>,
    ) -> [u32; VERIFY_PEAKS] {
        let hint_scale = hint.map_or(1 << 16, |(_, t)| scale_of(&t));
        let mut scales = [hint_scale; VERIFY_PEAKS];
        if self.scale.is_none() {
            return scales;
        }
        for (peak, scale) in peaks.iter().zip(scales.iter_mut()) {
            let alpha = peak_alpha::<N>(peak);
            let on_hint = hint.is_some_and(|(h, _)| h == alpha || h == alpha + Angle::HALF_TURN);
            if let (false, (_, _, Some(pose))) =
                (on_hint, self.profile_test(reference, grid, alpha))
            {
                *scale = scale_of(&pose);
            }
        }
        scales
    }

    /// The verification by alignment (improved mode, on by default): both
    /// halves of the strongest correlation peaks are scored by their best
    /// translation ([`Aligner::search`], exact over ±`max_shift`), and their
    /// quarter turns too when the best aligns poorly; a local angle search
    /// runs around the strongest; every seed is then judged both ways on a
    /// large sample, with the views' free space when the estimate is on
    /// scans ([`agreement`]); the best supported wins and ICP refines it.
    /// The status and the confidence follow from the winner's lead in
    /// support over the best seed at least 5° away
    /// ([`Thresholds::decision_gap`]) and from its overlap
    /// ([`Thresholds::min_overlap`]).
    ///
    /// Not inlined: its frame (about 2 KiB) stays off the stack of estimates
    /// without verification.
    #[inline(never)]
    pub(super) fn verified(
        &mut self,
        reference: &Reference<W, H, RW, HALF, RHO>,
        grid: &Grid<W, H, RW>,
        found: Unverified<'_>,
        free: Option<&FreeSpace<'_, W, H, RW>>,
        prior: Option<Prior>,
    ) -> Estimate {
        let Unverified {
            correlation,
            best_score,
            test,
            hint,
        } = found;
        let t = self.thresholds;
        // The strongest distinct peaks, each verified with both halves.
        let mut peaks: Vec<&Peak, VERIFY_PEAKS> = Vec::new();
        for peak in &correlation.peaks {
            let apart = peaks
                .iter()
                .all(|p| circular_distance(p.shift, peak.shift, HALF) >= (N / 72).max(2));
            if apart && peaks.push(peak).is_err() {
                break;
            }
        }
        let scales = self.peak_scales(reference, grid, &peaks, hint);
        // Built here, on the stack, so that estimates without verification
        // do not carry it (`4 · PW` bytes: 752 at 128²).
        let mut pyramid = Pyramid::<W, H, PW>::new();
        pyramid.build(reference.grid());
        let max_shift = self.max_shift() as i32;
        let separation = Angle::from_steps_q16(((N / 72).max(2) as i64) << 16, N);
        let mut seeds: Vec<Seed, SEEDS> = Vec::new();
        let (winner, points, near, alpha, u_q8, cut, search_rows) = {
            // A point on the reference's free space costs what the support
            // charges: `free_space_weight` in alignment units, twice that in
            // points (a point scores at most 2).
            let penalty = (t.free_space_weight.clamp(Score::ZERO, Score::from_num(64)) * 2)
                .to_num::<u32>()
                .max(1);
            let free_penalty = free.map(|f| (f.reference, penalty));
            let mut aligner = Aligner::new(
                reference.grid(),
                &pyramid,
                reference.reach(),
                grid,
                free_penalty,
                inverse(scales[0]),
            )
            .with_budget(t.search_budget);
            // 1. Both halves of the strongest distinct peaks, each with the
            //    best translation over the whole window.
            for (peak, &scale) in peaks.iter().zip(&scales) {
                let alpha = peak_alpha::<N>(peak);
                let score = correlation.score(peak);
                // The half the profile test chose goes first: its translation
                // gives the search a floor at once.
                let halves = match hint {
                    Some((h, _)) if h == alpha + Angle::HALF_TURN => [h, alpha],
                    _ => [alpha, alpha + Angle::HALF_TURN],
                };
                for half in halves {
                    let hinted = hint
                        .filter(|(h, _)| *h == half)
                        .map(|(h, t)| hint_shift::<N>(h, &t));
                    seed_at::<W, H, RW, N, PW>(
                        &mut aligner,
                        &mut seeds,
                        SeedStart {
                            alpha: half,
                            correlation: score,
                            hinted,
                            scale_q16: scale,
                        },
                        max_shift,
                        t.alignment_ratio,
                    );
                }
            }
            // 1b. A poor best alignment may be the wrong axis of a
            //     rectangular scene: its quarter turns are seeds too.
            let strongest = seeds.iter().max_by_key(|s| s.placement.score).copied();
            if let Some(best) = strongest.filter(|s| s.placement.score < aligner.points()) {
                for quarter in [Angle::QUARTER_TURN, Angle::HALF_TURN + Angle::QUARTER_TURN] {
                    seed_at::<W, H, RW, N, PW>(
                        &mut aligner,
                        &mut seeds,
                        SeedStart {
                            alpha: best.placement.alpha + quarter,
                            correlation: Score::ZERO,
                            hinted: None,
                            scale_q16: best.scale_q16,
                        },
                        max_shift,
                        t.alignment_ratio,
                    );
                }
            }
            if seeds.is_empty() {
                // No seed: nothing aligned, or the budget ran out first (then
                // the correlation's best half, unverified, and the status
                // says why).
                return match hint.filter(|_| aligner.cut()) {
                    Some((alpha, _)) => Estimate {
                        alpha,
                        status: Status::SearchCut,
                        correlation: best_score,
                        half_turn: test,
                        search_rows: aligner.spent(),
                        ..Estimate::no_structure()
                    },
                    None => Estimate::no_structure(),
                };
            }
            sort_descending(&mut seeds, |s| s.placement.score);
            // 2. Local angle search around the strongest seeds: ±4° in
            //    strides of ~2°, then halving strides down to one θ step.
            let strongest = seeds.first().map_or(0, |s| s.placement.score);
            for seed in seeds.iter_mut().take(ANGLE_SEARCH_SEEDS) {
                if seed.placement.score * 2 < strongest {
                    continue;
                }
                aligner.set_inv_scale(inverse(seed.scale_q16));
                seed.placement =
                    angle_search::<W, H, RW, N, PW>(&mut aligner, &seed.placement, max_shift);
            }
            // 3. Every seed judged both ways on the large sample.
            for seed in seeds.iter_mut() {
                let p = seed.placement;
                seed.agreement = agreement::<W, H, RW, N>(
                    reference.grid(),
                    grid,
                    free,
                    p.alpha,
                    shift_q8(p.shift),
                    seed.scale_q16,
                );
            }
            sort_descending(&mut seeds, |s| support_key(s.support(&t)));
            let Some(winner) = seeds.first() else {
                return Estimate::no_structure();
            };
            // 4. ICP below one cell and one θ step; kept unless it loses
            //    alignment (e.g. drawn onto a neighbouring wall).
            let inv_scale_q16 = inverse(winner.scale_q16);
            let (alpha, u_q8) =
                refine::<W, H, RW, N>(reference.grid(), grid, &winner.placement, inv_scale_q16);
            aligner.set_inv_scale(inv_scale_q16);
            aligner.rotate::<N>(alpha, u_q8);
            let refined = aligner.score((0, 0));
            // The decision stays with the seeds' agreements: each judged at
            // its search pose, none favoured by a refinement the others did
            // not get.
            let (alpha, u_q8, near) = if 16 * refined >= 15 * winner.placement.score {
                (alpha, u_q8, aligner.near((0, 0)))
            } else {
                aligner.rotate::<N>(winner.placement.alpha, (0, 0));
                let p = winner.placement;
                (p.alpha, shift_q8(p.shift), aligner.near(p.shift))
            };
            (
                *winner,
                aligner.points(),
                near,
                alpha,
                u_q8,
                aligner.cut(),
                aligner.spent(),
            )
        };
        let max_score = (2 * points).max(1);
        let alignment = |score: u32| {
            let share = (u64::from(score) << 16).checked_div(u64::from(max_score));
            Score::from_bits(share.unwrap_or(0) as i32)
        };
        let overlap = Score::from_bits(((u64::from(near) << 16) / u64::from(points.max(1))) as i32);
        let support = winner.support(&t);
        // The best supported seed at least 5° from the winner.
        let rival = seeds
            .iter()
            .skip(1)
            .filter(|s| s.placement.alpha.distance(winner.placement.alpha) >= separation)
            .max_by_key(|s| support_key(s.support(&t)))
            .copied();
        // Two rotations that both lay every sampled point on an occupied
        // cell (dense or periodic inputs) cannot be told apart: their
        // translations are ties of the search, and the large sample would
        // only judge which tie it happened to pick.
        let saturated = |s: &Seed| s.placement.score >= 2 * points;
        let gap = match rival {
            Some(r) if saturated(&winner) && saturated(&r) => Score::ZERO,
            Some(r) => support - r.support(&t),
            None => support,
        };
        let mut confidence = verified_confidence(overlap, gap, &t);
        let status = if overlap < t.min_overlap {
            Status::LowOverlap
        } else if cut {
            confidence = confidence.min(Score::from_bits((1 << 15) - 1));
            Status::SearchCut
        } else if gap < t.decision_gap {
            let near_half_turn = rival.is_some_and(|r| {
                r.placement
                    .alpha
                    .distance(winner.placement.alpha + Angle::HALF_TURN)
                    < Angle::from_steps_q16(((N / 8) as i64) << 16, N)
            });
            if near_half_turn {
                Status::AmbiguousDirection
            } else {
                Status::AmbiguousAxis
            }
        } else {
            Status::Confident
        };
        let candidate = |seed: &Seed, chosen: bool| {
            let (candidate_alpha, u) = if chosen {
                (alpha, u_q8)
            } else {
                (seed.placement.alpha, shift_q8(seed.placement.shift))
            };
            let tr = verified_translation::<N>(candidate_alpha, u, seed.scale_q16, None);
            Candidate {
                alpha: candidate_alpha,
                score: seed.correlation.clamp(Score::ZERO, Score::ONE),
                alignment: Some(alignment(seed.placement.score)),
                translation: Some((tr.x, tr.y)),
                support: Some(seed.support(&t)),
                free_space: free.map(|_| seed.agreement.violation()),
            }
        };
        let mut candidates: Vec<Candidate, MAX_CANDIDATES> = Vec::new();
        let mut listed: Vec<Angle, MAX_CANDIDATES> = Vec::new();
        for (i, seed) in seeds.iter().enumerate() {
            // Duplicates are judged on the seeds' rotations (ICP may move the
            // winner towards a rival it was compared with).
            let duplicate = listed
                .iter()
                .any(|a: &Angle| a.distance(seed.placement.alpha) < separation);
            if !duplicate && !candidates.is_full() {
                let _ = listed.push(seed.placement.alpha);
                let _ = candidates.push(candidate(seed, i == 0));
            }
        }
        let mut chosen = alpha;
        let mut status = status;
        if let Some(prior) = prior {
            if let Some((picked, alone)) = pick_with_prior(&candidates, prior) {
                chosen = picked;
                if alone && !matches!(status, Status::LowOverlap | Status::SearchCut) {
                    status = Status::Confident;
                }
            }
        }
        let translation = if chosen == alpha {
            // The observability comes from the column profiles: a corridor
            // leaves the shift along its walls free. The profile test of the
            // best peak serves when the winner is that peak or its half turn
            // (the same column normals); otherwise it runs again.
            let near_hint = hint.filter(|(h, _)| {
                let apart = alpha.distance(*h);
                apart < separation || apart > Angle::HALF_TURN - separation
            });
            let fit = match near_hint {
                Some((_, t)) => Some(t),
                None => self.profile_test(reference, grid, alpha).2,
            };
            Some(verified_translation::<N>(
                alpha,
                u_q8,
                winner.scale_q16,
                fit.as_ref(),
            ))
        } else {
            // A candidate the prior picked: its own search's translation.
            seeds
                .iter()
                .find(|seed| seed.placement.alpha == chosen)
                .map(|seed| {
                    let shift = shift_q8(seed.placement.shift);
                    verified_translation::<N>(chosen, shift, seed.scale_q16, None)
                })
        };
        Estimate {
            alpha: chosen,
            status,
            confidence,
            correlation: best_score,
            rival: correlation
                .rival((N / 72).max(2))
                .map_or(Score::ZERO, |p| correlation.score(p)),
            half_turn: test,
            candidates,
            runner_up: rival.map(|r| candidate(&r, false)),
            overlap,
            translation,
            search_rows,
        }
    }
}

/// What the correlation and the profile test found, handed to the
/// verification.
pub(super) struct Unverified<'c> {
    pub(super) correlation: &'c Correlation,
    /// Pearson correlation of the best peak.
    pub(super) best_score: Score,
    /// The profile test of the best peak.
    pub(super) test: HalfTurnTest,
    /// The half of the best peak the profile test chose, and its pose.
    pub(super) hint: Option<(Angle, Pose)>,
}
