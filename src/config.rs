//! Compile-time configuration: derived sizes and the paper's θ resolution rule.
//!
//! Stable Rust cannot compute array lengths from generic parameters, so every
//! size derived from the image size is an extra const generic parameter. The
//! functions here compute those values; the `estimator!`, `grid!` and
//! `reference!` macros fill them in, and the types check them at compile time
//! (a wrong value is a compile error whose message names the right function).

/// Number of `u32` words per grid row: `ceil(width / 32)`.
pub const fn row_words(width: usize) -> usize {
    width.div_ceil(32)
}

/// Half of the θ steps: the number of voted columns, θ ∈ [0, π).
pub const fn half_turn_steps(n_theta: usize) -> usize {
    n_theta / 2
}

/// Number of ρ bins (1 pixel wide) of one accumulator column for a
/// `width × height` image: the smallest power of two that holds every
/// `|ρ| ≤ d/2 + 1` with the origin at the image centre (DESIGN.md §2), plus the
/// unused bin 0 that makes the column its own mirror (`b ↔ RHO − b`).
///
/// 64² → 128, 128² → 256, 256² → 512.
pub const fn rho_bins(width: usize, height: usize) -> usize {
    let w = if width == 0 { 0 } else { width - 1 };
    let h = if height == 0 { 0 } else { height - 1 };
    // Twice the half diagonal, rounded up: sqrt((W−1)² + (H−1)²).
    let diagonal = isqrt_ceil((w * w + h * h) as u64) as usize;
    // Largest |bin offset| is floor(d/2 + 0.5 + rounding slack) ≤ d/2 + 1.
    let half = diagonal / 2 + 2;
    (2 * (half + 1)).next_power_of_two()
}

const fn isqrt_ceil(v: u64) -> u64 {
    let r = v.isqrt();
    if r * r == v {
        r
    } else {
        r + 1
    }
}

/// The paper's recommended range of θ steps over the full circle for a
/// `width × height` image (eqs. 4–5): `max(w, h) ≤ N_θ < 2π / θ_lim` with
/// `θ_lim = atan(b / (b² + a(a − 1)))`, `a = max(w, h)`, `b = min(w, h)`.
///
/// Returns `(min, max_exclusive)`. Finer steps than `max_exclusive` cannot add
/// accuracy. 64² → (64, 800), 128² → (128, 1602), 256² → (256, 3209).
pub const fn recommended_n_theta(width: usize, height: usize) -> (usize, usize) {
    let a = if width > height { width } else { height };
    let b = if width > height { height } else { width };
    if b == 0 {
        return (a, a + 1);
    }
    let (a, b) = (a as f64, b as f64);
    let theta_lim = atan(b / (b * b + a * (a - 1.0)));
    let max = TAU / theta_lim;
    // ceil(max): the range is half-open.
    let max_int = max as usize;
    let max_exclusive = if (max_int as f64) < max {
        max_int + 1
    } else {
        max_int
    };
    (a as usize, max_exclusive)
}

pub(crate) const PI: f64 = core::f64::consts::PI;
pub(crate) const TAU: f64 = 2.0 * PI;

/// `atan(x)` for `x ≥ 0` in const context: two argument halvings
/// (`atan x = 2 atan(x / (1 + sqrt(1 + x²)))`) then a Taylor series; error
/// below 1e-15 for `x ≤ 1`.
const fn atan(x: f64) -> f64 {
    let x1 = x / (1.0 + sqrt(1.0 + x * x));
    let x2 = x1 / (1.0 + sqrt(1.0 + x1 * x1));
    // |x2| ≤ tan(π/16) ≈ 0.199: 20 terms reach f64 precision.
    let x2sq = x2 * x2;
    let mut term = x2;
    let mut sum = 0.0;
    let mut k = 0;
    while k < 20 {
        sum += term / (2 * k + 1) as f64;
        term *= -x2sq;
        k += 1;
    }
    4.0 * sum
}

/// `sqrt(v)` for `v ≥ 0` in const context by Newton iteration.
const fn sqrt(v: f64) -> f64 {
    if v <= 0.0 {
        return 0.0;
    }
    let mut r = if v > 1.0 { v } else { 1.0 };
    let mut i = 0;
    while i < 64 {
        r = 0.5 * (r + v / r);
        i += 1;
    }
    r
}

/// Compile-time checks of one estimator configuration. Each failed check is a
/// compile error naming the parameter to fix.
pub(crate) const fn check_config(
    width: usize,
    height: usize,
    row_words_param: usize,
    n_theta: usize,
    half: usize,
    rho: usize,
) {
    check_grid(width, height, row_words_param);
    assert!(
        n_theta >= 8 && n_theta % 2 == 0,
        "N_THETA must be even and at least 8"
    );
    assert!(n_theta <= 4096, "N_THETA must be at most 4096");
    assert!(
        half == half_turn_steps(n_theta),
        "HALF must equal hough_heading::half_turn_steps(N_THETA) = N_THETA / 2"
    );
    assert!(
        rho == rho_bins(width, height),
        "RHO must equal hough_heading::rho_bins(W, H)"
    );
    // Two-bin peaks (A[b] + A[b+1]) must fit the u16 signature.
    assert!(
        2 * crate::accumulator::max_votes_per_bin(width, height) <= u16::MAX as usize,
        "grid too large: two-bin vote counts would overflow u16"
    );
}

/// Compile-time checks of a grid's parameters.
pub(crate) const fn check_pyramid(width: usize, height: usize, pyramid_words: usize) {
    assert!(
        pyramid_words == crate::align::pyramid_words(width, height),
        "PW must equal hough_heading::pyramid_words(W, H)"
    );
}

pub(crate) const fn check_grid(width: usize, height: usize, row_words_param: usize) {
    assert!(width >= 2 && height >= 2, "W and H must be at least 2");
    assert!(
        width <= 2048 && height <= 2048,
        "W and H must be at most 2048"
    );
    assert!(
        row_words_param == row_words(width),
        "ROW_WORDS must equal hough_heading::row_words(W) = W.div_ceil(32)"
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rho_bins_cover_the_half_diagonal() {
        assert_eq!(rho_bins(64, 64), 128);
        assert_eq!(rho_bins(128, 128), 256);
        assert_eq!(rho_bins(256, 256), 512);
        // Every |ρ| ≤ d/2 must land in bins 1..RHO−1 with slack for rounding.
        for (w, h) in [(2usize, 2usize), (17, 5), (96, 64), (300, 7)] {
            let half_diag = (((w - 1) * (w - 1) + (h - 1) * (h - 1)) as f64).sqrt() / 2.0;
            let center = rho_bins(w, h) / 2;
            assert!(half_diag + 1.5 < center as f64, "{w}x{h}");
        }
    }

    #[test]
    fn recommended_range_matches_the_paper() {
        for (w, h) in [(64usize, 64usize), (128, 128), (256, 256), (160, 90)] {
            let a = w.max(h) as f64;
            let b = w.min(h) as f64;
            let lim = (b / (b * b + a * (a - 1.0))).atan();
            let expect = (core::f64::consts::TAU / lim).ceil() as usize;
            assert_eq!(recommended_n_theta(w, h), (w.max(h), expect), "{w}x{h}");
        }
    }
}
