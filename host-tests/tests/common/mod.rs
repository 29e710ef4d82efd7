//! Test support shared by the property-test files and the fuzz harness.

use hough_heading::{Angle, Estimate, Score, Status, Thresholds};
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
/// `min_overlap`; otherwise `Confident` exactly when the winner's support
/// (the first candidate's) leads the runner-up's (`Estimate::runner_up`, or
/// 0 without one; no lead when both align every sampled point on an
/// occupied cell) by at least `decision_gap`, and exactly when the
/// confidence is at least ½; when not confident, `AmbiguousDirection` when
/// the runner-up lies within `N/8` steps of the winner's half turn,
/// `AmbiguousAxis` when farther. The winner's reported α is refined after
/// the decision, so a runner-up within 3° of the `N/8` boundary is not held
/// to either side. `SearchCut` (the work budget ran out) has a confidence
/// below ½; without candidates (cut before any was scored) no overlap was
/// measured.
#[allow(dead_code)] // not every test file uses it
pub fn check_status_rule<const N: usize>(
    e: &Estimate,
    t: &Thresholds,
) -> Result<(), TestCaseError> {
    if e.status == Status::NoStructure {
        return Ok(());
    }
    if e.status == Status::SearchCut && e.candidates.is_empty() {
        // The work budget ran out before any pose was scored: the
        // correlation's answer, no overlap measured, never confident.
        prop_assert!(e.confidence < Score::from_num(0.5), "{:?}", e);
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
    if e.status == Status::SearchCut {
        // The work budget ran out: never confident.
        prop_assert!(e.confidence < Score::from_num(0.5), "{:?}", e);
        return Ok(());
    }
    let winner = &e.candidates[0];
    let Some(support) = winner.support else {
        return Ok(());
    };
    // The rule, from the fields the estimate reports: the winner's support
    // leads the runner-up's (the best candidate ≥ 5° away, whatever its
    // lead) by the decision gap, or it is ambiguous; direction when the
    // runner-up lies within an octant of the half turn. The confidence is
    // at least ½ exactly when the answer is confident.
    // Both laying every sampled point on an occupied cell (alignment 1):
    // ties, ambiguous whatever the supports say.
    let saturated = |c: &hough_heading::Candidate| c.alignment == Some(Score::ONE);
    let gap = match e.runner_up {
        Some(r) if saturated(winner) && saturated(&r) => Score::ZERO,
        Some(r) => support - r.support.unwrap_or(Score::ZERO),
        None => support,
    };
    let deg = |a: Angle| f64::from(a.0) * 360.0 / 4_294_967_296.0;
    let apart = |a: Angle, b: Angle| {
        let d = (deg(a) - deg(b)).rem_euclid(360.0);
        d.min(360.0 - d)
    };
    let confident = gap >= t.decision_gap;
    prop_assert_eq!(e.status == Status::Confident, confident, "{:?}", e);
    prop_assert_eq!(e.confidence >= Score::from_num(0.5), confident, "{:?}", e);
    if let (false, Some(r)) = (confident, e.runner_up) {
        let octant = (N / 8) as f64 * 360.0 / N as f64;
        let separation = (N / 72).max(2) as f64 * 360.0 / N as f64;
        // The runner-up is judged against the winner's search pose; ICP may
        // have moved the winner's α since (up to a few steps).
        let slack = 3.0;
        prop_assert!(apart(r.alpha, winner.alpha) >= separation - slack, "{e:?}");
        let d = apart(r.alpha, winner.alpha + Angle::HALF_TURN);
        if d < octant - slack {
            prop_assert_eq!(e.status, Status::AmbiguousDirection, "{:?}", e);
        } else if d > octant + slack {
            prop_assert_eq!(e.status, Status::AmbiguousAxis, "{:?}", e);
        }
    }
    Ok(())
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
