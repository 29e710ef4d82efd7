//! `log FILE`: the motion between the scans of a robot's recording, a CARMEN
//! log (plain or `.gz`), a ROS 2 bag (MCAP or SQLite) or a ROS 1 bag.
//!
//! The recording is streamed: only the scans a pair still needs are kept
//! (one for consecutive pairs, the reference scan, or the window). Each pair
//! goes through the same path as a line of a pair file (`scans::estimate`),
//! so its output equals `scans` on the same two scans bit for bit; with
//! `--prior odom` the log's odometry delta is the prior on the rotation.
//!
//! Exit status: 0 success; 1 some records (lines, messages) or pairs failed
//! and the rest were processed; 2 unusable arguments or file, or no usable
//! scan.

pub mod bagdir;
pub mod carmen;
pub mod chain;
pub mod db3;
pub mod evo;
pub mod ros1;
pub mod ros2;
pub mod trajectory;

use std::collections::{BTreeMap, VecDeque};
use std::fs::File;
use std::io::{self, BufRead, BufReader, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use clap::{Args, ValueEnum};
use hough_heading::{Angle, Mode, Prior};
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;

use super::engine::Engine;
use super::jobs::{JobsArgs, Workers};
use super::scans::{self, Check, OutputLine, PairRecord, RasterOptions, ScanRecord, Truth};
use super::summary::{Method, Summary};
use super::{BeamArgs, EstimatorArgs, Fatal, ScanGridArgs};
use carmen::{CarmenReader, FlaserGeometry};
use chain::{Chain, ChainLine};
use trajectory::Trajectory;

/// A planar pose: metres and radians.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// x, metres.
    pub x: f64,
    /// y, metres.
    pub y: f64,
    /// Heading, radians.
    pub theta: f64,
}

impl Pose {
    /// The origin.
    pub const ZERO: Pose = Pose {
        x: 0.0,
        y: 0.0,
        theta: 0.0,
    };

    /// `other` in the frame of `self` (the pair files' `dx, dy, dθ`).
    pub fn between(&self, other: &Pose) -> Pose {
        let (s, c) = self.theta.sin_cos();
        let (ex, ey) = (other.x - self.x, other.y - self.y);
        Pose {
            x: c * ex + s * ey,
            y: -s * ex + c * ey,
            theta: wrap_rad(other.theta - self.theta),
        }
    }

    /// `self ⊕ delta`: the pose `delta` (in the frame of `self`) in the world.
    pub fn compose(&self, delta: &Pose) -> Pose {
        let (s, c) = self.theta.sin_cos();
        Pose {
            x: self.x + c * delta.x - s * delta.y,
            y: self.y + s * delta.x + c * delta.y,
            theta: wrap_rad(self.theta + delta.theta),
        }
    }
}

/// Wraps radians to (−π, π].
pub fn wrap_rad(a: f64) -> f64 {
    scans::wrap_deg(a.to_degrees()).to_radians()
}

/// One scan of a recording.
#[derive(Clone, Debug)]
pub struct LogScan {
    /// The scan, as a pair file stores it.
    pub record: ScanRecord,
    /// Time stamp, seconds.
    pub time: Option<f64>,
    /// The odometry pose at the scan.
    pub odom: Option<Pose>,
    /// The log's own pose of the robot (`FLASER` x y θ: corrected in a
    /// Radish `-corrected` log).
    pub log_pose: Option<Pose>,
    /// Where it is in the file (`line 12`, `message 3 (topic /scan)`).
    pub name: String,
}

/// What a reader yields.
#[derive(Clone, Debug)]
pub enum Event {
    /// A laser scan.
    Scan(LogScan),
    /// An odometry pose.
    Odometry {
        /// Time stamp, seconds.
        time: Option<f64>,
        /// The pose.
        pose: Pose,
    },
}

impl Event {
    fn with_record(self, name: String) -> Self {
        match self {
            Event::Scan(mut s) => {
                s.name = name;
                Event::Scan(s)
            }
            other => other,
        }
    }

    /// The event with its record named in `file` (a split bag's part).
    fn in_file(self, file: &str) -> Self {
        match self {
            Event::Scan(mut s) => {
                s.name = format!("{file}: {}", s.name);
                Event::Scan(s)
            }
            other => other,
        }
    }
}

/// A record of the file that could not be used.
#[derive(Clone, Debug)]
pub struct RecordError {
    /// Which record (`line 12`, `message 40 (topic /scan)`).
    pub record: String,
    /// Why.
    pub message: String,
}

impl RecordError {
    fn new(record: impl Into<String>, message: impl Into<String>) -> Self {
        Self {
            record: record.into(),
            message: message.into(),
        }
    }
}

/// The format of a recording.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// By content: a directory is a ROS 2 bag, SQLite, MCAP and ROS 1 bags
    /// are known by their first bytes, anything else is read as CARMEN.
    Auto,
    /// CARMEN log (`FLASER`, `ROBOTLASER1`, `ODOM` lines), plain or gzip.
    Carmen,
    /// ROS 2 bag in MCAP: its `.mcap` file, or its directory
    /// (`metadata.yaml` and `.mcap` files, read in the order it lists them).
    Mcap,
    /// ROS 1 bag (format 2.0; chunks uncompressed, bz2 or lz4).
    Ros1,
    /// ROS 2 bag in SQLite: its directory (`metadata.yaml` and `.db3`
    /// files, read in the order it lists them) or one `.db3` file.
    Db3,
    /// Raw LDRobot LD06 / LD19 / STL-19P capture: one scan per revolution.
    Ld06,
    /// Raw Slamtec RPLIDAR capture (standard scan): one scan per revolution.
    Rplidar,
    /// Raw YDLIDAR X2 / X4 capture: one scan per revolution.
    Ydlidar,
    /// Raw Neato XV-11 / LDS02RR capture: one scan per revolution.
    Xv11,
}

/// Which scan pairs are estimated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum PairsArg {
    /// Each scan against the previous one (with `--every N`: scans 0, N, 2N, …).
    Consecutive,
    /// Each later scan against scan `--reference`.
    Reference,
    /// Every pair at most `--window` scans (and `--window-s` seconds) apart
    /// (loop-closure candidates).
    Window,
    /// Keyframe odometry: each scan against the current keyframe, a new
    /// keyframe when the overlap falls below 0.6 or an estimate is flagged;
    /// always with the motion prior.
    Keyframes,
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
    /// Bags: the `Odometry` topic (default `/odom` when the bag has it).
    #[arg(long, value_name = "TOPIC")]
    pub odom_topic: Option<String>,
    /// Which pairs.
    #[arg(long, value_enum, default_value_t = PairsArg::Consecutive)]
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

/// A relative pose in the output: degrees and metres.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Delta {
    /// Heading change, degrees.
    pub dtheta_deg: f64,
    /// x, metres, frame of scan 1.
    pub dx_m: f64,
    /// y, metres.
    pub dy_m: f64,
}

impl Delta {
    fn of(p: &Pose) -> Self {
        Self {
            dtheta_deg: scans::round(p.theta.to_degrees(), 4),
            dx_m: scans::round(p.x, 4),
            dy_m: scans::round(p.y, 4),
        }
    }
}

/// One output line: the `scans` line, and which scans, when, and the log's
/// own deltas.
#[derive(Clone, Debug, Serialize)]
pub struct LogLine {
    /// The estimate, as `scans` prints it (`index` counts the pairs).
    #[serde(flatten)]
    pub line: OutputLine,
    /// Index of the first scan in the recording (0-based, over its scans).
    pub scan1: usize,
    /// Index of the second scan.
    pub scan2: usize,
    /// Time of the first scan, seconds.
    pub t1: Option<f64>,
    /// Time of the second scan.
    pub t2: Option<f64>,
    /// The odometry's delta between the two scans.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub odom: Option<Delta>,
    /// The log's own poses' delta (`FLASER` x y θ: corrected in a Radish
    /// `-corrected` log).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub log_pose: Option<Delta>,
    /// What the chain made of the pair (`--prior motion`, `--pairs
    /// keyframes`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub chain: Option<ChainLine>,
}

/// A pair's estimate, or why there is none.
type PairResult = Result<Vec<scans::PairEstimate>, String>;

/// A scan kept for pairing, with its index.
type Kept = (usize, Arc<LogScan>);

/// A pair waiting for its estimate: the two scans and what the log says
/// about their motion.
struct PairJob {
    a: Kept,
    b: Kept,
    /// The odometry's delta.
    odom: Option<Pose>,
    /// The log's own poses' delta.
    log_pose: Option<Pose>,
    /// The prior on the rotation (`--prior odom`).
    prior: Option<Prior>,
    /// The two scans as a pair file's line.
    pair: PairRecord,
}

/// What waits to be written, in the order of the recording.
enum Pending {
    /// A pair to estimate.
    Pair(Box<PairJob>),
    /// A record that could not be used.
    Error(RecordError),
}

struct Run<'a> {
    args: &'a LogArgs,
    file: String,
    workers: Workers<Box<dyn Engine>>,
    options: RasterOptions,
    mode: Mode,
    out: BufWriter<io::StdoutLock<'static>>,
    /// Pairs and record errors not yet written: the pairs are estimated a
    /// batch at a time ([`Workers::batch`]), then everything is written in
    /// order.
    pending: Vec<Pending>,
    /// Pairs among `pending`.
    pending_pairs: usize,
    pairs: usize,
    failed: usize,
    summary: Summary,
    trajectory: Option<Trajectory>,
    /// The chain of `--prior motion` and `--pairs keyframes`.
    chain: Option<Chain>,
    stdout_closed: bool,
    bar: ProgressBar,
}

impl Run<'_> {
    /// The first scan of a chain (consecutive or keyframe pairs).
    fn start(&mut self, first: &Kept) {
        if let Some(t) = &mut self.trajectory {
            t.start(first);
        }
        if let Some(c) = &mut self.chain {
            c.start(first);
        }
    }

    /// Reports a record that could not be used, after the pairs before it.
    fn record_error(&mut self, error: RecordError) {
        self.pending.push(Pending::Error(error));
    }

    fn report(&mut self, error: &RecordError) {
        self.failed += 1;
        let text = format!(
            "hough-heading: {}: {}: {}",
            self.file, error.record, error.message
        );
        self.bar.suspend(|| eprintln!("{text}"));
    }

    /// Queues one pair; a full batch is estimated and written.
    fn pair(&mut self, a: &Kept, b: &Kept) -> Result<(), Fatal> {
        let (s1, s2) = (&a.1, &b.1);
        let odom = s1.odom.zip(s2.odom).map(|(p, q)| p.between(&q));
        let log_pose = s1.log_pose.zip(s2.log_pose).map(|(p, q)| p.between(&q));
        let prior = match (self.args.prior(), odom) {
            (PriorArg::Odom, Some(d)) => Some(Prior {
                alpha: Angle::from_degrees(-d.theta.to_degrees() as f32),
                sigma: Angle::from_degrees(self.args.prior_sigma() as f32),
            }),
            _ => None,
        };
        let pair = PairRecord {
            scan1: s1.record.clone(),
            scan2: s2.record.clone(),
        };
        self.pending.push(Pending::Pair(Box::new(PairJob {
            a: a.clone(),
            b: b.clone(),
            odom,
            log_pose,
            prior,
            pair,
        })));
        self.pending_pairs += 1;
        if self.pending_pairs >= self.workers.batch() {
            self.flush()?;
        }
        Ok(())
    }

    /// Estimates the pending pairs (on every worker) and writes them and the
    /// pending record errors in order.
    fn flush(&mut self) -> Result<(), Fatal> {
        let pending = std::mem::take(&mut self.pending);
        self.pending_pairs = 0;
        let (options, mode) = (self.options, self.mode);
        let results = self.workers.map(&pending, |engine, _, item| match item {
            Pending::Pair(job) => Some(scans::estimate_with_prior(
                engine.as_mut(),
                &job.pair,
                &options,
                &[mode],
                job.prior,
            )),
            Pending::Error(_) => None,
        });
        for (item, result) in pending.into_iter().zip(results) {
            match (item, result) {
                (Pending::Pair(job), Some(result)) => {
                    let (result, chained) = self.chain(&job, result);
                    self.write(&job, result, chained)?;
                }
                (Pending::Error(error), _) => self.report(&error),
                (Pending::Pair(_), None) => unreachable!("every pair is estimated"),
            }
        }
        Ok(())
    }

    /// Adds an estimated pair to the chain, if the run has one: the pair is
    /// estimated again with the motion prior when the chain wants it. The
    /// result (that one, then) and what the chain made of it.
    fn chain(
        &mut self,
        job: &PairJob,
        result: PairResult,
    ) -> (PairResult, Option<(ChainLine, Pose)>) {
        let Some(chain) = &self.chain else {
            return (result, None);
        };
        let prior = result.as_ref().ok().and_then(|e| chain.prior_for(&e[0]));
        let result = match prior {
            Some(prior) => {
                let (options, mode) = (self.options, self.mode);
                let again = self
                    .workers
                    .map(std::slice::from_ref(job), |engine, _, job| {
                        scans::estimate_with_prior(
                            engine.as_mut(),
                            &job.pair,
                            &options,
                            &[mode],
                            Some(prior),
                        )
                    });
                again.into_iter().next().unwrap_or(result)
            }
            None => result,
        };
        let chain = self.chain.as_mut().expect("checked above");
        let added = chain.add(&job.b, result.as_ref().ok().map(|e| &e[0]), prior, job.odom);
        (result, Some(added))
    }

    /// Writes one estimated pair's line, and adds it to the trajectory and
    /// the summary.
    fn write(
        &mut self,
        job: &PairJob,
        result: PairResult,
        chained: Option<(ChainLine, Pose)>,
    ) -> Result<(), Fatal> {
        let PairJob {
            a,
            b,
            odom,
            log_pose,
            pair,
            ..
        } = job;
        let (s1, s2) = (&a.1, &b.1);
        let index = self.pairs;
        self.pairs += 1;
        let line = match &result {
            Ok(estimates) => OutputLine::of(index, &estimates[0]),
            Err(message) => {
                let message = format!("{} and {}: {message}", s1.name, s2.name);
                self.report(&RecordError::new("pair", message.clone()));
                OutputLine::error(index, message)
            }
        };
        if let Some(t) = &mut self.trajectory {
            match &chained {
                Some((line, pose)) => t.add_chained(b, *pose, line.source),
                None => t.add(a, b, result.as_ref().ok().map(|e| &e[0]), *odom),
            }
        }
        if self.args.summary {
            match (&result, log_pose) {
                (Ok(estimates), Some(d)) => {
                    let truth = Truth {
                        dx: d.x,
                        dy: d.y,
                        dtheta: d.theta,
                        check: Check::default(),
                    };
                    let method = match self.mode {
                        Mode::Improved => Method::Improved,
                        Mode::Paper => Method::Paper,
                    };
                    self.summary
                        .add(index, &truth, pair, &[(method, &estimates[0])]);
                }
                _ => self.summary.add_error(),
            }
        }
        let text = serde_json::to_string(&LogLine {
            line,
            scan1: a.0,
            scan2: b.0,
            t1: s1.time,
            t2: s2.time,
            odom: odom.as_ref().map(Delta::of),
            log_pose: log_pose.as_ref().map(Delta::of),
            chain: chained.map(|(line, _)| line),
        })
        .map_err(|e| Fatal::io(format!("JSON output: {e}")))?;
        if !self.stdout_closed && writeln!(self.out, "{text}").is_err() {
            // stdout closed (e.g. piped into `head`): keep going for the
            // trajectory and summary, quietly.
            self.stdout_closed = true;
        }
        Ok(())
    }
}

/// Opens the file, undoing gzip (by its magic bytes), with the progress bar
/// counting the file's bytes.
pub fn open(path: &Path, bar: &ProgressBar) -> Result<Box<dyn BufRead>, Fatal> {
    let name = path.display();
    let file = File::open(path).map_err(|e| Fatal::io(format!("{name}: cannot read: {e}")))?;
    if let Ok(meta) = file.metadata() {
        bar.set_length(meta.len());
    }
    let mut raw = BufReader::new(bar.wrap_read(file));
    let gzip = raw
        .fill_buf()
        .map_err(|e| Fatal::io(format!("{name}: cannot read: {e}")))?
        .starts_with(&[0x1f, 0x8b]);
    Ok(if gzip {
        Box::new(BufReader::new(flate2::bufread::MultiGzDecoder::new(raw)))
    } else {
        Box::new(raw)
    })
}

/// The MCAP magic bytes.
pub const MCAP_MAGIC: &[u8] = b"\x89MCAP0\r\n";

/// A recording opened for reading: a raw lidar capture (read by
/// [`crate::wire::WireReader`]), or a log or bag as [`Event`]s.
pub enum Opened {
    /// A CARMEN log or a bag.
    Recording(Recording),
    /// A raw lidar capture: its protocol and bytes.
    Capture(crate::wire::Protocol, Box<dyn BufRead>),
}

/// A CARMEN log or a bag, opened: its format, a bag's scan topic, and its
/// events (scans carry `--laser-offset`).
pub struct Recording {
    /// The format read (never [`Format::Auto`]).
    pub format: Format,
    /// The scan topic of a bag.
    pub topic: Option<String>,
    /// The events in file order.
    pub events: Box<dyn Iterator<Item = ros2::BagItem>>,
}

/// Opens `args.file` as `log` reads it: the format by `--format` or by
/// content, a bag's topics chosen ([`choose_topics`]), `bar` counting the
/// bytes read.
///
/// # Errors
/// A [`Fatal`] error when the file cannot be read, a bag directory is
/// unusable or contradicts `--format`, or a bag's topics are unusable.
pub fn open_recording(args: &LogArgs, bar: &ProgressBar) -> Result<Opened, Fatal> {
    let file = args.file.display().to_string();
    let laser_offset = args
        .laser_offset
        .as_ref()
        .filter(|v| v.len() == 3)
        .map(|v| [v[0], v[1], v[2]]);
    // A directory is a ROS 2 bag (`metadata.yaml` and `.db3` or `.mcap` files).
    let directory = args
        .file
        .is_dir()
        .then(|| bagdir::files(&args.file))
        .transpose()?;
    let mut input: Box<dyn BufRead> = if directory.is_some() {
        Box::new(io::empty())
    } else {
        open(&args.file, bar)?
    };
    let head = input
        .fill_buf()
        .map_err(|e| Fatal::io(format!("{file}: cannot read: {e}")))?;
    let format = match (args.format, &directory) {
        (Format::Auto, Some((bagdir::Storage::Sqlite, _))) => Format::Db3,
        (Format::Auto, Some((bagdir::Storage::Mcap, _))) => Format::Mcap,
        (Format::Auto, None) if head.starts_with(db3::MAGIC) => Format::Db3,
        (Format::Auto, None) if head.starts_with(MCAP_MAGIC) => Format::Mcap,
        (Format::Auto, None) if head.starts_with(ros1::MAGIC) => Format::Ros1,
        (Format::Auto, None) => Format::Carmen,
        (f, _) => f,
    };
    let from_directory = directory.is_some();
    let files = match directory {
        Some((storage, files)) => {
            let expected = match storage {
                bagdir::Storage::Sqlite => Format::Db3,
                bagdir::Storage::Mcap => Format::Mcap,
            };
            if format != expected {
                return Err(Fatal::usage(format!(
                    "{file}: a ROS 2 bag directory in {storage:?} storage, not {format:?}"
                )));
            }
            files
        }
        None => vec![args.file.clone()],
    };
    let (events, topic): (Box<dyn Iterator<Item = ros2::BagItem>>, _) = match format {
        Format::Ld06 | Format::Rplidar | Format::Ydlidar | Format::Xv11 => {
            let protocol = match format {
                Format::Ld06 => crate::wire::Protocol::Ld06,
                Format::Rplidar => crate::wire::Protocol::Rplidar,
                Format::Ydlidar => crate::wire::Protocol::Ydlidar,
                _ => crate::wire::Protocol::Xv11,
            };
            return Ok(Opened::Capture(protocol, input));
        }
        Format::Db3 => {
            let topics = db3::topics(&files)?;
            let (topic, odom) = choose_topics(args, &file, &topics, BagTypes::ROS2)?;
            let reader = db3::BagReader::new(files, &file, &topic, odom.as_deref());
            (Box::new(reader), Some(topic))
        }
        Format::Ros1 => {
            let topics = ros1::topics(input, &file)?;
            let (topic, odom) = choose_topics(args, &file, &topics, BagTypes::ROS1)?;
            // The topics took one pass; the messages take another.
            bar.reset();
            let input = open(&args.file, bar)?;
            let reader = ros1::BagReader::new(input, &file, &topic, odom.as_deref());
            (Box::new(reader), Some(topic))
        }
        Format::Mcap => {
            // One file, or the files of a bag directory in order.
            let topics = if from_directory {
                let mut all: BTreeMap<String, ros2::TopicInfo> = BTreeMap::new();
                for path in &files {
                    let name = path.display().to_string();
                    for (t, info) in ros2::topics(open(path, bar)?, &name)? {
                        let merged = all.entry(t).or_default();
                        merged.schema = info.schema;
                        merged.count += info.count;
                    }
                }
                all
            } else {
                ros2::topics(input, &file)?
            };
            let (topic, odom) = choose_topics(args, &file, &topics, BagTypes::ROS2)?;
            (mcap_events(files, bar, topic.clone(), odom), Some(topic))
        }
        Format::Carmen | Format::Auto => {
            let geometry = FlaserGeometry {
                max_range: args.max_range,
                laser_offset: laser_offset.unwrap_or([0.0; 3]),
            };
            let events = CarmenReader::new(input, geometry).map(Ok);
            return Ok(Opened::Recording(Recording {
                format,
                topic: None,
                events: Box::new(events),
            }));
        }
    };
    let events = events.map(move |item| {
        item.map(|event| {
            event.map(|e| match (e, laser_offset) {
                (Event::Scan(mut s), Some(o)) => {
                    s.record.laser_offset = o;
                    Event::Scan(s)
                }
                (e, _) => e,
            })
        })
    });
    Ok(Opened::Recording(Recording {
        format,
        topic,
        events: Box::new(events),
    }))
}

/// The events of MCAP `files` read in order (a split bag's records named
/// with their file).
fn mcap_events(
    files: Vec<PathBuf>,
    bar: &ProgressBar,
    topic: String,
    odom: Option<String>,
) -> Box<dyn Iterator<Item = ros2::BagItem>> {
    let bar = bar.clone();
    let split = files.len() > 1;
    Box::new(files.into_iter().flat_map(move |path| {
        bar.reset();
        let name = path.display().to_string();
        let part = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .filter(|_| split);
        let reader: Box<dyn Iterator<Item = ros2::BagItem>> = match open(&path, &bar) {
            Ok(input) => Box::new(ros2::BagReader::new(input, &name, &topic, odom.as_deref())),
            Err(e) => Box::new(std::iter::once(Err(e))),
        };
        reader.map(move |item| match &part {
            Some(part) => item.map(|r| {
                r.map(|e| e.in_file(part)).map_err(|mut e| {
                    e.record = format!("{part}: {}", e.record);
                    e
                })
            }),
            None => item,
        })
    }))
}

/// Runs `log`; the number of failed records and pairs.
///
/// # Errors
/// A [`Fatal`] error for unusable arguments or files, or a recording without
/// one usable scan.
pub fn run(args: &LogArgs) -> Result<usize, Fatal> {
    if args.every == 0 {
        return Err(Fatal::usage("--every 0: must be at least 1"));
    }
    if args.window == 0 {
        return Err(Fatal::usage("--window 0: must be at least 1"));
    }
    let sigma = args.prior_sigma();
    if !(sigma.is_finite() && sigma > 0.0 && sigma <= 90.0) {
        return Err(Fatal::usage(format!(
            "--prior-sigma {sigma}: must be in (0, 90] degrees"
        )));
    }
    if args.prior() == PriorArg::Motion
        && !matches!(args.pairs(), PairsArg::Consecutive | PairsArg::Keyframes)
    {
        return Err(Fatal::usage(
            "--prior motion chains the scans: use it with --pairs consecutive or keyframes",
        ));
    }
    if args.window_s.is_some_and(|w| !(w.is_finite() && w > 0.0)) {
        return Err(Fatal::usage(
            "--window-s: must be a positive number of seconds",
        ));
    }
    if !(args.max_range.is_finite() && args.max_range > 0.0) {
        return Err(Fatal::usage(format!(
            "--max-range {}: must be a positive number of metres",
            args.max_range
        )));
    }
    let laser_offset = match &args.laser_offset {
        Some(v) if v.len() == 3 && v.iter().all(|x| x.is_finite()) => Some([v[0], v[1], v[2]]),
        Some(v) => {
            return Err(Fatal::usage(format!(
                "--laser-offset {v:?}: expected three finite numbers X,Y,THETA"
            )))
        }
        None => None,
    };
    let chains = matches!(args.pairs(), PairsArg::Consecutive | PairsArg::Keyframes);
    if (args.trajectory.is_some() || args.plot.is_some()) && !chains {
        return Err(Fatal::usage(
            "--trajectory and --plot chain the scans: use them with --pairs consecutive or keyframes",
        ));
    }
    let file = args.file.display().to_string();
    let bar = if args.quiet {
        ProgressBar::hidden()
    } else {
        let bar = ProgressBar::new(0);
        if let Ok(style) = ProgressStyle::with_template(
            "{bar:40} {bytes}/{total_bytes} {binary_bytes_per_sec} eta {eta} {msg}",
        ) {
            bar.set_style(style);
        }
        bar
    };
    let opened = open_recording(args, &bar)?;
    let mut run = Run {
        args,
        file: file.clone(),
        workers: Workers::new(args.jobs.threads(), || {
            args.estimator.engine(args.grid.size)
        })?,
        options: args.grid.options(&args.beams)?,
        mode: args.estimator.mode.into(),
        out: BufWriter::new(io::stdout().lock()),
        pending: Vec::new(),
        pending_pairs: 0,
        pairs: 0,
        failed: 0,
        summary: Summary::default(),
        // `--summary` on consecutive pairs also scores the chain (APE, RPE).
        trajectory: (args.trajectory.is_some() || args.plot.is_some() || (args.summary && chains))
            .then(Trajectory::default),
        chain: args
            .chained()
            .then(|| Chain::new(args.prior_sigma(), args.pairs() != PairsArg::Keyframes)),
        stdout_closed: false,
        bar: bar.clone(),
    };
    let start = Instant::now();
    let scans = match opened {
        Opened::Recording(recording) => stream(&mut run, recording.events)?,
        Opened::Capture(protocol, input) => {
            let offset = laser_offset.unwrap_or([0.0; 3]);
            let mut reader = crate::wire::WireReader::new(input, protocol, args.max_range, offset);
            let scans = stream(&mut run, reader.by_ref().map(Ok))?;
            eprintln!("hough-heading: {file}: {}", reader.report());
            scans
        }
    };
    let _ = run.out.flush();
    bar.finish_and_clear();
    if scans == 0 {
        return Err(Fatal::io(format!(
            "{file}: no usable laser scan ({} record(s) failed)",
            run.failed
        )));
    }
    if !args.quiet {
        eprintln!(
            "hough-heading: {file}: {scans} scans, {} pairs ({} failed record(s) or pair(s)) in {:.2} s",
            run.pairs,
            run.failed,
            start.elapsed().as_secs_f64()
        );
    }
    if args.summary {
        eprintln!(
            "\n{file}: {} pairs scored against the log's poses ({}², N_θ = {})\n\n{}",
            args.pairs_name(),
            args.grid.size,
            args.estimator.n_theta,
            run.summary.table()
        );
        if let Some(errors) = run.trajectory.as_ref().and_then(evo::report) {
            eprintln!("{errors}");
        }
    }
    if let Some(t) = &run.trajectory {
        if let Some(path) = &args.trajectory {
            let written = evo::write(t, path)?;
            if !args.quiet && evo::TrajectoryFormat::of(path) != evo::TrajectoryFormat::Csv {
                let names: Vec<String> = written.iter().map(|p| p.display().to_string()).collect();
                eprintln!("hough-heading: trajectory written: {}", names.join(", "));
            }
        }
        if let Some(path) = &args.plot {
            let name = args
                .file
                .file_name()
                .map_or(file.clone(), |n| n.to_string_lossy().into_owned());
            t.plot(path, &name)?;
        }
    }
    Ok(run.failed)
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
            (None, PairsArg::Consecutive) => PriorArg::Motion,
            (None, _) => PriorArg::None,
        }
    }

    /// The prior's σ, degrees: `--prior-sigma`, or the prior's default.
    pub fn prior_sigma(&self) -> f64 {
        let default = if self.chained() { 30.0 } else { 10.0 };
        self.prior_sigma.unwrap_or(default)
    }

    /// The run chains the scans (motion prior or keyframes).
    fn chained(&self) -> bool {
        self.prior() == PriorArg::Motion
    }

    fn pairs_name(&self) -> &'static str {
        match self.pairs() {
            PairsArg::Consecutive => "consecutive",
            PairsArg::Reference => "reference",
            PairsArg::Window => "window",
            PairsArg::Keyframes => "keyframe",
        }
    }
}

/// The message types a bag names its scans and odometry by.
#[derive(Clone, Copy, Debug)]
pub struct BagTypes {
    /// The laser scans' types (the first is the one found without `--topic`).
    pub scan: &'static [&'static str],
    /// The odometry's type.
    pub odometry: &'static str,
}

impl BagTypes {
    /// ROS 2 (MCAP).
    pub const ROS2: Self = Self {
        scan: &[ros2::LASER_SCAN],
        odometry: ros2::ODOMETRY,
    };
    /// ROS 1.
    pub const ROS1: Self = Self {
        scan: &[ros1::LASER_SCAN, ros1::MULTI_ECHO_SCAN],
        odometry: ros1::ODOMETRY,
    };
}

/// The scan topic (`--topic`, or the bag's only scan topic) and the
/// odometry topic (`--odom-topic`, or `/odom` when it carries odometry) of a
/// bag whose `topics` were listed.
///
/// # Errors
/// A usage error listing the bag's topics when the scan topic is missing,
/// ambiguous or unknown, or the odometry topic unknown or of another type.
pub fn choose_topics(
    args: &LogArgs,
    file: &str,
    topics: &BTreeMap<String, ros2::TopicInfo>,
    types: BagTypes,
) -> Result<(String, Option<String>), Fatal> {
    let topic = match &args.topic {
        Some(t) if topics.contains_key(t) => t.clone(),
        None => match types
            .scan
            .iter()
            .find_map(|&schema| ros2::only_topic_of(topics, schema).map(|t| (t, schema)))
        {
            Some((t, schema)) => {
                eprintln!("hough-heading: {file}: using {t}, the bag's only {schema} topic");
                t
            }
            None => return Err(ros2::topic_error(file, None, topics)),
        },
        other => return Err(ros2::topic_error(file, other.as_deref(), topics)),
    };
    // A scan topic of another type fails at its first message (named).
    let odom = match &args.odom_topic {
        Some(t) => match topics.get(t) {
            Some(i) if i.schema == types.odometry => Some(t.clone()),
            Some(i) => {
                return Err(Fatal::usage(format!(
                    "{file}: topic {t} carries {}, not {}",
                    i.schema, types.odometry
                )))
            }
            None => return Err(ros2::topic_error(file, Some(t), topics)),
        },
        None => topics
            .iter()
            .find(|(t, i)| t.as_str() == "/odom" && i.schema == types.odometry)
            .map(|(t, _)| t.clone()),
    };
    Ok((topic, odom))
}

/// Pairs the scans of `events` as asked; the number of scans read. Every
/// pair before the end (or a fatal error) is estimated and written.
fn stream(
    run: &mut Run<'_>,
    events: impl Iterator<Item = Result<Result<Event, RecordError>, Fatal>>,
) -> Result<usize, Fatal> {
    let scans = stream_pairs(run, events);
    let flushed = run.flush();
    let scans = scans?;
    flushed?;
    Ok(scans)
}

/// [`stream`] without the last batch.
fn stream_pairs(
    run: &mut Run<'_>,
    events: impl Iterator<Item = Result<Result<Event, RecordError>, Fatal>>,
) -> Result<usize, Fatal> {
    let args = run.args;
    let mut scans = 0;
    let mut kept: VecDeque<Kept> = VecDeque::new();
    let mut reference: Option<Kept> = None;
    let mut last_odom: Option<Pose> = None;
    for event in events {
        let mut scan = match event? {
            Err(e) => {
                run.record_error(e);
                continue;
            }
            Ok(Event::Odometry { pose, .. }) => {
                last_odom = Some(pose);
                continue;
            }
            Ok(Event::Scan(scan)) => scan,
        };
        if args.limit.is_some_and(|l| scans >= l) {
            break;
        }
        let index = scans;
        scans += 1;
        if !index.is_multiple_of(args.every) {
            continue;
        }
        if scan.odom.is_none() {
            scan.odom = last_odom;
        }
        let current: Kept = (index, Arc::new(scan));
        run.bar.set_message(format!("scan {index}"));
        match args.pairs() {
            PairsArg::Consecutive => {
                if let Some(previous) = kept.pop_back() {
                    run.pair(&previous, &current)?;
                } else {
                    run.start(&current);
                }
                kept.push_back(current);
            }
            PairsArg::Keyframes => {
                // Each pair waits for the one before: its keyframe and
                // prior come from that pair's estimate.
                match run.chain.as_ref().and_then(|c| c.keyframe.clone()) {
                    Some(keyframe) => {
                        run.pair(&keyframe, &current)?;
                        run.flush()?;
                    }
                    None => run.start(&current),
                }
            }
            PairsArg::Reference => {
                if index == args.reference {
                    reference = Some(current);
                } else if let Some(r) = &reference {
                    run.pair(&r.clone(), &current)?;
                }
            }
            PairsArg::Window => {
                let t2 = current.1.time;
                kept.retain(|(i, s)| {
                    index - i <= args.window.saturating_mul(args.every)
                        && match (args.window_s, s.time, t2) {
                            (Some(w), Some(a), Some(b)) => (b - a).abs() <= w,
                            _ => true,
                        }
                });
                for k in kept.clone() {
                    run.pair(&k, &current)?;
                }
                kept.push_back(current);
            }
        }
    }
    if args.pairs() == PairsArg::Reference && reference.is_none() && scans > 0 {
        return Err(Fatal::usage(format!(
            "--reference {}: the recording has only {scans} scans",
            args.reference
        )));
    }
    Ok(scans)
}

/// A deterministic spread of values for the readers' damage tests
/// (xorshift64 from `seed`, not zero).
#[cfg(test)]
fn xorshift(seed: u64) -> impl FnMut() -> u64 {
    let mut state = seed;
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    }
}

/// `data` with `bytes` of its bytes set to values of `next`, at places of
/// `next` (for the readers' damage tests).
#[cfg(test)]
fn damaged(data: &[u8], bytes: usize, next: &mut impl FnMut() -> u64) -> Vec<u8> {
    let mut d = data.to_vec();
    for _ in 0..bytes {
        let at = (next() % d.len().max(1) as u64) as usize;
        if let Some(b) = d.get_mut(at) {
            *b = (next() & 0xff) as u8;
        }
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn between_and_compose_are_inverse() {
        let a = Pose {
            x: 1.0,
            y: -2.0,
            theta: 2.5,
        };
        let b = Pose {
            x: -0.5,
            y: 0.7,
            theta: -2.9,
        };
        let d = a.between(&b);
        let c = a.compose(&d);
        assert!((c.x - b.x).abs() < 1e-12 && (c.y - b.y).abs() < 1e-12);
        assert!(wrap_rad(c.theta - b.theta).abs() < 1e-12);
        // Robot at the origin facing +y; a pose 1 m further along +y is 1 m
        // straight ahead.
        let facing = Pose {
            x: 0.0,
            y: 0.0,
            theta: std::f64::consts::FRAC_PI_2,
        };
        let ahead = facing.between(&Pose {
            x: 0.0,
            y: 1.0,
            theta: 0.0,
        });
        assert!((ahead.x - 1.0).abs() < 1e-12 && ahead.y.abs() < 1e-12);
    }
}
