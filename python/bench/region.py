"""Per-frame cost of a region of interest (Deformer(region=...)) against the whole model, on the bundled human
(6,890 vertices, the 6 point handles of data/human_bend.json, both hands moved; rigid, float32, one thread,
timed inside C++): the right forearm (a compact region, a short ring) and the first 3,000 and 6,000 vertices
by index (scattered over the body: a ring of hundreds to thousands of vertices), with and without the faces
(which decide the ring: outside vertices sharing a triangle, or among the 8 nearest of a region vertex).

    python3 python/bench/region.py    (after tools/dev.sh python, or with PYTHONPATH=build/python)
"""
import os

import numpy as np

import mlsdeform
from timing import banner, cpp_seconds_per_frame

HERE = os.path.dirname(os.path.abspath(__file__))


def human():
    V, F = [], []
    with open(os.path.join(HERE, "..", "..", "data", "human_man.obj")) as f:
        for line in f:
            if line.startswith("v "):
                V.append([float(x) for x in line.split()[1:4]])
            elif line.startswith("f "):
                idx = [int(w.split("/")[0]) - 1 for w in line.split()[1:]]
                F += [[idx[0], idx[i], idx[i + 1]] for i in range(1, len(idx) - 1)]
    return np.array(V, dtype=np.float32), np.array(F)


def main():
    print(banner())
    V, F = human()
    P = V[[1337, 3215, 3386, 411, 5906, 2445]]
    Q = P.copy()
    Q[4] += [0.1, 0.3, 0.2]
    Q[5] += [-0.1, 0.3, 0.2]
    forearm = np.flatnonzero(np.linalg.norm(V - V[2445], axis=1) < 0.3)
    regions = [
        ("whole model", None),
        (f"right forearm ({len(forearm)})", forearm),
        ("range(3000)", np.arange(3000)),
        ("range(6000)", np.arange(6000)),
    ]
    print("\nms per frame (best of 5 runs of 50 frames), weight storage, memory_bytes")
    print(f"{'region':22} {'faces':>5} {'ms':>8} {'storage':>12} {'MiB':>6}")
    for name, region in regions:
        for faces in (None, F):
            if region is None and faces is not None:
                continue
            d = mlsdeform.Deformer(V, points=P, faces=faces, region=region, threads=1)
            ms = 1e3 * cpp_seconds_per_frame(d, reps=50, repeat=5, warmup=10, points=Q)
            storage = "precomputed" if d.uses_precomputed_weights else "on the fly"
            print(
                f"{name:22} {'yes' if faces is not None else 'no':>5} {ms:8.3f} {storage:>12} "
                f"{d.memory_bytes / 2**20:6.1f}"
            )


if __name__ == "__main__":
    main()
