#!/usr/bin/env bash
# The firmware build commands the documentation gives, run verbatim (issue 48
# item 7), so that they cannot drift from what builds.
#
# Extracts every `cargo build … --target <bare-metal triple>` command from the
# tracked Markdown files and Rust sources (doc comments, fenced blocks and
# inline code; continuation lines joined; CHANGELOG.md is history and left
# out), prints it, and runs it with bash from the repository root, as a user
# who copies it from a fresh clone would. Fails when one fails, and when fewer
# than $DOC_FIRMWARE_MIN commands are found (default 4: an extractor that
# finds nothing must not pass).
#
#   bash .ci/doc-firmware.sh          # run them
#   bash .ci/doc-firmware.sh --list   # print them only
set -euo pipefail
cd "$(dirname "$0")/.."

mapfile -t commands < <(git ls-files '*.md' '*.rs' | grep -v '^CHANGELOG\.md$' | python3 -c '
import re, sys
TRIPLE = r"--target\s+(thumbv[0-9a-z]+-none-eabi(hf)?|riscv32[a-z]+-unknown-none-elf)\b"
found = []
for path in sys.stdin.read().split():
    joined, pending = [], ""
    for raw in open(path, encoding="utf-8"):
        line = re.sub(r"^\s*(//[!/]?)?\s?", "", raw.rstrip("\n")).strip()
        if line.endswith("\\"):
            pending += line[:-1].strip() + " "
            continue
        joined.append((pending + line).strip())
        pending = ""
    for line in joined:
        spans = re.findall(r"`([^`]*)`", line) or [line]
        for span in spans:
            if re.match(r"^([A-Z_][A-Z0-9_]*=\S+\s+)*cargo build\b", span) and re.search(TRIPLE, span):
                found.append(f"{path}\t{span}")
for f in dict.fromkeys(found):
    print(f)
')

echo "doc-firmware: ${#commands[@]} firmware build command(s) in the docs"
if ((${#commands[@]} < ${DOC_FIRMWARE_MIN:-4})); then
    echo "doc-firmware: expected at least ${DOC_FIRMWARE_MIN:-4}: the extraction is broken" >&2
    exit 1
fi
for entry in "${commands[@]}"; do
    file="${entry%%$'\t'*}"
    command="${entry#*$'\t'}"
    echo "--- $file: $command"
    [[ "${1:-}" == --list ]] && continue
    bash -c "$command"
done
