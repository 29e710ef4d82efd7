//! The library's one error type.

/// Why an operation was refused. No library function panics; each failure is
/// one of these.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error {
    /// A cell outside the `W × H` grid. In-range cells of the same call were
    /// still set; `rejected` counts the others.
    OutOfBounds {
        /// Number of cells that were not set.
        rejected: u32,
    },
    /// A byte buffer is too short for the stored reference.
    BufferTooSmall {
        /// Bytes needed.
        needed: usize,
    },
    /// Stored bytes are not a reference of this configuration (wrong magic,
    /// version, sizes, mode or checksum).
    InvalidReference,
    /// Stored reference bytes of another format version: prepare the
    /// reference from its grid and store it again.
    ReferenceVersion {
        /// Version found in the bytes.
        found: u8,
        /// Version this library reads.
        expected: u8,
    },
    /// A scale range outside `0.5 ≤ min ≤ max ≤ 2`.
    InvalidScaleRange,
    /// A scan with more readings than a stored scan reference of this type
    /// holds ([`ScanReference`](crate::ScanReference)'s `BEAMS`).
    TooManyBeams {
        /// Readings of the scan.
        beams: usize,
        /// Readings the type holds.
        capacity: usize,
    },
}

impl core::fmt::Display for Error {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Error::OutOfBounds { rejected } => {
                write!(f, "{rejected} cell(s) outside the grid were rejected")
            }
            Error::BufferTooSmall { needed } => {
                write!(f, "buffer too small: {needed} bytes needed")
            }
            Error::InvalidReference => write!(f, "bytes are not a reference of this configuration"),
            Error::ReferenceVersion { found, expected } => write!(
                f,
                "reference bytes are format {found}, this library reads format {expected}: prepare and store the reference again"
            ),
            Error::InvalidScaleRange => write!(f, "scale range must satisfy 0.5 ≤ min ≤ max ≤ 2"),
            Error::TooManyBeams { beams, capacity } => write!(
                f,
                "a scan of {beams} readings does not fit a scan reference of {capacity}"
            ),
        }
    }
}

impl core::error::Error for Error {}
