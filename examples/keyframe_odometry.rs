//! Firmware example: keyframe odometry on a robot's stream of scans (issue
//! 39), the keyframe's reference built in RAM.
//!
//! The stream: the bundled Seattle excerpt's 20 real scans (361 beams, 180°;
//! `data/seattle-stream.bin`, the 19 consecutive pairs of
//! `cli/data/logs/seattle-excerpt.pairs.jsonl` written by `hough-heading
//! mcu export`), stored with the firmware. For each scan the robot:
//!
//! 1. rasterizes it (and its free space) with the keyframe's window
//!    (`Raster::auto` over the keyframe's scan, 128², segments between
//!    beams at most 0.3 m apart);
//! 2. estimates it against the keyframe's reference (`Estimator::
//!    estimate_scans`, verification and free space), checks the estimate on
//!    the beams (`Raster::check_on_beams`);
//! 3. when the answer is flagged (`KeyframeOdometry::wants_prior`),
//!    estimates again with the damped constant-velocity motion prior, the
//!    beam check judging only rivals the prior allows (`BeamCheck::given`);
//! 4. refines the answer on the beams, turns it into the robot's motion
//!    (`Raster::motion`) and offers it to the chain
//!    (`KeyframeOdometry::place`: only a confident answer places the scan;
//!    otherwise `leave_unplaced` keeps it out of the chain, and the next
//!    scan is tried against the same keyframe); a new keyframe rebuilds the
//!    reference from this scan. This firmware keeps one stored scan, the
//!    keyframe: it offers no estimate against the last placed scan or the
//!    previous keyframe (the tool does).
//!
//! It logs one line per scan (source, keyframe, heading, heading σ) and
//! exits through semihosting with status 0 when the chained heading ends
//! within 2° of the truth (−105.24°, the sum of the pair file's
//! gmapping-corrected turns) and every scan was placed by an estimate, 1
//! otherwise, 2 on a malformed
//! stream. RAM: the keyframe's scan (1.5 KiB), two grids and two free-space
//! grids (8 KiB), the reference (`reference!(128, 128, 360)`) and the
//! estimator, on the stack: the Cortex-M4F (MPS2 AN386) runs it under QEMU
//! in `.ci/firmware.sh`; it does not fit the micro:bit's 16 KiB. On the host
//! this example is an empty stub.
#![cfg_attr(target_os = "none", no_std, no_main)]

// Only the exit is used here.
#[cfg(target_os = "none")]
#[allow(dead_code)]
mod support;

#[cfg(target_os = "none")]
#[path = "../recordings/src/mcu_pairs.rs"]
mod pairs;

#[cfg(target_os = "none")]
mod firmware {
    use hough_heading::odometry::{Against, KeyframeOdometry, KeyframeSettings, StepSource};
    use hough_heading::{
        estimator, grid, Estimate, FreeSpace, Mode, Raster, Scan, SensorOffset, Thresholds,
    };

    use crate::pairs::{self, ScanHeader, CONNECT_M, HEADER_LEN, N_THETA, SCAN_HEADER_LEN, SIDE};
    use crate::support;

    /// Most beams per scan.
    const MAX_BEAMS: usize = 384;
    /// The stream, a pair file of consecutive pairs.
    static STREAM: &[u8] = include_bytes!("data/seattle-stream.bin");
    /// The robot's true turn over the stream, millidegrees: the sum of the
    /// pair file's `dtheta` (gmapping-corrected poses).
    const TRUE_TURN_MDEG: i32 = -105_241;
    /// Largest accepted error of the chained heading, millidegrees.
    const TOLERANCE_MDEG: i32 = 2_000;
    /// Exit status on a malformed stream.
    const EXIT_BAD_INPUT: i32 = 2;

    type Estimator = estimator!(SIDE, SIDE, N_THETA);
    type ScanGrid = grid!(SIDE, SIDE);

    /// One scan of the stream, decoded.
    struct StreamScan {
        header: ScanHeader,
        ranges: [f32; MAX_BEAMS],
    }

    impl StreamScan {
        const EMPTY: Self = Self {
            header: ScanHeader {
                beams: 0,
                angle_min: 0.0,
                angle_increment: 0.0,
                max_range: 0.0,
                offset: [0.0; 3],
            },
            ranges: [0.0; MAX_BEAMS],
        };

        /// Decodes the scan at byte `at` of the stream; the byte after it.
        fn read(&mut self, at: usize) -> Option<usize> {
            let head: &[u8; SCAN_HEADER_LEN] =
                STREAM.get(at..at + SCAN_HEADER_LEN)?.try_into().ok()?;
            let header = ScanHeader::read(head);
            let beams = usize::from(header.beams);
            if beams == 0 || beams > MAX_BEAMS {
                return None;
            }
            let codes = STREAM.get(at + SCAN_HEADER_LEN..at + SCAN_HEADER_LEN + 2 * beams)?;
            for (r, code) in self.ranges.iter_mut().zip(codes.chunks_exact(2)) {
                *r = pairs::range(u16::from_le_bytes([code[0], code[1]]), header.max_range);
            }
            self.header = header;
            Some(at + SCAN_HEADER_LEN + 2 * beams)
        }

        /// The library's view of it.
        fn scan(&self) -> Scan<'_> {
            let h = &self.header;
            Scan {
                ranges: &self.ranges[..usize::from(h.beams).min(MAX_BEAMS)],
                angle_min: h.angle_min,
                angle_increment: h.angle_increment,
                max_range: h.max_range,
                offset: SensorOffset {
                    x: h.offset[0],
                    y: h.offset[1],
                    theta: h.offset[2],
                },
            }
        }
    }

    /// Rasterizes `scan` into `grid` and its free space into `free`.
    fn rasterize(raster: &Raster, scan: &Scan<'_>, grid: &mut ScanGrid, free: &mut ScanGrid) {
        grid.clear_all();
        free.clear_all();
        raster.rasterize(scan, grid);
        raster.free_space(scan, free);
    }

    /// The step was made by an estimate (confident, or made so by the prior).
    fn from_estimate(source: StepSource) -> bool {
        matches!(source, StepSource::Estimate | StepSource::Prior)
    }

    fn fail(message: &str) -> ! {
        defmt::println!("error {=str}", message);
        support::exit(EXIT_BAD_INPUT)
    }

    #[cfg_attr(target_arch = "arm", cortex_m_rt::entry)]
    #[cfg_attr(target_arch = "riscv32", riscv_rt::entry)]
    fn main() -> ! {
        let header: &[u8; HEADER_LEN] = match STREAM.get(..HEADER_LEN).map(TryInto::try_into) {
            Some(Ok(h)) => h,
            _ => fail("stream: no header"),
        };
        let Some((count, _)) = pairs::header(header) else {
            fail("stream: not a pair file")
        };
        let mut estimator = Estimator::new(Mode::Improved)
            .with_thresholds(Thresholds::DEFAULT)
            .with_verification(true);
        let (mut keyframe, mut current) = (StreamScan::EMPTY, StreamScan::EMPTY);
        // Pair 0's first scan is the first keyframe; every pair's second
        // scan is the next scan of the stream.
        let Some(mut at) = keyframe.read(HEADER_LEN + 4) else {
            fail("stream: bad first scan")
        };
        let window = |s: &StreamScan| {
            Raster::auto(&[s.scan()], SIDE).map(|r| r.clip_to_disc(false).connect(CONNECT_M))
        };
        let Some(mut raster) = window(&keyframe) else {
            fail("stream: no usable window")
        };
        let (mut key_grid, mut key_free) = (ScanGrid::new(), ScanGrid::new());
        let (mut grid, mut free) = (ScanGrid::new(), ScanGrid::new());
        rasterize(&raster, &keyframe.scan(), &mut key_grid, &mut key_free);
        let mut reference = estimator.reference(&key_grid);
        let mut chain = KeyframeOdometry::new(KeyframeSettings::default());
        chain.start();
        let mut not_estimated = 0u32;
        for pair in 0..count {
            if pair > 0 {
                // Skip the pair's index and its first scan (the last scan).
                let Some(next) = current.read(at + 4) else {
                    fail("stream: bad scan")
                };
                at = next;
            }
            let Some(next) = current.read(at) else {
                fail("stream: bad scan")
            };
            at = next;
            let (key_scan, scan) = (keyframe.scan(), current.scan());
            rasterize(&raster, &scan, &mut grid, &mut free);
            let views = FreeSpace {
                reference: &key_free,
                current: &free,
            };
            let judge = |mut estimate: Estimate, prior| {
                if let Some(check) = raster.check_on_beams(&key_scan, &scan, &estimate) {
                    match prior {
                        Some(_) => check.given(prior).flag(&mut estimate),
                        None => check.apply(&mut estimate),
                    }
                }
                estimate
            };
            let to_motion = |estimate: &Estimate| {
                let (alpha, translation) = match estimate
                    .translation
                    .map(|t| raster.refine_on_beams(&key_scan, &scan, estimate.alpha, &t))
                {
                    Some(Ok(fit)) => (fit.alpha, Some(fit.translation)),
                    _ => (estimate.alpha, estimate.translation),
                };
                raster.motion(alpha, translation.as_ref())
            };
            let estimate = judge(
                estimator.estimate_scans(&reference, &grid, &views, None),
                None,
            );
            let motion = to_motion(&estimate);
            // The answer made with the prior first when the chain wants it;
            // the original still places the scan if it is confident.
            let mut step = None;
            let mut guess = None;
            let mut contradicted = false;
            if chain.wants_prior(Against::Keyframe, &estimate) {
                let prior = chain.prior(Against::Keyframe);
                let again = judge(
                    estimator.estimate_scans(&reference, &grid, &views, prior),
                    prior,
                );
                let again_motion = to_motion(&again);
                step = chain.place(Against::Keyframe, &again, &again_motion, true);
                contradicted = chain.contradicts(Against::Keyframe, &again);
                guess = Some((again, again_motion));
            }
            if step.is_none() && !contradicted {
                step = chain.place(Against::Keyframe, &estimate, &motion, false);
            }
            let guess = guess.unwrap_or((estimate, motion));
            let step = step.unwrap_or_else(|| {
                chain.leave_unplaced(None, Some((Against::Keyframe, &guess.0, &guess.1)))
            });
            not_estimated += u32::from(!from_estimate(step.source));
            defmt::println!(
                "scan {=u32} source={=str} keyframe={=bool} heading_mdeg={=i32} sigma_mdeg={=i32}",
                pair + 1,
                step.source.name(),
                step.new_keyframe,
                support::millidegrees(step.pose.heading),
                (step.heading_sigma_deg * 1000.0) as i32
            );
            if step.new_keyframe {
                core::mem::swap(&mut keyframe, &mut current);
                let Some(r) = window(&keyframe) else {
                    fail("stream: no usable window")
                };
                raster = r;
                rasterize(&raster, &keyframe.scan(), &mut key_grid, &mut key_free);
                estimator.reference_in_place(&key_grid, &mut reference);
            }
        }
        let error = (support::millidegrees(chain.pose().heading) - TRUE_TURN_MDEG).abs();
        defmt::println!(
            "done scans={=u32} heading_error_mdeg={=i32} not_estimated={=u32}",
            count + 1,
            error,
            not_estimated
        );
        support::exit(i32::from(error > TOLERANCE_MDEG || not_estimated > 0))
    }
}

/// On the host this example does nothing: it is firmware.
#[cfg(not(target_os = "none"))]
fn main() {
    println!("keyframe_odometry is firmware: see .ci/firmware.sh");
}
