//! Binary angles: a fraction of a turn in a `u32`, counter-clockwise.

use fixed::types::I16F16;

/// An angle as a fraction of a full turn times 2³² (a "binary angle"),
/// counter-clockwise. Wraps naturally: `Angle(0)` is 0°, `Angle(1 << 31)` is
/// 180°. Resolution 2⁻³² turn ≈ 8.4e-8°.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Angle(pub u32);

impl Angle {
    /// 0°.
    pub const ZERO: Angle = Angle(0);
    /// 180°.
    pub const HALF_TURN: Angle = Angle(1 << 31);
    /// A quarter turn (90°).
    pub const QUARTER_TURN: Angle = Angle(1 << 30);

    /// `steps_q16 / 2¹⁶` steps of `2π / n` (`n > 0`); e.g. the θ step `k` of
    /// an `n`-step circle with a sub-step fraction.
    /// `n` must be in `1..=MAX_STEPS` and `|steps| < 2³⁰`; otherwise the
    /// result is `Angle::ZERO`.
    pub const fn from_steps_q16(steps_q16: i64, n: usize) -> Angle {
        if n == 0 || n > Self::MAX_STEPS || steps_q16 >= 1 << 46 || steps_q16 <= -(1 << 46) {
            return Angle::ZERO;
        }
        // turns · 2³² = steps · 2³² / n = steps_q16 · 2¹⁶ / n, within i64.
        Angle(((steps_q16 << 16) / n as i64) as u32)
    }

    /// Largest step count the step conversions accept (2²⁰).
    pub const MAX_STEPS: usize = 1 << 20;

    /// This angle in steps of `2π / n`, with 16 fraction bits, in `[0, n)`;
    /// 0 when `n > MAX_STEPS`.
    pub const fn to_steps_q16(self, n: usize) -> u64 {
        if n > Self::MAX_STEPS {
            return 0;
        }
        (self.0 as u64 * n as u64) >> 16
    }

    /// The nearest whole step of `2π / n`, in `[0, n)`.
    pub const fn nearest_step(self, n: usize) -> usize {
        if n == 0 || n > Self::MAX_STEPS {
            return 0;
        }
        ((self.to_steps_q16(n) + (1 << 15)) >> 16) as usize % n
    }

    /// Signed fraction of a turn times 2³², in `[−2³¹, 2³¹)`.
    pub const fn signed(self) -> i32 {
        self.0 as i32
    }

    /// Degrees in (−180°, 180°]. Error ≤ 1e-5° (f32 rounding).
    pub fn to_degrees(self) -> f32 {
        let s = self.signed();
        if s == i32::MIN {
            return 180.0;
        }
        (f64::from(s) * (360.0 / 4_294_967_296.0)) as f32
    }

    /// From degrees (any value, wrapped). Non-finite input gives 0°. A
    /// `const fn`: limits in degrees become angles at compile time.
    pub const fn from_degrees(degrees: f32) -> Angle {
        if !degrees.is_finite() {
            return Angle::ZERO;
        }
        let turns = degrees as f64 / 360.0;
        let frac = turns - floor(turns);
        Angle((frac * 4_294_967_296.0) as u64 as u32)
    }

    /// Radians in (−π, π] as a Q16.16 fixed-point number (error ≤ 2⁻¹⁶ rad).
    pub fn to_radians(self) -> I16F16 {
        const PI_Q29: i64 = 1_686_629_713; // round(π · 2²⁹)
        let s = i64::from(self.signed());
        let s = if s == i64::from(i32::MIN) { -s } else { s };
        // rad = s / 2³¹ · π, in Q16: s · π·2²⁹ / 2⁴⁴ (|product| < 2⁶²).
        I16F16::from_bits(((s * PI_Q29 + (1 << 43)) >> 44) as i32)
    }

    /// Absolute circular difference, in [0°, 180°].
    pub const fn distance(self, other: Angle) -> Angle {
        let d = self.0.wrapping_sub(other.0) as i32;
        Angle(d.unsigned_abs())
    }
}

/// `floor` without `std`: exact for |v| < 2⁵².
const fn floor(v: f64) -> f64 {
    let t = v as i64 as f64;
    if t > v {
        t - 1.0
    } else {
        t
    }
}

impl core::ops::Add for Angle {
    type Output = Angle;
    fn add(self, rhs: Angle) -> Angle {
        Angle(self.0.wrapping_add(rhs.0))
    }
}

impl core::ops::Sub for Angle {
    type Output = Angle;
    fn sub(self, rhs: Angle) -> Angle {
        Angle(self.0.wrapping_sub(rhs.0))
    }
}

impl core::ops::Neg for Angle {
    type Output = Angle;
    fn neg(self) -> Angle {
        Angle(self.0.wrapping_neg())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn degrees_round_trip_and_range() {
        for d in [0.0f32, 1.0, 45.0, 179.9, 180.0, -180.0, -90.0, 359.0, 725.0] {
            let a = Angle::from_degrees(d);
            let back = a.to_degrees();
            let expect = {
                let r = d.rem_euclid(360.0);
                if r > 180.0 {
                    r - 360.0
                } else {
                    r
                }
            };
            assert!((back - expect).abs() < 1e-4, "{d} → {back}");
            assert!(back > -180.0 && back <= 180.0);
        }
        assert_eq!(Angle::from_degrees(f32::NAN), Angle::ZERO);
    }

    /// In `const` context as at run time: exact binary angles for exact
    /// fractions of a turn, and `(d / 360) · 2³²` truncated for the rest
    /// (the old `limit_angle` of the beam module, which it replaces).
    #[test]
    fn from_degrees_is_const() {
        const QUARTER: Angle = Angle::from_degrees(90.0);
        const BACK: Angle = Angle::from_degrees(-90.0);
        const ONE: Angle = Angle::from_degrees(1.0);
        assert_eq!(QUARTER, Angle::QUARTER_TURN);
        assert_eq!(BACK, Angle(3 << 30));
        assert_eq!(ONE, Angle((4_294_967_296.0f64 / 360.0) as u32));
        assert_eq!(ONE, Angle::from_degrees(core::hint::black_box(1.0)));
        const NOT_FINITE: Angle = Angle::from_degrees(f32::INFINITY);
        assert_eq!(NOT_FINITE, Angle::ZERO);
    }

    #[test]
    fn steps_and_radians() {
        assert_eq!(Angle::from_steps_q16(90 << 16, 360), Angle(1 << 30));
        assert_eq!(Angle::from_steps_q16(-(90 << 16), 360), Angle(3 << 30));
        assert_eq!(Angle(1 << 30).nearest_step(360), 90);
        assert_eq!(Angle(u32::MAX).nearest_step(360), 0);
        let r = Angle::from_degrees(-90.0).to_radians().to_num::<f64>();
        assert!((r + core::f64::consts::FRAC_PI_2).abs() < 2e-5);
        assert!(
            (Angle::HALF_TURN.to_radians().to_num::<f64>() - core::f64::consts::PI).abs() < 2e-5
        );
        let d = Angle::from_degrees(350.0).distance(Angle::from_degrees(10.0));
        assert!(d.0.abs_diff(Angle::from_degrees(20.0).0) <= 2);
    }
}
