//! Test support shared by the property-test files and the fuzz harness.

use hough_heading::{Angle, Estimate, Grid, Score, Status, Thresholds};
use proptest::prelude::{prop_assert, prop_assert_eq, ProptestConfig};
use proptest::test_runner::{RngSeed, TestCaseError};

/// 24 cases per property from a fixed seed (reproducible runs); `HH_CASES`
/// and `HH_SEED` in the environment override them for longer local runs. No
/// regression files are written into the source tree. `default_seed` keeps
/// each test file on its own stream of cases.
#[allow(dead_code)] // not every test file uses it
pub fn proptest_config(default_seed: u64) -> ProptestConfig {
    fn env<T: std::str::FromStr>(name: &str) -> Option<T> {
        std::env::var(name).ok().and_then(|v| v.parse().ok())
    }
    ProptestConfig {
        cases: env("HH_CASES").unwrap_or(24),
        rng_seed: RngSeed::Fixed(env("HH_SEED").unwrap_or(default_seed)),
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

/// The status of a verified estimate (no prior) follows its rule, read
/// back from the estimate: `LowOverlap` exactly when the overlap is below
/// `min_overlap`; otherwise `Confident` exactly when the winner's alignment
/// (the first candidate's) is at least `alignment_ratio` × every candidate's
/// at least 5° (`max(2, N/72)` steps) away, and `AmbiguousDirection` when
/// the strongest of those rivals lies within `N/8` steps of the winner's
/// half turn, `AmbiguousAxis` when it lies farther. Alignments are read back
/// as integer scores (`alignment · 2·points`, exact in Q16); the winner's
/// reported α is refined after the decision, so candidates within 3° of the
/// 5° separation or of the `N/8` boundary are not held to either side, and
/// an ambiguous estimate whose rival is not among its candidates is passed
/// over (see the comment in the code).
#[allow(dead_code)] // not every test file uses it
pub fn check_status_rule<const N: usize>(
    e: &Estimate,
    t: &Thresholds,
    view: &impl Occupied,
) -> Result<(), TestCaseError> {
    if e.status == Status::NoStructure {
        return Ok(());
    }
    prop_assert_eq!(
        e.status == Status::LowOverlap,
        e.overlap < t.min_overlap,
        "{:?}",
        e
    );
    if e.status == Status::LowOverlap {
        return Ok(());
    }
    let points = view.points();
    let score = |c: &hough_heading::Candidate| {
        (c.alignment.unwrap_or(Score::ZERO).to_num::<f64>() * f64::from(2 * points)).round() as i64
    };
    let deg = |a: Angle| f64::from(a.0) * 360.0 / 4_294_967_296.0;
    let apart = |a: Angle, b: Angle| {
        let d = (deg(a) - deg(b)).rem_euclid(360.0);
        d.min(360.0 - d)
    };
    let winner = &e.candidates[0];
    let separation = (N / 72).max(2) as f64 * 360.0 / N as f64;
    let octant = (N / 8) as f64 * 360.0 / N as f64;
    let slack = 3.0;
    // beats(c): the winner does not lead c by the ratio.
    let ratio = i64::from(t.alignment_ratio.to_bits());
    let beats = |c: &hough_heading::Candidate| (score(winner) << 16) < ratio * score(c);
    let clear_rivals = || {
        e.candidates[1..]
            .iter()
            .filter(move |c| apart(c.alpha, winner.alpha) >= separation + slack)
    };
    let maybe_rivals: Vec<_> = e.candidates[1..]
        .iter()
        .filter(|c| apart(c.alpha, winner.alpha) >= separation - slack)
        .collect();
    match e.status {
        Status::Confident => {
            prop_assert!(clear_rivals().all(|c| !beats(c)), "{e:?}");
        }
        Status::AmbiguousDirection | Status::AmbiguousAxis => {
            // The rival is judged against the winner before the ICP moves
            // it; a rival the refinement brought within 5° of the winner is
            // then dropped from the candidates as a duplicate, and nothing
            // here can be read back (`verify_reference.rs`,
            // `finding_an_ambiguous_estimate_lists_its_rival`).
            if !maybe_rivals.iter().any(|c| beats(c)) {
                return Ok(());
            }
            // The rival the rule used is at least as strong as every clear
            // rival. With the candidate list full, a rival tied with the
            // weakest candidate may be one the list had no room for: then
            // which side it lies on cannot be read back.
            let strongest = clear_rivals().map(score).max().unwrap_or(0);
            let weakest = e.candidates.iter().map(score).min().unwrap_or(0);
            let full = e.candidates.len() == hough_heading::MAX_CANDIDATES;
            if full && strongest <= weakest {
                return Ok(());
            }
            let opposite = winner.alpha + Angle::HALF_TURN;
            let direction = e.status == Status::AmbiguousDirection;
            prop_assert!(
                maybe_rivals.iter().any(|c| {
                    let d = apart(c.alpha, opposite);
                    score(c) >= strongest
                        && if direction {
                            d < octant + slack
                        } else {
                            d >= octant - slack
                        }
                }),
                "{e:?}"
            );
        }
        _ => {}
    }
    Ok(())
}

/// Grids of any configuration, for [`check_status_rule`].
pub trait Occupied {
    /// The number of cells the verification scores: the occupied cells, at
    /// most `align_points(W, H)`.
    fn points(&self) -> u32;
}

impl<const W: usize, const H: usize, const RW: usize> Occupied for Grid<W, H, RW> {
    fn points(&self) -> u32 {
        self.occupied()
            .min(hough_heading::config::align_points(W, H) as u32)
    }
}

/// Fails unless at least one case was checked and the skipped share is at
/// most `max_share`; prints the counts either way. `detail` (e.g. the
/// skipped cases by status) goes into the message.
#[allow(dead_code)] // not every test file uses it
pub fn assert_skipped_share(
    what: &str,
    checked: usize,
    skipped: usize,
    max_share: f64,
    detail: &str,
) {
    let share = skipped as f64 / (checked + skipped).max(1) as f64;
    eprintln!("{what}: {checked} checked, {skipped} skipped {detail}");
    assert!(
        checked > 0 && share <= max_share,
        "{what}: {skipped} of {} skipped ({:.1} %, at most {:.0} % allowed) {detail}",
        checked + skipped,
        100.0 * share,
        100.0 * max_share
    );
}
