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
use hough_lidar::ld06::{self, Ld06Layout};
use hough_lidar::rplidar::RplidarLayout;
use hough_lidar::xv11::{self, Xv11Layout};
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
/// copied out, with what the packet that closed it says of time.
fn feed<L: Layout, const CAP: usize>(
    lidar: &mut Lidar<L, CAP, BINS>,
    byte: Option<u8>,
    tick_of: fn(&[u8]) -> Tick,
) -> Option<(Turn, Tick)> {
    let done = match byte {
        Some(b) => lidar.push(b),
        None => lidar.step(),
    };
    if !done {
        return None;
    }
    let tick = lidar
        .parser()
        .current()
        .map_or(Tick::default(), |p| tick_of(p.bytes()));
    lidar.revolution().map(|r| {
        let turn = Turn {
            ranges: r.ranges.to_vec(),
            quality: r.quality.to_vec(),
            index: r.index,
            time_s: None,
        };
        (turn, tick)
    })
}

/// What a packet says of time: its time stamp (LD06: milliseconds,
/// wrapping at [`LD06_STAMP_WRAP_MS`]) and the revolution period its motor
/// speed gives, seconds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Tick {
    stamp_ms: Option<u16>,
    period_s: Option<f64>,
}

/// The LD06 time stamp wraps at 30 000 ms (its development manual).
const LD06_STAMP_WRAP_MS: u16 = 30_000;

/// A period from a rate, seconds; `None` for a stopped or absurd motor
/// (slower than 1 turn/s or faster than 100 turns/s).
fn period_s(turns_per_s: f64) -> Option<f64> {
    (1.0..=100.0)
        .contains(&turns_per_s)
        .then(|| 1.0 / turns_per_s)
}

fn ld06_tick(packet: &[u8]) -> Tick {
    Tick {
        stamp_ms: Some(ld06::timestamp_ms(packet) % LD06_STAMP_WRAP_MS),
        period_s: period_s(f64::from(ld06::speed_deg_per_s(packet)) / 360.0),
    }
}

fn xv11_tick(packet: &[u8]) -> Tick {
    Tick {
        stamp_ms: None,
        period_s: period_s(f64::from(xv11::rpm(packet)) / 60.0),
    }
}

/// RPLIDAR standard scan and YDLIDAR X2/X4 packets carry neither a time
/// nor the motor speed.
fn no_tick(_: &[u8]) -> Tick {
    Tick::default()
}

/// The revolutions' times from their closing packets' [`Tick`]s, seconds
/// from an arbitrary origin.
///
/// Where packets carry a time stamp (LD06) the time is the stamp, unwrapped
/// (a stamp that did not move takes the motor's period); otherwise the
/// periods are summed (XV-11). A revolution without either has no time,
/// and neither have those after it: a capture has one clock or none.
#[derive(Clone, Copy, Debug, Default)]
struct Clock {
    last_stamp_ms: Option<u16>,
    time_s: Option<f64>,
    started: bool,
}

impl Clock {
    fn time(&mut self, tick: Tick) -> Option<f64> {
        self.time_s = if self.started {
            let stamp_step = match (tick.stamp_ms, self.last_stamp_ms) {
                (Some(ms), Some(last)) => {
                    let wrap = u32::from(LD06_STAMP_WRAP_MS);
                    let dt_ms = (u32::from(ms) + wrap - u32::from(last)) % wrap;
                    (dt_ms > 0).then(|| f64::from(dt_ms) / 1e3)
                }
                _ => None,
            };
            let step = stamp_step.or(tick.period_s);
            self.time_s.zip(step).map(|(t, dt)| t + dt)
        } else {
            let stamp = tick.stamp_ms.map(|ms| f64::from(ms) / 1e3);
            stamp.or(tick.period_s.map(|_| 0.0))
        };
        self.last_stamp_ms = tick.stamp_ms;
        self.started = true;
        self.time_s
    }
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
    /// The revolution's time, seconds from an arbitrary origin, from the
    /// packet that closed it: the LD06 time stamp (unwrapped), or the sum
    /// of the XV-11 motor's periods; `None` where the packets carry no
    /// clock (RPLIDAR, YDLIDAR) or the motor speed is implausible.
    pub time_s: Option<f64>,
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
    fn feed(&mut self, byte: Option<u8>) -> Option<(Turn, Tick)> {
        match self {
            AnyLidar::Ld06(l) => feed(l, byte, ld06_tick),
            AnyLidar::Rplidar(l) => feed(l, byte, no_tick),
            AnyLidar::Ydlidar(l) => feed(l, byte, no_tick),
            AnyLidar::Xv11(l) => feed(l, byte, xv11_tick),
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
    clock: Clock,
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
            clock: Clock::default(),
        }
    }

    /// The next revolution, or `None` at the end of the capture.
    pub fn next_turn(&mut self) -> Option<Turn> {
        loop {
            while self.pos < self.len {
                let byte = self.buf.get(self.pos).copied();
                self.pos += 1;
                if let Some(turn) = self.lidar.feed(byte) {
                    return Some(self.timed(turn));
                }
            }
            if self.done {
                return self.lidar.feed(None).map(|turn| self.timed(turn));
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

    fn timed(&mut self, (mut turn, tick): (Turn, Tick)) -> Turn {
        turn.time_s = self.clock.time(tick);
        turn
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
            time: turn.time_s,
            odom: None,
            log_pose: None,
            name: format!("revolution {}", turn.index),
        })))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stamp(ms: u16, turns_per_s: f64) -> Tick {
        Tick {
            stamp_ms: Some(ms),
            period_s: period_s(turns_per_s),
        }
    }

    fn times(ticks: &[Tick]) -> Vec<Option<f64>> {
        let mut clock = Clock::default();
        ticks.iter().map(|&t| clock.time(t)).collect()
    }

    fn close(a: &[Option<f64>], b: &[Option<f64>]) -> bool {
        a.len() == b.len()
            && a.iter().zip(b).all(|(x, y)| match (x, y) {
                (Some(x), Some(y)) => (x - y).abs() < 1e-9,
                (None, None) => true,
                _ => false,
            })
    }

    #[test]
    fn ld06_stamps_are_unwrapped_and_a_still_stamp_takes_the_motor_period() {
        let t = times(&[
            stamp(29_900, 10.0),
            stamp(29_999, 10.0),
            stamp(99, 10.0), // wrapped: 100 ms later
            stamp(99, 12.5), // did not move: one period at 12.5 turns/s
            stamp(199, 0.0), // motor speed absurd: the stamp still times it
        ]);
        let want = [29.9, 29.999, 30.099, 30.179, 30.279].map(Some);
        assert!(close(&t, &want), "{t:?}");
    }

    #[test]
    fn xv11_periods_are_summed_until_the_motor_speed_is_unknown() {
        let rpm = |r: f64| Tick {
            stamp_ms: None,
            period_s: period_s(r / 60.0),
        };
        let t = times(&[rpm(300.0), rpm(300.0), rpm(240.0), rpm(0.0), rpm(300.0)]);
        assert!(
            close(&t, &[Some(0.0), Some(0.2), Some(0.45), None, None]),
            "{t:?}"
        );
    }

    #[test]
    fn captures_without_a_clock_have_no_times() {
        assert_eq!(times(&[Tick::default(); 3]), vec![None; 3]);
    }

    #[test]
    fn the_bundled_ld06_capture_is_timed_by_its_stamps() {
        // `lidar/tests/data/ld06.bin`: 60 packets a revolution, stamps
        // 2 ms apart (written by the test-data generator).
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../lidar/tests/data/ld06.bin");
        let file = std::fs::File::open(path).expect("capture");
        let mut reader = WireReader::new(file, Protocol::Ld06, 81.91, [0.0; 3]);
        let times: Vec<f64> = std::iter::from_fn(|| reader.next_turn())
            .map(|t| t.time_s.expect("timed"))
            .collect();
        assert_eq!(times.len(), 20);
        for w in times.windows(2) {
            assert!((w[1] - w[0] - 0.12).abs() < 1e-9, "{times:?}");
        }
    }
}
