#!/usr/bin/env python3
"""Embree 4 closest-hit throughput on the BVH benchmark's rays (the peer of `cargo bench --bench bvh`).

The same workload as benches/bvh.rs: unit icospheres of 20·4ⁿ triangles (n = 5: 20,480; n = 8:
1,310,720), built by subdividing an icosahedron and projecting its vertices onto the sphere; 2^20
rays with origins uniform in [−2, 2]³, "box" directions uniform on the sphere, "aimed" directions
toward a uniform point inside the unit ball. Closest hit through `embreex` (Embree 4 with its
AVX2/AVX-512 kernels), the rays split into `--threads` equal parts traced by that many Python
threads (embreex releases the GIL while Embree traces). The rays are not the same numbers as the
Rust bench's (another generator), only the same distributions; the hit fractions are printed for
comparison. Build time is that of the scene's commit (Embree's BVH, build quality medium).
`rtcIntersect1` returns t, barycentrics, the geometric normal and the primitive's ids: set its figures beside the
Rust bench's `box_primitive` and `aimed_primitive` rows (`SceneGeometry::intersect_primitive`, the same question),
not beside `box` and `aimed`, which also build the renderer's hit record with its shading normal.

Usage: python3 benches/peers/embree_bvh.py [--levels 5,8] [--runs 3] [--threads 2]
(needs `pip install embreex numpy`).
"""

import argparse
import statistics
import sys
import threading
import time


def icosphere(np, levels):
    t = (1.0 + 5 ** 0.5) / 2.0
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
         (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
         (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
         (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    verts = np.array(v, dtype=np.float64)
    verts /= np.linalg.norm(verts, axis=1, keepdims=True)
    faces = np.array(f, dtype=np.int64)
    for _ in range(levels):
        # One midpoint per edge, shared by the two faces of the edge.
        edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
        key = np.sort(edges, axis=1)
        uniq, inv = np.unique(key, axis=0, return_inverse=True)
        mid = verts[uniq[:, 0]] + verts[uniq[:, 1]]
        mid /= np.linalg.norm(mid, axis=1, keepdims=True)
        base = len(verts)
        verts = np.concatenate([verts, mid])
        n = len(faces)
        m01, m12, m20 = (base + inv.reshape(-1)[k * n:(k + 1) * n] for k in range(3))
        a, b, c = faces[:, 0], faces[:, 1], faces[:, 2]
        faces = np.concatenate([np.stack(s, axis=1) for s in
                                ((a, m01, m20), (b, m12, m01), (c, m20, m12), (m01, m12, m20))])
    return verts.astype(np.float32), faces


def rays(np, kind, n, seed):
    rng = np.random.default_rng(seed)
    o = rng.uniform(-2.0, 2.0, (n, 3))
    if kind == "box":
        z = rng.uniform(-1.0, 1.0, n)
        phi = rng.uniform(0.0, 2.0 * np.pi, n)
        r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
        d = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)
    else:
        p = rng.normal(size=(n, 3))
        p *= (rng.uniform(0.0, 1.0, n) ** (1 / 3) / np.linalg.norm(p, axis=1))[:, None]
        d = p - o
        d /= np.linalg.norm(d, axis=1, keepdims=True)
    return o.astype(np.float32), d.astype(np.float32)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--levels", default="5,8")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--rays", type=int, default=1 << 20)
    args = ap.parse_args()
    try:
        import numpy as np
        from embreex import rtcore_scene as rtcs
        from embreex.mesh_construction import TriangleMesh
    except ImportError:
        print("needs numpy and embreex: pip install numpy embreex")
        return 0
    print(f"Embree (embreex), {args.threads} threads, {args.rays} rays, median [min–max] of {args.runs} runs")
    print("| triangles | build s | ray set | hit fraction | M rays/s |")
    print("|---|---|---|---|---|")
    for levels in (int(x) for x in args.levels.split(",")):
        verts, faces = icosphere(np, levels)
        faces32 = faces.astype(np.int32)
        t0 = time.perf_counter()
        scene = rtcs.EmbreeScene()
        TriangleMesh(scene, verts, faces32)
        # The BVH is built on the first query (the scene's commit): time a one-ray query.
        scene.run(np.zeros((1, 3), np.float32), np.array([[1, 0, 0]], np.float32))
        build = time.perf_counter() - t0
        for kind in ("box", "aimed"):
            o, d = rays(np, kind, args.rays, 7)
            parts = np.array_split(np.arange(args.rays), args.threads)
            rates, hits = [], 0.0
            for _ in range(args.runs):
                out = [None] * args.threads

                def work(k):
                    out[k] = scene.run(o[parts[k]], d[parts[k]])

                ts = [threading.Thread(target=work, args=(k,)) for k in range(args.threads)]
                t0 = time.perf_counter()
                for t in ts:
                    t.start()
                for t in ts:
                    t.join()
                rates.append(args.rays / (time.perf_counter() - t0) / 1e6)
                hits = float(np.mean(np.concatenate(out) >= 0))
            print(f"| {len(faces):,} | {build:.2f} | {kind} | {hits:.3f} | "
                  f"{statistics.median(rates):.2f} [{min(rates):.2f}–{max(rates):.2f}] |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
