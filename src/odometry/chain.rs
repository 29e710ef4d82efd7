//! [`KeyframeOdometry`]: a robot's stream of scans chained into one path,
//! without a guessed step where a confident one can be had.
//!
//! A pair of scans can be honestly ambiguous (a corridor seen by a 180°
//! sensor matches itself turned by half a turn; a low-overlap pair has
//! several fits), and the estimator flags it. Taking such a pair's "best
//! guess" into the chain keeps its error for the rest of the run: on the
//! shared logs a handful of guessed low-overlap steps, each 10–95° off,
//! were the whole drift (DESIGN.md §3f). So the chain:
//!
//! * places a scan only by a **confident** estimate: against the
//!   **keyframe** first, then the **last placed** scan, then the
//!   **previous keyframe** ([`KeyframeOdometry::attempts`]); a flagged
//!   estimate, or a confident one beyond 3σ of the damped
//!   constant-velocity [`prior`](KeyframeOdometry::prior), may be made
//!   again with that prior and is taken when that is confident
//!   ([`StepSource::Prior`]);
//! * leaves a scan that none of them places **unplaced**
//!   ([`StepSource::Unplaced`]): its pose is the prediction, with the
//!   prior's σ, and it never becomes a keyframe: the next scans are tried
//!   against the same stored scans, and the first that is placed bridges
//!   the gap;
//! * only after [`KeyframeSettings::max_unplaced`] unplaced scans in a row
//!   **carries** one ([`StepSource::Carried`]): the candidate nearest the
//!   prediction when the caller offers one within 3σ of it, else the
//!   prediction; its σ grows by the prior's, and it becomes the keyframe
//!   so the chain goes on;
//! * takes a confident estimate as it is, never a guess instead;
//! * makes a placed scan the next keyframe when its overlap with the
//!   keyframe fell below [`KeyframeSettings::min_overlap`], or the robot
//!   turned or moved more than [`KeyframeSettings::max_turn`] /
//!   [`KeyframeSettings::max_distance_m`] since the keyframe, or it was
//!   placed against another stored scan. `min_overlap` = `Score::MAX`
//!   makes every placed scan a keyframe: consecutive pairs.
//!
//! Every step states the heading σ of its pose ([`Step::heading_sigma_deg`]):
//! the variances of the steps since the first scan, summed
//! ([`KeyframeSettings::step_sigma_deg`] a confident step,
//! [`KeyframeSettings::prior_step_sigma_deg`] one made confident by the
//! prior, [`KeyframeSettings::prior_sigma`] a prediction).

use super::pose::{sqrt, RobotPose};
#[cfg(doc)]
use super::settings::prior_sigma_for_interval;
use super::settings::{KeyframeSettings, TURN_KEPT_DIVISOR};
use crate::angle::Angle;
use crate::estimate::{Estimate, Prior, Status};
use crate::motion::Motion;

/// Which stored scan an estimate of the new scan is made against.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Against {
    /// The current keyframe.
    Keyframe,
    /// The last placed scan (when it is not the keyframe).
    LastPlaced,
    /// The keyframe before the current one.
    PreviousKeyframe,
}

impl Against {
    /// Its name in lower case (`keyframe`, `last_placed`,
    /// `previous_keyframe`), as the tool prints it.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Keyframe => "keyframe",
            Self::LastPlaced => "last_placed",
            Self::PreviousKeyframe => "previous_keyframe",
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
    /// A flagged estimate made confident by the motion prior.
    Prior,
    /// Nothing placed the scan: its pose is the prediction, and it is left
    /// out of the chain (never a keyframe, never estimated against).
    Unplaced,
    /// Nothing placed this scan nor the [`KeyframeSettings::max_unplaced`]
    /// before it: the chain carries it (the candidate nearest the
    /// prediction within 3σ, else the prediction) and goes on from it.
    Carried,
}

impl StepSource {
    /// Its name in lower case (`start`, `estimate`, `prior`, `unplaced`,
    /// `carried`), as the tool's `chain.source` prints it.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Start => "start",
            Self::Estimate => "estimate",
            Self::Prior => "prior",
            Self::Unplaced => "unplaced",
            Self::Carried => "carried",
        }
    }

    /// The scan is in the chain: the next scans may be estimated against it.
    pub const fn is_placed(self) -> bool {
        !matches!(self, Self::Unplaced)
    }
}

/// One scan's place in the chain.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Step {
    /// The scan's pose in the first scan's frame.
    pub pose: RobotPose,
    /// One standard deviation of its heading, degrees.
    pub heading_sigma_deg: f32,
    /// Where the step came from.
    pub source: StepSource,
    /// The stored scan it was placed against (`None`: start, unplaced, or
    /// carried on the prediction).
    pub against: Option<Against>,
    /// The scan is now the keyframe: estimate the next scans against it
    /// (the old keyframe becomes [`Against::PreviousKeyframe`]).
    pub new_keyframe: bool,
}

/// A stored scan's pose and heading variance (degrees²).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
struct Placed {
    pose: RobotPose,
    variance: f32,
}

/// The chain of a robot's scans (see the module doc). RAM: 96 bytes.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct KeyframeOdometry {
    settings: KeyframeSettings,
    keyframe: Placed,
    last_placed: Placed,
    /// The last placed scan is the keyframe.
    last_is_keyframe: bool,
    previous_keyframe: Option<Placed>,
    /// The motion per scan interval between the last two placed scans.
    velocity: Option<RobotPose>,
    /// Scans left unplaced since the last placed one.
    unplaced: u32,
    /// The last unplaced scan's pose and variance: the candidate nearest
    /// the prediction for the first, then the confident steps between the
    /// unplaced scans (the chain's best hypothesis while it waits).
    floating: Placed,
    /// The last scan's step.
    last: Step,
    started: bool,
}

impl KeyframeOdometry {
    /// A chain that has seen no scan yet.
    pub const fn new(settings: KeyframeSettings) -> Self {
        const ORIGIN: Placed = Placed {
            pose: RobotPose::ZERO,
            variance: 0.0,
        };
        Self {
            settings,
            keyframe: ORIGIN,
            last_placed: ORIGIN,
            last_is_keyframe: true,
            previous_keyframe: None,
            velocity: None,
            unplaced: 0,
            floating: ORIGIN,
            last: Step {
                pose: RobotPose::ZERO,
                heading_sigma_deg: 0.0,
                source: StepSource::Start,
                against: None,
                new_keyframe: true,
            },
            started: false,
        }
    }

    /// The settings.
    pub const fn settings(&self) -> &KeyframeSettings {
        &self.settings
    }

    /// The last scan's step (the origin before the first scan).
    pub const fn last(&self) -> &Step {
        &self.last
    }

    /// The last scan's pose.
    pub const fn pose(&self) -> RobotPose {
        self.last.pose
    }

    /// The last placed scan's pose.
    pub const fn last_placed(&self) -> RobotPose {
        self.last_placed.pose
    }

    /// The keyframe's pose.
    pub const fn keyframe(&self) -> RobotPose {
        self.keyframe.pose
    }

    /// The first scan: the origin and the first keyframe. A chain already
    /// started starts again.
    pub fn start(&mut self) -> Step {
        *self = Self::new(self.settings);
        self.started = true;
        self.last
    }

    /// The stored scans to estimate the next scan against, in order:
    /// the keyframe, the last placed scan when it is another, the previous
    /// keyframe when there is one. Stop at the first that places it
    /// ([`place`](Self::place)).
    pub fn attempts(&self) -> impl Iterator<Item = Against> {
        let last = (!self.last_is_keyframe).then_some(Against::LastPlaced);
        let previous = self
            .previous_keyframe
            .is_some()
            .then_some(Against::PreviousKeyframe);
        [Some(Against::Keyframe), last, previous]
            .into_iter()
            .flatten()
    }

    fn stored(&self, against: Against) -> Placed {
        match against {
            Against::Keyframe => self.keyframe,
            Against::LastPlaced => self.last_placed,
            Against::PreviousKeyframe => self.previous_keyframe.unwrap_or(self.keyframe),
        }
    }

    /// The predicted pose of the next scan (the first scan's frame): the
    /// last step per scan, its turn divided by [`TURN_KEPT_DIVISOR`],
    /// repeated from the last placed scan over the scans since; no motion
    /// before the chain has a step. (An unplaced scan's hypothesis does not
    /// move the prediction: it may be a guess.)
    ///
    /// The scans' times are not used here: recordings kept by distance or
    /// turn (gmapping's, the shared logs) have gaps of seconds to a minute
    /// between steps of similar size. They set the prior's σ instead
    /// ([`prior_sigma_for_interval`]).
    pub fn predicted(&self) -> RobotPose {
        let Some(step) = self.velocity else {
            return self.last_placed.pose;
        };
        let step = RobotPose {
            heading: Angle((step.heading.signed() / TURN_KEPT_DIVISOR) as u32),
            ..step
        };
        let mut pose = self.last_placed.pose;
        for _ in 0..=self.unplaced.min(u32::from(u8::MAX)) {
            pose = pose.compose(&step);
        }
        pose
    }

    /// The settings, to change between scans (e.g. the prior's σ from the
    /// time since the last placed scan: [`prior_sigma_for_interval`]).
    pub fn settings_mut(&mut self) -> &mut KeyframeSettings {
        &mut self.settings
    }

    /// The prior on the estimator's α for the next scan against `against`:
    /// the predicted rotation from that scan turned into α = −dθ, with σ
    /// from the settings. `None` before the chain has a step.
    pub fn prior(&self, against: Against) -> Option<Prior> {
        self.velocity?;
        let relative = self.stored(against).pose.between(&self.predicted());
        Some(Prior {
            alpha: Angle(relative.heading.0.wrapping_neg()),
            sigma: self.settings.prior_sigma,
        })
    }

    /// Whether `estimate` (of the next scan against `against`) should be
    /// made again with [`prior`](Self::prior) and offered first: it is not
    /// confident, or its rotation lies beyond 3σ of the prediction (then the
    /// answer made with the prior is taken if it is confident, else this
    /// one: a confident answer is never replaced by a guess). Never before
    /// the chain has a step.
    pub fn wants_prior(&self, against: Against, estimate: &Estimate) -> bool {
        let Some(prior) = self.prior(against) else {
            return false;
        };
        let gate = Angle(prior.sigma.0.saturating_mul(3));
        estimate.status != Status::Confident || estimate.alpha.distance(prior.alpha) > gate
    }

    /// Whether `with_prior` (the next scan against `against`, made with
    /// [`prior`](Self::prior)) contradicts a confident answer beyond 3σ
    /// of the prediction: its own rotation lies within 3σ. Then neither is
    /// placed (on the shared freiburg-campus log such confident answers
    /// were half turns, the prior's low-overlap answers right), and the scan
    /// is left unplaced with `with_prior` as the guess.
    pub fn contradicts(&self, against: Against, with_prior: &Estimate) -> bool {
        self.prior(against).is_some_and(|prior| {
            with_prior.alpha.distance(prior.alpha) <= Angle(prior.sigma.0.saturating_mul(3))
        })
    }

    /// Offers an `estimate` of the next scan against `against` that gave
    /// the robot's `motion` from that scan (`by_prior`: made with
    /// [`prior`](Self::prior)). A confident estimate with a finite motion
    /// places the scan: its step is returned. A bridge, or an answer made
    /// with the prior, must also lie within 3σ of the prediction; an answer
    /// made with the prior places nothing unless
    /// [`KeyframeSettings::takes_prior_answers`]. Otherwise `None`: try the
    /// next of [`attempts`](Self::attempts), then
    /// [`leave_unplaced`](Self::leave_unplaced). Before [`start`](Self::start)
    /// the scan starts the chain.
    pub fn place(
        &mut self,
        against: Against,
        estimate: &Estimate,
        motion: &Motion,
        by_prior: bool,
    ) -> Option<Step> {
        if !self.started {
            return Some(self.start());
        }
        if estimate.status != Status::Confident
            || !finite(motion)
            || (by_prior && !self.settings.takes_prior_answers)
        {
            return None;
        }
        let (source, sigma) = if by_prior {
            (StepSource::Prior, self.settings.prior_step_sigma_deg)
        } else {
            (StepSource::Estimate, self.settings.step_sigma_deg)
        };
        let from = self.stored(against);
        let placed = Placed {
            pose: from.pose.compose(&RobotPose::of_motion(motion)),
            variance: from.variance + sigma * sigma,
        };
        // A bridge (over unplaced scans, or from a stored scan other than the
        // keyframe) spans more than one step: it must also agree with the
        // prediction, as a confident answer over a long gap is more often
        // wrong (the shared seattle log: a 5-scan bridge 145° off). So must
        // an answer made with the prior: the prior weighs the candidates,
        // it does not bound them (the dense sim/orebro stream: one 17° from
        // a 5° prior, and 17° off).
        let bridge = self.unplaced > 0 || against != Against::Keyframe || by_prior;
        if bridge && self.velocity.is_some() && !self.within_gate(placed.pose.heading) {
            return None;
        }
        let moved = self.keyframe.pose.between(&placed.pose);
        let limit = self.settings.max_distance_m;
        let new_keyframe = against != Against::Keyframe
            || estimate.overlap < self.settings.min_overlap
            || moved.heading.distance(Angle::ZERO) > self.settings.max_turn
            // A non-finite distance counts as moved too far.
            || !matches!(
                moved.distance_squared().partial_cmp(&(limit * limit)),
                Some(core::cmp::Ordering::Less | core::cmp::Ordering::Equal)
            );
        Some(self.add(placed, source, Some(against), new_keyframe))
    }

    /// Ends the next scan when no estimate placed it. `previous`: the
    /// estimate of the scan against the scan just before it and its
    /// motion, when that scan was itself left unplaced (a confident one
    /// carries the hypothesis on at a confident step's σ). `guess`: the
    /// caller's best flagged estimate against a stored scan (made with the
    /// prior) and its motion, taken as the hypothesis when its rotation lies
    /// within 3σ of the prediction and the settings take such answers
    /// ([`KeyframeSettings::takes_prior_answers`]); else the prediction is. The scan is
    /// left unplaced at the hypothesis, or carried there after
    /// [`KeyframeSettings::max_unplaced`] unplaced scans.
    pub fn leave_unplaced(
        &mut self,
        previous: Option<(&Estimate, &Motion)>,
        guess: Option<(Against, &Estimate, &Motion)>,
    ) -> Step {
        if !self.started {
            return self.start();
        }
        let prior_sigma = self.settings.prior_sigma.to_degrees();
        let step = self.settings.step_sigma_deg;
        let follows = previous
            .filter(|(e, m)| self.unplaced > 0 && e.status == Status::Confident && finite(m));
        let (hypothesis, against) = match follows {
            Some((_, m)) => (
                Placed {
                    pose: self.floating.pose.compose(&RobotPose::of_motion(m)),
                    variance: self.floating.variance + step * step,
                },
                None,
            ),
            None => {
                let base = if self.unplaced > 0 {
                    self.floating.variance
                } else {
                    self.last_placed.variance
                };
                let variance = base + prior_sigma * prior_sigma;
                let guessed = guess
                    .filter(|(_, _, m)| finite(m) && self.settings.takes_prior_answers)
                    .and_then(|(against, _, m)| {
                        let pose = self.stored(against).pose.compose(&RobotPose::of_motion(m));
                        self.within_gate(pose.heading).then_some((against, pose))
                    });
                match guessed {
                    Some((against, pose)) => (Placed { pose, variance }, Some(against)),
                    None => (
                        Placed {
                            pose: self.predicted(),
                            variance,
                        },
                        None,
                    ),
                }
            }
        };
        if self.unplaced < u32::from(self.settings.max_unplaced) {
            self.unplaced += 1;
            self.floating = hypothesis;
            self.last = Step {
                pose: hypothesis.pose,
                heading_sigma_deg: sqrt(hypothesis.variance),
                source: StepSource::Unplaced,
                against,
                new_keyframe: false,
            };
            return self.last;
        }
        self.add(hypothesis, StepSource::Carried, against, true)
    }

    /// `heading` lies within 3σ of the predicted heading.
    fn within_gate(&self, heading: Angle) -> bool {
        let gate = Angle(self.settings.prior_sigma.0.saturating_mul(3));
        heading.distance(self.predicted().heading) <= gate
    }

    /// Adds a placed scan.
    fn add(
        &mut self,
        placed: Placed,
        source: StepSource,
        against: Option<Against>,
        new_keyframe: bool,
    ) -> Step {
        let intervals = self.unplaced + 1;
        self.velocity = Some(
            self.last_placed
                .pose
                .between(&placed.pose)
                .divided(intervals),
        );
        self.unplaced = 0;
        self.last_placed = placed;
        self.last_is_keyframe = new_keyframe;
        if new_keyframe {
            self.previous_keyframe = Some(self.keyframe);
            self.keyframe = placed;
        }
        self.last = Step {
            pose: placed.pose,
            heading_sigma_deg: sqrt(placed.variance),
            source,
            against,
            new_keyframe,
        };
        self.last
    }
}

/// The motion is finite (a non-finite one is no estimate).
fn finite(m: &Motion) -> bool {
    m.dtheta.is_finite()
        && m.translation
            .is_none_or(|(x, y)| x.is_finite() && y.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Score;

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

    fn consecutive(max_unplaced: u8) -> KeyframeOdometry {
        KeyframeOdometry::new(KeyframeSettings {
            max_unplaced,
            ..KeyframeSettings::default().consecutive()
        })
    }

    /// `chain` started, and its second scan placed by a confident step of
    /// `dtheta_deg`.
    fn after_one_step(mut chain: KeyframeOdometry, dtheta_deg: f32) -> KeyframeOdometry {
        chain.start();
        let (e, m) = step(dtheta_deg, Status::Confident, 0.9);
        chain.place(Against::Keyframe, &e, &m, false).unwrap();
        chain
    }

    fn heading(s: &Step) -> f32 {
        s.pose.heading.to_degrees()
    }

    #[test]
    fn the_prior_repeats_half_the_last_turn() {
        let mut chain = KeyframeOdometry::new(KeyframeSettings::default());
        assert_eq!(chain.start().source, StepSource::Start);
        assert_eq!(
            chain.prior(Against::Keyframe),
            None,
            "nothing to predict from yet"
        );
        let (e, m) = step(20.0, Status::Confident, 0.9);
        let s = chain.place(Against::Keyframe, &e, &m, false).unwrap();
        assert_eq!(s.source, StepSource::Estimate);
        assert!(!s.new_keyframe, "overlap 0.9 and 20° keep the keyframe");
        // From the keyframe (the first scan): 20° and half of 20° more.
        let prior = chain.prior(Against::Keyframe).unwrap();
        assert!((prior.alpha.to_degrees() + 30.0).abs() < 0.01);
        // From the last placed scan (not the keyframe): 10°.
        let prior = chain.prior(Against::LastPlaced).unwrap();
        assert!((prior.alpha.to_degrees() + 10.0).abs() < 0.01);
        assert_eq!(
            chain.attempts().collect::<heapless::Vec<_, 3>>().as_slice(),
            &[Against::Keyframe, Against::LastPlaced]
        );
    }

    #[test]
    fn a_flagged_scan_is_bridged_by_the_next_and_never_guessed() {
        let mut chain = after_one_step(consecutive(2), 10.0);
        // Flagged: not placed, whatever its answer.
        let (e, m) = step(-170.0, Status::LowOverlap, 0.2);
        assert!(chain.wants_prior(Against::Keyframe, &e));
        assert_eq!(chain.place(Against::Keyframe, &e, &m, true), None);
        let s = chain.leave_unplaced(None, Some((Against::Keyframe, &e, &m)));
        assert_eq!(s.source, StepSource::Unplaced);
        assert!(!s.new_keyframe && !s.source.is_placed());
        // Its hypothesis is the prediction (the guess is beyond 3σ), and
        // its σ says so.
        assert!((heading(&s) - 15.0).abs() < 0.01, "{}", heading(&s));
        assert!(s.heading_sigma_deg > 29.0);
        // The next scan, against the same keyframe (two scans' motion),
        // bridges it: back to a confident step's σ.
        let (e, m) = step(12.0, Status::Confident, 0.8);
        let s = chain.place(Against::Keyframe, &e, &m, false).unwrap();
        assert_eq!(s.source, StepSource::Estimate);
        assert!((heading(&s) - 22.0).abs() < 0.01);
        assert!(s.heading_sigma_deg < 1.0, "{}", s.heading_sigma_deg);
    }

    #[test]
    fn a_bridge_must_agree_with_the_prediction() {
        let mut chain = after_one_step(consecutive(2), 0.0);
        let (f, fm) = step(0.0, Status::LowOverlap, 0.2);
        chain.leave_unplaced(None, Some((Against::Keyframe, &f, &fm)));
        // A confident answer over the gap 145° from the prediction (0°) is
        // not taken as a bridge…
        let (e, m) = step(145.0, Status::Confident, 0.6);
        assert_eq!(chain.place(Against::Keyframe, &e, &m, false), None);
        // …but a confident answer for the next scan alone is always taken.
        let mut fresh = after_one_step(consecutive(2), 0.0);
        let (e0, _) = step(0.0, Status::Confident, 0.9);
        assert!(
            fresh.wants_prior(Against::Keyframe, &e),
            "145° is beyond 3σ of 0°"
        );
        assert!(!fresh.wants_prior(Against::Keyframe, &e0));
        assert!(fresh.place(Against::Keyframe, &e, &m, false).is_some());
    }

    #[test]
    fn a_dense_stream_takes_no_answer_the_prior_made() {
        let dense = KeyframeSettings::default().consecutive().for_interval(0.1);
        let mut chain = after_one_step(KeyframeOdometry::new(dense), 4.0);
        // Made confident by the prior, 6° from the prediction (2°, gate
        // 15°): a sparse log would take it, a dense stream does not.
        let (p, pm) = step(8.0, Status::Confident, 0.5);
        let mut sparse = chain;
        *sparse.settings_mut() = KeyframeSettings::default().consecutive();
        assert_eq!(
            sparse
                .place(Against::Keyframe, &p, &pm, true)
                .unwrap()
                .source,
            StepSource::Prior
        );
        assert_eq!(chain.place(Against::Keyframe, &p, &pm, true), None);
        // Nor is it the unplaced scan's hypothesis: the prediction is.
        let s = chain.leave_unplaced(None, Some((Against::Keyframe, &p, &pm)));
        assert_eq!((s.source, s.against), (StepSource::Unplaced, None));
        assert!((heading(&s) - 6.0).abs() < 0.01, "{}", heading(&s));
        // Even a sparse log takes a prior-made answer only within 3σ of the
        // prediction: 100° from it is not.
        let (far, farm) = step(100.0, Status::Confident, 0.5);
        assert_eq!(sparse.place(Against::Keyframe, &far, &farm, true), None);
    }

    #[test]
    fn unplaced_scans_follow_their_own_confident_steps_then_are_carried() {
        let mut chain = after_one_step(consecutive(1), 4.0);
        let (f, fm) = step(30.0, Status::LowOverlap, 0.2);
        // First unplaced: the guess is within 3σ (30°) of the prediction (2°).
        let s = chain.leave_unplaced(None, Some((Against::Keyframe, &f, &fm)));
        assert_eq!(
            (s.source, s.against),
            (StepSource::Unplaced, Some(Against::Keyframe))
        );
        assert!((heading(&s) - 34.0).abs() < 0.01);
        let sigma = s.heading_sigma_deg;
        // Second: nothing places it, but it follows the first by a confident
        // step; past max_unplaced it is carried, and is the next keyframe.
        let (c, cm) = step(3.0, Status::Confident, 0.9);
        let s = chain.leave_unplaced(Some((&c, &cm)), None);
        assert_eq!(s.source, StepSource::Carried);
        assert!(s.new_keyframe);
        assert!((heading(&s) - 37.0).abs() < 0.01);
        assert!(s.heading_sigma_deg > sigma && s.heading_sigma_deg < sigma + 0.1);
        assert_eq!(chain.keyframe(), s.pose);
    }

    #[test]
    fn keyframes_move_on_overlap_turn_distance_and_bridges() {
        let mut chain = KeyframeOdometry::new(KeyframeSettings::default());
        chain.start();
        let (e, m) = step(10.0, Status::Confident, 0.9);
        assert!(
            !chain
                .place(Against::Keyframe, &e, &m, false)
                .unwrap()
                .new_keyframe
        );
        let (e, m) = step(35.0, Status::Confident, 0.9);
        assert!(
            chain
                .place(Against::Keyframe, &e, &m, false)
                .unwrap()
                .new_keyframe,
            "35° > 30°"
        );
        let (e, m) = step(0.0, Status::Confident, 0.5);
        assert!(
            chain
                .place(Against::Keyframe, &e, &m, false)
                .unwrap()
                .new_keyframe,
            "0.5 < 0.6"
        );
        let (e, _) = step(0.0, Status::Confident, 0.9);
        let far = Motion {
            dtheta: 0.0,
            translation: Some((1.5, 0.0)),
        };
        assert!(
            chain
                .place(Against::Keyframe, &e, &far, false)
                .unwrap()
                .new_keyframe,
            "1.5 m > 1 m"
        );
        assert_eq!(
            chain.attempts().collect::<heapless::Vec<_, 3>>().as_slice(),
            &[Against::Keyframe, Against::PreviousKeyframe]
        );
    }

    #[test]
    fn sigma_grows_with_the_steps_and_bad_input_places_nothing() {
        let mut chain = consecutive(0);
        // An offer before start starts the chain.
        let (e, m) = step(1.0, Status::Confident, 0.9);
        assert_eq!(
            chain
                .place(Against::Keyframe, &e, &m, false)
                .unwrap()
                .source,
            StepSource::Start
        );
        let mut last = 0.0;
        for _ in 0..100 {
            let s = chain.place(Against::Keyframe, &e, &m, false).unwrap();
            assert!(s.heading_sigma_deg > last);
            last = s.heading_sigma_deg;
        }
        // 100 steps of 0.25°: 2.5°.
        assert!((last - 2.5).abs() < 1e-3, "{last}");
        let bad = Motion {
            dtheta: f32::NAN,
            translation: Some((f32::INFINITY, 0.0)),
        };
        assert_eq!(chain.place(Against::Keyframe, &e, &bad, false), None);
        let s = chain.leave_unplaced(Some((&e, &bad)), Some((Against::Keyframe, &e, &bad)));
        assert_eq!(s.source, StepSource::Carried);
        assert!(s.pose.x.is_finite() && s.pose.y.is_finite());
    }
}
