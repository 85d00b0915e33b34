"""Scale invariance through the Python package, where it was found broken: ARAP refinement of a 30 x 30 grid
at 1e21 (float32) and 1e160 (float64) returned 897 of 900 vertices NaN, and at 1e-23 (float32) a result off by
0.28 of the model; fit_points at 1e200 refused finite input as "NaN or infinite", naming fit_rotation. And what
a float cannot hold is raised as ValueError, never returned as NaN or infinity.

The reference of a scene at a decimal scale s (rounded once when scaled, as a user's data would be) is the same
scene divided by the power of two 2^j nearest s: an exact division, so the library must return exactly 2^j
times the result for the divided scene (tests/test_scale_invariance.cpp derives why: it computes in frames
scaled by powers of two taken from the input, and rounds the result once; the grids' outputs here stay in the
normal range, so nothing is rounded twice).
"""
import math

import numpy as np
import pytest

import mlsdeform


def grid(n=30):
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    V = np.stack([i / 32, j / 32, ((i * 7 + j * 3) % 5) / 256], axis=-1).reshape(-1, 3)
    a = (i[:-1, :-1] * n + j[:-1, :-1]).ravel()
    F = np.concatenate([np.stack([a, a + 1, a + n + 1], 1), np.stack([a, a + n + 1, a + n], 1)])
    corners = [0, n - 1, n * (n - 1), n * n - 1, n * n // 2 + n // 2]
    P = V[corners]
    Q = P.copy()
    Q[4, 2] += 0.25
    Q[3, 0] += 0.125
    return V, F, P, Q


@pytest.mark.parametrize(
    "dtype,s", [(np.float32, 1e21), (np.float64, 1e160), (np.float32, 1e-23), (np.float64, 1e-300)]
)
def test_arap_grid_far_from_unit_size(dtype, s):
    V, F, P, Q = grid()
    Vs, Ps, Qs = ((x * s).astype(dtype) for x in (V, P, Q))
    X = mlsdeform.Deformer(Vs, points=Ps, faces=F, arap_iterations=2).deform(points=Qs)
    assert np.isfinite(X).all()
    j = round(math.log2(s))

    def down(x):  # exact: stays in the normal range
        return np.ldexp(x, -j).astype(dtype)

    X1 = mlsdeform.Deformer(down(Vs), points=down(Ps), faces=F, arap_iterations=2).deform(points=down(Qs))
    assert np.array_equal(X, np.ldexp(X1, j).astype(dtype))
    # And the scene is deformed, not collapsed: the lifted handle's vertex sits on its target.
    assert np.array_equal(X[465], Qs[4])


def test_fit_points_at_1e200():
    g = np.random.default_rng(3)
    P = g.uniform(-1, 1, (20, 3))
    Q = P @ np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1.0]]).T + 0.5
    Ps, Qs = P * 1e200, Q * 1e200
    for transform in ("rigid", "similarity"):
        r = mlsdeform.fit_points(Ps, Qs, transform=transform)
        r1 = mlsdeform.fit_points(np.ldexp(Ps, -664), np.ldexp(Qs, -664), transform=transform)
        assert np.array_equal(r[0], r1[0])
        assert np.array_equal(r[1], np.ldexp(r1[1], 664))
        if transform == "similarity":
            assert r[2] == r1[2]
        assert np.allclose(r[0] @ P[0] + r[1] / 1e200, Q[0])


def test_fit_points_names_itself_and_the_reason():
    P = np.random.default_rng(4).uniform(-1, 1, (10, 3))
    with pytest.raises(ValueError, match=r"^fit_points: the scale overflows double"):
        mlsdeform.fit_points(P * 1e-300, P * 1e300, transform="similarity")
    with pytest.raises(ValueError, match=r"^fit_points: non-finite coordinate in q"):
        mlsdeform.fit_points(P, P * np.inf)


@pytest.mark.parametrize("arap", [0, 2])
def test_deformed_position_beyond_float_raises(arap):
    # Similarity: two handles 2^-10 apart pulled max / 256 apart scale the scene by about 4 max / 1024 per unit;
    # the third vertex, 1 away, would land near 4 max(float32).
    V = np.array([[0, 0, 0], [2.0**-10, 0, 0], [1, 0.5, 0]], dtype=np.float32)
    F = np.array([[0, 1, 2]])
    d = mlsdeform.Deformer(V, points=V[:2], faces=F, transform="similarity", arap_iterations=arap)
    Q = V[:2].copy()
    Q[1, 0] = np.finfo(np.float32).max / 256
    out = np.full((3, 3), 7, dtype=np.float32)
    with pytest.raises(ValueError, match="vertex 2's deformed position overflows float"):
        d.deform(points=Q, out=out)
    if arap:
        assert (out == 7).all()  # untouched
