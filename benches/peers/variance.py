#!/usr/bin/env python3
"""Variance per image at equal spp, `reflect` against Mitsuba 3 (guide "Performance notes and their history").

Time to an error is rate × samples needed; `reflect bench` gives the product, this script the second factor
alone: how noisy one image of each renderer is at the same spp, so that an estimator's variance can be told
apart from its speed.

Usage (from the repository root, after `cargo build --release`; Mitsuba set up as in peers.py):

    python3 benches/peers/variance.py [--scenes lambert-grace,beckmann-grace] [--sampler independent|qmc]
                                      [--seeds 16] [--spp 64] [--size 128] [--reflect target/release/reflect]

For each scene, `--seeds` images from each renderer (seeds 1…K): the scene of `scenes/bench-*.toml` (or
`benches/peers/bench-mesh-sky.toml`), found as peers.py finds it, with its map in `../shared/data` beside the
checkout, and its Mitsuba translation (`mitsuba_worker.py`). `--sampler independent`
compares the independent samplers; `qmc` compares `sobol-single` with Mitsuba's `ldsampler`. Per pixel and
channel, the variance across the K images divided by the square of their mean (each renderer's own mean),
averaged over the object's pixels (reflect's mask = 1 and every channel's mean > 0, both renderers on the
same pixels; the framing is the same). The estimate's own noise: a pixel's sample variance over K = 16 images
has a relative standard error √(2/15) ≈ 37 %, and the mean over ~10⁴ pixels brings it to well under 1 %.

Prints per scene and channel the two relative variances and their ratio (ours ÷ Mitsuba: below 1 means our
images are less noisy at equal spp), and the ratio of the means of the two renderers' images (agreement).
"""

import argparse
import os
import subprocess
import sys
import tempfile

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import mitsuba_worker  # noqa: E402  (the one translation of the scenes)
import peers  # noqa: E402  (the scene files and the data folder, as peers.py finds them)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", default="lambert-grace,beckmann-grace")
    ap.add_argument("--sampler", choices=["independent", "qmc"], default="independent")
    ap.add_argument("--seeds", type=int, default=16)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--reflect", default=os.path.join(ROOT, "target", "release", "reflect"))
    a = ap.parse_args()
    if a.seeds < 2:
        sys.exit("error: --seeds must be at least 2 (a variance needs two images)")
    os.environ.setdefault("DRJIT_LIBLLVM_PATH", mitsuba_worker.LLVM)
    try:
        import numpy as np
        import mitsuba as mi
    except ImportError as e:
        sys.exit(f"error: {e}; set up Mitsuba 3 as benches/peers/peers.py says")
    mi.set_variant("llvm_ad_rgb")
    ours_sampler, theirs_sampler = ("independent", "independent") if a.sampler == "independent" \
        else ("sobol-single", "ldsampler")
    data = os.path.abspath(peers.data_dir())
    print(f"{a.size}² pixels, {a.spp} spp, {a.seeds} seeds; reflect `{ours_sampler}` against Mitsuba `{theirs_sampler}`")
    print("| scene | channel | reflect rel. variance | Mitsuba rel. variance | ours ÷ Mitsuba | mean ratio |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for name in a.scenes.split(","):
            toml = peers.scene_file(name)
            ours, mask = [], None
            for s in range(1, a.seeds + 1):
                out = os.path.join(tmp, f"{name}-{s}.exr")
                subprocess.run([a.reflect, "render", toml, "--size", f"{a.size}x{a.size}", "--spp", str(a.spp),
                                "--sampler", ours_sampler, "--seed", str(s), "--out", out, "-q"], check=True)
                img = np.array(mi.Bitmap(out), dtype=np.float64)
                ours.append(img[:, :, :3])
                mask = img[:, :, 3]
            scene = mitsuba_worker.mitsuba_scene(mi, np, name, a.size, a.spp, theirs_sampler, data, tmp)
            theirs = [np.array(mi.render(scene, spp=a.spp, seed=s), dtype=np.float64)[:, :, :3]
                      for s in range(1, a.seeds + 1)]
            o, t = np.stack(ours), np.stack(theirs)
            mo, mt = o.mean(0), t.mean(0)
            sel = (mask > 0.5) & (mo > 0).all(-1) & (mt > 0).all(-1)
            vo = (o.var(0, ddof=1)[sel] / mo[sel] ** 2).mean(0)
            vt = (t.var(0, ddof=1)[sel] / mt[sel] ** 2).mean(0)
            agree = mo[sel].mean(0) / mt[sel].mean(0)
            for c, ch in enumerate("RGB"):
                print(f"| {name} | {ch} | {vo[c]:.5f} | {vt[c]:.5f} | {vo[c] / vt[c]:.3f} | {agree[c]:.4f} |")
            print(f"| {name} | mean | {vo.mean():.5f} | {vt.mean():.5f} | {vo.mean() / vt.mean():.3f} | |")


if __name__ == "__main__":
    main()
