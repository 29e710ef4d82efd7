//! Laser scan → occupancy [`Grid`]: rasterising, and the automatic window
//! radius ([`Raster::auto`]). The estimate → robot motion conversion is in
//! [`motion`](crate::motion).
//!
//! # Frames
//!
//! - **Robot frame**: x forward, y left, metres (the usual ROS/CARMEN frame).
//!   The sensor sits at [`SensorOffset`] in it; beam `i` leaves the sensor at
//!   `angle_min + i·angle_increment` (radians, counter-clockwise from the
//!   sensor's x axis).
//! - **Grid**: the robot origin is the grid centre, robot x along grid +x
//!   (columns to the right) and robot y along grid +y (rows up), so the grid
//!   is the scan seen from above and a point `(x, y)` metres lands in the cell
//!   containing `(x / cell, y / cell)` in the centred, y-up cell coordinates
//!   of DESIGN.md §2. No mirror is involved: a left turn is a left turn.
//!
//! # Rasterization choices (measured)
//!
//! On the real scan pairs of `../shared/data` with `overlap_gt` ≥ 0.5 (3277
//! pairs, 256², `N_θ` = 360; tables in `host-tests/REAL_DATA.md`), share of
//! pairs within 2°:
//!
//! - window radius `R` = the 90th percentile of the valid ranges of both
//!   scans, clamped to 2–40 m, one `R` per pair ([`Raster::auto`]): 83.9 %;
//!   fixed cells of 0.05 / 0.1 / 0.2 m: 80.6 / 82.1 / 75.7 % (indoors the
//!   window must stay small, outdoors it must reach 20–40 m);
//! - 128² instead of 256²: 80.3 %; clipping to the inscribed disc
//!   ([`Raster::clip_to_disc`]): 83.7 %;
//! - segments between neighbouring beams ([`Raster::connect`]) at most
//!   0.2 / 0.3 / 0.5 / 1 m apart: 85.8 / 86.0 / 86.3 / 84.6 %. With one cell
//!   per beam a wall weighs as many cells as it has beams, so a near wall
//!   outweighs a far one; segments make its weight its length. They help the
//!   sparse 180-beam scanners most (+4 to +7 points) but raise the half-turn
//!   flips on some files.
//!
//! Everything here is `no_std`, allocation-free and panic-free: bad readings
//! are dropped and counted in [`ScanStats`], never an error.

use crate::grid::Grid;
use crate::math::{sin_cos_f32 as sin_cos, sqrt_f32 as sqrt};

/// Pose of the sensor in the robot frame: metres, radians (x forward, y left,
/// θ counter-clockwise).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SensorOffset {
    /// Forward offset, metres.
    pub x: f32,
    /// Leftward offset, metres.
    pub y: f32,
    /// Mounting angle, radians.
    pub theta: f32,
}

/// One 2D laser scan, borrowed.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Scan<'a> {
    /// Range of each beam, metres.
    pub ranges: &'a [f32],
    /// Direction of beam 0 in the sensor frame, radians.
    pub angle_min: f32,
    /// Angle between consecutive beams, radians (negative for clockwise
    /// scanners).
    pub angle_increment: f32,
    /// A reading at or beyond this is "no return" and dropped.
    pub max_range: f32,
    /// Sensor pose in the robot frame.
    pub offset: SensorOffset,
}

impl Scan<'_> {
    /// Beam `i`'s range if it is a valid return: finite, positive and below
    /// `max_range`.
    fn valid_range(&self, i: usize) -> Option<f32> {
        let r = *self.ranges.get(i)?;
        valid(r, self.max_range).then_some(r)
    }

    /// Beam `i`'s end point in the robot frame, metres; `None` for an invalid
    /// reading or non-finite geometry.
    fn point(&self, i: usize) -> Option<(f32, f32)> {
        let r = self.valid_range(i)?;
        let phi = self.angle_min + i as f32 * self.angle_increment + self.offset.theta;
        let (s, c) = sin_cos(phi)?;
        let x = self.offset.x + r * c;
        let y = self.offset.y + r * s;
        (x.is_finite() && y.is_finite()).then_some((x, y))
    }
}

/// What [`Raster::rasterize`] did with the beams of one scan. Every beam is
/// counted exactly once among `kept`, `no_return`, `not_finite`,
/// `non_positive` and `outside`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ScanStats {
    /// Number of beams in the scan.
    pub beams: u32,
    /// Beams whose end point set a cell (several may share a cell).
    pub kept: u32,
    /// Readings at or beyond `max_range` (no return).
    pub no_return: u32,
    /// NaN or infinite readings, or beams whose angle or end point is not
    /// finite (e.g. a NaN `angle_increment` or sensor offset).
    pub not_finite: u32,
    /// Readings that are zero or negative.
    pub non_positive: u32,
    /// Valid returns whose end point lies outside the window.
    pub outside: u32,
    /// Extra points set along segments between neighbouring beams
    /// ([`Raster::connect`]); 0 otherwise.
    pub segment_points: u32,
}

impl ScanStats {
    /// Beams dropped for any reason.
    pub const fn dropped(&self) -> u32 {
        self.beams.saturating_sub(self.kept)
    }
}

/// Quantile of the valid ranges used by [`Raster::auto`]: the 90th percentile.
pub const AUTO_PERCENTILE: u32 = 90;
/// Smallest window radius [`Raster::auto`] picks, metres.
pub const AUTO_MIN_RADIUS_M: f32 = 2.0;
/// Largest window radius [`Raster::auto`] picks, metres.
pub const AUTO_MAX_RADIUS_M: f32 = 40.0;

/// How a scan becomes a grid: the cell size (metres per cell), and two
/// options. The robot is at the grid centre; the window is the grid itself
/// (a `W × H` grid covers `±W·cell/2` by `±H·cell/2` metres).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Raster {
    cell: f32,
    connect: Option<f32>,
    disc: bool,
}

impl Raster {
    /// `metres_per_cell` cells; `None` unless it is finite and positive.
    pub fn with_cell(metres_per_cell: f32) -> Option<Self> {
        (metres_per_cell.is_finite() && metres_per_cell > 0.0).then_some(Self {
            cell: metres_per_cell,
            connect: None,
            disc: false,
        })
    }

    /// The cell size that makes a grid `width` cells wide span `±radius`
    /// metres: `cell = 2·radius / width`. `None` unless the result is finite
    /// and positive.
    pub fn with_radius(radius: f32, width: usize) -> Option<Self> {
        Self::with_cell(2.0 * radius / width as f32)
    }

    /// The window DESIGN.md §3b measured best on real scans: radius = the
    /// [`AUTO_PERCENTILE`]th percentile of the valid ranges of all `scans`
    /// (one radius for the pair, so both grids share the scale), clamped to
    /// [[`AUTO_MIN_RADIUS_M`], [`AUTO_MAX_RADIUS_M`]]; the minimum radius when
    /// no scan has a valid range. Cost: 32 passes over the ranges.
    pub fn auto(scans: &[Scan<'_>], width: usize) -> Option<Self> {
        let radius = range_percentile(scans, AUTO_PERCENTILE)
            .unwrap_or(AUTO_MIN_RADIUS_M)
            .clamp(AUTO_MIN_RADIUS_M, AUTO_MAX_RADIUS_M);
        Self::with_radius(radius, width)
    }

    /// Also draws the segment between neighbouring beams (consecutive
    /// indices, both valid) whose end points are at most `max_gap` metres
    /// apart, sampled every half cell. A non-finite or non-positive gap turns
    /// the option off.
    pub fn connect(mut self, max_gap: f32) -> Self {
        self.connect = (max_gap.is_finite() && max_gap > 0.0).then_some(max_gap);
        self
    }

    /// Keeps only points within the disc inscribed in the grid (radius
    /// `min(W, H)·cell/2`), so the window does not change when the robot
    /// turns; otherwise the whole square grid is the window.
    pub fn clip_to_disc(mut self, on: bool) -> Self {
        self.disc = on;
        self
    }

    /// Metres per cell.
    pub const fn cell(&self) -> f32 {
        self.cell
    }

    /// Adds the end points of `scan`'s valid beams to `grid` (which is not
    /// cleared first) and counts what was dropped.
    ///
    /// Work: one `sin_cos` per beam, plus `2·gap/cell` points per connected
    /// pair of beams.
    pub fn rasterize<const W: usize, const H: usize, const RW: usize>(
        &self,
        scan: &Scan<'_>,
        grid: &mut Grid<W, H, RW>,
    ) -> ScanStats {
        let mut stats = ScanStats {
            beams: saturate(scan.ranges.len()),
            ..ScanStats::default()
        };
        let mut previous: Option<(f32, f32)> = None;
        for (i, &r) in scan.ranges.iter().enumerate() {
            let point = scan.point(i);
            let counter = match point {
                Some(p) if self.put(p, grid) => &mut stats.kept,
                Some(_) => &mut stats.outside,
                None if r.is_nan() || r.is_infinite() => &mut stats.not_finite,
                None if r >= scan.max_range => &mut stats.no_return,
                None if r <= 0.0 => &mut stats.non_positive,
                // A finite, positive, in-range reading whose geometry is not finite.
                None => &mut stats.not_finite,
            };
            *counter = counter.saturating_add(1);
            if let (Some(gap), Some(a), Some(b)) = (self.connect, previous, point) {
                let added = self.segment(a, b, gap, grid);
                stats.segment_points = stats.segment_points.saturating_add(added);
            }
            previous = point;
        }
        stats
    }

    /// Sets the cell of point `p` (metres, robot frame); whether it was
    /// inside the window.
    fn put<const W: usize, const H: usize, const RW: usize>(
        &self,
        p: (f32, f32),
        grid: &mut Grid<W, H, RW>,
    ) -> bool {
        let (x, y) = (p.0 / self.cell, p.1 / self.cell);
        if self.disc {
            let r = W.min(H) as f32 * 0.5;
            // `p` is finite (see `Scan::point`).
            if x * x + y * y > r * r {
                return false;
            }
        }
        grid.set_point(x, y).is_ok()
    }

    /// Points along the open segment `a → b` (ends excluded: they are the
    /// beams' own points), every half cell; the number set inside the window.
    fn segment<const W: usize, const H: usize, const RW: usize>(
        &self,
        a: (f32, f32),
        b: (f32, f32),
        max_gap: f32,
        grid: &mut Grid<W, H, RW>,
    ) -> u32 {
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let length_sq = dx * dx + dy * dy;
        // Both ends are finite (see `Scan::point`).
        if length_sq > max_gap * max_gap {
            return 0;
        }
        // Steps of at most half a cell: n = ceil(|ab| / (cell/2)), at most
        // 4·(W + H) (twice the grid's perimeter in half cells: a longer
        // segment is drawn sparser, and the work stays bounded whatever
        // `cell` and `max_gap` are). `as` saturates.
        let limit = 4 * (W + H) as u32;
        let steps = ((sqrt(length_sq) * 2.0 / self.cell) as u32).min(limit) + 1;
        let mut added = 0u32;
        for j in 1..steps {
            let f = j as f32 / steps as f32;
            if self.put((a.0 + f * dx, a.1 + f * dy), grid) {
                added = added.saturating_add(1);
            }
        }
        added
    }
}

/// The `percent`-th percentile (nearest rank, `percent` clamped to 1–100) of
/// the valid ranges (finite, positive, below `max_range`) of all `scans`;
/// `None` if there are none. Exact (one of the ranges), allocation-free:
/// a bisection over the bit patterns of positive `f32`s, 32 passes over the
/// ranges.
pub fn range_percentile(scans: &[Scan<'_>], percent: u32) -> Option<f32> {
    let count_at_most = |bits: u32| -> u64 {
        scans
            .iter()
            .flat_map(|s| s.ranges.iter().filter(|&&r| valid(r, s.max_range)))
            .filter(|r| r.to_bits() <= bits)
            .count() as u64
    };
    let total = count_at_most(u32::MAX);
    if total == 0 {
        return None;
    }
    let percent = u64::from(percent.clamp(1, 100));
    // Nearest rank: the smallest value with at least ceil(p·n/100) values ≤ it.
    let rank = (percent * total).div_ceil(100).max(1);
    // Positive finite f32 bit patterns are ordered like the values.
    let (mut lo, mut hi) = (0u32, f32::MAX.to_bits());
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        if count_at_most(mid) >= rank {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    Some(f32::from_bits(lo))
}

/// A valid return: finite, positive, below `max_range`.
fn valid(r: f32, max_range: f32) -> bool {
    r.is_finite() && r > 0.0 && r < max_range
}

fn saturate(n: usize) -> u32 {
    u32::try_from(n).unwrap_or(u32::MAX)
}

#[cfg(test)]
mod tests {
    use super::*;

    type G = crate::grid!(64, 64);

    fn scan(ranges: &[f32]) -> Scan<'_> {
        Scan {
            ranges,
            angle_min: -core::f32::consts::FRAC_PI_2,
            angle_increment: core::f32::consts::PI / (ranges.len().max(2) - 1) as f32,
            max_range: 30.0,
            offset: SensorOffset::default(),
        }
    }

    #[test]
    fn bad_readings_are_counted_not_kept() {
        let ranges = [1.0, f32::NAN, f32::INFINITY, -1.0, 0.0, 30.0, 99.0, 1.5];
        let mut g = G::new();
        let stats = Raster::with_cell(0.1)
            .unwrap()
            .rasterize(&scan(&ranges), &mut g);
        assert_eq!(stats.beams, 8);
        assert_eq!(stats.kept, 2);
        assert_eq!(stats.not_finite, 2);
        assert_eq!(stats.non_positive, 2);
        assert_eq!(stats.no_return, 2);
        assert_eq!(stats.outside, 0);
        assert_eq!(stats.dropped(), 6);
        assert_eq!(g.occupied(), 2);
    }

    #[test]
    fn points_outside_the_window_are_counted() {
        // 64 cells of 0.1 m: ±3.2 m. A 5 m return is outside.
        let mut g = G::new();
        let stats = Raster::with_cell(0.1)
            .unwrap()
            .rasterize(&scan(&[1.0, 5.0, 2.0]), &mut g);
        assert_eq!((stats.kept, stats.outside), (2, 1));
        // A corner point at (3.0, 3.0) m is inside the square, outside the
        // disc of radius 3.2 m.
        let corner = Scan {
            ranges: &[3.0 * core::f32::consts::SQRT_2],
            angle_min: core::f32::consts::FRAC_PI_4,
            angle_increment: 0.0,
            max_range: 30.0,
            offset: SensorOffset::default(),
        };
        let raster = Raster::with_cell(0.1).unwrap();
        assert_eq!(raster.rasterize(&corner, &mut G::new()).kept, 1);
        let disc = raster.clip_to_disc(true).rasterize(&corner, &mut G::new());
        assert_eq!((disc.kept, disc.outside), (0, 1));
    }

    #[test]
    fn axes_map_forward_to_right_and_left_to_up() {
        // Beam 0 straight ahead (x), beam 1 to the left (y).
        let s = Scan {
            ranges: &[1.0, 2.0],
            angle_min: 0.0,
            angle_increment: core::f32::consts::FRAC_PI_2,
            max_range: 30.0,
            offset: SensorOffset::default(),
        };
        let mut g = G::new();
        Raster::with_cell(0.1).unwrap().rasterize(&s, &mut g);
        // x = 10 cells → col = 10 + 31.5 + 0.5 = 42; y = 0 → row 32.
        assert!(g.get(42, 32));
        // y = 20 cells up → row = 31.5 − 20 + 0.5 = 12; col 32.
        assert!(g.get(32, 12));
        assert_eq!(g.occupied(), 2);
    }

    #[test]
    fn sensor_offset_is_applied() {
        // Sensor 1 m forward, turned left 90°: its beam at 0 points along robot +y.
        let s = Scan {
            ranges: &[2.0],
            angle_min: 0.0,
            angle_increment: 0.0,
            max_range: 30.0,
            offset: SensorOffset {
                x: 1.0,
                y: 0.0,
                theta: core::f32::consts::FRAC_PI_2,
            },
        };
        let mut g = G::new();
        Raster::with_cell(0.1).unwrap().rasterize(&s, &mut g);
        // Robot point (1, 2) m → cells (10, 20) → col 42, row 12.
        assert!(g.get(42, 12));
    }

    #[test]
    fn degenerate_inputs_do_not_panic() {
        assert!(Raster::with_cell(0.0).is_none());
        assert!(Raster::with_cell(f32::NAN).is_none());
        assert!(Raster::with_radius(-1.0, 64).is_none());
        assert!(Raster::with_radius(1.0, 0).is_none());
        let raster = Raster::with_cell(0.1).unwrap().connect(1.0);
        let mut g = G::new();
        assert_eq!(raster.rasterize(&scan(&[]), &mut g), ScanStats::default());
        let nan_geometry = Scan {
            angle_increment: f32::NAN,
            ..scan(&[1.0, 1.0])
        };
        let stats = raster.rasterize(&nan_geometry, &mut g);
        assert_eq!((stats.kept, stats.not_finite), (0, 2));
        assert!(range_percentile(&[], 90).is_none());
        assert!(range_percentile(&[scan(&[f32::NAN, -1.0])], 90).is_none());
        let auto = Raster::auto(&[], 64).unwrap();
        assert!((auto.cell() - 2.0 * AUTO_MIN_RADIUS_M / 64.0).abs() < 1e-6);
    }

    #[test]
    fn percentile_is_the_nearest_rank() {
        let a: [f32; 6] = [5.0, 1.0, 4.0, 2.0, 3.0, f32::NAN];
        let b: [f32; 5] = [10.0, 9.0, 8.0, 7.0, 6.0];
        let scans = [scan(&a), scan(&b)];
        assert_eq!(range_percentile(&scans, 90), Some(9.0));
        assert_eq!(range_percentile(&scans, 50), Some(5.0));
        assert_eq!(range_percentile(&scans, 100), Some(10.0));
        assert_eq!(range_percentile(&scans, 0), Some(1.0));
        // p90 = 9 m → radius 9 m.
        let auto = Raster::auto(&scans, 64).unwrap();
        assert!((auto.cell() - 18.0 / 64.0).abs() < 1e-6);
    }

    #[test]
    fn connect_draws_between_close_neighbours_only() {
        // Two beams 1 m ahead, 0.5 m apart: 10 cells of 0.05 m between them.
        let s = Scan {
            ranges: &[1.0, 1.0],
            angle_min: -0.25,
            angle_increment: 0.5,
            max_range: 30.0,
            offset: SensorOffset::default(),
        };
        let raster = Raster::with_cell(0.05).unwrap();
        let mut plain = G::new();
        raster.rasterize(&s, &mut plain);
        assert_eq!(plain.occupied(), 2);
        let mut joined = G::new();
        let stats = raster.connect(0.6).rasterize(&s, &mut joined);
        assert!(stats.segment_points >= 19, "{stats:?}");
        assert!(joined.occupied() >= 10);
        let mut far = G::new();
        raster.connect(0.4).rasterize(&s, &mut far);
        assert_eq!(far.occupied(), 2);
    }
}
