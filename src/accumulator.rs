//! Hough votes `A(θ, ρ)`: one θ column at a time (streaming), or the full
//! matrix for hosts that want to look at it.
//!
//! Every line is counted twice, as `(θ, ρ)` and `(θ + π, −ρ)` (the paper's
//! doubled lines). Only θ ∈ [0, π) is voted; the other half is the mirror image
//! `A(θ + π, b) = A(θ, RHO − b)` in bin indices, exact by construction.
//!
//! ρ is in pixels with the origin at the image centre; bin `b` holds
//! `ρ ∈ [b − RHO/2 − ½, b − RHO/2 + ½)` computed from the Q15 tables. The
//! fixed-point ρ differs from the exact one by at most
//! `(|x| + |y|) · 2⁻¹⁶ ≤ 0.006` pixel at 256², so a vote changes bin only when
//! the exact ρ lies that close to a bin edge.

use crate::config::{check_grid, rho_bins};
use crate::grid::{CellBounds, Grid};
use crate::trig::TrigTable;

/// Compile-time check of a column vote's sizes: the grid's (`RW`), an even
/// `N ≥ 8`, and `RHO = rho_bins(W, H)` (the vote mask needs that power of
/// two: another `RHO` would put votes in the wrong bins silently).
const fn check_column<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const RHO: usize,
>() {
    check_grid(W, H, RW);
    assert!(N >= 8 && N % 2 == 0, "N_THETA must be even and at least 8");
    // `vote_column_pair` scales positions by 2^(16 − log2(2·RHO)).
    assert!(
        RHO <= 1 << 15,
        "RHO too large for the pair vote's positions"
    );
    assert!(
        RHO == rho_bins(W, H),
        "RHO must equal hough_heading::config::rho_bins(W, H)"
    );
}

/// One accumulator column: vote counts per ρ bin.
pub type Column<const RHO: usize> = [u16; RHO];

/// Fixed-point offset of every vote: `RHO/2` bins to make ρ non-negative, plus
/// one half for round-half-up, in Q16.
const fn vote_offset(rho: usize) -> i32 {
    ((rho as i32 / 2) << 16) + (1 << 15)
}

/// Adds the votes of every occupied cell of `grid` to `column` for
/// `θ = 2πk/N` (`k` any index; the caller passes `k < N/2`).
///
/// The inner loop is one multiply-add, a shift, a mask and an increment per
/// vote: ρ in Q16 is `X·cos + Y·sin` with doubled coordinates
/// `X = 2·col − (W−1)`, `Y = (H−1) − 2·row` (so half-pixel centres stay
/// integer) and Q15 tables. The mask `RHO − 1` (a power of two) keeps every
/// index in range without a bounds check; with the sizes checked at compile
/// time it never changes a bin.
pub fn vote_column<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const RHO: usize,
>(
    grid: &Grid<W, H, RW>,
    k: usize,
    column: &mut Column<RHO>,
) {
    const { check_column::<W, H, RW, N, RHO>() };
    let table = &TrigTable::<N>::TABLE;
    let (c, s) = (table.cos(k), table.sin(k));
    let step = 2 * c;
    let mask = RHO - 1;
    let mut y2 = H as i32 - 1;
    let row_start = vote_offset(RHO) - (W as i32 - 1) * c;
    for row in grid.words() {
        let row_base = row_start + y2 * s;
        for (j, &word) in row.iter().enumerate() {
            if word == 0 {
                continue;
            }
            // As in `vote_column_pair`: positions only for occupied words.
            let word_base = row_base + 32 * j as i32 * step;
            let mut bits = word;
            while bits != 0 {
                let col = bits.trailing_zeros() as i32;
                let bin = ((word_base + col * step) >> 16) as usize & mask;
                column[bin] = column[bin].wrapping_add(1);
                bits &= bits - 1;
            }
        }
        y2 -= 2;
    }
}

/// The bins that the votes of [`vote_column`] (or [`vote_column_pair`]) for
/// column `k` can reach from cells inside `bounds`, `(first, last)`
/// inclusive: the bins of the box's corners, since a vote's Q16 position is
/// linear in the cell's coordinates and computed exactly (the same integers
/// as the vote loops), and the bin is monotonic in the position. Every bin
/// outside stays untouched by those votes.
pub(crate) fn bin_span<const W: usize, const H: usize, const N: usize, const RHO: usize>(
    bounds: &CellBounds,
    k: usize,
) -> (usize, usize) {
    let table = &TrigTable::<N>::TABLE;
    let (c, s) = (table.cos(k), table.sin(k));
    // Doubled coordinates of the box's edges (as in `vote_column`).
    let x = |col: usize| 2 * col as i32 - (W as i32 - 1);
    let y = |row: usize| (H as i32 - 1) - 2 * row as i32;
    let (x0, x1) = (x(bounds.first_col) * c, x(bounds.last_col) * c);
    let (y0, y1) = (y(bounds.first_row) * s, y(bounds.last_row) * s);
    let low = vote_offset(RHO) + x0.min(x1) + y0.min(y1);
    let high = vote_offset(RHO) + x0.max(x1) + y0.max(y1);
    let mask = RHO - 1;
    ((low >> 16) as usize & mask, (high >> 16) as usize & mask)
}

/// Fraction bits of a split vote ([`vote_column_split`]): each occupied cell
/// adds `1 << SPLIT_VOTE_BITS` = 4, shared between its two nearest bins.
pub const SPLIT_VOTE_BITS: u32 = 2;

/// `1.0` in the Q16 scale factors of [`vote_column_split`].
pub const UNIT_SCALE_Q16: u32 = 1 << 16;

/// Largest `inv_scale_q16` [`vote_column_split`] uses (2.0, i.e. scales down
/// to ½); larger values are clamped.
pub const MAX_INV_SCALE_Q16: u32 = 2 << 16;

/// Adds the votes of every occupied cell of `grid` to `column` for
/// `θ = 2πk/N`, at `ρ · inv_scale` and split linearly between the two nearest
/// bins: a cell at position `u = ρ·inv_scale + RHO/2` (bins; bin `b` is
/// centred on `u = b`, as in [`vote_column`]) adds `4 − f` to bin `⌊u⌋` and
/// `f` to bin `⌊u⌋ + 1`, `f` = `4·frac(u)` rounded to the nearest integer.
///
/// This is the column profile used to locate lines to a fraction of a bin
/// (translation and scale): unlike [`vote_column`] its centre of mass
/// follows ρ continuously, so a wall lying on a bin edge is not biased by
/// half a bin. `inv_scale_q16` (Q16, `1.0` = [`UNIT_SCALE_Q16`], clamped to
/// [`MAX_INV_SCALE_Q16`]) undoes a scale `s = 1 / inv_scale` of the scene
/// about the image centre. Votes that fall outside the column (only when
/// `inv_scale > 1`, far from the centre) are dropped; bins saturate at
/// `u16::MAX` (never reached: each bin sees at most `16 · max(W, H) ≤ 32 768`).
///
/// Positions stay in `i32`: with `inv_scale ≤ 2`, `|cos|, |sin| ≤ 2¹⁵` (Q15)
/// and `W, H ≤ 2048` every term is below 2²⁸, the sum below 7·10⁸.
///
/// When no cell of the grid can reach the column's last bin or below 0
/// (always at unit scale: `rho_bins` leaves that margin), the votes need no
/// check, and the loop works as [`vote_column_pair`]'s (positions scaled so that
/// the bin is the top bits of a `u32`, empty words skipped, the lowest-bit
/// look-up on ARMv6-M); otherwise every bin is checked as described above.
pub fn vote_column_split<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const RHO: usize,
>(
    grid: &Grid<W, H, RW>,
    k: usize,
    inv_scale_q16: u32,
    column: &mut Column<RHO>,
) {
    split_vote::<W, H, RW, N, RHO, FAST_CTZ>(grid, k, inv_scale_q16, column);
}

/// [`vote_column_split`] finding the cells of a word with `trailing_zeros`
/// or with [`lowest_bit_index`] (`CTZ`, see [`FAST_CTZ`]): the same votes
/// either way (both are tested on the host).
#[inline(always)]
fn split_vote<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const RHO: usize,
    const CTZ: bool,
>(
    grid: &Grid<W, H, RW>,
    k: usize,
    inv_scale_q16: u32,
    column: &mut Column<RHO>,
) {
    const { check_column::<W, H, RW, N, RHO>() };
    let table = &TrigTable::<N>::TABLE;
    let inv_scale = i64::from(inv_scale_q16.min(MAX_INV_SCALE_Q16));
    // Q15 × Q16 → Q15, |result| ≤ 2¹⁶.
    let scaled = |v: i32| ((i64::from(v) * inv_scale) >> 16) as i32;
    let (c, s) = (scaled(table.cos(k)), scaled(table.sin(k)));
    // Q16 position of the image centre, plus half a share so that `f`
    // rounds to the nearest quarter (truncating would move every line by
    // −⅛ bin).
    let centre = ((RHO as i32 / 2) << 16) + (1 << (15 - SPLIT_VOTE_BITS));
    // Farthest any cell's position lies from the centre (Q16): the
    // positions are linear in the doubled coordinates `|X| ≤ W − 1`,
    // `|Y| ≤ H − 1`.
    let reach = (W as i32 - 1) * c.abs() + (H as i32 - 1) * s.abs();
    if centre - reach >= 0 && centre + reach < (RHO as i32 - 1) << 16 {
        // Every vote and its upper neighbour `⌊u⌋ + 1` are inside the
        // column: nothing to drop (always so at unit scale).
        split_in_range::<W, H, RW, RHO, CTZ>(grid, c, s, centre, column);
    } else {
        split_checked::<W, H, RW, RHO, CTZ>(grid, c, s, centre, column);
    }
}

/// The lowest set bit's index of `bits ≠ 0`, with `trailing_zeros` or
/// [`lowest_bit_index`] (see [`FAST_CTZ`]).
#[inline(always)]
fn lowest_bit<const CTZ: bool>(bits: u32) -> u32 {
    if CTZ {
        bits.trailing_zeros()
    } else {
        lowest_bit_index(bits)
    }
}

/// [`vote_column_split`] when every position `u` of a cell of the grid
/// satisfies `0 ≤ u < (RHO − 1)·2¹⁶` (Q16; `c`, `s`: scaled Q15 cosine and
/// sine, `centre`: Q16 position of the image centre): both bins of every
/// vote are in the column. Positions are scaled by `2^(16 − log2 RHO)` so
/// that the bin is the top bits of a `u32` and the share `f` the two bits
/// below (no bounds check for `⌊u⌋`; `⌊u⌋ + 1` masked with `RHO − 1`, which
/// never changes it here); empty words cost a load and a branch.
#[inline(always)]
fn split_in_range<
    const W: usize,
    const H: usize,
    const RW: usize,
    const RHO: usize,
    const CTZ: bool,
>(
    grid: &Grid<W, H, RW>,
    c: i32,
    s: i32,
    centre: i32,
    column: &mut Column<RHO>,
) {
    let bits_of_bin = RHO.trailing_zeros();
    let scale = 16 - bits_of_bin;
    // Exact: every position is in [0, RHO·2¹⁶), so shifting loses no bit.
    let q = |v: i32| (v as u32) << scale;
    let step = q(2 * c);
    let down = q(2 * s);
    let shift = 32 - bits_of_bin;
    let fraction_shift = shift - SPLIT_VOTE_BITS;
    let fraction_mask = (1u32 << SPLIT_VOTE_BITS) - 1;
    let one = 1u16 << SPLIT_VOTE_BITS;
    let mut row_base = q(centre - (W as i32 - 1) * c + (H as i32 - 1) * s);
    for row in grid.words() {
        for (j, &word) in row.iter().enumerate() {
            if word != 0 {
                let base = row_base.wrapping_add((32 * j as u32).wrapping_mul(step));
                let mut bits = word;
                while bits != 0 {
                    let u = base.wrapping_add(lowest_bit::<CTZ>(bits).wrapping_mul(step));
                    let b = (u >> shift) as usize;
                    let f = ((u >> fraction_shift) & fraction_mask) as u16;
                    if let Some(a) = column.get_mut(b) {
                        *a = a.saturating_add(one - f);
                    }
                    if let Some(a) = column.get_mut((b + 1) & (RHO - 1)) {
                        *a = a.saturating_add(f);
                    }
                    bits &= bits - 1;
                }
            }
        }
        row_base = row_base.wrapping_sub(down);
    }
}

/// [`vote_column_split`] with a bounds check per bin: a vote whose position
/// `u` (Q16) is negative is dropped, one at `⌊u⌋ ≥ RHO − 1` keeps only its
/// shares inside the column. Empty words cost a load and a branch.
#[inline(always)]
fn split_checked<
    const W: usize,
    const H: usize,
    const RW: usize,
    const RHO: usize,
    const CTZ: bool,
>(
    grid: &Grid<W, H, RW>,
    c: i32,
    s: i32,
    centre: i32,
    column: &mut Column<RHO>,
) {
    let step = 2 * c;
    let one = 1u16 << SPLIT_VOTE_BITS;
    let fraction_shift = 16 - SPLIT_VOTE_BITS;
    let fraction_mask = (1i32 << SPLIT_VOTE_BITS) - 1;
    let row_start = centre - (W as i32 - 1) * c;
    let mut y2 = H as i32 - 1;
    for row in grid.words() {
        let row_base = row_start + y2 * s;
        for (j, &word) in row.iter().enumerate() {
            if word != 0 {
                let base = row_base + 32 * j as i32 * step;
                let mut bits = word;
                while bits != 0 {
                    let u = base + lowest_bit::<CTZ>(bits) as i32 * step;
                    let f = ((u >> fraction_shift) & fraction_mask) as u16;
                    // A negative `u` reads as at least 2³¹, its bin at least
                    // 2¹⁵ ≥ RHO: both shares dropped.
                    let b = (u as u32 >> 16) as usize;
                    if let Some(a) = column.get_mut(b) {
                        *a = a.saturating_add(one - f);
                    }
                    if let Some(a) = column.get_mut(b + 1) {
                        *a = a.saturating_add(f);
                    }
                    bits &= bits - 1;
                }
            }
        }
        y2 -= 2;
    }
}

/// Votes two adjacent columns, `k` into `columns[0]` and `k + 1` into
/// `columns[1]`, in one pass over the grid: the bit extraction and the scan
/// over the grid's words are shared. Same result as two calls of
/// [`vote_column`] at `k` and `k + 1` (taken modulo `N`, so any `k`,
/// `usize::MAX` included, is valid).
///
/// The two columns are one contiguous array of `2·RHO` bins, the second
/// column's offset folded into its positions, and the positions are scaled
/// so that the bin is their top bits: one pointer, one shift, no mask and
/// no bounds check per vote (registers matter on the Cortex-M0). An empty
/// word costs a load and a branch: the positions of a word are computed
/// from its row and index only when it holds a cell. The cells of a word
/// are found with `trailing_zeros` where the target counts zeros in an
/// instruction or two (Cortex-M3/M4/M7: RBIT + CLZ; hosts), and with a
/// multiply and a 32-entry table look-up elsewhere (Cortex-M0/M0+, RV32
/// without Zbb, where `trailing_zeros` is a long sequence with a zero
/// test). At 128², `N_THETA` = 360 the loop takes 11.0 instructions per vote
/// on Cortex-M4F and 20.1 on Cortex-M0 (`budgets/TABLE.md`, *vote loop*).
pub fn vote_column_pair<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const RHO: usize,
>(
    grid: &Grid<W, H, RW>,
    k: usize,
    columns: &mut [Column<RHO>; 2],
) {
    vote_pair::<W, H, RW, N, RHO, FAST_CTZ>(grid, k, columns);
}

/// [`vote_column_pair`] finding the cells of a word with `trailing_zeros`
/// (`CTZ`) or with [`lowest_bit_index`]: the same votes either way (both
/// are tested on the host).
#[inline(always)]
fn vote_pair<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const RHO: usize,
    const CTZ: bool,
>(
    grid: &Grid<W, H, RW>,
    k: usize,
    columns: &mut [Column<RHO>; 2],
) {
    const { check_column::<W, H, RW, N, RHO>() };
    let table = &TrigTable::<N>::TABLE;
    let (c1, s1) = (table.cos(k), table.sin(k));
    // `k mod N + 1`: the same column as `k + 1`, without its overflow at usize::MAX.
    let (c2, s2) = (table.cos(k % N + 1), table.sin(k % N + 1));
    // Both columns as one array of 2·RHO = 2^BITS bins, the second
    // column's votes offset by RHO bins. Positions are Q16 scaled by
    // 2^(16 − BITS), so that the bin is the top BITS bits of a u32: one
    // shift, no mask, and an index the compiler knows is in range. The
    // wrapping arithmetic is exact modulo 2³², which gives the masked bin of
    // `vote_column` (every position is in its column's range anyway).
    let bins = columns.as_flattened_mut();
    let bits_of_bin = (2 * RHO).trailing_zeros();
    let scale = 16 - bits_of_bin;
    let q = |v: i32| (v as u32) << scale;
    let (step1, step2) = (q(2 * c1), q(2 * c2));
    let second = q((RHO as i32) << 16);
    // Positions of column 0 of the current row, updated by −2·sin per row
    // (y2 = H − 1 − 2·row).
    let mut row1 = q(vote_offset(RHO) - (W as i32 - 1) * c1 + (H as i32 - 1) * s1);
    let mut row2 = second.wrapping_add(q(
        vote_offset(RHO) - (W as i32 - 1) * c2 + (H as i32 - 1) * s2
    ));
    let (down1, down2) = (q(2 * s1), q(2 * s2));
    let shift = 32 - bits_of_bin;
    for row in grid.words() {
        for (j, &word) in row.iter().enumerate() {
            if word != 0 {
                // The same values as the running sums `row + 32·j·step`,
                // computed only for words that hold a cell.
                let j = 32 * j as u32;
                let base1 = row1.wrapping_add(j.wrapping_mul(step1));
                let base2 = row2.wrapping_add(j.wrapping_mul(step2));
                let mut bits = word;
                while bits != 0 {
                    let col = lowest_bit::<CTZ>(bits);
                    let bin1 = base1.wrapping_add(col.wrapping_mul(step1)) >> shift;
                    let bin2 = base2.wrapping_add(col.wrapping_mul(step2)) >> shift;
                    if let Some(v) = bins.get_mut(bin1 as usize) {
                        *v = v.wrapping_add(1);
                    }
                    if let Some(v) = bins.get_mut(bin2 as usize) {
                        *v = v.wrapping_add(1);
                    }
                    bits &= bits - 1;
                }
            }
        }
        row1 = row1.wrapping_sub(down1);
        row2 = row2.wrapping_sub(down2);
    }
}

/// Whether `trailing_zeros` is one or two instructions (RBIT + CLZ on
/// ARMv7-M, TZCNT/BSF on hosts). Not on ARMv6-M (Cortex-M0/M0+/M1: the only
/// Arm profile without atomic read-modify-write, hence the test) nor on
/// RV32 without Zbb, where it is a long sequence with a zero test: there
/// the vote loop uses [`lowest_bit_index`].
const FAST_CTZ: bool = !cfg!(any(
    all(target_arch = "arm", not(target_has_atomic = "ptr")),
    target_arch = "riscv32"
));

/// Multiplier of [`lowest_bit_index`]: the top five bits of
/// `(2^(i+1) − 1) · LOWEST_BIT_MULTIPLIER` differ for every `i ∈ [0, 32)`.
const LOWEST_BIT_MULTIPLIER: u32 = 0x07C4_ACDD;

/// `i` for the top five bits of `(2^(i+1) − 1) · LOWEST_BIT_MULTIPLIER`.
const LOWEST_BIT_INDEX: [u8; 32] = {
    let mut index = [0u8; 32];
    let mut i = 0;
    while i < 32 {
        let ones = if i == 31 {
            u32::MAX
        } else {
            (1 << (i + 1)) - 1
        };
        index[(ones.wrapping_mul(LOWEST_BIT_MULTIPLIER) >> 27) as usize] = i as u8;
        i += 1;
    }
    index
};

/// `bits.trailing_zeros()` for `bits ≠ 0` (31 for 0) without CLZ: the ones
/// up to the lowest set bit, `bits ^ (bits − 1) = 2^(i+1) − 1`, times a
/// constant whose top five bits differ for every `i`, looked up in a
/// 32-entry table (flash: 32 B). `bits − 1` is also what clears that bit
/// in the vote loop. (Isolating the bit with `bits & −bits` instead, the
/// textbook de Bruijn form, is recognised by LLVM and turned back into its
/// own `cttz` expansion, which adds a zero test.)
#[inline(always)]
fn lowest_bit_index(bits: u32) -> u32 {
    let ones = bits ^ bits.wrapping_sub(1);
    // The shift leaves five bits: the index is always in range.
    u32::from(LOWEST_BIT_INDEX[(ones.wrapping_mul(LOWEST_BIT_MULTIPLIER) >> 27) as usize])
}

/// The full accumulator over θ ∈ [0, π) (`HALF` columns of `RHO` bins), with
/// the half-turn mirror for θ ∈ [π, 2π). For hosts (figures, debugging):
/// 128² at `N_THETA` = 360 takes 180 · 256 · 2 = 92 KiB. The estimator itself
/// streams one column at a time and gives bit-identical signatures.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Accumulator<const HALF: usize, const RHO: usize> {
    columns: [Column<RHO>; HALF],
}

impl<const HALF: usize, const RHO: usize> Accumulator<HALF, RHO> {
    /// Votes every occupied cell of `grid` in every column θ ∈ [0, π).
    /// `N = 2 · HALF` is the number of θ steps over the full circle.
    pub fn vote<const W: usize, const H: usize, const RW: usize, const N: usize>(
        grid: &Grid<W, H, RW>,
    ) -> Self {
        const { crate::config::check_config(W, H, RW, N, HALF, RHO) };
        let mut columns = [[0u16; RHO]; HALF];
        for (k, column) in columns.iter_mut().enumerate() {
            vote_column::<W, H, RW, N, RHO>(grid, k, column);
        }
        Self { columns }
    }

    /// The voted column `k ∈ [0, HALF)`, i.e. θ = πk/HALF.
    pub fn half_column(&self, k: usize) -> Option<&Column<RHO>> {
        self.columns.get(k)
    }

    /// `A(θ_k, b)` over the full circle, `k ∈ [0, 2·HALF)`, bin `b ∈ [0, RHO)`;
    /// 0 outside. `A(θ + π, b) = A(θ, RHO − b)`.
    pub fn get(&self, k: usize, b: usize) -> u16 {
        let (k, b) = if k < HALF {
            (k, b)
        } else {
            (k - HALF, RHO.wrapping_sub(b))
        };
        self.columns
            .get(k)
            .and_then(|c| c.get(b))
            .copied()
            .unwrap_or(0)
    }

    /// Number of θ steps over the full circle.
    pub const fn n_theta(&self) -> usize {
        2 * HALF
    }
}

/// Votes column `m ∈ [0, N)` of image 2 into `column` (zeroed first) with
/// split votes at `ρ · inv_scale`: columns `m ≥ HALF` are the mirror of
/// `m − HALF`.
pub(crate) fn vote_profile_column<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const HALF: usize,
    const RHO: usize,
>(
    grid: &Grid<W, H, RW>,
    m: usize,
    inv_scale_q16: u32,
    column: &mut Column<RHO>,
) {
    column.fill(0);
    vote_column_split::<W, H, RW, N, RHO>(grid, m % HALF, inv_scale_q16, column);
    if m >= HALF {
        mirror(column);
    }
}

/// Reverses a column in place about its centre: `b ↔ RHO − b` (θ → θ + π).
pub(crate) fn mirror<const RHO: usize>(column: &mut Column<RHO>) {
    // Bins 1..RHO: reversing that slice maps b to RHO − b.
    if let Some(tail) = column.get_mut(1..) {
        tail.reverse();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::max_votes_per_bin;

    #[test]
    fn vote_bound_holds_for_a_full_grid() {
        // A fully occupied grid puts the most votes in a bin; the bound must hold.
        let g = Grid::<32, 32, 1>::from_words([[u32::MAX; 1]; 32]);
        let acc = Accumulator::<64, 64>::vote::<32, 32, 1, 128>(&g);
        let max = (0..64)
            .flat_map(|k| (0..64).map(move |b| (k, b)))
            .map(|(k, b)| acc.get(k, b))
            .max();
        assert!(max.unwrap() as usize <= max_votes_per_bin(32, 32));
        // θ = 0: each bin is one pixel column of 32 cells.
        assert_eq!((0..64).map(|b| acc.get(0, b)).max(), Some(32));
        // θ = 45°: a unit-wide strip holds two pixel diagonals, close to the bound.
        assert!(max.unwrap() > 32);
        // Each column holds every pixel once.
        for k in 0..64 {
            let total: u32 = acc.half_column(k).unwrap().iter().map(|&v| v as u32).sum();
            assert_eq!(total, 32 * 32);
        }
    }

    #[test]
    fn horizontal_line_votes_at_ninety_degrees() {
        // Row 1 of a 8×4 grid: y = (4−1)/2 − 1 = 0.5 → ρ = 0.5 at θ = 90°, rounded up to bin +1.
        let mut g = Grid::<8, 4, 1>::new();
        g.set_cells((0..8).map(|c| (c, 1))).unwrap();
        let acc = Accumulator::<8, 16>::vote::<8, 4, 1, 16>(&g);
        assert_eq!(acc.get(4, 8 + 1), 8);
        // θ = 270°: ρ = −0.5, the mirror bin.
        assert_eq!(acc.get(12, 8 - 1), 8);
    }

    #[test]
    fn mirror_maps_b_to_rho_minus_b() {
        let mut c = [0u16; 8];
        c[1] = 1;
        c[3] = 3;
        c[4] = 4;
        mirror(&mut c);
        assert_eq!(c, [0, 0, 0, 0, 4, 3, 0, 1]);
    }

    /// The look-up against `trailing_zeros`: every single bit, every
    /// single bit with random higher bits, and random words.
    #[test]
    fn lowest_bit_index_matches_trailing_zeros() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 32) as u32
        };
        for i in 0..32 {
            assert_eq!(lowest_bit_index(1 << i), i);
            for _ in 0..100 {
                let word = (1u32 << i) | (next().checked_shl(i + 1).unwrap_or(0));
                assert_eq!(lowest_bit_index(word), i, "{word:#x}");
            }
        }
        for _ in 0..10_000 {
            let word = next() >> (next() % 32);
            if word != 0 {
                assert_eq!(lowest_bit_index(word), word.trailing_zeros(), "{word:#x}");
            }
        }
    }

    /// Both bit extractions of the pair vote give the votes of two single
    /// columns, on random grids (sparse to full, a width that is not a
    /// multiple of 32) and at every `k`.
    #[test]
    fn vote_pair_both_bit_orders_equal_single_columns() {
        type G = Grid<45, 13, 2>;
        const RHO: usize = crate::config::rho_bins(45, 13);
        let mut state = 0x2545_f491_4f6c_dd1du64;
        for density in [1u64, 8, 32, 64] {
            let mut words = [[0u32; 2]; 13];
            for w in words.iter_mut().flatten() {
                for bit in 0..32 {
                    state = state
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    if (state >> 58) < density {
                        *w |= 1 << bit;
                    }
                }
            }
            let g = G::from_words(words);
            for k in 0..24 {
                let (mut a, mut b) = ([0u16; RHO], [0u16; RHO]);
                vote_column::<45, 13, 2, 24, RHO>(&g, k, &mut a);
                vote_column::<45, 13, 2, 24, RHO>(&g, k + 1, &mut b);
                let mut native = [[0u16; RHO]; 2];
                vote_pair::<45, 13, 2, 24, RHO, true>(&g, k, &mut native);
                let mut looked_up = [[0u16; RHO]; 2];
                vote_pair::<45, 13, 2, 24, RHO, false>(&g, k, &mut looked_up);
                assert_eq!(native, [a, b], "density {density}, k {k}");
                assert_eq!(looked_up, [a, b], "density {density}, k {k}");
            }
        }
    }

    /// Every vote of a column lands inside `bin_span` of the grid's bounds.
    #[test]
    fn bin_span_holds_every_vote() {
        const RHO: usize = crate::config::rho_bins(45, 13);
        let mut g = Grid::<45, 13, 2>::new();
        g.set_cells([(3, 2), (40, 9), (17, 5), (22, 11)]).unwrap();
        let bounds = g.occupied_bounds().unwrap();
        for k in 0..36 {
            let mut column = [0u16; RHO];
            vote_column::<45, 13, 2, 36, RHO>(&g, k, &mut column);
            let (low, high) = bin_span::<45, 13, 36, RHO>(&bounds, k);
            assert!(low <= high);
            for (b, &v) in column.iter().enumerate() {
                assert!(v == 0 || (low..=high).contains(&b), "k {k} bin {b}");
            }
        }
    }

    /// `k + 1` never overflows: the pair at `usize::MAX` is the columns
    /// `usize::MAX mod N` and the next one, as two single votes give them.
    #[test]
    fn vote_column_pair_at_the_largest_index() {
        let mut g = Grid::<8, 4, 1>::new();
        g.set_cells([(0, 0), (3, 1), (7, 3), (5, 2)]).unwrap();
        for k in [usize::MAX, usize::MAX - 1, 15, 0] {
            let mut pair = [[0u16; 16]; 2];
            vote_column_pair::<8, 4, 1, 16, 16>(&g, k, &mut pair);
            let (mut a, mut b) = ([0u16; 16], [0u16; 16]);
            vote_column::<8, 4, 1, 16, 16>(&g, k % 16, &mut a);
            vote_column::<8, 4, 1, 16, 16>(&g, k % 16 + 1, &mut b);
            assert_eq!(pair, [a, b], "{k}");
        }
    }

    /// The old straightforward split vote (every word, running sums, a
    /// bounds check per bin): the reference for [`split_vote`].
    fn split_reference<
        const W: usize,
        const H: usize,
        const RW: usize,
        const N: usize,
        const RHO: usize,
    >(
        grid: &Grid<W, H, RW>,
        k: usize,
        inv_scale_q16: u32,
        column: &mut Column<RHO>,
    ) {
        let table = &TrigTable::<N>::TABLE;
        let inv_scale = i64::from(inv_scale_q16.min(MAX_INV_SCALE_Q16));
        let scaled = |v: i32| ((i64::from(v) * inv_scale) >> 16) as i32;
        let (c, s) = (scaled(table.cos(k)), scaled(table.sin(k)));
        let step = 2 * c;
        let one = 1u16 << SPLIT_VOTE_BITS;
        let fraction_shift = 16 - SPLIT_VOTE_BITS;
        let fraction_mask = (1i32 << SPLIT_VOTE_BITS) - 1;
        let row_start = ((RHO as i32 / 2) << 16) + (1 << (fraction_shift - 1)) - (W as i32 - 1) * c;
        let mut y2 = H as i32 - 1;
        for words in grid.words() {
            let mut word_base = row_start + y2 * s;
            for &word in words {
                let mut bits = word;
                while bits != 0 {
                    let u = word_base + bits.trailing_zeros() as i32 * step;
                    let f = ((u >> fraction_shift) & fraction_mask) as u16;
                    if let Ok(b) = usize::try_from(u >> 16) {
                        if let Some(a) = column.get_mut(b) {
                            *a = a.saturating_add(one - f);
                        }
                        if let Some(a) = column.get_mut(b + 1) {
                            *a = a.saturating_add(f);
                        }
                    }
                    bits &= bits - 1;
                }
                word_base += 32 * step;
            }
            y2 -= 2;
        }
    }

    /// A random grid: each cell occupied with probability `density / 64`.
    fn random_grid<const W: usize, const H: usize, const RW: usize>(
        state: &mut u64,
        density: u64,
    ) -> Grid<W, H, RW> {
        let mut words = [[0u32; RW]; H];
        for w in words.iter_mut().flatten() {
            for bit in 0..32 {
                *state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                if (*state >> 58) < density {
                    *w |= 1 << bit;
                }
            }
        }
        Grid::from_words(words)
    }

    /// Both paths of the split vote (in range, checked) with both bit
    /// extractions against the old loop, on random grids (sparse to full,
    /// widths that are not a multiple of 32, non-zero starting columns), at
    /// every `k` and at scales from ¼ to beyond [`MAX_INV_SCALE_Q16`]
    /// (clamped), where votes fall outside the column.
    fn split_vote_matches_reference<
        const W: usize,
        const H: usize,
        const RW: usize,
        const N: usize,
        const RHO: usize,
    >(
        seed: u64,
    ) {
        let mut state = seed;
        let scales = [
            0,
            1 << 14,
            UNIT_SCALE_Q16 - 1,
            UNIT_SCALE_Q16,
            UNIT_SCALE_Q16 + 12_345,
            3 << 15,
            MAX_INV_SCALE_Q16 - 1,
            MAX_INV_SCALE_Q16,
            MAX_INV_SCALE_Q16 + 1,
            u32::MAX,
        ];
        let mut dropped = false;
        for density in [1u64, 8, 32, 64] {
            let g = random_grid::<W, H, RW>(&mut state, density);
            for k in 0..N {
                for inv in scales {
                    let start = core::array::from_fn(|b| (b * 7 % 5) as u16);
                    let mut expected: Column<RHO> = start;
                    split_reference::<W, H, RW, N, RHO>(&g, k, inv, &mut expected);
                    let total = |c: &Column<RHO>| c.iter().map(|&v| u32::from(v)).sum::<u32>();
                    dropped |= total(&expected) - total(&start) < 4 * g.occupied();
                    // At unit scale no vote is dropped: the column gains
                    // exactly 4 per cell (so a stored profile is never all
                    // zero, which `Reference::from_bytes` checks).
                    if inv == UNIT_SCALE_Q16 {
                        assert_eq!(
                            total(&expected) - total(&start),
                            4 * g.occupied(),
                            "density {density}, k {k}"
                        );
                    }
                    let mut native = start;
                    split_vote::<W, H, RW, N, RHO, true>(&g, k, inv, &mut native);
                    let mut looked_up = start;
                    split_vote::<W, H, RW, N, RHO, false>(&g, k, inv, &mut looked_up);
                    let mut public = start;
                    vote_column_split::<W, H, RW, N, RHO>(&g, k, inv, &mut public);
                    assert_eq!(native, expected, "density {density}, k {k}, scale {inv}");
                    assert_eq!(looked_up, expected, "density {density}, k {k}, scale {inv}");
                    assert_eq!(public, expected, "density {density}, k {k}, scale {inv}");
                    // The checked path alone, at every scale (in range too).
                    let table = &TrigTable::<N>::TABLE;
                    let inv_scale = i64::from(inv.min(MAX_INV_SCALE_Q16));
                    let scaled = |v: i32| ((i64::from(v) * inv_scale) >> 16) as i32;
                    let (c, s) = (scaled(table.cos(k)), scaled(table.sin(k)));
                    let centre = ((RHO as i32 / 2) << 16) + (1 << (15 - SPLIT_VOTE_BITS));
                    let mut checked = start;
                    split_checked::<W, H, RW, RHO, false>(&g, c, s, centre, &mut checked);
                    assert_eq!(checked, expected, "density {density}, k {k}, scale {inv}");
                }
            }
        }
        assert!(dropped, "no vote fell outside the column");
    }

    #[test]
    fn split_vote_equals_the_plain_loop() {
        split_vote_matches_reference::<45, 13, 2, 24, { crate::config::rho_bins(45, 13) }>(
            0x2545_f491_4f6c_dd1d,
        );
        split_vote_matches_reference::<64, 64, 2, 36, { crate::config::rho_bins(64, 64) }>(7);
        split_vote_matches_reference::<100, 37, 4, 60, { crate::config::rho_bins(100, 37) }>(11);
        split_vote_matches_reference::<8, 4, 1, 16, 16>(3);
    }
}
