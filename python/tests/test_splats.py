"""The splat functions from Python (mlsdeform.rotate_splats, transform_splats_affine) and the example that
deforms a splat array in numpy (python/examples/deform_splats.py)."""
import os
import subprocess
import sys

import numpy as np
import pytest

import mlsdeform
from support import rng

EXAMPLES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "examples")

# 3DGS's real SH, bands 1-3, written from the textbook normalisations with the Condon-Shortley phase (an
# independent copy of what the library evaluates).
_PI = np.pi


def basis(d):
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    n1, n2, n20, n22 = np.sqrt(3 / (4 * _PI)), np.sqrt(15 / _PI) / 2, np.sqrt(5 / _PI) / 4, np.sqrt(15 / _PI) / 4
    n33, n32, n31, n30 = (
        np.sqrt(35 / (2 * _PI)) / 4,
        np.sqrt(105 / _PI) / 2,
        np.sqrt(21 / (2 * _PI)) / 4,
        np.sqrt(7 / _PI) / 4,
    )
    b = [n1 * y, n1 * z, n1 * x, n2 * x * y, n2 * y * z, n20 * (3 * z * z - 1), n2 * x * z, n22 * (x * x - y * y)]
    b += [n33 * y * (3 * x * x - y * y), n32 * x * y * z, n31 * y * (5 * z * z - 1), n30 * z * (5 * z * z - 3)]
    b += [n31 * x * (5 * z * z - 1), n32 / 2 * z * (x * x - y * y), n33 * x * (x * x - 3 * y * y)]
    m = np.array([-1, 0, 1, -2, -1, 0, 1, 2, -3, -2, -1, 0, 1, 2, 3])
    return np.stack(b, axis=-1) * np.where(m % 2 != 0, -1, 1)


def unit_quaternions(g, n):
    q = g.normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def rotation_of(q):
    w, x, y, z = q / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def splats(g, n, dtype):
    return (
        (g.normal(size=(n, 4)) * 1.5).astype(dtype),
        (np.log(0.02) + 0.5 * g.normal(size=(n, 3))).astype(dtype),
        (0.1 * g.normal(size=(n, 45))).astype(dtype),
    )


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_rotated_colour_seen_from_rotated_direction(dtype):
    g = rng()
    n = 50
    rot, ls, sh = splats(g, n, dtype)
    before = sh.copy()
    q = unit_quaternions(g, n)
    Rs = [
        rotation_of(qi.astype(dtype).astype(np.float64)) for qi in q
    ]  # the rotation of the quaternion the library receives
    mlsdeform.rotate_splats(q, rotations=rot, log_scales=ls, sh_rest=sh)
    d = g.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    for c in range(3):
        f = np.sum(before[:, 15 * c : 15 * c + 15] * basis(d), axis=1)
        f_rotated = np.sum(sh[:, 15 * c : 15 * c + 15] * basis(np.einsum("nij,nj->ni", np.array(Rs), d)), axis=1)
        # test_splats.cpp's colour bound, (eps / 2 + 2600 eps_d) |c| sqrt(15 / 4 pi): the coefficients rounded
        # to dtype once, the rest in double; R is that of the quaternion as the library receives it.
        eps = np.finfo(dtype).eps
        bound = (eps / 2 + 2600 * np.finfo(np.float64).eps) * np.linalg.norm(before, axis=1) * np.sqrt(15 / (4 * _PI))
        assert np.all(np.abs(f_rotated - f) <= bound)


def test_identity_keeps_every_bit_and_dtypes_are_kept():
    g = rng()
    for dtype in (np.float32, np.float64):
        rot, ls, sh = splats(g, 20, dtype)
        copies = rot.copy(), ls.copy(), sh.copy()
        q = np.tile([1.0, 0, 0, 0], (20, 1))
        mlsdeform.rotate_splats(q, np.ones(20), rotations=rot, log_scales=ls, sh_rest=sh.reshape(20, 3, 15))
        mlsdeform.transform_splats_affine(np.tile(np.eye(3), (20, 1, 1)), rotations=rot, log_scales=ls, sh_rest=sh)
        for a, b in zip((rot, ls, sh), copies):
            assert a.dtype == dtype and a.tobytes() == b.tobytes()


def test_affine_by_a_rotation_times_s_is_the_similarity():
    g = rng()
    rot, ls, sh = splats(g, 30, np.float64)
    a = rot.copy(), ls.copy(), sh.copy()
    q = unit_quaternions(g, 30)
    Rs = [rotation_of(qi) for qi in q]
    s = g.uniform(0.5, 2, 30)
    mlsdeform.rotate_splats(q, s, rotations=rot, log_scales=ls, sh_rest=sh)
    mlsdeform.transform_splats_affine(
        np.array([si * R for si, R in zip(s, Rs)]), rotations=a[0], log_scales=a[1], sh_rest=a[2]
    )

    def cov(q, log_scales):
        R = np.array([rotation_of(qi) for qi in q])
        return np.einsum("nij,nj,nkj->nik", R, np.exp(2 * log_scales), R)

    # Both in double: a covariance agrees to a few hundred eps of its size, the SH coefficients likewise.
    C1, C2 = cov(rot, ls), cov(a[0], a[1])
    assert np.all(np.abs(C1 - C2) <= 1e-12 * np.abs(C1).max(axis=(1, 2), keepdims=True))
    assert np.allclose(sh, a[2], rtol=0, atol=1e-12)


def test_bad_input_names_the_problem_and_writes_nothing():
    g = rng()
    rot, ls, sh = splats(g, 10, np.float32)
    q = np.tile([1.0, 0, 0, 0], (10, 1))
    q[:, :] = [0, 1, 0, 0]
    sh[4, 7] = np.nan
    copies = rot.copy(), ls.copy()
    with pytest.raises(ValueError, match="splat 4: SH coefficient"):
        mlsdeform.rotate_splats(q, rotations=rot, log_scales=ls, sh_rest=sh)
    assert rot.tobytes() == copies[0].tobytes() and ls.tobytes() == copies[1].tobytes()
    with pytest.raises(ValueError, match="not a unit quaternion"):
        mlsdeform.rotate_splats(2 * q, rotations=rot)
    with pytest.raises(TypeError, match="log_scales: expected dtype float32"):
        mlsdeform.rotate_splats(q, rotations=rot, log_scales=ls.astype(np.float64))
    with pytest.raises(ValueError, match=r"rotations: expected shape \(10, 4\)"):
        mlsdeform.rotate_splats(q, rotations=rot[:, :3].copy())
    with pytest.raises(ValueError, match="sh_rest: expected shape"):
        mlsdeform.rotate_splats(q, sh_rest=sh[:, :40].copy())
    with pytest.raises(ValueError, match="C-contiguous"):
        mlsdeform.rotate_splats(q[::2], log_scales=ls[::2])
    ro = ls.copy()
    ro.flags.writeable = False
    with pytest.raises(ValueError, match="read-only"):
        mlsdeform.rotate_splats(q, log_scales=ro)
    with pytest.raises(ValueError, match="singular"):
        mlsdeform.transform_splats_affine(np.zeros((10, 3, 3)), rotations=rot, log_scales=ls)


def test_example_deforms_a_splat_array(tmp_path):
    out = tmp_path / "splats.npz"
    script = os.path.join(EXAMPLES, "deform_splats.py")
    text = subprocess.run([sys.executable, script, str(out)], check=True, capture_output=True, text=True).stdout
    assert "20000 splats" in text
    r = np.load(out)
    assert r["rotations"].dtype == np.float32 and r["sh_rest"].shape == (20000, 45)
    assert np.allclose(np.linalg.norm(r["rotations"], axis=1), 1, atol=1e-6)
    # the splats' new orientation is the MLS turn composed with their own: q' = q_R q
    sys.path.insert(0, EXAMPLES)
    try:
        import deform_splats
    finally:
        sys.path.pop(0)
    _, rest, _, _ = deform_splats.splat_bar()
    t = r["turns"].astype(np.float64)
    rest = rest / np.linalg.norm(rest, axis=1, keepdims=True)
    w0, v0 = t[:, :1], t[:, 1:]
    w1, v1 = rest[:, :1], rest[:, 1:]
    product = np.hstack([w0 * w1 - np.sum(v0 * v1, axis=1, keepdims=True), w0 * v1 + w1 * v0 + np.cross(v0, v1)])
    assert np.allclose(r["rotations"], product, atol=1e-5)
