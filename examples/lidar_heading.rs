//! Firmware example: from a lidar's bytes to the heading (issue 25).
//!
//! The robot loop fed from a UART byte stream: a recorded LDRobot LD06
//! capture (`lidar/tests/data/ld06.bin`, 20 revolutions of real Seattle
//! scans written by the independent encoder `tools/lidar_streams.py`) is
//! read through semihosting (`SYS_OPEN`, `SYS_READ`) 64 bytes at a time, as a
//! UART driver would hand them over, and each byte goes to the `hough-lidar`
//! parser and revolution assembler. Each completed revolution becomes a
//! scan, and the motion from the previous one is estimated
//! (`examples/support/lidar_pipeline.rs`: 360 beams, 64² grids, `N_θ` = 360,
//! which fits the Cortex-M0's 16 KiB). Every result must equal, bit for
//! bit, the host's in `lidar/tests/data/ld06-headings.bin` (written and
//! checked on the host by `lidar/tests/firmware_reference.rs`).
//!
//! Each revolution's decoding and each estimate run between the marker
//! functions `hh_bench_start` / `hh_bench_stop`, so the `qemu-icount`
//! plugin can count their instructions (`budgets` tool).
//!
//! Exit status: 0 when all 19 pairs match and no packet was dropped, 1 on a
//! mismatch, 2 when the capture cannot be read. On the host this example is
//! an empty stub.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
#[allow(dead_code)]
mod support;

#[cfg(target_os = "none")]
#[path = "support/lidar_pipeline.rs"]
mod pipeline;

#[cfg(target_os = "none")]
#[path = "support/markers.rs"]
mod markers;

#[cfg(target_os = "none")]
mod firmware {

    use semihosting::fs::File;
    use semihosting::io::Read;

    use crate::markers::{hh_bench_start, hh_bench_stop};
    use crate::pipeline::{self, BINS, RECORD_LEN};
    use crate::support;

    /// The host's results, one record per pair.
    static HEADINGS: &[u8] = include_bytes!("../lidar/tests/data/ld06-headings.bin");
    /// Exit status when the capture cannot be read.
    const EXIT_BAD_INPUT: i32 = 2;

    #[cfg_attr(target_arch = "arm", cortex_m_rt::entry)]
    #[cfg_attr(target_arch = "riscv32", riscv_rt::entry)]
    fn main() -> ! {
        let Ok(mut file) = File::open(c"lidar/tests/data/ld06.bin") else {
            defmt::println!("lidar_heading: cannot open lidar/tests/data/ld06.bin");
            support::exit(EXIT_BAD_INPUT)
        };
        let mut lidar = pipeline::lidar();
        let mut estimator = pipeline::estimator();
        let mut grids = [pipeline::Grid::new(), pipeline::Grid::new()];
        let mut previous: Option<[f32; BINS]> = None;
        let (mut pairs, mut wrong) = (0usize, 0u32);
        let mut chunk = [0u8; 64];
        // Decoding of one revolution's bytes, measured as one region.
        hh_bench_start();
        loop {
            let n = match file.read(&mut chunk) {
                Ok(0) => break,
                Ok(n) => n,
                Err(_) => support::exit(EXIT_BAD_INPUT),
            };
            for &byte in &chunk[..n] {
                if !lidar.push(byte) {
                    continue;
                }
                hh_bench_stop();
                let Some(revolution) = lidar.revolution() else {
                    continue;
                };
                if let Some(p) = &previous {
                    hh_bench_start();
                    let e = pipeline::estimate(&mut estimator, p, &revolution, &mut grids);
                    hh_bench_stop();
                    let got = pipeline::record(&e);
                    let want = HEADINGS.get(pairs * RECORD_LEN..(pairs + 1) * RECORD_LEN);
                    let ok = want == Some(&got[..]);
                    wrong += u32::from(!ok);
                    defmt::println!(
                        "pair {=usize}: alpha = {=i32} mdeg, {=u32} returns, {=str}",
                        pairs,
                        support::millidegrees(e.alpha),
                        revolution.stats.returns,
                        if ok {
                            "= host"
                        } else {
                            "DIFFERS FROM THE HOST"
                        }
                    );
                    pairs += 1;
                }
                previous = Some(*revolution.ranges);
                hh_bench_start();
            }
        }
        hh_bench_stop();
        let c = lidar.parser().counters();
        defmt::println!(
            "lidar_heading: {=u32} packets, {=u32} dropped, {=u32} bytes skipped, {=u32} revolutions",
            c.packets,
            c.dropped_packets(),
            c.skipped_bytes,
            lidar.assembler().counters().revolutions
        );
        if wrong == 0 && pairs * RECORD_LEN == HEADINGS.len() && c.dropped_packets() == 0 {
            defmt::println!(
                "lidar_heading: PASS ({=usize} pairs bit-identical to the host)",
                pairs
            );
            support::exit(0)
        }
        defmt::println!(
            "lidar_heading: FAIL ({=u32} of {=usize} pairs differ)",
            wrong,
            pairs
        );
        support::exit(support::EXIT_WRONG_ESTIMATE)
    }
}

/// On the host this example does nothing: it is firmware.
#[cfg(not(target_os = "none"))]
fn main() {
    println!("lidar_heading is firmware: build it for thumbv7em-none-eabihf or thumbv6m-none-eabi (.ci/firmware.sh)");
}
