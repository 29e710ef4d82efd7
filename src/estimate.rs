//! The estimator: rotation (and translation) of image 2 relative to a
//! reference, with status, confidence and candidates.

use crate::accumulator::{vote_column_split, Column, UNIT_SCALE_Q16};
use crate::align::{self, sort_descending, Aligner, Placement, Pyramid};
use crate::correlation::circular_distance;
use crate::correlation::{Correlation, Peak};
use crate::direction::{match_curve, match_profile, paper_asymmetry, MatchCurve, ProfileMatch};
use crate::reference::{Reference, PROFILE_COLUMNS};
use crate::scale::{self, ScaleRange, Window};
use crate::signature::{PeakKind, Signature};
use crate::translation::{
    fit_best_shifts, fit_translation, ColumnShift, Translation, WeightedShift,
};
use crate::trig::TrigTable;
use crate::{Angle, Grid, Score};
use fixed::types::I16F16;
use heapless::Vec;

/// Which pipeline the estimator runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Mode {
    /// The paper as written: `D = max_ρ A`, the whole-step correlation peak,
    /// and the asymmetry-map test for α vs α + π.
    Paper,
    /// Two-bin `D`, parabolic sub-step peak, and the column-profile test for
    /// α vs α + π (DESIGN.md §3), plus the translation.
    Improved,
}

impl Mode {
    /// The `D(θ)` reduction this mode uses.
    pub const fn peak_kind(self) -> PeakKind {
        match self {
            Mode::Paper => PeakKind::SingleBin,
            Mode::Improved => PeakKind::TwoBin,
        }
    }
}

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
    /// `(winner − loser) / max(|winner|, |loser|)` in [0, 1] (improved mode),
    /// or `|direct|` (paper mode, where `flipped = −direct`).
    pub fn margin(&self) -> Score {
        let (hi, lo) = if self.direct >= self.flipped {
            (self.direct, self.flipped)
        } else {
            (self.flipped, self.direct)
        };
        if lo == -hi {
            return hi.abs();
        }
        let scale = hi.abs().max(lo.abs());
        if scale == Score::ZERO {
            Score::ZERO
        } else {
            hi.saturating_sub(lo).saturating_div(scale)
        }
    }
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
    /// With verification: ambiguous unless the best candidate's alignment is
    /// at least this multiple of the best one at least 5° away. Default 1.15
    /// (chosen on the real scan pairs of `../shared/data`, README).
    pub alignment_ratio: Score,
    /// With verification: [`Status::LowOverlap`] when the best pose puts less
    /// than this share of the second view within one cell of the reference.
    /// Default 0.30 (chosen on the real scan pairs, README).
    pub min_overlap: Score,
}

impl Thresholds {
    /// The defaults, usable in `const` context.
    pub const DEFAULT: Thresholds = Thresholds {
        rival_ratio: Score::from_bits(58_982),     // 0.9
        direction_margin: Score::from_bits(6_554), // 0.10
        min_occupied: 8,
        max_shift_fraction: Score::from_bits(16_384), // 0.25
        alignment_ratio: Score::from_bits(75_366),    // 1.15
        min_overlap: Score::from_bits(19_661),        // 0.30
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
    /// rival peak or the direction margin approach their thresholds.
    pub confidence: Score,
    /// Pearson correlation of the winning shift (modulo π), in [−1, 1].
    pub correlation: Score,
    /// Pearson correlation of the best rival peak at least 5° away (0 if none).
    pub rival: Score,
    /// The α vs α + π test of the winning peak.
    pub half_turn: HalfTurnTest,
    /// Up to [`MAX_CANDIDATES`] rotations, strongest first; `alpha` is one of
    /// them (the first, unless a prior picked another).
    pub candidates: Vec<Candidate, MAX_CANDIDATES>,
    /// With verification: the share of the second view's sampled cells that
    /// the chosen pose puts within one cell of the reference, in [0, 1];
    /// 0 without verification.
    pub overlap: Score,
    /// The rest of the pose for `alpha`: translation `t` in pixels, scale
    /// (1 unless [`Estimator::with_scale_search`]), residual and the
    /// unobservable direction, if any. Improved mode only; `None` when the
    /// rotation is not resolved or a prior picked another candidate than the
    /// one the translation was fitted for.
    pub translation: Option<Translation>,
}

impl Estimate {
    fn no_structure() -> Self {
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
            overlap: Score::ZERO,
            translation: None,
        }
    }
}

/// The estimator for `W × H` grids and `N` θ steps over the full circle.
/// `RW`, `HALF` and `RHO` are derived sizes: use the
/// [`estimator!`](crate::estimator) macro.
///
/// State: two ρ columns (`4·RHO` bytes) and the signature of the current
/// image (`4·HALF + 2` bytes): 1.8 KiB at 128², `N` = 360. Work per estimate: the
/// votes of `HALF` columns (occupied cells × `HALF`), `HALF²` multiply-adds of
/// the correlation, and per direction test (improved mode) `PROFILE_COLUMNS`
/// split-vote columns and twice as many profile matches, which also give the
/// translation. The scale search, when on, adds up to 26 × `PROFILE_COLUMNS`
/// column votes and matches ([`ScaleRange`]).
#[derive(Clone, Debug)]
pub struct Estimator<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const HALF: usize,
    const RHO: usize,
    const PW: usize,
> {
    mode: Mode,
    thresholds: Thresholds,
    scale: Option<ScaleRange>,
    verify: bool,
    columns: [Column<RHO>; 2],
    current: Signature<HALF>,
    pyramid: Pyramid<W, H, PW>,
}

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
    /// An estimator with the default [`Thresholds`].
    pub const fn new(mode: Mode) -> Self {
        const { crate::config::check_config(W, H, RW, N, HALF, RHO) };
        const { crate::config::check_pyramid(W, H, PW) };
        Self {
            mode,
            thresholds: Thresholds::DEFAULT,
            scale: None,
            verify: true,
            columns: [[0; RHO]; 2],
            current: Signature::empty(mode.peak_kind()),
            pyramid: Pyramid::new(),
        }
    }

    /// Turns the verification by alignment on (the default) or off
    /// (improved mode; the paper mode never verifies). Off, the estimator
    /// answers from the correlation and the column-profile test alone.
    pub const fn with_verification(mut self, on: bool) -> Self {
        self.verify = on;
        self
    }

    /// Whether the improved mode verifies its candidates by alignment.
    pub const fn verification(&self) -> bool {
        self.verify
    }

    /// Replaces the thresholds.
    pub const fn with_thresholds(mut self, thresholds: Thresholds) -> Self {
        self.thresholds = thresholds;
        self
    }

    /// Also estimates the scale `s` (improved mode), searching `range`;
    /// without this `s` = 1 (the right model for scans of one sensor or a
    /// camera at a fixed height). Costs up to 26 re-votes and matches of the
    /// profile columns per estimate (see [`ScaleRange`]).
    pub const fn with_scale_search(mut self, range: ScaleRange) -> Self {
        self.scale = Some(range);
        self
    }

    /// Turns the scale search on (`Some`) or off (`None`, `s` = 1) in place,
    /// e.g. when a camera starts or stops changing height.
    pub fn set_scale_search(&mut self, range: Option<ScaleRange>) {
        self.scale = range;
    }

    /// The status thresholds.
    pub const fn thresholds(&self) -> Thresholds {
        self.thresholds
    }

    /// The scale range searched, if any.
    pub const fn scale_search(&self) -> Option<ScaleRange> {
        self.scale
    }

    /// The mode.
    pub const fn mode(&self) -> Mode {
        self.mode
    }

    /// The signature of the last grid passed to [`Self::estimate`].
    pub const fn current_signature(&self) -> &Signature<HALF> {
        &self.current
    }

    /// Prepares `grid` as a reference for this estimator's mode.
    pub fn reference(&mut self, grid: &Grid<W, H, RW>) -> Reference<W, H, RW, HALF, RHO> {
        Reference::prepare::<N>(grid, self.mode.peak_kind(), &mut self.columns)
    }

    /// Rotation of `grid` relative to two grids: prepares `first` as the
    /// reference, then [`Self::estimate`].
    pub fn estimate_pair(&mut self, first: &Grid<W, H, RW>, second: &Grid<W, H, RW>) -> Estimate {
        let reference = self.reference(first);
        self.estimate(&reference, second)
    }

    /// Rotation of `grid` relative to `reference`.
    pub fn estimate(
        &mut self,
        reference: &Reference<W, H, RW, HALF, RHO>,
        grid: &Grid<W, H, RW>,
    ) -> Estimate {
        self.estimate_with_prior(reference, grid, None)
    }

    /// Like [`Self::estimate`], with a prior that picks among the candidates:
    /// the one nearest the prior within 3σ; if it is the only one within 3σ,
    /// the status becomes [`Status::Confident`] (the prior resolved the
    /// ambiguity). Without any candidate within 3σ the vision answer stands.
    pub fn estimate_with_prior(
        &mut self,
        reference: &Reference<W, H, RW, HALF, RHO>,
        grid: &Grid<W, H, RW>,
        prior: Option<Prior>,
    ) -> Estimate {
        let occupied = grid.occupied();
        if occupied < self.thresholds.min_occupied
            || reference.occupied() < self.thresholds.min_occupied
        {
            return Estimate::no_structure();
        }
        let kind = reference.signature().kind();
        self.current
            .restream::<W, H, RW, N, RHO>(grid, kind, &mut self.columns);
        let correlation = Correlation::of(reference.signature().peaks(), self.current.peaks());
        let Some(best) = correlation.best().copied() else {
            return Estimate::no_structure();
        };
        let best_score = correlation.score(&best);
        if best_score <= Score::ZERO {
            return Estimate::no_structure();
        }
        let separation = (N / 72).max(2);
        let rival = correlation.rival(separation).copied();
        let rival_score = rival.map_or(Score::ZERO, |p| correlation.score(&p));

        let mut candidates: Vec<Candidate, MAX_CANDIDATES> = Vec::new();
        let (alpha_best, test, translation) = self.resolve(reference, grid, &best);
        push_pair(&mut candidates, alpha_best, best_score, &test);
        // A rival close to the best is worth a second direction test.
        if let Some(r) = rival.filter(|_| rival_score * 4 >= best_score * 3) {
            let (alpha_r, test_r, _) = self.resolve(reference, grid, &r);
            push_pair(&mut candidates, alpha_r, rival_score, &test_r);
        }
        if self.mode == Mode::Improved && self.verify {
            let hint = translation.map(|t| match test.chosen {
                HalfTurn::Direct => (alpha_best, t),
                HalfTurn::Flipped => (alpha_best + Angle::HALF_TURN, t),
            });
            let found = Unverified {
                correlation: &correlation,
                best_score,
                test,
                hint,
            };
            return self.verified(reference, grid, found, prior);
        }

        let axis_ambiguous = rival_score >= best_score.saturating_mul(self.thresholds.rival_ratio);
        let margin = test.margin();
        let direction_ambiguous = margin < self.thresholds.direction_margin;
        let mut status = if direction_ambiguous {
            Status::AmbiguousDirection
        } else if axis_ambiguous {
            Status::AmbiguousAxis
        } else {
            Status::Confident
        };
        let chosen_alpha = match test.chosen {
            HalfTurn::Direct => alpha_best,
            HalfTurn::Flipped => alpha_best + Angle::HALF_TURN,
        };
        let mut alpha = chosen_alpha;
        if let Some((picked, alone)) = prior.and_then(|p| pick_with_prior(&candidates, p)) {
            alpha = picked;
            if alone {
                status = Status::Confident;
            }
        }
        let confidence = confidence(best_score, rival_score, margin, &self.thresholds);
        Estimate {
            alpha,
            status,
            confidence,
            correlation: best_score,
            rival: rival_score,
            half_turn: test,
            candidates,
            overlap: Score::ZERO,
            translation: if alpha == chosen_alpha {
                translation
            } else {
                None
            },
        }
    }

    /// α of a correlation peak, its direction test and (improved mode) the
    /// translation implied by the profile shifts.
    fn resolve(
        &mut self,
        reference: &Reference<W, H, RW, HALF, RHO>,
        grid: &Grid<W, H, RW>,
        peak: &Peak,
    ) -> (Angle, HalfTurnTest, Option<Translation>) {
        match self.mode {
            Mode::Paper => {
                let alpha = Angle::from_steps_q16((peak.shift as i64) << 16, N);
                let direct = paper_asymmetry(reference.signature(), &self.current, peak.shift);
                let direct = Score::from_bits(direct);
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
            Mode::Improved => {
                let alpha =
                    Angle::from_steps_q16(((peak.shift as i64) << 16) + peak.offset_q16(), N);
                self.profile_test(reference, grid, alpha)
            }
        }
    }

    /// The verification by alignment (improved mode, on by default): both
    /// halves of the strongest correlation peaks are scored by their best
    /// translation ([`Aligner::search`], exact over ±`max_shift`), a local
    /// angle search runs around the strongest, ICP refines the winner, and
    /// the status says whether a rival at least 5° away comes close
    /// ([`Thresholds::alignment_ratio`]) or the pose explains too little of
    /// the view ([`Thresholds::min_overlap`]).
    ///
    /// Not inlined: its frame (about 2 KiB) stays off the stack of estimates
    /// without verification.
    #[inline(never)]
    fn verified(
        &mut self,
        reference: &Reference<W, H, RW, HALF, RHO>,
        grid: &Grid<W, H, RW>,
        found: Unverified<'_>,
        prior: Option<Prior>,
    ) -> Estimate {
        let Unverified {
            correlation,
            best_score,
            test,
            hint,
        } = found;
        self.pyramid.build(reference.grid());
        let max_shift = self.max_shift() as i32;
        // The scale the profile test found (1 without a scale search) holds
        // for every candidate rotation.
        let scale_q16 = hint.map_or(1 << 16, |(_, t)| t.scale.to_bits().max(1 << 15) as u32);
        let inv_scale_q16 = ((1u64 << 32) / u64::from(scale_q16)) as u32;
        let separation = Angle::from_steps_q16(((N / 72).max(2) as i64) << 16, N);
        let mut seeds: Vec<(Placement, Score), SEEDS> = Vec::new();
        let (winner, points, near, alpha, u_q8) = {
            let mut aligner = Aligner::new(reference.grid(), &self.pyramid, grid, inv_scale_q16);
            // 1. Both halves of the strongest distinct peaks, each with the
            //    best translation over the whole window.
            let mut peaks: Vec<&Peak, VERIFY_PEAKS> = Vec::new();
            for peak in &correlation.peaks {
                let apart = peaks
                    .iter()
                    .all(|p| circular_distance(p.shift, peak.shift, HALF) >= (N / 72).max(2));
                if apart && peaks.push(peak).is_err() {
                    break;
                }
            }
            for peak in peaks {
                let alpha =
                    Angle::from_steps_q16(((peak.shift as i64) << 16) + peak.offset_q16(), N);
                let score = correlation.score(peak);
                // The half the profile test chose goes first: its translation
                // gives the search a floor at once.
                let halves = match hint {
                    Some((h, _)) if h == alpha + Angle::HALF_TURN => [h, alpha],
                    _ => [alpha, alpha + Angle::HALF_TURN],
                };
                for half in halves {
                    aligner.rotate::<N>(half, (0, 0));
                    // A seed that cannot reach the best so far divided by the
                    // ambiguity ratio cannot change the decision: its search
                    // stops there (and it is not a candidate).
                    let floor = seeds.iter().map(|s| s.0.score).max().map_or(0, |best| {
                        irrelevant_below(best, self.thresholds.alignment_ratio)
                    });
                    let floor = match hint {
                        Some((h, t)) if h == half => {
                            floor.max(aligner.score(hint_shift::<N>(h, &t)).saturating_sub(1))
                        }
                        _ => floor,
                    };
                    if let Some((shift, s)) = aligner.search((0, 0), max_shift, floor) {
                        let _ = seeds.push((
                            Placement {
                                alpha: half,
                                shift,
                                score: s,
                            },
                            score,
                        ));
                    }
                }
            }
            if seeds.is_empty() {
                return Estimate::no_structure();
            }
            sort_descending(&mut seeds, |s| s.0.score);
            // 2. Local angle search around the strongest seeds: ±10° in
            //    strides of ~2°, then halving strides down to one θ step.
            let strongest = seeds.first().map_or(0, |s| s.0.score);
            for (seed, _) in seeds.iter_mut().take(ANGLE_SEARCH_SEEDS) {
                if seed.score * 2 < strongest {
                    continue;
                }
                *seed = angle_search::<W, H, RW, N, PW>(&mut aligner, seed);
            }
            sort_descending(&mut seeds, |s| s.0.score);
            let Some(&(winner, _)) = seeds.first() else {
                return Estimate::no_structure();
            };
            // 3. ICP below one cell and one θ step; kept unless it loses
            //    alignment (e.g. drawn onto a neighbouring wall).
            let (alpha, u_q8) =
                align::refine::<W, H, RW, N>(reference.grid(), grid, &winner, inv_scale_q16);
            aligner.rotate::<N>(alpha, u_q8);
            let refined = aligner.score((0, 0));
            let (alpha, u_q8, near) = if 16 * refined >= 15 * winner.score {
                (alpha, u_q8, aligner.near((0, 0)))
            } else {
                aligner.rotate::<N>(winner.alpha, (0, 0));
                let u = (
                    i64::from(winner.shift.0) << 8,
                    -(i64::from(winner.shift.1) << 8),
                );
                (winner.alpha, u, aligner.near(winner.shift))
            };
            (winner, aligner.points(), near, alpha, u_q8)
        };
        let max_score = (2 * points).max(1);
        let alignment =
            |score: u32| Score::from_bits(((u64::from(score) << 16) / u64::from(max_score)) as i32);
        let overlap = Score::from_bits(((u64::from(near) << 16) / u64::from(points.max(1))) as i32);
        // The strongest seed at least 5° from the winner.
        let rival = seeds
            .iter()
            .map(|s| s.0)
            .filter(|p| p.alpha.distance(winner.alpha) >= separation)
            .max_by_key(|p| p.score);
        let rival_score = rival.map_or(0, |p| p.score);
        let t = self.thresholds;
        let clear = Score::from_num(winner.score)
            >= t.alignment_ratio.saturating_mul_int(rival_score as i32);
        let status = if overlap < t.min_overlap {
            Status::LowOverlap
        } else if !clear {
            let near_half_turn = rival.is_some_and(|r| {
                r.alpha.distance(winner.alpha + Angle::HALF_TURN)
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
        let mut candidates: Vec<Candidate, MAX_CANDIDATES> = Vec::new();
        let mut listed: Vec<Angle, MAX_CANDIDATES> = Vec::new();
        for (placement, correlation) in &seeds {
            let candidate_alpha = if placement == &winner {
                alpha
            } else {
                placement.alpha
            };
            // Duplicates are judged on the seeds' rotations (ICP may move the
            // winner towards a rival it was compared with).
            let duplicate = listed
                .iter()
                .any(|a: &Angle| a.distance(placement.alpha) < separation);
            if !duplicate && !candidates.is_full() {
                let u = if placement == &winner {
                    u_q8
                } else {
                    (
                        i64::from(placement.shift.0) << 8,
                        -(i64::from(placement.shift.1) << 8),
                    )
                };
                let t = verified_translation::<N>(candidate_alpha, u, scale_q16, None);
                let _ = listed.push(placement.alpha);
                let _ = candidates.push(Candidate {
                    alpha: candidate_alpha,
                    score: (*correlation).clamp(Score::ZERO, Score::ONE),
                    alignment: Some(alignment(placement.score)),
                    translation: Some((t.x, t.y)),
                });
            }
        }
        let mut chosen = alpha;
        let mut status = status;
        if let Some(prior) = prior {
            if let Some((picked, alone)) = pick_with_prior(&candidates, prior) {
                chosen = picked;
                if alone && status != Status::LowOverlap {
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
                scale_q16,
                fit.as_ref(),
            ))
        } else {
            None
        };
        let best = Score::from_num(winner.score);
        let separation_share = if winner.score == 0 {
            Score::ZERO
        } else {
            (best - Score::from_num(rival_score))
                .checked_div(best)
                .unwrap_or(Score::ZERO)
        };
        Estimate {
            alpha: chosen,
            status,
            confidence: verified_confidence(overlap, separation_share, &t),
            correlation: best_score,
            rival: correlation
                .rival((N / 72).max(2))
                .map_or(Score::ZERO, |p| correlation.score(p)),
            half_turn: test,
            candidates,
            overlap,
            translation,
        }
    }

    /// Largest translation searched, ρ bins (= pixels).
    fn max_shift(&self) -> usize {
        self.thresholds
            .max_shift_fraction
            .saturating_mul_int(RHO as i32)
            .to_num::<i32>()
            .max(1) as usize
    }

    /// The improved direction test and the pose (translation, and scale when
    /// a [`ScaleRange`] is set).
    fn profile_test(
        &mut self,
        reference: &Reference<W, H, RW, HALF, RHO>,
        grid: &Grid<W, H, RW>,
        alpha: Angle,
    ) -> (Angle, HalfTurnTest, Option<Translation>) {
        let max_shift = self.max_shift();
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
        let [column, _] = &mut self.columns;
        for profile in reference.profiles() {
            // Column of image 2 where the reference column θ lands under α.
            let theta = Angle::from_steps_q16((profile.theta as i64) << 16, N);
            let m = (theta + alpha).nearest_step(N);
            vote_profile_column::<W, H, RW, N, HALF, RHO>(grid, m, UNIT_SCALE_Q16, column);
            let direct = match_profile(&profile.counts, column, max_shift, false);
            let flipped = match_profile(&profile.counts, column, max_shift, true);
            let strength = u64::from(reference.signature().peak(profile.theta));
            direct_sum += u64::from(direct.score_q16);
            flipped_sum += u64::from(flipped.score_q16);
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
        let translation = match self.scale {
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
}

/// A reference column that locates the pose: its profile, the column `m` of
/// image 2 it lands on, that column's normal and its relative strength.
struct PoseColumn<'a, const RHO: usize> {
    counts: &'a [u8; RHO],
    m: usize,
    normal_q15: (i32, i32),
    relative_q16: u64,
}

impl<const RHO: usize> PoseColumn<'_, RHO> {
    /// The column's shift for the translation fit, weighted by the match
    /// score times the relative strength (both Q16).
    fn shift(&self, m: ProfileMatch) -> ColumnShift {
        ColumnShift {
            normal_q15: self.normal_q15,
            shift_q16: m.shift_q16,
            weight_q16: self.weight(m.score_q16),
            runners_up: m.runners_up.map(|r| WeightedShift {
                shift_q16: r.shift_q16,
                weight_q16: self.weight(r.score_q16),
            }),
        }
    }

    /// Match score (Q16) times relative strength, Q16.
    fn weight(&self, score_q16: u32) -> u32 {
        ((u64::from(score_q16) * self.relative_q16) >> 16) as u32
    }
}

/// What the scale search needs besides the columns.
struct PoseSearch {
    range: ScaleRange,
    mirrored: bool,
    max_shift: usize,
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
fn search_scale<
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
    let scale_q16 = scale::search(search.range, |s_q16, window| {
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
                *centre = (shift.shift_q16 + (1 << 15)) >> 16;
            }
        }
        total
    });
    (shifts, scale_q16)
}

/// Votes column `m ∈ [0, N)` of image 2 into `column` (zeroed first) with
/// split votes at `ρ · inv_scale`: columns `m ≥ HALF` are the mirror of
/// `m − HALF`.
fn vote_profile_column<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const HALF: usize,
    const RHO: usize,
>(
    grid: &Grid<W, H, RW>,
    m: usize,
    inv_scale_q16: u32,
    column: &mut Column<RHO>,
) {
    column.fill(0);
    vote_column_split::<W, H, RW, N, RHO>(grid, m % HALF, inv_scale_q16, column);
    if m >= HALF {
        mirror(column);
    }
}

/// Reverses a column in place about its centre: `b ↔ RHO − b` (θ → θ + π).
fn mirror<const RHO: usize>(column: &mut Column<RHO>) {
    // Bins 1..RHO: reversing that slice maps b to RHO − b.
    if let Some(tail) = column.get_mut(1..) {
        tail.reverse();
    }
}

/// Adds α and, when the direction test is close, α + π, scored by correlation
/// × direction share.
fn push_pair(
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
        },
    );
    insert_sorted(
        candidates,
        Candidate {
            alpha: second,
            score: correlation * second_share,
            alignment: None,
            translation: None,
        },
    );
}

/// Inserts keeping the candidates sorted by score, strongest first; when full,
/// the weakest is dropped.
fn insert_sorted(candidates: &mut Vec<Candidate, MAX_CANDIDATES>, candidate: Candidate) {
    let at = candidates
        .iter()
        .position(|c| c.score < candidate.score)
        .unwrap_or(candidates.len());
    if at >= MAX_CANDIDATES {
        return;
    }
    if candidates.is_full() {
        candidates.pop();
    }
    // Cannot fail: there is room and `at ≤ len`.
    let _ = candidates.insert(at, candidate);
}

/// Confidence in [0, 1]: the best correlation, scaled linearly to 0 as the
/// rival ratio rises from `rival_ratio − 0.1` to `rival_ratio`, and as the
/// direction margin falls from twice its threshold to the threshold.
fn confidence(best: Score, rival: Score, margin: Score, t: &Thresholds) -> Score {
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

/// What the correlation and the profile test found, handed to the
/// verification.
struct Unverified<'c> {
    correlation: &'c Correlation,
    /// Pearson correlation of the best peak.
    best_score: Score,
    /// The profile test of the best peak.
    test: HalfTurnTest,
    /// The half of the best peak the profile test chose, and its pose.
    hint: Option<(Angle, Translation)>,
}

/// Correlation peaks whose two halves the verification scores.
const VERIFY_PEAKS: usize = 3;
/// Seeds of the verification: both halves of each peak.
const SEEDS: usize = 2 * VERIFY_PEAKS;
/// Seeds that get the local angle search (those at least half as aligned as
/// the best).
const ANGLE_SEARCH_SEEDS: usize = 3;
/// Translation window (± cells) of each rotation of the angle search, around
/// the shift predicted from the seed.
const LOCAL_RADIUS: i32 = 3;

/// Searches rotations within ±10° of `seed`, first in strides of about 2°,
/// then halving the stride around the best down to one θ step; each rotation
/// gets the best shift within ±[`LOCAL_RADIUS`] of the one predicted from the
/// seed. Returns the pose (the seed's unless a rotation beats it by 3 %)
/// with the best score found at any rotation.
fn angle_search<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const PW: usize,
>(
    aligner: &mut Aligner<'_, W, H, RW, PW>,
    seed: &Placement,
) -> Placement {
    let step = |k: i64| Angle::from_steps_q16(k << 16, N);
    let reach = (N / 36).max(1) as i64; // 10°
    let mut stride = (N / 180).max(1) as i64; // 2°
    let mut best = *seed;
    // The pose moves only when a rotation beats the seed by a margin:
    // single-point differences between neighbouring steps are noise, and the
    // seed's sub-step α from the correlation is the more precise (synthetic
    // polygons 128²: median 0.33° without the margin, 0.17° with it). The
    // score reported is the best found at any rotation, so that a rival is
    // judged by its best alignment.
    let margin = seed.score + (seed.score / 32).max(2);
    let mut peak = seed.score;
    let mut try_at =
        |aligner: &mut Aligner<'_, W, H, RW, PW>, best: &mut Placement, alpha: Angle| {
            aligner.rotate::<N>(alpha, (0, 0));
            let centre = aligner.predict::<N>(seed, alpha);
            if let Some((shift, score)) = aligner.search(centre, LOCAL_RADIUS, peak) {
                peak = score;
                if score >= margin && score > best.score {
                    *best = Placement {
                        alpha,
                        shift,
                        score,
                    };
                }
            }
        };
    let mut k = -reach;
    while k <= reach {
        if k != 0 {
            try_at(aligner, &mut best, seed.alpha + step(k));
        }
        k += stride;
    }
    while stride > 1 {
        stride /= 2;
        let centre = best.alpha;
        for k in [-stride, stride] {
            try_at(aligner, &mut best, centre + step(k));
        }
    }
    Placement {
        score: peak.max(best.score),
        ..best
    }
}

/// The shift (reference cells `(Δcol, Δrow)`) of the translation `t` fitted
/// by the profile test for rotation α: `u = −R(−α)·t`.
fn hint_shift<const N: usize>(alpha: Angle, t: &Translation) -> (i32, i32) {
    let (cos, sin) = align::sin_cos_q15::<N>(alpha);
    let (cos, sin) = (i64::from(cos), i64::from(sin));
    let (tx, ty) = (i64::from(t.x.to_bits()), i64::from(t.y.to_bits()));
    // R(−α)·t in Q31 → cells; u = −that; Δrow = −u_y.
    let ux = -(cos * tx + sin * ty) >> 31;
    let uy = -(cos * ty - sin * tx) >> 31;
    (ux as i32, -uy as i32)
}

/// The largest score that cannot make `best` ambiguous: `⌊best / ratio⌋`
/// (0 for a ratio ≤ 1, where every score counts).
fn irrelevant_below(best: u32, ratio: Score) -> u32 {
    if ratio <= Score::ONE {
        return 0;
    }
    ((u64::from(best) << 16) / ratio.to_bits() as u64) as u32
}

/// The candidate nearest the prior within 3σ, and whether it is the only one
/// within 3σ.
fn pick_with_prior(candidates: &[Candidate], prior: Prior) -> Option<(Angle, bool)> {
    let gate = Angle(prior.sigma.0.saturating_mul(3));
    let inside = || {
        candidates
            .iter()
            .filter(move |c| c.alpha.distance(prior.alpha) <= gate)
    };
    let nearest = inside().min_by_key(|c| c.alpha.distance(prior.alpha))?;
    Some((nearest.alpha, inside().count() == 1))
}

/// `t = −s·R(α)·u` in pixels from the verified pose (`u` in centred Q8
/// cells, `s` in Q16), with the column fit's unobservable direction and
/// column count; along an unobservable direction `t` keeps no component.
fn verified_translation<const N: usize>(
    alpha: Angle,
    u_q8: (i64, i64),
    scale_q16: u32,
    fit: Option<&Translation>,
) -> Translation {
    let (cos, sin) = align::sin_cos_q15::<N>(alpha);
    let (cos, sin) = (i64::from(cos), i64::from(sin));
    let s = i64::from(scale_q16);
    // Q8 × Q15 = Q23 → Q16: >> 7; then × s (Q16).
    let mut tx = ((-(cos * u_q8.0 - sin * u_q8.1) >> 7) * s) >> 16;
    let mut ty = ((-(sin * u_q8.0 + cos * u_q8.1) >> 7) * s) >> 16;
    let unobservable = fit.and_then(|f| f.unobservable);
    if let Some((dx, dy)) = unobservable {
        let (dx, dy) = (i64::from(dx.to_bits()), i64::from(dy.to_bits()));
        let along = (tx * dx + ty * dy) >> 16;
        tx -= (along * dx) >> 16;
        ty -= (along * dy) >> 16;
    }
    let clamp =
        |v: i64| I16F16::from_bits(v.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32);
    Translation {
        x: clamp(tx),
        y: clamp(ty),
        scale: I16F16::from_bits(scale_q16 as i32),
        residual: fit.map_or(I16F16::ZERO, |f| f.residual),
        columns: fit.map_or(0, |f| f.columns),
        unobservable,
    }
}

/// Confidence with verification, in [0, 1]: the overlap, scaled linearly to
/// 0 as the winner's lead over the rival (`1 − rival/best`) falls from twice
/// the threshold's lead (`1 − 1/alignment_ratio`) to it, and as the overlap
/// falls from twice `min_overlap` to it.
fn verified_confidence(overlap: Score, lead: Score, t: &Thresholds) -> Score {
    let one = Score::ONE;
    let ramp = |value: Score, threshold: Score| {
        if threshold <= Score::ZERO {
            one
        } else {
            value
                .saturating_sub(threshold)
                .saturating_div(threshold)
                .clamp(Score::ZERO, one)
        }
    };
    let needed = if t.alignment_ratio > one {
        one - one.saturating_div(t.alignment_ratio)
    } else {
        Score::ZERO
    };
    overlap.clamp(Score::ZERO, one) * ramp(lead, needed) * ramp(overlap, t.min_overlap)
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

    #[test]
    fn mirror_maps_b_to_rho_minus_b() {
        let mut c = [0u16; 8];
        c[1] = 1;
        c[3] = 3;
        c[4] = 4;
        mirror(&mut c);
        assert_eq!(c, [0, 0, 0, 0, 4, 3, 0, 1]);
    }
}
