//! `wire --protocol P CAPTURE --out LOG`: a raw lidar capture (LD06,
//! RPLIDAR, YDLIDAR, XV-11 bytes) written as a CARMEN log, one
//! `ROBOTLASER1` line per revolution, which `log` (and other CARMEN tools)
//! read back. The capture is read by the recordings crate's
//! [`WireReader`]; the counters of the parser and the assembler are printed
//! on stderr.

use std::fs::File;
use std::io::{BufWriter, Read, Write};
use std::path::PathBuf;

use clap::Args;
use hough_heading_recordings::capture_file::capture_bytes;
use hough_heading_recordings::open::open;
use hough_heading_recordings::wire::{Protocol, WireReader, BINS};
use hough_heading_recordings::Fatal;
use indicatif::ProgressBar;

/// `wire --protocol P CAPTURE --out LOG`.
#[derive(Clone, Debug, Args)]
pub struct WireArgs {
    /// The capture: the bytes as they came off the lidar's UART, as stored
    /// (gzip read directly) or as hex text (`54 2C …`, one packet a line or
    /// not).
    pub capture: PathBuf,
    /// The lidar's protocol.
    #[arg(long, value_enum)]
    pub protocol: Protocol,
    /// The CARMEN log to write (`-`: stdout).
    #[arg(long, value_name = "LOG")]
    pub out: PathBuf,
    /// Returns at or beyond this are "no return", metres.
    #[arg(long, value_name = "METRES", default_value_t = 81.91)]
    pub max_range: f32,
    /// The lidar's pose `X,Y,THETA` (metres, radians) on the robot.
    #[arg(long, value_name = "X,Y,THETA", value_delimiter = ',', num_args = 3)]
    pub laser_offset: Option<Vec<f32>>,
}

/// Checks `--max-range` and `--laser-offset`.
///
/// # Errors
/// A usage error for a non-positive range or an offset that is not three
/// finite numbers.
pub fn geometry(max_range: f32, offset: Option<&[f32]>) -> Result<[f32; 3], Fatal> {
    if !(max_range.is_finite() && max_range > 0.0) {
        return Err(Fatal::usage(format!(
            "--max-range {max_range}: must be a positive number of metres"
        )));
    }
    match offset {
        None => Ok([0.0; 3]),
        Some(&[x, y, t]) if [x, y, t].iter().all(|v| v.is_finite()) => Ok([x, y, t]),
        Some(v) => Err(Fatal::usage(format!(
            "--laser-offset {v:?}: expected three finite numbers X,Y,THETA"
        ))),
    }
}

/// Runs `wire`: the number of revolutions written.
///
/// The log says what the capture does not know: the robot's pose is
/// unknown (`PARAM hough_heading_odometry none`; the pose fields hold
/// `0 0 0`, which other CARMEN readers take at face value), and where the
/// packets carry no clock (RPLIDAR, YDLIDAR) `PARAM hough_heading_clock
/// none` (the time fields then hold the revolution's index). A run that
/// fails leaves no output file.
///
/// # Errors
/// Unusable arguments, an unreadable capture or an unwritable log; a capture
/// without one complete revolution.
pub fn run(args: &WireArgs) -> Result<usize, Fatal> {
    let offset = geometry(args.max_range, args.laser_offset.as_deref())?;
    let name = args.capture.display().to_string();
    let input = open(&args.capture, &ProgressBar::hidden())?;
    let bytes = capture_bytes(input, &name, args.protocol)?;
    let mut reader = WireReader::new(bytes, args.protocol, args.max_range, offset);
    let out_name = args.out.display().to_string();
    if out_name == "-" {
        let mut out = BufWriter::new(std::io::stdout().lock());
        return write_log(&mut reader, args.protocol, &name, &mut out, &out_name);
    }
    // Written beside the target and renamed at the end: a failed run
    // leaves neither a partial log nor a header-only one.
    let cannot_write = cannot_write(&out_name);
    let mut partial = args.out.clone().into_os_string();
    partial.push(".partial");
    let partial = PathBuf::from(partial);
    let result = File::create(&partial)
        .map_err(cannot_write)
        .and_then(|file| {
            let mut out = BufWriter::new(file);
            write_log(&mut reader, args.protocol, &name, &mut out, &out_name)
        })
        .and_then(|written| {
            std::fs::rename(&partial, &args.out).map_err(cannot_write)?;
            Ok(written)
        });
    if result.is_err() {
        // Nothing to keep; a file that was never created is fine too.
        let _ = std::fs::remove_file(&partial);
    }
    result
}

/// The error of a log that cannot be written to `out_name`.
fn cannot_write(out_name: &str) -> impl Fn(std::io::Error) -> Fatal + Copy + '_ {
    move |e| Fatal::io(format!("{out_name}: cannot write: {e}"))
}

/// Writes the revolutions of `reader` to `out`: the number written.
fn write_log<R: Read>(
    reader: &mut WireReader<R>,
    protocol: Protocol,
    name: &str,
    out: &mut impl Write,
    out_name: &str,
) -> Result<usize, Fatal> {
    let io = cannot_write(out_name);
    let mut written = 0;
    while let Some(turn) = reader.next_turn() {
        if written == 0 {
            write_header(out, protocol, name, turn.time_s.is_some()).map_err(io)?;
        }
        let record = reader.record(&turn);
        write!(
            out,
            "ROBOTLASER1 0 {} {} {} {} 0.01 0 {}",
            record.angle_min,
            std::f32::consts::TAU,
            record.angle_increment,
            record.max_range,
            BINS
        )
        .map_err(io)?;
        for r in &turn.ranges {
            write!(out, " {r}").map_err(io)?;
        }
        write!(out, " {}", BINS).map_err(io)?;
        for q in &turn.quality {
            write!(out, " {q}").map_err(io)?;
        }
        let [x, y, t] = record.laser_offset;
        let time = turn
            .time_s
            .map_or(turn.index.to_string(), |t| t.to_string());
        writeln!(
            out,
            " {x} {y} {t} 0 0 0 0 0 0 0 0 {time} hough-lidar {time}"
        )
        .map_err(io)?;
        written += 1;
    }
    out.flush().map_err(io)?;
    eprintln!("hough-heading: {name}: {}", reader.report());
    if written == 0 {
        return Err(Fatal::io(format!("{name}: no complete revolution")));
    }
    Ok(written)
}

/// The log's header: what it holds, and the `PARAM`s saying what it does
/// not know (`timed`: the revolutions have the capture's own times).
fn write_header(
    out: &mut impl Write,
    protocol: Protocol,
    name: &str,
    timed: bool,
) -> std::io::Result<()> {
    let time = if timed {
        "timestamp = the revolution's time in seconds from the capture's packets \
         (LD06 time stamps, XV-11 motor speed)"
    } else {
        "timestamp = the revolution's index (the packets carry no clock)"
    };
    writeln!(
        out,
        "# CARMEN log written by hough-heading wire from {name} ({protocol} capture)\n\
         # ROBOTLASER1 type start_angle fov angular_resolution max_range accuracy remission_mode \
         n ranges m remissions laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv \
         forward_safety side_safety turn_axis timestamp hostname logger_timestamp\n\
         # one line per revolution: beam i at i*0.5 deg counter-clockwise from the sensor's zero, \
         remissions = the sensor's quality bytes, robot pose unknown (written 0 0 0), {time}\n\
         PARAM hough_heading_odometry none"
    )?;
    if !timed {
        writeln!(out, "PARAM hough_heading_clock none")?;
    }
    Ok(())
}
