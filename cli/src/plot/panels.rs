//! The panels of a sheet: the grids, their overlay, the accumulators as
//! heat maps, the signatures, the correlation, the asymmetry maps and text.

use std::error::Error;

use hough_heading::Estimate;
use hough_heading_recordings::engine::Figures;
use hough_heading_recordings::image::Image;
use plotters::prelude::*;

use super::style::{Area, Chart, Drawn, C1, C2, FONT};

/// Centred coordinates of the occupied cells.
pub(super) fn points(image: &Image) -> Vec<(f64, f64)> {
    image
        .occupied()
        .into_iter()
        .map(|(c, r)| image.coords(c, r))
        .collect()
}

pub(super) fn half_extent(image: &Image) -> f64 {
    image.width.max(image.height) as f64 / 2.0
}

pub(super) fn square_chart<'a, 'b>(
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

pub(super) fn grid_panel(area: &Area<'_>, image: &Image, title: &str, colour: RGBColor) -> Drawn {
    let mut chart = square_chart(area, title, half_extent(image))?;
    chart.draw_series(
        points(image).into_iter().map(|(x, y)| {
            Rectangle::new([(x - 0.5, y - 0.5), (x + 0.5, y + 0.5)], colour.filled())
        }),
    )?;
    Ok(())
}

/// Grid 1, and grid 2 mapped back onto it: `p₁ = R(−α)(p₂ − t)`.
pub(super) fn overlay_panel(
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
pub(super) fn heatmap_panel(area: &Area<'_>, f: &Figures, which: usize, title: &str) -> Drawn {
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
pub(super) fn steps(alpha_deg: f64, n: usize) -> usize {
    ((alpha_deg / 360.0 * n as f64).round() as i64).rem_euclid(n as i64) as usize
}

pub(super) fn signature_panel(area: &Area<'_>, f: &Figures, alpha_deg: f64) -> Drawn {
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

pub(super) fn legend<'a, 'b: 'a>(chart: &mut Chart<'a, 'b>) -> Drawn {
    chart
        .configure_series_labels()
        .label_font((FONT, 12))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}

pub(super) fn correlation_panel(area: &Area<'_>, f: &Figures, e: &Estimate) -> Drawn {
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

pub(super) fn asymmetry_panel(area: &Area<'_>, f: &Figures, alpha_deg: f64) -> Drawn {
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

pub(super) fn text_panel(area: &Area<'_>, title: &str, lines: &[String]) -> Drawn {
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
