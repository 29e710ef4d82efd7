//! `wire --protocol P CAPTURE --out LOG`: a raw lidar capture (LD06,
//! RPLIDAR, YDLIDAR, XV-11 bytes) written as a CARMEN log, one
//! `ROBOTLASER1` line per revolution, which `log` (and other CARMEN tools)
//! read back. The capture is read by the recordings crate's
//! [`WireReader`]; the counters of the parser and the assembler are printed
//! on stderr.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::PathBuf;

use clap::Args;
use hough_heading_recordings::wire::{Protocol, WireReader, BINS};
use hough_heading_recordings::Fatal;

/// `wire --protocol P CAPTURE --out LOG`.
#[derive(Clone, Debug, Args)]
pub struct WireArgs {
    /// The capture: the bytes as they came off the lidar's UART.
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
/// # Errors
/// Unusable arguments, an unreadable capture or an unwritable log; a capture
/// without one complete revolution.
pub fn run(args: &WireArgs) -> Result<usize, Fatal> {
    let offset = geometry(args.max_range, args.laser_offset.as_deref())?;
    let name = args.capture.display().to_string();
    let file =
        File::open(&args.capture).map_err(|e| Fatal::io(format!("{name}: cannot read: {e}")))?;
    let mut reader = WireReader::new(file, args.protocol, args.max_range, offset);
    let out_name = args.out.display().to_string();
    let sink: Box<dyn Write> = if out_name == "-" {
        Box::new(std::io::stdout().lock())
    } else {
        Box::new(
            File::create(&args.out)
                .map_err(|e| Fatal::io(format!("{out_name}: cannot write: {e}")))?,
        )
    };
    let mut out = BufWriter::new(sink);
    let io = |e: std::io::Error| Fatal::io(format!("{out_name}: cannot write: {e}"));
    writeln!(
        out,
        "# CARMEN log written by hough-heading wire from {name} ({} capture)\n\
         # ROBOTLASER1 type start_angle fov angular_resolution max_range accuracy remission_mode \
         n ranges m remissions laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv \
         forward_safety side_safety turn_axis timestamp hostname logger_timestamp\n\
         # one line per revolution: beam i at i*0.5 deg counter-clockwise from the sensor's zero, \
         remissions = the sensor's quality bytes, robot pose unknown (0 0 0), \
         timestamp = the revolution's index (the capture has no clock)",
        args.protocol
    )
    .map_err(io)?;
    let mut written = 0;
    while let Some(turn) = reader.next_turn() {
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
        let i = turn.index;
        writeln!(out, " {x} {y} {t} 0 0 0 0 0 0 0 0 {i} hough-lidar {i}").map_err(io)?;
        written += 1;
    }
    out.flush().map_err(io)?;
    eprintln!("hough-heading: {name}: {}", reader.report());
    if written == 0 {
        return Err(Fatal::io(format!("{name}: no complete revolution")));
    }
    Ok(written)
}
