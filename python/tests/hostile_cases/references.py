"""Independent references in numpy float64 and their tolerances: rotation fits by SVD, the direct per-vertex
MLS from the paper's equations, the RBF centroids."""
import numpy as np


from .common import EPS, EPS64, Wrong, finite, within


def kabsch(H):
    """The proper rotation maximising trace(R^T H) for a batch (m, 3, 3) (numpy's SVD, float64), and the
    fit's condition number kappa = s1 / (s2 + sign(det) s3)."""
    U, s, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(U @ Vt))
    d[d == 0] = 1
    R = U @ (np.eye(3) * np.stack([np.ones_like(d), np.ones_like(d), d], -1)[:, None, :]) @ Vt
    kappa = s[:, 0] / np.maximum(s[:, 1] + d * s[:, 2], 1e-300)
    return R, kappa


def rotation_tol(kappa, eps):
    # The accuracy suite's bound on either side's angle error, 2 sqrt(3) 16 eps kappa + 96 eps, for the
    # library and for the SVD (with its own 64 eps64 kappa), as a Frobenius distance between the two
    # rotations (twice the angle error bounds it): python/tests/test_mlsdeform.py uses the same.
    return 2 * ((2 * np.sqrt(3) * 16 * kappa + 96) * eps + 64 * EPS64 * kappa)


def check_rotations(R, H, eps, what="rotations"):
    """R (m, 3, 3) against numpy's SVD of H where the optimum is unique, and as a proper rotation with the
    optimal value trace(R^T H) everywhere (kappa = inf: the optimum is not unique)."""
    finite(R, what)
    H = np.asarray(H, np.float64)
    R = np.asarray(R, np.float64)
    Rk, kappa = kabsch(H)
    ortho = np.abs(R @ np.swapaxes(R, 1, 2) - np.eye(3)).max(axis=(1, 2))
    if np.any(ortho > 64 * eps) or np.any(np.abs(np.linalg.det(R) - 1) > 96 * eps):
        raise Wrong(f"{what}: not a proper rotation (|R R^T - I| up to {ortho.max():.3g})")
    unique = kappa < 1 / (1e3 * eps)
    err = np.linalg.norm(R - Rk, axis=(1, 2))
    tol = rotation_tol(kappa, eps)
    if np.any(unique & (err > tol)):
        i = int(np.argmax(np.where(unique, err / tol, 0)))
        raise Wrong(f"{what}: matrix {i} off by {err[i]:.3g} (bound {tol[i]:.3g}, kappa {kappa[i]:.3g})")
    # The optimal value, whatever the conditioning: it is flat at the optimum, so a rotation at angle e from
    # an optimal one loses only about e^2 |H|, and e itself is small along the directions H determines; the
    # traces' own rounding is 9 eps |H| on each side. 2 x 96 eps |H| (the accuracy suite's constant term,
    # twice) bounds both.
    value = np.einsum("mij,mij->m", R, H)
    best = np.einsum("mij,mij->m", Rk, H)
    scale = np.linalg.norm(H, axis=(1, 2))
    if np.any(value < best - 2 * 96 * eps * scale - 1e-300):
        i = int(np.argmin(value - best))
        raise Wrong(f"{what}: matrix {i} not optimal: trace {value[i]:.17g} < {best[i]:.17g}")


PAPER_W = np.array([[1 / 3, 1 / 6], [1 / 6, 1 / 3]])  # Sec. 6.2, the constant segment weights


def rbf_weights(centres, X):
    """beta (n, m): q* = beta @ values interpolates with phi(r) = r and a linear polynomial (docs/api.md),
    and kappa(M) of the interpolation matrix."""
    m = len(centres)
    Phi = np.linalg.norm(centres[:, None] - centres[None], axis=2)
    Pp = np.hstack([np.ones((m, 1)), centres])
    M = np.block([[Phi, Pp], [Pp.T, np.zeros((4, 4))]])
    rows = np.hstack([np.linalg.norm(X[:, None] - centres[None], axis=2), np.ones((len(X), 1)), X])
    beta = np.linalg.solve(M.T, rows.T).T[:, :m]
    return beta, np.linalg.cond(M)


def mls_reference(V, P, Q, A=None, B=None, C=None, D=None, transform="rigid", u=2.0, centroids="mls"):
    """The deformed vertices straight from the paper (eqs. 1-6; Sec. 6.1 similarity, Sec. 6.2 segments with
    the constant weights; RBF centroids q* = g(p*)), in float64, vectorised over vertices. Returns X, the
    per-vertex bound factor kappa (of the rotation fit, or of G for affine) and the extra error term of the
    RBF centroid (0 for MLS centroids)."""
    V, P, Q = (np.asarray(x, np.float64).reshape(-1, 3) for x in (V, P, Q))
    segs = A is not None and len(A) > 0
    if segs:
        A, B, C, D = (np.asarray(x, np.float64).reshape(-1, 3) for x in (A, B, C, D))
    wP = np.linalg.norm(P[None] - V[:, None], axis=2) ** -u
    S = wP.sum(1)
    p_star = wP @ P
    q_star = wP @ Q
    if segs:
        E = B - A
        t = np.clip(np.einsum("nsc,sc->ns", V[:, None] - A[None], E) / np.einsum("sc,sc->s", E, E), 0, 1)
        wS = np.linalg.norm(A[None] + t[..., None] * E[None] - V[:, None], axis=2) ** -u
        S = S + wS.sum(1)  # the constant W sums to 1
        p_star = p_star + wS @ ((A + B) / 2)
        q_star = q_star + wS @ ((C + D) / 2)
    p_star /= S[:, None]
    q_star /= S[:, None]
    Ph, Qh = P[None] - p_star[:, None], Q[None] - q_star[:, None]
    H = np.einsum("nj,nja,njb->nab", wP, Qh, Ph)
    G = np.einsum("nj,nja,njb->nab", wP, Ph, Ph)
    if segs:
        ends_p = [A[None] - p_star[:, None], B[None] - p_star[:, None]]
        ends_q = [C[None] - q_star[:, None], D[None] - q_star[:, None]]
        for k in range(2):
            for j in range(2):
                H += PAPER_W[k, j] * np.einsum("nj,nja,njb->nab", wS, ends_q[k], ends_p[j])
                G += PAPER_W[k, j] * np.einsum("nj,nja,njb->nab", wS, ends_p[k], ends_p[j])
    rbf_extra = np.zeros(len(V))
    if centroids == "rbf":
        rest = np.vstack([P] + ([A, B] if segs else []))
        moved = np.vstack([Q] + ([C, D] if segs else []))
        centres, first = np.unique(rest, axis=0, return_index=True)
        beta, kappa_m = rbf_weights(centres, p_star)
        q_star = beta @ moved[first]
        # docs/api.md: the centroid weights carry (J + 4) eps kappa(M) sum|beta| |q|, relative to |q|.
        rbf_extra = (len(rest) + 4) * kappa_m * np.abs(beta).sum(1) * np.abs(moved).max()
    vh = V - p_star
    if transform == "affine":
        X = q_star + np.einsum("nab,nb->na", H, np.linalg.solve(G, vh[..., None])[..., 0])
        return X, np.linalg.cond(G), rbf_extra
    R, kappa = kabsch(H)
    mu = np.ones(len(V))
    if transform == "similarity":
        mu = np.einsum("nij,nij->n", R, H) / np.trace(G, axis1=1, axis2=2)
    return q_star + mu[:, None] * np.einsum("nab,nb->na", R, vh), kappa, rbf_extra


def mls_tol(J, kappa, eps, scale, rbf_extra=0.0):
    # Per vertex: the weighted sums carry (J + 16) eps relative error (J pseudo-handles, plus the roundings
    # of the precomputed coefficients), amplified by kappa through the fit (or G^-1), on coordinates of size
    # `scale`; a factor 4 covers both sides (library and this float64 reference) and the paths' constants,
    # and another 4 the |v'| <= 4 |scene| of the unit test scenes (python/tests/test_mlsdeform.py derives it).
    # RBF centroids add their own term (docs/api.md).
    return 16 * (J + 16) * eps * (1 + kappa) * scale + 4 * eps * np.asarray(rbf_extra) * scale


def check_mls(
    X, V, P, Q, dtype, A=None, B=None, C=None, D=None, transform="rigid", u=2.0, centroids="mls", what="deform"
):
    ref, kappa, extra = mls_reference(V, P, Q, A, B, C, D, transform, u, centroids)
    J = len(P) + (2 * len(A) if A is not None else 0)
    scale = max(np.abs(x).max() for x in (V, P, Q, A, B, C, D) if x is not None and len(x))
    within(X, ref, mls_tol(J, kappa, EPS[dtype], scale, extra), what)
    return ref
