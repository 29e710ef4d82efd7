//! The signature of one image: `D(θ)` (eq. 10) and the asymmetry map `S(θ)`
//! (eqs. 13–17), for θ ∈ [0, π). The other half follows exactly:
//! `D(θ + π) = D(θ)`, `S(θ + π) = −S(θ)`.

use crate::accumulator::{bin_span, vote_column, vote_column_pair, Accumulator, Column};
use crate::grid::Grid;

/// How `D(θ)` reduces one accumulator column.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PeakKind {
    /// `max_ρ A(θ, ρ)`: the paper's eq. (10).
    SingleBin,
    /// `max_ρ (A(θ, ρ) + A(θ, ρ + 1))`: a line that straddles two bins keeps
    /// all its votes; lowers the median error 20–40 % (DESIGN.md §3).
    TwoBin,
}

/// Fraction bits of [`ColumnStats::asymmetry`] and of the stored `S(θ)` (Q4
/// in an `i16`: ±2047 votes; beyond that, only for grids far denser than an
/// outline, the value saturates).
pub const ASYMMETRY_FRACTION_BITS: u32 = 4;

/// What the method keeps of one accumulator column.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ColumnStats {
    /// `D(θ)` for the requested [`PeakKind`] (votes).
    pub peak: u16,
    /// `s(θ) = Σ_{ρ=l}^{u} (ρ − m)/w · A(θ, ρ)` in Q4, saturated to `i16`,
    /// with `l`, `u` the smallest and largest bins holding votes, `w = u − l`,
    /// `m = l + w/2` (eqs. 13–17); 0 when the column is empty or `w = 0`.
    pub asymmetry: i16,
}

impl ColumnStats {
    /// Reduces one column. `S(θ)` is computed for [`PeakKind::SingleBin`]
    /// (the paper's mode, whose direction test uses it) and left 0 for
    /// [`PeakKind::TwoBin`] (the improved mode tests the direction from
    /// column profiles), which saves a multiply-add per bin. Before
    /// saturation `|s| ≤ votes / 2` (each vote has `|ρ − m| ≤ w/2`); the i64
    /// intermediate cannot overflow.
    pub fn of<const RHO: usize>(column: &Column<RHO>, kind: PeakKind) -> Self {
        match kind {
            PeakKind::SingleBin => Self {
                peak: column.iter().copied().max().unwrap_or(0),
                asymmetry: asymmetry(column, 0),
            },
            PeakKind::TwoBin => Self {
                peak: two_bin_peak(column),
                asymmetry: 0,
            },
        }
    }
}

/// [`ColumnStats::of`] of a column whose votes all lie in `bins`, the bins
/// `offset..offset + bins.len()` (every other bin is 0), and zeroes `bins`
/// in the same pass: the streaming loop reduces a column and clears it for
/// the next one without a second pass or a `memset`.
fn take_stats(bins: &mut [u16], offset: usize, kind: PeakKind) -> ColumnStats {
    match kind {
        PeakKind::SingleBin => {
            let stats = ColumnStats {
                peak: bins.iter().copied().max().unwrap_or(0),
                asymmetry: asymmetry(bins, offset),
            };
            bins.fill(0);
            stats
        }
        PeakKind::TwoBin => ColumnStats {
            peak: take_two_bin_peak(bins),
            asymmetry: 0,
        },
    }
}

/// [`two_bin_peak`] of `bins` with zeros on both sides (the pairs across
/// either end are then a single bin, never more than an inner pair when
/// `bins.len() ≥ 2`), zeroing `bins`. Two bins per step.
fn take_two_bin_peak(bins: &mut [u16]) -> u16 {
    let mut peak = 0u32;
    let mut previous = 0u32;
    let mut pairs = bins.chunks_exact_mut(2);
    for pair in &mut pairs {
        if let [a, b] = pair {
            let (x, y) = (u32::from(*a), u32::from(*b));
            *a = 0;
            *b = 0;
            peak = peak.max(previous + x).max(x + y);
            previous = y;
        }
    }
    for a in pairs.into_remainder() {
        let x = u32::from(*a);
        *a = 0;
        peak = peak.max(previous + x);
    }
    peak.min(u32::from(u16::MAX)) as u16
}

/// `max_b (A[b] + A[b + 1])`, summed in `u32` and saturated to `u16` (for
/// voted columns the sum always fits: `2 · max_votes_per_bin` is checked
/// against `u16` at compile time).
fn two_bin_peak(column: &[u16]) -> u16 {
    let mut peak = 0u32;
    let mut previous = 0u32;
    for &a in column {
        let a = u32::from(a);
        peak = peak.max(a + previous);
        previous = a;
    }
    peak.min(u32::from(u16::MAX)) as u16
}

/// `s(θ)` of eqs. 13–17 in Q4, saturated symmetrically to `±i16::MAX`, of
/// a column whose votes all lie in `bins`, the bins `offset..` (every other
/// bin is 0).
fn asymmetry(bins: &[u16], offset: usize) -> i16 {
    let mut first = usize::MAX;
    let mut last = 0usize;
    let mut votes = 0u64;
    let mut moment = 0u64;
    for (b, &a) in (offset..).zip(bins) {
        if a != 0 {
            first = first.min(b);
            last = b;
            votes += u64::from(a);
            moment += u64::from(a) * b as u64;
        }
    }
    let width = last.saturating_sub(first) as i64;
    if votes == 0 || width == 0 {
        return 0;
    }
    // Σ (b − m) A = Σ b A − m Σ A with m = (l + u)/2; doubled to stay integer.
    let twice_centred = 2 * moment as i64 - (first + last) as i64 * votes as i64;
    // Symmetric saturation, so that −s never overflows.
    ((twice_centred << ASYMMETRY_FRACTION_BITS) / (2 * width))
        .clamp(-i64::from(i16::MAX), i16::MAX.into()) as i16
}

/// `D(θ)` and `S(θ)` of one image over θ_k = πk/HALF, `k ∈ [0, HALF)`.
///
/// Size: `4 · HALF + 2` bytes (`N_THETA` = 360 → 722 B).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Signature<const HALF: usize> {
    pub(crate) kind: PeakKind,
    pub(crate) peak: [u16; HALF],
    pub(crate) asymmetry: [i16; HALF],
}

impl<const HALF: usize> Signature<HALF> {
    /// An all-zero signature (the signature of an empty grid).
    pub const fn empty(kind: PeakKind) -> Self {
        Self {
            kind,
            peak: [0; HALF],
            asymmetry: [0; HALF],
        }
    }

    /// Computes the signature two θ columns at a time (the full matrix never
    /// exists), using `columns` as scratch (left zeroed). `N = 2 · HALF`.
    ///
    /// The columns are zeroed once; each voted column is then reduced and
    /// cleared in one pass over the bins its votes can reach (from the
    /// occupied cells' bounding box), not over all `RHO` bins.
    pub fn stream<
        const W: usize,
        const H: usize,
        const RW: usize,
        const N: usize,
        const RHO: usize,
    >(
        grid: &Grid<W, H, RW>,
        kind: PeakKind,
        columns: &mut [Column<RHO>; 2],
    ) -> Self {
        let mut signature = Self::empty(kind);
        signature.restream::<W, H, RW, N, RHO>(grid, kind, columns);
        signature
    }

    /// [`Self::stream`] in place: overwrites this signature, so no second
    /// copy is ever on the stack (the estimator's loop uses this).
    pub fn restream<
        const W: usize,
        const H: usize,
        const RW: usize,
        const N: usize,
        const RHO: usize,
    >(
        &mut self,
        grid: &Grid<W, H, RW>,
        kind: PeakKind,
        columns: &mut [Column<RHO>; 2],
    ) {
        const { crate::config::check_config(W, H, RW, N, HALF, RHO) };
        self.kind = kind;
        columns.as_flattened_mut().fill(0);
        let Some(bounds) = grid.occupied_bounds() else {
            self.peak.fill(0);
            self.asymmetry.fill(0);
            return;
        };
        // Reduces column `k` and leaves it zeroed: only the bins its votes
        // can reach are read and cleared.
        let mut take = |k: usize, column: &mut Column<RHO>| {
            let (low, high) = bin_span::<W, H, N, RHO>(&bounds, k);
            let stats = match column.get_mut(low..=high) {
                Some(bins) => take_stats(bins, low, kind),
                None => take_stats(column, 0, kind),
            };
            self.set(k, stats);
        };
        let mut k = 0;
        while k + 1 < HALF {
            vote_column_pair::<W, H, RW, N, RHO>(grid, k, columns);
            let [first, second] = columns;
            take(k, first);
            take(k + 1, second);
            k += 2;
        }
        if k < HALF {
            let [first, _] = columns;
            vote_column::<W, H, RW, N, RHO>(grid, k, first);
            take(k, first);
        }
    }

    /// The signature of a full accumulator; bit-identical to [`Self::stream`].
    pub fn from_accumulator<const RHO: usize>(
        accumulator: &Accumulator<HALF, RHO>,
        kind: PeakKind,
    ) -> Self {
        let mut signature = Self::empty(kind);
        for k in 0..HALF {
            if let Some(column) = accumulator.half_column(k) {
                signature.set(k, ColumnStats::of(column, kind));
            }
        }
        signature
    }

    fn set(&mut self, k: usize, stats: ColumnStats) {
        if let (Some(p), Some(s)) = (self.peak.get_mut(k), self.asymmetry.get_mut(k)) {
            *p = stats.peak;
            *s = stats.asymmetry;
        }
    }

    /// How `D` was reduced.
    pub const fn kind(&self) -> PeakKind {
        self.kind
    }

    /// `D(θ_k)` in votes over the full circle, `θ_k = 2πk/(2·HALF)`; `k` is
    /// taken modulo `2·HALF` (`D(θ + π) = D(θ)`).
    pub fn peak(&self, k: usize) -> u16 {
        self.peak.get(k % HALF.max(1)).copied().unwrap_or(0)
    }

    /// `S(θ_k)` in Q4 over the full circle; `S(θ + π) = −S(θ)`. Computed for
    /// [`PeakKind::SingleBin`] signatures only (0 for `TwoBin`). The library
    /// writes `|S| ≤ i16::MAX`; a stored `i16::MIN` (refused by
    /// [`Reference::from_bytes`](crate::Reference::from_bytes)) negates to
    /// `i16::MAX` (saturating, so total on any value).
    pub fn asymmetry(&self, k: usize) -> i16 {
        let half = HALF.max(1);
        let s = self.asymmetry.get(k % half).copied().unwrap_or(0);
        if (k / half) % 2 == 0 {
            s
        } else {
            s.saturating_neg()
        }
    }

    /// `D(θ)` over θ ∈ [0, π).
    pub const fn peaks(&self) -> &[u16; HALF] {
        &self.peak
    }

    /// `S(θ)` (Q4) over θ ∈ [0, π).
    pub const fn asymmetries(&self) -> &[i16; HALF] {
        &self.asymmetry
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn column_stats_by_hand() {
        let mut col = [0u16; 16];
        col[3] = 2;
        col[4] = 5;
        col[9] = 1;
        let single = ColumnStats::of(&col, PeakKind::SingleBin);
        assert_eq!(single.peak, 5);
        // l = 3, u = 9, m = 6, w = 6: s = (−3·2 − 2·5 + 3·1)/6 = −13/6.
        assert_eq!(single.asymmetry, (-13 * 16) / 6);
        let two = ColumnStats::of(&col, PeakKind::TwoBin);
        assert_eq!((two.peak, two.asymmetry), (7, 0));
        let empty = ColumnStats::of(&[0u16; 16], PeakKind::TwoBin);
        assert_eq!((empty.peak, empty.asymmetry), (0, 0));
    }

    #[test]
    fn stream_equals_full_accumulator() {
        let mut g = Grid::<20, 12, 1>::new();
        g.set_cells([(1, 1), (2, 1), (3, 1), (4, 2), (5, 3), (19, 11), (7, 7)])
            .unwrap();
        let acc = Accumulator::<18, 32>::vote::<20, 12, 1, 36>(&g);
        let mut columns = [[0u16; 32]; 2];
        for kind in [PeakKind::SingleBin, PeakKind::TwoBin] {
            let streamed = Signature::<18>::stream::<20, 12, 1, 36, 32>(&g, kind, &mut columns);
            assert_eq!(streamed, Signature::from_accumulator(&acc, kind));
        }
    }

    /// The fused reduce-and-clear of a sub-range equals `ColumnStats::of` of
    /// the whole column, for both kinds, odd and even ranges, and leaves the
    /// range zeroed.
    #[test]
    fn take_stats_equals_of_and_clears() {
        let mut state = 0x5851_f42d_4c95_7f2du64;
        for _ in 0..500 {
            let mut next = || {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (state >> 33) as usize
            };
            let low = next() % 16;
            let high = (low + next() % 16).min(15);
            let mut col = [0u16; 16];
            for a in &mut col[low..=high] {
                *a = if next() % 3 == 0 {
                    0
                } else {
                    (next() % 300) as u16
                };
            }
            for kind in [PeakKind::SingleBin, PeakKind::TwoBin] {
                let expected = ColumnStats::of(&col, kind);
                let mut taken = col;
                assert_eq!(take_stats(&mut taken[low..=high], low, kind), expected);
                assert_eq!(taken, [0; 16]);
            }
        }
    }

    /// `S(θ + π) = −S(θ)` is total: a stored `i16::MIN` (which
    /// `Reference::from_bytes` refuses, but a `Signature` can hold) reads
    /// back as `i16::MAX` on the other half, not as an overflow.
    #[test]
    fn asymmetry_of_the_other_half_saturates() {
        let mut s = Signature::<4>::empty(PeakKind::SingleBin);
        s.asymmetry = [i16::MIN, i16::MAX, -7, 0];
        assert_eq!(s.asymmetry(0), i16::MIN);
        assert_eq!(s.asymmetry(4), i16::MAX);
        assert_eq!(s.asymmetry(5), -i16::MAX);
        assert_eq!(s.asymmetry(6), 7);
        assert_eq!(s.asymmetry(8), i16::MIN);
        assert_eq!(s.asymmetry(usize::MAX), 0);
    }
}
