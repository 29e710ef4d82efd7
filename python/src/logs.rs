//! The recordings `hough-heading log` reads (CARMEN logs, plain or gzip;
//! ROS 1 bags; ROS 2 bags in MCAP or SQLite, or their directories), read by
//! the tool's own opener and readers: the scans as numpy arrays with their
//! time, odometry and the log's own pose.

use std::path::PathBuf;

use clap::Parser;
use hough_heading_cli::log::{self, Event, LogArgs, LogScan, Pose, RecordError};
use hough_heading_cli::Fatal;
use indicatif::ProgressBar;
use numpy::PyArray1;
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::{on_big_stack, value_error};

/// The tool's `log` options (only the reading ones are used).
#[derive(Clone, Debug, Parser)]
#[command(name = "hough_heading", no_binary_name = true)]
struct LogOptions {
    #[command(flatten)]
    log: LogArgs,
}

/// What a recording held: its scans, the records that failed, the format
/// and the scan topic read.
struct Read {
    scans: Vec<LogScan>,
    errors: Vec<RecordError>,
    format: &'static str,
    topic: Option<String>,
}

fn read(args: &LogArgs) -> Result<Read, Fatal> {
    let file = args.file.display().to_string();
    let bar = ProgressBar::hidden();
    let recording = match log::open_recording(args, &bar)? {
        log::Opened::Recording(r) => r,
        log::Opened::Capture(..) => {
            return Err(Fatal::usage(format!(
                "{file}: raw lidar captures are not read here; convert one with \
                 `hough-heading wire --protocol PROTOCOL CAPTURE --out LOG` and read LOG"
            )))
        }
    };
    let mut out = Read {
        scans: Vec::new(),
        errors: Vec::new(),
        format: match recording.format {
            log::Format::Mcap => "mcap",
            log::Format::Ros1 => "ros1",
            log::Format::Db3 => "db3",
            _ => "carmen",
        },
        topic: recording.topic,
    };
    let mut last_odom: Option<Pose> = None;
    for item in recording.events {
        match item? {
            Ok(Event::Scan(mut scan)) => {
                // As `log` pairs them: a scan without its own odometry gets
                // the latest odometry message's pose.
                if scan.odom.is_none() {
                    scan.odom = last_odom;
                }
                out.scans.push(scan);
            }
            Ok(Event::Odometry { pose, .. }) => last_odom = Some(pose),
            Err(e) => out.errors.push(e),
        }
    }
    Ok(out)
}

fn pose(p: Option<Pose>) -> Option<(f64, f64, f64)> {
    p.map(|p| (p.x, p.y, p.theta))
}

/// Reads a recording with the tool's options `args` (`[FILE, --format …,
/// --topic …]`): `(scans as dicts, [(record, message)], format, topic)`.
#[pyfunction]
#[allow(clippy::type_complexity)]
fn read_log<'py>(
    py: Python<'py>,
    args: Vec<String>,
) -> PyResult<(
    Vec<Bound<'py, PyDict>>,
    Vec<(String, String)>,
    &'static str,
    Option<String>,
)> {
    let options = LogOptions::try_parse_from(&args)
        .map_err(|e| value_error(e.render().to_string().trim()))?;
    let log = options.log;
    if !(log.max_range.is_finite() && log.max_range > 0.0) {
        return Err(value_error(format!(
            "max_range={}: must be a positive number of metres",
            log.max_range
        )));
    }
    if let Some(v) = &log.laser_offset {
        if v.len() != 3 || v.iter().any(|x| !x.is_finite()) {
            return Err(value_error(format!(
                "laser_offset={v:?}: expected three finite numbers (x, y, theta)"
            )));
        }
    }
    let path: PathBuf = log.file.clone();
    let read = py
        .detach(|| on_big_stack(|| read(&log)))
        .map_err(PyRuntimeError::new_err)?
        .map_err(|e| value_error(format!("{}: {e}", path.display())))?;
    let mut scans = Vec::with_capacity(read.scans.len());
    for s in &read.scans {
        let d = PyDict::new(py);
        d.set_item("ranges", PyArray1::from_vec(py, s.record.ranges()))?;
        d.set_item("angle_min", s.record.angle_min)?;
        d.set_item("angle_increment", s.record.angle_increment)?;
        d.set_item("max_range", s.record.max_range)?;
        let [x, y, th] = s.record.laser_offset;
        d.set_item("laser_offset", (x, y, th))?;
        d.set_item("time", s.time)?;
        d.set_item("odom", pose(s.odom))?;
        d.set_item("log_pose", pose(s.log_pose))?;
        d.set_item("name", &s.name)?;
        scans.push(d);
    }
    let errors = read
        .errors
        .into_iter()
        .map(|e| (e.record, e.message))
        .collect();
    Ok((scans, errors, read.format, read.topic))
}

/// Adds the reader to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(read_log, m)?)
}
