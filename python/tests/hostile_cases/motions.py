"""The frames' oracle: an exact rigid, similarity or affine motion x -> A x + t of every handle, which MLS
reproduces, so every vertex must get A's position and frame (rotation, quaternion, scale, linear part), with
the per-vertex conditioning its tolerance needs, computed in float64 from the paper's sums (independently of
the library's tables, kernels and limits)."""
import numpy as np

from support import random_rotation

from .common import EPS, EPS64, Wrong, finite, within
from .references import PAPER_W

# The ratio beyond which the docs (docs/api.md, "On and beside handles") take a vertex's fit apart in double:
# the nearest handle's term outweighs the others' spread by 2^10 (float) or 2^26 (double). Below it the fit
# runs in T on sums whose conditioning is at most that ratio times the others' own: the cap on kappa below.
CAP = {np.float32: 2.0**10, np.float64: 2.0**26}


def motion(g, transform):
    """(A, R, s, t): x -> A x + t with A = R (rigid), s R (similarity, s in [0.5, 2]) or a general invertible
    matrix of condition number at most 10 (affine; R its polar rotation is not needed)."""
    R = random_rotation(g)
    t = g.uniform(-1, 1, 3)
    if transform == "rigid":
        return R, R, 1.0, t
    if transform == "similarity":
        s = float(g.uniform(0.5, 2))
        return s * R, R, s, t
    while True:
        A = R @ (np.eye(3) + 0.45 * g.uniform(-1, 1, (3, 3)))
        if np.linalg.cond(A) < 10:
            return A, None, None, t


def moved(X, A, t, dt):
    """The exact image of X (already in dt), computed in float64 and rounded once to dt: the targets."""
    return np.ascontiguousarray((np.asarray(X, np.float64) @ A.T + t).astype(dt))


def _exact_segment_terms(v, a, b, u, nodes=16):
    """The exact_integral weights along segment a-b seen from v: (weight, first moment, second moment) of
    w(x) = |x - v|^-u over the segment (arc-length measure), by Gauss-Legendre on intervals graded
    geometrically around the closest point (the integrand's peak has width |v - p(t)|)."""
    e = b - a
    L2 = e @ e
    t0 = float(np.clip((v - a) @ e / L2, 0, 1))
    d = np.linalg.norm(a + t0 * e - v) / np.sqrt(L2)
    cuts = {0.0, 1.0, t0}
    h = max(d, 1e-18)
    while h < 1:
        cuts.update({min(1.0, t0 + h), max(0.0, t0 - h)})
        h *= 4
    cuts = np.array(sorted(cuts))
    x, wq = np.polynomial.legendre.leggauss(nodes)
    lo, hi = cuts[:-1], cuts[1:]
    ts = ((hi - lo)[:, None] * (x[None] + 1) / 2 + lo[:, None]).ravel()
    ws = ((hi - lo)[:, None] / 2 * wq[None]).ravel() * np.sqrt(L2)
    pts = a + ts[:, None] * e
    w = ws * np.linalg.norm(pts - v, axis=1) ** -u
    return w.sum(), w @ pts, np.einsum("k,ka,kb->ab", w, pts, pts)


def conditioning(V, P, A=None, B=None, sw="paper_constant", u=2.0, transform="rigid"):
    """Per vertex, in float64: (kappa_full, kappa_others, c, r) where kappa_full is the condition number of
    the fit as MLS poses it at the vertex (the rotation fit's s1 / (s2 + s3) of G = sum_j w_j phat phat^T for
    rigid and similarity, kappa(G) for affine; under an exact motion H = A G), kappa_others the same without
    the nearest handle's term (what stays when that term is set apart: the fit's limit on the handle), and r
    = |v - p*|, the lever arm a rotation error moves the position by. A vertex exactly on a handle has an
    infinite kappa_full."""
    V = np.asarray(V, np.float64)
    P = np.asarray(P, np.float64).reshape(-1, 3)
    segs = A is not None and len(A) > 0
    if segs:
        A = np.asarray(A, np.float64).reshape(-1, 3)
        B = np.asarray(B, np.float64).reshape(-1, 3)
    kf, ko, arm = (np.empty(len(V)) for _ in range(3))

    def kappa(G):
        if not np.all(np.isfinite(G)):
            return np.inf  # a weight beyond double's range: the vertex is on the handle for the sums
        s = np.linalg.svd(G, compute_uv=False)
        if transform == "affine":
            return s[0] / s[2] if s[2] > 0 else np.inf
        return s[0] / (s[1] + s[2]) if s[1] + s[2] > 0 else np.inf

    for i, v in enumerate(V):
        # Each handle's (weight, first moment, second moment) about the origin.
        terms, dist = [], []
        for p in P:
            r = np.linalg.norm(p - v)
            w = r**-u if r > 0 else np.inf
            terms.append((w, w * p, w * np.outer(p, p)) if r > 0 else None)
            dist.append(r)
        for j in range(len(A) if segs else 0):
            a, b = A[j], B[j]
            e = b - a
            t0 = np.clip((v - a) @ e / (e @ e), 0, 1)
            r = np.linalg.norm(a + t0 * e - v)
            dist.append(r)
            if r == 0:
                terms.append(None)
            elif sw == "paper_constant":
                w = r**-u
                ends = np.stack([a, b])
                terms.append((w, w * (a + b) / 2, w * np.einsum("kj,ka,jb->ab", PAPER_W, ends, ends)))
            else:
                terms.append(_exact_segment_terms(v, a, b, u))
        near = int(np.argmin(dist))

        def centred(ts):
            W = sum(x[0] for x in ts)
            m = sum(x[1] for x in ts) / W
            return sum(x[2] for x in ts) - W * np.outer(m, m), m

        others = [x for k, x in enumerate(terms) if k != near]
        if any(x is None for x in others) or not others:
            kf[i] = ko[i] = np.inf
            arm[i] = 0.0
            continue
        # The others about the nearest handle's closest point c (the limit there: sum_{j != n} w_j (p_j - c)
        # (p_j - c)^T, weights as seen from v).
        if near < len(P):
            c = P[near]
        else:
            a, b = A[near - len(P)], B[near - len(P)]
            c = a + np.clip((v - a) @ (b - a) / ((b - a) @ (b - a)), 0, 1) * (b - a)
        W = sum(x[0] for x in others)
        m1 = sum(x[1] for x in others)
        Go = sum(x[2] for x in others) - np.outer(c, m1) - np.outer(m1, c) + W * np.outer(c, c)
        ko[i] = kappa(Go)
        if terms[near] is None:
            kf[i] = np.inf
            arm[i] = 0.0
            continue
        G, m = centred(terms)
        kf[i] = kappa(G)
        arm[i] = np.linalg.norm(v - m)
        if not np.isfinite(arm[i]):
            # The nearest term's weight is beyond double's range (a vertex on a segment within rounding): p*
            # is that term's own centre, the closest point (exact_integral) or the midpoint (paper_constant);
            # the larger of the two distances bounds the lever arm.
            if near < len(P):
                arm[i] = np.linalg.norm(v - c)
            else:
                a, b = A[near - len(P)], B[near - len(P)]
                arm[i] = max(np.linalg.norm(v - c), np.linalg.norm(v - (a + b) / 2))
    return kf, ko, arm


def rotation_bound(kappa, eps):
    # The accuracy suite's bound on a rotation fit's angle error, 2 sqrt(3) 16 eps kappa + 96 eps, as a
    # Frobenius distance between two rotations (twice the angle bounds it), plus float64's own 64 eps64 kappa
    # for the conditioning computed here (references.rotation_tol, the same).
    return 2 * ((2 * np.sqrt(3) * 16 * kappa + 96) * eps + 64 * EPS64 * kappa)


def effective_kappa(kf, ko, dt, on):
    """The conditioning a correct evaluation in dt faces at each vertex. Away from handles, the fit's own
    kappa_full. Beside a handle the nearest term's weight grows without bound, but its part along itself only
    pins what it pins (the handle's direction for a segment, nothing for a point): the docs' design evaluates
    the fit in T while that term outweighs the others by less than CAP, and in double beyond, so the error is
    at most that of a fit of conditioning CAP x kappa_others. On a handle (distance 0), the fit's limit, whose
    conditioning is kappa_others."""
    k = np.minimum(kf, CAP[dt] * ko)
    return np.where(on, ko, k)


def check_motion(X, fr, V, A, R, s, t, transform, dt, kappa, arm, J, what):
    """Every vertex: position A v + t and frame A (rotation R, quaternion of R up to sign, scale s, linear A),
    to bounds derived per vertex from kappa (the conditioning a correct evaluation faces) and J (pseudo-handles).

    Positions: q* carries the weighted sums' (J + 16) eps relative error on coordinates of size `scale`
    (references.mls_tol's 16 (J + 16) eps with kappa 0: q* has no fit in it), plus the frame's error times the
    lever arm |v - p*| it turns. The targets were rounded to T once: eps/2 |q| on data whose spread is the
    handles' spacing, which the fit carries with kappa, inside rotation_bound's 96 eps + kappa terms."""
    eps = EPS[dt]
    V64 = np.asarray(V, np.float64)
    scale = max(np.abs(V64).max(), np.abs(V64 @ A.T + t).max(), 1.0)
    finite(X, f"{what}: positions")
    tolR = rotation_bound(kappa, eps)
    nA = np.linalg.norm(A, 2)
    tol_pos = 16 * (J + 16) * eps * scale + tolR * nA * arm
    within(X, V64 @ A.T + t, tol_pos, f"{what}: positions")
    if transform == "affine":
        # L = H G^-1: the weighted sums' (J + 16) eps relative error (references.mls_tol's derivation) through
        # G^-1, amplified by kappa(G), times 16 for both sides and the paths' constants, relative to |A|; plus
        # float64's own 64 eps64 kappa for the conditioning computed here.
        L = fr["linear"].astype(np.float64)
        finite(L, f"{what}: linear")
        tolL = (16 * (J + 16) * eps * (1 + kappa) + 64 * EPS64 * kappa) * nA
        within(L.reshape(-1, 9), np.broadcast_to(A.reshape(9), (len(V), 9)), tolL, f"{what}: linear = A")
        return
    Rg = fr["rotations"].astype(np.float64)
    q = fr["quaternions"].astype(np.float64)
    sc = fr["scales"].astype(np.float64)
    L = fr["linear"].astype(np.float64)
    for name, arr in (("rotations", Rg), ("quaternions", q), ("scales", sc), ("linear", L)):
        finite(arr, f"{what}: {name}")
    within(Rg.reshape(-1, 9), np.broadcast_to(R.reshape(9), (len(V), 9)), tolR, f"{what}: rotations = R")
    # A unit quaternion with w >= 0 (docs), rounded to T: its norm off 1 by a few eps.
    if np.any(q[:, 0] < 0):
        raise Wrong(f"{what}: {int(np.sum(q[:, 0] < 0))} quaternions with w < 0")
    within(np.linalg.norm(q, axis=1), np.ones(len(q)), 8 * eps, f"{what}: |quaternion|")
    q0 = quaternion_of(R)
    # |q - q0| is half the rotation angle's chord: at most the Frobenius distance of the rotations, whose
    # bound tolR is; up to the sign (both are the rotation at w = 0).
    dq = np.minimum(np.linalg.norm(q - q0, axis=1), np.linalg.norm(q + q0, axis=1))
    within(dq, np.zeros(len(q)), tolR, f"{what}: quaternions = q(R)")
    # The scale is trace(R^T H) / trace(G): relative error of the fit's order, tolR.
    within(sc, np.full(len(sc), s), s * tolR, f"{what}: scales = s")
    within(L.reshape(-1, 9), np.broadcast_to((s * R).reshape(9), (len(V), 9)), s * tolR + s * eps, f"{what}: linear")


def quaternion_of(R):
    """The unit quaternion (w, x, y, z), w >= 0, of a rotation matrix (float64, from the largest of the four
    squared components)."""
    t = np.trace(R)
    c = np.array([1 + t, 1 + 2 * R[0, 0] - t, 1 + 2 * R[1, 1] - t, 1 + 2 * R[2, 2] - t]) / 4
    k = int(np.argmax(c))
    q = np.empty(4)
    q[k] = np.sqrt(c[k])
    f = 4 * q[k]
    if k == 0:
        q[1:] = [(R[2, 1] - R[1, 2]) / f, (R[0, 2] - R[2, 0]) / f, (R[1, 0] - R[0, 1]) / f]
    elif k == 1:
        q[[0, 2, 3]] = [(R[2, 1] - R[1, 2]) / f, (R[0, 1] + R[1, 0]) / f, (R[0, 2] + R[2, 0]) / f]
    elif k == 2:
        q[[0, 1, 3]] = [(R[0, 2] - R[2, 0]) / f, (R[0, 1] + R[1, 0]) / f, (R[1, 2] + R[2, 1]) / f]
    else:
        q[[0, 1, 2]] = [(R[1, 0] - R[0, 1]) / f, (R[0, 2] + R[2, 0]) / f, (R[1, 2] + R[2, 1]) / f]
    return q if q[0] >= 0 else -q


def frame_arrays(n, dt, transform):
    if transform == "affine":
        return {"linear": np.full((n, 3, 3), np.nan, dt)}
    return {
        "quaternions": np.full((n, 4), np.nan, dt),
        "rotations": np.full((n, 3, 3), np.nan, dt),
        "scales": np.full((n,), np.nan, dt),
        "linear": np.full((n, 3, 3), np.nan, dt),
    }
