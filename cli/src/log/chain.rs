//! `log --prior motion` and `log --pairs keyframes`: the library's
//! [`KeyframeOdometry`] over a recording's scans.
//!
//! Consecutive pairs with the motion prior: every scan is the keyframe of
//! the next, and a pair whose estimate is flagged (or lies beyond 3σ of
//! the constant-velocity prediction) is estimated again with the prior.
//! Keyframe pairs: each scan against the current keyframe, a new keyframe
//! when the library's rule says so ([`KeyframeOdometry::update`]).

use hough_heading::odometry::{KeyframeOdometry, KeyframeSettings, StepSource};
use hough_heading::{Angle, Motion, Prior, Score};
use serde::Serialize;

use hough_heading_recordings::model::Pose;
use hough_heading_recordings::pairs::{self, PairEstimate};
use hough_heading_recordings::trajectory::{fused_delta, Kept};

/// The chain of a run, and its keyframe.
pub struct Chain {
    odometry: KeyframeOdometry,
    /// The current keyframe (keyframe pairs) or the last scan.
    pub keyframe: Option<Kept>,
    /// The keyframe's pose in `f64`: the chain's poses are composed here
    /// from the estimates' own `f64` motions (the library's `f32` pose
    /// decides, and serves only for the prediction).
    keyframe_pose: Pose,
}

/// What the chain made of one pair, as the output line reports it.
#[derive(Clone, Debug, Serialize)]
pub struct ChainLine {
    /// `estimate` (a confident estimate), `prior` (a flagged one taken as
    /// the candidate nearest the constant-velocity prediction), `predicted`
    /// (no estimate within 3σ of it: the prediction itself), `flagged` (a
    /// flagged estimate with nothing yet to predict from).
    pub source: &'static str,
    /// The second scan is now the keyframe.
    pub keyframe: bool,
    /// The prior the pair was estimated again with (its α turned into the
    /// robot's heading change, degrees, and σ), when it was.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub prior: Option<PriorLine>,
    /// The second scan's chained pose: metres and degrees, in the first
    /// scan's frame.
    pub x_m: f64,
    /// y, metres.
    pub y_m: f64,
    /// Heading, degrees in (−180, 180].
    pub theta_deg: f64,
}

/// A motion prior, in the robot's terms.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct PriorLine {
    /// Predicted heading change, degrees.
    pub dtheta_deg: f64,
    /// One standard deviation, degrees.
    pub sigma_deg: f64,
}

impl Chain {
    /// A chain whose keyframe moves on every scan (`every_scan`: consecutive
    /// pairs) or by the library's rule, with σ = `sigma_deg`.
    pub fn new(sigma_deg: f64, every_scan: bool) -> Self {
        let mut settings = KeyframeSettings {
            prior_sigma: Angle::from_degrees(sigma_deg as f32),
            ..KeyframeSettings::default()
        };
        if every_scan {
            settings.min_overlap = Score::MAX;
        }
        Self {
            odometry: KeyframeOdometry::new(settings),
            keyframe: None,
            keyframe_pose: Pose::ZERO,
        }
    }

    /// The first scan.
    pub fn start(&mut self, first: &Kept) {
        self.odometry.start();
        self.keyframe = Some(first.clone());
        self.keyframe_pose = Pose::ZERO;
    }

    /// The prior to estimate the next scan again with, when its `estimate`
    /// against the keyframe wants one.
    pub fn prior_for(&self, estimate: &PairEstimate) -> Option<Prior> {
        self.odometry
            .wants_prior(&estimate.estimate)
            .then(|| self.odometry.prior())
            .flatten()
    }

    /// Adds `scan` with its estimate against the keyframe (`None`: it
    /// failed), made with `prior` if given, and the odometry's motion from
    /// the keyframe; the line to report and the scan's pose.
    pub fn add(
        &mut self,
        scan: &Kept,
        estimate: Option<&PairEstimate>,
        prior: Option<Prior>,
        odom: Option<Pose>,
    ) -> (ChainLine, Pose) {
        // Along a corridor the odometry's translation (as the trajectory of
        // the pairs alone takes it).
        let delta = estimate.map(|e| {
            let (x, y) = fused_delta(e, odom).map_or((0.0, 0.0), |(d, _)| (d.x, d.y));
            Pose {
                x,
                y,
                theta: e.dtheta_deg.to_radians(),
            }
        });
        let motion = delta.map(|d| Motion {
            dtheta: d.theta as f32,
            translation: Some((d.x as f32, d.y as f32)),
        });
        let keyframe = self.odometry.keyframe();
        let step = self.odometry.update(
            estimate.zip(motion.as_ref()).map(|(e, m)| (&e.estimate, m)),
            prior.is_some(),
        );
        // The estimate's own motion when the chain took it, else the
        // library's step (the prediction).
        let delta = match (step.source, delta) {
            (StepSource::Estimate | StepSource::Prior | StepSource::Flagged, Some(d)) => d,
            _ => {
                let r = keyframe.between(&step.pose);
                Pose {
                    x: f64::from(r.x),
                    y: f64::from(r.y),
                    theta: f64::from(r.heading.to_degrees()).to_radians(),
                }
            }
        };
        let pose = self.keyframe_pose.compose(&delta);
        if step.new_keyframe {
            self.keyframe = Some(scan.clone());
            self.keyframe_pose = pose;
        }
        let line = ChainLine {
            source: step.source.name(),
            keyframe: step.new_keyframe,
            prior: prior.map(|p| PriorLine {
                dtheta_deg: round(-f64::from(p.alpha.to_degrees())),
                sigma_deg: round(f64::from(p.sigma.to_degrees())),
            }),
            x_m: round(pose.x),
            y_m: round(pose.y),
            theta_deg: round(pose.theta.to_degrees()),
        };
        (line, pose)
    }
}

fn round(v: f64) -> f64 {
    pairs::round(v, 4)
}
