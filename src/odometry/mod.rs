//! A robot's stream of scans chained into one path: keyframe odometry
//! that never guesses a step it can bridge, with an honest heading
//! uncertainty, and the heading correction a loop closure brings.
//!
//! * [`KeyframeOdometry`] ([`chain`]): each scan is
//!   placed by a confident estimate against a stored scan (the keyframe,
//!   the last placed scan, the previous keyframe); a scan that none places
//!   is left out of the chain, its pose predicted, and only after
//!   [`KeyframeSettings::max_unplaced`] such scans does the chain carry a
//!   prediction, with a heading σ that says so.
//! * [`HeadingCorrection`]: on a confident loop closure, the heading error
//!   spread over the keyframes since the last anchor, each by its share of
//!   the chain's heading variance.
//!
//! # Conventions
//!
//! Poses ([`RobotPose`]) are the robot's, in the frame of the first scan:
//! metres, x forward, y left, heading counter-clockwise (a binary
//! [`Angle`](crate::Angle)). A step is the robot's [`Motion`](crate::Motion) from one
//! scan to another (the scan-pair files' convention;
//! [`Raster::motion`](crate::Raster::motion)), and a prior is on the
//! estimator's α = −dθ (DESIGN.md §2). Heading σ are in degrees (`f32`).
//!
//! # Numbers
//!
//! `f32` for positions and σ, a binary angle for the heading, the library's
//! Q16 sine table (error below 2·10⁻⁵) for rotations: a few dozen float
//! operations a scan, no trigonometric function. No allocation, no panic.

pub mod chain;
mod correction;
mod pose;
pub mod settings;

pub use chain::{Against, KeyframeOdometry, Step, StepSource};
pub use correction::{HeadingCorrection, MAX_CORRECTED_KEYFRAMES};
pub use pose::RobotPose;
pub use settings::{
    prior_sigma_for_interval, KeyframeSettings, DENSE_INTERVAL_S, MAX_TURN_RATE_DEG_S,
    TURN_KEPT_DIVISOR,
};
