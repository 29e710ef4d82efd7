//! The verification's work budget (`Thresholds::search_budget`): a search
//! that runs out says so (`Status::SearchCut`, confidence below ½), and a
//! budget that was not exhausted changes nothing (the estimate is the one
//! without a budget, field for field).

use host_tests::eval::{grid_from_image, trial_pair};
use host_tests::scene::{Damage, SceneKind};
use hough_heading::config::{half_turn_steps, pyramid_words, rho_bins, row_words};
use hough_heading::{Estimate, Estimator, Grid, Mode, Score, Status, Thresholds};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const W: usize = 128;
const RW: usize = row_words(W);
const N: usize = 360;
const HALF: usize = half_turn_steps(N);
const RHO: usize = rho_bins(W, W);
const PW: usize = pyramid_words(W, W);

fn estimate(g1: &Grid<W, W, RW>, g2: &Grid<W, W, RW>, budget: u32) -> Estimate {
    let t = Thresholds {
        search_budget: budget,
        ..Thresholds::DEFAULT
    };
    Estimator::<W, W, RW, N, HALF, RHO, PW>::new(Mode::Improved)
        .with_thresholds(t)
        .estimate_pair(g1, g2)
}

fn scene_pair(kind: SceneKind, seed: u64) -> (Grid<W, W, RW>, Grid<W, W, RW>) {
    let (_, pair) = trial_pair(kind, &Damage::PRESETS[1].1, W, W, false, seed);
    (
        grid_from_image::<W, W, RW>(&pair.i1.image),
        grid_from_image::<W, W, RW>(&pair.i2.image),
    )
}

/// Scattered single cells, the second view a shifted copy with a quarter
/// of them moved elsewhere: every block of translations reaches occupied
/// cells, so the branch and bound cannot prune and explores the window.
fn scattered_pair(seed: u64) -> (Grid<W, W, RW>, Grid<W, W, RW>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut g1, mut g2) = (Grid::new(), Grid::new());
    for _ in 0..600 {
        let (c, r) = (rng.gen_range(8..W - 8), rng.gen_range(8..W - 8));
        g1.set(c, r).unwrap();
        if rng.gen_bool(0.75) {
            g2.set(c + 3, r - 2).unwrap();
        } else {
            g2.set(rng.gen_range(0..W), rng.gen_range(0..W)).unwrap();
        }
    }
    (g1, g2)
}

/// Every estimate with the default budget is either cut (and says so) or
/// identical to the estimate without a budget; on scenes of every kind the
/// default budget cuts none.
#[test]
fn an_unexhausted_budget_changes_nothing() {
    let mut cut = 0;
    let mut checked = 0;
    for (i, kind) in SceneKind::ALL.iter().cycle().take(40).enumerate() {
        let (g1, g2) = scene_pair(*kind, 0xB0D6_E700 + i as u64);
        let bounded = estimate(&g1, &g2, Thresholds::DEFAULT.search_budget);
        let free = estimate(&g1, &g2, u32::MAX);
        assert_ne!(free.status, Status::SearchCut, "{free:?}");
        if bounded.status == Status::SearchCut {
            cut += 1;
            assert!(bounded.confidence < Score::from_num(0.5), "{bounded:?}");
        } else {
            assert_eq!(bounded, free);
            checked += 1;
        }
    }
    println!("{checked} identical, {cut} cut");
    assert_eq!(cut, 0, "the default budget cut synthetic scenes");
}

/// A scene built to make the search explore: with a small budget it runs
/// out, the status says so and the confidence is below ½; without a budget
/// the same pair is not cut.
#[test]
fn a_search_that_runs_out_says_so() {
    for seed in 0..4 {
        let (g1, g2) = scattered_pair(seed);
        let free = estimate(&g1, &g2, u32::MAX);
        assert_ne!(free.status, Status::SearchCut, "{free:?}");
        // A budget (grid rows per sampled point) that lets the first seeds
        // be scored but not the whole search (these pairs need about 10 M;
        // an ordinary 128² real pair 1.7 M).
        let cut = estimate(&g1, &g2, 3_000_000);
        assert_eq!(cut.status, Status::SearchCut, "{cut:?}");
        assert!(!cut.candidates.is_empty(), "{cut:?}");
        assert!(cut.confidence < Score::from_num(0.5), "{cut:?}");
    }
    // The tiniest budget on an ordinary scene: cut, never confident.
    let (g1, g2) = scene_pair(SceneKind::RandomPolygon, 7);
    let e = estimate(&g1, &g2, 1);
    assert_eq!(e.status, Status::SearchCut, "{e:?}");
    assert!(e.confidence < Score::from_num(0.5), "{e:?}");
}

/// `Estimate::search_rows` is the budget an estimate needs, exactly: with
/// that budget it is the unbudgeted estimate, field for field; with one row
/// less its last evaluation does not fit and the status says so. Without
/// verification it is 0.
#[test]
fn search_rows_is_the_budget_an_estimate_needs() {
    for (i, kind) in SceneKind::ALL.iter().enumerate() {
        let (g1, g2) = scene_pair(*kind, 0x5EA2_C400 + i as u64);
        let free = estimate(&g1, &g2, u32::MAX);
        let needed = free.search_rows;
        assert!(needed > 0, "{kind:?}: {free:?}");
        assert_eq!(estimate(&g1, &g2, needed), free, "{kind:?}");
        let short = estimate(&g1, &g2, needed - 1);
        assert_eq!(short.status, Status::SearchCut, "{kind:?}: {short:?}");
        assert!(short.search_rows < needed, "{kind:?}: {short:?}");
        let unverified = Estimator::<W, W, RW, N, HALF, RHO, PW>::new(Mode::Improved)
            .with_verification(false)
            .estimate_pair(&g1, &g2);
        assert_eq!(unverified.search_rows, 0, "{kind:?}");
    }
}
