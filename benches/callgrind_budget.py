#!/usr/bin/env python3
"""Per-sample instruction budget of a render, from a callgrind profile (guide "Performance notes and their
history", round five).

    valgrind --tool=callgrind --cache-sim=yes --dump-instr=yes --collect-atstart=no \\
        --toggle-collect='*render_range*' --callgrind-out-file=cg.out \\
        target/release/reflect render scenes/bench-lambert-grace.toml --size 128x128 --spp 16 --threads 1 --out x.exr
    python3 benches/callgrind_budget.py cg.out target/release/reflect --samples 262144

Callgrind charges an instruction to the function symbol it sits in, and in a release build most of the
render is inlined into `PathTracer::li_lanes`. This script asks `addr2line -i` for the inline chain of every
instruction address and charges the instruction to the stage of the renderer that called it (the frame
just inside the integrator (`li_lanes` and its stage functions) or `render_tile`, or the non-inlined function around it), so e.g. a `reverse_bits`
inlined into the sampler counts as the sampler and a `dot` inlined into `Frame::to_local` as the
integrator. Calls into libc are charged to their caller's stage (memcpy and malloc to the film, sincosf to
the BRDF sample). Out-of-line functions are charged by name (e.g. `Envmap::texel_index` to the light
eval, though the light sample calls it too): split such a function by its call counts
(`callgrind_annotate --tree=caller`). Needs `addr2line` (binutils) and a binary with line tables (the release profile has them).
"""

import argparse
import collections
import re
import subprocess
import sys


def parse(path):
    """Self Ir per instruction address of the main object, self Ir per function elsewhere, and the
    callers of each function outside the main object (for charging libc calls)."""
    names = {}

    def resolve(v):
        m = re.match(r"\((\d+)\)(?: (.*))?", v)
        if not m:
            return v
        if m.group(2) is not None:
            names[m.group(1)] = m.group(2)
        return names.get(m.group(1), v)

    obj = fn = cfn = None
    main_obj = None
    pending_call = False
    last = [0, 0]
    addr_cost = collections.Counter()
    other = collections.Counter()
    calls_into = collections.defaultdict(collections.Counter)
    for line in open(path):
        line = line.rstrip("\n")
        if line.startswith("cmd:") and main_obj is None:
            main_obj = line.split()[1].rsplit("/", 1)[-1]
        if line.startswith("ob="):
            obj = resolve(line[3:])
            continue
        if line.startswith("fn="):
            fn = resolve(line[3:])
            continue
        if line.startswith("cfn="):
            cfn = resolve(line[4:])
            continue
        if line.startswith(("fl=", "fi=", "fe=")):
            resolve(line[3:])
            continue
        if line.startswith(("cob=", "cfi=", "cfl=")):
            resolve(line[4:])
            continue
        if line.startswith("calls="):
            pending_call = True
            continue
        if not line or not (line[0].isdigit() or line[0] in "+-*"):
            continue
        parts = line.split()
        vals = []
        for i, p in enumerate(parts[:2]):
            if p == "*":
                v = last[i]
            elif p[0] in "+-":
                mag = int(p[1:], 16) if p[1:].startswith("0x") else int(p[1:])
                v = last[i] + (mag if p[0] == "+" else -mag)
            else:
                v = int(p, 16) if p.startswith("0x") else int(p)
            vals.append(v)
        last = vals
        ir = int(parts[2]) if len(parts) > 2 else 0
        if pending_call:
            pending_call = False
            calls_into[cfn][fn] += ir
            continue
        if obj and obj.rsplit("/", 1)[-1] == main_obj:
            addr_cost[vals[0]] += ir
        else:
            other[fn] += ir
    return addr_cost, other, calls_into


def inline_chains(binary, addrs):
    """For each address, its frames innermost first, as (function, source file) pairs."""
    out = subprocess.run(
        ["addr2line", "-a", "-i", "-f", "-C", "-e", binary],
        input="\n".join(hex(a) for a in addrs) + "\n",
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    blocks = re.split(r"^0x[0-9a-f]+\n", out, flags=re.M)[1:]
    assert len(blocks) == len(addrs), (len(blocks), len(addrs))
    chains = []
    for b in blocks:
        ls = b.rstrip("\n").split("\n")
        frames = []
        for i in range(0, len(ls) - 1, 2):
            # Inlined frames carry short names; the outermost one its full path (kept whole).
            name = ls[i] if i == len(ls) - 2 else ls[i].split("<")[0]
            frames.append((name, ls[i + 1].split("/src/")[-1].split(":")[0]))
        chains.append(frames)
    return chains


def stage_of_callee(name, f):
    """The stage of a frame called from the integrator or `render_tile`, or None."""
    if f.endswith("sampling/sampler.rs"):
        return "Sobol sampler (next_1d, next_2d)"
    if f.endswith("film.rs"):
        return "film accumulation (per-sample statistics, block joins)"
    if "camera/" in f:
        return "camera ray generation"
    if "geometry/" in f:
        return "intersection (analytic sphere)"
    if "brdf/" in f:
        # `sample_at` etc. are `sample` given the vertex's precomputed terms of ω_o (`outgoing`).
        # The batch's lane versions (formerly `sample_at_lanes`, …) count as the one-vertex method.
        name = name.removesuffix("_lanes").removesuffix("_at")
        for k in ("sample", "eval", "pdf"):
            if name.endswith(k):
                return "BRDF " + k
        if name.endswith("outgoing"):
            return "BRDF terms of ω_o (outgoing)"
        return "BRDF other"
    if "light/" in f or f.endswith("distribution.rs"):
        # The batch's lane bodies (`sample_each`, …) count as the one-lane method.
        name = name.removesuffix("_lanes").removesuffix("_each")
        if name in ("sample", "prefetch_sample"):
            return "light sample (cutpoint walk, warp, its texel)"
        if name in ("locate", "eval_pdf_located", "eval", "eval_pdf", "pdf"):
            return "light eval/pdf of the BRDF direction (lookup, texel)"
        return "light other"
    return None


def stage(frames):
    names = [n for n, _ in frames]
    files = [f for _, f in frames]
    for i, (n, f) in enumerate(frames):
        # The innermost frame of the integrator: `li_lanes` or one of its stage functions.
        if f.endswith("integrator/path.rs") or "PathTracer::li" in n:
            if n == "power_heuristic":
                return "MIS (power heuristic)"
            if n in ("visible", "offset_origin", "ray_toward", "occluded"):
                return "shadow rays / visibility"
            c = stage_of_callee(*frames[i - 1]) if i > 0 else None
            return c or "integrator (li_lanes and its stages: frames, dot products, lane state, control)"
    for i, (n, f) in enumerate(frames):
        if f.endswith("render.rs") or n.endswith("render_tile"):
            c = stage_of_callee(*frames[i - 1]) if i > 0 else None
            return c or "tile loop"
    outer = names[-1]
    if "sampler::Sampler" in outer:
        return "Sobol sampler (next_1d, next_2d)"
    if "film::" in outer:
        return "film accumulation (per-sample statistics, block joins)"
    if "texel_index" in outer:
        return "light eval/pdf of the BRDF direction (lookup, texel)"
    if "distribution::" in outer or "light::" in outer:
        return "light sample (cutpoint walk, warp, its texel)"
    if "geometry::" in outer:
        return "intersection (analytic sphere)"
    if "microfacet::Microfacet::lambda" in outer:
        return "BRDF Smith Λ (out of line)"
    if "brdf::" in outer:
        for k in ("sample", "eval", "pdf"):
            if outer.endswith("::" + k) or outer.endswith("::" + k + "_at"):
                return "BRDF " + k
        return "BRDF other"
    if "render::" in outer or "rayon" in outer:
        return "tile loop"
    if "camera" in outer:
        return "camera ray generation"
    return "other (" + (files[-1] or outer)[:40] + ")"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("profile", help="callgrind.out file (recorded with --dump-instr=yes)")
    ap.add_argument("binary", help="the profiled reflect binary")
    ap.add_argument("--samples", type=int, required=True, help="samples rendered (pixels x spp)")
    a = ap.parse_args()
    addr_cost, other, calls_into = parse(a.profile)
    addrs = sorted(addr_cost)
    budget = collections.Counter()
    for addr, frames in zip(addrs, inline_chains(a.binary, addrs)):
        budget[stage(frames)] += addr_cost[addr]
    # Functions of other objects (libc): charged to the stage of their heaviest caller.
    for fn, ir in other.items():
        callers = calls_into.get(fn)
        caller = callers.most_common(1)[0][0] if callers else ""
        while caller in other and calls_into.get(caller):  # malloc <- __rdl_alloc <- ...: walk up
            nxt = calls_into[caller].most_common(1)[0][0]
            if nxt == caller:
                break
            caller = nxt
        if "film" in caller or "alloc" in fn or "free" in fn or "malloc" in fn:
            budget["film accumulation (per-sample statistics, block joins)"] += ir
        elif "brdf" in caller:
            budget["BRDF sample"] += ir
        elif "render" in caller:
            budget["tile loop"] += ir
        else:
            budget["libc (" + fn + ")"] += ir
    total = sum(budget.values())
    small = sum(c for c in budget.values() if c < 0.003 * total)
    print("| stage | instructions | per sample | share |")
    print("|---|---|---|---|")
    for k, c in budget.most_common():
        if c >= 0.003 * total:
            print(f"| {k} | {c / 1e6:.1f} M | {c / a.samples:.0f} | {100 * c / total:.1f} % |")
    print(f"| (the rest, each < 0.3 %) | {small / 1e6:.1f} M | {small / a.samples:.0f} | {100 * small / total:.1f} % |")
    print(f"| **total** | {total / 1e6:.1f} M | {total / a.samples:.0f} | 100 % |")


if __name__ == "__main__":
    sys.exit(main())
