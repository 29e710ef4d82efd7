//! Firmware example: the rotation between two grids held in flash.
//!
//! Two 128² outlines of the same room are rasterised at compile time into
//! `static` grids (flash, no RAM): the second is turned by 30° counter-clockwise
//! and shifted by (3, −2) cells. The estimator finds the rotation and the
//! translation, a GPIO pin is high during the estimate (for a scope), the
//! result goes to the `defmt` log, and the program exits through semihosting:
//! status 0 when the rotation is within 1° of 30° and the translation within
//! ½ cell of (3, −2), 1 otherwise.
//!
//! ```text
//! cargo build --release --example two_grids --target thumbv7em-none-eabihf
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
    use hough_heading::{estimator, grid, row_words, Grid, Mode, Score};

    use crate::support::room::{room_words, Pose};
    use crate::support::{self, ScopePin};

    /// Image side, cells.
    const SIDE: usize = 128;
    /// θ steps over the full circle.
    const N_THETA: usize = 360;
    /// The rotation between the grids, degrees counter-clockwise.
    const TURN_DEGREES: i32 = 30;
    /// Largest accepted error, millidegrees.
    const TOLERANCE_MDEG: i32 = 1_000;
    /// The shift between the grids, cells (x right, y up).
    const SHIFT: (f64, f64) = (3.0, -2.0);
    /// Largest accepted translation error per axis, millicells.
    const TOLERANCE_MCELLS: i32 = 500;

    type Estimator = estimator!(SIDE, SIDE, N_THETA);

    /// The room as the robot saw it first.
    static FIRST: grid!(SIDE, SIDE) =
        Grid::from_words(room_words::<SIDE, SIDE, { row_words(SIDE) }>(Pose::ORIGIN));
    /// The same room after the robot turned right by 30° and moved a little.
    static SECOND: grid!(SIDE, SIDE) =
        Grid::from_words(room_words::<SIDE, SIDE, { row_words(SIDE) }>(Pose {
            degrees: TURN_DEGREES as f64,
            dx: SHIFT.0,
            dy: SHIFT.1,
        }));

    #[cfg_attr(target_arch = "arm", cortex_m_rt::entry)]
    #[cfg_attr(target_arch = "riscv32", riscv_rt::entry)]
    fn main() -> ! {
        let mut pin = ScopePin::default();
        let mut estimator = Estimator::new(Mode::Improved);
        defmt::println!(
            "two_grids: {=usize}² cells, N_THETA = {=usize}, {=u32} and {=u32} occupied",
            SIDE,
            N_THETA,
            FIRST.occupied(),
            SECOND.occupied()
        );

        let Ok(estimate) = support::timed(&mut pin, || estimator.estimate_pair(&FIRST, &SECOND));

        let expected = support::angle_of_degrees(TURN_DEGREES);
        let error = support::error_millidegrees(estimate.alpha, expected);
        defmt::println!(
            "alpha = {=i32} mdeg (expected {=i32}000, error {=i32} mdeg), status {=str}, pin pulses {=u32}",
            support::millidegrees(estimate.alpha),
            TURN_DEGREES,
            error,
            support::status_name(estimate.status),
            pin.rising_edges()
        );
        // Q16.16 cells to millicells.
        let millicells = |v: Score| ((i64::from(v.to_bits()) * 1000) >> 16) as i32;
        let (tx, ty) = estimate
            .translation
            .map_or((i32::MIN, i32::MIN), |t| (millicells(t.x), millicells(t.y)));
        let (ex, ey) = (
            tx.saturating_sub((SHIFT.0 * 1000.0) as i32),
            ty.saturating_sub((SHIFT.1 * 1000.0) as i32),
        );
        defmt::println!(
            "t = ({=i32}, {=i32}) millicells (expected ({=i32}, {=i32}))",
            tx,
            ty,
            (SHIFT.0 * 1000.0) as i32,
            (SHIFT.1 * 1000.0) as i32
        );
        let translation_right = ex.unsigned_abs() <= TOLERANCE_MCELLS as u32
            && ey.unsigned_abs() <= TOLERANCE_MCELLS as u32;
        if error.abs() <= TOLERANCE_MDEG && translation_right && pin.rising_edges() == 1 {
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
