//! Shared helpers of the evaluations (accuracy binary, property tests,
//! benchmarks): image ↔ grid conversion, one seeded trial, error measures and
//! their summary (quantiles: [`crate::stats`]).
//!
//! A *trial* draws a scene of one [`SceneKind`], a random [`Transform`]
//! (α uniform over the full circle, translation 2 px … 10 % of the image side,
//! optionally a scale in 0.9–1.1) and renders the pair with a [`Damage`]
//! preset, all from one `u64` seed, so the same seed gives the same images
//! for the paper mode, the improved mode and the float reference.

use std::f64::consts::TAU;

use hough_heading::stages::HalfTurnTest;
use hough_heading::{Angle, Estimate, Estimator, Grid, Status, Thresholds};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::reference::Image;
use crate::scene::{render_pair, Damage, Pair, Point, Scene, SceneKind, Segment, Transform};
use crate::stats::quantile;

/// Gross failure: error above this, degrees (full circle).
pub const GROSS_DEG: f64 = 5.0;

/// The library grid holding the occupied cells of `image`.
///
/// # Panics
/// If the sizes differ.
pub fn grid_from_image<const W: usize, const H: usize, const RW: usize>(
    image: &Image,
) -> Grid<W, H, RW> {
    assert_eq!((image.width, image.height), (W, H), "image size");
    let mut grid = Grid::new();
    for (col, row) in image.occupied() {
        grid.set(col, row).expect("cell inside the grid");
    }
    grid
}

/// The reference image holding the occupied cells of `grid`.
pub fn image_from_grid<const W: usize, const H: usize, const RW: usize>(
    grid: &Grid<W, H, RW>,
) -> Image {
    let mut image = Image::new(W, H);
    for row in 0..H {
        for col in 0..W {
            if grid.get(col, row) {
                image.set(col, row, true);
            }
        }
    }
    image
}

/// `angle` wrapped to `[0°, 360°)`.
pub fn wrap_360(deg: f64) -> f64 {
    deg.rem_euclid(360.0)
}

/// Circular distance of `a` and `b` modulo `period` degrees, in
/// `[0, period/2]`.
pub fn circular_error_deg(a: f64, b: f64, period: f64) -> f64 {
    let d = (a - b).rem_euclid(period);
    d.min(period - d)
}

/// Error of a library angle against a true rotation in radians, degrees, full
/// circle (`[0, 180]`).
pub fn angle_error_deg(estimate: Angle, truth_rad: f64) -> f64 {
    circular_error_deg(
        f64::from(estimate.0) * 360.0 / 4_294_967_296.0,
        truth_rad.to_degrees(),
        360.0,
    )
}

/// Error modulo a half turn (the axis only), degrees in `[0, 90]`.
pub fn axis_error_deg(estimate: Angle, truth_rad: f64) -> f64 {
    circular_error_deg(
        f64::from(estimate.0) * 360.0 / 4_294_967_296.0,
        truth_rad.to_degrees(),
        180.0,
    )
}

/// A library angle in radians, `[0, 2π)`.
pub fn angle_rad(a: Angle) -> f64 {
    f64::from(a.0) * TAU / 4_294_967_296.0
}

/// The scene and transform of trial `seed`, and the rendered pair.
pub fn trial_pair(
    kind: SceneKind,
    damage: &Damage,
    width: usize,
    height: usize,
    with_scale: bool,
    seed: u64,
) -> (Transform, Pair) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let scene = kind.generate(&mut rng);
    let transform = Transform::sample(&mut rng, width, height, with_scale);
    let pair = render_pair(&scene, &transform, damage, width, height, rng.gen());
    (transform, pair)
}

/// Like [`trial_pair`], but `I2` comes from a second rendering with another
/// seed, so the two views have independent missing stretches (the scene
/// generator draws the same gaps for both views of one pair). For scenes
/// invariant under a half turn this keeps α and α + π truly
/// indistinguishable: no damage pattern is shared between the views.
pub fn trial_pair_independent(
    kind: SceneKind,
    damage: &Damage,
    width: usize,
    height: usize,
    with_scale: bool,
    seed: u64,
) -> (Transform, Pair) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let scene = kind.generate(&mut rng);
    let transform = Transform::sample(&mut rng, width, height, with_scale);
    let first = render_pair(&scene, &transform, damage, width, height, rng.gen());
    let second = render_pair(&scene, &transform, damage, width, height, rng.gen());
    let pair = Pair {
        i1: first.i1,
        i2: second.i2,
        fit_radius_px: first.fit_radius_px,
    };
    (transform, pair)
}

/// A corridor whose two walls cross the whole image: segments three
/// unit-disc radii long at `y = ±w`, `w ∈ [0.15, 0.4)`, no doors, so after
/// fitting they are clipped by the image border in both views and nothing
/// shows the shift along them (unlike [`crate::scene::corridor`], whose wall
/// ends and doors lie inside the image and make the translation observable).
pub fn wall_to_wall_corridor<R: Rng + ?Sized>(rng: &mut R) -> Scene {
    let w = rng.gen_range(0.15..0.4);
    Scene {
        segments: vec![
            Segment::new(Point::new(-3.0, w), Point::new(3.0, w)),
            Segment::new(Point::new(-3.0, -w), Point::new(3.0, -w)),
        ],
    }
}

/// A seed for trial `index` of the row identified by `row` (any stable
/// number), decorrelated by a SplitMix64 step.
pub fn trial_seed(row: u64, index: u64) -> u64 {
    let mut z = row
        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .wrapping_add(index)
        .wrapping_add(0x632B_E59B_D9B4_E019);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// What one estimate got right and wrong, plus the raw scores needed to
/// re-derive the status under other [`Thresholds`] without re-running.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Outcome {
    /// Error, degrees: full circle, or modulo 180° for scenes that are
    /// invariant under a half turn (there α and α + π are equally right).
    pub error_deg: f64,
    /// Error modulo 180°, degrees.
    pub axis_error_deg: f64,
    /// Error over the full circle, degrees, whatever the scene's symmetry.
    pub full_error_deg: f64,
    /// The axis was right (≤ [`GROSS_DEG`]) but the half turn wrong (only for
    /// scenes without half-turn symmetry).
    pub wrong_half_turn: bool,
    /// Status of the estimate.
    pub status: Status,
    /// Winner's correlation.
    pub correlation: f64,
    /// Rival's correlation.
    pub rival: f64,
    /// [`HalfTurnTest::margin`].
    pub margin: f64,
    /// Direction test score of α (as reported by the estimate).
    pub direct: f64,
    /// Direction test score of α + π.
    pub flipped: f64,
    /// Translation error, pixels, when a translation was returned: the norm
    /// of the difference, restricted to the observable component when the
    /// library reports an unobservable direction.
    pub translation_error_px: Option<f64>,
    /// The library reported an unobservable translation direction.
    pub translation_unobservable: bool,
    /// Relative scale error `|ŝ − s| / s` when a translation (and so a
    /// scale, 1 unless searched) was returned.
    pub scale_error: Option<f64>,
    /// [`Estimate::confidence`].
    pub confidence: f64,
    /// [`Estimate::overlap`].
    pub overlap: f64,
    /// The winner's support and the runner-up's (`NaN` when absent).
    pub supports: (f64, f64),
    /// A listed candidate is within [`GROSS_DEG`] of the truth (modulo 180°
    /// for half-turn symmetric scenes).
    pub truth_listed: bool,
}

impl Outcome {
    /// A gross failure: error above [`GROSS_DEG`].
    pub fn failed(&self) -> bool {
        self.error_deg > GROSS_DEG
    }

    /// Flagged: any status but [`Status::Confident`] (so
    /// [`Status::LowOverlap`] counts).
    pub fn flagged(&self) -> bool {
        self.status != Status::Confident
    }

    /// The status the library would report with thresholds `t` without the
    /// verification by alignment (`Estimator::with_verification(false)`:
    /// direction first, then axis; no prior). The verified status depends on
    /// the candidates' alignments, which an `Outcome` does not keep.
    pub fn status_with(&self, t: &Thresholds) -> Status {
        if self.status == Status::NoStructure {
            Status::NoStructure
        } else if self.margin < t.direction_margin.to_num::<f64>() {
            Status::AmbiguousDirection
        } else if self.rival >= self.correlation * t.rival_ratio.to_num::<f64>() {
            Status::AmbiguousAxis
        } else {
            Status::Confident
        }
    }
}

/// Scores an estimate against the truth.
pub fn outcome(estimate: &Estimate, truth: &Transform, half_turn_symmetric: bool) -> Outcome {
    let full = angle_error_deg(estimate.alpha, truth.alpha_rad);
    let axis = axis_error_deg(estimate.alpha, truth.alpha_rad);
    // The error that counts: modulo 180° for half-turn symmetric scenes.
    let error_of = |alpha| {
        if half_turn_symmetric {
            axis_error_deg(alpha, truth.alpha_rad)
        } else {
            angle_error_deg(alpha, truth.alpha_rad)
        }
    };
    let error_deg = error_of(estimate.alpha);
    let wrong_half_turn = !half_turn_symmetric && axis <= GROSS_DEG && full > 90.0;
    let translation_error_px = estimate.translation.map(|t| {
        let dx = t.x.to_num::<f64>() - truth.tx;
        let dy = t.y.to_num::<f64>() - truth.ty;
        match t.unobservable {
            Some((ux, uy)) => {
                // Normalised here: the library's vector is only approximately
                // unit (see `unobservable_direction`).
                let (ux, uy) = unobservable_direction(ux.to_num(), uy.to_num());
                let along = dx * ux + dy * uy;
                (dx - along * ux).hypot(dy - along * uy)
            }
            None => dx.hypot(dy),
        }
    });
    Outcome {
        error_deg,
        axis_error_deg: axis,
        full_error_deg: full,
        wrong_half_turn,
        status: estimate.status,
        correlation: estimate.correlation.to_num(),
        rival: estimate.rival.to_num(),
        margin: margin(&estimate.half_turn),
        direct: estimate.half_turn.direct.to_num(),
        flipped: estimate.half_turn.flipped.to_num(),
        translation_error_px,
        translation_unobservable: estimate
            .translation
            .is_some_and(|t| t.unobservable.is_some()),
        scale_error: estimate
            .translation
            .map(|t| (t.scale.to_num::<f64>() - truth.scale).abs() / truth.scale),
        confidence: estimate.confidence.to_num(),
        overlap: estimate.overlap.to_num(),
        supports: (
            estimate
                .candidates
                .first()
                .and_then(|c| c.support)
                .map_or(f64::NAN, |s| s.to_num()),
            estimate
                .runner_up
                .and_then(|c| c.support)
                .map_or(f64::NAN, |s| s.to_num()),
        ),
        truth_listed: estimate
            .candidates
            .iter()
            .any(|c| error_of(c.alpha) <= GROSS_DEG),
    }
}

/// The unit vector along `(ux, uy)` (`(1, 0)` for a zero vector).
///
/// `Pose::unobservable` is a unit vector in Q16 (its norm is within a few
/// units of the last place of 1); the evaluations normalise it again so
/// that rounding never enters a figure.
pub fn unobservable_direction(ux: f64, uy: f64) -> (f64, f64) {
    let n = ux.hypot(uy);
    if n > 0.0 {
        (ux / n, uy / n)
    } else {
        (1.0, 0.0)
    }
}

fn margin(test: &HalfTurnTest) -> f64 {
    test.margin().to_num()
}

/// Runs `estimator` on a rendered pair and scores it.
pub fn run_pair<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const HALF: usize,
    const RHO: usize,
    const PW: usize,
>(
    estimator: &mut Estimator<W, H, RW, N, HALF, RHO, PW>,
    pair: &Pair,
    truth: &Transform,
    half_turn_symmetric: bool,
) -> Outcome {
    let g1 = grid_from_image::<W, H, RW>(&pair.i1.image);
    let g2 = grid_from_image::<W, H, RW>(&pair.i2.image);
    let estimate = estimator.estimate_pair(&g1, &g2);
    outcome(&estimate, truth, half_turn_symmetric)
}

/// Summary of a set of outcomes (one table row).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Summary {
    /// Number of trials.
    pub trials: usize,
    /// Median error, degrees (this and every percentile below:
    /// [`crate::stats::quantile`], nearest rank).
    pub median_deg: f64,
    /// 90th percentile of the error, degrees.
    pub p90_deg: f64,
    /// Share of gross failures (> 5°).
    pub failures: f64,
    /// Share of wrong half-turns (axis right, direction wrong).
    pub wrong_half_turns: f64,
    /// Share flagged (status not confident).
    pub flagged: f64,
    /// Share of failures among the unflagged results (NaN if all flagged).
    pub failures_unflagged: f64,
    /// Median translation error, pixels, over trials with the rotation right.
    pub translation_median_px: f64,
    /// 90th percentile of the translation error, pixels.
    pub translation_p90_px: f64,
    /// Median relative scale error, over trials with the rotation right.
    pub scale_median: f64,
    /// 90th percentile of the relative scale error.
    pub scale_p90: f64,
}

impl Summary {
    /// Summarises `outcomes` with the statuses they carry.
    pub fn of(outcomes: &[Outcome]) -> Self {
        Self::with_status(outcomes, |o| o.status)
    }

    /// Summarises `outcomes`, deriving each status with `status`.
    pub fn with_status(outcomes: &[Outcome], status: impl Fn(&Outcome) -> Status) -> Self {
        let n = outcomes.len().max(1) as f64;
        let errors: Vec<f64> = outcomes.iter().map(|o| o.error_deg).collect();
        let share =
            |f: &dyn Fn(&Outcome) -> bool| outcomes.iter().filter(|o| f(o)).count() as f64 / n;
        let unflagged: Vec<&Outcome> = outcomes
            .iter()
            .filter(|o| status(o) == Status::Confident)
            .collect();
        let failures_unflagged = if unflagged.is_empty() {
            f64::NAN
        } else {
            unflagged.iter().filter(|o| o.failed()).count() as f64 / unflagged.len() as f64
        };
        let translation: Vec<f64> = outcomes
            .iter()
            .filter(|o| !o.failed())
            .filter_map(|o| o.translation_error_px)
            .collect();
        let scale: Vec<f64> = outcomes
            .iter()
            .filter(|o| !o.failed())
            .filter_map(|o| o.scale_error)
            .collect();
        Self {
            trials: outcomes.len(),
            median_deg: quantile(&errors, 0.5),
            p90_deg: quantile(&errors, 0.9),
            failures: share(&|o| o.failed()),
            wrong_half_turns: share(&|o| o.wrong_half_turn),
            flagged: share(&|o| status(o) != Status::Confident),
            failures_unflagged,
            translation_median_px: quantile(&translation, 0.5),
            translation_p90_px: quantile(&translation, 0.9),
            scale_median: quantile(&scale, 0.5),
            scale_p90: quantile(&scale, 0.9),
        }
    }
}

/// Runs `job(i)` for `i ∈ [0, count)` on `threads` threads (interleaved
/// indices, so the result does not depend on the thread count) and returns
/// the results in index order.
pub fn parallel_map<T: Send>(
    count: usize,
    threads: usize,
    job: impl Fn(usize) -> T + Sync,
) -> Vec<T> {
    let threads = threads.clamp(1, count.max(1));
    let mut parts: Vec<Vec<(usize, T)>> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                let job = &job;
                s.spawn(move || {
                    (t..count)
                        .step_by(threads)
                        .map(|i| (i, job(i)))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("worker panicked"))
            .collect()
    });
    let mut out: Vec<(usize, T)> = parts.drain(..).flatten().collect();
    out.sort_by_key(|(i, _)| *i);
    out.into_iter().map(|(_, v)| v).collect()
}

/// Degrees of `steps` θ steps of an `n`-step circle.
pub fn step_deg(n_theta: usize) -> f64 {
    360.0 / n_theta as f64
}
