//! The markers of measured regions, for the `qemu-icount` plugin: it counts
//! the instructions from each call of `hh_bench_start` to the next call of
//! `hh_bench_stop` (see `examples/bench.rs`). Included by `#[path]` in the
//! lidar examples.

use core::hint::black_box;

/// Start marker of a measured region.
#[inline(never)]
pub fn hh_bench_start() {
    black_box(1u32);
}

/// Stop marker of a measured region.
#[inline(never)]
pub fn hh_bench_stop() {
    black_box(2u32);
}
