"""Arrays that share memory: every function that writes an array while it reads others (Deformer.deform's out
and frames, transform_normals / transform_tangents, rotate_splats, transform_splats_affine) either reads what
the caller passed, whatever it writes over, or refuses two outputs that share memory with a ValueError naming
both, before anything is written. The oracle is the same call on separate copies, or numpy's reference."""
import numpy as np
import pytest

import mlsdeform
from support import random_rotation, rng, scene


def reference_normals(L, N):
    r = np.einsum("nij,nj->ni", np.linalg.inv(L).transpose(0, 2, 1), N)
    return r / np.linalg.norm(r, axis=1)[:, None]


def reference_tangents(L, T):
    r = np.einsum("nij,nj->ni", L, T[:, :3])
    w = np.where(np.linalg.det(L) < 0, -T[:, 3], T[:, 3])
    return np.concatenate([r / np.linalg.norm(r, axis=1)[:, None], w[:, None]], axis=1)


def linear_parts(g, n):
    return np.stack([random_rotation(g) * s for s in g.uniform(0.5, 2, n)])


def test_deform_refuses_outputs_that_share_memory_and_writes_nothing():
    g = rng()
    V, P, _, _ = scene(g)
    n = len(V)
    d = mlsdeform.Deformer(V, points=P, transform="similarity")
    buf = np.full(12 * n, 7.0)
    X, L = buf[: 3 * n].reshape(n, 3), buf[3 * n :].reshape(n, 3, 3)  # one buffer, apart: fine
    d.deform(points=P + 0.1, out=X, linear=L)
    L_alone = np.empty((n, 3, 3))
    assert np.array_equal(X, d.deform(points=P + 0.1, linear=L_alone))
    assert np.array_equal(L, L_alone)
    buf[:] = 7.0
    shifted = buf[3 * n - 9 : 12 * n - 9].reshape(n, 3, 3)  # its first matrix is X's last three rows
    with pytest.raises(ValueError, match="out and linear share memory"):
        d.deform(points=P + 0.1, out=X, linear=shifted)
    b = np.full(13 * n, 7.0)
    q, R = b[: 4 * n].reshape(n, 4), b[4 * n - 4 : 13 * n - 4].reshape(n, 3, 3)
    with pytest.raises(ValueError, match="quaternions and rotations share memory"):
        d.deform(points=P + 0.1, quaternions=q, rotations=R)
    R2 = np.full((n, 3, 3), 7.0)
    with pytest.raises(ValueError, match="rotations and scales share memory"):
        d.deform(points=P + 0.1, rotations=R2, scales=R2.reshape(-1)[5 : 5 + n])
    with pytest.raises(ValueError, match="out and scales share memory"):
        d.deform(points=P + 0.1, out=X, scales=X.reshape(-1)[:n])
    assert np.all(buf == 7.0) and np.all(b == 7.0) and np.all(R2 == 7.0)


def test_deform_reads_handles_that_share_memory_with_out():
    g = rng()
    V, P, _, _ = scene(g)
    d = mlsdeform.Deformer(V, points=P)
    Q = P + g.uniform(-0.2, 0.2, P.shape)
    want = d.deform(points=Q)
    X = np.zeros_like(V)
    X[: len(P)] = Q  # the handles are the first rows of out
    d.deform(points=X[: len(P)], out=X)
    assert np.array_equal(X, want)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_transform_normals_with_out_overlapping_its_inputs(dtype):
    g = rng()
    n = 60
    L = linear_parts(g, n)
    b = g.normal(size=(n + 1, 3))
    want = reference_normals(L, b[:-1])
    tol = 1e-5 if dtype == np.float32 else 1e-13
    b = b.astype(dtype)
    r = mlsdeform.transform_normals(L.astype(dtype), b[:-1], out=b[1:])  # each row written over the next read
    assert np.abs(r - want).max() <= tol
    # out overlapping linear: the matrices' buffer continues into out.
    buf = np.empty(9 * n + 3 * n, dtype)
    Lv = buf[: 9 * n].reshape(n, 3, 3)
    Lv[:] = L
    N = g.normal(size=(n, 3))
    out = buf[6 * n : 9 * n].reshape(n, 3)  # the last third of the matrices
    r = mlsdeform.transform_normals(Lv, N.astype(dtype), out=out)
    assert np.abs(r - reference_normals(L, N)).max() <= tol
    # In place stays in place.
    N2 = N.astype(dtype)
    assert mlsdeform.transform_normals(L.astype(dtype), N2, out=N2) is N2
    assert np.abs(N2 - reference_normals(L, N)).max() <= tol


def test_transform_tangents_with_out_overlapping_its_input():
    g = rng()
    n = 40
    L = linear_parts(g, n)
    L[::3] *= np.array([-1.0, 1.0, 1.0])  # some reflections: w flips
    b = np.concatenate([g.normal(size=(n + 2, 3)), np.ones((n + 2, 1))], axis=1)
    want = reference_tangents(L, b[:-2])
    r = mlsdeform.transform_tangents(L, b[:-2], out=b[2:])
    assert np.abs(r - want).max() <= 1e-13


def splat_arrays(g, n):
    q = g.normal(size=(n, 4))
    return (
        q / np.linalg.norm(q, axis=1, keepdims=True),
        g.normal(size=(n, 4)) * 1.5,
        np.log(0.02) + 0.5 * g.normal(size=(n, 3)),
        0.1 * g.normal(size=(n, 45)),
    )


def test_rotate_splats_reads_transforms_that_share_memory_with_what_it_updates():
    g = rng()
    n = 30
    turns, rot, log_s, sh = splat_arrays(g, n)
    # The quaternions are the splats' own rotations, normalised, passed as the very array updated.
    q = rot / np.linalg.norm(rot, axis=1, keepdims=True)
    expected = q.copy()
    mlsdeform.rotate_splats(q.copy(), rotations=expected)
    mlsdeform.rotate_splats(q, rotations=q)
    assert np.array_equal(q, expected)
    # The scales: the start of the buffer whose rest holds the log scales, the first row over the last scales.
    s = np.exp(0.1 * g.normal(size=n))
    buf = np.concatenate([s, log_s.reshape(-1)])
    log_scales = buf[n - 3 : 4 * n - 3].reshape(n, 3)
    expected = log_scales.copy()
    mlsdeform.rotate_splats(turns, s.copy(), log_scales=expected)
    mlsdeform.rotate_splats(turns, buf[:n], log_scales=log_scales)
    assert np.array_equal(log_scales, expected)


def test_splat_arrays_updated_that_share_memory_are_refused():
    g = rng()
    n = 30
    turns, rot, log_s, sh = splat_arrays(g, n)
    buf = np.concatenate([rot.reshape(-1), log_s.reshape(-1)])
    before = buf.copy()
    with pytest.raises(ValueError, match="rotations and log_scales share memory"):
        mlsdeform.rotate_splats(
            turns, rotations=buf[: 4 * n].reshape(n, 4), log_scales=buf[4 * n - 3 : 7 * n - 3].reshape(n, 3)
        )
    with pytest.raises(ValueError, match="rotations and log_scales share memory"):
        mlsdeform.transform_splats_affine(
            np.tile(np.eye(3), (n, 1, 1)),
            rotations=buf[: 4 * n].reshape(n, 4),
            log_scales=buf[4 * n - 3 : 7 * n - 3].reshape(n, 3),
        )
    assert np.array_equal(buf, before)


def test_transform_splats_affine_reads_linear_that_shares_memory_with_what_it_updates():
    g = rng()
    n = 20
    sh = 0.1 * g.normal(size=(n, 45))
    M = linear_parts(g, n)
    sh[0] = M[-5:].reshape(-1)  # in the buffer below, the first splat's coefficients are the last 5 matrices
    expected = sh.copy()
    mlsdeform.transform_splats_affine(M.copy(), sh_rest=expected)
    buf = np.empty(9 * n - 45 + 45 * n)
    Mv, shared_sh = buf[: 9 * n].reshape(n, 3, 3), buf[9 * n - 45 :].reshape(n, 45)
    Mv[:] = M
    shared_sh[1:] = sh[1:]
    mlsdeform.transform_splats_affine(Mv, sh_rest=shared_sh)
    assert np.array_equal(shared_sh, expected)
    assert not np.array_equal(Mv, M)  # written over after it was read
