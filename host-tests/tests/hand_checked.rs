//! Hand-checked cases on a 64×64 grid with `N_THETA` = 360 (θ_k = k°).
//!
//! Conventions used in the derivations: cell `(col, row)` is at
//! `x = col − 31.5`, `y = 31.5 − row`; ρ = x cos θ + y sin θ is exact at 0°
//! and 90° (the Q15 tables hold exactly 0 and ±32768 there); a vote goes to
//! bin `b = ⌊ρ + ½⌋ + RHO/2` (round half up) with `RHO = rho_bins(64, 64) =
//! 128`, so bin `b` holds `ρ = b − 64`. Only θ ∈ [0°, 180°) is voted; the
//! other half is the mirror `A(θ + 180°, b) = A(θ, 128 − b)`.

use host_tests::eval::{grid_from_image, image_from_grid};
use host_tests::reference::{self as fref};
use host_tests::scene::rotate_image;
use hough_heading::{
    estimator, grid, max_votes_per_bin, rho_bins, Accumulator, Angle, Estimator, Mode, PeakKind,
    Signature, Status,
};

type G = grid!(64, 64);
type E = estimator!(64, 64, 360);
const HALF: usize = 180;
const RHO: usize = rho_bins(64, 64);
type A = Accumulator<HALF, RHO>;

fn grid(cells: impl IntoIterator<Item = (usize, usize)>) -> G {
    let mut g = G::new();
    g.set_cells(cells).expect("cells inside the grid");
    g
}

fn signature(g: &G, kind: PeakKind) -> Signature<HALF> {
    let mut columns = [[0u16; RHO]; 2];
    Signature::stream::<64, 64, { hough_heading::row_words(64) }, 360, RHO>(g, kind, &mut columns)
}

fn votes(g: &G) -> Box<A> {
    Box::new(A::vote::<64, 64, { hough_heading::row_words(64) }, 360>(g))
}

fn degrees(a: Angle) -> f64 {
    f64::from(a.0) * 360.0 / 4_294_967_296.0
}

fn near(a: Angle, deg: f64) -> bool {
    let d = (degrees(a) - deg).rem_euclid(360.0);
    d.min(360.0 - d) < 1e-6
}

/// A horizontal line of n = 40 pixels: row 20, cols 12..=51.
///
/// * θ = 90°: ρ = y = 31.5 − 20 = 11.5 for every pixel, rounded up to 12
///   (bin 76): `A(90°, 76) = 40`, so `D(90°) = 40`, in one bin, and `S(90°) = 0`
///   (`w = 0`). The mirror θ = 270° holds the 40 votes in bin 128 − 76 = 52.
/// * θ = 89° or 91°: ρ = 11.5·cos 1° ∓ x·sin 1° spans 11.498 ± 0.340, across
///   the rounding edge 11.5, so the line splits over bins 11 and 12: D < 40.
///   Farther from 90° the spread only grows: `D(θ) < 40` for every θ ≠ 90°.
/// * θ = 0°: ρ = x = col − 31.5, 40 distinct bins of 1 vote: `D(0°) = 1`,
///   two-bin `D(0°) = 2`, and `S(0°) = 0` (uniform over a symmetric range).
/// * The line is its own half turn about its midpoint: against itself the
///   estimate is α = 0 or 180°, `AmbiguousDirection`, both candidates present.
#[test]
fn single_line() {
    let g = grid((12..=51).map(|c| (c, 20)));
    let single = signature(&g, PeakKind::SingleBin);
    assert_eq!(single.peak(90), 40);
    assert_eq!(single.peak(270), 40);
    for k in (0..360).filter(|&k| k != 90 && k != 270) {
        assert!(single.peak(k) < 40, "D({k}°) = {}", single.peak(k));
    }
    assert_eq!(single.peak(89).max(single.peak(91)), single.peak(89));
    assert!(single.peak(89) >= 20, "two bins at most at 89°");
    assert_eq!(single.peak(0), 1);
    assert_eq!(signature(&g, PeakKind::TwoBin).peak(0), 2);
    assert_eq!((single.asymmetry(90), single.asymmetry(0)), (0, 0));
    let acc = votes(&g);
    assert_eq!(acc.get(90, 76), 40);
    assert_eq!(acc.get(270, 52), 40);

    for mode in [Mode::Paper, Mode::Improved] {
        let r = E::new(mode).estimate_pair(&g, &g);
        assert!(
            near(r.alpha, 0.0) || near(r.alpha, 180.0),
            "{mode:?}: {r:?}"
        );
        if mode == Mode::Improved {
            assert_eq!(r.status, Status::AmbiguousDirection, "{r:?}");
            assert!(r.candidates.iter().any(|c| near(c.alpha, 0.0)));
            assert!(r.candidates.iter().any(|c| near(c.alpha, 180.0)));
        }
    }
}

/// The outline of a 20×20 square, cells 22..=41 in both directions (76
/// pixels), centred on the image centre.
///
/// * θ = 0°: the left side (x = −9.5) puts its 20 pixels in bin 55 (ρ = −9),
///   the right side (x = 9.5) its 20 in bin 74 (ρ = 10); each column between
///   holds 2 (top and bottom): `D(0°) = 20`, two-bin `D(0°) = 20 + 2 = 22`.
///   θ = 90° likewise with rows: `D(90°) = 20`.
/// * θ = 45°: consecutive pixels of a side are 1/√2 apart in ρ, so a bin holds
///   at most 2 of each side: `D(45°) ≤ 8`.
/// * A quarter turn about the centre maps the outline onto itself with the
///   same integer ρ in the shifted column, so `D(θ + 90°) = D(θ)`: the
///   correlation has two equal peaks, 0° and 90° (`rival = correlation`, the
///   axis ambiguity), and the square is centrally symmetric (direct and
///   mirrored profiles match equally, the direction ambiguity). The library
///   reports the direction ambiguity first, so the status is
///   `AmbiguousDirection`, and all four quarter turns are candidates.
#[test]
fn square() {
    let mut cells = Vec::new();
    for i in 22..=41 {
        cells.extend([(i, 22), (i, 41), (22, i), (41, i)]);
    }
    let g = grid(cells);
    assert_eq!(g.occupied(), 76);
    let single = signature(&g, PeakKind::SingleBin);
    assert_eq!((single.peak(0), single.peak(90)), (20, 20));
    assert!(single.peak(45) <= 8, "D(45°) = {}", single.peak(45));
    for k in 0..90 {
        assert_eq!(
            single.peak(k),
            single.peak(k + 90),
            "quarter-turn symmetry at {k}°"
        );
    }
    assert_eq!(signature(&g, PeakKind::TwoBin).peak(0), 22);
    let acc = votes(&g);
    assert_eq!(
        (acc.get(0, 55), acc.get(0, 74), acc.get(0, 60)),
        (20, 20, 2)
    );

    for mode in [Mode::Paper, Mode::Improved] {
        let r = E::new(mode).estimate_pair(&g, &g);
        assert!(r.status != Status::Confident, "{mode:?}: {r:?}");
        assert_eq!(
            r.rival, r.correlation,
            "{mode:?}: equal peaks at 0° and 90°"
        );
        if mode == Mode::Improved {
            assert_eq!(r.status, Status::AmbiguousDirection);
            for quarter in [0.0, 90.0, 180.0, 270.0] {
                assert!(
                    r.candidates.iter().any(|c| near(c.alpha, quarter)),
                    "{quarter}° missing from {:?}",
                    r.candidates
                );
            }
        }
    }
}

/// A "T": a bar of 30 pixels (row 20, cols 17..=46) and a stem of 30
/// (col 32, rows 21..=50): 60 pixels.
///
/// * θ = 0°: the stem (x = 0.5) puts 30 votes in bin 65, plus the bar's
///   pixel at col 32: `D(0°) = 31`. θ = 90°: the bar (y = 11.5) puts 30 in
///   bin 76; the stem starts at y = 10.5 (bin 75): `D(90°) = 30`.
/// * Two equal perpendicular segments: `D(θ + 90°) ≈ D(θ)`, so the
///   correlation of the T with itself has a rival peak at 90° nearly as high
///   as the true one at 0° — the axis ambiguity of a Manhattan room — while
///   the T is not centrally symmetric: flagged (see the test), with α = 0°
///   the best candidate and 90° (or 270°) among the others.
#[test]
fn t_shape_is_ambiguous_axis() {
    let mut cells: Vec<(usize, usize)> = (17..=46).map(|c| (c, 20)).collect();
    cells.extend((21..=50).map(|r| (32, r)));
    let g = grid(cells);
    assert_eq!(g.occupied(), 60);
    let single = signature(&g, PeakKind::SingleBin);
    assert_eq!((single.peak(0), single.peak(90)), (31, 30));
    let r = E::new(Mode::Improved).estimate_pair(&g, &g);
    // The T's columns are also nearly mirror-symmetric (direct 1.0 against
    // flipped ≈ 0.93, below the 0.10 direction margin), and the direction
    // flag takes precedence: either flag is honest, `Confident` is not.
    assert!(
        matches!(r.status, Status::AmbiguousAxis | Status::AmbiguousDirection),
        "{r:?}"
    );
    assert!(near(r.alpha, 0.0), "{r:?}");
    assert!(r.rival.to_num::<f64>() >= 0.9 * r.correlation.to_num::<f64>());
    assert!(r
        .candidates
        .iter()
        .any(|c| near(c.alpha, 90.0) || near(c.alpha, 270.0)));
}

/// An "L": a horizontal arm of 30 pixels (row 40, cols 16..=45) and a
/// vertical arm of 15 (col 16, rows 26..=40, sharing the corner): 44 pixels.
///
/// * θ = 0°: the vertical arm (x = −15.5) puts 15 votes in bin 49; the
///   horizontal arm adds 1 vote in each of bins 50..=78. `D(0°) = 15`.
///   Paper's asymmetry: `l = 49`, `u = 78`, `w = 29`, `m = 63.5`,
///   `S = [15·(−14.5) + Σ_{j=1}^{29} (j − 14.5)] / 29 = (−217.5 + 14.5)/29 = −7`
///   exactly, i.e. −112 in Q4; `S(180°) = +112`.
/// * θ = 90°: the horizontal arm (y = −8.5) puts 30 votes in bin 56; the
///   vertical arm 1 vote in each of bins 57..=70. `D(90°) = 30`;
///   `l = 56`, `u = 70`, `w = 14`, `m = 63`,
///   `S = [30·(−7) + Σ_{j=−6}^{7} j] / 14 = −203/14 = −14.5`: −232 in Q4.
/// * No symmetry: against itself α = 0 exactly, against its quarter turn
///   (a permutation of pixels) α = 90° exactly, `Confident`, in both modes.
#[test]
fn l_shape() {
    let mut cells: Vec<(usize, usize)> = (16..=45).map(|c| (c, 40)).collect();
    cells.extend((26..40).map(|r| (16, r)));
    let g = grid(cells);
    assert_eq!(g.occupied(), 44);
    let single = signature(&g, PeakKind::SingleBin);
    assert_eq!((single.peak(0), single.peak(90)), (15, 30));
    assert_eq!(single.asymmetry(0), -112);
    assert_eq!(single.asymmetry(180), 112);
    assert_eq!(single.asymmetry(90), -232);
    let acc = votes(&g);
    assert_eq!((acc.get(0, 49), acc.get(0, 50), acc.get(0, 78)), (15, 1, 1));
    assert_eq!(acc.get(90, 56), 30);
    // The float reference agrees: S(0°) = −7 votes.
    let image = image_from_grid(&g);
    let s = fref::Accumulator::build(&image, 360).asymmetry();
    assert!((s[0] + 7.0).abs() < 1e-12 && (s[90] + 14.5).abs() < 1e-12);

    let turned: G = grid_from_image(&rotate_image(&image, 90, 360));
    for mode in [Mode::Paper, Mode::Improved] {
        let mut e: Estimator<64, 64, 2, 360, HALF, RHO> = E::new(mode);
        let same = e.estimate_pair(&g, &g);
        assert!(near(same.alpha, 0.0), "{mode:?}: {same:?}");
        assert_eq!(same.status, Status::Confident, "{mode:?}: {same:?}");
        let quarter = e.estimate_pair(&g, &turned);
        assert!(near(quarter.alpha, 90.0), "{mode:?}: {quarter:?}");
        assert_eq!(quarter.status, Status::Confident, "{mode:?}: {quarter:?}");
    }
}

/// An empty grid: every column is empty, `D ≡ 0` and `S ≡ 0`; no angle —
/// `NoStructure`, no candidates, no translation — whichever image is empty.
#[test]
fn empty_grid() {
    let empty = G::new();
    let line = grid((12..=51).map(|c| (c, 20)));
    for kind in [PeakKind::SingleBin, PeakKind::TwoBin] {
        let s = signature(&empty, kind);
        assert!(s.peaks().iter().all(|&d| d == 0));
        assert!(s.asymmetries().iter().all(|&v| v == 0));
    }
    for mode in [Mode::Paper, Mode::Improved] {
        for (a, b) in [(&empty, &empty), (&empty, &line), (&line, &empty)] {
            let r = E::new(mode).estimate_pair(a, b);
            assert_eq!(r.status, Status::NoStructure);
            assert_eq!(r.alpha, Angle::ZERO);
            assert!(r.candidates.is_empty() && r.translation.is_none());
        }
    }
}

/// A fully occupied grid (4096 cells).
///
/// * Every column holds one vote per cell: Σ_b A(θ, b) = 4096.
/// * θ = 0°: a bin is one column of 64 cells: `D(0°) = 64`, two-bin 128;
///   θ = 90° likewise.
/// * No bin exceeds the compile-time bound `max_votes_per_bin(64, 64) = 128`
///   (a unit strip meets each of the 64 columns in at most 2 cells).
/// * Invariant under quarter and half turns: no panic, and the estimate is
///   flagged (never `Confident`).
#[test]
fn full_grid() {
    let g = grid((0..64).flat_map(|r| (0..64).map(move |c| (c, r))));
    assert_eq!(g.occupied(), 4096);
    let acc = votes(&g);
    for k in 0..HALF {
        let total: u32 = acc
            .half_column(k)
            .unwrap()
            .iter()
            .map(|&v| u32::from(v))
            .sum();
        assert_eq!(total, 4096, "column {k}");
    }
    let single = signature(&g, PeakKind::SingleBin);
    let two = signature(&g, PeakKind::TwoBin);
    assert_eq!((single.peak(0), single.peak(90)), (64, 64));
    assert_eq!((two.peak(0), two.peak(90)), (128, 128));
    assert!(single
        .peaks()
        .iter()
        .all(|&d| usize::from(d) <= max_votes_per_bin(64, 64)));
    for mode in [Mode::Paper, Mode::Improved] {
        let r = E::new(mode).estimate_pair(&g, &g);
        assert!(r.status != Status::Confident, "{mode:?}: {r:?}");
    }
}
