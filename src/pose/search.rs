//! Verification by alignment: how well a full pose (rotation and translation)
//! lays the second view's occupied cells onto the reference grid.
//!
//! A pose maps a point `p₂` of image 2 back into the reference frame as
//! `p₁ = R(−α)·p₂ + u` (then `t = −R(α)·u` in `p₂ = R(α)·p₁ + t`). Up to
//! [`ALIGN_POINTS`] occupied cells of image 2, spread evenly in raster order,
//! are scored: 2 when the reference cell under the point is occupied, 1 when
//! only one of its 8 neighbours is, 0 otherwise. The *alignment* of a pose is
//! the sum over `2 × points` (in [0, 1]); its *overlap* is the share of points
//! scoring at least 1 (within one cell of the reference).
//!
//! The best integer translation of a rotation is found by branch and bound
//! over an OR-pooled pyramid of the reference grid (level `k` cell = OR of a
//! `2ᵏ × 2ᵏ` block), as in correlative scan matching: a block of `2ᵏ × 2ᵏ`
//! translations is bounded by counting the points whose block of possible
//! positions, widened by one cell, touches an occupied pyramid cell. The
//! search is exact over its window (the best integer translation, ties to the
//! first found). [`refine`](super::icp::refine) then moves the pose below one cell and one θ step
//! by point-to-point ICP on the occupied cells, in fixed point.

use crate::angle::Angle;
use crate::config::{align_points, ALIGN_POINTS};
use crate::grid::Grid;
use crate::math::sort_descending;
use crate::pose::pyramid::{all_in_columns, any_in_columns, bits, grid_bits, Pyramid};
use crate::pose::reach::{ReachTables, EXACT_LEVELS};
use crate::trig::sin_cos_q15;

/// A point of image 2 turned into the reference frame, in reference cells
/// `(col, row)`.
pub(crate) type Cell = (i16, i16);

/// A pose found by the search: rotation and the translation `u` in
/// reference cells (`col`, `row` directions), with its alignment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Placement {
    /// Rotation α of the scene.
    pub(crate) alpha: Angle,
    /// Translation in reference cells, `(Δcol, Δrow)`.
    pub(crate) shift: (i32, i32),
    /// Σ point scores (0, 1 or 2 each).
    pub(crate) score: u32,
}

/// Scores poses of image 2's occupied cells against a reference grid.
pub(crate) struct Aligner<'a, const W: usize, const H: usize, const RW: usize, const PW: usize> {
    reference: &'a Grid<W, H, RW>,
    pyramid: &'a Pyramid<W, H, PW>,
    /// The reference's reach tables, when it keeps them (read only with
    /// the feature `reach-tables`).
    #[cfg_attr(not(feature = "reach-tables"), allow(dead_code))]
    reach: Option<&'a ReachTables<W, H, RW>>,
    view: &'a Grid<W, H, RW>,
    /// The reference's free space (scans) and what a point scoring 0 on it
    /// costs, score units.
    free: Option<(&'a Grid<W, H, RW>, u32)>,
    /// Centroid of the sampled view points, centred coordinates × 2.
    centroid_q1: (i32, i32),
    /// `1/s` (Q16): view points are shrunk by it before the pose.
    inv_scale_q16: i64,
    /// View points turned by the current rotation, reference cells.
    cells: [Cell; ALIGN_POINTS],
    count: usize,
    /// Grid rows (per sampled point) the searches may still read.
    budget: core::cell::Cell<u32>,
    /// A search stopped because the budget ran out.
    cut: core::cell::Cell<bool>,
}

impl<'a, const W: usize, const H: usize, const RW: usize, const PW: usize>
    Aligner<'a, W, H, RW, PW>
{
    /// An aligner of `view` against `reference`, whose `pyramid` is built
    /// (and its `reach` tables, if it keeps them: the same answers, faster);
    /// the view is at scale `s` = 2¹⁶ / `inv_scale_q16` of the reference.
    /// With `free` (the reference's free space and a penalty), a point that
    /// scores 0 on a free cell costs the penalty: the score of a pose is
    /// then `max(0, Σ scores − penalty · violations)`, and the search finds
    /// the best translation by that score (the bounds, which ignore the
    /// penalty, stay upper bounds).
    pub(crate) fn new(
        reference: &'a Grid<W, H, RW>,
        pyramid: &'a Pyramid<W, H, PW>,
        reach: Option<&'a ReachTables<W, H, RW>>,
        view: &'a Grid<W, H, RW>,
        free: Option<(&'a Grid<W, H, RW>, u32)>,
        inv_scale_q16: u32,
    ) -> Self {
        let (mut n, mut sx, mut sy) = (0i64, 0i64, 0i64);
        for (col, row) in sampled_cells(view, align_points(W, H)) {
            let (x, y) = centred_q1::<W, H>(col, row);
            n += 1;
            sx += i64::from(x);
            sy += i64::from(y);
        }
        let n = n.max(1);
        Self {
            reference,
            pyramid,
            reach,
            view,
            free,
            centroid_q1: ((sx / n) as i32, (sy / n) as i32),
            inv_scale_q16: i64::from(inv_scale_q16),
            cells: [(0, 0); ALIGN_POINTS],
            count: 0,
            budget: core::cell::Cell::new(u32::MAX),
            cut: core::cell::Cell::new(false),
        }
    }

    /// The aligner with a work budget: its searches read at most `rows`
    /// grid rows in all, counted per sampled point ([`Self::cost`]), then
    /// keep what they found. `u32::MAX`: no budget.
    pub(crate) fn with_budget(self, rows: u32) -> Self {
        self.budget.set(rows);
        self
    }

    /// Whether a search ran out of the work budget.
    pub(crate) fn cut(&self) -> bool {
        self.cut.get()
    }

    /// Takes the work of one evaluation at pyramid level `k` (0: a score)
    /// from the budget ([`Self::cost`]); `false` (and the search marked cut)
    /// when the budget cannot cover it. A budget of `u32::MAX` is none.
    fn spend(&self, k: usize) -> bool {
        let budget = self.budget.get();
        if budget == u32::MAX {
            return true;
        }
        match budget.checked_sub(self.cost(k)) {
            Some(left) => {
                self.budget.set(left);
                true
            }
            None => {
                self.cut.set(true);
                false
            }
        }
    }

    /// The most grid rows one evaluation at level `k` reads, over all its
    /// points (the work unit of the budget, charged in full even when the
    /// evaluation stops early): a score reads 3 rows a point
    /// ([`point_score`]) and one free-space bit; an exact bound `2ᵏ + 2`
    /// rows of the reference and, with free space, `2ᵏ` of its free grid; a
    /// pyramid bound at most 3 rows of its level. At most 34 rows a point,
    /// `34 · ALIGN_POINTS` an evaluation: no overflow in `u32`.
    fn cost(&self, k: usize) -> u32 {
        let with_free = u32::from(self.free.is_some());
        let rows = match k {
            0 => 3 + with_free,
            k if k <= EXACT_LEVELS => (1 << k) + 2 + with_free * (1 << k),
            _ => 3,
        };
        rows * self.points().max(1)
    }

    /// The shift for rotation `alpha` that keeps the view's centroid where
    /// `from` put it: `u' = u + (R(−α₀) − R(−α))·p̄`, reference cells.
    pub(crate) fn predict<const N: usize>(&self, from: &Placement, alpha: Angle) -> (i32, i32) {
        let at = |a: Angle| {
            scaled(
                rotate_inverse_q16(sin_cos_q15::<N>(a), self.centroid_q1),
                self.inv_scale_q16,
            )
        };
        let (x0, y0) = at(from.alpha);
        let (x1, y1) = at(alpha);
        // Q16 centred (y up) → cells (Δcol, Δrow = −Δy).
        let dc = ((x0 - x1) + (1 << 15)) >> 16;
        let dr = ((y1 - y0) + (1 << 15)) >> 16;
        (from.shift.0 + dc as i32, from.shift.1 + dr as i32)
    }

    /// Sets `1/s` (Q16) for the next [`Self::rotate`]: the view is at scale
    /// `s` = 2¹⁶ / `inv_scale_q16` of the reference.
    pub(crate) fn set_inv_scale(&mut self, inv_scale_q16: u32) {
        self.inv_scale_q16 = i64::from(inv_scale_q16);
    }

    /// Number of points scored (`min(occupied, align_points(W, H))`).
    pub(crate) fn points(&self) -> u32 {
        self.count as u32
    }

    /// Turns the sampled view points by `−alpha` into the reference cells,
    /// plus `u_q8` (centred reference coordinates, Q8 cells, y up).
    pub(crate) fn rotate<const N: usize>(&mut self, alpha: Angle, u_q8: (i64, i64)) {
        let (cos, sin) = sin_cos_q15::<N>(alpha);
        let mut count = 0;
        let cells = sampled_cells(self.view, align_points(W, H));
        for ((col, row), slot) in cells.zip(self.cells.iter_mut()) {
            let (x, y) = scaled(
                rotate_inverse_q16((cos, sin), centred_q1::<W, H>(col, row)),
                self.inv_scale_q16,
            );
            let cell = to_cell_q16::<W, H>(x + (u_q8.0 << 8), y + (u_q8.1 << 8));
            *slot = (clamp_i16(cell.0), clamp_i16(cell.1));
            count += 1;
        }
        self.count = count;
    }

    /// Score of the rotated points shifted by `(dc, dr)` cells.
    pub(crate) fn score(&self, shift: (i32, i32)) -> u32 {
        self.score_above(shift, 0)
    }

    /// [`Self::score`] if it exceeds `floor`, else 0 (stops as soon as the
    /// points left cannot lift it above `floor`). With `floor` 0 it is the
    /// score itself (less the free-space penalties, at least 0).
    fn score_above(&self, shift: (i32, i32), floor: u32) -> u32 {
        let mut reachable = 2 * self.points();
        let mut total = 0u32;
        let mut penalties = 0u32;
        for &(c, r) in self.turned() {
            let (c, r) = (i32::from(c) + shift.0, i32::from(r) + shift.1);
            let s = point_score(self.reference, c, r);
            total += s;
            reachable -= 2 - s;
            if s == 0 {
                if let Some((free, penalty)) = self.free {
                    if c >= 0 && r >= 0 && free.get(c as usize, r as usize) {
                        penalties = penalties.saturating_add(penalty);
                    }
                }
            }
            if floor > 0 && reachable.saturating_sub(penalties) <= floor {
                return 0;
            }
        }
        total.saturating_sub(penalties)
    }

    /// Points within one cell of the reference when shifted by `(dc, dr)`.
    pub(crate) fn near(&self, shift: (i32, i32)) -> u32 {
        self.turned()
            .iter()
            .filter(|&&(c, r)| {
                point_score(
                    self.reference,
                    i32::from(c) + shift.0,
                    i32::from(r) + shift.1,
                ) > 0
            })
            .count() as u32
    }

    fn turned(&self) -> &[Cell] {
        self.cells.get(..self.count).unwrap_or(&[])
    }

    /// Upper bound of [`Self::score`] over the block of shifts
    /// `[c0, c0 + 2ᵏ) × [r0, r0 + 2ᵏ)`, level `k ≥ 1`: twice the number of
    /// points with an occupied reference cell within their reach (the block
    /// widened by one cell, [`Self::reaches`]).
    ///
    /// With the reference's free space (exact levels only), a point that
    /// reaches no occupied cell and lies on free space at every shift of the
    /// block also costs its penalty: it scores 0 and violates at each of them.
    ///
    /// Returns 0 as soon as the bound cannot exceed `floor`.
    fn bound(&self, k: usize, c0: i32, r0: i32, floor: u32) -> u32 {
        match self.free.filter(|_| k <= EXACT_LEVELS) {
            Some((free, penalty)) => self.bound_with_free(k, c0, r0, floor, free, penalty),
            None => self.bound_occupied(k, c0, r0, floor),
        }
    }

    /// [`Self::bound`] without free space.
    fn bound_occupied(&self, k: usize, c0: i32, r0: i32, floor: u32) -> u32 {
        // 2·hits > floor ⟺ hits ≥ floor/2 + 1: at most this many may miss.
        let Some(allowed) = self.points().checked_sub(floor / 2 + 1) else {
            return 0;
        };
        let mut misses = 0;
        for &point in self.turned() {
            if !self.reaches(k, c0, r0, point) {
                misses += 1;
                if misses > allowed {
                    return 0;
                }
            }
        }
        2 * (self.points() - misses)
    }

    /// [`Self::bound`] with the reference's free space, levels
    /// `1..=`[`EXACT_LEVELS`].
    fn bound_with_free(
        &self,
        k: usize,
        c0: i32,
        r0: i32,
        floor: u32,
        free: &Grid<W, H, RW>,
        penalty: u32,
    ) -> u32 {
        let side = 1i32 << k;
        // Free at every shift of the block: the block's own cells (not
        // widened), all set, all inside the grid.
        let free_throughout = |(c, r): Cell| {
            let (a, b) = (i32::from(c) + c0, i32::from(r) + r0);
            let block = usize::try_from(b)
                .ok()
                .and_then(|b| free.words().get(b..b + side as usize));
            block.is_some_and(|rows| all_in_columns(rows, a, side as u32))
        };
        // What the block can still score: 2 a point not yet missed, less
        // the certain penalties.
        let mut reachable = 2 * self.points();
        for &point in self.turned() {
            if !self.reaches(k, c0, r0, point) {
                reachable = reachable.saturating_sub(2);
                if free_throughout(point) {
                    reachable = reachable.saturating_sub(penalty);
                }
                if reachable <= floor {
                    return 0;
                }
            }
        }
        reachable
    }

    /// Whether `point` shifted anywhere in the block `[c0, c0 + 2ᵏ) ×
    /// [r0, r0 + 2ᵏ)` has an occupied reference cell within one cell. Up to
    /// level [`EXACT_LEVELS`] it is tested exactly on the grid's rows
    /// (`2ᵏ + 2` rows a point); above, on the pyramid (2–3 cells of `2ᵏ`
    /// per axis: looser, but few blocks are that large).
    #[inline(always)]
    fn reaches(&self, k: usize, c0: i32, r0: i32, (c, r): Cell) -> bool {
        let side = 1i32 << k;
        let (a, b) = (i32::from(c) + c0 - 1, i32::from(r) + r0 - 1);
        if k <= EXACT_LEVELS {
            // Compiled only with the feature: without it the test costs the
            // rows' path 2 % (M4F, budget scene).
            #[cfg(feature = "reach-tables")]
            if let Some(hit) = self.reach.and_then(|t| t.reaches(k, a, b)) {
                return hit;
            }
            let reach = self
                .reference
                .words()
                .get(b.max(0) as usize..(b + side + 2).clamp(0, H as i32) as usize)
                .unwrap_or(&[]);
            any_in_columns(reach, a, (side + 2) as u32)
        } else {
            let (lo_c, hi_c) = (a >> k, (a + side + 1) >> k);
            let (lo_r, hi_r) = (b >> k, (b + side + 1) >> k);
            let n = (hi_c - lo_c + 1) as u32;
            (lo_r..=hi_r).any(|row| bits(self.pyramid.row(k, row), lo_c, n) != 0)
        }
    }

    /// The best integer shift within `[centre − radius, centre + radius]` in
    /// both axes whose score beats `floor`, by branch and bound; `None` if
    /// none beats it. Ties keep the first found (blocks with the higher
    /// bound first). Each bound and score spends the grid rows it may read
    /// from the work budget ([`Self::with_budget`], [`Self::cost`]); when it
    /// runs out the search returns
    /// the best found so far and [`Self::cut`] is set. The radius is
    /// clamped to `2^(L+1)` cells (`L` the pyramid's levels: at least half
    /// the grid's larger side; the default window, ¼ of the ρ range, is
    /// that), so that at most 5 × 5 top blocks cover the window.
    pub(crate) fn search(
        &self,
        centre: (i32, i32),
        radius: i32,
        floor: u32,
    ) -> Option<((i32, i32), u32)> {
        // At most 5 × 5 top blocks of the largest pyramid level.
        let radius = radius.clamp(0, 2 << Pyramid::<W, H, PW>::LEVELS);
        let span = 2 * radius + 1;
        // Top level: blocks at most a quarter of the window, within the pyramid.
        let mut top = 0usize;
        while top < Pyramid::<W, H, PW>::LEVELS && (4i32 << top) < span {
            top += 1;
        }
        let side = 1i32 << top;
        let blocks = (span + side - 1) / side;
        let origin = (centre.0 - radius, centre.1 - radius);
        // Blocks are kept compact (8 bytes) relative to the origin: the
        // frames of the search are on the deepest stack path.
        let at = |b: &Block| (origin.0 + i32::from(b.col), origin.1 + i32::from(b.row));
        let mut tops: heapless::Vec<Block, TOP_BLOCKS> = heapless::Vec::new();
        for i in 0..blocks {
            for j in 0..blocks {
                let (col, row) = (j * side, i * side);
                let (c0, r0) = (origin.0 + col, origin.1 + row);
                if !self.spend(top) {
                    return None;
                }
                let b = if top == 0 {
                    self.score_above((c0, r0), floor)
                } else {
                    self.bound(top, c0, r0, floor)
                };
                if b > floor {
                    let _ = tops.push(Block::new(b, top, col, row));
                }
            }
        }
        let mut best: Option<((i32, i32), u32)> = None;
        let mut floor = floor;
        let last = span - 1;
        // Highest bound first.
        sort_descending(&mut tops, |t| u32::from(t.bound));
        let mut stack: heapless::Vec<Block, STACK> = heapless::Vec::new();
        for &block in &tops {
            if u32::from(block.bound) <= floor {
                break;
            }
            let _ = stack.push(block);
            while let Some(block) = stack.pop() {
                let (b, k) = (u32::from(block.bound), usize::from(block.level));
                if b <= floor || i32::from(block.col) > last || i32::from(block.row) > last {
                    continue;
                }
                if k == 0 {
                    // At level 0 the bound is the score.
                    floor = b;
                    best = Some((at(&block), b));
                    continue;
                }
                let half = 1i32 << (k - 1);
                let mut children = [Block::new(0, 0, 0, 0); 4];
                for (n, child) in children.iter_mut().enumerate() {
                    let col = i32::from(block.col) + half * (n as i32 & 1);
                    let row = i32::from(block.row) + half * (n as i32 >> 1);
                    let (c, r) = (origin.0 + col, origin.1 + row);
                    let cb = if col > last || row > last {
                        0
                    } else if !self.spend(k - 1) {
                        return best;
                    } else if k == 1 {
                        self.score_above((c, r), floor)
                    } else {
                        self.bound(k - 1, c, r, floor)
                    };
                    *child = Block::new(cb, k - 1, col, row);
                }
                // Push the lowest first so the highest is explored first.
                children.sort_unstable_by_key(|c| c.bound);
                for child in children {
                    if u32::from(child.bound) > floor {
                        let _ = stack.push(child);
                    }
                }
            }
        }
        best
    }
}

/// A block of shifts of the search: `2^level` square from `(col, row)`
/// cells past the window's origin, with its bound (scores ≤ 2 ×
/// [`ALIGN_POINTS`] fit 16 bits; offsets ≤ 8 · 2¹¹).
#[derive(Clone, Copy)]
struct Block {
    bound: u16,
    level: u8,
    col: u16,
    row: u16,
}

impl Block {
    fn new(bound: u32, level: usize, col: i32, row: i32) -> Self {
        Self {
            bound: bound.min(u32::from(u16::MAX)) as u16,
            level: level as u8,
            col: col.clamp(0, i32::from(u16::MAX)) as u16,
            row: row.clamp(0, i32::from(u16::MAX)) as u16,
        }
    }
}

/// Most top-level blocks of one search (a window of at most `4·2ᴸ + 1`
/// cells per axis in blocks of `2^top`, `4·2^top` ≥ the window or `top = L`).
const TOP_BLOCKS: usize = 25;
/// Depth-first stack: 4 children per level, 12 levels at most (W ≤ 2048).
const STACK: usize = 48;

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

fn clamp_i16(v: i64) -> i16 {
    v.clamp(i64::from(i16::MIN), i64::from(i16::MAX)) as i16
}

/// With the feature only: without it the aligner reads no table.
#[cfg(all(test, feature = "reach-tables"))]
mod tests {
    use super::*;
    use crate::config::{pyramid_words, row_words};

    const N: usize = 360;

    /// xorshift32.
    fn next(state: &mut u32) -> u32 {
        *state ^= *state << 13;
        *state ^= *state >> 17;
        *state ^= *state << 5;
        *state
    }

    /// Random wall segments and scattered cells.
    fn scene<const S: usize, const RW: usize>(seed: u32) -> Grid<S, S, RW> {
        let mut grid = Grid::new();
        let mut state = seed;
        for _ in 0..S / 10 {
            let (c, r) = (next(&mut state) as usize % S, next(&mut state) as usize % S);
            let horizontal = next(&mut state) % 2 == 0;
            let len = 5 + next(&mut state) as usize % (S / 2);
            for i in 0..len {
                let (c, r) = if horizontal { (c + i, r) } else { (c, r + i) };
                let _ = grid.set(c, r);
            }
        }
        for _ in 0..S / 3 {
            let _ = grid.set(next(&mut state) as usize % S, next(&mut state) as usize % S);
        }
        grid
    }

    /// The reach tables change no search at `S × S`: the same best shift
    /// and score, rotation by rotation, with and without free space, for
    /// every window and floor, and the same work spent. Returns how many
    /// searches found a shift.
    fn same_searches<const S: usize, const RW: usize, const PW: usize>() -> usize {
        let mut searches = 0;
        for seed in 1..=12u32 {
            let reference = scene::<S, RW>(seed.wrapping_mul(0x9E37_79B9));
            let view = scene::<S, RW>(seed.wrapping_mul(0x85EB_CA6B));
            let mut free = Grid::<S, S, RW>::new();
            for r in 8..S - 8 {
                for c in 8..S - 8 {
                    if !reference.get(c, r) && (c + r) % 3 != 0 {
                        let _ = free.set(c, r);
                    }
                }
            }
            let mut pyramid = Pyramid::<S, S, PW>::new();
            pyramid.build(&reference);
            let tables = ReachTables::of(&reference);
            for with_free in [None, Some((&free, 3))] {
                let aligner = |reach| {
                    Aligner::new(&reference, &pyramid, reach, &view, with_free, 1 << 16)
                        .with_budget(1 << 24)
                };
                let (mut plain, mut fast) = (aligner(None), aligner(Some(&tables)));
                for degrees in [0, 7, 90, 181, 300] {
                    let alpha = Angle::from_steps_q16(i64::from(degrees) << 16, N);
                    plain.rotate::<N>(alpha, (0, 0));
                    fast.rotate::<N>(alpha, (0, 0));
                    let wide = S as i32 * 5 / 8;
                    for (centre, radius, floor) in
                        [((0, 0), wide, 0), ((3, -2), 3, 0), ((0, 0), 16, 20)]
                    {
                        let found = plain.search(centre, radius, floor);
                        let fast_found = fast.search(centre, radius, floor);
                        assert_eq!(fast_found, found, "{S}²: seed {seed}, α {degrees}°");
                        searches += usize::from(found.is_some());
                    }
                }
                assert_eq!(fast.budget.get(), plain.budget.get());
            }
        }
        searches
    }

    #[test]
    fn reach_tables_keep_every_search() {
        // 64²: the exact levels; 128²: the pyramid's top level too.
        let found = same_searches::<64, { row_words(64) }, { pyramid_words(64, 64) }>();
        assert!(
            found >= 90,
            "64²: only {found} of 360 searches found a shift"
        );
        let found = same_searches::<128, { row_words(128) }, { pyramid_words(128, 128) }>();
        assert!(
            found >= 90,
            "128²: only {found} of 360 searches found a shift"
        );
    }
}
