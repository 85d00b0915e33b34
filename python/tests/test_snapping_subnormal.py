"""Regression tests, through the package, for two silent wrong answers: the batched rotation fit at subnormal
scales (NaN from the SIMD lanes where the scalar fit gives a rotation), and snapping decided by the whole
model's size (one stray vertex far away put hundreds of others exactly onto a handle's target).

Run from the build tree with PYTHONPATH=<build>/python (ctest does), or against the installed package.
"""
import os

import numpy as np
import pytest

import mlsdeform

SEED = int(os.environ.get("MLSDEFORM_SEED", "20261124"))

# The subnormal range of each precision: from denorm_min to the smallest normal binade.
SUBNORMAL = {np.float32: (-149, -126), np.float64: (-1074, -1022)}


@pytest.fixture
def each_isa():
    """Yields every instruction set this CPU runs, forced in turn, and restores the one in force."""
    saved = mlsdeform.active_isa()
    try:
        yield mlsdeform.supported_isas()
    finally:
        mlsdeform.set_isa(saved)


def rotation_checks(R, dtype):
    """Finite, orthonormal to 64 eps and det 1 to 96 eps (the accuracy suite's c_o bounds)."""
    eps = np.finfo(dtype).eps
    R64 = R.astype(np.float64)
    assert np.isfinite(R64).all()
    assert np.abs(R64 @ R64.transpose(0, 2, 1) - np.eye(3)).max() <= 64 * eps
    assert np.abs(np.linalg.det(R64) - 1).max() <= 96 * eps


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("method", ["axis_angle", "horn_quaternion"])
def test_fit_rotations_subnormal_scales_every_isa(dtype, method, each_isa):
    lo, hi = SUBNORMAL[dtype]
    g = np.random.default_rng(SEED)
    # The finding: 1e-44 I (float32) gave NaN, and Gaussian H at 1e-42 / 1e-43 did in 963 / 1000 cases.
    tiny = np.ldexp(1.0, lo + 3)
    G = g.normal(size=(1000, 3, 3))
    # Exactly representable at every subnormal scale 2^b: entries on the grid 2^(lo - b) of a matrix scaled to
    # max |H| in [1, 2), so 2^b Q only shifts exponents; the fit normalises by exact powers of two, so its
    # result is bitwise the result for Q itself.
    Q = []
    for b in range(lo, hi + 1):
        for H in G[:8]:
            unit = np.ldexp(H, -int(np.floor(np.log2(np.abs(H).max()))))
            grid = np.ldexp(1.0, lo - b)
            Q.append(np.round(unit / grid) * grid)
    Q = np.array(Q)
    scales = np.repeat(np.arange(lo, hi + 1), 8)
    exact = np.ldexp(Q, scales[:, None, None]).astype(dtype)
    assert (np.ldexp(exact.astype(np.float64), -scales[:, None, None]) == Q).all()  # exactly representable
    for isa in each_isa:
        mlsdeform.set_isa(isa)
        R = mlsdeform.fit_rotations((tiny * np.eye(3)).astype(dtype)[None], method=method)
        assert np.array_equal(R[0], np.eye(3, dtype=dtype)), isa
        for s in [1e-42, 1e-43] if dtype == np.float32 else [1e-310, 1e-320]:
            H = (G * s).astype(dtype)
            R = mlsdeform.fit_rotations(H, method=method)
            rotation_checks(R, dtype)
            # Against the scalar single-matrix fit: both are within the suite's angle bound of the optimum of
            # the same (rounded) H, 2 sqrt(3) 16 eps kappa + 96 eps each, where that optimum is unique.
            eps = np.finfo(dtype).eps
            for Hi, Ri in zip(H[:50], R[:50]):
                unit = np.ldexp(Hi.astype(np.float64), -int(np.floor(np.log2(np.abs(Hi).max()))))
                U, sv, Vt = np.linalg.svd(unit)
                d = np.sign(np.linalg.det(U @ Vt))
                if sv[1] + d * sv[2] <= 0:
                    continue
                kappa = sv[0] / (sv[1] + d * sv[2])
                tol = 2 * ((2 * np.sqrt(3) * 16 * kappa + 96) * eps)
                if tol >= np.pi:
                    continue
                Rs = mlsdeform.fit_rotation(Hi, method=method).astype(np.float64)
                angle = 2 * np.arcsin(min(1.0, np.linalg.norm(Ri.astype(np.float64) - Rs) / np.sqrt(8)))
                assert angle <= tol, (isa, s)
        Rq = mlsdeform.fit_rotations(Q.astype(dtype), method=method)
        Re = mlsdeform.fit_rotations(exact, method=method)
        rotation_checks(Re, dtype)
        assert np.array_equal(Re, Rq), isa


def stray_scene(dtype, n=5000, k=4):
    g = np.random.default_rng(SEED)
    V = g.uniform(-1, 1, (n, 3))
    P = g.uniform(-1, 1, (k, 3))
    V[0] = P[0]  # one vertex on a handle: it must stay exactly on its target
    Q = P + g.uniform(-0.3, 0.3, (k, 3))
    return V.astype(dtype), P.astype(dtype), Q.astype(dtype)


@pytest.mark.parametrize("dtype,strays", [(np.float32, [1e4, 1e5, 1e6]), (np.float64, [1e4, 1e10, 1e13])])
@pytest.mark.parametrize("transform", ["rigid", "similarity", "affine"])
def test_a_stray_vertex_collapses_nothing(dtype, strays, transform):
    # The finding: a 2-unit cloud of 5,000 points with 4 handles and one vertex at x = 1e4 had 808 vertices
    # put exactly on a handle's target in float32, at 1e5 all of them (and in float64 from 1e13 on).
    V, P, Q = stray_scene(dtype)
    n = len(V)
    clean = mlsdeform.Deformer(V, points=P, transform=transform).deform(points=Q)
    on_clean = [i for i in range(n) if (clean[i] == Q).all(axis=1).any()]
    assert on_clean == [0]
    assert len(np.unique(clean, axis=0)) == n
    for x in strays:
        Vs = np.vstack([V, np.array([[x, 0, 0]], dtype=dtype)])
        out = mlsdeform.Deformer(Vs, points=P, transform=transform).deform(points=Q)[:n]
        assert np.isfinite(out).all()
        assert [i for i in range(n) if (out[i] == Q).all(axis=1).any()] == on_clean, x
        assert len(np.unique(out, axis=0)) == n, x  # distinct rest vertices stay distinct
