//! Reach tables: for the upper exact levels `k` of the branch and bound
//! ([`search`](super::search)), which `(2ᵏ + 2)`-cell squares of the
//! reference hold an occupied cell, one bit a square.
//!
//! A bound at level `k` asks, for each sampled point, whether the square of
//! side `2ᵏ + 2` cells at the point's shifted position holds an occupied
//! reference cell (its reach). Read from the grid that is `2ᵏ + 2` rows a
//! point; from the level's table it is one bit. The tables are the same for
//! every rotation and candidate of a reference, so they are built with it
//! (feature `reach-tables`, on by default): levels 2 to 4, 3 grids,
//! `12 · ROW_WORDS · H` bytes (6 KiB at 128², 24 KiB at 256²). Level 1 (4
//! rows a point) reads the grid: its table costs another grid (feature
//! `reach-tables-level-1`, which the host tool enables) for about 6 % of
//! the verified estimate on the M4F (real pairs at 128²: median 10.7 M →
//! 10.1 M instructions) and 15 % of the tool's time on the shared pairs,
//! and without it a reference built at run time, with its tables, keeps
//! the verified estimate within 16 KiB of RAM (issue 40). The answers are
//! those of the rows, bit for bit.

use crate::grid::Grid;

/// Levels whose bound is tested exactly on the grid rows (`2ᵏ + 2 ≤ 18`
/// rows and bits a point, within the 31 bits of [`any_in_columns`](crate::pose::pyramid::any_in_columns)): the
/// exact bound at level 4 prunes so much more than the pyramid's that it
/// pays for its longer reach (budget scene, M4F: 15.1 M → 12.3 M
/// instructions with 4 instead of 3).
pub(crate) const EXACT_LEVELS: usize = 4;

/// The lowest level with a table: 2, where level 1 reads its 4 rows from
/// the grid; 1 with the feature `reach-tables-level-1` (a grid more, for
/// hosts).
const FIRST_TABLE_LEVEL: usize = if cfg!(feature = "reach-tables-level-1") {
    1
} else {
    2
};

/// How many levels have a table: [`FIRST_TABLE_LEVEL`]`..=`[`EXACT_LEVELS`].
const TABLE_LEVELS: usize = EXACT_LEVELS + 1 - FIRST_TABLE_LEVEL;

/// The squares of side `2ᵏ + 2` (`k =`
/// [`FIRST_TABLE_LEVEL`]`..=`[`EXACT_LEVELS`]) of a grid that
/// hold an occupied cell: bit `(c, r)` of level `k` is set when a cell of
/// `[c, c + 2ᵏ + 2) × [r, r + 2ᵏ + 2)` is (cells outside the grid are
/// free; bits past column `W` are clear, as in a [`Grid`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct ReachTables<const W: usize, const H: usize, const RW: usize> {
    levels: [[[u32; RW]; H]; TABLE_LEVELS],
}

// Built and read only with the feature (a `Reference` keeps them); the
// tests check them either way.
#[cfg_attr(not(feature = "reach-tables"), allow(dead_code))]
impl<const W: usize, const H: usize, const RW: usize> ReachTables<W, H, RW> {
    /// Tables in which no square reaches anything, to [`build`](Self::build) in place.
    pub(crate) const EMPTY: Self = Self {
        levels: [[[0; RW]; H]; TABLE_LEVELS],
    };

    /// The tables of `grid`.
    pub(crate) const fn of(grid: &Grid<W, H, RW>) -> Self {
        let mut tables = Self::EMPTY;
        tables.build(grid);
        tables
    }

    /// Makes these the tables of `grid`, in place (no grid-sized temporary:
    /// a reference built at run time needs no more stack for its tables),
    /// each level from the one below (a square of side `2ᵏ + 2` is four of
    /// side `2ᵏ⁻¹ + 2`, `2ᵏ⁻¹` apart): about `12 · RW · H` word operations
    /// a level. A `const fn`: a reference parsed at compile time carries
    /// its tables in flash.
    pub(crate) const fn build(&mut self, grid: &Grid<W, H, RW>) {
        // Squares of side 2 and 3 (level 0) from the grid, grown in the
        // first table up to its level.
        copy_rows(&mut self.levels[0], grid.words());
        grow(&mut self.levels[0], 1);
        grow(&mut self.levels[0], 1);
        let mut k = 1;
        while k <= EXACT_LEVELS {
            // Each level past the first with a table starts from the one below.
            let table = k.saturating_sub(FIRST_TABLE_LEVEL);
            if k > FIRST_TABLE_LEVEL {
                let (below, level) = self.levels.split_at_mut(table);
                copy_rows(&mut level[0], &below[table - 1]);
            }
            grow(&mut self.levels[table], 1 << (k - 1));
            k += 1;
        }
    }

    /// Whether the square of side `2ᵏ + 2` with its first cell at
    /// `(col, row)` holds an occupied cell, `k` in
    /// [`FIRST_TABLE_LEVEL`]`..=`[`EXACT_LEVELS`];
    /// `None` when the square starts left of or above the grid (not in the
    /// table) or `k` has no table.
    #[inline]
    pub(crate) fn reaches(&self, k: usize, col: i32, row: i32) -> Option<bool> {
        let table = self.levels.get(k.wrapping_sub(FIRST_TABLE_LEVEL))?;
        let (col, row) = (usize::try_from(col).ok()?, usize::try_from(row).ok()?);
        let word = table.get(row).and_then(|words| words.get(col / 32));
        Some(word.is_some_and(|&w| w >> (col % 32) & 1 != 0))
    }
}

/// Grows the squares of `a` by `step`, in place: bit `(c, r)` becomes set
/// when one of `a`'s bits `(c, r)`, `(c + step, r)`, `(c, r + step)`,
/// `(c + step, r + step)` was (bits past the grid read clear). Rows and
/// words go in increasing order, so each reads only bits not yet grown.
const fn grow<const RW: usize, const H: usize>(a: &mut [[u32; RW]; H], step: usize) {
    let mut r = 0;
    while r < H {
        let mut w = 0;
        while w < RW {
            let mut bits = a[r][w] | shifted(&a[r], w, step);
            if r + step < H {
                bits |= a[r + step][w] | shifted(&a[r + step], w, step);
            }
            a[r][w] = bits;
            w += 1;
        }
        r += 1;
    }
}

/// Copies `from` into `to` a row at a time (no grid-sized temporary).
const fn copy_rows<const RW: usize, const H: usize>(
    to: &mut [[u32; RW]; H],
    from: &[[u32; RW]; H],
) {
    let mut r = 0;
    while r < H {
        to[r] = from[r];
        r += 1;
    }
}

/// Word `w` of `row` moved `by` columns towards column 0 (columns past the
/// row read clear).
const fn shifted<const RW: usize>(row: &[u32; RW], w: usize, by: usize) -> u32 {
    let (q, b) = (by / 32, (by % 32) as u32);
    let low = if w + q < RW { row[w + q] } else { 0 };
    if b == 0 {
        return low;
    }
    let high = if w + q + 1 < RW { row[w + q + 1] } else { 0 };
    (low >> b) | (high << (32 - b))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every square of every level, against the grid's cells one by one.
    #[test]
    fn tables_match_the_cells() {
        const S: usize = 40;
        let mut grid = Grid::<S, S, 2>::new();
        // xorshift32 cells, sparse enough for empty squares at every level.
        let mut state: u32 = 0x9E37_79B9;
        for _ in 0..24 {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            let (c, r) = (
                (state % S as u32) as usize,
                ((state >> 8) % S as u32) as usize,
            );
            grid.set(c, r).unwrap();
        }
        grid.set(S - 1, S - 1).unwrap();
        grid.set(31, 0).unwrap();
        grid.set(32, 5).unwrap();
        let tables = ReachTables::of(&grid);
        for k in FIRST_TABLE_LEVEL..=EXACT_LEVELS {
            let side = (1 << k) + 2;
            let (mut hits, mut misses) = (0, 0);
            for row in 0..S as i32 + 2 {
                for col in 0..S as i32 + 2 {
                    let expected = (col..col + side)
                        .any(|c| (row..row + side).any(|r| grid.get(c as usize, r as usize)));
                    assert_eq!(
                        tables.reaches(k, col, row),
                        Some(expected),
                        "k {k} ({col}, {row})"
                    );
                    if expected {
                        hits += 1;
                    } else {
                        misses += 1;
                    }
                }
            }
            assert!(hits > 0 && misses > 0, "level {k}: {hits} / {misses}");
        }
        assert_eq!(tables.reaches(2, -1, 0), None);
        assert_eq!(tables.reaches(3, 0, -3), None);
        if FIRST_TABLE_LEVEL > 1 {
            assert_eq!(tables.reaches(1, 0, 0), None);
        }
        assert_eq!(tables.reaches(0, 0, 0), None);
        assert_eq!(tables.reaches(EXACT_LEVELS + 1, 0, 0), None);
    }
}
