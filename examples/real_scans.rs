//! Firmware example: real laser scan pairs from the host, estimated on the
//! MCU, results back to the host (issue 16, item 4).
//!
//! The program reads a binary pair file (format in `recordings/src/mcu_pairs.rs`, written
//! by `hough-heading mcu export`; by default the bundled
//! `host-tests/data/real-pairs.bin`, relative to QEMU's working directory,
//! another with `HH_REAL_PAIRS=path` at build time) through semihosting
//! (`SYS_OPEN`, `SYS_READ`, `SYS_SEEK`), and for each pair does what
//! `hough-heading scans --size 128 --n-theta 360` does:
//!
//! 1. decodes both scans' ranges (`u16` millimetres) to `f32` metres;
//! 2. picks the window with [`Raster::auto`] over both scans (radius = the
//!    90th percentile of the valid ranges, clamped to 2–40 m), with segments
//!    between neighbouring beams at most 0.3 m apart and no disc (the CLI's
//!    defaults);
//! 3. rasterizes scan 1 into a 128² grid (and its free space, the cells its
//!    beams crossed, into another) and prepares the reference from it;
//! 4. reads scan 2 again and rasterizes it (and its free space) into the same
//!    grid (the reference
//!    keeps its own copy of scan 1's grid: one grid of RAM instead of two, and
//!    the ranges are on the stack only while a scan is rasterized, which is
//!    what makes the Cortex-M0's 16 KiB enough);
//! 5. estimates (`Mode::Improved`, default thresholds, verification on,
//!    `N_θ` = 360) with both scans' free space, as the CLI does
//!    (`Estimator::estimate_scans`);
//! 6. reads both scans again, checks the estimate on their beams
//!    (`Raster::check_on_beams`, `BeamCheck::apply`; on the Cortex-M4F only,
//!    the M0's 16 KiB have no room for its vote) and refines the answer on
//!    them (`Raster::refine_on_beams`), as the CLI does by default.
//!
//! It logs one result line per pair ([`write_result`]: every field of the
//! rasterization and of the estimate as raw bits), and `hough-heading mcu
//! check` compares them with the host's own estimates of the same pairs: they
//! must be identical.
//!
//! Each step runs between the marker functions [`hh_bench_start`] and
//! [`hh_bench_stop`]: `budgets report` runs this firmware with the
//! `qemu-icount` plugin, which counts the instructions of each region (one
//! empty region first, the markers' overhead, then seven per pair: window,
//! rasterize scan 1, reference, rasterize scan 2, estimate, check on the
//! beams (empty on the M0), refinement on the beams) and the stack's
//! low-water mark, for the budget table's real-scan rows.
//!
//! ```text
//! cargo build --release -p hough-heading --example real_scans --target thumbv6m-none-eabi
//! target/tools/debug/budgets run --machine microbit --timeout 120 \
//!     target/thumbv6m-none-eabi/release/examples/real_scans > m0.log
//! cargo run --release --bin hough-heading -- mcu check host-tests/data/real-pairs.bin m0.log
//! ```
//!
//! or `bash .ci/firmware.sh`, which does this on both cores. Exit status: 0
//! when every pair was estimated, 2 when the pair file is missing or
//! malformed. On the host this example is an empty stub.
//!
//! [`write_result`]: pairs::write_result
#![cfg_attr(target_os = "none", no_std, no_main)]

// Only the exit and the logger are used here; the scenes and the scope pin
// serve the other examples.
#[cfg(target_os = "none")]
#[allow(dead_code)]
mod support;

#[cfg(target_os = "none")]
#[path = "../recordings/src/mcu_pairs.rs"]
mod pairs;

#[cfg(target_os = "none")]
mod firmware {
    use core::ffi::CStr;
    use core::hint::black_box;
    use core::mem::size_of;

    use hough_heading::{
        estimator, grid, reference, BeamFit, BeamFitError, Estimate, FreeSpace, Mode, Raster, Scan,
        ScanStats, SensorOffset, Thresholds,
    };
    use semihosting::fs::File;
    use semihosting::io::{Read, Seek, SeekFrom};

    use crate::pairs::{self, ScanHeader, CONNECT_M, HEADER_LEN, N_THETA, SCAN_HEADER_LEN, SIDE};
    use crate::support;

    /// Most beams per scan (the shared data has 180, 181, 360 and 361).
    const MAX_BEAMS: usize = 384;
    /// The pair file, relative to QEMU's working directory (the repository
    /// root in `.ci/firmware.sh`); another one with `HH_REAL_PAIRS=path` at
    /// build time.
    const PATH: &str = match option_env!("HH_REAL_PAIRS") {
        Some(path) => path,
        None => "host-tests/data/real-pairs.bin",
    };
    /// Exit status when the pair file is missing or malformed.
    const EXIT_BAD_INPUT: i32 = 2;
    /// Range codes read per semihosting call.
    const CHUNK: usize = 64;

    type Estimator = estimator!(SIDE, SIDE, N_THETA);
    type Reference = reference!(SIDE, SIDE, N_THETA);
    type ScanGrid = grid!(SIDE, SIDE);

    /// Start marker of a measured region (see `examples/bench.rs`).
    #[inline(never)]
    pub fn hh_bench_start() {
        black_box(1u32);
    }

    /// Stop marker of a measured region.
    #[inline(never)]
    pub fn hh_bench_stop() {
        black_box(2u32);
    }

    /// Runs `work` between the two markers.
    #[inline(always)]
    fn measure<T>(work: impl FnOnce() -> T) -> T {
        hh_bench_start();
        let out = work();
        hh_bench_stop();
        out
    }

    /// The pair file, and where in it the next read starts (semihosting
    /// seeks only to absolute positions).
    struct Pairs {
        file: File,
        at: u64,
    }

    impl Pairs {
        /// Reads exactly `buffer.len()` bytes.
        fn read(&mut self, buffer: &mut [u8]) -> Result<(), &'static str> {
            self.file
                .read_exact(buffer)
                .map_err(|_| "pair file: unexpected end")?;
            self.at += buffer.len() as u64;
            Ok(())
        }

        /// Continues reading at byte `at`.
        fn seek(&mut self, at: u64) -> Result<(), &'static str> {
            self.file
                .seek(SeekFrom::Start(at))
                .map_err(|_| "pair file: cannot seek")?;
            self.at = at;
            Ok(())
        }

        /// Reads one scan: its header, and its ranges decoded into `ranges`.
        fn scan(&mut self, ranges: &mut [f32; MAX_BEAMS]) -> Result<ScanHeader, &'static str> {
            let mut bytes = [0u8; SCAN_HEADER_LEN];
            self.read(&mut bytes)?;
            let header = ScanHeader::read(&bytes);
            let beams = usize::from(header.beams);
            if beams == 0 || beams > MAX_BEAMS {
                return Err("pair file: a scan has no beams or more than MAX_BEAMS");
            }
            let mut chunk = [0u8; 2 * CHUNK];
            for part in ranges[..beams].chunks_mut(CHUNK) {
                let bytes = &mut chunk[..2 * part.len()];
                self.read(bytes)?;
                for (r, code) in part.iter_mut().zip(bytes.chunks_exact(2)) {
                    *r = pairs::range(u16::from_le_bytes([code[0], code[1]]), header.max_range);
                }
            }
            Ok(header)
        }
    }

    /// The library's view of a scan read by [`Pairs::scan`].
    fn scan<'a>(header: &ScanHeader, ranges: &'a [f32]) -> Scan<'a> {
        Scan {
            ranges: &ranges[..usize::from(header.beams).min(ranges.len())],
            angle_min: header.angle_min,
            angle_increment: header.angle_increment,
            max_range: header.max_range,
            offset: SensorOffset {
                x: header.offset[0],
                y: header.offset[1],
                theta: header.offset[2],
            },
        }
    }

    /// What [`first_scan`] found of a pair.
    struct Window {
        index: u32,
        raster: Raster,
        stats: ScanStats,
        /// Where scan 1 and scan 2 start in the file, and where the next
        /// pair does.
        first_at: u64,
        second_at: u64,
        next_at: u64,
    }

    /// Reads the next pair, picks its window from both scans and rasterizes
    /// scan 1 into `grid`. Not inlined: both scans' ranges (3 KiB) live in
    /// this frame only, not beside the reference or during the estimate.
    #[inline(never)]
    fn first_scan(
        pairs: &mut Pairs,
        grid: &mut ScanGrid,
        free: Option<&mut ScanGrid>,
    ) -> Result<Window, &'static str> {
        let mut index = [0u8; 4];
        pairs.read(&mut index)?;
        let mut ranges = [[0f32; MAX_BEAMS]; 2];
        let [first, second] = &mut ranges;
        let first_at = pairs.at;
        let first = pairs.scan(first)?;
        let second_at = pairs.at;
        let second = pairs.scan(second)?;
        let scans = [scan(&first, &ranges[0]), scan(&second, &ranges[1])];
        // As the CLI's `RasterOptions::raster` with its defaults.
        let raster = measure(|| {
            Raster::auto(&scans, SIDE).map(|r| r.clip_to_disc(false).connect(CONNECT_M))
        })
        .ok_or("no usable cell size")?;
        grid.clear_all();
        let stats = measure(|| {
            let stats = raster.rasterize(&scans[0], grid);
            if let Some(free) = free {
                free.clear_all();
                raster.free_space(&scans[0], free);
            }
            stats
        });
        Ok(Window {
            index: u32::from_le_bytes(index),
            raster,
            stats,
            first_at,
            second_at,
            next_at: pairs.at,
        })
    }

    /// Reads both scans of the pair of `window` again, checks the estimate
    /// on their beams (`Raster::check_on_beams` and `BeamCheck::apply`,
    /// not on the 16 KiB micro:bit: its stack has no room for the vote)
    /// and refines the answer on them (`Raster::refine_on_beams`), as the
    /// CLI does by default; leaves the file at the next pair. Always two
    /// measured regions (empty when there is nothing to do). Not inlined,
    /// like [`first_scan`]: the ranges are not on the stack during the
    /// estimate.
    #[inline(never)]
    fn on_beams(
        pairs: &mut Pairs,
        window: &Window,
        estimate: &mut Estimate,
    ) -> Result<Option<Result<BeamFit, BeamFitError>>, &'static str> {
        pairs.seek(window.first_at)?;
        let mut ranges = [[0f32; MAX_BEAMS]; 2];
        let [first, second] = &mut ranges;
        let first = pairs.scan(first)?;
        let second = pairs.scan(second)?;
        if pairs.at != window.next_at {
            return Err("pair file: the pair changed");
        }
        let scans = [scan(&first, &ranges[0]), scan(&second, &ranges[1])];
        measure(|| {
            #[cfg(not(hh_small_ram))]
            if let Some(check) = window.raster.check_on_beams(&scans[0], &scans[1], estimate) {
                check.apply(estimate);
            }
        });
        Ok(measure(|| {
            estimate.translation.map(|t| {
                window
                    .raster
                    .refine_on_beams(&scans[0], &scans[1], estimate.alpha, &t)
            })
        }))
    }

    /// Reads scan 2 of the pair of `window` again and rasterizes it into
    /// `grid`; leaves the file at the next pair. Not inlined, like
    /// [`first_scan`].
    #[inline(never)]
    fn second_scan(
        pairs: &mut Pairs,
        window: &Window,
        grid: &mut ScanGrid,
        free: Option<&mut ScanGrid>,
    ) -> Result<ScanStats, &'static str> {
        pairs.seek(window.second_at)?;
        let mut ranges = [0f32; MAX_BEAMS];
        let header = pairs.scan(&mut ranges)?;
        if pairs.at != window.next_at {
            return Err("pair file: scan 2 changed");
        }
        let scan = scan(&header, &ranges);
        grid.clear_all();
        Ok(measure(|| {
            let stats = window.raster.rasterize(&scan, grid);
            if let Some(free) = free {
                free.clear_all();
                window.raster.free_space(&scan, free);
            }
            stats
        }))
    }

    /// Logs the result line of a pair. Not inlined: the line buffer is not
    /// on the stack during the estimate.
    #[inline(never)]
    fn report(
        window: &Window,
        occupied: [u32; 2],
        stats: &[ScanStats; 2],
        estimate: &Estimate,
        fit: Option<&Result<BeamFit, BeamFitError>>,
    ) -> Result<(), &'static str> {
        let mut line = heapless::String::<1024>::new();
        pairs::write_result(
            &mut line,
            window.index,
            window.raster.cell(),
            occupied,
            stats,
            estimate,
            fit,
        )
        .map_err(|_| "result line too long")?;
        defmt::println!("{=str}", line.as_str());
        Ok(())
    }

    /// Logs `message` and exits with [`EXIT_BAD_INPUT`].
    fn fail(message: &str) -> ! {
        defmt::println!("error {=str}", message);
        support::exit(EXIT_BAD_INPUT)
    }

    #[cfg_attr(target_arch = "arm", cortex_m_rt::entry)]
    #[cfg_attr(target_arch = "riscv32", riscv_rt::entry)]
    fn main() -> ! {
        defmt::println!(
            "config side={=usize} n_theta={=usize} max_beams={=usize} estimator={=usize} reference={=usize} grid={=usize} ranges={=usize} free_space={=bool}",
            SIDE,
            N_THETA,
            MAX_BEAMS,
            size_of::<Estimator>(),
            size_of::<Reference>(),
            size_of::<ScanGrid>(),
            2 * MAX_BEAMS * size_of::<f32>(),
            cfg!(not(hh_small_ram))
        );
        let mut path = [0u8; 256];
        if let Some(to) = path.get_mut(..PATH.len()) {
            to.copy_from_slice(PATH.as_bytes());
        }
        let Some(file) = CStr::from_bytes_until_nul(&path)
            .ok()
            .and_then(|path| File::open(path).ok())
        else {
            defmt::println!("error cannot open {=str}", PATH);
            fail("no pair file (make one with `hough-heading mcu export`)")
        };
        let mut pairs = Pairs { file, at: 0 };
        let mut header = [0u8; HEADER_LEN];
        if pairs.read(&mut header).is_err() {
            fail("pair file: no header");
        }
        let Some((count, most_beams)) = pairs::header(&header) else {
            fail("pair file: wrong magic, version or header size")
        };
        if most_beams as usize > MAX_BEAMS {
            fail("pair file: scans longer than MAX_BEAMS");
        }
        // As the CLI's engine: `Estimator::new`, the thresholds set, then the
        // verification.
        let mut estimator = Estimator::new(Mode::Improved)
            .with_thresholds(Thresholds::DEFAULT)
            .with_verification(true);
        let mut grid = ScanGrid::new();
        // The free space of both scans (`Raster::free_space`): what their
        // beams saw through, for `Estimator::estimate_scans`. Not on the
        // 16 KiB micro:bit (`hh_small_ram`): its two 2 KiB grids do not fit
        // beside the verified estimate; there the estimate uses the grids
        // alone, as `hough-heading scans --no-free-space` does.
        #[cfg(not(hh_small_ram))]
        let mut free = [ScanGrid::new(), ScanGrid::new()];
        // The markers' own cost, subtracted by the budget tool.
        measure(|| ());
        for _ in 0..count {
            #[cfg(not(hh_small_ram))]
            let (mut free_first, mut free_second) = {
                let [first, second] = &mut free;
                (Some(first), Some(second))
            };
            #[cfg(hh_small_ram)]
            let (mut free_first, mut free_second): (
                Option<&mut ScanGrid>,
                Option<&mut ScanGrid>,
            ) = (None, None);
            let window = first_scan(&mut pairs, &mut grid, free_first.as_deref_mut())
                .unwrap_or_else(|m| fail(m));
            let occupied_first = grid.occupied();
            // With the reach tables, in place: returned by value, the
            // reference would be built once more on the stack. Without them
            // (the micro:bit) the return by value is built where it lands,
            // and in place from `Reference::empty` measured 1.2 KiB more
            // stack (M4F), more than the 16 KiB leave.
            #[cfg(not(hh_small_ram))]
            let mut reference = Reference::empty(Mode::Improved.peak_kind());
            #[cfg(not(hh_small_ram))]
            measure(|| estimator.reference_in_place(&grid, &mut reference));
            #[cfg(hh_small_ram)]
            let reference = measure(|| estimator.reference(&grid));
            let second = second_scan(&mut pairs, &window, &mut grid, free_second.as_deref_mut())
                .unwrap_or_else(|m| fail(m));
            let mut estimate = match (free_first.as_deref(), free_second.as_deref()) {
                (Some(reference_free), Some(current_free)) => {
                    let views = FreeSpace {
                        reference: reference_free,
                        current: current_free,
                    };
                    measure(|| estimator.estimate_scans(&reference, &grid, &views, None))
                }
                _ => measure(|| estimator.estimate(&reference, &grid)),
            };
            let fit = on_beams(&mut pairs, &window, &mut estimate).unwrap_or_else(|m| fail(m));
            let stats = [window.stats, second];
            report(
                &window,
                [occupied_first, grid.occupied()],
                &stats,
                &estimate,
                fit.as_ref(),
            )
            .unwrap_or_else(|m| fail(m));
        }
        defmt::println!("done pairs={=u32}", count);
        support::exit(0)
    }
}

/// On the host this example does nothing: it is firmware.
#[cfg(not(target_os = "none"))]
fn main() {
    println!("real_scans is firmware: see .ci/firmware.sh");
}
