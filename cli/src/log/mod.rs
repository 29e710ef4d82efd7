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

mod args;
pub mod chain;
mod figure;
pub mod loops;
mod pairing;
mod placing;

use std::io::{self, BufWriter, Write};
use std::time::Instant;

use hough_heading_recordings::pairs::wrap_deg;
use hough_heading_recordings::stats::quantile;
use hough_heading_recordings::trajectory::Trajectory;
use hough_heading_recordings::wire::WireReader;
use hough_heading_recordings::{chain_report, evo};
use hough_heading_recordings::{open_recording, Fatal, Opened};
use indicatif::{ProgressBar, ProgressStyle};

pub use args::{LogArgs, PairsArg, PriorArg};
use chain::Chain;
use pairing::{stream, Run};

use crate::jobs::Workers;
use crate::summary::Summary;

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
    if args.prior() == PriorArg::Motion && !args.pairs().chains() {
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
    let chains = args.pairs().chains();
    if (args.trajectory.is_some() || args.plot.is_some()) && !chains {
        return Err(Fatal::usage(
            "--trajectory and --plot chain the scans: use them with --pairs consecutive or keyframes",
        ));
    }
    if (args.loops || args.g2o.is_some() || args.closures.is_some()) && !args.chained() {
        return Err(Fatal::usage(
            "--loops, --g2o and --closures close loops over a chained run: not with --prior none or odom",
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
    let opened = open_recording(&args.source(), &bar)?;
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
        statuses: Default::default(),
        missing_readings: Default::default(),
        // `--summary` on consecutive pairs also scores the chain (APE, RPE).
        trajectory: (args.trajectory.is_some() || args.plot.is_some() || (args.summary && chains))
            .then(Trajectory::default),
        chain: args
            .chained()
            .then(|| Chain::new(args.prior_sigma, args.pairs() != PairsArg::Keyframes)),
        // `auto` is settled at the second scan (`pairing::stream`); it is
        // consecutive pairs without the motion prior.
        way: match args.pairs() {
            PairsArg::Auto if !args.chained() => PairsArg::Consecutive,
            pairs => pairs,
        },
        stdout_closed: false,
        bar: bar.clone(),
    };
    let start = Instant::now();
    let scans = match opened {
        Opened::Recording(recording) => stream(&mut run, recording.events)?,
        Opened::Capture(protocol, input) => {
            let offset = laser_offset.unwrap_or([0.0; 3]);
            let mut reader = WireReader::new(input, protocol, args.max_range, offset);
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
            "hough-heading: {file}: {scans} scans, {} {} pairs ({} failed record(s) or pair(s)) in {:.2} s",
            run.pairs,
            run.way.name(),
            run.failed,
            start.elapsed().as_secs_f64()
        );
    }
    let missing = run.missing_readings.text();
    if let Some(text) = missing.as_ref().filter(|_| !args.quiet) {
        eprintln!("hough-heading: {file}: {text}");
    }
    let closures = if args.closes_loops() {
        close_loops(&mut run, &file)?
    } else {
        0
    };
    if args.summary && run.summary.is_empty() {
        // Nothing to score against: what the run shows without it.
        eprintln!(
            "\n{file}: no reference poses to score against (the recording has no poses of its \
             own, as a Radish `-corrected` log's `FLASER` lines are), so no scored table; \
             {} pairs, {} failed record(s) or pair(s)",
            run.pairs, run.failed
        );
        let statuses: Vec<String> = run
            .statuses
            .iter()
            .map(|(status, &[n, by_beams])| match by_beams {
                0 => format!("{status} {n}"),
                _ => format!("{status} {n} ({by_beams} flagged by the beam check)"),
            })
            .collect();
        eprintln!(
            "pairs by their estimate's status (the JSON lines' `status`): {}",
            statuses.join(", ")
        );
        if let Some(text) = &missing {
            eprintln!("{text}");
        }
        if let Some(report) = run.trajectory.as_ref().and_then(chain_report::report) {
            eprintln!("\n{}", report);
        }
    } else if args.summary {
        eprintln!(
            "\n{file}: {} pairs scored against the log's poses ({}², N_θ = {})\n\n{}",
            run.way.name(),
            args.grid.size,
            args.estimator.n_theta,
            run.summary.table()
        );
        if let Some(text) = &missing {
            eprintln!("{text}");
        }
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
            let loops = match closures {
                0 => String::new(),
                n => format!(", {n} loop closures"),
            };
            let title = format!("{name}: {} pairs chained{loops}", run.way.name());
            figure::plot(t, path, &title)?;
        }
    }
    Ok(run.failed)
}

/// `--loops`: closes the run's loops and puts the corrected poses into its
/// trajectory (each scan moved with the placed scan at or before it);
/// reports the closures on stderr, and writes `--g2o`. The number of
/// closures accepted.
fn close_loops(run: &mut Run<'_>, file: &str) -> Result<usize, Fatal> {
    let Some(chain) = &run.chain else {
        return Ok(0);
    };
    let nodes = &chain.nodes;
    let solved = loops::close(
        nodes,
        &mut run.workers,
        &run.options,
        run.mode,
        &loops::LoopSettings::default(),
    )?;
    if let Some(t) = &mut run.trajectory {
        let mut k = 0;
        for step in &mut t.steps {
            while k + 1 < nodes.len() && nodes[k + 1].scan.0 <= step.scan {
                k += 1;
            }
            if let (Some(node), Some(corrected)) = (nodes.get(k), solved.poses.get(k)) {
                step.pose = corrected.compose(&node.pose.between(&step.pose));
            }
        }
    }
    // Closures more than 5° off the recording's own poses, where it has them.
    let wrong = |c: &loops::Closure| {
        let (a, b) = (&nodes[c.from].scan.1, &nodes[c.to].scan.1);
        a.log_pose.zip(b.log_pose).map(|(p, q)| {
            let truth = p.between(&q).theta.to_degrees();
            wrap_deg(c.delta.theta.to_degrees() - truth).abs() > 5.0
        })
    };
    let accepted: Vec<&loops::Closure> = solved.closures.iter().filter(|c| c.accepted).collect();
    let count_wrong =
        |cs: &mut dyn Iterator<Item = &loops::Closure>| cs.filter_map(wrong).filter(|w| *w).count();
    let judged = accepted.iter().any(|c| wrong(c).is_some());
    // Each accepted closure's heading difference to the optimized
    // trajectory, degrees.
    let after: Vec<f64> = accepted
        .iter()
        .map(|c| c.disagreement_deg(&solved.poses))
        .collect();
    if !run.args.quiet || run.args.summary {
        let wrong_text = if judged {
            format!(
                "; more than 5° off the recording's poses: {} of the accepted, {} of the rejected",
                count_wrong(&mut accepted.iter().copied()),
                count_wrong(&mut solved.closures.iter().filter(|c| !c.accepted))
            )
        } else {
            String::new()
        };
        let agreeing = after.iter().filter(|d| **d <= 1.0).count();
        eprintln!(
            "hough-heading: {file}: loop closures: {} confident tried, {} accepted into the pose graph of {} placed scans, {agreeing} of them within 1° of the optimized trajectory{wrong_text}",
            solved.closures.len(),
            accepted.len(),
            nodes.len()
        );
    }
    if run.args.summary && !accepted.is_empty() {
        let before: Vec<f64> = accepted.iter().map(|c| c.residual_deg.abs()).collect();
        let degrees = |values: &[f64], q: f64| format!("{:.2}", quantile(values, q));
        eprintln!(
            "hough-heading: {file}: accepted closures' heading difference to the trajectory, before / after the graph: median {} / {}°, 90th percentile {} / {}°, largest {} / {}°",
            degrees(&before, 0.5),
            degrees(&after, 0.5),
            degrees(&before, 0.9),
            degrees(&after, 0.9),
            degrees(&before, 1.0),
            degrees(&after, 1.0),
        );
    }
    if let Some(path) = &run.args.g2o {
        loops::write_g2o(path, nodes, &solved)?;
    }
    if let Some(path) = &run.args.closures {
        loops::write_closures(path, nodes, &solved)?;
    }
    Ok(accepted.len())
}
