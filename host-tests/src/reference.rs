//! Float (`f64`) reference implementation of the paper, written straight from
//! its equations and sharing no code with the library.
//!
//! Conventions (DESIGN.md §2):
//!
//! - Pixel `(col, row)` of a `W × H` image has coordinates
//!   `x = col − (W−1)/2`, `y = (H−1)/2 − row` (origin at the image centre,
//!   y up, units of pixels).
//! - `θ_k = 2πk/N` for `k ∈ [0, N)`, `N = n_theta`; one θ step is `2π/N`.
//! - ρ bins have width 1 and are indexed by the integer `b = ⌊ρ + ½⌋`
//!   (round half up), over `[−R, R]` with `R = ⌈d⌉`, `d = √(W² + H²)`
//!   (eq. 6–7). With the centred origin every vote lands in `|b| ≤ d/2 + 1`.
//! - The rotation α is counter-clockwise: a point `p` of `I1` appears in `I2`
//!   at `R(α)·p + t`. A line of `I1` with normal angle θ therefore has normal
//!   angle `θ + α` in `I2`, so `D2(θ + α) = D1(θ)` and the shift `k` of
//!   eq. (11) gives `α = 2πk/N`. The paper's eq. (1) writes the same transform
//!   with the opposite sign of α.
//!
//! Everything here favours clarity over speed: the full accumulator matrix is
//! built (`N × (2R + 1)` `u32` counters), and correlations are computed over
//! all `N` shifts in `O(N²)`.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// A binary image, row-major, `true` = occupied.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Image {
    /// Number of columns `W`.
    pub width: usize,
    /// Number of rows `H`.
    pub height: usize,
    /// `W × H` cells, row-major: cell `(col, row)` is `pixels[row * W + col]`.
    pub pixels: Vec<bool>,
}

impl Image {
    /// An empty (all `false`) `width × height` image.
    pub fn new(width: usize, height: usize) -> Self {
        Self::filled(width, height, false)
    }

    /// A `width × height` image with every cell set to `value`.
    pub fn filled(width: usize, height: usize, value: bool) -> Self {
        Self {
            width,
            height,
            pixels: vec![value; width * height],
        }
    }

    /// An image with the given `(col, row)` cells occupied.
    ///
    /// # Panics
    /// If a cell lies outside the image.
    pub fn from_cells(width: usize, height: usize, cells: &[(usize, usize)]) -> Self {
        let mut image = Self::new(width, height);
        for &(col, row) in cells {
            image.set(col, row, true);
        }
        image
    }

    /// Whether cell `(col, row)` is occupied.
    ///
    /// # Panics
    /// If the cell lies outside the image.
    pub fn get(&self, col: usize, row: usize) -> bool {
        assert!(
            col < self.width && row < self.height,
            "cell ({col}, {row}) outside the image"
        );
        self.pixels[row * self.width + col]
    }

    /// Sets cell `(col, row)` to `value`.
    ///
    /// # Panics
    /// If the cell lies outside the image.
    pub fn set(&mut self, col: usize, row: usize, value: bool) {
        assert!(
            col < self.width && row < self.height,
            "cell ({col}, {row}) outside the image"
        );
        self.pixels[row * self.width + col] = value;
    }

    /// Number of occupied cells.
    pub fn count(&self) -> usize {
        self.pixels.iter().filter(|&&p| p).count()
    }

    /// The occupied cells as `(col, row)`, in row-major order.
    pub fn occupied(&self) -> Vec<(usize, usize)> {
        self.pixels
            .iter()
            .enumerate()
            .filter(|(_, &p)| p)
            .map(|(i, _)| (i % self.width, i / self.width))
            .collect()
    }

    /// Centred coordinates `(x, y)` of cell `(col, row)` in pixels:
    /// `x = col − (W−1)/2`, `y = (H−1)/2 − row` (y up).
    pub fn coords(&self, col: usize, row: usize) -> (f64, f64) {
        (
            col as f64 - (self.width as f64 - 1.0) / 2.0,
            (self.height as f64 - 1.0) / 2.0 - row as f64,
        )
    }

    /// The cell containing the point `(x, y)` (centred coordinates, pixels;
    /// cell `(col, row)` covers `|x − x_c| ≤ ½`, `|y − y_c| ≤ ½` around its
    /// centre), or `None` if the point lies outside the image. Points on a
    /// cell border go to the larger `col` and the larger `row`.
    pub fn cell_at(&self, x: f64, y: f64) -> Option<(usize, usize)> {
        let col = (x + self.width as f64 / 2.0).floor();
        let row = (self.height as f64 / 2.0 - y).floor();
        let inside =
            (0.0..self.width as f64).contains(&col) && (0.0..self.height as f64).contains(&row);
        inside.then_some((col as usize, row as usize))
    }
}

/// `θ_k = 2πk/N` in radians, in `[0, 2π)` for `k < N`.
pub fn theta(k: usize, n_theta: usize) -> f64 {
    TAU * k as f64 / n_theta as f64
}

/// `(cos θ_k, sin θ_k)` for `θ_k = 2πk/N` (`k` taken modulo `N`).
///
/// Evaluated through quadrant symmetry, so multiples of π/2 give exact
/// `0`/`±1` and, for even `N`, the second half-turn is the exact negation of
/// the first: `cos_sin(k + N/2) == (−cos, −sin)` bit for bit. Error against
/// the true values: a few ulp (< 1e-15).
pub fn cos_sin(k: usize, n_theta: usize) -> (f64, f64) {
    assert!(n_theta > 0, "n_theta must be positive");
    let k = k % n_theta;
    // 4k = q·N + r: θ = q·π/2 + φ with φ = (π/2)·r/N ∈ [0, π/2).
    let quarter = 4 * k / n_theta;
    let r = 4 * k - quarter * n_theta;
    let (c, s) = if 2 * r <= n_theta {
        let phi = FRAC_PI_2 * r as f64 / n_theta as f64;
        (phi.cos(), phi.sin())
    } else {
        // Fold around π/4 for symmetric accuracy: φ = π/2 − φ'.
        let phi = FRAC_PI_2 * (n_theta - r) as f64 / n_theta as f64;
        (phi.sin(), phi.cos())
    };
    match quarter {
        0 => (c, s),
        1 => (-s, c),
        2 => (-c, -s),
        _ => (s, -c),
    }
}

/// The ρ bin of a vote: `⌊ρ + ½⌋` (round half up, as eq. 8 asks for an
/// integer ρ).
pub fn rho_bin(rho: f64) -> i64 {
    (rho + 0.5).floor() as i64
}

/// The full Hough accumulator `A(θ, ρ)` of eq. (8): every occupied pixel votes
/// `ρ = x cos θ_k + y sin θ_k` (bin `⌊ρ + ½⌋`) in every column `θ_k`,
/// `k ∈ [0, N)` — doubled lines, since column `k + N/2` receives the same line
/// at `−ρ`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Accumulator {
    n_theta: usize,
    rho_half: i64,
    votes: Vec<u32>,
}

impl Accumulator {
    /// Votes all occupied pixels of `image` into `n_theta` columns.
    ///
    /// # Panics
    /// If `n_theta == 0`.
    pub fn build(image: &Image, n_theta: usize) -> Self {
        assert!(n_theta > 0, "n_theta must be positive");
        let d = ((image.width * image.width + image.height * image.height) as f64).sqrt();
        let rho_half = d.ceil() as i64;
        let n_rho = (2 * rho_half + 1) as usize;
        let mut votes = vec![0u32; n_theta * n_rho];
        let trig: Vec<(f64, f64)> = (0..n_theta).map(|k| cos_sin(k, n_theta)).collect();
        for (col, row) in image.occupied() {
            let (x, y) = image.coords(col, row);
            for (k, &(c, s)) in trig.iter().enumerate() {
                let b = rho_bin(x * c + y * s);
                votes[k * n_rho + (b + rho_half) as usize] += 1;
            }
        }
        Self {
            n_theta,
            rho_half,
            votes,
        }
    }

    /// Number of θ columns `N`.
    pub fn n_theta(&self) -> usize {
        self.n_theta
    }

    /// `R = ⌈d⌉`: bins run over `ρ ∈ [−R, R]`.
    pub fn rho_half(&self) -> i64 {
        self.rho_half
    }

    /// Number of ρ bins, `2R + 1`.
    pub fn n_rho(&self) -> usize {
        (2 * self.rho_half + 1) as usize
    }

    /// Column `θ_k`: entry `i` holds `A(θ_k, ρ = i − R)`.
    pub fn column(&self, k: usize) -> &[u32] {
        let n_rho = self.n_rho();
        &self.votes[k * n_rho..(k + 1) * n_rho]
    }

    /// `A(θ_k, ρ)`; zero for ρ outside `[−R, R]`.
    pub fn get(&self, k: usize, rho: i64) -> u32 {
        if rho.abs() > self.rho_half {
            0
        } else {
            self.column(k)[(rho + self.rho_half) as usize]
        }
    }

    /// Signature `D(θ_k) = max_ρ A(θ_k, ρ)` (eq. 10), one value per column.
    pub fn signature_max(&self) -> Vec<u32> {
        (0..self.n_theta)
            .map(|k| self.column(k).iter().copied().max().unwrap_or(0))
            .collect()
    }

    /// Two-bin signature `max_ρ (A(θ_k, ρ) + A(θ_k, ρ + 1))`, one value per
    /// column (less sensitive to a line straddling two bins).
    pub fn signature_two_bin(&self) -> Vec<u32> {
        (0..self.n_theta)
            .map(|k| {
                self.column(k)
                    .windows(2)
                    .map(|w| w[0] + w[1])
                    .max()
                    .unwrap_or(0)
            })
            .collect()
    }

    /// `(l, u)`: the smallest and largest ρ with `A(θ_k, ρ) > 0` (eqs. 13–14),
    /// or `None` for an empty column.
    pub fn bounds(&self, k: usize) -> Option<(i64, i64)> {
        let column = self.column(k);
        let l = column.iter().position(|&a| a > 0)?;
        let u = column.iter().rposition(|&a| a > 0)?;
        Some((l as i64 - self.rho_half, u as i64 - self.rho_half))
    }

    /// Asymmetry map `S(θ_k)` (eqs. 13–17): with `l, u` from [`bounds`],
    /// `w = u − l`, `m = l + w/2`, `s = Σ_{ρ=l}^{u} (ρ − m)/w · A(θ_k, ρ)`.
    /// Defined as `0` for an empty column or `w = 0`. Units: votes (the
    /// weights are dimensionless, in `[−½, ½]`).
    ///
    /// [`bounds`]: Self::bounds
    pub fn asymmetry(&self) -> Vec<f64> {
        (0..self.n_theta)
            .map(|k| match self.bounds(k) {
                Some((l, u)) if u > l => {
                    let w = (u - l) as f64;
                    let m = l as f64 + 0.5 * w;
                    (l..=u)
                        .map(|rho| (rho as f64 - m) / w * f64::from(self.get(k, rho)))
                        .sum()
                }
                _ => 0.0,
            })
            .collect()
    }
}

/// Tolerance on ρ used to call a vote "borderline": the fixed-point ρ of a
/// pixel at `(x, y)` may differ from the exact one by at most
/// `per_coord · (|x| + |y|) + absolute` pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RhoTolerance {
    /// Error per unit of `|x| + |y|` (the sin/cos table error).
    pub per_coord: f64,
    /// Constant error in pixels (rounding of ρ itself, float noise).
    pub absolute: f64,
}

impl RhoTolerance {
    /// Q15 sin/cos tables rounded to nearest: each entry is within `2⁻¹⁶` of
    /// the true value, so `|ρ_fixed − ρ| ≤ (|x| + |y|)·2⁻¹⁶` when the product
    /// and sum are exact; `absolute = 1e-9` covers the `f64` evaluation.
    pub const Q15: Self = Self {
        per_coord: 1.0 / 65536.0,
        absolute: 1e-9,
    };
}

/// For each column `θ_k`, the number of occupied pixels whose exact
/// `ρ = x cos θ_k + y sin θ_k` lies within `tol` of a rounding boundary
/// `j + ½` (the value a rounded ρ jumps at).
///
/// Only these votes can land in a different bin in an implementation whose
/// ρ is within `tol` of the exact one. Each such vote changes any single bin,
/// and any two-bin sum, by at most 1, so
/// `|D_other(θ_k) − D_ref(θ_k)| ≤ borderline_counts(..)[k]`, for both the
/// one-bin and the two-bin signature.
pub fn borderline_counts(image: &Image, n_theta: usize, tol: RhoTolerance) -> Vec<u32> {
    let trig: Vec<(f64, f64)> = (0..n_theta).map(|k| cos_sin(k, n_theta)).collect();
    let mut counts = vec![0u32; n_theta];
    for (col, row) in image.occupied() {
        let (x, y) = image.coords(col, row);
        let eps = tol.per_coord * (x.abs() + y.abs()) + tol.absolute;
        for (count, &(c, s)) in counts.iter_mut().zip(&trig) {
            let rho = x * c + y * s;
            if (rho - rho.floor() - 0.5).abs() <= eps {
                *count += 1;
            }
        }
    }
    counts
}

/// Pearson's correlation of two equally long series (eq. 12), or `None` when
/// either is (numerically) constant and the correlation is undefined.
///
/// # Panics
/// If the lengths differ.
pub fn pearson(x: &[f64], y: &[f64]) -> Option<f64> {
    assert_eq!(x.len(), y.len(), "series of different lengths");
    if x.is_empty() {
        return None;
    }
    let n = x.len() as f64;
    let mx = x.iter().sum::<f64>() / n;
    let my = y.iter().sum::<f64>() / n;
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (&a, &b) in x.iter().zip(y) {
        sxy += (a - mx) * (b - my);
        sxx += (a - mx) * (a - mx);
        syy += (b - my) * (b - my);
    }
    // A constant series gives sxx of order ε²·Σx² from the rounding of the
    // mean; anything that small is no signal.
    let tiny = |s: f64, v: &[f64]| s <= 1e-24 * v.iter().map(|a| a * a).sum::<f64>();
    if tiny(sxx, x) || tiny(syy, y) {
        None
    } else {
        Some(sxy / (sxx.sqrt() * syy.sqrt()))
    }
}

/// Circular correlation (eq. 11): entry `k` is
/// `cor(D1(θ_i), D2(θ_{i+k mod N}))` over all `i`, for every shift
/// `k ∈ [0, N)`. Shift `k` corresponds to `α = 2πk/N`. `None` when either
/// series is constant (no structure).
///
/// # Panics
/// If the lengths differ.
pub fn circular_correlation(d1: &[f64], d2: &[f64]) -> Option<Vec<f64>> {
    assert_eq!(d1.len(), d2.len(), "series of different lengths");
    let n = d1.len();
    let mut shifted = vec![0.0; n];
    (0..n)
        .map(|k| {
            for (i, v) in shifted.iter_mut().enumerate() {
                *v = d2[(i + k) % n];
            }
            pearson(d1, &shifted)
        })
        .collect()
}

/// Index of the largest entry (the first one on ties).
///
/// # Panics
/// If `values` is empty or holds a NaN.
pub fn argmax(values: &[f64]) -> usize {
    assert!(!values.is_empty(), "argmax of an empty series");
    let mut best = 0;
    for (i, &v) in values.iter().enumerate() {
        assert!(!v.is_nan(), "NaN in argmax");
        if v > values[best] {
            best = i;
        }
    }
    best
}

/// Parabolic sub-step refinement of the peak at `k` of a circular series:
/// the offset `δ ∈ [−½, ½]` (in steps) of the vertex of the parabola through
/// `c[k−1], c[k], c[k+1]`, so the refined peak is at `k + δ`. Returns `0` when
/// the three points do not form a strict maximum (flat or concave up).
pub fn parabolic_offset(values: &[f64], k: usize) -> f64 {
    let n = values.len();
    let prev = values[(k + n - 1) % n];
    let next = values[(k + 1) % n];
    let curvature = prev - 2.0 * values[k] + next;
    if curvature < 0.0 {
        (0.5 * (prev - next) / curvature).clamp(-0.5, 0.5)
    } else {
        0.0
    }
}

/// Eq. (18) scores of the two half-turn candidates for a shift `k`:
/// `(cor(S1(θ), S2(θ + α)), cor(S1(θ), S2(θ + α + π)))` with `α = 2πk/N`.
/// Each is `None` when a series is constant (e.g. `S ≡ 0` for a centrally
/// symmetric or empty image).
///
/// # Panics
/// If the lengths differ or `N` is odd.
pub fn half_turn_scores(s1: &[f64], s2: &[f64], k: usize) -> (Option<f64>, Option<f64>) {
    assert_eq!(s1.len(), s2.len(), "series of different lengths");
    let n = s1.len();
    assert!(n.is_multiple_of(2), "the half turn needs an even n_theta");
    let shifted = |k: usize| -> Vec<f64> { (0..n).map(|i| s2[(i + k) % n]).collect() };
    (pearson(s1, &shifted(k)), pearson(s1, &shifted(k + n / 2)))
}

/// Which signature the reference estimator correlates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SignatureKind {
    /// `D(θ) = max_ρ A(θ, ρ)`, the paper's eq. (10).
    Max,
    /// `max_ρ (A(θ, ρ) + A(θ, ρ + 1))`.
    TwoBin,
}

/// Signatures of one image.
#[derive(Clone, Debug, PartialEq)]
pub struct Signatures {
    /// `D(θ_k)`, votes (of the chosen [`SignatureKind`]).
    pub d: Vec<u32>,
    /// `S(θ_k)` of eq. (17), votes.
    pub s: Vec<f64>,
}

impl Signatures {
    /// Builds the accumulator of `image` and extracts `D` and `S`.
    pub fn of(image: &Image, n_theta: usize, kind: SignatureKind) -> Self {
        let acc = Accumulator::build(image, n_theta);
        let d = match kind {
            SignatureKind::Max => acc.signature_max(),
            SignatureKind::TwoBin => acc.signature_two_bin(),
        };
        Self {
            d,
            s: acc.asymmetry(),
        }
    }
}

/// Result of the reference estimator (paper, sections 5–8).
#[derive(Clone, Debug, PartialEq)]
pub struct Estimate {
    /// `N`, the number of θ steps.
    pub n_theta: usize,
    /// Winning shift of the `D` correlation over all `N` shifts (eq. 11), in
    /// `[0, N)`; ambiguous modulo `N/2` (α vs α + π).
    pub axis_shift: usize,
    /// Pearson correlation at `axis_shift`, in `[−1, 1]`.
    pub axis_score: f64,
    /// Parabolic sub-step offset of the peak, in steps, `[−½, ½]`.
    pub sub_step: f64,
    /// Eq. (18) score of `α = axis_shift` (`None`: `S` constant).
    pub direct_score: Option<f64>,
    /// Eq. (18) score of `α = axis_shift + N/2` (`None`: `S` constant).
    pub half_turn_score: Option<f64>,
    /// Whether the half turn was kept (its score strictly larger).
    pub half_turn: bool,
}

impl Estimate {
    /// Final shift in `[0, N)`, after the half-turn choice.
    pub fn shift(&self) -> usize {
        (self.axis_shift + if self.half_turn { self.n_theta / 2 } else { 0 }) % self.n_theta
    }

    /// Final α in radians, `[0, 2π)`, on the θ grid.
    pub fn alpha_rad(&self) -> f64 {
        theta(self.shift(), self.n_theta)
    }

    /// Final α in radians with the parabolic sub-step, `[0, 2π)`.
    pub fn alpha_refined_rad(&self) -> f64 {
        (TAU * (self.shift() as f64 + self.sub_step) / self.n_theta as f64).rem_euclid(TAU)
    }
}

/// The paper's estimator: signatures of both images, circular correlation of
/// `D` (eqs. 11–12), its argmax and parabolic offset, then the α vs α + π
/// choice from the asymmetry maps (eq. 18, the larger score wins; the direct
/// shift is kept on ties or when both scores are undefined).
///
/// Returns `None` ("no structure") when either `D` is constant, e.g. for an
/// empty image or a single pixel.
///
/// # Panics
/// If the images differ in size or `n_theta` is odd or zero.
pub fn estimate(i1: &Image, i2: &Image, n_theta: usize, kind: SignatureKind) -> Option<Estimate> {
    assert!(
        i1.width == i2.width && i1.height == i2.height,
        "images of different sizes"
    );
    let sig1 = Signatures::of(i1, n_theta, kind);
    let sig2 = Signatures::of(i2, n_theta, kind);
    let to_f64 = |d: &[u32]| -> Vec<f64> { d.iter().map(|&v| f64::from(v)).collect() };
    let corr = circular_correlation(&to_f64(&sig1.d), &to_f64(&sig2.d))?;
    let axis_shift = argmax(&corr);
    let (direct_score, half_turn_score) = half_turn_scores(&sig1.s, &sig2.s, axis_shift);
    let half_turn = match (direct_score, half_turn_score) {
        (Some(direct), Some(flipped)) => flipped > direct,
        (None, Some(_)) => true,
        _ => false,
    };
    Some(Estimate {
        n_theta,
        axis_shift,
        axis_score: corr[axis_shift],
        sub_step: parabolic_offset(&corr, axis_shift),
        direct_score,
        half_turn_score,
        half_turn,
    })
}

/// The paper's recommended θ resolution for a `w × h` image (eqs. 4–5).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThetaRange {
    /// `θ_lim = atan(b / (b² + a(a − 1)))`, `a = max(w, h)`, `b = min(w, h)`,
    /// radians: the finest angle at which lines stay distinguishable.
    pub theta_lim_rad: f64,
    /// Smallest recommended `N`: `max(w, h)`.
    pub min_steps: usize,
    /// `2π / θ_lim`: `N` must stay strictly below it (finer steps add no
    /// accuracy).
    pub max_steps_exclusive: f64,
}

impl ThetaRange {
    /// Whether `n_theta` lies in `[min_steps, max_steps_exclusive)`.
    pub fn contains(&self, n_theta: usize) -> bool {
        n_theta >= self.min_steps && (n_theta as f64) < self.max_steps_exclusive
    }
}

/// The recommended range of `N` for a `w × h` image (eqs. 4–5).
pub fn recommended_theta_range(width: usize, height: usize) -> ThetaRange {
    let a = width.max(height) as f64;
    let b = width.min(height) as f64;
    let theta_lim_rad = (b / (b * b + a * (a - 1.0))).atan();
    ThetaRange {
        theta_lim_rad,
        min_steps: width.max(height),
        max_steps_exclusive: TAU / theta_lim_rad,
    }
}

/// `angle` wrapped to `(−π, π]` radians.
pub fn wrap_pi(angle: f64) -> f64 {
    let a = angle.rem_euclid(TAU);
    if a > PI {
        a - TAU
    } else {
        a
    }
}

/// Absolute angular error over the full circle, radians in `[0, π]`.
pub fn angle_error_rad(estimate: f64, truth: f64) -> f64 {
    wrap_pi(estimate - truth).abs()
}

/// Absolute angular error modulo a half turn (the axis only), radians in
/// `[0, π/2]`.
pub fn axis_error_rad(estimate: f64, truth: f64) -> f64 {
    let e = angle_error_rad(estimate, truth);
    e.min(PI - e)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{self, Damage, Transform};
    use rand::SeedableRng;

    const N: usize = 360;

    fn horizontal_line(w: usize, h: usize, row: usize, cols: std::ops::Range<usize>) -> Image {
        let cells: Vec<_> = cols.map(|c| (c, row)).collect();
        Image::from_cells(w, h, &cells)
    }

    fn deg(k: usize) -> usize {
        k * N / 360
    }

    #[test]
    fn coordinates_follow_the_design_convention() {
        let img = Image::new(4, 3);
        assert_eq!(img.coords(0, 0), (-1.5, 1.0));
        assert_eq!(img.coords(3, 2), (1.5, -1.0));
        for (col, row) in [(0, 0), (3, 2), (1, 1), (2, 0)] {
            let (x, y) = img.coords(col, row);
            assert_eq!(img.cell_at(x, y), Some((col, row)));
            assert_eq!(img.cell_at(x + 0.49, y - 0.49), Some((col, row)));
        }
        assert_eq!(img.cell_at(2.0, 0.0), None);
        assert_eq!(img.cell_at(0.0, -1.6), None);
    }

    #[test]
    fn trig_is_exact_at_quarter_turns_and_antisymmetric() {
        for n in [4, 128, 360, 512, 10] {
            for k in 0..n {
                let (c, s) = cos_sin(k, n);
                let t = theta(k, n);
                assert!((c - t.cos()).abs() < 1e-15 && (s - t.sin()).abs() < 1e-15);
                let (c2, s2) = cos_sin(k + n / 2, n);
                assert_eq!((c2, s2), (-c, -s), "n = {n}, k = {k}");
                if 4 * k % n == 0 {
                    assert!(c.fract() == 0.0 && s.fract() == 0.0);
                }
            }
        }
    }

    #[test]
    fn single_horizontal_line_peaks_at_90_and_270_degrees() {
        // 20 pixels on row 10 of a 32×32 image: y = 15.5 − 10 = 5.5.
        let img = horizontal_line(32, 32, 10, 6..26);
        let acc = Accumulator::build(&img, N);
        let d = acc.signature_max();
        assert_eq!(d[deg(90)], 20);
        assert_eq!(d[deg(270)], 20);
        assert_eq!(acc.get(deg(90), 6), 20, "ρ = 5.5 rounds up to 6");
        assert_eq!(acc.get(deg(270), -5), 20, "ρ = −5.5 rounds up to −5");
        assert_eq!(*d.iter().max().unwrap(), 20);
        // Across the line, all 20 pixels spread over ≥ 19 bins.
        assert_eq!(d[deg(0)], 1);
        assert_eq!(d[deg(180)], 1);
        // Every column holds one vote per pixel.
        for k in 0..N {
            assert_eq!(acc.column(k).iter().sum::<u32>(), 20);
        }
        // The maxima are confined to a few degrees around 90° and 270°.
        for (k, &v) in d.iter().enumerate() {
            if v == 20 {
                let e = axis_error_rad(theta(k, N), FRAC_PI_2).to_degrees();
                assert!(e <= 3.5, "D = 20 at {k}°");
            }
        }
        // Every one of the 20 votes sits on a boundary at 90° and 270°.
        let border = borderline_counts(&img, N, RhoTolerance::Q15);
        assert_eq!(border[deg(90)], 20);
        assert_eq!(border[deg(270)], 20);
    }

    #[test]
    fn single_pixel_is_flat_and_has_no_structure() {
        let img = Image::from_cells(16, 16, &[(3, 12)]);
        let sig = Signatures::of(&img, N, SignatureKind::Max);
        assert!(sig.d.iter().all(|&v| v == 1));
        assert!(sig.s.iter().all(|&v| v == 0.0), "w = 0 gives s = 0");
        assert_eq!(estimate(&img, &img, N, SignatureKind::Max), None);
    }

    #[test]
    fn empty_image_gives_zero_signatures_and_no_structure() {
        let img = Image::new(24, 16);
        let acc = Accumulator::build(&img, N);
        assert!(acc.signature_max().iter().all(|&v| v == 0));
        assert!(acc.signature_two_bin().iter().all(|&v| v == 0));
        assert!(acc.asymmetry().iter().all(|&v| v == 0.0));
        assert_eq!(acc.bounds(0), None);
        let other = horizontal_line(24, 16, 3, 2..20);
        assert_eq!(estimate(&img, &img, N, SignatureKind::Max), None);
        assert_eq!(estimate(&img, &other, N, SignatureKind::TwoBin), None);
        assert_eq!(estimate(&other, &img, N, SignatureKind::Max), None);
    }

    #[test]
    fn full_image_votes_are_bounded_by_the_diagonal() {
        let img = Image::filled(16, 12, true);
        let acc = Accumulator::build(&img, N);
        let d = acc.signature_max();
        assert_eq!(d[deg(0)], 12, "a full column of pixels");
        assert_eq!(d[deg(90)], 16, "a full row of pixels");
        for k in 0..N {
            let (l, u) = acc.bounds(k).unwrap();
            assert!(l >= -11 && u <= 11, "|ρ| ≤ d/2 + 1 with d = 20");
        }
    }

    #[test]
    fn square_peaks_on_the_axes_with_the_side_length() {
        // Outline of a 10×10 square (side 10 pixels, 36 pixels in all).
        let mut cells = Vec::new();
        for i in 0..10 {
            cells.extend([(5 + i, 5), (5 + i, 14), (5, 5 + i), (14, 5 + i)]);
        }
        let img = Image::from_cells(24, 20, &cells);
        assert_eq!(img.count(), 36);
        let acc = Accumulator::build(&img, N);
        let d = acc.signature_max();
        for a in [0, 90, 180, 270] {
            assert_eq!(d[deg(a)], 10, "at {a}°");
        }
        assert!(d[deg(45)] < 10);
        // Both sides of the column at 0° hold 10 votes: symmetric about the
        // middle, so S vanishes there.
        let s = acc.asymmetry();
        assert!(s[deg(0)].abs() < 1e-12 && s[deg(90)].abs() < 1e-12);
        // Self-correlation: every quarter turn is a perfect match.
        let est = estimate(&img, &img, N, SignatureKind::Max).unwrap();
        assert_eq!(est.axis_shift % (N / 4), 0);
        assert!((est.axis_score - 1.0).abs() < 1e-12);
    }

    fn l_shape_image() -> Image {
        // Corner at (8, 23); horizontal arm of 16 pixels, vertical arm of 8.
        let mut cells: Vec<_> = (8..24).map(|c| (c, 23)).collect();
        cells.extend((16..23).map(|r| (8, r)));
        Image::from_cells(32, 32, &cells)
    }

    fn rotate_quarter(img: &Image) -> Image {
        // 90° CCW about the centre of a square image: (x, y) → (−y, x).
        let n = img.width;
        let cells: Vec<_> = img
            .occupied()
            .into_iter()
            .map(|(c, r)| (r, n - 1 - c))
            .collect();
        Image::from_cells(n, n, &cells)
    }

    #[test]
    fn l_shape_signature_and_asymmetry() {
        let img = l_shape_image();
        let acc = Accumulator::build(&img, N);
        let d = acc.signature_max();
        assert_eq!(d[deg(90)], 16);
        assert_eq!(d[deg(0)], 8);
        // At θ = 0 the vertical arm (x = −7.5, 8 votes at bin −7) is at the
        // left end of the range [−7, 8]; the horizontal arm spreads 1 vote
        // per bin over it.
        assert_eq!(acc.bounds(deg(0)), Some((-7, 8)));
        let s = acc.asymmetry();
        assert!(s[deg(0)] < 0.0, "mass on the low side");
        assert_eq!(s[deg(180)].signum(), -s[deg(0)].signum());
    }

    #[test]
    fn l_shape_quarter_turns_are_recovered_with_direction() {
        let mut img = l_shape_image();
        let base = img.clone();
        for quarter in 1..4 {
            img = rotate_quarter(&img);
            for kind in [SignatureKind::Max, SignatureKind::TwoBin] {
                let est = estimate(&base, &img, N, kind).unwrap();
                assert_eq!(
                    est.shift(),
                    quarter * N / 4,
                    "{quarter} quarter turns, {kind:?}"
                );
                assert!(est.axis_score > 0.99);
            }
        }
    }

    #[test]
    fn rotated_random_polygon_is_recovered() {
        let n = 360;
        for seed in 0..8u64 {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let polygon = scene::random_polygon(&mut rng);
            let truth = 0.1 + 0.77 * seed as f64; // spread over the circle
            let t = Transform {
                alpha_rad: truth,
                tx: 3.0,
                ty: -2.0,
                scale: 1.0,
            };
            let pair = scene::render_pair(&polygon, &t, &Damage::CLEAN, 96, 96, seed);
            let est = estimate(&pair.i1.image, &pair.i2.image, n, SignatureKind::TwoBin).unwrap();
            let step = TAU / n as f64;
            let axis = axis_error_rad(est.alpha_refined_rad(), truth);
            assert!(
                axis < 1.5 * step,
                "seed {seed}: axis error {}°",
                axis.to_degrees()
            );
            let full = angle_error_rad(est.alpha_refined_rad(), truth);
            assert!(
                full < 1.5 * step,
                "seed {seed}: direction wrong ({}°)",
                full.to_degrees()
            );
        }
    }

    #[test]
    fn correlation_helpers() {
        assert_eq!(pearson(&[1.0, 1.0, 1.0], &[1.0, 2.0, 3.0]), None);
        assert_eq!(
            pearson(&[0.1; 7], &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]),
            None
        );
        let r = pearson(&[1.0, 2.0, 3.0], &[2.0, 4.0, 6.5]).unwrap();
        assert!(r > 0.99 && r <= 1.0);
        assert!((pearson(&[1.0, 2.0, 3.0], &[3.0, 2.0, 1.0]).unwrap() + 1.0).abs() < 1e-12);
        // D2 is D1 shifted by 3 steps: D2(θ + 3) = D1(θ).
        let d1: Vec<f64> = (0..12).map(|i| f64::from(i * i % 7)).collect();
        let d2: Vec<f64> = (0..12).map(|i| d1[(i + 12 - 3) % 12]).collect();
        let c = circular_correlation(&d1, &d2).unwrap();
        assert_eq!(argmax(&c), 3);
        assert!((c[3] - 1.0).abs() < 1e-12);
        // Parabola through (−1, 0), (0, 1), (1, 0.5): vertex at +1/6.
        let v = [0.0, 1.0, 0.5, -1.0];
        assert!((parabolic_offset(&v, 1) - 1.0 / 6.0).abs() < 1e-12);
        assert_eq!(parabolic_offset(&[1.0, 1.0, 1.0], 1), 0.0);
        // Circular: neighbours of index 3 are 0.8 and (wrapping) 0.9.
        assert!((parabolic_offset(&[0.9, 0.0, 0.8, 1.0], 3) - 1.0 / 6.0).abs() < 1e-12);
    }

    #[test]
    fn recommended_range_matches_eqs_4_and_5() {
        let r = recommended_theta_range(128, 128);
        assert_eq!(r.min_steps, 128);
        assert!(
            (r.theta_lim_rad - (128.0f64 / (128.0 * 128.0 + 128.0 * 127.0)).atan()).abs() < 1e-15
        );
        assert!((r.max_steps_exclusive - 1602.2).abs() < 0.5);
        assert!(r.contains(360) && r.contains(512) && !r.contains(64) && !r.contains(2000));
        let r = recommended_theta_range(64, 48);
        assert_eq!(r.min_steps, 64);
        assert!((r.theta_lim_rad - (48.0f64 / (48.0 * 48.0 + 64.0 * 63.0)).atan()).abs() < 1e-15);
    }

    #[test]
    fn angle_helpers() {
        assert!((wrap_pi(3.0 * PI) - PI).abs() < 1e-12);
        assert!((wrap_pi(-PI) - PI).abs() < 1e-12);
        assert!((angle_error_rad(0.1, TAU - 0.1) - 0.2).abs() < 1e-12);
        assert!((axis_error_rad(PI + 0.05, 0.0) - 0.05).abs() < 1e-12);
    }
}
