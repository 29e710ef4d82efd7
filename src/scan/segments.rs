//! The reference scan's segments: for a point, the beams around its
//! bearing from the reference sensor and the wall segment nearest it
//! (what the refinement on the beams fits to and the check on the beams
//! scores against).
//!
//! Two returns are neighbours when at most
//! [`BEAM_MAX_MISSING`](super::BEAM_MAX_MISSING) beams without a return lie
//! between them ([`Segments::ends_around`]); a segment between neighbours
//! longer than [`BEAM_SEGMENT_MAX_M`] is a depth jump, not a wall. Beam
//! indices wrap when the scan closes the circle, and a clockwise scan
//! (negative increment) gives the same beams around a bearing as its
//! counter-clockwise form. Integer throughout: Q16 cells, a 32-bit
//! arctangent ([`atan2_turns`]), no division per point but the chosen
//! segment's normal.

use super::beam::{BeamEnd, ScanBeams, BEAM_MAX_MISSING};
use super::refine::BEAM_SEGMENT_MAX_M;
use super::{Raster, Scan};

/// A point or a vector, Q16 cells, centred and y up.
pub(super) type Point = (i64, i64);

/// The reference scan's beams and where its sensor is.
pub(super) struct Segments<'a> {
    beams: ScanBeams,
    ranges: &'a [f32],
    pub(super) origin: (i32, i32),
    /// Beam 0's direction and the magnitude of the step, 2⁶⁴ = one turn.
    start: u64,
    step: u64,
    /// The beams turn counter-clockwise (`angle_increment > 0`).
    counter_clockwise: bool,
    /// The beams cover the full circle: indices wrap.
    full_circle: bool,
    /// `2⁴⁸ / (step / 2³²)` when the step is at least 2⁻¹⁶ turn (beam index
    /// = turns·2³² times this, `>> 48`: within one beam).
    inverse_step: Option<u64>,
    /// Squared longest segment, Q16 cells squared (`u64`).
    max_len_sq: u64,
    /// Recent reference ends by beam index (direct-mapped).
    cache: [(i64, Option<(i32, i32)>); CACHED_ENDS],
}

/// Reference ends [`Segments`] keeps (a power of two).
const CACHED_ENDS: usize = 8;

impl<'a> Segments<'a> {
    /// The segments of `scan`'s beams on `raster`'s cells; `None` when the
    /// scan's geometry is not finite or its sensor is far from the robot.
    pub(super) fn new(raster: &Raster, scan: &Scan<'a>) -> Option<Self> {
        let beams = ScanBeams::new(scan, raster);
        let origin = beams.near_origin()?;
        let (start, step) = beams.angles();
        let max_len = raster.metres_q16(BEAM_SEGMENT_MAX_M).max(1) as u64;
        let counter_clockwise = (step as i64) >= 0;
        let step = if counter_clockwise {
            step
        } else {
            step.wrapping_neg()
        };
        // n·step within one step of a turn: the beams close the circle.
        let span = u128::from(step) * scan.ranges.len() as u128;
        let full_circle = step > 0 && span + u128::from(step) / 2 >= 1 << 64;
        Some(Self {
            beams,
            ranges: scan.ranges,
            origin,
            start,
            step,
            counter_clockwise,
            full_circle,
            inverse_step: (step >> 32 >= 1 << 16).then(|| (1u64 << 48) / (step >> 32).max(1)),
            max_len_sq: max_len.saturating_mul(max_len),
            cache: [(i64::MIN, None); CACHED_ENDS],
        })
    }
}

impl Segments<'_> {
    /// The end of reference beam `k`, when it is a valid near return; from
    /// the cache when it holds `k` (consecutive end points of the current
    /// scan read overlapping reference beams).
    pub(super) fn end(&mut self, k: i64) -> Option<(i32, i32)> {
        let n = self.ranges.len() as i64;
        let k = if self.full_circle && !(0..n).contains(&k) {
            k.rem_euclid(n.max(1))
        } else {
            k
        };
        let slot = (k as usize) % CACHED_ENDS;
        if let Some(&(_, end)) = self.cache.get(slot).filter(|c| c.0 == k) {
            return end;
        }
        let range = *self.ranges.get(usize::try_from(k).ok()?)?;
        let end = match self.beams.end(k as usize, range) {
            BeamEnd::Near { x, y } => Some((x, y)),
            _ => None,
        };
        if let Some(c) = self.cache.get_mut(slot) {
            *c = (k, end);
        }
        end
    }

    /// The four returns around `beam`, in beam order: the two nearest at or
    /// before it and the two nearest after it, each found within
    /// [`BEAM_MAX_MISSING`] beams without a return of the one before
    /// (`None` from where the search found none). On a scan without holes,
    /// beams `beam − 1 … beam + 2`.
    pub(super) fn ends_around(&mut self, beam: i64) -> [Option<(i32, i32)>; 4] {
        let mut ends = [None; 4];
        let reach = i64::from(BEAM_MAX_MISSING) + 1;
        for (slots, direction) in [([1, 0], -1), ([2, 3], 1)] {
            // The search starts at `beam` going back, at `beam + 1` going on.
            let mut k = if direction < 0 { beam + 1 } else { beam };
            for slot in slots {
                let found = (0..reach).find_map(|_| {
                    k += direction;
                    self.end(k)
                });
                let Some(end) = found else {
                    break;
                };
                if let Some(e) = ends.get_mut(slot) {
                    *e = Some(end);
                }
            }
        }
        ends
    }

    /// The beam whose direction is at or just before `bearing` (2³² = one
    /// turn; the bearing's lower bits taken as zero), −1 just before beam
    /// 0; `None` outside the field of view. One multiplication by the
    /// step's reciprocal and one check (exact division for steps below
    /// 2⁻¹⁶ turn).
    pub(super) fn beam_before(&self, bearing: u32) -> Option<i64> {
        let bearing = u64::from(bearing) << 32;
        let rel = if self.counter_clockwise {
            bearing.wrapping_sub(self.start)
        } else {
            self.start.wrapping_sub(bearing)
        };
        let beam = match self.inverse_step {
            Some(inverse) => {
                // Within one beam of ⌊rel / step⌋; made exact with one
                // product, so that a clockwise scan (its beams in the
                // other order) picks the same beams around a bearing.
                let beam = ((rel >> 32) * inverse) >> 48;
                let below = |k: u64| u128::from(k) * u128::from(self.step) <= u128::from(rel);
                if !below(beam) {
                    beam.saturating_sub(1)
                } else if below(beam + 1) {
                    beam + 1
                } else {
                    beam
                }
            }
            None => rel.checked_div(self.step)?,
        };
        if beam <= self.ranges.len() as u64 {
            Some(beam as i64)
        } else if rel.wrapping_neg() <= self.step {
            Some(-1)
        } else {
            None
        }
    }

    /// The beam at or just before the bearing of `p` (Q16 cells) from the
    /// sensor ([`beam_before`](Self::beam_before)).
    pub(super) fn beam_of(&self, p: (i64, i64)) -> Option<i64> {
        let (dx, dy) = (
            p.0 - i64::from(self.origin.0),
            p.1 - i64::from(self.origin.1),
        );
        self.beam_before(atan2_turns(dy, dx))
    }

    /// The signed distance (Q16 cells) of `p` (Q16 cells) to the line of the
    /// usable segment around its bearing whose midpoint is nearest, with
    /// that line's unit normal (Q15).
    pub(super) fn nearest(&mut self, p: (i64, i64)) -> Option<(i64, (i64, i64))> {
        let beam = self.beam_of(p)?;
        self.nearest_around(p, beam)
    }

    /// [`nearest`](Self::nearest) given the beam around `p`'s bearing
    /// ([`beam_of`](Self::beam_of)). The choice needs no root or division;
    /// the chosen segment's normal takes one of each.
    pub(super) fn nearest_around(&mut self, p: (i64, i64), beam: i64) -> Option<(i64, (i64, i64))> {
        let ends = self.ends_around(beam);
        self.nearest_among(p, &ends)
    }

    /// [`nearest`](Self::nearest) given the returns around `p`'s bearing
    /// ([`ends_around`](Self::ends_around)).
    pub(super) fn nearest_among(
        &self,
        p: (i64, i64),
        ends: &[Option<(i32, i32)>; 4],
    ) -> Option<(i64, (i64, i64))> {
        // (squared distance to the midpoint, start, direction)
        let mut best: Option<(u32, Point, Point)> = None;
        for pair in ends.windows(2) {
            let (Some(a), Some(b)) = (pair[0], pair[1]) else {
                continue;
            };
            let (a, b) = (
                (i64::from(a.0), i64::from(a.1)),
                (i64::from(b.0), i64::from(b.1)),
            );
            let e = (b.0 - a.0, b.1 - a.1);
            let len_sq = (e.0 * e.0 + e.1 * e.1) as u64;
            if len_sq == 0 || len_sq > self.max_len_sq {
                continue;
            }
            // 2·(p − midpoint) to 1/16 cell, squared in 32 bits (beyond
            // 2¹¹ cells every candidate is as far).
            let coarse = |v: i64| (v >> 12).clamp(-(1 << 15), 1 << 15) as i32;
            let (mx, my) = (coarse(2 * p.0 - a.0 - b.0), coarse(2 * p.1 - a.1 - b.1));
            let far = (mx * mx) as u32 + (my * my) as u32;
            if best.is_none_or(|(f, _, _)| far < f) {
                best = Some((far, a, e));
            }
        }
        let (_, a, e) = best?;
        // The normal to 2⁻¹⁴: e shifted below 2¹⁵, so that the root and the
        // one division (a reciprocal) are 32-bit.
        let drop =
            (64 - (e.0.unsigned_abs() | e.1.unsigned_abs()).leading_zeros()).saturating_sub(15);
        let (ex, ey) = ((e.0 >> drop) as i32, (e.1 >> drop) as i32);
        let len = ((ex * ex + ey * ey) as u32).isqrt().max(1) as i32;
        // |e| ≤ len: each product below 2³⁰.
        let inverse = (1 << 30) / len;
        let n = (
            i64::from((-ey * inverse) >> 15),
            i64::from((ex * inverse) >> 15),
        );
        let r = (n.0 * (p.0 - a.0) + n.1 * (p.1 - a.1)) >> 15;
        Some((r, n))
    }
}

/// `atan2(y, x)` as a binary angle (2³² = one turn), error below
/// 2·10⁻⁴ rad (0.007°: it only picks beams, give or take one); 0 for the
/// origin.
pub(super) fn atan2_turns(y: i64, x: i64) -> u32 {
    if x == 0 && y == 0 {
        return 0;
    }
    let (ax, ay) = (x.unsigned_abs(), y.unsigned_abs());
    // z = min/max ∈ [0, 1].
    let (num, den, swapped) = if ay <= ax {
        (ay, ax, false)
    } else {
        (ax, ay, true)
    };
    // Both below 2¹⁶ first: one 32-bit division (the inputs to 2⁻¹⁵
    // relative).
    let drop = 48u32.saturating_sub(den.leading_zeros());
    let (num, den) = ((num >> drop) as u32, ((den >> drop) as u32).max(1));
    let z = ((num << 15) / den) as i32;
    // atan z on [0, 1] (Abramowitz & Stegun 4.4.47, error ≤ 10⁻⁵ rad),
    // z and the coefficients Q15, Horner in z² with 32-bit products.
    const C: [i32; 5] = [32_763, -10_823, 5_903, -2_790, 683];
    let z2 = (z * z) >> 15;
    let mut acc = C[4];
    for &c in C[..4].iter().rev() {
        acc = c + ((acc * z2) >> 15);
    }
    let radians_q15 = (acc * z) >> 15;
    // radians → turns·2³²: × 2³²/(2π) / 2¹⁵ = 20 860.76 (2¹⁵·π/4 times
    // that fits an i32).
    let mut turns = i64::from(radians_q15 * 20_861);
    if swapped {
        turns = (1 << 30) - turns;
    }
    if x < 0 {
        turns = (1 << 31) - turns;
    }
    if y < 0 {
        turns = -turns;
    }
    turns as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atan2_turns_matches_f64() {
        let mut worst = 0.0f64;
        for k in 0..3600 {
            let phi = (k as f64 + 0.37) * core::f64::consts::TAU / 3600.0;
            for r in [3.0, 1000.0, 1.0e6] {
                let (x, y) = ((r * phi.cos()) as i64, (r * phi.sin()) as i64);
                let want = (y as f64).atan2(x as f64);
                let got =
                    f64::from(atan2_turns(y, x) as i32) / 4_294_967_296.0 * core::f64::consts::TAU;
                let diff = (got - want + core::f64::consts::PI).rem_euclid(core::f64::consts::TAU)
                    - core::f64::consts::PI;
                worst = worst.max(diff.abs());
            }
        }
        assert!(worst < 2e-4, "{worst}");
        assert_eq!(atan2_turns(0, 0), 0);
        assert_eq!(atan2_turns(0, 5), 0);
        assert_eq!(atan2_turns(5, 0), 1 << 30);
        assert_eq!(atan2_turns(0, -5), 1 << 31);
    }
}
