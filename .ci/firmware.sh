#!/usr/bin/env bash
# Firmware CI of hough-heading (issue 6): build the firmware examples for the
# Cortex-M targets, run them under QEMU (a wrong estimate fails), then measure
# the budgets and compare them with budgets/budgets.json (> 10 % growth fails).
#
#   bash .ci/firmware.sh            # CI: everything, budgets in --check mode
#   bash .ci/firmware.sh --report   # the same, but regenerate budgets/budgets.json and budgets/TABLE.md
#
# Installs what it needs: qemu-system-arm 10 (.ci/install-qemu.sh) and the
# rustup targets. The host tools (the qemu-icount plugin and the budgets
# runner, tools/) build into target/tools.
set -euo pipefail
cd "$(dirname "$0")/.."

section() { printf '\n=== firmware: %s (at %d s) ===\n' "$*" "$SECONDS"; }

budget_mode=--check
case "${1:-}" in
    "") ;;
    --report) budget_mode="" ;;
    *) echo "usage: $0 [--report]" >&2; exit 2 ;;
esac

# target triple → QEMU machine
declare -A MACHINES=([thumbv7em-none-eabihf]=mps2-an386 [thumbv6m-none-eabi]=microbit)
ARM_TARGETS=(thumbv7em-none-eabihf thumbv6m-none-eabi)
# The library's features per target: the 16 KiB micro:bit builds references
# at run time without the reach tables (on by default), as a board with that
# little RAM does.
declare -A FEATURES=([thumbv7em-none-eabihf]="" [thumbv6m-none-eabi]="--no-default-features")
EXAMPLES=(two_grids robot_loop)

section "QEMU"
bash .ci/install-qemu.sh
rustup target add "${ARM_TARGETS[@]}" riscv32imac-unknown-none-elf

section "host tools (tools/)"
cargo fmt --manifest-path tools/Cargo.toml -p qemu-icount -p budgets -- --check
cargo build --manifest-path tools/Cargo.toml --target-dir target/tools
cargo test --manifest-path tools/Cargo.toml --target-dir target/tools
budgets=target/tools/debug/budgets
target_dir="${CARGO_TARGET_DIR:-target}"

# `-p hough-heading`: the firmware's features only (the host crates of the
# workspace, selected by default, would switch on `std` features of shared
# dependencies such as byteorder).
section "clippy on the firmware examples (thumbv7em-none-eabihf)"
cargo clippy --release -p hough-heading --examples --target thumbv7em-none-eabihf -- -D warnings

for target in "${ARM_TARGETS[@]}"; do
    section "examples on $target (QEMU ${MACHINES[$target]})"
    # shellcheck disable=SC2086 # the flags split on purpose
    cargo build --release -p hough-heading --examples --target "$target" ${FEATURES[$target]}
    for example in "${EXAMPLES[@]}"; do
        echo "--- $example"
        "$budgets" run --machine "${MACHINES[$target]}" --timeout 30 \
            "$target_dir/$target/release/examples/$example"
    done
done

# Real scan pairs (issue 16): examples/real_scans.rs estimates the bundled
# pairs on each core; the host tool must find every result line identical.
section "real scan pairs on the MCUs, compared with the host"
cargo build --release --bin hough-heading
mkdir -p target/real-scans
logs=()
for target in "${ARM_TARGETS[@]}"; do
    log="target/real-scans/${MACHINES[$target]}.log"
    "$budgets" run --machine "${MACHINES[$target]}" --timeout 120 \
        "$target_dir/$target/release/examples/real_scans" >"$log" || { cat "$log"; exit 1; }
    logs+=("$log")
done
"$target_dir/release/hough-heading" mcu check host-tests/data/real-pairs.bin "${logs[@]}"

# A raw lidar capture (issue 25): examples/lidar_heading.rs decodes the LD06
# bytes with hough-lidar and estimates each revolution against the previous
# one; every result must equal the host's (lidar/tests/data/ld06-headings.bin,
# checked on the host by lidar/tests/firmware_reference.rs).
section "lidar capture to heading on the MCUs, compared with the host"
for target in "${ARM_TARGETS[@]}"; do
    echo "--- lidar_heading on $target"
    "$budgets" run --machine "${MACHINES[$target]}" --timeout 120 \
        "$target_dir/$target/release/examples/lidar_heading"
done

# Keyframe odometry on a robot's stream (issue 39): examples/keyframe_odometry.rs
# chains the bundled Seattle scans with the reference built in RAM; it exits 1
# unless the chained heading ends within 2° of the corrected poses'. The
# Cortex-M4F only: it does not fit the micro:bit's 16 KiB.
section "keyframe odometry on the Cortex-M4F"
"$budgets" run --machine mps2-an386 --timeout 120 \
    "$target_dir/thumbv7em-none-eabihf/release/examples/keyframe_odometry"

section "examples build for riscv32imac-unknown-none-elf"
cargo build --release -p hough-heading --examples --target riscv32imac-unknown-none-elf

# Software floating point (issue 48 item 8): every example on every target
# against the allow-list the README states (`budgets floats`); the estimate
# alone (the bench) links none, as the budgets check too.
section "software floating point of every firmware example (README's allow-list)"
"$budgets" floats --target-dir "$target_dir" "${ARM_TARGETS[@]}" riscv32imac-unknown-none-elf

section "budgets"
bash tools/budgets.sh $budget_mode
