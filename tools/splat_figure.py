#!/usr/bin/env python3
"""Draws docs/figures/splats.png: splat centres with their three axes (red, green, blue: scale_0..2, each axis
drawn 2 standard deviations long) before and after a bend, the splats turned by the MLS rotation at their
centres, the deformer's frames (python/examples/deform_splats.py's bend, on a sheet of splats so that the axes read).

    PYTHONPATH=build/python python3 tools/splat_figure.py [out.png]
"""
import json
import os
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "python", "examples"))
sys.path.insert(0, HERE)

import deform_splats  # noqa: E402
import figures  # noqa: E402
import mlsdeform  # noqa: E402

AXIS_COLOURS = [[0.85, 0.15, 0.1], [0.1, 0.6, 0.15], [0.1, 0.3, 0.9]]


def axes(centres, rotations, log_scales):
    """Segments from each centre along its three axes, 2 sigma long: one list (a, b) per axis."""
    q = rotations / np.linalg.norm(rotations, axis=1, keepdims=True)
    w, x, y, z = q.T
    R = np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=1),
        ],
        axis=1,
    )
    return [(centres, centres + 2 * np.exp(log_scales[:, [k]]) * R[:, :, k]) for k in range(3)]


def panel(title, centres, rotations, log_scales, handles):
    segments = [
        {"a": a.ravel().tolist(), "b": b.ravel().tolist(), "color": c, "width": 1.2, "label": f"scale_{k} axis"}
        for k, ((a, b), c) in enumerate(zip(axes(centres, rotations, log_scales), AXIS_COLOURS))
    ]
    points = [
        {"xyz": centres.ravel().tolist(), "color": [0.3, 0.3, 0.3], "size": 3, "label": "splat centre"},
        {"xyz": handles.ravel().tolist(), "color": [0.95, 0.55, 0.0], "size": 22, "label": "handle"},
    ]
    return {"title": title, "view": {"elev": 15, "azim": -60}, "meshes": [], "points": points, "segments": segments}


def main(argv):
    out = argv[1] if len(argv) > 1 else os.path.join(HERE, "..", "docs", "figures", "splats.png")
    # A sheet of splats through the bar's middle, all with one orientation and elongated along the bar (scale_1,
    # green), so that the turn each one takes reads at a glance.
    x, y = np.meshgrid(np.linspace(-0.4, 0.4, 5), np.linspace(0.0, 4.0, 21))
    centres = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], axis=1).astype(np.float32)
    n = len(centres)
    rotations = np.tile(np.float32([1, 0, 0, 0]), (n, 1))
    log_scales = np.tile(np.log(np.float32([0.03, 0.07, 0.03])), (n, 1))
    sh_rest = deform_splats.splat_bar(n=n)[3]
    P, Q = deform_splats.bend()
    moved, turns = np.empty_like(centres), np.empty((len(centres), 4), dtype=np.float32)
    mlsdeform.Deformer(centres, points=P).deform(points=Q, out=moved, quaternions=turns)
    after_rot, after_sh = rotations.copy(), sh_rest.copy()
    mlsdeform.rotate_splats(turns, rotations=after_rot, sh_rest=after_sh)
    spec = {
        "title": "Gaussian splats bent by MLS: centres moved, each splat turned by the rotation at its centre",
        "rows": 1,
        "cols": 2,
        "panel_size": [4.2, 5.0],
        "dpi": 110,
        "output": os.path.abspath(out),
        "panels": [
            panel("before", centres, rotations, log_scales, P),
            panel("after (rot_* composed, f_rest_* rotated)", moved, after_rot, log_scales, Q),
        ],
    }
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
        json.dump(spec, f)
    try:
        figures.draw(json.load(open(f.name)))
    finally:
        os.unlink(f.name)
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
