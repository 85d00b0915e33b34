"""The Python package's overhead over the C++ library, in one run:

  1. Deformer.deform(points=Q, out=X) from Python against the same session's C++ deform loop (timed inside
     C++, no Python in the loop), on a 100,000-vertex mesh with 10 point handles, float32 and float64,
     one thread and all cores;
  2. fit_rotations on 10^6 (m, 3, 3) matrices from Python (which transposes to the library's
     structure-of-arrays layout and back) against the batched C++ call alone on the same data.

    python3 python/bench/overhead.py    (after tools/dev.sh python, or with PYTHONPATH=build/python)
"""
import numpy as np

import mlsdeform
from timing import banner, best_of, cpp_seconds_per_frame


def main():
    print(banner())
    g = np.random.default_rng(1)
    V = g.uniform(-1, 1, (100_000, 3))
    P = V[g.choice(len(V), 10, replace=False)]
    Q = P + g.normal(scale=0.1, size=P.shape)
    print("\ndeform, 100,000 vertices, 10 point handles (ms per frame, best of 7 runs of 20 frames)")
    print(f"{'dtype':8} {'threads':>7} {'C++':>9} {'Python':>9} {'overhead':>9}")
    for dtype in (np.float32, np.float64):
        for threads in (1, 0):
            d = mlsdeform.Deformer(V.astype(dtype), points=P, threads=threads)
            X = np.empty((len(V), 3), dtype)
            Qt = Q.astype(dtype)
            reps = 20
            cpp = cpp_seconds_per_frame(d, reps=reps, repeat=7, points=Qt, out=X)

            def frames():
                for _ in range(reps):
                    d.deform(points=Qt, out=X)

            py = best_of(frames) / reps
            print(
                f"{np.dtype(dtype).name:8} {threads or 'all':>7} {1e3 * cpp:9.3f} {1e3 * py:9.3f} "
                f"{100 * (py / cpp - 1):8.1f}%"
            )
    print("\nfit_rotations, 10^6 matrices, one thread (ms, best of 7); Python with out= (no new array)")
    print(f"{'dtype':8} {'C++ batch':>10} {'Python':>9} {'overhead':>9}")
    for dtype in (np.float32, np.float64):
        H = g.normal(size=(1_000_000, 3, 3)).astype(dtype)
        cpp = min(mlsdeform._mlsdeform._time_cpp_fit_rotations(H, 1) for _ in range(7))
        R = np.empty_like(H)
        py_out = best_of(lambda: mlsdeform.fit_rotations(H, out=R))
        py_new = best_of(lambda: mlsdeform.fit_rotations(H))
        print(
            f"{np.dtype(dtype).name:8} {1e3 * cpp:10.2f} {1e3 * py_out:9.2f} {100 * (py_out / cpp - 1):8.1f}%"
            f"   (returning a new array: {1e3 * py_new:.2f} ms, {100 * (py_new / cpp - 1):.1f}%)"
        )


if __name__ == "__main__":
    main()
