//! Reach tables: for each exact level `k` of the branch and bound
//! ([`search`](super::search)), which `(2ᵏ + 2)`-cell squares of the
//! reference hold an occupied cell, one bit a square.
//!
//! A bound at level `k` asks, for each sampled point, whether the square of
//! side `2ᵏ + 2` cells at the point's shifted position holds an occupied
//! reference cell (its reach). Read from the grid that is `2ᵏ + 2` rows a
//! point; from the level's table it is one bit. The tables are the same for
//! every rotation and candidate of a reference, so they are built with it
//! (feature `reach-tables`): 4 grids, `16 · ROW_WORDS · H` bytes (8 KiB at
//! 128², 32 KiB at 256²). The answers are those of the rows, bit for bit.

use crate::grid::Grid;

/// Levels whose bound is tested exactly on the grid rows (`2ᵏ + 2 ≤ 18`
/// rows and bits a point, within the 31 bits of [`any_in_columns`](crate::pose::pyramid::any_in_columns)): the
/// exact bound at level 4 prunes so much more than the pyramid's that it
/// pays for its longer reach (budget scene, M4F: 15.1 M → 12.3 M
/// instructions with 4 instead of 3).
pub(crate) const EXACT_LEVELS: usize = 4;

/// Levels with a table: `1..=`[`TABLE_LEVELS`], the levels whose bound reads
/// the grid's rows exactly.
pub(crate) const TABLE_LEVELS: usize = EXACT_LEVELS;

/// The squares of side `2ᵏ + 2` (`k = 1..=`[`TABLE_LEVELS`]) of a grid that
/// hold an occupied cell: bit `(c, r)` of level `k` is set when a cell of
/// `[c, c + 2ᵏ + 2) × [r, r + 2ᵏ + 2)` is (cells outside the grid are
/// free).
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct ReachTables<const W: usize, const H: usize, const RW: usize> {
    levels: [Grid<W, H, RW>; TABLE_LEVELS],
}

// Built and read only with the feature (a `Reference` keeps them); the
// tests check them either way.
#[cfg_attr(not(feature = "reach-tables"), allow(dead_code))]
impl<const W: usize, const H: usize, const RW: usize> ReachTables<W, H, RW> {
    /// The tables of `grid`, each level from the one below (a square of
    /// side `2ᵏ + 2` is four of side `2ᵏ⁻¹ + 2`, `2ᵏ⁻¹` apart): about
    /// `12 · RW · H` word operations a level (a `const fn`, so a reference
    /// parsed at compile time carries them in flash).
    pub(crate) const fn of(grid: &Grid<W, H, RW>) -> Self {
        // Level 0: squares of side 3, two steps of one cell from the grid.
        let mut below = squares(&squares(grid.words(), 1), 1);
        let mut levels = [const { Grid::new() }; TABLE_LEVELS];
        let mut k = 0;
        while k < TABLE_LEVELS {
            below = squares(&below, 1 << k);
            levels[k] = Grid::from_words(below);
            k += 1;
        }
        Self { levels }
    }

    /// Whether the square of side `2ᵏ + 2` with its first cell at
    /// `(col, row)` holds an occupied cell, `k` in `1..=`[`TABLE_LEVELS`];
    /// `None` when the square starts left of or above the grid (not in the
    /// table) or `k` has no table.
    #[inline]
    pub(crate) fn reaches(&self, k: usize, col: i32, row: i32) -> Option<bool> {
        let table = self.levels.get(k.wrapping_sub(1))?;
        let (col, row) = (usize::try_from(col).ok()?, usize::try_from(row).ok()?);
        Some(table.get(col, row))
    }
}

/// The squares of `a` one `step` larger: bit `(c, r)` of the result is set
/// when one of `a`'s bits `(c, r)`, `(c + step, r)`, `(c, r + step)`,
/// `(c + step, r + step)` is (bits past the grid read clear).
const fn squares<const RW: usize, const H: usize>(
    a: &[[u32; RW]; H],
    step: usize,
) -> [[u32; RW]; H] {
    let mut out = [[0u32; RW]; H];
    let mut r = 0;
    while r < H {
        let mut w = 0;
        while w < RW {
            let mut bits = a[r][w] | shifted(&a[r], w, step);
            if r + step < H {
                bits |= a[r + step][w] | shifted(&a[r + step], w, step);
            }
            out[r][w] = bits;
            w += 1;
        }
        r += 1;
    }
    out
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
        for k in 1..=TABLE_LEVELS {
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
        assert_eq!(tables.reaches(1, -1, 0), None);
        assert_eq!(tables.reaches(2, 0, -3), None);
        assert_eq!(tables.reaches(0, 0, 0), None);
        assert_eq!(tables.reaches(TABLE_LEVELS + 1, 0, 0), None);
    }
}
