//! The recordings `hough-heading log` reads (CARMEN logs, plain or gzip;
//! ROS 2 bags in MCAP), read by the tool's own readers: the scans as numpy
//! arrays with their time, odometry and the log's own pose.

use std::io::BufRead;
use std::path::PathBuf;

use clap::Parser;
use hough_heading_cli::log::carmen::{CarmenReader, FlaserGeometry};
use hough_heading_cli::log::{self, ros2, Event, LogArgs, LogScan, Pose, RecordError};
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
    let mut input = log::open(&args.file, &bar)?;
    let head = input
        .fill_buf()
        .map_err(|e| Fatal::io(format!("{file}: cannot read: {e}")))?;
    let mcap = match args.format {
        log::Format::Auto => head.starts_with(log::MCAP_MAGIC),
        log::Format::Mcap => true,
        log::Format::Carmen => false,
        log::Format::Ld06 | log::Format::Rplidar | log::Format::Ydlidar | log::Format::Xv11 => {
            return Err(Fatal::usage(format!(
                "{file}: raw lidar captures are not read here; convert one with \
                 `hough-heading wire --protocol PROTOCOL CAPTURE --out LOG` and read LOG"
            )))
        }
    };
    let laser_offset = args.laser_offset.as_ref().map(|v| [v[0], v[1], v[2]]);
    let mut out = Read {
        scans: Vec::new(),
        errors: Vec::new(),
        format: if mcap { "mcap" } else { "carmen" },
        topic: None,
    };
    let mut last_odom: Option<Pose> = None;
    let mut take = |out: &mut Read, event: Result<Event, RecordError>| match event {
        Ok(Event::Scan(mut scan)) => {
            // As `log` pairs them: a scan without its own odometry gets the
            // latest odometry message's pose.
            if scan.odom.is_none() {
                scan.odom = last_odom;
            }
            if let Some(o) = laser_offset {
                scan.record.laser_offset = o;
            }
            out.scans.push(scan);
        }
        Ok(Event::Odometry { pose, .. }) => last_odom = Some(pose),
        Err(e) => out.errors.push(e),
    };
    if mcap {
        let (topic, odom_topic) = log::choose_topics(args, &file, input)?;
        let input = log::open(&args.file, &bar)?;
        for item in ros2::BagReader::new(input, &file, &topic, odom_topic.as_deref()) {
            take(&mut out, item?);
        }
        out.topic = Some(topic);
    } else {
        let geometry = FlaserGeometry {
            max_range: args.max_range,
            laser_offset: laser_offset.unwrap_or([0.0; 3]),
        };
        for event in CarmenReader::new(input, geometry) {
            take(&mut out, event);
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
