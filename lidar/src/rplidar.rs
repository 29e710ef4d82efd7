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
//! what the stream itself guarantees: angles grow clockwise by small steps
//! (at least 1/64 °: a misaligned window over nodes without a return reads
//! a nearly constant "angle"), and two consecutive nodes never both start
//! a revolution (a window misaligned by one byte reads `C` as `S`).
//! After any rejection (and at the start) it hands a node on only when it
//! and the next [`LOCK_NODES`]` − 1` nodes are all well-formed and each
//! continues the previous one's angle by at most [`MAX_STEP_Q6`]; once
//! locked, a node must continue the last one handed on and the next
//! [`LOCKED_NODES`]` − 1` must continue it (so each node waits for the next
//! two: a node whose last bytes were lost is caught by its misaligned
//! successors). A node rejected while locked counts once in `bad_framing`
//! (or `out_of_range`), the bytes skipped while searching count in
//! `skipped_bytes`. One damaged node thus costs up to the two nodes before
//! it as well. A flipped bit in a distance or the quality (or a low bit of
//! an angle) cannot be detected by any receiver: the protocol has nothing
//! to check it against.

use crate::bytes::{u16_at, u8_at};
use crate::parser::{Frame, Layout, Reject};
use crate::point::{Direction, Point};

/// Bytes per node.
pub const NODE_LEN: usize = 5;
/// Bytes of a response descriptor.
pub const DESCRIPTOR_LEN: usize = 7;
/// The response descriptor of the `SCAN` (0x20) and `FORCE_SCAN` requests.
pub const SCAN_DESCRIPTOR: [u8; DESCRIPTOR_LEN] = [0xA5, 0x5A, 0x05, 0x00, 0x00, 0x40, 0x81];
/// Nodes that must agree before the first is handed on after a rejection
/// (or at the start): a window of random bytes passes with a probability
/// of about 10⁻⁸.
pub const LOCK_NODES: usize = 4;
/// Nodes that must agree, the first continuing the last node handed on,
/// once locked: each node waits for the next two.
pub const LOCKED_NODES: usize = 3;
/// Largest angle step between consecutive nodes, 1/64 ° (8 °: an A1 at
/// 2 000 samples/s and 10 Hz steps 1.8 °, so several lost nodes still pass).
pub const MAX_STEP_Q6: u32 = 8 * 64;
/// 360 ° in 1/64 °.
const TURN_Q6: u32 = 360 * 64;

/// The RPLIDAR standard-scan protocol ([`Rplidar`](crate::Rplidar) is its
/// parser). Its state is the last node handed on (the lock).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RplidarLayout {
    last: Option<Node>,
}

/// What the framing looks at in a node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Node {
    /// Angle, 1/64 °.
    angle_q6: u32,
    /// The `S` bit.
    start: bool,
}

/// The node at the start of `bytes`: `Ok(node)` if well-formed, `Err(why)`
/// if not, `None` if incomplete.
fn node(bytes: &[u8]) -> Option<Result<Node, Reject>> {
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
        Ok(Node {
            angle_q6: angle,
            start: s == 1,
        })
    })
}

/// Whether `next` can follow `previous`: its angle ahead (clockwise) by
/// 1/64 ° to [`MAX_STEP_Q6`], and not both starting a revolution.
fn continues(previous: Node, next: Node) -> bool {
    let step = (next.angle_q6 + TURN_Q6 - previous.angle_q6) % TURN_Q6;
    (1..=MAX_STEP_Q6).contains(&step) && !(previous.start && next.start)
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
                    self.last = None;
                    return Frame::Descriptor(DESCRIPTOR_LEN);
                }
                // 0xA5 is also a well-formed first byte (S = 1, quality 41).
                Some(_) => {}
            }
        }
        let locked = self.last;
        // Locked: this node must continue the last one handed on and the
        // next must continue it; searching: LOCK_NODES nodes must agree.
        let (need, fail) = match locked {
            Some(_) => (LOCKED_NODES, Frame::Reject(Reject::Framing)),
            None => (LOCK_NODES, Frame::Noise),
        };
        // The verdict needs every node of the window: wait for them first
        // (the same verdict, without re-checking at each byte).
        if bytes.len() < need * NODE_LEN {
            return Frame::NeedMore;
        }
        let Some(first) = node(bytes) else {
            return Frame::NeedMore;
        };
        let first = match (first, locked) {
            (Ok(first), Some(last)) if !continues(last, first) => {
                self.last = None;
                return fail;
            }
            (Ok(first), _) => first,
            (Err(why), Some(_)) => {
                self.last = None;
                return Frame::Reject(why);
            }
            (Err(_), None) => return Frame::Noise,
        };
        let mut previous = first;
        for k in 1..need {
            match node(bytes.get(k * NODE_LEN..).unwrap_or(&[])) {
                None => return Frame::NeedMore,
                Some(Ok(next)) if continues(previous, next) => previous = next,
                Some(_) => {
                    self.last = None;
                    return fail;
                }
            }
        }
        self.last = Some(first);
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
