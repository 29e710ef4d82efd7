#!/usr/bin/env python3
"""List the panic paths left in a linked bare-metal ELF (issue 7).

Usage: panic_paths.py ELF [SOURCE_ROOT]

Reads `llvm-objdump -d -C` of ELF, builds the static call graph (direct `bl`
calls and `b`/`b<cond>` branches into other functions; indirect calls are not
followed), and finds every function that can reach the panic handler
(`rust_begin_unwind`, usually inlined into `core::panicking::panic_fmt`). A *panic site* is a call from a function outside
`core` into such a function. Each site is resolved with `llvm-addr2line -i`
to its chain of inlined source frames; the innermost frame under SOURCE_ROOT
(default: the parent of `tools/`) is the line to fix.

Prints one line per distinct source location, with the panic kind, the
number of call sites and the entry points (`entry_*` functions of the checker)
that reach it. Exit status: 0 if the ELF has no panic path, 1 if it has, 2 on
usage or tool errors.
"""

import bisect
import os
import re
import shutil
import subprocess
import sys
from collections import defaultdict

HANDLER = "rust_begin_unwind"
# `   31e90:   bl  0x4805a <...>`: a direct call or branch and its target.
INSN = re.compile(r"^\s+([0-9a-f]+):\s+(?:b|bl|b\.w|b[a-z]{2}(?:\.w)?|cbn?z)\s+(?:r\d+,\s*)?0x([0-9a-f]+)")
LEGACY = [("$LT$", "<"), ("$GT$", ">"), ("$u20$", " "), ("$u27$", "'"), ("$u5b$", "["),
          ("$u5d$", "]"), ("$u7b$", "{"), ("$u7d$", "}"), ("$C$", ","), ("$RF$", "&"),
          ("$BP$", "*"), ("..", "::"), ("_$", "$")]


def tool(*names):
    for name in names:
        path = shutil.which(name)
        if path:
            return path
    return None


def strip_hash(name):
    """`path::fn::h0123456789abcdef` -> `path::fn`, legacy escapes decoded."""
    name = re.sub(r"::h[0-9a-f]{16}$", "", name)
    for escaped, plain in LEGACY:
        name = name.replace(escaped, plain)
    return name.replace("$", "")


def main():
    if len(sys.argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    elf = sys.argv[1]
    here = os.path.dirname(os.path.abspath(__file__))
    root = os.path.abspath(sys.argv[2] if len(sys.argv) > 2 else os.path.join(here, "..", ".."))
    objdump = tool("llvm-objdump", "llvm-objdump-14")
    addr2line = tool("llvm-addr2line", "llvm-addr2line-14")
    nm_tool = tool("llvm-nm", "llvm-nm-14")
    if not objdump or not addr2line or not nm_tool:
        print("panic_paths: llvm-objdump and llvm-addr2line are needed "
              "(Debian package `llvm`)", file=sys.stderr)
        return 2
    dis = subprocess.run([objdump, "-d", "--no-show-raw-insn", "-C", elf],
                         check=True, capture_output=True, text=True).stdout

    # Function extents from the symbol table: branch targets and call sites
    # are resolved by address (objdump's own labels include the `$t`/`$d`
    # mapping symbols, which are not functions).
    nm = subprocess.run([nm_tool, "-S", "-C", "--defined-only", elf],
                        check=True, capture_output=True, text=True).stdout
    extents = []
    for line in nm.splitlines():
        parts = line.split(" ", 3)
        if len(parts) == 4 and parts[2] in ("t", "T", "W", "w"):
            start, size = int(parts[0], 16) & ~1, int(parts[1], 16)
            extents.append((start, start + size, parts[3]))
    extents.sort()
    starts = [e[0] for e in extents]

    def function_at(address):
        i = bisect.bisect_right(starts, address) - 1
        if i >= 0 and address < extents[i][1]:
            return extents[i][2]
        return None

    dis = subprocess.run([objdump, "-d", "--no-show-raw-insn", elf],
                         check=True, capture_output=True, text=True).stdout
    calls = defaultdict(set)  # function -> functions it calls or branches to
    sites = []  # (caller, address, callee)
    for line in dis.splitlines():
        m = INSN.match(line)
        if not m:
            continue
        address, target = int(m.group(1), 16), int(m.group(2), 16)
        caller, callee = function_at(address), function_at(target)
        if caller and callee and callee != caller:
            calls[caller].add(callee)
            sites.append((caller, address, callee))

    functions = set(calls) | {c for cs in calls.values() for c in cs}
    # The handler is usually inlined into `core::panicking::panic_fmt`.
    sinks = {f for f in functions if f == HANDLER or f.startswith("core::panicking::")}
    if not sinks:
        print("panic_paths: no panic handler in the binary: no panic path.")
        return 0

    # Functions that can reach the handler (reverse reachability).
    callers = defaultdict(set)
    for f, cs in calls.items():
        for c in cs:
            callers[c].add(f)
    panicking = set(sinks)
    stack = list(sinks)
    while stack:
        f = stack.pop()
        for g in callers[f]:
            if g not in panicking:
                panicking.add(g)
                stack.append(g)

    def is_core(name):
        return name.startswith(("core::", "<core::", "compiler_builtins::", HANDLER))

    # Which entry points reach each function.
    entries = sorted(f for f in functions if "::entry_" in f)
    reach = defaultdict(set)
    for entry in entries:
        seen = {entry}
        stack = [entry]
        while stack:
            f = stack.pop()
            for g in calls[f]:
                if g not in seen:
                    seen.add(g)
                    stack.append(g)
        for f in seen:
            reach[f].add(strip_hash(entry).split("::")[-1])

    boundary = [(f, addr, callee) for f, addr, callee in sites
                if callee in panicking and not is_core(f) and is_core(callee)]
    if not boundary:
        print("panic_paths: the handler is linked but no call from outside core reaches it.")
        return 1

    by_location = defaultdict(lambda: {"count": 0, "kinds": set(), "entries": set(), "chain": ""})
    for f, addr, callee in boundary:
        frames = subprocess.run([addr2line, "-e", elf, "-i", "-f", "-C", hex(addr)],
                                check=True, capture_output=True, text=True).stdout.splitlines()
        pairs = list(zip(frames[0::2], frames[1::2]))
        own = [(fn, loc) for fn, loc in pairs if loc.startswith(root) and "/tools/" not in loc]
        if own:
            fn, loc = own[0]
            loc = os.path.relpath(loc.split(" ")[0], root)
        else:
            # No line of ours: name the dependency's file and our function.
            fn, loc = (pairs[0] if pairs else (strip_hash(f), "?"))
            loc = re.sub(r"^.*/registry/src/[^/]+/", "", loc.split(" ")[0])
            loc = re.sub(r"^/rustc/[0-9a-f]+/library/", "", loc)
            fn = strip_hash(f)
        chain = " <- ".join(strip_hash(x) for x, _ in pairs[:4])
        entry = by_location[loc]
        entry["count"] += 1
        entry["kinds"].add(strip_hash(callee).split("::")[-1])
        entry["entries"] |= reach.get(f, set())
        entry["chain"] = entry["chain"] or chain
        entry["function"] = strip_hash(fn)

    print(f"panic_paths: {len(boundary)} call site(s) into the panic machinery, "
          f"{len(by_location)} source location(s):")
    for loc in sorted(by_location):
        e = by_location[loc]
        print(f"  {loc}: {', '.join(sorted(e['kinds']))} "
              f"({e['count']} site(s); in {e['function']}; "
              f"reached from {', '.join(sorted(e['entries'])) or '?'})")
    reaching = sorted({strip_hash(x).split('::')[-1] for x in entries if x in panicking})
    print(f"panic_paths: entry points that can panic: {', '.join(reaching) or 'none'}")
    return 1


if __name__ == "__main__":
    sys.exit(main())
