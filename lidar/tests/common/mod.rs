//! Shared by the lidar tests: the fixtures of `tests/data/` (written by
//! `tools/lidar_streams.py`, an encoder independent of this crate) and
//! decoding helpers.
#![allow(dead_code)]

use hough_lidar::{Counters, Layout, Parser, Point};
use serde_json::Value;

/// One fixture: the bytes and what the encoder says they carry.
pub struct Fixture {
    pub bytes: Vec<u8>,
    pub meta: Value,
}

impl Fixture {
    pub fn load(name: &str) -> Fixture {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/");
        let bytes = std::fs::read(format!("{dir}{name}.bin")).expect("fixture bytes");
        let text = std::fs::read_to_string(format!("{dir}{name}.json")).expect("fixture json");
        let meta = serde_json::from_str(&text).expect("fixture JSON parses");
        Fixture { bytes, meta }
    }

    /// Wire distance of point k of each turn.
    pub fn turns(&self) -> Vec<Vec<u64>> {
        self.meta["turns"]
            .as_array()
            .unwrap()
            .iter()
            .map(|t| {
                t.as_array()
                    .unwrap()
                    .iter()
                    .map(|v| v.as_u64().unwrap())
                    .collect()
            })
            .collect()
    }

    /// Millimetres per wire unit.
    pub fn unit_mm(&self) -> f64 {
        self.meta["unit_mm"].as_f64().unwrap()
    }

    pub fn points_per_turn(&self) -> usize {
        self.meta["points_per_turn"].as_u64().unwrap() as usize
    }

    pub fn lead_in(&self) -> usize {
        self.meta["lead_in_points"].as_u64().unwrap() as usize
    }
}

/// A packet handed on: its bytes and points.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Decoded {
    pub bytes: Vec<u8>,
    pub points: Vec<Point>,
}

/// The packets of a stream, the counters, and the bytes left buffered.
pub type Decoding = (Vec<Decoded>, Counters, usize);

/// Every packet of `stream`, the counters, and the bytes left buffered.
pub fn decode<L: Layout, const CAP: usize>(mut parser: Parser<L, CAP>, stream: &[u8]) -> Decoding {
    let mut out = Vec::new();
    let take = |p: hough_lidar::Packet<'_, L>| Decoded {
        bytes: p.bytes().to_vec(),
        points: p.points().collect(),
    };
    for &b in stream {
        if let Some(p) = parser.push(b) {
            out.push(take(p));
        }
        while let Some(p) = parser.poll() {
            out.push(take(p));
        }
    }
    let buffered = parser.buffered();
    (out, *parser.counters(), buffered)
}

/// Every byte is accounted for: in a packet, a descriptor, the first byte
/// of a rejected candidate, skipped, or still buffered.
pub fn assert_bytes_accounted(
    total: usize,
    packets: &[Decoded],
    c: &Counters,
    buffered: usize,
    descriptor_len: usize,
) {
    let in_packets: usize = packets.iter().map(|p| p.bytes.len()).sum();
    assert_eq!(
        in_packets
            + c.descriptors as usize * descriptor_len
            + c.dropped_packets() as usize
            + c.skipped_bytes as usize
            + buffered,
        total,
        "bytes not accounted for: {c:?}, buffered {buffered}"
    );
    assert_eq!(c.packets as usize, packets.len());
    assert_eq!(c.overflow_bytes, 0);
}

/// A small deterministic generator (xorshift64*), so the damage tests
/// are reproducible.
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }

    pub fn byte(&mut self) -> u8 {
        self.next() as u8
    }
}
