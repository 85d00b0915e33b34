"""The deformer's results: bitwise the C++ library's own, against a direct numpy MLS (paper eqs. 1-6), and
the features on top of it (ARAP, RBF centroids, groups of handles, regions).

Run from the build tree with PYTHONPATH=<build>/python (ctest does), or against the installed package.
"""
import os
import subprocess
import tempfile

import numpy as np
import pytest

import mlsdeform
from support import random_rotation, rng, scene


# ---- the C++ library's own results, bitwise ----------------------------------------------------------------

REFERENCE = os.environ.get("MLSDEFORM_PY_REFERENCE")


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("transform", ["rigid", "similarity", "affine"])
@pytest.mark.parametrize("segment_weight", ["paper_constant", "exact_integral"])
def test_bitwise_equal_to_cpp(dtype, transform, segment_weight):
    if not REFERENCE or not os.path.exists(REFERENCE):
        pytest.skip("MLSDEFORM_PY_REFERENCE (the C++ reference program, built as mlsdeform_py_reference) not set")
    g = rng()
    V, P, A, B = (x.astype(dtype) for x in scene(g, n=300, k=5, s=2))
    R = random_rotation(g)
    Q, C, D = ((x @ R.T + 0.1).astype(dtype) for x in (P, A, B))
    Q[0] += dtype(0.2)
    d = mlsdeform.Deformer(
        V, points=P, segments=(A, B), transform=transform, exponent=2.5, segment_weight=segment_weight
    )
    X = d.deform(points=Q, segments=(C, D))
    with tempfile.TemporaryDirectory() as tmp:
        inp, out = os.path.join(tmp, "in.bin"), os.path.join(tmp, "out.bin")
        with open(inp, "wb") as f:
            for x in (V, P, A, B, Q, C, D):
                f.write(np.ascontiguousarray(x, dtype=dtype).tobytes())
        subprocess.run(
            [
                REFERENCE,
                "f" if dtype == np.float32 else "d",
                transform,
                "2.5",
                segment_weight,
                str(len(V)),
                str(len(P)),
                str(len(A)),
                inp,
                out,
            ],
            check=True,
        )
        expected = np.fromfile(out, dtype=dtype).reshape(-1, 3)
    assert X.dtype == dtype
    assert np.array_equal(X, expected)  # the same library call: bitwise


# ---- a direct numpy MLS (paper eqs. 1-6, Sec. 6.1, 6.2 with paper_constant segment weights) -----------------


def direct_mls(V, P, Q, A=None, B=None, C=None, D=None, transform="rigid", u=2.0):
    """Straight from the paper, one vertex at a time, in float64. Returns the result and, per vertex, the
    condition number kappa = |H| / gap of its rotation fit (gap = s2 + sign(det H) s3) or of G (affine)."""
    out, kappa = np.zeros_like(V), np.zeros(len(V))
    for i, v in enumerate(V):
        ps, qs, ws, Ws = [], [], [], []
        for p, q in zip(P, Q):
            ps.append([p])
            qs.append([q])
            ws.append(np.linalg.norm(p - v) ** -u)
            Ws.append(np.array([[1.0]]))
        if A is not None:
            for a, b, c, d in zip(A, B, C, D):
                e = b - a
                t = np.clip((v - a) @ e / (e @ e), 0, 1)
                ps.append([a, b])
                qs.append([c, d])
                ws.append(np.linalg.norm(a + t * e - v) ** -u)
                Ws.append(np.array([[1 / 3, 1 / 6], [1 / 6, 1 / 3]]))  # Sec. 6.2, constant weight
        S = sum(w * W.sum() for w, W in zip(ws, Ws))
        p_star = sum(w * (W.sum(axis=1) @ np.array(pp)) for w, W, pp in zip(ws, Ws, ps)) / S
        q_star = sum(w * (W.sum(axis=1) @ np.array(qq)) for w, W, qq in zip(ws, Ws, qs)) / S
        H, G = np.zeros((3, 3)), np.zeros((3, 3))
        for w, W, pp, qq in zip(ws, Ws, ps, qs):
            ph, qh = np.array(pp) - p_star, np.array(qq) - q_star
            H += w * qh.T @ W @ ph / S
            G += w * ph.T @ W @ ph / S
        vh = v - p_star
        if transform == "affine":
            out[i] = q_star + H @ np.linalg.solve(G, vh)
            kappa[i] = np.linalg.cond(G)
            continue
        U, sv, Wt = np.linalg.svd(H)
        sgn = np.sign(np.linalg.det(U @ Wt))
        R = U @ np.diag([1, 1, sgn]) @ Wt
        mu = np.trace(R.T @ H) / np.trace(G) if transform == "similarity" else 1.0
        out[i] = q_star + mu * R @ vh
        kappa[i] = sv[0] / max(sv[1] + sgn * sv[2], 1e-300)
    return out, kappa


@pytest.mark.parametrize("transform", ["rigid", "similarity", "affine"])
@pytest.mark.parametrize("with_segments", [False, True])
def test_against_direct_numpy_mls(transform, with_segments):
    g = rng()
    V, P, A, B = scene(g, n=150, k=6, s=2 if with_segments else 0)
    R = random_rotation(g)
    Q = P @ R.T + g.normal(scale=0.05, size=P.shape)
    C, D = A @ R.T, B @ R.T
    seg = (A, B) if with_segments else None
    d = mlsdeform.Deformer(V, points=P, segments=seg, transform=transform)
    X = d.deform(points=Q, segments=(C, D) if with_segments else None)
    ref, kappa = direct_mls(V, P, Q, *((A, B, C, D) if with_segments else ()), transform=transform)
    # Both evaluations are backward stable per vertex: the weighted sums carry (J + 16) eps relative error
    # (J pseudo-handles, plus the roundings of the precomputed coefficients), which the rotation fit (or G^-1)
    # amplifies by kappa; |v'| <= 4 in this unit scene. A factor 4 covers both sides and the paths' constants.
    J = len(P) + 2 * len(A)
    tol = 4 * (J + 16) * np.finfo(np.float64).eps * (1 + kappa) * 4
    err = np.linalg.norm(X - ref, axis=1)
    assert np.all(err <= tol), f"worst err/tol {np.max(err / tol):.3g} at vertex {np.argmax(err / tol)}"


def test_arap_iterations_with_faces():
    # A strip of 12 x 6 vertices in the plane z = 0, two triangles per quad; its two short ends are handles.
    nx, ny = 12, 6
    V = np.array([[i / 5, j / 5, 0.0] for i in range(nx) for j in range(ny)])
    F = []
    for i in range(nx - 1):
        for j in range(ny - 1):
            a, b, c, d = i * ny + j, (i + 1) * ny + j, (i + 1) * ny + j + 1, i * ny + j + 1
            F += [[a, b, c], [a, c, d]]
    F = np.array(F)
    ends = [j for j in range(ny)] + [(nx - 1) * ny + j for j in range(ny)]
    P = V[ends]
    Q = P.copy()
    Q[ny:, 2] += 0.8  # lift the far end
    mls = mlsdeform.Deformer(V, points=P).deform(points=Q)
    arap = mlsdeform.Deformer(V, points=P, faces=F, arap_iterations=5).deform(points=Q)
    assert np.array_equal(arap[ends], Q)  # handles at vertices: exact
    assert not np.allclose(arap, mls)
    with pytest.raises(ValueError, match="triangles"):
        mlsdeform.Deformer(V, points=P, arap_iterations=2)
    with pytest.raises(ValueError, match="faces"):
        mlsdeform.Deformer(V, points=P, faces=F[:, :2], arap_iterations=2)
    with pytest.raises(ValueError, match="outside"):
        mlsdeform.Deformer(V, points=P, faces=F + len(V), arap_iterations=2)


def test_arap_acceleration_and_warm_start():
    # The strip of test_arap_iterations_with_faces, its far end lifted in two small steps.
    nx, ny = 12, 6
    V = np.array([[i / 5, j / 5, 0.0] for i in range(nx) for j in range(ny)])
    F = np.array(
        [
            f
            for i in range(nx - 1)
            for j in range(ny - 1)
            for f in (
                [i * ny + j, (i + 1) * ny + j, (i + 1) * ny + j + 1],
                [i * ny + j, (i + 1) * ny + j + 1, i * ny + j + 1],
            )
        ]
    )
    ends = [j for j in range(ny)] + [(nx - 1) * ny + j for j in range(ny)]
    P = V[ends]
    Q1, Q2 = P.copy(), P.copy()
    Q1[ny:, 2] += 0.8
    Q2[ny:, 2] += 0.82  # 0.02 against a diagonal of 2.4: under the warm start's limit of 0.05 of it
    plain = mlsdeform.Deformer(V, points=P, faces=F, arap_iterations=5).deform(points=Q1)
    fast = mlsdeform.Deformer(V, points=P, faces=F, arap_iterations=5, arap_acceleration="anderson")
    accelerated = fast.deform(points=Q1)
    assert np.array_equal(accelerated[ends], Q1)  # handles at vertices: exact
    assert not np.array_equal(accelerated, plain)
    cold = mlsdeform.Deformer(V, points=P, faces=F, arap_iterations=2)
    warm = mlsdeform.Deformer(V, points=P, faces=F, arap_iterations=2, arap_warm_start=True)
    assert np.array_equal(warm.deform(points=Q1), cold.deform(points=Q1))  # the first frame: from MLS
    assert not np.array_equal(warm.deform(points=Q2), cold.deform(points=Q2))  # then from the last result
    with pytest.raises(ValueError, match="arap_acceleration"):
        mlsdeform.Deformer(V, points=P, faces=F, arap_iterations=2, arap_acceleration="fast")


def test_rbf_centroids():
    g = rng()
    V, P, _, _ = scene(g, n=300, k=7)
    Q = P.copy()
    Q[0] += 0.7
    mls = mlsdeform.Deformer(V, points=P).deform(points=Q)
    rbf = mlsdeform.Deformer(V, points=P, centroids="rbf").deform(points=Q)
    assert not np.allclose(mls, rbf)
    # Nothing moved: RBF centroids reproduce affine maps, so the rest pose comes back to rounding: the
    # centroid weights carry (J + 4) eps kappa(M) sum|beta| |q| (docs/api.md), with kappa(M) = 122 for these 7
    # handles and sum|beta|, |q| of order 1: about 3e-13, far below 1e-11 (an error in g would be O(0.1)).
    same = mlsdeform.Deformer(V, points=P, centroids="rbf").deform(points=P)
    assert np.abs(same - V).max() < 1e-11
    with pytest.raises(ValueError, match="centroids"):
        mlsdeform.Deformer(V, points=P, centroids="spline")


def test_transform_handles():
    g = rng()
    V, P, A, B = scene(g, k=5, s=1)
    R = random_rotation(g)
    t, c = np.array([0.2, -0.1, 0.3]), np.array([0.5, 0.0, -0.2])
    d = mlsdeform.Deformer(V, points=P, segments=(A, B))
    # Every handle in one group: the targets are the rest handles under x -> R (x - c) + c + t, and so is
    # the whole mesh (MLS reproduces a rigid motion). Rounding: each coordinate is 3 products and 5 sums of
    # terms below 4 in magnitude, within 8 * 4 eps = 7.1e-15 of exact on either side (library and numpy),
    # so they differ by at most 1.5e-14 < 2e-14. The deformed vertices add the MLS fit's own rounding, a few
    # hundred eps for 6 spread handles (the rigid-reproduction tests in C++ measure below 100 eps), inside
    # 1e-12 = 4500 eps.
    d.transform_handles(points=range(5), segments=[0], rotation=R, translation=t, pivot=c)

    def move(X):
        return (X - c) @ R.T + c + t

    assert np.allclose(d.targets["points"], move(P), rtol=0, atol=2e-14)
    assert np.allclose(d.targets["segments"][0], move(A), rtol=0, atol=2e-14)
    assert np.allclose(d.deform(), move(V), rtol=0, atol=1e-12)
    # Refused motions change nothing: a reflection, an index out of range, a wrong shape.
    before = d.targets
    with pytest.raises(ValueError, match="reflection"):
        d.transform_handles(points=[0], rotation=-np.eye(3))
    with pytest.raises(IndexError, match="point index 7"):
        d.transform_handles(points=[0, 7], rotation=R)
    with pytest.raises(ValueError, match=r"shape \(3, 3\)"):
        d.transform_handles(points=[0], rotation=np.eye(2))
    with pytest.raises(ValueError, match=r"points: expected .*integer indices, found 0\.5"):
        d.transform_handles(points=[0.5])
    assert np.array_equal(d.targets["points"], before["points"])


def test_region():
    g = rng()
    V, P, _, _ = scene(g, n=300, k=6)
    region = np.flatnonzero(V[:, 0] > 0)
    d = mlsdeform.Deformer(V, points=P, region=region)
    X = d.deform(points=P + [0, 0.2, 0])
    outside = np.setdiff1d(np.arange(len(V)), region)
    assert np.array_equal(X[outside], V[outside])  # bitwise at rest
    assert not np.array_equal(X[region], V[region])
    with pytest.raises(ValueError, match="no vertices"):
        mlsdeform.Deformer(V, points=P, region=[])
    with pytest.raises(ValueError, match="vertex 300"):
        mlsdeform.Deformer(V, points=P, region=[0, 300])
