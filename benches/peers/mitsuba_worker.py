#!/usr/bin/env python3
"""Mitsuba 3 side of `reflect bench` (and of `peers.py`): the one place where the benchmark scenes are
translated into Mitsuba's conventions (docs/src/reference/bench.md, "Peers").

    python3 mitsuba_worker.py JOB_JSON

JOB_JSON: {"scene": "lambert-grace" | "beckmann-grace" | "mesh-sky", "size": N, "ladder": [spp, …],
"seed": S, "sampler": "independent" | "ldsampler", "threads": T, "data": DIR, "out": DIR}

Renders one warm-up (its time, JIT compilation included, is `cold_seconds`), then each spp of the ladder
with `mi.render(scene, spp=…, seed=…)` plus the copy to a NumPy array (which forces the evaluation),
timed with `time.perf_counter`, and writes each image as raw little-endian float32, H × W × 3, row 0 at
the top (`OUT/<scene>-<sampler>-<seed>-<spp>.f32`). Prints one JSON object on stdout:
{"version", "cold_seconds", "points": [{"spp", "seconds", "file"}], "peak_mb"}.

Conventions that differ from reflect's (see the guide): Mitsuba's envmap frame is +y up with u running
clockwise seen from above, so the map gets a reflecting `to_world`; its rows are corner-aligned, so it is
handed a (2H+1)-row bitmap whose bilinear interpolant passes through our texel centres (ours is piecewise
constant: integrals over the map agree, a direction seen directly can differ); its orthographic camera is scaled to
reflect's extent; `path` with max_depth 2 is our max_depth 1.
"""

import json
import os
import sys
import time

LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"
SCENES = {
    # name: (map, object kind, bsdf)
    "lambert-grace": ("grace_latlong.exr", "sphere", "diffuse"),
    "beckmann-grace": ("grace_latlong.exr", "sphere", "beckmann"),
    "mesh-sky": ("sky_latlong.exr", "icosphere", "diffuse"),
}


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
    tmp = path + ".tmp"
    with open(tmp, "wb") as fh:
        fh.write((f"ply\nformat binary_little_endian 1.0\nelement vertex {len(v)}\n"
                  "property float x\nproperty float y\nproperty float z\n"
                  "property float nx\nproperty float ny\nproperty float nz\n"
                  f"element face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n").encode())
        fh.write(np.concatenate([v, v], 1).astype("<f4").tobytes())
        rec = np.zeros(len(f), dtype=[("n", "u1"), ("i", "<i4", 3)])
        rec["n"], rec["i"] = 3, f
        fh.write(rec.tobytes())
    os.replace(tmp, path)


def corner_aligned(img, np):
    """Mitsuba's envmap rows are corner-aligned; in a (2H+1)-row bitmap whose odd rows are ours and
    whose even rows are the means of their neighbours, its bilinear lookup passes through our texel
    centres (v = (j + 1/2)/H) as a linear interpolant, which has our map's integrals."""
    h = img.shape[0]
    out = np.empty((2 * h + 1,) + img.shape[1:], np.float32)
    out[1::2] = img
    out[2:-1:2] = 0.5 * (img[:-1] + img[1:])
    out[0], out[-1] = img[0], img[-1]
    return out


def mitsuba_scene(mi, np, name, size, spp, sampler, data, tmp, albedo=0.8, rotate_z_deg=0.0, rfilter="box",
                  aligned=True):
    """The Mitsuba scene of a reflect benchmark scene (see the module docstring). The keywords make the
    deliberately wrong scenes of `compare_done_when.py`: another Lambert `albedo`, the map turned by
    `rotate_z_deg` about +z (right-handed, in our frame), Mitsuba's default `rfilter="gaussian"`
    instead of our box film, and `aligned=False` to hand Mitsuba the map unchanged (its corner-aligned
    rows then shift it by half a texel in latitude)."""
    map_file, shape, bsdf = SCENES[name]
    T = mi.ScalarTransform4f
    img = np.array(mi.Bitmap(os.path.join(data, map_file)), dtype=np.float32)[:, :, :3]
    bsdfs = {
        "diffuse": {"type": "diffuse", "reflectance": {"type": "rgb", "value": albedo}},
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
            "film": {"type": "hdrfilm", "width": size, "height": size, "rfilter": {"type": rfilter},
                     "pixel_format": "rgb", "component_format": "float32"},
            "sampler": {"type": sampler, "sample_count": spp},
        },
        "emitter": {"type": "envmap", "bitmap": mi.Bitmap(corner_aligned(img, np) if aligned else img),
                    "to_world": T().rotate([0, 0, 1], rotate_z_deg)
                    @ T([[0, 0, -1, 0], [1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 1]])},
    }
    if shape == "sphere":
        scene["object"] = {"type": "sphere", "center": [0, 0, 0], "radius": 1.0, "bsdf": bsdfs[bsdf]}
    else:
        ply = os.path.join(tmp, "icosphere8.ply")
        if not os.path.exists(ply):
            write_ply(ply, *icosphere(8, np), np)
        scene["object"] = {"type": "ply", "filename": ply, "face_normals": False, "bsdf": bsdfs[bsdf]}
    return mi.load_dict(scene)


def own_peak_mb():
    """This process's peak RSS in MB (10⁶ bytes), VmHWM of /proc/self/status; None elsewhere."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024 / 1e6
    except OSError:
        pass
    return None


def main():
    job = json.loads(sys.argv[1])
    os.environ.setdefault("DRJIT_LIBLLVM_PATH", LLVM)
    import numpy as np
    import drjit as dr
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    ladder = job["ladder"]
    # The scene (and its bitmaps) before the thread count: Mitsuba 3.9.1 hangs in mi.Bitmap(...)
    # after dr.set_thread_count(1).
    scene = mitsuba_scene(mi, np, job["scene"], job["size"], ladder[0], job["sampler"], job["data"], job["out"])
    dr.set_thread_count(job["threads"])
    t = time.perf_counter()
    np.array(mi.render(scene, spp=ladder[0], seed=10_000 + job["seed"]))
    cold = time.perf_counter() - t
    points = []
    for spp in ladder:
        t = time.perf_counter()
        img = np.array(mi.render(scene, spp=spp, seed=job["seed"]), dtype=np.float32)
        seconds = time.perf_counter() - t
        path = os.path.join(job["out"], f"{job['scene']}-mitsuba-{job['sampler']}-{job['seed']}-{spp}.f32")
        np.ascontiguousarray(img[:, :, :3]).astype("<f4").tofile(path)
        points.append({"spp": spp, "seconds": seconds, "file": path})
    print(json.dumps({"version": mi.__version__, "cold_seconds": cold, "points": points, "peak_mb": own_peak_mb()}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
