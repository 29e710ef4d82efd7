//! A reference view, prepared once: its signature plus the ρ-profiles of its
//! strongest θ columns (for the improved direction test and the translation).
//! Stored as a plain struct or as bytes (e.g. in flash), so each new
//! measurement costs one signature, not two.

use crate::accumulator::{vote_column_split, Column, UNIT_SCALE_Q16};
use crate::config::max_votes_per_bin;
use crate::correlation::circular_distance;
use crate::error::Error;
use crate::grid::Grid;
use crate::pose::reach::ReachTables;
use crate::signature::{PeakKind, Signature};

mod bytes;
mod scan;
use bytes::{all_zero, byte, fnv1a, le_u16, le_u32, same_words, Writer};
pub use scan::{ScanReference, SCAN_REFERENCE_FORMAT};

/// How many θ columns of the reference keep their ρ-profile.
pub const PROFILE_COLUMNS: usize = 4;

/// The ρ-profile of one θ column of the reference, scaled to `u8`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Profile<const RHO: usize> {
    /// Column index `k ∈ [0, HALF)` (θ = πk/HALF).
    pub theta: usize,
    /// The column's split votes ([`vote_column_split`](crate::stages::vote_column_split))
    /// `>> shift` per bin, with the smallest shift that fits `u8` (the
    /// matching is invariant to a common factor).
    pub counts: [u8; RHO],
}

impl<const RHO: usize> Profile<RHO> {
    /// An unused profile slot: column 0, no counts.
    const EMPTY: Self = Self {
        theta: 0,
        counts: [0; RHO],
    };
}

/// A prepared reference: signature plus up to [`PROFILE_COLUMNS`] profiles.
///
/// Size: about `4·HALF + 4·(RHO + 8) + 4·RW·H + 16` bytes (128², `N_THETA`
/// = 360: 3.7 KiB, of which the grid kept for the verification by alignment
/// is 2 KiB). A reference stored with the firmware can live in flash instead
/// of RAM: see [`Self::from_bytes`].
///
/// With the feature `reach-tables` (on by default) it also keeps the grid's
/// reach tables (`12·RW·H` bytes more: 6 KiB at 128², 24 KiB at 256²; built
/// by [`Self::prepare`] and by [`Self::from_bytes`], at compile time for a
/// `static`, so in flash, not stored in the bytes): the verification's
/// branch and bound then reads one bit a point where it read up to 18 grid
/// rows, for the same answers, bit for bit (the real pairs' verified
/// estimate on the Cortex-M4F at 128²: median 14.1 M → 10.7 M
/// instructions). Without the feature the reference is the size above.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Reference<
    const W: usize,
    const H: usize,
    const RW: usize,
    const HALF: usize,
    const RHO: usize,
> {
    pub(crate) signature: Signature<HALF>,
    pub(crate) profiles: [Profile<RHO>; PROFILE_COLUMNS],
    /// How many of `profiles` are used (the first `count`).
    pub(crate) count: u8,
    pub(crate) occupied: u32,
    pub(crate) grid: Grid<W, H, RW>,
    /// The grid's reach tables for the verification (feature
    /// `reach-tables`; derived from `grid`, not stored in the bytes).
    #[cfg(feature = "reach-tables")]
    pub(crate) reach: ReachTables<W, H, RW>,
}

/// Magic and format version of the stored bytes ("HHR" + version).
const MAGIC: [u8; 4] = [b'H', b'H', b'R', b'0' + REFERENCE_FORMAT];
/// The format version this library writes and reads.
pub const REFERENCE_FORMAT: u8 = 3;

impl<const W: usize, const H: usize, const RW: usize, const HALF: usize, const RHO: usize>
    Reference<W, H, RW, HALF, RHO>
{
    /// Bytes of [`Self::to_bytes`]: header 20, signature `4·HALF`, profiles
    /// `4·(2 + RHO)`, the grid `4·RW·H` (for the verification by alignment),
    /// checksum 4. 128², `N_THETA` = 360: 3 824 bytes, of which the grid is
    /// 2 048.
    pub const BYTES: usize = 20 + 4 * HALF + PROFILE_COLUMNS * (2 + RHO) + 4 * RW * H + 4;

    /// Prepares `grid` as a reference: streams its signature, then re-votes the
    /// [`PROFILE_COLUMNS`] strongest, well-separated columns to keep their
    /// profiles. `columns` is scratch. `N = 2·HALF`.
    ///
    /// The columns are the strongest local maxima of `D(θ)` (`D > 0`, not
    /// below either neighbour, circularly modulo π), chosen greedily,
    /// strongest first (the lowest θ among equals), each at least
    /// `max(HALF/18, 2)` steps (10°) modulo π from those already chosen; as
    /// many as there are, up to [`PROFILE_COLUMNS`].
    ///
    /// Returning a reference by value can cost a second one on the stack
    /// while it is built (with the reach tables, 9 960 B at 128² on the
    /// Cortex-M4F): a firmware short of RAM keeps one reference and renews
    /// it with [`Self::prepare_in_place`].
    pub fn prepare<const N: usize>(
        grid: &Grid<W, H, RW>,
        kind: PeakKind,
        columns: &mut [Column<RHO>; 2],
    ) -> Self {
        let signature = Signature::<HALF>::stream::<W, H, RW, N, RHO>(grid, kind, columns);
        let (profiles, count) =
            profiles_of::<W, H, RW, N, RHO, HALF>(grid, &signature.peak, columns);
        // Built as the returned value itself (no reference-sized local).
        Self {
            signature,
            profiles,
            count,
            occupied: grid.occupied(),
            grid: grid.clone(),
            #[cfg(feature = "reach-tables")]
            reach: ReachTables::of(grid),
        }
    }

    /// The reference of an empty grid (what [`Self::prepare`] makes of it):
    /// a place to [`prepare_in_place`](Self::prepare_in_place) references in.
    pub const fn empty(kind: PeakKind) -> Self {
        Self {
            signature: Signature::empty(kind),
            profiles: [const { Profile::EMPTY }; PROFILE_COLUMNS],
            count: 0,
            occupied: 0,
            grid: Grid::new(),
            #[cfg(feature = "reach-tables")]
            reach: ReachTables::EMPTY,
        }
    }

    /// Makes `self` the reference of `grid`, as [`Self::prepare`] does, in
    /// place: no reference-sized temporary, so a firmware that builds its
    /// references at run time needs the reference once and this call's
    /// stack (Cortex-M4F, 128², `N_THETA` = 360, with the reach tables:
    /// the reference 10 732 B, the call's peak stack in `budgets/TABLE.md`).
    pub fn prepare_in_place<const N: usize>(
        &mut self,
        grid: &Grid<W, H, RW>,
        kind: PeakKind,
        columns: &mut [Column<RHO>; 2],
    ) {
        self.signature
            .restream::<W, H, RW, N, RHO>(grid, kind, columns);
        (self.profiles, self.count) =
            profiles_of::<W, H, RW, N, RHO, HALF>(grid, &self.signature.peak, columns);
        self.occupied = grid.occupied();
        self.grid.clone_from(grid);
        #[cfg(feature = "reach-tables")]
        self.reach.build(&self.grid);
    }

    /// The reference grid itself, kept for the verification by alignment.
    pub const fn grid(&self) -> &Grid<W, H, RW> {
        &self.grid
    }

    /// The grid's reach tables, with the feature `reach-tables`.
    pub(crate) const fn reach(&self) -> Option<&ReachTables<W, H, RW>> {
        #[cfg(feature = "reach-tables")]
        return Some(&self.reach);
        #[cfg(not(feature = "reach-tables"))]
        None
    }

    /// The signature `D`, `S` of the reference.
    pub const fn signature(&self) -> &Signature<HALF> {
        &self.signature
    }

    /// The stored column profiles, strongest column first.
    pub fn profiles(&self) -> &[Profile<RHO>] {
        self.profiles.get(..self.count as usize).unwrap_or(&[])
    }

    /// Number of occupied cells of the reference grid.
    pub const fn occupied(&self) -> u32 {
        self.occupied
    }

    /// Writes the reference as [`Self::BYTES`] bytes (little-endian, with a
    /// magic number, the sizes and an FNV-1a checksum). Returns the length.
    ///
    /// # Errors
    /// [`Error::BufferTooSmall`] if `out` is shorter than [`Self::BYTES`].
    pub fn to_bytes(&self, out: &mut [u8]) -> Result<usize, Error> {
        let out = out.get_mut(..Self::BYTES).ok_or(Error::BufferTooSmall {
            needed: Self::BYTES,
        })?;
        let mut w = Writer { out, at: 0 };
        w.put(&MAGIC);
        w.put(&(W as u16).to_le_bytes());
        w.put(&(H as u16).to_le_bytes());
        w.put(&(HALF as u16).to_le_bytes());
        w.put(&(RHO as u16).to_le_bytes());
        w.put(&[kind_byte(self.signature.kind), self.count, 0, 0]);
        w.put(&self.occupied.to_le_bytes());
        for p in self.signature.peaks() {
            w.put(&p.to_le_bytes());
        }
        for s in self.signature.asymmetries() {
            w.put(&s.to_le_bytes());
        }
        for i in 0..PROFILE_COLUMNS {
            match self.profiles().get(i) {
                Some(p) => {
                    w.put(&(p.theta as u16).to_le_bytes());
                    w.put(&p.counts);
                }
                None => w.skip(2 + RHO),
            }
        }
        for word in self.grid.words().iter().flatten() {
            w.put(&word.to_le_bytes());
        }
        let sum = fnv1a(w.out, w.at);
        w.put(&sum.to_le_bytes());
        Ok(Self::BYTES)
    }

    /// Reads a reference written by [`Self::to_bytes`] for the same grid size,
    /// `HALF` and `RHO`.
    ///
    /// # Errors
    /// [`Error::ReferenceVersion`] if the bytes are a reference of another
    /// format version (e.g. version 2, written before the grid was kept: prepare
    /// and store the reference again); [`Error::BufferTooSmall`] if `bytes` is
    /// short; [`Error::InvalidReference`] if the magic, grid size, θ steps, ρ
    /// bins, mode, profile columns or checksum do not match, the two
    /// reserved header bytes are not zero, or the grid
    /// disagrees with the stored cell count or has bits beyond `W`, or the
    /// bytes hold a value [`Self::to_bytes`] never writes: `S(θ) = i16::MIN`,
    /// `S(θ) ≠ 0` in a two-bin reference, `D(θ)` above the cell count or
    /// above [`max_votes_per_bin`](crate::config::max_votes_per_bin) (twice
    /// it for two-bin peaks), profile columns other than those
    /// [`Self::prepare`] chooses from the stored `D(θ)` (another count, order
    /// or column: a column that is not a local maximum of `D`, one too close
    /// to a stronger one, a duplicate, a weaker column ahead of a stronger
    /// one, a strong column left out), a used profile whose counts are all
    /// zero (its column holds every cell's vote), or an unused profile slot
    /// that is not zero.
    ///
    /// Not checked: the values of `D(θ)`, `S(θ)` and the profile counts
    /// (beyond the bounds above), and whether they belong to the stored
    /// grid. They are functions of the grid, but checking them means voting
    /// it again (what [`Self::prepare`] costs, which a stored reference
    /// exists to avoid; the vote loops are not `const fn`), so a grid
    /// replaced together with its cell count is read with the old
    /// signature and profiles; the checksum catches accidental corruption.
    ///
    /// A `const fn`: a reference stored with the firmware can be parsed at
    /// compile time into a `static`, which then lives in flash and costs no
    /// RAM (the checks above run in the compiler; invalid bytes fail the
    /// build):
    ///
    /// ```ignore
    /// static REFERENCE: hough_heading::reference!(128, 128, 360) =
    ///     match hough_heading::Reference::from_bytes(include_bytes!("dock.hhr")) {
    ///         Ok(r) => r,
    ///         Err(_) => panic!("dock.hhr is not a 128², N_THETA = 360 reference"),
    ///     };
    /// ```
    pub const fn from_bytes(bytes: &[u8]) -> Result<Self, Error> {
        if let Err(e) = check_envelope(bytes, MAGIC, Self::BYTES) {
            return Err(e);
        }
        let header_ok = le_u16(bytes, 4) as usize == W
            && le_u16(bytes, 6) as usize == H
            && le_u16(bytes, 8) as usize == HALF
            && le_u16(bytes, 10) as usize == RHO;
        let kind = match byte(bytes, 12) {
            0 => PeakKind::SingleBin,
            1 => PeakKind::TwoBin,
            _ => return Err(Error::InvalidReference),
        };
        let count = byte(bytes, 13) as usize;
        // Bytes 14–15 are reserved: written as zeros.
        let reserved_ok = byte(bytes, 14) == 0 && byte(bytes, 15) == 0;
        if !header_ok || !reserved_ok || count > PROFILE_COLUMNS {
            return Err(Error::InvalidReference);
        }
        let occupied = le_u32(bytes, 16);
        let mut at = 20;
        let mut signature = Signature::empty(kind);
        let mut k = 0;
        while k < HALF {
            signature.peak[k] = le_u16(bytes, at + 2 * k);
            signature.asymmetry[k] = le_u16(bytes, at + 2 * (HALF + k)) as i16;
            k += 1;
        }
        at += 4 * HALF;
        let (chosen, chosen_count) = strongest_columns(&signature.peak);
        if count != chosen_count {
            return Err(Error::InvalidReference);
        }
        let mut profiles = [const { Profile::EMPTY }; PROFILE_COLUMNS];
        let mut i = 0;
        while i < PROFILE_COLUMNS {
            let theta = le_u16(bytes, at) as usize;
            let mut counts = [0u8; RHO];
            let mut b = 0;
            while b < RHO {
                counts[b] = byte(bytes, at + 2 + b);
                b += 1;
            }
            if i < count {
                // The columns `prepare` chooses from this D, in its order.
                if theta != chosen[i] || all_zero(&counts) {
                    return Err(Error::InvalidReference);
                }
                profiles[i] = Profile { theta, counts };
            } else if theta != 0 || !all_zero(&counts) {
                // Unused slots are written as zeros.
                return Err(Error::InvalidReference);
            }
            at += 2 + RHO;
            i += 1;
        }
        let grid = match read_grid::<W, H, RW>(bytes, at, occupied) {
            Some(grid) if signature_is_possible(&signature, occupied, W, H) => grid,
            _ => return Err(Error::InvalidReference),
        };
        Ok(Self {
            signature,
            profiles,
            count: count as u8,
            occupied,
            #[cfg(feature = "reach-tables")]
            reach: ReachTables::of(&grid),
            grid,
        })
    }
}

/// The checks every stored format of this module shares, in order: bytes
/// that start like `magic` (its three letters) but carry another version
/// digit give [`Error::ReferenceVersion`]; fewer than `len` bytes
/// [`Error::BufferTooSmall`]; another magic, or an FNV-1a checksum of the
/// first `len − 4` bytes that differs from the last four,
/// [`Error::InvalidReference`].
const fn check_envelope(bytes: &[u8], magic: [u8; 4], len: usize) -> Result<(), Error> {
    let version = byte(bytes, 3);
    if bytes.len() >= 4
        && byte(bytes, 0) == magic[0]
        && byte(bytes, 1) == magic[1]
        && byte(bytes, 2) == magic[2]
        && version.is_ascii_digit()
        && version != magic[3]
    {
        return Err(Error::ReferenceVersion {
            found: version.wrapping_sub(b'0'),
            expected: magic[3].wrapping_sub(b'0'),
        });
    }
    if bytes.len() < len {
        return Err(Error::BufferTooSmall { needed: len });
    }
    let body = len - 4;
    if le_u32(bytes, 0) != u32::from_le_bytes(magic) || le_u32(bytes, body) != fnv1a(bytes, body) {
        return Err(Error::InvalidReference);
    }
    Ok(())
}

/// The grid stored as `H` rows of `RW` little-endian words from byte `at`;
/// `None` if a row has bits beyond `W` or the grid does not hold
/// `occupied` cells.
const fn read_grid<const W: usize, const H: usize, const RW: usize>(
    bytes: &[u8],
    at: usize,
    occupied: u32,
) -> Option<Grid<W, H, RW>> {
    let mut rows = [[0u32; RW]; H];
    let mut at = at;
    let mut r = 0;
    while r < H {
        let mut w = 0;
        while w < RW {
            rows[r][w] = le_u32(bytes, at);
            at += 4;
            w += 1;
        }
        r += 1;
    }
    let grid = Grid::from_words(rows);
    // `from_words` clears bits beyond W: a changed row held such bits.
    if same_words(grid.words(), &rows) && grid.occupied() == occupied {
        Some(grid)
    } else {
        None
    }
}

/// Whether `signature` holds only values the library writes for a grid of
/// `occupied` cells out of `width × height`: `S(θ) ≠ i16::MIN` (the
/// saturation is symmetric, `|S| ≤ i16::MAX`), `S(θ) = 0` for
/// [`PeakKind::TwoBin`] (not computed), and `D(θ) ≤ min(occupied, bound)`
/// with `bound` = [`max_votes_per_bin`] (single bin) or twice it (two bins):
/// each column holds every occupied cell's vote once.
const fn signature_is_possible<const HALF: usize>(
    signature: &Signature<HALF>,
    occupied: u32,
    width: usize,
    height: usize,
) -> bool {
    let per_bin = max_votes_per_bin(width, height) as u64;
    let bound = match signature.kind {
        PeakKind::SingleBin => per_bin,
        PeakKind::TwoBin => 2 * per_bin,
    };
    let bound = if bound < occupied as u64 {
        bound
    } else {
        occupied as u64
    };
    let mut k = 0;
    while k < HALF {
        let s = signature.asymmetry[k];
        let asymmetry_ok = match signature.kind {
            PeakKind::SingleBin => s != i16::MIN,
            PeakKind::TwoBin => s == 0,
        };
        if signature.peak[k] as u64 > bound || !asymmetry_ok {
            return false;
        }
        k += 1;
    }
    true
}

/// The profiles [`Reference::prepare`] keeps for the signature `D` = `peak`
/// of `grid`, and how many: its [`strongest_columns`] re-voted, with
/// `columns[0]` as scratch.
fn profiles_of<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const RHO: usize,
    const HALF: usize,
>(
    grid: &Grid<W, H, RW>,
    peak: &[u16; HALF],
    columns: &mut [Column<RHO>; 2],
) -> ([Profile<RHO>; PROFILE_COLUMNS], u8) {
    let [column, _] = columns;
    let mut profiles = [const { Profile::EMPTY }; PROFILE_COLUMNS];
    let (chosen, count) = strongest_columns(peak);
    for (slot, &theta) in profiles.iter_mut().zip(chosen.iter().take(count)) {
        column.fill(0);
        vote_column_split::<W, H, RW, N, RHO>(grid, theta, UNIT_SCALE_Q16, column);
        let max = column.iter().copied().max().unwrap_or(0);
        let shift = (16 - max.leading_zeros()).saturating_sub(8);
        let mut counts = [0u8; RHO];
        for (c, &a) in counts.iter_mut().zip(column.iter()) {
            *c = (a >> shift) as u8;
        }
        *slot = Profile { theta, counts };
    }
    // At most PROFILE_COLUMNS columns are chosen.
    (profiles, count as u8)
}

/// The columns [`Reference::prepare`] keeps for the signature `D` = `peak`:
/// the [`PROFILE_COLUMNS`] strongest local maxima of `D` (`D(k) > 0` and
/// `D(k) ≥ D(k ± 1)`, circularly modulo π), at least `max(HALF/18, 2)`
/// steps (10°) apart modulo π, chosen greedily: strongest first, the lowest
/// `k` among equals. Returns the columns (the first `count` are used) and
/// `count`. A `const fn`, so that [`Reference::from_bytes`] checks the
/// stored columns by the very rule that chose them.
const fn strongest_columns<const HALF: usize>(
    peak: &[u16; HALF],
) -> ([usize; PROFILE_COLUMNS], usize) {
    let separation = if HALF / 18 > 2 { HALF / 18 } else { 2 };
    let mut chosen = [0usize; PROFILE_COLUMNS];
    let mut count = 0;
    while count < PROFILE_COLUMNS {
        // The strongest admissible column, the lowest k among equals.
        let mut best: Option<(u16, usize)> = None;
        let mut k = 0;
        while k < HALF {
            let value = peak[k];
            let before = peak[if k == 0 { HALF - 1 } else { k - 1 }];
            let after = peak[if k + 1 == HALF { 0 } else { k + 1 }];
            let stronger = match best {
                Some((b, _)) => value > b,
                None => true,
            };
            if value > 0
                && value >= before
                && value >= after
                && stronger
                && far_from(&chosen, count, k, separation, HALF)
            {
                best = Some((value, k));
            }
            k += 1;
        }
        match best {
            Some((_, k)) => {
                chosen[count] = k;
                count += 1;
            }
            None => break,
        }
    }
    (chosen, count)
}

/// Whether `k` is at least `separation` steps (modulo `half`) from each of
/// the first `count` columns of `chosen`.
const fn far_from(
    chosen: &[usize; PROFILE_COLUMNS],
    count: usize,
    k: usize,
    separation: usize,
    half: usize,
) -> bool {
    let mut i = 0;
    while i < count && i < PROFILE_COLUMNS {
        if circular_distance(chosen[i], k, half) < separation {
            return false;
        }
        i += 1;
    }
    true
}

fn kind_byte(kind: PeakKind) -> u8 {
    match kind {
        PeakKind::SingleBin => 0,
        PeakKind::TwoBin => 1,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::rho_bins;

    const RHO: usize = rho_bins(32, 32);
    type R = Reference<32, 32, 1, 32, RHO>;

    /// An L of two walls and a stray cell: a reference with several profiles.
    fn prepared(kind: PeakKind) -> R {
        let mut g = Grid::<32, 32, 1>::new();
        g.set_cells((4..28).map(|c| (c, 6))).unwrap();
        g.set_cells((6..26).map(|r| (5, r))).unwrap();
        g.set_cells([(20, 20), (25, 12)]).unwrap();
        let mut columns = [[0u16; RHO]; 2];
        R::prepare::<64>(&g, kind, &mut columns)
    }

    fn bytes_of(r: &R) -> [u8; R::BYTES] {
        let mut out = [0u8; R::BYTES];
        assert_eq!(r.to_bytes(&mut out), Ok(R::BYTES));
        out
    }

    /// Recomputes the checksum after an edit, as `to_bytes` writes it.
    fn resum(bytes: &mut [u8]) {
        let end = bytes.len() - 4;
        let sum = fnv1a(bytes, end);
        bytes[end..].copy_from_slice(&sum.to_le_bytes());
    }

    const PEAKS: usize = 20;
    const ASYMMETRY: usize = PEAKS + 2 * 32;
    const PROFILE: usize = ASYMMETRY + 2 * 32;
    const GRID: usize = PROFILE + PROFILE_COLUMNS * (2 + RHO);

    /// Preparing in place over another reference leaves nothing of it: the
    /// same reference as one prepared afresh, tables included; the empty
    /// reference is that of an empty grid.
    #[test]
    fn prepared_in_place_over_another_reference_is_the_fresh_one() {
        let mut columns = [[0u16; RHO]; 2];
        let mut sparse = Grid::<32, 32, 1>::new();
        sparse.set_cells([(3, 3), (29, 17)]).unwrap();
        for (kind, other) in [
            (PeakKind::SingleBin, PeakKind::TwoBin),
            (PeakKind::TwoBin, PeakKind::SingleBin),
        ] {
            let mut reference = prepared(other);
            assert!(reference.profiles().len() >= 2);
            let fresh = R::prepare::<64>(&sparse, kind, &mut columns);
            reference.prepare_in_place::<64>(&sparse, kind, &mut columns);
            assert_eq!(reference, fresh, "{kind:?}");
            assert_ne!(reference, prepared(other));
            // Over a reference with profiles, an empty grid leaves none.
            let mut reference = prepared(other);
            reference.prepare_in_place::<64>(&Grid::new(), kind, &mut columns);
            assert_eq!(reference, R::empty(kind), "{kind:?}");
            assert!(reference.profiles().is_empty());
            let empty = R::prepare::<64>(&Grid::new(), kind, &mut columns);
            assert_eq!(R::empty(kind), empty, "{kind:?}");
        }
    }

    #[test]
    fn round_trip_both_kinds() {
        for kind in [PeakKind::SingleBin, PeakKind::TwoBin] {
            let r = prepared(kind);
            assert!(r.profiles().len() >= 2, "{kind:?}");
            let bytes = bytes_of(&r);
            assert_eq!(R::from_bytes(&bytes), Ok(r.clone()));
            // Longer buffers are fine: only the first BYTES count.
            let mut long = [0xA5u8; R::BYTES + 7];
            long[..R::BYTES].copy_from_slice(&bytes);
            assert_eq!(R::from_bytes(&long), Ok(r.clone()));
            // Too short to write or to read.
            let mut short = [0u8; R::BYTES - 1];
            let needed = Error::BufferTooSmall { needed: R::BYTES };
            assert_eq!(r.to_bytes(&mut short), Err(needed));
            assert_eq!(R::from_bytes(&bytes[..R::BYTES - 1]), Err(needed));
        }
    }

    #[test]
    fn version_is_checked_before_anything_else() {
        let mut bytes = bytes_of(&prepared(PeakKind::SingleBin));
        assert_eq!(&bytes[..4], b"HHR3");
        for version in [b'0', b'2', b'4', b'9'] {
            bytes[3] = version;
            let expected = Error::ReferenceVersion {
                found: version - b'0',
                expected: REFERENCE_FORMAT,
            };
            // Even a short buffer with a wrong checksum says "version".
            assert_eq!(R::from_bytes(&bytes), Err(expected));
            assert_eq!(R::from_bytes(&bytes[..4]), Err(expected));
        }
    }

    /// Every field `from_bytes` checks, edited with the checksum recomputed:
    /// each edit alone is refused.
    #[test]
    fn every_rejected_field() {
        let single = bytes_of(&prepared(PeakKind::SingleBin));
        let two = bytes_of(&prepared(PeakKind::TwoBin));
        let r = prepared(PeakKind::SingleBin);
        assert!(!r.profiles().is_empty());
        let occupied = r.occupied() as u16;
        let bound = max_votes_per_bin(32, 32) as u16;
        type Edit = fn(&mut [u8], u16, u16);
        let edits: [(&str, bool, Edit); 23] = [
            ("magic", false, |b, _, _| b[0] = b'X'),
            ("width", false, |b, _, _| b[4] = 33),
            ("height", false, |b, _, _| b[6] = 31),
            ("half", false, |b, _, _| b[8] = 16),
            ("rho", false, |b, _, _| b[10] = 0),
            ("kind", false, |b, _, _| b[12] = 2),
            ("profile count", false, |b, _, _| b[13] = 5),
            ("occupied", false, |b, _, _| b[16] ^= 1),
            ("grid disagrees with the count", false, |b, _, _| {
                b[GRID] ^= 1
            }),
            ("profile θ ≥ HALF", false, |b, _, _| {
                b[PROFILE..PROFILE + 2].copy_from_slice(&32u16.to_le_bytes());
            }),
            ("S = i16::MIN", false, |b, _, _| {
                b[ASYMMETRY + 6..ASYMMETRY + 8].copy_from_slice(&i16::MIN.to_le_bytes());
            }),
            ("S ≠ 0 in a two-bin reference", true, |b, _, _| {
                b[ASYMMETRY + 6..ASYMMETRY + 8].copy_from_slice(&1i16.to_le_bytes());
            }),
            ("D above the cell count", false, |b, occupied, _| {
                b[PEAKS + 4..PEAKS + 6].copy_from_slice(&(occupied + 1).to_le_bytes());
            }),
            ("D above the two-bin bound", true, |b, _, bound| {
                b[PEAKS + 4..PEAKS + 6].copy_from_slice(&(2 * bound + 1).to_le_bytes());
            }),
            // The last slot becomes unused but keeps its bytes.
            ("unused profile slot not zero", false, |b, _, _| b[13] -= 1),
            ("profile θ at D = 0", false, |b, _, _| {
                let theta = usize::from(u16::from_le_bytes([b[PROFILE], b[PROFILE + 1]]));
                b[PEAKS + 2 * theta..PEAKS + 2 * theta + 2].fill(0);
            }),
            // The profile columns must be those `prepare` chooses from D.
            ("count one less, last slot zeroed", false, |b, _, _| {
                b[13] -= 1;
                let last = PROFILE + usize::from(b[13]) * (2 + RHO);
                b[last..last + 2 + RHO].fill(0);
            }),
            ("first two profiles swapped", false, |b, _, _| {
                let (first, second) = b[PROFILE..GRID].split_at_mut(2 + RHO);
                first.swap_with_slice(&mut second[..2 + RHO]);
            }),
            ("first profile duplicated", false, |b, _, _| {
                b.copy_within(PROFILE..PROFILE + 2 + RHO, PROFILE + 2 + RHO);
            }),
            (
                "first column no longer a local maximum",
                false,
                |b, _, _| {
                    let theta = usize::from(u16::from_le_bytes([b[PROFILE], b[PROFILE + 1]]));
                    let d = u16::from_le_bytes([b[PEAKS + 2 * theta], b[PEAKS + 2 * theta + 1]]);
                    let next = PEAKS + 2 * ((theta + 1) % 32);
                    b[next..next + 2].copy_from_slice(&(d + 1).to_le_bytes());
                },
            ),
            (
                "second column within the separation of the first",
                false,
                |b, _, _| {
                    // θ₀ + 1 made a local maximum as strong as θ₀: `prepare`
                    // skips it (closer than max(HALF/18, 2) = 2 steps).
                    let theta = usize::from(u16::from_le_bytes([b[PROFILE], b[PROFILE + 1]]));
                    let close = (theta + 1) % 32;
                    b.copy_within(PEAKS + 2 * theta..PEAKS + 2 * theta + 2, PEAKS + 2 * close);
                    let second = PROFILE + 2 + RHO;
                    b[second..second + 2].copy_from_slice(&(close as u16).to_le_bytes());
                },
            ),
            ("profile counts all zero", false, |b, _, _| {
                b[PROFILE + 2..PROFILE + 2 + RHO].fill(0);
            }),
            ("checksum", false, |b, _, _| b[R::BYTES - 1] ^= 1),
        ];
        for (name, two_bin, edit) in edits {
            let mut bytes = if two_bin { two } else { single };
            edit(&mut bytes, occupied, bound);
            if name != "checksum" {
                resum(&mut bytes);
            }
            assert_eq!(
                R::from_bytes(&bytes),
                Err(Error::InvalidReference),
                "{name}"
            );
        }
    }

    /// Bounds `from_bytes` accepts: `|S| = i16::MAX` (what the saturation
    /// writes) and `D` at the cell count (at the strongest profile column,
    /// where it leaves the choice of columns as it is).
    #[test]
    fn extreme_values_the_library_writes_are_accepted() {
        let r = prepared(PeakKind::SingleBin);
        let mut bytes = bytes_of(&r);
        bytes[ASYMMETRY..ASYMMETRY + 2].copy_from_slice(&i16::MAX.to_le_bytes());
        bytes[ASYMMETRY + 2..ASYMMETRY + 4].copy_from_slice(&(-i16::MAX).to_le_bytes());
        let strongest = PEAKS + 2 * r.profiles()[0].theta;
        bytes[strongest..strongest + 2].copy_from_slice(&(r.occupied() as u16).to_le_bytes());
        resum(&mut bytes);
        let read = R::from_bytes(&bytes).unwrap();
        assert_eq!(read.signature().asymmetry(32), -i16::MAX);
        assert_eq!(read.signature().asymmetry(33), i16::MAX);
        assert_eq!(
            read.signature().peak(r.profiles()[0].theta),
            r.occupied() as u16
        );
        assert_eq!(read.profiles(), r.profiles());
    }

    /// What `from_bytes` cannot check (documented): the profile counts
    /// beyond "not all zero". Halved, they are accepted.
    #[test]
    fn profile_counts_are_not_checked_against_the_grid() {
        let r = prepared(PeakKind::SingleBin);
        let mut bytes = bytes_of(&r);
        bytes[PROFILE + 2..PROFILE + 2 + RHO]
            .iter_mut()
            .for_each(|c| *c >>= 1);
        resum(&mut bytes);
        let read = R::from_bytes(&bytes).unwrap();
        assert_ne!(read.profiles()[0].counts, r.profiles()[0].counts);
    }

    /// The former iterator form of the column choice (before it became a
    /// `const fn` for `from_bytes`), kept as the oracle of the rule.
    fn strongest_columns_oracle<const HALF: usize>(
        signature: &Signature<HALF>,
    ) -> heapless::Vec<usize, PROFILE_COLUMNS> {
        let separation = (HALF / 18).max(2);
        let mut chosen: heapless::Vec<usize, PROFILE_COLUMNS> = heapless::Vec::new();
        while !chosen.is_full() {
            let next = (0..HALF)
                .map(|k| {
                    (
                        k,
                        signature.peak(k),
                        signature.peak(k + HALF - 1),
                        signature.peak(k + 1),
                    )
                })
                .filter(|&(_, value, before, after)| value > 0 && value >= before && value >= after)
                .filter(|&(k, ..)| {
                    chosen
                        .iter()
                        .all(|&c| circular_distance(c, k, HALF) >= separation)
                })
                .map(|(k, value, ..)| (value, core::cmp::Reverse(k)))
                .max()
                .map(|(_, core::cmp::Reverse(k))| k);
            match next {
                Some(k) => {
                    let _ = chosen.push(k);
                }
                None => break,
            }
        }
        chosen
    }

    /// The `const fn` choice equals the oracle on random `D` with few
    /// distinct values (plateaus, ties, zeros, wrap-around maxima).
    fn choice_matches_oracle<const HALF: usize>(seed: u64) {
        let mut state = seed;
        for levels in [2u64, 3, 5, 40] {
            for _ in 0..300 {
                let mut signature = Signature::<HALF>::empty(PeakKind::SingleBin);
                for d in signature.peak.iter_mut() {
                    state = state
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    *d = ((state >> 33) % levels) as u16;
                }
                let (chosen, count) = strongest_columns(&signature.peak);
                let oracle = strongest_columns_oracle(&signature);
                assert_eq!(&chosen[..count], &oracle[..], "{:?}", signature.peak);
            }
        }
    }

    #[test]
    fn column_choice_matches_the_iterator_form() {
        choice_matches_oracle::<1>(1);
        choice_matches_oracle::<2>(2);
        choice_matches_oracle::<3>(3);
        choice_matches_oracle::<32>(4);
        choice_matches_oracle::<64>(5);
        choice_matches_oracle::<180>(6);
    }
}
