#!/usr/bin/env bash
# Software floating point per scan pair on the MCUs: the instructions executed
# inside the compiler runtime's floating-point routines (`__aeabi_d…`,
# `__aeabi_f…` and their conversions), per region of `examples/real_scans.rs`
# (window, rasterize scan 1, reference, rasterize scan 2, estimate, check on
# the beams, refinement on the beams), summed over the bundled 120 pairs and
# divided by them, next to the region's whole count. Exact instruction counts
# from the qemu-icount plugin's flat profile (`budgets profile`); the routines
# are never inlined, so the instructions inside them are the floating point's
# cost (a call and a return each aside).
#
#   bash tools/float_cost.sh    # builds real_scans as .ci/firmware.sh does, ~20 min of QEMU
set -euo pipefail
cd "$(dirname "$0")/.."
target_dir="${CARGO_TARGET_DIR:-target}"
budgets=target/tools/debug/budgets
bash .ci/install-qemu.sh >/dev/null
cargo build --quiet --manifest-path tools/Cargo.toml --target-dir target/tools
names=(window "rasterize scan 1" reference "rasterize scan 2" estimate "check on the beams" "refine on the beams")
declare -A MACHINES=([thumbv7em-none-eabihf]=mps2-an386 [thumbv6m-none-eabi]=microbit)
# The features of .ci/firmware.sh: the M0 without the reach tables.
declare -A FEATURES=([thumbv7em-none-eabihf]="" [thumbv6m-none-eabi]="--no-default-features")
mkdir -p target/float-cost
printf '%-22s %-20s %12s %12s %8s\n' target region "instr./pair" "float/pair" "float"
for target in thumbv7em-none-eabihf thumbv6m-none-eabi; do
    # shellcheck disable=SC2086 # the flags split on purpose
    env -u HH_REAL_PAIRS cargo build --quiet --release -p hough-heading --example real_scans --target "$target" ${FEATURES[$target]}
    elf="target/float-cost/real_scans-$target"
    cp "$target_dir/$target/release/examples/real_scans" "$elf"
    for region in 0 1 2 3 4 5 6; do
        "$budgets" profile --machine "${MACHINES[$target]}" --cycle 7 --region "$region" --top 100000 "$elf" |
            python3 -c '
import re, sys
target, region = sys.argv[1], sys.argv[2]
lines = sys.stdin.read().splitlines()
rounds = int(re.search(r"\((\d+) rounds\)", lines[0]).group(1))
total = int(re.search(r": (-?\d+) instructions", lines[0]).group(1))
start = next(i for i, l in enumerate(lines) if l.startswith("self"))
floats = 0
for line in lines[start + 1:]:
    if line and not line[0].isspace():
        break
    fields = line.split()
    if len(fields) >= 3 and re.match(r"__(aeabi_([fd]|[uil]+2[fd])|(add|sub|mul|div|neg|cmp|eq|ne|lt|le|gt|ge|unord|fix|float|extend|trunc)[a-z]*[sd]f)", fields[-1]):
        floats += int(fields[0])
print(f"{target:<22} {region:<20} {total / rounds:12.0f} {floats / rounds:12.0f} {100 * floats / max(total, 1):7.2f}%")
' "$target" "${names[$region]}"
    done
done
