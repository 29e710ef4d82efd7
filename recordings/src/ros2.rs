//! ROS 2 bags in MCAP: `sensor_msgs/msg/LaserScan` messages of one topic,
//! and `nav_msgs/msg/Odometry` as the odometry.
//!
//! The container is read by the `mcap` crate's streaming reader (constant
//! memory, chunks decompressed one at a time; zstd and lz4 chunks are
//! supported); the messages' CDR payloads by the `cdr` crate through serde.
//! Ranges follow REP 117: a value that is not finite, or below `range_min`,
//! is no reading (dropped like a `null` of the pair files); a scan with no
//! finite range at all is an error of its message. A scan's odometry is the
//! last odometry message before it in the file (no interpolation), and its
//! time the header stamp (the log time when the stamp is zero). The laser's
//! offset on the robot is `--laser-offset` (`/tf_static` is not read). A bag
//! without `/odom` takes its odometry from `/tf` ([`crate::tf`]).

use std::collections::BTreeMap;
use std::io::Read;

use mcap::sans_io::LinearReaderOptions;
use serde::Deserialize;

use crate::error::{Fatal, RecordError};
use crate::model::{Event, Odometry, Pose, Scan};
use crate::pairs::ScanRecord;

/// Largest MCAP record (and chunk, compressed or not) read, bytes: a
/// corrupt length fails instead of allocating it.
pub const RECORD_LIMIT: usize = 1 << 28;

/// The bag's messages, streamed: chunk CRCs checked before a chunk's
/// messages are used, record lengths bounded by [`RECORD_LIMIT`].
fn messages<R: Read>(input: R) -> mcap::io::MessageReader<R> {
    let options = LinearReaderOptions::default()
        .with_prevalidate_chunk_crcs(true)
        .with_record_length_limit(RECORD_LIMIT);
    mcap::io::MessageReader::new_with_options(input, options)
}

/// The schema name of a laser scan.
pub const LASER_SCAN: &str = "sensor_msgs/msg/LaserScan";
/// The schema name of an odometry message.
pub const ODOMETRY: &str = "nav_msgs/msg/Odometry";

#[derive(Debug, Deserialize)]
struct Time {
    sec: i32,
    nanosec: u32,
}

#[derive(Debug, Deserialize)]
struct Header {
    stamp: Time,
    #[allow(dead_code)]
    frame_id: String,
}

/// `sensor_msgs/msg/LaserScan`.
#[derive(Debug, Deserialize)]
struct LaserScanMsg {
    header: Header,
    angle_min: f32,
    #[allow(dead_code)]
    angle_max: f32,
    angle_increment: f32,
    #[allow(dead_code)]
    time_increment: f32,
    #[allow(dead_code)]
    scan_time: f32,
    range_min: f32,
    range_max: f32,
    ranges: Vec<f32>,
    // `intensities` follows; not read.
}

#[derive(Debug, Deserialize)]
struct Point {
    x: f64,
    y: f64,
    #[allow(dead_code)]
    z: f64,
}

#[derive(Debug, Deserialize)]
struct Quaternion {
    x: f64,
    y: f64,
    z: f64,
    w: f64,
}

/// The start of `nav_msgs/msg/Odometry` (covariance and twist not read).
#[derive(Debug, Deserialize)]
struct OdometryMsg {
    header: Header,
    #[allow(dead_code)]
    child_frame_id: String,
    position: Point,
    orientation: Quaternion,
}

impl Time {
    fn seconds(&self) -> f64 {
        f64::from(self.sec) + f64::from(self.nanosec) * 1e-9
    }
}

/// Checks that the CDR string at `offset` (after the 4-byte encapsulation
/// header) fits in the payload; returns the offset after it. (The `cdr`
/// crate allocates a string's declared length before reading it, so a
/// corrupt length must not reach it.)
fn check_string(data: &[u8], offset: usize) -> Result<usize, String> {
    let body = data.get(4..).ok_or("shorter than the CDR header")?;
    let little = data.get(1).is_some_and(|b| b & 1 == 1);
    let at = offset.next_multiple_of(4);
    let bytes: [u8; 4] = body
        .get(at..at + 4)
        .and_then(|b| b.try_into().ok())
        .ok_or("truncated")?;
    let len = if little {
        u32::from_le_bytes(bytes)
    } else {
        u32::from_be_bytes(bytes)
    } as usize;
    if len > body.len().saturating_sub(at + 4) {
        return Err(format!(
            "a string of {len} bytes does not fit in the message"
        ));
    }
    Ok(at + 4 + len)
}

pub(super) fn decode_scan(data: &[u8]) -> Result<(Scan, f64), String> {
    check_string(data, 8)?;
    let msg: LaserScanMsg = cdr::deserialize(data).map_err(|e| format!("not a LaserScan: {e}"))?;
    scan_of(LaserFields {
        time: msg.header.stamp.seconds(),
        angle_min: msg.angle_min,
        angle_increment: msg.angle_increment,
        range_min: msg.range_min,
        range_max: msg.range_max,
        ranges: msg.ranges,
    })
}

/// What a `LaserScan` message (ROS 1 or 2) gives the scan.
pub(super) struct LaserFields {
    /// Header stamp, seconds.
    pub(super) time: f64,
    /// Angle of the first beam, radians.
    pub(super) angle_min: f32,
    /// Angle between beams, radians.
    pub(super) angle_increment: f32,
    /// Shortest valid range, metres.
    pub(super) range_min: f32,
    /// Longest valid range, metres.
    pub(super) range_max: f32,
    /// Ranges, metres.
    pub(super) ranges: Vec<f32>,
}

/// The scan of a `LaserScan` message and its stamp (REP 117: a range that
/// is not finite or below `range_min` is no reading).
pub(super) fn scan_of(msg: LaserFields) -> Result<(Scan, f64), String> {
    for (name, v) in [
        ("angle_min", msg.angle_min),
        ("angle_increment", msg.angle_increment),
        ("range_max", msg.range_max),
    ] {
        if !v.is_finite() {
            return Err(format!("{name} is {v}"));
        }
    }
    if msg.ranges.is_empty() {
        return Err("no ranges".into());
    }
    if !msg.ranges.iter().any(|r| r.is_finite()) {
        return Err(format!(
            "all {} ranges are NaN or infinite: nothing to estimate from",
            msg.ranges.len()
        ));
    }
    let range_min = if msg.range_min.is_finite() {
        msg.range_min
    } else {
        0.0
    };
    let ranges = msg
        .ranges
        .iter()
        .map(|&r| (r.is_finite() && r >= range_min).then_some(r))
        .collect();
    Ok((
        Scan {
            record: ScanRecord {
                ranges,
                angle_min: msg.angle_min,
                angle_increment: msg.angle_increment,
                max_range: msg.range_max,
                laser_offset: [0.0; 3],
            },
            time: Some(msg.time),
            odom: None,
            log_pose: None,
            name: String::new(),
        },
        msg.time,
    ))
}

pub(super) fn decode_odometry(data: &[u8]) -> Result<(Pose, f64), String> {
    let after = check_string(data, 8)?;
    check_string(data, after)?;
    let msg: OdometryMsg =
        cdr::deserialize(data).map_err(|e| format!("not an Odometry message: {e}"))?;
    let q = &msg.orientation;
    let pose = odometry_pose((msg.position.x, msg.position.y), [q.x, q.y, q.z, q.w])?;
    Ok((pose, msg.header.stamp.seconds()))
}

/// The planar pose of an odometry message: its position's `x`, `y` and the
/// yaw of its orientation quaternion `[x, y, z, w]`.
pub(super) fn odometry_pose(
    (x, y): (f64, f64),
    [qx, qy, qz, qw]: [f64; 4],
) -> Result<Pose, String> {
    let theta = (2.0 * (qw * qz + qx * qy)).atan2(1.0 - 2.0 * (qy * qy + qz * qz));
    let pose = Pose { x, y, theta };
    if !(pose.x.is_finite() && pose.y.is_finite() && pose.theta.is_finite()) {
        return Err("pose is not finite".into());
    }
    Ok(pose)
}

/// The item of a decoded scan message `named` (its record): the scan timed
/// by its header stamp, or by `time` (the bag's own time of the message,
/// seconds) when the stamp is zero.
pub(super) fn scan_item(decoded: Result<(Scan, f64), String>, time: f64, named: String) -> BagItem {
    Ok(match decoded {
        Ok((mut scan, stamp)) => {
            scan.time = Some(if stamp > 0.0 { stamp } else { time });
            Ok(Event::Scan(scan).with_record(named))
        }
        Err(e) => Err(RecordError::new(named, e)),
    })
}

/// [`scan_item`] for an odometry message.
pub(super) fn odometry_item(
    decoded: Result<(Pose, f64), String>,
    time: f64,
    named: String,
) -> BagItem {
    Ok(match decoded {
        Ok((pose, stamp)) => Ok(Event::Odometry(Odometry {
            time: Some(if stamp > 0.0 { stamp } else { time }),
            pose,
        })),
        Err(e) => Err(RecordError::new(named, e)),
    })
}

/// One topic of a bag: its type and message count.
#[derive(Clone, Debug, Default)]
pub struct TopicInfo {
    /// Schema name.
    pub schema: String,
    /// Messages.
    pub count: usize,
}

/// Every topic with messages, by one streaming pass over the bag.
///
/// # Errors
/// A [`Fatal`] error when the file is not a readable MCAP file.
pub fn topics(input: impl Read, file: &str) -> Result<BTreeMap<String, TopicInfo>, Fatal> {
    let mut topics: BTreeMap<String, TopicInfo> = BTreeMap::new();
    for (i, message) in messages(input).enumerate() {
        let message = match message {
            Ok(m) => m,
            // A damaged file with readable messages first: the reading pass
            // reports the damage as a failed record after them.
            Err(_) if !topics.is_empty() => break,
            Err(e) => {
                return Err(Fatal::io(format!(
                    "{file}: record after message {i}: not a readable MCAP file: {e}"
                )))
            }
        };
        let info = topics.entry(message.channel.topic.clone()).or_default();
        info.schema = message
            .channel
            .schema
            .as_ref()
            .map_or_else(String::new, |s| s.name.clone());
        info.count += 1;
    }
    Ok(topics)
}

/// The usage error for a missing or unknown `--topic`, listing the bag's topics.
pub fn topic_error(file: &str, asked: Option<&str>, topics: &BTreeMap<String, TopicInfo>) -> Fatal {
    let mut list: Vec<String> = topics
        .iter()
        .map(|(t, i)| format!("  {t}  ({}, {} messages)", i.schema, i.count))
        .collect();
    if list.is_empty() {
        list.push("  (none)".into());
    }
    let head = match asked {
        None => format!("{file}: choose the scan topic with --topic; the bag's topics:"),
        Some(t) => format!("{file}: no messages on topic {t}; the bag's topics:"),
    };
    Fatal::usage(format!("{head}\n{}", list.join("\n")))
}

/// The bag's only topic of message type `schema`, if it has exactly one
/// (`log` then needs no `--topic` for its scans).
pub fn only_topic_of(topics: &BTreeMap<String, TopicInfo>, schema: &str) -> Option<String> {
    let mut scans = topics.iter().filter(|(_, i)| i.schema == schema);
    match (scans.next(), scans.next()) {
        (Some((t, _)), None) => Some(t.clone()),
        _ => None,
    }
}

/// Streams the scans of `topic` and the odometry of `odom_topic` (if any).
pub struct BagReader<R: Read> {
    messages: mcap::io::MessageReader<R>,
    file: String,
    topic: String,
    odom_topic: Option<String>,
    count: usize,
    checked: bool,
    done: bool,
}

impl<R: Read> BagReader<R> {
    /// A reader of `topic` (LaserScan) and `odom_topic` (Odometry).
    pub fn new(input: R, file: &str, topic: &str, odom_topic: Option<&str>) -> Self {
        Self {
            messages: messages(input),
            file: file.into(),
            topic: topic.into(),
            odom_topic: odom_topic.map(Into::into),
            count: 0,
            checked: false,
            done: false,
        }
    }
}

/// An item of a bag: an event, a message's error, or a fatal error.
pub type BagItem = Result<Result<Event, RecordError>, Fatal>;

impl<R: Read> Iterator for BagReader<R> {
    type Item = BagItem;

    fn next(&mut self) -> Option<BagItem> {
        while !self.done {
            let Some(message) = self.messages.next() else {
                self.done = true;
                break;
            };
            self.count += 1;
            let record = format!("message {}", self.count);
            let message = match message {
                Ok(m) => m,
                Err(e) => {
                    self.done = true;
                    let error = RecordError::new(
                        format!("record after message {}", self.count - 1),
                        format!("unreadable MCAP (truncated or corrupt file?): {e}"),
                    );
                    return Some(Ok(Err(error)));
                }
            };
            let topic = message.channel.topic.as_str();
            let is_scan = topic == self.topic;
            let is_odom = self.odom_topic.as_deref() == Some(topic);
            if !is_scan && !is_odom {
                continue;
            }
            let schema = message
                .channel
                .schema
                .as_ref()
                .map_or("(no schema)", |s| s.name.as_str());
            let expected = if is_scan { LASER_SCAN } else { ODOMETRY };
            let known = if is_scan {
                schema == LASER_SCAN
            } else {
                crate::tf::is_odometry(schema)
            };
            if !known || message.channel.message_encoding != "cdr" {
                let fatal = Fatal::io(format!(
                    "{}: {record} on topic {topic} is {schema} ({} encoding); expected {expected} \
                     (cdr encoding)",
                    self.file, message.channel.message_encoding
                ));
                if is_scan && !self.checked {
                    self.done = true;
                    return Some(Err(fatal));
                }
                return Some(Ok(Err(RecordError::new(record, fatal.to_string()))));
            }
            let time = message.log_time as f64 * 1e-9;
            let named = format!("{record} (topic {topic})");
            if is_scan {
                self.checked = true;
                return Some(scan_item(decode_scan(&message.data), time, named));
            }
            if let Some(item) = crate::tf::odometry_message(schema, &message.data, time, named) {
                return Some(item);
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::open::{damaged, xorshift};

    const BAG: &[u8] = include_bytes!("../../cli/data/logs/seattle-bag.mcap");

    fn payloads(topic: &str) -> Vec<Vec<u8>> {
        messages(BAG)
            .map(|m| m.expect("a readable bag"))
            .filter(|m| m.channel.topic == topic)
            .map(|m| m.data.into_owned())
            .collect()
    }

    #[test]
    fn the_bundled_payloads_decode() {
        let scans = payloads("/scan");
        assert_eq!(scans.len(), 12);
        let (scan, time) = decode_scan(&scans[0]).expect("a scan");
        assert_eq!(scan.record.ranges.len(), 361);
        assert!(time > 1000.0);
        let (pose, _) = decode_odometry(&payloads("/odom")[0]).expect("odometry");
        assert!(pose.theta.is_finite());
        // Each decoder refuses the other's message.
        assert!(decode_scan(&payloads("/odom")[0]).is_err());
    }

    #[test]
    fn damaged_payloads_are_errors_not_panics() {
        let mut next = xorshift(0x9e37_79b9_7f4a_7c15u64);
        for data in payloads("/scan").iter().chain(&payloads("/odom")).take(4) {
            for cut in 0..data.len().min(200) {
                let _ = decode_scan(&data[..cut]);
                let _ = decode_odometry(&data[..cut]);
            }
            for _ in 0..500 {
                let d = damaged(data, 3, &mut next);
                let _ = decode_scan(&d);
                let _ = decode_odometry(&d);
            }
        }
        // A string length beyond the message is refused before decoding.
        let mut d = payloads("/scan")[0].clone();
        d[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(decode_scan(&d).unwrap_err().contains("does not fit"));
    }
}
