//! Support shared by the firmware examples (`two_grids`, `robot_loop`,
//! `bench`), for bare-metal targets only.
//!
//! - Runtime: `cortex-m-rt` on Arm, `riscv-rt` on RISC-V; each example marks its
//!   `main` with the runtime's `entry` attribute.
//! - Logging: `defmt` frames over semihosting (`defmt-semihosting`) on the
//!   host's standard output; `tools/budgets` (`hh-fw run`) decodes them with the
//!   ELF, as `defmt-print -e ELF` would.
//! - Exit: semihosting `SYS_EXIT_EXTENDED`, so QEMU exits with the firmware's
//!   status ([`EXIT_WRONG_ESTIMATE`] on a wrong answer). A panic prints its
//!   message on the host's standard error and exits with 101 (the
//!   `semihosting` crate's panic handler; `panic-probe` would hang QEMU).
//! - [`ScopePin`]: an `embedded-hal` output pin raised around each estimate, so
//!   a scope on a real board times it; under QEMU a dummy that counts edges.
//! - [`room`]: the test scenes, rasterised at compile time into flash.

pub mod room;

use core::convert::Infallible;

use embedded_hal::digital::{ErrorType, OutputPin};
use hough_heading::{Angle, Status};

// Link the critical-section implementation that `defmt-semihosting` needs.
#[cfg(target_arch = "arm")]
use cortex_m as _;
#[cfg(target_arch = "riscv32")]
use riscv as _;
// The global `defmt` logger.
use defmt_semihosting as _;

/// Exit status when an estimate is not the expected angle.
pub const EXIT_WRONG_ESTIMATE: i32 = 1;

/// Ends the program: QEMU exits with `code`.
pub fn exit(code: i32) -> ! {
    semihosting::process::exit(code)
}

/// An `embedded-hal` output pin for timing the estimate on a scope.
///
/// On a board, use the HAL's GPIO pin instead; under QEMU this stand-in keeps
/// the level and counts rising edges, so the examples can check that the pin
/// really framed each estimate.
#[derive(Debug, Default)]
pub struct ScopePin {
    high: bool,
    rising_edges: u32,
}

impl ScopePin {
    /// Number of low → high transitions so far.
    pub fn rising_edges(&self) -> u32 {
        self.rising_edges
    }
}

impl ErrorType for ScopePin {
    type Error = Infallible;
}

impl OutputPin for ScopePin {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.high = false;
        Ok(())
    }

    fn set_high(&mut self) -> Result<(), Infallible> {
        if !self.high {
            self.rising_edges += 1;
        }
        self.high = true;
        Ok(())
    }
}

/// Runs `work` with `pin` high, as a scope trigger around it.
pub fn timed<P: OutputPin, T>(pin: &mut P, work: impl FnOnce() -> T) -> Result<T, P::Error> {
    pin.set_high()?;
    let out = work();
    pin.set_low()?;
    Ok(out)
}

/// An angle in whole millidegrees in (−180 000, 180 000], computed in integers
/// (no float on the M0).
pub fn millidegrees(angle: Angle) -> i32 {
    ((i64::from(angle.signed()) * 360_000) >> 32) as i32
}

/// The binary angle of `degrees` (any integer, wrapped).
pub const fn angle_of_degrees(degrees: i32) -> Angle {
    Angle(((degrees as i64).rem_euclid(360) * (1i64 << 32) / 360) as u32)
}

/// `got − expected` wrapped to (−180°, 180°], in millidegrees.
pub fn error_millidegrees(got: Angle, expected: Angle) -> i32 {
    millidegrees(Angle(got.0.wrapping_sub(expected.0)))
}

/// A short name of an estimate's status, for the log.
pub fn status_name(status: Status) -> &'static str {
    match status {
        Status::Confident => "confident",
        Status::AmbiguousDirection => "ambiguous-direction",
        Status::AmbiguousAxis => "ambiguous-axis",
        Status::LowOverlap => "low-overlap",
        Status::NoStructure => "no-structure",
        Status::SearchCut => "search-cut",
    }
}
