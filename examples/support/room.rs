//! The test scene: the outline of a room, rasterised at compile time.
//!
//! An L-shaped room with a chamfered corner, a door gap, a shelf and a short
//! partition wall: mostly Manhattan, like a real room, but with no central
//! symmetry, so the estimator can tell α from α + π. The outline is drawn one
//! cell wide, as a laser scan would see it.
//!
//! [`room_words`] is a `const fn`: a `static` grid built from it lives in flash
//! and costs no RAM and no start-up time.

/// Where the room sits in the image: rotated counter-clockwise by `degrees`
/// about the image centre, then shifted by `(dx, dy)` cells (y up), the
/// convention of DESIGN.md §2. An estimate between the room at pose 0 and the
/// room at this pose must return `α = degrees`.
#[derive(Clone, Copy, Debug)]
pub struct Pose {
    /// Rotation, degrees, counter-clockwise.
    pub degrees: f64,
    /// Shift right, cells.
    pub dx: f64,
    /// Shift up, cells.
    pub dy: f64,
}

impl Pose {
    /// The room as drawn: no rotation, no shift.
    pub const ORIGIN: Pose = Pose::turned(0.0);

    /// A pure rotation by `degrees`.
    pub const fn turned(degrees: f64) -> Pose {
        Pose {
            degrees,
            dx: 0.0,
            dy: 0.0,
        }
    }
}

/// The walls, `(x0, y0, x1, y1)`, in units of [`SCALE`] × the image's smaller
/// side, y up, origin at the image centre. The farthest point is 1.31 units
/// from the centre, so the room stays inside the image at any rotation.
const WALLS: [(f64, f64, f64, f64); 10] = [
    (-1.0, -0.8, 0.15, -0.8), // south wall, west of the door
    (0.45, -0.8, 0.7, -0.8),  // south wall, east of the door
    (0.7, -0.8, 1.0, -0.5),   // chamfered south-east corner
    (1.0, -0.5, 1.0, 0.2),    // east wall
    (1.0, 0.2, 0.4, 0.2),     // inner corner of the L
    (0.4, 0.2, 0.4, 0.85),    // east wall of the north wing
    (0.4, 0.85, -1.0, 0.85),  // north wall
    (-1.0, 0.85, -1.0, -0.8), // west wall
    (-0.6, 0.3, -0.6, -0.2),  // a shelf standing in the room
    (0.0, 0.85, 0.0, 0.55),   // a partition stub on the north wall
];

/// One unit of [`WALLS`] as a fraction of the image's smaller side.
const SCALE: f64 = 0.36;

/// The room at `pose` as the row words of a `W × H` grid (`RW = ceil(W/32)`
/// words per row, bit `col % 32` of word `col / 32`), ready for
/// `Grid::from_words`. Cells falling outside the image are dropped.
pub const fn room_words<const W: usize, const H: usize, const RW: usize>(
    pose: Pose,
) -> [[u32; RW]; H] {
    let mut rows = [[0u32; RW]; H];
    let side = if W < H { W } else { H };
    let unit = SCALE * side as f64;
    let (sin, cos) = sin_cos_degrees(pose.degrees);
    let mut i = 0;
    while i < WALLS.len() {
        let (x0, y0, x1, y1) = WALLS[i];
        // Rotate, scale and shift both ends (y up, origin at the centre).
        let ax = unit * (cos * x0 - sin * y0) + pose.dx;
        let ay = unit * (sin * x0 + cos * y0) + pose.dy;
        let bx = unit * (cos * x1 - sin * y1) + pose.dx;
        let by = unit * (sin * x1 + cos * y1) + pose.dy;
        // Sample every half cell along the wall: a connected 1-cell outline.
        let length = abs(bx - ax) + abs(by - ay);
        let steps = 2 * (length as usize) + 1;
        let mut s = 0;
        while s <= steps {
            let t = s as f64 / steps as f64;
            let x = ax + t * (bx - ax);
            let y = ay + t * (by - ay);
            // Cell centres: x = col − (W−1)/2, y = (H−1)/2 − row.
            let col = round(x + (W as f64 - 1.0) / 2.0);
            let row = round((H as f64 - 1.0) / 2.0 - y);
            if col >= 0 && row >= 0 && (col as usize) < W && (row as usize) < H {
                let (col, row) = (col as usize, row as usize);
                rows[row][col / 32] |= 1 << (col % 32);
            }
            s += 1;
        }
        i += 1;
    }
    rows
}

/// Nearest integer, halves away from zero.
const fn round(v: f64) -> i64 {
    if v >= 0.0 {
        (v + 0.5) as i64
    } else {
        -((-v + 0.5) as i64)
    }
}

const fn abs(v: f64) -> f64 {
    if v < 0.0 {
        -v
    } else {
        v
    }
}

/// `(sin, cos)` of an angle in degrees, by Taylor series after reducing the
/// argument to [−180°, 180°]; error below 1e-15.
const fn sin_cos_degrees(degrees: f64) -> (f64, f64) {
    let turns = degrees / 360.0;
    let whole = round(turns) as f64;
    let x = (turns - whole) * 2.0 * core::f64::consts::PI;
    let (mut sin, mut cos) = (0.0, 0.0);
    let (mut sin_term, mut cos_term) = (x, 1.0);
    let mut k = 0;
    while k < 30 {
        sin += sin_term;
        cos += cos_term;
        let n = (2 * k + 2) as f64;
        sin_term *= -x * x / (n * (n + 1.0));
        cos_term *= -x * x / ((n - 1.0) * n);
        k += 1;
    }
    (sin, cos)
}
