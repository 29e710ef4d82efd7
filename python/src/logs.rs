//! The recordings `hough-heading log` reads (CARMEN logs, plain or gzip;
//! ROS 1 bags; ROS 2 bags in MCAP or SQLite, or their directories), read by
//! the tool's own opener and readers (`hough_heading_recordings`): the scans
//! as numpy arrays with their time, odometry and the log's own pose.

use std::path::PathBuf;

use clap::Parser;
use hough_heading_recordings::{
    open_recording, Event, Fatal, Format, Opened, Pose, RecordError, Scan, Source,
};
use indicatif::ProgressBar;
use numpy::PyArray1;
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::{on_big_stack, value_error};

/// The reading options of the tool's `log` (names, values and defaults
/// as there).
#[derive(Clone, Debug, Parser)]
#[command(name = "hough_heading", no_binary_name = true)]
struct LogOptions {
    /// The recording.
    file: PathBuf,
    /// Input format.
    #[arg(long, value_enum, default_value_t = Format::Auto)]
    format: Format,
    /// Bags: the `LaserScan` topic.
    #[arg(long)]
    topic: Option<String>,
    /// Bags: the `Odometry` topic.
    #[arg(long, value_name = "TOPIC")]
    odom_topic: Option<String>,
    /// CARMEN `FLASER`: "no return" at or beyond this, metres.
    #[arg(long, value_name = "METRES", default_value_t = 81.91)]
    max_range: f32,
    /// CARMEN `FLASER` and LaserScan: the laser pose `X,Y,THETA`.
    #[arg(long, value_name = "X,Y,THETA", value_delimiter = ',', num_args = 3)]
    laser_offset: Option<Vec<f32>>,
}

/// What a recording held: its scans, the records that failed, the format
/// and the scan topic read.
struct Read {
    scans: Vec<Scan>,
    errors: Vec<RecordError>,
    format: &'static str,
    topic: Option<String>,
}

fn read(source: &Source) -> Result<Read, Fatal> {
    let file = source.file.display().to_string();
    let bar = ProgressBar::hidden();
    let recording = match open_recording(source, &bar)? {
        Opened::Recording(r) => r,
        Opened::Capture(..) => {
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
            Format::Mcap => "mcap",
            Format::Ros1 => "ros1",
            Format::Db3 => "db3",
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
            Ok(Event::Odometry(o)) => last_odom = Some(o.pose),
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
    let log = LogOptions::try_parse_from(&args)
        .map_err(|e| value_error(e.render().to_string().trim()))?;
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
    let source = Source {
        file: log.file,
        format: log.format,
        topic: log.topic,
        odom_topic: log.odom_topic,
        max_range: log.max_range,
        laser_offset: log.laser_offset.map(|v| [v[0], v[1], v[2]]),
    };
    let read = py
        .detach(|| on_big_stack(|| read(&source)))
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
