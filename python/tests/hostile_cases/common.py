"""The campaign's vocabulary: outcomes, the case registry (add) and the checks that classify a result or a
refusal."""
import os

import numpy as np


CORRECT, CLEAR, SILENT_WRONG, BAD_ERROR, CRASH, HANG, SKIPPED = (
    "correct",
    "clear error",
    "SILENT WRONG",
    "BAD ERROR",
    "CRASH",
    "HANG",
    "skipped",
)
FAILURES = (SILENT_WRONG, BAD_ERROR, CRASH, HANG)
EPS = {np.float32: float(np.finfo(np.float32).eps), np.float64: float(np.finfo(np.float64).eps)}
EPS64 = EPS[np.float64]
HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
DATA = os.path.join(HERE, "..", "..", "data")


class Wrong(Exception):
    """A silent wrong result."""


class BadError(Exception):
    """A refusal that is not clear (wrong type, or a message that names nothing)."""


class Hang(Exception):
    """A call that did not end or could not be interrupted in time."""


class Skip(Exception):
    """The case cannot run here (no program given, an ISA this CPU lacks)."""


class Case:
    def __init__(self, ident, tag, name, fn, accept, timeout, quick):
        self.id, self.tag, self.name, self.fn = ident, tag, name, fn
        self.accept, self.timeout, self.quick = accept, timeout, quick


CASES = []


def add(tag, name, fn, accept=None, timeout=60, quick=None):
    """Register a case. fn(g) returns CLEAR for a refusal it checked, anything else for a checked result;
    accept = (types, words): a refusal of valid input that is still acceptable (a scale the precision cannot
    represent), if its type is one of types and its message names one of words. quick=False keeps a slow
    case out of the --quick run."""
    CASES.append(Case(len(CASES), tag, name, fn, accept, timeout, True if quick is None else quick))


def words_in(message, words):
    m = message.lower()
    return any(w.lower() in m for w in words)


def refused(call, types, words, untouched=()):
    """call() must raise one of types with a message naming one of words, leaving the arrays untouched."""
    before = [np.array(a, copy=True) for a in untouched]
    try:
        r = call()
    except types as e:
        if not words_in(str(e), words):
            raise BadError(f"{type(e).__name__} naming none of {words}: {e}")
        for a, b in zip(untouched, before):
            if not np.array_equal(a, b, equal_nan=True):
                raise Wrong("an array was written by a refused call")
        return CLEAR
    except (Wrong, BadError, Hang, Skip):
        raise
    except Exception as e:  # noqa: BLE001 - classified here
        names = "/".join(t.__name__ for t in (types if isinstance(types, tuple) else (types,)))
        raise BadError(f"expected {names} naming one of {words}, got {type(e).__name__}: {e}")
    raise Wrong(f"accepted, returned {summary(r)}")


def summary(r):
    if isinstance(r, np.ndarray):
        return f"array {r.shape} {r.dtype}" + (" with NaN" if r.dtype.kind == "f" and np.isnan(r).any() else "")
    return repr(r)[:80]


def same(a, b, what):
    if a.shape != b.shape or a.dtype != b.dtype or not np.array_equal(a, b):
        d = np.nanmax(np.abs(a.astype(np.float64) - b.astype(np.float64))) if a.shape == b.shape else "shape"
        raise Wrong(f"{what}: not bitwise equal (max diff {d})")


def finite(X, what="result"):
    if not np.all(np.isfinite(X)):
        raise Wrong(f"{what}: {int(np.sum(~np.isfinite(X)))} non-finite values")


def within(X, ref, tol, what):
    """|X_i - ref_i| <= tol_i for every row i (tol a scalar or per row)."""
    finite(X, what)
    if np.ndim(ref) > 1:
        # Each row's norm, scaled first so that it does not overflow: rows near 1e300 differ by about 1e284,
        # whose squares are beyond double.
        d = np.asarray(X, np.float64) - ref
        s = np.max(np.abs(d), axis=-1, keepdims=True)
        s = np.where(s == 0, 1.0, s)
        err = s[..., 0] * np.linalg.norm(d / s, axis=-1)
    else:
        err = np.abs(X - ref)
    tol = np.broadcast_to(tol, err.shape)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(err == 0, 0.0, err / tol)  # a zero bound: bitwise equality
    if not np.all(ratio <= 1):
        i = int(np.argmax(ratio))
        raise Wrong(
            f"{what}: {int(np.sum(ratio > 1))} of {ratio.size} beyond the bound, worst "
            f"{float(np.max(err)):.3g} (x{float(ratio.flat[i]):.3g} of its bound at {i})"
        )


DTYPES = (np.float32, np.float64)
METHODS = ("axis_angle", "horn_quaternion", "horn_matrix", "kanatani", "svd")
VALUE, TYPE, INDEX, RUNTIME = ValueError, TypeError, IndexError, RuntimeError
# A refusal of a valid input at the edge of the precision's range names its reason.
SCALE_WORDS = [
    "scale",
    "range",
    "represent",
    "overflow",
    "underflow",
    "too large",
    "too small",
    "beyond",
    "extent",
    "magnitude",
    "max(T)",
]
SCALE_ACCEPT = (ValueError, SCALE_WORDS)
