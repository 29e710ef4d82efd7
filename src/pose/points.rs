//! The sampled points of an alignment: which view cells are sampled, their
//! centred coordinates, turned and scaled, the reference cell they land
//! in, and its score. Shared by the translation search, the agreement and
//! ICP.

use crate::grid::Grid;
use crate::pose::pyramid::grid_bits;

/// Score of reference cell `(c, r)`: 2 occupied, 1 a neighbour occupied, else 0.
pub(crate) fn point_score<const W: usize, const H: usize, const RW: usize>(
    grid: &Grid<W, H, RW>,
    c: i32,
    r: i32,
) -> u32 {
    let row = |r: i32| grid_bits(grid, c - 1, r, 3);
    let middle = row(r);
    if middle & 2 != 0 {
        2
    } else if middle != 0 || row(r - 1) != 0 || row(r + 1) != 0 {
        1
    } else {
        0
    }
}

/// Up to `max` occupied cells `(col, row)` of `grid`, spread evenly in
/// raster order.
pub(crate) fn sampled_cells<const W: usize, const H: usize, const RW: usize>(
    grid: &Grid<W, H, RW>,
    max: usize,
) -> impl Iterator<Item = (usize, usize)> + '_ {
    let occupied = grid.occupied() as usize;
    let keep = max.min(occupied);
    // Cell i is kept when ⌊(i + 1)·keep / occupied⌋ steps up: the running
    // remainder `(i + 1)·keep mod occupied` wraps (keep ≤ occupied, so it
    // wraps at most once a cell), without a division a cell.
    let mut remainder = 0usize;
    grid.occupied_cells().filter(move |_| {
        remainder += keep;
        let step = remainder >= occupied;
        if step {
            remainder -= occupied;
        }
        step
    })
}

/// Centred coordinates of cell `(col, row)` times 2 (exact integers):
/// `2x = 2·col − (W − 1)`, `2y = (H − 1) − 2·row`.
pub(crate) fn centred_q1<const W: usize, const H: usize>(col: usize, row: usize) -> (i32, i32) {
    (
        2 * col as i32 - (W as i32 - 1),
        (H as i32 - 1) - 2 * row as i32,
    )
}

/// `p · inv_scale` for `p` in Q16 and `inv_scale` in Q16.
pub(crate) fn scaled((x, y): (i64, i64), inv_scale_q16: i64) -> (i64, i64) {
    if inv_scale_q16 == 1 << 16 {
        return (x, y);
    }
    ((x * inv_scale_q16) >> 16, (y * inv_scale_q16) >> 16)
}

/// `R(−α)·p` for `p` in Q1 and `(cos α, sin α)` in Q15: Q16.
pub(crate) fn rotate_inverse_q16((cos, sin): (i32, i32), (x, y): (i32, i32)) -> (i64, i64) {
    let (x, y, cos, sin) = (i64::from(x), i64::from(y), i64::from(cos), i64::from(sin));
    (cos * x + sin * y, cos * y - sin * x)
}

/// The reference cell nearest the centred point `(x, y)` (Q16).
pub(crate) fn to_cell_q16<const W: usize, const H: usize>(x: i64, y: i64) -> (i64, i64) {
    let col = x + ((W as i64 - 1) << 15);
    let row = ((H as i64 - 1) << 15) - y;
    ((col + (1 << 15)) >> 16, (row + (1 << 15)) >> 16)
}

pub(crate) fn clamp_i16(v: i64) -> i16 {
    v.clamp(i64::from(i16::MIN), i64::from(i16::MAX)) as i16
}
