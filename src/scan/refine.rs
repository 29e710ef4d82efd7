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

use super::beam::{BeamEnd, ScanBeams};
use super::segments::{atan2_turns, Segments};
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
}
