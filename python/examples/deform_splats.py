"""Gaussian splats deformed in numpy with the library's splat functions: a bar of 20,000 splats (the 3DGS
per-splat arrays: centres, rot_0..3, scale_0..2, f_rest_0..44) bent by turning its top end 90 degrees. The centres
move by MLS (Deformer); the deformer's frames (its rotation at each centre) turn each splat: its quaternion
composed, its spherical harmonics rotated (mlsdeform.rotate_splats; docs/splats.md). python/examples/splats.py
composes the quaternions by hand in numpy instead, for per-point data of the user's own.

    python3 python/examples/deform_splats.py [out.npz]
"""
import sys
import time

import numpy as np

import mlsdeform


def splat_bar(n=20000, length=4.0, seed=7):
    """n splats as 3DGS stores them (float32): centres in a bar along y, unnormalised quaternions w x y z, log
    scales, and degree-3 SH coefficients f_rest channel-major (n, 45)."""
    rng = np.random.default_rng(seed)
    centres = rng.uniform([-0.5, 0, -0.5], [0.5, length, 0.5], size=(n, 3))
    rotations = rng.normal(size=(n, 4)) * rng.uniform(0.5, 2, size=(n, 1))
    log_scales = np.log(0.02) + 0.5 * rng.normal(size=(n, 3))
    sh_rest = 0.1 * rng.normal(size=(n, 45))
    return [a.astype(np.float32) for a in (centres, rotations, log_scales, sh_rest)]


def bend(length=4.0):
    """Handles in two slabs at each end of the bar (two layers hold a slab's rotation as well as its place); the
    top slab turned 90 degrees about z around (1, length, 0)."""
    layers = (0.0, 0.5, length - 0.5, length)
    P = np.array([[x, y, z] for y in layers for x in (-0.5, 0.5) for z in (-0.5, 0.0, 0.5)])
    top = P[:, 1] > length / 2
    c, s, pivot = 0.0, 1.0, np.array([1.0, length, 0.0])
    R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    Q = P.copy()
    Q[top] = (P[top] - pivot) @ R.T + pivot
    return P, Q


def main(argv):
    if len(argv) > 2:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    centres, rotations, log_scales, sh_rest = splat_bar()
    rest_rotations = rotations.copy()
    P, Q = bend()
    start = time.perf_counter()
    d = mlsdeform.Deformer(centres, points=P)
    moved, turns = np.empty_like(centres), np.empty((len(centres), 4), dtype=np.float32)
    d.deform(points=Q, out=moved, quaternions=turns)  # each centre's rotation as a unit quaternion, w x y z
    mlsdeform.rotate_splats(turns, rotations=rotations, log_scales=log_scales, sh_rest=sh_rest, threads=0)
    ms = 1000 * (time.perf_counter() - start)
    # How far each splat turned: the angle between its old and new orientation, 2 acos |<q, q'>|.
    unit = rest_rotations / np.linalg.norm(rest_rotations, axis=1, keepdims=True)
    angle = np.degrees(2 * np.arccos(np.clip(np.abs(np.sum(unit * rotations, axis=1)), 0, 1)))
    top = centres[:, 1] > 3.5
    print(
        f"{len(centres)} splats, {len(P)} handles: {ms:.1f} ms; splats turned by {np.median(angle[~top]):.1f} "
        f"degrees (median below y = 3.5), {np.median(angle[top]):.1f} degrees (median at the top end)"
    )
    if len(argv) == 2:
        np.savez(argv[1], centres=moved, rotations=rotations, log_scales=log_scales, sh_rest=sh_rest, turns=turns)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
