#!/usr/bin/env bash
# The accuracy guard of issue 40 and the verified search's work on the
# shared real pairs: runs `hough-heading scans` on every ../shared/data pair
# file at 256² and 128² (default options) into OUT_DIR, then
# tools/search_guard.py (with BASE_DIR: also how many answers differ).
#
#   bash tools/search_guard.sh OUT_DIR [BASE_DIR]
#   HH_BIN=target/eval/hough-heading bash tools/search_guard.sh OUT_DIR
#
# Needs ../shared/data; about 1.5 min on two cores.
set -euo pipefail
cd "$(dirname "$0")/.."
DATA=../shared/data
if ! ls "$DATA"/*_pairs.jsonl >/dev/null 2>&1; then
    echo "no $DATA/*_pairs.jsonl: nothing to measure" >&2
    exit 1
fi
OUT=${1:?usage: search_guard.sh OUT_DIR [BASE_DIR]}
BIN=${HH_BIN:-target/release/hough-heading}
if [ -z "${HH_BIN:-}" ]; then
    cargo build -q --release --bin hough-heading
fi
mkdir -p "$OUT"
for size in 256 128; do
    for f in "$DATA"/*_pairs.jsonl; do
        "$BIN" scans -q --size "$size" "$f" > "$OUT/$size-$(basename "$f" .jsonl).out"
    done
done
python3 tools/search_guard.py "$OUT" ${2:+"$2"}
