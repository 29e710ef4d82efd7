//! The scan rasterizer's fixed point (issue 16 item 2): beam end points
//! against an `f64` computation within the documented bound, and the
//! `ScanStats` categories on hostile readings and geometry.

mod common;

use hough_heading::stages::{BeamEnd, ScanBeams, BEAM_FAR_CELLS, BEAM_NEAR_CELLS};
use hough_heading::{grid, Raster, Scan, ScanStats, SensorOffset};
use proptest::prelude::*;

/// The bound of `src/scan/beam.rs` (cells, per coordinate) for a range of
/// `r_c` cells.
fn bound(r_c: f64) -> f64 {
    r_c * 2.3e-5 + 1.0 / 8_192.0
}

/// Beam `i`'s exact end point in cells, `f64`.
fn exact(scan: &Scan<'_>, cell: f32, i: usize, r: f32) -> (f64, f64) {
    let phi = f64::from(scan.angle_min)
        + f64::from(scan.offset.theta)
        + i as f64 * f64::from(scan.angle_increment);
    let (s, c) = phi.sin_cos();
    let (r, cell) = (f64::from(r), f64::from(cell));
    (
        (f64::from(scan.offset.x) + r * c) / cell,
        (f64::from(scan.offset.y) + r * s) / cell,
    )
}

fn check_scan(scan: &Scan<'_>, cell: f32) -> Result<f64, TestCaseError> {
    let raster = Raster::with_cell(cell).unwrap();
    let beams = ScanBeams::new(scan, &raster);
    let mut worst = 0.0f64;
    for (i, &r) in scan.ranges.iter().enumerate() {
        let (xe, ye) = exact(scan, cell, i, r);
        let r_c = f64::from(r) / f64::from(cell);
        match beams.end(i, r) {
            BeamEnd::Near { x, y } => {
                let (dx, dy) = (
                    (f64::from(x) / 65_536.0 - xe).abs(),
                    (f64::from(y) / 65_536.0 - ye).abs(),
                );
                let limit = BEAM_NEAR_CELLS << 16;
                prop_assert!(x.abs() < limit && y.abs() < limit);
                prop_assert!(
                    dx <= bound(r_c) && dy <= bound(r_c),
                    "beam {i}, r {r}: ({x}, {y}) vs ({xe}, {ye}): {dx} {dy} > {}",
                    bound(r_c)
                );
                worst = worst.max(dx.max(dy) / bound(r_c));
            }
            BeamEnd::Far => {
                prop_assert!(
                    xe.hypot(ye) >= f64::from(BEAM_FAR_CELLS) - 1.0,
                    "beam {i}, r {r}: far but at ({xe}, {ye})"
                );
            }
            other => prop_assert!(false, "beam {i}, r {r}: valid reading dropped as {other:?}"),
        }
    }
    Ok(worst)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..common::proptest_config(0x5343_414e) })]

    /// Random scans (any orientation, offsets near and far, ranges from
    /// millimetres to kilometres, cells from 5 mm to 1 m): every end point
    /// within the bound of the exact one.
    #[test]
    fn end_points_within_the_bound(
        ranges in proptest::collection::vec(
            prop_oneof![4 => 0.01f32..60.0, 1 => 1e-6f32..1e4],
            1..400,
        ),
        angle_min in prop_oneof![4 => -7.0f32..7.0, 1 => -1e4f32..1e4],
        increment in prop_oneof![4 => -0.05f32..0.05, 1 => -10.0f32..10.0],
        offset in prop_oneof![
            4 => (-2.0f32..2.0, -2.0f32..2.0, -7.0f32..7.0),
            1 => (-500.0f32..500.0, -500.0f32..500.0, -7.0f32..7.0),
        ],
        cell in 0.005f32..1.0,
    ) {
        let scan = Scan {
            ranges: &ranges,
            angle_min,
            angle_increment: increment,
            max_range: f32::INFINITY,
            offset: SensorOffset { x: offset.0, y: offset.1, theta: offset.2 },
        };
        check_scan(&scan, cell)?;
    }
}

/// A 360-beam scan of a room at the tool's scale: the end points are within
/// a hundredth of the bound's slack, and the rasterized grid is the one the
/// exact end points give except where a point lies within the bound of a
/// cell border.
#[test]
fn room_scan_matches_the_exact_cells() {
    let ranges: Vec<f32> = (0..360)
        .map(|i| 3.0 + 2.0 * ((i as f32) * 0.05).sin())
        .collect();
    let scan = Scan {
        ranges: &ranges,
        angle_min: -std::f32::consts::PI,
        angle_increment: std::f32::consts::TAU / 360.0,
        max_range: 30.0,
        offset: SensorOffset {
            x: 0.1,
            y: -0.05,
            theta: 0.3,
        },
    };
    let cell = 0.04;
    check_scan(&scan, cell).unwrap();
    let mut g = <grid!(256, 256)>::new();
    let stats = Raster::with_cell(cell).unwrap().rasterize(&scan, &mut g);
    assert_eq!(stats.kept, 360);
    let mut differ = 0;
    for (i, &r) in ranges.iter().enumerate() {
        let (x, y) = exact(&scan, cell, i, r);
        let (col, row) = ((x + 128.0).floor(), (128.0 - y).floor());
        if !g.get(col as usize, row as usize) {
            // Only a point within the bound of a border may change cell.
            let near_border = |v: f64| (v - v.round()).abs() <= bound(f64::from(r) / 0.04);
            assert!(near_border(x + 128.0) || near_border(128.0 - y), "beam {i}");
            differ += 1;
        }
    }
    assert!(differ <= 2, "{differ}");
}

/// Each reading's category as `ScanStats` defines it (the float rasterizer's
/// order of tests): NaN/∞, then `r ≥ max_range`, then `r ≤ 0`, then a
/// non-finite geometry (or NaN `max_range`).
#[derive(Debug, PartialEq)]
enum Category {
    Valid,
    NoReturn,
    NotFinite,
    NonPositive,
}

fn category(r: f32, max_range: f32, geometry_finite: bool) -> Category {
    if r.is_nan() || r.is_infinite() {
        Category::NotFinite
    } else if r >= max_range {
        Category::NoReturn
    } else if r <= 0.0 {
        Category::NonPositive
    } else if !geometry_finite || max_range.is_nan() {
        Category::NotFinite
    } else {
        Category::Valid
    }
}

#[test]
fn hostile_values_keep_their_categories() {
    let readings = [
        f32::NAN,
        -f32::NAN,
        f32::from_bits(0x7f80_0001),
        f32::INFINITY,
        f32::NEG_INFINITY,
        0.0,
        -0.0,
        f32::from_bits(1),
        -f32::from_bits(1),
        f32::MIN_POSITIVE,
        f32::MIN_POSITIVE / 4.0,
        1.0,
        -1.0,
        5.0,
        29.999_998,
        30.0,
        f32::MAX,
        f32::MIN,
    ];
    let max_ranges = [
        30.0,
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        0.0,
        -0.0,
        -5.0,
        f32::MAX,
        f32::from_bits(1),
    ];
    let base = Scan {
        ranges: &readings,
        angle_min: 0.0,
        angle_increment: 0.01,
        max_range: 30.0,
        offset: SensorOffset::default(),
    };
    let geometries = [
        (base, true),
        (
            Scan {
                angle_increment: f32::NAN,
                ..base
            },
            false,
        ),
        (
            Scan {
                angle_min: f32::INFINITY,
                ..base
            },
            false,
        ),
        (
            Scan {
                offset: SensorOffset {
                    x: f32::NAN,
                    ..SensorOffset::default()
                },
                ..base
            },
            false,
        ),
        (
            Scan {
                offset: SensorOffset {
                    theta: f32::NEG_INFINITY,
                    ..SensorOffset::default()
                },
                ..base
            },
            false,
        ),
        // Huge but finite angles: reduced modulo one turn, the beams kept.
        (
            Scan {
                angle_min: 1e30,
                angle_increment: -3e37,
                ..base
            },
            true,
        ),
        (
            Scan {
                angle_min: f32::MAX,
                offset: SensorOffset {
                    x: f32::MAX,
                    y: -f32::MAX,
                    theta: f32::MAX,
                },
                ..base
            },
            true,
        ),
    ];
    for raster in [
        Raster::with_cell(0.1).unwrap(),
        Raster::with_cell(0.1)
            .unwrap()
            .connect(0.3)
            .clip_to_disc(true),
        Raster::with_cell(f32::from_bits(1)).unwrap().connect(1.0),
        Raster::with_cell(f32::MAX).unwrap(),
    ] {
        for (scan, finite) in geometries {
            for max_range in max_ranges {
                let scan = Scan { max_range, ..scan };
                let mut expected = ScanStats {
                    beams: readings.len() as u32,
                    ..ScanStats::default()
                };
                let mut valid = 0;
                for &r in &readings {
                    match category(r, max_range, finite) {
                        Category::Valid => valid += 1,
                        Category::NoReturn => expected.no_return += 1,
                        Category::NotFinite => expected.not_finite += 1,
                        Category::NonPositive => expected.non_positive += 1,
                    }
                }
                let mut g = <grid!(64, 64)>::new();
                let stats = raster.rasterize(&scan, &mut g);
                let what = format!("{raster:?} {scan:?}");
                assert_eq!(stats.no_return, expected.no_return, "{what}");
                assert_eq!(stats.not_finite, expected.not_finite, "{what}");
                assert_eq!(stats.non_positive, expected.non_positive, "{what}");
                assert_eq!(stats.kept + stats.outside, valid, "{what}");
                assert!(g.occupied() <= stats.kept + stats.segment_points);
                // ScanBeams agrees with the stats, beam by beam.
                let beams = ScanBeams::new(&scan, &raster);
                for (i, &r) in readings.iter().enumerate() {
                    let got = match beams.end(i, r) {
                        BeamEnd::Near { .. } | BeamEnd::Far => Category::Valid,
                        BeamEnd::NoReturn => Category::NoReturn,
                        BeamEnd::NotFinite => Category::NotFinite,
                        BeamEnd::NonPositive => Category::NonPositive,
                    };
                    assert_eq!(got, category(r, max_range, finite), "{r} {what}");
                }
            }
        }
    }
}

/// A subnormal reading with a 0.1 m cell lands in the centre cell; a
/// reading of `f32::MAX` is far outside.
#[test]
fn extreme_ranges_land_where_they_should() {
    let readings = [f32::from_bits(1), f32::MAX, 1.0];
    let scan = Scan {
        ranges: &readings,
        angle_min: 0.0,
        angle_increment: 0.0,
        max_range: f32::INFINITY,
        offset: SensorOffset::default(),
    };
    let mut g = <grid!(64, 64)>::new();
    let stats = Raster::with_cell(0.1).unwrap().rasterize(&scan, &mut g);
    assert_eq!((stats.kept, stats.outside), (2, 1));
    assert!(g.get(32, 32));
    assert!(g.get(42, 32));
}
