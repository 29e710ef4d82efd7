//! A reference view, prepared once: its signature plus the ρ-profiles of its
//! strongest θ columns (for the improved direction test and the translation).
//! Stored as a plain struct or as bytes (e.g. in flash), so each new
//! measurement costs one signature, not two.

use crate::accumulator::{vote_column_split, Column, UNIT_SCALE_Q16};
use crate::config::max_votes_per_bin;
use crate::correlation::circular_distance;
use crate::error::Error;
use crate::grid::Grid;
use crate::signature::{PeakKind, Signature};

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

/// A prepared reference: signature plus up to [`PROFILE_COLUMNS`] profiles.
///
/// Size: about `4·HALF + 4·(RHO + 8) + 16` bytes (128², `N_THETA` = 360:
/// 1.8 KiB).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Reference<
    const W: usize,
    const H: usize,
    const RW: usize,
    const HALF: usize,
    const RHO: usize,
> {
    pub(crate) signature: Signature<HALF>,
    pub(crate) profiles: heapless::Vec<Profile<RHO>, PROFILE_COLUMNS>,
    pub(crate) occupied: u32,
    pub(crate) grid: Grid<W, H, RW>,
}

/// Magic and format version of the stored bytes ("HHR" + version).
const MAGIC: [u8; 4] = *b"HHR3";
/// The format version this library writes and reads.
pub const REFERENCE_FORMAT: u8 = 3;

impl<const W: usize, const H: usize, const RW: usize, const HALF: usize, const RHO: usize>
    Reference<W, H, RW, HALF, RHO>
{
    /// Bytes of [`Self::to_bytes`]: header 20, signature `4·HALF`, profiles
    /// `4·(2 + RHO)`, the grid `4·RW·H` (for the verification by alignment),
    /// checksum 4. 128², `N_THETA` = 360: 4 164 bytes, of which the grid is
    /// 2 048.
    pub const BYTES: usize = 20 + 4 * HALF + PROFILE_COLUMNS * (2 + RHO) + 4 * RW * H + 4;

    /// Prepares `grid` as a reference: streams its signature, then re-votes the
    /// [`PROFILE_COLUMNS`] strongest, well-separated columns to keep their
    /// profiles. `columns` is scratch. `N = 2·HALF`.
    pub fn prepare<const N: usize>(
        grid: &Grid<W, H, RW>,
        kind: PeakKind,
        columns: &mut [Column<RHO>; 2],
    ) -> Self {
        let signature = Signature::<HALF>::stream::<W, H, RW, N, RHO>(grid, kind, columns);
        let [column, _] = columns;
        let mut profiles = heapless::Vec::new();
        for theta in strongest_columns(&signature) {
            column.fill(0);
            vote_column_split::<W, H, RW, N, RHO>(grid, theta, UNIT_SCALE_Q16, column);
            let max = column.iter().copied().max().unwrap_or(0);
            let shift = (16 - max.leading_zeros()).saturating_sub(8);
            let mut counts = [0u8; RHO];
            for (c, &a) in counts.iter_mut().zip(column.iter()) {
                *c = (a >> shift) as u8;
            }
            // Cannot fail: at most PROFILE_COLUMNS columns are chosen.
            let _ = profiles.push(Profile { theta, counts });
        }
        Self {
            signature,
            profiles,
            occupied: grid.occupied(),
            grid: grid.clone(),
        }
    }

    /// The reference grid itself, kept for the verification by alignment.
    pub const fn grid(&self) -> &Grid<W, H, RW> {
        &self.grid
    }

    /// The signature `D`, `S` of the reference.
    pub const fn signature(&self) -> &Signature<HALF> {
        &self.signature
    }

    /// The stored column profiles, strongest column first.
    pub fn profiles(&self) -> &[Profile<RHO>] {
        &self.profiles
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
        w.put(&[
            kind_byte(self.signature.kind),
            self.profiles.len() as u8,
            0,
            0,
        ]);
        w.put(&self.occupied.to_le_bytes());
        for p in self.signature.peaks() {
            w.put(&p.to_le_bytes());
        }
        for s in self.signature.asymmetries() {
            w.put(&s.to_le_bytes());
        }
        for i in 0..PROFILE_COLUMNS {
            match self.profiles.get(i) {
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
        let sum = fnv1a(&w.out[..w.at]);
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
    /// bins, mode, profile columns or checksum do not match, or the grid
    /// disagrees with the stored cell count or has bits beyond `W`, or the
    /// bytes hold a value [`Self::to_bytes`] never writes: `S(θ) = i16::MIN`,
    /// `S(θ) ≠ 0` in a two-bin reference, `D(θ)` above the cell count or
    /// above [`max_votes_per_bin`](crate::config::max_votes_per_bin) (twice
    /// it for two-bin peaks), a profile column θ ≥ `HALF` or with
    /// `D(θ) = 0`, or an unused profile slot that is not zero.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, Error> {
        if let Some(&[b'H', b'H', b'R', version @ b'0'..=b'9']) = bytes.get(..4) {
            if version != MAGIC[3] {
                return Err(Error::ReferenceVersion {
                    found: version.wrapping_sub(b'0'),
                    expected: REFERENCE_FORMAT,
                });
            }
        }
        let bytes = bytes.get(..Self::BYTES).ok_or(Error::BufferTooSmall {
            needed: Self::BYTES,
        })?;
        let (body, sum) = bytes.split_at(Self::BYTES - 4);
        if sum != fnv1a(body).to_le_bytes() {
            return Err(Error::InvalidReference);
        }
        let mut r = Reader { bytes: body, at: 0 };
        let header_ok = r.take::<4>() == MAGIC
            && u16::from_le_bytes(r.take()) as usize == W
            && u16::from_le_bytes(r.take()) as usize == H
            && u16::from_le_bytes(r.take()) as usize == HALF
            && u16::from_le_bytes(r.take()) as usize == RHO;
        let [kind, count, _, _] = r.take::<4>();
        let kind = match kind {
            0 => PeakKind::SingleBin,
            1 => PeakKind::TwoBin,
            _ => return Err(Error::InvalidReference),
        };
        if !header_ok || count as usize > PROFILE_COLUMNS {
            return Err(Error::InvalidReference);
        }
        let occupied = u32::from_le_bytes(r.take());
        let mut signature = Signature::empty(kind);
        for p in signature.peak.iter_mut() {
            *p = u16::from_le_bytes(r.take());
        }
        for s in signature.asymmetry.iter_mut() {
            *s = i16::from_le_bytes(r.take());
        }
        let mut profiles = heapless::Vec::new();
        for i in 0..PROFILE_COLUMNS {
            let theta_bytes = r.take::<2>();
            let theta = u16::from_le_bytes(theta_bytes) as usize;
            let mut counts = [0u8; RHO];
            for c in counts.iter_mut() {
                *c = r.take::<1>()[0];
            }
            if i < count as usize {
                // A stored column is a local maximum of D with D > 0.
                if theta >= HALF || signature.peak(theta) == 0 {
                    return Err(Error::InvalidReference);
                }
                let _ = profiles.push(Profile { theta, counts });
            } else if theta_bytes != [0, 0] || counts.iter().any(|&c| c != 0) {
                // Unused slots are written as zeros.
                return Err(Error::InvalidReference);
            }
        }
        let mut rows = [[0u32; RW]; H];
        for word in rows.iter_mut().flatten() {
            *word = u32::from_le_bytes(r.take());
        }
        let grid = Grid::from_words(rows);
        if grid.words() != &rows
            || grid.occupied() != occupied
            || !signature_is_possible(&signature, occupied, W, H)
        {
            return Err(Error::InvalidReference);
        }
        Ok(Self {
            signature,
            profiles,
            occupied,
            grid,
        })
    }
}

/// Whether `signature` holds only values the library writes for a grid of
/// `occupied` cells out of `width × height`: `S(θ) ≠ i16::MIN` (the
/// saturation is symmetric, `|S| ≤ i16::MAX`), `S(θ) = 0` for
/// [`PeakKind::TwoBin`] (not computed), and `D(θ) ≤ min(occupied, bound)`
/// with `bound` = [`max_votes_per_bin`] (single bin) or twice it (two bins):
/// each column holds every occupied cell's vote once.
fn signature_is_possible<const HALF: usize>(
    signature: &Signature<HALF>,
    occupied: u32,
    width: usize,
    height: usize,
) -> bool {
    let per_bin = max_votes_per_bin(width, height) as u64;
    let bound = match signature.kind {
        PeakKind::SingleBin => per_bin,
        PeakKind::TwoBin => 2 * per_bin,
    }
    .min(u64::from(occupied));
    let asymmetry_ok = |&s: &i16| match signature.kind {
        PeakKind::SingleBin => s != i16::MIN,
        PeakKind::TwoBin => s == 0,
    };
    signature.peaks().iter().all(|&d| u64::from(d) <= bound)
        && signature.asymmetries().iter().all(asymmetry_ok)
}

/// The [`PROFILE_COLUMNS`] strongest local maxima of `D`, at least 10° apart
/// (modulo π), strongest first.
fn strongest_columns<const HALF: usize>(
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

fn kind_byte(kind: PeakKind) -> u8 {
    match kind {
        PeakKind::SingleBin => 0,
        PeakKind::TwoBin => 1,
    }
}

fn fnv1a(bytes: &[u8]) -> u32 {
    bytes.iter().fold(0x811c_9dc5u32, |h, &b| {
        (h ^ u32::from(b)).wrapping_mul(0x0100_0193)
    })
}

struct Writer<'a> {
    out: &'a mut [u8],
    at: usize,
}

impl Writer<'_> {
    fn put(&mut self, bytes: &[u8]) {
        if let Some(dst) = self.out.get_mut(self.at..self.at + bytes.len()) {
            dst.copy_from_slice(bytes);
        }
        self.at += bytes.len();
    }

    fn skip(&mut self, n: usize) {
        if let Some(dst) = self.out.get_mut(self.at..self.at + n) {
            dst.fill(0);
        }
        self.at += n;
    }
}

struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    /// The next `K` bytes; zeros past the end (lengths are checked up front).
    fn take<const K: usize>(&mut self) -> [u8; K] {
        let mut out = [0u8; K];
        if let Some(src) = self.bytes.get(self.at..self.at + K) {
            out.copy_from_slice(src);
        }
        self.at += K;
        out
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
        let sum = fnv1a(&bytes[..end]);
        bytes[end..].copy_from_slice(&sum.to_le_bytes());
    }

    const PEAKS: usize = 20;
    const ASYMMETRY: usize = PEAKS + 2 * 32;
    const PROFILE: usize = ASYMMETRY + 2 * 32;
    const GRID: usize = PROFILE + PROFILE_COLUMNS * (2 + RHO);

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
        let edits: [(&str, bool, Edit); 17] = [
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
    /// writes) and `D` at the cell count.
    #[test]
    fn extreme_values_the_library_writes_are_accepted() {
        let r = prepared(PeakKind::SingleBin);
        let mut bytes = bytes_of(&r);
        bytes[ASYMMETRY..ASYMMETRY + 2].copy_from_slice(&i16::MAX.to_le_bytes());
        bytes[ASYMMETRY + 2..ASYMMETRY + 4].copy_from_slice(&(-i16::MAX).to_le_bytes());
        bytes[PEAKS + 2..PEAKS + 4].copy_from_slice(&(r.occupied() as u16).to_le_bytes());
        resum(&mut bytes);
        let read = R::from_bytes(&bytes).unwrap();
        assert_eq!(read.signature().asymmetry(32), -i16::MAX);
        assert_eq!(read.signature().asymmetry(33), i16::MAX);
    }
}
