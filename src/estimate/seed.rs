//! The verification's seeds: the candidate rotations it scores (both
//! halves of the strongest correlation peaks and the quarter turns of the
//! best), each with its best translation ([`seed_at`]), the local angle
//! search around each ([`angle_search`]) and the translation a verified
//! pose reports ([`verified_translation`]). The decision among them is
//! [`verify`](super::verify)'s.

use super::Thresholds;
use crate::angle::Angle;
use crate::correlation::Peak;
use crate::pose::agreement::Agreement;
use crate::pose::search::{Aligner, Placement};
use crate::pose::translation::without_component;
use crate::pose::Pose;
use crate::trig::sin_cos_q15;
use crate::Score;
use fixed::types::I16F16;
use heapless::Vec;

/// A candidate pose of the verification: its placement (best translation,
/// forward alignment on the search sample), the correlation of its peak (0
/// for the quarter turns) and its [`Agreement`] (after step 3).
#[derive(Clone, Copy, Debug)]
pub(super) struct Seed {
    pub(super) placement: Placement,
    pub(super) correlation: Score,
    pub(super) agreement: Agreement,
    /// The scale `s` (Q16) the seed was searched and is judged at.
    pub(super) scale_q16: u32,
}

impl Seed {
    /// [`Candidate::support`].
    pub(super) fn support(&self, t: &Thresholds) -> Score {
        self.agreement.support(t.free_space_weight)
    }
}

/// Sort key of a support (monotone in it; supports are at least −80).
pub(super) fn support_key(support: Score) -> u32 {
    (i64::from(support.to_bits()) + (128 << 16)).clamp(0, i64::from(u32::MAX)) as u32
}

/// `u` in centred Q8 cells of a shift in reference cells `(Δcol, Δrow)`.
pub(super) fn shift_q8(shift: (i32, i32)) -> (i64, i64) {
    (i64::from(shift.0) << 8, -(i64::from(shift.1) << 8))
}

/// A rotation to seed the verification with ([`seed_at`]).
pub(super) struct SeedStart {
    pub(super) alpha: Angle,
    /// Its correlation peak's score (0 for the quarter turns).
    pub(super) correlation: Score,
    /// The shift (reference cells) the profile test fitted for this
    /// rotation, a floor for the search.
    pub(super) hinted: Option<(i32, i32)>,
    /// The scale `s` (Q16) to search at; the aligner is set to it.
    pub(super) scale_q16: u32,
}

/// Adds the seed of `start` with its best translation, unless it cannot
/// reach the best so far divided by `ratio` (then it is no candidate) or
/// is already a seed within one θ step.
pub(super) fn seed_at<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const PW: usize,
>(
    aligner: &mut Aligner<'_, W, H, RW, PW>,
    seeds: &mut Vec<Seed, SEEDS>,
    start: SeedStart,
    max_shift: i32,
    ratio: Score,
) {
    let SeedStart {
        alpha,
        correlation,
        hinted,
        scale_q16,
    } = start;
    let step = Angle::from_steps_q16(1 << 16, N);
    if seeds.is_full()
        || seeds
            .iter()
            .any(|s| s.placement.alpha.distance(alpha) < step)
    {
        return;
    }
    aligner.set_inv_scale(inverse(scale_q16));
    aligner.rotate::<N>(alpha, (0, 0));
    let floor = seeds
        .iter()
        .map(|s| s.placement.score)
        .max()
        .map_or(0, |best| irrelevant_below(best, ratio));
    let floor = match hinted {
        Some(shift) => floor.max(aligner.score(shift).saturating_sub(1)),
        None => floor,
    };
    if let Some((shift, score)) = aligner.search((0, 0), max_shift, floor) {
        let _ = seeds.push(Seed {
            placement: Placement {
                alpha,
                shift,
                score,
            },
            correlation,
            agreement: Agreement::default(),
            scale_q16,
        });
    }
}

/// The rotation of a correlation peak.
pub(super) fn peak_alpha<const N: usize>(peak: &Peak) -> Angle {
    Angle::from_steps_q16(((peak.shift as i64) << 16) + peak.offset_q16(), N)
}

/// A pose's scale, Q16, at least ½ (the scale searches stay far above).
pub(super) fn scale_of(pose: &Pose) -> u32 {
    pose.scale.to_bits().max(1 << 15) as u32
}

/// `1/s` in Q16 of a scale `s` in Q16 (at least ½: below 2¹⁷).
pub(super) fn inverse(scale_q16: u32) -> u32 {
    ((1u64 << 32) / u64::from(scale_q16.max(1))) as u32
}

/// Correlation peaks whose two halves the verification scores.
pub(super) const VERIFY_PEAKS: usize = 3;
/// Seeds of the verification: both halves of each peak, and the quarter
/// turns of the strongest.
pub(super) const SEEDS: usize = 2 * VERIFY_PEAKS + 2;
/// Seeds that get the local angle search (those at least half as aligned as
/// the best): all, so that the decision compares poses found alike.
pub(super) const ANGLE_SEARCH_SEEDS: usize = SEEDS;
/// Translation window (± cells) of each rotation of the angle search, around
/// the shift predicted from the seed.
pub(super) const LOCAL_RADIUS: i32 = 3;

/// Searches rotations within about ±5° of `seed` (the candidates'
/// separation: a seed that moved farther would be another candidate): in
/// strides of about 2° up to ±5° (±4° at `N` = 360), then halving the
/// stride around the best down to one θ step; each rotation gets the best
/// shift within ±[`LOCAL_RADIUS`] of the one predicted from the seed.
/// Returns the pose (the seed's unless a rotation beats it by 3 %; a pose
/// that moved then gets its rotation's best shift over the whole window,
/// ±`max_shift`, as every seed has) with the best score found at any
/// rotation.
///
/// The reach was ±10° until the alignment's noise showed: where the views
/// align poorly everywhere (a second view at an unmodelled scale, harsh
/// damage) the seed drifted 5–10° to a rotation that aligned a little
/// better by chance (synthetic polygons 128², scale 0.9–1.1 not searched:
/// 8 of the 10 wrong confident answers). With this reach and the final
/// whole-window search (`cargo run --release -p host-tests --bin accuracy`;
/// `bash tools/confidence.sh` for the shared real pairs) that row gives
/// 0.3 % wrong among unflagged (was 1.4 %; failures 8.4 → 6.1 %), the 64²
/// harsh rows 5.8 % (polygons, was 9.7 %) and 6.5 % (Manhattan, was
/// 11.3 %), no row worse beyond noise; the shared real pairs (256²) 42
/// wrong among unflagged of 4 730 (was 47). Half the rotations are
/// searched.
pub(super) fn angle_search<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const PW: usize,
>(
    aligner: &mut Aligner<'_, W, H, RW, PW>,
    seed: &Placement,
    max_shift: i32,
) -> Placement {
    let step = |k: i64| Angle::from_steps_q16(k << 16, N);
    // Strides of 2°; the reach is 5° in whole steps, down to a whole number
    // of strides (N = 360: 4°; the halving strides reach the rest).
    let mut stride = (N / 180).max(1) as i64;
    let reach = (((5 * N + 180) / 360) as i64 / stride * stride).max(1);
    let mut best = *seed;
    // The pose moves only when a rotation beats the seed by a margin:
    // single-point differences between neighbouring steps are noise, and the
    // seed's sub-step α from the correlation is the more precise (synthetic
    // polygons 128²: median 0.33° without the margin, 0.17° with it). The
    // score reported is the best found at any rotation, so that a rival is
    // judged by its best alignment.
    let margin = seed.score + (seed.score / 32).max(2);
    let mut peak = seed.score;
    let mut try_at =
        |aligner: &mut Aligner<'_, W, H, RW, PW>, best: &mut Placement, alpha: Angle| {
            aligner.rotate::<N>(alpha, (0, 0));
            let centre = aligner.predict::<N>(seed, alpha);
            if let Some((shift, score)) = aligner.search(centre, LOCAL_RADIUS, peak) {
                peak = score;
                if score >= margin && score > best.score {
                    *best = Placement {
                        alpha,
                        shift,
                        score,
                    };
                }
            }
        };
    let mut k = -reach;
    while k <= reach {
        if k != 0 {
            try_at(aligner, &mut best, seed.alpha + step(k));
        }
        k += stride;
    }
    while stride > 1 {
        stride /= 2;
        let centre = best.alpha;
        for k in [-stride, stride] {
            try_at(aligner, &mut best, centre + step(k));
        }
    }
    // A pose that moved has the best shift near the predicted one; its
    // rotation's best over the whole window may lie elsewhere (another
    // wall's match): searched above what it has, it is then the rotation's
    // best translation, as every seed's is.
    if best.alpha != seed.alpha {
        aligner.rotate::<N>(best.alpha, (0, 0));
        if let Some((shift, score)) = aligner.search((0, 0), max_shift, best.score) {
            best.shift = shift;
            best.score = score;
        }
    }
    Placement {
        score: peak.max(best.score),
        ..best
    }
}

/// The shift (reference cells `(Δcol, Δrow)`) of the translation `t` fitted
/// by the profile test for rotation α: `u = −R(−α)·t`.
pub(super) fn hint_shift<const N: usize>(alpha: Angle, t: &Pose) -> (i32, i32) {
    let (cos, sin) = sin_cos_q15::<N>(alpha);
    let (cos, sin) = (i64::from(cos), i64::from(sin));
    let (tx, ty) = (i64::from(t.x.to_bits()), i64::from(t.y.to_bits()));
    // R(−α)·t in Q31 → cells; u = −that; Δrow = −u_y.
    let ux = -(cos * tx + sin * ty) >> 31;
    let uy = -(cos * ty - sin * tx) >> 31;
    (ux as i32, -uy as i32)
}

/// The largest score that cannot make `best` ambiguous: `⌊best / ratio⌋`
/// (0 for a ratio ≤ 1, where every score counts).
pub(super) fn irrelevant_below(best: u32, ratio: Score) -> u32 {
    if ratio <= Score::ONE {
        return 0;
    }
    ((u64::from(best) << 16) / ratio.to_bits() as u64) as u32
}

/// `t = −s·R(α)·u` in pixels from the verified pose (`u` in centred Q8
/// cells, `s` in Q16), with the column fit's unobservable direction and
/// column count; along an unobservable direction `t` keeps no component.
pub(super) fn verified_translation<const N: usize>(
    alpha: Angle,
    u_q8: (i64, i64),
    scale_q16: u32,
    fit: Option<&Pose>,
) -> Pose {
    let (cos, sin) = sin_cos_q15::<N>(alpha);
    let (cos, sin) = (i64::from(cos), i64::from(sin));
    let s = i64::from(scale_q16);
    // Q8 × Q15 = Q23 → Q16: >> 7; then × s (Q16).
    let mut tx = ((-(cos * u_q8.0 - sin * u_q8.1) >> 7) * s) >> 16;
    let mut ty = ((-(sin * u_q8.0 + cos * u_q8.1) >> 7) * s) >> 16;
    let unobservable = fit.and_then(|f| f.unobservable);
    if let Some(u) = unobservable {
        (tx, ty) = without_component((tx, ty), u);
    }
    let clamp =
        |v: i64| I16F16::from_bits(v.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32);
    Pose {
        x: clamp(tx),
        y: clamp(ty),
        scale: I16F16::from_bits(scale_q16 as i32),
        residual: fit.map_or(I16F16::ZERO, |f| f.residual),
        columns: fit.map_or(0, |f| f.columns),
        unobservable,
    }
}
