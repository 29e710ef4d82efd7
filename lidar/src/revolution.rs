//! Points → one scan per turn, in `hough-heading`'s conventions.
//!
//! # Conventions
//!
//! A revolution has `N` bins (a compile-time constant): bin `i` holds the
//! beam at `i · 360°/N` **counter-clockwise** from the sensor's zero (its
//! front), whatever the sensor's own direction (a clockwise sensor's angle
//! `a` is the counter-clockwise angle `−a`). A point
//! goes to the nearest bin (angle error at most half a bin, `180°/N`), its
//! range in metres (`f32`, the quarter-millimetre reading divided by
//! 4 000). Two returns in one bin keep the nearer one (counted in
//! [`RevolutionStats::merged`]). A bin without a return holds `max_range`,
//! which `hough_heading::Scan` counts as "no return".
//!
//! The sensor's pose on the robot (mounting offset and angle) is not
//! applied here: it is the `SensorOffset` of the scan
//! ([`Revolution::scan`], feature `scan`), in the robot frame (x forward,
//! y left, θ counter-clockwise), so a sensor mounted turned by θ reports
//! its zero along the robot's θ.
//!
//! # Revolutions
//!
//! A revolution ends when the angles (in the sensor's direction) move
//! forward through 360° = 0°: a point lies ahead of the foremost angle so
//! far (by less than 315°) but its angle is smaller. A point up to
//! [`BACKWARD`] (45°) behind the foremost one is jitter (e.g. YDLIDAR's
//! triangulation correction near 0°): it goes into its bin and starts
//! nothing. Consequence: a gap of more than 315° in the data merges two
//! turns into one revolution (counted in [`RevolutionStats::merged`]). The points before the first wrap are a partial
//! revolution (the stream started mid-turn): they are dropped and counted
//! ([`AssemblerCounters::leading_points`]). The last revolution of a
//! stream is complete only when the next one starts.

use crate::counters::bump;
use crate::point::{Direction, Point, UNITS_PER_TURN};

/// A point at most this far behind the foremost angle so far (in the
/// sensor's direction) is jitter, not a new revolution: 45 °.
pub const BACKWARD: u32 = UNITS_PER_TURN / 8;

/// Counts of one revolution.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RevolutionStats {
    /// Points received in the revolution.
    pub points: u32,
    /// Bins holding a return.
    pub returns: u32,
    /// Points without a return (range 0) or at or beyond `max_range`.
    pub no_return: u32,
    /// Returns that fell in a bin already holding one (the nearer is kept).
    pub merged: u32,
}

/// Counts of an assembler over its whole life.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AssemblerCounters {
    /// Complete revolutions handed out.
    pub revolutions: u32,
    /// Points of the partial revolution before the first wrap, dropped.
    pub leading_points: u32,
}

/// One complete revolution, borrowed from the [`Assembler`] until its next
/// [`add`](Assembler::add).
#[derive(Clone, Copy, Debug)]
pub struct Revolution<'a, const N: usize> {
    /// Range of bin `i` (at `i·360°/N` counter-clockwise), metres;
    /// `max_range` where there is no return.
    pub ranges: &'a [f32; N],
    /// The quality byte of the point kept in each bin (0 where none).
    pub quality: &'a [u8; N],
    /// A reading at or beyond this is "no return", metres.
    pub max_range: f32,
    /// What went into it.
    pub stats: RevolutionStats,
    /// Its index among the revolutions of the stream (0 = the first
    /// complete one).
    pub index: u32,
}

impl<const N: usize> Revolution<'_, N> {
    /// Angle of bin `i`, radians counter-clockwise from the sensor's zero.
    pub fn angle_rad(i: usize) -> f32 {
        i as f32 * Self::increment_rad()
    }

    /// Angle between consecutive bins, radians (`2π/N`, counter-clockwise).
    pub fn increment_rad() -> f32 {
        core::f32::consts::TAU / N as f32
    }

    /// The revolution as a `hough_heading::Scan` (beam `i` = bin `i`), the
    /// sensor at `offset` in the robot frame. Feed it to
    /// `Raster::rasterize` to get a grid.
    #[cfg(feature = "scan")]
    pub fn scan(&self, offset: hough_heading::SensorOffset) -> hough_heading::Scan<'_> {
        hough_heading::Scan {
            ranges: self.ranges,
            angle_min: 0.0,
            angle_increment: Self::increment_rad(),
            max_range: self.max_range,
            offset,
        }
    }
}

/// Collects points into revolutions of `N` bins. RAM: `5·N` bytes plus 56.
#[derive(Clone, Debug)]
pub struct Assembler<const N: usize> {
    direction: Direction,
    max_range: f32,
    ranges: [f32; N],
    quality: [u8; N],
    stats: RevolutionStats,
    counters: AssemblerCounters,
    /// Angle of the previous point, in the sensor's direction.
    last_angle: Option<u32>,
    /// A wrap has been seen: the buffer fills a complete revolution.
    started: bool,
    /// The buffer holds a complete revolution, handed out; `pending` starts
    /// the next one.
    complete: bool,
    pending: Option<Point>,
}

impl<const N: usize> Assembler<N> {
    /// An assembler for a sensor turning in `direction`, with returns at or
    /// beyond `max_range` metres treated as "no return" (a non-finite or
    /// non-positive `max_range` is replaced by 1000 m).
    pub const fn new(direction: Direction, max_range: f32) -> Self {
        const { assert!(N > 0 && N <= 1 << 16, "1 to 65 536 bins") };
        let max_range = if max_range.is_finite() && max_range > 0.0 {
            max_range
        } else {
            1000.0
        };
        Self {
            direction,
            max_range,
            ranges: [max_range; N],
            quality: [0; N],
            stats: RevolutionStats {
                points: 0,
                returns: 0,
                no_return: 0,
                merged: 0,
            },
            counters: AssemblerCounters {
                revolutions: 0,
                leading_points: 0,
            },
            last_angle: None,
            started: false,
            complete: false,
            pending: None,
        }
    }

    /// The counters so far.
    pub const fn counters(&self) -> &AssemblerCounters {
        &self.counters
    }

    /// "No return" threshold, metres.
    pub const fn max_range(&self) -> f32 {
        self.max_range
    }

    /// Adds a point; `true` when it started a new revolution, so the
    /// previous one is complete: read it with
    /// [`revolution`](Self::revolution) before the next `add`.
    pub fn add(&mut self, point: Point) -> bool {
        if self.complete {
            self.complete = false;
            self.clear();
            if let Some(p) = self.pending.take() {
                self.insert(p);
            }
        }
        let wrapped = match self.last_angle {
            None => {
                self.last_angle = Some(point.angle % UNITS_PER_TURN);
                false
            }
            Some(last) => {
                let angle = point.angle % UNITS_PER_TURN;
                let forward = (angle + UNITS_PER_TURN - last) % UNITS_PER_TURN;
                if forward >= UNITS_PER_TURN - BACKWARD {
                    // A little behind the front (angle jitter): no wrap.
                    false
                } else {
                    self.last_angle = Some(angle);
                    angle < last
                }
            }
        };
        if wrapped {
            if self.started {
                self.complete = true;
                self.pending = Some(point);
                bump(&mut self.counters.revolutions, 1);
                return true;
            }
            self.started = true;
            bump(&mut self.counters.leading_points, self.stats.points);
            self.clear();
        }
        self.insert(point);
        false
    }

    /// The revolution completed by the last [`add`](Self::add) that
    /// returned `true`, until the next `add`.
    pub fn revolution(&self) -> Option<Revolution<'_, N>> {
        self.complete.then_some(Revolution {
            ranges: &self.ranges,
            quality: &self.quality,
            max_range: self.max_range,
            stats: self.stats,
            index: self.counters.revolutions.saturating_sub(1),
        })
    }

    /// Forgets the revolution in progress (e.g. after a long gap in the
    /// data): the next wrap starts a partial one again.
    pub fn restart(&mut self) {
        bump(&mut self.counters.leading_points, self.stats.points);
        self.clear();
        self.started = false;
        self.complete = false;
        self.pending = None;
        self.last_angle = None;
    }

    fn clear(&mut self) {
        self.ranges = [self.max_range; N];
        self.quality = [0; N];
        self.stats = RevolutionStats::default();
    }

    /// The bin of a point: nearest to its counter-clockwise angle.
    fn bin(&self, angle: u32) -> usize {
        let turn = UNITS_PER_TURN;
        let angle = angle % turn;
        let ccw = match self.direction {
            Direction::Clockwise => (turn - angle) % turn,
            Direction::CounterClockwise => angle,
        };
        // round(ccw·N / turn) with turn = 2¹¹ · 1125: ⌊⌊x / 2¹¹⌋ / 1125⌋ =
        // ⌊x / turn⌋, and x / 2¹¹ < 2²⁷ fits a `u32` (N ≤ 2¹⁶).
        const { assert!(UNITS_PER_TURN == 2048 * 1125) };
        let x = u64::from(ccw) * N as u64 + u64::from(turn / 2);
        let bin = ((x >> 11) as u32 / 1125) as usize;
        if bin >= N {
            bin - N
        } else {
            bin
        }
    }

    fn insert(&mut self, point: Point) {
        bump(&mut self.stats.points, 1);
        let range = point.range_m();
        if point.range_q2 == 0 || range >= self.max_range {
            bump(&mut self.stats.no_return, 1);
            return;
        }
        let bin = self.bin(point.angle);
        let (Some(slot), Some(q)) = (self.ranges.get_mut(bin), self.quality.get_mut(bin)) else {
            return;
        };
        if *slot >= self.max_range {
            bump(&mut self.stats.returns, 1);
        } else {
            bump(&mut self.stats.merged, 1);
            if *slot <= range {
                return;
            }
        }
        *slot = range;
        *q = point.quality;
    }
}
