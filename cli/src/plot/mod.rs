//! `hough-heading plot`: one PNG sheet per pair with what the estimator sees,
//! like the paper's Figures 2–8 — the two grids, both accumulators as heat
//! maps, the signatures `D1`, `D2` overlaid after alignment, the correlation
//! over the shift with the chosen peak and the rival, the asymmetry maps
//! `S1`, `S2` (direct and half-turned), and the grids overlaid after
//! alignment by the estimate (and by the ground truth, for scan pairs).

use std::path::{Path, PathBuf};

use clap::{Args, Subcommand};
use hough_heading::{Estimate, Mode};
use hough_heading_recordings::answer::load_images;
use hough_heading_recordings::engine::{Engine, View};
use hough_heading_recordings::options::{BeamArgs, EstimatorArgs, ImageArgs, ScanGridArgs};
use hough_heading_recordings::pairs::{self as scans, PairRecord, RasterOptions, Truth};
use hough_heading_recordings::Fatal;
use plotters::prelude::*;

use crate::input::{lines, read_input};

mod panels;
pub(crate) mod style;

use panels::*;
use style::{register_font, Drawn, C1, C2, C_TRUTH, FONT, SHEET};

/// `plot`.
#[derive(Clone, Debug, Args)]
pub struct PlotArgs {
    /// What to plot.
    #[command(subcommand)]
    pub what: PlotWhat,
    /// Output directory (created).
    #[arg(long, short, global = true, default_value = "figures")]
    pub out: PathBuf,
}

/// `plot images` or `plot scans`.
#[derive(Clone, Debug, Subcommand)]
pub enum PlotWhat {
    /// Figures of two images.
    Images {
        /// Reference image A.
        a: PathBuf,
        /// Image B.
        b: PathBuf,
        /// How images are read.
        #[command(flatten)]
        image: ImageArgs,
        /// Estimator options.
        #[command(flatten)]
        estimator: EstimatorArgs,
    },
    /// Figures of scan pairs of a pair file.
    Scans {
        /// Pair file.
        pairs: PathBuf,
        /// 0-based line indices, comma separated.
        #[arg(long, value_delimiter = ',', required = true)]
        index: Vec<usize>,
        /// How scans become grids.
        #[command(flatten)]
        grid: ScanGridArgs,
        /// What the beams do after the grid estimate.
        #[command(flatten)]
        beams: BeamArgs,
        /// Estimator options.
        #[command(flatten)]
        estimator: EstimatorArgs,
    },
}

/// Writes the figures.
///
/// # Errors
/// Unreadable inputs, unknown pair indices, unwritable output.
pub fn run(args: &PlotArgs) -> Result<(), Fatal> {
    register_font();
    std::fs::create_dir_all(&args.out)
        .map_err(|e| Fatal::io(format!("{}: cannot create: {e}", args.out.display())))?;
    match &args.what {
        PlotWhat::Images {
            a,
            b,
            image,
            estimator,
        } => {
            let (mut engine, _) = load_images(a, b, image, estimator)?;
            let mode: Mode = estimator.mode.into();
            let estimate = engine.estimate(mode);
            let name = format!("{}-{}.png", stem(a), stem(b));
            let path = args.out.join(name);
            let context = Context {
                title: format!("{} → {}", a.display(), b.display()),
                mode,
                estimate,
                truth: None,
                lines: Vec::new(),
            };
            write_sheet(&path, engine.as_ref(), &context)?;
            println!("{}", path.display());
        }
        PlotWhat::Scans {
            pairs,
            index,
            grid,
            beams,
            estimator,
        } => {
            let options = grid.options(beams)?;
            let mut engine = estimator.engine(grid.size)?;
            let bytes = read_input(pairs)?;
            let all = lines(&bytes);
            let mode: Mode = estimator.mode.into();
            for &i in index {
                let path = plot_pair(pairs, &all, i, engine.as_mut(), &options, mode, &args.out)?;
                println!("{}", path.display());
            }
        }
    }
    Ok(())
}

fn stem(p: &Path) -> String {
    p.file_stem()
        .map_or_else(|| "image".into(), |s| s.to_string_lossy().into_owned())
}

/// What a sheet shows besides the engine's grids.
struct Context {
    title: String,
    mode: Mode,
    estimate: Estimate,
    /// Ground truth `(α, t)` in the grid's terms (degrees, pixels).
    truth: Option<(f64, (f64, f64))>,
    lines: Vec<String>,
}

fn plot_pair(
    file: &Path,
    all: &[&[u8]],
    index: usize,
    engine: &mut dyn Engine,
    options: &RasterOptions,
    mode: Mode,
    out: &Path,
) -> Result<PathBuf, Fatal> {
    let named = |e: String| Fatal::io(format!("{}: line {}: {e}", file.display(), index + 1));
    let line = all.get(index).ok_or_else(|| {
        Fatal::usage(format!(
            "{}: no pair with index {index} (0-based; the file has {} lines)",
            file.display(),
            all.len()
        ))
    })?;
    let pair: PairRecord = serde_json::from_slice(line).map_err(|e| named(e.to_string()))?;
    let p = scans::estimate(engine, &pair, options, &[mode])
        .map_err(named)?
        .remove(0);
    let truth = serde_json::from_slice::<Truth>(line).ok();
    let mut text = vec![
        format!(
            "estimate: dθ = {:+.2}°, d = {}",
            p.dtheta_deg,
            p.translation
                .map_or("–".into(), |(x, y)| format!("({x:+.3}, {y:+.3}) m"))
        ),
        format!(
            "cell {:.4} m; scan 1: {} beams, {} kept; scan 2: {} beams, {} kept",
            p.cell, p.stats[0].beams, p.stats[0].kept, p.stats[1].beams, p.stats[1].kept
        ),
    ];
    let truth_px = truth.map(|t| {
        // α = −dθ, t = −R(α)·d / cell.
        let alpha = -t.dtheta;
        let (s, c) = alpha.sin_cos();
        let cell = f64::from(p.cell);
        let tx = -(c * t.dx - s * t.dy) / cell;
        let ty = -(s * t.dx + c * t.dy) / cell;
        text.push(format!(
            "truth: dθ = {:+.2}°, d = ({:+.3}, {:+.3}) m, overlap {}; error {:.2}°",
            t.dtheta.to_degrees(),
            t.dx,
            t.dy,
            t.check.overlap_gt.map_or("?".into(), |o| format!("{o:.2}")),
            scans::wrap_deg(p.dtheta_deg - t.dtheta.to_degrees()).abs()
        ));
        (alpha.to_degrees(), (tx, ty))
    });
    let path = out.join(format!("{}-{index}.png", stem(file)));
    let context = Context {
        title: format!("{} line {} (index {index})", file.display(), index + 1),
        mode,
        estimate: p.estimate,
        truth: truth_px,
        lines: text,
    };
    write_sheet(&path, engine, &context)?;
    Ok(path)
}

fn write_sheet(path: &Path, engine: &dyn Engine, context: &Context) -> Result<(), Fatal> {
    draw_sheet(path, engine, context)
        .map_err(|e| Fatal::io(format!("{}: cannot draw: {e}", path.display())))?;
    if context
        .estimate
        .candidates
        .iter()
        .any(|c| c.alignment.is_some())
    {
        let candidates = path.with_file_name(format!(
            "{}-candidates.png",
            path.file_stem()
                .map_or("sheet".into(), |s| s.to_string_lossy())
        ));
        draw_candidates(&candidates, engine, context)
            .map_err(|e| Fatal::io(format!("{}: cannot draw: {e}", candidates.display())))?;
        eprintln!("hough-heading: wrote {}", candidates.display());
    }
    Ok(())
}

/// One panel per verified candidate: grid 2 laid on grid 1 by the
/// candidate's rotation and best translation, titled with its alignment.
fn draw_candidates(path: &Path, engine: &dyn Engine, context: &Context) -> Drawn {
    let (a, b) = (engine.image(View::First), engine.image(View::Second));
    let e = &context.estimate;
    let root = BitMapBackend::new(path, (SHEET.0, SHEET.0 / 4 + 70)).into_drawing_area();
    root.fill(&WHITE)?;
    let (header, body) = root.split_vertically(50);
    header.draw(&Text::new(
        format!(
            "{}: candidates verified by alignment (status {}, overlap {:.2})",
            context.title,
            scans::status_name(e.status),
            e.overlap.to_num::<f64>()
        ),
        (12, 12),
        (FONT, 20).into_font(),
    ))?;
    let panels = body.split_evenly((1, 4));
    for (i, panel) in panels.iter().enumerate() {
        match e.candidates.get(i) {
            Some(c) => {
                let alpha = f64::from(c.alpha.to_degrees());
                let t = c
                    .translation
                    .map(|(x, y)| (x.to_num::<f64>(), y.to_num::<f64>()));
                let chosen = if c.alpha == e.alpha { ", chosen" } else { "" };
                overlay_panel(
                    panel,
                    &a,
                    &b,
                    alpha,
                    t,
                    &format!(
                        "α = {alpha:+.2}°: alignment {:.2}{chosen}",
                        c.alignment.map_or(0.0, |v| v.to_num::<f64>())
                    ),
                    if chosen.is_empty() { C_TRUTH } else { C2 },
                )?;
            }
            None => text_panel(panel, "", &[])?,
        }
    }
    root.present()?;
    Ok(())
}

fn draw_sheet(path: &Path, engine: &dyn Engine, context: &Context) -> Drawn {
    let figures = engine.figures(context.mode);
    let (a, b) = (engine.image(View::First), engine.image(View::Second));
    let e = &context.estimate;
    let alpha = f64::from(e.alpha.to_degrees());
    let t = e
        .translation
        .map(|t| (t.x.to_num::<f64>(), t.y.to_num::<f64>()));

    let root = BitMapBackend::new(path, SHEET).into_drawing_area();
    root.fill(&WHITE)?;
    let (header, body) = root.split_vertically(60);
    header.draw(&Text::new(
        context.title.clone(),
        (12, 8),
        (FONT, 22).into_font(),
    ))?;
    header.draw(&Text::new(
        format!(
            "α = {alpha:+.2}° ({}), confidence {:.2}, correlation {:.3}, rival {:.3}, {} mode, {}², N_θ = {}",
            scans::status_name(e.status),
            e.confidence.to_num::<f64>(),
            e.correlation.to_num::<f64>(),
            e.rival.to_num::<f64>(),
            match context.mode {
                Mode::Improved => "improved",
                Mode::Paper => "paper",
            },
            engine.size(),
            engine.n_theta()
        ),
        (12, 34),
        (FONT, 18).into_font(),
    ))?;
    let rows = body.split_evenly((3, 1));
    let top = rows[0].split_evenly((1, 4));
    grid_panel(&top[0], &a, "grid 1 (reference)", C1)?;
    grid_panel(&top[1], &b, "grid 2", C2)?;
    overlay_panel(
        &top[2],
        &a,
        &b,
        alpha,
        t,
        "2 aligned on 1 by the estimate",
        C2,
    )?;
    match context.truth {
        Some((ta, tt)) => overlay_panel(
            &top[3],
            &a,
            &b,
            ta,
            Some(tt),
            "2 aligned on 1 by the ground truth",
            C_TRUTH,
        )?,
        None => text_panel(&top[3], "no ground truth", &[])?,
    }
    let middle = rows[1].split_evenly((1, 4));
    heatmap_panel(&middle[0], &figures, 0, "accumulator 1: A(θ, ρ)")?;
    heatmap_panel(&middle[1], &figures, 1, "accumulator 2")?;
    signature_panel(&middle[2], &figures, alpha)?;
    correlation_panel(&middle[3], &figures, e)?;
    let (bottom_left, bottom_right) = rows[2].split_horizontally(SHEET.0 / 4);
    asymmetry_panel(&bottom_left, &figures, alpha)?;
    let mut info: Vec<String> = context.lines.clone();
    info.push(format!(
        "half-turn test: chose {} (direct {:.3}, flipped {:.3})",
        scans::half_turn_name(e.half_turn.chosen),
        e.half_turn.direct.to_num::<f64>(),
        e.half_turn.flipped.to_num::<f64>()
    ));
    info.push(format!(
        "candidates α: {}",
        e.candidates
            .iter()
            .map(|c| match c.alignment {
                Some(a) => format!(
                    "{:+.2}° (alignment {:.2})",
                    c.alpha.to_degrees(),
                    a.to_num::<f64>()
                ),
                None => format!(
                    "{:+.2}° ({:.2})",
                    c.alpha.to_degrees(),
                    c.score.to_num::<f64>()
                ),
            })
            .collect::<Vec<_>>()
            .join(", ")
    ));
    if let Some(tr) = e.translation {
        info.push(format!(
            "translation t = ({:+.2}, {:+.2}) px, residual {:.2} px{}",
            tr.x.to_num::<f64>(),
            tr.y.to_num::<f64>(),
            tr.residual.to_num::<f64>(),
            tr.unobservable.map_or(String::new(), |(ux, uy)| format!(
                ", unobservable along ({:+.2}, {:+.2})",
                ux.to_num::<f64>(),
                uy.to_num::<f64>()
            ))
        ));
    }
    info.push(format!("occupied cells: {} and {}", a.count(), b.count()));
    text_panel(&bottom_right, "numbers", &info)?;
    root.present()?;
    Ok(())
}
