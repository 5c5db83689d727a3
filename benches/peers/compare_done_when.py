#!/usr/bin/env python3
"""`reflect compare` and `reflect analyze` judged on real Mitsuba 3 renders (guide "Comparing two renderers",
section "Measured against Mitsuba 3").

The question: does `compare` pass correct images at its stated false-alarm rate and fail wrong ones, and does
`analyze` say "CONTRADICTS" for images that contradict their description and not for correct ones, when the
images come from another renderer? The scene is `scenes/bench-lambert-grace.toml` (a Lambert 0.8 unit sphere under
`../shared/data/grace_latlong.exr`, orthographic, 512², 64 spp), translated into Mitsuba's conventions by
`benches/peers/mitsuba_worker.py` (envmap frame, the (2H+1)-row bitmap that removes its corner-aligned lookup,
box film).

Usage (from anywhere, after `cargo build --release --workspace`; Mitsuba 3 in a venv as in `peers.py`):

    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so \\
        /tmp/venv/bin/python benches/peers/compare_done_when.py [--seeds 20] [--spp 64] [--replicates 16]

What it renders and runs (all files in a temporary folder, or `--keep DIR`):
- `reflect render scenes/bench-lambert-grace.toml --seed s` for s < `--seeds` (our Sobol sampler, 64 spp).
- Mitsuba images of the same scene (`llvm_ad_rgb`, `independent` sampler). Mitsuba writes no error layer, and
  its `moment` integrator records second moments of XYZ, not of R, G, B (the per-channel variance needs their
  covariances), so an image here is the mean of `--replicates` k independent Mitsuba renders of spp/k samples
  each (together exactly a render of spp independent samples), and its `stderr.R/G/B` layer is the spread of the
  k replicate means / √k, with k − 1 degrees of freedom, stated in the string attribute `reflect:stderr_dof`
  (guide "Output images"). A pixel whose replicates agree to float rounding (the envmap seen directly: every
  sample of an orthographic pixel sees one direction) has no noise: its stderr is 0 in the images `analyze` reads
  and +inf ("no estimate", left out) in those `compare` reads, because the background differs between the two
  renderers by construction (our piecewise-constant lookup against Mitsuba's bilinear one, guide "Comparing two
  renderers") and `compare` has no other way to leave it out.
- (a) `reflect compare ours_s mitsuba_s` for every seed s: the false alarms against the stated rate `--alpha`
  (binomial probability of at least that many); the same without the aligned bitmap (Mitsuba given our map as
  it is: the +0.12–0.18 % offset of its lookup; `--unaligned` seeds); and `--seeds` mode, ours_s against groups of `--group` Mitsuba
  images without their error layer.
- (b) a 1 % scale error (reflectance 0.808) and the map turned by 2° about +z: `compare` must exit 1, with the
  error layer and with `--seeds` (`--group` seeds of the wrong scene).
- (c) `reflect analyze --lmax 2 --no-diagnosis` (the verdict without the minutes-long search for its cause) with
  the camera flags (`--from … --extent 1.05`), `--brdf lambert --albedo 0.8`
  and the lighting: on the correct images (every seed: the false-contradiction rate), the map turned by 5° and
  2°, the wrong mapping (Grace's square probe `grace_probe.hdr` read as lat-long), the wrong extent (1.25
  instead of 1.05), each with a box film and with Mitsuba's default `gaussian` film, with and without the stderr
  layer. "flagged" = the verdict says CONTRADICTS, or the command refuses the description (exit 2, e.g. the
  silhouette check of a wrong extent).

Prints the markdown tables (and the command, host and load to paste beside them). Exit status 0 once measured,
whatever the outcome: the outcome is the table.
"""

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
DATA = os.path.join(ROOT, "..", "shared", "data")
SCENE = os.path.join(ROOT, "scenes", "bench-lambert-grace.toml")
LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"
sys.path.insert(0, HERE)
import mitsuba_worker  # noqa: E402  (the one translation of the scenes into Mitsuba's conventions)

FROM = "4.789131426105757,0,1.436739427831727"  # 5·normalize(1, 0, 0.3), as in the scene file


def binom_tail(k, n, p):
    """P(X ≥ k) for X ~ Binomial(n, p)."""
    return sum(math.comb(n, j) * p ** j * (1 - p) ** (n - j) for j in range(k, n + 1))


class Mitsuba:
    def __init__(self, args, tmp):
        os.environ.setdefault("DRJIT_LIBLLVM_PATH", LLVM)
        import numpy as np
        import mitsuba as mi
        try:
            mi.set_variant("llvm_ad_rgb")
            self.variant = "llvm_ad_rgb"
        except (AttributeError, ValueError, ImportError):
            mi.set_variant("scalar_rgb")
            self.variant = "scalar_rgb"
        self.mi, self.np, self.args, self.tmp = mi, np, args, tmp
        self.scenes = {}

    def scene(self, **kw):
        key = tuple(sorted(kw.items()))
        if key not in self.scenes:
            self.scenes[key] = mitsuba_worker.mitsuba_scene(
                self.mi, self.np, "lambert-grace", self.args.size, self.args.spp, "independent", DATA, self.tmp, **kw)
        return self.scenes[key]

    def render(self, name, seed, **kw):
        """Writes NAME-SEED.exr (stderr 0 where noise-free), NAME-SEED-cmp.exr (stderr +inf there) and
        NAME-SEED-rgb.exr (no error layer); returns the three paths."""
        np, mi = self.np, self.mi
        k = self.args.replicates
        sc = self.scene(**kw)
        reps = np.stack([np.array(mi.render(sc, spp=self.args.spp // k, seed=seed * 1000 + j), dtype=np.float64)[..., :3]
                         for j in range(k)])
        mean = reps.mean(0)
        se = reps.std(0, ddof=1) / math.sqrt(k)
        exact = se <= 1e-6 * np.abs(mean)
        se[exact] = 0.0
        paths = []
        for suffix, bg in (("", 0.0), ("-cmp", np.inf), ("-rgb", None)):
            path = os.path.join(self.tmp, f"{name}-{seed}{suffix}.exr")
            if bg is None:
                data, names = mean, ["R", "G", "B"]
            else:
                s = se.copy()
                s[exact] = bg
                data, names = np.concatenate([mean, s], -1), ["R", "G", "B", "stderr.R", "stderr.G", "stderr.B"]
            bmp = mi.Bitmap(np.ascontiguousarray(data.astype(np.float32)), channel_names=names)
            if bg is not None:
                bmp.metadata()["reflect:stderr_dof"] = str(k - 1)
            bmp.write(path)
            paths.append(path)
        return paths


def run(cmd):
    p = subprocess.run(cmd, capture_output=True, text=True)
    return p.returncode, p.stdout, p.stderr


def reflect_render(args, seed, tmp):
    out = os.path.join(tmp, f"ours-{seed}.exr")
    if not os.path.exists(out):
        rc, _, err = run([args.reflect, "render", SCENE, "--seed", str(seed), "--threads", str(args.threads),
                          "--out", out])
        if rc != 0:
            sys.exit(f"reflect render failed:\n{err}")
    return out


def compare(args, a, b, seeds=(), extra=()):
    cmd = [args.reflect, "compare", a, b, "--alpha", str(args.alpha), "--json", *extra]
    if seeds:
        cmd += ["--seeds", *seeds]
    rc, out, err = run(cmd)
    if rc == 2:
        return rc, err.strip().splitlines()[-1] if err.strip() else "exit 2", None
    d = json.loads(out)
    return rc, d["reason"], d


def analyze(args, image, lighting, mapping=None, extent="1.05"):
    cmd = [args.reflect, "analyze", image, "--lmax", str(args.lmax), "--from", FROM, "--extent", extent,
           "--brdf", "lambert", "--albedo", "0.8", "--lighting", lighting, "--json", "--no-diagnosis"]
    if mapping:
        cmd += ["--mapping", mapping]
    rc, out, err = run(cmd)
    if rc == 2:
        return True, "refused: " + (err.strip().splitlines()[-1] if err.strip() else "exit 2")
    if rc != 0:
        return None, f"exit {rc}: {err.strip()[-200:]}"
    v = json.loads(out)["verdict"]
    return v["status"] != "consistent", v["line"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--replicates", type=int, default=16)
    ap.add_argument("--group", type=int, default=5, help="Mitsuba seeds per `--seeds` comparison")
    ap.add_argument("--unaligned", type=int, default=10, help="seeds rendered without the aligned bitmap")
    ap.add_argument("--alpha", type=float, default=0.01)
    ap.add_argument("--lmax", type=int, default=2)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--reflect", default=os.path.join(ROOT, "target", "release", "reflect"))
    ap.add_argument("--keep", help="folder for the images (kept); default a temporary one")
    args = ap.parse_args()
    if args.size != 512 or args.spp % args.replicates:
        sys.exit("the scene file is 512²; --spp must be a multiple of --replicates")
    tmp_ctx = None
    if args.keep:
        os.makedirs(args.keep, exist_ok=True)
        tmp = args.keep
    else:
        tmp_ctx = tempfile.TemporaryDirectory()
        tmp = tmp_ctx.name
    m = Mitsuba(args, tmp)
    log = lambda s: print(s, file=sys.stderr, flush=True)
    t0 = time.time()
    n = args.seeds
    ours = [reflect_render(args, s, tmp) for s in range(n)]
    log(f"reflect renders done ({time.time() - t0:.0f} s)")
    good = [m.render("good", s) for s in range(n)]
    log(f"Mitsuba correct images done ({time.time() - t0:.0f} s)")

    rows_cmp = []
    # (a) false alarms, error layer on both sides.
    res = [compare(args, ours[s], good[s][1]) for s in range(n)]
    fa = sum(r[0] == 1 for r in res)
    bad = sum(r[0] == 2 for r in res)
    rows_cmp.append(("correct (aligned bitmap), stderr layers", n, fa, bad, binom_tail(fa, n, args.alpha),
                     next((r[1] for r in res if r[0] != 0), "")))
    # Without the aligned bitmap.
    nu = min(n, args.unaligned)
    unal = [m.render("unaligned", s, aligned=False) for s in range(nu)]
    res = [compare(args, ours[s], unal[s][1]) for s in range(nu)]
    fa = sum(r[0] == 1 for r in res)
    rows_cmp.append(("correct, map given as it is (corner-aligned lookup)", nu, fa, sum(r[0] == 2 for r in res),
                     binom_tail(fa, nu, args.alpha), next((r[1] for r in res if r[0] != 0), "")))
    # --seeds mode: ours_s against groups of Mitsuba images without error layer.
    g = args.group
    groups = [[good[j][2] for j in range(i, i + g)] for i in range(0, n - g + 1, g)]
    res = [compare(args, ours[i], grp[0], seeds=grp[1:]) for i, grp in enumerate(groups)]
    fa = sum(r[0] == 1 for r in res)
    rows_cmp.append((f"correct, --seeds ({g} Mitsuba seeds, no error layer)", len(groups), fa,
                     sum(r[0] == 2 for r in res), binom_tail(fa, len(groups), args.alpha),
                     next((r[1] for r in res if r[0] != 0), "")))
    log(f"(a) done ({time.time() - t0:.0f} s)")

    # (b) wrong images must disagree.
    wrong = {"scale 1 % (reflectance 0.808)": dict(albedo=0.808), "map turned 2° about +z": dict(rotate_z_deg=2.0)}
    rows_wrong = []
    for label, kw in wrong.items():
        imgs = [m.render("w" + str(abs(hash(label)) % 1000), 100 + j, **kw) for j in range(g)]
        rc, reason, _ = compare(args, ours[0], imgs[0][1])
        rows_wrong.append((label, "stderr layers", rc, reason))
        rc, reason, _ = compare(args, ours[0], imgs[0][2], seeds=[x[2] for x in imgs[1:]])
        rows_wrong.append((label, f"--seeds ({g} Mitsuba seeds)", rc, reason))
    log(f"(b) done ({time.time() - t0:.0f} s)")

    # (c) analyze.
    latlong = os.path.join(DATA, "grace_latlong.exr")
    probe = os.path.join(DATA, "grace_probe.hdr")
    gauss = [m.render("gauss", s, rfilter="gaussian") for s in range(n)]
    rot = {d: {f: m.render(f"rot{d}{f}", 200, rotate_z_deg=float(d), rfilter=f) for f in ("box", "gaussian")}
           for d in (5, 2)}
    rows_an = []
    for film, imgs in (("box", good), ("gaussian", gauss)):
        for layer, idx in (("stderr", 0), ("none", 2)):
            res = [analyze(args, imgs[s][idx], latlong) for s in range(n)]
            flagged = sum(r[0] is True for r in res)
            rows_an.append(("correct", film, layer, f"{flagged}/{n}", binom_tail(flagged, n, args.alpha),
                            next((r[1] for r in res if r[0]), res[0][1])))
            cases = [("map turned 5°", rot[5][film][idx], latlong, None, "1.05"),
                     ("map turned 2°", rot[2][film][idx], latlong, None, "1.05"),
                     ("wrong mapping (probe read as lat-long)", imgs[0][idx], probe, "latlong", "1.05"),
                     ("wrong extent (1.25 for 1.05)", imgs[0][idx], latlong, None, "1.25")]
            for label, img, light, mapping, extent in cases:
                f, line = analyze(args, img, light, mapping, extent)
                rows_an.append((label, film, layer, "yes" if f else ("no" if f is False else "error"), None, line))
    log(f"(c) done ({time.time() - t0:.0f} s)")

    host = subprocess.run("lscpu | grep 'Model name'", shell=True, capture_output=True, text=True).stdout.strip()
    load = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    print(f"Mitsuba {m.mi.__version__} {m.variant}; {args.size}², {args.spp} spp "
          f"({args.replicates} replicates of {args.spp // args.replicates}); α {args.alpha}; analyze --lmax {args.lmax}; "
          f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; {host}; {load}; {time.time() - t0:.0f} s")
    print()
    print("| compare: correct images | pairs | disagree (exit 1) | bad input (exit 2) | P(≥ that many at α) | first reason |")
    print("|---|---|---|---|---|---|")
    for r in rows_cmp:
        print(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]} | {r[4]:.3g} | {short(r[5])} |")
    print()
    print("| compare: wrong images | noise of B | exit | reason |")
    print("|---|---|---|---|")
    for r in rows_wrong:
        print(f"| {r[0]} | {r[1]} | {r[2]} {'(disagree)' if r[2] == 1 else '(MISSED)' if r[2] == 0 else ''} | {short(r[3])} |")
    print()
    print("| analyze | film | stderr layer | flagged | P(≥ that many at α) | verdict line (first flagged, else first) |")
    print("|---|---|---|---|---|---|")
    for r in rows_an:
        p = "" if r[4] is None else f"{r[4]:.3g}"
        print(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]} | {p} | {short(r[5])} |")
    if tmp_ctx:
        tmp_ctx.cleanup()
    return 0


def short(s, n=220):
    s = s.replace("|", "\\|").replace("\n", " ")
    return s if len(s) <= n else s[:n - 1] + "…"


if __name__ == "__main__":
    sys.exit(main())
