//! A reference for estimates on laser scans: the [`Reference`] of the scan's
//! occupied cells, the free space its beams crossed and the scan itself,
//! stored together so that a relocalization against a stored view keeps the
//! evidence that tells a large turn from a small one
//! ([`Estimator::estimate_scans`]) and the beams that confirm or refuse the
//! answer ([`Raster::check_on_beams`], [`Raster::refine_on_beams`]).
//!
//! [`Estimator::estimate_scans`]: crate::Estimator::estimate_scans

use super::bytes::{fnv1a, le_u32, Writer};
use super::{check_envelope, read_grid, Reference};
use crate::error::Error;
use crate::grid::Grid;
use crate::scan::{FreeSpace, Raster, Scan, SensorOffset};

/// Magic and format version of the stored bytes ("HHS" + version).
const MAGIC: [u8; 4] = [b'H', b'H', b'S', b'0' + SCAN_REFERENCE_FORMAT];
/// The scan reference format this library writes and reads. Format 2 added
/// the scan's beams; format 1 bytes are refused with
/// [`Error::ReferenceVersion`].
pub const SCAN_REFERENCE_FORMAT: u8 = 2;
/// Bytes of the stored raster: cell, gap, clip flag and 3 reserved.
const RASTER_BYTES: usize = 12;
/// Bytes of the stored scan's geometry: `angle_min`, `angle_increment`,
/// `max_range` and the offset's `x`, `y`, `theta`, as `f32` bits.
const GEOMETRY_BYTES: usize = 24;

/// A scan's [`Reference`] together with its free space (the cells its beams
/// crossed, [`Raster::free_space`]), the [`Raster`] both were drawn with and
/// the scan itself (up to `BEAMS` readings and their geometry). What a
/// firmware stores (in flash, see [`Self::from_bytes`]) to relocalize on
/// scans against a known view: it rasterizes each new scan with
/// [`Self::raster`], so the two views share their scale, estimates with the
/// free-space test of the verification
/// ([`Estimator::estimate_scans`](crate::Estimator::estimate_scans)), and
/// checks the answer on the beams of [`Self::scan`] and the new scan
/// ([`Raster::check_on_beams`]), as the host tool does for a pair.
///
/// Size: [`Reference`] plus one grid (`4·RW·H` bytes: 2 KiB at 128²), the
/// raster's settings and `4·BEAMS + 32` bytes for the scan (4.3 KiB for a
/// 1 081-beam scanner). `BEAMS` = 0 stores no beams: the free-space test
/// still works, the check on the beams does not (it returns `None`).
#[derive(Clone, Debug, PartialEq)]
pub struct ScanReference<
    const W: usize,
    const H: usize,
    const RW: usize,
    const HALF: usize,
    const RHO: usize,
    const BEAMS: usize,
> {
    reference: Reference<W, H, RW, HALF, RHO>,
    free: Grid<W, H, RW>,
    raster: Raster,
    /// The scan's readings (metres); the first `beams` are used, the rest 0.
    ranges: [f32; BEAMS],
    beams: usize,
    angle_min: f32,
    angle_increment: f32,
    max_range: f32,
    offset: SensorOffset,
}

impl<
        const W: usize,
        const H: usize,
        const RW: usize,
        const HALF: usize,
        const RHO: usize,
        const BEAMS: usize,
    > ScanReference<W, H, RW, HALF, RHO, BEAMS>
{
    /// Bytes of [`Self::to_bytes`] before the scan's readings: magic 4, the
    /// reference's [`Reference::BYTES`], the raster 12, the free grid
    /// `4·RW·H`, its cell count 4, the scan's geometry 24 and its beam
    /// count 4.
    const HEAD_BYTES: usize = 4
        + Reference::<W, H, RW, HALF, RHO>::BYTES
        + RASTER_BYTES
        + 4 * RW * H
        + 4
        + GEOMETRY_BYTES
        + 4;

    /// The most bytes [`Self::to_bytes`] writes: a scan of `BEAMS` readings
    /// (a buffer this long holds any scan reference of this type). 128²,
    /// `N_THETA` = 360: `5 924 + 4·BEAMS` bytes.
    pub const MAX_BYTES: usize = Self::bytes_for(BEAMS);

    /// Bytes of the stored form of a scan of `readings` readings: the head,
    /// four bytes a reading and the checksum (`usize::MAX` past `usize`: a
    /// count read from untrusted bytes).
    const fn bytes_for(readings: usize) -> usize {
        match readings.checked_mul(4) {
            Some(bytes) => bytes.saturating_add(Self::HEAD_BYTES + 4),
            None => usize::MAX,
        }
    }

    /// The reference of a scan's occupied cells and the free space of the
    /// same scan, both drawn with `raster`, and the scan (copied).
    ///
    /// # Errors
    /// [`Error::TooManyBeams`] if `scan` has more than `BEAMS` readings.
    pub const fn new(
        reference: Reference<W, H, RW, HALF, RHO>,
        free: Grid<W, H, RW>,
        raster: Raster,
        scan: &Scan<'_>,
    ) -> Result<Self, Error> {
        let beams = scan.ranges.len();
        if beams > BEAMS {
            return Err(Error::TooManyBeams {
                beams,
                capacity: BEAMS,
            });
        }
        let mut ranges = [0.0; BEAMS];
        let mut i = 0;
        while i < beams {
            ranges[i] = scan.ranges[i];
            i += 1;
        }
        Ok(Self {
            reference,
            free,
            raster,
            ranges,
            beams,
            angle_min: scan.angle_min,
            angle_increment: scan.angle_increment,
            max_range: scan.max_range,
            offset: scan.offset,
        })
    }

    /// The reference of the scan's occupied cells (for
    /// [`Estimator::estimate_scans`](crate::Estimator::estimate_scans)).
    pub const fn reference(&self) -> &Reference<W, H, RW, HALF, RHO> {
        &self.reference
    }

    /// The cells the reference scan's beams crossed.
    pub const fn free(&self) -> &Grid<W, H, RW> {
        &self.free
    }

    /// The raster the reference scan was drawn with: draw each new scan
    /// (its occupied cells and its free space) with it too.
    pub const fn raster(&self) -> Raster {
        self.raster
    }

    /// The stored scan, exactly as it was given to [`Self::new`] (readings
    /// and geometry bit for bit): the reference scan of
    /// [`Raster::check_on_beams`] and [`Raster::refine_on_beams`] against a
    /// new scan.
    pub const fn scan(&self) -> Scan<'_> {
        let ranges = match self.ranges.split_at_checked(self.beams) {
            Some((used, _)) => used,
            None => &self.ranges,
        };
        Scan {
            ranges,
            angle_min: self.angle_min,
            angle_increment: self.angle_increment,
            max_range: self.max_range,
            offset: self.offset,
        }
    }

    /// The free space of an estimate against this reference: its own and
    /// `current`'s, the free cells of the new scan on the same raster.
    pub const fn free_space<'a>(&'a self, current: &'a Grid<W, H, RW>) -> FreeSpace<'a, W, H, RW> {
        FreeSpace {
            reference: &self.free,
            current,
        }
    }

    /// Bytes [`Self::to_bytes`] writes for this scan reference:
    /// `MAX_BYTES − 4·(BEAMS − beams)`.
    pub const fn byte_len(&self) -> usize {
        Self::bytes_for(self.beams)
    }

    /// Writes the scan reference as [`Self::byte_len`] bytes
    /// (little-endian): the magic `HHS2`, the reference as
    /// [`Reference::to_bytes`] writes it (with its own checksum), the raster
    /// (metres per cell and the [`connect`](Raster::connect) gap as `f32`
    /// bits, 0 when off; 1 when [`clip_to_disc`](Raster::clip_to_disc),
    /// then 3 zero bytes), the free grid's row words, its cell count, the
    /// scan's `angle_min`, `angle_increment`, `max_range`, offset `x`, `y`,
    /// `theta` (`f32` bits), its number of readings, the readings (`f32`
    /// bits) and an FNV-1a checksum of everything before. Returns the
    /// length.
    ///
    /// # Errors
    /// [`Error::BufferTooSmall`] if `out` is shorter than
    /// [`Self::byte_len`].
    pub fn to_bytes(&self, out: &mut [u8]) -> Result<usize, Error> {
        let needed = self.byte_len();
        let out = out
            .get_mut(..needed)
            .ok_or(Error::BufferTooSmall { needed })?;
        let (head, rest) = out
            .split_at_mut_checked(MAGIC.len())
            .ok_or(Error::BufferTooSmall { needed })?;
        head.copy_from_slice(&MAGIC);
        let written = self
            .reference
            .to_bytes(rest)
            .map_err(|_| Error::BufferTooSmall { needed })?;
        let mut w = Writer {
            out,
            at: MAGIC.len() + written,
        };
        let (cell, gap, disc) = self.raster.settings();
        w.put(&cell.to_bits().to_le_bytes());
        w.put(&gap.to_bits().to_le_bytes());
        w.put(&[u8::from(disc), 0, 0, 0]);
        for word in self.free.words().iter().flatten() {
            w.put(&word.to_le_bytes());
        }
        w.put(&self.free.occupied().to_le_bytes());
        let scan = self.scan();
        for value in [
            scan.angle_min,
            scan.angle_increment,
            scan.max_range,
            scan.offset.x,
            scan.offset.y,
            scan.offset.theta,
        ] {
            w.put(&value.to_bits().to_le_bytes());
        }
        // At most `BEAMS` readings, a count `new` and `from_bytes` keep
        // below 2³².
        w.put(&(scan.ranges.len() as u32).to_le_bytes());
        for range in scan.ranges {
            w.put(&range.to_bits().to_le_bytes());
        }
        let sum = fnv1a(w.out, w.at);
        w.put(&sum.to_le_bytes());
        Ok(needed)
    }

    /// Reads a scan reference written by [`Self::to_bytes`] for the same
    /// grid size, `HALF` and `RHO`, and a scan of at most `BEAMS` readings
    /// (the bytes may come from a type of another `BEAMS`: the host tool
    /// writes them for any capacity). Bytes past the stored length are
    /// ignored.
    ///
    /// # Errors
    /// [`Error::ReferenceVersion`] if the bytes are a scan reference of
    /// another format version (`found` and `expected` are scan reference
    /// versions: prepare and store it again; format 1 kept no beams);
    /// [`Error::BufferTooSmall`] if `bytes` is shorter than its stored
    /// length; [`Error::TooManyBeams`] if the stored scan has more than
    /// `BEAMS` readings (checked after the checksum, so the count is the
    /// one written); [`Error::InvalidReference`] if the magic or the
    /// checksum do not match (the bytes of a plain [`Reference`], which has
    /// no free space, are refused so: read those with
    /// [`Reference::from_bytes`]), if the free grid has bits beyond `W` or
    /// disagrees with its stored cell count, if the raster is not one
    /// [`Raster`] makes (a cell size that is not finite and positive, a gap
    /// that is neither 0 nor finite and positive, a clip byte other than 0
    /// or 1, reserved bytes not 0), and for whatever
    /// [`Reference::from_bytes`] refuses in the embedded reference (its
    /// errors are passed on). The scan's readings and geometry are taken as
    /// they are: the beams handle any value, NaN included, as
    /// [`Raster::rasterize`] does.
    ///
    /// A `const fn`, as [`Reference::from_bytes`]: a scan reference stored
    /// with the firmware can be a `static` in flash.
    pub const fn from_bytes(bytes: &[u8]) -> Result<Self, Error> {
        // The stored count, read before the envelope to know where the
        // checksum is; a count beyond the bytes makes them too short.
        let stored = le_u32(bytes, Self::HEAD_BYTES - 4) as usize;
        if let Err(e) = check_envelope(bytes, MAGIC, Self::bytes_for(stored)) {
            return Err(e);
        }
        if stored > BEAMS {
            return Err(Error::TooManyBeams {
                beams: stored,
                capacity: BEAMS,
            });
        }
        let Some((_, inner)) = bytes.split_at_checked(MAGIC.len()) else {
            return Err(Error::InvalidReference);
        };
        let reference = match Reference::from_bytes(inner) {
            Ok(r) => r,
            Err(e) => return Err(e),
        };
        let at = MAGIC.len() + Reference::<W, H, RW, HALF, RHO>::BYTES;
        let cell = f32::from_bits(le_u32(bytes, at));
        let gap = f32::from_bits(le_u32(bytes, at + 4));
        let disc = match le_u32(bytes, at + 8) {
            0 => false,
            1 => true,
            _ => return Err(Error::InvalidReference),
        };
        let Some(raster) = Raster::from_settings(cell, gap, disc) else {
            return Err(Error::InvalidReference);
        };
        let at = at + RASTER_BYTES;
        let Some(free) = read_grid::<W, H, RW>(bytes, at, le_u32(bytes, at + 4 * RW * H)) else {
            return Err(Error::InvalidReference);
        };
        let at = at + 4 * RW * H + 4;
        let mut ranges = [0.0; BEAMS];
        let mut i = 0;
        while i < stored {
            ranges[i] = le_f32(bytes, Self::HEAD_BYTES + 4 * i);
            i += 1;
        }
        Ok(Self {
            reference,
            free,
            raster,
            ranges,
            beams: stored,
            angle_min: le_f32(bytes, at),
            angle_increment: le_f32(bytes, at + 4),
            max_range: le_f32(bytes, at + 8),
            offset: SensorOffset {
                x: le_f32(bytes, at + 12),
                y: le_f32(bytes, at + 16),
                theta: le_f32(bytes, at + 20),
            },
        })
    }
}

/// The `f32` whose bits are the little-endian word at `at` (0 past the end).
const fn le_f32(bytes: &[u8], at: usize) -> f32 {
    f32::from_bits(le_u32(bytes, at))
}
