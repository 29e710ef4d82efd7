//! [`RobotPose`]: a pose in the plane, composed with the library's sine
//! table.

use crate::angle::Angle;
use crate::motion::Motion;
use crate::scan::sine::sin_cos;

/// A robot pose in the plane: metres and a binary angle (x forward, y
/// left, heading counter-clockwise).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RobotPose {
    /// Forward, metres.
    pub x: f32,
    /// Left, metres.
    pub y: f32,
    /// Heading, counter-clockwise.
    pub heading: Angle,
}

impl RobotPose {
    /// The origin.
    pub const ZERO: RobotPose = RobotPose {
        x: 0.0,
        y: 0.0,
        heading: Angle::ZERO,
    };

    /// The pose `step` (in this pose's frame) leads to: `self ∘ step`.
    /// Rotation error below 3·10⁻⁵ of the step's length (the sine table).
    pub fn compose(&self, step: &RobotPose) -> RobotPose {
        let (s, c) = unit(self.heading);
        RobotPose {
            x: self.x + c * step.x - s * step.y,
            y: self.y + s * step.x + c * step.y,
            heading: Angle(self.heading.0.wrapping_add(step.heading.0)),
        }
    }

    /// `other` in this pose's frame: `self⁻¹ ∘ other`.
    pub fn between(&self, other: &RobotPose) -> RobotPose {
        let (s, c) = unit(self.heading);
        let (dx, dy) = (other.x - self.x, other.y - self.y);
        RobotPose {
            x: c * dx + s * dy,
            y: -s * dx + c * dy,
            heading: Angle(other.heading.0.wrapping_sub(self.heading.0)),
        }
    }

    /// A robot motion as a step; a missing translation counts as none.
    pub fn of_motion(motion: &Motion) -> RobotPose {
        let (x, y) = motion.translation.unwrap_or((0.0, 0.0));
        RobotPose {
            x,
            y,
            heading: Angle::from_degrees(motion.dtheta * (180.0 / core::f32::consts::PI)),
        }
    }

    /// This pose taken as a motion (`dθ` in radians in (−π, π], error below
    /// 10⁻⁶ rad).
    pub fn to_motion(&self) -> Motion {
        Motion {
            dtheta: self.heading.to_degrees() * (core::f32::consts::PI / 180.0),
            translation: Some((self.x, self.y)),
        }
    }

    /// This step taken `1/n` of the way in a straight line: the translation
    /// divided by `n`, the turn too (`n` = 0 counts as 1). The step per
    /// scan of a step over `n` scan intervals.
    pub fn divided(&self, n: u32) -> RobotPose {
        let n = n.max(1);
        RobotPose {
            x: self.x / n as f32,
            y: self.y / n as f32,
            heading: Angle((self.heading.signed() / n as i32) as u32),
        }
    }

    /// Squared distance from the origin, m² (no square root on a
    /// microcontroller: compare it with a squared limit).
    pub fn distance_squared(&self) -> f32 {
        self.x * self.x + self.y * self.y
    }
}

/// `(sin, cos)` of `a` from the Q16 table.
fn unit(a: Angle) -> (f32, f32) {
    let (s, c) = sin_cos(a.0);
    (s as f32 / 65_536.0, c as f32 / 65_536.0)
}

/// √v for a variance (v ≥ 0, finite; else 0), by Newton from a power of
/// two: relative error below 10⁻⁶ (no `sqrtf` in `core`).
pub(super) fn sqrt(v: f32) -> f32 {
    if !(v > 0.0 && v.is_finite()) {
        return 0.0;
    }
    let mut x = if v > 1.0 { v } else { 1.0 };
    for _ in 0..64 {
        let next = 0.5 * (x + v / x);
        if next >= x {
            break;
        }
        x = next;
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compose_and_between_match_f64() {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..500 {
            let (ax, ay, at) = (
                next() * 20.0 - 10.0,
                next() * 20.0 - 10.0,
                (next() - 0.5) * core::f64::consts::TAU,
            );
            let (bx, by, bt) = (
                next() * 4.0 - 2.0,
                next() * 4.0 - 2.0,
                (next() - 0.5) * core::f64::consts::TAU,
            );
            let pose = |x: f64, y: f64, t: f64| RobotPose {
                x: x as f32,
                y: y as f32,
                heading: Angle::from_degrees(t.to_degrees() as f32),
            };
            let (a, b) = (pose(ax, ay, at), pose(bx, by, bt));
            let c = a.compose(&b);
            // f64 reference: a ∘ b.
            let (s, co) = at.sin_cos();
            let (cx, cy) = (ax + co * bx - s * by, ay + s * bx + co * by);
            assert!((f64::from(c.x) - cx).abs() < 2e-4, "x {} vs {cx}", c.x);
            assert!((f64::from(c.y) - cy).abs() < 2e-4, "y {} vs {cy}", c.y);
            let dt = (f64::from(c.heading.to_degrees()) - (at + bt).to_degrees() + 540.0)
                .rem_euclid(360.0)
                - 180.0;
            assert!(dt.abs() < 1e-3, "heading off by {dt}°");
            // between undoes compose.
            let back = a.between(&c);
            assert!((back.x - b.x).abs() < 2e-4 && (back.y - b.y).abs() < 2e-4);
            assert!(back.heading.distance(b.heading) < Angle::from_degrees(1e-3));
        }
    }

    #[test]
    fn divided_splits_a_step() {
        let step = RobotPose {
            x: 3.0,
            y: -1.5,
            heading: Angle::from_degrees(-30.0),
        };
        let third = step.divided(3);
        assert!((third.x - 1.0).abs() < 1e-6 && (third.y + 0.5).abs() < 1e-6);
        assert!((third.heading.to_degrees() + 10.0).abs() < 1e-4);
        assert_eq!(step.divided(0), step);
        assert!((step.distance_squared() - 11.25).abs() < 1e-5);
    }

    #[test]
    fn sqrt_matches_f64() {
        for v in [1e-6f32, 0.0625, 1.0, 2.0, 900.0, 1e6] {
            let r = f64::from(sqrt(v));
            assert!(
                (r - f64::from(v).sqrt()).abs() <= 1e-6 * f64::from(v).sqrt(),
                "{v}"
            );
        }
        assert_eq!(sqrt(-1.0), 0.0);
        assert_eq!(sqrt(f32::NAN), 0.0);
    }
}
