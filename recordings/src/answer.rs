//! The `images` answer: α, status, candidates and translation of image B
//! relative to image A, as JSON or as text.

use std::path::Path;

use hough_heading::{Estimate, Mode};
use serde::Serialize;

use crate::engine::{self, Engine, View};
use crate::error::Fatal;
use crate::image::{self, Fit, Threshold};
use crate::options::{EstimatorArgs, ImageArgs, ModeArg};
use crate::pairs::{round, status_name};

/// The result of `images`: α, status, candidates and translation of B
/// relative to A.
#[derive(Clone, Debug, Serialize)]
pub struct ImagesResult {
    /// Rotation of B relative to A, counter-clockwise, degrees in (−180, 180].
    pub alpha_deg: f64,
    /// Status word.
    pub status: &'static str,
    /// Confidence in [0, 1].
    pub confidence: f64,
    /// Candidate rotations, strongest first.
    pub candidates: Vec<CandidateJson>,
    /// Share of B's sampled cells the chosen pose puts within one cell of A
    /// (verification on).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub overlap: Option<f64>,
    /// Translation x, pixels (null when not estimated).
    pub tx_px: Option<f64>,
    /// Translation y (up), pixels.
    pub ty_px: Option<f64>,
    /// Scale of B relative to A (1 unless `--scale-search`; null when no
    /// translation was estimated).
    pub scale: Option<f64>,
    /// How well the columns agree on the translation: weighted RMS, pixels.
    pub residual_px: Option<f64>,
    /// Profile columns the translation fit kept: 3 or more cross-check each
    /// other, 2 determine it exactly (residual 0, unchecked).
    pub columns: Option<u8>,
    /// Unit vector along which the translation is not observable (a
    /// corridor), `[x, y]`; null when it is fully observable.
    pub unobservable: Option<[f64; 2]>,
    /// Grid side used.
    pub size: usize,
    /// θ steps used.
    pub n_theta: usize,
}

/// One candidate in the `images` JSON.
#[derive(Clone, Debug, Serialize)]
pub struct CandidateJson {
    /// Rotation, degrees.
    pub alpha_deg: f64,
    /// Correlation × direction share, in [0, 1].
    pub score: f64,
    /// How well this rotation's best translation aligns B onto A, in [0, 1]
    /// (verification on).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub alignment: Option<f64>,
    /// The decision score: both-way alignment on a large sample
    /// (verification on; candidates are sorted by it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub support: Option<f64>,
}

/// An engine holding two images, and each image's offset in the grid
/// (`p_grid = p_image + offset`, see [`image::Placed`]).
pub type Loaded = (Box<dyn Engine>, [(f64, f64); 2]);

/// Reads A and B and places both on a common grid: the engine holds them.
pub fn load_images(
    a: &Path,
    b: &Path,
    args: &ImageArgs,
    estimator: &EstimatorArgs,
) -> Result<Loaded, Fatal> {
    let threshold = Threshold {
        level: args.threshold,
        invert: args.invert,
    };
    let ia = image::read(a, threshold)?;
    let ib = image::read(b, threshold)?;
    place_images(
        (&a.display().to_string(), &ia),
        (&b.display().to_string(), &ib),
        args,
        estimator,
    )
}

/// Places two decoded images, each with its file name (for messages), on a
/// common grid: the engine holds them.
pub fn place_images(
    (a, ia): (&str, &image::Image),
    (b, ib): (&str, &image::Image),
    args: &ImageArgs,
    estimator: &EstimatorArgs,
) -> Result<Loaded, Fatal> {
    let supported = engine::sizes();
    let size = match args.size {
        Some(s) => s,
        None if args.fit == Fit::None => {
            if ia.width == ia.height && supported.contains(&ia.width) {
                ia.width
            } else {
                return Err(Fatal::io(format!(
                    "{}: image is {}×{}; supported grids are square, side {:?}: use --fit centre \
                     to pad/crop, or resize the image",
                    a, ia.width, ia.height, supported
                )));
            }
        }
        None => {
            let need = ia.width.max(ia.height).max(ib.width).max(ib.height);
            supported
                .iter()
                .copied()
                .find(|&s| s >= need)
                .unwrap_or(*supported.last().unwrap_or(&256))
        }
    };
    let mut engine = estimator.engine(size)?;
    engine.set_scale_search(args.scale_range()?);
    let pa = image::place(ia, a, size, args.fit)?;
    let pb = image::place(ib, b, size, args.fit)?;
    for (name, p) in [(a, &pa), (b, &pb)] {
        if p.cropped > 0 {
            eprintln!(
                "hough-heading: {}: {} occupied pixel(s) outside the {size}×{size} grid were cropped",
                name,
                p.cropped
            );
        }
    }
    engine.load(View::First, &pa.image);
    engine.load(View::Second, &pb.image);
    Ok((engine, [pa.offset, pb.offset]))
}

/// Estimates on two loaded images; the translation is mapped back to the
/// images' own centred coordinates.
pub fn images_result(
    engine: &mut dyn Engine,
    mode: Mode,
    offsets: [(f64, f64); 2],
) -> ImagesResult {
    let e = engine.estimate(mode);
    images_answer(&e, engine.size(), engine.n_theta(), offsets)
}

/// The `images` answer of an estimate on two grids of `size` cells and
/// `n_theta` θ steps (also for an estimate against a prepared reference);
/// the translation is mapped back to the images' own centred coordinates.
pub fn images_answer(
    e: &Estimate,
    size: usize,
    n_theta: usize,
    offsets: [(f64, f64); 2],
) -> ImagesResult {
    let alpha = f64::from(e.alpha.to_degrees());
    let t = e.translation.map(|t| {
        image::unplace_translation(
            (t.x.to_num::<f64>(), t.y.to_num::<f64>()),
            alpha.to_radians(),
            t.scale.to_num(),
            offsets[0],
            offsets[1],
        )
    });
    ImagesResult {
        alpha_deg: round(alpha, 4),
        status: status_name(e.status),
        confidence: round(e.confidence.to_num::<f64>(), 4),
        candidates: e
            .candidates
            .iter()
            .map(|c| CandidateJson {
                alpha_deg: round(f64::from(c.alpha.to_degrees()), 4),
                score: round(c.score.to_num::<f64>(), 4),
                alignment: c.alignment.map(|a| round(a.to_num::<f64>(), 4)),
                support: c.support.map(|a| round(a.to_num::<f64>(), 4)),
            })
            .collect(),
        overlap: e
            .candidates
            .iter()
            .any(|c| c.alignment.is_some())
            .then(|| round(e.overlap.to_num::<f64>(), 4)),
        tx_px: t.map(|t| round(t.0, 3)),
        ty_px: t.map(|t| round(t.1, 3)),
        scale: e.translation.map(|t| round(t.scale.to_num::<f64>(), 4)),
        residual_px: e.translation.map(|t| round(t.residual.to_num::<f64>(), 3)),
        columns: e.translation.map(|t| t.columns),
        unobservable: e
            .translation
            .and_then(|t| t.unobservable)
            .map(|(x, y)| [round(x.to_num::<f64>(), 4), round(y.to_num::<f64>(), 4)]),
        size,
        n_theta,
    }
}

/// The human-readable report of an `images` result.
pub fn describe_images(r: &ImagesResult, mode: ModeArg) -> String {
    let candidates: Vec<String> = r
        .candidates
        .iter()
        .map(|c| match c.alignment {
            Some(a) => format!("{:+.2}° (alignment {a:.2})", c.alpha_deg),
            None => format!("{:+.2}° ({:.2})", c.alpha_deg, c.score),
        })
        .collect();
    let translation = match (r.tx_px, r.ty_px) {
        (Some(x), Some(y)) => {
            let mut text = format!("tx = {x:+.2} px, ty = {y:+.2} px (x right, y up)");
            if let Some(residual) = r.residual_px {
                text.push_str(&format!(", residual {residual:.2} px"));
            }
            match r.columns {
                Some(c @ 3..) => text.push_str(&format!(" over {c} columns")),
                Some(c) => text.push_str(&format!(" over {c} column(s): not cross-checked")),
                None => {}
            }
            if let Some([ux, uy]) = r.unobservable {
                text.push_str(&format!(
                    "; not observable along ({ux:+.2}, {uy:+.2}): only the component across it"
                ));
            }
            text
        }
        _ => "not estimated (paper mode, or the rotation is not resolved)".into(),
    };
    let scale = match r.scale {
        Some(s) => format!("{s:.4}"),
        None => "–".into(),
    };
    let mode = match mode {
        ModeArg::Improved => "improved",
        ModeArg::Paper => "paper",
    };
    format!(
        "rotation of B relative to A: {:+.2}° (counter-clockwise)\n\
         status:      {} (confidence {:.2}{})\n\
         candidates:  {}\n\
         translation: {translation}\n\
         scale:       {scale}\n\
         grid:        {size}×{size}, N_θ = {}, {mode} mode",
        r.alpha_deg,
        r.status,
        r.confidence,
        r.overlap
            .map_or(String::new(), |o| format!(", overlap {o:.2}")),
        candidates.join(", "),
        r.n_theta,
        size = r.size,
    )
}
