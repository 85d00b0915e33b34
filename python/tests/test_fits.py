"""The rotation fits: fit_rotations against numpy's SVD (Kabsch), degenerate batches, fit_rotation and
fit_points, out= and out= overlapping H.

Run from the build tree with PYTHONPATH=<build>/python (ctest does), or against the installed package.
"""

import numpy as np
import pytest

import mlsdeform
from support import random_rotation, rng


# ---- batched rotation fits against numpy's SVD (Kabsch) -----------------------------------------------------


def kabsch(H):
    U, s, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(U @ Vt))
    return U @ np.diag([1, 1, d]) @ Vt, s, d


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_fit_rotations_against_svd(dtype):
    g = rng()
    m = 2000
    P = g.normal(size=(m, 8, 3))
    Rt = np.array([random_rotation(g) for _ in range(m)])
    Qp = np.einsum("mij,mkj->mki", Rt, P) + g.normal(scale=0.1, size=P.shape)
    H = np.einsum("mki,mkj->mij", Qp, P).astype(dtype)
    R = mlsdeform.fit_rotations(H)
    assert R.dtype == dtype and R.shape == (m, 3, 3)
    eps = np.finfo(dtype).eps
    for i in range(m):
        Rk, s, d = kabsch(H[i].astype(np.float64))
        kappa = s[0] / (s[1] + d * s[2])
        # The optimum is unique here; each side's angle error is at most c eps kappa (the accuracy suite's
        # bound, 2 sqrt(3) 16 eps kappa + 96 eps), plus the SVD's own few eps.
        tol = (2 * np.sqrt(3) * 16 * kappa + 96) * eps + 64 * np.finfo(np.float64).eps * kappa
        assert np.linalg.norm(R[i] - Rk) <= 2 * tol
        assert np.abs(R[i] @ R[i].T - np.eye(3)).max() <= 64 * eps
        assert abs(np.linalg.det(R[i].astype(np.float64)) - 1) <= 96 * eps


def test_fit_rotations_degenerate_batches():
    g = rng()
    p, q = g.normal(size=3), g.normal(size=3)
    p, q = p / np.linalg.norm(p), q / np.linalg.norm(q)
    H = np.stack(
        [
            np.zeros((3, 3)),
            np.outer(q, p),
            np.eye(3),
            -np.eye(3) @ random_rotation(g),
            np.diag([1.0, 1.0, -1.0]),
            np.diag([3.0, 2.0, 0.0]),
        ]
    )
    R = mlsdeform.fit_rotations(H)
    eps = np.finfo(np.float64).eps
    assert np.array_equal(R[0], np.eye(3))  # H = 0: the identity
    assert np.linalg.norm(R[1] @ p - q) <= 16 * eps  # rank 1: p goes to q
    assert np.abs(R[2] - np.eye(3)).max() <= 16 * eps  # H = I
    for r in R:
        assert np.abs(r @ r.T - np.eye(3)).max() <= 64 * eps and abs(np.linalg.det(r) - 1) <= 96 * eps
    # det H < 0 (diag(1, 1, -1): every rotation about z by 0 is optimal, trace 1) and rank 2: the optimal
    # value trace(R^T H), which is well-conditioned even where R is not unique.
    best = np.trace(kabsch(H[4])[0].T @ H[4])
    assert abs(np.trace(R[4].T @ H[4]) - best) <= 64 * eps
    assert abs(np.trace(R[5].T @ H[5]) - np.trace(kabsch(H[5])[0].T @ H[5])) <= 64 * eps * 5


def test_fit_rotation_and_fit_points():
    g = rng()
    P = g.normal(size=(20, 3))
    R0 = random_rotation(g)
    Q = P @ R0.T + np.array([1.0, 2.0, 3.0])
    for method in ["axis_angle", "horn_quaternion", "horn_matrix", "kanatani", "svd"]:
        R, t = mlsdeform.fit_points(P, Q, method=method)
        assert np.abs(R - R0).max() <= 1e-12 and np.abs(t - [1, 2, 3]).max() <= 1e-12
    R, t, s = mlsdeform.fit_points(P, 2 * Q, np.ones(20), transform="similarity")
    assert abs(s - 2) <= 1e-12
    Pc = P - P.mean(axis=0)
    H = (Q - Q.mean(axis=0)).T @ Pc
    assert np.abs(mlsdeform.fit_rotation(H) - R0).max() <= 1e-12
    assert np.abs(mlsdeform.fit_rotation(H, method="svd") - R0).max() <= 1e-12


def test_fit_rotations_out_and_error_index():
    g = rng()
    H = g.normal(size=(6000, 3, 3))
    R = np.full_like(H, 5.0)
    assert mlsdeform.fit_rotations(H, out=R) is R
    assert np.array_equal(R, mlsdeform.fit_rotations(H))
    for threads in (1, 0):
        bad = H.copy()
        bad[5000, 2, 1] = np.nan
        out = np.full_like(H, 5.0)
        with pytest.raises(ValueError, match=r"H\[5000, 2, 1\] is NaN or infinite"):
            mlsdeform.fit_rotations(bad, out=out, threads=threads)
        assert np.all(out == 5.0)  # nothing written
        with pytest.raises(ValueError, match=r"H\[5000, 2, 1\]"):
            mlsdeform.fit_rotations(bad, threads=threads)
    with pytest.raises(TypeError, match="expected dtype float64"):
        mlsdeform.fit_rotations(H, out=R.astype(np.float32))
    with pytest.raises(ValueError, match=r"expected shape \(6000, 3, 3\)"):
        mlsdeform.fit_rotations(H, out=R[:10])


# ---- out= overlapping the input -------------------------------------------------------------------------------


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("threads", [1, 0])
def test_fit_rotations_out_overlapping_h(dtype, threads):
    # Shifts by one row and across the binding's block boundaries (2048 rows with threads=1, 32768 with more):
    # with out= a view of the same buffer as H, every result must equal the fit of an independent copy of H
    # bitwise (each matrix is fitted alone in its lane, whatever its place in the batch).
    g = rng()
    m = 40000
    for shift in (1, 3, 2047, 2048, 2049, 32768):
        for out_after in (True, False):
            B = g.standard_normal((m + shift, 3, 3)).astype(dtype)
            H, out = (B[:m], B[shift:]) if out_after else (B[shift:], B[:m])
            expected = mlsdeform.fit_rotations(H.copy(), threads=threads)
            r = mlsdeform.fit_rotations(H, out=out, threads=threads)
            assert r is out
            assert np.array_equal(out, expected), (shift, out_after)
    # Exact in place: out is H itself.
    H = g.standard_normal((5000, 3, 3)).astype(dtype)
    expected = mlsdeform.fit_rotations(H, threads=threads)
    assert mlsdeform.fit_rotations(H, out=H, threads=threads) is H
    assert np.array_equal(H, expected)
    # H a reversed or strided view of out's buffer (converted to a C-contiguous copy before anything is written).
    B = g.standard_normal((2 * m, 3, 3)).astype(dtype)
    for H in (B[::-1][:m], B[::2], B[m:][::-1], B[:, ::-1, :][:m]):
        expected = mlsdeform.fit_rotations(H.copy(), threads=threads)
        out = B[:m] if H.base is not None and np.shares_memory(H, B[:m]) else B[m // 2 : m // 2 + m]
        mlsdeform.fit_rotations(H, out=out, threads=threads)
        assert np.array_equal(out, expected)


def test_fit_rotations_overlap_refused_input_untouched():
    # A NaN in H with out= overlapping H: ValueError and the shared buffer unchanged.
    g = rng()
    B = g.standard_normal((3001, 3, 3))
    B[2500, 1, 1] = np.nan
    before = B.copy()
    with pytest.raises(ValueError, match=r"H\[2499, 1, 1\] is NaN"):
        mlsdeform.fit_rotations(B[1:], out=B[:-1])
    assert np.array_equal(B, before, equal_nan=True)
