"""Frames out of Deformer.deform (quaternions=, rotations=, scales=, linear= into preallocated arrays) and
mlsdeform.transform_normals / transform_tangents: positions unchanged, a rigid motion's rotation at every vertex,
no copy, bad arrays refused before anything is written. The bounds of the C++ tests (tests/test_frames.cpp)
are derived per vertex; here a rigid motion of well-spread handles is checked to a fixed 1e-9 (double), far
above the fit's error (a few hundred eps times the conditioning of these scenes) and far below any real bug.

Run from the build tree with PYTHONPATH=<build>/python (ctest does), or against the installed package.
"""
import numpy as np
import pytest

import mlsdeform
from support import random_rotation, rng, scene


def frames_for(n, dtype=np.float64):
    return {
        "quaternions": np.empty((n, 4), dtype),
        "rotations": np.empty((n, 3, 3), dtype),
        "scales": np.empty((n,), dtype),
        "linear": np.empty((n, 3, 3), dtype),
    }


def test_frames_leave_positions_unchanged_and_are_written_in_place():
    g = rng()
    V, P, _, _ = scene(g)
    d = mlsdeform.Deformer(V, points=P, transform="similarity")
    Q = P + g.uniform(-0.2, 0.2, P.shape)
    f = frames_for(len(V))
    ids = {k: id(a) for k, a in f.items()}
    X = d.deform(points=Q, **f)
    assert np.array_equal(X, d.deform(points=Q))
    assert {k: id(a) for k, a in f.items()} == ids
    q, R, s, L = f["quaternions"], f["rotations"], f["scales"], f["linear"]
    assert np.all(q[:, 0] >= 0)
    assert np.abs(np.linalg.norm(q, axis=1) - 1).max() <= 1e-14
    assert np.abs(np.einsum("nji,njk->nik", R, R) - np.eye(3)).max() <= 1e-13
    assert np.array_equal(L, s[:, None, None] * R)


@pytest.mark.parametrize("angle", [0.4, 2.5, np.pi])
def test_rigid_motion_gives_its_rotation_everywhere(angle):
    g = rng()
    V, P, _, _ = scene(g, k=9)
    axis = np.array([0.3, -1.0, 0.6]) / np.linalg.norm([0.3, -1.0, 0.6])
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    R0 = np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K
    q0 = np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * axis])
    d = mlsdeform.Deformer(V, points=P)
    f = frames_for(len(V))
    d.deform(points=P @ R0.T + [0.5, -1, 2], **f)
    assert np.abs(f["rotations"] - R0).max() <= 1e-9
    # q and -q are one rotation (at 180 degrees w = 0 and either sign is exact).
    dq = np.minimum(np.linalg.norm(f["quaternions"] - q0, axis=1), np.linalg.norm(f["quaternions"] + q0, axis=1))
    assert dq.max() <= 1e-9
    assert np.all(f["scales"] == 1)


def test_frames_in_float32_and_each_alone():
    g = rng()
    V, P, _, _ = scene(g)
    d = mlsdeform.Deformer(V.astype(np.float32), points=P.astype(np.float32))
    Q = (P + 0.1).astype(np.float32)
    f = frames_for(len(V), np.float32)
    d.deform(points=Q, **f)
    for k, a in f.items():
        alone = np.empty_like(a)
        d.deform(points=Q, **{k: alone})
        assert np.array_equal(alone, a), k


def test_arap_frames_are_rotations():
    g = rng()
    n = 6
    xs, ys = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    V = np.stack([xs.ravel(), ys.ravel(), 0.1 * xs.ravel() * ys.ravel()], axis=1)
    F = []
    for i in range(n - 1):
        for j in range(n - 1):
            a = i * n + j
            F += [[a, a + 1, a + n + 1], [a, a + n + 1, a + n]]
    P = V[[0, n - 1, n * n - 1, n * n - n]]
    d = mlsdeform.Deformer(V, points=P, faces=np.array(F), arap_iterations=3)
    R0 = random_rotation(g)
    f = frames_for(len(V))
    X = d.deform(points=P @ R0.T, **f)
    assert np.abs(X - V @ R0.T).max() <= 1e-9
    assert np.abs(f["rotations"] - R0).max() <= 1e-6
    assert np.all(f["scales"] == 1)


def test_bad_frame_arrays_are_refused_before_writing():
    g = rng()
    V, P, _, _ = scene(g)
    d = mlsdeform.Deformer(V, points=P)
    out = np.full_like(V, 7.0)
    good = np.full((len(V), 3, 3), 7.0)
    with pytest.raises(ValueError, match=r"quaternions: expected shape \(400, 4\), got \(400, 3\)"):
        d.deform(points=P + 0.1, out=out, rotations=good, quaternions=np.empty((len(V), 3)))
    with pytest.raises(TypeError, match="scales: expected dtype float64"):
        d.deform(points=P + 0.1, out=out, rotations=good, scales=np.empty(len(V), np.float32))
    with pytest.raises(ValueError, match="linear: must be C-contiguous"):
        d.deform(points=P + 0.1, out=out, linear=np.empty((3, 3, len(V))).transpose(2, 0, 1))
    with pytest.raises(TypeError, match="rotations: expected a numpy array"):
        d.deform(points=P + 0.1, out=out, rotations=[[0.0] * 9] * len(V))
    assert np.all(out == 7) and np.all(good == 7)
    a = mlsdeform.Deformer(V, points=P, transform="affine")
    with pytest.raises(ValueError, match="rotations is not available for Transform::affine"):
        a.deform(points=P + 0.1, out=out, rotations=good)
    assert np.all(out == 7) and np.all(good == 7)


@pytest.mark.parametrize("kind", ["general", "shear", "reflection"])
def test_affine_linear_is_the_motions_matrix(kind):
    # An affine motion x -> A x + t of every handle is reproduced by the affine fit: its matrix is A at every
    # vertex (to the fixed 1e-9 of this file: the C++ test derives the per-vertex bound).
    g = rng()
    V, P, _, _ = scene(g, k=9)
    A = {
        "general": random_rotation(g) @ (np.eye(3) + 0.4 * g.uniform(-1, 1, (3, 3))),
        "shear": np.array([[1, 0.8, 0], [0, 1, 0], [0, 0, 1]]),
        "reflection": 1.7 * random_rotation(g) @ np.diag([1, -1, 1]),
    }[kind]
    d = mlsdeform.Deformer(V, points=P, transform="affine", affine_frames=True)
    L = np.empty((len(V), 3, 3))
    X = d.deform(points=P @ A.T + [0.5, -1, 2], linear=L)
    assert np.array_equal(X, d.deform(points=P @ A.T + [0.5, -1, 2]))
    assert np.abs(L - A).max() <= 1e-9
    # Normals go by its inverse transpose.
    N = g.normal(size=(len(V), 3))
    ref = N @ np.linalg.inv(A)
    ref /= np.linalg.norm(ref, axis=1)[:, None]
    assert np.abs(mlsdeform.transform_normals(L, N) - ref).max() <= 1e-9


def test_affine_linear_needs_affine_frames():
    # Without affine_frames an affine session keeps its weights alone (a quarter of the memory) and refuses
    # linear, naming the option, before anything is written; its positions are those of a session with it.
    g = rng()
    V, P, _, _ = scene(g, k=9)
    plain = mlsdeform.Deformer(V, points=P, transform="affine")
    with_frames = mlsdeform.Deformer(V, points=P, transform="affine", affine_frames=True)
    out = np.full_like(V, 7.0)
    L = np.full((len(V), 3, 3), 7.0)
    with pytest.raises(ValueError, match="Options::affine_frames"):
        plain.deform(points=P + 0.1, out=out, linear=L)
    assert np.all(out == 7) and np.all(L == 7)
    X = with_frames.deform(points=P + 0.1, linear=L)
    assert np.array_equal(plain.deform(points=P + 0.1), X)
    # The difference is the fit's matrix table alone: 3 values per padded vertex (blocks of 16) and handle.
    padded = -(-len(V) // 16) * 16
    assert with_frames.memory_bytes - plain.memory_bytes == 3 * padded * 9 * 8


def test_transform_normals_and_tangents():
    g = rng()
    n = 50
    L = np.stack([random_rotation(g) * s for s in g.uniform(0.5, 2, n)])
    N = g.normal(size=(n, 3))
    got = mlsdeform.transform_normals(L, N)
    ref = np.einsum("nij,nj->ni", np.linalg.inv(L).transpose(0, 2, 1), N)
    ref /= np.linalg.norm(ref, axis=1)[:, None]
    assert np.abs(got - ref).max() <= 1e-13
    # In place, float32 following linear's dtype.
    N32 = N.astype(np.float32)
    r = mlsdeform.transform_normals(L.astype(np.float32), N32, out=N32)
    assert r is N32 and r.dtype == np.float32 and np.abs(r - ref).max() <= 1e-5
    # A reflection flips the bitangent sign.
    M = np.tile(np.diag([-1.0, 1.0, 1.0]), (n, 1, 1))
    T = np.concatenate([g.normal(size=(n, 3)), np.ones((n, 1))], axis=1)
    t = mlsdeform.transform_tangents(M, T)
    assert np.all(t[:, 3] == -1)
    assert np.allclose(t[:, :3], (T[:, :3] * [-1, 1, 1]) / np.linalg.norm(T[:, :3], axis=1)[:, None], atol=1e-15)
    with pytest.raises(ValueError, match=r"normals: expected shape \(50, 3\)"):
        mlsdeform.transform_normals(L, N[:10])
    N[3, 1] = np.nan
    with pytest.raises(ValueError, match="row 3 is not finite"):
        mlsdeform.transform_normals(L, N)


def rigid_motion(g, *arrays, dtype=np.float64):
    """A random rotation R0 far from the identity and each array moved by x -> R0 x + t (in double, rounded
    once to dtype)."""
    R0 = random_rotation(g)
    while np.linalg.norm(R0 - np.eye(3)) <= 1:
        R0 = random_rotation(g)
    t = np.array([0.5, -1.0, 2.0])
    return R0, [(X.astype(np.float64) @ R0.T + t).astype(dtype) for X in arrays]


# Handles placed on vertices, as users place them: a rigid motion of every handle must give its rotation at
# every vertex, those on handles too (the fit's limit there). 1e-9 (double) and 1e-3 (float32: the fit's error
# is a few hundred eps_f times these scenes' conditioning) are far below the identity's distance from R0 (over
# 1) and that of a segment's own rank-1 fit.
def tolerance(dtype):
    return 1e-3 if dtype == np.float32 else 1e-9


def worst(R, R0):
    err = np.abs(R - R0).reshape(len(R), 9).max(axis=1)
    return err.max(), np.argsort(err)[-3:]


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("storage", ["precomputed", "on_the_fly", "precomputed_weights"])
@pytest.mark.parametrize("transform", ["rigid", "similarity"])
def test_rigid_motion_turns_vertices_on_point_handles(dtype, storage, transform):
    g = rng()
    V = scene(g)[0].astype(dtype)
    P = V[[0, 3, 5, 10, 20, 40]]
    R0, (Q,) = rigid_motion(g, P, dtype=dtype)
    d = mlsdeform.Deformer(V, points=P, weight_storage=storage, transform=transform)
    R, s = np.empty((len(V), 3, 3), dtype), np.empty(len(V), dtype)
    d.deform(points=Q, rotations=R, scales=s)
    err, at = worst(R, R0)
    assert err <= tolerance(dtype), f"worst at vertices {at}"
    assert np.abs(s - 1).max() <= tolerance(dtype)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("segment_weight", ["paper_constant", "exact_integral"])
def test_rigid_motion_turns_vertices_on_segment_handles(dtype, segment_weight):
    # Point handles on six vertices, two segments between vertices and a vertex at one segment's midpoint
    # (segment handles are served by the precomputed table alone).
    g = rng()
    V = scene(g)[0]
    V = np.vstack([V, (V[6] + V[7]) / 2]).astype(dtype)
    P, A, B = V[:6], V[[6, 8]], V[[7, 9]]
    R0, (Q, C, D) = rigid_motion(g, P, A, B, dtype=dtype)
    d = mlsdeform.Deformer(V, points=P, segments=(A, B), segment_weight=segment_weight)
    R = np.empty((len(V), 3, 3), dtype)
    d.deform(points=Q, segments=(C, D), rotations=R)
    err, at = worst(R, R0)
    assert err <= tolerance(dtype), f"worst at vertices {at}"


@pytest.mark.parametrize("segments", [False, True])
def test_affine_motion_gives_its_matrix_on_point_and_segment_handles(segments):
    g = rng()
    V = scene(g)[0]
    P, A, B = V[:6], V[[6, 8]], V[[7, 9]]
    M = np.array([[1.0, 0.5, 0.0], [0.0, 1.0, 0.25], [0.0, 0.0, 1.5]])
    t = np.array([0.25, -1.0, 0.5])
    d = mlsdeform.Deformer(V, points=P, segments=(A, B) if segments else None, transform="affine", affine_frames=True)
    L = np.empty((len(V), 3, 3))
    d.deform(points=P @ M.T + t, segments=(A @ M.T + t, B @ M.T + t) if segments else None, linear=L)
    err = np.abs(L - M).reshape(len(V), 9).max(axis=1)
    assert err.max() <= 1e-9, f"worst at vertices {np.argsort(err)[-3:]}"
