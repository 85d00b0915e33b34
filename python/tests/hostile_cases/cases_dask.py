"""mlsdeform.dask: an animation whose every frame is one rigid motion of every handle (every output vertex on
that motion's image, and bitwise the direct session's), in each output format and transform; a folder of
meshes with a bad one; the refusals. One in-process cluster per worker process, shared by these cases."""
import json
import os
import tempfile

import numpy as np

import mlsdeform
from mlsdeform import files

from .common import EPS, Skip, VALUE, Wrong, add, refused, same, within
from .motions import conditioning, effective_kappa, rotation_bound
from .scenes import grid_mesh

_client = []


def client():
    if not _client:
        try:
            import logging

            import distributed
        except ImportError:
            raise Skip("no dask.distributed")
        cluster = distributed.LocalCluster(
            n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None, silence_logs=logging.ERROR
        )
        _client.append(distributed.Client(cluster))
    return _client[0]


def rotation(axis, degrees):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    t = np.radians(degrees)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(t) * K + (1 - np.cos(t)) * K @ K


def scene(tmp, g, frames):
    V, F = grid_mesh(10, 10)
    V = V.astype(np.float32).astype(np.float64)
    with open(os.path.join(tmp, "m.obj"), "w") as fh:
        fh.write("".join("v %r %r %r\n" % tuple(float(x) for x in v) for v in V))
        fh.write("".join("f %d %d %d\n" % tuple(int(i) + 1 for i in f) for f in F))
    pts = [0, 9, 45, 90, 99]
    motions = []
    spec = {"points": [{"vertex": i} for i in pts], "groups": [{"points": list(range(5))}], "frames": []}
    for _ in range(frames):
        axis, deg, t = g.normal(size=3), float(g.uniform(10, 175)), g.uniform(-1, 1, 3)
        motions.append((rotation(axis, deg), t))
        spec["frames"].append(
            {
                "groups": [
                    {"rotate": {"axis": axis.tolist(), "degrees": deg, "pivot": [0, 0, 0]}, "translate": t.tolist()}
                ]
            }
        )
    with open(os.path.join(tmp, "m.json"), "w") as fh:
        json.dump(spec, fh)
    return V, pts, motions


def animation_case(g, ext, transform):
    import mlsdeform.dask as mdask

    c = client()
    with tempfile.TemporaryDirectory() as tmp:
        V, pts, motions = scene(tmp, g, 5)
        os.mkdir(os.path.join(tmp, "out"))
        s = mdask.render_animation(
            c,
            os.path.join(tmp, "m.obj"),
            os.path.join(tmp, "m.json"),
            os.path.join(tmp, "out", "a" + ext),
            frames_per_task=2,
            transform=transform,
        )
        names = sorted(os.listdir(os.path.join(tmp, "out")))
        if names != [f"a_{i:04d}{ext}" for i in range(5)] or len(s.written) != 5:
            raise Wrong(f"outputs {names}")
        Vr, _ = files.read_mesh(os.path.join(tmp, "m.obj"))
        anim = files.read_handles(os.path.join(tmp, "m.json"), Vr)
        d = mlsdeform.Deformer(Vr, transform=transform, **anim.session_arguments())
        kf, ko, arm = conditioning(V, V[pts], None, None, "paper_constant", 2.0, transform)
        kappa = effective_kappa(kf, ko, np.float32, ~np.isfinite(kf))
        tolR = rotation_bound(kappa, EPS[np.float32])
        for i, (R, t) in enumerate(motions):
            path = os.path.join(tmp, "out", names[i])
            X = np.load(path) if ext == ".npy" else files.read_mesh(path).vertices
            same(np.asarray(X), d.deform(**anim.targets(i)), f"frame {i}: the direct session's")
            # The exact motion (the bound of motions.check_motion: 16 (J + 16) eps |x| plus the frame's error on
            # its arm).
            within(X, V @ R.T + t, 16 * 21 * EPS[np.float32] * 3 + tolR * 2 * arm, f"frame {i}: the motion")


def build(args):
    for ext in (".npy", ".ply", ".obj"):
        for transform in ("rigid", "similarity", "affine"):

            def f(g, ext=ext, transform=transform):
                animation_case(g, ext, transform)

            add(
                "dask",
                f"render_animation {ext} {transform}",
                f,
                timeout=120,
            )

    def f(g):
        import mlsdeform.dask as mdask

        with tempfile.TemporaryDirectory() as tmp:
            scene(tmp, g, 2)
            os.mkdir(os.path.join(tmp, "out"))
            with open(os.path.join(tmp, "bad.obj"), "w") as fh:
                fh.write("v 1 2\nf 1 2 3\n")
            with open(os.path.join(tmp, "bad.json"), "w") as fh:
                fh.write('{"points": [{"vertex": 0}]}')
            s = mdask.deform_meshes(client(), tmp, os.path.join(tmp, "out"), output_format=".npy")
            if list(s.failed) != [os.path.join(tmp, "bad.obj")] and not any("bad" in k for k in s.failed):
                raise Wrong(f"failed: {s.failed}")
            if sorted(os.listdir(os.path.join(tmp, "out"))) != ["m_0000.npy", "m_0001.npy"]:
                raise Wrong(f"written: {sorted(os.listdir(os.path.join(tmp, 'out')))}")

    add("dask", "deform_meshes: a bad mesh listed, the good one written", f, timeout=120)

    def f(g):
        import mlsdeform.dask as mdask

        with tempfile.TemporaryDirectory() as tmp:
            scene(tmp, g, 2)
            out = os.path.join(tmp, "a.npy")
            open(os.path.join(tmp, "a_0001.npy"), "w").close()
            return refused(
                lambda: mdask.render_animation(client(), os.path.join(tmp, "m.obj"), os.path.join(tmp, "m.json"), out),
                VALUE,
                ["exists", "overwrite"],
            )

    add("dask", "render_animation onto an existing output: refused", f, timeout=120)

    def f(g):
        import mlsdeform.dask as mdask

        with tempfile.TemporaryDirectory() as tmp:
            V, _, _ = scene(tmp, g, 2)
            out = os.path.join(tmp, "a.npy")
            mdask.render_animation(
                client(), os.path.join(tmp, "m.obj"), os.path.join(tmp, "m.json"), out, arap_iterations=2
            )
            # The oracle: a session of the library itself on the mesh's triangles, 2 ARAP iterations.
            Vr, F = files.read_mesh(os.path.join(tmp, "m.obj"))
            anim = files.read_handles(os.path.join(tmp, "m.json"), Vr)
            d = mlsdeform.Deformer(Vr, faces=F.triangles(), arap_iterations=2, **anim.session_arguments())
            for i in range(2):
                same(np.load(os.path.join(tmp, f"a_{i:04d}.npy")), d.deform(**anim.targets(i)), f"frame {i}")

    add("dask", "render_animation with arap_iterations: the library's ARAP session's frames", f, timeout=120)
