//! Float (`f64`) reference of the verification by alignment, written from its
//! definition and sharing no code with the library (only the [`Image`] type
//! of [`crate::reference`]).
//!
//! Definition (the library's `src/align.rs` and `Estimator::verified`, as
//! specified, not as implemented):
//!
//! - Coordinates: cell `(col, row)` of a `W × H` image is at
//!   `x = col − (W−1)/2`, `y = (H−1)/2 − row` (y up, cells).
//! - Points: up to `m` occupied cells of image 2, spread evenly in raster
//!   order (row 0 first, then by column): of `n` occupied cells,
//!   `k = min(n, m)` are kept, the `j`-th (`j = 0..k`) being the one of
//!   raster index `⌈(j + 1)·n / k⌉ − 1` — the last cell of the `j`-th of `k`
//!   equal slices of the raster sequence. `m` = [`points_for`]`(W, H)`:
//!   `max(W, H) / 2` within 64 ..= [`ALIGN_POINTS`] (the library's
//!   `align_points`).
//! - A pose `(α, u)` maps a point `p₂` of image 2 into the reference image
//!   as `p₁ = R(−α)·p₂ + u`, and the point lands on the reference cell
//!   whose centre is nearest (ties to the larger `col` / `row`). It scores 2
//!   if that cell is occupied, 1 if only one of its 8 neighbours is (cells
//!   outside the image are free), 0 otherwise.
//! - Alignment of a pose: `Σ scores / (2·points)`, in [0, 1]; overlap: the
//!   share of points scoring at least 1.
//! - The best integer translation of a rotation: every integer `u` with
//!   `|u_x|, |u_y| ≤ max_shift` (here evaluated exhaustively, by summing, for
//!   every pair of a point and a scoring reference cell, that cell's score
//!   into the translation taking one onto the other).
//! - Status rule: [`LowOverlap`](Verdict::low_overlap) when the best pose's
//!   overlap is below [`MIN_OVERLAP`]; ambiguous when the best alignment is
//!   below [`ALIGNMENT_RATIO`] × the best alignment of a rotation at least
//!   [`RIVAL_SEPARATION_DEG`] away.
//!
//! The library searches around its correlation peaks only (both halves of
//! the three strongest, then ±10° around the best seeds); this reference
//! scans every θ step of the full circle, so it also says how far the
//! library's restricted search can be from the global optimum.

use std::f64::consts::TAU;

use crate::reference::Image;

/// Most points of image 2 scored on any grid (the library's
/// `ALIGN_POINTS`).
pub const ALIGN_POINTS: usize = 128;

/// Points of image 2 scored on a `width × height` grid: `max(w, h) / 2`,
/// at least 64 and at most [`ALIGN_POINTS`] (about one per two cells of a
/// wall across the grid).
pub fn points_for(width: usize, height: usize) -> usize {
    (width.max(height) / 2).clamp(64, ALIGN_POINTS)
}

/// Default share of the view that must lie within one cell of the reference
/// (the library's `Thresholds::min_overlap` default).
pub const MIN_OVERLAP: f64 = 0.30;

/// Lead of the winner's alignment over its rival below which the
/// reference's own verdict is ambiguous (the library's rule up to 0.2; the
/// library now decides on both-way support, `docs/confidence.md`).
pub const ALIGNMENT_RATIO: f64 = 1.15;

/// Smallest angular distance of a rival rotation, degrees.
pub const RIVAL_SEPARATION_DEG: f64 = 5.0;

/// The points of `view` that are scored, `(col, row)`, in raster order:
/// [`points_for`] its size at most.
pub fn sample_points(view: &Image) -> Vec<(usize, usize)> {
    sample_at_most(view, points_for(view.width, view.height))
}

/// At most `max` occupied cells of `view`, spread evenly in raster order.
pub fn sample_at_most(view: &Image, max: usize) -> Vec<(usize, usize)> {
    let occupied = view.occupied(); // row-major = raster order
    let n = occupied.len();
    let k = n.min(max);
    (0..k)
        .map(|j| occupied[((j + 1) * n).div_ceil(k) - 1])
        .collect()
}

/// The score of each reference cell, 2 (occupied), 1 (a neighbour occupied)
/// or 0, over the image and a one-cell ring around it.
#[derive(Clone, Debug)]
pub struct ScoreMap {
    width: i64,
    height: i64,
    /// `(W + 2) × (H + 2)` scores, cell `(c, r)` at `(r + 1)·(W + 2) + c + 1`.
    scores: Vec<u8>,
    /// The cells with a non-zero score, `(col, row, score)`.
    support: Vec<(i64, i64, u32)>,
}

impl ScoreMap {
    /// The score map of `reference`.
    pub fn new(reference: &Image) -> Self {
        let (w, h) = (reference.width as i64, reference.height as i64);
        let occupied = |c: i64, r: i64| {
            (0..w).contains(&c) && (0..h).contains(&r) && reference.get(c as usize, r as usize)
        };
        let mut scores = vec![0u8; ((w + 2) * (h + 2)) as usize];
        let mut support = Vec::new();
        for r in -1..=h {
            for c in -1..=w {
                let score = if occupied(c, r) {
                    2
                } else if (-1..=1).any(|dr| (-1..=1).any(|dc| occupied(c + dc, r + dr))) {
                    1
                } else {
                    0
                };
                scores[((r + 1) * (w + 2) + c + 1) as usize] = score;
                if score > 0 {
                    support.push((c, r, u32::from(score)));
                }
            }
        }
        Self {
            width: w,
            height: h,
            scores,
            support,
        }
    }

    /// Score of reference cell `(c, r)` (0 beyond the ring).
    pub fn score(&self, c: i64, r: i64) -> u32 {
        if (-1..=self.width).contains(&c) && (-1..=self.height).contains(&r) {
            u32::from(self.scores[((r + 1) * (self.width + 2) + c + 1) as usize])
        } else {
            0
        }
    }
}

/// A scored pose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Alignment {
    /// Σ point scores.
    pub score: u32,
    /// Points scored.
    pub points: u32,
    /// Points scoring at least 1.
    pub near: u32,
    /// The translation `u` in cells, `(u_x, u_y)` (x right, y up).
    pub u: (f64, f64),
}

impl Alignment {
    /// `score / (2·points)`, 0 without points.
    pub fn alignment(&self) -> f64 {
        if self.points == 0 {
            0.0
        } else {
            f64::from(self.score) / (2.0 * f64::from(self.points))
        }
    }

    /// `near / points`, 0 without points.
    pub fn overlap(&self) -> f64 {
        if self.points == 0 {
            0.0
        } else {
            f64::from(self.near) / f64::from(self.points)
        }
    }
}

/// The reference cell `(col, row)` nearest `p₁ = R(−α)·p₂ + u` for the view
/// cell `(col, row)` (both images `W × H`).
fn landing(view: &Image, cell: (usize, usize), alpha: f64, u: (f64, f64)) -> (i64, i64) {
    let (x2, y2) = view.coords(cell.0, cell.1);
    let (s, c) = alpha.sin_cos();
    // R(−α) = [[cos, sin], [−sin, cos]].
    let (x1, y1) = (c * x2 + s * y2 + u.0, -s * x2 + c * y2 + u.1);
    let col = (x1 + (view.width as f64 - 1.0) / 2.0 + 0.5).floor();
    let row = ((view.height as f64 - 1.0) / 2.0 - y1 + 0.5).floor();
    (col as i64, row as i64)
}

/// The alignment of the pose `(α, u)` (any real `u`).
pub fn alignment_at(
    map: &ScoreMap,
    view: &Image,
    points: &[(usize, usize)],
    alpha: f64,
    u: (f64, f64),
) -> Alignment {
    let scores: Vec<u32> = points
        .iter()
        .map(|&p| {
            let (c, r) = landing(view, p, alpha, u);
            map.score(c, r)
        })
        .collect();
    Alignment {
        score: scores.iter().sum(),
        points: points.len() as u32,
        near: scores.iter().filter(|&&s| s > 0).count() as u32,
        u,
    }
}

/// The best integer translation for rotation `α`, exhaustively over
/// `|u_x|, |u_y| ≤ max_shift`: the highest score, then the highest overlap,
/// then the smallest `|u|`.
pub fn best_translation(
    map: &ScoreMap,
    view: &Image,
    points: &[(usize, usize)],
    alpha: f64,
    max_shift: i64,
) -> Alignment {
    let side = (2 * max_shift + 1) as usize;
    let mut score = vec![0u32; side * side];
    let mut near = vec![0u32; side * side];
    for &p in points {
        let (c0, r0) = landing(view, p, alpha, (0.0, 0.0));
        // An integer u moves the landing cell by (u_x, −u_y) exactly.
        for &(c, r, s) in &map.support {
            let (dc, dr) = (c - c0, r - r0);
            if dc.abs() <= max_shift && dr.abs() <= max_shift {
                let i = (dr + max_shift) as usize * side + (dc + max_shift) as usize;
                score[i] += s;
                near[i] += 1;
            }
        }
    }
    let mut best: Option<(u32, u32, i64, usize)> = None;
    for i in 0..side * side {
        let (dc, dr) = ((i % side) as i64 - max_shift, (i / side) as i64 - max_shift);
        let key = (score[i], near[i], -(dc * dc + dr * dr), i);
        if best.is_none_or(|b| (key.0, key.1, key.2) > (b.0, b.1, b.2)) {
            best = Some(key);
        }
    }
    let (s, n, _, i) = best.unwrap_or((0, 0, 0, side * side / 2));
    let (dc, dr) = ((i % side) as i64 - max_shift, (i / side) as i64 - max_shift);
    Alignment {
        score: s,
        points: points.len() as u32,
        near: n,
        u: (dc as f64, -dr as f64),
    }
}

/// The reference's view of one pair: the best translation at every θ step
/// `2πk/N` of the full circle.
#[derive(Clone, Debug)]
pub struct Scan {
    /// θ steps over the full circle.
    pub n_theta: usize,
    /// The best integer translation at each step.
    pub steps: Vec<Alignment>,
}

/// Scans every θ step (see [`Scan`]).
pub fn scan(reference: &Image, view: &Image, n_theta: usize, max_shift: i64) -> Scan {
    let map = ScoreMap::new(reference);
    let points = sample_points(view);
    let steps = (0..n_theta)
        .map(|k| {
            best_translation(
                &map,
                view,
                &points,
                TAU * k as f64 / n_theta as f64,
                max_shift,
            )
        })
        .collect();
    Scan { n_theta, steps }
}

/// Circular distance of two angles, degrees in [0, 180].
pub fn distance_deg(a_rad: f64, b_rad: f64) -> f64 {
    let d = (a_rad - b_rad).to_degrees().rem_euclid(360.0);
    d.min(360.0 - d)
}

/// The status rule applied to a [`Scan`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Verdict {
    /// θ step of the best alignment (the first of equal ones).
    pub best_step: usize,
    /// Its pose.
    pub best: Alignment,
    /// The best alignment at least [`RIVAL_SEPARATION_DEG`] from it, and its
    /// step.
    pub rival: Option<(usize, Alignment)>,
}

impl Verdict {
    /// The best rotation, radians in [0, 2π).
    pub fn alpha(&self, n_theta: usize) -> f64 {
        TAU * self.best_step as f64 / n_theta as f64
    }

    /// `best / rival` (alignment ratio; ∞ without a rival or with a rival of
    /// alignment 0).
    pub fn ratio(&self) -> f64 {
        match self.rival {
            Some((_, r)) if r.score > 0 => f64::from(self.best.score) / f64::from(r.score),
            _ => f64::INFINITY,
        }
    }

    /// Overlap below [`MIN_OVERLAP`].
    pub fn low_overlap(&self) -> bool {
        self.best.overlap() < MIN_OVERLAP
    }

    /// The winner does not lead its rival by [`ALIGNMENT_RATIO`].
    pub fn ambiguous(&self) -> bool {
        self.ratio() < ALIGNMENT_RATIO
    }
}

impl Scan {
    /// The rotation of step `k`, radians.
    pub fn alpha(&self, k: usize) -> f64 {
        TAU * k as f64 / self.n_theta as f64
    }

    /// The status rule over the whole circle.
    pub fn verdict(&self) -> Verdict {
        let best_step = (0..self.steps.len())
            .max_by_key(|&k| (self.steps[k].score, std::cmp::Reverse(k)))
            .unwrap_or(0);
        let best_alpha = self.alpha(best_step);
        let rival = (0..self.steps.len())
            .filter(|&k| distance_deg(self.alpha(k), best_alpha) >= RIVAL_SEPARATION_DEG - 1e-9)
            .max_by_key(|&k| (self.steps[k].score, std::cmp::Reverse(k)))
            .map(|k| (k, self.steps[k]));
        Verdict {
            best_step,
            best: self.steps[best_step],
            rival,
        }
    }

    /// The best alignment of a rotation at least `separation_deg` from
    /// `alpha` (radians), and its step.
    pub fn best_away_from(&self, alpha: f64, separation_deg: f64) -> Option<(usize, Alignment)> {
        (0..self.steps.len())
            .filter(|&k| distance_deg(self.alpha(k), alpha) >= separation_deg - 1e-9)
            .max_by_key(|&k| (self.steps[k].score, std::cmp::Reverse(k)))
            .map(|k| (k, self.steps[k]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sampling_keeps_every_cell_up_to_the_limit_then_spreads() {
        assert_eq!(
            [points_for(16, 4), points_for(96, 64), points_for(128, 128)],
            [64, 64, 64]
        );
        assert_eq!([points_for(256, 256), points_for(2048, 90)], [128, 128]);
        let cells: Vec<(usize, usize)> = (0..10).map(|i| (i, 0)).collect();
        let small = Image::from_cells(16, 4, &cells);
        assert_eq!(sample_points(&small), cells);
        // 256 cells, 128 kept: every second one, the last of each pair.
        let cells: Vec<(usize, usize)> = (0..256).map(|i| (i % 64, i / 64)).collect();
        let big = Image::from_cells(64, 4, &cells);
        let points = sample_at_most(&big, 128);
        assert_eq!(points.len(), 128);
        assert_eq!(points[0], (1, 0));
        assert_eq!(points[127], (63, 3));
        // A 64-wide image keeps 64: every fourth.
        let points = sample_points(&big);
        assert_eq!(points.len(), 64);
        assert_eq!((points[0], points[63]), ((3, 0), (63, 3)));
        // 129 cells, 128 kept: all but the first.
        let cells: Vec<(usize, usize)> = (0..129).map(|i| (i % 64, i / 64)).collect();
        let points = sample_at_most(&Image::from_cells(64, 4, &cells), 128);
        assert_eq!(points.len(), 128);
        assert_eq!(points[0], (1, 0));
        assert_eq!(points[127], (0, 2));
    }

    #[test]
    fn scores_by_hand() {
        let reference = Image::from_cells(8, 8, &[(0, 0), (5, 5)]);
        let map = ScoreMap::new(&reference);
        assert_eq!(map.score(0, 0), 2);
        assert_eq!(map.score(-1, -1), 1);
        assert_eq!(map.score(1, 1), 1);
        assert_eq!(map.score(2, 2), 0);
        assert_eq!(map.score(6, 4), 1);
        assert_eq!(map.score(-2, 0), 0);
        // A view of the same two cells moved by (+1 col, +1 row): u = (−1, +1)
        // takes it back (x right, y up: one column left, one row up).
        let view = Image::from_cells(8, 8, &[(1, 1), (6, 6)]);
        let points = sample_points(&view);
        let a = alignment_at(&map, &view, &points, 0.0, (-1.0, 1.0));
        assert_eq!((a.score, a.near), (4, 2));
        // Unmoved: each point lands diagonally next to a reference cell.
        let a = alignment_at(&map, &view, &points, 0.0, (0.0, 0.0));
        assert_eq!((a.score, a.near), (2, 2));
        assert_eq!((a.alignment(), a.overlap()), (0.5, 1.0));
        let best = best_translation(&map, &view, &points, 0.0, 3);
        assert_eq!((best.score, best.u), (4, (-1.0, 1.0)));
        assert_eq!(best.alignment(), 1.0);
        // A half turn maps (col, row) to (7 − col, 7 − row).
        let turned = Image::from_cells(8, 8, &[(7, 7), (2, 2)]);
        let points = sample_points(&turned);
        let a = alignment_at(&map, &turned, &points, std::f64::consts::PI, (0.0, 0.0));
        assert_eq!(a.score, 4);
    }

    #[test]
    fn scan_finds_a_quarter_turn() {
        // An L of two arms of different lengths, turned by 90°: the best step
        // is exactly 90°, with nothing close.
        let mut cells: Vec<(usize, usize)> = (4..=27).map(|c| (c, 24)).collect();
        cells.extend((12..24).map(|r| (4, r)));
        let a = Image::from_cells(32, 32, &cells);
        // (x, y) → (−y, x): (col, row) → (row, 31 − col).
        let turned: Vec<(usize, usize)> = cells.iter().map(|&(c, r)| (r, 31 - c)).collect();
        let b = Image::from_cells(32, 32, &turned);
        let scan = scan(&a, &b, 360, 8);
        let v = scan.verdict();
        // 90° fits exactly; so do the steps within ~2° (a 24-cell arm turned
        // by 2° moves its end by less than half a cell).
        assert_eq!(scan.steps[90].alignment(), 1.0);
        assert_eq!(scan.steps[90].u, (0.0, 0.0));
        assert!(v.best_step.abs_diff(90) <= 2, "{v:?}");
        assert_eq!(v.best.alignment(), 1.0);
        assert!(!v.low_overlap());
        // Rotations 30° or more away align far worse; 5° away, a 36-point L
        // still aligns nearly as well (67 of 72), so the rule flags it.
        let (_, far) = scan.best_away_from(scan.alpha(90), 30.0).unwrap();
        assert!(far.alignment() < 0.6, "{far:?}");
        assert!(v.ambiguous(), "{v:?}");
    }
}
