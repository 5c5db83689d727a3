"""Render a Lambertian sphere under the Grace Cathedral probe, project it into SH, and compare the
measured B_lm with the prediction B_lm = albedo · Λ_l ρ̂_l · L_lm (eq. 15; guide "Spherical harmonics:
the terms the commands print").

    pip install ./python matplotlib        # from the checkout
    python examples/python/sphere_grace.py [--out sphere_grace.png] [--lmax 6] [--spp 64]

The render is a `normal-probe` image: pixel (r, c) of a W × H image is the sphere point whose
normal is the lat-long direction of that pixel, seen along the normal, so the image is B(n) on a
lat-long grid and its projection is B_lm. `jitter = true` averages each pixel over its solid
angle, which is exactly what the projection's pixel integration assumes.

The data folder (holding grace_probe.hdr) is found as the CLI finds it: $REFLECT_DATA, else
../shared/data from the current directory, else from this checkout. Matplotlib is optional
(without it the comparison is printed only); the plot is written headless (Agg backend).
"""

import argparse
import os
import sys
from pathlib import Path

import numpy as np

import reflect
from reflect import sh


def data_dir() -> Path:
    env = os.environ.get("REFLECT_DATA")
    places = [Path(env)] if env else [Path.cwd().parent / "shared" / "data",
                                      Path(__file__).resolve().parents[3] / "shared" / "data"]
    for d in places:
        if (d / "grace_probe.hdr").is_file():
            return d
    sys.exit(f"data folder not found: no grace_probe.hdr in {', '.join(map(str, places))}; set REFLECT_DATA")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lmax", type=int, default=6)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--height", type=int, default=48, help="probe image height (width = 2 × height)")
    ap.add_argument("--out", default="sphere_grace.png", help="plot file (PNG)")
    a = ap.parse_args()

    probe = data_dir() / "grace_probe.hdr"
    albedo = 0.8
    scene = {
        "render": {"width": 2 * a.height, "height": a.height, "spp": a.spp, "seed": 1, "max_depth": 1},
        "camera": {"type": "normal-probe", "jitter": True},
        "lighting": {"type": "envmap", "file": str(probe), "mapping": "angular"},
        "objects": [{"shape": "sphere", "brdf": {"type": "lambert", "albedo": albedo}}],
    }
    img = reflect.render(scene)
    print(f"rendered {img.rgb.shape[1]}×{img.rgb.shape[0]} at {a.spp} spp: "
          f"{img.stats['wall_seconds']:.2f} s, {img.stats['samples_per_sec'] / 1e6:.2f} M samples/s")

    b = sh.project(img.rgb, "latlong", lmax=a.lmax)             # measured B_lm, ((L+1)², 3)
    L = sh.project(probe, "angular", lmax=a.lmax)               # lighting L_lm
    f = sh.transfer("lambert", a.lmax)                          # Λ_l ρ̂_l, (L+1,)
    l_of_k = np.array([sh.lm(k)[0] for k in range(len(L))])
    predicted = albedo * f[l_of_k, None] * L                    # eq. 15

    print(f"{'l':>3} {'m':>3} {'measured B (R)':>15} {'predicted (R)':>15}")
    for k in range(len(b)):
        l, m = sh.lm(k)
        print(f"{l:>3} {m:>3} {b[k, 0]:>15.5f} {predicted[k, 0]:>15.5f}")
    rel = np.abs(b - predicted)[:9].max() / np.abs(predicted[0]).max()
    print(f"largest difference over l ≤ 2, relative to B_00: {rel:.2e}")

    try:
        import matplotlib
    except ImportError:
        print("matplotlib is not installed: no plot")
        return
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    k = np.arange(len(b))
    fig, ax = plt.subplots(figsize=(8, 4))
    for ch, colour in enumerate("rgb"):
        ax.plot(k, predicted[:, ch], "-", color=colour, alpha=0.5, label=f"predicted {'RGB'[ch]}")
        ax.plot(k, b[:, ch], "o", color=colour, ms=4, label=f"measured {'RGB'[ch]}")
    for l in range(a.lmax + 1):
        ax.axvline(l * l - 0.5, color="0.85", lw=0.8)
    ax.set_xlabel("k = l(l+1) + m")
    ax.set_ylabel("B_lm")
    ax.set_title(f"Lambertian sphere (albedo {albedo}) under Grace: render vs eq. 15")
    ax.legend(ncol=2, fontsize=7)
    fig.tight_layout()
    fig.savefig(a.out, dpi=120)
    print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
