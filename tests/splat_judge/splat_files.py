"""Splat scenes and files for the splat-format judge (judge.py): a random 3DGS scene of a given SH degree, a
binary PLY reader and writer for float vertex elements, the antimatter15 `.splat` writer (its convert.py's
rules), and the chunk bounds of a compressed PLY (for the per-chunk error bounds). numpy only."""

import numpy as np

C0 = 0.28209479177387814  # band 0's SH constant, 1 / (2 sqrt(pi))
TYPES = {
    "float": "<f4",
    "float32": "<f4",
    "double": "<f8",
    "float64": "<f8",
    "uchar": "u1",
    "uint8": "u1",
    "uint": "<u4",
    "uint32": "<u4",
    "int": "<i4",
    "int32": "<i4",
}


def splat_names(degree):
    rest = 3 * ((degree + 1) ** 2 - 1)
    return (
        ["x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2"]
        + [f"f_rest_{k}" for k in range(rest)]
        + ["opacity", "scale_0", "scale_1", "scale_2"]
        + ["rot_0", "rot_1", "rot_2", "rot_3"]
    )


def scene(n, degree, seed):
    """n splats on a jittered grid (centres at least 0.1 apart, so that a reordered file is matched back by
    nearest centres), values well inside every format's range: SH rest within +-0.25 (a rotated band's
    coefficients stay within its norm, sqrt(7) * 0.25 < 1, SPZ's range), band 0 within +-1.5, log scales
    in [-5, -1], opacities of every size, quaternions uniform on the sphere (unnormalised, as trained)."""
    rng = np.random.default_rng(seed)
    side = int(np.ceil(n ** (1 / 3)))
    cells = rng.permutation(side**3)[:n]
    grid = np.stack([cells % side, cells // side % side, cells // side**2], 1)
    d = {}
    centre = (grid - (side - 1) / 2) * (4.0 / side) + rng.uniform(-0.1, 0.1, (n, 3)) * (4.0 / side)
    d["x"], d["y"], d["z"] = centre.T
    for k in range(3):
        d[f"f_dc_{k}"] = rng.uniform(-1.5, 1.5, n)
        d[f"scale_{k}"] = rng.uniform(-5, -1, n)
    for k in range(3 * ((degree + 1) ** 2 - 1)):
        d[f"f_rest_{k}"] = rng.uniform(-0.25, 0.25, n)
    d["opacity"] = rng.normal(0, 2.5, n)
    q = rng.normal(0, 1, (n, 4)) * rng.uniform(0.5, 2, (n, 1))
    for k in range(4):
        d[f"rot_{k}"] = q[:, k]
    return {k: np.asarray(d[k], np.float32) for k in splat_names(degree)}


def write_ply(path, columns):
    names = list(columns)
    n = len(columns[names[0]])
    head = f"ply\nformat binary_little_endian 1.0\nelement vertex {n}\n"
    head += "".join(f"property float {k}\n" for k in names) + "end_header\n"
    body = np.stack([np.asarray(columns[k], np.float32) for k in names], 1)
    with open(path, "wb") as f:
        f.write(head.encode() + body.astype("<f4").tobytes())


def read_ply(path):
    """Every element of a binary little-endian PLY without lists: {element: {property: array}}."""
    data = open(path, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    elements = []
    for line in data[:end].decode().splitlines():
        w = line.split()
        if w[0] == "format":
            assert w[1] == "binary_little_endian", path
        elif w[0] == "element":
            elements.append((w[1], int(w[2]), []))
        elif w[0] == "property":
            assert w[1] != "list", path
            elements[-1][2].append((w[2], TYPES[w[1]]))
    out, at = {}, end
    for name, count, props in elements:
        dt = np.dtype(props)
        rows = np.frombuffer(data, dt, count, at)
        at += dt.itemsize * count
        out[name] = {p: rows[p].astype(np.float64) for p, _ in props}
    assert at == len(data), f"{path}: {len(data) - at} bytes after the last element"
    return out


def write_splat(path, columns):
    """The antimatter15 layout as its convert.py writes it: float centre, float exp(scale), RGBA bytes of
    0.5 + C0 f_dc and sigmoid(opacity), quaternion bytes q / |q| * 128 + 128, each clipped and truncated."""
    n = len(columns["x"])
    rec = np.zeros(n, [("p", "<f4", 3), ("s", "<f4", 3), ("c", "u1", 4), ("r", "u1", 4)])
    rec["p"] = np.stack([columns[k] for k in "xyz"], 1)
    rec["s"] = np.exp(np.stack([columns[f"scale_{k}"] for k in range(3)], 1))
    rgb = 0.5 + C0 * np.stack([columns[f"f_dc_{k}"] for k in range(3)], 1)
    alpha = 1 / (1 + np.exp(-columns["opacity"].astype(np.float64)))
    rgba = np.concatenate([rgb, alpha[:, None]], 1) * 255
    rec["c"] = np.clip(rgba, 0, 255).astype(np.uint8)
    q = np.stack([columns[f"rot_{k}"] for k in range(4)], 1).astype(np.float64)
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    rec["r"] = np.clip(q * 128 + 128, 0, 255).astype(np.uint8)
    with open(path, "wb") as f:
        f.write(rec.tobytes())


def chunk_extents(path):
    """Per splat of a compressed PLY (file order): the extent (max - min) of its chunk's centre, log scale
    and colour bounds, n x 3 each, and the largest bound's size (for float rounding)."""
    chunk = read_ply(path)["chunk"]
    n = len(read_ply(path)["vertex"]["packed_position"])
    which = np.arange(n) // 256

    def extent(lo, hi):
        return np.stack([chunk[hi[k]] - chunk[lo[k]] for k in range(3)], 1)[which]

    pos = extent(["min_x", "min_y", "min_z"], ["max_x", "max_y", "max_z"])
    scl = extent(["min_scale_x", "min_scale_y", "min_scale_z"], ["max_scale_x", "max_scale_y", "max_scale_z"])
    col = extent(["min_r", "min_g", "min_b"], ["max_r", "max_g", "max_b"])
    big = np.max(np.abs(np.stack(list(chunk.values()), 1)), 1)[which]
    return pos, scl, col, big
