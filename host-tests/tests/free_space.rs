//! The free space of laser scans (issue 23): the library's
//! `Raster::free_space` against an `f64` trace written from its definition,
//! and hand-checked scenes where free space decides or must flag.

use std::collections::HashSet;

use host_tests::raycast::{Laser, Wall};
use hough_heading::{
    estimator, grid, stages::BEAM_MAX_MISSING, stages::FREE_MARGIN_CELLS,
    stages::FREE_MARGIN_SHIFT, Angle, Estimate, FreeSpace, Mode, Raster, Scan, SensorOffset,
    Status,
};
use proptest::prelude::*;

mod common;

type G64 = grid!(64, 64);
type G128 = grid!(128, 128);
type E128 = estimator!(128, 128, 360);

/// The cells (col, row) a 64² grid's free space should hold, in `f64` from
/// the definition: each beam with a return (finite, positive, below
/// `max_range`) is followed from the sensor to `FREE_MARGIN_CELLS + L/32`
/// cells short of `L`, the shortest return among itself and its
/// neighbouring returns (over at most `BEAM_MAX_MISSING` beams without one); a point `(x, y)` (cells, centred, y up) is in the cell
/// `(⌊x + 32⌋, ⌊32 − y⌋)`. Points every 1/16 cell.
fn free_reference(scan: &Scan<'_>, cell: f64) -> HashSet<(i64, i64)> {
    let o = scan.offset;
    let valid = |r: f32| r.is_finite() && r > 0.0 && r < scan.max_range;
    let origin = (f64::from(o.x) / cell, f64::from(o.y) / cell);
    let beam = |i: usize| -> Option<(f64, f64, f64)> {
        let r = *scan.ranges.get(i)?;
        if !valid(r) {
            return None;
        }
        let phi = f64::from(scan.angle_min)
            + i as f64 * f64::from(scan.angle_increment)
            + f64::from(o.theta);
        let r = f64::from(r) / cell;
        Some((phi.cos(), phi.sin(), r))
    };
    // The neighbouring returns: the nearest valid beam on each side with at
    // most BEAM_MAX_MISSING beams without a return between, and no return
    // beyond every grid (2¹⁴ cells: `BeamEnd::Far`) between.
    let gap = BEAM_MAX_MISSING as usize;
    let far = |i: usize| {
        scan.ranges
            .get(i)
            .is_some_and(|&r| valid(r) && f64::from(r) / cell >= 16_384.0)
    };
    let neighbour = |i: usize, step: isize| {
        (1..=gap + 1).find_map(|k| {
            let j = i.checked_add_signed(step * k as isize)?;
            if far(j) {
                return Some(None);
            }
            beam(j).map(Some)
        })?
    };
    let mut cells = HashSet::new();
    for i in 0..scan.ranges.len() {
        let Some((c, s, r)) = beam(i) else { continue };
        let reach = [neighbour(i, -1), Some((c, s, r)), neighbour(i, 1)]
            .into_iter()
            .flatten()
            .map(|b| b.2)
            .fold(r, f64::min);
        let free =
            reach - f64::from(FREE_MARGIN_CELLS) - reach / f64::from(1u32 << FREE_MARGIN_SHIFT);
        let mut t = 0.0;
        while t <= free {
            let (x, y) = (origin.0 + t * c, origin.1 + t * s);
            let cell = ((x + 32.0).floor() as i64, (32.0 - y).floor() as i64);
            if (0..64).contains(&cell.0) && (0..64).contains(&cell.1) {
                cells.insert(cell);
            }
            t += 1.0 / 16.0;
        }
    }
    cells
}

fn near(cells: &HashSet<(i64, i64)>, (c, r): (i64, i64)) -> bool {
    (-1..=1).any(|dc| (-1..=1).any(|dr| cells.contains(&(c + dc, r + dr))))
}

fn config() -> ProptestConfig {
    common::proptest_config(0x4652_4545)
}

proptest! {
    #![proptest_config(config())]

    /// Every cell the library frees is within one cell of the `f64` trace,
    /// and every cell of the trace is within one cell of a freed cell (the
    /// library steps at most one cell at a time and rounds its end points to
    /// 2⁻¹⁶ cells).
    #[test]
    fn free_space_matches_an_f64_trace(
        ranges in proptest::collection::vec(
            prop_oneof![8 => 0.05f32..4.0, 1 => Just(f32::NAN), 1 => Just(10.0f32)],
            2..200,
        ),
        angle_min in -3.2f32..3.2,
        increment in -0.05f32..0.05,
        cell in 0.05f32..0.2,
        offset in (-0.3f32..0.3, -0.3f32..0.3, -1.0f32..1.0),
    ) {
        let scan = Scan {
            ranges: &ranges,
            angle_min,
            angle_increment: increment,
            max_range: 10.0,
            offset: SensorOffset { x: offset.0, y: offset.1, theta: offset.2 },
        };
        let raster = Raster::with_cell(cell).unwrap();
        let mut free = G64::new();
        raster.free_space(&scan, &mut free);
        let reference = free_reference(&scan, f64::from(cell));
        let library: HashSet<(i64, i64)> = free
            .occupied_cells()
            .map(|(c, r)| (c as i64, r as i64))
            .collect();
        for &c in &library {
            prop_assert!(near(&reference, c), "freed {c:?} is off the trace");
        }
        for &c in &reference {
            prop_assert!(near(&library, c), "trace cell {c:?} not freed");
        }
    }
}

/// Rasterizes `ranges` of `laser` on a 128² grid of `raster` with its free
/// space.
fn view(laser: &Laser, ranges: &[f32], raster: &Raster) -> (G128, G128) {
    let scan = Scan {
        ranges,
        angle_min: laser.angle_min as f32,
        angle_increment: laser.angle_increment as f32,
        max_range: laser.max_range as f32,
        offset: SensorOffset::default(),
    };
    let (mut grid, mut free) = (G128::new(), G128::new());
    raster.rasterize(&scan, &mut grid);
    raster.free_space(&scan, &mut free);
    (grid, free)
}

/// The estimates of scan 2 against scan 1 with their free space and on the
/// grids alone.
fn estimates(
    laser: &Laser,
    first: &[f32],
    second: &[f32],
    raster: &Raster,
) -> (Estimate, Estimate) {
    let (g1, f1) = view(laser, first, raster);
    let (g2, f2) = view(laser, second, raster);
    let mut e = E128::new(Mode::Improved);
    let reference = e.reference(&g1);
    let free = FreeSpace {
        reference: &f1,
        current: &f2,
    };
    (
        e.estimate_scans(&reference, &g2, &free, None),
        e.estimate(&reference, &g2),
    )
}

/// The scene rotation α for a robot that turned by `dtheta_deg` (α = −dθ).
fn near_alpha(alpha: Angle, dtheta_deg: f64, tolerance_deg: f32) -> bool {
    alpha
        .distance(Angle::from_degrees(-dtheta_deg as f32))
        .to_degrees()
        < tolerance_deg
}

/// A corridor 2 m wide along x, closed at x = 0 and x = 10 m, with a
/// doorway into a side room on one side only (x = 3–4 m, y = +1). The
/// robot looks along it from x = 2 m (facing +x), comes back and looks the
/// other way from x = 7 m (facing −x): a half turn and 5 m. A 180° laser.
///
/// On the grids alone a corridor is nearly its own half turn (and "no turn"
/// with a shift along it even aligns more wall). With the beams, "no turn"
/// puts the end wall scan 2 sees 7 m ahead where scan 1's beams went on to
/// x = 10 m: free space should rule it out, and the half turn win.
///
/// KNOWN LIMIT (issue 23, open): today the search's best translation for
/// the half turn slides along the corridor, the end wall is a small share
/// of the points, and "no turn" comes out confident (`docs/limits.md`,
/// "Corridors revisited from the other end"). Run with `--ignored`.
#[test]
#[ignore = "known limit: a corridor revisited from the other end, docs/limits.md"]
fn a_corridor_revisited_from_the_other_end_is_resolved_by_free_space() {
    let walls: Vec<Wall> = vec![
        ((0.0, -1.0), (10.0, -1.0)),
        ((0.0, 1.0), (3.0, 1.0)),
        ((4.0, 1.0), (10.0, 1.0)),
        ((3.0, 1.0), (3.0, 3.0)),
        ((4.0, 1.0), (4.0, 3.0)),
        ((3.0, 3.0), (4.0, 3.0)),
        ((0.0, -1.0), (0.0, 1.0)),
        ((10.0, -1.0), (10.0, 1.0)),
    ];
    let laser = Laser::centred(180.0, 361, 30.0);
    let first = laser.scan(&walls, (2.0, 0.2, 0.0));
    let second = laser.scan(&walls, (7.0, -0.1, std::f64::consts::PI));
    let raster = Raster::with_radius(9.0, 128).unwrap();
    let (with_beams, grids_only) = estimates(&laser, &first, &second, &raster);
    println!("grids only: {grids_only:?}");
    assert!(
        near_alpha(with_beams.alpha, 180.0, 2.0),
        "with free space: {with_beams:?}"
    );
    assert_eq!(with_beams.status, Status::Confident, "{with_beams:?}");
    // The wrong half scores worse on free space than the right one.
    let runner_up = with_beams.runner_up.expect("a runner-up");
    assert!(
        runner_up.free_space > with_beams.candidates[0].free_space,
        "{with_beams:?}"
    );
}

/// Walls of an L-shaped building with a few pieces of furniture.
fn building() -> Vec<Wall> {
    vec![
        ((0.0, 0.0), (12.0, 0.0)),
        ((12.0, 0.0), (12.0, 5.0)),
        ((12.0, 5.0), (6.0, 5.0)),
        ((6.0, 5.0), (6.0, 10.0)),
        ((6.0, 10.0), (0.0, 10.0)),
        ((0.0, 10.0), (0.0, 0.0)),
        ((2.0, 2.0), (3.0, 2.0)),
        ((3.0, 2.0), (3.0, 2.6)),
        ((9.0, 3.5), (10.5, 3.5)),
        ((1.5, 7.0), (1.5, 8.5)),
        ((4.0, 4.0), (4.4, 4.4)),
    ]
}

/// Half turns between places that share about a third of their view (a
/// 240° laser, 3–6 m apart in an L-shaped building): each answer is right
/// (within 2°) or flagged, never confidently wrong.
#[test]
fn half_turns_with_partial_overlap_are_right_or_flagged() {
    let walls = building();
    let laser = Laser::centred(240.0, 481, 30.0);
    let raster = Raster::with_radius(10.0, 128).unwrap();
    let poses = [
        ((2.0, 4.0, 0.3), (7.0, 2.5, 3.3)),
        ((3.0, 1.2, 0.0), (8.5, 2.0, 3.1)),
        ((1.2, 5.0, 1.4), (3.0, 8.5, -1.8)),
        ((10.0, 1.5, 2.9), (4.5, 2.5, -0.2)),
        ((2.5, 8.0, -1.2), (2.0, 3.0, 1.9)),
        ((5.0, 2.5, 0.1), (9.5, 4.0, 3.0)),
    ];
    let mut right = 0;
    for (a, b) in poses {
        let s1 = laser.scan(&walls, a);
        let s2 = laser.scan(&walls, b);
        let (r, _) = estimates(&laser, &s1, &s2, &raster);
        let dtheta = (b.2 - a.2).to_degrees();
        let ok = near_alpha(r.alpha, dtheta, 2.0);
        right += usize::from(ok);
        assert!(
            ok || r.status != Status::Confident,
            "{a:?} → {b:?} (dθ {dtheta:.1}°): confidently wrong {r:?}"
        );
    }
    println!("{right} of {} right", poses.len());
    assert!(right >= poses.len() / 2, "{right} right");
}

/// A centrally symmetric room (a rectangle with a pillar in each of two
/// opposite corners) seen twice from its centre, the second view turned by
/// 180° (or not: the views are the same either way), each view missing its
/// own stretch of wall (a person standing in front of it). Both 0° and 180°
/// explain the views: flagged, not a coin toss.
#[test]
fn a_symmetric_room_with_each_views_own_occlusion_is_flagged() {
    type G = grid!(128, 128);
    let outline = |skip: &dyn Fn(usize, usize) -> bool| {
        let mut g = G::new();
        let mut set = |c: usize, r: usize| {
            if !skip(c, r) {
                g.set(c, r).unwrap();
            }
        };
        for c in 24..=103 {
            set(c, 34);
            set(c, 93);
        }
        for r in 34..=93 {
            set(24, r);
            set(103, r);
        }
        for k in 0..6 {
            set(30 + k, 40);
            set(97 - k, 87);
        }
        g
    };
    let first = outline(&|c, r| r == 34 && (40..60).contains(&c));
    let second = outline(&|c, r| c == 103 && (50..70).contains(&r));
    for verify in [true, false] {
        let r = E128::new(Mode::Improved)
            .with_verification(verify)
            .estimate_pair(&first, &second);
        assert_ne!(r.status, Status::Confident, "verification {verify}: {r:?}");
    }
}

/// The free-space share of a candidate from its definition, in `f64`: the
/// decision samples (up to `4 · points_for(W, H)` occupied cells of each
/// view, spread evenly in raster order), each mapped by the candidate's
/// pose into the other view (`p₁ = R(−α)·p₂ + u` forward, `p₂ = R(α)·(p₁ −
/// u)` backward, `u = −R(−α)·t`, the nearest cell), a violation when it
/// scores 0 there (no occupied cell within one) and the cell is free; the
/// mean of the two directions' shares.
fn free_share_reference(views: [&G128; 2], free: [&G128; 2], alpha: f64, t: (f64, f64)) -> f64 {
    use host_tests::reference::Image;
    use host_tests::verify_reference::{points_for, sample_at_most, ScoreMap};
    let image = |g: &G128| {
        let mut i = Image::new(128, 128);
        for (c, r) in g.occupied_cells() {
            i.set(c, r, true);
        }
        i
    };
    let (images, half) = (views.map(image), 63.5);
    let (s, c) = alpha.sin_cos();
    // u = −R(−α)·t, a whole number of cells for a rival (its search shift).
    let u = (
        (-(c * t.0 + s * t.1)).round(),
        (-(c * t.1 - s * t.0)).round(),
    );
    let share = |from: usize, map: &dyn Fn(f64, f64) -> (f64, f64)| {
        let to = 1 - from;
        let scores = ScoreMap::new(&images[to]);
        let points = sample_at_most(&images[from], 4 * points_for(128, 128));
        let violations = points
            .iter()
            .filter(|&&(col, row)| {
                let (x, y) = map(col as f64 - half, half - row as f64);
                let (c1, r1) = (
                    (x + half + 0.5).floor() as i64,
                    (half - y + 0.5).floor() as i64,
                );
                scores.score(c1, r1) == 0
                    && c1 >= 0
                    && r1 >= 0
                    && free[to].get(c1 as usize, r1 as usize)
            })
            .count();
        violations as f64 / points.len().max(1) as f64
    };
    let forward = share(1, &|x, y| (c * x + s * y + u.0, c * y - s * x + u.1));
    let backward = share(0, &|x, y| {
        let (dx, dy) = (x - u.0, y - u.1);
        (c * dx - s * dy, s * dx + c * dy)
    });
    (forward + backward) / 2.0
}

/// Every rival's reported free-space share (judged at its search pose:
/// whole θ steps and cells) equals the `f64` definition within a few points
/// of each sample, on ray-cast scans in the L-shaped building.
#[test]
fn free_space_shares_match_their_definition() {
    let walls = building();
    let laser = Laser::centred(240.0, 481, 30.0);
    let raster = Raster::with_radius(10.0, 128).unwrap();
    let mut checked = 0;
    let mut nonzero = 0;
    for (a, b) in [
        ((2.0, 4.0, 0.3), (7.0, 2.5, 3.3)),
        ((3.0, 1.2, 0.0), (8.5, 2.0, 3.1)),
        ((1.2, 5.0, 1.4), (3.0, 8.5, -1.8)),
        ((10.0, 1.5, 2.9), (4.5, 2.5, -0.2)),
        ((2.5, 8.0, -1.2), (2.0, 3.0, 1.9)),
        ((5.0, 2.5, 0.1), (9.5, 4.0, 3.0)),
        ((3.0, 3.0, 0.0), (3.5, 3.2, 0.4)),
        ((8.0, 2.0, 1.0), (4.0, 7.0, 2.0)),
    ] {
        let (g1, f1) = view(&laser, &laser.scan(&walls, a), &raster);
        let (g2, f2) = view(&laser, &laser.scan(&walls, b), &raster);
        let mut e = E128::new(Mode::Improved);
        let reference = e.reference(&g1);
        let free = FreeSpace {
            reference: &f1,
            current: &f2,
        };
        let r = e.estimate_scans(&reference, &g2, &free, None);
        for c in r.candidates.iter().skip(1).chain(&r.runner_up) {
            let (Some(share), Some((tx, ty))) = (c.free_space, c.translation) else {
                panic!("a verified candidate on scans: {c:?}");
            };
            let alpha = f64::from(c.alpha.0) / 4_294_967_296.0 * std::f64::consts::TAU;
            let expected =
                free_share_reference([&g1, &g2], [&f1, &f2], alpha, (tx.to_num(), ty.to_num()));
            let got = share.to_num::<f64>();
            assert!(
                (got - expected).abs() <= 0.02,
                "{a:?} → {b:?}: {got} against {expected} for {c:?}"
            );
            checked += 1;
            nonzero += usize::from(expected > 0.0);
        }
    }
    println!("{checked} candidates checked, {nonzero} with violations");
    assert!(checked >= 8 && nonzero >= 3, "{checked} / {nonzero}");
}
