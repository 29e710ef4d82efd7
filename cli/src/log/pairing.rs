//! The pairs of `log`: each kept scan paired as `--pairs` asks, the pairs
//! estimated a batch at a time on every worker, their lines written in the
//! recording's order with the record errors between them.

use std::collections::VecDeque;
use std::io::{self, BufWriter, Write};
use std::sync::Arc;

use hough_heading::odometry::DENSE_INTERVAL_S;
use hough_heading::{Angle, Mode, Prior};
use hough_heading_recordings::engine::Engine;
use hough_heading_recordings::line::OutputLine;
use hough_heading_recordings::model::{Event, Pose};
use hough_heading_recordings::pairs::{
    self as scans, Check, FlaggedBy, PairRecord, RasterOptions, Truth,
};
use hough_heading_recordings::trajectory::{Kept, Trajectory};
use hough_heading_recordings::{Fatal, RecordError};
use indicatif::ProgressBar;
use serde::Serialize;

use super::args::{LogArgs, PairsArg, PriorArg};
use super::chain::{Chain, ChainLine};
use super::placing::odom_between;
use crate::jobs::Workers;
use crate::summary::{Method, Summary};

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
pub(super) type PairResult = Result<Vec<scans::PairEstimate>, String>;

/// A pair waiting for its estimate: the two scans and what the log says
/// about their motion.
pub(super) struct PairJob {
    /// The first scan.
    pub(super) a: Kept,
    /// The second scan.
    pub(super) b: Kept,
    /// The odometry's delta.
    pub(super) odom: Option<Pose>,
    /// The log's own poses' delta.
    log_pose: Option<Pose>,
    /// The prior on the rotation (`--prior odom`).
    prior: Option<Prior>,
    /// The two scans as a pair file's line.
    pair: PairRecord,
}

/// What waits to be written, in the order of the recording.
pub(super) enum Pending {
    /// A pair to estimate.
    Pair(Box<PairJob>),
    /// A record that could not be used.
    Error(RecordError),
}

/// A `log` run: its options, workers and output, and what waits to be
/// written.
pub(super) struct Run<'a> {
    pub(super) args: &'a LogArgs,
    pub(super) file: String,
    pub(super) workers: Workers<Box<dyn Engine>>,
    pub(super) options: RasterOptions,
    pub(super) mode: Mode,
    pub(super) out: BufWriter<io::StdoutLock<'static>>,
    /// Pairs and record errors not yet written: the pairs are estimated a
    /// batch at a time ([`Workers::batch`]), then everything is written in
    /// order.
    pub(super) pending: Vec<Pending>,
    /// Pairs among `pending`.
    pub(super) pending_pairs: usize,
    pub(super) pairs: usize,
    pub(super) failed: usize,
    pub(super) summary: Summary,
    /// The pairs' statuses (the output line's `status`), counted for
    /// `--summary` on a recording without reference poses: all, and those
    /// flagged by the check on the beams (`flagged_by`).
    pub(super) statuses: std::collections::BTreeMap<&'static str, [usize; 2]>,
    /// Beams without a reading in the file (NaN, inf, below `range_min`)
    /// and the scans that had any, over the scans read.
    pub(super) missing_readings: MissingReadings,
    pub(super) trajectory: Option<Trajectory>,
    /// The chain of `--prior motion` and `--pairs keyframes`.
    pub(super) chain: Option<Chain>,
    /// The pairs the run makes: `--pairs`, `auto` until the second scan
    /// settles it ([`settle`]).
    pub(super) way: PairsArg,
    pub(super) stdout_closed: bool,
    pub(super) bar: ProgressBar,
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
        let odom = odom_between(a, b);
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
            Ok(estimates) => {
                let line = OutputLine::of(index, &estimates[0]);
                let [all, by_beams] = self.statuses.entry(line.status).or_default();
                *all += 1;
                *by_beams += usize::from(line.flagged_by == Some(FlaggedBy::BeamCheck.name()));
                line
            }
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

/// Beams of the scans read that had no reading in the file.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct MissingReadings {
    /// Such beams.
    pub(super) beams: usize,
    /// Scans with at least one.
    pub(super) scans: usize,
}

impl MissingReadings {
    /// The words for stderr, or `None` when every beam had a reading.
    pub(super) fn text(&self) -> Option<String> {
        (self.beams > 0).then(|| {
            format!(
                "{} beam(s) in {} scan(s) had no reading in the file (NaN, inf or below the \
                 sensor's range_min): used as beams without a return",
                self.beams, self.scans
            )
        })
    }
}

/// Pairs the scans of `events` as asked; the number of scans read. Every
/// pair before the end (or a fatal error) is estimated and written.
pub(super) fn stream(
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
            Ok(Event::Odometry(o)) => {
                last_odom = Some(o.pose);
                continue;
            }
            Ok(Event::Scan(scan)) => scan,
        };
        if args.limit.is_some_and(|l| scans >= l) {
            break;
        }
        let index = scans;
        scans += 1;
        let missing = scan.missing_readings();
        if missing > 0 {
            run.missing_readings.beams += missing;
            run.missing_readings.scans += 1;
        }
        if !index.is_multiple_of(args.every) {
            continue;
        }
        if scan.odom.is_none() {
            scan.odom = last_odom;
        }
        let current: Kept = (index, Arc::new(scan));
        run.bar.set_message(format!("scan {index}"));
        if run.way == PairsArg::Auto {
            if let Some(first) = kept
                .back()
                .or(run.chain.as_ref().and_then(|c| c.keyframe()))
            {
                run.way = settle(first, &current);
                if let Some(chain) = &mut run.chain {
                    chain.keep_every_scan(run.way == PairsArg::Consecutive);
                }
            }
        }
        match run.way {
            PairsArg::Auto | PairsArg::Consecutive => {
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
                match run.chain.as_ref().and_then(|c| c.keyframe().cloned()) {
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
    if run.way == PairsArg::Reference && reference.is_none() && scans > 0 {
        return Err(Fatal::usage(format!(
            "--reference {}: the recording has only {scans} scans",
            args.reference
        )));
    }
    Ok(scans)
}

/// `--pairs auto` at the second scan: keyframes when the first two scans
/// are at most [`DENSE_INTERVAL_S`] apart by their times, else consecutive
/// pairs.
fn settle(first: &Kept, second: &Kept) -> PairsArg {
    match first.1.time.zip(second.1.time) {
        Some((a, b)) if b > a && b - a <= f64::from(DENSE_INTERVAL_S) => PairsArg::Keyframes,
        _ => PairsArg::Consecutive,
    }
}
