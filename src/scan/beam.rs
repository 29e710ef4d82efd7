//! Where each beam of a scan ends, in fixed point: the per-scan parameters
//! converted once ([`ScanBeams::new`]), then integer arithmetic per beam
//! (no soft float on the Cortex-M0, no division).
//!
//! - **Angle**: `angle_min + offset.theta` and `angle_increment` become
//!   fractions of a turn in 64 bits (2⁶⁴ = one turn, reduced modulo one turn
//!   in `f64` once per scan), so beam `i`'s direction is the exact wrapping
//!   sum `start + i·step`; its upper 32 bits are a binary angle.
//! - **Validity**: by the reading's bit pattern (positive finite `f32`s are
//!   ordered like their bits), with the categories of [`ScanStats`].
//! - **Range**: `r / cell` in Q16 cells from the reading's mantissa and
//!   exponent times `1/cell` rounded to 20 bits (two 32-bit products).
//! - **Direction**: `sin_cos` (module `sine`) of the binary angle (Q16,
//!   1024-segment table, linear interpolation).
//! - **End point**: `offset/cell + r·(cos, sin)`, Q16 cells, in the grid's
//!   centred, y-up coordinates.
//!
//! # Error bound
//!
//! Against the exact end point `(offset + r·(cos φ, sin φ)) / cell` with
//! `φ = angle_min + i·angle_increment + offset.theta` evaluated in `f64`
//! (units: cells, per coordinate): below `r_c·2.3·10⁻⁵ + 2⁻¹³` where
//! `r_c = r / cell` (sine table 2.0·10⁻⁵, `1/cell` 2⁻²⁰ relative, the
//! angle's reduction ~10⁻¹⁵ turn per radian of `|angle_min + θ|`, the
//! truncations of the range (2⁻¹⁵) and of the products (2⁻¹⁵) and the
//! offset's rounding (2⁻¹⁷): below 2⁻¹³ in all).
//! On the tool's 256² grids (`r_c` ≤ 181 inside the window) that is
//! 0.004 cells; at the largest grid (2048², `r_c` ≤ 1449) 0.034 cells. In
//! metres, multiply by `cell`. Beams of 2¹⁴ cells or more are reported
//! [`BeamEnd::Far`] (at least 2¹³ cells away: outside any grid, which is at
//! most 2048 cells wide), without coordinates.
//!
//! Cost: the common case (a normal reading between the scan's smallest and
//! largest fast range, finite geometry, sensor near the robot) takes one
//! compare to classify, two products for the range, two table
//! interpolations and four products for the end point; every other reading
//! goes through the general path, out of line.

use super::sine::{sin_cos, SINE_FRACTION_BITS};
use super::{Raster, Scan, ScanStats};

/// [`BeamEnd::Far`] beams end at least this many cells from the robot:
/// outside every grid (W, H ≤ 2048).
pub const BEAM_FAR_CELLS: i32 = 1 << 13;
/// [`BeamEnd::Near`] coordinates are below this many cells in magnitude
/// (`2¹⁴ + 4096`: a range below 2¹⁴ cells from an offset below 4096).
pub const BEAM_NEAR_CELLS: i32 = (1 << 14) + 4096;

/// Two returns are neighbouring beams when at most this many beams without
/// a return lie between them: a wall's segment, its free space and the
/// beam check's four beams around a bearing reach over such a hole. A lidar
/// revolution binned finer than the sensor's own spacing (a 360-point turn
/// in 720 bins, an LD06's ~450 points in 720) leaves every other bin
/// empty; an empty bin is unmeasured, not a depth jump, and before this
/// the beam check saw nothing in such a scan. Every kind of no-return
/// (at or beyond `max_range`, 0, NaN, ±inf) counts alike. One, not more:
/// on the shared real pairs (256², all 4 730) reaching over three took
/// 0.08 points off "within 2°" (0.06 at overlap ≥ 0.5) and moved the demo's
/// fr079 #630 from 1.2° to 2.6° off; one leaves both as they were
/// (`docs/stream.md`).
///
/// [`Raster::connect`]: super::Raster::connect
pub const BEAM_MAX_MISSING: u32 = 1;

/// The beams without a return since the last one, after `end` (not a
/// near return): one more, or more than [`BEAM_MAX_MISSING`] at once for a
/// return beyond every grid (a depth jump, not a hole). Shared by the
/// raster's segments and free space, so that both see the same
/// neighbours.
pub(crate) fn missing_after(missing: u32, end: BeamEnd) -> u32 {
    match end {
        BeamEnd::Far => u32::MAX,
        _ => missing.saturating_add(1),
    }
}

/// Q16: one cell is `1 << 16`.
const ONE: i32 = 1 << 16;
/// Ranges of at least 2¹⁴ cells end outside every grid as long as the offset
/// is within [`NEAR_OFFSET_CELLS`].
const NEAR_RANGE_Q16: u32 = 1 << 30;
/// Sensor offsets (per axis, cells) below which the per-beam arithmetic is
/// 32-bit; beyond, the beams are computed in `f64` (a sensor thousands of
/// cells from the robot: only in hostile inputs).
const NEAR_OFFSET_CELLS: f64 = 4096.0;

/// Where one beam ends, or why it was dropped (the [`ScanStats`] categories).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BeamEnd {
    /// A valid return ending at `(x, y)`: centred, y-up cell coordinates
    /// (DESIGN.md §2) in Q16 (cells × 2¹⁶), both below [`BEAM_NEAR_CELLS`]
    /// in magnitude.
    Near {
        /// Cells to the right of the grid centre, Q16.
        x: i32,
        /// Cells above the grid centre, Q16.
        y: i32,
    },
    /// A valid return ending at least [`BEAM_FAR_CELLS`] from the robot
    /// (Euclidean distance): outside every grid.
    Far,
    /// A reading at or beyond `max_range` ([`ScanStats::no_return`]).
    NoReturn,
    /// A NaN or infinite reading, or a valid one in a scan whose geometry
    /// (`angle_min`, `angle_increment`, `offset`) is not finite or whose
    /// `max_range` is NaN ([`ScanStats::not_finite`]).
    NotFinite,
    /// A reading that is zero or negative ([`ScanStats::non_positive`]).
    NonPositive,
}

/// The fixed-point form of one scan's geometry for one [`Raster`]: what
/// [`Raster::rasterize`] computes once per scan. See the module doc for the
/// error bound.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScanBeams {
    /// Direction of beam 0, 2⁶⁴ = one turn.
    start: u64,
    /// Angle between consecutive beams, 2⁶⁴ = one turn (wrapping).
    step: u64,
    /// The geometry is finite and `max_range` is not NaN.
    finite: bool,
    /// Sort key of `max_range` ([`order_key`]).
    max_key: u32,
    /// `1/cell ≈ inv_mantissa · 2^inv_exponent`, `inv_mantissa ∈ [2¹⁹, 2²⁰)`.
    inv_mantissa: u32,
    inv_exponent: i32,
    origin: Origin,
    /// Readings whose bits are in `fast_low..fast_low + fast_span` take the
    /// fast path: normal, below `max_range`, with `shift ∈ [14, 31]`
    /// (empty unless the geometry is finite and the origin near).
    fast_low: u32,
    fast_span: u32,
    /// `134 − inv_exponent`: the range's right shift is this minus the
    /// reading's biased exponent.
    shift_base: i32,
    /// The near origin, Q16 (0 when wide: the fast path is then empty).
    origin_x: i32,
    origin_y: i32,
}

/// The sensor's position in cells.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Origin {
    /// Within ±4096 cells per axis, Q16.
    Near { x: i32, y: i32 },
    /// Farther (hostile inputs): the beams are computed in `f64`.
    Wide { x: f64, y: f64, inv_cell: f64 },
}

impl ScanBeams {
    /// Converts `scan`'s geometry for `raster`'s cells. Cost: a few `f64`
    /// operations (software on the Cortex-M).
    pub fn new(scan: &Scan<'_>, raster: &Raster) -> Self {
        let o = scan.offset;
        let finite = scan.angle_min.is_finite()
            && scan.angle_increment.is_finite()
            && o.theta.is_finite()
            && o.x.is_finite()
            && o.y.is_finite()
            && !scan.max_range.is_nan();
        let inv_cell = raster.inv_cell;
        let (ox, oy) = (f64::from(o.x) * inv_cell, f64::from(o.y) * inv_cell);
        let origin = if ox.abs() < NEAR_OFFSET_CELLS && oy.abs() < NEAR_OFFSET_CELLS {
            Origin::Near {
                x: round_q16(ox),
                y: round_q16(oy),
            }
        } else {
            Origin::Wide {
                x: ox,
                y: oy,
                inv_cell,
            }
        };
        let (inv_mantissa, inv_exponent) = mantissa_20(inv_cell);
        let shift_base = 134 - inv_exponent;
        let (origin_x, origin_y, near_origin) = match origin {
            Origin::Near { x, y } => (x, y, true),
            Origin::Wide { .. } => (0, 0, false),
        };
        // Fast readings: biased exponent e ∈ [1, 254] with the shift
        // `shift_base − e` ∈ [14, 31] (the range is then below 2¹⁴ cells and
        // both partial products' shifts are below 32), and below `max_range`
        // (bits of a positive `max_range`, +∞ included).
        let (mut fast_low, mut fast_span) = (0, 0);
        if finite && near_origin && scan.max_range > 0.0 {
            let low_e = (shift_base - 31).max(1);
            let high_e = (shift_base - 14).min(254);
            if low_e <= high_e {
                fast_low = (low_e as u32) << 23;
                let high = (((high_e + 1) as u32) << 23).min(scan.max_range.to_bits());
                fast_span = high.saturating_sub(fast_low);
            }
        }
        Self {
            start: turns(f64::from(scan.angle_min) + f64::from(o.theta)),
            step: turns(f64::from(scan.angle_increment)),
            finite,
            max_key: order_key(scan.max_range.to_bits()),
            inv_mantissa,
            inv_exponent,
            origin,
            fast_low,
            fast_span,
            shift_base,
            origin_x,
            origin_y,
        }
    }

    /// Where beam `i` ends if its reading is `range`.
    pub fn end(&self, i: usize, range: f32) -> BeamEnd {
        let angle = self.start.wrapping_add(self.step.wrapping_mul(i as u64));
        self.end_at(binary_angle(angle), range)
    }

    /// The sensor's position (Q16 cells, centred, y up) when it is within
    /// ±4096 cells of the robot and the geometry is finite; `None` otherwise.
    pub(crate) const fn near_origin(&self) -> Option<(i32, i32)> {
        match self.origin {
            Origin::Near { x, y } if self.finite => Some((x, y)),
            _ => None,
        }
    }

    /// Direction of beam 0 and the step between beams, 2⁶⁴ = one turn.
    pub(crate) const fn angles(&self) -> (u64, u64) {
        (self.start, self.step)
    }

    /// Where a beam in direction `angle` (2³² = one turn) with reading
    /// `range` ends.
    #[inline(always)]
    pub(crate) fn end_at(&self, angle: u32, range: f32) -> BeamEnd {
        let bits = range.to_bits();
        if bits.wrapping_sub(self.fast_low) < self.fast_span {
            // Normal, positive, below `max_range`, shift in [14, 31]: the
            // range is below 2¹⁴ cells (m·K < 2⁴⁴).
            let shift = (self.shift_base - (bits >> 23) as i32) as u32;
            let m = (bits & 0x007f_ffff) | 0x0080_0000;
            let k = self.inv_mantissa;
            let r =
                ((m >> 12) * k).wrapping_shr(shift - 12) + ((m & 0xfff) * k).wrapping_shr(shift);
            let (s, c) = sin_cos(angle);
            return BeamEnd::Near {
                x: self.origin_x + times(r, c),
                y: self.origin_y + times(r, s),
            };
        }
        self.general_end(angle, range)
    }

    /// [`end_at`](Self::end_at) for every reading, out of line: the
    /// categories, subnormals, long and tiny ranges, far sensors.
    #[inline(never)]
    fn general_end(&self, angle: u32, range: f32) -> BeamEnd {
        let bits = range.to_bits();
        let magnitude = bits & 0x7fff_ffff;
        if magnitude >= 0x7f80_0000 {
            return BeamEnd::NotFinite;
        }
        // `r ≥ max_range` comes first, as in `ScanStats`: a negative reading
        // at or above a negative `max_range` is "no return".
        if order_key(bits) >= self.max_key && self.max_key != NAN_KEY {
            return BeamEnd::NoReturn;
        }
        if bits >> 31 != 0 || magnitude == 0 {
            return BeamEnd::NonPositive;
        }
        if !self.finite {
            return BeamEnd::NotFinite;
        }
        match self.origin {
            Origin::Near { x: ox, y: oy } => {
                let r = self.range_q16(bits);
                if r >= NEAR_RANGE_Q16 {
                    // |end| ≥ 2¹⁴ − 4096·√2 cells > 2¹³.
                    return BeamEnd::Far;
                }
                let (s, c) = sin_cos(angle);
                // |x| < 4096 + 2¹⁴ cells: fits Q16 in an i32.
                BeamEnd::Near {
                    x: ox + times(r, c),
                    y: oy + times(r, s),
                }
            }
            Origin::Wide { x, y, inv_cell } => wide_end(angle, range, x, y, inv_cell),
        }
    }

    /// `range / cell` in Q16 (`bits` positive and finite), saturated to
    /// [`NEAR_RANGE_Q16`] or above: error below `r_c·2⁻²⁰ + 2⁻¹⁵` cells.
    fn range_q16(&self, bits: u32) -> u32 {
        let (m, exponent) = match (bits >> 23) as i32 {
            0 => {
                // A subnormal (non-zero): normalised so that m ≥ 2²³.
                let m = bits & 0x007f_ffff;
                let z = m.leading_zeros().saturating_sub(8);
                (m << z, 1 - z as i32)
            }
            e => ((bits & 0x007f_ffff) | 0x0080_0000, e),
        };
        // r = m·2^(e − 150), r/cell·2¹⁶ = m·K·2^(e − 150 + k + 16): shift
        // right by t. 2⁴² ≤ m·K < 2⁴⁴, so with t ≤ 12 the result is ≥ 2³⁰.
        let t = 134 - exponent - self.inv_exponent;
        if t <= 12 {
            return NEAR_RANGE_Q16;
        }
        let t = t as u32;
        let k = self.inv_mantissa;
        // m = high·2¹² + low, both < 2¹², K < 2²⁰: each product < 2³².
        let high = (m >> 12) * k;
        let low = (m & 0xfff) * k;
        let high = high.checked_shr(t - 12).unwrap_or(0);
        let low = low.checked_shr(t).unwrap_or(0);
        // high < 2³¹ (t ≥ 13), low < 2²⁰.
        high + low
    }
}

/// `r·v` in Q16 for `r` Q16 below 2³⁰ and `v` Q16 within ±1, signed
/// throughout (no branch): the integer cells of `r` times `v` exactly, its
/// fraction to 15 bits, floored: error below 2⁻¹⁵ cells. Two 32-bit
/// products.
#[inline(always)]
fn times(r: u32, v: i32) -> i32 {
    // r >> 16 < 2¹⁴ and |v| ≤ 2¹⁶: |·| ≤ 2³⁰; the fraction's 15 bits
    // times |v| ≤ 2¹⁶: below 2³¹.
    let whole = (r >> 16) as i32 * v;
    let fraction = ((r >> 1) & 0x7fff) as i32 * v;
    whole + (fraction >> (SINE_FRACTION_BITS - 1))
}

/// The end point in `f64` for a sensor thousands of cells from the robot.
#[cold]
#[inline(never)]
fn wide_end(angle: u32, range: f32, ox: f64, oy: f64, inv_cell: f64) -> BeamEnd {
    let (s, c) = sin_cos(angle);
    let scale = f64::from(range) * inv_cell / f64::from(ONE);
    let (x, y) = (ox + scale * f64::from(c), oy + scale * f64::from(s));
    let limit = f64::from(BEAM_NEAR_CELLS - 1);
    if x.abs() < limit && y.abs() < limit {
        BeamEnd::Near {
            x: round_q16(x),
            y: round_q16(y),
        }
    } else {
        BeamEnd::Far
    }
}

/// The key of NaN `max_range`s ([`order_key`] of any NaN is above it).
const NAN_KEY: u32 = u32::MAX;

/// A key whose unsigned order is the `f32` order of non-NaN values
/// (`−0.0` and `+0.0` equal); every NaN maps to [`NAN_KEY`].
#[inline(always)]
fn order_key(bits: u32) -> u32 {
    let magnitude = bits & 0x7fff_ffff;
    if magnitude > 0x7f80_0000 {
        NAN_KEY
    } else if bits >> 31 != 0 {
        // Negative (or −0.0, which becomes +0.0's key): below the positives.
        0x8000_0000 - magnitude
    } else {
        0x8000_0000 + magnitude
    }
}

/// `x` radians as the fraction of a turn in 64 bits, wrapping
/// (2⁶⁴ = one turn). Exact to ~10⁻¹⁶ turn per turn of `|x|`; 0 when
/// `|x| ≥ 2⁶²` turns (no fraction left in an `f64`) or `x` is not finite.
fn turns(x: f64) -> u64 {
    let t = x * (1.0 / crate::math::TAU);
    // NaN fails the compare too.
    let in_range = t.abs() < 4.611_686_018_427_388e18;
    if !in_range {
        return 0;
    }
    let whole = t as i64;
    let fraction = t - whole as f64; // exact, in (−1, 1)
                                     // `as` saturates; |fraction·2⁶³| < 2⁶³.
    ((fraction * 9.223_372_036_854_776e18) as i64 as u64) << 1
}

/// Upper 32 bits of a 2⁶⁴-per-turn angle: the binary angle.
#[inline(always)]
pub(crate) const fn binary_angle(turns: u64) -> u32 {
    (turns >> 32) as u32
}

/// `v` (positive, finite) as `K·2^k` with `K ∈ [2¹⁹, 2²⁰)` rounded to
/// nearest: relative error at most 2⁻²⁰.
fn mantissa_20(v: f64) -> (u32, i32) {
    let bits = v.to_bits();
    let exponent = ((bits >> 52) & 0x7ff) as i32;
    // `v = 1/cell` of a positive finite f32 cell: a normal f64.
    let mantissa = (bits & ((1u64 << 52) - 1)) | (1u64 << 52);
    let rounded = (mantissa + (1u64 << 32)) >> 33;
    let (k, extra) = if rounded >> 20 != 0 {
        (rounded >> 1, 1)
    } else {
        (rounded, 0)
    };
    // v = mantissa·2^(exponent − 1075) = K·2^(exponent − 1075 + 33).
    (k as u32, exponent - 1075 + 33 + extra)
}

/// `v` in Q16, rounded (`|v| < 2¹⁵ − 1`).
fn round_q16(v: f64) -> i32 {
    let scaled = v * f64::from(ONE);
    let rounded = if scaled >= 0.0 {
        scaled + 0.5
    } else {
        scaled - 0.5
    };
    rounded as i32
}

/// Counts `end` in `stats` (not `kept`/`outside`, which the caller decides).
#[inline(always)]
pub(crate) fn count_dropped(stats: &mut ScanStats, end: BeamEnd) {
    let counter = match end {
        BeamEnd::Near { .. } => return,
        BeamEnd::Far => &mut stats.outside,
        BeamEnd::NoReturn => &mut stats.no_return,
        BeamEnd::NotFinite => &mut stats.not_finite,
        BeamEnd::NonPositive => &mut stats.non_positive,
    };
    *counter = counter.saturating_add(1);
}
