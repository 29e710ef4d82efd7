//! Raw lidar captures (issue 25): the bytes as they came off the UART of an
//! LDRobot LD06 / LD19 / STL-19P, a Slamtec RPLIDAR (standard scan), a
//! YDLIDAR X2 / X4 or a Neato XV-11 / LDS02RR, decoded by the `hough-lidar` crate into one scan per
//! revolution.
//!
//! - `log CAPTURE --format ld06|rplidar|ydlidar|xv11` estimates the motion
//!   between the revolutions ([`WireReader`] feeds `log`'s pairing);
//! - `wire --protocol P CAPTURE --out LOG` writes the revolutions as a
//!   CARMEN log, one `ROBOTLASER1` line each, which `log` (and other CARMEN
//!   tools) read back.
//!
//! A revolution has [`BINS`] beams: beam `i` at `i·0.5°` counter-clockwise
//! from the sensor's zero (`angle_min` 0, `angle_increment` 2π/720, field
//! of view 2π), ranges in metres, `max_range` (the `--max-range` option)
//! where the bin holds no return. The counters of the parser (what it
//! dropped, by cause) and of the assembler are printed on stderr.

use std::fmt;
use std::io::Read;

use clap::ValueEnum;
use hough_lidar::ld06::Ld06Layout;
use hough_lidar::rplidar::RplidarLayout;
use hough_lidar::xv11::Xv11Layout;
use hough_lidar::ydlidar::YdlidarLayout;
use hough_lidar::{
    AssemblerCounters, Counters, Layout, Ld06, Lidar, Revolution, Rplidar, Xv11, Ydlidar,
};

use crate::error::RecordError;
use crate::model::{Event, Scan};
use crate::pairs::ScanRecord;

/// Beams a revolution: 0.5° apart.
pub const BINS: usize = 720;

/// A lidar's wire protocol.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Protocol {
    /// LDRobot LD06 / LD19 / STL-19P (47-byte packets, CRC-8).
    Ld06,
    /// Slamtec RPLIDAR A1 / A2 / C1, standard scan (5-byte nodes).
    Rplidar,
    /// YDLIDAR X2 / X4 (`AA 55` packets, XOR check, angle correction).
    Ydlidar,
    /// Neato XV-11 / LDS02RR (22-byte `FA` packets, 15-bit checksum).
    Xv11,
}

impl fmt::Display for Protocol {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Protocol::Ld06 => "ld06",
            Protocol::Rplidar => "rplidar",
            Protocol::Ydlidar => "ydlidar",
            Protocol::Xv11 => "xv11",
        })
    }
}

/// One protocol's parser and assembler.
enum AnyLidar {
    Ld06(Box<Lidar<Ld06Layout, { Ld06::CAPACITY }, BINS>>),
    Rplidar(Box<Lidar<RplidarLayout, { Rplidar::CAPACITY }, BINS>>),
    Ydlidar(Box<Lidar<YdlidarLayout, { Ydlidar::CAPACITY }, BINS>>),
    Xv11(Box<Lidar<Xv11Layout, { Xv11::CAPACITY }, BINS>>),
}

/// Feeds a byte (`None`: the end of the stream); a completed revolution,
/// copied out.
fn feed<L: Layout, const CAP: usize>(
    lidar: &mut Lidar<L, CAP, BINS>,
    byte: Option<u8>,
) -> Option<Turn> {
    let done = match byte {
        Some(b) => lidar.push(b),
        None => lidar.step(),
    };
    if !done {
        return None;
    }
    lidar.revolution().map(|r| Turn {
        ranges: r.ranges.to_vec(),
        quality: r.quality.to_vec(),
        index: r.index,
    })
}

/// A revolution: ranges (metres) and quality bytes of its [`BINS`] beams.
#[derive(Clone, Debug, PartialEq)]
pub struct Turn {
    /// Range of beam `i`, metres (`max_range`: no return).
    pub ranges: Vec<f32>,
    /// The sensor's quality byte of beam `i`.
    pub quality: Vec<u8>,
    /// Index among the complete revolutions.
    pub index: u32,
}

impl AnyLidar {
    fn new(protocol: Protocol, max_range: f32) -> Self {
        match protocol {
            Protocol::Ld06 => AnyLidar::Ld06(Box::new(Lidar::new(Ld06::new(), max_range))),
            Protocol::Rplidar => AnyLidar::Rplidar(Box::new(Lidar::new(Rplidar::new(), max_range))),
            Protocol::Ydlidar => AnyLidar::Ydlidar(Box::new(Lidar::new(Ydlidar::new(), max_range))),
            Protocol::Xv11 => AnyLidar::Xv11(Box::new(Lidar::new(Xv11::new(), max_range))),
        }
    }

    /// Feeds a byte (`None`: the end of the stream); a completed revolution.
    fn feed(&mut self, byte: Option<u8>) -> Option<Turn> {
        match self {
            AnyLidar::Ld06(l) => feed(l, byte),
            AnyLidar::Rplidar(l) => feed(l, byte),
            AnyLidar::Ydlidar(l) => feed(l, byte),
            AnyLidar::Xv11(l) => feed(l, byte),
        }
    }

    fn counters(&self) -> (Counters, AssemblerCounters) {
        match self {
            AnyLidar::Ld06(l) => (*l.parser().counters(), *l.assembler().counters()),
            AnyLidar::Rplidar(l) => (*l.parser().counters(), *l.assembler().counters()),
            AnyLidar::Ydlidar(l) => (*l.parser().counters(), *l.assembler().counters()),
            AnyLidar::Xv11(l) => (*l.parser().counters(), *l.assembler().counters()),
        }
    }
}

/// Reads a capture and yields its revolutions as `log` events.
pub struct WireReader<R> {
    input: R,
    lidar: AnyLidar,
    protocol: Protocol,
    max_range: f32,
    laser_offset: [f32; 3],
    buf: Vec<u8>,
    pos: usize,
    len: usize,
    done: bool,
    error: Option<String>,
}

impl<R: Read> WireReader<R> {
    /// A reader of `protocol` over `input`; returns at or beyond
    /// `max_range` metres are "no return"; the sensor at `laser_offset`
    /// (`x, y, θ`) on the robot.
    pub fn new(input: R, protocol: Protocol, max_range: f32, laser_offset: [f32; 3]) -> Self {
        Self {
            input,
            lidar: AnyLidar::new(protocol, max_range),
            protocol,
            max_range,
            laser_offset,
            buf: vec![0; 1 << 16],
            pos: 0,
            len: 0,
            done: false,
            error: None,
        }
    }

    /// The next revolution, or `None` at the end of the capture.
    pub fn next_turn(&mut self) -> Option<Turn> {
        loop {
            while self.pos < self.len {
                let byte = self.buf.get(self.pos).copied();
                self.pos += 1;
                if let Some(turn) = self.lidar.feed(byte) {
                    return Some(turn);
                }
            }
            if self.done {
                return self.lidar.feed(None);
            }
            match self.input.read(&mut self.buf) {
                Ok(0) => self.done = true,
                Ok(n) => (self.pos, self.len) = (0, n),
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => {
                    self.error = Some(e.to_string());
                    self.done = true;
                }
            }
        }
    }

    /// The scan of a revolution, as the pair files store it.
    pub fn record(&self, turn: &Turn) -> ScanRecord {
        ScanRecord {
            ranges: turn.ranges.iter().map(|&r| Some(r)).collect(),
            angle_min: 0.0,
            angle_increment: Revolution::<'_, BINS>::increment_rad(),
            max_range: self.max_range,
            laser_offset: self.laser_offset,
        }
    }

    /// The counters, one line for stderr.
    pub fn report(&self) -> String {
        let (c, a) = self.lidar.counters();
        format!(
            "{}: {} packets ({} points), {} revolutions; dropped: {} bad checksum, {} bad framing, \
             {} out of range, {} bytes skipped, {} points before the first full turn; \
             {} response descriptors skipped{}",
            self.protocol,
            c.packets,
            c.points,
            a.revolutions,
            c.bad_checksum,
            c.bad_framing,
            c.out_of_range,
            c.skipped_bytes,
            a.leading_points,
            c.descriptors,
            self.error
                .as_ref()
                .map_or(String::new(), |e| format!("; read error: {e}"))
        )
    }
}

impl<R: Read> Iterator for WireReader<R> {
    type Item = Result<Event, RecordError>;

    fn next(&mut self) -> Option<Self::Item> {
        let turn = self.next_turn()?;
        Some(Ok(Event::Scan(Scan {
            record: self.record(&turn),
            time: None,
            odom: None,
            log_pose: None,
            name: format!("revolution {}", turn.index),
        })))
    }
}
