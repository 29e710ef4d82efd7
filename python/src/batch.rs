//! Many pairs in one call: the GIL is released and the pairs are spread
//! over threads, each with an engine of its own.

use std::sync::atomic::{AtomicUsize, Ordering};

use hough_heading::Mode;
use hough_heading_recordings::engine::Engine;
use hough_heading_recordings::line::OutputLine;
use hough_heading_recordings::pairs::PairRecord;
use numpy::PyReadonlyArray2;
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;

use crate::{
    image_of, images_text, parse_options, record_of, scan_answer, value_error, GridIn,
    ImageOptions, ScanAnswer, ScanGrid, ScanIn, ScanOptions, STACK_BYTES,
};

/// Threads to use: `threads`, or every core when 0; never more than `jobs`.
pub fn thread_count(threads: usize, jobs: usize) -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let wanted = if threads == 0 { cores } else { threads };
    wanted.clamp(1, jobs.max(1))
}

/// Runs `work(state, i)` for every `i < jobs` on `threads` threads, each
/// with its own `state` from `init`; the results in the order of `i`.
///
/// # Errors
/// When a thread cannot start, `init` fails, or a job panics.
pub fn run_parallel<S, T: Send>(
    jobs: usize,
    threads: usize,
    init: impl Fn() -> Result<S, String> + Sync,
    work: impl Fn(&mut S, usize) -> T + Sync,
) -> Result<Vec<T>, String> {
    let next = AtomicUsize::new(0);
    let parts: Vec<Result<Vec<(usize, T)>, String>> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..thread_count(threads, jobs))
            .map(|k| {
                std::thread::Builder::new()
                    .name(format!("hough-heading-{k}"))
                    .stack_size(STACK_BYTES)
                    .spawn_scoped(scope, || {
                        let mut state = init()?;
                        let mut done = Vec::new();
                        loop {
                            let i = next.fetch_add(1, Ordering::Relaxed);
                            if i >= jobs {
                                return Ok(done);
                            }
                            done.push((i, work(&mut state, i)));
                        }
                    })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| match h {
                Ok(h) => h.join().unwrap_or_else(|_| {
                    Err("internal error: the estimator panicked (please report it)".into())
                }),
                Err(e) => Err(format!("cannot start a thread: {e}")),
            })
            .collect()
    });
    let mut slots: Vec<Option<T>> = (0..jobs).map(|_| None).collect();
    for part in parts {
        for (i, value) in part? {
            slots[i] = Some(value);
        }
    }
    slots
        .into_iter()
        .enumerate()
        .map(|(i, s)| s.ok_or_else(|| format!("internal error: pair {i} was not estimated")))
        .collect()
}

/// `scans` of the tool on many pairs: one JSON line each (index = position;
/// a failed pair is the tool's `"status": "error"` line), with the extras.
#[pyfunction]
#[pyo3(signature = (pairs, args, grid, threads))]
fn scans_json_batch(
    py: Python<'_>,
    pairs: Vec<(ScanIn<'_>, ScanIn<'_>)>,
    args: Vec<String>,
    grid: GridIn,
    threads: usize,
) -> PyResult<Vec<ScanAnswer>> {
    let options: ScanOptions = parse_options(&args)?;
    let nan_ok = grid.4;
    let grid = ScanGrid::new(&grid)?;
    // Unknown configurations and bad thresholds fail here, once.
    options.estimator.engine(grid.size).map_err(value_error)?;
    let records = pairs
        .iter()
        .enumerate()
        .map(|(i, (a, b))| {
            Ok(PairRecord {
                scan1: record_of(&format!("pair {i}: scan1"), a, nan_ok)?,
                scan2: record_of(&format!("pair {i}: scan2"), b, nan_ok)?,
            })
        })
        .collect::<PyResult<Vec<_>>>()?;
    let mode: Mode = options.estimator.mode.into();
    py.detach(|| {
        run_parallel(
            records.len(),
            threads,
            || {
                options
                    .estimator
                    .engine(grid.size)
                    .map_err(|e| e.to_string())
            },
            |engine: &mut Box<dyn Engine>, i| {
                scan_answer(engine.as_mut(), &records[i], &grid, mode, None, i).unwrap_or_else(
                    |message| {
                        let line = serde_json::to_string(&OutputLine::error(i, message))
                            .unwrap_or_default();
                        (line, None)
                    },
                )
            },
        )
    })
    .map_err(PyRuntimeError::new_err)
}

/// `images` of the tool on many pairs: `(True, JSON)` or `(False, message)`
/// per pair, in order.
#[pyfunction]
#[pyo3(signature = (pairs, args, threads))]
fn images_json_batch(
    py: Python<'_>,
    pairs: Vec<(PyReadonlyArray2<'_, u8>, PyReadonlyArray2<'_, u8>)>,
    args: Vec<String>,
    threads: usize,
) -> PyResult<Vec<(bool, String)>> {
    let options: ImageOptions = parse_options(&args)?;
    let images = pairs
        .iter()
        .enumerate()
        .map(|(i, (a, b))| {
            Ok((
                image_of(&format!("pair {i}: a"), a)?,
                image_of(&format!("pair {i}: b"), b)?,
            ))
        })
        .collect::<PyResult<Vec<_>>>()?;
    py.detach(|| {
        run_parallel(
            images.len(),
            threads,
            || Ok(()),
            |_: &mut (), i| match images_text(&images[i].0, &images[i].1, &options) {
                Ok(text) => (true, text),
                Err(message) => (false, format!("pair {i}: {message}")),
            },
        )
    })
    .map_err(PyRuntimeError::new_err)
}

/// Adds the batch functions to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(scans_json_batch, m)?)?;
    m.add_function(wrap_pyfunction!(images_json_batch, m)?)?;
    Ok(())
}
