//! `/tf` as odometry, for bags without an `Odometry` topic: a
//! `TFMessage`'s transform from `odom` to `base_link` (or `base_footprint`;
//! frame names without a leading `/`) is the robot's odometry pose, stamped
//! by its header. A message without that transform (the other transforms of
//! the tree) is no odometry and is passed over.
//!
//! [`transforms_odometry`] walks a message by its serialization's
//! [`TransformFields`]: ROS 2's CDR here (the `cdr` crate allocates a
//! declared length before reading it), ROS 1's in [`crate::ros1`]. Every
//! count and string length is checked against the message before it is
//! used.

use crate::model::Pose;
use crate::ros2::{decode_odometry, odometry_item, odometry_pose, BagItem, ODOMETRY};

/// The schema name of a ROS 2 transform message.
pub const TF_MESSAGE: &str = "tf2_msgs/msg/TFMessage";
/// The odometry frame, and the robot's frames it may move.
const PARENT: &str = "odom";
const CHILDREN: [&str; 2] = ["base_link", "base_footprint"];
/// The fewest bytes a transform takes (stamp, two string lengths, seven
/// `f64`; a ROS 1 header's `seq` is 4 more).
const MIN_TRANSFORM: usize = 72;

/// The fields of a `TFMessage` in one serialization.
pub(crate) trait TransformFields<'a> {
    /// The bytes left in the message.
    fn left(&self) -> usize;
    /// A `uint32`.
    fn u32(&mut self) -> Result<u32, String>;
    /// A `float64`.
    fn f64(&mut self) -> Result<f64, String>;
    /// A header up to its `frame_id`: its stamp, seconds.
    fn stamp(&mut self) -> Result<f64, String>;
    /// A string, without a NUL terminator.
    fn string(&mut self) -> Result<&'a [u8], String>;
}

/// Whether a transform from `parent` to `child` (frame names, a leading
/// `/` ignored) moves the robot in the odometry frame.
fn is_odometry_transform(parent: &[u8], child: &[u8]) -> bool {
    fn frame(name: &[u8]) -> &[u8] {
        name.strip_prefix(b"/").unwrap_or(name)
    }
    frame(parent) == PARENT.as_bytes() && CHILDREN.iter().any(|c| c.as_bytes() == frame(child))
}

/// The odometry pose and stamp (s) of a `TFMessage` read by `m`, `None`
/// when it holds no `odom` → robot transform (the last one when it holds
/// several).
///
/// # Errors
/// A message that is not a whole `TFMessage`, or a non-finite odometry
/// pose.
pub(crate) fn transforms_odometry<'a>(
    m: &mut impl TransformFields<'a>,
) -> Result<Option<(Pose, f64)>, String> {
    let count = m.u32()? as usize;
    if count.saturating_mul(MIN_TRANSFORM) > m.left() {
        return Err(format!("{count} transforms do not fit in the message"));
    }
    let mut found = None;
    for _ in 0..count {
        let stamp = m.stamp()?;
        let parent = m.string()?;
        let child = m.string()?;
        let mut v = [0.0; 7];
        for x in &mut v {
            *x = m.f64()?;
        }
        if is_odometry_transform(parent, child) {
            let pose = odometry_pose((v[0], v[1]), [v[3], v[4], v[5], v[6]])?;
            found = Some((pose, stamp));
        }
    }
    Ok(found)
}

/// A CDR message being read: offsets relative to the body (after the
/// 4-byte encapsulation header), values aligned to their size.
struct Cdr<'a> {
    body: &'a [u8],
    at: usize,
    little: bool,
}

impl<'a> Cdr<'a> {
    fn take(&mut self, n: usize, align: usize) -> Result<&'a [u8], String> {
        let at = self.at.next_multiple_of(align);
        let bytes = at
            .checked_add(n)
            .and_then(|end| self.body.get(at..end))
            .ok_or("truncated message")?;
        self.at = at + n;
        Ok(bytes)
    }
}

impl<'a> TransformFields<'a> for Cdr<'a> {
    fn left(&self) -> usize {
        self.body.len().saturating_sub(self.at)
    }

    fn u32(&mut self) -> Result<u32, String> {
        let b: [u8; 4] = self.take(4, 4)?.try_into().map_err(|_| "truncated")?;
        Ok(if self.little {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        })
    }

    fn f64(&mut self) -> Result<f64, String> {
        let b: [u8; 8] = self.take(8, 8)?.try_into().map_err(|_| "truncated")?;
        Ok(if self.little {
            f64::from_le_bytes(b)
        } else {
            f64::from_be_bytes(b)
        })
    }

    /// `builtin_interfaces/Time`: `int32` seconds, `uint32` nanoseconds.
    fn stamp(&mut self) -> Result<f64, String> {
        let sec = self.u32()? as i32;
        let nanosec = self.u32()?;
        Ok(f64::from(sec) + f64::from(nanosec) * 1e-9)
    }

    fn string(&mut self) -> Result<&'a [u8], String> {
        let len = self.u32()? as usize;
        let bytes = self
            .take(len, 1)
            .map_err(|_| format!("a string of {len} bytes does not fit in the message"))?;
        Ok(bytes.strip_suffix(&[0]).unwrap_or(bytes))
    }
}

/// The odometry pose and stamp (s) of a ROS 2 `TFMessage` (CDR), `None`
/// when it holds no `odom` → robot transform ([`transforms_odometry`]).
///
/// # Errors
/// A message that is not a whole `TFMessage` in CDR.
pub fn decode_tf_odometry(data: &[u8]) -> Result<Option<(Pose, f64)>, String> {
    let body = data.get(4..).ok_or("shorter than the CDR header")?;
    transforms_odometry(&mut Cdr {
        body,
        at: 0,
        little: data.get(1).is_some_and(|b| b & 1 == 1),
    })
}

/// Whether `schema` is an odometry the ROS 2 readers read: `Odometry` or
/// `TFMessage`.
pub fn is_odometry(schema: &str) -> bool {
    schema == ODOMETRY || schema == TF_MESSAGE
}

/// The item of an odometry message of `schema` ([`is_odometry`]) `named`
/// (its record) at bag time `time`; `None` for a `TFMessage` without the
/// odometry's transform.
pub(crate) fn odometry_message(
    schema: &str,
    data: &[u8],
    time: f64,
    named: String,
) -> Option<BagItem> {
    if schema == TF_MESSAGE {
        return decode_tf_odometry(data)
            .transpose()
            .map(|decoded| odometry_item(decoded, time, named));
    }
    Some(odometry_item(decode_odometry(data), time, named))
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::model::Event;
    use crate::open::{open_recording, Format, Opened, Source};

    /// A `TFMessage` in little-endian CDR: `(parent, child, x, y, yaw)`
    /// transforms stamped `stamp` (s).
    fn tf_message(stamp: f64, transforms: &[(&str, &str, f64, f64, f64)]) -> Vec<u8> {
        let sec = stamp.floor() as u32;
        let nanosec = ((stamp - stamp.floor()) * 1e9).round() as u32;
        let mut body: Vec<u8> = (transforms.len() as u32).to_le_bytes().to_vec();
        let align = |b: &mut Vec<u8>, n: usize| b.resize(b.len().next_multiple_of(n), 0);
        for &(parent, child, x, y, yaw) in transforms {
            align(&mut body, 4);
            body.extend(sec.to_le_bytes());
            body.extend(nanosec.to_le_bytes());
            for frame in [parent, child] {
                align(&mut body, 4);
                body.extend((frame.len() as u32 + 1).to_le_bytes());
                body.extend(frame.as_bytes());
                body.push(0);
            }
            let (s, c) = (yaw / 2.0).sin_cos();
            for v in [x, y, 0.0, 0.0, 0.0, s, c] {
                align(&mut body, 8);
                body.extend(v.to_le_bytes());
            }
        }
        [vec![0, 1, 0, 0], body].concat()
    }

    #[test]
    fn the_odom_transform_is_the_odometry() {
        let m = tf_message(
            7.0,
            &[
                ("map", "odom", 9.0, 9.0, 1.0),
                ("/odom", "base_link", 1.5, -2.0, 0.5),
            ],
        );
        let (pose, t) = decode_tf_odometry(&m).unwrap().expect("a pose");
        assert_eq!(t, 7.0);
        assert!((pose.x - 1.5).abs() < 1e-12 && (pose.y + 2.0).abs() < 1e-12);
        assert!((pose.theta - 0.5).abs() < 1e-12);
        let other = tf_message(7.0, &[("base_link", "laser", 0.1, 0.0, 0.0)]);
        assert_eq!(decode_tf_odometry(&other).unwrap(), None);
        // Cut anywhere, an error, never a panic or a pose.
        for cut in 0..m.len() {
            assert!(decode_tf_odometry(&m[..cut]).is_err(), "cut at {cut}");
        }
    }

    /// The odometry events of the recording `file` (its `/scan` scans).
    fn odometry(file: &Path) -> Vec<(f64, Pose)> {
        let source = Source {
            file: file.to_path_buf(),
            format: Format::Auto,
            topic: Some("/scan".into()),
            odom_topic: None,
            max_range: 50.0,
            laser_offset: None,
        };
        let hidden = indicatif::ProgressBar::hidden();
        let Ok(Opened::Recording(r)) = open_recording(&source, &hidden) else {
            panic!("{}: a recording", file.display())
        };
        r.events
            .filter_map(|e| match e.expect("not fatal").expect("no failed record") {
                Event::Odometry(o) => Some((o.time.expect("a time"), o.pose)),
                Event::Scan(_) => None,
            })
            .collect()
    }

    /// The bundled SQLite bag with its `/odom` turned into `/tf` (each
    /// odometry message the `odom` → `base_link` transform, beside another
    /// transform; one more message with no odometry transform) gives the
    /// same odometry.
    #[test]
    fn a_ros2_bag_without_odom_takes_its_odometry_from_tf() {
        let logs = Path::new(env!("CARGO_MANIFEST_DIR")).join("../cli/data/logs");
        let original = odometry(&logs.join("seattle-bag-db3"));
        assert_eq!(original.len(), 12);
        let dir = std::env::temp_dir().join(format!("hough-heading-tf-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let copy = dir.join("tf.db3");
        std::fs::copy(logs.join("seattle-bag-db3/seattle-bag-db3.db3"), &copy).unwrap();
        {
            let db = rusqlite::Connection::open(&copy).unwrap();
            let ids: Vec<i64> = db
                .prepare(
                    "SELECT m.id FROM messages m JOIN topics t ON m.topic_id = t.id \
                     WHERE t.name = '/odom' ORDER BY m.timestamp, m.id",
                )
                .unwrap()
                .query_map([], |r| r.get(0))
                .unwrap()
                .collect::<Result<_, _>>()
                .unwrap();
            assert_eq!(ids.len(), original.len());
            for (id, (t, p)) in ids.iter().zip(&original) {
                let m = tf_message(
                    *t,
                    &[
                        ("base_link", "laser", 0.2, 0.0, 0.0),
                        ("odom", "base_link", p.x, p.y, p.theta),
                    ],
                );
                db.execute(
                    "UPDATE messages SET data = ?1 WHERE id = ?2",
                    rusqlite::params![m, id],
                )
                .unwrap();
            }
            db.execute(
                "INSERT INTO messages (topic_id, timestamp, data) \
                 SELECT topic_id, timestamp + 1, ?1 FROM messages WHERE id = ?2",
                rusqlite::params![tf_message(1.0, &[("map", "odom", 1.0, 2.0, 3.0)]), ids[3]],
            )
            .unwrap();
            db.execute(
                "UPDATE topics SET name = '/tf', type = ?1 WHERE name = '/odom'",
                [TF_MESSAGE],
            )
            .unwrap();
        }
        let from_tf = odometry(&copy);
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(from_tf.len(), original.len());
        for ((ta, a), (tb, b)) in original.iter().zip(&from_tf) {
            assert!((ta - tb).abs() < 1e-6, "{ta} {tb}");
            assert!((a.x - b.x).abs() < 1e-12 && (a.y - b.y).abs() < 1e-12);
            assert!(crate::model::wrap_rad(a.theta - b.theta).abs() < 1e-12);
        }
    }
}
