//! Keyframe odometry: a robot's stream of scans chained into one path, and
//! a constant-velocity motion prior that carries it through flagged pairs.
//!
//! A pair of scans can be honestly ambiguous (a corridor seen by a 180°
//! sensor matches itself turned by half a turn; a low-overlap outdoor pair
//! has several fits), and the estimator flags it. A robot on its own stream
//! knows more than the pair: it cannot turn half a turn between two scans
//! of one trip without having been turning already. [`KeyframeOdometry`]
//! keeps that knowledge:
//!
//! * each scan is estimated against the current **keyframe** (a scan the
//!   caller keeps as a reference), not against the previous scan, so the
//!   errors of the scans in between do not add up;
//! * [`KeyframeOdometry::prior`] predicts the rotation of the next scan
//!   from the keyframe by **damped constant velocity** (the last step's
//!   motion repeated, half its turn: [`TURN_KEPT_DIVISOR`]) as a
//!   [`Prior`] of σ = [`KeyframeSettings::prior_sigma`];
//! * [`KeyframeOdometry::update`] takes a confident estimate as it is; a
//!   flagged one (the caller estimates it again with the prior, which picks
//!   the candidate nearest the prediction) is taken when it lies within 3σ
//!   of the prediction, marked [`StepSource::Prior`]; otherwise the
//!   prediction itself is taken, marked [`StepSource::Predicted`]. A flagged
//!   pair never breaks the chain;
//! * the scan becomes the next keyframe when its step is not a confident
//!   estimate ([`StepSource::Estimate`]) or its overlap with the keyframe fell below
//!   [`KeyframeSettings::min_overlap`].
//!
//! # Conventions
//!
//! Poses ([`RobotPose`]) are the robot's, in the frame of the first scan:
//! metres, x forward, y left, heading counter-clockwise (a binary
//! [`Angle`]). A step is the robot's [`Motion`] from one scan to another
//! (the scan-pair files' convention; [`Raster::motion`](crate::Raster::motion)),
//! and a prior is on the estimator's α = −dθ (DESIGN.md §2).
//!
//! # Numbers
//!
//! `f32` for positions, a binary angle for the heading, the library's
//! Q16 sine table (error below 2·10⁻⁵) for rotations: a few dozen float
//! operations a scan, no trigonometric function. No allocation, no panic.
//!
//! Measured on the shared whole logs and their LD06 / RPLIDAR captures
//! (`docs/stream.md`, `bash tools/stream_figures.sh`).

use crate::angle::Angle;
use crate::estimate::{Estimate, Prior, Status};
use crate::motion::Motion;
use crate::scan::sine::sin_cos;
use crate::Score;

/// The prediction repeats the last step's translation and this fraction
/// (1/2) of its turn: a robot's turn rate falls back towards zero. On the
/// shared logs' consecutive scans the halved turn is off by at most 68°,
/// 55°, 62° and 18° (aces, orebro, seattle, freiburg-campus), the whole
/// turn by 96°, 69°, 60° and 23°, no turn by 78°, 76°, 81° and 16°; a
/// prediction more than 90° off puts the half turn nearer. Chosen on those
/// logs (`docs/stream.md`).
pub const TURN_KEPT_DIVISOR: i32 = 2;

/// A robot pose in the plane: metres and a binary angle (x forward, y
/// left, heading counter-clockwise).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RobotPose {
    /// Forward, metres.
    pub x: f32,
    /// Left, metres.
    pub y: f32,
    /// Heading, counter-clockwise.
    pub heading: Angle,
}

impl RobotPose {
    /// The pose `step` (in this pose's frame) leads to: `self ∘ step`.
    /// Rotation error below 3·10⁻⁵ of the step's length (the sine table).
    pub fn compose(&self, step: &RobotPose) -> RobotPose {
        let (s, c) = unit(self.heading);
        RobotPose {
            x: self.x + c * step.x - s * step.y,
            y: self.y + s * step.x + c * step.y,
            heading: Angle(self.heading.0.wrapping_add(step.heading.0)),
        }
    }

    /// `other` in this pose's frame: `self⁻¹ ∘ other`.
    pub fn between(&self, other: &RobotPose) -> RobotPose {
        let (s, c) = unit(self.heading);
        let (dx, dy) = (other.x - self.x, other.y - self.y);
        RobotPose {
            x: c * dx + s * dy,
            y: -s * dx + c * dy,
            heading: Angle(other.heading.0.wrapping_sub(self.heading.0)),
        }
    }

    /// A robot motion as a step; a missing translation counts as none.
    pub fn of_motion(motion: &Motion) -> RobotPose {
        let (x, y) = motion.translation.unwrap_or((0.0, 0.0));
        RobotPose {
            x,
            y,
            heading: angle_of_radians(motion.dtheta),
        }
    }

    /// This pose taken as a motion (`dθ` in radians in (−π, π], error below
    /// 10⁻⁶ rad).
    pub fn to_motion(&self) -> Motion {
        Motion {
            dtheta: self.heading.to_degrees() * (core::f32::consts::PI / 180.0),
            translation: Some((self.x, self.y)),
        }
    }
}

/// `(sin, cos)` of `a` from the Q16 table.
fn unit(a: Angle) -> (f32, f32) {
    let (s, c) = sin_cos(a.0);
    (s as f32 / 65_536.0, c as f32 / 65_536.0)
}

/// Radians (any finite value, wrapped; non-finite: 0) as a binary angle.
fn angle_of_radians(radians: f32) -> Angle {
    Angle::from_degrees(radians * (180.0 / core::f32::consts::PI))
}

/// What the chain's settings are. [`Default`]: σ 30°, overlap 0.6.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct KeyframeSettings {
    /// One standard deviation of the constant-velocity prediction of the
    /// rotation; candidates beyond 3σ are not taken. The default 30° puts
    /// the gate at 90°: a half turn is never within it of a prediction
    /// less than 90° off. On the shared logs' consecutive scans (recorded
    /// every ~1 m or ~30° of turn, far sparser than a 10 Hz lidar) the
    /// prediction is off by 63° at the 99th percentile (96° at most).
    pub prior_sigma: Angle,
    /// A scan becomes the next keyframe when its overlap with the keyframe
    /// ([`Estimate::overlap`]) is below this.
    pub min_overlap: Score,
}

impl Default for KeyframeSettings {
    fn default() -> Self {
        Self {
            prior_sigma: Angle::from_degrees(30.0),
            min_overlap: Score::from_bits(39_322), // 0.6
        }
    }
}

/// Where a step of the chain came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StepSource {
    /// The first scan: the origin.
    Start,
    /// A confident estimate.
    Estimate,
    /// A flagged estimate within 3σ of the motion prior: the candidate
    /// nearest the constant-velocity prediction.
    Prior,
    /// No estimate within 3σ of the prediction (or none at all): the
    /// constant-velocity prediction itself (no motion before the chain has
    /// a step).
    Predicted,
    /// A flagged estimate taken as it is: the chain has no step yet to
    /// predict from (its second scan).
    Flagged,
}

impl StepSource {
    /// Its name in lower case (`start`, `estimate`, `prior`, `predicted`,
    /// `flagged`), as the tool's `chain.source` prints it.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Start => "start",
            Self::Estimate => "estimate",
            Self::Prior => "prior",
            Self::Predicted => "predicted",
            Self::Flagged => "flagged",
        }
    }
}

/// One scan's place in the chain ([`KeyframeOdometry::update`]).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Step {
    /// The scan's pose in the first scan's frame.
    pub pose: RobotPose,
    /// Where the step came from.
    pub source: StepSource,
    /// The scan is now the keyframe: estimate the next scans against it.
    pub new_keyframe: bool,
}

/// The chain of a robot's scans (see the module doc). RAM: 56 bytes.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct KeyframeOdometry {
    settings: KeyframeSettings,
    /// The keyframe's pose.
    keyframe: RobotPose,
    /// The last scan's pose.
    pose: RobotPose,
    /// The last step (previous scan → last scan).
    velocity: Option<RobotPose>,
    started: bool,
}

impl KeyframeOdometry {
    /// A chain that has seen no scan yet.
    pub const fn new(settings: KeyframeSettings) -> Self {
        Self {
            settings,
            keyframe: RobotPose {
                x: 0.0,
                y: 0.0,
                heading: Angle::ZERO,
            },
            pose: RobotPose {
                x: 0.0,
                y: 0.0,
                heading: Angle::ZERO,
            },
            velocity: None,
            started: false,
        }
    }

    /// The settings.
    pub const fn settings(&self) -> &KeyframeSettings {
        &self.settings
    }

    /// The last scan's pose (the origin before the first).
    pub const fn pose(&self) -> RobotPose {
        self.pose
    }

    /// The keyframe's pose.
    pub const fn keyframe(&self) -> RobotPose {
        self.keyframe
    }

    /// The first scan: the origin and the first keyframe. A chain already
    /// started starts again.
    pub fn start(&mut self) -> Step {
        *self = Self::new(self.settings);
        self.started = true;
        Step {
            pose: self.pose,
            source: StepSource::Start,
            new_keyframe: true,
        }
    }

    /// The predicted pose of the next scan, in the keyframe's frame: the
    /// last step repeated, its turn halved ([`TURN_KEPT_DIVISOR`]). `None`
    /// before the chain has a step.
    ///
    /// The scans' times are not used: recordings kept by distance or turn
    /// (gmapping's, the shared logs) have gaps of seconds to a minute
    /// between steps of similar size. Scaling the step by the time ratio
    /// (clamped to 4) put half turns into the chain on the shared aces log
    /// (`docs/stream.md`).
    pub fn predicted(&self) -> Option<RobotPose> {
        let step = self.velocity?;
        let turn = Angle((step.heading.signed() / TURN_KEPT_DIVISOR) as u32);
        let step = RobotPose {
            heading: turn,
            ..step
        };
        Some(self.keyframe.between(&self.pose.compose(&step)))
    }

    /// The prior on the estimator's α for the next scan against the
    /// keyframe: the predicted rotation turned into α = −dθ, with σ from
    /// the settings. `None` before the chain has a step.
    pub fn prior(&self) -> Option<Prior> {
        self.predicted().map(|p| Prior {
            alpha: Angle(p.heading.0.wrapping_neg()),
            sigma: self.settings.prior_sigma,
        })
    }

    /// Whether `estimate` (of the next scan against the keyframe) should
    /// be estimated again with [`prior`](Self::prior): it is flagged, or
    /// its rotation lies beyond 3σ of the prediction. Never before the
    /// chain has a step.
    pub fn wants_prior(&self, estimate: &Estimate) -> bool {
        let Some(prior) = self.prior() else {
            return false;
        };
        estimate.status != Status::Confident || !within_gate(estimate.alpha, &prior)
    }

    /// Adds the next scan, whose `estimate` against the keyframe gave the
    /// robot's `motion` (`None` or a non-finite motion: no estimate;
    /// `by_prior`: the estimate was
    /// made with [`prior`](Self::prior)). Returns its pose and whether it
    /// is the next keyframe. The first scan must come through
    /// [`start`](Self::start); an update before it starts the chain.
    pub fn update(&mut self, estimate: Option<(&Estimate, &Motion)>, by_prior: bool) -> Step {
        if !self.started {
            return self.start();
        }
        let prior = self.prior();
        // A non-finite motion is no estimate.
        let finite = |m: &Motion| {
            m.dtheta.is_finite()
                && m.translation
                    .is_none_or(|(x, y)| x.is_finite() && y.is_finite())
        };
        let estimate = estimate.filter(|(_, m)| finite(m));
        let (relative, source) = match estimate {
            Some((e, m)) => {
                let confident = e.status == Status::Confident;
                let near = prior.map(|p| within_gate(e.alpha, &p));
                let source = match (near, confident) {
                    (Some(true), true) if by_prior => StepSource::Prior,
                    (_, true) => StepSource::Estimate,
                    (Some(true), false) => StepSource::Prior,
                    (None, false) => StepSource::Flagged,
                    (Some(false), false) => StepSource::Predicted,
                };
                match (source, self.predicted()) {
                    (StepSource::Predicted, Some(p)) => (p, source),
                    _ => (RobotPose::of_motion(m), source),
                }
            }
            None => (self.predicted().unwrap_or_default(), StepSource::Predicted),
        };
        let pose = self.keyframe.compose(&relative);
        self.velocity = Some(self.pose.between(&pose));
        self.pose = pose;
        let overlap_low = estimate.is_none_or(|(e, _)| e.overlap < self.settings.min_overlap);
        let new_keyframe = source != StepSource::Estimate || overlap_low;
        if new_keyframe {
            self.keyframe = pose;
        }
        Step {
            pose,
            source,
            new_keyframe,
        }
    }
}

/// `alpha` lies within 3σ of the prior's α.
fn within_gate(alpha: Angle, prior: &Prior) -> bool {
    alpha.distance(prior.alpha) <= Angle(prior.sigma.0.saturating_mul(3))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An estimate of a robot turn of `dtheta_deg` (α = −dθ) with `status`
    /// and `overlap`, and its motion (1 m forward).
    fn step(dtheta_deg: f32, status: Status, overlap: f32) -> (Estimate, Motion) {
        let mut e = Estimate::no_structure();
        e.alpha = Angle::from_degrees(-dtheta_deg);
        e.status = status;
        e.overlap = Score::from_num(overlap);
        let m = Motion {
            dtheta: dtheta_deg.to_radians(),
            translation: Some((1.0, 0.0)),
        };
        (e, m)
    }

    fn degrees(a: Angle) -> f32 {
        a.to_degrees()
    }

    #[test]
    fn compose_and_between_match_f64() {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..500 {
            let (ax, ay, at) = (
                next() * 20.0 - 10.0,
                next() * 20.0 - 10.0,
                (next() - 0.5) * core::f64::consts::TAU,
            );
            let (bx, by, bt) = (
                next() * 4.0 - 2.0,
                next() * 4.0 - 2.0,
                (next() - 0.5) * core::f64::consts::TAU,
            );
            let pose = |x: f64, y: f64, t: f64| RobotPose {
                x: x as f32,
                y: y as f32,
                heading: Angle::from_degrees(t.to_degrees() as f32),
            };
            let (a, b) = (pose(ax, ay, at), pose(bx, by, bt));
            let c = a.compose(&b);
            // f64 reference: a ∘ b.
            let (s, co) = at.sin_cos();
            let (cx, cy) = (ax + co * bx - s * by, ay + s * bx + co * by);
            assert!((f64::from(c.x) - cx).abs() < 2e-4, "x {} vs {cx}", c.x);
            assert!((f64::from(c.y) - cy).abs() < 2e-4, "y {} vs {cy}", c.y);
            let dt = (f64::from(c.heading.to_degrees()) - (at + bt).to_degrees() + 540.0)
                .rem_euclid(360.0)
                - 180.0;
            assert!(dt.abs() < 1e-3, "heading off by {dt}°");
            // between undoes compose.
            let back = a.between(&c);
            assert!((back.x - b.x).abs() < 2e-4 && (back.y - b.y).abs() < 2e-4);
            assert!(back.heading.distance(b.heading) < Angle::from_degrees(1e-3));
        }
    }

    #[test]
    fn the_prior_repeats_the_last_step() {
        let mut chain = KeyframeOdometry::new(KeyframeSettings::default());
        assert_eq!(chain.start().source, StepSource::Start);
        assert_eq!(chain.prior(), None, "nothing to predict from yet");
        let (e, m) = step(20.0, Status::Confident, 0.9);
        let s = chain.update(Some((&e, &m)), false);
        assert_eq!(s.source, StepSource::Estimate);
        assert!(!s.new_keyframe, "overlap 0.9 keeps the keyframe");
        // The keyframe is still the first scan: 20° and half of 20° more.
        let prior = chain.prior().unwrap();
        assert!(
            (degrees(prior.alpha) + 30.0).abs() < 0.01,
            "{}",
            degrees(prior.alpha)
        );
        assert_eq!(prior.sigma, KeyframeSettings::default().prior_sigma);
    }

    #[test]
    fn a_flagged_half_turn_is_not_taken() {
        let mut chain = KeyframeOdometry::new(KeyframeSettings {
            min_overlap: Score::MAX, // every scan a keyframe: consecutive pairs
            ..KeyframeSettings::default()
        });
        chain.start();
        let (e, m) = step(10.0, Status::Confident, 0.9);
        chain.update(Some((&e, &m)), false);
        // The next pair is flagged and its answer is the half turn of the
        // truth (~10°): beyond 3σ = 90° of the prediction (5°).
        let (e, m) = step(-170.0, Status::AmbiguousDirection, 0.8);
        assert!(chain.wants_prior(&e));
        let s = chain.update(Some((&e, &m)), true);
        assert_eq!(s.source, StepSource::Predicted);
        assert!((degrees(s.pose.heading) - 15.0).abs() < 0.01);
        assert!(s.new_keyframe);
        // A flagged answer within 3σ is taken, marked.
        let (e, m) = step(40.0, Status::AmbiguousDirection, 0.8);
        let s = chain.update(Some((&e, &m)), true);
        assert_eq!(s.source, StepSource::Prior);
        assert!((degrees(s.pose.heading) - 55.0).abs() < 0.01);
    }

    #[test]
    fn a_low_overlap_answer_beyond_the_gate_gives_way_to_the_prediction() {
        let mut chain = KeyframeOdometry::new(KeyframeSettings::default());
        chain.start();
        let (e, m) = step(0.0, Status::Confident, 0.5);
        assert!(
            chain.update(Some((&e, &m)), false).new_keyframe,
            "overlap 0.5 < 0.6"
        );
        // Low overlap 100° from the prediction (0°): beyond 3σ = 90°.
        let (e, m) = step(100.0, Status::LowOverlap, 0.2);
        assert_eq!(
            chain.update(Some((&e, &m)), true).source,
            StepSource::Predicted
        );
        let (e, m) = step(45.0, Status::LowOverlap, 0.2);
        assert_eq!(chain.update(Some((&e, &m)), true).source, StepSource::Prior);
    }

    #[test]
    fn a_confident_answer_stands_without_a_prior_and_the_chain_never_breaks() {
        let mut chain = KeyframeOdometry::new(KeyframeSettings::default());
        // An update before start starts the chain.
        assert_eq!(chain.update(None, false).source, StepSource::Start);
        // A flagged second scan: nothing to predict from, taken as it is.
        let (e, m) = step(-30.0, Status::AmbiguousAxis, 0.7);
        assert!(!chain.wants_prior(&e));
        assert_eq!(
            chain.update(Some((&e, &m)), false).source,
            StepSource::Flagged
        );
        // No estimate at all: the prediction.
        let s = chain.update(None, false);
        assert_eq!(s.source, StepSource::Predicted);
        assert!((degrees(s.pose.heading) + 45.0).abs() < 0.01);
        // A confident answer far from the prediction stands.
        let (e, m) = step(100.0, Status::Confident, 0.9);
        assert!(
            chain.wants_prior(&e),
            "100° is 107.5° from the predicted −7.5°"
        );
        let s = chain.update(Some((&e, &m)), false);
        assert_eq!(s.source, StepSource::Estimate);
        assert!((degrees(s.pose.heading) - 55.0).abs() < 0.01);
        // Non-finite motions give finite poses.
        let bad = Motion {
            dtheta: f32::NAN,
            translation: Some((f32::INFINITY, 0.0)),
        };
        let (e, _) = step(0.0, Status::Confident, 0.9);
        let s = chain.update(Some((&e, &bad)), false);
        assert_eq!(s.source, StepSource::Predicted);
        assert!(s.pose.x.is_finite() && s.pose.y.is_finite());
    }
}
