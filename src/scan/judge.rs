//! The estimate's candidates judged again on the beams (issue 23): a
//! second, independent opinion that flags an answer the beams contradict.
//!
//! The grid estimate decides on cells; the beams know more. For a pose,
//! each scan's end points are laid into the other scan's frame
//! ([`Raster::agreement_on_beams`](super::Raster::agreement_on_beams), both ways) and scored:
//!
//! * **explained**: each point weighs `1 − (r / τ)²` (0 beyond τ =
//!   [`BEAM_MATCH_M`]), `r` its distance to the line of the other scan's
//!   segment around its bearing (the segments of
//!   [`Raster::refine_on_beams`](super::Raster::refine_on_beams)), averaged over all the scan's end points;
//! * **seen through**: the share of points nearer to the other sensor than
//!   what every one of the four beams around their bearing measured, by
//!   more than [`BEAM_SEEN_THROUGH_M`] plus 1/32 of that range: walls where
//!   the other sensor saw free space.
//!
//! The score is explained minus [`BEAM_SEEN_THROUGH_WEIGHT`] × seen
//! through, the mean of both directions. [`Raster::check_on_beams`](super::Raster::check_on_beams) scores
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
//! the Cortex-M4F (`examples/real_scans.rs`, `budgets/TABLE.md`): 8.3 M
//! instructions a real pair (median; 33.8 M at most; 8.1 / 30.6 M before
//! the vote's even sample of the returns, issue 39), about half the
//! estimate, and 3.4 KiB more stack; on the host 10–15 % of a pair
//! (fr079, 400 pairs, one thread: 1.45–1.56 s user without, 1.63–1.77 s
//! with).

use crate::angle::Angle;
use crate::pose::Pose;
use crate::{Estimate, Prior, Score, Status};
use fixed::types::I16F16;

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
/// ([`Raster::agreement_on_beams`](super::Raster::agreement_on_beams)).
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
    /// one of the two beams of that sensor the bearing lies between has a
    /// return, so a full circle of bins with returns over half of it sees
    /// half of it. Only these can be explained or seen through.
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
/// ([`Raster::check_on_beams`](super::Raster::check_on_beams)).
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

/// A positive share or score given as `f32` (a constant of this module)
/// in Q16, rounded to nearest, without the conversion of `from_num` that
/// may panic.
pub(super) const fn q16_score(value: f32) -> Score {
    Score::from_bits((value * 65536.0 + 0.5) as i32)
}
