//! [`KeyframeSettings`]: how far the chain trusts its motion prior, how
//! long it waits for a bridge, when it takes a new keyframe; and how the
//! time between scans sets them ([`KeyframeSettings::for_interval`]).

use crate::angle::Angle;
#[cfg(doc)]
use crate::estimate::Estimate;
use crate::Score;

/// The prediction repeats the last step's translation and this fraction
/// (1/2) of its turn: a robot's turn rate falls back towards zero. On the
/// shared logs' consecutive scans the halved turn is off by at most 68°,
/// 55°, 62° and 18° (aces, orebro, seattle, freiburg-campus), the whole
/// turn by 96°, 69°, 60° and 23°, no turn by 78°, 76°, 81° and 16°; a
/// prediction more than 90° off puts the half turn nearer. Chosen on those
/// logs (`docs/stream.md`).
pub const TURN_KEPT_DIVISOR: i32 = 2;

/// The fastest turn the prior expects of a robot, degrees a second
/// ([`prior_sigma_for_interval`]).
pub const MAX_TURN_RATE_DEG_S: f32 = 50.0;

/// The motion prior's σ for a scan `seconds` after the last placed one: the
/// turn [`MAX_TURN_RATE_DEG_S`] allows in that time, within 5°–30° (not
/// finite or not positive: unknown, 30°; some logs carry no times). At
/// 10 Hz 5° (the gate at 15°: a dense stream's flagged candidates tens of
/// degrees off are not taken); a log kept every metre or 30° of turn,
/// seconds apart, 30°.
pub fn prior_sigma_for_interval(seconds: f32) -> Angle {
    let degrees = if seconds.is_finite() && seconds > 0.0 {
        (seconds * MAX_TURN_RATE_DEG_S).clamp(5.0, 30.0)
    } else {
        30.0
    };
    Angle::from_degrees(degrees)
}

/// Scans at most this far apart, seconds, are a dense stream
/// ([`KeyframeSettings::for_interval`]).
pub const DENSE_INTERVAL_S: f32 = 0.25;

/// What the chain's settings are. [`Default`]: see each field.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct KeyframeSettings {
    /// One standard deviation of the constant-velocity prediction of the
    /// rotation; the prior's candidates beyond 3σ are not taken, and an
    /// unplaced or carried scan's heading variance grows by its square.
    /// Default 30° (the gate at 90°: a half turn is never within it of a
    /// prediction less than 90° off). On the shared logs' consecutive
    /// scans (every ~1 m or ~30° of turn) the prediction is off by 63° at
    /// the 99th percentile.
    pub prior_sigma: Angle,
    /// A placed scan becomes the next keyframe when its overlap with the
    /// keyframe ([`Estimate::overlap`]) is below this. Default 0.6;
    /// `Score::MAX`: every placed scan (consecutive pairs).
    pub min_overlap: Score,
    /// … or when the robot turned more than this since the keyframe.
    /// Default 30°.
    pub max_turn: Angle,
    /// … or moved more than this since the keyframe, metres. Default 1.0.
    pub max_distance_m: f32,
    /// Scans left unplaced in a row before the chain carries one (0: a scan
    /// that nothing places is carried at once). Default 2.
    pub max_unplaced: u8,
    /// Heading σ of a confident step, degrees. Default 0.25°, chosen on the
    /// shared logs so that the truth lies within 2σ of the chained heading
    /// (`docs/drift.md`).
    pub step_sigma_deg: f32,
    /// Heading σ of a step the prior made confident, degrees. Default 2°.
    pub prior_step_sigma_deg: f32,
    /// An answer the prior made confident may place a scan, and a flagged
    /// candidate near the prediction may stand for an unplaced or carried
    /// one. Default true; a dense stream
    /// ([`for_interval`](Self::for_interval)) takes the prediction and waits
    /// for the next scans to bridge instead: on the shared dense streams
    /// the few such answers were 5–17° off, the prediction a few degrees.
    pub takes_prior_answers: bool,
}

impl Default for KeyframeSettings {
    fn default() -> Self {
        Self {
            prior_sigma: Angle::from_degrees(30.0),
            min_overlap: Score::from_bits(39_322), // 0.6
            max_turn: Angle::from_degrees(30.0),
            max_distance_m: 1.0,
            max_unplaced: 2,
            step_sigma_deg: 0.25,
            prior_step_sigma_deg: 2.0,
            takes_prior_answers: true,
        }
    }
}

impl KeyframeSettings {
    /// The settings for a stream of scans `seconds` apart: a dense stream
    /// (at most [`DENSE_INTERVAL_S`] apart) waits up to 5 scans (half a
    /// second at 10 Hz) for a bridge, a sparse one carries an unplaced scan
    /// at once (a bridge over two scans kept a metre or 30° of turn apart
    /// was more often wrong than the prior's candidate on the shared logs);
    /// only a sparse one takes the answers the prior made
    /// ([`takes_prior_answers`](Self::takes_prior_answers)); the prior's σ is
    /// [`prior_sigma_for_interval`]. Chosen on the shared logs and dense
    /// streams (`docs/drift.md`).
    pub fn for_interval(self, seconds: f32) -> Self {
        let dense = seconds.is_finite() && seconds > 0.0 && seconds <= DENSE_INTERVAL_S;
        Self {
            prior_sigma: prior_sigma_for_interval(seconds),
            max_unplaced: if dense { 5 } else { 0 },
            takes_prior_answers: !dense,
            ..self
        }
    }

    /// Every placed scan a keyframe: consecutive pairs, each scan against
    /// the last placed one, then the one before it.
    pub fn consecutive(self) -> Self {
        Self {
            min_overlap: Score::MAX,
            ..self
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_interval_sets_the_prior_and_the_wait() {
        let dense = KeyframeSettings::default().for_interval(0.1);
        assert_eq!(dense.max_unplaced, 5);
        assert!(!dense.takes_prior_answers);
        assert!((dense.prior_sigma.to_degrees() - 5.0).abs() < 1e-3);
        let sparse = KeyframeSettings::default().for_interval(2.0);
        assert_eq!(sparse.max_unplaced, 0);
        assert!(sparse.takes_prior_answers);
        assert!((sparse.prior_sigma.to_degrees() - 30.0).abs() < 1e-3);
        for unknown in [0.0, -1.0, f32::NAN] {
            assert_eq!(KeyframeSettings::default().for_interval(unknown), sparse);
        }
        assert!((prior_sigma_for_interval(0.4).to_degrees() - 20.0).abs() < 1e-3);
    }
}
