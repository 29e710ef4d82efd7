//! Synthetic laser scans: beams cast from a pose against a map of wall
//! segments, in `f64` (for hand-checked cases on scans, e.g. a corridor
//! seen from both ends). Independent of the library's algorithms: only
//! [`Laser::as_scan`] names its input type.

/// A wall from `.0` to `.1`, metres, world frame.
pub type Wall = ((f64, f64), (f64, f64));

/// A 10 m × 8 m L-shaped room with a pillar and a cupboard, metres (the
/// scene of the scan tests: every direction of translation observable
/// from most poses).
pub fn l_room() -> Vec<Wall> {
    vec![
        ((0.0, 0.0), (10.0, 0.0)),
        ((10.0, 0.0), (10.0, 4.0)),
        ((10.0, 4.0), (5.0, 4.0)),
        ((5.0, 4.0), (5.0, 8.0)),
        ((5.0, 8.0), (0.0, 8.0)),
        ((0.0, 8.0), (0.0, 0.0)),
        ((2.0, 2.0), (2.6, 2.0)),
        ((2.6, 2.0), (2.6, 2.6)),
        ((7.5, 3.0), (9.0, 3.0)),
    ]
}

/// A simulated 2D laser: `beams` beams from `angle_min` in steps of
/// `angle_increment` (radians, counter-clockwise from the robot's x axis),
/// no return beyond `max_range` (reported as `max_range`).
#[derive(Clone, Copy, Debug)]
pub struct Laser {
    /// Number of beams.
    pub beams: usize,
    /// First beam's direction, radians.
    pub angle_min: f64,
    /// Step between beams, radians.
    pub angle_increment: f64,
    /// No return at or beyond this range, metres.
    pub max_range: f64,
}

impl Laser {
    /// A laser covering `fov_deg` degrees centred ahead with `beams` beams.
    pub fn centred(fov_deg: f64, beams: usize, max_range: f64) -> Self {
        let fov = fov_deg.to_radians();
        Self {
            beams,
            angle_min: -fov / 2.0,
            angle_increment: fov / (beams.max(2) - 1) as f64,
            max_range,
        }
    }

    /// The ranges (metres) seen from the robot pose `(x, y, θ)` (world
    /// frame, θ counter-clockwise): the nearest wall along each beam, or
    /// `max_range`.
    pub fn scan(&self, walls: &[Wall], (x, y, theta): (f64, f64, f64)) -> Vec<f32> {
        (0..self.beams)
            .map(|i| {
                let a = theta + self.angle_min + i as f64 * self.angle_increment;
                let (dx, dy) = (a.cos(), a.sin());
                let hit = walls
                    .iter()
                    .filter_map(|&w| intersect((x, y), (dx, dy), w))
                    .fold(self.max_range, f64::min);
                hit as f32
            })
            .collect()
    }

    /// `ranges` cast by this laser as the library's [`Scan`](hough_heading::Scan)
    /// (the sensor at the robot's origin).
    pub fn as_scan<'a>(&self, ranges: &'a [f32]) -> hough_heading::Scan<'a> {
        hough_heading::Scan {
            ranges,
            angle_min: self.angle_min as f32,
            angle_increment: self.angle_increment as f32,
            max_range: self.max_range as f32,
            offset: hough_heading::SensorOffset::default(),
        }
    }
}

/// The robot at world pose `b` seen from the robot frame at world pose `a`:
/// `(d, dθ)`, metres and radians (`p_a = R(dθ)·p_b + d`).
pub fn relative(a: (f64, f64, f64), b: (f64, f64, f64)) -> ((f64, f64), f64) {
    let (s, c) = a.2.sin_cos();
    let (x, y) = (b.0 - a.0, b.1 - a.1);
    ((c * x + s * y, -s * x + c * y), b.2 - a.2)
}

/// Distance along the ray `p + t·d` (t > 0) to the segment `w`, if it hits.
fn intersect(p: (f64, f64), d: (f64, f64), w: Wall) -> Option<f64> {
    let ((ax, ay), (bx, by)) = w;
    let (ex, ey) = (bx - ax, by - ay);
    let denom = d.0 * ey - d.1 * ex;
    if denom.abs() < 1e-12 {
        return None;
    }
    let (qx, qy) = (ax - p.0, ay - p.1);
    let t = (qx * ey - qy * ex) / denom;
    let u = (qx * d.1 - qy * d.0) / denom;
    (t > 1e-9 && (0.0..=1.0).contains(&u)).then_some(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_beam_hits_the_nearest_wall() {
        let walls = [((2.0, -1.0), (2.0, 1.0)), ((5.0, -1.0), (5.0, 1.0))];
        let laser = Laser::centred(0.0, 1, 30.0);
        let r = laser.scan(&walls, (0.0, 0.0, 0.0));
        assert!((r[0] - 2.0).abs() < 1e-6, "{r:?}");
        let back = laser.scan(&walls, (0.0, 0.0, std::f64::consts::PI));
        assert_eq!(back[0], 30.0);
    }
}
