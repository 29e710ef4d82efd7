//! `log --plot`: the chained trajectory over the odometry's (and the log's
//! poses), with the scans projected.

use std::path::Path;

use hough_heading_recordings::model::Pose;
use hough_heading_recordings::stats::quantile;
use hough_heading_recordings::trajectory::{Step, Trajectory};
use hough_heading_recordings::Fatal;
use plotters::prelude::*;

use crate::plot::style::{register_font, FONT};

/// Draws the figure of `t` (PNG).
///
/// # Errors
/// An unwritable file.
pub fn plot(t: &Trajectory, path: &Path, title: &str) -> Result<(), Fatal> {
    register_font();
    draw(t, path, title).map_err(|e| Fatal::io(format!("{}: cannot draw: {e}", path.display())))
}

fn draw(t: &Trajectory, path: &Path, title: &str) -> Result<(), Box<dyn std::error::Error>> {
    let track = |f: fn(&Step) -> Option<Pose>| -> Vec<(f64, f64)> {
        t.steps.iter().filter_map(f).map(|p| (p.x, p.y)).collect()
    };
    let estimated = track(|s| Some(s.pose));
    let odom = track(|s| s.odom);
    let log = track(|s| s.log_pose);
    // The tracks and the bulk of the points (2nd to 98th percentile on
    // each axis: a few far returns would shrink the map to a dot).
    let xs: Vec<f64> = t.points().iter().map(|p| p.0).collect();
    let ys: Vec<f64> = t.points().iter().map(|p| p.1).collect();
    let bulk: Vec<(f64, f64)> = if xs.is_empty() {
        Vec::new()
    } else {
        vec![
            (quantile(&xs, 0.02), quantile(&ys, 0.02)),
            (quantile(&xs, 0.98), quantile(&ys, 0.98)),
        ]
    };
    let all = estimated.iter().chain(&odom).chain(&log).chain(&bulk);
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in all {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if x0 > x1 {
        (x0, x1, y0, y1) = (-1.0, 1.0, -1.0, 1.0);
    }
    // Equal scales on both axes.
    let (w, h) = (1400u32, 1200u32);
    let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    let half = ((x1 - x0) / 2.0).max((y1 - y0) / 2.0 * f64::from(w - 100) / f64::from(h - 100));
    let half = half.max(1.0) * 1.05;
    let half_y = half * f64::from(h - 100) / f64::from(w - 100);
    let root = BitMapBackend::new(path, (w, h)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(format!("{title} ({} scans)", t.steps.len()), (FONT, 24))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(cx - half..cx + half, cy - half_y..cy + half_y)?;
    chart
        .configure_mesh()
        .x_desc("x (m)")
        .y_desc("y (m)")
        .light_line_style(WHITE)
        .label_style((FONT, 16))
        .draw()?;
    let grey = RGBColor(150, 150, 150);
    let (xr, yr) = (cx - half..cx + half, cy - half_y..cy + half_y);
    chart.draw_series(
        t.points()
            .iter()
            .filter(|p| xr.contains(&p.0) && yr.contains(&p.1))
            .map(|&p| Circle::new(p, 1, grey.mix(0.35).filled())),
    )?;
    let c1 = RGBColor(31, 119, 180);
    let odom_colour = RGBColor(255, 127, 14);
    let truth_colour = RGBColor(44, 160, 44);
    if !log.is_empty() {
        chart
            .draw_series(LineSeries::new(log, truth_colour.stroke_width(6)))?
            .label("log poses (corrected)")
            .legend(move |(x, y)| {
                PathElement::new([(x, y), (x + 20, y)], truth_colour.stroke_width(6))
            });
    }
    if !odom.is_empty() {
        chart
            .draw_series(LineSeries::new(odom, odom_colour.stroke_width(2)))?
            .label("odometry")
            .legend(move |(x, y)| {
                PathElement::new([(x, y), (x + 20, y)], odom_colour.stroke_width(2))
            });
    }
    chart
        .draw_series(LineSeries::new(estimated, c1.stroke_width(2)))?
        .label("estimates, chained")
        .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], c1.stroke_width(2)));
    chart
        .configure_series_labels()
        .label_font((FONT, 18))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperLeft)
        .draw()?;
    root.present()?;
    Ok(())
}
