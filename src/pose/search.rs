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
use crate::pose::points::{
    centred_q1, clamp_i16, point_score, rotate_inverse_q16, sampled_cells, scaled, to_cell_q16,
};
use crate::pose::pyramid::{all_in_columns, any_in_columns, bits, Pyramid};
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
    pub(super) reference: &'a Grid<W, H, RW>,
    pub(super) pyramid: &'a Pyramid<W, H, PW>,
    /// The reference's reach tables, when it keeps them (read only with
    /// the feature `reach-tables`).
    #[cfg_attr(not(feature = "reach-tables"), allow(dead_code))]
    pub(super) reach: Option<&'a ReachTables<W, H, RW>>,
    pub(super) view: &'a Grid<W, H, RW>,
    /// The reference's free space (scans) and what a point scoring 0 on it
    /// costs, score units.
    pub(super) free: Option<(&'a Grid<W, H, RW>, u32)>,
    /// Centroid of the sampled view points, centred coordinates × 2.
    pub(super) centroid_q1: (i32, i32),
    /// `1/s` (Q16): view points are shrunk by it before the pose.
    pub(super) inv_scale_q16: i64,
    /// View points turned by the current rotation, reference cells.
    pub(super) cells: [Cell; ALIGN_POINTS],
    pub(super) count: usize,
    /// Grid rows (per sampled point) the searches may still read.
    pub(super) budget: core::cell::Cell<u32>,
    /// A search stopped because the budget ran out.
    pub(super) cut: core::cell::Cell<bool>,
    /// Grid rows (per sampled point) the searches have charged so far.
    pub(super) spent: core::cell::Cell<u32>,
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
            spent: core::cell::Cell::new(0),
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

    /// The work the searches have charged so far ([`Self::cost`] of every
    /// evaluation they made), whether a budget is set or not.
    pub(crate) fn spent(&self) -> u32 {
        self.spent.get()
    }

    /// Takes the work of one evaluation at pyramid level `k` (0: a score)
    /// from the budget ([`Self::cost`]); `false` (and the search marked cut)
    /// when the budget cannot cover it. A budget of `u32::MAX` is none.
    pub(super) fn spend(&self, k: usize) -> bool {
        let cost = self.cost(k);
        let budget = self.budget.get();
        if budget == u32::MAX {
            self.spent.set(self.spent.get().saturating_add(cost));
            return true;
        }
        match budget.checked_sub(cost) {
            Some(left) => {
                self.budget.set(left);
                self.spent.set(self.spent.get().saturating_add(cost));
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
    pub(super) fn cost(&self, k: usize) -> u32 {
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
    pub(super) fn score_above(&self, shift: (i32, i32), floor: u32) -> u32 {
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

    pub(super) fn turned(&self) -> &[Cell] {
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
    pub(super) fn bound(&self, k: usize, c0: i32, r0: i32, floor: u32) -> u32 {
        match self.free.filter(|_| k <= EXACT_LEVELS) {
            Some((free, penalty)) => self.bound_with_free(k, c0, r0, floor, free, penalty),
            None => self.bound_occupied(k, c0, r0, floor),
        }
    }

    /// [`Self::bound`] without free space.
    pub(super) fn bound_occupied(&self, k: usize, c0: i32, r0: i32, floor: u32) -> u32 {
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
    pub(super) fn bound_with_free(
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
    /// (`2ᵏ + 2` rows a point); above, on the pyramid's level `k − 2` (5–6
    /// cells of `2ᵏ⁻²` per axis, up to 6 rows: looser than exact, but few
    /// blocks are that large). Level `k` itself (2–3 cells of `2ᵏ`) pruned
    /// almost nothing on the real scan pairs; level `k − 2` cut the
    /// estimate's median 14.83 → 14.07 M instructions (M4F, 128²,
    /// `bash tools/budgets.sh`) and changed the answer of 14 of the 4 730
    /// shared pairs (ties of the search; within 2° and wrong among
    /// unflagged unchanged).
    #[inline(always)]
    pub(super) fn reaches(&self, k: usize, c0: i32, r0: i32, (c, r): Cell) -> bool {
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
            let j = k - 2;
            let (lo_c, hi_c) = (a >> j, (a + side + 1) >> j);
            let (lo_r, hi_r) = (b >> j, (b + side + 1) >> j);
            let n = (hi_c - lo_c + 1) as u32;
            (lo_r..=hi_r).any(|row| bits(self.pyramid.row(j, row), lo_c, n) != 0)
        }
    }
}

/// With the feature only: without it the aligner reads no table.
#[cfg(all(test, feature = "reach-tables"))]
mod tests {
    use super::*;
    use crate::config::{pyramid_words, row_words};

    const N: usize = 360;

    /// xorshift32.
    pub(super) fn next(state: &mut u32) -> u32 {
        *state ^= *state << 13;
        *state ^= *state >> 17;
        *state ^= *state << 5;
        *state
    }

    /// Random wall segments and scattered cells.
    pub(super) fn scene<const S: usize, const RW: usize>(seed: u32) -> Grid<S, S, RW> {
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
    pub(super) fn same_searches<const S: usize, const RW: usize, const PW: usize>() -> usize {
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
    pub(super) fn reach_tables_keep_every_search() {
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
