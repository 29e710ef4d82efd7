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
//! first found). [`refine`] then moves the pose below one cell and one θ step
//! by point-to-point ICP on the occupied cells, in fixed point.

use crate::angle::Angle;
use crate::trig::TrigTable;
use crate::Grid;

/// Most occupied cells of image 2 scored per pose (taken evenly in raster
/// order when there are more); a `W × H` grid scores
/// [`align_points`]`(W, H)` of them.
pub const ALIGN_POINTS: usize = 128;

/// Cells of image 2 the search scores on a `w × h` grid: `max(w, h) / 2`
/// within 64 ..= [`ALIGN_POINTS`] (64 up to 128², 128 at 256²): about one
/// per two cells of a wall across the grid, and at least 64 (with 32 a
/// circle at 64² came out confident: one point is 3 % of the score).
pub const fn align_points(width: usize, height: usize) -> usize {
    let side = if width > height { width } else { height };
    let half = side / 2;
    if half < 64 {
        64
    } else if half > ALIGN_POINTS {
        ALIGN_POINTS
    } else {
        half
    }
}

/// Cells of image 2 the ICP matches on a `w × h` grid: four times
/// [`align_points`] (256 at 128², 512 at 256²).
pub const fn icp_points(width: usize, height: usize) -> usize {
    4 * align_points(width, height)
}

/// Pyramid levels above the grid: the smallest `L ≥ 1` with
/// `4 · 2ᴸ ≥ max(w, h)`, so the top level is at most 4 × 4 cells.
pub const fn pyramid_levels(width: usize, height: usize) -> usize {
    let side = if width > height { width } else { height };
    let mut levels = 1;
    while 4usize << levels < side {
        levels += 1;
    }
    levels
}

/// `u32` words of the pyramid levels `1..=pyramid_levels(w, h)` (the estimator's
/// `PW`): 188 words (752 B) at 128², 700 (2.7 KiB) at 256².
pub const fn pyramid_words(width: usize, height: usize) -> usize {
    let levels = pyramid_levels(width, height);
    let mut total = 0;
    let mut k = 1;
    while k <= levels {
        total += level_height(height, k) * level_row_words(width, k);
        k += 1;
    }
    total
}

/// Most pyramid levels (W, H ≤ 2048: `4 · 2⁹ ≥ 2048`).
const MAX_LEVELS: usize = 9;

/// Offset, height and row words of each level of a `w × h` pyramid.
const fn layout(width: usize, height: usize) -> [(usize, usize, usize); MAX_LEVELS + 1] {
    let mut out = [(0, 0, 0); MAX_LEVELS + 1];
    let levels = pyramid_levels(width, height);
    let mut offset = 0;
    let mut k = 1;
    while k <= levels && k <= MAX_LEVELS {
        let (h, rw) = (level_height(height, k), level_row_words(width, k));
        out[k] = (offset, h, rw);
        offset += h * rw;
        k += 1;
    }
    out
}

const fn level_width(width: usize, k: usize) -> usize {
    width.div_ceil(1 << k)
}

const fn level_height(height: usize, k: usize) -> usize {
    height.div_ceil(1 << k)
}

const fn level_row_words(width: usize, k: usize) -> usize {
    level_width(width, k).div_ceil(32)
}

/// The OR-pooled levels `1..=L` of a `W × H` grid, level `k` stored row by
/// row, `ceil(W/2ᵏ)` bits per row padded to words.
#[derive(Clone, Debug)]
pub(crate) struct Pyramid<const W: usize, const H: usize, const PW: usize> {
    words: [u32; PW],
}

impl<const W: usize, const H: usize, const PW: usize> Pyramid<W, H, PW> {
    /// An empty pyramid.
    pub(crate) const fn new() -> Self {
        Self { words: [0; PW] }
    }

    const LEVELS: usize = pyramid_levels(W, H);
    /// Per level `k` (index `k`, 0 unused): word offset, height, row words;
    /// evaluated at compile time (no division at run time).
    const LAYOUT: [(usize, usize, usize); MAX_LEVELS + 1] = layout(W, H);

    /// Word offset of level `k ≥ 1`.
    fn offset(k: usize) -> usize {
        Self::LAYOUT.get(k).map_or(PW, |l| l.0)
    }

    /// Rebuilds every level from `grid` (`≈ W·H/16` word operations).
    pub(crate) fn build<const RW: usize>(&mut self, grid: &Grid<W, H, RW>) {
        let rows = grid.words();
        let (first, rest) = self.words.split_at_mut(Self::offset(2).min(PW));
        pool(
            |r| rows.get(r).map(|row| row.as_slice()),
            first,
            level_row_words(W, 1),
            level_height(H, 1),
        );
        let mut below: &mut [u32] = first;
        let mut rest: &mut [u32] = rest;
        for k in 2..=Self::LEVELS {
            let size = level_height(H, k) * level_row_words(W, k);
            let (this, tail) = rest.split_at_mut(size.min(rest.len()));
            let below_rw = level_row_words(W, k - 1);
            let source: &[u32] = below;
            pool(
                |r| source.get(r * below_rw..(r + 1) * below_rw),
                this,
                level_row_words(W, k),
                level_height(H, k),
            );
            below = this;
            rest = tail;
        }
    }

    /// Row `r` of level `k ≥ 1` (empty outside).
    fn row(&self, k: usize, r: i32) -> &[u32] {
        let Some(&(offset, height, rw)) = Self::LAYOUT.get(k) else {
            return &[];
        };
        if r < 0 || r as usize >= height {
            return &[];
        }
        let start = offset + r as usize * rw;
        self.words.get(start..start + rw).unwrap_or(&[])
    }
}

/// Writes `height` pooled rows of `row_words` words into `out`: output bit
/// `(r, c)` = OR of input bits `(2r..2r+2, 2c..2c+2)`.
fn pool<'a>(
    input: impl Fn(usize) -> Option<&'a [u32]>,
    out: &mut [u32],
    row_words: usize,
    height: usize,
) {
    for r in 0..height {
        for o in 0..row_words {
            let word = |i: usize| {
                let row = |j: usize| input(j).and_then(|w| w.get(i)).copied().unwrap_or(0);
                row(2 * r) | row(2 * r + 1)
            };
            let pooled = halve(word(2 * o)) | (halve(word(2 * o + 1)) << 16);
            if let Some(w) = out.get_mut(r * row_words + o) {
                *w = pooled;
            }
        }
    }
}

/// ORs bit pairs `2j, 2j+1` of `w` into bit `j` (16 result bits).
const fn halve(w: u32) -> u32 {
    let mut x = (w | (w >> 1)) & 0x5555_5555;
    x = (x | (x >> 1)) & 0x3333_3333;
    x = (x | (x >> 2)) & 0x0F0F_0F0F;
    x = (x | (x >> 4)) & 0x00FF_00FF;
    (x | (x >> 8)) & 0x0000_FFFF
}

/// Bits `lo..lo + n` of a row (`n ≤ 31`), bit 0 = column `lo`; columns
/// outside the row read 0.
#[inline]
fn bits(row: &[u32], lo: i32, n: u32) -> u32 {
    // Arithmetic shift and mask: floor division and remainder by 32.
    let w = lo >> 5;
    let b = (lo & 31) as u32;
    let word = |i: i32| -> u32 {
        usize::try_from(i)
            .ok()
            .and_then(|i| row.get(i))
            .copied()
            .unwrap_or(0)
    };
    let low = word(w) >> b;
    let high = if b == 0 { 0 } else { word(w + 1) << (32 - b) };
    (low | high) & ((1u32 << n) - 1)
}

/// Whether any of `rows` has a bit in columns `lo..lo + n` (`n ≤ 31`): the
/// word index and shift are computed once for all rows.
#[inline]
fn any_in_columns<const RW: usize>(rows: &[[u32; RW]], lo: i32, n: u32) -> bool {
    let w = lo >> 5;
    let b = (lo & 31) as u32;
    let mask = (1u32 << n) - 1;
    let index = |i: i32| usize::try_from(i).ok().filter(|&i| i < RW);
    match (index(w), index(w + 1)) {
        (Some(i), Some(j)) if b > 0 => rows
            .iter()
            .any(|r| ((r[i] >> b) | (r[j] << (32 - b))) & mask != 0),
        (Some(i), _) => rows.iter().any(|r| (r[i] >> b) & mask != 0),
        (None, Some(j)) if b > 0 => rows.iter().any(|r| (r[j] << (32 - b)) & mask != 0),
        _ => false,
    }
}

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
    view: &'a Grid<W, H, RW>,
    /// Centroid of the sampled view points, centred coordinates × 2.
    centroid_q1: (i32, i32),
    /// `1/s` (Q16): view points are shrunk by it before the pose.
    inv_scale_q16: i64,
    /// View points turned by the current rotation, reference cells.
    cells: [Cell; ALIGN_POINTS],
    count: usize,
}

impl<'a, const W: usize, const H: usize, const RW: usize, const PW: usize>
    Aligner<'a, W, H, RW, PW>
{
    /// An aligner of `view` against `reference`, whose `pyramid` is built;
    /// the view is at scale `s` = 2¹⁶ / `inv_scale_q16` of the reference.
    pub(crate) fn new(
        reference: &'a Grid<W, H, RW>,
        pyramid: &'a Pyramid<W, H, PW>,
        view: &'a Grid<W, H, RW>,
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
            view,
            centroid_q1: ((sx / n) as i32, (sy / n) as i32),
            inv_scale_q16: i64::from(inv_scale_q16),
            cells: [(0, 0); ALIGN_POINTS],
            count: 0,
        }
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

    /// Number of points scored (`min(occupied, align_points(W, H))`).
    pub(crate) fn points(&self) -> u32 {
        self.count as u32
    }

    /// Turns the sampled view points by `−alpha` into the reference cells,
    /// plus `u_q8` (centred reference coordinates, Q8 cells, y up).
    pub(crate) fn rotate<const N: usize>(&mut self, alpha: Angle, u_q8: (i64, i64)) {
        let (cos, sin) = sin_cos_q15::<N>(alpha);
        let mut count = 0;
        for (col, row) in sampled_cells(self.view, align_points(W, H)) {
            let (x, y) = scaled(
                rotate_inverse_q16((cos, sin), centred_q1::<W, H>(col, row)),
                self.inv_scale_q16,
            );
            let cell = to_cell_q16::<W, H>(x + (u_q8.0 << 8), y + (u_q8.1 << 8));
            if let Some(slot) = self.cells.get_mut(count) {
                *slot = (clamp_i16(cell.0), clamp_i16(cell.1));
                count += 1;
            }
        }
        self.count = count;
    }

    /// Score of the rotated points shifted by `(dc, dr)` cells.
    pub(crate) fn score(&self, shift: (i32, i32)) -> u32 {
        self.score_above(shift, 0)
    }

    /// [`Self::score`] if it exceeds `floor`, else 0 (stops as soon as the
    /// points left cannot lift it above `floor`). With `floor` 0 it is the
    /// score itself.
    fn score_above(&self, shift: (i32, i32), floor: u32) -> u32 {
        let mut reachable = 2 * self.points();
        let mut total = 0;
        for &(c, r) in self.turned() {
            let s = point_score(
                self.reference,
                i32::from(c) + shift.0,
                i32::from(r) + shift.1,
            );
            total += s;
            reachable -= 2 - s;
            if floor > 0 && reachable <= floor {
                return 0;
            }
        }
        total
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
    /// widened by one cell). Up to level [`EXACT_LEVELS`] the reach is tested
    /// exactly on the grid's rows (`2ᵏ + 2` rows a point); above, on the
    /// pyramid (2–3 cells of `2ᵏ` per axis: looser, but few blocks are that
    /// large).
    ///
    /// Returns 0 as soon as the bound cannot exceed `floor`.
    fn bound(&self, k: usize, c0: i32, r0: i32, floor: u32) -> u32 {
        let side = 1i32 << k;
        let rows = self.reference.words();
        // 2·hits > floor ⟺ hits ≥ floor/2 + 1: at most this many may miss.
        let Some(allowed) = self.points().checked_sub(floor / 2 + 1) else {
            return 0;
        };
        let mut misses = 0;
        let mut hits = 0;
        for &(c, r) in self.turned() {
            let reached = {
                let (a, b) = (i32::from(c) + c0 - 1, i32::from(r) + r0 - 1);
                if k <= EXACT_LEVELS {
                    let reach = rows
                        .get(b.max(0) as usize..(b + side + 2).clamp(0, H as i32) as usize)
                        .unwrap_or(&[]);
                    any_in_columns(reach, a, (side + 2) as u32)
                } else {
                    let (lo_c, hi_c) = (a >> k, (a + side + 1) >> k);
                    let (lo_r, hi_r) = (b >> k, (b + side + 1) >> k);
                    let n = (hi_c - lo_c + 1) as u32;
                    (lo_r..=hi_r).any(|row| bits(self.pyramid.row(k, row), lo_c, n) != 0)
                }
            };
            if reached {
                hits += 1;
            } else {
                misses += 1;
                if misses > allowed {
                    return 0;
                }
            }
        }
        2 * hits
    }

    /// The best integer shift within `[centre − radius, centre + radius]` in
    /// both axes whose score beats `floor`, by branch and bound; `None` if
    /// none beats it. Ties keep the first found (blocks with the higher
    /// bound first).
    pub(crate) fn search(
        &self,
        centre: (i32, i32),
        radius: i32,
        floor: u32,
    ) -> Option<((i32, i32), u32)> {
        // At most 8 × 8 top blocks of the largest pyramid level.
        let radius = radius.clamp(0, (7 << Pyramid::<W, H, PW>::LEVELS) / 2);
        let span = 2 * radius + 1;
        // Top level: blocks at most a quarter of the window, within the pyramid.
        let mut top = 0usize;
        while top < Pyramid::<W, H, PW>::LEVELS && (4i32 << top) < span {
            top += 1;
        }
        let side = 1i32 << top;
        let blocks = (span + side - 1) / side;
        let origin = (centre.0 - radius, centre.1 - radius);
        let mut tops: heapless::Vec<(u32, i32, i32), TOP_BLOCKS> = heapless::Vec::new();
        for i in 0..blocks {
            for j in 0..blocks {
                let (c0, r0) = (origin.0 + j * side, origin.1 + i * side);
                let b = if top == 0 {
                    self.score_above((c0, r0), floor)
                } else {
                    self.bound(top, c0, r0, floor)
                };
                if b > floor {
                    let _ = tops.push((b, c0, r0));
                }
            }
        }
        let mut best: Option<((i32, i32), u32)> = None;
        let mut floor = floor;
        let last = (origin.0 + span - 1, origin.1 + span - 1);
        // Highest bound first.
        sort_descending(&mut tops, |t| t.0);
        let mut stack: heapless::Vec<(usize, i32, i32, u32), STACK> = heapless::Vec::new();
        for &(b, c0, r0) in &tops {
            if b <= floor {
                break;
            }
            let _ = stack.push((top, c0, r0, b));
            while let Some((k, c0, r0, b)) = stack.pop() {
                if b <= floor || c0 > last.0 || r0 > last.1 {
                    continue;
                }
                if k == 0 {
                    // At level 0 the bound is the score.
                    floor = b;
                    best = Some(((c0, r0), b));
                    continue;
                }
                let half = 1i32 << (k - 1);
                let mut children = [(0u32, 0i32, 0i32); 4];
                for (n, child) in children.iter_mut().enumerate() {
                    let (c, r) = (c0 + half * (n as i32 & 1), r0 + half * (n as i32 >> 1));
                    let cb = if c > last.0 || r > last.1 {
                        0
                    } else if k == 1 {
                        self.score_above((c, r), floor)
                    } else {
                        self.bound(k - 1, c, r, floor)
                    };
                    *child = (cb, c, r);
                }
                // Push the lowest first so the highest is explored first.
                children.sort_unstable_by_key(|c| c.0);
                for (cb, c, r) in children {
                    if cb > floor {
                        let _ = stack.push((k - 1, c, r, cb));
                    }
                }
            }
        }
        best
    }
}

/// Levels whose bound is tested exactly on the grid rows (`2ᵏ + 2 ≤ 10`
/// rows and bits a point).
const EXACT_LEVELS: usize = 3;

/// Most top-level blocks of one search (window ≤ 4·2ᴸ + … per axis).
const TOP_BLOCKS: usize = 64;
/// Depth-first stack: 4 children per level, 12 levels at most (W ≤ 2048).
const STACK: usize = 48;

/// Score of reference cell `(c, r)`: 2 occupied, 1 a neighbour occupied, else 0.
fn point_score<const W: usize, const H: usize, const RW: usize>(
    grid: &Grid<W, H, RW>,
    c: i32,
    r: i32,
) -> u32 {
    let rows = grid.words();
    let row = |r: i32| -> &[u32] {
        if r < 0 {
            &[]
        } else {
            rows.get(r as usize).map_or(&[], |w| w.as_slice())
        }
    };
    let middle = bits(row(r), c - 1, 3);
    if middle & 2 != 0 {
        2
    } else if middle != 0 || bits(row(r - 1), c - 1, 3) != 0 || bits(row(r + 1), c - 1, 3) != 0 {
        1
    } else {
        0
    }
}

/// Up to `max` occupied cells `(col, row)` of `grid`, spread evenly in
/// raster order.
fn sampled_cells<const W: usize, const H: usize, const RW: usize>(
    grid: &Grid<W, H, RW>,
    max: usize,
) -> impl Iterator<Item = (usize, usize)> + '_ {
    let occupied = grid.occupied() as usize;
    let keep = max.min(occupied);
    grid.occupied_cells()
        .enumerate()
        .filter(move |&(i, _)| {
            // Cell i is kept when ⌊(i + 1)·keep / occupied⌋ steps up.
            occupied > 0 && ((i + 1) * keep / occupied) > (i * keep / occupied)
        })
        .map(|(_, cell)| cell)
}

/// Centred coordinates of cell `(col, row)` times 2 (exact integers):
/// `2x = 2·col − (W − 1)`, `2y = (H − 1) − 2·row`.
fn centred_q1<const W: usize, const H: usize>(col: usize, row: usize) -> (i32, i32) {
    (
        2 * col as i32 - (W as i32 - 1),
        (H as i32 - 1) - 2 * row as i32,
    )
}

/// `p · inv_scale` for `p` in Q16 and `inv_scale` in Q16.
fn scaled((x, y): (i64, i64), inv_scale_q16: i64) -> (i64, i64) {
    if inv_scale_q16 == 1 << 16 {
        return (x, y);
    }
    ((x * inv_scale_q16) >> 16, (y * inv_scale_q16) >> 16)
}

/// `R(−α)·p` for `p` in Q1 and `(cos α, sin α)` in Q15: Q16.
fn rotate_inverse_q16((cos, sin): (i32, i32), (x, y): (i32, i32)) -> (i64, i64) {
    let (x, y, cos, sin) = (i64::from(x), i64::from(y), i64::from(cos), i64::from(sin));
    (cos * x + sin * y, cos * y - sin * x)
}

/// The reference cell nearest the centred point `(x, y)` (Q16).
fn to_cell_q16<const W: usize, const H: usize>(x: i64, y: i64) -> (i64, i64) {
    let col = x + ((W as i64 - 1) << 15);
    let row = ((H as i64 - 1) << 15) - y;
    ((col + (1 << 15)) >> 16, (row + (1 << 15)) >> 16)
}

fn clamp_i16(v: i64) -> i16 {
    v.clamp(i64::from(i16::MIN), i64::from(i16::MAX)) as i16
}

/// `(cos α, sin α)` in Q15 for any binary angle: the nearest entry of the
/// `N`-step table turned by the remainder `δ` (`|δ| ≤ π/N`) with
/// `cos δ ≈ 1 − δ²/2`, `sin δ ≈ δ` (error < 2·10⁻⁵ for `N ≥ 90`).
pub(crate) fn sin_cos_q15<const N: usize>(alpha: Angle) -> (i32, i32) {
    let table = &TrigTable::<N>::TABLE;
    let k = alpha.nearest_step(N);
    let base = Angle::from_steps_q16((k as i64) << 16, N);
    // δ in binary turns (2³² a turn) → Q15 radians: × 2π·2¹⁵/2³² = × π/2¹⁶,
    // with π·2²⁹ = 1 686 629 713 (|δ| ≤ 2³¹/N: the product fits i64).
    let delta = i64::from(alpha.0.wrapping_sub(base.0) as i32);
    let delta_q15 = (delta * 1_686_629_713) >> 45;
    let (c, s) = (i64::from(table.cos(k)), i64::from(table.sin(k)));
    let half_sq = (delta_q15 * delta_q15) >> 16; // δ²/2, Q15
    let cos_d = (1 << 15) - half_sq;
    let cos = (c * cos_d - s * delta_q15) >> 15;
    let sin = (s * cos_d + c * delta_q15) >> 15;
    (cos as i32, sin as i32)
}

/// ICP of up to [`icp_points`] view cells onto the reference's occupied
/// cells, starting from `start`. Each iteration pairs every view cell with
/// the nearest occupied reference cell within one cell, then solves the
/// small rigid motion point to line (the line through the reference cells
/// within 2 cells of the match, where they form one: synthetic polygons 128²,
/// median 0.19° → 0.15° against point to point) or, with fewer than 8 such
/// pairs, point to point; until the step is below 1/128 cell and 2⁻¹⁴ rad or
/// after [`ICP_ITERATIONS`]. The view is shrunk by
/// `inv_scale_q16` first (the scale stays fixed). Returns the refined
/// rotation and the translation `u` in centred reference coordinates (Q8
/// cells, y up).
///
/// Fixed point: positions in Q8 cells (|·| < 2²⁰ for W, H ≤ 2048 and
/// s ≥ ½), sums in `i64` (< 2⁵¹ with ≤ 512 points). More points than the
/// search scores: the refinement averages their residuals (synthetic
/// polygons 128², point to point, 128 → all cells: median 0.33° → 0.22°).
pub(crate) fn refine<const W: usize, const H: usize, const RW: usize, const N: usize>(
    reference: &Grid<W, H, RW>,
    view: &Grid<W, H, RW>,
    start: &Placement,
    inv_scale_q16: u32,
) -> (Angle, (i64, i64)) {
    let mut alpha = start.alpha;
    // Cells (Δcol, Δrow) → centred (Δx, Δy) = (Δcol, −Δrow), Q8.
    let mut u = (
        i64::from(start.shift.0) << 8,
        -(i64::from(start.shift.1) << 8),
    );
    // Point to point (cheap) until the steps are small, then point to line
    // (a normal per match) for the last few.
    let mut line_iterations = 0;
    for _ in 0..ICP_ITERATIONS {
        let to_line = line_iterations > 0;
        let (cos, sin) = sin_cos_q15::<N>(alpha);
        let mut sums = PairSums::default();
        let mut lines = LineSums::default();
        for (col, row) in sampled_cells(view, icp_points(W, H)) {
            let (x, y) = scaled(
                rotate_inverse_q16((cos, sin), centred_q1::<W, H>(col, row)),
                i64::from(inv_scale_q16),
            );
            let q = ((x >> 8) + u.0, (y >> 8) + u.1);
            if let Some((m, cell)) = nearest_occupied::<W, H, RW>(reference, q) {
                sums.add(q, m);
                if let Some(n) = to_line.then(|| local_normal(reference, cell)).flatten() {
                    lines.add(q, m, n);
                }
            }
        }
        // Point to line where the reference shows a line (sub-cell along the
        // wall does not pull), point to point otherwise.
        let solved = lines.solve().or_else(|| sums.solve());
        let Some((delta_q16, step)) = solved else {
            break;
        };
        // q' = R(δ)·q + step; q = R(−α)·p + u ⇒ α' = α − δ, u' = R(δ)·u + step.
        let (cd, sd) = small_rotation_q16(delta_q16);
        u = (
            ((cd * u.0 - sd * u.1) >> 16) + step.0,
            ((sd * u.0 + cd * u.1) >> 16) + step.1,
        );
        alpha = alpha + Angle(radians_q16_to_turns(-delta_q16) as u32);
        let small = delta_q16.abs() < 64 && step.0.abs() < 32 && step.1.abs() < 32;
        let converged = delta_q16.abs() < 4 && step.0.abs() < 2 && step.1.abs() < 2;
        if to_line {
            line_iterations += 1;
            if converged || line_iterations > LINE_ITERATIONS {
                break;
            }
        } else if small || converged {
            line_iterations = 1;
        }
    }
    (alpha, u)
}

/// ICP iterations at most.
const ICP_ITERATIONS: usize = 15;
/// Point-to-line iterations at most, after the point-to-point ones have
/// settled (steps below 1/8 cell and 0.06°).
const LINE_ITERATIONS: usize = 3;

/// Largest rotation one ICP step may make, Q16 radians (≈ 2.9°).
const MAX_ICP_STEP_Q16: i64 = 3277;

/// Radians (Q16) to binary turns (× 2³²/2π).
fn radians_q16_to_turns(rad_q16: i64) -> i64 {
    // 2³² / 2π = 683 565 275.6; × rad_q16 / 2¹⁶.
    (rad_q16 * 683_565_276) >> 16
}

/// `(cos δ, sin δ)` in Q16 for a small δ in Q16 radians.
fn small_rotation_q16(delta_q16: i64) -> (i64, i64) {
    let half_sq = (delta_q16 * delta_q16) >> 17;
    ((1 << 16) - half_sq, delta_q16)
}

/// A match of the ICP: the reference cell's centre (centred, Q8) and the
/// cell `(col, row)`.
type Match = ((i64, i64), (i64, i64));

/// Centre of the occupied reference cell nearest `q` (centred, Q8) among the
/// 3 × 3 cells around it, in centred Q8 coordinates.
fn nearest_occupied<const W: usize, const H: usize, const RW: usize>(
    grid: &Grid<W, H, RW>,
    (x, y): (i64, i64),
) -> Option<Match> {
    // Cell coordinates in Q8: col = x + (W − 1)/2, row = (H − 1)/2 − y.
    let col_q8 = x + ((W as i64 - 1) << 7);
    let row_q8 = ((H as i64 - 1) << 7) - y;
    let (c, r) = ((col_q8 + 128) >> 8, (row_q8 + 128) >> 8);
    let mut best: Option<(i64, Match)> = None;
    for dr in -1..=1 {
        for dc in -1..=1 {
            let (cc, rr) = (c + dc, r + dr);
            if cc < 0 || rr < 0 || !grid.get(cc as usize, rr as usize) {
                continue;
            }
            let (ex, ey) = ((cc << 8) - col_q8, (rr << 8) - row_q8);
            let d = ex * ex + ey * ey;
            if best.is_none_or(|(bd, _)| d < bd) {
                let centre = (
                    (cc << 8) - ((W as i64 - 1) << 7),
                    ((H as i64 - 1) << 7) - (rr << 8),
                );
                best = Some((d, (centre, (cc, rr))));
            }
        }
    }
    best.map(|(_, m)| m)
}

/// Unit normal (Q14, centred y-up frame) of the line the occupied cells
/// within 2 cells of `(col, row)` form: the minor axis of their scatter.
/// `None` with fewer than 3 cells or no clear direction (the major axis'
/// variance less than 4 times the minor one's: a corner or a blob).
fn local_normal<const W: usize, const H: usize, const RW: usize>(
    grid: &Grid<W, H, RW>,
    (c, r): (i64, i64),
) -> Option<(i64, i64)> {
    let (mut n, mut sx, mut sy, mut sxx, mut syy, mut sxy) = (0i64, 0i64, 0i64, 0i64, 0i64, 0i64);
    for dr in -2i64..=2 {
        for dc in -2i64..=2 {
            let (cc, rr) = (c + dc, r + dr);
            if cc < 0 || rr < 0 || !grid.get(cc as usize, rr as usize) {
                continue;
            }
            // y up: Δy = −Δrow.
            let (dx, dy) = (dc, -dr);
            n += 1;
            sx += dx;
            sy += dy;
            sxx += dx * dx;
            syy += dy * dy;
            sxy += dx * dy;
        }
    }
    if n < 3 {
        return None;
    }
    // n² × the scatter matrix [[a, b], [b, d]].
    let a = n * sxx - sx * sx;
    let d = n * syy - sy * sy;
    let b = n * sxy - sx * sy;
    let root = (((a - d) * (a - d) + 4 * b * b) as u64).isqrt() as i64;
    let (major, minor) = (a + d + root, a + d - root); // twice the eigenvalues
    if major < 4 * minor || major <= 0 {
        return None;
    }
    // Major-axis direction, from whichever row of (M − λ) is better
    // conditioned; the normal is perpendicular to it.
    let (vx, vy) = if a >= d {
        (major - 2 * d, 2 * b)
    } else {
        (2 * b, major - 2 * a)
    };
    let len = ((vx * vx + vy * vy) as u64).isqrt() as i64;
    if len == 0 {
        return None;
    }
    Some(((-vy << 14) / len, (vx << 14) / len))
}

/// Sums of the point-to-line normal equations: unknowns δ (Q16 rad) and the
/// step τ (Q8 cells); each pair adds `a = (n·J q / 2¹⁶, n_x, n_y)` and
/// `e = n·(m − q)` (`J q = (−q_y, q_x)`).
#[derive(Default)]
struct LineSums {
    count: i64,
    h: [[i128; 3]; 3],
    g: [i128; 3],
}

impl LineSums {
    fn add(&mut self, q: (i64, i64), m: (i64, i64), n: (i64, i64)) {
        let a = [
            i128::from((n.1 * q.0 - n.0 * q.1) >> 16),
            i128::from(n.0),
            i128::from(n.1),
        ];
        let e = i128::from(n.0 * (m.0 - q.0) + n.1 * (m.1 - q.1));
        for i in 0..3 {
            for j in 0..3 {
                self.h[i][j] += a[i] * a[j];
            }
            self.g[i] += a[i] * e;
        }
        self.count += 1;
    }

    /// δ (Q16 rad, clamped) and the step (Q8), or `None` with fewer than 8
    /// pairs or a singular system.
    fn solve(&self) -> Option<(i64, (i64, i64))> {
        if self.count < 8 {
            return None;
        }
        let mut h = self.h;
        let mut g = self.g;
        // A small pull of τ towards 0 keeps an unobservable direction (a
        // corridor) where the search put it.
        let ridge = (h[1][1] + h[2][2]) >> 12;
        h[1][1] += ridge.max(1);
        h[2][2] += ridge.max(1);
        // Scale so every entry is below 2⁴⁰: 3-term products stay in i128.
        let big = h
            .iter()
            .flatten()
            .chain(g.iter())
            .map(|v| v.unsigned_abs())
            .max()
            .unwrap_or(0);
        let shift = (128 - big.leading_zeros()).saturating_sub(40);
        for v in h.iter_mut().flatten().chain(g.iter_mut()) {
            *v >>= shift;
        }
        let det3 = |m: &[[i128; 3]; 3]| {
            m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
        };
        let det = det3(&h);
        if det <= 0 {
            return None;
        }
        let mut x = [0i128; 3];
        for (i, xi) in x.iter_mut().enumerate() {
            let mut m = h;
            for (row, gv) in m.iter_mut().zip(g) {
                row[i] = gv;
            }
            *xi = det3(&m) / det;
        }
        let delta = (x[0] as i64).clamp(-MAX_ICP_STEP_Q16, MAX_ICP_STEP_Q16);
        // τ is in Q8: limit a step to 2 cells.
        let step = (
            (x[1] as i64).clamp(-512, 512),
            (x[2] as i64).clamp(-512, 512),
        );
        Some((delta, step))
    }
}

/// Running sums of matched pairs `(q, m)` (Q8).
#[derive(Default)]
struct PairSums {
    n: i64,
    q: (i64, i64),
    m: (i64, i64),
    /// Σ q·m (dot) and Σ q × m (cross), Q16.
    dot: i64,
    cross: i64,
}

impl PairSums {
    fn add(&mut self, q: (i64, i64), m: (i64, i64)) {
        self.n += 1;
        self.q = (self.q.0 + q.0, self.q.1 + q.1);
        self.m = (self.m.0 + m.0, self.m.1 + m.1);
        self.dot += q.0 * m.0 + q.1 * m.1;
        self.cross += q.0 * m.1 - q.1 * m.0;
    }

    /// The small rotation δ (Q16 rad) and the step (Q8) of the rigid motion
    /// `m ≈ R(δ)·q + step`, or `None` with fewer than 3 pairs or no spread.
    fn solve(&self) -> Option<(i64, (i64, i64))> {
        if self.n < 3 {
            return None;
        }
        let n = self.n;
        // Centred sums: Σ(q − q̄)·(m − m̄) = Σ q·m − Σq·Σm / n.
        let dot = self.dot - (self.q.0 * self.m.0 + self.q.1 * self.m.1) / n;
        let cross = self.cross - (self.q.0 * self.m.1 - self.q.1 * self.m.0) / n;
        if dot <= 0 {
            return None;
        }
        let delta = ((cross << 16) / dot).clamp(-MAX_ICP_STEP_Q16, MAX_ICP_STEP_Q16);
        let (cd, sd) = small_rotation_q16(delta);
        let (qx, qy) = (self.q.0 / n, self.q.1 / n);
        let (mx, my) = (self.m.0 / n, self.m.1 / n);
        let step = (
            mx - ((cd * qx - sd * qy) >> 16),
            my - ((sd * qx + cd * qy) >> 16),
        );
        Some((delta, step))
    }
}

/// Sorts `items` by `key`, largest first (insertion sort: a few items, and
/// no panic path, unlike `sort_unstable_by`'s order-violation check).
pub(crate) fn sort_descending<T: Copy>(items: &mut [T], key: impl Fn(&T) -> u32) {
    for i in 1..items.len() {
        let mut j = i;
        while j > 0 && key(&items[j - 1]) < key(&items[j]) {
            items.swap(j - 1, j);
            j -= 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halve_ors_bit_pairs() {
        assert_eq!(halve(0b11), 1);
        assert_eq!(halve(0b10_0100), 0b110);
        assert_eq!(halve(0x8000_0000), 0x8000);
    }

    #[test]
    fn bits_reads_across_words_and_outside() {
        let row = [0x8000_0000u32, 0x1];
        assert_eq!(bits(&row, 31, 2), 0b11);
        assert_eq!(bits(&row, 30, 3), 0b110);
        assert_eq!(bits(&row, -2, 3), 0);
        assert_eq!(bits(&row, 63, 3), 0);
    }

    #[test]
    fn pyramid_sizes() {
        assert_eq!(pyramid_levels(128, 128), 5);
        assert_eq!(pyramid_words(128, 128), 188);
        assert_eq!(pyramid_levels(256, 256), 6);
        assert_eq!(pyramid_words(256, 256), 700);
    }

    #[test]
    fn sin_cos_between_steps() {
        for deg in [0.0f32, 0.4, 1.3, 45.5, 91.7, 179.9, 200.25, 359.6] {
            let (c, s) = sin_cos_q15::<360>(Angle::from_degrees(deg));
            let r = f64::from(deg).to_radians();
            assert!((f64::from(c) / 32768.0 - r.cos()).abs() < 1e-4, "{deg}");
            assert!((f64::from(s) / 32768.0 - r.sin()).abs() < 1e-4, "{deg}");
        }
    }
}
