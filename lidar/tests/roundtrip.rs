//! Round trip: the streams of `tests/data/`, written from real scans by an
//! independent encoder (`tools/lidar_streams.py`), decode to every range
//! and angle the encoder put in, point by point and revolution by
//! revolution.

mod common;

use common::{assert_bytes_accounted, decode, Fixture};
use hough_lidar::ydlidar::YdlidarLayout;
use hough_lidar::{Layout, Ld06, Lidar, Parser, Point, Rplidar, Xv11, Ydlidar, UNITS_PER_TURN};

const BINS: usize = 720;
const MAX_RANGE: f32 = 100.0;

/// (point index k within its turn, wire distance) of every point the
/// stream carries: the lead-in, the turns, then `trailer` points of the
/// closing turn.
fn expected_points(f: &Fixture, trailer: usize) -> Vec<(usize, u64)> {
    let n = f.points_per_turn();
    let mut out: Vec<(usize, u64)> = (n - f.lead_in()..n).map(|k| (k, 0)).collect();
    for turn in f.turns() {
        assert_eq!(turn.len(), n);
        out.extend(turn.into_iter().enumerate());
    }
    out.extend((0..trailer).map(|k| (k, 0)));
    out
}

/// Every decoded point at its encoded angle (exactly, in 1/6400 °) and
/// distance (exactly, in the wire's unit).
fn check_points(f: &Fixture, points: &[Point], trailer: usize) {
    let expected = expected_points(f, trailer);
    assert_eq!(points.len(), expected.len());
    let step = UNITS_PER_TURN / f.points_per_turn() as u32;
    for (i, (p, &(k, d))) in points.iter().zip(&expected).enumerate() {
        assert_eq!(p.angle, k as u32 * step, "point {i}");
        assert_eq!(
            f64::from(p.range_q2) / 4.0,
            d as f64 * f.unit_mm(),
            "point {i}"
        );
    }
}

/// Decodes `f` into revolutions of 720 bins and checks every bin.
fn check_revolutions<L: Layout, const CAP: usize>(f: &Fixture, parser: Parser<L, CAP>) {
    let mut lidar: Lidar<L, CAP, BINS> = Lidar::new(parser, MAX_RANGE);
    let mut revolutions = Vec::new();
    for &b in &f.bytes {
        if lidar.push(b) {
            let r = lidar.revolution().expect("a completed revolution");
            revolutions.push((r.ranges.to_vec(), r.stats, r.index));
        }
    }
    assert!(!lidar.step(), "no revolution completes after the last byte");
    let turns = f.turns();
    assert_eq!(revolutions.len(), turns.len());
    for (r, ((ranges, stats, index), turn)) in revolutions.iter().zip(&turns).enumerate() {
        assert_eq!(*index as usize, r);
        let returns = turn.iter().filter(|&&d| d != 0).count();
        assert_eq!(stats.points as usize, BINS);
        assert_eq!(stats.returns as usize, returns);
        assert_eq!(stats.no_return as usize, BINS - returns);
        assert_eq!(stats.merged, 0);
        for (bin, &got) in ranges.iter().enumerate() {
            // Bin i is i·0.5° counter-clockwise: the clockwise point k = −i.
            let d = turn[(BINS - bin) % BINS];
            if d == 0 {
                assert_eq!(got, MAX_RANGE, "turn {r} bin {bin}");
            } else {
                let metres = d as f64 * f.unit_mm() / 1000.0;
                assert!(
                    (f64::from(got) - metres).abs() <= 1e-6 * metres.max(1.0),
                    "turn {r} bin {bin}: {got} vs {metres}"
                );
            }
        }
    }
    assert_eq!(
        lidar.assembler().counters().leading_points as usize,
        f.lead_in()
    );
    assert_eq!(lidar.parser().counters().dropped_packets(), 0);
    assert_eq!(lidar.parser().counters().skipped_bytes, 0);
}

#[test]
fn ld06_round_trip() {
    let f = Fixture::load("ld06");
    let (packets, c, buffered) = decode(Ld06::new(), &f.bytes);
    assert_bytes_accounted(f.bytes.len(), &packets, &c, buffered, 0);
    assert_eq!((c.dropped_packets(), c.skipped_bytes, buffered), (0, 0, 0));
    let points: Vec<Point> = packets.iter().flat_map(|p| p.points.clone()).collect();
    check_points(&f, &points, 12);
    check_revolutions(&f, Ld06::new());
}

#[test]
fn rplidar_round_trip() {
    let f = Fixture::load("rplidar");
    let (packets, c, buffered) = decode(Rplidar::new(), &f.bytes);
    assert_bytes_accounted(f.bytes.len(), &packets, &c, buffered, 7);
    assert_eq!(c.descriptors, 1);
    // The last two nodes wait for successors that never come.
    assert_eq!((c.dropped_packets(), c.skipped_bytes, buffered), (0, 0, 10));
    let points: Vec<Point> = packets.iter().flat_map(|p| p.points.clone()).collect();
    check_points(&f, &points, 1);
    // Quality: the encoder writes 47 on returns, 0 otherwise.
    assert!(points
        .iter()
        .all(|p| p.quality == if p.range_q2 > 0 { 47 } else { 0 }));
    check_revolutions(&f, Rplidar::new());
}

#[test]
fn ydlidar_round_trip_uncorrected() {
    let f = Fixture::load("ydlidar");
    let parser = Ydlidar::with_layout(YdlidarLayout::uncorrected());
    let (packets, c, buffered) = decode(parser.clone(), &f.bytes);
    assert_bytes_accounted(f.bytes.len(), &packets, &c, buffered, 0);
    assert_eq!((c.dropped_packets(), c.skipped_bytes, buffered), (0, 0, 0));
    let points: Vec<Point> = packets.iter().flat_map(|p| p.points.clone()).collect();
    check_points(&f, &points, 1);
    // The start-of-turn packets (CT bit 0) are the one-sample packets at 0°.
    for p in &packets {
        let start = hough_lidar::ydlidar::starts_revolution(&p.bytes);
        assert_eq!(start, p.points.len() == 1 && p.points[0].angle == 0);
    }
    check_revolutions(&f, parser);
}

#[test]
fn ydlidar_triangulation_correction_matches_the_manual_formula() {
    let f = Fixture::load("ydlidar");
    let corrections = f.meta["corrections_deg"].as_object().unwrap();
    let (packets, _, _) = decode(Ydlidar::new(), &f.bytes);
    let points: Vec<Point> = packets.iter().flat_map(|p| p.points.clone()).collect();
    let expected = expected_points(&f, 1);
    assert_eq!(points.len(), expected.len());
    let mut corrected = 0;
    for (p, &(k, d)) in points.iter().zip(&expected) {
        let nominal = f64::from(k as u32 * 3_200);
        let want = if d == 0 {
            nominal
        } else {
            corrected += 1;
            nominal + corrections[&d.to_string()].as_f64().unwrap() * 6400.0
        };
        let turn = f64::from(UNITS_PER_TURN);
        let diff = (f64::from(p.angle) - want).rem_euclid(turn);
        let diff = diff.min(turn - diff);
        // CORDIC to within 2/6400 ° of Python's math.atan.
        assert!(diff <= 2.0, "k {k} d {d}: {} vs {want}", p.angle);
    }
    assert!(corrected > 1000, "{corrected} corrected points");
}

#[test]
fn a_clockwise_quarter_turn_lands_in_the_counter_clockwise_bin() {
    // 90° clockwise (the sensor's right) is 270° counter-clockwise: bin 540
    // of 720; a counter-clockwise sensor puts it in bin 180.
    use hough_lidar::{Assembler, Direction};
    for (direction, bin) in [
        (Direction::Clockwise, 540),
        (Direction::CounterClockwise, 180),
    ] {
        let mut a: Assembler<720> = Assembler::new(direction, 10.0);
        let point = |deg: u32, mm: u32| Point {
            angle: deg * 6400,
            range_q2: mm * 4,
            quality: 9,
        };
        for p in [point(300, 0), point(10, 0), point(90, 1500), point(350, 0)] {
            assert!(!a.add(p));
        }
        assert!(a.add(point(1, 0)));
        let r = a.revolution().unwrap();
        assert_eq!(r.ranges[bin], 1.5);
        assert_eq!(r.quality[bin], 9);
        assert_eq!(r.stats.returns, 1);
        assert_eq!(r.ranges.iter().filter(|&&x| x < 10.0).count(), 1);
        // The point before the first wrap was the partial leading turn.
        assert_eq!(a.counters().leading_points, 1);
    }
}

#[test]
fn xv11_round_trip() {
    let f = Fixture::load("xv11");
    let (packets, c, buffered) = decode(Xv11::new(), &f.bytes);
    assert_bytes_accounted(f.bytes.len(), &packets, &c, buffered, 0);
    assert_eq!((c.dropped_packets(), c.skipped_bytes, buffered), (0, 0, 0));
    let points: Vec<Point> = packets.iter().flat_map(|p| p.points.clone()).collect();
    check_points(&f, &points, 4);
    // Quality: the signal strength the encoder writes, 500, saturated.
    assert!(points
        .iter()
        .all(|p| p.quality == if p.range_q2 > 0 { 255 } else { 0 }));
    // Counter-clockwise, one reading a degree: 360 beams, beam k = reading k.
    let mut lidar: Lidar<_, { Xv11::CAPACITY }, 360> = Lidar::new(Xv11::new(), MAX_RANGE);
    let turns = f.turns();
    let mut seen = 0;
    for &b in &f.bytes {
        if lidar.push(b) {
            let r = lidar.revolution().unwrap();
            let turn = &turns[seen];
            for (k, (&got, &d)) in r.ranges.iter().zip(turn).enumerate() {
                let want = if d == 0 { MAX_RANGE } else { d as f32 / 1000.0 };
                assert!((got - want).abs() <= 1e-6 * want, "turn {seen} beam {k}");
            }
            seen += 1;
        }
    }
    assert_eq!(seen, turns.len());
}
