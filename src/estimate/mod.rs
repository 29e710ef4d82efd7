//! The estimator: the pipeline's orchestration. One estimate streams the
//! grid's signature ([`signature`](crate::signature)), correlates it with the
//! reference's ([`correlation`](crate::correlation)), resolves α versus
//! α + π for the best peak and a close rival ([`direction`](crate::direction),
//! which also gives the pose), and, in the improved mode with verification,
//! scores the candidates by alignment ([`verify`]). The answer types are in
//! [`answer`].

mod answer;
mod seed;
mod verify;

pub use answer::{Candidate, Estimate, Prior, Status, Thresholds, MAX_CANDIDATES};

use crate::angle::Angle;
use crate::correlation::{Correlation, Peak};
use crate::direction::{self, HalfTurn, HalfTurnTest};
use crate::grid::Grid;
use crate::pose::scale::ScaleRange;
use crate::pose::Pose;
use crate::reference::Reference;
use crate::scan::FreeSpace;
use crate::signature::{PeakKind, Signature};
use crate::Score;
use answer::{confidence, pick_with_prior, push_pair};
use heapless::Vec;
use verify::Unverified;

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
/// The estimator for `W × H` grids and `N` θ steps over the full circle.
/// `RW`, `HALF` and `RHO` are derived sizes: use the
/// [`estimator!`](crate::estimator) macro.
///
/// State: the signature of the current image (`4·HALF + 2` bytes) and the
/// settings: 760 B at 128², `N` = 360. Scratch on the stack, only while it
/// is used: two ρ columns (`4·RHO` bytes) while a signature is voted, one
/// (`2·RHO`) during each direction test. Work per estimate: the
/// votes of `HALF` columns (occupied cells × `HALF`), `HALF²` multiply-adds of
/// the correlation, and per direction test (improved mode) `PROFILE_COLUMNS`
/// split-vote columns and twice as many profile matches, which also give the
/// translation. The scale search, when on, adds up to 26 × `PROFILE_COLUMNS`
/// column votes and matches per direction test ([`ScaleRange`]), and with
/// the verification one more direction test per other verified peak.
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
    current: Signature<HALF>,
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
            current: Signature::empty(mode.peak_kind()),
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

    /// Replaces the thresholds in place, e.g. a firmware that lowers the
    /// work budget ([`Thresholds::search_budget`]) when its deadline
    /// tightens, without moving the estimator.
    pub fn set_thresholds(&mut self, thresholds: Thresholds) {
        self.thresholds = thresholds;
    }

    /// Also estimates the scale `s` (improved mode), searching `range`;
    /// without this `s` = 1 (the right model for scans of one sensor or a
    /// camera at a fixed height). Costs up to 26 re-votes and matches of the
    /// profile columns per direction test (see [`ScaleRange`]); with the
    /// verification each of the (up to three) verified correlation peaks
    /// gets its own test and is aligned at its own scale: on the Cortex-M4F
    /// bench scene (128², `N_θ` 360) 14.7 M instructions more than without
    /// the search (`budgets/TABLE.md`).
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
        Reference::prepare::<N>(grid, self.mode.peak_kind(), &mut [[0; RHO]; 2])
    }

    /// Makes `reference` the reference of `grid` for this estimator's mode,
    /// in place ([`Reference::prepare_in_place`]: no second reference on
    /// the stack while it is built).
    pub fn reference_in_place(
        &mut self,
        grid: &Grid<W, H, RW>,
        reference: &mut Reference<W, H, RW, HALF, RHO>,
    ) {
        reference.prepare_in_place::<N>(grid, self.mode.peak_kind(), &mut [[0; RHO]; 2]);
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
        self.estimate_views(reference, grid, None, prior)
    }

    /// Rotation of `grid` relative to `reference` when both are laser scans
    /// and `free` holds the cells their beams crossed
    /// ([`Raster::free_space`](crate::Raster::free_space) of each scan, on
    /// the same [`Raster`](crate::Raster) as its occupied cells). With the
    /// verification on (the default), a candidate pose that lays one scan's
    /// walls where the other sensor saw through loses support
    /// ([`Candidate::free_space`], [`Thresholds::free_space_weight`]): this
    /// is what tells a corridor seen from its two ends apart, or a large turn
    /// from a small one in a symmetric building. Without verification,
    /// exactly [`Self::estimate_with_prior`]. `prior` as there.
    pub fn estimate_scans(
        &mut self,
        reference: &Reference<W, H, RW, HALF, RHO>,
        grid: &Grid<W, H, RW>,
        free: &FreeSpace<'_, W, H, RW>,
        prior: Option<Prior>,
    ) -> Estimate {
        self.estimate_views(reference, grid, Some(free), prior)
    }

    /// [`Self::estimate_with_prior`], with the scans' free space if known.
    fn estimate_views(
        &mut self,
        reference: &Reference<W, H, RW, HALF, RHO>,
        grid: &Grid<W, H, RW>,
        free: Option<&FreeSpace<'_, W, H, RW>>,
        prior: Option<Prior>,
    ) -> Estimate {
        let occupied = grid.occupied();
        if occupied < self.thresholds.min_occupied
            || reference.occupied() < self.thresholds.min_occupied
        {
            return Estimate::no_structure();
        }
        self.stream_current(grid, reference.signature().kind());
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
            return self.verified(reference, grid, found, free, prior);
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
            runner_up: None,
            overlap: Score::ZERO,
            translation: if alpha == chosen_alpha {
                translation
            } else {
                None
            },
            search_rows: 0,
        }
    }

    /// Votes `grid`'s signature into `current`. Not inlined: its two columns
    /// (`4·RHO` bytes) are on the stack only while it runs, not during the
    /// direction tests and the verification that follow.
    #[inline(never)]
    fn stream_current(&mut self, grid: &Grid<W, H, RW>, kind: PeakKind) {
        self.current
            .restream::<W, H, RW, N, RHO>(grid, kind, &mut [[0; RHO]; 2]);
    }

    /// α of a correlation peak, its direction test and (improved mode) the
    /// translation implied by the profile shifts.
    fn resolve(
        &mut self,
        reference: &Reference<W, H, RW, HALF, RHO>,
        grid: &Grid<W, H, RW>,
        peak: &Peak,
    ) -> (Angle, HalfTurnTest, Option<Pose>) {
        match self.mode {
            Mode::Paper => direction::paper::<N, HALF>(reference.signature(), &self.current, peak),
            Mode::Improved => {
                let alpha =
                    Angle::from_steps_q16(((peak.shift as i64) << 16) + peak.offset_q16(), N);
                self.profile_test(reference, grid, alpha)
            }
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
    /// a [`ScaleRange`] is set): [`direction::improved`]. Not inlined: its
    /// column (`2·RHO` bytes) is on the stack only while it runs.
    #[inline(never)]
    fn profile_test(
        &mut self,
        reference: &Reference<W, H, RW, HALF, RHO>,
        grid: &Grid<W, H, RW>,
        alpha: Angle,
    ) -> (Angle, HalfTurnTest, Option<Pose>) {
        let max_shift = self.max_shift();
        direction::improved::<W, H, RW, N, HALF, RHO>(
            reference,
            grid,
            alpha,
            self.scale,
            max_shift,
            &mut [0; RHO],
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{pyramid_words, rho_bins};

    type E = Estimator<64, 64, 2, 128, 64, { rho_bins(64, 64) }, { pyramid_words(64, 64) }>;

    /// A centred rectangle outline: centrally symmetric, so α and α + π
    /// are both candidates and the direction is ambiguous; a prior picks.
    #[test]
    fn estimate_with_prior_picks_among_the_candidates() {
        let mut g = Grid::<64, 64, 2>::new();
        g.set_cells((12..52).flat_map(|c| [(c, 22), (c, 41)]))
            .unwrap();
        g.set_cells((22..42).flat_map(|r| [(12, r), (51, r)]))
            .unwrap();
        for verify in [false, true] {
            let mut e = E::new(Mode::Improved).with_verification(verify);
            let reference = e.reference(&g);
            let plain = e.estimate(&reference, &g);
            assert_ne!(plain.status, Status::Confident, "verify {verify}");
            let near = |e: &Estimate, degrees: f32| {
                e.alpha.distance(Angle::from_degrees(degrees)).to_degrees() < 1.0
            };
            assert!(plain.candidates.iter().any(|c| near_c(c, 0.0)));
            assert!(plain.candidates.iter().any(|c| near_c(c, 180.0)));
            for target in [0.0f32, 180.0] {
                let prior = Prior {
                    alpha: Angle::from_degrees(target + 2.0),
                    sigma: Angle::from_degrees(3.0),
                };
                let picked = e.estimate_with_prior(&reference, &g, Some(prior));
                assert!(near(&picked, target), "verify {verify}: {:?}", picked.alpha);
                assert_eq!(picked.status, Status::Confident, "verify {verify}");
            }
            // A prior far from every candidate changes nothing.
            let far = Prior {
                alpha: Angle::from_degrees(90.0),
                sigma: Angle::from_degrees(1.0),
            };
            let unchanged = e.estimate_with_prior(&reference, &g, Some(far));
            assert_eq!(
                (unchanged.alpha, unchanged.status),
                (plain.alpha, plain.status)
            );
        }
    }

    fn near_c(c: &Candidate, degrees: f32) -> bool {
        c.alpha.distance(Angle::from_degrees(degrees)).to_degrees() < 1.0
    }
}
