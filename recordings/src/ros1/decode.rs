//! The payloads of a ROS 1 bag's messages: `sensor_msgs/LaserScan`,
//! `sensor_msgs/MultiEchoLaserScan` (each beam's first echo),
//! `nav_msgs/Odometry` and `tf2_msgs/TFMessage` (its odometry transform,
//! [`crate::tf`]), in the ROS 1 serialization (little-endian; strings
//! and arrays a u32 length, then the items), decoded by hand with every
//! length checked against the message.

use crate::model::{Pose, Scan};
use crate::ros2::{odometry_pose, scan_of, LaserFields};
use crate::tf::{transforms_odometry, TransformFields};

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

    fn string(&mut self) -> Result<&'a [u8], String> {
        let len = self.u32()? as usize;
        self.take(len)
            .map_err(|_| format!("a string of {len} bytes does not fit in the message"))
    }

    /// `std_msgs/Header` up to its `frame_id`: its stamp, seconds.
    fn stamp(&mut self) -> Result<f64, String> {
        let _seq = self.u32()?;
        let secs = self.u32()?;
        let nsecs = self.u32()?;
        Ok(f64::from(secs) + f64::from(nsecs) * 1e-9)
    }

    /// `std_msgs/Header`: its stamp, seconds.
    fn header(&mut self) -> Result<f64, String> {
        let stamp = self.stamp()?;
        self.string()?;
        Ok(stamp)
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

impl<'a> TransformFields<'a> for Payload<'a> {
    fn left(&self) -> usize {
        self.data.len()
    }

    fn u32(&mut self) -> Result<u32, String> {
        Payload::u32(self)
    }

    fn f64(&mut self) -> Result<f64, String> {
        Payload::f64(self)
    }

    fn stamp(&mut self) -> Result<f64, String> {
        Payload::stamp(self)
    }

    fn string(&mut self) -> Result<&'a [u8], String> {
        Payload::string(self)
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

pub(super) fn decode_scan(data: &[u8]) -> Result<(Scan, f64), String> {
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
pub(super) fn decode_multi_echo(data: &[u8]) -> Result<(Scan, f64), String> {
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

pub(super) fn decode_odometry(data: &[u8]) -> Result<(Pose, f64), String> {
    let mut p = Payload { data };
    let time = p.header()?;
    p.string()?; // child_frame_id
    let (x, y, _z) = (p.f64()?, p.f64()?, p.f64()?);
    let q = [p.f64()?, p.f64()?, p.f64()?, p.f64()?];
    Ok((odometry_pose((x, y), q)?, time))
}

/// The odometry pose and stamp of a `tf2_msgs/TFMessage` (or
/// `tf/tfMessage`), `None` when it holds no `odom` → robot transform.
pub(super) fn decode_tf_odometry(data: &[u8]) -> Result<Option<(Pose, f64)>, String> {
    transforms_odometry(&mut Payload { data })
}
