//! The fixed estimator configurations the tool offers, behind one trait.
//!
//! The library's estimator is const-generic (`estimator!(W, H, N_THETA)`), so
//! every grid size × θ resolution the tool offers is compiled in separately;
//! [`engine`] picks one at run time.

use hough_heading::place::place_similarity;
use hough_heading::{
    config::half_turn_steps, config::pyramid_words, config::rho_bins, config::row_words,
    stages::Accumulator, stages::Correlation, stages::PeakKind, stages::Signature, Estimate,
    Estimator, FreeSpace, Grid, Mode, Prior, Raster, ScaleRange, Scan, ScanReference, ScanStats,
    Thresholds,
};

use crate::image::Image;

/// Which of the two views of a pair.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum View {
    /// The reference (image A, scan 1).
    First,
    /// The new view (image B, scan 2).
    Second,
}

impl View {
    fn index(self) -> usize {
        match self {
            View::First => 0,
            View::Second => 1,
        }
    }
}

/// What the figures show of one pair, in plain vectors.
#[derive(Clone, Debug)]
pub struct Figures {
    /// θ steps over the half circle (`N_THETA / 2`).
    pub half: usize,
    /// ρ bins per column; bin `b` is ρ = `b − rho/2` pixels.
    pub rho: usize,
    /// Both accumulators over θ ∈ [0, π), column-major: `acc[k·rho + b]`.
    pub accumulators: [Vec<u16>; 2],
    /// `D(θ)` of both views over θ ∈ [0, π).
    pub signatures: [Vec<u16>; 2],
    /// `S(θ)` of both views over θ ∈ [0, π) (the paper's asymmetry map, in
    /// the library's fixed-point units).
    pub asymmetries: [Vec<i32>; 2],
    /// Pearson correlation `r(k)` of `D1(θ)` and `D2(θ + k·Δθ)`, `k ∈ [0, half)`.
    pub correlation: Vec<f64>,
    /// Shift of the strongest correlation peak.
    pub best: Option<usize>,
    /// Shift of the rival peak (the strongest at least 5° from the best).
    pub rival: Option<usize>,
}

/// One compiled configuration: two grids and an estimator per mode. `Send`:
/// `--jobs` gives each thread an engine of its own.
pub trait Engine: Send {
    /// Grid side, cells.
    fn size(&self) -> usize;
    /// θ steps over the full circle.
    fn n_theta(&self) -> usize;
    /// Replaces the status thresholds of both modes.
    fn set_thresholds(&mut self, thresholds: Thresholds);
    /// Makes the improved mode search the scale over `range` (`None`: s = 1).
    fn set_scale_search(&mut self, range: Option<ScaleRange>);
    /// Turns the improved mode's verification by alignment on or off.
    fn set_verification(&mut self, on: bool);
    /// Whether estimates on rasterized scans use their free space (the
    /// default) or the grids alone.
    fn set_free_space(&mut self, on: bool);
    /// Clears the grid of `view` and draws `scan` into it, with the cells its
    /// beams crossed (`Raster::free_space`): an estimate on two rasterized
    /// scans uses their free space (`Estimator::estimate_scans`).
    fn rasterize(&mut self, view: View, scan: &Scan<'_>, raster: &Raster) -> ScanStats;
    /// Replaces the grid of `view` by `image` (cells beyond the grid are
    /// ignored; callers check the size first).
    fn load(&mut self, view: View, image: &Image);
    /// The grid of `view` as an image.
    fn image(&self, view: View) -> Image;
    /// Rotation (and translation) of the second view relative to the first.
    fn estimate(&mut self, mode: Mode) -> Estimate {
        self.estimate_with_prior(mode, None)
    }
    /// Like [`Engine::estimate`], with an optional prior on α that picks
    /// among the candidates (`Estimator::estimate_with_prior`).
    fn estimate_with_prior(&mut self, mode: Mode, prior: Option<Prior>) -> Estimate;
    /// Accumulators, signatures and correlation of the two grids (for plots).
    fn figures(&self, mode: Mode) -> Figures;
    /// The improved mode's signature `D(θ)` of `view` (θ over the half
    /// circle): its place descriptor (`hough_heading::place`).
    fn place_signature(&mut self, view: View) -> Vec<u16>;
    /// `hough_heading::place::place_similarity` of two signatures of this
    /// configuration, in [−1, 1]; 0 when either has another length.
    fn place_similarity(&self, a: &[u16], b: &[u16]) -> f64;
    /// The bytes of `view` as a stored scan reference (`ScanReference`, the
    /// improved mode's reference with the view's free space, `raster` and
    /// `scan`, the scan the view was rasterized from: at most
    /// [`STORED_BEAMS`] readings). An error unless the view was rasterized
    /// from a scan, or when the scan has too many readings.
    fn scan_reference(
        &mut self,
        view: View,
        raster: &Raster,
        scan: &Scan<'_>,
    ) -> Result<Vec<u8>, String>;
}

/// The most readings of a scan the tool stores in a scan reference (a
/// firmware reads the bytes with its own capacity, at least the scan's
/// readings).
pub const STORED_BEAMS: usize = 4096;

struct Config<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const HALF: usize,
    const RHO: usize,
    const PW: usize,
> {
    grids: [Grid<W, H, RW>; 2],
    /// The free space of each view, when it was rasterized from a scan.
    free: [Option<Grid<W, H, RW>>; 2],
    /// Estimates use `free` when both views have it.
    use_free: bool,
    improved: Estimator<W, H, RW, N, HALF, RHO, PW>,
    paper: Estimator<W, H, RW, N, HALF, RHO, PW>,
}

impl<
        const W: usize,
        const H: usize,
        const RW: usize,
        const N: usize,
        const HALF: usize,
        const RHO: usize,
        const PW: usize,
    > Engine for Config<W, H, RW, N, HALF, RHO, PW>
{
    fn size(&self) -> usize {
        W
    }

    fn n_theta(&self) -> usize {
        N
    }

    fn set_thresholds(&mut self, thresholds: Thresholds) {
        let scale = self.improved.scale_search();
        let verify = self.improved.verification();
        self.improved = Estimator::new(Mode::Improved)
            .with_thresholds(thresholds)
            .with_verification(verify);
        self.improved.set_scale_search(scale);
        self.paper = Estimator::new(Mode::Paper).with_thresholds(thresholds);
    }

    fn set_scale_search(&mut self, range: Option<ScaleRange>) {
        self.improved.set_scale_search(range);
    }

    fn set_verification(&mut self, on: bool) {
        let improved = self.improved.clone().with_verification(on);
        self.improved = improved;
    }

    fn set_free_space(&mut self, on: bool) {
        self.use_free = on;
    }

    fn scan_reference(
        &mut self,
        view: View,
        raster: &Raster,
        scan: &Scan<'_>,
    ) -> Result<Vec<u8>, String> {
        let free = self.free[view.index()]
            .clone()
            .ok_or("the view was not rasterized from a scan")?;
        let reference = self.improved.reference(&self.grids[view.index()]);
        let stored =
            ScanReference::<W, H, RW, HALF, RHO, STORED_BEAMS>::new(reference, free, *raster, scan)
                .map_err(|e| e.to_string())?;
        let mut bytes = vec![0; stored.byte_len()];
        stored.to_bytes(&mut bytes).map_err(|e| e.to_string())?;
        Ok(bytes)
    }

    fn place_signature(&mut self, view: View) -> Vec<u16> {
        let reference = self.improved.reference(&self.grids[view.index()]);
        reference.signature().peaks().to_vec()
    }

    fn place_similarity(&self, a: &[u16], b: &[u16]) -> f64 {
        if a.len() != HALF || b.len() != HALF {
            return 0.0;
        }
        place_similarity::<HALF>(&signature_array(a), &signature_array(b)).to_num()
    }

    fn rasterize(&mut self, view: View, scan: &Scan<'_>, raster: &Raster) -> ScanStats {
        let grid = &mut self.grids[view.index()];
        grid.clear_all();
        let stats = raster.rasterize(scan, grid);
        let free = self.free[view.index()].get_or_insert_with(Grid::new);
        free.clear_all();
        raster.free_space(scan, free);
        stats
    }

    fn load(&mut self, view: View, image: &Image) {
        self.free[view.index()] = None;
        let grid = &mut self.grids[view.index()];
        grid.clear_all();
        // Cells beyond W × H are rejected by the grid; the caller checked the size.
        let _ = grid.set_cells(image.occupied());
    }

    fn image(&self, view: View) -> Image {
        let grid = &self.grids[view.index()];
        let mut image = Image::new(W, H);
        for row in 0..H {
            for col in 0..W {
                if grid.get(col, row) {
                    image.set(col, row, true);
                }
            }
        }
        image
    }

    fn estimate_with_prior(&mut self, mode: Mode, prior: Option<Prior>) -> Estimate {
        let [first, second] = &self.grids;
        let estimator = match mode {
            Mode::Improved => &mut self.improved,
            Mode::Paper => &mut self.paper,
        };
        // `estimate_pair` is exactly this with no prior and no scans.
        let reference = estimator.reference(first);
        match &self.free {
            [Some(reference_free), Some(current_free)] if self.use_free => {
                let free = FreeSpace {
                    reference: reference_free,
                    current: current_free,
                };
                estimator.estimate_scans(&reference, second, &free, prior)
            }
            _ => estimator.estimate_with_prior(&reference, second, prior),
        }
    }

    fn figures(&self, mode: Mode) -> Figures {
        let kind = mode.peak_kind();
        let mut accumulators: [Vec<u16>; 2] = Default::default();
        let mut signatures: [Vec<u16>; 2] = Default::default();
        let mut asymmetries: [Vec<i32>; 2] = Default::default();
        for (i, grid) in self.grids.iter().enumerate() {
            // 256² × 720 is 368 KiB: keep it off the stack.
            let acc = Box::new(Accumulator::<HALF, RHO>::vote::<W, H, RW, N>(grid));
            accumulators[i] = (0..HALF)
                .flat_map(|k| acc.half_column(k).into_iter().flatten().copied())
                .collect();
            signatures[i] = Signature::from_accumulator(&acc, kind).peaks().to_vec();
            // The library computes S(θ) only for the paper's single-bin
            // signature (the improved mode does not use it); the figure
            // always shows it.
            let paper = Signature::from_accumulator(&acc, PeakKind::SingleBin);
            asymmetries[i] = paper.asymmetries().iter().map(|&v| i32::from(v)).collect();
        }
        let d1: [u16; HALF] = signature_array(&signatures[0]);
        let d2: [u16; HALF] = signature_array(&signatures[1]);
        let correlation = Correlation::of(&d1, &d2);
        Figures {
            half: HALF,
            rho: RHO,
            correlation: pearson_curve(&signatures[0], &signatures[1]),
            best: correlation.best().map(|p| p.shift),
            rival: correlation.rival((N / 72).max(2)).map(|p| p.shift),
            accumulators,
            signatures,
            asymmetries,
        }
    }
}

fn signature_array<const HALF: usize>(values: &[u16]) -> [u16; HALF] {
    let mut out = [0u16; HALF];
    for (o, v) in out.iter_mut().zip(values) {
        *o = *v;
    }
    out
}

/// `r(k)` = Pearson correlation of `d1(θ)` and `d2(θ + k)` (circular), in f64.
fn pearson_curve(d1: &[u16], d2: &[u16]) -> Vec<f64> {
    let n = d1.len();
    let mean = |d: &[u16]| d.iter().map(|&v| f64::from(v)).sum::<f64>() / n.max(1) as f64;
    let (m1, m2) = (mean(d1), mean(d2));
    let var = |d: &[u16], m: f64| d.iter().map(|&v| (f64::from(v) - m).powi(2)).sum::<f64>();
    let den = (var(d1, m1) * var(d2, m2)).sqrt();
    (0..n)
        .map(|k| {
            if den == 0.0 {
                return 0.0;
            }
            let num: f64 = (0..n)
                .map(|i| (f64::from(d1[i]) - m1) * (f64::from(d2[(i + k) % n]) - m2))
                .sum();
            num / den
        })
        .collect()
}

macro_rules! configurations {
    ($(($size:literal, $n:literal)),* $(,)?) => {
        /// Every `(grid side, N_THETA)` the tool is compiled for.
        pub const CONFIGURATIONS: &[(usize, usize)] = &[$(($size, $n)),*];

        /// The engine for a `size × size` grid and `n_theta` θ steps over the
        /// full circle, if that configuration is compiled in.
        pub fn engine(size: usize, n_theta: usize) -> Option<Box<dyn Engine>> {
            match (size, n_theta) {
                $(($size, $n) => Some(Box::new(Config::<
                    $size,
                    $size,
                    { row_words($size) },
                    $n,
                    { half_turn_steps($n) },
                    { rho_bins($size, $size) },
                    { pyramid_words($size, $size) },
                > {
                    grids: [Grid::new(), Grid::new()],
                    free: [None, None],
                    use_free: true,
                    improved: Estimator::new(Mode::Improved),
                    paper: Estimator::new(Mode::Paper),
                })),)*
                _ => None,
            }
        }
    };
}

/// Calls the macro `$m` with every compiled configuration, `(grid side,
/// N_THETA)` pairs of literals: the one list of them, for this crate's
/// [`engine`] and [`CONFIGURATIONS`] and for the Python package's typed
/// references.
#[macro_export]
macro_rules! with_configurations {
    ($m:ident) => {
        $m!(
            (64, 180),
            (64, 360),
            (64, 720),
            (128, 180),
            (128, 360),
            (128, 720),
            (256, 180),
            (256, 360),
            (256, 720),
        );
    };
}

with_configurations!(configurations);

/// The grid sides compiled in, ascending.
pub fn sizes() -> Vec<usize> {
    let mut s: Vec<usize> = CONFIGURATIONS.iter().map(|c| c.0).collect();
    s.dedup();
    s
}
