//! The tool's binary images: reading them (PBM `P1`/`P4`, PNG, other PNM)
//! and fitting them to a supported grid size.

use std::io::{BufRead, Cursor, Seek};
use std::path::Path;

use image::{ImageFormat, ImageReader};

use crate::error::Fatal;

/// A binary image, row-major, `true` = occupied.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Image {
    /// Number of columns `W`.
    pub width: usize,
    /// Number of rows `H`.
    pub height: usize,
    /// `W × H` cells, row-major: cell `(col, row)` is `pixels[row * W + col]`.
    pixels: Vec<bool>,
}

impl Image {
    /// An empty (all free) `width × height` image.
    pub fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            pixels: vec![false; width * height],
        }
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
}

/// How an image becomes occupied cells.
#[derive(Clone, Copy, Debug)]
pub struct Threshold {
    /// A pixel is occupied when its grey level (0–255, after compositing any
    /// alpha over white) is below this (dark = occupied, as in PBM where 1 is
    /// black).
    pub level: u8,
    /// Occupied = bright instead (white-on-black images).
    pub invert: bool,
}

/// Reads `path` as a binary image: grey levels are thresholded, colour is
/// converted to grey first.
///
/// # Errors
/// A message naming the file when it cannot be read or decoded (truncated,
/// unknown format), or has no occupied pixel.
pub fn read(path: &Path, threshold: Threshold) -> Result<Image, Fatal> {
    let name = path.display().to_string();
    let reader =
        ImageReader::open(path).map_err(|e| Fatal::io(format!("{name}: cannot open: {e}")))?;
    from_reader(reader, &name, threshold)
}

/// Decodes the bytes of an image file named `name` (its extension is the
/// format's first guess, as for a file; the bytes decide when they can).
///
/// # Errors
/// As [`read`].
pub fn decode(bytes: &[u8], name: &str, threshold: Threshold) -> Result<Image, Fatal> {
    let mut reader = ImageReader::new(Cursor::new(bytes));
    if let Ok(format) = ImageFormat::from_path(name) {
        reader.set_format(format);
    }
    from_reader(reader, name, threshold)
}

fn from_reader<R: BufRead + Seek>(
    reader: ImageReader<R>,
    name: &str,
    threshold: Threshold,
) -> Result<Image, Fatal> {
    let decoded = reader
        .with_guessed_format()
        .map_err(|e| Fatal::io(format!("{name}: cannot read: {e}")))?
        .decode()
        .map_err(|e| Fatal::io(format!("{name}: not a readable PBM/PNG image: {e}")))?;
    let grey = decoded.to_luma_alpha8();
    let (width, height) = (grey.width() as usize, grey.height() as usize);
    let mut image = Image::new(width, height);
    for (col, row, px) in grey.enumerate_pixels() {
        let [luma, alpha] = px.0;
        // Composite over white: transparent pixels are free.
        let level = (u32::from(luma) * u32::from(alpha) + 255 * (255 - u32::from(alpha))) / 255;
        let dark = level < u32::from(threshold.level);
        if dark != threshold.invert {
            image.set(col as usize, row as usize, true);
        }
    }
    if image.count() == 0 {
        return Err(Fatal::io(format!(
            "{name}: no occupied pixel ({width}×{height}, threshold {}{}); \
             try --threshold or --invert",
            threshold.level,
            if threshold.invert { ", inverted" } else { "" }
        )));
    }
    Ok(image)
}

/// How to bring an image to the grid size.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Fit {
    /// The image must already have the grid's size.
    None,
    /// Centre the image in the grid; cells beyond the grid are dropped
    /// (pads a smaller image, crops a larger one).
    Centre,
}

/// An image placed in a `size × size` grid, with the offset that maps its own
/// centred coordinates to the grid's: `p_grid = p_image + offset` (pixels,
/// y up).
#[derive(Clone, Debug)]
pub struct Placed {
    /// The fitted image, `size × size`.
    pub image: Image,
    /// `(ox, oy)`.
    pub offset: (f64, f64),
    /// Occupied pixels that fell outside the grid (cropping).
    pub cropped: usize,
}

/// Places `image` (read from `name`) in a `size × size` grid.
///
/// # Errors
/// With [`Fit::None`], when the image is not `size × size`; when nothing is
/// left after cropping.
pub fn place(image: &Image, name: &str, size: usize, fit: Fit) -> Result<Placed, Fatal> {
    if fit == Fit::None && (image.width != size || image.height != size) {
        return Err(Fatal::io(format!(
            "{name}: image is {}×{}, the grid is {size}×{size}; use an image of a supported \
             size (--size, see --help) or --fit centre to pad/crop it",
            image.width, image.height
        )));
    }
    // Integer placement: column c of the image goes to c + left.
    let left = (size as i64 - image.width as i64).div_euclid(2);
    let top = (size as i64 - image.height as i64).div_euclid(2);
    let mut out = Image::new(size, size);
    let mut cropped = 0;
    for (col, row) in image.occupied() {
        let (c, r) = (col as i64 + left, row as i64 + top);
        if (0..size as i64).contains(&c) && (0..size as i64).contains(&r) {
            out.set(c as usize, r as usize, true);
        } else {
            cropped += 1;
        }
    }
    if out.count() == 0 {
        return Err(Fatal::io(format!(
            "{name}: no occupied pixel left inside the {size}×{size} grid"
        )));
    }
    // x_grid = c + left − (S−1)/2 = x_image + (W−1)/2 + left − (S−1)/2; y likewise, negated.
    let ox = left as f64 + (image.width as f64 - 1.0) / 2.0 - (size as f64 - 1.0) / 2.0;
    let oy = -(top as f64 + (image.height as f64 - 1.0) / 2.0 - (size as f64 - 1.0) / 2.0);
    Ok(Placed {
        image: out,
        offset: (ox, oy),
        cropped,
    })
}

/// The translation in the images' own centred coordinates from the one
/// measured on the placed grids: with `p₁' = p₁ + c₁`, `p₂' = p₂ + c₂` and
/// `p₂' = s·R(α)p₁' + t'`, `t = t' + s·R(α)c₁ − c₂`.
pub fn unplace_translation(
    t: (f64, f64),
    alpha_rad: f64,
    scale: f64,
    c1: (f64, f64),
    c2: (f64, f64),
) -> (f64, f64) {
    let (s, c) = alpha_rad.sin_cos();
    (
        t.0 + scale * (c * c1.0 - s * c1.1) - c2.0,
        t.1 + scale * (s * c1.0 + c * c1.1) - c2.1,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn placement_offset_matches_the_centred_coordinates() {
        let mut image = Image::new(5, 3);
        image.set(4, 0, true);
        let placed = place(&image, "x", 8, Fit::Centre).unwrap();
        let (col, row) = placed.image.occupied()[0];
        let (xi, yi) = image.coords(4, 0);
        let (xg, yg) = placed.image.coords(col, row);
        assert_eq!((xg - xi, yg - yi), placed.offset);
    }

    #[test]
    fn translation_is_mapped_back() {
        // A point p1 in A, p2 = k·R p1 + t in B; both images shifted.
        for k in [1.0, 1.1] {
            let (alpha, t) = (0.7f64, (3.0, -2.0));
            let (c1, c2) = ((0.5, -1.0), (-0.5, 0.5));
            let (s, c) = alpha.sin_cos();
            let map = |p: (f64, f64), t: (f64, f64)| {
                (k * (c * p.0 - s * p.1) + t.0, k * (s * p.0 + c * p.1) + t.1)
            };
            let p1 = (2.0, 1.0);
            let p2 = map(p1, t);
            let (q1, q2) = ((p1.0 + c1.0, p1.1 + c1.1), (p2.0 + c2.0, p2.1 + c2.1));
            let rq1 = map(q1, (0.0, 0.0));
            let t_placed = (q2.0 - rq1.0, q2.1 - rq1.1);
            let back = unplace_translation(t_placed, alpha, k, c1, c2);
            assert!((back.0 - t.0).abs() < 1e-12 && (back.1 - t.1).abs() < 1e-12);
        }
    }
}
