//! What every reader yields: [`Event`]s, each a [`Scan`] or an
//! [`Odometry`] pose, with [`Pose`] the planar pose of both.

use crate::pairs::{wrap_deg, ScanRecord};

/// A planar pose: metres and radians.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// x, metres.
    pub x: f64,
    /// y, metres.
    pub y: f64,
    /// Heading, radians.
    pub theta: f64,
}

impl Pose {
    /// The origin.
    pub const ZERO: Pose = Pose {
        x: 0.0,
        y: 0.0,
        theta: 0.0,
    };

    /// `other` in the frame of `self` (the pair files' `dx, dy, dθ`).
    pub fn between(&self, other: &Pose) -> Pose {
        let (s, c) = self.theta.sin_cos();
        let (ex, ey) = (other.x - self.x, other.y - self.y);
        Pose {
            x: c * ex + s * ey,
            y: -s * ex + c * ey,
            theta: wrap_rad(other.theta - self.theta),
        }
    }

    /// `self ⊕ delta`: the pose `delta` (in the frame of `self`) in the world.
    pub fn compose(&self, delta: &Pose) -> Pose {
        let (s, c) = self.theta.sin_cos();
        Pose {
            x: self.x + c * delta.x - s * delta.y,
            y: self.y + s * delta.x + c * delta.y,
            theta: wrap_rad(self.theta + delta.theta),
        }
    }
}

/// Wraps radians to (−π, π].
pub fn wrap_rad(a: f64) -> f64 {
    wrap_deg(a.to_degrees()).to_radians()
}

/// One scan of a recording.
#[derive(Clone, Debug)]
pub struct Scan {
    /// The scan, as a pair file stores it.
    pub record: ScanRecord,
    /// Time stamp, seconds.
    pub time: Option<f64>,
    /// The odometry pose at the scan.
    pub odom: Option<Pose>,
    /// The log's own pose of the robot (`FLASER` x y θ: corrected in a
    /// Radish `-corrected` log; a simulator's `TRUEPOS`).
    pub log_pose: Option<Pose>,
    /// Where it is in the file (`line 12`, `message 3 (topic /scan)`).
    pub name: String,
}

impl Scan {
    /// Beams without a reading in the file (a non-finite range, or one
    /// below the sensor's `range_min`): neither a return nor "no return".
    pub fn missing_readings(&self) -> usize {
        self.record.ranges.iter().filter(|r| r.is_none()).count()
    }
}

/// An odometry pose of a recording.
#[derive(Clone, Copy, Debug)]
pub struct Odometry {
    /// Time stamp, seconds.
    pub time: Option<f64>,
    /// The pose.
    pub pose: Pose,
}

/// What a reader yields.
#[derive(Clone, Debug)]
pub enum Event {
    /// A laser scan.
    Scan(Scan),
    /// An odometry pose.
    Odometry(Odometry),
}

impl Event {
    /// The event with its record named `name`.
    pub(crate) fn with_record(self, name: String) -> Self {
        match self {
            Event::Scan(mut s) => {
                s.name = name;
                Event::Scan(s)
            }
            other => other,
        }
    }

    /// The event with its record named in `file` (a split bag's part).
    pub(crate) fn in_file(self, file: &str) -> Self {
        match self {
            Event::Scan(mut s) => {
                s.name = format!("{file}: {}", s.name);
                Event::Scan(s)
            }
            other => other,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn between_and_compose_are_inverse() {
        let a = Pose {
            x: 1.0,
            y: -2.0,
            theta: 2.5,
        };
        let b = Pose {
            x: -0.5,
            y: 0.7,
            theta: -2.9,
        };
        let d = a.between(&b);
        let c = a.compose(&d);
        assert!((c.x - b.x).abs() < 1e-12 && (c.y - b.y).abs() < 1e-12);
        assert!(wrap_rad(c.theta - b.theta).abs() < 1e-12);
        // Robot at the origin facing +y; a pose 1 m further along +y is 1 m
        // straight ahead.
        let facing = Pose {
            x: 0.0,
            y: 0.0,
            theta: std::f64::consts::FRAC_PI_2,
        };
        let ahead = facing.between(&Pose {
            x: 0.0,
            y: 1.0,
            theta: 0.0,
        });
        assert!((ahead.x - 1.0).abs() < 1e-12 && ahead.y.abs() < 1e-12);
    }
}
