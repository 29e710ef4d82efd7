//! CARMEN log files (the Radish / Freiburg / MIT 2D-SLAM data sets), read
//! line by line.
//!
//! Lines used (whitespace-separated fields):
//!
//! - `FLASER n r₁ … rₙ x y θ odom_x odom_y odom_θ [ipc_timestamp ipc_hostname
//!   logger_timestamp]`: a front laser scan. `x y θ` is the log's pose of the
//!   robot (in a Radish `-corrected` log, the corrected pose: the reference
//!   of `--summary`), `odom_*` the odometry. The old format carries no field
//!   of view: beam `i` points at `−90° + i·Δ` with Δ guessed from `n` as
//!   CARMEN does (1° for 180 or 181 beams, 0.5° for 360 or 361, 0.25° for
//!   400 or 401, otherwise 180°/(n − 1)); the maximum range and the laser's
//!   offset on the robot come from the options.
//! - `ROBOTLASER1 type start_angle fov angular_resolution max_range accuracy
//!   remission_mode n r₁ … rₙ m e₁ … eₘ laser_x laser_y laser_θ robot_x
//!   robot_y robot_θ tv rv forward_safety side_safety turn_axis [timestamp
//!   hostname logger_timestamp]`: a scan with its own geometry. The laser
//!   offset is the laser pose in the robot pose's frame; the robot pose is
//!   the odometry.
//! - `ODOM x y θ tv rv accel [timestamp hostname logger_timestamp]`: checked
//!   (a malformed one is reported) but not needed: each scan line carries the
//!   odometry interpolated at the scan's time.
//!
//! Every other line (`PARAM`, `SYNC`, `RLASER`, `RAWLASER*`, `TRUEPOS`,
//! `NMEA*`, comments, …) is skipped. Numbers are read as `f64`; scan values
//! become `f32` exactly as the pair files' JSON reader makes them, so a scan
//! gives the same grid in both formats. A range that is not a finite number
//! is an error of its line (CARMEN writes only real readings).

use std::f64::consts::PI;
use std::io::BufRead;

use crate::error::RecordError;
use crate::model::{wrap_rad, Event, Odometry, Pose, Scan};
use crate::pairs::ScanRecord;

/// How `FLASER` lines become scans (they carry no geometry).
#[derive(Clone, Copy, Debug)]
pub struct FlaserGeometry {
    /// A reading at or beyond this is "no return", metres.
    pub max_range: f32,
    /// Laser pose `[x, y, θ]` in the robot frame.
    pub laser_offset: [f32; 3],
}

/// Reads a CARMEN log one line at a time (constant memory).
pub struct CarmenReader<R> {
    input: R,
    geometry: FlaserGeometry,
    line: Vec<u8>,
    line_no: usize,
    done: bool,
}

impl<R: BufRead> CarmenReader<R> {
    /// A reader over `input`.
    pub fn new(input: R, geometry: FlaserGeometry) -> Self {
        Self {
            input,
            geometry,
            line: Vec::new(),
            line_no: 0,
            done: false,
        }
    }
}

impl<R: BufRead> Iterator for CarmenReader<R> {
    type Item = Result<Event, RecordError>;

    fn next(&mut self) -> Option<Self::Item> {
        while !self.done {
            self.line.clear();
            match self.input.read_until(b'\n', &mut self.line) {
                Ok(0) => self.done = true,
                Ok(_) => {
                    self.line_no += 1;
                    let record = format!("line {}", self.line_no);
                    let Ok(text) = std::str::from_utf8(&self.line) else {
                        return Some(Err(RecordError::new(record, "not UTF-8 text")));
                    };
                    match parse_line(text, &self.geometry) {
                        Ok(Some(event)) => return Some(Ok(event.with_record(record))),
                        Ok(None) => {}
                        Err(message) => return Some(Err(RecordError::new(record, message))),
                    }
                }
                Err(e) => {
                    self.done = true;
                    return Some(Err(RecordError::new(
                        format!("after line {}", self.line_no),
                        format!("cannot read further: {e}"),
                    )));
                }
            }
        }
        None
    }
}

/// The fields of one line, with their 1-based positions for messages.
struct Fields<'a> {
    kind: &'a str,
    fields: Vec<&'a str>,
}

impl<'a> Fields<'a> {
    fn need(&self, count: usize, what: &str) -> Result<(), String> {
        if self.fields.len() < count {
            return Err(format!(
                "{}: too few fields: {} after the message name, need at least {count} ({what})",
                self.kind,
                self.fields.len()
            ));
        }
        Ok(())
    }

    fn number(&self, i: usize, name: &str) -> Result<f64, String> {
        let text = self.fields.get(i).copied().unwrap_or("");
        match text.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(format!(
                "{}: field {} ({name}) is {text:?}, not a finite number",
                self.kind,
                i + 2
            )),
        }
    }

    fn count(&self, i: usize, name: &str) -> Result<usize, String> {
        let text = self.fields.get(i).copied().unwrap_or("");
        text.parse::<usize>().map_err(|_| {
            format!(
                "{}: field {} ({name}) is {text:?}, not a count",
                self.kind,
                i + 2
            )
        })
    }

    fn pose(&self, i: usize, name: &str) -> Result<Pose, String> {
        Ok(Pose {
            x: self.number(i, &format!("{name} x"))?,
            y: self.number(i + 1, &format!("{name} y"))?,
            theta: self.number(i + 2, &format!("{name} θ"))?,
        })
    }

    fn ranges(&self, start: usize, n: usize) -> Result<Vec<Option<f32>>, String> {
        (start..start + n)
            .map(|i| {
                self.number(i, &format!("range {}", i - start))
                    .map(|v| Some(v as f32))
            })
            .collect()
    }

    fn time(&self, i: usize) -> Option<f64> {
        self.fields
            .get(i)
            .and_then(|t| t.parse::<f64>().ok())
            .filter(|t| t.is_finite())
    }
}

/// The beam spacing CARMEN assumes for `n` beams over a half turn.
pub fn guess_increment(n: usize) -> f64 {
    match n {
        180 | 181 => PI / 180.0,
        360 | 361 => PI / 360.0,
        400 | 401 => PI / 720.0,
        _ => PI / (n.max(2) - 1) as f64,
    }
}

/// One line: `Ok(None)` for a line of a type the tool does not use.
fn parse_line(text: &str, geometry: &FlaserGeometry) -> Result<Option<Event>, String> {
    let mut tokens = text.split_ascii_whitespace();
    let Some(kind) = tokens.next() else {
        return Ok(None);
    };
    let line = Fields {
        kind,
        fields: tokens.collect(),
    };
    match kind {
        "FLASER" => flaser(&line, geometry).map(Some),
        "ROBOTLASER1" => robotlaser1(&line).map(Some),
        "ODOM" => {
            line.need(6, "x y θ tv rv accel")?;
            Ok(Some(Event::Odometry(Odometry {
                time: line.time(6),
                pose: line.pose(0, "odometry")?,
            })))
        }
        _ => Ok(None),
    }
}

fn flaser(line: &Fields<'_>, geometry: &FlaserGeometry) -> Result<Event, String> {
    line.need(1, "the number of readings")?;
    let n = line.count(0, "number of readings")?;
    if n == 0 {
        return Err("FLASER: no readings".into());
    }
    line.need(
        n.saturating_add(7),
        &format!("{n} readings, then x y θ odom_x odom_y odom_θ"),
    )?;
    let ranges = line.ranges(1, n)?;
    let pose = line.pose(n + 1, "pose")?;
    let odom = line.pose(n + 4, "odometry")?;
    Ok(Event::Scan(Scan {
        record: ScanRecord {
            ranges,
            angle_min: (-PI / 2.0) as f32,
            angle_increment: guess_increment(n) as f32,
            max_range: geometry.max_range,
            laser_offset: geometry.laser_offset,
        },
        time: line.time(n + 7),
        odom: Some(odom),
        log_pose: Some(pose),
        name: String::new(),
    }))
}

fn robotlaser1(line: &Fields<'_>) -> Result<Event, String> {
    const HEAD: &str =
        "type start_angle fov angular_resolution max_range accuracy remission_mode n";
    line.need(8, HEAD)?;
    let start = line.number(1, "start_angle")?;
    let resolution = line.number(3, "angular_resolution")?;
    let max_range = line.number(4, "max_range")?;
    let n = line.count(7, "number of readings")?;
    if n == 0 {
        return Err("ROBOTLASER1: no readings".into());
    }
    line.need(
        n.saturating_add(9),
        "the readings and the number of remissions",
    )?;
    let ranges = line.ranges(8, n)?;
    let m = line.count(n + 8, "number of remissions")?;
    let poses = (n + 9).saturating_add(m);
    line.need(
        poses.saturating_add(11),
        "remissions, laser pose, robot pose, tv rv forward_safety side_safety turn_axis",
    )?;
    let laser = line.pose(poses, "laser pose")?;
    let robot = line.pose(poses + 3, "robot pose")?;
    // The laser's pose in the robot frame.
    let (s, c) = robot.theta.sin_cos();
    let (ex, ey) = (laser.x - robot.x, laser.y - robot.y);
    let offset = [
        (c * ex + s * ey) as f32,
        (-s * ex + c * ey) as f32,
        wrap_rad(laser.theta - robot.theta) as f32,
    ];
    Ok(Event::Scan(Scan {
        record: ScanRecord {
            ranges,
            angle_min: start as f32,
            angle_increment: resolution as f32,
            max_range: max_range as f32,
            laser_offset: offset,
        },
        time: line.time(poses + 11),
        odom: Some(robot),
        log_pose: None,
        name: String::new(),
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    const GEOMETRY: FlaserGeometry = FlaserGeometry {
        max_range: 81.91,
        laser_offset: [0.0; 3],
    };

    fn parse(text: &str) -> Result<Option<Event>, String> {
        parse_line(text, &GEOMETRY)
    }

    #[test]
    fn flaser_reads_ranges_poses_and_time() {
        let Ok(Some(Event::Scan(s))) =
            parse("FLASER 3 1.5 2.0 81.91 1 2 0.5 1.1 2.1 0.6 123.25 host 124.0")
        else {
            panic!("not a scan");
        };
        assert_eq!(s.record.ranges, vec![Some(1.5), Some(2.0), Some(81.91)]);
        assert_eq!(s.record.angle_min, (-PI / 2.0) as f32);
        assert_eq!(
            s.log_pose,
            Some(Pose {
                x: 1.0,
                y: 2.0,
                theta: 0.5
            })
        );
        assert_eq!(s.odom.map(|p| p.theta), Some(0.6));
        assert_eq!(s.time, Some(123.25));
    }

    #[test]
    fn robotlaser1_gives_the_offset_in_the_robot_frame() {
        // Robot at (1, 1) facing +y; laser 0.2 m ahead of it, same heading.
        let Ok(Some(Event::Scan(s))) = parse(
            "ROBOTLASER1 0 -1.5708 3.1416 0.5 30 0.01 0 2 1 2 0 1 1.2 1.5708 1 1 1.5708 0 0 0 0 0 7.5 h 7.6",
        ) else {
            panic!("not a scan");
        };
        assert!((s.record.laser_offset[0] - 0.2).abs() < 1e-5);
        assert!(s.record.laser_offset[1].abs() < 1e-5);
        assert_eq!(s.record.angle_increment, 0.5);
        assert_eq!(s.record.max_range, 30.0);
        assert_eq!(s.time, Some(7.5));
    }

    #[test]
    fn short_and_nan_lines_are_errors_and_others_skipped() {
        let short = parse("FLASER 3 1 2 3 0 0").unwrap_err();
        assert!(short.contains("too few fields"), "{short}");
        let nan = parse("FLASER 2 1 nan 0 0 0 0 0 0").unwrap_err();
        assert!(nan.contains("field 4 (range 1)"), "{nan}");
        assert!(matches!(parse("PARAM robot_length 0.5"), Ok(None)));
        assert!(matches!(parse("   "), Ok(None)));
        assert!(parse("ODOM 1 2").is_err());
        // A remission count beyond any length is an error, not an overflow.
        let huge = format!(
            "ROBOTLASER1 0 -1.5 3.1 0.5 30 0.01 0 1 1 {} 0 0 0",
            usize::MAX
        );
        assert!(parse(&huge).unwrap_err().contains("too few fields"));
        assert!(parse(&format!("FLASER {} 1 2", usize::MAX)).is_err());
    }

    #[test]
    fn increments_follow_carmen() {
        assert_eq!(guess_increment(181), PI / 180.0);
        assert_eq!(guess_increment(361), PI / 360.0);
        assert_eq!(guess_increment(91), PI / 90.0);
    }
}
