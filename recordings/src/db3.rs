//! ROS 2 bags in SQLite (`.db3`, the default storage of ROS 2 up to
//! Humble): `sensor_msgs/msg/LaserScan` messages of one topic, and
//! `nav_msgs/msg/Odometry` as the odometry.
//!
//! A bag is a directory holding `metadata.yaml` and one or more `.db3` files
//! (a split bag, its files in order: [`crate::bagdir`]), or one `.db3` file
//! given by itself. In each file, the `messages` of the two topics are read
//! in time order (then by row id), a page of rows at a time, so memory holds
//! one page. The files are opened read-only and immutable ([`open`]): reading
//! leaves the bag's directory as it was. Payloads are CDR, decoded as for MCAP bags
//! ([`crate::ros2`]); a message's time is its header stamp (the bag's
//! receive time when the stamp is zero).

use std::collections::{BTreeMap, VecDeque};
use std::path::{Path, PathBuf};

use rusqlite::{Connection, OpenFlags};

use crate::error::{Fatal, RecordError};
use crate::ros2::{decode_scan, scan_item, BagItem, TopicInfo, LASER_SCAN, ODOMETRY};

/// The first bytes of an SQLite database.
pub const MAGIC: &[u8] = b"SQLite format 3\0";
/// Rows read from the database at a time.
const PAGE: i64 = 256;

/// Opens `path` read-only and immutable (an SQLite URI with `mode=ro` and
/// `immutable=1`): SQLite then takes no lock and writes nothing beside the
/// file (no `-shm`, no `-wal`), so a bag on a read-only medium reads, and a
/// bag read is left as it was. Immutable means the file must not change
/// while it is read, as a finished recording does not. A bag whose
/// recording left a non-empty write-ahead log (`FILE-wal`, rosbag2's
/// `resilient` preset cut short) holds messages there that an immutable
/// reader would miss: it is opened read-only only (SQLite may then add its
/// `-shm` file beside it).
fn open(path: &Path) -> Result<Connection, String> {
    let mut wal = path.as_os_str().to_owned();
    wal.push("-wal");
    let immutable = std::fs::metadata(&wal).map_or(true, |m| m.len() == 0);
    Connection::open_with_flags(
        uri(path, immutable),
        OpenFlags::SQLITE_OPEN_READ_ONLY
            | OpenFlags::SQLITE_OPEN_URI
            | OpenFlags::SQLITE_OPEN_NO_MUTEX,
    )
    .map_err(|e| format!("cannot open: {e}"))
}

/// The read-only (and `immutable`) SQLite URI of `path` (`%`, `?` and `#`,
/// which a URI's path cannot hold as they are, percent-encoded).
fn uri(path: &Path, immutable: bool) -> String {
    let mut out = String::from("file:");
    for c in path.to_string_lossy().chars() {
        match c {
            '%' | '?' | '#' => out.push_str(&format!("%{:02X}", c as u32)),
            c => out.push(c),
        }
    }
    out.push_str(if immutable {
        "?mode=ro&immutable=1"
    } else {
        "?mode=ro"
    });
    out
}

/// Every topic with messages in the bag's files.
///
/// # Errors
/// A [`Fatal`] error when a file is not a readable ROS 2 SQLite bag.
pub fn topics(files: &[PathBuf]) -> Result<BTreeMap<String, TopicInfo>, Fatal> {
    let mut topics: BTreeMap<String, TopicInfo> = BTreeMap::new();
    for path in files {
        let fail = |e: String| {
            Fatal::io(format!(
                "{}: not a readable ROS 2 bag in SQLite: {e}",
                path.display()
            ))
        };
        let db = open(path).map_err(fail)?;
        let mut query = db
            .prepare(
                "SELECT t.name, t.type, COUNT(m.id) FROM topics t \
                 JOIN messages m ON m.topic_id = t.id GROUP BY t.id",
            )
            .map_err(|e| fail(e.to_string()))?;
        let rows = query
            .query_map([], |r| {
                Ok((
                    r.get::<_, String>(0)?,
                    r.get::<_, String>(1)?,
                    r.get::<_, i64>(2)?,
                ))
            })
            .map_err(|e| fail(e.to_string()))?;
        for row in rows {
            let (name, schema, count) = row.map_err(|e| fail(e.to_string()))?;
            let info = topics.entry(name).or_default();
            info.schema = schema;
            info.count += usize::try_from(count).unwrap_or(0);
        }
    }
    Ok(topics)
}

/// One row of `messages`: its topic's name, the receive time (ns) and the
/// payload.
struct Row {
    topic: String,
    time_ns: i64,
    data: Vec<u8>,
}

/// A row of a file's `topics` table.
struct Topic {
    id: i64,
    name: String,
    schema: String,
    format: String,
}

/// Streams the scans of `topic` and the odometry of `odom_topic` (if any).
pub struct BagReader {
    /// The bag as the user named it (for the errors).
    name: String,
    files: VecDeque<PathBuf>,
    /// The file being read, and its topics.
    db: Option<(Connection, Vec<Topic>)>,
    /// Where the last page ended: (timestamp, row id).
    after: (i64, i64),
    page: VecDeque<Row>,
    topic: String,
    odom_topic: Option<String>,
    count: usize,
    checked: bool,
    failed: bool,
}

impl BagReader {
    /// A reader of `topic` (LaserScan) and `odom_topic` (Odometry) in `files`
    /// of the bag `name`.
    pub fn new(files: Vec<PathBuf>, name: &str, topic: &str, odom_topic: Option<&str>) -> Self {
        Self {
            name: name.into(),
            files: files.into(),
            db: None,
            after: (i64::MIN, i64::MIN),
            page: VecDeque::new(),
            topic: topic.into(),
            odom_topic: odom_topic.map(Into::into),
            count: 0,
            checked: false,
            failed: false,
        }
    }

    /// Opens the next file; `Ok(false)` when none is left.
    fn next_file(&mut self) -> Result<bool, String> {
        self.db = None;
        let Some(path) = self.files.pop_front() else {
            return Ok(false);
        };
        let name = path.display().to_string();
        let db = open(&path).map_err(|e| format!("{name}: {e}"))?;
        let topics = {
            let mut query = db
                .prepare("SELECT id, name, type, serialization_format FROM topics")
                .map_err(|e| format!("{name}: {e}"))?;
            let rows = query
                .query_map([], |r| {
                    Ok(Topic {
                        id: r.get(0)?,
                        name: r.get(1)?,
                        schema: r.get(2)?,
                        format: r.get(3)?,
                    })
                })
                .map_err(|e| format!("{name}: {e}"))?;
            rows.collect::<Result<Vec<_>, _>>()
                .map_err(|e| format!("{name}: {e}"))?
        };
        self.db = Some((db, topics));
        self.after = (i64::MIN, i64::MIN);
        Ok(true)
    }

    /// Reads the next page of the current file's rows on the two topics.
    fn next_page(&mut self) -> Result<(), String> {
        let Some((db, topics)) = &self.db else {
            return Ok(());
        };
        let wanted: Vec<i64> = topics
            .iter()
            .filter(|t| t.name == self.topic || self.odom_topic.as_deref() == Some(&t.name))
            .map(|t| t.id)
            .collect();
        let (Some(&scan), odom) = (wanted.first(), wanted.get(1).copied()) else {
            return Ok(());
        };
        let mut query = db
            .prepare_cached(
                "SELECT id, topic_id, timestamp, data FROM messages \
                 WHERE topic_id IN (?1, ?2) AND (timestamp > ?3 OR (timestamp = ?3 AND id > ?4)) \
                 ORDER BY timestamp, id LIMIT ?5",
            )
            .map_err(|e| e.to_string())?;
        let rows = query
            .query_map(
                rusqlite::params![scan, odom.unwrap_or(scan), self.after.0, self.after.1, PAGE],
                |r| {
                    Ok((
                        r.get::<_, i64>(0)?,
                        r.get::<_, i64>(1)?,
                        r.get::<_, i64>(2)?,
                        r.get::<_, Vec<u8>>(3)?,
                    ))
                },
            )
            .map_err(|e| e.to_string())?;
        for row in rows {
            let (id, topic_id, time_ns, data) = row.map_err(|e| e.to_string())?;
            self.after = (time_ns, id);
            let topic = topics
                .iter()
                .find(|t| t.id == topic_id)
                .map_or_else(String::new, |t| t.name.clone());
            self.page.push_back(Row {
                topic,
                time_ns,
                data,
            });
        }
        Ok(())
    }

    /// The next row of the bag, across its files.
    fn next_row(&mut self) -> Result<Option<Row>, String> {
        loop {
            if let Some(row) = self.page.pop_front() {
                return Ok(Some(row));
            }
            if self.db.is_some() {
                self.next_page()?;
                if !self.page.is_empty() {
                    continue;
                }
            }
            if !self.next_file()? {
                return Ok(None);
            }
        }
    }

    /// The type and serialization format of `topic` in the current file.
    fn type_of(&self, topic: &str) -> (String, String) {
        self.db
            .as_ref()
            .and_then(|(_, t)| t.iter().find(|t| t.name == topic))
            .map_or_else(Default::default, |t| (t.schema.clone(), t.format.clone()))
    }
}

impl Iterator for BagReader {
    type Item = BagItem;

    fn next(&mut self) -> Option<BagItem> {
        loop {
            if self.failed {
                return None;
            }
            let row = match self.next_row() {
                Ok(row) => row?,
                Err(e) => {
                    self.failed = true;
                    let error = RecordError::new(
                        format!("after message {}", self.count),
                        format!("unreadable ROS 2 bag in SQLite (truncated or corrupt file?): {e}"),
                    );
                    return Some(Ok(Err(error)));
                }
            };
            self.count += 1;
            let record = format!("message {}", self.count);
            let topic = row.topic.as_str();
            let is_scan = topic == self.topic;
            let expected = if is_scan { LASER_SCAN } else { ODOMETRY };
            let (schema, format) = self.type_of(topic);
            let known = if is_scan {
                schema == LASER_SCAN
            } else {
                crate::tf::is_odometry(&schema)
            };
            if !known || format != "cdr" {
                let fatal = Fatal::io(format!(
                    "{}: {record} on topic {topic} is {schema} ({format} encoding); expected \
                     {expected} (cdr encoding)",
                    self.name
                ));
                if is_scan && !self.checked {
                    self.failed = true;
                    return Some(Err(fatal));
                }
                return Some(Ok(Err(RecordError::new(record, fatal.to_string()))));
            }
            let time = row.time_ns as f64 * 1e-9;
            let named = format!("{record} (topic {topic})");
            if is_scan {
                self.checked = true;
                return Some(scan_item(decode_scan(&row.data), time, named));
            }
            // A transform message without the odometry's transform: the next.
            if let Some(item) = crate::tf::odometry_message(&schema, &row.data, time, named) {
                return Some(item);
            }
        }
    }
}
