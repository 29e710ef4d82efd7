#!/usr/bin/env bash
# Firmware budgets of hough-heading, one command:
#
#   bash tools/budgets.sh            # measure, print the table, rewrite budgets/budgets.json + budgets/TABLE.md
#   bash tools/budgets.sh --check    # measure, print the table, fail on > 10 % growth over budgets/budgets.json
#   bash tools/budgets.sh --only 128x128/360   # one configuration, printed only (a quick look while working)
#   bash tools/budgets.sh --only lidar         # the lidar drivers' rows (tools/budgets/src/lidar.rs), printed only
#
# Where the instructions of one measured region go (after a run, which leaves
# the bench ELFs in target/budgets/<triple>/; needs llvm-addr2line), e.g. the
# verification by alignment on the Cortex-M4F:
#
#   target/tools/debug/budgets profile --machine mps2-an386 --region estimate --minus unverified \
#       target/budgets/thumbv7em-none-eabihf/bench-128-360.elf
#
# For 64², 128² and 256² room outlines with N_THETA = 360 and the paper's
# recommended range, on Cortex-M4F (QEMU mps2-an386), Cortex-M0 (QEMU microbit)
# and RV32IMAC (built only): instructions per estimate and per vote (exact
# counts from the qemu-icount TCG plugin), estimator state and peak stack,
# the verification by alignment's share (the estimate with and without it),
# static RAM and the library's flash; the real scan pairs' costs and the
# lidar drivers' (parser and assembler per packet and per point, RAM). See
# tools/budgets/src/main.rs.
set -euo pipefail
cd "$(dirname "$0")/.."

bash .ci/install-qemu.sh
rustup target add thumbv7em-none-eabihf thumbv6m-none-eabi riscv32imac-unknown-none-elf >/dev/null
cargo build --quiet --manifest-path tools/Cargo.toml --target-dir target/tools
exec target/tools/debug/budgets report --root . --plugin target/tools/debug/libqemu_icount.so "$@"
