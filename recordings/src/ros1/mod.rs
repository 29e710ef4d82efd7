//! ROS 1 bags (format 2.0): `sensor_msgs/LaserScan` (or
//! `sensor_msgs/MultiEchoLaserScan`, each beam's first echo) messages of one
//! topic, and `nav_msgs/Odometry` as the odometry, or, in a bag without
//! `/odom`, `/tf`'s `odom` → `base_link` transform (`tf2_msgs/TFMessage` or
//! the older `tf/tfMessage`, [`crate::tf`]).
//!
//! The file is read front to back, twice: [`contents`] lists its topics and
//! connections (wherever their records are), then [`BagReader`] streams the
//! messages of the chosen topics. The records and every layout of them
//! that the format allows (chunked or not, compressed or not, connections
//! and index records anywhere, with or without the index at the end) are
//! [`records`]; the payloads [`decode`].
//!
//! Ranges follow REP 117 as for ROS 2 bags ([`crate::ros2`]). A scan's time
//! is its header stamp (the record time when the stamp is zero); its
//! odometry the last odometry message before it in the file. The laser's
//! offset on the robot is `--laser-offset` (not read from `/tf`).

mod decode;
pub mod records;
#[cfg(test)]
mod tests;

use std::collections::{BTreeMap, HashMap};
use std::io::Read;

use crate::error::{Fatal, RecordError};
use crate::ros2::{odometry_item, scan_item, BagItem, TopicInfo};
use decode::{decode_multi_echo, decode_odometry, decode_scan, decode_tf_odometry};
pub use records::{Connection, Messages, MAGIC, RECORD_LIMIT};

/// The message type of a laser scan.
pub const LASER_SCAN: &str = "sensor_msgs/LaserScan";
/// The message type of a laser scan with several echoes a beam (the first
/// echo of each beam is its range; Cartographer's public bags carry these).
pub const MULTI_ECHO_SCAN: &str = "sensor_msgs/MultiEchoLaserScan";
/// The message type of an odometry message.
pub const ODOMETRY: &str = "nav_msgs/Odometry";
/// The message type of a transform message (`/tf`).
pub const TF_MESSAGE: &str = "tf2_msgs/TFMessage";
/// The message type of a transform message before `tf2` (the same layout).
pub const TF_MESSAGE_OLD: &str = "tf/tfMessage";
/// The transforms' message types, read as odometry ([`crate::tf`]).
pub const TRANSFORMS: [&str; 2] = [TF_MESSAGE, TF_MESSAGE_OLD];
/// MD5 sums of the messages' definitions (a connection that gives another
/// sum has another layout and is refused).
const LASER_SCAN_MD5: &str = "90c7ef2dc6895d81024acba2ac42f369";
const MULTI_ECHO_SCAN_MD5: &str = "6fefb0c6da89d7c8abe4b339f5c2f8fb";
const ODOMETRY_MD5: &str = "cd5e73d190d741a2f92e81eda573aca7";
const TF_MESSAGE_MD5: &str = "94810edda583a504dfda3829e70d7eec";
/// The odometry's types and their sums (the first when a connection is of
/// none of them).
const ODOMETRY_TYPES: [(&str, &str); 3] = [
    (ODOMETRY, ODOMETRY_MD5),
    (TF_MESSAGE, TF_MESSAGE_MD5),
    (TF_MESSAGE_OLD, TF_MESSAGE_MD5),
];

/// What one pass over a bag found: its topics with messages, and every
/// connection declared anywhere in it.
#[derive(Clone, Debug, Default)]
pub struct Contents {
    /// Each topic with messages: its message type and count.
    pub topics: BTreeMap<String, TopicInfo>,
    /// The connections by id.
    pub connections: HashMap<u32, Connection>,
}

/// The topics and connections of a bag, by one pass over it (messages on a
/// connection no record declares are not counted).
///
/// # Errors
/// A [`Fatal`] error when the file is not a readable ROS 1 bag.
pub fn contents(input: impl Read, file: &str) -> Result<Contents, Fatal> {
    let mut messages = Messages::new(input);
    let mut counts: BTreeMap<u32, usize> = BTreeMap::new();
    for message in messages.by_ref() {
        match message {
            Ok(m) => *counts.entry(m.conn).or_default() += 1,
            // A damaged file with readable messages first: the reading pass
            // reports the damage as a failed record after them.
            Err(_) if !counts.is_empty() => break,
            Err(e) => return Err(Fatal::io(format!("{file}: not a readable ROS 1 bag: {e}"))),
        }
    }
    let mut topics: BTreeMap<String, TopicInfo> = BTreeMap::new();
    for (id, count) in counts {
        if let Some(c) = messages.connection(id) {
            let info = topics.entry(c.topic.clone()).or_default();
            info.schema.clone_from(&c.msg_type);
            info.count += count;
        }
    }
    Ok(Contents {
        topics,
        connections: messages.connections().clone(),
    })
}

/// Streams the scans of `topic` and the odometry of `odom_topic` (if any).
pub struct BagReader<R: Read> {
    messages: Messages<R>,
    file: String,
    topic: String,
    odom_topic: Option<String>,
    count: usize,
    checked: bool,
}

impl<R: Read> BagReader<R> {
    /// A reader of `topic` (LaserScan) and `odom_topic` (Odometry or
    /// TFMessage).
    pub fn new(input: R, file: &str, topic: &str, odom_topic: Option<&str>) -> Self {
        Self {
            messages: Messages::new(input),
            file: file.into(),
            topic: topic.into(),
            odom_topic: odom_topic.map(Into::into),
            count: 0,
            checked: false,
        }
    }

    /// The reader knowing the connections a first pass found ([`contents`]),
    /// so that a message before its connection record is read.
    pub fn knowing(mut self, contents: &Contents) -> Self {
        self.messages = self.messages.knowing(contents.connections.clone());
        self
    }
}

impl<R: Read> Iterator for BagReader<R> {
    type Item = BagItem;

    fn next(&mut self) -> Option<BagItem> {
        loop {
            let message = match self.messages.next()? {
                Ok(m) => m,
                Err(e) => {
                    let error = RecordError::new(
                        format!("after message {}", self.count),
                        format!("unreadable ROS 1 bag (truncated or corrupt file?): {e}"),
                    );
                    return Some(Ok(Err(error)));
                }
            };
            self.count += 1;
            let record = format!("message {}", self.count);
            let Some(c) = self.messages.connection(message.conn) else {
                let error = format!(
                    "on connection {}, which no record of the bag declares",
                    message.conn
                );
                return Some(Ok(Err(RecordError::new(record, error))));
            };
            let topic = c.topic.as_str();
            let is_scan = topic == self.topic;
            let is_odom = self.odom_topic.as_deref() == Some(topic);
            if !is_scan && !is_odom {
                continue;
            }
            let multi_echo = is_scan && c.msg_type == MULTI_ECHO_SCAN;
            let (expected, md5) = match (is_scan, multi_echo) {
                (true, true) => (MULTI_ECHO_SCAN, MULTI_ECHO_SCAN_MD5),
                (true, false) => (LASER_SCAN, LASER_SCAN_MD5),
                _ => ODOMETRY_TYPES
                    .into_iter()
                    .find(|(t, _)| *t == c.msg_type)
                    .unwrap_or(ODOMETRY_TYPES[0]),
            };
            if c.msg_type != expected || !(c.md5sum.is_empty() || c.md5sum == md5) {
                let fatal = Fatal::io(format!(
                    "{}: {record} on topic {topic} is {} (md5sum {}); expected {expected} \
                     (md5sum {md5})",
                    self.file, c.msg_type, c.md5sum
                ));
                if is_scan && !self.checked {
                    return Some(Err(fatal));
                }
                return Some(Ok(Err(RecordError::new(record, fatal.to_string()))));
            }
            let named = format!("{record} (topic {topic})");
            if is_scan {
                self.checked = true;
                let decoded = if multi_echo {
                    decode_multi_echo(&message.data)
                } else {
                    decode_scan(&message.data)
                };
                return Some(scan_item(decoded, message.time, named));
            }
            if expected == ODOMETRY {
                return Some(odometry_item(
                    decode_odometry(&message.data),
                    message.time,
                    named,
                ));
            }
            // A transform message without the odometry's transform is passed
            // over.
            if let Some(decoded) = decode_tf_odometry(&message.data).transpose() {
                return Some(odometry_item(decoded, message.time, named));
            }
        }
    }
}
