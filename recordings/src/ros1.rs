//! ROS 1 bags (format 2.0): `sensor_msgs/LaserScan` (or
//! `sensor_msgs/MultiEchoLaserScan`, each beam's first echo) messages of one
//! topic, and `nav_msgs/Odometry` as the odometry.
//!
//! The file is read front to back in one pass. A bag is a sequence of
//! records, each `header length (u32), header, data length (u32), data`; a
//! header is a list of `name=value` fields (each with its u32 length), `op`
//! giving the record's kind. Chunks (op 0x05; compression `none`, `bz2` or
//! `lz4`) hold the connection records (op 0x07: a connection's topic and
//! message type, before its first message) and the message data records
//! (op 0x02: connection, time, serialized message); the index section after
//! the chunks (index data, chunk information, the connections again) is
//! skipped. Lengths are bounded by [`RECORD_LIMIT`] and read as the bytes
//! arrive, so a corrupt length fails without allocating it; a truncated or
//! corrupt file ends with an error of its record after the messages before
//! it. Memory: one decompressed chunk.
//!
//! Payloads use the ROS 1 serialization (little-endian; strings and arrays
//! a u32 length, then the items), decoded by hand with every length checked
//! against the message. Ranges follow REP 117 as for ROS 2 bags
//! ([`crate::ros2`]). A scan's time is its header stamp (the record time
//! when the stamp is zero); its odometry the last odometry message before
//! it in the file. The laser's offset on the robot is `--laser-offset`
//! (`/tf` is not read).

use std::collections::{BTreeMap, HashMap};
use std::io::Read;

use crate::error::{Fatal, RecordError};
use crate::model::{Pose, Scan};
use crate::ros2::{
    odometry_item, odometry_pose, scan_item, scan_of, BagItem, LaserFields, TopicInfo,
};

/// The first bytes of a ROS 1 bag.
pub const MAGIC: &[u8] = b"#ROSBAG V2.0\n";
/// Largest record header or data (and decompressed chunk) read, bytes.
pub const RECORD_LIMIT: usize = 1 << 28;
/// The message type of a laser scan.
pub const LASER_SCAN: &str = "sensor_msgs/LaserScan";
/// The message type of a laser scan with several echoes a beam (the first
/// echo of each beam is its range; Cartographer's public bags carry these).
pub const MULTI_ECHO_SCAN: &str = "sensor_msgs/MultiEchoLaserScan";
/// The message type of an odometry message.
pub const ODOMETRY: &str = "nav_msgs/Odometry";
/// MD5 sums of the two messages' definitions (a connection that gives
/// another sum has another layout and is refused).
const LASER_SCAN_MD5: &str = "90c7ef2dc6895d81024acba2ac42f369";
const MULTI_ECHO_SCAN_MD5: &str = "6fefb0c6da89d7c8abe4b339f5c2f8fb";
const ODOMETRY_MD5: &str = "cd5e73d190d741a2f92e81eda573aca7";

const OP_MESSAGE_DATA: u8 = 0x02;
const OP_BAG_HEADER: u8 = 0x03;
const OP_CHUNK: u8 = 0x05;
const OP_CONNECTION: u8 = 0x07;

/// One record: its header fields and data.
struct Record {
    header: Vec<u8>,
    data: Vec<u8>,
}

impl Record {
    /// The value of header field `name`.
    fn field(&self, name: &str) -> Option<&[u8]> {
        fields(&self.header).find_map(|(n, v)| (n == name.as_bytes()).then_some(v))
    }

    fn op(&self) -> Option<u8> {
        match self.field("op") {
            Some(&[op]) => Some(op),
            _ => None,
        }
    }

    fn u32_field(&self, name: &str) -> Result<u32, String> {
        self.field(name)
            .and_then(|v| v.try_into().ok())
            .map(u32::from_le_bytes)
            .ok_or_else(|| format!("no 4-byte `{name}` field"))
    }
}

/// The `name=value` fields of a header (a malformed field ends the list).
fn fields(header: &[u8]) -> impl Iterator<Item = (&[u8], &[u8])> {
    let mut rest = header;
    std::iter::from_fn(move || {
        let len = u32::from_le_bytes(rest.get(..4)?.try_into().ok()?) as usize;
        let field = rest.get(4..4 + len)?;
        rest = &rest[4 + len..];
        let eq = field.iter().position(|&b| b == b'=')?;
        Some((&field[..eq], &field[eq + 1..]))
    })
}

/// Reads a length-prefixed block of at most [`RECORD_LIMIT`] bytes.
fn block(input: &mut impl Read, what: &str) -> Result<Vec<u8>, String> {
    let mut len = [0u8; 4];
    input
        .read_exact(&mut len)
        .map_err(|e| format!("{what} length: {e}"))?;
    let len = u32::from_le_bytes(len) as usize;
    if len > RECORD_LIMIT {
        return Err(format!("{what} of {len} bytes (corrupt length?)"));
    }
    let mut out = Vec::new();
    input
        .take(len as u64)
        .read_to_end(&mut out)
        .map_err(|e| format!("{what}: {e}"))?;
    if out.len() != len {
        return Err(format!(
            "{what}: {} of {len} bytes (truncated file?)",
            out.len()
        ));
    }
    Ok(out)
}

/// The next record, or `None` at the end of `input`.
fn record(input: &mut impl Read) -> Result<Option<Record>, String> {
    // The end is clean only between records.
    let mut first = [0u8; 1];
    loop {
        match input.read(&mut first) {
            Ok(0) => return Ok(None),
            Ok(_) => break,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(format!("record: {e}")),
        }
    }
    let mut input = first.as_slice().chain(input);
    let header = block(&mut input, "record header")?;
    let data = block(&mut input, "record data")?;
    Ok(Some(Record { header, data }))
}

/// A chunk's records, decompressed (at most its declared size).
fn unchunk(chunk: &Record) -> Result<Vec<u8>, String> {
    let size = chunk.u32_field("size")? as usize;
    if size > RECORD_LIMIT {
        return Err(format!("chunk of {size} bytes (corrupt size?)"));
    }
    let compression = chunk.field("compression").unwrap_or(b"none");
    let mut out = Vec::with_capacity(size.min(1 << 20));
    let limit = size as u64 + 1;
    let read = match compression {
        b"none" if chunk.data.len() == size => return Ok(chunk.data.clone()),
        b"none" => {
            return Err(format!(
                "chunk of {} bytes, its header says {size}",
                chunk.data.len()
            ))
        }
        b"bz2" => bzip2::read::BzDecoder::new(chunk.data.as_slice())
            .take(limit)
            .read_to_end(&mut out),
        b"lz4" => lz4_flex::frame::FrameDecoder::new(chunk.data.as_slice())
            .take(limit)
            .read_to_end(&mut out),
        other => {
            return Err(format!(
                "chunk compression `{}` (bz2, lz4 and none are read)",
                String::from_utf8_lossy(other)
            ))
        }
    };
    read.map_err(|e| format!("chunk does not decompress: {e}"))?;
    if out.len() != size {
        return Err(format!(
            "chunk decompresses to {} bytes, its header says {size}",
            out.len()
        ));
    }
    Ok(out)
}

/// A connection: its topic and message type, and the definition's MD5 sum.
#[derive(Clone, Debug)]
struct Connection {
    topic: String,
    msg_type: String,
    md5sum: String,
}

fn connection(record: &Record) -> Result<(u32, Connection), String> {
    let id = record.u32_field("conn")?;
    let text = |v: &[u8]| String::from_utf8_lossy(v).into_owned();
    let topic = record.field("topic").map(text).ok_or("no topic")?;
    let mut msg_type = String::new();
    let mut md5sum = String::new();
    for (name, value) in fields(&record.data) {
        match name {
            b"type" => msg_type = text(value),
            b"md5sum" => md5sum = text(value),
            _ => {}
        }
    }
    Ok((
        id,
        Connection {
            topic,
            msg_type,
            md5sum,
        },
    ))
}

/// A message: its connection, the record time (s) and the payload.
struct Message {
    connection: Connection,
    time: f64,
    data: Vec<u8>,
}

/// The bag's messages, in file order, then the first error (a damaged file
/// yields the messages before the damage, then its error).
struct Messages<R: Read> {
    input: R,
    connections: HashMap<u32, Connection>,
    /// The decompressed chunk being read, and where.
    chunk: Option<(Vec<u8>, usize)>,
    /// Records read (top level and in chunks), for the error messages.
    records: usize,
    started: bool,
    done: bool,
}

impl<R: Read> Messages<R> {
    fn new(input: R) -> Self {
        Self {
            input,
            connections: HashMap::new(),
            chunk: None,
            records: 0,
            started: false,
            done: false,
        }
    }

    /// The next record: from the current chunk, else from the file.
    fn next_record(&mut self) -> Result<Option<(Record, bool)>, String> {
        if let Some((data, at)) = &mut self.chunk {
            let mut rest = data.get(*at..).unwrap_or(&[]);
            let before = rest.len();
            match record(&mut rest)? {
                Some(r) => {
                    *at += before - rest.len();
                    return Ok(Some((r, true)));
                }
                None => self.chunk = None,
            }
        }
        if !self.started {
            let mut magic = [0u8; 13];
            self.input
                .read_exact(&mut magic)
                .map_err(|e| format!("no ROS 1 bag header: {e}"))?;
            if magic != MAGIC {
                return Err("not a ROS 1 bag (format 2.0)".into());
            }
            self.started = true;
        }
        Ok(record(&mut self.input)?.map(|r| (r, false)))
    }
}

impl<R: Read> Iterator for Messages<R> {
    type Item = Result<Message, String>;

    fn next(&mut self) -> Option<Self::Item> {
        while !self.done {
            let item = self.next_record();
            self.records += 1;
            let fail = |e: String, records: usize| Err(format!("record {records}: {e}"));
            let (record, in_chunk) = match item {
                Ok(Some(r)) => r,
                Ok(None) => {
                    self.done = true;
                    break;
                }
                Err(e) => {
                    self.done = true;
                    return Some(fail(e, self.records));
                }
            };
            match record.op() {
                Some(OP_CHUNK) if !in_chunk => match unchunk(&record) {
                    Ok(data) => self.chunk = Some((data, 0)),
                    Err(e) => {
                        self.done = true;
                        return Some(fail(e, self.records));
                    }
                },
                Some(OP_CONNECTION) => match connection(&record) {
                    Ok((id, c)) => {
                        self.connections.insert(id, c);
                    }
                    Err(e) => return Some(fail(format!("connection: {e}"), self.records)),
                },
                Some(OP_MESSAGE_DATA) => {
                    let id = match record.u32_field("conn") {
                        Ok(id) => id,
                        Err(e) => return Some(fail(format!("message: {e}"), self.records)),
                    };
                    let Some(connection) = self.connections.get(&id).cloned() else {
                        return Some(fail(
                            format!("message on connection {id}, which no record declared"),
                            self.records,
                        ));
                    };
                    let time = match record.field("time") {
                        Some(&[a, b, c, d, e, f, g, h]) => {
                            let secs = u32::from_le_bytes([a, b, c, d]);
                            let nsecs = u32::from_le_bytes([e, f, g, h]);
                            f64::from(secs) + f64::from(nsecs) * 1e-9
                        }
                        _ => return Some(fail("message without its time".into(), self.records)),
                    };
                    return Some(Ok(Message {
                        connection,
                        time,
                        data: record.data,
                    }));
                }
                Some(OP_BAG_HEADER) if in_chunk => {
                    return Some(fail("a bag header inside a chunk".into(), self.records))
                }
                // The bag header, index data, chunk information.
                Some(_) => {}
                None => {
                    self.done = true;
                    return Some(fail("a record without its `op`".into(), self.records));
                }
            }
        }
        None
    }
}

/// A ROS 1 message being read: every length checked against the payload.
struct Payload<'a> {
    data: &'a [u8],
}

impl<'a> Payload<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        if n > self.data.len() {
            return Err("truncated message".into());
        }
        let (head, rest) = self.data.split_at(n);
        self.data = rest;
        Ok(head)
    }

    fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().unwrap_or([0; 4]),
        ))
    }

    fn f32(&mut self) -> Result<f32, String> {
        Ok(f32::from_bits(self.u32()?))
    }

    fn f64(&mut self) -> Result<f64, String> {
        Ok(f64::from_le_bytes(
            self.take(8)?.try_into().unwrap_or([0; 8]),
        ))
    }

    fn string(&mut self) -> Result<(), String> {
        let len = self.u32()? as usize;
        self.take(len)
            .map(|_| ())
            .map_err(|_| format!("a string of {len} bytes does not fit in the message"))
    }

    /// `std_msgs/Header`: its stamp, seconds.
    fn header(&mut self) -> Result<f64, String> {
        let _seq = self.u32()?;
        let secs = self.u32()?;
        let nsecs = self.u32()?;
        self.string()?;
        Ok(f64::from(secs) + f64::from(nsecs) * 1e-9)
    }

    fn f32_array(&mut self) -> Result<Vec<f32>, String> {
        let len = self.u32()? as usize;
        let bytes = len
            .checked_mul(4)
            .filter(|&b| b <= self.data.len())
            .ok_or_else(|| format!("an array of {len} floats does not fit in the message"))?;
        Ok(self
            .take(bytes)?
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect())
    }
}

/// The fields of a `LaserScan` or `MultiEchoLaserScan` before its ranges
/// (ranges left empty).
fn scan_head(p: &mut Payload<'_>) -> Result<LaserFields, String> {
    let time = p.header()?;
    let angle_min = p.f32()?;
    let _angle_max = p.f32()?;
    let angle_increment = p.f32()?;
    let _time_increment = p.f32()?;
    let _scan_time = p.f32()?;
    Ok(LaserFields {
        time,
        angle_min,
        angle_increment,
        range_min: p.f32()?,
        range_max: p.f32()?,
        ranges: Vec::new(),
    })
}

fn decode_scan(data: &[u8]) -> Result<(Scan, f64), String> {
    let mut p = Payload { data };
    let head = scan_head(&mut p)?;
    // `intensities` follows the ranges; not read.
    scan_of(LaserFields {
        ranges: p.f32_array()?,
        ..head
    })
}

/// A `MultiEchoLaserScan`: each beam's first echo is its range (a beam
/// without echoes has no reading).
fn decode_multi_echo(data: &[u8]) -> Result<(Scan, f64), String> {
    let mut p = Payload { data };
    let head = scan_head(&mut p)?;
    let beams = p.u32()? as usize;
    // Each beam takes at least its 4-byte echo count.
    if beams.saturating_mul(4) > p.data.len() {
        return Err(format!("{beams} beams do not fit in the message"));
    }
    let mut ranges = Vec::with_capacity(beams);
    for _ in 0..beams {
        let echoes = p.f32_array()?;
        ranges.push(echoes.first().copied().unwrap_or(f32::NAN));
    }
    // `intensities` follows; not read.
    scan_of(LaserFields { ranges, ..head })
}

fn decode_odometry(data: &[u8]) -> Result<(Pose, f64), String> {
    let mut p = Payload { data };
    let time = p.header()?;
    p.string()?; // child_frame_id
    let (x, y, _z) = (p.f64()?, p.f64()?, p.f64()?);
    let q = [p.f64()?, p.f64()?, p.f64()?, p.f64()?];
    Ok((odometry_pose((x, y), q)?, time))
}

/// Every topic with messages, by one pass over the bag.
///
/// # Errors
/// A [`Fatal`] error when the file is not a readable ROS 1 bag.
pub fn topics(input: impl Read, file: &str) -> Result<BTreeMap<String, TopicInfo>, Fatal> {
    let mut topics: BTreeMap<String, TopicInfo> = BTreeMap::new();
    for message in Messages::new(input) {
        let message = match message {
            Ok(m) => m,
            // A damaged file with readable messages first: the reading pass
            // reports the damage as a failed record after them.
            Err(_) if !topics.is_empty() => break,
            Err(e) => return Err(Fatal::io(format!("{file}: not a readable ROS 1 bag: {e}"))),
        };
        let info = topics.entry(message.connection.topic).or_default();
        info.schema = message.connection.msg_type;
        info.count += 1;
    }
    Ok(topics)
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
    /// A reader of `topic` (LaserScan) and `odom_topic` (Odometry).
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
            let topic = message.connection.topic.as_str();
            let is_scan = topic == self.topic;
            let is_odom = self.odom_topic.as_deref() == Some(topic);
            if !is_scan && !is_odom {
                continue;
            }
            let c = &message.connection;
            let multi_echo = is_scan && c.msg_type == MULTI_ECHO_SCAN;
            let (expected, md5) = match (is_scan, multi_echo) {
                (true, true) => (MULTI_ECHO_SCAN, MULTI_ECHO_SCAN_MD5),
                (true, false) => (LASER_SCAN, LASER_SCAN_MD5),
                _ => (ODOMETRY, ODOMETRY_MD5),
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
            return Some(odometry_item(
                decode_odometry(&message.data),
                message.time,
                named,
            ));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::open::{damaged, xorshift};

    const BAG: &[u8] = include_bytes!("../../cli/data/logs/seattle-bag.bag");
    const LZ4: &[u8] = include_bytes!("../../cli/data/logs/seattle-bag-lz4.bag");

    fn payloads(bag: &[u8], topic: &str) -> Vec<Vec<u8>> {
        Messages::new(bag)
            .map(|m| m.expect("a readable bag"))
            .filter(|m| m.connection.topic == topic)
            .map(|m| m.data)
            .collect()
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
}
