//! Where a laser saw *through*: the free space of a scan as a grid, and the
//! pair of free-space grids an estimate on two scans takes.
//!
//! An occupancy grid says where the walls are; a scan also says where they
//! are not: every beam crossed empty space from the sensor to its return. A
//! pose that puts one scan's walls where the other sensor's beams passed is
//! wrong, however well the walls line up elsewhere (a corridor seen from its
//! two ends, a half turn in a rectangular room). [`Raster::free_space`]
//! marks the cells each valid beam crossed, from the sensor to
//! [`FREE_MARGIN_CELLS`] cells short of the nearest return among itself
//! and its two neighbouring returns (over at most
//! [`BEAM_MAX_MISSING`](super::BEAM_MAX_MISSING) beams without one; a wall
//! seen at a grazing angle is not seen through between two returns); the
//! verification
//! ([`Estimator::estimate_scans`](crate::Estimator::estimate_scans)) counts
//! the points of each view that a pose lays on the other view's free cells
//! (and not within one cell of its walls).
//!
//! Conservative by construction: a beam without a return (at or beyond
//! `max_range`, NaN, non-positive) marks nothing (a missed return is not
//! evidence of free space), a sensor more than 4096 cells from the robot
//! marks nothing, and cells are marked at steps of at most one cell along
//! the beam, so a cell the beam only grazed may stay unmarked.

use super::beam::{binary_angle, missing_after, BeamEnd, ScanBeams, BEAM_MAX_MISSING};
use super::{Raster, Scan};
use crate::grid::Grid;

/// Cells short of its return at which a beam's free space stops: a wall
/// point of the other view within this distance of a return along the beam
/// is not a violation. Two cells absorb the rasterization (half a cell per
/// view) and a one-cell pose error; the verification adds the 8 neighbours
/// of the view's own occupied cells.
pub const FREE_MARGIN_CELLS: i32 = 2;

/// The free space also stops `1/2^FREE_MARGIN_SHIFT` of the range short of
/// the return (1/32: a candidate pose off by 1.8° moves a wall point at
/// range `r` by `r/32`), so that a rival judged at whole θ steps and whole
/// cells is not penalised for its rounding.
pub const FREE_MARGIN_SHIFT: u32 = 5;

/// The free space of both views of an estimate on scans: for each, the
/// cells its beams crossed ([`Raster::free_space`]), in the same grid as its
/// occupied cells.
#[derive(Clone, Copy, Debug)]
pub struct FreeSpace<'a, const W: usize, const H: usize, const RW: usize> {
    /// Free cells of the reference view (scan 1).
    pub reference: &'a Grid<W, H, RW>,
    /// Free cells of the current view (scan 2).
    pub current: &'a Grid<W, H, RW>,
}

impl Raster {
    /// Marks in `free` (not cleared first) the cells the valid beams of
    /// `scan` crossed: along each beam from the sensor to
    /// [`FREE_MARGIN_CELLS`] short of its return, at steps of at most one
    /// cell, within the grid. Returns the number of beams traced.
    ///
    /// Integer only per beam (the end points of [`Self::rasterize`], an
    /// integer square root and one division); work ≈ the beam's length in
    /// cells, capped at `2·(W + H)` steps.
    pub fn free_space<const W: usize, const H: usize, const RW: usize>(
        &self,
        scan: &Scan<'_>,
        free: &mut Grid<W, H, RW>,
    ) -> u32 {
        let beams = ScanBeams::new(scan, self);
        let Some(origin) = beams.near_origin() else {
            return 0;
        };
        let max_steps = (2 * (W + H)) as i64;
        let (mut angle, step) = beams.angles();
        let mut traced = 0u32;
        // Each beam is traced to the shortest return among itself and its
        // neighbours (the returns before and after it, over at most
        // `BEAM_MAX_MISSING` beams without one): where a wall is seen at a
        // grazing angle, the space between two returns is not seen through.
        // `current` waits for its next neighbour; `missing` counts the beams
        // without a return since it.
        let mut previous: Option<Beam> = None;
        let mut current: Option<Beam> = None;
        let mut missing = 0u32;
        for &r in scan.ranges {
            let end = beams.end_at(binary_angle(angle), r);
            angle = angle.wrapping_add(step);
            let BeamEnd::Near { x, y } = end else {
                missing = missing_after(missing, end);
                if missing > BEAM_MAX_MISSING {
                    if let Some(beam) = current.take() {
                        beam.trace(shortest(&[previous, Some(beam)]), max_steps, free);
                        traced = traced.saturating_add(1);
                    }
                    previous = None;
                }
                continue;
            };
            let next = Beam::new(origin, (x, y));
            if let Some(beam) = current {
                beam.trace(shortest(&[previous, current, Some(next)]), max_steps, free);
                traced = traced.saturating_add(1);
            }
            (previous, current, missing) = (current, Some(next), 0);
        }
        if let Some(beam) = current {
            beam.trace(shortest(&[previous, current]), max_steps, free);
            traced = traced.saturating_add(1);
        }
        traced
    }
}

/// One beam with a return: the sensor, the offset to the return (Q16
/// cells) and its length (Q16 cells).
#[derive(Clone, Copy)]
struct Beam {
    origin: (i32, i32),
    d: (i64, i64),
    length: i64,
}

impl Beam {
    /// The beam from `origin` to `end` (Q16 cells, both below 2¹⁵ cells in
    /// magnitude).
    fn new(origin: (i32, i32), end: (i32, i32)) -> Self {
        let d = (
            i64::from(end.0) - i64::from(origin.0),
            i64::from(end.1) - i64::from(origin.1),
        );
        // |d| < 2¹⁶ cells · 2¹⁶: the squares' sum is below 2⁶³.
        let length = ((d.0 * d.0 + d.1 * d.1) as u64).isqrt() as i64;
        Self { origin, d, length }
    }

    /// Marks the cells along the beam up to [`FREE_MARGIN_CELLS`] plus
    /// `reach/2^FREE_MARGIN_SHIFT` short of `reach` (Q16 cells, at most the beam's length), at steps of at most
    /// one cell, at most `max_steps` of them.
    fn trace<const W: usize, const H: usize, const RW: usize>(
        &self,
        reach: i64,
        max_steps: i64,
        free: &mut Grid<W, H, RW>,
    ) {
        let reach = reach.min(self.length);
        let free_length =
            reach - (i64::from(FREE_MARGIN_CELLS) << 16) - (reach >> FREE_MARGIN_SHIFT);
        if free_length <= 0 || self.length <= 0 {
            return;
        }
        let steps = ((free_length + 0xffff) >> 16).clamp(1, max_steps);
        // |d|·free_length < 2⁶² and length·steps ≥ 1: no overflow, no zero.
        let per_step = self.length.saturating_mul(steps);
        let (sx, sy) = (
            (self.d.0 * free_length).checked_div(per_step).unwrap_or(0),
            (self.d.1 * free_length).checked_div(per_step).unwrap_or(0),
        );
        let (mut x, mut y) = (i64::from(self.origin.0), i64::from(self.origin.1));
        for _ in 0..=steps {
            // Within ±2¹⁷ cells: the Q16 values fit an i32.
            let _ = free.set_q16(x as i32, y as i32);
            x += sx;
            y += sy;
        }
    }
}

/// The shortest length among the beams with a return.
fn shortest(beams: &[Option<Beam>]) -> i64 {
    beams.iter().flatten().map(|b| b.length).min().unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scan::SensorOffset;

    type G = crate::grid!(64, 64);

    /// One beam straight ahead along +x, 2 m at 0.1 m cells: 20 cells from
    /// the centre; free from the sensor's cell to the margin short of the
    /// wall.
    #[test]
    fn a_beam_frees_its_cells_up_to_the_margin() {
        let scan = Scan {
            ranges: &[2.0],
            angle_min: 0.0,
            angle_increment: 0.0,
            max_range: 30.0,
            offset: SensorOffset::default(),
        };
        let mut free = G::new();
        let traced = Raster::with_cell(0.1).unwrap().free_space(&scan, &mut free);
        assert_eq!(traced, 1);
        // The sensor at x = 0 is in column 32, row 32 (`set_q16`'s cell of
        // the point (0, 0)); the return at x = 20 cells in column 52; free
        // up to x = 20 − 2 − 20/32 = 17.375 cells: columns 32 ..= 49 of
        // row 32, nothing else.
        for col in 0..64 {
            assert_eq!(free.get(col, 32), (32..=49).contains(&col), "column {col}");
        }
        assert_eq!(free.occupied(), 18);
    }

    /// No return, NaN and non-positive readings mark nothing.
    #[test]
    fn beams_without_a_return_mark_nothing() {
        let scan = Scan {
            ranges: &[30.0, f32::NAN, -1.0, 0.0, 0.1],
            angle_min: 0.0,
            angle_increment: 0.5,
            max_range: 30.0,
            offset: SensorOffset::default(),
        };
        let mut free = G::new();
        let raster = Raster::with_cell(0.1).unwrap();
        // 0.1 m is one cell: traced, but shorter than the margin.
        assert_eq!(raster.free_space(&scan, &mut free), 1);
        assert_eq!(free.occupied(), 0);
    }

    /// A wall seen at a grazing angle: the far beam is traced only as far as
    /// its nearer neighbour's return, so the cells beside the near return
    /// are not freed by the far beam.
    #[test]
    fn a_beam_stops_at_its_nearer_neighbour() {
        // Beam 0 straight ahead 1 m; beam 1 at 10°, 3 m.
        let scan = Scan {
            ranges: &[1.0, 3.0],
            angle_min: 0.0,
            angle_increment: 10f32.to_radians(),
            max_range: 30.0,
            offset: SensorOffset::default(),
        };
        let mut free = G::new();
        Raster::with_cell(0.1).unwrap().free_space(&scan, &mut free);
        // Both traced to at most 10 − 2 − 10/32 cells from the sensor.
        for (col, row) in free.occupied_cells() {
            let (x, y) = (col as f32 - 32.0, 32.0 - row as f32);
            assert!(x * x + y * y <= 8.7 * 8.7, "({col}, {row})");
        }
        assert!(free.occupied() >= 16);
    }
}
