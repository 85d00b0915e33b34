"""fit_rotations: sizes around the lane widths, dtypes, methods, ISAs, scale, NaN, out=, layouts,
threads."""
import numpy as np

import mlsdeform

from support import random_rotation

from .common import DTYPES, EPS, EPS64, METHODS, SCALE_ACCEPT, Skip, TYPE, VALUE, Wrong, add, refused, same
from .references import check_rotations
from .scenes import cloud


D_ = mlsdeform.Deformer


def build(args):
    # ---- fit_rotations: sizes around the lane widths, dtypes, methods, threads ----
    sizes = (0, 1, 3, 7, 8, 15, 16, 17, 31, 33, 2047, 2048, 2049)
    for dt in DTYPES:
        for m in sizes:
            for method in METHODS:

                def f(g, dt=dt, m=m, method=method):
                    H = (g.standard_normal((m, 3, 3)) * g.uniform(0.1, 10, (m, 1, 1))).astype(dt)
                    R = mlsdeform.fit_rotations(H, method=method, threads=int(g.integers(0, 3)))
                    if R.dtype != dt or R.shape != (m, 3, 3):
                        raise Wrong(f"got {R.dtype} {R.shape}")
                    check_rotations(R, H, EPS[dt])

                add("fit_rotations", f"random m={m} {np.dtype(dt).name} {method}", f)

    def degenerate(g, dt):
        p, q = g.normal(size=3), g.normal(size=3)
        p, q = p / np.linalg.norm(p), q / np.linalg.norm(q)
        Rr = random_rotation(g)
        Hs = [
            np.zeros((3, 3)),
            np.outer(q, p),
            np.eye(3),
            -np.eye(3),
            -Rr,
            np.diag([1.0, 1.0, -1.0]),
            np.diag([3.0, 2.0, 0.0]),
            Rr @ np.diag([5.0, 5.0, 5.0]),
            Rr @ np.diag([1.0, 1e-9, 1e-9]),
            np.outer(q, p) + 1e-12 * Rr,
            Rr @ np.diag([1.0, 1.0, 0.0]),
        ]
        return np.array(Hs).astype(dt)

    for dt in DTYPES:
        for method in METHODS:

            def f(g, dt=dt, method=method):
                H = degenerate(g, dt)
                R = mlsdeform.fit_rotations(H, method=method)
                check_rotations(R, H, EPS[dt], "degenerate batch")
                if not np.array_equal(R[0], np.eye(3, dtype=dt)):
                    raise Wrong("H = 0 did not give the identity")

            add("fit_rotations", f"degenerate batch {np.dtype(dt).name} {method}", f)

            def f1(g, dt=dt, method=method):
                for H in degenerate(g, dt):
                    R = mlsdeform.fit_rotation(H, method=method)
                    check_rotations(R[None], H[None], EPS[dt], "fit_rotation")

            add("fit_rotation", f"degenerate one by one {np.dtype(dt).name} {method}", f1)

    # Scale: the optimal rotation of s H is that of H; powers of two keep H's digits, so the fit is the same
    # problem, and the result must pass the same bound (or be bitwise the same).
    for dt, exps in (
        (np.float32, (-140, -135, -126, -120, -100, -60, 60, 100, 119)),
        (np.float64, (-1070, -1060, -1022, -1000, -600, 600, 1000, 1015)),
    ):
        for e in exps:
            for method in ("axis_angle", "horn_quaternion", "svd"):
                tag = (
                    "subnormal"
                    if (dt == np.float32 and e <= -126) or (dt == np.float64 and e <= -1022)
                    else "fit_rotations-scale"
                )

                def f(g, dt=dt, e=e, method=method):
                    # Integer matrices (|entries| <= 255) scaled by 2^e are exact even as subnormals (8 bits).
                    Hi = g.integers(-255, 256, (64, 3, 3)).astype(np.float64)
                    H = np.ldexp(Hi, e).astype(dt)
                    if not np.array_equal(np.ldexp(H.astype(np.float64), -e), Hi):
                        raise RuntimeError("test set-up: the scaled matrices are not exact")
                    R = mlsdeform.fit_rotations(H, method=method)
                    check_rotations(R, Hi, EPS[dt], f"2^{e} H")

                add(tag, f"fit_rotations 2^{e} x integer H {np.dtype(dt).name} {method}", f, accept=SCALE_ACCEPT)

    for isa in ("scalar", "sse4_2", "avx2", "avx512"):
        for dt, values in (
            (np.float32, (1e-44, 1e-42, 1e-40, 2.0**-149, 1e-38)),
            (np.float64, (5e-324, 1e-310, 2.0**-1022)),
        ):
            for c in values:

                def f(g, isa=isa, dt=dt, c=c):
                    if isa not in mlsdeform.supported_isas():
                        raise Skip(f"this CPU has no {isa}")
                    best = mlsdeform.active_isa()
                    mlsdeform.set_isa(isa)
                    try:
                        H = np.array([np.eye(3) * c, g.standard_normal((3, 3)) * c, random_rotation(g) * c] * 8).astype(
                            dt
                        )
                        R = mlsdeform.fit_rotations(H)
                    finally:
                        mlsdeform.set_isa(best)
                    # The reference reads the rounded (subnormal) values scaled up exactly.
                    up = np.ldexp(H.astype(np.float64), 1100 if dt == np.float64 else 160)
                    check_rotations(R, up, EPS[dt], f"{c:g} H on {isa}")
                    if not np.allclose(R[0], np.eye(3), rtol=0, atol=16 * EPS[dt]):
                        raise Wrong(f"{c:g} I did not give the identity")

                add("subnormal", f"fit_rotations {c:g} x H {np.dtype(dt).name} on {isa}", f)

    # NaN and infinities: ValueError naming H[i, r, c], nothing written to out.
    for dt in DTYPES:
        for bad in (np.nan, np.inf, -np.inf):
            for m in (1, 17, 5000):

                def f(g, dt=dt, bad=bad, m=m):
                    H = g.standard_normal((m, 3, 3)).astype(dt)
                    i, r, c = int(g.integers(m)), int(g.integers(3)), int(g.integers(3))
                    H[i, r, c] = bad
                    out = np.full_like(H, 5)
                    return refused(
                        lambda: mlsdeform.fit_rotations(H, out=out, threads=int(g.integers(0, 3))),
                        VALUE,
                        [f"H[{i}, {r}, {c}]"],
                        untouched=[out],
                    )

                add("fit_rotations-nonfinite", f"{bad} at a random entry m={m} {np.dtype(dt).name}", f)

    # out= overlapping H, and out= errors.
    for dt in DTYPES:
        for shift in (-32769, -2049, -2048, -1, 1, 2, 2047, 2048, 32768):
            for threads in (1, 0):

                def f(g, dt=dt, shift=shift, threads=threads):
                    m = 40000
                    Bf = g.standard_normal((m + abs(shift), 3, 3)).astype(dt)
                    H, out = (Bf[:m], Bf[shift:]) if shift > 0 else (Bf[-shift:], Bf[:m])
                    expected = mlsdeform.fit_rotations(H.copy(), threads=threads)
                    r = mlsdeform.fit_rotations(H, out=out, threads=threads)
                    if r is not out:
                        raise Wrong("out= not returned")
                    same(out, expected, f"out shifted by {shift} rows")

                add("overlap", f"fit_rotations out=H shifted {shift} {np.dtype(dt).name} threads={threads}", f)
        for kind in ("in place", "reversed H", "strided H", "transposed H", "misaligned out", "misaligned H"):

            def f(g, dt=dt, kind=kind):
                m = 6000
                Bf = g.standard_normal((2 * m, 3, 3)).astype(dt)
                if kind == "in place":
                    H, out = Bf[:m], Bf[:m]
                elif kind == "reversed H":
                    H, out = Bf[::-1][:m], Bf[m:]
                elif kind == "strided H":
                    H, out = Bf[::2], Bf[m // 2 : m // 2 + m]
                elif kind == "transposed H":
                    H, out = np.swapaxes(Bf[:m], 1, 2), Bf[:m]
                else:
                    raw = np.zeros(2 * m * 9 * np.dtype(dt).itemsize + 1, np.uint8)
                    mis = raw[1:].view(dt).reshape(2 * m, 3, 3)
                    mis[...] = Bf
                    H, out = (Bf[:m], mis[:m]) if kind == "misaligned out" else (mis[:m], mis[1 : m + 1])
                expected = mlsdeform.fit_rotations(np.array(H, copy=True))
                mlsdeform.fit_rotations(H, out=out)
                same(out, expected, kind)

            add("overlap", f"fit_rotations {kind} {np.dtype(dt).name}", f)
        bad_outs = [
            ("wrong dtype", lambda H: np.empty(H.shape, np.float16), TYPE, ["out", "dtype"]),
            ("wrong shape", lambda H: np.empty((len(H) + 1, 3, 3), H.dtype), VALUE, ["out", "shape"]),
            ("F-order", lambda H: np.asfortranarray(np.empty(H.shape, H.dtype)), VALUE, ["out", "contiguous"]),
            (
                "read-only",
                lambda H: np.broadcast_to(np.zeros((1, 3, 3), H.dtype), H.shape),
                VALUE,
                ["out", "read-only", "contiguous"],
            ),
            ("list", lambda H: H.tolist(), TYPE, ["out"]),
            ("strided", lambda H: np.empty((2 * len(H), 3, 3), H.dtype)[::2], VALUE, ["out", "contiguous"]),
        ]
        for name, make, exc, words in bad_outs:

            def f(g, dt=dt, make=make, exc=exc, words=words):
                H = g.standard_normal((50, 3, 3)).astype(dt)
                out = make(H)
                keep = [out] if isinstance(out, np.ndarray) else []
                return refused(lambda: mlsdeform.fit_rotations(H, out=out), exc, words, untouched=keep)

            add("fit_rotations-out", f"out {name} {np.dtype(dt).name}", f)

    # Layouts and dtypes of H: the same result as the C-contiguous float64/float32 array, bitwise.
    layouts = {
        "F-order": lambda H: np.asfortranarray(H),
        "reversed": lambda H: H[::-1].copy()[::-1],
        "every other": lambda H: np.repeat(H, 2, axis=0)[::2],
        "broadcast": lambda H: np.broadcast_to(H[:1], H.shape),
        "list": lambda H: H.tolist(),
        "tuple of arrays": lambda H: tuple(H),
        "object array": lambda H: H.astype(object),
        "read-only": lambda H: np.frombuffer(H.tobytes(), H.dtype).reshape(H.shape),
    }
    for dt in DTYPES:
        for name, make in layouts.items():

            def f(g, dt=dt, name=name, make=make):
                H = g.standard_normal((33, 3, 3)).astype(dt)
                if name == "broadcast":
                    H = np.broadcast_to(H[:1], H.shape).copy()
                R = mlsdeform.fit_rotations(make(H))
                want = mlsdeform.fit_rotations(
                    H if name not in ("list", "tuple of arrays", "object array") else H.astype(np.float64)
                )
                same(R, want, name)

            add("fit_rotations-layout", f"H {name} {np.dtype(dt).name}", f)
    for name, make, exc, words in [
        ("int", lambda g: g.integers(-9, 9, (20, 3, 3)), None, None),
        ("uint8", lambda g: g.integers(0, 9, (20, 3, 3)).astype(np.uint8), None, None),
        ("bool", lambda g: g.integers(0, 2, (20, 3, 3)).astype(bool), None, None),
        ("float16", lambda g: g.standard_normal((20, 3, 3)).astype(np.float16), None, None),
        ("longdouble", lambda g: g.standard_normal((20, 3, 3)).astype(np.longdouble), None, None),
        ("complex", lambda g: g.standard_normal((20, 3, 3)) + 1j, TYPE, ["H", "real", "complex"]),
        ("complex zero imaginary", lambda g: g.standard_normal((20, 3, 3)) + 0j, TYPE, ["H", "complex"]),
        ("datetime", lambda g: np.zeros((20, 3, 3), "M8[s]"), TYPE, ["H", "datetime"]),
        ("strings", lambda g: np.full((2, 3, 3), "x"), TYPE, ["H"]),
        ("ragged", lambda g: [[[1, 2, 3]] * 3, [[1, 2]] * 3], TYPE, ["H"]),
        ("None", lambda g: None, (TYPE, VALUE), ["H"]),
        ("shape (3, 3)", lambda g: np.eye(3), VALUE, ["H", "shape"]),
        ("shape (m, 3, 4)", lambda g: np.zeros((4, 3, 4)), VALUE, ["H", "shape"]),
        ("shape (m, 9)", lambda g: np.zeros((4, 9)), VALUE, ["H", "shape"]),
        ("shape (2, m, 3, 3)", lambda g: np.zeros((2, 4, 3, 3)), VALUE, ["H", "shape"]),
        ("scalar", lambda g: 3.0, VALUE, ["H", "shape"]),
    ]:

        def f(g, make=make, exc=exc, words=words):
            H = make(g)
            if exc is not None:
                return refused(lambda: mlsdeform.fit_rotations(H), exc, words)
            R = mlsdeform.fit_rotations(H)
            want_dt = np.float64
            if R.dtype != want_dt:
                raise Wrong(f"dtype {R.dtype}, expected float64")
            check_rotations(R, np.asarray(H, np.float64), EPS64)

        add("fit_rotations-dtype", f"H {name}", f)
    for method in ("qr", "", "AXIS_ANGLE", None):
        add(
            "fit_rotations-args",
            f"method={method!r}",
            lambda g, method=method: refused(
                lambda: mlsdeform.fit_rotations(np.zeros((2, 3, 3)), method=method),
                (VALUE, TYPE),
                ["method", "incompatible"],
            ),
        )

    # threads: bitwise the same for every valid count; one check and message for fit_rotations and Deformer.
    for threads in (0, 1, 2, 3, 7, 64, 2**31 - 1):

        def f(g, threads=threads):
            H = g.standard_normal((70000, 3, 3)).astype(np.float32)
            same(
                mlsdeform.fit_rotations(H, threads=threads), mlsdeform.fit_rotations(H, threads=1), f"threads={threads}"
            )

        add("threads", f"fit_rotations threads={threads}", f)

        def f2(g, threads=threads):
            V, P, Q, *_ = cloud(g, n=3000, k=9)
            X = D_(V, points=P, threads=threads).deform(points=Q)
            same(X, D_(V, points=P, threads=1).deform(points=Q), f"threads={threads}")

        add("threads", f"Deformer threads={threads}", f2)
    for threads, exc in (
        (-1, VALUE),
        (-(2**31), VALUE),
        (2**31, TYPE),
        (1.5, TYPE),
        (1.0, TYPE),
        ("2", TYPE),
        (None, TYPE),
    ):
        add(
            "threads",
            f"fit_rotations threads={threads!r}",
            lambda g, threads=threads, exc=exc: refused(
                lambda: mlsdeform.fit_rotations(np.zeros((2, 3, 3)), threads=threads), exc, ["threads", "incompatible"]
            ),
        )

        def f(g, threads=threads, exc=exc):
            V, P, *_ = cloud(g, n=20, k=4)
            return refused(lambda: D_(V, points=P, threads=threads), exc, ["threads", "incompatible"])

        add("threads", f"Deformer threads={threads!r}", f)

    def f(g):
        V, P, *_ = cloud(g, n=20, k=4)
        msgs = []
        for call in (
            lambda: D_(V, points=P, threads=-3),
            lambda: mlsdeform.fit_rotations(np.zeros((1, 3, 3)), threads=-3),
        ):
            try:
                call()
            except ValueError as e:
                msgs.append(str(e))
        if len(msgs) != 2 or msgs[0] != msgs[1]:
            raise Wrong(f"threads=-3 refused differently: {msgs}")

    add("threads", "one message for threads=-3 in Deformer and fit_rotations", f)
