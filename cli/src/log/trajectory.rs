//! `--trajectory` and `--plot`: consecutive estimates chained into poses.
//!
//! Each pair moves the pose by the estimate when it is `confident` and has
//! a translation (`source` = `estimate`; where the translation is not
//! observable along one direction, a corridor, the odometry gives the
//! component along it: `estimate+odometry`); otherwise by the odometry's delta when the log has one
//! (`source` = `odometry`); otherwise by the estimate if it has a
//! translation (`flagged`); otherwise the pose stays (`none`). The
//! odometry's and the log's own poses are expressed relative to the first
//! scan's, so all tracks start at the origin facing +x.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use hough_heading::Status;
use plotters::prelude::*;

use super::{Kept, Pose};
use crate::plot::{register_font, FONT};
use crate::scans::PairEstimate;
use crate::stats::quantile;
use crate::Fatal;

/// Most scan points kept for the figure (the scans are thinned evenly).
const MAX_POINTS: usize = 200_000;

/// One pose of the chain.
#[derive(Clone, Debug)]
pub struct Step {
    /// Scan index.
    pub scan: usize,
    /// Scan time, seconds.
    pub time: Option<f64>,
    /// The chained pose.
    pub pose: Pose,
    /// What moved it: `start`, `estimate`, `estimate+odometry`, `odometry`,
    /// `flagged`, `none`.
    pub source: &'static str,
    /// Odometry pose relative to the first scan's.
    pub odom: Option<Pose>,
    /// The log's pose relative to the first scan's.
    pub log_pose: Option<Pose>,
}

/// The chain, and the scans' points in the world for the figure.
#[derive(Clone, Debug, Default)]
pub struct Trajectory {
    /// The poses, one per scan used.
    pub steps: Vec<Step>,
    first_odom: Option<Pose>,
    first_log: Option<Pose>,
    points: Vec<(f64, f64)>,
    seen_points: usize,
}

/// The robot's motion an estimate gives (`None` without a translation):
/// with odometry and a direction the estimate cannot observe (a corridor),
/// the estimate across it and the odometry along it
/// (`estimate+odometry`), else the estimate's (`estimate`).
pub fn fused_delta(estimate: &PairEstimate, odom: Option<Pose>) -> Option<(Pose, &'static str)> {
    let e = estimate;
    let (x, y) = e.translation?;
    let d = Pose {
        x,
        y,
        theta: e.dtheta_deg.to_radians(),
    };
    // The direction along which the translation is not observable, in the
    // frame of scan 1 (as `OutputLine::of` turns it).
    let unobservable = e.estimate.translation.and_then(|t| {
        let (ux, uy) = t.unobservable?;
        let (ux, uy) = (ux.to_num::<f64>(), uy.to_num::<f64>());
        let (s, c) = d.theta.sin_cos();
        Some((c * ux - s * uy, s * ux + c * uy))
    });
    Some(match (odom, unobservable) {
        (Some(o), Some((ux, uy))) => {
            let along = (o.x - d.x) * ux + (o.y - d.y) * uy;
            let fused = Pose {
                x: d.x + along * ux,
                y: d.y + along * uy,
                theta: d.theta,
            };
            (fused, "estimate+odometry")
        }
        _ => (d, "estimate"),
    })
}

impl Trajectory {
    /// Starts the chain at `first`.
    pub fn start(&mut self, first: &Kept) {
        self.first_odom = first.1.odom;
        self.first_log = first.1.log_pose;
        self.push(first, Pose::ZERO, "start");
    }

    fn push(&mut self, scan: &Kept, pose: Pose, source: &'static str) {
        let s = &scan.1;
        let relative =
            |first: Option<Pose>, p: Option<Pose>| first.zip(p).map(|(f, p)| f.between(&p));
        self.steps.push(Step {
            scan: scan.0,
            time: s.time,
            pose,
            source,
            odom: relative(self.first_odom, s.odom),
            log_pose: relative(self.first_log, s.log_pose),
        });
        // Thin the points evenly: keep one in `stride` of all seen.
        let (sn, cs) = pose.theta.sin_cos();
        for (x, y) in s.record.points() {
            self.seen_points += 1;
            let stride = self.seen_points.div_ceil(MAX_POINTS).max(1);
            if self.seen_points.is_multiple_of(stride) {
                self.points
                    .push((pose.x + cs * x - sn * y, pose.y + sn * x + cs * y));
            }
        }
        if self.points.len() > MAX_POINTS {
            self.points = self.points.iter().copied().step_by(2).collect();
        }
    }

    /// Adds `scan` at `pose`, chained elsewhere (`log --prior motion`,
    /// `--pairs keyframes`); `source` says how.
    pub fn add_chained(&mut self, scan: &Kept, pose: Pose, source: &'static str) {
        self.push(scan, pose, source);
    }

    /// Adds the pair `a → b` (`a` is the last pose of the chain).
    pub fn add(&mut self, a: &Kept, b: &Kept, estimate: Option<&PairEstimate>, odom: Option<Pose>) {
        if self.steps.is_empty() {
            self.start(a);
        }
        let last = self.steps.last().map_or(Pose::ZERO, |s| s.pose);
        let confident = estimate.is_some_and(|e| e.estimate.status == Status::Confident);
        let fused = estimate.and_then(|e| fused_delta(e, odom));
        let (delta, source) = match (fused, odom) {
            (Some(d), _) if confident => d,
            (_, Some(o)) => (o, "odometry"),
            (Some((d, _)), None) => (d, "flagged"),
            (None, None) => (Pose::ZERO, "none"),
        };
        self.push(b, last.compose(&delta), source);
    }

    /// Writes the CSV.
    ///
    /// # Errors
    /// An unwritable file.
    pub fn write_csv(&self, path: &Path) -> Result<(), Fatal> {
        let fail = |e: std::io::Error| Fatal::io(format!("{}: cannot write: {e}", path.display()));
        let mut out = BufWriter::new(File::create(path).map_err(fail)?);
        writeln!(
            out,
            "scan,t,x,y,theta,source,odom_x,odom_y,odom_theta,log_x,log_y,log_theta"
        )
        .map_err(fail)?;
        let opt = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.6}"));
        for s in &self.steps {
            writeln!(
                out,
                "{},{},{:.6},{:.6},{:.6},{},{},{},{},{},{},{}",
                s.scan,
                opt(s.time),
                s.pose.x,
                s.pose.y,
                s.pose.theta,
                s.source,
                opt(s.odom.map(|p| p.x)),
                opt(s.odom.map(|p| p.y)),
                opt(s.odom.map(|p| p.theta)),
                opt(s.log_pose.map(|p| p.x)),
                opt(s.log_pose.map(|p| p.y)),
                opt(s.log_pose.map(|p| p.theta)),
            )
            .map_err(fail)?;
        }
        out.flush().map_err(fail)
    }

    /// Draws the figure (PNG).
    ///
    /// # Errors
    /// An unwritable file.
    pub fn plot(&self, path: &Path, title: &str) -> Result<(), Fatal> {
        register_font();
        self.draw(path, title)
            .map_err(|e| Fatal::io(format!("{}: cannot draw: {e}", path.display())))
    }

    fn draw(&self, path: &Path, title: &str) -> Result<(), Box<dyn std::error::Error>> {
        let track = |f: fn(&Step) -> Option<Pose>| -> Vec<(f64, f64)> {
            self.steps
                .iter()
                .filter_map(f)
                .map(|p| (p.x, p.y))
                .collect()
        };
        let estimated = track(|s| Some(s.pose));
        let odom = track(|s| s.odom);
        let log = track(|s| s.log_pose);
        // The tracks and the bulk of the points (2nd to 98th percentile on
        // each axis: a few far returns would shrink the map to a dot).
        let xs: Vec<f64> = self.points.iter().map(|p| p.0).collect();
        let ys: Vec<f64> = self.points.iter().map(|p| p.1).collect();
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
            .caption(
                format!(
                    "{title}: {} scans, chained consecutive estimates",
                    self.steps.len()
                ),
                (FONT, 24),
            )
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
            self.points
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
}
