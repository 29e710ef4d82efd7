//! The ROS 1 reader on the bundled bags, and on bags written here in every
//! record layout of format 2.0 (the writer below follows the format's
//! description, not a bag's bytes).

use std::collections::HashMap;
use std::io::Write;

use super::decode::{decode_multi_echo, decode_odometry, decode_scan, decode_tf_odometry};
use super::*;
use crate::model::{wrap_rad, Event};
use crate::open::{choose_topics, damaged, xorshift, BagTypes, Format, Source};

const BAG: &[u8] = include_bytes!("../../../cli/data/logs/seattle-bag.bag");
const LZ4: &[u8] = include_bytes!("../../../cli/data/logs/seattle-bag-lz4.bag");

/// The payloads of `topic`, in file order.
fn payloads(bag: &[u8], topic: &str) -> Vec<Vec<u8>> {
    let mut messages = Messages::new(bag);
    let mut out = Vec::new();
    while let Some(m) = messages.next() {
        let m = m.expect("a readable bag");
        if messages.connection(m.conn).expect("declared").topic == topic {
            out.push(m.data);
        }
    }
    out
}

#[test]
fn the_bundled_bags_decode() {
    for bag in [BAG, LZ4] {
        let scans = payloads(bag, "/scan");
        assert_eq!(scans.len(), 12);
        let (scan, time) = decode_scan(&scans[0]).expect("a scan");
        assert_eq!(scan.record.ranges.len(), 361);
        assert!(time > 1000.0);
        let odometry = payloads(bag, "/odom");
        assert_eq!(odometry.len(), 12);
        let (pose, _) = decode_odometry(&odometry[0]).expect("odometry");
        assert!(pose.theta.is_finite());
        assert_eq!(payloads(bag, "/chatter").len(), 3);
    }
    // Both compressions hold the same messages.
    assert_eq!(payloads(BAG, "/scan"), payloads(LZ4, "/scan"));
    // The multi-echo copies (one echo a beam) give the same scans.
    let echoes = payloads(BAG, "/echoes");
    assert_eq!(echoes.len(), 12);
    for (multi, single) in echoes.iter().zip(&payloads(BAG, "/scan")) {
        let (a, ta) = decode_multi_echo(multi).expect("a multi-echo scan");
        let (b, tb) = decode_scan(single).expect("a scan");
        assert_eq!(a.record.ranges, b.record.ranges);
        assert_eq!(
            (ta, a.record.angle_increment),
            (tb, b.record.angle_increment)
        );
    }
}

#[test]
fn damaged_payloads_are_errors_not_panics() {
    let mut next = xorshift(0x9e37_79b9_7f4a_7c15u64);
    let scans = payloads(BAG, "/scan");
    let odometry = payloads(BAG, "/odom");
    for data in scans.iter().chain(&odometry).take(4) {
        for cut in 0..data.len().min(200) {
            assert!(decode_scan(&data[..cut]).is_err());
            assert!(decode_odometry(&data[..cut]).is_err());
        }
        for _ in 0..500 {
            let d = damaged(data, 3, &mut next);
            let _ = decode_scan(&d);
            let _ = decode_multi_echo(&d);
            let _ = decode_odometry(&d);
        }
    }
    for data in payloads(BAG, "/echoes").iter().take(2) {
        for cut in 0..data.len().min(300) {
            assert!(decode_multi_echo(&data[..cut]).is_err());
        }
    }
    // Lengths beyond the message are refused before reading.
    let mut d = scans[0].clone();
    d[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(decode_scan(&d).unwrap_err().contains("does not fit"));
}

#[test]
fn damaged_files_end_with_an_error_not_a_panic() {
    let mut next = xorshift(0x2545_f491_4f6c_dd1du64);
    for bag in [BAG, LZ4] {
        let whole: Vec<Vec<u8>> = Messages::new(bag).map(|m| m.unwrap().data).collect();
        for cut in (0..bag.len()).step_by(97) {
            let read: Vec<_> = Messages::new(&bag[..cut]).collect();
            // The messages before the cut, whole, then at most one error.
            let errors = read.iter().filter(|m| m.is_err()).count();
            let good: Vec<&[u8]> = read.iter().flatten().map(|m| m.data.as_slice()).collect();
            assert!(errors <= 1, "cut at {cut}: {errors} errors");
            assert!(good.iter().zip(&whole).all(|(a, b)| a == b), "cut at {cut}");
            assert!(good.len() <= whole.len(), "cut at {cut}");
        }
        for _ in 0..300 {
            let d = damaged(bag, 4, &mut next);
            for m in Messages::new(d.as_slice()).flatten() {
                let _ = decode_scan(&m.data);
                let _ = decode_odometry(&m.data);
            }
        }
    }
    let mut not_a_bag = BAG.to_vec();
    not_a_bag[1] = b'X';
    let first = Messages::new(not_a_bag.as_slice()).next();
    assert!(matches!(first, Some(Err(e)) if e.contains("not a ROS 1 bag")));
}

// ---------------------------------------------------------------------------
// A writer of bags in any layout of format 2.0.

/// Where a bag's connection records are.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Connections {
    /// In the chunk (or at the top level) before the connection's first
    /// message, as rosbag writes them.
    BeforeFirstMessage,
    /// All at the top level before the first chunk.
    AtTheStart,
    /// Only in the index at the end (after every message).
    OnlyInTheIndex,
}

/// A record layout.
#[derive(Clone, Copy, Debug)]
struct Layout {
    /// Messages a chunk (0: no chunks, every message at the top level).
    per_chunk: usize,
    /// The chunks' compression: `none`, `bz2` or `lz4`.
    compression: &'static str,
    connections: Connections,
    /// Index data records after each chunk, their data length stated as
    /// this many bytes an entry (12 is right; the demo bag's writer said 20).
    index_entry: Option<usize>,
    /// The index at the end (connections, chunk information) and the bag
    /// header pointing at it.
    trailing_index: bool,
}

/// A field of a record header.
fn field(name: &str, value: &[u8]) -> Vec<u8> {
    let mut out = ((name.len() + 1 + value.len()) as u32)
        .to_le_bytes()
        .to_vec();
    out.extend_from_slice(name.as_bytes());
    out.push(b'=');
    out.extend_from_slice(value);
    out
}

/// A record: its header fields, then the data, with `stated` as its data
/// length (the data's own length when `None`).
fn record_bytes(fields: &[Vec<u8>], data: &[u8], stated: Option<usize>) -> Vec<u8> {
    let header: Vec<u8> = fields.concat();
    let mut out = (header.len() as u32).to_le_bytes().to_vec();
    out.extend_from_slice(&header);
    out.extend_from_slice(&(stated.unwrap_or(data.len()) as u32).to_le_bytes());
    out.extend_from_slice(data);
    out
}

fn time_bytes(t: (u32, u32)) -> Vec<u8> {
    [t.0.to_le_bytes(), t.1.to_le_bytes()].concat()
}

/// One message to write: connection, record time (s, ns), payload.
struct Written {
    conn: u32,
    time: (u32, u32),
    data: Vec<u8>,
}

/// The connections of the written bags: id, topic, type, md5sum (`/tf`
/// in either transform type; a bag has messages on one of them).
const CONNECTIONS: [(u32, &str, &str, &str); 4] = [
    (0, "/scan", LASER_SCAN, LASER_SCAN_MD5),
    (1, "/odom", ODOMETRY, ODOMETRY_MD5),
    (2, "/tf", TF_MESSAGE, TF_MESSAGE_MD5),
    (3, "/tf", TF_MESSAGE_OLD, TF_MESSAGE_MD5),
];

fn connection_record(id: u32) -> Vec<u8> {
    let (_, topic, msg_type, md5) = CONNECTIONS[id as usize];
    let data = [
        field("topic", topic.as_bytes()),
        field("type", msg_type.as_bytes()),
        field("md5sum", md5.as_bytes()),
        field("message_definition", b"(not read)"),
    ]
    .concat();
    record_bytes(
        &[
            field("op", &[0x07]),
            field("conn", &id.to_le_bytes()),
            field("topic", topic.as_bytes()),
        ],
        &data,
        None,
    )
}

fn message_record(m: &Written) -> Vec<u8> {
    record_bytes(
        &[
            field("op", &[0x02]),
            field("conn", &m.conn.to_le_bytes()),
            field("time", &time_bytes(m.time)),
        ],
        &m.data,
        None,
    )
}

fn compress(data: &[u8], compression: &str) -> Vec<u8> {
    match compression {
        "bz2" => {
            let mut e = bzip2::write::BzEncoder::new(Vec::new(), bzip2::Compression::default());
            e.write_all(data).unwrap();
            e.finish().unwrap()
        }
        "lz4" => {
            let mut e = lz4_flex::frame::FrameEncoder::new(Vec::new());
            e.write_all(data).unwrap();
            e.finish().unwrap()
        }
        _ => data.to_vec(),
    }
}

/// `messages` as a bag in `layout`.
fn write_bag(messages: &[Written], layout: Layout) -> Vec<u8> {
    let mut out = MAGIC.to_vec();
    let header_at = out.len();
    let bag_header = |index_pos: u64, chunks: u32| {
        let fields = [
            field("op", &[0x03]),
            field("index_pos", &index_pos.to_le_bytes()),
            field("conn_count", &(CONNECTIONS.len() as u32).to_le_bytes()),
            field("chunk_count", &chunks.to_le_bytes()),
        ];
        // rosbag pads the bag header to 4096 bytes with spaces.
        let len = record_bytes(&fields, &[], None).len();
        record_bytes(&fields, &vec![b' '; 4096 - len], None)
    };
    out.extend(bag_header(0, 0));
    let mut declared = [false; CONNECTIONS.len()];
    if layout.connections == Connections::AtTheStart {
        for (id, ..) in CONNECTIONS {
            out.extend(connection_record(id));
        }
    }
    let mut declare = |body: &mut Vec<u8>, conn: u32| {
        if layout.connections == Connections::BeforeFirstMessage && !declared[conn as usize] {
            declared[conn as usize] = true;
            body.extend(connection_record(conn));
        }
    };
    let mut chunk_infos = Vec::new();
    if layout.per_chunk == 0 {
        for m in messages {
            declare(&mut out, m.conn);
            out.extend(message_record(m));
        }
    }
    for chunk in messages.chunks(layout.per_chunk.max(1)) {
        if layout.per_chunk == 0 {
            break;
        }
        let mut body = Vec::new();
        let mut index: HashMap<u32, Vec<u8>> = HashMap::new();
        for m in chunk {
            declare(&mut body, m.conn);
            let entry = index.entry(m.conn).or_default();
            entry.extend(time_bytes(m.time));
            entry.extend((body.len() as u32).to_le_bytes());
            body.extend(message_record(m));
        }
        let chunk_pos = out.len() as u64;
        out.extend(record_bytes(
            &[
                field("op", &[0x05]),
                field("compression", layout.compression.as_bytes()),
                field("size", &(body.len() as u32).to_le_bytes()),
            ],
            &compress(&body, layout.compression),
            None,
        ));
        let mut conns: Vec<_> = index.into_iter().collect();
        conns.sort_by_key(|(c, _)| *c);
        if let Some(entry) = layout.index_entry {
            for (conn, entries) in &conns {
                let count = entries.len() / 12;
                out.extend(record_bytes(
                    &[
                        field("op", &[0x04]),
                        field("ver", &1u32.to_le_bytes()),
                        field("conn", &conn.to_le_bytes()),
                        field("count", &(count as u32).to_le_bytes()),
                    ],
                    entries,
                    Some(count * entry),
                ));
            }
        }
        let counts: Vec<u8> = conns
            .iter()
            .flat_map(|(c, e)| [c.to_le_bytes(), ((e.len() / 12) as u32).to_le_bytes()].concat())
            .collect();
        let (first, last) = (chunk[0].time, chunk[chunk.len() - 1].time);
        chunk_infos.push(record_bytes(
            &[
                field("op", &[0x06]),
                field("ver", &1u32.to_le_bytes()),
                field("chunk_pos", &chunk_pos.to_le_bytes()),
                field("start_time", &time_bytes(first)),
                field("end_time", &time_bytes(last)),
                field("count", &(conns.len() as u32).to_le_bytes()),
            ],
            &counts,
            None,
        ));
    }
    if layout.trailing_index || layout.connections == Connections::OnlyInTheIndex {
        let index_pos = out.len() as u64;
        for (id, ..) in CONNECTIONS {
            out.extend(connection_record(id));
        }
        let chunks = chunk_infos.len() as u32;
        for info in chunk_infos {
            out.extend(info);
        }
        let header = bag_header(index_pos, chunks);
        out[header_at..header_at + header.len()].copy_from_slice(&header);
    }
    out
}

/// A ROS 1 `std_msgs/Header`.
fn ros_header(seq: u32, stamp: (u32, u32), frame: &str) -> Vec<u8> {
    let mut out = [
        seq.to_le_bytes(),
        stamp.0.to_le_bytes(),
        stamp.1.to_le_bytes(),
    ]
    .concat();
    out.extend((frame.len() as u32).to_le_bytes());
    out.extend_from_slice(frame.as_bytes());
    out
}

/// A `sensor_msgs/LaserScan` of `ranges` (1° apart from −90°).
fn laser_scan(seq: u32, stamp: (u32, u32), ranges: &[f32]) -> Vec<u8> {
    let mut out = ros_header(seq, stamp, "laser");
    let step = 1f32.to_radians();
    let head = [
        -90f32.to_radians(),
        90f32.to_radians(),
        step,
        0.0,
        0.1,
        0.05,
        20.0,
    ];
    for v in head {
        out.extend(v.to_le_bytes());
    }
    for array in [ranges, &vec![100.0; ranges.len()]] {
        out.extend((array.len() as u32).to_le_bytes());
        for r in array {
            out.extend(r.to_le_bytes());
        }
    }
    out
}

/// A `nav_msgs/Odometry` at `(x, y)` with heading `theta` (radians).
fn odometry(seq: u32, stamp: (u32, u32), x: f64, y: f64, theta: f64) -> Vec<u8> {
    let mut out = ros_header(seq, stamp, "odom");
    out.extend(9u32.to_le_bytes());
    out.extend_from_slice(b"base_link");
    let (s, c) = (theta / 2.0).sin_cos();
    let mut values = vec![x, y, 0.0, 0.0, 0.0, s, c];
    values.extend([0.0; 36 + 6 + 36]);
    for v in values {
        out.extend(v.to_le_bytes());
    }
    out
}

/// `scans` scans and, when `with_odometry`, an odometry message before each.
fn recording(scans: u32, with_odometry: bool) -> Vec<Written> {
    let mut out = Vec::new();
    for i in 0..scans {
        let stamp = (1_000 + i / 10, (i % 10) * 100_000_000);
        if with_odometry {
            let theta = 0.01 * f64::from(i);
            out.push(Written {
                conn: 1,
                time: stamp,
                data: odometry(i, stamp, 0.1 * f64::from(i), 0.0, theta),
            });
        }
        let ranges: Vec<f32> = (0..181).map(|b| 1.0 + 0.01 * (b + i) as f32).collect();
        out.push(Written {
            conn: 0,
            time: (stamp.0, stamp.1 + 1),
            data: laser_scan(i, stamp, &ranges),
        });
    }
    out
}

/// The bag read as the tool reads it: a first pass, then the events.
fn read_events(bag: &[u8]) -> Vec<Event> {
    let contents = contents(bag, "bag").expect("a readable bag");
    let odom = contents.topics.contains_key("/odom").then_some("/odom");
    BagReader::new(bag, "bag", "/scan", odom)
        .knowing(&contents)
        .map(|item| item.expect("no fatal error").expect("no failed record"))
        .collect()
}

/// What the events should be: each message decoded by itself.
fn expected_events(messages: &[Written]) -> Vec<(bool, f64)> {
    messages
        .iter()
        .map(|m| match m.conn {
            0 => (true, decode_scan(&m.data).unwrap().1),
            _ => (false, decode_odometry(&m.data).unwrap().1),
        })
        .collect()
}

fn summary(events: &[Event]) -> Vec<(bool, f64)> {
    events
        .iter()
        .map(|e| match e {
            Event::Scan(s) => (true, s.time.unwrap()),
            Event::Odometry(o) => (false, o.time.unwrap()),
        })
        .collect()
}

/// The `laser_scan_matcher` demo bag's layout: uncompressed chunks, each
/// with its connection record before the first message (only the first
/// chunk has one), index data after each chunk whose stated data length is
/// 20 bytes an entry (12 written), the index at the end.
#[test]
fn a_bag_in_the_demo_bags_layout_reads_whole() {
    let messages = recording(30, false);
    let demo = Layout {
        per_chunk: 23,
        compression: "none",
        connections: Connections::BeforeFirstMessage,
        index_entry: Some(20),
        trailing_index: true,
    };
    let bag = write_bag(&messages, demo);
    let events = read_events(&bag);
    assert_eq!(events.len(), 30);
    assert_eq!(summary(&events), expected_events(&messages));
    // The second scan of the second chunk decodes to what was written.
    let Event::Scan(s) = &events[24] else {
        panic!("a scan")
    };
    let (written, _) = decode_scan(&messages[24].data).unwrap();
    assert_eq!(s.record.ranges, written.record.ranges);
    // Trusting the stated length lands inside the second chunk: the
    // index data's `count` decides, not its length.
    let stated = 23 * 20;
    let honest = write_bag(
        &messages,
        Layout {
            index_entry: Some(12),
            ..demo
        },
    );
    assert_eq!(bag.len(), honest.len());
    assert_ne!(bag, honest);
    assert!(bag
        .windows(4)
        .any(|w| w == (stated as u32).to_le_bytes().as_slice()));
}

#[test]
fn every_record_layout_reads_the_same_events() {
    let messages = recording(25, true);
    let expected = expected_events(&messages);
    let mut layouts = 0;
    for per_chunk in [0, 1, 7, 1000] {
        for compression in ["none", "bz2", "lz4"] {
            for connections in [
                Connections::BeforeFirstMessage,
                Connections::AtTheStart,
                Connections::OnlyInTheIndex,
            ] {
                for index_entry in [None, Some(12), Some(20)] {
                    for trailing_index in [false, true] {
                        if per_chunk == 0 && (compression != "none" || index_entry.is_some()) {
                            continue;
                        }
                        let layout = Layout {
                            per_chunk,
                            compression,
                            connections,
                            index_entry,
                            trailing_index,
                        };
                        let bag = write_bag(&messages, layout);
                        let events = read_events(&bag);
                        assert_eq!(summary(&events), expected, "{layout:?}");
                        let Some(Event::Odometry(o)) = events.get(48) else {
                            panic!("{layout:?}: odometry");
                        };
                        assert!((o.pose.theta - 0.24).abs() < 1e-9, "{layout:?}");
                        layouts += 1;
                    }
                }
            }
        }
    }
    assert_eq!(layouts, 3 * 3 * 3 * 3 * 2 + 3 * 2);
}

/// Without the first pass, a message before its connection record is a
/// failed record, not a wrong one; the rest are read.
#[test]
fn a_message_on_an_undeclared_connection_is_a_failed_record() {
    let messages = recording(3, true);
    let layout = Layout {
        per_chunk: 4,
        compression: "none",
        connections: Connections::OnlyInTheIndex,
        index_entry: None,
        trailing_index: true,
    };
    let bag = write_bag(&messages, layout);
    let items: Vec<_> = BagReader::new(bag.as_slice(), "bag", "/scan", Some("/odom")).collect();
    assert_eq!(items.len(), 6);
    for item in items {
        let error = item.expect("not fatal").expect_err("a failed record");
        assert!(error.message.contains("no record of the bag declares"));
    }
    assert_eq!(read_events(&bag).len(), 6);
}

// ---------------------------------------------------------------------------
// `/tf` as the odometry.

/// A `tf2_msgs/TFMessage` of `(parent, child, x, y, yaw)` transforms
/// stamped `stamp`.
fn tf_message(stamp: (u32, u32), transforms: &[(&str, &str, f64, f64, f64)]) -> Vec<u8> {
    let mut out = (transforms.len() as u32).to_le_bytes().to_vec();
    for (seq, &(parent, child, x, y, yaw)) in (0..).zip(transforms) {
        out.extend(ros_header(seq, stamp, parent));
        out.extend((child.len() as u32).to_le_bytes());
        out.extend_from_slice(child.as_bytes());
        let (s, c) = (yaw / 2.0).sin_cos();
        for v in [x, y, 0.0, 0.0, 0.0, s, c] {
            out.extend(v.to_le_bytes());
        }
    }
    out
}

/// `messages` with each odometry message's pose, moved `shift` metres in
/// `x`, also (`keep_odom`) or instead sent on `/tf` (connection `conn`)
/// as ROS 1 names its frames, beside the laser's transform; after the
/// third, a message without the odometry's transform.
fn with_tf(messages: &[Written], conn: u32, keep_odom: bool, shift: f64) -> Vec<Written> {
    let mut out = Vec::new();
    for (i, m) in messages.iter().enumerate() {
        if m.conn != 1 || keep_odom {
            out.push(Written {
                data: m.data.clone(),
                ..*m
            });
        }
        if m.conn != 1 {
            continue;
        }
        let (p, _) = decode_odometry(&m.data).unwrap();
        let transforms = [
            ("/base_link", "/laser", 0.2, 0.0, 0.0),
            ("/odom", "/base_link", p.x + shift, p.y, p.theta),
        ];
        let data = tf_message(m.time, &transforms);
        out.push(Written { conn, data, ..*m });
        if i == 4 {
            let data = tf_message(m.time, &[("/map", "/odom", 1.0, 2.0, 3.0)]);
            out.push(Written { conn, data, ..*m });
        }
    }
    out
}

/// The topics `log` chooses in `bag` (`/scan` and `odom_topic`, or the
/// default) and the items of reading them.
fn read_chosen(bag: &[u8], odom_topic: Option<&str>) -> (Option<String>, Vec<BagItem>) {
    let contents = contents(bag, "bag").expect("a readable bag");
    let source = Source {
        file: "bag".into(),
        format: Format::Ros1,
        topic: Some("/scan".into()),
        odom_topic: odom_topic.map(Into::into),
        max_range: 50.0,
        laser_offset: None,
    };
    let (topic, odom) = choose_topics(&source, "bag", &contents.topics, BagTypes::ROS1).unwrap();
    let items = BagReader::new(bag, "bag", &topic, odom.as_deref())
        .knowing(&contents)
        .collect();
    (odom, items)
}

/// The events of `items`, none failed.
fn events_of(items: Vec<BagItem>) -> Vec<Event> {
    items
        .into_iter()
        .map(|item| item.expect("no fatal error").expect("no failed record"))
        .collect()
}

/// The odometry poses and times of `events`, each beside the scans'
/// times, the same to 1e-9.
fn assert_same_odometry(a: &[Event], b: &[Event], shift: f64) {
    assert_eq!(summary(a), summary(b));
    for (a, b) in a.iter().zip(b) {
        if let (Event::Odometry(a), Event::Odometry(b)) = (a, b) {
            assert!((a.pose.x + shift - b.pose.x).abs() < 1e-9, "{a:?} {b:?}");
            assert!((a.pose.y - b.pose.y).abs() < 1e-9, "{a:?} {b:?}");
            assert!(wrap_rad(a.pose.theta - b.pose.theta).abs() < 1e-9);
        }
    }
}

const TF_LAYOUT: Layout = Layout {
    per_chunk: 7,
    compression: "lz4",
    connections: Connections::BeforeFirstMessage,
    index_entry: Some(12),
    trailing_index: true,
};

#[test]
fn a_bag_without_odom_takes_its_odometry_from_tf() {
    let messages = recording(25, true);
    let (odom, items) = read_chosen(&write_bag(&messages, TF_LAYOUT), None);
    assert_eq!(odom.as_deref(), Some("/odom"));
    let from_odom = events_of(items);
    assert_eq!(from_odom.len(), 50);
    // Either transform type, chunked or not.
    for (conn, per_chunk) in [(2, 7), (3, 7), (2, 0), (3, 0)] {
        let layout = Layout {
            per_chunk,
            compression: if per_chunk == 0 { "none" } else { "lz4" },
            index_entry: (per_chunk > 0).then_some(12),
            ..TF_LAYOUT
        };
        let bag = write_bag(&with_tf(&messages, conn, false, 0.0), layout);
        let (odom, items) = read_chosen(&bag, None);
        assert_eq!(odom.as_deref(), Some("/tf"), "{conn} {layout:?}");
        assert_same_odometry(&from_odom, &events_of(items), 0.0);
    }
}

#[test]
fn a_bag_with_odom_and_tf_takes_odom() {
    let messages = recording(25, true);
    let from_odom = events_of(read_chosen(&write_bag(&messages, TF_LAYOUT), None).1);
    // `/tf` 5 m off the odometry: taken only when asked for.
    let bag = write_bag(&with_tf(&messages, 2, true, 5.0), TF_LAYOUT);
    let (odom, items) = read_chosen(&bag, None);
    assert_eq!(odom.as_deref(), Some("/odom"));
    assert_same_odometry(&from_odom, &events_of(items), 0.0);
    let (odom, items) = read_chosen(&bag, Some("/tf"));
    assert_eq!(odom.as_deref(), Some("/tf"));
    assert_same_odometry(&from_odom, &events_of(items), 5.0);
}

#[test]
fn a_damaged_tf_message_is_an_error_not_a_panic() {
    let m = tf_message(
        (1_000, 5),
        &[
            ("base_link", "laser", 0.2, 0.0, 0.0),
            ("odom", "base_footprint", 1.5, -2.0, 0.5),
        ],
    );
    let (pose, t) = decode_tf_odometry(&m).unwrap().expect("a pose");
    assert!((t - 1_000.000_000_005).abs() < 1e-9);
    assert!((pose.x - 1.5).abs() < 1e-12 && (pose.theta - 0.5).abs() < 1e-12);
    // Cut anywhere, an error, never a panic or a pose.
    for cut in 0..m.len() {
        assert!(decode_tf_odometry(&m[..cut]).is_err(), "cut at {cut}");
    }
    let mut next = xorshift(0x51_7cc1_b727_220a);
    for _ in 0..2000 {
        let _ = decode_tf_odometry(&damaged(&m, 3, &mut next));
    }
    // Counts and lengths beyond the message are refused before reading.
    let mut d = m.clone();
    d[..4].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(decode_tf_odometry(&d).unwrap_err().contains("do not fit"));
    d = m.clone();
    d[16..20].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(decode_tf_odometry(&d).unwrap_err().contains("does not fit"));
    // In a bag, the damaged message is a failed record, the rest are read.
    let mut messages = with_tf(&recording(10, true), 2, false, 0.0);
    let at = messages.iter().position(|m| m.conn == 2).unwrap() + 2;
    assert_eq!(messages[at].conn, 2);
    let len = messages[at].data.len();
    messages[at].data.truncate(len - 4);
    let bag = write_bag(&messages, TF_LAYOUT);
    let (odom, items) = read_chosen(&bag, None);
    assert_eq!(odom.as_deref(), Some("/tf"));
    assert_eq!(items.len(), 20);
    let failed: Vec<_> = items
        .iter()
        .filter_map(|item| item.as_ref().expect("not fatal").as_ref().err())
        .collect();
    assert_eq!(failed.len(), 1);
    assert_eq!(failed[0].record, format!("message {} (topic /tf)", at + 1));
    assert!(
        failed[0].message.contains("truncated"),
        "{}",
        failed[0].message
    );
    // Damaged bags end with errors, never a panic.
    for _ in 0..200 {
        let d = damaged(&bag, 4, &mut next);
        if let Ok(contents) = contents(d.as_slice(), "bag") {
            let reader = BagReader::new(d.as_slice(), "bag", "/scan", Some("/tf"));
            for _ in reader.knowing(&contents) {}
        }
    }
}
