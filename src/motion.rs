//! The estimate → the robot's motion between two scans.
//!
//! Let the robot pose at scan 2, expressed in the robot frame at scan 1, be
//! `(dx, dy, dθ)` (the convention of the scan-pair files): a point seen at
//! `p₂` in frame 2 is at `p₁ = R(dθ)·p₂ + d` in frame 1. Hence
//! `p₂ = R(−dθ)·(p₁ − d)`, and the estimator run on `raster(scan 1)`,
//! `raster(scan 2)` (which finds `p₂ = R(α)·p₁ + t`) returns
//! `α = −dθ` and `t = −R(α)·d / cell` pixels, i.e. `d = −R(dθ)·t·cell`.
//! [`Raster::motion`] does this conversion.

use crate::angle::Angle;
use crate::math::sin_cos_f32 as sin_cos;
use crate::pose::Pose;
use crate::scan::Raster;

impl Raster {
    /// The robot's motion between the two scans from an estimate on their
    /// grids (see the module docs): `dθ = −α` in (−π, π], and, given the
    /// estimate's translation `t` (pixels), `d = −R(dθ)·t·cell` metres, in
    /// the robot frame at scan 1 — directly comparable with the scan-pair
    /// files' `dx`, `dy`, `dtheta`. The translation's scale is not used: two
    /// scans of one sensor have `s = 1` (leave the scale search off).
    pub fn motion(&self, alpha: Angle, translation: Option<&Pose>) -> Motion {
        let dtheta = angle_radians(-alpha);
        let d = translation.and_then(|t| {
            let (tx, ty) = (
                t.x.to_num::<f32>() * self.cell(),
                t.y.to_num::<f32>() * self.cell(),
            );
            let (s, c) = sin_cos(dtheta)?;
            Some((-(c * tx - s * ty), -(s * tx + c * ty)))
        });
        Motion {
            dtheta,
            translation: d,
        }
    }
}

/// The robot's motion between two scans: its pose at scan 2 in the robot
/// frame at scan 1 (the scan-pair files' convention).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Motion {
    /// Heading change, radians in (−π, π], positive for a left turn.
    pub dtheta: f32,
    /// `(dx, dy)` in metres, when the estimate has a translation.
    pub translation: Option<(f32, f32)>,
}

/// `α` in radians in (−π, π], to f32 precision.
fn angle_radians(alpha: Angle) -> f32 {
    let s = alpha.signed();
    if s == i32::MIN {
        return core::f32::consts::PI;
    }
    (f64::from(s) * (core::f64::consts::PI / 2_147_483_648.0)) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn motion_inverts_the_scene_transform() {
        // Robot turned left 30° and moved (1, 0.5) m; cell 0.1 m.
        let dtheta = 30f32.to_radians();
        let d = (1.0f32, 0.5f32);
        // t = −R(α)·d / cell with α = −dθ.
        let (s, c) = (-dtheta).sin_cos();
        let t = (-(c * d.0 - s * d.1) / 0.1, -(s * d.0 + c * d.1) / 0.1);
        let translation = Pose {
            x: fixed::types::I16F16::from_num(t.0),
            y: fixed::types::I16F16::from_num(t.1),
            scale: fixed::types::I16F16::ONE,
            residual: fixed::types::I16F16::ZERO,
            columns: 2,
            unobservable: None,
        };
        let raster = Raster::with_cell(0.1).unwrap();
        let m = raster.motion(Angle::from_degrees(-30.0), Some(&translation));
        assert!((m.dtheta - dtheta).abs() < 1e-5);
        let (dx, dy) = m.translation.unwrap();
        assert!(
            (dx - d.0).abs() < 1e-3 && (dy - d.1).abs() < 1e-3,
            "{dx} {dy}"
        );
        assert_eq!(raster.motion(Angle::HALF_TURN, None).translation, None);
        assert!(
            (raster.motion(Angle::HALF_TURN, None).dtheta - core::f32::consts::PI).abs() < 1e-6
        );
    }
}
