#!/usr/bin/env python3
"""Of a render's instructions, how many run in 256-bit registers, how many in 128-bit ones (scalar
f32 operations and the shuffles that build and take apart vectors) and how many are integer or
control instructions, per stage of the renderer (guide "Performance notes and their history",
2026-12-04, "What the lanes compile to").

Same profile as `callgrind_budget.py` (its docstring has the valgrind command; `--dump-instr=yes` is
needed), then:

    python3 benches/callgrind_widths.py cg.out target/release/reflect --samples 262144 [--lines 30]

Each instruction's class comes from its operands in `objdump -d` (a ymm register: 256-bit; an xmm
register: 128-bit or scalar; neither: integer, memory or control), its stage from
`callgrind_budget.stage` (the inline chain by `addr2line -i`). `--lines N` adds the N source lines
(innermost frame) with the most instructions. Needs binutils (objdump, addr2line).
"""

import argparse
import collections
import os
import re
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import callgrind_budget as budget  # noqa: E402


def operand_widths(binary, addrs):
    """The class of each address's instruction: 'ymm', 'xmm' or 'int'."""
    lo, hi = min(addrs), max(addrs) + 16
    out = subprocess.run(
        ["objdump", "-d", "--no-show-raw-insn", f"--start-address={lo:#x}", f"--stop-address={hi:#x}", binary],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    width = {}
    for line in out.splitlines():
        m = re.match(r"\s*([0-9a-f]+):\s+\S+\s*(.*)", line)
        if m:
            args = m.group(2)
            width[int(m.group(1), 16)] = "ymm" if "ymm" in args else ("xmm" if "xmm" in args else "int")
    return width


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("profile", help="callgrind.out file (recorded with --dump-instr=yes)")
    ap.add_argument("binary", help="the profiled reflect binary")
    ap.add_argument("--samples", type=int, required=True, help="samples rendered (pixels x spp)")
    ap.add_argument("--lines", type=int, default=0, help="also list this many source lines")
    a = ap.parse_args()
    addr_cost = budget.parse(a.profile)[0]
    addrs = sorted(x for x, c in addr_cost.items() if c > 0)
    width = operand_widths(a.binary, addrs)
    by_stage = collections.defaultdict(collections.Counter)
    by_line = collections.defaultdict(collections.Counter)
    lines = subprocess.run(
        ["addr2line", "-a", "-e", a.binary], input="\n".join(hex(x) for x in addrs) + "\n",
        capture_output=True, text=True, check=True,
    ).stdout.splitlines()[1::2]
    for addr, frames, line in zip(addrs, budget.inline_chains(a.binary, addrs), lines):
        w, c = width.get(addr, "int"), addr_cost[addr]
        for table, key in ((by_stage, budget.stage(frames)), (by_line, line.split("/src/")[-1])):
            table[key][w] += c
            table[key]["all"] += c
    n = a.samples
    print("| stage | per sample | 256-bit | 128-bit / scalar f32 | integer, memory, control |")
    print("|---|---|---|---|---|")
    total = collections.Counter()
    for k, c in sorted(by_stage.items(), key=lambda kv: -kv[1]["all"]):
        total.update(c)
        if c["all"] >= 0.003 * sum(v["all"] for v in by_stage.values()):
            print(f"| {k} | {c['all'] / n:.0f} | {c['ymm'] / n:.0f} | {c['xmm'] / n:.0f} | {c['int'] / n:.0f} |")
    print(f"| **total** | {total['all'] / n:.0f} | {total['ymm'] / n:.0f} | {total['xmm'] / n:.0f} | {total['int'] / n:.0f} |")
    if a.lines:
        print()
        print("| source line (innermost frame) | per sample | 256-bit | 128-bit / scalar | integer |")
        print("|---|---|---|---|---|")
        for k, c in sorted(by_line.items(), key=lambda kv: -kv[1]["all"])[: a.lines]:
            print(f"| {k} | {c['all'] / n:.1f} | {c['ymm'] / n:.1f} | {c['xmm'] / n:.1f} | {c['int'] / n:.1f} |")


if __name__ == "__main__":
    sys.exit(main())
