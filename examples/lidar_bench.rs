//! Firmware bench of the lidar drivers (issue 25): instructions per packet
//! of each protocol's parser, alone and with the revolution assembler, and
//! the RAM of each, on the Cortex-M4F and the Cortex-M0 (QEMU with the
//! `qemu-icount` plugin: `bash tools/budgets.sh` measures it with the rest
//! and writes its rows into `budgets/TABLE.md`; `bash tools/budgets.sh
//! --only lidar` measures it alone).
//!
//! The four captures of `lidar/tests/data/` are in flash; for each, two
//! regions between the markers `hh_bench_start` / `hh_bench_stop`: the
//! parser over every byte (each point decoded), then a `Lidar` (parser and
//! 720-beam assembler) over every byte. Region 0 is empty (the markers'
//! own cost). The log gives each capture's bytes, packets, points and
//! revolutions and the types' sizes. Exit status 0 when every capture
//! decodes without a drop. On the host this example is an empty stub.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
#[allow(dead_code)]
mod support;

#[cfg(target_os = "none")]
#[path = "support/markers.rs"]
mod markers;

#[cfg(target_os = "none")]
mod firmware {
    use core::hint::black_box;
    use core::mem::size_of;

    use hough_lidar::{Assembler, Layout, Ld06, Lidar, Parser, Rplidar, Xv11, Ydlidar};

    use crate::markers::{hh_bench_start, hh_bench_stop};
    use crate::support;

    static LD06: &[u8] = include_bytes!("../lidar/tests/data/ld06.bin");
    static RPLIDAR: &[u8] = include_bytes!("../lidar/tests/data/rplidar.bin");
    static YDLIDAR: &[u8] = include_bytes!("../lidar/tests/data/ydlidar.bin");
    static XV11: &[u8] = include_bytes!("../lidar/tests/data/xv11.bin");
    /// Beams a revolution.
    const BINS: usize = 720;

    /// The two regions of one capture; `true` when nothing was dropped.
    #[inline(never)]
    fn bench<L: Layout + Clone, const CAP: usize>(
        name: &str,
        parser: Parser<L, CAP>,
        bytes: &[u8],
    ) -> bool {
        let mut p = parser.clone();
        hh_bench_start();
        for &b in bytes {
            p.append(black_box(b));
            while let Some(packet) = p.poll() {
                for point in packet.points() {
                    black_box(point);
                }
            }
        }
        hh_bench_stop();
        let mut lidar: Lidar<L, CAP, BINS> = Lidar::new(parser, 100.0);
        let mut revolutions = 0u32;
        hh_bench_start();
        for &b in bytes {
            if lidar.push(black_box(b)) {
                revolutions += 1;
                black_box(lidar.revolution());
            }
        }
        hh_bench_stop();
        let c = p.counters();
        defmt::println!(
            "{=str}: {=usize} bytes, {=u32} packets, {=u32} points, {=u32} revolutions, {=u32} dropped, parser {=usize} B, lidar {=usize} B",
            name,
            bytes.len(),
            c.packets,
            c.points,
            revolutions,
            c.dropped_packets(),
            size_of::<Parser<L, CAP>>(),
            size_of::<Lidar<L, CAP, BINS>>()
        );
        c.dropped_packets() == 0 && c.skipped_bytes == 0
    }

    #[cfg_attr(target_arch = "arm", cortex_m_rt::entry)]
    #[cfg_attr(target_arch = "riscv32", riscv_rt::entry)]
    fn main() -> ! {
        hh_bench_start();
        hh_bench_stop();
        let ok = [
            bench("ld06", Ld06::new(), LD06),
            bench("rplidar", Rplidar::new(), RPLIDAR),
            bench("ydlidar", Ydlidar::new(), YDLIDAR),
            bench("xv11", Xv11::new(), XV11),
        ];
        defmt::println!(
            "assembler {=usize} B ({=usize} beams)",
            size_of::<Assembler<BINS>>(),
            BINS
        );
        support::exit(if ok.iter().all(|&x| x) { 0 } else { 1 })
    }
}

/// On the host this example does nothing: it is firmware.
#[cfg(not(target_os = "none"))]
fn main() {
    println!("lidar_bench is firmware: build it for thumbv7em-none-eabihf or thumbv6m-none-eabi (bash tools/budgets.sh --only lidar)");
}
