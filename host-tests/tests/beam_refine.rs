//! The refinement on the beams (`Raster::refine_on_beams`, issue 23 item
//! 7) against ray-cast scans whose relative pose is known exactly (`f64`,
//! `host_tests::raycast`, independent of the library): it brings the grid
//! estimate, or a start a fraction of a degree and a cell off, to the
//! truth well below a cell; it refuses a start it would have to move too
//! far, and inputs it cannot use, with a typed error.

mod room_turns;

use host_tests::raycast::{l_room as room, relative, Laser, Wall};
use hough_heading::{Angle, BeamFitError, Pose, Raster, Scan, Score, Status};

/// A 270° laser of 541 beams, 30 m.
fn laser() -> Laser {
    Laser::centred(270.0, 541, 30.0)
}

/// 9 m radius on 128 cells (0.14 m cells), segments up to 0.3 m.
fn raster() -> Raster {
    Raster::with_radius(9.0, 128).unwrap().connect(0.3)
}

/// The estimator's `(α, t)` for a robot motion `(d, dθ)`: α = −dθ,
/// t = −R(α)·d / cell.
fn estimator_pose(d: (f64, f64), dtheta: f64, cell: f64) -> (Angle, Pose) {
    let alpha = -dtheta;
    let (s, c) = alpha.sin_cos();
    let t = (-(c * d.0 - s * d.1) / cell, -(s * d.0 + c * d.1) / cell);
    (
        Angle::from_degrees(alpha.to_degrees() as f32),
        Pose {
            x: Score::from_num(t.0),
            y: Score::from_num(t.1),
            scale: Score::ONE,
            residual: Score::ZERO,
            columns: 3,
            unobservable: None,
        },
    )
}

/// Rotation (degrees) and translation (metres) errors of a pose against a
/// motion.
fn errors(raster: &Raster, alpha: Angle, t: &Pose, d: (f64, f64), dtheta: f64) -> (f64, f64) {
    let m = raster.motion(alpha, Some(t));
    let rotation = (f64::from(m.dtheta) - dtheta).to_degrees();
    let rotation = (rotation + 180.0).rem_euclid(360.0) - 180.0;
    let (x, y) = m.translation.unwrap();
    (
        rotation.abs(),
        (f64::from(x) - d.0).hypot(f64::from(y) - d.1),
    )
}

const FROM: (f64, f64, f64) = (3.0, 2.5, 0.4);
/// Small and large turns, moves that are no whole number of cells.
const TO: [(f64, f64, f64); 4] = [
    (3.37, 2.21, 0.613),
    (4.06, 3.03, 3.41),
    (2.51, 5.47, 2.02),
    (3.12, 2.58, 0.355),
];

#[test]
fn the_grid_estimate_refined_on_the_beams_is_within_a_tenth_of_a_cell() {
    let (laser, raster) = (laser(), raster());
    let cell = f64::from(raster.cell());
    room_turns::each_turn(&laser, &raster, FROM, &TO, |to, first, second, estimate| {
        assert_eq!(estimate.status, Status::Confident, "{to:?}");
        let t = estimate.translation.unwrap();
        let (d, dtheta) = relative(FROM, to);
        let before = errors(&raster, estimate.alpha, &t, d, dtheta);
        let fit = raster
            .refine_on_beams(
                &laser.as_scan(first),
                &laser.as_scan(second),
                estimate.alpha,
                &t,
            )
            .unwrap();
        let after = errors(&raster, fit.alpha, &fit.translation, d, dtheta);
        // Exact ranges (f32): the beams pin the walls far below a cell.
        assert!(
            after.0 < 0.03 && after.1 < 0.1 * cell,
            "{to:?}: grid {before:?}, beams {after:?}"
        );
        assert!(after.0 <= before.0 && after.1 <= before.1, "{to:?}");
        assert!(
            fit.pairs > 100 && fit.residual.to_num::<f64>() < 0.05,
            "{fit:?}"
        );
        // Kept: the scale, the column count.
        assert_eq!(fit.translation.columns, t.columns);
    });
}

/// The 270° laser, a full-circle one starting straight ahead (as the
/// spinning lidars report), and a clockwise one.
fn lasers() -> [Laser; 3] {
    let full = core::f64::consts::TAU;
    let counter_clockwise = laser();
    [
        counter_clockwise,
        Laser {
            beams: 720,
            angle_min: 0.0,
            angle_increment: full / 720.0,
            max_range: 30.0,
        },
        Laser {
            angle_min: -counter_clockwise.angle_min,
            angle_increment: -counter_clockwise.angle_increment,
            ..counter_clockwise
        },
    ]
}

#[test]
fn a_start_off_by_half_a_degree_and_a_cell_comes_back() {
    let raster = raster();
    let cell = f64::from(raster.cell());
    for laser in lasers() {
        off_by_half_a_degree_and_a_cell(&laser, &raster, cell);
    }
}

fn off_by_half_a_degree_and_a_cell(laser: &Laser, raster: &Raster, cell: f64) {
    let first = laser.scan(&room(), FROM);
    for to in TO {
        let second = laser.scan(&room(), to);
        let (d, dtheta) = relative(FROM, to);
        for (dd, dt) in [((cell, 0.0), 0.5f64), ((-0.7 * cell, 0.7 * cell), -0.5)] {
            let (alpha, t) =
                estimator_pose((d.0 + dd.0, d.1 + dd.1), dtheta + dt.to_radians(), cell);
            let fit = raster
                .refine_on_beams(&laser.as_scan(&first), &laser.as_scan(&second), alpha, &t)
                .unwrap();
            let after = errors(raster, fit.alpha, &fit.translation, d, dtheta);
            // From the third pose the reference's side walls are seen
            // grazing through the room's opening (their beams more than
            // 0.5 m apart): the matched walls are nearly parallel, and the
            // fit holds the translation along them where it started.
            let bound = if to == TO[2] {
                0.5 * dd.0.hypot(dd.1)
            } else {
                0.1 * cell
            };
            assert!(
                after.0 < 0.03 && after.1 < bound,
                "{laser:?} {to:?}: {after:?}"
            );
        }
        // Two degrees off: the fit would leave the estimate's basin.
        let (alpha, t) = estimator_pose(d, dtheta + 2f64.to_radians(), cell);
        assert_eq!(
            raster.refine_on_beams(&laser.as_scan(&first), &laser.as_scan(&second), alpha, &t),
            Err(BeamFitError::MovedTooFar),
            "{laser:?} {to:?}"
        );
    }
}

#[test]
fn a_corridor_keeps_its_unobservable_direction() {
    // Two long parallel walls: the motion along them is not observable.
    let walls: Vec<Wall> = vec![((-50.0, -1.0), (50.0, -1.0)), ((-50.0, 1.2), (50.0, 1.2))];
    let (laser, raster) = (laser(), raster());
    let cell = f64::from(raster.cell());
    let (from, to) = ((0.0, 0.0, 0.0), (0.83, 0.07, 0.02));
    let (a, b) = (laser.scan(&walls, from), laser.scan(&walls, to));
    let (d, dtheta) = relative(from, to);
    // The start: 0.3° and a third of a cell across the corridor off, and
    // nothing along it (what the estimator reports there).
    let (alpha, mut t) =
        estimator_pose((0.0, d.1 + 0.3 * cell), dtheta + 0.3f64.to_radians(), cell);
    let (s, c) = (-dtheta).sin_cos();
    let u = (c, s); // R(α)·x̂: the walls' direction in t's frame.
    t.unobservable = Some((Score::from_num(u.0), Score::from_num(u.1)));
    let fit = raster
        .refine_on_beams(&laser.as_scan(&a), &laser.as_scan(&b), alpha, &t)
        .unwrap();
    let (ux, uy) = fit.translation.unobservable.unwrap();
    let component = fit.translation.x.to_num::<f64>() * ux.to_num::<f64>()
        + fit.translation.y.to_num::<f64>() * uy.to_num::<f64>();
    assert!(component.abs() < 1e-3, "{component}");
    let m = raster.motion(fit.alpha, Some(&fit.translation));
    let rotation = (f64::from(m.dtheta) - dtheta).to_degrees().abs();
    let (_, y) = m.translation.unwrap();
    assert!(rotation < 0.03, "{rotation}");
    assert!((f64::from(y) - d.1).abs() < 0.1 * cell, "{y} {d:?}");
}

#[test]
fn unusable_inputs_are_refused_with_a_typed_error() {
    let (laser, raster) = (laser(), raster());
    let first = laser.scan(&room(), FROM);
    let second = laser.scan(&room(), TO[0]);
    let (d, dtheta) = relative(FROM, TO[0]);
    let (alpha, t) = estimator_pose(d, dtheta, f64::from(raster.cell()));
    let good = laser.as_scan(&first);
    let nan = vec![f32::NAN; 541];
    let refine = |a: &Scan<'_>, b: &Scan<'_>, t: &Pose| raster.refine_on_beams(a, b, alpha, t);
    assert!(refine(&good, &laser.as_scan(&second), &t).is_ok());
    assert_eq!(
        refine(&good, &laser.as_scan(&nan), &t),
        Err(BeamFitError::TooFewPairs)
    );
    assert_eq!(
        refine(&laser.as_scan(&nan), &laser.as_scan(&second), &t),
        Err(BeamFitError::TooFewPairs)
    );
    assert_eq!(
        refine(&good, &laser.as_scan(&[]), &t),
        Err(BeamFitError::TooFewPairs)
    );
    let broken = Scan {
        angle_increment: f32::NAN,
        ..good
    };
    assert_eq!(
        refine(&broken, &laser.as_scan(&second), &t),
        Err(BeamFitError::TooFewPairs)
    );
    let scaled = Pose {
        scale: Score::from_num(1.1),
        ..t
    };
    assert_eq!(
        refine(&good, &laser.as_scan(&second), &scaled),
        Err(BeamFitError::Unsupported)
    );
    let far = Pose { x: Score::MAX, ..t };
    assert_eq!(
        refine(&good, &laser.as_scan(&second), &far),
        Err(BeamFitError::Unsupported)
    );
    // A scan refined against itself at its own pose stays there.
    let (zero, at_rest) = estimator_pose((0.0, 0.0), 0.0, f64::from(raster.cell()));
    let fit = raster
        .refine_on_beams(&good, &good, zero, &at_rest)
        .unwrap();
    assert!(
        fit.alpha.distance(Angle::ZERO).to_degrees() < 1e-3,
        "{fit:?}"
    );
    assert!(fit.translation.x.abs().to_num::<f64>() < 1e-3, "{fit:?}");
}
