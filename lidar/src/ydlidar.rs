//! YDLIDAR X2 / X4 (and the other triangulation models of the same
//! protocol, e.g. X2L, X4PRO): `AA 55` packets of up to 255 samples with a
//! 16-bit XOR check code.
//!
//! Source: EAI / YDLIDAR, "YDLIDAR X4 Development Manual" (v1.x, section
//! "Scan command" and its figure of the scan packet, and the angle and
//! distance formulas), the "YDLIDAR X2 Development Manual", and the
//! `YDLidar-SDK` (`src/YDlidarDriver.cpp`: `waitPackage`, the check code
//! `CheckSum`, `AngleCorr`). Details and wiring in `docs/lidar/ydlidar.md`.
//!
//! | offset | bytes | field |
//! |---|---|---|
//! | 0 | 2 | header `AA 55` (`PH` = 0x55AA little-endian) |
//! | 2 | 1 | `CT`: bit 0 = 1 on the packet that starts a revolution |
//! | 3 | 1 | `LSN`: number of samples (1–255) |
//! | 4 | 2 | `FSA`: first angle, bit 0 = 1 (check), `(FSA >> 1) / 64` ° |
//! | 6 | 2 | `LSA`: last angle, same coding |
//! | 8 | 2 | `CS`: XOR of every other 16-bit little-endian word of the packet |
//! | 10 | 2·LSN | samples `Sᵢ`, distance `Sᵢ / 4` mm; 0 = no return |
//!
//! Sample `i` (0-based) lies at `FSA + i·(LSA − FSA)/(LSN − 1)` (the
//! difference modulo 360 °; `FSA` when `LSN` = 1), rounded down to
//! 1/6400 °, plus the triangulation correction of the X2/X4 manuals,
//! `atan(21.8·(155.3 − d)/(155.3·d))` with `d` in mm (0 when `d` = 0),
//! computed in integers (CORDIC) to within 2/6400 °. Angles grow
//! clockwise seen from above; 0 ° is the front of the manual's coordinate
//! figure.

use crate::bytes::{u16_at, u8_at};
use crate::parser::{Frame, Layout, Reject};
use crate::point::{wrap, Direction, Point};

/// Bytes before the samples.
pub const HEADER_LEN: usize = 10;
/// Most samples in a packet (`LSN` is one byte).
pub const MAX_SAMPLES: usize = 255;
/// Bytes of the longest packet.
pub const MAX_PACKET_LEN: usize = HEADER_LEN + 2 * MAX_SAMPLES;
/// 360 ° in 1/64 °.
const TURN_Q6: u16 = 360 * 64;

/// The YDLIDAR X2/X4 protocol ([`Ydlidar`](crate::Ydlidar) is its parser).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct YdlidarLayout {
    correction: bool,
}

impl Default for YdlidarLayout {
    /// The X2 / X4: with the triangulation angle correction.
    fn default() -> Self {
        Self::triangulation()
    }
}

impl YdlidarLayout {
    /// The X2 / X4 and other triangulation models: each sample's angle is
    /// corrected for the offset between laser and camera.
    pub const fn triangulation() -> Self {
        Self { correction: true }
    }

    /// Angles as sent, uncorrected (time-of-flight models, or to apply a
    /// correction of one's own).
    pub const fn uncorrected() -> Self {
        Self { correction: false }
    }

    /// Whether the triangulation correction is applied.
    pub const fn corrects(&self) -> bool {
        self.correction
    }
}

/// The number of samples of a packet (`LSN`).
fn samples(bytes: &[u8]) -> usize {
    usize::from(u8_at(bytes, 3))
}

/// XOR of the packet's 16-bit words except the check code itself.
pub fn check_code(packet: &[u8]) -> u16 {
    let words = packet.len() / 2;
    (0..words)
        .filter(|&w| w != 4)
        .fold(0, |acc, w| acc ^ u16_at(packet, 2 * w))
}

impl Layout for YdlidarLayout {
    const MAX_LEN: usize = MAX_PACKET_LEN;
    const DIRECTION: Direction = Direction::Clockwise;

    fn classify(&mut self, bytes: &[u8]) -> Frame {
        match (bytes.first(), bytes.get(1)) {
            (Some(0xAA), None) => return Frame::NeedMore,
            (Some(0xAA), Some(0x55)) => {}
            _ => return Frame::Noise,
        }
        if bytes.len() < HEADER_LEN {
            return Frame::NeedMore;
        }
        let n = samples(bytes);
        if n == 0 || u16_at(bytes, 4) & 1 == 0 || u16_at(bytes, 6) & 1 == 0 {
            return Frame::Reject(Reject::Framing);
        }
        let len = HEADER_LEN + 2 * n;
        let Some(packet) = bytes.get(..len) else {
            return Frame::NeedMore;
        };
        if check_code(packet) != u16_at(packet, 8) {
            return Frame::Reject(Reject::Checksum);
        }
        if u16_at(packet, 4) >> 1 >= TURN_Q6 || u16_at(packet, 6) >> 1 >= TURN_Q6 {
            return Frame::Reject(Reject::Range);
        }
        Frame::Packet(len)
    }

    fn count(&self, packet: &[u8]) -> usize {
        samples(packet)
    }

    fn point(&self, packet: &[u8], i: usize) -> Option<Point> {
        let n = samples(packet);
        if i >= n {
            return None;
        }
        // Angles below 360 ° (checked by `classify`; reduced again here), so
        // `span · 100 · i` < 23 040 · 100 · 255 fits in `u32`.
        let turn = u32::from(TURN_Q6);
        let first = u32::from(u16_at(packet, 4) >> 1) % turn;
        let last = u32::from(u16_at(packet, 6) >> 1) % turn;
        let span = (last + turn - first) % turn;
        // 1/64 ° = 100 units.
        let step = if n > 1 {
            span * 100 * i as u32 / (n as u32 - 1)
        } else {
            0
        };
        let sample = u16_at(packet, HEADER_LEN + 2 * i);
        let correction = if self.correction {
            correction_units(sample)
        } else {
            0
        };
        Some(Point {
            angle: wrap(i64::from(first * 100 + step) + correction),
            range_q2: u32::from(sample),
            quality: 0,
        })
    }
}

/// Whether a packet starts a revolution (`CT` bit 0).
pub fn starts_revolution(packet: &[u8]) -> bool {
    u8_at(packet, 2) & 1 == 1
}

/// `atan(2^-i)` in 1/(6400·256) °, for the CORDIC.
const ATAN_TABLE: [i64; 26] = [
    73_728_000, 43_524_180, 22_996_981, 11_673_627, 5_859_466, 2_932_590, 1_466_653, 733_371,
    366_691, 183_346, 91_673, 45_837, 22_918, 11_459, 5_730, 2_865, 1_432, 716, 358, 179, 90, 45,
    22, 11, 6, 3,
];

/// The X2/X4 angle correction for a sample `s` (distance `s/4` mm), in
/// 1/6400 °: `atan(21.8·(155.3 − d)/(155.3·d))`, 0 for `s` = 0.
///
/// With `d = s/4`, the tangent is `(1 354 216 − 2 180·s) / (15 530·s)`
/// exactly; its angle comes from a 26-step CORDIC in 64-bit integers
/// (inputs scaled by 2¹⁶, angles in 1/256 of a unit), rounded to a unit.
pub fn correction_units(sample: u16) -> i64 {
    if sample == 0 {
        return 0;
    }
    let s = i64::from(sample);
    let mut x = (15_530 * s) << 16;
    let mut y = (1_354_216 - 2_180 * s) << 16;
    let mut z = 0i64;
    for (i, &t) in ATAN_TABLE.iter().enumerate() {
        let (dx, dy) = (y >> i, x >> i);
        if y > 0 {
            x += dx;
            y -= dy;
            z += t;
        } else {
            x -= dx;
            y += dy;
            z -= t;
        }
    }
    (z + 128) >> 8
}
