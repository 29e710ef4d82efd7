//! `hough-heading demo`: the estimator on the bundled data (`cli/data`,
//! embedded in the binary, so an installed tool runs it anywhere): synthetic
//! image pairs made by the project's scene generator, and a few real laser
//! scan pairs with ground truth.

use std::borrow::Cow;
use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::Args;
use hough_heading::Mode;
use hough_heading_recordings::answer::{images_result, place_images};
use hough_heading_recordings::engine::Engine;
use hough_heading_recordings::image::{self as images, Fit, Threshold};
use hough_heading_recordings::options::{engine_for, EstimatorArgs, ImageArgs, ModeArg};
use hough_heading_recordings::pairs::{self as scans, wrap_deg, PairRecord, RasterOptions, Truth};
use hough_heading_recordings::Fatal;
use serde::Deserialize;

use crate::input::{lines, read_input};

/// `demo`.
#[derive(Clone, Debug, Args)]
pub struct DemoArgs {
    /// Read the demo's files from this directory (laid out as `cli/data` of
    /// the source) instead of the copy bundled in the binary.
    #[arg(long, value_name = "DIR", conflicts_with = "write_data")]
    pub data: Option<PathBuf>,
    /// Write the bundled files into DIR (created) and exit, e.g. to try the
    /// other subcommands on them.
    #[arg(long, value_name = "DIR")]
    pub write_data: Option<PathBuf>,
}

/// Side of the bundled synthetic images.
pub const IMAGE_SIZE: usize = 128;

/// One bundled image pair: files (relative to the data directory) and truth.
#[derive(Clone, Debug, Deserialize)]
pub struct ImagePairSpec {
    /// Short name.
    pub name: String,
    /// What the scene is.
    pub about: String,
    /// Reference image file.
    pub a: String,
    /// Moved image file.
    pub b: String,
    /// True rotation of B relative to A, degrees (counter-clockwise).
    pub alpha_deg: f64,
    /// True translation, pixels (x right, y up).
    pub tx_px: f64,
    /// True translation y, pixels.
    pub ty_px: f64,
}

/// The manifest of the bundled images.
pub const IMAGES_MANIFEST: &str = "images/truth.json";
/// The bundled scan pairs (lines copied verbatim from `../shared/data`).
pub const SCANS_FILE: &str = "scans.jsonl";
/// One short note per line of [`SCANS_FILE`] (a JSON array of strings).
pub const SCANS_NOTES: &str = "scans.notes.json";

/// The demo's data files (`cli/data`, see its README), embedded: name
/// relative to the data directory, bytes.
pub const BUNDLED: [(&str, &[u8]); 12] = [
    (IMAGES_MANIFEST, include_bytes!("../data/images/truth.json")),
    (
        "images/polygon-a.pbm",
        include_bytes!("../data/images/polygon-a.pbm"),
    ),
    (
        "images/polygon-b.pbm",
        include_bytes!("../data/images/polygon-b.pbm"),
    ),
    (
        "images/room-a.pbm",
        include_bytes!("../data/images/room-a.pbm"),
    ),
    (
        "images/room-b.pbm",
        include_bytes!("../data/images/room-b.pbm"),
    ),
    (
        "images/l-shape-a.png",
        include_bytes!("../data/images/l-shape-a.png"),
    ),
    (
        "images/l-shape-b.png",
        include_bytes!("../data/images/l-shape-b.png"),
    ),
    (
        "images/corridor-a.pbm",
        include_bytes!("../data/images/corridor-a.pbm"),
    ),
    (
        "images/corridor-b.pbm",
        include_bytes!("../data/images/corridor-b.pbm"),
    ),
    (SCANS_FILE, include_bytes!("../data/scans.jsonl")),
    (SCANS_NOTES, include_bytes!("../data/scans.notes.json")),
    ("README.md", include_bytes!("../data/README.md")),
];

/// Where the demo reads its files.
#[derive(Clone, Copy, Debug)]
enum Source<'a> {
    /// [`BUNDLED`].
    Bundled,
    /// A directory with the layout of `cli/data`.
    Dir(&'a Path),
}

impl Source<'_> {
    /// The file's name for messages and its bytes.
    fn read(self, file: &str) -> Result<(String, Cow<'static, [u8]>), Fatal> {
        match self {
            Source::Bundled => BUNDLED
                .iter()
                .find(|(name, _)| *name == file)
                .map(|(name, bytes)| (format!("<bundled>/{name}"), Cow::Borrowed(*bytes)))
                .ok_or_else(|| Fatal::io(format!("<bundled>/{file}: not bundled"))),
            Source::Dir(dir) => {
                let path = dir.join(file);
                let bytes = read_input(&path)?;
                Ok((path.display().to_string(), Cow::Owned(bytes)))
            }
        }
    }
}

/// Writes [`BUNDLED`] into `dir` (created).
fn write_data(dir: &Path) -> Result<(), Fatal> {
    for (name, bytes) in BUNDLED {
        let path = dir.join(name);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent)
                .map_err(|e| Fatal::io(format!("{}: {e}", parent.display())))?;
        }
        std::fs::write(&path, bytes).map_err(|e| Fatal::io(format!("{}: {e}", path.display())))?;
    }
    eprintln!("wrote {} files to {}", BUNDLED.len(), dir.display());
    Ok(())
}

/// Runs the demo (or writes the bundled data out).
///
/// # Errors
/// When the data cannot be read (`--data`) or written (`--write-data`).
pub fn run(args: &DemoArgs) -> Result<(), Fatal> {
    if let Some(dir) = &args.write_data {
        return write_data(dir);
    }
    let source = args.data.as_deref().map_or(Source::Bundled, Source::Dir);
    let start = Instant::now();
    match source {
        Source::Bundled => {
            println!("hough-heading demo: the bundled data (cli/data, embedded in the binary)\n");
        }
        Source::Dir(dir) => println!("hough-heading demo: data in {}\n", dir.display()),
    }
    let (ok_images, n_images) = demo_images(source)?;
    let (ok_scans, n_scans) = demo_scans(source)?;
    println!(
        "\n✓ {ok_images}/{n_images} image pairs and {ok_scans}/{n_scans} scan pairs right: within 2° of the \
         truth, or flagged with the truth among the candidates; {:.2} s.",
        start.elapsed().as_secs_f64()
    );
    println!("Try:");
    let d = match source {
        Source::Bundled => {
            println!("  hough-heading demo --write-data demo-data");
            "demo-data".to_string()
        }
        Source::Dir(dir) => dir.display().to_string(),
    };
    println!("  hough-heading images {d}/images/polygon-a.pbm {d}/images/polygon-b.pbm");
    println!("  hough-heading scans {d}/{SCANS_FILE} --summary --compare");
    println!("  hough-heading plot scans {d}/{SCANS_FILE} --index 6 --out figures");
    Ok(())
}

fn demo_images(source: Source<'_>) -> Result<(usize, usize), Fatal> {
    let (manifest_name, manifest) = source.read(IMAGES_MANIFEST)?;
    let specs: Vec<ImagePairSpec> = serde_json::from_slice(&manifest)
        .map_err(|e| Fatal::io(format!("{manifest_name}: {e}")))?;
    println!("Synthetic image pairs ({IMAGE_SIZE}², N_θ = 360, improved mode; made by host-tests/src/scene.rs):");
    println!(
        "    {:<10} {:>8} {:>9} {:>7}  {:<20} {:>14} {:>14}",
        "pair", "true α", "α", "error", "status", "true t (px)", "t (px)"
    );
    let options = ImageArgs {
        size: None,
        fit: Fit::None,
        threshold: 128,
        invert: false,
        scale_search: None,
    };
    let estimator = EstimatorArgs {
        mode: ModeArg::Improved,
        n_theta: 360,
        rival_ratio: None,
        direction_margin: None,
        max_shift: None,
        no_verify: false,
        alignment_ratio: None,
        decision_gap: None,
        free_space_weight: None,
        no_free_space: false,
        min_overlap: None,
        search_budget: None,
    };
    let threshold = Threshold {
        level: options.threshold,
        invert: options.invert,
    };
    let mut ok = 0;
    for spec in &specs {
        let (a, a_bytes) = source.read(&spec.a)?;
        let (b, b_bytes) = source.read(&spec.b)?;
        let ia = images::decode(&a_bytes, &a, threshold)?;
        let ib = images::decode(&b_bytes, &b, threshold)?;
        let (mut engine, offsets) = place_images((&a, &ia), (&b, &ib), &options, &estimator)?;
        let r = images_result(engine.as_mut(), Mode::Improved, offsets);
        let error = wrap_deg(r.alpha_deg - spec.alpha_deg).abs();
        let right = error <= 2.0
            || (r.status != "confident"
                && r.candidates
                    .iter()
                    .any(|c| wrap_deg(c.alpha_deg - spec.alpha_deg).abs() <= 2.0));
        ok += usize::from(right);
        let t = match (r.tx_px, r.ty_px) {
            (Some(x), Some(y)) => format!("({x:+.1}, {y:+.1})"),
            _ => "–".into(),
        };
        println!(
            "  {} {:<10} {:>+7.1}° {:>+8.2}° {:>6.2}°  {:<20} {:>14} {:>14}  {}",
            mark(right),
            spec.name,
            spec.alpha_deg,
            r.alpha_deg,
            error,
            r.status,
            format!("({:+.1}, {:+.1})", spec.tx_px, spec.ty_px),
            t,
            spec.about
        );
    }
    Ok((ok, specs.len()))
}

fn demo_scans(source: Source<'_>) -> Result<(usize, usize), Fatal> {
    let (path, bytes) = source.read(SCANS_FILE)?;
    let mut engine: Box<dyn Engine> = engine_for(256, 360)?;
    // The `scans` command's defaults: segments between beams ≤ 0.3 m apart.
    let options = RasterOptions {
        cell: None,
        connect: Some(scans::DEFAULT_CONNECT_M),
        disc: false,
        beam_refine: true,
        beam_check: true,
    };
    println!("\nReal laser scan pairs (256², N_θ = 360, improved mode; window = p90 of ranges; see data/README.md):");
    let (notes_path, notes) = source.read(SCANS_NOTES)?;
    let notes: Vec<String> =
        serde_json::from_slice(&notes).map_err(|e| Fatal::io(format!("{notes_path}: {e}")))?;
    println!(
        "    {:<18} {:>8} {:>9} {:>7}  {:<20} {:>14} {:>14}",
        "pair", "true dθ", "dθ", "error", "status", "true d (m)", "d (m)"
    );
    let mut ok = 0;
    let all = lines(&bytes);
    for (i, line) in all.iter().enumerate() {
        let named = |e: String| Fatal::io(format!("{path}: line {}: {e}", i + 1));
        let pair: PairRecord = serde_json::from_slice(line).map_err(|e| named(e.to_string()))?;
        let truth: Truth = serde_json::from_slice(line).map_err(|e| named(e.to_string()))?;
        let name: Label = serde_json::from_slice(line).map_err(|e| named(e.to_string()))?;
        let estimates =
            scans::estimate(engine.as_mut(), &pair, &options, &[Mode::Improved]).map_err(named)?;
        let p = &estimates[0];
        let true_deg = truth.dtheta.to_degrees();
        let error = wrap_deg(p.dtheta_deg - true_deg).abs();
        let right = error <= 2.0
            || (p.estimate.status != hough_heading::Status::Confident
                && p.estimate
                    .candidates
                    .iter()
                    .any(|c| wrap_deg(-f64::from(c.alpha.to_degrees()) - true_deg).abs() <= 2.0));
        ok += usize::from(right);
        let d = p
            .translation
            .map_or("–".into(), |(x, y)| format!("({x:+.2}, {y:+.2})"));
        println!(
            "  {} {:<18} {:>+7.1}° {:>+8.2}° {:>6.2}°  {:<20} {:>14} {:>14}  {}",
            mark(right),
            format!(
                "{} #{}",
                name.dataset.split('-').next().unwrap_or(&name.dataset),
                name.pair_id.unwrap_or(i)
            ),
            true_deg,
            p.dtheta_deg,
            error,
            scans::status_name(p.estimate.status),
            format!("({:+.2}, {:+.2})", truth.dx, truth.dy),
            d,
            notes.get(i).map_or("", String::as_str),
        );
    }
    Ok((ok, all.len()))
}

/// ✓ or ✗.
fn mark(right: bool) -> char {
    if right {
        '✓'
    } else {
        '✗'
    }
}

/// Where a bundled scan pair comes from.
#[derive(Deserialize)]
struct Label {
    dataset: String,
    pair_id: Option<usize>,
}
