"""The Python package's overhead over the C++ library, in one run, at 10^6 items, one thread and all cores:

  1. Deformer.deform(points=Q, out=X) from Python against the same session's C++ deform (timed inside C++, no
     Python in the loop: Deformer._time_cpp_deform) with the same handles into the same X, on 10^6 vertices
     with 10 point handles;
  2. fit_rotations(H, out=R) from Python against the library call it makes, fit_rotations_interleaved, on the
     same H into the same R, timed inside C++ (_time_cpp_fit_rotations); and, to show what numpy's (m, 3, 3)
     layout costs, the library's fit_rotations on a 3 x 3 x m copy of H made beforehand (the lanes' layout).

C++ and Python runs alternate, and each figure is the fastest of its runs (the least disturbed by other load).

    python3 python/bench/overhead.py    (after tools/dev.sh python, or with PYTHONPATH=build/python)
"""
import os
import time

import numpy as np

import mlsdeform
from timing import banner

REPEAT = 7


def best_pair(cpp, py, repeat=REPEAT):
    """The fastest of `repeat` runs of each of cpp() (seconds, timed inside C++) and py(), taken in turn."""
    cpp_times, py_times = [], []
    for _ in range(repeat):
        cpp_times.append(cpp())
        t0 = time.perf_counter()
        py()
        py_times.append(time.perf_counter() - t0)
    return min(cpp_times), min(py_times)


def row(label, cpp, py, extra=""):
    print(f"{label:24} {1e3 * cpp:9.2f} {1e3 * py:9.2f} {100 * (py / cpp - 1):8.1f}%{extra}", flush=True)


def main():
    print(banner())
    print(f"load average {os.getloadavg()[0]:.1f} (1 min)")
    g = np.random.default_rng(1)
    V = g.uniform(-1, 1, (1_000_000, 3))
    P = V[g.choice(len(V), 10, replace=False)]
    Q = P + g.normal(scale=0.1, size=P.shape)
    reps = 3
    print(f"\ndeform(points=Q, out=X), 10^6 vertices, 10 point handles: ms per frame, fastest of {REPEAT} runs")
    print(f"of {reps} frames; C++ = the same session's deform on the same Q into the same X, timed inside C++")
    print(f"{'dtype, threads':24} {'C++':>9} {'Python':>9} {'overhead':>9}")
    for dtype in (np.float32, np.float64):
        for threads in (1, 0):
            d = mlsdeform.Deformer(V.astype(dtype), points=P, threads=threads)
            X = np.empty((len(V), 3), dtype)
            Qt = Q.astype(dtype)
            d.deform(points=Qt, out=X)  # the pages of X and the session's first touch, outside the timing

            def frames():
                for _ in range(reps):
                    d.deform(points=Qt, out=X)

            # _time_cpp_deform gives seconds per frame already.
            cpp, py = best_pair(lambda: d._time_cpp_deform(reps=reps, points=Qt, out=X), frames)
            storage = "precomputed" if d.uses_precomputed_weights else "on the fly"
            row(f"{np.dtype(dtype).name}, {threads or 'all'}", cpp, py / reps, f"   (weights {storage})")
    print(f"\nfit_rotations(H, out=R), 10^6 matrices: ms, fastest of {REPEAT}; C++ = fit_rotations_interleaved on")
    print("the same H into the same R, timed inside C++; planar = fit_rotations on a 3 x 3 x m copy of H")
    print(f"{'dtype, threads':24} {'C++':>9} {'Python':>9} {'overhead':>9}   {'planar':>9}")
    time_cpp = mlsdeform._mlsdeform._time_cpp_fit_rotations
    for dtype in (np.float32, np.float64):
        H = g.normal(size=(1_000_000, 3, 3)).astype(dtype)
        R = np.empty_like(H)
        for threads in (1, 0):
            mlsdeform.fit_rotations(H, out=R, threads=threads)  # R's pages touched outside the timing
            cpp, py = best_pair(
                lambda: time_cpp(H, threads, out=R), lambda: mlsdeform.fit_rotations(H, out=R, threads=threads)
            )
            planar = min(time_cpp(H, threads, out=R, interleaved=False) for _ in range(REPEAT))
            row(
                f"{np.dtype(dtype).name}, {threads or 'all'}",
                cpp,
                py,
                f"   {1e3 * planar:9.2f} (numpy's layout: +{100 * (cpp / planar - 1):.0f}%)",
            )


if __name__ == "__main__":
    main()
