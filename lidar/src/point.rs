//! One measured point, and the units every protocol decodes into.

/// Angle units per degree: 1/6400 °. Exact for every protocol here: LDRobot
/// angles are in 0.01 ° (64 units), Slamtec and YDLIDAR ones in 1/64 °
/// (100 units), Neato ones in whole degrees.
pub const UNITS_PER_DEGREE: u32 = 6_400;
/// Angle units per turn: `360 · UNITS_PER_DEGREE` = 2 304 000.
pub const UNITS_PER_TURN: u32 = 360 * UNITS_PER_DEGREE;

/// Which way a sensor's angles grow, seen from above (the sensor's top, the
/// side with the manufacturer's logo, facing up).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Direction {
    /// Angles grow clockwise (LD06, RPLIDAR, YDLIDAR).
    Clockwise,
    /// Angles grow counter-clockwise (the convention of ROS and of
    /// `hough-heading`).
    CounterClockwise,
}

/// One point as the sensor reports it, in the sensor's own frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Point {
    /// Angle from the sensor's zero (the front of its manual's coordinate
    /// figure), in [`UNITS_PER_DEGREE`] units, in `0..UNITS_PER_TURN`,
    /// growing in the sensor's own [`Direction`] (clockwise for all but the
    /// XV-11).
    pub angle: u32,
    /// Range in quarter millimetres (0.25 mm); 0 = no return.
    pub range_q2: u32,
    /// The sensor's quality or intensity byte, as sent (its scale depends on
    /// the sensor: LD06 confidence 0–255, RPLIDAR quality 0–63, YDLIDAR X2/X4
    /// send none and report 0).
    pub quality: u8,
}

impl Point {
    /// The range in metres (`range_q2 / 4000`; 0.0 = no return).
    pub fn range_m(&self) -> f32 {
        self.range_q2 as f32 / 4000.0
    }

    /// The angle in degrees, in the sensor's own direction.
    pub fn degrees(&self) -> f32 {
        self.angle as f32 / UNITS_PER_DEGREE as f32
    }
}

/// `angle` (any number of units) wrapped into `0..UNITS_PER_TURN`; within a
/// turn of that range (the usual case) without a 64-bit division.
pub(crate) const fn wrap(angle: i64) -> u32 {
    let turn = UNITS_PER_TURN as i64;
    let wrapped = if angle >= 0 && angle < turn {
        angle
    } else if angle >= -turn && angle < 0 {
        angle + turn
    } else if angle >= turn && angle < 2 * turn {
        angle - turn
    } else {
        angle.rem_euclid(turn)
    };
    wrapped as u32
}
