//! `Reference`: a grid prepared once (the library's `Reference`), stored as
//! bytes (`to_bytes` / `from_bytes`, the firmware's format) and estimated
//! against; the answer is the tool's `images` JSON
//! ([`hough_heading_recordings::answer::images_answer`]).

use hough_heading::config::{half_turn_steps, pyramid_words, rho_bins, row_words};
use hough_heading::{Estimate, Estimator, Grid, Mode, ScaleRange, Thresholds};
use hough_heading_recordings::answer::images_answer;
use hough_heading_recordings::engine::CONFIGURATIONS;
use hough_heading_recordings::image::Image;
use hough_heading_recordings::options::ModeArg;
use numpy::{PyArray2, PyReadonlyArray2};
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::PyBytes;

use crate::{image_of, on_big_stack, parse_options, value_error, ImageOptions};

/// How an estimate against a reference is made.
#[derive(Clone, Copy, Debug)]
pub struct Settings {
    /// Status thresholds.
    pub thresholds: Thresholds,
    /// Verification by alignment (improved mode).
    pub verify: bool,
    /// Scale search (improved mode).
    pub scale: Option<ScaleRange>,
}

/// A prepared reference of one compiled configuration.
trait AnyReference: Send + Sync {
    fn size(&self) -> usize;
    fn n_theta(&self) -> usize;
    fn mode(&self) -> Mode;
    fn bytes(&self) -> Vec<u8>;
    fn image(&self) -> Image;
    fn estimate(&self, image: &Image, settings: &Settings) -> Estimate;
}

struct Typed<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const HALF: usize,
    const RHO: usize,
    const PW: usize,
> {
    reference: hough_heading::Reference<W, H, RW, HALF, RHO>,
    mode: Mode,
}

impl<
        const W: usize,
        const H: usize,
        const RW: usize,
        const N: usize,
        const HALF: usize,
        const RHO: usize,
        const PW: usize,
    > Typed<W, H, RW, N, HALF, RHO, PW>
{
    fn grid(image: &Image) -> Grid<W, H, RW> {
        let mut grid = Grid::new();
        // The caller checked the image's size.
        let _ = grid.set_cells(image.occupied());
        grid
    }

    fn prepare(image: &Image, mode: Mode) -> Self {
        let mut estimator = Estimator::<W, H, RW, N, HALF, RHO, PW>::new(mode);
        Self {
            reference: estimator.reference(&Self::grid(image)),
            mode,
        }
    }

    fn from_bytes(bytes: &[u8]) -> Result<Self, String> {
        let reference = hough_heading::Reference::from_bytes(bytes).map_err(|e| format!("{e}"))?;
        // Byte 12 is the signature kind: 0 single-bin (paper), 1 two-bin.
        let mode = match bytes.get(12) {
            Some(0) => Mode::Paper,
            _ => Mode::Improved,
        };
        Ok(Self { reference, mode })
    }
}

impl<
        const W: usize,
        const H: usize,
        const RW: usize,
        const N: usize,
        const HALF: usize,
        const RHO: usize,
        const PW: usize,
    > AnyReference for Typed<W, H, RW, N, HALF, RHO, PW>
{
    fn size(&self) -> usize {
        W
    }

    fn n_theta(&self) -> usize {
        N
    }

    fn mode(&self) -> Mode {
        self.mode
    }

    fn bytes(&self) -> Vec<u8> {
        let mut out = vec![0; hough_heading::Reference::<W, H, RW, HALF, RHO>::BYTES];
        // The buffer has the length the reference needs.
        let n = self.reference.to_bytes(&mut out).unwrap_or(0);
        out.truncate(n);
        out
    }

    fn image(&self) -> Image {
        let mut image = Image::new(W, H);
        for (col, row) in self.reference.grid().occupied_cells() {
            image.set(col, row, true);
        }
        image
    }

    fn estimate(&self, image: &Image, settings: &Settings) -> Estimate {
        // As the tool's engine builds its estimators (`set_thresholds`,
        // `set_verification`, `set_scale_search`).
        let mut estimator = Estimator::<W, H, RW, N, HALF, RHO, PW>::new(self.mode)
            .with_thresholds(settings.thresholds);
        if self.mode == Mode::Improved {
            estimator = estimator.with_verification(settings.verify);
            estimator.set_scale_search(settings.scale);
        }
        estimator.estimate(&self.reference, &Self::grid(image))
    }
}

macro_rules! typed {
    ($(($size:literal, $n:literal)),* $(,)?) => {
        fn prepare_any(size: usize, n_theta: usize, image: &Image, mode: Mode) -> Option<Box<dyn AnyReference>> {
            match (size, n_theta) {
                $(($size, $n) => Some(Box::new(Typed::<
                    $size, $size, { row_words($size) }, $n, { half_turn_steps($n) },
                    { rho_bins($size, $size) }, { pyramid_words($size, $size) },
                >::prepare(image, mode))),)*
                _ => None,
            }
        }

        fn from_bytes_any(size: usize, n_theta: usize, bytes: &[u8]) -> Option<Result<Box<dyn AnyReference>, String>> {
            match (size, n_theta) {
                $(($size, $n) => Some(Typed::<
                    $size, $size, { row_words($size) }, $n, { half_turn_steps($n) },
                    { rho_bins($size, $size) }, { pyramid_words($size, $size) },
                >::from_bytes(bytes).map(|r| Box::new(r) as Box<dyn AnyReference>)),)*
                _ => None,
            }
        }
    };
}

// The configurations the tool is compiled for, from their one list.
hough_heading_recordings::with_configurations!(typed);

fn configurations_text() -> String {
    let list: Vec<String> = CONFIGURATIONS
        .iter()
        .map(|(s, n)| format!("{s}×{s}/{n}"))
        .collect();
    list.join(", ")
}

fn mode_of(name: &str) -> PyResult<Mode> {
    match name {
        "improved" => Ok(Mode::Improved),
        "paper" => Ok(Mode::Paper),
        other => Err(value_error(format!(
            "mode={other:?}: expected 'improved' or 'paper'"
        ))),
    }
}

fn mode_name(mode: Mode) -> &'static str {
    match mode {
        Mode::Improved => "improved",
        Mode::Paper => "paper",
    }
}

/// A prepared reference grid (native half of `hough_heading.Reference`).
#[pyclass(frozen, module = "hough_heading._core")]
pub struct NativeReference {
    inner: Box<dyn AnyReference>,
}

#[pymethods]
impl NativeReference {
    /// Prepares a square grid of a compiled size (`uint8` 0/1, row 0 at the top).
    #[staticmethod]
    fn prepare(
        py: Python<'_>,
        grid: PyReadonlyArray2<'_, u8>,
        n_theta: usize,
        mode: &str,
    ) -> PyResult<Self> {
        let mode = mode_of(mode)?;
        let image = image_of("grid", &grid)?;
        let size = image.width;
        if image.height != size || !CONFIGURATIONS.contains(&(size, n_theta)) {
            return Err(value_error(format!(
                "grid is {}×{} with n_theta={n_theta}; compiled (side/n_theta): {}",
                image.height,
                image.width,
                configurations_text()
            )));
        }
        let inner = py
            .detach(|| on_big_stack(|| prepare_any(size, n_theta, &image, mode)))
            .map_err(PyRuntimeError::new_err)?
            .ok_or_else(|| value_error("no such configuration"))?;
        Ok(Self { inner })
    }

    /// Reads a reference written by `to_bytes` (or by the library on a robot).
    #[staticmethod]
    fn from_bytes(py: Python<'_>, bytes: &[u8]) -> PyResult<Self> {
        let u16_at = |at: usize| {
            bytes
                .get(at..at + 2)
                .map(|b| usize::from(u16::from_le_bytes([b[0], b[1]])))
        };
        let (Some(width), Some(height), Some(half)) = (u16_at(4), u16_at(6), u16_at(8)) else {
            return Err(value_error(format!(
                "{} bytes: too short for a reference header",
                bytes.len()
            )));
        };
        if !bytes.starts_with(b"HHR") {
            return Err(value_error(
                "not a hough-heading reference (the bytes do not start with 'HHR')",
            ));
        }
        let n_theta = 2 * half;
        if width != height || !CONFIGURATIONS.contains(&(width, n_theta)) {
            return Err(value_error(format!(
                "a reference of a {width}×{height} grid with n_theta={n_theta}: not compiled \
                 in; compiled (side/n_theta): {}",
                configurations_text()
            )));
        }
        let bytes = bytes.to_vec();
        let inner = py
            .detach(|| on_big_stack(|| from_bytes_any(width, n_theta, &bytes)))
            .map_err(PyRuntimeError::new_err)?
            .ok_or_else(|| value_error("no such configuration"))?
            .map_err(|e| value_error(format!("{width}×{width}, n_theta={n_theta}: {e}")))?;
        Ok(Self { inner })
    }

    /// The reference as bytes (the library's `Reference::to_bytes`).
    fn to_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, &self.inner.bytes())
    }

    /// Grid side, cells.
    #[getter]
    fn size(&self) -> usize {
        self.inner.size()
    }

    /// θ steps over the full circle.
    #[getter]
    fn n_theta(&self) -> usize {
        self.inner.n_theta()
    }

    /// `'improved'` or `'paper'` (the mode it was prepared for).
    #[getter]
    fn mode(&self) -> &'static str {
        mode_name(self.inner.mode())
    }

    /// The reference grid, `size × size` booleans, row 0 at the top.
    #[getter]
    fn grid<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<bool>>> {
        let image = self.inner.image();
        let rows: Vec<Vec<bool>> = (0..image.height)
            .map(|r| (0..image.width).map(|c| image.get(c, r)).collect())
            .collect();
        PyArray2::from_vec2(py, &rows).map_err(|e| value_error(e.to_string()))
    }

    /// The tool's `images` JSON for `image` estimated against this
    /// reference, with the tool's options `args` (`--mode` must match).
    fn estimate_json(
        &self,
        py: Python<'_>,
        image: PyReadonlyArray2<'_, u8>,
        args: Vec<String>,
    ) -> PyResult<String> {
        let options: ImageOptions = parse_options(&args)?;
        let image = image_of("image", &image)?;
        let size = self.inner.size();
        if image.width != size || image.height != size {
            return Err(value_error(format!(
                "image is {}×{}; this reference is {size}×{size} (n_theta={})",
                image.height,
                image.width,
                self.inner.n_theta()
            )));
        }
        let asked = match options.estimator.mode {
            ModeArg::Improved => Mode::Improved,
            ModeArg::Paper => Mode::Paper,
        };
        if asked != self.inner.mode() {
            return Err(value_error(format!(
                "mode={:?}: this reference was prepared for mode={:?}",
                mode_name(asked),
                mode_name(self.inner.mode())
            )));
        }
        if options.estimator.n_theta != self.inner.n_theta() {
            return Err(value_error(format!(
                "n_theta={}: this reference has n_theta={}",
                options.estimator.n_theta,
                self.inner.n_theta()
            )));
        }
        let settings = Settings {
            thresholds: options.estimator.thresholds().map_err(value_error)?,
            verify: !options.estimator.no_verify,
            scale: options.image.scale_range().map_err(value_error)?,
        };
        if image.count() == 0 {
            return Err(value_error("image: no occupied cell"));
        }
        let inner = &self.inner;
        let e = py
            .detach(|| on_big_stack(|| inner.estimate(&image, &settings)))
            .map_err(PyRuntimeError::new_err)?;
        let answer = images_answer(&e, size, inner.n_theta(), [(0.0, 0.0); 2]);
        serde_json::to_string(&answer).map_err(|e| value_error(format!("JSON output: {e}")))
    }
}

/// Adds the class to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<NativeReference>()
}
