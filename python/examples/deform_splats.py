"""Gaussian splats deformed in numpy: a bar of 20,000 splats (the 3DGS per-splat arrays: centres, rot_0..3,
scale_0..2, f_rest_0..44) bent by turning its top end 90 degrees. The centres move by MLS (Deformer); each splat
turns by the MLS rotation at its centre: its quaternion composed, its spherical harmonics rotated
(mlsdeform.rotate_splats). The rotations here are the MLS fit at each centre, computed from the handles with
mlsdeform.fit_rotations (the rigid MLS rotation of the paper's Algorithm 1, w = |p - v|^-2).

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


def mls_rotations(P, Q, X, exponent=2.0):
    """The rigid MLS rotation at each point of X (rest pose) for handles P moved to Q: the rotation maximising
    trace(R^T H) with H = sum_j w_j (q_j - q*)(p_j - p*)^T, w_j = |p_j - x|^-exponent, p* and q* the weighted
    centroids."""
    w = np.sum((X[:, None, :] - P[None, :, :]) ** 2, axis=2) ** (-exponent / 2)
    w /= w.sum(axis=1, keepdims=True)
    p_hat = P[None, :, :] - (w @ P)[:, None, :]
    q_hat = Q[None, :, :] - (w @ Q)[:, None, :]
    H = np.einsum("nk,nki,nkj->nij", w, q_hat, p_hat)
    return mlsdeform.fit_rotations(H)


def to_quaternions(R):
    """Unit quaternions w x y z of rotation matrices (n, 3, 3) (Shepperd: divide by the largest component)."""
    t = np.trace(R, axis1=1, axis2=2)
    case = np.argmax(np.stack([t, R[:, 0, 0], R[:, 1, 1], R[:, 2, 2]], axis=1), axis=1)
    q = np.empty((len(R), 4))
    s = R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0], R[:, 1, 0] - R[:, 0, 1]  # 4 w x, 4 w y, 4 w z
    a = R[:, 0, 1] + R[:, 1, 0], R[:, 0, 2] + R[:, 2, 0], R[:, 1, 2] + R[:, 2, 1]  # 4 x y, 4 x z, 4 y z
    diag = (
        1 + t,
        1 + R[:, 0, 0] - R[:, 1, 1] - R[:, 2, 2],
        1 - R[:, 0, 0] + R[:, 1, 1] - R[:, 2, 2],
        1 - R[:, 0, 0] - R[:, 1, 1] + R[:, 2, 2],
    )
    # per case: the largest component (from the diagonal), then the other three (from s and a) divided by 4 x it
    others = [(s[0], s[1], s[2]), (s[0], a[0], a[1]), (s[1], a[0], a[2]), (s[2], a[1], a[2])]
    for c in range(4):
        m = case == c
        big = np.sqrt(np.maximum(diag[c][m], 0)) / 2
        q[m] = np.insert(np.stack([x[m] / (4 * big) for x in others[c]], axis=1), c, big, axis=1)
    return q


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
    moved = mlsdeform.Deformer(centres, points=P).deform(points=Q)
    turns = to_quaternions(mls_rotations(P, Q, centres.astype(np.float64))).astype(np.float32)
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
