#!/usr/bin/env bash
# Link-time panic-freedom check of the library (issue 7).
#
# Builds `tools/no-panic`, a bare-metal Cortex-M4F binary that calls every
# public entry point of `hough-heading` on inputs the optimiser cannot see,
# in release (LTO, one codegen unit, no overflow checks), and checks that no
# panic path survived:
#
# 1. `--features strict`: the panic handler calls a symbol defined nowhere, so
#    the link succeeds only if the optimiser removed every path to it. This is
#    the check; it needs nothing beyond cargo and the target.
# 2. If that link fails, the binary is built again with a plain handler and
#    `tools/no-panic/panic_paths.py` lists every call from library code into
#    the panic machinery, with its source line and the entry points reaching
#    it (needs `llvm-objdump`, `llvm-nm`, `llvm-addr2line`: Debian's `llvm`).
#
# 3. Negative control (issue 14): the same strict build with
#    `--features negative-control`, which adds an index out of bounds on an
#    opaque input, must FAIL to link on the undefined symbol. If it links, the
#    check cannot fail and the script fails (exit 3), --report-only or not.
#
# Usage: tools/no-panic-check.sh [--report-only]
#   --report-only   list the panic paths but exit 0 (for a CI that only
#                   reports until the remaining sites are removed); the
#                   negative control still fails the run
# Environment:
#   NO_PANIC_OPT_LEVELS   release opt-levels to check, default "3" (the
#                         crate's release profile); e.g. "3 s z".
#   NO_PANIC_TARGET       default thumbv7em-none-eabihf.
#   NO_PANIC_FEATURES     more features of the checker.
#   NO_PANIC_NO_DEFAULT_FEATURES
#                         1: the checker without its default features, so
#                         the library without its reach tables.
#   NO_PANIC_NEGATIVE_CONTROL
#                         1 (default): run the negative control once, at the
#                         first opt-level; 0: skip it.
#
# Exit status: 0 no panic path (or --report-only), 1 panic paths found,
# 2 the checker itself failed to build for another reason, 3 the negative
# control linked (the check is broken).
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
manifest="$root/tools/no-panic/Cargo.toml"
target="${NO_PANIC_TARGET:-thumbv7em-none-eabihf}"
target_dir="$root/target/no-panic"
report_only=0
[[ "${1:-}" == "--report-only" ]] && report_only=1

if ! rustup target list --installed 2>/dev/null | grep -qx "$target"; then
    echo "no-panic-check: installing target $target"
    rustup target add "$target"
fi

extra="${NO_PANIC_FEATURES:+,$NO_PANIC_FEATURES}"
defaults=()
[[ "${NO_PANIC_NO_DEFAULT_FEATURES:-0}" == 1 ]] && defaults=(--no-default-features)
status=0
for opt in ${NO_PANIC_OPT_LEVELS:-3}; do
    export CARGO_PROFILE_RELEASE_OPT_LEVEL="$opt"
    log="$target_dir/strict-$opt.log"
    mkdir -p "$target_dir"
    echo "no-panic-check: opt-level $opt, $target${extra:+ ($NO_PANIC_FEATURES)}${defaults[*]:+ (${defaults[*]})}: strict link (panic handler undefined)"
    if cargo build --quiet --release --locked --target "$target" "${defaults[@]}" --features "strict$extra" \
        --manifest-path "$manifest" --target-dir "$target_dir" >"$log" 2>&1; then
        echo "no-panic-check: PASS at opt-level $opt: no panic path is reachable from any public entry point"
        continue
    fi
    if ! grep -q "hough_heading_panic_path_reachable" "$log"; then
        cat "$log" >&2
        echo "no-panic-check: the checker failed to build (see above)" >&2
        exit 2
    fi
    echo "no-panic-check: FAIL at opt-level $opt: panic paths remain; locating them"
    status=1
    cargo build --quiet --release --locked --target "$target" "${defaults[@]}" ${extra:+--features "${extra#,}"} \
        --manifest-path "$manifest" --target-dir "$target_dir"
    python3 "$root/tools/no-panic/panic_paths.py" \
        "$target_dir/$target/release/no-panic-check" "$root" || true
done

if [[ "${NO_PANIC_NEGATIVE_CONTROL:-1}" == 1 ]]; then
    opts=(${NO_PANIC_OPT_LEVELS:-3})
    opt="${opts[0]}"
    export CARGO_PROFILE_RELEASE_OPT_LEVEL="$opt"
    log="$target_dir/negative-control-$opt.log"
    echo "no-panic-check: negative control, opt-level $opt, $target: a deliberate panic must make the strict link fail"
    if cargo build --quiet --release --locked --target "$target" --features strict,negative-control \
        --manifest-path "$manifest" --target-dir "$target_dir" >"$log" 2>&1; then
        echo "no-panic-check: NEGATIVE CONTROL FAILED: the binary with a deliberate panic linked, so the check cannot fail" >&2
        exit 3
    fi
    if ! grep -q "hough_heading_panic_path_reachable" "$log"; then
        cat "$log" >&2
        echo "no-panic-check: the negative control failed to build for another reason (see above)" >&2
        exit 2
    fi
    echo "no-panic-check: negative control OK: the strict link failed as it must:"
    grep -m1 "undefined symbol.*hough_heading_panic_path_reachable" "$log" | sed 's/^/    /' || true
fi

if [[ $status -ne 0 && $report_only -eq 1 ]]; then
    echo "no-panic-check: --report-only: not failing"
    exit 0
fi
exit $status
