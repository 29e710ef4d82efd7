//! Time of one estimate, library (fixed point, improved and paper mode)
//! against the `f64` reference of the paper, on the same scene pairs, at
//! 64², 128² and 256² with `N_THETA` = 360.
//!
//! ```text
//! cargo bench -p host-tests --bench estimate
//! ```
//!
//! Criterion reports each benchmark; at the end a table gives the mean time
//! per estimate of each and the ratio reference / library (timed again with
//! `Instant` over the same pairs, so the ratio needs no criterion output
//! files). Both sides include the grid conversion they need: the library
//! takes `Grid`s (built outside the timed loop), the reference `Image`s.
//!
//! The pairs are random polygons with moderate damage (seeded), the
//! library's reference view is prepared inside the timed call
//! (`estimate_pair`: two signatures, correlation, direction test,
//! translation), like the reference's `estimate` (two accumulators).

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::Criterion;
use host_tests::eval::{grid_from_image, trial_pair, trial_seed};
use host_tests::reference::{self as fref, Image, SignatureKind};
use host_tests::scene::{Damage, SceneKind};
use hough_heading::{
    config::half_turn_steps, config::rho_bins, config::row_words, Estimator, Grid, Mode,
};

const N: usize = 360;
const HALF: usize = half_turn_steps(N);
/// Scene pairs per size; each benchmark iteration estimates all of them.
const PAIRS: usize = 4;

/// The seeded pairs of one size, as images and as library grids.
struct Scenes<const W: usize, const RW: usize> {
    images: Vec<(Image, Image)>,
    grids: Vec<(Grid<W, W, RW>, Grid<W, W, RW>)>,
}

impl<const W: usize, const RW: usize> Scenes<W, RW> {
    fn new() -> Self {
        let images: Vec<(Image, Image)> = (0..PAIRS as u64)
            .map(|i| {
                let (_, pair) = trial_pair(
                    SceneKind::RandomPolygon,
                    &Damage::MODERATE,
                    W,
                    W,
                    true,
                    trial_seed(4242, i),
                );
                (pair.i1.image, pair.i2.image)
            })
            .collect();
        let grids = images
            .iter()
            .map(|(a, b)| (grid_from_image(a), grid_from_image(b)))
            .collect();
        Self { images, grids }
    }
}

/// The three timed operations of one size.
struct Runner<const W: usize, const RW: usize, const RHO: usize, const PW: usize> {
    scenes: Scenes<W, RW>,
}

impl<const W: usize, const RW: usize, const RHO: usize, const PW: usize> Runner<W, RW, RHO, PW> {
    fn library(&self, mode: Mode) {
        let mut e = Estimator::<W, W, RW, N, HALF, RHO, PW>::new(mode);
        for (g1, g2) in &self.scenes.grids {
            black_box(e.estimate_pair(black_box(g1), black_box(g2)));
        }
    }

    fn reference(&self) {
        for (i1, i2) in &self.scenes.images {
            black_box(fref::estimate(
                black_box(i1),
                black_box(i2),
                N,
                SignatureKind::Max,
            ));
        }
    }

    fn bench(&self, c: &mut Criterion) {
        let mut group = c.benchmark_group(format!("estimate_{W}x{W}_n{N}"));
        group.sample_size(10);
        group.warm_up_time(Duration::from_millis(500));
        group.measurement_time(Duration::from_secs(2));
        group.bench_function("library_improved", |b| {
            b.iter(|| self.library(Mode::Improved))
        });
        group.bench_function("library_paper", |b| b.iter(|| self.library(Mode::Paper)));
        group.bench_function("reference_f64", |b| b.iter(|| self.reference()));
        group.finish();
    }

    /// Mean seconds per estimate of `f`, over at least `budget`.
    fn mean(f: impl Fn(), budget: Duration) -> f64 {
        f();
        let start = Instant::now();
        let mut runs = 0u32;
        while start.elapsed() < budget || runs < 3 {
            f();
            runs += 1;
        }
        start.elapsed().as_secs_f64() / f64::from(runs) / PAIRS as f64
    }

    fn summary_row(&self) -> String {
        let budget = Duration::from_millis(700);
        let improved = Self::mean(|| self.library(Mode::Improved), budget);
        let paper = Self::mean(|| self.library(Mode::Paper), budget);
        let reference = Self::mean(|| self.reference(), budget);
        format!(
            "| {W}² | {:.3} | {:.3} | {:.2} | {:.1}× | {:.1}× |",
            improved * 1e3,
            paper * 1e3,
            reference * 1e3,
            reference / improved,
            reference / paper
        )
    }
}

fn main() {
    let r64 = Runner::<
        64,
        { row_words(64) },
        { rho_bins(64, 64) },
        { hough_heading::config::pyramid_words(64, 64) },
    > {
        scenes: Scenes::new(),
    };
    let r128 = Runner::<
        128,
        { row_words(128) },
        { rho_bins(128, 128) },
        { hough_heading::config::pyramid_words(128, 128) },
    > {
        scenes: Scenes::new(),
    };
    let r256 = Runner::<
        256,
        { row_words(256) },
        { rho_bins(256, 256) },
        { hough_heading::config::pyramid_words(256, 256) },
    > {
        scenes: Scenes::new(),
    };
    let mut c = Criterion::default().configure_from_args();
    r64.bench(&mut c);
    r128.bench(&mut c);
    r256.bench(&mut c);
    c.final_summary();
    // `cargo bench` passes `--bench`; `cargo test --benches` does not (and
    // criterion then runs each benchmark once as a test): skip the table.
    if !std::env::args().any(|a| a == "--bench") {
        return;
    }
    println!("\nMean time per estimate (ms), N_THETA = {N}, random polygons, moderate damage:\n");
    println!("| size | library improved | library paper | f64 reference | ratio ref / improved | ratio ref / paper |");
    println!("|---|---|---|---|---|---|");
    for row in [r64.summary_row(), r128.summary_row(), r256.summary_row()] {
        println!("{row}");
    }
}
