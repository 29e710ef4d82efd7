//! The setup the beam tests share: grid estimates (128², `N_θ` = 360, the
//! scans' free space on) of ray-cast turns in the L-shaped room of
//! `host_tests::raycast` or another map.

use host_tests::raycast::{l_room, Laser, Wall};
use hough_heading::{estimator, grid, Estimate, FreeSpace, Mode, Raster};

type G128 = grid!(128, 128);
type E128 = estimator!(128, 128, 360);

/// A world pose of the robot: x, y (metres), heading (radians).
pub type RobotPose = (f64, f64, f64);

/// For each pose of `to`: the ranges `laser` casts in the room from `from`
/// and from that pose, and the grid estimate (`Estimator::estimate_scans`
/// on `raster`, no prior) of the motion between them, handed to `f`.
pub fn each_turn(
    laser: &Laser,
    raster: &Raster,
    from: RobotPose,
    to: &[RobotPose],
    f: impl FnMut(RobotPose, &[f32], &[f32], Estimate),
) {
    each_turn_in(&l_room(), laser, raster, from, to, f);
}

/// [`each_turn`] in the map `walls`.
pub fn each_turn_in(
    walls: &[Wall],
    laser: &Laser,
    raster: &Raster,
    from: RobotPose,
    to: &[RobotPose],
    mut f: impl FnMut(RobotPose, &[f32], &[f32], Estimate),
) {
    let first = laser.scan(walls, from);
    let (mut grid1, mut free1) = (G128::new(), G128::new());
    raster.rasterize(&laser.as_scan(&first), &mut grid1);
    raster.free_space(&laser.as_scan(&first), &mut free1);
    let mut e = E128::new(Mode::Improved);
    let reference = e.reference(&grid1);
    for &pose in to {
        let second = laser.scan(walls, pose);
        let (mut grid2, mut free2) = (G128::new(), G128::new());
        raster.rasterize(&laser.as_scan(&second), &mut grid2);
        raster.free_space(&laser.as_scan(&second), &mut free2);
        let views = FreeSpace {
            reference: &free1,
            current: &free2,
        };
        let estimate = e.estimate_scans(&reference, &grid2, &views, None);
        f(pose, &first, &second, estimate);
    }
}
