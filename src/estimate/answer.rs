//! What an estimate answers: the rotation, the [`Status`] (how far to trust
//! it), the [`Candidate`]s, the [`Thresholds`] of the status decision and
//! the confidences; and the optional [`Prior`] that picks among candidates.

use crate::angle::Angle;
use crate::direction::{HalfTurn, HalfTurnTest};
use crate::math::insert_sorted;
use crate::pose::Pose;
use crate::Score;
use fixed::types::I16F16;
use heapless::Vec;

/// How far to trust the answer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Status {
    /// One clear answer.
    Confident,
    /// α vs α + π cannot be told apart (corridors, centrally symmetric
    /// rooms): both are in the candidates.
    AmbiguousDirection,
    /// A rival correlation peak nearly as strong as the best (e.g. a square,
    /// Manhattan room: rival near 90°): see the candidates.
    AmbiguousAxis,
    /// The best pose explains too little of the second view (verification
    /// on): less than [`Thresholds::min_overlap`] of its sampled cells lie
    /// within one cell of the reference. The views may not overlap at all.
    LowOverlap,
    /// Too few occupied cells or a featureless signature: no angle.
    NoStructure,
    /// The verification's translation searches ran out of their work
    /// budget ([`Thresholds::search_budget`]) before they finished: the
    /// answer is the best pose found, but rivals may not have been searched
    /// to the end, so it is not confident (confidence below ½). When it ran
    /// out before any candidate was scored, `alpha` is the correlation's
    /// best half, unverified, and `candidates` is empty.
    SearchCut,
}

/// A possible rotation and its scores.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Candidate {
    /// Rotation α of the scene (counter-clockwise, DESIGN.md §2).
    pub alpha: Angle,
    /// Correlation × direction share, in [0, 1].
    pub score: Score,
    /// With the verification by alignment: how well the best translation for
    /// this rotation lays the second view onto the reference, in [0, 1] (each
    /// sampled cell scores 1 on an occupied reference cell, ½ next to one);
    /// candidates are then sorted by it. `None` without verification
    /// (candidates sorted by `score`).
    pub alignment: Option<Score>,
    /// With verification: the translation `t` (pixels, `p₂ = s·R(α)·p₁ + t`)
    /// that aligns this candidate best: whole cells for the others, refined
    /// for the chosen one (where [`Estimate::translation`] also holds it).
    /// `None` without verification.
    pub translation: Option<(I16F16, I16F16)>,
    /// With verification: what the decision compares, in
    /// [−[`Thresholds::free_space_weight`], 1]: the pose judged both ways
    /// on a large sample (the mean of the two alignments, each view onto
    /// the other) minus the free-space weight times [`Self::free_space`].
    /// Candidates are sorted by it. `None` without verification.
    pub support: Option<Score>,
    /// With verification on scans
    /// ([`Estimator::estimate_scans`](crate::Estimator::estimate_scans)):
    /// the share of each view's sampled cells that this pose lays where the
    /// other sensor's beams passed (not within one cell of its walls),
    /// averaged over the two directions, in [0, 1]. On the real scan pairs
    /// of `../shared/data` right poses have a median near 0.01, wrong ones
    /// 0.1–0.2. `None` on images or without verification.
    pub free_space: Option<Score>,
}

/// Most candidates an [`Estimate`] carries.
pub const MAX_CANDIDATES: usize = 4;

/// An optional prior on α, e.g. from a gyro or odometry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Prior {
    /// Expected α (scene rotation; for a robot that turned left by `dθ`,
    /// α = −dθ).
    pub alpha: Angle,
    /// One standard deviation; candidates farther than 3σ are not picked.
    pub sigma: Angle,
}

/// Thresholds of the status decision (defaults from DESIGN.md §3, checked by
/// the accuracy evaluation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Thresholds {
    /// [`Status::AmbiguousAxis`] when the rival peak's correlation is at least
    /// this fraction of the best one's. Default 0.9.
    pub rival_ratio: Score,
    /// [`Status::AmbiguousDirection`] when [`HalfTurnTest::margin`] is below
    /// this. Default 0.10 (on the real scan pairs 0.05 left 2–7 % of the
    /// unflagged answers wrong, 0.10 leaves 0.3–1.9 %).
    pub direction_margin: Score,
    /// [`Status::NoStructure`] when either grid has fewer occupied cells.
    /// Default 8.
    pub min_occupied: u32,
    /// Largest translation searched by the profile test and the
    /// verification, as a fraction of the ρ range. Default ¼ (±64 px at 128²).
    pub max_shift_fraction: Score,
    /// With verification: rotations whose best alignment (search sample)
    /// cannot reach the best so far divided by this are not searched to the
    /// end and not listed. Default 2 (on the real scan pairs of
    /// `../shared/data` a wrong winner leads the true rotation by 1.15–1.49×,
    /// p10–p90: they must stay in the race). Lower is cheaper.
    pub alignment_ratio: Score,
    /// With verification: ambiguous (and a confidence below ½) unless the
    /// winner's [`Candidate::support`] leads the best candidate at least 5°
    /// away by this much. Default 0.08 (chosen on the real scan pairs of
    /// `../shared/data`, where it flags about a quarter of all pairs;
    /// `docs/confidence.md`).
    pub decision_gap: Score,
    /// With verification on scans: how much a free-space violation share
    /// costs in [`Candidate::support`] (clamped to [0, 64]). Default 2.
    pub free_space_weight: Score,
    /// With verification: [`Status::LowOverlap`] when the best pose puts less
    /// than this share of the second view within one cell of the reference.
    /// Default 0.30 (chosen on the real scan pairs, README).
    pub min_overlap: Score,
    /// With verification: the work the translation searches of one estimate
    /// may spend, in grid rows read per sampled point (each bound or score
    /// of the branch and bound is charged the rows it may read over its
    /// whole sample, at most 34 a point: 3 for a score, `2ᵏ + 2` for an
    /// exact bound at level `k`, twice that with free space). When it runs
    /// out, the searches keep what they found and the status is
    /// [`Status::SearchCut`]. The searches' instructions are at most a
    /// constant times this (`budgets/TABLE.md` gives it per core); the rest
    /// of the verification is bounded by fixed loop counts. Lower it for a
    /// real-time bound at the price of more cut searches. Default 2²⁶
    /// (67 108 864): the most a real scan pair of `../shared/data` spends is
    /// 6.6 M at 64², 10.0 M at 128² and 50.2 M at 256² (medians 1.2 M,
    /// 1.7 M, 5.9 M; chosen on those data). `u32::MAX`: no budget. What an
    /// estimate spent is [`Estimate::search_rows`]; what each budget costs
    /// in answers on the real scan pairs and bounds in instructions:
    /// `docs/work-budget.md`.
    pub search_budget: u32,
}

impl Thresholds {
    /// The defaults, usable in `const` context.
    pub const DEFAULT: Thresholds = Thresholds {
        rival_ratio: Score::from_bits(58_982),     // 0.9
        direction_margin: Score::from_bits(6_554), // 0.10
        min_occupied: 8,
        max_shift_fraction: Score::from_bits(16_384), // 0.25
        alignment_ratio: Score::from_bits(131_072),   // 2
        decision_gap: Score::from_bits(5_243),        // 0.08
        free_space_weight: Score::from_bits(131_072), // 2
        min_overlap: Score::from_bits(19_661),        // 0.30
        search_budget: 1 << 26,
    };
}

impl Default for Thresholds {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The result of one estimate.
#[derive(Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Estimate {
    /// Rotation of the scene from the reference to the new image,
    /// counter-clockwise: a point `p` of image 1 appears in image 2 at
    /// `R(α)·p + t`. Meaningless when `status` is [`Status::NoStructure`].
    pub alpha: Angle,
    /// How far to trust `alpha`.
    pub status: Status,
    /// A summary in [0, 1]: the correlation of the winner, scaled down as the
    /// rival peak or the direction margin approach their thresholds. On
    /// scans, [`BeamCheck::flag`](crate::BeamCheck::flag) caps it further by
    /// the share of end points the other sensor saw through. What a cut on it
    /// means on real pairs: `docs/confidence.md`.
    pub confidence: Score,
    /// Pearson correlation of the winning shift (modulo π), in [−1, 1].
    pub correlation: Score,
    /// Pearson correlation of the best rival peak at least 5° away (0 if none).
    pub rival: Score,
    /// The α vs α + π test of the winning peak.
    pub half_turn: HalfTurnTest,
    /// Up to [`MAX_CANDIDATES`] rotations, strongest first; `alpha` is one of
    /// them (the first, unless a prior picked another) or the runner-up's
    /// (when [`BeamCheck::apply`](crate::BeamCheck::apply) switched to it).
    pub candidates: Vec<Candidate, MAX_CANDIDATES>,
    /// With verification: the best candidate at least 5° from the winner
    /// (whatever its lead: the decision's other side), so a caller can set
    /// its own threshold on [`Candidate::support`]; `None` without
    /// verification or when no other rotation was found.
    pub runner_up: Option<Candidate>,
    /// With verification: the share of the second view's sampled cells that
    /// the chosen pose puts within one cell of the reference, in [0, 1];
    /// 0 without verification.
    pub overlap: Score,
    /// The rest of the pose for `alpha`: translation `t` in pixels, scale
    /// (1 unless [`Estimator::with_scale_search`](crate::Estimator::with_scale_search)), residual and the
    /// unobservable direction, if any. Improved mode only; `None` when the
    /// rotation is not resolved or a prior picked another candidate than the
    /// one the translation was fitted for.
    pub translation: Option<Pose>,
    /// With verification: the work its translation searches spent, in the
    /// unit of [`Thresholds::search_budget`] (grid rows a sampled point,
    /// each evaluation charged its most), whether a budget was set or not;
    /// 0 without verification. Log it on the robot to choose a budget: on
    /// the shared real scan pairs at 128² the median is 1.6 M and the
    /// largest 12.0 M (`python3 tools/work_budget.py`, `docs/work-budget.md`).
    pub search_rows: u32,
}

impl Estimate {
    pub(crate) fn no_structure() -> Self {
        Self {
            alpha: Angle::ZERO,
            status: Status::NoStructure,
            confidence: Score::ZERO,
            correlation: Score::ZERO,
            rival: Score::ZERO,
            half_turn: HalfTurnTest {
                chosen: HalfTurn::Direct,
                direct: Score::ZERO,
                flipped: Score::ZERO,
            },
            candidates: Vec::new(),
            runner_up: None,
            overlap: Score::ZERO,
            translation: None,
            search_rows: 0,
        }
    }
}

/// Adds α and, when the direction test is close, α + π, scored by correlation
/// × direction share.
pub(crate) fn push_pair(
    candidates: &mut Vec<Candidate, MAX_CANDIDATES>,
    alpha: Angle,
    correlation: Score,
    test: &HalfTurnTest,
) {
    let (d, f) = (test.direct.max(Score::ZERO), test.flipped.max(Score::ZERO));
    let total = d + f;
    let share = |s: Score| {
        if total == Score::ZERO {
            Score::from_num(0.5)
        } else {
            s / total
        }
    };
    let (first, second, first_share, second_share) = match test.chosen {
        HalfTurn::Direct => (alpha, alpha + Angle::HALF_TURN, share(d), share(f)),
        HalfTurn::Flipped => (alpha + Angle::HALF_TURN, alpha, share(f), share(d)),
    };
    insert_sorted(
        candidates,
        Candidate {
            alpha: first,
            score: correlation * first_share,
            alignment: None,
            translation: None,
            support: None,
            free_space: None,
        },
        stronger,
    );
    insert_sorted(
        candidates,
        Candidate {
            alpha: second,
            score: correlation * second_share,
            alignment: None,
            translation: None,
            support: None,
            free_space: None,
        },
        stronger,
    );
}

/// Candidates sorted by score, strongest first (ties keep their order).
fn stronger(a: &Candidate, b: &Candidate) -> bool {
    b.score < a.score
}

/// Confidence in [0, 1]: the best correlation, scaled linearly to 0 as the
/// rival ratio rises from `rival_ratio − 0.1` to `rival_ratio`, and as the
/// direction margin falls from twice its threshold to the threshold.
pub(crate) fn confidence(best: Score, rival: Score, margin: Score, t: &Thresholds) -> Score {
    let one = Score::ONE;
    let ratio = if best > Score::ZERO {
        rival.saturating_div(best)
    } else {
        one
    };
    let axis = t
        .rival_ratio
        .saturating_sub(ratio)
        .saturating_mul_int(10)
        .clamp(Score::ZERO, one);
    let direction = if t.direction_margin > Score::ZERO {
        margin
            .saturating_sub(t.direction_margin)
            .saturating_div(t.direction_margin)
            .clamp(Score::ZERO, one)
    } else {
        one
    };
    best.clamp(Score::ZERO, one) * axis * direction
}

/// The candidate nearest the prior within 3σ, and whether it is the only one
/// within 3σ.
pub(crate) fn pick_with_prior(candidates: &[Candidate], prior: Prior) -> Option<(Angle, bool)> {
    let gate = Angle(prior.sigma.0.saturating_mul(3));
    let inside = || {
        candidates
            .iter()
            .filter(move |c| c.alpha.distance(prior.alpha) <= gate)
    };
    let nearest = inside().min_by_key(|c| c.alpha.distance(prior.alpha))?;
    Some((nearest.alpha, inside().count() == 1))
}

/// Confidence with verification, in [0, 1]:
/// `min(gap / (2·decision_gap), overlap / (2·min_overlap))`, each clamped to
/// [0, 1], so that it is at least ½ exactly when the status rule finds the
/// answer confident (the winner's support leads the runner-up's by
/// `decision_gap` and its overlap reaches `min_overlap`). What a confidence
/// means in wrong answers is measured on the real scan pairs in
/// `docs/confidence.md`.
pub(crate) fn verified_confidence(overlap: Score, gap: Score, t: &Thresholds) -> Score {
    let one = Score::ONE;
    let half = Score::from_bits(1 << 15);
    // `value / (2·threshold)`, below ½ exactly when `value < threshold`
    // (the division's rounding cannot cross ½ either way).
    let ramp = |value: Score, threshold: Score| {
        if threshold <= Score::ZERO {
            one
        } else if value < threshold {
            value
                .saturating_div(threshold.saturating_mul_int(2))
                .clamp(Score::ZERO, half - Score::DELTA)
        } else {
            half.saturating_add(
                value
                    .saturating_sub(threshold)
                    .saturating_div(threshold.saturating_mul_int(2)),
            )
            .clamp(half, one)
        }
    };
    ramp(gap, t.decision_gap).min(ramp(overlap, t.min_overlap))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `confidence` against its formula in f64:
    /// `best · clamp(10·(rival_ratio − rival/best)) · clamp((margin − m)/m)`.
    #[test]
    fn confidence_matches_its_formula() {
        let t = Thresholds::DEFAULT;
        let (ratio, m) = (0.9, 0.1);
        let clamp = |v: f64| v.clamp(0.0, 1.0);
        for &(best, rival, margin) in &[
            (0.95, 0.5, 0.6),
            (0.8, 0.7, 0.15),
            (0.9, 0.85, 0.3),
            (0.7, 0.2, 0.05),
            (1.0, 0.0, 1.0),
            (0.6, 0.6, 0.5),
        ] {
            let expected =
                clamp(best) * clamp(10.0 * (ratio - rival / best)) * clamp((margin - m) / m);
            let got = confidence(
                Score::from_num(best),
                Score::from_num(rival),
                Score::from_num(margin),
                &t,
            )
            .to_num::<f64>();
            assert!(
                (got - expected).abs() < 2e-3,
                "{best} {rival} {margin}: {got} vs {expected}"
            );
        }
        // A rival at the threshold ratio or a margin at the threshold: 0.
        let zero = |b: f64, r: f64, g: f64| {
            confidence(
                Score::from_num(b),
                Score::from_num(r),
                Score::from_num(g),
                &t,
            )
        };
        assert_eq!(zero(0.8, 0.8, 0.9), Score::ZERO);
        assert_eq!(zero(0.8, 0.1, 0.1), Score::ZERO);
        assert_eq!(zero(0.0, 0.0, 1.0), Score::ZERO);
        // Extremes stay in [0, 1].
        for v in [Score::MIN, Score::ZERO, Score::ONE, Score::MAX] {
            let c = confidence(v, v, v, &t);
            assert!((Score::ZERO..=Score::ONE).contains(&c), "{v}: {c}");
        }
    }

    /// The verified confidence: ½ exactly at the thresholds, in [0, 1] for
    /// any inputs (a threshold of one bit makes the ramp saturate, not wrap).
    #[test]
    fn verified_confidence_is_half_at_its_thresholds() {
        let t = Thresholds::DEFAULT;
        let half = Score::from_num(0.5);
        assert_eq!(verified_confidence(Score::ONE, t.decision_gap, &t), half);
        assert_eq!(verified_confidence(t.min_overlap, Score::ONE, &t), half);
        assert!(verified_confidence(Score::ONE, t.decision_gap - Score::DELTA, &t) < half);
        assert!(verified_confidence(t.min_overlap - Score::DELTA, Score::ONE, &t) < half);
        let tiny = Thresholds {
            decision_gap: Score::DELTA,
            min_overlap: Score::DELTA,
            ..t
        };
        for v in [Score::MIN, -Score::ONE, Score::ZERO, Score::ONE, Score::MAX] {
            let c = verified_confidence(v, v, &tiny);
            assert!((Score::ZERO..=Score::ONE).contains(&c), "{v}: {c}");
        }
        assert_eq!(
            verified_confidence(Score::MAX, Score::MAX, &tiny),
            Score::ONE
        );
    }

    fn candidate(degrees: f32) -> Candidate {
        Candidate {
            alpha: Angle::from_degrees(degrees),
            score: Score::ONE,
            alignment: None,
            translation: None,
            support: None,
            free_space: None,
        }
    }

    /// The nearest candidate within 3σ, alone or not; none outside.
    #[test]
    fn pick_with_prior_by_hand() {
        let c = [candidate(10.0), candidate(190.0), candidate(30.0)];
        let prior = |a: f32, s: f32| Prior {
            alpha: Angle::from_degrees(a),
            sigma: Angle::from_degrees(s),
        };
        assert_eq!(
            pick_with_prior(&c, prior(185.0, 2.0)),
            Some((c[1].alpha, true))
        );
        // 10° and 30° both within 3·8°: the nearer, not alone.
        assert_eq!(
            pick_with_prior(&c, prior(22.0, 8.0)),
            Some((c[2].alpha, false))
        );
        assert_eq!(pick_with_prior(&c, prior(100.0, 5.0)), None);
        assert_eq!(pick_with_prior(&[], prior(0.0, 180.0)), None);
        // Across 0°: 350° is 20° from 10°.
        assert_eq!(
            pick_with_prior(&c, prior(350.0, 7.0)),
            Some((c[0].alpha, true))
        );
        // A huge σ saturates instead of wrapping.
        assert!(pick_with_prior(&c, prior(0.0, 170.0)).is_some());
    }
}
