//! Translation from the ρ shifts of a few accumulator columns.
//!
//! A translation `t` shifts the column at normal angle ψ by `t·(cos ψ, sin ψ)`
//! in ρ. Given the measured shift `s_j` of a few columns, `t` is the weighted
//! least-squares solution of `n_j · t = s_j`. Where the shifts disagree (a
//! column locked onto the wrong one of parallel walls), the translation best
//! supported by the columns' best and runner-up shifts decides which shift
//! each column contributes. When all normals are nearly parallel
//! (a corridor) the shift along the walls is unobservable: the fit keeps only
//! the observable component and reports the unobservable direction.

use fixed::types::I16F16;
use micromath::F32Ext;

use crate::math::sqrt_f32 as sqrt;

use crate::profile::{Shift, RUNNERS_UP};

/// The shift of one column, as measured by the profile match.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ColumnShift {
    /// Unit normal `(cos ψ, sin ψ)` of the column in image 2, Q15.
    pub normal_q15: (i32, i32),
    /// The best shift `s` (pixels, Q16) and its weight (`score_q16`: match
    /// score times relative strength, Q16 in [0, 1]).
    pub best: Shift,
    /// The match's runner-up shifts, weighted like `best` (score 0: none):
    /// the fit may pick one where the best shifts disagree.
    pub runners_up: [Shift; RUNNERS_UP],
}

/// The rest of the pose after the rotation: translation `t` (pixels, in the
/// centred, y-up image frame) and scale `s`, such that a point `p` of image 1
/// appears in image 2 at `s·R(α)·p + t`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Pose {
    /// `t_x`, pixels.
    pub x: I16F16,
    /// `t_y`, pixels.
    pub y: I16F16,
    /// Scale `s`: exactly 1 unless the estimator searches a
    /// [`ScaleRange`](crate::ScaleRange).
    pub scale: I16F16,
    /// Weighted RMS of `n_j · t − s_j` over the columns kept, pixels of
    /// image 2: how well the columns agree. With two columns `t` is exactly
    /// determined and the residual is 0 whatever the shifts: see
    /// [`columns`](Self::columns).
    pub residual: I16F16,
    /// Columns kept in the fit (1 to [`PROFILE_COLUMNS`](crate::stages::PROFILE_COLUMNS)
    /// from the estimator; a column none of whose shifts lies within 2 px of
    /// the best-supported translation is dropped). Only three or more can
    /// disagree: with one (or one direction) the translation is partly
    /// unobservable, with two a column locked on the wrong one of parallel
    /// walls moves `t` unchecked (real scan pairs: 14.7 % more than 0.3 m
    /// off with two columns, 3.2 % with three or more; README).
    pub columns: u8,
    /// Unit vector along which `t` is not observable (all column normals are
    /// nearly perpendicular to it); `t` has no component along it.
    pub unobservable: Option<(I16F16, I16F16)>,
}

/// Ratio of the small to the large eigenvalue of `Σ w n nᵀ` below which one
/// direction counts as unobservable (normals within ~13° of each other).
const OBSERVABILITY: f32 = 0.05;
/// A shift farther than this from a translation's prediction (pixels) does
/// not support it.
const OUTLIER_PX: f32 = 2.0;
/// At most this many columns take part in the fit (the estimator gives
/// [`PROFILE_COLUMNS`](crate::stages::PROFILE_COLUMNS)); later ones are ignored.
pub const MAX_FIT_COLUMNS: usize = 8;

/// Which of a column's shifts the fit uses: its best (0), a runner-up
/// (1 + index), or none ([`DROPPED`]).
type Choice = u8;

/// The column takes no part in the fit.
const DROPPED: Choice = u8::MAX;

/// Fits `t` to the column shifts; `None` without a usable column. Only the
/// first [`MAX_FIT_COLUMNS`] shifts are used.
///
/// When the best shifts agree (each within 2 px of their least-squares fit)
/// they are the answer. Otherwise a column may have locked onto the wrong
/// one of repeated walls: every translation that two non-parallel columns'
/// candidate shifts (best or runner-up, at least one a best) determine —
/// or, when all normals are nearly parallel, one column's candidate — is
/// scored by the summed weight of the columns with a candidate within 2 px
/// of its prediction, and the best-supported one picks each column's shift
/// (or drops the column) for the final least-squares fit.
pub fn fit_translation(shifts: &[ColumnShift]) -> Option<Pose> {
    fit(shifts, CANDIDATES)
}

/// [`fit_translation`] on the best shifts alone (runners-up ignored): the
/// scale search scores every scale with it, where weighing the runners-up
/// would cost FPU-less targets dearly at scales whose columns disagree anyway.
pub(crate) fn fit_best_shifts(shifts: &[ColumnShift]) -> Option<Pose> {
    fit(shifts, 1)
}

/// The fit over each column's first `candidates` shifts (1: the best only).
#[inline(never)]
fn fit(shifts: &[ColumnShift], candidates: Choice) -> Option<Pose> {
    let shifts = shifts.get(..MAX_FIT_COLUMNS).unwrap_or(shifts);
    let mut choices: [Choice; MAX_FIT_COLUMNS] = [0; MAX_FIT_COLUMNS];
    let mut fit = solve(shifts, &choices)?;
    let agree = shifts
        .iter()
        .zip(choices)
        .all(|(c, k)| residual_of(c, k, fit.0, fit.1).is_none_or(|r| F32Ext::abs(r) <= OUTLIER_PX));
    if !agree {
        if let Some((x, y)) = consensus(shifts, candidates) {
            for (choice, c) in choices.iter_mut().zip(shifts) {
                *choice = supporting(c, x, y, candidates).map_or(DROPPED, |(k, _)| k);
            }
            fit = solve(shifts, &choices)?;
        }
    }
    let (x, y, unobservable) = fit;
    if !(x.is_finite() && y.is_finite()) {
        return None;
    }
    let (mut sum_w, mut sum_r2, mut columns) = (0.0f32, 0.0f32, 0u8);
    for (c, k) in shifts.iter().zip(choices) {
        if let (Some((_, w)), Some(r)) = (candidate(c, k), residual_of(c, k, x, y)) {
            sum_w += w;
            sum_r2 += w * r * r;
            columns = columns.saturating_add(1);
        }
    }
    let residual = if sum_w > 0.0 {
        sqrt(sum_r2 / sum_w)
    } else {
        0.0
    };
    Some(Pose {
        x: to_fixed(x),
        y: to_fixed(y),
        scale: I16F16::ONE,
        residual: to_fixed(residual),
        columns,
        unobservable: unobservable.map(|(ux, uy)| (to_fixed(ux), to_fixed(uy))),
    })
}

impl Pose {
    /// The ρ shift `n·t` (Q16 pixels) this translation gives a column with
    /// unit normal `n` (Q15), saturated to `i32`.
    pub fn column_shift_q16(&self, normal_q15: (i32, i32)) -> i32 {
        let dot = i64::from(normal_q15.0) * i64::from(self.x.to_bits())
            + i64::from(normal_q15.1) * i64::from(self.y.to_bits());
        (dot >> 15).clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
    }

    /// The pose for column shifts measured on columns re-voted at `ρ / s`
    /// (which measure `n·t / s`): `t` and the residual times `s`, and `s`.
    pub(crate) fn scaled(self, scale_q16: u32) -> Self {
        let s = I16F16::from_bits(scale_q16.min(i32::MAX as u32) as i32);
        Self {
            x: self.x.saturating_mul(s),
            y: self.y.saturating_mul(s),
            scale: s,
            residual: self.residual.saturating_mul(s),
            columns: self.columns,
            unobservable: self.unobservable,
        }
    }
}

/// Q16.16 from `f32`, saturating; NaN → 0 (never panics).
fn to_fixed(v: f32) -> I16F16 {
    // `as` saturates and maps NaN to 0.
    I16F16::from_bits((v * 65536.0) as i32)
}

/// Candidates a column offers: its best shift, then its runners-up.
const CANDIDATES: Choice = 1 + RUNNERS_UP as Choice;

/// Shift (pixels) and weight of candidate `choice` of column `c`; `None`
/// when dropped, absent or of zero weight.
fn candidate(c: &ColumnShift, choice: Choice) -> Option<(f32, f32)> {
    let (shift_q16, weight_q16) = match choice {
        0 => (c.best.shift_q16, c.best.score_q16),
        k => {
            let r = c.runners_up.get(usize::from(k).checked_sub(1)?)?;
            (r.shift_q16, r.score_q16)
        }
    };
    (weight_q16 > 0).then(|| (shift_q16 as f32 / 65536.0, weight_q16 as f32 / 65536.0))
}

fn normal(c: &ColumnShift) -> (f32, f32) {
    (
        c.normal_q15.0 as f32 / 32768.0,
        c.normal_q15.1 as f32 / 32768.0,
    )
}

/// `n · t − s` for the chosen candidate of `c`.
fn residual_of(c: &ColumnShift, choice: Choice, x: f32, y: f32) -> Option<f32> {
    let (shift, _) = candidate(c, choice)?;
    let (nx, ny) = normal(c);
    Some(nx * x + ny * y - shift)
}

/// Among the first `candidates` of `c`, the one within [`OUTLIER_PX`] of
/// `t`'s prediction with the largest weight, and that weight.
fn supporting(c: &ColumnShift, x: f32, y: f32, candidates: Choice) -> Option<(Choice, f32)> {
    (0..candidates)
        .filter_map(|k| {
            let (_, w) = candidate(c, k)?;
            let r = residual_of(c, k, x, y)?;
            (F32Ext::abs(r) <= OUTLIER_PX).then_some((k, w))
        })
        .fold(None, |best: Option<(Choice, f32)>, (k, w)| match best {
            Some((_, bw)) if bw >= w => best,
            _ => Some((k, w)),
        })
}

/// The best-supported translation among those two non-parallel columns'
/// candidates determine (at least one of them a best shift), or, with no
/// such pair, those one column's candidate determines (its shift along the
/// normal). Not inlined: its frame is only on the stack while it runs.
#[inline(never)]
fn consensus(shifts: &[ColumnShift], candidates: Choice) -> Option<(f32, f32)> {
    let mut best: Option<(f32, f32, f32)> = None;
    let mut consider = |x: f32, y: f32| {
        if !(x.is_finite() && y.is_finite()) {
            return;
        }
        let support: f32 = shifts
            .iter()
            .filter_map(|c| supporting(c, x, y, candidates))
            .map(|(_, w)| w)
            .sum();
        if best.is_none_or(|b| support > b.0) {
            best = Some((support, x, y));
        }
    };
    let mut pairs = false;
    for (i, a) in shifts.iter().enumerate() {
        let (ax, ay) = normal(a);
        for b in shifts.iter().skip(i + 1) {
            let (bx, by) = normal(b);
            let det = ax * by - ay * bx;
            if F32Ext::abs(det) < MIN_PAIR_SINE {
                continue;
            }
            pairs = true;
            for ka in 0..candidates {
                for kb in (0..candidates).filter(|&kb| ka == 0 || kb == 0) {
                    if let (Some((sa, _)), Some((sb, _))) = (candidate(a, ka), candidate(b, kb)) {
                        consider((sa * by - ay * sb) / det, (ax * sb - sa * bx) / det);
                    }
                }
            }
        }
    }
    if !pairs {
        for c in shifts {
            let (nx, ny) = normal(c);
            for k in 0..candidates {
                if let Some((shift, _)) = candidate(c, k) {
                    consider(shift * nx, shift * ny);
                }
            }
        }
    }
    best.map(|(_, x, y)| (x, y))
}

/// Two columns determine a translation when their normals are at least
/// ~20° apart (sine of the angle between them).
const MIN_PAIR_SINE: f32 = 0.34;

/// `t_x`, `t_y` (pixels) and the unobservable direction, if any.
type Fit = (f32, f32, Option<(f32, f32)>);

/// Weighted least squares over the chosen candidates; pseudo-inverse when
/// one direction is unobservable.
fn solve(shifts: &[ColumnShift], choices: &[Choice; MAX_FIT_COLUMNS]) -> Option<Fit> {
    let (mut a, mut b, mut c, mut u, mut v) = (0.0f32, 0.0f32, 0.0f32, 0.0f32, 0.0f32);
    for (s, &k) in shifts.iter().zip(choices) {
        let Some((shift, w)) = candidate(s, k) else {
            continue;
        };
        let (nx, ny) = normal(s);
        a += w * nx * nx;
        b += w * nx * ny;
        c += w * ny * ny;
        u += w * nx * shift;
        v += w * ny * shift;
    }
    // Eigen-decomposition of the symmetric [[a, b], [b, c]].
    let mean = 0.5 * (a + c);
    let spread = sqrt(0.25 * (a - c) * (a - c) + b * b);
    let (large, small) = (mean + spread, mean - spread);
    if large.is_nan() || large <= 1e-6 {
        return None;
    }
    // Eigenvector of the large eigenvalue.
    let (ex, ey) = if F32Ext::abs(b) > 1e-9 {
        unit(large - c, b)
    } else if a >= c {
        (1.0, 0.0)
    } else {
        (0.0, 1.0)
    };
    if small < OBSERVABILITY * large {
        // Only the component along (ex, ey) is observable.
        let along = (ex * u + ey * v) / large;
        return Some((along * ex, along * ey, Some((-ey, ex))));
    }
    let det = a * c - b * b;
    Some(((c * u - b * v) / det, (a * v - b * u) / det, None))
}

fn unit(x: f32, y: f32) -> (f32, f32) {
    let n = sqrt(x * x + y * y);
    if n > 0.0 {
        (x / n, y / n)
    } else {
        (1.0, 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn column(deg: f32, t: (f32, f32), noise: f32) -> ColumnShift {
        let (s, c) = deg.to_radians().sin_cos();
        let shift = c * t.0 + s * t.1 + noise;
        ColumnShift {
            normal_q15: ((c * 32768.0) as i32, (s * 32768.0) as i32),
            best: Shift {
                shift_q16: (shift * 65536.0) as i32,
                score_q16: 1 << 16,
            },
            runners_up: [Shift::default(); RUNNERS_UP],
        }
    }

    /// `column` whose best shift is `wrong` pixels off, with the right shift
    /// as its runner-up of weight ¾.
    fn locked_on_wrong_wall(deg: f32, t: (f32, f32), wrong: f32) -> ColumnShift {
        let right = column(deg, t, 0.0);
        ColumnShift {
            runners_up: [
                Shift {
                    shift_q16: right.best.shift_q16,
                    score_q16: 3 << 14,
                },
                Shift::default(),
            ],
            ..column(deg, t, wrong)
        }
    }

    #[test]
    fn recovers_translation_and_drops_an_outlier() {
        let t = (3.25, -1.5);
        let cols = [
            column(0.0, t, 0.0),
            column(90.0, t, 0.0),
            column(45.0, t, 0.0),
            column(130.0, t, 9.0),
        ];
        let fit = fit_translation(&cols).unwrap();
        assert!((fit.x.to_num::<f32>() - 3.25).abs() < 0.01);
        assert!((fit.y.to_num::<f32>() + 1.5).abs() < 0.01);
        assert!(fit.unobservable.is_none());
        assert_eq!(fit.columns, 3);
    }

    #[test]
    fn agreeing_columns_keep_their_best_shifts() {
        let t = (-4.0, 2.5);
        let cols = [
            column(10.0, t, 0.3),
            column(100.0, t, -0.2),
            column(55.0, t, 0.1),
        ];
        let fit = fit_translation(&cols).unwrap();
        assert_eq!(fit.columns, 3);
        assert!(
            fit.residual > 0,
            "three columns with noise disagree a little"
        );
        assert!((fit.x.to_num::<f32>() + 4.0).abs() < 0.5);
        assert!((fit.y.to_num::<f32>() - 2.5).abs() < 0.5);
    }

    #[test]
    fn a_column_locked_on_the_wrong_wall_takes_its_runner_up() {
        // Three columns, one 12 px off (a parallel wall): least squares over
        // the best shifts would be ~4 px off; the runner-up agrees with the
        // other two.
        let t = (6.0, -3.0);
        let cols = [
            column(0.0, t, 0.0),
            column(90.0, t, 0.0),
            locked_on_wrong_wall(45.0, t, 12.0),
        ];
        let fit = fit_translation(&cols).unwrap();
        assert_eq!(fit.columns, 3);
        assert!((fit.x.to_num::<f32>() - 6.0).abs() < 0.01, "{fit:?}");
        assert!((fit.y.to_num::<f32>() + 3.0).abs() < 0.01, "{fit:?}");
        assert!(fit.residual < I16F16::from_num(0.01));
    }

    #[test]
    fn two_columns_fit_exactly_and_say_so() {
        let cols = [column(0.0, (1.0, 2.0), 5.0), column(90.0, (1.0, 2.0), 0.0)];
        let fit = fit_translation(&cols).unwrap();
        assert_eq!(fit.columns, 2);
        assert_eq!(fit.residual, 0);
        assert!((fit.x.to_num::<f32>() - 6.0).abs() < 0.01);
    }

    #[test]
    fn corridor_reports_the_unobservable_direction() {
        let t = (2.0, 5.0);
        let cols = [
            column(90.0, t, 0.0),
            column(92.0, t, 0.0),
            column(88.0, t, 0.0),
        ];
        let fit = fit_translation(&cols).unwrap();
        let (ux, uy) = fit.unobservable.unwrap();
        assert!(ux.to_num::<f32>().abs() > 0.99 && uy.to_num::<f32>().abs() < 0.1);
        assert!((fit.y.to_num::<f32>() - 5.0).abs() < 0.2);
    }
}
