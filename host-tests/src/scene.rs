//! Deterministic synthetic scenes for the property tests, the accuracy
//! evaluation and the demo.
//!
//! A [`Scene`] is a set of line segments in continuous coordinates: origin at
//! the image centre, y up, the conventions of DESIGN.md §2. The generators
//! ([`random_polygon`], [`manhattan_room`], [`corridor`],
//! [`centrally_symmetric`], and the fixed shapes [`line()`], [`square`],
//! [`l_shape`]) return scenes inside the unit disc; [`render_pair`] scales them
//! to pixels, applies a [`Transform`] (`p' = s·R(α)·p + t`, α
//! counter-clockwise) and rasterizes both views with a level of [`Damage`].
//! Every random choice comes from a seeded [`ChaCha8Rng`] (or any [`Rng`]
//! passed in), so a seed always gives the same images.

use std::f64::consts::{PI, TAU};
use std::io;
use std::path::Path;

use rand::seq::index;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::reference::cos_sin;
pub use crate::reference::Image;

/// A point in continuous centred coordinates (y up).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point {
    /// Abscissa.
    pub x: f64,
    /// Ordinate (up).
    pub y: f64,
}

impl Point {
    /// The point `(x, y)`.
    pub const fn new(x: f64, y: f64) -> Self {
        Self { x, y }
    }

    /// Distance from the origin.
    pub fn norm(self) -> f64 {
        self.x.hypot(self.y)
    }

    fn lerp(self, other: Self, t: f64) -> Self {
        Self::new(
            self.x + t * (other.x - self.x),
            self.y + t * (other.y - self.y),
        )
    }
}

/// A straight segment from `a` to `b`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    /// First end.
    pub a: Point,
    /// Second end.
    pub b: Point,
}

impl Segment {
    /// The segment from `a` to `b`.
    pub const fn new(a: Point, b: Point) -> Self {
        Self { a, b }
    }

    /// Length, in the units of the scene.
    pub fn length(&self) -> f64 {
        (self.b.x - self.a.x).hypot(self.b.y - self.a.y)
    }
}

/// A scene: a set of line segments.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Scene {
    /// The segments, in drawing order (the order defines the arc length along
    /// which [`Damage`] gaps are placed).
    pub segments: Vec<Segment>,
}

impl Scene {
    /// The closed polygon through `vertices` (the last one joins the first).
    pub fn polygon(vertices: &[Point]) -> Self {
        let mut scene = Self::default();
        scene.add_polygon(vertices);
        scene
    }

    /// Appends the closed polygon through `vertices`.
    pub fn add_polygon(&mut self, vertices: &[Point]) {
        let n = vertices.len();
        self.segments
            .extend((0..n).map(|i| Segment::new(vertices[i], vertices[(i + 1) % n])));
    }

    /// Largest distance of a segment end from the origin (the radius of the
    /// smallest centred disc holding the scene).
    pub fn radius(&self) -> f64 {
        self.segments
            .iter()
            .flat_map(|s| [s.a.norm(), s.b.norm()])
            .fold(0.0, f64::max)
    }

    /// Total length of the segments.
    pub fn length(&self) -> f64 {
        self.segments.iter().map(Segment::length).sum()
    }

    /// The scene scaled by `factor` about the origin.
    pub fn scaled(&self, factor: f64) -> Self {
        self.map(|p| Point::new(factor * p.x, factor * p.y))
    }

    /// The scene moved by `t` (`p' = s·R(α)·p + t`).
    pub fn transformed(&self, t: &Transform) -> Self {
        self.map(|p| t.apply(p))
    }

    fn map(&self, f: impl Fn(Point) -> Point) -> Self {
        Self {
            segments: self
                .segments
                .iter()
                .map(|s| Segment::new(f(s.a), f(s.b)))
                .collect(),
        }
    }
}

/// The families of random scenes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SceneKind {
    /// [`random_polygon`].
    RandomPolygon,
    /// [`manhattan_room`].
    ManhattanRoom,
    /// [`corridor`].
    Corridor,
    /// [`centrally_symmetric`].
    CentrallySymmetric,
}

impl SceneKind {
    /// Every kind, in a fixed order.
    pub const ALL: [Self; 4] = [
        Self::RandomPolygon,
        Self::ManhattanRoom,
        Self::Corridor,
        Self::CentrallySymmetric,
    ];

    /// Short name for tables and file names (`polygon`, `manhattan`,
    /// `corridor`, `symmetric`).
    pub fn name(self) -> &'static str {
        match self {
            Self::RandomPolygon => "polygon",
            Self::ManhattanRoom => "manhattan",
            Self::Corridor => "corridor",
            Self::CentrallySymmetric => "symmetric",
        }
    }

    /// Whether every scene of this kind is invariant under a half turn (so α
    /// and α + π cannot be told apart).
    pub fn is_centrally_symmetric(self) -> bool {
        matches!(self, Self::Corridor | Self::CentrallySymmetric)
    }

    /// A random scene of this kind, inside the unit disc.
    pub fn generate<R: Rng + ?Sized>(self, rng: &mut R) -> Scene {
        match self {
            Self::RandomPolygon => random_polygon(rng),
            Self::ManhattanRoom => manhattan_room(rng),
            Self::Corridor => corridor(rng),
            Self::CentrallySymmetric => centrally_symmetric(rng),
        }
    }
}

/// Clearance kept between furniture, walls and cut-outs (unit-disc units).
const CLEARANCE: f64 = 0.05;
/// Largest radius the generators use, leaving a margin inside the unit disc.
const MAX_RADIUS: f64 = 0.97;

/// A random simple polygon of 3–8 vertices inside the unit disc: star-shaped
/// about the origin (vertex angles spread around the circle with jitter, each
/// gap below π; radii in `[0.5, 1]·0.97`), so it spans about 50–90 % of the
/// disc's diameter. Random orientation.
pub fn random_polygon<R: Rng + ?Sized>(rng: &mut R) -> Scene {
    let n = rng.gen_range(3..=8usize);
    // Gaps between consecutive angles stay below π: (1 + 2·jitter)·2π/n < π.
    let jitter = if n == 3 { 0.2 } else { 0.35 };
    let phase = rng.gen_range(0.0..TAU);
    let vertices: Vec<Point> = (0..n)
        .map(|i| {
            let angle = phase + (i as f64 + rng.gen_range(-jitter..jitter)) * TAU / n as f64;
            let r = MAX_RADIUS * rng.gen_range(0.5..1.0);
            Point::new(r * angle.cos(), r * angle.sin())
        })
        .collect();
    Scene::polygon(&vertices)
}

/// An axis-aligned box as a closed polygon: centre `(cx, cy)`, half sizes
/// `(hx, hy)`.
fn rectangle(cx: f64, cy: f64, hx: f64, hy: f64) -> [Point; 4] {
    [
        Point::new(cx - hx, cy - hy),
        Point::new(cx + hx, cy - hy),
        Point::new(cx + hx, cy + hy),
        Point::new(cx - hx, cy + hy),
    ]
}

/// Axis-aligned box `(cx, cy, hx, hy)` used for overlap tests.
type BoxXY = (f64, f64, f64, f64);

fn boxes_overlap(p: BoxXY, q: BoxXY, clearance: f64) -> bool {
    (p.0 - q.0).abs() < p.2 + q.2 + clearance && (p.1 - q.1).abs() < p.3 + q.3 + clearance
}

/// Room half extents `(a, b)` with `a ∈ [0.45, 0.8)`, `b ∈ [0.3, 0.6)`,
/// shrunk so the corners stay inside the unit disc.
fn room_extents<R: Rng + ?Sized>(rng: &mut R) -> (f64, f64) {
    let (a, b) = (rng.gen_range(0.45..0.8), rng.gen_range(0.3..0.6));
    let k = (MAX_RADIUS / f64::hypot(a, b)).min(1.0);
    (k * a, k * b)
}

/// The segment from `a` to `b` with the intervals `gaps` (distances from `a`,
/// sorted, disjoint) left open.
fn wall_with_gaps(a: Point, b: Point, gaps: &[(f64, f64)]) -> Vec<Segment> {
    let len = Segment::new(a, b).length();
    let mut pieces = Vec::new();
    let mut start = 0.0;
    for &(g0, g1) in gaps {
        pieces.push(Segment::new(a.lerp(b, start / len), a.lerp(b, g0 / len)));
        start = g1;
    }
    pieces.push(Segment::new(a.lerp(b, start / len), b));
    pieces
}

/// A random door `(start, end)` along a wall of length `len`: width in
/// `[0.1, 0.18)`, at least `0.05` from either end (requires `len ≥ 0.3`).
fn door<R: Rng + ?Sized>(rng: &mut R, len: f64) -> (f64, f64) {
    let width = rng.gen_range(0.1..0.18);
    let start = rng.gen_range(0.05..len - width - 0.05);
    (start, start + width)
}

/// A Manhattan room inside the unit disc: an axis-aligned rectangle (half
/// extents about 0.45–0.8 by 0.3–0.6), L-shaped half of the time (one corner
/// cut out), with one door gap in a wall and 1–3 rectangular furniture boxes
/// (half sizes 0.04–0.12) that touch neither the walls nor each other.
pub fn manhattan_room<R: Rng + ?Sized>(rng: &mut R) -> Scene {
    let (a, b) = room_extents(rng);
    let sx = if rng.gen_bool(0.5) { 1.0 } else { -1.0 };
    let sy = if rng.gen_bool(0.5) { 1.0 } else { -1.0 };
    let mut outline = vec![
        Point::new(-a, -b),
        Point::new(a, -b),
        Point::new(a, b),
        Point::new(-a, b),
    ];
    let mut cut = None;
    if rng.gen_bool(0.5) {
        let cw = rng.gen_range(0.3..0.55) * 2.0 * a;
        let ch = rng.gen_range(0.3..0.55) * 2.0 * b;
        outline = [
            (-a, -b),
            (a, -b),
            (a, b - ch),
            (a - cw, b - ch),
            (a - cw, b),
            (-a, b),
        ]
        .iter()
        .map(|&(x, y)| Point::new(sx * x, sy * y))
        .collect();
        cut = Some((sx * (a - cw / 2.0), sy * (b - ch / 2.0), cw / 2.0, ch / 2.0));
    }

    let n = outline.len();
    let walls: Vec<Segment> = (0..n)
        .map(|i| Segment::new(outline[i], outline[(i + 1) % n]))
        .collect();
    let long_walls: Vec<usize> = (0..n).filter(|&i| walls[i].length() >= 0.35).collect();
    let door_wall = long_walls[rng.gen_range(0..long_walls.len())];
    let mut scene = Scene::default();
    for (i, wall) in walls.iter().enumerate() {
        if i == door_wall {
            let gap = door(rng, wall.length());
            scene
                .segments
                .extend(wall_with_gaps(wall.a, wall.b, &[gap]));
        } else {
            scene.segments.push(*wall);
        }
    }

    let mut boxes: Vec<BoxXY> = Vec::new();
    let wanted = rng.gen_range(1..=3);
    for _ in 0..100 {
        if boxes.len() == wanted {
            break;
        }
        let (hx, hy) = (rng.gen_range(0.04..0.12), rng.gen_range(0.04..0.12));
        let candidate = (
            rng.gen_range(-a + hx + CLEARANCE..a - hx - CLEARANCE),
            rng.gen_range(-b + hy + CLEARANCE..b - hy - CLEARANCE),
            hx,
            hy,
        );
        let blocked = cut.is_some_and(|c| boxes_overlap(candidate, c, CLEARANCE))
            || boxes
                .iter()
                .any(|&o| boxes_overlap(candidate, o, CLEARANCE));
        if !blocked {
            boxes.push(candidate);
        }
    }
    for (cx, cy, hx, hy) in boxes {
        scene.add_polygon(&rectangle(cx, cy, hx, hy));
    }
    scene
}

/// A corridor inside the unit disc: two parallel horizontal walls at
/// `y = ±w` (half width `w ∈ [0.12, 0.3)`) running almost across the disc,
/// with 0–2 pairs of door gaps placed symmetrically (a door at `x` in the top
/// wall, its twin at `−x` in the bottom one). Invariant under a half turn.
pub fn corridor<R: Rng + ?Sized>(rng: &mut R) -> Scene {
    let w = rng.gen_range(0.12..0.3);
    let half_len = (MAX_RADIUS * MAX_RADIUS - w * w).sqrt();
    let len = 2.0 * half_len;
    let mut gaps: Vec<(f64, f64)> = Vec::new();
    for _ in 0..rng.gen_range(0..=2) {
        let gap = door(rng, len);
        if gaps
            .iter()
            .all(|&(s, e)| gap.1 + CLEARANCE < s || e + CLEARANCE < gap.0)
        {
            gaps.push(gap);
        }
    }
    gaps.sort_by(|p, q| p.0.total_cmp(&q.0));
    let top = wall_with_gaps(Point::new(-half_len, w), Point::new(half_len, w), &gaps);
    let bottom = top
        .iter()
        .map(|s| Segment::new(Point::new(-s.a.x, -s.a.y), Point::new(-s.b.x, -s.b.y)));
    Scene {
        segments: top.iter().copied().chain(bottom).collect(),
    }
}

/// A scene invariant under a half turn (`p → −p`), inside the unit disc, one
/// of (chosen uniformly): a rectangle; a parallelogram; a centrally symmetric
/// hexagon or octagon; a rectangular room with 1–2 pairs of furniture boxes
/// at `c` and `−c` and a pair of doors at `x` (top wall) and `−x` (bottom).
pub fn centrally_symmetric<R: Rng + ?Sized>(rng: &mut R) -> Scene {
    let mirrored = |p: Point| Point::new(-p.x, -p.y);
    match rng.gen_range(0..4) {
        0 => {
            let (a, b) = room_extents(rng);
            Scene::polygon(&rectangle(0.0, 0.0, a, b))
        }
        1 => {
            let u = Point::new(rng.gen_range(0.3..0.6), 0.0);
            let v = Point::new(rng.gen_range(-0.3..0.3), rng.gen_range(0.2..0.5));
            let corners = [
                Point::new(u.x + v.x, v.y),
                Point::new(-u.x + v.x, v.y),
                Point::new(-u.x - v.x, -v.y),
                Point::new(u.x - v.x, -v.y),
            ];
            let k = (MAX_RADIUS / corners.iter().map(|p| p.norm()).fold(0.0, f64::max)).min(1.0);
            Scene::polygon(&corners.map(|p| Point::new(k * p.x, k * p.y)))
        }
        2 => {
            let m = rng.gen_range(3..=4usize);
            let phase = rng.gen_range(0.0..PI);
            let half: Vec<Point> = (0..m)
                .map(|i| {
                    let angle = phase + (i as f64 + rng.gen_range(-0.3..0.3)) * PI / m as f64;
                    let r = MAX_RADIUS * rng.gen_range(0.5..1.0);
                    Point::new(r * angle.cos(), r * angle.sin())
                })
                .collect();
            let vertices: Vec<Point> = half
                .iter()
                .copied()
                .chain(half.iter().map(|&p| mirrored(p)))
                .collect();
            Scene::polygon(&vertices)
        }
        _ => {
            let (a, b) = room_extents(rng);
            let gap = door(rng, 2.0 * a);
            let top = wall_with_gaps(Point::new(-a, b), Point::new(a, b), &[gap]);
            let mut scene = Scene::default();
            for wall in [
                &top[..],
                &[Segment::new(Point::new(a, b), Point::new(a, -b))],
            ] {
                for s in wall {
                    scene.segments.push(*s);
                    scene
                        .segments
                        .push(Segment::new(mirrored(s.a), mirrored(s.b)));
                }
            }
            let mut boxes: Vec<BoxXY> = Vec::new();
            let wanted = 2 * rng.gen_range(1..=2);
            for _ in 0..100 {
                if boxes.len() == wanted {
                    break;
                }
                let (hx, hy) = (rng.gen_range(0.04..0.12), rng.gen_range(0.04..0.12));
                let bx = (
                    rng.gen_range(-a + hx + CLEARANCE..a - hx - CLEARANCE),
                    rng.gen_range(-b + hy + CLEARANCE..b - hy - CLEARANCE),
                    hx,
                    hy,
                );
                let twin = (-bx.0, -bx.1, hx, hy);
                let blocked = boxes_overlap(bx, twin, CLEARANCE)
                    || boxes.iter().any(|&o| {
                        boxes_overlap(bx, o, CLEARANCE) || boxes_overlap(twin, o, CLEARANCE)
                    });
                if !blocked {
                    boxes.extend([bx, twin]);
                }
            }
            for (cx, cy, hx, hy) in boxes {
                scene.add_polygon(&rectangle(cx, cy, hx, hy));
            }
            scene
        }
    }
}

/// A single segment from `a` to `b`.
pub fn line(a: Point, b: Point) -> Scene {
    Scene {
        segments: vec![Segment::new(a, b)],
    }
}

/// The outline of an axis-aligned square centred on the origin, side
/// `2·half_side`.
pub fn square(half_side: f64) -> Scene {
    Scene::polygon(&rectangle(0.0, 0.0, half_side, half_side))
}

/// An "L": a horizontal arm of length `long` and a vertical arm of length
/// `short` rising from its left end, centred on the origin (bounding box
/// `long × short`). Not symmetric under any rotation when `long ≠ short`.
pub fn l_shape(long: f64, short: f64) -> Scene {
    let corner = Point::new(-long / 2.0, -short / 2.0);
    Scene {
        segments: vec![
            Segment::new(corner, Point::new(long / 2.0, -short / 2.0)),
            Segment::new(corner, Point::new(-long / 2.0, short / 2.0)),
        ],
    }
}

/// A similarity transform `p' = s·R(α)·p + t`, α counter-clockwise (the
/// crate's convention; the paper's eq. (1) has the opposite sign of α).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// Rotation α, radians, counter-clockwise.
    pub alpha_rad: f64,
    /// Translation along x, pixels (after [`render_pair`]'s fitting).
    pub tx: f64,
    /// Translation along y (up), pixels.
    pub ty: f64,
    /// Isotropic scale `s`.
    pub scale: f64,
}

impl Transform {
    /// The identity.
    pub const IDENTITY: Self = Self {
        alpha_rad: 0.0,
        tx: 0.0,
        ty: 0.0,
        scale: 1.0,
    };

    /// A pure rotation by `alpha_rad` (counter-clockwise).
    pub const fn rotation(alpha_rad: f64) -> Self {
        Self {
            alpha_rad,
            ..Self::IDENTITY
        }
    }

    /// `s·R(α)·p + t`.
    pub fn apply(&self, p: Point) -> Point {
        let (sin, cos) = self.alpha_rad.sin_cos();
        Point::new(
            self.scale * (cos * p.x - sin * p.y) + self.tx,
            self.scale * (sin * p.x + cos * p.y) + self.ty,
        )
    }

    /// Length of the translation, pixels.
    pub fn translation_norm(&self) -> f64 {
        self.tx.hypot(self.ty)
    }

    /// A random transform for a `width × height` image: α uniform over
    /// `[0, 2π)`, translation in a uniform direction with length uniform in
    /// `[2, max(2, 0.1·min(W, H))]` pixels, scale uniform in `[0.9, 1.1]` when
    /// `with_scale` (else 1).
    pub fn sample<R: Rng + ?Sized>(
        rng: &mut R,
        width: usize,
        height: usize,
        with_scale: bool,
    ) -> Self {
        let alpha_rad = rng.gen_range(0.0..TAU);
        let max_t = (0.1 * width.min(height) as f64).max(2.0);
        let t = rng.gen_range(2.0..=max_t);
        let direction = rng.gen_range(0.0..TAU);
        let scale = if with_scale {
            rng.gen_range(0.9..=1.1)
        } else {
            1.0
        };
        Self {
            alpha_rad,
            tx: t * direction.cos(),
            ty: t * direction.sin(),
            scale,
        }
    }
}

/// Damage applied when rendering: point jitter, outlier pixels and missing
/// stretches of the outline.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Damage {
    /// Standard deviation of the Gaussian noise added to each sample point,
    /// per axis, pixels.
    pub jitter_px: f64,
    /// Outlier pixels added uniformly at random over the free cells, as a
    /// fraction of the outline's pixel count.
    pub outlier_fraction: f64,
    /// Fraction of the outline's length removed, as 1–3 contiguous gaps
    /// (the same stretches in both views of a pair).
    pub missing_fraction: f64,
    /// Fraction of the outline's length each view of a pair loses as one
    /// contiguous stretch of its own, drawn independently per view: an
    /// occlusion that differs between the two views (0: none).
    pub occluded_fraction: f64,
}

impl Damage {
    /// No damage.
    pub const CLEAN: Self = Self {
        jitter_px: 0.0,
        outlier_fraction: 0.0,
        missing_fraction: 0.0,
        occluded_fraction: 0.0,
    };
    /// 0.5 px jitter, 10 % outliers, 10 % missing.
    pub const MODERATE: Self = Self {
        jitter_px: 0.5,
        outlier_fraction: 0.1,
        missing_fraction: 0.1,
        occluded_fraction: 0.0,
    };
    /// 1 px jitter, 30 % outliers, 30 % missing.
    pub const HARSH: Self = Self {
        jitter_px: 1.0,
        outlier_fraction: 0.3,
        missing_fraction: 0.3,
        occluded_fraction: 0.0,
    };
    /// 0.5 px jitter, 10 % outliers, and each view loses its own contiguous
    /// 25 % of the outline (partial views whose occlusions differ).
    pub const OCCLUDED: Self = Self {
        jitter_px: 0.5,
        outlier_fraction: 0.1,
        missing_fraction: 0.0,
        occluded_fraction: 0.25,
    };
    /// The presets with their names (`clean`, `moderate`, `harsh`,
    /// `occluded`).
    pub const PRESETS: [(&'static str, Self); 4] = [
        ("clean", Self::CLEAN),
        ("moderate", Self::MODERATE),
        ("harsh", Self::HARSH),
        ("occluded", Self::OCCLUDED),
    ];
}

/// Largest spacing between sample points along a segment, pixels.
pub const SAMPLE_SPACING_PX: f64 = 0.5;

/// Radius of the disc the unit-disc scene is scaled to by [`render_pair`], as
/// a fraction of `min(W, H)` (before the transform's own margin is taken).
pub const FIT_RADIUS_FRACTION: f64 = 0.45;

/// One rendered image and what went into it.
#[derive(Clone, Debug, PartialEq)]
pub struct Rendered {
    /// The binary image.
    pub image: Image,
    /// Points sampled along the outline (before damage).
    pub samples: usize,
    /// Samples removed by the missing gaps.
    pub missing_samples: usize,
    /// Samples that fell outside the image (after jitter) and were dropped.
    pub clipped_samples: usize,
    /// Distinct pixels set by the outline.
    pub outline_pixels: usize,
    /// Outlier pixels added (distinct, disjoint from the outline):
    /// `round(outlier_fraction · outline_pixels)`, unless the image is full.
    pub outlier_pixels: usize,
}

/// A pair of views of one scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Pair {
    /// The reference view `I1`: the scene scaled by `fit_radius_px`.
    pub i1: Rendered,
    /// The moved view `I2`: the transform applied to `I1`'s scene.
    pub i2: Rendered,
    /// The factor that took the unit-disc scene to pixels.
    pub fit_radius_px: f64,
}

/// Sample points along the segments, spacing ≤ `spacing`, each with its
/// position along the total arc length as a fraction in `[0, 1]`.
fn sample_outline(scene: &Scene, spacing: f64) -> Vec<(Point, f64)> {
    let total = scene.length();
    let mut samples = Vec::new();
    let mut done = 0.0;
    for s in &scene.segments {
        let len = s.length();
        let n = ((len / spacing).ceil() as usize).max(1);
        for i in 0..=n {
            let t = i as f64 / n as f64;
            let arc = if total > 0.0 {
                (done + t * len) / total
            } else {
                0.0
            };
            samples.push((s.a.lerp(s.b, t), arc));
        }
        done += len;
    }
    samples
}

/// 1–3 disjoint gaps covering `fraction` of the arc `[0, 1]` (none for 0):
/// the arc is cut into as many equal slots, one gap of equal length in each.
fn missing_gaps<R: Rng + ?Sized>(rng: &mut R, fraction: f64) -> Vec<(f64, f64)> {
    if fraction <= 0.0 {
        return Vec::new();
    }
    let count = rng.gen_range(1..=3);
    let slot = 1.0 / count as f64;
    let len = fraction.min(1.0) * slot;
    (0..count)
        .map(|i| {
            let start = i as f64 * slot + rng.gen_range(0.0..=slot - len);
            (start, start + len)
        })
        .collect()
}

/// A standard normal deviate (Box–Muller).
fn gaussian<R: Rng + ?Sized>(rng: &mut R) -> f64 {
    let u1 = 1.0 - rng.gen::<f64>(); // (0, 1]
    let u2 = rng.gen::<f64>();
    (-2.0 * u1.ln()).sqrt() * (TAU * u2).cos()
}

/// Rasterizes the samples not in `gaps` with `damage`'s jitter, then adds
/// its outliers.
fn rasterize(
    samples: impl Iterator<Item = (Point, f64)>,
    gaps: &[(f64, f64)],
    damage: &Damage,
    width: usize,
    height: usize,
    jitter_rng: &mut impl Rng,
    outlier_rng: &mut impl Rng,
) -> Rendered {
    let mut image = Image::new(width, height);
    let (mut count, mut missing, mut clipped) = (0, 0, 0);
    for (p, arc) in samples {
        count += 1;
        if gaps.iter().any(|&(g0, g1)| (g0..g1).contains(&arc)) {
            missing += 1;
            continue;
        }
        let (mut x, mut y) = (p.x, p.y);
        if damage.jitter_px > 0.0 {
            x += damage.jitter_px * gaussian(jitter_rng);
            y += damage.jitter_px * gaussian(jitter_rng);
        }
        match image.cell_at(x, y) {
            Some((col, row)) => image.set(col, row, true),
            None => clipped += 1,
        }
    }
    let outline_pixels = image.count();
    let wanted = (damage.outlier_fraction * outline_pixels as f64).round() as usize;
    let mut outlier_pixels = 0;
    if wanted > 0 {
        let free: Vec<usize> = image
            .pixels
            .iter()
            .enumerate()
            .filter(|(_, &p)| !p)
            .map(|(i, _)| i)
            .collect();
        outlier_pixels = wanted.min(free.len());
        for i in index::sample(outlier_rng, free.len(), outlier_pixels) {
            image.pixels[free[i]] = true;
        }
    }
    Rendered {
        image,
        samples: count,
        missing_samples: missing,
        clipped_samples: clipped,
        outline_pixels,
        outlier_pixels,
    }
}

/// Renders a scene given in pixels (centred coordinates) into a
/// `width × height` image with `damage`: samples every segment at spacing
/// ≤ [`SAMPLE_SPACING_PX`], removes the samples in the missing gaps, jitters
/// the rest, sets the pixel containing each (dropping those outside the image)
/// and adds outlier pixels.
pub fn render<R: Rng + ?Sized>(
    scene: &Scene,
    damage: &Damage,
    width: usize,
    height: usize,
    rng: &mut R,
) -> Rendered {
    let gaps = missing_gaps(rng, damage.missing_fraction);
    let samples = sample_outline(scene, SAMPLE_SPACING_PX);
    let mut jitter_rng = ChaCha8Rng::seed_from_u64(rng.gen());
    let mut outlier_rng = ChaCha8Rng::seed_from_u64(rng.gen());
    rasterize(
        samples.into_iter(),
        &gaps,
        damage,
        width,
        height,
        &mut jitter_rng,
        &mut outlier_rng,
    )
}

/// Renders `I1` from `scene` (inside the unit disc) and `I2` from the
/// transformed scene, both `width × height`, deterministically from `seed`.
///
/// Fitting: the scene is scaled by
/// `f = min(0.45·m, (0.5·m − margin − |t|) / max(s, 1))`, `m = min(W, H)`,
/// `margin = 0.5 + 3·jitter_px`, so that both views stay inside the image for
/// any α. `transform` is in pixels: a point `p` of `I1`'s scene is at
/// `s·R(α)·p + t` in `I2`.
///
/// Damage realisation: the same sample points are used for both views (the
/// points of `I2` are exactly the transformed points of `I1`, sampled densely
/// enough for both), and the same stretches of the outline are missing in
/// both (same arc positions); the jitter, the outlier pixels and each view's
/// own occluded stretch ([`Damage::occluded_fraction`]) are drawn
/// independently for each view. With [`Damage::CLEAN`], `I2` is the
/// rasterization of exactly the transformed point set of `I1`.
///
/// # Panics
/// If the translation is too large for the scene to fit (`f ≤ 0`).
pub fn render_pair(
    scene: &Scene,
    transform: &Transform,
    damage: &Damage,
    width: usize,
    height: usize,
    seed: u64,
) -> Pair {
    let m = width.min(height) as f64;
    let margin = 0.5 + 3.0 * damage.jitter_px;
    let fit = (FIT_RADIUS_FRACTION * m)
        .min((0.5 * m - margin - transform.translation_norm()) / transform.scale.max(1.0));
    assert!(
        fit > 0.0,
        "translation too large for a {width}×{height} image"
    );
    let stream = |s: u64| {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(s);
        rng
    };
    let gaps = missing_gaps(&mut stream(0), damage.missing_fraction);
    // Each view's own occlusion: one stretch at a random arc position.
    let occlusion = |s: u64| {
        let mut rng = stream(s);
        let len = damage.occluded_fraction.clamp(0.0, 1.0);
        let mut own = gaps.clone();
        if len > 0.0 {
            let start = rng.gen_range(0.0..1.0);
            // The arc wraps: a stretch past 1 continues from 0.
            own.push((start, (start + len).min(1.0)));
            if start + len > 1.0 {
                own.push((0.0, start + len - 1.0));
            }
        }
        own
    };
    let (gaps1, gaps2) = (occlusion(5), occlusion(6));
    let samples = sample_outline(
        &scene.scaled(fit),
        SAMPLE_SPACING_PX / transform.scale.max(1.0),
    );
    let i1 = rasterize(
        samples.iter().copied(),
        &gaps1,
        damage,
        width,
        height,
        &mut stream(1),
        &mut stream(3),
    );
    let moved = samples.iter().map(|&(p, arc)| (transform.apply(p), arc));
    let i2 = rasterize(
        moved,
        &gaps2,
        damage,
        width,
        height,
        &mut stream(2),
        &mut stream(4),
    );
    Pair {
        i1,
        i2,
        fit_radius_px: fit,
    }
}

/// Rotates an image by exactly `k·2π/N` about its centre (counter-clockwise),
/// moving each occupied pixel centre and setting the pixel containing the
/// result (pixels leaving the image are dropped).
///
/// Exact (a permutation of pixels) for quarter turns of a square image, or
/// half turns of any image, when `N` is a multiple of 4 (resp. 2). Other
/// angles merge and split pixels: the result is not the image of the rotated
/// scene, so use [`render_pair`] to test "rotation by exactly `k` steps".
pub fn rotate_image(image: &Image, k: usize, n_theta: usize) -> Image {
    let (c, s) = cos_sin(k, n_theta);
    let mut out = Image::new(image.width, image.height);
    for (col, row) in image.occupied() {
        let (x, y) = image.coords(col, row);
        // Round to the nearest pixel centre: centres are at x + (W−1)/2 ∈ ℤ.
        let xr = c * x - s * y + (image.width as f64 - 1.0) / 2.0;
        let yr = (image.height as f64 - 1.0) / 2.0 - (s * x + c * y);
        let (col2, row2) = ((xr + 0.5).floor(), (yr + 0.5).floor());
        if (0.0..image.width as f64).contains(&col2) && (0.0..image.height as f64).contains(&row2) {
            out.set(col2 as usize, row2 as usize, true);
        }
    }
    out
}

/// Netpbm bitmap encodings (occupied = 1 = black).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PbmFormat {
    /// `P1`: ASCII, one image row per text line.
    Ascii,
    /// `P4`: binary, rows packed 8 pixels a byte, most significant bit first,
    /// each row padded to a whole byte.
    Binary,
}

/// Encodes `image` as a PBM file.
pub fn to_pbm(image: &Image, format: PbmFormat) -> Vec<u8> {
    let magic = match format {
        PbmFormat::Ascii => "P1",
        PbmFormat::Binary => "P4",
    };
    let mut out = format!("{magic}\n{} {}\n", image.width, image.height).into_bytes();
    for row in image.pixels.chunks(image.width.max(1)).take(image.height) {
        match format {
            PbmFormat::Ascii => {
                let line: Vec<&str> = row.iter().map(|&p| if p { "1" } else { "0" }).collect();
                out.extend_from_slice(line.join(" ").as_bytes());
                out.push(b'\n');
            }
            PbmFormat::Binary => {
                out.extend(row.chunks(8).map(|bits| {
                    bits.iter()
                        .enumerate()
                        .fold(0u8, |byte, (i, &p)| byte | (u8::from(p) << (7 - i)))
                }));
            }
        }
    }
    out
}

/// Writes `image` as a PBM file at `path`.
pub fn write_pbm(image: &Image, path: impl AsRef<Path>, format: PbmFormat) -> io::Result<()> {
    std::fs::write(path, to_pbm(image, format))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rng(seed: u64) -> ChaCha8Rng {
        ChaCha8Rng::seed_from_u64(seed)
    }

    fn half_turn(image: &Image) -> Image {
        let (w, h) = (image.width, image.height);
        let cells: Vec<_> = image
            .occupied()
            .into_iter()
            .map(|(c, r)| (w - 1 - c, h - 1 - r))
            .collect();
        Image::from_cells(w, h, &cells)
    }

    /// Whether every segment has a twin under `p → −p` (either orientation).
    fn is_centrally_symmetric(scene: &Scene) -> bool {
        let close = |p: Point, q: Point| (p.x + q.x).abs() < 1e-12 && (p.y + q.y).abs() < 1e-12;
        scene.segments.iter().all(|s| {
            scene.segments.iter().any(|t| {
                (close(s.a, t.a) && close(s.b, t.b)) || (close(s.a, t.b) && close(s.b, t.a))
            })
        })
    }

    #[test]
    fn generators_stay_in_the_unit_disc() {
        for seed in 0..300 {
            let mut r = rng(seed);
            for kind in SceneKind::ALL {
                let scene = kind.generate(&mut r);
                assert!(!scene.segments.is_empty(), "{kind:?} seed {seed}");
                assert!(
                    scene.radius() <= 1.0,
                    "{kind:?} seed {seed}: radius {}",
                    scene.radius()
                );
                assert!(
                    scene.segments.iter().all(|s| s.length() > 1e-3),
                    "{kind:?} seed {seed}"
                );
                assert_eq!(
                    is_centrally_symmetric(&scene),
                    kind.is_centrally_symmetric(),
                    "{kind:?} seed {seed}"
                );
            }
        }
    }

    #[test]
    fn generators_are_deterministic() {
        for kind in SceneKind::ALL {
            assert_eq!(kind.generate(&mut rng(7)), kind.generate(&mut rng(7)));
            assert_ne!(kind.generate(&mut rng(7)), kind.generate(&mut rng(8)));
        }
    }

    #[test]
    fn random_polygon_is_simple() {
        fn cross(o: Point, a: Point, b: Point) -> f64 {
            (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x)
        }
        for seed in 0..300 {
            let scene = random_polygon(&mut rng(seed));
            let n = scene.segments.len();
            assert!((3..=8).contains(&n));
            for i in 0..n {
                for j in i + 2..n {
                    if i == 0 && j == n - 1 {
                        continue; // adjacent through the closing edge
                    }
                    let (p, q) = (scene.segments[i], scene.segments[j]);
                    let crosses = cross(p.a, p.b, q.a) * cross(p.a, p.b, q.b) < 0.0
                        && cross(q.a, q.b, p.a) * cross(q.a, q.b, p.b) < 0.0;
                    assert!(!crosses, "seed {seed}: edges {i} and {j} cross");
                }
            }
        }
    }

    #[test]
    fn same_seed_gives_the_same_pair() {
        let scene = manhattan_room(&mut rng(3));
        let t = Transform::sample(&mut rng(4), 128, 128, true);
        let a = render_pair(&scene, &t, &Damage::MODERATE, 128, 128, 11);
        let b = render_pair(&scene, &t, &Damage::MODERATE, 128, 128, 11);
        assert_eq!(a, b);
        let c = render_pair(&scene, &t, &Damage::MODERATE, 128, 128, 12);
        assert_ne!(a.i1.image, c.i1.image);
        assert_eq!(
            render(&scene, &Damage::HARSH, 64, 64, &mut rng(5)),
            render(&scene, &Damage::HARSH, 64, 64, &mut rng(5))
        );
    }

    #[test]
    fn transformed_scenes_fit_in_the_image() {
        let mut r = rng(21);
        for _ in 0..200 {
            for (w, h) in [(64, 64), (128, 96), (40, 120)] {
                let kind = SceneKind::ALL[r.gen_range(0..4)];
                let scene = kind.generate(&mut r);
                let t = Transform::sample(&mut r, w, h, true);
                assert!(
                    t.translation_norm() >= 2.0
                        && t.translation_norm() <= 0.1 * w.min(h) as f64 + 1e-9
                );
                assert!((0.9..=1.1).contains(&t.scale));
                let pair = render_pair(&scene, &t, &Damage::CLEAN, w, h, 1);
                assert_eq!(pair.i1.clipped_samples, 0);
                assert_eq!(pair.i2.clipped_samples, 0);
                let moved = scene.scaled(pair.fit_radius_px).transformed(&t);
                for s in &moved.segments {
                    for p in [s.a, s.b] {
                        assert!(
                            p.x.abs() < w as f64 / 2.0 - 0.5 && p.y.abs() < h as f64 / 2.0 - 0.5
                        );
                    }
                }
                assert!(pair.fit_radius_px > 0.3 * w.min(h) as f64);
            }
        }
    }

    #[test]
    fn clean_rendering_has_no_gaps_in_a_line() {
        // A horizontal line 40 px long at y = 0.3: one pixel per column.
        let scene = line(Point::new(-20.0, 0.3), Point::new(19.9, 0.3));
        let out = render(&scene, &Damage::CLEAN, 64, 32, &mut rng(0));
        assert_eq!(out.outline_pixels, 40);
        assert_eq!(out.image.count(), 40);
        assert_eq!(
            (out.missing_samples, out.clipped_samples, out.outlier_pixels),
            (0, 0, 0)
        );
        assert!(out.image.occupied().iter().all(|&(_, row)| row == 15));
    }

    #[test]
    fn damage_levels_produce_the_advertised_counts() {
        let mut r = rng(99);
        for (name, damage) in Damage::PRESETS {
            for _ in 0..40 {
                let scene = random_polygon(&mut r);
                let t = Transform::sample(&mut r, 128, 128, true);
                let pair = render_pair(&scene, &t, &damage, 128, 128, r.gen());
                for view in [&pair.i1, &pair.i2] {
                    let expected =
                        (damage.outlier_fraction * view.outline_pixels as f64).round() as usize;
                    assert_eq!(view.outlier_pixels, expected, "{name}");
                    assert_eq!(
                        view.image.count(),
                        view.outline_pixels + view.outlier_pixels,
                        "{name}"
                    );
                    let missing = view.missing_samples as f64 / view.samples as f64;
                    // Shared gaps and the view's own occlusion may overlap.
                    let lost = damage.missing_fraction + damage.occluded_fraction;
                    assert!(
                        missing <= lost + 0.01
                            && missing
                                >= lost.min(1.0)
                                    - damage.missing_fraction.min(damage.occluded_fraction)
                                    - 0.01,
                        "{name}: missing {missing}"
                    );
                    assert!(view.clipped_samples <= view.samples / 1000, "{name}");
                }
                // Same gaps in both views, unless each view is occluded on
                // its own (then only the shared gaps are common).
                if damage.occluded_fraction == 0.0 {
                    assert_eq!(pair.i1.missing_samples, pair.i2.missing_samples, "{name}");
                }
            }
        }
    }

    #[test]
    fn jitter_is_gaussian_with_the_given_deviation() {
        let mut r = rng(5);
        let v: Vec<f64> = (0..20_000).map(|_| gaussian(&mut r)).collect();
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        let var = v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / v.len() as f64;
        assert!(
            mean.abs() < 0.03 && (var.sqrt() - 1.0).abs() < 0.03,
            "mean {mean}, var {var}"
        );

        // A line on a pixel centre row spreads over the neighbouring rows:
        // P(|N(0, 0.5²)| > 0.5) ≈ 32 % of the points leave the centre row.
        let scene = line(Point::new(-25.0, 0.0), Point::new(25.0, 0.0));
        let damage = Damage {
            jitter_px: 0.5,
            ..Damage::CLEAN
        };
        let out = render(&scene, &damage, 64, 33, &mut rng(1));
        let off = out
            .image
            .occupied()
            .iter()
            .filter(|&&(_, row)| row != 16)
            .count();
        assert!(off > 20, "{off} pixels off the line");
        assert!(out
            .image
            .occupied()
            .iter()
            .all(|&(_, row)| (13..=19).contains(&row)));
    }

    #[test]
    fn clean_centrally_symmetric_scenes_render_symmetric() {
        // Odd sizes only: with an even size the centre line x = 0 (or y = 0)
        // is a pixel border, and a sample exactly on it (the midpoint of a
        // symmetric wall) cannot land in a pixel symmetric to itself.
        let mut r = rng(8);
        for _ in 0..50 {
            let scene = centrally_symmetric(&mut r);
            for (w, h) in [(63, 63), (65, 49)] {
                let pair = render_pair(&scene, &Transform::IDENTITY, &Damage::CLEAN, w, h, 0);
                assert_eq!(half_turn(&pair.i1.image), pair.i1.image);
            }
        }
    }

    #[test]
    fn clean_pair_is_the_transformed_point_set() {
        fn distance(p: Point, s: &Segment) -> f64 {
            let (dx, dy) = (s.b.x - s.a.x, s.b.y - s.a.y);
            let t =
                (((p.x - s.a.x) * dx + (p.y - s.a.y) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
            (p.x - s.a.x - t * dx).hypot(p.y - s.a.y - t * dy)
        }
        let scene = l_shape(1.2, 0.6);
        let t = Transform {
            alpha_rad: 0.3,
            tx: 4.0,
            ty: -1.5,
            scale: 1.05,
        };
        let pair = render_pair(&scene, &t, &Damage::CLEAN, 96, 80, 3);
        let moved = scene.scaled(pair.fit_radius_px).transformed(&t);
        // Every pixel of I2 is crossed by the transformed scene...
        for (col, row) in pair.i2.image.occupied() {
            let (x, y) = pair.i2.image.coords(col, row);
            let d = moved
                .segments
                .iter()
                .map(|s| distance(Point::new(x, y), s))
                .fold(f64::INFINITY, f64::min);
            assert!(
                d <= std::f64::consts::FRAC_1_SQRT_2 + 1e-9,
                "({col}, {row}) at {d} px"
            );
        }
        // ...and it has about as many pixels as a direct rendering of it.
        let direct = render(&moved, &Damage::CLEAN, 96, 80, &mut rng(0));
        let (a, b) = (pair.i2.image.count() as f64, direct.image.count() as f64);
        assert!((a - b).abs() <= 0.05 * b, "{a} vs {b}");
    }

    #[test]
    fn rotate_image_is_exact_for_quarter_turns() {
        let scene = manhattan_room(&mut rng(2));
        let pair = render_pair(&scene, &Transform::IDENTITY, &Damage::MODERATE, 64, 64, 2);
        let img = &pair.i1.image;
        let mut turned = img.clone();
        for _ in 0..4 {
            turned = rotate_image(&turned, 90, 360);
            assert_eq!(turned.count(), img.count());
        }
        assert_eq!(&turned, img);
        assert_eq!(rotate_image(img, 64, 128), half_turn(img));
        let wide = render_pair(&scene, &Transform::IDENTITY, &Damage::CLEAN, 80, 50, 2)
            .i1
            .image;
        assert_eq!(rotate_image(&wide, 180, 360), half_turn(&wide));
        // A generic angle keeps the pixels within the image.
        assert!(rotate_image(img, 37, 360).count() > img.count() / 2);
    }

    #[test]
    fn pbm_encodings() {
        let img = Image::from_cells(10, 2, &[(0, 0), (9, 0), (3, 1)]);
        let p1 = String::from_utf8(to_pbm(&img, PbmFormat::Ascii)).unwrap();
        assert_eq!(p1, "P1\n10 2\n1 0 0 0 0 0 0 0 0 1\n0 0 0 1 0 0 0 0 0 0\n");
        let p4 = to_pbm(&img, PbmFormat::Binary);
        assert_eq!(&p4[..8], b"P4\n10 2\n");
        assert_eq!(&p4[8..], &[0b1000_0000, 0b0100_0000, 0b0001_0000, 0]);
        // Both decode with the `image` crate to the same pixels (black = 1).
        for bytes in [p1.into_bytes(), p4] {
            let decoded = image::load_from_memory_with_format(&bytes, image::ImageFormat::Pnm)
                .unwrap()
                .to_luma8();
            assert_eq!((decoded.width(), decoded.height()), (10, 2));
            for (col, row, px) in decoded.enumerate_pixels() {
                assert_eq!(
                    px.0[0] == 0,
                    img.get(col as usize, row as usize),
                    "({col}, {row})"
                );
            }
        }
        let path = std::env::temp_dir().join(format!("scene-test-{}.pbm", std::process::id()));
        write_pbm(&img, &path, PbmFormat::Binary).unwrap();
        assert_eq!(
            std::fs::read(&path).unwrap(),
            to_pbm(&img, PbmFormat::Binary)
        );
        std::fs::remove_file(&path).unwrap();
    }
}
