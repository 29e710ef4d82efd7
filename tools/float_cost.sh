#!/usr/bin/env bash
# Software floating point per scan pair on the MCUs: the instructions executed
# inside the compiler runtime's floating-point routines (`__aeabi_d…`,
# `__aeabi_f…` and their conversions), per region of `examples/real_scans.rs`
# (window, rasterize scan 1, reference, rasterize scan 2, estimate, check on
# the beams, refinement on the beams), summed over the bundled 120 pairs and
# divided by them, next to the region's whole count. Exact instruction counts
# from the qemu-icount plugin's flat profile (`budgets profile --floats`,
# one QEMU run per core); the routines
# are never inlined, so the instructions inside them are the floating point's
# cost (a call and a return each aside).
#
#   bash tools/float_cost.sh    # builds real_scans as .ci/firmware.sh does, a few minutes of QEMU
set -euo pipefail
cd "$(dirname "$0")/.."
target_dir="${CARGO_TARGET_DIR:-target}"
budgets=target/tools/debug/budgets
bash .ci/install-qemu.sh >/dev/null
cargo build --quiet --manifest-path tools/Cargo.toml --target-dir target/tools
declare -A MACHINES=([thumbv7em-none-eabihf]=mps2-an386 [thumbv6m-none-eabi]=microbit)
# The features of .ci/firmware.sh: the M0 without the reach tables.
declare -A FEATURES=([thumbv7em-none-eabihf]="" [thumbv6m-none-eabi]="--no-default-features")
mkdir -p target/float-cost
echo "regions: 0 window, 1 rasterize scan 1, 2 reference, 3 rasterize scan 2, 4 estimate, 5 check on the beams, 6 refinement on the beams"
for target in thumbv7em-none-eabihf thumbv6m-none-eabi; do
    # shellcheck disable=SC2086 # the flags split on purpose
    env -u HH_REAL_PAIRS cargo build --quiet --release -p hough-heading --example real_scans --target "$target" ${FEATURES[$target]}
    elf="target/float-cost/real_scans-$target"
    cp "$target_dir/$target/release/examples/real_scans" "$elf"
    "$budgets" profile --machine "${MACHINES[$target]}" --cycle 7 --floats "$elf"
done
