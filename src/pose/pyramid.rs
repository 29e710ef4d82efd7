//! The OR-pooled pyramid of the reference grid (level `k` cell = OR of a
//! `2ᵏ × 2ᵏ` block) that bounds the branch and bound of
//! [`search`](super::search), and the bit readers it shares with it.

use crate::config::{layout, level_height, level_row_words, pyramid_levels, MAX_LEVELS};
use crate::grid::Grid;

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

    pub(crate) const LEVELS: usize = pyramid_levels(W, H);
    /// Per level `k` (index `k`, 0 unused): word offset, height, row words;
    /// evaluated at compile time (no division at run time).
    const LAYOUT: [(usize, usize, usize); MAX_LEVELS + 1] = layout(W, H);

    /// Word offset of level `k ≥ 1`.
    fn offset(k: usize) -> usize {
        Self::LAYOUT.get(k).map_or(PW, |l| l.0)
    }

    /// Rebuilds every level from `grid` (`≈ W·H/16` word operations). Not
    /// inlined: inlined into the verification it doubled its code.
    #[inline(never)]
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
    pub(crate) fn row(&self, k: usize, r: i32) -> &[u32] {
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
pub(crate) fn bits(row: &[u32], lo: i32, n: u32) -> u32 {
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
    // The next word only when the columns run into it.
    let high = if b + n <= 32 {
        0
    } else {
        word(w + 1) << (32 - b)
    };
    (low | high) & ((1u32 << n) - 1)
}

/// [`bits`] of row `row` of `grid`: columns `col..col + n` (`n ≤ 31`), bit
/// 0 = column `col`; rows and columns outside the grid read clear.
#[inline]
pub(crate) fn grid_bits<const W: usize, const H: usize, const RW: usize>(
    grid: &Grid<W, H, RW>,
    col: i32,
    row: i32,
    n: u32,
) -> u32 {
    usize::try_from(row)
        .ok()
        .and_then(|r| grid.words().get(r))
        .map_or(0, |words| bits(words, col, n))
}

/// Whether any of `rows` has a bit in columns `lo..lo + n` (`n ≤ 31`): the
/// word index and shift are computed once for all rows.
#[inline]
pub(crate) fn any_in_columns<const RW: usize>(rows: &[[u32; RW]], lo: i32, n: u32) -> bool {
    let w = lo >> 5;
    let b = (lo & 31) as u32;
    let mask = (1u32 << n) - 1;
    let index = |i: i32| usize::try_from(i).ok().filter(|&i| i < RW);
    match (index(w), index(w + 1)) {
        // Columns within one word: one read a row.
        (Some(i), _) if b + n <= 32 => {
            let mask = mask << b;
            rows.iter().any(|r| r[i] & mask != 0)
        }
        (Some(i), Some(j)) if b > 0 => rows
            .iter()
            .any(|r| ((r[i] >> b) | (r[j] << (32 - b))) & mask != 0),
        (Some(i), _) => rows.iter().any(|r| (r[i] >> b) & mask != 0),
        (None, Some(j)) if b > 0 => rows.iter().any(|r| (r[j] << (32 - b)) & mask != 0),
        _ => false,
    }
}

/// Whether every one of `rows` has all bits in columns `lo..lo + n` set
/// (`1 ≤ n ≤ 31`; columns outside the row count as clear).
#[inline]
pub(crate) fn all_in_columns<const RW: usize>(rows: &[[u32; RW]], lo: i32, n: u32) -> bool {
    let mask = (1u32 << n) - 1;
    !rows.is_empty() && rows.iter().all(|r| bits(r, lo, n) == mask)
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
}
