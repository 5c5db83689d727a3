#!/usr/bin/env python3
"""Side-by-side benchmark of `reflect` against Mitsuba 3 (guide "Performance").

Renders the benchmark scenes `scenes/bench-*.toml` and `benches/peers/bench-mesh-sky.toml` with `reflect` and the same scenes with Mitsuba 3's
`llvm_ad_rgb` variant in one run, on the same number of threads, and prints a table of render times,
throughputs, the ratio ours ÷ theirs (time; < 1 means reflect is faster) and the image agreement.

Usage (from the repository root, after `cargo build --release`):

    python3 benches/peers/peers.py [--spp 64] [--runs 3] [--threads 2] [--scenes lambert-grace,...]

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
SCENES = {
    # name: (map, object kind, bsdf)
    "lambert-grace": ("grace_latlong.exr", "sphere", "diffuse"),
    "beckmann-grace": ("grace_latlong.exr", "sphere", "beckmann"),
    "mesh-sky": ("sky_latlong.exr", "icosphere", "diffuse"),
}
SIZE = 512

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


def run_reflect(binary, scene, spp, seed, threads, out):
    """Renders one bench scene; returns the render wall time (s) that reflect prints and the process's
    peak resident set size (MB of 10⁶ bytes, the peak reflect prints: map, BVH, film and all)."""
    cmd = [binary, "render", scene_file(scene), "--spp", str(spp),
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
    """This process's peak RSS in MB (10⁶ bytes): VmHWM of /proc/self/status, which is the peak of the
    address space since exec (ru_maxrss also holds the parent's peak at the spawn); ru_maxrss where
    there is no /proc."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024 / 1e6
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024 / 1e6


def mitsuba_peak_mb(name, spp, threads, tmp):
    """Peak RSS (MB) of a fresh Python process that loads the scene in Mitsuba and renders it once
    (`--peak-of`): the interpreter, numpy and Dr.Jit's LLVM JIT are in it, as they are in any use of
    Mitsuba from Python. The mesh's PLY is written by the caller first, so generating it is not."""
    cmd = [sys.executable, os.path.abspath(__file__), "--peak-of", name, "--spp", str(spp),
           "--threads", str(threads), "--tmp", tmp]
    p = subprocess.run(cmd, capture_output=True, text=True)
    m = re.search(r"peak_mb ([0-9.]+)", p.stdout)
    if p.returncode != 0 or not m:
        sys.exit(f"Mitsuba's memory run failed: {' '.join(cmd)}\n{p.stderr}")
    return float(m.group(1))


def icosphere(n, np):
    """Unit icosphere with 20·4ⁿ triangles (the same surface as reflect's geometry::icosphere)."""
    phi = (1.0 + 5.0 ** 0.5) / 2.0
    v = np.array([[-1, phi, 0], [1, phi, 0], [-1, -phi, 0], [1, -phi, 0], [0, -1, phi], [0, 1, phi],
                  [0, -1, -phi], [0, 1, -phi], [phi, 0, -1], [phi, 0, 1], [-phi, 0, -1], [-phi, 0, 1]], float)
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    f = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
                  [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9],
                  [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]], np.int64)
    for _ in range(n):
        nv = len(v)
        e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
        e.sort(axis=1)
        key = e[:, 0] * nv + e[:, 1]
        uniq, inv = np.unique(key, return_inverse=True)
        a, b = uniq // nv, uniq % nv
        mid = v[a] + v[b]
        mid /= np.linalg.norm(mid, axis=1, keepdims=True)
        v = np.concatenate([v, mid])
        m = (nv + inv).reshape(3, -1)
        m01, m12, m20 = m[0], m[1], m[2]
        f = np.concatenate([np.stack([f[:, 0], m01, m20], 1), np.stack([f[:, 1], m12, m01], 1),
                            np.stack([f[:, 2], m20, m12], 1), np.stack([m01, m12, m20], 1)])
    return v.astype(np.float32), f.astype(np.int32)


def write_ply(path, v, f, np):
    """Binary PLY with vertex normals = positions (smooth unit sphere)."""
    with open(path, "wb") as fh:
        fh.write((f"ply\nformat binary_little_endian 1.0\nelement vertex {len(v)}\n"
                  "property float x\nproperty float y\nproperty float z\n"
                  "property float nx\nproperty float ny\nproperty float nz\n"
                  f"element face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n").encode())
        fh.write(np.concatenate([v, v], 1).astype("<f4").tobytes())
        rec = np.zeros(len(f), dtype=[("n", "u1"), ("i", "<i4", 3)])
        rec["n"], rec["i"] = 3, f
        fh.write(rec.tobytes())


def corner_aligned(img, np):
    """Mitsuba's envmap rows are corner-aligned; a (2H+1)-row bitmap whose row m holds our
    bilinear value at v = m/(2H) makes it look up exactly our function."""
    h = img.shape[0]
    out = np.empty((2 * h + 1,) + img.shape[1:], np.float32)
    out[1::2] = img
    out[2:-1:2] = 0.5 * (img[:-1] + img[1:])
    out[0], out[-1] = img[0], img[-1]
    return out


def mitsuba_scene(mi, np, name, spp, tmp):
    map_file, shape, bsdf = SCENES[name]
    T = mi.ScalarTransform4f
    img = np.array(mi.Bitmap(os.path.join(data_dir(), map_file)), dtype=np.float32)[:, :, :3]
    bsdfs = {
        "diffuse": {"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.8}},
        "beckmann": {"type": "roughconductor", "distribution": "beckmann", "alpha": 0.2, "material": "none",
                     "specular_reflectance": {"type": "rgb", "value": 1.0}, "sample_visible": True},
    }
    d = 5.0 / (1.0 + 0.09) ** 0.5
    scene = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 2},
        "sensor": {
            "type": "orthographic",
            "to_world": T().look_at(origin=[d, 0, 0.3 * d], target=[0, 0, 0], up=[0, 0, 1]) @ T().scale([1.05, 1.05, 1]),
            "film": {"type": "hdrfilm", "width": SIZE, "height": SIZE, "rfilter": {"type": "box"},
                     "pixel_format": "rgb", "component_format": "float32"},
            "sampler": {"type": "independent", "sample_count": spp},
        },
        "emitter": {"type": "envmap", "bitmap": mi.Bitmap(corner_aligned(img, np)),
                    "to_world": T([[0, 0, -1, 0], [1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 1]])},
    }
    if shape == "sphere":
        scene["object"] = {"type": "sphere", "center": [0, 0, 0], "radius": 1.0, "bsdf": bsdfs[bsdf]}
    else:
        ply = os.path.join(tmp, "icosphere8.ply")
        if not os.path.exists(ply):
            write_ply(ply, *icosphere(8, np), np)
        scene["object"] = {"type": "ply", "filename": ply, "face_normals": False, "bsdf": bsdfs[bsdf]}
    return mi.load_dict(scene)


def read_rgb(mi, np, path):
    bmp = mi.Bitmap(path)
    names = [bmp.struct_()[i].name for i in range(bmp.channel_count())]
    a = np.array(bmp)
    return np.stack([a[:, :, names.index(c)] for c in "RGB"], -1)


def block_rms(a, b, np, block=16):
    n = SIZE // block
    c = (np.arange(SIZE) + 0.5) / SIZE * 2.0 - 1.0
    x, y = np.meshgrid(1.05 * c, -1.05 * c)
    inside = (x * x + y * y < 0.98 ** 2).reshape(n, block, n, block).all(axis=(1, 3))
    bm = lambda im: im.reshape(n, block, n, block, 3).mean(axis=(1, 3))[inside]
    ma, mb = bm(a), bm(b)
    return float(np.sqrt(np.mean((ma - mb) ** 2)) / np.mean(mb))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--scenes", default=",".join(SCENES))
    ap.add_argument("--reflect", default=os.path.join(ROOT, "target", "release", "reflect"))
    ap.add_argument("--peak-of", help=argparse.SUPPRESS)  # internal: one Mitsuba render, prints its peak RSS
    ap.add_argument("--tmp", help=argparse.SUPPRESS)
    args = ap.parse_args()
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
        np.array(mi.render(mitsuba_scene(mi, np, args.peak_of, args.spp, args.tmp), spp=args.spp, seed=0))
        import resource
        print(f"peak_mb {own_peak_mb(resource):.1f}")
        return 0
    print(f"reflect: {args.reflect}; Mitsuba {mi.__version__} llvm_ad_rgb; {args.threads} threads, "
          f"512², {args.spp} spp, median of {args.runs}; {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.scenes.split(","):
            out = os.path.join(tmp, f"{name}.exr")
            scene = mitsuba_scene(mi, np, name, args.spp, tmp)
            np.array(mi.render(scene, spp=4, seed=99))  # warm-up: JIT compilation
            # Pairs: reflect with seed s, then Mitsuba with seed s, so that a change of the
            # machine's speed during the run (a shared host) falls on both sides of a pair.
            runs, times, imgs = [], [], []
            for s in range(args.runs):
                runs.append(run_reflect(args.reflect, name, args.spp, s, args.threads, out))
                t = time.perf_counter()
                imgs.append(np.array(mi.render(scene, spp=args.spp, seed=s)))
                times.append(time.perf_counter() - t)
            ours = statistics.median(t for t, _ in runs)
            ours_mb = max(mb for _, mb in runs)
            ours_img = read_rgb(mi, np, out)
            theirs = statistics.median(times)
            ratio = statistics.median(a / b for (a, _), b in zip(runs, times))
            samples = SIZE * SIZE * args.spp
            rms = block_rms(ours_img, imgs[0], np)
            floor = block_rms(imgs[1], imgs[0], np) if len(imgs) > 1 else float("nan")
            theirs_mb = mitsuba_peak_mb(name, args.spp, args.threads, tmp)
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
