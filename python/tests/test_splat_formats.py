"""The compact splat formats (SPZ, compressed PLY, .splat; docs/splats.md "Other formats") through mlsdeform.files:
read and written by the program's own readers and writers, a DeformJob's output byte for byte the program's, a
value a format cannot hold refused naming the splat (the program's own output is the reference where the program
is found: MLSDEFORM_CLI, or `mlsdeform` on PATH)."""
import json
import os
import shutil
import subprocess

import numpy as np
import pytest

from mlsdeform import files

HERE = os.path.dirname(os.path.abspath(__file__))
SEEDS = os.path.join(HERE, "..", "..", "tests", "fuzz")
SPZ = os.path.join(SEEDS, "corpus_spz", "v4_degree3.spz")
FILES = [
    "corpus_spz/v2_degree0.spz",
    "corpus_spz/v3_degree1.spz",
    "corpus_spz/v4_degree3.spz",
    "corpus_splat/three.splat",
    "corpus_compressed_ply/degree1.compressed.ply",
]


def program():
    path = os.environ.get("MLSDEFORM_CLI") or shutil.which("mlsdeform")
    if not path or not os.path.exists(path):
        pytest.skip("the mlsdeform program is not found (MLSDEFORM_CLI, or on PATH)")
    return path


@pytest.mark.parametrize("name", FILES)
def test_read_and_write_each_format(tmp_path, name):
    mesh = files.read_mesh(os.path.join(SEEDS, name))
    n = len(mesh.vertices)
    assert n > 0
    for ext in (".spz", ".compressed.ply", ".ply"):
        out = str(tmp_path / ("o" + ext))
        assert files.write_mesh(out, mesh) > 0
        back = files.read_mesh(out)
        assert back.vertices.shape == (n, 3)
        # Each format's centre quantisation at most (SPZ: 2^-13; compressed PLY: a chunk's extent / 2046).
        extent = np.ptp(mesh.vertices, axis=0).max()
        assert np.abs(back.vertices - mesh.vertices).max() <= max(2.0**-13, extent / 2046) * 1.001 + 1e-6


def test_deform_job_writes_the_programs_bytes(tmp_path):
    handles = str(tmp_path / "h.json")
    with open(handles, "w") as f:
        json.dump({"points": [{"rest": [0, 0, 0]}, {"rest": [3, 0, 0], "offset": [0, 0.2, 0]}]}, f)
    for ext in (".spz", ".compressed.ply"):
        job = files.DeformJob(SPZ, handles, str(tmp_path / ("py" + ext)))
        data, _, _ = job.encode_frame(0)
        out = str(tmp_path / ("cli" + ext))
        subprocess.run([program(), "deform", "-m", SPZ, "-H", handles, "-o", out], check=True, capture_output=True)
        with open(out, "rb") as f:
            assert data == f.read()


def test_a_value_the_format_cannot_hold_is_refused(tmp_path):
    names = ["x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2"] + [f"f_rest_{k}" for k in range(9)]
    names += ["opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"]
    values = np.zeros((4, len(names)), np.float32)
    values[:, 0] = np.arange(4)
    values[:, names.index("rot_0")] = 1
    values[2, names.index("f_rest_5")] = 1.5  # SPZ holds -1 .. 127/128
    head = "ply\nformat binary_little_endian 1.0\nelement vertex 4\n"
    head += "".join(f"property float {n}\n" for n in names) + "end_header\n"
    path = tmp_path / "s.ply"
    path.write_bytes(head.encode() + values.tobytes())
    mesh = files.read_mesh(str(path))
    out = str(tmp_path / "o.spz")
    with pytest.raises(ValueError, match="splat 2: f_rest_5 = 1.5 is outside what SPZ holds"):
        files.write_mesh(out, mesh)
    assert not os.path.exists(out)
    assert files.write_mesh(str(tmp_path / "o.compressed.ply"), mesh) > 0  # which holds -4 .. 4
    with pytest.raises(ValueError, match="read only"):
        files.write_mesh(str(tmp_path / "o.splat"), mesh)


def test_dask_writes_the_programs_bytes(tmp_path):
    distributed = pytest.importorskip("distributed")
    import mlsdeform.dask

    src, out = tmp_path / "in", tmp_path / "out"
    src.mkdir()
    out.mkdir()
    shutil.copy(SPZ, src / "cap.spz")
    shutil.copy(os.path.join(SEEDS, "corpus_compressed_ply", "degree1.compressed.ply"), src / "scene.compressed.ply")
    spec = {"points": [{"rest": [0, 0, 0]}, {"rest": [1, 1, 1], "offset": [0, 0.1, 0]}]}
    for name in ("cap", "scene"):  # NAME.compressed.ply's handles are NAME.json, as for any format
        (src / f"{name}.json").write_text(json.dumps(spec))
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False) as cluster:
        with distributed.Client(cluster) as client:
            summary = mlsdeform.dask.deform_meshes(client, str(src), str(out), output_format=".compressed.ply")
    assert sorted(os.path.basename(p) for p in summary.written) == ["cap.compressed.ply", "scene.compressed.ply"]
    for name, mesh in (("cap", src / "cap.spz"), ("scene", src / "scene.compressed.ply")):
        ref = str(tmp_path / f"{name}_cli.compressed.ply")
        handles = str(src / f"{name}.json")
        subprocess.run(
            [program(), "deform", "-m", str(mesh), "-H", handles, "-o", ref], check=True, capture_output=True
        )
        assert (out / f"{name}.compressed.ply").read_bytes() == open(ref, "rb").read()
