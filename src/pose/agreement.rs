//! How well a pose makes the two views agree, both ways, on a large sample:
//! the decision between candidate poses.
//!
//! The branch and bound ([`search`](super::search)) scores a small sample of
//! the second view one way; that is enough to find each rotation's best
//! translation, but too noisy to choose between two rotations whose
//! alignments differ by a few points (a half turn in a corridor). Here a
//! pose is judged on [`icp_points`] cells of *each* view (4× the search's
//! sample), in both directions:
//!
//! - **forward**: a cell `p₂` of the current view lands in the reference at
//!   `p₁ = R(−α)·p₂/s + u`; **backward**: a reference cell `p₁` lands in the
//!   current view at `p₂ = s·R(α)·(p₁ − u)` (`u` in centred reference cells,
//!   `s` the scale);
//! - each point scores 2 on an occupied cell, 1 next to one (8 neighbours),
//!   0 otherwise ([`point_score`]);
//! - with the views' free space ([`FreeSpace`]), a point scoring 0 on a cell
//!   the other view's beams crossed is a *violation*: a wall where the other
//!   sensor saw through.
//!
//! [`Agreement::support`] combines them: the mean of the two alignments
//! (`Σ score / 2·points`, each in [0, 1]) minus the free-space weight times
//! the mean of the two violation shares. Work: `2 ×` [`icp_points`] grid
//! look-ups and rotations per pose, plus the walk over both views' occupied
//! cells that picks the samples.

use crate::angle::Angle;
use crate::config::icp_points;
use crate::grid::Grid;
use crate::pose::points::{
    centred_q1, point_score, rotate_inverse_q16, sampled_cells, scaled, to_cell_q16,
};
use crate::scan::FreeSpace;
use crate::trig::sin_cos_q15;
use crate::Score;

/// How one view's sampled cells land on the other view under a pose.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Tally {
    /// Cells scored (at most [`icp_points`], 512: 16 bits keep the
    /// verification's seeds small on the stack).
    pub(crate) points: u16,
    /// Σ point scores (0, 1 or 2 each).
    pub(crate) score: u16,
    /// Points scoring 0 on a cell the other view's beams crossed.
    pub(crate) violations: u16,
}

impl Tally {
    /// `Σ score / (2·points)` in [0, 1] (0 without points).
    fn alignment(&self) -> Score {
        share(u32::from(self.score), 2 * u32::from(self.points))
    }

    /// `violations / points` in [0, 1] (0 without points).
    fn violation(&self) -> Score {
        share(u32::from(self.violations), u32::from(self.points))
    }
}

/// A pose judged both ways.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Agreement {
    /// Current view onto the reference.
    pub(crate) forward: Tally,
    /// Reference onto the current view.
    pub(crate) backward: Tally,
}

impl Agreement {
    /// Mean of the two alignments, in [0, 1].
    pub(crate) fn alignment(&self) -> Score {
        mean(self.forward.alignment(), self.backward.alignment())
    }

    /// Mean of the two violation shares, in [0, 1] (0 without free space).
    /// (The larger of the two did worse on the real scan pairs: 6.6 %
    /// wrong among unflagged against 5.8 %.)
    pub(crate) fn violation(&self) -> Score {
        mean(self.forward.violation(), self.backward.violation())
    }

    /// `alignment − weight · violation`, in [−weight, 1] (weight clamped to
    /// [0, 64]).
    pub(crate) fn support(&self, weight: Score) -> Score {
        let weight = weight.clamp(Score::ZERO, Score::from_num(64));
        self.alignment() - self.violation().saturating_mul(weight)
    }
}

/// Judges the pose `(alpha, u_q8)` (`u` in centred reference cells, Q8, y
/// up; scale `scale_q16`, Q16, 2¹⁶ = 1) on both views.
pub(crate) fn agreement<const W: usize, const H: usize, const RW: usize, const N: usize>(
    reference: &Grid<W, H, RW>,
    current: &Grid<W, H, RW>,
    free: Option<&FreeSpace<'_, W, H, RW>>,
    alpha: Angle,
    u_q8: (i64, i64),
    scale_q16: u32,
) -> Agreement {
    let (cos, sin) = sin_cos_q15::<N>(alpha);
    let scale = i64::from(scale_q16.max(1));
    let inv_scale = (1i64 << 32).checked_div(scale).unwrap_or(1 << 16);
    let u_q16 = (u_q8.0 << 8, u_q8.1 << 8);
    let forward = tally(current, reference, free.map(|f| f.reference), |p| {
        let (x, y) = scaled(rotate_inverse_q16((cos, sin), p), inv_scale);
        (x + u_q16.0, y + u_q16.1)
    });
    let backward = tally(reference, current, free.map(|f| f.current), |(x, y)| {
        let (dx, dy) = (
            (i64::from(x) << 15) - u_q16.0,
            (i64::from(y) << 15) - u_q16.1,
        );
        let (c, s) = (i64::from(cos), i64::from(sin));
        // Q16 × Q15 → Q16; |d| < 2²⁸ (cells < 2¹²): the products fit.
        let (rx, ry) = ((c * dx - s * dy) >> 15, (s * dx + c * dy) >> 15);
        scaled((rx, ry), scale)
    });
    Agreement { forward, backward }
}

/// Scores [`icp_points`] occupied cells of `source`, each mapped by `map`
/// (centred Q1 coordinates → centred Q16 coordinates of `target`), against
/// `target` and its free cells.
fn tally<const W: usize, const H: usize, const RW: usize>(
    source: &Grid<W, H, RW>,
    target: &Grid<W, H, RW>,
    target_free: Option<&Grid<W, H, RW>>,
    map: impl Fn((i32, i32)) -> (i64, i64),
) -> Tally {
    let mut t = Tally::default();
    for (col, row) in sampled_cells(source, icp_points(W, H)) {
        let (x, y) = map(centred_q1::<W, H>(col, row));
        let (c, r) = to_cell_q16::<W, H>(x, y);
        // Far outside any grid beyond ±2³⁰ cells: clamped into an i32.
        let clamp = |v: i64| v.clamp(-(1 << 30), 1 << 30) as i32;
        let (c, r) = (clamp(c), clamp(r));
        let score = point_score(target, c, r);
        t.points = t.points.saturating_add(1);
        t.score = t.score.saturating_add(score as u16);
        if let (0, Some(free)) = (score, target_free) {
            if c >= 0 && r >= 0 && free.get(c as usize, r as usize) {
                t.violations = t.violations.saturating_add(1);
            }
        }
    }
    t
}

/// `a / b` in [0, 1] as a [`Score`]; 0 when `b` is 0.
fn share(a: u32, b: u32) -> Score {
    if b == 0 {
        return Score::ZERO;
    }
    Score::from_bits(((u64::from(a.min(b)) << 16) / u64::from(b)) as i32)
}

fn mean(a: Score, b: Score) -> Score {
    Score::from_bits(((i64::from(a.to_bits()) + i64::from(b.to_bits())) / 2) as i32)
}
