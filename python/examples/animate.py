"""An animation written frame by frame: a bar of 20,000 vertices bent by turning its top end, one session,
one output buffer reused every frame (no copies, no allocation), frames as numbered .npy files.

    python3 python/examples/animate.py out_dir [frames]
"""
import os
import sys
import time

import numpy as np

import mlsdeform


def bar(n_side=20, n_len=50, length=4.0):
    x, y, z = np.meshgrid(
        np.linspace(-0.5, 0.5, n_side), np.linspace(0, length, n_len), np.linspace(-0.5, 0.5, n_side), indexing="ij"
    )
    return np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)


def main(argv):
    if len(argv) not in (2, 3):
        print(__doc__.strip(), file=sys.stderr)
        return 2
    out_dir, frames = argv[1], int(argv[2]) if len(argv) == 3 else 30
    os.makedirs(out_dir, exist_ok=True)
    V = bar()
    bottom = V[V[:, 1] == 0][::7]
    top = V[V[:, 1] == V[:, 1].max()][::7]
    P = np.vstack([bottom, top])
    d = mlsdeform.Deformer(V, points=P)
    X = np.empty_like(V)
    Q = P.copy()
    start = time.perf_counter()
    for f in range(frames):
        a = 0.5 * np.pi * f / max(frames - 1, 1)  # the top end turns up to 90 degrees about z, around (1, 4, 0)
        c, s = np.cos(a), np.sin(a)
        R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
        pivot = np.array([1.0, 4.0, 0.0])
        Q[len(bottom) :] = (top - pivot) @ R.T + pivot
        d.deform(points=Q, out=X)
        np.save(os.path.join(out_dir, f"frame_{f:04d}.npy"), X)
    ms = 1000 * (time.perf_counter() - start) / frames
    print(f"{frames} frames of {len(V)} vertices, {len(P)} handles: {ms:.2f} ms per frame (with the .npy writes)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
