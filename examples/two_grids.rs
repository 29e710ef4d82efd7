//! Firmware example: the pose between two grids held in flash, verified by
//! alignment.
//!
//! Two 128² outlines of the same room are rasterised at compile time into
//! `static` grids (flash, no RAM): the second is turned by 30° counter-clockwise
//! about the image centre and shifted by (3, −2) cells, so the truth is
//! `α = 30°`, `t = (3, −2)` (`p₂ = R(α)·p₁ + t`, DESIGN.md §2; see
//! [`Pose`]). The estimator runs twice, a GPIO pin high during each estimate
//! (for a scope), the results go to the `defmt` log:
//!
//! 1. with the verification by alignment (the default of `Mode::Improved`):
//!    the status must be `Confident`, at least [`MIN_OVERLAP_PERMILLE`] of the
//!    sampled cells must lie within one cell of the reference, every candidate
//!    must carry an alignment (the first, the chosen rotation, the highest),
//!    the rotation must be within [`VERIFIED_MDEG`] of 30° and the translation
//!    within [`VERIFIED_MCELLS`] of (3, −2) per axis;
//! 2. with `with_verification(false)`: the correlation and column-profile
//!    answer, within 1° and ½ cell, with no overlap and no alignments (its
//!    status is logged, not checked: this L-shaped, mostly Manhattan room has
//!    a rival correlation peak at 90°, which only the alignment rules out).
//!
//! The program exits through semihosting: status 0 when every check holds, 1
//! otherwise.
//!
//! Why these bounds (from how the scene is built, `support/room.rs`): each wall
//! is sampled at most every half cell and each sample rounded to the nearest
//! cell centre. A cell of the second grid lies within ½ cell per axis of a
//! sample on its wall; turned back by the true pose it lies within `√2/2` of a
//! point of the reference wall, which is within ¼ cell of a reference sample,
//! itself within ½ cell per axis of its occupied reference cell: at most 1.46
//! cells per axis in all, so the reference cell nearest the point is at most
//! one cell from an occupied one. Every sampled point scores at least 1 at the
//! true pose: overlap 100 %, alignment (2 per point on an occupied cell, 1 next
//! to one, over 2 per point) at least ½. The overlap bound leaves 10 % for the
//! estimated pose's own error. The rounding errors are at most ½ cell each and
//! average out over the ~400 cells, so a fit is expected well within ½ cell;
//! the walls reach ~60 cells from the centre, where ½° moves a point by ½
//! cell.
//!
//! ```text
//! cargo build --release -p hough-heading --example two_grids --target thumbv7em-none-eabihf
//! qemu-system-arm -machine mps2-an386 -display none -semihosting-config enable=on,target=native \
//!     -kernel target/thumbv7em-none-eabihf/release/examples/two_grids | defmt-print -e ...
//! ```
//!
//! or `.ci/firmware.sh`, which runs it on `mps2-an386` (Cortex-M4F) and
//! `microbit` (Cortex-M0) and decodes the log with `tools/budgets`. On the host
//! this example is an empty stub.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod support;

#[cfg(target_os = "none")]
mod firmware {
    use hough_heading::{config::row_words, estimator, grid, Estimate, Grid, Mode, Score, Status};

    use crate::support::room::{room_words, Pose};
    use crate::support::{self, ScopePin};

    /// Image side, cells.
    const SIDE: usize = 128;
    /// θ steps over the full circle.
    const N_THETA: usize = 360;
    /// The scene of the second grid: the room turned by 30° counter-clockwise
    /// about the image centre, then shifted by (3, −2) cells (x right, y up).
    const TRUTH: Pose = Pose {
        degrees: 30.0,
        dx: 3.0,
        dy: -2.0,
    };
    /// Largest accepted rotation error of the verified pose, millidegrees.
    const VERIFIED_MDEG: i32 = 500;
    /// Largest accepted translation error of the verified pose per axis,
    /// millicells.
    const VERIFIED_MCELLS: i32 = 500;
    /// Smallest accepted overlap of the verified pose, ‰ of the sampled cells.
    const MIN_OVERLAP_PERMILLE: i32 = 900;
    /// Smallest accepted alignment of the chosen candidate, ‰ (½: every point
    /// next to an occupied reference cell).
    const MIN_ALIGNMENT_PERMILLE: i32 = 500;
    /// Largest accepted rotation error without verification, millidegrees.
    const PLAIN_MDEG: i32 = 1_000;
    /// Largest accepted translation error without verification, millicells.
    const PLAIN_MCELLS: i32 = 500;

    type Estimator = estimator!(SIDE, SIDE, N_THETA);

    /// The room as the robot saw it first.
    static FIRST: grid!(SIDE, SIDE) =
        Grid::from_words(room_words::<SIDE, SIDE, { row_words(SIDE) }>(Pose::ORIGIN));
    /// The same room after the robot turned right by 30° and moved a little.
    static SECOND: grid!(SIDE, SIDE) =
        Grid::from_words(room_words::<SIDE, SIDE, { row_words(SIDE) }>(TRUTH));

    /// A Q16.16 value in thousandths (millicells, ‰), rounded towards −∞.
    fn milli(v: Score) -> i32 {
        ((i64::from(v.to_bits()) * 1000) >> 16) as i32
    }

    /// Logs `estimate` and checks its rotation and translation against
    /// [`TRUTH`]; true when both are within the tolerances.
    fn pose_right(label: &str, estimate: &Estimate, mdeg: i32, mcells: i32) -> bool {
        let expected = support::angle_of_degrees(TRUTH.degrees as i32);
        let error = support::error_millidegrees(estimate.alpha, expected);
        let (tx, ty) = estimate
            .translation
            .map_or((i32::MIN, i32::MIN), |t| (milli(t.x), milli(t.y)));
        let truth = ((TRUTH.dx * 1000.0) as i32, (TRUTH.dy * 1000.0) as i32);
        let (ex, ey) = (tx.saturating_sub(truth.0), ty.saturating_sub(truth.1));
        defmt::println!(
            "{=str}: alpha = {=i32} mdeg (truth {=i32}, error {=i32}, limit {=i32}), status {=str}, confidence {=i32} ‰",
            label,
            support::millidegrees(estimate.alpha),
            (TRUTH.degrees * 1000.0) as i32,
            error,
            mdeg,
            support::status_name(estimate.status),
            milli(estimate.confidence)
        );
        defmt::println!(
            "{=str}: t = ({=i32}, {=i32}) millicells (truth ({=i32}, {=i32}), error ({=i32}, {=i32}), limit {=i32}), overlap {=i32} ‰",
            label,
            tx,
            ty,
            truth.0,
            truth.1,
            ex,
            ey,
            mcells,
            milli(estimate.overlap)
        );
        for (i, c) in estimate.candidates.iter().enumerate() {
            defmt::println!(
                "{=str}: candidate {=usize}: alpha = {=i32} mdeg, score {=i32} ‰, alignment {=i32} ‰",
                label,
                i,
                support::millidegrees(c.alpha),
                milli(c.score),
                c.alignment.map_or(-1, milli)
            );
        }
        error.abs() <= mdeg
            && ex.unsigned_abs() <= mcells.unsigned_abs()
            && ey.unsigned_abs() <= mcells.unsigned_abs()
    }

    /// The checks of the verified estimate beyond its pose: status, overlap
    /// and the candidates' alignments. Logs each failed check.
    fn verification_right(estimate: &Estimate) -> bool {
        let mut ok = true;
        let mut check = |holds: bool, what: &str| {
            if !holds {
                defmt::println!("verified: check failed: {=str}", what);
                ok = false;
            }
        };
        check(estimate.status == Status::Confident, "status is Confident");
        check(
            milli(estimate.overlap) >= MIN_OVERLAP_PERMILLE,
            "overlap >= MIN_OVERLAP_PERMILLE",
        );
        let candidates = &estimate.candidates;
        // With a clear winner the rivals that cannot come within
        // `alignment_ratio` of it are not candidates: one is enough.
        check(!candidates.is_empty(), "at least one candidate");
        check(
            candidates.iter().all(|c| {
                c.alignment
                    .is_some_and(|a| a >= Score::ZERO && a <= Score::ONE)
            }),
            "every candidate has an alignment in [0, 1]",
        );
        let first = candidates.first();
        check(
            first.is_some_and(|c| c.alpha == estimate.alpha),
            "the first candidate is the chosen rotation",
        );
        let best = first.and_then(|c| c.alignment).unwrap_or(Score::ZERO);
        check(
            milli(best) >= MIN_ALIGNMENT_PERMILLE,
            "the chosen candidate's alignment >= MIN_ALIGNMENT_PERMILLE",
        );
        check(
            candidates
                .iter()
                .all(|c| c.alignment.is_some_and(|a| a <= best)),
            "the chosen candidate is the best aligned",
        );
        ok
    }

    #[cfg_attr(target_arch = "arm", cortex_m_rt::entry)]
    #[cfg_attr(target_arch = "riscv32", riscv_rt::entry)]
    fn main() -> ! {
        let mut pin = ScopePin::default();
        let mut estimator = Estimator::new(Mode::Improved);
        defmt::println!(
            "two_grids: {=usize}² cells, N_THETA = {=usize}, {=u32} and {=u32} occupied, verification {=bool}",
            SIDE,
            N_THETA,
            FIRST.occupied(),
            SECOND.occupied(),
            estimator.verification()
        );
        let verifies_by_default = estimator.verification();

        let Ok(verified) = support::timed(&mut pin, || estimator.estimate_pair(&FIRST, &SECOND));
        let verified_ok = pose_right("verified", &verified, VERIFIED_MDEG, VERIFIED_MCELLS)
            & verification_right(&verified);

        let mut estimator = estimator.with_verification(false);
        let Ok(plain) = support::timed(&mut pin, || estimator.estimate_pair(&FIRST, &SECOND));
        let plain_ok = pose_right("unverified", &plain, PLAIN_MDEG, PLAIN_MCELLS)
            && plain.overlap == Score::ZERO
            && plain.candidates.iter().all(|c| c.alignment.is_none())
            && !estimator.verification();

        defmt::println!(
            "verified {=bool}, unverified {=bool}, verification on by default {=bool}, pin pulses {=u32}",
            verified_ok,
            plain_ok,
            verifies_by_default,
            pin.rising_edges()
        );
        if verified_ok && plain_ok && verifies_by_default && pin.rising_edges() == 2 {
            defmt::println!("two_grids: PASS");
            support::exit(0)
        }
        defmt::println!("two_grids: FAIL");
        support::exit(support::EXIT_WRONG_ESTIMATE)
    }
}

/// On the host this example does nothing: it is firmware.
#[cfg(not(target_os = "none"))]
fn main() {
    println!("two_grids is firmware: build it for thumbv7em-none-eabihf or thumbv6m-none-eabi (.ci/firmware.sh)");
}
