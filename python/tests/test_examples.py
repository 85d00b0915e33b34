"""The examples in python/examples run and write what they say (Open3D and matplotlib parts skip themselves
where the package is missing)."""
import os
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
EXAMPLES = os.path.join(HERE, "..", "examples")
DATA = os.path.join(HERE, "..", "..", "data")


def run(script, *args, cwd):
    return subprocess.run(
        [sys.executable, os.path.join(EXAMPLES, script), *args], cwd=cwd, check=True, capture_output=True, text=True
    ).stdout


def test_deform_obj(tmp_path):
    out = tmp_path / "posed.obj"
    run("deform_obj.py", os.path.join(DATA, "human_man.obj"), str(out), cwd=tmp_path)
    lines = out.read_text().splitlines()
    assert sum(line.startswith("v ") for line in lines) == 6890
    assert sum(line.startswith("f ") for line in lines) == 13776


def test_animate(tmp_path):
    run("animate.py", str(tmp_path / "frames"), "3", cwd=tmp_path)
    frames = sorted(os.listdir(tmp_path / "frames"))
    assert frames == ["frame_0000.npy", "frame_0001.npy", "frame_0002.npy"]
    first, last = (np.load(tmp_path / "frames" / f) for f in (frames[0], frames[-1]))
    assert first.shape == (20000, 3) and np.isfinite(last).all() and not np.array_equal(first, last)


def test_interop(tmp_path):
    out = run("interop.py", str(tmp_path / "picture.png"), cwd=tmp_path)
    assert "deformed mesh" in out or "open3d is not installed" in out


def rotation_matrices(q):
    w, x, y, z = q.T
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=1),
        ],
        axis=1,
    )


def test_splats(tmp_path):
    out = run("splats.py", str(tmp_path / "splats.npz"), cwd=tmp_path)
    assert "20000 splats deformed" in out
    z = np.load(tmp_path / "splats.npz")
    # The splat's new orientation is its vertex's rotation (the linear part over its scale) after its own.
    s = np.exp(z["moved_log_scales"][:, 0] - z["log_scales"][:, 0])
    composed = rotation_matrices(z["moved_rot"])
    own = rotation_matrices(z["rot"])
    R_vertex = np.einsum("nij,njk->nik", composed, own.transpose(0, 2, 1))
    assert np.abs(np.einsum("nji,njk->nik", R_vertex, R_vertex) - np.eye(3)).max() <= 1e-12
    assert np.all(z["moved_rot"].shape == z["rot"].shape)
    assert np.all(s > 0.9) and np.all(s < 1.6)  # between the fixed end's 1 and the grown end's 1.5
    # Normals stay unit; the bottom end (fixed) keeps its splats' orientations.
    assert np.abs(np.linalg.norm(z["moved_normals"], axis=1) - 1).max() <= 1e-12
    bottom = z["centres"][:, 1] < 0.05
    assert np.abs(np.abs(np.sum(z["moved_rot"][bottom] * z["rot"][bottom], axis=1)) - 1).max() <= 1e-2


def test_deform_file(tmp_path):
    """The example's output is byte for byte the program's for the same mesh and the first frame's handles."""
    import json
    import shutil

    out = run("deform_file.py", cwd=tmp_path)
    assert "normals (nx ny nz)" in out and (tmp_path / "posed.ply").exists()
    program = os.environ.get("MLSDEFORM_CLI") or shutil.which("mlsdeform")
    if not program or not os.path.exists(program):
        return
    spec = json.load(open(os.path.join(DATA, "human_bend.json")))
    spec["frames"] = spec["frames"][:1]
    first = tmp_path / "first.json"
    first.write_text(json.dumps(spec))
    # One frame of a handles file with frames: the program names it posed_0000.ply.
    subprocess.run(
        [program, "deform", "-q", "-m", "human_normals.ply", "-H", str(first), "-o", "cli.ply"],
        cwd=tmp_path,
        check=True,
    )
    assert (tmp_path / "cli_0000.ply").read_bytes() == (tmp_path / "posed.ply").read_bytes()
