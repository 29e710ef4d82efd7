//! Host side of hough-heading: the float references of the paper and of the
//! verification by alignment, the scene generator, evaluations and the
//! command-line tool's modules.
//!
//! On bare-metal targets this crate is empty (`no_std`): it is a default
//! workspace member, and `cargo build --lib --target <bare-metal>` must work.
#![cfg_attr(target_os = "none", no_std)]
#[cfg(not(target_os = "none"))]
pub mod cli;
#[cfg(not(target_os = "none"))]
pub mod eval;
#[cfg(not(target_os = "none"))]
pub mod pose_reference;
#[cfg(not(target_os = "none"))]
pub mod reference;
#[cfg(not(target_os = "none"))]
pub mod scene;
#[cfg(not(target_os = "none"))]
pub mod verify_reference;
