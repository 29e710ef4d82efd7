//! The estimate's candidates judged again on the beams (issue 23): a
//! second, independent opinion that flags an answer the beams contradict.
//!
//! The grid estimate decides on cells; the beams know more. For a pose,
//! each scan's end points are laid into the other scan's frame
//! ([`Raster::agreement_on_beams`], both ways) and scored:
//!
//! * **explained**: each point weighs `1 − (r / τ)²` (0 beyond τ =
//!   [`BEAM_MATCH_M`]), `r` its distance to the line of the other scan's
//!   segment around its bearing (the segments of
//!   [`Raster::refine_on_beams`]), averaged over all the scan's end points;
//! * **seen through**: the share of points nearer to the other sensor than
//!   what every one of the four beams around their bearing measured, by
//!   more than [`BEAM_SEEN_THROUGH_M`] plus 1/32 of that range: walls where
//!   the other sensor saw free space.
//!
//! The score is explained minus [`BEAM_SEEN_THROUGH_WEIGHT`] × seen
//! through, the mean of both directions. [`Raster::check_on_beams`] scores
//! every listed rotation (the candidates and the runner-up) at the best of
//! several poses: the grid's translation and the strongest bins of a
//! translation vote on the end points, the best of them refined on the
//! beams. The grid's translation alone is not enough: it maximises the
//! alignment of a small sample, and for a wrong rotation's rival (a half
//! turn, say) it often lays walls where the other sensor saw through while
//! the rival's true pose explains fewer points and contradicts none. When a
//! rival outscores the chosen rotation the beams contradict the grid
//! ([`BeamCheck::flag`]); when it leads by [`BEAM_SWITCH_LEAD`], and per
//! end point in the other sensor's field of view as well
//! ([`BeamAgreement::in_view_above`]), it becomes the answer
//! ([`BeamCheck::apply`]).
//!
//! Measured on the shared real pairs (256², `N_θ` = 360, `bash
//! tools/confidence.sh`, `docs/confidence.md`): over all 4 730 pairs,
//! within 2° / flagged / wrong among unflagged 80.3 / 25.3 / 4.4 % without
//! the check, 82.4 / 27.6 / 2.3 % with it, 82.4 / 29.9 / 1.4 % with its
//! floor ([`BEAM_MIN_SCORE`]: a chosen pose the beams do not confirm is
//! flagged too; these three with a seen-through weight of 2), 82.7 / 30.7
//! / 1.0 % with the weight at 3 and rivals refined over
//! [`BEAM_RIVAL_MAX_ROTATION_DEG`], 82.7 / 30.8 / 1.0 % with the confidence
//! capped as well ([`BEAM_SEEN_THROUGH_CONFIDENCE`]), 83.0 / 30.8 / 1.0 %
//! with a switch needing the lead per end point in view too (overlap ≥ 0.5:
//! 95.7 → 96.0 % within 2°). τ, the weight, the
//! lead, the floor and the cap were chosen on those same files; an
//! exhaustive float model of the decision (`tools/csm_model.py`) is what
//! pointed at the rivals' poses.
//!
//! # Numbers
//!
//! Integer per beam, as in the refinement: Q16 cells, one 32-bit
//! arctangent per end point, `i64` sums, an integer root only for the
//! seen-through tests a comparison of squares cannot settle, one division
//! per scan for the explained share. The vote uses a 41 × 41 byte
//! histogram on the stack (1.7 KiB) and at most 96 end points of each scan,
//! in bin units (one division per end point). A rival whose best start
//! trails the chosen pose by 0.2 or more is not refined. Cost on
//! the Cortex-M4F (`examples/real_scans.rs`, `budgets/TABLE.md`): 8.1 M
//! instructions a real pair (median; 30.6 M at most), about half the
//! estimate, and 3.4 KiB more stack; on the host 10–15 % of a pair
//! (fr079, 400 pairs, one thread: 1.45–1.56 s user without, 1.63–1.77 s
//! with).

use super::beam::{BeamEnd, ScanBeams};
use super::refine::{for_each_end, FitPose, Segments, MAX_TURN};
use super::sine::sin_cos;
use super::{Raster, Scan};
use crate::angle::Angle;
use crate::pose::Pose;
use crate::{Estimate, Prior, Score, Status};
use fixed::types::I16F16;
use heapless::Vec;

/// Distance from a segment's line beyond which an end point explains
/// nothing, metres (τ).
pub const BEAM_MATCH_M: f32 = 0.1;
/// An end point is seen through when it is nearer to the other sensor than
/// that sensor's ranges around its bearing by more than this, metres, plus
/// 1/32 of the range.
pub const BEAM_SEEN_THROUGH_M: f32 = 0.1;
/// Weight of the seen-through share against the explained share. Chosen
/// on the shared real pairs (256², `docs/confidence.md`): 3 instead of 2
/// took the wrong share among unflagged answers from 1.3 to 1.0 % and
/// flagged 0.8 % more of the pairs; 4 and 6 took it to 0.86 and 0.81 % but
/// flagged 31.2 and 32.3 % and lost answers within 2°.
pub const BEAM_SEEN_THROUGH_WEIGHT: i32 = 3;
/// A rival's rotation may move by at most this in its refinement, degrees
/// (the chosen rotation's by [`BEAM_FIT_MAX_ROTATION_DEG`]): a rival is a
/// correlation peak or the half turn of the winner, which no angle search
/// has refined, and is often several degrees off its own best fit (on the
/// shared real pairs, half turns of loop closures 2–7°). A rival that
/// moves to within 5° of the chosen rotation is not a rival and keeps its
/// unrefined score.
///
/// [`BEAM_FIT_MAX_ROTATION_DEG`]: super::refine::BEAM_FIT_MAX_ROTATION_DEG
pub const BEAM_RIVAL_MAX_ROTATION_DEG: f32 = 6.0;
/// The chosen pose's seen-through share caps the answer's confidence at
/// `1 −` this `×` the share ([`BeamCheck::confidence_cap`]): walls where
/// the other sensor saw free space are the mark of a wrong pose that
/// otherwise fits. Chosen on the shared real pairs (256², `bash
/// tools/confidence.sh`): at confidence ≥ 0.8 the wrong share among kept
/// answers fell from 0.42 to 0.15 % (60.1 → 58.3 % of the pairs kept; of
/// the pairs turned more than 90°, 10 wrong of 35 kept → 2 of 21), at ≥ 0.9
/// from 0.34 to 0 %, while the statuses hardly move (a share above 1/12
/// flags a confident answer: 0.1 % of the pairs).
pub const BEAM_SEEN_THROUGH_CONFIDENCE: i32 = 6;
/// Lead in score by which the beams' rival replaces the grid's answer
/// ([`BeamCheck::switches`]; chosen on the shared real pairs).
pub const BEAM_SWITCH_LEAD: f32 = 0.05;
/// Score ([`BeamAgreement::score`]) below which the chosen pose lays too
/// little of the scans onto each other to be trusted
/// ([`BeamCheck::too_weak`]): about a third of the end points or less
/// explained. Chosen on the shared real pairs, where it took the wrong
/// share among unflagged answers from 2.3 to 1.4 % and flagged 2.3 % more
/// of the pairs (`docs/confidence.md`).
pub const BEAM_MIN_SCORE: f32 = 0.3;

/// How well a pose lays two scans onto each other, both ways
/// ([`Raster::agreement_on_beams`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BeamAgreement {
    /// Mean weight of the end points near the other scan's walls, in [0, 1]
    /// (the mean of both directions).
    pub explained: Score,
    /// Share of the end points where the other sensor saw free space, in
    /// [0, 1] (the mean of both directions).
    pub seen_through: Score,
    /// Share of the end points whose bearing from the other sensor lies
    /// within its field of view, in [0, 1] (the mean of both directions):
    /// only these can be explained or seen through.
    pub in_view: Score,
}

impl BeamAgreement {
    /// `explained − BEAM_SEEN_THROUGH_WEIGHT · seen_through`, in [−3, 1]
    /// (saturating for shares outside [0, 1]).
    pub fn score(&self) -> Score {
        self.explained.saturating_sub(
            self.seen_through
                .saturating_mul_int(BEAM_SEEN_THROUGH_WEIGHT),
        )
    }

    /// Whether this agreement's [`score`](Self::score) per end point in
    /// view ([`in_view`](Self::in_view)) is above `other`'s. The plain
    /// score counts every end point, so with a sensor that sees less than
    /// the full circle it favours the pose that brings more of them into
    /// the other's view (a half turn along a corridor seen from one end
    /// lays the dense near walls of each scan far into the other's view);
    /// per end point in view it favours the pose that brings few. An
    /// agreement with nothing in view is above none.
    pub fn in_view_above(&self, other: &BeamAgreement) -> bool {
        if self.in_view <= Score::ZERO {
            return false;
        }
        if other.in_view <= Score::ZERO {
            return true;
        }
        // s₁ / v₁ > s₂ / v₂ with v₁, v₂ > 0 (Q16 products in 64 bits).
        let cross = |a: Score, b: Score| i64::from(a.to_bits()) * i64::from(b.to_bits());
        cross(self.score(), other.in_view) > cross(other.score(), self.in_view)
    }
}

/// A pose as the check on the beams scored it: the estimator's convention
/// (`p₂ = R(α)·p₁ + t`, `t` in cells).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BeamPose {
    /// The listed rotation it started from (a candidate's or the runner-up's).
    pub listed: Angle,
    /// The rotation scored (refined on the beams when that succeeded).
    pub alpha: Angle,
    /// The translation scored, cells: the best of the grid's and the voted
    /// starts, refined.
    pub translation: (I16F16, I16F16),
    /// Its scores.
    pub agreement: BeamAgreement,
}

/// The chosen rotation and its strongest rival judged on the beams
/// ([`Raster::check_on_beams`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BeamCheck {
    /// The estimate's chosen rotation at its best scored pose.
    pub chosen: BeamPose,
    /// The best scored of the other listed rotations (the candidates and
    /// the runner-up at least 5° away); `None` when there is none with a
    /// translation.
    pub rival: Option<BeamPose>,
}

impl BeamCheck {
    /// The rival's score minus the chosen pose's; `None` without a rival.
    pub fn lead(&self) -> Option<Score> {
        self.rival.map(|r| {
            r.agreement
                .score()
                .saturating_sub(self.chosen.agreement.score())
        })
    }

    /// The beams prefer another rotation than the estimate's (a positive
    /// [`lead`](Self::lead)).
    pub fn contradicts(&self) -> bool {
        self.lead().is_some_and(|l| l > Score::ZERO)
    }

    /// The beams prefer the rival by at least [`BEAM_SWITCH_LEAD`], and
    /// per end point in the other sensor's view as well
    /// ([`BeamAgreement::in_view_above`]): the answer should be the
    /// rival's. When the two measures disagree the grid's answer stays
    /// (flagged, as the beams [`contradict`](Self::contradicts) it): on the
    /// shared real pairs (256²) the condition left 20 more answers within
    /// 2° and 3 fewer (of 4 730; within 2° with overlap ≥ 0.5 95.7 →
    /// 96.0 %, mostly corridors seen from one end), and changed no status.
    pub fn switches(&self) -> bool {
        self.lead()
            .is_some_and(|l| l >= q16_score(BEAM_SWITCH_LEAD))
            && self
                .rival
                .is_some_and(|r| r.agreement.in_view_above(&self.chosen.agreement))
    }

    /// The chosen pose scores below [`BEAM_MIN_SCORE`]: whatever the
    /// rivals, the beams do not confirm it.
    pub fn too_weak(&self) -> bool {
        self.chosen.agreement.score() < q16_score(BEAM_MIN_SCORE)
    }

    /// The most confidence the chosen pose leaves an answer: `1 −`
    /// [`BEAM_SEEN_THROUGH_CONFIDENCE`] `×` its seen-through share, at
    /// least 0. Below ½ (more than 1/12 of the end points where the other
    /// sensor saw through) it does not confirm the answer either.
    pub fn confidence_cap(&self) -> Score {
        let seen = self.chosen.agreement.seen_through;
        Score::ONE
            .saturating_sub(seen.saturating_mul_int(BEAM_SEEN_THROUGH_CONFIDENCE))
            .clamp(Score::ZERO, Score::ONE)
    }

    /// The check as a prior sees it: the rival is dropped when it lies
    /// farther than 3σ from the prior's α (the rule by which
    /// [`Estimator::estimate_scans`](crate::Estimator::estimate_scans) picks
    /// among the candidates), so a rotation the prior rules out (the half
    /// turn of a robot's constant-velocity motion between two scans, say)
    /// contradicts nothing. Without a prior, the check as it is.
    pub fn given(self, prior: Option<Prior>) -> Self {
        let Some(prior) = prior else {
            return self;
        };
        let gate = Angle(prior.sigma.0.saturating_mul(3));
        Self {
            rival: self
                .rival
                .filter(|r| r.listed.distance(prior.alpha) <= gate),
            ..self
        }
    }

    /// Caps `estimate`'s confidence at [`confidence_cap`](Self::confidence_cap)
    /// and flags it when the beams contradict it or do not confirm it.
    /// Contradicted (a rival outscores the chosen rotation): a confident
    /// answer becomes [`Status::AmbiguousDirection`] (the rival within 45°
    /// of its half turn) or [`Status::AmbiguousAxis`]. Not confirmed
    /// ([`too_weak`](Self::too_weak), or a cap below ½) and not
    /// contradicted: a confident answer becomes [`Status::LowOverlap`].
    /// Either way the confidence is at most ¼: on the shared real pairs
    /// (256²) the grid's answer was within 2° in 18 % of the contradicted
    /// pairs, the rival in 36 % (41 % where it led by
    /// [`BEAM_SWITCH_LEAD`]). Everything else is kept.
    pub fn flag(&self, estimate: &mut Estimate) {
        let cap = self.confidence_cap();
        estimate.confidence = estimate.confidence.min(cap);
        let contradicting = self.rival.filter(|_| self.contradicts());
        let unconfirmed = self.too_weak() || cap < Score::from_bits(1 << 15);
        if contradicting.is_none() && !unconfirmed {
            return;
        }
        estimate.confidence = estimate.confidence.min(Score::from_bits(1 << 14));
        if estimate.status != Status::Confident {
            return;
        }
        let eighth = Angle(1 << 29);
        estimate.status = match contradicting {
            Some(rival) if rival.listed.distance(estimate.alpha + Angle::HALF_TURN) < eighth => {
                Status::AmbiguousDirection
            }
            Some(_) => Status::AmbiguousAxis,
            None => Status::LowOverlap,
        };
    }

    /// [`flag`](Self::flag), and when the beams [`switch`](Self::switches)
    /// the answer becomes the rival: `alpha` and `translation` are its
    /// scored pose (scale 1, no unobservable direction). The status stays
    /// flagged: the grid and the beams disagree. Estimates with
    /// [`Status::NoStructure`] are left alone.
    pub fn apply(&self, estimate: &mut Estimate) {
        self.flag(estimate);
        let Some(rival) = self.rival.filter(|_| self.switches()) else {
            return;
        };
        if estimate.status == Status::NoStructure {
            return;
        }
        estimate.alpha = rival.alpha;
        estimate.translation = Some(Pose {
            x: rival.translation.0,
            y: rival.translation.1,
            scale: I16F16::ONE,
            residual: I16F16::ZERO,
            columns: 0,
            unobservable: None,
        });
    }
}

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
            tau,
            margin,
        )?;
        let b = one_way(
            &mut into_current,
            &ScanBeams::new(reference, self),
            reference.ranges,
            &backward,
            tau,
            margin,
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
    /// pairs), five [`agreement_on_beams`](Self::agreement_on_beams)
    /// and one refinement. The chosen rotation goes first; a rival whose
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
            // Each start scored as it is; the best one refined and scored
            // again (the better of the two is kept).
            let score = |alpha: Angle, translation: (I16F16, I16F16)| {
                let agreement = self.agreement_on_beams(reference, current, alpha, translation)?;
                Some(BeamPose {
                    listed: candidate.alpha,
                    alpha,
                    translation,
                    agreement,
                })
            };
            let Some(best_start) = starts
                .filter_map(|t| score(candidate.alpha, t))
                .max_by_key(|p| p.agreement.score())
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
                .and_then(|f| score(f.alpha, (f.translation.x, f.translation.y)));
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

/// A positive share or score given as `f32` (a constant of this module)
/// in Q16, rounded to nearest, without the conversion of `from_num` that
/// may panic.
const fn q16_score(value: f32) -> Score {
    Score::from_bits((value * 65536.0 + 0.5) as i32)
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
    let stride = current.ranges.len().div_ceil(VOTE_POINTS).max(1);
    for (i, &range) in current.ranges.iter().enumerate().step_by(stride) {
        if let BeamEnd::Near { x, y } = cur.end(i, range) {
            let (x, y) = (i64::from(x), i64::from(y));
            let _ = turned.push((
                in_bins((c * x - s * y) >> 16),
                in_bins((s * x + c * y) >> 16),
            ));
        }
    }
    let half = (VOTE_BINS / 2) as i64;
    let mut votes = [[0u8; VOTE_BINS]; VOTE_BINS];
    let refs = ScanBeams::new(reference, raster);
    let stride = reference.ranges.len().div_ceil(VOTE_POINTS).max(1);
    for (i, &range) in reference.ranges.iter().enumerate().step_by(stride) {
        let BeamEnd::Near { x, y } = refs.end(i, range) else {
            continue;
        };
        let (x, y) = (in_bins(i64::from(x)), in_bins(i64::from(y)));
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
    }
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

/// One direction of [`Raster::agreement_on_beams`]: `from`'s end points
/// moved by `pose` into the frame of `into`. Returns the explained, the
/// seen-through and the in-view shares (Q16), `None` without end points.
fn one_way(
    into: &mut Segments<'_>,
    from: &ScanBeams,
    ranges: &[f32],
    pose: &FitPose,
    tau: i64,
    margin: i64,
) -> Option<(i64, i64, i64)> {
    let (s, c) = sin_cos(pose.theta);
    let rot = (i64::from(c), i64::from(s));
    let tau_sq = tau * tau;
    // Σ (τ² − r²), divided once at the end (τ² < 2⁴⁸: the sum in 128 bits).
    let (mut explained, mut seen, mut in_view, mut count) = (0i128, 0i64, 0i64, 0i64);
    for_each_end(from, ranges, |q| {
        count += 1;
        let p = pose.apply(rot, q);
        let Some(beam) = into.beam_of(p) else {
            return;
        };
        in_view += 1;
        if let Some((r, _)) = into.nearest_around(p, beam) {
            let r = r.abs().min(tau);
            explained += i128::from(tau_sq - r * r);
        }
        seen += i64::from(into.seen_through(p, beam, margin));
    });
    // The mean of 1 − (r/τ)², Q16: at most 2¹⁶.
    let explained = (explained << 16)
        .checked_div(i128::from(tau_sq) * i128::from(count))
        .unwrap_or(0) as i64;
    (count > 0).then(|| (explained, (seen << 16) / count, (in_view << 16) / count))
}

impl Segments<'_> {
    /// `p` (Q16 cells, around `beam`: [`Segments::beam_of`]) lies nearer to
    /// the sensor than each of the four returns around its bearing
    /// ([`Segments::ends_around`]) measured, by more than `margin` (Q16
    /// cells, at least 32) plus 1/32 of that range; false where fewer than
    /// four near returns are around.
    fn seen_through(&mut self, p: (i64, i64), beam: i64, margin: i64) -> bool {
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
        for end in self.ends_around(beam) {
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
