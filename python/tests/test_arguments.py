"""Arguments: every error path (the right exception, the library's message, nothing written), read-only
and strided inputs, threads checked alike, integers never truncated, complex and date arrays refused.

Run from the build tree with PYTHONPATH=<build>/python (ctest does), or against the installed package.
"""

import numpy as np
import pytest

import mlsdeform
from support import rng, scene


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
    big[:, ::2] = P  # a strided view: converted, not rejected
    d = mlsdeform.Deformer(V, points=big[:, ::2])
    assert np.abs(d.deform(points=P) - V).max() <= 1e-12


# ---- threads and integer arguments ----------------------------------------------------------------------------


def test_threads_checked_alike():
    g = rng()
    V, P, _, _ = scene(g, n=30, k=4)
    messages = []
    for call in (
        lambda: mlsdeform.Deformer(V, points=P, threads=-1),
        lambda: mlsdeform.fit_rotations(np.zeros((4, 3, 3)), threads=-1),
        lambda: mlsdeform.fit_rotations(np.zeros((4, 3, 3), np.float32), threads=-1),
    ):
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
    F = np.array(
        [[i * ny + j, (i + 1) * ny + j, (i + 1) * ny + j + 1] for i in range(nx - 1) for j in range(ny - 1)]
        + [[i * ny + j, (i + 1) * ny + j + 1, i * ny + j + 1] for i in range(nx - 1) for j in range(ny - 1)]
    )
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
    assert np.array_equal(
        mlsdeform.Deformer(V, points=P, region=region.astype(float)).deform(points=Q),
        mlsdeform.Deformer(V, points=P, region=region).deform(points=Q),
    )
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
