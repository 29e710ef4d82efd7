//! ICP below one cell and one θ step: the verified pose's refinement, point
//! to point then point to line, in fixed point.

use crate::angle::Angle;
use crate::config::icp_points;
use crate::grid::Grid;
use crate::pose::points::{centred_q1, rotate_inverse_q16, sampled_cells, scaled};
use crate::pose::pyramid::grid_bits;
use crate::pose::search::Placement;
use crate::trig::sin_cos_q15;

/// ICP of up to [`icp_points`] view cells onto the reference's occupied
/// cells, starting from `start`. Each iteration pairs every view cell with
/// the nearest occupied reference cell within one cell, then solves the
/// small rigid motion point to line (the line through the reference cells
/// within 2 cells of the match, where they form one: synthetic polygons 128²,
/// median 0.19° → 0.15° against point to point) or, with fewer than 8 such
/// pairs, point to point; until the step is below 1/128 cell and 2⁻¹⁴ rad or
/// after [`ICP_ITERATIONS`]. The view is shrunk by
/// `inv_scale_q16` first (the scale stays fixed). Returns the refined
/// rotation and the translation `u` in centred reference coordinates (Q8
/// cells, y up).
///
/// Fixed point: positions in Q8 cells (|·| < 2²⁰ for W, H ≤ 2048 and
/// s ≥ ½), sums in `i64` (< 2⁵¹ with ≤ 512 points). More points than the
/// search scores: the refinement averages their residuals (synthetic
/// polygons 128², point to point, 128 → all cells: median 0.33° → 0.22°).
pub(crate) fn refine<const W: usize, const H: usize, const RW: usize, const N: usize>(
    reference: &Grid<W, H, RW>,
    view: &Grid<W, H, RW>,
    start: &Placement,
    inv_scale_q16: u32,
) -> (Angle, (i64, i64)) {
    let mut alpha = start.alpha;
    // Cells (Δcol, Δrow) → centred (Δx, Δy) = (Δcol, −Δrow), Q8.
    let mut u = (
        i64::from(start.shift.0) << 8,
        -(i64::from(start.shift.1) << 8),
    );
    // Point to point (cheap) until the steps are small, then point to line
    // (a normal per match) for the last few.
    let mut line_iterations = 0;
    for _ in 0..ICP_ITERATIONS {
        let to_line = line_iterations > 0;
        let (cos, sin) = sin_cos_q15::<N>(alpha);
        let mut sums = PairSums::default();
        let mut lines = LineSums::default();
        for (col, row) in sampled_cells(view, icp_points(W, H)) {
            let (x, y) = scaled(
                rotate_inverse_q16((cos, sin), centred_q1::<W, H>(col, row)),
                i64::from(inv_scale_q16),
            );
            let q = ((x >> 8) + u.0, (y >> 8) + u.1);
            if let Some((m, cell)) = nearest_occupied::<W, H, RW>(reference, q) {
                sums.add(q, m);
                if let Some(n) = to_line.then(|| local_normal(reference, cell)).flatten() {
                    lines.add(q, m, n);
                }
            }
        }
        // Point to line where the reference shows a line (sub-cell along the
        // wall does not pull), point to point otherwise.
        let solved = lines.solve().or_else(|| sums.solve());
        let Some((delta_q16, step)) = solved else {
            break;
        };
        // q' = R(δ)·q + step; q = R(−α)·p + u ⇒ α' = α − δ, u' = R(δ)·u + step.
        let (cd, sd) = small_rotation_q16(delta_q16);
        u = (
            ((cd * u.0 - sd * u.1) >> 16) + step.0,
            ((sd * u.0 + cd * u.1) >> 16) + step.1,
        );
        alpha = alpha + Angle(radians_q16_to_turns(-delta_q16) as u32);
        let small = delta_q16.abs() < 64 && step.0.abs() < 32 && step.1.abs() < 32;
        let converged = delta_q16.abs() < 4 && step.0.abs() < 2 && step.1.abs() < 2;
        if to_line {
            line_iterations += 1;
            if converged || line_iterations > LINE_ITERATIONS {
                break;
            }
        } else if small || converged {
            line_iterations = 1;
        }
    }
    (alpha, u)
}

/// ICP iterations at most.
const ICP_ITERATIONS: usize = 15;
/// Point-to-line iterations at most, after the point-to-point ones have
/// settled (steps below 1/8 cell and 0.06°).
const LINE_ITERATIONS: usize = 3;

/// Largest rotation one ICP step may make, Q16 radians (≈ 2.9°).
const MAX_ICP_STEP_Q16: i64 = 3277;

/// Radians (Q16) to binary turns (× 2³²/2π).
fn radians_q16_to_turns(rad_q16: i64) -> i64 {
    // 2³² / 2π = 683 565 275.6; × rad_q16 / 2¹⁶.
    (rad_q16 * 683_565_276) >> 16
}

/// `(cos δ, sin δ)` in Q16 for a small δ in Q16 radians.
fn small_rotation_q16(delta_q16: i64) -> (i64, i64) {
    let half_sq = (delta_q16 * delta_q16) >> 17;
    ((1 << 16) - half_sq, delta_q16)
}

/// A match of the ICP: the reference cell's centre (centred, Q8) and the
/// cell `(col, row)`.
type Match = ((i64, i64), (i64, i64));

/// Centre of the occupied reference cell nearest `q` (centred, Q8) among the
/// 3 × 3 cells around it, in centred Q8 coordinates.
fn nearest_occupied<const W: usize, const H: usize, const RW: usize>(
    grid: &Grid<W, H, RW>,
    (x, y): (i64, i64),
) -> Option<Match> {
    // Cell coordinates in Q8: col = x + (W − 1)/2, row = (H − 1)/2 − y.
    let col_q8 = x + ((W as i64 - 1) << 7);
    let row_q8 = ((H as i64 - 1) << 7) - y;
    let (c, r) = ((col_q8 + 128) >> 8, (row_q8 + 128) >> 8);
    let mut best: Option<(i64, Match)> = None;
    for dr in -1..=1 {
        // The three cells of the row at once (columns outside read clear).
        let mut occupied = neighbourhood_row(grid, c - 1, r + dr, 3);
        while occupied != 0 {
            let dc = i64::from(occupied.trailing_zeros()) - 1;
            occupied &= occupied - 1;
            let (cc, rr) = (c + dc, r + dr);
            let (ex, ey) = ((cc << 8) - col_q8, (rr << 8) - row_q8);
            let d = ex * ex + ey * ey;
            if best.is_none_or(|(bd, _)| d < bd) {
                let centre = (
                    (cc << 8) - ((W as i64 - 1) << 7),
                    ((H as i64 - 1) << 7) - (rr << 8),
                );
                best = Some((d, (centre, (cc, rr))));
            }
        }
    }
    best.map(|(_, m)| m)
}

/// [`grid_bits`] at `i64` coordinates (those of the ICP): beyond `i32`
/// they are outside the grid and read clear.
fn neighbourhood_row<const W: usize, const H: usize, const RW: usize>(
    grid: &Grid<W, H, RW>,
    col: i64,
    row: i64,
    n: u32,
) -> u32 {
    match (i32::try_from(col), i32::try_from(row)) {
        (Ok(col), Ok(row)) => grid_bits(grid, col, row, n),
        _ => 0,
    }
}

/// Unit normal (Q14, centred y-up frame) of the line the occupied cells
/// within 2 cells of `(col, row)` form: the minor axis of their scatter.
/// `None` with fewer than 3 cells or no clear direction (the major axis'
/// variance less than 4 times the minor one's: a corner or a blob).
fn local_normal<const W: usize, const H: usize, const RW: usize>(
    grid: &Grid<W, H, RW>,
    (c, r): (i64, i64),
) -> Option<(i64, i64)> {
    let (mut n, mut sx, mut sy, mut sxx, mut syy, mut sxy) = (0i64, 0i64, 0i64, 0i64, 0i64, 0i64);
    for dr in -2i64..=2 {
        let mut occupied = neighbourhood_row(grid, c - 2, r + dr, 5);
        while occupied != 0 {
            let dc = i64::from(occupied.trailing_zeros()) - 2;
            occupied &= occupied - 1;
            // y up: Δy = −Δrow.
            let (dx, dy) = (dc, -dr);
            n += 1;
            sx += dx;
            sy += dy;
            sxx += dx * dx;
            syy += dy * dy;
            sxy += dx * dy;
        }
    }
    if n < 3 {
        return None;
    }
    // n² × the scatter matrix [[a, b], [b, d]].
    let a = n * sxx - sx * sx;
    let d = n * syy - sy * sy;
    let b = n * sxy - sx * sy;
    let root = (((a - d) * (a - d) + 4 * b * b) as u64).isqrt() as i64;
    let (major, minor) = (a + d + root, a + d - root); // twice the eigenvalues
    if major < 4 * minor || major <= 0 {
        return None;
    }
    // Major-axis direction, from whichever row of (M − λ) is better
    // conditioned; the normal is perpendicular to it.
    let (vx, vy) = if a >= d {
        (major - 2 * d, 2 * b)
    } else {
        (2 * b, major - 2 * a)
    };
    let len = ((vx * vx + vy * vy) as u64).isqrt() as i64;
    if len == 0 {
        return None;
    }
    Some(((-vy << 14) / len, (vx << 14) / len))
}

/// Sums of the point-to-line normal equations: unknowns δ (Q16 rad) and the
/// step τ (Q8 cells); each pair adds `a = (n·J q / 2¹⁶, n_x, n_y)` and
/// `e = n·(m − q)` (`J q = (−q_y, q_x)`).
#[derive(Default)]
struct LineSums {
    count: i64,
    h: [[i128; 3]; 3],
    g: [i128; 3],
}

impl LineSums {
    fn add(&mut self, q: (i64, i64), m: (i64, i64), n: (i64, i64)) {
        let a = [
            i128::from((n.1 * q.0 - n.0 * q.1) >> 16),
            i128::from(n.0),
            i128::from(n.1),
        ];
        let e = i128::from(n.0 * (m.0 - q.0) + n.1 * (m.1 - q.1));
        for i in 0..3 {
            for j in 0..3 {
                self.h[i][j] += a[i] * a[j];
            }
            self.g[i] += a[i] * e;
        }
        self.count += 1;
    }

    /// δ (Q16 rad, clamped) and the step (Q8), or `None` with fewer than 8
    /// pairs or a singular system.
    fn solve(&self) -> Option<(i64, (i64, i64))> {
        if self.count < 8 {
            return None;
        }
        let mut h = self.h;
        let mut g = self.g;
        // A small pull of τ towards 0 keeps an unobservable direction (a
        // corridor) where the search put it.
        let ridge = (h[1][1] + h[2][2]) >> 12;
        h[1][1] += ridge.max(1);
        h[2][2] += ridge.max(1);
        // Scale so every entry is below 2⁴⁰: 3-term products stay in i128.
        let big = h
            .iter()
            .flatten()
            .chain(g.iter())
            .map(|v| v.unsigned_abs())
            .max()
            .unwrap_or(0);
        let shift = (128 - big.leading_zeros()).saturating_sub(40);
        for v in h.iter_mut().flatten().chain(g.iter_mut()) {
            *v >>= shift;
        }
        let det3 = |m: &[[i128; 3]; 3]| {
            m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
        };
        let det = det3(&h);
        if det <= 0 {
            return None;
        }
        let mut x = [0i128; 3];
        for (i, xi) in x.iter_mut().enumerate() {
            let mut m = h;
            for (row, gv) in m.iter_mut().zip(g) {
                row[i] = gv;
            }
            *xi = det3(&m) / det;
        }
        let delta = (x[0] as i64).clamp(-MAX_ICP_STEP_Q16, MAX_ICP_STEP_Q16);
        // τ is in Q8: limit a step to 2 cells.
        let step = (
            (x[1] as i64).clamp(-512, 512),
            (x[2] as i64).clamp(-512, 512),
        );
        Some((delta, step))
    }
}

/// Running sums of matched pairs `(q, m)` (Q8).
#[derive(Default)]
struct PairSums {
    n: i64,
    q: (i64, i64),
    m: (i64, i64),
    /// Σ q·m (dot) and Σ q × m (cross), Q16.
    dot: i64,
    cross: i64,
}

impl PairSums {
    fn add(&mut self, q: (i64, i64), m: (i64, i64)) {
        self.n += 1;
        self.q = (self.q.0 + q.0, self.q.1 + q.1);
        self.m = (self.m.0 + m.0, self.m.1 + m.1);
        self.dot += q.0 * m.0 + q.1 * m.1;
        self.cross += q.0 * m.1 - q.1 * m.0;
    }

    /// The small rotation δ (Q16 rad) and the step (Q8) of the rigid motion
    /// `m ≈ R(δ)·q + step`, or `None` with fewer than 3 pairs or no spread.
    fn solve(&self) -> Option<(i64, (i64, i64))> {
        if self.n < 3 {
            return None;
        }
        let n = self.n;
        // Centred sums: Σ(q − q̄)·(m − m̄) = Σ q·m − Σq·Σm / n.
        let dot = self.dot - (self.q.0 * self.m.0 + self.q.1 * self.m.1) / n;
        let cross = self.cross - (self.q.0 * self.m.1 - self.q.1 * self.m.0) / n;
        if dot <= 0 {
            return None;
        }
        let delta = ((cross << 16) / dot).clamp(-MAX_ICP_STEP_Q16, MAX_ICP_STEP_Q16);
        let (cd, sd) = small_rotation_q16(delta);
        let (qx, qy) = (self.q.0 / n, self.q.1 / n);
        let (mx, my) = (self.m.0 / n, self.m.1 / n);
        let step = (
            mx - ((cd * qx - sd * qy) >> 16),
            my - ((sd * qx + cd * qy) >> 16),
        );
        Some((delta, step))
    }
}
