//! Fuzzing of every parser and of the assembler behind it (proptest): random
//! byte streams rich in header bytes, and the real streams of `tests/data/`
//! with random bytes overwritten, inserted and removed. Properties: no
//! panic; every byte accounted for in the counters; every point's angle
//! within one turn; every revolution's ranges finite, positive and at most
//! `max_range`, with its statistics consistent.
//!
//! 256 cases per property by default (8 properties); the long run sets
//! `LIDAR_FUZZ_CASES`, e.g. `LIDAR_FUZZ_CASES=130000 cargo test -p
//! hough-lidar --test fuzz` for over 10⁶ inputs.

mod common;

use common::{assert_bytes_accounted, decode, Fixture};
use hough_lidar::{Layout, Ld06, Lidar, Parser, Rplidar, Xv11, Ydlidar, UNITS_PER_TURN};
use proptest::prelude::*;

const MAX_RANGE: f32 = 12.0;

fn cases() -> u32 {
    std::env::var("LIDAR_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(256)
}

/// Random bytes, half of them the protocols' sync and header bytes.
fn noisy_bytes() -> impl Strategy<Value = Vec<u8>> {
    let byte = prop_oneof![
        any::<u8>(),
        prop::sample::select(vec![
            0x54u8, 0x2C, 0xAA, 0x55, 0xA5, 0x5A, 0x81, 0x00, 0x01, 0x03
        ]),
    ];
    prop::collection::vec(byte, 0..3000)
}

/// A window of a real stream with random edits (overwrite, insert, remove).
fn edited(stream: Vec<u8>) -> impl Strategy<Value = Vec<u8>> {
    let len = stream.len();
    (
        0..len,
        100usize..4000,
        prop::collection::vec((any::<usize>(), 0u8..3, any::<u8>()), 0..12),
    )
        .prop_map(move |(start, size, edits)| {
            let mut s = stream[start..(start + size).min(len)].to_vec();
            for (at, kind, byte) in edits {
                if s.is_empty() {
                    break;
                }
                let at = at % s.len();
                match kind {
                    0 => s[at] = byte,
                    1 => s.insert(at, byte),
                    _ => {
                        s.remove(at);
                    }
                }
            }
            s
        })
}

/// The properties, for one parser type.
fn check<L: Layout + Clone, const CAP: usize>(
    parser: Parser<L, CAP>,
    bytes: &[u8],
    descriptor_len: usize,
) {
    let (packets, c, buffered) = decode(parser.clone(), bytes);
    assert_bytes_accounted(bytes.len(), &packets, &c, buffered, descriptor_len);
    assert_eq!(
        c.points as usize,
        packets.iter().map(|p| p.points.len()).sum::<usize>()
    );
    for p in packets.iter().flat_map(|p| &p.points) {
        assert!(p.angle < UNITS_PER_TURN, "{p:?}");
    }
    let mut lidar: Lidar<L, CAP, 360> = Lidar::new(parser, MAX_RANGE);
    let check_revolution = |lidar: &Lidar<L, CAP, 360>| {
        let r = lidar.revolution().expect("a revolution after true");
        let s = r.stats;
        assert_eq!(s.points, s.returns + s.no_return + s.merged, "{s:?}");
        let returns = r.ranges.iter().filter(|&&x| x < MAX_RANGE).count();
        assert_eq!(returns, s.returns as usize);
        assert!(r
            .ranges
            .iter()
            .all(|&x| x.is_finite() && x > 0.0 && x <= MAX_RANGE));
    };
    for &b in bytes {
        if lidar.push(b) {
            check_revolution(&lidar);
        }
    }
    while lidar.step() {
        check_revolution(&lidar);
    }
    // The lidar's parser saw the same bytes as the plain one.
    assert_eq!(*lidar.parser().counters(), c);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(cases()))]

    #[test]
    fn ld06_noise(bytes in noisy_bytes()) {
        check(Ld06::new(), &bytes, 0);
    }

    #[test]
    fn rplidar_noise(bytes in noisy_bytes()) {
        check(Rplidar::new(), &bytes, 7);
    }

    #[test]
    fn ydlidar_noise(bytes in noisy_bytes()) {
        check(Ydlidar::new(), &bytes, 0);
    }

    #[test]
    fn xv11_noise(bytes in noisy_bytes()) {
        check(Xv11::new(), &bytes, 0);
    }

    #[test]
    fn xv11_edited(bytes in edited(Fixture::load("xv11").bytes)) {
        check(Xv11::new(), &bytes, 0);
    }

    #[test]
    fn ld06_edited(bytes in edited(Fixture::load("ld06").bytes)) {
        check(Ld06::new(), &bytes, 0);
    }

    #[test]
    fn rplidar_edited(bytes in edited(Fixture::load("rplidar").bytes)) {
        check(Rplidar::new(), &bytes, 7);
    }

    #[test]
    fn ydlidar_edited(bytes in edited(Fixture::load("ydlidar").bytes)) {
        check(Ydlidar::new(), &bytes, 0);
    }
}
