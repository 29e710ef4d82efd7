//! Host side of hough-heading: the float references of the paper and of the
//! verification by alignment, and the test kit (the scene generator with its
//! damage and rendering, evaluations). The command-line tool is the package
//! `hough-heading-cli` (`cli/`).
//!
//! On bare-metal targets this crate is empty (`no_std`): it is a default
//! workspace member, and `cargo build --lib --target <bare-metal>` must work.
#![cfg_attr(target_os = "none", no_std)]
#[cfg(not(target_os = "none"))]
pub mod eval;
#[cfg(not(target_os = "none"))]
pub mod fuzz;
#[cfg(not(target_os = "none"))]
pub mod pose_reference;
#[cfg(not(target_os = "none"))]
pub mod raycast;
#[cfg(not(target_os = "none"))]
pub mod reference;
#[cfg(not(target_os = "none"))]
pub mod scene;
/// The project's one quantile (nearest rank) and Markdown table rows: the
/// host library's file `recordings/src/stats.rs`, compiled here too so that the test kit's
/// figures and the tool's are the same statistic.
#[cfg(not(target_os = "none"))]
#[path = "../../recordings/src/stats.rs"]
pub mod stats;
#[cfg(not(target_os = "none"))]
pub mod verify_reference;
