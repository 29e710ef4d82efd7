//! [`HeadingCorrection`]: a loop closure's heading error spread over the
//! keyframes since the last anchor, for a robot without a host.
//!
//! The chain from the anchor (the first scan, or the last closure) to the
//! keyframe that closes a loop is a line of steps, each with a heading
//! variance; the closure measures the last keyframe's heading with its own
//! variance. The least-squares headings of that line with one closure move
//! each keyframe by the closure's error times its share of the variance
//! accumulated from the anchor: `cᵢ = e · Vᵢ / (V_n + v_closure)`, with `Vᵢ`
//! the chain's variance at keyframe `i` above the anchor's. The anchor does
//! not move; the last keyframe moves by nearly the whole error when the
//! closure is far more certain than the chain.

use heapless::Vec;

use crate::angle::Angle;

/// Keyframes a [`HeadingCorrection`] can hold by default (256 B of
/// variances).
pub const MAX_CORRECTED_KEYFRAMES: usize = 64;

/// The keyframes since the last anchor, by their chain heading variance
/// (degrees², as [`Step::heading_sigma_deg`](super::Step::heading_sigma_deg)
/// squared). `N` keyframes at most: 4·N + 8 bytes.
#[derive(Clone, Debug, PartialEq)]
pub struct HeadingCorrection<const N: usize = MAX_CORRECTED_KEYFRAMES> {
    anchor_variance: f32,
    variances: Vec<f32, N>,
}

impl<const N: usize> Default for HeadingCorrection<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> HeadingCorrection<N> {
    /// No keyframe yet; the anchor's variance 0 (the first scan).
    pub const fn new() -> Self {
        Self {
            anchor_variance: 0.0,
            variances: Vec::new(),
        }
    }

    /// A new anchor of heading σ `sigma_deg` (degrees): the keyframes held
    /// so far are forgotten. Call it after a closure has been applied.
    pub fn anchor(&mut self, sigma_deg: f32) {
        self.anchor_variance = variance(sigma_deg);
        self.variances.clear();
    }

    /// Adds a keyframe of chain heading σ `sigma_deg`. `false` when `N` are
    /// held already: the keyframe is not added (anchor on it, or give the
    /// correction a larger `N`).
    pub fn push(&mut self, sigma_deg: f32) -> bool {
        self.variances.push(variance(sigma_deg)).is_ok()
    }

    /// Keyframes held, in the order they were pushed.
    pub fn len(&self) -> usize {
        self.variances.len()
    }

    /// No keyframe held.
    pub fn is_empty(&self) -> bool {
        self.variances.is_empty()
    }

    /// The heading correction of each held keyframe, in order, for a closure
    /// that finds the last one's heading off by `error` (the closure's
    /// heading minus the chain's; add the correction to the chain's
    /// heading) with σ `closure_sigma_deg`. Corrections grow with each
    /// keyframe's share of the variance and never exceed `error`; a chain
    /// without variance above its anchor gets none.
    pub fn spread(&self, error: Angle, closure_sigma_deg: f32) -> impl Iterator<Item = Angle> + '_ {
        let last = self.variances.last().map_or(0.0, |v| self.above(*v));
        let total = last + variance(closure_sigma_deg);
        let error = error.signed() as f32;
        self.variances.iter().map(move |v| {
            if total > 0.0 {
                let share = (self.above(*v) / total).clamp(0.0, 1.0);
                Angle((error * share) as i32 as u32)
            } else {
                Angle::ZERO
            }
        })
    }

    fn above(&self, v: f32) -> f32 {
        (v - self.anchor_variance).max(0.0)
    }
}

/// σ² of a σ in degrees; non-finite or negative σ count as 0.
fn variance(sigma_deg: f32) -> f32 {
    if sigma_deg.is_finite() && sigma_deg > 0.0 {
        sigma_deg * sigma_deg
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_error_spreads_by_variance_share() {
        // Four keyframes each 1° σ above the anchor: variances 1, 2, 3, 4.
        let mut c: HeadingCorrection<8> = HeadingCorrection::new();
        for k in 1..=4 {
            assert!(c.push((k as f32).sqrt()));
        }
        let error = Angle::from_degrees(8.0);
        // A closure of σ 0: shares 1/4, 2/4, 3/4, 4/4.
        let spread: heapless::Vec<f32, 8> = c.spread(error, 0.0).map(|a| a.to_degrees()).collect();
        for (got, want) in spread.iter().zip([2.0, 4.0, 6.0, 8.0]) {
            assert!((got - want).abs() < 1e-3, "{got} vs {want}");
        }
        // A closure of σ 2 (variance 4): shares over 8.
        let spread: heapless::Vec<f32, 8> = c.spread(error, 2.0).map(|a| a.to_degrees()).collect();
        for (got, want) in spread.iter().zip([1.0, 2.0, 3.0, 4.0]) {
            assert!((got - want).abs() < 1e-3, "{got} vs {want}");
        }
        // Against the least-squares solution of the line with one closure
        // (f64 reference): the headings h_i = d_i + c_i minimise
        // Σ (c_i − c_{i−1})² / v_i + (c_4 − e)² / v_closure; for unit step
        // variances and a closure variance of 4 the solution is c_i = e·i/8.
        let e = -8.0f64;
        let got: heapless::Vec<f32, 8> = c
            .spread(Angle::from_degrees(e as f32), 2.0)
            .map(|a| a.to_degrees())
            .collect();
        for (i, g) in got.iter().enumerate() {
            assert!((f64::from(*g) - e * (i + 1) as f64 / 8.0).abs() < 1e-3);
        }
    }

    #[test]
    fn anchoring_forgets_and_a_full_correction_refuses() {
        let mut c: HeadingCorrection<2> = HeadingCorrection::new();
        assert!(c.push(1.0) && c.push(2.0));
        assert!(!c.push(3.0), "full");
        assert_eq!(c.len(), 2);
        c.anchor(2.0);
        assert!(c.is_empty());
        // A keyframe no more uncertain than the anchor gets no correction.
        assert!(c.push(2.0));
        assert_eq!(
            c.spread(Angle::from_degrees(10.0), 0.0).next(),
            Some(Angle::ZERO)
        );
        // Non-finite σ counts as 0.
        c.anchor(f32::NAN);
        assert!(c.push(f32::INFINITY));
        assert_eq!(
            c.spread(Angle::from_degrees(10.0), 0.0).next(),
            Some(Angle::ZERO)
        );
    }
}
