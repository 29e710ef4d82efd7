//! A reference for estimates on laser scans: the [`Reference`] of the scan's
//! occupied cells and the free space its beams crossed, stored together so
//! that a relocalization against a stored view keeps the evidence that tells
//! a large turn from a small one ([`Estimator::estimate_scans`]).
//!
//! [`Estimator::estimate_scans`]: crate::Estimator::estimate_scans

use super::{check_envelope, fnv1a, le_u32, read_grid, Reference, Writer};
use crate::error::Error;
use crate::grid::Grid;
use crate::scan::{FreeSpace, Raster};

/// Magic and format version of the stored bytes ("HHS" + version).
const MAGIC: [u8; 4] = [b'H', b'H', b'S', b'0' + SCAN_REFERENCE_FORMAT];
/// The scan reference format this library writes and reads.
pub const SCAN_REFERENCE_FORMAT: u8 = 1;
/// Bytes of the stored raster: cell, gap, clip flag and 3 reserved.
const RASTER_BYTES: usize = 12;

/// A scan's [`Reference`] together with its free space (the cells its beams
/// crossed, [`Raster::free_space`]) and the [`Raster`] both were drawn
/// with. What a firmware stores (in flash, see [`Self::from_bytes`]) to
/// relocalize on scans against a known view with the free-space test of the
/// verification; it rasterizes each new scan with [`Self::raster`], so the
/// two views share their scale.
///
/// Size: [`Reference`] plus one grid (`4·RW·H` bytes: 2 KiB at 128²) and
/// the raster's settings.
#[derive(Clone, Debug, PartialEq)]
pub struct ScanReference<
    const W: usize,
    const H: usize,
    const RW: usize,
    const HALF: usize,
    const RHO: usize,
> {
    reference: Reference<W, H, RW, HALF, RHO>,
    free: Grid<W, H, RW>,
    raster: Raster,
}

impl<const W: usize, const H: usize, const RW: usize, const HALF: usize, const RHO: usize>
    ScanReference<W, H, RW, HALF, RHO>
{
    /// Bytes of [`Self::to_bytes`]: magic 4, the reference's
    /// [`Reference::BYTES`], the raster 12, the free grid `4·RW·H`, its cell
    /// count 4, checksum 4. 128², `N_THETA` = 360: 5 896 bytes.
    pub const BYTES: usize =
        4 + Reference::<W, H, RW, HALF, RHO>::BYTES + RASTER_BYTES + 4 * RW * H + 8;

    /// The reference of a scan's occupied cells and the free space of the
    /// same scan, both drawn with `raster`.
    pub const fn new(
        reference: Reference<W, H, RW, HALF, RHO>,
        free: Grid<W, H, RW>,
        raster: Raster,
    ) -> Self {
        Self {
            reference,
            free,
            raster,
        }
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

    /// The free space of an estimate against this reference: its own and
    /// `current`'s, the free cells of the new scan on the same raster.
    pub const fn free_space<'a>(&'a self, current: &'a Grid<W, H, RW>) -> FreeSpace<'a, W, H, RW> {
        FreeSpace {
            reference: &self.free,
            current,
        }
    }

    /// Writes the scan reference as [`Self::BYTES`] bytes (little-endian):
    /// the magic `HHS1`, the reference as [`Reference::to_bytes`] writes it
    /// (with its own checksum), the raster (metres per cell and the
    /// [`connect`](Raster::connect) gap as `f32` bits, 0 when off; 1 when
    /// [`clip_to_disc`](Raster::clip_to_disc), then 3 zero bytes), the free
    /// grid's row words, its cell count and an FNV-1a checksum of everything
    /// before. Returns the length.
    ///
    /// # Errors
    /// [`Error::BufferTooSmall`] if `out` is shorter than [`Self::BYTES`].
    pub fn to_bytes(&self, out: &mut [u8]) -> Result<usize, Error> {
        let needed = Self::BYTES;
        let out = out
            .get_mut(..needed)
            .ok_or(Error::BufferTooSmall { needed })?;
        let (head, rest) = out.split_at_mut(MAGIC.len());
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
        let sum = fnv1a(w.out, w.at);
        w.put(&sum.to_le_bytes());
        Ok(needed)
    }

    /// Reads a scan reference written by [`Self::to_bytes`] for the same
    /// grid size, `HALF` and `RHO`.
    ///
    /// # Errors
    /// [`Error::ReferenceVersion`] if the bytes are a scan reference of
    /// another format version (`found` and `expected` are scan reference
    /// versions: prepare and store it again); [`Error::BufferTooSmall`] if
    /// `bytes` is short; [`Error::InvalidReference`] if the magic or the
    /// checksum do not match (the bytes of a plain [`Reference`], which has
    /// no free space, are refused so: read those with
    /// [`Reference::from_bytes`]), if the free grid has bits beyond `W` or
    /// disagrees with its stored cell count, if the raster is not one
    /// [`Raster`] makes (a cell size that is not finite and positive, a gap
    /// that is neither 0 nor finite and positive, a clip byte other than 0
    /// or 1, reserved bytes not 0), and for whatever
    /// [`Reference::from_bytes`] refuses in the embedded reference (its
    /// errors are passed on).
    ///
    /// A `const fn`, as [`Reference::from_bytes`]: a scan reference stored
    /// with the firmware can be a `static` in flash.
    pub const fn from_bytes(bytes: &[u8]) -> Result<Self, Error> {
        if let Err(e) = check_envelope(bytes, MAGIC, Self::BYTES) {
            return Err(e);
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
        Ok(Self {
            reference,
            free,
            raster,
        })
    }
}
