//! The host library under the `hough-heading` tool and its Python package.
//!
//! **Recordings.** One reader a format, every one yielding the same
//! [`Event`]s ([`Scan`] or [`Odometry`]) or a [`RecordError`] for a record
//! it skips, and failing with [`Fatal`] when nothing more can be read:
//! CARMEN logs ([`carmen`], plain or gzip), ROS 1 bags ([`ros1`]), ROS 2 bags
//! in MCAP ([`ros2`]) or SQLite ([`db3`]) and their directories
//! ([`bagdir`]), raw lidar captures ([`wire`]). [`open_recording`] opens any
//! of them by option or by content. Consecutive estimates chain into a
//! [`trajectory`], written for `evo` (TUM, KITTI) or as CSV and scored by
//! APE and RPE ([`evo`]).
//!
//! **Estimates.** The compiled configurations of the estimator
//! ([`engine`], listed once: [`with_configurations!`]), the options the tool
//! and the Python package parse alike ([`options`]), and their answers as
//! JSON: image pairs ([`answer`], [`image`]) and scan pairs ([`pairs`]).
//!
//! It depends on the library and `hough-lidar`, never on the tool. On
//! bare-metal targets it is empty (`no_std`): the package is a default
//! workspace member, and `cargo build --lib --target <bare-metal>` must work
//! from the repository root.
#![cfg_attr(target_os = "none", no_std)]
#![cfg(not(target_os = "none"))]

pub mod answer;
pub mod bagdir;
pub mod capture_file;
pub mod carmen;
pub mod chain_report;
pub mod db3;
pub mod engine;
pub mod error;
pub mod evo;
pub mod image;
pub mod line;
pub mod mcu_pairs;
pub mod model;
pub mod open;
pub mod options;
pub mod pairs;
pub mod ros1;
pub mod ros2;
pub mod stats;
pub mod tf;
pub mod trajectory;
pub mod wire;

pub use error::{Fatal, RecordError};
pub use model::{Event, Odometry, Pose, Scan};
pub use open::{open_recording, Format, Opened, Recording, Source};
