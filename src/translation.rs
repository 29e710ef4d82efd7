//! Translation from the ρ shifts of a few accumulator columns.
//!
//! A translation `t` shifts the column at normal angle ψ by `t·(cos ψ, sin ψ)`
//! in ρ. Given the measured shift `s_j` of a few columns, `t` is the weighted
//! least-squares solution of `n_j · t = s_j`; the worst column is dropped once
//! if it disagrees by more than 2 px. When all normals are nearly parallel
//! (a corridor) the shift along the walls is unobservable: the fit keeps only
//! the observable component and reports the unobservable direction.

use fixed::types::I16F16;
use micromath::F32Ext;

/// The shift of one column, as measured by the profile match.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ColumnShift {
    /// Unit normal `(cos ψ, sin ψ)` of the column in image 2, Q15.
    pub normal_q15: (i32, i32),
    /// Shift `s` in pixels, Q16.
    pub shift_q16: i32,
    /// Weight (match score), Q16 in [0, 1].
    pub weight_q16: u32,
}

/// The rest of the pose after the rotation: translation `t` (pixels, in the
/// centred, y-up image frame) and scale `s`, such that a point `p` of image 1
/// appears in image 2 at `s·R(α)·p + t`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Translation {
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
    /// Columns kept in the fit (1 to [`PROFILE_COLUMNS`](crate::PROFILE_COLUMNS),
    /// after dropping an outlier). Only three or more can disagree: with
    /// one (or one direction) the translation is partly unobservable, with
    /// two a column locked on the wrong wall moves `t` unchecked.
    pub columns: u8,
    /// Unit vector along which `t` is not observable (all column normals are
    /// nearly perpendicular to it); `t` has no component along it.
    pub unobservable: Option<(I16F16, I16F16)>,
}

/// Ratio of the small to the large eigenvalue of `Σ w n nᵀ` below which one
/// direction counts as unobservable (normals within ~13° of each other).
const OBSERVABILITY: f32 = 0.05;
/// A column farther than this from the fit (pixels) is dropped once.
const OUTLIER_PX: f32 = 2.0;

/// Fits `t` to the column shifts; `None` with fewer than one usable column.
pub fn fit_translation(shifts: &[ColumnShift]) -> Option<Translation> {
    let mut keep = [true; 8];
    let mut fit = solve(shifts, &keep)?;
    if shifts.len() >= 4 {
        let worst = shifts
            .iter()
            .enumerate()
            .map(|(i, c)| (i, F32Ext::abs(residual_of(c, fit.0, fit.1))))
            .fold((0, 0.0f32), |a, b| if b.1 > a.1 { b } else { a });
        if worst.1 > OUTLIER_PX {
            if let Some(k) = keep.get_mut(worst.0) {
                *k = false;
            }
            fit = solve(shifts, &keep)?;
        }
    }
    let (x, y, unobservable) = fit;
    if !(x.is_finite() && y.is_finite()) {
        return None;
    }
    let (mut sum_w, mut sum_r2, mut columns) = (0.0f32, 0.0f32, 0u8);
    for (c, _) in shifts.iter().zip(keep).filter(|(_, k)| *k) {
        let w = weight(c);
        columns = columns.saturating_add(1);
        sum_w += w;
        sum_r2 += w * residual_of(c, x, y) * residual_of(c, x, y);
    }
    let residual = if sum_w > 0.0 {
        sqrt(sum_r2 / sum_w)
    } else {
        0.0
    };
    Some(Translation {
        x: to_fixed(x),
        y: to_fixed(y),
        scale: I16F16::ONE,
        residual: to_fixed(residual),
        columns,
        unobservable: unobservable.map(|(ux, uy)| (to_fixed(ux), to_fixed(uy))),
    })
}

impl Translation {
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

/// `√v` to f32 precision: `micromath`'s estimate (≈ 5 % error) refined by
/// two Newton steps (relative error squared each step). 0 for `v ≤ 0`.
fn sqrt(v: f32) -> f32 {
    if v.is_nan() || v <= 0.0 {
        return 0.0;
    }
    let mut r = F32Ext::sqrt(v);
    for _ in 0..2 {
        r = 0.5 * (r + v / r);
    }
    r
}

/// Q16.16 from `f32`, saturating; NaN → 0 (never panics).
fn to_fixed(v: f32) -> I16F16 {
    // `as` saturates and maps NaN to 0.
    I16F16::from_bits((v * 65536.0) as i32)
}

fn weight(c: &ColumnShift) -> f32 {
    c.weight_q16 as f32 / 65536.0
}

fn normal(c: &ColumnShift) -> (f32, f32) {
    (
        c.normal_q15.0 as f32 / 32768.0,
        c.normal_q15.1 as f32 / 32768.0,
    )
}

fn residual_of(c: &ColumnShift, x: f32, y: f32) -> f32 {
    let (nx, ny) = normal(c);
    nx * x + ny * y - c.shift_q16 as f32 / 65536.0
}

/// `t_x`, `t_y` (pixels) and the unobservable direction, if any.
type Fit = (f32, f32, Option<(f32, f32)>);

/// Weighted least squares over the kept columns; pseudo-inverse when one
/// direction is unobservable.
fn solve(shifts: &[ColumnShift], keep: &[bool; 8]) -> Option<Fit> {
    let (mut a, mut b, mut c, mut u, mut v) = (0.0f32, 0.0f32, 0.0f32, 0.0f32, 0.0f32);
    for (s, _) in shifts.iter().zip(keep).filter(|(_, k)| **k) {
        let w = weight(s);
        let (nx, ny) = normal(s);
        let shift = s.shift_q16 as f32 / 65536.0;
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
            shift_q16: (shift * 65536.0) as i32,
            weight_q16: 1 << 16,
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
