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
//!   from the keyframe by **constant velocity** (the last step's motion,
//!   repeated) as a [`Prior`] of σ = [`KeyframeSettings::prior_sigma`];
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
    /// last step repeated. `None` before the chain has a step.
    ///
    /// The scans' times are not used: recordings kept by distance or turn
    /// (gmapping's, the shared logs) have gaps of seconds to a minute
    /// between steps of similar size. Scaling the step by the time ratio
    /// (clamped to 4) put half turns into the chain on the shared aces log
    /// (`docs/stream.md`).
    pub fn predicted(&self) -> Option<RobotPose> {
        let step = self.velocity?;
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
    /// robot's `motion` (`None`: no estimate; `by_prior`: the estimate was
    /// made with [`prior`](Self::prior)). Returns its pose and whether it
    /// is the next keyframe. The first scan must come through
    /// [`start`](Self::start); an update before it starts the chain.
    pub fn update(&mut self, estimate: Option<(&Estimate, &Motion)>, by_prior: bool) -> Step {
        if !self.started {
            return self.start();
        }
        let prior = self.prior();
        let (relative, source) = match estimate {
            Some((e, m)) => {
                let confident = e.status == Status::Confident;
                // A weak match (not an ambiguity between good ones) is taken
                // only near the prediction: within 1σ instead of 3σ.
                let weak = matches!(
                    e.status,
                    Status::LowOverlap | Status::SearchCut | Status::NoStructure
                );
                let gate = if weak { 1 } else { 3 };
                let near = prior.map(|p| within(e.alpha, &p, gate));
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
    within(alpha, prior, 3)
}

/// `alpha` lies within `k`σ of the prior's α.
fn within(alpha: Angle, prior: &Prior, k: u32) -> bool {
    alpha.distance(prior.alpha) <= Angle(prior.sigma.0.saturating_mul(k))
}
