//! The pipeline of the firmware example `examples/lidar_heading.rs` (issue
//! 25): lidar bytes → revolutions → scans → grids → heading. Shared, by
//! `#[path]`, with the host test `lidar/tests/firmware_reference.rs`, which
//! keeps the host's results in `lidar/tests/data/ld06-headings.bin`: the
//! firmware must reproduce them bit for bit on every core.
//!
//! The configuration fits the Cortex-M0's 16 KiB of RAM: 360 beams a
//! revolution (1°), 64² grids, `N_θ` = 360, the window of `Raster::auto`
//! over both scans of a pair and segments up to 0.3 m (the CLI's defaults).

use hough_heading::{estimator, grid, Estimate, Mode, Raster, Scan, SensorOffset, Status};
use hough_lidar::ld06::Ld06Layout;
use hough_lidar::{Ld06, Lidar, Parser, Revolution};

/// Grid side, cells.
pub const SIDE: usize = 64;
/// θ steps over the full circle.
pub const N_THETA: usize = 360;
/// Beams a revolution.
pub const BINS: usize = 360;
/// Returns at or beyond this are "no return", metres.
pub const MAX_RANGE_M: f32 = 81.9;
/// Segments between neighbouring beams up to this long, metres.
pub const CONNECT_M: f32 = 0.3;
/// Bytes of one result record.
pub const RECORD_LEN: usize = 16;

/// The estimator.
pub type Estimator = estimator!(SIDE, SIDE, N_THETA);
/// A grid.
pub type Grid = grid!(SIDE, SIDE);
/// The LD06 parser and the revolution assembler.
pub type Ld06Lidar = Lidar<Ld06Layout, { Ld06::CAPACITY }, BINS>;

/// A fresh LD06 lidar.
pub const fn lidar() -> Ld06Lidar {
    Lidar::new(Parser::with_layout(Ld06Layout), MAX_RANGE_M)
}

/// The scan of a previous revolution's ranges (beam `i` at `i`° ccw).
fn scan(ranges: &[f32; BINS]) -> Scan<'_> {
    Scan {
        ranges,
        angle_min: 0.0,
        angle_increment: Revolution::<'_, BINS>::increment_rad(),
        max_range: MAX_RANGE_M,
        offset: SensorOffset::default(),
    }
}

/// The motion from the revolution whose ranges are `previous` to `current`:
/// both rasterised into `grids` with one window, then estimated.
pub fn estimate(
    estimator: &mut Estimator,
    previous: &[f32; BINS],
    current: &Revolution<'_, BINS>,
    grids: &mut [Grid; 2],
) -> Estimate {
    let scans = [scan(previous), current.scan(SensorOffset::default())];
    let raster = Raster::auto(&scans, SIDE)
        .or(Raster::with_cell(1.0))
        .map(|r| r.connect(CONNECT_M));
    let [a, b] = grids;
    a.clear_all();
    b.clear_all();
    if let Some(raster) = raster {
        raster.rasterize(&scans[0], a);
        raster.rasterize(&scans[1], b);
    }
    estimator.estimate_pair(a, b)
}

/// The estimator of the pipeline.
pub fn estimator() -> Estimator {
    Estimator::new(Mode::Improved)
}

/// An estimate as 16 bytes: α (binary angle, `i32` little-endian), the
/// status (`u8`), three zero bytes, the translation's x and y (Q16.16 cells,
/// `i32::MIN` without one).
pub fn record(e: &Estimate) -> [u8; RECORD_LEN] {
    let status: u8 = match e.status {
        Status::Confident => 0,
        Status::AmbiguousDirection => 1,
        Status::AmbiguousAxis => 2,
        Status::LowOverlap => 3,
        Status::NoStructure => 4,
        Status::SearchCut => 5,
    };
    let (x, y) = e
        .translation
        .map_or((i32::MIN, i32::MIN), |t| (t.x.to_bits(), t.y.to_bits()));
    let mut out = [0u8; RECORD_LEN];
    let fields = [
        e.alpha.signed().to_le_bytes(),
        [status, 0, 0, 0],
        x.to_le_bytes(),
        y.to_le_bytes(),
    ];
    for (chunk, field) in out.chunks_exact_mut(4).zip(fields) {
        chunk.copy_from_slice(&field);
    }
    out
}
