//! Neato XV-11 / LDS02RR (the Botvac and XV series' lidar): 22-byte packets
//! of 4 one-degree readings, 90 packets a turn, with a 15-bit checksum.
//!
//! Sources: the XV-11 community documentation of the protocol (the
//! "XV-11 hacking" wiki's "LIDAR sensor" page: packet format, flags and the
//! checksum routine) and the ROS `xv_11_laser_driver`
//! (`xv11_laser.cpp`), which publishes reading `i` of a turn at `i`
//! degrees of a counter-clockwise `LaserScan`. Details and wiring in
//! `docs/lidar/xv11.md`.
//!
//! | offset | bytes | field |
//! |---|---|---|
//! | 0 | 1 | start `0xFA` |
//! | 1 | 1 | index `0xA0`–`0xF9`: readings `4·(index − 0xA0)` to `+3` degrees |
//! | 2 | 2 | speed, 1/64 rpm (`u16` little-endian) |
//! | 4 | 16 | 4 × (distance `u16`: bits 0–13 mm, bit 14 strength warning, bit 15 invalid; signal strength `u16`) |
//! | 20 | 2 | checksum |
//!
//! Checksum: the first 20 bytes as ten little-endian words `w`, `c = 2·c +
//! w` in 32 bits, then `((c & 0x7FFF) + (c >> 15)) & 0x7FFF`. A reading
//! with the invalid flag has no return; the strength warning keeps the
//! reading (the quality byte is the signal strength, saturated at 255).
//! Angles: whole degrees, taken as counter-clockwise from the sensor's
//! zero, as the ROS driver publishes them.

use crate::bytes::u16_at;
use crate::parser::{Frame, Layout, Reject};
use crate::point::{Direction, Point, UNITS_PER_DEGREE};

/// Bytes per packet.
pub const PACKET_LEN: usize = 22;
/// Readings per packet.
pub const POINTS: usize = 4;
/// First byte of a packet.
pub const START: u8 = 0xFA;
/// Index of the packet holding 0° to 3°.
pub const FIRST_INDEX: u8 = 0xA0;
/// Index of the packet holding 356° to 359°.
pub const LAST_INDEX: u8 = 0xF9;

/// The checksum of a packet's first 20 bytes.
pub fn checksum(packet: &[u8]) -> u16 {
    let c = (0..10).fold(0u32, |c, w| {
        (c << 1).wrapping_add(u32::from(u16_at(packet, 2 * w)))
    });
    (((c & 0x7FFF) + (c >> 15)) & 0x7FFF) as u16
}

/// The XV-11 protocol ([`Xv11`](crate::Xv11) is its parser).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Xv11Layout;

impl Layout for Xv11Layout {
    const MAX_LEN: usize = PACKET_LEN;
    const DIRECTION: Direction = Direction::CounterClockwise;

    fn classify(&mut self, bytes: &[u8]) -> Frame {
        match (bytes.first(), bytes.get(1)) {
            (Some(&START), None) => return Frame::NeedMore,
            (Some(&START), Some(i)) if (FIRST_INDEX..=LAST_INDEX).contains(i) => {}
            _ => return Frame::Noise,
        }
        let Some(packet) = bytes.get(..PACKET_LEN) else {
            return Frame::NeedMore;
        };
        if checksum(packet) != u16_at(packet, 20) {
            return Frame::Reject(Reject::Checksum);
        }
        Frame::Packet(PACKET_LEN)
    }

    fn count(&self, _packet: &[u8]) -> usize {
        POINTS
    }

    fn point(&self, packet: &[u8], i: usize) -> Option<Point> {
        if i >= POINTS {
            return None;
        }
        let index = u32::from(packet.get(1)?.checked_sub(FIRST_INDEX)?);
        let degrees = (index * 4 + i as u32) % 360;
        let distance = u16_at(packet, 4 + 4 * i);
        let strength = u16_at(packet, 6 + 4 * i);
        let mm = if distance & 0x8000 != 0 {
            0
        } else {
            u32::from(distance & 0x3FFF)
        };
        Some(Point {
            angle: degrees * UNITS_PER_DEGREE,
            range_q2: mm * 4,
            quality: u8::try_from(strength).unwrap_or(u8::MAX),
        })
    }
}

/// Rotation speed of a packet, revolutions per minute (bytes 2–3 / 64).
pub fn rpm(packet: &[u8]) -> f32 {
    f32::from(u16_at(packet, 2)) / 64.0
}
