#!/usr/bin/env python3
"""Where the control step's instructions go, by function and source line, on the emulated MCU.

Usage (after `cargo build -p firmware --target thumbv7em-none-eabihf --release --features bench`):

    scripts/profile-step.py [ELF]

It runs the `qemu` firmware's `bench` mode (one scripted docking through every path of the
step; docs/benchmarks.md) in QEMU with `-icount shift=0 -d exec,nochain,in_asm`, counts every
executed instruction inside `Controller::step` (its inlined callees included), and attributes
each to the innermost inlined function and source line with `arm-none-eabi-addr2line -i`.
Counts are exact (QEMU executes each logged translation block whole; `nochain` logs every
execution). Needs qemu-system-arm and the ARM binutils (scripts/test-all.sh installs both).
A development tool: nothing in CI depends on it.
"""
import collections
import os
import re
import subprocess
import sys
import tempfile

ELF = sys.argv[1] if len(sys.argv) > 1 else "target/thumbv7em-none-eabihf/release/firmware"
ROOT = "ibvs_core::controller::Controller::step"


def symbol_range(elf, name):
    out = subprocess.run(["arm-none-eabi-nm", "-C", "-S", elf], capture_output=True,
                         text=True, check=True).stdout
    for line in out.splitlines():
        parts = line.split(maxsplit=3)
        if len(parts) == 4 and parts[3] == name:
            start, size = int(parts[0], 16), int(parts[1], 16)
            return start, start + size
    sys.exit(f"{name} not found in {elf}")


def trace(elf):
    log = tempfile.NamedTemporaryFile(suffix=".log", delete=False).name
    subprocess.run(["qemu-system-arm", "-machine", "netduinoplus2", "-cpu", "cortex-m4",
                    "-icount", "shift=0", "-display", "none", "-monitor", "none",
                    "-semihosting-config", "enable=on,target=native,arg=firmware,arg=bench",
                    "-serial", "null", "-kernel", elf, "-d", "exec,nochain,in_asm", "-D", log],
                   check=True, timeout=300, capture_output=True)
    return log


def counts_in(log, lo, hi):
    """Executions of every instruction address in [lo, hi)."""
    blocks, block, counts = {}, None, collections.Counter()
    with open(log) as f:
        for line in f:
            if line.startswith("IN:"):
                block = []
                continue
            m = re.match(r"0x([0-9a-f]{8}):\s", line)
            if m and block is not None:
                block.append(int(m.group(1), 16))
                continue
            if not line.strip() and block is not None:
                if block:
                    blocks[block[0]] = block
                block = None
                continue
            m = re.match(r"Trace \d+: 0x[0-9a-f]+ \[[0-9a-f]+/([0-9a-f]+)/", line)
            if m:
                for a in blocks.get(int(m.group(1), 16), []):
                    if lo <= a < hi:
                        counts[a] += 1
    os.unlink(log)
    return counts


def innermost(elf, addrs):
    """Innermost inlined (function, file:line) of each address."""
    out = subprocess.run(["arm-none-eabi-addr2line", "-a", "-f", "-C", "-i", "-e", elf]
                         + [hex(a) for a in addrs], capture_output=True, text=True,
                         check=True).stdout.splitlines()
    where, cur, i = {}, None, 0
    while i < len(out):
        if out[i].startswith("0x"):
            cur = int(out[i], 16)
            i += 1
        elif cur is not None and cur not in where and i + 1 < len(out):
            loc = re.sub(r".*/(core|firmware|library)/", r"\1/", out[i + 1].split(" ")[0])
            where[cur] = (out[i], loc)
            i += 2
        else:
            i += 1
    return where


def main():
    lo, hi = symbol_range(ELF, ROOT)
    counts = counts_in(trace(ELF), lo, hi)
    where = innermost(ELF, sorted(counts))
    total = sum(counts.values())
    by_fn, by_line = collections.Counter(), collections.Counter()
    for a, n in counts.items():
        fn, loc = where.get(a, ("?", "?"))
        by_fn[fn] += n
        by_line[loc] += n
    print(f"{total} instructions in {ROOT} over the bench script (all its steps)")
    print("\nby innermost function:")
    for k, v in by_fn.most_common(30):
        print(f"{v:8d} {100 * v / total:5.1f} %  {k}")
    print("\nby source line:")
    for k, v in by_line.most_common(30):
        print(f"{v:8d} {100 * v / total:5.1f} %  {k}")


if __name__ == "__main__":
    main()
