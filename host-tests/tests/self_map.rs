//! The self-map rule (issue 48 item 4) on hand-built scenes: a runner-up
//! near the half turn that lays the reference onto itself about as well as
//! the answer lays the view onto the reference (`Estimate::self_map` ≥
//! `Thresholds::self_map_ratio`) makes the answer ambiguous.
//!
//! Scenes: a rectangular room with a door in the top wall and one at the
//! mirrored place in the bottom wall, and a corridor (both invariant under a
//! half turn), rendered with *independent* moderate damage in the two views
//! (each view from its own damage seed), so α and α + π are truly
//! indistinguishable; and an L-shaped room (no symmetry), which must stay
//! confident and right. 128², `N_θ` = 360, default options.

use host_tests::eval::{angle_error_deg, axis_error_deg, grid_from_image};
use host_tests::scene::{render_pair, Damage, Pair, Point, Scene, Segment, Transform};
use hough_heading::{estimator, grid, Estimate, Mode, Score, Status, Thresholds};

type G = grid!(128, 128);
type E = estimator!(128, 128, 360);

/// A 1.4 × 0.8 room (unit-disc coordinates) with doors at `x = 0.3` in the
/// top wall and `x = −0.3` in the bottom one: invariant under `p ↦ −p`.
fn symmetric_room() -> Scene {
    let (a, b, d) = (0.7, 0.4, 0.12);
    let p = Point::new;
    let top = [
        Segment::new(p(-a, b), p(0.3 - d, b)),
        Segment::new(p(0.3 + d, b), p(a, b)),
    ];
    let mut segments: Vec<Segment> = top.to_vec();
    segments.extend(
        top.iter()
            .map(|s| Segment::new(p(-s.a.x, -s.a.y), p(-s.b.x, -s.b.y))),
    );
    segments.push(Segment::new(p(a, b), p(a, -b)));
    segments.push(Segment::new(p(-a, -b), p(-a, b)));
    Scene { segments }
}

/// Two walls at `y = ±0.25` from `x = −0.85` to `0.85`, a door in each at
/// mirrored places: invariant under `p ↦ −p`.
fn corridor() -> Scene {
    let p = Point::new;
    let wall = [
        Segment::new(p(-0.85, 0.25), p(-0.1, 0.25)),
        Segment::new(p(0.1, 0.25), p(0.85, 0.25)),
    ];
    let mut segments: Vec<Segment> = wall.to_vec();
    segments.extend(
        wall.iter()
            .map(|s| Segment::new(p(-s.a.x, -s.a.y), p(-s.b.x, -s.b.y))),
    );
    Scene { segments }
}

/// An L-shaped room: no rotation but the identity maps it onto itself.
fn l_room() -> Scene {
    let p = Point::new;
    Scene::polygon(&[
        p(-0.7, -0.6),
        p(0.7, -0.6),
        p(0.7, 0.0),
        p(0.0, 0.0),
        p(0.0, 0.6),
        p(-0.7, 0.6),
    ])
}

/// The two views of `scene` under `transform`, each with its own damage
/// seed (the generator otherwise removes the same stretches in both).
fn independent_views(scene: &Scene, transform: &Transform, seed: u64) -> Pair {
    let first = render_pair(scene, transform, &Damage::MODERATE, 128, 128, seed);
    let second = render_pair(scene, transform, &Damage::MODERATE, 128, 128, seed + 1000);
    Pair {
        i1: first.i1,
        i2: second.i2,
        fit_radius_px: first.fit_radius_px,
    }
}

fn transform(alpha_deg: f64) -> Transform {
    Transform {
        alpha_rad: alpha_deg.to_radians(),
        tx: 3.0,
        ty: -2.0,
        scale: 1.0,
    }
}

fn estimate(pair: &Pair, thresholds: Thresholds) -> Estimate {
    let g1: G = grid_from_image(&pair.i1.image);
    let g2: G = grid_from_image(&pair.i2.image);
    E::new(Mode::Improved)
        .with_thresholds(thresholds)
        .estimate_pair(&g1, &g2)
}

const ANGLES: [f64; 6] = [0.0, 35.0, 90.0, 160.0, 233.0, 301.0];

/// Symmetric scenes with independent damage: never confident; ambiguous
/// about the direction, with the axis right.
#[test]
fn symmetric_scenes_are_ambiguous_about_the_direction() {
    for (name, scene) in [("room", symmetric_room()), ("corridor", corridor())] {
        for (i, &deg) in ANGLES.iter().enumerate() {
            let truth = transform(deg);
            let e = estimate(
                &independent_views(&scene, &truth, i as u64),
                Thresholds::DEFAULT,
            );
            assert_eq!(e.status, Status::AmbiguousDirection, "{name} {deg}°: {e:?}");
            assert!(e.confidence < Score::from_num(0.5), "{name} {deg}°: {e:?}");
            let axis = axis_error_deg(e.alpha, truth.alpha_rad);
            assert!(axis <= 2.0, "{name} {deg}°: axis {axis:.2}° off");
        }
    }
}

/// The L-shaped room stays confident and right; where its self-map was
/// measured it is far below the threshold.
#[test]
fn an_asymmetric_room_stays_confident() {
    let ratio = Thresholds::DEFAULT.self_map_ratio;
    for (i, &deg) in ANGLES.iter().enumerate() {
        let truth = transform(deg);
        let e = estimate(
            &independent_views(&l_room(), &truth, i as u64),
            Thresholds::DEFAULT,
        );
        assert_eq!(e.status, Status::Confident, "{deg}°: {e:?}");
        let error = angle_error_deg(e.alpha, truth.alpha_rad);
        assert!(error <= 1.0, "{deg}°: {error:.2}° off");
        if let Some(s) = e.self_map {
            assert!(s < ratio * Score::from_num(0.8), "{deg}°: self-map {s}");
        }
    }
}

/// The rule is what decides once measured: the same asymmetric pairs with
/// `self_map_ratio` 0 are ambiguous about the direction wherever the
/// self-map was measured (never confident, confidence below ½), and
/// confident again with the rule out of reach (above 64).
#[test]
fn the_ratio_decides_where_the_self_map_is_measured() {
    let mut measured = 0;
    for (i, &deg) in ANGLES.iter().enumerate() {
        let pair = independent_views(&l_room(), &transform(deg), i as u64);
        let never = estimate(
            &pair,
            Thresholds {
                self_map_ratio: Score::from_num(65),
                ..Thresholds::DEFAULT
            },
        );
        let always = estimate(
            &pair,
            Thresholds {
                self_map_ratio: Score::ZERO,
                ..Thresholds::DEFAULT
            },
        );
        assert_eq!(never.status, Status::Confident, "{deg}°: {never:?}");
        assert_eq!(never.alpha, always.alpha, "{deg}°: the answer stays");
        if always.self_map.is_some() {
            measured += 1;
            assert_eq!(always.status, Status::AmbiguousDirection, "{deg}°");
            assert!(always.confidence < Score::from_num(0.5), "{deg}°");
        } else {
            assert_eq!(always.status, Status::Confident, "{deg}°");
        }
    }
    assert!(measured > 0, "no runner-up near the half turn was measured");
}
