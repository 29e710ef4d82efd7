//! The scan rasterizer's conventions on a ray-cast synthetic room: the
//! estimate's α is −dθ, and `Raster::motion` gives the robot's motion in the
//! pair files' convention.

use std::f64::consts::PI;

use hough_heading::{estimator, grid, Mode, Raster, Scan, SensorOffset, Status};

type G = grid!(256, 256);
type E = estimator!(256, 256, 360);

/// A wall from one point to another, metres.
type Wall = ((f64, f64), (f64, f64));

/// A room that is not symmetric under any rotation: an L-shaped outline
/// (metres) with a chamfered corner (so no 90° ambiguity) and two pillars.
fn room() -> Vec<Wall> {
    let outline = [
        (-4.0, -3.0),
        (5.0, -3.0),
        (5.0, 1.0),
        (2.0, 1.0),
        (2.0, 4.0),
        (-2.5, 4.0),
        (-4.0, 2.0),
    ];
    let mut walls: Vec<_> = (0..outline.len())
        .map(|i| (outline[i], outline[(i + 1) % outline.len()]))
        .collect();
    for (cx, cy, h) in [(-2.0, 2.0, 0.3), (3.0, -1.5, 0.4)] {
        let corners = [
            (cx - h, cy - h),
            (cx + h, cy - h),
            (cx + h, cy + h),
            (cx - h, cy + h),
        ];
        walls.extend((0..4).map(|i| (corners[i], corners[(i + 1) % 4])));
    }
    walls
}

/// Ray-casts `walls` from the sensor at world pose `(x, y, θ)`: `n` beams
/// from `angle_min` (sensor frame), spacing `step`; no return → `max_range`.
fn cast(
    walls: &[Wall],
    pose: (f64, f64, f64),
    n: usize,
    angle_min: f64,
    step: f64,
    max_range: f64,
) -> Vec<f32> {
    (0..n)
        .map(|i| {
            let phi = pose.2 + angle_min + i as f64 * step;
            let (dx, dy) = (phi.cos(), phi.sin());
            let mut best = max_range;
            for &((ax, ay), (bx, by)) in walls {
                // Solve pose + r·d = a + s·(b − a).
                let (ex, ey) = (bx - ax, by - ay);
                let den = dx * ey - dy * ex;
                if den.abs() < 1e-12 {
                    continue;
                }
                let (wx, wy) = (ax - pose.0, ay - pose.1);
                let r = (wx * ey - wy * ex) / den;
                let s = (wx * dy - wy * dx) / den;
                if r > 0.0 && (0.0..=1.0).contains(&s) {
                    best = best.min(r);
                }
            }
            best as f32
        })
        .collect()
}

/// The robot pose 2 in the robot frame 1: `(dx, dy, dθ)`.
fn relative(p1: (f64, f64, f64), p2: (f64, f64, f64)) -> (f64, f64, f64) {
    let (s, c) = p1.2.sin_cos();
    let (wx, wy) = (p2.0 - p1.0, p2.1 - p1.1);
    let dtheta = (p2.2 - p1.2 + PI).rem_euclid(2.0 * PI) - PI;
    (c * wx + s * wy, -s * wx + c * wy, dtheta)
}

fn wrap_deg(d: f64) -> f64 {
    (d + 180.0).rem_euclid(360.0) - 180.0
}

#[test]
fn synthetic_room_gives_alpha_minus_dtheta_and_the_motion() {
    let walls = room();
    // A 360° scanner, 720 beams, mounted 0.2 m ahead of the robot origin.
    let offset = (0.2, 0.0, 0.0);
    let (n, angle_min, step, max_range) = (720, -PI, 2.0 * PI / 720.0, 30.0);
    let cases = [
        ((0.0, 0.0, 0.0), (0.5, 0.3, 0.0)),
        ((0.0, 0.0, 0.3), (0.4, -0.2, 1.2)),
        ((-1.0, 0.5, -0.4), (0.0, 0.0, 2.6)),
        ((0.5, -0.5, 1.0), (-0.3, 0.4, -2.2)),
    ];
    for (robot1, robot2) in cases {
        // The sensor's world pose from the robot's.
        let sensor = |p: (f64, f64, f64)| {
            let (s, c) = p.2.sin_cos();
            (
                p.0 + c * offset.0 - s * offset.1,
                p.1 + s * offset.0 + c * offset.1,
                p.2 + offset.2,
            )
        };
        let r1 = cast(&walls, sensor(robot1), n, angle_min, step, max_range);
        let r2 = cast(&walls, sensor(robot2), n, angle_min, step, max_range);
        let scan = |ranges| Scan {
            ranges,
            angle_min: angle_min as f32,
            angle_increment: step as f32,
            max_range: max_range as f32,
            offset: SensorOffset {
                x: offset.0 as f32,
                y: offset.1 as f32,
                theta: offset.2 as f32,
            },
        };
        let (s1, s2) = (scan(&r1), scan(&r2));
        let raster = Raster::with_radius(7.0, 256).unwrap();
        let (mut g1, mut g2) = (G::new(), G::new());
        assert_eq!(raster.rasterize(&s1, &mut g1).kept, n as u32);
        assert_eq!(raster.rasterize(&s2, &mut g2).kept, n as u32);
        let estimate = E::new(Mode::Improved).estimate_pair(&g1, &g2);
        let (dx, dy, dtheta) = relative(robot1, robot2);
        // α = −dθ.
        let alpha = f64::from(estimate.alpha.to_degrees());
        assert!(
            wrap_deg(alpha + dtheta.to_degrees()).abs() < 1.0,
            "α = {alpha}, dθ = {}",
            dtheta.to_degrees()
        );
        // A room of mostly perpendicular walls may be flagged AmbiguousAxis
        // (its rival peak is at 90°); the best candidate must still be right.
        assert_ne!(estimate.status, Status::NoStructure);
        // The motion in the file convention.
        let motion = raster.motion(estimate.alpha, estimate.translation.as_ref());
        assert!(wrap_deg(f64::from(motion.dtheta).to_degrees() - dtheta.to_degrees()).abs() < 1.0);
        let (ex, ey) = motion.translation.expect("translation");
        let error = (f64::from(ex) - dx).hypot(f64::from(ey) - dy);
        assert!(
            error < 2.0 * f64::from(raster.cell()),
            "d = ({dx:.3}, {dy:.3}), estimated ({ex:.3}, {ey:.3})"
        );
    }
}
