//! The library's verification by alignment against the independent `f64`
//! reference of its definition (`host_tests::verify_reference`, which
//! shares no code with it), on random scenes from `host_tests::scene` (every
//! kind; clean, moderate and harsh damage; scale 1), for 64×64 / `N_θ` 128,
//! 96×64 / 180 and 128×128 / 360, with the default estimator (improved mode,
//! verification on, default thresholds).
//!
//! The reference scans every θ step of the full circle, each with the best
//! integer translation within the library's window (`max_shift` = ¼ of the
//! ρ range), found exhaustively. Properties and tolerances, in alignment
//! units, with `P` the points scored (`align_points(W, H)`: 32 at 64², 48
//! at 96×64, 64 at 128²; one point's full score is `1/P`):
//!
//! 1. **Candidates other than the winner** carry the alignment of their own
//!    rotation at its best translation: within `1/P` (one point) of the
//!    reference's best at that rotation (a point may round to another cell
//!    through the Q15 rotation), and of the reference's alignment at the
//!    translation the candidate reports. Measured over 450 pairs: within
//!    half a point.
//! 2. **The winner**: its alignment is that of the pose before the ICP
//!    refinement moved its rotation by a fraction of a step, and the
//!    refinement is kept only while it keeps 15/16 of the score: within
//!    `1/16 + 1/P` of the reference's best at the library's (refined)
//!    rotation. Measured: within 1/16.
//! 3. **Near-optimal over the whole circle**: the reference's best at the
//!    library's rotation is within `1/16 + 1/P` of the best any θ step
//!    reaches (the library searches only around its three strongest
//!    correlation peaks). Measured: within 1/16.
//! 4. **Rotation agreement** when the reference's best is clearly unique
//!    (its best step's score beats every step more than one step away by 8
//!    score units, four points' full scores): the library's rotation within
//!    1.5 θ steps of it (one step, plus the reference's own half-step
//!    quantization). Measured: within 0.98 steps; with a margin of 2 points
//!    a 64² pair came out a half turn apart.
//! 5. **Overlap**: the library's overlap is the reference's overlap at the
//!    library's final pose (α and `u = −R(−α)·t`, when `t` is fully
//!    observable), within one point; the winner's candidate reports that
//!    `t`.
//! 6. **Status rule**: the status follows its definition read back from the
//!    candidates (`common::check_status_rule`).

mod common;

use host_tests::eval::{angle_rad, grid_from_image, trial_pair};
use host_tests::scene::{Damage, SceneKind};
use host_tests::verify_reference as vref;
use hough_heading::{config::rho_bins, config::row_words, Estimator, Mode, Status, Thresholds};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

/// Proptest settings of this file (see `common::proptest_config`).
fn config() -> ProptestConfig {
    common::proptest_config(0x5645_5249)
}

/// Property 4: the margin (score units) that makes the reference's best
/// clearly unique, and the agreement asked then, θ steps.
const UNIQUE_MARGIN: u32 = 8;
const AGREEMENT_STEPS: f64 = 1.5;

/// All properties on one seeded pair.
fn check<
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
    let (_, pair) = trial_pair(kind, damage, W, H, false, seed);
    let (i1, i2) = (&pair.i1.image, &pair.i2.image);
    let g1 = grid_from_image::<W, H, RW>(i1);
    let g2 = grid_from_image::<W, H, RW>(i2);
    let e = Estimator::<W, H, RW, N, HALF, RHO, PW>::new(Mode::Improved).estimate_pair(&g1, &g2);
    if e.status == Status::NoStructure {
        return Ok(());
    }
    let max_shift = (RHO / 4) as i64;
    let map = vref::ScoreMap::new(i1);
    let points = vref::sample_points(i2);
    let at = |alpha: f64| vref::best_translation(&map, i2, &points, alpha, max_shift);
    let point = 1.0 / points.len() as f64;
    let winner_tolerance = 1.0 / 16.0 + point;
    let alignment = |c: &hough_heading::Candidate| {
        c.alignment
            .expect("verified candidates carry an alignment")
            .to_num::<f64>()
    };
    // u = −R(−α)·t (scale 1) for a candidate's reported translation.
    let u_of = |alpha: f64, (tx, ty): (f64, f64)| {
        let (s, c) = alpha.sin_cos();
        (-(c * tx + s * ty), -(c * ty - s * tx))
    };
    // 1. Candidates other than the winner, at their best translation and at
    //    the translation they report (whole cells).
    for c in e.candidates.iter().skip(1) {
        let alpha = angle_rad(c.alpha);
        let reference = at(alpha);
        prop_assert!(
            (alignment(c) - reference.alignment()).abs() <= point + 1e-4,
            "candidate {c:?}: reference {reference:?}"
        );
        let (tx, ty) = c
            .translation
            .expect("verified candidates carry a translation");
        let reported = vref::alignment_at(
            &map,
            i2,
            &points,
            alpha,
            u_of(alpha, (tx.to_num(), ty.to_num())),
        );
        prop_assert!(
            (alignment(c) - reported.alignment()).abs() <= point + 1e-4,
            "candidate {c:?}: reference at its translation {reported:?}"
        );
    }
    // 2. The winner.
    let lib_alpha = angle_rad(e.alpha);
    let at_lib = at(lib_alpha);
    let winner = alignment(&e.candidates[0]);
    prop_assert!(
        (winner - at_lib.alignment()).abs() <= winner_tolerance,
        "winner {winner}, reference at the library's α {at_lib:?}: {e:?}"
    );
    // 3. and 4. Against the whole circle.
    let scan = vref::scan(i1, i2, N, max_shift);
    let verdict = scan.verdict();
    prop_assert!(
        at_lib.alignment() >= verdict.best.alignment() - winner_tolerance,
        "the library's α {:.2}° aligns {:.3}, the reference's best {:.1}° {:.3}: {e:?}",
        e.alpha.to_degrees(),
        at_lib.alignment(),
        verdict.alpha(N).to_degrees(),
        verdict.best.alignment()
    );
    let others = (0..N)
        .filter(|&k| {
            let d = k.abs_diff(verdict.best_step);
            d.min(N - d) > 1
        })
        .map(|k| scan.steps[k].score)
        .max()
        .unwrap_or(0);
    if verdict.best.score >= others + UNIQUE_MARGIN {
        let steps = vref::distance_deg(lib_alpha, verdict.alpha(N)) / (360.0 / N as f64);
        prop_assert!(
            steps <= AGREEMENT_STEPS,
            "{steps:.2} steps from the reference's unique best {:.1}°: {e:?}",
            verdict.alpha(N).to_degrees()
        );
    }
    // 5. The overlap at the final pose; the winner's candidate reports the
    //    same translation.
    if let Some(t) = e.translation.filter(|t| t.unobservable.is_none()) {
        let (tx, ty) = (t.x.to_num::<f64>(), t.y.to_num::<f64>());
        prop_assert_eq!(e.candidates[0].translation, Some((t.x, t.y)));
        let pose = vref::alignment_at(&map, i2, &points, lib_alpha, u_of(lib_alpha, (tx, ty)));
        prop_assert!(
            (e.overlap.to_num::<f64>() - pose.overlap()).abs() <= point + 1e-4,
            "overlap {} against {pose:?}",
            e.overlap
        );
    }
    // 6. The status rule.
    common::check_status_rule::<N>(&e, &Thresholds::DEFAULT)
}

fn damage() -> impl Strategy<Value = Damage> {
    prop::sample::select(vec![Damage::CLEAN, Damage::MODERATE, Damage::HARSH])
}

macro_rules! configuration {
    ($name:ident, $w:literal, $h:literal, $n:literal) => {
        mod $name {
            use super::*;

            proptest! {
                #![proptest_config(config())]

                #[test]
                fn library_verification_agrees_with_the_reference(
                    kind in prop::sample::select(SceneKind::ALL.to_vec()),
                    damage in damage(),
                    seed in any::<u64>(),
                ) {
                    check::<
                        $w,
                        $h,
                        { row_words($w) },
                        $n,
                        { $n / 2 },
                        { rho_bins($w, $h) },
                        { hough_heading::config::pyramid_words($w, $h) },
                    >(kind, &damage, seed)?;
                }
            }
        }
    };
}

configuration!(c64x64_n128, 64, 64, 128);
configuration!(c96x64_n180, 96, 64, 180);
configuration!(c128x128_n360, 128, 128, 360);

/// The reference scores as many points as the library.
#[test]
fn the_reference_samples_as_many_points_as_the_library() {
    assert_eq!(vref::ALIGN_POINTS, hough_heading::config::ALIGN_POINTS);
    for (w, h) in [
        (2, 2),
        (64, 64),
        (96, 64),
        (80, 64),
        (128, 128),
        (160, 90),
        (256, 256),
    ] {
        assert_eq!(
            vref::points_for(w, h),
            hough_heading::config::align_points(w, h),
            "{w}×{h}"
        );
    }
    let t = Thresholds::DEFAULT;
    assert!((t.min_overlap.to_num::<f64>() - vref::MIN_OVERLAP).abs() < 1e-4);
}

/// A pair whose two views share almost nothing: view 1 is 12 isolated
/// cells far apart, view 2 an L of two long walls (about 200 cells). A pose
/// can bring at most 3 cells of a wall within one cell of each isolated
/// cell, 36 of 200 (18 %): below `min_overlap` (30 %) whatever the pose.
/// The reference finds no pose reaching 30 %, and the library says
/// `LowOverlap`; without the verification it answers from the signatures
/// alone and never says `LowOverlap`.
#[test]
fn views_without_overlap_are_low_overlap_for_both() {
    type G = hough_heading::grid!(128, 128);
    type E = hough_heading::estimator!(128, 128, 360);
    let mut a = host_tests::reference::Image::new(128, 128);
    let mut b = host_tests::reference::Image::new(128, 128);
    for i in 0..12 {
        a.set(10 + 9 * i, 10 + (37 * i) % 100, true);
    }
    for i in 0..100 {
        b.set(14 + i, 100, true);
        b.set(14, 100 - i, true);
    }
    let (g1, g2): (G, G) = (grid_from_image(&a), grid_from_image(&b));
    let verdict = vref::scan(&a, &b, 360, 64).verdict();
    assert!(verdict.low_overlap(), "{verdict:?}");
    let e = E::new(Mode::Improved).estimate_pair(&g1, &g2);
    assert_eq!(e.status, Status::LowOverlap, "{e:?}");
    assert!(e.overlap < Thresholds::DEFAULT.min_overlap, "{e:?}");
    let u = E::new(Mode::Improved)
        .with_verification(false)
        .estimate_pair(&g1, &g2);
    assert_ne!(u.status, Status::LowOverlap, "{u:?}");
}

/// FINDING (fails): an ambiguous estimate should list the rival that makes
/// it ambiguous (`Status::AmbiguousAxis`: "see the candidates"). Here
/// (64², `N_θ` 128, a random polygon with harsh damage) the verification
/// seeds −10.7° and −3.8° align equally (34 score units each, 6.9° apart:
/// rivals); the ICP then moves the winner from −10.7° to −2.2°, within 5° of
/// the rival, which is dropped from the candidates as a duplicate: the
/// estimate says `AmbiguousAxis` with the winner as its only candidate. The
/// rival is judged against the winner before the refinement, the duplicates
/// after it.
#[test]
fn finding_an_ambiguous_estimate_lists_its_rival() {
    type E = hough_heading::estimator!(64, 64, 128);
    let (_, pair) = trial_pair(
        SceneKind::RandomPolygon,
        &Damage::HARSH,
        64,
        64,
        false,
        16_200_087_499_166_535_012,
    );
    let g1 = grid_from_image::<64, 64, 2>(&pair.i1.image);
    let g2 = grid_from_image::<64, 64, 2>(&pair.i2.image);
    let e = E::new(Mode::Improved).estimate_pair(&g1, &g2);
    if matches!(e.status, Status::AmbiguousAxis | Status::AmbiguousDirection) {
        // The runner-up is reported whatever happened to the candidates.
        let runner_up = e
            .runner_up
            .expect("an ambiguous estimate names its runner-up");
        let winner = e.candidates[0].support.expect("verified");
        assert!(
            winner - runner_up.support.expect("verified") < Thresholds::DEFAULT.decision_gap,
            "{e:?}"
        );
    }
}
