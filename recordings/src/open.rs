//! [`open_recording`]: a recording opened as the tool's `log` reads it, its
//! format by option or by content, a bag's topics chosen, the events of the
//! format's reader.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{self, BufRead, BufReader};
use std::path::{Path, PathBuf};

use clap::ValueEnum;
use indicatif::ProgressBar;

use crate::carmen::{CarmenReader, FlaserGeometry};
use crate::error::Fatal;
use crate::model::Event;
use crate::wire::Protocol;
use crate::{bagdir, capture_file, db3, ros1, ros2};

/// The format of a recording.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// By content: a directory is a ROS 2 bag, SQLite, MCAP and ROS 1 bags
    /// are known by their first bytes, a binary or hex-text file is refused
    /// with the capture `--format` its bytes look like, and anything else
    /// is read as CARMEN.
    Auto,
    /// CARMEN log (`FLASER`, `ROBOTLASER1`, `ODOM` lines), plain or gzip.
    Carmen,
    /// ROS 2 bag in MCAP: its `.mcap` file, or its directory
    /// (`metadata.yaml` and `.mcap` files, read in the order it lists them).
    Mcap,
    /// ROS 1 bag (format 2.0; chunks uncompressed, bz2 or lz4).
    Ros1,
    /// ROS 2 bag in SQLite: its directory (`metadata.yaml` and `.db3`
    /// files, read in the order it lists them) or one `.db3` file.
    Db3,
    /// Raw LDRobot LD06 / LD19 / STL-19P capture: one scan per revolution.
    /// Each raw capture format reads the bytes as stored or hex text
    /// ([`crate::capture_file`]).
    Ld06,
    /// Raw Slamtec RPLIDAR capture (standard scan): one scan per revolution.
    Rplidar,
    /// Raw YDLIDAR X2 / X4 capture: one scan per revolution.
    Ydlidar,
    /// Raw Neato XV-11 / LDS02RR capture: one scan per revolution.
    Xv11,
}

/// What [`open_recording`] opens: the file and the options of reading it
/// (the tool's `log FILE --format … --topic …`).
#[derive(Clone, Debug)]
pub struct Source {
    /// The recording: a CARMEN log (`.gz` read directly), a ROS 2 bag (its
    /// directory, or its `.mcap` or `.db3` file), a ROS 1 bag (`.bag`), or a
    /// raw lidar capture.
    pub file: PathBuf,
    /// Its format ([`Format::Auto`]: by content).
    pub format: Format,
    /// Bags: the `LaserScan` topic (without it, the bag's only one).
    pub topic: Option<String>,
    /// Bags: the `Odometry` topic (default `/odom` when the bag has it, else
    /// the bag's `/tf`: its `odom` → `base_link` transform).
    pub odom_topic: Option<String>,
    /// CARMEN `FLASER`: "no return" at or beyond this, metres.
    pub max_range: f32,
    /// CARMEN `FLASER` and LaserScan: the laser pose `[x, y, θ]` (metres,
    /// radians) in the robot frame (`ROBOTLASER1` carries its own).
    pub laser_offset: Option<[f32; 3]>,
}

/// Opens the file, undoing gzip (by its magic bytes), with the progress bar
/// counting the file's bytes.
pub fn open(path: &Path, bar: &ProgressBar) -> Result<Box<dyn BufRead>, Fatal> {
    let name = path.display();
    let file = File::open(path).map_err(|e| Fatal::io(format!("{name}: cannot read: {e}")))?;
    if let Ok(meta) = file.metadata() {
        bar.set_length(meta.len());
    }
    let mut raw = BufReader::new(bar.wrap_read(file));
    let gzip = raw
        .fill_buf()
        .map_err(|e| Fatal::io(format!("{name}: cannot read: {e}")))?
        .starts_with(&[0x1f, 0x8b]);
    Ok(if gzip {
        Box::new(BufReader::new(flate2::bufread::MultiGzDecoder::new(raw)))
    } else {
        Box::new(raw)
    })
}

/// The MCAP magic bytes.
pub const MCAP_MAGIC: &[u8] = b"\x89MCAP0\r\n";

/// A recording opened for reading: a raw lidar capture (read by
/// [`crate::wire::WireReader`]), or a log or bag as [`Event`]s.
pub enum Opened {
    /// A CARMEN log or a bag.
    Recording(Recording),
    /// A raw lidar capture: its protocol and bytes.
    Capture(Protocol, Box<dyn BufRead>),
}

/// A CARMEN log or a bag, opened: its format, a bag's scan topic, and its
/// events (scans carry `--laser-offset`).
pub struct Recording {
    /// The format read (never [`Format::Auto`]).
    pub format: Format,
    /// The scan topic of a bag.
    pub topic: Option<String>,
    /// The events in file order.
    pub events: Box<dyn Iterator<Item = ros2::BagItem>>,
}

/// Opens `source.file` as `log` reads it: the format by `--format` or by
/// content, a bag's topics chosen ([`choose_topics`]), `bar` counting the
/// bytes read.
///
/// # Errors
/// A [`Fatal`] error when the file cannot be read, a bag directory is
/// unusable or contradicts `--format`, or a bag's topics are unusable.
pub fn open_recording(source: &Source, bar: &ProgressBar) -> Result<Opened, Fatal> {
    let file = source.file.display().to_string();
    let laser_offset = source.laser_offset;
    // A directory is a ROS 2 bag (`metadata.yaml` and `.db3` or `.mcap` files).
    let directory = source
        .file
        .is_dir()
        .then(|| bagdir::files(&source.file))
        .transpose()?;
    let mut input: Box<dyn BufRead> = if directory.is_some() {
        Box::new(io::empty())
    } else {
        open(&source.file, bar)?
    };
    let head = input
        .fill_buf()
        .map_err(|e| Fatal::io(format!("{file}: cannot read: {e}")))?;
    let format = match (source.format, &directory) {
        (Format::Auto, Some((bagdir::Storage::Sqlite, _))) => Format::Db3,
        (Format::Auto, Some((bagdir::Storage::Mcap, _))) => Format::Mcap,
        (Format::Auto, None) if head.starts_with(db3::MAGIC) => Format::Db3,
        (Format::Auto, None) if head.starts_with(MCAP_MAGIC) => Format::Mcap,
        (Format::Auto, None) if head.starts_with(ros1::MAGIC) => Format::Ros1,
        (Format::Auto, None) => match capture_file::unread_capture(&file, head) {
            Some(message) => return Err(Fatal::usage(message)),
            None => Format::Carmen,
        },
        (f, _) => f,
    };
    let from_directory = directory.is_some();
    let files = match directory {
        Some((storage, files)) => {
            let expected = match storage {
                bagdir::Storage::Sqlite => Format::Db3,
                bagdir::Storage::Mcap => Format::Mcap,
            };
            if format != expected {
                return Err(Fatal::usage(format!(
                    "{file}: a ROS 2 bag directory in {storage:?} storage, not {format:?}"
                )));
            }
            files
        }
        None => vec![source.file.clone()],
    };
    let (events, topic): (Box<dyn Iterator<Item = ros2::BagItem>>, _) = match format {
        Format::Ld06 | Format::Rplidar | Format::Ydlidar | Format::Xv11 => {
            let protocol = match format {
                Format::Ld06 => Protocol::Ld06,
                Format::Rplidar => Protocol::Rplidar,
                Format::Ydlidar => Protocol::Ydlidar,
                _ => Protocol::Xv11,
            };
            let bytes = capture_file::capture_bytes(input, &file, protocol)?;
            return Ok(Opened::Capture(protocol, bytes));
        }
        Format::Db3 => {
            let topics = db3::topics(&files)?;
            let (topic, odom) = choose_topics(source, &file, &topics, BagTypes::ROS2)?;
            let reader = db3::BagReader::new(files, &file, &topic, odom.as_deref());
            (Box::new(reader), Some(topic))
        }
        Format::Ros1 => {
            let contents = ros1::contents(input, &file)?;
            let (topic, odom) = choose_topics(source, &file, &contents.topics, BagTypes::ROS1)?;
            // The topics took one pass; the messages take another.
            bar.reset();
            let input = open(&source.file, bar)?;
            let reader =
                ros1::BagReader::new(input, &file, &topic, odom.as_deref()).knowing(&contents);
            (Box::new(reader), Some(topic))
        }
        Format::Mcap => {
            // One file, or the files of a bag directory in order.
            let topics = if from_directory {
                let mut all: BTreeMap<String, ros2::TopicInfo> = BTreeMap::new();
                for path in &files {
                    let name = path.display().to_string();
                    for (t, info) in ros2::topics(open(path, bar)?, &name)? {
                        let merged = all.entry(t).or_default();
                        merged.schema = info.schema;
                        merged.count += info.count;
                    }
                }
                all
            } else {
                ros2::topics(input, &file)?
            };
            let (topic, odom) = choose_topics(source, &file, &topics, BagTypes::ROS2)?;
            (mcap_events(files, bar, topic.clone(), odom), Some(topic))
        }
        Format::Carmen | Format::Auto => {
            let geometry = FlaserGeometry {
                max_range: source.max_range,
                laser_offset: laser_offset.unwrap_or([0.0; 3]),
            };
            let events = CarmenReader::new(input, geometry).map(Ok);
            return Ok(Opened::Recording(Recording {
                format,
                topic: None,
                events: Box::new(events),
            }));
        }
    };
    let events = events.map(move |item| {
        item.map(|event| {
            event.map(|e| match (e, laser_offset) {
                (Event::Scan(mut s), Some(o)) => {
                    s.record.laser_offset = o;
                    Event::Scan(s)
                }
                (e, _) => e,
            })
        })
    });
    Ok(Opened::Recording(Recording {
        format,
        topic,
        events: Box::new(events),
    }))
}

/// The events of MCAP `files` read in order (a split bag's records named
/// with their file).
fn mcap_events(
    files: Vec<PathBuf>,
    bar: &ProgressBar,
    topic: String,
    odom: Option<String>,
) -> Box<dyn Iterator<Item = ros2::BagItem>> {
    let bar = bar.clone();
    let split = files.len() > 1;
    Box::new(files.into_iter().flat_map(move |path| {
        bar.reset();
        let name = path.display().to_string();
        let part = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .filter(|_| split);
        let reader: Box<dyn Iterator<Item = ros2::BagItem>> = match open(&path, &bar) {
            Ok(input) => Box::new(ros2::BagReader::new(input, &name, &topic, odom.as_deref())),
            Err(e) => Box::new(std::iter::once(Err(e))),
        };
        reader.map(move |item| match &part {
            Some(part) => item.map(|r| {
                r.map(|e| e.in_file(part)).map_err(|mut e| {
                    e.record = format!("{part}: {}", e.record);
                    e
                })
            }),
            None => item,
        })
    }))
}

/// The message types a bag names its scans and odometry by.
#[derive(Clone, Copy, Debug)]
pub struct BagTypes {
    /// The laser scans' types (the first is the one found without `--topic`).
    pub scan: &'static [&'static str],
    /// The odometry's type.
    pub odometry: &'static str,
    /// The transforms' types, read as odometry when the bag has no `/odom`
    /// ([`crate::tf`]).
    pub transforms: &'static [&'static str],
}

impl BagTypes {
    /// ROS 2 (MCAP).
    pub const ROS2: Self = Self {
        scan: &[ros2::LASER_SCAN],
        odometry: ros2::ODOMETRY,
        transforms: &[crate::tf::TF_MESSAGE],
    };
    /// ROS 1.
    pub const ROS1: Self = Self {
        scan: &[ros1::LASER_SCAN, ros1::MULTI_ECHO_SCAN],
        odometry: ros1::ODOMETRY,
        transforms: &ros1::TRANSFORMS,
    };
}

/// The scan topic (`--topic`, or the bag's only scan topic) and the
/// odometry topic (`--odom-topic`, or `/odom` when it carries odometry, else
/// `/tf` when it carries transforms) of a bag whose `topics` were listed.
///
/// # Errors
/// A usage error listing the bag's topics when the scan topic is missing,
/// ambiguous or unknown, or the odometry topic unknown or of another type.
pub fn choose_topics(
    args: &Source,
    file: &str,
    topics: &BTreeMap<String, ros2::TopicInfo>,
    types: BagTypes,
) -> Result<(String, Option<String>), Fatal> {
    let topic = match &args.topic {
        Some(t) if topics.contains_key(t) => t.clone(),
        None => match types
            .scan
            .iter()
            .find_map(|&schema| ros2::only_topic_of(topics, schema).map(|t| (t, schema)))
        {
            Some((t, schema)) => {
                eprintln!("hough-heading: {file}: using {t}, the bag's only {schema} topic");
                t
            }
            None => return Err(ros2::topic_error(file, None, topics)),
        },
        other => return Err(ros2::topic_error(file, other.as_deref(), topics)),
    };
    // A scan topic of another type fails at its first message (named).
    let odom = match &args.odom_topic {
        Some(t) => match topics.get(t) {
            Some(i) if i.schema == types.odometry || types.transforms.contains(&&*i.schema) => {
                Some(t.clone())
            }
            Some(i) => {
                return Err(Fatal::usage(format!(
                    "{file}: topic {t} carries {}, not {}",
                    i.schema, types.odometry
                )))
            }
            None => return Err(ros2::topic_error(file, Some(t), topics)),
        },
        None => {
            let odom = topics
                .iter()
                .find(|(t, i)| t.as_str() == "/odom" && i.schema == types.odometry);
            let tf = topics
                .iter()
                .find(|(t, i)| t.as_str() == "/tf" && types.transforms.contains(&&*i.schema));
            if let (None, Some((t, _))) = (odom, tf) {
                eprintln!("hough-heading: {file}: odometry from {t} (odom → base_link), the bag has no /odom");
            }
            odom.or(tf).map(|(t, _)| t.clone())
        }
    };
    Ok((topic, odom))
}

/// A deterministic spread of values for the readers' damage tests
/// (xorshift64 from `seed`, not zero).
#[cfg(test)]
pub(crate) fn xorshift(seed: u64) -> impl FnMut() -> u64 {
    let mut state = seed;
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    }
}

/// `data` with `bytes` of its bytes set to values of `next`, at places of
/// `next` (for the readers' damage tests).
#[cfg(test)]
pub(crate) fn damaged(data: &[u8], bytes: usize, next: &mut impl FnMut() -> u64) -> Vec<u8> {
    let mut d = data.to_vec();
    for _ in 0..bytes {
        let at = (next() % d.len().max(1) as u64) as usize;
        if let Some(b) = d.get_mut(at) {
            *b = (next() & 0xff) as u8;
        }
    }
    d
}
