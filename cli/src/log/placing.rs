//! Placing a scan in the chain: the estimates `log` makes of a scan
//! against the stored scans the chain names, in the order the chain wants
//! them (answers that need no prior first, then those made with it), until
//! one places the scan; what the chain makes of a scan none places.

use hough_heading::odometry::Against;
use hough_heading::Prior;
use hough_heading_recordings::model::Pose;
use hough_heading_recordings::pairs::{self as scans, PairRecord};
use hough_heading_recordings::trajectory::Kept;

use super::chain::{Chain, ChainLine, Offer};
use super::pairing::{PairJob, PairResult, Run};

/// The chain's best flagged estimate of a scan against its keyframe: the
/// stored scan, the estimates, the prior they were made with and the
/// odometry from the stored scan.
type Guess = (
    Against,
    Vec<scans::PairEstimate>,
    Option<Prior>,
    Option<Pose>,
);

/// The odometry's motion from scan `a` to scan `b`, when both have a pose.
pub(super) fn odom_between(a: &Kept, b: &Kept) -> Option<Pose> {
    a.1.odom.zip(b.1.odom).map(|(p, q)| p.between(&q))
}

/// Offers `result` (the scan's estimate against `against`, made with
/// `prior` if given; `odom` the odometry from the stored scan) to the
/// chain: the line and pose when it places the scan. An estimate against
/// the keyframe that does not is kept as the guess (one made with the
/// prior before one made without).
fn offer(
    chain: &mut Chain,
    scan: &Kept,
    (against, odom): (Against, Option<Pose>),
    result: &PairResult,
    prior: Option<Prior>,
    guess: &mut Option<Guess>,
) -> Option<(ChainLine, Pose)> {
    let estimates = result.as_ref().ok()?;
    let offer = Offer {
        against,
        estimate: &estimates[0],
        prior,
    };
    let added = chain.offer(scan, &offer, odom);
    if added.is_none() && against == Against::Keyframe && (guess.is_none() || prior.is_some()) {
        *guess = Some((against, estimates.clone(), prior, odom));
    }
    added
}

impl Run<'_> {
    /// Estimates one pair now, on the first worker.
    pub(super) fn estimate_one(&mut self, a: &Kept, b: &Kept, prior: Option<Prior>) -> PairResult {
        let pair = PairRecord {
            scan1: a.1.record.clone(),
            scan2: b.1.record.clone(),
        };
        let (options, mode) = (self.options, self.mode);
        self.workers
            .map(std::slice::from_ref(&pair), |engine, _, pair| {
                scans::estimate_with_prior(engine.as_mut(), pair, &options, &[mode], prior)
            })
            .pop()
            .unwrap_or_else(|| Err("no worker".into()))
    }

    /// Places the pair's second scan in the chain, if the run has one: it
    /// is estimated against each stored scan the chain names (the pair's
    /// own estimate where that is its first scan), first with the motion
    /// prior when the chain wants it, until one places it. The pair's
    /// result (the one the chain took, or the one made with the prior) and
    /// what the chain made of the scan.
    pub(super) fn chain(
        &mut self,
        job: &PairJob,
        result: PairResult,
    ) -> (PairResult, Option<(ChainLine, Pose)>) {
        let Some(mut chain) = self.chain.take() else {
            return (result, None);
        };
        let mut line = result;
        let mut guess: Option<Guess> = None;
        let mut placed = None;
        // First every stored scan's own answer that needs no prior (the
        // pair's own estimate where that is its first scan); then, in the
        // same order, the answers made again with the prior. A confident
        // answer against the last placed scan is worth more than the
        // keyframe's answer forced by the prior (on a dense stream such
        // forced answers were the keyframes' drift).
        let mut wanting = Vec::new();
        for (against, stored) in chain.attempts(&job.b) {
            let odom = odom_between(&stored, &job.b);
            let own = stored.0 == job.a.0;
            let first = if own {
                line.clone()
            } else {
                self.estimate_one(&stored, &job.b, None)
            };
            let prior = first
                .as_ref()
                .ok()
                .and_then(|e| chain.prior_for(against, &e[0]));
            let Some(prior) = prior else {
                placed = offer(
                    &mut chain,
                    &job.b,
                    (against, odom),
                    &first,
                    None,
                    &mut guess,
                );
                if placed.is_some() {
                    if own {
                        line = first;
                    }
                    break;
                }
                continue;
            };
            wanting.push((against, stored, own, first, prior, odom));
        }
        'wanting: for (against, stored, own, first, prior, odom) in wanting {
            // The answer made with the prior first: the original still
            // places the scan if it is confident, unless the prior's own
            // answer contradicts it. Once the scan is placed, the pair's
            // line still shows its answer made with the prior, as when the
            // chain takes it.
            if placed.is_some() && !own {
                continue;
            }
            let again = self.estimate_one(&stored, &job.b, Some(prior));
            if own {
                line = again.clone();
            }
            if placed.is_some() {
                continue;
            }
            let contradicted = again
                .as_ref()
                .is_ok_and(|e| chain.contradicts(against, &e[0]));
            let mut tries = vec![(again, Some(prior))];
            if !contradicted {
                tries.push((first, None));
            }
            for (result, prior) in tries {
                placed = offer(
                    &mut chain,
                    &job.b,
                    (against, odom),
                    &result,
                    prior,
                    &mut guess,
                );
                if placed.is_some() {
                    // The line shows the answer the chain took.
                    if own {
                        line = result;
                    }
                    break 'wanting;
                }
            }
        }
        let added = placed.unwrap_or_else(|| {
            let offer = guess.as_ref().map(|(against, e, prior, odom)| {
                (
                    Offer {
                        against: *against,
                        estimate: &e[0],
                        prior: *prior,
                    },
                    *odom,
                )
            });
            // The scan's estimate against the one just before, when the
            // chain left that one unplaced: the pair's own (consecutive
            // pairs), else made here (keyframe pairs).
            let just_before = chain.unplaced_scan().filter(|s| s.0 != job.a.0).cloned();
            let previous = match &just_before {
                Some(before) => {
                    let odom = odom_between(before, &job.b);
                    self.estimate_one(before, &job.b, None)
                        .ok()
                        .map(|e| (e, odom))
                }
                None => line
                    .as_ref()
                    .ok()
                    .filter(|_| job.b.0 == job.a.0 + self.args.every)
                    .map(|e| (e.clone(), job.odom)),
            };
            let previous = previous.as_ref().map(|(e, odom)| (&e[0], *odom));
            chain.unplaced(&job.b, previous, offer.as_ref().map(|(o, odom)| (o, *odom)))
        });
        self.chain = Some(chain);
        (line, Some(added))
    }
}
