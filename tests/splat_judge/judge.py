"""The splat formats against an independent converter (PlayCanvas splat-transform, pinned in package-lock.json):
for a random scene of SH degree D, a rigid motion of every handle gives, through each format, the program's
own 3DGS PLY result within that format's derived bound (docs/splats.md, "Other formats"):

  in:   splat-transform encodes the scene, the program reads and deforms it, writes 3DGS PLY;
  out:  the program deforms the scene's PLY and writes the format, splat-transform decodes it;
  both: splat-transform encodes, the program reads, deforms and writes the format, splat-transform decodes.

SPZ is tried as splat-transform writes it (version 4, zstd) and as version 3 (gzip); compressed PLY (which
splat-transform reorders: splats are matched back by their nearest centres); `.splat` (read only) from its
convert.py rules, the program's reading against splat-transform's and against the scene.

  judge.py --mlsdeform build/tools/mlsdeform --degree 3 [--splats 900] [--seed 1]

Exit 77 (ctest: skipped), saying why, where node or splat-transform is not installed (tools/install_deps.sh
judge)."""

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np

import splat_files as sf

HERE = os.path.dirname(os.path.abspath(__file__))
EPS = 2.0**-23  # float's epsilon
H_ROT = {"spz": 0.5 * np.sqrt(0.5) / 511, "cply": 0.5 * np.sqrt(2) / 1023}


def rot_bound(h):
    """Largest rotation angle from a quaternion stored as its three smallest components, each within h: the
    error vector (e, de) with de = -(q_s . e) / q_L and q_L >= 1/2 has |.| <= |e| / q_L <= 2 sqrt(3) h, and a
    unit quaternion's chord c is the angle 4 asin(c / 2) ~ 2c."""
    return 4 * np.arcsin(np.sqrt(3) * h) * 1.001


def bounds(fmt, writer, path, n, degree):
    """Per splat (file order) the error a file in `fmt` allows each quantity, written by `writer` ("judge":
    splat-transform's encoder, "mine": the program's), as docs/splats.md derives them: centre (Euclidean),
    rotation angle, log scale, band 0, linear opacity, and an SH coefficient per band (l = 1, 2, 3)."""
    b = {}
    if fmt == "spz":
        b["pos"] = np.full(n, np.sqrt(3) * 2.0**-13)  # 24-bit fixed point, 12 fractional bits
        b["rot"] = np.full(n, rot_bound(H_ROT["spz"]))
        b["scale"] = np.full((n, 3), 1 / 32)  # (s + 10) * 16 in 8 bits
        b["f_dc"] = np.full((n, 3), 0.5 / (0.15 * 255))
        b["alpha"] = np.full(n, 0.5 / 255)
        # splat-transform keeps 5 bits of band 1 and 4 of bands 2-3 (buckets of 8 and 16 of the 8-bit steps);
        # the program keeps all 8.
        steps = [0.5 + 4, 0.5 + 8, 0.5 + 8] if writer == "judge" else [0.5, 0.5, 0.5]
        b["sh"] = [np.full(n, s / 128) for s in steps]
    else:
        pos, scl, col, big = sf.chunk_extents(path)
        steps = np.array([2047, 1023, 2047])
        slack = 4 * EPS * big  # the lerp's float rounding
        # splat-transform maps a chunk narrower than 1e-5 to its minimum
        flat = 1e-5 if writer == "judge" else 0
        b["pos"] = np.linalg.norm(pos / (2 * steps) + flat + slack[:, None], axis=1)
        b["rot"] = np.full(n, rot_bound(H_ROT["cply"]))
        b["scale"] = scl / (2 * steps) + flat + slack[:, None]
        b["f_dc"] = (col / 510 + flat + slack[:, None]) / sf.C0
        b["alpha"] = np.full(n, 0.5 / 255)
        b["sh"] = [np.full(n, 1 / 64)] * 3  # bucket centres 8 / 256 apart (|v| < 4 - 1/32)
    return b


def add(a, b):
    return {k: [x + y for x, y in zip(a[k], b[k])] if k == "sh" else a[k] + b[k] for k in a}


def measure(ref, got, degree):
    """Per splat and quantity, the difference between two files' splats (same order)."""
    q1 = np.stack([ref[f"rot_{k}"] for k in range(4)], 1)
    q2 = np.stack([got[f"rot_{k}"] for k in range(4)], 1)
    q1 /= np.linalg.norm(q1, axis=1, keepdims=True)
    q2 /= np.linalg.norm(q2, axis=1, keepdims=True)
    q2 *= np.sign(np.sum(q1 * q2, 1))[:, None]
    d = {
        "pos": np.linalg.norm(np.stack([ref[k] - got[k] for k in "xyz"], 1), axis=1),
        "rot": 4 * np.arcsin(np.minimum(1, np.linalg.norm(q1 - q2, axis=1) / 2)),
        "scale": np.abs(np.stack([ref[f"scale_{k}"] - got[f"scale_{k}"] for k in range(3)], 1)),
        "f_dc": np.abs(np.stack([ref[f"f_dc_{k}"] - got[f"f_dc_{k}"] for k in range(3)], 1)),
        "alpha": np.abs(1 / (1 + np.exp(-ref["opacity"])) - 1 / (1 + np.exp(-got["opacity"]))),
        "sh": [],
    }
    k = (degree + 1) ** 2 - 1
    for band in range(1, degree + 1):
        lo, hi = band * band - 1, (band + 1) ** 2 - 1
        per = []
        for ch in range(3):
            idx = [ch * k + j for j in range(lo, hi)]
            per.append(np.linalg.norm(np.stack([ref[f"f_rest_{i}"] - got[f"f_rest_{i}"] for i in idx], 1), axis=1))
        d["sh"].append(np.max(np.stack(per, 1), 1))
    return d


def judge(name, ref, got, bound, degree, log):
    """Compares `got` with `ref` (matched by nearest centres) within `bound` (per splat, in got's order); an
    SH band's error is compared as a norm (a rotation keeps an error's norm, not its largest coefficient:
    sqrt(2l + 1) times the per-coefficient bound). Returns False on any splat beyond its bound."""
    centres = np.stack([ref[k] for k in "xyz"], 1)
    points = np.stack([got[k] for k in "xyz"], 1)
    perm = np.concatenate(
        [
            np.argmin(((c[:, None, :] - centres[None]) ** 2).sum(2), 1)
            for c in np.array_split(points, 1 + len(points) // 256)
        ]
    )
    if len(set(perm.tolist())) != len(perm):
        log.append(f"FAIL {name}: splats could not be matched one to one by their centres")
        return False
    ref = {k: v[perm] for k, v in ref.items()}
    d = measure(ref, got, degree)
    # Float rounding of the rigid motion through MLS (positions, frames) and of the 3DGS values: a few
    # dozen epsilons of the scene's size (radius + translation ~ 4) and of each value.
    size = 1 + np.max(np.abs(centres))
    slack = {"pos": 64 * EPS * size, "rot": 1e-5, "scale": 16 * EPS * 6, "f_dc": 16 * EPS * 4, "alpha": 1e-6}
    ok = True
    row = [name]
    for key in ["pos", "rot", "scale", "f_dc", "alpha"]:
        lim = bound[key]
        over = d[key] - (lim + slack[key])
        ok &= bool(np.all(over <= 0))
        row.append(f"{key} {np.max(d[key]):.3g}/{np.max(lim):.3g}")
    for band, (err, lim) in enumerate(zip(d["sh"], bound["sh"]), start=1):
        lim = lim * np.sqrt(2 * band + 1) + 1e-6
        ok &= bool(np.all(err <= lim))
        row.append(f"sh{band} {np.max(err):.3g}/{np.max(lim):.3g}")
    log.append(("ok   " if ok else "FAIL ") + "  ".join(row))
    return ok


def run(cmd, expect=0):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != expect:
        raise RuntimeError(f"{' '.join(cmd)}: exit {r.returncode}\n{r.stdout}\n{r.stderr}")
    return r


def handles(path, seed):
    """Five handles around the scene, all moved by one rigid motion (a turn of 0.8 rad and a translation)."""
    rng = np.random.default_rng(seed)
    axis = rng.normal(0, 1, 3)
    axis /= np.linalg.norm(axis)
    kx = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    r = np.eye(3) + np.sin(0.8) * kx + (1 - np.cos(0.8)) * kx @ kx
    t = np.array([0.3, -0.2, 0.5])
    rest = [[-3, -3, -3], [3, -3, -3], [0, 3, -3], [0, 0, 3], [1, 1, 1]]
    points = [{"rest": p, "target": (r @ np.array(p, float) + t).tolist()} for p in rest]
    with open(path, "w") as f:
        json.dump({"points": points}, f)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mlsdeform", required=True)
    ap.add_argument("--degree", type=int, required=True)
    ap.add_argument("--splats", type=int, default=900)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    tool = os.path.join(HERE, "node_modules", ".bin", "splat-transform")
    if not shutil.which("node") or not os.path.exists(tool):
        print("splat judge skipped: node or splat-transform missing (tools/install_deps.sh judge)")
        return 77
    print(f"seed {a.seed}, {a.splats} splats of SH degree {a.degree} (rerun: --seed S --splats N)")
    log, ok = [], True
    with tempfile.TemporaryDirectory() as w:
        p = lambda name: os.path.join(w, name)  # noqa: E731
        mls = lambda src, dst: run([a.mlsdeform, "deform", "-m", src, "-H", p("h.json"), "-o", dst, "-f"])  # noqa
        st = lambda *args: run([tool, "-q", "-w", *args])  # noqa: E731
        x = sf.scene(a.splats, a.degree, a.seed)
        n = a.splats
        sf.write_ply(p("x.ply"), x)
        handles(p("h.json"), a.seed)
        mls(p("x.ply"), p("ref.ply"))
        ref = sf.read_ply(p("ref.ply"))["vertex"]
        cases = [("spz", "spz v4", ".spz", []), ("spz", "spz v3", ".spz", ["--spz-version", "3"])]
        cases.append(("cply", "compressed PLY", ".compressed.ply", []))
        for fmt, label, ext, opts in cases:
            st(*opts, p("x.ply"), p("xj" + ext))  # the judge encodes
            mls(p("xj" + ext), p("a.ply"))
            got = sf.read_ply(p("a.ply"))["vertex"]
            b_in = bounds(fmt, "judge", p("xj" + ext), n, a.degree)
            ok &= judge(f"{label} in  ", ref, got, b_in, a.degree, log)
            mls(p("xj" + ext), p("c" + ext))
            st(p("c" + ext), p("c.ply"))  # ... and decodes what the program wrote
            got = sf.read_ply(p("c.ply"))["vertex"]
            ok &= judge(
                f"{label} both", ref, got, add(b_in, bounds(fmt, "mine", p("c" + ext), n, a.degree)), a.degree, log
            )
            if opts:
                continue
            mls(p("x.ply"), p("b" + ext))
            st(p("b" + ext), p("b.ply"))
            got = sf.read_ply(p("b.ply"))["vertex"]
            written = "SPZ 4" if open(p("b" + ext), "rb").read(4) == b"NGSP" else "SPZ 3"
            name = f"spz out ({written})" if fmt == "spz" else f"{label} out "
            ok &= judge(name, ref, got, bounds(fmt, "mine", p("b" + ext), n, a.degree), a.degree, log)
        if a.degree == 0:
            ok &= splat_case(p, x, mls, st, log)
    print("\n".join(log))
    return 0 if ok else 1


def splat_case(p, x, mls, st, log):
    """`.splat`: the program's reading against splat-transform's (both deformed by the program), and against the
    scene, within the layout's quantisation: colour and alpha truncated to 1/255, quaternion components to
    1/128 (so each within 1/128 of the unit quaternion's; the angle as rot_bound for a chord of 2/128 ...)."""
    n = len(x["x"])
    sf.write_splat(p("x.splat"), x)
    mls(p("x.splat"), p("s.ply"))
    st(p("x.splat"), p("sj.ply"))
    mls(p("sj.ply"), p("sj_out.ply"))
    mine = sf.read_ply(p("s.ply"))["vertex"]
    theirs = sf.read_ply(p("sj_out.ply"))["vertex"]
    ref = sf.read_ply(p("ref.ply"))["vertex"]
    # The decoders differ only where the layout leaves room: splat-transform reads a quaternion byte as
    # b / 127.5 - 1, the viewer the layout comes from as (b - 128) / 128 (directions 0.5 byte apart in each
    # component, |q| >= 126 bytes: at most 2 asin(1 / 126) apart as a rotation), and it keeps alpha 0 and 1
    # 1e-6 inside (0, 1).
    agree = {
        "pos": np.zeros(n),
        "rot": np.full(n, 4 * np.arcsin(1 / 126)),
        "scale": np.zeros((n, 3)),
        "f_dc": np.zeros((n, 3)),
        "alpha": np.full(n, 1e-6),
        "sh": [],
    }
    ok = judge(".splat read vs judge", theirs, mine, agree, 0, log)
    own = {
        "pos": np.zeros(n),
        "rot": np.full(n, 4 * np.arcsin(1 / 128)),  # truncation: within 1/128 per component, chord <= 2/128
        "scale": np.full((n, 3), 2 * EPS),
        "f_dc": np.full((n, 3), 1 / 255 / sf.C0),
        "alpha": np.full(n, 1 / 255),
        "sh": [],
    }
    return ok & judge(".splat read vs scene", ref, mine, own, 0, log)


if __name__ == "__main__":
    sys.exit(main())
