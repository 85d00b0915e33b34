"""Scenes for the cases: random clouds, grid meshes, rigid motions, exact scalings, and the ARAP bound."""
import numpy as np

from support import random_rotation


def cloud(g, n=300, k=6, s=0, dtype=np.float64):
    """Vertices and handles in [-1, 1]^3; moved handles by a random rotation plus noise. Returned in dtype
    (the reference reads the same rounded values)."""
    V = g.uniform(-1, 1, (n, 3))
    P = g.uniform(-1, 1, (k, 3))
    A = g.uniform(-1, 1, (s, 3))
    B = A + g.uniform(-0.6, 0.6, (s, 3))
    R = random_rotation(g)
    Q = P @ R.T + g.normal(scale=0.1, size=P.shape) + 0.2
    C, D = A @ R.T + 0.2, B @ R.T + 0.2
    return tuple(np.ascontiguousarray(x, dtype) for x in (V, P, Q, A, B, C, D))


def grid_mesh(nx=10, ny=10, dtype=np.float64):
    """A gently curved nx x ny sheet, two triangles per quad, unit side."""
    x, y = np.meshgrid(np.linspace(0, 1, nx), np.linspace(0, 1, ny), indexing="ij")
    V = np.stack([x.ravel(), y.ravel(), 0.1 * np.sin(3 * x.ravel()) * np.cos(2 * y.ravel())], 1)
    F = []
    for i in range(nx - 1):
        for j in range(ny - 1):
            a, b, c, d = i * ny + j, (i + 1) * ny + j, (i + 1) * ny + j + 1, i * ny + j + 1
            F += [[a, b, c], [a, c, d]]
    return V.astype(dtype), np.array(F)


def rigid(g):
    R = random_rotation(g)
    t = g.uniform(-1, 1, 3)
    return R, t, (lambda X: np.asarray(X, np.float64) @ R.T + t)


def arap_tol(V, F, held, iterations, eps, scale):
    """A bound for an ARAP result against an exact invariant (rest pose, rigid motion): each iteration's
    global step solves L x = b, L the cotangent Laplacian (weights (cot a + cot b) / 2, clamped at zero, as
    the refiner builds it: docs/cli.md) without the held vertices' rows, by a backward-stable Cholesky
    factorisation, so its error is c eps cond(L) |x|; c = 64 covers the solve, the right-hand side and the
    local step's rotation fits (Wilkinson's 3n is a worst case the sparse factor's short dot products do not
    reach). Per iteration, plus the MLS start (mls_tol's 16 (J + 16))."""
    n = len(V)
    W = np.zeros((n, n))
    for tri in F:
        for k in range(3):
            i, j, o = tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]
            e1, e2 = V[i] - V[o], V[j] - V[o]
            cot = np.dot(e1, e2) / max(np.linalg.norm(np.cross(e1, e2)), 1e-300)
            W[i, j] += cot / 2
            W[j, i] += cot / 2
    W = np.maximum(W, 0)
    L = np.diag(W.sum(1)) - W
    free = np.setdiff1d(np.arange(n), held)
    cond = np.linalg.cond(L[np.ix_(free, free)])
    return (64 * iterations * cond + 16 * (len(held) + 16)) * eps * scale


def exact_scaling(e, dt, *arrays):
    """The arrays rounded so that they and their multiples by 2^e are all exact in dt: values that 2^e
    would push into the subnormal range keep only the digits they keep there (so the scaled scene is the
    same problem, not a rounded one)."""
    return tuple(np.ldexp(np.ldexp(np.asarray(x, np.float64), e).astype(dt).astype(np.float64), -e) for x in arrays)


def misaligned(X):
    """A C-contiguous copy of X at an odd address (one byte into a buffer)."""
    raw = np.zeros(X.nbytes + 1, np.uint8)[1:].view(X.dtype).reshape(X.shape)
    raw[...] = X
    return raw


def region_ring(F, region, n):
    """The outside vertices sharing a triangle with a region vertex (docs/api.md, Region of interest)."""
    inside = np.zeros(n, bool)
    inside[region] = True
    touching = inside[F].any(axis=1)
    ring = np.unique(F[touching])
    return ring[~inside[ring]]
