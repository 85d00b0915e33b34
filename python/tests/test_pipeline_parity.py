"""One file pipeline: the program (`mlsdeform deform`), Python (mlsdeform.files.DeformJob) and Dask
(mlsdeform.dask.deform_meshes) give the same output bytes, or the same error message, for every input: the fuzz
corpora (tests/fuzz/corpus_*), mutants of every format the program reads (OBJ, OFF, PLY ASCII and both binary
orders, their .gz; SPZ, .splat and compressed PLY: tests/fuzz/mutations.py, the mutation campaign's own), 3DGS
splat files and their mutants, and the handles corpus (tests/fuzz/corpus), under options and output formats that
vary from input to input.

The oracle is the program's own run (bytes of every output file, or its one-line error), independent of the
Python and Dask front ends that are under test. MLSDEFORM_PARITY_MUTANTS sets the mutants per format (default
24, the quick form CI runs; the campaign: a few hundred)."""
import gzip
import json
import logging
import os
import random
import shutil
import subprocess
import sys

import numpy as np
import pytest

from mlsdeform import files

HERE = os.path.dirname(os.path.abspath(__file__))
FUZZ = os.path.join(HERE, "..", "..", "tests", "fuzz")
sys.path.insert(0, FUZZ)
from mutations import (  # noqa: E402
    SPLAT_KINDS,
    encode,
    make_mutant,
    make_splat_mutant,
    mutate_bytes,
    mutate_header,
    seed_mesh,
    splat_seeds,
)

MUTANTS = int(os.environ.get("MLSDEFORM_PARITY_MUTANTS", "24"))
# Options that vary from input to input: (program flags, DeformJob keyword arguments, output extension).
VARIANTS = [
    ([], {}, ".ply"),
    (["--precision", "double"], {"dtype": np.float64}, ".obj"),
    (["--transform", "similarity", "--ply-ascii"], {"transform": "similarity", "ply_ascii": True}, ".ply"),
    (["--transform", "affine"], {"transform": "affine"}, ".off"),
    (["--precision", "double", "--output-type", "double"], {"dtype": np.float64, "output_type": "float64"}, ".ply.gz"),
    (["--normals", "computed"], {"normals": "computed"}, ".obj.gz"),
    ([], {}, ".npy"),
    (["--transform", "similarity"], {"transform": "similarity"}, ".spz"),
    ([], {}, ".compressed.ply"),
]


def program():
    path = os.environ.get("MLSDEFORM_CLI") or shutil.which("mlsdeform")
    if not path or not os.path.exists(path):
        pytest.skip("the mlsdeform program is not found (MLSDEFORM_CLI, or on PATH)")
    return path


def gz_kind(data):
    """The extension a .gz of the corpus is named by: its decompressed bytes' format (or .obj if unreadable)."""
    try:
        head = gzip.decompress(data)[:4]
    except (OSError, EOFError, gzip.BadGzipFile):
        return ".obj.gz"
    return ".ply.gz" if head.startswith(b"ply") else ".off.gz" if head[:3] in (b"OFF", b"COF") else ".obj.gz"


def splat_ply(n, degree, g):
    """A binary 3DGS PLY (docs/splats.md) of n splats with SH degree `degree`, and normals as 3DGS writes them."""
    names = ["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"]
    names += [f"f_rest_{i}" for i in range(3 * ((degree + 1) ** 2 - 1))]
    names += ["opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"]
    rec = g.normal(size=(n, len(names))).astype("<f4")
    rec[:, 3:6] = 0
    head = "ply\nformat binary_little_endian 1.0\nelement vertex %d\n" % n
    head += "".join(f"property float {p}\n" for p in names) + "end_header\n"
    return head.encode() + rec.tobytes()


def inputs():
    """[(file name, bytes, handles bytes)]: every input of the differential test."""
    verts, faces = seed_mesh()
    # Rest positions, not vertex indices: the same handles fit any mutant, whatever its vertex count.
    handles = json.dumps({"points": [{"rest": [0, 0, 0]}, {"rest": [1, 1, 1], "offset": [0, 0.1, 0]}]}).encode()
    animated = json.dumps(
        {
            "points": [{"rest": [0, 0, 0]}, {"rest": [1, 1, 1]}, {"rest": [1, 0, 0]}],
            "frames": [{"points": [None, [1, 1.1, 1], None]}, {"points": [[0, 0, 0.1], None, None]}],
        }
    ).encode()
    out = []
    for kind in ("obj", "off", "ply"):
        d = os.path.join(FUZZ, "corpus_" + kind)
        for name in sorted(os.listdir(d)):
            stem = os.path.splitext(name)[0]
            out.append((f"corpus_{kind}_{stem}.{kind}", open(os.path.join(d, name), "rb").read(), handles))
    d = os.path.join(FUZZ, "corpus_gz")
    for name in sorted(os.listdir(d)):
        data = open(os.path.join(d, name), "rb").read()
        out.append((f"corpus_gz_{name.split('.')[0]}{gz_kind(data)}", data, handles))
    kinds = ["obj", "off", "ply", "le.ply", "be.ply"]
    base = {k: encode(verts, faces, k) for k in kinds}
    for kind in kinds + [k + ".gz" for k in ("obj", "off", "ply", "le.ply")]:
        for i in range(MUTANTS):
            data = make_mutant(kind, base, random.Random(f"parity/{kind}/{i}"))
            out.append((f"mutant_{i:03d}.{kind}", data, animated if i % 5 == 0 else handles))
    for name in sorted(os.listdir(os.path.join(FUZZ, "corpus"))):  # the handles corpus on the seed mesh
        out.append(
            (
                f"handles_{os.path.splitext(name)[0]}.obj",
                base["obj"],
                open(os.path.join(FUZZ, "corpus", name), "rb").read(),
            )
        )
    g = np.random.default_rng(7)
    for degree in (0, 1, 2, 3):
        splats = splat_ply(40, degree, g)
        out.append((f"splats_{degree}.ply", splats, handles))
        for i in range(max(2, MUTANTS // 4)):
            rng = random.Random(f"parity/splats/{degree}/{i}")
            data = (mutate_header if i % 2 else mutate_bytes)(splats, rng)
            out.append((f"splats_{degree}_{i:03d}.ply", data, handles))
    seeds = splat_seeds(FUZZ)  # SPZ, .splat and compressed PLY: the corpora and their mutants
    for kind in SPLAT_KINDS:
        for k, data in enumerate(seeds[kind]):
            out.append((f"corpus_{kind.split('.')[0]}_{k}.{kind}", data, handles))
        for i in range(MUTANTS):
            data = make_splat_mutant(kind, seeds, random.Random(f"parity/{kind}/{i}"))
            out.append((f"mutant_{i:03d}.{kind}", data, handles))
    return out


def run_program(exe, mesh, handles, out, flags):
    """(None, {name: bytes}) or (message, {})."""
    os.makedirs(os.path.dirname(out))
    r = subprocess.run([exe, "deform", "-q", "-m", mesh, "-H", handles, "-o", out] + flags, capture_output=True)
    written = {n: open(os.path.join(os.path.dirname(out), n), "rb").read() for n in os.listdir(os.path.dirname(out))}
    if r.returncode == 0:
        return None, written
    # One error line, after at most the line that names what the output drops.
    err = r.stderr.decode("utf-8", "replace").strip().splitlines()
    ok = r.returncode == 2 and 1 <= len(err) <= 2 and err[-1].startswith("mlsdeform: error: ")
    assert ok and (len(err) == 1 or err[0].startswith("mlsdeform: dropped from ")), (mesh, r.returncode, err)
    assert not written, (mesh, "the program left files after an error")
    return err[-1][len("mlsdeform: error: ") :], {}


def run_python(mesh, handles, out, options):
    """DeformJob, frame by frame, all or nothing as the program: (None, {name: bytes}) or (message, {})."""
    os.makedirs(os.path.dirname(out))
    written = []
    try:
        job = files.DeformJob(mesh, handles, out, **options)
        for i, path in enumerate(job.outputs):
            job.write_frame(i)
            written.append(path)
    except ValueError as e:
        for p in written:
            os.unlink(p)
        return str(e), {}
    return None, {os.path.basename(p): open(p, "rb").read() for p in written}


def test_program_and_python_agree_on_every_input(tmp_path):
    exe = program()
    cases = inputs()
    outcomes = {"written": 0, "refused": 0}
    for k, (name, data, handles) in enumerate(cases):
        flags, options, ext = VARIANTS[k % len(VARIANTS)]
        case = tmp_path / f"c{k:04d}"
        case.mkdir()
        mesh, hpath = str(case / name), str(case / "h.json")
        open(mesh, "wb").write(data)
        open(hpath, "wb").write(handles)
        stem = "out" + ext
        want_err, want = run_program(exe, mesh, hpath, str(case / "cli" / stem), flags)
        got_err, got = run_python(mesh, hpath, str(case / "py" / stem), options)
        where = f"{name} ({' '.join(flags) or 'defaults'} -> {ext})"
        if want_err is not None:
            outcomes["refused"] += 1
            # The same message, the output's folder aside (an error may name the output).
            assert got_err is not None, f"{where}: the program refused ({want_err}), Python wrote {sorted(got)}"
            assert got_err.replace(str(case / "py"), str(case / "cli")) == want_err, where
            continue
        outcomes["written"] += 1
        assert got_err is None, f"{where}: the program wrote {sorted(want)}, Python refused: {got_err}"
        assert sorted(got) == sorted(want), where
        for n in want:
            assert got[n] == want[n], f"{where}: {n} differs"
    # Both kinds of outcome are exercised (the mutants are mostly refused, the seeds and corpora mostly read).
    assert outcomes["written"] >= 10 and outcomes["refused"] >= 10, outcomes


def test_program_and_dask_agree_on_every_input(tmp_path):
    """deform_meshes over folders of every input (each with its handles file; one folder per variant of options
    and output format), against the program's output bytes or its error message per input (Summary.failed)."""
    pytest.importorskip("dask")
    distributed = pytest.importorskip("distributed")
    import mlsdeform.dask as mdask

    exe = program()
    folders = {}  # variant -> [(file name, handles base name)]
    for k, (name, data, handles) in enumerate(inputs()):
        v = k % len(VARIANTS)
        src = tmp_path / f"in{v}"
        src.mkdir(exist_ok=True)
        stem = f"i{k:04d}_" + name  # one name per input, its extension the format
        open(src / stem, "wb").write(data)
        base = stem[:-3] if stem.endswith(".gz") else stem
        # NAME.EXT's handles file is NAME.json (NAME.compressed.ply's too: its format's name has two dots).
        base = base[: -len(".compressed.ply")] if base.endswith(".compressed.ply") else os.path.splitext(base)[0]
        open(src / (base + ".json"), "wb").write(handles)
        folders.setdefault(v, []).append((stem, base))
    cluster = distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None, silence_logs=logging.ERROR
    )
    client = distributed.Client(cluster)
    compared = 0
    try:
        for v, names in folders.items():
            flags, options, ext = VARIANTS[v]
            src, out = tmp_path / f"in{v}", tmp_path / f"out{v}"
            out.mkdir()
            s = mdask.deform_meshes(client, str(src), str(out), output_format=ext, **options)
            for stem, base in names:
                mesh = str(src / stem)
                cli = tmp_path / f"cli{v}" / base
                want_err, want = run_program(exe, mesh, str(src / (base + ".json")), str(cli / (base + ext)), flags)
                where = f"{stem} ({' '.join(flags) or 'defaults'} -> {ext})"
                if want_err is not None:  # the same message, the output's folder aside (an error may name it)
                    got = s.failed.get(mesh, "").replace(str(out), str(cli))
                    assert got == want_err, where
                    continue
                assert mesh not in s.failed, f"{where}: the program wrote, Dask failed: {s.failed[mesh]}"
                for n, data in want.items():
                    assert open(out / n, "rb").read() == data, f"{where}: {n} differs"
                    compared += 1
    finally:
        client.close()
        cluster.close()
    assert compared >= 10
