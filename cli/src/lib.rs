//! The `hough-heading` command-line tool: rotation (and translation) between
//! two binary images or laser scans, a demo on bundled data, a real-data
//! summary and figures. The binary (`src/main.rs`) parses [`Cli`] and runs
//! its [`Command`]; each command is a module of its own with its arguments
//! and its `run`. What the tool shares with the Python package (the
//! recordings' readers, the compiled configurations, the estimator's
//! options and the JSON answers) is the crate `hough-heading-recordings`.
//!
//! Exit status: 0 success; 1 some scan pairs failed (their output lines have
//! `"status": "error"`); 2 usage error, unreadable file, wrong image size or
//! empty image.
//!
//! On bare-metal targets this library is empty (`no_std`): the package is a
//! default workspace member, and `cargo build --lib --target <bare-metal>`
//! must work from the repository root.
#![cfg_attr(target_os = "none", no_std)]
#![cfg(not(target_os = "none"))]

pub mod demo;
pub mod images;
pub mod input;
pub mod jobs;
pub mod log;
pub mod mcu;
pub mod plot;
pub mod reference;
pub mod scans;
pub mod summary;
pub mod wire;

use clap::{Parser, Subcommand};
use hough_heading_recordings::Fatal;

/// Exit status: some scan pairs failed.
pub const EXIT_PAIR_ERRORS: u8 = 1;
/// Exit status: usage error or an unusable input file.
pub const EXIT_FATAL: u8 = 2;

const AFTER_HELP: &str = "\
Compiled configurations (--size × --n-theta): 64, 128, 256 × 180, 360, 720.

Conventions: α is the counter-clockwise rotation of the scene (a point p of A
appears in B at R(α)·p + t, t in pixels, x right, y up, origin at the image
centre). For scans, dθ = −α is the robot's heading change and (dx, dy) its
displacement in the frame of scan 1, as in the pair files.

Exit status: 0 success; 1 some scan pairs failed (their output lines say
\"status\": \"error\"); 2 usage error, unreadable file, wrong image size or empty
image.";

/// Rotation (and translation) between two binary images or 2D laser scans,
/// by the doubled-line Hough signature (no_std fixed-point library).
#[derive(Debug, Parser)]
#[command(name = "hough-heading", version, after_help = AFTER_HELP)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Rotation of image B relative to image A (PBM P1/P4, PNG, PGM).
    Images(images::ImagesArgs),
    /// One JSON line per scan pair of a pair file (`-` reads stdin).
    Scans(scans::ScansArgs),
    /// Runs on the bundled example data and prints a short report.
    Demo(demo::DemoArgs),
    /// PNG figures: grids, accumulators, signatures, correlation, asymmetry.
    Plot(plot::PlotArgs),
    /// Scan pairs for the firmware (`export`), and its results checked (`check`).
    Mcu(mcu::McuArgs),
    /// Motion between the scans of a recording: a CARMEN log (`.gz` too), a
    /// ROS 1 bag or a ROS 2 bag (MCAP or SQLite); one JSON line per scan pair.
    Log(Box<log::LogArgs>),
    /// A raw lidar capture (LD06, RPLIDAR, YDLIDAR, XV-11; bytes or hex text)
    /// as a CARMEN log, one `ROBOTLASER1` line per revolution.
    ///
    /// The robot's pose is written as unknown (`PARAM hough_heading_odometry
    /// none`); the times are each revolution's own (LD06 stamps, XV-11
    /// motor periods) or, for captures without a clock, the index with
    /// `PARAM hough_heading_clock none`. A failed run writes no file.
    Wire(wire::WireArgs),
    /// One scan of a pair file as a stored scan reference for the firmware
    /// (`ScanReference` bytes: the reference, its free space, raster and
    /// scan).
    Reference(reference::ReferenceArgs),
}

impl Command {
    /// Runs the command; the number of failed pairs.
    ///
    /// # Errors
    /// A [`Fatal`] error for unusable arguments or input files.
    pub fn run(&self) -> Result<usize, Fatal> {
        match self {
            Command::Images(args) => images::run(args).map(|()| 0),
            Command::Scans(args) => scans::run(args),
            Command::Demo(args) => demo::run(args).map(|()| 0),
            Command::Plot(args) => plot::run(args).map(|()| 0),
            Command::Mcu(args) => mcu::run(args),
            Command::Log(args) => log::run(args),
            Command::Wire(args) => wire::run(args).map(|_| 0),
            Command::Reference(args) => reference::run(args).map(|()| 0),
        }
    }
}
