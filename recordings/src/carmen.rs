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
//! - `TRUEPOS true_x true_y true_θ odom_x odom_y odom_θ [timestamp hostname
//!   logger_timestamp]` (a simulator's true pose): the log's pose of the
//!   scan line with the same time stamp (within [`SAME_TIME_S`]), before or
//!   after it, or, where either has no time, of the scan line just before
//!   it. It replaces a `FLASER` line's own pose.
//! - `PARAM hough_heading_odometry none` and `PARAM hough_heading_clock
//!   none` (as `hough-heading wire` writes them): the scan lines after it
//!   carry no odometry, or no time stamp, whatever their fields hold (a raw
//!   capture has neither; the fields then hold placeholders).
//!
//! Every other line (other `PARAM`s, `SYNC`, `RLASER`, `RAWLASER*`,
//! `NMEA*`, comments, …) is skipped. Numbers are read as `f64`; scan values
//! become `f32` exactly as the pair files' JSON reader makes them, so a scan
//! gives the same grid in both formats. A range written as `nan`, `inf` or
//! `-inf` (SICK drivers write them for a beam without an echo) is a beam
//! without a reading, as the LaserScan readers make a non-finite range: the
//! line is kept and the beam is counted by `log` (`Scan::missing_readings`)
//! and, per pair, in the line's `dropped.not_finite`. Any other field that
//! is not a number is an error of its line.

use std::collections::VecDeque;
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

/// A `TRUEPOS` line and a scan line belong together when their time stamps
/// differ by at most this, seconds.
pub const SAME_TIME_S: f64 = 1e-3;

/// Reads a CARMEN log one line at a time (constant memory: the last scan
/// line is held until the next line that is not `TRUEPOS`).
pub struct CarmenReader<R> {
    input: R,
    geometry: FlaserGeometry,
    line: Vec<u8>,
    line_no: usize,
    done: bool,
    /// What `PARAM hough_heading_*` lines said so far.
    unknown: Unknown,
    /// The last scan line read, until a later line says it is complete.
    held: Option<Scan>,
    /// The last `TRUEPOS` line, for a scan line of the same time after it.
    true_pose: Option<(Option<f64>, Pose)>,
    /// Events ready to be handed out, in the file's order.
    ready: VecDeque<Result<Event, RecordError>>,
}

/// What the log says it does not know (`PARAM hough_heading_odometry none`,
/// `PARAM hough_heading_clock none`).
#[derive(Clone, Copy, Debug, Default)]
struct Unknown {
    odometry: bool,
    clock: bool,
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
            unknown: Unknown::default(),
            held: None,
            true_pose: None,
            ready: VecDeque::new(),
        }
    }

    /// Reads one line into `ready` (or holds its scan).
    fn read_line(&mut self) {
        self.line.clear();
        match self.input.read_until(b'\n', &mut self.line) {
            Ok(0) => self.done = true,
            Ok(_) => {
                self.line_no += 1;
                let record = format!("line {}", self.line_no);
                let Ok(text) = std::str::from_utf8(&self.line) else {
                    self.release();
                    self.ready
                        .push_back(Err(RecordError::new(record, "not UTF-8 text")));
                    return;
                };
                match parse_line(text, &self.geometry) {
                    Ok(Some(Line::Event(Event::Scan(scan)))) => {
                        self.release();
                        self.held = Some(self.complete(scan, record));
                    }
                    Ok(Some(Line::Event(event))) => {
                        self.release();
                        self.ready.push_back(Ok(event));
                    }
                    Ok(Some(Line::TruePose(time, pose))) => self.true_pose(time, pose),
                    Ok(Some(Line::Unknown(unknown))) => {
                        self.unknown.odometry |= unknown.odometry;
                        self.unknown.clock |= unknown.clock;
                    }
                    Ok(None) => {}
                    Err(message) => {
                        self.release();
                        self.ready.push_back(Err(RecordError::new(record, message)));
                    }
                }
            }
            Err(e) => {
                self.done = true;
                self.release();
                self.ready.push_back(Err(RecordError::new(
                    format!("after line {}", self.line_no),
                    format!("cannot read further: {e}"),
                )));
            }
        }
    }

    /// A scan line as the log's `PARAM`s and a `TRUEPOS` before it say.
    fn complete(&mut self, mut scan: Scan, record: String) -> Scan {
        scan.name = record;
        if self.unknown.odometry {
            scan.odom = None;
        }
        if self.unknown.clock {
            scan.time = None;
        }
        if let Some((Some(t), pose)) = self.true_pose {
            if scan.time.is_some_and(|s| (s - t).abs() <= SAME_TIME_S) {
                scan.log_pose = Some(pose);
                self.true_pose = None;
            }
        }
        scan
    }

    /// A `TRUEPOS` line: the pose of the held scan when their times agree
    /// (or either has none), else kept for a scan line of its time.
    fn true_pose(&mut self, time: Option<f64>, pose: Pose) {
        let time = time.filter(|_| !self.unknown.clock);
        match &mut self.held {
            Some(scan)
                if match (scan.time, time) {
                    (Some(s), Some(t)) => (s - t).abs() <= SAME_TIME_S,
                    _ => true,
                } =>
            {
                scan.log_pose = Some(pose);
            }
            _ => self.true_pose = Some((time, pose)),
        }
    }

    /// Hands the held scan out.
    fn release(&mut self) {
        if let Some(scan) = self.held.take() {
            self.ready.push_back(Ok(Event::Scan(scan)));
        }
    }
}

impl<R: BufRead> Iterator for CarmenReader<R> {
    type Item = Result<Event, RecordError>;

    fn next(&mut self) -> Option<Self::Item> {
        while self.ready.is_empty() && !self.done {
            self.read_line();
        }
        if self.done {
            self.release();
        }
        self.ready.pop_front()
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

    /// `n` ranges from field `start`: a non-finite one (`nan`, `inf`) is a
    /// beam without a reading.
    fn ranges(&self, start: usize, n: usize) -> Result<Vec<Option<f32>>, String> {
        (start..start + n)
            .map(|i| {
                let text = self.fields.get(i).copied().unwrap_or("");
                match text.parse::<f64>() {
                    Ok(v) => Ok(v.is_finite().then_some(v as f32)),
                    Err(_) => Err(format!(
                        "{}: field {} (range {}) is {text:?}, not a number",
                        self.kind,
                        i + 2,
                        i - start
                    )),
                }
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

/// What a line holds.
enum Line {
    /// A scan or an odometry pose.
    Event(Event),
    /// A `TRUEPOS` line: its time stamp and the true pose.
    TruePose(Option<f64>, Pose),
    /// A `PARAM hough_heading_odometry|clock none` line.
    Unknown(Unknown),
}

/// One line: `Ok(None)` for a line of a type the tool does not use.
fn parse_line(text: &str, geometry: &FlaserGeometry) -> Result<Option<Line>, String> {
    let mut tokens = text.split_ascii_whitespace();
    let Some(kind) = tokens.next() else {
        return Ok(None);
    };
    let line = Fields {
        kind,
        fields: tokens.collect(),
    };
    match kind {
        "FLASER" => flaser(&line, geometry).map(|e| Some(Line::Event(e))),
        "ROBOTLASER1" => robotlaser1(&line).map(|e| Some(Line::Event(e))),
        "ODOM" => {
            line.need(6, "x y θ tv rv accel")?;
            Ok(Some(Line::Event(Event::Odometry(Odometry {
                time: line.time(6),
                pose: line.pose(0, "odometry")?,
            }))))
        }
        "TRUEPOS" => {
            line.need(6, "true_x true_y true_θ odom_x odom_y odom_θ")?;
            Ok(Some(Line::TruePose(
                line.time(6),
                line.pose(0, "true pose")?,
            )))
        }
        "PARAM" => Ok(match (line.fields.first(), line.fields.get(1)) {
            (Some(&"hough_heading_odometry"), Some(&"none")) => Some(Line::Unknown(Unknown {
                odometry: true,
                clock: false,
            })),
            (Some(&"hough_heading_clock"), Some(&"none")) => Some(Line::Unknown(Unknown {
                odometry: false,
                clock: true,
            })),
            _ => None,
        }),
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

    /// The event of one line (`None`: skipped, or not an event).
    fn parse(text: &str) -> Result<Option<Event>, String> {
        parse_line(text, &GEOMETRY).map(|line| match line {
            Some(Line::Event(e)) => Some(e),
            _ => None,
        })
    }

    /// Every event of a whole log, errors as their messages.
    fn read(log: &str) -> Vec<Result<Event, String>> {
        CarmenReader::new(log.as_bytes(), GEOMETRY)
            .map(|e| e.map_err(|e| format!("{}: {}", e.record, e.message)))
            .collect()
    }

    fn scans(log: &str) -> Vec<Scan> {
        read(log)
            .into_iter()
            .filter_map(|e| match e {
                Ok(Event::Scan(s)) => Some(s),
                _ => None,
            })
            .collect()
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
    fn non_finite_ranges_are_beams_without_a_reading() {
        // As a SICK driver writes a beam without an echo: the line is kept.
        let Ok(Some(Event::Scan(s))) = parse("FLASER 4 1 nan inf -INF 0 0 0 0 0 0") else {
            panic!("not a scan");
        };
        assert_eq!(s.record.ranges, vec![Some(1.0), None, None, None]);
        assert_eq!(s.missing_readings(), 3);
        let Ok(Some(Event::Scan(s))) = parse(
            "ROBOTLASER1 0 -1.5708 3.1416 0.5 30 0.01 0 3 NaN 2 Infinity 0 0 0 0 0 0 0 0 0 0 0 0 0 0",
        ) else {
            panic!("not a scan");
        };
        assert_eq!(s.record.ranges, vec![None, Some(2.0), None]);
        // A field that is no number at all is still an error of its line.
        let text = parse("FLASER 2 1 x 0 0 0 0 0 0").unwrap_err();
        assert!(text.contains("field 4 (range 1)"), "{text}");
        // A non-finite pose is no pose.
        assert!(parse("FLASER 1 1 nan 0 0 0 0 0").is_err());
    }

    #[test]
    fn truepos_is_the_pose_of_the_scan_of_its_time() {
        let laser = |t: f64| {
            format!("ROBOTLASER1 0 -1.5 3.1 0.5 30 0.01 0 1 1 0 0 0 0 0 0 0 0 0 0 0 0 {t} h {t}")
        };
        let log = [
            laser(0.0),
            "TRUEPOS 1 2 0.5 9 9 9 0.0 sim 0.0".into(),
            // An odometry line between does not separate them by time.
            "ODOM 0 0 0 0 0 0 0.05 h 0.05".into(),
            "TRUEPOS 3 4 0.25 9 9 9 0.1 sim 0.1".into(),
            laser(0.1),
            laser(0.2),
            // Not its time: the scan keeps none.
            "TRUEPOS 5 6 0.125 9 9 9 0.3 sim 0.3".into(),
        ]
        .join("\n");
        let poses: Vec<Option<(f64, f64, f64)>> = scans(&log)
            .iter()
            .map(|s| s.log_pose.map(|p| (p.x, p.y, p.theta)))
            .collect();
        assert_eq!(
            poses,
            vec![Some((1.0, 2.0, 0.5)), Some((3.0, 4.0, 0.25)), None]
        );
        // The events stay in the file's order.
        let kinds: Vec<&str> = read(&log)
            .iter()
            .map(|e| match e {
                Ok(Event::Scan(_)) => "scan",
                Ok(Event::Odometry(_)) => "odom",
                Err(_) => "error",
            })
            .collect();
        assert_eq!(kinds, ["scan", "odom", "scan", "scan"]);
        // Without times, a TRUEPOS line is the scan line's just before it.
        let untimed = "FLASER 1 1 0 0 0 0 0 0\nTRUEPOS 7 8 0.5 0 0 0";
        assert_eq!(scans(untimed)[0].log_pose.map(|p| p.x), Some(7.0));
    }

    #[test]
    fn params_say_what_the_log_does_not_know() {
        let laser = "ROBOTLASER1 0 -1.5 3.1 0.5 30 0.01 0 1 1 0 0 0 0 0 0 0 0 0 0 0 0 7 h 7";
        let before = scans(laser);
        assert!(before[0].odom.is_some() && before[0].time == Some(7.0));
        let log = format!(
            "PARAM hough_heading_odometry none\n{laser}\nPARAM hough_heading_clock none\n{laser}"
        );
        let after = scans(&log);
        assert!(after[0].odom.is_none() && after[0].time == Some(7.0));
        assert!(after[1].odom.is_none() && after[1].time.is_none());
    }

    #[test]
    fn short_and_malformed_lines_are_errors_and_others_skipped() {
        let short = parse("FLASER 3 1 2 3 0 0").unwrap_err();
        assert!(short.contains("too few fields"), "{short}");
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
