//! `hough_heading._core`: the native half of the Python package
//! `hough_heading` (the Python half, `py/hough_heading/__init__.py`, checks
//! the arguments, builds the option lists and wraps the answers).
//!
//! Every answer is the `hough-heading` tool's own JSON for the same input,
//! made by the same functions as the tool's, those of the host library
//! under it (`hough_heading_recordings`):
//! the options are parsed by the tool's own `clap` definitions
//! ([`EstimatorArgs`], [`ImageArgs`]), images go through
//! [`place_images`] and [`images_result`], scan pairs through
//! [`scans::estimate_with_prior`] and [`OutputLine::of`]. A field the tool
//! adds to its JSON reaches Python without a change here.
//!
//! The estimates run with the GIL released, on a thread with a stack of its
//! own ([`STACK_BYTES`]), so Python threads may call in parallel; the batch
//! calls spread the pairs over several threads. No input reaches a panic:
//! every array and number is checked here (and in the Python half) and a
//! panic in the tool's code would become a Python exception, not an abort.

mod batch;
mod logs;
mod reference;

use std::fmt::Display;

use clap::Parser;
use hough_heading::{Angle, Mode, Prior};
use hough_heading_recordings::answer::{images_result, place_images};
use hough_heading_recordings::image::Image;
use hough_heading_recordings::line::OutputLine;
use hough_heading_recordings::options::{EstimatorArgs, ImageArgs};
use hough_heading_recordings::pairs::{self as scans, PairRecord, RasterOptions, ScanRecord};
use numpy::{PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

/// Stack of the threads the estimates run on (the 256² × 720 engines keep
/// their grids and scratch on it; Python's own threads may have less).
pub const STACK_BYTES: usize = 64 << 20;

/// A `ValueError` with `message`.
pub fn value_error(message: impl Display) -> PyErr {
    PyValueError::new_err(message.to_string())
}

/// Runs `f` on a thread with a [`STACK_BYTES`] stack; a panic in it becomes
/// an error message instead of unwinding into Python.
pub fn on_big_stack<T: Send>(f: impl FnOnce() -> T + Send) -> Result<T, String> {
    std::thread::scope(|scope| {
        let handle = std::thread::Builder::new()
            .name("hough-heading".into())
            .stack_size(STACK_BYTES)
            .spawn_scoped(scope, f)
            .map_err(|e| format!("cannot start a thread: {e}"))?;
        handle
            .join()
            .map_err(|_| "internal error: the estimator panicked (please report it)".to_string())
    })
}

/// The options of an image pair: the tool's `images` options.
#[derive(Clone, Debug, Parser)]
#[command(name = "hough_heading", no_binary_name = true)]
pub struct ImageOptions {
    /// How images are read and placed.
    #[command(flatten)]
    pub image: ImageArgs,
    /// Estimator options.
    #[command(flatten)]
    pub estimator: EstimatorArgs,
}

/// The options of a scan pair: the tool's estimator options (the grid
/// options come as numbers, [`ScanGrid`]).
#[derive(Clone, Debug, Parser)]
#[command(name = "hough_heading", no_binary_name = true)]
pub struct ScanOptions {
    /// Estimator options.
    #[command(flatten)]
    pub estimator: EstimatorArgs,
}

/// Parses tool options (`["--n-theta", "360", …]`) with the tool's own
/// definitions; a bad value is a `ValueError` with the tool's message.
pub fn parse_options<P: Parser>(args: &[String]) -> PyResult<P> {
    P::try_parse_from(args).map_err(|e| value_error(e.render().to_string().trim()))
}

/// A binary image from a 2-D `uint8` array of 0 and 1 (row 0 at the top).
pub fn image_of(name: &str, array: &PyReadonlyArray2<'_, u8>) -> PyResult<Image> {
    let view = array.as_array();
    let (height, width) = view.dim();
    let mut image = Image::new(width, height);
    for ((row, col), &v) in view.indexed_iter() {
        match v {
            0 => {}
            1 => image.set(col, row, true),
            other => {
                return Err(value_error(format!(
                    "{name}: cell (row {row}, column {col}) is {other}; expected 0 or 1 \
                     (or booleans)"
                )))
            }
        }
    }
    Ok(image)
}

/// The tool's `images --json` answer for two images, as its JSON text.
fn images_text(a: &Image, b: &Image, options: &ImageOptions) -> Result<String, String> {
    let (mut engine, offsets) =
        place_images(("a", a), ("b", b), &options.image, &options.estimator)
            .map_err(|e| e.to_string())?;
    let result = images_result(engine.as_mut(), options.estimator.mode.into(), offsets);
    serde_json::to_string(&result).map_err(|e| format!("JSON output: {e}"))
}

/// `images` of the tool on two arrays: its JSON text.
#[pyfunction]
fn images_json(
    py: Python<'_>,
    a: PyReadonlyArray2<'_, u8>,
    b: PyReadonlyArray2<'_, u8>,
    args: Vec<String>,
) -> PyResult<String> {
    let options: ImageOptions = parse_options(&args)?;
    let (a, b) = (image_of("a", &a)?, image_of("b", &b)?);
    py.detach(|| on_big_stack(|| images_text(&a, &b, &options)))
        .map_err(PyRuntimeError::new_err)?
        .map_err(value_error)
}

/// How scans become grids (the tool's `ScanGridArgs`, as numbers).
#[derive(Clone, Copy, Debug)]
pub struct ScanGrid {
    /// Grid side, cells.
    pub size: usize,
    /// The rasterization.
    pub raster: RasterOptions,
}

impl ScanGrid {
    /// From the Python call's numbers `(size, cell, connect, disc, _)`:
    /// `cell` `None` means per pair, `connect` 0 draws one cell per beam.
    pub fn new(&(size, cell, connect, disc, _): &GridIn) -> PyResult<Self> {
        if let Some(c) = cell.filter(|c| !(c.is_finite() && *c > 0.0)) {
            return Err(value_error(format!(
                "cell={c}: must be a positive number of metres (or None: per pair)"
            )));
        }
        if !(connect.is_finite() && connect >= 0.0) {
            return Err(value_error(format!(
                "connect={connect}: must be 0 (no segments) or a positive number of metres"
            )));
        }
        Ok(Self {
            size,
            raster: RasterOptions {
                cell,
                connect: (connect > 0.0).then_some(connect),
                disc,
                // The tool's defaults: the answer checked and refined on the
                // beams.
                beam_refine: true,
                beam_check: true,
            },
        })
    }
}

/// The grid options from Python: side, metres per cell (`None`: per pair),
/// segment gap (metres, 0: none), disc only, NaN ranges allowed.
pub type GridIn = (usize, Option<f32>, f32, bool, bool);

/// A scan from Python: ranges (metres), `angle_min`, `angle_increment`,
/// `max_range`, sensor offset `(x, y, θ)` in the robot frame.
pub type ScanIn<'py> = (PyReadonlyArray1<'py, f64>, f64, f64, f64, (f64, f64, f64));

/// Checks a scan and converts it as the tool's JSON reader does (`f64` →
/// `f32`). `nan_ok`: NaN and ±∞ ranges are kept (the rasterizer drops and
/// counts them); otherwise they are an error.
pub fn record_of(name: &str, scan: &ScanIn<'_>, nan_ok: bool) -> PyResult<ScanRecord> {
    let (ranges, angle_min, angle_increment, max_range, (ox, oy, oth)) = scan;
    let view = ranges.as_array();
    if view.is_empty() {
        return Err(value_error(format!("{name}: the scan has no beams")));
    }
    for (what, v) in [
        ("angle_min", *angle_min),
        ("angle_increment", *angle_increment),
        ("max_range", *max_range),
        ("offset x", *ox),
        ("offset y", *oy),
        ("offset theta", *oth),
    ] {
        if !v.is_finite() || (v as f32).is_infinite() {
            return Err(value_error(format!(
                "{name}: {what} = {v}: must be a finite number"
            )));
        }
    }
    if *max_range <= 0.0 {
        return Err(value_error(format!(
            "{name}: max_range = {max_range}: must be positive (metres)"
        )));
    }
    if *angle_increment == 0.0 {
        return Err(value_error(format!(
            "{name}: angle_increment is 0: the beams must be spread (radians)"
        )));
    }
    let mut out = Vec::with_capacity(view.len());
    for (i, &r) in view.iter().enumerate() {
        if r.is_nan() || r.is_infinite() {
            if !nan_ok {
                return Err(value_error(format!(
                    "{name}: range {i} is {r} (nan='raise'; nan='drop' drops it as the \
                     tool does)"
                )));
            }
        } else if r < 0.0 {
            return Err(value_error(format!(
                "{name}: range {i} is {r}: ranges are distances, not negative"
            )));
        }
        out.push(Some(r as f32));
    }
    Ok(ScanRecord {
        ranges: out,
        angle_min: *angle_min as f32,
        angle_increment: *angle_increment as f32,
        max_range: *max_range as f32,
        laser_offset: [*ox as f32, *oy as f32, *oth as f32],
    })
}

/// The raw pose of a scan estimate that the tool's line does not print:
/// translation in cells (image 2's frame, x right, y up), scale and
/// residual in cells.
pub type Extras = Option<(f64, f64, f64, f64)>;

/// One scan pair's answer: the tool's JSON line and the [`Extras`].
pub type ScanAnswer = (String, Extras);

/// A rotation prior from the robot's heading change: `(dθ°, σ°)`.
pub fn prior_of(prior: Option<(f64, f64)>) -> PyResult<Option<Prior>> {
    let Some((dtheta, sigma)) = prior else {
        return Ok(None);
    };
    if !(dtheta.is_finite() && sigma.is_finite() && sigma > 0.0 && sigma <= 90.0) {
        return Err(value_error(format!(
            "prior=({dtheta}, {sigma}): expected (heading change in degrees, sigma in (0, 90] \
             degrees)"
        )));
    }
    Ok(Some(Prior {
        alpha: Angle::from_degrees(-dtheta as f32),
        sigma: Angle::from_degrees(sigma as f32),
    }))
}

/// Estimates one pair with `engine`, as `scans` prints line `index`.
pub fn scan_answer(
    engine: &mut dyn hough_heading_recordings::engine::Engine,
    pair: &PairRecord,
    grid: &ScanGrid,
    mode: Mode,
    prior: Option<Prior>,
    index: usize,
) -> Result<ScanAnswer, String> {
    let estimates = scans::estimate_with_prior(engine, pair, &grid.raster, &[mode], prior)?;
    let p = estimates
        .first()
        .ok_or("internal error: no estimate for the mode asked")?;
    let text = serde_json::to_string(&OutputLine::of(index, p))
        .map_err(|e| format!("JSON output: {e}"))?;
    let round = |v: f64, digits| scans::round(v, digits);
    // The reported pose: refined on the beams when the fit succeeded.
    let (_, translation) = scans::reported_pose(&p.estimate, p.beam_fit.as_ref());
    let extras = translation.map(|t| {
        (
            round(t.x.to_num::<f64>(), 3),
            round(t.y.to_num::<f64>(), 3),
            round(t.scale.to_num::<f64>(), 4),
            round(t.residual.to_num::<f64>(), 3),
        )
    });
    Ok((text, extras))
}

/// `scans` of the tool on one pair: its JSON line (index 0) and the extras.
#[pyfunction]
#[pyo3(signature = (scan1, scan2, args, grid, prior))]
fn scans_json(
    py: Python<'_>,
    scan1: ScanIn<'_>,
    scan2: ScanIn<'_>,
    args: Vec<String>,
    grid: GridIn,
    prior: Option<(f64, f64)>,
) -> PyResult<ScanAnswer> {
    let options: ScanOptions = parse_options(&args)?;
    let nan_ok = grid.4;
    let grid = ScanGrid::new(&grid)?;
    let prior = prior_of(prior)?;
    let pair = PairRecord {
        scan1: record_of("scan1", &scan1, nan_ok)?,
        scan2: record_of("scan2", &scan2, nan_ok)?,
    };
    let mode: Mode = options.estimator.mode.into();
    py.detach(|| {
        on_big_stack(|| {
            let mut engine = options
                .estimator
                .engine(grid.size)
                .map_err(|e| e.to_string())?;
            scan_answer(engine.as_mut(), &pair, &grid, mode, prior, 0)
        })
    })
    .map_err(PyRuntimeError::new_err)?
    .map_err(value_error)
}

/// The compiled configurations `(grid side, N_θ)`.
#[pyfunction]
fn configurations() -> Vec<(usize, usize)> {
    hough_heading_recordings::engine::CONFIGURATIONS.to_vec()
}

/// The native module.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(images_json, m)?)?;
    m.add_function(wrap_pyfunction!(scans_json, m)?)?;
    m.add_function(wrap_pyfunction!(configurations, m)?)?;
    batch::register(m)?;
    reference::register(m)?;
    logs::register(m)?;
    Ok(())
}
