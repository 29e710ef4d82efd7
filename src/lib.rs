#![no_std]
#![forbid(unsafe_code)]
#![doc = include_str!("../README.md")]

mod accumulator;
mod angle;
mod config;
mod correlation;
mod direction;
mod error;
mod estimate;
mod grid;
mod math;
mod motion;
mod pose;
mod profile;
mod reference;
mod scan;
mod signature;
mod trig;

pub use accumulator::{
    vote_column, vote_column_pair, vote_column_split, Accumulator, Column, MAX_INV_SCALE_Q16,
    SPLIT_VOTE_BITS, UNIT_SCALE_Q16,
};
pub use angle::Angle;
pub use config::{
    align_points, half_turn_steps, icp_points, max_votes_per_bin, pyramid_levels, pyramid_words,
    recommended_n_theta, rho_bins, row_words, ALIGN_POINTS,
};
pub use correlation::{Correlation, Peak, MAX_PEAKS};
pub use direction::{paper_asymmetry, HalfTurn, HalfTurnTest};
pub use error::Error;
pub use estimate::{
    Candidate, Estimate, Estimator, Mode, Prior, Status, Thresholds, MAX_CANDIDATES,
};
pub use grid::Grid;
pub use motion::Motion;
pub use pose::scale::{ScaleRange, MAX_COARSE_STEPS};
pub use pose::{fit_translation, ColumnShift, Translation, WeightedShift, MAX_FIT_COLUMNS};
pub use profile::{
    match_profile, match_profile_near, ProfileMatch, RunnerUp, RUNNERS_UP, RUNNER_UP_SEPARATION,
};
pub use reference::{Profile, Reference, PROFILE_COLUMNS, REFERENCE_FORMAT};
pub use scan::{
    range_percentile, Raster, Scan, ScanStats, SensorOffset, AUTO_MAX_RADIUS_M, AUTO_MIN_RADIUS_M,
    AUTO_PERCENTILE,
};
pub use signature::{ColumnStats, PeakKind, Signature, ASYMMETRY_FRACTION_BITS};
pub use trig::{TrigTable, TRIG_FRACTION_BITS};

/// Scores (correlations, margins, confidence) in Q16.16.
pub type Score = fixed::types::I16F16;

/// The [`Grid`] type for a `W × H` image: `grid!(128, 128)`.
#[macro_export]
macro_rules! grid {
    ($w:expr, $h:expr) => {
        $crate::Grid<{ $w }, { $h }, { $crate::row_words($w) }>
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
            { $crate::row_words($w) },
            { $n },
            { $crate::half_turn_steps($n) },
            { $crate::rho_bins($w, $h) },
            { $crate::pyramid_words($w, $h) },
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
            { $crate::row_words($w) },
            { $crate::half_turn_steps($n) },
            { $crate::rho_bins($w, $h) },
        >
    };
}
