"""The session as a Python object: zero copy, dtype rules, the stateful session, out= overlapping the
handles, threads and reference counts, uninitialised and re-initialised sessions, pickling.

Run from the build tree with PYTHONPATH=<build>/python (ctest does), or against the installed package.
"""
import gc
import sys
import threading
import tracemalloc

import numpy as np
import pytest

import mlsdeform
from support import rng, scene


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
    assert mlsdeform.Deformer(V.tolist(), points=P.tolist()).dtype == np.float64  # any array-like
    assert mlsdeform.Deformer(np.round(V * 10).astype(int), points=P * 10).dtype == np.float64
    assert mlsdeform.Deformer(V, points=P, dtype=np.float32).dtype == np.float32
    d = mlsdeform.Deformer(V.astype(np.float32), points=P)
    X = d.deform(points=P + 0.1)  # float64 handles are converted to the session's dtype
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


# ---- uninitialised and re-initialised sessions, pickling ------------------------------------------------------


def test_uninitialised_session_refused():
    g = rng()
    V, P, _, _ = scene(g, n=30, k=4)
    u = mlsdeform.Deformer.__new__(mlsdeform.Deformer)
    calls = [
        lambda: u.deform(),
        lambda: u.deform(points=P, out=np.empty_like(V)),
        lambda: u.set_point_target(0, [0, 0, 0]),
        lambda: u.set_segment_target(0, [0, 0, 0], [1, 0, 0]),
        lambda: u.transform_handles(points=[0]),
        lambda: u.targets,
        lambda: u.vertex_count,
        lambda: u.point_count,
        lambda: u.segment_count,
        lambda: u.dtype,
        lambda: u.memory_bytes,
        lambda: u.uses_precomputed_weights,
        lambda: u._time_cpp_deform(reps=1),
    ]
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
    assert d.vertex_count == 30 and np.array_equal(d.deform(points=P + 0.1), X)  # unchanged

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
