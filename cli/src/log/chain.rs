//! `log --prior motion` and `log --pairs keyframes`: the library's
//! [`KeyframeOdometry`] over a recording's scans.
//!
//! The tool keeps the scans the chain may estimate a new scan against (the
//! keyframe, the last placed scan, the previous keyframe), asks the chain
//! which to try ([`KeyframeOdometry::attempts`]) and offers it each
//! estimate until one places the scan; a scan none places is left
//! unplaced, or carried after a few (the library's module doc). Poses are
//! composed here in `f64` from the estimates' own motions (the library's
//! `f32` pose decides, and serves the prediction).

use hough_heading::odometry::{
    prior_sigma_for_interval, Against, KeyframeOdometry, KeyframeSettings, Step,
};
use hough_heading::{Angle, Motion, Prior};
use serde::Serialize;

use hough_heading_recordings::model::Pose;
use hough_heading_recordings::pairs::{self, PairEstimate};
use hough_heading_recordings::trajectory::{fused_delta, Kept};

use super::loops::Node;

/// The chain of a run, and the scans it may estimate the next one against.
pub struct Chain {
    odometry: KeyframeOdometry,
    /// The prior's σ from the time since the last placed scan
    /// ([`prior_sigma_for_interval`]), unless `--prior-sigma` fixed it.
    sigma_from_time: bool,
    /// The time of the last scan tried, seconds.
    last_time: Option<f64>,
    /// The keyframe and the one before it: indices into `nodes`.
    keyframe: Option<usize>,
    previous_keyframe: Option<usize>,
    /// The last scan, when the chain left it unplaced: the next scan's
    /// estimate against it carries the hypothesis on.
    unplaced_scan: Option<Kept>,
    /// Every placed scan, in order, with its chained pose (the last is the
    /// last placed scan): the stored scans, and the pose graph's nodes
    /// (`--loops`).
    pub nodes: Vec<Node>,
}

/// What the chain made of one scan, as the output line reports it.
#[derive(Clone, Debug, Serialize)]
pub struct ChainLine {
    /// How the step was made: `estimate` (a confident estimate), `prior`
    /// (made confident by the motion prior), `unplaced` (nothing placed it:
    /// the prediction, left out of the chain), `carried` (nothing placed it
    /// nor the scans before: the chain goes on from the candidate nearest
    /// the prediction, or the prediction).
    pub source: &'static str,
    /// The stored scan it was placed against (`keyframe`, `last_placed`,
    /// `previous_keyframe`), and that scan's index.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub against: Option<&'static str>,
    /// Index of the scan it was placed against.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub against_scan: Option<usize>,
    /// The scan is now the keyframe.
    pub keyframe: bool,
    /// The prior the placing estimate was made with (its α turned into the
    /// robot's heading change from the stored scan, degrees, and σ).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub prior: Option<PriorLine>,
    /// The scan's chained pose: metres and degrees, in the first scan's
    /// frame.
    pub x_m: f64,
    /// y, metres.
    pub y_m: f64,
    /// Heading, degrees in (−180, 180].
    pub theta_deg: f64,
    /// One standard deviation of the chained heading, degrees.
    pub heading_sigma_deg: f64,
}

/// A motion prior, in the robot's terms.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct PriorLine {
    /// Predicted heading change, degrees.
    pub dtheta_deg: f64,
    /// One standard deviation, degrees.
    pub sigma_deg: f64,
}

/// One estimate of the new scan against a stored scan: what was tried.
pub struct Offer<'a> {
    /// The stored scan.
    pub against: Against,
    /// The estimate.
    pub estimate: &'a PairEstimate,
    /// The prior it was made with.
    pub prior: Option<Prior>,
}

impl Chain {
    /// A chain whose keyframe moves on every placed scan (`every_scan`:
    /// consecutive pairs) or by the library's rule, with the motion prior's
    /// σ = `sigma_deg`.
    pub fn new(sigma_deg_given: Option<f64>, every_scan: bool) -> Self {
        let sigma_deg = sigma_deg_given.unwrap_or(30.0);
        let settings = KeyframeSettings {
            prior_sigma: Angle::from_degrees(sigma_deg as f32),
            ..KeyframeSettings::default()
        };
        let mut chain = Self {
            odometry: KeyframeOdometry::new(settings),
            sigma_from_time: sigma_deg_given.is_none(),
            last_time: None,
            keyframe: None,
            previous_keyframe: None,
            unplaced_scan: None,
            nodes: Vec::new(),
        };
        chain.keep_every_scan(every_scan);
        chain
    }

    /// Makes every placed scan a keyframe (consecutive pairs), or the
    /// library's rule decide (keyframes).
    pub fn keep_every_scan(&mut self, every_scan: bool) {
        let settings = self.odometry.settings_mut();
        settings.min_overlap = if every_scan {
            KeyframeSettings::default().consecutive().min_overlap
        } else {
            KeyframeSettings::default().min_overlap
        };
    }

    /// The first scan.
    pub fn start(&mut self, first: &Kept) {
        self.odometry.start();
        self.keyframe = Some(0);
        self.previous_keyframe = None;
        self.unplaced_scan = None;
        self.nodes = vec![Node {
            scan: first.clone(),
            pose: Pose::ZERO,
            variance: 0.0,
        }];
        self.last_time = first.1.time;
    }

    /// The scan just before, when the chain left it unplaced.
    pub fn unplaced_scan(&self) -> Option<&Kept> {
        self.unplaced_scan.as_ref()
    }

    /// The current keyframe's scan.
    pub fn keyframe(&self) -> Option<&Kept> {
        self.keyframe.map(|k| &self.nodes[k].scan)
    }

    /// The stored scans to try `scan` against, in order, with the scan
    /// each names; the prior's σ is set from the time since the last placed
    /// scan first, unless `--prior-sigma` fixed it.
    pub fn attempts(&mut self, scan: &Kept) -> Vec<(Against, Kept)> {
        if self.sigma_from_time {
            let since = self
                .nodes
                .last()
                .and_then(|s| Some(scan.1.time? - s.scan.1.time?));
            let since = since.map_or(f32::NAN, |t| t as f32);
            // The stream's rate at this scan: the time since the scan before.
            let interval = self
                .last_time
                .zip(scan.1.time)
                .map_or(f32::NAN, |(a, b)| (b - a) as f32);
            let settings = self.odometry.settings_mut();
            *settings = settings.for_interval(interval);
            settings.prior_sigma = prior_sigma_for_interval(since);
        }
        self.last_time = scan.1.time;
        self.odometry
            .attempts()
            .filter_map(|a| self.stored(a).map(|s| (a, s.scan.clone())))
            .collect()
    }

    fn stored(&self, against: Against) -> Option<&Node> {
        let index = match against {
            Against::Keyframe => self.keyframe,
            Against::LastPlaced => self.nodes.len().checked_sub(1),
            Against::PreviousKeyframe => self.previous_keyframe,
        };
        index.and_then(|k| self.nodes.get(k))
    }

    /// The prior to estimate the scan again with against `against`, when
    /// `estimate` wants one.
    pub fn prior_for(&self, against: Against, estimate: &PairEstimate) -> Option<Prior> {
        self.odometry
            .wants_prior(against, &estimate.estimate)
            .then(|| self.odometry.prior(against))
            .flatten()
    }

    /// `with_prior` contradicts an answer that wanted the prior
    /// ([`KeyframeOdometry::contradicts`]).
    pub fn contradicts(&self, against: Against, with_prior: &PairEstimate) -> bool {
        self.odometry.contradicts(against, &with_prior.estimate)
    }

    /// The robot's motion of `estimate` (the odometry's translation along a
    /// corridor, as the trajectory of the pairs alone takes it).
    fn delta(estimate: &PairEstimate, odom: Option<Pose>) -> (Pose, Motion) {
        let (x, y) = fused_delta(estimate, odom).map_or((0.0, 0.0), |(d, _)| (d.x, d.y));
        let delta = Pose {
            x,
            y,
            theta: estimate.dtheta_deg.to_radians(),
        };
        let motion = Motion {
            dtheta: delta.theta as f32,
            translation: Some((delta.x as f32, delta.y as f32)),
        };
        (delta, motion)
    }

    /// Offers one estimate of `scan` (odometry `odom` from the stored scan);
    /// the line and pose when it places the scan.
    pub fn offer(
        &mut self,
        scan: &Kept,
        offer: &Offer<'_>,
        odom: Option<Pose>,
    ) -> Option<(ChainLine, Pose)> {
        let (delta, motion) = Self::delta(offer.estimate, odom);
        let step = self.odometry.place(
            offer.against,
            &offer.estimate.estimate,
            &motion,
            offer.prior.is_some(),
        )?;
        let from = self.stored(offer.against)?;
        let (pose, from_scan) = (from.pose.compose(&delta), from.scan.0);
        Some(self.record(scan, step, pose, Some(from_scan), offer.prior))
    }

    /// Ends `scan` when no offer placed it. `previous`: its estimate
    /// against the scan just before it and the odometry between them;
    /// `guess`: the best flagged estimate (made with the prior) and the
    /// odometry from its stored scan.
    pub fn unplaced(
        &mut self,
        scan: &Kept,
        previous: Option<(&PairEstimate, Option<Pose>)>,
        guess: Option<(&Offer<'_>, Option<Pose>)>,
    ) -> (ChainLine, Pose) {
        let deltas = guess.map(|(o, odom)| (o, Self::delta(o.estimate, odom)));
        let previous = previous.map(|(e, odom)| (e, Self::delta(e, odom).1));
        let from = self.odometry.last_placed();
        let step = self.odometry.leave_unplaced(
            previous.as_ref().map(|(e, m)| (&e.estimate, m)),
            deltas
                .as_ref()
                .map(|(o, (_, m))| (o.against, &o.estimate.estimate, m)),
        );
        // The candidate's own f64 motion when the chain carried it, else the
        // library's prediction from the last placed scan.
        let taken = match (step.against, &deltas) {
            (Some(a), Some((o, (d, _)))) if o.against == a => self
                .stored(a)
                .map(|s| (s.pose.compose(d), Some(s.scan.0), o.prior)),
            _ => None,
        };
        let (pose, from_scan, prior) = taken.unwrap_or_else(|| {
            let last = self.nodes.last().map_or(Pose::ZERO, |s| s.pose);
            let r = from.between(&step.pose);
            let delta = Pose {
                x: f64::from(r.x),
                y: f64::from(r.y),
                theta: f64::from(r.heading.to_degrees()).to_radians(),
            };
            (last.compose(&delta), None, None)
        });
        self.record(scan, step, pose, from_scan, prior)
    }

    /// Stores the scan as the step says, and its line.
    fn record(
        &mut self,
        scan: &Kept,
        step: Step,
        pose: Pose,
        from_scan: Option<usize>,
        prior: Option<Prior>,
    ) -> (ChainLine, Pose) {
        self.unplaced_scan = (!step.source.is_placed()).then(|| scan.clone());
        if step.source.is_placed() {
            if step.new_keyframe {
                self.previous_keyframe = self.keyframe.replace(self.nodes.len());
            }
            self.nodes.push(Node {
                scan: scan.clone(),
                pose,
                variance: f64::from(step.heading_sigma_deg).powi(2),
            });
        }
        let line = ChainLine {
            source: step.source.name(),
            against: step.against.map(Against::name),
            against_scan: from_scan,
            keyframe: step.new_keyframe,
            prior: prior.map(|p| PriorLine {
                dtheta_deg: round(-f64::from(p.alpha.to_degrees())),
                sigma_deg: round(f64::from(p.sigma.to_degrees())),
            }),
            x_m: round(pose.x),
            y_m: round(pose.y),
            theta_deg: round(pose.theta.to_degrees()),
            heading_sigma_deg: round(f64::from(step.heading_sigma_deg)),
        };
        (line, pose)
    }
}

fn round(v: f64) -> f64 {
    pairs::round(v, 4)
}
