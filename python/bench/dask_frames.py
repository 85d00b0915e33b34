"""Frames/s of mlsdeform.dask.render_animation on the 737,986-vertex spot_loop3 (../shared/data/meshes, or
MLSDEFORM_MESHES) on a LocalCluster: one worker of one thread against two of one thread (and one worker of two
threads: the library's own parallelism), for each output format, with the share of the tasks' time spent writing,
the worker processes' CPU time per frame and the cores they had (CPU time / wall-clock time after the set-up: on a
machine shared with other work, fewer than asked for).

    python3 python/bench/dask_frames.py [frames] [out_dir] [formats, e.g. .npy,.ply]

The handles are docs/cli.md's spot example (4 point handles, offsets growing over the frames). Each
configuration runs twice on a fresh cluster; the faster run is reported (the machine may be shared).
"""
import json
import logging
import os
import shutil
import sys
import tempfile
import time

from dask.distributed import Client, LocalCluster

import mlsdeform
import mlsdeform.dask

HERE = os.path.dirname(os.path.abspath(__file__))
MESHES = os.environ.get("MLSDEFORM_MESHES") or os.path.join(HERE, "..", "..", "..", "shared", "data", "meshes")


def handles_file(path, frames):
    spec = {
        "points": [{"vertex": 380598}, {"vertex": 722737}, {"vertex": 704787}, {"vertex": 219348}],
        "frames": [
            {
                "points": [
                    None,
                    None,
                    {"offset": [0, 0.05 * (i + 1) / frames * 8, 0]},
                    {"offset": [0.04 * (i + 1) / frames * 8, 0, 0]},
                ]
            }
            for i in range(frames)
        ],
    }
    with open(path, "w") as f:
        json.dump(spec, f)


def run(mesh, handles, out, workers, threads, ext):
    best = None
    for _ in range(2):
        shutil.rmtree(out, ignore_errors=True)
        os.makedirs(out)
        with LocalCluster(
            n_workers=workers,
            threads_per_worker=threads,
            processes=True,
            dashboard_address=None,
            silence_logs=logging.ERROR,
        ) as cluster, Client(cluster) as client:
            client.run(lambda: __import__("mlsdeform"))  # workers started and the module loaded: not timed
            s = mlsdeform.dask.render_animation(client, mesh, handles, os.path.join(out, "spot" + ext))
        if best is None or s.seconds < best.seconds:
            best = s
    return best


def main(argv):
    frames = int(argv[1]) if len(argv) > 1 else 32
    out_root = argv[2] if len(argv) > 2 else tempfile.mkdtemp(prefix="mlsdeform-dask-")
    os.makedirs(out_root, exist_ok=True)
    mesh = os.path.join(MESHES, "spot_loop3.ply.gz")
    if not os.path.exists(mesh):
        print(f"{mesh} not found (MLSDEFORM_MESHES names the folder)", file=sys.stderr)
        return 2
    handles = os.path.join(out_root, "spot.json")
    handles_file(handles, frames)
    cpu = next((line.split(":", 1)[1].strip() for line in open("/proc/cpuinfo") if line.startswith("model name")), "?")
    print(
        f"spot_loop3, {frames} frames, {os.cpu_count()} cores ({cpu}), ISA {mlsdeform.active_isa()}; "
        "seconds include reading the mesh and resolving the handles on the client (once)"
    )
    print(
        "| output | workers x threads | frames/s | speed-up | frames/s after set-up | speed-up | CPU ms per frame | "
        "cores used | writing share of task time | run |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for ext in argv[3].split(",") if len(argv) > 3 else (".npy", ".ply"):
        base = None
        for workers, threads in ((1, 1), (2, 1), (1, 2)):
            t = time.perf_counter()
            s = run(mesh, handles, os.path.join(out_root, "out"), workers, threads, ext)
            base = base or (s.frames_per_second, s.frames_per_second_after_setup)
            print(
                f"| {ext} | {workers} x {threads} | {s.frames_per_second:.2f} | "
                f"{s.frames_per_second / base[0]:.2f}x | {s.frames_per_second_after_setup:.2f} | "
                f"{s.frames_per_second_after_setup / base[1]:.2f}x | {1000 * s.cpu_seconds / s.frames:.1f} | "
                f"{s.cpu_seconds / (s.seconds - s.seconds_setup):.2f} | {100 * s.write_share:.0f}% | "
                f"{s.seconds:.1f} s (set-up {s.seconds_setup:.1f} s; tasks: deform {s.seconds_deform:.1f} s, "
                f"write {s.seconds_write:.1f} s; {time.perf_counter() - t:.0f} s with the clusters) |",
                flush=True,
            )
    shutil.rmtree(os.path.join(out_root, "out"), ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
