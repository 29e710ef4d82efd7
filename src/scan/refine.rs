//! The estimate refined on the beams' own end points (issue 23 item 7):
//! a point-to-line ICP of the current scan's end points on the segments
//! between neighbouring beams of the reference scan, after the grid
//! estimate has chosen the rotation ([`Raster::refine_on_beams`]).
//!
//! The grid estimate works on cell centres (4–9 cm on the shared real
//! scans at 256² and 128²); the beams place each wall to the sensor's own
//! precision. Each iteration:
//!
//! 1. every valid end point `q` of the current scan lands in the
//!    reference's robot frame at `p = R(θ)·q + d` (`θ = −α`,
//!    `d = −R(θ)·t`: the estimator's convention turned into the robot's
//!    motion, [`motion`](crate::motion));
//! 2. its bearing from the reference sensor picks the reference beams
//!    `j − 1 … j + 2` around it (the four nearest returns, reaching over
//!    at most [`BEAM_MAX_MISSING`] beams without one between two); of the
//!    segments between two consecutive ones at most [`BEAM_SEGMENT_MAX_M`]
//!    long, the one whose
//!    midpoint is nearest gives the signed distance `r = n·(p − a)` to its
//!    line;
//! 3. points farther than three times the median `|r|` of the previous
//!    iteration (clamped to [`BEAM_TRIM_MIN_M`]…[`BEAM_TRIM_MAX_M`]; the
//!    first iteration trims at the maximum) are dropped, and one
//!    Gauss–Newton step of `Σ r²` over `(d_x, d_y, θ)` moves the pose.
//!
//! It stops after [`BEAM_FIT_MAX_ITERATIONS`] or when a step moves the pose by less
//! than 0.01 cells and 10⁻⁴ rad. Along a direction the estimate reports
//! unobservable (a corridor), the translation does not move.
//!
//! # Numbers
//!
//! Integer throughout the iterations: the end points are [`ScanBeams`]'
//! Q16 cells, the bearing a 32-bit arctangent (error below 2·10⁻⁴ rad,
//! enough to pick beams), the normals Q15, the sums `i64`, the 3 × 3
//! normal equations solved by a power-of-two-scaled Cramer's rule (within
//! 10⁻³ of the exact step);
//! only the setup converts a few lengths from metres in `f64`, as
//! [`ScanBeams::new`] does. Measured on the shared real pairs
//! (`overlap_gt` ≥ 0.5, estimate within 2°; `bash tools/confidence.sh`):
//! the median rotation error falls from 0.249° to 0.229° at 256² and from
//! 0.321° to 0.231° at 128², the median translation error from 2.6 to
//! 2.3 cm and from 3.4 to 2.4 cm; the files' own ground truth agrees with a
//! float beam-level fit only to about 0.19° (`tools/beam_checks.py
//! refine`). Cost on the microcontroller: `budgets/TABLE.md`, real-scan
//! table (`examples/real_scans.rs` refines every pair).

use super::beam::{BeamEnd, ScanBeams, BEAM_MAX_MISSING};
use super::sine::sin_cos;
use super::{Raster, Scan};
use crate::angle::Angle;
use crate::pose::translation::without_component;
use crate::pose::Pose;
use fixed::types::I16F16;

/// Longest segment between two neighbouring beams that counts as a wall,
/// metres (a longer gap is a depth jump).
pub const BEAM_SEGMENT_MAX_M: f32 = 0.5;
/// The trim distance is three times the median residual, at least this,
/// metres.
pub const BEAM_TRIM_MIN_M: f32 = 0.02;
/// … and at most this, metres.
pub const BEAM_TRIM_MAX_M: f32 = 0.3;
/// Gauss–Newton iterations at most.
pub const BEAM_FIT_MAX_ITERATIONS: u8 = 8;
/// Matched points below which no step is taken.
pub const BEAM_FIT_MIN_PAIRS: u16 = 10;
/// The refinement may move the rotation by at most this, degrees; farther
/// it has left the estimate's basin and is refused
/// ([`BeamFitError::MovedTooFar`]).
pub const BEAM_FIT_MAX_ROTATION_DEG: f32 = 1.0;
/// … and the translation by at most this many cells.
pub const BEAM_FIT_MAX_SHIFT_CELLS: f32 = 3.0;

/// [`BEAM_FIT_MAX_ROTATION_DEG`] as a binary angle (2³² = one turn).
pub(super) const MAX_TURN: Angle = Angle::from_degrees(BEAM_FIT_MAX_ROTATION_DEG);
/// [`BEAM_FIT_MAX_SHIFT_CELLS`] in Q16 cells.
const MAX_SHIFT_Q16: i64 = (BEAM_FIT_MAX_SHIFT_CELLS as f64 * 65_536.0) as i64;
/// Width of a bin of the residual histogram, metres (rounded down to a
/// power of two of Q16 cells).
const BIN_M: f32 = 0.0025;
/// Bins of the residual histogram (the last collects everything beyond).
const BINS: usize = 64;

/// The pose refined on the beams ([`Raster::refine_on_beams`]), in the
/// estimator's convention: `p₂ = R(α)·p₁ + t`, cells of the raster.
/// [`Raster::motion`] turns it into the robot's motion.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BeamFit {
    /// The refined rotation of the scene (α = −dθ).
    pub alpha: Angle,
    /// The refined translation `t`, cells; the estimate's scale, residual,
    /// column count and unobservable direction are kept (`t` still has no
    /// component along an unobservable direction).
    pub translation: Pose,
    /// End points of the current scan within the trim distance of a
    /// reference segment at the last iteration.
    pub pairs: u16,
    /// RMS distance of those points to their segments' lines, cells.
    pub residual: I16F16,
    /// Gauss–Newton steps taken (1 to [`BEAM_FIT_MAX_ITERATIONS`]).
    pub iterations: u8,
}

/// Why [`Raster::refine_on_beams`] kept the estimate as it was.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BeamFitError {
    /// The estimate is not one the beams can refine: a scale other than 1,
    /// a translation beyond the beams' reach, or a current scan of more
    /// than 65 535 beams.
    Unsupported,
    /// Fewer than [`BEAM_FIT_MIN_PAIRS`] end points found a reference segment (too
    /// little overlap, no valid beams, a reference scan whose geometry is
    /// not finite or whose sensor is far from the robot).
    TooFewPairs,
    /// The normal equations are singular (all matched segments parallel and
    /// through one point, or no lever arm for the rotation).
    Singular,
    /// The fit moved the pose beyond [`BEAM_FIT_MAX_ROTATION_DEG`] or
    /// [`BEAM_FIT_MAX_SHIFT_CELLS`]: it slid to another wall.
    MovedTooFar,
}

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

/// A point or a vector, Q16 cells, centred and y up.
type Point = (i64, i64);

/// The current pose of the fit: `p = R(θ)·q + d`.
#[derive(Clone, Copy)]
pub(super) struct FitPose {
    /// θ = −α, binary (2³² = one turn).
    pub(super) theta: u32,
    /// `d`, Q16 cells.
    pub(super) d: (i64, i64),
}

impl FitPose {
    pub(super) fn apply(&self, cos_sin: (i64, i64), q: (i32, i32)) -> (i64, i64) {
        let (c, s) = cos_sin;
        let (x, y) = (i64::from(q.0), i64::from(q.1));
        (
            ((c * x - s * y) >> 16) + self.d.0,
            ((s * x + c * y) >> 16) + self.d.1,
        )
    }
}

/// Normal equations of one iteration: `Σ J Jᵀ` (upper triangle) and
/// `Σ J r`, with `J = (n_x, n_y, n × (p − d))` (Q15, Q15, Q8 cells) and
/// `r` Q16 cells.
#[derive(Default)]
struct Normal {
    a: [i64; 6],
    b: [i64; 3],
    pairs: u16,
    r_sq: i64,
}

impl Normal {
    /// Adds one point. With `|J₁|, |J₂| ≤ 2¹⁵`, `|J₃| ≤ 2²²`, `|r| ≤ 2²⁴`
    /// and at most 2¹⁶ points (what the fit guarantees) no sum can reach
    /// 2⁶³: plain additions.
    fn add(&mut self, j: [i64; 3], r: i64) {
        let [a, b, c] = j;
        for (sum, term) in self
            .a
            .iter_mut()
            .zip([a * a, a * b, a * c, b * b, b * c, c * c])
        {
            *sum = sum.wrapping_add(term);
        }
        for (sum, ji) in self.b.iter_mut().zip(j) {
            *sum = sum.wrapping_add(ji * r);
        }
        self.pairs = self.pairs.saturating_add(1);
        self.r_sq = self.r_sq.wrapping_add((r * r) >> 16);
    }

    /// The Gauss–Newton step: `δd` in Q16 cells and `δθ` as a binary angle
    /// (2³² = one turn), or `None` when singular. `lock`: a unit vector
    /// (frame 1, Q16) along which `d` stays; without one, the weakest
    /// translation direction is held when it is too weak ([`weak_direction`]).
    fn step(&self, lock: Option<(i64, i64)>) -> Option<((i64, i64), i64)> {
        let [a00, a01, a02, a11, a12, a22] = self.a;
        let [b0, b1, b2] = self.b.map(|v| v.saturating_neg());
        let (x_t, x_theta) = match lock.or_else(|| weak_direction(a00, a01, a11)) {
            None => {
                let x = solve(
                    &[[a00, a01, a02], [a01, a11, a12], [a02, a12, a22]],
                    &[b0, b1, b2],
                )?;
                ((x[0], x[1]), x[2])
            }
            Some((ux, uy)) => {
                // Only along w = (−u_y, u_x): δd = s·w. The 2 × 2 system of
                // (s, θ), products in i128 (multiplications only).
                let (wx, wy) = (i128::from(-uy), i128::from(ux));
                let wide = |v: i64| i128::from(v);
                let narrow = |v: i128| v.clamp(i64::MIN.into(), i64::MAX.into()) as i64;
                let m00 = narrow(
                    (wide(a00) * wx * wx + 2 * wide(a01) * wx * wy + wide(a11) * wy * wy) >> 32,
                );
                let m01 = narrow((wide(a02) * wx + wide(a12) * wy) >> 16);
                let g0 = narrow((wide(b0) * wx + wide(b1) * wy) >> 16);
                let [s, theta] = solve(&[[m00, m01], [m01, a22]], &[g0, b2])?;
                let along = |w: i128| narrow((wide(s) * w) >> 16);
                ((along(wx), along(wy)), theta)
            }
        };
        // x = A⁻¹(−b) in Q16 of the equations' units: J₁, J₂ carry 2¹⁵ and r
        // 2¹⁶, so δd = x·2¹⁵/2¹⁶ cells = x_q16 / 2 in Q16 cells; J₃ carries
        // 2⁸, so δθ = x / 2⁸ rad = x_q16 · 2⁸ / 2π in binary turns
        // (2⁸/2π · 2¹⁶ = 2 670 177).
        let theta = (i128::from(x_theta) * 2_670_177) >> 16;
        Some((
            (x_t.0 >> 1, x_t.1 >> 1),
            theta.clamp(i64::MIN.into(), i64::MAX.into()) as i64,
        ))
    }
}

/// The unit vector (Q16) along which the matched segments constrain the
/// translation least, when they constrain it less than 1/20 of the best
/// direction (all matched walls nearly parallel, within about 13°: the fit
/// would slide along them on noise; the estimator's corridor test uses the
/// same ratio: `λ₂ < λ₁/20` ⇔ `441·det < 20·trace²`); `None` otherwise.
/// `a, b, c`: the translation block `[[a, b], [b, c]]` of the normal
/// equations.
fn weak_direction(a: i64, b: i64, c: i64) -> Option<(i64, i64)> {
    // Below 2⁵⁶ first, so that 441·a·c fits an i128.
    let drop = (64
        - a.unsigned_abs()
            .max(b.unsigned_abs())
            .max(c.unsigned_abs())
            .leading_zeros())
    .saturating_sub(56);
    let (a, b, c) = (
        i128::from(a >> drop),
        i128::from(b >> drop),
        i128::from(c >> drop),
    );
    if 441 * (a * c - b * b) >= 20 * (a + c) * (a + c) {
        return None;
    }
    // The strong direction is at ½·atan2(2b, a − c); the weak one a quarter
    // turn on. Both arguments shifted into an i64 together.
    let (y, x) = (2 * b, a - c);
    let drop = (128 - y.abs().max(x.abs()).leading_zeros()).saturating_sub(62);
    let strong = atan2_turns((y >> drop) as i64, (x >> drop) as i64) / 2;
    let (sin, cos) = sin_cos(strong.wrapping_add(1 << 30));
    Some((i64::from(cos), i64::from(sin)))
}

/// `A·x = rhs` for a symmetric positive semi-definite `A` (`N` = 2 or 3),
/// `x` in Q16; `None` when `A` is (nearly) singular. Integer only: `A` is
/// scaled by powers of two to a unit-ish diagonal (`Mᵢᵢ ∈ [2¹⁸, 2²⁰)`, so
/// every `|Mᵢⱼ| < 2²⁰` and a sum of six products of three fits an `i64`), `rhs`
/// likewise, then Cramer's rule; within 10⁻³ of the exact solution
/// (relative, or absolute below one unit; test `solve_matches_f64`),
/// plenty for a Gauss–Newton step.
fn solve<const N: usize>(a: &[[i64; N]; N], rhs: &[i64; N]) -> Option<[i64; N]> {
    let shift = |v: i64, s: i32| {
        if s >= 0 {
            v >> s.min(63)
        } else {
            v.saturating_mul(1 << (-s).min(62))
        }
    };
    let mut e = [0i32; N];
    for (i, ei) in e.iter_mut().enumerate() {
        let d = a[i][i];
        if d <= 0 {
            return None;
        }
        *ei = (64 - d.leading_zeros() as i32 - 19).div_euclid(2);
    }
    let limit = 1i64 << 20;
    let mut m = [[0i64; N]; N];
    for i in 0..N {
        for j in 0..N {
            m[i][j] = shift(a[i][j], e[i] + e[j]).clamp(-limit, limit);
        }
    }
    let mut g = [0i64; N];
    for i in 0..N {
        g[i] = shift(rhs[i], e[i]);
    }
    let largest = g.iter().map(|v| v.unsigned_abs()).max().unwrap_or(0);
    let h = (64 - largest.leading_zeros() as i32 - 20).max(0);
    for v in &mut g {
        *v >>= h;
    }
    let det = determinant(&m);
    let diagonal = (0..N).fold(1i64, |p, i| p.saturating_mul(m[i][i]));
    if det <= 0 || det < diagonal >> 16 {
        return None;
    }
    // The quotient keeps 24 significant bits of the divisor: y = det_c /
    // (det >> s) is in Q(s).
    let s = (64 - det.leading_zeros() as i32 - 24).clamp(0, 40);
    let divisor = (det >> s).max(1);
    let mut x = [0i64; N];
    for c in 0..N {
        let mut mc = m;
        for (row, gr) in mc.iter_mut().zip(g) {
            row[c] = gr;
        }
        // y = det_c / det; x = y · 2ʰ / 2^e_c, in Q16.
        let y = determinant(&mc) / divisor;
        x[c] = shift(y, s - 16 + e[c] - h);
    }
    Some(x)
}

/// The determinant of a 2 × 2 or 3 × 3 matrix whose entries are below 2²⁰
/// in magnitude (other sizes: 0).
fn determinant<const N: usize>(m: &[[i64; N]; N]) -> i64 {
    let at = |i: usize, j: usize| m.get(i).and_then(|r| r.get(j)).copied().unwrap_or(0);
    match N {
        2 => at(0, 0) * at(1, 1) - at(0, 1) * at(1, 0),
        3 => {
            at(0, 0) * (at(1, 1) * at(2, 2) - at(1, 2) * at(2, 1))
                - at(0, 1) * (at(1, 0) * at(2, 2) - at(1, 2) * at(2, 0))
                + at(0, 2) * (at(1, 0) * at(2, 1) - at(1, 1) * at(2, 0))
        }
        _ => 0,
    }
}

impl Raster {
    /// Refines an estimate of `current` against `reference` (the scans
    /// rasterized with this raster: `alpha` and `translation` from
    /// [`Estimator::estimate_scans`](crate::Estimator::estimate_scans)) on
    /// the beams' end points: point-to-line ICP, integer per beam (see
    /// [`BeamFit`] and the `stages::BEAM_*` constants). Returns the refined pose in the same convention,
    /// or why the estimate is better kept.
    ///
    /// It refines the pose, it does not judge it: run it on the answer the
    /// estimator chose (its status says whether to trust that), and expect
    /// it to pull a wrong answer onto nearby walls rather than to fix it.
    /// Cost: one pass over the current scan's beams per iteration, each end
    /// point reading up to four reference beams (most from a small cache;
    /// instructions on the microcontrollers: `budgets/TABLE.md`).
    pub fn refine_on_beams(
        &self,
        reference: &Scan<'_>,
        current: &Scan<'_>,
        alpha: Angle,
        translation: &Pose,
    ) -> Result<BeamFit, BeamFitError> {
        self.refine_on_beams_within(reference, current, alpha, translation, MAX_TURN)
    }

    /// [`refine_on_beams`](Self::refine_on_beams) with the rotation allowed
    /// to move by at most `max_turn` instead of
    /// [`BEAM_FIT_MAX_ROTATION_DEG`] (the check on the beams lets a rival's
    /// rotation, which no angle search has refined, move farther).
    pub(super) fn refine_on_beams_within(
        &self,
        reference: &Scan<'_>,
        current: &Scan<'_>,
        alpha: Angle,
        translation: &Pose,
        max_turn: Angle,
    ) -> Result<BeamFit, BeamFitError> {
        if translation.scale != I16F16::ONE || current.ranges.len() > usize::from(u16::MAX) {
            return Err(BeamFitError::Unsupported);
        }
        let cur_beams = ScanBeams::new(current, self);
        let mut segments = Segments::new(self, reference).ok_or(BeamFitError::TooFewPairs)?;
        let q16 = |metres: f32| self.metres_q16(metres);
        // At most 256 cells (tiny cells): the sums' bound (`Normal::add`).
        let (trim_min, trim_max) = (
            q16(BEAM_TRIM_MIN_M).min(1 << 24),
            q16(BEAM_TRIM_MAX_M).min(1 << 24),
        );
        // Bins a power of two of Q16 cells wide, between ½ and 1 × BIN_M.
        let bin_shift = 63 - q16(BIN_M).max(1).leading_zeros();
        let bin = 1i64 << bin_shift;
        // The start: θ = −α, d = −R(θ)·t.
        let theta = alpha.0.wrapping_neg();
        let (tx, ty) = (
            i64::from(translation.x.to_bits()),
            i64::from(translation.y.to_bits()),
        );
        if tx.abs().max(ty.abs()) >= 1 << 30 {
            return Err(BeamFitError::Unsupported);
        }
        let cs = |theta: u32| {
            let (s, c) = sin_cos(theta);
            (i64::from(c), i64::from(s))
        };
        let (c, s) = cs(theta);
        let start_pose = FitPose {
            theta,
            d: (-((c * tx - s * ty) >> 16), -((s * tx + c * ty) >> 16)),
        };
        // The unobservable direction u lives in t's frame; in d's it is R(θ)·u.
        let lock = translation.unobservable.map(|(ux, uy)| {
            let (ux, uy) = (i64::from(ux.to_bits()), i64::from(uy.to_bits()));
            ((c * ux - s * uy) >> 16, (s * ux + c * uy) >> 16)
        });
        let mut pose = start_pose;
        let residual_bin = |r: i64| {
            usize::try_from(r.unsigned_abs() >> bin_shift).map_or(BINS - 1, |k| k.min(BINS - 1))
        };
        // The first iteration keeps every match within the widest trim;
        // later ones trim at three times the previous iteration's median.
        let mut trim = trim_max;
        let mut last = Normal::default();
        let mut iterations = 0;
        while iterations < BEAM_FIT_MAX_ITERATIONS {
            iterations += 1;
            let rot = cs(pose.theta);
            let mut histogram = [0u16; BINS];
            let mut normal = Normal::default();
            for_each_end(&cur_beams, current.ranges, |q| {
                let p = pose.apply(rot, q);
                if let Some((r, n)) = segments.nearest(p) {
                    if let Some(h) = histogram.get_mut(residual_bin(r)) {
                        *h = h.saturating_add(1);
                    }
                    if r.abs() <= trim {
                        let (lx, ly) = (p.0 - pose.d.0, p.1 - pose.d.1);
                        // n × (p − d) rotated a quarter turn: ∂p/∂θ = (−l_y, l_x).
                        let lever = ((n.1 * lx - n.0 * ly) >> 23).clamp(-(1 << 22), 1 << 22);
                        normal.add([n.0, n.1, lever], r);
                    }
                }
            });
            if normal.pairs < BEAM_FIT_MIN_PAIRS {
                return Err(BeamFitError::TooFewPairs);
            }
            trim = trim_distance(&histogram, bin)
                .ok_or(BeamFitError::TooFewPairs)?
                .max(trim_min)
                .min(trim_max);
            let ((sx, sy), turns) = normal.step(lock).ok_or(BeamFitError::Singular)?;
            last = normal;
            // Bounded steps (1024 cells, 1/8 turn) keep every product below
            // 2⁶³; a fit that needs larger ones is refused below anyway.
            let (sx, sy) = (sx.clamp(-1 << 26, 1 << 26), sy.clamp(-1 << 26, 1 << 26));
            let turns = turns.clamp(-(1 << 29), 1 << 29);
            pose.d = (pose.d.0 + sx, pose.d.1 + sy);
            pose.theta = pose.theta.wrapping_add(turns as u32);
            // Converged: below 0.01 cells and 10⁻⁴ rad (68 359 in 2³² turns).
            if sx.abs().max(sy.abs()) < 655 && turns.abs() < 68_359 {
                break;
            }
        }
        let moved = Angle(pose.theta).distance(Angle(start_pose.theta)).0;
        let shift = (pose.d.0 - start_pose.d.0)
            .abs()
            .max((pose.d.1 - start_pose.d.1).abs());
        if moved > max_turn.0 || shift > MAX_SHIFT_Q16 {
            return Err(BeamFitError::MovedTooFar);
        }
        // Back to the estimator's convention: α = −θ, t = −R(−θ)·d.
        let (c, s) = cs(pose.theta);
        let (dx, dy) = pose.d;
        let mut t = (-((c * dx + s * dy) >> 16), -((c * dy - s * dx) >> 16));
        if let Some(u) = translation.unobservable {
            t = without_component(t, u);
        }
        let rms = (last.r_sq / i64::from(last.pairs.max(1))).max(0) as u64;
        Ok(BeamFit {
            alpha: Angle(pose.theta.wrapping_neg()),
            translation: Pose {
                x: I16F16::from_bits(t.0 as i32),
                y: I16F16::from_bits(t.1 as i32),
                ..*translation
            },
            pairs: last.pairs,
            residual: I16F16::from_bits((rms << 16).isqrt().min(i32::MAX as u64) as i32),
            iterations,
        })
    }
}

/// Three times the median residual (Q16 cells) of a histogram of bins
/// `bin` wide, from the median bin's upper edge; `None` below
/// [`BEAM_FIT_MIN_PAIRS`] residuals.
fn trim_distance(histogram: &[u16; BINS], bin: i64) -> Option<i64> {
    let matched: u32 = histogram.iter().map(|&h| u32::from(h)).sum();
    if matched < u32::from(BEAM_FIT_MIN_PAIRS) {
        return None;
    }
    let mut below = 0u32;
    let median = histogram
        .iter()
        .position(|&h| {
            below += u32::from(h);
            2 * below >= matched
        })
        .unwrap_or(BINS - 1) as i64;
    Some(3 * (median + 1) * bin)
}

/// Calls `f` with every valid near end point of `scan` (Q16 cells).
pub(super) fn for_each_end(beams: &ScanBeams, ranges: &[f32], mut f: impl FnMut((i32, i32))) {
    for (i, &range) in ranges.iter().enumerate() {
        if let BeamEnd::Near { x, y } = beams.end(i, range) {
            f((x, y));
        }
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

    /// The integer solve against Gaussian elimination in f64, on normal
    /// equations `Σ J Jᵀ` of random Jacobians at the magnitudes the fit
    /// meets (normals Q15, levers up to thousands of Q8 cells).
    #[test]
    fn solve_matches_f64() {
        let mut seed = 12_345u64;
        let mut next = |range: i64| {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            ((seed >> 33) as i64 % (2 * range + 1)) - range
        };
        let mut worst = 0.0f64;
        for case in 0..200 {
            let mut a = [[0i64; 3]; 3];
            let mut rhs = [0i64; 3];
            let lever = [100, 10_000, 500_000][case % 3];
            for _ in 0..(20 + case) {
                let j = [next(32_768), next(32_768), next(lever)];
                let r = next(1 << 18);
                for i in 0..3 {
                    for k in 0..3 {
                        a[i][k] += j[i] * j[k];
                    }
                    rhs[i] -= j[i] * r;
                }
            }
            let x = solve(&a, &rhs).unwrap();
            // f64 reference: x = A⁻¹·rhs by elimination with pivoting.
            let mut m: [[f64; 4]; 3] = core::array::from_fn(|i| {
                [
                    a[i][0] as f64,
                    a[i][1] as f64,
                    a[i][2] as f64,
                    rhs[i] as f64,
                ]
            });
            for c in 0..3 {
                let p = (c..3)
                    .max_by(|&u, &v| m[u][c].abs().total_cmp(&m[v][c].abs()))
                    .unwrap();
                m.swap(c, p);
                let pivot = m[c];
                for (r, row) in m.iter_mut().enumerate() {
                    if r != c {
                        let f = row[c] / pivot[c];
                        for (v, p) in row.iter_mut().zip(pivot).skip(c) {
                            *v -= f * p;
                        }
                    }
                }
            }
            for i in 0..3 {
                let want = m[i][3] / m[i][i] * 65_536.0;
                let got = x[i] as f64;
                worst = worst.max((got - want).abs() / (want.abs() + 65_536.0));
            }
        }
        // Relative error, or absolute for steps below one unit: 2.7·10⁻⁴.
        assert!(worst < 1e-3, "{worst}");
        assert_eq!(solve(&[[0, 0], [0, 5]], &[1, 1]), None);
        assert_eq!(solve(&[[4, 2], [2, 1]], &[1, 1]), None); // rank 1
    }

    /// Walls all along x (normals along y) leave x weak; walls in two
    /// directions leave nothing weak.
    #[test]
    fn weak_direction_by_hand() {
        let q30 = 1i64 << 30;
        let (x, y) = weak_direction(q30 / 100, 0, 50 * q30).unwrap();
        assert!(x.abs() > 65_500 && y.abs() < 100, "{x} {y}");
        // Normals along (1, 1)/√2: weak along (1, −1)/√2.
        let (x, y) = weak_direction(25 * q30, 25 * q30, 25 * q30).unwrap();
        assert!((x + y).abs() < 100 && x.abs() > 46_000, "{x} {y}");
        assert_eq!(weak_direction(30 * q30, q30, 20 * q30), None);
    }

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
