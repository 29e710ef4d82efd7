//! Compile-time configuration: derived sizes and the paper's θ resolution rule.
//!
//! Stable Rust cannot compute array lengths from generic parameters, so every
//! size derived from the image size is an extra const generic parameter. The
//! functions here compute those values; the `estimator!`, `grid!` and
//! `reference!` macros fill them in, and the types check them at compile time
//! (a wrong value is a compile error whose message names the right function).
//!
//! The ground floor with `math`: it imports nothing else of
//! the crate.
//!
//! # The column votes check their sizes too
//!
//! The public [`stages::vote_column`](crate::stages::vote_column),
//! [`vote_column_split`](crate::stages::vote_column_split) and
//! [`vote_column_pair`](crate::stages::vote_column_pair) assert at compile
//! time that `RHO = rho_bins(W, H)` (their bin mask needs it). This compiles:
//!
//! ```
//! use hough_heading::{config::rho_bins, stages::vote_column_pair, Grid};
//! const RHO: usize = rho_bins(64, 64); // 128
//! let g = Grid::<64, 64, 2>::new();
//! let mut pair = [[0u16; RHO]; 2];
//! vote_column_pair::<64, 64, 2, 128, RHO>(&g, 0, &mut pair);
//! ```
//!
//! and each of these, the same call with another power of two for `RHO`
//! (which would put votes in the wrong bins), is a compile error:
//!
//! ```compile_fail,E0080
//! use hough_heading::{stages::vote_column_pair, Grid};
//! let g = Grid::<64, 64, 2>::new();
//! let mut pair = [[0u16; 256]; 2];
//! vote_column_pair::<64, 64, 2, 128, 256>(&g, 0, &mut pair);
//! ```
//!
//! ```compile_fail,E0080
//! use hough_heading::{stages::vote_column, Grid};
//! let g = Grid::<64, 64, 2>::new();
//! let mut a = [0u16; 64];
//! vote_column::<64, 64, 2, 128, 64>(&g, 0, &mut a);
//! ```
//!
//! ```compile_fail,E0080
//! use hough_heading::{stages::vote_column_split, Grid};
//! let g = Grid::<64, 64, 2>::new();
//! let mut a = [0u16; 256];
//! vote_column_split::<64, 64, 2, 128, 256>(&g, 0, 1 << 16, &mut a);
//! ```

use crate::math::{atan_f64, isqrt_ceil, TAU};

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

/// The paper's recommended range of θ steps over the full circle for a
/// `width × height` image (eqs. 4–5): `max(w, h) ≤ N_θ < 2π / θ_lim` with
/// `θ_lim = atan_f64(b / (b² + a(a − 1)))`, `a = max(w, h)`, `b = min(w, h)`.
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
    let theta_lim = atan_f64(b / (b * b + a * (a - 1.0)));
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

/// Largest number of votes any single bin can receive for a `width × height`
/// grid (a compile-time bound, checked against `u16`).
///
/// Proof: a bin is a strip of width 1 across the grid. If `|sin θ| ≥ 1/√2` each
/// of the `W` pixel columns meets the strip in an interval of length
/// `1/|sin θ| ≤ √2`, which holds at most 2 pixel centres; otherwise each of the
/// `H` pixel rows does. So a bin holds at most `2 · max(W, H)` votes, and never
/// more than `W · H`.
pub const fn max_votes_per_bin(width: usize, height: usize) -> usize {
    let side = if width > height { width } else { height };
    let strip = 2 * side;
    let all = width * height;
    if strip < all {
        strip
    } else {
        all
    }
}

/// Most occupied cells of image 2 scored per pose (taken evenly in raster
/// order when there are more); a `W × H` grid scores
/// [`align_points`]`(W, H)` of them.
pub const ALIGN_POINTS: usize = 128;

/// Cells of image 2 the search scores on a `w × h` grid: `max(w, h) / 2`
/// within 64 ..= [`ALIGN_POINTS`] (64 up to 128², 128 at 256²): about one
/// per two cells of a wall across the grid, and at least 64 (with 32 a
/// circle at 64² came out confident: one point is 3 % of the score).
pub const fn align_points(width: usize, height: usize) -> usize {
    let side = if width > height { width } else { height };
    let half = side / 2;
    if half < 64 {
        64
    } else if half > ALIGN_POINTS {
        ALIGN_POINTS
    } else {
        half
    }
}

/// Cells of image 2 the ICP matches on a `w × h` grid: four times
/// [`align_points`] (256 at 128², 512 at 256²).
pub const fn icp_points(width: usize, height: usize) -> usize {
    4 * align_points(width, height)
}

/// Pyramid levels above the grid: the smallest `L ≥ 1` with
/// `4 · 2ᴸ ≥ max(w, h)`, so the top level is at most 4 × 4 cells.
pub const fn pyramid_levels(width: usize, height: usize) -> usize {
    let side = if width > height { width } else { height };
    let mut levels = 1;
    while 4usize << levels < side {
        levels += 1;
    }
    levels
}

/// `u32` words of the pyramid levels `1..=pyramid_levels(w, h)` (the estimator's
/// `PW`): 188 words (752 B) at 128², 700 (2.7 KiB) at 256².
pub const fn pyramid_words(width: usize, height: usize) -> usize {
    let levels = pyramid_levels(width, height);
    let mut total = 0;
    let mut k = 1;
    while k <= levels {
        total += level_height(height, k) * level_row_words(width, k);
        k += 1;
    }
    total
}

/// Most pyramid levels (W, H ≤ 2048: `4 · 2⁹ ≥ 2048`).
pub(crate) const MAX_LEVELS: usize = 9;

/// Offset, height and row words of each level of a `w × h` pyramid.
pub(crate) const fn layout(width: usize, height: usize) -> [(usize, usize, usize); MAX_LEVELS + 1] {
    let mut out = [(0, 0, 0); MAX_LEVELS + 1];
    let levels = pyramid_levels(width, height);
    let mut offset = 0;
    let mut k = 1;
    while k <= levels && k <= MAX_LEVELS {
        let (h, rw) = (level_height(height, k), level_row_words(width, k));
        out[k] = (offset, h, rw);
        offset += h * rw;
        k += 1;
    }
    out
}

pub(crate) const fn level_width(width: usize, k: usize) -> usize {
    width.div_ceil(1 << k)
}

pub(crate) const fn level_height(height: usize, k: usize) -> usize {
    height.div_ceil(1 << k)
}

pub(crate) const fn level_row_words(width: usize, k: usize) -> usize {
    level_width(width, k).div_ceil(32)
}

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
        "HALF must equal hough_heading::config::half_turn_steps(N_THETA) = N_THETA / 2"
    );
    assert!(
        rho == rho_bins(width, height),
        "RHO must equal hough_heading::config::rho_bins(W, H)"
    );
    // Two-bin peaks (A[b] + A[b+1]) must fit the u16 signature.
    assert!(
        2 * max_votes_per_bin(width, height) <= u16::MAX as usize,
        "grid too large: two-bin vote counts would overflow u16"
    );
}

/// Compile-time checks of a grid's parameters.
pub(crate) const fn check_pyramid(width: usize, height: usize, pyramid_words_param: usize) {
    assert!(
        pyramid_words_param == pyramid_words(width, height),
        "PW must equal hough_heading::config::pyramid_words(W, H)"
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
        "ROW_WORDS must equal hough_heading::config::row_words(W) = W.div_ceil(32)"
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

    #[test]
    fn pyramid_sizes() {
        assert_eq!(pyramid_levels(128, 128), 5);
        assert_eq!(pyramid_words(128, 128), 188);
        assert_eq!(pyramid_levels(256, 256), 6);
        assert_eq!(pyramid_words(256, 256), 700);
    }
}
