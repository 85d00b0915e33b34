"""The program on 3D Gaussian splat files (docs/splats.md): a 3DGS PLY whose handles all move by one rigid motion,
every splat turned by R (rot_* and f_rest_* against numpy float64 references), every other property bit for bit; a
value its float property cannot hold after the turn refused, nothing written."""
import json
import os
import tempfile

import numpy as np

from support import random_rotation

from .cases_attributes import axis_angle, rotation, run
from .common import CLEAR, EPS, BadError, Skip, Wrong, add, within
from .motions import conditioning, effective_kappa, rotation_bound


SPLAT_PROPS = (
    ["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"]
    + [f"f_rest_{i}" for i in range(45)]
    + ["opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"]
)


def splat_case(program, g, variant):
    """A 3DGS PLY (docs/splats.md) whose point handles (splats named by index) all move by one rigid motion:
    every splat turns by R (rot_* = normalise(q_R q), f_rest by R, the SH least squares of cases_splats),
    keeps its scales, and every other property bit for bit; f_rest near float's maximum whose rotation leaves
    float's range is refused (exit 2), never written as inf."""
    from .cases_splats import hamilton, sh_rotated, sh_tol

    if not program:
        raise Skip("no program (--cli or MLSDEFORM_CLI)")
    n = 40
    rec = np.zeros(n, dtype=[(p, "<f4") for p in SPLAT_PROPS])
    V = g.uniform(-1, 1, (n, 3))
    for i, k in enumerate("xyz"):
        rec[k] = V[:, i]
    for p in SPLAT_PROPS[6:]:
        rec[p] = g.normal(size=n) * (0.3 if p.startswith("f_") else 1)
    if variant == "f_rest near float's maximum":
        for c in range(3):
            for j in range(3):
                rec[f"f_rest_{15 * c + j}"] = np.float32(3.0e38)
    V = np.stack([rec[k] for k in "xyz"], 1).astype(np.float64)
    pts = [0, 7, 15, 22, 31]
    R = random_rotation(g)
    axis, degrees = axis_angle(R)
    R = rotation(axis, degrees)
    t = g.uniform(-1, 1, 3)
    spec = {
        "points": [{"vertex": i} for i in pts],
        "groups": [
            {
                "points": list(range(5)),
                "rotate": {"axis": axis.tolist(), "degrees": degrees, "pivot": [0, 0, 0]},
                "translate": t.tolist(),
            }
        ],
    }
    header = f"ply\nformat binary_little_endian 1.0\nelement vertex {n}\n"
    header += "".join(f"property float {p}\n" for p in SPLAT_PROPS) + "end_header\n"
    with tempfile.TemporaryDirectory() as tmp:
        with open(os.path.join(tmp, "in.ply"), "wb") as fh:
            fh.write(header.encode() + rec.tobytes())
        with open(os.path.join(tmp, "h.json"), "w") as fh:
            json.dump(spec, fh)
        r = run(program, ["deform", "-m", "in.ply", "-H", "h.json", "-o", "out.ply"], tmp)
        sh0 = np.stack([rec[f"f_rest_{i}"] for i in range(45)], 1).astype(np.float64)
        ref_sh = sh_rotated(sh0, np.broadcast_to(R, (n, 3, 3)), 15)
        over = np.abs(ref_sh).max() > float(np.finfo(np.float32).max)
        if r.returncode == 2:
            if over and ("in.ply" in r.stderr or "out.ply" in r.stderr):
                return CLEAR
            raise BadError(f"exit 2: {r.stderr[-300:]}")
        if r.returncode != 0:
            raise BadError(f"exit {r.returncode}: {r.stderr[-300:]}")
        data = open(os.path.join(tmp, "out.ply"), "rb").read()
    body = data.partition(b"end_header\n")[2]
    out = np.frombuffer(body, rec.dtype, count=n)
    if over:
        largest = np.abs(np.stack([out[p] for p in SPLAT_PROPS[9:54]])).max()
        raise Wrong(f"f_rest beyond float's range written (largest {largest})")
    for p in ["nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2", "opacity"]:
        if out[p].tobytes() != rec[p].tobytes():
            raise Wrong(f"{p} not passed through bit for bit")
    V64 = V
    kf, ko, arm = conditioning(V64, V64[pts], None, None, "paper_constant", 2.0, "rigid")
    kappa = effective_kappa(kf, ko, np.float32, ~np.isfinite(kf))
    tolR = rotation_bound(kappa, EPS[np.float32])
    X = np.stack([out[k] for k in "xyz"], 1).astype(np.float64)
    within(X, V64 @ R.T + t, 16 * 21 * EPS[np.float32] * 3 + tolR * arm, "centres")
    q0 = np.stack([rec[f"rot_{i}"] for i in range(4)], 1).astype(np.float64)
    q0 /= np.linalg.norm(q0, axis=1, keepdims=True)
    from .motions import quaternion_of

    want = hamilton(np.broadcast_to(quaternion_of(R), (n, 4)), q0)
    got = np.stack([out[f"rot_{i}"] for i in range(4)], 1).astype(np.float64)
    d = np.minimum(np.linalg.norm(got - want, axis=1), np.linalg.norm(got + want, axis=1))
    # The splat's turn is the frame's rotation: its error tolR (a chord bound, as in motions.check_motion),
    # plus the product's rounding to float (4 eps).
    within(d, np.zeros(n), tolR + 4 * EPS[np.float32], "rot_* = normalise(q_R q)")
    for i in range(3):
        same_bits = out[f"scale_{i}"].tobytes() == rec[f"scale_{i}"].tobytes()
        if not same_bits:
            within(out[f"scale_{i}"].astype(np.float64), rec[f"scale_{i}"].astype(np.float64), 0.0, "rigid scales")
    sh = np.stack([out[f"f_rest_{i}"] for i in range(45)], 1).astype(np.float64)
    # Band l turns by R's error tolR at most l tolR |band| (l <= 3), beside the rotation's own rounding.
    tol = sh_tol(sh0, 15, np.float32) + 3 * np.repeat(tolR[:, None], 45, axis=1) * np.repeat(
        np.linalg.norm(sh0.reshape(n, 3, 15), axis=2), 15, axis=1
    )
    within(sh.ravel(), ref_sh.ravel(), tol.ravel(), "f_rest rotated by R")


def build(args):
    cli = args.cli
    for variant in ("rigid motion", "f_rest near float's maximum"):
        for rep in range(3):

            def f(g, variant=variant):
                return splat_case(cli, g, variant)

            add("cli-splats", f"splat PLY, {variant} #{rep}", f)
