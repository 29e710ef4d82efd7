//! The readers on damaged recordings: the bundled bags (MCAP, ROS 1) cut
//! short and with bytes changed, and CARMEN lines with fields removed,
//! repeated or replaced, never panic a reader (the tool's own runs on the
//! bundled recordings are `cli/tests/log.rs`).

use std::path::{Path, PathBuf};

/// The bundled recordings (`cli/data/logs`, by relative path).
fn logs() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../cli/data/logs")
}

#[test]
fn damaged_recordings_never_panic_the_readers() {
    use hough_heading_recordings::carmen::{CarmenReader, FlaserGeometry};
    use hough_heading_recordings::ros1;
    use hough_heading_recordings::ros2::BagReader;

    let bag = std::fs::read(logs().join("seattle-bag.mcap")).expect("bag");
    let read_bag = |bytes: &[u8]| {
        for topic in ["/scan", "/odom"] {
            let reader = BagReader::new(bytes, "bag", topic, Some("/odom"));
            for _ in reader.take(100) {}
        }
    };
    for cut in (0..bag.len()).step_by(53) {
        read_bag(&bag[..cut]);
    }
    // A deterministic spread of positions and byte values.
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    for _ in 0..400 {
        let mut damaged = bag.clone();
        let at = (next() % damaged.len() as u64) as usize;
        damaged[at] = (next() & 0xff) as u8;
        read_bag(&damaged);
    }
    // The same for the ROS 1 bag (bz2 chunks).
    let ros1 = std::fs::read(logs().join("seattle-bag.bag")).expect("bag");
    let read_ros1 = |bytes: &[u8]| {
        for topic in ["/scan", "/odom"] {
            let reader = ros1::BagReader::new(bytes, "bag", topic, Some("/odom"));
            for _ in reader.take(100) {}
        }
        let _ = ros1::contents(bytes, "bag");
    };
    for cut in (0..ros1.len()).step_by(53) {
        read_ros1(&ros1[..cut]);
    }
    for _ in 0..400 {
        let mut damaged = ros1.clone();
        let at = (next() % damaged.len() as u64) as usize;
        damaged[at] = (next() & 0xff) as u8;
        read_ros1(&damaged);
    }
    let text = std::fs::read_to_string(logs().join("seattle-excerpt.log")).expect("log");
    let geometry = FlaserGeometry {
        max_range: 81.91,
        laser_offset: [0.0; 3],
    };
    let samples = [
        "",
        "-1",
        "nan",
        "1e400",
        "18446744073709551616",
        "x",
        "0",
        "361",
    ];
    for (i, line) in text
        .lines()
        .enumerate()
        .filter(|(_, l)| l.starts_with("FLASER"))
    {
        let fields: Vec<&str> = line.split(' ').collect();
        for _ in 0..30 {
            let mut f = fields.clone();
            let at = (next() % f.len() as u64) as usize;
            match next() % 3 {
                0 => {
                    f.remove(at);
                }
                1 => f.insert(at, f[at]),
                _ => f[at] = samples[(next() % samples.len() as u64) as usize],
            }
            let damaged = f.join(" ");
            let reader = CarmenReader::new(damaged.as_bytes(), geometry);
            assert!(reader.count() <= 1, "line {i}");
        }
    }
}
