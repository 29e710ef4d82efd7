#!/usr/bin/env bash
# Budgets of the lidar drivers (issue 25): instructions per packet and per
# point of each protocol's parser, alone and with the 720-beam revolution
# assembler, and the RAM of each type, on the Cortex-M4F (QEMU mps2-an386)
# and the Cortex-M0 (QEMU microbit). Writes docs/lidar/budgets.md.
#
#   bash tools/lidar_budgets.sh
#
# Runs examples/lidar_bench.rs twice per core: through `budgets run` for its
# log (packets, points, sizes) and under QEMU with the qemu-icount plugin
# for the exact instruction count of each region (region 0: the markers'
# own cost, subtracted). Needs what .ci/firmware.sh installs (QEMU, the
# tools in target/tools, llvm-nm).
set -euo pipefail
cd "$(dirname "$0")/.."

bash .ci/install-qemu.sh >/dev/null
rustup target add thumbv7em-none-eabihf thumbv6m-none-eabi >/dev/null
cargo build --quiet --manifest-path tools/Cargo.toml --target-dir target/tools
target_dir="${CARGO_TARGET_DIR:-target}"
out=target/lidar-budgets
mkdir -p "$out"

# target:machine:stack_hi
for spec in thumbv7em-none-eabihf:mps2-an386:0x20400000 thumbv6m-none-eabi:microbit:0x20004000; do
    IFS=: read -r target machine stack_hi <<<"$spec"
    cargo build --quiet --release -p hough-heading --example lidar_bench --target "$target"
    elf="$target_dir/$target/release/examples/lidar_bench"
    target/tools/debug/budgets run --machine "$machine" --timeout 60 "$elf" >"$out/$target.log"
    start=$(llvm-nm "$elf" | awk '/hh_bench_start/ && !f {print "0x"$1; f = 1}')
    stop=$(llvm-nm "$elf" | awk '/hh_bench_stop/ && !f {print "0x"$1; f = 1}')
    timeout 120 qemu-system-arm -machine "$machine" -display none -monitor none -serial null \
        -semihosting-config enable=on,target=native -kernel "$elf" \
        -plugin "target/tools/debug/libqemu_icount.so,start=$start,stop=$stop,stack_lo=0x20000000,stack_hi=$stack_hi" \
        </dev/null >/dev/null 2>"$out/$target.icount"
done

python3 - "$out" <<'PY'
import re, sys
out = sys.argv[1]
cores = [("Cortex-M4F", "thumbv7em-none-eabihf"), ("Cortex-M0", "thumbv6m-none-eabi")]
rows, sizes = [], {}
for core, target in cores:
    counts = [int(m.group(1)) for m in re.finditer(r"hh-icount (\d+)", open(f"{out}/{target}.icount").read())]
    log = open(f"{out}/{target}.log").read()
    caps = re.findall(r"(\w+): (\d+) bytes, (\d+) packets, (\d+) points, (\d+) revolutions, 0 dropped, parser (\d+) B, lidar (\d+) B", log)
    assembler = re.search(r"assembler (\d+) B", log).group(1)
    assert len(counts) == 1 + 2 * len(caps) and len(caps) == 4, (counts, caps)
    base = counts[0]
    for i, (name, nbytes, packets, points, revs, parser, lidar) in enumerate(caps):
        parse, both = counts[1 + 2 * i] - base, counts[2 + 2 * i] - base
        rows.append((core, name, int(packets), int(points), parse, both))
        sizes[name] = (parser, lidar, assembler)
lines = [
    "# Lidar driver budgets",
    "",
    "Measured by `bash tools/lidar_budgets.sh` (exact instruction counts from",
    "the `qemu-icount` plugin, `examples/lidar_bench.rs` over the captures of",
    "`lidar/tests/data/`, release build). \"Parser\" decodes every point of",
    "every packet; \"parser + assembler\" is a `Lidar` with 720 beams a",
    "revolution (binning, revolution detection, clearing the buffer at",
    "each turn).",
    "",
    "| core | protocol | packets | points | parser: instr. / packet | instr. / point | parser + assembler: instr. / packet | instr. / point |",
    "|---|---|---|---|---|---|---|---|",
]
for core, name, packets, points, parse, both in rows:
    lines.append(f"| {core} | {name} | {packets} | {points} | {parse / packets:.0f} | {parse / points:.0f} | {both / packets:.0f} | {both / points:.0f} |")
lines += [
    "",
    "RAM (`size_of`, the same on both cores):",
    "",
    "| protocol | parser | `Lidar` (parser + assembler, 720 beams) |",
    "|---|---|---|",
]
for name, (parser, lidar, assembler) in sizes.items():
    lines.append(f"| {name} | {parser} B | {lidar} B |")
lines += ["", f"The assembler alone, 720 beams: {assembler} B (5 bytes a beam: `f32` range, `u8` quality, plus its state).", ""]
open("docs/lidar/budgets.md", "w").write("\n".join(lines))
print("\n".join(lines))
PY
