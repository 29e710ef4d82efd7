//! Firmware example: the robot's loop. Prepare a reference once, then estimate
//! each new view against it.
//!
//! The reference is the room as the robot first saw it, stored with the
//! firmware (`data/home-128-360.hhr`, 3 824 bytes) and parsed by the compiler
//! into a `static`: it lives in flash and costs no RAM. At start-up the program
//! checks that it is what the library prepares from the home view today. Each
//! later view (here
//! five 128² grids rasterised into flash at compile time, standing in for laser
//! scans) costs one signature, not two, plus the verification by alignment
//! against the grid the reference keeps (on by default in `Mode::Improved`).
//! For each view the heading change of the robot is `−α` (when the robot turns
//! left, the scene turns right; DESIGN.md §2). A GPIO pin is high during each
//! estimate. The program exits through semihosting with status 0 when every
//! view's α is within 1° of its known rotation, its translation within
//! [`TOLERANCE_MCELLS`] of its known shift per axis, its status `Confident`
//! and its overlap at least [`MIN_OVERLAP_PERMILLE`] (the bounds of
//! `two_grids`, which explains them), 1 otherwise. On the host this example
//! is an empty stub.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod support;

#[cfg(target_os = "none")]
mod firmware {
    use hough_heading::{
        config::row_words, estimator, grid, reference, Grid, Mode, Reference, Score, Status,
    };

    use crate::support::room::{room_words, Pose};
    use crate::support::{self, ScopePin};

    /// Image side, cells.
    const SIDE: usize = 128;
    /// θ steps over the full circle.
    const N_THETA: usize = 360;
    /// Row words of a grid.
    const RW: usize = row_words(SIDE);
    /// Largest accepted error, millidegrees.
    const TOLERANCE_MDEG: i32 = 1_000;
    /// Largest accepted translation error per axis, millicells.
    const TOLERANCE_MCELLS: i32 = 500;
    /// Smallest accepted overlap, ‰ of the sampled cells.
    const MIN_OVERLAP_PERMILLE: i32 = 900;

    type Estimator = estimator!(SIDE, SIDE, N_THETA);
    type View = grid!(SIDE, SIDE);
    type Stored = reference!(SIDE, SIDE, N_THETA);

    /// The reference of [`HOME`], stored with the firmware and parsed at
    /// compile time (invalid bytes fail the build). Rewrite the file with
    /// `UPDATE_STORED_REFERENCE=1 cargo test -p host-tests --test stored_reference`.
    static STORED: Stored = match Reference::from_bytes(include_bytes!("data/home-128-360.hhr")) {
        Ok(r) => r,
        Err(_) => panic!("data/home-128-360.hhr is not a 128², N_THETA = 360 reference"),
    };

    /// The first view: the reference.
    static HOME: View = Grid::from_words(room_words::<SIDE, SIDE, RW>(Pose::ORIGIN));

    /// Scene rotation (degrees) and shift (cells) of each later view.
    const POSES: [Pose; 5] = [
        Pose {
            degrees: 12.0,
            dx: 2.0,
            dy: 1.0,
        },
        Pose {
            degrees: -45.0,
            dx: -3.0,
            dy: 2.0,
        },
        Pose {
            degrees: 105.0,
            dx: 4.0,
            dy: -4.0,
        },
        Pose {
            degrees: 170.0,
            dx: 0.0,
            dy: 3.0,
        },
        Pose::turned(-135.0),
    ];

    /// Each pose as the check compares it, computed at build time so the
    /// firmware links no floating point: rotation (whole degrees) and shift
    /// (thousandths of a cell).
    const EXPECTED: [(i32, i32, i32); 5] = {
        let mut out = [(0, 0, 0); 5];
        let mut i = 0;
        while i < out.len() {
            let p = POSES[i];
            out[i] = (
                p.degrees as i32,
                (p.dx * 1000.0) as i32,
                (p.dy * 1000.0) as i32,
            );
            i += 1;
        }
        out
    };

    /// The later views, as the robot's sensor would deliver them.
    static VIEWS: [View; 5] = [
        Grid::from_words(room_words::<SIDE, SIDE, RW>(POSES[0])),
        Grid::from_words(room_words::<SIDE, SIDE, RW>(POSES[1])),
        Grid::from_words(room_words::<SIDE, SIDE, RW>(POSES[2])),
        Grid::from_words(room_words::<SIDE, SIDE, RW>(POSES[3])),
        Grid::from_words(room_words::<SIDE, SIDE, RW>(POSES[4])),
    ];

    #[cfg_attr(target_arch = "arm", cortex_m_rt::entry)]
    #[cfg_attr(target_arch = "riscv32", riscv_rt::entry)]
    fn main() -> ! {
        let mut pin = ScopePin::default();
        let mut estimator = Estimator::new(Mode::Improved);
        if estimator.reference(&HOME) != STORED {
            defmt::println!("robot_loop: FAIL (the stored reference is stale)");
            support::exit(support::EXIT_WRONG_ESTIMATE)
        }
        let reference = &STORED;
        defmt::println!(
            "robot_loop: reference of {=u32} cells in flash, {=usize} views to go",
            reference.occupied(),
            VIEWS.len()
        );

        let mut failures = 0u32;
        for (i, (view, (degrees, dx_milli, dy_milli))) in VIEWS.iter().zip(EXPECTED).enumerate() {
            let Ok(estimate) = support::timed(&mut pin, || estimator.estimate(reference, view));
            let expected = support::angle_of_degrees(degrees);
            let error = support::error_millidegrees(estimate.alpha, expected);
            // Q16.16 to thousandths.
            let milli = |v: Score| ((i64::from(v.to_bits()) * 1000) >> 16) as i32;
            let (ex, ey) = estimate.translation.map_or((i32::MAX, i32::MAX), |t| {
                (
                    milli(t.x).saturating_sub(dx_milli),
                    milli(t.y).saturating_sub(dy_milli),
                )
            });
            let overlap = milli(estimate.overlap);
            let ok = error.abs() <= TOLERANCE_MDEG
                && ex.abs() <= TOLERANCE_MCELLS
                && ey.abs() <= TOLERANCE_MCELLS
                && estimate.status == Status::Confident
                && overlap >= MIN_OVERLAP_PERMILLE;
            failures += u32::from(!ok);
            defmt::println!(
                "view {=usize}: alpha = {=i32} mdeg, heading change = {=i32} mdeg, error {=i32} mdeg, t error ({=i32}, {=i32}) millicells, overlap {=i32} ‰, {=str}, {=str}",
                i,
                support::millidegrees(estimate.alpha),
                -support::millidegrees(estimate.alpha),
                error,
                ex,
                ey,
                overlap,
                support::status_name(estimate.status),
                if ok { "ok" } else { "WRONG" }
            );
        }

        if failures == 0 && pin.rising_edges() == VIEWS.len() as u32 {
            defmt::println!("robot_loop: PASS");
            support::exit(0)
        }
        defmt::println!("robot_loop: FAIL ({=u32} wrong)", failures);
        support::exit(support::EXIT_WRONG_ESTIMATE)
    }
}

/// On the host this example does nothing: it is firmware.
#[cfg(not(target_os = "none"))]
fn main() {
    println!("robot_loop is firmware: build it for thumbv7em-none-eabihf or thumbv6m-none-eabi (.ci/firmware.sh)");
}
