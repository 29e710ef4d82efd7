//! Rotation of a robot between two binary images or laser scans, by a
//! doubled-line Hough signature: `no_std`, fixed point, allocation-free,
//! panic-free.
//!
//! Each grid is reduced to a signature `D(θ)` of its Hough transform (every
//! line voted twice, as `(θ, ρ)` and `(θ + π, −ρ)`); the circular correlation
//! of two signatures gives the rotation α modulo π, a test on the ρ-profiles
//! of the strongest columns chooses between α and α + π and gives the
//! translation (and optionally the scale), and, by default, the candidates are
//! verified by aligning the grids themselves.
//!
//! # Usage
//!
//! ```
//! use hough_heading::{estimator, grid, Angle, Mode, Status};
//!
//! type Grid = grid!(128, 128); // 128 × 128 cells, bit-packed: 2 KiB
//! type Estimator = estimator!(128, 128, 360); // 360 θ steps over the full circle
//!
//! let (mut before, mut after) = (Grid::new(), Grid::new());
//! for i in 0..60 {
//!     let i = i as f32;
//!     before.set_point(i - 30.0, -20.0).unwrap(); // a wall along x, an L with a wall along y
//!     before.set_point(-30.0, i - 20.0).unwrap();
//!     after.set_point(20.0, i - 30.0).unwrap(); // the same L turned by 90° counter-clockwise
//!     after.set_point(20.0 - i, -30.0).unwrap();
//! }
//! let mut estimator = Estimator::new(Mode::Improved);
//! // A robot keeps a prepared reference (storable as bytes) and estimates
//! // each new grid against it.
//! let reference = estimator.reference(&before);
//! let estimate = estimator.estimate(&reference, &after);
//! assert!(estimate.alpha.distance(Angle::from_degrees(90.0)).to_degrees() < 0.5);
//! assert_ne!(estimate.status, Status::NoStructure);
//! ```
//!
//! Laser scans become grids with a [`Raster`] ([`Raster::rasterize`]); an
//! estimate on two rasterised scans is judged again on their beams with
//! [`Raster::check_on_beams`] (flagged, or replaced by a rival the beams
//! clearly prefer), refined on them with [`Raster::refine_on_beams`], and
//! becomes the robot's [`Motion`] with [`Raster::motion`].
//!
//! # Conventions
//!
//! Grids are centred, x to the right (columns), y up (rows count down). α is
//! the counter-clockwise rotation of the scene: a point `p` of the reference
//! appears in the new grid at `s·R(α)·p + t` (`t` in cells, `s` = 1 unless
//! the scale is searched). Angles are binary ([`Angle`]: 2³² to the turn),
//! scores Q16.16 ([`Score`]).
//!
//! # Architecture: the pipeline, one module per stage
//!
//! The modules follow the data; each imports only the ones above it (no
//! cycle), and the root only re-exports.
//!
//! | module | stage |
//! |---|---|
//! | `math` | ground floor: integer and `const` roots, parabolic vertex, sorted insert, dot product (each with its error bound) |
//! | [`config`] | derived sizes of a configuration (the macros' const fns) and its compile-time checks |
//! | `angle`, `grid`, `error` | binary angles, bit-packed grids, the error type |
//! | `trig` | Q15 sin/cos tables built at compile time |
//! | `accumulator` | Hough votes: columns, split votes at a scale, mirroring (θ + π) |
//! | `signature` | `D(θ)` and the asymmetry map `S(θ)` of each column |
//! | `correlation` | circular Pearson correlation of two signatures, its peaks |
//! | `profile` | matching a reference ρ-profile against a column (shift, runners-up) |
//! | `direction` | α versus α + π: the paper's asymmetry test and the improved profile test, one shape |
//! | `pose/` | translation fit, scale search, and the verification's pyramid, branch-and-bound search and ICP |
//! | `reference` | a prepared reference grid and its bytes |
//! | `estimate/` | the orchestration ([`Estimator`]), the answer types, the verification driver |
//! | `scan`, `motion` | laser scan → grid and free space; the estimate refined on the beams (`scan/refine`); estimate → robot motion |
//!
//! A change goes where its stage is: a new vote scheme in `accumulator`, a
//! new half-turn test in `direction`, another pose search in `pose/`.
//!
//! # Guarantees
//!
//! No panic on any input (every public function returns a value or an
//! [`Error`]; checked by linking a Cortex-M4F binary that calls every public
//! item against an undefined panic handler), no allocation, no `unsafe`
//! (`forbid(unsafe_code)`), no overflow at the largest accepted configuration
//! (W, H ≤ 2048, `N_THETA` ≤ 4096, checked at compile time). The proofs, the
//! worst cases per type and what degenerate inputs return are in
//! `docs/guarantees.md` of the repository.
//!
//! # Feature flags
//!
//! * `defmt`: derives `defmt::Format` on the public types (for logging on
//!   microcontrollers).
//! * `reach-tables` (on by default): each [`Reference`] keeps the reach
//!   tables of its grid (`12·RW·H` bytes more, 6 KiB at 128²; in flash with
//!   a reference stored as a `static`): the verification's branch and bound
//!   reads one bit a point where it read up to 18 grid rows, with the same
//!   answers bit for bit (Cortex-M4F, 128²: the real pairs' estimate median
//!   14.1 M → 10.7 M instructions). A board that builds its references at run
//!   time in little RAM (the 16 KiB Cortex-M0) turns it off with
//!   `default-features = false`.
//!
//! # Public API
//!
//! At the root, what a firmware author needs:
//!
//! * [`Estimator`] (with [`Mode`], [`Thresholds`], [`Prior`], [`ScaleRange`])
//!   and [`Reference`]; the macros [`grid!`], [`estimator!`], [`reference!`]
//!   that fill in the derived sizes (the const fns they use are in
//!   [`config`]);
//! * [`Grid`], [`Angle`], [`Score`], [`Error`];
//! * the answer: [`Estimate`], [`Status`], [`Candidate`]
//!   ([`stages::MAX_CANDIDATES`]), [`HalfTurn`] (its test:
//!   [`stages::HalfTurnTest`]), [`Pose`]
//!   (the pose: translation, scale, residual);
//! * scans: [`Scan`], [`SensorOffset`], [`Raster`], [`ScanStats`],
//!   [`FreeSpace`] (what the beams saw through), [`BeamCheck`] /
//!   [`stages::BeamPose`] / [`stages::BeamAgreement`] (the check on the
//!   beams), [`BeamFit`] /
//!   [`BeamFitError`] (the refinement on the beams), [`Motion`].
//!
//! Under [`config`]: the sizes (`row_words`, `half_turn_steps`, `rho_bins`,
//! `pyramid_words`, `recommended_n_theta`, …). Under [`stages`]: every
//! stage on its own (votes, signatures, correlation, profile matches, the
//! translation fit, trig tables), for tests, the no-panic harness and the
//! curious.

#![no_std]
#![forbid(unsafe_code)]

mod accumulator;
mod angle;
pub mod config;
mod correlation;
mod direction;
mod error;
mod estimate;
mod grid;
mod math;
mod motion;
pub mod odometry;
pub mod place;
mod pose;
mod profile;
mod reference;
mod scan;
mod signature;
mod trig;

pub use angle::Angle;
pub use direction::HalfTurn;
pub use error::Error;
pub use estimate::{Candidate, Estimate, Estimator, Mode, Prior, Status, Thresholds};
pub use grid::Grid;
pub use motion::Motion;
pub use pose::scale::ScaleRange;
pub use pose::Pose;
pub use reference::{Reference, ScanReference};
pub use scan::{
    BeamCheck, BeamFit, BeamFitError, FreeSpace, Raster, Scan, ScanStats, SensorOffset,
};

/// The pipeline's stages on their own, below the [`Estimator`]: Hough votes,
/// signatures, the correlation, profile matches, the paper's direction
/// score, the translation fit, the trig tables and the reference's parts.
/// For tests, the no-panic harness and users who want to look inside; a
/// firmware author needs none of it. Each item documents its units and
/// bounds where it is defined.
pub mod stages {
    pub use crate::accumulator::{
        vote_column, vote_column_pair, vote_column_split, Accumulator, Column, MAX_INV_SCALE_Q16,
        SPLIT_VOTE_BITS, UNIT_SCALE_Q16,
    };
    pub use crate::correlation::{Correlation, Peak, MAX_PEAKS};
    pub use crate::direction::{paper_asymmetry, HalfTurnTest};
    pub use crate::estimate::MAX_CANDIDATES;
    pub use crate::pose::scale::MAX_COARSE_STEPS;
    pub use crate::pose::{fit_translation, ColumnShift, MAX_FIT_COLUMNS};
    pub use crate::profile::{
        match_profile, match_profile_near, ProfileMatch, Shift, RUNNERS_UP, RUNNER_UP_SEPARATION,
    };
    pub use crate::reference::{Profile, PROFILE_COLUMNS, REFERENCE_FORMAT, SCAN_REFERENCE_FORMAT};
    pub use crate::scan::{
        range_percentile, BeamAgreement, BeamEnd, BeamPose, ScanBeams, AUTO_MAX_RADIUS_M,
        AUTO_MIN_RADIUS_M, AUTO_PERCENTILE, BEAM_FAR_CELLS, BEAM_FIT_MAX_ITERATIONS,
        BEAM_FIT_MAX_ROTATION_DEG, BEAM_FIT_MAX_SHIFT_CELLS, BEAM_FIT_MIN_PAIRS, BEAM_MATCH_M,
        BEAM_MAX_MISSING, BEAM_MIN_SCORE, BEAM_NEAR_CELLS, BEAM_RIVAL_MAX_ROTATION_DEG,
        BEAM_SEEN_THROUGH_CONFIDENCE, BEAM_SEEN_THROUGH_M, BEAM_SEEN_THROUGH_WEIGHT,
        BEAM_SEGMENT_MAX_M, BEAM_SWITCH_LEAD, BEAM_TRIM_MAX_M, BEAM_TRIM_MIN_M, FREE_MARGIN_CELLS,
        FREE_MARGIN_SHIFT,
    };
    pub use crate::signature::{ColumnStats, PeakKind, Signature, ASYMMETRY_FRACTION_BITS};
    pub use crate::trig::{TrigTable, TRIG_FRACTION_BITS};
}

// The README's examples run as doctests (`cargo test --doc`), so the user
// guide cannot drift from the API.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;

/// Scores (correlations, margins, confidence) in Q16.16.
pub type Score = fixed::types::I16F16;

/// The [`Grid`] type for a `W × H` image: `grid!(128, 128)`.
#[macro_export]
macro_rules! grid {
    ($w:expr, $h:expr) => {
        $crate::Grid<{ $w }, { $h }, { $crate::config::row_words($w) }>
    };
}

/// The [`Estimator`] type for `W × H` grids and `N_THETA` steps over the full
/// circle: `estimator!(128, 128, 360)`.
#[macro_export]
macro_rules! estimator {
    ($w:expr, $h:expr, $n:expr) => {
        $crate::Estimator<
            { $w },
            { $h },
            { $crate::config::row_words($w) },
            { $n },
            { $crate::config::half_turn_steps($n) },
            { $crate::config::rho_bins($w, $h) },
            { $crate::config::pyramid_words($w, $h) },
        >
    };
}

/// The [`Reference`] type matching `estimator!(W, H, N_THETA)`.
#[macro_export]
macro_rules! reference {
    ($w:expr, $h:expr, $n:expr) => {
        $crate::Reference<
            { $w },
            { $h },
            { $crate::config::row_words($w) },
            { $crate::config::half_turn_steps($n) },
            { $crate::config::rho_bins($w, $h) },
        >
    };
}

/// The [`ScanReference`] type matching `estimator!(W, H, N_THETA)` that
/// stores a scan of up to `BEAMS` readings (e.g. 1081 for a 270° scanner at
/// ¼°): `scan_reference!(W, H, N_THETA, BEAMS)`.
#[macro_export]
macro_rules! scan_reference {
    ($w:expr, $h:expr, $n:expr, $beams:expr) => {
        $crate::ScanReference<
            { $w },
            { $h },
            { $crate::config::row_words($w) },
            { $crate::config::half_turn_steps($n) },
            { $crate::config::rho_bins($w, $h) },
            { $beams },
        >
    };
}
