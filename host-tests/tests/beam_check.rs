//! The check on the beams (`Raster::agreement_on_beams`,
//! `Raster::check_on_beams`, issue 23) against ray-cast scans whose
//! relative pose is known exactly (`host_tests::raycast`) and against an
//! `f64` reimplementation of its two shares written from the module doc:
//! the integer shares agree with it, the true pose explains nearly every
//! end point and sees through none, a wrong rotation scores far lower, and
//! an estimate whose listed rival is the truth is flagged.

mod room_turns;

use host_tests::raycast::{l_room as room, relative, Laser, Wall};
use hough_heading::stages::{
    BeamAgreement, BeamPose, BEAM_MATCH_M, BEAM_MIN_SCORE, BEAM_SEEN_THROUGH_CONFIDENCE,
    BEAM_SEEN_THROUGH_M, BEAM_SEEN_THROUGH_WEIGHT, BEAM_SEGMENT_MAX_M,
};
use hough_heading::{Angle, BeamCheck, Candidate, Estimate, Raster, Scan, Score, Status};

/// A 180° laser of 361 beams, 30 m (the shared files' geometry).
fn laser() -> Laser {
    Laser::centred(180.0, 361, 30.0)
}

/// 9 m radius on 128 cells (0.14 m cells), segments up to 0.3 m.
fn raster() -> Raster {
    Raster::with_radius(9.0, 128).unwrap().connect(0.3)
}

/// The estimator's `(α, t)` (t in cells) for a robot motion `(d, dθ)`.
fn estimator_pose(d: (f64, f64), dtheta: f64, cell: f64) -> (Angle, (Score, Score)) {
    let alpha = -dtheta;
    let (s, c) = alpha.sin_cos();
    let t = (-(c * d.0 - s * d.1) / cell, -(s * d.0 + c * d.1) / cell);
    (
        Angle::from_degrees(alpha.to_degrees() as f32),
        (Score::from_num(t.0), Score::from_num(t.1)),
    )
}

/// End points (metres, robot frame) of a ray-cast scan, `None` for beams
/// without a return.
fn ends(laser: &Laser, ranges: &[f32]) -> Vec<Option<(f64, f64)>> {
    ranges
        .iter()
        .enumerate()
        .map(|(i, &r)| {
            let r = f64::from(r);
            (r > 0.0 && r < laser.max_range).then(|| {
                let a = laser.angle_min + i as f64 * laser.angle_increment;
                (r * a.cos(), r * a.sin())
            })
        })
        .collect()
}

/// The `f64` shares of one direction: `from`'s end points moved by the
/// motion `(d, dθ)` into `into`'s frame (explained, seen through, in view:
/// the bearing within one beam of the field of view).
fn one_way(
    laser: &Laser,
    into: &[f32],
    from: &[f32],
    d: (f64, f64),
    dtheta: f64,
) -> (f64, f64, f64) {
    let walls = ends(laser, into);
    let (s, c) = dtheta.sin_cos();
    let (tau, margin) = (f64::from(BEAM_MATCH_M), f64::from(BEAM_SEEN_THROUGH_M));
    let max_len = f64::from(BEAM_SEGMENT_MAX_M);
    let end = |k: i64| {
        usize::try_from(k)
            .ok()
            .and_then(|k| walls.get(k).copied().flatten())
    };
    let (mut explained, mut seen, mut in_view, mut count) = (0.0, 0.0, 0.0, 0.0);
    for q in ends(laser, from).into_iter().flatten() {
        count += 1.0;
        let p = (c * q.0 - s * q.1 + d.0, s * q.0 + c * q.1 + d.1);
        let bearing = p.1.atan2(p.0);
        let beam = ((bearing - laser.angle_min) / laser.angle_increment).floor() as i64;
        if !(-1..=walls.len() as i64).contains(&beam) {
            continue;
        }
        in_view += 1.0;
        // The segment around the bearing whose midpoint is nearest.
        let mut best: Option<(f64, f64)> = None;
        for k in beam - 1..=beam + 1 {
            let (Some(a), Some(b)) = (end(k), end(k + 1)) else {
                continue;
            };
            let e = (b.0 - a.0, b.1 - a.1);
            let len = e.0.hypot(e.1);
            if len == 0.0 || len > max_len {
                continue;
            }
            let mid = (p.0 - (a.0 + b.0) / 2.0).hypot(p.1 - (a.1 + b.1) / 2.0);
            let r = (e.0 * (p.1 - a.1) - e.1 * (p.0 - a.0)) / len;
            if best.is_none_or(|(m, _)| mid < m) {
                best = Some((mid, r));
            }
        }
        if let Some((_, r)) = best {
            explained += (1.0 - (r / tau).powi(2)).max(0.0);
        }
        let around: Option<Vec<f64>> = (beam - 1..=beam + 2)
            .map(|k| end(k).map(|e| e.0.hypot(e.1)))
            .collect();
        if let Some(nearest) = around.and_then(|r| r.into_iter().reduce(f64::min)) {
            seen += f64::from(u8::from(p.0.hypot(p.1) < nearest - nearest / 32.0 - margin));
        }
    }
    (explained / count, seen / count, in_view / count)
}

/// Both directions, averaged: `(explained, seen through, in view)`.
fn reference_shares(
    laser: &Laser,
    a: &[f32],
    b: &[f32],
    d: (f64, f64),
    dtheta: f64,
) -> (f64, f64, f64) {
    let forward = one_way(laser, a, b, d, dtheta);
    // The inverse motion: a point of `a` in `b`'s frame.
    let (s, c) = (-dtheta).sin_cos();
    let back = (-(c * d.0 - s * d.1), -(s * d.0 + c * d.1));
    let backward = one_way(laser, b, a, back, -dtheta);
    (
        (forward.0 + backward.0) / 2.0,
        (forward.1 + backward.1) / 2.0,
        (forward.2 + backward.2) / 2.0,
    )
}

const FROM: (f64, f64, f64) = (3.0, 2.5, 0.4);
/// Turns of 12°, 42° and −11° with views that overlap well, moves that are
/// no whole number of cells.
const TO: [(f64, f64, f64); 3] = [(3.37, 2.21, 0.613), (3.62, 2.93, 1.13), (2.8, 2.2, 0.21)];
/// A 93° turn: the 180° views share a third of their walls.
const FAR_TURN: (f64, f64, f64) = (2.51, 5.47, 2.02);

#[test]
fn the_shares_agree_with_an_f64_reference_and_single_out_the_true_pose() {
    let (laser, raster) = (laser(), raster());
    let cell = f64::from(raster.cell());
    let first = laser.scan(&room(), FROM);
    for to in TO.into_iter().chain([FAR_TURN]) {
        let second = laser.scan(&room(), to);
        let (d, dtheta) = relative(FROM, to);
        let mut scores = Vec::new();
        // The truth, and the same translation a quarter turn off.
        for turn in [0.0, std::f64::consts::FRAC_PI_2] {
            let (alpha, t) = estimator_pose(d, dtheta + turn, cell);
            let got = raster
                .agreement_on_beams(&laser.as_scan(&first), &laser.as_scan(&second), alpha, t)
                .unwrap();
            let want = reference_shares(&laser, &first, &second, d, dtheta + turn);
            let (e, s, v) = (
                got.explained.to_num::<f64>(),
                got.seen_through.to_num::<f64>(),
                got.in_view.to_num::<f64>(),
            );
            assert!(
                (e - want.0).abs() < 0.02 && (s - want.1).abs() < 0.01 && (v - want.2).abs() < 0.01,
                "{to:?} {turn}: library ({e}, {s}, {v}), f64 {want:?}"
            );
            let score = e - f64::from(BEAM_SEEN_THROUGH_WEIGHT) * s;
            assert!((got.score().to_num::<f64>() - score).abs() < 1e-3);
            scores.push((score, s));
        }
        // The truth sees through nothing and leads the quarter turn, which
        // puts walls where the other sensor saw free space.
        let [(truth, seen), (quarter, quarter_seen)] = scores[..] else {
            unreachable!()
        };
        assert!(seen < 0.01 && quarter_seen > 0.04, "{to:?}: {scores:?}");
        assert!(truth > quarter + 0.3, "{to:?}: {scores:?}");
    }
}

#[test]
fn an_estimate_whose_rival_is_the_truth_is_flagged() {
    let (laser, raster) = (laser(), raster());
    room_turns::each_turn(&laser, &raster, FROM, &TO, |to, first, second, estimate| {
        let (s1, s2) = (laser.as_scan(first), laser.as_scan(second));
        assert_eq!(estimate.status, Status::Confident, "{to:?}");
        // The right answer: the beams agree; nothing changes but the
        // confidence, capped by the few end points seen through (≥ 0.9).
        let check = raster.check_on_beams(&s1, &s2, &estimate).unwrap();
        assert!(!check.contradicts(), "{to:?}: {check:?}");
        assert!(!check.switches());
        assert!(
            check.confidence_cap() > Score::from_num(0.9),
            "{to:?}: {check:?}"
        );
        let mut kept = estimate.clone();
        check.apply(&mut kept);
        let capped = Estimate {
            confidence: estimate.confidence.min(check.confidence_cap()),
            ..estimate.clone()
        };
        assert_eq!(kept, capped);
        // The same estimate with a wrong rotation chosen (its translation the
        // truth's, turned with it) and the truth listed as the runner-up.
        let truth = estimate.candidates[0];
        let wrong_alpha = truth.alpha + Angle::QUARTER_TURN;
        let wrong = Candidate {
            alpha: wrong_alpha,
            ..truth
        };
        let mut confused = estimate.clone();
        confused.alpha = wrong_alpha;
        confused.candidates.clear();
        confused.candidates.push(wrong).unwrap();
        confused.candidates.push(truth).unwrap();
        confused.runner_up = Some(truth);
        let check = raster.check_on_beams(&s1, &s2, &confused).unwrap();
        assert!(check.contradicts(), "{to:?}: {check:?}");
        assert_eq!(check.rival.map(|r| r.listed), Some(truth.alpha));
        let mut flagged = confused.clone();
        check.flag(&mut flagged);
        assert_eq!(flagged.status, Status::AmbiguousAxis, "{to:?}");
        assert!(flagged.confidence < Score::from_num(0.5));
        assert_eq!(flagged.alpha, wrong_alpha, "flag() does not pick");
        // The truth leads by far: apply() makes it the answer, still
        // flagged, at the truth's pose.
        assert!(check.switches(), "{to:?}: {check:?}");
        check.apply(&mut confused);
        assert_eq!(confused.status, Status::AmbiguousAxis);
        let (d, dtheta) = relative(FROM, to);
        let (alpha, t) = estimator_pose(d, dtheta, f64::from(raster.cell()));
        assert!(
            confused.alpha.distance(alpha) < Angle::from_degrees(0.1),
            "{to:?}"
        );
        let got = confused.translation.unwrap();
        let off = (got.x - t.0)
            .to_num::<f64>()
            .hypot((got.y - t.1).to_num::<f64>());
        assert!(off < 0.2, "{to:?}: {off} cells off");
    });
}

/// A rival is a correlation peak or a half turn, listed a few degrees off
/// its own best fit: its refinement may move it by up to
/// `BEAM_RIVAL_MAX_ROTATION_DEG` (the chosen rotation's by 1°). Listed 4°
/// off the truth behind a wrong quarter turn, it is refined onto the truth
/// and becomes the answer; refined to within 5° of the chosen rotation, it
/// is no rival and keeps its unrefined score.
#[test]
fn a_rival_listed_degrees_off_is_refined_onto_its_own_fit() {
    let (laser, raster) = (laser(), raster());
    room_turns::each_turn(&laser, &raster, FROM, &TO, |to, first, second, estimate| {
        let (s1, s2) = (laser.as_scan(first), laser.as_scan(second));
        let (d, dtheta) = relative(FROM, to);
        let (alpha, _) = estimator_pose(d, dtheta, f64::from(raster.cell()));
        let truth = estimate.candidates[0];
        let listed_as = |chosen: Angle, rival: Angle| {
            let mut e = estimate.clone();
            e.alpha = chosen;
            e.candidates.clear();
            e.candidates
                .push(Candidate {
                    alpha: chosen,
                    ..truth
                })
                .unwrap();
            e.candidates
                .push(Candidate {
                    alpha: rival,
                    ..truth
                })
                .unwrap();
            e.runner_up = Some(Candidate {
                alpha: rival,
                ..truth
            });
            e
        };
        // Behind a wrong quarter turn, 4° off the truth.
        let off = truth.alpha + Angle::from_degrees(4.0);
        let mut confused = listed_as(truth.alpha + Angle::QUARTER_TURN, off);
        let check = raster.check_on_beams(&s1, &s2, &confused).unwrap();
        let rival = check.rival.unwrap();
        assert_eq!(rival.listed, off);
        assert!(
            rival.alpha.distance(alpha) < Angle::from_degrees(0.1),
            "{to:?}: {rival:?}"
        );
        assert!(check.switches(), "{to:?}: {check:?}");
        check.apply(&mut confused);
        assert!(
            confused.alpha.distance(alpha) < Angle::from_degrees(0.1),
            "{to:?}"
        );
        // Chosen 3° off the truth, the rival 3° off on the other side: the
        // rival would refine onto the truth, within 5° of the chosen
        // rotation, so it is no rival (the chosen one is merely imprecise,
        // which the final refinement mends) and keeps its listed rotation.
        let (below, above) = (
            truth.alpha - Angle::from_degrees(3.0),
            truth.alpha + Angle::from_degrees(3.0),
        );
        let imprecise = listed_as(below, above);
        let check = raster.check_on_beams(&s1, &s2, &imprecise).unwrap();
        assert_eq!(
            check.rival.map(|r| r.alpha),
            Some(above),
            "{to:?}: {check:?}"
        );
    });
}

/// The chosen pose's seen-through share caps the confidence at
/// `1 − BEAM_SEEN_THROUGH_CONFIDENCE × share` (hand-computed here): a
/// confident answer stays confident under a cap of ½ or more, and becomes
/// `LowOverlap` with a confidence of at most ¼ under a smaller one.
#[test]
fn walls_where_the_other_sensor_saw_through_cap_the_confidence() {
    let (laser, raster) = (laser(), raster());
    room_turns::each_turn(
        &laser,
        &raster,
        FROM,
        &TO[..1],
        |to, first, second, estimate| {
            let (s1, s2) = (laser.as_scan(first), laser.as_scan(second));
            assert_eq!(estimate.status, Status::Confident, "{to:?}");
            let mut check = raster.check_on_beams(&s1, &s2, &estimate).unwrap();
            check.rival = None;
            check.chosen.agreement.explained = Score::from_num(0.9);
            let k = f64::from(BEAM_SEEN_THROUGH_CONFIDENCE);
            for share in [0.0, 0.05, 1.0 / k - 0.01, 1.0 / k + 0.01, 0.2] {
                check.chosen.agreement.seen_through = Score::from_num(share);
                let cap = (1.0 - k * share).max(0.0);
                assert!((check.confidence_cap().to_num::<f64>() - cap).abs() < 1e-3);
                let mut judged = estimate.clone();
                judged.confidence = Score::ONE;
                check.flag(&mut judged);
                if cap >= 0.5 {
                    assert_eq!(judged.status, Status::Confident, "share {share}");
                    assert!((judged.confidence.to_num::<f64>() - cap).abs() < 1e-3);
                } else {
                    assert_eq!(judged.status, Status::LowOverlap, "share {share}");
                    assert!(judged.confidence <= Score::from_num(0.25));
                }
            }
            // Shares no check produces (the fields are public): no
            // overflow, a cap within [0, 1].
            for share in [Score::MAX, Score::MIN, Score::from_num(-5)] {
                check.chosen.agreement.seen_through = share;
                check.chosen.agreement.explained = share;
                let cap = check.confidence_cap();
                assert!((Score::ZERO..=Score::ONE).contains(&cap), "{share}: {cap}");
                let _ = check.chosen.agreement.score();
                check.flag(&mut estimate.clone());
            }
            // The widest lead: a rival at the top of the range, the chosen
            // pose at the bottom.
            check.chosen.agreement = BeamAgreement {
                explained: Score::MIN,
                seen_through: Score::ZERO,
                in_view: Score::ONE,
            };
            check.rival = Some(BeamPose {
                agreement: BeamAgreement {
                    explained: Score::MAX,
                    seen_through: Score::ZERO,
                    in_view: Score::ONE,
                },
                ..check.chosen
            });
            assert_eq!(check.lead(), Some(Score::MAX));
            assert!(check.contradicts() && check.switches());
            check.apply(&mut estimate.clone());
            // In-view shares at the ends of the range: no overflow; none in
            // view is above nothing.
            for (a, b) in [
                (Score::MAX, Score::MIN),
                (Score::MIN, Score::MAX),
                (Score::MAX, Score::MAX),
            ] {
                let mut rival = check.rival.unwrap();
                rival.agreement.in_view = a;
                check.chosen.agreement.in_view = b;
                let above = rival.agreement.in_view_above(&check.chosen.agreement);
                assert_eq!(above, a > Score::ZERO, "{a} {b}");
                check.rival = Some(rival);
                assert_eq!(check.switches(), above);
            }
        },
    );
}

#[test]
fn unusable_inputs_give_no_judgement() {
    let (laser, raster) = (laser(), raster());
    let first = laser.scan(&room(), FROM);
    let good = laser.as_scan(&first);
    let t = (Score::ZERO, Score::ZERO);
    // No valid end point.
    let empty = vec![f32::NAN; first.len()];
    assert!(raster
        .agreement_on_beams(&good, &laser.as_scan(&empty), Angle::ZERO, t)
        .is_none());
    // A geometry that is not finite.
    let broken = Scan {
        angle_increment: f32::INFINITY,
        ..good
    };
    assert!(raster
        .agreement_on_beams(&broken, &good, Angle::ZERO, t)
        .is_none());
    // A translation beyond the beams' reach.
    assert!(raster
        .agreement_on_beams(&good, &good, Angle::ZERO, (Score::MAX, Score::ZERO))
        .is_none());
    // The same scan at rest explains itself and sees through nothing.
    let same = raster
        .agreement_on_beams(&good, &good, Angle::ZERO, t)
        .unwrap();
    assert!(same.explained > Score::from_num(0.95), "{same:?}");
    assert_eq!(same.seen_through, Score::ZERO);
}

/// A rotation 30° off in a room of right angles lays no wall onto a wall:
/// alone in the estimate (nothing outscores it), the beams do not confirm
/// it and `flag` makes it `LowOverlap` with a confidence of at most ¼; the
/// right answer clears `BEAM_MIN_SCORE` by far.
#[test]
fn an_estimate_the_beams_do_not_confirm_is_flagged() {
    let (laser, raster) = (laser(), raster());
    let floor = Score::from_num(BEAM_MIN_SCORE);
    room_turns::each_turn(&laser, &raster, FROM, &TO, |to, first, second, estimate| {
        let (s1, s2) = (laser.as_scan(first), laser.as_scan(second));
        let check = raster.check_on_beams(&s1, &s2, &estimate).unwrap();
        assert!(!check.too_weak(), "{to:?}: {check:?}");
        assert!(
            check.chosen.agreement.score() > floor * 2,
            "{to:?}: {check:?}"
        );
        let truth = estimate.candidates[0];
        let off = Candidate {
            alpha: truth.alpha + Angle::from_degrees(30.0),
            ..truth
        };
        let mut lonely = estimate.clone();
        lonely.alpha = off.alpha;
        lonely.candidates.clear();
        lonely.candidates.push(off).unwrap();
        lonely.runner_up = None;
        let check = raster.check_on_beams(&s1, &s2, &lonely).unwrap();
        assert!(check.rival.is_none() && !check.contradicts());
        assert!(check.too_weak(), "{to:?}: {check:?}");
        check.apply(&mut lonely);
        assert_eq!(lonely.status, Status::LowOverlap, "{to:?}");
        assert!(lonely.confidence <= Score::from_num(0.25));
        assert_eq!(lonely.alpha, off.alpha, "nothing to switch to");
    });
}

/// A corridor 1.4 m wide with a niche in each wall, seen from one end.
fn corridor() -> Vec<Wall> {
    vec![
        ((-20.0, 0.7), (2.0, 0.7)),
        ((2.0, 0.7), (2.0, 0.9)),
        ((2.0, 0.9), (3.0, 0.9)),
        ((3.0, 0.9), (3.0, 0.7)),
        ((3.0, 0.7), (20.0, 0.7)),
        ((-20.0, -0.7), (4.0, -0.7)),
        ((4.0, -0.7), (4.0, -0.9)),
        ((4.0, -0.9), (4.6, -0.9)),
        ((4.6, -0.9), (4.6, -0.7)),
        ((4.6, -0.7), (20.0, -0.7)),
    ]
}

/// A 180° sensor that looks down a corridor and moves 0.9 m along it: at
/// the truth the nearest walls of the first scan (most of its end points)
/// fall behind the second sensor, while the half turn slid 4.9 m along
/// the corridor lays both scans' near walls far into the other's view. The
/// plain score prefers that half turn; per end point in view the truth
/// leads, and the rival does not replace the answer (it is flagged).
#[test]
fn a_half_turn_that_only_brings_more_end_points_into_view_does_not_replace_the_answer() {
    let laser = laser();
    let raster = Raster::with_radius(5.0, 128).unwrap().connect(0.3);
    let cell = f64::from(raster.cell());
    let (from, to) = ((0.0, 0.0, 0.0), (0.9, 0.02, 0.025));
    let (d, dtheta) = relative(from, to);
    let agreement = |first: &[f32], second: &[f32], turn: f64, slide: f64| {
        let (alpha, t) = estimator_pose((d.0 + slide, d.1), dtheta + turn, cell);
        let got = raster
            .agreement_on_beams(&laser.as_scan(first), &laser.as_scan(second), alpha, t)
            .unwrap();
        (alpha, t, got)
    };
    room_turns::each_turn_in(
        &corridor(),
        &laser,
        &raster,
        from,
        &[to],
        |_, first, second, estimate| {
            let (alpha, t, truth) = agreement(first, second, 0.0, 0.0);
            let (half_alpha, half_t, half) = agreement(first, second, std::f64::consts::PI, 4.9);
            // The in-view shares against the f64 reference.
            for (got, turn, slide) in [(truth, 0.0, 0.0), (half, std::f64::consts::PI, 4.9)] {
                let want =
                    reference_shares(&laser, first, second, (d.0 + slide, d.1), dtheta + turn);
                let v = got.in_view.to_num::<f64>();
                assert!((v - want.2).abs() < 0.01, "library {v}, f64 {want:?}");
            }
            assert!(
                half.score() > truth.score() + Score::from_num(0.05),
                "{truth:?} {half:?}"
            );
            assert!(truth.in_view < Score::from_num(0.8) && half.in_view > Score::from_num(0.9));
            assert!(truth.in_view_above(&half) && !half.in_view_above(&truth));
            let pose = |listed: Angle, translation: (Score, Score), agreement| BeamPose {
                listed,
                alpha: listed,
                translation,
                agreement,
            };
            let check = BeamCheck {
                chosen: pose(alpha, t, truth),
                rival: Some(pose(half_alpha, half_t, half)),
            };
            assert!(check.contradicts() && !check.switches());
            let mut judged = Estimate {
                alpha,
                status: Status::Confident,
                ..estimate
            };
            check.apply(&mut judged);
            assert_eq!(judged.alpha, alpha);
            assert_eq!(judged.status, Status::AmbiguousDirection);
            // The same rival, leading per end point in view as well, replaces it.
            let leading = BeamAgreement {
                in_view: Score::from_num(0.75),
                ..half
            };
            let check = BeamCheck {
                rival: Some(pose(half_alpha, half_t, leading)),
                ..check
            };
            assert!(leading.in_view_above(&truth) && check.switches());
            check.apply(&mut judged);
            assert_eq!(judged.alpha, half_alpha);
        },
    );
    // A sensor that sees the whole circle has nearly every end point in
    // view (in view: a return of the other sensor on one of the two beams
    // around the bearing; the corridor's far ends, beyond 30 m, return
    // nothing): the condition is nearly the plain score's, and the half turn
    // no longer fits.
    let all_round = Laser::centred(359.0, 360, 30.0);
    let (first, second) = (
        all_round.scan(&corridor(), from),
        all_round.scan(&corridor(), to),
    );
    for (turn, slide) in [(0.0, 0.0), (std::f64::consts::PI, 4.9)] {
        let (alpha, t) = estimator_pose((d.0 + slide, d.1), dtheta + turn, cell);
        let got = raster
            .agreement_on_beams(
                &all_round.as_scan(&first),
                &all_round.as_scan(&second),
                alpha,
                t,
            )
            .unwrap();
        assert!(got.in_view > Score::from_num(0.95), "{turn}: {got:?}");
        assert_eq!(
            turn == 0.0,
            got.score() > Score::from_num(0.9),
            "{turn}: {got:?}"
        );
    }
}
