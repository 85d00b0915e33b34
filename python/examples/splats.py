"""Gaussian splats deformed in numpy with the deformer's frames: each splat's centre by MLS, its orientation
composed with its vertex's rotation (quaternion product, normalised), its log-scales offset by log(s) of the
similarity scale, its normal carried by the linear part. 3D Gaussian splatting stores per splat a unit
quaternion rot_0..3 in the order (w, x, y, z) and log-scales scale_0..2; here they are random, on a bar bent
by turning its top end. Writes the splats before and after as one .npz file.

    python3 python/examples/splats.py out.npz
"""
import sys

import numpy as np

import mlsdeform


def quaternion_product(a, b):
    """a b for (n, 4) arrays of (w, x, y, z) quaternions: the rotation b, then a."""
    aw, ax, ay, az = a.T
    bw, bx, by, bz = b.T
    return np.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        axis=1,
    )


def main(argv):
    if len(argv) != 2:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    g = np.random.default_rng(3)
    n = 20000
    centres = g.uniform([-0.5, 0, -0.5], [0.5, 4, 0.5], (n, 3))
    rot = g.normal(size=(n, 4))
    rot /= np.linalg.norm(rot, axis=1)[:, None]
    log_scales = np.log(g.uniform(0.01, 0.05, (n, 3)))
    normals = g.normal(size=(n, 3))
    normals /= np.linalg.norm(normals, axis=1)[:, None]

    # Handles: the two ends of the bar; the top end turned by 60 degrees about z and grown by 1.5.
    P = np.array([[x, y, z] for y in (0.0, 4.0) for x in (-0.5, 0.5) for z in (-0.5, 0.5)])
    a = np.pi / 3
    R = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    Q = P.copy()
    top = P[:, 1] == 4.0
    pivot = np.array([0.0, 4.0, 0.0])
    Q[top] = 1.5 * (P[top] - pivot) @ R.T + pivot + [1.0, 0, 0]

    d = mlsdeform.Deformer(centres, points=P, transform="similarity")
    moved = np.empty_like(centres)
    q = np.empty((n, 4))
    s = np.empty(n)
    L = np.empty((n, 3, 3))
    d.deform(points=Q, out=moved, quaternions=q, scales=s, linear=L)  # preallocated: reusable every frame

    moved_rot = quaternion_product(q, rot)
    moved_rot /= np.linalg.norm(moved_rot, axis=1)[:, None]
    moved_log_scales = log_scales + np.log(s)[:, None]
    moved_normals = mlsdeform.transform_normals(L, normals)
    np.savez(
        argv[1],
        centres=centres,
        rot=rot,
        log_scales=log_scales,
        normals=normals,
        moved_centres=moved,
        moved_rot=moved_rot,
        moved_log_scales=moved_log_scales,
        moved_normals=moved_normals,
    )
    print(f"{n} splats deformed; scales from {s.min():.3f} to {s.max():.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
