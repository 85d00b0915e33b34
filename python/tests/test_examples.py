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
