//! `hough-heading plot`: one PNG sheet per pair with what the estimator sees,
//! like the paper's Figures 2–8 — the two grids, both accumulators as heat
//! maps, the signatures `D1`, `D2` overlaid after alignment, the correlation
//! over the shift with the chosen peak and the rival, the asymmetry maps
//! `S1`, `S2` (direct and half-turned), and the grids overlaid after
//! alignment by the estimate (and by the ground truth, for scan pairs).

use std::error::Error;
use std::path::{Path, PathBuf};
use std::sync::Once;

use clap::{Args, Subcommand};
use hough_heading::{Estimate, Mode};
use hough_heading_recordings::answer::load_images;
use hough_heading_recordings::engine::{Engine, Figures, View};
use hough_heading_recordings::image::Image;
use hough_heading_recordings::options::{BeamArgs, EstimatorArgs, ImageArgs, ScanGridArgs};
use hough_heading_recordings::pairs::{self as scans, PairRecord, RasterOptions, Truth};
use hough_heading_recordings::Fatal;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;

use crate::input::{lines, read_input};

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

type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;
type Drawn = Result<(), Box<dyn Error>>;
type Chart<'a, 'b> =
    ChartContext<'a, BitMapBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

pub(crate) const FONT: &str = "sans-serif";
const SHEET: (u32, u32) = (2000, 1500);
/// Colours of view 1, view 2 and the ground-truth alignment.
const C1: RGBColor = RGBColor(31, 119, 180);
const C2: RGBColor = RGBColor(214, 39, 40);
const C_TRUTH: RGBColor = RGBColor(44, 160, 44);

/// Registers the embedded DejaVu Sans as `sans-serif` (no system fonts).
pub(crate) fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The embedded font is a valid TTF; a failure only loses the text.
        let _ = register_font_bytes();
    });
}

fn register_font_bytes() -> Result<(), Box<dyn Error>> {
    plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular())
        .map_err(|_| "invalid font".into())
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

/// Centred coordinates of the occupied cells.
fn points(image: &Image) -> Vec<(f64, f64)> {
    image
        .occupied()
        .into_iter()
        .map(|(c, r)| image.coords(c, r))
        .collect()
}

fn half_extent(image: &Image) -> f64 {
    image.width.max(image.height) as f64 / 2.0
}

fn square_chart<'a, 'b>(
    area: &'a Area<'b>,
    title: &str,
    half: f64,
) -> Result<Chart<'a, 'b>, Box<dyn Error>> {
    let mut chart = ChartBuilder::on(area)
        .caption(title, (FONT, 18))
        .margin(10)
        .x_label_area_size(28)
        .y_label_area_size(40)
        .build_cartesian_2d(-half..half, -half..half)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .label_style((FONT, 12))
        .draw()?;
    Ok(chart)
}

fn grid_panel(area: &Area<'_>, image: &Image, title: &str, colour: RGBColor) -> Drawn {
    let mut chart = square_chart(area, title, half_extent(image))?;
    chart.draw_series(
        points(image).into_iter().map(|(x, y)| {
            Rectangle::new([(x - 0.5, y - 0.5), (x + 0.5, y + 0.5)], colour.filled())
        }),
    )?;
    Ok(())
}

/// Grid 1, and grid 2 mapped back onto it: `p₁ = R(−α)(p₂ − t)`.
fn overlay_panel(
    area: &Area<'_>,
    a: &Image,
    b: &Image,
    alpha_deg: f64,
    t: Option<(f64, f64)>,
    title: &str,
    colour: RGBColor,
) -> Drawn {
    let mut chart = square_chart(area, title, half_extent(a))?;
    let (tx, ty) = t.unwrap_or((0.0, 0.0));
    let (s, c) = (-alpha_deg.to_radians()).sin_cos();
    chart.draw_series(
        points(a)
            .into_iter()
            .map(|(x, y)| Rectangle::new([(x - 0.5, y - 0.5), (x + 0.5, y + 0.5)], C1.filled())),
    )?;
    chart.draw_series(points(b).into_iter().map(|(x, y)| {
        let (x, y) = (x - tx, y - ty);
        Circle::new((c * x - s * y, s * x + c * y), 1, colour.filled())
    }))?;
    if t.is_none() {
        chart.draw_series(std::iter::once(Text::new(
            "(no translation: rotation only)",
            (-half_extent(a) * 0.95, -half_extent(a) * 0.9),
            (FONT, 13).into_font(),
        )))?;
    }
    Ok(())
}

/// The accumulator over the full circle (`A(θ + π, ρ) = A(θ, −ρ)`), log
/// colour scale, ρ trimmed to the bins that hold votes in either image.
fn heatmap_panel(area: &Area<'_>, f: &Figures, which: usize, title: &str) -> Drawn {
    let (half, rho) = (f.half, f.rho);
    let acc = &f.accumulators[which];
    let get = |k: usize, b: usize| -> u16 {
        if k < half {
            acc[k * rho + b]
        } else {
            acc[(k - half) * rho + (rho - b) % rho]
        }
    };
    // ρ extent with votes, over both images and both halves (symmetric).
    let centre = rho / 2;
    let reach = f
        .accumulators
        .iter()
        .flat_map(|acc| {
            acc.chunks(rho).flat_map(|col| {
                col.iter()
                    .enumerate()
                    .filter(|(_, &v)| v > 0)
                    .map(|(b, _)| b.abs_diff(centre))
            })
        })
        .max()
        .unwrap_or(1)
        .max(1);
    let max = acc.iter().copied().max().unwrap_or(1).max(1);
    let log_max = f64::from(max).ln_1p();
    let step = 360.0 / (2 * half) as f64;
    let mut chart = ChartBuilder::on(area)
        .caption(title, (FONT, 18))
        .margin(10)
        .x_label_area_size(28)
        .y_label_area_size(40)
        .build_cartesian_2d(0f64..360f64, -(reach as f64)..reach as f64)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc("θ (°)")
        .y_desc("ρ (px)")
        .label_style((FONT, 12))
        .draw()?;
    let lo = centre.saturating_sub(reach);
    let hi = (centre + reach).min(rho - 1);
    let cells = (0..2 * half).flat_map(|k| (lo..=hi).map(move |b| (k, b)));
    chart.draw_series(cells.filter_map(|(k, b)| {
        let v = get(k, b);
        (v > 0).then(|| {
            let colour = ViridisRGB.get_color(f64::from(v).ln_1p() / log_max);
            let (x, y) = (k as f64 * step, b as f64 - centre as f64);
            Rectangle::new([(x, y - 0.5), (x + step, y + 0.5)], colour.filled())
        })
    }))?;
    Ok(())
}

/// Index shift (θ steps over the full circle) of a rotation α.
fn steps(alpha_deg: f64, n: usize) -> usize {
    ((alpha_deg / 360.0 * n as f64).round() as i64).rem_euclid(n as i64) as usize
}

fn signature_panel(area: &Area<'_>, f: &Figures, alpha_deg: f64) -> Drawn {
    let n = 2 * f.half;
    let d = |which: usize, k: usize| f64::from(f.signatures[which][k % f.half]);
    let max = (0..n).map(|k| d(0, k).max(d(1, k))).fold(1.0, f64::max);
    let shift = steps(alpha_deg, n);
    let step = 360.0 / n as f64;
    let mut chart = ChartBuilder::on(area)
        .caption("D1(θ) and D2(θ + α)", (FONT, 18))
        .margin(10)
        .x_label_area_size(28)
        .y_label_area_size(40)
        .build_cartesian_2d(0f64..360f64, 0f64..1.05f64)?;
    chart
        .configure_mesh()
        .light_line_style(TRANSPARENT)
        .x_labels(7)
        .x_desc("θ (°)")
        .y_desc("D / max")
        .label_style((FONT, 12))
        .draw()?;
    chart
        .draw_series(LineSeries::new(
            (0..n).map(|k| (k as f64 * step, d(1, k) / max)),
            RGBColor(190, 190, 190).stroke_width(1),
        ))?
        .label("D2(θ) (not aligned)")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], RGBColor(190, 190, 190)));
    chart
        .draw_series(LineSeries::new(
            (0..n).map(|k| (k as f64 * step, d(0, k) / max)),
            C1.stroke_width(2),
        ))?
        .label("D1(θ)")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], C1));
    chart
        .draw_series(LineSeries::new(
            (0..n).map(|k| (k as f64 * step, d(1, k + shift) / max)),
            C2.stroke_width(1),
        ))?
        .label("D2(θ + α)")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], C2));
    legend(&mut chart)
}

fn legend<'a, 'b: 'a>(chart: &mut Chart<'a, 'b>) -> Drawn {
    chart
        .configure_series_labels()
        .label_font((FONT, 12))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}

fn correlation_panel(area: &Area<'_>, f: &Figures, e: &Estimate) -> Drawn {
    let step = 180.0 / f.half as f64;
    let lo = f.correlation.iter().copied().fold(0.0, f64::min).min(-0.1);
    let mut chart = ChartBuilder::on(area)
        .caption("correlation r(shift), modulo 180°", (FONT, 18))
        .margin(10)
        .x_label_area_size(28)
        .y_label_area_size(40)
        .build_cartesian_2d(0f64..180f64, lo..1.05f64)?;
    chart
        .configure_mesh()
        .light_line_style(TRANSPARENT)
        .x_labels(7)
        .x_desc("shift (°)")
        .y_desc("Pearson r")
        .label_style((FONT, 12))
        .draw()?;
    chart
        .draw_series(LineSeries::new(
            f.correlation
                .iter()
                .enumerate()
                .map(|(k, &r)| (k as f64 * step, r)),
            BLACK.stroke_width(1),
        ))?
        .label("r")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLACK));
    if let Some(best) = f.best {
        let r = f.correlation[best];
        chart
            .draw_series(std::iter::once(Circle::new(
                (best as f64 * step, r),
                6,
                C2.filled(),
            )))?
            .label(format!("peak {:.1}° (r {r:.3})", best as f64 * step))
            .legend(|(x, y)| Circle::new((x + 9, y), 5, C2.filled()));
        let limit = 0.9 * e.correlation.to_num::<f64>();
        chart
            .draw_series(DashedLineSeries::new(
                [(0.0, limit), (180.0, limit)],
                6,
                4,
                RGBColor(120, 120, 120).into(),
            ))?
            .label("0.9 × best: rival flag")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], RGBColor(120, 120, 120)));
    }
    if let Some(rival) = f.rival {
        let r = f.correlation[rival];
        chart
            .draw_series(std::iter::once(Circle::new(
                (rival as f64 * step, r),
                6,
                RGBColor(255, 127, 14).filled(),
            )))?
            .label(format!("rival {:.1}° (r {r:.3})", rival as f64 * step))
            .legend(|(x, y)| Circle::new((x + 9, y), 5, RGBColor(255, 127, 14).filled()));
    }
    legend(&mut chart)
}

fn asymmetry_panel(area: &Area<'_>, f: &Figures, alpha_deg: f64) -> Drawn {
    let n = 2 * f.half;
    // S(θ + π) = −S(θ).
    let s = |which: usize, k: usize| {
        let v = f64::from(f.asymmetries[which][k % f.half]);
        if (k / f.half).is_multiple_of(2) {
            v
        } else {
            -v
        }
    };
    let max = (0..f.half)
        .map(|k| s(0, k).abs().max(s(1, k).abs()))
        .fold(1.0, f64::max);
    let shift = steps(alpha_deg, n);
    let step = 360.0 / n as f64;
    let mut chart = ChartBuilder::on(area)
        .caption("asymmetry S1(θ), S2(θ + α), S2(θ + α + π)", (FONT, 18))
        .margin(10)
        .x_label_area_size(28)
        .y_label_area_size(40)
        .build_cartesian_2d(0f64..360f64, -1.05f64..1.05f64)?;
    chart
        .configure_mesh()
        .light_line_style(TRANSPARENT)
        .x_labels(7)
        .x_desc("θ (°)")
        .y_desc("S / max |S|")
        .label_style((FONT, 12))
        .draw()?;
    chart
        .draw_series(LineSeries::new(
            (0..n).map(|k| (k as f64 * step, s(0, k) / max)),
            C1.stroke_width(2),
        ))?
        .label("S1(θ)")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], C1));
    chart
        .draw_series(LineSeries::new(
            (0..n).map(|k| (k as f64 * step, s(1, k + shift) / max)),
            C2.stroke_width(1),
        ))?
        .label("S2(θ + α)")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], C2));
    chart
        .draw_series(DashedLineSeries::new(
            (0..n).map(|k| (k as f64 * step, s(1, k + shift + f.half) / max)),
            4,
            3,
            RGBColor(150, 150, 150).into(),
        ))?
        .label("S2(θ + α + π)")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], RGBColor(150, 150, 150)));
    legend(&mut chart)
}

fn text_panel(area: &Area<'_>, title: &str, lines: &[String]) -> Drawn {
    area.draw(&Text::new(
        title.to_string(),
        (16, 14),
        (FONT, 18).into_font(),
    ))?;
    for (i, line) in lines.iter().enumerate() {
        area.draw(&Text::new(
            line.clone(),
            (16, 48 + 24 * i as i32),
            (FONT, 15).into_font(),
        ))?;
    }
    Ok(())
}
