//! Slamtec RPLIDAR A1 / A2 / C1 (and A3, S1 in standard mode): the
//! standard scan's 5-byte nodes, after the `SCAN` request's response
//! descriptor.
//!
//! Source: Slamtec, "RPLIDAR Interface Protocol and Application Notes"
//! (LR001, v2.x: sections "Response descriptor", "SCAN (0x20)" and its
//! figure of the measurement node) and the `rplidar_sdk`
//! (`sl_lidar_cmd.h`: `sl_lidar_response_measurement_node_t`,
//! `SL_LIDAR_RESP_MEASUREMENT_SYNCBIT`, `…_CHECKBIT`, `…_ANGLE_SHIFT`).
//! Details and wiring in `docs/lidar/rplidar.md`.
//!
//! A capture may start with the response descriptor of the `SCAN` request,
//! `A5 5A 05 00 00 40 81` (start flags, 30-bit length 5 and 2-bit mode 1
//! "multiple response", type 0x81); any 7-byte `A5 5A …` descriptor is
//! skipped and counted in [`Counters::descriptors`](crate::Counters).
//! Then one node per measurement:
//!
//! | byte | bits | field |
//! |---|---|---|
//! | 0 | 7–2 | quality (0–63) |
//! | 0 | 1 | `!S` |
//! | 0 | 0 | `S`: 1 on the first node of a new revolution |
//! | 1 | 0 | `C`: check bit, always 1 |
//! | 1–2 | 15–1 | angle, 1/64 ° (`u16` little-endian, shifted left by one) |
//! | 3–4 | | distance, 1/4 mm (`u16` little-endian); 0 = no return |
//!
//! Nodes carry **no checksum**: the only framing is `S ≠ !S` and `C = 1`,
//! which a random 5-byte window passes one time in four. This parser adds
//! what the stream itself guarantees: angles grow clockwise by small steps.
//! After any rejection (and at the start) it hands a node on only when it
//! and the next [`LOCK_NODES`]` − 1` nodes are all well-formed and each
//! continues the previous one's angle by at most [`MAX_STEP_Q6`]; once
//! locked, a node must continue the last one handed on and the next node
//! must continue it (so each node waits for the next: a node whose last
//! byte was lost is caught by its misaligned successor). A node rejected
//! while locked counts once in `bad_framing` (or `out_of_range`), the bytes
//! skipped while searching count in `skipped_bytes`. A flipped bit in a
//! distance or the quality cannot be detected by any receiver: the protocol
//! has nothing to check it against.

use crate::bytes::{u16_at, u8_at};
use crate::parser::{Frame, Layout, Reject};
use crate::point::{Direction, Point};

/// Bytes per node.
pub const NODE_LEN: usize = 5;
/// Bytes of a response descriptor.
pub const DESCRIPTOR_LEN: usize = 7;
/// The response descriptor of the `SCAN` (0x20) and `FORCE_SCAN` requests.
pub const SCAN_DESCRIPTOR: [u8; DESCRIPTOR_LEN] = [0xA5, 0x5A, 0x05, 0x00, 0x00, 0x40, 0x81];
/// Nodes that must agree before the first is handed on after a rejection.
pub const LOCK_NODES: usize = 3;
/// Largest angle step between consecutive nodes, 1/64 ° (8 °: an A1 at
/// 2 000 samples/s and 10 Hz steps 1.8 °, so several lost nodes still pass).
pub const MAX_STEP_Q6: u32 = 8 * 64;
/// 360 ° in 1/64 °.
const TURN_Q6: u32 = 360 * 64;

/// The RPLIDAR standard-scan protocol ([`Rplidar`](crate::Rplidar) is its
/// parser). Its state is the angle of the last node handed on (the lock).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RplidarLayout {
    last_q6: Option<u32>,
}

/// The node at the start of `bytes`: `Ok(angle_q6)` if well-formed,
/// `Err(why)` if not, `None` if incomplete.
fn node(bytes: &[u8]) -> Option<Result<u32, Reject>> {
    let raw = bytes.get(..NODE_LEN)?;
    let b0 = u8_at(raw, 0);
    let s = b0 & 1;
    let not_s = (b0 >> 1) & 1;
    let c = u8_at(raw, 1) & 1;
    if s == not_s || c != 1 {
        return Some(Err(Reject::Framing));
    }
    let angle = u32::from(u16_at(raw, 1) >> 1);
    Some(if angle >= TURN_Q6 {
        Err(Reject::Range)
    } else {
        Ok(angle)
    })
}

/// Whether `next` continues `previous` (clockwise, at most [`MAX_STEP_Q6`]).
fn continues(previous: u32, next: u32) -> bool {
    (next + TURN_Q6 - previous) % TURN_Q6 <= MAX_STEP_Q6
}

impl Layout for RplidarLayout {
    const MAX_LEN: usize = NODE_LEN * LOCK_NODES;
    const DIRECTION: Direction = Direction::Clockwise;

    fn classify(&mut self, bytes: &[u8]) -> Frame {
        if bytes.first() == Some(&0xA5) {
            match bytes.get(1) {
                None => return Frame::NeedMore,
                Some(0x5A) if bytes.len() < DESCRIPTOR_LEN => return Frame::NeedMore,
                Some(0x5A) => {
                    self.last_q6 = None;
                    return Frame::Descriptor(DESCRIPTOR_LEN);
                }
                // 0xA5 is also a well-formed first byte (S = 1, quality 41).
                Some(_) => {}
            }
        }
        let Some(first) = node(bytes) else {
            return Frame::NeedMore;
        };
        let locked = self.last_q6;
        // Locked: this node must continue the last one handed on and the
        // next must continue it; searching: LOCK_NODES nodes must agree.
        let (need, fail) = match locked {
            Some(_) => (2, Frame::Reject(Reject::Framing)),
            None => (LOCK_NODES, Frame::Noise),
        };
        let angle = match (first, locked) {
            (Ok(angle), Some(last)) if !continues(last, angle) => {
                self.last_q6 = None;
                return fail;
            }
            (Ok(angle), _) => angle,
            (Err(why), Some(_)) => {
                self.last_q6 = None;
                return Frame::Reject(why);
            }
            (Err(_), None) => return Frame::Noise,
        };
        let mut previous = angle;
        for k in 1..need {
            match node(bytes.get(k * NODE_LEN..).unwrap_or(&[])) {
                None => return Frame::NeedMore,
                Some(Ok(next)) if continues(previous, next) => previous = next,
                Some(_) => {
                    self.last_q6 = None;
                    return fail;
                }
            }
        }
        self.last_q6 = Some(angle);
        Frame::Packet(NODE_LEN)
    }

    fn count(&self, _packet: &[u8]) -> usize {
        1
    }

    fn point(&self, packet: &[u8], i: usize) -> Option<Point> {
        if i != 0 || packet.len() < NODE_LEN {
            return None;
        }
        Some(Point {
            // 1/64 ° = 100 units.
            angle: u32::from(u16_at(packet, 1) >> 1) * 100,
            range_q2: u32::from(u16_at(packet, 3)),
            quality: u8_at(packet, 0) >> 2,
        })
    }
}

/// Whether a node is the first of a new revolution (its `S` bit).
pub fn starts_revolution(node: &[u8]) -> bool {
    u8_at(node, 0) & 1 == 1
}
