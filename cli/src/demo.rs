//! `hough-heading demo`: the estimator on the bundled data
//! (`host-tests/data`): synthetic image pairs made by the project's scene
//! generator, and a few real laser scan pairs with ground truth.

use std::path::{Path, PathBuf};
use std::time::Instant;

use hough_heading::Mode;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::engine::Engine;
use super::images::Fit;
use super::scans::{self, wrap_deg, PairRecord, RasterOptions, Truth};
use super::{
    engine_for, images_result, lines, load_images, read_input, DemoArgs, EstimatorArgs, Fatal,
    ImageArgs, ModeArg,
};
use crate::reference::Image;
use crate::scene::{self, Damage, PbmFormat, Scene, Transform};

/// The bundled data, found from the source tree (works from the repo root
/// and from `host-tests/`).
pub const DATA_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/data");

/// Side of the bundled synthetic images.
pub const IMAGE_SIZE: usize = 128;

/// One bundled image pair: files (relative to the data directory) and truth.
#[derive(Clone, Debug, Serialize, Deserialize)]
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

/// The synthetic pairs: spec, scene, damage and seed. Deterministic.
pub fn image_pairs() -> Vec<(ImagePairSpec, Scene, Damage, u64)> {
    let rng = |seed| ChaCha8Rng::seed_from_u64(seed);
    let spec = |name: &str, about: &str, ext: &str, alpha: f64, t: (f64, f64)| ImagePairSpec {
        name: name.into(),
        about: about.into(),
        a: format!("images/{name}-a.{ext}"),
        b: format!("images/{name}-b.{ext}"),
        alpha_deg: alpha,
        tx_px: t.0,
        ty_px: t.1,
    };
    vec![
        (
            spec(
                "polygon",
                "random polygon, moderate damage",
                "pbm",
                37.0,
                (4.0, -3.0),
            ),
            scene::random_polygon(&mut rng(11)),
            Damage::MODERATE,
            101,
        ),
        (
            spec(
                "room",
                "Manhattan room with furniture, moderate damage",
                "pbm",
                -120.0,
                (-5.0, 2.0),
            ),
            scene::manhattan_room(&mut rng(12)),
            Damage::MODERATE,
            102,
        ),
        (
            spec("l-shape", "an L, clean (PNG)", "png", -160.0, (3.0, 6.0)),
            scene::l_shape(1.6, 0.9),
            Damage::CLEAN,
            103,
        ),
        (
            spec(
                "corridor",
                "corridor: α and α + 180° look alike",
                "pbm",
                60.0,
                (2.0, 0.0),
            ),
            scene::corridor(&mut rng(14)),
            Damage::MODERATE,
            104,
        ),
    ]
}

/// Renders the synthetic pairs: `(spec, A, B)`.
pub fn render_image_pairs() -> Vec<(ImagePairSpec, Image, Image)> {
    image_pairs()
        .into_iter()
        .map(|(spec, scene, damage, seed)| {
            let transform = Transform {
                alpha_rad: spec.alpha_deg.to_radians(),
                tx: spec.tx_px,
                ty: spec.ty_px,
                scale: 1.0,
            };
            let pair =
                scene::render_pair(&scene, &transform, &damage, IMAGE_SIZE, IMAGE_SIZE, seed);
            (spec, pair.i1.image, pair.i2.image)
        })
        .collect()
}

/// The bytes of a bundled image file: P4 PBM for `.pbm` (P1 for the room, to
/// bundle both encodings), PNG for `.png` (black = occupied).
pub fn encode(image: &Image, file: &str) -> Result<Vec<u8>, Fatal> {
    if file.ends_with(".png") {
        let grey = image::GrayImage::from_fn(image.width as u32, image.height as u32, |c, r| {
            image::Luma([if image.get(c as usize, r as usize) {
                0
            } else {
                255
            }])
        });
        let mut bytes = Vec::new();
        grey.write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )
        .map_err(|e| Fatal::io(format!("{file}: {e}")))?;
        Ok(bytes)
    } else if file.contains("room") {
        Ok(scene::to_pbm(image, PbmFormat::Ascii))
    } else {
        Ok(scene::to_pbm(image, PbmFormat::Binary))
    }
}

fn regenerate(dir: &Path) -> Result<(), Fatal> {
    std::fs::create_dir_all(dir.join("images"))
        .map_err(|e| Fatal::io(format!("{}: {e}", dir.display())))?;
    let mut specs = Vec::new();
    for (spec, a, b) in render_image_pairs() {
        for (file, image) in [(&spec.a, &a), (&spec.b, &b)] {
            let path = dir.join(file);
            std::fs::write(&path, encode(image, file)?)
                .map_err(|e| Fatal::io(format!("{}: {e}", path.display())))?;
        }
        specs.push(spec);
    }
    let manifest = serde_json::to_string_pretty(&specs).map_err(|e| Fatal::io(e.to_string()))?;
    let path = dir.join(IMAGES_MANIFEST);
    std::fs::write(&path, manifest + "\n")
        .map_err(|e| Fatal::io(format!("{}: {e}", path.display())))?;
    eprintln!("wrote {} image pairs to {}", specs.len(), dir.display());
    Ok(())
}

/// Runs the demo (or regenerates the bundled images).
///
/// # Errors
/// When the bundled data cannot be read.
pub fn run(args: &DemoArgs) -> Result<(), Fatal> {
    if args.regenerate {
        return regenerate(&args.data);
    }
    let start = Instant::now();
    println!("hough-heading demo: data in {}\n", args.data.display());
    let (ok_images, n_images) = demo_images(&args.data)?;
    let (ok_scans, n_scans) = demo_scans(&args.data)?;
    println!(
        "\n✓ {ok_images}/{n_images} image pairs and {ok_scans}/{n_scans} scan pairs right: within 2° of the \
         truth, or flagged with the truth among the candidates; {:.2} s.",
        start.elapsed().as_secs_f64()
    );
    let d = args.data.display();
    println!("Try:");
    println!("  hough-heading images {d}/images/polygon-a.pbm {d}/images/polygon-b.pbm");
    println!("  hough-heading scans {d}/{SCANS_FILE} --summary --compare");
    println!("  hough-heading plot scans {d}/{SCANS_FILE} --index 6 --out figures");
    Ok(())
}

fn demo_images(dir: &Path) -> Result<(usize, usize), Fatal> {
    let manifest_path = dir.join(IMAGES_MANIFEST);
    let manifest = read_input(&manifest_path)?;
    let specs: Vec<ImagePairSpec> = serde_json::from_slice(&manifest)
        .map_err(|e| Fatal::io(format!("{}: {e}", manifest_path.display())))?;
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
        min_overlap: None,
    };
    let mut ok = 0;
    for spec in &specs {
        let (mut engine, offsets) =
            load_images(&dir.join(&spec.a), &dir.join(&spec.b), &options, &estimator)?;
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

fn demo_scans(dir: &Path) -> Result<(usize, usize), Fatal> {
    let path: PathBuf = dir.join(SCANS_FILE);
    let bytes = read_input(&path)?;
    let mut engine: Box<dyn Engine> = engine_for(256, 360)?;
    // The `scans` command's defaults: segments between beams ≤ 0.3 m apart.
    let options = RasterOptions {
        cell: None,
        connect: Some(scans::DEFAULT_CONNECT_M),
        disc: false,
    };
    println!("\nReal laser scan pairs (256², N_θ = 360, improved mode; window = p90 of ranges; see data/README.md):");
    let notes_path = dir.join(SCANS_NOTES);
    let notes: Vec<String> = serde_json::from_slice(&read_input(&notes_path)?)
        .map_err(|e| Fatal::io(format!("{}: {e}", notes_path.display())))?;
    println!(
        "    {:<18} {:>8} {:>9} {:>7}  {:<20} {:>14} {:>14}",
        "pair", "true dθ", "dθ", "error", "status", "true d (m)", "d (m)"
    );
    let mut ok = 0;
    let all = lines(&bytes);
    for (i, line) in all.iter().enumerate() {
        let named = |e: String| Fatal::io(format!("{}: line {}: {e}", path.display(), i + 1));
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
