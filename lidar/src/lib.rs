//! `no_std` drivers for the spinning lidars of small robots, from the bytes
//! on the UART to one scan per turn: LDRobot LD06 / LD19 / STL-19P, Slamtec
//! RPLIDAR A1 / A2 / C1 (standard scan), YDLIDAR X2 / X4, Neato XV-11 /
//! LDS02RR.
//!
//! No heap, no `unsafe`, no panic (checked at link time with the library's
//! `tools/no-panic-check.sh`), every buffer sized at compile time. Usable
//! on its own; with the feature `scan`, a revolution is a
//! `hough_heading::Scan` ready for `Raster::rasterize` and the heading
//! estimate.
//!
//! # Pipeline
//!
//! 1. A [`Parser`] per protocol ([`Ld06`], [`Rplidar`], [`Ydlidar`],
//!    [`Xv11`]) takes
//!    one byte at a time, finds the packets, checks every checksum and
//!    framing bit, and counts every byte it drops by cause ([`Counters`]).
//!    After noise it resynchronises within one packet: a rejected
//!    candidate only costs its first byte, so an intact packet that started
//!    inside it is still found.
//! 2. An [`Assembler`] bins the points of one turn into `N` beams (a const
//!    generic), counter-clockwise from the sensor's zero, and hands out a
//!    [`Revolution`] each time the angles wrap.
//! 3. [`Lidar`] is the two together; a [`Driver`] reads a UART into it:
//!    `next_revolution` over an `embedded_io::Read` (feature `io`),
//!    `next_revolution_async` over an `embedded_io_async::Read` (feature
//!    `async`).
//!
//! ```
//! use hough_lidar::{Ld06, Lidar};
//!
//! // 720 beams a turn (0.5°), returns beyond 12 m are "no return".
//! let mut lidar: Lidar<_, { Ld06::CAPACITY }, 720> = Lidar::new(Ld06::new(), 12.0);
//! # let uart_bytes: [u8; 0] = [];
//! for byte in uart_bytes {
//!     if lidar.push(byte) {
//!         let turn = lidar.revolution().unwrap();
//!         // turn.ranges[i]: metres at i·0.5° counter-clockwise from the front
//!         # let _ = turn;
//!     }
//! }
//! let dropped = lidar.parser().counters().dropped_packets();
//! # assert_eq!(dropped, 0);
//! ```
//!
//! # Units and conventions
//!
//! Points ([`Point`]) are in the sensor's own frame: angle in 1/6400 °
//! ([`UNITS_PER_DEGREE`]) from the sensor's zero in its own direction
//! (clockwise for all but the XV-11), range in quarter millimetres.
//! Revolutions are in `hough-heading`'s: bin `i` at `i·360°/N`
//! counter-clockwise, ranges in metres; the mounting pose is the scan's
//! `SensorOffset`. See [`revolution`] and `docs/lidar/` of the repository
//! (one page per protocol: layout, checksum, UART settings, wiring).
//!
//! # Features
//!
//! * `scan`: [`Revolution::scan`], the revolution as a `hough_heading::Scan`;
//! * `io`: [`Driver::next_revolution`] over `embedded_io::Read`;
//! * `async`: [`Driver::next_revolution_async`] over `embedded_io_async::Read`;
//! * `defmt`: `defmt::Format` on the counters, points and statistics.

#![no_std]
#![forbid(unsafe_code)]

mod bytes;
mod counters;
mod lidar;
mod parser;
mod point;

pub mod ld06;
pub mod revolution;
pub mod rplidar;
pub mod xv11;
pub mod ydlidar;

#[cfg(any(feature = "io", feature = "async"))]
mod feed;

pub use counters::Counters;
#[cfg(any(feature = "io", feature = "async"))]
pub use feed::{Driver, CHUNK};
pub use lidar::Lidar;
pub use parser::{Frame, Layout, Packet, Parser, Reject};
pub use point::{Direction, Point, UNITS_PER_DEGREE, UNITS_PER_TURN};
pub use revolution::{Assembler, AssemblerCounters, Revolution, RevolutionStats};

// The buffers hold one byte more than the longest packet: a [`Lidar`] keeps
// the packet it is reading while the next byte comes in.

/// LDRobot LD06 / LD19 / STL-19P parser ([`ld06`]).
pub type Ld06 = Parser<ld06::Ld06Layout, { ld06::PACKET_LEN + 1 }>;
/// Slamtec RPLIDAR standard-scan parser ([`rplidar`]).
pub type Rplidar = Parser<rplidar::RplidarLayout, { rplidar::NODE_LEN * rplidar::LOCK_NODES + 1 }>;
/// Neato XV-11 / LDS02RR parser ([`xv11`]).
pub type Xv11 = Parser<xv11::Xv11Layout, { xv11::PACKET_LEN + 1 }>;
/// YDLIDAR X2 / X4 parser ([`ydlidar`]).
pub type Ydlidar = Parser<ydlidar::YdlidarLayout, { ydlidar::MAX_PACKET_LEN + 1 }>;

impl<L: Layout, const CAP: usize> Parser<L, CAP> {
    /// The buffer size of this parser type, for [`Lidar`]'s `CAP`.
    pub const CAPACITY: usize = CAP;
}
