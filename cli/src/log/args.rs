//! The options of `log FILE`.

use std::path::PathBuf;

use clap::{Args, ValueEnum};
use hough_heading_recordings::options::{BeamArgs, EstimatorArgs, ScanGridArgs};
use hough_heading_recordings::{Format, Source};

use crate::jobs::JobsArgs;

/// Which scan pairs are estimated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum PairsArg {
    /// Keyframes on a dense stream (its first two scans at most 0.25 s
    /// apart by their times), else consecutive pairs (also when the scans
    /// carry no times, or with a `--prior` other than `motion`). On the
    /// shared dense streams keyframes drifted less (`docs/drift.md`); on
    /// logs kept every metre they did not. `log` says which it took.
    Auto,
    /// Each scan against the previous one (with `--every N`: scans 0, N, 2N, …).
    Consecutive,
    /// Each later scan against scan `--reference`.
    Reference,
    /// Every pair at most `--window` scans (and `--window-s` seconds) apart
    /// (loop-closure candidates).
    Window,
    /// Keyframe odometry: each scan against the current keyframe, a new
    /// keyframe when the overlap falls below 0.6, the robot turned 30° or
    /// moved 1 m since it, or a scan was placed against another stored
    /// scan; always with the motion prior.
    Keyframes,
}

impl PairsArg {
    /// The pairs make a stream the chain follows (consecutive, keyframes,
    /// or either).
    pub fn chains(self) -> bool {
        matches!(self, Self::Auto | Self::Consecutive | Self::Keyframes)
    }

    /// Its name, for the summary's heading and the run's last line.
    pub fn name(self) -> &'static str {
        match self {
            Self::Auto => "auto",
            Self::Consecutive => "consecutive",
            Self::Reference => "reference",
            Self::Window => "window",
            Self::Keyframes => "keyframe",
        }
    }
}

/// Where the rotation prior comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum PriorArg {
    /// No prior.
    None,
    /// The log's odometry delta between the two scans.
    Odom,
    /// Constant velocity: the chain's last step, repeated (scaled by the
    /// scans' times when known). Consecutive pairs and keyframes only: a
    /// flagged pair, or one beyond 3σ of the prediction, is estimated again
    /// with it, and a flagged answer no candidate of which lies within 3σ
    /// is replaced by the prediction (marked in the line's `chain`).
    Motion,
}

/// `log FILE`.
#[derive(Clone, Debug, Args)]
pub struct LogArgs {
    /// The recording: a CARMEN log (`.gz` read directly), a ROS 2 bag (its
    /// directory, or its `.mcap` or `.db3` file), a ROS 1 bag (`.bag`), or a
    /// raw lidar capture (`--format ld06|rplidar|ydlidar|xv11`).
    pub file: PathBuf,
    /// Input format.
    #[arg(long, value_enum, default_value_t = Format::Auto)]
    pub format: Format,
    /// Bags: the `LaserScan` topic (without it, the bag's only one, or the
    /// bag's topics are listed).
    #[arg(long)]
    pub topic: Option<String>,
    /// Bags: the `Odometry` topic (default `/odom` when the bag has it, else
    /// the bag's `/tf`: its `odom` → `base_link` transform).
    #[arg(long, value_name = "TOPIC")]
    pub odom_topic: Option<String>,
    /// Which pairs.
    #[arg(long, value_enum, default_value_t = PairsArg::Auto)]
    pub pairs: PairsArg,
    /// Use every N-th scan only (scans 0, N, 2N, …).
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub every: usize,
    /// `--pairs reference`: the reference scan's index.
    #[arg(long, value_name = "INDEX", default_value_t = 0)]
    pub reference: usize,
    /// `--pairs window`: pairs at most this many used scans apart (with
    /// `--every N`, N × this many scans of the recording).
    #[arg(long, value_name = "SCANS", default_value_t = 10)]
    pub window: usize,
    /// `--pairs window`: and at most this many seconds apart.
    #[arg(long, value_name = "SECONDS")]
    pub window_s: Option<f64>,
    /// `odom`: the odometry's rotation picks among the candidates (within
    /// 3 × `--prior-sigma`); `motion`: the chain's constant-velocity
    /// prediction does. Default: `motion` for consecutive and keyframe
    /// pairs (a robot's stream), `none` for the others.
    #[arg(long, value_enum)]
    pub prior: Option<PriorArg>,
    /// One standard deviation of the prior, degrees (default 10 for `odom`,
    /// 30 for `motion` and keyframes).
    #[arg(long, value_name = "DEGREES")]
    pub prior_sigma: Option<f64>,
    /// Loop closures and a pose graph at the end of a chained run: the
    /// corrected poses go to `--trajectory`, `--plot` and `--summary` (the
    /// JSON lines keep the chain's). The default on every chained run (on
    /// the shared logs, captures and dense streams no wrong closure got in,
    /// and the largest heading error fell; `docs/drift.md`); the flag says
    /// so explicitly.
    #[arg(long, conflicts_with = "no_loops")]
    pub loops: bool,
    /// No loop closures (the chain's own poses everywhere).
    #[arg(long)]
    pub no_loops: bool,
    /// Writes the pose graph as `.g2o` (VERTEX_SE2, EDGE_SE2) for g2o or
    /// GTSAM users (a chained run with loop closures).
    #[arg(long, value_name = "FILE", conflicts_with = "no_loops")]
    pub g2o: Option<PathBuf>,
    /// Writes every loop closure tried as CSV: its scans, its heading
    /// change, the chain's and the optimized trajectory's between the same
    /// scans, the differences before and after the graph (degrees), and
    /// whether it was accepted (a chained run with loop closures).
    #[arg(long, value_name = "FILE", conflicts_with = "no_loops")]
    pub closures: Option<PathBuf>,
    /// Shorthand for `--pairs keyframes`.
    #[arg(long, conflicts_with = "pairs")]
    pub keyframes: bool,
    /// Writes the chained consecutive estimates as poses: `FILE.tum` (TUM,
    /// `t x y z qx qy qz qw`, times from the recording) or `FILE.kitti`
    /// (KITTI rows) for evo, with `FILE-reference` (the log's poses) and
    /// `FILE-odometry` beside it; any other name: CSV (scan, t, x, y, θ,
    /// source, with the odometry's and the log's poses).
    #[arg(long, value_name = "FILE")]
    pub trajectory: Option<PathBuf>,
    /// Draws the trajectory over the odometry's (and the log's poses), with
    /// the scans projected (PNG).
    #[arg(long, value_name = "PNG")]
    pub plot: Option<PathBuf>,
    /// Scores the estimates against the log's poses (the corrected poses of a
    /// Radish `-corrected` log's `FLASER` lines), like `scans --summary`;
    /// with consecutive pairs also the chained trajectory's (and the
    /// odometry's) APE and RPE, as `evo_ape` / `evo_rpe` define them.
    #[arg(long)]
    pub summary: bool,
    /// Only the first N scans.
    #[arg(long, value_name = "N")]
    pub limit: Option<usize>,
    /// CARMEN `FLASER`: "no return" at or beyond this, metres (`ROBOTLASER1`
    /// and LaserScan carry their own).
    #[arg(long, value_name = "METRES", default_value_t = 81.91)]
    pub max_range: f32,
    /// CARMEN `FLASER` and LaserScan: the laser pose `X,Y,THETA` (metres,
    /// radians) in the robot frame (`ROBOTLASER1` carries its own).
    #[arg(long, value_name = "X,Y,THETA", value_delimiter = ',', num_args = 3)]
    pub laser_offset: Option<Vec<f32>>,
    /// No progress bar or timing line.
    #[arg(long, short)]
    pub quiet: bool,
    /// Threads.
    #[command(flatten)]
    pub jobs: JobsArgs,
    /// How scans become grids.
    #[command(flatten)]
    pub grid: ScanGridArgs,
    /// What the beams do after the grid estimate.
    #[command(flatten)]
    pub beams: BeamArgs,
    /// Estimator options.
    #[command(flatten)]
    pub estimator: EstimatorArgs,
}

impl LogArgs {
    /// The pairs asked for (`--keyframes` is `--pairs keyframes`).
    pub fn pairs(&self) -> PairsArg {
        if self.keyframes {
            PairsArg::Keyframes
        } else {
            self.pairs
        }
    }

    /// The prior asked for, or the pairs' default (`motion` for a stream:
    /// consecutive and keyframe pairs).
    pub fn prior(&self) -> PriorArg {
        match (self.prior, self.pairs()) {
            (_, PairsArg::Keyframes) => PriorArg::Motion,
            (Some(p), _) => p,
            (None, PairsArg::Consecutive | PairsArg::Auto) => PriorArg::Motion,
            (None, _) => PriorArg::None,
        }
    }

    /// The prior's σ, degrees: `--prior-sigma`, or the prior's default.
    pub fn prior_sigma(&self) -> f64 {
        let default = if self.chained() { 30.0 } else { 10.0 };
        self.prior_sigma.unwrap_or(default)
    }

    /// The run closes loops: a chained run without `--no-loops`.
    pub fn closes_loops(&self) -> bool {
        self.chained() && !self.no_loops
    }

    /// The run chains the scans (motion prior or keyframes).
    pub fn chained(&self) -> bool {
        self.prior() == PriorArg::Motion
    }

    /// What [`open_recording`](hough_heading_recordings::open_recording)
    /// opens: the file and the reading options (a `--laser-offset` of three
    /// numbers, as `run` checks it).
    pub fn source(&self) -> Source {
        Source {
            file: self.file.clone(),
            format: self.format,
            topic: self.topic.clone(),
            odom_topic: self.odom_topic.clone(),
            max_range: self.max_range,
            laser_offset: self
                .laser_offset
                .as_ref()
                .filter(|v| v.len() == 3)
                .map(|v| [v[0], v[1], v[2]]),
        }
    }
}
