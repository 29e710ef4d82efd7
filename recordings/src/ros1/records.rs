//! The records of a ROS 1 bag (format 2.0), read front to back in one pass,
//! and the messages among them.
//!
//! A bag is the line `#ROSBAG V2.0`, then a sequence of records, each
//! `header length (u32), header, data length (u32), data`; a header is a
//! list of `name=value` fields (each with its u32 length), `op` giving the
//! record's kind:
//!
//! | op | record | where |
//! |---|---|---|
//! | 0x03 | bag header (index position, counts; padded) | first |
//! | 0x05 | chunk (`compression` `none`, `bz2` or `lz4`; `size` decompressed) | top level |
//! | 0x07 | connection (`conn`, `topic`; data: `type`, `md5sum`, …) | in or out of chunks, and in the index |
//! | 0x02 | message data (`conn`, `time`; data: the message) | in chunks, or at the top level (an unchunked bag) |
//! | 0x04 | index data (`ver` 1, `conn`, `count`; data: `count` × 12 bytes) | after each chunk, or anywhere |
//! | 0x06 | chunk information (`ver` 1, `count`; data: `count` × 8 bytes) | in the index at the end |
//!
//! Every layout of these is read the same way: chunks are opened where
//! they are, messages read inside or outside them, connections taken
//! wherever they are (a message before its connection is resolved by the
//! caller, who may know the connections from a first pass: [`Messages::knowing`]),
//! and index records skipped, so a bag without its index (a recording cut
//! short) reads as one with it.
//!
//! The two index records' data lengths are taken from their `count`, as
//! rosbag's own readers take them (they skip the stated length): older
//! rosbag versions wrote a wrong length on index data (the
//! `laser_scan_matcher` demo bag: 20 bytes an entry stated, 12 written), so
//! that trusting it lands mid-chunk. Lengths are bounded by
//! [`RECORD_LIMIT`] and read as the bytes arrive, so a corrupt length fails
//! without allocating it; a truncated or corrupt file ends with an error of
//! its record after the messages before it. Memory: one decompressed chunk.

use std::collections::HashMap;
use std::io::Read;

/// The first bytes of a ROS 1 bag.
pub const MAGIC: &[u8] = b"#ROSBAG V2.0\n";
/// Largest record header or data (and decompressed chunk) read, bytes.
pub const RECORD_LIMIT: usize = 1 << 28;

const OP_MESSAGE_DATA: u8 = 0x02;
const OP_BAG_HEADER: u8 = 0x03;
const OP_INDEX_DATA: u8 = 0x04;
const OP_CHUNK: u8 = 0x05;
const OP_CHUNK_INFO: u8 = 0x06;
const OP_CONNECTION: u8 = 0x07;

/// One record: its header fields and data.
struct Record {
    header: Vec<u8>,
    data: Vec<u8>,
}

impl Record {
    /// The value of header field `name`.
    fn field(&self, name: &str) -> Option<&[u8]> {
        field(&self.header, name)
    }

    fn op(&self) -> Option<u8> {
        op(&self.header)
    }

    fn u32_field(&self, name: &str) -> Result<u32, String> {
        u32_field(&self.header, name).ok_or_else(|| format!("no 4-byte `{name}` field"))
    }
}

/// The `name=value` fields of a header (a malformed field ends the list).
fn fields(header: &[u8]) -> impl Iterator<Item = (&[u8], &[u8])> {
    let mut rest = header;
    std::iter::from_fn(move || {
        let len = u32::from_le_bytes(rest.get(..4)?.try_into().ok()?) as usize;
        let field = rest.get(4..4usize.checked_add(len)?)?;
        rest = &rest[4 + len..];
        let eq = field.iter().position(|&b| b == b'=')?;
        Some((&field[..eq], &field[eq + 1..]))
    })
}

fn field<'a>(header: &'a [u8], name: &str) -> Option<&'a [u8]> {
    fields(header).find_map(|(n, v)| (n == name.as_bytes()).then_some(v))
}

fn op(header: &[u8]) -> Option<u8> {
    match field(header, "op") {
        Some(&[op]) => Some(op),
        _ => None,
    }
}

fn u32_field(header: &[u8], name: &str) -> Option<u32> {
    field(header, name)
        .and_then(|v| v.try_into().ok())
        .map(u32::from_le_bytes)
}

/// Reads a u32 length.
fn length(input: &mut impl Read, what: &str) -> Result<usize, String> {
    let mut len = [0u8; 4];
    input
        .read_exact(&mut len)
        .map_err(|e| format!("{what} length: {e}"))?;
    Ok(u32::from_le_bytes(len) as usize)
}

/// Reads `len` bytes, at most [`RECORD_LIMIT`].
fn bytes(input: &mut impl Read, len: usize, what: &str) -> Result<Vec<u8>, String> {
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

/// The data length of a record with `header`: for index data and chunk
/// information (version 1) their entries times `count`, whatever the
/// `stated` length says; for the others the stated length.
fn data_length(header: &[u8], stated: usize) -> usize {
    let entry = match (op(header), u32_field(header, "ver")) {
        (Some(OP_INDEX_DATA), Some(1)) => 12,
        (Some(OP_CHUNK_INFO), Some(1)) => 8,
        _ => return stated,
    };
    u32_field(header, "count").map_or(stated, |count| (count as usize).saturating_mul(entry))
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
    let len = length(&mut input, "record header")?;
    let header = bytes(&mut input, len, "record header")?;
    let stated = length(&mut input, "record data")?;
    let data = bytes(&mut input, data_length(&header, stated), "record data")?;
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
#[derive(Clone, Debug, PartialEq)]
pub struct Connection {
    /// The topic.
    pub topic: String,
    /// The message type (`sensor_msgs/LaserScan`).
    pub msg_type: String,
    /// The MD5 sum of the message definition (empty when not given).
    pub md5sum: String,
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

/// A message: its connection's id, the record time (s) and the payload.
pub struct Message {
    /// The connection's id ([`Messages::connection`] names it).
    pub conn: u32,
    /// The record time, seconds.
    pub time: f64,
    /// The serialized message.
    pub data: Vec<u8>,
}

/// The bag's messages, in file order, then the first error (a damaged file
/// yields the messages before the damage, then its error).
pub struct Messages<R: Read> {
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
    /// The messages of the bag `input`.
    pub fn new(input: R) -> Self {
        Self {
            input,
            connections: HashMap::new(),
            chunk: None,
            records: 0,
            started: false,
            done: false,
        }
    }

    /// The reader knowing `connections` before it reads them (a first pass
    /// found them anywhere in the file, e.g. only in the index at its end).
    pub fn knowing(mut self, connections: HashMap<u32, Connection>) -> Self {
        self.connections = connections;
        self
    }

    /// Connection `id`, when known by now.
    pub fn connection(&self, id: u32) -> Option<&Connection> {
        self.connections.get(&id)
    }

    /// Every connection known by now.
    pub fn connections(&self) -> &HashMap<u32, Connection> {
        &self.connections
    }

    /// The next record: from the current chunk, else from the file; and
    /// whether it was in a chunk.
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

    /// What `record` gives: a message, `None` for a record with none, or
    /// an error (`Err(true)`: the reading cannot go on).
    fn take(&mut self, record: Record, in_chunk: bool) -> Result<Option<Message>, (String, bool)> {
        match record.op() {
            Some(OP_CHUNK) if !in_chunk => {
                self.chunk = Some((unchunk(&record).map_err(|e| (e, true))?, 0));
            }
            Some(OP_CHUNK) => return Err(("a chunk inside a chunk".into(), false)),
            Some(OP_CONNECTION) => {
                let (id, c) =
                    connection(&record).map_err(|e| (format!("connection: {e}"), false))?;
                self.connections.insert(id, c);
            }
            Some(OP_MESSAGE_DATA) => {
                let conn = record
                    .u32_field("conn")
                    .map_err(|e| (format!("message: {e}"), false))?;
                let time = match record.field("time") {
                    Some(&[a, b, c, d, e, f, g, h]) => {
                        let secs = u32::from_le_bytes([a, b, c, d]);
                        let nsecs = u32::from_le_bytes([e, f, g, h]);
                        f64::from(secs) + f64::from(nsecs) * 1e-9
                    }
                    _ => return Err(("message without its time".into(), false)),
                };
                return Ok(Some(Message {
                    conn,
                    time,
                    data: record.data,
                }));
            }
            Some(OP_BAG_HEADER) if in_chunk => {
                return Err(("a bag header inside a chunk".into(), false))
            }
            // The bag header, index data, chunk information (sized by
            // `record`), and records of later versions.
            Some(_) => {}
            None => return Err(("a record without its `op`".into(), true)),
        }
        Ok(None)
    }
}

impl<R: Read> Iterator for Messages<R> {
    type Item = Result<Message, String>;

    fn next(&mut self) -> Option<Self::Item> {
        while !self.done {
            let item = self.next_record();
            self.records += 1;
            let records = self.records;
            let fail = |e: String| Some(Err(format!("record {records}: {e}")));
            let (record, in_chunk) = match item {
                Ok(Some(r)) => r,
                Ok(None) => {
                    self.done = true;
                    break;
                }
                Err(e) => {
                    self.done = true;
                    return fail(e);
                }
            };
            match self.take(record, in_chunk) {
                Ok(Some(message)) => return Some(Ok(message)),
                Ok(None) => {}
                Err((e, stop)) => {
                    self.done = stop;
                    return fail(e);
                }
            }
        }
        None
    }
}
