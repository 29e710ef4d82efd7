//! `--trajectory` and `--plot` of `log`: consecutive estimates chained into
//! poses.
//!
//! Each pair moves the pose by the estimate when it is `confident` and has
//! a translation (`source` = `estimate`; where the translation is not
//! observable along one direction, a corridor, the odometry gives the
//! component along it: `estimate+odometry`); otherwise by the odometry's delta when the log has one
//! (`source` = `odometry`); otherwise by the estimate if it has a
//! translation (`flagged`); otherwise the pose stays (`none`). The
//! odometry's and the log's own poses are expressed relative to the first
//! scan's, so all tracks start at the origin facing +x. A recording whose
//! odometry (or poses) begin after its first scan (a bag whose first
//! odometry message comes after its first scan) starts that track at the
//! first scan that has one, placed at the chain's pose there.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use std::sync::Arc;

use hough_heading::Status;

use crate::error::Fatal;
use crate::model::{Pose, Scan};
use crate::pairs::PairEstimate;

/// A scan kept for pairing: its index among the recording's scans, and the
/// scan.
pub type Kept = (usize, Arc<Scan>);

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
    /// The first odometry pose, and the chain's pose at its scan.
    odom_anchor: Option<(Pose, Pose)>,
    /// The first log pose, and the chain's pose at its scan.
    log_anchor: Option<(Pose, Pose)>,
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

/// `p` in the chain's frame: relative to the track's first pose, placed at
/// the chain's pose there (`anchor` set by the first `p`, at `at`).
fn anchored(anchor: &mut Option<(Pose, Pose)>, p: Option<Pose>, at: Pose) -> Option<Pose> {
    let p = p?;
    let (first, origin) = *anchor.get_or_insert((p, at));
    Some(origin.compose(&first.between(&p)))
}

impl Trajectory {
    /// Starts the chain at `first`.
    pub fn start(&mut self, first: &Kept) {
        self.odom_anchor = None;
        self.log_anchor = None;
        self.push(first, Pose::ZERO, "start");
    }

    fn push(&mut self, scan: &Kept, pose: Pose, source: &'static str) {
        let s = &scan.1;
        let odom = anchored(&mut self.odom_anchor, s.odom, pose);
        let log_pose = anchored(&mut self.log_anchor, s.log_pose, pose);
        self.steps.push(Step {
            scan: scan.0,
            time: s.time,
            pose,
            source,
            odom,
            log_pose,
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

    /// The scans' points in the world (thinned evenly), for a figure.
    pub fn points(&self) -> &[(f64, f64)] {
        &self.points
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pairs::ScanRecord;

    fn kept(index: usize, odom: Option<Pose>) -> Kept {
        let record = ScanRecord {
            ranges: vec![Some(1.0); 4],
            angle_min: 0.0,
            angle_increment: 0.1,
            max_range: 10.0,
            laser_offset: [0.0; 3],
        };
        let scan = Scan {
            record,
            time: Some(index as f64),
            odom,
            log_pose: None,
            name: format!("scan {index}"),
        };
        (index, Arc::new(scan))
    }

    /// Odometry that starts after the first scan starts the odometry track
    /// at the chain's pose of the first scan that has one.
    #[test]
    fn late_odometry_starts_at_the_chains_pose() {
        let at = |x: f64, y: f64, theta: f64| Pose { x, y, theta };
        let mut t = Trajectory::default();
        let scans = [
            kept(0, None),
            kept(1, Some(at(5.0, 5.0, 1.0))),
            kept(2, Some(at(5.0, 6.0, 1.0 + 0.2))),
        ];
        t.start(&scans[0]);
        // The chain turned 90° and moved 1 m by scan 1.
        t.add_chained(
            &scans[1],
            at(1.0, 0.0, std::f64::consts::FRAC_PI_2),
            "estimate",
        );
        t.add_chained(
            &scans[2],
            at(1.0, 1.0, std::f64::consts::FRAC_PI_2),
            "estimate",
        );
        let odom: Vec<Option<Pose>> = t.steps.iter().map(|s| s.odom).collect();
        assert_eq!(odom[0], None);
        assert_eq!(odom[1], Some(at(1.0, 0.0, std::f64::consts::FRAC_PI_2)));
        // The odometry's step from scan 1 to 2, composed onto the chain's
        // pose at scan 1.
        let d = at(5.0, 5.0, 1.0).between(&at(5.0, 6.0, 1.2));
        let expected = at(1.0, 0.0, std::f64::consts::FRAC_PI_2).compose(&d);
        let got = odom[2].expect("odometry");
        assert!((got.x - expected.x).abs() < 1e-12 && (got.y - expected.y).abs() < 1e-12);
        assert!((got.theta - (std::f64::consts::FRAC_PI_2 + 0.2)).abs() < 1e-12);
        // A recording whose first scan has odometry starts it at the origin.
        let mut t = Trajectory::default();
        t.start(&scans[1]);
        t.add_chained(&scans[2], at(0.0, 0.0, 0.0), "estimate");
        assert_eq!(t.steps[0].odom, Some(Pose::ZERO));
        assert!((t.steps[1].odom.unwrap().theta - 0.2).abs() < 1e-12);
    }
}
