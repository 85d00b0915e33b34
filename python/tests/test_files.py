"""mlsdeform.files: mesh files round-trip exactly, bad files are refused with the file's name, and a handles file
resolves to bitwise the handles the `mlsdeform` program uses (the program's own output is the reference, where
the program is found: MLSDEFORM_CLI, or `mlsdeform` on PATH)."""
import gzip
import json
import os
import shutil
import subprocess

import numpy as np
import pytest

import mlsdeform
from mlsdeform import files

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "..", "data")
HUMAN = os.path.join(DATA, "human_man.obj")


def program():
    path = os.environ.get("MLSDEFORM_CLI") or shutil.which("mlsdeform")
    if not path or not os.path.exists(path):
        pytest.skip("the mlsdeform program is not found (MLSDEFORM_CLI, or on PATH)")
    return path


def polygons():
    """A quad, a triangle and a pentagon over 7 vertices with awkward float32 values."""
    g = np.random.default_rng(5)
    V = (g.uniform(-1, 1, (7, 3)) * np.float32(1e3) / 3).astype(np.float32)
    return V, files.Faces([4, 3, 5], [0, 1, 2, 3, 3, 4, 5, 6, 5, 4, 1, 0])


@pytest.mark.parametrize("ext", [".ply", ".obj"])
def test_round_trip_exact(tmp_path, ext):
    V, F = polygons()
    path = str(tmp_path / ("m" + ext))
    files.write_mesh(path, V, F)
    V2, F2 = files.read_mesh(path)
    assert V2.dtype == np.float32 and np.array_equal(V, V2)
    assert np.array_equal(F.counts, F2.counts) and np.array_equal(F.indices, F2.indices)
    with open(path, "rb") as f, gzip.open(path + ".gz", "wb") as g:
        g.write(f.read())
    V3, F3 = files.read_mesh(path + ".gz")
    assert np.array_equal(V, V3) and np.array_equal(F.indices, F3.indices)


def test_ascii_ply_and_npy(tmp_path):
    V, F = polygons()
    path = tmp_path / "a.ply"
    faces = ["4 0 1 2 3", "3 3 4 5", "5 6 5 4 1 0"]
    path.write_text(
        "ply\nformat ascii 1.0\ncomment x\nelement vertex 7\nproperty float x\nproperty float y\n"
        "property float z\nelement face 3\nproperty list uchar int vertex_indices\nend_header\n"
        + "".join(f"{x!r} {y!r} {z!r}\n" for x, y, z in V.astype(float).tolist())
        + "\n".join(faces)
    )
    V2, F2 = files.read_mesh(str(path))
    assert np.array_equal(V, V2) and np.array_equal(F.indices, F2.indices)
    files.write_mesh(str(tmp_path / "v.npy"), V)
    assert np.array_equal(np.load(tmp_path / "v.npy"), V)


def test_decimal_text_is_rounded_once(tmp_path):
    """1 + 2^-24 is halfway between the floats 1 and 1 + 2^-23: a decimal a little above it is 1 + 2^-23 when
    rounded once (std::from_chars, the program), but 1 when rounded to double (exactly the half) and then to float
    (the tie to even); a little below, 1 either way. Likewise in double for 1 + 2^-53."""
    half = "1.000000059604644775390625"
    above, below = half + "0000001", "1.0000000596046447753906249999"
    for ext, text in (
        (".obj", f"v {above} {below} {half}\n"),
        (
            ".ply",
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
            f"property float z\nend_header\n{above} {below} {half}\n",
        ),
    ):
        path = tmp_path / ("tie" + ext)
        path.write_text(text)
        V, _ = files.read_mesh(str(path))
        assert V.tolist() == [[1 + 2**-23, 1.0, 1.0]], ext  # the exact half itself: to even
        V, _ = files.read_mesh(str(path), dtype=np.float64)
        if ext == ".obj":
            assert V.dtype == np.float64 and V[0, 0] == float(above) and V[0, 2] == 1 + 2**-24
        else:  # a PLY property declared float is a float whatever the precision, as the program reads it
            assert V.dtype == np.float64 and V.tolist() == [[1 + 2**-23, 1.0, 1.0]]


@pytest.mark.parametrize(
    "text, problem",
    [
        ("v 0 0 0\nv 1 0 0\nf 1 2 3\n", "out of range"),
        ("v 0 0 zero\n", "not a number"),
        ("v 0 0 0\nf 1 2\n", "at least 3"),
    ],
)
def test_bad_obj_is_refused(tmp_path, text, problem):
    path = tmp_path / "bad.obj"
    path.write_text(text)
    with pytest.raises(ValueError, match=problem) as e:
        files.read_mesh(str(path))
    assert str(path) in str(e.value)


def test_truncated_ply_is_refused(tmp_path):
    V, F = polygons()
    path = str(tmp_path / "t.ply")
    files.write_mesh(path, V, F)
    with open(path, "rb") as f:
        data = f.read()
    with open(path, "wb") as f:
        f.write(data[:-7])
    with pytest.raises(ValueError, match="truncated"):
        files.read_mesh(path)


def test_write_is_all_or_nothing(tmp_path, monkeypatch):
    """A write that fails after its temporary file is written (the rename refused) leaves nothing behind."""
    path = str(tmp_path / "x.npy")

    def refuse(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(files.os, "replace", refuse)
    with pytest.raises(OSError):
        files.write_atomically(path, b"partial", tag="t")
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize(
    "spec, problem",
    [
        ({"points": [{"vertex": 7000}]}, "/points/0/vertex: vertex index 7000 out of range"),
        ({"points": [{"vertex": 1, "tagret": [0, 0, 0]}]}, "/points/0/tagret: unknown key"),
        ({"points": [{"vertex": 1}], "frames": [{"points": [None, None]}]}, "/frames/0/points: 2 entries, expected 1"),
        (
            {"points": [{"vertex": 1}], "groups": [{"points": [0], "rotate": {"axis": [0, 0, 0], "degrees": 9}}]},
            "/groups/0/rotate/axis: zero axis",
        ),
        ({}, "no handles"),
    ],
)
def test_bad_handles_are_refused(tmp_path, spec, problem):
    V, _ = files.read_mesh(HUMAN)
    path = tmp_path / "h.json"
    path.write_text(json.dumps(spec))
    with pytest.raises(ValueError, match=problem.replace("[", r"\[")):
        files.read_handles(str(path), V)


def deform_all(V, anim):
    d = mlsdeform.Deformer(V, **anim.session_arguments())
    return [d.deform(**anim.targets(i)).copy() for i in range(len(anim.frames))]


def test_handles_resolve_as_the_program_does(tmp_path):
    """human_bend.json (24 frames: targets, offsets, a segment) and a file with groups (a quarter turn about z,
    37 degrees, a translation, comments): every frame equals the program's output bitwise (float32)."""
    exe = program()
    groups = tmp_path / "groups.json"
    groups.write_text(
        """// comments as the program allows them
    {"points": [{"vertex": 1337}, {"vertex": 411}, {"vertex": 5906}, {"vertex": 2445}],
     "segments": [{"vertices": [6618, 6786]}],
     /* the arms as one rigid body */
     "groups": [{"points": [2, 3], "rotate": {"axis": [0, 0, 2], "degrees": 90}, "translate": [0, 0.1, 0]}],
     "frames": [{}, {"groups": [{"rotate": {"axis": [0, 0, 1], "degrees": 37, "pivot": [0, 1, 0]}}]},
                {"points": [null, {"offset": [0, 0.1, 0]}, null, null], "segments": [{"offset": [0, 0, 0.1]}]}]}
    """
    )
    for handles, count in ((os.path.join(DATA, "human_bend.json"), 24), (str(groups), 3)):
        out = tmp_path / (os.path.basename(handles) + ".obj")
        subprocess.run([exe, "deform", "-m", HUMAN, "-H", handles, "-o", str(out)], check=True, capture_output=True)
        V, _ = files.read_mesh(HUMAN)
        anim = files.read_handles(handles, V)
        assert anim.animated and len(anim.frames) == count
        for i, X in enumerate(deform_all(V, anim)):
            want, _ = files.read_mesh(str(tmp_path / f"{os.path.basename(handles)}_{i:04d}.obj"))
            assert np.array_equal(X, want), f"{handles}: frame {i}"


# What mlsdeform.files read differently from the program when it was a Python copy of the readers (each the
# program's rule now, through the one reader).
def test_obj_w_coordinate_divides(tmp_path):
    (tmp_path / "w.obj").write_text("v 4 5 6 0.5\nv 0 0 0\nv 1 0 0\nf 1 2 3\n")
    assert files.read_mesh(str(tmp_path / "w.obj")).vertices[0].tolist() == [8, 10, 12]


def test_obj_comment_after_a_vertex_reads(tmp_path):
    (tmp_path / "c.obj").write_text("v 1 2 3 # apex\nv 0 0 0\nv 1 0 0\nf 1 2 3\n")
    assert files.read_mesh(str(tmp_path / "c.obj")).vertices[0].tolist() == [1, 2, 3]


def ply(header_extra, body, count=3):
    return (
        "ply\nformat ascii 1.0\n%selement vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 1\nproperty list uchar float texcoord\nproperty list uchar int vertex_indices\nend_header\n"
        "%s" % (header_extra, count, body)
    )


def test_ply_faces_are_the_vertex_indices_list(tmp_path):
    (tmp_path / "t.ply").write_text(ply("comment no end_header here\n", "0 0 0\n1 0 0\n0 1 0\n2 0.5 0.5 3 2 1 0\n"))
    mesh = files.read_mesh(str(tmp_path / "t.ply"))
    assert mesh.faces.indices.tolist() == [2, 1, 0] and "face properties texcoord" in mesh.attributes("o.ply")["kept"]


def test_ply_body_longer_than_its_header_is_refused(tmp_path):
    (tmp_path / "l.ply").write_text(ply("", "0 0 0\n1 0 0\n0 1 0\n2 0.5 0.5 3 2 1 0\n", count=2))
    with pytest.raises(ValueError, match="l.ply"):
        files.read_mesh(str(tmp_path / "l.ply"))


def test_handles_duplicate_key_refused_and_byte_order_mark_read(tmp_path):
    V = files.read_mesh(HUMAN).vertices
    (tmp_path / "d.json").write_text('{"points": [{"vertex": 1}], "points": [{"vertex": 2}]}')
    with pytest.raises(ValueError, match="d.json"):
        files.read_handles(str(tmp_path / "d.json"), V)
    (tmp_path / "b.json").write_bytes(b'\xef\xbb\xbf{"points": [{"vertex": 1}]}')
    assert files.read_handles(str(tmp_path / "b.json"), V).points.tolist() == [V[1].tolist()]


@pytest.mark.parametrize("transform", ["rigid", "similarity", "affine"])
def test_mesh_object_carries_splats_as_the_program(tmp_path, transform):
    """A 3DGS splat file read, deformed by a session with Mesh.frames_for's frames and written: the program's
    bytes for the same file, handles and transform; without its frames, a ValueError that says what to pass."""
    g = np.random.default_rng(3)
    names = ["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"] + [f"f_rest_{i}" for i in range(24)]
    names += ["opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"]
    rec = g.normal(size=(60, len(names))).astype("<f4")
    head = "ply\nformat binary_little_endian 1.0\nelement vertex 60\n"
    head += "".join(f"property float {p}\n" for p in names) + "end_header\n"
    (tmp_path / "s.ply").write_bytes(head.encode() + rec.tobytes())
    spec = {"points": [{"vertex": 0}, {"vertex": 1, "offset": [0, 0.3, 0]}, {"vertex": 2}, {"vertex": 3}]}
    (tmp_path / "h.json").write_text(json.dumps(spec))
    mesh = files.read_mesh(str(tmp_path / "s.ply"))
    assert mesh.splat_sh_degree == 2
    anim = files.read_handles(str(tmp_path / "h.json"), mesh)
    options = {"affine_frames": True} if transform == "affine" else {}
    d = mlsdeform.Deformer(mesh.vertices, transform=transform, **anim.session_arguments(), **options)
    frames = mesh.frames_for(transform)
    X = d.deform(**anim.targets(0), **frames)
    files.write_mesh(str(tmp_path / "py.ply"), mesh.deformed(X, **frames))
    r = subprocess.run(
        [program(), "deform", "-q", "-m", "s.ply", "-H", "h.json", "-o", "cli.ply", "-t", transform], cwd=tmp_path
    )
    assert r.returncode == 0
    assert (tmp_path / "py.ply").read_bytes() == (tmp_path / "cli.ply").read_bytes()
    with pytest.raises(ValueError, match="frames_for"):
        mesh.deformed(X)


@pytest.mark.parametrize("dtype", ["<f4", "<f8"])
def test_binary_ply_output_is_the_records_with_new_positions(tmp_path, dtype):
    """A binary PLY written from a PLY read: every record byte for byte as read, x, y, z replaced by the deformed
    positions (numpy the oracle: the input's structured array, its x, y, z set from the .npy of the same job)."""
    g = np.random.default_rng(11)
    names = ["x", "y", "z", "red", "q", "nz_", "w"]
    types = [dtype, dtype, dtype, "u1", "<i2", "<f4", "<f8"]
    rec = np.zeros(50, np.dtype(list(zip(names, types))))
    for n in names:
        rec[n] = g.uniform(0, 100, 50)
    head = "ply\nformat binary_little_endian 1.0\nelement vertex 50\n"
    ply_type = {"<f4": "float", "<f8": "double", "u1": "uchar", "<i2": "short"}
    head += "".join(f"property {ply_type[t]} {n}\n" for n, t in zip(names, types)) + "end_header\n"
    (tmp_path / "in.ply").write_bytes(head.encode() + rec.tobytes())
    (tmp_path / "h.json").write_text('{"points": [{"vertex": 0}, {"vertex": 7, "offset": [1, 2, 3]}, {"vertex": 9}]}')
    precision = np.float32 if dtype == "<f4" else np.float64
    for out in ("o.ply", "o.npy"):
        job = files.DeformJob(str(tmp_path / "in.ply"), str(tmp_path / "h.json"), str(tmp_path / out), dtype=precision)
        job.write_frame(0)
    want = rec.copy()
    X = np.load(tmp_path / "o.npy")
    for c, n in enumerate("xyz"):
        want[n] = X[:, c]
    data = (tmp_path / "o.ply").read_bytes()
    body = data[data.index(b"end_header\n") + len(b"end_header\n") :]
    assert body == want.tobytes()
