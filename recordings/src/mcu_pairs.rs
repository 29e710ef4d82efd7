//! The scan-pair file of the real-scan firmware (`examples/real_scans.rs`),
//! and its result lines. Shared, source for source, by the firmware and the
//! host (the recordings crate's module `mcu_pairs`, which `hough-heading mcu`
//! uses), so that both
//! ends decode the ranges and print the estimates with the same code.
//!
//! # Pair file, version 1 (`hough-heading mcu export`)
//!
//! Little-endian throughout, no padding.
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 4 | magic `HHSP` |
//! | 4 | 2 | version, `1` ([`VERSION`]) |
//! | 6 | 2 | header size in bytes, `16` ([`HEADER_LEN`]) |
//! | 8 | 4 | number of pairs |
//! | 12 | 4 | most beams of any scan in the file |
//!
//! Then each pair: its index (`u32`: the pair's position in the export, the
//! `pair=` of the result line), then scan 1 and scan 2, each
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 2 | beams `n` |
//! | 2 | 2 | reserved, `0` |
//! | 4 | 4 | `angle_min`, radians (`f32` bits) |
//! | 8 | 4 | `angle_increment`, radians (`f32` bits) |
//! | 12 | 4 | `max_range`, metres (`f32` bits) |
//! | 16 | 12 | sensor offset `x`, `y` (metres), `θ` (radians), `f32` bits |
//! | 28 | 2·n | ranges, `u16` millimetres |
//!
//! A range code is millimetres (`0` … [`MAX_MM`]), or [`NO_READING`] (`null`
//! or NaN in the pair file: decoded as NaN) or [`NO_RETURN`] (at or beyond
//! `max_range`: decoded as `max_range`). [`range`] decodes a code: `mm / 1000`
//! in `f32`, correctly rounded on every target. The geometry is kept
//! bit-exact; only the ranges are quantized to the millimetre, and both the
//! firmware and the host's comparison estimate from the decoded ranges.
//!
//! # Result line
//!
//! [`write_result`] prints one line per pair: `key=value` words of every
//! field of the rasterization and of the [`Estimate`], fixed-point values as
//! their raw bits (decimal), so two lines are equal exactly when the results
//! are bit-identical.
#![allow(dead_code)] // each side uses its part: the host encodes, the firmware decodes

use core::fmt::{self, Write};

use hough_heading::{BeamFit, BeamFitError, Candidate, Estimate, HalfTurn, ScanStats, Status};

/// First bytes of a pair file.
pub const MAGIC: [u8; 4] = *b"HHSP";
/// Format version written and accepted.
pub const VERSION: u16 = 1;
/// Size of the file header.
pub const HEADER_LEN: usize = 16;
/// Size of a scan's header before its ranges.
pub const SCAN_HEADER_LEN: usize = 28;
/// Range code of a missing reading (`null`, NaN, infinite).
pub const NO_READING: u16 = 0xFFFF;
/// Range code of a reading at or beyond `max_range`.
pub const NO_RETURN: u16 = 0xFFFE;
/// Largest range in millimetres (longer valid ranges are clamped to it).
pub const MAX_MM: u16 = 0xFFFD;
/// Grid side of the comparison (128², which fits the Cortex-M0's RAM).
pub const SIDE: usize = 128;
/// θ steps over the full circle.
pub const N_THETA: usize = 360;
/// Segments between neighbouring beams at most this far apart, metres (the
/// CLI's `--connect` default; a host test checks they agree).
pub const CONNECT_M: f32 = 0.3;

/// The file header: number of pairs and most beams per scan; `None` unless
/// the magic, version and header size are right.
pub fn header(bytes: &[u8; HEADER_LEN]) -> Option<(u32, u32)> {
    let version = u16::from_le_bytes([bytes[4], bytes[5]]);
    let length = u16::from_le_bytes([bytes[6], bytes[7]]);
    (bytes[..4] == MAGIC && version == VERSION && usize::from(length) == HEADER_LEN)
        .then(|| (word(bytes, 8), word(bytes, 12)))
}

/// A scan's geometry as stored before its ranges.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScanHeader {
    /// Number of beams.
    pub beams: u16,
    /// Direction of beam 0, radians.
    pub angle_min: f32,
    /// Angle between beams, radians.
    pub angle_increment: f32,
    /// "No return" at or beyond this, metres.
    pub max_range: f32,
    /// Sensor pose `[x, y, θ]` in the robot frame.
    pub offset: [f32; 3],
}

impl ScanHeader {
    /// Decodes a scan header.
    pub fn read(bytes: &[u8; SCAN_HEADER_LEN]) -> Self {
        let float = |at| f32::from_bits(word(bytes, at));
        Self {
            beams: u16::from_le_bytes([bytes[0], bytes[1]]),
            angle_min: float(4),
            angle_increment: float(8),
            max_range: float(12),
            offset: [float(16), float(20), float(24)],
        }
    }

    /// Encodes a scan header.
    pub fn bytes(&self) -> [u8; SCAN_HEADER_LEN] {
        let mut out = [0; SCAN_HEADER_LEN];
        out[..2].copy_from_slice(&self.beams.to_le_bytes());
        let floats = [
            self.angle_min,
            self.angle_increment,
            self.max_range,
            self.offset[0],
            self.offset[1],
            self.offset[2],
        ];
        for (i, v) in floats.iter().enumerate() {
            out[4 + 4 * i..8 + 4 * i].copy_from_slice(&v.to_bits().to_le_bytes());
        }
        out
    }
}

/// The range in metres of a range code (see the module docs).
pub fn range(code: u16, max_range: f32) -> f32 {
    match code {
        NO_READING => f32::NAN,
        NO_RETURN => max_range,
        mm => f32::from(mm) / 1000.0,
    }
}

/// The `u32` at `at` in `bytes` (little-endian; 0 past the end).
fn word(bytes: &[u8], at: usize) -> u32 {
    match bytes.get(at..at + 4) {
        Some(&[a, b, c, d]) => u32::from_le_bytes([a, b, c, d]),
        _ => 0,
    }
}

/// The short name of a status.
pub fn status_name(status: Status) -> &'static str {
    match status {
        Status::Confident => "confident",
        Status::AmbiguousDirection => "ambiguous_direction",
        Status::AmbiguousAxis => "ambiguous_axis",
        Status::LowOverlap => "low_overlap",
        Status::NoStructure => "no_structure",
        Status::SearchCut => "search_cut",
    }
}

/// Why the refinement on the beams kept the grid's pose, as a word.
pub fn beam_fit_kept_name(error: BeamFitError) -> &'static str {
    match error {
        BeamFitError::Unsupported => "unsupported",
        BeamFitError::TooFewPairs => "too_few_pairs",
        BeamFitError::Singular => "singular",
        BeamFitError::MovedTooFar => "moved_too_far",
    }
}

/// Writes the result line of pair `index`: the cell size, the grids'
/// occupied cells and the rasterization counts of both scans, then every
/// field of `estimate` (raw bits of the fixed-point values), then the
/// refinement on the beams (`beam_fit=alpha/x/y/pairs/residual/iterations`,
/// `beam_fit=kept:REASON`, or `beam_fit=-` when it did not run).
pub fn write_result(
    out: &mut impl Write,
    index: u32,
    cell: f32,
    occupied: [u32; 2],
    stats: &[ScanStats; 2],
    estimate: &Estimate,
    fit: Option<&Result<BeamFit, BeamFitError>>,
) -> fmt::Result {
    write!(
        out,
        "pair={index} cell={:#010x} occupied={},{}",
        cell.to_bits(),
        occupied[0],
        occupied[1]
    )?;
    for (i, s) in stats.iter().enumerate() {
        write!(
            out,
            " scan{}={}/{}/{}/{}/{}/{}/{}",
            i + 1,
            s.beams,
            s.kept,
            s.no_return,
            s.not_finite,
            s.non_positive,
            s.outside,
            s.segment_points
        )?;
    }
    let e = estimate;
    let half = match e.half_turn.chosen {
        HalfTurn::Direct => "direct",
        HalfTurn::Flipped => "flipped",
    };
    write!(
        out,
        " alpha={} status={} confidence={} correlation={} rival={} half_turn={half}/{}/{} overlap={}",
        e.alpha.0,
        status_name(e.status),
        e.confidence.to_bits(),
        e.correlation.to_bits(),
        e.rival.to_bits(),
        e.half_turn.direct.to_bits(),
        e.half_turn.flipped.to_bits(),
        e.overlap.to_bits()
    )?;
    out.write_str(" candidates=")?;
    if e.candidates.is_empty() {
        out.write_str("-")?;
    }
    for (i, c) in e.candidates.iter().enumerate() {
        if i > 0 {
            out.write_char(';')?;
        }
        write_candidate(out, c)?;
    }
    out.write_str(" runner_up=")?;
    match &e.runner_up {
        Some(c) => write_candidate(out, c)?,
        None => out.write_str("-")?,
    }
    out.write_str(" translation=")?;
    match &e.translation {
        Some(t) => {
            write!(
                out,
                "{}/{}/{}/{}/{}/",
                t.x.to_bits(),
                t.y.to_bits(),
                t.scale.to_bits(),
                t.residual.to_bits(),
                t.columns
            )?;
            match t.unobservable {
                Some((x, y)) => write!(out, "{},{}", x.to_bits(), y.to_bits()),
                None => out.write_str("-"),
            }
        }
        None => out.write_str("-"),
    }?;
    out.write_str(" beam_fit=")?;
    match fit {
        Some(Ok(f)) => write!(
            out,
            "{}/{}/{}/{}/{}/{}",
            f.alpha.0,
            f.translation.x.to_bits(),
            f.translation.y.to_bits(),
            f.pairs,
            f.residual.to_bits(),
            f.iterations
        ),
        Some(Err(e)) => write!(out, "kept:{}", beam_fit_kept_name(*e)),
        None => out.write_str("-"),
    }
}

/// One candidate: `alpha:score:alignment:x,y:support:free_space`, raw bits,
/// `-` for a missing value.
fn write_candidate(out: &mut impl Write, c: &Candidate) -> fmt::Result {
    let bits = |out: &mut dyn Write, v: Option<hough_heading::Score>| match v {
        Some(v) => write!(out, "{}", v.to_bits()),
        None => out.write_str("-"),
    };
    write!(out, "{}:{}:", c.alpha.0, c.score.to_bits())?;
    bits(out, c.alignment)?;
    out.write_char(':')?;
    match c.translation {
        Some((x, y)) => write!(out, "{},{}", x.to_bits(), y.to_bits())?,
        None => out.write_str("-")?,
    }
    out.write_char(':')?;
    bits(out, c.support)?;
    out.write_char(':')?;
    bits(out, c.free_space)
}
