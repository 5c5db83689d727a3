#!/usr/bin/env python3
"""Side-by-side benchmark of `reflect` against Mitsuba 3 (guide "Performance notes and their history").

Renders the benchmark scenes `scenes/bench-*.toml` and `benches/peers/bench-mesh-sky.toml` with `reflect` and the same scenes with Mitsuba 3's
`llvm_ad_rgb` variant in one run, on the same number of threads, and prints a table of render times,
throughputs, the ratio ours ÷ theirs (time; < 1 means reflect is faster) and the image agreement.

Usage (from the repository root, after `cargo build --release`):

    python3 benches/peers/peers.py [--size 512] [--spp 64] [--runs 3] [--threads 2] [--scenes lambert-grace,...]

The second workload of the comparison is `--size 128 --spp 128` (a small image at more samples per pixel).

Timing protocol: scene loading is not counted. reflect: the render wall time it prints
(`reflect render` excludes map loading and BVH construction). Mitsuba: one warm-up render (JIT), then
`mi.render(scene, spp, seed)` plus the conversion to a numpy array. The runs alternate (reflect with
seed s, then Mitsuba with seed s, for s < `--runs`), so that a change of the machine's speed during the
run falls on both sides of a pair; the times are the medians of each side, the ratio the median of the
pairs' ratios.

Agreement: both images are cut into 16×16-pixel blocks; blocks whose pixel centres all lie on the
sphere (radius < 0.98 in the image plane) are compared by their RGB means:
rms = sqrt(mean over blocks and channels of (ours − theirs)²) / mean(theirs). Mitsuba's seed-to-seed
value at the same spp is printed beside it (the noise floor).

Memory: the peak resident set size of the `reflect render` process (largest over the runs; the peak it
prints, Linux's VmHWM), and that of a fresh Python process that loads the same scene in Mitsuba and renders
it once (interpreter, numpy and the LLVM JIT included, as in any use of Mitsuba from Python; its VmHWM).
Both are MB of 10⁶ bytes. Not the rusage the parent reads: Linux keeps a process's peak from before its
exec in ru_maxrss, so a child of this script (which holds Mitsuba) would report at least this script's size.

Without the `mitsuba` package it prints how to install it and exits with status 0.
"""

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import mitsuba_worker  # noqa: E402  (the scene translation, one place for this script and `reflect bench`)

SCENES = mitsuba_worker.SCENES
SIZE = 512  # default image side; --size changes it

INSTALL = """The peer benchmark needs Mitsuba 3 (and numpy) in Python:

    python3 -m venv /tmp/peers-venv && /tmp/peers-venv/bin/pip install mitsuba numpy
    apt-get install -y libllvm19            # Mitsuba's LLVM variants (Debian/Ubuntu)
    export DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so
    /tmp/peers-venv/bin/python benches/peers/peers.py

Without it, `reflect render scenes/bench-<name>.toml --threads 2` alone prints reflect's times."""


def data_dir():
    return os.path.join(ROOT, "..", "shared", "data")


def scene_file(name):
    """scenes/bench-<name>.toml, or benches/peers/bench-<name>.toml for the mesh (see its header)."""
    p = os.path.join(ROOT, "scenes", f"bench-{name}.toml")
    return p if os.path.exists(p) else os.path.join(ROOT, "benches", "peers", f"bench-{name}.toml")


def run_reflect(binary, scene, spp, seed, threads, out, size):
    """Renders one bench scene; returns the render wall time (s) that reflect prints and the process's
    peak resident set size (MB of 10⁶ bytes, the peak reflect prints: map, BVH, film and all)."""
    cmd = [binary, "render", scene_file(scene), "--size", f"{size}x{size}", "--spp", str(spp),
           "--seed", str(seed), "--threads", str(threads), "--out", out]
    with tempfile.TemporaryFile("w+") as err:
        p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=err, text=True)
        _, status, usage = os.wait4(p.pid, 0)
        p.returncode = os.waitstatus_to_exitcode(status)
        err.seek(0)
        stderr = err.read()
    if p.returncode != 0:
        sys.exit(f"reflect failed: {' '.join(cmd)}\n{stderr}")
    m = re.search(r"render loop ([0-9.]+) s on", stderr)
    if not m:
        sys.exit(f"cannot find the render time in reflect's output:\n{stderr}")
    # reflect's own peak (VmHWM): the rusage of a child spawned by this process also holds this
    # process's peak at the spawn (Linux keeps the pre-exec peak in ru_maxrss), which with Mitsuba
    # loaded is larger than a sphere render's.
    peak = re.search(r"peak memory ([0-9.]+) MB", stderr)
    return float(m.group(1)), float(peak.group(1)) if peak else usage.ru_maxrss * 1024 / 1e6


def own_peak_mb(resource):
    """This process's peak RSS in MB (10⁶ bytes): VmHWM (mitsuba_worker.own_peak_mb), which is the peak
    of the address space since exec (ru_maxrss also holds the parent's peak at the spawn); ru_maxrss
    where there is no /proc."""
    peak = mitsuba_worker.own_peak_mb()
    return peak if peak is not None else resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024 / 1e6


def mitsuba_peak_mb(name, spp, threads, tmp, size):
    """Peak RSS (MB) of a fresh Python process that loads the scene in Mitsuba and renders it once
    (`--peak-of`): the interpreter, numpy and Dr.Jit's LLVM JIT are in it, as they are in any use of
    Mitsuba from Python. The mesh's PLY is written by the caller first, so generating it is not."""
    cmd = [sys.executable, os.path.abspath(__file__), "--peak-of", name, "--spp", str(spp),
           "--threads", str(threads), "--tmp", tmp, "--size", str(size)]
    p = subprocess.run(cmd, capture_output=True, text=True)
    m = re.search(r"peak_mb ([0-9.]+)", p.stdout)
    if p.returncode != 0 or not m:
        sys.exit(f"Mitsuba's memory run failed: {' '.join(cmd)}\n{p.stderr}")
    return float(m.group(1))


def mitsuba_scene(mi, np, name, spp, tmp, size):
    """The Mitsuba scene of a benchmark scene: the translation lives in mitsuba_worker.py (shared with
    `reflect bench`)."""
    return mitsuba_worker.mitsuba_scene(mi, np, name, size, spp, "independent", data_dir(), tmp)


def read_rgb(mi, np, path):
    bmp = mi.Bitmap(path)
    names = [bmp.struct_()[i].name for i in range(bmp.channel_count())]
    a = np.array(bmp)
    return np.stack([a[:, :, names.index(c)] for c in "RGB"], -1)


def block_rms(a, b, np, block=16):
    size = a.shape[0]
    n = size // block
    c = (np.arange(size) + 0.5) / size * 2.0 - 1.0
    x, y = np.meshgrid(1.05 * c, -1.05 * c)
    inside = (x * x + y * y < 0.98 ** 2).reshape(n, block, n, block).all(axis=(1, 3))
    bm = lambda im: im.reshape(n, block, n, block, 3).mean(axis=(1, 3))[inside]
    ma, mb = bm(a), bm(b)
    return float(np.sqrt(np.mean((ma - mb) ** 2)) / np.mean(mb))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--size", type=int, default=SIZE, help="image side in pixels, a multiple of 16 (default 512)")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--scenes", default=",".join(SCENES))
    ap.add_argument("--reflect", default=os.path.join(ROOT, "target", "release", "reflect"))
    ap.add_argument("--peak-of", help=argparse.SUPPRESS)  # internal: one Mitsuba render, prints its peak RSS
    ap.add_argument("--tmp", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.size < 16 or args.size % 16:
        sys.exit(f"error: --size {args.size}: the image side must be a positive multiple of 16 (16-pixel blocks)")
    if not os.path.exists(LLVM) and "DRJIT_LIBLLVM_PATH" not in os.environ:
        print(f"note: {LLVM} not found; set DRJIT_LIBLLVM_PATH to libLLVM (>= 11)", file=sys.stderr)
    os.environ.setdefault("DRJIT_LIBLLVM_PATH", LLVM)
    try:
        import numpy as np
        import drjit as dr
        import mitsuba as mi
        mi.set_variant("llvm_ad_rgb")
    except (ImportError, AttributeError, ValueError) as e:
        print(f"Mitsuba 3 is not available ({e}).\n\n{INSTALL}")
        return 0
    if not os.path.exists(args.reflect):
        sys.exit(f"{args.reflect} not found: run `cargo build --release` first (or pass --reflect)")
    dr.set_thread_count(args.threads)
    if args.peak_of:
        np.array(mi.render(mitsuba_scene(mi, np, args.peak_of, args.spp, args.tmp, args.size), spp=args.spp, seed=0))
        import resource
        print(f"peak_mb {own_peak_mb(resource):.1f}")
        return 0
    print(f"reflect: {args.reflect}; Mitsuba {mi.__version__} llvm_ad_rgb; {args.threads} threads, "
          f"{args.size}², {args.spp} spp, median of {args.runs}; {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.scenes.split(","):
            out = os.path.join(tmp, f"{name}.exr")
            scene = mitsuba_scene(mi, np, name, args.spp, tmp, args.size)
            np.array(mi.render(scene, spp=4, seed=99))  # warm-up: JIT compilation
            # Pairs: reflect with seed s, then Mitsuba with seed s, so that a change of the
            # machine's speed during the run (a shared host) falls on both sides of a pair.
            runs, times, imgs = [], [], []
            for s in range(args.runs):
                runs.append(run_reflect(args.reflect, name, args.spp, s, args.threads, out, args.size))
                t = time.perf_counter()
                imgs.append(np.array(mi.render(scene, spp=args.spp, seed=s)))
                times.append(time.perf_counter() - t)
            ours = statistics.median(t for t, _ in runs)
            ours_mb = max(mb for _, mb in runs)
            ours_img = read_rgb(mi, np, out)
            theirs = statistics.median(times)
            ratio = statistics.median(a / b for (a, _), b in zip(runs, times))
            samples = args.size * args.size * args.spp
            rms = block_rms(ours_img, imgs[0], np)
            floor = block_rms(imgs[1], imgs[0], np) if len(imgs) > 1 else float("nan")
            theirs_mb = mitsuba_peak_mb(name, args.spp, args.threads, tmp, args.size)
            rows.append((name, ours, samples / ours / 1e6, theirs, samples / theirs / 1e6, ratio, rms, floor,
                         ours_mb, theirs_mb))
            print(f"  {name}: done", file=sys.stderr)
    print()
    print("| scene | reflect s | M samples/s | Mitsuba s | M samples/s | ours ÷ theirs (time) | block RMS vs Mitsuba "
          "| Mitsuba seed-to-seed | reflect peak MB | Mitsuba peak MB |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r[0]} | {r[1]:.2f} | {r[2]:.2f} | {r[3]:.2f} | {r[4]:.2f} | {r[5]:.2f} | {100 * r[6]:.2f} % "
              f"| {100 * r[7]:.2f} % | {r[8]:.0f} | {r[9]:.0f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
