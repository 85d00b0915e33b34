"""Tests of the Python package: results against the C++ library (bitwise) and against a direct numpy MLS,
the batched fit against numpy's SVD, zero-copy and dtype rules, every error path, threads, reference counts.

Run from the build tree with PYTHONPATH=<build>/python (ctest does), or against the installed package.
"""
import gc
import os
import subprocess
import sys
import tempfile
import threading
import tracemalloc

import numpy as np
import pytest

import mlsdeform

SEED = int(os.environ.get("MLSDEFORM_SEED", "20261124"))


def rng():
    return np.random.default_rng(SEED)


def scene(g, n=400, k=6, s=0):
    V = g.uniform(-1, 1, (n, 3))
    P = g.uniform(-1, 1, (k, 3))
    A = g.uniform(-1, 1, (s, 3))
    B = A + g.uniform(-0.5, 0.5, (s, 3))
    return V, P, A, B


def random_rotation(g):
    q = g.normal(size=4)
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


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
    d = mlsdeform.Deformer(V, points=P, segments=(A, B), transform=transform, exponent=2.5,
                           segment_weight=segment_weight)
    X = d.deform(points=Q, segments=(C, D))
    with tempfile.TemporaryDirectory() as tmp:
        inp, out = os.path.join(tmp, "in.bin"), os.path.join(tmp, "out.bin")
        with open(inp, "wb") as f:
            for x in (V, P, A, B, Q, C, D):
                f.write(np.ascontiguousarray(x, dtype=dtype).tobytes())
        subprocess.run([REFERENCE, "f" if dtype == np.float32 else "d", transform, "2.5", segment_weight,
                        str(len(V)), str(len(P)), str(len(A)), inp, out], check=True)
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
    H = np.stack([np.zeros((3, 3)), np.outer(q, p), np.eye(3), -np.eye(3) @ random_rotation(g),
                  np.diag([1.0, 1.0, -1.0]), np.diag([3.0, 2.0, 0.0])])
    R = mlsdeform.fit_rotations(H)
    eps = np.finfo(np.float64).eps
    assert np.array_equal(R[0], np.eye(3))                   # H = 0: the identity
    assert np.linalg.norm(R[1] @ p - q) <= 16 * eps           # rank 1: p goes to q
    assert np.abs(R[2] - np.eye(3)).max() <= 16 * eps         # H = I
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


# ---- zero copy, dtypes, the stateful session -----------------------------------------------------------------

def test_out_is_written_in_place_without_copy():
    g = rng()
    V, P, _, _ = scene(g)
    d = mlsdeform.Deformer(V, points=P)
    out = np.empty_like(V)
    r = d.deform(points=P + 0.1, out=out)
    assert r is out and np.shares_memory(r, out)
    assert np.array_equal(out, d.deform(points=P + 0.1))
    # At the rest pose the map is the identity to rounding.
    assert np.abs(d.deform(out=out) - V).max() <= 1e-12


def test_dtype_rules():
    g = rng()
    V, P, _, _ = scene(g)
    assert mlsdeform.Deformer(V.astype(np.float32), points=P).dtype == np.float32
    assert mlsdeform.Deformer(V, points=P).dtype == np.float64
    assert mlsdeform.Deformer(V.tolist(), points=P.tolist()).dtype == np.float64      # any array-like
    assert mlsdeform.Deformer(np.round(V * 10).astype(int), points=P * 10).dtype == np.float64
    assert mlsdeform.Deformer(V, points=P, dtype=np.float32).dtype == np.float32
    d = mlsdeform.Deformer(V.astype(np.float32), points=P)
    X = d.deform(points=P + 0.1)                        # float64 handles are converted to the session's dtype
    assert X.dtype == np.float32
    assert mlsdeform.fit_rotations(np.zeros((4, 3, 3), np.float32)).dtype == np.float32
    assert mlsdeform.fit_rotations(np.zeros((4, 3, 3), int)).dtype == np.float64


def test_stateful_session():
    g = rng()
    V, P, A, B = scene(g, k=4, s=1)
    d = mlsdeform.Deformer(V, points=P, segments=(A, B))
    assert (d.vertex_count, d.point_count, d.segment_count) == (len(V), 4, 1)
    d.set_point_target(2, P[2] + [0, 0, 0.3])
    d.set_segment_target(0, A[0] + 0.1, B[0] + 0.1)
    Q = P.copy()
    Q[2] += [0, 0, 0.3]
    expected = d.deform(points=Q, segments=(A + 0.1, B + 0.1))
    assert np.array_equal(d.deform(), expected)
    assert np.array_equal(d.targets["points"], Q)
    # A kind not given keeps the session's targets.
    assert np.array_equal(d.deform(points=Q), expected)


# ---- errors: the right exception, the library's message, nothing written ------------------------------------

def test_errors():
    g = rng()
    V, P, _, _ = scene(g, n=50, k=4)
    d = mlsdeform.Deformer(V, points=P)
    out = np.full((50, 3), 7.0)
    cases = [
        (ValueError, "4 point handles at rest but 3", lambda: d.deform(points=P[:3], out=out)),
        (ValueError, "expected shape (n, 3), got (4, 2)", lambda: d.deform(points=P[:, :2], out=out)),
        (ValueError, "non-finite", lambda: d.deform(points=np.full((4, 3), np.nan), out=out)),
        (TypeError, "expected dtype float64", lambda: d.deform(points=P, out=out.astype(np.float32))),
        (ValueError, "expected shape (50, 3), got (49, 3)", lambda: d.deform(points=P, out=out[:49])),
        (ValueError, "C-contiguous", lambda: d.deform(points=P, out=np.asfortranarray(out))),
        (TypeError, "points: expected an (n, 3) array", lambda: d.deform(points="abc", out=out)),
        (TypeError, "out: expected a numpy array", lambda: d.deform(points=P, out=[[0, 0, 0]] * 50)),
        (IndexError, "index 9", lambda: d.set_point_target(9, [0, 0, 0])),
        (ValueError, "expected 3 numbers", lambda: d.set_point_target(0, [0, 0])),
        (ValueError, "unknown value 'bogus'", lambda: mlsdeform.Deformer(V, points=P, transform="bogus")),
        (ValueError, "unknown value 'qr'", lambda: mlsdeform.fit_rotations(np.zeros((1, 3, 3)), method="qr")),
        (ValueError, "no handles", lambda: mlsdeform.Deformer(V)),
        (ValueError, "weight_exponent", lambda: mlsdeform.Deformer(V, points=P, exponent=0.5)),
        (ValueError, "segments: A has 2 rows but B has 1", lambda: mlsdeform.Deformer(V, segments=(P[:2], P[:1]))),
        (ValueError, "NaN or infinite", lambda: mlsdeform.fit_rotations(np.full((2, 3, 3), np.inf))),
        (ValueError, "expected shape (m, 3, 3)", lambda: mlsdeform.fit_rotations(np.zeros((2, 3)))),
        (ValueError, "expected shape (3, 3)", lambda: mlsdeform.fit_rotation(np.zeros((2, 3)))),
        (ValueError, "supports 'rigid' and 'similarity'", lambda: mlsdeform.fit_points(P, P, transform="affine")),
        (ValueError, "set_isa", lambda: mlsdeform.set_isa("neon")),
    ]
    for exc, text, call in cases:
        with pytest.raises(exc) as info:
            call()
        assert text in str(info.value), (text, str(info.value))
    assert np.all(out == 7.0)  # nothing was written by the failed calls
    ro = np.empty((50, 3))
    ro.setflags(write=False)
    with pytest.raises(ValueError, match="read-only"):
        d.deform(points=P, out=ro)


def test_readonly_input_and_views_are_accepted():
    g = rng()
    V, P, _, _ = scene(g, n=60)
    V.setflags(write=False)
    big = np.zeros((len(P), 6))
    big[:, ::2] = P                          # a strided view: converted, not rejected
    d = mlsdeform.Deformer(V, points=big[:, ::2])
    assert np.abs(d.deform(points=P) - V).max() <= 1e-12


# ---- threads and reference counts ----------------------------------------------------------------------------

def test_two_sessions_in_two_threads():
    g = rng()
    sessions, handles, expected = [], [], []
    for _ in range(2):
        V, P, _, _ = scene(g, n=3000, k=8)
        Q = P + g.normal(scale=0.1, size=P.shape)
        d = mlsdeform.Deformer(V, points=P, threads=1)
        sessions.append(d)
        handles.append(Q)
        expected.append(d.deform(points=Q))
    results, errors = [None, None], []

    def work(j):
        try:
            out = np.empty_like(expected[j])
            for _ in range(50):
                sessions[j].deform(points=handles[j], out=out)
                if not np.array_equal(out, expected[j]):
                    errors.append(f"session {j}: result changed")
            results[j] = out
        except Exception as e:  # noqa: BLE001 - reported below
            errors.append(repr(e))

    threads = [threading.Thread(target=work, args=(j,)) for j in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    assert all(np.array_equal(results[j], expected[j]) for j in range(2))


def test_no_reference_or_memory_leak():
    g = rng()
    V, P, _, _ = scene(g, n=200)
    d = mlsdeform.Deformer(V, points=P)
    out = np.empty_like(V)
    Q = P + 0.05
    H = g.normal(size=(16, 3, 3))
    for _ in range(100):  # warm up allocator caches
        d.deform(points=Q, out=out)
        mlsdeform.fit_rotations(H)
    counts = (sys.getrefcount(out), sys.getrefcount(Q), sys.getrefcount(d))
    gc.collect()
    tracemalloc.start()
    before = tracemalloc.take_snapshot()
    for _ in range(10000):
        d.deform(points=Q, out=out)
        d.deform(points=Q)
        mlsdeform.fit_rotations(H)
    gc.collect()
    after = tracemalloc.take_snapshot()
    tracemalloc.stop()
    grown = sum(s.size_diff for s in after.compare_to(before, "filename"))
    assert (sys.getrefcount(out), sys.getrefcount(Q), sys.getrefcount(d)) == counts
    assert grown < 64 * 1024, f"Python heap grew by {grown} bytes over 10^4 calls"


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
    F = np.array([f for i in range(nx - 1) for j in range(ny - 1)
                  for f in ([i * ny + j, (i + 1) * ny + j, (i + 1) * ny + j + 1],
                            [i * ny + j, (i + 1) * ny + j + 1, i * ny + j + 1])])
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
    # so they differ by at most 1.5e-14 < 2e-14. The deformed vertices add the MLS fit's own rounding, a few hundred eps for 6 spread
    # handles (the rigid-reproduction tests in C++ measure below 100 eps), inside 1e-12 = 4500 eps.
    d.transform_handles(points=range(5), segments=[0], rotation=R, translation=t, pivot=c)
    move = lambda X: (X - c) @ R.T + c + t
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
    assert np.array_equal(X[outside], V[outside])          # bitwise at rest
    assert not np.array_equal(X[region], V[region])
    with pytest.raises(ValueError, match="no vertices"):
        mlsdeform.Deformer(V, points=P, region=[])
    with pytest.raises(ValueError, match="vertex 300"):
        mlsdeform.Deformer(V, points=P, region=[0, 300])


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
        out = B[:m] if H.base is not None and np.shares_memory(H, B[:m]) else B[m // 2:m // 2 + m]
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


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_deform_out_overlapping_handles(dtype):
    # deform() copies its handles before it writes: out= may hold them.
    g = rng()
    V, P, A, B = (x.astype(dtype) for x in scene(g, n=200, k=5, s=2))
    d = mlsdeform.Deformer(V, points=P, segments=(A, B))
    Q, C, D = P + dtype(0.1), A - dtype(0.05), B + dtype(0.02)
    expected = d.deform(points=Q, segments=(C, D))
    X = np.zeros_like(V)
    X[:5], X[5:7], X[7:9] = Q, C, D
    assert d.deform(points=X[:5], segments=(X[5:7], X[7:9]), out=X) is X
    assert np.array_equal(X, expected)
    X = np.zeros_like(V)
    X[-5:] = Q[::-1]
    d.deform(points=X[::-1][:5], segments=(C, D), out=X)
    assert np.array_equal(X, expected)


# ---- uninitialised and re-initialised sessions, pickling ------------------------------------------------------

def test_uninitialised_session_refused():
    g = rng()
    V, P, _, _ = scene(g, n=30, k=4)
    u = mlsdeform.Deformer.__new__(mlsdeform.Deformer)
    calls = [lambda: u.deform(), lambda: u.deform(points=P, out=np.empty_like(V)),
             lambda: u.set_point_target(0, [0, 0, 0]), lambda: u.set_segment_target(0, [0, 0, 0], [1, 0, 0]),
             lambda: u.transform_handles(points=[0]), lambda: u.targets, lambda: u.vertex_count,
             lambda: u.point_count, lambda: u.segment_count, lambda: u.dtype, lambda: u.memory_bytes,
             lambda: u.uses_precomputed_weights, lambda: u._time_cpp_deform(reps=1)]
    for call in calls:
        with pytest.raises(TypeError, match="never initialised"):
            call()
    # __init__ after __new__ is the ordinary construction.
    u.__init__(V, points=P)
    assert u.vertex_count == 30 and np.abs(u.deform() - V).max() <= 1e-12


def test_second_init_refused():
    g = rng()
    V, P, _, _ = scene(g, n=30, k=4)
    d = mlsdeform.Deformer(V, points=P)
    X = d.deform(points=P + 0.1)
    W, R, _, _ = scene(g, n=12, k=3)
    with pytest.raises(RuntimeError, match="initialised session"):
        d.__init__(W, points=R)
    with pytest.raises(RuntimeError, match="initialised session"):
        mlsdeform.Deformer.__init__(d, W, points=R)
    assert d.vertex_count == 30 and np.array_equal(d.deform(points=P + 0.1), X)   # unchanged

    class Twice(mlsdeform.Deformer):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            super().__init__(*args, **kwargs)

    with pytest.raises(RuntimeError, match="initialised session"):
        Twice(V, points=P)

    class Never(mlsdeform.Deformer):
        def __init__(self):
            pass

    with pytest.raises(TypeError, match="__init__"):
        Never()


def test_session_cannot_be_pickled_or_copied():
    import copy
    import pickle
    g = rng()
    V, P, _, _ = scene(g, n=30, k=4)
    for d in (mlsdeform.Deformer(V, points=P), mlsdeform.Deformer.__new__(mlsdeform.Deformer)):
        for f in (pickle.dumps, copy.copy, copy.deepcopy):
            with pytest.raises(TypeError, match="cannot pickle"):
                f(d)


# ---- threads and integer arguments ----------------------------------------------------------------------------

def test_threads_checked_alike():
    g = rng()
    V, P, _, _ = scene(g, n=30, k=4)
    messages = []
    for call in (lambda: mlsdeform.Deformer(V, points=P, threads=-1),
                 lambda: mlsdeform.fit_rotations(np.zeros((4, 3, 3)), threads=-1),
                 lambda: mlsdeform.fit_rotations(np.zeros((4, 3, 3), np.float32), threads=-1)):
        with pytest.raises(ValueError, match="threads") as info:
            call()
        messages.append(str(info.value))
    assert messages[0] == messages[1] == messages[2]
    for threads in (1.5, "2", None):
        with pytest.raises(TypeError):
            mlsdeform.fit_rotations(np.zeros((4, 3, 3)), threads=threads)
        with pytest.raises(TypeError):
            mlsdeform.Deformer(V, points=P, threads=threads)


def test_integer_arguments_never_truncated():
    nx, ny = 6, 4
    V = np.array([[i / 5, j / 5, 0.0] for i in range(nx) for j in range(ny)])
    F = np.array([[i * ny + j, (i + 1) * ny + j, (i + 1) * ny + j + 1] for i in range(nx - 1) for j in range(ny - 1)]
                 + [[i * ny + j, (i + 1) * ny + j + 1, i * ny + j + 1] for i in range(nx - 1) for j in range(ny - 1)])
    P = V[[0, ny - 1, len(V) - 1]]
    Q = P + [[0, 0, 0], [0, 0, 0.3], [0, 0.2, 0]]
    exact = mlsdeform.Deformer(V, points=P, faces=F, arap_iterations=2).deform(points=Q)
    # Float arrays whose values are integers are those integers.
    for faces in (F.astype(np.float64), F.astype(np.float32), F.tolist(), F.astype(np.uint16)):
        X = mlsdeform.Deformer(V, points=P, faces=faces, arap_iterations=2).deform(points=Q)
        assert np.array_equal(X, exact)
    # A fraction, NaN or infinity is refused, never truncated.
    for bad, shown in ((0.5, "0.5"), (np.nan, "nan"), (np.inf, "inf"), (2.9999999999999996, "2.9999999999999996")):
        faces = F.astype(np.float64)
        faces[3, 1] = bad
        with pytest.raises(ValueError, match=r"faces: .*found " + shown + r" \(entry 10\)"):
            mlsdeform.Deformer(V, points=P, faces=faces, arap_iterations=2)
    with pytest.raises(ValueError, match="faces: index 1e\\+300 is too large"):
        mlsdeform.Deformer(V, points=P, faces=np.full((2, 3), 1e300), arap_iterations=2)
    with pytest.raises(ValueError, match="faces: index 18446744073709551615 is too large"):
        mlsdeform.Deformer(V, points=P, faces=np.full((2, 3), 2**64 - 1, np.uint64), arap_iterations=2)
    with pytest.raises(TypeError, match="faces: .*dtype <U1"):
        mlsdeform.Deformer(V, points=P, faces=[["a", "b", "c"]], arap_iterations=2)
    # region and handle groups: the same rules.
    region = np.arange(10)
    assert np.array_equal(mlsdeform.Deformer(V, points=P, region=region.astype(float)).deform(points=Q),
                          mlsdeform.Deformer(V, points=P, region=region).deform(points=Q))
    with pytest.raises(ValueError, match=r"region: .*found 1\.5"):
        mlsdeform.Deformer(V, points=P, region=[0, 1.5])
    with pytest.raises(TypeError, match="flatnonzero"):
        mlsdeform.Deformer(V, points=P, region=V[:, 0] > 0.5)
    d = mlsdeform.Deformer(V, points=P)
    with pytest.raises(ValueError, match=r"segments: .*found 0\.25"):
        d.transform_handles(segments=[0.25])
    d.transform_handles(points=[2.0], translation=[0, 0, 1])
    assert np.array_equal(d.targets["points"][2], P[2] + [0, 0, 1])
    # A handle index is a Python integer: a float is refused by the binding (TypeError), never truncated.
    with pytest.raises(TypeError):
        d.set_point_target(1.0, [0, 0, 0])
    d.set_point_target(np.int64(1), [0, 0, 0])
    assert np.array_equal(d.targets["points"][1], [0, 0, 0])


def test_complex_and_date_arrays_refused():
    # numpy's cast to float would drop an imaginary part with no more than a ComplexWarning.
    g = rng()
    V, P, _, _ = scene(g, n=30, k=4)
    d = mlsdeform.Deformer(V, points=P)
    for bad in (P + 1j, P + 0j, P.astype("m8[s]"), P.astype("M8[s]"), (P + 1j).tolist()):
        with pytest.raises(TypeError, match="points: expected an .* of real numbers"):
            d.deform(points=bad)
        with pytest.raises(TypeError, match="vertices: expected an .* of real numbers"):
            mlsdeform.Deformer(bad, points=P)
    with pytest.raises(TypeError, match="complex128"):
        mlsdeform.fit_rotations(np.eye(3)[None] * 1j)
    with pytest.raises(TypeError, match="complex128"):
        mlsdeform.fit_rotation(np.eye(3) * 1j)
    with pytest.raises(TypeError, match="target: expected 3 real numbers"):
        d.set_point_target(0, [1j, 0, 0])
    with pytest.raises(TypeError, match="rotation: expected a 3 x 3 array of real numbers"):
        d.transform_handles(points=[0], rotation=np.eye(3) + 0j)
    with pytest.raises(ValueError, match="w: expected a 1-D array"):
        mlsdeform.fit_points(P, P, np.ones(4) + 1j)
