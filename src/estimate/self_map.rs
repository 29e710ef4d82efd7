//! The runner-up's self-map: does the scene map onto itself?
//!
//! The winner `W` and the runner-up `R` both lay the second view onto the
//! reference. When the scene is symmetric (a corridor, a rectangular or
//! centrally symmetric room: `R` is the other member of the α / α + π pair,
//! or a quarter turn of a square), `W⁻¹ ∘ R` lays the *reference onto
//! itself*, and the views cannot tell `W` from `R`: what separates their
//! supports is where the damage of the two views happens to fall (with
//! independent damage in the two views, the host-tests' symmetric scenes
//! left 40–80 % of the unflagged answers wrong, issue 48). That map is
//! judged here on the reference alone, after ICP (the composition of two
//! whole-cell shifts is up to a cell off, which thin walls do not forgive),
//! and compared with how well the refined answer lays the view onto the
//! reference ([`self_map_share`]); the decision ([`Thresholds::self_map_ratio`])
//! is [`verify`](super::verify)'s.

use super::seed::{inverse, shift_q8, Seed};
use super::Thresholds;
use crate::angle::Angle;
use crate::grid::Grid;
use crate::pose::agreement::agreement;
use crate::pose::icp::refine;
use crate::pose::search::Placement;
use crate::scan::FreeSpace;
use crate::trig::sin_cos_q15;
use crate::Score;

/// `S / A`, in [0, 64]: `S` the support of the reference laid onto itself
/// by `W⁻¹ ∘ R` (the runner-up `rival` after the winner `winner`'s pose is
/// undone, refined by ICP, judged both ways with the reference's free space
/// on either side when there is one), `A` the larger of the winner's
/// support at its search pose and at its refined pose `(alpha, u_q8)`,
/// each with the better of its two directions' alignments
/// (`Agreement::support_one_way`: a view that shows only part of the
/// reference lays onto it fully one way; with the mean, a Manhattan room
/// whose second view misses 30 % of its outline came out ambiguous,
/// `hand_checked::missing_stretch_in_second_view_is_resolved_or_flagged`).
/// 0 when `A` is not positive. The scale of the self-map is the ratio of the
/// two poses' scales, taken as 1 (both are searched in the same range and
/// the self-map is refined by ICP, which keeps the scale it starts from).
/// Not inlined: its ICP and samples are on the stack only while it runs.
#[inline(never)]
pub(super) fn self_map_share<const W: usize, const H: usize, const RW: usize, const N: usize>(
    reference: &Grid<W, H, RW>,
    grid: &Grid<W, H, RW>,
    free: Option<&FreeSpace<'_, W, H, RW>>,
    (winner, alpha, u_q8): (&Seed, Angle, (i64, i64)),
    rival: &Seed,
    t: &Thresholds,
) -> Score {
    let answer = agreement::<W, H, RW, N>(reference, grid, free, alpha, u_q8, winner.scale_q16)
        .support_one_way(t.free_space_weight)
        .max(winner.agreement.support_one_way(t.free_space_weight));
    if answer <= Score::ZERO {
        return Score::ZERO;
    }
    // Poses map p₁ ↦ R(α)(p₁ − u): W⁻¹ ∘ R is p₁ ↦ R(δ)(p₁ − u′) with
    // δ = α_R − α_W and u′ = u_R − R(−δ)·u_W.
    let (w, r) = (winner.placement, rival.placement);
    let delta = r.alpha - w.alpha;
    let (uw, ur) = (shift_q8(w.shift), shift_q8(r.shift));
    let (cos, sin) = sin_cos_q15::<N>(delta);
    let (cos, sin) = (i64::from(cos), i64::from(sin));
    let turned = (
        (cos * uw.0 + sin * uw.1) >> 15,
        (cos * uw.1 - sin * uw.0) >> 15,
    );
    let u = (ur.0 - turned.0, ur.1 - turned.1);
    // Whole cells for ICP's start, (Δcol, Δrow) = (uₓ, −u_y), rounded;
    // |u| is at most a few grid sides: the casts cannot overflow.
    let cells = |v: i64| ((v + 128) >> 8).clamp(-(1 << 20), 1 << 20) as i32;
    let start = Placement {
        alpha: delta,
        shift: (cells(u.0), -cells(u.1)),
        score: 0,
    };
    let one = inverse(1 << 16);
    let (self_alpha, self_u) = refine::<W, H, RW, N>(reference, reference, &start, one);
    let own_free = free.map(|f| FreeSpace {
        reference: f.reference,
        current: f.reference,
    });
    let mapped = agreement::<W, H, RW, N>(
        reference,
        reference,
        own_free.as_ref(),
        self_alpha,
        self_u,
        1 << 16,
    )
    .support(t.free_space_weight)
    .max(Score::ZERO);
    mapped
        .saturating_div(answer)
        .clamp(Score::ZERO, Score::from_num(64))
}
