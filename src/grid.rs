//! Bounded, bit-packed occupancy grid: the binary image the method works on.
//!
//! Cell `(col, row)` is bit `col % 32` of word `col / 32` of row `row`; row 0 is
//! the top of the image. Coordinates used by the method (DESIGN.md §2):
//! `x = col − (W−1)/2`, `y = (H−1)/2 − row` (origin at the centre, y up).

use crate::error::Error;

/// A `W × H` binary image, one bit per cell, `ROW_WORDS = row_words(W)` words
/// per row (use the [`grid!`](crate::grid) macro to fill it in).
///
/// Size: `4 · ROW_WORDS · H` bytes (128² → 2 KiB). Bits beyond `W` in the last
/// word of a row are always zero.
#[derive(Clone, PartialEq, Eq, Debug)]
pub struct Grid<const W: usize, const H: usize, const ROW_WORDS: usize> {
    rows: [[u32; ROW_WORDS]; H],
}

impl<const W: usize, const H: usize, const ROW_WORDS: usize> Default for Grid<W, H, ROW_WORDS> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const W: usize, const H: usize, const ROW_WORDS: usize> Grid<W, H, ROW_WORDS> {
    /// Grid width in cells.
    pub const WIDTH: usize = W;
    /// Grid height in cells.
    pub const HEIGHT: usize = H;

    /// An empty grid.
    pub const fn new() -> Self {
        const { crate::config::check_grid(W, H, ROW_WORDS) };
        Self {
            rows: [[0; ROW_WORDS]; H],
        }
    }

    /// A grid from raw row words (e.g. a `const` table in flash). Bits beyond
    /// `W` are cleared.
    pub const fn from_words(mut rows: [[u32; ROW_WORDS]; H]) -> Self {
        const { crate::config::check_grid(W, H, ROW_WORDS) };
        let mut r = 0;
        while r < H {
            rows[r][ROW_WORDS - 1] &= Self::last_word_mask();
            r += 1;
        }
        Self { rows }
    }

    const fn last_word_mask() -> u32 {
        match W % 32 {
            0 => u32::MAX,
            used => (1u32 << used) - 1,
        }
    }

    /// The raw row words.
    pub const fn words(&self) -> &[[u32; ROW_WORDS]; H] {
        &self.rows
    }

    /// Marks cell `(col, row)` occupied.
    ///
    /// # Errors
    /// [`Error::OutOfBounds`] if `col ≥ W` or `row ≥ H`; the grid is unchanged.
    pub fn set(&mut self, col: usize, row: usize) -> Result<(), Error> {
        self.assign(col, row, true)
    }

    /// Marks cell `(col, row)` free.
    ///
    /// # Errors
    /// [`Error::OutOfBounds`] if `col ≥ W` or `row ≥ H`; the grid is unchanged.
    pub fn clear(&mut self, col: usize, row: usize) -> Result<(), Error> {
        self.assign(col, row, false)
    }

    fn assign(&mut self, col: usize, row: usize, occupied: bool) -> Result<(), Error> {
        if col >= W {
            return Err(Error::OutOfBounds { rejected: 1 });
        }
        let word = self
            .rows
            .get_mut(row)
            .and_then(|r| r.get_mut(col / 32))
            .ok_or(Error::OutOfBounds { rejected: 1 })?;
        let bit = 1u32 << (col % 32);
        if occupied {
            *word |= bit;
        } else {
            *word &= !bit;
        }
        Ok(())
    }

    /// Whether cell `(col, row)` is occupied; `false` outside the grid.
    pub fn get(&self, col: usize, row: usize) -> bool {
        col < W
            && self
                .rows
                .get(row)
                .and_then(|r| r.get(col / 32))
                .is_some_and(|w| w & (1 << (col % 32)) != 0)
    }

    /// Marks every `(col, row)` of `cells` occupied.
    ///
    /// # Errors
    /// [`Error::OutOfBounds`] with the number of cells outside the grid; all
    /// in-range cells were still set.
    pub fn set_cells<I: IntoIterator<Item = (usize, usize)>>(
        &mut self,
        cells: I,
    ) -> Result<(), Error> {
        let mut rejected = 0u32;
        for (col, row) in cells {
            if self.set(col, row).is_err() {
                rejected = rejected.saturating_add(1);
            }
        }
        match rejected {
            0 => Ok(()),
            rejected => Err(Error::OutOfBounds { rejected }),
        }
    }

    /// Marks the cell containing point `(x, y)` occupied, in the centred, y-up
    /// coordinates of DESIGN.md §2 (units: cells; the cell centres are at
    /// `x = col − (W−1)/2`).
    ///
    /// # Errors
    /// [`Error::OutOfBounds`] if the point is outside the grid or not finite.
    pub fn set_point(&mut self, x: f32, y: f32) -> Result<(), Error> {
        let col = x + (W as f32 - 1.0) * 0.5 + 0.5;
        let row = (H as f32 - 1.0) * 0.5 - y + 0.5;
        // NaN fails both comparisons.
        if !(col >= 0.0 && col < W as f32 && row >= 0.0 && row < H as f32) {
            return Err(Error::OutOfBounds { rejected: 1 });
        }
        self.set(col as usize, row as usize)
    }

    /// Marks the cell containing point `(x, y)` occupied, in the centred,
    /// y-up coordinates of [`set_point`](Self::set_point) in Q16 (cells ×
    /// 2¹⁶, both within ±(2³¹ − 2²⁶)); whether it is inside the grid.
    /// Integer only: the scan rasterizer's setter (the cell is `⌊x + W/2⌋`,
    /// `⌊H/2 − y⌋`, as `set_point` computes it in `f32`).
    #[inline(always)]
    pub(crate) fn set_q16(&mut self, x: i32, y: i32) -> bool {
        // W, H ≤ 2048: W·2¹⁵ ≤ 2²⁶, so nothing wraps in range.
        let col = x.wrapping_add((W as i32) << 15) >> 16;
        let row = ((H as i32) << 15).wrapping_sub(y) >> 16;
        if col < 0 || col as usize >= W {
            return false;
        }
        match self
            .rows
            .get_mut(row as usize)
            .and_then(|r| r.get_mut(col as usize / 32))
        {
            Some(word) => {
                *word |= 1 << (col % 32);
                true
            }
            None => false,
        }
    }

    /// Clears every cell.
    pub fn clear_all(&mut self) {
        self.rows = [[0; ROW_WORDS]; H];
    }

    /// Number of occupied cells.
    pub const fn occupied(&self) -> u32 {
        let mut total = 0;
        let mut r = 0;
        while r < H {
            let mut w = 0;
            while w < ROW_WORDS {
                total += self.rows[r][w].count_ones();
                w += 1;
            }
            r += 1;
        }
        total
    }

    /// The smallest box holding every occupied cell, `None` for an empty
    /// grid. One pass over the words (`H · ROW_WORDS` loads).
    pub(crate) fn occupied_bounds(&self) -> Option<CellBounds> {
        let mut union = [0u32; ROW_WORDS];
        let mut rows: Option<(usize, usize)> = None;
        for (row, words) in self.rows.iter().enumerate() {
            let mut any = 0;
            for (u, &w) in union.iter_mut().zip(words) {
                *u |= w;
                any |= w;
            }
            if any != 0 {
                rows = Some((rows.map_or(row, |(first, _)| first), row));
            }
        }
        let (first_row, last_row) = rows?;
        let first_word = union.iter().position(|&w| w != 0)?;
        let last_word = union.iter().rposition(|&w| w != 0)?;
        let low = union.get(first_word).copied().unwrap_or(0);
        let high = union.get(last_word).copied().unwrap_or(0);
        Some(CellBounds {
            first_col: 32 * first_word + low.trailing_zeros() as usize,
            last_col: 32 * last_word + 31 - high.leading_zeros() as usize,
            first_row,
            last_row,
        })
    }

    /// The occupied cells `(col, row)` in raster order (row 0 first, then by
    /// column), skipping empty words.
    pub fn occupied_cells(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.rows.iter().enumerate().flat_map(|(row, words)| {
            words.iter().enumerate().flat_map(move |(w, &word)| {
                SetBits(word).map(move |bit| (32 * w + bit as usize, row))
            })
        })
    }
}

/// The bounding box of a grid's occupied cells, inclusive, in cells
/// ([`Grid::occupied_bounds`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct CellBounds {
    /// Leftmost occupied column.
    pub(crate) first_col: usize,
    /// Rightmost occupied column.
    pub(crate) last_col: usize,
    /// Topmost occupied row.
    pub(crate) first_row: usize,
    /// Bottommost occupied row.
    pub(crate) last_row: usize,
}

/// The set bits of a word, lowest first.
struct SetBits(u32);

impl Iterator for SetBits {
    type Item = u32;

    fn next(&mut self) -> Option<u32> {
        if self.0 == 0 {
            return None;
        }
        let bit = self.0.trailing_zeros();
        self.0 &= self.0 - 1;
        Some(bit)
    }
}

#[cfg(test)]
mod tests {
    type G = Grid<40, 3, 2>;
    use super::*;

    #[test]
    fn set_get_and_bounds() {
        let mut g = G::new();
        assert_eq!(g.set(39, 2), Ok(()));
        assert!(g.get(39, 2));
        assert_eq!(g.set(40, 0), Err(Error::OutOfBounds { rejected: 1 }));
        assert_eq!(g.set(0, 3), Err(Error::OutOfBounds { rejected: 1 }));
        assert_eq!(
            g.set_cells([(1, 1), (99, 1), (2, 9)]),
            Err(Error::OutOfBounds { rejected: 2 })
        );
        assert_eq!(g.occupied(), 2);
        g.clear(39, 2).unwrap();
        assert_eq!(g.occupied(), 1);
    }

    #[test]
    fn points_map_to_centred_cells() {
        let mut g = Grid::<4, 4, 1>::new();
        // Cell centres are at x ∈ {−1.5, −0.5, 0.5, 1.5}, y likewise (row 0 at y = 1.5).
        g.set_point(-1.5, 1.5).unwrap();
        assert!(g.get(0, 0));
        g.set_point(1.6, -1.4).unwrap();
        assert!(g.get(3, 3));
        assert!(g.set_point(2.1, 0.0).is_err());
        assert!(g.set_point(f32::NAN, 0.0).is_err());
        assert_eq!(g.occupied(), 2);
    }

    #[test]
    fn occupied_bounds_is_the_bounding_box() {
        assert_eq!(G::new().occupied_bounds(), None);
        let mut g = G::new();
        g.set(5, 1).unwrap();
        let one = CellBounds {
            first_col: 5,
            last_col: 5,
            first_row: 1,
            last_row: 1,
        };
        assert_eq!(g.occupied_bounds(), Some(one));
        g.set_cells([(39, 0), (31, 2), (32, 1)]).unwrap();
        let all = CellBounds {
            first_col: 5,
            last_col: 39,
            first_row: 0,
            last_row: 2,
        };
        assert_eq!(g.occupied_bounds(), Some(all));
        // Random grids against the definition.
        let mut state = 0x1234_5678_9abc_def0u64;
        for _ in 0..200 {
            let mut g = Grid::<70, 9, 3>::new();
            let cells = (state % 6) as usize;
            for _ in 0..cells {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let col = (state >> 33) as usize % 70;
                let row = (state >> 45) as usize % 9;
                g.set(col, row).unwrap();
            }
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1);
            let expected = g
                .occupied_cells()
                .fold(None, |b: Option<CellBounds>, (c, r)| {
                    Some(match b {
                        None => CellBounds {
                            first_col: c,
                            last_col: c,
                            first_row: r,
                            last_row: r,
                        },
                        Some(b) => CellBounds {
                            first_col: b.first_col.min(c),
                            last_col: b.last_col.max(c),
                            first_row: b.first_row.min(r),
                            last_row: b.last_row.max(r),
                        },
                    })
                });
            assert_eq!(g.occupied_bounds(), expected);
        }
    }

    #[test]
    fn from_words_masks_bits_beyond_width() {
        let g = G::from_words([[u32::MAX; 2]; 3]);
        assert_eq!(g.occupied(), 3 * 40);
    }
}
