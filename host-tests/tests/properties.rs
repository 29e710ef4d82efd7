//! Properties of the estimator on random scenes (`host_tests::scene`), for
//! 64×64 / `N_THETA` 128, 128×128 / 360 and the non-square 96×64 / 512.
//!
//! What "rotation by exactly k θ steps" means here. A binary image can be
//! rotated *exactly* only by a map that sends pixel centres to pixel centres:
//! quarter turns of a square image and half turns of any image (the centred
//! lattice `x = col − (W−1)/2` is invariant under them). For those
//! (`scene::rotate_image`, a permutation of the occupied cells) the Q15 tables
//! give the same integer ρ for a pixel and its image in the shifted column
//! (`cos θ_{k+N/4} = −sin θ_k` entry for entry), so `D` and `S` of the turned
//! image are the shifted signatures — except that a vote whose ρ is exactly a
//! half-integer rounds up in both, so it moves one bin in the mirrored half
//! (`A(θ + π, ρ)` is the mirror of `A(θ, ρ)` and would need round-half-down).
//! Result: the paper mode returns exactly `k` steps and the improved mode
//! returns `k` steps up to 0.05 step of sub-step interpolation. Any other
//! angle can only rotate the *scene*: `render_pair` rotates the sample points
//! of the segments exactly by `2πk/N` before rasterizing, and the estimate is
//! then within the resolution `Δθ + atan(1/r)` (`r` the scene radius in
//! pixels, see `reference_agreement.rs`).

mod common;

use host_tests::eval::{
    angle_error_deg, axis_error_deg, grid_from_image, trial_pair, unobservable_direction,
    wall_to_wall_corridor, GROSS_DEG,
};
use host_tests::reference::Image;
use host_tests::scene::{render_pair, rotate_image, Damage, SceneKind, Transform};
use hough_heading::{
    config::rho_bins, config::row_words, stages::Accumulator, stages::Correlation,
    stages::PeakKind, stages::Signature, Angle, Error, Estimate, Estimator, Grid, HalfTurn, Mode,
    Prior, Reference, ScaleRange, Score, Status,
};
use proptest::prelude::*;
use proptest::test_runner::{TestCaseError, TestRunner};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::cell::Cell;
use std::f64::consts::TAU;

/// Proptest settings of this file (see `common::proptest_config`).
fn config() -> ProptestConfig {
    common::proptest_config(0x5052_4f50)
}

/// What a check that may pass over its case did with it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Case {
    /// The property was asserted on this case.
    Checked,
    /// The answer left nothing to assert (e.g. not `Confident`): skipped.
    Skipped,
}

/// Runs `check` over `strategy` with this file's proptest settings, as
/// `proptest!` does (a failure panics with the minimal failing input), and
/// counts the cases it skipped: a check that skipped every case would pass
/// without testing anything. Prints the counts (`--nocapture`) and asserts
/// that at most `max_skipped` of the cases were skipped and at least one
/// was checked.
fn run_counted<S: Strategy>(
    name: &str,
    strategy: S,
    max_skipped: f64,
    check: impl Fn(S::Value) -> Result<Case, TestCaseError>,
) {
    let (checked, skipped) = (Cell::new(0usize), Cell::new(0usize));
    let mut runner = TestRunner::new(config());
    let result = runner.run(&strategy, |value| {
        let counter = match check(value)? {
            Case::Checked => &checked,
            Case::Skipped => &skipped,
        };
        counter.set(counter.get() + 1);
        Ok(())
    });
    if let Err(e) = result {
        panic!("{name}: {e}");
    }
    common::assert_skipped_share(name, checked.get(), skipped.get(), max_skipped, "");
}

fn damage() -> impl Strategy<Value = Damage> {
    prop::sample::select(vec![Damage::CLEAN, Damage::MODERATE, Damage::HARSH])
}

fn asymmetric_kind() -> impl Strategy<Value = SceneKind> {
    prop::sample::select(vec![SceneKind::RandomPolygon, SceneKind::ManhattanRoom])
}

fn degrees(a: Angle) -> f64 {
    f64::from(a.0) * 360.0 / 4_294_967_296.0
}

/// Circular distance of two library angles, degrees.
fn distance_deg(a: Angle, b: Angle) -> f64 {
    degrees(a.distance(b))
}

/// `k` steps of an `N`-step circle as a library angle, built in plain `f64`
/// (not with the library's `Angle::from_steps_q16`, issue 14 item 4).
fn steps(k: usize, n: usize) -> Angle {
    let turns = (k % n) as f64 / n as f64;
    Angle(((turns * 4_294_967_296.0).round() as u64 % (1u64 << 32)) as u32)
}

/// The resolution bound of `reference_agreement.rs`: one θ step plus the
/// angle one pixel subtends at the scene's radius, degrees.
fn resolution_deg(n: usize, radius_px: f64) -> f64 {
    360.0 / n as f64 + (1.0 / radius_px).atan().to_degrees()
}

/// Quarter turns (square grids) and half turns (any grid) of the pixels are
/// recovered exactly (paper) or to 0.05 step (improved).
fn check_exact_turns<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const HALF: usize,
    const RHO: usize,
    const PW: usize,
>(
    kind: SceneKind,
    damage: &Damage,
    seed: u64,
) -> Result<(), TestCaseError> {
    let (_, pair) = trial_pair(kind, damage, W, H, true, seed);
    let image = &pair.i1.image;
    let g1 = grid_from_image::<W, H, RW>(image);
    let quarters: &[usize] = if W == H && N.is_multiple_of(4) {
        &[0, 1, 2, 3]
    } else {
        &[0, 2]
    };
    let step = 360.0 / N as f64;
    for &q in quarters {
        let k = q * N / 4;
        let g2 = grid_from_image::<W, H, RW>(&rotate_image(image, k, N));
        let truth = steps(k, N);
        let paper =
            Estimator::<W, H, RW, N, HALF, RHO, PW>::new(Mode::Paper).estimate_pair(&g1, &g2);
        let improved =
            Estimator::<W, H, RW, N, HALF, RHO, PW>::new(Mode::Improved).estimate_pair(&g1, &g2);
        // A rotation of the same pixels correlates perfectly at the true shift
        // (up to the half-integer votes of the mirrored half).
        prop_assert!(
            paper.correlation > Score::from_num(0.99),
            "{}",
            paper.correlation
        );
        for (mode, e, tolerance) in [("paper", &paper, 0.0), ("improved", &improved, 0.05 * step)] {
            // `LowOverlap` takes precedence over (and may hide) the
            // direction ambiguity.
            if matches!(e.status, Status::AmbiguousDirection | Status::LowOverlap) {
                let axis = distance_deg(e.alpha, truth)
                    .min(distance_deg(e.alpha, truth + Angle::HALF_TURN));
                prop_assert!(axis <= tolerance, "{mode} k = {k}: axis off by {axis}°");
            } else {
                let error = distance_deg(e.alpha, truth);
                prop_assert!(
                    error <= tolerance,
                    "{mode} k = {k}: {}° instead of {}°, status {:?}",
                    degrees(e.alpha),
                    degrees(truth),
                    e.status
                );
            }
        }
    }
    Ok(())
}

/// Scenes whose sample points are rotated by exactly `k` steps (then
/// rasterized): within the resolution bound; `Confident` results right over
/// the full circle. The others are skipped (see [`MAX_SKIPPED_POINT_ROTATION`]).
fn check_point_rotation<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const HALF: usize,
    const RHO: usize,
    const PW: usize,
>(
    k: usize,
    seed: u64,
) -> Result<Case, TestCaseError> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let scene = SceneKind::RandomPolygon.generate(&mut rng);
    let alpha = TAU * k as f64 / N as f64;
    let pair = render_pair(
        &scene,
        &Transform::rotation(alpha),
        &Damage::CLEAN,
        W,
        H,
        seed,
    );
    let g1 = grid_from_image::<W, H, RW>(&pair.i1.image);
    let g2 = grid_from_image::<W, H, RW>(&pair.i2.image);
    let e = Estimator::<W, H, RW, N, HALF, RHO, PW>::new(Mode::Improved).estimate_pair(&g1, &g2);
    if e.status != Status::Confident {
        return Ok(Case::Skipped);
    }
    let bound = resolution_deg(N, pair.fit_radius_px);
    let error = angle_error_deg(e.alpha, alpha);
    prop_assert!(error <= bound, "k = {k}: error {error}° > {bound}°");
    Ok(Case::Checked)
}

/// Largest share of [`check_point_rotation`]'s cases skipped (not
/// `Confident`). Measured on 2026-12-02 with the default 24 cases: 2 / 1 / 1
/// skipped (64² / 128² / 96×64, at most 8.3 %); with `HH_CASES=1000` and
/// `HH_SEED` 1 and 2: 12–20 / 4–5 / 12–14 of 1000 (at most 2.0 %). The
/// bound, 25 % (6 of 24), holds with margin for any seed (at a true 2 %,
/// 7 skips of 24 has a chance below 10⁻⁶).
const MAX_SKIPPED_POINT_ROTATION: f64 = 0.25;

/// `Signature::stream` equals the signature of the full accumulator bit for
/// bit, and the estimate follows the full-matrix path exactly.
fn check_streaming<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const HALF: usize,
    const RHO: usize,
    const PW: usize,
>(
    kind: SceneKind,
    damage: &Damage,
    seed: u64,
) -> Result<(), TestCaseError> {
    let (_, pair) = trial_pair(kind, damage, W, H, true, seed);
    let g1 = grid_from_image::<W, H, RW>(&pair.i1.image);
    let g2 = grid_from_image::<W, H, RW>(&pair.i2.image);
    let acc1 = Box::new(Accumulator::<HALF, RHO>::vote::<W, H, RW, N>(&g1));
    let acc2 = Box::new(Accumulator::<HALF, RHO>::vote::<W, H, RW, N>(&g2));
    let mut columns = [[0u16; RHO]; 2];
    // The full accumulator's second half is the exact mirror of the first.
    for k in (0..HALF).step_by(7) {
        for b in 1..RHO {
            prop_assert_eq!(acc1.get(k + HALF, b), acc1.get(k, RHO - b));
        }
    }
    for mode in [Mode::Paper, Mode::Improved] {
        let kind = mode.peak_kind();
        let s1 = Signature::<HALF>::stream::<W, H, RW, N, RHO>(&g1, kind, &mut columns);
        let s2 = Signature::<HALF>::stream::<W, H, RW, N, RHO>(&g2, kind, &mut columns);
        let f1 = Signature::from_accumulator(&acc1, kind);
        let f2 = Signature::from_accumulator(&acc2, kind);
        prop_assert_eq!(&s1, &f1);
        prop_assert_eq!(&s2, &f2);
        // D(θ + π) = D(θ) and S(θ + π) = −S(θ) over the full circle, and D is
        // the column maximum of the full matrix.
        for k in 0..HALF {
            prop_assert_eq!(f1.peak(k + HALF), f1.peak(k));
            prop_assert_eq!(f1.asymmetry(k + HALF), -f1.asymmetry(k));
            if kind == PeakKind::SingleBin {
                let max = (0..RHO).map(|b| acc1.get(k + HALF, b)).max().unwrap_or(0);
                prop_assert_eq!(max, f1.peak(k));
            }
        }
        // The estimate, through the streaming path, against the correlation
        // of the full-matrix signatures (without the verification by
        // alignment, which then moves α by its own search; it reports the
        // same correlation and direction test).
        let e = Estimator::<W, H, RW, N, HALF, RHO, PW>::new(mode)
            .with_verification(false)
            .estimate_pair(&g1, &g2);
        let v = Estimator::<W, H, RW, N, HALF, RHO, PW>::new(mode).estimate_pair(&g1, &g2);
        if e.status != Status::NoStructure && v.status != Status::NoStructure {
            prop_assert_eq!(v.correlation, e.correlation);
            prop_assert_eq!(v.half_turn, e.half_turn);
        }
        let correlation = Correlation::of(f1.peaks(), f2.peaks());
        match correlation.best() {
            None => prop_assert_eq!(e.status, Status::NoStructure),
            Some(best) if e.status != Status::NoStructure => {
                prop_assert_eq!(e.correlation, correlation.score(best));
                let offset = if mode == Mode::Paper {
                    0
                } else {
                    best.offset_q16()
                };
                let alpha = Angle::from_steps_q16(((best.shift as i64) << 16) + offset, N);
                let expected = match e.half_turn.chosen {
                    HalfTurn::Direct => alpha,
                    HalfTurn::Flipped => alpha + Angle::HALF_TURN,
                };
                prop_assert_eq!(e.alpha, expected);
            }
            Some(_) => {}
        }
    }
    Ok(())
}

/// Turning the second image by a half turn (a permutation of its pixels)
/// turns the answer by a half turn. Votes at exact half-integer ρ round to
/// the other side in the turned image, so `D` can change by a vote in a few
/// columns; that moves the axis by at most one θ step (measured: ≤ 0.07 step
/// in most cases, 0.5 step at most over 8 × 400 cases per configuration) —
/// unless the correlation has a *split peak*, two local maxima closer than
/// the rival separation (`N/72` steps) and within 0.001 of each other, which
/// one vote can swap (seen once in 3200 harsh 96×64 cases: 1.4 steps). The
/// half turn itself must flip unless either estimate reports
/// `AmbiguousDirection` (or `LowOverlap`, which may hide it).
///
/// These bounds hold for the paper mode and for the improved mode without
/// the verification by alignment. The verification is not exactly
/// equivariant: it scores the second view's cells taken evenly in raster
/// order, and a half turn reverses that order, so the two estimates score
/// different subsets of the same cells (and the ICP refines from different
/// seeds). It is checked separately on clean and moderate damage, with the
/// scale search on (these scenes have a scale of 0.9–1.1, which the
/// verification must be told about): when both estimates are `Confident`,
/// the half turn flips and the two answers agree within
/// `max(3 steps, 5°)` (no gross disagreement). Measured (600 clean and
/// moderate scenes per configuration): at most 2.1 steps (5.9°) at
/// 64² / 128, 1.0° at 128² / 360, 3.6° at 96×64 / 512.
fn check_half_turned_input<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const HALF: usize,
    const RHO: usize,
    const PW: usize,
>(
    kind: SceneKind,
    damage: &Damage,
    seed: u64,
) -> Result<(), TestCaseError> {
    let (_, pair) = trial_pair(kind, damage, W, H, true, seed);
    let g1 = grid_from_image::<W, H, RW>(&pair.i1.image);
    let g2 = grid_from_image::<W, H, RW>(&pair.i2.image);
    let turned = grid_from_image::<W, H, RW>(&rotate_image(&pair.i2.image, N / 2, N));
    let step = 360.0 / N as f64;
    let separation = (N / 72).max(2);
    for mode in [Mode::Paper, Mode::Improved] {
        let mut e = Estimator::<W, H, RW, N, HALF, RHO, PW>::new(mode).with_verification(false);
        let a = e.estimate_pair(&g1, &g2);
        let b = e.estimate_pair(&g1, &turned);
        if a.status == Status::NoStructure {
            prop_assert_eq!(b.status, Status::NoStructure);
            continue;
        }
        let mut columns = [[0u16; RHO]; 2];
        let s1 = Signature::<HALF>::stream::<W, H, RW, N, RHO>(&g1, mode.peak_kind(), &mut columns);
        let s2 = Signature::<HALF>::stream::<W, H, RW, N, RHO>(&g2, mode.peak_kind(), &mut columns);
        let correlation = Correlation::of(s1.peaks(), s2.peaks());
        let split = correlation.peaks.iter().skip(1).any(|p| {
            let best = correlation.peaks[0];
            let d = p.shift.abs_diff(best.shift);
            d.min(HALF - d) < separation
                && (correlation.score(&best) - correlation.score(p)) < Score::from_num(0.001)
        });
        let tolerance = if split {
            separation as f64 * step
        } else {
            step
        };
        let expected = a.alpha + Angle::HALF_TURN;
        let axis = distance_deg(b.alpha, expected).min(distance_deg(b.alpha, a.alpha));
        prop_assert!(
            axis <= tolerance,
            "{mode:?}: axis moved by {axis}° (split peak: {split})"
        );
        let hidden = |s: Status| matches!(s, Status::AmbiguousDirection | Status::LowOverlap);
        if !hidden(a.status) && !hidden(b.status) {
            let error = distance_deg(b.alpha, expected);
            prop_assert!(
                error <= tolerance,
                "{mode:?}: {}° then {}° for the half-turned image",
                degrees(a.alpha),
                degrees(b.alpha)
            );
        }
    }
    // The verified estimate (see above).
    if *damage != Damage::HARSH {
        let mut e = Estimator::<W, H, RW, N, HALF, RHO, PW>::new(Mode::Improved)
            .with_scale_search(ScaleRange::DEFAULT);
        let a = e.estimate_pair(&g1, &g2);
        let b = e.estimate_pair(&g1, &turned);
        if a.status == Status::Confident && b.status == Status::Confident {
            let expected = a.alpha + Angle::HALF_TURN;
            let error = distance_deg(b.alpha, expected);
            prop_assert!(
                error <= (3.0 * step).max(GROSS_DEG),
                "verified: {}° then {}° for the half-turned image",
                degrees(a.alpha),
                degrees(b.alpha)
            );
        }
    }
    Ok(())
}

/// Clean centrally symmetric scenes (corridors, rectangles, parallelograms,
/// symmetric polygons and rooms) are flagged `AmbiguousDirection`, with both
/// members of the pair among the candidates; a prior then picks the right
/// one. With the verification (see the comments) the status may also be
/// `AmbiguousAxis`, and the members are within the rival separation of each
/// other's half turn.
fn check_symmetric<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const HALF: usize,
    const RHO: usize,
    const PW: usize,
>(
    kind: SceneKind,
    seed: u64,
) -> Result<(), TestCaseError> {
    let (truth, pair) = trial_pair(kind, &Damage::CLEAN, W, H, true, seed);
    let g1 = grid_from_image::<W, H, RW>(&pair.i1.image);
    let g2 = grid_from_image::<W, H, RW>(&pair.i2.image);
    // Without the verification: exactly a half turn apart.
    let mut estimator =
        Estimator::<W, H, RW, N, HALF, RHO, PW>::new(Mode::Improved).with_verification(false);
    let reference = estimator.reference(&g1);
    let e = estimator.estimate(&reference, &g2);
    prop_assert_eq!(e.status, Status::AmbiguousDirection, "{:?}", e.half_turn);
    let has = |e: &Estimate, a: Angle, tolerance: f64| {
        e.candidates
            .iter()
            .any(|c| distance_deg(c.alpha, a) <= tolerance)
    };
    prop_assert!(
        has(&e, e.alpha, 1e-6) && has(&e, e.alpha + Angle::HALF_TURN, 1e-6),
        "{:?}",
        e.candidates
    );
    // A prior 3° off the truth (σ = 10°) picks the right member.
    let prior = Prior {
        alpha: Angle::from_degrees((truth.alpha_rad.to_degrees() + 3.0) as f32),
        sigma: Angle::from_degrees(10.0),
    };
    let axis = axis_error_deg(e.alpha, truth.alpha_rad);
    if axis <= 2.0 {
        let p = estimator.estimate_with_prior(&reference, &g2, Some(prior));
        let error = angle_error_deg(p.alpha, truth.alpha_rad);
        prop_assert!(error <= 5.0, "prior picked {}°", degrees(p.alpha));
    }
    // Verified (with the scale search: these scenes have a scale of
    // 0.9–1.1, and the verification aligns cells at the scale it is given).
    // Both members are verified on their own: the winner's α is refined by
    // the ICP, the other member's is its seed's moved by the angle search in
    // whole θ steps, so they are not exactly a half turn apart (measured over
    // 100 scenes per configuration: up to 2.9° at 64² / 128, 1.3° at 128² /
    // 360, 1.7° at 96×64 / 512); asked: within the rival separation (5°,
    // at least 2 steps), below which the library itself treats two
    // rotations as one. The α + π member aligns as well in the scene but,
    // rasterized, a few cells apart; a near-square room may then find its
    // quarter turn the strongest rival: `AmbiguousAxis` is as honest,
    // `Confident` is not.
    let mut estimator = Estimator::<W, H, RW, N, HALF, RHO, PW>::new(Mode::Improved)
        .with_scale_search(ScaleRange::DEFAULT);
    let reference = estimator.reference(&g1);
    let v = estimator.estimate(&reference, &g2);
    prop_assert!(
        matches!(v.status, Status::AmbiguousDirection | Status::AmbiguousAxis),
        "{:?}",
        v
    );
    let separation = (N / 72).max(2) as f64 * 360.0 / N as f64;
    prop_assert!(
        has(&v, v.alpha, 0.0) && has(&v, v.alpha + Angle::HALF_TURN, separation),
        "{:?}",
        v.candidates
    );
    if axis_error_deg(v.alpha, truth.alpha_rad) <= 2.0 {
        let p = estimator.estimate_with_prior(&reference, &g2, Some(prior));
        let error = angle_error_deg(p.alpha, truth.alpha_rad);
        prop_assert!(error <= 5.0, "verified: prior picked {}°", degrees(p.alpha));
    }
    Ok(())
}

/// `Reference::to_bytes` / `from_bytes` round-trips; any single corrupted
/// byte, a short buffer or another configuration is refused.
fn check_reference_bytes<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const HALF: usize,
    const RHO: usize,
    const PW: usize,
>(
    kind: SceneKind,
    damage: &Damage,
    seed: u64,
    corrupt_at: prop::sample::Index,
    corrupt_with: u8,
) -> Result<(), TestCaseError> {
    let (_, pair) = trial_pair(kind, damage, W, H, true, seed);
    let g1 = grid_from_image::<W, H, RW>(&pair.i1.image);
    let g2 = grid_from_image::<W, H, RW>(&pair.i2.image);
    for mode in [Mode::Paper, Mode::Improved] {
        let mut e = Estimator::<W, H, RW, N, HALF, RHO, PW>::new(mode);
        let reference = e.reference(&g1);
        let mut bytes = vec![0u8; Reference::<W, H, RW, HALF, RHO>::BYTES + 3];
        let len = reference.to_bytes(&mut bytes).expect("large enough");
        prop_assert_eq!(len, Reference::<W, H, RW, HALF, RHO>::BYTES);
        let back = Reference::<W, H, RW, HALF, RHO>::from_bytes(&bytes[..len]).expect("round trip");
        prop_assert_eq!(&back, &reference);
        prop_assert_eq!(e.estimate(&back, &g2), e.estimate(&reference, &g2));
        // One corrupted byte (xor with a non-zero value) anywhere.
        let mut bad = bytes[..len].to_vec();
        bad[corrupt_at.index(len)] ^= corrupt_with;
        prop_assert_eq!(
            Reference::<W, H, RW, HALF, RHO>::from_bytes(&bad),
            Err(Error::InvalidReference)
        );
        // Too short, for writing and reading.
        prop_assert_eq!(
            reference.to_bytes(&mut bytes[..len - 1]),
            Err(Error::BufferTooSmall { needed: len })
        );
        prop_assert_eq!(
            Reference::<W, H, RW, HALF, RHO>::from_bytes(&bytes[..len - 1]),
            Err(Error::BufferTooSmall { needed: len })
        );
        // Another configuration's reference: refused whatever its length.
        type Other = Reference<90, 90, 3, 100, 1024>;
        let other = Other::from_bytes(&bytes[..len]);
        prop_assert!(
            matches!(
                other,
                Err(Error::InvalidReference | Error::BufferTooSmall { .. })
            ),
            "{other:?}"
        );
    }
    Ok(())
}

/// Known translations (whole and fractional pixels: multiples of ¼ px up to
/// ±6 px) and scales, recovered within bounds when the rotation is right,
/// restricted to the observable component when the library reports an
/// unobservable direction.
///
/// Scale 1 (no scale search): within 1.25 px on clean scenes and 2 px with
/// moderate damage. Measured over 4000 random polygons per configuration:
/// median 0.11–0.15 px clean, 0.13–0.21 px moderate; 99th percentile ≤
/// 0.62 / 0.67 px; maximum 0.97 / 1.53 px (64×64 / 128 is the coarsest).
///
/// Scale uniform in 0.9–1.1 (scale search over [`ScaleRange::DEFAULT`]): `t`
/// within [`SCALED_T_PX`] and `s` within [`SCALE_BOUND`] (relative).
///
/// A case whose rotation is wrong (more than 5° off) is skipped: its pose
/// means nothing (see [`MAX_SKIPPED_POSE`]).
fn check_pose<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const HALF: usize,
    const RHO: usize,
    const PW: usize,
>(
    damage: &Damage,
    quarters: (i32, i32),
    scale: Option<f64>,
    seed: u64,
) -> Result<Case, TestCaseError> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let scene = SceneKind::RandomPolygon.generate(&mut rng);
    let truth = Transform {
        alpha_rad: rng.gen_range(0.0..TAU),
        tx: f64::from(quarters.0) / 4.0,
        ty: f64::from(quarters.1) / 4.0,
        scale: scale.unwrap_or(1.0),
    };
    let pair = render_pair(&scene, &truth, damage, W, H, seed);
    let g1 = grid_from_image::<W, H, RW>(&pair.i1.image);
    let g2 = grid_from_image::<W, H, RW>(&pair.i2.image);
    let mut estimator = Estimator::<W, H, RW, N, HALF, RHO, PW>::new(Mode::Improved);
    if scale.is_some() {
        estimator = estimator.with_scale_search(ScaleRange::DEFAULT);
    }
    let e = estimator.estimate_pair(&g1, &g2);
    if angle_error_deg(e.alpha, truth.alpha_rad) > 5.0 {
        // Wrong rotation (rare, see ACCURACY.md): the pose is meaningless.
        return Ok(Case::Skipped);
    }
    let t = e
        .translation
        .expect("a translation with the rotation resolved");
    let (mut dx, mut dy) = (
        t.x.to_num::<f64>() - truth.tx,
        t.y.to_num::<f64>() - truth.ty,
    );
    if let Some((ux, uy)) = t.unobservable {
        // Only the component across the reported direction is claimed (this
        // happens for ~1 % of polygons, whose strongest profile columns are
        // nearly parallel).
        let (ux, uy) = unobservable_direction(ux.to_num(), uy.to_num());
        let along = dx * ux + dy * uy;
        (dx, dy) = (dx - along * ux, dy - along * uy);
    }
    let clean = *damage == Damage::CLEAN;
    let bound = match (scale.is_some(), clean) {
        (false, true) => 1.25,
        (false, false) => 2.0,
        (true, true) => SCALED_T_PX.0,
        (true, false) => SCALED_T_PX.1,
    };
    let scale_error = (t.scale.to_num::<f64>() - truth.scale).abs() / truth.scale;
    let scale_bound = match (scale.is_some(), clean) {
        (false, _) => 0.0,
        (true, true) => SCALE_BOUND.0,
        (true, false) => SCALE_BOUND.1,
    };
    prop_assert!(
        dx.hypot(dy) <= bound && scale_error <= scale_bound,
        "t = ({}, {}), s = {} for ({}, {}), s = {}, unobservable {:?}",
        t.x,
        t.y,
        t.scale,
        truth.tx,
        truth.ty,
        truth.scale,
        t.unobservable
    );
    Ok(Case::Checked)
}

/// Largest share of [`check_pose`]'s cases skipped (wrong rotation), with
/// and without the scale search. Measured on 2026-12-02 with the default 24
/// cases: at most 1 skipped (96×64 with the scale search, 4.2 %; none
/// elsewhere); with `HH_CASES=1000` and `HH_SEED` 1 and 2: 0–5 of 1000 (at
/// most 0.5 %). The bound, 15 % (3 of 24), holds with margin for any seed
/// (at a true 0.5 %, 4 skips of 24 has a chance below 10⁻⁵).
const MAX_SKIPPED_POSE: f64 = 0.15;

/// Bound on the translation error with the scale searched (clean, moderate),
/// pixels. Measured with `HH_CASES=1000` (about 500 cases per damage and
/// configuration): median 0.10–0.12 px clean, 0.12–0.17 px moderate; 99th
/// percentile ≤ 0.56 / 0.61 px; maximum 0.83 px clean, 0.91 px moderate but
/// for one 96×64 case at 2.44 px (its scale was 15 % off, below).
const SCALED_T_PX: (f64, f64) = (1.25, 3.0);
/// Bound on the relative scale error with the scale searched (clean,
/// moderate). Measured as above: median 0.2 % (128²), 0.5–0.7 % (64×64,
/// 96×64: the error grows as the scene shrinks, about one pixel over the
/// scene's radius); 99th percentile 1.2 % / 3.6 %; maximum 1.8 % (128²),
/// 5.4 % (64²), and one 96×64 moderate case at 15 % whose columns agreed on
/// one translation at the wrong scale (residual 0.03 px: no flag sees it).
const SCALE_BOUND: (f64, f64) = (0.06, 0.16);

/// No grid content makes the estimator panic; the status is sensible.
fn check_any_grid<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const HALF: usize,
    const RHO: usize,
    const PW: usize,
>(
    density1: f64,
    density2: f64,
    seed: u64,
    prior: Option<(f32, f32)>,
) -> Result<(), TestCaseError> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut noise = |density: f64| {
        let mut g = Grid::<W, H, RW>::new();
        for row in 0..H {
            for col in 0..W {
                if rng.gen_bool(density) {
                    g.set(col, row).expect("inside");
                }
            }
        }
        g
    };
    let (g1, g2) = (noise(density1), noise(density2));
    for mode in [Mode::Paper, Mode::Improved] {
        let mut e = Estimator::<W, H, RW, N, HALF, RHO, PW>::new(mode);
        let reference = e.reference(&g1);
        let prior = prior.map(|(a, s)| Prior {
            alpha: Angle::from_degrees(a),
            sigma: Angle::from_degrees(s),
        });
        let r: Estimate = e.estimate_with_prior(&reference, &g2, prior);
        prop_assert!(r.confidence >= Score::ZERO && r.confidence <= Score::ONE);
        if g1.occupied() < 8 || g2.occupied() < 8 {
            prop_assert_eq!(r.status, Status::NoStructure);
        }
        if r.status == Status::NoStructure {
            prop_assert!(r.candidates.is_empty() && r.translation.is_none());
        } else {
            prop_assert!(!r.candidates.is_empty());
        }
    }
    Ok(())
}

macro_rules! configuration {
    ($name:ident, $w:literal, $h:literal, $n:literal) => {
        mod $name {
            use super::*;
            const HALF: usize = $n / 2;
            const RW: usize = row_words($w);
            const RHO: usize = rho_bins($w, $h);
            const PW: usize = hough_heading::config::pyramid_words($w, $h);

            proptest! {
                #![proptest_config(config())]

                #[test]
                fn exact_turns_are_recovered_exactly(
                    kind in asymmetric_kind(), damage in damage(), seed in any::<u64>(),
                ) {
                    check_exact_turns::<$w, $h, RW, $n, HALF, RHO, PW>(kind, &damage, seed)?;
                }

                #[test]
                fn streaming_equals_full_accumulator(
                    kind in prop::sample::select(SceneKind::ALL.to_vec()),
                    damage in damage(),
                    seed in any::<u64>(),
                ) {
                    check_streaming::<$w, $h, RW, $n, HALF, RHO, PW>(kind, &damage, seed)?;
                }

                #[test]
                fn half_turned_input_gives_half_turned_answer(
                    kind in asymmetric_kind(), damage in damage(), seed in any::<u64>(),
                ) {
                    check_half_turned_input::<$w, $h, RW, $n, HALF, RHO, PW>(kind, &damage, seed)?;
                }

                #[test]
                fn centrally_symmetric_scenes_are_ambiguous_direction(
                    kind in prop::sample::select(vec![
                        SceneKind::Corridor,
                        SceneKind::CentrallySymmetric,
                    ]),
                    seed in any::<u64>(),
                ) {
                    check_symmetric::<$w, $h, RW, $n, HALF, RHO, PW>(kind, seed)?;
                }

                #[test]
                fn reference_bytes_round_trip_and_reject_corruption(
                    kind in prop::sample::select(SceneKind::ALL.to_vec()),
                    damage in damage(),
                    seed in any::<u64>(),
                    corrupt_at in any::<prop::sample::Index>(),
                    corrupt_with in 1u8..=255,
                ) {
                    check_reference_bytes::<$w, $h, RW, $n, HALF, RHO, PW>(
                        kind, &damage, seed, corrupt_at, corrupt_with,
                    )?;
                }

                #[test]
                fn no_panic_on_any_grid(
                    d1 in prop::sample::select(vec![0.0, 0.001, 0.01, 0.1, 0.5, 0.9, 1.0]),
                    d2 in prop::sample::select(vec![0.0, 0.001, 0.01, 0.1, 0.5, 0.9, 1.0]),
                    seed in any::<u64>(),
                    prior in prop::option::of((-720.0f32..720.0, 0.0f32..200.0)),
                ) {
                    check_any_grid::<$w, $h, RW, $n, HALF, RHO, PW>(d1, d2, seed, prior)?;
                }
            }

            // The checks that skip some cases, run with their skips counted.

            #[test]
            fn point_sets_rotated_by_k_steps_within_resolution() {
                run_counted(
                    concat!(
                        stringify!($name),
                        "::point_sets_rotated_by_k_steps_within_resolution"
                    ),
                    (0usize..$n, any::<u64>()),
                    MAX_SKIPPED_POINT_ROTATION,
                    |(k, seed)| check_point_rotation::<$w, $h, RW, $n, HALF, RHO, PW>(k, seed),
                );
            }

            #[test]
            fn known_translations_are_recovered() {
                run_counted(
                    concat!(stringify!($name), "::known_translations_are_recovered"),
                    (
                        prop::sample::select(vec![Damage::CLEAN, Damage::MODERATE]),
                        (-24i32..=24, -24i32..=24),
                        any::<u64>(),
                    ),
                    MAX_SKIPPED_POSE,
                    |(damage, quarters, seed)| {
                        check_pose::<$w, $h, RW, $n, HALF, RHO, PW>(&damage, quarters, None, seed)
                    },
                );
            }

            #[test]
            fn known_scales_and_translations_are_recovered() {
                run_counted(
                    concat!(
                        stringify!($name),
                        "::known_scales_and_translations_are_recovered"
                    ),
                    (
                        prop::sample::select(vec![Damage::CLEAN, Damage::MODERATE]),
                        (-24i32..=24, -24i32..=24),
                        0.9f64..=1.1,
                        any::<u64>(),
                    ),
                    MAX_SKIPPED_POSE,
                    |(damage, quarters, scale, seed)| {
                        check_pose::<$w, $h, RW, $n, HALF, RHO, PW>(
                            &damage,
                            quarters,
                            Some(scale),
                            seed,
                        )
                    },
                );
            }
        }
    };
}

configuration!(c64x64_n128, 64, 64, 128);
configuration!(c128x128_n360, 128, 128, 360);
configuration!(c96x64_n512, 96, 64, 512);

/// Estimates for corridors whose walls cross the whole image (no ends, no
/// doors, `eval::wall_to_wall_corridor`), 128², clean, random rotation and
/// translation, scale 1.
fn wall_to_wall_corridors() -> Vec<(Transform, Estimate)> {
    type E = hough_heading::estimator!(128, 128, 360);
    type G = hough_heading::grid!(128, 128);
    (0..24u64)
        .map(|seed| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let scene = wall_to_wall_corridor(&mut rng);
            let truth = Transform {
                alpha_rad: rng.gen_range(0.0..TAU),
                tx: rng.gen_range(-5.0..5.0),
                ty: rng.gen_range(-5.0..5.0),
                scale: 1.0,
            };
            let pair = render_pair(&scene, &truth, &Damage::CLEAN, 128, 128, seed);
            let g1: G = grid_from_image(&pair.i1.image);
            let g2: G = grid_from_image(&pair.i2.image);
            (truth, E::new(Mode::Improved).estimate_pair(&g1, &g2))
        })
        .collect()
}

/// A corridor whose walls cross the whole image: the shift along the walls is
/// not observable, and the estimate says so (`AmbiguousDirection` too: the
/// corridor is its own half turn); the translation across the walls is right
/// within 1 px.
#[test]
fn corridor_reports_an_unobservable_direction() {
    for (seed, (truth, e)) in wall_to_wall_corridors().into_iter().enumerate() {
        assert_eq!(e.status, Status::AmbiguousDirection, "seed {seed}");
        let t = e.translation.expect("a translation");
        assert!(t.unobservable.is_some(), "seed {seed}: {t:?}");
        let (s, c) = truth.alpha_rad.sin_cos();
        let (dx, dy) = (
            t.x.to_num::<f64>() - truth.tx,
            t.y.to_num::<f64>() - truth.ty,
        );
        let across = (dx * -s + dy * c).abs();
        assert!(across <= 1.0, "seed {seed}: {across} px across the walls");
    }
}

/// The reported direction is a unit vector along the walls (within 1°: the
/// normal of the strongest column is quantized to the θ step). With
/// `micromath`'s bare `sqrt` (about 5 % error) this failed: norms of
/// 0.97–0.99 and directions up to 53° off; `translation.rs` now computes it
/// in integers (an exact integer square root).
#[test]
fn corridor_unobservable_direction_is_a_unit_vector_along_the_walls() {
    for (seed, (truth, e)) in wall_to_wall_corridors().into_iter().enumerate() {
        let (ux, uy) = e
            .translation
            .and_then(|t| t.unobservable)
            .expect("unobservable direction reported");
        let (ux, uy) = (ux.to_num::<f64>(), uy.to_num::<f64>());
        let norm = ux.hypot(uy);
        assert!((norm - 1.0).abs() < 1e-3, "seed {seed}: |u| = {norm}");
        let (s, c) = truth.alpha_rad.sin_cos();
        let off = ((ux * c + uy * s) / norm)
            .abs()
            .min(1.0)
            .acos()
            .to_degrees();
        assert!(off <= 1.0, "seed {seed}: {off:.2}° off the walls");
    }
}

/// The image helpers the properties rely on.
#[test]
fn rotate_image_quarter_turn_is_a_permutation() {
    let image = Image::from_cells(8, 8, &[(0, 0), (7, 0), (3, 5)]);
    let turned = rotate_image(&image, 90, 360);
    // (x, y) → (−y, x): the top-left cell goes to the bottom-left.
    assert!(turned.get(0, 7) && turned.get(0, 0) && turned.count() == 3);
}

/// Scales far from 1 (0.7–0.8 and 1.2–1.3, the range DESIGN.md §3 calls the
/// signature robust to), searched over 0.7–1.3: the rotation, its half turn
/// and the scale stay right. 60 random polygons per band, 128², moderate
/// damage, translation within ±4 px. Measured over 300 per band: no rotation
/// failure, no wrong half turn, scale error median 0.22–0.25 % / p90 0.60–
/// 0.65 %, translation median 0.09–0.12 px / p90 0.18–0.24 px. Asserted:
/// every rotation within 5°, scale within 2 % and translation within 1 px
/// for all, median scale error ≤ 0.5 %.
#[test]
fn scales_far_from_one_are_recovered() {
    type E = hough_heading::estimator!(128, 128, 360);
    type G = hough_heading::grid!(128, 128);
    let range = ScaleRange::new(Score::from_num(0.7), Score::from_num(1.3)).expect("valid");
    for (low, high) in [(0.7, 0.8), (1.2, 1.3)] {
        let mut scale_errors = Vec::new();
        for seed in 0..60u64 {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let scene = SceneKind::RandomPolygon.generate(&mut rng);
            let truth = Transform {
                alpha_rad: rng.gen_range(0.0..TAU),
                tx: rng.gen_range(-4.0..4.0),
                ty: rng.gen_range(-4.0..4.0),
                scale: rng.gen_range(low..high),
            };
            let pair = render_pair(&scene, &truth, &Damage::MODERATE, 128, 128, seed);
            let g1: G = grid_from_image(&pair.i1.image);
            let g2: G = grid_from_image(&pair.i2.image);
            let e = E::new(Mode::Improved)
                .with_scale_search(range)
                .estimate_pair(&g1, &g2);
            let what = format!("seed {seed}, truth {truth:?}: {e:?}");
            assert!(angle_error_deg(e.alpha, truth.alpha_rad) <= 5.0, "{what}");
            let t = e.translation.expect("a pose with the rotation resolved");
            let scale_error = (t.scale.to_num::<f64>() / truth.scale - 1.0).abs();
            let t_error = (t.x.to_num::<f64>() - truth.tx).hypot(t.y.to_num::<f64>() - truth.ty);
            assert!(scale_error <= 0.02 && t_error <= 1.0, "{what}");
            scale_errors.push(scale_error);
        }
        scale_errors.sort_by(f64::total_cmp);
        let median = scale_errors[scale_errors.len() / 2];
        assert!(median <= 0.005, "{low}–{high}: median scale error {median}");
    }
}

/// The verification by alignment (on by default) keeps the README's
/// accuracy targets of issue 4 and adds no confident failure: 200 random
/// polygons and 200 Manhattan rooms, 128², `N_θ` = 360, moderate damage,
/// scale 1 (`eval::trial_pair`); and 200 polygons with a scale of 0.9–1.1
/// and the scale search on.
///
/// Targets: polygons median ≤ 0.25°, p90 ≤ 0.7°, failures (> 5°) ≤ 1 %;
/// Manhattan rooms failures ≤ 3.5 %; none `Confident` and wrong. Measured
/// with the verification: polygons median 0.18°, p90 0.44°, no failure;
/// Manhattan rooms no failure and none flagged (without it 0 failures but
/// 40 % flagged); scaled polygons median 0.15°, no failure.
///
/// (Without the scale search, a scale of 0.9–1.1 misleads the verification,
/// which aligns cells at scale 1: measured over 300 polygons, moderate
/// damage, 14 failures of which 6 `Confident` (p90 0.40° → 2.5°), against
/// none without the verification; Manhattan rooms 8 and 5. Turn the scale
/// search on when the scale can change.)
#[test]
fn verified_accuracy_meets_the_targets() {
    type E = hough_heading::estimator!(128, 128, 360);
    type G = hough_heading::grid!(128, 128);
    let quantile = host_tests::stats::quantile;
    for (kind, with_scale) in [
        (SceneKind::RandomPolygon, false),
        (SceneKind::ManhattanRoom, false),
        (SceneKind::RandomPolygon, true),
    ] {
        let mut errors = Vec::new();
        let mut confidently_wrong = Vec::new();
        for seed in 0..200u64 {
            let (truth, pair) = trial_pair(kind, &Damage::MODERATE, 128, 128, with_scale, seed);
            let g1: G = grid_from_image(&pair.i1.image);
            let g2: G = grid_from_image(&pair.i2.image);
            let mut e = E::new(Mode::Improved);
            if with_scale {
                e = e.with_scale_search(ScaleRange::DEFAULT);
            }
            let r = e.estimate_pair(&g1, &g2);
            let error = angle_error_deg(r.alpha, truth.alpha_rad);
            if r.status == Status::Confident && error > GROSS_DEG {
                confidently_wrong.push(format!("seed {seed}: {error:.1}° {r:?}"));
            }
            errors.push(error);
        }
        let failures = errors.iter().filter(|&&e| e > GROSS_DEG).count() as f64 / 200.0;
        let (median, p90) = (quantile(&errors, 0.5), quantile(&errors, 0.9));
        let what = format!(
            "{kind:?} (scale search {with_scale}): median {median:.3}°, p90 {p90:.3}°, \
             failures {:.1} %",
            100.0 * failures
        );
        println!("{what}");
        assert!(
            confidently_wrong.is_empty(),
            "{what}: {confidently_wrong:?}"
        );
        match kind {
            SceneKind::RandomPolygon => {
                assert!(median <= 0.25 && p90 <= 0.7 && failures <= 0.01, "{what}")
            }
            _ => assert!(failures <= 0.035, "{what}"),
        }
    }
}

/// Issue 14 item 4: the scale search, the pose and the confidence measured
/// over a fixed set of seeds, the skips counted. Random polygons, moderate
/// damage, a scale uniform in 0.9–1.1 with `|s − 1| ≥ 0.04` (so a search
/// stuck at `s = 1` is off by at least 3.6 %), a random translation of up
/// to ±6 px. Returns (relative scale errors, translation errors in px, the
/// wrong rotations skipped, the `Confident` answers) over `cases` seeds.
fn pose_distribution<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const HALF: usize,
    const RHO: usize,
    const PW: usize,
>(
    cases: u64,
) -> (Vec<f64>, Vec<f64>, usize, usize) {
    let (mut scale_errors, mut t_errors, mut wrong, mut confident) = (vec![], vec![], 0, 0);
    for seed in 0..cases {
        let mut rng = ChaCha8Rng::seed_from_u64(0x5343_0000 + seed);
        let scene = SceneKind::RandomPolygon.generate(&mut rng);
        let s = rng.gen_range(0.04..=0.1) * if rng.gen_bool(0.5) { 1.0 } else { -1.0 };
        let truth = Transform {
            alpha_rad: rng.gen_range(0.0..TAU),
            tx: rng.gen_range(-6.0..6.0),
            ty: rng.gen_range(-6.0..6.0),
            scale: 1.0 + s,
        };
        let pair = render_pair(&scene, &truth, &Damage::MODERATE, W, H, seed);
        let g1 = grid_from_image::<W, H, RW>(&pair.i1.image);
        let g2 = grid_from_image::<W, H, RW>(&pair.i2.image);
        let e = Estimator::<W, H, RW, N, HALF, RHO, PW>::new(Mode::Improved)
            .with_scale_search(ScaleRange::DEFAULT)
            .estimate_pair(&g1, &g2);
        if e.status == Status::Confident {
            confident += 1;
        }
        if angle_error_deg(e.alpha, truth.alpha_rad) > 5.0 {
            wrong += 1;
            continue;
        }
        let Some(t) = e.translation else {
            wrong += 1;
            continue;
        };
        scale_errors.push((t.scale.to_num::<f64>() - truth.scale).abs() / truth.scale);
        let (dx, dy) = (
            t.x.to_num::<f64>() - truth.tx,
            t.y.to_num::<f64>() - truth.ty,
        );
        t_errors.push(if t.unobservable.is_some() {
            0.0
        } else {
            dx.hypot(dy)
        });
    }
    (scale_errors, t_errors, wrong, confident)
}

/// The `q`-quantile of `values` (nearest rank).
fn quantile(values: &[f64], q: f64) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

#[test]
fn scale_search_and_confidence_distribution() {
    const CASES: u64 = 200;
    for (name, (scale, t, wrong, confident)) in [
        (
            "64x64/128",
            pose_distribution::<
                64,
                64,
                2,
                128,
                64,
                { rho_bins(64, 64) },
                { hough_heading::config::pyramid_words(64, 64) },
            >(CASES),
        ),
        (
            "128x128/360",
            pose_distribution::<
                128,
                128,
                4,
                360,
                180,
                { rho_bins(128, 128) },
                { hough_heading::config::pyramid_words(128, 128) },
            >(CASES),
        ),
    ] {
        let (m, p90) = (quantile(&scale, 0.5), quantile(&scale, 0.9));
        let (tm, t90) = (quantile(&t, 0.5), quantile(&t, 0.9));
        println!(
            "{name}: scale error median {:.4} p90 {:.4}; t median {tm:.3} px p90 {t90:.3} px; wrong rotations {wrong}/{CASES}; Confident {confident}/{CASES}",
            m, p90
        );
        assert!(
            m <= MEASURED.0 && p90 <= MEASURED.1,
            "{name}: scale error median {m}, p90 {p90}"
        );
        assert!(
            tm <= MEASURED.2 && t90 <= MEASURED.3,
            "{name}: t error median {tm}, p90 {t90}"
        );
        assert!(
            wrong as f64 <= MEASURED.4 * CASES as f64,
            "{name}: {wrong} wrong rotations skipped"
        );
        assert!(
            confident as f64 >= MEASURED.5 * CASES as f64,
            "{name}: only {confident} Confident"
        );
    }
}

/// Bounds of [`scale_search_and_confidence_distribution`]: scale error
/// median and p90 (relative), translation error median and p90 (px), the
/// largest share of skipped (wrong) rotations, the smallest share of
/// `Confident` answers. Measured (200 seeds each): scale error median
/// 0.73 % / 0.23 % (64² / 128²), p90 1.82 % / 0.57 %; translation median
/// 0.17 / 0.13 px, p90 0.36 / 0.28 px; 0 wrong rotations; `Confident`
/// 193 / 199 of 200. Bounds: about twice the worst, and below what a
/// scale search stuck at `s = 1` gives (every error ≥ 3.8 %, median ≈ 6.5 %).
const MEASURED: (f64, f64, f64, f64, f64, f64) = (0.015, 0.03, 0.4, 0.8, 0.05, 0.85);
