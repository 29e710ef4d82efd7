//! Link-time panic-freedom check of `hough-heading` (issue 7) and of the
//! lidar drivers `hough-lidar` (issue 25: `entry_lidar*`).
//!
//! This bare-metal binary calls every public entry point of the library with
//! inputs the optimiser cannot see (`core::hint::black_box`), for four
//! estimator configurations, including the verification by alignment
//! (estimates with it on and off, `Reference::grid`, `Grid::occupied_cells`,
//! the pyramid sizes) and stored references of the previous format (version
//! 2, which `Reference::from_bytes` must refuse with a typed error). Every
//! `pub fn` of the library (root, `config`, `stages`, and their methods) is
//! called: `vote_column_pair`, `Signature::stream`/`restream`,
//! `Reference::prepare` (`prepare_in_place`, `empty` and
//! `Estimator::reference_in_place` for issue 40), `TrigTable::cos`/`sin`, `ScaleRange::min`/`max`,
//! `config::align_points` and `icp_points` were added for issue 14 item 2
//! (checked by name against `grep 'pub (const )?fn' src`). Each group of calls sits in its own
//! `#[inline(never)]` function named `entry_*`, so a remaining panic path can
//! be attributed to the entry point that reaches it.
//!
//! Built in release (LTO, one codegen unit, no overflow checks: the profile a
//! firmware ships with), the binary contains a panic path only if some
//! library code can still reach the panic handler. `tools/no-panic-check.sh`
//! checks that in two ways:
//!
//! * with `--features strict` the panic handler calls a symbol that is
//!   defined nowhere, so the link fails unless every panic path was removed
//!   (the `panic-never` trick; needs no other tool);
//! * without it, the binary links and the script walks its call graph
//!   (`llvm-objdump`) to list each call into a panicking function from
//!   library code, with the source line of the call (`llvm-addr2line`).
//!
//! The binary is never run: there is no vector table or memory layout.
#![no_std]
#![no_main]
// The strict handler needs an `extern` call; the library itself forbids
// unsafe code, this checker does not ship.
#![allow(unsafe_code)]

use core::future::Future;
use core::hint::black_box;
use core::pin::pin;
use core::task::{Context, Poll, Waker};
use hough_heading::{
    config::max_votes_per_bin, config::pyramid_levels, config::pyramid_words,
    config::recommended_n_theta, config::rho_bins, config::row_words, config::ALIGN_POINTS,
    stages::fit_translation, stages::match_profile, stages::match_profile_near,
    stages::paper_asymmetry, stages::range_percentile, stages::vote_column,
    stages::vote_column_split, stages::Accumulator, stages::Column, stages::ColumnShift,
    stages::ColumnStats, stages::Correlation, stages::Peak, stages::PeakKind, stages::ScanBeams,
    stages::Shift, stages::Signature, stages::REFERENCE_FORMAT, stages::RUNNERS_UP, Angle, Error,
    Estimate, Estimator, FreeSpace, Grid, Mode, Pose, Prior, Raster, Reference, ScaleRange, Scan,
    ScanReference, ScanStats, Score, SensorOffset, Thresholds,
};
use hough_lidar::ydlidar::YdlidarLayout;
use hough_lidar::{
    Assembler, Layout, Ld06, Lidar, Parser, Point, Revolution, Rplidar, Xv11, Ydlidar,
};

/// Any value of `T`, as far as the optimiser knows.
fn opaque<T>(value: T) -> T {
    black_box(value)
}

fn opaque_mode() -> Mode {
    if opaque(false) {
        Mode::Paper
    } else {
        Mode::Improved
    }
}

fn opaque_kind() -> PeakKind {
    if opaque(false) {
        PeakKind::SingleBin
    } else {
        PeakKind::TwoBin
    }
}

fn opaque_thresholds() -> Thresholds {
    Thresholds {
        rival_ratio: Score::from_bits(opaque(0)),
        direction_margin: Score::from_bits(opaque(0)),
        min_occupied: opaque(0),
        max_shift_fraction: Score::from_bits(opaque(0)),
        alignment_ratio: Score::from_bits(opaque(0)),
        min_overlap: Score::from_bits(opaque(0)),
        decision_gap: Score::from_bits(opaque(0)),
        free_space_weight: Score::from_bits(opaque(0)),
        search_budget: opaque(0),
    }
}

/// Every grid method.
#[inline(never)]
fn entry_grid<const W: usize, const H: usize, const RW: usize>() -> Grid<W, H, RW> {
    let mut g = Grid::<W, H, RW>::from_words(opaque([[0u32; RW]; H]));
    let _ = opaque(g.set(opaque(0), opaque(0)));
    let _ = opaque(g.clear(opaque(0), opaque(0)));
    opaque(g.get(opaque(0), opaque(0)));
    let _ = opaque(g.set_cells(opaque([(0usize, 0usize); 8])));
    let _ = opaque(g.set_point(opaque(0.0), opaque(0.0)));
    opaque(g.occupied());
    opaque(g.words());
    for cell in g.occupied_cells() {
        opaque(cell);
    }
    if opaque(false) {
        g.clear_all();
    }
    g
}

/// The estimator: references, estimates with and without a prior and with
/// and without the verification, the result's helpers.
#[inline(never)]
fn entry_estimator<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const HALF: usize,
    const RHO: usize,
    const PW: usize,
>(
    g1: &Grid<W, H, RW>,
    g2: &Grid<W, H, RW>,
) -> Estimate {
    let mut e = Estimator::<W, H, RW, N, HALF, RHO, PW>::new(opaque_mode());
    if opaque(false) {
        e = e.with_thresholds(opaque_thresholds());
    }
    e = e.with_verification(opaque(true));
    opaque(e.verification());
    if opaque(false) {
        if let Ok(range) = ScaleRange::new(opaque(Score::ONE), opaque(Score::ONE)) {
            opaque((range.min(), range.max()));
            e = e.with_scale_search(range);
        }
        e.set_scale_search(opaque(Some(ScaleRange::DEFAULT)));
    }
    opaque(e.scale_search());
    opaque(e.thresholds());
    let mut reference = e.reference(g1);
    // In place over the reference of the other grid, and back.
    e.reference_in_place(g2, &mut reference);
    opaque(&reference);
    e.reference_in_place(g1, &mut reference);
    opaque(reference.grid());
    for cell in reference.grid().occupied_cells() {
        opaque(cell);
    }
    let estimate = e.estimate(&reference, g2);
    opaque(estimate.overlap);
    for candidate in &estimate.candidates {
        opaque(candidate.alignment);
    }
    opaque(estimate.half_turn.margin());
    if let Some(t) = &estimate.translation {
        opaque(t.column_shift_q16((opaque(0), opaque(0))));
    }
    opaque(&estimate);
    opaque(e.estimate_pair(g1, g2));
    let prior = Prior {
        alpha: Angle(opaque(0)),
        sigma: Angle(opaque(0)),
    };
    opaque(e.estimate_with_prior(&reference, g2, opaque(Some(prior))));
    // The verification explicitly on (improved mode) and off.
    let mut verified = Estimator::<W, H, RW, N, HALF, RHO, PW>::new(Mode::Improved)
        .with_verification(true)
        .with_thresholds(opaque(Thresholds::DEFAULT));
    opaque(verified.estimate(&reference, g2));
    opaque(verified.estimate_with_prior(&reference, g2, opaque(Some(prior))));
    // Scans: the free space of both views (any grids here).
    let free = FreeSpace {
        reference: g2,
        current: g1,
    };
    let on_scans = verified.estimate_scans(&reference, g2, &free, opaque(Some(prior)));
    opaque(&on_scans.runner_up);
    opaque(e.estimate_scans(&reference, g2, &free, opaque(None)));
    let mut plain = verified.with_verification(false);
    opaque(plain.verification());
    opaque(plain.estimate(&reference, g2));
    opaque(e.current_signature());
    opaque(e.mode());
    opaque(Mode::peak_kind(opaque_mode()));
    on_scans
}

/// A stored reference: bytes in, bytes out, and an estimate against a
/// reference read from arbitrary (checksummed) bytes, with the verification
/// on and off, and the same bytes as a scan reference; bytes of the previous
/// format (version 2) give a typed error.
#[inline(never)]
fn entry_reference_bytes<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const HALF: usize,
    const RHO: usize,
    const PW: usize,
>(
    bytes: &[u8],
    version_2: &[u8],
    grid: &Grid<W, H, RW>,
) {
    if let Ok(reference) = Reference::<W, H, RW, HALF, RHO>::from_bytes(bytes) {
        opaque(reference.signature());
        opaque(reference.profiles());
        opaque(reference.occupied());
        opaque(reference.grid());
        let mut out = opaque([0u8; 64]);
        let len = opaque(0usize).min(out.len());
        let _ = opaque(reference.to_bytes(out.get_mut(..len).unwrap_or(&mut [])));
        let mut e = Estimator::<W, H, RW, N, HALF, RHO, PW>::new(opaque_mode())
            .with_verification(opaque(true));
        opaque(e.estimate(&reference, grid));
    }
    // The same bytes as a scan reference (free space and scan stored with
    // it), its scan checking an estimate against itself.
    if let Ok(stored) = ScanReference::<W, H, RW, HALF, RHO, 16>::from_bytes(bytes) {
        opaque(stored.raster());
        opaque(stored.byte_len());
        let mut out = opaque([0u8; 64]);
        let len = opaque(0usize).min(out.len());
        let _ = opaque(stored.to_bytes(out.get_mut(..len).unwrap_or(&mut [])));
        let mut e = Estimator::<W, H, RW, N, HALF, RHO, PW>::new(opaque_mode())
            .with_verification(opaque(true));
        let estimate = e.estimate_scans(stored.reference(), grid, &stored.free_space(grid), None);
        let scan = stored.scan();
        opaque(stored.raster().check_on_beams(&scan, &scan, &estimate));
        let _ = opaque(ScanReference::<W, H, RW, HALF, RHO, 8>::new(
            stored.reference().clone(),
            stored.free().clone(),
            stored.raster(),
            &scan,
        ));
    }
    match Reference::<W, H, RW, HALF, RHO>::from_bytes(version_2) {
        Err(Error::ReferenceVersion { found, expected }) => {
            opaque((found, expected));
        }
        other => {
            opaque(other.is_ok());
        }
    }
}

/// Votes, the full accumulator and the signature.
#[inline(never)]
fn entry_votes<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const HALF: usize,
    const RHO: usize,
>(
    grid: &Grid<W, H, RW>,
) {
    let mut column: Column<RHO> = opaque([0u16; RHO]);
    vote_column::<W, H, RW, N, RHO>(grid, opaque(0), &mut column);
    vote_column_split::<W, H, RW, N, RHO>(grid, opaque(0), opaque(0), &mut column);
    opaque(ColumnStats::of(&column, opaque_kind()));
    let accumulator = Accumulator::<HALF, RHO>::vote::<W, H, RW, N>(grid);
    opaque(accumulator.get(opaque(0), opaque(0)));
    opaque(accumulator.half_column(opaque(0)));
    opaque(accumulator.n_theta());
    let signature = Signature::<HALF>::from_accumulator(&accumulator, opaque_kind());
    opaque(signature.peak(opaque(0)));
    opaque(signature.asymmetry(opaque(0)));
    opaque(signature.kind());
    opaque(signature.peaks());
    opaque(signature.asymmetries());
    // Issue 14 item 2: the streaming signature, the pair vote at any `k`,
    // the trig table and a prepared reference.
    let mut pair: [Column<RHO>; 2] = opaque([[0u16; RHO]; 2]);
    hough_heading::stages::vote_column_pair::<W, H, RW, N, RHO>(grid, opaque(0), &mut pair);
    opaque(&pair);
    let mut streamed =
        Signature::<HALF>::stream::<W, H, RW, N, RHO>(grid, opaque_kind(), &mut pair);
    streamed.restream::<W, H, RW, N, RHO>(grid, opaque_kind(), &mut pair);
    opaque(&streamed);
    let table = &hough_heading::stages::TrigTable::<N>::TABLE;
    opaque(table.cos(opaque(0)));
    opaque(table.sin(opaque(0)));
    let prepared = Reference::<W, H, RW, HALF, RHO>::prepare::<N>(grid, opaque_kind(), &mut pair);
    let mut in_place = Reference::<W, H, RW, HALF, RHO>::empty(opaque_kind());
    in_place.prepare_in_place::<N>(grid, opaque_kind(), &mut pair);
    opaque(&in_place);
    opaque(prepared.profiles());
    opaque(prepared.occupied());
    opaque(prepared.signature());
}

/// Correlation, direction tests and the translation fit on arbitrary data.
#[inline(never)]
fn entry_matching<const HALF: usize, const RHO: usize>() {
    let d1 = opaque([0u16; HALF]);
    let d2 = opaque([0u16; HALF]);
    let c = Correlation::of(&d1, &d2);
    if let Some(best) = c.best() {
        opaque(c.score(best));
        opaque(best.offset_q16());
    }
    opaque(c.rival(opaque(0)));
    opaque(
        Peak {
            shift: opaque(0),
            before: opaque(0),
            value: opaque(0),
            after: opaque(0),
        }
        .offset_q16(),
    );
    let s1 = opaque(Signature::<HALF>::empty(PeakKind::SingleBin));
    let s2 = opaque(Signature::<HALF>::empty(PeakKind::SingleBin));
    opaque(paper_asymmetry(&s1, &s2, opaque(0)));
    let profile = opaque([0u8; RHO]);
    let column = opaque([0u16; RHO]);
    opaque(match_profile(&profile, &column, opaque(0), opaque(false)));
    opaque(match_profile_near(
        &profile,
        &column,
        opaque(0),
        opaque(0),
        opaque(false),
    ));
}

#[inline(never)]
fn entry_translation() {
    let shift = ColumnShift {
        normal_q15: (opaque(0), opaque(0)),
        best: Shift {
            shift_q16: opaque(0),
            score_q16: opaque(0),
        },
        runners_up: opaque(
            [Shift {
                shift_q16: opaque(0),
                score_q16: opaque(0),
            }; RUNNERS_UP],
        ),
    };
    let shifts = opaque([shift; 12]);
    opaque(fit_translation(shifts.get(..opaque(0)).unwrap_or(&[])));
}

#[inline(never)]
fn entry_angle() {
    let a = Angle(opaque(0));
    let b = Angle(opaque(0));
    opaque(Angle::from_steps_q16(opaque(0), opaque(0)));
    opaque(a.to_steps_q16(opaque(0)));
    opaque(a.nearest_step(opaque(0)));
    opaque(a.signed());
    opaque(a.to_degrees());
    opaque(Angle::from_degrees(opaque(0.0)));
    opaque(a.to_radians());
    opaque(a.distance(b));
    opaque(a + b);
    opaque(a - b);
    opaque(-a);
}

/// The configuration helpers, called at run time with arbitrary sizes.
#[inline(never)]
fn entry_config() {
    opaque(row_words(opaque(0)));
    opaque(hough_heading::config::half_turn_steps(opaque(0)));
    opaque(rho_bins(opaque(0), opaque(0)));
    opaque(recommended_n_theta(opaque(0), opaque(0)));
    opaque(max_votes_per_bin(opaque(0), opaque(0)));
    opaque(pyramid_levels(opaque(0), opaque(0)));
    opaque(pyramid_words(opaque(0), opaque(0)));
    opaque(hough_heading::config::align_points(opaque(0), opaque(0)));
    opaque(hough_heading::config::icp_points(opaque(0), opaque(0)));
    opaque(ALIGN_POINTS);
    opaque(REFERENCE_FORMAT);
}

/// Laser scans to grids and the estimate back to a motion.
#[inline(never)]
fn entry_scan<const W: usize, const H: usize, const RW: usize>(
    grid: &mut Grid<W, H, RW>,
    mut estimate: Estimate,
) {
    let ranges = opaque([0.0f32; 16]);
    let scan = Scan {
        ranges: ranges.get(..opaque(0)).unwrap_or(&[]),
        angle_min: opaque(0.0),
        angle_increment: opaque(0.0),
        max_range: opaque(0.0),
        offset: SensorOffset {
            x: opaque(0.0),
            y: opaque(0.0),
            theta: opaque(0.0),
        },
    };
    let scans = [scan, scan];
    let some = scans.get(..opaque(0)).unwrap_or(&[]);
    opaque(range_percentile(some, opaque(0)));
    let raster = match opaque(0u8) {
        0 => Raster::with_cell(opaque(0.0)),
        1 => Raster::with_radius(opaque(0.0), opaque(0)),
        _ => Raster::auto(some, opaque(0)),
    };
    if let Some(raster) = raster {
        let raster = raster.connect(opaque(0.0)).clip_to_disc(opaque(false));
        opaque(raster.cell());
        let stats: ScanStats = raster.rasterize(&scan, grid);
        opaque(raster.free_space(&scan, grid));
        let beams = ScanBeams::new(&scan, &raster);
        opaque(beams.end(opaque(0), opaque(0.0)));
        opaque(stats.dropped());
        opaque(raster.motion(Angle(opaque(0)), opaque(None)));
        let pose = Pose {
            x: Score::from_bits(opaque(0)),
            y: Score::from_bits(opaque(0)),
            scale: Score::from_bits(opaque(0)),
            residual: Score::from_bits(opaque(0)),
            columns: opaque(0),
            unobservable: opaque(None),
        };
        let _ = opaque(raster.refine_on_beams(&scan, &scans[opaque(0) & 1], Angle(opaque(0)), &pose));
        let other = &scans[opaque(1) & 1];
        opaque(raster.agreement_on_beams(&scan, other, Angle(opaque(0)), (pose.x, pose.y)));
        if let Some(check) = raster.check_on_beams(&scan, other, &estimate) {
            check.apply(&mut estimate);
            opaque(estimate);
        }
    }
}

/// One estimator configuration: every generic entry point.
fn configuration<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const HALF: usize,
    const RHO: usize,
    const PW: usize,
>(
    bytes: &[u8],
    version_2: &[u8],
) {
    let mut g1 = entry_grid::<W, H, RW>();
    let g2 = entry_grid::<W, H, RW>();
    let estimate = entry_estimator::<W, H, RW, N, HALF, RHO, PW>(&g1, &g2);
    entry_reference_bytes::<W, H, RW, N, HALF, RHO, PW>(bytes, version_2, &g2);
    entry_votes::<W, H, RW, N, HALF, RHO>(&g1);
    entry_matching::<HALF, RHO>();
    entry_scan::<W, H, RW>(&mut g1, estimate);
}

macro_rules! configuration {
    ($w:expr, $h:expr, $n:expr, $bytes:expr, $version_2:expr) => {
        configuration::<
            $w,
            $h,
            { row_words($w) },
            $n,
            { hough_heading::config::half_turn_steps($n) },
            { rho_bins($w, $h) },
            { pyramid_words($w, $h) },
        >($bytes, $version_2)
    };
}

/// One parser of `hough-lidar` and an assembler behind it: every public
/// method of `Parser`, `Packet`, `Lidar`, `Assembler`, `Revolution` and the
/// blocking and async drivers, on opaque bytes.
#[inline(never)]
fn entry_lidar<L: Layout + Clone, const CAP: usize>(parser: Parser<L, CAP>, bytes: &[u8]) {
    let mut p = opaque(parser.clone());
    for &b in bytes {
        if let Some(packet) = p.push(opaque(b)) {
            opaque((
                packet.bytes(),
                packet.len(),
                packet.is_empty(),
                packet.point(opaque(3)),
            ));
            for point in packet.points() {
                opaque((point.range_m(), point.degrees()));
            }
        }
        p.append(opaque(b));
        while let Some(packet) = p.poll() {
            opaque(packet.len());
        }
        opaque(p.current().map(|c| c.len()));
    }
    opaque((p.counters().dropped_packets(), p.buffered(), p.layout()));
    if opaque(false) {
        p.clear();
    }
    let mut lidar: Lidar<L, CAP, 360> = Lidar::new(p, opaque(12.0));
    for &b in bytes {
        if lidar.push(opaque(b)) {
            if let Some(r) = lidar.revolution() {
                opaque(r.scan(opaque(SensorOffset::default())));
                opaque(Revolution::<'_, 360>::angle_rad(opaque(7)));
            }
        }
    }
    while lidar.step() {
        opaque(lidar.revolution().map(|r| r.stats));
    }
    opaque((lidar.parser().counters(), lidar.assembler().counters()));
    let mut assembler: Assembler<720> = Assembler::new(L::DIRECTION, opaque(-1.0));
    let point = Point {
        angle: opaque(0),
        range_q2: opaque(0),
        quality: opaque(0),
    };
    if assembler.add(point) {
        opaque(assembler.revolution().map(|r| r.index));
    }
    opaque(assembler.max_range());
    assembler.restart();
    let mut driver = hough_lidar::Driver::new(
        opaque(bytes),
        Lidar::<L, CAP, 360>::new(parser.clone(), 8.0),
    );
    while let Ok(Some(r)) = driver.next_revolution() {
        opaque(r.stats);
    }
    opaque(driver.lidar().parser().counters());
    opaque(driver.into_reader());
    let mut driver =
        hough_lidar::Driver::new(opaque(bytes), Lidar::<L, CAP, 360>::new(parser, 8.0));
    let mut cx = Context::from_waker(Waker::noop());
    let mut future = pin!(driver.next_revolution_async());
    opaque(matches!(
        future.as_mut().poll(&mut cx),
        Poll::Ready(Ok(Some(_)))
    ));
}

/// The protocols' free functions.
#[inline(never)]
fn entry_lidar_helpers(bytes: &[u8]) {
    opaque((
        hough_lidar::ld06::crc8(bytes),
        hough_lidar::ld06::speed_deg_per_s(bytes),
        hough_lidar::ld06::timestamp_ms(bytes),
    ));
    opaque((
        hough_lidar::ydlidar::check_code(bytes),
        hough_lidar::ydlidar::correction_units(opaque(0)),
        hough_lidar::ydlidar::starts_revolution(bytes),
        hough_lidar::rplidar::starts_revolution(bytes),
        hough_lidar::xv11::checksum(bytes),
        hough_lidar::xv11::rpm(bytes),
    ));
    let layout = if opaque(false) {
        YdlidarLayout::uncorrected()
    } else {
        YdlidarLayout::triangulation()
    };
    opaque(layout.corrects());
}

/// The entry point of the binary: calls every check once.
#[no_mangle]
pub extern "C" fn _start() -> ! {
    // Longer than the largest reference (256², N = 720).
    static BYTES: [u8; 16384] = [0; 16384];
    /// The header of a version-2 reference (before the grid was kept).
    static VERSION_2: [u8; 16384] = {
        let mut b = [0u8; 16384];
        b[0] = b'H';
        b[1] = b'H';
        b[2] = b'R';
        b[3] = b'2';
        b
    };
    let bytes: &[u8] = opaque(&BYTES);
    let version_2: &[u8] = opaque(&VERSION_2);
    configuration!(64, 64, 128, bytes, version_2);
    configuration!(128, 128, 360, bytes, version_2);
    configuration!(160, 90, 512, bytes, version_2);
    configuration!(256, 256, 720, bytes, version_2);
    entry_translation();
    entry_angle();
    entry_config();
    let lidar_bytes: &[u8] = opaque(&BYTES[..600]);
    entry_lidar(Ld06::new(), lidar_bytes);
    entry_lidar(Rplidar::new(), lidar_bytes);
    entry_lidar(Xv11::new(), lidar_bytes);
    entry_lidar(
        Ydlidar::with_layout(opaque(YdlidarLayout::default())),
        lidar_bytes,
    );
    entry_lidar_helpers(lidar_bytes);
    #[cfg(feature = "negative-control")]
    entry_negative_control();
    loop {
        core::hint::spin_loop();
    }
}

/// The negative control (`--features negative-control`): indexes a table
/// with an index the optimiser cannot see, so a bounds-check panic stays in
/// the binary and the strict link must fail.
#[cfg(feature = "negative-control")]
#[inline(never)]
fn entry_negative_control() {
    let table = opaque([0u8; 4]);
    opaque(table[opaque(4usize)]);
}

#[cfg(feature = "strict")]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    extern "Rust" {
        /// Defined nowhere: linking fails if a panic path survived.
        fn hough_heading_panic_path_reachable() -> !;
    }
    // SAFETY: never called in a build that links; see the module docs.
    unsafe { hough_heading_panic_path_reachable() }
}

#[cfg(not(feature = "strict"))]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    loop {
        core::hint::spin_loop();
    }
}
