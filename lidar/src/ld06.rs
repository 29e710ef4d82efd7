//! LDRobot LD06 / LD19 / STL-19P (and the STL-06P, STL-26 of the same
//! family): 47-byte packets of 12 points with a CRC-8.
//!
//! Source: LDRobot's "LD06 Development Manual" (v1.0, section 3,
//! "Communication protocol") and the `ldlidar_stl_ros` / `ldlidar_stl_sdk`
//! drivers (`lipkg.cpp`: `LiPkg::Parse`, the CRC table `CrcTable`). Details
//! and wiring in `docs/lidar/ld06.md`.
//!
//! | offset | bytes | field |
//! |---|---|---|
//! | 0 | 1 | header `0x54` |
//! | 1 | 1 | `VerLen` `0x2C`: packet type 1 (top 3 bits), 12 points (low 5 bits) |
//! | 2 | 2 | rotation speed, degrees per second |
//! | 4 | 2 | start angle, 0.01 ° |
//! | 6 | 36 | 12 × (distance mm `u16`, confidence `u8`) |
//! | 42 | 2 | end angle, 0.01 ° |
//! | 44 | 2 | time stamp, ms (wraps at 30 000) |
//! | 46 | 1 | CRC-8 (polynomial 0x4D, initial 0, not reflected) of bytes 0–45 |
//!
//! All fields little-endian. Point `i` lies at `start + i·(end − start)/11`
//! (the difference taken modulo 360 °, at most [`MAX_SPAN`]), rounded down
//! to 1/6400 °. Angles grow clockwise seen from above; 0 ° is the front
//! of the manual's coordinate-system figure.

use crate::bytes::{u16_at, u8_at};
use crate::parser::{Frame, Layout, Reject};
use crate::point::{Direction, Point, UNITS_PER_TURN};

/// Bytes per packet.
pub const PACKET_LEN: usize = 47;
/// Points per packet.
pub const POINTS: usize = 12;
/// First byte of a packet.
pub const HEADER: u8 = 0x54;
/// Second byte: packet type 1, 12 points.
pub const VER_LEN: u8 = 0x2C;

/// Largest angle from a packet's first point to its last, 0.01 ° (40 °:
/// 12 points at 4 500 points/s span 14.4 ° at 15 turns/s). A packet with a
/// good CRC but a wider span is dropped as out of range.
pub const MAX_SPAN: u32 = 4_000;

/// The CRC-8 table (polynomial 0x4D), built at compile time.
const CRC_TABLE: [u8; 256] = crc_table();

const fn crc_table() -> [u8; 256] {
    let mut table = [0u8; 256];
    let mut i = 0;
    while i < 256 {
        let mut crc = i as u8;
        let mut bit = 0;
        while bit < 8 {
            crc = if crc & 0x80 != 0 {
                (crc << 1) ^ 0x4D
            } else {
                crc << 1
            };
            bit += 1;
        }
        table[i] = crc;
        i += 1;
    }
    table
}

/// CRC-8 (polynomial 0x4D, initial value 0, no reflection, no final XOR).
pub fn crc8(bytes: &[u8]) -> u8 {
    bytes.iter().fold(0u8, |crc, &b| {
        CRC_TABLE.get(usize::from(crc ^ b)).copied().unwrap_or(0)
    })
}

/// The LD06 protocol ([`Ld06`](crate::Ld06) is its parser).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Ld06Layout;

impl Layout for Ld06Layout {
    const MAX_LEN: usize = PACKET_LEN;
    const DIRECTION: Direction = Direction::Clockwise;

    fn classify(&mut self, bytes: &[u8]) -> Frame {
        match (bytes.first(), bytes.get(1)) {
            (Some(&HEADER), None) => return Frame::NeedMore,
            (Some(&HEADER), Some(&VER_LEN)) => {}
            _ => return Frame::Noise,
        }
        let Some(packet) = bytes.get(..PACKET_LEN) else {
            return Frame::NeedMore;
        };
        if crc8(packet.get(..PACKET_LEN - 1).unwrap_or(&[])) != u8_at(packet, PACKET_LEN - 1) {
            return Frame::Reject(Reject::Checksum);
        }
        let (start, end) = (u32::from(u16_at(packet, 4)), u32::from(u16_at(packet, 42)));
        if start >= 36_000 || end >= 36_000 || (end + 36_000 - start) % 36_000 > MAX_SPAN {
            return Frame::Reject(Reject::Range);
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
        // Checked by `classify`: start, end < 36 000 and the span at most
        // MAX_SPAN, so everything fits in `u32` (division by a constant).
        let start = u32::from(u16_at(packet, 4)) % 36_000;
        let end = u32::from(u16_at(packet, 42)) % 36_000;
        let span = (end + 36_000 - start) % 36_000;
        // 0.01 ° = 64 units.
        let angle = start * 64 + (span * 64 * i as u32) / (POINTS as u32 - 1);
        let angle = if angle >= UNITS_PER_TURN {
            angle - UNITS_PER_TURN
        } else {
            angle
        };
        let at = 6 + 3 * i;
        Some(Point {
            angle,
            range_q2: u32::from(u16_at(packet, at)) * 4,
            quality: u8_at(packet, at + 2),
        })
    }
}

/// Rotation speed of a packet, degrees per second (bytes 2–3).
pub fn speed_deg_per_s(packet: &[u8]) -> u16 {
    u16_at(packet, 2)
}

/// Time stamp of a packet, milliseconds (bytes 44–45; wraps at 30 000).
pub fn timestamp_ms(packet: &[u8]) -> u16 {
    u16_at(packet, 44)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_table_matches_the_manual() {
        // The first 16 entries of `CrcTable` as printed in LDRobot's LD06
        // development manual and SDK.
        let published = [
            0x00, 0x4d, 0x9a, 0xd7, 0x79, 0x34, 0xe3, 0xae, 0xf2, 0xbf, 0x68, 0x25, 0x8b, 0xc6,
            0x11, 0x5c,
        ];
        assert_eq!(CRC_TABLE.get(..16), Some(&published[..]));
    }
}
