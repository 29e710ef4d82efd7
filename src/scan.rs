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
//! # Fixed point
//!
//! [`Raster::rasterize`] uses no float per beam (the Cortex-M0 has no FPU,
//! the M4F none for `f64`): the scan's angles, `1/cell` and the sensor
//! offset are converted once per scan ([`ScanBeams`](beam::ScanBeams)),
//! then each beam is classified by its bit pattern, its range converted to
//! Q16 cells with two 32-bit products, its direction read from a
//! full-circle sine table (`sine`, 4 KiB, error below 2.0·10⁻⁵), and its cell set
//! with integers. Each end point is within `r_c·2.3·10⁻⁵ + 2⁻¹³` cells of
//! the exact one (`r_c` = range in cells: at most 0.004 cells on a 256²
//! grid); the segments of [`Raster::connect`] are stepped in `2^s` exact
//! integer steps (no square root, no division).
//!
//! # Rasterization choices (measured)
//!
//! On the real scan pairs of `../shared/data` with `overlap_gt` ≥ 0.5 (3277
//! pairs, 256², `N_θ` = 360; tables in `host-tests/REAL_DATA.md`), share of
//! pairs within 2°, measured with the earlier `f32`/`f64` rasterizer and
//! before the verification by alignment (with both, the default set-up
//! gives 95.7 %; with the fixed-point rasterizer 95.8 %):
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

mod agree;
mod beam;
mod free;
mod judge;
mod refine;
mod segments;
pub(crate) mod sine;

pub use beam::{BeamEnd, ScanBeams, BEAM_FAR_CELLS, BEAM_MAX_MISSING, BEAM_NEAR_CELLS};
pub use free::{FreeSpace, FREE_MARGIN_CELLS, FREE_MARGIN_SHIFT};
pub use judge::{
    BeamAgreement, BeamCheck, BeamPose, BEAM_MATCH_M, BEAM_MIN_SCORE, BEAM_RIVAL_MAX_ROTATION_DEG,
    BEAM_SEEN_THROUGH_CONFIDENCE, BEAM_SEEN_THROUGH_M, BEAM_SEEN_THROUGH_WEIGHT, BEAM_SWITCH_LEAD,
};
pub use refine::{
    BeamFit, BeamFitError, BEAM_FIT_MAX_ITERATIONS, BEAM_FIT_MAX_ROTATION_DEG,
    BEAM_FIT_MAX_SHIFT_CELLS, BEAM_FIT_MIN_PAIRS, BEAM_SEGMENT_MAX_M, BEAM_TRIM_MAX_M,
    BEAM_TRIM_MIN_M,
};

use crate::grid::Grid;
use beam::{binary_angle, count_dropped, missing_after};

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
    /// `1 / cell`, for the fixed-point conversions ([`ScanBeams`]).
    inv_cell: f64,
    connect: Option<f32>,
    disc: bool,
}

impl Raster {
    /// `metres_per_cell` cells; `None` unless it is finite and positive.
    pub const fn with_cell(metres_per_cell: f32) -> Option<Self> {
        if !(metres_per_cell.is_finite() && metres_per_cell > 0.0) {
            return None;
        }
        Some(Self {
            cell: metres_per_cell,
            inv_cell: 1.0 / metres_per_cell as f64,
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
    /// apart, sampled at `2^s − 1` evenly spaced points, `s` the smallest
    /// with a spacing under half a cell (at most `4·(W + H)` steps: a
    /// longer segment is drawn sparser). Gaps are capped at 4096 cells
    /// (beyond any grid's diagonal) and tested to 2⁻¹⁴ of the gap. A
    /// non-finite or non-positive gap turns the option off.
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

    /// `metres` in Q16 cells of this raster (at most 10¹², so that
    /// products stay in `i64`; a NaN cell size gives that bound too).
    pub(crate) fn metres_q16(&self, metres: f32) -> i64 {
        (f64::from(metres) * self.inv_cell * 65_536.0).min(1e12) as i64
    }

    /// The raster's settings as stored with a
    /// [`ScanReference`](crate::ScanReference): metres per cell, the
    /// [`connect`](Self::connect) gap (0 when off) and
    /// [`clip_to_disc`](Self::clip_to_disc).
    pub(crate) const fn settings(&self) -> (f32, f32, bool) {
        let gap = match self.connect {
            Some(gap) => gap,
            None => 0.0,
        };
        (self.cell, gap, self.disc)
    }

    /// The raster of stored [`Self::settings`]; `None` unless the cell is
    /// finite and positive and the gap is 0 or finite and positive.
    pub(crate) const fn from_settings(cell: f32, gap: f32, disc: bool) -> Option<Self> {
        let Some(raster) = Self::with_cell(cell) else {
            return None;
        };
        let connect = if gap.to_bits() == 0 {
            None
        } else if gap.is_finite() && gap > 0.0 {
            Some(gap)
        } else {
            return None;
        };
        Some(Self {
            connect,
            disc,
            ..raster
        })
    }

    /// Adds the end points of `scan`'s valid beams to `grid` (which is not
    /// cleared first) and counts what was dropped.
    ///
    /// Fixed point ([`ScanBeams`]): each end point is within
    /// `r_c·2.3·10⁻⁵ + 2⁻¹³` cells of the exact one (`r_c` = range in
    /// cells), then set in the cell containing it. Work per beam: integer
    /// only (a table sine and cosine, six 32-bit products), plus, with
    /// [`connect`](Self::connect), the segment's points.
    pub fn rasterize<const W: usize, const H: usize, const RW: usize>(
        &self,
        scan: &Scan<'_>,
        grid: &mut Grid<W, H, RW>,
    ) -> ScanStats {
        let mut stats = ScanStats {
            beams: saturate(scan.ranges.len()),
            ..ScanStats::default()
        };
        let beams = ScanBeams::new(scan, self);
        let segments = self.connect.map(|gap| Segments::new(gap, self, W, H));
        let window = Window::new(self.disc, W, H);
        let (mut angle, step) = beams.angles();
        // The last return and the beams without one since it: a segment
        // reaches over at most `BEAM_MAX_MISSING` of them.
        let mut previous: Option<(i32, i32)> = None;
        let mut missing = 0u32;
        for &r in scan.ranges {
            let end = beams.end_at(binary_angle(angle), r);
            angle = angle.wrapping_add(step);
            let BeamEnd::Near { x, y } = end else {
                count_dropped(&mut stats, end);
                missing = missing_after(missing, end);
                if missing > BEAM_MAX_MISSING {
                    previous = None;
                }
                continue;
            };
            missing = 0;
            let counter = if window.put(x, y, grid) {
                &mut stats.kept
            } else {
                &mut stats.outside
            };
            *counter = counter.saturating_add(1);
            if let (Some(segments), Some(a)) = (&segments, previous) {
                let added = segments.draw(a, (x, y), &window, grid);
                stats.segment_points = stats.segment_points.saturating_add(added);
            }
            previous = Some((x, y));
        }
        stats
    }
}

/// The window: the grid, or the disc inscribed in it.
struct Window {
    /// `(min(W, H)/2)²` in Q32 (cells² × 2³²) with the disc; `None` for the
    /// whole grid.
    disc: Option<u64>,
}

impl Window {
    fn new(disc: bool, width: usize, height: usize) -> Self {
        // min(W, H) ≤ 2048: the radius in Q16 is at most 2²⁶.
        let radius = (width.min(height) as u64) << 15;
        Self {
            disc: disc.then_some(radius * radius),
        }
    }

    /// Sets the cell of the point `(x, y)` (Q16 cells, a `BeamEnd::Near`
    /// point or between two); whether it was inside the window.
    #[inline(always)]
    fn put<const W: usize, const H: usize, const RW: usize>(
        &self,
        x: i32,
        y: i32,
        grid: &mut Grid<W, H, RW>,
    ) -> bool {
        if let Some(radius_sq) = self.disc {
            // |x|, |y| < 2³¹: the sum of the squares fits in a u64.
            let (x, y) = (u64::from(x.unsigned_abs()), u64::from(y.unsigned_abs()));
            if x * x + y * y > radius_sq {
                return false;
            }
        }
        grid.set_q16(x, y)
    }
}

/// Longest gap [`Raster::connect`] draws, cells: beyond any grid's diagonal
/// (W, H ≤ 2048), so that Q16 differences of near points fit 32 bits.
const MAX_GAP_CELLS: f64 = 4096.0;

/// [`Raster::connect`]'s segments in fixed point.
struct Segments {
    /// The longest gap drawn, Q16 cells (at most 2²⁸).
    gap: u32,
    /// Right shift that brings the gap (and every accepted difference)
    /// below 2¹⁵, so that squares of sums fit 32 bits.
    shift: u32,
    /// `⌈gap >> shift⌉²`.
    gap_sq: u32,
    /// At most `2^max_steps` steps per segment: `4·(W + H)` or less.
    max_steps: u32,
}

impl Segments {
    fn new(gap: f32, raster: &Raster, width: usize, height: usize) -> Self {
        let cells = (f64::from(gap) * raster.inv_cell).min(MAX_GAP_CELLS);
        // `as` saturates; `gap` is positive and finite.
        let gap = (cells * 65_536.0) as u32;
        let shift = (32 - gap.leading_zeros()).saturating_sub(15);
        let scaled = gap >> shift;
        // W + H ≤ 4096: 4·(W + H) ≤ 2¹⁴.
        let limit = (4 * (width + height)).max(1) as u32;
        Self {
            gap,
            shift,
            gap_sq: scaled * scaled,
            max_steps: 31 - limit.leading_zeros(),
        }
    }

    /// Points along the open segment `a → b` (Q16 cells, `BeamEnd::Near`
    /// points; ends excluded: they are the beams' own points) if it is at
    /// most the gap long; the number set inside the window. A segment from
    /// a `BeamEnd::Far` point (at least 2¹³ cells away) would stay 4096
    /// cells or more from the robot: outside every grid, not drawn.
    ///
    /// The length test uses the differences rounded up to `2^shift` Q16
    /// units (a segment within 2⁻¹⁴ of the gap of it may be left out). The
    /// segment is cut into `2^s` steps, `s` the smallest with steps shorter
    /// than half a cell (at most `2^max_steps`: longer segments are drawn
    /// sparser), and point `j` is `a + ⌊j·(b − a)/2^s⌋` exactly (Q16): no
    /// division, no square root.
    fn draw<const W: usize, const H: usize, const RW: usize>(
        &self,
        a: (i32, i32),
        b: (i32, i32),
        window: &Window,
        grid: &mut Grid<W, H, RW>,
    ) -> u32 {
        // `Near` coordinates are below 20480 cells: a true difference is
        // below 2³¹·1.25, so one that wraps is still above 2³⁰ in magnitude,
        // far beyond the gap (≤ 2²⁸), and rejected here.
        let (dx, dy) = (b.0.wrapping_sub(a.0), b.1.wrapping_sub(a.1));
        let (ax, ay) = (dx.unsigned_abs(), dy.unsigned_abs());
        if ax > self.gap || ay > self.gap {
            return 0;
        }
        // Shorter than half a cell (|dx| + |dy| < 2¹⁵): one step, no point.
        if ax + ay < 1 << 15 {
            return 0;
        }
        let round_up = |d: u32| (d + (1 << self.shift) - 1) >> self.shift;
        let (ux, uy) = (round_up(ax), round_up(ay));
        // Both ≤ 2¹⁵: the sum of squares fits.
        let length_sq = ux * ux + uy * uy;
        if length_sq > self.gap_sq {
            return 0;
        }
        // Steps shorter than half a cell: 2^(2s) > 4·length², where
        // length² = length_sq·2^(2·shift − 32) cells².
        let base = 30 - 2 * self.shift;
        let mut s = 0;
        while s < self.max_steps
            && 1u32
                .checked_shl(2 * s + base)
                .is_some_and(|v| v <= length_sq)
        {
            s += 1;
        }
        if s == 0 {
            return 0;
        }
        let n = 1i32 << s;
        let mask = n - 1;
        let (step_x, rem_x, step_y, rem_y) = (dx >> s, dx & mask, dy >> s, dy & mask);
        let (mut x, mut y, mut fx, mut fy) = (a.0, a.1, 0, 0);
        let mut added = 0u32;
        for _ in 1..n {
            x += step_x;
            y += step_y;
            fx += rem_x;
            fy += rem_y;
            if fx >= n {
                x += 1;
                fx -= n;
            }
            if fy >= n {
                y += 1;
                fy -= n;
            }
            if window.put(x, y, grid) {
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
    // Valid and at most `bits` (≥ 1): `1 ≤ r.bits < limit` (positive finite
    // `f32`s are ordered like their bits; negatives, NaNs and infinities are
    // at or above any limit) and `r.bits ≤ bits`, one compare.
    let count_at_most = |bits: u32| -> u64 {
        scans
            .iter()
            .map(|s| {
                let below = valid_limit(s.max_range).saturating_sub(1).min(bits);
                s.ranges
                    .iter()
                    .filter(|r| r.to_bits().wrapping_sub(1) < below)
                    .count() as u64
            })
            .sum()
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

/// The bit patterns of the valid returns (finite, positive, below
/// `max_range`) are `1..limit`: `max_range`'s bits when it is positive (or
/// +∞), 0 when no reading can be valid (`max_range` ≤ 0 or NaN).
fn valid_limit(max_range: f32) -> u32 {
    if max_range > 0.0 {
        max_range.to_bits()
    } else {
        0
    }
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
