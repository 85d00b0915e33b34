#!/usr/bin/env python3
"""Draws docs/figures/normals.png: the human's last human-bend frame, smooth-shaded (per-vertex light, Gouraud)
with three sets of normals: the rest normals carried by `mlsdeform deform` (each vertex's MLS rotation), the
same after `--arap 2` (the refined local rotations), and the normals recomputed from the deformed surface
(area-weighted, `--normals computed`). Prints the angle between each carried set and the normals recomputed
from the surface it shades.

    python3 tools/normals_figure.py [build/tools/mlsdeform] [out.png]
"""
import os
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")


def read_obj(path):
    """Vertices, triangles, and the normal of each vertex (from the `vn` its corners name; None without)."""
    V, VN, F, FN = [], [], [], []
    for line in open(path):
        t = line.split()
        if not t:
            continue
        if t[0] == "v":
            V.append([float(x) for x in t[1:4]])
        elif t[0] == "vn":
            VN.append([float(x) for x in t[1:4]])
        elif t[0] == "f":
            F.append([int(c.split("/")[0]) - 1 for c in t[1:]])
            FN.append([int(c.split("/")[2]) - 1 if c.count("/") == 2 else -1 for c in t[1:]])
    V, F = np.array(V), np.array(F)
    if not VN:
        return V, F, None
    N = np.zeros_like(V)
    N[F.ravel()] = np.array(VN)[np.array(FN).ravel()]
    return V, F, N


def area_normals(V, F):
    n = np.zeros_like(V)
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    for k in range(3):
        np.add.at(n, F[:, k], fn)
    return n / np.linalg.norm(n, axis=1)[:, None]


def deform(program, mesh, extra, workdir):
    """The last frame of human-bend, as the program writes it."""
    out = os.path.join(workdir, "out.obj")
    handles = os.path.join(ROOT, "data", "human_bend.json")
    subprocess.run([program, "deform", "-m", mesh, "-H", handles, "-o", out, "-f", "-q"] + extra, check=True)
    frames = sorted(f for f in os.listdir(workdir) if f.startswith("out_") and f.endswith(".obj"))
    return read_obj(os.path.join(workdir, frames[-1]))


def main(argv):
    program = argv[1] if len(argv) > 1 else os.path.join(ROOT, "build", "tools", "mlsdeform")
    out_png = argv[2] if len(argv) > 2 else os.path.join(ROOT, "docs", "figures", "normals.png")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with tempfile.TemporaryDirectory() as d:
        V, F, _ = read_obj(os.path.join(ROOT, "data", "human_man.obj"))
        rest = os.path.join(d, "rest.obj")
        with open(rest, "w") as o:  # the human with its area-weighted rest normals, one per vertex
            for v in V:
                o.write("v %r %r %r\n" % tuple(float(x) for x in v))
            for n in area_normals(V, F):
                o.write("vn %r %r %r\n" % tuple(float(x) for x in n))
            for f in F:
                o.write("f " + " ".join("%d//%d" % (i + 1, i + 1) for i in f) + "\n")
        panels = []
        for title, extra in [
            ("rest normals turned by\nthe MLS rotations", []),
            ("rest normals turned by\nARAP's rotations (--arap 2)", ["--arap", "2"]),
            ("normals recomputed from\nthe MLS-deformed surface", ["--normals", "computed"]),
        ]:
            W, G, N = deform(
                program, rest if "--normals" not in extra else os.path.join(ROOT, "data", "human_man.obj"), extra, d
            )
            panels.append((title, W, G, N))
    light = np.array([0.35, 0.45, 1.0])
    light /= np.linalg.norm(light)
    fig, axes = plt.subplots(1, 3, figsize=(10.5, 5.2))
    for ax, (title, W, G, N) in zip(axes, panels):
        recomputed = area_normals(W, G)  # from this panel's own deformed surface
        angle = np.degrees(np.arccos(np.clip(np.sum(N * recomputed, axis=1), -1, 1)))
        label = title
        if "recomputed" not in title:
            label += "\nvs recomputed: median %.1f°, p95 %.1f°" % (np.median(angle), np.percentile(angle, 95))
        print(
            title.replace("\n", " ") + ": median %.2f, p95 %.2f degrees" % (np.median(angle), np.percentile(angle, 95))
        )
        order = np.argsort(W[G].mean(axis=1)[:, 2])  # painter's order: far triangles first (viewer on +z)
        shade = 0.2 + 0.8 * np.clip(N @ light, 0, 1)
        ax.tripcolor(W[:, 0], W[:, 1], G[order], shade, shading="gouraud", cmap="bone", vmin=0, vmax=1.15)
        ax.set_title(label, fontsize=9)
        ax.set_aspect("equal")
        ax.axis("off")
    fig.suptitle("human-bend, last frame: smooth shading from each set of normals", fontsize=10)
    fig.tight_layout()
    fig.savefig(out_png, dpi=110)
    print("wrote", out_png)


if __name__ == "__main__":
    main(sys.argv)
